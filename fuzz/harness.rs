//! The fuzz targets' bodies: one function per target, taking the raw
//! input. Two things include this file:
//!
//! * the cargo-fuzz binaries in `fuzz/fuzz_targets/` (libFuzzer, nightly:
//!   `cargo +nightly fuzz run TARGET`), one per entry of [`TARGETS`];
//! * the stable-toolchain integration test `tests/it/fuzz.rs`, which replays
//!   `fuzz/seeds/TARGET/*` and `fuzz/regressions/TARGET/*` through the same
//!   functions and runs a short built-in mutation loop on each (CI).
//!
//! A body returns normally for any input the reader refuses (an `Err` is
//! the right answer to garbage) and panics only when a contract is broken:
//! a panic inside a reader, or a value it returned that breaks what its
//! documentation promises. To add a target (e.g. `obj`): write `pub fn
//! obj(data: &[u8])` here, list it in [`TARGETS`] (the integration test
//! then replays and mutates it), and add `fuzz_targets/obj.rs` with its
//! `[[bin]]` in `fuzz/Cargo.toml`, copied from another target's; seeds go
//! in `fuzz/seeds/obj/` (or in [`generated_seeds`]).

#![allow(dead_code)]

use probeplace::lightfield::{self, LightField};
use probeplace::svo::{self, Svo};
use std::path::Path;

/// A target's body.
pub type Target = fn(&[u8]);

/// Every target by name: the cargo-fuzz binary's name and the folder under
/// `fuzz/seeds/` and `fuzz/regressions/`.
pub const TARGETS: &[(&str, Target)] = &[
    ("config", config),
    ("svo", svo),
    ("lightfield", lightfield),
    ("probes", probes),
    ("obj", obj),
    ("gltf", gltf),
];

/// The RON config parser ([`probeplace::config::Config::parse`]) on any
/// text (invalid UTF-8 is replaced, so every input is text): an `Err` is
/// fine, a panic is a bug.
pub fn config(data: &[u8]) {
    let text = String::from_utf8_lossy(data);
    let _ = probeplace::config::Config::parse(&text, Path::new("fuzz.ron"));
}

/// `svo.bin` ([`svo::format::from_bytes`]) on the bytes as they are and,
/// so that mutations get past the checksum to the checks behind it, with
/// the trailing CRC-32 recomputed. A tree it returns must pass
/// [`svo::format::validate`], answer lookups within its arrays and survive
/// the writer unchanged.
pub fn svo(data: &[u8]) {
    svo_exact(data);
    if let Some(fixed) = with_crc(data, svo::format::HEADER_BYTES) {
        svo_exact(&fixed);
    }
}

fn svo_exact(data: &[u8]) {
    let Ok(tree) = svo::format::from_bytes(data) else {
        return;
    };
    svo::format::validate(&tree).expect("from_bytes returned a tree that validate refuses");
    let _ = svo::format::exact_origin(data);
    assert_eq!(tree.bytes(), data.len() as u64);
    let (nodes, payload) = tree.words();
    assert_eq!(nodes.len(), tree.nodes());
    assert!(tree.leaves() <= nodes.len());
    assert!(tree.distinct_lists() <= tree.leaves());
    assert!(payload.len() <= data.len());
    let d = tree.dims.as_u64vec3();
    assert_eq!(
        tree.dense_bytes() as u128,
        4 * (d.x * d.y) as u128 * d.z as u128
    );
    for p in lookup_points(&tree, data) {
        let list = tree.probes_at(p);
        assert!(list.len() <= tree.max_probes as usize, "{p}: {list:?}");
        assert!(list.iter().all(|&i| i < tree.probe_count), "{p}: {list:?}");
    }
    let again = svo::format::from_bytes(&tree.to_bytes())
        .expect("the writer's bytes of a tree the reader accepted are refused");
    assert_eq!(again, tree);
}

