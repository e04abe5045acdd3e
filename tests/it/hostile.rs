//! The hostile-input suite (issue 19): inputs a hostile but realistic user
//! tries. Each must exit 2 with one line naming the cause, print no panic,
//! write nothing, and do so within a wall-clock bound enforced by
//! `timeout(1)`, so that a hang fails the test instead of stalling CI.

use crate::common::*;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Duration;

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
            "bake: (resolution: 1024, samples: 65536),\n",
            &["--method", "grid:2x2x2"],
            "bake.samples: the bake of 8 probes",
        ),
        (
            "reference: (camera: (position: (1, 1, 0.5), look_at: (1, 1, 1.5)), width: 2048, height: 2048, samples_per_pixel: 1000000),\n",
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

// Config and command line.

/// Runs `probeplace ARGS` in the scratch directory; its exit status and
/// stderr, for the checks [`refused`] does not make (no stage ran).
pub fn stderr_of(s: &Scratch, args: &[&str]) -> (Option<i32>, String) {
    let o = Command::new(env!("CARGO_BIN_EXE_probeplace"))
        .args(args)
        .current_dir(s.dir.path())
        .output()
        .unwrap();
    (
        o.status.code(),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

/// The column (1-based) of `needle` on line `line` of the scratch file `name`.
fn column(s: &Scratch, name: &str, line: usize, needle: &str) -> usize {
    let text = std::fs::read_to_string(s.path(name)).unwrap();
    let l = text.lines().nth(line - 1).unwrap();
    l.find(needle).expect(needle) + 1
}

#[test]
fn a_misspelt_light_field_is_refused_with_its_path_and_position() {
    let s = Scratch::new();
    s.config(
        "run.ron",
        "    lights: [Sky(radiance: (1, 1, 1)), Spot(position: (1, 1, 1), direction: (0, -1, 0), intensity: (1, 1, 1), cone_degrees: 30, edge_degree: 20)],\n",
    );
    let e = refused(&s, &["place", "run.ron"]);
    assert!(e.starts_with("error: run.ron:5:"), "{e}");
    assert!(e.contains("lights[1].Spot.edge_degree:"), "{e}");
    assert!(e.contains("`edge_degrees`"), "the fields it could be: {e}");
}

#[test]
fn a_config_with_a_byte_order_mark_runs_and_counts_columns_after_it() {
    let s = Scratch::new();
    let text = std::fs::read_to_string(s.path("run.ron")).unwrap();
    s.write("run.ron", &format!("\u{feff}{text}"));
    let (code, stderr) = stderr_of(&s, &["place", "run.ron", "--quiet"]);
    assert_eq!(code, Some(0), "{stderr}");
    assert!(s.path("out/probes.json").is_file());
    std::fs::remove_dir_all(s.path("out")).unwrap();
    // Columns count as an editor shows the line, the mark unseen.
    let bad = "(scene: \"room.obj\", voxel_size: -1)\n";
    s.write("bad.ron", &format!("\u{feff}{bad}"));
    s.write("plain.ron", bad);
    let e = refused(&s, &["place", "bad.ron"]);
    let plain = refused(&s, &["place", "plain.ron"]);
    assert!(
        e.starts_with("error: bad.ron:1:3") && e.contains(": voxel_size: "),
        "{e}"
    );
    assert_eq!(e.replace("bad.ron", "plain.ron"), plain);
}

#[test]
fn huge_and_tiny_numbers_are_echoed_in_short_form() {
    let s = Scratch::new();
    for (value, shown) in [("1e300", "got 1e300"), ("1e-300", "got 1e-300")] {
        s.write(
            "n.ron",
            &format!("(\n    scene: \"room.obj\",\n    voxel_size: {value},\n)\n"),
        );
        let e = refused(&s, &["place", "n.ron"]);
        assert!(
            e.starts_with("error: n.ron:3:") && e.ends_with(shown),
            "{e}"
        );
        assert!(e.len() < 160, "{e}");
    }
    let e = refused(&s, &["place", "run.ron", "--method", "greedy:1e300"]);
    assert!(e.ends_with("got 1e300"), "{e}");
}

#[test]
fn a_stage_error_names_the_line_and_column_of_its_field() {
    let s = Scratch::new();
    s.config(
        "run.ron",
        "    placement: SdfSkeleton((\n        min_distance: 5,\n    )),\n",
    );
    let e = refused(&s, &["place", "run.ron"]);
    let col = column(&s, "run.ron", 6, "min_distance");
    assert!(
        e.starts_with(&format!(
            "error: run.ron:6:{col}: placement.min_distance: 5 culls every free voxel"
        )),
        "{e}"
    );
    // The same placement from the command line is the file's: same line.
    let again = refused(&s, &["place", "run.ron", "--method", "sdf-skeleton"]);
    assert_eq!(again, e);
    // A field left at its default has no line to point at.
    let e = refused(&s, &["render", "run.ron"]);
    assert!(e.starts_with("error: run.ron: reference.camera: "), "{e}");
}

#[test]
fn an_empty_output_is_refused_where_it_is_written() {
    let s = Scratch::new();
    s.write(
        "run.ron",
        "(\n    scene: \"room.obj\",\n    voxel_size: 0.1,\n    output: \"\",\n)\n",
    );
    let e = refused(&s, &["place", "run.ron"]);
    assert!(e.starts_with("error: run.ron:4:1"), "{e}");
    assert!(e.ends_with(": output: must not be empty"), "{e}");
}

#[test]
fn an_output_below_a_file_is_refused_before_any_stage() {
    let s = Scratch::new();
    s.write("notes.txt", "mine\n");
    for args in [
        &["place", "run.ron", "--out", "notes.txt/sub"][..],
        &["place", "run.ron", "--out", "notes.txt/a/b"][..],
    ] {
        let e = refused(&s, args);
        assert!(
            e.starts_with("error: notes.txt: is not a directory, so the output directory"),
            "{e}"
        );
        let (_, stderr) = stderr_of(&s, args);
        assert_eq!(stderr.lines().count(), 1, "a stage ran: {stderr}");
    }
    s.write(
        "below.ron",
        "(\n    scene: \"room.obj\",\n    output: \"notes.txt/run\",\n)\n",
    );
    let (code, stderr) = stderr_of(&s, &["place", "below.ron"]);
    assert_eq!(code, Some(2), "{stderr}");
    assert!(
        stderr.starts_with("error: notes.txt: is not a directory") && stderr.lines().count() == 1,
        "{stderr}"
    );
    assert_eq!(
        std::fs::read_to_string(s.path("notes.txt")).unwrap(),
        "mine\n"
    );
}

#[test]
fn a_placement_left_without_probes_is_refused_before_the_svo() {
    let s = Scratch::new();
    // A floor alone: its bounding box, the domain, is flat.
    s.write(
        "flat.obj",
        "v 0 0 0\nv 2 0 0\nv 2 0 2\nv 0 0 2\nf 1 2 3 4\n",
    );
    s.write(
        "flat.ron",
        "(\n    scene: \"flat.obj\",\n    voxel_size: 0.1,\n    placement: Grid((cells: (2, 2, 2))),\n)\n",
    );
    let e = refused(&s, &["place", "flat.ron"]);
    assert!(e.starts_with("error: flat.ron: domain: "), "{e}");
    assert!(e.contains("none of the placement's 8 probes"), "{e}");
    let (_, stderr) = stderr_of(&s, &["place", "flat.ron"]);
    assert!(!stderr.contains("svo done"), "the SVO was built: {stderr}");
    // A coverage target of 0 needs no probe at all.
    s.config("zero.ron", "    refine: (coverage_target: 0),\n");
    let e = refused(&s, &["place", "zero.ron"]);
    let col = column(&s, "zero.ron", 5, "coverage_target");
    assert!(
        e.starts_with(&format!(
            "error: zero.ron:5:{col}: refine.coverage_target: 0 needs no probe"
        )),
        "{e}"
    );
}

#[test]
fn inspect_names_a_file_missing_from_an_output_directory() {
    let s = Scratch::new();
    let (code, stderr) = stderr_of(&s, &["place", "run.ron", "--quiet", "--out", "run"]);
    assert_eq!(code, Some(0), "{stderr}");
    let (code, stderr) = stderr_of(&s, &["inspect", "run", "--quiet"]);
    assert_eq!(code, Some(0), "the whole run inspects: {stderr}");
    std::fs::rename(s.path("run/probes.json"), s.path("probes.json")).unwrap();
    for target in ["run", "run/svo.bin"] {
        let e = refused(&s, &["inspect", target]);
        assert!(
            e.starts_with("error: run/probes.json: missing, though run/svo.bin is there"),
            "{target}: {e}"
        );
    }
    // An svo.bin on its own is checked alone, and says so.
    std::fs::create_dir(s.path("lone")).unwrap();
    std::fs::copy(s.path("run/svo.bin"), s.path("lone/svo.bin")).unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_probeplace"))
        .args(["inspect", "lone/svo.bin"])
        .current_dir(s.dir.path())
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(String::from_utf8_lossy(&o.stdout).contains("checked alone"));
    // A directory is an output directory: a lone svo.bin in it is not a run.
    let e = refused(&s, &["inspect", "lone"]);
    assert!(e.starts_with("error: lone/report.json: missing"), "{e}");
}

#[test]
fn no_arguments_print_the_usage_to_stderr_and_exit_2() {
    let s = Scratch::new();
    let o = Command::new(env!("CARGO_BIN_EXE_probeplace"))
        .current_dir(s.dir.path())
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert!(o.stdout.is_empty());
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(
        stderr.contains("Usage: probeplace") && stderr.contains("place"),
        "{stderr}"
    );
}

// More of the sweep: nesting, light counts, probe files.

#[test]
fn deeply_nested_inputs_are_refused_not_overflowed() {
    let s = Scratch::new();
    s.write("deep.ron", &"(".repeat(100_000));
    let e = refused(&s, &["place", "deep.ron"]);
    assert!(e.starts_with("error: deep.ron:1:2: "), "{e}");
    s.write("deep.json", &"[".repeat(100_000));
    let e = refused(&s, &["place", "run.ron", "--probes", "deep.json"]);
    assert!(
        e.contains("deep.json") && e.contains("recursion limit"),
        "{e}"
    );
}

#[test]
fn probe_files_that_are_not_regular_files_are_refused() {
    let s = Scratch::new();
    mkfifo(&s.path("pipe.json"));
    let e = refused(&s, &["place", "run.ron", "--probes", "pipe.json"]);
    assert!(e.contains("pipe.json: is a FIFO"), "{e}");
    let e = refused(&s, &["place", "run.ron", "--probes", "/dev/zero"]);
    assert!(e.contains("/dev/zero: is a device"), "{e}");
}

#[test]
fn probe_files_of_another_format_or_version_are_refused_before_any_stage() {
    // Issue 45: a report, a probes.json of a future version, or an object
    // that says nothing of its format was read as probes.
    let s = Scratch::new();
    let probes = r#"[{"position": [1, 1, 1]}]"#;
    for (name, text, says) in [
        (
            "report.json",
            format!(r#"{{"format": "probeplace.report", "version": 1, "probes": {probes}}}"#),
            "is a `probeplace.report` file",
        ),
        (
            "v9.json",
            format!(r#"{{"format": "probeplace.probes", "version": 9, "probes": {probes}}}"#),
            "version 9",
        ),
        (
            "bare.json",
            format!(r#"{{"probes": {probes}}}"#),
            "has no `format`",
        ),
    ] {
        s.write(name, &text);
        let o = Command::new(env!("CARGO_BIN_EXE_probeplace"))
            .args(["place", "run.ron", "--probes", name])
            .current_dir(s.dir.path())
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{name}: {stderr}");
        assert!(
            !stderr.contains(" done in "),
            "{name}: a stage ran first: {stderr}"
        );
        let e = refused(&s, &["place", "run.ron", "--probes", name]);
        assert!(e.contains(name) && e.contains(says), "{e}");
    }
    // Our own file at our version is read.
    s.write(
        "ok.json",
        &format!(r#"{{"format": "probeplace.probes", "version": 1, "probes": {probes}}}"#),
    );
    let o = Command::new(env!("CARGO_BIN_EXE_probeplace"))
        .args([
            "place", "run.ron", "--probes", "ok.json", "--out", "given", "--quiet",
        ])
        .current_dir(s.dir.path())
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    // `--method` beside `--probes` was ignored without a word.
    let e = refused(
        &s,
        &[
            "place",
            "run.ron",
            "--probes",
            "ok.json",
            "--method",
            "grid:2x2x2",
        ],
    );
    assert!(e.contains("--method") && e.contains("--probes"), "{e}");
}

#[test]
fn thousands_of_shadow_casting_lights_enter_the_bake_estimate() {
    let s = Scratch::new();
    let lights = vec!["Point(position: (1, 1, 1), intensity: (1, 1, 1))"; 20_000].join(", ");
    s.config("lights.ron", &format!("lights: [{lights}],\n"));
    let e = refused(&s, &["bake", "lights.ron", "--method", "grid:2x2x2"]);
    assert!(
        e.contains("bake.samples") && e.contains("20000 lights"),
        "{e}"
    );
    // `place` bakes nothing, but its diffuse step path-traces the light.
    let e = refused(&s, &["place", "lights.ron"]);
    assert!(
        e.contains("refine.diffuse.rays") && e.contains("20000 lights"),
        "{e}"
    );
}

#[test]
fn a_compare_over_too_many_grids_is_refused_before_the_first() {
    let s = Scratch::new();
    s.config(
        "cmp.ron",
        "reference: (camera: (position: (1, 1, 0.3), look_at: (1, 1, 1.5))),\n",
    );
    let grids = vec!["4x4x4"; 100].join(",");
    let e = refused(&s, &["compare", "cmp.ron", "--cpu", "--grids", &grids]);
    assert!(e.contains("compare.grids: baking the 100 grids"), "{e}");
}

/// The scratch room with a camera (so a bake has a reference), baked
/// quickly into `dir` with `extra` arguments.
pub fn baked(s: &Scratch, dir: &str, extra: &[&str]) {
    if !s.path("cam.ron").exists() {
        s.config(
            "cam.ron",
            "reference: (camera: (position: (1, 1, 0.3), look_at: (1, 1, 1.5)), width: 16, height: 12, samples_per_pixel: 4),\nbake: (resolution: 16, samples: 2),\n",
        );
    }
    let mut args = vec!["bake", "cam.ron", "--quiet", "--out", dir];
    args.extend(extra);
    let (code, stderr) = stderr_of(s, &args);
    assert_eq!(code, Some(0), "{stderr}");
}

/// Every file of `dir`, by name, with its bytes (and links as links).
pub fn snapshot(dir: &Path) -> Vec<(String, bool, Vec<u8>)> {
    let mut v: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .flatten()
        .map(|e| {
            let link = e.file_type().unwrap().is_symlink();
            (
                e.file_name().to_string_lossy().into_owned(),
                link,
                std::fs::read(e.path()).unwrap_or_default(),
            )
        })
        .collect();
    v.sort();
    v
}

#[test]
fn reuse_through_symbolic_links_is_refused_and_destroys_nothing() {
    let s = Scratch::new();
    let (code, stderr) = stderr_of(&s, &["place", "run.ron", "--quiet", "--out", "run"]);
    assert_eq!(code, Some(0), "{stderr}");
    let before = snapshot(&s.path("run"));
    // D: the report and manifest copied, every other file a link into run/.
    std::fs::create_dir(s.path("d")).unwrap();
    for (name, _, _) in &before {
        let (from, to) = (s.path("run").join(name), s.path("d").join(name));
        if name == "report.json" || name == "manifest.json" {
            std::fs::copy(&from, &to).unwrap();
        } else {
            std::os::unix::fs::symlink(&from, &to).unwrap();
        }
    }
    let e = refused(&s, &["bake", "--from", "d", "--out", "run"]);
    assert!(e.contains("is a symbolic link"), "{e}");
    // Without the manifest, D is not a whole output set.
    std::fs::remove_file(s.path("d/manifest.json")).unwrap();
    let e = refused(&s, &["bake", "--from", "d", "--out", "run"]);
    assert!(e.starts_with("error: d/manifest.json: missing"), "{e}");
    assert_eq!(snapshot(&s.path("run")), before, "run/ changed");
    let (code, stderr) = stderr_of(&s, &["inspect", "run", "--quiet"]);
    assert_eq!(code, Some(0), "{stderr}");
    // An --out inside --from, or a --from inside --out, is refused first.
    let e = refused(&s, &["bake", "--from", "run", "--out", "run/deeper"]);
    assert!(e.contains("lies inside run"), "{e}");
    std::fs::create_dir(s.path("outer")).unwrap();
    std::fs::rename(s.path("run"), s.path("outer/run")).unwrap();
    let e = refused(&s, &["bake", "--from", "outer/run", "--out", "outer"]);
    assert!(e.starts_with("error: outer"), "{e}");
}

#[test]
fn files_changed_copied_in_or_gone_from_a_run_are_refused_by_name() {
    let s = Scratch::new();
    baked(&s, "a", &[]);
    baked(&s, "b", &["--seed", "2"]);
    let (code, stderr) = stderr_of(&s, &["inspect", "a", "--quiet"]);
    assert_eq!(code, Some(0), "{stderr}");
    let whole = snapshot(&s.path("a"));
    let put_back = || {
        std::fs::remove_dir_all(s.path("a")).unwrap();
        std::fs::create_dir(s.path("a")).unwrap();
        for (name, _, bytes) in &whole {
            std::fs::write(s.path("a").join(name), bytes).unwrap();
        }
    };
    // References of another seed copied in: the manifest refuses them.
    for name in ["reference.exr", "reference-glossy.exr"] {
        std::fs::copy(s.path("b").join(name), s.path("a").join(name)).unwrap();
    }
    for args in [
        &["render", "--from", "a"][..],
        &["inspect", "a"],
        &["export", "a", "--format", "glb"],
    ] {
        let e = refused(&s, args);
        assert!(
            e.contains("a/reference") && e.contains("SHA-256 differs"),
            "{args:?}: {e}"
        );
    }
    // With the manifest edited to match, the EXR's own metadata refuses it.
    let mut manifest: serde_json::Value =
        serde_json::from_slice(&std::fs::read(s.path("a/manifest.json")).unwrap()).unwrap();
    let theirs: serde_json::Value =
        serde_json::from_slice(&std::fs::read(s.path("b/manifest.json")).unwrap()).unwrap();
    for name in ["reference.exr", "reference-glossy.exr"] {
        manifest["files"][name] = theirs["files"][name].clone();
    }
    std::fs::write(s.path("a/manifest.json"), manifest.to_string()).unwrap();
    let e = refused(&s, &["render", "--from", "a"]);
    assert!(
        e.contains("probeplace.seed is 2 where this run has 0"),
        "{e}"
    );
    put_back();
    // A partial set: export, render and inspect refuse it, naming the file.
    std::fs::remove_file(s.path("a/lightfield.bin")).unwrap();
    for args in [
        &["export", "a", "--format", "glb"][..],
        &["render", "--from", "a"],
        &["inspect", "a"],
    ] {
        let e = refused(&s, args);
        assert!(e.contains("a/lightfield.bin: missing"), "{args:?}: {e}");
    }
    put_back();
    // probes.json gone, or a FIFO in its place: refused, not recomputed
    // (and the FIFO is never opened, so nothing blocks).
    std::fs::remove_file(s.path("a/probes.json")).unwrap();
    let e = refused(&s, &["bake", "--from", "a"]);
    assert!(e.starts_with("error: a/probes.json: missing"), "{e}");
    mkfifo(&s.path("a/probes.json"));
    let e = refused(&s, &["bake", "--from", "a"]);
    assert!(
        e.starts_with("error: a/probes.json: is not a regular file"),
        "{e}"
    );
    std::fs::remove_file(s.path("a/probes.json")).unwrap();
    put_back();
    // A file of the user's beside the run is named, not swept away.
    std::fs::write(s.path("a/notes.txt"), "mine").unwrap();
    let e = refused(&s, &["bake", "--from", "a"]);
    assert!(
        e.starts_with("error: a/notes.txt: is not a file of the run"),
        "{e}"
    );
    let e = refused(&s, &["inspect", "a"]);
    assert!(
        e.starts_with("error: a/notes.txt: is not a file of the run"),
        "{e}"
    );
    assert_eq!(std::fs::read(s.path("a/notes.txt")).unwrap(), b"mine");
    std::fs::remove_file(s.path("a/notes.txt")).unwrap();
    let (code, stderr) = stderr_of(&s, &["render", "--from", "a", "--quiet"]);
    assert_eq!(code, Some(0), "the whole set is reused: {stderr}");
}

#[test]
fn a_compare_whose_bakes_run_past_the_limit_lowers_their_samples_alike_and_finishes() {
    let s = Scratch::new();
    s.config(
        "cmp.ron",
        "reference: (camera: (position: (1, 1, 0.3), look_at: (1, 1, 1.5)), width: 16, height: 12, samples_per_pixel: 4),\nbake: (resolution: 16, samples: 65536),\nlights: [Point(position: (1, 1.5, 1), intensity: (1, 1, 1))],\n",
    );
    // Each bake of 65 536 paths a texel would run past a 20 s limit; the
    // old compare refused at the first bake, after placing.
    let o = Command::new(env!("CARGO_BIN_EXE_probeplace"))
        .args(["compare", "cmp.ron", "--cpu", "--quiet", "--out", "c"])
        .env("PROBEPLACE_WORK_LIMIT", "20")
        .current_dir(s.dir.path())
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(0), "{stderr}");
    let r: serde_json::Value =
        serde_json::from_slice(&std::fs::read(s.path("c/compare.json")).unwrap()).unwrap();
    let warnings = r["warnings"].to_string();
    assert!(
        warnings.contains("bake.samples from 65536 to ")
            && warnings.contains("for every placement alike"),
        "{warnings}"
    );
    // Every family is still measured.
    let families: std::collections::BTreeSet<&str> = r["placements"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| p["family"].as_str().unwrap())
        .collect();
    for f in ["ours", "grid", "relocated", "greedy"] {
        assert!(families.contains(f), "{f}: {families:?}");
    }
}

#[test]
fn a_killed_runs_staging_is_swept_by_the_next_run_into_its_directory_only() {
    let s = Scratch::new();
    let staging = || -> Vec<String> {
        let mut v: Vec<String> = std::fs::read_dir(s.dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .filter(|n| n.contains(".probeplace-"))
            .collect();
        v.sort();
        v
    };
    // Killed after its first file: the staging directory of `a` is left.
    let o = Command::new(env!("CARGO_BIN_EXE_probeplace"))
        .args(["place", "run.ron", "--quiet", "--out", "a"])
        .env("PROBEPLACE_TEST_KILL_AT", "1")
        .current_dir(s.dir.path())
        .output()
        .unwrap();
    assert!(!o.status.success());
    let left = staging();
    assert_eq!(left.len(), 1, "{left:?}");
    assert!(left[0].starts_with(".a.probeplace-"), "{left:?}");
    // A run into another directory beside it leaves it (docs/formats.md).
    let (code, stderr) = stderr_of(&s, &["place", "run.ron", "--quiet", "--out", "b"]);
    assert_eq!(code, Some(0), "{stderr}");
    assert_eq!(staging(), left);
    // The next run into `a` sweeps it.
    let (code, stderr) = stderr_of(&s, &["place", "run.ron", "--quiet", "--out", "a"]);
    assert_eq!(code, Some(0), "{stderr}");
    assert!(staging().is_empty(), "{:?}", staging());
    let docs = std::fs::read_to_string(crate::common::root().join("docs/formats.md")).unwrap();
    assert!(
        docs.contains("is removed by the next run into the same output directory; runs into other\ndirectories, even beside it, leave it alone"),
        "docs/formats.md no longer says which runs sweep a killed run's staging directory"
    );
}

#[test]
fn runs_into_one_directory_at_once_leave_one_whole_set_or_are_refused() {
    let s = Scratch::new();
    for round in 0..3 {
        let children: Vec<_> = ["1", "2", "3"]
            .iter()
            .map(|seed| {
                Command::new(env!("CARGO_BIN_EXE_probeplace"))
                    .args([
                        "place", "run.ron", "--quiet", "--out", "out", "--seed", seed,
                    ])
                    .current_dir(s.dir.path())
                    .stderr(std::process::Stdio::piped())
                    .spawn()
                    .unwrap()
            })
            .collect();
        // Each run finishes, or is refused while another holds the
        // directory (issue 70): never two sets mixed.
        let mut finished = 0;
        for c in children {
            let o = c.wait_with_output().unwrap();
            let err = String::from_utf8_lossy(&o.stderr);
            if o.status.success() {
                finished += 1;
            } else {
                assert_eq!(o.status.code(), Some(2), "round {round}: {err}");
                assert!(
                    err.contains("is writing this output directory"),
                    "round {round}: {err}"
                );
            }
        }
        assert!(finished >= 1, "round {round}");
        // One run's set, whole: its manifest holds, every file is of its
        // seed, and inspect passes it.
        let files = crate::common::dir_files(&s.path("out"));
        crate::common::assert_manifest_holds(&files);
        let json =
            |name: &str| -> serde_json::Value { serde_json::from_slice(&files[name]).unwrap() };
        let seed = json("report.json")["provenance"]["seed"].clone();
        assert_eq!(
            json("probes.json")["provenance"]["seed"],
            seed,
            "round {round}"
        );
        assert_eq!(
            json("manifest.json")["provenance"]["seed"],
            seed,
            "round {round}"
        );
        let (code, stderr) = stderr_of(&s, &["inspect", "out", "--quiet"]);
        assert_eq!(code, Some(0), "round {round}: {stderr}");
    }
    let left: Vec<String> = std::fs::read_dir(s.dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.contains(".probeplace-"))
        .collect();
    assert!(left.is_empty(), "staging left: {left:?}");
}

// glTF 2.0 scenes (issue 48): each mistake named with the object at fault.

/// A scratch directory holding `bad.glb` (or `bad.gltf`) and a config for it.
fn refused_gltf(name: &str, bytes: &[u8]) -> String {
    let s = Scratch::new();
    std::fs::write(s.path(name), bytes).unwrap();
    s.config_for("bad.ron", Path::new(name));
    refused(&s, &["place", "bad.ron"])
}

fn gltf_room() -> probeplace::fixtures::gltf_writer::Builder {
    let mut b = probeplace::fixtures::gltf_writer::Builder::new();
    let mesh = b.unit_quad(None);
    let node = b.node(serde_json::json!({"mesh": mesh}));
    b.scene(&[node]);
    b
}

#[test]
fn hostile_gltf_files_are_refused_in_one_line_naming_what_is_wrong() {
    let good = gltf_room();
    let doc = |edit: &dyn Fn(&mut serde_json::Value)| {
        let mut d = good.document(None);
        edit(&mut d);
        d
    };
    let glb_of = |d: serde_json::Value| good.glb_of(&d);
    let cases: Vec<(&str, Vec<u8>, &str)> = vec![
        (
            "truncated GLB",
            good.glb()[..40].to_vec(),
            "the file has 40",
        ),
        (
            "GLB version 1",
            {
                let mut g = good.glb();
                g[4] = 1;
                g
            },
            "GLB version 1",
        ),
        (
            "not JSON",
            b"{\"asset\": [".to_vec(),
            "not a glTF 2.0 document",
        ),
        (
            "glTF 1.0",
            glb_of(doc(&|d| d["asset"]["version"] = serde_json::json!("1.0"))),
            "glTF version \"1.0\"",
        ),
        (
            "Draco",
            glb_of(doc(&|d| {
                d["extensionsRequired"] = serde_json::json!(["KHR_draco_mesh_compression"])
            })),
            "compressed geometry",
        ),
        (
            "accessor past its view",
            glb_of(doc(&|d| {
                d["accessors"][0]["count"] = serde_json::json!(1000)
            })),
            "accessor 0: 1000 elements",
        ),
        (
            "view past its buffer",
            glb_of(doc(&|d| {
                d["bufferViews"][0]["byteLength"] = serde_json::json!(1 << 20)
            })),
            "buffer view 0",
        ),
        (
            "missing accessor",
            glb_of(doc(&|d| {
                d["meshes"][0]["primitives"][0]["attributes"]["POSITION"] = serde_json::json!(77)
            })),
            "accessor 77 does not exist",
        ),
        (
            "missing mesh",
            glb_of(doc(&|d| d["nodes"][0]["mesh"] = serde_json::json!(9))),
            "node 0: mesh 9 does not exist",
        ),
        (
            "a cycle",
            glb_of(doc(&|d| d["nodes"][0]["children"] = serde_json::json!([0]))),
            "reached twice",
        ),
        (
            "missing material",
            glb_of(doc(&|d| {
                d["meshes"][0]["primitives"][0]["material"] = serde_json::json!(3)
            })),
            "material 3 does not exist",
        ),
        (
            "a URL buffer",
            glb_of(doc(&|d| {
                d["buffers"][0]["uri"] = serde_json::json!("https://example.com/a.bin")
            })),
            "reads no URL",
        ),
        (
            "a missing buffer file",
            glb_of(doc(&|d| {
                d["buffers"][0]["uri"] = serde_json::json!("gone.bin")
            })),
            "gone.bin: glTF buffer not found",
        ),
        (
            "bad base64",
            glb_of(doc(&|d| {
                d["buffers"][0]["uri"] =
                    serde_json::json!("data:application/octet-stream;base64,!!")
            })),
            "base64",
        ),
        (
            "short buffer",
            glb_of(doc(&|d| {
                d["buffers"][0]["byteLength"] = serde_json::json!(1 << 30)
            })),
            "fewer than its byteLength",
        ),
        (
            "a zero rotation",
            glb_of(doc(&|d| {
                d["nodes"][0]["rotation"] = serde_json::json!([0, 0, 0, 0])
            })),
            "node 0: its transform is not finite",
        ),
        (
            "a bad stride",
            glb_of(doc(&|d| {
                d["bufferViews"][0]["byteStride"] = serde_json::json!(4)
            })),
            "byteStride 4",
        ),
        (
            "an index out of range",
            {
                let mut d = good.document(None);
                d["accessors"][1]["componentType"] = serde_json::json!(5125);
                let mut g = glb_of(d);
                // The first index (at the start of the second view) set to 999.
                let json_len = u32::from_le_bytes(g[12..16].try_into().unwrap()) as usize;
                let at = 20 + json_len + 8 + 48;
                g[at..at + 4].copy_from_slice(&999u32.to_le_bytes());
                g
            },
            "names vertex 999",
        ),
        (
            "a colour texture that does not exist",
            glb_of(doc(&|d| {
                d["materials"] = serde_json::json!([
                    {"name": "m", "pbrMetallicRoughness": {"baseColorTexture": {"index": 4}}}
                ])
            })),
            "baseColorTexture: texture 4 does not exist",
        ),
        (
            "an emission texture whose image does not exist",
            glb_of(doc(&|d| {
                d["textures"] = serde_json::json!([{"source": 2}]);
                d["materials"] = serde_json::json!([{"emissiveTexture": {"index": 0}}]);
            })),
            "texture 0's image 2 does not exist",
        ),
        (
            "a texture whose sampler does not exist",
            glb_of(doc(&|d| {
                d["images"] = serde_json::json!([{"uri": "x.png"}]);
                d["textures"] = serde_json::json!([{"source": 0, "sampler": 7}]);
                d["materials"] = serde_json::json!([{"emissiveTexture": {"index": 0}}]);
            })),
            "texture 0's sampler 7 does not exist",
        ),
    ];
    for (what, bytes, needle) in cases {
        let e = refused_gltf("bad.glb", &bytes);
        assert!(e.contains("bad.glb"), "{what}: {e}");
        assert!(e.contains(needle), "{what}: {e}");
    }
}

/// The lights a glTF file defines cast shadow rays as config lights do,
/// so a file of twenty thousand of them is refused by the bake's estimate
/// once the scene is read, as the config's are before.
#[test]
fn thousands_of_lights_in_a_gltf_enter_the_bake_estimate() {
    let s = Scratch::new();
    let room = probeplace::scene::load(&s.path("room.obj"), 1.0, Default::default()).unwrap();
    let flat = probeplace::fixtures::gltf_writer::from_scene(&room);
    let mut doc = flat.document(None);
    let lamp = serde_json::json!({"type": "point", "intensity": 1.0});
    doc["extensions"] = serde_json::json!({"KHR_lights_punctual": {"lights": [lamp]}});
    let nodes = doc["nodes"].as_array_mut().unwrap();
    let first = nodes.len();
    for _ in 0..20_000 {
        nodes.push(serde_json::json!({"translation": [1, 1, 1], "extensions": {"KHR_lights_punctual": {"light": 0}}}));
    }
    let roots: Vec<usize> = (0..first).chain(first..first + 20_000).collect();
    doc["scenes"][0]["nodes"] = serde_json::json!(roots);
    let glb = flat.glb_of(&doc);
    std::fs::write(s.path("lit.glb"), glb).unwrap();
    s.config_for("lit.ron", Path::new("lit.glb"));
    // The diffuse step, the first to light the scene, refuses first.
    for job in ["place", "bake"] {
        let e = refused(&s, &[job, "lit.ron", "--method", "grid:2x2x2"]);
        assert!(
            e.contains("refine.diffuse.rays") && e.contains("20000 lights"),
            "{e}"
        );
    }
    // Without it, the bake's estimate.
    let e = refused(
        &s,
        &["bake", "lit.ron", "--method", "grid:2x2x2", "--no-refine"],
    );
    assert!(
        e.contains("bake.samples") && e.contains("20000 lights"),
        "{e}"
    );
}
