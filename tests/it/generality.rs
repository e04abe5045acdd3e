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
    // asset uses but its MTL lacks, a texture missing or spelt in another
    // letter case) are the asset's and name its file; placement itself
    // must not warn.
    let asset = |w: &String| w.contains(".obj: ") || w.contains(".mtl") || w.contains("texture");
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

/// The generated scenes of the CI tier: the families a new user's scene
/// most often trips on, and cheap to place (about 2 s each): both unit
/// plans' seeds (millimetres Z-up, centimetres Y-up; `suite`'s comment),
/// furniture, slats and thin walls. The full tier (`full_tier_suite`)
/// places the first seed of every other family.
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
            Kind::Furniture | Kind::Slats | Kind::ThinWalls => first(kind) == Some(seed),
            _ => false,
        })
        .collect()
}

/// The generated scenes of the full tier: the first seed of every family
/// the CI tier leaves out.
fn full_tier_suite() -> Vec<(Kind, u64)> {
    let suite = suite();
    let ci = ci_suite();
    let first = |kind: Kind| suite.iter().find(|(k, _)| *k == kind).map(|&(_, s)| s);
    suite
        .iter()
        .copied()
        .filter(|&(kind, seed)| !ci.iter().any(|&(k, _)| k == kind) && first(kind) == Some(seed))
        .collect()
}

fn place_generated(suite: &[(Kind, u64)]) {
    let dir = tempfile::tempdir().unwrap();
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

/// The two tiers together place every family of the suite, each family in
/// one tier only: a family added to the generator lands in the full tier.
#[test]
fn the_tiers_place_every_generated_family_once() {
    let (ci, full) = (ci_suite(), full_tier_suite());
    assert_eq!(ci.len(), 5, "{ci:?}");
    let mut kinds: Vec<Kind> = suite().iter().map(|&(k, _)| k).collect();
    kinds.dedup();
    for kind in kinds {
        let (a, b) = (
            ci.iter().any(|&(k, _)| k == kind),
            full.iter().any(|&(k, _)| k == kind),
        );
        assert!(a != b, "{kind:?}: CI tier {a}, full tier {b}");
    }
}

#[test]
fn generated_scenes_are_covered_by_the_stock_config() {
    place_generated(&ci_suite());
}

#[test]
#[ignore = "full tier (about 4 min): cargo test --release -- --include-ignored"]
fn every_other_generated_family_is_covered_by_the_stock_config() {
    place_generated(&full_tier_suite());
}

#[test]
#[ignore = "full tier (about 3 min): cargo test --release -- --include-ignored"]
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