/// Points to look up in `tree`: the centres of its corner and middle
/// leaves, points just outside its domain, and a few picked by the input.
fn lookup_points(tree: &Svo, data: &[u8]) -> Vec<glam::Vec3> {
    let d = tree.dims;
    let mut cells = Vec::new();
    for x in [0, d.x / 2, d.x - 1] {
        for y in [0, d.y / 2, d.y - 1] {
            for z in [0, d.z / 2, d.z - 1] {
                cells.push(glam::Vec3::new(x as f32, y as f32, z as f32) + 0.5);
            }
        }
    }
    let mut rng = Rng::new(svo::format::crc32(data) as u64);
    for _ in 0..8 {
        let f = glam::Vec3::new(rng.unit(), rng.unit(), rng.unit());
        cells.push(f * d.as_vec3());
    }
    cells.push(glam::Vec3::splat(-0.5));
    cells.push(d.as_vec3() + 0.5);
    let mut points: Vec<glam::Vec3> = cells
        .into_iter()
        .map(|c| tree.origin + c * tree.leaf_size)
        .collect();
    points.extend([
        glam::Vec3::NAN,
        glam::Vec3::INFINITY,
        glam::Vec3::NEG_INFINITY,
        glam::Vec3::MAX,
    ]);
    points
}

/// `lightfield.bin` ([`lightfield::format::from_bytes`]), as is and with
/// the CRC-32 recomputed. A field it returns must have the documented size
/// and be written back to bytes the reader accepts.
pub fn lightfield(data: &[u8]) {
    lightfield_exact(data);
    if let Some(fixed) = with_crc(data, lightfield::format::HEADER_BYTES) {
        lightfield_exact(&fixed);
    }
}

fn lightfield_exact(data: &[u8]) {
    let Ok(field) = lightfield::format::from_bytes(data) else {
        return;
    };
    assert_eq!(field.bytes(), data.len());
    let p = field.positions.len();
    let texels = p * field.texels();
    assert_eq!(field.radiance.len(), texels);
    assert_eq!(field.normal.len(), texels);
    assert_eq!(field.distance.len(), texels);
    assert_eq!(
        field.pyramid.len() as u32,
        field.resolution.trailing_zeros() + 1
    );
    if p > 0 {
        let n = field.resolution;
        assert_eq!(field.index(p - 1, n - 1, n - 1), texels - 1);
    }
    let m = field.irradiance_resolution as usize;
    assert_eq!(field.irradiance.len(), p * m * m);
    assert_eq!(field.moments.len(), p * m * m);
    let out = field.to_bytes();
    assert_eq!(out.len(), data.len());
    lightfield::format::from_bytes(&out)
        .expect("the writer's bytes of a field the reader accepted are refused");
}

/// `probes.json` ([`probeplace::placement::file::parse_world`], what
/// `read_world` and `read` parse): a list it returns is non-empty, within
/// `MAX_PROBES` and finite; an error names the file.
pub fn probes(data: &[u8]) {
    use probeplace::placement::file;
    match file::parse_world(data, Path::new("fuzz.json")) {
        Ok(list) => {
            assert!(!list.is_empty() && list.len() <= file::MAX_PROBES);
            assert!(list.iter().all(|(p, _)| p.is_finite()), "{list:?}");
        }
        Err(e) => assert!(e.to_string().starts_with("fuzz.json: "), "{e}"),
    }
}

/// `data` with its last four bytes replaced by the CRC-32 of the bytes
/// before them, if it is longer than `header` bytes and the CRC differs.
fn with_crc(data: &[u8], header: usize) -> Option<Vec<u8>> {
    if data.len() < header + 4 {
        return None;
    }
    let body = data.len() - 4;
    let crc = svo::format::crc32(&data[..body]).to_le_bytes();
    if data[body..] == crc {
        return None;
    }
    let mut fixed = data.to_vec();
    fixed[body..].copy_from_slice(&crc);
    Some(fixed)
}

/// A small deterministic PRNG (SplitMix64), shared with the built-in
/// mutation loop of `tests/it/fuzz.rs`.
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Rng {
        Rng(seed)
    }

    pub fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in `0..n` (`n` > 0).
    pub fn below(&mut self, n: usize) -> usize {
        (self.next() % n as u64) as usize
    }

    /// Uniform in [0, 1).
    pub fn unit(&mut self) -> f32 {
        (self.next() >> 40) as f32 / (1u64 << 24) as f32
    }
}

