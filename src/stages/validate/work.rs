//! What the tracer did per glossy ray (Wang et al. 2019 §4.2, Table 1):
//! the rays no probe resolved, the texels the march read, and what those
//! reads cost on a GPU that runs its rays in lock step.

use super::metric::{Measure, Show, ViewMetric, ViewRender};
use crate::gpu::kind;

/// Glossy rays no probe resolved (unknown or no probe), as a fraction.
pub struct UnresolvedFraction;

impl ViewMetric for UnresolvedFraction {
    const KEY: &'static str = "unresolved_fraction";
    const LABEL: &'static str = "unresolved";
    const ABOUT: &'static str = "share of the glossy rays no probe resolved (`unresolved_rays` over all), answered with the last probe's radiance where the ray ended";
    const SHOW: Show = Show::Percent(2);

    fn measure(v: &ViewRender) -> Measure {
        let unresolved = v
            .records
            .iter()
            .filter(|r| r.kind == kind::UNKNOWN || r.kind == kind::NO_PROBE)
            .count();
        Measure::Value(unresolved as f64 / v.records.len().max(1) as f64)
    }
}

/// Pyramid texels the march visits per glossy ray, at every level.
pub struct TexelFetchesPerRay;

impl ViewMetric for TexelFetchesPerRay {
    const KEY: &'static str = "texel_fetches_per_ray";
    const LABEL: &'static str = "texel fetches / ray";
    const ABOUT: &'static str = "pyramid texels the march visits per glossy ray, at every level (where the marches differ); the performance figure without GPU timestamps";
    const SHOW: Show = Show::Fixed(1);

    fn measure(v: &ViewRender) -> Measure {
        let fetches: u64 = v.records.iter().map(|r| r.fetches as u64).sum();
        Measure::Value(fetches as f64 / v.records.len().max(1) as f64)
    }
}

/// Lanes of a GPU warp: NVIDIA's 32 (AMD's waves are 32 or 64 wide).
pub const WARP: usize = 32;

/// Pyramid texel fetches per ray as a SIMT GPU pays for them: the rays in
/// dispatch order, `warp` at a time, each group stepping until its longest
/// march ends, so a group costs `warp` × its largest fetch count. The
/// kernels fetch one texel per march step, so this is the march's steps in
/// lock step: a march that saves fetches on average (Wang et al. 2019
/// §4.2, 30–53%) saves time on a GPU only where it shortens each group's
/// longest ray. A model, not a timing: it leaves out memory latency and
/// the step's arithmetic, which differ between marches.
///
/// Contract: 0 for no records; at least the mean fetches per ray; equal
/// to it for `warp` 1; a last partial group costs only its own lanes.
pub fn warp_fetches_per_ray(records: &[crate::gpu::Record], warp: usize) -> f64 {
    let paid: u64 = records
        .chunks(warp.max(1))
        .map(|g| g.len() as u64 * g.iter().map(|r| r.fetches as u64).max().unwrap_or(0))
        .sum();
    paid as f64 / records.len().max(1) as f64
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_warp_pays_for_its_longest_ray() {
        let records: Vec<crate::gpu::Record> = [1u32, 9, 2, 2, 4, 4, 3]
            .iter()
            .map(|&fetches| crate::gpu::Record {
                fetches,
                ..bytemuck::Zeroable::zeroed()
            })
            .collect();
        let mean = 25.0 / 7.0;
        assert!((warp_fetches_per_ray(&records, 1) - mean).abs() < 1e-12);
        // Groups (1 9) (2 2) (4 4) (3): 18 + 4 + 8 + 3 over 7 rays.
        assert!((warp_fetches_per_ray(&records, 2) - 33.0 / 7.0).abs() < 1e-12);
        // (1 9 2 2) (4 4 3): 36 + 12.
        assert!((warp_fetches_per_ray(&records, 4) - 48.0 / 7.0).abs() < 1e-12);
        assert_eq!(warp_fetches_per_ray(&[], WARP), 0.0);
    }
}
