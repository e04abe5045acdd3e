//! The sparse voxel octree of probe indices (Wang et al. 2019 §4.1, §5):
//! for any point in space, the few probes worth asking, best first.
//!
//! A renderer with non-uniform probes cannot find a point's probes by
//! rounding its coordinates as it would on a grid. The paper bakes, into the
//! leaves of an SVO, up to four probe indices per voxel: the probes whose
//! region of influence holds the voxel ([`influence`]), culled by visibility
//! and sorted by projected solid-angle-weighted visibility ([`rank`]). We do
//! the same, and store it far smaller than the paper's dense RGBA8 texture
//! (Table 2: 15–243 MB): solid and outside space take no nodes, and regions
//! one ranked list serves collapse into one leaf ([`octree`]). The result
//! is written as `svo.bin` ([`mod@format`], docs/formats.md) and answered by
//! [`Svo::probes_at`] in O(depth).
//!
//! Why every listed probe must see the leaf: a light-field trace that goes
//! "unknown" moves on to the next probe (McGuire et al. 2017 §4), and a
//! back-face hit re-queries the tree at the hit (Wang §4.1); probes that see
//! the query point end both quickly.

pub mod format;
pub mod influence;
pub mod octree;
pub mod rank;
mod tiles;

use crate::config::params::SvoParams;
use crate::error::{Error, Result};
use crate::probes::{PlacementInput, ProbeSet};
use crate::sampling::{hash2, unit_f32};
use crate::sdf;
use glam::{DVec3, UVec3, Vec3};
use octree::{Builder, CHILD_MASK_BITS, LEAF_BIT, PAYLOAD_OFFSET_BITS};
use rank::LeafRanker;
use serde::Serialize;
use std::path::Path;

/// Random free points the bake checks its own first choices at.
pub const CHECK_POINTS: usize = 10_000;

/// A baked octree: the contents of `svo.bin`.
///
/// Built only by [`bake`] or read by [`Svo::read`] / [`format::from_bytes`],
/// both of which guarantee the node array is well formed.
///
/// Coordinates: `origin` and the points [`Svo::probes_at`] takes are
/// relative to [`Svo::frame`]. A tree just baked is in the scene's local
/// coordinates, as every stage is ([`crate::scene`]); `svo.bin` is in world
/// coordinates, so a tree read from it has `frame` zero and takes world
/// points, as a renderer's would.
#[derive(Debug, Clone, PartialEq)]
pub struct Svo {
    /// Lower corner of leaf (0, 0, 0): the domain's lower corner, relative to `frame`.
    pub origin: Vec3,
    /// World position of the zero of `origin`'s coordinates: the scene's
    /// [`crate::scene::Scene::origin`] for a baked tree, zero for a read one.
    pub frame: DVec3,
    /// Edge of a leaf.
    pub leaf_size: f32,
    /// The root cube is 2^depth leaves along an edge.
    pub depth: u32,
    /// Leaves along x, y, z over the domain; points beyond list no probe.
    pub dims: UVec3,
    /// Number of probes the indices refer to.
    pub probe_count: u32,
    /// Most indices a leaf lists.
    pub max_probes: u32,
    /// Leaves (at leaf size) that none of their 64 nearest probes sees
    /// ([`crate::svo::rank`]); they list the nearest probe.
    pub leaves_without_visible_probe: u32,
    /// The run's provenance ([`crate::provenance`]), written in the header;
    /// zero until the job that writes the tree sets it.
    pub provenance: crate::provenance::ProvenanceBytes,
    nodes: Vec<u32>,
    payload: Vec<u32>,
}

