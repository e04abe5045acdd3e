//! The perceptual error of a validation render: ꟻLIP (Andersson et al.
//! 2020), as `render::flip` computes it.

use super::metric::{Measure, Show, ViewMetric, ViewRender};

/// Mean ꟻLIP error of the tone-mapped, filtered glossy indirect against
/// the reference's, in [0, 1].
pub struct Flip;

impl ViewMetric for Flip {
    const KEY: &'static str = "flip";
    const LABEL: &'static str = "ꟻLIP";
    const ABOUT: &'static str = "mean ꟻLIP error (NVIDIA's perceptual difference, Andersson et al. 2020, at 67 pixels per degree) of the filtered glossy indirect against the reference's, both tone mapped at the filtered reference's exposure; 0 is identical, 1 the most different";
    const SHOW: Show = Show::Fixed(4);
    const PAIRED: bool = true;

    fn measure(v: &ViewRender) -> Measure {
        Measure::Pixels(v.flip_map.iter().map(|&e| e as f64).collect())
    }
}
