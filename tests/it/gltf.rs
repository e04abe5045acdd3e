//! glTF 2.0 input (issue 48): files written by the test kit's builder
//! (`probeplace::fixtures::gltf_writer`) read as the specification says —
//! containers, node hierarchy, instancing, mirrored nodes, primitive modes,
//! quantized and sparse accessors, materials and punctual lights — and
//! hostile ones refused in one line naming the object at fault.

use glam::{DVec3, Vec3};
use probeplace::config::{Light, UpAxis};
use probeplace::fixtures::gltf_writer::{from_scene, Builder, Positions};
use probeplace::scene::{self, Scene};
use serde_json::json;

fn world(s: &Scene, v: Vec3) -> DVec3 {
    s.to_world(v)
}

fn close(a: DVec3, b: DVec3) -> bool {
    (a - b).length() < 1e-5
}

#[test]
fn glb_gltf_with_a_bin_and_a_data_uri_read_alike_and_match_the_obj() {
    let dir = tempfile::tempdir().unwrap();
    let f = probeplace::fixtures::cornell_box();
    std::fs::write(dir.path().join("cornell_box.obj"), &f.obj).unwrap();
    std::fs::write(dir.path().join("cornell_box.mtl"), &f.mtl).unwrap();
    let obj = scene::load(&dir.path().join("cornell_box.obj"), 0.001, UpAxis::Y).unwrap();
    let b = from_scene(&obj);
    std::fs::write(dir.path().join("box.glb"), b.glb()).unwrap();
    std::fs::write(dir.path().join("box data.bin"), b.bin()).unwrap();
    std::fs::write(dir.path().join("box.gltf"), b.gltf(Some("box%20data.bin"))).unwrap();
    std::fs::write(dir.path().join("inline.gltf"), b.gltf(None)).unwrap();
    let glb = scene::load(&dir.path().join("box.glb"), 1.0, UpAxis::Y).unwrap();
    for other in ["box.gltf", "inline.gltf"] {
        let s = scene::load(&dir.path().join(other), 1.0, UpAxis::Y).unwrap();
        assert_eq!(s.triangles, glb.triangles, "{other}");
        assert_eq!(s.material_ids, glb.material_ids, "{other}");
        assert_eq!(s.origin, glb.origin, "{other}");
    }
    assert_eq!(glb.triangles.len(), obj.triangles.len());
    assert_eq!(glb.material_ids, obj.material_ids);
    for (a, b) in glb.triangles.iter().zip(&obj.triangles) {
        for k in 0..3 {
            assert!(close(world(&glb, a[k]), world(&obj, b[k])), "{a:?} {b:?}");
        }
    }
    for (g, o) in glb.materials.iter().zip(&obj.materials) {
        assert_eq!(g.name, o.name);
        assert_eq!(g.diffuse, o.diffuse);
        assert_eq!(g.emission, o.emission, "{}", g.name);
    }
    assert!(
        glb.lights.is_empty() && glb.warnings.is_empty(),
        "{:?}",
        glb.warnings
    );
    // The GLB magic decides, whatever the name.
    std::fs::copy(dir.path().join("box.glb"), dir.path().join("renamed.obj")).unwrap();
    let renamed = scene::load(&dir.path().join("renamed.obj"), 1.0, UpAxis::Y).unwrap();
    assert_eq!(renamed.triangles, glb.triangles);
}

