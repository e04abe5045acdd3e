//! The `medial-axis` method (Wang et al. 2019 §3.1 "Ball Shrinking
//! Skeletonization", Fig. 3): the skeleton as the centres of medial balls
//! shrunk from the scene's surface.
//!
//! 1. **Oriented surface points** at `point_spacing`, normals towards free
//!    space by the SDF ([`super::surface_points`]).
//! 2. **Pre-clustering** by position (`precluster_radius`) and orientation
//!    (`precluster_angle_deg`): one ball per pre-cluster, the density control
//!    of the paper's Fig. 3 ([`super::surface_points`]).
//! 3. **Ball shrinking** from each pre-cluster's representative against
//!    *all* samples ([`super::ball_shrinking`]), in parallel, with the
//!    separation-angle guard and the iteration cap.
//! 4. **Keep** the balls whose centres can hold a probe: radius at least
//!    `min_radius` (smaller balls sit in creases and narrow gaps), centre
//!    inside the domain, in a free SDF voxel at least `min_radius / 2` from
//!    the nearest surface. Balls are sample-based, so this last test also
//!    catches a ball that slipped through a hole in the mesh.
//! 5. **Cluster** the kept centres by visibility, largest ball first
//!    ([`super::cluster`]): a seed takes the visible centres within
//!    `cluster_radius` × its clearance (by default its own ball, so the
//!    merged centres lie in empty space the seed's ball already spans), or
//!    within `precluster_radius`, whichever is larger. One probe stands
//!    at each seed, the centre of the cluster's largest ball, where a probe
//!    sees the most. A seed is a kept centre, so no probe stands in solid or
//!    outside space.
//!
//! **Why the pre-clustering radius also sets the merge reach.** The paper
//! controls probe density by pre-clustering alone (Fig. 3). Measured here,
//! that works only while the final merge is modest: with a merge reach of
//! 2 × the seed's ball, the greedy merge decides the count and the count
//! wanders up and down as the pre-clustering radius grows (Cornell box:
//! 11, 12, 10, 9, 9, 12 probes for radii of 2 to 12 voxels). Reaching
//! exactly the seed's ball, or the pre-clustering radius when that is
//! larger, keeps the count falling steadily with the radius on every scene
//! tried, so `precluster_radius` is one knob for probe spacing: balls
//! thinned on the surface, centres thinned in space at the same scale.
//!
//! A ball's clearance is its radius, capped by the SDF distance at its
//! centre plus one voxel, so a ball that the guard stopped before it was
//! empty does not claim more room than it has.

use super::ball_shrinking::{shrink_ball, NoBall, ShrinkParams, SurfaceIndex};
use super::cluster::cluster_by_visibility;
use super::surface_points::{precluster, sample_surface_points};
use crate::config::numbers::{Count, Degrees, Positive};
use crate::error::{Error, Result};
use crate::placement::method::{Method, Role};
use crate::probes::{PlacementInput, Probe, ProbeSet};
use crate::sdf::{Sdf, VoxelClass};
use indicatif::ParallelProgressIterator;
use rayon::prelude::*;
use serde::Deserialize;
use std::collections::BTreeMap;

/// Parameters of the ball-shrinking medial axis placement (Wang et al. 2019,
/// §3.1 "Ball Shrinking Skeletonization", Fig. 3; Ma, Bae, Choi 2012). Lengths
/// left out scale with `voxel_size`, so one set of defaults suits every scene.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct MedialAxisParams {
    /// Mean spacing of the oriented surface points (world units): one point
    /// per `point_spacing`² of surface. `None`: 1 voxel.
    pub point_spacing: Option<Positive>,
    /// Pre-clustering radius (world units): surface points within it of a
    /// cluster's seed, with normals within `precluster_angle_deg`, shrink one
    /// ball together, and medial balls within it of a larger visible ball
    /// merge into that ball's probe. The density control (Wang Fig. 3):
    /// larger means fewer probes. `None`: 1.25 × the largest clearance in
    /// the domain (the radius of its biggest empty ball), so that one value
    /// suits a Cornell box and a palace alike.
    pub precluster_radius: Option<Positive>,
    /// Largest angle between a pre-cluster seed's normal and a member's.
    pub precluster_angle_deg: Degrees,
    /// Radius of the ball every shrink starts from (world units). `None`: the
    /// domain's diagonal, larger than any ball that fits inside it.
    pub initial_radius: Option<Positive>,
    /// Guard against noise: a shrink towards a point q that the new centre c
    /// sees at less than this angle from p (∠pcq) is refused and the ball
    /// stops (Ma et al. 2012's separation-angle denoising).
    pub min_separation_deg: Degrees,
    /// Guard: most shrinking steps per ball.
    pub max_iterations: Count<10_000>,
    /// Medial balls smaller than this (world units) are dropped: they sit in
    /// creases and narrow gaps, too close to a surface for a useful probe.
    /// `None`: 3 voxels.
    pub min_radius: Option<Positive>,
    /// Medial balls within `cluster_radius` × the seed ball's radius (or
    /// `precluster_radius`, if larger), and visible from its centre, join its
    /// cluster; one probe per cluster. 1: balls whose centres lie inside the
    /// seed's ball.
    pub cluster_radius: Positive,
}

