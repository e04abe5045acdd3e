//! How much of the scene a probe set sees, measured independently of any
//! placement method, so that every method (and McGuire et al. 2017's grid) is
//! scored by the same rule.
//!
//! Wang et al. 2019 (§2, §3.2) require *full geometric visibility coverage*:
//! every scene point sampled by at least one probe. Their visibility atlas is
//! a texture-space union of per-probe visibility; here the atlas is replaced
//! by area-uniform surface samples, which needs no UV parameterization:
//!
//! * points are drawn area-uniformly over all triangles (stratified over the
//!   area CDF, seeded), in rounds of independent stratified batches until at
//!   least `samples` of them are coverable (below): 40 000 coverable samples
//!   bound the 95% interval of the estimate by 1.96·sqrt(0.25/40000) < 0.5%
//!   whatever the coverage, on any scene, however much of its surface is
//!   hidden;
//! * a sample is **seen** from a point `v` when the segment between them is
//!   unoccluded and the incidence angle (between the surface's front normal
//!   and the direction to `v`) is under `max_incidence_deg` (85°), which
//!   rejects the grazing views that distort probe lookups (§3.2, "Probe View
//!   Distortion"). Only front faces count: seeing a back face means the
//!   viewer is behind the surface, the very rule the SDF uses for solid space;
//!   the outer sides of single-sided walls are thereby nobody's business;
//! * **coverable** when [`MIN_REFERENCE_VIEWS`] reference points see it
//!   ([`CoverageReference::by_rays`]): points of a lattice over the domain
//!   where a probe could legally stand, each free by its own rays
//!   ([`free_points`]) and a quarter of the lattice's spacing (at least
//!   [`REFERENCE_MIN_CLEARANCE_VOXELS`]) from every surface, so that no
//!   SDF verdict moves the denominator. Points nearer a surface stand in
//!   gaps the lattice does not resolve. (The measure before,
//!   [`CoverageReference::new`], took free voxel centres of the SDF, one
//!   view enough.);
//! * **covered** when some probe sees it (and it is coverable).
//!
//! `coverage = covered area / coverable area`, estimated as the ratio of
//! sample counts, with a 95% binomial interval.
//!
//! **Train and validate apart.** Samples and reference points can come
//! from independent seed *streams* ([`Stream`]): a placer that fits one
//! stream is measured honestly only on another, since on the stream it
//! fitted the samples are not independent of the probes chosen to see
//! them ([`crate::refine::holdout`]). Surfaces that no free point
//! can see (back sides of walls, faces buried in other geometry) are left out
//! of both, so a method is not blamed for what nobody could see.

use crate::config::params::CoverageParams;
use crate::progress::Progress;
use crate::sampling::{hash2, point_in_triangle, unit_f32};
use crate::scene::raycast::{Blocker, SceneBvh};
use crate::scene::{Bounds, Scene};
use crate::sdf::{RayRule, Sdf, VoxelClass};
use glam::Vec3;
use kiddo::{ImmutableKdTree, SquaredEuclidean};
use rayon::prelude::*;
use std::num::NonZero;

/// Reference points stand at least this many voxels from every surface
/// (module docs); no placement method puts a probe nearer.
pub const REFERENCE_MIN_CLEARANCE_VOXELS: f32 = 1.0;

/// The independent streams of samples and reference points one run's seed
/// gives: what the placer fits (`Train`), the fresh rounds it checks its
/// result on and fills from (`Check`), and the measure the report prints
/// (`Validation`), which the placer never sees. A figure measured on
/// `Train` is a training score.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stream {
    /// The samples refinement, filling, pruning and the budget fit.
    Train,
    /// The `k`-th round of fresh samples the placer checks its probes on,
    /// and fills the holes of ([`crate::refine::holdout`]).
    Check(u32),
    /// The samples and reference points `report.json`'s `coverage` is
    /// measured on, never shown to the placer.
    Validation,
}

impl Stream {
    /// The seed of this stream for a run of seed `seed`: streams of one
    /// seed, and of different seeds, share no samples.
    pub fn seed(self, seed: u64) -> u64 {
        match self {
            Stream::Train => hash2(seed, 0x7EA1_0000),
            Stream::Check(k) => hash2(seed, 0xC4EC_0000 + k as u64),
            Stream::Validation => hash2(seed, 0x7A11_DA7E),
        }
    }
}

/// Rays of [`stands_free`]: with this many, the share of back faces a
/// point sees is known to a few percent (binomial standard deviation under
/// 0.04 at any share), against the SDF's 32 rays a voxel.
pub const PROBE_RAYS: u32 = 128;

/// The share of back-face hits above which [`stands_free`] calls a point
/// solid: half the SDF's default (`sdf.solid_backface_fraction`, 0.25). A
/// probe at the SDF's own threshold would be called solid by about half
/// the seeds' SDFs (32 rays a voxel); at half of it, by few: the margin
/// is what makes a probe free under any seed's judgement.
pub const PROBE_SOLID_FRACTION: f32 = 0.125;

/// The class of the point `p` by rays of its own, not by any SDF:
/// [`PROBE_RAYS`] rays on a spherical Fibonacci set, turned by a rotation
/// hashed from the position alone (so every seed, and every run, judges a
/// position alike); solid when more than [`PROBE_SOLID_FRACTION`] of them
/// first hit a back face, else outside the scene when more than half
/// escape (the SDF's default), else free: the SDF's rule
/// ([`RayRule`]) with a margin on solid. `voxel_size` scales the hit
/// tolerances. Where a probe may stand ([`stands_free`]) and where the
/// coverage measure's reference points may ([`free_points`]) are both
/// this verdict, so every reference point is a position a probe may take.
pub fn judge_point(bvh: &SceneBvh, voxel_size: f32, p: Vec3) -> VoxelClass {
    thread_local! {
        static RULE: std::cell::RefCell<Option<(f32, RayRule)>> = const { std::cell::RefCell::new(None) };
    }
    let key = p
        .to_array()
        .iter()
        .fold(0x5EED_F4EEu64, |h, c| hash2(h, c.to_bits() as u64));
    let rot = crate::sampling::random_rotation(key);
    RULE.with(|cell| {
        let mut cell = cell.borrow_mut();
        if cell.as_ref().is_none_or(|(v, _)| *v != voxel_size) {
            let outside = crate::config::params::SdfParams::default()
                .outside_escape_fraction
                .0;
            *cell = Some((
                voxel_size,
                RayRule::new(PROBE_RAYS, PROBE_SOLID_FRACTION, outside, voxel_size),
            ));
        }
        let (_, rule) = cell.as_ref().expect("set above");
        rule.classify(bvh, p, rot)
    })
}

