//! Deterministic sampling helpers shared by the stages: hashing a seed and an
//! index into random numbers (so parallel loops stay reproducible whatever the
//! thread schedule), well-spread direction sets, area-uniform surface points.
//!
//! Why not the `rand` crates: every draw here is a pure function of
//! `(seed, stream, index)`, so any work item, on any thread, in any order,
//! gets the same numbers with no generator state to create, seed or carry;
//! a `rand` generator per work item (seeded from such a hash) would give the
//! same guarantee at the cost of its state and setup in the hottest loops
//! (path tracing, coverage), and its streams may change between `rand`
//! releases, which would silently change every figure. The crates were
//! declared and unused, and are removed (docs/method.md, "Random numbers").

use glam::{DVec3, Mat3, Quat, Vec3};
use std::f32::consts::PI;

/// SplitMix64 finalizer: a good 64-bit mix of `seed` and `index`, used to give
/// every work item its own random stream independent of execution order.
#[inline]
pub fn hash2(seed: u64, index: u64) -> u64 {
    let mut z = seed ^ index.wrapping_mul(0x9E37_79B9_7F4A_7C15);
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// A uniform number in [0, 1) from the top 24 bits of `h`.
#[inline]
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

/// The `i`-th of a stream of directions uniform over the sphere, keyed by
/// `seed` (two hashed uniforms: z and the azimuth).
pub fn uniform_direction(seed: u64, i: u64) -> Vec3 {
    let z = 2.0 * unit_f32(hash2(seed, 2 * i)) - 1.0;
    let phi = 2.0 * PI * unit_f32(hash2(seed, 2 * i + 1));
    let r = (1.0 - z * z).max(0.0).sqrt();
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
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
#[inline]
pub fn point_in_triangle(t: &[Vec3; 3], u: f32, v: f32) -> Vec3 {
    let su = u.sqrt();
    let b0 = 1.0 - su;
    let b1 = v * su;
    t[0] * b0 + t[1] * b1 + t[2] * (1.0 - b0 - b1)
}

/// Solid angle (steradians) that triangle `t` subtends at `p`, by Van
/// Oosterom and Strackee's formula (1983): `tan(Ω/2) = |a·(b×c)| /
/// (1 + a·b + b·c + c·a)` with `a`, `b`, `c` the unit directions to the
/// corners. 0 when `p` lies on a corner.
pub fn solid_angle(p: DVec3, t: &[DVec3; 3]) -> f64 {
    corners_seen_from(p, t).map_or(0.0, |[a, b, c]| solid_angle_of_units(a, b, c))
}

/// The unit directions from `p` to the corners of `t`; `None` when `p`
/// lies on a corner.
fn corners_seen_from(p: DVec3, t: &[DVec3; 3]) -> Option<[DVec3; 3]> {
    let units = t.map(|v| (v - p).normalize_or_zero());
    (!units.contains(&DVec3::ZERO)).then_some(units)
}

/// [`solid_angle`] of the spherical triangle with unit corners `a`, `b`, `c`.
fn solid_angle_of_units(a: DVec3, b: DVec3, c: DVec3) -> f64 {
    let num = a.dot(b.cross(c)).abs();
    let den = 1.0 + a.dot(b) + b.dot(c) + c.dot(a);
    2.0 * num.atan2(den)
}

/// `∫ cos θ dω` over the directions from `p` into triangle `t`, against
/// normal `n` (the irradiance a unit-radiance emitter gives, over π the form
/// factor): Lambert's formula `½ |Σ Θᵢ n·Γᵢ|` over the edges, `Θᵢ` the
/// angle an edge subtends at `p` and `Γᵢ` the unit normal of the plane
/// through `p` and that edge (pbrt-v4 §4.5.1's polygonal emitter).
///
/// Contract: exact when the whole triangle lies on the side of `n`.
pub fn projected_solid_angle(p: DVec3, n: DVec3, t: &[DVec3; 3]) -> f64 {
    let a = t.map(|v| (v - p).normalize());
    let mut sum = 0.0;
    for i in 0..3 {
        let (x, y) = (a[i], a[(i + 1) % 3]);
        let theta = x.cross(y).length().atan2(x.dot(y));
        sum += theta * n.dot(x.cross(y).normalize_or_zero());
    }
    0.5 * sum.abs()
}

/// A direction from `p` uniformly distributed over the solid angle that
/// triangle `t` subtends, from two uniforms in [0,1), with that solid angle
/// (the direction's density is its inverse): Arvo's stratified sampling of
/// spherical triangles (Arvo 1995, "Stratified Sampling of Spherical
/// Triangles", §2; pbrt-v4 §6.5.4 `SampleSphericalTriangle`).
///
/// Why: next-event estimation that picks a point uniformly by area weighs
/// it by `cos θ_light / d²`, which has no bound near the emitter. A lamp
/// set a centimetre under a ceiling lights the ceiling beside it with
/// samples thousands of times the mean, and one such path in a probe's
/// bake decided a scene's diffuse figures (docs/method.md, "Fireflies").
/// Drawn by solid angle, a sample's weight is `cos θ · Ω`, at most `2π`.
///
/// Returns `None` when the triangle subtends less than `min_solid_angle`
/// (where area sampling is as good and the trigonometry loses precision),
/// nearly a hemisphere (above `2π − 1e-3`), or is degenerate seen from `p`.
///
/// Contract: the direction is unit and points into the triangle (up to
/// rounding); deterministic.
pub fn sample_spherical_triangle(
    p: DVec3,
    t: &[DVec3; 3],
    u: [f64; 2],
    min_solid_angle: f64,
) -> Option<(DVec3, f64)> {
    let [a, b, c] = corners_seen_from(p, t)?;
    let omega = solid_angle_of_units(a, b, c);
    if !(omega >= min_solid_angle && omega <= 2.0 * std::f64::consts::PI - 1e-3) {
        return None;
    }
    // The spherical angle at corner `a`, between the great circles to `b`
    // and to `c`.
    let (nab, nac) = (a.cross(b), a.cross(c));
    let alpha = nab.cross(nac).length().atan2(nab.dot(nac));
    let (sin_alpha, cos_alpha) = alpha.sin_cos();
    // Arvo §2: the sub-triangle of area u₀·Ω fixes the third corner ĉ on the
    // arc from a to c ...
    let (s, co) = (u[0] * omega - alpha).sin_cos();
    let uu = co - cos_alpha;
    let vv = s + sin_alpha * a.dot(b);
    let den = (vv * s + uu * co) * sin_alpha;
    if den == 0.0 || !den.is_finite() {
        return None;
    }
    let q = (((vv * co - uu * s) * cos_alpha - vv) / den).clamp(-1.0, 1.0);
    let c_hat = q * a + (1.0 - q * q).max(0.0).sqrt() * (c - c.dot(a) * a).normalize_or_zero();
    // ... and u₁ places the direction on the arc from b to ĉ, uniformly in
    // the cosine about b.
    let z = 1.0 - u[1] * (1.0 - c_hat.dot(b));
    let w = z * b + (1.0 - z * z).max(0.0).sqrt() * (c_hat - c_hat.dot(b) * b).normalize_or_zero();
    let w = w.normalize_or_zero();
    (w != DVec3::ZERO).then_some((w, omega))
}

/// A counter-based stream of uniform numbers: the `i`-th draw is a pure
/// function of `(seed, stream, i)`.
///
/// Why: the renderer runs pixels and probe texels in parallel, and results
/// must be bit-identical whatever the thread schedule. Giving every pixel (or
/// texel) its own stream, keyed by its index, and hashing a counter instead
/// of advancing shared state makes each sample independent of which thread
/// ran first. It holds no heap memory, so hot loops can create one per path.
#[derive(Debug, Clone)]
pub struct Sampler {
    key: u64,
    counter: u64,
}

impl Sampler {
    /// The stream `stream` of the sequence family `seed`. Different streams of
    /// one seed, and one stream of different seeds, are uncorrelated.
    pub fn new(seed: u64, stream: u64) -> Sampler {
        Sampler {
            key: hash2(seed, stream),
            counter: 0,
        }
    }

    /// The next uniform number in [0, 1) (24 bits of resolution).
    pub fn next_f32(&mut self) -> f32 {
        let v = unit_f32(hash2(self.key, self.counter));
        self.counter = self.counter.wrapping_add(1);
        v
    }

    /// The next two uniform numbers in [0, 1)², drawn in order `x` then `y`.
    pub fn next_2d(&mut self) -> glam::Vec2 {
        let x = self.next_f32();
        let y = self.next_f32();
        glam::Vec2::new(x, y)
    }
}

/// Indices of `points` in the Morton order of their positions (ties: the
/// earlier), so that neighbours in the order are neighbours in space.
pub(crate) fn morton_order(points: &[Vec3]) -> Vec<usize> {
    let (lo, hi) = points.iter().fold(
        (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
        |(lo, hi), &p| (lo.min(p), hi.max(p)),
    );
    let cells = ((1u32 << 10) - 1) as f32;
    let scale = cells / (hi - lo).max_element().max(f32::MIN_POSITIVE);
    let spread = |v: u32| {
        let mut x = v as u64 & 0x3ff;
        x = (x | x << 16) & 0x30000ff;
        x = (x | x << 8) & 0x300f00f;
        x = (x | x << 4) & 0x30c30c3;
        (x | x << 2) & 0x9249249
    };
    let mut keys: Vec<(u64, usize)> = points
        .iter()
        .enumerate()
        .map(|(k, &p)| {
            let c = ((p - lo) * scale).clamp(Vec3::ZERO, Vec3::splat(cells));
            let c = if c.is_finite() {
                c.as_uvec3()
            } else {
                glam::UVec3::ZERO
            };
            (spread(c.x) | spread(c.y) << 1 | spread(c.z) << 2, k)
        })
        .collect();
    keys.sort_unstable();
    keys.into_iter().map(|(_, k)| k).collect()
}

/// `items` cut to its `keep` least, in order: what sorting all of them
/// and keeping the first `keep` gives when no two items are equal (a
/// seeded hash paired with a distinct index, say), without sorting the
/// rest: the least are selected first, in linear time.
pub(crate) fn keep_least<T: Ord>(items: &mut Vec<T>, keep: usize) {
    if keep < items.len() {
        items.select_nth_unstable(keep);
        items.truncate(keep);
    }
    items.sort_unstable();
}

/// A point of the cube [-1, 1]³ from the hash `h`, for tests that need
/// reproducible random points.
#[cfg(test)]
pub(crate) fn cube_point(h: u64) -> glam::Vec3 {
    glam::Vec3::new(
        unit_f32(hash2(h, 1)),
        unit_f32(hash2(h, 2)),
        unit_f32(hash2(h, 3)),
    ) * 2.0
        - 1.0
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Where the ray from `p` along `w` meets the plane of `t`, in
    /// barycentric coordinates.
    fn barycentric_hit(p: DVec3, w: DVec3, t: &[DVec3; 3]) -> [f64; 3] {
        let n = (t[1] - t[0]).cross(t[2] - t[0]);
        let x = p + w * ((t[0] - p).dot(n) / w.dot(n));
        let area = |a: DVec3, b: DVec3, c: DVec3| (b - a).cross(c - a).dot(n) / n.length_squared();
        [
            area(x, t[1], t[2]),
            area(t[0], x, t[2]),
            area(t[0], t[1], x),
        ]
    }

    #[test]
    fn spherical_triangle_samples_are_uniform_over_its_solid_angle() {
        let tri = [
            DVec3::new(-0.3, 1.0, -0.2),
            DVec3::new(0.5, 1.0, -0.1),
            DVec3::new(0.1, 1.0, 0.6),
        ];
        // A point far below, one close under the emitter, one a millimetre
        // beside its edge and a centimetre above its plane (where the area
        // density's weight has no bound).
        for p in [
            DVec3::new(0.0, -3.0, 0.0),
            DVec3::new(0.1, 0.9, 0.1),
            DVec3::new(0.1, 1.01, -0.201),
        ] {
            let omega = solid_angle(p, &tri);
            let n = (tri[0] + tri[1] + tri[2]) / 3.0 - p;
            let n = n.normalize();
            let (mut cos_sum, mut count) = (0.0, 0usize);
            // The four midpoint sub-triangles' shares of the samples.
            let m = [
                0.5 * (tri[0] + tri[1]),
                0.5 * (tri[1] + tri[2]),
                0.5 * (tri[2] + tri[0]),
            ];
            let subs = [
                [tri[0], m[0], m[2]],
                [m[0], tri[1], m[1]],
                [m[2], m[1], tri[2]],
                m,
            ];
            let mut hits = [0usize; 4];
            let samples = 20_000u64;
            for i in 0..samples {
                let u = [
                    unit_f32(hash2(3, 2 * i)) as f64,
                    unit_f32(hash2(3, 2 * i + 1)) as f64,
                ];
                let (w, o) =
                    sample_spherical_triangle(p, &tri, u, 1e-6).expect("a proper triangle");
                assert!((o - omega).abs() < 1e-12 && (w.length() - 1.0).abs() < 1e-9);
                let b = barycentric_hit(p, w, &tri);
                assert!(b.iter().all(|&x| x > -1e-6), "{p:?}: {w:?} misses, {b:?}");
                cos_sum += n.dot(w).max(0.0);
                count += 1;
                let k = subs
                    .iter()
                    .position(|s| barycentric_hit(p, w, s).iter().all(|&x| x >= -1e-9))
                    .unwrap();
                hits[k] += 1;
            }
            let estimate = omega * cos_sum / count as f64;
            let exact = projected_solid_angle(p, n, &tri);
            assert!(
                (estimate - exact).abs() < 0.01 * exact,
                "{p:?}: {estimate} vs {exact}"
            );
            for (s, &h) in subs.iter().zip(&hits) {
                let share = h as f64 / samples as f64;
                let want = solid_angle(p, s) / omega;
                assert!((share - want).abs() < 0.015, "{p:?}: {share} vs {want}");
            }
        }
    }

    #[test]
    fn spherical_triangle_sampling_declines_the_tiny_and_the_degenerate() {
        let tri = [DVec3::ZERO, DVec3::X, DVec3::Z];
        // Seen edge-on from its own plane, from a corner, or subtending less
        // than asked.
        assert!(
            sample_spherical_triangle(DVec3::new(2.0, 0.0, 2.0), &tri, [0.5; 2], 1e-6).is_none()
        );
        assert!(sample_spherical_triangle(DVec3::ZERO, &tri, [0.5; 2], 1e-6).is_none());
        let far = DVec3::new(0.2, 1e3, 0.2);
        assert!(solid_angle(far, &tri) < 1e-6);
        assert!(sample_spherical_triangle(far, &tri, [0.5; 2], 1e-6).is_none());
        assert!(sample_spherical_triangle(far, &tri, [0.5; 2], 0.0).is_some());
    }

    #[test]
    fn keep_least_is_a_full_sort_cut_short() {
        for (n, keep) in [(1000, 10), (1000, 0), (50, 50), (50, 80), (0, 3)] {
            let items: Vec<(u64, usize)> = (0..n).map(|i| (hash2(5, i as u64) % 97, i)).collect();
            let mut sorted = items.clone();
            sorted.sort();
            sorted.truncate(keep);
            let mut kept = items;
            keep_least(&mut kept, keep);
            assert_eq!(kept, sorted, "{n} items, keep {keep}");
        }
    }

    #[test]
    fn sampler_streams_are_reproducible_and_distinct() {
        let draw = |seed, stream| {
            let mut s = Sampler::new(seed, stream);
            (0..64).map(|_| s.next_f32()).collect::<Vec<f32>>()
        };
        assert_eq!(draw(3, 7), draw(3, 7));
        assert_ne!(draw(3, 7), draw(3, 8));
        assert_ne!(draw(3, 7), draw(4, 7));
        let mut s = Sampler::new(3, 7);
        let v = s.next_2d();
        assert_eq!([v.x, v.y], [draw(3, 7)[0], draw(3, 7)[1]]);
    }

    #[test]
    fn sampler_is_uniform_in_the_unit_interval() {
        let mut s = Sampler::new(11, 0);
        let mut bins = [0u32; 10];
        let n = 100_000;
        for _ in 0..n {
            let u = s.next_f32();
            assert!((0.0..1.0).contains(&u));
            bins[(u * 10.0) as usize] += 1;
        }
        // Each bin expects 10 000 draws, standard deviation 95.
        for b in bins {
            assert!((b as i32 - 10_000).abs() < 500, "{bins:?}");
        }
        // Consecutive draws are uncorrelated.
        let mut s = Sampler::new(11, 1);
        let mut sum = 0.0f64;
        for _ in 0..n {
            let v = s.next_2d();
            sum += ((v.x - 0.5) * (v.y - 0.5)) as f64;
        }
        assert!((sum / n as f64).abs() < 2e-3, "{sum}");
    }

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
