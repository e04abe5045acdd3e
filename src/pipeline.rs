//! The `place` job: config → scene → BVH → SDF → placement → coverage
//! reference → refinement → coverage → SVO → outputs. Each stage is a function from the previous stage's typed output
//! to its own; this module only sequences them, times them, and writes the
//! results once everything has succeeded.

use crate::config::{Config, Domain, Placement, VoxelSize};
use crate::coverage::{self, CoverageReference};
use crate::error::{Error, Result};
use crate::placement::{self, PlacementInput, ProbeSet};
use crate::progress::Progress;
use crate::refine;
use crate::report::{self, preview, ProbesFile, Report};
use crate::resolution::{self, Resolution};
use crate::scene::raycast::SceneBvh;
use crate::scene::{self, Bounds, Scene};
use crate::sdf::{self, Sdf};
use crate::svo::{self, Svo};
use glam::{DVec3, Vec3};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Pixel size of each of the two views in `placement.png`.
pub const PREVIEW_VIEW_SIZE: u32 = 512;

/// What the command line may override in a config.
#[derive(Debug, Clone, Default)]
pub struct PlaceOptions {
    /// Output directory instead of the config's `output`.
    pub out: Option<PathBuf>,
    /// Method instead of the config's `placement` (`sdf-skeleton`, `medial-axis`, `grid:NxMxK`).
    pub method: Option<String>,
    /// Seed instead of the config's `seed`.
    pub seed: Option<u64>,
    /// Show progress bars.
    pub progress: bool,
    /// Skip refinement whatever the config says.
    pub no_refine: bool,
}

/// What a finished run produced.
#[derive(Debug)]
pub struct PlaceOutcome {
    /// Directory holding the outputs.
    pub out_dir: PathBuf,
    /// The report as written.
    pub report: Report,
}

/// Runs the whole `place` job for the config at `config_path`.
///
/// Contract: on success, `probes.json`, `svo.bin`, `placement.png` and `report.json` are
/// in the output directory (report last); on any error nothing new is written
/// there. User mistakes come back as [`Error::User`].
pub fn place(config_path: &Path, options: &PlaceOptions) -> Result<PlaceOutcome> {
    place_with(Config::load(config_path)?, config_path, options)
}

/// [`place`] for a config already loaded from `config_path` (and perhaps
/// changed by the caller, e.g. a test or a parameter sweep); `config_path`
/// only names the file in messages and the report.
pub fn place_with(
    config: Config,
    config_path: &Path,
    options: &PlaceOptions,
) -> Result<PlaceOutcome> {
    let mut run = compute_place(config, config_path, options)?;
    run.finish_timings();
    run.write()
}

/// A placement computed but not yet written: everything `place` writes,
/// plus what later stages (the bake) build on.
pub struct PlaceRun {
    /// The config as run (command-line overrides applied).
    pub config: Config,
    /// Where the outputs go.
    pub out_dir: PathBuf,
    /// Scene, domain, BVH and SDF.
    pub prepared: Prepared,
    /// The coverage measure's reference the run was scored by.
    pub reference: CoverageReference,
    /// The probes placed.
    pub probes: ProbeSet,
    /// The octree of probe indices.
    pub svo: Svo,
    /// The report so far (`report.json` is written last).
    pub report: Report,
    /// Files to write besides `report.json`, by name, in order.
    pub files: Vec<(String, Vec<u8>)>,
    /// Files of earlier runs that would no longer match, removed on writing.
    pub stale: Vec<String>,
    /// The progress bars' switch.
    pub progress: Progress,
    started: Instant,
}

impl PlaceRun {
    /// Records the total wall time so far in the report.
    pub fn finish_timings(&mut self) {
        self.report
            .timings_ms
            .insert("total".into(), self.started.elapsed().as_secs_f64() * 1e3);
    }

    /// Writes every file atomically, `report.json` last, and removes stale ones.
    pub fn write(self) -> Result<PlaceOutcome> {
        self.write_files()?;
        Ok(PlaceOutcome {
            out_dir: self.out_dir,
            report: self.report,
        })
    }

    /// [`PlaceRun::write`], keeping the run for the caller's later stages.
    pub fn write_files(&self) -> Result<()> {
        let report_json = report::to_json(&self.report)?;
        report::prepare_output_dir(&self.out_dir)?;
        for (name, bytes) in &self.files {
            report::write_atomic(&self.out_dir.join(name), bytes)?;
        }
        for name in &self.stale {
            let path = self.out_dir.join(name);
            if path.exists() {
                std::fs::remove_file(&path).map_err(|e| Error::io(&path, e))?;
            }
        }
        report::write_atomic(&self.out_dir.join("report.json"), &report_json)
    }
}