impl Svo {
    /// The probes listed for `point` (relative to [`Svo::frame`]: world
    /// coordinates for a tree read from `svo.bin`), best first: empty outside
    /// the domain and in solid or outside-the-scene space.
    ///
    /// Contract: O(depth) word reads, no allocation; every index is below
    /// [`Svo::probe_count`] and the slice has at most [`Svo::max_probes`] entries.
    pub fn probes_at(&self, point: Vec3) -> &[u32] {
        let g = ((point - self.origin) / self.leaf_size).floor();
        if !g.is_finite() || g.cmplt(Vec3::ZERO).any() || g.cmpge(self.dims.as_vec3()).any() {
            return &[];
        }
        let c = g.as_uvec3();
        let mut level = self.depth;
        let mut word = self.nodes[0];
        loop {
            if word & LEAF_BIT != 0 {
                let count = ((word >> PAYLOAD_OFFSET_BITS) & 7) as usize + 1;
                let offset = (word & ((1 << PAYLOAD_OFFSET_BITS) - 1)) as usize;
                return self.payload.get(offset..offset + count).unwrap_or(&[]);
            }
            let mask = word & 0xFF;
            if mask == 0 || level == 0 {
                return &[];
            }
            level -= 1;
            let child =
                ((c.x >> level) & 1) | (((c.y >> level) & 1) << 1) | (((c.z >> level) & 1) << 2);
            if mask & (1 << child) == 0 {
                return &[];
            }
            let index = (word >> CHILD_MASK_BITS) + (mask & ((1 << child) - 1)).count_ones();
            match self.nodes.get(index as usize) {
                Some(&w) => word = w,
                None => return &[],
            }
        }
    }

    /// World position of the lower corner of leaf (0, 0, 0), in f64; what
    /// `svo.bin` stores, rounded to f32.
    pub fn world_origin(&self) -> DVec3 {
        self.frame + self.origin.as_dvec3()
    }

    /// The node words and the payload words, as `svo.bin` stores them
    /// (docs/formats.md): what the GPU kernels walk.
    pub fn words(&self) -> (&[u32], &[u32]) {
        (&self.nodes, &self.payload)
    }

    /// Nodes in the array (inner nodes and leaves).
    pub fn nodes(&self) -> usize {
        self.nodes.len()
    }

    /// Leaf nodes (each may stand for many leaf-size cells).
    pub fn leaves(&self) -> usize {
        self.nodes.iter().filter(|&&w| w & LEAF_BIT != 0).count()
    }

    /// Distinct probe lists, stored once each in the payload.
    pub fn distinct_lists(&self) -> usize {
        let mut offsets: Vec<u32> = self
            .nodes
            .iter()
            .filter(|&&w| w & LEAF_BIT != 0)
            .map(|&w| w & ((1 << PAYLOAD_OFFSET_BITS) - 1))
            .collect();
        offsets.sort_unstable();
        offsets.dedup();
        offsets.len()
    }

    /// Per probe, the leaf-size cells whose lists name it: what a renderer
    /// reading `svo.bin` consults the probe for, fallback cells included
    /// (a probe whose influence region, [`influence`], overlaps a cell it
    /// sees, or the nearest that sees a cell no such probe sees). The
    /// report's 3D view shows each probe's box.
    ///
    /// Contract: one entry per probe index below [`Svo::probe_count`];
    /// `cells == 0` (and an empty box) for a probe no leaf lists; boxes
    /// lie within [`Svo::dims`]; O(nodes + listed entries).
    pub fn listings(&self) -> Vec<Listing> {
        let mut out = vec![Listing::default(); self.probe_count as usize];
        // (node index, level, lower corner in leaf cells)
        let mut stack = vec![(0usize, self.depth, UVec3::ZERO)];
        while let Some((index, level, base)) = stack.pop() {
            let Some(&word) = self.nodes.get(index) else {
                continue;
            };
            if word & LEAF_BIT != 0 {
                let lo = base.min(self.dims);
                let hi = (base + UVec3::splat(1 << level)).min(self.dims);
                if lo.cmpge(hi).any() {
                    continue;
                }
                let cells = (hi - lo).as_u64vec3().element_product();
                let count = ((word >> PAYLOAD_OFFSET_BITS) & 7) as usize + 1;
                let offset = (word & ((1 << PAYLOAD_OFFSET_BITS) - 1)) as usize;
                let list = self.payload.get(offset..offset + count).unwrap_or(&[]);
                for (rank, &probe) in list.iter().enumerate() {
                    if let Some(l) = out.get_mut(probe as usize) {
                        l.add(lo, hi, cells, rank == 0);
                    }
                }
                continue;
            }
            let mask = word & 0xFF;
            if level == 0 {
                continue;
            }
            let half = 1u32 << (level - 1);
            let first = (word >> CHILD_MASK_BITS) as usize;
            for child in 0..8u32 {
                if mask & (1 << child) == 0 {
                    continue;
                }
                let at = first + (mask & ((1 << child) - 1)).count_ones() as usize;
                let offset = UVec3::new(child & 1, (child >> 1) & 1, child >> 2) * half;
                stack.push((at, level - 1, base + offset));
            }
        }
        out
    }

