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
//! [`blend_weights`] gives a renderer the probes and the normalized weights
//! of this blend at a point, the weights [`irradiance_at`] uses (both read
//! them from one function); the Python and C readers give the same bits
//! from the files a run writes (docs/formats.md, "Readers").
//!
//! This is the CPU twin of `gather_irradiance` in
//! `src/gpu/shaders/irradiance.wgsl`, whose `blend_term` is the twin of the
//! weights.

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

/// Calls `visit(probe, w)` for every term of the blend at point `p` with
/// unit normal `n`, in blend order, `w` the term's weight before
/// normalization: spatial × facing × visibility (McGuire §5.2), where
/// facing is max(n·ω, [`MIN_NORMAL_WEIGHT`]) for the unit direction ω from
/// `p` toward the probe ("a clamped dot product … a spatially-smooth
/// backface test") and visibility is [`chebyshev_visibility`] of the
/// probe's moments read (bilinearly) in direction −ω at the distance r to
/// the probe ("a Chebyshev visibility test of the local radiance distance
/// distribution"). At the probe itself (r = 0) the direction is undefined:
/// facing counts n·0 = 0, so the floor, and visibility 1.
///
/// The spatial weight and the order follow the selection (module docs):
/// the eight corners of [`super::Lattice::cell`]`(p)` in corner order (bit
/// 0 = +x, bit 1 = +y, bit 2 = +z), trilinear; or every probe in index
/// order, 1 / (|q − p|² + leaf²) with the SVO's leaf size.
///
/// The one place the weights are computed: [`irradiance_at`] and
/// [`blend_weights`] both read them here, so the two cannot drift; the
/// WGSL twin is `blend_term` in `src/gpu/shaders/irradiance.wgsl`.
#[inline]
fn for_each_term(
    field: &LightField,
    selection: &Selection,
    p: Vec3,
    n: Vec3,
    mut visit: impl FnMut(u32, f32),
) {
    let m = field.irradiance_resolution;
    let mut term = |probe: u32, spatial: f32| {
        let to_probe = field.positions[probe as usize] - p;
        let r = to_probe.length();
        let toward = if r > 0.0 { to_probe / r } else { Vec3::ZERO };
        let facing = n.dot(toward).max(MIN_NORMAL_WEIGHT);
        let visibility = if r > 0.0 {
            chebyshev_visibility(bilinear(&field.moments, m, probe as usize, -toward), r)
        } else {
            1.0
        };
        visit(probe, spatial * facing * visibility);
    };
    match selection {
        Selection::Grid(lattice) => {
            let cell = lattice.cell(p);
            let f = ((p - lattice.origin) / lattice.spacing - cell.as_vec3())
                .clamp(Vec3::ZERO, Vec3::ONE);
            for i in 0..8u32 {
                let o = IVec3::new((i & 1) as i32, ((i >> 1) & 1) as i32, ((i >> 2) & 1) as i32);
                let w = Vec3::select(o.cmpeq(IVec3::ONE), f, Vec3::ONE - f);
                term(lattice.corner(cell, i), w.x * w.y * w.z);
            }
        }
        Selection::Svo(svo) => {
            let soft = svo.leaf_size * svo.leaf_size;
            for (probe, q) in field.positions.iter().enumerate() {
                term(probe as u32, 1.0 / (q.distance_squared(p) + soft));
            }
        }
    }
}

/// Irradiance E at point `p` with unit normal `n`, interpolated from the
/// probes `selection` picks (module docs): Σ wᵢ Eᵢ(n) / Σ wᵢ over the
/// terms of [`blend_weights`], each Eᵢ a bilinear read of the probe's
/// irradiance map in direction `n`.
///
/// Contract: the result is finite and non-negative; zero only when every
/// probe's irradiance is zero, or when the weights sum to no positive
/// number (then [`blend_weights`] is empty). Deterministic; allocation-free.
pub fn irradiance_at(field: &LightField, selection: &Selection, p: Vec3, n: Vec3) -> Vec3 {
    let mut sum = Vec3::ZERO;
    let mut total = 0.0f32;
    let m = field.irradiance_resolution;
    for_each_term(field, selection, p, n, |probe, w| {
        let e = bilinear(&field.irradiance, m, probe as usize, n);
        sum += Vec3::from(e) * w;
        total += w;
    });
    if total > 0.0 {
        sum / total
    } else {
        Vec3::ZERO
    }
}

