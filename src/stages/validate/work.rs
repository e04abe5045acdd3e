//! What the tracer did per glossy ray (Wang et al. 2019 §4.2, Table 1):
//! the rays no probe resolved, the texels the march read.

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
