//! Jobs as one pipeline: `--from DIR` reuse, provenance refusals, output
//! sets committed whole (a directory taken by a name, a full disk, SIGKILL
//! at every step of the commit), `--probes`, and the destination checks.

use crate::common::{probeplace, read_json, root, test_quality, Overlay};
use std::collections::BTreeMap;
use std::path::Path;
use std::process::Command;

/// Every file of `dir` by name, with its bytes.
/// Every file of the output directory `dir`, by name, after checking them
/// against its manifest (every commit writes one).
fn files(dir: &Path) -> BTreeMap<String, Vec<u8>> {
    let files = crate::common::dir_files(dir);
    crate::common::assert_manifest_holds(&files);
    files
}

/// A report without what legitimately differs between runs of the same
/// inputs: timings and the list of reused files.
fn steady(v: &serde_json::Value) -> serde_json::Value {
    match v {
        serde_json::Value::Object(m) => m
            .iter()
            .filter(|(k, _)| *k != "timings_ms" && *k != "reused")
            .map(|(k, x)| (k.clone(), steady(x)))
            .collect::<serde_json::Map<_, _>>()
            .into(),
        serde_json::Value::Array(a) => a.iter().map(steady).collect(),
        other => other.clone(),
    }
}

fn ok(args: &[&str]) -> std::process::Output {
    let o = probeplace(args);
    assert!(
        o.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    o
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// Nothing but `out` in `parent`: no staging directory left behind.
fn alone(parent: &Path) {
    let names: Vec<String> = std::fs::read_dir(parent)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n != "cornell.ron")
        .collect();
    assert_eq!(names, ["out"], "left beside the output: {names:?}");
}

/// Our Cornell box at test quality (the jobs' plumbing, not its figures).
fn cornell() -> Overlay {
    test_quality("configs/cornell.ron", &[])
}

#[test]
fn place_then_bake_then_render_from_equals_one_render() {
    let d = tempfile::tempdir().unwrap();
    let (chain, once) = (d.path().join("chain"), d.path().join("once"));
    let quality = cornell();
    let config = quality.path().to_path_buf();
    ok(&["place", s(&config), "--out", s(&chain), "-q"]);
    ok(&["bake", "--from", s(&chain), "-q"]);
    let bake = read_json(&chain.join("report.json"));
    let reused: Vec<&str> = bake["reused"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_str().unwrap())
        .collect();
    assert!(
        reused.contains(&"probes.json") && reused.contains(&"svo.bin"),
        "{reused:?}"
    );
    // The reused stages took no time in this run.
    assert!(
        bake["timings_ms"].get("refine").is_none(),
        "{}",
        bake["timings_ms"]
    );
    ok(&["render", "--from", s(&chain), "--cpu", "-q"]);
    let render = read_json(&chain.join("report.json"));
    assert!(render["reused"]
        .as_array()
        .unwrap()
        .iter()
        .any(|v| v == "lightfield.bin"));
    assert!(
        render["timings_ms"].get("bake").is_none(),
        "{}",
        render["timings_ms"]
    );
    ok(&["render", s(&config), "--cpu", "--out", s(&once), "-q"]);
    let (a, b) = (files(&chain), files(&once));
    assert_eq!(a.keys().collect::<Vec<_>>(), b.keys().collect::<Vec<_>>());
    for (name, bytes) in &a {
        match name.as_str() {
            // The manifest hashes report.json and report.html.
            "report.json" | "manifest.json" => {}
            // Its timings (and the files reused) differ, as report.json's.
            "report.html" => assert!(
                crate::browser::untimed(&String::from_utf8_lossy(bytes))
                    == crate::browser::untimed(&String::from_utf8_lossy(&b[name])),
                "report.html differs between the chain and one run, timings aside"
            ),
            _ => assert!(
                bytes == &b[name],
                "{name} differs between the chain and one run"
            ),
        }
    }
    assert_eq!(
        steady(&render),
        steady(&read_json(&once.join("report.json")))
    );
}

#[test]
fn from_a_run_of_another_seed_or_config_is_refused_in_one_line() {
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("out");
    let config = root().join("configs/cornell.ron");
    ok(&[
        "place",
        s(&config),
        "--out",
        s(&out),
        "--method",
        "grid:2x2x2",
        "--no-refine",
        "-q",
    ]);
    let before = files(&out);
    let o = probeplace(&["bake", "--from", s(&out), "--seed", "77"]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert_eq!(err.trim_end().lines().count(), 1, "{err}");
    assert!(err.contains("seed 1") && err.contains("seed 77"), "{err}");
    let other = root().join("configs/cornell-glossy.ron");
    let o = probeplace(&[
        "bake",
        s(&other),
        "--from",
        s(&out),
        "--method",
        "grid:2x2x2",
        "--no-refine",
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("scene") || err.contains("config"), "{err}");
    assert_eq!(files(&out), before, "a refused run changed the directory");
}

#[test]
fn place_over_an_old_bake_leaves_none_of_its_files() {
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("out");
    let quality = cornell();
    let config = quality.path().to_path_buf();
    ok(&[
        "bake",
        s(&config),
        "--out",
        s(&out),
        "--method",
        "grid:2x2x2",
        "--no-refine",
        "-q",
    ]);
    assert!(out.join("lightfield.bin").is_file() && out.join("reference.exr").is_file());
    ok(&[
        "place",
        s(&config),
        "--out",
        s(&out),
        "--method",
        "grid:3x3x3",
        "--no-refine",
        "-q",
    ]);
    let names: Vec<String> = files(&out).into_keys().collect();
    assert_eq!(
        names,
        [
            "manifest.json",
            "placement.png",
            "probes.json",
            "report.html",
            "report.json",
            "svo.bin"
        ]
    );
    alone(d.path());
    ok(&["inspect", s(&out), "-q"]);
}

/// A complete earlier output in `parent/out` and the command of a later,
/// different run into it.
fn earlier_and_later(parent: &Path) -> (BTreeMap<String, Vec<u8>>, Vec<String>) {
    let out = parent.join("out");
    let config = parent.join("cornell.ron");
    std::fs::copy(cornell().path(), &config).unwrap();
    ok(&[
        "place",
        s(&config),
        "--out",
        s(&out),
        "--method",
        "grid:2x2x2",
        "--no-refine",
        "-q",
    ]);
    let later = [
        "place",
        s(&config),
        "--out",
        s(&out),
        "--method",
        "grid:3x2x3",
        "--no-refine",
        "-q",
    ];
    (files(&out), later.iter().map(|a| a.to_string()).collect())
}

#[test]
fn an_output_name_taken_by_a_directory_leaves_the_earlier_output_whole() {
    let d = tempfile::tempdir().unwrap();
    let (before, later) = earlier_and_later(d.path());
    let o = Command::new(env!("CARGO_BIN_EXE_probeplace"))
        .args(&later)
        .env("PROBEPLACE_TEST_DIR_AT", "report.json")
        .output()
        .unwrap();
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("report.json"), "{err}");
    assert_eq!(files(&d.path().join("out")), before);
    alone(d.path());
}

#[test]
fn a_full_disk_leaves_the_earlier_output_whole() {
    // A private mount namespace with a 2 MiB tmpfs: the earlier output fits,
    // the filler takes the rest, the later run cannot stage its files.
    let d = tempfile::tempdir().unwrap();
    let script = String::from(
        r#"set -e
mount -t tmpfs -o size=2m tmpfs "$1"
"$2" place "$3" --out "$1/out" --method grid:2x2x2 --no-refine -q
cp -r "$1/out" "$1/../before"
dd if=/dev/zero of="$1/filler" bs=64k 2>/dev/null || true
if "$2" place "$3" --out "$1/out" --method grid:4x4x4 --no-refine -q 2>"$1/../stderr"; then echo SUCCEEDED; exit 1; fi
diff -r "$1/out" "$1/../before"
rm "$1/filler"
ls -A "$1"
"#,
    );
    let mnt = d.path().join("mnt");
    std::fs::create_dir(&mnt).unwrap();
    let o = Command::new("unshare")
        .args([
            "-m",
            "sh",
            "-c",
            &script,
            "sh",
            s(&mnt),
            env!("CARGO_BIN_EXE_probeplace"),
        ])
        .arg(root().join("configs/cornell.ron"))
        .output()
        .expect("unshare runs (util-linux)");
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(
        o.status.success(),
        "stdout: {stdout}\nstderr: {}\nprobeplace: {}",
        String::from_utf8_lossy(&o.stderr),
        std::fs::read_to_string(d.path().join("stderr")).unwrap_or_default()
    );
    assert_eq!(
        stdout.trim(),
        "out",
        "the tmpfs after the failed run holds only the old output"
    );
    let err = std::fs::read_to_string(d.path().join("stderr")).unwrap();
    assert!(err.starts_with("error: "), "{err}");
}

#[test]
fn a_kill_at_any_step_of_the_commit_leaves_the_old_set_or_the_new() {
    let d = tempfile::tempdir().unwrap();
    let (old, later) = earlier_and_later(d.path());
    let fresh = tempfile::tempdir().unwrap();
    let mut fresh_args = later.clone();
    fresh_args[3] = fresh.path().join("out").to_str().unwrap().to_string();
    ok(&fresh_args.iter().map(String::as_str).collect::<Vec<_>>());
    let new = files(&fresh.path().join("out"));
    let steady_files = |f: &BTreeMap<String, Vec<u8>>| {
        f.iter()
            .map(|(k, v)| {
                // The manifest hashes the timed reports: its names and the
                // hashes of the untimed files are what stays.
                let v = if k == "manifest.json" {
                    let m: serde_json::Value = serde_json::from_slice(v).unwrap();
                    let files = m["files"].as_object().unwrap();
                    let kept: Vec<(String, serde_json::Value)> = files
                        .iter()
                        .map(
                            |(n, e)| match n.ends_with(".json") || n.ends_with(".html") {
                                true => (n.clone(), serde_json::Value::Null),
                                false => (n.clone(), e.clone()),
                            },
                        )
                        .collect();
                    serde_json::to_vec(&kept).unwrap()
                } else if k.ends_with(".json") {
                    serde_json::to_vec(&steady(&serde_json::from_slice(v).unwrap())).unwrap()
                } else if k.ends_with(".html") {
                    crate::browser::untimed(&String::from_utf8_lossy(v)).into_bytes()
                } else {
                    v.clone()
                };
                (k.clone(), v)
            })
            .collect::<BTreeMap<_, _>>()
    };
    let (old_s, new_s) = (steady_files(&old), steady_files(&new));
    let steps = (1..=new.len() + 1).chain([1000, 1001]);
    let mut saw = (0, 0);
    for step in steps {
        let o = Command::new(env!("CARGO_BIN_EXE_probeplace"))
            .args(&later)
            .env("PROBEPLACE_TEST_KILL_AT", step.to_string())
            .output()
            .unwrap();
        assert!(!o.status.success(), "step {step}: the kill did not happen");
        let now = steady_files(&files(&d.path().join("out")));
        if now == old_s {
            saw.0 += 1;
        } else if now == new_s {
            saw.1 += 1;
        } else {
            panic!(
                "step {step}: a mix of the old and the new set: {:?}",
                now.keys()
            );
        }
        // Put the old set back for the next step.
        if now != old_s {
            std::fs::remove_dir_all(d.path().join("out")).unwrap();
            std::fs::create_dir(d.path().join("out")).unwrap();
            for (k, v) in &old {
                std::fs::write(d.path().join("out").join(k), v).unwrap();
            }
        }
    }
    assert!(
        saw.0 > 0 && saw.1 > 0,
        "old {} times, new {} times",
        saw.0,
        saw.1
    );
    // The next run sweeps what the killed ones left.
    ok(&later.iter().map(String::as_str).collect::<Vec<_>>());
    alone(d.path());
}

#[test]
fn probes_from_a_file_are_scored_and_read_back_exactly() {
    let d = tempfile::tempdir().unwrap();
    let (first, again) = (d.path().join("first"), d.path().join("again"));
    let quality = cornell();
    let config = quality.path().to_path_buf();
    ok(&["place", s(&config), "--out", s(&first), "-q"]);
    ok(&[
        "place",
        s(&config),
        "--out",
        s(&again),
        "--probes",
        s(&first.join("probes.json")),
        "-q",
    ]);
    let (a, b) = (
        read_json(&first.join("probes.json")),
        read_json(&again.join("probes.json")),
    );
    let positions = |v: &serde_json::Value| -> Vec<serde_json::Value> {
        v["probes"]
            .as_array()
            .unwrap()
            .iter()
            .map(|p| p["position"].clone())
            .collect()
    };
    assert_eq!(
        positions(&a),
        positions(&b),
        "probes.json does not round-trip"
    );
    let r = read_json(&again.join("report.json"));
    assert_eq!(r["method"], "file");
    assert!(
        r["refine"].is_null(),
        "a given probe set is scored, not refined"
    );
    assert_eq!(
        r["coverage"],
        read_json(&first.join("report.json"))["coverage"]
    );
    // A hand-made list of points, with a mistake in it.
    let hand = d.path().join("hand.json");
    std::fs::write(&hand, "[[0, 1, 0], [0.2, 1.2]]").unwrap();
    let o = probeplace(&[
        "place",
        s(&config),
        "--out",
        s(&d.path().join("h")),
        "--probes",
        s(&hand),
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("hand.json") && err.contains("probe 1"),
        "{err}"
    );
}

#[test]
fn inputs_in_the_output_and_foreign_directories_are_refused() {
    let d = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(root().join("configs/cornell.ron")).unwrap();
    let scene = root().join("fixtures/cornell_box.obj");
    assert!(scene.is_file(), "{}", scene.display());
    let text = text
        .lines()
        .map(|l| match l.trim_start().starts_with("scene:") {
            true => format!("    scene: {:?},", scene.to_str().unwrap()),
            false => l.to_string(),
        })
        .collect::<Vec<_>>()
        .join("\n");
    let cfg = d.path().join("run.ron");
    std::fs::write(&cfg, text).unwrap();
    let o = probeplace(&["place", s(&cfg), "--out", s(d.path())]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("run.ron") && err.contains("output directory"),
        "{err}"
    );
    assert!(cfg.is_file());
    let photos = d.path().join("photos");
    std::fs::create_dir(&photos).unwrap();
    std::fs::write(photos.join("holiday.jpg"), b"x").unwrap();
    let o = probeplace(&["place", s(&cfg), "--out", s(&photos)]);
    assert_eq!(o.status.code(), Some(2));
    assert!(photos.join("holiday.jpg").is_file());
}

#[test]
fn compare_from_a_bake_reuses_it_and_scores_given_probes_beside_ours() {
    let d = tempfile::tempdir().unwrap();
    let (baked, from, given) = (
        d.path().join("baked"),
        d.path().join("from"),
        d.path().join("given"),
    );
    let quality = cornell();
    let config = quality.path().to_path_buf();
    ok(&["bake", s(&config), "--out", s(&baked), "-q"]);
    ok(&[
        "compare",
        "--from",
        s(&baked),
        "--cpu",
        "--out",
        s(&from),
        "-q",
    ]);
    let probes = baked.join("probes.json");
    ok(&[
        "compare",
        s(&config),
        "--cpu",
        "--out",
        s(&given),
        "--probes",
        s(&probes),
        "-q",
    ]);
    let (a, b) = (
        read_json(&from.join("compare.json")),
        read_json(&given.join("compare.json")),
    );
    let reused = a["reused"].as_array().unwrap();
    for f in ["probes.json", "lightfield.bin", "reference.exr"] {
        assert!(reused.iter().any(|r| r == f), "{f} not reused: {reused:?}");
    }
    // Reusing changes no figure: every row of the reusing run is the fresh
    // run's row of the same name.
    let rows = |v: &serde_json::Value| -> BTreeMap<String, serde_json::Value> {
        v["placements"]
            .as_array()
            .unwrap()
            .iter()
            .map(|p| (p["name"].as_str().unwrap().to_string(), steady(p)))
            .collect()
    };
    let (ra, rb) = (rows(&a), rows(&b));
    for (name, row) in &ra {
        assert_eq!(Some(row), rb.get(name), "{name}");
    }
    // The given probes are the baked run's refined sdf-skeleton: scored as
    // given, they cover what that row covers.
    let file = &rb["file"];
    assert_eq!(file["family"], "given");
    assert_eq!(file["probes"], rb["sdf-skeleton"]["probes"]);
    assert_eq!(file["coverage"], rb["sdf-skeleton"]["coverage"]);
    assert_eq!(file["mse_glossy"], rb["sdf-skeleton"]["mse_glossy"]);
}
