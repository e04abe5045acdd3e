//! Octahedral mapping of the unit sphere onto the square [-1, 1]²
//! (Cigolle et al. 2014, "A Survey of Efficient Representations for
//! Independent Unit Vectors"; McGuire et al. 2017 §3 stores every probe map
//! this way).
//!
//! The sphere is projected onto the octahedron |x|+|y|+|z| = 1; the upper
//! half (z ≥ 0) maps to the diamond |u|+|v| ≤ 1 and the lower half folds
//! out over the four corners. Texels of an n×n map have equal area in the
//! square; their solid angles, ∝ 1/|p|³ for the octahedron point p, vary
//! by at most (√3)³ ≈ 5.2 between a face's centre and its vertices.

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

/// The texel of an `n`×`n` map whose footprint contains direction `d`.
///
/// Contract: `d` is non-zero; the result lies in `0..n` on both axes. A
/// direction on a texel edge belongs to the texel above/right of it, except
/// on the square's outer edge, which belongs to the last texel.
pub fn texel_of(d: Vec3, n: u32) -> (u32, u32) {
    let e = encode(d);
    let f = |c: f32| (((c + 1.0) * 0.5 * n as f32) as i64).clamp(0, n as i64 - 1) as u32;
    (f(e.x), f(e.y))
}

/// Direction through corner (`x`, `y`) of the texel grid of an `n`×`n` map,
/// `x`, `y` in `0..=n` (texel (x, y) has corners (x, y) … (x+1, y+1)).
pub fn corner_direction(x: u32, y: u32, n: u32) -> Vec3 {
    decode(Vec2::new(x as f32, y as f32) / n as f32 * 2.0 - 1.0)
}

/// The texel that lies across the map's border from the out-of-range texel
/// (`x`, `y`), `x`, `y` in `-1..=n`, for filtering across the octahedral fold.
///
/// The square's edges fold onto themselves: the point (1, v) is the same
/// direction as (1, −v), and so on, so the neighbour beyond an edge is the
/// mirror image along that edge; beyond a corner it is the opposite corner.
/// In-range texels are returned unchanged.
pub fn wrap_texel(x: i64, y: i64, n: u32) -> (u32, u32) {
    let n = n as i64;
    let (mut wx, mut wy) = (x, y);
    if x < 0 || x >= n {
        wx = x.clamp(0, n - 1);
        wy = n - 1 - y;
    }
    if y < 0 || y >= n {
        wy = wy.clamp(0, n - 1);
        wx = n - 1 - wx;
    }
    (wx.clamp(0, n - 1) as u32, wy.clamp(0, n - 1) as u32)
}

