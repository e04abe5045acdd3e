//! The diffuse evaluation of `compare`: receivers and their reference,
//! once per comparison, then each placement's SH blended at them as
//! engines blend it ([`crate::diffuse`] has the method and why).
//!
//! It runs on the scene's own materials, whatever `compare.materials`
//! says: engines bake probe light with the scene's albedo and leave
//! glossy light to reflection probes, and an all-glossy stand-in smooths
//! the bounce light until every placement's error crowds together.

use super::prepare::Prepared;
use crate::config::{CameraParams, Config};
use crate::diffuse::{self, Errors, Receivers, ShLookup};
use crate::reachable::{self, Reachable};
use crate::render::probes::GBuffer;
use crate::render::Renderer;
use crate::sampling::fibonacci_sphere;
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
    // Both counts 0 is documented as no diffuse evaluation: nothing of it
    // runs (`bench` is `None`), so nothing is to bound — the probes' SH
    // are taken only at receivers.
    if receivers == 0.0 {
        return Ok(());
    }
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

/// The primary hits of `camera` (camera `index` of the comparison) at the
/// reference's size: the surface points a view sees, with their normals.
pub fn view_hits(config: &Config, prepared: &Prepared, camera: &CameraParams, index: usize) -> GBuffer {
    let direct = Renderer::new(&prepared.scene, &prepared.bvh, &config.lights, 0);
    crate::render::probes::gbuffer(
        &direct,
        camera,
        config.reference.width.0,
        config.reference.height.0,
        1,
        &prepared.scene.bounds,
        config.seed ^ index as u64,
    )
}

/// The diffuse evaluation's fixed inputs: free space reached from the
/// config's `cameras`, the surface receivers of the views' primary hits
/// (`views`) shared evenly among them, the free receivers, and the
/// reference at each. `None` when `compare.diffuse.surface_receivers` and
/// `free_receivers` are both 0.
///
/// Contract: deterministic for a config whatever the thread count.
pub fn bench(
    config: &Config,
    prepared: &Prepared,
    views: &[&GBuffer],
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
        .flat_map(|(i, v)| diffuse::surface_receivers(&v.irradiance, per_view, i as u32))
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
    pub tetrahedra: Measured,
    /// Probes dropped from the SH blend as standing in solid
    /// ([`crate::coverage::stands_free`]).
    pub invalid_probes: usize,
    /// Probes in open space no camera reaches (sealed voids).
    pub unreachable_probes: usize,
    /// Probes that see no reachable free space at all ([`idle_probes`]):
    /// unreachable, and no ray of theirs crosses reached space.
    pub idle_probes: usize,
}

/// Measures the placement whose probes stand at `positions` (`valid`:
/// each one's [`crate::coverage::probes_free`] verdict) against `bench`.
///
/// Contract: `valid` as long as `positions`; deterministic whatever the
/// thread count.
pub fn measure(
    config: &Config,
    prepared: &Prepared,
    bench: &Bench,
    positions: &[Vec3],
    valid: &[bool],
) -> DiffuseMeasure {
    let d = &config.compare.diffuse;
    let renderer = prepared.renderer(config);
    let sh = diffuse::bake_sh(&renderer, positions, d.probe_rays.0, config.seed ^ 0x5A5A);
    let lookup = ShLookup::new(positions, &sh, valid);
    let r = &bench.receivers;
    let at = |rs: &[diffuse::Receiver]| -> Vec<diffuse::Irradiance> {
        rs.par_iter().map(|x| lookup.irradiance(x)).collect()
    };
    let unreachable_probes = positions
        .iter()
        .filter(|&&p| bench.reachable.excludes(&prepared.sdf, p))
        .count();
    DiffuseMeasure {
        tetrahedra: Measured {
            surface: Errors::measure(&r.surface, &r.surface_reference, &at(&r.surface)),
            free: Errors::measure(&r.free, &r.free_reference, &at(&r.free)),
        },
        invalid_probes: valid.iter().filter(|&&v| !v).count(),
        unreachable_probes,
        idle_probes: idle_probes(prepared, &bench.reachable, positions)
            .iter()
            .filter(|&&i| i)
            .count(),
    }
}

/// Directions [`idle_probes`] looks along from each probe.
const IDLE_RAYS: u32 = 64;

/// Whether each probe at `positions` serves nothing a viewer sees: it
/// stands outside `reachable`, and none of [`IDLE_RAYS`] rays from it
/// (spread evenly over the sphere) crosses a reached voxel before it hits
/// a surface or leaves the domain (stepping a voxel at a time). A probe in
/// a sealed void, or in the attic over a vault, lights no receiver a
/// player meets; users count it as waste (godot-proposals #7900).
///
/// Contract: deterministic; a probe in reached space is never idle.
pub fn idle_probes(prepared: &Prepared, reachable: &Reachable, positions: &[Vec3]) -> Vec<bool> {
    let sdf = &prepared.sdf;
    let dirs = fibonacci_sphere(IDLE_RAYS);
    let far = prepared.domain.size().length();
    positions
        .par_iter()
        .map(|&p| {
            if reachable.contains(sdf, p) {
                return false;
            }
            !dirs.iter().any(|&d| {
                let end = prepared
                    .bvh
                    .closest_hit(p, d, 0.0, far)
                    .map_or(far, |h| h.t);
                let steps = (end / sdf.voxel_size).ceil().min(1e6) as u32;
                (1..=steps).any(|k| {
                    let t = (k as f32 * sdf.voxel_size).min(end);
                    reachable.contains(sdf, p + d * t)
                })
            })
        })
        .collect()
}

