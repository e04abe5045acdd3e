//! The figures `report.html` of `place`, `bake` and `render` shows, read
//! from the run's `report.json` into types ([`RunFigures`]): what the page
//! ([`super::run_html`]) takes, so that it names fields, not string keys.
//!
//! The page is written from the report as written, not from the stages'
//! products, because a job that reuses a placement (`--from`) has its
//! placement's figures only there. So the jobs hand the page this reading
//! of the report: the report's schema (docs/formats.md, "`report.json`")
//! as the page needs it, every field optional as the sections are (no
//! refinement, no bake), and numbers as written ([`Num`]: a whole number
//! stays whole on the page).

use serde::de::{Deserializer, IgnoredAny, MapAccess, Visitor};
use serde::Deserialize;
use std::collections::BTreeMap;
use std::fmt;

/// A number of the report as written: whole (shown as it is) or real
/// (shown with four significant digits, [`super::run_html`]).
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(untagged)]
pub enum Num {
    /// A whole number, zero or more.
    Whole(u64),
    /// A whole number below zero.
    Negative(i64),
    /// Any other number.
    Real(f64),
}

impl Num {
    /// The number as a whole one, `None` unless it is one and not negative.
    pub fn as_u64(self) -> Option<u64> {
        match self {
            Num::Whole(n) => Some(n),
            _ => None,
        }
    }

    /// The number as a real one.
    pub fn as_f64(self) -> f64 {
        match self {
            Num::Whole(n) => n as f64,
            Num::Negative(n) => n as f64,
            Num::Real(x) => x,
        }
    }
}

/// A JSON object's entries in the order written (the report's maps are
/// written in a meaningful order: stages as they ran, variants as
/// configured).
#[derive(Debug, Clone, PartialEq)]
pub struct Ordered<T>(pub Vec<(String, T)>);

impl<T> Default for Ordered<T> {
    fn default() -> Self {
        Ordered(Vec::new())
    }
}

impl<'de, T: Deserialize<'de>> Deserialize<'de> for Ordered<T> {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct Entries<T>(std::marker::PhantomData<T>);
        impl<'de, T: Deserialize<'de>> Visitor<'de> for Entries<T> {
            type Value = Ordered<T>;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("an object")
            }
            fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<Ordered<T>, A::Error> {
                let mut entries = Vec::new();
                while let Some(entry) = map.next_entry()? {
                    entries.push(entry);
                }
                Ok(Ordered(entries))
            }
        }
        d.deserialize_map(Entries(std::marker::PhantomData))
    }
}

/// `report.json` of `place`, `bake` or `render`, as the page reads it.
#[derive(Debug, Default, Deserialize)]
#[serde(default)]
pub struct RunFigures {
    /// The placement method (`+refine` when refinement ran).
    pub method: Option<String>,
    /// The config file.
    pub config: Option<String>,
    /// The seed.
    pub seed: Option<Num>,
    /// What ties the outputs together.
    pub provenance: ProvenanceFigures,
    /// The scene.
    pub scene: SceneFigures,
    /// Probes placed.
    pub probe_count: Option<Num>,
    /// Coverage on the validation stream, and its 95% half-width.
    pub coverage: Option<f64>,
    /// See `coverage`.
    pub coverage_ci95: Option<f64>,
    /// The sample counts behind `coverage`.
    pub coverage_detail: CoverageFigures,
    /// World positions of the sampled coverage holes.
    pub coverage_holes: Vec<[f64; 3]>,
    /// Probes in solid, by their own rays.
    pub probes_in_solid: Option<Num>,
    /// Probes filling placed below the placement's clearance.
    pub probes_below_clearance: Option<Num>,
    /// Probes in voxels outside the scene.
    pub probes_outside_scene: Option<Num>,
    /// Probes outside the domain box.
    pub probes_outside_domain: Option<Num>,
    /// Mean incidence of each covered sample's best view, degrees.
    pub best_view_incidence_deg: Option<f64>,
    /// The SDF.
    pub sdf: SdfFigures,
    /// How the voxel size was chosen.
    pub resolution: Option<ResolutionFigures>,
    /// The probe domain.
    pub domain: BoxFigures,
    /// Counts of the placement method's steps, by name.
    pub placement_stats: Option<Ordered<Num>>,
    /// The placement method's parameters as used, by name.
    pub placement_params: Option<Ordered<Num>>,
    /// Refinement; `None` when it was off.
    pub refine: Option<RefineFigures>,
    /// The diffuse step; `None` when it did not run.
    pub diffuse: Option<DiffuseFigures>,
    /// The artist controls.
    pub controls: ControlsFigures,
    /// The octree.
    pub svo: Option<SvoFigures>,
    /// The bake; `None` after `place`.
    pub bake: Option<BakeFigures>,
    /// The validation renders; `None` unless `render` ran.
    pub render: Option<RenderFigures>,
    /// Warnings of the run.
    pub warnings: Vec<String>,
    /// Wall time per stage, ms.
    pub timings_ms: Option<Ordered<Num>>,
    /// Files reused from an earlier run (`--from`).
    pub reused: Vec<String>,
}

