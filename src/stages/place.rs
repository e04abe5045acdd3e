//! The place stage: a placement method (Wang et al. 2019 §3.1, or a
//! baseline), refinement where the config asks for it (§3.3), the coverage
//! of the result (§2, §3.2) and the SVO of probe indices (§4.1).

use super::prepare::Prepared;
use crate::config::{short, Config, Objective};
use crate::coverage::{self, Coverage, CoverageReference, ProbeHealth, Stream};
use crate::error::{Error, Result};
use crate::limits;
use crate::placement::controls::{Controls, ControlsReport};
use crate::placement::{self, PlacementInput, ProbeSet};
use crate::progress::{Progress, Stopwatch};
use crate::refine::{self, RefineReport};
use crate::svo::{self, Svo, SvoReport};
use glam::Vec3;

/// What the place stage produced.
pub struct Placed {
    /// The probes.
    pub probes: ProbeSet,
    /// Refinement's report and its atlas image; `None` when it was off.
    pub refined: Option<(RefineReport, crate::raster::RgbImage)>,
    /// Their coverage by the run's validation reference, which the placer
    /// never saw.
    pub coverage: Coverage,
    /// Their coverage on the samples the placer fitted (a training score;
    /// `None` when nothing was fitted: no refinement and no budget).
    pub coverage_train: Option<f64>,
    /// The coverable samples no probe sees.
    pub holes: Vec<Vec3>,
    /// Probes in solid, outside the scene or the domain.
    pub health: ProbeHealth,
    /// The octree of probe indices and its figures.
    pub svo: (Svo, SvoReport),
    /// What the artist controls did.
    pub controls: ControlsReport,
    /// What the diffuse step did (`refine.objective: Both`); `None` when
    /// it did not run.
    pub diffuse: Option<refine::diffuse::DiffuseReport>,
    /// Warnings for the report.
    pub warnings: Vec<String>,
    /// `placement`, `refine`, `coverage`, `svo`.
    pub timings: Stopwatch,
}

