//! Stage 1 (Wang et al. 2019 §3.1, "Signed Distance Function
//! Skeletonization"): a voxel grid over the probe domain holding, per voxel,
//! the distance to the nearest surface and a classification into free,
//! solid and outside-the-scene space.
//!
//! The paper builds its SDF with OpenVDB, which needs closed meshes for a
//! sign. Real assets are open, non-watertight and single-sided (Cornell walls
//! are single quads, Sponza has cracks), so the sign here comes from rays, the
//! rule used by RTXGI and Unity's probe volumes:
//!
//! * `rays_per_voxel` rays leave each voxel centre along a spherical Fibonacci
//!   set, randomly rotated per voxel (seeded, so reproducible);
//! * **solid** when more than `solid_backface_fraction` (default 0.25) of
//!   them first hit a back face: the centre is behind surfaces, inside an
//!   object or a wall;
//! * otherwise **outside the scene** when more than `outside_escape_fraction`
//!   (default 0.5) of them escape to infinity: the centre sees mostly sky,
//!   as above a roofless building or in front of the open Cornell box;
//! * otherwise **free**.
//!
//! A back face coplanar with a front face (within 0.001 voxel) wins the tie:
//! solids resting against walls and floors (a box's bottom on the floor, a
//! platform's side against a wall) would otherwise look open from inside
//! wherever the wall's front face happened to be returned first. The
//! exception is a two-sided sheet, the same triangle twice, once each way
//! (a zero-thickness partition): nothing is behind it, so its face towards
//! the ray wins ([`SceneBvh::closest_hit_prefer_back`]); rooms walled by
//! such sheets otherwise read as solid.
//!
//! Only one voxel in eight, those with even coordinates, is always
//! classified by rays. Any other voxel lies inside a cell of that lattice; if
//! the (up to 8) lattice voxels bracketing it agree, and no surface separates
//! it from them, it takes their class without casting its own rays. No
//! surface separates them when its distance to the nearest surface exceeds
//! a voxel diagonal, which settles most of the open space and the interiors
//! of thick solids; nearer a surface, when a short segment to each of them
//! crosses none ([`sees_corners`]), up to 8 segments of at most a voxel
//! diagonal in place of 8 to 32 rays that run until they hit. Only where
//! the corners disagree, or a surface passes between, is a voxel classified
//! by its own rays. Solid versus not solid matches the rays of every voxel
//! in a unit test; the statistical free/outside boundary, where the escape
//! share crosses its threshold, can shift by a voxel, and so can a voxel
//! whose rays fall either side of the back-face threshold (on the
//! configs, at most 11 voxels in one scene changed between solid and
//! free when segments were added: BENCHMARKS.md, "Sixth session").
//!
//! Two stages keep the rays themselves affordable: the first 8 directions
//! (spread over the whole sphere) are cast, and when every one of them hits a
//! front face the voxel is free at once, which settles the bulk of open space
//! in a quarter of the rays (a voxel seeing no back face in 8 directions
//! spread over the sphere is very unlikely to see one in more than a quarter
//! of all directions); otherwise all `rays_per_voxel` are cast, stopping
//! as soon as the outcome cannot change. The Fibonacci set is ordered along
//! its spiral, so the first octet is taken with a stride over the whole set.
//!
//! Distances are exact (point-to-triangle) within a band of 2 voxels of the
//! surfaces, and propagated elsewhere by jump flooding of nearest surface
//! points (Rong & Tan 2006), which keeps them Euclidean to within a small
//! fraction of a voxel. Solid voxels carry negative distances.

use crate::config::params::SdfParams;
use crate::error::{Error, Result};
use crate::progress::Progress;
use crate::sampling::{fibonacci_sphere, hash2, random_rotation};
use crate::scene::raycast::SceneBvh;
use crate::scene::{Bounds, Scene};
use glam::{IVec3, UVec3, Vec3};
use rayon::prelude::*;

/// Most voxels a grid may have: about 1.3 GB of working memory at the limit.
pub const MAX_VOXELS: u64 = 64_000_000;

/// What occupies a voxel's centre.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum VoxelClass {
    /// Empty space inside the scene: probes may go here.
    Free,
    /// Inside an object or wall (mostly back faces seen).
    Solid,
    /// Empty space outside the scene (mostly sky seen).
    Outside,
}

/// The signed distance field of the probe domain.
#[derive(Debug, Clone)]
pub struct Sdf {
    /// Lower corner of voxel (0,0,0).
    pub origin: Vec3,
    /// Edge length of a voxel.
    pub voxel_size: f32,
    /// Voxel count along x, y, z.
    pub dims: UVec3,
    /// Distance from each voxel centre to the nearest surface; negative when solid.
    pub distance: Vec<f32>,
    /// Classification of each voxel.
    pub class: Vec<VoxelClass>,
    /// Nearest surface point of each voxel centre (`None` only when the
    /// domain holds no surface at all). The skeleton reads its jumps.
    pub nearest: Vec<Option<Vec3>>,
}

impl Sdf {
    /// Distance below which [`Sdf::distance`] is exact (up to rounding):
    /// the band where it is computed point to triangle. Beyond it the
    /// jump-flooded distance may exceed the true one, which is then still
    /// at least this.
    pub fn exact_reach(&self) -> f32 {
        BAND * self.voxel_size
    }

