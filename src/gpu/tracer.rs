//! Uploads a light field and its selection structures, and runs the
//! kernels over batches of queries.

use super::context::Context;
use super::interface::{Query, Record, SelectionKind, BATCH};
use crate::lightfield::LightField;
use crate::svo::Svo;
use crate::trace::single::March;
use crate::trace::Lattice;
use bytemuck::{Pod, Zeroable};
use half::f16;
use wgpu::util::DeviceExt;

/// The kernels' uniform parameters. Layout of WGSL `Params`.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
struct Params {
    n: u32,
    levels: u32,
    march: u32,
    selection: u32,
    probe_count: u32,
    query_count: u32,
    m: u32,
    svo_depth: u32,
    svo_origin: [f32; 3],
    svo_leaf: f32,
    svo_dims: [u32; 3],
    pad2: u32,
    lattice_origin: [f32; 3],
    pad3: f32,
    lattice_spacing: [f32; 3],
    pad0: u32,
    lattice_dims: [i32; 3],
    pad1: u32,
}

/// The source of every kernel: the shared part first.
const SOURCE: [&str; 3] = [
    include_str!("shaders/common.wgsl"),
    include_str!("shaders/trace.wgsl"),
    include_str!("shaders/irradiance.wgsl"),
];

/// A light field resident on the GPU, ready to trace.
pub struct ProbeTracer<'c> {
    ctx: &'c Context,
    base: Params,
    has_svo: bool,
    has_grid: bool,
    trace: wgpu::ComputePipeline,
    gather: wgpu::ComputePipeline,
    blend: wgpu::ComputePipeline,
    bind_group: wgpu::BindGroup,
    params: wgpu::Buffer,
    queries: wgpu::Buffer,
    records: wgpu::Buffer,
    readback: wgpu::Buffer,
    timestamps: Option<(wgpu::QuerySet, wgpu::Buffer, wgpu::Buffer)>,
}

/// What a batch run returns: a record per query and the GPU time in
/// milliseconds where the adapter has timestamps.
pub type Traced = (Vec<Record>, Option<f64>);

fn halves(values: impl Iterator<Item = f32>) -> Vec<u8> {
    values
        .flat_map(|v| f16::from_f32(v).to_bits().to_le_bytes())
        .collect()
}

