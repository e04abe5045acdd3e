//! Hostile scenes (issue 70): glTF files of a few KB that ask the scene
//! reader or the BVH build for far more work or memory than their size.
//! Each runs the binary under an address-space limit of its memory budget
//! (`PROBEPLACE_MEMORY`, set explicitly) plus 512 MiB of headroom for the
//! process itself, so that an allocation the budget did not count aborts
//! the run and fails the test, and under `timeout`, so that a hang fails
//! it too. A refusal is exit 2 with one line naming the file and the
//! cause, no panic or abort, nothing written.

use crate::common::*;
use crate::hostile::Scratch;
use probeplace::fixtures::gltf_writer::hostile;
use std::path::Path;
use std::process::Command;
use std::time::{Duration, Instant};

/// The memory budget each case runs with, in MiB.
const BUDGET_MIB: u64 = 512;
/// Address space beyond the budget for the process itself (its code,
/// threads' stacks, the config), in MiB.
const HEADROOM_MIB: u64 = 512;

/// What a run under the limits printed.
struct Run {
    code: Option<i32>,
    stderr: String,
    took: Duration,
}

/// Runs `probeplace ARGS` in `dir` with the budget and the address-space
/// limit above, killed after [`REFUSAL_SECONDS`] times three.
fn limited(dir: &Path, args: &[&str]) -> Run {
    let bin = env!("CARGO_BIN_EXE_probeplace");
    let kib = (BUDGET_MIB + HEADROOM_MIB) * 1024;
    let start = Instant::now();
    let o = Command::new("timeout")
        .args([
            "--signal=KILL",
            &(3 * REFUSAL_SECONDS).to_string(),
            "bash",
            "-c",
        ])
        .arg(format!("ulimit -v {kib} && exec {bin} {}", args.join(" ")))
        .env("PROBEPLACE_MEMORY", format!("{BUDGET_MIB}M"))
        .current_dir(dir)
        .output()
        .unwrap();
    Run {
        code: o.status.code(),
        stderr: String::from_utf8_lossy(&o.stderr).into_owned(),
        took: start.elapsed(),
    }
}

/// [`limited`], checked as a refusal: exit 2, no panic or abort, one
/// `error:` line (stage lines aside), nothing in `out/`; the line.
fn refused_limited(dir: &Path, args: &[&str]) -> String {
    let r = limited(dir, args);
    assert!(
        r.code.is_some(),
        "killed after {:?} (a hang or an abort): {}",
        r.took,
        r.stderr
    );
    assert_eq!(r.code, Some(2), "{}", r.stderr);
    assert!(
        !r.stderr.contains("panicked") && !r.stderr.contains("memory allocation"),
        "{}",
        r.stderr
    );
    let lines: Vec<&str> = r
        .stderr
        .trim_end()
        .lines()
        .filter(|l| !(l.starts_with("probeplace: ") && l.contains(" done in ")))
        .collect();
    assert_eq!(lines.len(), 1, "one line expected: {}", r.stderr);
    assert!(lines[0].starts_with("error: "), "{}", r.stderr);
    let out = dir.join("out");
    assert!(
        !out.is_dir() || std::fs::read_dir(&out).unwrap().next().is_none(),
        "wrote into out/"
    );
    lines[0].to_string()
}

/// A scratch directory holding `name` (its bytes) and `scene.ron` for it.
fn scene_dir(name: &str, bytes: &[u8]) -> Scratch {
    let s = Scratch::new();
    std::fs::write(s.path(name), bytes).unwrap();
    s.config_for("scene.ron", Path::new(name));
    s
}

/// The scratch room (a closed 2 m cube) with `copies` quads over its
/// middle, each `step` above the last (0: all at one place).
fn room_with_pile(copies: usize, step: f64) -> String {
    let mut obj = crate::hostile::CUBE_ROOM.to_string();
    for i in 0..copies {
        let y = 1.0 + i as f64 * step;
        obj += &format!("v 0.5 {y} 0.5\nv 1.5 {y} 0.5\nv 1.5 {y} 1.5\nv 0.5 {y} 1.5\n");
        if step == 0.0 {
            break;
        }
    }
    for i in 0..copies {
        let b = 9 + if step == 0.0 { 0 } else { 4 * i };
        obj += &format!("f {b} {} {} {}\n", b + 1, b + 2, b + 3);
    }
    obj
}

