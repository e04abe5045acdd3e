//! The pinhole camera of reference renders (config [`CameraParams`]).
//!
//! Pixel coordinates are continuous: pixel `(i, j)` covers `[i, i+1) × [j, j+1)`,
//! `y` grows downwards as in image files, and the vertical field of view spans
//! the image's height; the horizontal one follows from the aspect ratio.

use crate::config::CameraParams;
use crate::scene::Scene;
use glam::{DVec3, Vec3};

/// A pinhole camera with its image plane set up for one resolution.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Camera {
    position: Vec3,
    forward: Vec3,
    /// Image-plane vector from the centre to the right edge, at unit distance.
    right: Vec3,
    /// Image-plane vector from the centre to the top edge, at unit distance.
    up: Vec3,
    width: f32,
    height: f32,
}

impl Camera {
    /// The camera `params` (world coordinates, as the config gives them)
    /// producing a `width × height` image, in `scene`'s local coordinates,
    /// which its rays are traced in.
    ///
    /// Contract: `params` validated by the config (look-at differs from the
    /// position, up not parallel to the view, fov in (0°, 180°)); `width` and
    /// `height` at least 1.
    pub fn new(params: &CameraParams, scene: &Scene, width: u32, height: u32) -> Camera {
        let position = scene.to_local(DVec3::from(params.position.0));
        let forward = (scene.to_local(DVec3::from(params.look_at.0)) - position).normalize();
        let right = forward.cross(Vec3::from(params.up.0)).normalize();
        let up = right.cross(forward);
        let half_h = (0.5 * params.fov_degrees.to_radians()).tan();
        let aspect = width as f32 / height as f32;
        Camera {
            position,
            forward,
            right: right * (half_h * aspect),
            up: up * half_h,
            width: width as f32,
            height: height as f32,
        }
    }

    /// The ray through continuous pixel position `(px, py)`: its origin (the
    /// eye) and unit direction. `(0, 0)` is the top-left corner of the image,
    /// `(width, height)` the bottom-right one.
    pub fn ray(&self, px: f32, py: f32) -> (Vec3, Vec3) {
        let x = 2.0 * px / self.width - 1.0;
        let y = 1.0 - 2.0 * py / self.height;
        let dir = (self.forward + self.right * x + self.up * y).normalize();
        (self.position, dir)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::{Direction, Point3};

    fn params(fov: f32) -> CameraParams {
        CameraParams {
            position: Point3([0.0, 1.0, 3.0]),
            look_at: Point3([0.0, 1.0, 0.0]),
            up: Direction([0.0, 1.0, 0.0]),
            fov_degrees: fov,
        }
    }

    #[test]
    fn centre_looks_at_the_target_and_edges_span_the_field_of_view() {
        let cam = Camera::new(
            &params(40.0),
            &crate::scene::testing::room_with_box(),
            200,
            100,
        );
        let (o, d) = cam.ray(100.0, 50.0);
        assert_eq!(o, Vec3::new(0.0, 1.0, 3.0));
        assert!((d - Vec3::NEG_Z).length() < 1e-6);
        // Top edge: 20° above the axis; y down in the image.
        let (_, top) = cam.ray(100.0, 0.0);
        assert!((top.y - 20f32.to_radians().sin()).abs() < 1e-5, "{top}");
        let (_, bottom) = cam.ray(100.0, 100.0);
        assert!(bottom.y < 0.0);
        // Right edge: tan(half width) = aspect · tan(20°). Looking down -z
        // with y up, the image's right is +x.
        let (_, right) = cam.ray(200.0, 50.0);
        assert!((right.x / -right.z - 2.0 * 20f32.to_radians().tan()).abs() < 1e-5);
    }
}
