//! The bake stage: every probe's light-field maps (McGuire et al. 2017 §3),
//! their distance pyramid (Wang et al. 2019 §4.2) and irradiance, with
//! radiance path traced from the config's lights; and the check of the CPU
//! tracer against exact ray casts that every bake reports.

use super::prepare::Prepared;
use crate::config::params::ShDirect;
use crate::config::Config;
pub use crate::diffuse::ProbeLight;
use crate::error::Result;
use crate::lightfield::LightField;
use crate::limits;
use crate::progress::{Progress, Stopwatch};
use crate::sampling::Sampler;
use crate::svo::{self, Svo};
use crate::trace::check::{self, Agreement};
use crate::trace::{single::March, Selection};
use glam::Vec3;

/// Seed offset of the probe radiance's random streams, so they differ from
/// the reference image's even under the same config seed.
const BAKE_STREAMS: u64 = 0x1F_BA4E;

/// Seed offset of the SH projections' and their references' streams.
pub(crate) const SH_STREAMS: u64 = 0x5_4A12;

/// Free points whose random rays check the tracer in every bake.
pub const TRACER_CHECK_RAYS: usize = 4096;

/// What the bake stage produced.
pub struct Baked {
    /// The probes' maps.
    pub field: LightField,

    /// Area lights (emissive triangles) the radiance saw.
    pub area_lights: usize,
    /// Warnings for the report.
    pub warnings: Vec<String>,
    /// `geometry`, `radiance`, `pyramid`, `irradiance`.
    pub timings: Stopwatch,
}

/// `config` as the work estimates must see a run of it on `scene`: with
/// the lights the scene file defines (glTF's punctual lights,
/// [`crate::scene::Scene::lights`]) among its `lights`, since each casts
/// its shadow rays as a config light does ([`light_factor`]). The
/// estimates made before the scene is loaded count the config's alone; the
/// jobs check again with this once it is.
pub(crate) fn lit_by_scene<'a>(config: &'a Config, scene: &crate::scene::Scene) -> std::borrow::Cow<'a, Config> {
    if scene.lights.is_empty() {
        return std::borrow::Cow::Borrowed(config);
    }
    let mut c = config.clone();
    c.lights.splice(0..0, scene.lights.iter().cloned());
    std::borrow::Cow::Owned(c)
}

/// How much more a path vertex costs than at the rate's calibration (one
/// delta light besides the area and sky lights): every point, spot and
/// directional light of the config casts a shadow ray from every vertex
/// (`render::lights`, `direct_delta`), the other lights one sampled ray.
pub(crate) fn light_factor(config: &Config) -> f64 {
    let delta = config
        .lights
        .iter()
        .filter(|l| !matches!(l, crate::config::Light::Sky { .. }))
        .count() as f64;
    ((2.0 + delta) / 3.0).max(1.0)
}

/// Refuses, before any of it is allocated or traced, a bake of `probes`
/// probes that would not fit the memory budget or would run longer than
/// the work limit ([`limits`]; errors name `bake.resolution` or
/// `bake.samples`, unprefixed).
///
/// Memory: the maps in f32 (radiance, normal, distance, the distance
/// pyramid's 4/3, irradiance and moments), half as much again for the
/// working copies, and the encoded file. Work: `probes × n² × samples`
/// paths of `1 + bounces` vertices, and the irradiance and moment
/// convolutions, `probes × m² × n²` terms.
pub fn check(config: &Config, probes: usize) -> Result<()> {
    check_with(config, probes, Work::WithSh)
}

/// What a bake computes: `bake`'s maps and SH ([`probe_light`]), or the
/// maps alone (`compare`, whose diffuse evaluation projects its own SH).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Work {
    /// The maps and the SH.
    WithSh,
    /// The maps alone.
    Maps,
}

/// [`check`] of a bake computing `work`.
pub fn check_with(config: &Config, probes: usize, work: Work) -> Result<()> {
    check_memory(config, probes)?;
    let b = &config.bake;
    limits::check_work(
        "bake.samples",
        &format!(
            "the bake of {probes} probes at {}² maps, {} paths per texel, {} bounces, {} lights",
            b.resolution.0,
            b.samples.0,
            b.bounces.0,
            config.lights.len()
        ),
        core_seconds(config, probes, work),
        1.0,
    )
}

/// [`check`]'s memory half, which `bake.samples` does not change.
pub fn check_memory(config: &Config, probes: usize) -> Result<()> {
    let b = &config.bake;
    let (n, m) = (b.resolution.0 as f64, b.irradiance_resolution.0 as f64);
    let maps = probes as f64 * (34.7 * n * n + 20.0 * m * m);
    let file =
        crate::lightfield::format::file_bytes(probes, b.resolution.0, b.irradiance_resolution.0)
            as f64;
    limits::check_memory(
        "bake.resolution",
        &format!("the bake of {probes} probes at {}² maps", b.resolution.0),
        1.5 * maps + file,
    )
}

