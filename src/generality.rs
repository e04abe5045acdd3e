//! The generality check: a stock-config `place` run on a scene, held
//! against the uniform grids an engine would use instead.
//!
//! Wang et al. 2019 claim full coverage with fewer probes than a uniform
//! grid (§5, Table 1) on scenes they chose. The claim is only worth making
//! if it holds on scenes nobody tuned for, so this job runs the default
//! pipeline with nothing but the scene given (automatic voxel size, default
//! placement and refinement), then sweeps the uniform grids of
//! [`crate::placement::cubic_grid_sweep`] (up to [`GRID_SWEEP_CELLS`] cells
//! along the longest axis) for the smallest one that reaches the same
//! coverage, by the same coverage measure (same samples, same seed).
//! The claim is coverage's, so the run keeps to `refine.objective:
//! Coverage`: the diffuse step, which the stock config runs after it on a
//! lit scene, adds probes for diffuse light that `compare` scores.
//! `tests/it/generality.rs` asserts on its rows; `cargo run --release
//! --example generality` writes them as JSON, which `examples/results.rs` turns into docs/results.md.

use crate::config::Config;
use crate::error::Result;
use crate::jobs::{self, RunOptions};
use crate::placement::grid::smallest_grid_reaching;
use crate::progress::Progress;
use serde::Serialize;
use std::path::Path;

/// Most cells along the domain's longest axis in the grid sweep.
pub const GRID_SWEEP_CELLS: u32 = 16;

/// One scene's figures.
#[derive(Debug, Clone, Serialize)]
pub struct GeneralityRow {
    /// The scene's name.
    pub scene: String,
    /// The placement method as reported (`sdf-skeleton+refine`, …).
    pub method: String,
    /// Usable triangles.
    pub triangles: usize,
    /// The voxel size used, and whether it was chosen automatically.
    pub voxel_size: f32,
    /// `auto` or `config`.
    pub voxel_source: &'static str,
    /// Probes placed.
    pub probes: usize,
    /// Coverage reached, on the run's validation stream (samples the
    /// placer never saw).
    pub coverage: f64,
    /// Half-width of its 95% interval.
    pub coverage_ci95: f64,
    /// Coverage on the samples the placer fitted (a training score).
    pub coverage_train: Option<f64>,
    /// Probes in solid by their own rays.
    pub probes_in_solid: usize,
    /// The same probes measured again by another seed
    /// ([`REMEASURE_SEED`]): its validation stream and its SDF, as
    /// `place CONFIG --probes OUT/probes.json --seed S` does.
    pub remeasure: Remeasure,
    /// Probes filling placed below the placement's clearance.
    pub probes_below_clearance: usize,
    /// Mean incidence (degrees) of each covered sample's best view.
    pub best_view_incidence_deg: Option<f64>,
    /// Warnings of the run.
    pub warnings: Vec<String>,
    /// The smallest grid of the sweep reaching `coverage` (`NxMxK`), its
    /// probe count and its coverage; `None` when no grid of the sweep (of
    /// at most `grid_probe_limit` probes) does.
    pub smallest_grid: Option<(String, usize, f64)>,
    /// The sweep stopped at grids of this many probes (`null`: the whole
    /// sweep): enough to tell whether ours wins, without scoring the
    /// large grids.
    pub grid_probe_limit: Option<usize>,
    /// Wall time of the `place` run (ms).
    pub place_ms: f64,
}

/// The seed of the re-measure: none of the configs' or the suite's.
pub const REMEASURE_SEED: u64 = 101;

/// A placement's figures by another seed's measure.
#[derive(Debug, Clone, Copy, Default, Serialize)]
pub struct Remeasure {
    /// The seed.
    pub seed: u64,
    /// Coverage by that seed's validation stream.
    pub coverage: f64,
    /// Half-width of its 95% interval.
    pub coverage_ci95: f64,
    /// Probes in solid by their own rays.
    pub probes_in_solid: usize,
    /// Probes in voxels that seed's SDF classifies solid.
    pub probes_in_solid_sdf: usize,
}

/// Scores the probes of `probes_json` (a run of `config_path`, whose
/// config is `config`) with `seed`: its SDF and validation stream.
pub fn remeasure(
    config: Config,
    config_path: &Path,
    probes_json: &Path,
    seed: u64,
) -> Result<Remeasure> {
    let out = std::env::temp_dir().join(format!(
        "probeplace-remeasure-{}-{seed}",
        std::process::id()
    ));
    let options = RunOptions {
        config: Some(config_path.to_path_buf()),
        loaded: Some(config),
        out: Some(out),
        overrides: crate::provenance::Overrides {
            seed: Some(seed),
            probes: Some(probes_json.to_path_buf()),
            ..Default::default()
        },
        ..Default::default()
    };
    let run = jobs::place::compute(&options)?;
    let r = &run.report;
    Ok(Remeasure {
        seed,
        coverage: r.coverage,
        coverage_ci95: r.coverage_ci95,
        probes_in_solid: r.probes_in_solid,
        probes_in_solid_sdf: r.probes_in_solid_sdf,
    })
}