    /// Linear index of voxel `v` (x fastest).
    pub fn index(&self, v: UVec3) -> usize {
        (v.x + self.dims.x * (v.y + self.dims.y * v.z)) as usize
    }

    /// Voxel coordinates of linear index `i`.
    pub fn coords(&self, i: usize) -> UVec3 {
        let i = i as u32;
        UVec3::new(
            i % self.dims.x,
            (i / self.dims.x) % self.dims.y,
            i / (self.dims.x * self.dims.y),
        )
    }

    /// World-space centre of voxel `i`.
    pub fn center(&self, i: usize) -> Vec3 {
        self.center_of(self.coords(i))
    }

    /// World-space centre of voxel `v`: [`Sdf::center`] of its index,
    /// without the divisions that find its coordinates.
    pub fn center_of(&self, v: UVec3) -> Vec3 {
        self.origin + (v.as_vec3() + 0.5) * self.voxel_size
    }

    /// The voxel containing `p`, or `None` outside the grid.
    pub fn voxel_at(&self, p: Vec3) -> Option<usize> {
        let c = ((p - self.origin) / self.voxel_size).floor();
        if !c.is_finite() || c.cmplt(Vec3::ZERO).any() || c.cmpge(self.dims.as_vec3()).any() {
            return None;
        }
        Some(self.index(c.as_uvec3()))
    }

    /// Coordinates of the voxel containing `p`, or of the border voxel
    /// nearest to it when `p` lies beyond the grid.
    pub fn nearest_voxel(&self, p: Vec3) -> UVec3 {
        ((p - self.origin) / self.voxel_size)
            .floor()
            .clamp(Vec3::ZERO, (self.dims - 1).as_vec3())
            .as_uvec3()
    }

    /// The class of every point of the cube of edge `edge` centred at
    /// `centre`, when the SDF proves no surface crosses it: the distance at
    /// the nearest voxel centre, less the way from there (distance is
    /// 1-Lipschitz), exceeds the cube's half diagonal. `None` when a surface
    /// may cross it. Centres beyond the grid read the border voxels.
    pub fn clear_cube_class(&self, centre: Vec3, edge: f32) -> Option<VoxelClass> {
        let i = self.index(self.nearest_voxel(centre));
        let clearance = self.distance[i].abs() - centre.distance(self.center(i));
        (clearance > 0.5 * 3f32.sqrt() * edge).then_some(self.class[i])
    }

    /// Number of voxels.
    pub fn len(&self) -> usize {
        (self.dims.x * self.dims.y * self.dims.z) as usize
    }

    /// Whether the grid has no voxel (never true for a built SDF).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The largest distance to a surface over free voxels (0 when none is
    /// free): the radius of the biggest empty ball centred in free space,
    /// i.e. the scale of the scene's largest room.
    pub fn largest_clearance(&self) -> f32 {
        self.class
            .iter()
            .zip(&self.distance)
            .filter(|(c, _)| **c == VoxelClass::Free)
            .map(|(_, d)| *d)
            .fold(0.0, f32::max)
    }

    /// Voxel counts per class: (free, solid, outside).
    pub fn class_counts(&self) -> (usize, usize, usize) {
        self.class.iter().fold((0, 0, 0), |(f, s, o), c| match c {
            VoxelClass::Free => (f + 1, s, o),
            VoxelClass::Solid => (f, s + 1, o),
            VoxelClass::Outside => (f, s, o + 1),
        })
    }
}

/// Grid dimensions for `domain` at `voxel_size`, or a user error naming
/// `voxel_size` when the grid would exceed [`MAX_VOXELS`].
pub fn grid_dims(domain: &Bounds, voxel_size: f32) -> Result<UVec3> {
    let n = (domain.size() / voxel_size).ceil().max(Vec3::ONE);
    let total = n.x as f64 * n.y as f64 * n.z as f64;
    if !total.is_finite() || total > MAX_VOXELS as f64 {
        return Err(Error::User(format!(
            "voxel_size: {} gives {total:.3e} voxels over a domain of {:.3} x {:.3} x {:.3} (limit {MAX_VOXELS}); use a larger voxel_size",
            crate::config::numbers::short(voxel_size),
            domain.size().x,
            domain.size().y,
            domain.size().z
        )));
    }
    Ok(n.as_uvec3())
}

/// Builds the SDF of `domain` (Wang et al. 2019 §3.1, first step of Fig. 2).
///
/// Contract: the grid starts at `domain.min` and covers it with cubic voxels
/// of edge `voxel_size` (the last layer may overhang `domain.max`);
/// classification follows the module's rule with `params`; the result depends
/// only on the inputs and `seed`, never on thread scheduling.
pub fn build(
    scene: &Scene,
    bvh: &SceneBvh,
    domain: &Bounds,
    voxel_size: f32,
    params: &SdfParams,
    seed: u64,
    progress: &Progress,
) -> Result<Sdf> {
    let dims = grid_dims(domain, voxel_size)?;
    let mut sdf = Sdf {
        origin: domain.min,
        voxel_size,
        dims,
        distance: Vec::new(),
        class: Vec::new(),
        nearest: Vec::new(),
    };
    sdf.nearest = nearest_surface_points(scene, &sdf);
    sdf.distance = (0..sdf.len())
        .into_par_iter()
        .map(|i| match sdf.nearest[i] {
            Some(p) => p.distance(sdf.center(i)),
            None => f32::INFINITY,
        })
        .collect();
    sdf.class = classify(&sdf, bvh, params, seed, progress);
    for (d, c) in sdf.distance.iter_mut().zip(&sdf.class) {
        if *c == VoxelClass::Solid {
            *d = -*d;
        }
    }
    Ok(sdf)
}

