//! The point-based scene input of ball shrinking (Wang et al. 2019 §3.1
//! "Ball Shrinking Skeletonization"): oriented surface points, and their
//! pre-clustering by position–orientation similarity (Fig. 3).
//!
//! **Points.** The paper uses the vertices of a sufficiently fine
//! tessellation; area-uniform samples serve the same purpose without
//! re-meshing and cost nothing on long sliver triangles. Each triangle gets
//! `area / spacing²` points on average (stochastic rounding keeps small
//! triangles unbiased), placed by the R2 low-discrepancy sequence folded into
//! the triangle, so points are evenly spread rather than clumped.
//!
//! **Orientation rule.** Probes live in free space, so a point's normal must
//! point into it, whatever the mesh's winding. For a point p on a triangle
//! with geometric normal n, each side s ∈ {+n, −n} is tested: the side is
//! free when the SDF voxel holding p + s·voxel_size is
//! [`VoxelClass::Free`]. A point yields one oriented point per free side:
//! none for a surface between solid and outside space (a façade's exterior,
//! a buried face), one for an ordinary wall, two for a two-sided surface with
//! free space on both sides (a curtain, a leaf). Every sample, oriented or
//! not, stays an obstacle for the shrinking balls.
//!
//! **Pre-clustering.** Greedily, in sampling order: each point not yet
//! clustered seeds a cluster and takes every unclustered point within
//! `radius` whose normal lies within `max_angle` of the seed's. The cluster
//! is represented by its member nearest the members' mean position, with that
//! member's own normal, so the represented point lies exactly on the surface
//! and the ball stays tangent there. Bigger radii mean fewer balls, hence
//! fewer probes: the paper's density control.

use crate::error::{Error, Result};
use crate::sampling::{hash2, unit_f32};
use crate::scene::Scene;
use crate::sdf::{Sdf, VoxelClass};
use glam::Vec3;
use kiddo::{ImmutableKdTree, SquaredEuclidean};
use rayon::prelude::*;

/// Most surface points the medial-axis method may sample; a `point_spacing`
/// far below the scene's scale is a mistake, not a request for a billion points.
pub const MAX_SURFACE_POINTS: u64 = 20_000_000;

/// A surface point with a unit normal pointing into free space.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OrientedPoint {
    /// Position on the surface.
    pub position: Vec3,
    /// Unit normal, towards free space.
    pub normal: Vec3,
}

/// The sampled surface.
#[derive(Debug, Clone, Default)]
pub struct SurfacePoints {
    /// Every sample, oriented or not: the obstacles.
    pub positions: Vec<Vec3>,
    /// The samples facing free space, once per free side.
    pub oriented: Vec<OrientedPoint>,
    /// Samples with free space on both sides (each gave two oriented points).
    pub two_sided: usize,
    /// Samples with free space on neither side (no oriented point).
    pub unoriented: usize,
}

/// Plastic number, the basis of the R2 sequence (Roberts 2018).
const PLASTIC: f64 = 1.324_717_957_244_746;

/// Samples `scene` at mean spacing `spacing` and orients the samples by the
/// SDF (module docs).
///
/// Contract: deterministic for a given `seed`; `positions` holds every
/// sample in triangle order; each oriented point's normal is unit length and
/// its side's probe voxel is free. Errors ([`Error::User`] naming
/// `placement.point_spacing`) when the spacing would need more than
/// [`MAX_SURFACE_POINTS`] points.
pub fn sample_surface_points(
    scene: &Scene,
    sdf: &Sdf,
    spacing: f32,
    seed: u64,
) -> Result<SurfacePoints> {
    let per_area = 1.0 / (spacing as f64 * spacing as f64);
    let areas: Vec<f64> = scene.triangle_areas().collect();
    let expected = areas.iter().sum::<f64>() * per_area;
    if expected > MAX_SURFACE_POINTS as f64 {
        return Err(Error::User(format!(
            "placement.point_spacing: {} would sample {expected:.3e} surface points (the limit is {MAX_SURFACE_POINTS}); raise it",
            crate::config::numbers::short(spacing)
        )));
    }
    let a1 = 1.0 / PLASTIC;
    let a2 = 1.0 / (PLASTIC * PLASTIC);
    let samples: Vec<(Vec3, Vec3)> = (0..scene.triangles.len())
        .into_par_iter()
        .flat_map_iter(|t| {
            let h = hash2(seed, t as u64);
            let count = (areas[t] * per_area + unit_f32(h) as f64).floor() as usize;
            let [v0, v1, v2] = scene.triangles[t];
            let normal = scene.normals[t];
            let (o1, o2) = (unit_f32(hash2(h, 1)) as f64, unit_f32(hash2(h, 2)) as f64);
            (0..count).map(move |i| {
                let i = i as f64;
                let mut u = (o1 + a1 * i).fract() as f32;
                let mut v = (o2 + a2 * i).fract() as f32;
                if u + v > 1.0 {
                    u = 1.0 - u;
                    v = 1.0 - v;
                }
                (v0 + (v1 - v0) * u + (v2 - v0) * v, normal)
            })
        })
        .collect();

    let free = |p: Vec3| {
        sdf.voxel_at(p)
            .is_some_and(|v| sdf.class[v] == VoxelClass::Free)
    };
    let sides: Vec<(bool, bool)> = samples
        .par_iter()
        .map(|&(p, n)| (free(p + n * sdf.voxel_size), free(p - n * sdf.voxel_size)))
        .collect();
    let mut out = SurfacePoints {
        positions: samples.iter().map(|s| s.0).collect(),
        ..SurfacePoints::default()
    };
    for (&(position, normal), &(front, back)) in samples.iter().zip(&sides) {
        if front {
            out.oriented.push(OrientedPoint { position, normal });
        }
        if back {
            out.oriented.push(OrientedPoint {
                position,
                normal: -normal,
            });
        }
        match (front, back) {
            (true, true) => out.two_sided += 1,
            (false, false) => out.unoriented += 1,
            _ => {}
        }
    }
    Ok(out)
}

