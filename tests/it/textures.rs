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
    refused(
        write("no_metal.glb", &|d| {
            d["materials"][0]["pbrMetallicRoughness"]["metallicRoughnessTexture"] =
                json!({"index": 5})
        }),
        "material 0 (`m`): metallicRoughnessTexture: texture 5 does not exist",
    );
    // A cutoff out of range: clamped, with the factors' warning.
    let s = write("cutoff.glb", &|d| {
        d["materials"][0]["alphaMode"] = json!("MASK");
        d["materials"][0]["alphaCutoff"] = json!(-2.0);
    })
    .unwrap();
    assert_eq!(s.warnings.len(), 1, "{:?}", s.warnings);
    assert!(s.warnings[0].contains("clamped"), "{:?}", s.warnings);
    assert!(
        s.materials[0].cutout.is_none(),
        "alpha 1 at cutoff 0 stops every ray"
    );
    // Images that are not images, or claim to be huge, or point nowhere:
    // warnings, and the factor.
    let s = write("junk.glb", &|d| {
        d["images"] = json!([
            {"uri": "data:image/png;base64,AAAA"},
            {"uri": "https://example.com/a.png"},
        ]);
        d["textures"] = json!([{"source": 0}, {"source": 1}]);
        d["materials"] = json!([
            {"name": "a", "pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}},
            {"name": "b", "pbrMetallicRoughness": {"baseColorTexture": {"index": 1}}},
        ]);
    })
    .unwrap();
    assert_eq!(s.warnings.len(), 2, "{:?}", s.warnings);
    assert!(
        s.warnings[0].contains("image 0") && s.warnings[0].contains("not a PNG or JPEG"),
        "{:?}",
        s.warnings
    );
    assert!(s.warnings[1].contains("URL"), "{:?}", s.warnings);
    assert!(s.textures.is_empty());
    // An image in a buffer view that does not exist: a bad index, refused
    // as the others are (issue 70; it was a warning).
    refused(
        write("no_view.glb", &|d| {
            d["images"] = json!([{"bufferView": 99}]);
            d["textures"] = json!([{"source": 0}]);
            d["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"] = json!({"index": 0});
        }),
        "texture 0's image 0: buffer view 99 does not exist",
    );
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

/// A glTF material as real assets write it (issue 69): `metallicFactor`
/// and `roughnessFactor` 1, the metal painted in the blue channel of a
/// `metallicRoughnessTexture` and the roughness in its green one. The
/// BSDF is made per texel (a dielectric texel keeps its base colour as
/// diffuse albedo, a metal texel none); what reads the material without
/// a point sees the texture's mean; `report.json`'s list says what each
/// image is for.
#[test]
fn a_metal_roughness_texture_sets_metal_and_roughness_per_texel() {
    let dir = tempfile::tempdir().unwrap();
    let mut b = Builder::new();
    // Left texel: dielectric, rough; right texel: metal, roughness ½.
    let image = b.image(&png_rgb(2, 1, &[0, 255, 0, 0, 128, 255]), "image/png");
    let clamp = b.sampler(json!({"wrapS": 33071, "wrapT": 33071}));
    let t = b.texture(image, Some(clamp));
    let m = b.material("painted", [0.5; 3], 1.0, 1.0, [0.0; 3]);
    b.material_json(m)["pbrMetallicRoughness"]["metallicRoughnessTexture"] = json!({"index": t});
    let mesh = b.textured_quad(m);
    let node = b.node(json!({"mesh": mesh}));
    b.scene(&[node]);
    std::fs::write(dir.path().join("painted.glb"), b.glb()).unwrap();
    let s = load(&dir.path().join("painted.glb"));
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    let m = &s.materials[0];
    let (kd, ks, ns) = s.colours_at(m, Vec2::new(0.1, 0.5));
    assert_eq!((kd, ks), ([0.5; 3], [0.04; 3]), "dielectric texel");
    assert_eq!(probeplace::render::material::alpha_from_shininess(ns), 1.0);
    let (kd, ks, ns) = s.colours_at(m, Vec2::new(0.9, 0.5));
    assert_eq!((kd, ks), ([0.0; 3], [0.5; 3]), "metal texel");
    let alpha = probeplace::render::material::alpha_from_shininess(ns);
    let r = 128.0f32 / 255.0;
    assert!((alpha - r * r).abs() < 1e-4, "α {alpha}, roughness {r}");
    // Without a point: the mean texel, metal ½.
    assert!((m.diffuse[0] - 0.25).abs() < 1e-6, "{:?}", m.diffuse);
    let files = &s.texture_files;
    assert_eq!(files.len(), 1);
    assert_eq!(files[0].uses, ["metal-roughness"]);
    assert_eq!(files[0].status, Ok([2, 1]));
    // The path tracer reads it: the metal half reflects no diffuse light.
    let bvh = SceneBvh::new(&s);
    let r = Renderer::new(&s, &bvh, &[], 0);
    // (Scenes are stored relative to their lower corner.)
    let at = |x: f64| s.to_local(glam::DVec3::new(x, 1.0, -0.5));
    let v = r.intersect(at(0.1), -Vec3::Y).unwrap();
    assert_eq!(v.bsdf.diffuse, Vec3::splat(0.5));
    let v = r.intersect(at(0.9), -Vec3::Y).unwrap();
    assert_eq!(v.bsdf.diffuse, Vec3::ZERO);
}

/// Alpha cut-outs (issue 69): glTF's MASK with its cutoff, BLEND read as
/// MASK at 0.5 with one warning, and an MTL's `map_d` and `d`. Rays pass
/// where the alpha is under the cutoff, so light reaches a point behind a
/// masked quad's clear half and not behind its opaque half.
#[test]
fn alpha_masks_let_light_through_their_holes() {
    let dir = tempfile::tempdir().unwrap();
    let mut b = Builder::new();
    // Alpha 0 on the left texel, 255 on the right: clear where u < ½.
    let image = b.image(
        &probeplace::fixtures::gltf_writer::png_rgba(2, 1, &[255, 255, 255, 0, 255, 255, 255, 255]),
        "image/png",
    );
    let clamp = b.sampler(json!({"wrapS": 33071, "wrapT": 33071}));
    let t = b.texture(image, Some(clamp));
    let fence = b.material("fence", [0.5; 3], 0.0, 1.0, [0.0; 3]);
    let mj = b.material_json(fence);
    mj["pbrMetallicRoughness"]["baseColorTexture"] = json!({"index": t});
    mj["alphaMode"] = json!("MASK");
    mj["alphaCutoff"] = json!(0.5);
    let glass = b.material("glass", [0.9; 3], 0.0, 0.1, [0.0; 3]);
    let gj = b.material_json(glass);
    gj["alphaMode"] = json!("BLEND");
    gj["pbrMetallicRoughness"]["baseColorFactor"] = json!([0.9, 0.9, 0.9, 0.2]);
    let light = b.material("light", [0.0; 3], 0.0, 1.0, [4.0; 3]);
    // The fence at y = 1, a glass pane at y = 1.5 (both facing up), the
    // light at y = 2 facing down (a mirrored node).
    let quads = [(fence, 1.0, false), (glass, 1.5, false), (light, 2.0, true)];
    let roots: Vec<usize> = quads
        .iter()
        .map(|&(m, y, down)| {
            let mesh = b.textured_quad(m);
            let scale = if down { -1.0 } else { 1.0 };
            b.node(json!({"mesh": mesh, "translation": [0.0, y, 0.0], "scale": [1.0, scale, 1.0]}))
        })
        .collect();
    b.scene(&roots);
    std::fs::write(dir.path().join("fence.glb"), b.glb()).unwrap();
    let s = load(&dir.path().join("fence.glb"));
    let blend: Vec<_> = s.warnings.iter().filter(|w| w.contains("BLEND")).collect();
    assert_eq!(blend.len(), 1, "{:?}", s.warnings);
    assert!(blend[0].contains("glass"), "{}", blend[0]);
    assert_eq!(s.warnings.len(), 1, "{:?}", s.warnings);
    assert_eq!(s.texture_files[0].uses, ["colour", "alpha"]);
    let cut = s.materials[0].cutout.unwrap();
    assert!(cut.map.is_some() && cut.cutoff == 0.5);
    assert!(
        s.materials[1].cutout.unwrap().everywhere(),
        "BLEND at alpha 0.2"
    );
    let bvh = SceneBvh::new(&s);
    let r = Renderer::new(&s, &bvh, &[], 0);
    // Under the clear half the light is seen through the fence and the
    // glass; under the opaque half the fence is.
    // (Scenes are stored relative to their lower corner.)
    let at = |x: f32, y: f32| s.to_local(glam::DVec3::new(x as f64, y as f64, -0.5));
    let up = |x: f32| radiance(&r, at(x, 0.5), at(x, 2.0), 1);
    assert_eq!(up(0.25), Vec3::splat(4.0));
    assert!(up(0.75).x < 4.0 * 0.5, "{}", up(0.75));
    // The irradiance a probe below the clear half gathers: the light,
    // through the hole (a quarter of the opaque fence's share is left).
    let gather = |x: f32| -> f32 {
        let p = at(x, 0.9);
        (0..4000u64)
            .map(|k| {
                let mut smp = Sampler::new(11, k);
                let u = smp.next_2d();
                let d = probeplace::render::material::cosine_hemisphere(Vec3::Y, u);
                r.radiance(p, d, &mut smp).x
            })
            .sum::<f32>()
            / 4000.0
    };
    let (clear, opaque) = (gather(0.1), gather(0.9));
    assert!(
        clear > 1.5 * opaque,
        "under the hole {clear}, under the fence {opaque}"
    );

    // The same in an MTL: `map_d` (a grey image: no alpha channel) and
    // `d`, with `Tr` its complement.
    std::fs::write(
        dir.path().join("mask.png"),
        png_rgb(2, 1, &[0, 0, 0, 255, 255, 255]),
    )
    .unwrap();
    let obj = room(
        dir.path(),
        "masked",
        "Kd 0.5 0.5 0.5\nmap_d -clamp on mask.png",
        "Kd 0 0 0\nKe 1 1 1\nd 0.2",
    );
    let s = load(&obj);
    let invisible: Vec<_> = s
        .warnings
        .iter()
        .filter(|w| w.contains("opacity"))
        .collect();
    assert_eq!(invisible.len(), 1, "{:?}", s.warnings);
    assert!(invisible[0].contains("`light` (0.2)"), "{}", invisible[0]);
    let floor = s.materials[0].cutout.unwrap();
    assert!(floor.grey && floor.map.is_some());
    assert_eq!(s.texture_files[0].uses, ["alpha"]);
    let bvh = SceneBvh::new(&s);
    // The floor's left half (u < ½, x < 2) lets rays through; the light
    // (d 0.2) lets every ray through.
    let down = |x: f32| bvh.closest_hit(Vec3::new(x, 1.0, 2.0), -Vec3::Y, 0.0, 10.0);
    assert!(down(1.0).is_none());
    assert!(down(3.0).is_some());
    assert!(bvh
        .closest_hit(Vec3::new(3.0, 1.0, 2.0), Vec3::Y, 0.0, 10.0)
        .is_none());
    // Coverage samples no hole: of 4000 drawn over the 32 m² (the floor
    // and the light), about the floor's opaque quarter remain.
    let samples = probeplace::coverage::sample_surface(&s, 4000, 1);
    assert!((800..1200).contains(&samples.len()), "{}", samples.len());
    assert!(
        samples
            .iter()
            .all(|p| p.position.y < 1e-3 && p.position.x >= 2.0 - 1e-3),
        "a sample in a hole"
    );
    for (mtl, cut) in [
        ("d 1\nTr 0", false),
        ("Tr 0.9", true),
        ("d 0.9\nTr 0.9", false),
    ] {
        let s = load(&room(dir.path(), "dissolve", mtl, "Kd 1 1 1"));
        assert_eq!(
            s.materials[0].cutout.is_some_and(|c| c.everywhere()),
            cut,
            "{mtl}"
        );
    }
}

/// Texture files as real downloads place them (issue 69): a map written
/// relative to the OBJ while the MTL sits in another folder, and a path
/// from the author's machine whose image ships beside the MTL, are found,
/// with one warning naming both; `report.json`'s list names each file
/// read, and the summary line counts them.
#[test]
fn textures_are_found_beside_the_obj_or_the_mtl_and_listed_in_the_report() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::create_dir_all(d.join("materials")).unwrap();
    std::fs::create_dir_all(d.join("tex")).unwrap();
    std::fs::write(d.join("tex/wall.png"), checker_png(4)).unwrap();
    std::fs::write(d.join("materials/floor.png"), checker_png(2)).unwrap();
    std::fs::write(
        d.join("scene.obj"),
        "mtllib materials/scene.mtl\n\
         v 0 0 0\nv 0 0 4\nv 4 0 4\nv 4 0 0\nv 0 3 0\nv 4 3 0\nv 4 3 4\nv 0 3 4\n\
         vt 0 0\nvt 0 1\nvt 1 1\nvt 1 0\n\
         usemtl floor\nf 1/1 2/2 3/3 4/4\nusemtl wall\nf 5/1 6/4 7/3 8/2\nusemtl gone\nf 1 5 8 2\n",
    )
    .unwrap();
    std::fs::write(
        d.join("materials/scene.mtl"),
        "newmtl floor\nmap_Kd C:\\Users\\artist\\floor.png\nnewmtl wall\nmap_Kd tex/wall.png\nnewmtl gone\nmap_Kd nowhere.png\n",
    )
    .unwrap();
    let s = load(&d.join("scene.obj"));
    let moved: Vec<_> = s
        .warnings
        .iter()
        .filter(|w| w.contains("found elsewhere"))
        .collect();
    assert_eq!(moved.len(), 1, "{:?}", s.warnings);
    assert!(
        moved[0].contains("(beside the OBJ)") && moved[0].contains("(in the MTL's folder)"),
        "{}",
        moved[0]
    );
    assert!(s.materials[0].diffuse_map.is_some() && s.materials[1].diffuse_map.is_some());
    let read: Vec<_> = s
        .texture_files
        .iter()
        .filter(|f| f.status.is_ok())
        .collect();
    assert_eq!(read.len(), 2, "{:?}", s.texture_files);
    assert!(read
        .iter()
        .any(|f| f.name.ends_with("tex/wall.png") && f.status == Ok([4, 4])));
    assert!(read.iter().any(|f| f.name.ends_with("materials/floor.png")));
    // The report lists the three, and the summary line counts them.
    std::fs::write(
        d.join("run.ron"),
        "(scene: \"scene.obj\", voxel_size: 0.2, output: \"out\", refine: (enabled: false))\n",
    )
    .unwrap();
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_probeplace"))
        .args(["place", "run.ron"])
        .current_dir(d)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(stdout.contains("textures: 2 of 3 read"), "{stdout}");
    let report: serde_json::Value =
        serde_json::from_slice(&std::fs::read(d.join("out/report.json")).unwrap()).unwrap();
    let list = report["scene"]["textures"].as_array().unwrap();
    assert_eq!(list.len(), 3);
    let gone = list
        .iter()
        .find(|t| t["file"].as_str().unwrap().ends_with("nowhere.png"))
        .unwrap();
    assert_eq!(gone["missing"], "texture not found");
    assert_eq!(gone["size"], serde_json::Value::Null);
    assert_eq!(gone["uses"], json!(["colour"]));
}

