//! Refinement: move probes to where they see the scene best, then keep the
//! fewest that see all of it (Wang et al. 2019 §3.2–3.3).
//!
//! | step | file | paper |
//! |---|---|---|
//! | visibility atlas: surface cut into near-uniform texels | [`atlas`] | §3.2, Fig. 4 |
//! | a probe's view: `V^k_ij`, Ω̄_k, d̄_k from its octahedral directions | [`view`] | §3.2 |
//! | fitness `R(P)` (eqs. 1–2, and a saturating variant) with per-texel accumulators | [`fitness`] | §3.3 |
//! | Gibbs sampling with stochastic direction steps | [`gibbs`] | §3.3, eq. 3, Fig. 6 |
//! | fill holes and prune superfluous probes, by the coverage measure | [`prune`] | §1 "fewest probes" |
//! | polish: move each probe to sharpen the views it serves | [`polish`] | McGuire 2017 §4; §3.3 eqs. 1–2 |
//! | top-up: spend a `min_probes` budget where views sharpen most | [`topup`] | §5.2 equal count; McGuire 2017 §4 |
//! | hold: drop probes in solid by their own rays; fresh rounds of samples, their holes filled | [`holdout`] | §2, §3.2 "full coverage" |
//!
//! The stage is [`refine`]: a placement's [`ProbeSet`] in, a refined one out,
//! with a [`RefineReport`] and the before/after atlas picture (Fig. 5).
//!
//! **Which fitness.** Eq. 2 as written sums each probe's score over the
//! texels it sees; probes do not compete, so every probe climbs towards the
//! same most-visible spots and the fitness says nothing about what the
//! *union* sees. The saturating variant credits each texel once, to its best
//! view, so a probe gains only by seeing what others miss or see worse. The
//! docs/method.md describes both; saturating is the default.

pub mod atlas;
pub(crate) mod cover;
pub mod diffuse;
pub mod fitness;
pub mod gibbs;
pub mod holdout;
pub mod polish;
pub mod prune;
pub mod topup;
pub mod view;

use crate::config::{FitnessKind, RefineParams};
use crate::coverage::{CoverageReference, Stream, REFERENCE_MIN_CLEARANCE_VOXELS};
use crate::error::Result;
use crate::placement::controls::Controls;
use crate::placement::{PlacementInput, Probe, ProbeSet};
use crate::progress::Stopwatch;
use crate::raster::RgbImage;
use crate::sampling::hash2;
use crate::scene::Bounds;
use crate::sdf::{Sdf, VoxelClass};
use atlas::Atlas;
use fitness::{AtlasState, AtlasSummary};
use gibbs::SweepStats;
use glam::Vec3;
use prune::{CoverMatrix, FillPrune, Rules};
use rayon::prelude::*;
use serde::Serialize;
use std::collections::BTreeMap;
use view::{ProbeView, Viewer};

/// Most pixels of each panel of `atlas.png`.
pub const ATLAS_PANEL_PIXELS: u32 = 1 << 20;

/// Colour of atlas texels some probe sees.
pub(crate) const SEEN: [u8; 3] = [70, 180, 95];
/// Colour of atlas texels no probe sees.
pub(crate) const UNSEEN: [u8; 3] = [225, 45, 40];

/// What refinement did, for `report.json` (docs/formats.md).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RefineReport {
    /// The fitness maximized.
    pub fitness: FitnessKind,
    /// Sweeps over all probes.
    pub iterations: u32,
    /// Proposals made.
    pub proposals: u64,
    /// Proposals accepted.
    pub accepted: u64,
    /// Proposals where a probe may not stand.
    pub rejected_illegal: u64,
    /// `R` of the input probes.
    pub r_initial: f64,
    /// `R` after the sweeps (the best set seen).
    pub r_refined: f64,
    /// `R` of the final probes.
    pub r_final: f64,
    /// Coverage of the input probes on the training samples
    /// ([`crate::coverage::Stream::Train`]: what filling and pruning fit).
    pub coverage_initial: f64,
    /// Training coverage after the sweeps, before filling and pruning.
    pub coverage_refined: f64,
    /// Training coverage of the final probes: a training score
    /// (`report.json`'s `coverage_train`).
    pub coverage_final: f64,
    /// Share of the atlas area the input probes see.
    pub atlas_coverage_initial: f64,
    /// Share of the atlas area the final probes see.
    pub atlas_coverage_final: f64,
    /// Mean incidence angle (degrees) of each covered sample's best view, input probes.
    pub best_view_incidence_deg_initial: Option<f64>,
    /// The same for the final probes.
    pub best_view_incidence_deg_final: Option<f64>,
    /// Probes in.
    pub probes_initial: usize,
    /// Probes out.
    pub probes_final: usize,
    /// Input probes removed by pruning.
    pub removed: usize,
    /// Probes added by filling and kept (`probes_final = probes_initial −
    /// removed + added`).
    pub added: usize,
    /// Final probes nearer to a surface than `params.min_clearance` (the
    /// placement's clearance): those filling had to add from a lower tier,
    /// because no position at that clearance sees what they see.
    pub probes_below_clearance: usize,
    /// Clearances of the fill tiers, in order (world units).
    pub clearance_tiers: Vec<f64>,
    /// Filling's rounds.
    pub fill_rounds: Vec<prune::FillRound>,
    /// Probes pruning kept before the `max_probes` budget cut them
    /// (`null` when it did not).
    pub probes_before_budget: Option<usize>,
    /// Probes the run had before the `min_probes` top-up added to them
    /// (`null` when it did not).
    pub probes_before_minimum: Option<usize>,
    /// The fresh rounds of samples the final probes were checked on and
    /// filled from ([`holdout`]), in order; empty without filling or under
    /// a `max_probes` budget.
    pub check_rounds: Vec<holdout::CheckRound>,
    /// Probes dropped for standing in solid by their own rays
    /// ([`crate::coverage::stands_free`]).
    pub probes_dropped_in_solid: usize,
    /// Fill candidates the same rays refused: judged all, and filling and
    /// pruning run again without the refused, when a position they kept
    /// failed; 0 when none did.
    pub candidates_refused: usize,
    /// Parameters as used, defaults resolved (lengths in world units).
    pub params: BTreeMap<&'static str, f64>,
}