/// Whether a probe at `p` stands in free space by [`judge_point`]: not
/// solid (open sky does not make a point solid).
pub fn stands_free(bvh: &SceneBvh, voxel_size: f32, p: Vec3) -> bool {
    judge_point(bvh, voxel_size, p) != VoxelClass::Solid
}

/// Reference points that must see a sample for it to count as coverable.
/// One is not enough: on real assets a sample is now and then seen by a
/// single reference point of thousands, through a crack between two
/// triangles or past a ledge from one spot, and a fresh stream of
/// reference points finds other such samples than the last (on Dabrovic
/// Sponza about 0.15% of the samples, half the holes a fresh stream found
/// in 43 probes that met 99.9% on their training set). A surface seen from
/// so little of the free space that one point of 4096 finds it by chance
/// is no surface a probe placer can promise; one that two see is seen
/// from a region. BENCHMARKS.md ("Coverage on samples the placer never
/// saw") has the counts.
pub const MIN_REFERENCE_VIEWS: usize = 2;

/// Reference points keep this share of the lattice spacing from every
/// surface (at least [`REFERENCE_MIN_CLEARANCE_VOXELS`]): a length of the
/// lattice, not of the voxel, so an automatic voxel size (which follows
/// the seed) moves no reference point in or out. A lattice point nearer a
/// surface than that stands in a gap narrower than half the spacing, which
/// a lattice of this density does not resolve anyway.
pub const LATTICE_CLEARANCE: f32 = 0.25;

/// The distance from `p` to the nearest surface: the least distance to
/// the nearest surface points the SDF found for the voxels around `p`
/// (its own and its 26 neighbours'; [`Sdf::nearest`]): never below the
/// true distance, and above it by a fraction of a voxel at most where the
/// nearest surface is flat. Unlike a voxel's distance
/// less the offset from its centre, it does not swing with where `p`
/// falls in its voxel.
pub(crate) fn surface_distance(sdf: &Sdf, p: Vec3) -> f32 {
    let c = sdf.nearest_voxel(p).as_ivec3();
    let max = sdf.dims.as_ivec3() - 1;
    let mut best = f32::INFINITY;
    for dz in -1..=1 {
        for dy in -1..=1 {
            for dx in -1..=1 {
                let u = c + glam::IVec3::new(dx, dy, dz);
                if u.cmplt(glam::IVec3::ZERO).any() || u.cmpgt(max).any() {
                    continue;
                }
                if let Some(q) = sdf.nearest[sdf.index(u.as_uvec3())] {
                    best = best.min(p.distance(q));
                }
            }
        }
    }
    best
}

/// Most lattice points [`free_points`] judges: its densest lattice
/// (about 1 GB of nothing, 2 s of rays, at the limit).
const MAX_LATTICE_POINTS: usize = 1 << 22;

/// The coverage measure's reference points: the centres of a regular
/// lattice over the `domain` box where a probe could legally stand, at least
/// [`REFERENCE_MIN_CLEARANCE_VOXELS`] from every surface and free by
/// [`judge_point`] (neither solid nor outside the scene, the same verdict a
/// probe must pass, [`stands_free`]).
///
/// Freeness is the measure's own verdict, not the SDF's voxels. The SDF
/// lends only its unsigned distance (geometry, the same under any seed) for
/// the clearance. So an SDF that misreads a region (a seed whose rays fall
/// the other way, a two-sided sheet read as solid) removes no surface from
/// the coverable denominator.
///
/// The lattice depends on the domain and `count` alone, not on any seed,
/// stream or voxel size (an automatic voxel size follows the seed): which surfaces are coverable is then one fact about the scene,
/// the same for training, every check round, the validation stream and any
/// other seed's re-measure, which differ only by their surface samples.
/// Random reference points made it a draw: a small room or a pocket under
/// an overhang held two of one stream's 4096 points and none of the next's,
/// and the coverage of one placement moved by over 1% between seeds
/// (BENCHMARKS.md, "Coverage on samples the placer never saw"). The lattice
/// starts with about `count` points over the box and doubles its density
/// while fewer than half of `count` are free, down to a voxel's spacing.
pub fn free_points(bvh: &SceneBvh, sdf: &Sdf, domain: &Bounds, count: usize) -> Vec<Vec3> {
    let extent = domain.size();
    let volume = extent.x as f64 * extent.y as f64 * extent.z as f64;
    let mut spacing = ((volume / count.max(1) as f64).cbrt() as f32).max(sdf.voxel_size);
    loop {
        let clearance =
            (LATTICE_CLEARANCE * spacing).max(REFERENCE_MIN_CLEARANCE_VOXELS * sdf.voxel_size);
        let n = (extent / spacing).ceil().max(glam::Vec3::ONE).as_uvec3();
        let total = n.x as usize * n.y as usize * n.z as usize;
        let step = extent / n.as_vec3();
        let judge = |k: usize| -> Option<Vec3> {
            let (i, j, l) = (
                k % n.x as usize,
                (k / n.x as usize) % n.y as usize,
                k / (n.x as usize * n.y as usize),
            );
            let p = domain.min + (Vec3::new(i as f32, j as f32, l as f32) + 0.5) * step;
            if surface_distance(sdf, p) < clearance {
                return None;
            }
            (judge_point(bvh, sdf.voxel_size, p) == VoxelClass::Free).then_some(p)
        };
        let found: Vec<Vec3> = (0..total)
            .into_par_iter()
            .with_min_len(64)
            .filter_map(judge)
            .collect();
        let finer = spacing / 2f32.cbrt();
        if 2 * found.len() >= count || finer < sdf.voxel_size || 2 * total > MAX_LATTICE_POINTS {
            return found;
        }
        spacing = finer;
    }
}

