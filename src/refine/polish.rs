//! Polish: after pruning has chosen how many probes there are, move each
//! one to where the views it serves are sharper, without losing a covered
//! sample.
//!
//! **Why.** Pruning keeps the fewest probes that see the target share of
//! the surface, and nothing else: the probes left often see what they alone
//! cover from far away or at grazing angles (the mean incidence of each
//! sample's best view rises from about 25° to 30–35°; docs/method.md). A
//! light-field probe resolves a glossy ray by a probe that sees the ray's
//! hit point (McGuire et al. 2017 §4), and what it returns there is one
//! octahedral texel of radiance and depth: a texel of solid angle `Ω_t`
//! covers `Ω_t·d²/cos θ` of a surface at distance `d` seen at incidence `θ`,
//! so the error of the lookup grows with that footprint. Wang et al. 2019
//! §3.3 score a view by the same two terms, orientation `Ω` and distance `d`
//! (eqs. 1–2), but add them; here they multiply into the footprint, the
//! quantity the lookup's resolution depends on.
//!
//! **What.** The cost of a probe set is `Σ_s d_s²/cos θ_s` over the
//! coverable samples (area-uniform, so the sum estimates the surface
//! integral), each sample taking its best view: the least footprint among
//! the probes that see it ([`footprint`]). For each probe in turn (the
//! pinned ones stay), candidates are the fill positions near it in tiers no
//! nearer a surface than its own ([`POLISH_CANDIDATES`] of the
//! [`POLISH_POOL`] nearest, from the nearest to the farthest in log steps
//! of rank); a candidate qualifies only if coverage stays at or above the
//! target: it must see every sample whose cover depends on this probe but
//! as many as the slack pruning left above the target. Qualifying candidates
//! are ranked by the cost they save on an even subsample of
//! [`POLISH_SAMPLES`] samples; the best is then scored on every sample and
//! taken only if it lowers the exact cost. Up to [`POLISH_PASSES`] passes,
//! fewer when a pass moves nothing. The count never changes.

use super::prune::{ones, Bits, CoverMatrix, Working};
use glam::Vec3;
use indicatif::ProgressBar;
use rayon::prelude::*;

/// Fill positions nearest a probe considered for its move.
pub const POLISH_POOL: usize = 1024;

/// Candidates per probe, taken from those [`POLISH_POOL`] at distance ranks
/// spaced evenly in log rank (0, 1, 3, 5, 9, …, 1023; see
/// [`candidate_ranks`]): as many near moves as far ones, so one pass can
/// take a probe that pruning left in a corner of a room to its middle.
pub const POLISH_CANDIDATES: usize = 16;

/// Samples candidates are ranked on (an even subsample of the coverable
/// ones); the chosen move is checked on all of them.
pub const POLISH_SAMPLES: usize = 2048;

/// Most passes over the probes.
pub const POLISH_PASSES: usize = 2;

/// The distance ranks, among `n` positions sorted by distance, of the
/// [`POLISH_CANDIDATES`] candidates: `n^(j/15) − 1` for `j` from 0 to 15,
/// rounded, without repeats (so fewer when `n` is small).
pub fn candidate_ranks(n: usize) -> impl Iterator<Item = usize> {
    let top = (n.max(1) as f64).log2();
    let last_j = (POLISH_CANDIDATES - 1) as f64;
    let mut last = None;
    (0..POLISH_CANDIDATES).filter_map(move |j| {
        let r = ((top * j as f64 / last_j).exp2().round() as usize).saturating_sub(1);
        let r = r.min(n.max(1) - 1);
        (last != Some(r)).then(|| {
            last = Some(r);
            r
        })
    })
}

/// The footprint `d²/cos θ` of the view from `viewer` of a surface point at
/// `position` with unit normal `normal` (proportional to the surface area
/// one octahedral texel covers there; module docs). Infinite from behind
/// or edge-on.
pub fn footprint(viewer: Vec3, position: Vec3, normal: Vec3) -> f64 {
    let v = (viewer - position).as_dvec3();
    let d2 = v.length_squared();
    let along = normal.as_dvec3().dot(v);
    if along <= 0.0 {
        return f64::INFINITY;
    }
    // d²/cos θ = d²·d/(n·v).
    d2 * d2.sqrt() / along
}

