//! ꟻLIP, NVIDIA's perceptual difference of two displayed images (Andersson
//! et al. 2020, *FLIP: A Difference Evaluator for Alternating Images*,
//! HPG; the LDR evaluator of its §3–4), through the `nv-flip` crate, which
//! builds NVIDIA's reference C++ implementation.
//!
//! MSE weighs every radiance difference alike; an expert comparing
//! placements also asks what a viewer sees: a missing reflection on a dark
//! wall and the same error in a bright highlight differ on screen. ꟻLIP
//! compares the images as a viewer at [`PIXELS_PER_DEGREE`] would, after
//! tone mapping, giving each pixel an error in [0, 1].
//!
//! The comparison applies it to the glossy-indirect component tone mapped
//! at one exposure per view (the reference's), box filtered as for
//! [`crate::stages::validate::Metrics::mse_glossy_filtered`]: at the ray
//! counts a comparison affords, the unfiltered images differ mostly by
//! Monte Carlo noise that every placement shares.

use crate::raster::RgbImage;
use nv_flip::{FlipImageRgb8, DEFAULT_PIXELS_PER_DEGREE};

/// Pixels per degree of visual angle: ꟻLIP's default, a 0.7 m wide 4K
/// monitor seen from 0.7 m (Andersson et al. 2020 §3).
pub const PIXELS_PER_DEGREE: f32 = DEFAULT_PIXELS_PER_DEGREE;

/// `pixels` tone mapped at `exposure` to sRGB bytes, RGB row by row: what
/// ꟻLIP compares.
///
/// Contract: `pixels.len() == width · height`.
pub fn display(pixels: &[[f32; 3]], width: u32, height: u32, exposure: f32) -> Vec<u8> {
    crate::raster::tonemap(pixels, width, height, exposure).into_raw()
}

/// The ꟻLIP error of each pixel of `test` against `reference` (both from
/// [`display`], `width × height`), row by row, each in [0, 1].
///
/// Contract: both images have `3 · width · height` bytes; deterministic.
pub fn flip(reference: &[u8], test: &[u8], width: u32, height: u32) -> Vec<f32> {
    let n = 3 * width as usize * height as usize;
    assert!(reference.len() == n && test.len() == n, "image sizes");
    let r = FlipImageRgb8::with_data(width, height, reference);
    let t = FlipImageRgb8::with_data(width, height, test);
    nv_flip::flip(r, t, PIXELS_PER_DEGREE).to_vec()
}

/// `errors` (from [`flip`]) through ꟻLIP's magma colour map, as an image.
///
/// Contract: `errors.len() == width · height`.
pub fn error_map(errors: &[f32], width: u32, height: u32) -> RgbImage {
    let image = nv_flip::FlipImageFloat::with_data(width, height, errors);
    let bytes = image.apply_color_lut(&nv_flip::magma_lut()).to_vec();
    RgbImage::from_raw(width, height, bytes).expect("3 bytes per pixel")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn gradient(w: u32, h: u32, shift: f32) -> Vec<[f32; 3]> {
        (0..w * h)
            .map(|i| {
                let x = (i % w) as f32 / w as f32;
                [x * 0.5 + shift, 0.2, 0.3]
            })
            .collect()
    }

    #[test]
    fn identical_images_have_no_error_and_larger_changes_more() {
        let (w, h) = (32, 24);
        let base = display(&gradient(w, h, 0.0), w, h, 1.0);
        let same = flip(&base, &base, w, h);
        assert!(same.iter().all(|&e| e == 0.0));
        let mean = |shift| {
            let e = flip(&base, &display(&gradient(w, h, shift), w, h, 1.0), w, h);
            assert!(e.iter().all(|v| (0.0..=1.0).contains(v)));
            e.iter().sum::<f32>() / e.len() as f32
        };
        let (small, large) = (mean(0.05), mean(0.3));
        assert!(0.0 < small && small < large, "{small} {large}");
        assert_eq!(error_map(&same, w, h).dimensions(), (w, h));
    }
}