/// Runs every stage of `place` without writing anything.
pub fn compute_place(
    mut config: Config,
    config_path: &Path,
    options: &PlaceOptions,
) -> Result<PlaceRun> {
    let t_start = Instant::now();
    let mut timings = BTreeMap::new();
    let progress = Progress::new(options.progress);

    if let Some(m) = &options.method {
        config.placement = Placement::parse_cli(m, &config.placement)?;
    }
    if let Some(s) = options.seed {
        config.seed = s;
    }
    if options.no_refine {
        config.refine.enabled = false;
    }
    let out_dir = options.out.clone().unwrap_or_else(|| config.output.clone());
    // Fail before the expensive stages, not after them.
    report::check_output_dir(&out_dir)?;

    let prepared = prepare(&config, config_path, &progress, &mut timings)?;
    let Prepared {
        scene,
        domain,
        bvh,
        sdf,
        ..
    } = &prepared;

    let input = prepared.placement_input(config.seed, &progress);
    let t = Instant::now();
    let reference =
        CoverageReference::new(scene, bvh, sdf, &config.coverage, config.seed, &progress);
    lap(&mut timings, "coverage_reference", t);

    let (probes, refined) =
        placement_stage(&config, config_path, &input, &reference, &mut timings)?;

    let t = Instant::now();
    let positions = probes.positions();
    let (cov, holes) = reference.evaluate_with_holes(bvh, &positions, &progress);
    let health = coverage::probe_health(sdf, domain, &positions);
    lap(&mut timings, "coverage", t);

    let t = Instant::now();
    let baked = svo::bake(&config.svo, &probes, &input).map_err(|e| e.in_file(config_path))?;
    let svo_bin = baked.svo.to_bytes();
    lap(&mut timings, "svo", t);

    let t = Instant::now();
    let png = render_png(scene, domain, &probes, &holes)?;
    lap(&mut timings, "preview", t);

    let scene_name = config.scene.display().to_string();
    let probes_json = report::to_json(&ProbesFile::new(
        &probes,
        scene,
        sdf,
        &scene_name,
        config.seed,
        config.scale.0,
        config.up,
    ))?;
    let mut warnings = scene.warnings.clone();
    if health.probes_in_solid > 0 {
        warnings.push(format!(
            "{} probe(s) stand in solid space",
            health.probes_in_solid
        ));
    }
    let report = Report::new(
        &config_path.display().to_string(),
        &scene_name,
        scene,
        domain,
        sdf,
        &probes,
        config.seed,
        cov,
        health,
        timings,
        warnings,
    );
    let mut report = report;
    report.svo = Some(baked.report);
    report.resolution = Some(prepared.resolution);
    let mut files = vec![
        ("probes.json".to_string(), probes_json),
        ("svo.bin".to_string(), svo_bin),
        ("placement.png".to_string(), png),
    ];
    let mut stale = Vec::new();
    match refined {
        Some((refine_report, image)) => {
            let target = config.refine.coverage_target.0 as f64;
            if config.refine.fill && refine_report.coverage_final < target {
                report.warnings.push(format!(
                    "refine: coverage {:.2}% is short of the target {:.2}%: no position at least {:.3} from every surface sees the rest; lower refine.min_clearance (or remove it) to reach it",
                    100.0 * refine_report.coverage_final,
                    100.0 * target,
                    refine_report.params["min_fill_clearance"]
                ));
            }
            report.probes_below_clearance = refine_report.probes_below_clearance;
            report.best_view_incidence_deg = refine_report.best_view_incidence_deg_final;
            report.refine = Some(refine_report);
            files.push(("atlas.png".to_string(), encode_png(&image, "atlas.png")?));
        }
        // An atlas from an earlier refined run would no longer match.
        None => stale.push("atlas.png".to_string()),
    }
    Ok(PlaceRun {
        config,
        out_dir,
        prepared,
        reference,
        probes,
        svo: baked.svo,
        report,
        files,
        stale,
        progress,
        started: t_start,
    })
}

