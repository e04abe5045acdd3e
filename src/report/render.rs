//! What `render` adds to `report.json`: the validation renders measured
//! against the reference (Wang et al. 2019 §5.1) and the tracer's work
//! per ray (Wang §4.2, Table 1).

use serde::Serialize;
use std::collections::BTreeMap;

/// `report.render`.
#[derive(Debug, Clone, Serialize)]
pub struct RenderReport {
    /// The wgpu adapter and backend, or `cpu twin` when no GPU was used.
    pub adapter: String,
    /// Image size, the reference's.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Glossy rays traced per variant (pixels with a glossy lobe).
    pub glossy_rays: usize,
    /// Per variant, by name (`bilevel`, `hiz`).
    pub variants: BTreeMap<String, VariantReport>,
    /// Wall time per step in milliseconds (`gbuffer`, `upload`, and per
    /// variant).
    pub timings_ms: BTreeMap<String, f64>,
}

/// `report.render.variants.<name>`.
#[derive(Debug, Clone, Serialize)]
pub struct VariantReport {
    /// The march: `bilevel` (McGuire 2017 §4.1) or `hiz` (Wang 2019 §4.2).
    pub march: &'static str,
    /// Probe selection: `grid` (McGuire) or `svo` (Wang §4.1).
    pub selection: &'static str,
    /// Mean squared error of the glossy indirect image against the
    /// reference's, per pixel and channel.
    pub mse_glossy: f64,
    /// Mean RGB of the glossy indirect image, to set beside
    /// `bake.reference.glossy_indirect_mean`.
    pub glossy_indirect_mean: [f64; 3],
    /// Mean squared error of the full image against the reference's.
    pub mse_full: f64,
    /// Pyramid texels the march visits per glossy ray, at every level.
    pub texel_fetches_per_ray: f64,
    /// Texels the surfel tests read per glossy ray (the same in both
    /// marches: they test the same texels).
    pub surfel_fetches_per_ray: f64,
    /// Probes consulted after the first, per glossy ray.
    pub probe_switches_per_ray: f64,
    /// Glossy rays no probe could resolve.
    pub unresolved_rays: u64,
    /// Glossy rays that hit a surface.
    pub hits: u64,
    /// Glossy rays that leave the scene.
    pub misses: u64,
    /// GPU time of the glossy trace and the irradiance gather in
    /// milliseconds, from timestamp queries; `null` on the CPU twin or
    /// without timestamp support.
    pub gpu_ms: Option<f64>,
}
