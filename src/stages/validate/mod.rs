//! Validation (Wang et al. 2019 §5.1): the path-traced reference of a
//! camera, and renders of the same view through the probes, measured
//! against it. `render` and `compare` both go through here: one G-buffer
//! per view, one tracer chosen once (the GPU's, or its CPU twin), one
//! composition and one set of [`Metrics`]: the figures of the metrics of
//! [`registry`] (one file each, docs/layout.md, "Adding a compare
//! metric") and the tracer's counts.

pub mod errors;
pub mod metric;
pub mod perceptual;
pub mod registry;
pub mod work;

use super::prepare::Prepared;
use crate::config::{CameraParams, Config};
use crate::error::{Error, Result};
use crate::gpu::{kind, twin, Context, ProbeTracer, Record, SelectionKind};
use crate::lightfield::LightField;
use crate::raster::RgbImage;
use crate::render::flip;
use crate::render::probes::{box_filter, compose, error_heat_map, gbuffer, GBuffer, ProbeImage};
use crate::render::reference::{mean_of, render_reference};
use crate::render::{Reference, Renderer};
use crate::svo::Svo;
use crate::trace::{check::padded_bounds, single::March, Lattice, Selection};
pub use errors::{mean_luminance, RELATIVE_EPSILON};
use glam::Vec3;
use metric::{Measure, ViewRender};
pub use registry::{Metric, PerMetric, METRICS};
use serde::Serialize;

/// Random streams of the validation renders' glossy rays.
const GLOSSY_STREAMS: u64 = 0x6_1055;

/// Radius of the box filter of [`errors::MseGlossyFiltered`].
pub const FILTER_RADIUS: u32 = 3;

/// Side in pixels of the blocks the comparison's intervals resample
/// ([`crate::stats`]): over twice the filter's width, so that neighbouring
/// blocks share few filtered pixels.
pub const BLOCK: u32 = 16;

/// The seed of camera `index`'s reference and rays; camera 0's is the
/// config's, so `bake`'s reference is `compare`'s first.
fn camera_seed(config: &Config, index: usize) -> u64 {
    config.seed ^ (index as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15)
}

/// Refuses reference images that would not fit the memory budget or
/// would run past `limits` work limits, for `views` cameras
/// ([`crate::limits`]; errors name the `reference` field, unprefixed).
/// Memory: the RGB f32 images (full, glossy indirect, the G-buffer) at
/// about 64 bytes a pixel. Work: `width × height × samples_per_pixel`
/// paths of `1 + bounces` vertices per view.
pub fn check_reference(config: &Config, views: usize, limits: f64) -> crate::error::Result<()> {
    let r = &config.reference;
    let pixels = r.width.0 as f64 * r.height.0 as f64;
    crate::limits::check_memory(
        "reference.width",
        &format!("a {}×{} reference", r.width.0, r.height.0),
        pixels * 64.0,
    )?;
    let vertices = views as f64
        * pixels
        * r.samples_per_pixel.0 as f64
        * (1.0 + r.bounces.0 as f64)
        * super::bake::light_factor(config);
    crate::limits::check_work(
        "reference.samples_per_pixel",
        &format!(
            "{views} reference image(s) of {}×{} pixels, {} paths each, {} bounces",
            r.width.0, r.height.0, r.samples_per_pixel.0, r.bounces.0
        ),
        vertices,
        crate::limits::rate::PATH_VERTICES * limits,
    )
}

/// The path-traced reference of camera `index` (`camera`), at the config's
/// `reference` size, paths and bounces.
///
/// Contract: deterministic for a config and camera index.
pub fn reference(
    config: &Config,
    prepared: &Prepared,
    camera: &CameraParams,
    index: usize,
) -> Reference {
    let r = &config.reference;
    let renderer = Renderer::new(&prepared.scene, &prepared.bvh, &config.lights, r.bounces.0);
    render_reference(
        &renderer,
        camera,
        r.width.0,
        r.height.0,
        r.samples_per_pixel.0,
        camera_seed(config, index),
    )
}