impl<'c> ProbeTracer<'c> {
    /// Uploads `field` with the SVO and/or the grid its selections need.
    ///
    /// Contract: `svo` (if any) was baked for `field`'s probes, `lattice`
    /// recognized from its positions. `Err` (one line) when the field does
    /// not fit the adapter: more probes than texture-array layers, or maps
    /// beyond its largest texture.
    pub fn new(
        ctx: &'c Context,
        field: &LightField,
        svo: Option<&Svo>,
        lattice: Option<&Lattice>,
    ) -> Result<ProbeTracer<'c>, String> {
        let device = &ctx.device;
        let probes = check_fits(&device.limits(), field)?;
        // Validation and memory errors become `Err`, not wgpu's panic.
        let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
        let memory = device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        let maps = upload_maps(ctx, field, probes);
        let tables = upload_tables(device, field, svo, lattice);
        let io = IoBuffers::new(device);
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("probeplace kernels"),
            source: wgpu::ShaderSource::Wgsl(SOURCE.concat().into()),
        });
        let layout = bind_group_layout(device);
        let bind_group = bind_group(device, &layout, &maps, &tables, &io);
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("probeplace"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let timestamps = ctx.timestamps.then(|| timestamp_queries(device));
        let trace = compute_pipeline(device, &pipeline_layout, &module, "trace_rays");
        let gather = compute_pipeline(device, &pipeline_layout, &module, "gather_irradiance");
        let blend = compute_pipeline(device, &pipeline_layout, &module, "blend_weights");
        for scope in [memory, scope] {
            if let Some(e) = pollster::block_on(scope.pop()) {
                return Err(format!("GPU set-up failed: {e}"));
            }
        }
        let tracer = ProbeTracer {
            ctx,
            base: base_params(field, probes, svo, lattice),
            has_svo: svo.is_some(),
            has_grid: lattice.is_some(),
            trace,
            gather,
            blend,
            bind_group,
            params: io.params,
            queries: io.queries,
            records: io.records,
            readback: io.readback,
            timestamps,
        };
        tracer.warm_up(field.positions.first().copied().unwrap_or_default())?;
        Ok(tracer)
    }

    /// Runs one short query through each kernel, untimed: a driver may
    /// finish a pipeline on its first dispatch (lavapipe took some 20 ms),
    /// which would otherwise fall on whichever variant is timed first and
    /// make it look slower.
    fn warm_up(&self, at: glam::Vec3) -> Result<(), String> {
        let query = Query {
            origin: at.into(),
            t_max: 1e-3,
            dir: [1.0, 0.0, 0.0],
            pad: 0.0,
        };
        let selection = match (self.has_svo, self.has_grid) {
            (true, _) => SelectionKind::Svo,
            (false, true) => SelectionKind::Grid,
            (false, false) => return Ok(()),
        };
        self.trace_rays(&[query], March::HiZ, selection)?;
        self.gather_irradiance(&[query], selection)?;
        Ok(())
    }

    /// Traces every ray of `queries` (kernel `trace_rays`).
    ///
    /// Contract: rays as [`crate::trace::trace`] takes them; record `i`
    /// answers query `i`. `Err` when `selection` needs a structure not
    /// uploaded, or the device fails.
    pub fn trace_rays(
        &self,
        queries: &[Query],
        march: March,
        selection: SelectionKind,
    ) -> Result<Traced, String> {
        let march = match march {
            March::Texel => 0,
            March::BiLevel => 1,
            March::HiZ => 2,
        };
        self.run(&self.trace, queries, march, selection)
    }

    /// Irradiance at every point of `queries` (kernel `gather_irradiance`),
    /// in each record's `radiance`.
    pub fn gather_irradiance(
        &self,
        queries: &[Query],
        selection: SelectionKind,
    ) -> Result<Traced, String> {
        self.run(&self.gather, queries, 0, selection)
    }

    /// One normalized weight of the diffuse blend per query (kernel
    /// `blend_weights`, whose `blend_term` `gather_irradiance` blends
    /// with): query `i` holds a point in `origin`, its unit normal in `dir`
    /// and a term index k in `t_max` (as f32); record `i` holds term k of
    /// [`crate::trace::gather::blend_weights`] at that point, its probe in
    /// `probe` and its weight in `t` ([`super::twin::blend_weights`] is
    /// the CPU side). Each query weighs every term again to normalize: a
    /// check of the kernel's weights, not a fast path.
    pub fn blend_weights(
        &self,
        queries: &[Query],
        selection: SelectionKind,
    ) -> Result<Traced, String> {
        self.run(&self.blend, queries, 0, selection)
    }

    fn run(
        &self,
        pipeline: &wgpu::ComputePipeline,
        queries: &[Query],
        march: u32,
        selection: SelectionKind,
    ) -> Result<Traced, String> {
        let selection = match selection {
            SelectionKind::Grid if self.has_grid => 0,
            SelectionKind::Svo if self.has_svo => 1,
            other => return Err(format!("{other:?} selection without its structure")),
        };
        let scope = self
            .ctx
            .device
            .push_error_scope(wgpu::ErrorFilter::Validation);
        let result = self.batches(pipeline, queries, march, selection);
        match pollster::block_on(scope.pop()) {
            Some(e) => Err(format!("GPU failed: {e}")),
            None => result,
        }
    }

    fn batches(
        &self,
        pipeline: &wgpu::ComputePipeline,
        queries: &[Query],
        march: u32,
        selection: u32,
    ) -> Result<Traced, String> {
        let (device, queue) = (&self.ctx.device, &self.ctx.queue);
        let mut out = Vec::with_capacity(queries.len());
        let mut gpu_ms = self.timestamps.as_ref().map(|_| 0.0f64);
        for batch in queries.chunks(BATCH) {
            let params = Params {
                march,
                selection,
                query_count: batch.len() as u32,
                ..self.base
            };
            queue.write_buffer(&self.params, 0, bytemuck::bytes_of(&params));
            queue.write_buffer(&self.queries, 0, bytemuck::cast_slice(batch));
            let bytes = (batch.len() * std::mem::size_of::<Record>()) as u64;
            let mut encoder = device.create_command_encoder(&Default::default());
            {
                let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some("probeplace"),
                    timestamp_writes: self.timestamps.as_ref().map(|(set, _, _)| {
                        wgpu::ComputePassTimestampWrites {
                            query_set: set,
                            beginning_of_pass_write_index: Some(0),
                            end_of_pass_write_index: Some(1),
                        }
                    }),
                });
                pass.set_pipeline(pipeline);
                pass.set_bind_group(0, &self.bind_group, &[]);
                pass.dispatch_workgroups((batch.len() as u32).div_ceil(64), 1, 1);
            }
            encoder.copy_buffer_to_buffer(&self.records, 0, &self.readback, 0, bytes);
            if let Some((set, resolve, read)) = &self.timestamps {
                encoder.resolve_query_set(set, 0..2, resolve, 0);
                encoder.copy_buffer_to_buffer(resolve, 0, read, 0, 16);
            }
            queue.submit([encoder.finish()]);
            out.extend_from_slice(bytemuck::cast_slice(&self.read(&self.readback, bytes)?));
            if let (Some((_, _, read)), Some(ms)) = (&self.timestamps, gpu_ms.as_mut()) {
                let ticks: Vec<u64> = bytemuck::cast_slice(&self.read(read, 16)?).to_vec();
                let period = queue.get_timestamp_period() as f64;
                *ms += ticks[1].saturating_sub(ticks[0]) as f64 * period * 1e-6;
            }
        }
        Ok((out, gpu_ms))
    }

    /// Maps the first `bytes` of `buffer`, copies them out and unmaps.
    fn read(&self, buffer: &wgpu::Buffer, bytes: u64) -> Result<Vec<u8>, String> {
        let slice = buffer.slice(..bytes);
        let (tx, rx) = std::sync::mpsc::channel();
        slice.map_async(wgpu::MapMode::Read, move |r| {
            let _ = tx.send(r);
        });
        self.ctx
            .device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| format!("GPU failed: {e}"))?;
        rx.recv()
            .map_err(|e| format!("GPU readback lost: {e}"))?
            .map_err(|e| format!("GPU readback failed: {e}"))?;
        let data = slice
            .get_mapped_range()
            .map_err(|e| format!("GPU readback failed: {e}"))?
            .to_vec();
        buffer.unmap();
        Ok(data)
    }
}

