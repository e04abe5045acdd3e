//! Conservative min/max pyramids of radial distance for hierarchical (Hi-Z)
//! tracing in probe maps (Wang et al. 2019 §4.2; McGuire et al. 2017 §4.1
//! uses a two-level min-MIP map).
//!
//! Wang et al. warn that mip-mapping the octahedral map directly distorts
//! it, and build cube-map mips that they resample per level. That concern is
//! about *averaging*: octahedral texels differ in solid angle, and a cone of
//! directions is not a square of texels. A min/max bound has no such
//! problem: the octahedral map is a bijection between the square and the
//! sphere, so the footprint on the sphere of a level-k texel is exactly the
//! union of its 2×2 children's footprints, seams included (the fold maps
//! the square's edges onto themselves, never across a texel). Taking the
//! min and max of the four children is therefore exact, not an
//! approximation, and needs no resampling.
//!
//! Level 0 bounds more than the texel's one stored distance. The tracer
//! treats each texel as a planar surfel (McGuire §4.1): the plane through
//! the stored point with the stored normal, seen through the texel's cone.
//! Level 0's bounds are the min and max radial distance of that plane at
//! the texel's centre, corners and edge midpoints (and at the plane's foot
//! when the foot's direction falls inside the texel), widened by 2⁻⁹ and
//! rounded outward to half precision. Every level thus bounds every value
//! the fine test compares against, so skipping a coarse texel whose min lies
//! beyond the ray never changes a trace's result.

use super::maps::{decode_normal, half_down, half_up};
use super::octahedral;
use glam::Vec3;
use rayon::prelude::*;

/// Relative widening of level 0's bounds, covering the plane's extremes that
/// fall between the nine sampled directions and rounding in the tracer.
const GUARD: f32 = 1.0 / 512.0;

/// Below this cosine between the plane normal and a direction, the plane is
/// treated as reaching infinity along it.
const GRAZING: f32 = 1e-4;

/// The pyramid of `levels` (min, max) maps for every probe: level k has side
/// `n >> k`, probes one after another, texels row by row.
///
/// Contract: `distance` and `normal` hold `probes × n²` entries as made by
/// [`super::maps::bake_geometry`]; `n` is a power of two; the result has
/// log2(n) + 1 levels, the last 1×1. Every level-k texel's min is ≤, and its
/// max ≥, every level-0 distance whose texel lies in its footprint.
pub fn build(n: u32, distance: &[f32], normal: &[[f32; 2]]) -> Vec<Vec<[f32; 2]>> {
    let texels = (n * n) as usize;
    let mut level0 = vec![[0.0f32; 2]; distance.len()];
    level0
        .par_chunks_mut(texels)
        .zip(distance.par_chunks(texels).zip(normal.par_chunks(texels)))
        .for_each(|(out, (dist, norm))| {
            for y in 0..n {
                for x in 0..n {
                    let i = (y * n + x) as usize;
                    out[i] = surfel_bounds(x, y, n, dist[i], decode_normal(norm[i]));
                }
            }
        });
    let mut levels = vec![level0];
    let mut side = n;
    while side > 1 {
        let fine = levels.last().expect("level 0 exists");
        let half = side / 2;
        let coarse: Vec<[f32; 2]> = fine
            .par_chunks((side * side) as usize)
            .flat_map_iter(|probe| {
                (0..half * half).map(move |c| {
                    let (cx, cy) = (c % half, c / half);
                    let mut b = [f32::INFINITY, f32::NEG_INFINITY];
                    for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                        let f = probe[((2 * cy + dy) * side + 2 * cx + dx) as usize];
                        b[0] = b[0].min(f[0]);
                        b[1] = b[1].max(f[1]);
                    }
                    b
                })
            })
            .collect();
        levels.push(coarse);
        side = half;
    }
    levels
}

/// Min and max radial distance of texel (`x`, `y`)'s surfel: the plane at
/// distance `s` along the texel's centre direction with normal `nrm`
/// (facing the probe). An empty texel (s = ∞) is (∞, ∞).
pub fn surfel_bounds(x: u32, y: u32, n: u32, s: f32, nrm: Vec3) -> [f32; 2] {
    if !s.is_finite() {
        return [f32::INFINITY, f32::INFINITY];
    }
    let centre = octahedral::texel_direction(x, y, n);
    // Plane: nrm · q = nrm · (s ω_c) = −h, with h > 0 when it faces the probe.
    let h = -nrm.dot(centre) * s;
    let (mut lo, mut hi) = (s, s);
    if h <= 0.0 {
        // A surfel seen edge-on: only its centre is known.
        return [half_down(s * (1.0 - GUARD)), f32::INFINITY];
    }
    let along = |d: Vec3| {
        let c = -nrm.dot(d);
        if c > GRAZING {
            h / c
        } else {
            f32::INFINITY
        }
    };
    for j in 0..=2u32 {
        for i in 0..=2u32 {
            let d = octahedral::decode(
                (glam::Vec2::new((2 * x + i) as f32, (2 * y + j) as f32) / (2 * n) as f32) * 2.0
                    - 1.0,
            );
            let r = along(d);
            lo = lo.min(r);
            hi = hi.max(r);
        }
    }
    if octahedral::texel_of(-nrm, n) == (x, y) {
        lo = lo.min(h);
    }
    [half_down(lo * (1.0 - GUARD)), half_up(hi * (1.0 + GUARD))]
}

