//! The `compare` job: our placements against what engines use today, on one
//! scene and camera set, measured alike (Wang et al. 2019 §5, Figs. 8–12,
//! Tables 1–2).
//!
//! The placements:
//! - **ours**: the SDF skeleton and the ball-shrinking medial axis (§3.1),
//!   each refined (§3.3);
//! - **a sweep of uniform grids** (McGuire et al. 2017), from a quarter to
//!   eight times our probe count, or the grids the user names;
//! - **a relocated grid** ([`crate::placement::relocate`]): the sweep grid
//!   nearest our count with RTXGI-style relocation and classification;
//! - **greedy voxel placement** ([`crate::placement::greedy`], Silvennoinen &
//!   Lehtinen 2017 §4.1) at our probe count.
//!
//! Every placement goes through the same stages as `render`: coverage,
//! SVO (§4.1), light-field bake (McGuire §3), and the validation render
//! from each camera, measured against one path-traced reference per camera.
//! As in the paper's comparisons, each side runs its own tracer: the grids
//! McGuire's (bi-level march, the cell's eight probes, §4.1 of McGuire et
//! al.), what engines run today; every other placement Wang's (Hi-Z march,
//! SVO selection, §4.1–4.2), which non-uniform probes need. The glossy
//! rays are the same for every placement (common random numbers), so the
//! differences in error come from the probes, not from sampling noise.

use crate::config::{CameraParams, Config, GreedyParams, GridParams, Placement, Positive};
use crate::coverage::{self, CoverageReference};
use crate::error::{Error, Result};
use crate::gpu::{kind, twin, Context, ProbeTracer, Record, SelectionKind};
use crate::lightfield::LightField;
use crate::pipeline::{self, Prepared};
use crate::placement::{self, ProbeSet};
use crate::progress::Progress;
use crate::render::probes::{box_filter, compose, error_heat_map, gbuffer, mse, GBuffer};
use crate::render::reference::render_reference;
use crate::render::{Reference, Renderer};
use crate::report::compare::{
    comparisons, performance_metric, to_csv, CameraRecord, CameraRow, CompareReport, Family,
    PlacementRow,
};
use crate::report::html::{self, Figures, PlacementFigures};
use crate::report::{self, exr};
use crate::svo::{self, Svo};
use crate::trace::{check::padded_bounds, single::March, Lattice, Selection};
use glam::Vec3;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// What the command line may override.
#[derive(Debug, Clone, Default)]
pub struct CompareOptions {
    /// Output directory instead of the config's `output`.
    pub out: Option<PathBuf>,
    /// Seed instead of the config's.
    pub seed: Option<u64>,
    /// Grids instead of the config's `compare.grids` (or the sweep).
    pub grids: Option<Vec<GridParams>>,
    /// Trace on the CPU twin even where a GPU adapter exists.
    pub cpu: bool,
    /// Show progress bars.
    pub progress: bool,
}

/// What a finished comparison produced.
#[derive(Debug)]
pub struct CompareOutcome {
    /// Directory holding `compare.json`, `compare.csv` and `report.html`.
    pub out_dir: PathBuf,
    /// `compare.json` as written.
    pub report: CompareReport,
}

/// Pixel size of each of the two placement views in the report.
const VIEW_SIZE: u32 = 320;

/// Random streams of the comparison's glossy rays (as `render`'s).
const GLOSSY_STREAMS: u64 = 0x6_1055;

/// Radius of the box filter of [`CameraRow::mse_glossy_filtered`].
const FILTER_RADIUS: u32 = 3;

/// Our methods, in report order.
const OURS: [&str; 2] = ["sdf-skeleton", "medial-axis"];