/// The refined probes and what came with them.
pub struct Refined {
    /// The final probe set.
    pub probes: ProbeSet,
    /// What refinement did.
    pub report: RefineReport,
    /// The visibility atlas before (left) and after (right), as in the
    /// paper's Fig. 5: texels some probe sees in green, the rest in red.
    pub atlas_image: RgbImage,
    /// Wall time of refinement's steps, for `report.json`'s `timings_ms`
    /// ([`STEPS`]): where a long refinement spends it.
    pub steps: Stopwatch,
    /// Each final probe's column of the training coverage matrix (the
    /// coverable samples it sees), in probe order: what the diffuse step
    /// keeps coverage's floor by.
    pub(crate) columns: Vec<prune::Bits>,
}

/// The steps [`Refined::steps`] times, in order: the views and sweeps
/// (§3.3; the first check round's samples are judged beside them, on the
/// core the sweeps leave idle), filling and pruning on the training samples, the check rounds
/// on fresh ones ([`holdout`]), and the final views and atlas.
pub const STEPS: [&str; 4] = ["refine_sweeps", "refine_fill", "refine_rounds", "refine_finish"];

/// Refinement parameters with every default resolved.
struct Resolved {
    texel_size: f32,
    directions: u32,
    corner_directions: u32,
    initial_step: f32,
    min_step: f32,
    beta: f64,
    /// Clearances of the fill tiers, never empty: the first is the one
    /// probes move at (the placement's, or the pinned minimum if larger),
    /// the last the least clearance any probe may have.
    tiers: Vec<f32>,
    diagonal: f32,
}

impl Resolved {
    fn new(params: &RefineParams, probes: &ProbeSet, input: &PlacementInput) -> Resolved {
        let voxel = input.sdf.voxel_size;
        let clearance = input.sdf.largest_clearance().max(voxel);
        let n = params.directions.0;
        // The least clearance: the user's pin, or the coverage measure's
        // own reference clearance, at which every coverable sample is seen
        // by some candidate.
        let floor = params
            .min_clearance
            .map_or(REFERENCE_MIN_CLEARANCE_VOXELS * voxel, |c| c.0);
        let start = probes.min_clearance.max(floor);
        // Solid angle per direction ≈ 4π/n²: its footprint's edge at the
        // distance of the largest clearance.
        let spacing = (4.0 * std::f32::consts::PI).sqrt() / n as f32;
        Resolved {
            texel_size: params.texel_size.map_or(clearance * spacing, |t| t.0),
            directions: n,
            corner_directions: corner_directions(params),
            initial_step: params
                .initial_step
                .map_or((0.5 * clearance).max(voxel), |s| s.0),
            min_step: params.min_step.map_or(voxel, |s| s.0),
            beta: params
                .acceptance_exponent
                .map_or(probes.probes.len().max(1) as f64, |b| b.0 as f64),
            tiers: clearance_tiers(start, floor),
            diagonal: input.domain.size().length(),
        }
    }

    /// The clearance probes move at, and filling starts from.
    fn min_clearance(&self) -> f32 {
        self.tiers[0]
    }

    fn report(&self, params: &RefineParams, texels: usize) -> BTreeMap<&'static str, f64> {
        BTreeMap::from([
            ("texel_size", self.texel_size as f64),
            ("atlas_texels", texels as f64),
            ("directions", self.directions as f64),
            ("corner_directions", self.corner_directions as f64),
            ("initial_step", self.initial_step as f64),
            ("min_step", self.min_step as f64),
            ("acceptance_exponent", self.beta),
            ("min_clearance", self.min_clearance() as f64),
            (
                "min_fill_clearance",
                self.tiers[self.tiers.len() - 1] as f64,
            ),
            ("coverage_target", params.coverage_target.0 as f64),
            ("w_orientation", params.w_orientation.0 as f64),
            ("w_distance", params.w_distance.0 as f64),
        ])
    }
}

/// The side of the corners' direction map ([`RefineParams::corner_directions`]).
fn corner_directions(params: &RefineParams) -> u32 {
    let n = params.directions.0;
    params
        .corner_directions
        .map_or((n / 2).max(8).min(n), |c| c.0)
}

/// Whether a probe may stand at `p`: inside the domain, in a free voxel,
/// and at least `min_clearance` from every surface (bounded from below by
/// the voxel centre's distance minus the offset from it).
pub fn may_stand(sdf: &Sdf, domain: &Bounds, min_clearance: f32, p: Vec3) -> bool {
    if !domain.contains(p) {
        return false;
    }
    let Some(v) = sdf.voxel_at(p) else {
        return false;
    };
    sdf.class[v] == VoxelClass::Free
        && sdf.distance[v] - (p - sdf.center(v)).length() >= min_clearance
}

/// Refines `probes` (module docs), placed from `input`, against the
/// coverage measure's `reference`: sweeps of Gibbs sampling over the atlas
/// fitness, then filling and pruning against the coverage measure.
///
/// Refuses a step of refinement whose estimate exceeds the work limit:
/// the sweeps before the first ([`sweep_core_seconds`]), filling and
/// pruning once the sweeps have moved the probes ([`fill_core_seconds`]),
/// and the check rounds on the probes filling kept
/// ([`rounds_core_seconds`]). Each step is judged when what it costs can
/// be counted, as the SDF, the coverage reference and the SVO are before
/// theirs; one estimate of the three made before the sweeps refused a
/// 4M-triangle tiled Sponza (9 min) that refines in 47 s.
fn check_work(step: &str, what: String, core_seconds: f64) -> Result<()> {
    crate::limits::check_work(step, &what, core_seconds, 1.0)
}

