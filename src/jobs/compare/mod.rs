//! The `compare` job: our placements against what engines use today, on one
//! scene and camera set, measured alike (Wang et al. 2019 §5, Figs. 8–12,
//! Tables 1–2).
//!
//! The placements:
//! - **ours**: the SDF skeleton and the ball-shrinking medial axis (§3.1),
//!   each refined (§3.3);
//! - **a sweep of uniform grids** (McGuire et al. 2017), from a quarter to
//!   four times our probe count, or the grids the user names;
//! - **a relocated grid** ([`crate::placement::relocate`]): the sweep grid
//!   nearest our count with RTXGI-style relocation and classification;
//! - **greedy voxel placement** ([`crate::placement::greedy`], Silvennoinen &
//!   Lehtinen 2017 §4.1) at our probe count.
//!
//! - **an adaptive baseline** ([`crate::placement::adaptive`], Unity's
//!   Adaptive Probe Volumes as documented) at the minimum spacing whose
//!   count is nearest ours.
//!
//! Every placement goes through the same stages as `render`: coverage,
//! SVO (§4.1), light-field bake (McGuire §3), and the validation render
//! from every view, measured against one path-traced reference per view.
//! The views are the config's cameras and `compare.views` more chosen from
//! the scene alone ([`crate::render::views`]), before any placement exists.
//!
//! **Placement apart from tracer.** Every placement is traced with Wang's
//! tracer (Hi-Z march, SVO selection, §4.1–4.2); the grids are traced a
//! second time with McGuire's (bi-level march, the cell's eight probes,
//! §4.1 of McGuire et al.), what engines run today. A ratio against a grid
//! on the same tracer measures placement alone; one against the grid on
//! McGuire's tracer measures what a user switching would get. Unresolved
//! rays fall back alike in both (the last probe's radiance at the ray's
//! end, [`crate::trace::RayOutcome::lookup`]), and their share is reported.
//!
//! **Intervals.** The glossy rays are the same for every placement (common
//! random numbers), so errors are paired pixel for pixel; every ratio
//! carries a 95% two-stage paired-bootstrap interval over views and pixel
//! blocks ([`crate::stats::paired_ratio_over_views`]), and is a win only
//! when the interval excludes 1.

mod diffuse;
mod placing;

use super::bake;
use super::outcome::Outcome;
use super::run::{Job, RunOptions};
use crate::config::{CameraParams, Config, GridParams, Materials, Placement};
use crate::encode::png::encode_png;
use crate::error::{Error, Result};
use crate::gpu::{Context, SelectionKind};
use crate::lightfield::LightField;
use crate::page::html::{self, Figures, PlacementFigures};
use crate::page::view3d;
use crate::placement::grid::nearest_grid;
use crate::placement::method::Role;
use crate::placement::registry::METHODS;
use crate::placement::{self, ProbeSet};
use crate::report;
use crate::report::compare::{
    comparisons, performance_metric, to_csv, CameraRecord, CameraRow, CompareReport, Family,
    PlacementRow, TRACER_BILEVEL, TRACER_HIZ,
};
use crate::stages::bake::Work;
use crate::stages::validate::{self, Blocks, Tracer, ValidationView};
use crate::stages::{self, Prepared};
use crate::svo::Svo;
use crate::trace::{single::March, Lattice};
use glam::Vec3;
use placing::{candidate_of, reuse, Candidate, Over};

/// Pixel size of each of the two placement views in the report.
const VIEW_SIZE: u32 = 320;

/// Views whose renders and error maps the page shows for each headline
/// placement (ours, the equal-count grid, the competitors); every view is
/// measured, and the figures of the others are left out to keep the page
/// small.
const FIGURE_VIEWS: usize = 1;

/// How many work limits ([`crate::limits`]) the sum of the grids' bakes,
/// and the sum of the views' references, may each take; each bake and
/// each reference alone is bounded by one.
const COMPARE_WORK_FACTOR: f64 = 4.0;

/// Our methods, in report order: those of the registry whose role is
/// [`Role::Ours`](crate::placement::Role::Ours), in its order.
fn ours() -> impl Iterator<Item = &'static str> {
    placement::METHODS
        .iter()
        .filter(|m| m.role == placement::Role::Ours)
        .map(|m| m.word)
}

