//! Textures (issue 48): colour and emission maps of OBJ (`map_Kd`,
//! `map_Ke`) and glTF (`baseColorTexture`, `emissiveTexture`) change what
//! the bake and the reference see, as the texels say; a missing texture
//! warns once and leaves the factor; a glTF converted from a textured OBJ
//! renders as the OBJ does.

use glam::{Vec2, Vec3};
use probeplace::config::UpAxis;
use probeplace::fixtures::gltf_writer::{from_scene, png_rgb, Builder};
use probeplace::render::Renderer;
use probeplace::sampling::Sampler;
use probeplace::scene::raycast::SceneBvh;
use probeplace::scene::{self, Scene};
use serde_json::json;
use std::path::Path;

/// An `n × n` checker PNG: texel `(x, y)` white where `x + y` is even.
fn checker_png(n: u32) -> Vec<u8> {
    let texels: Vec<u8> = (0..n * n)
        .flat_map(|i| {
            let v = if (i % n + i / n).is_multiple_of(2) {
                255
            } else {
                0
            };
            [v, v, v]
        })
        .collect();
    png_rgb(n, n, &texels)
}

/// A 4 m × 4 m floor (y = 0, facing up, `vt` running 0..1 over it, its
/// material `floor_mtl`) under a 4 m × 4 m emitter at y = 3 facing down
/// (`light_mtl`, `vt` likewise), written as `name.obj` + `name.mtl`.
fn room(dir: &Path, name: &str, floor_mtl: &str, light_mtl: &str) -> std::path::PathBuf {
    let obj = format!(
        "mtllib {name}.mtl\n\
         v 0 0 0\nv 0 0 4\nv 4 0 4\nv 4 0 0\n\
         v 0 3 0\nv 4 3 0\nv 4 3 4\nv 0 3 4\n\
         vt 0 0\nvt 0 1\nvt 1 1\nvt 1 0\n\
         usemtl floor\nf 1/1 2/2 3/3 4/4\n\
         usemtl light\nf 5/1 6/4 7/3 8/2\n"
    );
    std::fs::write(dir.join(format!("{name}.obj")), obj).unwrap();
    std::fs::write(
        dir.join(format!("{name}.mtl")),
        format!("newmtl floor\n{floor_mtl}\nnewmtl light\n{light_mtl}\n"),
    )
    .unwrap();
    dir.join(format!("{name}.obj"))
}

/// The floor point at the centre of texel `(i, j)` of an `n × n` texture
/// (OBJ's `v` is up, the image's rows run down: row `j` is at
/// `v = 1 − (j + ½)/n`, and `v` runs along z).
fn texel_centre(i: u32, j: u32, n: u32) -> Vec3 {
    let u = (i as f32 + 0.5) / n as f32;
    let v = 1.0 - (j as f32 + 0.5) / n as f32;
    Vec3::new(4.0 * u, 0.0, 4.0 * v)
}

/// Mean of `n` one-sample radiance estimates along `eye → target`.
fn radiance(r: &Renderer, eye: Vec3, target: Vec3, n: u64) -> Vec3 {
    let dir = (target - eye).normalize();
    (0..n)
        .map(|k| r.radiance(eye, dir, &mut Sampler::new(7, k)))
        .sum::<Vec3>()
        / n as f32
}

fn load(path: &Path) -> Scene {
    scene::load(path, 1.0, UpAxis::Y).unwrap()
}

