//! Converts an OBJ scene to glTF 2.0, as the tests convert Dabrovic Sponza
//! and the Holodeck to place in them from glTF
//! (`probeplace::fixtures::gltf_writer::from_scene` says what is kept):
//!
//! `cargo run --release --example obj_to_gltf -- IN.obj OUT.glb [--scale S] [--up Y|Z] [--metal-rough]`
//!
//! `--metal-rough` writes the materials as most real assets do, their metal
//! and roughness in a `metallicRoughnessTexture` under factors of 1
//! (`gltf_writer::from_scene_with`).
//!
//! `OUT` ending in `.gltf` writes its buffer beside it (`OUT.bin`). The
//! scale and up axis are applied, so the glTF is Y up in the world units a
//! config of the OBJ with that `scale` and `up` works in: its config takes
//! `scale: 1, up: Y`.

use probeplace::config::UpAxis;
use std::path::PathBuf;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let usage = "usage: cargo run --release --example obj_to_gltf -- IN.obj OUT.glb|OUT.gltf [--scale S] [--up Y|Z] [--metal-rough]";
    let args: Vec<String> = std::env::args().skip(1).collect();
    let input: PathBuf = args.first().ok_or(usage)?.into();
    let output: PathBuf = args.get(1).ok_or(usage)?.into();
    let value = |flag: &str| {
        args.iter()
            .position(|a| a == flag)
            .and_then(|i| args.get(i + 1))
    };
    let scale: f64 = value("--scale").map_or(Ok(1.0), |s| s.parse())?;
    let up = match value("--up").map(String::as_str) {
        None | Some("Y") => UpAxis::Y,
        Some("Z") => UpAxis::Z,
        Some(other) => return Err(format!("--up {other}: Y or Z").into()),
    };
    let scene = probeplace::scene::load_obj(&input, scale, up)?;
    let metal_rough = args.iter().any(|a| a == "--metal-rough");
    let gltf = probeplace::fixtures::gltf_writer::from_scene_with(&scene, metal_rough);
    if output.extension().is_some_and(|e| e == "gltf") {
        let bin = output.with_extension("bin");
        let name = bin
            .file_name()
            .unwrap()
            .to_string_lossy()
            .replace('%', "%25")
            .replace(' ', "%20");
        std::fs::write(&bin, gltf.bin())?;
        std::fs::write(&output, gltf.gltf(Some(&name)))?;
    } else {
        std::fs::write(&output, gltf.glb())?;
    }
    println!(
        "{}: {} triangles, {} materials",
        output.display(),
        scene.triangles.len(),
        scene.materials.len()
    );
    Ok(())
}
