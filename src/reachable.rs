//! The free space a viewer can reach: the voxels of the SDF connected to
//! the cameras (or to points a user names) through free space, never
//! through geometry. Without any seed nothing says which part a viewer
//! reaches, and all open space counts: a guess (the largest region, say)
//! would flip between regions of similar size as the seed moves the voxel
//! grid, and move the coverage of a placement with it.
//!
//! Why: a probe, a coverage sample or an irradiance receiver in a sealed
//! void (the cavity behind a wall panel, the inside of a hollow column)
//! serves nothing a player sees, and users call such probes waste
//! (godot-proposals #7900, #7282). Wang et al. 2019 §3.1 place on the
//! skeleton of all free space, sealed or not; this stage tells the two
//! apart.
//!
//! Two neighbouring voxels (six-connected) are joined when neither is
//! solid ([`VoxelClass::Solid`]) and no surface crosses the segment
//! between their centres: proved by the distance field alone when the two
//! distances sum to more than the segment's length (a surface crossing it
//! at `t` from one end would lie within `t` of that end and `h − t` of the
//! other), and otherwise decided by a ray over the segment lengthened by
//! a thousandth at each end (a wall through a voxel centre blocks both of
//! its sides). A gap narrower than about a voxel may therefore close; a
//! wall thinner than a voxel never opens.

use crate::scene::raycast::SceneBvh;
use crate::sdf::{Sdf, VoxelClass};
use glam::{UVec3, Vec3};
use rayon::prelude::*;
use std::collections::VecDeque;

/// The reachable voxels of an SDF.
#[derive(Debug, Clone)]
pub struct Reachable {
    /// One flag per SDF voxel, in [`Sdf::index`] order.
    pub mask: Vec<bool>,
    /// Voxels that are not solid.
    pub open_voxels: usize,
    /// Open voxels reached.
    pub reached_voxels: usize,
    /// Seeds that stood in an open voxel (or next to one) and started the
    /// flood; 0 when none did and all open space counts.
    pub seeds_used: usize,
}

impl Reachable {
    /// Whether `p` lies in a reached voxel (`false` beyond the grid).
    pub fn contains(&self, sdf: &Sdf, p: Vec3) -> bool {
        sdf.voxel_at(p).is_some_and(|i| self.mask[i])
    }

    /// Whether `p` lies in open space that is not reached (a sealed void,
    /// a region cut off): `false` in solid and beyond the grid.
    pub fn excludes(&self, sdf: &Sdf, p: Vec3) -> bool {
        sdf.voxel_at(p)
            .is_some_and(|i| !self.mask[i] && sdf.class[i] != VoxelClass::Solid)
    }

    /// Share of the open voxels that no seed reaches: sealed voids and
    /// regions cut off by geometry.
    pub fn excluded_fraction(&self) -> f64 {
        if self.open_voxels == 0 {
            0.0
        } else {
            1.0 - self.reached_voxels as f64 / self.open_voxels as f64
        }
    }
}

/// Bit `a` of a voxel's passable edges: to its `+x`, `+y`, `+z` neighbour.
fn edges(sdf: &Sdf, bvh: &SceneBvh, open: &[bool]) -> Vec<u8> {
    let h = sdf.voxel_size;
    let dims = sdf.dims;
    (0..sdf.len())
        .into_par_iter()
        .map(|i| {
            if !open[i] {
                return 0u8;
            }
            let v = sdf.coords(i);
            let mut bits = 0u8;
            for axis in 0..3 {
                let mut w = v;
                w[axis] += 1;
                if w[axis] >= dims[axis] {
                    continue;
                }
                let j = sdf.index(w);
                if !open[j] {
                    continue;
                }
                // The segment is lengthened a little at both ends: a wall
                // through a voxel centre touches the segment only at its end,
                // which an open-segment test would let through.
                let (a, b) = (sdf.center(i), sdf.center(j));
                let reach = (b - a) * 1e-3;
                // The proof by distance keeps a 1% margin for rounding: a
                // wall through one centre leaves the two distances summing
                // to the segment's length, give or take an ulp.
                let clear = sdf.distance[i] + sdf.distance[j] > 1.01 * h
                    || !bvh.occluded(a - reach, b + reach, 0.0);
                if clear {
                    bits |= 1 << axis;
                }
            }
            bits
        })
        .collect()
}

/// The voxels of `sdf` reachable from `seeds` (module docs). A seed in a
/// solid voxel starts from the nearest open voxel within two voxels of
/// it; seeds beyond the grid or deep in solid are skipped. Without a
/// usable seed, every open voxel counts.
///
/// Contract: deterministic whatever the thread count; every reached voxel
/// is open; with seeds that start nothing, every open voxel is reached.
pub fn reachable(sdf: &Sdf, bvh: &SceneBvh, seeds: &[Vec3]) -> Reachable {
    let open: Vec<bool> = sdf.class.iter().map(|c| *c != VoxelClass::Solid).collect();
    let open_voxels = open.iter().filter(|&&o| o).count();
    let starts: Vec<usize> = seeds
        .iter()
        .filter_map(|&p| seed_voxel(sdf, &open, p))
        .collect();
    let seeds_used = starts.len();
    let mask: Vec<bool> = if starts.is_empty() {
        open
    } else {
        let passable = edges(sdf, bvh, &open);
        let mut label = vec![u32::MAX; sdf.len()];
        flood(sdf, &passable, &mut label, &starts, 0);
        label.iter().map(|&l| l == 0).collect()
    };
    Reachable {
        reached_voxels: mask.iter().filter(|&&m| m).count(),
        mask,
        open_voxels,
        seeds_used,
    }
}