/// Edge of the cubic bricks that bin triangles for the exact band, in voxels.
const BRICK: u32 = 8;
/// Half-width of the exact band, in voxels.
const BAND: f32 = 2.0;
/// Voxels (a fraction of one) by which a triangle's band box is grown
/// before it is cut to whole voxel centres, so that rounding never drops a
/// centre the band reaches.
const SLACK: f32 = 0.01;

/// Nearest surface point of every voxel centre: exact within the band, then
/// jump flooding outward.
fn nearest_surface_points(scene: &Scene, sdf: &Sdf) -> Vec<Option<Vec3>> {
    let bricks = (sdf.dims + BRICK - 1) / BRICK;
    let brick_count = (bricks.x * bricks.y * bricks.z) as usize;
    let reach = BAND * sdf.voxel_size;
    // Triangles overlapping each brick (with the band around them).
    let mut bins: Vec<Vec<u32>> = vec![Vec::new(); brick_count];
    let brick_size = sdf.voxel_size * BRICK as f32;
    for (ti, t) in scene.triangles.iter().enumerate() {
        let lo = t[0].min(t[1]).min(t[2]) - reach;
        let hi = t[0].max(t[1]).max(t[2]) + reach;
        let b0 = ((lo - sdf.origin) / brick_size)
            .floor()
            .as_ivec3()
            .max(IVec3::ZERO);
        let b1 = ((hi - sdf.origin) / brick_size)
            .floor()
            .as_ivec3()
            .min(bricks.as_ivec3() - 1);
        for z in b0.z..=b1.z {
            for y in b0.y..=b1.y {
                for x in b0.x..=b1.x {
                    bins[(x as u32 + bricks.x * (y as u32 + bricks.y * z as u32)) as usize]
                        .push(ti as u32);
                }
            }
        }
    }
    let mut nearest: Vec<Option<Vec3>> = vec![None; sdf.len()];
    let per_brick: Vec<Vec<(usize, Vec3)>> = bins
        .par_iter()
        .enumerate()
        .map(|(b, tris)| {
            let mut out = Vec::new();
            if tris.is_empty() {
                return out;
            }
            let b = b as u32;
            let base = UVec3::new(
                b % bricks.x,
                (b / bricks.x) % bricks.y,
                b / (bricks.x * bricks.y),
            ) * BRICK;
            let end = (base + BRICK).min(sdf.dims);
            let size = end - base;
            let mut best: Vec<(f32, Option<Vec3>)> =
                vec![(reach * reach, None); (size.x * size.y * size.z) as usize];
            // Each triangle updates only the voxels whose centres lie in its
            // box grown by the band (and [`SLACK`] against rounding):
            // a centre outside it is farther than the band from the
            // triangle, so it could not have won. Triangles are visited in
            // index order and a strictly nearer point wins, as when every
            // voxel scanned every triangle of its brick.
            let lo_voxel = base.as_ivec3();
            let hi_voxel = end.as_ivec3() - 1;
            // The brick's voxel centres, as [`Sdf::center`] computes them,
            // once rather than once per triangle reaching them.
            let mut centres = Vec::with_capacity(best.len());
            for z in base.z..end.z {
                for y in base.y..end.y {
                    for x in base.x..end.x {
                        let v = UVec3::new(x, y, z);
                        centres.push(sdf.origin + (v.as_vec3() + 0.5) * sdf.voxel_size);
                    }
                }
            }
            for &ti in tris {
                let t = &scene.triangles[ti as usize];
                let tri = EdgedTriangle::new(t);
                let lo = (t[0].min(t[1]).min(t[2]) - reach - sdf.origin) / sdf.voxel_size - 0.5;
                let hi = (t[0].max(t[1]).max(t[2]) + reach - sdf.origin) / sdf.voxel_size - 0.5;
                let v0 = (lo - SLACK).ceil().as_ivec3().max(lo_voxel) - lo_voxel;
                let v1 = (hi + SLACK).floor().as_ivec3().min(hi_voxel) - lo_voxel;
                for z in v0.z..=v1.z {
                    for y in v0.y..=v1.y {
                        let row = (size.x * (y as u32 + size.y * z as u32)) as usize;
                        for x in v0.x..=v1.x {
                            let l = row + x as usize;
                            let c = centres[l];
                            let q = tri.closest_point(c);
                            let d2 = q.distance_squared(c);
                            let slot = &mut best[l];
                            if d2 < slot.0 {
                                *slot = (d2, Some(q));
                            }
                        }
                    }
                }
            }
            for z in base.z..end.z {
                for y in base.y..end.y {
                    for x in base.x..end.x {
                        let l = UVec3::new(x, y, z) - base;
                        if let (_, Some(q)) = best[(l.x + size.x * (l.y + size.y * l.z)) as usize] {
                            out.push((sdf.index(UVec3::new(x, y, z)), q));
                        }
                    }
                }
            }
            out
        })
        .collect();
    for (i, q) in per_brick.into_iter().flatten() {
        nearest[i] = Some(q);
    }
    jump_flood(sdf, nearest)
}