/// Runs `probeplace compare`.
///
/// Contract: a config without any camera (`reference.camera` or
/// `compare.cameras`) is a user error before any work. On success the
/// output directory holds `compare.json`, `compare.csv` and `report.html`
/// (and, with `--from DIR`, the files reused from there), committed as one
/// set; on error nothing changes. The same config and seed give the same
/// files, timings (and `gpu_ms` on a GPU) aside.
pub fn compare(options: &RunOptions) -> Result<Outcome> {
    let mut job = Job::new(options)?;
    let benchmarks = options.benchmarks;
    let cameras: Vec<CameraParams> = job
        .config
        .reference
        .camera
        .iter()
        .chain(&job.config.compare.cameras)
        .copied()
        .collect();
    // Grids given by name are checked before any work; a sweep once our
    // count is known.
    let named: Vec<GridParams> = options
        .grids
        .clone()
        .unwrap_or_else(|| job.config.compare.grids.clone());
    if benchmarks.glossy() {
        check_grids(&job.config, &named).map_err(|e| job.config_error(e))?;
    }
    let chosen = job.config.compare.views.0 as usize;
    if cameras.is_empty() && chosen == 0 {
        return Err(job.config_error(Error::User(
            "compare.views: compare needs a view: `reference.camera`, `compare.cameras` or `compare.views` above 0 (placements are rendered from each and measured against its reference)".into(),
        )));
    }
    // One reference alone is bounded as `bake`'s is; the views' together
    // may take the comparison's budget.
    if benchmarks.glossy() {
        validate::check_reference(&job.config, 1, 1.0).map_err(|e| job.config_error(e))?;
        validate::check_reference(&job.config, cameras.len() + chosen, COMPARE_WORK_FACTOR)
            .map_err(|e| job.config_error(e))?;
    }
    // The receivers' references, and the SH of a thousand probes (more
    // than the placements of a comparison usually hold together).
    if benchmarks.diffuse() {
        stages::diffuse::check(&job.config, 1000, COMPARE_WORK_FACTOR)
            .map_err(|e| job.config_error(e))?;
    }
    let mut prepared = job.prepare()?;
    // Again with the lights the scene file brought, which cast shadow rays
    // as the config's do.
    if !prepared.scene.lights.is_empty() {
        let lit = stages::bake::lit_by_scene(&job.config, &prepared.scene);
        if benchmarks.glossy() {
            validate::check_reference(&lit, cameras.len() + chosen, COMPARE_WORK_FACTOR)
                .map_err(|e| job.config_error(e))?;
        }
        if benchmarks.diffuse() {
            stages::diffuse::check(&lit, 1000, COMPARE_WORK_FACTOR)
                .map_err(|e| job.config_error(e))?;
        }
    }
    let mut warnings = prepared.scene.warnings.clone();
    let coverage = prepared.coverage_reference(
        &job.config.coverage,
        crate::coverage::Stream::Validation,
        job.config.seed,
        &job.progress,
    );
    // Ours always refine: a top-up (`min_probes`) they cannot make is
    // refused now, as `place` refuses it, not once the views and their
    // references are made.
    if let Some(min) = job.config.min_probes {
        stages::place::check_min_probes(&job.config, &prepared, &coverage, min.0 as usize)
            .map_err(|e| job.config_error(e))?;
    }
    let mut cameras: Vec<(CameraParams, bool)> = cameras.into_iter().map(|c| (c, false)).collect();
    let picked = job.watch.time("views", || {
        crate::render::views::choose_views(
            &prepared.scene,
            &prepared.bvh,
            &prepared.sdf,
            &prepared.domain,
            &coverage,
            crate::render::views::Request {
                count: chosen,
                fov_degrees: cameras.first().map_or(60.0, |c| c.0.fov_degrees),
                seed: job.config.seed,
            },
        )
    });
    if picked.len() < chosen {
        warnings.push(format!(
            "compare.views: {} of {chosen} views found (free space over a floor, looking at coverable surface)",
            picked.len()
        ));
    }
    cameras.extend(picked.into_iter().map(|v| (v.camera, true)));
    if cameras.is_empty() {
        return Err(job.config_error(Error::User(
            "compare.views: no view qualifies (no free space over a floor sees coverable surface); give `reference.camera` or `compare.cameras`".into(),
        )));
    }
    // Ours on the scene's own materials: what the diffuse benchmark
    // measures, and the glossy one too when its materials are the scene's.
    let scene_config = job.config.clone();
    let own = Over {
        config: &scene_config,
        prepared: &prepared,
        coverage: &coverage,
        progress: job.progress,
    };
    // Ours are placed once, on the scene's own materials (the diffuse step
    // follows the scene's light, as a user's run does), and measured by
    // both benchmarks.
    let ours = place_ours(&mut job, &own)?;
    // The diffuse benchmark: the space the config's cameras reach (chosen
    // views are not seeds: they are drawn from the free voxels, which keep
    // to that space when the config restricts placement to it), the
    // receivers the views see, and every placement's SH blended there.
    let diffuse = match (benchmarks.diffuse(), &ours) {
        (true, (placed, _)) => {
            let given: Vec<CameraParams> = cameras.iter().filter(|c| !c.1).map(|c| c.0).collect();
            let bench = job.watch.time("diffuse reference", || {
                let hits: Vec<crate::render::probes::GBuffer> = cameras
                    .iter()
                    .enumerate()
                    .map(|(i, c)| stages::diffuse::view_hits(&job.config, own.prepared, &c.0, i))
                    .collect();
                let hits: Vec<&crate::render::probes::GBuffer> = hits.iter().collect();
                stages::diffuse::bench(&job.config, own.prepared, &hits, &given)
            });
            match bench {
                Some(bench) => {
                    let lit = job.watch.time("diffuse figures", || {
                        stages::diffuse::lit_view(
                            &job.config,
                            own.prepared,
                            &cameras[0].0,
                            0,
                            LIT_VIEW_RAYS,
                        )
                    });
                    let sets: Vec<(&'static str, &ProbeSet)> =
                        placed.iter().map(|(m, c, _)| (*m, &c.probes)).collect();
                    let named = (options.grids.is_some() || !job.config.compare.grids.is_empty())
                        .then_some(named.as_slice());
                    Some(diffuse::run(
                        &mut job,
                        &own,
                        &bench,
                        &sets,
                        named,
                        Some(&lit),
                    )?)
                }
                None => None,
            }
        }
        _ => None,
    };
    if let Some(d) = &diffuse {
        warnings.extend(d.warnings.iter().cloned());
    }
    if !benchmarks.glossy() {
        let context = None;
        return write(
            job,
            Glossy::none(&prepared, warnings),
            diffuse,
            &[],
            &cameras,
            context,
        );
    }
    // The glossy benchmark, on `compare.materials`. Its grids, and ours
    // again at the count of the one nearest ours, placed first, on the
    // scene's own materials as ours are.
    let (ours, ours_count) = ours;
    let (grids, sweep) = grid_choice(
        &job.config,
        &prepared.domain,
        options.grids.as_ref(),
        ours_count,
    );
    let ours_at = match nearest_by_cells(&grids, ours_count).map(|g| g.probes()) {
        Some(n) if n != ours_count => {
            let method = ours_default(&job.config.placement);
            let t = std::time::Instant::now();
            // An extra row: a stage that cannot take it (refinement's
            // work at that count) is a finding, not a reason to lose
            // the comparison.
            let placed = match own.refined(&job, method, Some(n)) {
                Err(Error::User(e)) => {
                    warnings.push(format!("compare: {method}@{n}: {e}"));
                    None
                }
                Err(e) => return Err(e),
                Ok(c) => Some((format!("{method}@{n}"), c, t.elapsed().as_secs_f64() * 1e3)),
            };
            placed
        }
        _ => None,
    };
    if let Materials::AllGlossy(alpha) = job.config.compare.materials {
        crate::render::material::all_glossy(&mut prepared.scene.materials, alpha.0);
    }
    let glossy_config = job.config.clone();
    let over = Over {
        config: &glossy_config,
        prepared: &prepared,
        coverage: &coverage,
        progress: job.progress,
    };
    let views = views(&mut job, &prepared, &cameras)?;
    let context = if job.cpu {
        None
    } else {
        Context::new()
            .map_err(|e| warnings.push(format!("compare: {e}; traced on the CPU twin")))
            .ok()
    };
    let mut bench = Bench {
        config: job.config.clone(),
        config_path: job.config_path.clone(),
        config_text: job.provenance.config_text.clone(),
        over: &over,
        views: &views,
        context: context.as_ref(),
        gpu_used: true,
        warnings,
        rows: Vec::new(),
        figures: Vec::new(),
        sets: Vec::new(),
        measured: Vec::new(),
    };
    // Every bake of the comparison is planned (and fitted to the work
    // limit) before the first one runs; the rivals are sized to ours.
    let ours_counts: Vec<usize> = ours.iter().map(|(_, c, _)| c.probes.probes.len()).collect();
    let plan = plan(
        &bench.config,
        Planned {
            ours: &ours_counts,
            given: job.given.as_ref().map(Vec::len),
            grids,
            sweep,
            ours_count,
        },
        rayon::current_num_threads().max(1) as f64,
        crate::limits::work_limit_seconds(),
        |n| stages::place::check_probes(&job.config, &prepared, n),
    )
    .map_err(|e| job.config_error(e))?;
    bench.warnings.extend(plan.warnings(&bench.config));
    if let Some(lowered) = plan.lowered {
        bench.config.bake = lowered.bake;
    }
    bench.measure_ours(&mut job, ours)?;
    bench.given(&mut job)?;
    let grid_rows = bench.grids(&mut job, &plan.grids, ours_count)?;
    bench.ours_at_grid_count(&mut job, ours_at)?;
    bench.competitors(&mut job, &grid_rows, ours_count)?;
    let glossy = Glossy {
        gpu_used: bench.gpu_used,
        rows: bench.rows,
        figures: bench.figures,
        sets: bench.sets,
        warnings: bench.warnings,
        prepared: &prepared,
    };
    write(job, glossy, diffuse, &views, &cameras, context.as_ref())
}

/// Paths per pixel of the diffuse figures' reference view.
const LIT_VIEW_RAYS: u32 = 96;

/// Ours, placed and refined whatever the config says (§3.3) over `over`
/// (the scene's own materials), or reused from `--from`, not yet
/// measured, with the time each took, the config's method first (the one
/// the comparison headlines); and the probe count the others are matched
/// to (that method's).
fn place_ours(job: &mut Job, over: &Over) -> Result<(Vec<Unmeasured>, usize)> {
    let first = ours_default(&over.config.placement);
    let mut out = Vec::new();
    for method in std::iter::once(first).chain(ours().filter(|m| *m != first)) {
        let t = std::time::Instant::now();
        let found = reuse(job, method, over.prepared, job.config.compare.materials)?;
        let candidate = match found {
            Some(c) => c,
            None => over.refined(job, method, None)?,
        };
        out.push((method, candidate, t.elapsed().as_secs_f64() * 1e3));
    }
    let count = out[0].1.probes.probes.len();
    Ok((out, count))
}

/// What the glossy benchmark measured (nothing with `--only diffuse`).
struct Glossy<'a> {
    gpu_used: bool,
    rows: Vec<PlacementRow>,
    figures: Vec<PlacementFigures>,
    sets: Vec<view3d::ProbeSet>,
    warnings: Vec<String>,
    prepared: &'a Prepared,
}