/// Core-seconds the Gibbs sweeps over `probes` probes and an atlas of
/// `texels` texels may take at most, by the rates of
/// [`crate::limits::rate`]: every probe's step in every sweep traces the
/// views of its eight corners and of its proposal
/// ([`crate::limits::rate::REFINE_RAYS`]), and updates the texels its view
/// lands on, each shared with the other probes that see it
/// ([`crate::limits::rate::REFINE_TEXEL_UPDATES`]).
///
/// The probes sharing a texel are what all views together land on
/// (`probes × directions²`) over the texels they can reach (the atlas, or
/// fewer): hundreds in a small room (the Cornell box, where every probe
/// sees every wall), a few in a large scene, where each probe sees its own
/// part. The estimate before grew as `probes^1.5` times the texels reached,
/// the dense room's law applied to every scene: it put a 1M-triangle tiled
/// Sponza at half the `Auto` voxel at 50 min, which refines in 17 s.
pub(crate) fn sweep_core_seconds(params: &RefineParams, probes: usize, texels: usize) -> f64 {
    use crate::limits::rate;
    let n = probes as f64;
    let d2 = (params.directions.0 as f64).powi(2);
    let rays = 8.0 * (corner_directions(params) as f64).powi(2) + d2;
    let reached = (texels as f64).min(n * d2).max(1.0);
    let sharing = (n * d2 / reached).clamp(1.0, n.max(1.0));
    let steps = n * params.iterations.0 as f64;
    steps * rays / rate::REFINE_RAYS + steps * d2 * sharing / rate::REFINE_TEXEL_UPDATES
}

/// Core-seconds filling and pruning `probes` probes against `samples`
/// coverage samples may take: every sample is judged from every probe and
/// from the candidates near it, but only the pairs that face each other
/// cast a segment, so the views count as the share of them that do
/// (`facing`, counted by [`facing_share`];
/// [`crate::limits::rate::REFINE_FACING_VIEWS`]). In the Cornell box most
/// pairs face (85%); in a tiled or furnished interior a third do. Counting
/// every pair at the Cornell box's rate put the 4M-triangle tiled Sponza's
/// filling at 6 min; it took 14 s.
///
/// The probes filling adds are not counted: how many a scene needs is
/// known only once it has filled. Filling grows a block world's set from
/// 69 probes to 329 (BENCHMARKS.md, issue 47), and its estimate falls
/// short there; the check rounds after it, which grow sets most, are
/// judged on the filled set ([`rounds_core_seconds`]).
pub(crate) fn fill_core_seconds(probes: usize, samples: usize, facing: f64) -> f64 {
    samples as f64 * (probes as f64 + 16.0) * facing / crate::limits::rate::REFINE_FACING_VIEWS
}

/// Core-seconds the check rounds ([`holdout::hold`]) may take on the
/// `probes` probes filling kept: at most [`crate::coverage::MAX_CHECK_ROUNDS`]
/// rounds, each judging about `samples` fresh samples from every probe as
/// filling does ([`fill_core_seconds`]), and filling again. Their fresh
/// samples' judgement against the reference points is the coverage
/// measure's, bounded with it ([`crate::coverage::check_work`]).
pub(crate) fn rounds_core_seconds(probes: usize, samples: usize, facing: f64) -> f64 {
    crate::coverage::MAX_CHECK_ROUNDS as f64 * fill_core_seconds(probes, samples, facing)
}

/// Coverable samples [`facing_share`] counts on.
const PILOT_SAMPLES: usize = 64;

/// Of the pairs of one of `matrix`'s coverable samples and one of
/// `probes`, the share that face each other ([`CoverMatrix::faces_sample`]:
/// the pairs a coverage test casts a segment for), counted on
/// [`PILOT_SAMPLES`] samples spread evenly over them: 64 × 4 471 pairs on
/// the 4M-triangle tiled Sponza. 1 when there is nothing to count.
pub(crate) fn facing_share(matrix: &CoverMatrix, probes: &[Vec3]) -> f64 {
    let k = PILOT_SAMPLES.min(matrix.len());
    if k == 0 || probes.is_empty() {
        return 1.0;
    }
    let facing: usize = (0..k)
        .map(|j| {
            let i = j * matrix.len() / k;
            probes.iter().filter(|&&p| matrix.faces_sample(p, i)).count()
        })
        .sum();
    facing as f64 / (k * probes.len()) as f64
}