/// A pre-cluster: the point whose ball stands for it, and how many points it holds.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PreCluster {
    /// The representative (module docs).
    pub point: OrientedPoint,
    /// Member count.
    pub size: u32,
}

/// Pre-clusters `points` by position (`radius`) and orientation (`max_angle`,
/// radians), as in the module docs.
///
/// Contract: every point belongs to exactly one cluster; each member lies
/// within `radius` of its cluster's seed with a normal within `max_angle` of
/// the seed's; the representative is a member; deterministic; clusters come
/// in the order of their seeds.
pub fn precluster(points: &[OrientedPoint], radius: f32, max_angle: f32) -> Vec<PreCluster> {
    if points.is_empty() {
        return Vec::new();
    }
    let coords: Vec<[f32; 3]> = points.iter().map(|p| p.position.to_array()).collect();
    let tree = ImmutableKdTree::<f32, 3>::new_from_slice(&coords)
        .expect("a k-d tree builds from a non-empty point set");
    let min_cos = max_angle.cos();
    let mut taken = vec![false; points.len()];
    let mut members = Vec::new();
    let mut clusters = Vec::new();
    for s in 0..points.len() {
        if taken[s] {
            continue;
        }
        let seed = points[s];
        members.clear();
        members.push(s);
        members.extend(
            tree.query(&coords[s])
                .within::<SquaredEuclidean<f32>>(radius * radius)
                .execute()
                .iter()
                .map(|r| r.item as usize)
                .filter(|&m| m != s && !taken[m] && points[m].normal.dot(seed.normal) >= min_cos),
        );
        let mean = members.iter().map(|&m| points[m].position).sum::<Vec3>() / members.len() as f32;
        let mut best = s;
        for &m in &members {
            taken[m] = true;
            let (d, d_best) = (
                points[m].position.distance_squared(mean),
                points[best].position.distance_squared(mean),
            );
            if d < d_best || (d == d_best && m < best) {
                best = m;
            }
        }
        clusters.push(PreCluster {
            point: points[best],
            size: members.len() as u32,
        });
    }
    clusters
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::testing::room_sdf;

    #[test]
    fn room_points_face_into_the_room() {
        let (scene, _, sdf) = room_sdf(0.2, 3);
        let pts = sample_surface_points(&scene, &sdf, 0.1, 3).unwrap();
        // Room walls 6 × 16 m², box faces 5 × 1 m² exposed (+1 on the floor).
        let expected = (6.0 * 16.0 + 6.0) / 0.01;
        let n = pts.positions.len() as f64;
        assert!((n / expected - 1.0).abs() < 0.02, "{n} vs {expected}");
        assert_eq!(pts.two_sided, 0);
        let centre = Vec3::splat(2.0);
        for p in &pts.oriented {
            assert!((p.normal.length() - 1.0).abs() < 1e-5);
            // Every free side of a wall or box faces the room's interior.
            let probe = p.position + p.normal * 0.2;
            assert!(sdf.class[sdf.voxel_at(probe).unwrap()] == VoxelClass::Free);
            let on_room_wall = p.position.cmple(Vec3::splat(1e-4)).any()
                || p.position.cmpge(Vec3::splat(4.0 - 1e-4)).any();
            if on_room_wall {
                assert!(p.normal.dot(centre - p.position) > 0.0, "{p:?}");
            }
        }
        // The box's bottom face lies on the floor: solid on one side, and
        // coplanar with the floor's free side only where the box is not.
        assert!(pts.unoriented > 0);
        assert!(pts.oriented.len() < pts.positions.len());
    }

    #[test]
    fn a_flipped_face_is_oriented_by_free_space_not_winding() {
        // The room of `room_with_box`, with the box's top face wound the
        // wrong way (normal into the box).
        use crate::scene::{Material, Scene};
        let mut tris = crate::scene::testing::room_with_box_triangles();
        let mut flipped = 0;
        for t in tris.iter_mut() {
            if t.iter().all(|v| v.y == 1.0) {
                t.swap(1, 2);
                flipped += 1;
            }
        }
        assert_eq!(flipped, 2);
        let scene = Scene::from_triangles(
            "flipped".into(),
            tris.into_iter().map(|t| (t, 0)),
            vec![Material::fallback()],
        )
        .unwrap();
        let (_, sdf) = crate::scene::testing::bvh_and_sdf(&scene, 0.2, 1);
        let pts = sample_surface_points(&scene, &sdf, 0.1, 1).unwrap();
        let on_top: Vec<&OrientedPoint> = pts
            .oriented
            .iter()
            .filter(|p| {
                (p.position.y - 1.0).abs() < 1e-6 && p.position.x > 1.0 && p.position.x < 2.0
            })
            .collect();
        assert!(on_top.len() > 50, "{}", on_top.len());
        assert!(
            on_top.iter().all(|p| p.normal == Vec3::Y),
            "top points face up"
        );
    }

    #[test]
    fn samples_are_evenly_spread() {
        // One 1 m² square (two triangles) at spacing 0.1: ~100 points, and
        // no point far from the others, unlike independent random samples.
        let (_, _, sdf) = room_sdf(0.25, 1);
        let square = crate::scene::Scene::from_triangles(
            "square".into(),
            [
                (
                    [
                        Vec3::new(1.0, 2.0, 1.0),
                        Vec3::new(2.0, 2.0, 1.0),
                        Vec3::new(2.0, 2.0, 2.0),
                    ],
                    0,
                ),
                (
                    [
                        Vec3::new(1.0, 2.0, 1.0),
                        Vec3::new(2.0, 2.0, 2.0),
                        Vec3::new(1.0, 2.0, 2.0),
                    ],
                    0,
                ),
            ],
            vec![crate::scene::Material::fallback()],
        )
        .unwrap();
        let pts = sample_surface_points(&square, &sdf, 0.1, 8).unwrap();
        assert!(
            (90..=110).contains(&pts.positions.len()),
            "{}",
            pts.positions.len()
        );
        // A square hovering in free air is two-sided.
        assert_eq!(pts.two_sided, pts.positions.len());
        for (i, p) in pts.positions.iter().enumerate() {
            let nearest = pts
                .positions
                .iter()
                .enumerate()
                .filter(|&(j, _)| j != i)
                .map(|(_, q)| q.distance(*p))
                .fold(f32::MAX, f32::min);
            assert!(nearest < 0.15, "isolated sample {p}: {nearest}");
        }
    }

    #[test]
    fn absurd_spacing_is_a_user_error() {
        let (scene, _, sdf) = room_sdf(0.25, 1);
        match sample_surface_points(&scene, &sdf, 1e-4, 1) {
            Err(Error::User(m)) => assert!(m.starts_with("placement.point_spacing"), "{m}"),
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn preclustering_respects_radius_and_angle() {
        // A 10×10 grid of points on a plane, spacing 0.1, half facing +y and
        // half facing +x (a crease), all within a radius-2 ball.
        let mut points = Vec::new();
        for i in 0..10 {
            for j in 0..10 {
                let normal = if i < 5 { Vec3::Y } else { Vec3::X };
                points.push(OrientedPoint {
                    position: Vec3::new(i as f32 * 0.1, 0.0, j as f32 * 0.1),
                    normal,
                });
            }
        }
        let big = precluster(&points, 2.0, 30f32.to_radians());
        assert_eq!(big.len(), 2, "one cluster per orientation");
        assert_eq!(big.iter().map(|c| c.size).sum::<u32>(), 100);
        let all = precluster(&points, 2.0, 100f32.to_radians());
        assert_eq!(all.len(), 1);
        let none = precluster(&points, 0.05, 30f32.to_radians());
        assert_eq!(
            none.len(),
            100,
            "radius below the spacing keeps every point"
        );
        // Representatives are members with their own normals, near the
        // middle of their cluster: each half is a 5×10 patch centred at
        // x = 0.2 or 0.7, z = 0.45.
        for c in &big {
            assert!(points.contains(&c.point));
            let middle_x = if c.point.normal == Vec3::Y { 0.2 } else { 0.7 };
            assert!((c.point.position.x - middle_x).abs() < 0.01, "{c:?}");
            assert!((c.point.position.z - 0.45).abs() < 0.06, "{c:?}");
        }
        let mut sizes: Vec<usize> = [0.05, 0.15, 0.3, 0.6, 1.2]
            .iter()
            .map(|&r| precluster(&points, r, 30f32.to_radians()).len())
            .collect();
        let sorted = {
            let mut s = sizes.clone();
            s.sort_unstable_by(|a, b| b.cmp(a));
            s
        };
        assert_eq!(sizes, sorted, "cluster count falls with the radius");
        sizes.dedup();
        assert!(sizes.len() >= 4, "{sizes:?}");
    }
}
