//! Ray casting against the scene, shared by every CPU stage (SDF
//! classification, skeleton clustering, coverage, previews).
//!
//! Built on a 4-wide BVH of our own ([`super::wide_bvh`], which says why
//! not obvhs's compressed wide BVH), built with obvhs's PLOC builder. Each
//! triangle's box is padded by a tiny epsilon: the exactly flat,
//! axis-aligned walls of architectural scenes otherwise give
//! zero-thickness boxes, and traversal was measured about 10× slower on
//! them (0.5–0.9 vs 4.6 Mrays/s in a box room, with obvhs's CWBVH).
//!
//! The ray/triangle test is watertight (Woop, Benthin & Wald 2013, see
//! [`super::watertight`]): a ray through an edge or vertex that triangles
//! share hits at least one of them, exactly axis-aligned rays included, so
//! a segment cannot slip through a quad's diagonal seam or between the
//! faces of a closed mesh. A leaf's triangles are tested four at a time
//! ([`WatertightRay::distances4`], bit for bit the one-triangle test). The
//! padded boxes keep traversal conservative
//! around such rays, and −0 components of a direction are made +0 before
//! traversal, whose slab test would otherwise miss every box for them
//! (`positive_zeros`).
//!
//! Answers do not depend on the tree or on the order it is traversed in:
//! among hits at the same distance the lowest scene triangle index wins,
//! and the box tests are inclusive, so every such hit is seen.
//!
//! Cut-outs ([`super::Cutout`]: glTF's alpha MASK, an MTL's `map_d`): a
//! hit on a cut-out triangle counts only where its alpha at the hit point
//! stops rays, so every stage (coverage, placement, the bake, the
//! references, validation) sees through the holes of a fence or a leaf
//! alike. Scenes without one pay one branch per hit.

use super::watertight::{in_range, TriangleBlock, WatertightRay, WatertightTriangle};
use super::wide_bvh::{prefetch, BoxRay, WideBvh, LEAF_ALIGN, PAD};
use super::Scene;
use glam::{Vec3, Vec3A};
use obvhs::{aabb::Aabb, ray::Ray, triangle::Triangle, Boundable, BvhBuildParams};
use rayon::prelude::*;
use std::ops::Range;

/// A triangle whose bounding box is padded so that no box is flat.
struct PaddedTriangle {
    tri: Triangle,
    pad: f32,
}

impl Boundable for PaddedTriangle {
    fn aabb(&self) -> Aabb {
        let b = self.tri.aabb();
        Aabb::new(
            b.min - Vec3A::splat(self.pad),
            b.max + Vec3A::splat(self.pad),
        )
    }
}

/// `d` with any −0 component made +0 (`−0 + 0 = +0`; every other value is
/// unchanged). The box test takes a component's sign from `d < 0` when it
/// orders a box's slabs, but `1/−0 = −∞`: a ray such as `-Vec3::Y`,
/// `(−0, −1, −0)`, would miss every box.
fn positive_zeros(d: Vec3A) -> Vec3A {
    d + Vec3A::ZERO
}

/// What a ray hit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hit {
    /// Distance along the (unit) ray direction.
    pub t: f32,
    /// Index of the triangle in [`Scene::triangles`].
    pub triangle: u32,
    /// Whether the ray struck the triangle's back (its normal faces along the ray).
    pub backface: bool,
}

/// A slot's scene triangle index ([`PAD`] for a slot of no leaf) and its
/// normal ([`Scene::normals`]): together, so that the hit a ray returns
/// costs one cache miss, not two.
#[derive(Debug, Clone, Copy)]
#[repr(C, align(16))]
struct Slot {
    normal: [f32; 3],
    triangle: u32,
}

impl Slot {
    #[inline(always)]
    fn normal(&self) -> Vec3A {
        Vec3A::from_array(self.normal)
    }
}

/// A BVH over a scene's triangles.
pub struct SceneBvh {
    bvh: WideBvh,
    /// Triangles in BVH leaf order, so traversal reads them contiguously: a
    /// leaf is a range of slots (of `bvh.order`), slot `i` is lane `i % 4`
    /// of block `i / 4` (leaves start at multiples of four, [`LEAF_ALIGN`])
    /// and holds scene triangle `scene_index[i]`.
    blocks: Vec<TriangleBlock>,
    /// What a hit needs beyond its distance, per slot.
    slots: Vec<Slot>,
    /// Whether each slot's triangle is one face of a two-sided sheet:
    /// the scene holds the same triangle again, reversed ([`sheet_faces`]).
    sheet: Vec<bool>,
    /// Per slot, its index in `cut.triangles` ([`NOT_CUT`]: an opaque
    /// triangle); empty when the scene has no cut-out.
    cut_of: Vec<u32>,
    /// The cut-out triangles and what their test reads.
    cut: Cutouts,
}

/// A slot's [`SceneBvh::cut_of`] for an opaque triangle.
const NOT_CUT: u32 = u32::MAX;

/// What the alpha test of cut-out triangles reads ([`SceneBvh`]).
#[derive(Default)]
struct Cutouts {
    /// Each cut-out triangle's vertices, texture coordinates and cut-out.
    triangles: Vec<([Vec3; 3], [glam::Vec2; 3], super::Cutout)>,
    /// The scene's textures.
    textures: Vec<std::sync::Arc<super::texture::Texture>>,
}

impl Cutouts {
    /// Whether cut-out triangle `k` stops a ray at point `p` on it.
    #[inline]
    fn opaque(&self, k: u32, p: Vec3A) -> bool {
        let (tri, uv, cut) = &self.triangles[k as usize];
        if cut.everywhere() {
            return false;
        }
        let b = super::texture::barycentric(tri, p.into());
        cut.opaque_at(&self.textures, super::texture::interpolate(uv, b))
    }
}

/// Triangles above which the BVH is built with obvhs's fast preset rather
/// than the medium one.
///
/// The medium preset's extra PLOC search and reinsertion buy faster rays,
/// which pays on the scenes of configs/ (tens of thousands of triangles,
/// millions of rays); at millions of triangles its build alone took 10.8 s
/// of a 5.4M-triangle block's run and the fast one 8.0 s, for no slower a
/// run overall (BENCHMARKS.md, "Scale"). Rays return the same answers
/// either way: the nearest hit, ties going to the lowest triangle index
/// ([`SceneBvh::closest_hit`]).
pub const FAST_BUILD_TRIANGLES: usize = 1_000_000;

fn build_params(triangles: usize) -> BvhBuildParams {
    if triangles > FAST_BUILD_TRIANGLES {
        BvhBuildParams::fast_build()
    } else {
        BvhBuildParams::medium_build()
    }
}

impl SceneBvh {
    /// Primitives a ray tests on average ([`WideBvh::expected_tests`]).
    pub fn expected_tests(&self) -> f64 {
        self.bvh.expected_tests()
    }

    /// Builds the BVH. Deterministic: the same scene gives the same tree,
    /// whatever the thread count (a unit test of [`WideBvh`] checks it).
    /// obvhs builds a binary tree, in parallel (its `parallel` feature:
    /// the 5.4M-triangle city's build took 6.5 s rather than 8.1 s);
    /// [`WideBvh`] collapses it.
    pub fn new(scene: &Scene) -> SceneBvh {
        let diag = scene.bounds.size().length().max(1e-3);
        let pad = 5e-5 * diag;
        // The copies before and after the build (which obvhs runs on one
        // thread) are made in parallel: millions of triangles in a large
        // scene, in the same order either way.
        let prims: Vec<PaddedTriangle> = scene
            .triangles
            .par_iter()
            .map(|t| PaddedTriangle {
                tri: Triangle {
                    v0: t[0].into(),
                    v1: t[1].into(),
                    v2: t[2].into(),
                },
                pad,
            })
            .collect();
        let bvh = WideBvh::build(&prims, build_params(scene.triangles.len()));
        let scene_index: Vec<u32> = bvh.order.clone();
        let blocks = scene_index
            .par_chunks(LEAF_ALIGN)
            .map(|slots| {
                let tris: Vec<WatertightTriangle> = slots
                    .iter()
                    .take_while(|&&i| i != PAD)
                    .map(|&i| {
                        let t = prims[i as usize].tri;
                        WatertightTriangle::new([t.v0, t.v1, t.v2])
                    })
                    .collect();
                TriangleBlock::new(&tris)
            })
            .collect();
        let slots = scene_index
            .par_iter()
            .map(|&triangle| Slot {
                normal: match triangle {
                    PAD => [0.0; 3],
                    i => scene.normals[i as usize].to_array(),
                },
                triangle,
            })
            .collect();
        let sheet_of_scene = sheet_faces(&scene.triangles);
        let sheet = scene_index
            .iter()
            .map(|&i| i != PAD && sheet_of_scene[i as usize])
            .collect();
        let (cut_of, cut) = cutouts(scene, &scene_index);
        SceneBvh {
            bvh,
            blocks,
            slots,
            sheet,
            cut_of,
            cut,
        }
    }

