//! The diffuse step: the probe set, coverage's included, moved until the
//! engines' blend of its SH lights the scene's surfaces as a path tracer
//! does.
//!
//! Engines take diffuse light from probes: Unity's light probes and
//! Godot's LightmapGI store SH L2 per probe and blend it by tetrahedral
//! interpolation over a Delaunay tetrahedralization, blind to walls
//! ([`crate::diffuse`]). Coverage (Wang et al. 2019 §3.2) asks that every
//! surface be seen by a probe, which the light-field tracer needs; it says
//! nothing of what that blend gives. This step optimizes the blend's error
//! itself, at the user's count: a local search (insert, relocate, remove)
//! over the whole set, scored on training receivers and reported on
//! receivers it never saw.
//!
//! * **Receivers.** `surface_points` surface points as the free space sees
//!   them (the first hits of rays in uniform directions from free points
//!   where a probe may stand, on the side seen), and `free_points` points
//!   in that free space with random normals, where dynamic objects take
//!   their light; each with its path-traced irradiance
//!   ([`crate::diffuse::reference`], `rays` paths). They alternate between
//!   a training half, which the search scores, and a held-out half, which
//!   it never sees and the report gives (`validation_*`): the coverage
//!   measure's split (docs/method.md, "Coverage on samples the placer
//!   never saw").
//! * **Error** of a receiver: the relative error of its blended baked
//!   light (what a mixed-lighting probe holds; `compare`'s headline
//!   measure, [`crate::diffuse::relative_error`]), and one more unit when
//!   it is lit 2× too much or too little (a leak, [`crate::diffuse::leaks`]):
//!   the relative error alone costs a receiver lit twice too much 1 and one
//!   lit half too little 0.5, so a search on it darkens broadly.
//! * **Candidates** where the blend fails: above the training surface
//!   points (one voxel past the clearance, and a sixth and a third of the
//!   way to the surface facing them), so that receivers are interpolated
//!   from probes on their own side of any wall, not extrapolated or
//!   blended across it; and free points spread over the free space. Each
//!   is ranked by the error mass it would serve (the training errors
//!   within half its distance to the nearest probe), and its SH is baked
//!   only once it ranks high enough to be tried.
//! * **Moves.** Insertions while the set is under its budget, the best of
//!   the highest-ranked candidates each time; then rounds of relocations
//!   (a probe to a high-ranked candidate, paired with the probes whose
//!   removal costs least, or to a candidate near it) and removals, each
//!   kept only when the training error falls. Every move is scored by
//!   blending again only the receivers it changes
//!   ([`crate::diffuse::moves`]).
//! * **Constraints.** Fixed probes never move. Coverage stays at its
//!   floor: a probe that alone gives some coverage sample its view moves
//!   only to where it sees all such samples, and is removed only when it
//!   has none ([`crate::refine::prune`]'s matrix, on the training
//!   samples). Every candidate may stand at the clearance, outside every
//!   `exclude` box, and in free space by its own rays
//!   ([`crate::coverage::stands_free`]).
//! * **Budget.** `max_probes` and `min_probes` when set; otherwise
//!   insertions stop once the best brings less than `gain` of the training
//!   error, or at `growth` times coverage's count more.
//!
//! The training figures are training scores; the held-out ones are not,
//! and `compare` judges on receivers of its own.

use super::prune::{ones, Bits, CoverMatrix};
use crate::config::DiffuseSearch;
use crate::coverage::SurfaceSample;
use crate::diffuse::moves::{BlendedErrors, Move, ReceiverGrid};
use crate::diffuse::{self, bake_sh, dark_floor, Irradiance, ProbeSh, Receiver};
use crate::placement::controls::Controls;
use crate::probes::{PlacementInput, Probe, ProbeSet};
use crate::progress::Stopwatch;
use crate::render::integrator::Renderer;
use crate::sampling::{hash2, unit_f32, uniform_direction};
use crate::sdf::VoxelClass;
use glam::Vec3;
use rayon::prelude::*;
use std::collections::HashMap;

/// Candidates baked together when one is tried.
const BAKE_BATCH: usize = 16;

/// Candidates tried for each insertion: the highest-ranked by error mass.
const INSERT_TRIES: usize = 16;

/// Highest-ranked candidates whose insertion gain a round of relocations
/// scores (times the round's widening).
const PAIR_CANDIDATES: usize = 16;

/// Probes whose removal costs least that each of those is paired with
/// (times the widening).
const PAIR_PROBES: usize = 8;

/// Pairs of a probe and a candidate a round tries, those whose predicted
/// gain is highest (times the widening).
const PAIR_TRIES: usize = 12;

/// Candidates near each probe a round tries it at (4 lowered Sponza's
/// held-out error 7% more at 1.28× the time of `place`: docs/method.md).
const LOCAL_TRIES: usize = 2;

/// Most rounds of relocations.
const MAX_ROUNDS: usize = 80;

/// Rounds without a move kept, each trying more pairs than the last,
/// before the search ends.
const PATIENCE: usize = 2;

/// Most relocations kept in one round (far enough apart not to interact).
const PER_ROUND: usize = 4;