impl RunFigures {
    /// Reads `report` (a `report.json` as written); the error names the
    /// field that does not read and why.
    pub fn read(report: &serde_json::Value) -> Result<RunFigures, String> {
        serde_path_to_error::deserialize(report).map_err(|e| format!("{}: {}", e.path(), e.inner()))
    }

    /// The job whose report this is: `render`, `bake` or `place`.
    pub fn job(&self) -> &'static str {
        if self.render.is_some() {
            "render"
        } else if self.bake.is_some() {
            "bake"
        } else {
            "place"
        }
    }

    /// Coverable samples no probe sees.
    pub fn holes(&self) -> u64 {
        let d = &self.coverage_detail;
        let count = |n: Option<Num>| n.and_then(Num::as_u64).unwrap_or(0);
        count(d.coverable_samples).saturating_sub(count(d.covered_samples))
    }
}

/// `provenance`.
#[derive(Debug, Default, Deserialize)]
#[serde(default)]
pub struct ProvenanceFigures {
    /// The tool and its version.
    pub tool: Option<String>,
    /// Hash of the config.
    pub config_hash: Option<String>,
    /// Hash of the scene.
    pub scene_hash: Option<String>,
}

/// `scene`.
#[derive(Debug, Default, Deserialize)]
#[serde(default)]
pub struct SceneFigures {
    /// The scene file as the config gives it.
    pub path: Option<String>,
    /// Usable triangles.
    pub triangles: Option<Num>,
    /// Faces dropped.
    pub dropped_triangles: Option<Num>,
    /// One-sided area.
    pub area: Option<Num>,
}

/// `coverage_detail`.
#[derive(Debug, Default, Deserialize)]
#[serde(default)]
pub struct CoverageFigures {
    /// Surface samples drawn.
    pub samples: Option<Num>,
    /// Of those, the coverable ones.
    pub coverable_samples: Option<Num>,
    /// Of those, the covered ones.
    pub covered_samples: Option<Num>,
    /// Coverable share of the surface.
    pub coverable_fraction: Option<f64>,
}

/// `sdf`.
#[derive(Debug, Default, Deserialize)]
#[serde(default)]
pub struct SdfFigures {
    /// Voxel edge.
    pub voxel_size: Option<Num>,
    /// Voxels along x, y, z.
    pub dims: Option<Vec<Num>>,
}

/// `resolution`.
#[derive(Debug, Default, Deserialize)]
#[serde(default)]
pub struct ResolutionFigures {
    /// Whether the config gave the voxel size or it was chosen.
    pub source: Option<String>,
}

/// A box of the report (world coordinates).
#[derive(Debug, Default, Deserialize)]
#[serde(default)]
pub struct BoxFigures {
    /// Lower corner.
    pub min: Option<Vec<Num>>,
    /// Upper corner.
    pub max: Option<Vec<Num>>,
}

