//! Outputs of a run: `probes.json` (what a renderer loads), `report.json`
//! (what a script checks), the bake's, render's and compare's reports and
//! `placement.png` (what a person looks at; the pages, `report.html`, are
//! [`crate::page`]'s). Formats are specified in docs/formats.md.
//!
//! Every coordinate written is a world coordinate in f64, converted from the
//! stages' scene-local f32 ones by [`Scene::to_world`] here, at the boundary.
//!
//! Jobs gather every file of a run in an [`crate::output::commit::OutputSet`] and commit
//! it as one unit after every stage has succeeded, so a failed run never
//! leaves a half-written, stale or mixed output behind.

pub mod bake;
pub mod compare;
pub mod diffuse;
pub mod family;
pub mod preview;
pub mod render;
pub mod sh;

use crate::config::UpAxis;
use crate::coverage::Coverage;
use crate::error::Result;
use crate::placement::ProbeSet;
use crate::provenance::Provenance;
use crate::raster::RgbImage;
use crate::refine::RefineReport;
use crate::scene::{world_to_file, Bounds, Scene};
use crate::sdf::{Sdf, VoxelClass};
use crate::svo::SvoReport;
use serde::Serialize;
use std::collections::BTreeMap;

/// Version of the `probes.json` and `report.json` schemas.
pub const FORMAT_VERSION: u32 = 1;

/// `probes.json`.
#[derive(Debug, Serialize)]
pub struct ProbesFile {
    /// Always `probeplace.probes`.
    pub format: &'static str,
    /// [`FORMAT_VERSION`].
    pub version: u32,
    /// What ties the file to the run's other outputs.
    pub provenance: Provenance,
    /// Placement method.
    pub method: String,
    /// Seed of the run.
    pub seed: u64,
    /// Scene file as given in the config.
    pub scene: String,
    /// How `position` relates to the scene file's coordinates (an OBJ's own, or
    /// a glTF's root frame: metres, Y up, before `scale` and `up`).
    pub space: Space,
    /// The probes.
    pub probes: Vec<ProbeRecord>,
}

/// World space relative to the file: `world = rotate_up(file × scale)`.
#[derive(Debug, Serialize)]
pub struct Space {
    /// Multiplier applied to file coordinates.
    pub scale: f64,
    /// Up axis of the file (world space is always Y-up).
    pub up: UpAxis,
}

/// One probe in `probes.json`.
#[derive(Debug, Serialize)]
pub struct ProbeRecord {
    /// Index, stable for a given config and seed.
    pub index: usize,
    /// World-space position (Y up, scaled).
    pub position: [f64; 3],
    /// The same point in the scene file's own coordinates ([`Space`]).
    pub position_file: [f64; 3],
    /// Distance to the nearest surface (SDF value at the probe's voxel; negative inside solids).
    pub clearance: f32,
    /// Class of the voxel holding the probe; `null` outside the grid.
    pub voxel_class: Option<VoxelClass>,
    /// Skeleton voxels the probe stands for (0 for grid probes).
    pub cluster_size: u32,
    /// One of the config's `fixed_probes` (they come first).
    pub fixed: bool,
}

impl ProbesFile {
    /// Builds the file's contents from a placement in `scene`.
    pub fn new(
        probes: &ProbeSet,
        scene: &Scene,
        sdf: &Sdf,
        scene_path: &str,
        config: &crate::config::Config,
        provenance: &Provenance,
    ) -> ProbesFile {
        let (seed, scale, up) = (config.seed, config.scale.0, config.up);
        let records = probes
            .probes
            .iter()
            .enumerate()
            .map(|(index, p)| {
                let voxel = sdf.voxel_at(p.position);
                // A fixed probe is written where the artist put it, not
                // through the f32 local frame it was placed in.
                let world = match config.fixed_probes.get(index) {
                    Some(given) if index < probes.fixed => glam::DVec3::from_array(given.0),
                    _ => scene.to_world(p.position),
                };
                ProbeRecord {
                    index,
                    position: world.to_array(),
                    position_file: world_to_file(world, scale, up).to_array(),
                    clearance: voxel.map_or(f32::NAN, |v| sdf.distance[v]),
                    voxel_class: voxel.map(|v| sdf.class[v]),
                    cluster_size: p.cluster_size,
                    fixed: index < probes.fixed,
                }
            })
            .collect();
        ProbesFile {
            format: "probeplace.probes",
            version: FORMAT_VERSION,
            provenance: provenance.clone(),
            method: probes.method.clone(),
            seed,
            scene: scene_path.to_string(),
            space: Space { scale, up },
            probes: records,
        }
    }
}

/// Axis-aligned box as written in reports, in world coordinates.
#[derive(Debug, Serialize)]
pub struct BoundsRecord {
    /// Lower corner.
    pub min: [f64; 3],
    /// Upper corner.
    pub max: [f64; 3],
}

impl BoundsRecord {
    /// `b`, in `scene`'s local coordinates, as world coordinates.
    pub fn world(b: &Bounds, scene: &Scene) -> BoundsRecord {
        BoundsRecord {
            min: scene.to_world(b.min).to_array(),
            max: scene.to_world(b.max).to_array(),
        }
    }
}

