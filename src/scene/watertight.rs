//! Watertight ray/triangle intersection: Sven Woop, Carsten Benthin and
//! Ingo Wald, "Watertight Ray/Triangle Intersection", Journal of Computer
//! Graphics Techniques (JCGT) 2(1), 2013,
//! <https://jcgt.org/published/0002/01/05/>.
//!
//! The test of [`super::raycast`]. Möller–Trumbore, which it replaces,
//! computes each triangle's barycentrics from that triangle's own edge
//! vectors, so two triangles sharing an edge round differently along it
//! and a ray through the edge (a quad's diagonal seam, say) can miss both.
//! The paper instead transforms the ray into a space where it runs along
//! +z from the origin, and decides inside/outside by 2D edge functions of
//! the transformed vertices:
//!
//! 1. **Per ray** ([`WatertightRay::new`]): `kz` is the axis of the
//!    largest |dir| component, `kx`, `ky` the next two cyclically, swapped
//!    when `dir[kz] < 0` to keep the triangles' winding; the shear
//!    constants are `Sx = dir[kx]/dir[kz]`, `Sy = dir[ky]/dir[kz]` (the
//!    paper's third, `Sz = 1/dir[kz]`, only scales its distance, which
//!    step 4 takes otherwise).
//! 2. **Per triangle** ([`WatertightRay::intersect`]): the vertices are
//!    translated by the origin and sheared (`x = A[kx] − Sx·A[kz]`,
//!    `y = A[ky] − Sy·A[kz]`), and the edge functions
//!    `U = Cx·By − Cy·Bx`, `V = Ax·Cy − Ay·Cx`, `W = Bx·Ay − By·Ax` taken.
//!    A transformed vertex depends on the vertex and the ray only, and the
//!    neighbouring triangle computes a shared edge's function from the
//!    same two products (negated when it runs the edge the other way), so
//!    the two triangles cannot both reject a ray passing between them.
//!    When any of U, V, W is exactly 0 all three are recomputed in double
//!    precision, where the product of two floats is exact, so that the
//!    sign is right on the edge itself too.
//! 3. The ray misses when U, V, W have differing signs (both orientations
//!    are accepted: callers need hits on both faces and tell them apart by
//!    the normal), and when `det = U + V + W` is 0 (the ray lies in the
//!    triangle's plane, or the triangle is degenerate).
//! 4. **Distance.** Here this module departs from the paper, which takes
//!    `t = T/det` with `T = U·Az + V·Bz + W·Cz` (`Az = Sz·A[kz]` etc.) and
//!    tests `T` against the ray's interval scaled by `det` before dividing.
//!    That `t` interpolates the vertices' distances along the ray with the
//!    weights U, V, W, which lose their relative precision on a long thin
//!    triangle seen at a grazing angle, and the vertices' distances are
//!    as large as the triangle is long: measured on Sponza, a 10.8 × 0.01
//!    sliver under the ray origin (true t ≈ −2·10⁻⁶) came out at
//!    t = 6.6·10⁻⁴, past the callers' `eps` of 2.5·10⁻⁴, so a surface
//!    point occluded itself (48 of 26.8 M sample-to-viewer segments of the
//!    coverage reference; the `raycast` tests check the case). The
//!    distance is therefore the plane's, `t = n·(A − O) / n·dir` with the
//!    stored normal `n` (as Möller–Trumbore has it, accurate where the
//!    origin is near the plane), tested against `[tmin, tmax]`. Only the
//!    distance changes: whether the ray passes through the triangle is
//!    still decided by the edge functions alone, so the test stays
//!    watertight.
//!
//! The shear and the edge functions are computed for the three vertices at
//! once: a triangle is stored by coordinate ([`WatertightTriangle`]), so
//! the per-ray axis permutation is a choice of row.

use glam::{DVec3, Vec3A, Vec3Swizzles};

/// A triangle stored by coordinate: `axes[k]` holds coordinate `k` of the
/// three vertices `(A, B, C)`, so that one vector operation transforms all
/// three vertices along a permuted axis; with its normal `(B − A)×(C − A)`,
/// for the distance. One cache line.
#[derive(Debug, Clone, Copy, PartialEq)]
#[repr(align(64))]
pub struct WatertightTriangle {
    axes: [Vec3A; 3],
    normal: Vec3A,
}