/// `refine`.
#[derive(Debug, Default, Deserialize)]
#[serde(default)]
pub struct RefineFigures {
    /// Sweeps over all probes.
    pub iterations: Option<Num>,
    /// Moves proposed.
    pub proposals: Option<Num>,
    /// Of those, accepted.
    pub accepted: Option<Num>,
    /// Of those, refused as illegal.
    pub rejected_illegal: Option<Num>,
    /// Coverage before refinement.
    pub coverage_initial: Option<f64>,
    /// Coverage after it.
    pub coverage_final: Option<f64>,
    /// Atlas coverage before.
    pub atlas_coverage_initial: Option<f64>,
    /// Atlas coverage after.
    pub atlas_coverage_final: Option<f64>,
    /// Probes before.
    pub probes_initial: Option<Num>,
    /// Probes after.
    pub probes_final: Option<Num>,
    /// Probes pruning removed.
    pub removed: Option<Num>,
    /// Probes filling added.
    pub added: Option<Num>,
    /// Fitness before (eq. 1).
    pub r_initial: Option<Num>,
    /// Fitness after.
    pub r_final: Option<Num>,
    /// The rounds of filling (the page counts them).
    pub fill_rounds: Option<Vec<IgnoredAny>>,
}

/// `diffuse`.
#[derive(Debug, Default, Deserialize)]
#[serde(default)]
pub struct DiffuseFigures {
    /// Probes in (coverage's).
    pub probes_before: Option<Num>,
    /// Probes out.
    pub probes_after: Option<Num>,
    /// Probes inserted.
    pub inserted: Option<Num>,
    /// Probes moved.
    pub relocated: Option<Num>,
    /// Probes removed.
    pub removed: Option<Num>,
    /// Training receivers on surfaces.
    pub surface_points: Option<Num>,
    /// Training receivers in free space.
    pub free_points: Option<Num>,
    /// Held-out receivers.
    pub validation_points: Option<Num>,
    /// Training error before.
    pub error_before: Option<f64>,
    /// Training error after.
    pub error_after: Option<f64>,
    /// Held-out surface error before.
    pub validation_before: Option<f64>,
    /// Held-out surface error after.
    pub validation_after: Option<f64>,
    /// Held-out leak share before.
    pub leaks_before: Option<f64>,
    /// Held-out leak share after.
    pub leaks_after: Option<f64>,
    /// Why insertion stopped.
    pub stopped: Option<String>,
}

/// `controls`.
#[derive(Debug, Default, Deserialize)]
#[serde(default)]
pub struct ControlsFigures {
    /// Fixed probes.
    pub fixed_probes: Option<Num>,
    /// Probes dropped by `exclude` boxes.
    pub excluded: Option<Num>,
    /// `max_probes`, when set.
    pub max_probes: Option<Num>,
    /// Probes before the budget cut them.
    pub probes_before_budget: Option<Num>,
    /// `min_probes`, when set.
    pub min_probes: Option<Num>,
    /// Probes before the top-up.
    pub probes_before_minimum: Option<Num>,
    /// `probe_density` boxes.
    pub density_regions: Option<Num>,
    /// Samples whose demand they change.
    pub samples_with_density: Option<Num>,
    /// Samples seen as often as asked.
    pub demand_met: Option<f64>,
}

impl ControlsFigures {
    /// Whether the config set any control (else the page leaves the table out).
    pub fn any(&self) -> bool {
        let some = |n: Option<Num>| n.and_then(Num::as_u64).unwrap_or(0) > 0;
        some(self.fixed_probes)
            || some(self.excluded)
            || self.max_probes.is_some()
            || self.min_probes.is_some()
            || some(self.density_regions)
    }
}

/// `svo`.
#[derive(Debug, Default, Deserialize)]
#[serde(default)]
pub struct SvoFigures {
    /// Inner nodes.
    pub nodes: Option<Num>,
    /// Leaves.
    pub leaves: Option<Num>,
    /// Depth.
    pub depth: Option<Num>,
    /// Size of `svo.bin`.
    pub bytes: Option<u64>,
    /// Size of the paper's dense texture.
    pub dense_bytes: Option<u64>,
    /// Leaf edge.
    pub leaf_size: Option<Num>,
    /// Leaves along x, y, z.
    pub dims: Option<Vec<Num>>,
    /// Leaf cells of free space.
    pub free_cells: Option<Num>,
    /// Of those, filled by the fallback.
    pub fallback_cells: Option<Num>,
    /// Free cells no probe sees.
    pub leaves_without_visible_probe: Option<Num>,
    /// Different probe lists.
    pub distinct_lists: Option<Num>,
    /// Free points whose first listed probe sees them.
    pub first_probe_visible: Option<f64>,
}