/// The artist `controls` ([`crate::placement::controls`]) hold throughout:
/// the first `probes.fixed` probes never move and are never pruned, no
/// probe moves into or is added in an `exclude` box, filling and pruning
/// meet each sample's `probe_density` demand, and at most `max_probes`
/// probes come out.
///
/// Contract: deterministic for the same inputs and `input.seed`; no probe
/// moves to or is added at a position where [`may_stand`] fails, and no
/// probe moves through a surface; if the input probes, or filling, reach
/// `coverage_target`, the output does too (unless the budget cuts it).
/// Errors: an atlas over [`atlas::MAX_TEXELS`] texels (a user error naming
/// `refine.texel_size`).
pub fn refine(
    params: &RefineParams,
    probes: ProbeSet,
    input: &PlacementInput,
    reference: &CoverageReference,
    controls: &Controls,
) -> Result<Refined> {
    let mut steps = Stopwatch::new(false);
    let r = Resolved::new(params, &probes, input);
    let atlas = Atlas::new(input.scene, r.texel_size)?;
    check_work(
        "refine",
        format!(
            "sweeping {} probes ({} sweeps, {}² directions, {} atlas texels)",
            probes.probes.len(),
            params.iterations.0,
            params.directions.0,
            atlas.len()
        ),
        sweep_core_seconds(params, probes.probes.len(), atlas.len()),
    )?;
    let min_cos = reference.min_cos();
    let viewer_of = |directions: u32| {
        Viewer::new(
            input.scene,
            input.bvh,
            &atlas,
            directions,
            min_cos,
            params.w_orientation.0,
            params.w_distance.0,
            r.diagonal,
        )
    };
    let viewer = viewer_of(r.directions);
    let corner_viewer = viewer_of(r.corner_directions);
    let views_of = |ps: &[Vec3]| -> Vec<ProbeView> { ps.iter().map(|&p| viewer.view(p)).collect() };

    // Move the probes (§3.3).
    let initial = probes.positions();
    let mut state = AtlasState::new(params.fitness, &atlas, views_of(&initial));
    let r_initial = state.r();
    let atlas_initial = seen_texels(&atlas, &state);
    let atlas_coverage_initial = state.seen_share();
    let matrix = CoverMatrix::new(reference, input.bvh).with_need(|i, p| controls.need(i, p));
    // The report's coverage of the input probes, and the first check
    // round's samples (which depend on no probe), are measured while the
    // sweeps run: their steps leave a core idle between parallel views.
    let rounds_run = params.fill && controls.max_probes.is_none();
    let ((refined, stats), (summary_initial, first_round)) = rayon::join(
        || {
            sweep(
                params,
                &r,
                input,
                controls,
                probes.fixed,
                (&viewer, &corner_viewer, &mut state),
                &initial,
            )
        },
        || {
            rayon::join(
                || matrix.summary(&initial),
                || {
                    rounds_run
                        .then(|| reference.resampled(input, &reference.params, Stream::Check(0)))
                },
            )
        },
    );
    // The sweeps' state (per atlas texel: its viewers and their
    // qualities, over 400 MB on a 4M-triangle scene) goes when they end:
    // nothing after needs more than the views' fitness and an
    // [`AtlasSummary`], and alive it was most of refinement's peak
    // (BENCHMARKS.md, issue 47: peak memory).
    drop(state);
    let r_refined = fitness::fitness_of(params.fitness, &atlas, &views_of(&refined));
    steps.lap(STEPS[0]);

    // Fill holes and prune superfluous probes (§1 "fewest probes").
    let facing = facing_share(&matrix, &refined);
    check_work(
        "refine",
        format!(
            "filling and pruning {} probes against {} coverage samples ({:.0}% of pairs facing)",
            refined.len(),
            reference.samples.len(),
            100.0 * facing
        ),
        fill_core_seconds(refined.len(), reference.samples.len(), facing),
    )?;
    let mut tiers = fill_candidates(params, &r, input, reference, controls);
    let rules = Rules {
        pinned: probes.fixed,
        budget: controls.max_probes,
        // With the diffuse objective, its step spends `min_probes` where
        // the blended light needs probes (crate::refine::diffuse).
        minimum: match params.objective {
            crate::config::Objective::Both => None,
            crate::config::Objective::Coverage => controls.min_probes,
        },
    };
    let fill_and_prune = |tiers: &[Vec<Vec3>]| {
        matrix.fill_and_prune(
            &refined,
            tiers,
            params.coverage_target.0 as f64,
            params.fill,
            params.prune,
            rules,
            input.progress,
        )
    };
    let mut fp = fill_and_prune(&tiers);
    let mut candidates_refused = 0;
    if !refused_additions(input, &refined, &fp).is_empty() {
        // Where one kept position fails, others will (block worlds: a
        // dozen a round): judge every candidate, and fill and prune again.
        for tier in &mut tiers {
            let before = tier.len();
            *tier = tier
                .par_iter()
                .copied()
                .filter(|&p| crate::coverage::stands_free(input.bvh, input.sdf.voxel_size, p))
                .collect();
            candidates_refused += before - tier.len();
        }
        fp = fill_and_prune(&tiers);
    }
    steps.lap(STEPS[1]);
    let rounds = hold(
        &holdout::HoldInput {
            input,
            training: reference,
            params: &reference.params,
            tiers: &tiers,
            target: params.coverage_target.0 as f64,
            need: &|i, p| controls.need(i, p),
            fill: rounds_run,
            first_round: first_round.as_ref(),
        },
        &matrix,
        (&refined, probes.fixed),
        &mut fp,
    )?;
    steps.lap(STEPS[2]);
    let final_probes = kept_probes(&probes, &refined, &fp);
    let final_positions: Vec<Vec3> = final_probes.iter().map(|p| p.position).collect();
    let final_state = AtlasSummary::new(params.fitness, &atlas, &views_of(&final_positions));

    let outcome = RefineSteps {
        stats,
        summary_initial,
        r_initial,
        r_refined,
        atlas_coverage_initial,
        initial: &initial,
        final_positions: &final_positions,
        final_state: &final_state,
        fp: &fp,
        atlas_texels: atlas.len(),
        rounds,
        candidates_refused,
    };
    let report = refine_report(params, &r, &matrix, &outcome);
    let atlas_image = atlas_panels(&atlas, &atlas_initial, &final_state);
    steps.lap(STEPS[3]);
    Ok(Refined {
        probes: ProbeSet {
            method: format!("{}+refine", probes.method),
            probes: final_probes,
            stats: probes.stats,
            params: probes.params,
            min_clearance: final_min_clearance(&r, &fp),
            fixed: probes.fixed,
        },
        report,
        atlas_image,
        steps,
        columns: fp.kept_cols,
    })
}

/// Whether some probe of `state` sees each texel of `atlas`.
fn seen_texels(atlas: &Atlas, state: &AtlasState) -> Vec<bool> {
    (0..atlas.len())
        .map(|t| state.best_quality(t).is_some())
        .collect()
}