impl WatertightTriangle {
    /// The triangle with vertices `v[0], v[1], v[2]` (A, B, C).
    pub fn new(v: [Vec3A; 3]) -> WatertightTriangle {
        WatertightTriangle {
            axes: [
                Vec3A::new(v[0].x, v[1].x, v[2].x),
                Vec3A::new(v[0].y, v[1].y, v[2].y),
                Vec3A::new(v[0].z, v[1].z, v[2].z),
            ],
            normal: (v[1] - v[0]).cross(v[2] - v[0]),
        }
    }

    /// Vertex `i` (0, 1 or 2).
    pub fn vertex(&self, i: usize) -> Vec3A {
        Vec3A::new(self.axes[0][i], self.axes[1][i], self.axes[2][i])
    }
}

/// The per-ray constants of the test (step 1 of the module docs), built
/// once per query and shared by every triangle it meets.
#[derive(Debug, Clone, Copy)]
pub struct WatertightRay {
    /// `[kx, ky, kz]`.
    k: [usize; 3],
    /// The origin's `kx`, `ky`, `kz` coordinates, each in all lanes.
    ox: Vec3A,
    oy: Vec3A,
    oz: Vec3A,
    /// The shear constants `Sx`, `Sy`, each in all lanes.
    sx: Vec3A,
    sy: Vec3A,
    /// The direction, permuted: `(dir[kx], dir[ky], dir[kz])`.
    d: Vec3A,
}

impl WatertightRay {
    /// The ray `origin + t·dir`. `dir` must be finite and non-zero; it need
    /// not be unit length (`t` is then in units of `dir`).
    pub fn new(origin: Vec3A, dir: Vec3A) -> WatertightRay {
        // `[kx, ky]` by `kz` and by whether `dir[kz] < 0` (then swapped).
        const NEXT: [[[usize; 2]; 2]; 3] = [[[1, 2], [2, 1]], [[2, 0], [0, 2]], [[0, 1], [1, 0]]];
        let a = dir.abs();
        let kz = if a.z > a.x.max(a.y) {
            2
        } else if a.y > a.x {
            1
        } else {
            0
        };
        let d = dir.to_array();
        let [kx, ky] = NEXT[kz][(d[kz] < 0.0) as usize];
        let o = origin.to_array();
        // (Sx, Sy) = (dir[kx], dir[ky]) / dir[kz], in one division.
        let s = Vec3A::new(d[kx], d[ky], 0.0) / Vec3A::splat(d[kz]);
        WatertightRay {
            k: [kx, ky, kz],
            ox: Vec3A::splat(o[kx]),
            oy: Vec3A::splat(o[ky]),
            oz: Vec3A::splat(o[kz]),
            sx: Vec3A::splat(s.x),
            sy: Vec3A::splat(s.y),
            d: Vec3A::new(d[kx], d[ky], d[kz]),
        }
    }

    /// Distance `t` to the triangle, hit from either side, when it lies in
    /// `[tmin, tmax]`; `f32::INFINITY` otherwise (steps 2–4 of the module
    /// docs).
    #[inline(always)]
    pub fn intersect(&self, tri: &WatertightTriangle, tmin: f32, tmax: f32) -> f32 {
        in_range(self.distance(tri), tmin, tmax)
    }

