//! Regions of influence (Wang et al. 2019 §4.1, Fig. 7, after Sébastien and
//! Zanuttini 2012): "the influence distance for each face of a probe's
//! bounding cube is set as the median of the probe's sampled radial
//! distances".
//!
//! A probe's radial distances are sampled the way its radial-distance map
//! stores them (McGuire et al. 2017 §3): one ray through the centre of each
//! texel of an `n`×`n` octahedral map. A direction belongs to the cube face
//! its largest component points at. A ray that leaves the domain without a
//! hit is cut at the domain's boundary, which bounds influence to the scene
//! as §5 notes. The box is then clipped to the domain.
//!
//! The same rays give Ω̄_k, the probe's mean projected solid angle term of
//! eq. 2 (−ω·n over the front faces it sees), which ranks probes at a leaf.

use crate::lightfield::octahedral;
use crate::scene::raycast::SceneBvh;
use crate::scene::{Bounds, Scene};
use glam::Vec3;
use rayon::prelude::*;

/// Smallest Ω̄ a probe is given, so that a probe that sees only back faces
/// (one standing inside a solid) still ranks by visibility and distance.
pub const MIN_OMEGA_BAR: f32 = 1e-3;

/// One probe's region of influence and its ranking term.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Influence {
    /// The probe's position.
    pub position: Vec3,
    /// The influence box, clipped to the domain.
    pub region: Bounds,
    /// Median radial distance per face, in the order −x, +x, −y, +y, −z, +z.
    pub face_distance: [f32; 6],
    /// Ω̄_k: mean of −ω·n over the directions that hit a front face, at
    /// least [`MIN_OMEGA_BAR`].
    pub omega_bar: f32,
}

impl Influence {
    /// Whether the influence box overlaps the box `lo..hi` (boundaries
    /// included).
    pub fn overlaps(&self, lo: Vec3, hi: Vec3) -> bool {
        self.region.min.cmple(hi).all() && self.region.max.cmpge(lo).all()
    }
}

/// The cube face a direction points at: 0..6 for −x, +x, −y, +y, −z, +z.
pub fn face_of(d: Vec3) -> usize {
    let a = d.abs();
    let axis = if a.x >= a.y && a.x >= a.z {
        0
    } else if a.y >= a.z {
        1
    } else {
        2
    };
    2 * axis + usize::from(d[axis] > 0.0)
}

/// The influence of every probe at `positions`, sampled with `n`×`n`
/// octahedral directions.
///
/// Contract: one entry per probe, in order; each region contains its probe
/// (clipped to `domain`) and every face distance is finite and ≥ 0. The
/// result does not depend on thread scheduling.
pub fn influences(
    scene: &Scene,
    bvh: &SceneBvh,
    domain: &Bounds,
    positions: &[Vec3],
    n: u32,
) -> Vec<Influence> {
    let directions = octahedral::texel_directions(n);
    positions
        .par_iter()
        .map(|&p| influence(scene, bvh, domain, p, &directions))
        .collect()
}

/// One probe's influence from the rays along `directions`.
fn influence(
    scene: &Scene,
    bvh: &SceneBvh,
    domain: &Bounds,
    p: Vec3,
    directions: &[Vec3],
) -> Influence {
    let mut per_face: [Vec<f32>; 6] = Default::default();
    let mut omega_sum = 0.0f64;
    for &d in directions {
        let exit = domain.exit_distance(p, d);
        // Walls often lie on the domain's boundary (an automatic domain is
        // the scene's bounds): look a little past it so they still count.
        let r = match bvh.closest_hit(p, d, 0.0, exit * 1.001 + 1e-6) {
            Some(hit) => {
                if !hit.backface {
                    let normal = scene.normals[hit.triangle as usize];
                    omega_sum += f64::from((-d.dot(normal)).max(0.0));
                }
                hit.t.min(exit)
            }
            None => exit,
        };
        per_face[face_of(d)].push(if r.is_finite() { r } else { 0.0 });
    }
    let mut face_distance = [0.0f32; 6];
    for (f, distances) in per_face.iter_mut().enumerate() {
        face_distance[f] = median(distances);
    }
    let lo = p - Vec3::new(face_distance[0], face_distance[2], face_distance[4]);
    let hi = p + Vec3::new(face_distance[1], face_distance[3], face_distance[5]);
    Influence {
        position: p,
        region: Bounds {
            min: lo.max(domain.min).min(p),
            max: hi.min(domain.max).max(p),
        },
        face_distance,
        omega_bar: ((omega_sum / directions.len().max(1) as f64) as f32).max(MIN_OMEGA_BAR),
    }
}