/// Share of sample-reference pairs the reference's visibility search
/// tests, on average: samples stop at the first reference that sees them
/// (most within the [`NEAREST_FIRST`] nearest), but uncoverable ones try
/// every reference. A quarter bounds what was measured on the scenes in
/// configs/ (BENCHMARKS.md, "Limits").
const TESTED_SHARE: f64 = 0.25;

/// Sample sets one `place` run measures coverability of, at most: the
/// validation stream, the training stream and every check round
/// ([`MAX_CHECK_ROUNDS`]).
const SAMPLE_SETS_PER_RUN: u32 = 2 + MAX_CHECK_ROUNDS;

/// Most fresh rounds of samples the placer checks its probes on
/// ([`crate::refine::holdout`]): the streams it draws them from are
/// coverage's.
pub const MAX_CHECK_ROUNDS: u32 = 6;

/// Refuses coverage parameters whose references would take longer than
/// [`crate::limits::work_limit_seconds`] over a domain of `voxels` SDF
/// voxels (at most that many reference points exist): samples ×
/// references × [`TESTED_SHARE`] segments for each of the
/// [`SAMPLE_SETS_PER_RUN`] sample sets a run may draw.
pub fn check_work(params: &CoverageParams, voxels: f64) -> crate::error::Result<()> {
    let references = (params.reference_points.0 as f64).min(voxels);
    let sets = SAMPLE_SETS_PER_RUN as f64;
    let segments = sets * params.samples.0 as f64 * references * TESTED_SHARE;
    crate::limits::check_work(
        "coverage.samples",
        &format!(
            "the coverage measure (up to {SAMPLE_SETS_PER_RUN} sets of {} samples × {} reference points: validation, training and check rounds)",
            params.samples.0, references as u64
        ),
        segments,
        crate::limits::rate::COVERAGE_SEGMENTS,
    )
}

/// The estimated work of scoring `probes` probes against `params.samples`
/// samples (each tries its nearest probes first, then the others):
/// segments, for [`crate::limits::check_work`].
pub fn evaluation_segments(params: &CoverageParams, probes: usize) -> f64 {
    params.samples.0 as f64 * probes as f64 * TESTED_SHARE
}

/// Viewers each sample tries first, before all others: those nearest its
/// cell of [`NearViewers`].
const NEAREST_FIRST: usize = 32;

/// Cells of [`NearViewers`]'s grid per viewer, about.
const CELLS_PER_VIEWER: f32 = 1.0;

/// Most cells of [`NearViewers`]'s grid along an edge.
const MAX_CELLS_PER_EDGE: f32 = 64.0;

/// The [`NEAREST_FIRST`] viewers nearest the centre of each cell of a grid
/// over the viewers' box, about one cell per viewer: the viewers a sample
/// tries first are its cell's, one table lookup. Most coverable samples
/// are settled by a viewer among them. Which viewers a sample tries first
/// changes only how soon it finds those that see it, never whether it
/// does: it tries every other viewer that faces it after them. A k-d tree
/// query for each sample found the sample's own nearest, at a cost of a
/// third of a coverage reference's time on Dabrovic Sponza (BENCHMARKS.md,
/// "Coverage on samples the placer never saw"); a sample's cell's
/// nearest are nearly the same viewers.
struct NearViewers {
    lo: Vec3,
    cell: f32,
    dims: glam::UVec3,
    k: usize,
    /// `k` viewer indices per cell, nearest the cell's centre first.
    lists: Vec<u32>,
}