    /// Size of `svo.bin` in bytes.
    pub fn bytes(&self) -> u64 {
        (format::HEADER_BYTES + format::CHECKSUM_BYTES) as u64
            + 4 * (self.nodes.len() + self.payload.len()) as u64
    }

    /// What the paper's storage would take: a dense RGBA8 3D texture (four
    /// 8-bit probe indices per texel) with one texel per leaf over the domain.
    pub fn dense_bytes(&self) -> u64 {
        4 * self.dims.x as u64 * self.dims.y as u64 * self.dims.z as u64
    }

    /// Reads and checks `svo.bin` at `path`.
    ///
    /// Contract: a missing, truncated, corrupted or wrong-version file is an
    /// [`Error::User`] naming `path` and the problem; never a panic.
    pub fn read(path: &Path) -> Result<Svo> {
        let bytes = crate::input::read(path, "svo.bin", crate::limits::memory_budget())?;
        format::from_bytes(&bytes).map_err(|m| Error::user_file(path, m))
    }

    /// The bytes of `svo.bin`.
    pub fn to_bytes(&self) -> Vec<u8> {
        format::to_bytes(self)
    }
}

/// Where one probe is listed ([`Svo::listings`]), in leaf cells.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Listing {
    /// Lower corner of the bounding box of the cells listing the probe.
    pub lo: UVec3,
    /// Upper corner (exclusive): the box is `lo..hi` in leaf cells, i.e.
    /// `origin + lo · leaf_size .. origin + hi · leaf_size`.
    pub hi: UVec3,
    /// Leaf-size cells whose list names the probe.
    pub cells: u64,
    /// Of those, cells whose list names it first.
    pub first: u64,
}

impl Listing {
    /// Counts the `cells` cells `lo..hi` of one leaf in.
    fn add(&mut self, lo: UVec3, hi: UVec3, cells: u64, first: bool) {
        if self.cells == 0 {
            (self.lo, self.hi) = (lo, hi);
        } else {
            (self.lo, self.hi) = (self.lo.min(lo), self.hi.max(hi));
        }
        self.cells += cells;
        self.first += u64::from(first) * cells;
    }
}

/// The `svo` section of `report.json`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SvoReport {
    /// Nodes in `svo.bin` (inner nodes and leaves).
    pub nodes: usize,
    /// Leaf nodes.
    pub leaves: usize,
    /// Levels below the root.
    pub depth: u32,
    /// Size of `svo.bin`.
    pub bytes: u64,
    /// A dense RGBA8 3D texture at the same leaf size, as the paper stores it.
    pub dense_bytes: u64,
    /// Leaf-size cells holding free space that none of their 64 nearest
    /// probes sees.
    pub leaves_without_visible_probe: u64,
    /// Leaf edge.
    pub leaf_size: f32,
    /// Leaves along x, y, z over the domain.
    pub dims: [u32; 3],
    /// Leaf-size cells holding free space (each was ranked).
    pub free_cells: u64,
    /// Of those, cells no probe whose influence holds them sees, which list
    /// the nearest probe that does.
    pub fallback_cells: u64,
    /// Distinct probe lists in the payload.
    pub distinct_lists: usize,
    /// Share of [`CHECK_POINTS`] random free points whose first listed
    /// probe is unoccluded from them.
    pub first_probe_visible: f64,
}

/// The baked octree and its report.
#[derive(Debug, Clone)]
pub struct BakedSvo {
    /// The octree.
    pub svo: Svo,
    /// Its figures.
    pub report: SvoReport,
}

/// Refuses an octree whose leaves, probe-influence rays and leaf-probe
/// pairs would take longer than the work limit to bake
/// ([`crate::limits::rate`]), before the influences are known: as if every
/// probe's influence held every leaf, which bounds the pairs a leaf ranks
/// (in a room, where the rate was measured, it is the count). [`bake`]
/// checks again with the pairs its probes' influences make.
pub(crate) fn check_work(params: &SvoParams, dims: glam::UVec3, probes: usize) -> Result<()> {
    let cells = dims.x as f64 * dims.y as f64 * dims.z as f64;
    check_pairs(params, dims, probes, cells * probes as f64)
}

