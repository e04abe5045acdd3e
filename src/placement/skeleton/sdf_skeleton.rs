//! The `sdf-skeleton` method (Wang et al. 2019 §3.1 "Signed Distance Function
//! Skeletonization", Fig. 2): the skeleton approximated from the SDF.
//! Following Fig. 2 left to right:
//!
//! 1. **Cull** voxels that are solid, outside the scene, or nearer to a
//!    surface than `min_distance` (default 4 voxels).
//! 2. **Skeleton**: of the rest, keep the voxels where the nearest surface
//!    point jumps between face-adjacent voxels, i.e. the discrete medial axis
//!    (the centre of a maximal empty ball touches two or more surfaces). Jumps
//!    are measured on the SDF's nearest points: a voxel is on the skeleton when
//!    a neighbour's nearest point lies more than 2 voxels from its own.
//! 3. **Cluster** skeleton voxels greedily, largest distance first: a seed
//!    takes every unclustered skeleton voxel within `cluster_radius` × its own
//!    distance to the surface *and visible from it*, so that a cluster's voxels
//!    share most of their view ([`super::cluster`]).
//! 4. **Place** one probe at each cluster's centroid; when the centroid is
//!    not in a free, unculled voxel or not visible from the seed (clusters
//!    bend around corners), the probe moves to the cluster's voxel nearest to
//!    the centroid.
//!
//! A domain too small for a medial axis to show clusters all unculled voxels
//! instead.

use super::cluster::cluster_by_visibility;
use crate::config::numbers::Positive;
use crate::error::{Error, Result};
use crate::placement::method::{Method, Role};
use crate::probes::{PlacementInput, Probe, ProbeSet};
use crate::sdf::{Sdf, VoxelClass};
use glam::{IVec3, Vec3};
use rayon::prelude::*;
use serde::Deserialize;
use std::collections::BTreeMap;

/// Parameters of the SDF skeleton placement (Wang et al. 2019, §3.1).
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SdfSkeletonParams {
    /// Voxels nearer to a surface than this (world units) are culled. `None`:
    /// 4 voxels.
    pub min_distance: Option<Positive>,
    /// Skeleton voxels within `cluster_radius` × the seed voxel's distance to
    /// the nearest surface, and visible from the seed, join its cluster.
    pub cluster_radius: Positive,
}

impl Default for SdfSkeletonParams {
    fn default() -> Self {
        SdfSkeletonParams {
            min_distance: None,
            cluster_radius: Positive(2.0),
        }
    }
}

/// The `sdf-skeleton` method, ours: [`sdf_skeleton`].
pub struct SdfSkeleton;

impl Method for SdfSkeleton {
    type Params = SdfSkeletonParams;
    const WORD: &'static str = "sdf-skeleton";
    const TAKES_ARGUMENT: bool = false;
    const FORM: &'static str = "sdf-skeleton";
    const ABOUT: &'static str = "Wang et al. 2019 §3.1: SDF voxels near surfaces culled, the skeleton of the rest clustered by visibility";
    const ROLE: Role = Role::Ours;

    fn name(_: &SdfSkeletonParams) -> String {
        Self::WORD.into()
    }

    fn parse_cli(
        _: Option<&str>,
        base: Option<&SdfSkeletonParams>,
    ) -> std::result::Result<SdfSkeletonParams, String> {
        Ok(base.copied().unwrap_or_default())
    }

    fn place(params: &SdfSkeletonParams, input: &PlacementInput) -> Result<ProbeSet> {
        sdf_skeleton(params, input)
    }
}

/// Default culling distance, in voxels.
pub const DEFAULT_MIN_DISTANCE_VOXELS: f32 = 4.0;

/// Jump of the nearest surface point, in voxels, that marks a skeleton voxel.
const JUMP_VOXELS: f32 = 2.0;

/// The voxels that survive culling (step 1), as linear indices.
pub fn cull(sdf: &Sdf, min_distance: f32) -> Vec<usize> {
    (0..sdf.len())
        .filter(|&i| sdf.class[i] == VoxelClass::Free && sdf.distance[i] >= min_distance)
        .collect()
}

