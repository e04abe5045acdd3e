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
    /// The render's figures against the reference (the same as `compare`
    /// reports per camera).
    #[serde(flatten)]
    pub metrics: crate::stages::validate::Metrics,
}