/// The OBJ reader ([`probeplace::scene::obj::parse`]) on any bytes: the
/// input up to a line `#mtl` is the OBJ, the rest the text every
/// `mtllib` it names reads. What it returns must index only vertices it
/// read and materials its libraries define, with every material value in
/// its clamped range (docs/config.md, "Scenes"); the scene built from it
/// must hold only finite, non-degenerate triangles.
pub fn obj(data: &[u8]) {
    use probeplace::scene::obj::{parse, Library};
    use probeplace::scene::Scene;
    use std::path::PathBuf;
    let (obj, mtl) = match data.windows(6).position(|w| w == b"\n#mtl\n") {
        Some(i) => (&data[..i + 1], &data[i + 6..]),
        None => (data, &data[..0]),
    };
    let mtl = String::from_utf8_lossy(mtl).into_owned();
    let Ok(file) = parse(
        std::io::Cursor::new(obj),
        Path::new("fuzz.obj"),
        &mut |name: &str| Ok(Library::Text(PathBuf::from(name), mtl.clone())),
    ) else {
        return;
    };
    for (t, m) in &file.triangles {
        assert!(
            t.iter().all(|&i| (i as usize) < file.positions.len()),
            "{t:?}"
        );
        assert!(
            *m == u32::MAX || (*m as usize) < file.materials.len(),
            "{m}"
        );
    }
    check_materials(&file.materials);
    // Texture indices: none, or one per triangle, each naming a `vt`;
    // maps name materials that exist.
    assert!(
        file.triangle_texcoords.is_empty() || file.triangle_texcoords.len() == file.triangles.len()
    );
    for t in file.triangle_texcoords.iter().flatten() {
        assert!(
            *t == u32::MAX || (*t as usize) < file.texcoords.len(),
            "{t}"
        );
    }
    assert!(file.texcoords.iter().flatten().all(|v| v.is_finite()));
    for m in &file.maps {
        assert!(m.material < file.materials.len(), "{m:?}");
        assert!(!m.file.as_os_str().is_empty());
    }
    let triangles = file
        .triangles
        .iter()
        .map(|(t, m)| (t.map(|i| file.positions[i as usize]), *m));
    if let Ok(scene) =
        Scene::from_world_triangles(PathBuf::from("fuzz.obj"), triangles, file.materials)
    {
        check_scene(&scene);
    }
}

/// The glTF reader ([`probeplace::scene::gltf::parse`]) on any bytes, as
/// JSON or GLB; every external buffer it names reads the input itself.
/// What it returns must name only materials it read (or none), with every
/// material value in its clamped range, and only finite lights; the scene
/// built from it must hold only finite, non-degenerate triangles.
pub fn gltf(data: &[u8]) {
    use probeplace::config::{Light, UpAxis};
    use probeplace::scene::Scene;
    use std::path::PathBuf;
    let Ok(file) = probeplace::scene::gltf::parse(
        data,
        Path::new("fuzz.glb"),
        1.0,
        UpAxis::Y,
        &mut |_uri: &str, _what: &str| Ok(data.to_vec()),
    ) else {
        return;
    };
    for (_, m) in &file.triangles {
        assert!(
            *m == u32::MAX || (*m as usize) < file.materials.len(),
            "{m}"
        );
    }
    check_materials(&file.materials);
    // Texture coordinates for every triangle or none; every map names a
    // decoded texture, which samples finite colours anywhere.
    assert!(file.texcoords.is_empty() || file.texcoords.len() == file.triangles.len());
    for m in &file.materials {
        for map in [m.diffuse_map, m.emission_map].into_iter().flatten() {
            assert!((map.texture as usize) < file.textures.len(), "{map:?}");
            for uv in [[0.5f32, 0.5], [-3.25, 7.5], [1e30, f32::NAN]] {
                let c = map.sample(&file.textures, glam::Vec2::from(uv));
                assert!(
                    c.is_finite() && c.min_element() >= 0.0 && c.max_element() <= 1.0,
                    "{c}"
                );
            }
        }
    }
    for l in &file.lights {
        let finite = match l {
            Light::Point {
                position,
                intensity,
            } => {
                position.0.iter().all(|v| v.is_finite())
                    && intensity.0.iter().all(|v| v.is_finite() && *v >= 0.0)
            }
            Light::Spot {
                position,
                direction,
                intensity,
                cone_degrees,
                edge_degrees,
            } => {
                position.0.iter().all(|v| v.is_finite())
                    && direction.0.iter().all(|v| v.is_finite())
                    && intensity.0.iter().all(|v| v.is_finite() && *v >= 0.0)
                    && cone_degrees.0 > 0.0
                    && cone_degrees.0 <= 90.0
                    && edge_degrees.0 >= 0.0
            }
            Light::Directional {
                direction,
                irradiance,
            } => {
                direction.0.iter().all(|v| v.is_finite())
                    && irradiance.0.iter().all(|v| v.is_finite() && *v >= 0.0)
            }
            Light::Sky { .. } => false,
        };
        assert!(finite, "{l:?}");
    }
    if let Ok(scene) =
        Scene::from_world_triangles(PathBuf::from("fuzz.glb"), file.triangles, file.materials)
    {
        check_scene(&scene);
    }
}

