//! Position updates: Gibbs sampling with stochastic direction sampling
//! (Wang et al. 2019 §3.3, eq. 3, Fig. 6).
//!
//! Probes are updated one after another. For probe `k` at `p_k` with step
//! `γ_k`:
//!
//! 1. **Support cube.** The eight corners `p_k + (γ_k/√3)·(±1, ±1, ±1)`
//!    (so each corner is one step away) are scored by probe `k`'s marginal
//!    fitness `R(P′_s) − R(P ∖ k)` there (see the fitness module), all eight
//!    in parallel, each from a view of `corner_directions`² rays, a
//!    quarter of the proposal's by default: the paper subsamples view
//!    directions while it optimizes (§3.3), and the corners only shape the
//!    linear models of step 2, which a coarser view keeps (every corner is
//!    seen the same way); the proposal itself is scored in full (step 4).
//!    A corner where a probe may not stand scores 0. The paper
//!    fits its linear models to `R(P′_s)` itself; subtracting the part that
//!    does not depend on `p_k` leaves the models' shape alone where the
//!    paper's values would all lie within a fraction of a percent of each
//!    other, and turns them into something a sample can follow.
//! 2. **Stochastic direction sampling.** Along each of the four x-edges a
//!    linear model `f(t) = a·t + b` through the two corner values is sampled
//!    by inverting its CDF `F(t) = (a/2)t² + b·t` (normalized), giving four
//!    points; their values interpolate linearly. The two y-edges between
//!    those points are sampled the same way, then the z-edge between the
//!    two results: one point `p*` in the cube ([`stochastic_point`]).
//! 3. **Proposal** (eq. 3): `p′_k = p*`, i.e. `p_k + γ·∇`, with the sampled
//!    direction `∇ = (p* − p_k)/γ_k` and step `γ = γ_k`. A proposal outside
//!    the domain, in a voxel that is not free, nearer to a surface than the
//!    placement threshold, or behind a surface as seen from `p_k` is
//!    rejected outright: a probe never moves into solid space or through a
//!    wall.
//! 4. **Gibbs acceptance**: `ξ < (R(P′)/R(P))^β` ([`accept`]). With β = 1,
//!    the paper's rule, a single probe's move changes `R` by about `1/n` of
//!    itself, so almost every worse proposal passes and the set drifts; the
//!    default β = n makes the test as decisive as if probe `k` were alone.
//! 5. **Step schedule** ([`StepSchedule`]): the paper observes probes
//!    oscillating between two positions. A probe's step halves whenever an
//!    accepted move reverses its previous one and shrinks by a quarter on a
//!    rejection; a probe whose step falls under `min_step` stops. Sweeps
//!    end when every probe has stopped or after `iterations` sweeps.
//! 6. **Patience.** The sweeps also end after `patience` sweeps in a row
//!    without a new best set: what they return is the best set seen, and a
//!    chain that has wandered below its best for that long is spending its
//!    time on positions that are not kept. The paper runs a fixed number of
//!    iterations (100 in Fig. 5); its own sets stop improving long before,
//!    and on Dabrovic Sponza the best set of 20 sweeps is the first one's
//!    (BENCHMARKS.md, "Patience").
//!
//! The best probe set seen (highest `R`) is the result.

use super::fitness::AtlasState;
use super::view::Viewer;
use crate::progress::Progress;
use crate::sampling::{hash2, unit_f32};
use glam::Vec3;
use rayon::prelude::*;

/// Step factor after an accepted move that reverses the previous one.
pub const REVERSAL_FACTOR: f32 = 0.5;

/// Step factor after a rejected proposal.
pub const REJECT_FACTOR: f32 = 0.9;

