//! README.md's sentence on `max_probes`, from the two runs' JSON:
//! `cargo run --release --example budget_line -- OURS/report.json
//! GRID/report.json` prints it, with the budget, the count the coverage
//! target needed, and both runs' coverage as `report.json` gives them.
//!
//! The runs (docs/config.md, "Artist controls"): `configs/sponza.ron` with
//! `max_probes: 8` added, placed as it is (OURS) and with `--method
//! grid:4x1x2 --no-refine` (GRID).

use serde_json::Value;

#[path = "common/json.rs"]
mod json;
use json::read;

/// `v` as a number, or an error naming the file and field.
fn number(v: &Value, path: &str, field: &str) -> Result<f64, Box<dyn std::error::Error>> {
    v.as_f64()
        .ok_or_else(|| format!("{path}: no number at {field}").into())
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [ours_path, grid_path] = args.as_slice() else {
        return Err("usage: budget_line OURS/report.json GRID/report.json".into());
    };
    let (ours, grid) = (read(ours_path)?, read(grid_path)?);
    let budget = number(
        &ours["controls"]["max_probes"],
        ours_path,
        "controls.max_probes",
    )?;
    let needed = number(
        &ours["controls"]["probes_before_budget"],
        ours_path,
        "controls.probes_before_budget",
    )?;
    let target = number(
        &ours["refine"]["params"]["coverage_target"],
        ours_path,
        "refine.params.coverage_target",
    )?;
    let kept = number(&ours["probe_count"], ours_path, "probe_count")?;
    let grid_count = number(&grid["probe_count"], grid_path, "probe_count")?;
    let method = grid["method"]
        .as_str()
        .ok_or_else(|| format!("{grid_path}: no method"))?;
    let cells = method.strip_prefix("grid:").unwrap_or(method);
    println!(
        "On Sponza, `max_probes: {budget}` (added to `configs/sponza.ron`, then \
         `probeplace place`) keeps {kept} of the {needed} probes the {:.1}% target \
         needs and reaches **{:.2}%** coverage; the {grid_count}-probe uniform grid \
         (`--method grid:{cells} --no-refine`) reaches {:.2}%.",
        100.0 * target,
        100.0 * number(&ours["coverage"], ours_path, "coverage")?,
        100.0 * number(&grid["coverage"], grid_path, "coverage")?,
    );
    Ok(())
}
