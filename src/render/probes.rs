//! Validation renders: the image a real-time renderer would draw with the
//! light-field probes (McGuire et al. 2017 §5; Wang et al. 2019 §5.1),
//! measured against the path-traced reference.
//!
//! The G-buffer comes from primary rays cast with the BVH on the CPU,
//! through pixel centres of the reference's camera: the first surface's
//! point, normal and material are exact, so the error against the
//! reference measures the probes alone. At each pixel:
//! - **glossy indirect**: rays drawn from the material's glossy lobe
//!   (seeded per pixel; one for `render`, more for `compare`, whose
//!   placements differ by less than one ray's noise), traced through the
//!   probes on the GPU; the radiance read where each ends, times the
//!   lobe's weight `f cos / pdf`, averaged;
//! - **diffuse indirect**: `kd′/π · E`, with E gathered from the
//!   irradiance probes (McGuire §5.2);
//! - **direct**: point, spot and directional lights, shaded analytically
//!   with shadow rays, plus the surface's emission. Emissive surfaces and
//!   the sky reach the image through the probes, as in a real-time engine.
//!
//! The glossy image is compared with the reference's glossy indirect
//! component: light the glossy lobe reflects from surfaces, emitters
//! included ([`crate::render::lights::LightSet::direct_split`]); the sky is
//! direct light there, so rays that leave the scene add nothing to it.

use super::integrator::Renderer;
use super::lights::luminance;
use super::Camera;
use crate::config::CameraParams;
use crate::gpu::{kind, Query, Record};
use crate::raster::RgbImage;
use crate::sampling::Sampler;
use crate::scene::Bounds;
use glam::Vec3;
use rayon::prelude::*;

/// One pixel of the G-buffer.
#[derive(Debug, Clone, Copy, Default)]
pub struct Pixel {
    /// Light known without the probes: emission and delta lights, or the
    /// sky where the primary ray leaves the scene.
    pub direct: Vec3,
    /// `kd′ / π`: what irradiance is multiplied by.
    pub diffuse: Vec3,
    /// Whether the primary ray hit a surface.
    pub surface: bool,
}

/// The G-buffer and the queries the kernels answer for it.
pub struct GBuffer {
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Row-major pixels, rows top to bottom.
    pub pixels: Vec<Pixel>,
    /// One irradiance query (point lifted off the surface, normal) per
    /// pixel with a surface, in pixel order.
    pub irradiance: Vec<Query>,
    /// Pixel of each irradiance query.
    pub irradiance_pixel: Vec<u32>,
    /// One glossy ray per pixel with a glossy lobe, in pixel order.
    pub glossy: Vec<Query>,
    /// Pixel of each glossy ray.
    pub glossy_pixel: Vec<u32>,
    /// `f cos / pdf` of each glossy ray, divided by the rays per pixel.
    pub glossy_weight: Vec<Vec3>,
}

/// A pixel with its irradiance query and its glossy rays with their weights.
type PixelQueries = (Pixel, Option<Query>, Vec<(Query, Vec3)>);