    /// The plane distance of a triangle the ray passes through, NaN when
    /// it passes beside it (steps 2–4 of the module docs, before the range
    /// test): [`WatertightRay::intersect`] is [`in_range`] of it.
    #[inline(always)]
    fn distance(&self, tri: &WatertightTriangle) -> f32 {
        let [kx, ky, kz] = self.k;
        let axes = &tri.axes;
        // Vertices relative to the origin, `(Ax, Bx, Cx)` etc., then sheared.
        let px = axes[kx] - self.ox;
        let py = axes[ky] - self.oy;
        let pz = axes[kz] - self.oz;
        let x = px - self.sx * pz;
        let y = py - self.sy * pz;
        // (U, V, W) = (Cx·By − Cy·Bx, Ax·Cy − Ay·Cx, Bx·Ay − By·Ax).
        let mut uvw = x.zxy() * y.yzx() - y.zxy() * x.yzx();
        // The sign test comes before the fallback and again at its end,
        // the faster order a comment of the paper's listing points out:
        // most triangles are rejected here.
        let (neg, pos) = (
            uvw.cmplt(Vec3A::ZERO).bitmask(),
            uvw.cmpgt(Vec3A::ZERO).bitmask(),
        );
        if neg != 0 && pos != 0 {
            return f32::NAN;
        }
        if neg | pos != 0b111 {
            // Some of U, V, W is 0 (or NaN, which then misses below).
            let (xd, yd): (DVec3, DVec3) = (x.as_dvec3(), y.as_dvec3());
            uvw = (xd.zxy() * yd.yzx() - yd.zxy() * xd.yzx()).as_vec3a();
            if uvw.cmplt(Vec3A::ZERO).any() && uvw.cmpgt(Vec3A::ZERO).any() {
                return f32::NAN;
            }
        }
        let det = uvw.x + uvw.y + uvw.z;
        if det == 0.0 {
            return f32::NAN;
        }
        // The plane's distance (step 4), in the permuted axes: A − O is
        // lane 0 of (px, py, pz).
        let n = tri.normal.to_array();
        let n = Vec3A::new(n[kx], n[ky], n[kz]);
        n.dot(Vec3A::new(px.x, py.x, pz.x)) / n.dot(self.d)
    }

    /// [`WatertightRay::distance`] of the triangles of `block` in the lanes
    /// set in `lanes`, bit for bit, and the mask of those among them that
    /// the ray passes through (whose distance is not NaN); the other
    /// lanes' distances are unspecified.
    ///
    /// Four triangles at a time, one per SIMD lane, as the CPU ray tracers
    /// of Wald, Benthin & Boulos 2008 ("Getting Rid of Packets") and
    /// Embree test the triangles of a leaf. Each lane computes what
    /// [`WatertightRay::distance`] computes, the same IEEE operations in
    /// the same order (Rust contracts no multiply and add into an FMA), so
    /// its result is the same; a lane that the scalar test would send to
    /// its double-precision fallback (an edge function exactly 0, or NaN)
    /// is handed to the scalar test itself.
    #[inline(always)]
    pub fn distances4(&self, block: &TriangleBlock, lanes: u32) -> (u32, [f32; 4]) {
        #[cfg(target_arch = "x86_64")]
        let (mut hit, exact, mut t) = self.distances4_sse(block);
        #[cfg(not(target_arch = "x86_64"))]
        let (mut hit, exact, mut t) = (0, 0, [f32::NAN; 4]);
        // Lanes not decided in SIMD (rare: a ray through an edge or a
        // vertex, or a padding lane, which `lanes` leaves out; all of them
        // without SIMD).
        let mut rest = lanes & !exact;
        while rest != 0 {
            let i = rest.trailing_zeros() as usize;
            rest &= rest - 1;
            t[i] = self.distance(&block.triangle(i));
            hit |= ((!t[i].is_nan()) as u32) << i;
        }
        (hit & lanes, t)
    }

