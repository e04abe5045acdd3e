//! Leaf payloads (Wang et al. 2019 §4.1): the probes a leaf lists, best first.
//!
//! For a leaf, the candidates are the probes whose influence region overlaps
//! it. Each candidate is scored by the paper's projected solid-angle-weighted
//! visibility (Ω̄_k / d̄_k)·V, evaluated for the leaf as the query:
//!
//! - **V** is the share of the leaf's sample points from which a shadow ray
//!   to the probe is unblocked (the paper's culling of "probes that are not
//!   visible from current voxel" made fractional). A leaf that no surface
//!   crosses (its SDF clearance exceeds its half diagonal) is sampled at its
//!   centre; a leaf a surface crosses is sampled at those of its centre and
//!   eight octant centres that lie in free space ([`is_free`]), or, when
//!   none does, at points near its eight corners, because its centre may be
//!   inside a wall while shading points on that
//!   wall still query it.
//! - **d̄** is the distance from the probe to the leaf centre (at least half
//!   a leaf): the leaf is the query point the paper's per-texel d stands for.
//! - **Ω̄_k** is the probe's mean projected solid angle term from its
//!   influence rays ([`super::influence`]): a free-space leaf has no surface
//!   normal of its own, so the probe's view quality stands in.
//!
//! Candidates are visited in decreasing order of the bound Ω̄_k/d̄ (V ≤ 1),
//! so the search stops as soon as no remaining candidate can enter the
//! list. A leaf with no visible candidate falls back to the nearest probe,
//! of its [`FALLBACK_SEARCH`] nearest, that sees any of its sample points,
//! followed by those of the next 16 nearest probes that see it, by score
//! (so that it still shares probes with its neighbours and collapses with
//! them); a leaf none of those probes sees lists the nearest probe and is
//! counted.

use super::influence::Influence;
use crate::scene::raycast::{Blocker, SceneBvh};
use crate::sdf::{Sdf, VoxelClass};
use glam::{UVec3, Vec3};

/// Entries a leaf keeps while the octree is built: twice the default payload,
/// so that collapsing neighbours (which keeps the probes they share) still
/// has enough to fill a payload.
pub const KEEP: usize = 8;

/// Up to [`KEEP`] probes with their relative scores, best first.
///
/// `q` is a probe's score over the best score at the leaf (1 for the
/// first); after collapsing, the smallest such ratio over the leaves merged.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ranked {
    len: u8,
    probes: [u32; KEEP],
    q: [f32; KEEP],
}

impl Ranked {
    /// A list of one probe.
    pub fn single(probe: u32) -> Ranked {
        let mut r = Ranked::empty();
        r.push(probe, 1.0);
        r
    }

    /// The empty list.
    pub fn empty() -> Ranked {
        Ranked {
            len: 0,
            probes: [0; KEEP],
            q: [0.0; KEEP],
        }
    }

    /// Probe indices, best first.
    pub fn probes(&self) -> &[u32] {
        &self.probes[..self.len as usize]
    }

    /// Relative scores, in the order of [`Ranked::probes`].
    pub fn quality(&self) -> &[f32] {
        &self.q[..self.len as usize]
    }

    /// Number of entries.
    pub fn len(&self) -> usize {
        self.len as usize
    }

    /// Whether the list is empty.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// A list of `(probe, q)` items as given (tests build lists by hand).
    #[cfg(test)]
    pub(crate) fn from_items(items: &[(u32, f32)]) -> Ranked {
        let mut r = Ranked::single(items[0].0);
        r.q[0] = items[0].1;
        for &(p, q) in &items[1..] {
            r.push(p, q);
        }
        r
    }

    fn push(&mut self, probe: u32, q: f32) {
        let i = self.len as usize;
        self.probes[i] = probe;
        self.q[i] = q;
        self.len += 1;
    }

    /// The probes both lists hold, each with the smaller of its two relative
    /// scores, best first (ties by index, so the order is reproducible).
    pub fn intersect(&self, other: &Ranked) -> Ranked {
        let mut out = Ranked::empty();
        for (&p, &q) in self.probes().iter().zip(self.quality()) {
            if let Some(j) = other.probes().iter().position(|&o| o == p) {
                out.push(p, q.min(other.q[j]));
            }
        }
        out.sort();
        out
    }