#[test]
fn nodes_compose_instance_and_mirror_without_turning_faces_around() {
    let mut b = Builder::new();
    let mesh = b.unit_quad(None);
    let s = std::f32::consts::FRAC_1_SQRT_2;
    // Rotated 90° about +X: the quad's +Y normal turns to +Z.
    let turned = b.node(json!({"mesh": mesh, "rotation": [s, 0.0, 0.0, s]}));
    // Mirrored in x: its winding is reversed back, so it still faces +Y.
    let mirrored =
        b.node(json!({"mesh": mesh, "scale": [-2.0, 1.0, 1.0], "translation": [0.0, 5.0, 0.0]}));
    let parent = b.node(json!({"translation": [10.0, 0.0, 0.0], "children": [turned, mirrored]}));
    let by_matrix = b.node(json!({"mesh": mesh, "matrix": [1,0,0,0, 0,1,0,0, 0,0,1,0, -3,0,0,1]}));
    b.scene(&[parent, by_matrix]);
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("nodes.glb");
    std::fs::write(&path, b.glb()).unwrap();
    let sc = scene::load(&path, 1.0, UpAxis::Y).unwrap();
    assert_eq!(sc.triangles.len(), 6, "three instances of two triangles");
    // Depth-first node order: turned, mirrored, then the matrix node.
    for k in 0..2 {
        assert!(
            (sc.normals[k] - Vec3::Z).length() < 1e-6,
            "{:?}",
            sc.normals[k]
        );
        assert!(
            (sc.normals[2 + k] - Vec3::Y).length() < 1e-6,
            "mirrored: {:?}",
            sc.normals[2 + k]
        );
        assert!((sc.normals[4 + k] - Vec3::Y).length() < 1e-6);
    }
    let first = world(&sc, sc.triangles[0][1]);
    assert!(close(first, DVec3::new(11.0, 0.0, 0.0)), "{first}");
    let corners: Vec<DVec3> = sc.triangles[2..4]
        .iter()
        .flatten()
        .map(|&v| world(&sc, v))
        .collect();
    assert!(
        corners
            .iter()
            .any(|&c| close(c, DVec3::new(8.0, 5.0, -1.0))),
        "{corners:?}"
    );
    assert!(corners.iter().all(|c| (c.y - 5.0).abs() < 1e-9));
    let moved = world(&sc, sc.triangles[4][1]);
    assert!(close(moved, DVec3::new(-2.0, 0.0, 0.0)), "{moved}");
    // Z up and a scale apply after the nodes, as for an OBJ.
    let z = scene::load(&path, 2.0, UpAxis::Z).unwrap();
    let p = world(&z, z.triangles[0][1]);
    assert!(close(p, DVec3::new(22.0, 0.0, 0.0)), "{p}");
    // File +Z (the turned quad's normal) is world +Y when Z is up.
    assert!(
        (z.normals[0] - Vec3::Y).length() < 1e-6,
        "{:?}",
        z.normals[0]
    );
}