/// Samples `t` in [0, 1] with density proportional to the linear model
/// through `f(0) = f0` and `f(1) = f1` (both ≥ 0), by inverting its CDF
/// `F(t) = ((a/2)t² + b·t) / (a/2 + b)` with `a = f1 − f0`, `b = f0` at `xi`.
///
/// The root `(−b + sqrt(b² + 2a·ξ·(a/2 + b)))/a` is computed in the
/// cancellation-free form `ξ(f0 + f1) / (f0 + sqrt((1−ξ)f0² + ξf1²))`,
/// which also covers `a = 0`. Both values 0 (no information): `t = ξ`.
pub fn sample_linear(f0: f64, f1: f64, xi: f64) -> f64 {
    let (f0, f1) = (f0.max(0.0), f1.max(0.0));
    let denom = f0 + ((1.0 - xi) * f0 * f0 + xi * f1 * f1).sqrt();
    if denom <= 0.0 || !denom.is_finite() {
        return xi;
    }
    (xi * (f0 + f1) / denom).clamp(0.0, 1.0)
}

/// Stochastic direction sampling over a support cube (module docs, step 2).
///
/// `corner[s]` is the value at corner `s`, whose coordinates in the cube
/// `[-1, 1]³` are `x = ±1` by bit 0 of `s`, `y` by bit 1 and `z` by bit 2;
/// `xi` are seven canonical random numbers (four for x, two for y, one for
/// z). Returns the sampled point in cube coordinates.
pub fn stochastic_point(corner: &[f64; 8], xi: &[f64; 7]) -> Vec3 {
    // x: four edges, one per (y, z).
    let mut square = [(Vec3::ZERO, 0.0f64); 4];
    for (e, slot) in square.iter_mut().enumerate() {
        let (lo, hi) = (corner[2 * e], corner[2 * e + 1]);
        let t = sample_linear(lo, hi, xi[e]);
        let y = if e & 1 == 1 { 1.0 } else { -1.0 };
        let z = if e & 2 == 2 { 1.0 } else { -1.0 };
        *slot = (Vec3::new(-1.0 + 2.0 * t as f32, y, z), lo + (hi - lo) * t);
    }
    // y: two edges, one per z, between the x-sampled points.
    let mut line = [(Vec3::ZERO, 0.0f64); 2];
    for (z, slot) in line.iter_mut().enumerate() {
        let (a, b) = (square[2 * z], square[2 * z + 1]);
        let t = sample_linear(a.1, b.1, xi[4 + z]);
        *slot = (a.0.lerp(b.0, t as f32), a.1 + (b.1 - a.1) * t);
    }
    // z: the one remaining edge.
    let t = sample_linear(line[0].1, line[1].1, xi[6]);
    line[0].0.lerp(line[1].0, t as f32)
}

/// Gibbs acceptance of a proposal that takes the fitness from `r_old` to
/// `r_new`: `xi < (r_new / r_old)^beta`. Improvements always pass; from a
/// set that sees nothing (`r_old` = 0) only non-worsening moves do.
pub fn accept(r_old: f64, r_new: f64, beta: f64, xi: f64) -> bool {
    if r_new >= r_old {
        return true;
    }
    if r_old <= 0.0 || r_new <= 0.0 {
        return false;
    }
    xi < (r_new / r_old).powf(beta)
}

/// One probe's step size (module docs, step 5).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StepSchedule {
    /// The current step γ_k.
    pub step: f32,
    /// Where the probe stood before its last accepted move.
    previous: Option<Vec3>,
}

impl StepSchedule {
    /// A schedule starting at `step`.
    pub fn new(step: f32) -> StepSchedule {
        StepSchedule {
            step,
            previous: None,
        }
    }

    /// After an accepted move from `from` to `to`: the step halves when the
    /// probe came back to within a quarter step of where it stood before
    /// its previous move, the back-and-forth the paper describes.
    pub fn accepted(&mut self, from: Vec3, to: Vec3) {
        if self
            .previous
            .is_some_and(|p| p.distance(to) < 0.25 * self.step)
        {
            self.step *= REVERSAL_FACTOR;
        }
        self.previous = Some(from);
    }

