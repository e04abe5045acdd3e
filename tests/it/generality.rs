//! Placement that holds on any scene: the stock config (nothing but the
//! scene, its scale and up axis) on seeded generated scenes, and every
//! shipped config with its `voxel_size` removed, each reaching the coverage
//! target within its interval on samples the placer never saw (its
//! validation stream, and another seed's re-measure of the same probes)
//! with no probe in solid by its own rays or the other seed's SDF and fewer probes than the smallest uniform
//! grid that reaches the same coverage (or no grid of the sweep reaching it).
//!
//! `cargo run --release --example generality` writes the same rows as
//! JSON, which examples/results.rs turns into docs/results.md.

use crate::common::*;
use probeplace::config::{Config, VoxelSize};
use probeplace::fixtures::generated::{generate, suite, Kind};
use probeplace::generality::{self, GeneralityRow};
use std::path::Path;

/// The coverage target of the stock config.
const TARGET: f64 = 0.999;

/// Failures of one row against the bar, as lines.
fn failures(r: &GeneralityRow) -> Vec<String> {
    let mut out = Vec::new();
    // The validation figure (samples the placer never saw) and another
    // seed's re-measure of the same probes, each within its interval.
    if r.coverage < TARGET - r.coverage_ci95 {
        out.push(format!(
            "{}: coverage {:.4} ± {:.4} under {TARGET}",
            r.scene, r.coverage, r.coverage_ci95
        ));
    }
    let m = &r.remeasure;
    assert_eq!(m.seed, generality::REMEASURE_SEED);
    if m.coverage < TARGET - m.coverage_ci95 {
        out.push(format!(
            "{}: seed {} re-measures coverage {:.4} ± {:.4}, under {TARGET}",
            r.scene, m.seed, m.coverage, m.coverage_ci95
        ));
    }
    // In solid by the probes' own rays, the verdict the placer drops
    // probes by, under this seed and the other (the other seed's SDF may
    // still read a voxel as solid: the table shows it).
    if r.probes_in_solid > 0 || m.probes_in_solid > 0 {
        out.push(format!(
            "{}: {} probes in solid by their rays; by seed {}: {}",
            r.scene, r.probes_in_solid, m.seed, m.probes_in_solid
        ));
    }
    if !r.beats_grids() {
        out.push(format!(
            "{}: {} probes, but grid {:?} reaches the same coverage",
            r.scene, r.probes, r.smallest_grid
        ));
    }
    // Scene warnings (degenerate triangles dropped on load, a material an
    // asset uses but its MTL lacks) are the asset's and name its file;
    // placement itself must not warn.
    let asset = |w: &String| w.contains(".obj: ") || w.contains(".mtl");
    for w in r.warnings.iter().filter(|w| !asset(w)) {
        out.push(format!("{}: warning: {w}", r.scene));
    }
    out
}

fn check(rows: &[GeneralityRow]) {
    eprintln!("{}", generality::markdown_table(rows));
    let bad: Vec<String> = rows.iter().flat_map(failures).collect();
    assert!(bad.is_empty(), "{}", bad.join("\n"));
}

fn run(name: &str, config: Config, path: &Path) -> GeneralityRow {
    let out = tempfile::tempdir().unwrap();
    generality::run(name, config, path, out.path(), false).unwrap()
}

/// The generated scenes CI places: the first seed of every kind, and of
/// the units kind the two seeds that between them cover both units and both
/// up axes (millimetres Z-up, centimetres Y-up; `suite`'s comment).
/// `cargo run --release --example generality` runs the whole suite, every
/// seed of every kind, for docs/results.md.
fn ci_suite() -> Vec<(Kind, u64)> {
    let suite = suite();
    assert!(suite.len() >= 20);
    let first = |kind: Kind| suite.iter().find(|(k, _)| *k == kind).map(|&(_, s)| s);
    suite
        .iter()
        .copied()
        .filter(|&(kind, seed)| match kind {
            Kind::Units => [5, 10].contains(&seed),
            _ => first(kind) == Some(seed),
        })
        .collect()
}

#[test]
fn generated_scenes_are_covered_by_the_stock_config() {
    let dir = tempfile::tempdir().unwrap();
    let suite = ci_suite();
    assert!(suite.len() >= 9, "{suite:?}");
    let rows: Vec<GeneralityRow> = suite
        .iter()
        .map(|&(kind, seed)| {
            let g = generate(kind, seed);
            let path = g.write(dir.path()).unwrap();
            let config = Config::load(&path).unwrap();
            assert_eq!(config.voxel_size, VoxelSize::Auto);
            run(&g.fixture.name, config, &path)
        })
        .collect();
    assert!(rows.iter().all(|r| r.voxel_source == "auto"));
    check(&rows);
}

#[test]
fn every_shipped_config_holds_without_its_voxel_size() {
    let configs = shipped_configs();
    let rows: Vec<GeneralityRow> = configs
        .iter()
        .map(|path| {
            let mut config = Config::load(path).unwrap();
            config.voxel_size = VoxelSize::Auto;
            let name = path.file_stem().unwrap().to_string_lossy().into_owned();
            run(&name, config, path)
        })
        .collect();
    check(&rows);
}
