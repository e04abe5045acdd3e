//! The real scenes of McGuire's Computer Graphics Archive, read from
//! ../shared/scenes (never copied into the repository).

use crate::common::*;

/// The report of `place` on the shipped config, run once per test process
/// (the SVO tests read the same runs).
fn run(config: &str) -> &'static serde_json::Value {
    shared_scenes();
    let r = &shared_job("place", &format!("configs/{config}.ron"), &[]).report;
    assert_svo_sound(r, config);
    r
}

#[test]
fn dabrovic_sponza() {
    let r = run("sponza");
    assert_eq!(r["probes_in_solid"], 0);
    assert!(r["scene"]["triangles"].as_u64().unwrap() > 66_000);
    let cov = r["coverage"].as_f64().unwrap();
    assert!(cov >= 0.9, "coverage {cov}");
    assert!(r["coverage_ci95"].as_f64().unwrap() <= 0.005);
    // The atrium is open to the sky: some voxels must be classified outside.
    assert!(r["sdf"]["outside"].as_u64().unwrap() > 0);
    // No normals in the file, so the loader used geometric normals: nothing to drop but slivers.
    assert!(r["scene"]["dropped_triangles"].as_u64().unwrap() < 100);
    // Its MTL names textures in upper case (`SP_LUK.JPG`) that the archive
    // spells in mixed case (`sp_luk.JPG`): every one is found, and one
    // warning says which were respelt.
    let warnings: Vec<&str> = r["warnings"]
        .as_array()
        .unwrap()
        .iter()
        .filter_map(|w| w.as_str())
        .collect();
    assert!(
        !warnings.iter().any(|w| w.contains("texture not found")),
        "{warnings:?}"
    );
    let respelt: Vec<_> = warnings
        .iter()
        .filter(|w| w.contains("another letter case"))
        .collect();
    assert_eq!(respelt.len(), 1, "{warnings:?}");
    assert!(
        respelt[0].contains("SP_LUK.JPG as sp_luk.JPG"),
        "{}",
        respelt[0]
    );
    // `report.json` lists every colour texture the MTL names, each read:
    // its 12 distinct `map_Kd` files (the bump maps are not read).
    let textures = r["scene"]["textures"].as_array().unwrap();
    let mtl = std::fs::read_to_string(root().join("../shared/scenes/dabrovic_sponza/sponza.mtl"))
        .unwrap();
    let mut named: Vec<String> = mtl
        .lines()
        .filter_map(|l| l.trim().strip_prefix("map_Kd "))
        .map(|f| f.trim().to_lowercase())
        .collect();
    named.sort();
    named.dedup();
    assert_eq!(textures.len(), named.len(), "{textures:?}");
    for t in textures {
        assert!(t["missing"].is_null() && t["size"].is_array(), "{t}");
        assert_eq!(t["uses"], serde_json::json!(["colour"]), "{t}");
        let file = t["file"].as_str().unwrap().to_lowercase();
        assert!(named.iter().any(|n| file.ends_with(n.as_str())), "{file}");
    }
}

#[test]
fn holodeck() {
    let r = run("holodeck");
    assert_eq!(r["probes_in_solid"], 0);
    assert!(r["coverage"].as_f64().unwrap() >= 0.9, "{}", r["coverage"]);
}

fn cornell_variant(cfg: &str) {
    let r = run(cfg);
    assert_eq!(r["probes_in_solid"], 0, "{cfg}");
    assert!(r["probe_count"].as_u64().unwrap() >= 1, "{cfg}");
}

/// The variants other tests also run (their runs are shared), and the
/// mirror: a box of 36 triangles.
#[test]
fn cornell_variants() {
    for cfg in ["cornell-original", "cornell-glossy", "cornell-mirror"] {
        cornell_variant(cfg);
    }
}

/// The variants with a sphere, water (7 088 triangles) or nothing inside.
#[test]
#[ignore = "full tier (about 30 s): cargo test --release -- --include-ignored"]
fn cornell_variants_with_other_contents() {
    for cfg in ["cornell-sphere", "cornell-water", "cornell-empty"] {
        cornell_variant(cfg);
    }
}

#[test]
fn archive_cornell_box_matches_our_measured_fixture() {
    // Same box, two sources (the archive's ~2-unit model and our millimetre
    // fixture): both must meet the default run's bar, coverage's count (the
    // diffuse step adds its own after it).
    let r = run("cornell-original");
    assert!(r["coverage"].as_f64().unwrap() >= 0.95, "{}", r["coverage"]);
    assert!(r["refine"]["probes_final"].as_u64().unwrap() <= 12);
}