impl GeneralityRow {
    /// Whether ours beats the grids: fewer probes than the smallest grid
    /// reaching the same coverage, or no grid of the sweep reaching it.
    pub fn beats_grids(&self) -> bool {
        self.smallest_grid
            .as_ref()
            .is_none_or(|(_, count, _)| self.probes < *count)
    }
}

/// Runs `place` with `config` (read from `config_path`; outputs into
/// `out`), then the grid sweep (module docs), over the whole sweep or, when
/// `whole_sweep` is false, over the grids of at most our probe count (which
/// decides [`GeneralityRow::beats_grids`] at a fraction of the cost).
///
/// Contract: the row's coverage is the run's `report.json` coverage; the
/// grid coverages come from the coverage reference the run was scored by.
pub fn run(
    name: &str,
    mut config: Config,
    config_path: &Path,
    out: &Path,
    whole_sweep: bool,
) -> Result<GeneralityRow> {
    config.refine.objective = crate::config::Objective::Coverage;
    let options = RunOptions {
        config: Some(config_path.to_path_buf()),
        loaded: Some(config),
        out: Some(out.to_path_buf()),
        ..Default::default()
    };
    let run = jobs::place::compute(&options)?;
    let place_ms = run.job.watch.elapsed_ms();
    let r = &run.report;
    let progress = Progress::hidden();
    let grid_probe_limit = (!whole_sweep).then_some(r.probe_count);
    let smallest_grid = smallest_grid_reaching(
        &run.prepared.domain,
        &run.prepared.bvh,
        &run.reference,
        r.coverage,
        GRID_SWEEP_CELLS,
        grid_probe_limit,
        &progress,
    )
    .map(|(g, c)| (g.dims_text(), g.probes(), c));
    let probes_json = out.join("probes.json");
    let config = run.config().clone();
    let mut row = GeneralityRow {
        scene: name.to_string(),
        method: r.method.clone(),
        triangles: r.scene.triangles,
        voxel_size: r.sdf.voxel_size,
        voxel_source: r.resolution.map_or("config", |x| x.source),
        probes: r.probe_count,
        coverage: r.coverage,
        coverage_ci95: r.coverage_ci95,
        coverage_train: r.coverage_train,
        probes_in_solid: r.probes_in_solid,
        remeasure: Remeasure::default(),
        probes_below_clearance: r.probes_below_clearance,
        best_view_incidence_deg: r.best_view_incidence_deg,
        warnings: r.warnings.clone(),
        smallest_grid,
        grid_probe_limit,
        place_ms,
    };
    run.commit()?;
    row.remeasure = remeasure(config, config_path, &probes_json, REMEASURE_SEED)?;
    Ok(row)
}

/// The rows as a Markdown table (what the generality test prints).
pub fn markdown_table(rows: &[GeneralityRow]) -> String {
    let mut out = String::from(
        "| scene | method | triangles | voxel | probes | coverage (validation) | training | seed 101 | in solid (rays; seed 101's SDF) | below clearance | smallest grid reaching it |\n|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---|\n",
    );
    for r in rows {
        let grid = match &r.smallest_grid {
            Some((dims, n, c)) => format!("{dims} = {n} ({:.2}%)", 100.0 * c),
            None => match r.grid_probe_limit {
                Some(n) => format!("none of at most {n} probes"),
                None => format!("none up to {GRID_SWEEP_CELLS} cells"),
            },
        };
        out.push_str(&format!(
            "| {} | {} | {} | {:.4} ({}) | {} | {:.2}% ± {:.2}% | {} | {:.2}% | {}; {} | {} | {} |\n",
            r.scene,
            r.method,
            r.triangles,
            r.voxel_size,
            r.voxel_source,
            r.probes,
            100.0 * r.coverage,
            100.0 * r.coverage_ci95,
            r.coverage_train
                .map_or("–".to_string(), |c| format!("{:.2}%", 100.0 * c)),
            100.0 * r.remeasure.coverage,
            r.probes_in_solid,
            r.remeasure.probes_in_solid_sdf,
            r.probes_below_clearance,
            grid
        ));
    }
    out
}
