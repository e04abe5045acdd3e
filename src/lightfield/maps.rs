//! The per-probe octahedral maps of McGuire et al. 2017 §3: for every texel
//! direction ω about the probe centre x′, the radial distance r to the
//! closest surface point x″, that surface's normal, and the radiance
//! L(x′, ω) arriving from it.
//!
//! The paper rasterizes cube maps and resamples them; we cast one ray
//! through each texel centre for the geometry (so the distance and normal
//! are those of the exact texel direction the tracer reconstructs) and
//! average `samples` path-traced radiance estimates over jittered
//! directions inside the texel for the radiance, which the texel's
//! footprint should integrate rather than point-sample.

use super::octahedral;
use crate::sampling::{hash2, unit_f32};
use crate::scene::raycast::SceneBvh;
use crate::scene::Scene;
use glam::{Vec2, Vec3};
use half::f16;
use rayon::prelude::*;

/// Rounds to the nearest value a half float can hold (the stored precision).
pub fn to_half(v: f32) -> f32 {
    f16::from_f32(v).to_f32()
}

/// The largest half-float value ≤ `v` (rounding a lower bound down keeps it a
/// lower bound). Infinities and NaN pass through.
pub fn half_down(v: f32) -> f32 {
    let h = f16::from_f32(v);
    if !v.is_finite() || h.to_f32() <= v {
        return h.to_f32();
    }
    step_half(h, -1)
}

/// The smallest half-float value ≥ `v`; beyond the largest finite half it is +∞.
pub fn half_up(v: f32) -> f32 {
    let h = f16::from_f32(v);
    if !v.is_finite() || h.to_f32() >= v {
        return h.to_f32();
    }
    step_half(h, 1)
}

/// The half-float neighbour of `h` one step toward +∞ (`dir` = 1) or −∞.
fn step_half(h: f16, dir: i32) -> f32 {
    let bits = h.to_bits();
    let positive = bits & 0x8000 == 0;
    let next = if (dir > 0) == positive {
        bits + 1
    } else if bits & 0x7fff == 0 {
        // ±0 stepping away from zero across the sign.
        0x8001 ^ if dir > 0 { 0x8000 } else { 0 }
    } else {
        bits - 1
    };
    f16::from_bits(next).to_f32()
}

/// Octahedral encoding of a unit normal at the stored (half) precision.
pub fn encode_normal(n: Vec3) -> [f32; 2] {
    let e = octahedral::encode(n);
    [to_half(e.x), to_half(e.y)]
}

/// The unit normal a stored encoding stands for.
pub fn decode_normal(e: [f32; 2]) -> Vec3 {
    octahedral::decode(Vec2::new(e[0], e[1]))
}

/// Distance and normal maps of all probes, probe after probe, texels row by row.
pub struct Geometry {
    /// Radial distance (half precision); +∞ where the texel's ray escapes.
    pub distance: Vec<f32>,
    /// Octahedrally encoded normal of the surface seen, turned to face the
    /// probe (McGuire §4.1 uses it to tell front from back); (0, 0) where
    /// nothing is seen.
    pub normal: Vec<[f32; 2]>,
}

/// Casts one ray through every texel centre of every probe's `n`×`n` map.
///
/// Contract: `distance` and `normal` hold `positions.len() × n²` entries;
/// the result is deterministic.
pub fn bake_geometry(positions: &[Vec3], scene: &Scene, bvh: &SceneBvh, n: u32) -> Geometry {
    let dirs = octahedral::texel_directions(n);
    let texels = dirs.len();
    let mut distance = vec![f32::INFINITY; positions.len() * texels];
    let mut normal = vec![[0.0f32; 2]; positions.len() * texels];
    distance
        .par_chunks_mut(n as usize)
        .zip(normal.par_chunks_mut(n as usize))
        .enumerate()
        .for_each(|(row, (dist, norm))| {
            let probe = positions[row / n as usize];
            let y = row % n as usize;
            for x in 0..n as usize {
                let d = dirs[y * n as usize + x];
                if let Some(hit) = bvh.closest_hit(probe, d, 0.0, f32::INFINITY) {
                    let mut nrm = scene.normals[hit.triangle as usize];
                    if nrm.dot(d) > 0.0 {
                        nrm = -nrm;
                    }
                    dist[x] = to_half(hit.t);
                    norm[x] = encode_normal(nrm);
                }
            }
        });
    Geometry { distance, normal }
}

/// A radiance estimator: `radiance(origin, direction, stream)` returns one
/// sample of the radiance arriving at `origin` from `direction`, drawing its
/// random numbers from the stream numbered `stream` (every call gets its own,
/// so results do not depend on thread scheduling).
pub type RadianceFn<'a> = dyn Fn(Vec3, Vec3, u64) -> Vec3 + Sync + 'a;

