//! Exports for other tools (`probeplace export`, the config's `export`
//! list): the glTF binary checked by the Khronos validator and read back
//! by a GLB reader of our own (`read_back`, which checks the container as
//! it reads), the Godot scene parsed, the Unity file checked
//! against the importer's schema and the importer's fields against the
//! schema, the DDGI volume reproducing the probes, and the refusals.

use crate::common::*;
use serde_json::Value;
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::process::Command;

/// The world positions of a `probes.json`.
fn positions(probes_json: &Path) -> Vec<[f64; 3]> {
    read_json(probes_json)["probes"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| serde_json::from_value(p["position"].clone()).unwrap())
        .collect()
}

/// Runs `probeplace export ARGS…` quietly and asserts it succeeded.
fn export(args: &[&str]) {
    let mut all = vec!["export"];
    all.extend_from_slice(args);
    all.push("--quiet");
    let o = probeplace(&all);
    assert!(
        o.status.success(),
        "probeplace {all:?} failed: {}",
        String::from_utf8_lossy(&o.stderr)
    );
}

/// The Khronos glTF validator's script, with its package installed by
/// `python3 tests/node/install.py` (or `npm ci --prefix tests/node`);
/// `None` (the test skips) without node or the package, except under CI,
/// which installs both.
fn validator(test: &str) -> Option<PathBuf> {
    let script = root().join("tests/node/validate-gltf.mjs");
    let installed = root()
        .join("tests/node/node_modules/gltf-validator/package.json")
        .is_file();
    let node = Command::new("node").arg("--version").output();
    let why = match (&node, installed) {
        (Ok(o), true) if o.status.success() => return Some(script),
        (Ok(o), _) if o.status.success() => {
            "gltf-validator is not installed (python3 tests/node/install.py)"
        }
        _ => "no node on PATH",
    };
    assert!(
        std::env::var_os("CI").is_none(),
        "{test}: the glTF validator is required under CI (.ci/run installs nodejs and runs tests/node/install.py): {why}"
    );
    eprintln!("SKIPPED {test}: {why}");
    None
}

