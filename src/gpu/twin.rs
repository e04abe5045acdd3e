//! The CPU twins of the kernels: the same answers from the Rust code the
//! kernels mirror, in the kernels' record format, so that tests compare
//! the two record by record and `render` can run without a GPU.

use super::interface::{kind, Query, Record};
use crate::lightfield::LightField;
use crate::trace::gather;
use crate::trace::single::{March, Steps};
use crate::trace::{self, RayOutcome, Selection};
use bytemuck::Zeroable;
use glam::Vec3;
use rayon::prelude::*;

/// What `trace_rays` computes for each query, on the CPU.
///
/// Contract: record `i` answers query `i` and equals the kernel's record up
/// to floating-point rounding; deterministic whatever the thread count.
pub fn trace_rays(
    field: &LightField,
    selection: &Selection,
    queries: &[Query],
    march: March,
) -> Vec<Record> {
    queries
        .par_iter()
        .map(|q| {
            let (origin, dir) = (Vec3::from(q.origin), Vec3::from(q.dir));
            let mut steps = Steps::default();
            let outcome = trace::trace(field, selection, origin, dir, q.t_max, march, &mut steps);
            let (kind, t) = match outcome {
                RayOutcome::Hit { t, .. } => (kind::HIT, t),
                RayOutcome::Miss { .. } => (kind::MISS, q.t_max),
                RayOutcome::Unknown { t, probe: Some(_) } => (kind::UNKNOWN, t),
                RayOutcome::Unknown { t, probe: None } => (kind::NO_PROBE, t),
            };
            let (probe, texel, radiance) = match outcome.lookup(field, origin, dir) {
                Some((probe, texel)) => {
                    let c = field.radiance[probe as usize * field.texels() + texel as usize];
                    (probe, texel, [c[0], c[1], c[2], 1.0])
                }
                None => (u32::MAX, u32::MAX, [0.0; 4]),
            };
            Record {
                kind,
                probe,
                texel,
                t,
                fetches: steps.march_fetches(),
                probes: steps.probes,
                surfels: steps.surfels,
                pad: 0,
                radiance,
            }
        })
        .collect()
}

/// What `gather_irradiance` computes for each query, on the CPU.
///
/// Contract: as [`trace_rays`]; only `radiance` is meaningful.
pub fn gather_irradiance(
    field: &LightField,
    selection: &Selection,
    queries: &[Query],
) -> Vec<Record> {
    queries
        .par_iter()
        .map(|q| {
            let e =
                gather::irradiance_at(field, selection, Vec3::from(q.origin), Vec3::from(q.dir));
            Record {
                radiance: [e.x, e.y, e.z, 1.0],
                ..Record::zeroed()
            }
        })
        .collect()
}

/// What `blend_weights` computes for each query, on the CPU: term k (the
/// query's `t_max`) of [`gather::blend_weights`] at the query's point and
/// normal, its probe in `probe`, k in `texel` and its weight in `t`;
/// `u32::MAX` and 0 past the blend's terms.
///
/// Contract: as [`trace_rays`]; the other fields are zero.
pub fn blend_weights(field: &LightField, selection: &Selection, queries: &[Query]) -> Vec<Record> {
    queries
        .par_iter()
        .map_init(Vec::new, |terms, q| {
            let k = q.t_max as u32;
            let (p, n) = (Vec3::from(q.origin), Vec3::from(q.dir));
            gather::blend_weights(field, selection, p, n, terms);
            let (probe, t) = terms.get(k as usize).copied().unwrap_or((u32::MAX, 0.0));
            Record {
                probe,
                texel: k,
                t,
                ..Record::zeroed()
            }
        })
        .collect()
}
