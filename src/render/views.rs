//! Views chosen from the scene alone, without looking at any placement
//! (issue 21: the comparison's views must not favour one placement).
//!
//! Wang et al. 2019 §5 measure their placements from hand-set cameras; a
//! comparison that claims to hold on scenes nobody has seen needs views a
//! rule picks. The rule, seeded and deterministic:
//!
//! 1. **Candidates**: free voxel centres at least two voxels from every
//!    surface, up to [`CANDIDATES`] of them chosen by a seeded hash.
//! 2. **Eye height where the scene has a floor**: from each candidate a ray
//!    straight down must meet a near-horizontal surface (|n·y| ≥ cos 45°);
//!    the eye stands [`EYE_HEIGHT`] above it (world units, metres in the
//!    shipped configs), or halfway to the ceiling where the room is lower,
//!    and must itself be in free space. Candidates over no floor (the sky
//!    outside a building) are dropped.
//! 3. **Looking at much of the surface**: of [`VIEW_SAMPLES`] coverable
//!    coverage samples (an even subsample), those the eye sees by the
//!    coverage rule ([`CoverageReference::sees`]) are binned by direction;
//!    the view looks along whichever of [`YAWS`] horizontal directions,
//!    pitched down by [`PITCH_DEG`], holds the most of them inside its cone
//!    of half-angle `fov/2`. The candidate's score is that count.
//! 4. **Spread over the free space**: the best-scoring candidate first, then
//!    repeatedly, among candidates scoring at least half the best, the one
//!    farthest from every view chosen (ties: the higher score, then the
//!    lower index).

use crate::config::{CameraParams, Direction, Point3};
use crate::coverage::CoverageReference;
use crate::sampling::hash2;
use crate::scene::raycast::SceneBvh;
use crate::scene::{Bounds, Scene};
use crate::sdf::{Sdf, VoxelClass};
use glam::Vec3;
use rayon::prelude::*;

/// Most candidate eye positions scored.
pub const CANDIDATES: usize = 512;
/// Coverage samples each candidate is scored on.
pub const VIEW_SAMPLES: usize = 2048;
/// Horizontal directions tried at each candidate.
pub const YAWS: usize = 16;
/// Downward pitch of every view, degrees: eyes look slightly down, as a
/// person standing does.
pub const PITCH_DEG: f32 = 10.0;
/// Eye height above the floor, world units (a standing person, in metres).
pub const EYE_HEIGHT: f32 = 1.6;

/// A chosen view and what it sees.
#[derive(Debug, Clone, PartialEq)]
pub struct View {
    /// The camera, in world coordinates as a config writes it.
    pub camera: CameraParams,
    /// Of the scored samples, how many the view's cone holds and the eye sees.
    pub seen_samples: usize,
}

/// What [`choose_views`] is asked for.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Request {
    /// Most views.
    pub count: usize,
    /// Vertical field of view of each, degrees.
    pub fov_degrees: f32,
    /// Seed of the candidates.
    pub seed: u64,
}

/// Up to `request.count` views of `scene` (module docs).
///
/// Contract: deterministic for the same inputs whatever the thread count;
/// every view's eye is in a free voxel of `sdf`, inside `domain`, above a
/// floor; fewer than `count` views when fewer candidates qualify (none in
/// a scene without floors or coverable surface).
pub fn choose_views(
    scene: &Scene,
    bvh: &SceneBvh,
    sdf: &Sdf,
    domain: &Bounds,
    reference: &CoverageReference,
    request: Request,
) -> Vec<View> {
    let Request {
        count,
        fov_degrees,
        seed,
    } = request;
    let coverable: Vec<usize> = (0..reference.samples.len())
        .filter(|&i| reference.coverable[i])
        .collect();
    let stride = coverable.len().div_ceil(VIEW_SAMPLES).max(1);
    let samples: Vec<usize> = coverable.into_iter().step_by(stride).collect();
    let mut voxels: Vec<(u64, usize)> = (0..sdf.len())
        .filter(|&v| sdf.class[v] == VoxelClass::Free && sdf.distance[v] >= 2.0 * sdf.voxel_size)
        .map(|v| (hash2(hash2(seed, 0x71E3), v as u64), v))
        .collect();
    crate::sampling::keep_least(&mut voxels, CANDIDATES);
    let cone = (0.5 * fov_degrees).to_radians().cos();
    let scored: Vec<Option<(Vec3, Vec3, usize)>> = voxels
        .par_iter()
        .map(|&(_, v)| {
            let eye = eye_above_floor(bvh, scene, sdf, domain, sdf.center(v))?;
            let seen: Vec<Vec3> = samples
                .iter()
                .map(|&i| &reference.samples[i])
                .filter(|s| reference.sees(bvh, eye, s))
                .map(|s| (s.position - eye).normalize_or_zero())
                .collect();
            let (dir, n) = (0..YAWS)
                .map(|k| {
                    let dir = view_direction(k);
                    (dir, seen.iter().filter(|d| d.dot(dir) >= cone).count())
                })
                .fold((Vec3::Z, 0), |acc, x| if x.1 > acc.1 { x } else { acc });
            (n > 0).then_some((eye, dir, n))
        })
        .collect();
    let cands: Vec<(Vec3, Vec3, usize)> = scored.into_iter().flatten().collect();
    let Some(best) = cands.iter().map(|c| c.2).max() else {
        return Vec::new();
    };
    let eligible: Vec<&(Vec3, Vec3, usize)> = cands.iter().filter(|c| 2 * c.2 >= best).collect();
    let mut chosen: Vec<usize> = Vec::new();
    let mut nearest = vec![f32::INFINITY; eligible.len()];
    while chosen.len() < count.min(eligible.len()) {
        let pick = (0..eligible.len())
            .filter(|k| !chosen.contains(k))
            .max_by(|&a, &b| {
                nearest[a]
                    .total_cmp(&nearest[b])
                    .then(eligible[a].2.cmp(&eligible[b].2))
                    .then(b.cmp(&a))
            })
            .expect("an unchosen candidate");
        chosen.push(pick);
        for (k, d) in nearest.iter_mut().enumerate() {
            *d = d.min(eligible[k].0.distance(eligible[pick].0));
        }
    }
    chosen
        .into_iter()
        .map(|k| {
            let (eye, dir, n) = *eligible[k];
            let world = |p: Vec3| Point3(scene.to_world(p).to_array());
            View {
                camera: CameraParams {
                    position: world(eye),
                    look_at: world(eye + dir),
                    up: Direction([0.0, 1.0, 0.0]),
                    fov_degrees,
                },
                seen_samples: n,
            }
        })
        .collect()
}