#[test]
fn a_checker_texture_colours_the_reference_the_bake_and_a_missing_one_warns() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("checker.png"), checker_png(8)).unwrap();
    let light = "Kd 0 0 0\nKe 1 1 1";
    let textured = load(&room(
        dir.path(),
        "textured",
        "Kd 1 1 1\nmap_Kd checker.png",
        light,
    ));
    let white = load(&room(dir.path(), "white", "Kd 1 1 1", light));
    let grey = load(&room(dir.path(), "grey", "Kd 0.5 0.5 0.5", light));
    let missing = load(&room(
        dir.path(),
        "missing",
        "Kd 1 1 1\nmap_Kd gone.png",
        light,
    ));
    assert!(textured.warnings.is_empty(), "{:?}", textured.warnings);
    assert_eq!(textured.textures.len(), 1);
    assert_eq!(textured.texcoords.len(), textured.triangles.len());
    assert!(
        white.texcoords.is_empty(),
        "untextured scenes carry no texture coordinates"
    );

    // The missing texture: one warning naming it; the factor alone is used,
    // so the scene renders exactly as the untextured one.
    let named: Vec<_> = missing
        .warnings
        .iter()
        .filter(|w| w.contains("gone.png"))
        .collect();
    assert_eq!(named.len(), 1, "{:?}", missing.warnings);
    assert!(
        named[0].contains("texture not found") && named[0].contains("factor"),
        "{named:?}"
    );
    assert!(missing.textures.is_empty() && missing.materials[0].diffuse_map.is_none());

    let bvh = |s: &Scene| SceneBvh::new(s);
    let (bt, bw, bg, bm) = (bvh(&textured), bvh(&white), bvh(&grey), bvh(&missing));
    let rt = Renderer::new(&textured, &bt, &[], 1);
    let rw = Renderer::new(&white, &bw, &[], 1);
    let rg = Renderer::new(&grey, &bg, &[], 1);
    let rm = Renderer::new(&missing, &bm, &[], 1);

    // The reference: a white square reflects as the white floor does, a
    // black one nothing.
    let eye = Vec3::new(2.0, 1.5, 2.3);
    for (i, j) in [(2, 3), (5, 4), (3, 3), (4, 6)] {
        let target = texel_centre(i, j, 8);
        let t = radiance(&rt, eye, target, 64);
        let w = radiance(&rw, eye, target, 64);
        assert!(w.x > 0.01, "{w}");
        if (i + j) % 2 == 0 {
            assert!(
                ((t - w) / w).abs().max_element() < 1e-3,
                "white texel ({i}, {j}): {t} vs {w}"
            );
        } else {
            assert!(t.max_element() < 1e-3 * w.x, "black texel ({i}, {j}): {t}");
        }
        assert_eq!(
            radiance(&rm, eye, target, 16),
            radiance(&rw, eye, target, 16)
        );
        let split = rt.radiance_split(eye, (target - eye).normalize(), &mut Sampler::new(3, 1));
        assert_eq!(
            split.full == Vec3::ZERO,
            (i + j) % 2 == 1,
            "reference split at ({i}, {j})"
        );
    }

    // The bake: a probe above the checker sees the floor as bright as a
    // uniform floor of the checker's mean albedo (0.5 in linear light),
    // about half the white floor.
    let params = probeplace::config::BakeParams {
        resolution: probeplace::config::PowerOfTwo(16),
        samples: probeplace::config::Count(16),
        ..Default::default()
    };
    let downward = |s: &Scene, bvh: &SceneBvh, r: &Renderer| {
        let radiance = |o: Vec3, d: Vec3, k: u64| r.radiance(o, d, &mut Sampler::new(11, k));
        let field = probeplace::lightfield::bake(
            &params,
            &[Vec3::new(2.0, 1.0, 2.0)],
            s,
            bvh,
            8.0,
            5,
            &radiance,
            &probeplace::progress::Progress::hidden(),
        )
        .field;
        let n = field.resolution;
        let mut sum = 0.0f64;
        for y in 0..n {
            for x in 0..n {
                let d = probeplace::lightfield::octahedral::texel_direction(x, y, n);
                if d.y < -0.3 {
                    sum += field.radiance[(y * n + x) as usize][1] as f64;
                }
            }
        }
        sum
    };
    let (t, w, g) = (
        downward(&textured, &bt, &rt),
        downward(&white, &bw, &rw),
        downward(&grey, &bg, &rg),
    );
    assert!(
        (t / g - 1.0).abs() < 0.1,
        "textured {t} vs grey {g} (white {w})"
    );
    assert!((t / w - 0.5).abs() < 0.05, "textured {t} vs white {w}");
}