/// Weight of a free receiver's error against a surface receiver's: the
/// headline is the light on surfaces, and free receivers fill open space a
/// player does not look at alike.
const FREE_WEIGHT: f64 = 0.25;

/// A move is kept when it lowers the mean training error by more than
/// this share of it: below, a move only trades noise.
const MIN_DROP: f64 = 1e-4;

/// What the diffuse step did. Its `error_*` are training scores; its
/// `validation_*` figures are measured on receivers it never scored.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct DiffuseReport {
    /// Training receivers on surfaces.
    pub surface_points: usize,
    /// Training receivers in free space.
    pub free_points: usize,
    /// Held-out receivers (surface and free).
    pub validation_points: usize,
    /// Candidate positions offered.
    pub candidates: usize,
    /// Candidates whose SH was baked (those ranked high enough to try).
    pub candidates_baked: usize,
    /// Probes in (coverage's).
    pub probes_before: usize,
    /// Probes out.
    pub probes_after: usize,
    /// Probes inserted.
    pub inserted: usize,
    /// Probes moved elsewhere (coverage's among them).
    pub relocated: usize,
    /// Probes removed.
    pub removed: usize,
    /// Moves scored.
    pub trials: usize,
    /// Mean training error before the step (a training score).
    pub error_before: f64,
    /// Mean training error after (a training score).
    pub error_after: f64,
    /// Mean relative error of the baked light at the held-out surface
    /// receivers, before.
    pub validation_before: f64,
    /// The same after.
    pub validation_after: f64,
    /// Share of the held-out surface receivers that leak (lit 2× too much
    /// or too little), before.
    pub leaks_before: f64,
    /// The same after.
    pub leaks_after: f64,
    /// Why insertion stopped: `budget` (`max_probes`, or `growth`), `gain`
    /// (the best insertion brought less than `gain`), `no candidate` or
    /// `no light`.
    pub stopped: String,
}

/// The steps [`optimize`]'s stopwatch times: the receivers' references and
/// the probes' SH, then the search.
pub const STEPS: [&str; 2] = ["diffuse_training", "diffuse_search"];

/// Receivers with their reference.
struct Set {
    receivers: Vec<Receiver>,
    reference: Vec<Irradiance>,
    /// Surface receivers come first; this many.
    surface: usize,
}

/// The training and held-out receivers and the candidates.
struct Training {
    train: Set,
    held: Set,
    candidates: Vec<Vec3>,
    /// The floor of the relative error (of the training references'
    /// baked light).
    floor: f64,
}

/// What the coverage floor needs of the set: every live probe's column
/// of the coverage matrix (computed when first needed, several at once:
/// the matrix casts a column fastest sample by sample over many probes)
/// and the views each coverable sample has.
struct CoverFloor<'m> {
    matrix: &'m CoverMatrix<'m>,
    /// Per slot: its position while live, and its column once computed.
    slots: Vec<(Option<Vec3>, Option<Bits>)>,
    /// Views per coverable sample from the live slots whose column is
    /// counted.
    count: Vec<u32>,
    /// Samples that may still lose their views: those satisfied above the
    /// coverage target.
    slack: usize,
    /// Samples the coverage target asks to be satisfied.
    needed: usize,
}

impl CoverFloor<'_> {
    /// Computes and counts the columns of live slots that lack one.
    fn settle(&mut self) {
        let missing: Vec<usize> = (0..self.slots.len())
            .filter(|&s| self.slots[s].0.is_some() && self.slots[s].1.is_none())
            .collect();
        if missing.is_empty() {
            return;
        }
        let at: Vec<Vec3> = missing.iter().map(|&s| self.slots[s].0.unwrap()).collect();
        for (s, col) in missing.into_iter().zip(self.matrix.columns(&at)) {
            for i in ones(&col) {
                self.count[i] += 1;
            }
            self.slots[s].1 = Some(col);
        }
    }

    /// The samples only slot `s` gives the views they need.
    ///
    /// Contract: [`CoverFloor::settle`]d.
    fn critical(&self, s: usize) -> Vec<usize> {
        match &self.slots[s].1 {
            None => Vec::new(),
            Some(col) => ones(col)
                .filter(|&i| {
                    let need = self.matrix.needs(i);
                    need > 0 && self.count[i] == need
                })
                .collect(),
        }
    }

    /// Whether slot `s` may go: no more samples depend on it alone than
    /// the slack allows.
    fn may_remove(&self, s: usize) -> bool {
        self.critical(s).len() <= self.slack
    }

    /// Whether slot `s` may move to `q`: `q` sees every sample that
    /// depends on `s` alone, but for as many as the slack allows.
    fn may_move(&self, s: usize, q: Vec3) -> bool {
        let critical = self.critical(s);
        critical.is_empty() || self.matrix.sees_all_but(q, &critical, self.slack)
    }

    /// Counts the slack again: after a move that may have cost views.
    fn recount(&mut self) {
        self.slack = self.matrix.satisfied(&self.count).saturating_sub(self.needed);
    }

    /// A probe in a new slot (its column computed when next settled).
    fn add(&mut self, q: Vec3) {
        self.slots.push((Some(q), None));
    }

    /// Slot `s` gone.
    fn remove(&mut self, s: usize) {
        if let Some(col) = self.slots[s].1.take() {
            for i in ones(&col) {
                self.count[i] -= 1;
            }
        }
        self.slots[s].0 = None;
    }

    /// Slot `s` now at `q`. Its column there is taken over the samples
    /// that depended on it alone, those `q` sees, and no more: the count
    /// stays a lower bound of every sample's views, so that coverage by
    /// the count is never above the true one, and computing `q`'s whole
    /// column (a ray to every sample) is left out.
    fn relocate(&mut self, s: usize, q: Vec3) {
        let critical = self.critical(s);
        let seen = self.matrix.seen_among(q, &critical);
        self.remove(s);
        let mut col: Bits = vec![0; self.count.len().div_ceil(64)];
        for i in seen {
            col[i / 64] |= 1 << (i % 64);
            self.count[i] += 1;
        }
        self.slots[s] = (Some(q), Some(col));
    }
}