impl<'a> Glossy<'a> {
    /// No glossy benchmark: the warnings so far alone.
    fn none(prepared: &'a Prepared, warnings: Vec<String>) -> Glossy<'a> {
        Glossy {
            gpu_used: false,
            rows: Vec::new(),
            figures: Vec::new(),
            sets: Vec::new(),
            warnings,
            prepared,
        }
    }
}

/// Assembles `compare.json`, `compare.csv`, `diffuse.csv` and
/// `report.html` and commits them.
fn write(
    mut job: Job,
    glossy: Glossy,
    diffuse: Option<diffuse::Measured>,
    views: &[ValidationView],
    cameras: &[(CameraParams, bool)],
    context: Option<&Context>,
) -> Result<Outcome> {
    let adapter = match (context, glossy.gpu_used) {
        (Some(ctx), true) => ctx.adapter.clone(),
        _ => "cpu twin".to_string(),
    };
    let config = &job.config;
    let rows = glossy.rows;
    let metric = performance_metric(&adapter, &rows);
    let comparisons = comparisons(&rows, metric, config.seed);
    let (section, lit) = match diffuse {
        Some(d) => (Some(d.section), d.figures),
        None => (None, None),
    };
    let report = CompareReport {
        format: "probeplace.compare",
        version: 1,
        provenance: job.provenance.clone(),
        config: job.config_path.display().to_string(),
        scene: config.scene.display().to_string(),
        seed: config.seed,
        adapter,
        quality_metric: crate::report::compare::QUALITY.entry().key,
        performance_metric: metric,
        width: config.reference.width.0,
        height: config.reference.height.0,
        glossy_rays: config.compare.glossy_rays.0,
        materials: match config.compare.materials {
            Materials::Scene => "scene".into(),
            Materials::AllGlossy(a) => format!("all-glossy:{}", a.0),
        },
        cameras: cameras
            .iter()
            .enumerate()
            .map(|(i, (camera, chosen))| CameraRecord {
                position: camera.position.0,
                look_at: camera.look_at.0,
                fov_degrees: camera.fov_degrees,
                chosen: *chosen,
                reference_glossy_mean: views.get(i).map(|v| v.reference.glossy_mean()),
            })
            .collect(),
        placements: rows,
        comparisons,
        diffuse: section,
        warnings: glossy.warnings,
        timings_ms: job.watch.to_map(),
    };
    let figures = Figures {
        references: views
            .iter()
            .take(FIGURE_VIEWS)
            .map(|v| png(&v.reference.full, v, "reference"))
            .collect::<Result<_>>()?,
        placements: glossy.figures,
        view: view3d::View3d::new(&glossy.prepared.scene, &glossy.prepared.domain, glossy.sets),
        lit,
    };
    job.set.add("compare.csv", to_csv(&report).into_bytes());
    if let Some(d) = &report.diffuse {
        job.set.add(
            "diffuse.csv",
            crate::report::diffuse::to_csv(d).into_bytes(),
        );
    }
    job.set
        .add("report.html", html::page(&report, &figures).into_bytes());
    let value = serde_json::to_value(&report).map_err(|e| Error::Internal(e.to_string()))?;
    let summary = crate::report::compare::summary(&report);
    job.finish_with("compare.json", value, summary)
}

/// Refuses grids whose bakes together would take more than
/// [`COMPARE_WORK_FACTOR`] work limits (each bake alone is checked when it
/// runs; errors name `compare.grids`, unprefixed).
fn check_grids(config: &Config, grids: &[GridParams]) -> Result<()> {
    let total: f64 = grids
        .iter()
        .map(|g| stages::bake::core_seconds(config, g.probes(), Work::Maps))
        .sum();
    crate::limits::check_work(
        "compare.grids",
        &format!("baking the {} grids", grids.len()),
        total,
        COMPARE_WORK_FACTOR,
    )
}

/// Parses `--grids`: comma-separated `NxMxK`, e.g. `2x2x2,4x2x4`.
///
/// Contract: at least one grid; a bad entry is a user error naming it.
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

/// The view of every camera; camera 0's reference is the one `bake`
/// renders (same seed), reused from `--from DIR` when it holds it.
fn views(
    job: &mut Job,
    prepared: &Prepared,
    cameras: &[(CameraParams, bool)],
) -> Result<Vec<ValidationView>> {
    // A reference of the scene's own materials does not serve all-glossy ones.
    let own_materials = job.config.compare.materials == Materials::Scene;
    let earlier_reference = match &job.earlier {
        Some(e)
            if own_materials
                && !cameras[0].1
                && e.has("reference.exr")
                && e.has("reference-glossy.exr") =>
        {
            Some(bake::read_reference(e)?)
        }
        _ => None,
    };
    if earlier_reference.is_some() {
        job.carry(&bake::REFERENCE_FILES);
    }
    let config = &job.config;
    let mut earlier_reference = earlier_reference;
    let views = job.watch.time("references", || {
        cameras
            .iter()
            .enumerate()
            .map(|(i, (camera, _))| {
                let reference = match earlier_reference.take().filter(|_| i == 0) {
                    Some(r) => r,
                    None => validate::reference(config, prepared, camera, i),
                };
                ValidationView::new(
                    config,
                    prepared,
                    camera,
                    i,
                    reference,
                    config.compare.glossy_rays.0,
                )
            })
            .collect()
    });
    Ok(views)
}

/// One of ours placed, not yet measured: its method, its probes, and the
/// milliseconds its placement took.
type Unmeasured = (&'static str, Candidate, f64);

/// What a comparison will bake, known once ours are placed.
struct Planned<'a> {
    /// Our placements' probe counts (reused ones too: lowered samples bake
    /// them again).
    ours: &'a [usize],
    /// The `--probes` set's count.
    given: Option<usize>,
    /// The grids chosen ([`Bench::grid_choice`]).
    grids: Vec<GridParams>,
    /// Whether `grids` are the sweep.
    sweep: bool,
    /// The count the rivals are matched to.
    ours_count: usize,
}

impl Planned<'_> {
    /// The probe counts of every bake with `grids`: ours, the `--probes`
    /// set, the grids, and the rivals sized to ours (ours again at the
    /// nearest grid's count, that grid relocated, greedy and adaptive at
    /// about our count: the larger of ours and the nearest grid's, since
    /// greedy and adaptive aim at ours and land near it).
    fn counts(&self, grids: &[GridParams]) -> Vec<usize> {
        let nearest =
            nearest_by_cells(&self.grids, self.ours_count).map_or(self.ours_count, |g| g.probes());
        let mut counts = self.ours.to_vec();
        counts.extend(self.given);
        counts.extend(grids.iter().map(GridParams::probes));
        if nearest != self.ours_count {
            counts.push(nearest);
        }
        counts.extend([nearest.max(self.ours_count); 3]);
        counts
    }
}

