//! End-to-end runs of `probeplace place` on our own fixtures.

mod common;
use common::*;

#[test]
fn cornell_default_run_meets_the_acceptance_bar() {
    let out = tempfile::tempdir().unwrap();
    let r = place(&root().join("configs/cornell.ron"), out.path(), &[]);
    assert_eq!(r["method"], "sdf-skeleton");
    assert_eq!(r["probes_in_solid"], 0);
    assert_eq!(r["probes_outside_domain"], 0);
    let n = r["probe_count"].as_u64().unwrap();
    assert!((1..=12).contains(&n), "probe_count {n}");
    let cov = r["coverage"].as_f64().unwrap();
    assert!(cov >= 0.95, "coverage {cov}");
    assert!(r["coverage_ci95"].as_f64().unwrap() <= 0.005);
    assert_eq!(r["scene"]["triangles"], 32);
    for stage in [
        "load",
        "bvh",
        "sdf",
        "placement",
        "coverage",
        "preview",
        "total",
    ] {
        assert!(
            r["timings_ms"][stage].as_f64().is_some(),
            "timing {stage} missing"
        );
    }
    let probes = read_json(&out.path().join("probes.json"));
    assert_eq!(probes["probes"].as_array().unwrap().len() as u64, n);
    assert_eq!(probes["format"], "probeplace.probes");
    // position_file is the OBJ's millimetres: world metres × 1000.
    let p = &probes["probes"][0];
    let (w, f) = (
        p["position"][0].as_f64().unwrap(),
        p["position_file"][0].as_f64().unwrap(),
    );
    assert!(
        (w * 1000.0 - f).abs() < 1e-2 * f.abs().max(1.0),
        "{w} vs {f}"
    );
    let png = image::open(out.path().join("placement.png")).unwrap();
    assert_eq!(png.height(), 512);
    // Nothing else (no temporary files) is left behind.
    let mut names: Vec<String> = std::fs::read_dir(out.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(names, ["placement.png", "probes.json", "report.json"]);
}

#[test]
fn grid_method_from_the_command_line() {
    let out = tempfile::tempdir().unwrap();
    let r = place(
        &root().join("configs/cornell.ron"),
        out.path(),
        &["--method", "grid:2x2x2"],
    );
    assert_eq!(r["method"], "grid:2x2x2");
    assert_eq!(r["probe_count"], 8);
    let cov = r["coverage"].as_f64().unwrap();
    assert!(cov > 0.0 && cov <= 1.0, "{cov}");
    // A 2x2x2 grid in the Cornell box puts probes inside the tall block.
    let probes = read_json(&out.path().join("probes.json"));
    let in_solid = probes["probes"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|p| p["voxel_class"] == "solid")
        .count();
    assert_eq!(r["probes_in_solid"].as_u64().unwrap() as usize, in_solid);
}

#[test]
fn same_config_and_seed_give_byte_identical_probes() {
    for method in ["sdf-skeleton", "medial-axis"] {
        let (a, b) = (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
        let cfg = root().join("configs/cornell.ron");
        place(&cfg, a.path(), &["--method", method]);
        place(&cfg, b.path(), &["--method", method]);
        for f in ["probes.json", "placement.png"] {
            assert_eq!(
                std::fs::read(a.path().join(f)).unwrap(),
                std::fs::read(b.path().join(f)).unwrap(),
                "{method}: {f} differs between identical runs"
            );
        }
    }
}

#[test]
fn seed_changes_the_coverage_samples_not_the_validity() {
    let (a, b) = (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
    let cfg = root().join("configs/cornell.ron");
    let ra = place(&cfg, a.path(), &["--seed", "1"]);
    let rb = place(&cfg, b.path(), &["--seed", "2"]);
    assert_eq!(rb["seed"], 2);
    assert_ne!(
        ra["coverage_detail"]["covered_samples"],
        rb["coverage_detail"]["covered_samples"]
    );
    let diff = (ra["coverage"].as_f64().unwrap() - rb["coverage"].as_f64().unwrap()).abs();
    assert!(diff < 0.02, "coverage estimates disagree by {diff}");
}

#[test]
fn procedural_fixtures_place_without_solid_probes() {
    for cfg in ["pillared-hall", "two-rooms"] {
        let out = tempfile::tempdir().unwrap();
        let r = place(&root().join(format!("configs/{cfg}.ron")), out.path(), &[]);
        assert_eq!(r["probes_in_solid"], 0, "{cfg}");
        assert!(
            r["coverage"].as_f64().unwrap() >= 0.9,
            "{cfg}: {}",
            r["coverage"]
        );
    }
}

#[test]
fn committed_fixtures_match_their_generator() {
    for f in probeplace::fixtures::all() {
        for (ext, text) in [("obj", &f.obj), ("mtl", &f.mtl)] {
            let path = root().join(format!("fixtures/{}.{ext}", f.name));
            let on_disk = std::fs::read_to_string(&path).unwrap();
            assert!(
                &on_disk == text,
                "{} is stale: run `cargo run --example gen_fixtures`",
                path.display()
            );
        }
    }
}