/// Optimizes `probes` (coverage's, the first `probes.fixed` pinned) for
/// the engines' blend of their diffuse light (module docs), within the
/// artist `controls`' budget, every probe it places at `min_clearance`
/// from surfaces at least. `matrix` and `columns` are refinement's
/// coverage matrix over the training samples and each input probe's
/// column there (`None`: no coverage floor to keep). The stopwatch holds
/// the wall time of its [`STEPS`].
///
/// Contract: deterministic for its inputs whatever the thread count; the
/// fixed probes come first, unchanged; no probe it places or moves fails
/// [`super::may_stand`] at `min_clearance`, stands in an `exclude` box or
/// in solid by its own rays; the training coverage of `matrix` does not
/// fall; at most `controls.max_probes` probes, at least
/// `controls.min_probes` when there are candidates.
#[allow(clippy::too_many_arguments)]
pub fn optimize(
    params: &DiffuseSearch,
    probes: ProbeSet,
    input: &PlacementInput,
    renderer: &Renderer,
    min_clearance: f32,
    controls: &Controls,
    cover: Option<(&CoverMatrix, Vec<Bits>, f64)>,
) -> (ProbeSet, DiffuseReport, Stopwatch) {
    let mut steps = Stopwatch::new(false);
    let seed = hash2(input.seed, 0x0D1F_F5E7);
    let t = training(params, input, renderer, min_clearance, controls, seed);
    let positions = probes.positions();
    let rays = params.rays.0;
    let sh = bake_sh(renderer, &positions, rays, seed);
    steps.lap(STEPS[0]);
    let mut report = DiffuseReport {
        surface_points: t.train.surface,
        free_points: t.train.receivers.len() - t.train.surface,
        validation_points: t.held.receivers.len(),
        candidates: t.candidates.len(),
        probes_before: positions.len(),
        ..DiffuseReport::default()
    };
    let (before, leaks) = held_out(&t, &positions, &sh);
    report.validation_before = before;
    report.leaks_before = leaks;
    if t.floor <= 1e-12 || t.train.receivers.is_empty() {
        report.stopped = "no light".into();
        report.probes_after = positions.len();
        report.validation_after = before;
        report.leaks_after = leaks;
        steps.lap(STEPS[1]);
        return (probes, report, steps);
    }
    let floor = cover.map(|(matrix, cols, target)| {
        let mut count = vec![0u32; matrix.len()];
        for c in &cols {
            for i in ones(c) {
                count[i] += 1;
            }
        }
        // Coverage's floor: the target, or what coverage's probes reached
        // when more (refinement validated that on fresh samples).
        let target = (target * matrix.demanded() as f64).ceil() as usize;
        let needed = matrix.satisfied(&count).max(target);
        let mut f = CoverFloor {
            matrix,
            slots: positions.iter().zip(cols).map(|(&p, c)| (Some(p), Some(c))).collect(),
            count,
            slack: 0,
            needed,
        };
        f.recount();
        f
    });
    let placed = positions.len();
    let cap = controls.max_probes.unwrap_or_else(|| {
        placed + (params.growth.0 as f64 * placed as f64).floor() as usize
    });
    let least = controls.min_probes.unwrap_or(0).min(cap);
    let search = Search {
        params,
        t: &t,
        renderer,
        seed,
        pinned: probes.fixed,
        min_gap: input.sdf.voxel_size,
        auto: controls.max_probes.is_none() && controls.min_probes.is_none(),
        cap,
        least,
        bvh: input.bvh,
        voxel: input.sdf.voxel_size,
    };
    let (out, moves) = search.run(&positions, &sh, floor, &mut report);
    let final_positions: Vec<Vec3> = out.iter().map(|(p, _)| *p).collect();
    let final_sh: Vec<ProbeSh> = out.iter().map(|(_, l)| *l).collect();
    let (after, leaks) = held_out(&t, &final_positions, &final_sh);
    report.validation_after = after;
    report.leaks_after = leaks;
    report.probes_after = final_positions.len();
    report.trials = moves;
    steps.lap(STEPS[1]);
    // The probes out: the fixed first, then the rest in slot order;
    // cluster sizes kept for probes that never moved.
    let kept: HashMap<[u32; 3], u32> = probes
        .probes
        .iter()
        .map(|p| (p.position.to_array().map(f32::to_bits), p.cluster_size))
        .collect();
    let mut out_probes = probes;
    out_probes.probes = final_positions
        .iter()
        .map(|&p| Probe {
            position: p,
            cluster_size: kept
                .get(&p.to_array().map(f32::to_bits))
                .copied()
                .unwrap_or(0),
        })
        .collect();
    (out_probes, report, steps)
}

