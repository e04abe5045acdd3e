//! The `place` job: config → scene → BVH → SDF → placement → coverage
//! reference → refinement → coverage → SVO → outputs. Each stage is a function from the previous stage's typed output
//! to its own; this module only sequences them, times them, and writes the
//! results once everything has succeeded.

use crate::config::{Config, Domain, Placement};
use crate::coverage::{self, CoverageReference};
use crate::error::{Error, Result};
use crate::placement::{self, PlacementInput, ProbeSet};
use crate::progress::Progress;
use crate::refine;
use crate::report::{self, preview, ProbesFile, Report};
use crate::scene::raycast::SceneBvh;
use crate::scene::{self, Bounds, Scene};
use crate::sdf::{self, Sdf};
use crate::svo::{self, Svo};
use glam::Vec3;
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
    mut config: Config,
    config_path: &Path,
    options: &PlaceOptions,
) -> Result<PlaceOutcome> {
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
    } = &prepared;

    let input = prepared.placement_input(config.seed, &progress);
    let t = Instant::now();
    let probes = placement::place(&config.placement, &input).map_err(|e| e.in_file(config_path))?;
    lap(&mut timings, "placement", t);

    let t = Instant::now();
    let reference =
        CoverageReference::new(scene, bvh, sdf, &config.coverage, config.seed, &progress);
    lap(&mut timings, "coverage_reference", t);

    let (probes, refined) = if config.refine.enabled {
        let t = Instant::now();
        let out = refine::refine(&config.refine, probes, &input, &reference)
            .map_err(|e| e.in_file(config_path))?;
        lap(&mut timings, "refine", t);
        (out.probes, Some((out.report, out.atlas_image)))
    } else {
        (probes, None)
    };

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
    timings.insert("total".into(), t_start.elapsed().as_secs_f64() * 1e3);
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
    let atlas_png = match refined {
        Some((refine_report, image)) => {
            let target = config.refine.coverage_target.0 as f64;
            if config.refine.fill && refine_report.coverage_final < target {
                report.warnings.push(format!(
                    "refine: coverage {:.2}% is short of the target {:.2}%: no position at least {:.3} from every surface sees the rest; lower refine.min_clearance (or the placement's threshold) to reach it",
                    100.0 * refine_report.coverage_final,
                    100.0 * target,
                    refine_report.params["min_clearance"]
                ));
            }
            report.refine = Some(refine_report);
            Some(encode_png(&image, "atlas.png")?)
        }
        None => None,
    };
    let report_json = report::to_json(&report)?;

    report::prepare_output_dir(&out_dir)?;
    report::write_atomic(&out_dir.join("probes.json"), &probes_json)?;
    report::write_atomic(&out_dir.join("svo.bin"), &svo_bin)?;
    report::write_atomic(&out_dir.join("placement.png"), &png)?;
    let atlas_path = out_dir.join("atlas.png");
    match &atlas_png {
        Some(bytes) => report::write_atomic(&atlas_path, bytes)?,
        // An atlas from an earlier refined run would no longer match.
        None if atlas_path.exists() => {
            std::fs::remove_file(&atlas_path).map_err(|e| Error::io(&atlas_path, e))?
        }
        None => {}
    }
    report::write_atomic(&out_dir.join("report.json"), &report_json)?;
    Ok(PlaceOutcome { out_dir, report })
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
    let sdf = sdf::build(
        &scene,
        &bvh,
        &domain,
        config.voxel_size.0,
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
    })
}

/// Records the milliseconds since `since` as stage `name`.
fn lap(timings: &mut BTreeMap<String, f64>, name: &str, since: Instant) {
    timings.insert(name.to_string(), since.elapsed().as_secs_f64() * 1e3);
}

/// The domain box in world space: the scene bounds, or the config's box,
/// which must overlap the scene.
pub fn resolve_domain(domain: &Domain, scene: &Scene) -> Result<Bounds> {
    match domain {
        Domain::Auto => Ok(scene.bounds),
        Domain::Box(b) => {
            let d = Bounds {
                min: Vec3::from_array(b.min),
                max: Vec3::from_array(b.max),
            };
            let overlap =
                d.min.cmplt(scene.bounds.max).all() && d.max.cmpgt(scene.bounds.min).all();
            if !overlap {
                return Err(Error::User(format!(
                    "domain: box {:?}..{:?} does not overlap the scene bounds {:?}..{:?}",
                    b.min,
                    b.max,
                    scene.bounds.min.to_array(),
                    scene.bounds.max.to_array()
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
    let colors: Vec<[f32; 3]> = scene
        .material_ids
        .iter()
        .map(|&m| scene.materials[m as usize].diffuse)
        .collect();
    let positions = probes.positions();
    let image = preview::render_preview(
        &preview::PreviewInput {
            triangles: &scene.triangles,
            colors: &colors,
            probes: &positions,
            holes,
            bounds_min: domain.min,
            bounds_max: domain.max,
        },
        PREVIEW_VIEW_SIZE,
    );
    encode_png(&image, "placement.png")
}

/// PNG bytes of `image`, which will be written as `name`.
fn encode_png(image: &image::RgbImage, name: &str) -> Result<Vec<u8>> {
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
            s.origin.to_array(),
            s.max_probes,
            s.distinct_lists(),
            s.leaves_without_visible_probe
        )
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
    Ok(Inspection { path: file, svo })
}