#[test]
fn coincident_instances_are_dropped_as_copies_and_the_run_finishes() {
    // Before: 24k copies of a quad at one place (48k coincident
    // triangles) made the BVH build quadratic (23 s at 96k), then the
    // SDF's band and every ray that reached them test them all: a glTF of
    // a few hundred KB ran past every limit. A copy adds no surface, so
    // the loader drops it, and says so.
    let b = hostile::coincident_instances(24_000);
    let s = scene_dir("stack.gltf", &b.gltf(None));
    s.write("room.obj", &room_with_pile(24_000, 0.0));
    for (scene, refused) in [("stack.gltf", true), ("room.obj", false)] {
        s.config_for("scene.ron", Path::new(scene));
        let r = limited(s.dir.path(), &["place", "scene.ron"]);
        assert!(
            r.code.is_some(),
            "{scene}: killed after {:?}: {}",
            r.took,
            r.stderr
        );
        assert!(!r.stderr.contains("panicked"), "{}", r.stderr);
        if refused {
            // The quads alone enclose no room: refused for that, at once.
            assert_eq!(r.code, Some(2), "{scene}: {}", r.stderr);
        } else {
            assert_eq!(r.code, Some(0), "{scene}: {}", r.stderr);
            assert!(
                r.stderr
                    .contains("dropped 47998 triangle(s) that repeat an earlier one exactly"),
                "{}",
                r.stderr
            );
        }
        assert!(
            r.took < Duration::from_secs(REFUSAL_SECONDS),
            "{scene}: {:?}",
            r.took
        );
    }
}

#[test]
fn a_pile_of_overlapping_triangles_is_refused_by_the_estimate_naming_it() {
    // 24k quads a micrometre apart: no copies, and no tree separates
    // them, so every ray that reaches the pile tests thousands of
    // triangles (the coverage reference alone ran past 100 s). The
    // estimates see what a ray costs (the BVH's surface-area heuristic)
    // and refuse before the work, naming the cause.
    let s = Scratch::new();
    s.write("room.obj", &room_with_pile(24_000, 1e-6));
    let line = refused_limited(s.dir.path(), &["place", "run.ron"]);
    assert!(
        line.contains("overlapping triangles") && line.contains("PROBEPLACE_WORK_LIMIT"),
        "{line}"
    );
}

#[test]
fn a_shared_accessor_is_decoded_once_and_counted_against_the_budget() {
    // Eight primitives share one POSITION accessor of zeros whose decoded
    // elements and vertices (24 bytes a vertex) are beyond the budget:
    // refused naming the accessor, before it is allocated, rather than
    // aborted in the allocator on its second decoding.
    let vertices = BUDGET_MIB << 20 >> 4;
    let b = hostile::shared_accessor(8, vertices);
    let bytes = b.gltf(None);
    let s = scene_dir("shared.gltf", &bytes);
    let line = refused_limited(s.dir.path(), &["place", "scene.ron"]);
    assert!(
        line.contains("shared.gltf") && line.contains("POSITION"),
        "{line}"
    );
    assert!(line.contains("memory budget"), "{line}");
}

#[test]
fn a_padded_glb_is_not_read_past_the_budget() {
    let s = Scratch::new();
    let glb = hostile::coincident_instances(1).glb();
    let big = (BUDGET_MIB + 2 * HEADROOM_MIB) << 20;
    hostile::write_padded(&s.path("padded.glb"), &glb, big).unwrap();
    s.config_for("scene.ron", Path::new("padded.glb"));
    let line = refused_limited(s.dir.path(), &["place", "scene.ron"]);
    assert!(
        line.contains("padded.glb") && line.contains("over the limit"),
        "{line}"
    );
}