/// Runs `probeplace compare` on the config at `config_path`.
///
/// Contract: a config without any camera (`reference.camera` or
/// `compare.cameras`) is a user error before any work. On success the
/// output directory holds `compare.json`, `compare.csv` and `report.html`,
/// written atomically, the JSON last; on error nothing is written. The same
/// config and seed give the same files, timings (and `gpu_ms` on a GPU)
/// aside.
pub fn compare(config_path: &Path, options: &CompareOptions) -> Result<CompareOutcome> {
    let started = Instant::now();
    let mut config = Config::load(config_path)?;
    if let Some(seed) = options.seed {
        config.seed = seed;
    }
    let cameras: Vec<CameraParams> = config
        .reference
        .camera
        .iter()
        .chain(&config.compare.cameras)
        .copied()
        .collect();
    if cameras.is_empty() {
        return Err(Error::user_file(
            config_path,
            "reference.camera: compare needs a camera (placements are rendered from it and measured against the reference)",
        ));
    }
    let out_dir = options.out.clone().unwrap_or_else(|| config.output.clone());
    report::check_output_dir(&out_dir)?;
    let progress = Progress::new(options.progress);
    let mut timings = BTreeMap::new();
    let prepared = pipeline::prepare(&config, config_path, &progress, &mut timings)?;

    let mut warnings = prepared.scene.warnings.clone();
    let t = Instant::now();
    let views = views(&config, &prepared, &cameras);
    lap(&mut timings, "references", t);
    let context = if options.cpu {
        None
    } else {
        Context::new()
            .map_err(|e| warnings.push(format!("compare: {e}; traced on the CPU twin")))
            .ok()
    };
    let input = prepared.placement_input(config.seed, &progress);
    let coverage_reference = CoverageReference::new(
        &prepared.scene,
        &prepared.bvh,
        &prepared.sdf,
        &config.coverage,
        config.seed,
        &progress,
    );
    let bake_renderer = Renderer::new(
        &prepared.scene,
        &prepared.bvh,
        &config.lights,
        config.bake.bounces.0,
    );
    let mut bench = Bench {
        config: &config,
        prepared: &prepared,
        coverage: &coverage_reference,
        renderer: &bake_renderer,
        views: &views,
        context: context.as_ref(),
        progress: &progress,
        gpu_used: true,
        warnings: &mut warnings,
    };

    let mut rows = Vec::new();
    let mut figures = Vec::new();
    let mut push = |(row, fig): (PlacementRow, PlacementFigures)| {
        rows.push(row);
        figures.push(fig);
    };

    // Ours, refined whatever the config says (§3.3).
    let mut ours_count = 0;
    for method in OURS {
        let t = Instant::now();
        let mut c = config.clone();
        c.placement = Placement::parse_cli(method, &config.placement)?;
        c.refine.enabled = true;
        let mut stage_times = BTreeMap::new();
        let (probes, refined) = pipeline::placement_stage(
            &c,
            config_path,
            &input,
            &coverage_reference,
            &mut stage_times,
        )?;
        let mut stats: BTreeMap<String, f64> = stats_of(&probes);
        if let Some((report, _)) = &refined {
            stats.insert("refine_coverage_final".into(), report.coverage_final);
        }
        if ours_count == 0 || method == config.placement.name() {
            ours_count = probes.probes.len();
        }
        push(bench.measure(method, Family::Ours, &probes, stats)?);
        lap(&mut timings, method, t);
    }

    // The sweep of uniform grids.
    let grids = match (&options.grids, config.compare.grids.is_empty()) {
        (Some(g), _) => g.clone(),
        (None, false) => config.compare.grids.clone(),
        (None, true) => grid_sweep(&prepared.domain, ours_count),
    };
    let mut grid_rows: Vec<(usize, GridParams)> = Vec::new();
    for g in &grids {
        let t = Instant::now();
        let method = Placement::Grid(*g);
        let probes = placement::place(&method, &input)?;
        let name = method.name();
        grid_rows.push((probes.probes.len(), *g));
        push(bench.measure(&name, Family::Grid, &probes, BTreeMap::new())?);
        lap(&mut timings, &name, t);
    }

    // The competitors: what engines ship (the grid nearest our count,
    // relocated and classified), and Silvennoinen & Lehtinen's greedy
    // placement with as many probes as ours.
    let mut competitors = Vec::new();
    if let Some((_, g)) = grid_rows
        .iter()
        .min_by_key(|(n, _)| (n.abs_diff(ours_count), usize::MAX - n))
    {
        competitors.push((Placement::Relocated(*g), Family::Relocated));
    }
    let spacing = placement::greedy::spacing_for_count(&prepared.domain, ours_count.max(1));
    competitors.push((
        Placement::Greedy(GreedyParams {
            spacing: Positive(spacing),
        }),
        Family::Greedy,
    ));
    for (method, family) in competitors {
        let t = Instant::now();
        let name = method.name();
        match placement::place(&method, &input) {
            Ok(probes) => {
                let stats = stats_of(&probes);
                push(bench.measure(&name, family, &probes, stats)?);
            }
            // Every probe switched off, or no candidate voxel: a finding,
            // not a failure.
            Err(Error::User(e)) => bench.warnings.push(format!("compare: {name}: {e}")),
            Err(e) => return Err(e),
        }
        lap(&mut timings, &name, t);
    }
    let gpu_used = bench.gpu_used;

    let adapter = match (&context, gpu_used) {
        (Some(ctx), true) => ctx.adapter.clone(),
        _ => "cpu twin".to_string(),
    };
    let metric = performance_metric(&adapter, &rows);
    let comparisons = comparisons(&rows, metric);
    timings.insert("total".into(), started.elapsed().as_secs_f64() * 1e3);
    let report = CompareReport {
        format: "probeplace-compare",
        version: 1,
        config: config_path.display().to_string(),
        scene: config.scene.display().to_string(),
        seed: config.seed,
        adapter,
        quality_metric: "mse_glossy_filtered",
        performance_metric: metric,
        width: config.reference.width.0,
        height: config.reference.height.0,
        glossy_rays: config.compare.glossy_rays.0,
        cameras: views
            .iter()
            .map(|v| CameraRecord {
                position: v.camera.position.0,
                look_at: v.camera.look_at.0,
                fov_degrees: v.camera.fov_degrees,
                reference_glossy_mean: v.reference.glossy_mean(),
            })
            .collect(),
        placements: rows,
        comparisons,
        warnings,
        timings_ms: timings,
    };
    let figures = Figures {
        references: views
            .iter()
            .map(|v| png(&v.reference.full, v, "reference"))
            .collect::<Result<_>>()?,
        placements: figures,
    };
    let json = report::to_json(&report)?;
    let csv = to_csv(&report);
    let page = html::page(&report, &figures);
    report::prepare_output_dir(&out_dir)?;
    report::write_atomic(&out_dir.join("compare.csv"), csv.as_bytes())?;
    report::write_atomic(&out_dir.join("report.html"), page.as_bytes())?;
    report::write_atomic(&out_dir.join("compare.json"), &json)?;
    Ok(CompareOutcome { out_dir, report })
}