impl NearViewers {
    fn new(viewers: &[Vec3]) -> NearViewers {
        let (lo, hi) = viewers.iter().fold(
            (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
            |(lo, hi), &v| (lo.min(v), hi.max(v)),
        );
        let k = NEAREST_FIRST.min(viewers.len());
        let widest = (hi - lo).max_element();
        let size = (hi - lo).max(Vec3::splat(1e-3 * widest + 1e-6));
        let cells = (viewers.len() as f32 * CELLS_PER_VIEWER).max(1.0);
        let cell = (size.x * size.y * size.z / cells)
            .cbrt()
            .max(size.max_element() / MAX_CELLS_PER_EDGE);
        let dims = (size / cell).ceil().max(Vec3::ONE).as_uvec3();
        let total = (dims.x * dims.y * dims.z) as usize;
        let points: Vec<[f32; 3]> = viewers.iter().map(|v| v.to_array()).collect();
        let lists = match (
            ImmutableKdTree::<f32, 3>::new_from_slice(&points),
            NonZero::new(k),
        ) {
            (Ok(tree), Some(n)) => (0..total)
                .into_par_iter()
                .with_min_len(64)
                .flat_map_iter(|c| {
                    let u = glam::UVec3::new(
                        c as u32 % dims.x,
                        (c as u32 / dims.x) % dims.y,
                        c as u32 / (dims.x * dims.y),
                    );
                    let centre = lo + (u.as_vec3() + 0.5) * cell;
                    tree.query(&centre.to_array())
                        .nearest_n::<SquaredEuclidean<f32>>(n)
                        .execute()
                        .into_iter()
                        .map(|r| r.item)
                })
                .collect(),
            // Too few viewers for a tree: each cell lists them all.
            _ => (0..total).flat_map(|_| 0..k as u32).collect(),
        };
        NearViewers {
            lo,
            cell,
            dims,
            k,
            lists,
        }
    }

    /// The viewers listed for the cell that holds `p` (the nearest cell
    /// for points outside the grid).
    #[inline]
    fn of(&self, p: Vec3) -> &[u32] {
        let max = (self.dims - 1).as_vec3();
        let u = ((p - self.lo) / self.cell)
            .floor()
            .clamp(Vec3::ZERO, max)
            .as_uvec3();
        let c = (u.x + self.dims.x * (u.y + self.dims.y * u.z)) as usize;
        self.lists.get(c * self.k..(c + 1) * self.k).unwrap_or(&[])
    }
}

/// Viewers per group of neighbours whose facing test a sample makes once
/// for the whole group ([`ViewerGroups`]).
const GROUP: usize = 32;

/// Viewers in groups of [`GROUP`] neighbours in space (Morton order), each
/// with a ball around them: a sample none of whose viewers it faces (a
/// surface turned towards solid or away from the domain, where most
/// uncoverable samples lie) rejects a group with one test rather than
/// each viewer with its own.
struct ViewerGroups {
    /// Viewer indices, group after group.
    order: Vec<usize>,
    /// Centre and radius of each group's ball.
    balls: Vec<(Vec3, f32)>,
}

impl ViewerGroups {
    fn new(viewers: &[Vec3]) -> ViewerGroups {
        let order = crate::sampling::morton_order(viewers);
        let balls = order
            .chunks(GROUP)
            .map(|group| {
                let (lo, hi) = group.iter().fold(
                    (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
                    |(lo, hi), &v| (lo.min(viewers[v]), hi.max(viewers[v])),
                );
                let centre = 0.5 * (lo + hi);
                let radius = group
                    .iter()
                    .map(|&v| viewers[v].distance(centre))
                    .fold(0.0f32, f32::max);
                (
                    centre,
                    radius * (1.0 + 1e-5) + 1e-6 * centre.abs().max_element(),
                )
            })
            .collect();
        ViewerGroups { order, balls }
    }

    /// The groups whose ball may hold a viewer `sample` faces within
    /// `min_cos` ([`CoverageReference::sees_from`]'s first test, which
    /// needs `n·(v − s) ≥ min_cos·|v − s|`): over a ball of centre `c` and
    /// radius `r`, `n·(v − s)` is at most `n·(c − s) + r` and `|v − s|` at
    /// least `|c − s| − r`, with a margin for rounding.
    fn facing<'g>(
        &'g self,
        sample: &'g SurfaceSample,
        min_cos: f32,
    ) -> impl Iterator<Item = &'g [usize]> + 'g {
        self.order
            .chunks(GROUP)
            .zip(&self.balls)
            .filter(move |(_, &(c, r))| {
                let to = c - sample.position;
                let dist = to.length();
                let margin = 1e-4 * (dist + r) + 1e-6 * sample.position.abs().max_element();
                sample.normal.dot(to) + r + margin >= min_cos * (dist - r).max(0.0)
            })
            .map(|(group, _)| group)
    }
}

/// Most sampling rounds drawn to reach the coverable-sample target.
const MAX_ROUNDS: u64 = 8;

/// A point on the scene's surface.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SurfaceSample {
    /// Position.
    pub position: Vec3,
    /// Unit geometric normal of its triangle.
    pub normal: Vec3,
}

/// The probe-independent half of the coverage measure: surface samples and
/// which of them any legal probe position could see. Build it once per scene
/// and evaluate any number of probe sets against it.
pub struct CoverageReference {
    /// Area-uniform surface samples.
    pub samples: Vec<SurfaceSample>,
    /// Whether each sample is coverable.
    pub coverable: Vec<bool>,
    /// Number of reference points used.
    pub reference_points: usize,
    /// The reference points (free by [`free_points`]) themselves.
    pub references: Vec<Vec3>,
    /// The parameters it was built with.
    pub params: CoverageParams,
    /// The reachable voxels ([`crate::reachable`]), when the run has them:
    /// a sample is coverable only when the first open voxel in front of it
    /// is reached ([`faces_reach`]).
    reach: Option<std::sync::Arc<Vec<bool>>>,
    /// Reference points that must see a sample for it to be coverable.
    need: usize,
    min_cos: f32,
    eps: f32,
}

/// Coverage of one probe set.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Coverage {
    /// Covered area / coverable area, in [0, 1].
    pub coverage: f64,
    /// Half-width of the 95% interval of `coverage`.
    pub ci95: f64,
    /// Surface samples drawn.
    pub samples: usize,
    /// Samples some reference point sees.
    pub coverable_samples: usize,
    /// Coverable samples some probe sees.
    pub covered_samples: usize,
    /// Coverable share of the total surface area.
    pub coverable_fraction: f64,
    /// Reference points used for coverability.
    pub reference_points: usize,
}

/// `covered / coverable` (0 when nothing is coverable) and the half-width
/// of its normal-approximation 95% interval; with the default 40 000
/// coverable samples it is within ±0.5% for any ratio.
pub(crate) fn ratio_ci95(covered: usize, coverable: usize) -> (f64, f64) {
    if coverable == 0 {
        return (0.0, 0.0);
    }
    let p = covered as f64 / coverable as f64;
    (p, 1.96 * (p * (1.0 - p) / coverable as f64).sqrt())
}

/// Where probes stand relative to the SDF and the domain.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub struct ProbeHealth {
    /// Probes in solid space by [`stands_free`] (inside objects or walls),
    /// a verdict that does not depend on the run's seed or SDF.
    pub probes_in_solid: usize,
    /// Probes in voxels the run's SDF classifies solid.
    pub probes_in_solid_sdf: usize,
    /// Probes in voxels classified outside the scene.
    pub probes_outside_scene: usize,
    /// Probes outside the domain box.
    pub probes_outside_domain: usize,
}

/// Draws `n` area-uniform samples, stratified along the area CDF, less
/// those that fall in a cut-out's holes ([`Scene::opaque_at`]): a hole is
/// not surface, and every ray passes it.
///
/// Contract: deterministic for `(scene, n, seed)`; each triangle's expected
/// share is proportional to its area (its opaque area, for a cut-out); at
/// most `n`, exactly `n` in a scene without cut-outs.
pub fn sample_surface(scene: &Scene, n: usize, seed: u64) -> Vec<SurfaceSample> {
    let mut cdf = Vec::with_capacity(scene.triangles.len());
    let mut total = 0.0f64;
    for area in scene.triangle_areas() {
        total += area;
        cdf.push(total);
    }
    (0..n)
        .into_par_iter()
        .filter_map(|k| {
            let h = hash2(seed, k as u64);
            let u = (k as f64 + unit_f32(hash2(h, 0)) as f64) / n as f64 * total;
            let ti = cdf.partition_point(|&c| c < u).min(cdf.len() - 1);
            let t = &scene.triangles[ti];
            let position = point_in_triangle(t, unit_f32(hash2(h, 1)), unit_f32(hash2(h, 2)));
            scene.opaque_at(ti, position).then(|| SurfaceSample {
                position,
                normal: scene.normals[ti],
            })
        })
        .collect()
}