/// Every bake of a comparison, fitted to the work limit before the first.
#[derive(Debug)]
struct Plan {
    /// The grids to measure.
    grids: Vec<GridParams>,
    /// Sweep grids left out.
    left_out: Vec<GridParams>,
    /// The bake settings, when lowered.
    lowered: Option<Lowered>,
}

impl Plan {
    /// The report's warnings about the plan.
    fn warnings(&self, config: &Config) -> Vec<String> {
        let mut out: Vec<String> = self
            .left_out
            .iter()
            .map(|g| {
                format!(
                    "compare: grid:{} ({} probes) left out of the sweep: its octree or bake would run past the work limit (name it with --grids and set PROBEPLACE_WORK_LIMIT to measure it)",
                    Placement::Grid(*g).name().trim_start_matches("grid:"),
                    g.probes()
                )
            })
            .collect();
        if let Some(l) = &self.lowered {
            out.push(l.warning(&config.bake));
        }
        out
    }
}

/// Plans a comparison's bakes within the work limit (`limit` seconds on
/// `threads`; [`fit_bake`]): the bakes every headline ratio needs
/// (ours, the `--probes` set, the grids up to the nearest to ours, the
/// rivals at our count; every named grid) lower `bake.samples` for every
/// placement alike when they must; the sweep's larger grids are then kept
/// only while they fit at those samples, and left out otherwise. The
/// comparison thus finishes at a known cost, or is refused here, before
/// the first bake.
fn plan(
    config: &Config,
    planned: Planned,
    threads: f64,
    limit: f64,
    placeable: impl Fn(usize) -> Result<()>,
) -> Result<Plan> {
    let rival = nearest_by_cells(&planned.grids, planned.ours_count)
        .map_or(planned.ours_count, |g| g.probes())
        .max(planned.ours_count);
    let (mut grids, optional): (Vec<GridParams>, Vec<GridParams>) = planned
        .grids
        .iter()
        .partition(|g| !planned.sweep || g.probes() <= rival);
    // The stages before the bake (coverage, the octree) of every bake
    // needed, then the bakes.
    let needed = planned.counts(&grids);
    for &n in &needed {
        placeable(n)?;
    }
    let lowered = fit_bake(config, &needed, threads, limit)?;
    let mut at = config.clone();
    if let Some(l) = &lowered {
        at.bake = l.bake;
    }
    let mut left_out = Vec::new();
    for g in optional {
        let mut with = grids.clone();
        with.push(g);
        let fits = placeable(g.probes()).is_ok()
            && matches!(
                fit_bake(&at, &planned.counts(&with), threads, limit),
                Ok(None)
            );
        match fits {
            true => grids = with,
            false => left_out.push(g),
        }
    }
    // In the sweep's order, by probe count.
    grids.sort_by_key(|g| planned.grids.iter().position(|o| o == g));
    Ok(Plan {
        grids,
        left_out,
        lowered,
    })
}

/// Bake settings lowered for a whole comparison ([`fit_bake`]).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Lowered {
    /// What every placement is baked with.
    bake: crate::config::BakeParams,
    /// The estimated seconds of all bakes at the config's settings.
    seconds_before: f64,
    /// The same at `bake`.
    seconds_after: f64,
    /// How many bakes were fitted, and the probes of the largest.
    bakes: usize,
    largest: usize,
}

impl Lowered {
    /// The report's warning: what was lowered, why, and how to keep it.
    fn warning(&self, from: &crate::config::BakeParams) -> String {
        let mut changed = Vec::new();
        if self.bake.samples != from.samples {
            changed.push(format!(
                "bake.samples from {} to {}",
                from.samples.0, self.bake.samples.0
            ));
        }
        if self.bake.resolution != from.resolution {
            changed.push(format!(
                "bake.resolution from {} to {}",
                from.resolution.0, self.bake.resolution.0
            ));
        }
        format!(
            "compare: {} for every placement alike: the {} bakes ({} probes at most) would have taken about {} as configured, past the work limit for one bake or {COMPARE_WORK_FACTOR} for all; they take about {} now, and every placement's maps are noisier or coarser alike (lower the probe counts, or raise PROBEPLACE_WORK_LIMIT, to keep the config's)",
            changed.join(" and "),
            self.bakes,
            self.largest,
            crate::limits::duration_text(self.seconds_before),
            crate::limits::duration_text(self.seconds_after),
        )
    }
}