/// Checks the pyramid's defining property independently of how it was
/// built: for `directions` directions spread over the sphere (spherical
/// Fibonacci), the level-k texel whose footprint holds the direction has
/// min ≤ and max ≥ the level-0 distance of the fine texel holding it, for
/// every probe and level. Returns the number of comparisons, or the first
/// violation.
pub fn verify(
    n: u32,
    distance: &[f32],
    levels: &[Vec<[f32; 2]>],
    directions: u32,
) -> Result<u64, String> {
    let texels = (n * n) as usize;
    let probes = distance.len() / texels;
    let dirs = crate::sampling::fibonacci_sphere(directions);
    let mut checked = 0;
    for p in 0..probes {
        for &d in &dirs {
            let (fx, fy) = octahedral::texel_of(d, n);
            let fine = distance[p * texels + (fy * n + fx) as usize];
            for (k, level) in levels.iter().enumerate() {
                let side = level_side(n, k);
                let (cx, cy) = octahedral::texel_of(d, side);
                let [lo, hi] = level[p * (side * side) as usize + (cy * side + cx) as usize];
                if !(lo <= fine && hi >= fine) {
                    return Err(format!(
                        "probe {p}, direction {d}, level {k}: bounds {lo}..{hi} miss the fine value {fine}"
                    ));
                }
                checked += 1;
            }
        }
    }
    Ok(checked)
}

/// Side of level `k` of an `n`×`n` pyramid.
pub fn level_side(n: u32, k: usize) -> u32 {
    n >> k
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lightfield::maps::bake_geometry;
    use crate::sampling::{hash2, unit_f32};
    use crate::scene::raycast::SceneBvh;
    use crate::scene::testing::room_with_box;

    #[test]
    fn pyramid_is_conservative_in_a_room() {
        let scene = room_with_box();
        let bvh = SceneBvh::new(&scene);
        let probes = [
            Vec3::new(0.5, 0.5, 0.5),
            Vec3::new(2.5, 1.5, 3.0),
            Vec3::new(1.5, 1.01, 1.5),
        ];
        let n = 32;
        let g = bake_geometry(&probes, &scene, &bvh, n);
        let levels = build(n, &g.distance, &g.normal);
        assert_eq!(levels.len(), 6);
        assert_eq!(levels[5].len(), probes.len());
        let checked = verify(n, &g.distance, &levels, 4 * n * n).unwrap();
        assert_eq!(checked, (probes.len() * 4 * 32 * 32 * 6) as u64);
    }

    #[test]
    fn surfel_bounds_contain_the_plane_across_the_texel() {
        // A plane seen at various angles: dense samples inside the texel's
        // square footprint stay within the bounds.
        let n = 16;
        for k in 0..200u64 {
            let x = (hash2(1, k) % n as u64) as u32;
            let y = (hash2(2, k) % n as u64) as u32;
            let c = octahedral::texel_direction(x, y, n);
            let tilt = Vec3::new(
                unit_f32(hash2(3, k)),
                unit_f32(hash2(4, k)),
                unit_f32(hash2(5, k)),
            ) - 0.5;
            let nrm = (-c + tilt * 1.2).normalize();
            if nrm.dot(c) >= -0.05 {
                continue;
            }
            let s = 1.0 + 3.0 * unit_f32(hash2(6, k));
            let [lo, hi] = surfel_bounds(x, y, n, s, nrm);
            let h = -nrm.dot(c) * s;
            for j in 0..=8 {
                for i in 0..=8 {
                    let e = (glam::Vec2::new(x as f32 + i as f32 / 8.0, y as f32 + j as f32 / 8.0))
                        / n as f32
                        * 2.0
                        - 1.0;
                    let d = octahedral::decode(e);
                    let cos = -nrm.dot(d);
                    let r = if cos > 0.0 { h / cos } else { f32::INFINITY };
                    assert!(
                        lo <= r && r <= hi,
                        "texel ({x},{y}) sample ({i},{j}): {r} not in {lo}..{hi}"
                    );
                }
            }
        }
    }

    #[test]
    fn empty_texels_stay_empty_up_the_pyramid() {
        let n = 4;
        let distance = vec![f32::INFINITY; 16];
        let normal = vec![[0.0; 2]; 16];
        let levels = build(n, &distance, &normal);
        assert!(levels
            .iter()
            .flatten()
            .all(|b| b[0].is_infinite() && b[1].is_infinite()));
    }
}