/// One camera's fixed inputs: its reference, G-buffer and display scales.
pub struct ValidationView {
    /// The camera.
    pub camera: CameraParams,
    /// Its path-traced reference.
    pub reference: Reference,
    /// The reference's glossy indirect image, box filtered.
    pub filtered_glossy: Vec<[f32; 3]>,
    /// Primary hits, irradiance queries and glossy rays.
    pub gbuffer: GBuffer,
    /// Exposure of the PNG previews (the reference's).
    pub exposure: f32,
    /// Exposure of the glossy-indirect images ꟻLIP compares (the filtered
    /// reference's).
    pub glossy_exposure: f32,
    /// The filtered reference glossy indirect as ꟻLIP sees it
    /// ([`crate::render::flip::display`]).
    pub flip_reference: Vec<u8>,
    /// Error of the heat maps' full scale.
    pub error_scale: f32,
}

impl ValidationView {
    /// The view of camera `index` with its `reference`, `glossy_rays` glossy
    /// rays per pixel (common random numbers: the same rays for every
    /// placement measured from this view).
    pub fn new(
        config: &Config,
        prepared: &Prepared,
        camera: &CameraParams,
        index: usize,
        reference: Reference,
        glossy_rays: u32,
    ) -> ValidationView {
        let (scene, bvh) = (&prepared.scene, &prepared.bvh);
        let direct = Renderer::new(scene, bvh, &config.lights, 0);
        let gbuffer = gbuffer(
            &direct,
            camera,
            reference.width,
            reference.height,
            glossy_rays,
            &padded_bounds(&scene.bounds),
            camera_seed(config, index) ^ GLOSSY_STREAMS,
        );
        let filtered_glossy = box_filter(
            &reference.glossy_indirect,
            reference.width,
            reference.height,
            FILTER_RADIUS,
        );
        let glossy_exposure = auto_exposure(&filtered_glossy);
        ValidationView {
            camera: *camera,
            flip_reference: flip::display(
                &filtered_glossy,
                reference.width,
                reference.height,
                glossy_exposure,
            ),
            glossy_exposure,
            filtered_glossy,
            exposure: auto_exposure(&reference.full),
            error_scale: (4.0 * mean_luminance(&reference.glossy_indirect)) as f32,
            reference,
            gbuffer,
        }
    }

    /// The glossy error heat map of `glossy` against the reference.
    pub fn heat_map(&self, glossy: &[[f32; 3]]) -> RgbImage {
        let r = &self.reference;
        error_heat_map(
            glossy,
            &r.glossy_indirect,
            r.width,
            r.height,
            self.error_scale,
        )
    }
}

/// A kernel's answers, one record per query, and its GPU time (ms) where
/// the adapter has timestamps.
pub type Answers = (Vec<Record>, Option<f64>);

/// The light-field tracer of one probe set, chosen once: the GPU's where
/// an adapter takes the field, else the CPU twin, which gives the same
/// records (tests compare them).
pub struct Tracer<'a> {
    field: &'a LightField,
    svo: Option<&'a Svo>,
    lattice: Option<&'a Lattice>,
    gpu: Option<ProbeTracer<'a>>,
}

impl<'a> Tracer<'a> {
    /// The tracer of `field` with its SVO and/or grid. With a `context` the
    /// field is uploaded; when that fails the CPU twin traces and the
    /// second value says why.
    pub fn new(
        context: Option<&'a Context>,
        field: &'a LightField,
        svo: Option<&'a Svo>,
        lattice: Option<&'a Lattice>,
    ) -> (Tracer<'a>, Option<String>) {
        let (gpu, why) = match context.map(|ctx| ProbeTracer::new(ctx, field, svo, lattice)) {
            Some(Ok(t)) => (Some(t), None),
            Some(Err(e)) => (None, Some(e)),
            None => (None, None),
        };
        (
            Tracer {
                field,
                svo,
                lattice,
                gpu,
            },
            why,
        )
    }

    /// Whether the GPU traces.
    pub fn on_gpu(&self) -> bool {
        self.gpu.is_some()
    }