/// Scene facts in `report.json`.
#[derive(Debug, Serialize)]
pub struct SceneRecord {
    /// Scene file as given in the config.
    pub path: String,
    /// Its format: `obj` or `gltf` (a `.gltf` or `.glb`).
    pub format: &'static str,
    /// Lights the file defines that the run uses (glTF's punctual lights;
    /// 0 for an OBJ, or with `scene_lights: Ignore`).
    pub lights: usize,
    /// Usable triangles.
    pub triangles: usize,
    /// Faces dropped as degenerate or non-finite.
    pub dropped_triangles: usize,
    /// World-space bounds.
    pub bounds: BoundsRecord,
    /// Total surface area (one side).
    pub area: f64,
    /// What lights it: its emissive materials, and the point, spot,
    /// directional and sky lights of the config and the file.
    pub emitters: crate::stages::diffuse::Emitters,
    /// Every image file its materials name, read or not.
    pub textures: Vec<TextureRecord>,
}

/// One texture in `report.json`'s `scene.textures`.
#[derive(Debug, Serialize)]
pub struct TextureRecord {
    /// The file read (or, for a glTF, the image: the file and its index).
    pub file: String,
    /// What the materials use it for: `colour`, `emission`,
    /// `metal-roughness`, `alpha`.
    pub uses: Vec<&'static str>,
    /// Its width and height in texels; `null` when it was not read.
    pub size: Option<[u32; 2]>,
    /// Why it was not read; `null` when it was.
    pub missing: Option<String>,
}

impl TextureRecord {
    /// The records of `scene`'s texture files, in the order they are named.
    pub fn of(scene: &Scene) -> Vec<TextureRecord> {
        scene
            .texture_files
            .iter()
            .map(|f| TextureRecord {
                file: f.name.clone(),
                uses: f.uses.clone(),
                size: f.status.as_ref().ok().copied(),
                missing: f.status.as_ref().err().cloned(),
            })
            .collect()
    }
}

/// SDF facts in `report.json`.
#[derive(Debug, Serialize)]
pub struct SdfRecord {
    /// Voxel edge length.
    pub voxel_size: f32,
    /// Voxels along x, y, z.
    pub dims: [u32; 3],
    /// Free voxels.
    pub free: usize,
    /// Solid voxels.
    pub solid: usize,
    /// Voxels outside the scene.
    pub outside: usize,
}

impl From<&Sdf> for SdfRecord {
    fn from(sdf: &Sdf) -> Self {
        let (free, solid, outside) = sdf.class_counts();
        SdfRecord {
            voxel_size: sdf.voxel_size,
            dims: sdf.dims.to_array(),
            free,
            solid,
            outside,
        }
    }
}

/// `report.json`'s `reachable`.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct ReachRecord {
    /// Seeds that started the flood (cameras and given points in open
    /// space); 0 when none stood in open space, and all of it counts.
    pub seeds: usize,
    /// Voxels that are not solid.
    pub open_voxels: usize,
    /// Of those, the ones reached.
    pub reached_voxels: usize,
    /// Share of the open voxels left out (sealed voids, regions cut off by
    /// geometry, space outside): no probe and no coverage reference point
    /// stands there.
    pub excluded_fraction: f64,
    /// The viewer's radius the flood moved (world units): passages
    /// narrower than about twice it join nothing; 0 when a point's.
    pub viewer_radius: f32,
}

impl From<&crate::reachable::Reachable> for ReachRecord {
    fn from(r: &crate::reachable::Reachable) -> Self {
        ReachRecord {
            seeds: r.seeds_used,
            open_voxels: r.open_voxels,
            reached_voxels: r.reached_voxels,
            excluded_fraction: r.excluded_fraction(),
            viewer_radius: r.radius,
        }
    }
}

