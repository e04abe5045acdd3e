//! `split`, the tile jobs (under a real Slurm when there is one), and
//! `merge`: the world they make against one machine's, and the faults
//! `merge` must refuse.

use crate::common::{place, probeplace, read_json, test_quality, Overlay};
use probeplace::fixtures::generated::{generate, Kind};
use serde_json::Value;
use std::path::Path;
use std::process::Command;

/// Runs `split` on `config` into `dir`.
fn split(config: &str, tiles: &str, dir: &Path) {
    let o = probeplace(&[
        "split",
        config,
        "--tiles",
        tiles,
        "--out",
        dir.to_str().unwrap(),
        "--cpus",
        "1",
        "--quiet",
    ]);
    assert!(
        o.status.success(),
        "split failed: {}",
        String::from_utf8_lossy(&o.stderr)
    );
}

/// Runs tile `index` of the split in `dir` as the array task would.
fn run_tile(dir: &Path, index: u32, extra_env: &[(&str, &str)]) {
    let mut cmd = Command::new("sh");
    cmd.arg(dir.join("tile.sh")).arg(index.to_string());
    for (k, v) in extra_env {
        cmd.env(k, v);
    }
    let o = cmd.output().unwrap();
    assert!(
        o.status.success(),
        "tile {index} failed: {}",
        String::from_utf8_lossy(&o.stderr)
    );
}

