//! The re-measure table of docs/method.md ("Coverage on samples the placer
//! never saw"): for each placement directory `DIR` given, its `report.json`
//! and those of `DIR-sS` for each seed `S` of `--seeds` (the same probes
//! scored by `place CONFIG --probes DIR/probes.json --seed S --out DIR-sS`),
//! one Markdown row: probes, the validation coverage, the training score,
//! each seed's coverage with its interval and its probes in solid (by their
//! rays; by that seed's SDF), and whether every figure clears the target
//! less its interval's half-width with no probe in solid by their rays.
//!
//! ```sh
//! cargo run --release --example remeasure_table -- --seeds 101,202,303 out/acc/cornell out/acc/sponza
//! ```

#[path = "common/json.rs"]
mod json;
use json::read;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args: Vec<String> = std::env::args().skip(1).collect();
    let usage = "usage: remeasure_table --seeds S,S,... DIR [DIR ...]";
    if args.len() < 3 || args[0] != "--seeds" {
        return Err(usage.into());
    }
    let seeds: Vec<u64> = args[1]
        .split(',')
        .map(|s| s.parse().map_err(|_| format!("--seeds: {s}: not a seed")))
        .collect::<Result<_, _>>()?;
    let dirs = args.split_off(2);
    let pct = |v: &serde_json::Value| 100.0 * v.as_f64().unwrap_or(f64::NAN);
    let mut header = String::from("| scene | probes | validation | training |");
    let mut rule = String::from("|---|---:|---:|---:|");
    for s in &seeds {
        header += &format!(" seed {s} | in solid |");
        rule += "---:|---:|";
    }
    println!("{header} holds |");
    println!("{rule}---|");
    let (mut rows, mut held) = (0, 0);
    for dir in &dirs {
        let r = read(&format!("{dir}/report.json"))?;
        let target = r["refine"]["params"]["coverage_target"]
            .as_f64()
            .unwrap_or(0.999);
        let clears = |x: &serde_json::Value| {
            x["coverage"].as_f64().unwrap_or(0.0)
                >= target - x["coverage_ci95"].as_f64().unwrap_or(0.0)
                && x["probes_in_solid"] == 0
        };
        let name = std::path::Path::new(dir)
            .file_name()
            .map_or(dir.clone(), |n| n.to_string_lossy().into_owned());
        let mut row = format!(
            "| {name} | {} | {:.2}% ± {:.2}% | {} |",
            r["probe_count"],
            pct(&r["coverage"]),
            pct(&r["coverage_ci95"]),
            r["coverage_train"]
                .as_f64()
                .map_or("–".to_string(), |t| format!("{:.2}%", 100.0 * t)),
        );
        let mut ok = clears(&r);
        for s in &seeds {
            let m = read(&format!("{dir}-s{s}/report.json"))?;
            ok &= clears(&m);
            row += &format!(
                " {:.2}% ± {:.2}% | {}; {} |",
                pct(&m["coverage"]),
                pct(&m["coverage_ci95"]),
                m["probes_in_solid"],
                m["probes_in_solid_sdf"]
            );
        }
        rows += 1;
        held += ok as usize;
        println!("{row} {} |", if ok { "yes" } else { "**no**" });
    }
    println!();
    println!(
        "{held} of {rows} placements clear the target less the half-width on their validation stream and on every seed's re-measure, with no probe in solid by its rays."
    );
    Ok(())
}