/// A scene built from a reader's output: finite triangles, unit normals,
/// material ids in range.
fn check_scene(scene: &probeplace::scene::Scene) {
    assert!(scene.triangles.iter().flatten().all(|v| v.is_finite()));
    assert!(scene
        .normals
        .iter()
        .all(|n| (n.length() - 1.0).abs() < 1e-3));
    assert!(scene
        .material_ids
        .iter()
        .all(|&m| (m as usize) < scene.materials.len()));
}

/// Every material value within its clamped range (docs/config.md, "Scenes").
fn check_materials(materials: &[probeplace::scene::Material]) {
    use probeplace::scene::obj::{MAX_EMISSION, MAX_SHININESS};
    for m in materials {
        let unit = |v: &f32| (0.0..=1.0).contains(v);
        assert!(
            m.diffuse.iter().all(unit) && m.specular.iter().all(unit),
            "{m:?}"
        );
        assert!(
            m.emission
                .iter()
                .all(|v| (0.0..=MAX_EMISSION as f32).contains(v)),
            "{m:?}"
        );
        assert!((0.0..=MAX_SHININESS as f32).contains(&m.shininess), "{m:?}");
        // A cut-out's alpha and cutoff are finite, its factor in [0, 1].
        if let Some(c) = m.cutout {
            assert!(
                unit(&c.factor) && c.cutoff.is_finite() && c.cutoff >= 0.0,
                "{m:?}"
            );
        }
        if let Some(mr) = m.metal_rough {
            assert!(
                mr.base.iter().all(unit) && unit(&mr.metallic) && unit(&mr.roughness),
                "{m:?}"
            );
        }
    }
}

// ---------------------------------------------------------------------------
// Seeds: small valid inputs made by the real writers. `cargo test --release
// -- fuzz::write_seeds --ignored` writes them to `fuzz/seeds/TARGET/`.

/// Every generated seed: (target, file name, bytes). Each is an input its
/// reader accepts.
pub fn generated_seeds() -> Vec<(&'static str, String, Vec<u8>)> {
    let mut seeds = Vec::new();
    for (name, bytes) in svo_seeds() {
        seeds.push(("svo", name.to_string(), bytes));
    }
    for (name, bytes) in lightfield_seeds() {
        seeds.push(("lightfield", name.to_string(), bytes));
    }
    for (name, text) in probes_seeds() {
        seeds.push(("probes", name.to_string(), text.into_bytes()));
    }
    for (name, bytes) in gltf_seeds() {
        seeds.push(("gltf", name.to_string(), bytes));
    }
    seeds
}