/// The culled voxels that lie on the discrete medial axis (step 2).
pub fn medial_voxels(sdf: &Sdf, kept: &[usize]) -> Vec<usize> {
    let jump2 = (JUMP_VOXELS * sdf.voxel_size).powi(2);
    let dims = sdf.dims.as_ivec3();
    let on_axis = |i: usize| {
        let Some(q) = sdf.nearest[i] else {
            return false;
        };
        let v = sdf.coords(i).as_ivec3();
        [
            IVec3::X,
            IVec3::NEG_X,
            IVec3::Y,
            IVec3::NEG_Y,
            IVec3::Z,
            IVec3::NEG_Z,
        ]
        .iter()
        .any(|o| {
            let n = v + *o;
            if n.cmplt(IVec3::ZERO).any() || n.cmpge(dims).any() {
                return false;
            }
            sdf.nearest[sdf.index(n.as_uvec3())].is_some_and(|qn| qn.distance_squared(q) > jump2)
        })
    };
    kept.par_iter().copied().filter(|&i| on_axis(i)).collect()
}

/// The culling distance when the config names none and four voxels cull
/// every free voxel: half the domain's largest clearance. A coarse voxel
/// on a large scene (`Auto` keeps Dabrovic Sponza tiled 8×8, 4M
/// triangles, to 2²⁰ voxels of 0.87 m) puts four voxels beyond the widest
/// aisle; half the largest clearance keeps the skeleton of the widest
/// spaces, and refinement fills from there.
fn fallback_min_distance(sdf: &Sdf) -> f32 {
    0.5 * sdf.largest_clearance()
}