/// The probes the validation renders' diffuse blend reads at point `p`
/// with unit normal `n`, and their weights: what a renderer needs to blend
/// the probes' irradiance (or anything else stored per probe) exactly as
/// [`irradiance_at`] does. `out` is cleared, then holds `(probe, weight)`
/// per term, weight wᵢ / Σ wⱼ with wᵢ the geometry-aware weight of McGuire
/// et al. 2017 §5.2 (spatial × clamped normal × Chebyshev visibility; the
/// private `for_each_term` says each factor) "normalize\[d\] by the sum
/// of all \[the\] weights".
///
/// Contract:
/// - **Order**: the blend's. On a grid ([`Selection::Grid`]) the eight
///   corners of the cell holding `p` (clamped to the lattice), corner `i`
///   at offset (i & 1, i >> 1 & 1, i >> 2 & 1): always 8 terms, some of
///   them weight 0 (trilinear weights vanish on a cell face), and a probe
///   twice where the lattice has one layer along an axis. With the SVO
///   ([`Selection::Svo`]) every probe of `field`, in index order: the
///   selection's spatial weight is inverse square distance, softened by
///   the leaf size, over all probes (module docs say why not the SVO's
///   lists).
/// - **Values**: each weight is non-negative and at most 1, finite when
///   `p`, `n` and the field's positions and moments are, and the weights
///   sum to 1 up to rounding (one rounding per term). `Σ weight · Eᵢ(n)`
///   equals [`irradiance_at`] up to that rounding: `irradiance_at`
///   divides once, at the end.
/// - **Empty** when the weights sum to no positive number: never for a
///   finite `p` in a field of finite positions and moments, except by
///   underflow far outside the probes; `irradiance_at` is then zero.
/// - Deterministic, the same bits as the Python (`probeplace.blend_weights`)
///   and C (`pp_blend_weights`) readers on the files the run writes, and
///   no allocation once `out` has the capacity (8, or the probe count).
pub fn blend_weights(
    field: &LightField,
    selection: &Selection,
    p: Vec3,
    n: Vec3,
    out: &mut Vec<(u32, f32)>,
) {
    out.clear();
    let mut total = 0.0f32;
    for_each_term(field, selection, p, n, |probe, w| {
        out.push((probe, w));
        total += w;
    });
    if total > 0.0 {
        for (_, w) in out.iter_mut() {
            *w /= total;
        }
    } else {
        out.clear();
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

    /// An `svo.bin` image of an empty tree with leaf size `leaf`: the SVO
    /// selection of the blend reads nothing of the tree but that.
    fn svo_with_leaf(leaf: f32) -> crate::svo::Svo {
        use crate::svo::format;
        let mut b = format::MAGIC.to_vec();
        let words = [format::VERSION, 0, 0, 0, leaf.to_bits(), 0, 1, 1, 1];
        b.extend(words.into_iter().chain([1, 1, 0, 1, 0]).flat_map(u32::to_le_bytes));
        b.resize(format::HEADER_BYTES + 4, 0);
        let crc = format::crc32(&b);
        b.extend_from_slice(&crc.to_le_bytes());
        format::from_bytes(&b).unwrap()
    }

    /// A field over `grid_positions` whose probe k has irradiance k + 1 in
    /// every direction (so a blend reads which probes it weighs).
    fn graded_field() -> LightField {
        let mut field = uniform_field(grid_positions(), [1.0; 3], 50.0);
        let per = (field.irradiance_resolution * field.irradiance_resolution) as usize;
        for (i, e) in field.irradiance.iter_mut().enumerate() {
            *e = [(i / per + 1) as f32; 3];
        }
        field
    }

    fn points_and_normals() -> Vec<(Vec3, Vec3)> {
        let dirs = crate::sampling::fibonacci_sphere(40);
        (0..40u64)
            .map(|i| {
                let u = |k| crate::sampling::unit_f32(crate::sampling::hash2(7, 3 * i + k));
                let p = Vec3::new(u(0), u(1), u(2)) * 2.6 - 0.3;
                (p, dirs[i as usize])
            })
            .collect()
    }

    #[test]
    fn blend_weights_sum_to_one_and_blend_as_irradiance_at() {
        let field = graded_field();
        let lattice = Lattice::from_positions(&field.positions).unwrap();
        let svo = svo_with_leaf(0.25);
        let mut out = Vec::new();
        for selection in [Selection::Grid(&lattice), Selection::Svo(&svo)] {
            for (p, n) in points_and_normals() {
                blend_weights(&field, &selection, p, n, &mut out);
                let probes: Vec<u32> = out.iter().map(|t| t.0).collect();
                match selection {
                    Selection::Grid(l) => {
                        let cell = l.cell(p);
                        let corners: Vec<u32> = (0..8).map(|i| l.corner(cell, i)).collect();
                        assert_eq!(probes, corners, "{p}");
                    }
                    Selection::Svo(_) => assert_eq!(probes, (0..8).collect::<Vec<u32>>()),
                }
                let sum: f32 = out.iter().map(|t| t.1).sum();
                assert!((sum - 1.0).abs() <= 8.0 * f32::EPSILON, "{p}: {sum}");
                assert!(out.iter().all(|t| (0.0..=1.0).contains(&t.1)), "{out:?}");
                let blended: f32 = out.iter().map(|&(k, w)| w * (k + 1) as f32).sum();
                let e = irradiance_at(&field, &selection, p, n);
                assert!((blended - e.x).abs() <= 1e-5 * e.x, "{p}: {blended} vs {e}");
            }
        }
    }

    #[test]
    fn at_a_grid_probe_that_probe_takes_all_the_weight() {
        let field = graded_field();
        let lattice = Lattice::from_positions(&field.positions).unwrap();
        let mut out = Vec::new();
        for (k, &q) in field.positions.iter().enumerate() {
            blend_weights(&field, &Selection::Grid(&lattice), q, Vec3::Y, &mut out);
            for &(probe, w) in &out {
                let want = if probe == k as u32 { 1.0 } else { 0.0 };
                assert_eq!(w, want, "probe {k} at {q}: {out:?}");
            }
        }
    }

    #[test]
    fn svo_weights_are_softened_inverse_square_times_facing() {
        // Nothing occludes (every surface at 50): the weights are the
        // spatial and normal factors alone, recomputed here in f64.
        let field = graded_field();
        let leaf = 0.25f64;
        let svo = svo_with_leaf(leaf as f32);
        let mut out = Vec::new();
        let mut at_probe = field.positions.clone();
        at_probe.truncate(2);
        let points = points_and_normals().into_iter().chain(at_probe.iter().map(|&q| (q, Vec3::X)));
        for (p, n) in points {
            blend_weights(&field, &Selection::Svo(&svo), p, n, &mut out);
            let raw: Vec<f64> = field
                .positions
                .iter()
                .map(|q| {
                    let v = (*q - p).as_dvec3();
                    let toward = if v.length() > 0.0 { v / v.length() } else { v };
                    let facing = n.as_dvec3().dot(toward).max(MIN_NORMAL_WEIGHT as f64);
                    facing / (v.length_squared() + leaf * leaf)
                })
                .collect();
            let total: f64 = raw.iter().sum();
            for (&(_, w), r) in out.iter().zip(&raw) {
                assert!((w as f64 - r / total).abs() <= 1e-5 * (r / total) + 1e-7, "{p}");
            }
        }
    }

    #[test]
    fn a_probe_behind_a_wall_loses_its_blend_weight() {
        // Two probes either side of the point; the far one sees a surface
        // at 1.0 in every direction, so the point 3.0 from it is hidden.
        let open = uniform_field(vec![Vec3::ZERO, Vec3::new(0.0, 0.0, 4.0)], [1.0; 3], 10.0);
        let mut walled = open.clone();
        let half = walled.moments.len() / 2;
        for v in &mut walled.moments[half..] {
            *v = [1.0, 1.0];
        }
        let svo = svo_with_leaf(0.1);
        let lattice = Lattice::from_positions(&open.positions).unwrap();
        let p = Vec3::new(0.0, 0.0, 1.0);
        let mut out = Vec::new();
        for selection in [Selection::Grid(&lattice), Selection::Svo(&svo)] {
            let far = |field: &LightField, out: &mut Vec<(u32, f32)>| {
                blend_weights(field, &selection, p, Vec3::X, out);
                out.iter().filter(|t| t.0 == 1).map(|t| t.1).sum::<f32>()
            };
            let seen = far(&open, &mut out);
            let hidden = far(&walled, &mut out);
            assert!(seen > 0.05, "{seen}");
            assert!(hidden < 1e-5 * seen, "the hidden probe keeps {hidden} of {seen}");
        }
    }

    #[test]
    fn a_probe_behind_the_surface_keeps_the_floor_of_the_normal_weight() {
        // Two probes at the same distance either side of the point; the
        // normal faces one: their weights stand as 1 to MIN_NORMAL_WEIGHT.
        let field = uniform_field(vec![Vec3::new(-1.0, 0.0, 0.0), Vec3::X], [1.0; 3], 10.0);
        let svo = svo_with_leaf(0.1);
        let mut out = Vec::new();
        blend_weights(&field, &Selection::Svo(&svo), Vec3::ZERO, Vec3::X, &mut out);
        let ratio = out[0].1 / out[1].1;
        assert!((ratio - MIN_NORMAL_WEIGHT).abs() <= 1e-6, "{out:?}");
    }

    #[test]
    fn no_weights_where_the_blend_has_none() {
        let field = graded_field();
        let svo = svo_with_leaf(0.25);
        let mut out = vec![(9, 9.0)];
        for p in [Vec3::NAN, Vec3::new(0.0, f32::INFINITY, 0.0)] {
            blend_weights(&field, &Selection::Svo(&svo), p, Vec3::Y, &mut out);
            assert!(out.is_empty(), "{p}: {out:?}");
            assert_eq!(irradiance_at(&field, &Selection::Svo(&svo), p, Vec3::Y), Vec3::ZERO);
        }
    }
}
