//! Top-up: when the run may have more probes than coverage needs
//! (`min_probes`), the extra ones go where they sharpen the views most.
//!
//! **Why.** Wang et al. 2019 place the fewest probes that see the surface
//! (§1, §3.3); an engine with a probe budget (the count of the uniform grid
//! it uses today, say) gains nothing from leaving it unspent, and a
//! comparison "at equal count" (Wang §5.2, Table 1) is only one when both
//! sides have the same count. What an extra probe buys is not coverage,
//! which the target already holds, but sharper lookups: a glossy ray is
//! resolved by a probe that sees its hit point (McGuire et al. 2017 §4),
//! and what comes back is one octahedral texel there, whose footprint is
//! `d²/cos θ` ([`super::polish::footprint`]).
//!
//! **What.** The cost is polish's, `Σ_s d_s²/cos θ_s` over the coverable
//! samples, each by its best view. Candidates are the fill positions of the
//! highest-clearance tier that has any (at most [`TOPUP_POOL`], an even
//! subsample), scored on an even subsample of [`TOPUP_SAMPLES`] samples
//! whose visibility from every candidate is cast once. Each round adds the
//! candidate that lowers the cost most (the greedy choice of facility
//! location: a candidate's saving only falls as probes are added, so the
//! first probes taken save the most, and a lazy greedy rescores only the
//! candidates whose old saving could still win), until the count is met or
//! no candidate lowers the cost. Polish then runs over the larger set.

use super::polish::{footprint, Best};
use super::prune::{ones, Bits, CoverMatrix, Working};
use glam::Vec3;
use indicatif::ProgressBar;
use rayon::prelude::*;
use std::cmp::{Ordering, Reverse};
use std::collections::BinaryHeap;

/// A saving, ordered by [`f64::total_cmp`] for the heap.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Saving(f64);

impl Eq for Saving {}