/// Sponza and the Holodeck converted to glTF by the test kit's converter
/// (what `examples/obj_to_gltf.rs` runs) place as their OBJ does (issue
/// 48): the same triangles within float rounding, the same coverage
/// within the two runs' intervals, and coverage's probe count within 5%.
/// The conversion keeps each material's diffuse colour and emission; its
/// `Ks` becomes a dielectric's 4%, which changes the light the diffuse
/// step optimizes for (it follows the light transport), hence not
/// byte-identical placements, and final counts that may differ more.
/// Sponza is written as real assets are (issue 69): `metallicFactor` 1
/// and the metal (0) painted in a `metallicRoughnessTexture`. Its
/// materials are not metal: the `.glb` scene export's base colours are
/// the OBJ's diffuse colours.
#[test]
fn sponza_and_the_holodeck_as_gltf_place_as_their_obj() {
    for config in ["sponza", "holodeck"] {
        let metal_rough = config == "sponza";
        let obj = run(config);
        let cfg = probeplace::config::Config::load(&root().join(format!("configs/{config}.ron")))
            .unwrap();
        let scene = probeplace::scene::load_obj(&cfg.scene, cfg.scale.0, cfg.up).unwrap();
        let dir = tempfile::tempdir().unwrap();
        let glb = dir.path().join(format!("{config}.glb"));
        std::fs::write(
            &glb,
            probeplace::fixtures::gltf_writer::from_scene_with(&scene, metal_rough).glb(),
        )
        .unwrap();
        let loaded = probeplace::scene::load(&glb, 1.0, probeplace::config::UpAxis::Y).unwrap();
        assert_eq!(loaded.triangles.len(), scene.triangles.len(), "{config}");
        let painted = loaded
            .materials
            .iter()
            .filter(|m| m.metal_rough.is_some())
            .count();
        assert_eq!(painted > 0, metal_rough, "{config}");
        let ov = overlay(
            &format!("configs/{config}.ron"),
            &[
                ("scene", &format!("{:?}", glb.display().to_string())),
                ("scale", "1.0"),
                ("up", "Y"),
            ],
        );
        let r = place(ov.path(), &dir.path().join("out"), &[]);
        assert_eq!(r["probes_in_solid"], 0, "{config}");
        let (n, m) = (
            r["refine"]["probes_final"].as_f64().unwrap(),
            obj["refine"]["probes_final"].as_f64().unwrap(),
        );
        assert!(
            (n - m).abs() <= 0.05 * m,
            "{config}: coverage placed {n} probes from glTF, {m} from OBJ"
        );
        let (c, d) = (
            r["coverage"].as_f64().unwrap(),
            obj["coverage"].as_f64().unwrap(),
        );
        let ci = r["coverage_ci95"].as_f64().unwrap() + obj["coverage_ci95"].as_f64().unwrap();
        assert!(
            (c - d).abs() <= ci,
            "{config}: coverage {c} from glTF, {d} from OBJ (± {ci})"
        );
        eprintln!("{config}: glTF {n} probes, {c:.5}; OBJ {m} probes, {d:.5}");
        if metal_rough {
            // The scene export: each material's base colour is the OBJ's
            // diffuse colour (metal 0), as the glTF read it.
            let out = dir.path().join("scene-export");
            let o = probeplace(&[
                "export",
                dir.path().join("out").to_str().unwrap(),
                "--format",
                "glb",
                "--scene",
                "--out",
                out.to_str().unwrap(),
            ]);
            assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
            let glb = std::fs::read(out.join("probes.glb")).unwrap();
            let len = u32::from_le_bytes(glb[12..16].try_into().unwrap()) as usize;
            let doc: serde_json::Value = serde_json::from_slice(&glb[20..20 + len]).unwrap();
            let exported = doc["materials"].as_array().unwrap();
            let mut checked = 0;
            for m in exported {
                let name = m["name"].as_str().unwrap();
                let Some(source) = scene.materials.iter().find(|s| s.name == name) else {
                    continue;
                };
                let base: Vec<f64> =
                    serde_json::from_value(m["pbrMetallicRoughness"]["baseColorFactor"].clone())
                        .unwrap();
                for c in 0..3 {
                    assert!(
                        (base[c] - source.diffuse[c] as f64).abs() < 1e-6,
                        "{name}: base colour {base:?}, the OBJ's Kd {:?}",
                        source.diffuse
                    );
                }
                checked += 1;
            }
            assert!(
                checked >= 20,
                "{checked} materials checked of {}",
                exported.len()
            );
        }
    }
}