#[test]
fn strips_fans_points_quantized_and_sparse_accessors_unfold_as_specified() {
    let mut b = Builder::new();
    let strip = b.positions(
        &[
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 0.0, -1.0],
            [1.0, 0.0, -1.0],
        ],
        Positions::Float,
    );
    let fan = b.positions(
        &[
            [0.0, 1.0, 0.0],
            [1.0, 1.0, 0.0],
            [1.0, 1.0, -1.0],
            [0.0, 1.0, -1.0],
            [-1.0, 1.0, -1.0],
        ],
        Positions::Float,
    );
    let quantized = b.positions(
        &[[0.0, 0.5, 0.0], [1.0, 0.5, 0.0], [1.0, 0.5, 1.0]],
        Positions::NormalizedU16,
    );
    let sparse = b.positions(&[[0.0, 0.0, 0.0]; 3], Positions::Float);
    let mesh = b.mesh(
        "modes",
        &[
            (strip, None, 5, None),
            (fan, None, 6, None),
            (strip, None, 0, None),
            (quantized, None, 4, None),
            (sparse, None, 4, None),
        ],
    );
    let node = b.node(json!({"mesh": mesh}));
    b.scene(&[node]);
    // The sparse accessor: all its vertices zero but two, substituted.
    let sub: Vec<u8> = [1u8, 2, 0, 0]
        .into_iter()
        .chain(
            [[2.0f32, 0.0, 0.0], [0.0, 0.0, -2.0]]
                .iter()
                .flatten()
                .flat_map(|v| v.to_le_bytes()),
        )
        .collect();
    let bin_len = b.bin().len();
    let mut doc = b.document(None);
    let views = doc["bufferViews"].as_array().unwrap().len();
    doc["bufferViews"]
        .as_array_mut()
        .unwrap()
        .push(json!({"buffer": 0, "byteOffset": bin_len, "byteLength": 4}));
    doc["bufferViews"]
        .as_array_mut()
        .unwrap()
        .push(json!({"buffer": 0, "byteOffset": bin_len + 4, "byteLength": 24}));
    let acc = &mut doc["accessors"][sparse];
    acc.as_object_mut().unwrap().remove("bufferView");
    acc["sparse"] = json!({"count": 2, "indices": {"bufferView": views, "componentType": 5121}, "values": {"bufferView": views + 1}});
    let mut bin = b.bin().to_vec();
    bin.extend(&sub);
    doc["buffers"][0] = json!({"byteLength": bin.len(), "uri": "m.bin"});
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("m.bin"), &bin).unwrap();
    let path = dir.path().join("m.gltf");
    std::fs::write(&path, serde_json::to_vec(&doc).unwrap()).unwrap();
    let sc = scene::load(&path, 1.0, UpAxis::Y).unwrap();
    // 2 (strip) + 3 (fan) + 1 (quantized) + 1 (sparse); points skipped.
    assert_eq!(sc.triangles.len(), 7, "{:?}", sc.warnings);
    assert!(
        sc.warnings
            .iter()
            .any(|w| w.contains("skipped 1 primitive")),
        "{:?}",
        sc.warnings
    );
    for n in &sc.normals[..5] {
        assert!(
            (*n - Vec3::Y).length() < 1e-6,
            "strips and fans keep their winding: {n:?}"
        );
    }
    let q: Vec<DVec3> = sc.triangles[5].iter().map(|&v| world(&sc, v)).collect();
    assert!(close(q[2], DVec3::new(1.0, 0.5, 1.0)), "{q:?}");
    let sp: Vec<DVec3> = sc.triangles[6].iter().map(|&v| world(&sc, v)).collect();
    assert!(
        close(sp[1], DVec3::new(2.0, 0.0, 0.0)) && close(sp[2], DVec3::new(0.0, 0.0, -2.0)),
        "{sp:?}"
    );
}