/// Whether `sample` faces reached space: the first voxel along its
/// normal (half a voxel, then one and a half) that is not solid is in
/// `reach` ([`crate::reachable::Reachable::mask`]); `true` when both are
/// solid or beyond the grid, where the rays alone decide. A surface seen
/// from a reached point only through a gap too narrow for a viewer (the
/// ceiling of a roof space seen through a slit) faces the space beyond
/// the gap, and is not coverable: no viewer stands by it.
pub(crate) fn faces_reach(sdf: &Sdf, reach: &[bool], sample: &SurfaceSample) -> bool {
    for k in [0.5f32, 1.5] {
        let p = sample.position + sample.normal * (k * sdf.voxel_size);
        match sdf.voxel_at(p) {
            Some(v) if sdf.class[v] != VoxelClass::Solid => return reach[v],
            _ => {}
        }
    }
    true
}

impl CoverageReference {
    /// Samples the surface and decides which samples are coverable, by
    /// free voxel centres of the SDF (module docs) each able to make a
    /// sample coverable alone: the measure before
    /// [`CoverageReference::by_rays`], which every job now uses; quicker,
    /// but its denominator moves with the SDF's verdicts (a seed's), so
    /// only the unit tests of the steps, on small rooms, still build it.
    pub fn new(
        scene: &Scene,
        bvh: &SceneBvh,
        sdf: &Sdf,
        params: &CoverageParams,
        seed: u64,
        progress: &Progress,
    ) -> CoverageReference {
        let mut free: Vec<(u64, usize)> = (0..sdf.len())
            .into_par_iter()
            .with_min_len(4096)
            .filter(|&i| {
                sdf.class[i] == VoxelClass::Free
                    && sdf.distance[i] >= REFERENCE_MIN_CLEARANCE_VOXELS * sdf.voxel_size
            })
            .map(|i| (hash2(seed, i as u64), i))
            .collect();
        crate::sampling::keep_least(&mut free, params.reference_points.0 as usize);
        let mut refs: Vec<Vec3> = free.iter().map(|&(_, i)| sdf.center(i)).collect();
        refs.sort_by(|a, b| {
            a.to_array()
                .partial_cmp(&b.to_array())
                .unwrap_or(std::cmp::Ordering::Equal)
        });
        CoverageReference::build(scene, bvh, sdf, params, seed, (refs, 1), None, progress)
    }

    /// The measure whose denominator does not depend on the SDF's verdicts:
    /// reference points by [`free_points`] (free by their own rays), and a
    /// sample coverable when [`MIN_REFERENCE_VIEWS`] of them see it: the
    /// measure of every job's training, check rounds and report
    /// (docs/method.md, "Coverage on samples the placer never saw").
    pub fn by_rays(
        scene: &Scene,
        bvh: &SceneBvh,
        sdf: &Sdf,
        domain: &Bounds,
        params: &CoverageParams,
        seed: u64,
        progress: &Progress,
    ) -> CoverageReference {
        let refs = free_points(bvh, sdf, domain, params.reference_points.0 as usize);
        CoverageReference::on_free_points(scene, bvh, sdf, params, seed, refs, None, progress)
    }

    /// [`CoverageReference::by_rays`] on reference points `refs` that
    /// [`free_points`] found for this scene, domain and
    /// `params.reference_points` (which depend on no seed, so one run
    /// finds them once for all its streams).
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn on_free_points(
        scene: &Scene,
        bvh: &SceneBvh,
        sdf: &Sdf,
        params: &CoverageParams,
        seed: u64,
        refs: Vec<Vec3>,
        reach: Option<std::sync::Arc<Vec<bool>>>,
        progress: &Progress,
    ) -> CoverageReference {
        CoverageReference::build(
            scene,
            bvh,
            sdf,
            params,
            seed,
            (refs, MIN_REFERENCE_VIEWS),
            reach,
            progress,
        )
    }

    /// The same measure (reference points, reached space, and views a
    /// sample needs) on fresh samples over `input`'s scene: those of
    /// `stream` of `input.seed`, as many as `params` asks.
    pub(crate) fn resampled(
        &self,
        input: &crate::probes::PlacementInput,
        params: &CoverageParams,
        stream: Stream,
    ) -> CoverageReference {
        CoverageReference::build(
            input.scene,
            input.bvh,
            input.sdf,
            params,
            stream.seed(input.seed),
            (self.references.clone(), self.need),
            self.reach.clone(),
            input.progress,
        )
    }

    /// The samples of `seed` and their coverability by `refs`, each
    /// coverable when `need` of them see it and it faces `reach` (when
    /// given).
    #[allow(clippy::too_many_arguments)]
    fn build(
        scene: &Scene,
        bvh: &SceneBvh,
        sdf: &Sdf,
        params: &CoverageParams,
        seed: u64,
        (refs, need): (Vec<Vec3>, usize),
        reach: Option<std::sync::Arc<Vec<bool>>>,
        progress: &Progress,
    ) -> CoverageReference {
        let mut reference = CoverageReference {
            samples: Vec::new(),
            coverable: Vec::new(),
            reference_points: refs.len(),
            references: Vec::new(),
            params: *params,
            reach,
            need,
            min_cos: params.max_incidence_deg.0.to_radians().cos(),
            eps: 1e-3 * sdf.voxel_size,
        };
        // Rounds of independent stratified samples until enough are coverable
        // for the interval bound (module docs), at most MAX_ROUNDS rounds.
        let target = params.samples.0 as usize;
        let bar = progress.bar("coverage: reference", target as u64);
        let mut batch = target;
        for round in 0..MAX_ROUNDS {
            bar.set_length((reference.samples.len() + batch) as u64);
            let samples = sample_surface(scene, batch, hash2(seed, 0xC0FE + round));
            let mut coverable = reference.seen_by_all(bvh, &samples, &refs, need, &bar);
            if let Some(reach) = &reference.reach {
                for (c, s) in coverable.iter_mut().zip(&samples) {
                    *c = *c && faces_reach(sdf, reach, s);
                }
            }
            reference.samples.extend(samples);
            reference.coverable.extend(coverable);
            let have = reference.coverable.iter().filter(|&&c| c).count();
            if have >= target || have == 0 {
                break;
            }
            let rate = have as f64 / reference.samples.len() as f64;
            batch = (((target - have) as f64 / rate) * 1.05).ceil() as usize;
        }
        bar.finish_and_clear();
        reference.references = refs;
        reference
    }