/// `bake`.
#[derive(Debug, Default, Deserialize)]
#[serde(default)]
pub struct BakeFigures {
    /// Side of each map.
    pub resolution: Option<Num>,
    /// Side of each irradiance map.
    pub irradiance_resolution: Option<Num>,
    /// Probes baked.
    pub probes: Option<Num>,
    /// Paths per texel.
    pub samples: Option<Num>,
    /// Indirect bounces.
    pub bounces: Option<Num>,
    /// Size of `lightfield.bin`.
    pub bytes: Option<u64>,
    /// Emissive triangles.
    pub area_lights: Option<Num>,
    /// Config lights.
    pub config_lights: Option<Num>,
    /// The scene file's lights (absent from older runs).
    pub scene_lights: Option<Num>,
    /// The CPU tracer against exact casts.
    pub tracer: TracerFigures,
    /// The reference render, when the config has a camera.
    pub reference: Option<ReferenceFigures>,
    /// The diffuse views, when the config has a camera.
    pub diffuse_views: Option<DiffuseViewsFigures>,
    /// Wall time per step, ms.
    pub timings_ms: Option<Ordered<Num>>,
}

/// `bake.diffuse_views`.
#[derive(Debug, Default, Deserialize)]
#[serde(default)]
pub struct DiffuseViewsFigures {
    /// Pixels across.
    pub width: Option<Num>,
    /// Pixels down.
    pub height: Option<Num>,
    /// Paths per pixel of the reference.
    pub rays: Option<Num>,
    /// Ours, then the grid.
    pub sets: Vec<DiffuseViewSetFigures>,
}

/// One set of `bake.diffuse_views.sets`.
#[derive(Debug, Default, Deserialize)]
#[serde(default)]
pub struct DiffuseViewSetFigures {
    /// Its name.
    pub name: Option<String>,
    /// Its probes.
    pub probes: Option<Num>,
    /// Mean relative error over the view.
    pub mean_error: Option<f64>,
}

/// `bake.tracer`.
#[derive(Debug, Default, Deserialize)]
#[serde(default)]
pub struct TracerFigures {
    /// Rays cast.
    pub rays: Option<Num>,
    /// Of those, the ones whose hit the tracer saw.
    pub seen: Option<Num>,
    /// Of those, within two texels of the exact hit.
    pub agree: Option<Num>,
    /// Rays the tracer could not resolve.
    pub unknown: Option<Num>,
    /// Rays that leave the scene.
    pub escaping: Option<Num>,
    /// Of those, called a miss.
    pub escaping_missed: Option<Num>,
}

/// `bake.reference`.
#[derive(Debug, Default, Deserialize)]
#[serde(default)]
pub struct ReferenceFigures {
    /// Width, pixels.
    pub width: Option<Num>,
    /// Height, pixels.
    pub height: Option<Num>,
    /// Paths per pixel.
    pub samples_per_pixel: Option<Num>,
    /// Bounces.
    pub bounces: Option<Num>,
    /// Mean colour.
    pub mean: Option<Vec<Num>>,
    /// Mean glossy indirect colour.
    pub glossy_indirect_mean: Option<Vec<Num>>,
}

/// `render`.
#[derive(Debug, Default, Deserialize)]
#[serde(default)]
pub struct RenderFigures {
    /// Width, pixels.
    pub width: Option<Num>,
    /// Height, pixels.
    pub height: Option<Num>,
    /// Glossy rays per pixel.
    pub glossy_rays: Option<Num>,
    /// The adapter that rendered.
    pub adapter: Option<String>,
    /// Each variant's figures, as configured.
    pub variants: Option<Ordered<VariantFigures>>,
    /// Wall time per step, ms.
    pub timings_ms: Option<Ordered<Num>>,
}

