//! Every user mistake exits 2 with one line naming the file or field, prints
//! no panic, and writes nothing.

use crate::common::*;
use std::path::Path;

/// `dir/run.ron`: the minimal config for `scene`, plus the fields in `extra`.
fn config(dir: &Path, scene: &str, extra: &str) -> std::path::PathBuf {
    raw_config(
        dir,
        "run.ron",
        &format!("(\n    scene: \"{scene}\",\n    voxel_size: 0.1,\n    placement: SdfSkeleton(()),\n{extra})\n"),
    )
}

/// Writes a config of exactly `text` as `dir/name`.
fn raw_config(dir: &Path, name: &str, text: &str) -> std::path::PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

fn obj(dir: &Path, name: &str, text: &str) {
    std::fs::write(dir.join(name), text).unwrap();
}

/// Runs `place` on `config` into `out/` beside it and checks the failure
/// contract ([`refused_in`]); returns the error line.
fn fails(config: &Path, extra: &[&str]) -> String {
    let dir = config.parent().unwrap();
    let out = dir.join("out");
    let mut args = vec![
        "place",
        config.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    refused_in(dir, &args, &[]).line
}

const CUBE_ROOM: &str = "v 0 0 0\nv 2 0 0\nv 2 0 2\nv 0 0 2\nv 0 2 0\nv 2 2 0\nv 2 2 2\nv 0 2 2\n\
f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\n";

#[test]
fn missing_config() {
    let d = tempfile::tempdir().unwrap();
    let e = fails(&d.path().join("nope.ron"), &[]);
    assert!(e.contains("nope.ron"), "{e}");
}

#[test]
fn missing_scene_file() {
    let d = tempfile::tempdir().unwrap();
    let e = fails(&config(d.path(), "absent.obj", ""), &[]);
    assert!(e.contains("absent.obj") && e.contains("not found"), "{e}");
}

#[test]
fn malformed_obj() {
    let d = tempfile::tempdir().unwrap();
    obj(d.path(), "bad.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n");
    let e = fails(&config(d.path(), "bad.obj", ""), &[]);
    assert!(e.contains("bad.obj:4: face vertex index 7"), "{e}");
    obj(d.path(), "junk.obj", "v one two three\nf 1 2 3\n");
    let e = fails(&config(d.path(), "junk.obj", ""), &[]);
    assert!(e.contains("junk.obj:1: vertex coordinate `one`"), "{e}");
}

#[test]
fn obj_with_nan_coordinates() {
    let d = tempfile::tempdir().unwrap();
    obj(
        d.path(),
        "nan.obj",
        "v nan 0 0\nv 1 nan 0\nv 0 1 NaN\nv 1 1 1\nf 1 2 3\nf 2 3 4\n",
    );
    let e = fails(&config(d.path(), "nan.obj", ""), &[]);
    assert!(
        e.contains("nan.obj") && e.contains("no usable triangle"),
        "{e}"
    );
}

#[test]
fn empty_obj() {
    let d = tempfile::tempdir().unwrap();
    obj(d.path(), "empty.obj", "# nothing here\n");
    let e = fails(&config(d.path(), "empty.obj", ""), &[]);
    assert!(
        e.contains("empty.obj") && e.contains("no usable triangle"),
        "{e}"
    );
}

#[test]
fn malformed_ron() {
    let d = tempfile::tempdir().unwrap();
    let p = raw_config(
        d.path(),
        "broken.ron",
        "(\n  scene: \"a.obj\",\n  voxel_size: 0.1\n  placement: Grid((cells: (1,1,1))),\n)",
    );
    let e = fails(&p, &[]);
    assert!(e.contains("broken.ron:4:"), "line and column expected: {e}");
}

#[test]
fn unknown_field_and_wrong_type_name_the_field() {
    let d = tempfile::tempdir().unwrap();
    obj(d.path(), "room.obj", CUBE_ROOM);
    let e = fails(&config(d.path(), "room.obj", "    voxels: 3,\n"), &[]);
    assert!(e.contains("run.ron:5:") && e.contains("voxels"), "{e}");
    let e = fails(&config(d.path(), "room.obj", "    seed: \"seven\",\n"), &[]);
    assert!(e.contains("run.ron:5:") && e.contains("seed"), "{e}");
}

#[test]
fn unknown_method() {
    let d = tempfile::tempdir().unwrap();
    obj(d.path(), "room.obj", CUBE_ROOM);
    let c = config(d.path(), "room.obj", "");
    let e = fails(&c, &["--method", "voronoi"]);
    assert!(e.contains("--method voronoi"), "{e}");
    let e = fails(&c, &["--method", "grid:2x0x2"]);
    assert!(e.contains("grid:2x0x2"), "{e}");
    let p = raw_config(
        d.path(),
        "m.ron",
        "(scene: \"room.obj\", voxel_size: 0.1, placement: Voronoi(()))",
    );
    let e = fails(&p, &[]);
    assert!(e.contains("placement") && e.contains("Voronoi"), "{e}");
}

#[test]
fn impossible_parameters() {
    let d = tempfile::tempdir().unwrap();
    obj(d.path(), "room.obj", CUBE_ROOM);
    // Out of range in the file: negative voxel size, zero rays.
    let p = raw_config(
        d.path(),
        "neg.ron",
        "(scene: \"room.obj\", voxel_size: -1.0, placement: SdfSkeleton(()))",
    );
    let e = fails(&p, &[]);
    assert!(
        e.contains("voxel_size") && e.contains("greater than 0"),
        "{e}"
    );
    let e = fails(
        &config(d.path(), "room.obj", "    sdf: (rays_per_voxel: 0),\n"),
        &[],
    );
    assert!(e.contains("rays_per_voxel"), "{e}");
    // Valid alone, impossible for this scene: a grid of 8e12 voxels.
    let p = raw_config(
        d.path(),
        "tiny.ron",
        "(scene: \"room.obj\", voxel_size: 0.00001, placement: SdfSkeleton(()))",
    );
    let e = fails(&p, &[]);
    assert!(
        e.contains("tiny.ron:1:21: voxel_size: 1e-5 gives") && e.contains("voxels"),
        "{e}"
    );
}

#[test]
fn min_distance_that_culls_everything() {
    let d = tempfile::tempdir().unwrap();
    obj(d.path(), "room.obj", CUBE_ROOM);
    let p = raw_config(
        d.path(),
        "md.ron",
        "(scene: \"room.obj\", voxel_size: 0.1, placement: SdfSkeleton((min_distance: 5.0)))",
    );
    let e = fails(&p, &[]);
    assert!(
        e.contains("min_distance") && e.contains("culls every free voxel"),
        "{e}"
    );
}

#[test]
fn medial_axis_mistakes_name_their_field() {
    let d = tempfile::tempdir().unwrap();
    obj(d.path(), "room.obj", CUBE_ROOM);
    for (placement, field, why) in [
        // 1e-5 spacing over the 24 m² room: 2.4e11 points.
        (
            "MedialAxis((point_spacing: 0.00001))",
            "ma.ron:1:61: placement.point_spacing",
            "limit",
        ),
        // The 2 m room's largest ball has a radius of 1.
        (
            "MedialAxis((min_radius: 5.0))",
            "ma.ron:1:61: placement.min_radius",
            "no medial ball",
        ),
        (
            "MedialAxis((precluster_angle_deg: 0))",
            "ma.ron:1:",
            "precluster_angle_deg",
        ),
        (
            "MedialAxis((max_iterations: 0))",
            "ma.ron:1:",
            "max_iterations",
        ),
        (
            "MedialAxis((cluster_radius: -1))",
            "ma.ron:1:",
            "cluster_radius",
        ),
        (
            "MedialAxis((precluster_radius: 1, shrink: 2))",
            "ma.ron:1:",
            "shrink",
        ),
    ] {
        let p = raw_config(
            d.path(),
            "ma.ron",
            &format!("(scene: \"room.obj\", voxel_size: 0.1, placement: {placement})"),
        );
        let e = fails(&p, &[]);
        assert!(e.contains(field) && e.contains(why), "{placement}: {e}");
    }
}

/// A diffuse evaluation of hours is refused before any work, naming the
/// field, and writes nothing.
#[test]
fn compare_refuses_a_diffuse_evaluation_past_the_work_limit() {
    let d = tempfile::tempdir().unwrap();
    obj(d.path(), "room.obj", CUBE_ROOM);
    let p = raw_config(
        d.path(),
        "df.ron",
        "(scene: \"room.obj\", voxel_size: 0.1, compare: (views: 1, diffuse: (surface_receivers: 65536, free_receivers: 65536, reference_rays: 65536)))",
    );
    let out = d.path().join("out");
    let r = refused_in(
        d.path(),
        &[
            "compare",
            p.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ],
        &[],
    );
    assert!(
        r.line.contains("df.ron:1:")
            && r.line.contains("compare.diffuse.reference_rays")
            && r.line.contains("limit"),
        "{}",
        r.line
    );
    assert!(!out.exists());
}

#[test]
fn refine_mistakes_name_their_field() {
    let d = tempfile::tempdir().unwrap();
    obj(d.path(), "room.obj", CUBE_ROOM);
    for (refine, field, why) in [
        // 1e-5 texels over the 24 m² room: 2.4e11 of them.
        (
            "(texel_size: 0.00001)",
            "rf.ron:1:75: refine.texel_size",
            "limit",
        ),
        ("(coverage_target: 1.5)", "rf.ron:1:", "coverage_target"),
        ("(fitness: Greedy)", "rf.ron:1:", "fitness"),
        ("(directions: 1000)", "rf.ron:1:", "directions"),
        ("(w_distance: -1)", "rf.ron:1:", "w_distance"),
        ("(iterations: 0)", "rf.ron:1:", "iterations"),
        ("(steps: 3)", "rf.ron:1:", "steps"),
    ] {
        let p = raw_config(
            d.path(),
            "rf.ron",
            &format!("(scene: \"room.obj\", voxel_size: 0.1, placement: SdfSkeleton(()), refine: {refine})"),
        );
        let e = fails(&p, &[]);
        assert!(e.contains(field) && e.contains(why), "{refine}: {e}");
    }
}

#[test]
fn svo_mistakes_name_their_field() {
    let d = tempfile::tempdir().unwrap();
    obj(d.path(), "room.obj", CUBE_ROOM);
    for (svo, field, why) in [
        // 1e-4 leaves over the 2 m room: 8e12 of them.
        (
            "(leaf_size: 0.0001)",
            "sv.ron:1:98: svo.leaf_size",
            "larger leaf_size",
        ),
        ("(max_probes: 9)", "sv.ron:1:", "max_probes"),
        ("(max_probes: 0)", "sv.ron:1:", "max_probes"),
        ("(collapse_quality: 2)", "sv.ron:1:", "collapse_quality"),
        ("(directions: 0)", "sv.ron:1:", "directions"),
        ("(leaf: 1)", "sv.ron:1:", "leaf"),
    ] {
        let p = raw_config(
            d.path(),
            "sv.ron",
            &format!("(scene: \"room.obj\", voxel_size: 0.1, placement: SdfSkeleton(()), refine: (enabled: false), svo: {svo})"),
        );
        let e = fails(&p, &[]);
        assert!(e.contains(field) && e.contains(why), "{svo}: {e}");
    }
}

#[test]
fn inspect_refuses_what_is_not_an_intact_svo() {
    let d = tempfile::tempdir().unwrap();
    // A placement alone, shared with the `svo` inspect test (read only).
    let out = &shared_job("place", "configs/cornell.ron", &["--no-refine"]).dir;
    let good = std::fs::read(out.join("svo.bin")).unwrap();
    let check = |name: &str, bytes: &[u8], why: &str| {
        let p = d.path().join(name);
        std::fs::write(&p, bytes).unwrap();
        let o = probeplace(&["inspect", p.to_str().unwrap()]);
        let stderr = String::from_utf8_lossy(&o.stderr).into_owned();
        assert_eq!(o.status.code(), Some(2), "{name}: {stderr}");
        assert_eq!(stderr.trim_end().lines().count(), 1, "{name}: {stderr}");
        assert!(
            stderr.starts_with("error: ") && stderr.contains(name) && stderr.contains(why),
            "{name}: {stderr}"
        );
        assert!(!stderr.contains("panicked"), "{name}: {stderr}");
    };
    check("truncated.bin", &good[..good.len() / 2], "truncated");
    check("header.bin", &good[..30], "truncated");
    let mut corrupted = good.clone();
    let mid = corrupted.len() / 2;
    corrupted[mid] ^= 0x5A;
    check("corrupted.bin", &corrupted, "corrupted");
    let mut newer = good.clone();
    newer[8..12].copy_from_slice(&7u32.to_le_bytes());
    check("newer.bin", &newer, "unsupported version 7");
    check(
        "probes.json",
        &std::fs::read(out.join("probes.json")).unwrap(),
        "not a probeplace SVO",
    );
    // A directory without one, and an svo.bin beside another run's probes.
    let o = probeplace(&["inspect", d.path().to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("holds no svo.bin"));
    let other = d.path().join("other");
    place(
        &root().join("configs/cornell.ron"),
        &other,
        &["--method", "grid:2x2x2", "--no-refine"],
    );
    std::fs::copy(out.join("svo.bin"), other.join("svo.bin")).unwrap();
    let o = probeplace(&["inspect", other.to_str().unwrap()]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("different runs"), "{stderr}");
}

#[test]
fn domain_box_away_from_the_scene() {
    let d = tempfile::tempdir().unwrap();
    obj(d.path(), "room.obj", CUBE_ROOM);
    let c = config(
        d.path(),
        "room.obj",
        "    domain: Box((min: (10, 10, 10), max: (11, 11, 11))),\n",
    );
    let e = fails(&c, &[]);
    assert!(e.contains("domain"), "{e}");
}

#[test]
fn output_path_that_is_a_file() {
    let d = tempfile::tempdir().unwrap();
    obj(d.path(), "room.obj", CUBE_ROOM);
    let c = config(d.path(), "room.obj", "");
    let file = d.path().join("taken");
    std::fs::write(&file, b"").unwrap();
    let o = probeplace(&[
        "place",
        c.to_str().unwrap(),
        "--out",
        file.to_str().unwrap(),
        "--quiet",
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("taken"));
}

#[test]
fn a_valid_tiny_room_succeeds() {
    // The control for the tests above: the same room with sane settings works.
    let d = tempfile::tempdir().unwrap();
    obj(d.path(), "room.obj", CUBE_ROOM);
    let c = config(d.path(), "room.obj", "");
    let r = place(&c, &d.path().join("out"), &[]);
    assert_eq!(r["probes_in_solid"], 0);
    assert!(r["coverage"].as_f64().unwrap() > 0.95);
}

#[test]
fn command_line_mistakes_are_one_line_and_exit_2() {
    for args in [
        &["place"][..],
        &["place", "configs/cornell.ron", "--bogus"],
        &["place", "configs/cornell.ron", "--seed", "x"],
        &["render", "configs/cornell.ron", "--variant", "fastest"],
        &["compare", "configs/cornell.ron", "--grids", "2x2"],
        &["compare", "configs/cornell.ron", "--grids", "2xtwox2"],
        &["compare", "configs/cornell.ron", "--grids", "0x1x1"],
        &["compare", "configs/cornell.ron", "--grids", ","],
        &["frobnicate"],
    ] {
        let o = probeplace(args);
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {stderr}");
        // One line, and clap's tips (if any) after it.
        let lines: Vec<&str> = stderr.trim_end().lines().collect();
        assert!(lines[0].starts_with("error: "), "{args:?}: {stderr}");
        assert!(
            lines[1..]
                .iter()
                .all(|l| l.trim_start().starts_with("tip:")),
            "{args:?}: {stderr}"
        );
    }
    let tip = probeplace(&["place", "configs/cornell.ron", "--seeed", "3"]);
    assert!(
        String::from_utf8_lossy(&tip.stderr).contains("tip:"),
        "clap's suggestion kept: {}",
        String::from_utf8_lossy(&tip.stderr)
    );
    // A bare probeplace is a usage mistake: help on stderr, exit 2.
    let bare = probeplace(&[]);
    assert_eq!(bare.status.code(), Some(2));
    assert!(bare.stdout.is_empty());
    assert!(String::from_utf8_lossy(&bare.stderr).contains("Usage:"));
    let help = probeplace(&["place", "--help"]);
    assert_eq!(help.status.code(), Some(0));
    assert!(String::from_utf8_lossy(&help.stdout).contains("--method"));
}

#[test]
fn bake_and_light_mistakes_name_their_field() {
    let d = tempfile::tempdir().unwrap();
    obj(d.path(), "room.obj", CUBE_ROOM);
    for (extra, why) in [
        ("bake: (resolution: 100)", "power of two"),
        ("bake: (resolution: 4096)", "power of two"),
        ("bake: (irradiance_resolution: 0)", "power of two"),
        ("bake: (samples: 0)", "samples"),
        ("bake: (bounces: 65)", "0 to 64"),
        ("bake: (moment_exponent: -1)", "greater than 0"),
        ("reference: (camera: (position: (0, 1, 0), look_at: (0, 1, 0)))", "look_at must differ"),
        ("reference: (camera: (position: (0, 1, 0), look_at: (0, 2, 0)))", "parallel"),
        ("reference: (camera: (position: (0, 1, 0), look_at: (1, 1, 0), fov_degrees: 180))", "fov_degrees"),
        ("reference: (width: 0)", "width"),
        ("lights: [Point(position: (0, 1, 0), intensity: (1, -1, 1))]", "at least 0"),
        ("lights: [Directional(direction: (0, 0, 0), irradiance: (1, 1, 1))]", "not all zero"),
        ("lights: [Spot(position: (0, 1, 0), direction: (0, -1, 0), intensity: (1, 1, 1), cone_degrees: 95)]", "90"),
        ("lights: [Lamp(position: (0, 1, 0))]", "Lamp"),
    ] {
        let p = raw_config(
            d.path(),
            "bk.ron",
            &format!("(scene: \"room.obj\", voxel_size: 0.1, placement: SdfSkeleton(()),\n {extra})"),
        );
        for command in ["place", "bake", "render", "compare"] {
            let out = d.path().join("out");
            let o = probeplace(&[command, p.to_str().unwrap(), "--out", out.to_str().unwrap()]);
            let e = String::from_utf8_lossy(&o.stderr).into_owned();
            assert_eq!(o.status.code(), Some(2), "{command} {extra}: {e}");
            assert_eq!(e.trim().lines().count(), 1, "{extra}: {e}");
            assert!(e.contains("bk.ron:2:") && e.contains(why), "{command} {extra}: {e}");
            assert!(!out.exists(), "{extra}: nothing may be written");
        }
    }
}

/// `render` needs the config's camera; `compare` chooses views of its
/// own, so it is refused only when told to choose none.
#[test]
fn render_and_compare_without_a_view_name_the_field() {
    let d = tempfile::tempdir().unwrap();
    obj(d.path(), "room.obj", CUBE_ROOM);
    let out = d.path().join("out");
    for (command, extra, field) in [
        ("render", "", "reference.camera"),
        ("compare", "    compare: (views: 0),\n", "compare.views"),
    ] {
        let p = config(d.path(), "room.obj", extra);
        let o = probeplace(&[command, p.to_str().unwrap(), "--out", out.to_str().unwrap()]);
        let e = String::from_utf8_lossy(&o.stderr).into_owned();
        assert_eq!(o.status.code(), Some(2), "{command}: {e}");
        assert_eq!(e.trim().lines().count(), 1, "{command}: {e}");
        assert!(e.contains("run.ron") && e.contains(field), "{command}: {e}");
        assert!(!out.exists(), "{command}: nothing may be written");
    }
}

#[test]
fn compare_mistakes_name_their_field() {
    let d = tempfile::tempdir().unwrap();
    obj(d.path(), "room.obj", CUBE_ROOM);
    for (extra, why) in [
        ("compare: (glossy_rays: 0)", "glossy_rays"),
        ("compare: (grids: [(cells: (0, 1, 1))])", "grids"),
        (
            "compare: (cameras: [(position: (0, 1, 0), look_at: (0, 1, 0))])",
            "look_at must differ",
        ),
        ("compare: (sweep: 3)", "sweep"),
        ("compare: (views: 65)", "views"),
        ("compare: (materials: AllGlossy(1.5))", "materials"),
        ("compare: (materials: Shiny)", "materials"),
    ] {
        let p = raw_config(
            d.path(),
            "cmp.ron",
            &format!(
                "(scene: \"room.obj\", voxel_size: 0.1, placement: SdfSkeleton(()),\n {extra})"
            ),
        );
        let out = d.path().join("out");
        let o = probeplace(&[
            "compare",
            p.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ]);
        let e = String::from_utf8_lossy(&o.stderr).into_owned();
        assert_eq!(o.status.code(), Some(2), "{extra}: {e}");
        assert_eq!(e.trim().lines().count(), 1, "{extra}: {e}");
        assert!(e.contains("cmp.ron:2:") && e.contains(why), "{extra}: {e}");
        assert!(!out.exists(), "{extra}: nothing may be written");
    }
}
