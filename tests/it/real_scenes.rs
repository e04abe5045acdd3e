//! The real scenes of McGuire's Computer Graphics Archive, read from
//! ../shared/scenes (never copied into the repository).

use crate::common::*;

/// The report of `place` on the shipped config, run once per test process
/// (the SVO tests read the same runs).
fn run(config: &str) -> &'static serde_json::Value {
    shared_scenes();
    let r = &shared_job("place", &format!("configs/{config}.ron"), &[]).report;
    assert_svo_sound(r, config);
    r
}

#[test]
fn dabrovic_sponza() {
    let r = run("sponza");
    assert_eq!(r["probes_in_solid"], 0);
    assert!(r["scene"]["triangles"].as_u64().unwrap() > 66_000);
    let cov = r["coverage"].as_f64().unwrap();
    assert!(cov >= 0.9, "coverage {cov}");
    assert!(r["coverage_ci95"].as_f64().unwrap() <= 0.005);
    // The atrium is open to the sky: some voxels must be classified outside.
    assert!(r["sdf"]["outside"].as_u64().unwrap() > 0);
    // No normals in the file, so the loader used geometric normals: nothing to drop but slivers.
    assert!(r["scene"]["dropped_triangles"].as_u64().unwrap() < 100);
}

#[test]
fn holodeck() {
    let r = run("holodeck");
    assert_eq!(r["probes_in_solid"], 0);
    assert!(r["coverage"].as_f64().unwrap() >= 0.9, "{}", r["coverage"]);
}

fn cornell_variant(cfg: &str) {
    let r = run(cfg);
    assert_eq!(r["probes_in_solid"], 0, "{cfg}");
    assert!(r["probe_count"].as_u64().unwrap() >= 1, "{cfg}");
}

/// The variants other tests also run (their runs are shared), and the
/// mirror: a box of 36 triangles.
#[test]
fn cornell_variants() {
    for cfg in ["cornell-original", "cornell-glossy", "cornell-mirror"] {
        cornell_variant(cfg);
    }
}

/// The variants with a sphere, water (7 088 triangles) or nothing inside.
#[test]
#[ignore = "full tier (about 30 s): cargo test --release -- --include-ignored"]
fn cornell_variants_with_other_contents() {
    for cfg in ["cornell-sphere", "cornell-water", "cornell-empty"] {
        cornell_variant(cfg);
    }
}

#[test]
fn archive_cornell_box_matches_our_measured_fixture() {
    // Same box, two sources (the archive's ~2-unit model and our millimetre
    // fixture): both must meet the default run's bar, coverage's count (the
    // diffuse step adds its own after it).
    let r = run("cornell-original");
    assert!(r["coverage"].as_f64().unwrap() >= 0.95, "{}", r["coverage"]);
    assert!(r["refine"]["probes_final"].as_u64().unwrap() <= 12);
}
