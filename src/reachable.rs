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
//! its sides). A wall thinner than a voxel never opens.
//!
//! **A viewer has a size.** The flood moves a ball of the viewer's radius
//! `r`, not a point: it joins only voxels whose centre is at least `r`
//! from every surface (the ball fits there), and the space reached is the
//! voxels the free balls around those centres touch (each centre's own
//! distance-field ball, which no geometry crosses; grown to them through
//! open space, never through a wall), so the space by the walls and in
//! the corners of a reached room is reached too. A gap narrower than about `2r`
//! therefore joins nothing: a crack between a roof and its wall, the slit
//! behind a panel. Why: Dabrovic Sponza's roof space (a 31 m attic over
//! the galleries, pitch dark) opens onto the atrium only through gaps of
//! some 35 cm; flooded by a point it counts as reachable, collects probes,
//! coverage samples and a chosen view, and its black surfaces then decide
//! every diffuse figure. With `r` 0 the flood is a point's, and any gap
//! of about a voxel joins.

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
    /// The viewer's radius the flood moved (module docs); 0 when no seed
    /// found room for it and the flood fell back to a point's.
    pub radius: f32,
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

/// The voxels of `sdf` reachable from `seeds` by a viewer of radius
/// `radius` (module docs). A seed starts from the nearest voxel with room
/// for the viewer within `radius` and two voxels of it; seeds beyond the
/// grid or deep in solid are skipped. When seeds stand in open space but
/// none has room for the viewer (a camera in a crawl space), the flood is
/// a point's (`radius` 0). Without a usable seed, every open voxel counts.
///
/// Contract: deterministic whatever the thread count; every reached voxel
/// is open; with seeds that start nothing, every open voxel is reached;
/// with `radius` 0, what a point reaches.
pub fn reachable(sdf: &Sdf, bvh: &SceneBvh, seeds: &[Vec3], radius: f32) -> Reachable {
    let open: Vec<bool> = sdf.class.iter().map(|c| *c != VoxelClass::Solid).collect();
    let open_voxels = open.iter().filter(|&&o| o).count();
    let radius = if radius.is_finite() {
        radius.max(0.0)
    } else {
        0.0
    };
    let room = |r: f32| -> Vec<bool> {
        open.iter()
            .zip(&sdf.distance)
            .map(|(&o, &d)| o && d >= r)
            .collect()
    };
    let starts_in = |core: &[bool], r: f32| -> Vec<usize> {
        let window = 2 + (r / sdf.voxel_size).ceil() as i32;
        seeds
            .iter()
            .filter_map(|&p| seed_voxel(sdf, core, p, window))
            .collect()
    };
    let mut radius = radius;
    let mut core = room(radius);
    let mut starts = starts_in(&core, radius);
    if starts.is_empty() && radius > 0.0 {
        starts = starts_in(&open, 0.0);
        if !starts.is_empty() {
            radius = 0.0;
            core = open.clone();
        }
    }
    let seeds_used = starts.len();
    let mask: Vec<bool> = if starts.is_empty() {
        open
    } else {
        let passable = edges(sdf, bvh, &open);
        let mut label = vec![u32::MAX; sdf.len()];
        if radius > 0.0 {
            // The viewer's centre moves between voxels with room for it.
            let between = between_core(sdf, &passable, &core);
            flood(sdf, &between, &mut label, &starts, 0);
            let centres: Vec<bool> = label.iter().map(|&l| l == 0).collect();
            balls(sdf, &passable, &core, centres)
        } else {
            flood(sdf, &passable, &mut label, &starts, 0);
            label.iter().map(|&l| l == 0).collect()
        }
    };
    Reachable {
        reached_voxels: mask.iter().filter(|&&m| m).count(),
        mask,
        open_voxels,
        seeds_used,
        radius,
    }
}