/// Widest picture of a [`LitView`] (its height keeps the reference's
/// aspect): the figures need no more, and the reference's paths per
/// pixel are its cost.
pub const LIT_VIEW_WIDTH: u32 = 192;

/// One view as a lighting artist reads it: each pixel lit by the light
/// the renderer shades itself (emission, the point, spot and directional
/// lights' direct light) and its albedo times a baked irradiance, from the
/// probes' blend ([`LitView::render`]) or from the path tracer
/// ([`LitView::reference`]).
pub struct LitView {
    /// Pixels across.
    pub width: u32,
    /// Pixels down.
    pub height: u32,
    /// Per pixel: emission and the delta lights' direct light.
    direct: Vec<Vec3>,
    /// Per pixel: `kd′ / π`, what irradiance is multiplied by.
    albedo: Vec<Vec3>,
    /// Per pixel: its receiver (an index into `receivers`), for pixels
    /// with a surface.
    receiver: Vec<Option<u32>>,
    receivers: Vec<diffuse::Receiver>,
    /// Path-traced irradiance at each receiver.
    reference: Vec<diffuse::Irradiance>,
    /// The relative error's floor ([`diffuse::dark_floor`] of the baked
    /// reference).
    floor: f64,
}

/// [`LitView`] of `camera` (camera `index` of the comparison), at most
/// [`LIT_VIEW_WIDTH`] pixels wide, its reference by `rays` paths per
/// pixel.
///
/// Contract: deterministic whatever the thread count.
pub fn lit_view(
    config: &Config,
    prepared: &Prepared,
    camera: &CameraParams,
    index: usize,
    rays: u32,
) -> LitView {
    let (w, h) = (config.reference.width.0, config.reference.height.0);
    let width = w.min(LIT_VIEW_WIDTH);
    let height = ((h as u64 * width as u64) / w.max(1) as u64).max(1) as u32;
    let direct = Renderer::new(&prepared.scene, &prepared.bvh, &config.lights, 0);
    let g = crate::render::probes::gbuffer(
        &direct,
        camera,
        width,
        height,
        1,
        &prepared.scene.bounds,
        config.seed ^ index as u64,
    );
    let mut receiver = vec![None; g.pixels.len()];
    let receivers: Vec<diffuse::Receiver> = g
        .irradiance
        .iter()
        .zip(&g.irradiance_pixel)
        .enumerate()
        .map(|(k, (q, &px))| {
            receiver[px as usize] = Some(k as u32);
            diffuse::Receiver {
                p: Vec3::from(q.origin),
                n: Vec3::from(q.dir),
                group: 0,
            }
        })
        .collect();
    let renderer = prepared.renderer(config);
    let reference = diffuse::reference(&renderer, &receivers, rays, config.seed ^ 0x11_7E3 ^ index as u64);
    LitView {
        width,
        height,
        direct: g.pixels.iter().map(|p| p.direct).collect(),
        albedo: g.pixels.iter().map(|p| p.diffuse).collect(),
        receiver,
        floor: diffuse::dark_floor(reference.iter().map(|e| e.baked)),
        receivers,
        reference,
    }
}

impl LitView {
    /// The pixels with irradiance `baked` at each receiver.
    fn lit(&self, baked: impl Fn(usize) -> Vec3) -> Vec<[f32; 3]> {
        (0..self.direct.len())
            .map(|i| {
                let e = self.receiver[i].map_or(Vec3::ZERO, |k| baked(k as usize));
                (self.direct[i] + self.albedo[i] * e).to_array()
            })
            .collect()
    }

    /// The view lit by the path tracer's baked irradiance.
    pub fn reference(&self) -> Vec<[f32; 3]> {
        self.lit(|k| self.reference[k].baked)
    }

    /// The view lit by `lookup`'s blend, and each pixel's relative error
    /// of the baked irradiance (0 without a surface).
    pub fn render(&self, lookup: &ShLookup) -> (Vec<[f32; 3]>, Vec<f32>) {
        let got: Vec<diffuse::Irradiance> = self
            .receivers
            .par_iter()
            .map(|r| lookup.irradiance(r))
            .collect();
        let image = self.lit(|k| got[k].baked);
        let error = self
            .receiver
            .iter()
            .map(|r| {
                r.map_or(0.0, |k| {
                    let k = k as usize;
                    diffuse::relative_error(got[k].baked, self.reference[k].baked, self.floor) as f32
                })
            })
            .collect();
        (image, error)
    }
}