/// Small glTF files by the test kit's writer: a lit, instanced quad as a
/// GLB, quantized strips with a sparse accessor as a `.gltf` with its
/// buffer in a data URI, a textured quad whose material uses an extension
/// the reader does not apply, and a mesh placed twice whose primitives
/// share one POSITION accessor.
fn gltf_seeds() -> Vec<(&'static str, Vec<u8>)> {
    use probeplace::fixtures::gltf_writer::{Builder, Positions};
    use serde_json::json;
    let mut b = Builder::new();
    let lamp = b.material("lamp", [0.5, 0.4, 0.3], 0.2, 0.6, [3.0, 2.0, 1.0]);
    let mesh = b.unit_quad(Some(lamp));
    let spot = b.light(json!({"type": "spot", "intensity": 2.0, "spot": {"innerConeAngle": 0.2, "outerConeAngle": 0.5}}));
    let a = b.node(json!({"mesh": mesh, "scale": [-1.0, 1.0, 1.0]}));
    let c = b.node(json!({"mesh": mesh, "rotation": [0.0, std::f32::consts::FRAC_1_SQRT_2, 0.0, std::f32::consts::FRAC_1_SQRT_2], "extensions": {"KHR_lights_punctual": {"light": spot}}}));
    let root = b.node(json!({"translation": [1.0, 2.0, 3.0], "children": [a, c]}));
    b.scene(&[root]);
    let glb = b.glb();
    let mut q = Builder::new();
    let pos = q.positions(
        &[
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 0.0, 1.0],
            [1.0, 0.5, 1.0],
        ],
        Positions::NormalizedU16,
    );
    let mesh = q.mesh("strip", &[(pos, None, 5, None)]);
    let n = q.node(json!({"mesh": mesh, "scale": [4.0, 4.0, 4.0]}));
    q.scene(&[n]);
    // A textured quad: a PNG in the buffer, mirrored by its sampler and
    // moved by KHR_texture_transform, for the image decoders.
    let mut t = Builder::new();
    let texels: Vec<u8> = (0..16u8)
        .flat_map(|i| [i * 16, 255 - i * 16, 128])
        .collect();
    let image = t.image(
        &probeplace::fixtures::gltf_writer::png_rgb(4, 4, &texels),
        "image/png",
    );
    let sampler = t.sampler(json!({"wrapS": 33648, "wrapT": 33071}));
    let texture = t.texture(image, Some(sampler));
    let m = t.material("tiles", [1.0; 3], 0.0, 1.0, [1.0; 3]);
    t.material_json(m)["pbrMetallicRoughness"]["baseColorTexture"] = json!({"index": texture,
        "extensions": {"KHR_texture_transform": {"offset": [0.5, 0.0], "rotation": 0.3, "scale": [2.0, 2.0]}}});
    t.material_json(m)["emissiveTexture"] = json!({"index": texture});
    // An extension used but not applied (the reader warns and goes on).
    t.material_json(m)["extensions"] =
        json!({"KHR_materials_transmission": {"transmissionFactor": 0.5}});
    t.use_extension("KHR_materials_transmission");
    let mesh = t.textured_quad(m);
    let n = t.node(json!({"mesh": mesh}));
    t.scene(&[n]);
    // Metal and roughness painted in a texture under factors of 1, an
    // alpha-masked colour texture (RGBA) with its cutoff, and a BLEND
    // material: the per-texel BSDF and the cut-outs.
    let mut c = Builder::new();
    let rgba: Vec<u8> = (0..16u8)
        .flat_map(|i| [i * 16, 200, 100, if i % 3 == 0 { 0 } else { 255 }])
        .collect();
    let colour = c.image(
        &probeplace::fixtures::gltf_writer::png_rgba(4, 4, &rgba),
        "image/png",
    );
    let colour = c.texture(colour, None);
    let painted: Vec<u8> = (0..4u8).flat_map(|i| [0, 64 * i, 255 * (i % 2)]).collect();
    let mr = c.image(
        &probeplace::fixtures::gltf_writer::png_rgb(2, 2, &painted),
        "image/png",
    );
    let mr = c.texture(mr, None);
    let fence = c.material("fence", [0.8; 3], 1.0, 1.0, [0.0; 3]);
    let fj = c.material_json(fence);
    fj["pbrMetallicRoughness"]["baseColorTexture"] = json!({"index": colour});
    fj["pbrMetallicRoughness"]["metallicRoughnessTexture"] = json!({"index": mr});
    fj["alphaMode"] = json!("MASK");
    fj["alphaCutoff"] = json!(0.4);
    let glass = c.material("glass", [0.9; 3], 0.0, 0.1, [0.0; 3]);
    c.material_json(glass)["alphaMode"] = json!("BLEND");
    c.material_json(glass)["pbrMetallicRoughness"]["baseColorFactor"] = json!([0.9, 0.9, 0.9, 0.3]);
    let a = c.textured_quad(fence);
    let b2 = c.textured_quad(glass);
    let na = c.node(json!({"mesh": a}));
    let nb = c.node(json!({"mesh": b2, "translation": [0.0, 1.0, 0.0]}));
    c.scene(&[na, nb]);
    // One POSITION accessor shared by three primitives (a fan, a strip
    // and indexed triangles), each with its own indices: the accessor
    // the reader decodes once, however many primitives name it.
    let mut s = Builder::new();
    let pos = s.positions(
        &[
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 0.0, 1.0],
            [0.0, 0.0, 1.0],
            [0.5, 1.0, 0.5],
        ],
        Positions::Float,
    );
    let fan = s.indices(&[4, 0, 1, 2]);
    let strip = s.indices(&[2, 3, 4]);
    let tris = s.indices(&[0, 2, 1, 0, 3, 2]);
    let mesh = s.mesh(
        "shared",
        &[
            (pos, Some(fan), 6, None),
            (pos, Some(strip), 5, None),
            (pos, Some(tris), 4, None),
        ],
    );
    let a = s.node(json!({"mesh": mesh}));
    let b3 = s.node(json!({"mesh": mesh, "translation": [2.0, 0.0, 0.0]}));
    s.scene(&[a, b3]);
    vec![
        ("quad.glb", glb),
        ("strip.gltf", q.gltf(None)),
        ("textured.glb", t.glb()),
        ("masked.glb", c.glb()),
        ("shared.glb", s.glb()),
    ]
}

