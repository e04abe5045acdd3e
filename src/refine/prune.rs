//! The fewest probes that see everything (Wang et al. 2019's headline
//! claim): after refinement, fill the holes and drop the superfluous probes,
//! judged by the independent coverage measure (the `coverage` module's
//! surface samples and visibility rule), not by the atlas.
//!
//! Both steps read a visibility matrix: for every probe, the bit set of the
//! coverable samples it sees, computed once per probe with the coverage
//! module's own [`CoverageReference::sees`], so the coverage they reach is
//! exactly the coverage the report will print.
//!
//! * **Fill** is greedy set cover over candidate positions: while coverage
//!   is under the target, add the candidate that sees the most coverable
//!   samples no probe sees (ties: the earlier candidate). Candidates are the
//!   caller's (free positions where a probe may stand). With more than
//!   [`MAX_SCORED_HOLES`] holes, candidates are scored on an even subsample
//!   of them; coverage is then recounted exactly.
//! * **Prune** is reverse greedy: while some probe can go, drop the one that
//!   alone sees the fewest samples (ties: the one that sees fewest overall,
//!   then the later one). A probe can go when coverage without it stays at
//!   or above the target, or, when the target is out of reach, when nothing
//!   depends on it alone.

use crate::coverage::CoverageReference;
use crate::progress::Progress;
use crate::scene::raycast::SceneBvh;
use glam::Vec3;
use rayon::prelude::*;

/// A set of sample indices as 64-bit words.
type Bits = Vec<u64>;

/// Most holes candidates are scored on when filling: beyond it the scoring
/// (candidates × holes visibility tests) would dominate the run on scenes
/// far from the target, and an even subsample ranks candidates as well.
pub const MAX_SCORED_HOLES: usize = 2048;

fn popcount(bits: &[u64]) -> u32 {
    bits.iter().map(|w| w.count_ones()).sum()
}

fn popcount_and(a: &[u64], b: &[u64]) -> u32 {
    a.iter().zip(b).map(|(x, y)| (x & y).count_ones()).sum()
}

fn ones(bits: &[u64]) -> impl Iterator<Item = usize> + '_ {
    bits.iter().enumerate().flat_map(|(w, &word)| {
        (0..64)
            .filter(move |b| word >> b & 1 == 1)
            .map(move |b| w * 64 + b)
    })
}

/// The coverable samples of a coverage reference and who sees them.
pub struct CoverMatrix<'r> {
    reference: &'r CoverageReference,
    bvh: &'r SceneBvh,
    /// Indices into `reference.samples` of the coverable samples.
    coverable: Vec<usize>,
}

/// Result of [`CoverMatrix::fill_and_prune`].
#[derive(Debug, Clone, PartialEq)]
pub struct FillPrune {
    /// Final probes, as indices into `positions ++ added`.
    pub kept: Vec<usize>,
    /// Probes added by filling (some may have been pruned again).
    pub added: Vec<Vec3>,
    /// Coverable samples the input probes see.
    pub covered_initial: usize,
    /// Coverable samples the final probes see.
    pub covered_final: usize,
    /// Coverable samples.
    pub coverable: usize,
}