/// The open voxel a seed at `p` starts from: its own, or the nearest open
/// one within two voxels (first in index order among equals).
fn seed_voxel(sdf: &Sdf, open: &[bool], p: Vec3) -> Option<usize> {
    let i = sdf.voxel_at(p)?;
    if open[i] {
        return Some(i);
    }
    let v = sdf.coords(i).as_ivec3();
    let mut best: Option<(i32, usize)> = None;
    for dz in -2..=2 {
        for dy in -2..=2 {
            for dx in -2..=2 {
                let w = v + glam::IVec3::new(dx, dy, dz);
                if w.cmplt(glam::IVec3::ZERO).any() || w.cmpge(sdf.dims.as_ivec3()).any() {
                    continue;
                }
                let j = sdf.index(w.as_uvec3());
                let d = dx * dx + dy * dy + dz * dz;
                if open[j] && best.is_none_or(|(bd, bj)| (d, j) < (bd, bj)) {
                    best = Some((d, j));
                }
            }
        }
    }
    best.map(|(_, j)| j)
}

/// Labels with `id` every voxel joined to `starts` through passable
/// edges; returns how many it labelled.
fn flood(sdf: &Sdf, passable: &[u8], label: &mut [u32], starts: &[usize], id: u32) -> usize {
    let mut queue = VecDeque::new();
    let mut count = 0;
    for &s in starts {
        if label[s] == u32::MAX {
            label[s] = id;
            queue.push_back(s);
            count += 1;
        }
    }
    let dims = sdf.dims;
    while let Some(i) = queue.pop_front() {
        let v = sdf.coords(i);
        for axis in 0..3 {
            // Forward edge: this voxel's bit; backward: the neighbour's.
            if v[axis] + 1 < dims[axis] && passable[i] & (1 << axis) != 0 {
                let mut w = v;
                w[axis] += 1;
                let j = sdf.index(w);
                if label[j] == u32::MAX {
                    label[j] = id;
                    queue.push_back(j);
                    count += 1;
                }
            }
            if v[axis] > 0 {
                let mut w: UVec3 = v;
                w[axis] -= 1;
                let j = sdf.index(w);
                if passable[j] & (1 << axis) != 0 && label[j] == u32::MAX {
                    label[j] = id;
                    queue.push_back(j);
                    count += 1;
                }
            }
        }
    }
    count
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::testing::{add_box, bvh_and_sdf};
    use crate::scene::Scene;

    /// A closed box room (0..4)³ with a sealed hollow box (0.75..2.25)³
    /// inside it whose faces look into the hollow (free space to the SDF,
    /// as the cavity behind a wall panel is).
    fn room_with_void() -> (Scene, SceneBvh, Sdf) {
        let mut tris = Vec::new();
        add_box(&mut tris, Vec3::ZERO, Vec3::splat(4.0), true);
        add_box(&mut tris, Vec3::splat(0.75), Vec3::splat(2.25), true);
        let scene = Scene::from_triangles(
            "void".into(),
            tris.into_iter().map(|t| (t, 0)),
            vec![crate::scene::Material::fallback()],
        )
        .unwrap();
        let (bvh, sdf) = bvh_and_sdf(&scene, 0.25, 3);
        (scene, bvh, sdf)
    }

    #[test]
    fn a_sealed_void_is_not_reached_from_the_room() {
        let (_, bvh, sdf) = room_with_void();
        let r = reachable(&sdf, &bvh, &[Vec3::new(3.0, 3.0, 3.0)]);
        assert_eq!(r.seeds_used, 1);
        assert!(r.contains(&sdf, Vec3::new(3.0, 0.5, 3.0)));
        assert!(!r.contains(&sdf, Vec3::splat(1.5)), "the void is sealed");
        assert!(r.excluded_fraction() > 0.0);
        // From inside the void only the void is reached.
        let v = reachable(&sdf, &bvh, &[Vec3::splat(1.5)]);
        assert!(v.contains(&sdf, Vec3::splat(1.4)));
        assert!(!v.contains(&sdf, Vec3::new(3.0, 3.0, 3.0)));
        assert!(v.reached_voxels < r.reached_voxels);
    }

    #[test]
    fn without_a_seed_all_open_space_counts() {
        let (_, bvh, sdf) = room_with_void();
        // Beyond the grid: no seed starts.
        let r = reachable(&sdf, &bvh, &[Vec3::splat(-10.0)]);
        assert_eq!(r.seeds_used, 0);
        assert!(r.contains(&sdf, Vec3::new(3.0, 3.0, 3.0)));
        assert!(r.contains(&sdf, Vec3::splat(1.5)));
        assert_eq!(r.excluded_fraction(), 0.0);
        let seeded = reachable(&sdf, &bvh, &[Vec3::new(0.5, 3.5, 0.5)]);
        assert!(seeded.reached_voxels < r.reached_voxels);
    }

    #[test]
    fn every_reached_voxel_is_open() {
        let (_, bvh, sdf) = room_with_void();
        let r = reachable(&sdf, &bvh, &[Vec3::splat(3.0)]);
        for (i, &m) in r.mask.iter().enumerate() {
            assert!(!m || sdf.class[i] != VoxelClass::Solid);
        }
    }
}