#[test]
fn an_emission_texture_lights_as_its_texels_say() {
    let dir = tempfile::tempdir().unwrap();
    // 8 × 1: the left half black, the right half white, clamped.
    let texels: Vec<u8> = (0..8)
        .flat_map(|x| [if x < 4 { 0 } else { 255 }; 3])
        .collect();
    std::fs::write(dir.path().join("half.png"), png_rgb(8, 1, &texels)).unwrap();
    let floor = "Kd 0.5 0.5 0.5";
    let textured = load(&room(
        dir.path(),
        "glow",
        floor,
        "Kd 0 0 0\nKe 2 2 2\nmap_Ke -clamp on half.png",
    ));
    assert!(textured.warnings.is_empty(), "{:?}", textured.warnings);
    // The same light made of geometry: only the half x > 2 emits.
    let obj = "mtllib split.mtl\n\
         v 0 0 0\nv 0 0 4\nv 4 0 4\nv 4 0 0\n\
         v 0 3 0\nv 2 3 0\nv 2 3 4\nv 0 3 4\nv 4 3 0\nv 4 3 4\n\
         usemtl floor\nf 1 2 3 4\nusemtl dark\nf 5 6 7 8\nusemtl light\nf 6 9 10 7\n";
    std::fs::write(dir.path().join("split.obj"), obj).unwrap();
    std::fs::write(
        dir.path().join("split.mtl"),
        format!("newmtl floor\n{floor}\nnewmtl dark\nKd 0 0 0\nnewmtl light\nKd 0 0 0\nKe 2 2 2\n"),
    )
    .unwrap();
    let split = load(&dir.path().join("split.obj"));
    let (bt, bs) = (SceneBvh::new(&textured), SceneBvh::new(&split));
    let rt = Renderer::new(&textured, &bt, &[], 0);
    let rs = Renderer::new(&split, &bs, &[], 0);
    // Seen directly: the white half emits Ke, the black half nothing.
    let eye = Vec3::new(2.0, 1.0, 2.0);
    let at = |x: f32| radiance(&rt, eye, Vec3::new(x, 3.0, 2.0), 1);
    assert_eq!(at(3.5), Vec3::splat(2.0));
    assert_eq!(at(0.5), Vec3::ZERO);
    // Direct light on the floor (light sampling only, bounces 0) agrees
    // with the geometric split, under either half: the texel scales the
    // sample, unbiased.
    for x in [0.7f32, 2.0, 3.3] {
        let target = Vec3::new(x, 0.0, 1.7);
        let t = radiance(&rt, eye, target, 20_000).x;
        let s = radiance(&rs, eye, target, 20_000).x;
        assert!(
            (t / s - 1.0).abs() < 0.03,
            "floor at x = {x}: textured {t} vs split {s}"
        );
    }
    let under = |x: f32| radiance(&rt, eye, Vec3::new(x, 0.0, 2.0), 4000).x;
    assert!(
        under(3.5) > 2.0 * under(0.5),
        "more light under the white half"
    );
}