/// [`check_work`] for probes already placed, at `positions` over leaves
/// of `leaf` from the domain's corner: the bound first, and only where it
/// exceeds the limit the pairs their influences make
/// ([`influence_pairs`]), as [`bake`] counts them. The bound over-counts
/// wherever walls keep a probe's influence to its room: a 4M-triangle
/// tiled Sponza at half its `Auto` voxel, 8.57M leaves × 3 317 probes, is
/// 10 min by it, 74 s by the 28M pairs of their influences, and its whole
/// `place` took 114 s (BENCHMARKS.md, issue 47). The influences' rays are checked
/// before they are cast.
pub(crate) fn check_placed_work(
    params: &SvoParams,
    dims: glam::UVec3,
    leaf: f32,
    input: &PlacementInput,
    positions: &[Vec3],
) -> Result<()> {
    if check_work(params, dims, positions.len()).is_ok() {
        return Ok(());
    }
    check_pairs(params, dims, positions.len(), 0.0)?;
    let influence = influence::influences(
        input.scene,
        input.bvh,
        input.domain,
        positions,
        params.directions.0,
    );
    let pairs = influence_pairs(&influence, input.domain.min, leaf, dims);
    check_pairs(params, dims, positions.len(), pairs)
}

/// [`check_work`] with `pairs` leaf–influence pairs: the leaves each
/// probe's influence box overlaps, summed over the probes
/// ([`influence_pairs`]), which a leaf's ranking visits at most.
fn check_pairs(params: &SvoParams, dims: glam::UVec3, probes: usize, pairs: f64) -> Result<()> {
    let cells = dims.x as f64 * dims.y as f64 * dims.z as f64;
    let rays = probes as f64 * (params.directions.0 as f64).powi(2);
    let seconds_units = cells / crate::limits::rate::SVO_CELLS
        + rays / crate::limits::rate::SVO_PROBE_RAYS
        + pairs / crate::limits::rate::SVO_LEAF_PROBE_PAIRS;
    // The pairs are named when the influences gave them (not the bound,
    // nor the check before the influences are cast).
    let counted = pairs > 0.0 && pairs < cells * probes as f64;
    crate::limits::check_work(
        "svo",
        &format!(
            "the octree of {} leaves for {probes} probes ({}² directions each{})",
            crate::config::numbers::short(cells),
            params.directions.0,
            if counted {
                format!(
                    ", {} leaves in their influence regions",
                    crate::config::numbers::short(pairs)
                )
            } else {
                String::new()
            }
        ),
        seconds_units,
        1.0,
    )
}

/// The leaves of the grid of `dims` leaves of edge `leaf` from `origin`
/// that each influence box overlaps, summed: the leaf–probe pairs the
/// octree's build can rank. In a large scene each probe's influence holds
/// a part of it: on the 2M-triangle voxel world at half its voxel, 1983
/// probes over 8.5M leaves, the bound of every probe at every leaf made
/// the estimate 7 minutes for an octree built in 29 s.
pub(crate) fn influence_pairs(
    influence: &[influence::Influence],
    origin: Vec3,
    leaf: f32,
    dims: glam::UVec3,
) -> f64 {
    let last = dims.as_vec3() - 1.0;
    influence
        .iter()
        .map(|k| {
            let lo = ((k.region.min - origin) / leaf)
                .floor()
                .clamp(Vec3::ZERO, last);
            let hi = ((k.region.max - origin) / leaf)
                .floor()
                .clamp(Vec3::ZERO, last);
            let n = (hi - lo + 1.0).max(Vec3::ZERO);
            n.x as f64 * n.y as f64 * n.z as f64
        })
        .sum()
}