/// `svo.bin` of a tree given by its header fields and words, passed through
/// the library's reader and written again by its writer.
fn svo_file(
    depth: u32,
    dims: [u32; 3],
    probe_count: u32,
    max_probes: u32,
    nodes: &[u32],
    payload: &[u32],
) -> Vec<u8> {
    let origin = [-1.5f32, 0.25, 2.0];
    let mut out = svo::format::MAGIC.to_vec();
    let mut words = vec![svo::format::VERSION];
    words.extend(origin.map(f32::to_bits));
    words.push(0.125f32.to_bits());
    words.push(depth);
    words.extend(dims);
    words.extend([
        probe_count,
        max_probes,
        0,
        nodes.len() as u32,
        payload.len() as u32,
    ]);
    for w in words {
        out.extend_from_slice(&w.to_le_bytes());
    }
    for c in origin {
        out.extend_from_slice(&(c as f64).to_le_bytes());
    }
    out.extend((0u8..32).map(|b| b.wrapping_mul(37)));
    for w in nodes.iter().chain(payload) {
        out.extend_from_slice(&w.to_le_bytes());
    }
    let crc = svo::format::crc32(&out);
    out.extend_from_slice(&crc.to_le_bytes());
    let tree = svo::format::from_bytes(&out).expect("a valid seed tree");
    tree.to_bytes()
}

const LEAF: u32 = 1 << 31;

fn leaf(count: u32, offset: u32) -> u32 {
    LEAF | ((count - 1) << 28) | offset
}

fn inner(mask: u32, first: u32) -> u32 {
    mask | (first << 8)
}