/// The bake settings that let every bake of a comparison (`counts`, the
/// probes of each) run within the work limit: each bake alone within
/// `limit` seconds on `threads`, and all of them within
/// [`COMPARE_WORK_FACTOR`] limits, as `bake` and `check_grids` bound them.
/// `None` when the config's `bake` fits; else `bake.samples` halved down
/// to 1 path per texel, then `bake.resolution` halved down to 32 (and not
/// below `irradiance_resolution`) until they do, the same for every
/// placement, so the rivals are not baked noisier than ours.
///
/// Contract: a comparison that does not fit even then, or whose largest
/// bake does not fit the memory budget, is refused naming `bake.resolution`
/// (or [`stages::bake::check_memory`]'s error), before any bake.
fn fit_bake(
    config: &Config,
    counts: &[usize],
    threads: f64,
    limit: f64,
) -> Result<Option<Lowered>> {
    let largest = counts.iter().copied().max().unwrap_or(0);
    let seconds_of = |config: &Config, bake: &crate::config::BakeParams| {
        let mut c = config.clone();
        c.bake = *bake;
        let each: Vec<f64> = counts
            .iter()
            .map(|&n| stages::bake::core_seconds(&c, n, Work::Maps) / threads)
            .collect();
        (
            each.iter().copied().fold(0.0, f64::max),
            each.iter().sum::<f64>(),
        )
    };
    let seconds = |bake: &crate::config::BakeParams| seconds_of(config, bake);
    let fits = |(one, all): (f64, f64)| one <= limit && all <= COMPARE_WORK_FACTOR * limit;
    // The largest bake's memory (coarser maps only shrink it).
    stages::bake::check_memory(config, largest)?;
    let before = seconds(&config.bake);
    if fits(before) {
        return Ok(None);
    }
    let mut bake = config.bake;
    loop {
        if bake.samples.0 > 1 {
            bake.samples.0 = bake.samples.0.div_ceil(2).min(bake.samples.0 - 1);
        } else if bake.resolution.0 > 32 && bake.resolution.0 / 2 >= bake.irradiance_resolution.0 {
            bake.resolution.0 /= 2;
        } else {
            break;
        }
        let after = seconds(&bake);
        if fits(after) {
            return Ok(Some(Lowered {
                bake,
                seconds_before: before.1,
                seconds_after: after.1,
                bakes: counts.len(),
                largest,
            }));
        }
    }
    // Every path vertex costs `1 + bounces` over a bounce-free path, and
    // every point, spot and directional light casts a shadow ray from it
    // (`light_factor`): when the same bakes would fit without bounces and
    // with one light, those fields are the cause, not the maps or the
    // probe counts, and the message must say so.
    let mut plain = config.clone();
    plain.bake.bounces.0 = 0;
    plain.lights.clear();
    let mut plain_bake = bake;
    plain_bake.bounces.0 = 0;
    if fits(seconds_of(&plain, &plain_bake)) {
        let lights = config
            .lights
            .iter()
            .filter(|l| !matches!(l, crate::config::Light::Sky { .. }))
            .count();
        return Err(Error::User(format!(
            "bake.bounces, lights: the comparison's {} bakes ({largest} probes at most) would take about {} even at 1 path per texel and {}² maps, past the work limit of {} for one bake or {COMPARE_WORK_FACTOR} for all (PROBEPLACE_WORK_LIMIT=0 lifts it), because each path vertex of {} bounces casts a shadow ray to each of {lights} point, spot and directional lights ({:.0}x the work of bounce-free paths and one light, which would fit); lower bake.bounces or the number of lights",
            counts.len(),
            crate::limits::duration_text(seconds(&bake).1),
            bake.resolution.0,
            crate::limits::duration_text(limit),
            bake.bounces.0,
            (1.0 + bake.bounces.0 as f64) * stages::bake::light_factor(config),
        )));
    }
    Err(Error::User(format!(
        "bake.resolution: the comparison's {} bakes ({largest} probes at most) would take about {} even at 1 path per texel and {}² maps, past the work limit of {} for one bake or {COMPARE_WORK_FACTOR} for all (PROBEPLACE_WORK_LIMIT=0 lifts it); lower the probe counts",
        counts.len(),
        crate::limits::duration_text(seconds(&bake).1),
        bake.resolution.0,
        crate::limits::duration_text(limit),
    )))
}

/// What every placement is measured with, and the rows so far.
struct Bench<'a> {
    config: Config,
    /// The config file and its text, which errors about its fields name.
    config_path: std::path::PathBuf,
    config_text: String,
    /// What ours and the rivals are placed over.
    over: &'a Over<'a>,
    views: &'a [ValidationView],
    context: Option<&'a Context>,
    /// Whether every placement so far was traced on the GPU.
    gpu_used: bool,
    warnings: Vec<String>,
    rows: Vec<PlacementRow>,
    figures: Vec<PlacementFigures>,
    /// Every placement's probes for the 3D view, in row order.
    sets: Vec<view3d::ProbeSet>,
    /// What each placement measured on Wang's tracer, for a later
    /// placement with the same probes and octree.
    measured: Vec<Measured>,
}

/// What [`Bench::bake_and_render`] measures of a placement: it depends on
/// the probes and octree alone.
#[derive(Clone)]
struct Measurement {
    /// The light field's bytes.
    probe_bytes: u64,
    /// The renders on each tracer, Wang's first.
    traced: Traced,
    /// Why the CPU twin traced, when the GPU was refused.
    why_cpu: Option<String>,
}

/// A placement's [`Measurement`] on Wang's tracer ([`TRACER_HIZ`]) with
/// what it depends on: a placement that repeats both its probes and its
/// octree (a relocated grid where no probe needed moving) reuses it
/// instead of baking and rendering the same field again.
struct Measured {
    positions: Vec<Vec3>,
    /// The octree's bytes ([`Svo::to_bytes`]).
    svo: Vec<u8>,
    measurement: Measurement,
}

impl Measured {
    /// `measurement` of the placement with `positions` and the octree of
    /// bytes `svo` ([`Svo::to_bytes`]), kept to Wang's tracer.
    fn new(positions: &[Vec3], svo: Vec<u8>, measurement: &Measurement) -> Measured {
        Measured {
            positions: positions.to_vec(),
            svo,
            measurement: Measurement {
                traced: measurement.traced[..1].to_vec(),
                why_cpu: measurement.why_cpu.clone(),
                ..*measurement
            },
        }
    }

    /// Whether it serves a placement of `family` with `positions` and the
    /// octree of bytes `svo`, whose row shows its figures when `figures`:
    /// not a grid (also traced on McGuire's tracer), the same probes and
    /// octree, and the figures where the row needs them.
    fn serves(&self, family: Family, positions: &[Vec3], svo: &[u8], figures: bool) -> bool {
        let rendered = &self.measurement.traced[0].2;
        family != Family::Grid
            && self.positions == positions
            && self.svo == svo
            && (!figures
                || rendered
                    .iter()
                    .take(FIGURE_VIEWS)
                    .all(|r| r.figures.is_some()))
    }

    /// Its measurement for a row that shows figures when `figures`.
    fn reused(&self, figures: bool) -> Measurement {
        let mut m = self.measurement.clone();
        for r in &mut m.traced[0].2 {
            r.figures = r.figures.take().filter(|_| figures);
        }
        m
    }
}