/// Bakes the SVO of `probes` over the input's domain (module docs).
///
/// Contract: every leaf-size cell holding free space lists at least one
/// probe (the nearest one when none sees it, counted in
/// `leaves_without_visible_probe`); the result depends only on the inputs,
/// never on thread scheduling. A leaf size giving too many leaves is a
/// user error naming `svo.leaf_size`.
pub fn bake(params: &SvoParams, probes: &ProbeSet, input: &PlacementInput) -> Result<BakedSvo> {
    let sdf = input.sdf;
    let leaf_size = params.leaf_size.map_or(sdf.voxel_size, |s| s.0);
    let dims = sdf::grid_dims(input.domain, leaf_size).map_err(|_| {
        Error::User(format!(
            "svo.leaf_size: {leaf_size} gives more than {} leaves over the domain; use a larger leaf_size",
            sdf::MAX_VOXELS
        ))
    })?;
    let depth = dims.max_element().next_power_of_two().trailing_zeros();
    let positions = probes.positions();
    // The leaves and the influences' rays first, then the pairs those
    // influences make.
    check_pairs(params, dims, positions.len(), 0.0)?;
    let influence = influence::influences(
        input.scene,
        input.bvh,
        input.domain,
        &positions,
        params.directions.0,
    );
    let pairs = influence_pairs(&influence, input.domain.min, leaf_size, dims);
    check_pairs(params, dims, positions.len(), pairs)?;
    let ranker = LeafRanker {
        bvh: input.bvh,
        sdf,
        influence: &influence,
        origin: input.domain.min,
        leaf_size,
    };
    let builder = Builder::new(&ranker, dims, params.collapse_quality.0);
    let all: Vec<u32> = (0..positions.len() as u32).collect();
    let (root, tally) = builder.build(depth, UVec3::ZERO, &all, &mut rank::Scratch::default());
    let (nodes, payload) = octree::encode(&root, params.max_probes.0 as usize)?;
    let svo = Svo {
        origin: input.domain.min,
        frame: input.scene.origin,
        leaf_size,
        depth,
        dims,
        probe_count: positions.len() as u32,
        max_probes: params.max_probes.0,
        leaves_without_visible_probe: tally.blind.min(u32::MAX as u64) as u32,
        provenance: [0; 32],
        nodes,
        payload,
    };
    debug_assert!(format::validate(&svo).is_ok());
    let first_probe_visible = first_probe_visibility(&svo, input, &positions, input.seed);
    let report = SvoReport {
        nodes: svo.nodes(),
        leaves: svo.leaves(),
        depth,
        bytes: svo.bytes(),
        dense_bytes: svo.dense_bytes(),
        leaves_without_visible_probe: tally.blind,
        leaf_size,
        dims: dims.to_array(),
        free_cells: tally.free,
        fallback_cells: tally.fallback,
        distinct_lists: svo.distinct_lists(),
        first_probe_visible,
    };
    Ok(BakedSvo { svo, report })
}

/// Uniform random points of the domain in free space ([`rank::is_free`]): a
/// point in a free voxel but behind a wall that crosses the voxel is not
/// free. `count` of them (fewer when free space is too rare to find by 100 tries a point),
/// from `seed`.
pub fn random_free_points(input: &PlacementInput, count: usize, seed: u64) -> Vec<Vec3> {
    let domain = input.domain;
    let size = domain.size();
    let mut out = Vec::with_capacity(count);
    for i in 0..(100 * count as u64) {
        if out.len() == count {
            break;
        }
        let h = hash2(seed ^ 0x5_0F0, i);
        let p = domain.min
            + size
                * Vec3::new(
                    unit_f32(hash2(h, 1)),
                    unit_f32(hash2(h, 2)),
                    unit_f32(hash2(h, 3)),
                );
        if rank::is_free(input.sdf, input.bvh, p) {
            out.push(p);
        }
    }
    out
}

