//! Intervals for the comparison's error ratios (issue 21: "a ratio is
//! called a win only when its interval excludes 1").
//!
//! The comparison renders every placement from the same views with the
//! same glossy rays (common random numbers), so the errors of two
//! placements are paired: block `k` of view `v` is the same pixels, lit by
//! the same rays, in both. The interval of a ratio of mean errors is
//! therefore a **paired bootstrap** over blocks (Efron & Tibshirani 1993,
//! ch. 13, percentile interval): resample the blocks with replacement,
//! apply the same draw to both placements, and take the 2.5th and 97.5th
//! percentiles of the ratio of their sums. Blocks rather than pixels,
//! because neighbouring pixels' errors are correlated (one missing
//! reflection spans many), and a pixel bootstrap would understate the
//! spread.

use crate::sampling::hash2;

/// Resamples [`paired_ratio`] draws by default.
pub const RESAMPLES: usize = 2000;

/// A ratio and its 95% interval.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Interval {
    /// The ratio of the sums over all blocks.
    pub value: f64,
    /// 2.5th percentile of the resampled ratios.
    pub lo: f64,
    /// 97.5th percentile.
    pub hi: f64,
}

impl Interval {
    /// Whether the interval lies wholly above 1 (`num` has the larger
    /// error: the denominator's placement wins) or wholly below it.
    pub fn excludes_one(&self) -> bool {
        self.lo > 1.0 || self.hi < 1.0
    }
}

/// Mean of `values` (one per pixel, row by row, `width` wide) over square
/// blocks of `block` pixels on a side, row by row; edge blocks are smaller.
///
/// Contract: `values.len()` is a multiple of `width`; `width` and `block`
/// at least 1.
pub fn block_means(values: &[f64], width: usize, block: usize) -> Vec<f64> {
    let height = values.len() / width;
    let mut out = Vec::with_capacity(width.div_ceil(block) * height.div_ceil(block));
    for by in (0..height).step_by(block) {
        for bx in (0..width).step_by(block) {
            let (mut sum, mut n) = (0.0, 0usize);
            for y in by..(by + block).min(height) {
                for x in bx..(bx + block).min(width) {
                    sum += values[y * width + x];
                    n += 1;
                }
            }
            out.push(sum / n as f64);
        }
    }
    out
}

/// The ratio `Σ num / Σ den` of two placements' paired block errors and its
/// 95% paired-bootstrap interval over `resamples` draws seeded by `seed`.
///
/// Contract: `num` and `den` have the same length (the same blocks), at
/// least one; deterministic for the same inputs. A denominator summing to 0
/// gives an infinite (or NaN, when the numerator is 0 too) ratio.
pub fn paired_ratio(num: &[f64], den: &[f64], resamples: usize, seed: u64) -> Interval {
    assert_eq!(num.len(), den.len(), "paired blocks");
    let n = num.len();
    let value = num.iter().sum::<f64>() / den.iter().sum::<f64>();
    let mut ratios: Vec<f64> = (0..resamples as u64)
        .map(|r| {
            let (mut a, mut b) = (0.0, 0.0);
            for i in 0..n as u64 {
                let k = (hash2(hash2(seed, r), i) % n as u64) as usize;
                a += num[k];
                b += den[k];
            }
            a / b
        })
        .collect();
    ratios.sort_by(f64::total_cmp);
    let at = |q: f64| ratios[((q * (resamples - 1) as f64).round() as usize).min(resamples - 1)];
    Interval {
        value,
        lo: at(0.025),
        hi: at(0.975),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::unit_f32;

    #[test]
    fn blocks_average_their_pixels() {
        // 3 × 2 image, blocks of 2: [0 1 | 2], [3 4 | 5].
        let v: Vec<f64> = (0..6).map(f64::from).collect();
        assert_eq!(block_means(&v, 3, 2), vec![2.0, 3.5]);
        assert_eq!(block_means(&v, 3, 1), v);
    }

    #[test]
    fn exact_ratios_have_no_spread() {
        let den: Vec<f64> = (1..50).map(f64::from).collect();
        let num: Vec<f64> = den.iter().map(|d| 2.0 * d).collect();
        let r = paired_ratio(&num, &den, 500, 1);
        assert_eq!((r.value, r.lo, r.hi), (2.0, 2.0, 2.0));
        assert!(r.excludes_one());
        let same = paired_ratio(&den, &den, 500, 1);
        assert!(!same.excludes_one() && same.value == 1.0);
    }

    /// Noisy blocks whose true ratio is 1.5: many blocks give an interval
    /// around 1.5 that excludes 1; a handful give one too wide to.
    #[test]
    fn the_interval_narrows_with_blocks_and_covers_the_truth() {
        let noisy = |n: u64, seed: u64| -> (Vec<f64>, Vec<f64>) {
            (0..n)
                .map(|i| {
                    let base = 1.0 + 4.0 * unit_f32(hash2(seed, i)) as f64;
                    let noise = |k| 0.5 + unit_f32(hash2(seed ^ k, i)) as f64;
                    (1.5 * base * noise(7), base * noise(11))
                })
                .unzip()
        };
        let (num, den) = noisy(2000, 3);
        let many = paired_ratio(&num, &den, RESAMPLES, 1);
        assert!(many.lo < 1.5 && 1.5 < many.hi, "{many:?}");
        assert!(many.excludes_one(), "{many:?}");
        let (num, den) = noisy(4, 3);
        let few = paired_ratio(&num, &den, RESAMPLES, 1);
        assert!(
            few.hi - few.lo > many.hi - many.lo,
            "{few:?} against {many:?}"
        );
        assert_eq!(few, paired_ratio(&num, &den, RESAMPLES, 1), "deterministic");
    }
}