/// Parses `--grids`: comma-separated `NxMxK`, e.g. `2x2x2,4x2x4`.
///
/// Contract: at least one grid; a bad entry is a user error naming it.
/// The first grid of [`placement::cubic_grid_sweep`] (up to `max_cells`
/// cells along the domain's longest axis, by probe count, and at most
/// `max_probes` probes when given) whose coverage, by `reference`, reaches
/// `coverage`, with that coverage; `None` when no grid of the sweep does. The "smallest grid at the same coverage" that
/// our placements must beat (Wang et al. 2019 §5, Table 1).
pub fn smallest_grid_reaching(
    prepared: &Prepared,
    reference: &CoverageReference,
    coverage: f64,
    max_cells: u32,
    max_probes: Option<usize>,
    progress: &Progress,
) -> Option<(GridParams, f64)> {
    placement::cubic_grid_sweep(prepared.domain.size(), max_cells)
        .into_iter()
        .take_while(|g| {
            max_probes.is_none_or(|n| (g.cells.0 .0 * g.cells.1 .0 * g.cells.2 .0) as usize <= n)
        })
        .find_map(|g| {
            let positions: Vec<glam::Vec3> = placement::grid(&g, &prepared.domain)
                .iter()
                .map(|p| p.position)
                .collect();
            let c = reference
                .evaluate(&prepared.bvh, &positions, progress)
                .coverage;
            (c >= coverage).then_some((g, c))
        })
}

pub fn parse_grids(text: &str) -> Result<Vec<GridParams>> {
    let grids = text
        .split(',')
        .map(str::trim)
        .filter(|g| !g.is_empty())
        .map(|g| {
            let bad = |why: String| Error::User(format!("--grids {text}: `{g}`: {why}"));
            let cells: Vec<u32> = g
                .split('x')
                .map(|n| n.parse::<u32>())
                .collect::<std::result::Result<_, _>>()
                .map_err(|_| bad("expected NxMxK with whole numbers, e.g. 4x2x4".into()))?;
            let cells: [u32; 3] = cells
                .try_into()
                .map_err(|_| bad("expected three sizes, NxMxK, e.g. 4x2x4".into()))?;
            GridParams::new(cells).map_err(bad)
        })
        .collect::<Result<Vec<_>>>()?;
    if grids.is_empty() {
        return Err(Error::User(format!(
            "--grids {text}: no grid given; expected e.g. 2x2x2,4x2x4"
        )));
    }
    Ok(grids)
}