    fn selection(&self, kind: SelectionKind) -> Result<Selection<'a>> {
        match (kind, self.lattice, self.svo) {
            (SelectionKind::Grid, Some(l), _) => Ok(Selection::Grid(l)),
            (SelectionKind::Svo, _, Some(s)) => Ok(Selection::Svo(s)),
            _ => Err(Error::Internal(format!(
                "{kind:?} selection without its structure"
            ))),
        }
    }

    /// Irradiance at the view's surfaces, and the GPU time.
    pub fn gather(&self, view: &ValidationView, kind: SelectionKind) -> Result<Answers> {
        let q = &view.gbuffer.irradiance;
        match &self.gpu {
            Some(t) => t.gather_irradiance(q, kind).map_err(Error::Internal),
            None => Ok((
                twin::gather_irradiance(self.field, &self.selection(kind)?, q),
                None,
            )),
        }
    }

    /// The view's glossy rays through the probes, and the GPU time.
    pub fn trace(
        &self,
        view: &ValidationView,
        march: March,
        kind: SelectionKind,
    ) -> Result<Answers> {
        let q = &view.gbuffer.glossy;
        match &self.gpu {
            Some(t) => t.trace_rays(q, march, kind).map_err(Error::Internal),
            None => Ok((
                twin::trace_rays(self.field, &self.selection(kind)?, q, march),
                None,
            )),
        }
    }
}

/// The figures of one render through the probes against its view's
/// reference (Wang et al. 2019 §5.1, and the tracer's work per ray, §4.2).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Metrics {
    /// The figure of every metric of [`registry`], by its key.
    #[serde(flatten)]
    pub figures: PerMetric<f64>,
    /// GPU time of the trace and the gather in milliseconds (timestamps);
    /// `null` on the CPU twin or without timestamp queries.
    pub gpu_ms: Option<f64>,
    /// The glossy trace's part of `gpu_ms`: where the marches differ.
    pub gpu_trace_ms: Option<f64>,
    /// The irradiance gather's part of `gpu_ms`, the same for both
    /// marches on one selection.
    pub gpu_gather_ms: Option<f64>,
    /// Mean RGB of the glossy indirect image, to set beside the reference's.
    pub glossy_indirect_mean: [f64; 3],
    /// Texels the surfel tests read per glossy ray.
    pub surfel_fetches_per_ray: f64,
    /// Pyramid texel fetches per glossy ray as a GPU runs the march in
    /// lock step ([`work::warp_fetches_per_ray`]): each 32-ray warp, in
    /// dispatch order, takes as many steps as its longest ray.
    pub warp_fetches_per_ray: f64,
    /// Probes consulted after the first, per glossy ray.
    pub probe_switches_per_ray: f64,
    /// Glossy rays no probe could resolve.
    pub unresolved_rays: u64,
    /// Glossy rays that hit a surface.
    pub hits: u64,
    /// Glossy rays that leave the scene.
    pub misses: u64,
}

/// A render through the probes and its figures.
pub struct Validation {
    /// The image.
    pub image: ProbeImage,
    /// Its figures against the reference.
    pub metrics: Metrics,
    /// Its errors per [`BLOCK`]-pixel block, for intervals.
    pub blocks: Blocks,
    /// Its ꟻLIP error per pixel, for the error map.
    pub flip_map: Vec<f32>,
}

/// One render's errors per block of [`BLOCK`]² pixels, row by row
/// ([`crate::stats::block_means`]), for each paired metric
/// ([`metric::ViewMetric::PAIRED`]; empty for the others): what the
/// comparison's bootstrap resamples.
pub type Blocks = PerMetric<Vec<f64>>;

/// Most shading points of a view [`shading_probe_distance`] looks at (an
/// even subsample of its pixels with a surface).
pub const SHADING_POINTS: usize = 4096;