/// wgpu refuses empty storage bindings: one zero word stands in.
fn nonempty(words: &[u32]) -> &[u32] {
    if words.is_empty() {
        &[0]
    } else {
        words
    }
}

/// The number of probes of `field`, or `Err` (one line) when it has none or
/// does not fit `limits`: more probes than texture-array layers, or maps
/// beyond the largest texture.
fn check_fits(limits: &wgpu::Limits, field: &LightField) -> Result<u32, String> {
    let probes = field.positions.len() as u32;
    if probes == 0 {
        return Err("the light field has no probes".into());
    }
    if probes > limits.max_texture_array_layers {
        return Err(format!(
            "{probes} probes exceed the adapter's {} texture-array layers",
            limits.max_texture_array_layers
        ));
    }
    if field.resolution > limits.max_texture_dimension_2d {
        return Err(format!(
            "{}² probe maps exceed the adapter's largest texture ({})",
            field.resolution, limits.max_texture_dimension_2d
        ));
    }
    Ok(probes)
}

/// The probe maps of a light field as texture arrays, a layer per probe,
/// in the order of their bindings (1 to 6).
struct Maps {
    /// The min-depth pyramid, a mip level per pyramid level.
    pyramid: wgpu::Texture,
    distance: wgpu::Texture,
    normal: wgpu::Texture,
    radiance: wgpu::Texture,
    irradiance: wgpu::Texture,
    moments: wgpu::Texture,
}

