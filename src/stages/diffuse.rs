//! The diffuse evaluation of `compare`: receivers and their reference,
//! once per comparison, then each placement's lookups measured at them
//! ([`crate::diffuse`] has the method and why).

use super::prepare::Prepared;
use crate::config::{CameraParams, Config};
use crate::diffuse::{self, Errors, Irradiance, Receivers, ShLookup};
use crate::lightfield::LightField;
use crate::reachable::{self, Reachable};
use crate::stages::validate::ValidationView;
use crate::svo::Svo;
use crate::trace::{gather, Lattice, Selection};
use glam::{DVec3, Vec3};
use rayon::prelude::*;

/// What every placement's diffuse light is measured against.
pub struct Bench {
    /// The receivers and their reference.
    pub receivers: Receivers,
    /// The free space the cameras reach (all open space without one).
    pub reachable: Reachable,
}

/// Refuses, before any work, a diffuse evaluation whose references and
/// probe projections together would run past `limits` work limits
/// ([`crate::limits`]; the error names `compare.diffuse.reference_rays`,
/// unprefixed): `receivers × reference_rays` paths, and `probe_rays` per
/// probe for at most `probes` probes over all placements, of `1 + bounces`
/// vertices each.
pub fn check(config: &Config, probes: usize, limits: f64) -> crate::error::Result<()> {
    let d = &config.compare.diffuse;
    let receivers = (d.surface_receivers.0 + d.free_receivers.0) as f64;
    let paths = receivers * d.reference_rays.0 as f64 + probes as f64 * d.probe_rays.0 as f64;
    crate::limits::check_work(
        "compare.diffuse.reference_rays",
        &format!(
            "the diffuse evaluation ({} receivers at {} paths, {} rays per probe)",
            receivers, d.reference_rays.0, d.probe_rays.0
        ),
        paths * (1.0 + config.bake.bounces.0 as f64) * super::bake::light_factor(config),
        crate::limits::rate::PATH_VERTICES * limits,
    )
}

/// The diffuse evaluation's fixed inputs: free space reached from the
/// config's `cameras`, the surface receivers of `views` shared evenly
/// among them, the free receivers, and the reference at each. `None` when
/// `compare.diffuse.surface_receivers` and `free_receivers` are both 0.
///
/// Contract: deterministic for a config whatever the thread count.
pub fn bench(
    config: &Config,
    prepared: &Prepared,
    views: &[ValidationView],
    cameras: &[CameraParams],
) -> Option<Bench> {
    let d = &config.compare.diffuse;
    if d.surface_receivers.0 == 0 && d.free_receivers.0 == 0 {
        return None;
    }
    // The placements' own reach when the config restricts them
    // (`reachable`), else what the cameras reach.
    let reachable = prepared.reachable.clone().unwrap_or_else(|| {
        let seeds: Vec<Vec3> = cameras
            .iter()
            .map(|c| prepared.scene.to_local(DVec3::from(c.position.0)))
            .collect();
        reachable::reachable(
            &prepared.sdf,
            &prepared.bvh,
            &seeds,
            config.viewer_radius(prepared.sdf.voxel_size),
        )
    });
    let per_view = (d.surface_receivers.0 as usize).div_ceil(views.len().max(1));
    let surface: Vec<_> = views
        .iter()
        .enumerate()
        .flat_map(|(i, v)| diffuse::surface_receivers(&v.gbuffer.irradiance, per_view, i as u32))
        .collect();
    let free = diffuse::free_receivers(
        &prepared.sdf,
        &reachable,
        d.free_receivers.0 as usize,
        config.seed ^ 0xD1FF,
    );
    let renderer = prepared.renderer(config);
    let rays = d.reference_rays.0;
    let surface_reference = diffuse::reference(&renderer, &surface, rays, config.seed ^ 0x5EF);
    let free_reference = diffuse::reference(&renderer, &free, rays, config.seed ^ 0xF4EE);
    Some(Bench {
        receivers: Receivers {
            surface,
            free,
            surface_reference,
            free_reference,
        },
        reachable,
    })
}

/// One lookup's errors at the surface and the free receivers.
#[derive(Debug, Clone, Default)]
pub struct Measured {
    /// At the surface receivers.
    pub surface: Errors,
    /// At the free receivers.
    pub free: Errors,
}

/// A placement's diffuse measurements.
#[derive(Debug, Clone)]
pub struct DiffuseMeasure {
    /// SH L2 over Delaunay tetrahedra of the valid probes.
    pub sh: Measured,
    /// McGuire's irradiance gather by the SVO's probes, and for a grid
    /// also by the cell's eight (trilinear): `(svo, grid)`.
    pub gather_svo: Measured,
    /// The grid's trilinear gather, for a grid.
    pub gather_grid: Option<Measured>,
    /// Probes dropped from the SH blend as standing in solid
    /// ([`crate::coverage::stands_free`]).
    pub invalid_probes: usize,
    /// Probes in open space no camera reaches (sealed voids).
    pub unreachable_probes: usize,
}

/// Measures the placement whose probes stand at `positions` (`valid`:
/// each one's [`crate::coverage::probes_free`] verdict), baked into
/// `field`, with SVO `svo` (and `lattice` when a grid) against `bench`.
///
/// Contract: `valid` as long as `positions`; deterministic whatever the
/// thread count.
#[allow(clippy::too_many_arguments)]
pub fn measure(
    config: &Config,
    prepared: &Prepared,
    bench: &Bench,
    positions: &[Vec3],
    valid: &[bool],
    field: &LightField,
    svo: &Svo,
    lattice: Option<&Lattice>,
) -> DiffuseMeasure {
    let d = &config.compare.diffuse;
    let renderer = prepared.renderer(config);
    let sh = diffuse::bake_sh(&renderer, positions, d.probe_rays.0, config.seed ^ 0x5A5A);
    let lookup = ShLookup::new(positions, &sh, valid);
    let r = &bench.receivers;
    let both = |f: &(dyn Fn(&diffuse::Receiver) -> Irradiance + Sync), indirect: bool| {
        let at = |rs: &[diffuse::Receiver]| -> Vec<Irradiance> { rs.par_iter().map(f).collect() };
        Measured {
            surface: Errors::measure(&r.surface, &r.surface_reference, &at(&r.surface), indirect),
            free: Errors::measure(&r.free, &r.free_reference, &at(&r.free), indirect),
        }
    };
    let gather_by = |selection: &Selection| {
        both(
            &|x: &diffuse::Receiver| Irradiance {
                total: gather::irradiance_at(field, selection, x.p, x.n),
                indirect: Vec3::ZERO,
            },
            false,
        )
    };
    let unreachable_probes = positions
        .iter()
        .filter(|&&p| bench.reachable.excludes(&prepared.sdf, p))
        .count();
    DiffuseMeasure {
        sh: both(&|x| lookup.irradiance(x), true),
        gather_svo: gather_by(&Selection::Svo(svo)),
        gather_grid: lattice.map(|l| gather_by(&Selection::Grid(l))),
        invalid_probes: valid.iter().filter(|&&v| !v).count(),
        unreachable_probes,
    }
}
