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
//! spread; and views before blocks, since views differ far more than the
//! blocks of one view ([`paired_ratio_over_views`]).

use crate::sampling::hash2;

/// Resamples [`paired_ratio_over_views`] draws by default.
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

/// `value` with the 2.5th and 97.5th percentiles of `ratios` (the
/// resampled ratios, at least one) as its interval.
fn percentile_interval(value: f64, mut ratios: Vec<f64>) -> Interval {
    ratios.sort_by(f64::total_cmp);
    let n = ratios.len();
    let at = |q: f64| ratios[((q * (n - 1) as f64).round() as usize).min(n - 1)];
    Interval {
        value,
        lo: at(0.025),
        hi: at(0.975),
    }
}

/// The ratio of two placements' pooled errors over several views, and its
/// 95% interval by a two-stage paired bootstrap (Davison & Hinkley 1997
/// §3.8, resampling clusters then units within them): each draw picks as
/// many views as there are, with replacement, and within each picked view
/// as many of its blocks, with replacement; the same draw applies to both
/// placements. `num[v]` and `den[v]` are the block errors of view `v`. A
/// placement's pooled error is the mean over views of each view's mean
/// block error, so every view weighs alike whatever its size.
///
/// Contract: `num` and `den` have the same shape, at least one view of at
/// least one block each; deterministic for the same inputs.
pub fn paired_ratio_over_views(
    num: &[Vec<f64>],
    den: &[Vec<f64>],
    resamples: usize,
    seed: u64,
) -> Interval {
    assert_eq!(num.len(), den.len(), "paired views");
    assert!(!num.is_empty(), "at least one view");
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len().max(1) as f64;
    let pooled = |m: &[Vec<f64>]| m.iter().map(|v| mean(v)).sum::<f64>();
    let value = pooled(num) / pooled(den);
    let views = num.len() as u64;
    let ratios: Vec<f64> = (0..resamples as u64)
        .map(|r| {
            let draw = hash2(seed, r);
            let (mut a, mut b) = (0.0, 0.0);
            for slot in 0..views {
                let v = (hash2(draw, slot) % views) as usize;
                let (nv, dv) = (&num[v], &den[v]);
                assert_eq!(nv.len(), dv.len(), "paired blocks");
                let blocks = nv.len() as u64;
                let pick = hash2(hash2(draw, slot), 0xB10C);
                let (mut sa, mut sb) = (0.0, 0.0);
                for i in 0..blocks {
                    let k = (hash2(pick, i) % blocks) as usize;
                    sa += nv[k];
                    sb += dv[k];
                }
                a += sa / blocks as f64;
                b += sb / blocks as f64;
            }
            a / b
        })
        .collect();
    percentile_interval(value, ratios)
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
        let r = paired_ratio_over_views(&[num], std::slice::from_ref(&den), 500, 1);
        assert_eq!((r.value, r.lo, r.hi), (2.0, 2.0, 2.0));
        assert!(r.excludes_one());
        let same = paired_ratio_over_views(
            std::slice::from_ref(&den),
            std::slice::from_ref(&den),
            500,
            1,
        );
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
        let one = |v: Vec<f64>| vec![v];
        let many = paired_ratio_over_views(&one(num), &one(den), RESAMPLES, 1);
        assert!(many.lo < 1.5 && 1.5 < many.hi, "{many:?}");
        assert!(many.excludes_one(), "{many:?}");
        let (num, den) = noisy(4, 3);
        let (num, den) = (one(num), one(den));
        let few = paired_ratio_over_views(&num, &den, RESAMPLES, 1);
        assert!(
            few.hi - few.lo > many.hi - many.lo,
            "{few:?} against {many:?}"
        );
        assert_eq!(
            few,
            paired_ratio_over_views(&num, &den, RESAMPLES, 1),
            "deterministic"
        );
    }

    /// Views that disagree widen the interval: a placement better in half
    /// the views and worse in the rest is no win, however many blocks each
    /// view has, while one better in every view is.
    #[test]
    fn views_that_disagree_give_no_win() {
        let view = |scale: f64, seed: u64| -> Vec<f64> {
            (0..300)
                .map(|i| scale * (0.5 + unit_f32(hash2(seed, i)) as f64))
                .collect()
        };
        let den: Vec<Vec<f64>> = (0..8).map(|v| view(1.0, v)).collect();
        let split: Vec<Vec<f64>> = (0..8)
            .map(|v| view(if v % 2 == 0 { 0.5 } else { 1.6 }, v))
            .collect();
        let mixed = paired_ratio_over_views(&split, &den, RESAMPLES, 2);
        assert!(!mixed.excludes_one(), "{mixed:?}");
        let better: Vec<Vec<f64>> = (0..8).map(|v| view(0.7, v)).collect();
        let win = paired_ratio_over_views(&better, &den, RESAMPLES, 2);
        assert!(win.hi < 1.0 && win.lo > 0.6, "{win:?}");
        assert!((win.value - 0.7).abs() < 1e-9, "{win:?}");
    }
}
