//! The image errors of a validation render against the path-traced
//! reference (Wang et al. 2019 §5.1, Fig. 8: the glossy indirect
//! component, where placement shows).

use super::metric::{Measure, Show, ViewMetric, ViewRender};
use crate::render::lights::luminance;
use crate::render::probes::mse;
use glam::Vec3;

/// `ε` of [`MseGlossyRelative`] as a share of the squared mean luminance
/// of the view's filtered reference glossy indirect: keeps dark pixels
/// from dominating (Rousselle et al. 2011's relative MSE adds such a
/// constant).
pub const RELATIVE_EPSILON: f64 = 0.01;

/// Mean luminance of `pixels`, non-finite values left out (0 for none).
pub fn mean_luminance(pixels: &[[f32; 3]]) -> f64 {
    pixels
        .iter()
        .map(|&p| luminance(Vec3::from(p)) as f64)
        .filter(|v| v.is_finite())
        .sum::<f64>()
        / pixels.len().max(1) as f64
}

/// The glossy indirect image's MSE against the reference's, per pixel and
/// channel.
pub struct MseGlossy;

impl ViewMetric for MseGlossy {
    const KEY: &'static str = "mse_glossy";
    const LABEL: &'static str = "glossy MSE";
    const ABOUT: &'static str = "MSE of the glossy indirect image against the reference's (`reference-glossy.exr`), per pixel and channel";
    const SHOW: Show = Show::Sci;

    fn measure(v: &ViewRender) -> Measure {
        Measure::Value(mse(&v.image.glossy_indirect, &v.reference.glossy_indirect))
    }
}

/// [`MseGlossy`] after a 7×7 box filter of both images, which removes most
/// sampling noise and keeps what placement changes: missing and wrong
/// reflections (Wang's Fig. 8 compares filtered glossy components). The
/// quality figure `compare`'s matches use.
pub struct MseGlossyFiltered;

impl ViewMetric for MseGlossyFiltered {
    const KEY: &'static str = "mse_glossy_filtered";
    const LABEL: &'static str = "filtered glossy MSE";
    const ABOUT: &'static str = "the same after a 7×7 box filter of both images, which removes most sampling noise and keeps what placement changes: missing and wrong reflections (Wang et al. 2019 Fig. 8); the matches' quality figure";
    const SHOW: Show = Show::Sci;
    const PAIRED: bool = true;

    fn measure(v: &ViewRender) -> Measure {
        Measure::Pixels(
            v.filtered
                .iter()
                .zip(v.filtered_reference)
                .map(|(x, y)| {
                    (0..3)
                        .map(|c| (x[c] as f64 - y[c] as f64).powi(2))
                        .sum::<f64>()
                        / 3.0
                })
                .collect(),
        )
    }
}

/// Relative MSE of the filtered glossy indirect: the mean of
/// `(x − r)² / (r² + ε)` per pixel and channel, `ε` being
/// [`RELATIVE_EPSILON`] of the reference's squared mean luminance, so that
/// dim and bright regions weigh alike; 0 for a black reference.
pub struct MseGlossyRelative;

impl ViewMetric for MseGlossyRelative {
    const KEY: &'static str = "mse_glossy_relative";
    const LABEL: &'static str = "relative MSE";
    const ABOUT: &'static str = "relative MSE of the filtered glossy indirect: the mean of (x − r)² / (r² + ε) per pixel and channel, ε 1% of the filtered reference's squared mean luminance, so dim and bright regions weigh alike";
    const SHOW: Show = Show::Sci;

    fn measure(v: &ViewRender) -> Measure {
        let epsilon = RELATIVE_EPSILON * mean_luminance(v.filtered_reference).powi(2);
        if epsilon.is_nan() || epsilon <= 0.0 {
            return Measure::Value(0.0);
        }
        let sum = v
            .filtered
            .iter()
            .zip(v.filtered_reference)
            .map(|(x, y)| {
                (0..3)
                    .map(|c| {
                        (x[c] as f64 - y[c] as f64).powi(2) / ((y[c] as f64).powi(2) + epsilon)
                    })
                    .sum::<f64>()
                    / 3.0
            })
            .sum::<f64>();
        Measure::Value(sum / v.filtered.len().max(1) as f64)
    }
}

/// The whole image's MSE against the reference's.
pub struct MseFull;

impl ViewMetric for MseFull {
    const KEY: &'static str = "mse_full";
    const LABEL: &'static str = "full-image MSE";
    const ABOUT: &'static str = "MSE of the whole image against `reference.exr`";
    const SHOW: Show = Show::Sci;

    fn measure(v: &ViewRender) -> Measure {
        Measure::Value(mse(&v.image.full, &v.reference.full))
    }
}
