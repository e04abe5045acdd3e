//! The hostile-input suite (issue 19): inputs a hostile but realistic user
//! tries. Each must exit 2 with one line naming the cause, print no panic,
//! write nothing, and do so within a wall-clock bound enforced by
//! `timeout(1)`, so that a hang fails the test instead of stalling CI.

use crate::common::*;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

/// Seconds any refusal may take (the bound).
const REFUSAL_SECONDS: u64 = 10;

/// What a refused run printed.
pub struct Refusal {
    /// The one error line.
    pub line: String,
    /// How long the run took.
    pub took: Duration,
}

/// A scratch directory with the minimal inputs: `room.obj` (a closed 2 m
/// cube), `run.ron` (its config, writing to `out/`).
pub struct Scratch {
    pub dir: tempfile::TempDir,
}

impl Scratch {
    pub fn new() -> Scratch {
        let s = Scratch {
            dir: tempfile::tempdir().unwrap(),
        };
        s.write("room.obj", CUBE_ROOM);
        s.config("run.ron", "");
        s
    }

    pub fn path(&self, name: &str) -> PathBuf {
        self.dir.path().join(name)
    }

    pub fn write(&self, name: &str, text: &str) -> PathBuf {
        let p = self.path(name);
        std::fs::write(&p, text).unwrap();
        p
    }

    /// Writes `name`: the room's config with `extra` fields appended (each
    /// ending with a comma).
    pub fn config(&self, name: &str, extra: &str) -> PathBuf {
        self.write(
            name,
            &format!("(\n    scene: \"room.obj\",\n    voxel_size: 0.1,\n    output: \"out\",\n{extra})\n"),
        )
    }

    /// Writes `name` as a config whose `scene` is `scene` (any path).
    pub fn config_for(&self, name: &str, scene: &Path) -> PathBuf {
        self.write(
            name,
            &format!(
                "(\n    scene: \"{}\",\n    voxel_size: 0.1,\n    output: \"out\",\n)\n",
                scene.display()
            ),
        )
    }
}

/// A closed cube room, 2 units on a side.
pub const CUBE_ROOM: &str =
    "v 0 0 0\nv 2 0 0\nv 2 0 2\nv 0 0 2\nv 0 2 0\nv 2 2 0\nv 2 2 2\nv 0 2 2\n\
f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\n";

/// Runs `probeplace ARGS` in `dir` under `timeout`, with the environment's
/// extra `env` pairs, and checks the refusal contract: exit 2 within
/// [`REFUSAL_SECONDS`], no panic, one `error: ` line (besides the stage
/// lines of stages that finished), and `dir/out` absent or empty.
pub fn refused_in(dir: &Path, args: &[&str], env: &[(&str, &str)]) -> Refusal {
    let start = Instant::now();
    let mut cmd = Command::new("timeout");
    cmd.arg("--signal=KILL")
        .arg(REFUSAL_SECONDS.to_string())
        .arg(env!("CARGO_BIN_EXE_probeplace"))
        .args(args)
        .current_dir(dir);
    for (k, v) in env {
        cmd.env(k, v);
    }
    let o = cmd.output().expect("timeout(1) runs");
    let took = start.elapsed();
    let stderr = String::from_utf8_lossy(&o.stderr).into_owned();
    assert!(
        o.status.code().is_some(),
        "killed (a hang past {REFUSAL_SECONDS} s or an abort): {:?} {args:?}; stderr: {stderr}",
        o.status
    );
    assert_eq!(
        o.status.code(),
        Some(2),
        "expected exit 2 for {args:?}; stderr: {stderr}"
    );
    assert!(!stderr.contains("panicked"), "panic: {stderr}");
    let lines: Vec<&str> = stderr
        .trim_end()
        .lines()
        .filter(|l| !(l.starts_with("probeplace: ") && l.contains(" done in ")))
        .collect();
    assert_eq!(lines.len(), 1, "one line expected for {args:?}: {stderr}");
    assert!(lines[0].starts_with("error: "), "{stderr}");
    let out = dir.join("out");
    if out.is_dir() {
        let left: Vec<_> = std::fs::read_dir(&out).unwrap().collect();
        assert!(left.is_empty(), "{args:?} wrote into out/: {left:?}");
    }
    Refusal {
        line: lines[0].to_string(),
        took,
    }
}

/// [`refused_in`] the scratch directory with no extra environment.
pub fn refused(s: &Scratch, args: &[&str]) -> String {
    refused_in(s.dir.path(), args, &[]).line
}

#[test]
fn the_scratch_room_places() {
    // The baseline every case below departs from: it must succeed, or the
    // refusals would prove nothing.
    let s = Scratch::new();
    let o = Command::new(env!("CARGO_BIN_EXE_probeplace"))
        .args(["place", "run.ron", "--quiet"])
        .current_dir(s.dir.path())
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(s.path("out/probes.json").is_file());
    let _ = root();
}

#[test]
fn a_missing_config_is_refused() {
    let s = Scratch::new();
    let e = refused(&s, &["place", "absent.ron"]);
    assert!(e.contains("absent.ron"), "{e}");
    let r = refused_in(s.dir.path(), &["place", "absent.ron"], &[]);
    assert!(r.took < Duration::from_secs(REFUSAL_SECONDS));
    let _ = s.config_for("other.ron", Path::new("room.obj"));
}
