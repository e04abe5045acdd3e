//! Artist controls: `fixed_probes`, `exclude`, `max_probes`, `min_probes`
//! and `probe_density`, each honoured by placement, refinement, filling and
//! pruning (src/placement/controls.rs).

use crate::common::*;
use serde_json::Value;
use std::path::Path;

/// Runs `place` on `config` into a fresh directory; its report and probes.
fn place_into(config: &Overlay, extra: &[&str]) -> (tempfile::TempDir, Value, Vec<Value>) {
    let out = tempfile::tempdir().unwrap();
    let report = place(config.path(), out.path(), extra);
    let probes = probes_of(out.path());
    (out, report, probes)
}

fn probes_of(dir: &Path) -> Vec<Value> {
    read_json(&dir.join("probes.json"))["probes"]
        .as_array()
        .unwrap()
        .clone()
}

fn position(p: &Value) -> [f64; 3] {
    let a = p["position"].as_array().unwrap();
    [0, 1, 2].map(|i| a[i].as_f64().unwrap())
}

fn inside(p: [f64; 3], min: [f64; 3], max: [f64; 3]) -> bool {
    (0..3).all(|i| min[i] <= p[i] && p[i] <= max[i])
}

fn ron_box(min: [f64; 3], max: [f64; 3]) -> String {
    format!(
        "Box((min: ({}, {}, {}), max: ({}, {}, {})))",
        min[0], min[1], min[2], max[0], max[1], max[2]
    )
}

/// The coverage target less the validation interval's half-width: the
/// bar a validation figure (samples the placer never saw) must clear.
fn target(report: &Value) -> f64 {
    report["refine"]["params"]["coverage_target"]
        .as_f64()
        .unwrap()
        - report["coverage_ci95"].as_f64().unwrap()
}

