//! Writes every scene of `probeplace::fixtures::generated::suite()` to a directory:
//! `cargo run --release --example gen_scenes -- DIR` writes `<kind>-<seed>.obj`,
//! `.mtl` and a `.ron` stock config that loads it with its scale and up axis. Each
//! written scene is loaded back and listed with its triangle count and extent.

use probeplace::fixtures::generated::{generate, suite};
use std::path::PathBuf;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let dir: PathBuf = std::env::args_os()
        .nth(1)
        .ok_or("usage: cargo run --release --example gen_scenes -- DIR")?
        .into();
    std::fs::create_dir_all(&dir)?;
    for (kind, seed) in suite() {
        let g = generate(kind, seed);
        let name = &g.fixture.name;
        g.write(&dir)?;
        let obj = dir.join(format!("{name}.obj"));
        let scene = probeplace::scene::load_obj(&obj, g.scale, g.up)?;
        let size = scene.bounds.size();
        println!(
            "{name}: {} triangles, {:.2} x {:.2} x {:.2} m",
            scene.triangles.len(),
            size.x,
            size.y,
            size.z
        );
    }
    Ok(())
}