/// Averages `samples` radiance estimates per texel, over directions
/// jittered uniformly in the texel's square footprint, for every probe.
///
/// Contract: `positions.len() × n²` RGB entries at half precision; the same
/// inputs give the same output.
pub fn bake_radiance(
    positions: &[Vec3],
    n: u32,
    samples: u32,
    seed: u64,
    radiance: &RadianceFn,
    on_row: &(dyn Fn() + Sync),
) -> Vec<[f32; 3]> {
    let texels = (n * n) as usize;
    let mut out = vec![[0.0f32; 3]; positions.len() * texels];
    out.par_chunks_mut(n as usize)
        .enumerate()
        .for_each(|(row, rad)| {
            let probe = positions[row / n as usize];
            let y = (row % n as usize) as u32;
            for x in 0..n {
                let texel = (row / n as usize * texels) as u64 + (y * n + x) as u64;
                let mut sum = Vec3::ZERO;
                for i in 0..samples as u64 {
                    let stream = texel * samples as u64 + i;
                    let h = hash2(seed, stream);
                    let j = Vec2::new(unit_f32(h), unit_f32(hash2(h, 1)));
                    let e = (Vec2::new(x as f32, y as f32) + j) / n as f32 * 2.0 - 1.0;
                    sum += radiance(probe, octahedral::decode(e), stream);
                }
                let mean = sum / samples as f32;
                rad[x as usize] = [to_half(mean.x), to_half(mean.y), to_half(mean.z)];
            }
            on_row();
        });
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::testing::room_with_box;

    #[test]
    fn half_rounding_is_directed() {
        for &v in &[0.1f32, 1.0, 3.25, 1000.7, 60001.5, 1e-6, -2.3, 0.0] {
            let (d, u) = (half_down(v), half_up(v));
            assert!(d <= v && v <= u, "{v}: {d} {u}");
            assert_eq!(f16::from_f32(d).to_f32(), d);
            assert_eq!(f16::from_f32(u).to_f32(), u);
            assert!(u - d <= (v.abs() * 2e-3).max(1e-7), "{v}: {d} {u}");
        }
        assert_eq!(half_up(65519.0), f32::INFINITY);
        assert_eq!(half_down(65519.0), 65504.0);
        assert_eq!(half_down(f32::INFINITY), f32::INFINITY);
    }

    #[test]
    fn geometry_matches_ray_casts_and_faces_the_probe() {
        let scene = room_with_box();
        let bvh = SceneBvh::new(&scene);
        let probes = [Vec3::new(1.0, 1.2, 1.0), Vec3::new(3.0, 2.0, 2.5)];
        let n = 16;
        let g = bake_geometry(&probes, &scene, &bvh, n);
        let dirs = octahedral::texel_directions(n);
        for (p, probe) in probes.iter().enumerate() {
            for (t, d) in dirs.iter().enumerate() {
                let hit = bvh.closest_hit(*probe, *d, 0.0, f32::INFINITY).unwrap();
                let i = p * dirs.len() + t;
                assert!((g.distance[i] - hit.t).abs() <= hit.t * 1e-3);
                let nrm = decode_normal(g.normal[i]);
                assert!(nrm.dot(*d) < 0.0, "normal must face the probe");
                assert!(nrm.dot(scene.normals[hit.triangle as usize]).abs() > 0.999);
            }
        }
    }

    #[test]
    fn radiance_averages_the_texel_footprint() {
        // Radiance equal to the direction's z: each texel's mean lies
        // between the z of its corners.
        let n = 8;
        let r = bake_radiance(
            &[Vec3::ZERO],
            n,
            64,
            5,
            &|_, d, _| Vec3::splat(d.z + 2.0),
            &|| {},
        );
        for y in 0..n {
            for x in 0..n {
                let zs: Vec<f32> = (0..2)
                    .flat_map(|i| {
                        (0..2).map(move |j| octahedral::corner_direction(x + i, y + j, n).z)
                    })
                    .chain([octahedral::texel_direction(x, y, n).z])
                    .collect();
                let (lo, hi) = zs
                    .iter()
                    .fold((f32::MAX, f32::MIN), |(a, b), &z| (a.min(z), b.max(z)));
                let v = r[(y * n + x) as usize][0] - 2.0;
                assert!(
                    v >= lo - 0.01 && v <= hi + 0.01,
                    "({x},{y}) {v} not in {lo}..{hi}"
                );
            }
        }
        let again = bake_radiance(
            &[Vec3::ZERO],
            n,
            64,
            5,
            &|_, d, _| Vec3::splat(d.z + 2.0),
            &|| {},
        );
        assert_eq!(r, again);
    }
}
