//! The hostile suite's output directories (issue 70): a run never deletes
//! a file it did not write, two runs into one directory are never mixed,
//! and what a run reuses from an earlier one is checked again when it is
//! linked into the new set. The interleavings are made deterministic by
//! the commit's test hook `PROBEPLACE_TEST_HOLD_COMMIT=PATH`: the run
//! writes `PATH.held` once it has claimed its directory and computed its
//! files, and waits for `PATH` before committing.

use crate::common::*;
use crate::hostile::{baked, snapshot, stderr_of, Scratch};
use std::path::{Path, PathBuf};
use std::process::{Child, Command};
use std::time::{Duration, Instant};

/// A run of `args` in the scratch directory, held before its commit until
/// [`Held::release`].
struct Held {
    child: Child,
    go: PathBuf,
}

impl Held {
    /// Starts `probeplace ARGS` and waits until it is held.
    fn start(s: &Scratch, args: &[&str]) -> Held {
        let go = s.path("go");
        let _ = std::fs::remove_file(&go);
        let held = s.path("go.held");
        let _ = std::fs::remove_file(&held);
        let child = Command::new(env!("CARGO_BIN_EXE_probeplace"))
            .args(args)
            .env("PROBEPLACE_TEST_HOLD_COMMIT", &go)
            .current_dir(s.dir.path())
            .stderr(std::process::Stdio::piped())
            .spawn()
            .unwrap();
        let start = Instant::now();
        let mut child = child;
        while !held.exists() {
            if let Ok(Some(status)) = child.try_wait() {
                let mut err = String::new();
                std::io::Read::read_to_string(child.stderr.as_mut().unwrap(), &mut err).unwrap();
                panic!("{args:?} ended before its commit ({status}): {err}");
            }
            assert!(
                start.elapsed() < Duration::from_secs(60),
                "{args:?} never reached its commit"
            );
            std::thread::sleep(Duration::from_millis(10));
        }
        Held { child, go }
    }

    /// Lets the run commit; its exit status and stderr.
    fn release(self) -> (Option<i32>, String) {
        std::fs::write(&self.go, b"").unwrap();
        let o = self.child.wait_with_output().unwrap();
        (
            o.status.code(),
            String::from_utf8_lossy(&o.stderr).into_owned(),
        )
    }
}

/// The seed of every JSON file of `dir` that records one, by name.
fn seeds(dir: &Path) -> Vec<(String, serde_json::Value)> {
    ["report.json", "probes.json", "manifest.json"]
        .iter()
        .map(|n| {
            let v: serde_json::Value =
                serde_json::from_slice(&std::fs::read(dir.join(n)).unwrap()).unwrap();
            (n.to_string(), v["provenance"]["seed"].clone())
        })
        .collect()
}

#[test]
fn a_users_file_beside_outputs_without_a_readable_manifest_is_never_deleted() {
    let s = Scratch::new();
    let (code, err) = stderr_of(&s, &["place", "run.ron", "--quiet", "--out", "D"]);
    assert_eq!(code, Some(0), "{err}");
    let out = s.path("D");
    let manifest = std::fs::read(out.join("manifest.json")).unwrap();
    let other_version = String::from_utf8(manifest.clone()).unwrap().replacen(
        "\"version\": 1",
        "\"version\": 7",
        1,
    );
    assert_ne!(other_version.as_bytes(), &manifest[..]);
    std::fs::write(out.join("notes.txt"), b"the user's").unwrap();
    // Written by an older probeplace (none), deleted, cut short, of
    // another version: the manifest cannot say which files are the run's.
    let cases: [(&str, Option<Vec<u8>>); 4] = [
        ("missing", None),
        ("truncated", Some(manifest[..manifest.len() / 2].to_vec())),
        ("another version", Some(other_version.into_bytes())),
        ("not JSON", Some(b"\x00\x01".to_vec())),
    ];
    for (case, bytes) in cases {
        match &bytes {
            Some(b) => std::fs::write(out.join("manifest.json"), b).unwrap(),
            None => {
                let _ = std::fs::remove_file(out.join("manifest.json"));
            }
        }
        let before = snapshot(&out);
        let r = refused_in(
            s.dir.path(),
            &["place", "run.ron", "--quiet", "--seed", "2", "--out", "D"],
            &[],
        );
        assert!(
            r.line.contains("notes.txt") && r.line.contains("not a file probeplace writes"),
            "{case}: {}",
            r.line
        );
        assert_eq!(snapshot(&out), before, "{case}: the directory changed");
    }
    // Merely a directory of the tool's own files, manifest or not: the run
    // replaces it.
    std::fs::remove_file(out.join("notes.txt")).unwrap();
    std::fs::remove_file(out.join("manifest.json")).unwrap();
    let (code, err) = stderr_of(
        &s,
        &["place", "run.ron", "--quiet", "--seed", "2", "--out", "D"],
    );
    assert_eq!(code, Some(0), "{err}");
    assert!(out.join("manifest.json").is_file());
    // A directory under a name the tool writes is the user's too.
    std::fs::remove_file(out.join("manifest.json")).unwrap();
    std::fs::remove_file(out.join("atlas.png")).ok();
    std::fs::create_dir(out.join("atlas.png")).unwrap();
    std::fs::write(out.join("atlas.png/kept"), b"x").unwrap();
    let r = refused_in(
        s.dir.path(),
        &["place", "run.ron", "--quiet", "--out", "D"],
        &[],
    );
    assert!(r.line.contains("atlas.png"), "{}", r.line);
    assert!(out.join("atlas.png/kept").is_file());
}