/// The validator's reports of `files`, one each.
fn validate(script: &Path, files: &[&Path]) -> Vec<Value> {
    let o = Command::new("node")
        .arg(script)
        .args(files)
        .output()
        .expect("node runs");
    assert!(
        o.status.success(),
        "validate-gltf.mjs failed: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    let reports: Vec<Value> = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(reports.len(), files.len());
    reports
}

/// What a `.glb` read back holds.
struct ReadBack {
    /// Translations of the nodes named `probe N`, by N.
    probes: Vec<[f32; 3]>,
    /// The `extras` of those nodes.
    extras: Vec<Value>,
    /// Triangles of the mesh of the node named `scene` (0 without).
    scene_triangles: usize,
    /// For each probe, the box its child node `influence N` draws (the
    /// cube [−1, 1]³ scaled and moved by the child's transform and then by
    /// the probe's), in the file's frame: what an importer that carries
    /// nodes into its own frame places.
    boxes: Vec<Option<([f64; 3], [f64; 3])>>,
}

/// The little-endian `u32` at `at` of `bytes`.
fn u32_at(bytes: &[u8], at: usize) -> usize {
    u32::from_le_bytes(bytes[at..at + 4].try_into().unwrap()) as usize
}

/// A JSON number that must be a non-negative integer, as `usize`.
fn index(v: &Value, what: &str) -> usize {
    v.as_u64()
        .unwrap_or_else(|| panic!("{what}: not an index: {v}")) as usize
}

/// Reads `glb` back, checking its container on the way (glTF 2.0, "GLB
/// File Format Specification"): the 12-byte header (`glTF`, version 2, the
/// file's length), a JSON chunk padded with spaces, then one BIN chunk
/// padded with zeros, each chunk's length a multiple of 4, nothing after
/// them, and buffer 0 (the BIN chunk, no `uri`) within the chunk. A
/// node's translation is its `translation` ([0, 0, 0] without), or the
/// last column of its `matrix`. A scene primitive is checked to be a list
/// of triangles whose POSITION accessor (3 floats a vertex, tightly packed)
/// lies within its buffer view and that within the buffer; it counts its
/// vertices / 3 triangles, or its indices / 3 when indexed.
fn read_back(glb: &Path) -> ReadBack {
    let bytes = std::fs::read(glb).unwrap();
    let file = glb.display();
    assert!(bytes.len() >= 20, "{file}: {} bytes", bytes.len());
    assert_eq!(&bytes[..4], b"glTF", "{file}: magic");
    assert_eq!(u32_at(&bytes, 4), 2, "{file}: GLB version");
    assert_eq!(u32_at(&bytes, 8), bytes.len(), "{file}: header length");
    // The chunks: (type, data), each length 4-aligned and within the file.
    let mut chunks = Vec::new();
    let mut at = 12;
    while at < bytes.len() {
        assert!(
            at + 8 <= bytes.len(),
            "{file}: chunk header at {at} cut off"
        );
        let len = u32_at(&bytes, at);
        assert_eq!(len % 4, 0, "{file}: chunk at {at} is {len} bytes");
        let end = at + 8 + len;
        assert!(
            end <= bytes.len(),
            "{file}: chunk at {at} overruns the file"
        );
        chunks.push((&bytes[at + 4..at + 8], &bytes[at + 8..end]));
        at = end;
    }
    assert_eq!(at, bytes.len(), "{file}: trailing bytes");
    let types: Vec<&[u8]> = chunks.iter().map(|c| c.0).collect();
    assert_eq!(types, [&b"JSON"[..], b"BIN\0"], "{file}: chunks");
    let (text, bin) = (chunks[0].1, chunks[1].1);
    let json_end = text.iter().rposition(|&b| b != b' ').map_or(0, |i| i + 1);
    assert!(
        text.len() - json_end < 4,
        "{file}: JSON padded past 4 bytes"
    );
    let doc: Value = serde_json::from_slice(&text[..json_end]).unwrap();

    let buffers = doc["buffers"].as_array().expect("buffers");
    assert_eq!(buffers.len(), 1, "{file}: one buffer");
    assert!(
        buffers[0].get("uri").is_none(),
        "{file}: buffer 0 is the BIN chunk"
    );
    let buffer_len = index(&buffers[0]["byteLength"], "buffer 0");
    assert!(
        buffer_len <= bin.len() && bin.len() - buffer_len < 4,
        "{file}: buffer of {buffer_len} bytes in a BIN chunk of {}",
        bin.len()
    );
    assert!(
        bin[buffer_len..].iter().all(|&b| b == 0),
        "{file}: BIN padding"
    );
    let accessor = |i: &Value| &doc["accessors"][index(i, "accessor")];
    // Vertices of the POSITION accessor of `primitive`, checked to lie in
    // the buffer.
    let positions = |primitive: &Value| {
        let a = accessor(&primitive["attributes"]["POSITION"]);
        assert_eq!(a["type"], "VEC3", "{file}: {a}");
        assert_eq!(a["componentType"], 5126, "{file}: FLOAT positions: {a}");
        let count = index(&a["count"], "accessor count");
        let view = &doc["bufferViews"][index(&a["bufferView"], "bufferView")];
        assert_eq!(view["buffer"], 0, "{file}: {view}");
        assert!(
            view.get("byteStride").is_none_or(|s| s == 12),
            "{file}: {view}"
        );
        let offset = a.get("byteOffset").map_or(0, |o| index(o, "byteOffset"));
        let view_offset = view.get("byteOffset").map_or(0, |o| index(o, "byteOffset"));
        let view_len = index(&view["byteLength"], "byteLength");
        assert_eq!((offset % 4, view_offset % 4), (0, 0), "{file}: {a} {view}");
        assert!(offset + 12 * count <= view_len, "{file}: {a} past {view}");
        assert!(
            view_offset + view_len <= buffer_len,
            "{file}: {view} past the buffer"
        );
        count
    };

    let mut probes = Vec::new();
    let mut extras = Vec::new();
    let mut scene_triangles = 0;
    let mut boxes = Vec::new();
    let nodes = doc["nodes"].as_array().expect("nodes");
    for node in nodes {
        let name = node["name"].as_str().unwrap_or("");
        if let Some(n) = name.strip_prefix("probe ") {
            assert_eq!(
                n.parse::<usize>().unwrap(),
                probes.len(),
                "{name} out of order"
            );
            let f = |v: &Value| v.as_f64().unwrap() as f32;
            let translation = match (node.get("translation"), node.get("matrix")) {
                (Some(t), None) => [f(&t[0]), f(&t[1]), f(&t[2])],
                // Column-major: the translation is the last column.
                (None, Some(m)) => [f(&m[12]), f(&m[13]), f(&m[14])],
                (None, None) => [0.0; 3],
                (Some(_), Some(_)) => panic!("{file}: {name} has a translation and a matrix"),
            };
            probes.push(translation);
            extras.push(node.get("extras").expect("probe extras").clone());
            let child = node.get("children").map(|c| &nodes[index(&c[0], "child")]);
            boxes.push(child.map(|c| {
                assert_eq!(c["name"], format!("influence {n}"), "{file}");
                let v = |k: &str, a: usize| c[k][a].as_f64().unwrap();
                let at = |a: usize| f64::from(translation[a]) + v("translation", a);
                let lo = [0, 1, 2].map(|a| at(a) - v("scale", a));
                let hi = [0, 1, 2].map(|a| at(a) + v("scale", a));
                (lo, hi)
            }));
        }
        if name == "scene" {
            let mesh = &doc["meshes"][index(&node["mesh"], "mesh")];
            for p in mesh["primitives"].as_array().expect("primitives") {
                assert!(
                    p.get("mode").is_none_or(|m| m == 4),
                    "{file}: scene primitives are TRIANGLES: {p}"
                );
                let vertices = positions(p);
                scene_triangles += match p.get("indices") {
                    Some(i) => index(&accessor(i)["count"], "indices count"),
                    None => vertices,
                } / 3;
            }
        }
    }
    ReadBack {
        probes,
        extras,
        scene_triangles,
        boxes,
    }
}

/// A node of a Godot `.tscn`.
struct TscnNode {
    name: String,
    kind: String,
    parent: Option<String>,
    /// Its `key = value` lines.
    properties: Vec<(String, String)>,
}

/// The nodes of a Godot `.tscn` after checking that it is well formed:
/// a `[gd_scene … format=3]` header first (its `load_steps`, when given,
/// the resources plus one), then headings and `key = value` lines only;
/// one root without a parent, first; unique names.
fn tscn_nodes(text: &str) -> Vec<TscnNode> {
    let mut lines = text.lines();
    let header = lines.next().unwrap();
    assert!(
        header.starts_with("[gd_scene ") && header.ends_with(']') && header.contains(" format=3"),
        "{header}"
    );
    let attr = |heading: &str, key: &str| -> Option<String> {
        let at = heading.find(&format!(" {key}="))? + key.len() + 2;
        let rest = &heading[at..];
        Some(match rest.strip_prefix('"') {
            Some(q) => q[..q.find('"').unwrap()].to_string(),
            None => rest[..rest.find([' ', ']']).unwrap()].to_string(),
        })
    };
    let mut nodes: Vec<TscnNode> = Vec::new();
    let mut resources = 0;
    for line in lines.filter(|l| !l.trim().is_empty() && !l.starts_with(';')) {
        if line.starts_with("[node ") {
            assert!(line.ends_with(']'), "{line}");
            nodes.push(TscnNode {
                name: attr(line, "name").expect("a node has a name"),
                kind: attr(line, "type").expect("a node has a type"),
                parent: attr(line, "parent"),
                properties: Vec::new(),
            });
        } else if line.starts_with("[ext_resource ") || line.starts_with("[sub_resource ") {
            resources += 1;
        } else {
            let (key, value) = line
                .split_once(" = ")
                .unwrap_or_else(|| panic!("not key = value: {line}"));
            nodes
                .last_mut()
                .expect("a property before any node")
                .properties
                .push((key.into(), value.into()));
        }
    }
    if let Some(steps) = attr(header, "load_steps") {
        assert_eq!(steps.parse::<usize>().unwrap(), resources + 1, "{header}");
    }
    assert!(nodes[0].parent.is_none(), "the root has a parent");
    assert!(
        nodes[1..].iter().all(|n| n.parent.is_some()),
        "a second root"
    );
    let names: BTreeSet<(&Option<String>, &String)> =
        nodes.iter().map(|n| (&n.parent, &n.name)).collect();
    assert_eq!(
        names.len(),
        nodes.len(),
        "node names repeat under one parent"
    );
    nodes
}

/// The positions of a `.tscn`'s `LightmapProbe` nodes, in order.
fn tscn_probes(path: &Path) -> Vec<[f64; 3]> {
    let nodes = tscn_nodes(&std::fs::read_to_string(path).unwrap());
    assert_eq!(nodes[0].kind, "Node3D");
    nodes
        .iter()
        .filter(|n| n.kind == "LightmapProbe")
        .map(|n| {
            assert_eq!(n.parent.as_deref(), Some("."), "{}", n.name);
            let t = &n
                .properties
                .iter()
                .find(|(k, _)| k == "transform")
                .unwrap()
                .1;
            let inner = t
                .strip_prefix("Transform3D(")
                .unwrap()
                .strip_suffix(')')
                .unwrap();
            let v: Vec<f64> = inner.split(", ").map(|x| x.parse().unwrap()).collect();
            assert_eq!(v[..9], [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]);
            [v[9], v[10], v[11]]
        })
        .collect()
}

/// The acceptance: Sponza's probes as `.glb`, without and with the scene
/// mesh, pass the Khronos validator with no error and no warning, read back
/// as one node per probe at its position; the `.tscn` lists every probe.
#[test]
fn sponza_exports_pass_the_khronos_validator() {
    shared_scenes();
    let run = shared_job("place", "configs/sponza.ron", &[]);
    let tmp = tempfile::tempdir().unwrap();
    let copy = tmp.path().join("sponza");
    copy_dir(&run.dir, &copy);
    let (bare, full) = (tmp.path().join("bare"), tmp.path().join("full"));
    let copy_arg = copy.to_str().unwrap();
    export(&[
        copy_arg,
        "--format",
        "glb,tscn",
        "--out",
        bare.to_str().unwrap(),
    ]);
    export(&[
        copy_arg,
        "--format",
        "glb",
        "--scene",
        "--out",
        full.to_str().unwrap(),
    ]);
    // The copy is untouched; each output holds the run whole, with its exports.
    let before: BTreeSet<_> = std::fs::read_dir(&copy)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert!(!before
        .iter()
        .any(|n| n.to_string_lossy().starts_with("probes.glb")));
    for out in [&bare, &full] {
        // Each manifest lists its own set, exports included.
        for name in before.iter().filter(|n| *n != "manifest.json") {
            assert_eq!(
                std::fs::read(copy.join(name)).unwrap(),
                std::fs::read(out.join(name)).unwrap(),
                "{name:?}"
            );
        }
        let o = probeplace(&["inspect", out.to_str().unwrap(), "--quiet"]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    }

    let expected = positions(&copy.join("probes.json"));
    let report = &run.report;
    let (bare_glb, full_glb) = (bare.join("probes.glb"), full.join("probes.glb"));
    for (glb, with_scene) in [(&bare_glb, false), (&full_glb, true)] {
        let back = read_back(glb);
        assert_eq!(back.probes.len(), expected.len(), "{}", glb.display());
        for (i, (got, want)) in back.probes.iter().zip(&expected).enumerate() {
            for a in 0..3 {
                assert_eq!(got[a], want[a] as f32, "probe {i}");
            }
            assert_eq!(back.extras[i]["index"], i);
            assert!(back.extras[i]["clearance"].as_f64().unwrap() > 0.0);
            // Sponza's every probe is listed by some leaf of its octree.
            let b = &back.extras[i]["influence_box"];
            let (lo, hi): ([f64; 3], [f64; 3]) = (
                serde_json::from_value(b["min"].clone()).unwrap(),
                serde_json::from_value(b["max"].clone()).unwrap(),
            );
            // Within the domain's leaves: the last leaf may reach past it.
            let domain = &report["domain"];
            let leaf = report["svo"]["leaf_size"].as_f64().unwrap();
            // The child node draws the same box, where importers carry it.
            let (blo, bhi) = back.boxes[i].expect("an influence node");
            let tol = 1e-4 * (1.0 + hi.iter().map(|v| v.abs()).fold(0.0, f64::max));
            for a in 0..3 {
                assert!(
                    (blo[a] - lo[a]).abs() < tol && (bhi[a] - hi[a]).abs() < tol,
                    "probe {i}: {b} vs {blo:?} {bhi:?}"
                );
            }
            for a in 0..3 {
                assert!(lo[a] < hi[a], "probe {i}: {b}");
                assert!(
                    lo[a] >= domain["min"][a].as_f64().unwrap() - 1e-6,
                    "probe {i}: {b}"
                );
                assert!(
                    hi[a] <= domain["max"][a].as_f64().unwrap() + leaf,
                    "probe {i}: {b}"
                );
            }
        }
        let triangles = report["scene"]["triangles"].as_u64().unwrap() as usize;
        assert_eq!(back.scene_triangles, if with_scene { triangles } else { 0 });
    }
    let bytes = |p: &Path| std::fs::metadata(p).unwrap().len();
    eprintln!(
        "sponza: {} probes; probes.glb {} bytes, with the scene {} bytes",
        expected.len(),
        bytes(&bare_glb),
        bytes(&full_glb)
    );
    assert!(bytes(&full_glb) > bytes(&bare_glb));

    let tscn = tscn_probes(&bare.join("probes.tscn"));
    assert_eq!(tscn.len(), expected.len());
    assert_eq!(
        tscn, expected,
        "the .tscn writes probes.json's positions as they are"
    );
    // Its metadata: `fixed` a boolean on every probe, and the influence
    // box an AABB (position, size) in Godot's frame, which is the world's:
    // the box the .glb's extras give.
    let glb_extras = read_back(&bare_glb).extras;
    let nodes = tscn_nodes(&std::fs::read_to_string(bare.join("probes.tscn")).unwrap());
    let probes: Vec<&TscnNode> = nodes.iter().filter(|n| n.kind == "LightmapProbe").collect();
    for (i, n) in probes.iter().enumerate() {
        let meta = |k: &str| {
            n.properties
                .iter()
                .find(|(key, _)| key == k)
                .map(|(_, v)| v.as_str())
        };
        assert_eq!(meta("metadata/fixed"), Some("false"), "{}", n.name);
        let aabb = meta("metadata/influence_box").expect("an influence box");
        let v: Vec<f64> = aabb
            .strip_prefix("AABB(")
            .and_then(|s| s.strip_suffix(')'))
            .unwrap()
            .split(", ")
            .map(|x| x.parse().unwrap())
            .collect();
        let b = &glb_extras[i]["influence_box"];
        for a in 0..3 {
            let (lo, hi) = (b["min"][a].as_f64().unwrap(), b["max"][a].as_f64().unwrap());
            assert_eq!(v[a], lo, "{}", n.name);
            assert!(
                (v[3 + a] - (hi - lo)).abs() <= 1e-9 * (1.0 + hi.abs()),
                "{}",
                n.name
            );
        }
    }

    let Some(script) = validator("sponza_exports_pass_the_khronos_validator") else {
        return;
    };
    for r in validate(&script, &[&bare_glb, &full_glb]) {
        let issues = &r["issues"];
        let codes: Vec<String> = issues["messages"]
            .as_array()
            .unwrap()
            .iter()
            .map(|m| {
                format!(
                    "{} (severity {}) at {}: {}",
                    m["code"], m["severity"], m["pointer"], m["message"]
                )
            })
            .collect();
        eprintln!(
            "{}: {} errors, {} warnings, {} infos, {} hints {codes:?}",
            r["file"],
            issues["numErrors"],
            issues["numWarnings"],
            issues["numInfos"],
            issues["numHints"]
        );
        assert_eq!(issues["numErrors"], 0, "{}: {codes:?}", r["file"]);
        assert_eq!(issues["numWarnings"], 0, "{}: {codes:?}", r["file"]);
        assert_eq!(
            r["info"]["generator"],
            format!("probeplace {}", env!("CARGO_PKG_VERSION"))
        );
    }
}

/// An 8 m closed room as an OBJ (the hostile suite's 2 m cube room scaled
/// by 4 in its config).
const ROOM: &str = "v 0 0 0\nv 2 0 0\nv 2 0 2\nv 0 0 2\nv 0 2 0\nv 2 2 0\nv 2 2 2\nv 0 2 2\n\
f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\n";

/// A relocated 8³ grid in the 8 m room, unrefined, with every export in
/// its config: 1 m cells, so the 4³ probes at least 2.5 m from every wall
/// see no surface within a cell diagonal and are switched off.
fn relocated_room(dir: &Path) -> PathBuf {
    std::fs::write(dir.join("room.obj"), ROOM).unwrap();
    let config = dir.join("room.ron");
    std::fs::write(
        &config,
        "(\n    scene: \"room.obj\",\n    scale: 4.0,\n    voxel_size: 0.25,\n    placement: Relocated((cells: (8, 8, 8))),\n    refine: (enabled: false),\n    coverage: (samples: 2000, reference_points: 512),\n    output: \"out\",\n    bake: (resolution: 16, irradiance_resolution: 8, samples: 1, bounces: 1),\n    export: [Ddgi, Unity, Tscn, Glb],\n)\n",
    )
    .unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_probeplace"))
        .args(["place", "room.ron", "--quiet"])
        .current_dir(dir)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    dir.join("out")
}

/// The config's `export` list writes every export with the run, and
/// `probeplace export` of the directory gives the same bytes; the DDGI
/// volume lists the grid in RTXGI's order and reproduces every probe.
#[test]
fn a_relocated_grid_exports_its_ddgi_volume() {
    let tmp = tempfile::tempdir().unwrap();
    let out = relocated_room(tmp.path());
    let report = read_json(&out.join("report.json"));
    let expected = positions(&out.join("probes.json"));
    let names = [
        "ddgi.json",
        "probes.unity.json",
        "probes.tscn",
        "probes.glb",
    ];
    let again = tmp.path().join("again");
    export(&[
        out.to_str().unwrap(),
        "--format",
        "ddgi,unity,tscn,glb",
        "--out",
        again.to_str().unwrap(),
    ]);
    // Into the directory itself: the other files stay as they were.
    let listing = crate::common::dir_files;
    let before = listing(&again);
    export(&[again.to_str().unwrap(), "--format", "tscn"]);
    assert_eq!(listing(&again), before);
    // bake --from writes them again from the placement it reuses.
    let baked = tmp.path().join("baked");
    let o = probeplace(&[
        "bake",
        "--from",
        out.to_str().unwrap(),
        "--out",
        baked.to_str().unwrap(),
        "--quiet",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(baked.join("lightfield.bin").is_file());
    // The bake's exports carry its SH (sh.json) where the format holds it;
    // `probeplace export` of the baked directory writes the same bytes.
    let rebaked = tmp.path().join("rebaked");
    export(&[
        baked.to_str().unwrap(),
        "--format",
        "ddgi,unity,tscn,glb",
        "--out",
        rebaked.to_str().unwrap(),
    ]);
    for name in names {
        let a = std::fs::read(out.join(name)).unwrap();
        assert!(
            a == std::fs::read(again.join(name)).unwrap(),
            "{name}: place and export wrote different bytes"
        );
        let b = std::fs::read(baked.join(name)).unwrap();
        assert!(
            b == std::fs::read(rebaked.join(name)).unwrap(),
            "{name}: bake and export wrote different bytes"
        );
        let has_sh = String::from_utf8_lossy(&b).contains("\"sh");
        assert_eq!(has_sh, name != "probes.tscn", "{name}");
        assert_eq!(a == b, name == "probes.tscn", "{name}");
    }

    let d = read_json(&out.join("ddgi.json"));
    assert_eq!(d["format"], "probeplace.ddgi");
    assert_eq!(
        d["provenance"]["config_hash"],
        report["provenance"]["config_hash"]
    );
    let n: [u32; 3] = serde_json::from_value(d["counts"].clone()).unwrap();
    assert_eq!(n, [8, 8, 8]);
    let (origin, spacing): ([f64; 3], [f64; 3]) = (
        serde_json::from_value(d["origin"].clone()).unwrap(),
        serde_json::from_value(d["spacing"].clone()).unwrap(),
    );
    let probes = d["probes"].as_array().unwrap();
    assert_eq!(probes.len(), 512);
    let off = report["placement_stats"]["switched_off_no_surface"]
        .as_u64()
        .unwrap()
        + report["placement_stats"]["switched_off_inside"]
            .as_u64()
            .unwrap();
    assert!(off > 0, "the room's middle probes are switched off");
    assert_eq!(d["inactive"], off);
    assert_eq!(d["active"], expected.len());
    let mut seen = vec![false; expected.len()];
    for (k, e) in probes.iter().enumerate() {
        let c: [u32; 3] = serde_json::from_value(e["coords"].clone()).unwrap();
        // RTXGI's DDGIGetProbeIndex, Y up: x fastest, then z, then y.
        assert_eq!((c[0] + n[0] * c[2] + n[0] * n[2] * c[1]) as usize, k);
        let offset: [f64; 3] = serde_json::from_value(e["offset"].clone()).unwrap();
        match e["state"].as_str().unwrap() {
            "active" => {
                let i = e["probe"].as_u64().unwrap() as usize;
                assert!(!seen[i], "probe {i} listed twice");
                seen[i] = true;
                for a in 0..3 {
                    let rebuilt = origin[a] + f64::from(c[a]) * spacing[a] + offset[a];
                    assert!(
                        (rebuilt - expected[i][a]).abs() <= 1e-6 * spacing[a],
                        "probe {i}: {rebuilt} against {}",
                        expected[i][a]
                    );
                    assert!(
                        offset[a].abs() <= 0.45 * spacing[a] * (1.0 + 1e-6),
                        "probe {i}: {offset:?}"
                    );
                }
            }
            "inactive" => {
                assert!(e["probe"].is_null());
                assert_eq!(offset, [0.0; 3]);
                // Switched off for seeing no wall: the room's middle.
                assert!(c.iter().all(|&v| (2..6).contains(&v)), "{c:?}");
            }
            s => panic!("state {s}"),
        }
    }
    assert!(
        seen.iter().all(|&s| s),
        "every probe of probes.json is in the volume"
    );
    let moved = probes
        .iter()
        .filter(|e| e["offset"] != serde_json::json!([0.0, 0.0, 0.0]))
        .count();
    assert_eq!(
        moved as u64,
        report["placement_stats"]["relocated"].as_u64().unwrap()
    );

    // The Unity file matches the importer's schema, and holds the probes.
    let unity = read_json(&out.join("probes.unity.json"));
    let schema = read_json(&root().join("integrations/unity/probes.unity.schema.json"));
    check_schema(&unity, &schema, "probes.unity.json");
    let flat: Vec<f64> = serde_json::from_value(unity["positions"].clone()).unwrap();
    assert_eq!(flat, expected.iter().flatten().copied().collect::<Vec<_>>());
    assert_eq!(unity["count"], expected.len());
    // And the Godot scene and the glTF hold them as well.
    assert_eq!(tscn_probes(&out.join("probes.tscn")), expected);
    assert_eq!(
        read_back(&out.join("probes.glb")).probes.len(),
        expected.len()
    );
}

/// Checks `value` against the JSON-schema subset the Unity schema uses:
/// `type`, `const`, `required`, `properties`, `additionalProperties:
/// false`, `items`, `minimum`.
fn check_schema(value: &Value, schema: &Value, at: &str) {
    if let Some(c) = schema.get("const") {
        assert_eq!(value, c, "{at}");
    }
    if let Some(t) = schema["type"].as_str() {
        let ok = match t {
            "object" => value.is_object(),
            "array" => value.is_array(),
            "string" => value.is_string(),
            "integer" => value.is_i64() || value.is_u64(),
            "number" => value.is_number(),
            "boolean" => value.is_boolean(),
            other => panic!("schema type {other} not supported here"),
        };
        assert!(ok, "{at}: {value} is not of type {t}");
    }
    if let Some(m) = schema["minimum"].as_f64() {
        assert!(value.as_f64().unwrap() >= m, "{at}: {value} < {m}");
    }
    if let Some(required) = schema["required"].as_array() {
        for r in required {
            assert!(
                value.get(r.as_str().unwrap()).is_some(),
                "{at}: {r} missing"
            );
        }
    }
    if let Some(props) = schema["properties"].as_object() {
        for (k, v) in value.as_object().unwrap() {
            match props.get(k) {
                Some(s) => check_schema(v, s, &format!("{at}.{k}")),
                None => assert!(
                    schema["additionalProperties"] != false,
                    "{at}: {k} is not in the schema"
                ),
            }
        }
    }
    if let (Some(items), Some(a)) = (schema.get("items"), value.as_array()) {
        for (i, v) in a.iter().enumerate() {
            check_schema(v, items, &format!("{at}[{i}]"));
        }
    }
}

/// The Unity importer's `ProbesUnityFile` declares exactly the schema's
/// fields, each with the C# type `JsonUtility` reads that JSON type into.
#[test]
fn the_unity_importer_declares_the_schema_fields() {
    let dir = root().join("integrations/unity");
    let schema = read_json(&dir.join("probes.unity.schema.json"));
    let source = std::fs::read_to_string(dir.join("ProbeplaceImporter.cs")).unwrap();
    let class = source
        .split("public class ProbesUnityFile")
        .nth(1)
        .expect("ProbesUnityFile is declared");
    let body = &class[class.find('{').unwrap() + 1..class.find('}').unwrap()];
    let mut fields = std::collections::BTreeMap::new();
    for line in body
        .lines()
        .map(str::trim)
        .filter(|l| !l.is_empty() && !l.starts_with("//"))
    {
        let decl = line
            .strip_prefix("public ")
            .and_then(|l| l.strip_suffix(';'))
            .unwrap_or_else(|| panic!("not a public field: {line}"));
        let (ty, name) = decl.split_once(' ').unwrap();
        fields.insert(name.to_string(), ty.to_string());
    }
    let props = schema["properties"].as_object().unwrap();
    let declared: BTreeSet<&String> = fields.keys().collect();
    let specified: BTreeSet<&String> = props.keys().collect();
    assert_eq!(declared, specified, "ProbesUnityFile against the schema");
    let required: BTreeSet<&str> = schema["required"]
        .as_array()
        .unwrap()
        .iter()
        .map(|r| r.as_str().unwrap())
        .collect();
    assert_eq!(required.len(), props.len(), "every field is required");
    for (name, ty) in &fields {
        let p = &props[name];
        let json_type = match (p["type"].as_str(), &p["const"]) {
            (Some(t), _) => t.to_string(),
            (None, Value::String(_)) => "string".into(),
            (None, Value::Number(n)) if n.is_u64() => "integer".into(),
            other => panic!("{name}: {other:?}"),
        };
        let want = match json_type.as_str() {
            "string" => "string",
            "integer" => "int",
            "array" => {
                assert_eq!(p["items"]["type"], "number", "{name}");
                "float[]"
            }
            other => panic!("{name}: {other}"),
        };
        assert_eq!(ty, want, "{name}");
    }
    // The importer checks the format the exporter writes.
    assert!(source.contains("public const string Format = \"probeplace.unity\";"));
    assert_eq!(schema["properties"]["format"]["const"], "probeplace.unity");
}

/// A DDGI volume of a placement that is no grid, a directory that is no
/// output, an unknown format, `--scene` without glb: each one line, exit 2,
/// nothing written.
#[test]
fn exports_that_cannot_be_written_are_refused() {
    let run = shared_job("place", "configs/cornell.ron", &["--no-refine"]);
    let tmp = tempfile::tempdir().unwrap();
    let copy = tmp.path().join("run");
    copy_dir(&run.dir, &copy);
    let before: Vec<_> = std::fs::read_dir(&copy)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    let refused = |args: &[&str]| refused_in(tmp.path(), args, &[]).line;

    let e = refused(&["export", "run", "--format", "ddgi", "--out", "out"]);
    assert!(
        e.starts_with("error: run: --format ddgi: a DDGI volume needs"),
        "{e}"
    );
    assert!(e.contains("sdf-skeleton"), "{e}");
    std::fs::write(tmp.path().join("notes.txt"), "mine").unwrap();
    let e = refused(&["export", ".", "--format", "glb", "--out", "out"]);
    assert!(e.contains("holds no report.json"), "{e}");
    let e = refused(&["export", "run", "--format", "fbx"]);
    assert!(
        e.contains("fbx") && e.contains("glb, tscn, unity, ddgi"),
        "{e}"
    );
    let e = refused(&["export", "run", "--format", "tscn", "--scene"]);
    assert!(e.contains("--scene"), "{e}");
    // A probes.json of another run beside this report.
    let other = shared_job("place", "configs/cornell.ron", &[]);
    std::fs::copy(other.dir.join("probes.json"), copy.join("probes.json")).unwrap();
    let e = refused(&["export", "run", "--format", "glb", "--out", "out"]);
    assert!(
        e.starts_with("error: run/probes.json: holds") && e.contains("manifest.json records"),
        "{e}"
    );
    // With its manifest entry edited to match, the provenance refuses it.
    crate::common::reseal(&copy);
    let e = refused(&["export", "run", "--format", "glb", "--out", "out"]);
    assert!(
        e.starts_with("error: run/probes.json: comes from another run"),
        "{e}"
    );
    let after: Vec<_> = std::fs::read_dir(&copy)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(before, after, "a refused export wrote into the run");
}

/// A config's `export` list is checked before any stage: an unknown
/// format, and a DDGI volume of a placement that is no unrefined grid, are
/// refused naming the field where it is written.
#[test]
fn config_exports_are_checked_before_any_stage() {
    let tmp = tempfile::tempdir().unwrap();
    std::fs::write(tmp.path().join("room.obj"), ROOM).unwrap();
    for (placement, why) in [
        ("SdfSkeleton(())", "another method"),
        ("Relocated((cells: (2, 2, 2)))", "refinement"),
    ] {
        std::fs::write(
            tmp.path().join("room.ron"),
            format!("(\n    scene: \"room.obj\",\n    voxel_size: 0.25,\n    placement: {placement},\n    output: \"out\",\n    export: [Glb, Ddgi],\n)\n"),
        )
        .unwrap();
        let e = refused_in(tmp.path(), &["place", "room.ron"], &[]).line;
        assert!(
            e.starts_with("error: room.ron:6:5: export: Ddgi needs"),
            "{e}"
        );
        assert!(e.contains(why), "{e}");
    }
    std::fs::write(
        tmp.path().join("room.ron"),
        "(\n    scene: \"room.obj\",\n    export: [Glb, Fbx],\n)\n",
    )
    .unwrap();
    let e = refused_in(tmp.path(), &["place", "room.ron"], &[]).line;
    assert!(e.starts_with("error: room.ron:3:19: export[1]: "), "{e}");
    assert!(e.contains("Fbx") && e.contains("GlbWithScene"), "{e}");
}

/// `bake` writes each probe's SH L2 and the path-traced irradiance at the
/// probe (`sh.json`); the exports hand it on: the Unity file as
/// `SphericalHarmonicsL2` coefficients in Unity's frame and convention,
/// glTF nodes and the file's own rows in the world frame. Before a bake
/// the Unity file's `sh` is empty.
#[test]
fn a_bake_hands_its_sh_to_the_exports() {
    let bake = shared_job("bake", "configs/cornell.ron", &[]);
    let sh = read_json(&bake.dir.join("sh.json"));
    assert_eq!(sh["format"], "probeplace.sh");
    assert_eq!(sh["provenance"], bake.report["provenance"]);
    let probes = sh["probes"].as_array().unwrap();
    let n = bake.report["probe_count"].as_u64().unwrap() as usize;
    assert_eq!(probes.len(), n);
    let rgb = |v: &Value| -> [f64; 3] { serde_json::from_value(v.clone()).unwrap() };
    // The SH's irradiance along each axis is near the reference at the
    // probe (band 2 and noise: the report's own figure says how near).
    let err = bake.report["bake"]["sh_axis_error"].as_f64().unwrap();
    assert!((0.0..0.25).contains(&err), "sh_axis_error {err}");
    for p in probes {
        assert_eq!(p["total"].as_array().unwrap().len(), 9);
        let axes = p["irradiance_axes"].as_array().unwrap();
        assert_eq!(axes.len(), 6);
        assert!(axes
            .iter()
            .all(|a| rgb(a).iter().all(|v| v.is_finite() && *v >= 0.0)));
    }

    let out = tempfile::tempdir().unwrap();
    let o = out.path().to_str().unwrap();
    export(&[
        bake.dir.to_str().unwrap(),
        "--format",
        "unity,glb",
        "--out",
        o,
    ]);
    let unity = read_json(&out.path().join("probes.unity.json"));
    // Which light the SH holds: the file says it in docs/engines.md's
    // words, and the docs say it where a Unity user reads the workflow.
    let engines = std::fs::read_to_string("docs/engines.md").unwrap();
    let holds = engines
        .lines()
        .skip_while(|l| *l != "## Which light the SH holds")
        .find(|l| l.starts_with("The SH holds"))
        .expect("docs/engines.md says which light the SH holds");
    assert!(
        holds.contains("no direct light from point, spot or directional lights")
            && holds.contains("Mixed (Baked Indirect) or Realtime"),
        "{holds}"
    );
    let convention = unity["sh_convention"].as_str().unwrap();
    assert!(convention.ends_with(holds), "{convention}");
    let u: Vec<f64> = serde_json::from_value(unity["sh"].clone()).unwrap();
    assert_eq!(u.len(), 27 * n);
    // Unity's convention, from the published constants: irradiance over
    // π (band factors π, 2π/3, π/4) times each basis function's constant,
    // band 1 in y, z, x order, and x negated for Unity's frame.
    let pi = std::f64::consts::PI;
    let band = [
        pi,
        2.0 * pi / 3.0,
        2.0 * pi / 3.0,
        2.0 * pi / 3.0,
        pi / 4.0,
        pi / 4.0,
        pi / 4.0,
        pi / 4.0,
        pi / 4.0,
    ];
    let constant = [
        0.282095, 0.488603, 0.488603, 0.488603, 1.092548, 1.092548, 0.315392, 1.092548, 0.546274,
    ];
    let mirror = [1.0, 1.0, 1.0, -1.0, -1.0, 1.0, 1.0, -1.0, 1.0];
    for (i, p) in probes.iter().enumerate() {
        let total = p["total"].as_array().unwrap();
        for c in 0..3 {
            for k in 0..9 {
                let want = rgb(&total[k])[c] * band[k] * constant[k] / pi * mirror[k];
                let got = u[27 * i + 9 * c + k];
                assert!(
                    (got - want).abs() <= 1e-4 * want.abs().max(1e-3),
                    "probe {i} channel {c} coefficient {k}: {got} vs {want}"
                );
            }
        }
    }
    let glb = read_back(&out.path().join("probes.glb"));
    assert_eq!(glb.extras.len(), n);
    for (i, extras) in glb.extras.iter().enumerate() {
        assert_eq!(extras["sh_l2"], probes[i]["total"], "probe {i}");
    }

    // An sh.json of another run, or damaged, is refused in one line naming
    // it, by export and by a bake reusing the directory; nothing written.
    let work = tempfile::tempdir().unwrap();
    let copy = work.path().join("baked");
    copy_dir(&bake.dir, &copy);
    let other = sh["probes"].as_array().unwrap()[..n - 1].to_vec();
    let mut short = sh.clone();
    short["probes"] = Value::Array(other);
    std::fs::write(copy.join("sh.json"), short.to_string()).unwrap();
    crate::common::reseal(&copy);
    let c = copy.to_str().unwrap();
    for args in [
        vec!["export", c, "--format", "unity", "--out", "out"],
        vec!["bake", "--from", c, "--out", "out"],
    ] {
        let r = refused_in(work.path(), &args, &[]);
        assert!(r.line.contains("sh.json"), "{args:?}: {}", r.line);
    }
    std::fs::write(copy.join("sh.json"), "{\"format\": \"probeplace.sh\"").unwrap();
    crate::common::reseal(&copy);
    let r = refused_in(
        work.path(),
        &["export", c, "--format", "glb", "--out", "out"],
        &[],
    );
    assert!(
        r.line.contains("sh.json: not a probeplace SH file"),
        "{}",
        r.line
    );

    // A place run has no SH to hand on.
    let placed = shared_job("place", "configs/cornell.ron", &[]);
    assert!(!placed.dir.join("sh.json").exists());
    let out = tempfile::tempdir().unwrap();
    let o = out.path().to_str().unwrap();
    export(&[
        placed.dir.to_str().unwrap(),
        "--format",
        "unity",
        "--out",
        o,
    ]);
    let unity = read_json(&out.path().join("probes.unity.json"));
    assert_eq!(unity["sh"], serde_json::json!([]));
}

/// The synopsis's four formats together on a run that is no grid: the
/// three it can give are written, and the DDGI volume is left out with one
/// warning line saying why (issue 48); alone, it is refused.
#[test]
fn a_multi_format_export_writes_what_it_can_and_names_what_it_cannot() {
    let run = shared_job("place", "configs/cornell.ron", &["--no-refine"]);
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("out");
    let o = probeplace(&[
        "export",
        run.dir.to_str().unwrap(),
        "--format",
        "glb,tscn,unity,ddgi",
        "--out",
        out.to_str().unwrap(),
    ]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{stderr}");
    let warnings: Vec<&str> = stderr
        .lines()
        .filter(|l| l.starts_with("warning: "))
        .collect();
    assert_eq!(warnings.len(), 1, "{stderr}");
    assert!(
        warnings[0].starts_with("warning: --format ddgi: not written: a DDGI volume needs"),
        "{stderr}"
    );
    for name in ["probes.glb", "probes.tscn", "probes.unity.json"] {
        assert!(out.join(name).is_file(), "{name}");
    }
    assert!(!out.join("ddgi.json").exists());
    assert_manifest_holds(&dir_files(&out));
}

/// `bake.sh_direct: Include` adds the point light's direct light to the SH
/// and to the reference irradiance beside it, and nothing else: in a
/// closed room lit by one point light, each probe's SH differs from the
/// `Exclude` bake's by the light's exact projection (`I/d² · Y(ω)`, ω
/// towards the light), and each axis's reference by `I · max(0, n·ω)/d²`.
/// The files say which light they hold, in docs/engines.md's words.
#[test]
fn sh_direct_include_adds_the_delta_lights_direct_light_exactly() {
    let d = tempfile::tempdir().unwrap();
    std::fs::write(d.path().join("room.obj"), crate::hostile::CUBE_ROOM).unwrap();
    let light = [1.0f64, 1.3, 0.8];
    let intensity = 2.0f64;
    let bake = |mode: &str| -> Value {
        let config = d.path().join(format!("{mode}.ron"));
        std::fs::write(
            &config,
            format!(
                "(scene: \"room.obj\", voxel_size: 0.1, seed: 3,\n\
                 lights: [Point(position: ({}, {}, {}), intensity: ({intensity}, {intensity}, {intensity}))],\n\
                 bake: (resolution: 8, irradiance_resolution: 8, samples: 1, bounces: 1, sh_rays: 128, sh_direct: {mode}),\n)\n",
                light[0], light[1], light[2]
            ),
        )
        .unwrap();
        let out = d.path().join(mode);
        run_job("bake", &config, &out, &[]);
        read_json(&out.join("sh.json"))
    };
    let (exclude, include) = (bake("Exclude"), bake("Include"));
    let engines = std::fs::read_to_string(root().join("docs/engines.md")).unwrap();
    for (sh, mode) in [(&exclude, "Exclude"), (&include, "Include")] {
        assert_eq!(sh["sh_direct"], mode);
        let holds = sh["holds"].as_str().unwrap();
        assert!(engines.contains(holds), "docs/engines.md lacks {holds:?}");
    }
    assert_ne!(exclude["holds"], include["holds"]);
    let positions: Vec<[f64; 3]> = read_json(&d.path().join("Include/probes.json"))["probes"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| serde_json::from_value(p["position"].clone()).unwrap())
        .collect();
    let rows = |sh: &Value, i: usize, key: &str| -> Vec<[f64; 3]> {
        serde_json::from_value(sh["probes"][i][key].clone()).unwrap()
    };
    assert!(!positions.is_empty());
    for (i, p) in positions.iter().enumerate() {
        let to: [f64; 3] = std::array::from_fn(|a| light[a] - p[a]);
        let d2: f64 = to.iter().map(|v| v * v).sum();
        let w = to.map(|v| v / d2.sqrt());
        let e = intensity / d2;
        // Sloan's basis: Y00, Y1-1 (y), Y10 (z), Y11 (x), ...
        let y = [0.282095, 0.488603 * w[1], 0.488603 * w[2], 0.488603 * w[0]];
        let (a, b) = (rows(&exclude, i, "total"), rows(&include, i, "total"));
        for k in 0..4 {
            for c in 0..3 {
                let got = b[k][c] - a[k][c];
                assert!(
                    (got - e * y[k]).abs() <= 1e-3 * e,
                    "probe {i} coefficient {k}: {got} against {}",
                    e * y[k]
                );
            }
        }
        // The indirect part is the same light either way.
        assert_eq!(rows(&exclude, i, "indirect"), rows(&include, i, "indirect"));
        let (a, b) = (
            rows(&exclude, i, "irradiance_axes"),
            rows(&include, i, "irradiance_axes"),
        );
        let axes = [
            [1.0, 0.0, 0.0],
            [-1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, -1.0, 0.0],
            [0.0, 0.0, 1.0],
            [0.0, 0.0, -1.0],
        ];
        for (k, n) in axes.iter().enumerate() {
            let cos: f64 = (0..3).map(|a| n[a] * w[a]).sum::<f64>().max(0.0);
            let got = b[k][0] - a[k][0];
            assert!(
                (got - e * cos).abs() <= 1e-3 * e,
                "probe {i} axis {k}: {got} against {}",
                e * cos
            );
        }
    }
}
