//! Outputs of a run: `probes.json` (what a renderer loads), `report.json`
//! (what a person or a script checks), `placement.png` (what an artist looks
//! at). Formats are specified in docs/formats.md.
//!
//! Every coordinate written is a world coordinate in f64, converted from the
//! stages' scene-local f32 ones by [`Scene::to_world`] here, at the boundary.
//!
//! Every file is written atomically (a temporary file in the same directory,
//! then a rename), and only after every stage has succeeded, so a failed run
//! never leaves a half-written or stale-looking output behind.

pub mod bake;
pub mod compare;
pub mod exr;
pub mod html;
pub mod preview;
pub mod render;

use crate::config::UpAxis;
use crate::coverage::{Coverage, ProbeHealth};
use crate::error::{Error, Result};
use crate::placement::ProbeSet;
use crate::refine::RefineReport;
use crate::scene::{world_to_file, Bounds, Scene};
use crate::sdf::{Sdf, VoxelClass};
use crate::svo::SvoReport;
use serde::Serialize;
use std::collections::BTreeMap;
use std::path::Path;

/// Version of the `probes.json` and `report.json` schemas.
pub const FORMAT_VERSION: u32 = 1;

/// `probes.json`.
#[derive(Debug, Serialize)]
pub struct ProbesFile {
    /// Always `probeplace.probes`.
    pub format: &'static str,
    /// [`FORMAT_VERSION`].
    pub version: u32,
    /// Placement method.
    pub method: String,
    /// Seed of the run.
    pub seed: u64,
    /// Scene file as given in the config.
    pub scene: String,
    /// How `position` relates to the OBJ file's coordinates.
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
    /// The same point in the OBJ file's own coordinates.
    pub position_file: [f64; 3],
    /// Distance to the nearest surface (SDF value at the probe's voxel; negative inside solids).
    pub clearance: f32,
    /// Class of the voxel holding the probe; `null` outside the grid.
    pub voxel_class: Option<VoxelClass>,
    /// Skeleton voxels the probe stands for (0 for grid probes).
    pub cluster_size: u32,
}