/// `KHR_materials_specular` (issue 69): its factors set a dielectric's
/// specular reflectance (`min(0.04 · specularColorFactor, 1) ·
/// specularFactor`), so a converted MTL keeps its `Ks` (0 for most);
/// its textures are named as not applied, in one warning.
#[test]
fn khr_materials_specular_factors_set_a_dielectrics_reflectance() {
    let dir = tempfile::tempdir().unwrap();
    let mut b = Builder::new();
    let specs = [
        json!({"specularFactor": 0.0}),
        json!({"specularColorFactor": [2.0, 1.0, 0.5]}),
        json!({"specularFactor": 0.5, "specularTexture": {"index": 0}}),
    ];
    let image = b.image(&png_rgb(1, 1, &[255, 255, 255]), "image/png");
    b.texture(image, None);
    let mut roots = Vec::new();
    for (k, spec) in specs.iter().enumerate() {
        let m = b.material(&format!("s{k}"), [0.5; 3], 0.0, 1.0, [0.0; 3]);
        b.material_json(m)["extensions"]["KHR_materials_specular"] = spec.clone();
        let mesh = b.unit_quad(Some(m));
        roots.push(b.node(json!({"mesh": mesh, "translation": [2.0 * k as f64, 0.0, 0.0]})));
    }
    b.use_extension("KHR_materials_specular");
    b.scene(&roots);
    std::fs::write(dir.path().join("spec.glb"), b.glb()).unwrap();
    let s = load(&dir.path().join("spec.glb"));
    let ks: Vec<[f32; 3]> = s.materials[..3].iter().map(|m| m.specular).collect();
    assert_eq!(ks[0], [0.0; 3]);
    assert_eq!(ks[1], [0.08, 0.04, 0.02]);
    assert_eq!(ks[2], [0.02; 3]);
    assert!(s.materials[..3].iter().all(|m| m.diffuse == [0.5; 3]));
    assert_eq!(s.warnings.len(), 1, "{:?}", s.warnings);
    assert!(
        s.warnings[0].contains("`s2`") && s.warnings[0].contains("not applied"),
        "{}",
        s.warnings[0]
    );
}