#[test]
fn a_glb_buffer_file_past_the_budget_is_refused_by_name() {
    let s = Scratch::new();
    let b = hostile::coincident_instances(1);
    std::fs::write(s.path("scene.gltf"), b.gltf(Some("scene.bin"))).unwrap();
    let big = (BUDGET_MIB + 2 * HEADROOM_MIB) << 20;
    hostile::write_padded(&s.path("scene.bin"), b.bin(), big).unwrap();
    s.config_for("scene.ron", Path::new("scene.gltf"));
    let line = refused_limited(s.dir.path(), &["place", "scene.ron"]);
    assert!(
        line.contains("buffer 0") && line.contains("over the limit"),
        "{line}"
    );
}

#[test]
fn negative_light_colour_and_intensity_are_refused_each() {
    let mut b = hostile::coincident_instances(1);
    let light = b.light(
        serde_json::json!({"type": "point", "color": [-1.0, -1.0, -1.0], "intensity": -5.0}),
    );
    b.node(serde_json::json!({"extensions": {"KHR_lights_punctual": {"light": light}}}));
    let mut doc = b.document(None);
    doc["scenes"][0]["nodes"]
        .as_array_mut()
        .unwrap()
        .push(serde_json::json!(1));
    let s = scene_dir("lit.glb", &b.glb_of(&doc));
    let line = refused_limited(s.dir.path(), &["place", "scene.ron"]);
    assert!(
        line.contains("light 0") && line.contains("color[0]"),
        "{line}"
    );
}

#[test]
fn an_empty_buffer_uri_and_an_image_in_a_missing_view_are_refused() {
    let b = hostile::coincident_instances(1);
    let mut doc = b.document(Some(""));
    let s = scene_dir("empty.gltf", &serde_json::to_vec(&doc).unwrap());
    let line = refused_limited(s.dir.path(), &["place", "scene.ron"]);
    assert!(line.contains("buffer 0 has an empty uri"), "{line}");

    doc = b.document(None);
    doc["images"] = serde_json::json!([{"bufferView": 99, "mimeType": "image/png"}]);
    doc["textures"] = serde_json::json!([{"source": 0}]);
    doc["materials"] =
        serde_json::json!([{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}]);
    let s = scene_dir("view.glb", &b.glb_of(&doc));
    let line = refused_limited(s.dir.path(), &["place", "scene.ron"]);
    assert!(line.contains("buffer view 99 does not exist"), "{line}");
}

/// [`limited`], checked as a run that kept its bounds: it finished (exit
/// 0) or was refused in one `error:` line (exit 2); no panic, no abort
/// (an allocation past the address-space limit), no hang.
fn bounded_limited(dir: &Path, args: &[&str]) -> Run {
    let r = limited(dir, args);
    assert!(
        r.code.is_some(),
        "killed after {:?} (a hang or an abort): {}",
        r.took,
        r.stderr
    );
    assert!(
        !r.stderr.contains("panicked") && !r.stderr.contains("memory allocation"),
        "{}",
        r.stderr
    );
    match r.code {
        Some(0) => {}
        Some(2) => {
            let errors = r
                .stderr
                .lines()
                .filter(|l| l.starts_with("error: "))
                .count();
            assert_eq!(errors, 1, "one error line expected: {}", r.stderr);
        }
        c => panic!("exit {c:?}: {}", r.stderr),
    }
    r
}

/// A scratch directory whose `room.obj` (the cube room, all its faces of
/// material `m0`) names `room.mtl`, which holds `mtl`; `scene.ron` for it.
fn textured_room(mtl: &str) -> Scratch {
    let s = Scratch::new();
    s.write(
        "room.obj",
        &format!("mtllib room.mtl\nusemtl m0\n{}", crate::hostile::CUBE_ROOM),
    );
    s.write("room.mtl", mtl);
    s.config_for("scene.ron", Path::new("room.obj"));
    s
}

/// The lines of `stderr` that are not a stage's timing.
fn messages(stderr: &str) -> Vec<&str> {
    stderr
        .lines()
        .filter(|l| !(l.starts_with("probeplace: ") && l.contains(" done in ")))
        .collect()
}