/// `report.json`.
#[derive(Debug, Serialize)]
pub struct Report {
    /// Always `probeplace.report`.
    pub format: &'static str,
    /// [`FORMAT_VERSION`].
    pub version: u32,
    /// What ties the report to the run's other outputs.
    pub provenance: Provenance,
    /// Placement method.
    pub method: String,
    /// Seed of the run.
    pub seed: u64,
    /// Config file of the run.
    pub config: String,
    /// Number of probes placed.
    pub probe_count: usize,
    /// Covered share of the coverable surface (see the coverage module),
    /// measured on the validation stream: samples and reference points
    /// the placer never saw.
    pub coverage: f64,
    /// Half-width of the 95% interval of `coverage`.
    pub coverage_ci95: f64,
    /// Coverage on the samples the placer fitted (a training score);
    /// `null` when nothing was fitted.
    pub coverage_train: Option<f64>,
    /// Probes in solid by their own rays (`coverage::stands_free`), the
    /// same verdict under any seed.
    pub probes_in_solid: usize,
    /// Probes in voxels the run's SDF classifies solid.
    pub probes_in_solid_sdf: usize,
    /// Probes that serve nothing a viewer sees: outside the reached free
    /// space, and no ray of theirs crosses it (`null` when all free space
    /// counts: `reachable: Everywhere`, or no camera or point to reach
    /// from).
    pub idle_probes: Option<usize>,
    /// Probes in voxels outside the scene.
    pub probes_outside_scene: usize,
    /// Probes outside the domain box.
    pub probes_outside_domain: usize,
    /// Probes refinement's filling had to place nearer to a surface than
    /// the placement's clearance (`refine.probes_below_clearance`; 0
    /// without refinement).
    pub probes_below_clearance: usize,
    /// Mean incidence angle (degrees, 0 head-on) of each covered sample's
    /// best view by the final probes (`refine.best_view_incidence_deg_final`;
    /// `null` without refinement).
    pub best_view_incidence_deg: Option<f64>,
    /// The scene.
    pub scene: SceneRecord,
    /// The probe domain.
    pub domain: BoundsRecord,
    /// The SDF.
    pub sdf: SdfRecord,
    /// How the SDF's voxel size was chosen.
    pub resolution: Option<crate::resolution::Resolution>,
    /// The free space a viewer reaches (`config.reachable`), which the
    /// placement and the coverage measure keep to; `null` for
    /// `Everywhere`.
    pub reachable: Option<ReachRecord>,
    /// Sample counts behind `coverage`.
    pub coverage_detail: Coverage,
    /// World positions of up to [`HOLE_SAMPLE`] coverage holes (coverable
    /// samples no probe sees), every k-th in sample order ([`hole_sample`]):
    /// what `report.html` draws, kept here so that a later job reusing the
    /// placement (`--from`) draws them too.
    pub coverage_holes: Vec<[f64; 3]>,
    /// What the placement method's steps kept and dropped (see docs/formats.md).
    pub placement_stats: BTreeMap<&'static str, u64>,
    /// The placement method's parameters as used, defaults resolved.
    pub placement_params: BTreeMap<&'static str, f64>,
    /// What refinement did; `null` when it was off.
    pub refine: Option<RefineReport>,
    /// What the diffuse step added (`refine.objective: Both`; its errors
    /// are training scores); `null` when it did not run.
    pub diffuse: Option<crate::refine::diffuse::DiffuseReport>,
    /// What the artist controls (`fixed_probes`, `exclude`, `max_probes`,
    /// `probe_density`) did.
    pub controls: crate::placement::controls::ControlsReport,
    /// The octree of probe indices written as `svo.bin`.
    pub svo: Option<SvoReport>,
    /// The light-field bake; `null` after `place`.
    pub bake: Option<bake::BakeReport>,
    /// The validation renders; `null` unless `render` ran.
    pub render: Option<render::RenderReport>,
    /// Wall time per stage, in milliseconds, plus `total`.
    pub timings_ms: BTreeMap<String, f64>,
    /// Warnings raised during the run.
    pub warnings: Vec<String>,
}

/// Most coverage holes `report.json` and `report.html` keep.
pub const HOLE_SAMPLE: usize = 512;

/// At most [`HOLE_SAMPLE`] of `holes`: all of them when they are few, else
/// every k-th from the first, k = ⌈n / HOLE_SAMPLE⌉ (deterministic, and
/// spread over the surface as the samples are: they are drawn area-uniformly
/// in stratified order, [`crate::coverage`]).
pub fn hole_sample<T: Copy>(holes: &[T]) -> Vec<T> {
    let step = holes.len().div_ceil(HOLE_SAMPLE).max(1);
    holes.iter().step_by(step).copied().collect()
}

/// Pixel size of each of the two views in `placement.png`.
pub const PREVIEW_VIEW_SIZE: u32 = 512;

/// The top and side views of `probes` in `scene` over `domain`, surface
/// samples in `holes` marked, each view `view_size` pixels wide
/// ([`preview::render_preview`]).
pub fn placement_views(
    scene: &Scene,
    domain: &Bounds,
    probes: &[glam::Vec3],
    holes: &[glam::Vec3],
    view_size: u32,
) -> RgbImage {
    let colors: Vec<[f32; 3]> = scene
        .material_ids
        .iter()
        .map(|&m| scene.materials[m as usize].diffuse)
        .collect();
    preview::render_preview(
        &preview::PreviewInput {
            triangles: &scene.triangles,
            colors: &colors,
            probes,
            holes,
            bounds_min: domain.min,
            bounds_max: domain.max,
        },
        view_size,
    )
}

/// Adds `<stem>.exr` (linear) and `<stem>.png` (at `exposure`) of the
/// `width`×`height` image `pixels` to `set`.
pub fn add_image(
    set: &mut crate::output::commit::OutputSet,
    stem: &str,
    (width, height): (u32, u32),
    pixels: &[[f32; 3]],
    exposure: f32,
) -> Result<()> {
    let png = format!("{stem}.png");
    let image = crate::raster::tonemap(pixels, width, height, exposure);
    set.add(
        format!("{stem}.exr"),
        crate::encode::exr::encode_rgb(width, height, pixels),
    );
    set.add(png.clone(), crate::encode::png::encode_png(&image, &png)?);
    Ok(())
}