impl<'r> CoverMatrix<'r> {
    /// The matrix over `reference`'s coverable samples.
    pub fn new(reference: &'r CoverageReference, bvh: &'r SceneBvh) -> CoverMatrix<'r> {
        let coverable = (0..reference.samples.len())
            .filter(|&i| reference.coverable[i])
            .collect();
        CoverMatrix {
            reference,
            bvh,
            coverable,
        }
    }

    /// Number of coverable samples.
    pub fn len(&self) -> usize {
        self.coverable.len()
    }

    /// Whether there is no coverable sample.
    pub fn is_empty(&self) -> bool {
        self.coverable.is_empty()
    }

    /// Columns of all coverable samples for every viewer, one viewer per
    /// thread.
    fn columns(&self, viewers: &[Vec3]) -> Vec<Bits> {
        let all: Vec<usize> = (0..self.len()).collect();
        viewers.par_iter().map(|&v| self.column(v, &all)).collect()
    }

    /// For the probes at `viewers`: the coverable samples some of them sees,
    /// and the mean incidence angle (degrees) of each covered sample's best
    /// view, lower being better and 0 head-on (§3.2 "Probe View
    /// Distortion"; `None` when nothing is covered).
    pub fn summary(&self, viewers: &[Vec3]) -> (usize, Option<f64>) {
        let cols = self.columns(viewers);
        let (mut sum, mut count) = (0.0f64, 0usize);
        for (i, &si) in self.coverable.iter().enumerate() {
            let s = &self.reference.samples[si];
            let best = cols
                .iter()
                .zip(viewers)
                .filter(|(c, _)| c[i / 64] >> (i % 64) & 1 == 1)
                .map(|(_, &v)| s.normal.dot((v - s.position).normalize_or_zero()))
                .fold(f32::NEG_INFINITY, f32::max);
            if best.is_finite() {
                sum += best.clamp(-1.0, 1.0).acos().to_degrees() as f64;
                count += 1;
            }
        }
        (count, (count > 0).then(|| sum / count as f64))
    }

    /// Fills and prunes (module docs) the probes at `positions` towards
    /// `target` (a share of the coverable samples), filling from
    /// `candidates`.
    ///
    /// Contract: deterministic; if the input or filling reaches the target,
    /// the final probes do too; the final probes never see fewer samples
    /// than `min(target, what positions ++ added see)` requires.
    pub fn fill_and_prune(
        &self,
        positions: &[Vec3],
        candidates: &[Vec3],
        target: f64,
        fill: bool,
        prune: bool,
        progress: &Progress,
    ) -> FillPrune {
        let m = self.len();
        let words = m.div_ceil(64);
        let target_count = ((target * m as f64).ceil() as usize).min(m);
        let mut cols = self.columns(positions);
        let mut count = vec![0u32; m];
        for c in &cols {
            for i in ones(c) {
                count[i] += 1;
            }
        }
        let covered_initial = count.iter().filter(|&&c| c > 0).count();
        let mut covered = covered_initial;

        let mut added = Vec::new();
        if fill && covered < target_count && !candidates.is_empty() {
            let all_holes: Vec<usize> = (0..m).filter(|&i| count[i] == 0).collect();
            // Candidates are scored on at most MAX_SCORED_HOLES holes, an
            // even stride through them; each scored hole stands for
            // `weight` real ones.
            let stride = all_holes.len().div_ceil(MAX_SCORED_HOLES).max(1);
            let holes: Vec<usize> = all_holes.iter().copied().step_by(stride).collect();
            let weight = all_holes.len() as f64 / holes.len().max(1) as f64;
            let bar = progress.bar("refine: fill", candidates.len() as u64);
            let cand_cols: Vec<Bits> = candidates
                .par_iter()
                .map(|&c| {
                    let col = self.column(c, &holes);
                    bar.inc(1);
                    col
                })
                .collect();
            bar.finish_and_clear();
            let mut remaining: Bits = vec![0; holes.len().div_ceil(64)];
            for (i, _) in holes.iter().enumerate() {
                remaining[i / 64] |= 1 << (i % 64);
            }
            let mut estimate = covered as f64;
            while covered < target_count {
                let (best, gain) = cand_cols
                    .iter()
                    .enumerate()
                    .map(|(j, c)| (j, popcount_and(c, &remaining)))
                    .fold((usize::MAX, 0), |acc, x| if x.1 > acc.1 { x } else { acc });
                if gain == 0 {
                    break;
                }
                for (r, c) in remaining.iter_mut().zip(&cand_cols[best]) {
                    *r &= !c;
                }
                estimate += gain as f64 * weight;
                covered = estimate as usize;
                added.push(candidates[best]);
            }
            for c in self.columns(&added) {
                for i in ones(&c) {
                    count[i] += 1;
                }
                cols.push(c);
            }
            covered = count.iter().filter(|&&c| c > 0).count();
        }

        let mut alive = vec![true; cols.len()];
        if prune {
            loop {
                let mut once: Bits = vec![0; words];
                for (i, &c) in count.iter().enumerate() {
                    if c == 1 {
                        once[i / 64] |= 1 << (i % 64);
                    }
                }
                let need = target_count.min(covered);
                let pick = (0..cols.len())
                    .filter(|&k| alive[k])
                    .map(|k| {
                        (
                            k,
                            popcount_and(&cols[k], &once) as usize,
                            popcount(&cols[k]),
                        )
                    })
                    .filter(|&(_, unique, _)| unique == 0 || covered - unique >= need)
                    .min_by_key(|&(k, unique, total)| (unique, total, std::cmp::Reverse(k)));
                let Some((k, unique, _)) = pick else { break };
                alive[k] = false;
                covered -= unique;
                for i in ones(&cols[k]) {
                    count[i] -= 1;
                }
            }
        }
        FillPrune {
            kept: (0..cols.len()).filter(|&k| alive[k]).collect(),
            added,
            covered_initial,
            covered_final: covered,
            coverable: m,
        }
    }

    /// The coverable samples among `subset` (indices into `self.coverable`)
    /// that `viewer` sees, as bits over `subset`.
    fn column(&self, viewer: Vec3, subset: &[usize]) -> Bits {
        let mut bits = vec![0u64; subset.len().div_ceil(64)];
        for (b, &i) in subset.iter().enumerate() {
            let s = &self.reference.samples[self.coverable[i]];
            if self.reference.sees(self.bvh, viewer, s) {
                bits[b / 64] |= 1 << (b % 64);
            }
        }
        bits
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::{Count, CoverageParams, Degrees};
    use crate::scene::testing::room_sdf;

    #[test]
    fn fill_reaches_the_target_and_prune_drops_duplicates() {
        let (scene, bvh, sdf) = room_sdf(0.25, 2);
        let params = CoverageParams {
            samples: Count(4000),
            reference_points: Count(512),
            max_incidence_deg: Degrees(85.0),
        };
        let p = Progress::hidden();
        let reference = CoverageReference::new(&scene, &bvh, &sdf, &params, 2, &p);
        let matrix = CoverMatrix::new(&reference, &bvh);
        let one = Vec3::new(3.0, 2.0, 3.0);
        // Three copies of one probe: two are superfluous; the hole behind
        // the box needs a new probe.
        let positions = [one, one, one];
        let r = matrix.fill_and_prune(&positions, &reference.references, 0.999, true, true, &p);
        assert!(r.covered_initial < matrix.len());
        assert!(!r.added.is_empty());
        assert!(
            r.covered_final as f64 >= 0.999 * matrix.len() as f64,
            "{r:?}"
        );
        let copies = r.kept.iter().filter(|&&k| k < 3).count();
        assert!(copies <= 1, "{r:?}");
        // The matrix agrees with the coverage stage's own evaluation.
        let mut final_positions: Vec<Vec3> = positions.to_vec();
        final_positions.extend(&r.added);
        let kept: Vec<Vec3> = r.kept.iter().map(|&k| final_positions[k]).collect();
        let cov = reference.evaluate(&bvh, &kept, &p);
        assert_eq!(cov.covered_samples, r.covered_final);
        assert_eq!(matrix.summary(&kept).0, r.covered_final);
        // Without filling or pruning nothing changes.
        let same =
            matrix.fill_and_prune(&positions, &reference.references, 0.999, false, false, &p);
        assert_eq!(same.kept, vec![0, 1, 2]);
        assert_eq!(same.covered_final, same.covered_initial);
    }
}
