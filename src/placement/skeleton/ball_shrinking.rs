//! The shrinking-ball step of Ma, Bae and Choi 2012, *3D Medial Axis Point
//! Approximation using Nearest Neighbors and the Normal Field*, as used by
//! Wang et al. 2019 §3.1 "Ball Shrinking Skeletonization".
//!
//! For a surface point p with unit normal n (towards free space; the paper
//! writes the centre as p − r·n with n pointing out of the volume, the same
//! ball), start from a ball of large radius r tangent at p, centre
//! c = p + r·n. Find the surface point q nearest to c other than p. If q lies
//! inside the ball, the ball is not empty: replace it by the ball through q
//! that stays tangent at p, whose radius solves |c′ − q| = r′ for
//! c′ = p + r′·n:
//!
//! ```text
//!     r′ = |p − q|² / (2 n·(q − p))
//! ```
//!
//! and repeat until no sample lies inside. The final ball is (approximately)
//! the maximal empty ball touching p, whose centre is a medial-axis point.
//!
//! **Guards** (Ma et al. §4, noise handling):
//! - *Separation angle.* When the new centre c′ sees p and q at an angle
//!   ∠pc′q below `min_separation`, q is a near neighbour of p on the same
//!   sheet of surface (facets of a tessellated curve, a crease, sampling
//!   noise), not a second surface the ball is squeezed between. The shrink is
//!   refused and the current ball is the result. If that happens on the very
//!   first step, the point has no medial ball.
//! - *Iteration cap.* At most `max_iterations` shrinks; the ball reached then
//!   is the result, flagged as not converged.
//! - *Unbounded.* A ball that never shrinks (its side of the surface opens to
//!   the sky within `initial_radius`) has no medial ball.
//!
//! Points closer to p than `1e-6 × initial_radius` count as p itself, so
//! coincident samples (two-sided surfaces, duplicated faces) never shrink a
//! ball to nothing.

use glam::Vec3;
use kiddo::{ImmutableKdTree, SquaredEuclidean};
use std::num::NonZero;

/// The surface samples, indexed for nearest-point queries.
pub struct SurfaceIndex {
    points: Vec<Vec3>,
    tree: Option<ImmutableKdTree<f32, 3>>,
}

/// How many nearest samples a query fetches, so that a few coincident copies
/// of p can be skipped without a second query.
const NEAREST_K: usize = 4;

impl SurfaceIndex {
    /// Indexes `points` (any number, including none).
    pub fn new(points: Vec<Vec3>) -> SurfaceIndex {
        let coords: Vec<[f32; 3]> = points.iter().map(|p| p.to_array()).collect();
        let tree = ImmutableKdTree::<f32, 3>::new_from_slice(&coords).ok();
        SurfaceIndex { points, tree }
    }

    /// The sample nearest to `c` among those farther than `exclude_radius`
    /// from `p`. Contract: `None` only when no such sample exists.
    pub fn nearest_other(&self, c: Vec3, p: Vec3, exclude_radius: f32) -> Option<Vec3> {
        let tree = self.tree.as_ref()?;
        let ex2 = exclude_radius * exclude_radius;
        let mut k = NEAREST_K.min(self.points.len());
        loop {
            let found = tree
                .query(&c.to_array())
                .nearest_n::<SquaredEuclidean<f32>>(NonZero::new(k)?)
                .execute();
            if let Some(q) = found
                .iter()
                .map(|r| self.points[r.item as usize])
                .find(|q| q.distance_squared(p) > ex2)
            {
                return Some(q);
            }
            if k == self.points.len() {
                return None;
            }
            k = (k * 4).min(self.points.len());
        }
    }
}

/// Parameters of one shrink (module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ShrinkParams {
    /// Radius of the starting ball.
    pub initial_radius: f32,
    /// Smallest ∠pc′q accepted for a shrink, radians.
    pub min_separation: f32,
    /// Most shrinks.
    pub max_iterations: u32,
}

/// A medial ball.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MedialBall {
    /// Centre: a medial-axis point.
    pub center: Vec3,
    /// Radius: the centre's distance to the surface samples.
    pub radius: f32,
    /// The sample that stopped the ball, opposite p.
    pub touching: Vec3,
    /// Whether the ball is empty (false when the iteration cap stopped it).
    pub converged: bool,
}