#[test]
fn punctual_lights_and_emissive_strength_become_the_scenes_lights() {
    let mut b = Builder::new();
    let lamp = b.material("lamp", [0.5; 3], 0.0, 1.0, [4.0, 2.0, 0.0]);
    let mesh = b.unit_quad(Some(lamp));
    let point = b.light(
        json!({"type": "point", "color": [1.0, 0.5, 0.25], "intensity": 8.0, "range": 10.0}),
    );
    let spot = b.light(json!({"type": "spot", "intensity": 2.0, "spot": {"innerConeAngle": 0.2, "outerConeAngle": 0.5}}));
    let sun = b.light(json!({"type": "directional", "intensity": 3.0}));
    let s = std::f32::consts::FRAC_1_SQRT_2;
    let n0 = b.node(json!({"mesh": mesh}));
    let n1 = b.node(json!({"translation": [1.0, 2.0, 3.0], "extensions": {"KHR_lights_punctual": {"light": point}}}));
    // −Z turned by −90° about +X points down (−Y).
    let n2 = b.node(json!({"translation": [0.0, 4.0, 0.0], "rotation": [-s, 0.0, 0.0, s], "extensions": {"KHR_lights_punctual": {"light": spot}}}));
    let n3 = b.node(json!({"extensions": {"KHR_lights_punctual": {"light": sun}}}));
    b.scene(&[n0, n1, n2, n3]);
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("lit.glb");
    std::fs::write(&path, b.glb()).unwrap();
    let sc = scene::load(&path, 1.0, UpAxis::Y).unwrap();
    assert_eq!(sc.materials[0].emission, [4.0, 2.0, 0.0]);
    assert_eq!(sc.lights.len(), 3);
    match &sc.lights[0] {
        Light::Point {
            position,
            intensity,
        } => {
            assert_eq!(position.0, [1.0, 2.0, 3.0]);
            assert_eq!(intensity.0, [8.0, 4.0, 2.0]);
        }
        l => panic!("{l:?}"),
    }
    match &sc.lights[1] {
        Light::Spot {
            direction,
            cone_degrees,
            edge_degrees,
            ..
        } => {
            assert!(
                (Vec3::from(direction.0) - Vec3::NEG_Y).length() < 1e-6,
                "{direction:?}"
            );
            assert!((cone_degrees.0 - 0.5f32.to_degrees()).abs() < 1e-4);
            assert!((edge_degrees.0 - 0.3f32.to_degrees()).abs() < 1e-4);
        }
        l => panic!("{l:?}"),
    }
    match &sc.lights[2] {
        Light::Directional {
            direction,
            irradiance,
        } => {
            assert_eq!(direction.0, [0.0, 0.0, -1.0]);
            assert_eq!(irradiance.0, [3.0; 3]);
        }
        l => panic!("{l:?}"),
    }
    assert!(
        sc.warnings
            .iter()
            .any(|w| w.contains("1 light(s) give a range")),
        "{:?}",
        sc.warnings
    );
    // The converter writes them back: the same lights, read again.
    let again = dir.path().join("again.glb");
    std::fs::write(&again, from_scene(&sc).glb()).unwrap();
    let back = scene::load(&again, 1.0, UpAxis::Y).unwrap();
    assert_eq!(back.lights.len(), 3);
    let nums = |s: &str| -> Vec<f64> {
        s.split(|c: char| !(c.is_ascii_digit() || c == '.' || c == '-' || c == 'e'))
            .filter_map(|t| t.parse().ok())
            .collect()
    };
    for (a, b) in back.lights.iter().zip(&sc.lights) {
        let (a, b) = (format!("{a:?}"), format!("{b:?}"));
        assert_eq!(a.split('(').next(), b.split('(').next());
        let (x, y) = (nums(&a), nums(&b));
        assert_eq!(x.len(), y.len(), "{a} vs {b}");
        for (x, y) in x.iter().zip(&y) {
            assert!((x - y).abs() < 1e-4 * (1.0 + y.abs()), "{a} vs {b}");
        }
    }

    // A run uses them unless the config says `scene_lights: Ignore`.
    let prepare = |extra: &str| {
        let cfg_path = dir.path().join("run.ron");
        let text = format!("(scene: \"lit.glb\", voxel_size: 0.25, domain: Box((min: (-1, -1, -2), max: (2, 5, 4))), {extra})");
        std::fs::write(&cfg_path, &text).unwrap();
        let cfg = probeplace::config::Config::from_text(&text, &cfg_path).unwrap();
        let progress = probeplace::progress::Progress::hidden();
        probeplace::stages::prepare(&cfg, &cfg_path, &text, &progress).unwrap()
    };
    assert_eq!(prepare("").scene.lights.len(), 3);
    assert!(prepare("scene_lights: Ignore,").scene.lights.is_empty());
}

