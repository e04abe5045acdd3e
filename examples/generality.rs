//! The generality table: `cargo run --release --example generality -- DIR`
//! runs the stock config on every generated scene of
//! `probeplace::fixtures::generated::suite()`, and every config of
//! `configs/` with its `voxel_size` removed, with both of our placement
//! methods; it writes each run's outputs under `DIR/<scene>-<method>/`, the
//! rows as `DIR/generality.json`, which `examples/results.rs` turns into
//! docs/results.md's generality table, and prints the rows as a Markdown
//! table (`probeplace::generality::markdown_table`).

use probeplace::config::{Config, Placement, VoxelSize};
use probeplace::fixtures::generated::{generate, suite};
use probeplace::generality;
use std::path::PathBuf;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let dir: PathBuf = std::env::args_os()
        .nth(1)
        .ok_or("usage: cargo run --release --example generality -- DIR")?
        .into();
    let scenes = dir.join("scenes");
    std::fs::create_dir_all(&scenes)?;
    let mut inputs: Vec<(String, Config, PathBuf)> = Vec::new();
    for (kind, seed) in suite() {
        let g = generate(kind, seed);
        let path = g.write(&scenes)?;
        inputs.push((g.fixture.name.clone(), Config::load(&path)?, path));
    }
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let mut configs: Vec<PathBuf> = std::fs::read_dir(root.join("configs"))?
        .map(|e| e.map(|e| e.path()))
        .collect::<Result<_, _>>()?;
    configs.retain(|p| p.extension().is_some_and(|e| e == "ron"));
    configs.sort();
    for path in configs {
        let mut config = Config::load(&path)?;
        config.voxel_size = VoxelSize::Auto;
        let name = path
            .file_stem()
            .unwrap_or_default()
            .to_string_lossy()
            .into_owned();
        inputs.push((name, config, path));
    }
    let mut rows = Vec::new();
    for (name, config, path) in inputs {
        for method in [
            Placement::default(),
            Placement::MedialAxis(Default::default()),
        ] {
            let mut config = config.clone();
            config.placement = method;
            let out = dir.join(format!("{name}-{}", method.name()));
            let row = generality::run(&name, config, &path, &out, true)?;
            eprintln!(
                "{name} {}: {} probes, coverage {:.4}",
                row.method, row.probes, row.coverage
            );
            rows.push(row);
        }
    }
    std::fs::write(
        dir.join("generality.json"),
        serde_json::to_vec_pretty(&rows)?,
    )?;
    print!("{}", generality::markdown_table(&rows));
    Ok(())
}