    /// Whether the triangle of `slot` stops a ray at point `p` on it: an
    /// opaque triangle everywhere, a cut-out where its alpha is at its
    /// cutoff.
    #[inline(always)]
    fn stops(&self, slot: usize, p: Vec3A) -> bool {
        match self.cut_of.get(slot) {
            None | Some(&NOT_CUT) => true,
            Some(&k) => self.cut.opaque(k, p),
        }
    }

    /// Closest hit along `origin + t·dir` for `t` in `[tmin, tmax)`; `dir`
    /// must be unit length. Of hits at exactly the same distance, the one
    /// of the lowest triangle index ([`Hit::triangle`]), whatever the tree.
    pub fn closest_hit(&self, origin: Vec3, dir: Vec3, tmin: f32, tmax: f32) -> Option<Hit> {
        self.closest_hit_prefer_back(origin, dir, tmin, tmax, 0.0)
    }

    /// Closest hit, where a back face within `tie` beyond a front face wins,
    /// unless it is one face of a two-sided sheet: then its front twin wins.
    ///
    /// Solids often rest against other surfaces with coplanar faces (a box's
    /// bottom on a floor, a platform's side on a wall); seen from inside the
    /// solid, the wall's front face and the solid's back face are at the same
    /// distance and which one a plain closest hit returns is arbitrary. What
    /// lies behind such a pair is solid, so the back face is preferred.
    ///
    /// A zero-thickness partition written as the same triangle twice, once
    /// each way (a two-sided sheet), gives the same pair from either side,
    /// but nothing lies behind it but the next room: seen from the room,
    /// its face towards the room is the one hit. Preferring the back face
    /// there made whole rooms walled by sheets read as solid (42% of a
    /// generated thin-walled building's voxels).
    ///
    /// Precisely: each hit's distance `t` in `[tmin, tmax]` is shifted by
    /// `+tie` for a sheet's back face, `−tie` for another back face, 0 for
    /// a front face; the least shifted distance below `tmax` wins, equal
    /// ones going to the lowest triangle index; the hit reports its
    /// unshifted distance.
    #[inline]
    pub fn closest_hit_prefer_back(
        &self,
        origin: Vec3,
        dir: Vec3,
        tmin: f32,
        tmax: f32,
        tie: f32,
    ) -> Option<Hit> {
        self.closest(origin.into(), dir.into(), tmin, tmax, tie)
    }

    /// [`SceneBvh::closest_hit_prefer_back`] on whole SIMD vectors. The
    /// public entry points are trivial inline wrappers so that callers'
    /// loops stay as they were: handing the 12-byte `Vec3`s through memory
    /// to the large out-of-line traversal made coverage's loop over viewers
    /// stall on store forwarding (2.5× its time on Sponza).
    fn closest(&self, origin: Vec3A, dir: Vec3A, tmin: f32, tmax: f32, tie: f32) -> Option<Hit> {
        let d = positive_zeros(dir);
        let ray = Ray::new(origin, d, tmin, tmax);
        let wray = WatertightRay::new(origin, d);
        let shift = |slot: usize| -> f32 {
            if tie == 0.0 || self.slots[slot].normal().dot(d) <= 0.0 {
                0.0
            } else if self.sheet[slot] {
                tie
            } else {
                -tie
            }
        };
        // The best shifted distance so far and its slot (none yet: `tmax`).
        let (mut best_t, mut best) = (tmax, usize::MAX);
        // The unshifted distances that can still win: a hit shifted by
        // −|tie| wins from up to |tie| beyond the best, which the bound
        // covers with a margin for the rounding of the shift.
        let reach = tie.abs();
        let bound = |best_t: f32| -> f32 {
            if reach == 0.0 {
                best_t
            } else {
                (best_t + reach + (best_t.abs() + reach) * 1e-6).min(tmax)
            }
        };
        let touch = |slots: Range<usize>| self.prefetch(slots);
        self.bvh.closest(&BoxRay::new(&ray), tmax, touch, |slots| {
            for (block, lanes) in blocks_of(slots) {
                let (mut hit, dist) = wray.distances4(&self.blocks[block], lanes);
                while hit != 0 {
                    let i = hit.trailing_zeros() as usize;
                    hit &= hit - 1;
                    let slot = LEAF_ALIGN * block + i;
                    // What `wray.intersect(triangle, tmin, bound(best_t))`
                    // returns, the bound as it is after the lanes before.
                    let t = in_range(dist[i], tmin, bound(best_t));
                    if !t.is_finite() || !self.stops(slot, origin + d * t) {
                        continue;
                    }
                    let ts = t + shift(slot);
                    if ts < best_t
                        || (ts == best_t
                            && best != usize::MAX
                            && self.slots[slot].triangle < self.slots[best].triangle)
                    {
                        (best_t, best) = (ts, slot);
                        // Read when the ray's traversal ends, if it is
                        // still the best then.
                        prefetch(&self.slots[slot]);
                    }
                }
            }
            bound(best_t)
        });
        if best == usize::MAX {
            return None;
        }
        Some(Hit {
            t: best_t - shift(best),
            triangle: self.slots[best].triangle,
            backface: self.slots[best].normal().dot(d) > 0.0,
        })
    }

    /// Starts loading the first block of a leaf's triangles, for the
    /// traversal's `touch` ([`WideBvh::closest`]): the load of a leaf's
    /// triangles was measured as half the time of its test on Sponza,
    /// missing the cache.
    #[inline(always)]
    fn prefetch(&self, slots: Range<usize>) {
        prefetch(&self.blocks[slots.start / LEAF_ALIGN]);
    }

    /// Whether anything blocks the open segment from `a` to `b`. The ends are
    /// shrunk by `eps` so that a point lying on a surface does not occlude itself.
    #[inline]
    pub fn occluded(&self, a: Vec3, b: Vec3, eps: f32) -> bool {
        self.segment_blocked(a.into(), b.into(), eps, &mut Blocker::default())
    }

    /// [`SceneBvh::occluded`] for one of many neighbouring segments (from
    /// one point to many, or from a cluster of points to one), trying first
    /// the triangles that `blocker` remembers from the last of them that
    /// were blocked (and remembering this one's, when a traversal finds it).
    ///
    /// The answer is [`SceneBvh::occluded`]'s for any segment: a triangle
    /// that crosses the segment blocks it whichever way it is found, and
    /// the traversal visits every triangle whose padded box the segment
    /// enters. Only the traversal is saved, and often: a surface point that
    /// no viewer sees is usually hidden by one triangle right in front of
    /// it (the face of a solid it is pressed against, a floor over it),
    /// which then blocks the segments to thousands of viewers in turn.
    #[inline]
    pub fn occluded_from(&self, a: Vec3, b: Vec3, eps: f32, blocker: &mut Blocker) -> bool {
        self.segment_blocked(a.into(), b.into(), eps, blocker)
    }

    /// [`SceneBvh::occluded_from`] on whole SIMD vectors (see
    /// [`SceneBvh::closest`]).
    fn segment_blocked(&self, a: Vec3A, b: Vec3A, eps: f32, blocker: &mut Blocker) -> bool {
        self.segment_blocked_by::<false>(a, b, eps, blocker, None)
    }

    /// [`SceneBvh::occluded_from`] with two memories: `near_a`, shared with
    /// other segments from `a` (or from points near it), and `near_b`,
    /// shared with other segments to `b`. Both are tried before the
    /// traversal; a blocker the traversal finds goes into both. The answer
    /// is [`SceneBvh::occluded`]'s, with `NEAR_FIRST` or without.
    ///
    /// Why two: in a matrix of samples against viewers (refinement's
    /// columns), a sample is hidden from one viewer by the wall it stands
    /// by, and from the next by the walls around that viewer, which then
    /// hide it from the next samples too. On Dabrovic Sponza the viewers'
    /// memories cut the columns' traversals of blocked segments from 2.65M
    /// to 1.69M.
    ///
    /// With `NEAR_FIRST` the traversal visits nearer boxes first, so that
    /// the blocker it finds and remembers is usually one near `a`. Why: a
    /// sample that no viewer sees, on the wall of a cave in a block world,
    /// is hidden by the walls around it. The unordered traversal returns
    /// whichever blocking triangle it meets first, often one far along the
    /// segment, in the rock or near the viewer, which hides none of the
    /// sample's next segments; the walls near the sample hide most of
    /// them. On the 200k-triangle block world of the benchmark set this cut
    /// the traversals of blocked segments in coverage's builds from 52.6M
    /// to 22.4M (temporary counters) and each build from 2.0 s to 1.5 s
    /// (BENCHMARKS.md). Elsewhere (refinement's columns, the octree's
    /// ranking) it measured no better, and everywhere 7–14% slower on
    /// Dabrovic Sponza, whose blocked segments the memories mostly answer:
    /// the sort is paid on every node that free segments cross.
    #[inline]
    pub fn occluded_between<const NEAR_FIRST: bool>(
        &self,
        a: Vec3,
        b: Vec3,
        eps: f32,
        near_a: &mut Blocker,
        near_b: &mut Blocker,
    ) -> bool {
        self.segment_blocked_by::<NEAR_FIRST>(a.into(), b.into(), eps, near_a, Some(near_b))
    }