    fn sort(&mut self) {
        let n = self.len as usize;
        let mut items: [(u32, f32); KEEP] = [(0, 0.0); KEEP];
        for (i, item) in items.iter_mut().enumerate().take(n) {
            *item = (self.probes[i], self.q[i]);
        }
        items[..n].sort_by(|a, b| b.1.total_cmp(&a.1).then(a.0.cmp(&b.0)));
        for (i, item) in items.iter().enumerate().take(n) {
            self.probes[i] = item.0;
            self.q[i] = item.1;
        }
    }
}

/// Whether `p` lies in the scene's free space, to within a hair of the
/// surfaces: its
/// voxel is free and the SDF proves `p` on the same side (Lipschitz
/// bound), or an unblocked segment joins `p` to the centre of one of
/// the three nearest free voxels around it. An SDF
/// interpolation cannot decide this near edges and thin walls; the
/// segment test is exact. A segment shorter than its centre's distance to
/// every surface (exact within the SDF's band, [`Sdf::exact_reach`]) is
/// unblocked without casting it.
pub fn is_free(sdf: &Sdf, bvh: &SceneBvh, p: Vec3) -> bool {
    is_free_from(sdf, bvh, p, &mut FreeMemory::default())
}

/// What [`is_free_from`] keeps between the points of a family near each
/// other: the triangles that last hid them from the free voxels
/// beside them ([`SceneBvh::occluded_from`]), and the last voxel's
/// [`free_neighbours`] (a leaf's sample points usually share a voxel).
#[derive(Debug, Default)]
struct FreeMemory {
    blocker: Blocker,
    /// A voxel index and its free neighbours.
    voxel: Option<(usize, FreeNeighbours)>,
}

/// Voxels [`is_free`] may join a point to ([`free_neighbours`]): the
/// first `n` indices, and their centres.
#[derive(Debug, Clone, Copy)]
struct FreeNeighbours {
    index: [usize; 27],
    centre: [Vec3; 27],
    n: usize,
}

/// [`is_free`] for one of many points near each other, with their
/// `memory` ([`FreeMemory`]): the same answer, found faster when a few
/// walls hide them all from the free voxels beside them, and when they
/// share a voxel.
fn is_free_from(sdf: &Sdf, bvh: &SceneBvh, p: Vec3, memory: &mut FreeMemory) -> bool {
    let u = sdf.nearest_voxel(p);
    let i = sdf.index(u);
    match sdf.class[i] {
        VoxelClass::Outside => return false,
        VoxelClass::Free if sdf.distance[i] > p.distance(sdf.center_of(u)) => return true,
        _ => {}
    }
    // The nearest eligible centres, nearest first (ties: the lower index).
    let mut near = [(f32::INFINITY, usize::MAX, Vec3::ZERO); FREE_NEIGHBOURS_TRIED];
    let neighbours = match &memory.voxel {
        Some((known, neighbours)) if *known == i => neighbours,
        _ => {
            &memory
                .voxel
                .insert((i, free_neighbours(sdf, u.as_ivec3())))
                .1
        }
    };
    for (&j, &c) in neighbours
        .index
        .iter()
        .zip(&neighbours.centre)
        .take(neighbours.n)
    {
        let mut item = (p.distance_squared(c), j, c);
        for slot in near.iter_mut() {
            if item.0 < slot.0 || (item.0 == slot.0 && item.1 < slot.1) {
                std::mem::swap(slot, &mut item);
            }
        }
    }
    // Short of the shadow rays' tolerance: a point a hair behind a wall
    // must not pass for free.
    let eps = 1e-5 * sdf.voxel_size;
    // A segment no longer than the centre's (exact) distance to every
    // surface cannot be blocked: the ray would say so too, so it is not
    // cast. The slack covers the rounding of distances and of the ray test.
    let exact = sdf.exact_reach();
    let slack = 1e-3 * sdf.voxel_size + 1e-5 * p.abs().max_element();
    // Exactly the centres: a segment between points of the grid may run
    // along the diagonal seam of an axis-aligned quad, which the watertight
    // ray/triangle test does not let it slip through.
    near.iter()
        .take_while(|&&(_, j, _)| j != usize::MAX)
        .any(|&(d2, j, c)| {
            sdf.distance[j].min(exact) > d2.sqrt() + slack
                || !bvh.occluded_from(p, c, eps, &mut memory.blocker)
        })
}