/// The acceptance: three hand-picked points in the Holodeck stay
/// where given, first; coverage still reaches the target; the placer adds
/// only what they miss (at most the count without them plus 3, and one
/// for the greedy's slack).
#[test]
fn fixed_probes_stay_put_and_the_placer_adds_only_what_they_miss() {
    let base = &shared_job("place", "configs/holodeck.ron", &[]).report;
    let fixed = [[1.0, 1.5, 0.0], [4.0, 1.0, 1.5], [6.0, 2.0, -1.5]];
    let list: Vec<String> = fixed
        .iter()
        .map(|p| format!("({}, {}, {})", p[0], p[1], p[2]))
        .collect();
    let config = overlay(
        "configs/holodeck.ron",
        &[("fixed_probes", &format!("[{}]", list.join(", ")))],
    );
    let (out, r, probes) = place_into(&config, &[]);
    for (i, p) in fixed.iter().enumerate() {
        assert_eq!(position(&probes[i]), *p, "fixed probe {i} moved");
        assert_eq!(probes[i]["fixed"], true);
    }
    assert!(probes[3..].iter().all(|p| p["fixed"] == false));
    assert_eq!(r["controls"]["fixed_probes"], 3);
    // Coverage's own count: the diffuse step adds after it, in proportion.
    let (n, n_base) = (
        r["refine"]["probes_final"].as_u64().unwrap(),
        base["refine"]["probes_final"].as_u64().unwrap(),
    );
    // One more than the three: the greedy fill works around points it
    // did not choose (since surfaces seen only through a slit stopped
    // counting, the coverage set is 5 probes and has no slack to absorb
    // them: 3 fixed + 6 where 5 stood alone).
    assert!(
        n <= n_base + 3 + 1,
        "{n} probes, {n_base} without the fixed ones"
    );
    let coverage = r["coverage"].as_f64().unwrap();
    assert!(
        coverage >= target(&r),
        "coverage {coverage} under the target"
    );
    assert!(r["refine"]["removed"].as_u64().unwrap() > 0);
    // The page says what the controls did; a run without them has no table.
    let page = |d: &Path| std::fs::read_to_string(d.join("report.html")).unwrap();
    assert!(page(out.path()).contains("id=\"controls-table\""));
    let base_dir = &shared_job("place", "configs/holodeck.ron", &[]).dir;
    assert!(!page(base_dir).contains("id=\"controls-table\""));
    // The engines learn which probes were pinned.
    let dir = out.path().to_str().unwrap();
    let o = probeplace(&["export", dir, "--format", "tscn", "-q"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let tscn = std::fs::read_to_string(out.path().join("probes.tscn")).unwrap();
    assert_eq!(tscn.matches("metadata/fixed = true").count(), 3);
}

/// A fixed probe in solid, outside the domain, inside an exclude box, or
/// repeated, and more fixed probes than the budget: one line naming the
/// entry, exit 2, nothing written.
#[test]
fn impossible_fixed_probes_are_refused_by_name() {
    // The tall block of our Cornell box stands over x 0.265–0.423,
    // z 0.296–0.456, 0.33 high.
    let cases: [(&[(&str, &str)], &str); 6] = [
        (
            &[("fixed_probes", "[(0.1, 0.4, 0.1), (0.34, 0.15, 0.38)]")],
            "fixed_probes[1]: (0.34, 0.15, 0.38) stands in solid",
        ),
        (
            &[("fixed_probes", "[(0.3, 2.0, 0.3)]")],
            "fixed_probes[0]: (0.3, 2, 0.3) is outside the domain",
        ),
        (
            &[
                ("fixed_probes", "[(0.1, 0.4, 0.1)]"),
                ("exclude", "[Box((min: (0, 0.3, 0), max: (0.2, 0.5, 0.2)))]"),
            ],
            "fixed_probes[0]: (0.1, 0.4, 0.1) lies inside exclude[0]",
        ),
        (
            &[("fixed_probes", "[(0.1, 0.4, 0.1), (0.1, 0.4, 0.1)]")],
            "fixed_probes[1]: (0.1, 0.4, 0.1) repeats fixed_probes[0]",
        ),
        (
            &[
                ("fixed_probes", "[(0.1, 0.4, 0.1), (0.2, 0.4, 0.1)]"),
                ("max_probes", "1"),
            ],
            "max_probes: 1 is fewer than the 2 fixed_probes",
        ),
        (
            &[("max_probes", "3"), ("min_probes", "4")],
            "min_probes: 4 is more than max_probes: 3",
        ),
    ];
    for (set, expected) in cases {
        let config = overlay("configs/cornell.ron", set);
        let line = refused_in(
            config.path().parent().unwrap(),
            &["place", config.arg(), "--out", "out"],
            &[],
        )
        .line;
        assert!(line.contains(expected), "{set:?}: {line}");
        assert!(line.contains("cornell.ron"), "names the config: {line}");
    }
    for (field, value, expected) in [
        ("max_probes", "0", "max_probes"),
        ("max_probes", "70000", "max_probes"),
        ("min_probes", "0", "min_probes"),
        (
            "min_probes",
            "60000",
            "min_probes: topping up to 60000 probes",
        ),
        (
            "probe_density",
            "[(Box((min: (0, 0, 0), max: (1, 1, 1))), 9.0)]",
            "density factor must lie in [0, 8]",
        ),
        (
            "exclude",
            "[Box((min: (1, 0, 0), max: (0, 1, 1)))]",
            "min < max",
        ),
    ] {
        // Not an overlay: it loads what it writes.
        let dir = tempfile::tempdir().unwrap();
        let text = std::fs::read_to_string(root().join("configs/cornell.ron")).unwrap();
        let scene = format!("{:?}", root().join("fixtures/cornell_box.obj"));
        let config = dir.path().join("cornell.ron");
        std::fs::write(
            &config,
            set_ron_fields(&text, &[("scene", &scene), (field, value)]),
        )
        .unwrap();
        let line = refused_in(dir.path(), &["place", "cornell.ron", "--out", "out"], &[]).line;
        assert!(
            line.contains(field) && line.contains(expected),
            "{field}: {value}: {line}"
        );
    }
}

/// No probe inside an exclude box, whether the placement put one there
/// (dropped), refinement would move one there, or filling would add one;
/// coverage still reaches the target from outside it. A grid without
/// refinement loses exactly its cells inside the box.
#[test]
fn exclude_keeps_every_probe_out_of_its_boxes() {
    // A box, 0.08 m each way, around the first probe the placement puts
    // (the unrefined run's; refinement may move or replace it, so the
    // refined run's first probe need not be one the placement put).
    let base = &shared_job("place", "configs/cornell.ron", &["--no-refine"]).dir;
    let first = position(&probes_of(base)[0]);
    let (min, max) = (first.map(|c| c - 0.08), first.map(|c| c + 0.08));
    let config = overlay(
        "configs/cornell.ron",
        &[("exclude", &format!("[{}]", ron_box(min, max)))],
    );
    let (_out, r, probes) = place_into(&config, &[]);
    assert!(r["controls"]["excluded"].as_u64().unwrap() >= 1);
    for p in &probes {
        assert!(
            !inside(position(p), min, max),
            "probe at {:?} in the box",
            position(p)
        );
    }
    assert!(
        r["coverage"].as_f64().unwrap() >= target(&r),
        "{}",
        r["coverage"]
    );

    let (_grid_out, g, grid) = place_into(&config, &["--method", "grid:4x4x4", "--no-refine"]);
    let (_all_out, _, all) = place_into(
        &overlay("configs/cornell.ron", &[]),
        &["--method", "grid:4x4x4", "--no-refine"],
    );
    let kept: Vec<[f64; 3]> = all
        .iter()
        .map(position)
        .filter(|&p| !inside(p, min, max))
        .collect();
    assert!(kept.len() < all.len(), "the box holds some grid probe");
    assert_eq!(grid.iter().map(position).collect::<Vec<_>>(), kept);
    assert_eq!(
        g["controls"]["excluded"].as_u64().unwrap() as usize,
        all.len() - kept.len()
    );
}

/// The acceptance: `max_probes: 8` on Sponza gives 8 probes, picked
/// from what the unbounded run keeps (its count is the one before the
/// budget), and the report says what coverage they reach, short of the
/// target; they cover more than a uniform grid of 8 probes does. At test
/// quality, all three runs alike.
#[test]
fn max_probes_keeps_the_probes_that_cover_the_most() {
    let (_base_out, base, _) = place_into(&test_quality("configs/sponza.ron", &[]), &[]);
    let base = &base;
    let config = test_quality("configs/sponza.ron", &[("max_probes", "8")]);
    let (_out, r, probes) = place_into(&config, &[]);
    assert_eq!(probes.len(), 8);
    assert_eq!(r["probe_count"], 8);
    assert_eq!(r["controls"]["max_probes"], 8);
    // The unbounded run's probes before its check rounds added to them
    // (and dropped any in solid): under a budget no round runs.
    let refine = &base["refine"];
    let rounds_added: u64 = refine["check_rounds"]
        .as_array()
        .unwrap()
        .iter()
        .map(|r| r["added"].as_u64().unwrap())
        .sum();
    // (Coverage's own count: the diffuse step adds after it, and under a
    // budget it reaches adds none.)
    let before_rounds = refine["probes_final"].as_u64().unwrap() - rounds_added
        + refine["probes_dropped_in_solid"].as_u64().unwrap();
    assert_eq!(
        r["controls"]["probes_before_budget"].as_u64(),
        Some(before_rounds),
        "the budget cuts the run's own probes"
    );
    let coverage = r["coverage"].as_f64().unwrap();
    assert!(coverage < target(&r) && coverage < base["coverage"].as_f64().unwrap());
    let warned = r["warnings"]
        .as_array()
        .unwrap()
        .iter()
        .any(|w| w.as_str().unwrap().starts_with("max_probes: 8: 8 probes"));
    assert!(warned, "{}", r["warnings"]);
    let (_grid_out, g, _) = place_into(
        &test_quality("configs/sponza.ron", &[]),
        &["--method", "grid:4x1x2", "--no-refine"],
    );
    assert_eq!(g["probe_count"], 8);
    let grid = g["coverage"].as_f64().unwrap();
    assert!(
        coverage > grid,
        "budget of 8: {coverage}; 8-probe grid: {grid}"
    );
}

/// Without refinement the budget still holds: a grid cut to 3 keeps the
/// fixed probe first and 2 of its own probes, in grid order, and covers
/// less than the whole grid.
#[test]
fn max_probes_cuts_an_unrefined_grid_and_keeps_the_fixed_probe() {
    let config = overlay(
        "configs/cornell.ron",
        &[("max_probes", "3"), ("fixed_probes", "[(0.1, 0.45, 0.1)]")],
    );
    let (_out, r, probes) = place_into(&config, &["--method", "grid:4x4x4", "--no-refine"]);
    assert_eq!(probes.len(), 3);
    assert_eq!(position(&probes[0]), [0.1, 0.45, 0.1]);
    assert_eq!(r["controls"]["probes_before_budget"], 65);
    let (_all_out, all_report, all) = place_into(
        &overlay("configs/cornell.ron", &[]),
        &["--method", "grid:4x4x4", "--no-refine"],
    );
    let grid: Vec<[f64; 3]> = all.iter().map(position).collect();
    let mut at = 0;
    for p in &probes[1..] {
        let i = grid[at..]
            .iter()
            .position(|q| *q == position(p))
            .expect("a grid probe, in grid order");
        at += i + 1;
    }
    assert!(r["coverage"].as_f64().unwrap() < all_report["coverage"].as_f64().unwrap());
}

/// `min_probes` above what coverage needs: exactly that many probes, the
/// ones coverage needed among them, coverage no lower, and the report says
/// how many there were before; with `max_probes` of the same value below
/// what coverage needs, exactly that many too. Without refinement it is a
/// warning and changes nothing.
#[test]
fn min_probes_spends_the_budget_and_with_max_probes_places_exactly_that_many() {
    // Coverage alone: the diffuse step would add probes past the floor.
    let coverage_only = ("refine", "(objective: Coverage)");
    let (_base_out, base_report, base_probes) =
        place_into(&overlay("configs/cornell.ron", &[coverage_only]), &[]);
    let n = base_probes.len();
    let more = (n + 4).to_string();
    let (_o, r, probes) = place_into(
        &overlay(
            "configs/cornell.ron",
            &[("min_probes", &more), coverage_only],
        ),
        &[],
    );
    assert_eq!(probes.len(), n + 4);
    assert_eq!(r["controls"]["min_probes"], n as u64 + 4);
    assert_eq!(r["controls"]["probes_before_minimum"], n as u64);
    assert_eq!(r["refine"]["probes_before_minimum"], n as u64);
    let coverage = |r: &Value| r["coverage"].as_f64().unwrap();
    assert!(
        coverage(&r) >= coverage(&base_report),
        "{} < {}",
        coverage(&r),
        coverage(&base_report)
    );
    assert!(
        r["warnings"].as_array().unwrap().is_empty(),
        "{}",
        r["warnings"]
    );
    // The added probes stand where the placement may put probes: none in
    // solid, none below the fill tiers' clearance.
    assert_eq!(r["probes_in_solid"], 0);

    let fewer = (n - 1).max(1).to_string();
    let (_o, r, exact) = place_into(
        &overlay(
            "configs/cornell.ron",
            &[("min_probes", &fewer), ("max_probes", &fewer)],
        ),
        &[],
    );
    assert_eq!(exact.len(), (n - 1).max(1));
    assert!(r["controls"]["probes_before_minimum"].is_null());

    let grid = ["--method", "grid:2x2x2", "--no-refine"];
    let (_o, plain, _) = place_into(&overlay("configs/cornell.ron", &[]), &grid);
    let (_o, r, unrefined) = place_into(
        &overlay("configs/cornell.ron", &[("min_probes", "20")]),
        &grid,
    );
    assert_eq!(
        unrefined.len(),
        plain["probe_count"].as_u64().unwrap() as usize
    );
    assert!(r["warnings"]
        .as_array()
        .unwrap()
        .iter()
        .any(|w| w.as_str().unwrap().starts_with("min_probes: not applied")));
}

/// A density of 2 over half the box puts more probes there (every surface
/// sample there wants two views); a density of 0 there leaves it to the
/// other half and fewer probes. The report counts the samples it touched.
/// Density is a demand on coverage, so the runs keep to coverage's
/// objective (the diffuse step moves probes for the light, after it).
#[test]
fn probe_density_adds_probes_where_raised_and_removes_them_where_lowered() {
    let coverage = ("refine", "(objective: Coverage)");
    let (_ob, base_report, base_probes) =
        place_into(&overlay("configs/cornell.ron", &[coverage]), &[]);
    let half = ([-1.0, -1.0, -1.0], [0.278, 2.0, 2.0]);
    let left = |probes: &[Value]| {
        probes
            .iter()
            .filter(|p| inside(position(p), half.0, half.1))
            .count()
    };
    let density = |d: &str| format!("[({}, {d})]", ron_box(half.0, half.1));
    let (_o2, r2, more) = place_into(
        &overlay(
            "configs/cornell.ron",
            &[coverage, ("probe_density", &density("2.0"))],
        ),
        &[],
    );
    assert!(
        left(&more) > left(&base_probes) && more.len() > base_probes.len(),
        "density 2: {} of {} in the half; without: {} of {}",
        left(&more),
        more.len(),
        left(&base_probes),
        base_probes.len()
    );
    assert!(r2["controls"]["samples_with_density"].as_u64().unwrap() > 0);
    let met = r2["controls"]["demand_met"].as_f64().unwrap();
    assert!(met >= target(&r2), "demand met {met}");

    let (_o0, r0, fewer) = place_into(
        &overlay(
            "configs/cornell.ron",
            &[coverage, ("probe_density", &density("0.0"))],
        ),
        &[],
    );
    // No more probes than without it (the box's three probes may all still
    // be needed for the other half).
    assert!(fewer.len() <= base_probes.len(), "{} probes", fewer.len());
    // Its surfaces are no longer asked for: coverage of the whole box drops.
    assert!(r0["coverage"].as_f64().unwrap() < base_report["coverage"].as_f64().unwrap());
}

/// With every control set: byte-identical outputs for the same config and
/// seed, on one thread and on all.
#[test]
fn controls_are_deterministic_whatever_the_thread_count() {
    let config = test_quality(
        "configs/cornell.ron",
        &[
            ("fixed_probes", "[(0.1, 0.45, 0.1)]"),
            (
                "exclude",
                "[Box((min: (0.3, 0.3, 0.3), max: (0.5, 0.5, 0.5)))]",
            ),
            ("max_probes", "5"),
            ("min_probes", "5"),
            (
                "probe_density",
                "[(Box((min: (0, 0, 0), max: (0.278, 0.6, 0.6))), 1.5)]",
            ),
        ],
    );
    let (a, b) = (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
    place(config.path(), a.path(), &[]);
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_probeplace"))
        .args([
            "place",
            config.arg(),
            "--out",
            b.path().to_str().unwrap(),
            "-q",
        ])
        .env("RAYON_NUM_THREADS", "1")
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for name in ["probes.json", "svo.bin", "placement.png", "atlas.png"] {
        assert!(
            std::fs::read(a.path().join(name)).unwrap()
                == std::fs::read(b.path().join(name)).unwrap(),
            "{name} differs between thread counts"
        );
    }
    assert!(probes_of(a.path()).len() <= 5);
}