/// Casts the primary rays of `camera` at `width × height` and draws each
/// pixel's `glossy_rays` glossy rays from stream `(seed, pixel)`; rays end
/// at `bounds` (the scene's, padded as the tracer check pads them).
///
/// Contract: `glossy_rays ≥ 1`; deterministic for a seed, whatever the
/// thread count; a pixel's first ray is the same whatever `glossy_rays`;
/// every query direction is unit length and every `t_max` finite.
pub fn gbuffer(
    renderer: &Renderer,
    camera: &CameraParams,
    width: u32,
    height: u32,
    glossy_rays: u32,
    bounds: &Bounds,
    seed: u64,
) -> GBuffer {
    let share = 1.0 / glossy_rays.max(1) as f32;
    let cam = Camera::new(camera, renderer.scene(), width, height);
    let rows: Vec<Vec<PixelQueries>> = (0..height)
        .into_par_iter()
        .map(|y| {
            (0..width)
                .map(|x| {
                    let index = (y * width + x) as u64;
                    let (origin, dir) = cam.ray(x as f32 + 0.5, y as f32 + 0.5);
                    let Some(v) = renderer.intersect(origin, dir) else {
                        let sky = Pixel {
                            direct: renderer.lights().sky(),
                            ..Pixel::default()
                        };
                        return (sky, None, Vec::new());
                    };
                    let bsdf = &v.bsdf;
                    let start = renderer.spawn(&v);
                    let pixel = Pixel {
                        direct: v.emission + renderer.direct_delta(&v),
                        diffuse: bsdf.diffuse * std::f32::consts::FRAC_1_PI,
                        surface: true,
                    };
                    let irradiance = Query {
                        origin: start.to_array(),
                        t_max: 0.0,
                        dir: v.n.to_array(),
                        pad: 0.0,
                    };
                    let mut sampler = Sampler::new(seed, index);
                    let glossy = (0..glossy_rays)
                        .filter_map(|_| {
                            let s = bsdf.sample_glossy(v.n, v.wo, sampler.next_2d())?;
                            let query = Query {
                                origin: start.to_array(),
                                t_max: bounds.exit_distance(start, s.wi),
                                dir: s.wi.to_array(),
                                pad: 0.0,
                            };
                            Some((query, s.weight * share))
                        })
                        .collect();
                    (pixel, Some(irradiance), glossy)
                })
                .collect()
        })
        .collect();
    let mut g = GBuffer {
        width,
        height,
        pixels: Vec::with_capacity((width * height) as usize),
        irradiance: Vec::new(),
        irradiance_pixel: Vec::new(),
        glossy: Vec::new(),
        glossy_pixel: Vec::new(),
        glossy_weight: Vec::new(),
    };
    for (i, (pixel, irradiance, glossy)) in rows.into_iter().flatten().enumerate() {
        g.pixels.push(pixel);
        if let Some(q) = irradiance {
            g.irradiance.push(q);
            g.irradiance_pixel.push(i as u32);
        }
        for (q, weight) in glossy {
            g.glossy.push(q);
            g.glossy_pixel.push(i as u32);
            g.glossy_weight.push(weight);
        }
    }
    g
}

/// A finished validation render.
#[derive(Debug, Clone, PartialEq)]
pub struct ProbeImage {
    /// Direct + diffuse indirect + glossy indirect, row-major.
    pub full: Vec<[f32; 3]>,
    /// The glossy indirect component alone (rays leaving the scene add
    /// nothing, as in the reference's split).
    pub glossy_indirect: Vec<[f32; 3]>,
}

/// Composes the image from the kernels' answers: `irradiance` answers
/// `g.irradiance`, `glossy` answers `g.glossy`, record by record.
///
/// Contract: the records come from the G-buffer's own queries.
pub fn compose(g: &GBuffer, irradiance: &[Record], glossy: &[Record]) -> ProbeImage {
    let mut full: Vec<Vec3> = g.pixels.iter().map(|p| p.direct).collect();
    let mut glossy_indirect = vec![Vec3::ZERO; g.pixels.len()];
    for (&i, r) in g.irradiance_pixel.iter().zip(irradiance) {
        let e = Vec3::from_slice(&r.radiance[..3]);
        full[i as usize] += g.pixels[i as usize].diffuse * e;
    }
    for ((&i, r), weight) in g.glossy_pixel.iter().zip(glossy).zip(&g.glossy_weight) {
        let l = Vec3::from_slice(&r.radiance[..3]) * *weight;
        full[i as usize] += l;
        if r.kind != kind::MISS {
            glossy_indirect[i as usize] += l;
        }
    }
    ProbeImage {
        full: full.iter().map(Vec3::to_array).collect(),
        glossy_indirect: glossy_indirect.iter().map(Vec3::to_array).collect(),
    }
}

