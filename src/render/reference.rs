//! The path-traced reference image: Wang et al. 2019 §5.1 measure probe
//! placements by the error of the glossy indirect component against a Monte
//! Carlo ground truth, so a reference keeps that component beside the full image.

use super::camera::Camera;
use super::integrator::Renderer;
use crate::config::CameraParams;
use crate::sampling::Sampler;
use glam::DVec3;
use rayon::prelude::*;

/// A rendered reference: linear radiance per pixel, rows top to bottom.
#[derive(Debug, Clone, PartialEq)]
pub struct Reference {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Full radiance (emission, direct, diffuse and glossy indirect), row-major.
    pub full: Vec<[f32; 3]>,
    /// The glossy indirect component alone (Wang et al. 2019 §5.1), row-major.
    pub glossy_indirect: Vec<[f32; 3]>,
}

impl Reference {
    /// Mean of [`Reference::full`] over all pixels, per channel.
    pub fn mean(&self) -> [f64; 3] {
        mean_of(&self.full)
    }

    /// Mean of [`Reference::glossy_indirect`] over all pixels, per channel.
    pub fn glossy_mean(&self) -> [f64; 3] {
        mean_of(&self.glossy_indirect)
    }

    /// Pixel `(x, y)` of the full image (`y` down). Panics outside the image.
    pub fn full_at(&self, x: u32, y: u32) -> [f32; 3] {
        assert!(
            x < self.width && y < self.height,
            "pixel ({x}, {y}) outside the image"
        );
        self.full[(y * self.width + x) as usize]
    }
}

/// Mean of `pixels` per channel (0 for no pixels).
pub fn mean_of(pixels: &[[f32; 3]]) -> [f64; 3] {
    let sum = pixels.iter().fold(DVec3::ZERO, |acc, p| {
        acc + DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64)
    });
    (sum / pixels.len().max(1) as f64).to_array()
}

/// Renders `camera`'s view at `width × height` with `spp` paths per pixel.
///
/// Each path starts at a jittered position inside its pixel (box filter,
/// antialiasing) and is one [`Renderer::radiance_split`] sample. Rows run in
/// parallel; each pixel draws from its own [`Sampler`] stream keyed by
/// `(seed, y·width + x)`, so the same seed gives a bit-identical image
/// whatever the number of threads or their schedule.
///
/// Contract: `width`, `height`, `spp` at least 1 (the config guarantees it).
pub fn render_reference(
    renderer: &Renderer,
    camera: &CameraParams,
    width: u32,
    height: u32,
    spp: u32,
    seed: u64,
) -> Reference {
    let cam = Camera::new(camera, renderer.scene(), width, height);
    let n = width as usize * height as usize;
    let mut full = vec![[0.0f32; 3]; n];
    let mut glossy = vec![[0.0f32; 3]; n];
    let inv = 1.0 / spp.max(1) as f64;
    full.par_chunks_mut(width as usize)
        .zip(glossy.par_chunks_mut(width as usize))
        .enumerate()
        .for_each(|(y, (full_row, glossy_row))| {
            for x in 0..width as usize {
                let mut sampler = Sampler::new(seed, (y * width as usize + x) as u64);
                let (mut f, mut g) = (DVec3::ZERO, DVec3::ZERO);
                for _ in 0..spp {
                    let j = sampler.next_2d();
                    let (origin, dir) = cam.ray(x as f32 + j.x, y as f32 + j.y);
                    let s = renderer.radiance_split(origin, dir, &mut sampler);
                    f += s.full.as_dvec3();
                    g += s.glossy_indirect.as_dvec3();
                }
                full_row[x] = (f * inv).as_vec3().to_array();
                glossy_row[x] = (g * inv).as_vec3().to_array();
            }
        });
    Reference {
        width,
        height,
        full,
        glossy_indirect: glossy,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::{Direction, Light, Point3, Rgb, UpAxis};
    use crate::scene::raycast::SceneBvh;
    use crate::scene::{load_obj, Scene};
    use std::path::Path;

    fn cornell_fixture() -> Scene {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/cornell_box.obj");
        load_obj(&path, 0.001, UpAxis::Y).unwrap()
    }

    fn fixture_camera() -> CameraParams {
        CameraParams {
            position: Point3([0.278, 0.273, -0.8]),
            look_at: Point3([0.278, 0.273, 0.0]),
            up: Direction([0.0, 1.0, 0.0]),
            fov_degrees: 39.3,
        }
    }

    #[test]
    fn cornell_reference_is_reproducible_and_converges() {
        let scene = cornell_fixture();
        let bvh = SceneBvh::new(&scene);
        let r = Renderer::new(&scene, &bvh, &[], 3);
        let cam = fixture_camera();
        let a = render_reference(&r, &cam, 64, 48, 16, 1);
        // Same seed on one thread: bit-identical whatever the schedule.
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap();
        let again = pool.install(|| render_reference(&r, &cam, 64, 48, 16, 1));
        assert!(a == again, "same seed must give the same bits");
        let b = render_reference(&r, &cam, 64, 48, 16, 2);
        assert_ne!(a.full, b.full);
        let (ma, mb) = (a.mean(), b.mean());
        for c in 0..3 {
            assert!(ma[c] > 0.0, "{ma:?}");
            assert!(
                (ma[c] / mb[c] - 1.0).abs() < 0.05,
                "seed 1 {ma:?} vs seed 2 {mb:?}"
            );
        }
        // The all-diffuse fixture has no glossy lobe at all.
        assert!(a.glossy_indirect.iter().all(|p| *p == [0.0; 3]));
        // The red wall (+x) is on the image's left, the green one on its
        // right; the outermost columns look past the open front into the void.
        let left = a.full_at(12, 24);
        let right = a.full_at(51, 24);
        assert_eq!(a.full_at(1, 24), [0.0; 3]);
        assert!(
            left[0] > left[1] && right[1] > right[0],
            "{left:?} {right:?}"
        );
    }

    #[test]
    fn glossy_cornell_box_has_glossy_indirect_light() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../shared/scenes/cornell_box/CornellBox-Glossy.obj");
        let scene = load_obj(&path, 1.0, UpAxis::Y).unwrap();
        // The room spans about [-1, 1] × [0, 1.59] × [-1.04, 0.99], open at +z.
        let (min, max) = (
            scene.to_world(scene.bounds.min),
            scene.to_world(scene.bounds.max),
        );
        assert!((max.y - 1.59).abs() < 0.01, "{min} {max}");
        assert!(max.z < 1.0 && min.z > -1.1);
        // Its MTL does not define the `light` material, so the ceiling quad is
        // not emissive: light it with a point source just below it.
        let light = Light::Point {
            position: Point3([0.0, 1.3, -0.03]),
            intensity: Rgb([3.0, 2.1, 0.7]),
        };
        let bvh = SceneBvh::new(&scene);
        let r = Renderer::new(&scene, &bvh, &[light], 2);
        let cam = CameraParams {
            position: Point3([0.0, 1.0, 3.4]),
            look_at: Point3([0.0, 1.0, 0.0]),
            up: Direction([0.0, 1.0, 0.0]),
            fov_degrees: 40.0,
        };
        let img = render_reference(&r, &cam, 48, 36, 8, 3);
        let g = img.glossy_mean();
        let f = img.mean();
        assert!(g.iter().all(|&c| c > 0.0), "{g:?}");
        assert!((0..3).all(|c| g[c] < f[c]), "{g:?} {f:?}");
        let glossy_pixels = img.glossy_indirect.iter().filter(|p| p[0] > 0.0).count();
        assert!(glossy_pixels > 20, "{glossy_pixels}");
    }
}