/// Places probes with `config.placement`, then refines them (Wang et al.
/// 2019 §3.3) where `config.refine.enabled`; `reference` is the coverage
/// measure refinement maximizes. Returns the probes and, when refined,
/// refinement's report and atlas image. Stage times go into `timings`.
///
/// Contract: errors of config fields are prefixed with `config_path`.
pub fn placement_stage(
    config: &Config,
    config_path: &Path,
    input: &PlacementInput,
    reference: &CoverageReference,
    timings: &mut BTreeMap<String, f64>,
) -> Result<(ProbeSet, Option<(refine::RefineReport, image::RgbImage)>)> {
    let t = Instant::now();
    let probes = placement::place(&config.placement, input).map_err(|e| e.in_file(config_path))?;
    lap(timings, "placement", t);
    if !config.refine.enabled {
        return Ok((probes, None));
    }
    let t = Instant::now();
    let out = refine::refine(&config.refine, probes, input, reference)
        .map_err(|e| e.in_file(config_path))?;
    lap(timings, "refine", t);
    Ok((out.probes, Some((out.report, out.atlas_image))))
}

/// The scene and what every placement method reads, built by [`prepare`].
pub struct Prepared {
    /// The loaded scene.
    pub scene: Scene,
    /// Where probes may go.
    pub domain: Bounds,
    /// The scene's BVH.
    pub bvh: SceneBvh,
    /// The SDF of the domain.
    pub sdf: Sdf,
    /// How its voxel size was chosen.
    pub resolution: Resolution,
}

impl Prepared {
    /// The input of a placement method over this scene.
    pub fn placement_input<'a>(&'a self, seed: u64, progress: &'a Progress) -> PlacementInput<'a> {
        PlacementInput {
            scene: &self.scene,
            bvh: &self.bvh,
            sdf: &self.sdf,
            domain: &self.domain,
            seed,
            progress,
        }
    }
}

/// The stages before placement (load, domain, BVH, SDF) for `config`, read
/// from `config_path`; each stage's wall time goes into `timings` (ms).
///
/// Contract: errors of the stages that read config fields (domain, SDF) are
/// prefixed with `config_path`; scene errors name the scene file themselves.
pub fn prepare(
    config: &Config,
    config_path: &Path,
    progress: &Progress,
    timings: &mut BTreeMap<String, f64>,
) -> Result<Prepared> {
    let t = Instant::now();
    let scene = scene::load_obj(&config.scene, config.scale.0, config.up)?;
    lap(timings, "load", t);

    let domain = resolve_domain(&config.domain, &scene).map_err(|e| e.in_file(config_path))?;
    let t = Instant::now();
    let bvh = SceneBvh::new(&scene);
    lap(timings, "bvh", t);

    let t = Instant::now();
    let resolution = resolve_voxel_size(config, &scene, &bvh, &domain);
    lap(timings, "resolution", t);

    let t = Instant::now();
    let sdf = sdf::build(
        &scene,
        &bvh,
        &domain,
        resolution.voxel_size,
        &config.sdf,
        config.seed,
        progress,
    )
    .map_err(|e| e.in_file(config_path))?;
    lap(timings, "sdf", t);
    Ok(Prepared {
        scene,
        domain,
        bvh,
        sdf,
        resolution,
    })
}

/// The voxel size of `config` for `domain` of `scene`: the config's, or
/// the one [`resolution::auto`] chooses.
pub fn resolve_voxel_size(
    config: &Config,
    scene: &Scene,
    bvh: &SceneBvh,
    domain: &Bounds,
) -> Resolution {
    match config.voxel_size {
        VoxelSize::Fixed(v) => Resolution::fixed(v.0),
        VoxelSize::Auto => resolution::auto(scene, bvh, domain, config.seed),
    }
}

/// Records the milliseconds since `since` as stage `name`.
fn lap(timings: &mut BTreeMap<String, f64>, name: &str, since: Instant) {
    timings.insert(name.to_string(), since.elapsed().as_secs_f64() * 1e3);
}

/// The domain box in the scene's local coordinates: the scene bounds, or
/// the config's box (world coordinates), which must overlap the scene.
pub fn resolve_domain(domain: &Domain, scene: &Scene) -> Result<Bounds> {
    match domain {
        Domain::Auto => Ok(scene.bounds),
        Domain::Box(b) => {
            let d = Bounds {
                min: scene.to_local(DVec3::from_array(b.min)),
                max: scene.to_local(DVec3::from_array(b.max)),
            };
            let overlap =
                d.min.cmplt(scene.bounds.max).all() && d.max.cmpgt(scene.bounds.min).all();
            if !overlap {
                return Err(Error::User(format!(
                    "domain: box {:?}..{:?} does not overlap the scene bounds {:?}..{:?}",
                    b.min,
                    b.max,
                    scene.to_world(scene.bounds.min).to_array(),
                    scene.to_world(scene.bounds.max).to_array()
                )));
            }
            Ok(d)
        }
    }
}