/// Mean squared error per channel value between two images of one size.
///
/// Contract: equal lengths; the mean is over pixels × 3 channels.
pub fn mse(a: &[[f32; 3]], b: &[[f32; 3]]) -> f64 {
    assert_eq!(a.len(), b.len(), "images of different sizes");
    let sum: f64 = a
        .iter()
        .zip(b)
        .flat_map(|(x, y)| (0..3).map(move |c| (x[c] as f64 - y[c] as f64).powi(2)))
        .sum();
    sum / (3 * a.len().max(1)) as f64
}

/// `pixels` (`width × height`, row-major) averaged over the
/// `(2·radius+1)²` window around each pixel, clipped at the borders (a
/// separable box filter).
///
/// Contract: `pixels.len() == width · height`; deterministic.
pub fn box_filter(pixels: &[[f32; 3]], width: u32, height: u32, radius: u32) -> Vec<[f32; 3]> {
    let (w, h, r) = (width as usize, height as usize, radius as usize);
    assert_eq!(pixels.len(), w * h, "image size");
    let pass = |src: &[[f64; 3]], stride: usize, step: usize, n: usize, lines: usize| {
        let mut out = vec![[0.0f64; 3]; src.len()];
        for line in 0..lines {
            let at = |i: usize| line * stride + i * step;
            for i in 0..n {
                let (lo, hi) = (i.saturating_sub(r), (i + r).min(n - 1));
                let mut sum = [0.0f64; 3];
                for j in lo..=hi {
                    for c in 0..3 {
                        sum[c] += src[at(j)][c];
                    }
                }
                let k = (hi - lo + 1) as f64;
                out[at(i)] = sum.map(|v| v / k);
            }
        }
        out
    };
    let src: Vec<[f64; 3]> = pixels.iter().map(|p| p.map(f64::from)).collect();
    let rows = pass(&src, w, 1, w, h);
    let both = pass(&rows, 1, w, h, w);
    both.iter().map(|p| p.map(|v| v as f32)).collect()
}

/// A heat map of the luminance of `a − b`: black where they agree, through
/// red and yellow to white at `scale` and beyond.
pub fn error_heat_map(
    a: &[[f32; 3]],
    b: &[[f32; 3]],
    width: u32,
    height: u32,
    scale: f32,
) -> RgbImage {
    let mut img = RgbImage::new(width, height);
    for (i, px) in img.pixels_mut().enumerate() {
        let d = luminance(Vec3::from(a[i]) - Vec3::from(b[i])).abs();
        let x = if scale > 0.0 {
            (d / scale).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let ramp = |lo: f32| ((x - lo) * 3.0).clamp(0.0, 1.0);
        *px = [ramp(0.0), ramp(1.0 / 3.0), ramp(2.0 / 3.0)].map(|v| (v * 255.0).round() as u8);
    }
    img
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mse_is_the_mean_of_squared_channel_differences() {
        let a = [[1.0, 2.0, 3.0], [0.0, 0.0, 0.0]];
        let b = [[1.0, 2.0, 1.0], [0.0, 1.0, 0.0]];
        assert!((mse(&a, &b) - 5.0 / 6.0).abs() < 1e-12);
        assert_eq!(mse(&a, &a), 0.0);
    }

    #[test]
    fn heat_map_runs_from_black_to_white() {
        let a = [[0.0; 3], [0.5; 3], [4.0; 3]];
        let b = [[0.0; 3]; 3];
        let img = error_heat_map(&a, &b, 3, 1, 1.0);
        assert_eq!(img.get_pixel(0, 0), [0, 0, 0]);
        let mid = img.get_pixel(1, 0);
        assert!(
            mid[0] == 255 && mid[1] > 0 && mid[1] < 255 && mid[2] == 0,
            "{mid:?}"
        );
        assert_eq!(img.get_pixel(2, 0), [255, 255, 255]);
    }
}