#[test]
fn a_textured_obj_converted_to_gltf_renders_alike_with_its_transform_and_wrap() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("checker.png"), checker_png(8)).unwrap();
    // Scaled, offset and clamped: the map's transform and wrap travel as
    // KHR_texture_transform and a sampler.
    let obj = load(&room(
        dir.path(),
        "room",
        "Kd 1 1 1\nmap_Kd -s 0.75 0.5 -o 0.125 0.25 -clamp on checker.png",
        "Kd 0 0 0\nKe 1 1 1",
    ));
    let b = from_scene(&obj);
    std::fs::write(dir.path().join("room.glb"), b.glb()).unwrap();
    let glb = load(&dir.path().join("room.glb"));
    assert!(glb.warnings.is_empty(), "{:?}", glb.warnings);
    assert_eq!(glb.textures.len(), 1);
    assert_eq!(glb.textures[0].texels(), obj.textures[0].texels());
    let (mo, mg) = (&obj.materials[0], &glb.materials[0]);
    let (to, tg) = (mo.diffuse_map.unwrap(), mg.diffuse_map.unwrap());
    assert_eq!(tg.wrap, to.wrap);
    for (a, b) in to.transform.iter().zip(&tg.transform) {
        assert!(
            (a - b).abs() < 1e-6,
            "{:?} vs {:?}",
            to.transform,
            tg.transform
        );
    }
    // The albedo each scene gives the floor where a ray meets it (the
    // glTF's dielectric adds a 4% specular lobe the OBJ lacks, so it is the
    // texture's colour that is compared, not the rendered radiance).
    let albedo = |s: &Scene, bvh: &SceneBvh, target: Vec3| {
        let eye = Vec3::new(2.0, 1.5, 2.3);
        let dir = (target - eye).normalize();
        let hit = bvh.closest_hit(eye, dir, 0.0, f32::INFINITY).unwrap();
        let p = eye + dir * hit.t;
        let t = hit.triangle as usize;
        s.diffuse_at(
            &s.materials[s.material_ids[t] as usize],
            s.texcoord_at(t, p),
        )[0]
    };
    let (bo, bg) = (SceneBvh::new(&obj), SceneBvh::new(&glb));
    let mut seen = [false; 2];
    for k in 0..40 {
        let target = Vec3::new(0.05 + 0.1 * k as f32, 0.0, 0.2 + 0.09 * k as f32);
        let (a, b) = (albedo(&obj, &bo, target), albedo(&glb, &bg, target));
        assert!((a - b).abs() < 1e-4, "{target}: {a} vs {b}");
        seen[(a > 0.5) as usize] = true;
    }
    assert_eq!(
        seen,
        [true, true],
        "the rays see both colours of the checker"
    );
}

#[test]
fn gltf_images_read_from_a_buffer_view_a_data_uri_a_file_and_a_jpeg() {
    use base64::Engine;
    let dir = tempfile::tempdir().unwrap();
    let grey = |v: u8| png_rgb(2, 2, &[v; 12]);
    let mut jpeg = Vec::new();
    jpeg_encoder::Encoder::new(&mut jpeg, 100)
        .encode(&[200u8; 16 * 16 * 3], 16, 16, jpeg_encoder::ColorType::Rgb)
        .unwrap();
    std::fs::write(dir.path().join("file grey.png"), grey(64)).unwrap();
    let mut b = Builder::new();
    let images = [
        b.image(&grey(255), "image/png"),
        b.image_uri(&format!(
            "data:image/png;base64,{}",
            base64::engine::general_purpose::STANDARD.encode(grey(128))
        )),
        b.image_uri("file%20grey.png"),
        b.image(&jpeg, "image/jpeg"),
        b.image_uri("gone.png"),
    ];
    let mut roots = Vec::new();
    for (k, &image) in images.iter().enumerate() {
        let t = b.texture(image, None);
        let m = b.material(&format!("m{k}"), [1.0; 3], 0.0, 1.0, [0.0; 3]);
        b.material_json(m)["pbrMetallicRoughness"]["baseColorTexture"] = json!({"index": t});
        let mesh = b.textured_quad(m);
        roots.push(b.node(json!({"mesh": mesh, "translation": [2.0 * k as f64, 0.0, 0.0]})));
    }
    b.scene(&roots);
    std::fs::write(dir.path().join("quads.glb"), b.glb()).unwrap();
    let s = load(&dir.path().join("quads.glb"));
    let gone: Vec<_> = s
        .warnings
        .iter()
        .filter(|w| w.contains("image 4"))
        .collect();
    assert_eq!(gone.len(), 1, "{:?}", s.warnings);
    assert_eq!(s.warnings.len(), 1, "{:?}", s.warnings);
    // Named for what is missing: an image, not a buffer.
    assert!(
        gone[0].contains("glTF image") && !gone[0].contains("buffer"),
        "{}",
        gone[0]
    );
    let linear = |c: u8| probeplace::scene::texture::srgb_to_linear(c);
    let want = [
        Some(linear(255)),
        Some(linear(128)),
        Some(linear(64)),
        Some(linear(200)),
        None,
    ];
    for (k, want) in want.into_iter().enumerate() {
        let m = &s.materials[k];
        let Some(map) = m.diffuse_map else {
            assert!(want.is_none(), "material {k} lost its texture");
            continue;
        };
        let got = s.diffuse_at(m, Vec2::new(0.5, 0.5))[0];
        let want = want.unwrap();
        // The JPEG is lossy by a code value or two.
        assert!(
            (got - want).abs() < 0.01,
            "material {k} (texture {}): {got} vs {want}",
            map.texture
        );
    }
}