impl Bench<'_> {
    /// Measures ours ([`place_ours`]); a light field reused from
    /// `--from` is baked again when the comparison's bake samples were
    /// lowered, so that every placement is baked alike.
    fn measure_ours(&mut self, job: &mut Job, ours: Vec<Unmeasured>) -> Result<()> {
        for (method, mut candidate, placed_ms) in ours {
            let t = std::time::Instant::now();
            if self.config.bake != job.config.bake {
                candidate.field = None;
            }
            self.measure(method, Family::Ours, candidate, true)?;
            job.watch
                .record(method, placed_ms + t.elapsed().as_secs_f64() * 1e3);
        }
        Ok(())
    }

    /// Our default method again at the count of the grid nearest ours,
    /// when that differs from ours (`min_probes` and `max_probes` both set
    /// to it, [`crate::refine::topup`]), named `METHOD@COUNT`: a ratio
    /// against that grid is then one at equal count, not at about it
    /// (Wang et al. 2019 §5.2 compare at equal count).
    fn ours_at_grid_count(
        &mut self,
        job: &mut Job,
        placed: Option<(String, Candidate, f64)>,
    ) -> Result<()> {
        let Some((name, candidate, placed_ms)) = placed else {
            return Ok(());
        };
        let t = std::time::Instant::now();
        match self.measure(&name, Family::Ours, candidate, false) {
            Err(Error::User(e)) => self.warnings.push(format!("compare: {name}: {e}")),
            other => other?,
        }
        job.watch
            .record(&name, placed_ms + t.elapsed().as_secs_f64() * 1e3);
        Ok(())
    }

    /// The probe set of `--probes FILE.json`, scored as given (coverage,
    /// SVO, bake, render), beside ours.
    fn given(&mut self, job: &mut Job) -> Result<()> {
        let Some(probes) = job.given_probes(&self.over.prepared.scene)? else {
            return Ok(());
        };
        let t = std::time::Instant::now();
        let placed = stages::place(
            &self.config,
            self.over.prepared,
            self.over.coverage,
            Some(probes),
            &self.over.progress,
        )
        .map_err(|e| job.config_error(e))?;
        self.measure("file", Family::Given, candidate_of(placed), true)?;
        job.watch.record("file", t.elapsed().as_secs_f64() * 1e3);
        Ok(())
    }

    /// The uniform grids to compare with: the given ones, the config's, or
    /// a sweep around `ours_count` ([`placement::grid::grid_sweep`]); and whether they are
    /// the sweep (whose largest grids [`plan`] may leave out; named grids
    /// are the user's, checked before any work).

    /// Places and measures the planned `grids` ([`plan`]);
    /// returns each grid with its probe count.
    fn grids(
        &mut self,
        job: &mut Job,
        grids: &[GridParams],
        ours_count: usize,
    ) -> Result<Vec<(usize, GridParams)>> {
        let nearest = nearest_by_cells(grids, ours_count);
        let mut out = Vec::new();
        for g in grids {
            let t = std::time::Instant::now();
            let method = Placement::Grid(*g);
            let name = method.name();
            let placed = self.over.plain(method)?;
            out.push((placed.probes.probes.len(), *g));
            let mut candidate = candidate_of(placed);
            candidate.stats.clear();
            self.measure(&name, Family::Grid, candidate, Some(*g) == nearest)?;
            job.watch.record(&name, t.elapsed().as_secs_f64() * 1e3);
        }
        Ok(out)
    }

    /// The competitors: what engines ship (the grid nearest our count,
    /// relocated and classified, and Unity's adaptive probe volumes with
    /// the minimum spacing whose count is nearest ours), and Silvennoinen &
    /// Lehtinen's greedy placement with as many probes as ours.
    fn competitors(
        &mut self,
        job: &mut Job,
        grids: &[(usize, GridParams)],
        ours_count: usize,
    ) -> Result<()> {
        let input = self
            .over
            .prepared
            .placement_input(self.config.seed, &self.over.progress);
        let competitors: Vec<(Placement, Family)> = METHODS
            .iter()
            .filter(|m| m.role == Role::Competitor)
            .filter_map(|m| {
                Placement::at_count(m.variant, &input, grids, ours_count)
                    .map(|p| (p, Family::Competitor(m.word)))
            })
            .collect();
        for (method, family) in competitors {
            let t = std::time::Instant::now();
            let name = method.name();
            // Every probe switched off, no candidate voxel, or more probes
            // than planned for at our count: a finding, not a failure.
            match self
                .over
                .plain(method)
                .and_then(|placed| self.measure(&name, family, candidate_of(placed), true))
            {
                Err(Error::User(e)) => self.warnings.push(format!("compare: {name}: {e}")),
                other => other?,
            }
            job.watch.record(&name, t.elapsed().as_secs_f64() * 1e3);
        }
        Ok(())
    }

    /// Coverage, SVO, bake and the render from every view of a placement:
    /// one row on Wang's tracer, and for a grid a second on McGuire's.
    /// `figures`: whether the page shows its renders and error maps. A
    /// placement whose probes and octree an earlier one had (not a grid,
    /// which is also traced on McGuire's) takes that one's measurements
    /// ([`Measured`]).
    fn measure(
        &mut self,
        name: &str,
        family: Family,
        candidate: Candidate,
        figures: bool,
    ) -> Result<()> {
        let stats = candidate.stats;
        let Prepared {
            scene,
            domain,
            bvh,
            sdf,
            ..
        } = self.over.prepared;
        let probes = &candidate.probes;
        let positions = probes.positions();
        let (cov, holes) =
            self.over
                .coverage
                .evaluate_with_holes(bvh, &positions, &self.over.progress);
        let free = crate::coverage::probes_free(bvh, sdf.voxel_size, &positions);
        let health = crate::coverage::probe_health_of(&free, sdf, domain, &positions);
        let views_png = encode_png(
            &report::placement_views(scene, domain, &positions, &holes, VIEW_SIZE),
            "placement views",
        )?;
        // The place stage refuses an empty probe set, so every candidate
        // has probes and their SVO.
        let svo = candidate.svo;
        // Placement alone: the same for both tracers.
        let distances: Vec<f64> = self
            .views
            .iter()
            .filter_map(|v| validate::shading_probe_distance(v, bvh, &positions))
            .collect();
        let shading_probe_distance =
            (!distances.is_empty()).then(|| distances.iter().sum::<f64>() / distances.len() as f64);
        let octree = svo.to_bytes();
        let earlier = self
            .measured
            .iter()
            .find(|m| m.serves(family, &positions, &octree, figures));
        let Measurement {
            probe_bytes,
            traced,
            why_cpu,
        } = match earlier {
            Some(m) => m.reused(figures),
            None => {
                let m = self.bake_and_render(
                    name,
                    family,
                    &candidate.field,
                    &positions,
                    &svo,
                    figures,
                )?;
                self.measured.push(Measured::new(&positions, octree, &m));
                m
            }
        };
        if let Some(e) = why_cpu {
            self.warnings
                .push(format!("compare: {name}: {e}; traced on the CPU twin"));
        }
        let svo_bytes = svo.bytes();
        for (tracer_name, _kind, rendered) in traced {
            let cameras: Vec<CameraRow> = rendered.iter().map(|r| r.metrics.clone()).collect();
            self.rows.push(PlacementRow {
                name: name.to_string(),
                family,
                tracer: tracer_name,
                probes: positions.len(),
                coverage: cov.coverage,
                probes_in_solid: health.probes_in_solid,
                probe_bytes,
                svo_bytes,
                means: crate::stages::validate::PerMetric::from_fn(|m| {
                    cameras.iter().map(|c| c.figures[m]).sum::<f64>() / cameras.len().max(1) as f64
                }),
                shading_probe_distance,
                gpu_ms: cameras.iter().map(|c| c.gpu_ms).sum(),
                cameras,
                stats: stats.clone(),
                blocks: rendered.iter().map(|r| r.blocks.clone()).collect(),
            });
            let (mut renders, mut errors, mut flips) = (Vec::new(), Vec::new(), Vec::new());
            for r in rendered.into_iter().filter_map(|r| r.figures) {
                renders.push(r[0].clone());
                errors.push(r[1].clone());
                flips.push(r[2].clone());
            }
            self.figures.push(PlacementFigures {
                views: views_png.clone(),
                renders,
                errors,
                flips,
            });
            self.sets.push(view3d::ProbeSet::new(
                &format!("{name} ({tracer_name})"),
                &positions,
                sdf,
                &svo,
                &report::hole_sample(&holes),
                holes.len(),
            ));
        }
        Ok(())
    }

    /// [`Bench::measure`]'s work that depends on the probes and octree
    /// alone: the bake (unless `field` was reused) and the renders from
    /// every view on each tracer the `family` is measured on, Wang's
    /// first.
    fn bake_and_render(
        &mut self,
        name: &str,
        family: Family,
        field: &Option<LightField>,
        positions: &[Vec3],
        svo: &Svo,
        figures: bool,
    ) -> Result<Measurement> {
        let baked;
        let field = match field {
            Some(f) => f,
            None => {
                stages::bake::check_with(&self.config, positions.len(), Work::Maps)
                    .map_err(|e| e.in_config(&self.config_path, &self.config_text))?;
                baked = stages::bake(
                    &self.config,
                    self.over.prepared,
                    positions,
                    &self.over.progress,
                )
                .field;
                &baked
            }
        };
        // Every placement on Wang et al. 2019's Hi-Z march and SVO
        // selection; grids also as engines trace them today (McGuire et
        // al. 2017: bi-level march, the cell's eight probes).
        let lattice = match family {
            Family::Grid => Lattice::from_positions(&field.positions),
            _ => None,
        };
        let mut tracers = vec![(TRACER_HIZ, SelectionKind::Svo, March::HiZ)];
        if lattice.is_some() {
            tracers.push((TRACER_BILEVEL, SelectionKind::Grid, March::BiLevel));
        }
        let (tracer, why) = Tracer::new(self.context, field, Some(svo), lattice.as_ref());
        if !tracer.on_gpu() {
            self.gpu_used = false;
        }
        let traced = tracers
            .into_iter()
            .map(|(tracer_name, kind, march)| {
                Ok((
                    tracer_name,
                    kind,
                    self.render(name, &tracer, kind, march, figures)?,
                ))
            })
            .collect::<Result<Traced>>()?;
        Ok(Measurement {
            probe_bytes: field.bytes() as u64,
            traced,
            why_cpu: why,
        })
    }

    /// The renders through `tracer` from every view, with `kind` selection
    /// and `march`: their figures and blocks, and, for the first
    /// [`FIGURE_VIEWS`] views when `figures`, their PNGs (render, MSE heat
    /// map, ꟻLIP map).
    fn render(
        &self,
        name: &str,
        tracer: &Tracer,
        kind: SelectionKind,
        march: March,
        figures: bool,
    ) -> Result<Vec<Rendered>> {
        let gpu = |e: Error| Error::Internal(format!("compare {name}: {e}"));
        let mut out = Vec::with_capacity(self.views.len());
        for (i, view) in self.views.iter().enumerate() {
            let glossy = tracer.trace(view, march, kind).map_err(gpu)?;
            let irradiance = tracer.gather(view, kind).map_err(gpu)?;
            let v = validate::validate(view, &irradiance, &glossy);
            let figures = if figures && i < FIGURE_VIEWS {
                let (w, h) = (view.reference.width, view.reference.height);
                Some([
                    png(&v.image.full, view, "render")?,
                    encode_png(&view.heat_map(&v.image.glossy_indirect), "error map")?,
                    encode_png(
                        &crate::render::flip::error_map(&v.flip_map, w, h),
                        "FLIP map",
                    )?,
                ])
            } else {
                None
            };
            out.push(Rendered {
                metrics: v.metrics,
                blocks: v.blocks,
                figures,
            });
        }
        Ok(out)
    }
}