/// Places probes with `config.placement` (or takes `given`, a probe set made
/// elsewhere, which is scored, not refined), refines them where
/// `config.refine.enabled`, and measures and indexes the result.
/// `reference` is the coverage measure the result is scored by, the
/// validation stream ([`Stream::Validation`]): refinement and the budget
/// never see it; they fit a training reference of their own
/// ([`Stream::Train`], built here when they run), and refinement checks
/// its result on fresh rounds ([`crate::refine::holdout`]). The config's artist controls
/// ([`crate::placement::controls`]) shape a placement, not a given set
/// (which gets a warning instead): fixed probes first, none in an
/// `exclude` box, at most `max_probes`; `probe_density` needs refinement
/// (its filling and pruning meet the demand) and is a warning without it.
///
/// Contract: errors name the config field, not the file (the job prefixes
/// it). The probe set is never empty: a placement, or a refinement, that
/// leaves no probe is a user error naming the cause, found before the SVO
/// and any output, since a run without probes has nothing to bake, render
/// or score.
pub fn place(
    config: &Config,
    prepared: &Prepared,
    reference: &CoverageReference,
    given: Option<ProbeSet>,
    progress: &Progress,
) -> Result<Placed> {
    let mut timings = progress.stopwatch();
    let input = prepared.placement_input(config.seed, progress);
    let refine_it = config.refine.enabled && given.is_none();
    let mut warnings = Vec::new();
    let all = Controls::new(config, &prepared.scene);
    let controls = if given.is_none() {
        all.check(config, &prepared.sdf, &prepared.domain)?;
        all
    } else {
        if !all.is_empty() {
            warnings.push("fixed_probes, exclude, max_probes, min_probes and probe_density shape a placement; a probe set given with --probes is scored as given".to_string());
        }
        Controls::default()
    };
    if !controls.density.is_empty() && !(refine_it && (config.refine.fill || config.refine.prune)) {
        warnings.push("probe_density: not applied: it is met by refinement's filling and pruning, and this run does neither".to_string());
    }
    match controls.min_probes {
        Some(_) if !refine_it => warnings.push("min_probes: not applied: the probes it adds are chosen among refinement's fill positions, and this run does not refine".to_string()),
        Some(min) => check_min_probes(config, prepared, reference, min)?,
        None => {}
    }
    let fits = refine_it || (given.is_none() && controls.max_probes.is_some());
    let training = fits.then(|| {
        timings.time("coverage_train_reference", || {
            prepared.coverage_reference(&config.coverage, Stream::Train, config.seed, progress)
        })
    });
    let fitted = training.as_ref().unwrap_or(reference);
    let mut report = ControlsReport {
        max_probes: controls.max_probes,
        min_probes: controls.min_probes,
        density_regions: controls.density.len(),
        samples_with_density: fitted
            .samples
            .iter()
            .enumerate()
            .filter(|&(i, s)| fitted.coverable[i] && controls.density_at(s.position) != 1.0)
            .count(),
        ..ControlsReport::default()
    };
    let probes = match given {
        Some(p) => p,
        None => {
            let placed =
                timings.try_time("placement", || placement::place(&config.placement, &input))?;
            let (probes, excluded) = controls.apply(placed);
            report.excluded = excluded;
            probes
        }
    };
    if probes.probes.is_empty() {
        let outside = if report.excluded > 0 {
            format!(
                " outside the exclude boxes ({} inside them)",
                report.excluded
            )
        } else {
            " in the domain".to_string()
        };
        return Err(Error::User(format!(
            "placement: {} placed no probe{outside}; check the domain and the method's parameters",
            probes.method
        )));
    }
    check_placed(
        config,
        prepared,
        probes.probes.len(),
        Some((&input, &probes.positions())),
    )?;
    let mut refined_columns = None;
    let (probes, refined) = if refine_it {
        let placed = probes.probes.len();
        let out = timings.try_time("refine", || {
            refine::refine(&config.refine, probes, &input, fitted, &controls)
        })?;
        timings.absorb(&out.steps);
        if out.probes.probes.is_empty() {
            return Err(pruned_all(config, fitted, placed));
        }
        report.probes_before_budget = out.report.probes_before_budget;
        report.probes_before_minimum = out.report.probes_before_minimum;
        report.demand_met = Some(out.report.coverage_final);
        refined_columns = Some(out.columns);
        (out.probes, Some((out.report, out.atlas_image)))
    } else {
        match controls.max_probes {
            Some(budget) if probes.probes.len() > budget => {
                report.probes_before_budget = Some(probes.probes.len());
                let kept = timings.time("budget", || {
                    refine::prune::CoverMatrix::new(fitted, &prepared.bvh).select(
                        &probes.positions(),
                        probes.fixed,
                        budget,
                    )
                });
                let mut probes = probes;
                probes.probes = kept.iter().map(|&k| probes.probes[k]).collect();
                (probes, None)
            }
            _ => (probes, None),
        }
    };
    let (probes, diffuse) = if refine_it && config.refine.objective == Objective::Both {
        let columns = refined_columns.take().unwrap_or_default();
        check_diffuse(config, &prepared.scene, probes.probes.len(), &controls)?;
        let renderer = prepared.renderer(config);
        // Probes for diffuse light stand as near surfaces as the coverage
        // measure's reference points (one voxel), or the user's pin.
        let min_clearance = config
            .refine
            .min_clearance
            .map_or(placement::grid_min_clearance(&prepared.sdf), |c| c.0);
        let matrix = refine::prune::CoverMatrix::new(fitted, &prepared.bvh)
            .with_need(|i, p| controls.need(i, p));
        let target = config.refine.coverage_target.0 as f64;
        let cover = (columns.len() == probes.probes.len()).then_some((&matrix, columns, target));
        let (p, r, steps) = timings.time("diffuse", || {
            refine::diffuse::optimize(
                &config.refine.diffuse,
                probes,
                &input,
                &renderer,
                min_clearance,
                &controls,
                cover,
            )
        });
        timings.absorb(&steps);
        if r.probes_after > r.probes_before && controls.min_probes.is_some() {
            report.probes_before_minimum = Some(r.probes_before);
        }
        (p, Some(r))
    } else {
        (probes, None)
    };
    report.fixed_probes = probes.fixed;
    // Not the octree's bound (every influence holding every leaf), which
    // refused, after refinement, sets whose octree bakes in a minute: the
    // octree checks its work once the probes' influences are known
    // ([`svo::bake`]).
    check_count(probes.probes.len())?;
    check_scoring(config, probes.probes.len())?;
    let positions = probes.positions();
    let ((coverage, holes), health) = timings.time("coverage", || {
        (
            reference.evaluate_with_holes(&prepared.bvh, &positions, progress),
            coverage::probe_health(&prepared.bvh, &prepared.sdf, &prepared.domain, &positions),
        )
    });
    let coverage_train = match (&refined, &training) {
        (Some((r, _)), _) => Some(r.coverage_final),
        (None, Some(t)) => Some(t.evaluate(&prepared.bvh, &positions, progress).coverage),
        (None, None) => None,
    };
    let baked = timings.try_time("svo", || svo::bake(&config.svo, &probes, &input))?;
    let svo = (baked.svo, baked.report);
    Ok(Placed {
        probes,
        refined,
        coverage,
        coverage_train,
        holes,
        health,
        svo,
        controls: report,
        diffuse,
        warnings,
        timings,
    })
}

/// Refuses a top-up to `min` probes (`min_probes`) over the coverage
/// samples of `reference` that would run past the work limit, or a probe
/// set of `min` probes the later stages refuse ([`check_probes`]), naming
/// `min_probes`. `place` checks it before placing; `compare`, whose ours
/// always refine, before it makes any reference, so the refusal comes in
/// the time `place` takes to give it rather than after the references.
pub(crate) fn check_min_probes(
    config: &Config,
    prepared: &Prepared,
    reference: &CoverageReference,
    min: usize,
) -> Result<()> {
    refine::topup::check_work(min, reference.samples.len())?;
    check_probes(config, prepared, min).map_err(|e| match e {
        Error::User(m) => Error::User(format!("min_probes: {min}: {m}")),
        e => e,
    })
}