/// Uniform grids from a quarter to eight times `count` probes, in steps of
/// 2× (√2 around `count`, where equal count is matched), each with cells
/// as near cubic as the domain allows; distinct and by probe count.
///
/// Contract: at least one grid; every grid within the config's limits.
pub fn grid_sweep(domain: &crate::scene::Bounds, count: usize) -> Vec<GridParams> {
    let size = domain.size().max(Vec3::splat(1e-6));
    let volume = (size.x * size.y * size.z) as f64;
    let factors = [
        0.25,
        0.5,
        std::f64::consts::FRAC_1_SQRT_2,
        1.0,
        std::f64::consts::SQRT_2,
        2.0,
        4.0,
        8.0,
    ];
    let mut out: Vec<(u64, GridParams)> = Vec::new();
    for f in factors {
        let n = (count.max(1) as f64 * f).max(1.0);
        let spacing = (volume / n).cbrt() as f32;
        let cells = (size / spacing).round().max(Vec3::ONE);
        let Ok(g) = GridParams::new([cells.x as u32, cells.y as u32, cells.z as u32]) else {
            continue;
        };
        let probes = g.cells.0 .0 as u64 * g.cells.1 .0 as u64 * g.cells.2 .0 as u64;
        if !out.iter().any(|(_, o)| *o == g) {
            out.push((probes, g));
        }
    }
    out.sort_by_key(|(n, g)| (*n, g.cells.0 .0, g.cells.1 .0, g.cells.2 .0));
    out.into_iter().map(|(_, g)| g).collect()
}

/// One camera's fixed inputs: the reference, the G-buffer and the scales.
struct View {
    camera: CameraParams,
    reference: Reference,
    /// The reference's glossy indirect image, box filtered.
    filtered_glossy: Vec<[f32; 3]>,
    gbuffer: GBuffer,
    exposure: f32,
    error_scale: f32,
}

/// The reference and the G-buffer of every camera. Camera 0's reference
/// is the one `bake` renders (same seed).
fn views(config: &Config, prepared: &Prepared, cameras: &[CameraParams]) -> Vec<View> {
    let r = &config.reference;
    let (scene, bvh) = (&prepared.scene, &prepared.bvh);
    let reference_renderer = Renderer::new(scene, bvh, &config.lights, r.bounces.0);
    let direct_renderer = Renderer::new(scene, bvh, &config.lights, 0);
    let bounds = padded_bounds(&scene.bounds);
    cameras
        .iter()
        .enumerate()
        .map(|(i, camera)| {
            let seed = config.seed ^ (i as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15);
            let reference = render_reference(
                &reference_renderer,
                camera,
                r.width.0,
                r.height.0,
                r.samples_per_pixel.0,
                seed,
            );
            let gbuffer = gbuffer(
                &direct_renderer,
                camera,
                r.width.0,
                r.height.0,
                config.compare.glossy_rays.0,
                &bounds,
                seed ^ GLOSSY_STREAMS,
            );
            View {
                camera: *camera,
                filtered_glossy: box_filter(
                    &reference.glossy_indirect,
                    reference.width,
                    reference.height,
                    FILTER_RADIUS,
                ),
                exposure: pipeline::auto_exposure(&reference.full),
                error_scale: (4.0 * pipeline::mean_luminance(&reference.glossy_indirect)) as f32,
                reference,
                gbuffer,
            }
        })
        .collect()
}

/// What every placement is measured with.
struct Bench<'a> {
    config: &'a Config,
    prepared: &'a Prepared,
    coverage: &'a CoverageReference,
    renderer: &'a Renderer<'a>,
    views: &'a [View],
    context: Option<&'a Context>,
    progress: &'a Progress,
    /// Whether every placement so far was traced on the GPU.
    gpu_used: bool,
    warnings: &'a mut Vec<String>,
}