/// Jump flooding: each pass, every voxel adopts the nearest of the surface
/// points known to its 26 neighbours at offset `step`, halving `step` down to
/// 1, then one extra pass at 1 (JFA+1) to mend most of its rare errors.
/// Voxels of the exact band (those `nearest` holds a point for) keep theirs:
/// it is the nearest point of every triangle, so no neighbour's is nearer.
fn jump_flood(sdf: &Sdf, mut nearest: Vec<Option<Vec3>>) -> Vec<Option<Vec3>> {
    let exact: Vec<bool> = nearest.iter().map(Option::is_some).collect();
    let max_dim = sdf.dims.max_element();
    let mut steps = Vec::new();
    let mut step = max_dim.next_power_of_two() / 2;
    while step >= 1 {
        steps.push(step);
        step /= 2;
    }
    steps.push(1);
    let dims = sdf.dims.as_ivec3();
    let mut next: Vec<Option<Vec3>> = vec![None; sdf.len()];
    // A row of voxels (fixed y and z) per task: each voxel's centre and
    // coordinates follow from its place in the row, without the divisions
    // of [`Sdf::coords`], and the neighbour rows inside the grid are found
    // once per row, leaving one bounds test per neighbour (x) in the voxel
    // loop. The neighbours are tried in the same order as a scan of the
    // 3×3×3 block, so ties go to the same point (a test compares the two;
    // on Dabrovic Sponza the passes took about 0.85× as long).
    for step in steps {
        let s = step as i32;
        let from = &nearest;
        next.par_chunks_mut(sdf.dims.x as usize)
            .enumerate()
            .for_each(|(r, row)| {
                let (y, z) = ((r as i32) % dims.y, (r as i32) / dims.y);
                // The neighbour rows within the grid, in the order the
                // neighbours are tried (z, then y, then x, each from −s to
                // +s: the first of equally near points wins).
                let mut rows = [(0usize, 0i32); 9];
                let mut n_rows = 0;
                for dz in -1..=1 {
                    for dy in -1..=1 {
                        let (ny, nz) = (y + dy * s, z + dz * s);
                        if ny < 0 || ny >= dims.y || nz < 0 || nz >= dims.z {
                            continue;
                        }
                        rows[n_rows] = ((ny + dims.y * nz) as usize * dims.x as usize, dy | dz);
                        n_rows += 1;
                    }
                }
                let own = r * dims.x as usize;
                let cy = sdf.origin.y + (y as f32 + 0.5) * sdf.voxel_size;
                let cz = sdf.origin.z + (z as f32 + 0.5) * sdf.voxel_size;
                for (x, out) in row.iter_mut().enumerate() {
                    let i = own + x;
                    if exact[i] {
                        *out = from[i];
                        continue;
                    }
                    let c = Vec3::new(sdf.origin.x + (x as f32 + 0.5) * sdf.voxel_size, cy, cz);
                    let mut best = from[i];
                    let mut best_d2 = best.map_or(f32::INFINITY, |q| q.distance_squared(c));
                    let x = x as i32;
                    for &(base, off_row) in &rows[..n_rows] {
                        for dx in -1..=1 {
                            let nx = x + dx * s;
                            // The voxel itself holds `best` already.
                            if nx < 0 || nx >= dims.x || (dx == 0 && off_row == 0) {
                                continue;
                            }
                            if let Some(q) = from[base + nx as usize] {
                                let d2 = q.distance_squared(c);
                                if d2 < best_d2 {
                                    best_d2 = d2;
                                    best = Some(q);
                                }
                            }
                        }
                    }
                    *out = best;
                }
            });
        std::mem::swap(&mut nearest, &mut next);
    }
    nearest
}

/// Rays of the first stage: when all of them hit front faces, the voxel is
/// free without casting the rest (module docs).
const FIRST_STAGE_RAYS: usize = 8;

/// Voxels per tick of the classification's progress bar.
const PROGRESS_STEP: usize = 4096;

/// Classifies every voxel (module docs): first the voxels with even
/// coordinates by rays, then each other voxel by inheriting the class its
/// lattice corners agree on when no surface can lie between them, by rays
/// otherwise.
fn classify(
    sdf: &Sdf,
    bvh: &SceneBvh,
    params: &SdfParams,
    seed: u64,
    progress: &Progress,
) -> Vec<VoxelClass> {
    let rays = RayClassifier::new(sdf, params, seed);
    // The bar counts each pass over the voxels, a step at a time: a tick
    // per voxel read the clock and bounced the bar's counter between the
    // cores hundreds of thousands of times.
    let bar = progress.bar("sdf: classify voxels", 2 * sdf.len() as u64);
    let tick = |i: usize| {
        if i.is_multiple_of(PROGRESS_STEP) {
            bar.inc(PROGRESS_STEP.min(sdf.len() - i) as u64);
        }
    };
    let lattice: Vec<Option<VoxelClass>> = (0..sdf.len())
        .into_par_iter()
        .with_min_len(256)
        .map(|i| {
            tick(i);
            let on_lattice = sdf.coords(i).to_array().iter().all(|c| c % 2 == 0);
            on_lattice.then(|| rays.classify(bvh, i))
        })
        .collect();
    // A centre farther than this from every surface sees all its lattice
    // corners (at most one voxel diagonal away) without crossing a surface.
    let reach = 3f32.sqrt() * sdf.voxel_size;
    let classes = (0..sdf.len())
        .into_par_iter()
        .with_min_len(256)
        .map(|i| {
            tick(i);
            if let Some(class) = lattice[i] {
                return class;
            }
            let Some((corners, n)) = lattice_corners(sdf, i) else {
                return rays.classify(bvh, i);
            };
            let corners = &corners[..n];
            match agreed_corner_class(&lattice, corners) {
                Some(class) if sdf.distance[i] > reach || sees_corners(sdf, bvh, i, corners) => {
                    class
                }
                _ => rays.classify(bvh, i),
            }
        })
        .collect();
    bar.finish_and_clear();
    classes
}

