//! Writes every scene of `probeplace::fixtures::generated::suite()` to a directory:
//! `cargo run --release --example gen_scenes -- DIR` writes `<kind>-<seed>.obj`,
//! `.mtl` and a `.ron` stock config that loads it with its scale and up axis. Each
//! written scene is loaded back and listed with its triangle count and extent.
//! With `--lit`, each config also has a sun and a sky (`Generated::lit_config_text`),
//! for `compare`'s diffuse evaluation; with `--seeds A,B,…`, every kind at those
//! seeds instead of the suite's (seeds outside the suite: scenes nobody tuned for).

use probeplace::fixtures::generated::{generate, suite, Kind};
use std::path::PathBuf;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let usage = "usage: cargo run --release --example gen_scenes -- DIR [--lit] [--seeds A,B,...]";
    let args: Vec<String> = std::env::args().skip(1).collect();
    let dir: PathBuf = args.first().ok_or(usage)?.into();
    let lit = args.iter().any(|a| a == "--lit");
    let scenes: Vec<(Kind, u64)> = match args.iter().position(|a| a == "--seeds") {
        Some(i) => {
            let list = args.get(i + 1).ok_or(usage)?;
            let seeds: Vec<u64> = list
                .split(',')
                .map(|s| s.trim().parse::<u64>())
                .collect::<Result<_, _>>()
                .map_err(|e| format!("--seeds {list}: {e}"))?;
            Kind::ALL
                .iter()
                .flat_map(|&k| seeds.iter().map(move |&s| (k, s)))
                .collect()
        }
        None => suite(),
    };
    std::fs::create_dir_all(&dir)?;
    for (kind, seed) in scenes {
        let g = generate(kind, seed);
        let name = &g.fixture.name;
        if lit {
            g.write_lit(&dir)?;
        } else {
            g.write(&dir)?;
        }
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
