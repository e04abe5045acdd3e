//! Deterministic sampling helpers shared by the stages: hashing a seed and an
//! index into random numbers (so parallel loops stay reproducible whatever the
//! thread schedule), well-spread direction sets, area-uniform surface points.

use glam::{Mat3, Quat, Vec3};
use std::f32::consts::PI;

/// SplitMix64 finalizer: a good 64-bit mix of `seed` and `index`, used to give
/// every work item its own random stream independent of execution order.
pub fn hash2(seed: u64, index: u64) -> u64 {
    let mut z = seed ^ index.wrapping_mul(0x9E37_79B9_7F4A_7C15);
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// A uniform number in [0, 1) from the top 24 bits of `h`.
pub fn unit_f32(h: u64) -> f32 {
    (h >> 40) as f32 * (1.0 / (1u64 << 24) as f32)
}

/// `n` unit directions spread evenly over the sphere (spherical Fibonacci
/// lattice): lower variance than random directions for the same ray count.
pub fn fibonacci_sphere(n: u32) -> Vec<Vec3> {
    let golden = PI * (3.0 - 5f32.sqrt());
    (0..n)
        .map(|i| {
            let y = 1.0 - (2.0 * i as f32 + 1.0) / n as f32;
            let r = (1.0 - y * y).max(0.0).sqrt();
            let phi = golden * i as f32;
            Vec3::new(r * phi.cos(), y, r * phi.sin())
        })
        .collect()
}

/// A uniformly random rotation drawn from hash `h` (Shoemake's method), used
/// to decorrelate the fixed direction set between voxels.
pub fn random_rotation(h: u64) -> Mat3 {
    let u1 = unit_f32(hash2(h, 1));
    let u2 = unit_f32(hash2(h, 2)) * 2.0 * PI;
    let u3 = unit_f32(hash2(h, 3)) * 2.0 * PI;
    let a = (1.0 - u1).sqrt();
    let b = u1.sqrt();
    Mat3::from_quat(
        Quat::from_xyzw(a * u2.sin(), a * u2.cos(), b * u3.sin(), b * u3.cos()).normalize(),
    )
}

/// A point uniformly distributed over triangle `t` from two uniforms in [0,1).
pub fn point_in_triangle(t: &[Vec3; 3], u: f32, v: f32) -> Vec3 {
    let su = u.sqrt();
    let b0 = 1.0 - su;
    let b1 = v * su;
    t[0] * b0 + t[1] * b1 + t[2] * (1.0 - b0 - b1)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fibonacci_directions_are_unit_and_balanced() {
        let d = fibonacci_sphere(64);
        assert!(d.iter().all(|v| (v.length() - 1.0).abs() < 1e-5));
        let mean: Vec3 = d.iter().copied().sum::<Vec3>() / 64.0;
        assert!(mean.length() < 0.05, "{mean}");
    }

    #[test]
    fn rotations_are_orthonormal_and_vary() {
        let r = random_rotation(hash2(1, 2));
        assert!((r * r.transpose() - Mat3::IDENTITY).abs_diff_eq(Mat3::ZERO, 1e-5));
        assert!(r.determinant() > 0.99);
        assert_ne!(random_rotation(hash2(1, 3)), r);
    }

    #[test]
    fn triangle_points_stay_inside_and_are_uniform() {
        let t = [Vec3::ZERO, Vec3::X, Vec3::Y];
        let mut below_diag = 0;
        for i in 0..4000u64 {
            let p = point_in_triangle(&t, unit_f32(hash2(9, 2 * i)), unit_f32(hash2(9, 2 * i + 1)));
            assert!(p.x >= -1e-6 && p.y >= -1e-6 && p.x + p.y <= 1.0 + 1e-6);
            if p.x + p.y < std::f32::consts::FRAC_1_SQRT_2 {
                below_diag += 1;
            }
        }
        // The sub-triangle x+y < 1/sqrt(2) holds half the area.
        assert!(
            (below_diag as f32 / 4000.0 - 0.5).abs() < 0.03,
            "{below_diag}"
        );
    }
}