/// The lattice voxels bracketing voxel `i` (per axis: the coordinate itself
/// when even, its two odd neighbours' even neighbours otherwise), each
/// once: the first `n` of the array returned; `None` when the grid edge
/// cuts the bracket.
fn lattice_corners(sdf: &Sdf, i: usize) -> Option<([usize; 8], usize)> {
    let v = sdf.coords(i);
    let bracket = |c: u32, n: u32| -> Option<std::iter::StepBy<std::ops::RangeInclusive<u32>>> {
        if c.is_multiple_of(2) {
            Some((c..=c).step_by(2))
        } else if c + 1 < n {
            Some((c - 1..=c + 1).step_by(2))
        } else {
            None
        }
    };
    let (xs, ys, zs) = (
        bracket(v.x, sdf.dims.x)?,
        bracket(v.y, sdf.dims.y)?,
        bracket(v.z, sdf.dims.z)?,
    );
    let mut out = [0; 8];
    let mut n = 0;
    for z in zs {
        for y in ys.clone() {
            for x in xs.clone() {
                out[n] = sdf.index(UVec3::new(x, y, z));
                n += 1;
            }
        }
    }
    Some((out, n))
}

/// The class shared by all the lattice voxels `corners`, or `None` when
/// they disagree.
fn agreed_corner_class(lattice: &[Option<VoxelClass>], corners: &[usize]) -> Option<VoxelClass> {
    let mut agreed = None;
    for &j in corners {
        let class = lattice[j]?;
        if agreed.is_some_and(|a| a != class) {
            return None;
        }
        agreed = Some(class);
    }
    agreed
}

/// Whether voxel `i`'s centre sees the centres of the lattice voxels
/// `corners` along segments that cross no surface, and lies off every
/// surface: then no surface separates it from them, as when its distance
/// proves it, and a short segment each costs less than its own
/// classification rays.
fn sees_corners(sdf: &Sdf, bvh: &SceneBvh, i: usize, corners: &[usize]) -> bool {
    let eps = 1e-3 * sdf.voxel_size;
    let c = sdf.center(i);
    sdf.distance[i] > eps
        && corners
            .iter()
            .all(|&j| !bvh.occluded(c, sdf.center(j), eps))
}

/// The ray rule of the module docs at any point, on the grid or off it:
/// the one rule behind every verdict of solid, free and outside, shared by
/// the SDF (per voxel centre) and the coverage measure, which judges its
/// reference points and the final probes with its own rays rather than by
/// the SDF's voxels ([`crate::coverage`]).
pub struct RayRule {
    directions: Vec<Vec3>,
    solid_limit: f32,
    outside_limit: f32,
    /// Hits closer than this are the surface the point lies on: skipped.
    tmin: f32,
    /// Coplanar front/back pairs within this distance count as back faces.
    tie: f32,
}

impl RayRule {
    /// `rays` rays, solid above `solid_fraction` of back-face hits, outside
    /// above `outside_fraction` of escapes; `voxel_size` scales the
    /// tolerances.
    pub fn new(rays: u32, solid_fraction: f32, outside_fraction: f32, voxel_size: f32) -> RayRule {
        RayRule {
            directions: interleaved(fibonacci_sphere(rays), FIRST_STAGE_RAYS),
            solid_limit: solid_fraction * rays as f32,
            outside_limit: outside_fraction * rays as f32,
            tmin: 1e-4 * voxel_size,
            tie: 1e-3 * voxel_size,
        }
    }

    /// The SDF's rule for `params`.
    pub fn of(params: &SdfParams, voxel_size: f32) -> RayRule {
        RayRule::new(
            params.rays_per_voxel.0,
            params.solid_backface_fraction.0,
            params.outside_escape_fraction.0,
            voxel_size,
        )
    }

    /// Classifies the point `c` by casting the rule's rays, turned by
    /// `rot`, from it.
    pub fn classify(&self, bvh: &SceneBvh, c: Vec3, rot: glam::Mat3) -> VoxelClass {
        let n = self.directions.len();
        let (mut back, mut escaped) = (0u32, 0u32);
        for (k, d) in self.directions.iter().enumerate() {
            match bvh.closest_hit_prefer_back(c, rot * *d, self.tmin, f32::INFINITY, self.tie) {
                Some(h) if h.backface => back += 1,
                Some(_) => {}
                None => escaped += 1,
            }
            if back as f32 > self.solid_limit {
                return VoxelClass::Solid;
            }
            let cast = k + 1;
            // First stage: a unanimous first octet of front-face hits settles free space.
            if cast == FIRST_STAGE_RAYS && back == 0 && escaped == 0 {
                return VoxelClass::Free;
            }
            // Decided when no remaining ray can change the outcome.
            let left = (n - cast) as f32;
            if back as f32 + left <= self.solid_limit
                && (escaped as f32 > self.outside_limit
                    || escaped as f32 + left <= self.outside_limit)
            {
                break;
            }
        }
        if escaped as f32 > self.outside_limit {
            VoxelClass::Outside
        } else {
            VoxelClass::Free
        }
    }
}

