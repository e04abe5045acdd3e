//! Writes every scene of `probeplace::fixtures::generated::suite()` to a directory:
//! `cargo run --release --example gen_scenes -- DIR` writes `<kind>-<seed>.obj`,
//! `.mtl` and a `.ron` config that loads it with its scale and up axis. Each
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
        let obj = dir.join(format!("{name}.obj"));
        std::fs::write(&obj, &g.fixture.obj)?;
        std::fs::write(dir.join(format!("{name}.mtl")), &g.fixture.mtl)?;
        let config = format!(
            "(\n    scene: \"{name}.obj\",\n    scale: {:?},\n    up: {:?},\n    placement: SdfSkeleton(()),\n    seed: 1,\n)\n",
            g.scale, g.up
        );
        std::fs::write(dir.join(format!("{name}.ron")), config)?;
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