/// Gibbs sampling with stochastic direction steps (§3.3, eq. 3, Fig. 6)
/// from the `initial` positions, whose views `state` holds: a probe may move
/// only to where it may stand at the clearance probes move at, and not
/// through a surface. Returns the best positions seen and what the sweeps did.
fn sweep(
    params: &RefineParams,
    r: &Resolved,
    input: &PlacementInput,
    controls: &Controls,
    pinned: usize,
    (viewer, corner_viewer, state): (&Viewer, &Viewer, &mut AtlasState),
    initial: &[Vec3],
) -> (Vec<Vec3>, SweepStats) {
    let eps = 1e-3 * input.sdf.voxel_size;
    let legal_move = |a: Vec3, b: Vec3| -> bool {
        may_stand(input.sdf, input.domain, r.min_clearance(), b)
            && !controls.excluded(b)
            && !input.bvh.occluded(a, b, eps)
    };
    let sweeps = gibbs::Sweeps {
        viewer,
        corner_viewer,
        legal_move: &legal_move,
        iterations: params.iterations.0,
        patience: params.patience.0,
        initial_step: r.initial_step,
        min_step: r.min_step,
        beta: r.beta,
        seed: hash2(input.seed, 0x5EF1),
        pinned,
    };
    let mut positions = initial.to_vec();
    gibbs::optimize(&sweeps, state, &mut positions, input.progress)
}

/// Runs [`holdout::hold`] on the probes `fp` kept (of the input positions
/// `refined`, the first `pinned` of them fixed) and folds what it did into
/// `fp`: the dropped probes out of `kept`, the added ones appended to
/// `added` and `kept`, their training columns (by `matrix`) computed, and
/// `covered_final` counted again. Returns the rounds and how many probes
/// were dropped; refuses rounds whose estimate exceeds the work limit
/// ([`rounds_core_seconds`]).
fn hold(
    h: &holdout::HoldInput,
    matrix: &CoverMatrix,
    (refined, pinned): (&[Vec3], usize),
    fp: &mut FillPrune,
) -> Result<(Vec<holdout::CheckRound>, usize)> {
    let all = |k: usize| {
        if k < refined.len() {
            refined[k]
        } else {
            fp.added[k - refined.len()]
        }
    };
    let positions: Vec<Vec3> = fp.kept.iter().map(|&k| all(k)).collect();
    let fixed = fp.kept.iter().filter(|&&k| k < pinned).count();
    if h.fill {
        let samples = h.training.samples.len();
        let facing = facing_share(matrix, &positions);
        check_work(
            "refine",
            format!(
                "checking {} probes on up to {} rounds of {samples} fresh coverage samples ({:.0}% of pairs facing)",
                positions.len(),
                crate::coverage::MAX_CHECK_ROUNDS,
                100.0 * facing
            ),
            rounds_core_seconds(positions.len(), samples, facing),
        )?;
    }
    let held = holdout::hold(h, &positions, fixed);
    if held.dropped.is_empty() && held.added.is_empty() {
        return Ok((held.rounds, 0));
    }
    let keep: Vec<bool> = (0..positions.len())
        .map(|k| !held.dropped.contains(&k))
        .collect();
    fn retain<T>(v: &mut Vec<T>, keep: &[bool]) {
        let mut i = 0;
        v.retain(|_| {
            i += 1;
            keep[i - 1]
        });
    }
    retain(&mut fp.kept, &keep);
    retain(&mut fp.kept_tiers, &keep);
    retain(&mut fp.kept_cols, &keep);
    let added: Vec<Vec3> = held.added.iter().map(|&(p, _)| p).collect();
    for ((p, t), col) in held.added.iter().zip(matrix.columns(&added)) {
        fp.added.push(*p);
        fp.kept.push(refined.len() + fp.added.len() - 1);
        fp.kept_tiers.push(*t);
        fp.kept_cols.push(col);
    }
    let mut count = vec![0u32; matrix.len()];
    for c in &fp.kept_cols {
        for i in prune::ones(c) {
            count[i] += 1;
        }
    }
    fp.covered_final = matrix.satisfied(&count);
    Ok((held.rounds, held.dropped.len()))
}

/// The probes filling and pruning kept: the input probes at their `refined`
/// positions (with their cluster sizes) followed by those filling added
/// (cluster size 0), in the order of `fp.kept`.
fn kept_probes(probes: &ProbeSet, refined: &[Vec3], fp: &FillPrune) -> Vec<Probe> {
    let mut all: Vec<Probe> = probes
        .probes
        .iter()
        .zip(refined)
        .map(|(p, &position)| Probe {
            position,
            cluster_size: p.cluster_size,
        })
        .collect();
    all.extend(fp.added.iter().map(|&position| Probe {
        position,
        cluster_size: 0,
    }));
    fp.kept.iter().map(|&k| all[k]).collect()
}

/// The least clearance of the final probes: that of the lowest fill tier a
/// kept probe came from, or the one probes move at.
fn final_min_clearance(r: &Resolved, fp: &FillPrune) -> f32 {
    fp.kept_tiers
        .iter()
        .map(|&t| r.tiers[t])
        .fold(r.min_clearance(), f32::min)
}

/// What the steps of [`refine`] produced, for its report.
struct RefineSteps<'a> {
    /// What the sweeps did.
    stats: SweepStats,
    /// The input probes' [`CoverMatrix::summary`].
    summary_initial: (usize, Option<f64>),
    /// `R` of the input probes.
    r_initial: f64,
    /// `R` of the best set the sweeps saw.
    r_refined: f64,
    /// Share of the atlas area the input probes see.
    atlas_coverage_initial: f64,
    /// Positions of the input probes.
    initial: &'a [Vec3],
    /// Positions of the final probes.
    final_positions: &'a [Vec3],
    /// The atlas seen by the final probes.
    final_state: &'a AtlasSummary,
    /// What filling and pruning did.
    fp: &'a FillPrune,
    /// Texels of the atlas.
    atlas_texels: usize,
    /// The fresh rounds of samples and how many probes their judge dropped.
    rounds: (Vec<holdout::CheckRound>, usize),
    /// Fill positions refused by their own rays ([`refused_additions`]).
    candidates_refused: usize,
}