impl Bench<'_> {
    /// Coverage, SVO, bake and the render from every camera of `probes`.
    fn measure(
        &mut self,
        name: &str,
        family: Family,
        probes: &ProbeSet,
        stats: BTreeMap<String, f64>,
    ) -> Result<(PlacementRow, PlacementFigures)> {
        let Prepared {
            scene,
            domain,
            bvh,
            sdf,
            ..
        } = self.prepared;
        let positions = probes.positions();
        let (cov, holes) = self
            .coverage
            .evaluate_with_holes(bvh, &positions, self.progress);
        let health = coverage::probe_health(sdf, domain, &positions);
        let views_png = pipeline::placement_views(scene, domain, &positions, &holes, VIEW_SIZE);
        let input = self
            .prepared
            .placement_input(self.config.seed, self.progress);
        let mut tracer_name = "none";
        let (cameras, renders, errors, probe_bytes, svo_bytes) = if positions.is_empty() {
            self.warnings.push(format!(
                "compare: {name} placed no probes; its renders are black"
            ));
            let (rows, renders, errors) = self.measure_empty()?;
            (rows, renders, errors, 0, 0)
        } else {
            let baked_svo = svo::bake(&self.config.svo, probes, &input)?;
            let field = pipeline::bake_probes(
                self.config,
                self.prepared,
                self.renderer,
                &positions,
                self.progress,
            )
            .field;
            // Grids are traced as engines trace them today (McGuire et al.
            // 2017: bi-level march, the cell's eight probes); the rest with
            // Wang et al. 2019's Hi-Z march and SVO selection.
            let lattice = match family {
                Family::Grid => Lattice::from_positions(&field.positions),
                _ => None,
            };
            tracer_name = if lattice.is_some() {
                "bilevel+grid"
            } else {
                "hiz+svo"
            };
            let (rows, renders, errors) =
                self.render(name, &field, &baked_svo.svo, lattice.as_ref())?;
            (
                rows,
                renders,
                errors,
                field.bytes() as u64,
                baked_svo.svo.bytes(),
            )
        };
        let mean = |f: fn(&CameraRow) -> f64| {
            cameras.iter().map(f).sum::<f64>() / cameras.len().max(1) as f64
        };
        let row = PlacementRow {
            name: name.to_string(),
            family,
            tracer: tracer_name,
            probes: positions.len(),
            coverage: cov.coverage,
            probes_in_solid: health.probes_in_solid,
            probe_bytes,
            svo_bytes,
            mse_glossy: mean(|c| c.mse_glossy),
            mse_glossy_filtered: mean(|c| c.mse_glossy_filtered),
            texel_fetches_per_ray: mean(|c| c.texel_fetches_per_ray),
            gpu_ms: cameras.iter().map(|c| c.gpu_ms).sum(),
            cameras,
            stats,
        };
        let figures = PlacementFigures {
            views: encode(&views_png)?,
            renders,
            errors,
        };
        Ok((row, figures))
    }

    /// The renders of `field` from every camera, their rows and PNGs.
    #[allow(clippy::type_complexity)]
    fn render(
        &mut self,
        name: &str,
        field: &LightField,
        svo: &Svo,
        lattice: Option<&Lattice>,
    ) -> Result<(Vec<CameraRow>, Vec<Vec<u8>>, Vec<Vec<u8>>)> {
        let tracer = self.context.and_then(|ctx| {
            ProbeTracer::new(ctx, field, Some(svo), lattice)
                .map_err(|e| {
                    self.warnings
                        .push(format!("compare: {name}: {e}; traced on the CPU twin"))
                })
                .ok()
        });
        if tracer.is_none() {
            self.gpu_used = false;
        }
        let (selection, kind, march) = match lattice {
            Some(l) => (Selection::Grid(l), SelectionKind::Grid, March::BiLevel),
            None => (Selection::Svo(svo), SelectionKind::Svo, March::HiZ),
        };
        let gpu = |e: String| Error::Internal(format!("compare {name}: {e}"));
        let (mut rows, mut renders, mut errors) = (Vec::new(), Vec::new(), Vec::new());
        for view in self.views {
            let g = &view.gbuffer;
            let (glossy, trace_ms) = match &tracer {
                Some(tr) => tr.trace_rays(&g.glossy, march, kind).map_err(gpu)?,
                None => (twin::trace_rays(field, &selection, &g.glossy, march), None),
            };
            let (irradiance, gather_ms) = match &tracer {
                Some(tr) => tr.gather_irradiance(&g.irradiance, kind).map_err(gpu)?,
                None => (
                    twin::gather_irradiance(field, &selection, &g.irradiance),
                    None,
                ),
            };
            let image = compose(g, &irradiance, &glossy);
            rows.push(camera_row(
                view,
                &image,
                &glossy,
                trace_ms.zip(gather_ms).map(|(a, b)| a + b),
            ));
            renders.push(png(&image.full, view, "render")?);
            errors.push(heat(&image.glossy_indirect, view)?);
        }
        Ok((rows, renders, errors))
    }

    /// Rows and images of a placement without probes: no indirect light.
    #[allow(clippy::type_complexity)]
    fn measure_empty(&self) -> Result<(Vec<CameraRow>, Vec<Vec<u8>>, Vec<Vec<u8>>)> {
        let (mut rows, mut renders, mut errors) = (Vec::new(), Vec::new(), Vec::new());
        for view in self.views {
            let g = &view.gbuffer;
            let dark = |n: usize| {
                vec![
                    Record {
                        kind: kind::NO_PROBE,
                        ..bytemuck::Zeroable::zeroed()
                    };
                    n
                ]
            };
            let glossy = dark(g.glossy.len());
            let image = compose(g, &dark(g.irradiance.len()), &glossy);
            rows.push(camera_row(view, &image, &glossy, None));
            renders.push(png(&image.full, view, "render")?);
            errors.push(heat(&image.glossy_indirect, view)?);
        }
        Ok((rows, renders, errors))
    }
}