/// A placement's renders on each tracer: its name, selection and renders.
type Traced = Vec<(&'static str, SelectionKind, Vec<Rendered>)>;

/// One placement's render from one view, measured.
#[derive(Clone)]
struct Rendered {
    metrics: CameraRow,
    blocks: Blocks,
    /// Render, MSE heat map and ꟻLIP map, PNG, where the page shows them.
    figures: Option<[Vec<u8>; 3]>,
}

/// The uniform grids the glossy benchmark compares with: the given ones,
/// the config's, or a sweep around `ours_count`
/// ([`placement::grid::grid_sweep`]); and whether they are the sweep
/// (whose largest grids [`plan`] may leave out; named grids are the
/// user's, checked before any work).
fn grid_choice(
    config: &Config,
    domain: &crate::scene::Bounds,
    given: Option<&Vec<GridParams>>,
    ours_count: usize,
) -> (Vec<GridParams>, bool) {
    match (given, config.compare.grids.is_empty()) {
        (Some(g), _) => (g.clone(), false),
        (None, false) => (config.compare.grids.clone(), false),
        (None, true) => (placement::grid::grid_sweep(domain, ours_count), true),
    }
}

/// [`nearest_grid`] among `grids` by their cell counts, before any is
/// placed.
fn nearest_by_cells(grids: &[GridParams], count: usize) -> Option<GridParams> {
    let counted: Vec<(usize, GridParams)> = grids.iter().map(|g| (g.probes(), *g)).collect();
    nearest_grid(&counted, count).map(|&(_, g)| g)
}

/// The method of ours the comparison headlines: the config's, when it is
/// one of ours, else the first.
fn ours_default(config: &Placement) -> &'static str {
    ours()
        .find(|m| *m == config.name())
        .or_else(|| ours().next())
        .expect("the registry lists a method of ours")
}