/// The [`RefineReport`] of `outcome`, its coverages measured by `matrix`.
fn refine_report(
    params: &RefineParams,
    r: &Resolved,
    matrix: &CoverMatrix,
    outcome: &RefineSteps,
) -> RefineReport {
    let (stats, fp, initial) = (outcome.stats, outcome.fp, outcome.initial);
    let m = fp.coverable.max(1) as f64;
    let (covered_initial, incidence_initial) = outcome.summary_initial;
    let added_kept = fp.kept.iter().filter(|&&k| k >= initial.len()).count();
    let probes_final = outcome.final_positions.len();
    RefineReport {
        fitness: params.fitness,
        iterations: stats.iterations,
        proposals: stats.proposals,
        accepted: stats.accepted,
        rejected_illegal: stats.illegal,
        r_initial: outcome.r_initial,
        r_refined: outcome.r_refined,
        r_final: outcome.final_state.r(),
        coverage_initial: covered_initial as f64 / m,
        coverage_refined: fp.covered_initial as f64 / m,
        coverage_final: fp.covered_final as f64 / m,
        atlas_coverage_initial: outcome.atlas_coverage_initial,
        atlas_coverage_final: outcome.final_state.seen_share(),
        best_view_incidence_deg_initial: incidence_initial,
        best_view_incidence_deg_final: matrix.summary_of(outcome.final_positions, &fp.kept_cols).1,
        probes_initial: initial.len(),
        probes_final,
        removed: initial.len() - (probes_final - added_kept),
        added: added_kept,
        probes_below_clearance: fp.kept_tiers.iter().filter(|&&t| t > 0).count(),
        clearance_tiers: r.tiers.iter().map(|&c| c as f64).collect(),
        fill_rounds: fp.rounds.clone(),
        probes_before_budget: fp.before_budget,
        probes_before_minimum: fp.before_minimum,
        check_rounds: outcome.rounds.0.clone(),
        probes_dropped_in_solid: outcome.rounds.1,
        candidates_refused: outcome.candidates_refused,
        params: r.report(params, outcome.atlas_texels),
    }
}

/// The visibility atlas before (left) and after (right), as in the paper's
/// Fig. 5: texels some probe sees in green, the rest in red. `seen_before`
/// says which texels the input probes see, `after` holds the final probes.
fn atlas_panels(atlas: &Atlas, seen_before: &[bool], after: &AtlasSummary) -> RgbImage {
    let color = |seen: bool| if seen { SEEN } else { UNSEEN };
    let layout = atlas.layout(ATLAS_PANEL_PIXELS);
    let before = atlas.paint(&layout, |t| color(seen_before[t as usize]));
    let after = atlas.paint(&layout, |t| color(after.sees(t as usize)));
    side_by_side(&before, &after)
}

/// Clearances of the fill tiers: `start`, halved until it reaches `floor`,
/// which ends the list (one tier when `start <= floor`).
fn clearance_tiers(start: f32, floor: f32) -> Vec<f32> {
    let mut tiers = vec![start.max(floor)];
    while let Some(&last) = tiers.last() {
        if last <= floor * (1.0 + 1e-4) {
            break;
        }
        tiers.push((0.5 * last).max(floor));
    }
    tiers
}

/// Positions filling may add a probe at, one list per clearance tier of
/// `r.tiers`: in tier `t`, the positions where a probe may stand at tier
/// `t`'s clearance but not at the tier before's. Each tier holds the
/// coverage reference points of its band (in the last tier, at the
/// coverage measure's own clearance, every reference point is a candidate
/// of some tier, and every coverable sample is seen by one of them), then
/// up to `fill_candidates` other free voxel centres of its band where a
/// probe may stand, chosen by a seeded hash: free by the SDF, not yet by
/// rays of their own ([`refused_additions`] judges those that filling
/// keeps, and [`refine`] all of them when one fails). None lies in an
/// `exclude` box of `controls`.
fn fill_candidates(
    params: &RefineParams,
    r: &Resolved,
    input: &PlacementInput,
    reference: &CoverageReference,
    controls: &Controls,
) -> Vec<Vec<Vec3>> {
    let tier_of = |p: Vec3| candidate_tier(r, input, controls, p);
    let mut tiers: Vec<Vec<Vec3>> = vec![Vec::new(); r.tiers.len()];
    for &p in &reference.references {
        if let Some(t) = reference_tier(r, input, controls, p) {
            tiers[t].push(p);
        }
    }
    // Each voxel's tier, found in parallel (a serial scan of every voxel
    // was 3% of Sponza's run), in two bytes: the tiers halve an f32
    // clearance, so there are fewer than 300 of them.
    const NO_TIER: u16 = u16::MAX;
    let voxel_tier: Vec<u16> = (0..input.sdf.len())
        .into_par_iter()
        .with_min_len(4096)
        .map(|v| tier_of(input.sdf.center(v)).map_or(NO_TIER, |t| t as u16))
        .collect();
    let mut voxels: Vec<Vec<(u64, usize)>> = vec![Vec::new(); r.tiers.len()];
    for (v, &t) in voxel_tier.iter().enumerate() {
        if t != NO_TIER {
            voxels[t as usize].push((hash2(hash2(input.seed, 0xF111), v as u64), v));
        }
    }
    for (tier, mut band) in tiers.iter_mut().zip(voxels) {
        crate::sampling::keep_least(&mut band, params.fill_candidates.0 as usize);
        tier.extend(band.iter().map(|&(_, v)| input.sdf.center(v)));
    }
    tiers
}