#[test]
fn hostile_texture_references_are_refused_or_warned_in_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let write = |name: &str, edit: &dyn Fn(&mut serde_json::Value)| {
        let mut b = Builder::new();
        let m = b.material("m", [1.0; 3], 0.0, 1.0, [0.0; 3]);
        let mesh = b.unit_quad(Some(m));
        let node = b.node(json!({"mesh": mesh}));
        b.scene(&[node]);
        let mut doc = b.document(None);
        edit(&mut doc);
        let path = dir.path().join(name);
        std::fs::write(&path, b.glb_of(&doc)).unwrap();
        scene::load(&path, 1.0, UpAxis::Y)
    };
    let refused = |r: probeplace::Result<Scene>, words: &str| {
        let e = r.expect_err("refused").to_string();
        assert!(e.contains(words) && !e.contains('\n'), "{e}");
    };
    refused(
        write("no_texture.glb", &|d| {
            d["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"] = json!({"index": 3})
        }),
        "material 0 (`m`): baseColorTexture: texture 3 does not exist",
    );
    refused(
        write("no_image.glb", &|d| {
            d["textures"] = json!([{"source": 9}]);
            d["materials"][0]["emissiveTexture"] = json!({"index": 0});
        }),
        "emissiveTexture: texture 0's image 9 does not exist",
    );
    // Images that are not images, or claim to be huge, or point nowhere:
    // warnings, and the factor.
    let s = write("junk.glb", &|d| {
        d["images"] = json!([
            {"uri": "data:image/png;base64,AAAA"},
            {"uri": "https://example.com/a.png"},
            {"bufferView": 99},
        ]);
        d["textures"] = json!([{"source": 0}, {"source": 1}, {"source": 2}]);
        d["materials"] = json!([
            {"name": "a", "pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}},
            {"name": "b", "pbrMetallicRoughness": {"baseColorTexture": {"index": 1}}},
            {"name": "c", "pbrMetallicRoughness": {"baseColorTexture": {"index": 2}}},
        ]);
    })
    .unwrap();
    assert_eq!(s.warnings.len(), 3, "{:?}", s.warnings);
    assert!(
        s.warnings[0].contains("image 0") && s.warnings[0].contains("not a PNG or JPEG"),
        "{:?}",
        s.warnings
    );
    assert!(s.warnings[1].contains("URL"), "{:?}", s.warnings);
    assert!(
        s.warnings[2].contains("buffer view 99 does not exist"),
        "{:?}",
        s.warnings
    );
    assert!(s.textures.is_empty());
    // Extensions used but not required, which the reader does not apply:
    // one line naming them (each once, hostile names escaped), and the
    // file is read.
    let s = write("unapplied.glb", &|d| {
        d["extensionsUsed"] = json!([
            "KHR_materials_transmission",
            "KHR_materials_sheen",
            "KHR_materials_sheen",
            "KHR_texture_transform",
            "X_bad\nname",
        ]);
    })
    .unwrap();
    let named: Vec<_> = s
        .warnings
        .iter()
        .filter(|w| w.contains("not applied"))
        .collect();
    assert_eq!(named.len(), 1, "{:?}", s.warnings);
    let w = named[0];
    assert!(
        w.contains("KHR_materials_transmission, KHR_materials_sheen, X_bad\\nname")
            && w.matches("sheen").count() == 1
            && !w.contains("KHR_texture_transform")
            && !w.contains('\n'),
        "{w}"
    );
    assert!(!s.triangles.is_empty());
    // Required and unknown: refused, as the specification asks.
    refused(
        write("required.glb", &|d| {
            d["extensionsUsed"] = json!(["KHR_materials_transmission"]);
            d["extensionsRequired"] = json!(["KHR_materials_transmission"]);
        }),
        "requires the extension KHR_materials_transmission",
    );
}