/// Direction `k` of [`YAWS`]: yaw `k/YAWS` of a turn, pitched down by
/// [`PITCH_DEG`].
fn view_direction(k: usize) -> Vec3 {
    let yaw = std::f32::consts::TAU * k as f32 / YAWS as f32;
    let pitch = PITCH_DEG.to_radians();
    Vec3::new(
        yaw.cos() * pitch.cos(),
        -pitch.sin(),
        yaw.sin() * pitch.cos(),
    )
}

/// The eye over the floor below `p` (module docs, step 2), or `None`.
fn eye_above_floor(
    bvh: &SceneBvh,
    scene: &Scene,
    sdf: &Sdf,
    domain: &Bounds,
    p: Vec3,
) -> Option<Vec3> {
    let far = domain.size().length();
    let down = bvh.closest_hit(p, Vec3::NEG_Y, 0.0, far)?;
    if scene.normals[down.triangle as usize].y.abs() < std::f32::consts::FRAC_1_SQRT_2 {
        return None;
    }
    let floor = p - Vec3::Y * down.t;
    let ceiling = bvh
        .closest_hit(floor + Vec3::Y * 1e-3 * sdf.voxel_size, Vec3::Y, 0.0, far)
        .map_or(domain.max.y - floor.y, |h| h.t);
    let eye = floor + Vec3::Y * EYE_HEIGHT.min(0.5 * ceiling);
    let free = sdf
        .voxel_at(eye)
        .is_some_and(|v| sdf.class[v] == VoxelClass::Free && sdf.distance[v] > 0.0);
    (free && domain.contains(eye)).then_some(eye)
}

#[cfg(test)]
mod tests {
    use super::*;

    const REQUEST: Request = Request {
        count: 4,
        fov_degrees: 60.0,
        seed: 1,
    };

    fn room() -> (Scene, SceneBvh, Sdf, CoverageReference) {
        crate::coverage::test_room()
    }

    #[test]
    fn views_stand_over_the_floor_spread_out_and_look_at_the_room() {
        let (scene, bvh, sdf, reference) = room();
        let domain = scene.bounds;
        let views = choose_views(&scene, &bvh, &sdf, &domain, &reference, REQUEST);
        assert_eq!(views.len(), 4);
        for v in &views {
            let eye = scene.to_local(glam::DVec3::from(v.camera.position.0));
            let voxel = sdf.voxel_at(eye).expect("in the grid");
            assert_eq!(sdf.class[voxel], VoxelClass::Free);
            assert!(v.seen_samples > 0);
            // The eye is at most the eye height over the floor below it.
            let down = bvh.closest_hit(eye, Vec3::NEG_Y, 0.0, 100.0).unwrap();
            assert!(down.t <= EYE_HEIGHT + 1e-4, "{}", down.t);
        }
        // Spread: no two eyes share a voxel.
        for (i, a) in views.iter().enumerate() {
            for b in &views[..i] {
                assert_ne!(a.camera.position, b.camera.position);
            }
        }
        // Deterministic; in this small room every free voxel is a
        // candidate, so the four corners win whatever the seed.
        let again = choose_views(&scene, &bvh, &sdf, &domain, &reference, REQUEST);
        assert_eq!(views, again);
    }

    #[test]
    fn a_view_looks_the_way_that_sees_the_most() {
        let (scene, bvh, sdf, reference) = room();
        let views = choose_views(
            &scene,
            &bvh,
            &sdf,
            &scene.bounds,
            &reference,
            Request {
                count: 1,
                ..REQUEST
            },
        );
        let v = &views[0];
        let eye = scene.to_local(glam::DVec3::from(v.camera.position.0));
        let cone = 30f32.to_radians().cos();
        let count = |dir: Vec3| {
            reference
                .samples
                .iter()
                .enumerate()
                .filter(|&(i, s)| {
                    reference.coverable[i]
                        && reference.sees(&bvh, eye, s)
                        && (s.position - eye).normalize().dot(dir) >= cone
                })
                .count()
        };
        let chosen = (scene.to_local(glam::DVec3::from(v.camera.look_at.0)) - eye).normalize();
        let all: Vec<usize> = (0..YAWS).map(|k| count(view_direction(k))).collect();
        let mean = all.iter().sum::<usize>() as f64 / all.len() as f64;
        assert!(
            count(chosen) as f64 > mean,
            "{} against a mean of {mean}",
            count(chosen)
        );
    }
}