/// The passable edges of `passable` whose two voxels both have room
/// (`core`).
fn between_core(sdf: &Sdf, passable: &[u8], core: &[bool]) -> Vec<u8> {
    let dims = sdf.dims;
    (0..sdf.len())
        .into_par_iter()
        .map(|i| {
            if !core[i] {
                return 0;
            }
            let v = sdf.coords(i);
            let mut bits = passable[i];
            for axis in 0..3 {
                if bits & (1 << axis) != 0 && v[axis] + 1 < dims[axis] {
                    let mut w = v;
                    w[axis] += 1;
                    if !core[sdf.index(w)] {
                        bits &= !(1 << axis);
                    }
                }
            }
            bits
        })
        .collect()
}

/// The reached centres and the open voxels their free balls touch:
/// grown from each reached centre through passable edges (never through
/// geometry) into voxels without room (not in `core`) whose centre lies
/// within the centre's SDF distance and half a voxel diagonal of it.
fn balls(sdf: &Sdf, passable: &[u8], core: &[bool], centres: Vec<bool>) -> Vec<bool> {
    let slack = 0.5 * 3f32.sqrt() * sdf.voxel_size;
    let mut mask = centres;
    let mut queue: VecDeque<(usize, usize)> = (0..sdf.len())
        .filter(|&i| mask[i])
        .map(|i| (i, i))
        .collect();
    while let Some((i, origin)) = queue.pop_front() {
        let o = sdf.center(origin);
        let reach = sdf.distance[origin] + slack;
        passable_neighbours(sdf, passable, i, |j| {
            if !mask[j] && !core[j] && sdf.center(j).distance(o) <= reach {
                mask[j] = true;
                queue.push_back((j, origin));
            }
        });
    }
    mask
}

/// Whether a seed at `p` starts a flood of [`reachable`] at all (as a
/// point, `radius` 0): inside the grid, with an open voxel at it or within
/// two voxels. Config points that do not are refused
/// (`stages::prepare`), not skipped.
pub fn starts_from(sdf: &Sdf, p: Vec3) -> bool {
    let open: Vec<bool> = sdf.class.iter().map(|c| *c != VoxelClass::Solid).collect();
    seed_voxel(sdf, &open, p, 2).is_some()
}

/// The voxel a seed at `p` starts from: its own when `room` holds it,
/// else the nearest one `room` holds within `window` voxels (first in
/// index order among equals).
fn seed_voxel(sdf: &Sdf, room: &[bool], p: Vec3, window: i32) -> Option<usize> {
    let i = sdf.voxel_at(p)?;
    if room[i] {
        return Some(i);
    }
    let v = sdf.coords(i).as_ivec3();
    let mut best: Option<(i32, usize)> = None;
    for dz in -window..=window {
        for dy in -window..=window {
            for dx in -window..=window {
                let w = v + glam::IVec3::new(dx, dy, dz);
                if w.cmplt(glam::IVec3::ZERO).any() || w.cmpge(sdf.dims.as_ivec3()).any() {
                    continue;
                }
                let j = sdf.index(w.as_uvec3());
                let d = dx * dx + dy * dy + dz * dz;
                if room[j] && best.is_none_or(|(bd, bj)| (d, j) < (bd, bj)) {
                    best = Some((d, j));
                }
            }
        }
    }
    best.map(|(_, j)| j)
}

