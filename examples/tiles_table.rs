//! The README's table of tiled worlds against one machine, from the runs'
//! JSON: `cargo run --release --example tiles_table -- NAME ONE/report.json
//! SPLIT/world/report.json [NAME ONE WORLD ...]` prints one Markdown row per
//! scene (docs/tiles.md, "How close to one machine", has the commands).

#[path = "common/json.rs"]
mod json;
use json::read;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.is_empty() || !args.len().is_multiple_of(3) {
        return Err("usage: tiles_table NAME ONE/report.json WORLD/report.json [...]".into());
    }
    println!("| scene | tiles | one machine: probes | coverage | tiles merged: probes | coverage | in solid | probes / one machine's |");
    println!("|---|---|---|---|---|---|---|---|");
    for row in args.chunks(3) {
        let (one, world) = (read(&row[1])?, read(&row[2])?);
        let world_index = read(&row[2].replace("report.json", "world.json"))?;
        let grid = &world_index["tiles_grid"];
        let (a, b) = (
            one["probe_count"].as_f64().unwrap_or(f64::NAN),
            world["probe_count"].as_f64().unwrap_or(f64::NAN),
        );
        println!(
            "| {} | {}×{}×{} | {} | {:.2}% | {} | {:.2}% ± {:.2}% | {} | {:.2} |",
            row[0],
            grid[0],
            grid[1],
            grid[2],
            a,
            100.0 * one["coverage"].as_f64().unwrap_or(f64::NAN),
            b,
            100.0 * world["coverage"].as_f64().unwrap_or(f64::NAN),
            100.0 * world["coverage_ci95"].as_f64().unwrap_or(f64::NAN),
            world["probes_in_solid"],
            b / a
        );
    }
    Ok(())
}