    /// [`SceneBvh::occluded_between`] on whole SIMD vectors, the second
    /// memory optional, the traversal nearest first or not
    /// (`NEAR_FIRST`, [`SceneBvh::occluded_between`]).
    fn segment_blocked_by<const NEAR_FIRST: bool>(
        &self,
        a: Vec3A,
        b: Vec3A,
        eps: f32,
        blocker: &mut Blocker,
        other: Option<&mut Blocker>,
    ) -> bool {
        let d = b - a;
        let len = d.length();
        if len <= 2.0 * eps {
            return false;
        }
        let dir = positive_zeros(d / len);
        let ray = Ray::new(a, dir, eps, len - eps);
        let wray = WatertightRay::new(a, dir);
        // The remembered triangles first, by the traversal's own test.
        let remembered = |m: &Blocker| -> bool {
            m.lanes != 0 && blocking_lane(&wray, &m.block, m.lanes, &ray, |_, _| true).is_some()
        };
        if remembered(blocker) || other.as_deref().is_some_and(remembered) {
            return true;
        }
        let mut last = None;
        let touch = |slots: Range<usize>| self.prefetch(slots);
        let blocked = self.bvh.any::<NEAR_FIRST, _, _>(&BoxRay::new(&ray), ray.tmax, touch, |slots| {
            for (block, lanes) in blocks_of(slots) {
                let stops = |i: usize, t: f32| self.stops(LEAF_ALIGN * block + i, a + dir * t);
                if let Some(i) = blocking_lane(&wray, &self.blocks[block], lanes, &ray, stops) {
                    last = Some((LEAF_ALIGN * block + i) as u32);
                    return true;
                }
            }
            false
        });
        // A cut-out is not remembered: whether it blocks depends on where
        // a segment crosses it, which the memory's test does not ask.
        if let Some(slot) = last.filter(|&s| self.cut_of.get(s as usize).is_none_or(|&k| k == NOT_CUT)) {
            let slot = slot as usize;
            let tri = self.blocks[slot / LEAF_ALIGN].triangle(slot % LEAF_ALIGN);
            blocker.remember(&tri);
            if let Some(other) = other {
                other.remember(&tri);
            }
        }
        blocked
    }
}

/// The first of `lanes` of `block` whose triangle blocks the segment of
/// `ray` (its distance `t` within `[tmin, tmax]` and short of `tmax`, and
/// `stops(lane, t)`: not a cut-out's hole): the test of a leaf's blocks
/// in the traversal, and of a [`Blocker`]'s.
#[inline(always)]
fn blocking_lane(
    wray: &WatertightRay,
    block: &TriangleBlock,
    lanes: u32,
    ray: &Ray,
    stops: impl Fn(usize, f32) -> bool,
) -> Option<usize> {
    let (mut hit, dist) = wray.distances4(block, lanes);
    while hit != 0 {
        let i = hit.trailing_zeros() as usize;
        hit &= hit - 1;
        let t = in_range(dist[i], ray.tmin, ray.tmax);
        if t < ray.tmax && stops(i, t) {
            return Some(i);
        }
    }
    None
}

/// The cut-out triangles of `scene` ([`super::Material::cutout`]) in the
/// BVH's slot order `scene_index`: per slot its index among them
/// ([`NOT_CUT`] for the rest; empty when there are none), and what their
/// test reads. A cut-out's triangle without texture coordinates reads its
/// map at (0, 0).
fn cutouts(scene: &Scene, scene_index: &[u32]) -> (Vec<u32>, Cutouts) {
    let cut_material: Vec<Option<super::Cutout>> =
        scene.materials.iter().map(|m| m.cutout).collect();
    if cut_material.iter().all(Option::is_none) {
        return (Vec::new(), Cutouts::default());
    }
    let mut cut = Cutouts {
        triangles: Vec::new(),
        textures: scene.textures.clone(),
    };
    let cut_of = scene_index
        .iter()
        .map(|&i| {
            let Some(&Some(c)) = (i != PAD)
                .then(|| cut_material.get(scene.material_ids[i as usize] as usize))
                .flatten()
            else {
                return NOT_CUT;
            };
            let uv = scene.texcoords.get(i as usize).copied().unwrap_or_default();
            cut.triangles.push((scene.triangles[i as usize], uv, c));
            (cut.triangles.len() - 1) as u32
        })
        .collect();
    (cut_of, cut)
}

/// The blocks of a leaf's slots (which start at a multiple of
/// [`LEAF_ALIGN`]), each with the mask of its lanes in the leaf.
#[inline(always)]
fn blocks_of(slots: Range<usize>) -> impl Iterator<Item = (usize, u32)> {
    debug_assert_eq!(slots.start % LEAF_ALIGN, 0);
    (slots.start..slots.end).step_by(LEAF_ALIGN).map(move |s| {
        (
            s / LEAF_ALIGN,
            (1u32 << (slots.end - s).min(LEAF_ALIGN)) - 1,
        )
    })
}

/// For each triangle, whether the list holds it again reversed: the same
/// three vertices (bit for bit) in the opposite winding, so the two are the
/// faces of a two-sided sheet (see [`SceneBvh::closest_hit_prefer_back`]).
/// Triangles are matched by a hash of their vertex set, sorted in parallel,
/// and confirmed vertex by vertex.
pub(crate) fn sheet_faces(triangles: &[[Vec3; 3]]) -> Vec<bool> {
    let bits = |v: Vec3| v.to_array().map(f32::to_bits);
    // The vertex set in a canonical order, and the winding's parity against it.
    let canonical = |t: &[Vec3; 3]| -> ([[u32; 3]; 3], bool) {
        let mut v = t.map(bits);
        let mut odd = false;
        for (a, b) in [(0, 1), (1, 2), (0, 1)] {
            if v[a] > v[b] {
                v.swap(a, b);
                odd = !odd;
            }
        }
        (v, odd)
    };
    let mut keys: Vec<(u64, u32)> = triangles
        .par_iter()
        .enumerate()
        .map(|(i, t)| {
            let (v, _) = canonical(t);
            let mut h = 0xcbf2_9ce4_8422_2325u64;
            for w in v.iter().flatten() {
                h = (h ^ *w as u64).wrapping_mul(0x0100_0000_01b3);
            }
            (h, i as u32)
        })
        .collect();
    keys.par_sort_unstable();
    let mut sheet = vec![false; triangles.len()];
    let mut start = 0;
    while start < keys.len() {
        let mut end = start + 1;
        while end < keys.len() && keys[end].0 == keys[start].0 {
            end += 1;
        }
        // Sorted by vertex set, then winding: a run of one vertex set is a
        // sheet's where it holds both windings. Not every pair of the
        // group: a mesh instanced many times at one place gives groups of
        // thousands of equal triangles, and pairs made its build quadratic.
        let mut group: Vec<([[u32; 3]; 3], bool, u32)> = keys[start..end]
            .iter()
            .map(|&(_, i)| {
                let (v, odd) = canonical(&triangles[i as usize]);
                (v, odd, i)
            })
            .collect();
        group.sort_unstable();
        let mut a = 0;
        while a < group.len() {
            let mut b = a + 1;
            while b < group.len() && group[b].0 == group[a].0 {
                b += 1;
            }
            if group[a].1 != group[b - 1].1 {
                for g in &group[a..b] {
                    sheet[g.2 as usize] = true;
                }
            }
            a = b;
        }
        start = end;
    }
    sheet
}

/// The last [`BLOCKER_MEMORY`] triangles that blocked one of a family of
/// segments, for [`SceneBvh::occluded_from`]; the default remembers none.
/// It is only worth keeping for segments near each other.
///
/// Why four, tested at once: neighbouring segments are usually hidden by
/// one of a few triangles (a column's faces, a floor's two halves, the
/// quad of a wall), and a blocked segment that the memory misses costs a
/// traversal dearer than a free segment's, through the walls of other
/// rooms. On Dabrovic Sponza's `place`, remembering only the last
/// triangle stopped 8.8M segments and left 6.1M blocked ones to a
/// traversal; four stopped 10.6M and left 4.4M (eight: 10.9M and 4.0M,
/// for a second block's test on every segment). The four are kept as one
/// [`TriangleBlock`], whose SIMD test costs about what one triangle's did.
/// Replacement is first in, first out.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Blocker {
    /// The remembered triangles, one per lane.
    block: TriangleBlock,
    /// The lanes that hold one.
    lanes: u32,
    /// The lane the next triangle replaces: the longest remembered.
    next: u8,
}