/// Renders `placement.png` (with the coverage holes marked) to PNG bytes.
fn render_png(
    scene: &Scene,
    domain: &Bounds,
    probes: &ProbeSet,
    holes: &[Vec3],
) -> Result<Vec<u8>> {
    let image = placement_views(scene, domain, &probes.positions(), holes, PREVIEW_VIEW_SIZE);
    encode_png(&image, "placement.png")
}

/// The top and side views of `probes` in `scene` over `domain`, surface
/// samples in `holes` marked, each view `view_size` pixels wide
/// ([`preview::render_preview`]).
pub fn placement_views(
    scene: &Scene,
    domain: &Bounds,
    probes: &[Vec3],
    holes: &[Vec3],
    view_size: u32,
) -> image::RgbImage {
    let colors: Vec<[f32; 3]> = scene
        .material_ids
        .iter()
        .map(|&m| scene.materials[m as usize].diffuse)
        .collect();
    preview::render_preview(
        &preview::PreviewInput {
            triangles: &scene.triangles,
            colors: &colors,
            probes,
            holes,
            bounds_min: domain.min,
            bounds_max: domain.max,
        },
        view_size,
    )
}

/// PNG bytes of `image`, which will be written as `name`.
pub fn encode_png(image: &image::RgbImage, name: &str) -> Result<Vec<u8>> {
    let mut bytes = Vec::new();
    image
        .write_to(
            &mut std::io::Cursor::new(&mut bytes),
            image::ImageFormat::Png,
        )
        .map_err(|e| Error::Internal(format!("encoding {name}: {e}")))?;
    Ok(bytes)
}

/// What `probeplace inspect` found.
#[derive(Debug)]
pub struct Inspection {
    /// The `svo.bin` read.
    pub path: PathBuf,
    /// Its contents.
    pub svo: Svo,
    /// The `lightfield.bin` beside it, when there is one, checked too.
    pub light_field: Option<(PathBuf, crate::lightfield::LightField)>,
}

impl std::fmt::Display for Inspection {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let s = &self.svo;
        writeln!(
            f,
            "{}: {} probes, {} nodes ({} leaves), depth {}, {} bytes (a dense RGBA8 texture: {} bytes, {:.1}x more)",
            self.path.display(),
            s.probe_count,
            s.nodes(),
            s.leaves(),
            s.depth,
            s.bytes(),
            s.dense_bytes(),
            s.dense_bytes() as f64 / s.bytes() as f64
        )?;
        write!(
            f,
            "  leaf size {} over {} x {} x {} leaves from {:?}; at most {} probes per leaf; {} distinct lists; {} leaves without a visible probe",
            s.leaf_size,
            s.dims.x,
            s.dims.y,
            s.dims.z,
            s.world_origin().as_vec3().to_array(),
            s.max_probes,
            s.distinct_lists(),
            s.leaves_without_visible_probe
        )?;
        if let Some((path, lf)) = &self.light_field {
            write!(
                f,
                "\n{}: {} probes, {}² maps with {} pyramid levels, {}² irradiance, {} bytes",
                path.display(),
                lf.positions.len(),
                lf.resolution,
                lf.pyramid.len(),
                lf.irradiance_resolution,
                lf.bytes()
            )?;
        }
        Ok(())
    }
}