/// The mean distance from the shading points of `view` (its irradiance
/// queries: every pixel with a surface, lifted off it; an even subsample of
/// at most [`SHADING_POINTS`]) to the nearest of `probes` that sees them
/// (in front of the surface, unoccluded), over the points some probe sees;
/// `None` when no probe sees any.
///
/// **Why.** A light-field probe answers a glossy ray with the radiance of
/// the hit point *as the probe sees it* (McGuire et al. 2017 §4); where the
/// hit's surface is glossy, that differs from what the shading point sees
/// by the parallax between the two, which grows with their distance. It is
/// the figure that explains why one placement's glossy error differs from
/// another's at equal count (docs/method.md, "Comparing placements").
pub fn shading_probe_distance(
    view: &ValidationView,
    bvh: &crate::scene::raycast::SceneBvh,
    probes: &[Vec3],
) -> Option<f64> {
    use rayon::prelude::*;
    let queries = &view.gbuffer.irradiance;
    let stride = queries.len().div_ceil(SHADING_POINTS).max(1);
    // Probes in front of the point, nearest first; the first unoccluded
    // one is the answer, so most points cast one or two shadow rays, not
    // one per probe. The buffer is reused per thread.
    let nearest: Vec<f32> = queries
        .par_iter()
        .step_by(stride)
        .map_init(Vec::new, |ahead: &mut Vec<(f32, usize)>, q| {
            let (p, n) = (Vec3::from(q.origin), Vec3::from(q.dir));
            ahead.clear();
            ahead.extend(
                probes
                    .iter()
                    .enumerate()
                    .filter(|(_, &k)| n.dot(k - p) > 0.0)
                    .map(|(i, &k)| (k.distance(p), i)),
            );
            ahead.sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
            ahead
                .iter()
                .find(|&&(_, i)| !bvh.occluded(p, probes[i], 1e-4))
                .map_or(f32::INFINITY, |&(d, _)| d)
        })
        .collect();
    let seen: Vec<f64> = nearest
        .iter()
        .filter(|d| d.is_finite())
        .map(|&d| d as f64)
        .collect();
    (!seen.is_empty()).then(|| seen.iter().sum::<f64>() / seen.len() as f64)
}

/// Composes the view from `irradiance` (answers to its irradiance queries)
/// and `glossy` (to its glossy rays) and measures it; `gpu_ms` is the sum
/// of the two kernels' GPU times where both have one.
pub fn validate(view: &ValidationView, irradiance: &Answers, glossy: &Answers) -> Validation {
    let image = compose(&view.gbuffer, &irradiance.0, &glossy.0);
    let records = &glossy.0;
    let rays = records.len().max(1) as f64;
    let sum = |f: fn(&Record) -> u32| records.iter().map(|r| f(r) as u64).sum::<u64>();
    let count = |k: u32| records.iter().filter(|r| r.kind == k).count() as u64;
    let r = &view.reference;
    let filtered = box_filter(&image.glossy_indirect, r.width, r.height, FILTER_RADIUS);
    let flip_map = flip::flip(
        &view.flip_reference,
        &flip::display(&filtered, r.width, r.height, view.glossy_exposure),
        r.width,
        r.height,
    );
    let render = ViewRender {
        image: &image,
        reference: r,
        filtered: &filtered,
        filtered_reference: &view.filtered_glossy,
        flip_map: &flip_map,
        records,
    };
    let mut blocks = Blocks::default();
    let figures = PerMetric::from_fn(|m| match m.measure(&render) {
        Measure::Pixels(v) => {
            if m.entry().paired {
                blocks[m] = crate::stats::block_means(&v, r.width as usize, BLOCK as usize);
            }
            v.iter().sum::<f64>() / v.len().max(1) as f64
        }
        Measure::Value(v) => v,
    });
    let metrics = Metrics {
        figures,
        gpu_ms: glossy.1.zip(irradiance.1).map(|(a, b)| a + b),
        gpu_trace_ms: glossy.1,
        gpu_gather_ms: irradiance.1,
        glossy_indirect_mean: mean_of(&image.glossy_indirect),
        surfel_fetches_per_ray: (crate::trace::single::SURFEL_TEST_FETCHES as u64
            * sum(|r| r.surfels)) as f64
            / rays,
        warp_fetches_per_ray: work::warp_fetches_per_ray(records, work::WARP),
        probe_switches_per_ray: sum(|r| r.probes.saturating_sub(1)) as f64 / rays,
        unresolved_rays: count(kind::UNKNOWN) + count(kind::NO_PROBE),
        hits: count(kind::HIT),
        misses: count(kind::MISS),
    };
    Validation {
        image,
        metrics,
        blocks,
        flip_map,
    }
}

/// Exposure that maps the mean luminance of `pixels` to 0.4 (display
/// previews only; the EXR files hold the linear values).
pub fn auto_exposure(pixels: &[[f32; 3]]) -> f32 {
    let mean = mean_luminance(pixels);
    if mean > 1e-12 {
        (0.4 / mean) as f32
    } else {
        1.0
    }
}