/// The mean relative error of the baked light at the held-out surface
/// receivers under the probes at `positions` with `sh`, and their leak
/// share.
fn held_out(t: &Training, positions: &[Vec3], sh: &[ProbeSh]) -> (f64, f64) {
    let n = t.held.surface;
    if n == 0 || positions.is_empty() {
        return (0.0, 0.0);
    }
    let lookup = diffuse::ShLookup::new(positions, sh, &vec![true; positions.len()]);
    let rs = &t.held.receivers[..n];
    let got: Vec<Irradiance> = rs.par_iter().map(|r| lookup.irradiance(r)).collect();
    let e = diffuse::Errors::measure(rs, &t.held.reference[..n], &got);
    (
        diffuse::mean(&e.baked).unwrap_or(0.0),
        diffuse::mean(&e.leak).unwrap_or(0.0),
    )
}

/// The search's fixed inputs.
struct Search<'a> {
    params: &'a DiffuseSearch,
    t: &'a Training,
    renderer: &'a Renderer<'a>,
    seed: u64,
    pinned: usize,
    /// No candidate nearer a probe than this.
    min_gap: f32,
    /// Whether the count is the step's to choose (no `max_probes` or
    /// `min_probes`).
    auto: bool,
    /// The most probes.
    cap: usize,
    /// The fewest.
    least: usize,
    /// The scene's rays, and the voxel size, for judging candidates free.
    bvh: &'a crate::scene::raycast::SceneBvh,
    voxel: f32,
}

/// The search's state: the set's errors, the candidates baked and used,
/// the moves scored.
struct State<'a, 'g> {
    b: BlendedErrors<'a>,
    grid: &'g ReceiverGrid,
    baked: Baked,
    used: Vec<bool>,
    trials: usize,
}

/// Candidates' SH, baked on demand.
struct Baked {
    sh: Vec<Option<ProbeSh>>,
    /// Whether each stands free by its own rays (judged when baked).
    free: Vec<bool>,
}

