//! Diffuse indirect light at a shading point from the irradiance probes
//! (McGuire et al. 2017 §5.2): the probes around the point, each weighted
//! by where the point lies among them, by "a clamped dot product of the
//! shading point's surface normal and the direction towards each probe
//! center (a spatially-smooth backface test)", and by "a Chebyshev
//! visibility test of the local radiance distance distribution" with
//! variance σ² = |E\[r\]² − E\[r²\]|, normalized by the sum of the weights.
//!
//! The spatial weight follows the selection: trilinear over the eight
//! probes of the grid cell (McGuire), or, for probes placed off a grid,
//! the inverse square distance to every probe, softened by the SVO's leaf
//! size so that a probe at the point does not take all the weight.
//!
//! Why not the SVO's ranked lists (Wang et al. 2019 §4.1) for diffuse
//! light, as for glossy rays? Their lists are constant over collapsed
//! nodes and change at node faces, so the weights jump there, and the
//! jumps showed as rectangles on flat walls (measured on CornellBox-Glossy;
//! interpolating the lists of the eight surrounding leaves only narrowed
//! the seams to a leaf's width). Weighting every probe is continuous, and
//! the Chebyshev test already removes the probes that cannot see the
//! point; it costs O(probes) per pixel, a few hundred texel reads at the
//! probe counts refinement produces. The maps are read with bilinear
//! filtering across the octahedral fold ([`octahedral::wrap_texel`]).
//!
//! This is the CPU twin of `gather_irradiance` in
//! `src/gpu/shaders/irradiance.wgsl`.

use super::Selection;
use crate::lightfield::irradiance::chebyshev_visibility;
use crate::lightfield::{octahedral, LightField};
use glam::{IVec3, Vec3};

/// Floor of the normal weight: a probe behind the surface still counts a
/// little, so that a point with every probe behind it is not left black.
pub const MIN_NORMAL_WEIGHT: f32 = 0.05;

/// Bilinear read of `probe`'s m×m map `map` in direction `d`, wrapping
/// across the octahedral fold.
///
/// Contract: `d` non-zero; `map` holds at least `probe + 1` maps of side `m`.
pub fn bilinear<const C: usize>(map: &[[f32; C]], m: u32, probe: usize, d: Vec3) -> [f32; C] {
    let e = octahedral::encode(d);
    let ux = (e.x + 1.0) * 0.5 * m as f32 - 0.5;
    let uy = (e.y + 1.0) * 0.5 * m as f32 - 0.5;
    let (x0, y0) = (ux.floor(), uy.floor());
    let (fx, fy) = (ux - x0, uy - y0);
    let mut out = [0.0f32; C];
    for (dx, dy, w) in [
        (0, 0, (1.0 - fx) * (1.0 - fy)),
        (1, 0, fx * (1.0 - fy)),
        (0, 1, (1.0 - fx) * fy),
        (1, 1, fx * fy),
    ] {
        let (x, y) = octahedral::wrap_texel(x0 as i64 + dx, y0 as i64 + dy, m);
        let texel = &map[probe * (m * m) as usize + (y * m + x) as usize];
        for c in 0..C {
            out[c] += w * texel[c];
        }
    }
    out
}