/// The per-voxel ray rule of the module docs: [`RayRule`] at each voxel
/// centre, turned by a rotation seeded per voxel.
struct RayClassifier<'a> {
    sdf: &'a Sdf,
    seed: u64,
    rule: RayRule,
}

impl<'a> RayClassifier<'a> {
    fn new(sdf: &'a Sdf, params: &SdfParams, seed: u64) -> Self {
        RayClassifier {
            sdf,
            seed,
            rule: RayRule::of(params, sdf.voxel_size),
        }
    }

    /// Classifies voxel `i` by casting rays from its centre.
    fn classify(&self, bvh: &SceneBvh, i: usize) -> VoxelClass {
        let rot = random_rotation(hash2(self.seed, i as u64));
        self.rule.classify(bvh, self.sdf.center(i), rot)
    }
}

/// Reorders `dirs` so that its first `k` entries stride across the whole
/// list (the Fibonacci set runs pole to pole, so a prefix would be one cap).
fn interleaved(dirs: Vec<Vec3>, k: usize) -> Vec<Vec3> {
    let stride = (dirs.len() / k).max(1);
    (0..stride)
        .flat_map(|offset| dirs.iter().skip(offset).step_by(stride).copied())
        .collect()
}

/// The point of triangle `t` nearest to `p` (Ericson, Real-Time Collision
/// Detection §5.1.5).
pub fn closest_point_on_triangle(p: Vec3, t: &[Vec3; 3]) -> Vec3 {
    EdgedTriangle::new(t).closest_point(p)
}

/// A triangle with the two edges [`closest_point_on_triangle`] starts from,
/// taken once for the many voxel centres of its band (the same values it
/// would take for each).
#[derive(Clone, Copy)]
struct EdgedTriangle {
    a: Vec3,
    b: Vec3,
    c: Vec3,
    ab: Vec3,
    ac: Vec3,
}

impl EdgedTriangle {
    fn new(t: &[Vec3; 3]) -> EdgedTriangle {
        let (a, b, c) = (t[0], t[1], t[2]);
        EdgedTriangle {
            a,
            b,
            c,
            ab: b - a,
            ac: c - a,
        }
    }