    /// The SIMD part of [`WatertightRay::distances4`]: the lanes it
    /// decided (every lane but those whose U, V or W is 0 or NaN and whose
    /// signs do not already reject it), those among them the ray passes
    /// through, and the distances.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn distances4_sse(&self, block: &TriangleBlock) -> (u32, u32, [f32; 4]) {
        use std::arch::x86_64::*;
        let [kx, ky, kz] = self.k;
        let mut t = [0.0f32; 4];
        // SAFETY: SSE is part of every x86-64 target's baseline; the loads
        // read 16-byte rows of `block.rows` (64-byte aligned, rows of 16
        // bytes) and the store writes the 16 bytes of `t` (unaligned).
        let (hit, exact) = unsafe {
            let row = |r: usize| _mm_load_ps(block.rows[r].as_ptr());
            let (ox, oy, oz): (__m128, __m128, __m128) =
                (self.ox.into(), self.oy.into(), self.oz.into());
            let (sx, sy): (__m128, __m128) = (self.sx.into(), self.sy.into());
            let d: __m128 = self.d.into();
            // Vertex `v` relative to the origin, `(px, py, pz)`, and
            // sheared, `(x, y)`, as in `distance`.
            let vertex = |v: usize| {
                let px = _mm_sub_ps(row(3 * v + kx), ox);
                let py = _mm_sub_ps(row(3 * v + ky), oy);
                let pz = _mm_sub_ps(row(3 * v + kz), oz);
                let x = _mm_sub_ps(px, _mm_mul_ps(sx, pz));
                let y = _mm_sub_ps(py, _mm_mul_ps(sy, pz));
                (px, py, pz, x, y)
            };
            let (apx, apy, apz, ax, ay) = vertex(0);
            let (_, _, _, bx, by) = vertex(1);
            let (_, _, _, cx, cy) = vertex(2);
            let u = _mm_sub_ps(_mm_mul_ps(cx, by), _mm_mul_ps(cy, bx));
            let v = _mm_sub_ps(_mm_mul_ps(ax, cy), _mm_mul_ps(ay, cx));
            let w = _mm_sub_ps(_mm_mul_ps(bx, ay), _mm_mul_ps(by, ax));
            let zero = _mm_setzero_ps();
            let (ul, vl, wl) = (
                _mm_cmplt_ps(u, zero),
                _mm_cmplt_ps(v, zero),
                _mm_cmplt_ps(w, zero),
            );
            let (ug, vg, wg) = (
                _mm_cmpgt_ps(u, zero),
                _mm_cmpgt_ps(v, zero),
                _mm_cmpgt_ps(w, zero),
            );
            let neg = _mm_or_ps(_mm_or_ps(ul, vl), wl);
            let pos = _mm_or_ps(_mm_or_ps(ug, vg), wg);
            // Rejected by the signs, as `distance` rejects before its fallback.
            let mixed = _mm_and_ps(neg, pos);
            // U, V and W all of one sign, none 0 or NaN.
            let signed = _mm_and_ps(
                _mm_and_ps(_mm_or_ps(ul, ug), _mm_or_ps(vl, vg)),
                _mm_or_ps(wl, wg),
            );
            let exact = _mm_or_ps(mixed, signed);
            // `det == 0.0` misses; NaN cannot arise from U, V, W of one sign.
            let det = _mm_add_ps(_mm_add_ps(u, v), w);
            let through = _mm_andnot_ps(mixed, _mm_and_ps(signed, _mm_cmpneq_ps(det, zero)));
            // The plane's distance: n·(A − O) / n·d in the permuted axes,
            // each dot product `(x·x' + y·y') + z·z'` as glam's `dot`.
            let (nx, ny, nz) = (row(9 + kx), row(9 + ky), row(9 + kz));
            let num = _mm_add_ps(
                _mm_add_ps(_mm_mul_ps(nx, apx), _mm_mul_ps(ny, apy)),
                _mm_mul_ps(nz, apz),
            );
            let (dx, dy, dz) = (
                _mm_shuffle_ps::<0b00_00_00_00>(d, d),
                _mm_shuffle_ps::<0b01_01_01_01>(d, d),
                _mm_shuffle_ps::<0b10_10_10_10>(d, d),
            );
            let den = _mm_add_ps(
                _mm_add_ps(_mm_mul_ps(nx, dx), _mm_mul_ps(ny, dy)),
                _mm_mul_ps(nz, dz),
            );
            let dist = _mm_div_ps(num, den);
            _mm_storeu_ps(t.as_mut_ptr(), dist);
            // A NaN distance misses, as in `distance`.
            let hit = _mm_and_ps(through, _mm_cmpord_ps(dist, dist));
            (_mm_movemask_ps(hit) as u32, _mm_movemask_ps(exact) as u32)
        };
        (hit, exact, t)
    }
}

/// `t` when it lies in `[tmin, tmax]`, `f32::INFINITY` otherwise (NaN
/// included): the range test of [`WatertightRay::intersect`], for the
/// distances of [`WatertightRay::distances4`].
#[inline(always)]
pub fn in_range(t: f32, tmin: f32, tmax: f32) -> f32 {
    // Written so that NaN misses.
    if !(t >= tmin && t <= tmax) {
        return f32::INFINITY;
    }
    t
}