/// The figures of one render against its view's reference.
fn camera_row(
    view: &View,
    image: &crate::render::probes::ProbeImage,
    glossy: &[Record],
    gpu_ms: Option<f64>,
) -> CameraRow {
    let rays = glossy.len().max(1) as f64;
    let unresolved = glossy
        .iter()
        .filter(|r| r.kind == kind::UNKNOWN || r.kind == kind::NO_PROBE)
        .count();
    let (w, h) = (view.reference.width, view.reference.height);
    CameraRow {
        mse_glossy: mse(&image.glossy_indirect, &view.reference.glossy_indirect),
        mse_glossy_filtered: mse(
            &box_filter(&image.glossy_indirect, w, h, FILTER_RADIUS),
            &view.filtered_glossy,
        ),
        mse_full: mse(&image.full, &view.reference.full),
        texel_fetches_per_ray: glossy.iter().map(|r| r.fetches as u64).sum::<u64>() as f64 / rays,
        unresolved_fraction: unresolved as f64 / rays,
        gpu_ms,
    }
}

/// `ProbeSet::stats` and `params` as report numbers.
fn stats_of(probes: &ProbeSet) -> BTreeMap<String, f64> {
    probes
        .stats
        .iter()
        .map(|(k, v)| (k.to_string(), *v as f64))
        .chain(probes.params.iter().map(|(k, v)| (k.to_string(), *v)))
        .collect()
}

/// `pixels` tone mapped at the view's exposure, as PNG.
fn png(pixels: &[[f32; 3]], view: &View, what: &str) -> Result<Vec<u8>> {
    let (w, h) = (view.reference.width, view.reference.height);
    pipeline::encode_png(&exr::tonemap(pixels, w, h, view.exposure), what)
}

/// The glossy error heat map against the view's reference, as PNG.
fn heat(glossy: &[[f32; 3]], view: &View) -> Result<Vec<u8>> {
    let r = &view.reference;
    let map = error_heat_map(
        glossy,
        &r.glossy_indirect,
        r.width,
        r.height,
        view.error_scale,
    );
    pipeline::encode_png(&map, "error map")
}

fn encode(image: &image::RgbImage) -> Result<Vec<u8>> {
    pipeline::encode_png(image, "placement views")
}

fn lap(timings: &mut BTreeMap<String, f64>, name: &str, since: Instant) {
    timings.insert(name.to_string(), since.elapsed().as_secs_f64() * 1e3);
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Bounds;

    fn count(g: &GridParams) -> u32 {
        g.cells.0 .0 * g.cells.1 .0 * g.cells.2 .0
    }

    #[test]
    fn sweep_spans_a_quarter_to_eight_times_the_count_in_order() {
        let domain = Bounds {
            min: Vec3::ZERO,
            max: Vec3::new(24.0, 8.0, 14.0),
        };
        let sweep = grid_sweep(&domain, 20);
        let counts: Vec<u32> = sweep.iter().map(count).collect();
        assert!(counts.windows(2).all(|w| w[0] <= w[1]), "{counts:?}");
        assert!(counts[0] <= 10, "{counts:?}");
        assert!(*counts.last().unwrap() >= 100, "{counts:?}");
        // Rounding cells to whole numbers moves counts, but one grid stays
        // within a factor of two of the target.
        assert!(counts.iter().any(|&c| (10..=40).contains(&c)), "{counts:?}");
        // Cells stay near cubic: the long axis gets the most cells.
        let last = sweep.last().unwrap();
        assert!(last.cells.0 .0 > last.cells.1 .0);
    }

    #[test]
    fn sweep_of_a_tiny_count_starts_at_one_probe() {
        let domain = Bounds {
            min: Vec3::ZERO,
            max: Vec3::ONE,
        };
        let sweep = grid_sweep(&domain, 1);
        assert_eq!(count(&sweep[0]), 1);
        assert!(sweep.iter().all(|g| count(g) >= 1));
    }
}
