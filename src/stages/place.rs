//! The place stage: a placement method (Wang et al. 2019 §3.1, or a
//! baseline), refinement where the config asks for it (§3.3), the coverage
//! of the result (§2, §3.2) and the SVO of probe indices (§4.1).

use super::Prepared;
use crate::config::Config;
use crate::coverage::{self, Coverage, CoverageReference, ProbeHealth};
use crate::error::{Error, Result};
use crate::limits;
use crate::placement::{self, ProbeSet};
use crate::progress::{Progress, Stopwatch};
use crate::refine::{self, RefineReport};
use crate::svo::{self, Svo, SvoReport};
use glam::Vec3;

/// What the place stage produced.
pub struct Placed {
    /// The probes.
    pub probes: ProbeSet,
    /// Refinement's report and its atlas image; `None` when it was off.
    pub refined: Option<(RefineReport, image::RgbImage)>,
    /// Their coverage by the run's reference.
    pub coverage: Coverage,
    /// The coverable samples no probe sees.
    pub holes: Vec<Vec3>,
    /// Probes in solid, outside the scene or the domain.
    pub health: ProbeHealth,
    /// The octree of probe indices and its figures; `None` for an empty set.
    pub svo: Option<(Svo, SvoReport)>,
    /// `placement`, `refine`, `coverage`, `svo`.
    pub timings: Stopwatch,
}

/// Places probes with `config.placement` (or takes `given`, a probe set made
/// elsewhere, which is scored, not refined), refines them where
/// `config.refine.enabled`, and measures and indexes the result.
/// `reference` is the coverage measure refinement maximizes and the result
/// is scored by.
///
/// Contract: errors name the config field, not the file (the job prefixes
/// it); an empty probe set is returned without an SVO.
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
    let probes = match given {
        Some(p) => p,
        None => timings.try_time("placement", || placement::place(&config.placement, &input))?,
    };
    check_probes(config, probes.probes.len())?;
    let (probes, refined) = if refine_it {
        let out = timings.try_time("refine", || {
            refine::refine(&config.refine, probes, &input, reference)
        })?;
        (out.probes, Some((out.report, out.atlas_image)))
    } else {
        (probes, None)
    };
    check_probes(config, probes.probes.len())?;
    let positions = probes.positions();
    let ((coverage, holes), health) = timings.time("coverage", || {
        (
            reference.evaluate_with_holes(&prepared.bvh, &positions, progress),
            coverage::probe_health(&prepared.sdf, &prepared.domain, &positions),
        )
    });
    let svo = if positions.is_empty() {
        None
    } else {
        let baked = timings.try_time("svo", || svo::bake(&config.svo, &probes, &input))?;
        Some((baked.svo, baked.report))
    };
    Ok(Placed {
        probes,
        refined,
        coverage,
        holes,
        health,
        svo,
        timings,
    })
}

/// Refuses a probe set of more than [`limits::MAX_PROBES`] probes, or one
/// whose scoring would take longer than the work limit, before the stages
/// that grow with it run (refinement and the SVO check their own work).
fn check_probes(config: &Config, n: usize) -> Result<()> {
    if n > limits::MAX_PROBES {
        return Err(Error::User(format!(
            "placement: {n} probes, over the limit of {} that the later stages finish in minutes; use a coarser placement",
            limits::MAX_PROBES
        )));
    }
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