/// The voxels of the 3×3×3 block around `v` (within the grid; the
/// first `n` of the array returned) whose
/// centres [`is_free`] may join a point to: free, and clear of the
/// surfaces by [`FREE_NEIGHBOUR_CLEARANCE`] voxels, since a centre lying
/// on a surface would join the point to the wrong side.
fn free_neighbours(sdf: &Sdf, v: glam::IVec3) -> FreeNeighbours {
    let margin = FREE_NEIGHBOUR_CLEARANCE * sdf.voxel_size;
    let mut out = FreeNeighbours {
        index: [0; 27],
        centre: [Vec3::ZERO; 27],
        n: 0,
    };
    for dz in -1..=1 {
        for dy in -1..=1 {
            for dx in -1..=1 {
                let w = v + glam::IVec3::new(dx, dy, dz);
                if w.cmplt(glam::IVec3::ZERO).any() || w.cmpge(sdf.dims.as_ivec3()).any() {
                    continue;
                }
                let j = sdf.index(w.as_uvec3());
                if sdf.class[j] == VoxelClass::Free && sdf.distance[j] > margin {
                    out.index[out.n] = j;
                    out.centre[out.n] = sdf.center_of(w.as_uvec3());
                    out.n += 1;
                }
            }
        }
    }
    out
}

/// How a leaf got its list.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ListOrigin {
    /// From the probes whose influence region holds it.
    Influence,
    /// No such probe sees it: the nearest probe that does.
    Fallback,
    /// No probe sees it: the nearest probe.
    Blind,
}

/// Free voxels around a point near a surface that [`is_free`]
/// tries to reach.
const FREE_NEIGHBOURS_TRIED: usize = 3;

/// Least clearance, in voxels, of a free voxel centre that
/// [`is_free`] joins a point to.
const FREE_NEIGHBOUR_CLEARANCE: f32 = 0.1;

/// Probes, beyond the nearest one that sees it, that a fallback leaf ranks
/// for the rest of its list.
const FALLBACK_RUNNERS_UP: usize = 2 * KEEP;

/// Probes, nearest first, a leaf that none of its candidates sees searches
/// for one that does ([`ListOrigin::Fallback`]) before it is called
/// [`ListOrigin::Blind`]. A leaf in a sealed void (a cave in a voxel
/// world, the inside of a hollow column) is seen by no probe at all, and
/// proving so over every probe made the octree's cost grow as leaves ×
/// probes: on a generated 200k-triangle voxel world two leaves in three
/// were blind, and their rays half the octree's time.
const FALLBACK_SEARCH: usize = 64;

/// Candidates a leaf orders by bound before it visits them
/// ([`LeafRanker::best_visible`]); more only when the visit gets past them.
const VISIT_PREFIX: usize = 32;

/// Reusable buffers of one worker.
#[derive(Debug, Default)]
pub struct Scratch {
    samples: Vec<Vec3>,
    candidates: Vec<(f32, u32)>,
    best: Vec<(f32, u32)>,
    /// Per probe, the triangles that last hid it from a sample of this
    /// worker's leaves ([`LeafRanker::visible_within`]).
    blockers: Vec<Blocker>,
    /// The free-space tests' memory ([`is_free_from`]).
    free_memory: FreeMemory,
}

/// Ranks the probes of any leaf of the grid.
pub struct LeafRanker<'a> {
    /// The scene's BVH, for shadow rays.
    pub bvh: &'a SceneBvh,
    /// The SDF, for which leaves hold free space and where.
    pub sdf: &'a Sdf,
    /// Every probe's influence.
    pub influence: &'a [Influence],
    /// Lower corner of leaf (0, 0, 0).
    pub origin: Vec3,
    /// Leaf edge.
    pub leaf_size: f32,
}

