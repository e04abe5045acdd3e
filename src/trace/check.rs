//! The tracer checked against exact ray casts: the light-field trace should
//! find the hit a BVH finds wherever some probe sees that hit (McGuire §4.1:
//! any probe that observes a point places it at the same world position).

use super::{single::March, single::Steps, trace, RayOutcome, Selection};
use crate::lightfield::LightField;
use crate::sampling::uniform_direction;
use crate::scene::raycast::SceneBvh;
use crate::scene::{Bounds, Scene};
use glam::Vec3;
use rayon::prelude::*;
use serde::Serialize;

/// Tally of a comparison, in rays.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct Agreement {
    /// Rays traced.
    pub rays: u64,
    /// Rays whose true hit some probe sees.
    pub seen: u64,
    /// Of those, traced hits within the texel tolerance of the true hit.
    pub agree: u64,
    /// Of those, traces that ended unknown.
    pub unknown: u64,
    /// Rays that truly leave the scene.
    pub escaping: u64,
    /// Of those, traces that report a miss.
    pub escaping_missed: u64,
    /// Texels visited (level 0 and above), summed over rays.
    pub fine_steps: u64,
    /// Coarse texels visited, summed over rays.
    pub coarse_steps: u64,
}

impl Agreement {
    /// Share of seen hits found within tolerance (1 when none was seen).
    pub fn rate(&self) -> f64 {
        if self.seen == 0 {
            1.0
        } else {
            self.agree as f64 / self.seen as f64
        }
    }

    fn add(mut self, o: Agreement) -> Agreement {
        self.rays += o.rays;
        self.seen += o.seen;
        self.agree += o.agree;
        self.unknown += o.unknown;
        self.escaping += o.escaping;
        self.escaping_missed += o.escaping_missed;
        self.fine_steps += o.fine_steps;
        self.coarse_steps += o.coarse_steps;
        self
    }
}

/// How far a traced hit may be from the true one: two texels' width at the
/// hit's distance `r` from the probe that resolved it, stretched by the
/// grazing angle (|cos| between the ray and the surface, at least 1/4), as
/// a texel's surfel spans that much depth along a slanted surface.
pub fn texel_tolerance(r: f32, n: u32, cos: f32) -> f32 {
    2.0 * r * (4.0 / n as f32) / cos.abs().max(0.25)
}

/// The box beyond which a ray has left the scene: its bounds padded by 1%
/// of the diagonal, so that walls on the bounds, stored at half precision,
/// lie well inside.
pub fn padded_bounds(bounds: &Bounds) -> Bounds {
    let pad = Vec3::splat(0.01 * bounds.size().length());
    Bounds {
        min: bounds.min - pad,
        max: bounds.max + pad,
    }
}

/// Traces one random direction from each of `origins` (directions drawn
/// from `seed`) and compares with the BVH.
pub fn compare(
    field: &LightField,
    selection: &Selection,
    scene: &Scene,
    bvh: &SceneBvh,
    origins: &[Vec3],
    seed: u64,
    march: March,
) -> Agreement {
    let diag = scene.bounds.size().length();
    let eps = 1e-4 * diag;
    let n = field.resolution;
    let bounds = padded_bounds(&scene.bounds);
    origins
        .par_iter()
        .enumerate()
        .map(|(i, &o)| {
            let d = uniform_direction(seed, i as u64);
            let t_max = bounds.exit_distance(o, d);
            let mut steps = Steps::default();
            let out = trace(field, selection, o, d, t_max, march, &mut steps);
            let mut a = Agreement {
                rays: 1,
                fine_steps: steps.fine as u64,
                coarse_steps: steps.coarse as u64,
                ..Agreement::default()
            };
            match bvh.closest_hit(o, d, 0.0, t_max) {
                None => {
                    a.escaping = 1;
                    a.escaping_missed = matches!(out, RayOutcome::Miss { .. }) as u64;
                }
                Some(hit) => {
                    let x = o + d * hit.t;
                    let back = x - d * eps;
                    let seen = field.positions.iter().any(|&p| !bvh.occluded(p, back, eps));
                    if seen {
                        a.seen = 1;
                        let cos = scene.normals[hit.triangle as usize].dot(d);
                        match out {
                            RayOutcome::Hit { t, probe } => {
                                let r = (field.positions[probe as usize] - x).length();
                                a.agree = ((t - hit.t).abs() <= texel_tolerance(r, n, cos)) as u64;
                            }
                            RayOutcome::Unknown { .. } => a.unknown = 1,
                            RayOutcome::Miss { .. } => {}
                        }
                    }
                }
            }
            a
        })
        .reduce(Agreement::default, Agreement::add)
}