#[test]
fn a_run_into_a_directory_another_run_is_writing_is_refused_not_mixed() {
    let s = Scratch::new();
    baked(&s, "D", &[]);
    // `bake --from D` writes into D; while it runs, `place --out D`.
    let bake = Held::start(&s, &["bake", "--from", "D", "--quiet"]);
    let before = snapshot(&s.path("D"));
    let r = refused_in(
        s.dir.path(),
        &["place", "run.ron", "--quiet", "--seed", "2", "--out", "D"],
        &[],
    );
    assert!(
        r.line.contains("is writing this output directory") && r.line.starts_with("error: D:"),
        "{}",
        r.line
    );
    assert_eq!(snapshot(&s.path("D")), before);
    let (code, err) = bake.release();
    assert_eq!(code, Some(0), "{err}");
    // One run's set, whole; the lock is gone with the run.
    let seeds = seeds(&s.path("D"));
    assert!(seeds.iter().all(|(_, v)| *v == seeds[0].1), "{seeds:?}");
    let (code, err) = stderr_of(&s, &["inspect", "D", "--quiet"]);
    assert_eq!(code, Some(0), "{err}");
    assert!(!s.path(".D.probeplace.lock").exists());
    let (code, err) = stderr_of(
        &s,
        &["place", "run.ron", "--quiet", "--seed", "2", "--out", "D"],
    );
    assert_eq!(code, Some(0), "{err}");
}

#[test]
fn a_reused_file_replaced_or_edited_before_the_commit_refuses_the_run() {
    let s = Scratch::new();
    let (code, err) = stderr_of(&s, &["place", "run.ron", "--quiet", "--out", "D"]);
    assert_eq!(code, Some(0), "{err}");
    // Replaced whole: another run commits into D while a bake reads it.
    let bake = Held::start(&s, &["bake", "--from", "D", "--out", "O", "--quiet"]);
    let (code, err) = stderr_of(
        &s,
        &["place", "run.ron", "--quiet", "--seed", "2", "--out", "D"],
    );
    assert_eq!(code, Some(0), "{err}");
    let (code, err) = bake.release();
    assert_eq!(code, Some(2), "{err}");
    assert!(
        err.contains("probes.json") && err.contains("changed since this run checked it"),
        "{err}"
    );
    assert_eq!(err.trim_end().lines().count(), 1, "{err}");
    assert!(!s.path("O").exists(), "a refused run wrote O");
    // Edited in place (the same file, other contents): a probe moved 5 cm.
    let bake = Held::start(&s, &["bake", "--from", "D", "--out", "O", "--quiet"]);
    let probes = s.path("D/probes.json");
    let text = std::fs::read_to_string(&probes).unwrap();
    let mut v: serde_json::Value = serde_json::from_str(&text).unwrap();
    let x = v["probes"][0]["position"][0].as_f64().unwrap();
    v["probes"][0]["position"][0] = (x + 0.05).into();
    std::fs::write(&probes, serde_json::to_vec_pretty(&v).unwrap()).unwrap();
    let (code, err) = bake.release();
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("probes.json"), "{err}");
    assert!(!s.path("O").exists(), "a refused run wrote O");
}

#[test]
fn an_export_whose_run_is_replaced_before_its_commit_is_refused() {
    let s = Scratch::new();
    baked(&s, "D", &[]);
    let export = Held::start(
        &s,
        &["export", "D", "--format", "glb", "--out", "E", "--quiet"],
    );
    baked(&s, "D", &["--seed", "2"]);
    let (code, err) = export.release();
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("changed since this run checked it"), "{err}");
    assert!(!s.path("E").exists());
}
