//! Greedy visibility clustering of skeleton points, shared by both skeletons
//! (Wang et al. 2019 §3.1: one probe per skeleton element, because an
//! element's points share their view of the scene).
//!
//! Points are taken largest clearance first. Each point not yet clustered
//! seeds a cluster and takes every unclustered point within its reach *that
//! it can see*, so a cluster never spans a wall and its members see roughly
//! what the seed sees. The reach is `radius_factor` × the seed's clearance,
//! but at least `min_reach`. Seeding by clearance puts the seeds where a
//! probe sees the most: mid-room before corners.

use crate::scene::raycast::SceneBvh;
use glam::Vec3;
use rayon::prelude::*;

/// One cluster: its seed and its members, both as indices into the input.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Cluster {
    /// The point that opened the cluster (the members' largest clearance).
    pub seed: usize,
    /// All members, the seed first, in input order after it.
    pub members: Vec<usize>,
}

/// Clusters `points` (each with its `clearance`, the distance to the nearest
/// surface) as in the module docs.
///
/// Contract: every point belongs to exactly one cluster; clusters come in
/// order of decreasing seed clearance (ties by index), so the result is
/// deterministic whatever the thread count; every member lies within
/// `max(radius_factor × clearance[seed], min_reach)` of its seed with an
/// unoccluded segment between them (`eps` is the occlusion test's end-point
/// tolerance).
pub fn cluster_by_visibility(
    points: &[Vec3],
    clearance: &[f32],
    radius_factor: f32,
    min_reach: f32,
    bvh: &SceneBvh,
    eps: f32,
) -> Vec<Cluster> {
    assert_eq!(points.len(), clearance.len());
    let mut order: Vec<usize> = (0..points.len()).collect();
    order.sort_by(|&a, &b| clearance[b].total_cmp(&clearance[a]).then(a.cmp(&b)));
    let mut taken = vec![false; points.len()];
    let mut clusters = Vec::new();
    for (rank, &s) in order.iter().enumerate() {
        if taken[s] {
            continue;
        }
        let seed = points[s];
        let r2 = (radius_factor * clearance[s]).max(min_reach).powi(2);
        let mut members: Vec<usize> = order[rank + 1..]
            .par_iter()
            .copied()
            .filter(|&m| {
                !taken[m]
                    && points[m].distance_squared(seed) <= r2
                    && !bvh.occluded(seed, points[m], eps)
            })
            .collect();
        members.sort_unstable();
        members.insert(0, s);
        for &m in &members {
            taken[m] = true;
        }
        clusters.push(Cluster { seed: s, members });
    }
    clusters
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::testing::room_with_box;

    #[test]
    fn walls_split_clusters_and_clearance_orders_seeds() {
        // The room of `room_with_box`: the box [1,2]×[0,1]×[1,2] hides the
        // point behind it from the point in front.
        let scene = room_with_box();
        let bvh = SceneBvh::new(&scene);
        let points = [
            Vec3::new(1.5, 0.5, 0.5), // in front of the box, small clearance
            Vec3::new(1.5, 0.5, 2.5), // behind it
            Vec3::new(1.5, 2.5, 1.5), // above it, largest clearance
            Vec3::new(0.5, 0.5, 0.5), // beside the first
        ];
        let clearance = [0.5, 0.5, 1.5, 0.5];
        let clusters = cluster_by_visibility(&points, &clearance, 10.0, 0.0, &bvh, 1e-4);
        // The seed above sees all four; tie-broken seeds never start.
        assert_eq!(clusters.len(), 1);
        assert_eq!(clusters[0].seed, 2);
        assert_eq!(clusters[0].members, vec![2, 0, 1, 3]);

        let low = [Vec3::new(1.5, 0.5, 0.5), Vec3::new(1.5, 0.5, 2.5)];
        let clusters = cluster_by_visibility(&low, &[0.5, 0.5], 10.0, 0.0, &bvh, 1e-4);
        assert_eq!(clusters.len(), 2, "the box separates them: {clusters:?}");

        let clusters = cluster_by_visibility(&points, &clearance, 0.5, 0.0, &bvh, 1e-4);
        assert_eq!(clusters.len(), 4, "radius too small to merge: {clusters:?}");
        assert_eq!(clusters[0].seed, 2);
        // A minimum reach of 1 lets the first point take its neighbour 1 m away.
        let clusters = cluster_by_visibility(&points, &clearance, 0.5, 1.0, &bvh, 1e-4);
        assert_eq!(clusters.len(), 3, "{clusters:?}");
        assert_eq!(clusters[1].members, vec![0, 3]);
    }
}
