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

// Scene and material files.

fn mkfifo(path: &Path) {
    let c = std::ffi::CString::new(path.to_str().unwrap()).unwrap();
    // SAFETY: a valid NUL-terminated path.
    assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o600) }, 0);
}

#[test]
fn a_scene_that_is_not_a_regular_file_says_what_it_is() {
    let s = Scratch::new();
    std::fs::create_dir(s.path("dir.obj")).unwrap();
    mkfifo(&s.path("pipe.obj"));
    for (scene, kind) in [
        ("dir.obj", "is a directory"),
        ("pipe.obj", "is a FIFO"),
        ("/dev/zero", "is a device"),
    ] {
        s.config_for("bad.ron", Path::new(scene));
        let e = refused(&s, &["place", "bad.ron"]);
        assert!(e.contains(scene) && e.contains(kind), "{scene}: {e}");
    }
}

#[test]
fn a_material_library_that_is_a_fifo_or_a_device_is_refused() {
    let s = Scratch::new();
    mkfifo(&s.path("pipe.mtl"));
    std::os::unix::fs::symlink("/dev/zero", s.path("zero.mtl")).unwrap();
    for (lib, kind) in [("pipe.mtl", "is a FIFO"), ("zero.mtl", "is a device")] {
        s.write("lib.obj", &format!("mtllib {lib}\n{CUBE_ROOM}"));
        s.config_for("lib.ron", Path::new("lib.obj"));
        let e = refused(&s, &["place", "lib.ron"]);
        assert!(e.contains(lib) && e.contains(kind), "{lib}: {e}");
    }
}

#[test]
fn a_huge_binary_scene_is_refused_at_once() {
    let s = Scratch::new();
    // A sparse 2 GiB file of NUL bytes: nothing of it may be read whole.
    let f = std::fs::File::create(s.path("nul.obj")).unwrap();
    f.set_len(2 << 30).unwrap();
    s.config_for("nul.ron", Path::new("nul.obj"));
    let r = refused_in(s.dir.path(), &["place", "nul.ron"], &[]);
    assert!(r.line.contains("nul.obj:1: binary data"), "{}", r.line);
    assert!(r.took < Duration::from_secs(5), "{:?}", r.took);
}

#[test]
fn obj_mistakes_name_their_line() {
    let s = Scratch::new();
    s.write("bad.obj", &format!("{CUBE_ROOM}f 1 2 99\n"));
    s.config_for("bad.ron", Path::new("bad.obj"));
    let e = refused(&s, &["place", "bad.ron"]);
    assert!(e.contains("bad.obj:15: face vertex index 99"), "{e}");
}

#[test]
fn a_polygon_of_200000_vertices_is_refused_quickly() {
    let s = Scratch::new();
    let n = 200_000;
    let mut text = String::new();
    for i in 0..n {
        let a = i as f64 / n as f64 * std::f64::consts::TAU;
        text.push_str(&format!("v {} {} 0\n", a.cos(), a.sin()));
    }
    text.push('f');
    for i in 1..=n {
        text.push_str(&format!(" {i}"));
    }
    text.push('\n');
    s.write("poly.obj", &text);
    s.config_for("poly.ron", Path::new("poly.obj"));
    let e = refused(&s, &["place", "poly.ron"]);
    assert!(
        e.contains("poly.obj:200001: a face of more than 65536 vertices"),
        "{e}"
    );
}

#[test]
fn out_of_range_material_values_are_clamped_with_a_warning() {
    let s = Scratch::new();
    s.write(
        "m.mtl",
        "newmtl hot\nKe inf 1 1\nKd NaN 0.5 0.5\nNs -5\nnewmtl bright\nKd 5 5 5\n",
    );
    s.write("m.obj", &format!("mtllib m.mtl\nusemtl hot\n{CUBE_ROOM}"));
    s.config_for("m.ron", Path::new("m.obj"));
    let o = Command::new(env!("CARGO_BIN_EXE_probeplace"))
        .args(["place", "m.ron", "--quiet"])
        .current_dir(s.dir.path())
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let report = read_json(&s.path("out/report.json"));
    let warnings = report["warnings"].to_string();
    for expected in [
        "m.mtl:2: material `hot`: Ke",
        "m.mtl:3: material `hot`: Kd",
        "m.mtl:4: material `hot`: Ns -5",
        "m.mtl:6: material `bright`: Kd",
    ] {
        assert!(warnings.contains(expected), "{expected}: {warnings}");
    }
}

// Limits: estimated before the work they bound.

#[test]
fn work_that_would_take_hours_is_refused_naming_its_field() {
    let s = Scratch::new();
    let cases: [(&str, &[&str], &str); 6] = [
        (
            "coverage: (samples: 5000000, reference_points: 1000000),\n",
            &[],
            "coverage.samples",
        ),
        ("", &["--method", "greedy:1e-9"], "placement.spacing: greedy:1e-9 is below"),
        ("", &["--method", "greedy:1e-300"], "spacing"),
        (
            "placement: Grid((cells: (1024, 1024, 1))),\n",
            &["--no-refine"],
            "exceeds the limit of 65536",
        ),
        (
            "bake: (resolution: 2048, samples: 65536),\n",
            &["--method", "grid:2x2x2"],
            "bake.samples: the bake of 8 probes",
        ),
        (
            "reference: (camera: (position: (1, 1, 0.5), look_at: (1, 1, 1.5)), width: 8192, height: 8192, samples_per_pixel: 1000000),\n",
            &["--method", "grid:2x2x2"],
            "reference.samples_per_pixel",
        ),
    ];
    for (extra, flags, field) in cases {
        s.config("lim.ron", extra);
        let command = if extra.starts_with("bake") || extra.starts_with("reference") {
            "bake"
        } else {
            "place"
        };
        let mut args = vec![command, "lim.ron"];
        args.extend_from_slice(flags);
        let e = refused(&s, &args);
        assert!(e.contains(field), "{args:?}: {e}");
    }
}

#[test]
fn a_bake_beyond_the_memory_budget_is_refused_before_it_allocates() {
    let s = Scratch::new();
    s.config("mem.ron", "bake: (resolution: 1024),\n");
    // A 1 GiB budget: 64 probes at 1024² maps need about 3 GiB.
    let r = refused_in(
        s.dir.path(),
        &["bake", "mem.ron", "--method", "grid:4x4x4", "--no-refine"],
        &[("PROBEPLACE_MEMORY", "1G")],
    );
    assert!(
        r.line.contains("bake.resolution") && r.line.contains("PROBEPLACE_MEMORY"),
        "{}",
        r.line
    );
}

#[test]
fn no_command_aborts_under_a_4_gb_address_space_limit() {
    // `ulimit -v 4000000`: allocations past it fail; the budget reads the
    // limit, so a config asking for more is refused, never aborted.
    let s = Scratch::new();
    s.config("big.ron", "bake: (resolution: 512),\n");
    let bin = env!("CARGO_BIN_EXE_probeplace");
    let o = Command::new("timeout")
        .args(["--signal=KILL", "60", "sh", "-c"])
        .arg(format!(
            "ulimit -v 4000000 && exec {bin} bake big.ron --method grid:8x8x8 --no-refine"
        ))
        .current_dir(s.dir.path())
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("bake.resolution"), "{stderr}");
    assert!(
        !stderr.contains("panicked") && !stderr.contains("memory allocation"),
        "{stderr}"
    );
}