/// A relative-error map: black at 0, through red and yellow to white at
/// 1 (100%) and above.
pub fn error_map(error: &[f32], width: u32, height: u32) -> crate::raster::RgbImage {
    crate::raster::RgbImage::from_fn(width, height, |x, y| {
        let e = error[(y * width + x) as usize].clamp(0.0, 1.0);
        let ramp = |lo: f32| ((e - lo) * 3.0).clamp(0.0, 1.0);
        [ramp(0.0), ramp(1.0 / 3.0), ramp(2.0 / 3.0)].map(|v| (v * 255.0).round() as u8)
    })
}

/// What lights `scene` under `config`: its emissive materials (with the
/// triangles that use them) and the point, spot, directional and sky
/// lights of the config and the scene file.
pub fn emitters(config: &Config, scene: &crate::scene::Scene) -> Emitters {
    use crate::config::Light;
    let mut triangles = vec![0usize; scene.materials.len()];
    for &m in &scene.material_ids {
        if let Some(t) = triangles.get_mut(m as usize) {
            *t += 1;
        }
    }
    let emissive_materials = scene
        .materials
        .iter()
        .zip(&triangles)
        .filter(|(m, &t)| t > 0 && m.emission.iter().any(|&e| e.is_finite() && e > 0.0))
        .map(|(m, &t)| EmissiveMaterial {
            name: m.name.clone(),
            emission: m.emission,
            triangles: t,
        })
        .collect();
    let lights = super::bake::lit_by_scene(config, scene);
    let count = |f: fn(&Light) -> bool| lights.lights.iter().filter(|l| f(l)).count();
    Emitters {
        emissive_materials,
        point_lights: count(|l| matches!(l, Light::Point { .. })),
        spot_lights: count(|l| matches!(l, Light::Spot { .. })),
        directional_lights: count(|l| matches!(l, Light::Directional { .. })),
        sky: lights.lights.iter().any(|l| matches!(l, Light::Sky { .. })),
    }
}

/// The scene's lights: its emissive materials and the lights the config
/// and the scene file add.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct Emitters {
    /// Emissive materials (`Ke` above 0): area lights on both sides.
    pub emissive_materials: Vec<EmissiveMaterial>,
    /// Point lights.
    pub point_lights: usize,
    /// Spot lights.
    pub spot_lights: usize,
    /// Directional lights.
    pub directional_lights: usize,
    /// Whether a sky lights it.
    pub sky: bool,
}

/// An emissive material.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct EmissiveMaterial {
    /// Its name in the scene file.
    pub name: String,
    /// Its emission, RGB.
    pub emission: [f32; 3],
    /// Triangles that use it.
    pub triangles: usize,
}


/// One probe set's render of a [`LitView`].
pub struct LitRender {
    /// The set's name (`ours`, `grid:NxMxK`).
    pub name: String,
    /// Its probes.
    pub probes: usize,
    /// The view lit by its blend.
    pub image: Vec<[f32; 3]>,
    /// Each pixel's relative error of the baked irradiance.
    pub error: Vec<f32>,
    /// Their mean over the view's surface pixels.
    pub mean_error: f64,
}

impl LitView {
    /// The render of the probes at `positions` with light `sh` (those in
    /// solid by their own rays dropped, as engines drop them), named
    /// `name`.
    pub fn render_set(
        &self,
        prepared: &Prepared,
        name: &str,
        positions: &[Vec3],
        sh: &[diffuse::ProbeSh],
    ) -> LitRender {
        let valid = crate::coverage::probes_free(&prepared.bvh, prepared.sdf.voxel_size, positions);
        let lookup = ShLookup::new(positions, sh, &valid);
        let (image, error) = self.render(&lookup);
        let on: Vec<f64> = self
            .receiver
            .iter()
            .zip(&error)
            .filter(|(r, _)| r.is_some())
            .map(|(_, &e)| e as f64)
            .collect();
        LitRender {
            name: name.to_string(),
            probes: positions.len(),
            image,
            error,
            mean_error: diffuse::mean(&on).unwrap_or(0.0),
        }
    }

    /// The equal-count uniform grid of a set of `count` probes in
    /// `prepared`'s domain (the sweep's grid nearest the count), placed,
    /// and its SH baked as `bake_sh` bakes with `rays` and `seed`: the
    /// rival the figures set beside ours.
    pub fn grid_beside(
        config: &Config,
        prepared: &Prepared,
        count: usize,
        rays: u32,
        seed: u64,
    ) -> Option<(String, Vec<Vec3>, Vec<diffuse::ProbeSh>)> {
        let sweep = crate::placement::grid::grid_sweep(&prepared.domain, count);
        let g = sweep
            .iter()
            .min_by_key(|g| (g.probes().abs_diff(count), std::cmp::Reverse(g.probes())))?;
        let progress = crate::progress::Progress::hidden();
        let input = prepared.placement_input(config.seed, &progress);
        let method = crate::config::Placement::Grid(*g);
        let set = crate::placement::place(&method, &input).ok()?;
        let positions = set.positions();
        if positions.is_empty() {
            return None;
        }
        let renderer = prepared.renderer(config);
        let sh = diffuse::bake_sh(&renderer, &positions, rays, seed);
        Some((method.name(), positions, sh))
    }
}