    /// Cosine of the largest incidence angle at which a sample counts as seen.
    pub fn min_cos(&self) -> f32 {
        self.min_cos
    }

    /// Whether `viewer` sees `sample` (module docs): the one rule behind
    /// every coverage figure.
    #[inline]
    pub fn sees(&self, bvh: &SceneBvh, viewer: Vec3, sample: &SurfaceSample) -> bool {
        self.sees_from(bvh, viewer, sample, &mut Blocker::default())
    }

    /// [`CoverageReference::sees`] for one of many viewers of the same
    /// `sample`, with the sample's `blocker` ([`SceneBvh::occluded_from`]):
    /// the same answer, found faster when one triangle hides the sample
    /// from many viewers.
    #[inline]
    pub fn sees_from(
        &self,
        bvh: &SceneBvh,
        viewer: Vec3,
        sample: &SurfaceSample,
        blocker: &mut Blocker,
    ) -> bool {
        self.faces(viewer, sample) && !bvh.occluded_from(sample.position, viewer, self.eps, blocker)
    }

    /// Whether `viewer` lies off `sample` and in front of it, within the
    /// incidence limit: the part of [`CoverageReference::sees`] that casts
    /// nothing.
    #[inline]
    pub(crate) fn faces(&self, viewer: Vec3, sample: &SurfaceSample) -> bool {
        let to_viewer = viewer - sample.position;
        let len = to_viewer.length();
        len > self.eps && sample.normal.dot(to_viewer) >= self.min_cos * len
    }

    /// For each sample, whether at least `need` of `viewers` see it: the
    /// viewers near it first ([`NearViewers`]; most samples are settled by
    /// them), then every other that it faces.
    pub(crate) fn seen_by_all(
        &self,
        bvh: &SceneBvh,
        samples: &[SurfaceSample],
        viewers: &[Vec3],
        need: usize,
        bar: &indicatif::ProgressBar,
    ) -> Vec<bool> {
        if viewers.is_empty() {
            return vec![false; samples.len()];
        }
        let near = NearViewers::new(viewers);
        let groups = ViewerGroups::new(viewers);
        // Judged in Morton order: neighbours in a chunk share the walls that
        // hide them from a viewer (the viewer's memory).
        let positions: Vec<Vec3> = samples.iter().map(|s| s.position).collect();
        let order = crate::sampling::morton_order(&positions);
        let ordered: Vec<SurfaceSample> = order.iter().map(|&i| samples[i]).collect();
        let per_chunk: Vec<Vec<bool>> = ordered
            .par_chunks(256)
            .map_init(
                || (vec![false; viewers.len()], vec![Blocker::default(); viewers.len()]),
                |(tried, memory), chunk| {
                let mut blocker = Blocker::default();
                let out: Vec<bool> = chunk
                    .iter()
                    .map(|s| {
                        let near = near.of(s.position);
                        let mut found = 0;
                        for &v in near {
                            let v = v as usize;
                            tried[v] = true;
                            if self.sees_between::<true>(bvh, viewers[v], s, &mut blocker, &mut memory[v]) {
                                found += 1;
                                if found >= need {
                                    break;
                                }
                            }
                        }
                        if found < need {
                            'groups: for group in groups.facing(s, self.min_cos) {
                                for &v in group {
                                    if !tried[v]
                                        && self.sees_between::<true>(bvh, viewers[v], s, &mut blocker, &mut memory[v])
                                    {
                                        found += 1;
                                        if found >= need {
                                            break 'groups;
                                        }
                                    }
                                }
                            }
                        }
                        for &v in near {
                            tried[v as usize] = false;
                        }
                        found >= need
                    })
                    .collect();
                bar.inc(out.len() as u64);
                out
            })
            .collect();
        let mut out = vec![false; samples.len()];
        for (&i, seen) in order.iter().zip(per_chunk.concat()) {
            out[i] = seen;
        }
        out
    }

    /// For each sample, whether one of `viewers` sees it, judged for the
    /// coverable samples only (false for the others): what a coverage
    /// figure and its holes need. A sample no reference point sees is
    /// the dearest to judge, every viewer that faces it tried in vain, and
    /// on a voxel world two in five were such.
    pub(crate) fn seen_where_coverable(
        &self,
        bvh: &SceneBvh,
        viewers: &[Vec3],
        bar: &indicatif::ProgressBar,
    ) -> Vec<bool> {
        let at: Vec<usize> = (0..self.samples.len()).filter(|&i| self.coverable[i]).collect();
        let judged: Vec<SurfaceSample> = at.iter().map(|&i| self.samples[i]).collect();
        // The bar counts the samples judged.
        bar.set_length(judged.len() as u64);
        let mut seen = vec![false; self.samples.len()];
        for (&i, s) in at.iter().zip(self.seen_by_all(bvh, &judged, viewers, 1, bar)) {
            seen[i] = s;
        }
        seen
    }

    /// [`CoverageReference::sees_from`] with a second memory, `near_viewer`,
    /// shared by segments to `viewer` ([`SceneBvh::occluded_between`]),
    /// its traversal nearest first with `NEAR_FIRST`: the same answer,
    /// found sooner for a sample that many viewers try in vain, as
    /// [`CoverageReference::seen_by_all`]'s uncoverable samples.
    #[inline]
    pub fn sees_between<const NEAR_FIRST: bool>(
        &self,
        bvh: &SceneBvh,
        viewer: Vec3,
        sample: &SurfaceSample,
        near_sample: &mut Blocker,
        near_viewer: &mut Blocker,
    ) -> bool {
        self.faces(viewer, sample)
            && !bvh.occluded_between::<NEAR_FIRST>(sample.position, viewer, self.eps, near_sample, near_viewer)
    }

    /// Coverage of the probes at `probes` (module docs).
    pub fn evaluate(&self, bvh: &SceneBvh, probes: &[Vec3], progress: &Progress) -> Coverage {
        self.evaluate_with_holes(bvh, probes, progress).0
    }

    /// [`CoverageReference::evaluate`], plus the coverable samples no probe
    /// sees (the holes), for pictures and later refinement.
    pub fn evaluate_with_holes(
        &self,
        bvh: &SceneBvh,
        probes: &[Vec3],
        progress: &Progress,
    ) -> (Coverage, Vec<Vec3>) {
        let bar = progress.bar("coverage: probes", self.samples.len() as u64);
        let seen = self.seen_where_coverable(bvh, probes, &bar);
        bar.finish_and_clear();
        let holes = self
            .samples
            .iter()
            .zip(self.coverable.iter().zip(&seen))
            .filter(|(_, (&c, &s))| c && !s)
            .map(|(sample, _)| sample.position)
            .collect();
        let coverable = self.coverable.iter().filter(|&&c| c).count();
        let covered = self
            .coverable
            .iter()
            .zip(&seen)
            .filter(|(&c, &s)| c && s)
            .count();
        let (p, ci95) = ratio_ci95(covered, coverable);
        let coverage = Coverage {
            coverage: p,
            ci95,
            samples: self.samples.len(),
            coverable_samples: coverable,
            covered_samples: covered,
            coverable_fraction: coverable as f64 / self.samples.len().max(1) as f64,
            reference_points: self.reference_points,
        };
        (coverage, holes)
    }
}