/// Sponza as real glTF assets write it (metal and roughness painted in a
/// texture under factors of 1) bakes the light its OBJ bakes, within 2%
/// of its mean probe irradiance at the OBJ's probes (issue 69; measured:
/// 0.1%). The conversion keeps the MTL's `Ks` by `KHR_materials_specular`
/// (`Ks 0` on 19 of 21 materials: `specularFactor` 0); glTF's model alone
/// gives every dielectric a 4% specular layer, which baked 6% more light
/// (BENCHMARKS.md, "Cut-outs in the ray kernel"). Read as bare metal, as
/// before this issue, its diffuse albedo would be 0.
#[test]
#[ignore = "full tier (about 60 s): cargo test --release -- --include-ignored"]
fn sponza_as_metal_roughness_gltf_bakes_the_light_of_its_obj() {
    shared_scenes();
    let obj = shared_job("bake", "configs/sponza.ron", &[]);
    let probes = obj.dir.join("probes.json");
    let cfg = probeplace::config::Config::load(&root().join("configs/sponza.ron")).unwrap();
    let scene = probeplace::scene::load_obj(&cfg.scene, cfg.scale.0, cfg.up).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let glb = dir.path().join("sponza.glb");
    std::fs::write(
        &glb,
        probeplace::fixtures::gltf_writer::from_scene_with(&scene, true).glb(),
    )
    .unwrap();
    let mean = |out: &std::path::Path| -> f64 {
        let sh = read_json(&out.join("sh.json"));
        let probes = sh["probes"].as_array().unwrap();
        let sum: f64 = probes
            .iter()
            .flat_map(|p| p["irradiance_axes"].as_array().unwrap().iter())
            .flat_map(|a| a.as_array().unwrap().iter().map(|v| v.as_f64().unwrap()))
            .sum();
        sum / (18 * probes.len()) as f64
    };
    let bake_at_obj_probes = |scene: &std::path::Path, name: &str| -> f64 {
        let ov = overlay(
            "configs/sponza.ron",
            &[
                ("scene", &format!("{:?}", scene.display().to_string())),
                ("scale", "1.0"),
                ("up", "Y"),
            ],
        );
        let out = dir.path().join(name);
        run_job(
            "bake",
            ov.path(),
            &out,
            &["--probes", probes.to_str().unwrap()],
        );
        mean(&out)
    };
    let gltf = bake_at_obj_probes(&glb, "gltf");
    let plain = mean(&obj.dir);
    eprintln!("mean probe irradiance: glTF {gltf:.5}, OBJ {plain:.5}");
    assert!(
        (gltf / plain - 1.0).abs() < 0.02,
        "glTF {gltf} against the OBJ {plain}"
    );
}

/// Dabrovic Sponza's textures change the light its probes see (issue 69):
/// baked at the same probes, the light surfaces reflect to them
/// (`sh.json`'s `indirect`) is well under the untextured scene's, whose
/// materials keep their factors alone (`Kd` up to 1, where the stone
/// textures average far darker). Measured: 0.44×.
#[test]
#[ignore = "full tier (about 30 s): cargo test --release -- --include-ignored"]
fn sponza_textures_darken_the_light_its_probes_see() {
    shared_scenes();
    let obj = shared_job("bake", "configs/sponza.ron", &[]);
    let cfg = probeplace::config::Config::load(&root().join("configs/sponza.ron")).unwrap();
    // The same OBJ and MTL without the images beside them.
    let dir = tempfile::tempdir().unwrap();
    let bare = dir.path().join("bare");
    std::fs::create_dir_all(&bare).unwrap();
    let source = cfg.scene.parent().unwrap();
    for f in ["sponza.obj", "sponza.mtl"] {
        std::os::unix::fs::symlink(source.join(f), bare.join(f)).unwrap();
    }
    let ov = overlay(
        "configs/sponza.ron",
        &[(
            "scene",
            &format!("{:?}", bare.join("sponza.obj").display().to_string()),
        )],
    );
    let out = dir.path().join("out");
    let probes = obj.dir.join("probes.json");
    let r = run_job(
        "bake",
        ov.path(),
        &out,
        &["--probes", probes.to_str().unwrap()],
    );
    let list = r["scene"]["textures"].as_array().unwrap();
    assert!(list.iter().all(|t| t["missing"].is_string()), "{list:?}");
    assert!(obj.report["scene"]["textures"]
        .as_array()
        .unwrap()
        .iter()
        .all(|t| t["missing"].is_null()));
    let indirect = |out: &std::path::Path| -> f64 {
        let sh = read_json(&out.join("sh.json"));
        let probes = sh["probes"].as_array().unwrap();
        probes
            .iter()
            .map(|p| {
                let c: [f64; 3] = serde_json::from_value(p["indirect"][0].clone()).unwrap();
                c.iter().sum::<f64>() / 3.0
            })
            .sum::<f64>()
            / probes.len() as f64
    };
    let (textured, bare) = (indirect(&obj.dir), indirect(&out));
    eprintln!("mean reflected light at the probes: textured {textured:.5}, untextured {bare:.5}");
    assert!(
        textured < 0.8 * bare,
        "textured {textured}, untextured {bare}"
    );
}
