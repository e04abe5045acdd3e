//! Writes stand-in images for the textures an OBJ's materials map but
//! that are missing (../shared's Dabrovic Sponza and Holodeck come without
//! theirs), so that the cost of textures on a real interior can be
//! measured (BENCHMARKS.md, "Textures"):
//!
//! `cargo run --release --example texture_stand_ins -- IN.obj OUT_DIR [--side N]`
//!
//! Copies the OBJ and its MTL files into `OUT_DIR` and writes, for every
//! `map_Kd` and `map_Ke` file name they give, an `N × N` (default 1024)
//! image beside them: a JPEG for a `.jpg`/`.jpeg` name, a PNG otherwise.
//! Each image is a deterministic pattern (tiles of two colours derived
//! from the file name), so reruns write the same bytes. Other maps
//! (`map_bump`, …) are not read by probeplace and are not written.

use std::path::{Path, PathBuf};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let usage =
        "usage: cargo run --release --example texture_stand_ins -- IN.obj OUT_DIR [--side N]";
    let args: Vec<String> = std::env::args().skip(1).collect();
    let input: PathBuf = args.first().ok_or(usage)?.into();
    let out: PathBuf = args.get(1).ok_or(usage)?.into();
    let side: u16 = match args.iter().position(|a| a == "--side") {
        Some(i) => args.get(i + 1).ok_or(usage)?.parse()?,
        None => 1024,
    };
    std::fs::create_dir_all(&out)?;
    let dir = input.parent().unwrap_or(Path::new(""));
    let obj = std::fs::read_to_string(&input)?;
    std::fs::write(out.join(input.file_name().ok_or(usage)?), &obj)?;
    let mut written = 0;
    for line in obj.lines() {
        let Some(libs) = line.trim_start().strip_prefix("mtllib ") else {
            continue;
        };
        for lib in libs.split_whitespace() {
            let text = std::fs::read_to_string(dir.join(lib))?;
            std::fs::write(out.join(lib), &text)?;
            let (_, maps, _) = probeplace::scene::obj::parse_mtl(&text, &out.join(lib));
            for m in maps {
                if m.file.exists() {
                    continue;
                }
                if let Some(parent) = m.file.parent() {
                    std::fs::create_dir_all(parent)?;
                }
                std::fs::write(&m.file, image(&m.file, side)?)?;
                written += 1;
            }
        }
    }
    println!(
        "{written} stand-in textures of {side}×{side} in {}",
        out.display()
    );
    Ok(())
}

/// The stand-in image for `file`: tiles of two colours from its name's
/// hash, as JPEG or PNG by its extension.
fn image(file: &Path, side: u16) -> Result<Vec<u8>, Box<dyn std::error::Error>> {
    let name = file.file_name().unwrap_or_default().to_string_lossy();
    let h = name.bytes().fold(0xcbf29ce484222325u64, |h, b| {
        (h ^ b as u64).wrapping_mul(0x100000001b3)
    });
    let a = [
        (h & 0xff) as u8,
        (h >> 8 & 0xff) as u8,
        (h >> 16 & 0xff) as u8,
    ];
    let b = a.map(|c| c / 3);
    let n = side as usize;
    let tile = (n / 16).max(1);
    let rgb: Vec<u8> = (0..n * n)
        .flat_map(|i| {
            if (i % n / tile + i / n / tile).is_multiple_of(2) {
                a
            } else {
                b
            }
        })
        .collect();
    let ext = file
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase());
    Ok(if matches!(ext.as_deref(), Some("jpg" | "jpeg")) {
        let mut out = Vec::new();
        jpeg_encoder::Encoder::new(&mut out, 90).encode(
            &rgb,
            side,
            side,
            jpeg_encoder::ColorType::Rgb,
        )?;
        out
    } else {
        probeplace::fixtures::gltf_writer::png_rgb(side as u32, side as u32, &rgb)
    })
}