/// Counts probes in solid space (by [`stands_free`], the same verdict
/// under any seed), in voxels the run's SDF calls solid or outside the
/// scene, and outside the domain.
pub fn probe_health(bvh: &SceneBvh, sdf: &Sdf, domain: &Bounds, probes: &[Vec3]) -> ProbeHealth {
    probe_health_of(
        &probes_free(bvh, sdf.voxel_size, probes),
        sdf,
        domain,
        probes,
    )
}

/// [`stands_free`] of every probe, in parallel: the validity a lookup
/// that drops probes in solid reads (`stages::diffuse`).
pub fn probes_free(bvh: &SceneBvh, voxel_size: f32, probes: &[Vec3]) -> Vec<bool> {
    probes
        .par_iter()
        .map(|&p| stands_free(bvh, voxel_size, p))
        .collect()
}

/// [`probe_health`] with each probe's [`stands_free`] verdict given
/// (`free`, from [`probes_free`]), for a caller that needs them too.
pub fn probe_health_of(free: &[bool], sdf: &Sdf, domain: &Bounds, probes: &[Vec3]) -> ProbeHealth {
    let mut h = ProbeHealth {
        probes_in_solid: free.iter().filter(|&&f| !f).count(),
        probes_in_solid_sdf: 0,
        probes_outside_scene: 0,
        probes_outside_domain: 0,
    };
    for &p in probes {
        if !domain.contains(p) {
            h.probes_outside_domain += 1;
        }
        match sdf.voxel_at(p).map(|v| sdf.class[v]) {
            Some(VoxelClass::Solid) => h.probes_in_solid_sdf += 1,
            Some(VoxelClass::Outside) => h.probes_outside_scene += 1,
            _ => {}
        }
    }
    h
}

/// A reference over the given `samples`, every one coverable, at the
/// default incidence limit: for tests that count views of known samples.
#[cfg(test)]
pub(crate) fn reference_of(samples: Vec<SurfaceSample>) -> CoverageReference {
    let params = CoverageParams::default();
    CoverageReference {
        coverable: vec![true; samples.len()],
        samples,
        reference_points: 0,
        references: Vec::new(),
        params,
        reach: None,
        need: 1,
        min_cos: params.max_incidence_deg.0.to_radians().cos(),
        eps: 1e-4,
    }
}

