//! Octahedral mapping of the unit sphere onto the square [-1, 1]²
//! (Cigolle et al. 2014, "A Survey of Efficient Representations for
//! Independent Unit Vectors"; McGuire et al. 2017 §3 stores every probe map
//! this way).
//!
//! The sphere is projected onto the octahedron |x|+|y|+|z| = 1; the upper
//! half (z ≥ 0) maps to the diamond |u|+|v| ≤ 1 and the lower half folds
//! out over the four corners. Texels of an n×n map have equal area in the
//! square, which is within a factor of about 2 of equal solid angle.

use glam::{Vec2, Vec3};

/// Sign that maps 0 to +1, so that the fold of the lower hemisphere is
/// defined on the axes.
fn sign_not_zero(v: Vec2) -> Vec2 {
    Vec2::new(
        if v.x >= 0.0 { 1.0 } else { -1.0 },
        if v.y >= 0.0 { 1.0 } else { -1.0 },
    )
}

/// The point of [-1, 1]² that represents direction `d`.
///
/// Contract: `d` is non-zero (its length does not matter); the result lies
/// in [-1, 1]² and `decode(encode(d))` is `d` normalized, up to rounding.
pub fn encode(d: Vec3) -> Vec2 {
    let p = Vec2::new(d.x, d.y) / (d.x.abs() + d.y.abs() + d.z.abs());
    if d.z < 0.0 {
        (Vec2::ONE - Vec2::new(p.y.abs(), p.x.abs())) * sign_not_zero(p)
    } else {
        p
    }
}

/// The unit direction represented by `e` in [-1, 1]².
///
/// Contract: the result has unit length; points outside the square are
/// clamped into it first.
pub fn decode(e: Vec2) -> Vec3 {
    let e = e.clamp(Vec2::NEG_ONE, Vec2::ONE);
    let z = 1.0 - e.x.abs() - e.y.abs();
    let xy = if z < 0.0 {
        (Vec2::ONE - Vec2::new(e.y.abs(), e.x.abs())) * sign_not_zero(e)
    } else {
        e
    };
    Vec3::new(xy.x, xy.y, z).normalize()
}

/// Direction through the centre of texel (`x`, `y`) of an `n`×`n` map.
pub fn texel_direction(x: u32, y: u32, n: u32) -> Vec3 {
    let e = (Vec2::new(x as f32, y as f32) + 0.5) / n as f32 * 2.0 - 1.0;
    decode(e)
}

/// The directions through all texel centres of an `n`×`n` map, row by row.
pub fn texel_directions(n: u32) -> Vec<Vec3> {
    (0..n)
        .flat_map(|y| (0..n).map(move |x| texel_direction(x, y, n)))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::{fibonacci_sphere, hash2, unit_f32};

    #[test]
    fn round_trips_and_stays_in_the_square() {
        for d in fibonacci_sphere(4096) {
            let e = encode(d);
            assert!(e.abs().max_element() <= 1.0 + 1e-6, "{e:?}");
            assert!((decode(e) - d).length() < 1e-5, "{d:?}");
        }
        for k in 0..4096u64 {
            let e = Vec2::new(unit_f32(hash2(7, 2 * k)), unit_f32(hash2(7, 2 * k + 1))) * 2.0 - 1.0;
            assert!((encode(decode(e)) - e).length() < 1e-5, "{e:?}");
        }
    }

    #[test]
    fn texel_directions_cover_the_sphere_evenly() {
        let n = 16;
        let dirs = texel_directions(n);
        assert_eq!(dirs.len(), 256);
        // Every direction of a dense set has a texel direction within about
        // one texel's angular width (4π/n² steradians, a few times over).
        let width = (4.0 * std::f32::consts::PI / (n * n) as f32).sqrt();
        for d in fibonacci_sphere(2000) {
            let nearest = dirs
                .iter()
                .map(|t| t.dot(d).clamp(-1.0, 1.0).acos())
                .fold(f32::INFINITY, f32::min);
            assert!(nearest < 1.5 * width, "{d:?}: {nearest} vs {width}");
        }
        // Mirror symmetry of the layout: as many directions point up as down.
        let up = dirs.iter().filter(|d| d.z > 1e-6).count();
        let down = dirs.iter().filter(|d| d.z < -1e-6).count();
        assert_eq!(up, down);
        assert!(up > 100);
    }
}