    /// [`closest_point_on_triangle`] (Ericson §5.1.5).
    #[inline]
    fn closest_point(&self, p: Vec3) -> Vec3 {
        let EdgedTriangle { a, b, c, ab, ac } = *self;
        let ap = p - a;
        let d1 = ab.dot(ap);
        let d2 = ac.dot(ap);
        if d1 <= 0.0 && d2 <= 0.0 {
            return a;
        }
        let bp = p - b;
        let d3 = ab.dot(bp);
        let d4 = ac.dot(bp);
        if d3 >= 0.0 && d4 <= d3 {
            return b;
        }
        let vc = d1 * d4 - d3 * d2;
        if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
            return a + ab * (d1 / (d1 - d3));
        }
        let cp = p - c;
        let d5 = ab.dot(cp);
        let d6 = ac.dot(cp);
        if d6 >= 0.0 && d5 <= d6 {
            return c;
        }
        let vb = d5 * d2 - d1 * d6;
        if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
            return a + ac * (d2 / (d2 - d6));
        }
        let va = d3 * d6 - d5 * d4;
        if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
            return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
        }
        let denom = 1.0 / (va + vb + vc);
        a + ab * (vb * denom) + ac * (vc * denom)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::{Count, Fraction};
    use crate::scene::testing::{add_box, room_sdf};

    fn build_room(voxel: f32) -> Sdf {
        room_sdf(voxel, 1).2
    }

    #[test]
    fn classifies_free_solid_and_distances() {
        let sdf = build_room(0.25);
        assert_eq!(sdf.dims, UVec3::splat(16));
        let at = |p: Vec3| sdf.voxel_at(p).unwrap();
        // Inside the inner box: solid with negative distance ~ 0.375 to its faces.
        let inside = at(Vec3::new(1.6, 0.6, 1.6));
        assert_eq!(sdf.class[inside], VoxelClass::Solid);
        assert!(sdf.distance[inside] < 0.0);
        // Room centre above the box: free, exact distance to the nearest wall.
        let free = at(Vec3::new(3.1, 3.1, 3.1));
        assert_eq!(sdf.class[free], VoxelClass::Free);
        let c = sdf.center(free);
        let exact = (4.0 - c.x).min(4.0 - c.y).min(4.0 - c.z);
        assert!(
            (sdf.distance[free] - exact).abs() < 1e-4,
            "{} vs {exact}",
            sdf.distance[free]
        );
        // Far from surfaces (propagated by jump flooding): within 2% of exact.
        // Centre (2.875, 2.625, 2.875): nearest are the +x and +z walls, 1.125 away.
        let mid = at(Vec3::new(2.9, 2.6, 2.9));
        assert!(
            (sdf.distance[mid] - 1.125).abs() < 0.02,
            "{}",
            sdf.distance[mid]
        );
        let (free_n, solid_n, outside_n) = sdf.class_counts();
        // The inner box is 1 m³ = 64 voxels.
        assert_eq!(solid_n, 64);
        assert_eq!(outside_n, 0);
        assert_eq!(free_n, 16 * 16 * 16 - 64);
    }

    /// Jump flooding as its doc states it, voxel by voxel over all 26
    /// neighbours with bounds checks: the twin [`jump_flood`]'s row-wise
    /// loops must match bit for bit.
    fn jump_flood_by_voxel(sdf: &Sdf, mut nearest: Vec<Option<Vec3>>) -> Vec<Option<Vec3>> {
        let exact: Vec<bool> = nearest.iter().map(Option::is_some).collect();
        let mut steps = Vec::new();
        let mut step = sdf.dims.max_element().next_power_of_two() / 2;
        while step >= 1 {
            steps.push(step as i32);
            step /= 2;
        }
        steps.push(1);
        let dims = sdf.dims.as_ivec3();
        for s in steps {
            let next: Vec<Option<Vec3>> = (0..sdf.len())
                .map(|i| {
                    if exact[i] {
                        return nearest[i];
                    }
                    let v = sdf.coords(i).as_ivec3();
                    let c = sdf.center(i);
                    let mut best = nearest[i];
                    let mut best_d2 = best.map_or(f32::INFINITY, |q| q.distance_squared(c));
                    for dz in -1..=1 {
                        for dy in -1..=1 {
                            for dx in -1..=1 {
                                let n = v + IVec3::new(dx, dy, dz) * s;
                                if n.cmplt(IVec3::ZERO).any() || n.cmpge(dims).any() {
                                    continue;
                                }
                                if let Some(q) = nearest[sdf.index(n.as_uvec3())] {
                                    let d2 = q.distance_squared(c);
                                    if d2 < best_d2 {
                                        best_d2 = d2;
                                        best = Some(q);
                                    }
                                }
                            }
                        }
                    }
                    best
                })
                .collect();
            nearest = next;
        }
        nearest
    }

    #[test]
    fn jump_flood_rows_match_the_voxel_by_voxel_rule() {
        for seed in 0..4u64 {
            let pick = |k: u64, n: u64| hash2(seed, k) % n;
            let dims = UVec3::new(
                3 + pick(u64::MAX, 20) as u32,
                3 + pick(u64::MAX - 1, 20) as u32,
                3 + pick(u64::MAX - 2, 20) as u32,
            );
            let sdf = Sdf {
                origin: Vec3::new(-3.0, 0.5, 7.0),
                voxel_size: 0.3,
                dims,
                distance: Vec::new(),
                class: Vec::new(),
                nearest: Vec::new(),
            };
            // Sparse seeds on a coarse lattice, so that many voxels are
            // equally near two of them and the tie rule is exercised.
            let seeds: Vec<Option<Vec3>> = (0..sdf.len())
                .map(|i| {
                    (pick(i as u64, 40) == 0).then(|| {
                        let p = sdf.center(i) + Vec3::splat(0.15);
                        (p * 2.0).round() / 2.0
                    })
                })
                .collect();
            assert_eq!(
                jump_flood(&sdf, seeds.clone()),
                jump_flood_by_voxel(&sdf, seeds),
                "seed {seed}, dims {dims}"
            );
        }
    }

    /// The SDF (default parameters) of the triangles `tris` over their
    /// bounds, at `voxel` and `seed`.
    fn sdf_of(tris: Vec<[Vec3; 3]>, voxel: f32, seed: u64) -> Sdf {
        let scene =
            Scene::from_triangles("test".into(), tris.into_iter().map(|t| (t, 0)), vec![]).unwrap();
        let bvh = SceneBvh::new(&scene);
        let params = SdfParams::default();
        build(
            &scene,
            &bvh,
            &scene.bounds,
            voxel,
            &params,
            seed,
            &Progress::hidden(),
        )
        .unwrap()
    }

    #[test]
    fn solids_against_walls_stay_solid() {
        // A box in the room's corner shares three coplanar faces with the
        // floor and two walls: from inside it, those walls' front faces tie
        // with the box's back faces.
        let mut tris = Vec::new();
        add_box(&mut tris, Vec3::ZERO, Vec3::splat(4.0), true);
        add_box(&mut tris, Vec3::ZERO, Vec3::splat(1.0), false);
        let sdf = sdf_of(tris, 0.25, 9);
        let inside: Vec<usize> = (0..sdf.len())
            .filter(|&i| sdf.center(i).max_element() < 1.0)
            .collect();
        assert_eq!(inside.len(), 64);
        let free: Vec<Vec3> = inside
            .iter()
            .filter(|&&i| sdf.class[i] != VoxelClass::Solid)
            .map(|&i| sdf.center(i))
            .collect();
        assert!(
            free.is_empty(),
            "voxels inside the corner box not solid: {free:?}"
        );
    }

    #[test]
    fn rooms_divided_by_two_sided_sheets_stay_free() {
        // A closed room cut into four by two zero-thickness partitions, each
        // the same two triangles twice, once each way (a two-sided sheet),
        // and a box resting on the floor against a partition: the rooms
        // are free space right up to the sheets, the box stays solid.
        let mut tris = Vec::new();
        add_box(&mut tris, Vec3::ZERO, Vec3::splat(4.0), true);
        let sheet = |tris: &mut Vec<[Vec3; 3]>, q: [Vec3; 4]| {
            for t in [[q[0], q[1], q[2]], [q[0], q[2], q[3]]] {
                tris.push(t);
                tris.push([t[0], t[2], t[1]]);
            }
        };
        let x = 2.0;
        sheet(
            &mut tris,
            [
                Vec3::new(x, 0.0, 0.0),
                Vec3::new(x, 4.0, 0.0),
                Vec3::new(x, 4.0, 4.0),
                Vec3::new(x, 0.0, 4.0),
            ],
        );
        let z = 2.4;
        sheet(
            &mut tris,
            [
                Vec3::new(0.0, 0.0, z),
                Vec3::new(4.0, 0.0, z),
                Vec3::new(4.0, 4.0, z),
                Vec3::new(0.0, 4.0, z),
            ],
        );
        add_box(
            &mut tris,
            Vec3::new(2.8, 0.0, 2.4),
            Vec3::new(3.8, 1.0, 3.4),
            false,
        );
        let sdf = sdf_of(tris, 0.2, 5);
        let in_box = |c: Vec3| {
            c.cmpgt(Vec3::new(2.8, 0.0, 2.4)).all() && c.cmplt(Vec3::new(3.8, 1.0, 3.4)).all()
        };
        let (mut box_voxels, mut wrong) = (0, Vec::new());
        for i in 0..sdf.len() {
            let c = sdf.center(i);
            let expected = if in_box(c) {
                box_voxels += 1;
                VoxelClass::Solid
            } else {
                VoxelClass::Free
            };
            if sdf.class[i] != expected {
                wrong.push((c, sdf.class[i]));
            }
        }
        assert_eq!(box_voxels, 5 * 5 * 5);
        assert!(
            wrong.is_empty(),
            "{} voxels misread: {:?}",
            wrong.len(),
            &wrong[..wrong.len().min(8)]
        );
    }

    #[test]
    fn lattice_inheritance_matches_direct_rays_on_solidity() {
        let (_, bvh, sdf) = room_sdf(0.2, 3);
        let rays = RayClassifier::new(&sdf, &SdfParams::default(), 3);
        for i in 0..sdf.len() {
            let direct = rays.classify(&bvh, i);
            assert_eq!(
                direct == VoxelClass::Solid,
                sdf.class[i] == VoxelClass::Solid,
                "voxel {} at {}",
                i,
                sdf.center(i)
            );
        }
    }

    #[test]
    fn open_sky_is_outside() {
        // Just a floor: voxels above it see half sky and half floor front; at
        // 0.5 the rule needs "more than half" to escape, so lift the domain.
        let mut tris = Vec::new();
        add_box(
            &mut tris,
            Vec3::new(0.0, -1.0, 0.0),
            Vec3::new(4.0, 0.0, 4.0),
            false,
        );
        let scene =
            Scene::from_triangles("f".into(), tris.into_iter().map(|t| (t, 0)), vec![]).unwrap();
        let bvh = SceneBvh::new(&scene);
        let domain = Bounds {
            min: Vec3::new(0.0, 1.0, 0.0),
            max: Vec3::new(4.0, 3.0, 4.0),
        };
        let params = SdfParams {
            rays_per_voxel: Count(64),
            solid_backface_fraction: Fraction(0.25),
            outside_escape_fraction: Fraction(0.5),
        };
        let sdf = build(&scene, &bvh, &domain, 0.5, &params, 3, &Progress::hidden()).unwrap();
        let (_, solid, outside) = sdf.class_counts();
        assert_eq!(solid, 0);
        assert!(
            outside as f32 > 0.9 * sdf.len() as f32,
            "{outside} of {}",
            sdf.len()
        );
    }

    #[test]
    fn deterministic_for_a_seed() {
        let a = build_room(0.5);
        let b = build_room(0.5);
        assert_eq!(a.distance, b.distance);
        assert_eq!(a.class, b.class);
    }

    #[test]
    fn huge_grids_are_refused_naming_voxel_size() {
        let d = Bounds {
            min: Vec3::ZERO,
            max: Vec3::splat(100.0),
        };
        match grid_dims(&d, 0.01) {
            Err(Error::User(m)) => assert!(m.starts_with("voxel_size"), "{m}"),
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn first_stage_directions_span_the_sphere() {
        let d = interleaved(fibonacci_sphere(32), 8);
        assert_eq!(d.len(), 32);
        let first: Vec3 = d[..8].iter().copied().sum::<Vec3>() / 8.0;
        assert!(first.length() < 0.25, "first octet is lopsided: {first}");
        assert!(d[..8].iter().any(|v| v.y > 0.5) && d[..8].iter().any(|v| v.y < -0.5));
    }

    #[test]
    fn closest_point_regions() {
        let t = [Vec3::ZERO, Vec3::X, Vec3::Y];
        let inside = closest_point_on_triangle(Vec3::new(0.2, 0.2, 1.0), &t);
        assert!((inside - Vec3::new(0.2, 0.2, 0.0)).length() < 1e-6);
        assert_eq!(
            closest_point_on_triangle(Vec3::new(-1.0, -1.0, 0.0), &t),
            Vec3::ZERO
        );
        assert_eq!(
            closest_point_on_triangle(Vec3::new(2.0, -0.1, 0.0), &t),
            Vec3::X
        );
        let e = closest_point_on_triangle(Vec3::new(1.0, 1.0, 0.0), &t);
        assert!((e - Vec3::new(0.5, 0.5, 0.0)).length() < 1e-6);
    }
}