/// Triangles a [`Blocker`] remembers: one SIMD block's lanes.
pub const BLOCKER_MEMORY: usize = LEAF_ALIGN;

impl Default for Blocker {
    fn default() -> Blocker {
        Blocker {
            block: TriangleBlock::new(&[]),
            lanes: 0,
            next: 0,
        }
    }
}

impl Blocker {
    /// Remembers `tri` in place of the longest remembered triangle.
    fn remember(&mut self, tri: &WatertightTriangle) {
        let i = self.next as usize;
        self.block.set(i, tri);
        self.lanes |= 1 << i;
        self.next = ((i + 1) % BLOCKER_MEMORY) as u8;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::{cube_point, hash2, unit_f32};
    use crate::scene::Material;

    fn floor_and_ceiling() -> Scene {
        let f = [
            Vec3::new(-1.0, 0.0, -1.0),
            Vec3::new(-1.0, 0.0, 1.0),
            Vec3::new(1.0, 0.0, 1.0),
        ];
        let c = [
            Vec3::new(-1.0, 1.0, -1.0),
            Vec3::new(1.0, 1.0, 1.0),
            Vec3::new(-1.0, 1.0, 1.0),
        ];
        Scene::from_triangles("t".into(), [(f, 0), (c, 0)], vec![Material::fallback()]).unwrap()
    }

    fn scene_of(tris: &[[Vec3; 3]]) -> Scene {
        let s = Scene::from_triangles(
            "t".into(),
            tris.iter().map(|&t| (t, 0)),
            vec![Material::fallback()],
        )
        .unwrap();
        assert_eq!(s.triangles.len(), tris.len(), "no triangle dropped");
        s
    }

    fn rand_unit(h: u64) -> f32 {
        unit_f32(h)
    }

    /// A uniformly random unit vector.
    fn rand_dir(h: u64) -> Vec3 {
        let z = 2.0 * rand_unit(hash2(h, 1)) - 1.0;
        let phi = std::f32::consts::TAU * rand_unit(hash2(h, 2));
        let r = (1.0 - z * z).max(0.0).sqrt();
        Vec3::new(r * phi.cos(), r * phi.sin(), z)
    }

    /// `n` random triangles (seeded by `seed`) with centres in [-1, 1]³
    /// and vertices `size` from them.
    fn soup(seed: u64, n: u64, size: f32) -> Vec<[Vec3; 3]> {
        (0..n)
            .map(|i| {
                let h = hash2(seed, i);
                let c = cube_point(h);
                [0, 1, 2].map(|k| c + rand_dir(hash2(h, 10 + k)) * size)
            })
            .collect()
    }

    #[test]
    fn hits_report_distance_index_and_side() {
        let s = floor_and_ceiling();
        let bvh = SceneBvh::new(&s);
        // Exactly axis-aligned rays, with zeros in their directions.
        let o = Vec3::new(-0.5, 0.5, 0.5);
        let down = bvh.closest_hit(o, -Vec3::Y, 0.0, f32::INFINITY).unwrap();
        assert!((down.t - 0.5).abs() < 1e-6);
        assert_eq!(down.triangle, 0);
        assert!(!down.backface, "floor normal faces up, towards the origin");
        let up = bvh.closest_hit(o, Vec3::Y, 0.0, f32::INFINITY).unwrap();
        assert!((up.t - 0.5).abs() < 1e-6);
        assert_eq!(up.triangle, 1);
        assert!(!up.backface, "ceiling normal faces down");
        // From below the floor, the floor is seen from its back.
        let below = bvh
            .closest_hit(Vec3::new(-0.5, -1.0, 0.5), Vec3::Y, 0.0, f32::INFINITY)
            .unwrap();
        assert_eq!(below.triangle, 0);
        assert!(below.backface);
        assert!(bvh.closest_hit(o, Vec3::X, 0.0, f32::INFINITY).is_none());
        // Signed zeros in the direction change nothing.
        for d in [
            Vec3::new(0.0, -1.0, 0.0),
            Vec3::new(-0.0, -1.0, 0.0),
            Vec3::new(0.0, -1.0, -0.0),
            Vec3::new(-0.0, -1.0, -0.0),
        ] {
            let h = bvh.closest_hit(o, d, 0.0, f32::INFINITY).unwrap();
            assert_eq!((h.triangle, h.backface), (0, false), "{d:?}");
        }
    }

    #[test]
    fn coplanar_back_face_wins_the_tie() {
        // A floor facing up and, on the same plane, the bottom of a box
        // facing down (a smaller triangle: the same one reversed would be
        // a two-sided sheet).
        let floor = [
            Vec3::new(-1.0, 0.0, -1.0),
            Vec3::new(-1.0, 0.0, 1.0),
            Vec3::new(1.0, 0.0, 1.0),
        ];
        let bottom = [
            Vec3::new(-0.9, 0.0, -0.5),
            Vec3::new(0.5, 0.0, 0.9),
            Vec3::new(-0.9, 0.0, 0.9),
        ];
        for tris in [[(floor, 0), (bottom, 0)], [(bottom, 0), (floor, 0)]] {
            let s = Scene::from_triangles("t".into(), tris, vec![Material::fallback()]).unwrap();
            let bvh = SceneBvh::new(&s);
            let o = Vec3::new(-0.5, 0.5, 0.5);
            let h = bvh
                .closest_hit_prefer_back(o, -Vec3::Y, 0.0, f32::INFINITY, 1e-4)
                .unwrap();
            assert!(h.backface, "{tris:?}");
            assert!((h.t - 0.5).abs() < 1e-6);
        }
    }

    #[test]
    fn occlusion_between_points() {
        let s = floor_and_ceiling();
        let bvh = SceneBvh::new(&s);
        let a = Vec3::new(-0.5, 0.5, 0.5);
        assert!(bvh.occluded(a, Vec3::new(-0.5, -0.5, 0.5), 1e-4));
        assert!(!bvh.occluded(a, Vec3::new(-0.6, 0.2, 0.4), 1e-4));
        // A point on the floor is visible from above: the endpoint does not self-occlude.
        assert!(!bvh.occluded(a, Vec3::new(-0.5, 0.0, 0.5), 1e-4));
    }

    #[test]
    fn tmin_and_tmax_bound_the_hits() {
        let s = floor_and_ceiling();
        let bvh = SceneBvh::new(&s);
        let o = Vec3::new(-0.5, 0.5, 0.5);
        let d = Vec3::new(0.1, -1.0, 0.2).normalize();
        let t = bvh.closest_hit(o, d, 0.0, f32::INFINITY).unwrap().t;
        assert!(bvh.closest_hit(o, d, 0.0, t * 0.999).is_none());
        assert!(bvh.closest_hit(o, d, t * 1.001, f32::INFINITY).is_none());
        let h = bvh.closest_hit(o, d, t * 0.999, t * 1.001).unwrap();
        assert_eq!(h.t, t);
        // Closest, not first found: from the floor's back the ceiling is farther.
        let below = Vec3::new(-0.5, -1.0, 0.5);
        assert_eq!(
            bvh.closest_hit(below, Vec3::Y, 0.0, 5.0).unwrap().triangle,
            0
        );
        assert_eq!(
            bvh.closest_hit(below, Vec3::Y, 1.5, 5.0).unwrap().triangle,
            1
        );
        // Segments ending short of a surface are not blocked by it.
        assert!(!bvh.occluded(o, o + d * (t * 0.99), 1e-4));
        assert!(bvh.occluded(o, o + d * (t * 1.01), 1e-4));
    }

    /// A point to aim at, the mesh's normal there and a direction along
    /// the shared edge through it.
    type Target = (Vec3, Vec3, Vec3);

    /// Aims rays at `targets` (points of the mesh's interior edges and
    /// vertices, where a watertight test must hit) from many origins, and
    /// returns how many were tried and how many slipped through: no
    /// `closest_hit` at the target's distance, or an unblocked segment
    /// through the target in `occluded`.
    fn slips(bvh: &SceneBvh, targets: &[Target], seed: u64) -> (usize, usize) {
        let (mut tried, mut slipped) = (0, 0);
        for (k, &(p, n, e)) in targets.iter().enumerate() {
            let mut origins = Vec::new();
            // Exactly axis-aligned rays (the axes that cross the plane).
            for axis in [Vec3::X, Vec3::Y, Vec3::Z] {
                if axis.dot(n).abs() > 0.1 {
                    for s in [0.37f32, -0.37, 1.0, -1.0] {
                        origins.push(p + axis * s);
                    }
                }
            }
            // In the plane of the edge and the normal, as a segment
            // between grid points runs along a seam.
            for m in [0.25f32, -0.25, 1.0, -1.0] {
                for l in [-1.0f32, -0.5, 0.5, 1.0] {
                    origins.push(p + n * m + e * l);
                }
            }
            // Random, from everywhere.
            for r in 0..12u64 {
                let d = rand_dir(hash2(seed, (k as u64) << 8 | r));
                if d.dot(n).abs() > 0.05 {
                    origins.push(p + d * (0.1 + rand_unit(hash2(seed ^ 1, r)) * 2.0));
                }
            }
            for o in origins {
                tried += 1;
                let to = p - o;
                let dist = to.length();
                let dir = to / dist;
                let hit = bvh.closest_hit(o, dir, 0.0, f32::INFINITY);
                let hit_ok = hit.is_some_and(|h| (h.t - dist).abs() <= 1e-4 * dist.max(1.0));
                // The segment through the target and as far again beyond.
                let blocked = bvh.occluded(o, p + to, 1e-5);
                if !hit_ok || !blocked {
                    slipped += 1;
                }
            }
        }
        (tried, slipped)
    }

    /// An `n × n` grid of quads, each split along a diagonal (alternating
    /// directions, so that interior vertices are shared by 6 or 8
    /// triangles), spanned by `u` and `v` from `corner` with vertex
    /// spacing 1/n; and the targets on its interior edges and vertices.
    fn grid(corner: Vec3, u: Vec3, v: Vec3, n: usize) -> (Vec<[Vec3; 3]>, Vec<Target>) {
        let at =
            |i: usize, j: usize| corner + u * (i as f32 / n as f32) + v * (j as f32 / n as f32);
        let normal = u.cross(v).normalize();
        let mut tris = Vec::new();
        let mut targets = Vec::new();
        for j in 0..n {
            for i in 0..n {
                let (a, b, c, d) = (at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
                let (p, q) = if (i + j) % 2 == 0 {
                    tris.push([a, b, c]);
                    tris.push([a, c, d]);
                    (a, c)
                } else {
                    tris.push([a, b, d]);
                    tris.push([b, c, d]);
                    (b, d)
                };
                // The diagonal seam.
                for f in [0.5f32, 0.25, 0.7] {
                    targets.push((p + (q - p) * f, normal, q - p));
                }
                // Interior grid edges: the cell's lower and left edges.
                if j > 0 {
                    targets.push((a + (b - a) * 0.5, normal, b - a));
                    targets.push((a + (b - a) * 0.3, normal, b - a));
                }
                if i > 0 {
                    targets.push((a + (d - a) * 0.5, normal, d - a));
                }
                // Interior vertices.
                if i > 0 && j > 0 {
                    targets.push((a, normal, (c - a).normalize()));
                    targets.push((a, normal, (b - a).normalize()));
                }
            }
        }
        (tris, targets)
    }

    #[test]
    fn rays_through_a_quads_diagonal_seam_hit() {
        // One axis-aligned quad, split along its diagonal, at coordinates
        // that are not round in binary.
        let (a, b, c, d) = (
            Vec3::new(0.1, 0.3, 0.2),
            Vec3::new(0.8, 0.3, 0.2),
            Vec3::new(0.8, 0.3, 0.9),
            Vec3::new(0.1, 0.3, 0.9),
        );
        let s = scene_of(&[[a, c, b], [a, d, c]]);
        let bvh = SceneBvh::new(&s);
        let targets: Vec<_> = (1..40)
            .map(|k| (a + (c - a) * (k as f32 / 40.0), Vec3::Y, c - a))
            .collect();
        let (tried, slipped) = slips(&bvh, &targets, 3);
        assert!(tried > 1000);
        assert_eq!(
            slipped, 0,
            "{slipped} of {tried} rays slipped through the seam"
        );
        // Segments between the points of a regular grid straddling the
        // quad, through the seam and along it (what `svo::rank::is_free`
        // casts between voxel centres).
        let h = 0.7f32 / 7.0;
        let mut n = 0;
        for i in 1..14 {
            // Grid points at half spacing along the seam, and lattice
            // neighbours above and below it in the seam's vertical plane.
            let p = a + Vec3::new(1.0, 0.0, 1.0) * (i as f32 * h * 0.5);
            for k in [1.0f32, 2.0] {
                for (up, down) in [
                    (Vec3::new(-k, k, -k), Vec3::new(k, -k, k)),
                    (Vec3::new(k, k, k), Vec3::new(-k, -k, -k)),
                    (Vec3::new(0.0, k, 0.0), Vec3::new(0.0, -k, 0.0)),
                    (Vec3::new(-k, k, -k), Vec3::new(0.5 * k, -0.5 * k, 0.5 * k)),
                ] {
                    let (up, down) = (p + up * h, p + down * h);
                    assert!(bvh.occluded(up, down, 1e-5), "{up} → {down}");
                    assert!(bvh.occluded(down, up, 1e-5), "{down} → {up}");
                    n += 1;
                }
            }
        }
        assert_eq!(n, 13 * 2 * 4);
    }

    #[test]
    fn rays_through_shared_edges_and_vertices_of_a_grid_hit() {
        // Axis-aligned and tilted grids, and a fan of 11 triangles round
        // one vertex.
        for (corner, u, v) in [
            (
                Vec3::new(-0.35, 0.3, -0.45),
                Vec3::new(1.3, 0.0, 0.0),
                Vec3::new(0.0, 0.0, 1.1),
            ),
            (
                Vec3::new(0.2, -0.6, -0.1),
                Vec3::new(0.0, 1.7, 0.0),
                Vec3::new(0.0, 0.0, 0.9),
            ),
            (
                Vec3::new(-0.3, -0.2, 0.1),
                Vec3::new(1.1, 0.3, -0.2),
                Vec3::new(-0.1, 0.4, 0.9),
            ),
        ] {
            let (tris, targets) = grid(corner, u, v, 6);
            let bvh = SceneBvh::new(&scene_of(&tris));
            let (tried, slipped) = slips(&bvh, &targets, 5);
            assert!(tried > 5000, "{tried}");
            assert_eq!(
                slipped, 0,
                "{slipped} of {tried} rays slipped through the grid {u} {v}"
            );
        }
        // A fan: 11 triangles of irregular angles round a centre.
        let centre = Vec3::new(0.13, 0.41, -0.27);
        let (e1, e2) = (
            Vec3::new(0.9, 0.1, 0.3).normalize(),
            Vec3::new(-0.2, 0.3, 0.8),
        );
        let e2 = (e2 - e1 * e1.dot(e2)).normalize();
        let n = e1.cross(e2);
        let mut angles: Vec<f32> = (0..11)
            .map(|k| k as f32 + 0.6 * rand_unit(hash2(9, k)))
            .collect();
        angles
            .iter_mut()
            .for_each(|a| *a *= std::f32::consts::TAU / 11.0);
        let rim: Vec<Vec3> = angles
            .iter()
            .map(|a| centre + (e1 * a.cos() + e2 * a.sin()) * 0.8)
            .collect();
        let tris: Vec<[Vec3; 3]> = (0..11)
            .map(|k| [centre, rim[k], rim[(k + 1) % 11]])
            .collect();
        let bvh = SceneBvh::new(&scene_of(&tris));
        let mut targets = vec![(centre, n, e1), (centre, n, e2)];
        for r in &rim {
            for f in [0.5f32, 0.2, 0.9] {
                targets.push((centre + (*r - centre) * f, n, *r - centre));
            }
        }
        let (tried, slipped) = slips(&bvh, &targets, 7);
        assert!(tried > 500);
        assert_eq!(
            slipped, 0,
            "{slipped} of {tried} rays slipped through the fan"
        );
    }

    #[test]
    fn points_on_long_slivers_do_not_occlude_themselves() {
        // A sliver of Sponza's (10.8 × 0.01, tilted), with a point on it
        // and a segment leaving it at a grazing angle, as the coverage
        // reference casts them; then random points and directions on it
        // and on a long tilted sliver of our own. The paper's distance
        // T/det put such a point's own triangle at t ≈ 6.6e-4, past eps.
        let sponza = [
            Vec3::new(0.00724, 11.018311, 2.421488),
            Vec3::new(10.83524, 11.00831, 2.429487),
            Vec3::new(0.00724, 11.00831, 2.429487),
        ];
        let ours = [
            Vec3::new(-7.3, 2.1, 0.4),
            Vec3::new(6.9, 2.6, -1.3),
            Vec3::new(-7.3, 2.108, 0.39),
        ];
        let eps = 2.5e-4;
        let s = scene_of(&[sponza]);
        let bvh = SceneBvh::new(&s);
        let (a, b) = (
            Vec3::new(9.174919, 11.009175, 2.4287949),
            Vec3::new(5.4722404, 13.718311, -0.42351198),
        );
        assert!(!bvh.occluded(a, b, eps));
        let (mut tried, mut blocked) = (0, 0);
        for (k, tri) in [sponza, ours].into_iter().enumerate() {
            let s = scene_of(&[tri]);
            let bvh = SceneBvh::new(&s);
            let n = s.normals[0];
            for i in 0..4000u64 {
                let h = hash2(31 + k as u64, i);
                let p = crate::sampling::point_in_triangle(
                    &tri,
                    rand_unit(hash2(h, 1)),
                    rand_unit(hash2(h, 2)),
                );
                let d = rand_dir(hash2(h, 3));
                if d.dot(n).abs() < 0.05 {
                    continue;
                }
                tried += 1;
                if bvh.occluded(p, p + d * 5.0, eps)
                    || bvh.closest_hit(p, d, eps, f32::INFINITY).is_some()
                {
                    blocked += 1;
                }
            }
        }
        assert!(tried > 7000, "{tried}");
        assert_eq!(
            blocked, 0,
            "{blocked} of {tried} points on slivers occluded themselves"
        );
    }

    /// The 12 triangles of the box `min..max`, facing outward.
    fn closed_box(min: Vec3, max: Vec3) -> Vec<[Vec3; 3]> {
        let c = |i: usize| {
            Vec3::new(
                if i & 1 == 0 { min.x } else { max.x },
                if i & 2 == 0 { min.y } else { max.y },
                if i & 4 == 0 { min.z } else { max.z },
            )
        };
        // Quads counter-clockwise from outside.
        let quads = [
            [0, 4, 6, 2], // -x
            [1, 3, 7, 5], // +x
            [0, 1, 5, 4], // -y
            [2, 6, 7, 3], // +y
            [0, 2, 3, 1], // -z
            [4, 5, 7, 6], // +z
        ];
        let mut tris = Vec::new();
        for q in quads {
            tris.push([c(q[0]), c(q[1]), c(q[2])]);
            tris.push([c(q[0]), c(q[2]), c(q[3])]);
        }
        tris
    }

    #[test]
    fn a_closed_box_occludes_every_segment_leaving_it() {
        let (min, max) = (Vec3::new(-0.7, -0.3, -1.1), Vec3::new(0.9, 1.3, 0.5));
        let tris = closed_box(min, max);
        let s = scene_of(&tris);
        let centre = (min + max) * 0.5;
        assert!(s
            .normals
            .iter()
            .zip(&tris)
            .all(|(n, t)| n.dot(t[0] - centre) > 0.0));
        let bvh = SceneBvh::new(&s);
        let size = max - min;
        let corners: Vec<Vec3> = tris.iter().flatten().copied().collect();
        let (mut tried, mut slipped) = (0, 0);
        for i in 0..600u64 {
            let h = hash2(11, i);
            let r = |k| 0.01 + 0.98 * rand_unit(hash2(h, k));
            let p = min + size * Vec3::new(r(1), r(2), r(3));
            let mut ends = Vec::new();
            // Random directions, far out.
            for k in 0..4 {
                ends.push(p + rand_dir(hash2(h, 10 + k)) * 5.0);
            }
            // Exactly axis-aligned.
            for axis in [Vec3::X, Vec3::Y, Vec3::Z] {
                ends.push(p + axis * 3.0);
                ends.push(p - axis * 3.0);
            }
            // Through the corners, random points of the edges and of the
            // faces' diagonals (every one a shared edge or vertex).
            for &q in corners.iter().step_by(5) {
                ends.push(p + (q - p) * 2.0);
            }
            for (k, t) in tris.iter().enumerate() {
                let f = rand_unit(hash2(h, 100 + k as u64));
                ends.push(p + (t[0] + (t[1] - t[0]) * f - p) * 2.0);
                ends.push(p + (t[0] + (t[2] - t[0]) * f - p) * 2.0);
            }
            for q in ends {
                tried += 1;
                let hit = bvh.closest_hit(p, (q - p).normalize(), 0.0, f32::INFINITY);
                if !bvh.occluded(p, q, 1e-5) || !hit.is_some_and(|h| h.backface) {
                    slipped += 1;
                }
            }
        }
        assert!(tried > 20_000, "{tried}");
        assert_eq!(slipped, 0, "{slipped} of {tried} segments left the box");
    }

    #[test]
    fn a_two_sided_sheet_shows_its_front_and_a_pressed_solid_its_back() {
        // At x = 1: a sheet (one triangle, twice, reversed) over y, z < 0;
        // over y, z > 0 a wall's face and, coplanar, a different triangle
        // facing the other way (a solid's face pressed against the wall).
        let tri = [
            Vec3::new(1.0, -1.0, -3.0),
            Vec3::new(1.0, -1.0, -1.0),
            Vec3::new(1.0, -3.0, -1.0),
        ];
        let wall = [
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(1.0, 3.0, 0.0),
            Vec3::new(1.0, 0.0, 3.0),
        ];
        let pressed = [
            Vec3::new(1.0, 0.5, 0.5),
            Vec3::new(1.0, 0.5, 1.5),
            Vec3::new(1.0, 1.5, 0.5),
        ];
        let tris = [tri, [tri[0], tri[2], tri[1]], wall, pressed];
        let s = scene_of(&tris);
        assert_eq!(sheet_faces(&s.triangles), [true, true, false, false]);
        let bvh = SceneBvh::new(&s);
        let tie = 1e-3;
        for dir in [Vec3::X, -Vec3::X] {
            let from = Vec3::new(1.0, -1.5, -1.5) - 2.0 * dir;
            let hit = bvh
                .closest_hit_prefer_back(from, dir, 0.0, f32::INFINITY, tie)
                .unwrap();
            assert!(!hit.backface, "the sheet from {from}");
            assert!((hit.t - 2.0).abs() < 1e-5);
            let from = Vec3::new(1.0, 0.8, 0.8) - 2.0 * dir;
            let hit = bvh
                .closest_hit_prefer_back(from, dir, 0.0, f32::INFINITY, tie)
                .unwrap();
            assert!(hit.backface, "the pressed pair from {from}");
            assert!((hit.t - 2.0).abs() < 1e-5);
        }
    }

    #[test]
    fn a_remembered_blocker_never_changes_the_answer() {
        // A soup of random triangles; segments from one origin to many
        // ends, then between random pairs, through one memory shared by all
        // (so it often names a triangle that has nothing to do with the
        // segment at hand): every answer is `occluded`'s, and the memory
        // is used, answering most segments of an origin hidden by one
        // triangle right in front of it.
        let mut tris = soup(31, 400, 0.25);
        // One large triangle just above the origin `hidden`.
        let hidden = Vec3::new(0.05, -0.2, 0.03);
        let lid = |x: f32, z: f32| Vec3::new(x, -0.15, z);
        tris.push([lid(-9.0, -9.0), lid(9.0, -9.0), lid(0.0, 9.0)]);
        let s = scene_of(&tris);
        let bvh = SceneBvh::new(&s);
        let mut blocker = Blocker::default();
        let (mut tried, mut blocked, mut remembered) = (0, 0, 0);
        for i in 0..4000u64 {
            let h = hash2(32, i);
            let a = if i < 2000 { hidden } else { cube_point(h) };
            let b = a + rand_dir(hash2(h, 4)) * (0.1 + 3.0 * rand_unit(hash2(h, 5)));
            let before = blocker;
            let answer = bvh.occluded_from(a, b, 1e-4, &mut blocker);
            assert_eq!(answer, bvh.occluded(a, b, 1e-4), "segment {i}: {a} to {b}");
            tried += 1;
            if answer {
                blocked += 1;
                if blocker == before {
                    remembered += 1;
                }
            } else {
                assert_eq!(blocker, before, "a free segment leaves the memory alone");
            }
        }
        assert!(
            blocked > tried / 4 && blocked < tried,
            "{blocked} of {tried}"
        );
        assert!(remembered > tried / 8, "{remembered} of {blocked} blocked");
    }

    /// A point hidden under each of `n` small lids, far apart: the segment
    /// up from point `k` crosses lid `k` alone.
    fn lidded_points(n: usize) -> (SceneBvh, Vec<(Vec3, Vec3)>) {
        let mut tris = Vec::new();
        let mut segments = Vec::new();
        for k in 0..n {
            let x = 3.0 * k as f32;
            let lid = |dx: f32, dz: f32| Vec3::new(x + dx, 1.0, dz);
            tris.push([lid(-0.5, -0.5), lid(0.5, -0.5), lid(0.0, 0.5)]);
            segments.push((Vec3::new(x, 0.0, 0.0), Vec3::new(x, 2.0, 0.0)));
        }
        (SceneBvh::new(&scene_of(&tris)), segments)
    }

    #[test]
    fn a_blocker_remembers_the_last_four_triangles_found() {
        // Lids 0–3 found by traversals, then each answered from memory
        // (the memory left as it was); lid 4 replaces the first found, lid
        // 0, which a traversal then finds again.
        let (bvh, seg) = lidded_points(5);
        let mut blocker = Blocker::default();
        let from_memory = |k: usize, blocker: &mut Blocker| -> bool {
            let before = *blocker;
            assert!(
                bvh.occluded_from(seg[k].0, seg[k].1, 1e-4, blocker),
                "lid {k}"
            );
            *blocker == before
        };
        for k in 0..4 {
            assert!(!from_memory(k, &mut blocker), "lid {k} is new");
        }
        for k in [2, 0, 3, 1] {
            assert!(from_memory(k, &mut blocker), "lid {k} is remembered");
        }
        assert!(!from_memory(4, &mut blocker), "lid 4 is new");
        for k in [1, 2, 3, 4] {
            assert!(from_memory(k, &mut blocker), "lid {k} is remembered");
        }
        assert!(!from_memory(0, &mut blocker), "lid 0 was forgotten");
        // A free segment beside the lids neither blocks nor changes it.
        let before = blocker;
        let beside = Vec3::new(1.5, 0.0, 0.0);
        assert!(!bvh.occluded_from(beside, beside + Vec3::Y * 2.0, 1e-4, &mut blocker));
        assert_eq!(blocker, before);
    }

    #[test]
    fn two_memories_answer_as_one_segment_test_and_share_what_they_find() {
        // Random segments between a few clusters of points through a
        // soup, every pair of cluster memories reused: the answers are
        // `occluded`'s.
        let tris = soup(41, 500, 0.3);
        let bvh = SceneBvh::new(&scene_of(&tris));
        let mut near = vec![Blocker::default(); 8];
        let (mut blocked, mut tried) = (0, 0);
        for i in 0..4000u64 {
            let h = hash2(42, i);
            let (ca, cb) = ((h % 8) as usize, ((h >> 8) % 8) as usize);
            if ca == cb {
                continue;
            }
            let centre = |c: usize| cube_point(hash2(43, c as u64));
            let a = centre(ca) + 0.05 * rand_dir(hash2(h, 1));
            let b = centre(cb) + 0.05 * rand_dir(hash2(h, 2));
            let (lo, hi) = near.split_at_mut(ca.max(cb));
            let (ma, mb) = if ca < cb {
                (&mut lo[ca], &mut hi[0])
            } else {
                (&mut hi[0], &mut lo[cb])
            };
            let answer = bvh.occluded_between::<false>(a, b, 1e-4, ma, mb);
            assert_eq!(answer, bvh.occluded(a, b, 1e-4), "segment {i}: {a} to {b}");
            blocked += answer as usize;
            tried += 1;
        }
        assert!(
            blocked > tried / 8 && blocked < tried,
            "{blocked} of {tried}"
        );
        // What a traversal finds goes into both memories: the same
        // segment is then stopped by either alone.
        let (bvh, seg) = lidded_points(1);
        let (mut ma, mut mb) = (Blocker::default(), Blocker::default());
        assert!(bvh.occluded_between::<false>(seg[0].0, seg[0].1, 1e-4, &mut ma, &mut mb));
        for m in [ma, mb] {
            let mut m2 = m;
            assert!(bvh.occluded_from(seg[0].0, seg[0].1, 1e-4, &mut m2));
            assert_eq!(m2, m, "answered from the memory alone");
        }
        assert_ne!(ma, Blocker::default());
    }

    #[test]
    fn nearest_first_traversal_answers_alike_and_remembers_the_nearest_wall() {
        // The same random segments through a soup, each with its own
        // memories for both traversals: the same answers as `occluded`.
        let tris = soup(51, 500, 0.3);
        let bvh = SceneBvh::new(&scene_of(&tris));
        let (mut near, mut far) = (vec![Blocker::default(); 4], vec![Blocker::default(); 4]);
        let mut blocked = 0;
        for i in 0..3000u64 {
            let h = hash2(52, i);
            let (a, b) = (cube_point(hash2(h, 1)) * 1.2, cube_point(hash2(h, 2)) * 1.2);
            let c = (h % 4) as usize;
            let (ma, mb) = near.split_at_mut(2);
            let ordered = bvh.occluded_between::<true>(a, b, 1e-4, &mut ma[c % 2], &mut mb[c / 2]);
            let (fa, fb) = far.split_at_mut(2);
            let plain = bvh.occluded_between::<false>(a, b, 1e-4, &mut fa[c % 2], &mut fb[c / 2]);
            assert_eq!(ordered, bvh.occluded(a, b, 1e-4), "segment {i}");
            assert_eq!(plain, ordered, "segment {i}");
            blocked += ordered as usize;
        }
        assert!(blocked > 300 && blocked < 2700, "{blocked} of 3000 blocked");
        // Eight parallel walls of 128 triangles each across a segment
        // through all of them: the nearest-first traversal remembers a
        // triangle of the wall nearest the segment's start, whichever end
        // it starts from.
        let mut walls = Vec::new();
        for w in 0..8 {
            let z = 1.0 + w as f32;
            for i in 0..8 {
                for j in 0..8 {
                    let (x, y) = (i as f32 - 4.0, j as f32 - 4.0);
                    let v = |dx: f32, dy: f32| Vec3::new(x + dx, y + dy, z);
                    walls.push([v(0.0, 0.0), v(1.0, 0.0), v(1.0, 1.0)]);
                    walls.push([v(0.0, 0.0), v(1.0, 1.0), v(0.0, 1.0)]);
                }
            }
        }
        let bvh = SceneBvh::new(&scene_of(&walls));
        for (from, to, nearest) in [(0.0, 9.0, 1.0), (9.0, 0.0, 8.0)] {
            for k in 0..16u64 {
                let xy = cube_point(hash2(53, k)).truncate() * 3.0;
                let (a, b) = (xy.extend(from), xy.extend(to));
                let (mut ma, mut mb) = (Blocker::default(), Blocker::default());
                assert!(bvh.occluded_between::<true>(a, b, 1e-4, &mut ma, &mut mb));
                assert_eq!(ma.lanes, 1, "one triangle remembered");
                let z = ma.block.triangle(0).vertex(0).z;
                assert_eq!(z, nearest, "segment {k} from z = {from}");
            }
        }
    }

    #[test]
    fn closest_hits_agree_with_moller_trumbore_on_generic_rays() {
        // A soup of random triangles against a brute-force closest hit
        // with obvhs's Möller–Trumbore test, the one this module used
        // before: same triangle, same side, t within 1e-5 relative.
        let tris = soup(21, 300, 0.3);
        let s = scene_of(&tris);
        let bvh = SceneBvh::new(&s);
        let old: Vec<obvhs::triangle::Triangle> = tris
            .iter()
            .map(|t| obvhs::triangle::Triangle {
                v0: t[0].into(),
                v1: t[1].into(),
                v2: t[2].into(),
            })
            .collect();
        let (mut hits, mut misses) = (0, 0);
        for i in 0..4000u64 {
            let h = hash2(22, i);
            let o = rand_dir(hash2(h, 1)) * (1.5 * rand_unit(hash2(h, 2)));
            let d = rand_dir(hash2(h, 3));
            let ray = Ray::new(o.into(), d.into(), 0.0, f32::INFINITY);
            let mut ts: Vec<(f32, usize)> = old
                .iter()
                .enumerate()
                .map(|(k, t)| (t.intersect(&ray), k))
                .filter(|(t, _)| t.is_finite())
                .collect();
            ts.sort_by(|a, b| a.0.total_cmp(&b.0));
            let got = bvh.closest_hit(o, d, 0.0, f32::INFINITY);
            match (ts.first(), got) {
                (None, None) => misses += 1,
                (Some(&(t, k)), Some(g)) => {
                    if ts.len() > 1 && ts[1].0 - t < 1e-4 {
                        continue; // a near tie: either may be closest
                    }
                    assert_eq!(g.triangle as usize, k, "ray {i}");
                    // Relative, but no finer than the rounding of
                    // coordinates ~1 (both tests err by a few ulps there).
                    assert!(
                        (g.t - t).abs() <= 1e-5 * t.max(0.1),
                        "ray {i}: {} vs {t}",
                        g.t
                    );
                    assert_eq!(g.backface, s.normals[k].dot(d) > 0.0, "ray {i}");
                    hits += 1;
                }
                (want, got) => panic!("ray {i}: Möller–Trumbore {want:?}, watertight {got:?}"),
            }
        }
        assert!(hits > 1000 && misses > 300, "{hits} hits, {misses} misses");
    }
}

/// The BVH against a loop over every triangle with the same test.
#[cfg(test)]
mod brute_force {
    use super::*;
    use crate::sampling::{cube_point, hash2, unit_f32};
    use crate::scene::Material;

    /// [`SceneBvh::closest_hit_prefer_back`]'s documented rule, over all
    /// triangles.
    fn closest(s: &Scene, o: Vec3, dir: Vec3, tmax: f32, tie: f32) -> Option<Hit> {
        let d = positive_zeros(dir.into());
        let ray = WatertightRay::new(o.into(), d);
        let sheet = sheet_faces(&s.triangles);
        let mut best: Option<(f32, u32, f32)> = None;
        for (i, t) in s.triangles.iter().enumerate() {
            let t = ray.intersect(&WatertightTriangle::new(t.map(Vec3A::from)), 0.0, tmax);
            if !t.is_finite() {
                continue;
            }
            let back = Vec3A::from(s.normals[i]).dot(d) > 0.0;
            let shift = match (tie != 0.0 && back, sheet[i]) {
                (false, _) => 0.0,
                (true, true) => tie,
                (true, false) => -tie,
            };
            let ts = t + shift;
            if ts < tmax && best.is_none_or(|b| ts < b.0) {
                best = Some((ts, i as u32, shift));
            }
        }
        best.map(|(ts, i, shift)| Hit {
            t: ts - shift,
            triangle: i,
            backface: Vec3A::from(s.normals[i as usize]).dot(d) > 0.0,
        })
    }

    fn occluded(s: &Scene, a: Vec3, b: Vec3, eps: f32) -> bool {
        let (d, len) = (Vec3A::from(b - a), (b - a).length());
        if len <= 2.0 * eps {
            return false;
        }
        let ray = WatertightRay::new(a.into(), positive_zeros(d / len));
        s.triangles.iter().any(|t| {
            ray.intersect(&WatertightTriangle::new(t.map(Vec3A::from)), eps, len - eps) < len - eps
        })
    }

    #[test]
    fn answers_are_those_of_every_triangle_tried() {
        // A soup, and two grids of quads whose shared edges and vertices
        // give ties, one axis-aligned; every triangle also reversed once
        // in ten (two-sided sheets), and a coplanar copy (pressed solids).
        let mut tris: Vec<[Vec3; 3]> = Vec::new();
        for i in 0..300u64 {
            let h = hash2(41, i);
            let c = cube_point(h);
            tris.push([0, 1, 2].map(|k| c + cube_point(hash2(h, k)) * 0.3));
        }
        for (corner, u, v) in [
            (Vec3::new(-1.0, -0.5, -1.0), Vec3::X * 2.0, Vec3::Z * 2.0),
            (
                Vec3::new(-0.8, -1.0, 0.3),
                Vec3::new(1.5, 1.7, 0.2),
                Vec3::Z,
            ),
        ] {
            for j in 0..8 {
                for i in 0..8 {
                    let at =
                        |i: usize, j: usize| corner + u * (i as f32 / 8.0) + v * (j as f32 / 8.0);
                    let (a, b, c, d) = (at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
                    tris.push([a, b, c]);
                    tris.push([a, c, d]);
                }
            }
        }
        let n = tris.len();
        for i in (0..n).step_by(10) {
            let t = tris[i];
            tris.push([t[0], t[2], t[1]]);
        }
        for i in (5..n).step_by(10) {
            let t = tris[i];
            tris.push([t[1], t[0], (t[0] + t[1] + t[2]) / 3.0]);
        }
        let s = Scene::from_triangles(
            "t".into(),
            tris.iter().map(|&t| (t, 0)),
            vec![Material::fallback()],
        )
        .unwrap();
        assert_eq!(s.triangles.len(), tris.len());
        let bvh = SceneBvh::new(&s);
        let vertices: Vec<Vec3> = tris.iter().flatten().copied().collect();
        let (mut hits, mut blocked) = (0, 0);
        for i in 0..3000u64 {
            let h = hash2(42, i);
            let o = cube_point(hash2(h, 1)) * 1.5;
            // Random, exactly axis-aligned, and through vertices and edge
            // midpoints (seams).
            let q = vertices[(hash2(h, 2) % vertices.len() as u64) as usize];
            let r = vertices[(hash2(h, 3) % vertices.len() as u64) as usize];
            let axis = [Vec3::X, Vec3::Y, Vec3::Z, -Vec3::X, -Vec3::Y, -Vec3::Z][i as usize % 6];
            let end = match i % 4 {
                0 => o + cube_point(hash2(h, 4)) * 3.0,
                1 => o + axis * 2.5,
                2 => q + (q - o),
                _ => (q + r) * 0.5 + ((q + r) * 0.5 - o),
            };
            let dir = (end - o).normalize();
            let tie = if i % 2 == 0 { 0.0 } else { 1e-3 };
            let tmax = if i % 3 == 0 { 1.0 } else { f32::INFINITY };
            let got = bvh.closest_hit_prefer_back(o, dir, 0.0, tmax, tie);
            let want = closest(&s, o, dir, tmax, tie);
            assert_eq!(
                got.map(|h| h.t.to_bits()),
                want.map(|h| h.t.to_bits()),
                "ray {i}"
            );
            assert_eq!(got, want, "ray {i}");
            hits += got.is_some() as u32;
            let eps = 1e-4 * unit_f32(hash2(h, 5));
            let b = bvh.occluded(o, end, eps);
            assert_eq!(b, occluded(&s, o, end, eps), "segment {i}");
            blocked += b as u32;
        }
        assert!(
            hits > 1000 && blocked > 1000,
            "{hits} hits, {blocked} blocked"
        );
    }

    /// A unit quad on z = 0 whose alpha texture is opaque on its right
    /// half (x > ½) and clear on its left, MASK at 0.5, over a floor at
    /// z = −1; with `cut: false` the same quad opaque.
    fn half_masked_quad(cut: bool) -> Scene {
        use super::super::texture::{Texture, TextureMap, Wrap};
        use super::super::Cutout;
        use glam::Vec2;
        // 2 × 1 texels: the filter's ramp between their centres crosses
        // 0.5 at x = ½ exactly.
        let alpha = Texture::from_srgb8("a".into(), 2, 1, vec![[255; 3]; 2]).with_alpha(vec![0, 255]);
        let mut m = Material::fallback();
        m.cutout = cut.then_some(Cutout {
            factor: 1.0,
            map: Some(TextureMap {
                wrap: [Wrap::Clamp; 2],
                ..TextureMap::new(0)
            }),
            grey: false,
            cutoff: 0.5,
        });
        let (a, b, c, d) = (Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y);
        let uv = |p: Vec3| Vec2::new(p.x, p.y);
        let f = |z: f32| [Vec3::new(-5.0, -5.0, z), Vec3::new(5.0, -5.0, z), Vec3::new(0.0, 5.0, z)];
        Scene::from_textured_triangles(
            "quad".into(),
            [
                ([a, b, c], 0, [a, b, c].map(uv)),
                ([a, c, d], 0, [a, c, d].map(uv)),
                (f(-1.0), 1, [Vec2::ZERO; 3]),
            ],
            vec![m, Material::fallback()],
            vec![std::sync::Arc::new(alpha)],
        )
        .unwrap()
    }

    #[test]
    fn a_half_masked_quad_passes_half_the_rays_in_every_test() {
        let s = half_masked_quad(true);
        let bvh = SceneBvh::new(&s);
        let n = 10_000u64;
        let (mut passed, mut right_passed) = (0u64, 0u64);
        let mut near_a = Blocker::default();
        let mut near_b = Blocker::default();
        for i in 0..n {
            let h = hash2(0xA1FA, i);
            // From a point above to a point on the quad's plane below it
            // and on: the crossing is uniform over the quad.
            let o = Vec3::new(0.5, 0.5, 1.0) + (cube_point(hash2(h, 1)) * Vec3::new(0.5, 0.5, 0.2));
            let x = Vec3::new(unit_f32(hash2(h, 2)), unit_f32(hash2(h, 3)), 0.0);
            let dir = (x - o).normalize();
            let hit = bvh.closest_hit(o, dir, 0.0, f32::INFINITY).unwrap();
            let through = hit.triangle == 2;
            passed += through as u64;
            right_passed += (through && x.x > 0.5) as u64;
            // The segment to just above the floor, by each occlusion test
            // (the memories shared along the way, as coverage shares them).
            let end = o + dir * ((o.z + 0.99) / -dir.z);
            assert_eq!(bvh.occluded(o, end, 1e-4), !through, "ray {i}");
            assert_eq!(bvh.occluded_from(o, end, 1e-4, &mut near_a), !through, "ray {i}");
            assert_eq!(
                bvh.occluded_between::<true>(o, end, 1e-4, &mut near_a, &mut near_b),
                !through,
                "ray {i}"
            );
        }
        let fraction = passed as f64 / n as f64;
        assert!((fraction - 0.5).abs() < 0.02 * 0.5, "{fraction} of the rays passed");
        assert_eq!(right_passed, 0, "the opaque half stops every ray");
        // Opaque, the quad stops them all.
        let opaque = SceneBvh::new(&half_masked_quad(false));
        let o = Vec3::new(0.25, 0.5, 1.0);
        assert_eq!(opaque.closest_hit(o, -Vec3::Z, 0.0, f32::INFINITY).unwrap().triangle, 1);
        assert_eq!(bvh.closest_hit(o, -Vec3::Z, 0.0, f32::INFINITY).unwrap().triangle, 2);
    }
}