/// Creates the probe maps' texture arrays, a layer per probe, and fills them.
struct MapUploader<'a> {
    ctx: &'a Context,
    /// Layers of every array: the number of probes.
    layers: u32,
}

impl MapUploader<'_> {
    /// A `side`² texture array of `mips` mip levels.
    fn texture(
        &self,
        label: &str,
        side: u32,
        mips: u32,
        format: wgpu::TextureFormat,
    ) -> wgpu::Texture {
        self.ctx.device.create_texture(&wgpu::TextureDescriptor {
            label: Some(label),
            size: wgpu::Extent3d {
                width: side,
                height: side,
                depth_or_array_layers: self.layers,
            },
            mip_level_count: mips,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format,
            usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
            view_formats: &[],
        })
    }

    /// Writes `data`, every layer of mip level `mip` (`side`² texels of
    /// `texel_bytes` each, tightly packed), to `tex`.
    fn upload(&self, tex: &wgpu::Texture, mip: u32, side: u32, texel_bytes: u32, data: &[u8]) {
        self.ctx.queue.write_texture(
            wgpu::TexelCopyTextureInfo {
                texture: tex,
                mip_level: mip,
                origin: wgpu::Origin3d::ZERO,
                aspect: wgpu::TextureAspect::All,
            },
            data,
            wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(side * texel_bytes),
                rows_per_image: Some(side),
            },
            wgpu::Extent3d {
                width: side,
                height: side,
                depth_or_array_layers: self.layers,
            },
        );
    }
}

/// Creates the probe maps of `field` (`probes` layers each) and uploads
/// them as half floats: the pyramid's minima, distance, normal, radiance
/// (RGB, alpha 1), irradiance (likewise) and moments.
fn upload_maps(ctx: &Context, field: &LightField, probes: u32) -> Maps {
    use wgpu::TextureFormat::{R16Float, Rg16Float, Rgba16Float};
    let n = field.resolution;
    let m = field.irradiance_resolution;
    let levels = field.pyramid.len() as u32;
    let maps = MapUploader {
        ctx,
        layers: probes,
    };
    let pyramid = maps.texture("pyramid_min", n, levels, R16Float);
    for (k, level) in field.pyramid.iter().enumerate() {
        maps.upload(
            &pyramid,
            k as u32,
            n >> k,
            2,
            &halves(level.iter().map(|v| v[0])),
        );
    }
    let distance = maps.texture("distance", n, 1, R16Float);
    maps.upload(&distance, 0, n, 2, &halves(field.distance.iter().copied()));
    let normal = maps.texture("normal", n, 1, Rg16Float);
    maps.upload(
        &normal,
        0,
        n,
        4,
        &halves(field.normal.iter().flatten().copied()),
    );
    let rgba = |v: &[[f32; 3]]| halves(v.iter().flat_map(|c| [c[0], c[1], c[2], 1.0]));
    let radiance = maps.texture("radiance", n, 1, Rgba16Float);
    maps.upload(&radiance, 0, n, 8, &rgba(&field.radiance));
    let irradiance = maps.texture("irradiance", m, 1, Rgba16Float);
    maps.upload(&irradiance, 0, m, 8, &rgba(&field.irradiance));
    let moments = maps.texture("moments", m, 1, Rg16Float);
    maps.upload(
        &moments,
        0,
        m,
        4,
        &halves(field.moments.iter().flatten().copied()),
    );
    Maps {
        pyramid,
        distance,
        normal,
        radiance,
        irradiance,
        moments,
    }
}

/// The read-only storage buffers of the kernels, in the order of their
/// bindings (7 to 10).
struct Tables {
    /// Probe positions, `w` = 1.
    positions: wgpu::Buffer,
    /// The SVO's node and payload words (one zero word without an SVO).
    nodes: wgpu::Buffer,
    payload: wgpu::Buffer,
    /// The lattice's dense index (one zero word without a lattice).
    grid: wgpu::Buffer,
}