/// One variant of `render.variants`.
#[derive(Debug, Default, Deserialize)]
#[serde(default)]
pub struct VariantFigures {
    /// The march.
    pub march: Option<String>,
    /// The probe selection.
    pub selection: Option<String>,
    /// Surfel fetches per ray.
    pub surfel_fetches_per_ray: Option<Num>,
    /// Pyramid fetches per ray in 32-ray lock step.
    pub warp_fetches_per_ray: Option<Num>,
    /// Probe switches per ray.
    pub probe_switches_per_ray: Option<Num>,
    /// Rays left unresolved.
    pub unresolved_rays: Option<Num>,
    /// Rays that hit.
    pub hits: Option<Num>,
    /// Rays that missed.
    pub misses: Option<Num>,
    /// GPU time, ms (only on a GPU).
    pub gpu_ms: Option<Num>,
    /// The glossy trace's part of it.
    pub gpu_trace_ms: Option<Num>,
    /// The irradiance gather's part of it.
    pub gpu_gather_ms: Option<Num>,
    /// Every other field: the compare metrics' figures by key
    /// ([`crate::stages::validate::METRICS`]).
    #[serde(flatten)]
    pub metrics: BTreeMap<String, Figure>,
}

impl VariantFigures {
    /// The figure of the metric `key`, when the variant has one.
    pub fn metric(&self, key: &str) -> Option<f64> {
        match self.metrics.get(key) {
            Some(Figure::Number(x)) => Some(*x),
            _ => None,
        }
    }
}

/// A field of a variant beyond those named: a metric's figure, or
/// something the page does not show.
#[derive(Debug, Deserialize)]
#[serde(untagged)]
pub enum Figure {
    /// A number.
    Number(f64),
    /// Anything else.
    Other(IgnoredAny),
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_keep_whether_they_are_whole() {
        let v = serde_json::json!({"probe_count": 7, "seed": -3, "scene": {"area": 2.0}});
        let f = RunFigures::read(&v).unwrap();
        assert_eq!(f.probe_count, Some(Num::Whole(7)));
        assert_eq!(f.seed, Some(Num::Negative(-3)));
        assert_eq!(f.scene.area, Some(Num::Real(2.0)));
        assert_eq!(f.job(), "place");
    }

    #[test]
    fn maps_keep_their_order_and_absent_sections_read_as_none() {
        let v = serde_json::json!({
            "timings_ms": {"sdf": 1.5, "bvh": 2, "total": 4},
            "bake": {"probes": 3},
            "render": null,
        });
        let f = RunFigures::read(&v).unwrap();
        let keys: Vec<&str> = f
            .timings_ms
            .as_ref()
            .unwrap()
            .0
            .iter()
            .map(|(k, _)| k.as_str())
            .collect();
        assert_eq!(keys, ["sdf", "bvh", "total"]);
        assert_eq!(f.job(), "bake");
        assert!(f.refine.is_none() && f.svo.is_none());
    }

    #[test]
    fn a_variant_keeps_its_metrics_by_key() {
        let v = serde_json::json!({"render": {"variants": {"hiz": {
            "march": "HiZ", "hits": 10, "rmse": 0.25, "flip": 0.125, "note": [1]
        }}}});
        let f = RunFigures::read(&v).unwrap();
        let variants = &f.render.as_ref().unwrap().variants.as_ref().unwrap().0;
        let (name, hiz) = &variants[0];
        assert_eq!(name, "hiz");
        assert_eq!(hiz.hits, Some(Num::Whole(10)));
        assert_eq!(hiz.metric("rmse"), Some(0.25));
        assert_eq!(hiz.metric("note"), None);
        assert_eq!(hiz.metric("absent"), None);
    }

    #[test]
    fn a_field_of_the_wrong_type_is_named() {
        let v = serde_json::json!({"svo": {"bytes": "many"}});
        let e = RunFigures::read(&v).unwrap_err();
        assert!(e.contains("svo.bytes"), "{e}");
    }
}