/// Refuses a probe set of more than [`limits::MAX_PROBES`] probes, or one
/// whose scoring would take longer than the work limit, before the stages
/// that grow with it run (refinement and the SVO check their own work).
pub(crate) fn check_probes(config: &Config, prepared: &Prepared, n: usize) -> Result<()> {
    check_placed(config, prepared, n, None)
}

/// [`check_probes`] for `n` probes, at `placed.1` when they are placed
/// (over `placed.0`): the octree's bound is then counted by their
/// influences where it exceeds the limit ([`svo::check_placed_work`]).
fn check_placed(
    config: &Config,
    prepared: &Prepared,
    n: usize,
    placed: Option<(&PlacementInput, &[Vec3])>,
) -> Result<()> {
    check_count(n)?;
    // The octree's bound, before refinement and coverage run (the SVO
    // stage checks again with its probes' influences); its leaf grid is
    // the SDF's when `svo.leaf_size` is unset.
    let leaf = config
        .svo
        .leaf_size
        .map_or(prepared.sdf.voxel_size, |s| s.0);
    if let Ok(dims) = crate::sdf::grid_dims(&prepared.domain, leaf) {
        match placed {
            Some((input, positions)) => {
                svo::check_placed_work(&config.svo, dims, leaf, input, positions)?
            }
            None => svo::check_work(&config.svo, dims, n)?,
        }
    }
    check_scoring(config, n)
}

/// Refuses more than [`limits::MAX_PROBES`] probes.
fn check_count(n: usize) -> Result<()> {
    if n > limits::MAX_PROBES {
        return Err(Error::User(format!(
            "placement: {n} probes, over the limit of {} that the later stages finish in minutes; use a coarser placement",
            limits::MAX_PROBES
        )));
    }
    Ok(())
}

/// Refuses a diffuse step ([`refine::diffuse`]) that would take longer than
/// the work limit: its receivers' path-traced references, and the SH of
/// every probe it may hold and of as many candidates again (the placed
/// ones and at most `growth` times as many more, within the `controls`'
/// budget), `rays` paths each, of `1 + bake.bounces` vertices, each vertex
/// casting a shadow ray to every point, spot and directional light, the
/// config's and the scene file's ([`super::bake::lit_by_scene`]).
fn check_diffuse(
    config: &Config,
    scene: &crate::scene::Scene,
    placed: usize,
    controls: &Controls,
) -> Result<()> {
    let d = &config.refine.diffuse;
    let most = controls
        .max_probes
        .unwrap_or_else(|| (placed as f64 * (1.0 + d.growth.0 as f64)) as usize)
        .max(controls.min_probes.unwrap_or(0))
        .max(placed) as f64;
    let points = (d.surface_points.0 + d.free_points.0) as f64;
    let paths = (points + 2.0 * most) * d.rays.0 as f64;
    let lit = super::bake::lit_by_scene(config, scene);
    limits::check_work(
        "refine.diffuse.rays",
        &format!(
            "the diffuse step ({} receivers and up to {} probes and as many candidates at {} paths each, {} lights)",
            points, most, d.rays.0, lit.lights.len()
        ),
        paths * (1.0 + config.bake.bounces.0 as f64) * super::bake::light_factor(&lit),
        limits::rate::PATH_VERTICES,
    )
}

/// Refuses a probe set whose coverage scoring would take longer than the
/// work limit.
fn check_scoring(config: &Config, n: usize) -> Result<()> {
    limits::check_work(
        "coverage.samples",
        &format!(
            "scoring {n} probes against {} samples",
            config.coverage.samples.0
        ),
        coverage::evaluation_segments(&config.coverage, n),
        limits::rate::COVERAGE_SEGMENTS,
    )
}

/// Why pruning dropped all `placed` probes: a coverage target of 0 needs
/// none; a domain with no coverable surface (flat, or inside solid) gives
/// no probe anything to see; else no probe or fill candidate sees any
/// coverable sample. Each names the field to change.
fn pruned_all(config: &Config, reference: &CoverageReference, placed: usize) -> Error {
    let target = config.refine.coverage_target.0;
    let coverable = reference.coverable.iter().filter(|&&c| c).count();
    let undo = "or set refine.prune: false";
    Error::User(if target == 0.0 {
        format!(
            "refine.coverage_target: {} needs no probe, so pruning left none of the placement's {placed} probes; raise it, {undo}",
            short(target)
        )
    } else if coverable == 0 {
        format!(
            "domain: none of its {} surface samples can be seen from free space in it (is it flat, or inside solid?), so pruning left none of the placement's {placed} probes; check the domain, {undo}",
            reference.samples.len()
        )
    } else {
        format!(
            "refine.prune: no probe of the placement's {placed}, nor any fill candidate, sees any of the {coverable} coverable surface samples, so pruning left none; check the domain, {undo}"
        )
    })
}