impl Search<'_> {
    /// Runs the search from `positions` with `sh`; returns the final
    /// probes (position and light) and the moves scored.
    fn run(
        &self,
        positions: &[Vec3],
        sh: &[ProbeSh],
        mut floor: Option<CoverFloor>,
        report: &mut DiffuseReport,
    ) -> (Vec<(Vec3, ProbeSh)>, usize) {
        let t = self.t;
        let grid = ReceiverGrid::new(&t.train.receivers);
        let error_of = |k: usize, got: &Irradiance| -> f64 {
            let want = &t.train.reference[k];
            let e = diffuse::relative_error(got.baked, want.baked, t.floor);
            let leak = diffuse::leaks(got.baked, want.baked, t.floor) as u8 as f64;
            let w = if k < t.train.surface { 1.0 } else { FREE_WEIGHT };
            w * (e + leak)
        };
        let mut s = State {
            b: BlendedErrors::new(&t.train.receivers, &grid, &error_of, positions, sh),
            grid: &grid,
            baked: Baked {
                sh: vec![None; t.candidates.len()],
                free: vec![true; t.candidates.len()],
            },
            used: vec![false; t.candidates.len()],
            trials: 0,
        };
        report.error_before = s.b.mean();
        report.stopped = self.insert(&mut s, &mut floor, report);
        let mut idle = 0;
        for _ in 0..MAX_ROUNDS {
            if self.round(&mut s, &mut floor, report, 1 + idle) {
                idle = 0;
            } else {
                idle += 1;
                if idle > PATIENCE {
                    break;
                }
            }
        }
        report.error_after = s.b.mean();
        report.candidates_baked = s.baked.sh.iter().filter(|x| x.is_some()).count();
        let out = (0..s.b.slots())
            .filter(|&k| s.b.is_live(k))
            .map(|k| (s.b.position(k), s.b.light(k)))
            .collect();
        (out, s.trials)
    }

    /// Inserts probes while the set is under its budget and the best of
    /// the highest-ranked candidates pays for itself (module docs);
    /// returns why it stopped.
    fn insert(&self, s: &mut State, floor: &mut Option<CoverFloor>, report: &mut DiffuseReport) -> String {
        let t = self.t;
        let n = t.train.receivers.len();
        while s.b.count() < self.cap {
            let ranked = self.ranked(s, INSERT_TRIES);
            if ranked.is_empty() {
                return "no candidate".into();
            }
            let (trial, c) = ranked
                .par_iter()
                .map(|&c| (s.b.trial(Move::Add(t.candidates[c], s.baked.sh[c].unwrap())), c))
                .min_by(|x, y| x.0.mean(n).total_cmp(&y.0.mean(n)).then(x.1.cmp(&y.1)))
                .expect("a candidate");
            s.trials += ranked.len();
            let (now, after) = (s.b.mean(), trial.mean(n));
            // Without a budget: a probe must lower the error by at least
            // `gain` of its share of it (error / probes): the elasticity of
            // the error against the count, scale-free where a fixed share
            // of the error would stop early in a large scene.
            let enough = if self.auto {
                (now - after) * s.b.count() as f64 >= self.params.gain.0 as f64 * now
            } else {
                after < now || s.b.count() < self.least
            };
            if !enough {
                return if self.auto { "gain" } else { "no gain" }.into();
            }
            s.used[c] = true;
            s.b.apply(trial);
            if let Some(f) = floor {
                f.add(t.candidates[c]);
            }
            report.inserted += 1;
        }
        "budget".into()
    }

    /// One round of removals and relocations, `widen` times as many pairs
    /// tried as the first; whether it kept a move.
    fn round(
        &self,
        s: &mut State,
        floor: &mut Option<CoverFloor>,
        report: &mut DiffuseReport,
        widen: usize,
    ) -> bool {
        let t = self.t;
        let n = t.train.receivers.len();
        if let Some(f) = floor.as_mut() {
            f.settle();
            f.recount();
        }
        let movable: Vec<usize> = (self.pinned..s.b.slots()).filter(|&k| s.b.is_live(k)).collect();
        // What removing each movable probe would cost, cheapest first.
        let mut cheap: Vec<(f64, usize)> = movable
            .par_iter()
            .map(|&k| (s.b.trial(Move::Remove(k)).mean(n), k))
            .collect();
        s.trials += cheap.len();
        cheap.sort_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)));
        let now = s.b.mean();
        // A removal that does not raise the error, where the count may fall.
        let may_shrink = s.b.count() > self.least.max(1) && (self.auto || s.b.count() > self.cap);
        if may_shrink {
            let found = cheap
                .iter()
                .find(|&&(e, k)| e <= now && floor.as_ref().is_none_or(|f| f.may_remove(k)));
            if let Some(&(_, k)) = found {
                s.b.apply(s.b.trial(Move::Remove(k)));
                if let Some(f) = floor.as_mut() {
                    f.remove(k);
                    f.recount();
                }
                report.removed += 1;
                return true;
            }
        }
        // Relocations: pairs of a high-ranked candidate and a probe whose
        // removal costs little, those predicted best (each alone's gain
        // less the other's loss, which a swap far apart is worth), and
        // each probe to candidates near it.
        let ranked = self.ranked(s, PAIR_CANDIDATES * widen);
        let gains: Vec<(f64, usize)> = ranked
            .par_iter()
            .map(|&c| (s.b.trial(Move::Add(t.candidates[c], s.baked.sh[c].unwrap())).mean(n), c))
            .collect();
        s.trials += gains.len();
        let mut pairs: Vec<(f64, usize, usize)> = Vec::new();
        for &(added, c) in &gains {
            for &(removed, k) in cheap.iter().take(PAIR_PROBES * widen) {
                let predicted = (now - added) - (removed - now);
                if predicted > 0.0 {
                    pairs.push((predicted, k, c));
                }
            }
        }
        pairs.sort_by(|x, y| y.0.total_cmp(&x.0).then(x.1.cmp(&y.1)).then(x.2.cmp(&y.2)));
        let mut tries: Vec<(usize, usize)> = pairs
            .iter()
            .take(PAIR_TRIES * widen)
            .map(|&(_, k, c)| (k, c))
            .collect();
        tries.extend(self.near_candidates(s, &movable));
        tries.sort_unstable();
        tries.dedup();
        let mut scored: Vec<(f64, usize, usize)> = tries
            .par_iter()
            .filter(|&&(k, c)| floor.as_ref().is_none_or(|f| f.may_move(k, t.candidates[c])))
            .map(|&(k, c)| {
                let tr = s.b.trial(Move::Relocate(k, t.candidates[c], s.baked.sh[c].unwrap()));
                (tr.mean(n), k, c)
            })
            .collect();
        s.trials += scored.len();
        // The best first; then others far from the moves kept.
        scored.sort_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)).then(x.2.cmp(&y.2)));
        let mut done: Vec<(usize, usize)> = Vec::new();
        for (e, k, c) in scored {
            if e >= now * (1.0 - MIN_DROP) || done.len() >= PER_ROUND {
                break;
            }
            let q = t.candidates[c];
            let near_done = done.iter().any(|&(k2, c2)| {
                let (p2, q2) = (s.b.position(k2), t.candidates[c2]);
                let r = 3.0 * self.min_gap.max(p2.distance(q2));
                k2 == k || c2 == c || p2.distance(s.b.position(k)) < r || q2.distance(q) < r
            });
            // The moves kept before this one may have spent the slack.
            if near_done || (!done.is_empty() && floor.as_ref().is_some_and(|f| !f.may_move(k, q))) {
                continue;
            }
            let tr = s.b.trial(Move::Relocate(k, q, s.baked.sh[c].unwrap()));
            s.trials += 1;
            if tr.mean(n) < s.b.mean() * (1.0 - MIN_DROP) {
                let from = s.b.position(k);
                s.b.apply(tr);
                if let Some(f) = floor.as_mut() {
                    f.relocate(k, q);
                    f.recount();
                }
                s.used[c] = true;
                // The old position may serve another probe later.
                if let Some(old) = t.candidates.iter().position(|&x| x == from) {
                    s.used[old] = false;
                }
                report.relocated += 1;
                done.push((k, c));
            }
        }
        !done.is_empty()
    }

    /// Up to `take` unused candidates, highest error mass first (ties: the
    /// lower index), none within `min_gap` of a probe, each baked and
    /// standing free.
    fn ranked(&self, s: &mut State, take: usize) -> Vec<usize> {
        let t = self.t;
        let (b, grid, used, baked) = (&s.b, s.grid, &s.used, &mut s.baked);
        let probes = b.live_positions();
        let errors = b.errors();
        let mass: Vec<(f64, usize)> = (0..t.candidates.len())
            .into_par_iter()
            .filter(|&c| !used[c] && baked.free[c])
            .filter_map(|c| {
                let q = t.candidates[c];
                let d = probes
                    .iter()
                    .map(|p| p.distance(q))
                    .fold(f32::INFINITY, f32::min);
                if d < self.min_gap {
                    return None;
                }
                let r = (0.5 * d).max(2.0 * self.min_gap);
                let r2 = r * r;
                let mut m = 0.0;
                grid.each_in(q - Vec3::splat(r), q + Vec3::splat(r), |k| {
                    if t.train.receivers[k].p.distance_squared(q) <= r2 {
                        m += errors[k];
                    }
                });
                (m > 0.0).then_some((m, c))
            })
            .collect();
        let mut mass = mass;
        mass.sort_by(|x, y| y.0.total_cmp(&x.0).then(x.1.cmp(&y.1)));
        let mut out = Vec::with_capacity(take);
        let mut k = 0;
        while out.len() < take && k < mass.len() {
            // Bake the next batch of the ranking that lacks SH.
            let batch: Vec<usize> = mass[k..]
                .iter()
                .map(|&(_, c)| c)
                .filter(|&c| baked.sh[c].is_none() && baked.free[c])
                .take(BAKE_BATCH)
                .collect();
            self.bake(&batch, baked);
            while k < mass.len() && out.len() < take {
                let c = mass[k].1;
                k += 1;
                if baked.sh[c].is_some() && baked.free[c] {
                    out.push(c);
                } else if baked.sh[c].is_none() && baked.free[c] {
                    k -= 1;
                    break;
                }
            }
        }
        out
    }

    /// For each movable slot, the [`LOCAL_TRIES`] unused candidates nearest
    /// it within half its distance to the nearest other probe (baked and
    /// free), as (slot, candidate).
    fn near_candidates(&self, s: &mut State, movable: &[usize]) -> Vec<(usize, usize)> {
        let t = self.t;
        let (b, used, baked) = (&s.b, &s.used, &mut s.baked);
        let probes = b.live_positions();
        let near: Vec<(usize, Vec<usize>)> = movable
            .par_iter()
            .map(|&slot| {
                let k = LOCAL_TRIES;
                let p = b.position(slot);
                let d = probes
                    .iter()
                    .filter(|&&q| q != p)
                    .map(|q| q.distance(p))
                    .fold(f32::INFINITY, f32::min);
                let r = (0.5 * d).max(2.0 * self.min_gap);
                let mut c: Vec<(f32, usize)> = (0..t.candidates.len())
                    .filter(|&c| !used[c] && baked.free[c])
                    .map(|c| (t.candidates[c].distance(p), c))
                    .filter(|&(d, _)| d <= r && d > 0.0)
                    .collect();
                // Spread from the nearest to the farthest: steps and strides.
                c.sort_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)));
                let n = c.len();
                let mut pick: Vec<usize> =
                    (0..k.min(n)).map(|j| c[j * n / k.min(n).max(1)].1).collect();
                pick.dedup();
                (slot, pick)
            })
            .collect();
        let want: Vec<usize> = near
            .iter()
            .flat_map(|(_, c)| c.iter().copied())
            .filter(|&c| baked.sh[c].is_none())
            .collect();
        self.bake(&want, baked);
        near.into_iter()
            .flat_map(|(slot, c)| c.into_iter().map(move |c| (slot, c)))
            .filter(|&(_, c)| baked.sh[c].is_some() && baked.free[c])
            .collect()
    }

    /// Bakes the SH of `candidates` (and judges them free by their own
    /// rays) where not yet done.
    fn bake(&self, candidates: &[usize], baked: &mut Baked) {
        let mut todo: Vec<usize> = candidates
            .iter()
            .copied()
            .filter(|&c| baked.sh[c].is_none())
            .collect();
        todo.sort_unstable();
        todo.dedup();
        if todo.is_empty() {
            return;
        }
        let at: Vec<Vec3> = todo.iter().map(|&c| self.t.candidates[c]).collect();
        let free: Vec<bool> = at
            .par_iter()
            .map(|&p| crate::coverage::stands_free(self.bvh, self.voxel, p))
            .collect();
        let sh = bake_sh(self.renderer, &at, self.params.rays.0, self.seed);
        for ((c, l), f) in todo.into_iter().zip(sh).zip(free) {
            baked.sh[c] = Some(l);
            baked.free[c] = f;
        }
    }
}