/// The estimated core-seconds of a bake of `probes` probes with
/// `config.bake` ([`check`]'s work model), for sums over several bakes.
pub fn core_seconds(config: &Config, probes: usize, work: Work) -> f64 {
    let b = &config.bake;
    let (n, m) = (b.resolution.0 as f64, b.irradiance_resolution.0 as f64);
    let p = probes as f64;
    // The maps' paths, then the SH's directions and the six axes' paths.
    let sh = match work {
        Work::WithSh => 7.0 * b.sh_rays.0 as f64,
        Work::Maps => 0.0,
    };
    let paths = p * (n * n * b.samples.0 as f64 + sh);
    let vertices = paths * (1.0 + b.bounces.0 as f64) * light_factor(config);
    let convolution = p * m * m * n * n;
    vertices / limits::rate::PATH_VERTICES + convolution / limits::rate::CONVOLUTION_TERMS
}

/// Bakes the probes at `positions` with `config.bake`.
///
/// Contract: deterministic for a config and positions, whatever the thread
/// count; a scene without any light bakes black maps and says so in
/// [`Baked::warnings`].
pub fn bake(
    config: &Config,
    prepared: &Prepared,
    positions: &[Vec3],
    progress: &Progress,
) -> Baked {
    let (scene, bvh) = (&prepared.scene, &prepared.bvh);
    let renderer = prepared.renderer(config);
    let mut warnings = Vec::new();
    if renderer.lights().is_empty() {
        warnings.push(
            "bake: the scene has no emissive material and the config no lights; every radiance is black (add `lights` to the config)".into(),
        );
    }
    let seed = config.seed;
    let radiance = |o: Vec3, d: Vec3, stream: u64| {
        renderer.radiance(o, d, &mut Sampler::new(seed ^ BAKE_STREAMS, stream))
    };
    let baked = crate::lightfield::bake(
        &config.bake,
        positions,
        scene,
        bvh,
        prepared.domain.size().length(),
        seed,
        &radiance,
        progress,
    );
    let mut timings = progress.stopwatch();
    for (k, v) in &baked.timings_ms {
        timings.record(k, *v);
    }
    Baked {
        field: baked.field,
        area_lights: renderer.lights().area_light_count(),
        warnings,
        timings,
    }
}

/// Each probe's SH L2 from `bake.sh_rays` directions and its reference
/// irradiance along the six axes from as many cosine-weighted paths each:
/// with `bake.sh_direct: Exclude`, the delta lights' direct light
/// excluded from both, as a mixed-lighting engine shades it analytically
/// ([`crate::diffuse`]); with `Include`, in both (the SH's exactly
/// projected, [`crate::diffuse::ProbeSh::total`]).
///
/// Contract: deterministic for a config and positions, whatever the
/// thread count.
pub fn probe_light(config: &Config, prepared: &Prepared, positions: &[Vec3]) -> Vec<ProbeLight> {
    let renderer = &prepared.renderer(config);
    let rays = config.bake.sh_rays.0;
    let seed = config.seed ^ SH_STREAMS;
    let sh = crate::diffuse::bake_sh(renderer, positions, rays, seed);
    let receivers: Vec<crate::diffuse::Receiver> = positions
        .iter()
        .flat_map(|&p| crate::diffuse::AXES.map(|n| crate::diffuse::Receiver { p, n, group: 0 }))
        .collect();
    let reference = crate::diffuse::reference(renderer, &receivers, rays, seed ^ 0xA4E5);
    sh.into_iter()
        .zip(reference.chunks(crate::diffuse::AXES.len()))
        .map(|(sh, e)| {
            let include = config.bake.sh_direct == ShDirect::Include;
            ProbeLight {
                // `sh.json`'s `total` is `baked`: what a mixed-lighting
                // bake stores (the delta lights' direct light is the
                // renderer's), or with `Include` all the light.
                sh: crate::diffuse::ProbeSh {
                    baked: if include { sh.total() } else { sh.baked },
                    direct: crate::diffuse::ShL2::ZERO,
                    ..sh
                },
                irradiance_axes: std::array::from_fn(|k| {
                    if include {
                        e[k].total
                    } else {
                        e[k].baked
                    }
                }),
            }
        })
        .collect()
}

/// The CPU light-field tracer (Hi-Z march, SVO selection) against exact
/// ray casts: one random ray from each of [`TRACER_CHECK_RAYS`] random free
/// points of the domain.
pub fn check_tracer(
    config: &Config,
    prepared: &Prepared,
    field: &LightField,
    svo: &Svo,
    progress: &Progress,
) -> Agreement {
    let seed = config.seed;
    let input = prepared.placement_input(seed, progress);
    let origins = svo::random_free_points(&input, TRACER_CHECK_RAYS, seed ^ 0x7EACE);
    check::compare(
        field,
        &Selection::Svo(svo),
        &prepared.scene,
        &prepared.bvh,
        &origins,
        seed ^ 0xD1EC,
        March::HiZ,
    )
}