/// Four triangles by coordinate, one per lane ("SoA"), for
/// [`WatertightRay::distances4`]: `rows[3·v + k]` holds coordinate `k` of
/// vertex `v` (A, B, C) of the four, `rows[9 + k]` coordinate `k` of their
/// [`WatertightTriangle`] normals. Three cache lines, against the four of
/// four [`WatertightTriangle`]s.
#[derive(Debug, Clone, Copy, PartialEq)]
#[repr(align(64))]
pub struct TriangleBlock {
    rows: [[f32; 4]; 12],
}

impl TriangleBlock {
    /// The block of `tris`, lane `i` holding `tris[i]`; lanes without one
    /// hold a triangle of zeros (callers leave them out of `lanes`).
    pub fn new(tris: &[WatertightTriangle]) -> TriangleBlock {
        assert!(tris.len() <= 4, "{} triangles in a block", tris.len());
        let mut block = TriangleBlock {
            rows: [[0.0; 4]; 12],
        };
        for (i, t) in tris.iter().enumerate() {
            block.set(i, t);
        }
        block
    }

    /// Puts `tri` in lane `i`, in place of the triangle there.
    #[inline]
    pub fn set(&mut self, i: usize, tri: &WatertightTriangle) {
        for k in 0..3 {
            for v in 0..3 {
                self.rows[3 * v + k][i] = tri.axes[k][v];
            }
            self.rows[9 + k][i] = tri.normal[k];
        }
    }