/// Reads the `svo.bin` at `path`, or in the output directory `path`, and
/// checks it against the `probes.json` beside it when there is one.
///
/// Contract: a missing, truncated, corrupted or wrong-version file, or an
/// SVO whose probe count disagrees with `probes.json`, is an
/// [`Error::User`] naming the file.
pub fn inspect(path: &Path) -> Result<Inspection> {
    let file = if path.is_dir() {
        let f = path.join("svo.bin");
        if !f.exists() {
            return Err(Error::user_file(
                path,
                "holds no svo.bin (write one with probeplace place)",
            ));
        }
        f
    } else {
        path.to_path_buf()
    };
    let svo = Svo::read(&file)?;
    let probes_json = file.with_file_name("probes.json");
    if let Ok(text) = std::fs::read_to_string(&probes_json) {
        let count = serde_json::from_str::<serde_json::Value>(&text)
            .ok()
            .and_then(|v| v.get("probes").and_then(|p| p.as_array()).map(Vec::len));
        match count {
            Some(n) if n == svo.probe_count as usize => {}
            Some(n) => {
                return Err(Error::user_file(
                    &file,
                    format!(
                        "indexes {} probes but {} has {n}: the two come from different runs",
                        svo.probe_count,
                        probes_json.display()
                    ),
                ))
            }
            None => {
                return Err(Error::user_file(
                    &probes_json,
                    "is not a probeplace probes file",
                ))
            }
        }
    }
    let lf_path = file.with_file_name("lightfield.bin");
    let light_field = if lf_path.exists() {
        let field = crate::lightfield::LightField::read(&lf_path)?;
        if field.positions.len() != svo.probe_count as usize {
            return Err(Error::user_file(
                &lf_path,
                format!(
                    "holds {} probes but {} indexes {}: the two come from different runs",
                    field.positions.len(),
                    file.display(),
                    svo.probe_count
                ),
            ));
        }
        Some((lf_path, field))
    } else {
        None
    };
    Ok(Inspection {
        path: file,
        svo,
        light_field,
    })
}

/// Seed offset of the probe radiance's random streams, so they differ from
/// the reference image's even under the same config seed.
const BAKE_STREAMS: u64 = 0x1F_BA4E;

/// Free points whose random rays check the tracer in every bake.
pub const TRACER_CHECK_RAYS: usize = 4096;

/// Runs the `bake` job: everything `place` does, then the light-field
/// probe bake (McGuire et al. 2017 §3, §5.2), a check of the CPU tracer
/// against ray casts, and the path-traced reference image when the config
/// has a camera.
///
/// Contract: on success the output directory holds `place`'s files plus
/// `lightfield.bin`, the probe-map previews (`radiance.exr`/`.png`,
/// `irradiance.exr`/`.png`, `distance.png`, `normal.png`) and, with a
/// camera, `reference.exr`/`.png` and `reference-glossy.exr`/`.png`;
/// `report.json` (written last) has a `bake` section. On error nothing new
/// is written.
pub fn bake(config_path: &Path, options: &PlaceOptions) -> Result<PlaceOutcome> {
    let mut run = compute_place(Config::load(config_path)?, config_path, options)?;
    bake_stage(&mut run)?;
    run.finish_timings();
    run.write()
}

/// What the bake hands on to the validation render.
pub struct BakeProducts {
    /// The baked probes.
    pub field: crate::lightfield::LightField,
    /// The path-traced reference; `None` without a camera.
    pub reference: Option<crate::render::Reference>,
}