/// Irradiance E at point `p` with unit normal `n`, interpolated from the
/// probes `selection` picks (module docs).
///
/// Contract: the result is finite and non-negative; zero only when every
/// probe's irradiance is zero. Deterministic; allocation-free.
pub fn irradiance_at(field: &LightField, selection: &Selection, p: Vec3, n: Vec3) -> Vec3 {
    let mut sum = Vec3::ZERO;
    let mut total = 0.0f32;
    let mut add = |probe: u32, spatial: f32| {
        let to_probe = field.positions[probe as usize] - p;
        let r = to_probe.length();
        let toward = if r > 0.0 { to_probe / r } else { Vec3::ZERO };
        let facing = n.dot(toward).max(MIN_NORMAL_WEIGHT);
        let m = field.irradiance_resolution;
        let visibility = if r > 0.0 {
            chebyshev_visibility(bilinear(&field.moments, m, probe as usize, -toward), r)
        } else {
            1.0
        };
        let w = spatial * facing * visibility;
        let e = bilinear(&field.irradiance, m, probe as usize, n);
        sum += Vec3::from(e) * w;
        total += w;
    };
    match selection {
        Selection::Grid(lattice) => {
            let cell = lattice.cell(p);
            let f = ((p - lattice.origin) / lattice.spacing - cell.as_vec3())
                .clamp(Vec3::ZERO, Vec3::ONE);
            for i in 0..8u32 {
                let o = IVec3::new((i & 1) as i32, ((i >> 1) & 1) as i32, ((i >> 2) & 1) as i32);
                let w = Vec3::select(o.cmpeq(IVec3::ONE), f, Vec3::ONE - f);
                add(lattice.corner(cell, i), w.x * w.y * w.z);
            }
        }
        Selection::Svo(svo) => {
            let soft = svo.leaf_size * svo.leaf_size;
            for (probe, q) in field.positions.iter().enumerate() {
                add(probe as u32, 1.0 / (q.distance_squared(p) + soft));
            }
        }
    }
    if total > 0.0 {
        sum / total
    } else {
        Vec3::ZERO
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::trace::Lattice;

    /// A field of `positions` whose irradiance maps are `e` everywhere and
    /// whose moments put every surface at distance `wall`.
    fn uniform_field(positions: Vec<Vec3>, e: [f32; 3], wall: f32) -> LightField {
        let m = 8u32;
        let texels = (m * m) as usize * positions.len();
        LightField {
            resolution: 8,
            irradiance_resolution: m,
            max_distance: 10.0,
            radiance: vec![[0.0; 3]; 64 * positions.len()],
            normal: vec![[0.0; 2]; 64 * positions.len()],
            distance: vec![wall; 64 * positions.len()],
            pyramid: Vec::new(),
            irradiance: vec![e; texels],
            moments: vec![[wall, wall * wall]; texels],
            positions,
            frame: glam::DVec3::ZERO,
            provenance: [0; 32],
        }
    }

    fn grid_positions() -> Vec<Vec3> {
        let mut p = Vec::new();
        for z in 0..2 {
            for y in 0..2 {
                for x in 0..2 {
                    p.push(Vec3::new(x as f32, y as f32, z as f32) * 2.0);
                }
            }
        }
        p
    }

    #[test]
    fn bilinear_reads_a_constant_map_exactly_and_wraps_the_fold() {
        let field = uniform_field(grid_positions(), [0.25, 0.5, 2.0], 5.0);
        for d in crate::sampling::fibonacci_sphere(500) {
            let v = bilinear(&field.irradiance, 8, 3, d);
            for c in 0..3 {
                assert!((v[c] - field.irradiance[0][c]).abs() < 1e-6, "{d}: {v:?}");
            }
        }
    }

    #[test]
    fn uniform_irradiance_comes_back_unchanged() {
        let field = uniform_field(grid_positions(), [0.25, 0.5, 2.0], 5.0);
        let lattice = Lattice::from_positions(&field.positions).unwrap();
        let p = Vec3::new(0.7, 1.1, 1.6);
        let e = irradiance_at(&field, &Selection::Grid(&lattice), p, Vec3::Y);
        assert!(
            (e - Vec3::new(0.25, 0.5, 2.0)).abs().max_element() < 1e-5,
            "{e}"
        );
    }

    #[test]
    fn a_probe_behind_a_wall_loses_its_weight() {
        // Two probes on a line; the far one sees a surface at 1.0, so a
        // point 3.0 away from it is hidden (Chebyshev), and its irradiance
        // must not leak into the point.
        let mut field = uniform_field(vec![Vec3::ZERO, Vec3::new(0.0, 0.0, 4.0)], [1.0; 3], 1.0);
        let half = field.irradiance.len() / 2;
        for v in &mut field.irradiance[half..] {
            *v = [100.0; 3];
        }
        for v in &mut field.moments[..half] {
            *v = [10.0, 100.0];
        }
        let svo_free = Lattice::from_positions(&field.positions).unwrap();
        let e = irradiance_at(
            &field,
            &Selection::Grid(&svo_free),
            Vec3::new(0.0, 0.0, 1.0),
            Vec3::Z,
        );
        assert!(e.x < 5.0, "the hidden probe leaks: {e}");
        assert!(e.x >= 1.0 - 1e-4, "{e}");
    }
}