/// Each sample's best and second-best footprint among live probes, and
/// which probe gives the best.
pub(super) struct Best {
    pub(super) best: Vec<f64>,
    second: Vec<f64>,
    best_k: Vec<usize>,
}

impl Best {
    /// `m` samples no probe sees yet.
    pub(super) fn unseen(m: usize) -> Best {
        Best {
            best: vec![f64::INFINITY; m],
            second: vec![f64::INFINITY; m],
            best_k: vec![usize::MAX; m],
        }
    }
}

impl CoverMatrix<'_> {
    /// Footprint of sample `i` (index into the coverable samples) from `p`.
    fn footprint_of(&self, p: Vec3, i: usize) -> f64 {
        let s = self.sample(i);
        footprint(p, s.position, s.normal)
    }

    /// Recomputes `b` for the samples in `which` from the live probes.
    pub(super) fn rank_views(&self, w: &Working, which: &[usize], b: &mut Best) {
        let (all, cols) = (&w.all, &w.cols);
        let live: Vec<usize> = (0..cols.len()).filter(|&k| w.alive[k]).collect();
        let ranked: Vec<(f64, f64, usize)> = which
            .par_iter()
            .map(|&i| {
                let (mut best, mut second, mut best_k) = (f64::INFINITY, f64::INFINITY, usize::MAX);
                for &k in &live {
                    if cols[k][i / 64] >> (i % 64) & 1 == 1 {
                        let f = self.footprint_of(all[k], i);
                        if f < best {
                            (second, best, best_k) = (best, f, k);
                        } else if f < second {
                            second = f;
                        }
                    }
                }
                (best, second, best_k)
            })
            .collect();
        for (&i, (best, second, best_k)) in which.iter().zip(ranked) {
            b.best[i] = best;
            b.second[i] = second;
            b.best_k[i] = best_k;
        }
    }

    /// Cost saved on `samples` (module docs) if probe `k` moved to `c`,
    /// whose visibility of those samples `sees(index into samples)` gives.
    fn saving(
        &self,
        b: &Best,
        k: usize,
        c: Vec3,
        samples: &[usize],
        sees: impl Fn(usize) -> bool,
    ) -> f64 {
        let mut saved = 0.0;
        for (j, &i) in samples.iter().enumerate() {
            let now = b.best[i];
            if !now.is_finite() {
                continue;
            }
            let without = if b.best_k[i] == k { b.second[i] } else { now };
            let from_c = if sees(j) {
                self.footprint_of(c, i)
            } else {
                f64::INFINITY
            };
            // A sample the move leaves unseen is bounded by the slack of
            // the coverage target, not priced.
            let after = without.min(from_c);
            if after.is_finite() {
                saved += now - after;
            }
        }
        saved
    }

    /// Polishes the live probes (module docs): moves probe `k` (not among
    /// the first `pinned`) to a fill candidate of `tiers` when that lowers
    /// the footprint cost and the samples with the views they need stay at
    /// least `target_count` (or, if fewer now, as many as now): a move may
    /// spend the slack pruning left above the target.
    /// A moved probe dies and is appended to `w` again, as
    /// [`CoverMatrix::merge_pairs`] does. Returns the number of moves.
    ///
    /// Contract: deterministic; coverage stays at or above
    /// `min(target_count, coverage now)`, and no probe moves to a tier
    /// nearer the surfaces than its own.
    pub(super) fn polish(
        &self,
        tiers: &[Vec<Vec3>],
        w: &mut Working,
        pinned: usize,
        target_count: usize,
    ) -> usize {
        let m = self.len();
        let pool: Vec<(Vec3, usize)> = tiers
            .iter()
            .enumerate()
            .flat_map(|(t, c)| c.iter().map(move |&p| (p, t)))
            .collect();
        if m == 0 || pool.is_empty() {
            return 0;
        }
        let demanded: Vec<usize> = (0..m).filter(|&i| self.needs(i) > 0).collect();
        let stride = demanded.len().div_ceil(POLISH_SAMPLES).max(1);
        let sub: Vec<usize> = demanded.iter().copied().step_by(stride).collect();
        let mut b = Best::unseen(m);
        let everything: Vec<usize> = (0..m).collect();
        self.rank_views(w, &everything, &mut b);
        let mut moves = 0;
        for _ in 0..POLISH_PASSES {
            let mut moved = false;
            let probes: Vec<usize> = (pinned..w.cols.len()).filter(|&k| w.alive[k]).collect();
            for k in probes {
                let (all, cols, count, tier_of) = (&w.all, &w.cols, &w.count, &w.tier_of);
                // Samples that lose their views without k: c must see all
                // of them but the slack.
                let slack = self.satisfied(count).saturating_sub(target_count);
                let must: Vec<usize> = ones(&cols[k])
                    .filter(|&i| self.needs(i) > 0 && count[i] <= self.needs(i))
                    .collect();
                let mut near: Vec<(f32, usize)> = pool
                    .iter()
                    .enumerate()
                    .filter(|(_, &(p, t))| t <= tier_of[k] && p != all[k])
                    .map(|(j, &(p, _))| (p.distance_squared(all[k]), j))
                    .collect();
                let n = POLISH_POOL.min(near.len());
                if n == 0 {
                    continue;
                }
                let order =
                    |a: &(f32, usize), b: &(f32, usize)| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1));
                near.select_nth_unstable_by(n - 1, order);
                near.truncate(n);
                near.sort_by(order);
                let cands: Vec<usize> = candidate_ranks(n).map(|r| near[r].1).collect();
                let b_now = &b;
                let qualified: Vec<bool> = cands
                    .par_iter()
                    .map(|&j| {
                        let c = pool[j].0;
                        let mut missed = 0;
                        for &i in &must {
                            if !self.sees_sample(c, i) {
                                missed += 1;
                                if missed > slack {
                                    return false;
                                }
                            }
                        }
                        true
                    })
                    .collect();
                let at: Vec<Vec3> = cands
                    .iter()
                    .zip(&qualified)
                    .filter(|&(_, &q)| q)
                    .map(|(&j, _)| pool[j].0)
                    .collect();
                let mut sub_cols = self
                    .columns_of(&at, &sub, &ProgressBar::hidden())
                    .into_iter();
                let scored: Vec<Option<f64>> = cands
                    .iter()
                    .zip(&qualified)
                    .map(|(&j, &q)| {
                        if !q {
                            return None;
                        }
                        let col = sub_cols.next()?;
                        let c = pool[j].0;
                        let saved =
                            self.saving(b_now, k, c, &sub, |s| col[s / 64] >> (s % 64) & 1 == 1);
                        (saved > 0.0).then_some(saved)
                    })
                    .collect();
                let Some((j, _)) = cands
                    .iter()
                    .zip(&scored)
                    .filter_map(|(&j, s)| s.map(|s| (j, s)))
                    .min_by(|a, b| b.1.total_cmp(&a.1).then(a.0.cmp(&b.0)))
                else {
                    continue;
                };
                let (c, tier) = pool[j];
                let col = self
                    .columns_of(&[c], &everything, &ProgressBar::hidden())
                    .remove(0);
                let exact =
                    self.saving(&b, k, c, &everything, |i| col[i / 64] >> (i % 64) & 1 == 1);
                if exact <= 0.0 {
                    continue;
                }
                let union: Bits = cols[k].iter().zip(&col).map(|(a, c)| a | c).collect();
                let affected: Vec<usize> = ones(&union).collect();
                w.kill(k);
                w.push(c, col, tier);
                self.rank_views(w, &affected, &mut b);
                moves += 1;
                moved = true;
            }
            if !moved {
                break;
            }
        }
        moves
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `Σ_s d_s²/cos θ_s` over the coverable samples some of `viewers` see,
    /// each by its best view (module docs), and how many are seen.
    fn footprint_cost(matrix: &CoverMatrix, viewers: &[Vec3]) -> (f64, usize) {
        let cols = matrix.columns(viewers);
        let (mut sum, mut seen) = (0.0, 0);
        for i in 0..matrix.len() {
            let best = cols
                .iter()
                .zip(viewers)
                .filter(|(c, _)| c[i / 64] >> (i % 64) & 1 == 1)
                .map(|(_, &v)| matrix.footprint_of(v, i))
                .fold(f64::INFINITY, f64::min);
            if best.is_finite() {
                sum += best;
                seen += 1;
            }
        }
        (sum, seen)
    }

    /// Two probes of the test room (4 m, a box in it), one low in a corner
    /// where it sees the walls near it edge-on: polishing moves it (or the
    /// other), lowers the footprint cost, keeps every covered sample covered
    /// and the count, and does the same again from the same input; given a
    /// slack below the coverage it starts from, it gives up no more.
    #[test]
    fn polish_sharpens_the_views_and_keeps_the_cover() {
        let (_, bvh, _, reference) = crate::coverage::test_room();
        let matrix = CoverMatrix::new(&reference, &bvh);
        let start = vec![Vec3::new(0.4, 0.4, 0.4), Vec3::new(2.6, 2.4, 2.6)];
        // `slack`: how many covered samples the moves may give up.
        let run = |slack: usize| {
            let mut w = Working::new(
                start.clone(),
                matrix.columns(&start),
                vec![0; 2],
                matrix.len(),
            );
            let tiers = [reference.references.clone()];
            let target = matrix.satisfied(&w.count) - slack;
            let moves = matrix.polish(&tiers, &mut w, 0, target);
            let kept: Vec<Vec3> = (0..w.all.len())
                .filter(|&k| w.alive[k])
                .map(|k| w.all[k])
                .collect();
            (moves, kept, w.count)
        };
        let (moves, kept, count) = run(0);
        assert!(moves > 0);
        assert_eq!(kept.len(), 2);
        let (before, seen_before) = footprint_cost(&matrix, &start);
        let (after, seen_after) = footprint_cost(&matrix, &kept);
        assert!(after < before, "{after} against {before}");
        assert!(
            seen_after >= seen_before,
            "{seen_after} against {seen_before}"
        );
        // `count` was kept up to date: it is what the kept probes see.
        assert_eq!(count, crate::refine::prune::views(&matrix, &kept));
        assert_eq!(run(0).1, kept);
        // With a slack, the moves may give up that many covered samples,
        // no more, and still lower the cost.
        let slack = seen_before / 100;
        let (_, loose, _) = run(slack);
        let (cost, seen) = footprint_cost(&matrix, &loose);
        assert!(seen + slack >= seen_before, "{seen} against {seen_before}");
        assert!(cost < before, "{cost} against {before}");
    }

    /// The footprint is d²/cos θ: head-on it is d², at 60° twice that, and
    /// from behind or edge-on infinite.
    #[test]
    fn footprint_is_distance_squared_over_cosine() {
        let n = Vec3::Y;
        let s = Vec3::ZERO;
        let head_on = footprint(Vec3::new(0.0, 2.0, 0.0), s, n);
        assert!((head_on - 4.0).abs() < 1e-9, "{head_on}");
        let at_60 = footprint(
            2.0 * Vec3::new(60f32.to_radians().sin(), 60f32.to_radians().cos(), 0.0),
            s,
            n,
        );
        assert!((at_60 - 8.0).abs() < 1e-4, "{at_60}");
        assert!(footprint(Vec3::new(0.0, -1.0, 0.0), s, n).is_infinite());
        assert!(footprint(Vec3::new(1.0, 0.0, 0.0), s, n).is_infinite());
        // Nearer and more head-on are both better.
        assert!(footprint(Vec3::new(0.0, 1.0, 0.0), s, n) < head_on);
        assert!(
            footprint(Vec3::new(1.0, 1.0, 0.0), s, n) > footprint(Vec3::new(0.0, 1.0, 0.0), s, n)
        );
    }

    /// The candidates' ranks start at the nearest, end at the farthest,
    /// rise strictly, and stay in range for small pools.
    #[test]
    fn candidate_ranks_span_the_pool_in_log_steps() {
        let r: Vec<usize> = candidate_ranks(1024).collect();
        assert_eq!(r.first(), Some(&0));
        assert_eq!(r.last(), Some(&1023));
        assert!(r.windows(2).all(|w| w[0] < w[1]), "{r:?}");
        assert!(r.len() >= POLISH_CANDIDATES - 2, "{r:?}");
        let small: Vec<usize> = candidate_ranks(3).collect();
        assert_eq!(small, vec![0, 1, 2]);
        assert_eq!(candidate_ranks(1).collect::<Vec<_>>(), vec![0]);
    }
}