#[test]
fn twenty_names_for_one_padded_texture_are_read_within_the_budget() {
    // Twenty materials each map a different name, all links to one small
    // PNG padded (a hole: no disk) to 60 MiB; the PNG decoder stops at
    // its end chunk, so each is a valid image. Before the fix each file was
    // read whole up to the memory budget and held until decoding: 1.2 GB
    // of file bytes under a 1 GiB address-space limit, an abort. Now the
    // files' bytes count against the texture budget: those past it are
    // warned of and skipped, and the run places.
    const N: usize = 20;
    let mtl: String = (0..N)
        .map(|i| format!("newmtl m{i}\nKd 1 1 1\nmap_Kd t{i}.png\n"))
        .collect();
    let s = textured_room(&mtl);
    let png = probeplace::fixtures::gltf_writer::png_rgb(2, 2, &[128; 12]);
    // 60 MiB, not more: the run hashes every input file for its
    // provenance, 20 × 60 MiB of it.
    hostile::write_padded(&s.path("big.png"), &png, 60 << 20).unwrap();
    for i in 0..N {
        std::os::unix::fs::symlink("big.png", s.path(&format!("t{i}.png"))).unwrap();
    }
    let r = bounded_limited(s.dir.path(), &["place", "scene.ron"]);
    assert_eq!(r.code, Some(0), "{}", r.stderr);
    assert!(s.path("out/probes.json").is_file(), "{}", r.stderr);
    let skipped: Vec<&str> = messages(&r.stderr)
        .into_iter()
        .filter(|l| l.contains("over the limit") || l.contains("more texture(s) not read"))
        .collect();
    assert!(!skipped.is_empty(), "no texture skipped: {}", r.stderr);
}

#[test]
fn a_texture_in_a_symbolic_link_loop_is_named_a_loop() {
    let s = textured_room("newmtl m0\nKd 1 1 1\nmap_Kd a.png\n");
    std::os::unix::fs::symlink("b.png", s.path("a.png")).unwrap();
    std::os::unix::fs::symlink("a.png", s.path("b.png")).unwrap();
    let r = bounded_limited(s.dir.path(), &["place", "scene.ron"]);
    assert_eq!(r.code, Some(0), "{}", r.stderr);
    let named: Vec<&str> = messages(&r.stderr)
        .into_iter()
        .filter(|l| l.contains("a.png"))
        .collect();
    assert_eq!(named.len(), 1, "{}", r.stderr);
    assert!(named[0].contains("symbolic-link loop"), "{}", named[0]);
    assert!(!named[0].contains("not found"), "{}", named[0]);
}

#[test]
fn a_truncated_jpeg_texture_warns_in_one_line() {
    let s = textured_room("newmtl m0\nKd 1 1 1\nmap_Kd half.jpg\n");
    let texels: Vec<u8> = (0..64 * 64 * 3).map(|i| (i * 37 % 251) as u8).collect();
    let mut jpeg = Vec::new();
    jpeg_encoder::Encoder::new(&mut jpeg, 90)
        .encode(&texels, 64, 64, jpeg_encoder::ColorType::Rgb)
        .unwrap();
    // Cut at half its tables (before the scan's SOS marker): zune-jpeg
    // pads a scan cut short and decodes it, but a table cut short is an
    // error whose text ends in a line break.
    let sos = jpeg.windows(2).position(|w| w == [0xFF, 0xDA]).unwrap();
    std::fs::write(s.path("half.jpg"), &jpeg[..sos / 2]).unwrap();
    let r = bounded_limited(s.dir.path(), &["place", "scene.ron"]);
    assert_eq!(r.code, Some(0), "{}", r.stderr);
    // Every line is a message of its own (a warning, an error, a stage's
    // timing, the summary): none continues the line before it.
    let lines = messages(&r.stderr);
    let named: Vec<&&str> = lines.iter().filter(|l| l.contains("half.jpg")).collect();
    assert_eq!(named.len(), 1, "{}", r.stderr);
    assert!(named[0].starts_with("warning: "), "{}", r.stderr);
    let at = lines.iter().position(|l| l.contains("half.jpg")).unwrap();
    assert!(
        lines[at].contains("the texture is not used"),
        "the warning is cut: {}",
        r.stderr
    );
}