/// Places probes by SDF skeletonization (module docs, steps 1–4).
///
/// Contract: every probe lies at the centre of a free voxel at least
/// `min_distance` from any surface, or at a cluster centroid that itself is
/// such a point; probes come in order of decreasing clearance; the result is
/// deterministic. The set's stats count the voxels of steps 1 and 2. Errors
/// ([`Error::User`], naming the parameter) when culling
/// leaves nothing.
pub fn sdf_skeleton(params: &SdfSkeletonParams, input: &PlacementInput) -> Result<ProbeSet> {
    let sdf = input.sdf;
    let mut min_distance = params
        .min_distance
        .map_or(DEFAULT_MIN_DISTANCE_VOXELS * sdf.voxel_size, |d| d.0);
    let mut kept = cull(sdf, min_distance);
    if kept.is_empty() && params.min_distance.is_none() {
        let fallback = fallback_min_distance(sdf);
        if fallback > 0.0 {
            min_distance = fallback;
            kept = cull(sdf, min_distance);
        }
    }
    if kept.is_empty() {
        let largest = sdf.largest_clearance();
        return Err(Error::User(format!(
            "placement.min_distance: {} culls every free voxel (the largest clearance in the domain is {largest:.4}); lower it or the voxel_size",
            crate::config::numbers::short(min_distance)
        )));
    }
    let mut skeleton = medial_voxels(sdf, &kept);
    if skeleton.is_empty() {
        // A domain too small for a medial axis to show: its clearest voxel stands in.
        skeleton = kept.clone();
    }
    let centers: Vec<Vec3> = skeleton.iter().map(|&i| sdf.center(i)).collect();
    let clearance: Vec<f32> = skeleton.iter().map(|&i| sdf.distance[i]).collect();
    let eps = 1e-3 * sdf.voxel_size;
    let clusters = cluster_by_visibility(
        &centers,
        &clearance,
        params.cluster_radius.0,
        0.0,
        input.bvh,
        eps,
    );
    let stats = BTreeMap::from([
        ("unculled_voxels", kept.len() as u64),
        ("skeleton_voxels", skeleton.len() as u64),
    ]);
    let probes = clusters
        .par_iter()
        .map(|c| {
            let seed = centers[c.seed];
            let centroid =
                c.members.iter().map(|&m| centers[m]).sum::<Vec3>() / c.members.len() as f32;
            let free = sdf.voxel_at(centroid).is_some_and(|v| {
                sdf.class[v] == VoxelClass::Free && sdf.distance[v] >= min_distance
            });
            let position = if free && !input.bvh.occluded(seed, centroid, eps) {
                centroid
            } else {
                c.members
                    .iter()
                    .map(|&m| centers[m])
                    .min_by(|a, b| {
                        a.distance_squared(centroid)
                            .total_cmp(&b.distance_squared(centroid))
                    })
                    .unwrap_or(seed)
            };
            Probe {
                position,
                cluster_size: c.members.len() as u32,
            }
        })
        .collect();
    Ok(ProbeSet {
        method: "sdf-skeleton".into(),
        probes,
        stats,
        params: BTreeMap::from([
            ("min_distance", min_distance as f64),
            ("cluster_radius", params.cluster_radius.0 as f64),
        ]),
        min_clearance: min_distance,
        fixed: 0,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::{Placement, Positive};
    use crate::scene::raycast::SceneBvh;
    use crate::scene::testing::{place_in, room_sdf};
    use crate::scene::Scene;

    fn setup(voxel: f32) -> (Scene, SceneBvh, Sdf) {
        room_sdf(voxel, 5)
    }

    fn run(
        scene: &Scene,
        bvh: &SceneBvh,
        sdf: &Sdf,
        params: SdfSkeletonParams,
    ) -> Result<Vec<Probe>> {
        place_in(&Placement::SdfSkeleton(params), scene, bvh, sdf).map(|set| set.probes)
    }

    #[test]
    fn medial_voxels_lie_midway_between_walls() {
        let (_, _, sdf) = setup(0.25);
        let kept = cull(&sdf, 0.5);
        let medial = medial_voxels(&sdf, &kept);
        assert!(!medial.is_empty() && medial.len() < kept.len());
        // In the 4 m room, the plane x = 2 (midway between the x walls) is
        // medial wherever the x walls are the nearest surfaces.
        let c = sdf.center(sdf.voxel_at(glam::Vec3::new(2.1, 3.1, 3.1)).unwrap());
        assert!((c.x - 2.125).abs() < 1e-5);
        assert!(
            medial.iter().any(|&i| sdf.center(i) == c),
            "voxel at {c} should be medial"
        );
        // A voxel close to one wall only is not.
        let near_wall = sdf.voxel_at(glam::Vec3::new(3.4, 2.6, 2.6)).unwrap();
        assert!(!medial.contains(&near_wall));
    }

    #[test]
    fn probes_stand_in_free_space_clear_of_surfaces() {
        let (scene, bvh, sdf) = setup(0.2);
        let min_distance = 0.6;
        let probes = run(
            &scene,
            &bvh,
            &sdf,
            SdfSkeletonParams {
                min_distance: Some(Positive(min_distance)),
                cluster_radius: Positive(2.0),
            },
        )
        .unwrap();
        assert!(!probes.is_empty());
        for p in &probes {
            let v = sdf.voxel_at(p.position).unwrap();
            assert_eq!(sdf.class[v], VoxelClass::Free, "{:?}", p.position);
            assert!(
                sdf.distance[v] >= min_distance - sdf.voxel_size,
                "{:?} {}",
                p.position,
                sdf.distance[v]
            );
            assert!(p.cluster_size >= 1);
        }
    }

    #[test]
    fn larger_clusters_mean_fewer_probes() {
        let (scene, bvh, sdf) = setup(0.2);
        let counts: Vec<usize> = [0.75, 1.5, 3.0, 6.0]
            .iter()
            .map(|&r| {
                run(
                    &scene,
                    &bvh,
                    &sdf,
                    SdfSkeletonParams {
                        min_distance: None,
                        cluster_radius: Positive(r),
                    },
                )
                .unwrap()
                .len()
            })
            .collect();
        assert!(counts.windows(2).all(|w| w[0] >= w[1]), "{counts:?}");
        assert!(counts[0] > counts[3], "{counts:?}");
    }

    /// A voxel so coarse that four of them pass the widest clearance (a
    /// large scene at its `Auto` voxel): the default culls to half the
    /// largest clearance and places, where a named distance as large stops.
    #[test]
    fn a_default_that_would_cull_everything_falls_back_to_half_the_largest_clearance() {
        let (scene, bvh, sdf) = setup(0.5);
        let largest = sdf.largest_clearance();
        assert!(
            4.0 * sdf.voxel_size >= largest,
            "the room is too large for the test: {largest}"
        );
        let set = place_in(
            &Placement::SdfSkeleton(SdfSkeletonParams::default()),
            &scene,
            &bvh,
            &sdf,
        )
        .unwrap();
        assert!(!set.probes.is_empty());
        assert_eq!(set.min_clearance, 0.5 * largest);
        assert_eq!(set.params["min_distance"], (0.5 * largest) as f64);
        for p in &set.probes {
            let v = sdf.voxel_at(p.position).unwrap();
            assert!(sdf.distance[v] >= 0.5 * largest, "{p:?}");
        }
        let named = SdfSkeletonParams {
            min_distance: Some(Positive(4.0 * sdf.voxel_size)),
            ..SdfSkeletonParams::default()
        };
        assert!(run(&scene, &bvh, &sdf, named).is_err());
    }

    #[test]
    fn culling_everything_is_a_user_error_naming_the_parameter() {
        let (scene, bvh, sdf) = setup(0.25);
        let err = run(
            &scene,
            &bvh,
            &sdf,
            SdfSkeletonParams {
                min_distance: Some(Positive(3.0)),
                cluster_radius: Positive(2.0),
            },
        )
        .unwrap_err();
        match err {
            Error::User(m) => assert!(m.starts_with("placement.min_distance"), "{m}"),
            e => panic!("{e:?}"),
        }
    }
}