/// `pixels` tone mapped at the view's exposure, as PNG.
fn png(pixels: &[[f32; 3]], view: &ValidationView, what: &str) -> Result<Vec<u8>> {
    let (w, h) = (view.reference.width, view.reference.height);
    encode_png(&crate::raster::tonemap(pixels, w, h, view.exposure), what)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A view's render with (or without) its page figures.
    fn rendered(figures: bool) -> Rendered {
        Rendered {
            metrics: validate::Metrics {
                figures: Default::default(),
                gpu_ms: None,
                gpu_trace_ms: None,
                gpu_gather_ms: None,
                glossy_indirect_mean: [0.0; 3],
                surfel_fetches_per_ray: 0.0,
                warp_fetches_per_ray: 0.0,
                probe_switches_per_ray: 0.0,
                unresolved_rays: 0,
                hits: 0,
                misses: 0,
            },
            blocks: Blocks::default(),
            figures: figures.then(|| [vec![1], vec![2], vec![3]]),
        }
    }

    #[test]
    fn a_measurement_serves_only_the_same_probes_and_octree_off_the_grid() {
        let positions = [Vec3::ZERO, Vec3::ONE];
        let measured = |figures: bool| Measured {
            positions: positions.to_vec(),
            svo: vec![1, 2, 3],
            measurement: Measurement {
                probe_bytes: 9,
                traced: vec![(TRACER_HIZ, SelectionKind::Svo, vec![rendered(figures)])],
                why_cpu: Some("too many probes".into()),
            },
        };
        let (with, without) = (measured(true), measured(false));
        let relocated = Family::Competitor("relocated");
        assert!(with.serves(relocated, &positions, &[1, 2, 3], true));
        assert!(with.serves(relocated, &positions, &[1, 2, 3], false));
        // A grid is traced on McGuire's tracer too, which is not kept.
        assert!(!with.serves(Family::Grid, &positions, &[1, 2, 3], false));
        // Other probes, another octree, or figures it lacks.
        assert!(!with.serves(relocated, &positions[..1], &[1, 2, 3], false));
        assert!(!with.serves(relocated, &[Vec3::ZERO, Vec3::X], &[1, 2, 3], false));
        assert!(!with.serves(relocated, &positions, &[1, 2, 4], false));
        assert!(!without.serves(relocated, &positions, &[1, 2, 3], true));
        assert!(without.serves(relocated, &positions, &[1, 2, 3], false));
        // The row shows figures only where it asks for them.
        let shown = |m: &Measurement| m.traced[0].2[0].figures.is_some();
        assert!(shown(&with.reused(true)) && !shown(&with.reused(false)));
        let m = with.reused(false);
        assert_eq!(
            (m.probe_bytes, m.why_cpu.as_deref()),
            (9, Some("too many probes"))
        );
    }
    #[test]
    fn bake_settings_are_lowered_alike_until_every_bake_fits_or_refused() {
        let mut config =
            Config::parse("(scene: \"s.obj\")", std::path::Path::new("c.ron")).unwrap();
        config.bake.samples = crate::config::Count(64);
        let counts = [100, 100, 400];
        let at = |samples: u32, resolution: u32| {
            let mut c = config.clone();
            c.bake.samples = crate::config::Count(samples);
            c.bake.resolution.0 = resolution;
            counts
                .iter()
                .map(|&n| stages::bake::core_seconds(&c, n, Work::Maps))
                .collect::<Vec<f64>>()
        };
        let at_64 = at(64, 128);
        // Room for everything: nothing changes.
        assert_eq!(
            fit_bake(&config, &counts, 1.0, at_64[2] * 1.01).unwrap(),
            None
        );
        // The largest bake fits one limit at a quarter of the samples: the
        // samples halve until it does, for every bake alike.
        let limit = at(16, 128)[2] * 1.001;
        let lowered = fit_bake(&config, &counts, 1.0, limit).unwrap().unwrap();
        assert_eq!(
            (lowered.bake.samples.0, lowered.bake.resolution.0),
            (16, 128),
            "{lowered:?}"
        );
        assert!(at(32, 128)[2] > limit);
        assert!((lowered.seconds_before - at_64.iter().sum::<f64>()).abs() < 1e-6);
        let w = lowered.warning(&config.bake);
        assert!(
            w.contains("bake.samples from 64 to 16 for every placement alike")
                && w.contains("400 probes"),
            "{w}"
        );
        // Two threads halve the seconds: one halving fewer.
        let on_two = fit_bake(&config, &counts, 2.0, limit).unwrap().unwrap();
        assert_eq!(on_two.bake.samples.0, 32);
        // Below one path per texel, the maps get coarser.
        let limit = at(1, 64)[2] * 1.001;
        let lowered = fit_bake(&config, &counts, 1.0, limit).unwrap().unwrap();
        assert_eq!((lowered.bake.samples.0, lowered.bake.resolution.0), (1, 64));
        assert!(lowered
            .warning(&config.bake)
            .contains("bake.resolution from 128 to 64"));
        // The sum binds too: many small bakes.
        let many = vec![100; 64];
        let lowered = fit_bake(&config, &many, 1.0, at_64[0] * 2.0)
            .unwrap()
            .unwrap();
        assert!(lowered.bake.samples.0 < 64, "{lowered:?}");
        // Nothing fits: refused, naming the field.
        let e = fit_bake(&config, &counts, 1.0, 1e-3)
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with("bake.resolution: the comparison's 3 bakes"),
            "{e}"
        );
    }

    #[test]
    fn a_plan_keeps_what_the_ratios_need_and_leaves_out_larger_sweep_grids() {
        let config = Config::parse("(scene: \"s.obj\")", std::path::Path::new("c.ron")).unwrap();
        let grid = |n: u32| GridParams::new([n, 1, 1]).unwrap();
        let sweep: Vec<GridParams> = [5, 10, 20, 40].map(grid).to_vec();
        let planned = |sweep_flag| Planned {
            ours: &[10, 12],
            given: None,
            grids: sweep.clone(),
            sweep: sweep_flag,
            ours_count: 10,
        };
        // A bake's cost grows with its probes: 17 probes' worth is room
        // for ours (12) and every bake the ratios need (67 probes in all,
        // under the 4 limits of the sum), not for the sweep's 20 or 40.
        let room = stages::bake::core_seconds(&config, 17, Work::Maps);
        // Room for all: everything kept at the config's samples.
        let p = plan(&config, planned(true), 1.0, 1e9, |_| Ok(())).unwrap();
        assert_eq!((p.grids.len(), p.lowered), (4, None));
        // The 20- and 40-probe grids of the sweep are left out, not the
        // samples lowered for them.
        let p = plan(&config, planned(true), 1.0, room, |_| Ok(())).unwrap();
        assert_eq!(p.grids, [grid(5), grid(10)], "{p:?}");
        assert_eq!(p.left_out, [grid(20), grid(40)]);
        // Named grids are all kept: the samples are lowered instead.
        let mut quarter = config.clone();
        quarter.bake.samples = crate::config::Count(config.bake.samples.0 / 4);
        let limit = stages::bake::core_seconds(&quarter, 40, Work::Maps) * 1.01;
        let p = plan(&config, planned(false), 1.0, limit, |_| Ok(())).unwrap();
        assert_eq!(p.grids.len(), 4);
        assert_eq!(
            p.lowered.map(|l| l.bake.samples),
            Some(quarter.bake.samples),
            "{p:?}"
        );
        // A stage before the bake that cannot take a needed count refuses
        // the plan; one that cannot take a larger sweep grid leaves it out.
        let small = |n: usize| match n > 15 {
            true => Err(Error::User(format!("svo: {n} probes"))),
            false => Ok(()),
        };
        let p = plan(&config, planned(true), 1.0, 1e9, small).unwrap();
        assert_eq!(p.left_out, [grid(20), grid(40)]);
        let e = plan(&config, planned(false), 1.0, 1e9, small).unwrap_err();
        assert!(e.to_string().starts_with("svo: 20 probes"), "{e}");
    }
}
