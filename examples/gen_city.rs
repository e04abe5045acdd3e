//! Writes the seeded city block of `probeplace::fixtures::city` (the scaling
//! benchmark's scene, never committed):
//! `cargo run --release --example gen_city -- DIR [SEED] [TRIANGLES]`
//! writes `city-<seed>.obj`, `.mtl` and the stock config `city-<seed>.ron`
//! (defaults: seed 1, 5 000 000 triangles) and prints the config's path.

use probeplace::fixtures::city::write_city;
use std::path::PathBuf;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let dir: PathBuf = args
        .next()
        .ok_or("usage: cargo run --release --example gen_city -- DIR [SEED] [TRIANGLES]")?
        .into();
    let seed: u64 = args.next().map_or(Ok(1), |s| s.parse())?;
    let triangles: usize = args.next().map_or(Ok(5_000_000), |s| s.parse())?;
    std::fs::create_dir_all(&dir)?;
    let city = write_city(&dir, seed, triangles)?;
    eprintln!(
        "{} buildings, tessellation level {}, {} triangles",
        city.buildings, city.level, city.triangles
    );
    println!("{}", city.config.display());
    Ok(())
}