/// The median of `v` (the lower middle for an even count); 0 when empty.
fn median(v: &mut [f32]) -> f32 {
    if v.is_empty() {
        return 0.0;
    }
    let mid = (v.len() - 1) / 2;
    let (_, m, _) = v.select_nth_unstable_by(mid, f32::total_cmp);
    *m
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::testing::add_box;
    use crate::scene::Material;

    /// A closed room 4 × 2 × 2 (inward-facing walls).
    fn room() -> (Scene, SceneBvh) {
        let mut tris = Vec::new();
        add_box(&mut tris, Vec3::ZERO, Vec3::new(4.0, 2.0, 2.0), true);
        let scene = Scene::from_triangles(
            "room".into(),
            tris.into_iter().map(|t| (t, 0)),
            vec![Material::fallback()],
        )
        .unwrap();
        let bvh = SceneBvh::new(&scene);
        (scene, bvh)
    }

    #[test]
    fn faces_follow_the_largest_component() {
        assert_eq!(face_of(Vec3::new(-1.0, 0.2, 0.3)), 0);
        assert_eq!(face_of(Vec3::new(0.1, 0.9, -0.3)), 3);
        assert_eq!(face_of(Vec3::new(0.1, 0.2, -0.9)), 4);
        assert_eq!(face_of(Vec3::new(0.0, 0.0, 1.0)), 5);
    }

    #[test]
    fn median_distances_match_a_box_room() {
        let (scene, bvh) = room();
        let p = Vec3::new(1.0, 1.0, 1.0);
        let inf = &influences(&scene, &bvh, &scene.bounds, &[p], 64)[0];
        // Towards −x every ray of the face's cone meets the near wall first,
        // at 1/|ω.x| in [1, √3]; towards +x the far wall (3 away) competes
        // with the side walls (1 away), so the median lies between.
        assert!(
            (1.0..1.75).contains(&inf.face_distance[0]),
            "{:?}",
            inf.face_distance
        );
        assert!(
            (1.5..=3.0).contains(&inf.face_distance[1]),
            "{:?}",
            inf.face_distance
        );
        for f in 2..6 {
            assert!(
                (1.0..1.75).contains(&inf.face_distance[f]),
                "{:?}",
                inf.face_distance
            );
        }
        // The long side reaches further than the short sides.
        assert!(inf.face_distance[1] > 1.5 * inf.face_distance[0]);
        assert!(inf.region.contains(p));
        assert!(inf.region.min.cmpge(scene.bounds.min).all());
        assert!(inf.region.max.cmple(scene.bounds.max).all());
        // Seen from inside a box, every face is front-facing; Ω̄ is the mean cosine.
        assert!(
            inf.omega_bar > 0.5 && inf.omega_bar <= 1.0,
            "{}",
            inf.omega_bar
        );
    }

    #[test]
    fn rays_that_miss_stop_at_the_domain() {
        let (scene, bvh) = room();
        let domain = Bounds {
            min: Vec3::new(-10.0, -10.0, -10.0),
            max: Vec3::new(10.0, 10.0, 10.0),
        };
        // Outside the room, looking away from it: misses end at the domain.
        let p = Vec3::new(-5.0, 1.0, 1.0);
        let inf = &influences(&scene, &bvh, &domain, &[p], 32)[0];
        assert!(
            inf.face_distance[0] >= 5.0 - 1e-3,
            "{:?}",
            inf.face_distance
        );
        assert!(inf.region.min.x >= domain.min.x);
        assert!(inf.face_distance.iter().all(|d| d.is_finite() && *d >= 0.0));
    }
}