/// Calls `f` with every neighbour of voxel `i` joined to it by a passable
/// edge: forward edges are `i`'s bits, backward ones the neighbour's.
fn passable_neighbours(sdf: &Sdf, passable: &[u8], i: usize, mut f: impl FnMut(usize)) {
    let v = sdf.coords(i);
    for axis in 0..3 {
        if v[axis] + 1 < sdf.dims[axis] && passable[i] & (1 << axis) != 0 {
            let mut w = v;
            w[axis] += 1;
            f(sdf.index(w));
        }
        if v[axis] > 0 {
            let mut w: UVec3 = v;
            w[axis] -= 1;
            let j = sdf.index(w);
            if passable[j] & (1 << axis) != 0 {
                f(j);
            }
        }
    }
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
    while let Some(i) = queue.pop_front() {
        passable_neighbours(sdf, passable, i, |j| {
            if label[j] == u32::MAX {
                label[j] = id;
                queue.push_back(j);
                count += 1;
            }
        });
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
        scene_of("void", tris)
    }

    /// The scene of `tris`, its BVH and its SDF at a quarter-unit voxel.
    fn scene_of(name: &str, tris: Vec<[Vec3; 3]>) -> (Scene, SceneBvh, Sdf) {
        let scene = Scene::from_triangles(
            name.into(),
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
        let r = reachable(&sdf, &bvh, &[Vec3::new(3.0, 3.0, 3.0)], 0.25);
        assert_eq!(r.seeds_used, 1);
        assert!(r.contains(&sdf, Vec3::new(3.0, 0.5, 3.0)));
        assert!(!r.contains(&sdf, Vec3::splat(1.5)), "the void is sealed");
        assert!(r.excluded_fraction() > 0.0);
        // From inside the void only the void is reached.
        let v = reachable(&sdf, &bvh, &[Vec3::splat(1.5)], 0.25);
        assert!(v.contains(&sdf, Vec3::splat(1.4)));
        assert!(!v.contains(&sdf, Vec3::new(3.0, 3.0, 3.0)));
        assert!(v.reached_voxels < r.reached_voxels);
    }

    #[test]
    fn without_a_seed_all_open_space_counts() {
        let (_, bvh, sdf) = room_with_void();
        // Beyond the grid: no seed starts.
        let r = reachable(&sdf, &bvh, &[Vec3::splat(-10.0)], 0.25);
        assert_eq!(r.seeds_used, 0);
        assert!(r.contains(&sdf, Vec3::new(3.0, 3.0, 3.0)));
        assert!(r.contains(&sdf, Vec3::splat(1.5)));
        assert_eq!(r.excluded_fraction(), 0.0);
        let seeded = reachable(&sdf, &bvh, &[Vec3::new(0.5, 3.5, 0.5)], 0.25);
        assert!(seeded.reached_voxels < r.reached_voxels);
    }

    #[test]
    fn every_reached_voxel_is_open() {
        let (_, bvh, sdf) = room_with_void();
        for radius in [0.0, 0.25, 0.6] {
            let r = reachable(&sdf, &bvh, &[Vec3::splat(3.0)], radius);
            for (i, &m) in r.mask.iter().enumerate() {
                assert!(!m || sdf.class[i] != VoxelClass::Solid);
            }
        }
    }

    /// A closed room (0..4)³ split at x = 2 by a wall 0.2 thick with a
    /// square hole of side `hole` centred at y = z = 2.
    fn split_room(hole: f32) -> (SceneBvh, Sdf) {
        let (_, bvh, sdf) = split_room_scene(hole);
        (bvh, sdf)
    }

    fn split_room_scene(hole: f32) -> (Scene, SceneBvh, Sdf) {
        let mut tris = Vec::new();
        add_box(&mut tris, Vec3::ZERO, Vec3::splat(4.0), true);
        let (a, b) = (2.0 - 0.5 * hole, 2.0 + 0.5 * hole);
        let (x0, x1) = (1.9, 2.1);
        for (lo, hi) in [
            (Vec3::new(x0, 0.0, 0.0), Vec3::new(x1, a, 4.0)),
            (Vec3::new(x0, b, 0.0), Vec3::new(x1, 4.0, 4.0)),
            (Vec3::new(x0, a, 0.0), Vec3::new(x1, b, a)),
            (Vec3::new(x0, a, b), Vec3::new(x1, b, 4.0)),
        ] {
            add_box(&mut tris, lo, hi, false);
        }
        scene_of("split", tris)
    }

    #[test]
    fn surfaces_seen_only_through_a_slit_are_not_coverable() {
        let (scene, bvh, sdf) = split_room_scene(0.3);
        let reach = reachable(&sdf, &bvh, &[Vec3::new(1.0, 2.0, 2.0)], 0.25);
        let mut refs = crate::coverage::free_points(&bvh, &sdf, &scene.bounds, 400);
        refs.retain(|&p| !reach.excludes(&sdf, p));
        assert!(
            refs.iter().all(|p| p.x < 1.9),
            "reference points keep to the seed's room"
        );
        let build = |mask: Option<Vec<bool>>| {
            crate::coverage::CoverageReference::on_free_points(
                &scene,
                &bvh,
                &sdf,
                &crate::config::CoverageParams::default(),
                7,
                refs.clone(),
                mask.map(std::sync::Arc::new),
                &crate::progress::Progress::hidden(),
            )
        };
        let beyond = |c: &crate::coverage::CoverageReference| {
            c.samples
                .iter()
                .zip(&c.coverable)
                .filter(|(s, &k)| k && s.position.x > 2.2)
                .count()
        };
        // Seen through the slit from the room, the far room's walls count
        // without the reached space, and not with it.
        assert!(beyond(&build(None)) > 0);
        let with = build(Some(reach.mask.clone()));
        assert_eq!(beyond(&with), 0);
        // The seed room's own surfaces stay coverable.
        assert!(with
            .samples
            .iter()
            .zip(&with.coverable)
            .any(|(s, &k)| k && s.position.x < 0.01));
    }

    #[test]
    fn a_slit_narrower_than_the_viewer_joins_nothing_and_a_door_does() {
        let seed = [Vec3::new(1.0, 2.0, 2.0)];
        let beyond = Vec3::new(3.0, 2.0, 2.0);
        // A 0.3 slit: a point passes it, a viewer of radius 0.25 does not.
        let (bvh, sdf) = split_room(0.3);
        let point = reachable(&sdf, &bvh, &seed, 0.0);
        assert!(point.contains(&sdf, beyond), "a point passes a slit");
        assert_eq!(point.radius, 0.0);
        let viewer = reachable(&sdf, &bvh, &seed, 0.25);
        assert_eq!(viewer.radius, 0.25);
        assert!(!viewer.contains(&sdf, beyond), "the viewer does not");
        assert!(viewer.excluded_fraction() > 0.3);
        // The room's own corners and the space by its walls stay reached:
        // they lie in the free balls of the centres the viewer reaches.
        for p in [
            Vec3::new(0.1, 0.1, 0.1),
            Vec3::new(0.1, 2.0, 2.0),
            Vec3::new(1.0, 3.9, 2.0),
            Vec3::new(1.8, 1.0, 1.0),
        ] {
            assert!(viewer.contains(&sdf, p), "{p} by a wall of the seed's room");
        }
        // A door of 1.5 joins the rooms for the same viewer.
        let (bvh, sdf) = split_room(1.5);
        let door = reachable(&sdf, &bvh, &seed, 0.25);
        assert!(door.contains(&sdf, beyond));
        assert!(door.contains(&sdf, Vec3::new(3.9, 0.1, 3.9)));
    }

    #[test]
    fn a_camera_without_room_for_the_viewer_floods_as_a_point() {
        let (bvh, sdf) = split_room(0.3);
        // No voxel of either half (0.95 at most from a wall) has room
        // for a viewer of radius 1.5: the flood is a point's, and passes
        // the slit.
        let r = reachable(&sdf, &bvh, &[Vec3::new(1.0, 2.0, 2.0)], 1.5);
        assert_eq!(r.seeds_used, 1);
        assert_eq!(r.radius, 0.0);
        assert!(r.contains(&sdf, Vec3::new(1.0, 2.0, 2.0)));
        assert!(r.contains(&sdf, Vec3::new(3.0, 2.0, 2.0)));
    }
}