impl Default for MedialAxisParams {
    fn default() -> Self {
        MedialAxisParams {
            point_spacing: None,
            precluster_radius: None,
            precluster_angle_deg: Degrees(30.0),
            initial_radius: None,
            min_separation_deg: Degrees(20.0),
            max_iterations: Count(64),
            min_radius: None,
            cluster_radius: Positive(1.0),
        }
    }
}

/// The `medial-axis` method, ours: [`medial_axis`].
pub struct MedialAxis;

impl Method for MedialAxis {
    type Params = MedialAxisParams;
    const WORD: &'static str = "medial-axis";
    const TAKES_ARGUMENT: bool = false;
    const FORM: &'static str = "medial-axis";
    const ABOUT: &'static str = "Wang et al. 2019 §3.1, Fig. 3: balls shrunk from pre-clustered oriented surface points to the medial axis, clustered by visibility";
    const ROLE: Role = Role::Ours;

    fn name(_: &MedialAxisParams) -> String {
        Self::WORD.into()
    }

    fn parse_cli(
        _: Option<&str>,
        base: Option<&MedialAxisParams>,
    ) -> std::result::Result<MedialAxisParams, String> {
        Ok(base.copied().unwrap_or_default())
    }

    fn place(params: &MedialAxisParams, input: &PlacementInput) -> Result<ProbeSet> {
        medial_axis(params, input)
    }
}

/// Default `point_spacing`, in voxels.
pub const DEFAULT_POINT_SPACING_VOXELS: f32 = 1.0;
/// Default `precluster_radius`, in multiples of the domain's largest
/// clearance ([`crate::sdf::Sdf::largest_clearance`]).
pub const DEFAULT_PRECLUSTER_RADIUS_CLEARANCES: f32 = 1.25;
/// Default `min_radius`, in voxels.
pub const DEFAULT_MIN_RADIUS_VOXELS: f32 = 3.0;

/// The method's parameters with every default resolved to world units.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Resolved {
    /// Surface point spacing.
    pub point_spacing: f32,
    /// Pre-clustering radius.
    pub precluster_radius: f32,
    /// Pre-clustering angle, radians.
    pub precluster_angle: f32,
    /// The shrinking step's parameters.
    pub shrink: ShrinkParams,
    /// Smallest kept ball.
    pub min_radius: f32,
    /// Clustering radius factor.
    pub cluster_radius: f32,
}

impl Resolved {
    /// Resolves `params` for a run on `sdf`, whose domain has the diagonal
    /// `domain_diagonal`.
    pub fn new(params: &MedialAxisParams, sdf: &Sdf, domain_diagonal: f32) -> Resolved {
        let voxel_size = sdf.voxel_size;
        let or_voxels = |v: Option<crate::config::numbers::Positive>, voxels: f32| {
            v.map_or(voxels * voxel_size, |p| p.0)
        };
        Resolved {
            point_spacing: or_voxels(params.point_spacing, DEFAULT_POINT_SPACING_VOXELS),
            precluster_radius: params.precluster_radius.map_or(
                DEFAULT_PRECLUSTER_RADIUS_CLEARANCES * sdf.largest_clearance().max(voxel_size),
                |r| r.0,
            ),
            precluster_angle: params.precluster_angle_deg.0.to_radians(),
            shrink: ShrinkParams {
                initial_radius: params.initial_radius.map_or(domain_diagonal, |r| r.0),
                min_separation: params.min_separation_deg.0.to_radians(),
                max_iterations: params.max_iterations.0,
            },
            min_radius: or_voxels(params.min_radius, DEFAULT_MIN_RADIUS_VOXELS),
            cluster_radius: params.cluster_radius.0,
        }
    }