/// Share of [`CHECK_POINTS`] random free points whose first listed probe
/// is unoccluded from them (1 when there is no free point).
fn first_probe_visibility(svo: &Svo, input: &PlacementInput, probes: &[Vec3], seed: u64) -> f64 {
    use rayon::prelude::*;
    let points = random_free_points(input, CHECK_POINTS, seed);
    if points.is_empty() {
        return 1.0;
    }
    let eps = 1e-3 * input.sdf.voxel_size;
    let seen = points
        .par_iter()
        .filter(|&&p| {
            svo.probes_at(p)
                .first()
                .is_some_and(|&k| !input.bvh.occluded(p, probes[k as usize], eps))
        })
        .count();
    seen as f64 / points.len() as f64
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::placement::Probe;
    use crate::progress::Progress;
    use crate::scene::raycast::SceneBvh;
    use crate::scene::testing::room_sdf;
    use crate::scene::Bounds;
    use crate::scene::Scene;
    use crate::sdf::Sdf;
    use std::collections::BTreeMap;

    /// The 4 m room with its box, and probes on either side of the box.
    fn room() -> (Scene, SceneBvh, Sdf, ProbeSet) {
        let (scene, bvh, sdf) = room_sdf(0.1, 1);
        let probes = [
            Vec3::new(3.0, 2.0, 3.0),
            Vec3::new(0.5, 0.5, 0.5),
            Vec3::new(3.2, 0.5, 0.6),
        ]
        .map(|position| Probe {
            position,
            cluster_size: 0,
        });
        let set = ProbeSet {
            method: "test".into(),
            probes: probes.to_vec(),
            stats: BTreeMap::new(),
            params: BTreeMap::new(),
            min_clearance: 0.1,
            fixed: 0,
        };
        (scene, bvh, sdf, set)
    }

    /// The input of a bake over the room (seed 3).
    fn input<'a>(
        scene: &'a Scene,
        bvh: &'a SceneBvh,
        sdf: &'a Sdf,
        progress: &'a Progress,
    ) -> PlacementInput<'a> {
        crate::scene::testing::input_over(scene, bvh, sdf, 3, progress)
    }

    /// Placed probes whose influences stay in a small closed box pass the
    /// check that the bound (every influence holding every leaf) refuses:
    /// 2 000 probes in the room's 1 m box, over 200³ leaves, on one thread.
    #[test]
    fn placed_probes_are_checked_by_their_influences_where_the_bound_refuses() {
        assert_eq!(
            crate::limits::work_limit_seconds(),
            crate::limits::WORK_LIMIT_SECONDS,
            "run without PROBEPLACE_WORK_LIMIT"
        );
        let (scene, bvh, sdf, _) = room();
        let progress = Progress::hidden();
        let input = input(&scene, &bvh, &sdf, &progress);
        let params = SvoParams {
            directions: crate::config::Count(8),
            ..SvoParams::default()
        };
        let dims = UVec3::splat(200);
        let leaf = input.domain.size().max_element() / 200.0;
        let inside: Vec<Vec3> = (0..2000)
            .map(|k| Vec3::new(1.2 + 0.0003 * k as f32, 0.5, 1.5))
            .collect();
        let open: Vec<Vec3> = (0..2000)
            .map(|k| Vec3::new(3.0, 2.0 + 0.0005 * k as f32, 3.0))
            .collect();
        let one = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap();
        one.install(|| {
            assert!(check_work(&params, dims, inside.len()).is_err());
            check_placed_work(&params, dims, leaf, &input, &inside).unwrap();
            // In the open room every influence holds most leaves: refused.
            let err = check_placed_work(&params, dims, leaf, &input, &open).unwrap_err();
            assert!(
                err.to_string()
                    .contains("leaves in their influence regions"),
                "{err}"
            );
        });
    }

    fn bake_room(params: &SvoParams) -> (BakedSvo, Scene, SceneBvh, Sdf, ProbeSet) {
        let (scene, bvh, sdf, set) = room();
        let progress = Progress::hidden();
        let baked = bake(params, &set, &input(&scene, &bvh, &sdf, &progress)).unwrap();
        (baked, scene, bvh, sdf, set)
    }

    /// The octree's work estimate counts the leaves each influence box
    /// overlaps: all of them for a box over the domain (the bound the
    /// early check assumes), one for a point, none past the grid's edge
    /// but the edge leaves; the room's own probes fall between.
    #[test]
    fn influence_pairs_count_the_leaves_each_box_overlaps() {
        let (scene, bvh, sdf, set) = room();
        let progress = Progress::hidden();
        let input = input(&scene, &bvh, &sdf, &progress);
        let leaf = sdf.voxel_size;
        let dims = sdf::grid_dims(input.domain, leaf).unwrap();
        let cells = dims.x as f64 * dims.y as f64 * dims.z as f64;
        let positions = set.positions();
        let real = influence::influences(&scene, &bvh, input.domain, &positions, 16);
        let pairs = influence_pairs(&real, input.domain.min, leaf, dims);
        assert!(pairs >= positions.len() as f64 && pairs <= cells * positions.len() as f64);
        let with = |region: Bounds| {
            let mut k = real[0];
            k.region = region;
            influence_pairs(&[k], input.domain.min, leaf, dims)
        };
        assert_eq!(with(*input.domain), cells);
        let p = Vec3::new(1.01, 1.01, 1.01);
        assert_eq!(with(Bounds { min: p, max: p }), 1.0);
        // Two leaves along x, clipped at the grid's far corner.
        let lo = input.domain.min + (dims.as_vec3() - Vec3::new(1.5, 0.5, 0.5)) * leaf;
        let beyond = input.domain.max + 10.0;
        assert_eq!(
            with(Bounds {
                min: lo,
                max: beyond
            }),
            2.0
        );
    }

    #[test]
    fn every_free_point_lists_a_probe_it_sees_first() {
        let (baked, scene, bvh, sdf, set) = bake_room(&SvoParams::default());
        let svo = &baked.svo;
        assert_eq!(baked.report.leaves_without_visible_probe, 0);
        assert!(baked.report.first_probe_visible >= 0.99);
        let progress = Progress::hidden();
        let input = input(&scene, &bvh, &sdf, &progress);
        let positions = set.positions();
        let points = random_free_points(&input, 2000, 99);
        assert_eq!(points.len(), 2000);
        let mut first_seen = 0;
        for p in &points {
            let list = svo.probes_at(*p);
            assert!(!list.is_empty() && list.len() <= 4, "{p}: {list:?}");
            assert!(list.iter().all(|&k| k < 3));
            let mut sorted = list.to_vec();
            sorted.sort_unstable();
            sorted.dedup();
            assert_eq!(sorted.len(), list.len(), "a probe listed twice at {p}");
            if !bvh.occluded(*p, positions[list[0] as usize], 1e-4) {
                first_seen += 1;
            }
        }
        assert!(first_seen >= 1980, "{first_seen} of 2000");
        // Outside the domain: nothing.
        assert!(svo.probes_at(Vec3::new(-1.0, 0.5, 0.5)).is_empty());
        assert!(svo.probes_at(Vec3::new(0.5, 0.5, f32::NAN)).is_empty());
        // Behind the box from probe 0, the first probe is another one.
        let hidden = Vec3::new(0.4, 0.3, 0.4);
        assert!(bvh.occluded(hidden, positions[0], 1e-4));
        assert_ne!(svo.probes_at(hidden)[0], 0);
    }

    #[test]
    fn listings_bound_every_cell_that_lists_a_probe() {
        let (baked, ..) = bake_room(&SvoParams::default());
        let svo = &baked.svo;
        let listings = svo.listings();
        assert_eq!(listings.len(), 3);
        // Every cell centre's list is inside each listed probe's box, and
        // the counts add up to the cells each probe is queried at.
        let mut counted = [0u64; 3];
        let mut first = [0u64; 3];
        for z in 0..svo.dims.z {
            for y in 0..svo.dims.y {
                for x in 0..svo.dims.x {
                    let c = UVec3::new(x, y, z);
                    let p = svo.origin + (c.as_vec3() + 0.5) * svo.leaf_size;
                    for (rank, &k) in svo.probes_at(p).iter().enumerate() {
                        let l = &listings[k as usize];
                        assert!(
                            c.cmpge(l.lo).all() && c.cmplt(l.hi).all(),
                            "{c} outside {l:?}"
                        );
                        counted[k as usize] += 1;
                        first[k as usize] += u64::from(rank == 0);
                    }
                }
            }
        }
        for (k, l) in listings.iter().enumerate() {
            assert_eq!(l.cells, counted[k], "probe {k}");
            assert_eq!(l.first, first[k], "probe {k}");
            assert!(l.cells > 0 && l.hi.cmple(svo.dims).all(), "{l:?}");
        }
    }

    #[test]
    fn collapsing_shrinks_the_tree_and_strictness_grows_it() {
        let strict = SvoParams {
            collapse_quality: crate::config::Fraction(1.0),
            ..SvoParams::default()
        };
        let loose = SvoParams {
            collapse_quality: crate::config::Fraction(0.1),
            ..SvoParams::default()
        };
        let (s, ..) = bake_room(&strict);
        let (l, ..) = bake_room(&loose);
        assert!(
            l.report.nodes < s.report.nodes,
            "{} vs {}",
            l.report.nodes,
            s.report.nodes
        );
        assert_eq!(s.report.free_cells, l.report.free_cells);
    }

    #[test]
    fn bytes_round_trip_and_bakes_are_reproducible() {
        let (a, ..) = bake_room(&SvoParams::default());
        let (b, ..) = bake_room(&SvoParams::default());
        let bytes = a.svo.to_bytes();
        assert_eq!(bytes, b.svo.to_bytes(), "two bakes differ");
        assert_eq!(bytes.len() as u64, a.svo.bytes());
        let read = format::from_bytes(&bytes).unwrap();
        assert_eq!(read, a.svo);
        for i in 0..5000u64 {
            let h = hash2(7, i);
            let p = Vec3::new(
                unit_f32(hash2(h, 1)) * 4.4 - 0.2,
                unit_f32(hash2(h, 2)) * 4.4 - 0.2,
                unit_f32(hash2(h, 3)) * 4.4 - 0.2,
            );
            assert_eq!(read.probes_at(p), a.svo.probes_at(p));
        }
    }

    /// A tree baked in a scene's local coordinates is written in world
    /// coordinates, and the tree read back answers world points as the
    /// baked one answers the same points in local coordinates.
    #[test]
    fn files_are_in_world_coordinates() {
        let (mut baked, ..) = bake_room(&SvoParams::default());
        baked.svo.frame = DVec3::new(1000.0, -250.0, 64.0);
        let read = format::from_bytes(&baked.svo.to_bytes()).unwrap();
        assert_eq!(read.frame, DVec3::ZERO);
        assert_eq!(read.origin, baked.svo.world_origin().as_vec3());
        let svo = &baked.svo;
        for i in 0..2000u64 {
            let h = hash2(11, i);
            // Leaf centres, where f32 rounding of the world point cannot
            // move the query to another leaf.
            let cell = UVec3::new(
                (unit_f32(hash2(h, 1)) * svo.dims.x as f32) as u32,
                (unit_f32(hash2(h, 2)) * svo.dims.y as f32) as u32,
                (unit_f32(hash2(h, 3)) * svo.dims.z as f32) as u32,
            )
            .min(svo.dims - 1);
            let local = svo.origin + (cell.as_vec3() + 0.5) * svo.leaf_size;
            let world = (svo.frame + local.as_dvec3()).as_vec3();
            assert_eq!(read.probes_at(world), svo.probes_at(local), "{local}");
        }
    }

    #[test]
    fn damaged_files_are_refused_with_a_reason() {
        let (a, ..) = bake_room(&SvoParams::default());
        let bytes = a.svo.to_bytes();
        let err = |b: &[u8]| format::from_bytes(b).unwrap_err();
        assert!(err(&bytes[..bytes.len() - 1]).starts_with("truncated"));
        assert!(err(&bytes[..40]).starts_with("truncated"));
        assert!(err(b"PROBES").starts_with("not a probeplace SVO"));
        let mut longer = bytes.clone();
        longer.push(0);
        assert!(err(&longer).starts_with("corrupted"));
        let mut flipped = bytes.clone();
        flipped[format::HEADER_BYTES + 5] ^= 0x10;
        assert!(err(&flipped).contains("checksum"));
        // A newer version, checksum and all, is named as such.
        let mut newer = bytes.clone();
        newer[8..12].copy_from_slice(&3u32.to_le_bytes());
        let end = newer.len() - 4;
        let crc = format::crc32(&newer[..end]);
        newer[end..].copy_from_slice(&crc.to_le_bytes());
        assert!(err(&newer).starts_with("unsupported version 3"));
    }

    #[test]
    fn well_checksummed_nonsense_never_panics() {
        let (a, ..) = bake_room(&SvoParams::default());
        let bytes = a.svo.to_bytes();
        let end = bytes.len() - 4;
        let mut refused = 0;
        for i in 0..3000u64 {
            let mut b = bytes.clone();
            // Damage one to three words after the magic, then fix the checksum
            // so the structural checks, not the CRC, must catch it.
            for j in 0..(1 + i % 3) {
                let h = hash2(i, j);
                let at = 8 + (h as usize % (end - 8));
                b[at] = (h >> 32) as u8;
            }
            let crc = format::crc32(&b[..end]);
            b[end..].copy_from_slice(&crc.to_le_bytes());
            match format::from_bytes(&b) {
                Ok(svo) => {
                    for k in 0..64u64 {
                        let h = hash2(i, 100 + k);
                        let p = Vec3::new(
                            unit_f32(hash2(h, 1)) * 4.0,
                            unit_f32(hash2(h, 2)) * 4.0,
                            unit_f32(hash2(h, 3)) * 4.0,
                        );
                        assert!(svo.probes_at(p).iter().all(|&k| k < svo.probe_count));
                    }
                }
                Err(_) => refused += 1,
            }
        }
        assert!(refused > 0);
    }
}