/// The positions filling and pruning kept (`fp`, whose indices run over
/// `refined` and then its additions) that [`crate::coverage::stands_free`]
/// refuses, of those it added (the refined probes are judged after,
/// [`holdout::hold`]): the voxel candidates are free by the SDF only, and
/// a final probe must be free by its own rays. Judging the few positions
/// kept first, and every candidate (thousands, 128 rays each: a tenth of
/// Sponza's run) only when one of them fails, costs a second fill and
/// prune where the SDF and the rays disagree, and nothing elsewhere.
fn refused_additions(input: &PlacementInput, refined: &[Vec3], fp: &FillPrune) -> Vec<Vec3> {
    fp.kept
        .par_iter()
        .filter_map(|&k| k.checked_sub(refined.len()).map(|a| fp.added[a]))
        .filter(|&p| !crate::coverage::stands_free(input.bvh, input.sdf.voxel_size, p))
        .collect()
}

/// The first fill tier of `r.tiers` at whose clearance a probe may stand
/// at `p` ([`may_stand`]), `None` where none may or an `exclude` box of
/// `controls` holds it.
fn candidate_tier(
    r: &Resolved,
    input: &PlacementInput,
    controls: &Controls,
    p: Vec3,
) -> Option<usize> {
    if controls.excluded(p) {
        return None;
    }
    r.tiers
        .iter()
        .position(|&c| may_stand(input.sdf, input.domain, c, p))
}

/// [`candidate_tier`] of a coverage reference point, which is free by its
/// own rays ([`crate::coverage::free_points`]): the first tier whose
/// clearance it keeps by the measure's own distance
/// ([`crate::coverage::surface_distance`]), whatever the SDF's class says, so that every coverable sample stays in sight of some
/// candidate of the last tier (two reference points see it).
fn reference_tier(
    r: &Resolved,
    input: &PlacementInput,
    controls: &Controls,
    p: Vec3,
) -> Option<usize> {
    if controls.excluded(p) || !input.domain.contains(p) {
        return None;
    }
    let clearance = crate::coverage::surface_distance(input.sdf, p);
    r.tiers.iter().position(|&c| clearance >= c)
}