/// The bake on top of a computed placement: adds its files and report, and
/// returns the light field and the reference.
pub fn bake_stage(run: &mut PlaceRun) -> Result<BakeProducts> {
    use crate::render::{reference::render_reference, Renderer};
    use crate::report::bake::{
        atlas, distance_preview, normal_preview, BakeReport, ReferenceReport,
    };
    use crate::trace::{check, single::March, Selection};

    let config = &run.config;
    let Prepared { scene, bvh, .. } = &run.prepared;
    let seed = config.seed;
    let mut timings: BTreeMap<String, f64> = BTreeMap::new();
    let renderer = Renderer::new(scene, bvh, &config.lights, config.bake.bounces.0);
    if renderer.lights().is_empty() {
        run.report.warnings.push(
            "bake: the scene has no emissive material and the config no lights; every radiance is black (add `lights` to the config)".into(),
        );
    }
    let positions = run.probes.positions();
    let baked = bake_probes(config, &run.prepared, &renderer, &positions, &run.progress);
    for (k, v) in &baked.timings_ms {
        timings.insert(k.to_string(), *v);
    }
    let field = baked.field;

    let t = Instant::now();
    let input = run.prepared.placement_input(seed, &run.progress);
    let origins = svo::random_free_points(&input, TRACER_CHECK_RAYS, seed ^ 0x7EACE);
    let tracer = check::compare(
        &field,
        &Selection::Svo(&run.svo),
        scene,
        bvh,
        &origins,
        seed ^ 0xD1EC,
        March::HiZ,
    );
    lap(&mut timings, "tracer_check", t);

    let mut files: Vec<(String, Vec<u8>)> = vec![("lightfield.bin".into(), field.to_bytes())];
    let probes = positions.len();
    let (w, h, rad) = atlas(field.resolution, probes, |i| field.radiance[i]);
    push_image(&mut files, "radiance", w, h, &rad, auto_exposure(&rad))?;
    let (w, h, irr) = atlas(field.irradiance_resolution, probes, |i| field.irradiance[i]);
    push_image(&mut files, "irradiance", w, h, &irr, auto_exposure(&irr))?;
    files.push((
        "distance.png".into(),
        encode_png(&distance_preview(&field), "distance.png")?,
    ));
    files.push((
        "normal.png".into(),
        encode_png(&normal_preview(&field), "normal.png")?,
    ));

    let reference = match &config.reference.camera {
        Some(camera) => {
            let t = Instant::now();
            let r = &config.reference;
            let ref_renderer = Renderer::new(scene, bvh, &config.lights, r.bounces.0);
            let image = render_reference(
                &ref_renderer,
                camera,
                r.width.0,
                r.height.0,
                r.samples_per_pixel.0,
                seed,
            );
            lap(&mut timings, "reference", t);
            let exposure = auto_exposure(&image.full);
            let (w, h) = (image.width, image.height);
            push_image(&mut files, "reference", w, h, &image.full, exposure)?;
            push_image(
                &mut files,
                "reference-glossy",
                w,
                h,
                &image.glossy_indirect,
                exposure,
            )?;
            let report = ReferenceReport {
                width: image.width,
                height: image.height,
                samples_per_pixel: r.samples_per_pixel.0,
                bounces: r.bounces.0,
                mean: image.mean(),
                glossy_indirect_mean: image.glossy_mean(),
            };
            Some((report, image))
        }
        None => {
            run.report.warnings.push(
                "bake: no reference.camera in the config; the reference image is skipped".into(),
            );
            run.stale.extend(
                [
                    "reference.exr",
                    "reference.png",
                    "reference-glossy.exr",
                    "reference-glossy.png",
                ]
                .map(String::from),
            );
            None
        }
    };
    let total: f64 = timings.values().sum();
    timings.insert("total".into(), total);
    run.report.timings_ms.insert("bake".into(), total);
    run.report.bake = Some(BakeReport {
        resolution: field.resolution,
        irradiance_resolution: field.irradiance_resolution,
        probes: positions.len(),
        samples: config.bake.samples.0,
        bounces: config.bake.bounces.0,
        bytes: field.bytes(),
        area_lights: renderer.lights().area_light_count(),
        config_lights: config.lights.len(),
        tracer,
        reference: reference.as_ref().map(|(r, _)| r.clone()),
        timings_ms: timings,
    });
    run.files.extend(files);
    Ok(BakeProducts {
        field,
        reference: reference.map(|(_, image)| image),
    })
}

/// The light-field bake (McGuire et al. 2017 §3) of probes at `positions`
/// with `config.bake`, radiance path traced by `renderer` from the config's
/// seed.
///
/// Contract: deterministic for a config and positions.
pub fn bake_probes(
    config: &Config,
    prepared: &Prepared,
    renderer: &crate::render::Renderer,
    positions: &[Vec3],
    progress: &Progress,
) -> crate::lightfield::Baked {
    use crate::sampling::Sampler;
    let seed = config.seed;
    let radiance = |o: Vec3, d: Vec3, stream: u64| {
        renderer.radiance(o, d, &mut Sampler::new(seed ^ BAKE_STREAMS, stream))
    };
    crate::lightfield::bake(
        &config.bake,
        positions,
        &prepared.scene,
        &prepared.bvh,
        prepared.domain.size().length(),
        seed,
        &radiance,
        progress,
    )
}

/// The marches `render` can run (`--variant`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Variant {
    /// McGuire et al. 2017 §4.1: bi-level march, grid selection where the
    /// probes form a grid (else the SVO's).
    BiLevel,
    /// Wang et al. 2019 §4.2: Hi-Z march, SVO selection.
    HiZ,
}

impl Variant {
    /// The name in file names and the report.
    pub fn name(self) -> &'static str {
        match self {
            Variant::BiLevel => "bilevel",
            Variant::HiZ => "hiz",
        }
    }
}

/// What `render` adds to [`PlaceOptions`].
#[derive(Debug, Clone)]
pub struct RenderOptions {
    /// Variants to render, in order.
    pub variants: Vec<Variant>,
    /// Trace on the CPU twin even where a GPU adapter exists.
    pub cpu: bool,
}