/// Six quads facing into the box `[lo, hi]` (a room's shell), or out of it
/// (`outward`: a closed solid).
/// A box of six quads, facing out (or, for a room, in), of `material`,
/// each quad's texture coordinates spanning the unit square.
fn shell(
    b: &mut Builder,
    lo: [f32; 3],
    hi: [f32; 3],
    outward: bool,
    material: Option<usize>,
) -> usize {
    let c =
        |x: usize, y: usize, z: usize| [[lo[0], hi[0]][x], [lo[1], hi[1]][y], [lo[2], hi[2]][z]];
    // Each face counter-clockwise seen from outside the box.
    let faces = [
        [c(0, 0, 0), c(1, 0, 0), c(1, 0, 1), c(0, 0, 1)], // bottom, −Y
        [c(0, 1, 0), c(0, 1, 1), c(1, 1, 1), c(1, 1, 0)], // top, +Y
        [c(0, 0, 0), c(0, 0, 1), c(0, 1, 1), c(0, 1, 0)], // −X
        [c(1, 0, 0), c(1, 1, 0), c(1, 1, 1), c(1, 0, 1)], // +X
        [c(0, 0, 0), c(0, 1, 0), c(1, 1, 0), c(1, 0, 0)], // −Z
        [c(0, 0, 1), c(1, 0, 1), c(1, 1, 1), c(0, 1, 1)], // +Z
    ];
    let positions: Vec<[f32; 3]> = faces.iter().flatten().copied().collect();
    let mut ix = Vec::new();
    for f in 0..6u32 {
        let q = [4 * f, 4 * f + 1, 4 * f + 2, 4 * f, 4 * f + 2, 4 * f + 3];
        if outward {
            ix.extend(q);
        } else {
            ix.extend([q[0], q[2], q[1], q[3], q[5], q[4]]);
        }
    }
    let pos = b.positions(&positions, Positions::Float);
    let uv = b.texcoords(&[[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]].repeat(6));
    let ix = b.indices(&ix);
    let mut prim =
        json!({"attributes": {"POSITION": pos, "TEXCOORD_0": uv}, "indices": ix, "mode": 4});
    if let Some(m) = material {
        prim["material"] = json!(m);
    }
    b.mesh_json(if outward { "box" } else { "room" }, vec![prim])
}

