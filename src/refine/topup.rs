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
//! location: the cost is supermodular in the set, so the first probes
//! taken save the most), until the count is met or no candidate lowers the
//! cost. Polish then runs over the larger set.

use super::polish::{footprint, Best};
use super::prune::{ones, Bits, CoverMatrix, Working};
use glam::Vec3;
use rayon::prelude::*;

/// Most candidate positions scored (an even subsample of the tier).
pub const TOPUP_POOL: usize = 2048;

/// Samples the candidates are scored on (an even subsample of the
/// coverable ones); the footprints of the chosen probe are then updated on
/// every sample.
pub const TOPUP_SAMPLES: usize = 2048;

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
        let seen: Vec<Bits> = pool.par_iter().map(|&c| self.column(c, &sub)).collect();
        let everything: Vec<usize> = (0..m).collect();
        let mut b = Best::unseen(m);
        self.rank_views(w, &everything, &mut b);
        let mut taken = vec![false; pool.len()];
        let mut added = 0;
        while live + added < min_count {
            let b_now = &b;
            let best = (0..pool.len())
                .into_par_iter()
                .filter(|&j| !taken[j])
                .map(|j| {
                    let saved: f64 = ones(&seen[j])
                        .map(|s| {
                            let i = sub[s];
                            let now = b_now.best[i];
                            let f =
                                footprint(pool[j], self.sample(i).position, self.sample(i).normal);
                            if now.is_finite() && f < now {
                                now - f
                            } else {
                                0.0
                            }
                        })
                        .sum();
                    (j, saved)
                })
                .filter(|&(_, s)| s > 0.0)
                .max_by(|a, b| a.1.total_cmp(&b.1).then(b.0.cmp(&a.0)));
            let Some((j, _)) = best else {
                break;
            };
            taken[j] = true;
            let col = self.column(pool[j], &everything);
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