/// `probeplace render`: place, bake, then render the reference's view
/// through the probes with each variant and measure it (report.render).
///
/// Contract: a config without `reference.camera` is a user error before
/// any work; without a GPU adapter the CPU twin traces and
/// `report.warnings` says so. Writes nothing unless everything succeeds.
pub fn render(
    config_path: &Path,
    options: &PlaceOptions,
    render: &RenderOptions,
) -> Result<PlaceOutcome> {
    let config = Config::load(config_path)?;
    if config.reference.camera.is_none() {
        return Err(Error::user_file(
            config_path,
            "reference.camera: render needs a camera (the image is drawn from it and measured against the reference)",
        ));
    }
    let mut run = compute_place(config, config_path, options)?;
    let baked = bake_stage(&mut run)?;
    render_stage(&mut run, &baked, render)?;
    run.finish_timings();
    run.write()
}

/// Random streams of the validation render's glossy rays.
const RENDER_STREAMS: u64 = 0x6_1055;

/// The validation renders on top of a bake ([`crate::render::probes`]):
/// adds `render_<variant>` images, `error_<variant>.png` and report.render.
pub fn render_stage(
    run: &mut PlaceRun,
    baked: &BakeProducts,
    options: &RenderOptions,
) -> Result<()> {
    use crate::gpu::{kind, twin, Context, ProbeTracer, SelectionKind};
    use crate::render::probes::{compose, error_heat_map, gbuffer, mse};
    use crate::render::Renderer;
    use crate::report::render::{RenderReport, VariantReport};
    use crate::trace::{check::padded_bounds, single::March, Lattice, Selection};

    let (Some(camera), Some(reference)) = (&run.config.reference.camera, &baked.reference) else {
        return Err(Error::Internal("render without a reference".into()));
    };
    let field = &baked.field;
    let scene = &run.prepared.scene;
    let mut timings: BTreeMap<String, f64> = BTreeMap::new();
    let t = Instant::now();
    let renderer = Renderer::new(scene, &run.prepared.bvh, &run.config.lights, 0);
    let (w, h) = (reference.width, reference.height);
    let g = gbuffer(
        &renderer,
        camera,
        w,
        h,
        1,
        &padded_bounds(&scene.bounds),
        run.config.seed ^ RENDER_STREAMS,
    );
    lap(&mut timings, "gbuffer", t);

    let t = Instant::now();
    let lattice = Lattice::from_positions(&field.positions);
    if options.variants.contains(&Variant::BiLevel) && lattice.is_none() {
        run.report.warnings.push(
            "render: the probes are not a regular grid, so bi-level selects them with the SVO (place with --method grid:… for McGuire's grid selection)".into(),
        );
    }
    let context = if options.cpu {
        None
    } else {
        Context::new()
            .map_err(|e| {
                run.report
                    .warnings
                    .push(format!("render: {e}; traced on the CPU twin"))
            })
            .ok()
    };
    let tracer = context.as_ref().and_then(|ctx| {
        ProbeTracer::new(ctx, field, Some(&run.svo), lattice.as_ref())
            .map_err(|e| {
                run.report
                    .warnings
                    .push(format!("render: {e}; traced on the CPU twin"))
            })
            .ok()
    });
    let adapter = match (&context, &tracer) {
        (Some(ctx), Some(_)) => ctx.adapter.clone(),
        _ => "cpu twin".to_string(),
    };
    lap(&mut timings, "upload", t);

    let exposure = auto_exposure(&reference.full);
    let error_scale = (4.0 * mean_luminance(&reference.glossy_indirect)) as f32;
    let rays = g.glossy.len().max(1) as f64;
    // The irradiance gather depends on the selection only: when both
    // variants select alike it runs once.
    let mut gathered: Vec<(SelectionKind, Vec<crate::gpu::Record>, Option<f64>)> = Vec::new();
    let mut variants = BTreeMap::new();
    let mut files = Vec::new();
    for variant in [Variant::BiLevel, Variant::HiZ] {
        let name = variant.name();
        if !options.variants.contains(&variant) {
            run.stale.extend([
                format!("render_{name}.exr"),
                format!("render_{name}.png"),
                format!("render_{name}-glossy.exr"),
                format!("render_{name}-glossy.png"),
                format!("error_{name}.png"),
            ]);
            continue;
        }
        let t = Instant::now();
        let (march, grid) = match variant {
            Variant::BiLevel => (March::BiLevel, lattice.as_ref()),
            Variant::HiZ => (March::HiZ, None),
        };
        let (selection, selection_kind) = match grid {
            Some(l) => (Selection::Grid(l), SelectionKind::Grid),
            None => (Selection::Svo(&run.svo), SelectionKind::Svo),
        };
        let gpu = |e: String| Error::Internal(format!("render {name}: {e}"));
        let slot = match gathered.iter().position(|(k, ..)| *k == selection_kind) {
            Some(i) => i,
            None => {
                let (irr, ms) = match &tracer {
                    Some(tr) => tr
                        .gather_irradiance(&g.irradiance, selection_kind)
                        .map_err(gpu)?,
                    None => (
                        twin::gather_irradiance(field, &selection, &g.irradiance),
                        None,
                    ),
                };
                gathered.push((selection_kind, irr, ms));
                gathered.len() - 1
            }
        };
        let (_, irradiance, gather_ms) = &gathered[slot];
        let (glossy, trace_ms) = match &tracer {
            Some(tr) => tr
                .trace_rays(&g.glossy, march, selection_kind)
                .map_err(gpu)?,
            None => (twin::trace_rays(field, &selection, &g.glossy, march), None),
        };
        let gpu_ms = trace_ms.zip(*gather_ms).map(|(a, b)| a + b);
        let image = compose(&g, irradiance, &glossy);
        let sum =
            |f: fn(&crate::gpu::Record) -> u32| glossy.iter().map(|r| f(r) as u64).sum::<u64>();
        let count = |k: u32| glossy.iter().filter(|r| r.kind == k).count() as u64;
        variants.insert(
            name.to_string(),
            VariantReport {
                march: name,
                selection: if grid.is_some() { "grid" } else { "svo" },
                mse_glossy: mse(&image.glossy_indirect, &reference.glossy_indirect),
                mse_full: mse(&image.full, &reference.full),
                glossy_indirect_mean: crate::render::reference::mean_of(&image.glossy_indirect),
                texel_fetches_per_ray: sum(|r| r.fetches) as f64 / rays,
                surfel_fetches_per_ray: (crate::trace::single::SURFEL_TEST_FETCHES as u64
                    * sum(|r| r.surfels)) as f64
                    / rays,
                probe_switches_per_ray: sum(|r| r.probes.saturating_sub(1)) as f64 / rays,
                unresolved_rays: count(kind::UNKNOWN) + count(kind::NO_PROBE),
                hits: count(kind::HIT),
                misses: count(kind::MISS),
                gpu_ms,
            },
        );
        push_image(
            &mut files,
            &format!("render_{name}"),
            w,
            h,
            &image.full,
            exposure,
        )?;
        push_image(
            &mut files,
            &format!("render_{name}-glossy"),
            w,
            h,
            &image.glossy_indirect,
            exposure,
        )?;
        let heat = error_heat_map(
            &image.glossy_indirect,
            &reference.glossy_indirect,
            w,
            h,
            error_scale,
        );
        let heat_name = format!("error_{name}.png");
        files.push((heat_name.clone(), encode_png(&heat, &heat_name)?));
        lap(&mut timings, name, t);
    }
    let total: f64 = timings.values().sum();
    timings.insert("total".into(), total);
    run.report.timings_ms.insert("render".into(), total);
    run.report.render = Some(RenderReport {
        adapter,
        width: w,
        height: h,
        glossy_rays: g.glossy.len(),
        variants,
        timings_ms: timings,
    });
    run.files.extend(files);
    Ok(())
}

/// Adds `<stem>.exr` (linear) and `<stem>.png` (at `exposure`) of the
/// `width`×`height` image `pixels` to `files`.
fn push_image(
    files: &mut Vec<(String, Vec<u8>)>,
    stem: &str,
    width: u32,
    height: u32,
    pixels: &[[f32; 3]],
    exposure: f32,
) -> Result<()> {
    let png = format!("{stem}.png");
    let image = crate::report::exr::tonemap(pixels, width, height, exposure);
    files.push((
        format!("{stem}.exr"),
        crate::report::exr::encode_rgb(width, height, pixels),
    ));
    files.push((png.clone(), encode_png(&image, &png)?));
    Ok(())
}

/// Mean luminance of `pixels`, non-finite values left out (0 for none).
pub fn mean_luminance(pixels: &[[f32; 3]]) -> f64 {
    pixels
        .iter()
        .map(|&p| crate::render::lights::luminance(Vec3::from(p)) as f64)
        .filter(|v| v.is_finite())
        .sum::<f64>()
        / pixels.len().max(1) as f64
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