impl LeafRanker<'_> {
    /// The sample points of the leaf at `cell` into `out`; empty when the
    /// leaf holds no free space worth storing (solid or outside the scene).
    /// `memory` serves the free-space tests of the worker's leaves.
    fn samples(&self, cell: UVec3, out: &mut Vec<Vec3>, memory: &mut FreeMemory) {
        out.clear();
        let c = self.origin + (cell.as_vec3() + 0.5) * self.leaf_size;
        let sdf = self.sdf;
        if let Some(class) = sdf.clear_cube_class(c, self.leaf_size) {
            if class == VoxelClass::Free {
                out.push(c);
            }
            return;
        }
        if is_free_from(sdf, self.bvh, c, memory) {
            out.push(c);
        }
        // The octant centres, then, if none of them is free either, points
        // near the corners: a thin free slice along a wall is still stored.
        for reach in [0.5, 0.9] {
            for corner in 0..8u32 {
                let o = Vec3::new(
                    (corner & 1) as f32 - 0.5,
                    ((corner >> 1) & 1) as f32 - 0.5,
                    (corner >> 2) as f32 - 0.5,
                );
                let p = c + reach * o * self.leaf_size;
                if is_free_from(sdf, self.bvh, p, memory) {
                    out.push(p);
                }
            }
            if !out.is_empty() {
                return;
            }
        }
    }

    /// How many of `samples` see `probe`, or 0 as soon as more than
    /// `may_miss` of them do not.
    ///
    /// A worker visits leaves in octree order, next to each other, so a
    /// wall that hides the probe from one sample usually hides it from the
    /// next, in this leaf or the last: each segment first tries the
    /// triangles that last hid this probe (`blocker`, [`Blocker`]), which
    /// never changes an answer, only skips a traversal.
    fn visible_within(
        &self,
        samples: &[Vec3],
        probe: Vec3,
        may_miss: usize,
        blocker: &mut Blocker,
    ) -> usize {
        let eps = 1e-3 * self.sdf.voxel_size;
        let mut missed = 0;
        for &s in samples {
            if self.bvh.occluded_from(s, probe, eps, blocker) {
                missed += 1;
                if missed > may_miss {
                    return 0;
                }
            }
        }
        samples.len() - missed
    }

    /// The ranked list of the leaf at `cell` among `candidates` (probe
    /// indices; those whose influence misses the leaf are skipped), or
    /// `None` when the leaf holds no free space.
    ///
    /// Contract: the list is non-empty, best first, at most [`KEEP`] long;
    /// with [`ListOrigin::Influence`] every listed probe sees at least one
    /// sample point of the leaf and is a candidate whose influence overlaps it.
    pub fn rank(
        &self,
        cell: UVec3,
        candidates: &[u32],
        scratch: &mut Scratch,
    ) -> Option<(Ranked, ListOrigin)> {
        let Scratch {
            samples,
            candidates: bounded,
            best,
            blockers,
            free_memory,
        } = scratch;
        blockers.resize(self.influence.len(), Blocker::default());
        self.samples(cell, samples, free_memory);
        if samples.is_empty() {
            return None;
        }
        let lo = self.origin + cell.as_vec3() * self.leaf_size;
        let hi = lo + self.leaf_size;
        let centre = lo + 0.5 * self.leaf_size;
        bounded.clear();
        bounded.extend(
            candidates
                .iter()
                .filter(|&&k| self.influence[k as usize].overlaps(lo, hi))
                .map(|&k| (self.bound(k, centre), k)),
        );
        self.best_visible(samples, bounded, best, blockers);
        if !best.is_empty() {
            return Some((ranked(best, None), ListOrigin::Influence));
        }
        // Fallback over the nearest probes: the nearest that sees the leaf
        // first, then the others that see it, by score, so that the leaf
        // still shares probes with its neighbours.
        bounded.clear();
        bounded.extend(
            self.influence
                .iter()
                .enumerate()
                .map(|(k, inf)| (inf.position.distance_squared(centre), k as u32)),
        );
        let order = |a: &(f32, u32), b: &(f32, u32)| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1));
        let kept = FALLBACK_SEARCH + FALLBACK_RUNNERS_UP;
        if bounded.len() > kept {
            bounded.select_nth_unstable_by(kept, order);
            bounded.truncate(kept);
        }
        bounded.sort_unstable_by(order);
        let nearest = bounded.first()?.1;
        let n = samples.len() as f32;
        // Short-circuits only when every sample misses, so a probe that is
        // seen gets its exact count in the same pass.
        let searched = bounded.len().min(FALLBACK_SEARCH);
        let Some((at, seen)) = bounded[..searched]
            .iter()
            .enumerate()
            .find_map(|(i, &(_, k))| {
                let probe = self.influence[k as usize].position;
                let seen = self.visible_within(
                    samples,
                    probe,
                    samples.len() - 1,
                    &mut blockers[k as usize],
                );
                (seen > 0).then_some((i, seen))
            })
        else {
            return Some((Ranked::single(nearest), ListOrigin::Blind));
        };
        let first = bounded[at].1;
        let first_score = self.bound(first, centre) * seen as f32 / n;
        // The runners-up come from the probes nearest after it.
        let rest = (at + 1)..(at + 1 + FALLBACK_RUNNERS_UP).min(bounded.len());
        for i in rest.clone() {
            bounded[i].0 = self.bound(bounded[i].1, centre);
        }
        self.best_visible(samples, &mut bounded[rest], best, blockers);
        Some((
            ranked(best, Some((first_score, first))),
            ListOrigin::Fallback,
        ))
    }

    /// Ω̄_k / d̄ for probe `k` and the leaf centred at `centre`: the score
    /// of a probe that sees the whole leaf, and a bound on any other's.
    fn bound(&self, k: u32, centre: Vec3) -> f32 {
        let inf = &self.influence[k as usize];
        inf.omega_bar / inf.position.distance(centre).max(0.5 * self.leaf_size)
    }

    /// The best [`KEEP`] of the `(bound, probe)` pairs in `bounded` by score
    /// (bound × share of `samples` that see the probe) into `best`, best
    /// first; probes no sample sees are left out. Visits the pairs by
    /// decreasing bound and stops when none left can enter the list.
    fn best_visible(
        &self,
        samples: &[Vec3],
        bounded: &mut [(f32, u32)],
        best: &mut Vec<(f32, u32)>,
        blockers: &mut [Blocker],
    ) {
        // (bound descending, index ascending) is a total order, and the
        // walk below usually stops within the first few pairs: only the
        // first VISIT_PREFIX are ordered (a linear selection, then a sort of
        // those), the rest only if the walk reaches them. The visited
        // sequence is the fully sorted one's either way.
        let order = |a: &(f32, u32), b: &(f32, u32)| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1));
        let mut sorted = bounded.len().min(VISIT_PREFIX);
        if sorted < bounded.len() {
            bounded.select_nth_unstable_by(sorted, order);
        }
        bounded[..sorted].sort_unstable_by(order);
        best.clear();
        let n = samples.len() as f32;
        for i in 0..bounded.len() {
            if i == sorted {
                bounded[sorted..].sort_unstable_by(order);
                sorted = bounded.len();
            }
            let (bound, k) = bounded[i];
            if best.len() == KEEP && bound <= best[KEEP - 1].0 {
                break;
            }
            // Samples this probe may miss and still enter the list.
            let may_miss = if best.len() == KEEP {
                ((1.0 - best[KEEP - 1].0 / bound) * n).ceil() as usize - 1
            } else {
                samples.len() - 1
            };
            let probe = self.influence[k as usize].position;
            let seen = self.visible_within(samples, probe, may_miss, &mut blockers[k as usize]);
            if seen == 0 {
                continue;
            }
            let score = bound * seen as f32 / n;
            let at = best
                .iter()
                .position(|&(s, j)| score > s || (score == s && k < j))
                .unwrap_or(best.len());
            if at < KEEP {
                best.insert(at, (score, k));
                best.truncate(KEEP);
            }
        }
    }
}