    /// After a rejected proposal.
    pub fn rejected(&mut self) {
        self.step *= REJECT_FACTOR;
    }

    /// Caps the step at `cap` (the sweep's share of the global decay).
    pub fn cap(&mut self, cap: f32) {
        self.step = self.step.min(cap);
    }
}

/// What the sweeps did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SweepStats {
    /// Sweeps run.
    pub iterations: u32,
    /// Proposals made.
    pub proposals: u64,
    /// Proposals accepted.
    pub accepted: u64,
    /// Proposals rejected because a probe may not stand there.
    pub illegal: u64,
}

/// The settings of [`optimize`].
pub struct Sweeps<'v, 'a> {
    /// Casts the proposals' views.
    pub viewer: &'v Viewer<'a>,
    /// Casts the support-cube corners' views, usually with fewer directions
    /// than `viewer` (§3.3 subsamples view directions during optimization).
    pub corner_viewer: &'v Viewer<'a>,
    /// Where a probe may stand, and whether it may move from `a` to `b`.
    pub legal_move: &'v (dyn Fn(Vec3, Vec3) -> bool + Sync),
    /// Most sweeps.
    pub iterations: u32,
    /// Sweeps in a row without a new best set after which the sweeps end.
    pub patience: u32,
    /// First step of every probe.
    pub initial_step: f32,
    /// A probe stops when its step falls below this.
    pub min_step: f32,
    /// Acceptance exponent β.
    pub beta: f64,
    /// Seed of the random numbers.
    pub seed: u64,
    /// The first this many probes stay where they are (the config's
    /// `fixed_probes`): their views count in `R`, so the others move to
    /// see what they miss, but no step is proposed for them.
    pub pinned: usize,
}

/// Runs the sweeps (module docs) from `positions`, whose views `state`
/// holds, and returns the best positions seen (highest `R`).
///
/// Contract: deterministic for the same inputs; the sweeps up to the last
/// are those a larger `patience` would run; the fitness of the returned
/// positions is at least that of the initial ones. `state` ends at the last
/// position of every probe, which may be worse than the best.
pub fn optimize(
    sweeps: &Sweeps,
    state: &mut AtlasState,
    positions: &mut [Vec3],
    progress: &Progress,
) -> (Vec<Vec3>, SweepStats) {
    let n = positions.len();
    let mut schedule = vec![StepSchedule::new(sweeps.initial_step); n];
    let (mut best_r, mut best) = (state.r(), positions.to_vec());
    let mut stats = SweepStats {
        iterations: 0,
        proposals: 0,
        accepted: 0,
        illegal: 0,
    };
    let bar = progress.bar("refine", sweeps.iterations as u64);
    let mut stale = 0;
    for it in 0..sweeps.iterations {
        if stale >= sweeps.patience {
            break;
        }
        stale += 1;
        // The global decay: from the initial step at the first sweep to the
        // minimum at the last, so that every run converges.
        let progress_share = it as f32 / (sweeps.iterations.max(2) - 1) as f32;
        let cap =
            sweeps.initial_step * (sweeps.min_step / sweeps.initial_step).powf(progress_share);
        for s in schedule.iter_mut() {
            s.cap(cap.max(sweeps.min_step));
        }
        if schedule[sweeps.pinned.min(n)..]
            .iter()
            .all(|s| s.step < sweeps.min_step)
        {
            break;
        }
        stats.iterations += 1;
        for k in sweeps.pinned.min(n)..n {
            let step = schedule[k].step;
            if step < sweeps.min_step {
                continue;
            }
            let h = hash2(sweeps.seed, ((it as u64) << 32) | k as u64);
            let p = positions[k];
            let half = step / 3f32.sqrt();
            let corners: Vec<f64> = (0..8u32)
                .into_par_iter()
                .map(|s| {
                    let c = p + half * corner_sign(s);
                    if (sweeps.legal_move)(p, c) {
                        state.marginal(k, &sweeps.corner_viewer.view(c))
                    } else {
                        0.0
                    }
                })
                .collect();
            let corner: [f64; 8] = std::array::from_fn(|s| corners[s]);
            let xi: [f64; 7] = std::array::from_fn(|i| unit_f32(hash2(h, i as u64)) as f64);
            let proposal = p + half * stochastic_point(&corner, &xi);
            stats.proposals += 1;
            if !(sweeps.legal_move)(p, proposal) {
                stats.illegal += 1;
                schedule[k].rejected();
                continue;
            }
            let view = sweeps.viewer.view(proposal);
            let r_old = state.r();
            let r_new = r_old + state.delta(k, &view);
            if accept(r_old, r_new, sweeps.beta, unit_f32(hash2(h, 7)) as f64) {
                state.commit(k, view);
                schedule[k].accepted(p, proposal);
                positions[k] = proposal;
                stats.accepted += 1;
                if state.r() > best_r {
                    best_r = state.r();
                    best.copy_from_slice(positions);
                    stale = 0;
                }
            } else {
                schedule[k].rejected();
            }
        }
        bar.set_message(format!(
            "refine R={:.4} atlas {:.1}%",
            state.r(),
            100.0 * state.seen_share()
        ));
        bar.inc(1);
    }
    bar.finish_and_clear();
    (best, stats)
}