/// Uploads the probe positions of `field`, the words of `svo` and the dense
/// index of `lattice`, each as a storage buffer never empty.
fn upload_tables(
    device: &wgpu::Device,
    field: &LightField,
    svo: Option<&Svo>,
    lattice: Option<&Lattice>,
) -> Tables {
    let storage = |label: &str, words: &[u8]| {
        device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some(label),
            contents: words,
            usage: wgpu::BufferUsages::STORAGE,
        })
    };
    let positions: Vec<[f32; 4]> = field
        .positions
        .iter()
        .map(|p| [p.x, p.y, p.z, 1.0])
        .collect();
    let positions = storage("positions", bytemuck::cast_slice(&positions));
    let (nodes, payload) = svo.map_or((&[0u32][..], &[0u32][..]), |s| s.words());
    let nodes = storage("svo_nodes", bytemuck::cast_slice(nonempty(nodes)));
    let payload = storage("svo_payload", bytemuck::cast_slice(nonempty(payload)));
    let grid = lattice.map(Lattice::dense_index).unwrap_or_default();
    let grid = storage("lattice", bytemuck::cast_slice(nonempty(&grid)));
    Tables {
        positions,
        nodes,
        payload,
        grid,
    }
}

/// A buffer of `size` bytes, not mapped at creation.
fn plain_buffer(
    device: &wgpu::Device,
    label: &str,
    size: u64,
    usage: wgpu::BufferUsages,
) -> wgpu::Buffer {
    device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size,
        usage,
        mapped_at_creation: false,
    })
}

/// The buffers a batch passes through: the uniform parameters, the queries
/// in, the records out and their readback copy, each sized for [`BATCH`].
struct IoBuffers {
    params: wgpu::Buffer,
    queries: wgpu::Buffer,
    records: wgpu::Buffer,
    readback: wgpu::Buffer,
}

impl IoBuffers {
    /// Creates the buffers, in that order.
    fn new(device: &wgpu::Device) -> IoBuffers {
        use wgpu::BufferUsages as U;
        let params = plain_buffer(
            device,
            "params",
            std::mem::size_of::<Params>() as u64,
            U::UNIFORM | U::COPY_DST,
        );
        let record_bytes = (BATCH * std::mem::size_of::<Record>()) as u64;
        let queries = plain_buffer(
            device,
            "queries",
            (BATCH * std::mem::size_of::<Query>()) as u64,
            U::STORAGE | U::COPY_DST,
        );
        let records = plain_buffer(device, "records", record_bytes, U::STORAGE | U::COPY_SRC);
        let readback = plain_buffer(device, "readback", record_bytes, U::MAP_READ | U::COPY_DST);
        IoBuffers {
            params,
            queries,
            records,
            readback,
        }
    }
}

/// The kernels' bind group layout: the parameters (0), the six probe maps
/// (1 to 6), the four read-only tables and the queries (7 to 11), and the
/// records (12, read-write).
fn bind_group_layout(device: &wgpu::Device) -> wgpu::BindGroupLayout {
    let tex_entry = |binding: u32| wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Texture {
            sample_type: wgpu::TextureSampleType::Float { filterable: false },
            view_dimension: wgpu::TextureViewDimension::D2Array,
            multisampled: false,
        },
        count: None,
    };
    let buf_entry = |binding: u32, ty: wgpu::BufferBindingType| wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer {
            ty,
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    };
    let read = wgpu::BufferBindingType::Storage { read_only: true };
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("probeplace"),
        entries: &[
            buf_entry(0, wgpu::BufferBindingType::Uniform),
            tex_entry(1),
            tex_entry(2),
            tex_entry(3),
            tex_entry(4),
            tex_entry(5),
            tex_entry(6),
            buf_entry(7, read),
            buf_entry(8, read),
            buf_entry(9, read),
            buf_entry(10, read),
            buf_entry(11, read),
            buf_entry(12, wgpu::BufferBindingType::Storage { read_only: false }),
        ],
    })
}