impl ProbesFile {
    /// Builds the file's contents from a placement in `scene`.
    pub fn new(
        probes: &ProbeSet,
        scene: &Scene,
        sdf: &Sdf,
        scene_path: &str,
        seed: u64,
        scale: f64,
        up: UpAxis,
    ) -> ProbesFile {
        let records = probes
            .probes
            .iter()
            .enumerate()
            .map(|(index, p)| {
                let voxel = sdf.voxel_at(p.position);
                let world = scene.to_world(p.position);
                ProbeRecord {
                    index,
                    position: world.to_array(),
                    position_file: world_to_file(world, scale, up).to_array(),
                    clearance: voxel.map_or(f32::NAN, |v| sdf.distance[v]),
                    voxel_class: voxel.map(|v| sdf.class[v]),
                    cluster_size: p.cluster_size,
                }
            })
            .collect();
        ProbesFile {
            format: "probeplace.probes",
            version: FORMAT_VERSION,
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
    /// Usable triangles.
    pub triangles: usize,
    /// Faces dropped as degenerate or non-finite.
    pub dropped_triangles: usize,
    /// World-space bounds.
    pub bounds: BoundsRecord,
    /// Total surface area (one side).
    pub area: f64,
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

/// `report.json`.
#[derive(Debug, Serialize)]
pub struct Report {
    /// Always `probeplace.report`.
    pub format: &'static str,
    /// [`FORMAT_VERSION`].
    pub version: u32,
    /// Placement method.
    pub method: String,
    /// Seed of the run.
    pub seed: u64,
    /// Config file of the run.
    pub config: String,
    /// Number of probes placed.
    pub probe_count: usize,
    /// Covered share of the coverable surface (see the coverage module).
    pub coverage: f64,
    /// Half-width of the 95% interval of `coverage`.
    pub coverage_ci95: f64,
    /// Probes inside solid voxels.
    pub probes_in_solid: usize,
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
    /// Sample counts behind `coverage`.
    pub coverage_detail: Coverage,
    /// What the placement method's steps kept and dropped (see docs/formats.md).
    pub placement_stats: BTreeMap<&'static str, u64>,
    /// The placement method's parameters as used, defaults resolved.
    pub placement_params: BTreeMap<&'static str, f64>,
    /// What refinement did; `null` when it was off.
    pub refine: Option<RefineReport>,
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

impl Report {
    /// Assembles the report from the stages' outputs.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        config: &str,
        scene_path: &str,
        scene: &Scene,
        domain: &Bounds,
        sdf: &Sdf,
        probes: &ProbeSet,
        seed: u64,
        coverage: Coverage,
        health: ProbeHealth,
        timings_ms: BTreeMap<String, f64>,
        warnings: Vec<String>,
    ) -> Report {
        Report {
            format: "probeplace.report",
            version: FORMAT_VERSION,
            method: probes.method.clone(),
            seed,
            config: config.to_string(),
            probe_count: probes.probes.len(),
            coverage: coverage.coverage,
            coverage_ci95: coverage.ci95,
            probes_in_solid: health.probes_in_solid,
            probes_outside_scene: health.probes_outside_scene,
            probes_outside_domain: health.probes_outside_domain,
            probes_below_clearance: 0,
            best_view_incidence_deg: None,
            scene: SceneRecord {
                path: scene_path.to_string(),
                triangles: scene.triangles.len(),
                dropped_triangles: scene.dropped_triangles,
                bounds: BoundsRecord::world(&scene.bounds, scene),
                area: scene.area(),
            },
            domain: BoundsRecord::world(domain, scene),
            sdf: sdf.into(),
            resolution: None,
            coverage_detail: coverage,
            placement_stats: probes.stats.clone(),
            placement_params: probes.params.clone(),
            refine: None,
            svo: None,
            bake: None,
            render: None,
            timings_ms,
            warnings,
        }
    }
}

/// Serializes `value` as pretty JSON with a trailing newline.
pub fn to_json<T: Serialize>(value: &T) -> Result<Vec<u8>> {
    let mut bytes = serde_json::to_vec_pretty(value)
        .map_err(|e| Error::Internal(format!("serializing JSON: {e}")))?;
    bytes.push(b'\n');
    Ok(bytes)
}

/// Writes `bytes` to `path` atomically: a temporary file beside it, then a
/// rename. On failure the temporary file is removed and `path` is untouched.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    let name = path
        .file_name()
        .ok_or_else(|| Error::Internal(format!("{}: not a file path", path.display())))?;
    let tmp = path.with_file_name(format!(".{}.tmp", name.to_string_lossy()));
    let result = std::fs::write(&tmp, bytes).and_then(|_| std::fs::rename(&tmp, path));
    if let Err(e) = result {
        let _ = std::fs::remove_file(&tmp);
        return Err(Error::io(path, e));
    }
    Ok(())
}

/// Refuses an output path that exists and is not a directory.
pub fn check_output_dir(dir: &Path) -> Result<()> {
    if dir.exists() && !dir.is_dir() {
        return Err(Error::user_file(
            dir,
            "output path exists and is not a directory",
        ));
    }
    Ok(())
}

/// Creates the output directory, or explains in one line why it cannot.
pub fn prepare_output_dir(dir: &Path) -> Result<()> {
    check_output_dir(dir)?;
    std::fs::create_dir_all(dir)
        .map_err(|e| Error::user_file(dir, format!("cannot create output directory: {e}")))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn atomic_write_replaces_and_leaves_no_temporary() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("a.json");
        write_atomic(&p, b"one").unwrap();
        write_atomic(&p, b"two").unwrap();
        assert_eq!(std::fs::read(&p).unwrap(), b"two");
        let names: Vec<_> = std::fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names.len(), 1, "{names:?}");
    }

    #[test]
    fn failed_write_leaves_target_untouched() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("missing-subdir").join("a.json");
        assert!(write_atomic(&p, b"x").is_err());
        assert!(!p.exists());
    }

    #[test]
    fn output_dir_that_is_a_file_is_a_user_error() {
        let dir = tempfile::tempdir().unwrap();
        let f = dir.path().join("f");
        std::fs::write(&f, b"").unwrap();
        assert!(matches!(prepare_output_dir(&f), Err(Error::User(_))));
        assert!(prepare_output_dir(&dir.path().join("new/deeper")).is_ok());
    }
}