/// Corner `s` of the cube `[-1, 1]³` (bit 0: x, bit 1: y, bit 2: z).
fn corner_sign(s: u32) -> Vec3 {
    Vec3::new(
        if s & 1 == 1 { 1.0 } else { -1.0 },
        if s & 2 == 2 { 1.0 } else { -1.0 },
        if s & 4 == 4 { 1.0 } else { -1.0 },
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn inverse_cdf_matches_a_hand_computed_linear_model() {
        // f(t) = 1 + 2t on [0, 1]: ∫f = 2, F(t) = (t + t²)/2.
        // ξ = 0.5: t² + t − 1 = 0, t = (√5 − 1)/2.
        let t = sample_linear(1.0, 3.0, 0.5);
        assert!((t - (5f64.sqrt() - 1.0) / 2.0).abs() < 1e-12, "{t}");
        // ξ = 0.25: t² + t − 0.5 = 0, t = (−1 + √3)/2.
        let t = sample_linear(1.0, 3.0, 0.25);
        assert!((t - (3f64.sqrt() - 1.0) / 2.0).abs() < 1e-12, "{t}");
        // f(t) = 2t: F(t) = t², t = √ξ; mirrored, f(t) = 2(1−t): t = 1 − √(1−ξ).
        assert!((sample_linear(0.0, 5.0, 0.36) - 0.6).abs() < 1e-12);
        assert!((sample_linear(5.0, 0.0, 0.64) - 0.4).abs() < 1e-12);
        // Flat and empty models sample uniformly; ends map to ends.
        assert!((sample_linear(2.0, 2.0, 0.3) - 0.3).abs() < 1e-12);
        assert_eq!(sample_linear(0.0, 0.0, 0.7), 0.7);
        assert_eq!(sample_linear(1.0, 3.0, 0.0), 0.0);
        assert!((sample_linear(1.0, 3.0, 1.0) - 1.0).abs() < 1e-12);
        // The samples follow the density: the mean of 1 + 2t over its own
        // distribution is ∫t(1+2t)/2 = 7/12.
        let n = 100_000;
        let mean: f64 = (0..n)
            .map(|i| sample_linear(1.0, 3.0, (i as f64 + 0.5) / n as f64))
            .sum::<f64>()
            / n as f64;
        assert!((mean - 7.0 / 12.0).abs() < 1e-4, "{mean}");
    }

    #[test]
    fn stochastic_points_lean_towards_the_better_corners() {
        // All value at x = +1: every x-sample lands on the +x face.
        let mut corner = [0.0; 8];
        for s in (1..8).step_by(2) {
            corner[s] = 1.0;
        }
        let mut sum = Vec3::ZERO;
        let n = 4096;
        for i in 0..n {
            let xi: [f64; 7] = std::array::from_fn(|j| unit_f32(hash2(i, j as u64)) as f64);
            let p = stochastic_point(&corner, &xi);
            assert!(p.abs().max_element() <= 1.0 + 1e-6);
            assert!(p.x > -1.0 + 1e-6);
            sum += p;
        }
        let mean = sum / n as f32;
        // E[x] for density 2t on [0, 1] is 2/3, i.e. x = 1/3 in [-1, 1];
        // the y and z steps then favour the x-samples of higher value,
        // which lie further along x, so the mean lands a little beyond.
        assert!(mean.x > 1.0 / 3.0 && mean.x < 0.5, "{mean:?}");
        assert!(mean.y.abs() < 0.05 && mean.z.abs() < 0.05, "{mean:?}");
        // The corner with all the value pulls every coordinate.
        let mut corner = [0.0; 8];
        corner[7] = 1.0;
        let p = stochastic_point(&corner, &[0.5; 7]);
        assert!(p.cmpgt(Vec3::ZERO).all(), "{p:?}");
    }

    #[test]
    fn acceptance_passes_improvements_and_worse_moves_by_their_ratio() {
        assert!(accept(1.0, 1.5, 1.0, 0.999));
        assert!(accept(1.0, 1.0, 5.0, 0.999));
        // Ratio 0.8: accepted for ξ under 0.8, or 0.8^3 = 0.512 with β = 3.
        assert!(accept(1.0, 0.8, 1.0, 0.79));
        assert!(!accept(1.0, 0.8, 1.0, 0.81));
        assert!(accept(1.0, 0.8, 3.0, 0.5));
        assert!(!accept(1.0, 0.8, 3.0, 0.52));
        assert!(!accept(0.0, -1.0, 1.0, 0.0));
        assert!(!accept(1.0, 0.0, 1.0, 0.0));
        // Over many ξ, the acceptance rate of a worse move is its ratio.
        let n = 10_000;
        let rate = (0..n)
            .filter(|&i| accept(2.0, 1.4, 1.0, (i as f64 + 0.5) / n as f64))
            .count() as f64
            / n as f64;
        assert!((rate - 0.7).abs() < 1e-3, "{rate}");
    }

    #[test]
    fn the_step_halves_when_a_probe_turns_back() {
        let mut s = StepSchedule::new(1.0);
        s.accepted(Vec3::ZERO, Vec3::X);
        s.accepted(Vec3::X, Vec3::new(1.0, 1.0, 0.0));
        // A turn that does not come back keeps the step.
        s.accepted(Vec3::new(1.0, 1.0, 0.0), Vec3::new(0.0, 1.0, 0.0));
        assert_eq!(s.step, 1.0);
        // Back to where it stood before its last move: halved.
        s.accepted(Vec3::new(0.0, 1.0, 0.0), Vec3::new(1.0, 1.0, 0.1));
        assert_eq!(s.step, REVERSAL_FACTOR);
        s.rejected();
        assert_eq!(s.step, REVERSAL_FACTOR * REJECT_FACTOR);
        s.cap(0.1);
        assert_eq!(s.step, 0.1);
        // A probe bouncing between two positions stops after a few bounces.
        let mut s = StepSchedule::new(1.0);
        let (a, b) = (Vec3::ZERO, Vec3::X);
        let mut bounces = 0;
        while s.step >= 0.01 {
            let (from, to) = if bounces % 2 == 0 { (a, b) } else { (b, a) };
            s.accepted(from, to);
            bounces += 1;
        }
        assert!(bounces <= 9, "{bounces}");
    }
}