    /// The parameters by their config names, lengths in world units and
    /// angles in degrees, for `report.json`.
    pub fn report(&self) -> BTreeMap<&'static str, f64> {
        BTreeMap::from([
            ("point_spacing", self.point_spacing as f64),
            ("precluster_radius", self.precluster_radius as f64),
            (
                "precluster_angle_deg",
                self.precluster_angle.to_degrees() as f64,
            ),
            ("initial_radius", self.shrink.initial_radius as f64),
            (
                "min_separation_deg",
                self.shrink.min_separation.to_degrees() as f64,
            ),
            ("max_iterations", self.shrink.max_iterations as f64),
            ("min_radius", self.min_radius as f64),
            ("cluster_radius", self.cluster_radius as f64),
        ])
    }
}

/// Places probes on the ball-shrinking medial axis (module docs, steps 1–5).
///
/// Contract: every probe is the centre of a kept medial ball, so it lies
/// inside the domain in a free voxel at least `min_radius / 2` from any
/// surface; probes come in order of decreasing clearance; deterministic for a
/// given seed. The set's stats count what each step kept or dropped, its
/// params are [`Resolved::report`]. Errors ([`Error::User`] naming the parameter
/// to change) when no surface point faces free space or no ball is kept.
pub fn medial_axis(params: &MedialAxisParams, input: &PlacementInput) -> Result<ProbeSet> {
    let sdf = input.sdf;
    let r = Resolved::new(params, sdf, input.domain.size().length());
    let mut stats: BTreeMap<&'static str, u64> = [
        "unconverged_balls",
        "dropped_unbounded",
        "dropped_noise",
        "dropped_small",
        "dropped_outside_domain",
        "dropped_not_free",
    ]
    .into_iter()
    .map(|k| (k, 0))
    .collect();

    let surface = sample_surface_points(input.scene, sdf, r.point_spacing, input.seed)?;
    stats.insert("surface_points", surface.positions.len() as u64);
    stats.insert("oriented_points", surface.oriented.len() as u64);
    stats.insert("two_sided_points", surface.two_sided as u64);
    stats.insert("unoriented_points", surface.unoriented as u64);
    if surface.oriented.is_empty() {
        return Err(Error::User(format!(
            "placement.point_spacing: none of the {} surface points faces free space in the domain; lower point_spacing or check the domain",
            surface.positions.len()
        )));
    }

    let clusters = precluster(&surface.oriented, r.precluster_radius, r.precluster_angle);
    stats.insert("preclusters", clusters.len() as u64);

    let index = SurfaceIndex::new(surface.positions);
    let bar = input
        .progress
        .bar("medial axis: shrink balls", clusters.len() as u64);
    let shrunk: Vec<std::result::Result<_, NoBall>> = clusters
        .par_iter()
        .progress_with(bar)
        .map(|c| shrink_ball(c.point.position, c.point.normal, &index, &r.shrink))
        .collect();
    let mut centers = Vec::new();
    let mut clearance = Vec::new();
    let mut count = |key: &'static str| *stats.entry(key).or_insert(0) += 1;
    for ball in &shrunk {
        let ball = match ball {
            Ok(b) => *b,
            Err(NoBall::Unbounded) => {
                count("dropped_unbounded");
                continue;
            }
            Err(NoBall::Noise) => {
                count("dropped_noise");
                continue;
            }
        };
        if !ball.converged {
            count("unconverged_balls");
        }
        if ball.radius < r.min_radius {
            count("dropped_small");
            continue;
        }
        if !input.domain.contains(ball.center) {
            count("dropped_outside_domain");
            continue;
        }
        let voxel = sdf
            .voxel_at(ball.center)
            .filter(|&v| sdf.class[v] == VoxelClass::Free && sdf.distance[v] >= 0.5 * r.min_radius);
        let Some(voxel) = voxel else {
            count("dropped_not_free");
            continue;
        };
        centers.push(ball.center);
        clearance.push(ball.radius.min(sdf.distance[voxel] + sdf.voxel_size));
    }
    stats.insert("medial_points", centers.len() as u64);
    if centers.is_empty() {
        return Err(Error::User(format!(
            "placement.min_radius: no medial ball of the {} pre-clusters has a radius of at least {} with its centre free and inside the domain; lower min_radius or the voxel_size",
            clusters.len(),
            crate::config::numbers::short(r.min_radius)
        )));
    }

    let eps = 1e-3 * sdf.voxel_size;
    let groups = cluster_by_visibility(
        &centers,
        &clearance,
        r.cluster_radius,
        r.precluster_radius,
        input.bvh,
        eps,
    );
    let probes = groups
        .iter()
        .map(|g| Probe {
            position: centers[g.seed],
            cluster_size: g.members.len() as u32,
        })
        .collect();
    Ok(ProbeSet {
        method: "medial-axis".into(),
        probes,
        stats,
        params: r.report(),
        min_clearance: 0.5 * r.min_radius,
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

    fn run(scene: &Scene, bvh: &SceneBvh, sdf: &Sdf, params: MedialAxisParams) -> Result<ProbeSet> {
        place_in(&Placement::MedialAxis(params), scene, bvh, sdf)
    }

    #[test]
    fn probes_are_free_ball_centres_and_the_room_centre_comes_first() {
        let (scene, bvh, sdf) = room_sdf(0.1, 5);
        // Fine pre-clusters, so that some point lies near a wall's centre,
        // the only tangent points of the room's largest ball.
        let params = MedialAxisParams {
            precluster_radius: Some(Positive(0.3)),
            ..MedialAxisParams::default()
        };
        let set = run(&scene, &bvh, &sdf, params).unwrap();
        let (probes, stats) = (set.probes, set.stats);
        assert!(!probes.is_empty());
        let min_radius = DEFAULT_MIN_RADIUS_VOXELS * sdf.voxel_size;
        for p in &probes {
            let v = sdf.voxel_at(p.position).expect("inside the grid");
            assert_eq!(sdf.class[v], VoxelClass::Free, "{p:?}");
            assert!(sdf.distance[v] >= 0.5 * min_radius, "{p:?}");
        }
        // The largest empty ball of the 4 m room with the box [1,2]×[0,1]×[1,2]
        // has a radius of about 1.5 (e.g. centred at (2.5, 2.5, 2.5), between
        // the ceiling and the box's corner); its centre comes first.
        let clearance = |p: &Probe| sdf.distance[sdf.voxel_at(p.position).unwrap()];
        let first = clearance(&probes[0]);
        assert!(first > 1.3, "{:?} {first}", probes[0]);
        assert!(probes
            .iter()
            .all(|p| clearance(p) <= first + sdf.voxel_size));
        let total: u64 = probes.iter().map(|p| p.cluster_size as u64).sum();
        assert_eq!(total, stats["medial_points"]);
        assert!(stats["oriented_points"] > 0 && stats["preclusters"] < stats["oriented_points"]);
    }

    #[test]
    fn deterministic_for_a_seed_whatever_the_thread_count() {
        let (scene, bvh, sdf) = room_sdf(0.2, 5);
        let params = MedialAxisParams {
            precluster_radius: Some(Positive(0.4)),
            ..MedialAxisParams::default()
        };
        let a = run(&scene, &bvh, &sdf, params).unwrap();
        let one_thread = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap();
        let b = one_thread.install(|| run(&scene, &bvh, &sdf, params).unwrap());
        assert!(a.probes.len() > 1);
        assert_eq!(a, b);
    }

    #[test]
    fn a_min_radius_larger_than_the_room_is_a_user_error() {
        let (scene, bvh, sdf) = room_sdf(0.2, 5);
        let params = MedialAxisParams {
            min_radius: Some(Positive(3.0)),
            ..MedialAxisParams::default()
        };
        match run(&scene, &bvh, &sdf, params) {
            Err(Error::User(m)) => assert!(m.starts_with("placement.min_radius"), "{m}"),
            other => panic!("{other:?}"),
        }
    }
}