/// Solid angle (steradians) of every texel of an `n`×`n` map, row by row.
///
/// The octahedral map sends square point (u, v) to the octahedron point p
/// with |p|₁ = 1; the area element of the face x+y+z = 1 is √3 du dv and
/// its cosine to the viewing ray is 1/(√3 |p|), so dω = du dv / |p|³ on
/// every face (the fold of the lower half is an isometry of the square).
/// Each texel integrates this with a `k`×`k` midpoint rule (k = 8); the
/// total is 4π to about 1e-5.
pub fn texel_solid_angles(n: u32) -> Vec<f32> {
    const K: u32 = 8;
    let du = 2.0 / n as f64 / K as f64;
    let mut out = Vec::with_capacity((n * n) as usize);
    for y in 0..n {
        for x in 0..n {
            let mut sum = 0.0f64;
            for j in 0..K {
                for i in 0..K {
                    let u = -1.0 + (x * K + i) as f64 * du + 0.5 * du;
                    let v = -1.0 + (y * K + j) as f64 * du + 0.5 * du;
                    let z = 1.0 - u.abs() - v.abs();
                    let (px, py) = if z < 0.0 {
                        (1.0 - v.abs(), 1.0 - u.abs())
                    } else {
                        (u.abs(), v.abs())
                    };
                    let len = (px * px + py * py + z * z).sqrt();
                    sum += du * du / (len * len * len);
                }
            }
            out.push(sum as f32);
        }
    }
    out
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

    #[test]
    fn seams_are_continuous() {
        // The outer edges fold onto themselves: mirrored points are one direction.
        for k in 0..=64 {
            let t = k as f32 / 32.0 - 1.0;
            for (a, b) in [
                (Vec2::new(1.0, t), Vec2::new(1.0, -t)),
                (Vec2::new(-1.0, t), Vec2::new(-1.0, -t)),
                (Vec2::new(t, 1.0), Vec2::new(-t, 1.0)),
                (Vec2::new(t, -1.0), Vec2::new(-t, -1.0)),
            ] {
                assert!((decode(a) - decode(b)).length() < 1e-6, "{a:?} {b:?}");
            }
        }
        // Small steps in the square are small steps on the sphere everywhere,
        // including across the diagonal fold |u|+|v| = 1 and the axes:
        // the map's stretch peaks at the face centres, where |p| = 1/√3.
        let step = 1e-3;
        for k in 0..20_000u64 {
            let e = Vec2::new(unit_f32(hash2(3, 2 * k)), unit_f32(hash2(3, 2 * k + 1))) * 2.0 - 1.0;
            let a = unit_f32(hash2(4, k)) * std::f32::consts::TAU;
            let f = (e + Vec2::new(a.cos(), a.sin()) * step).clamp(Vec2::NEG_ONE, Vec2::ONE);
            let moved = (decode(f) - decode(e)).length();
            assert!(
                moved <= 3.5 * (f - e).length() + 1e-6,
                "{e:?} -> {f:?}: {moved}"
            );
        }
    }

    #[test]
    fn texel_lookup_inverts_texel_centres() {
        for n in [1, 2, 8, 32, 128] {
            for y in 0..n {
                for x in 0..n {
                    assert_eq!(texel_of(texel_direction(x, y, n), n), (x, y), "n={n}");
                }
            }
        }
        for d in fibonacci_sphere(500) {
            let (x, y) = texel_of(d, 16);
            // The direction lies within its texel's corners' angular reach.
            let c = texel_direction(x, y, 16);
            let r = (0..2)
                .flat_map(|i| (0..2).map(move |j| corner_direction(x + i, y + j, 16)))
                .map(|k| k.dot(c).clamp(-1.0, 1.0).acos())
                .fold(0.0f32, f32::max);
            assert!(d.dot(c).clamp(-1.0, 1.0).acos() <= r + 1e-5, "{d:?}");
        }
    }

    #[test]
    fn wrapped_neighbours_are_angular_neighbours() {
        let n = 16u32;
        let width = 2.0 * std::f32::consts::PI / n as f32;
        for y in -1..=n as i64 {
            for x in -1..=n as i64 {
                let inside = (0..n as i64).contains(&x) && (0..n as i64).contains(&y);
                let (wx, wy) = wrap_texel(x, y, n);
                if inside {
                    assert_eq!((wx as i64, wy as i64), (x, y));
                    continue;
                }
                // The wrapped texel touches the in-range texel it borders.
                let (bx, by) = (
                    x.clamp(0, n as i64 - 1) as u32,
                    y.clamp(0, n as i64 - 1) as u32,
                );
                let gap = texel_direction(wx, wy, n)
                    .dot(texel_direction(bx, by, n))
                    .clamp(-1.0, 1.0)
                    .acos();
                assert!(gap < 1.6 * width, "({x},{y}) -> ({wx},{wy}): {gap}");
            }
        }
    }

    #[test]
    fn solid_angles_sum_to_the_sphere() {
        for n in [4, 16, 64] {
            let w = texel_solid_angles(n);
            let total: f64 = w.iter().map(|&a| a as f64).sum();
            assert!(
                (total - 4.0 * std::f64::consts::PI).abs() < 1e-4,
                "n={n}: {total}"
            );
            let (lo, hi) = w
                .iter()
                .fold((f32::MAX, 0.0f32), |(a, b), &x| (a.min(x), b.max(x)));
            assert!(hi / lo < 5.2, "n={n}: {lo}..{hi}");
        }
    }
}
