//! What `bake` adds to the outputs: the `bake` section of `report.json`
//! and the preview atlases of the probe maps.

use crate::lightfield::maps::decode_normal;
use crate::lightfield::LightField;
use crate::raster::RgbImage;
use crate::trace::check::Agreement;
use serde::Serialize;
use std::collections::BTreeMap;

/// `report.bake`.
#[derive(Debug, Clone, Serialize)]
pub struct BakeReport {
    /// Side of the radiance, normal and distance maps.
    pub resolution: u32,
    /// Side of the irradiance and moment maps.
    pub irradiance_resolution: u32,
    /// Probes baked.
    pub probes: usize,
    /// Radiance paths per texel.
    pub samples: u32,
    /// Indirect bounces in the probes' radiance.
    pub bounces: u32,
    /// Size of `lightfield.bin`.
    pub bytes: usize,
    /// Area lights (emissive triangles) and config lights used.
    pub area_lights: usize,
    /// Lights from the config.
    pub config_lights: usize,
    /// Lights from the scene file (glTF's punctual lights) that shone.
    pub scene_lights: usize,
    /// The CPU light-field tracer against exact ray casts, one random ray
    /// from each of 4096 random free points, probes chosen by the SVO.
    pub tracer: Agreement,
    /// Directions of each probe's SH L2 in `sh.json`, and paths of each
    /// axis's reference irradiance.
    pub sh_rays: u32,
    /// Mean relative error of the SH's irradiance along the six axes
    /// against the path-traced reference at the probe
    /// ([`sh_axis_error`]): what band 2 and the sampling lose.
    pub sh_axis_error: Option<f64>,
    /// The camera's view lit by the probes' blended diffuse light and by
    /// the equal-count grid's (`diffuse-*.png`); `null` without a camera.
    pub diffuse_views: Option<DiffuseViewsReport>,
    /// The reference image; `null` without a camera.
    pub reference: Option<ReferenceReport>,
    /// Wall time per step in milliseconds: `geometry`, `radiance`,
    /// `pyramid`, `irradiance`, `tracer_check`, `reference`.
    pub timings_ms: BTreeMap<String, f64>,
}

/// The diffuse views of `bake`: the camera's view, each pixel lit by its
/// emission, the point, spot and directional lights' direct light and
/// its albedo times a baked irradiance, from the path tracer
/// (`diffuse-reference.png`) or from a probe set's SH blended over
/// tetrahedra as engines blend it (ours, and the uniform grid of about
/// our count).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DiffuseViewsReport {
    /// Pixels across (the reference's, at most 192).
    pub width: u32,
    /// Pixels down.
    pub height: u32,
    /// Paths per pixel of the reference's baked irradiance.
    pub rays: u32,
    /// Ours first, then the grid.
    pub sets: Vec<DiffuseViewSet>,
}

/// One probe set of the diffuse views.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DiffuseViewSet {
    /// `ours`, or the grid's method (`grid:NxMxK`).
    pub name: String,
    /// Its probes.
    pub probes: usize,
    /// Mean relative error of the baked irradiance over the view's surface
    /// pixels.
    pub mean_error: f64,
}

/// The mean, over probes and the six axes, of `|E_sh − E_ref| / max(E_ref,
/// 5% of the mean E_ref)` in luminance: the SH's own error at the probe
/// (the floor of [`crate::diffuse::DARK_FLOOR`]); `None` without probes
/// or light.
pub fn sh_axis_error(light: &[crate::stages::bake::ProbeLight]) -> Option<f64> {
    use crate::diffuse::{dark_floor, relative_error, AXES};
    let pairs: Vec<(glam::Vec3, glam::Vec3)> = light
        .iter()
        .flat_map(|l| {
            AXES.iter()
                .zip(l.irradiance_axes)
                .map(|(&n, e)| (l.sh.baked.irradiance(n).max(glam::Vec3::ZERO), e))
        })
        .collect();
    let floor = dark_floor(pairs.iter().map(|p| p.1));
    if pairs.is_empty() || floor <= 1e-12 {
        return None;
    }
    Some(
        pairs
            .iter()
            .map(|&(g, w)| relative_error(g, w, floor))
            .sum::<f64>()
            / pairs.len() as f64,
    )
}

/// `report.bake.reference`.
#[derive(Debug, Clone, Serialize)]
pub struct ReferenceReport {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Paths per pixel.
    pub samples_per_pixel: u32,
    /// Indirect bounces.
    pub bounces: u32,
    /// Mean RGB radiance of the full image.
    pub mean: [f64; 3],
    /// Mean RGB radiance of the glossy-indirect image.
    pub glossy_indirect_mean: [f64; 3],
}

/// Columns of a probe atlas: the probes tiled in a near-square grid.
fn columns(probes: usize) -> usize {
    (probes as f64).sqrt().ceil().max(1.0) as usize
}

/// `probes` maps of side `n` tiled row by row into one RGB float image;
/// returns (width, height, pixels). `texel(i)` gives the colour of entry
/// `i` = probe·n² + y·n + x.
pub fn atlas(
    n: u32,
    probes: usize,
    texel: impl Fn(usize) -> [f32; 3],
) -> (u32, u32, Vec<[f32; 3]>) {
    let n = n as usize;
    let p = probes;
    let cols = columns(p);
    let rows = p.div_ceil(cols).max(1);
    let (w, h) = (cols * n, rows * n);
    let mut out = vec![[0.0f32; 3]; w * h];
    for probe in 0..p {
        let (ox, oy) = ((probe % cols) * n, (probe / cols) * n);
        for y in 0..n {
            for x in 0..n {
                out[(oy + y) * w + ox + x] = texel(probe * n * n + y * n + x);
            }
        }
    }
    (w as u32, h as u32, out)
}

/// Distance atlas preview: near is bright, far dark, nothing seen is blue.
pub fn distance_preview(field: &LightField) -> RgbImage {
    let far = field.max_distance.max(1e-6);
    let (w, h, px) = atlas(field.resolution, field.positions.len(), |i| {
        let d = field.distance[i];
        if d.is_finite() {
            [1.0 - (d / far).min(1.0); 3]
        } else {
            [-1.0, -1.0, -1.0]
        }
    });
    RgbImage::from_fn(w, h, |x, y| {
        let v = px[(y * w + x) as usize];
        if v[0] < 0.0 {
            [40, 60, 160]
        } else {
            let g = (255.0 * v[0].sqrt()) as u8;
            [g, g, g]
        }
    })
}

/// Normal atlas preview: components mapped from [-1, 1] to [0, 255].
pub fn normal_preview(field: &LightField) -> RgbImage {
    let (w, h, px) = atlas(field.resolution, field.positions.len(), |i| {
        if field.distance[i].is_finite() {
            decode_normal(field.normal[i]).to_array()
        } else {
            [-1.0; 3]
        }
    });
    RgbImage::from_fn(w, h, |x, y| {
        let v = px[(y * w + x) as usize];
        v.map(|c| (127.5 * (c + 1.0)).clamp(0.0, 255.0) as u8)
    })
}