/// The training set and candidates of `params` (module docs), drawn from
/// `seed`.
fn training(
    params: &DiffuseSearch,
    input: &PlacementInput,
    renderer: &Renderer,
    min_clearance: f32,
    controls: &Controls,
    seed: u64,
) -> Training {
    let sdf = input.sdf;
    let h = sdf.voxel_size;
    let stands = |p: Vec3| {
        super::may_stand(sdf, input.domain, min_clearance, p) && !controls.excluded(p)
    };
    let open: Vec<usize> = (0..sdf.len())
        .filter(|&i| sdf.class[i] == VoxelClass::Free && stands(sdf.center(i)))
        .collect();
    let far = input.domain.size().length();
    let want = params.surface_points.0 as usize;
    // Where viewers are: free space over a floor, up to twice eye height
    // (the sky over a town, the air under a vault is no place a player
    // stands); all of it where little qualifies (a scene without floors).
    let band = 2.0 * crate::render::views::EYE_HEIGHT;
    let viewers: Vec<usize> = open
        .par_iter()
        .copied()
        .filter(|&i| {
            let hit = input.bvh.closest_hit(sdf.center(i), Vec3::NEG_Y, 0.0, band);
            hit.is_some_and(|hit| {
                let n = input.scene.normals[hit.triangle as usize];
                n.y.abs() >= std::f32::consts::FRAC_1_SQRT_2
            })
        })
        .collect();
    let origins = if viewers.len() * 20 >= open.len() { &viewers } else { &open };
    // Surfaces as the viewers' free space sees them (module docs).
    let samples: Vec<SurfaceSample> = if origins.is_empty() || want == 0 {
        Vec::new()
    } else {
        (0..4 * want as u64)
            .into_par_iter()
            .filter_map(|k| {
                let at = hash2(hash2(seed, 5), k) % origins.len() as u64;
                let o = sdf.center(origins[at as usize]);
                let d = uniform_direction(hash2(seed, 6), k);
                let hit = input.bvh.closest_hit(o, d, 0.0, far)?;
                let n = input.scene.normals[hit.triangle as usize];
                Some(SurfaceSample {
                    position: o + d * hit.t,
                    normal: if n.dot(d) < 0.0 { n } else { -n },
                })
            })
            .collect()
    };
    let mut surface: Vec<Receiver> = Vec::with_capacity(want);
    let mut candidates: Vec<Vec3> = Vec::new();
    for s in samples {
        if surface.len() == want {
            break;
        }
        // Room in front of the surface for a probe.
        let lift = min_clearance + h;
        let c = s.position + s.normal * lift;
        if !stands(c) {
            continue;
        }
        let k = surface.len();
        surface.push(Receiver {
            p: s.position + s.normal * (0.01 * h),
            n: s.normal,
            group: (k % 2) as u32,
        });
        // Candidates only from the training half.
        if k % 2 == 0 {
            candidates.push(c);
            let across = input
                .bvh
                .closest_hit(c, s.normal, 0.0, far)
                .map_or(far, |hit| hit.t);
            for share in [1.0 / 6.0, 1.0 / 3.0] {
                let q = c + s.normal * (share * across);
                if share * across > 2.0 * h && stands(q) {
                    candidates.push(q);
                }
            }
        }
    }
    // Free points: voxel centres where a probe may stand, jittered.
    let free_want = if open.is_empty() { 0 } else { params.free_points.0 as usize };
    let free: Vec<Receiver> = (0..free_want as u64)
        .filter_map(|k| {
            let key = hash2(hash2(seed, 3), k);
            let v = open[(hash2(key, 0) % open.len() as u64) as usize];
            let jitter = Vec3::new(
                unit_f32(hash2(key, 1)),
                unit_f32(hash2(key, 2)),
                unit_f32(hash2(key, 3)),
            ) - 0.5;
            let p = sdf.center(v) + jitter * h;
            stands(p).then(|| Receiver {
                p,
                n: uniform_direction(key, 4),
                group: (k % 2) as u32,
            })
        })
        .collect();
    for r in free.iter().filter(|r| r.group == 0) {
        candidates.push(r.p);
    }
    let rays = params.rays.0;
    let split = |rs: &[Receiver], g: u32| -> Vec<Receiver> {
        rs.iter().copied().filter(|r| r.group == g).collect()
    };
    let set = |g: u32, stream: u64| {
        let s = split(&surface, g);
        let f = split(&free, g);
        let n = s.len();
        let receivers: Vec<Receiver> = s.into_iter().chain(f).collect();
        let reference = diffuse::reference(renderer, &receivers, rays, hash2(seed, stream));
        Set {
            receivers,
            reference,
            surface: n,
        }
    };
    let train = set(0, 2);
    let held = set(1, 7);
    let floor = dark_floor(train.reference.iter().map(|e| e.baked));
    Training {
        train,
        held,
        candidates,
        floor,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::{Count, CoverageParams, Light, NonNegative, Point3, Rgb, Whole};
    use crate::coverage::CoverageReference;
    use crate::progress::Progress;
    use crate::scene::testing::{input_over, room_sdf};

    fn params() -> DiffuseSearch {
        DiffuseSearch {
            surface_points: Whole(512),
            free_points: Whole(128),
            rays: Count(64),
            gain: NonNegative(0.5),
            growth: NonNegative(1.0),
        }
    }

    fn lamp() -> Vec<Light> {
        vec![Light::Point {
            position: Point3([0.6, 3.4, 0.6]),
            intensity: Rgb([4.0, 4.0, 4.0]),
        }]
    }

    /// Eight probes at the corners of a 3 m cube in the 4 m room with its
    /// box (the first `fixed` of them pinned), optimized under `controls`
    /// with the coverage floor of a reference over the room when `floor`.
    fn run(
        lights: &[Light],
        controls: Controls,
        fixed: usize,
        floor: bool,
    ) -> (ProbeSet, DiffuseReport, Vec<Vec3>) {
        let (scene, bvh, sdf) = room_sdf(0.25, 3);
        let progress = Progress::hidden();
        let input = input_over(&scene, &bvh, &sdf, 7, &progress);
        let probes: Vec<Probe> = (0..8)
            .map(|k| {
                let c = |b: usize| if k >> b & 1 == 1 { 3.5 } else { 0.5 };
                Probe {
                    position: Vec3::new(c(0), c(1), c(2)),
                    cluster_size: 1,
                }
            })
            .collect();
        let set = ProbeSet {
            method: "corners".into(),
            probes,
            stats: Default::default(),
            params: Default::default(),
            min_clearance: 0.25,
            fixed,
        };
        let renderer = Renderer::new(&scene, &bvh, lights, 1);
        let reference = CoverageReference::by_rays(
            &scene,
            &bvh,
            &sdf,
            &scene.bounds,
            &CoverageParams::default(),
            11,
            &progress,
        );
        let matrix = CoverMatrix::new(&reference, &bvh);
        let cols = matrix.columns(&set.positions());
        let before: Vec<Vec3> = set.positions();
        let (out, report, steps) = optimize(
            &params(),
            set,
            &input,
            &renderer,
            0.25,
            &controls,
            floor.then_some((&matrix, cols, 0.0)),
        );
        let timed = steps.to_map();
        assert!(STEPS.iter().all(|s| timed.contains_key(*s)), "{timed:?}");
        for p in &out.probes {
            let p = p.position;
            assert!(
                before.contains(&p) || crate::refine::may_stand(&sdf, &scene.bounds, 0.25, p),
                "{p}"
            );
            assert!(crate::coverage::stands_free(&bvh, sdf.voxel_size, p), "{p}");
        }
        if floor {
            // Every coverable sample the corners saw is still seen.
            let seen = |ps: &[Vec3]| {
                let cols = matrix.columns(ps);
                (0..matrix.len())
                    .filter(|&i| cols.iter().any(|c| c[i / 64] >> (i % 64) & 1 == 1))
                    .count()
            };
            assert!(seen(&out.positions()) >= seen(&before), "coverage fell");
        }
        (out, report, before)
    }

    #[test]
    fn the_search_lowers_the_error_on_receivers_it_never_saw() {
        let (out, r, before) = run(&lamp(), Controls::default(), 0, true);
        assert!(r.inserted >= 1, "{r:?}");
        assert_eq!(out.probes.len(), r.probes_after);
        assert!(r.error_after < 0.9 * r.error_before, "{r:?}");
        assert!(r.validation_after < 0.9 * r.validation_before, "{r:?}");
        assert!(r.validation_before > 0.0 && r.validation_after.is_finite());
        // Probes that never moved keep their cluster sizes; new ones have 0.
        for p in &out.probes {
            let moved = !before.contains(&p.position);
            assert_eq!(p.cluster_size, if moved { 0 } else { 1 }, "{p:?}");
        }
        // Same inputs, same probes, whatever the thread count.
        let one = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap()
            .install(|| run(&lamp(), Controls::default(), 0, true));
        assert_eq!(one.0.positions(), out.positions());
        assert_eq!(one.1, r);
    }

    #[test]
    fn fixed_probes_stay_first_and_unmoved_and_the_budget_holds() {
        let controls = Controls {
            max_probes: Some(10),
            min_probes: Some(10),
            ..Controls::default()
        };
        let (out, r, before) = run(&lamp(), controls, 3, false);
        assert_eq!(out.probes.len(), 10, "{r:?}");
        assert_eq!(out.fixed, 3);
        assert_eq!(out.positions()[..3], before[..3]);
        let capped = Controls {
            max_probes: Some(8),
            ..Controls::default()
        };
        let (out, r, _) = run(&lamp(), capped, 0, false);
        assert!(out.probes.len() <= 8, "{r:?}");
        assert_eq!(r.inserted, 0);
    }

    #[test]
    fn a_dark_scene_is_left_as_it_is() {
        let (out, r, before) = run(&[], Controls::default(), 0, true);
        assert_eq!(out.positions(), before);
        assert_eq!(r.stopped, "no light");
    }
}