/// Binds the parameters, the maps (as 2D-array views), the tables and the
/// query and record buffers to `layout`.
fn bind_group(
    device: &wgpu::Device,
    layout: &wgpu::BindGroupLayout,
    maps: &Maps,
    tables: &Tables,
    io: &IoBuffers,
) -> wgpu::BindGroup {
    let views: Vec<wgpu::TextureView> = [
        &maps.pyramid,
        &maps.distance,
        &maps.normal,
        &maps.radiance,
        &maps.irradiance,
        &maps.moments,
    ]
    .iter()
    .map(|t| {
        t.create_view(&wgpu::TextureViewDescriptor {
            dimension: Some(wgpu::TextureViewDimension::D2Array),
            ..Default::default()
        })
    })
    .collect();
    let mut entries = vec![wgpu::BindGroupEntry {
        binding: 0,
        resource: io.params.as_entire_binding(),
    }];
    for (i, v) in views.iter().enumerate() {
        entries.push(wgpu::BindGroupEntry {
            binding: 1 + i as u32,
            resource: wgpu::BindingResource::TextureView(v),
        });
    }
    for (i, b) in [
        &tables.positions,
        &tables.nodes,
        &tables.payload,
        &tables.grid,
        &io.queries,
        &io.records,
    ]
    .iter()
    .enumerate()
    {
        entries.push(wgpu::BindGroupEntry {
            binding: 7 + i as u32,
            resource: b.as_entire_binding(),
        });
    }
    device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("probeplace"),
        layout,
        entries: &entries,
    })
}

/// The kernel `entry` of `module` as a compute pipeline.
fn compute_pipeline(
    device: &wgpu::Device,
    layout: &wgpu::PipelineLayout,
    module: &wgpu::ShaderModule,
    entry: &str,
) -> wgpu::ComputePipeline {
    device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some(entry),
        layout: Some(layout),
        module,
        entry_point: Some(entry),
        compilation_options: Default::default(),
        cache: None,
    })
}

/// A query set of two timestamps (a batch's start and end), the buffer they
/// resolve to and its readback copy.
fn timestamp_queries(device: &wgpu::Device) -> (wgpu::QuerySet, wgpu::Buffer, wgpu::Buffer) {
    use wgpu::BufferUsages as U;
    (
        device.create_query_set(&wgpu::QuerySetDescriptor {
            label: Some("timestamps"),
            ty: wgpu::QueryType::Timestamp,
            count: 2,
        }),
        plain_buffer(device, "timestamps", 16, U::QUERY_RESOLVE | U::COPY_SRC),
        plain_buffer(device, "timestamps readback", 16, U::MAP_READ | U::COPY_DST),
    )
}

/// The kernels' parameters for `field` (`probes` probes) with `svo` and
/// `lattice` (placeholders where absent); march, selection and query count
/// are set per batch.
fn base_params(
    field: &LightField,
    probes: u32,
    svo: Option<&Svo>,
    lattice: Option<&Lattice>,
) -> Params {
    let (svo_origin, svo_leaf, svo_dims, svo_depth) = svo.map_or(([0.0; 3], 1.0, [0; 3], 0), |s| {
        (s.origin.to_array(), s.leaf_size, s.dims.to_array(), s.depth)
    });
    let (lattice_origin, lattice_spacing, lattice_dims) = lattice
        .map_or(([0.0; 3], [1.0; 3], [1; 3]), |l| {
            (l.origin.to_array(), l.spacing.to_array(), l.dims.to_array())
        });
    Params {
        n: field.resolution,
        levels: field.pyramid.len() as u32,
        march: 0,
        selection: 0,
        probe_count: probes,
        query_count: 0,
        m: field.irradiance_resolution,
        svo_depth,
        svo_origin,
        svo_leaf,
        svo_dims,
        pad2: 0,
        lattice_origin,
        pad3: 0.0,
        lattice_spacing,
        pad0: 0,
        lattice_dims,
        pad1: 0,
    }
}