/// The list of `best` (scores and probes, best first), after `first` when
/// given; each probe's relative score is its score over the best score.
fn ranked(best: &[(f32, u32)], first: Option<(f32, u32)>) -> Ranked {
    let top = best
        .iter()
        .chain(first.iter())
        .map(|e| e.0)
        .fold(f32::MIN_POSITIVE, f32::max);
    let mut r = Ranked::empty();
    for &(score, k) in first.iter().chain(best.iter()).take(KEEP) {
        r.push(k, score / top);
    }
    r
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ranked(items: &[(u32, f32)]) -> Ranked {
        Ranked::from_items(items)
    }

    #[test]
    fn intersection_keeps_shared_probes_with_the_worse_score() {
        let a = ranked(&[(3, 1.0), (1, 0.8), (7, 0.5), (2, 0.4)]);
        let b = ranked(&[(1, 1.0), (3, 0.6), (2, 0.5)]);
        let r = a.intersect(&b);
        assert_eq!(r.probes(), &[1, 3, 2]);
        assert_eq!(r.quality(), &[0.8, 0.6, 0.4]);
        // Commutative up to order of ties.
        assert_eq!(b.intersect(&a), r);
        let none = a.intersect(&Ranked::single(9));
        assert!(none.is_empty());
    }

    #[test]
    fn a_point_behind_a_quads_seam_is_not_free() {
        // The box of the test room spans [1, 2] × [0, 1] × [1, 2]; its −x
        // face is a quad split along the diagonal from (1, 0, 1) to
        // (1, 1, 2), in the plane z − y = 1, which holds a row of voxel
        // centres (0.1 m voxels from 0). From a point a hair inside the
        // box on that plane, the segments to those of its nearest free
        // centres that lie on the plane too cross the face exactly on the
        // seam (along −x, where y is a centre's).
        let (_, bvh, sdf) = crate::scene::testing::room_sdf(0.1, 1);
        let mut n = 0;
        for k in 1..40 {
            let y = k as f32 * 0.025;
            for (x, free) in [(1.0 + 1e-3, false), (1.0 + 1e-2, false), (1.0 - 1e-2, true)] {
                let p = Vec3::new(x, y, 1.0 + y);
                assert_eq!(is_free(&sdf, &bvh, p), free, "{p}");
                n += 1;
            }
        }
        assert_eq!(n, 39 * 3);
    }

    /// [`is_free`] as it was before it skipped any segment: the three
    /// nearest eligible free centres by a full sort, each tried by a ray.
    /// Also says whether the distance test would settle one of those
    /// segments (so that a test knows it ran).
    fn is_free_by_rays(sdf: &Sdf, bvh: &SceneBvh, p: Vec3) -> (bool, bool) {
        let v = sdf.nearest_voxel(p).as_ivec3();
        let i = sdf.index(v.as_uvec3());
        match sdf.class[i] {
            VoxelClass::Outside => return (false, false),
            VoxelClass::Free if sdf.distance[i] > p.distance(sdf.center(i)) => {
                return (true, false)
            }
            _ => {}
        }
        let neighbours = free_neighbours(sdf, v);
        let mut near: Vec<(f32, usize)> = neighbours.index[..neighbours.n]
            .iter()
            .map(|&j| (p.distance_squared(sdf.center(j)), j))
            .collect();
        near.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        near.truncate(FREE_NEIGHBOURS_TRIED);
        let eps = 1e-5 * sdf.voxel_size;
        let free = near
            .iter()
            .any(|&(_, j)| !bvh.occluded(p, sdf.center(j), eps));
        let proven = near.iter().any(|&(d2, j)| {
            sdf.distance[j].min(sdf.exact_reach()) > d2.sqrt() + 1e-3 * sdf.voxel_size
        });
        (free, proven)
    }

    #[test]
    fn free_space_proven_by_distances_is_what_the_rays_say() {
        // Points near the room's and the box's surfaces, on both sides, in
        // grids aligned with the walls and not: where `is_free` takes a
        // centre's surface distance for its segment, the segment is
        // unblocked, so the answer is the rays' own.
        for (voxel, seed) in [(0.1, 1), (0.07, 2)] {
            let (_, bvh, sdf) = crate::scene::testing::room_sdf(voxel, seed);
            let (mut free, mut proven, mut tried) = (0, 0, 0);
            for i in 0..sdf.len() {
                if sdf.distance[i].abs() > 1.5 * voxel {
                    continue;
                }
                for k in 0..4u64 {
                    let h = crate::sampling::hash2(seed, (i as u64) << 2 | k);
                    let p = sdf.center(i) + crate::sampling::cube_point(h) * (0.5 * voxel);
                    let (want, settled) = is_free_by_rays(&sdf, &bvh, p);
                    assert_eq!(is_free(&sdf, &bvh, p), want, "{p} at {voxel}");
                    free += want as usize;
                    proven += settled as usize;
                    tried += 1;
                }
            }
            assert!(free > tried / 4 && free < tried, "{free} of {tried} free");
            assert!(
                proven > tried / 20,
                "{proven} of {tried} settled by distance"
            );
        }
    }

    #[test]
    fn one_memory_over_many_points_gives_each_its_own_answer() {
        // Points near the surfaces taken two or three to a voxel, then
        // again in another order, all through one memory (its voxel's
        // neighbours and its blockers carried from point to point): each
        // answer is the rays' own.
        let voxel = 0.1;
        let (_, bvh, sdf) = crate::scene::testing::room_sdf(voxel, 3);
        let near: Vec<usize> = (0..sdf.len())
            .filter(|&i| sdf.distance[i].abs() < voxel)
            .collect();
        let sdf_ref = &sdf;
        let points: Vec<Vec3> = near
            .iter()
            .flat_map(|&i| {
                (0..3u64).map(move |k| {
                    let h = crate::sampling::hash2(5, (i as u64) << 2 | k);
                    sdf_ref.center(i) + crate::sampling::cube_point(h) * (0.5 * voxel)
                })
            })
            .collect();
        let mut memory = FreeMemory::default();
        let (mut free, mut kept) = (0, 0);
        for (n, &p) in points
            .iter()
            .chain(points.iter().rev().step_by(2))
            .enumerate()
        {
            let before = memory.voxel.as_ref().map(|v| v.0);
            let want = is_free_by_rays(&sdf, &bvh, p).0;
            assert_eq!(
                is_free_from(&sdf, &bvh, p, &mut memory),
                want,
                "point {n}: {p}"
            );
            free += want as usize;
            kept += (before.is_some() && memory.voxel.as_ref().map(|v| v.0) == before) as usize;
        }
        let total = points.len() + points.len().div_ceil(2);
        assert!(free > total / 8 && free < total, "{free} of {total} free");
        assert!(
            kept > total / 4,
            "a voxel's neighbours reused {kept} times of {total}"
        );
    }

    /// A leaf none of whose candidates sees it lists the nearest probe
    /// that does among its [`FALLBACK_SEARCH`] nearest, and is blind when
    /// none of those does, however many probes farther off see it. The
    /// leaf stands by the room's box; the nearest probes stand inside the
    /// box (sealed), one more in the open room sees the leaf.
    #[test]
    fn a_fallback_searches_the_nearest_probes_only() {
        let (scene, bvh, sdf) = crate::scene::testing::room_sdf(0.25, 1);
        let origin = scene.bounds.min;
        let cell = UVec3::new(10, 2, 6);
        let centre = origin + (cell.as_vec3() + 0.5) * 0.25;
        assert!(centre.x > 2.1 && centre.y < 1.0, "{centre}");
        let influence_at = |p: Vec3| Influence {
            position: p,
            region: crate::scene::Bounds { min: p, max: p },
            face_distance: [0.0; 6],
            omega_bar: 1.0,
        };
        let sealed = |n: usize| -> Vec<Influence> {
            (0..n)
                .map(|k| {
                    let u = Vec3::new((k % 5) as f32, ((k / 5) % 5) as f32, (k / 25) as f32);
                    influence_at(Vec3::new(1.1, 0.1, 1.1) + u * 0.2)
                })
                .collect()
        };
        let open = Vec3::new(3.5, 3.5, 3.5);
        for (hidden, origin_of) in [
            (FALLBACK_SEARCH - 1, ListOrigin::Fallback),
            (FALLBACK_SEARCH, ListOrigin::Blind),
        ] {
            let mut influence = sealed(hidden);
            assert!(influence
                .iter()
                .all(|i| i.position.distance(centre) < open.distance(centre)));
            influence.push(influence_at(open));
            let ranker = LeafRanker {
                bvh: &bvh,
                sdf: &sdf,
                influence: &influence,
                origin,
                leaf_size: 0.25,
            };
            let (list, how) = ranker.rank(cell, &[], &mut Scratch::default()).unwrap();
            assert_eq!(how, origin_of, "{hidden} sealed probes");
            match how {
                ListOrigin::Fallback => assert_eq!(list.probes()[0], hidden as u32),
                _ => assert!((list.probes()[0] as usize) < hidden),
            }
        }
    }

    #[test]
    fn ties_order_by_index() {
        let a = ranked(&[(5, 1.0), (2, 1.0)]);
        let r = a.intersect(&a);
        assert_eq!(r.probes(), &[2, 5]);
    }
}