/// Why a point produced no medial ball.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NoBall {
    /// The ball never shrank: free space opens up beyond `initial_radius`.
    Unbounded,
    /// The first shrink was refused by the separation-angle guard.
    Noise,
}

/// Shrinks the ball tangent at `p` with free-space normal `n` (unit) against
/// the samples in `index` (module docs).
///
/// Contract: on success the ball is tangent at p (`center = p + radius·n`),
/// `0 < radius < initial_radius`, `touching` is a sample of `index`, and
/// when `converged` no sample other than p lies strictly inside the ball
/// (up to a relative tolerance of 1e-5).
pub fn shrink_ball(
    p: Vec3,
    n: Vec3,
    index: &SurfaceIndex,
    params: &ShrinkParams,
) -> Result<MedialBall, NoBall> {
    let exclude = 1e-6 * params.initial_radius;
    let min_cos = params.min_separation.cos();
    let finish = |radius: f32, touching: Option<Vec3>, converged: bool, none: NoBall| {
        touching
            .map(|touching| MedialBall {
                center: p + n * radius,
                radius,
                touching,
                converged,
            })
            .ok_or(none)
    };
    let mut radius = params.initial_radius;
    let mut touching = None;
    for step in 0..=params.max_iterations {
        let center = p + n * radius;
        let Some(q) = index.nearest_other(center, p, exclude) else {
            break;
        };
        if q.distance(center) >= radius * (1.0 - 1e-5) {
            break;
        }
        if step == params.max_iterations {
            return finish(radius, touching, false, NoBall::Unbounded);
        }
        // q inside a ball tangent at p implies n·(q − p) > 0.
        let along = n.dot(q - p).max(f32::MIN_POSITIVE);
        let next = (p.distance_squared(q) / (2.0 * along)).min(radius);
        let c_next = p + n * next;
        let separation_cos = (p - c_next)
            .normalize_or_zero()
            .dot((q - c_next).normalize_or_zero());
        if separation_cos > min_cos {
            return finish(radius, touching, false, NoBall::Noise);
        }
        radius = next;
        touching = Some(q);
    }
    finish(radius, touching, true, NoBall::Unbounded)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Samples of the square [−h, h]² at height `y`, spacing `s`.
    fn plane(y: f32, h: f32, s: f32) -> Vec<Vec3> {
        let n = (2.0 * h / s).round() as i32;
        let mut out = Vec::new();
        for i in 0..=n {
            for j in 0..=n {
                out.push(Vec3::new(-h + i as f32 * s, y, -h + j as f32 * s));
            }
        }
        out
    }

    const PARAMS: ShrinkParams = ShrinkParams {
        initial_radius: 100.0,
        min_separation: 0.35, // 20 degrees
        max_iterations: 64,
    };

    #[test]
    fn a_point_between_parallel_planes_converges_to_the_mid_plane() {
        // Planes y = 0 and y = 1; start from an off-grid point of the lower
        // plane so that no sample lies straight above it.
        let mut pts = plane(0.0, 3.0, 0.05);
        pts.extend(plane(1.0, 3.0, 0.05));
        let p = Vec3::new(0.31, 0.0, -0.18);
        pts.push(p);
        let index = SurfaceIndex::new(pts);
        let ball = shrink_ball(p, Vec3::Y, &index, &PARAMS).unwrap();
        assert!(ball.converged);
        // Hand-computed: the ball through a sample of y = 1 tangent at p has
        // r = (d² + 1) / 2 for horizontal offset d ≤ 0.025√2, so r ∈ [0.5, 0.5007].
        assert!((ball.radius - 0.5).abs() < 1e-3, "{ball:?}");
        assert!((ball.center.y - 0.5).abs() < 1e-3, "{ball:?}");
        assert!((ball.center.x - p.x).abs() < 1e-6 && (ball.center.z - p.z).abs() < 1e-6);
        assert!((ball.touching.y - 1.0).abs() < 1e-6);
    }

    #[test]
    fn a_point_inside_a_sphere_converges_to_the_centre() {
        // A sphere of radius 2 at (1, 2, 3), sampled densely; p on it with the
        // inward normal.
        let centre = Vec3::new(1.0, 2.0, 3.0);
        let dirs = crate::sampling::fibonacci_sphere(20_000);
        let pts: Vec<Vec3> = dirs.iter().map(|d| centre + *d * 2.0).collect();
        let p = pts[777];
        let n = (centre - p).normalize();
        let index = SurfaceIndex::new(pts);
        let ball = shrink_ball(p, n, &index, &PARAMS).unwrap();
        assert!(ball.converged);
        assert!((ball.radius - 2.0).abs() < 0.01, "{ball:?}");
        assert!(ball.center.distance(centre) < 0.01, "{ball:?}");
    }

    #[test]
    fn the_separation_guard_ignores_a_bump_next_to_p() {
        // Planes y = 0 and y = 1 plus one noisy sample just above p's plane:
        // the ball through it tangent at p has r = (0.05² + 0.01²) / 0.02
        // = 0.13, seen from that centre at atan(0.05 / 0.12) ≈ 22.6° from p.
        let mut pts = plane(0.0, 2.0, 0.1);
        pts.extend(plane(1.0, 2.0, 0.1));
        let p = Vec3::new(0.0, 0.0, 0.0);
        pts.push(Vec3::new(0.05, 0.01, 0.0));
        let index = SurfaceIndex::new(pts);
        let guarded = ShrinkParams {
            min_separation: 30f32.to_radians(),
            ..PARAMS
        };
        let ball = shrink_ball(p, Vec3::Y, &index, &guarded).unwrap();
        assert!(
            (ball.radius - 0.5).abs() < 1e-4,
            "guard keeps the mid-plane ball: {ball:?}"
        );
        assert!(
            !ball.converged,
            "the guard stopped it, so the ball is not empty"
        );
        let unguarded = ShrinkParams {
            min_separation: 10f32.to_radians(),
            ..PARAMS
        };
        let ball = shrink_ball(p, Vec3::Y, &index, &unguarded).unwrap();
        assert!((ball.radius - 0.13).abs() < 1e-4, "{ball:?}");
        assert!(ball.converged);
    }

    #[test]
    fn open_sides_and_iteration_caps() {
        // A lone plane: nothing above p, the ball never shrinks.
        let pts = plane(0.0, 2.0, 0.1);
        let index = SurfaceIndex::new(pts.clone());
        assert_eq!(
            shrink_ball(Vec3::ZERO, Vec3::Y, &index, &PARAMS),
            Err(NoBall::Unbounded)
        );
        // Floor y = 0, ceiling y = 1 and a wall x = 2.2: from p near the
        // wall the first shrink finds the ceiling (r ≈ 0.5), later ones the
        // wall, ending at the corner's ball of radius 0.25. A cap of one stops
        // at the ceiling, unconverged.
        let mut room = plane(0.0, 2.0, 0.05);
        room.extend(plane(1.0, 2.0, 0.05));
        room.extend(
            plane(0.0, 2.0, 0.05)
                .iter()
                .filter(|q| q.x >= 0.0 && q.x <= 1.0)
                .map(|q| Vec3::new(2.2, q.x, q.z)),
        );
        let index = SurfaceIndex::new(room);
        let p = Vec3::new(1.95, 0.0, 0.01);
        let full = shrink_ball(p, Vec3::Y, &index, &PARAMS).unwrap();
        assert!(
            full.converged && (full.radius - 0.25).abs() < 2e-3,
            "{full:?}"
        );
        assert!((full.touching.x - 2.2).abs() < 1e-6);
        let capped = shrink_ball(
            p,
            Vec3::Y,
            &index,
            &ShrinkParams {
                max_iterations: 1,
                ..PARAMS
            },
        )
        .unwrap();
        assert!(!capped.converged);
        assert!((capped.radius - 0.5).abs() < 2e-3, "{capped:?}");
        // An empty index gives no ball rather than a panic.
        let empty = SurfaceIndex::new(Vec::new());
        assert_eq!(
            shrink_ball(Vec3::ZERO, Vec3::Y, &empty, &PARAMS),
            Err(NoBall::Unbounded)
        );
    }
}