fn svo_seeds() -> Vec<(&'static str, Vec<u8>)> {
    // A full tree of depth 2: every inner node has 8 children; the leaves
    // list 1 to 4 of 6 probes.
    let mut nodes = vec![inner(0xFF, 1)];
    for i in 0..8 {
        nodes.push(inner(0xFF, 9 + 8 * i));
    }
    let payload = vec![0, 1, 2, 3, 4, 5, 0, 2];
    for i in 0..64u32 {
        nodes.push(leaf(1 + i % 4, i % 5));
    }
    vec![
        ("empty", svo_file(0, [1, 1, 1], 1, 1, &[0], &[])),
        (
            "one-leaf",
            svo_file(0, [1, 1, 1], 1, 1, &[leaf(1, 0)], &[0]),
        ),
        (
            "sparse",
            svo_file(
                2,
                [4, 3, 2],
                3,
                4,
                &[
                    inner(0b0000_0111, 1),
                    leaf(2, 0),
                    inner(0b1000_0001, 4),
                    leaf(1, 2),
                    leaf(3, 0),
                    leaf(1, 1),
                ],
                &[0, 1, 2],
            ),
        ),
        ("full", svo_file(2, [4, 4, 3], 6, 4, &nodes, &payload)),
    ]
}

/// A light field of `p` probes, map side `n`, irradiance side `m`, filled
/// with a deterministic pattern, written by the library's writer.
fn lightfield_file(p: usize, n: u32, m: u32) -> Vec<u8> {
    let texels = p * (n * n) as usize;
    let irr = p * (m * m) as usize;
    let v = |i: usize| (i % 17) as f32 * 0.25;
    let field = LightField {
        resolution: n,
        irradiance_resolution: m,
        max_distance: 5.0,
        positions: (0..p)
            .map(|i| glam::Vec3::new(i as f32, 1.5, -0.5 * i as f32))
            .collect(),
        frame: glam::DVec3::ZERO,
        radiance: (0..texels).map(|i| [v(i), v(i + 1), v(i + 2)]).collect(),
        normal: (0..texels).map(|i| [v(i) - 2.0, 0.5]).collect(),
        distance: (0..texels)
            .map(|i| if i % 5 == 0 { f32::INFINITY } else { v(i) })
            .collect(),
        pyramid: (0..=n.trailing_zeros())
            .map(|k| {
                let side = (n >> k) as usize;
                (0..p * side * side).map(|i| [v(i), v(i) + 1.0]).collect()
            })
            .collect(),
        irradiance: (0..irr).map(|i| [v(i), v(i), 0.0]).collect(),
        moments: (0..irr).map(|i| [v(i), v(i) * v(i)]).collect(),
        provenance: [7; 32],
    };
    let bytes = field.to_bytes();
    lightfield::format::from_bytes(&bytes).expect("a valid seed field");
    bytes
}

fn lightfield_seeds() -> Vec<(&'static str, Vec<u8>)> {
    vec![
        ("one-probe", lightfield_file(1, 1, 1)),
        ("two-probes", lightfield_file(2, 4, 2)),
    ]
}

fn probes_seeds() -> Vec<(&'static str, String)> {
    vec![
        ("bare-array.json", "[[0, 1, 2], [-1.5, 0.25, 1e3]]\n".into()),
        (
            "probes.json",
            r#"{
  "format": "probeplace.probes",
  "version": 1,
  "provenance": {"tool": "probeplace 0.1.0", "config_hash": "8ee8d3207bafd427", "seed": 1},
  "method": "sdf_skeleton",
  "seed": 1,
  "scene": "fixtures/cornell_box.obj",
  "space": {"scale": 0.001, "up": "Y"},
  "probes": [
    {"index": 0, "position": [0.278, 0.273, 0.28], "position_file": [278.0, 273.0, 280.0], "clearance": 0.12, "voxel_class": "Free", "cluster_size": 12},
    {"index": 1, "position": [0.1, 0.4999999999999999, -2.5e-7], "position_file": [100.0, 500.0, 0.0], "clearance": -0.01, "voxel_class": null, "cluster_size": 0}
  ]
}
"#
            .into(),
        ),
    ]
}
