//! Light-field probes (McGuire et al. 2017): spherical maps stored in
//! octahedral squares. Refinement already evaluates probes through the
//! mapping (Wang et al. 2019 §3.2 derives visibility from "each probe's
//! octahedral directional map"); the bake fills the maps themselves.

pub mod format;
pub mod irradiance;
pub mod maps;
pub mod octahedral;
pub mod pyramid;

use crate::config::BakeParams;
use crate::error::{Error, Result};
use crate::progress::Progress;
use crate::scene::raycast::SceneBvh;
use crate::scene::Scene;
use glam::{DVec3, Vec3};
use maps::RadianceFn;
use std::collections::BTreeMap;
use std::path::Path;
use std::time::Instant;

/// Every probe's baked maps (McGuire §3, §5.2), each value already rounded
/// to the half precision of `lightfield.bin`. Maps are stored probe after
/// probe, texels row by row; texel (x, y) of an n×n map looks along
/// [`octahedral::texel_direction`]`(x, y, n)`.
#[derive(Debug, Clone, PartialEq)]
pub struct LightField {
    /// Side n of the radiance, normal and distance maps.
    pub resolution: u32,
    /// Side m of the irradiance and moment maps.
    pub irradiance_resolution: u32,
    /// Distance standing in for "nothing seen" in the moments (the domain's diagonal).
    pub max_distance: f32,
    /// Probe centres, in the order of `probes.json`, relative to `frame`.
    pub positions: Vec<Vec3>,
    /// World position of the zero of `positions`' coordinates: the scene's
    /// [`crate::scene::Scene::origin`] for a bake (the tracer works in the
    /// scene's local coordinates), zero for a field read from
    /// `lightfield.bin`, which holds world coordinates.
    pub frame: DVec3,
    /// Radiance arriving at the probe, RGB.
    pub radiance: Vec<[f32; 3]>,
    /// Octahedral encoding of the seen surface's normal, facing the probe.
    pub normal: Vec<[f32; 2]>,
    /// Radial distance to the seen surface; +∞ where the ray escapes.
    pub distance: Vec<f32>,
    /// Min/max distance pyramid, level k of side n >> k ([`pyramid`]).
    pub pyramid: Vec<Vec<[f32; 2]>>,
    /// Irradiance E(n), RGB ([`irradiance`]).
    pub irradiance: Vec<[f32; 3]>,
    /// Filtered distance moments (E\[r\], E\[r²\]).
    pub moments: Vec<[f32; 2]>,
    /// The run's provenance ([`crate::provenance`]), in the header's
    /// reserved bytes; zero until the job that writes the field sets it.
    pub provenance: crate::provenance::ProvenanceBytes,
}

impl LightField {
    /// Texels per probe map.
    pub fn texels(&self) -> usize {
        (self.resolution * self.resolution) as usize
    }

    /// Index of texel (`x`, `y`) of `probe`'s n×n maps.
    pub fn index(&self, probe: usize, x: u32, y: u32) -> usize {
        probe * self.texels() + (y * self.resolution + x) as usize
    }

    /// Size of the serialized file in bytes.
    pub fn bytes(&self) -> usize {
        format::file_bytes(
            self.positions.len(),
            self.resolution,
            self.irradiance_resolution,
        )
    }

    /// Reads and checks a `lightfield.bin` file; problems are user errors
    /// naming the file.
    pub fn read(path: &Path) -> Result<LightField> {
        let bytes = crate::input::read(path, "lightfield.bin", crate::limits::memory_budget())?;
        format::from_bytes(&bytes).map_err(|m| Error::user_file(path, m))
    }

    /// The serialized bytes (see [`mod@format`]).
    pub fn to_bytes(&self) -> Vec<u8> {
        format::to_bytes(self)
    }
}

/// The bake's product and what each step cost.
pub struct BakedField {
    /// The maps.
    pub field: LightField,
    /// Wall time per step in milliseconds: `geometry`, `radiance`,
    /// `pyramid`, `irradiance`.
    pub timings_ms: BTreeMap<&'static str, f64>,
}

/// Bakes every probe's maps: geometry by ray casting, radiance from
/// `radiance`, then the pyramid and the irradiance convolution.
///
/// Contract: deterministic for the same inputs; `max_distance` > 0 is the
/// moments' stand-in for escaping rays.
#[allow(clippy::too_many_arguments)]
pub fn bake(
    params: &BakeParams,
    positions: &[Vec3],
    scene: &Scene,
    bvh: &SceneBvh,
    max_distance: f32,
    seed: u64,
    radiance: &RadianceFn,
    progress: &Progress,
) -> BakedField {
    let n = params.resolution.0;
    let mut timings_ms = BTreeMap::new();
    let mut lap = Instant::now();
    let mut mark = |name: &'static str, t: &mut BTreeMap<&'static str, f64>| {
        t.insert(name, lap.elapsed().as_secs_f64() * 1e3);
        lap = Instant::now();
    };
    let geometry = maps::bake_geometry(positions, scene, bvh, n);
    mark("geometry", &mut timings_ms);
    let bar = progress.bar("probe radiance", (positions.len() as u64) * n as u64);
    let rad = maps::bake_radiance(positions, n, params.samples.0, seed, radiance, &|| {
        bar.inc(1)
    });
    bar.finish_and_clear();
    mark("radiance", &mut timings_ms);
    let pyramid = pyramid::build(n, &geometry.distance, &geometry.normal);
    mark("pyramid", &mut timings_ms);
    let irr = irradiance::convolve(
        n,
        params.irradiance_resolution.0,
        &rad,
        &geometry.distance,
        params.moment_exponent.0,
        max_distance,
    );
    mark("irradiance", &mut timings_ms);
    BakedField {
        field: LightField {
            resolution: n,
            irradiance_resolution: params.irradiance_resolution.0,
            max_distance,
            positions: positions.to_vec(),
            frame: scene.origin,
            radiance: rad,
            normal: geometry.normal,
            distance: geometry.distance,
            pyramid,
            irradiance: irr.irradiance,
            moments: irr.moments,
            provenance: [0; 32],
        },
        timings_ms,
    }
}