/// `probeplace merge DIR`: its exit status and stderr.
fn merge(dir: &Path) -> (Option<i32>, String) {
    let o = probeplace(&["merge", dir.to_str().unwrap(), "--quiet"]);
    (
        o.status.code(),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

/// Our Cornell box at test quality with `fields` set, split into `tiles`
/// in a new temporary directory: the config (kept alive with its file),
/// the directory's owner and the split directory.
fn split_cornell(
    fields: &[(&str, &str)],
    tiles: &str,
) -> (Overlay, tempfile::TempDir, std::path::PathBuf) {
    let config = test_quality("configs/cornell.ron", fields);
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("split");
    split(config.arg(), tiles, &dir);
    (config, tmp, dir)
}

/// Whether a Slurm cluster answers; under CI (`CI` set) it must, since
/// `.ci/run` starts one.
fn slurm(test: &str) -> bool {
    let up = Command::new("sinfo")
        .arg("-h")
        .output()
        .is_ok_and(|o| o.status.success());
    if !up && std::env::var_os("CI").is_some() {
        panic!("{test}: no Slurm cluster answers under CI (.ci/run starts one: bash .ci/slurm up)");
    }
    if !up {
        eprintln!("SKIPPED {test}: no Slurm cluster (bash .ci/slurm up starts one)");
    }
    up
}

/// Checks a merged world's `report.json` against one machine's run of the
/// same `config`, and returns the world's probe count: no probe in solid,
/// coverage at the target within its interval, and the bar, no
/// more than 10% over one machine's count (fewer is allowed: the merge's
/// cover is stronger than refinement's prune; a quarter is the sanity
/// floor). `coverage` is the validation figure of both, and the merge ran
/// check rounds as one machine does.
fn near_one_machine(name: &str, one: &Value, world: &Value, config: &Overlay) -> u64 {
    let count = world["probe_count"].as_u64().unwrap();
    let single = one["probe_count"].as_u64().unwrap();
    let target = config.load().refine.coverage_target.0 as f64;
    let coverage = world["coverage"].as_f64().unwrap();
    let ci = world["coverage_ci95"].as_f64().unwrap();
    eprintln!(
        "{name} 2x1x2: one machine {single} probes, coverage {:.4}; tiles {count} probes, coverage {coverage:.4} ± {ci:.4}",
        one["coverage"]
    );
    assert_eq!(world["probes_in_solid"], 0, "{name}");
    let rounds = world["merge"]["check_rounds"].as_array().unwrap();
    assert!(!rounds.is_empty(), "{name}: no check round");
    assert!(
        world["coverage_train"].as_f64().is_some(),
        "{name}: no training figure"
    );
    assert!(
        coverage + ci >= target,
        "{name}: coverage {coverage} ± {ci} under {target}"
    );
    // Both check their probes on fresh rounds of samples and fill what
    // they find (refine::holdout, merge's fill_round).
    assert!(
        count * 10 <= single * 11 && count * 4 >= single,
        "{name}: {count} probes where one machine places {single}"
    );
    count
}

#[test]
fn sponza_split_into_tiles_under_slurm_and_merged_is_whole() {
    if !slurm("sponza_split_into_tiles_under_slurm_and_merged_is_whole") {
        return;
    }
    // A coarser grid than the shipped 0.25 keeps the five runs and the
    // merge within CI's time; the comparison is at the same voxel size.
    let config = test_quality("configs/sponza.ron", &[("voxel_size", "0.4")]);
    let tmp = tempfile::tempdir().unwrap();
    let one = place(config.path(), &tmp.path().join("one"), &[]);
    let dir = tmp.path().join("split");
    split(config.arg(), "2x1x2", &dir);
    let o = Command::new("bash")
        .arg(dir.join("submit.sh"))
        .arg("--wait")
        .output()
        .unwrap();
    assert!(
        o.status.success(),
        "submit.sh --wait: {}\n{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    let world = read_json(&dir.join("world/report.json"));
    let index = read_json(&dir.join("world/world.json"));
    let count = near_one_machine("sponza", &one, &world, &config);
    let merge = &world["merge"];
    assert!(merge["offered"].as_u64().unwrap() > 0);
    assert!(merge["offered_kept"].as_u64().unwrap() <= count);
    // The tiles' ranges number every probe once, and each tile's octree
    // lists world indices.
    let mut next = 0;
    for t in index["tiles"].as_array().unwrap() {
        assert_eq!(t["probes"]["first"].as_u64().unwrap(), next);
        next += t["probes"]["count"].as_u64().unwrap();
        let bytes = std::fs::read(dir.join("world").join(t["svo"].as_str().unwrap())).unwrap();
        let svo = probeplace::svo::format::from_bytes(&bytes).unwrap();
        assert_eq!(svo.probe_count as u64, count);
        let (_, payload) = svo.words();
        assert!(payload.iter().all(|&i| (i as u64) < count));
        assert!(!payload.is_empty());
    }
    assert_eq!(next, count);
}

/// The second world: a generated multi-room building (the
/// storeys of docs/tiles.md; other seeds there, by hand), split 2×1×2,
/// each tile run as its array task would be, and merged; against one
/// machine's run of the same config.
#[test]
fn a_generated_building_split_and_merged_stays_near_one_machine() {
    let tmp = tempfile::tempdir().unwrap();
    let g = generate(Kind::Storeys, 1);
    let name = g.fixture.name.clone();
    let path = g.write(tmp.path()).unwrap();
    let config = test_quality(path.to_str().unwrap(), &[]);
    let one = place(config.path(), &tmp.path().join(format!("{name}-one")), &[]);
    let dir = tmp.path().join(format!("{name}-split"));
    split(config.arg(), "2x1x2", &dir);
    for tile in 0..4 {
        run_tile(&dir, tile, &[]);
    }
    let (code, err) = merge(&dir);
    assert_eq!(code, Some(0), "{name}: {err}");
    let world = read_json(&dir.join("world/report.json"));
    near_one_machine(&name, &one, &world, &config);
}

#[test]
fn a_failed_or_foreign_tile_stops_the_merge_and_a_rerun_mends_it() {
    // The faults do not depend on the scene: the smallest one keeps the
    // four placements and two merges quick.
    let (config, _tmp, dir) = split_cornell(&[], "2x1x1");
    run_tile(&dir, 0, &[]);
    // Tile 1 never ran: the merge names it and writes nothing.
    let (code, err) = merge(&dir);
    assert_eq!(code, Some(2), "{err}");
    assert!(
        err.starts_with("error: tile-001: no finished placement"),
        "{err}"
    );
    assert_eq!(err.trim_end().lines().count(), 1, "{err}");
    assert!(!dir.join("world").exists());
    // Run with another seed, it is another run: refused by provenance.
    let tile_config = dir.join("tile-001/config.ron");
    let o = probeplace(&[
        "place",
        tile_config.to_str().unwrap(),
        "--seed",
        "77",
        "--quiet",
    ]);
    assert!(o.status.success());
    let (code, err) = merge(&dir);
    assert_eq!(code, Some(2), "{err}");
    assert!(
        err.contains("tile-001: its run used another config"),
        "{err}"
    );
    // Rerun as split wrote it; a file of its output changed since is
    // refused by the tile's manifest, naming the tile and the file.
    run_tile(&dir, 1, &[]);
    let probes_path = dir.join("tile-001/out/probes.json");
    let whole = std::fs::read(&probes_path).unwrap();
    let edited = String::from_utf8(whole.clone()).unwrap().replacen(
        "\"position\": [",
        "\"position\": [ ",
        1,
    );
    std::fs::write(&probes_path, edited).unwrap();
    let (code, err) = merge(&dir);
    assert_eq!(code, Some(2), "{err}");
    assert!(
        err.starts_with("error: tile-001: ") && err.contains("tile-001/out/probes.json: holds"),
        "{err}"
    );
    std::fs::write(&probes_path, &whole).unwrap();
    // An output inside a tile, or the split itself, is refused before the
    // tiles are read, and the tile keeps its placement.
    let tile_report = std::fs::read(dir.join("tile-000/out/report.json")).unwrap();
    let started = std::time::Instant::now();
    for out in [
        dir.join("tile-000/out"),
        dir.join("tile-000/world"),
        dir.clone(),
    ] {
        let o = probeplace(&[
            "merge",
            dir.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ]);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{err}");
        assert_eq!(err.trim_end().lines().count(), 1, "{err}");
        assert!(
            err.contains("tile-000") || err.contains("split.json"),
            "{err}"
        );
    }
    assert!(started.elapsed().as_secs() < 10, "refused only after work");
    assert_eq!(
        std::fs::read(dir.join("tile-000/out/report.json")).unwrap(),
        tile_report
    );
    // Nor may a split be written into one.
    let inner = dir.join("tile-000/again");
    let o = probeplace(&[
        "split",
        config.arg(),
        "--tiles",
        "2x1x1",
        "--out",
        inner.to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("lies inside tile-000 of the split"), "{err}");
    assert!(!inner.exists());
    // Nor may another run write into a tile: only the tile's own config.
    let o = probeplace(&[
        "place",
        tile_config.to_str().unwrap(),
        "--out",
        dir.join("tile-000/out").to_str().unwrap(),
        "--quiet",
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("lies inside tile-000 of the split"), "{err}");
    assert_eq!(
        std::fs::read(dir.join("tile-000/out/report.json")).unwrap(),
        tile_report
    );
    let (code, err) = merge(&dir);
    assert_eq!(code, Some(0), "{err}");
    let world = read_json(&dir.join("world/report.json"));
    assert_eq!(world["probes_in_solid"], 0);
    assert!(world["probe_count"].as_u64().unwrap() > 0);
    let probes = read_json(&dir.join("world/probes.json"));
    assert_eq!(
        probes["probes"].as_array().unwrap().len() as u64,
        world["probe_count"].as_u64().unwrap()
    );
    assert_eq!(probes["provenance"], world["provenance"]);
}

#[test]
fn a_tile_without_triangles_is_skipped_and_the_world_still_merges() {
    // A domain reaching well past the box (as an open world's reaches
    // past its buildings): the last of three tiles along x holds no
    // triangle at all.
    let (_config, _tmp, dir) = split_cornell(
        &[(
            "domain",
            "Box((min: (-0.5, -0.1, -0.5), max: (2.5, 0.7, 1.2)))",
        )],
        "3x1x1",
    );
    let index = read_json(&dir.join("split.json"));
    let triangles: Vec<u64> = index["tile"]
        .as_array()
        .unwrap()
        .iter()
        .map(|t| t["triangles"].as_u64().unwrap())
        .collect();
    assert_eq!(triangles[2], 0, "{triangles:?}");
    assert!(triangles[0] > 0);
    // Its array task succeeds at once, so that Slurm still runs the merge.
    let o = Command::new("sh")
        .arg(dir.join("tile.sh"))
        .arg("2")
        .output()
        .unwrap();
    assert!(o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("tile-002 holds no triangles"));
    assert!(!dir.join("tile-002/out").exists());
    run_tile(&dir, 0, &[]);
    run_tile(&dir, 1, &[]);
    let (code, err) = merge(&dir);
    assert_eq!(code, Some(0), "{err}");
    let world = read_json(&dir.join("world/world.json"));
    let tiles = world["tiles"].as_array().unwrap();
    assert_eq!(tiles[2]["svo"], Value::Null);
    assert_eq!(tiles[2]["probes"]["count"], 0);
    assert!(dir
        .join("world")
        .join(tiles[0]["svo"].as_str().unwrap())
        .is_file());
    let report = read_json(&dir.join("world/report.json"));
    assert!(report["coverage"].as_f64().unwrap() >= 0.999, "{report}");
    assert_eq!(report["probes_in_solid"], 0);
    let per_tile = &report["merge"]["per_tile"][2];
    assert_eq!(per_tile["coverable_samples"], 0);
    assert_eq!(per_tile["probes_placed"], 0);
}

#[test]
fn a_split_over_an_earlier_one_replaces_it_whole() {
    let (config, _tmp, dir) = split_cornell(&[], "2x1x1");
    run_tile(&dir, 0, &[]);
    run_tile(&dir, 1, &[]);
    let (code, err) = merge(&dir);
    assert_eq!(code, Some(0), "{err}");
    assert!(dir.join("world/report.json").is_file());
    // A user's file in the merged world, whose manifest is gone (issue 70):
    // neither the next merge nor the next split deletes it.
    let notes = dir.join("world/notes.txt");
    std::fs::write(&notes, b"the user's").unwrap();
    std::fs::remove_file(dir.join("world/manifest.json")).unwrap();
    let (code, err) = merge(&dir);
    assert_eq!(code, Some(2), "{err}");
    assert!(
        err.contains("notes.txt") && err.trim_end().lines().count() == 1,
        "{err}"
    );
    let refused = split_refusal(&config, &[], &dir);
    assert!(refused.contains("notes.txt"), "{refused}");
    assert!(notes.is_file() && dir.join("tile-001/config.ron").is_file());
    std::fs::remove_file(&notes).unwrap();
    // Nor one in a tile's folder.
    std::fs::write(dir.join("tile-001/mine.obj"), b"v 0 0 0").unwrap();
    let refused = split_refusal(&config, &[], &dir);
    assert!(refused.contains("tile-001/mine.obj"), "{refused}");
    std::fs::remove_file(dir.join("tile-001/mine.obj")).unwrap();
    // One tile now: the old second tile, both placements and the merged
    // world are stale, and none of them may stay to pass for the new
    // split's.
    split(config.arg(), "1x1x1", &dir);
    assert!(dir.join("tile-000/config.ron").is_file());
    for stale in ["tile-001", "tile-000/out", "world"] {
        assert!(!dir.join(stale).exists(), "{stale} left over");
    }
    let (code, err) = merge(&dir);
    assert_eq!(code, Some(2), "{err}");
    assert!(
        err.starts_with("error: tile-000: no finished placement"),
        "{err}"
    );
}

/// `split` of `config` into 2×1×1 tiles at `out` with `extra` arguments,
/// which must be refused with one line and exit status 2: the line.
fn split_refusal(config: &Overlay, extra: &[&str], out: &Path) -> String {
    let mut args = vec!["split", config.arg(), "--tiles", "2x1x1"];
    args.extend(extra);
    args.extend(["--out", out.to_str().unwrap()]);
    let o = probeplace(&args);
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert_eq!(err.trim_end().lines().count(), 1, "{err}");
    err
}

#[test]
fn split_refuses_what_it_cannot_split() {
    let tmp = tempfile::tempdir().unwrap();
    let config = test_quality("configs/cornell.ron", &[("max_probes", "12")]);
    let err = split_refusal(&config, &[], &tmp.path().join("s"));
    assert!(
        err.contains("max_probes: a count for the whole world"),
        "{err}"
    );
    for tiles in ["2x2", "0x1x1"] {
        let o = probeplace(&["split", config.arg(), "--tiles", tiles, "--out", "/tmp/x"]);
        assert_eq!(o.status.code(), Some(2));
        assert!(String::from_utf8_lossy(&o.stderr).starts_with("error: --tiles: "));
    }
    let plain = test_quality("configs/cornell.ron", &[]);
    for margin in ["-1", "NaN"] {
        let out = tmp.path().join("m");
        let err = split_refusal(&plain, &["--margin", margin], &out);
        assert_eq!(
            err.trim_end(),
            format!("error: --margin: {margin} is not a length of at least 0")
        );
        assert!(!out.exists());
    }
    // A field split cannot honour is named with its line and column.
    let fixed = test_quality(
        "configs/cornell.ron",
        &[("fixed_probes", "[(0.2, 0.3, 0.2)]")],
    );
    let err = split_refusal(&fixed, &[], &tmp.path().join("f"));
    let line = std::fs::read_to_string(fixed.path())
        .unwrap()
        .lines()
        .position(|l| l.contains("fixed_probes"))
        .unwrap()
        + 1;
    assert!(
        err.contains(&format!(":{line}:")) && err.contains(": fixed_probes: split cannot share"),
        "{err}"
    );
    // A glTF scene is not streamed into tiles: refused, naming the field.
    let obj =
        probeplace::scene::load(&plain.load().scene, 0.001, probeplace::config::UpAxis::Y).unwrap();
    let glb = tmp.path().join("cornell.glb");
    std::fs::write(
        &glb,
        probeplace::fixtures::gltf_writer::from_scene(&obj).glb(),
    )
    .unwrap();
    let gltf = test_quality(
        "configs/cornell.ron",
        &[
            ("scene", &format!("{:?}", glb.display().to_string())),
            ("scale", "1.0"),
        ],
    );
    let err = split_refusal(&gltf, &[], &tmp.path().join("g"));
    assert!(err.contains(": scene: split streams OBJ scenes"), "{err}");
    assert!(!tmp.path().join("g").exists());
    // A path that is not a directory is refused, naming it, and kept.
    let file = tmp.path().join("a-file");
    std::fs::write(&file, "x").unwrap();
    let err = split_refusal(&plain, &[], &file);
    assert!(err.contains("a-file: --out: is not a directory"), "{err}");
    assert_eq!(std::fs::read(&file).unwrap(), b"x");
}

#[test]
fn the_default_margin_is_half_the_longest_tile_edge_as_documented() {
    let (_config, _tmp, dir) = split_cornell(&[], "2x1x1");
    let index = read_json(&dir.join("split.json"));
    let f = |v: &Value| v.as_f64().unwrap();
    let (min, max) = (&index["domain"]["min"], &index["domain"]["max"]);
    let edge = (0..3)
        .map(|a| (f(&max[a]) - f(&min[a])) / f(&index["tiles"][a]))
        .fold(0.0, f64::max);
    let want = (0.5 * edge).max(8.0 * f(&index["voxel_size"]));
    assert!((f(&index["margin"]) - want).abs() < 1e-9 * want, "{index}");
    let docs = std::fs::read_to_string(crate::common::root().join("docs/tiles.md")).unwrap();
    assert!(
        docs.contains("default half of the longest tile edge and at least\n  8 voxels"),
        "docs/tiles.md no longer states the default margin"
    );
}

/// A textured scene split into tiles: each tile's OBJ keeps its faces'
/// texture coordinates, the textures its library maps are copied beside
/// the library's copy (so a tile reads the same texels), and one outside
/// the library's folder is named in a warning, not silently dropped.
#[test]
fn split_tiles_carry_texture_coordinates_and_textures() {
    let dir = tempfile::tempdir().unwrap();
    let src = dir.path().join("src");
    std::fs::create_dir_all(src.join("tex")).unwrap();
    let png = probeplace::fixtures::gltf_writer::png_rgb(2, 1, &[255, 0, 0, 0, 0, 255]);
    std::fs::write(src.join("tex/red-blue.png"), &png).unwrap();
    std::fs::write(dir.path().join("outside.png"), &png).unwrap();
    // A closed 4 × 2 × 2 box whose floor is textured.
    std::fs::write(
        src.join("room.mtl"),
        "newmtl floor\nmap_Kd tex/red-blue.png\nnewmtl walls\nmap_Kd ../outside.png\n",
    )
    .unwrap();
    std::fs::write(
        src.join("room.obj"),
        "mtllib room.mtl\nv 0 0 0\nv 4 0 0\nv 4 0 2\nv 0 0 2\nv 0 2 0\nv 4 2 0\nv 4 2 2\nv 0 2 2\n\
         vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n\
         usemtl floor\nf 1/1 4/4 3/3 2/2\n\
         usemtl walls\nf 5 6 7 8\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\n",
    )
    .unwrap();
    let config = src.join("room.ron");
    std::fs::write(&config, "(scene: \"room.obj\", voxel_size: 0.1)").unwrap();
    // Deeper than the source, so that `../outside.png` from the copied
    // library names nothing.
    let out = dir.path().join("runs/tiles");
    let o = probeplace(&[
        "split",
        config.to_str().unwrap(),
        "--tiles",
        "2x1x1",
        "--out",
        out.to_str().unwrap(),
        "--cpus",
        "1",
    ]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{stderr}");
    assert!(
        format!("{stdout}{stderr}").contains("outside.png"),
        "the texture left behind is named: {stdout} {stderr}"
    );
    assert_eq!(std::fs::read(out.join("tex/red-blue.png")).unwrap(), png);
    let world =
        probeplace::scene::load(&src.join("room.obj"), 1.0, probeplace::config::UpAxis::Y).unwrap();
    for tile in ["tile-000", "tile-001"] {
        let s = probeplace::scene::load(
            &out.join(tile).join("scene.obj"),
            1.0,
            probeplace::config::UpAxis::Y,
        )
        .unwrap();
        assert_eq!(s.textures.len(), 1, "{tile}: {:?}", s.warnings);
        assert_eq!(s.textures[0].texels(), world.textures[0].texels());
        // Every floor triangle of the tile carries texture coordinates
        // that are among the world's.
        let floor = s.materials.iter().position(|m| m.name == "floor").unwrap() as u32;
        let uvs: Vec<_> = world.texcoords.iter().flatten().collect();
        for (t, &m) in s.material_ids.iter().enumerate() {
            if m == floor {
                assert!(
                    s.texcoords[t].iter().all(|uv| uvs.contains(&uv)),
                    "{tile}: {:?}",
                    s.texcoords[t]
                );
            }
        }
    }
}