/// A room of 0.25-unit voxels with its coverage reference (4000 samples,
/// seed 2), for the tests of the stages that read coverage.
#[cfg(test)]
pub(crate) fn test_room() -> (Scene, SceneBvh, Sdf, CoverageReference) {
    use crate::config::{Count, Degrees};
    let (scene, bvh, sdf) = crate::scene::testing::room_sdf(0.25, 2);
    let params = CoverageParams {
        samples: Count(4000),
        reference_points: Count(512),
        max_incidence_deg: Degrees(85.0),
    };
    let reference = CoverageReference::new(&scene, &bvh, &sdf, &params, 2, &Progress::hidden());
    (scene, bvh, sdf, reference)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::testing::room_with_box;

    fn setup() -> (Scene, SceneBvh, Sdf, CoverageReference) {
        test_room()
    }

    #[test]
    fn samples_are_area_uniform() {
        let scene = room_with_box();
        let samples = sample_surface(&scene, 20_000, 4);
        // The room's floor is 16 m² of the 96 + 5 m² total (the inner box's
        // bottom lies on the floor but is a separate 1 m² face).
        let total = scene.area();
        let on_room_floor = samples
            .iter()
            .filter(|s| s.position.y.abs() < 1e-5 && s.normal.y > 0.5)
            .count();
        let expected = 16.0 / total;
        let got = on_room_floor as f64 / samples.len() as f64;
        assert!((got - expected).abs() < 0.01, "{got} vs {expected}");
        assert_eq!(samples, sample_surface(&scene, 20_000, 4));
    }

    #[test]
    fn reference_reaches_its_target_and_excludes_hidden_faces() {
        let (scene, _, _, reference) = setup();
        let coverable = reference.coverable.iter().filter(|&&c| c).count();
        assert!(coverable >= 4000);
        // The inner box's bottom face lies on the floor: nobody sees it. Its
        // area (1 m²) over the total bounds the uncoverable share from below.
        let hidden = reference
            .samples
            .iter()
            .zip(&reference.coverable)
            .filter(|(s, &c)| !c && s.normal.y < -0.5 && s.position.y.abs() < 1e-5)
            .count();
        assert!(hidden > 0);
        let share = 1.0 - coverable as f64 / reference.samples.len() as f64;
        assert!(share > 0.5 / scene.area(), "{share}");
    }

    #[test]
    fn coverage_grows_with_probes_and_is_zero_from_inside_a_solid() {
        let (_, bvh, sdf, reference) = setup();
        let p = Progress::hidden();
        let inside_box = reference.evaluate(&bvh, &[Vec3::new(1.5, 0.5, 1.5)], &p);
        assert_eq!(inside_box.covered_samples, 0);
        let one = reference.evaluate(&bvh, &[Vec3::new(3.0, 2.0, 3.0)], &p);
        let (two, holes) = reference.evaluate_with_holes(
            &bvh,
            &[Vec3::new(3.0, 2.0, 3.0), Vec3::new(0.5, 0.5, 0.5)],
            &p,
        );
        assert!(one.coverage > 0.5 && one.coverage < 1.0, "{}", one.coverage);
        assert!(
            two.coverage > one.coverage,
            "{} vs {}",
            two.coverage,
            one.coverage
        );
        assert!(one.ci95 > 0.0 && one.ci95 < 0.02, "{}", one.ci95);
        assert_eq!(holes.len(), two.coverable_samples - two.covered_samples);
        let health = probe_health(
            &bvh,
            &sdf,
            &Bounds {
                min: Vec3::ZERO,
                max: Vec3::splat(4.0),
            },
            &[
                Vec3::new(1.5, 0.5, 1.5),
                Vec3::new(3.0, 2.0, 3.0),
                Vec3::splat(9.0),
            ],
        );
        assert_eq!(health.probes_in_solid, 1);
        assert_eq!(health.probes_in_solid_sdf, 1);
        assert!(!stands_free(&bvh, sdf.voxel_size, Vec3::new(1.5, 0.5, 1.5)));
        assert!(stands_free(&bvh, sdf.voxel_size, Vec3::new(3.0, 2.0, 3.0)));
        assert_eq!(health.probes_outside_domain, 1);
        assert_eq!(health.probes_outside_scene, 0);
    }

    /// A group is passed over only when the sample faces none of its
    /// viewers: every viewer that passes the facing test of
    /// [`CoverageReference::sees_from`] lies in a group
    /// [`ViewerGroups::facing`] yields, and some groups are passed over.
    #[test]
    fn viewer_groups_never_hide_a_viewer_a_sample_faces() {
        let (_, _, _, reference) = setup();
        let viewers: Vec<Vec3> = (0..700u64)
            .map(|i| {
                let u = |k| crate::sampling::unit_f32(hash2(i, k));
                Vec3::new(4.0 * u(1), 4.0 * u(2), 4.0 * u(3))
            })
            .collect();
        let groups = ViewerGroups::new(&viewers);
        let mut skipped = 0;
        for s in reference.samples.iter().step_by(7) {
            let offered: Vec<usize> = groups
                .facing(s, reference.min_cos)
                .flatten()
                .copied()
                .collect();
            skipped += viewers.len() - offered.len();
            for (k, &v) in viewers.iter().enumerate() {
                let to = v - s.position;
                if s.normal.dot(to) >= reference.min_cos * to.length() {
                    assert!(offered.contains(&k), "viewer {k} at {v} hidden from {s:?}");
                }
            }
        }
        assert!(skipped > 0, "no group was ever passed over");
    }

    /// Which viewers a sample tries first ([`NearViewers`]) changes only
    /// how soon it is settled: for viewer sets spread through the room,
    /// flat on one plane, clustered in a corner, and fewer than
    /// [`NEAREST_FIRST`], `seen_by_all` says a sample is seen by `need`
    /// viewers exactly when a scan of every viewer counts that many.
    #[test]
    fn seen_by_all_agrees_with_a_scan_of_every_viewer() {
        let (_, bvh, _, reference) = setup();
        let u = |i: u64, k: u64| crate::sampling::unit_f32(hash2(i, k));
        let spread: Vec<Vec3> = (0..300u64)
            .map(|i| Vec3::new(4.0 * u(i, 1), 4.0 * u(i, 2), 4.0 * u(i, 3)))
            .collect();
        let flat: Vec<Vec3> = (0..200u64)
            .map(|i| Vec3::new(4.0 * u(i, 4), 2.5, 4.0 * u(i, 5)))
            .collect();
        let corner: Vec<Vec3> = (0..100u64)
            .map(|i| Vec3::new(0.3 * u(i, 6), 0.3 * u(i, 7), 0.3 * u(i, 8)) + 0.2)
            .collect();
        let few: Vec<Vec3> = spread[..5].to_vec();
        let samples: Vec<SurfaceSample> = reference.samples.iter().step_by(5).copied().collect();
        let bar = indicatif::ProgressBar::hidden();
        for (name, viewers) in [
            ("spread", spread),
            ("flat", flat),
            ("corner", corner),
            ("few", few),
        ] {
            let views: Vec<usize> = samples
                .iter()
                .map(|s| {
                    viewers
                        .iter()
                        .filter(|&&v| reference.sees(&bvh, v, s))
                        .count()
                })
                .collect();
            for need in [1, 2, 3] {
                let got = reference.seen_by_all(&bvh, &samples, &viewers, need, &bar);
                let want: Vec<bool> = views.iter().map(|&n| n >= need).collect();
                assert_eq!(got, want, "{name}, need {need}");
                assert!(want.iter().any(|&w| w), "{name}: no sample seen");
            }
        }
    }
}