#[test]
fn an_instanced_textured_lit_hierarchy_places_as_its_flattened_twin() {
    let mut b = Builder::new();
    let room = shell(&mut b, [0.0, 0.0, 0.0], [8.0, 3.0, 6.0], false, None);
    // Checkered pillars: a PNG in the buffer, mirrored by its sampler.
    let texels: Vec<u8> = (0..16u32)
        .flat_map(|i| [if (i % 4 + i / 4) % 2 == 0 { 230 } else { 40 }; 3])
        .collect();
    let image = b.image(
        &probeplace::fixtures::gltf_writer::png_rgb(4, 4, &texels),
        "image/png",
    );
    let sampler = b.sampler(json!({"wrapS": 33648, "wrapT": 33648}));
    let texture = b.texture(image, Some(sampler));
    let stone = b.material("stone", [0.9, 0.85, 0.8], 0.0, 0.8, [0.0; 3]);
    b.material_json(stone)["pbrMetallicRoughness"]["baseColorTexture"] = json!({"index": texture});
    let pillar = shell(
        &mut b,
        [-0.5, 0.0, -0.5],
        [0.5, 1.0, 0.5],
        true,
        Some(stone),
    );
    let lamp = b.light(json!({"type": "point", "intensity": 5.0}));
    let mut pillars = Vec::new();
    for (i, x) in [1.5f32, 3.5, 5.5].into_iter().enumerate() {
        for z in [-1.5f32, 1.5] {
            // Every other one mirrored in x; all 2.5 tall.
            let sx = if i % 2 == 0 { 0.6 } else { -0.6 };
            pillars.push(b.node(
                json!({"mesh": pillar, "translation": [x, 0.0, z], "scale": [sx, 2.5, 0.6]}),
            ));
        }
    }
    let group =
        b.node(json!({"name": "pillars", "translation": [0.5, 0.0, 3.0], "children": pillars}));
    let shell_node = b.node(json!({"mesh": room}));
    let light = b.node(json!({"translation": [4.0, 2.8, 3.0], "extensions": {"KHR_lights_punctual": {"light": lamp}}}));
    b.scene(&[shell_node, group, light]);
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("hall.glb"), b.glb()).unwrap();
    let hall = scene::load(&dir.path().join("hall.glb"), 1.0, UpAxis::Y).unwrap();
    assert_eq!(hall.triangles.len(), 12 * 7);
    assert!(hall.warnings.is_empty(), "{:?}", hall.warnings);
    assert_eq!((hall.textures.len(), hall.texcoords.len()), (1, 12 * 7));
    // Every pillar's faces point out of it, mirrored or not: its top up.
    let tops = hall
        .normals
        .iter()
        .filter(|n| (**n - Vec3::Y).length() < 1e-6)
        .count();
    assert_eq!(
        tops,
        2 * (1 + 6),
        "the room's floor and the six pillar tops face up"
    );
    // The flattened twin, as a GLB and as a .gltf with its buffer (the
    // image in it) in a data URI.
    let flat = from_scene(&hall);
    std::fs::write(dir.path().join("flat.glb"), flat.glb()).unwrap();
    std::fs::write(dir.path().join("inline.gltf"), flat.gltf(None)).unwrap();
    let inline = scene::load(&dir.path().join("inline.gltf"), 1.0, UpAxis::Y).unwrap();
    assert_eq!(inline.textures[0].texels(), hall.textures[0].texels());
    assert_eq!(
        inline.materials[0].diffuse_map.unwrap().wrap,
        hall.materials[0].diffuse_map.unwrap().wrap
    );
    let mut counts = Vec::new();
    for (name, file) in [
        ("hall", "hall.glb"),
        ("flat", "flat.glb"),
        ("inline", "inline.gltf"),
    ] {
        let cfg = dir.path().join(format!("{name}.ron"));
        std::fs::write(
            &cfg,
            format!("(scene: \"{file}\", voxel_size: 0.2, output: \"{name}-out\", seed: 3)"),
        )
        .unwrap();
        let r = crate::common::place(&cfg, &dir.path().join(format!("{name}-out")), &[]);
        counts.push((
            r["probe_count"].as_f64().unwrap(),
            r["coverage"].as_f64().unwrap(),
            r["probes_in_solid"].as_u64().unwrap(),
        ));
    }
    let ((n, c, solid), (m, d, _)) = (counts[0], counts[1]);
    let r = crate::common::read_json(&dir.path().join("hall-out/report.json"));
    assert_eq!(r["scene"]["format"], "gltf");
    assert_eq!(r["scene"]["lights"], 1);
    assert_eq!(solid, 0);
    assert!(c >= 0.99, "coverage {c}");
    assert!(
        (n - m).abs() <= 0.05 * m.max(20.0),
        "{n} probes instanced, {m} flattened"
    );
    assert!(
        (c - d).abs() <= 0.003,
        "coverage {c} instanced, {d} flattened"
    );
    // The same file in another container: the same placement.
    assert_eq!(counts[2], counts[1], "the .gltf places as the GLB");
}

#[test]
fn clamped_material_factors_are_warned_once_naming_the_first_five() {
    let mut b = Builder::new();
    let mats: Vec<usize> = (0..7)
        .map(|i| b.material(&format!("hot{i}"), [2.0, 0.5, 0.5], 0.0, 1.0, [0.0; 3]))
        .collect();
    let mesh = b.unit_quad(Some(mats[6]));
    let node = b.node(json!({"mesh": mesh}));
    b.scene(&[node]);
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("hot.glb");
    std::fs::write(&path, b.glb()).unwrap();
    let sc = scene::load(&path, 1.0, UpAxis::Y).unwrap();
    let w: Vec<&String> = sc
        .warnings
        .iter()
        .filter(|w| w.contains("clamped"))
        .collect();
    assert_eq!(w.len(), 1, "{:?}", sc.warnings);
    assert!(
        w[0].contains("0 (`hot0`)") && w[0].contains("4 (`hot4`)") && w[0].contains("and 2 more"),
        "{}",
        w[0]
    );
    assert!(!w[0].contains("hot5"), "{}", w[0]);
    assert_eq!(sc.materials[6].diffuse, [1.0, 0.5, 0.5]);
}