    /// The triangle of lane `i`, exactly as it was given.
    #[inline]
    pub fn triangle(&self, i: usize) -> WatertightTriangle {
        let r = |k: usize| self.rows[k][i];
        WatertightTriangle {
            axes: [0, 1, 2].map(|k| Vec3A::new(r(k), r(3 + k), r(6 + k))),
            normal: Vec3A::new(r(9), r(10), r(11)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::{cube_point, hash2, unit_f32};
    use obvhs::{ray::Ray, triangle::Triangle};

    fn rand3(h: u64) -> Vec3A {
        cube_point(h).into()
    }

    fn tri(v: [Vec3A; 3]) -> WatertightTriangle {
        WatertightTriangle::new(v)
    }

    #[test]
    fn stores_vertices_by_coordinate() {
        let v = [
            Vec3A::new(1.0, 2.0, 3.0),
            Vec3A::new(4.0, 5.0, 6.0),
            Vec3A::new(7.0, 8.0, 9.0),
        ];
        let t = tri(v);
        assert_eq!([t.vertex(0), t.vertex(1), t.vertex(2)], v);
    }

    #[test]
    fn hits_both_faces_along_every_axis_sign() {
        // A triangle in each axis plane, hit by exactly axis-aligned rays
        // from both sides, through its interior, an edge and a vertex.
        for axis in 0..3 {
            let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
            let mut p = [Vec3A::ZERO; 3];
            p[1][u] = 1.0;
            p[2][v] = 1.0;
            let t = tri(p);
            let targets = [
                Vec3A::ZERO,          // vertex
                p[1] * 0.5,           // edge on an axis
                (p[1] + p[2]) * 0.5,  // hypotenuse
                (p[1] + p[2]) * 0.25, // interior
            ];
            for target in targets {
                for s in [1.0f32, -1.0] {
                    let mut dir = Vec3A::ZERO;
                    dir[axis] = s;
                    let origin = target - dir * 2.0;
                    let r = WatertightRay::new(origin, dir);
                    let d = r.intersect(&t, 0.0, f32::INFINITY);
                    assert_eq!(d, 2.0, "axis {axis} sign {s} target {target}");
                }
            }
            // Just outside the hypotenuse: a miss.
            let mut dir = Vec3A::ZERO;
            dir[axis] = 1.0;
            let outside = (p[1] + p[2]) * 0.5001;
            let r = WatertightRay::new(outside - dir, dir);
            assert_eq!(r.intersect(&t, 0.0, f32::INFINITY), f32::INFINITY);
        }
    }

    #[test]
    fn parallel_and_degenerate_miss() {
        let t = tri([Vec3A::ZERO, Vec3A::X, Vec3A::Y]);
        // In the triangle's plane.
        let r = WatertightRay::new(Vec3A::new(-1.0, 0.25, 0.0), Vec3A::X);
        assert_eq!(r.intersect(&t, 0.0, f32::INFINITY), f32::INFINITY);
        // A triangle collapsed onto a segment the ray crosses.
        let flat = tri([Vec3A::ZERO, Vec3A::X, Vec3A::X * 2.0]);
        let r = WatertightRay::new(Vec3A::new(0.5, 0.0, -1.0), Vec3A::Z);
        assert_eq!(r.intersect(&flat, 0.0, f32::INFINITY), f32::INFINITY);
    }

    #[test]
    fn range_is_inclusive_and_behind_the_origin_misses() {
        let t = tri([
            Vec3A::new(-1.0, -1.0, 2.0),
            Vec3A::new(1.0, -1.0, 2.0),
            Vec3A::new(0.0, 1.0, 2.0),
        ]);
        let r = WatertightRay::new(Vec3A::ZERO, Vec3A::Z);
        assert_eq!(r.intersect(&t, 0.0, 2.0), 2.0);
        assert_eq!(r.intersect(&t, 2.0, 3.0), 2.0);
        assert_eq!(r.intersect(&t, 0.0, 1.999), f32::INFINITY);
        assert_eq!(r.intersect(&t, 2.001, 3.0), f32::INFINITY);
        let back = WatertightRay::new(Vec3A::ZERO, -Vec3A::Z);
        assert_eq!(back.intersect(&t, 0.0, f32::INFINITY), f32::INFINITY);
    }

    #[test]
    fn agrees_with_moller_trumbore_on_generic_rays() {
        // Random triangles and rays through random points of their plane,
        // away from the edges (barycentrics beyond ±0.02 of 0 and 1), so
        // that both tests decide the same way; distances within 1e-5.
        let (mut hits, mut misses) = (0, 0);
        for i in 0..20_000u64 {
            let h = hash2(77, i);
            let v = [rand3(hash2(h, 1)), rand3(hash2(h, 2)), rand3(hash2(h, 3))];
            let n = (v[1] - v[0]).cross(v[2] - v[0]);
            if n.length() < 1e-2 {
                continue;
            }
            let b1 = unit_f32(hash2(h, 4)) * 1.4 - 0.2;
            let b2 = unit_f32(hash2(h, 5)) * 1.4 - 0.2;
            let b0 = 1.0 - b1 - b2;
            if [b0, b1, b2]
                .iter()
                .any(|b| b.abs() < 0.02 || (b - 1.0).abs() < 0.02)
            {
                continue;
            }
            let target = v[0] * b0 + v[1] * b1 + v[2] * b2;
            let origin = target + rand3(hash2(h, 6)) * 3.0;
            let dir = (target - origin).normalize();
            if dir.dot(n.normalize()).abs() < 0.05 {
                continue;
            }
            let old = Triangle {
                v0: v[0],
                v1: v[1],
                v2: v[2],
            }
            .intersect(&Ray::new(origin, dir, 0.0, f32::INFINITY));
            let new = WatertightRay::new(origin, dir).intersect(&tri(v), 0.0, f32::INFINITY);
            let inside = b0 > 0.0 && b1 > 0.0 && b2 > 0.0;
            assert_eq!(new.is_finite(), inside, "ray {i}");
            assert_eq!(old.is_finite(), inside, "ray {i} (Möller–Trumbore)");
            if inside {
                assert!((new - old).abs() <= 1e-5 * old, "ray {i}: {new} vs {old}");
                hits += 1;
            } else {
                misses += 1;
            }
        }
        assert!(hits > 3000 && misses > 3000, "{hits} hits, {misses} misses");
    }

    #[test]
    fn four_at_a_time_is_one_at_a_time_bit_for_bit() {
        // Blocks of random triangles, some of them sharing vertices and
        // edges on a coarse grid (edge functions exactly 0), degenerate or
        // zero-area ones, against random rays, exactly axis-aligned rays,
        // and rays through a vertex or an edge's midpoint: every lane's
        // distance is the one-triangle test's, bit for bit, hit or miss.
        let grid = |h: u64| (rand3(h) * 4.0).round() * 0.25;
        let (mut hits, mut fallbacks) = (0, 0);
        for i in 0..20_000u64 {
            let h = hash2(91, i);
            let tris: Vec<WatertightTriangle> = (0..4)
                .map(|j| {
                    let h = hash2(h, 10 + j);
                    match h % 5 {
                        0 | 1 => tri([rand3(hash2(h, 1)), rand3(hash2(h, 2)), rand3(hash2(h, 3))]),
                        2 | 3 => tri([grid(hash2(h, 1)), grid(hash2(h, 2)), grid(hash2(h, 3))]),
                        _ => {
                            let a = grid(hash2(h, 1));
                            tri([a, a, grid(hash2(h, 2))])
                        }
                    }
                })
                .collect();
            let block = TriangleBlock::new(&tris);
            let o = if i % 2 == 0 {
                rand3(hash2(h, 4)) * 2.0
            } else {
                grid(hash2(h, 4)) * 2.0
            };
            let target = {
                let t = tris[(hash2(h, 5) % 4) as usize];
                match i % 4 {
                    0 => rand3(hash2(h, 6)),
                    1 => t.vertex((hash2(h, 6) % 3) as usize),
                    2 => (t.vertex(0) + t.vertex(1)) * 0.5,
                    _ => {
                        o + [
                            Vec3A::X,
                            Vec3A::Y,
                            Vec3A::Z,
                            -Vec3A::X,
                            -Vec3A::Y,
                            -Vec3A::Z,
                        ][(hash2(h, 6) % 6) as usize]
                    }
                }
            };
            let Some(dir) = (target - o).try_normalize() else {
                continue;
            };
            let r = WatertightRay::new(o, dir + Vec3A::ZERO);
            let lanes = (hash2(h, 7) % 16) as u32 | 1;
            let (hit, t) = r.distances4(&block, lanes);
            for (k, tk) in tris.iter().enumerate() {
                if lanes & 1 << k == 0 {
                    assert_eq!(hit & 1 << k, 0, "ray {i} lane {k}: not asked");
                    continue;
                }
                let want = r.distance(tk);
                assert_eq!(hit & 1 << k != 0, !want.is_nan(), "ray {i} lane {k}");
                if !want.is_nan() {
                    assert_eq!(t[k].to_bits(), want.to_bits(), "ray {i} lane {k}");
                    hits += 1;
                }
                assert_eq!(block.triangle(k), *tk);
            }
            #[cfg(target_arch = "x86_64")]
            {
                fallbacks += (lanes & !r.distances4_sse(&block).1).count_ones();
            }
        }
        assert!(hits > 5000, "{hits} hits");
        #[cfg(target_arch = "x86_64")]
        assert!(
            fallbacks > 1000,
            "{fallbacks} lanes left to the scalar test"
        );
    }

    #[test]
    fn ray_through_a_shared_edge_hits_both_triangles() {
        // Shared edge from (0,0,0) to (1,1,0) between two triangles: a ray
        // straight down through a point of that edge has an edge function
        // exactly 0 (the double-precision fallback runs) and hits both.
        let a = tri([
            Vec3A::ZERO,
            Vec3A::new(1.0, 0.0, 0.0),
            Vec3A::new(1.0, 1.0, 0.0),
        ]);
        let b = tri([
            Vec3A::ZERO,
            Vec3A::new(1.0, 1.0, 0.0),
            Vec3A::new(0.0, 1.0, 0.0),
        ]);
        for k in 1..100 {
            let s = k as f32 / 100.0;
            let r = WatertightRay::new(Vec3A::new(s, s, 1.0), -Vec3A::Z);
            assert_eq!(r.intersect(&a, 0.0, f32::INFINITY), 1.0, "{s}");
            assert_eq!(r.intersect(&b, 0.0, f32::INFINITY), 1.0, "{s}");
        }
    }
}