impl PartialOrd for Saving {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

impl Ord for Saving {
    fn cmp(&self, other: &Self) -> Ordering {
        self.0.total_cmp(&other.0)
    }
}

/// Most candidate positions scored (an even subsample of the tier).
pub const TOPUP_POOL: usize = 2048;

/// Samples the candidates are scored on (an even subsample of the
/// coverable ones); the footprints of the chosen probe are then updated on
/// every sample.
pub const TOPUP_SAMPLES: usize = 2048;

/// Refuses a top-up to `min_probes` probes over `samples` coverage samples
/// whose estimate exceeds the work limit ([`crate::limits`]), naming
/// `min_probes`: the candidates' views of the scoring subsample, each added
/// probe's view of every sample, and polish over that many probes, in
/// sample views ([`crate::limits::rate::REFINE_SAMPLE_VIEWS`]).
pub fn check_work(min_probes: usize, samples: usize) -> crate::error::Result<()> {
    use super::polish::{POLISH_CANDIDATES, POLISH_PASSES, POLISH_SAMPLES};
    let n = min_probes as f64;
    let views = (TOPUP_POOL * TOPUP_SAMPLES) as f64
        + n * samples as f64
        + n * (POLISH_CANDIDATES * POLISH_SAMPLES * POLISH_PASSES) as f64;
    crate::limits::check_work(
        "min_probes",
        &format!(
            "topping up to {min_probes} probes and polishing them ({samples} coverage samples)"
        ),
        views / crate::limits::rate::REFINE_SAMPLE_VIEWS,
        1.0,
    )
}

impl CoverMatrix<'_> {
    /// Adds fill candidates of `tiers` (module docs) until `min_count`
    /// probes are alive, each the one that lowers the footprint cost most
    /// on the scoring subsample, appended to `w`. Returns how many it added:
    /// fewer than asked when no candidate lowers the cost any more.
    ///
    /// Contract: deterministic; never removes a probe or a view, so
    /// coverage does not fall; adds nothing when `min_count` probes are
    /// alive already.
    pub(super) fn top_up(&self, tiers: &[Vec<Vec3>], w: &mut Working, min_count: usize) -> usize {
        let m = self.len();
        let live = w.live();
        let Some(tier) = tiers.iter().position(|t| !t.is_empty()) else {
            return 0;
        };
        if live >= min_count || m == 0 {
            return 0;
        }
        let stride = tiers[tier].len().div_ceil(TOPUP_POOL).max(1);
        let pool: Vec<Vec3> = tiers[tier]
            .iter()
            .step_by(stride)
            .copied()
            .filter(|p| !(0..w.all.len()).any(|k| w.alive[k] && w.all[k] == *p))
            .collect();
        let demanded: Vec<usize> = (0..m).filter(|&i| self.needs(i) > 0).collect();
        let stride = demanded.len().div_ceil(TOPUP_SAMPLES).max(1);
        let sub: Vec<usize> = demanded.iter().copied().step_by(stride).collect();
        let seen: Vec<Bits> = self.columns_of(&pool, &sub, &ProgressBar::hidden());
        let everything: Vec<usize> = (0..m).collect();
        let mut b = Best::unseen(m);
        self.rank_views(w, &everything, &mut b);
        // What candidate `j` would save now: Σ over the samples it sees of
        // how much it lowers their best footprint.
        let saving = |b: &Best, j: usize| -> f64 {
            ones(&seen[j])
                .map(|s| {
                    let i = sub[s];
                    let f = footprint(pool[j], self.sample(i).position, self.sample(i).normal);
                    if b.best[i].is_finite() && f < b.best[i] {
                        b.best[i] - f
                    } else {
                        0.0
                    }
                })
                .sum()
        };
        // Lazy greedy (Minoux 1978): an added probe only lowers the best
        // footprints, so every candidate's saving only falls, and a saving
        // computed earlier bounds it. The top of the heap, rescored, is the
        // greedy choice once it still beats the next bound; ties go to the
        // earlier candidate, as a full rescoring would take them.
        let mut heap: BinaryHeap<(Saving, Reverse<usize>)> = (0..pool.len())
            .into_par_iter()
            .map(|j| (Saving(saving(&b, j)), Reverse(j)))
            .collect::<Vec<_>>()
            .into_iter()
            .collect();
        let mut added = 0;
        while live + added < min_count {
            let Some((_, Reverse(j))) = heap.pop() else {
                break;
            };
            let fresh = (Saving(saving(&b, j)), Reverse(j));
            if heap.peek().is_some_and(|next| fresh < *next) {
                heap.push(fresh);
                continue;
            }
            if fresh.0 .0 <= 0.0 {
                break;
            }
            let col = self
                .columns_of(&[pool[j]], &everything, &ProgressBar::hidden())
                .remove(0);
            let affected: Vec<usize> = ones(&col).collect();
            w.push(pool[j], col, tier);
            self.rank_views(w, &affected, &mut b);
            added += 1;
        }
        added
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// In the test room (4 m, a box in it), one probe sees nearly all of it;
    /// topping up to four adds three probes, each of which lowers the
    /// footprint cost, keeps every view, and does the same again from the
    /// same input; asking for no more than are alive adds nothing.
    #[test]
    fn top_up_adds_probes_that_sharpen_the_views() {
        let (_, bvh, _, reference) = crate::coverage::test_room();
        let matrix = CoverMatrix::new(&reference, &bvh);
        let start = vec![Vec3::new(2.0, 3.0, 2.0)];
        let tiers = [reference.references.clone()];
        let run = |min_count: usize| {
            let mut w = Working::new(start.clone(), matrix.columns(&start), vec![0], matrix.len());
            let added = matrix.top_up(&tiers, &mut w, min_count);
            (added, w.all, w.count)
        };
        let cost = |viewers: &[Vec3]| {
            let cols = matrix.columns(viewers);
            (0..matrix.len())
                .map(|i| {
                    let s = matrix.sample(i);
                    cols.iter()
                        .zip(viewers)
                        .filter(|(c, _)| c[i / 64] >> (i % 64) & 1 == 1)
                        .map(|(_, &v)| footprint(v, s.position, s.normal))
                        .fold(f64::INFINITY, f64::min)
                })
                .filter(|f| f.is_finite())
                .sum::<f64>()
        };
        let (added, all, count) = run(4);
        assert_eq!(added, 3);
        assert_eq!(all.len(), 4);
        for n in 1..all.len() {
            assert!(
                cost(&all[..n + 1]) < cost(&all[..n]),
                "probe {n} did not help"
            );
        }
        let before = matrix.columns(&start);
        for i in ones(&before[0]) {
            assert!(count[i] >= 1);
        }
        assert_eq!(count, crate::refine::prune::views(&matrix, &all));
        assert_eq!(run(4).1, all);
        assert_eq!(run(1).0, 0);
    }
}