/// Two panels side by side with a dark gap, top-aligned.
fn side_by_side(a: &RgbImage, b: &RgbImage) -> RgbImage {
    let gap = 8;
    let mut img = RgbImage::from_pixel(
        a.width() + gap + b.width(),
        a.height().max(b.height()),
        [0, 0, 0],
    );
    img.replace(a, 0, 0);
    img.replace(b, a.width() + gap, 0);
    img
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The sweeps' estimate holds what they were measured to take, on the
    /// dense room its sharing term comes from and on a large scene its ray
    /// term comes from, and accepts the large scene on two threads (the
    /// estimate before put it at 50 min).
    #[test]
    fn the_sweeps_estimate_bounds_the_measured_runs_and_admits_large_scenes() {
        let p = RefineParams::default();
        // The Cornell box, grid:32x32x1: 1 024 probes seeing all of 4 216
        // texels, 20 sweeps in 32.7 s on 2 threads (BENCHMARKS.md, "Limits").
        let room = sweep_core_seconds(&p, 1024, 4216);
        assert!(room >= 2.0 * 32.7, "{room}");
        // Sponza tiled 4×4 at half its Auto voxel: 7.0 s of sweeps on 2
        // threads, 6 sweeps of 20 (BENCHMARKS.md, issue 47).
        let tiled = sweep_core_seconds(&p, 1227, 2_265_600);
        assert!(tiled >= 2.0 * 7.0 * 20.0 / 6.0, "{tiled}");
        assert!(tiled <= 2.0 * crate::limits::WORK_LIMIT_SECONDS, "{tiled}");
        // More probes cost more, and the most a config allows is refused.
        assert!(sweep_core_seconds(&p, 2454, 2_265_600) > tiled);
        let most = sweep_core_seconds(&p, crate::limits::MAX_PROBES, 4216);
        assert!(most > 64.0 * crate::limits::WORK_LIMIT_SECONDS, "{most}");
    }

    /// Filling's and the check rounds' estimates count the pairs that
    /// face: they hold the runs their rate comes from, admit the
    /// 4M-triangle tiled Sponza (a third of its pairs facing) that counting
    /// every pair refused, and still refuse the most probes a config allows.
    #[test]
    fn the_fill_and_rounds_estimates_count_facing_pairs() {
        let limit = 2.0 * crate::limits::WORK_LIMIT_SECONDS;
        // Cornell: 1 038 817 samples, 10 probes, 85% of the pairs facing;
        // filling took 3.9 s on 2 threads (BENCHMARKS.md, issue 47).
        assert!(fill_core_seconds(10, 1_038_817, 0.85) >= 2.0 * 3.9);
        // Sponza tiled 8×8 at Auto: 4 471 probes, 71 389 samples, 36% of
        // the pairs facing; filling took 14 s on 2 threads.
        let tiled = fill_core_seconds(4471, 71_389, 0.36);
        assert!(tiled >= 2.0 * 14.0, "{tiled}");
        assert!(tiled <= limit / 4.0, "{tiled}");
        assert_eq!(fill_core_seconds(4471, 71_389, 0.0), 0.0);
        assert!(fill_core_seconds(4471, 71_389, 1.0) > fill_core_seconds(4471, 71_389, 0.5));
        // Its check rounds: about 780 probes after filling, 13.6 s; the 2M
        // voxel world's: about 750 probes, 77 697 samples, 47% facing, 32 s.
        assert!(rounds_core_seconds(780, 71_389, 0.36) >= 2.0 * 13.6);
        assert!(rounds_core_seconds(750, 77_697, 0.47) >= 2.0 * 32.0);
        assert!(rounds_core_seconds(750, 77_697, 0.47) <= limit);
        let most = crate::limits::MAX_PROBES;
        assert!(fill_core_seconds(most, 71_389, 0.36) > limit);
        assert!(rounds_core_seconds(most, 71_389, 0.36) > 8.0 * limit);
    }

    /// The pilot counts the pairs that face: a sample on a floor faces a
    /// probe above it and not one below, and the share is of all pairs.
    #[test]
    fn the_pilot_counts_the_pairs_that_face() {
        use crate::coverage::SurfaceSample;
        let sample = |x: f32| SurfaceSample {
            position: Vec3::new(x, 0.0, 0.0),
            normal: Vec3::Y,
        };
        let reference = crate::coverage::reference_of((0..10).map(|i| sample(i as f32)).collect());
        let (_, bvh, _) = crate::scene::testing::room_sdf(0.5, 1);
        let matrix = CoverMatrix::new(&reference, &bvh);
        let above = Vec3::new(4.5, 5.0, 0.0);
        let below = Vec3::new(4.5, -5.0, 0.0);
        assert_eq!(facing_share(&matrix, &[above]), 1.0);
        assert_eq!(facing_share(&matrix, &[below]), 0.0);
        assert_eq!(facing_share(&matrix, &[above, below, below, below]), 0.25);
        assert_eq!(facing_share(&matrix, &[]), 1.0);
    }
    use crate::config::Count;

    /// Of the probes filling and pruning kept, only the added ones are
    /// judged, and exactly those whose own rays call them solid are
    /// refused: one inside the room's box, not one in the open, nor a
    /// refined probe (which [`holdout::hold`] judges).
    #[test]
    fn refused_additions_are_the_kept_additions_in_solid() {
        use crate::progress::Progress;
        use crate::scene::testing::{input_over, room_sdf};
        let (scene, bvh, sdf) = room_sdf(0.25, 2);
        let hidden = Progress::hidden();
        let input = input_over(&scene, &bvh, &sdf, 5, &hidden);
        let (open, other, inside) = (
            Vec3::new(3.0, 2.0, 3.0),
            Vec3::new(0.5, 3.0, 0.5),
            Vec3::new(1.5, 0.5, 1.5),
        );
        let fp = |kept: Vec<usize>| FillPrune {
            kept_tiers: vec![0; kept.len()],
            kept,
            added: vec![other, inside, inside + 0.1],
            rounds: Vec::new(),
            covered_initial: 0,
            covered_final: 0,
            coverable: 0,
            before_budget: None,
            before_minimum: None,
            kept_cols: Vec::new(),
        };
        let refined = [inside, open];
        assert_eq!(
            refused_additions(&input, &refined, &fp(vec![0, 1, 2, 3])),
            vec![inside]
        );
        assert!(refused_additions(&input, &refined, &fp(vec![0, 1, 2])).is_empty());
        assert_eq!(
            refused_additions(&input, &refined, &fp(vec![3, 4])),
            vec![inside, inside + 0.1]
        );
    }

    #[test]
    fn corners_take_half_the_directions_within_bounds_unless_set() {
        let with = |directions: u32, corners: Option<u32>| {
            corner_directions(&RefineParams {
                directions: Count(directions),
                corner_directions: corners.map(Count),
                ..RefineParams::default()
            })
        };
        assert_eq!(with(32, None), 16);
        assert_eq!(with(33, None), 16);
        assert_eq!(with(12, None), 8, "at least 8");
        assert_eq!(with(6, None), 6, "never more than the proposal's");
        assert_eq!(with(32, Some(32)), 32);
        assert_eq!(with(16, Some(24)), 24, "a set value stands");
    }

    /// Patience only ends the sweeps early: the sweeps a run makes are the
    /// first sweeps of a more patient run, so a more patient run sweeps at
    /// least as long and keeps a best set at least as good, and two runs
    /// that swept as long return the same probes.
    #[test]
    fn patience_ends_the_sweeps_early_and_changes_nothing_else() {
        use crate::config::{CoverageParams, Degrees, Placement, SdfSkeletonParams};
        use crate::progress::Progress;
        use crate::scene::testing::{place_in, room_sdf};
        let (scene, bvh, sdf) = room_sdf(0.25, 2);
        let coverage = CoverageParams {
            samples: Count(3000),
            reference_points: Count(256),
            max_incidence_deg: Degrees(85.0),
        };
        let hidden = Progress::hidden();
        let reference = CoverageReference::new(&scene, &bvh, &sdf, &coverage, 2, &hidden);
        let method = Placement::SdfSkeleton(SdfSkeletonParams::default());
        let placed = place_in(&method, &scene, &bvh, &sdf).unwrap();
        let input = PlacementInput {
            scene: &scene,
            bvh: &bvh,
            sdf: &sdf,
            domain: &scene.bounds,
            seed: 3,
            progress: &hidden,
        };
        let run = |patience: u32| {
            let params = RefineParams {
                iterations: Count(40),
                patience: Count(patience),
                ..RefineParams::default()
            };
            refine(
                &params,
                placed.clone(),
                &input,
                &reference,
                &Controls::default(),
            )
            .unwrap()
        };
        let runs: Vec<Refined> = [1, 2, 3, 40].into_iter().map(run).collect();
        assert!(
            runs[0].report.iterations < 40,
            "a sweep without a new best ends patience 1"
        );
        assert!(runs[3].report.iterations > runs[0].report.iterations);
        for pair in runs.windows(2) {
            let (a, b) = (&pair[0].report, &pair[1].report);
            assert!(
                a.iterations <= b.iterations,
                "{} > {}",
                a.iterations,
                b.iterations
            );
            assert!(
                a.r_refined <= b.r_refined,
                "{} > {}",
                a.r_refined,
                b.r_refined
            );
            if a.iterations == b.iterations {
                assert_eq!(pair[0].probes.positions(), pair[1].probes.positions());
            }
        }
    }
}
