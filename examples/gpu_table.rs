//! BENCHMARKS.md's table of GPU tracer runs, from the runs' JSON:
//! `cargo run --release --example gpu_table -- NAME RUN/report.json [NAME
//! RUN/report.json ...]` prints one Markdown row per `render` run: its
//! adapter and frame size, the glossy rays traced, each variant's texel
//! fetches per ray (on average and in 32-ray warps), the GPU time of each
//! variant's glossy trace and of the irradiance gather (timestamp queries;
//! none for the CPU twin, and no split in runs before the trace and the
//! gather were timed apart), and each variant's wall time
//! (`render.timings_ms`).
//!
//! `gpu_table --compare RUN/compare.json` prints instead each placement
//! row's texel fetches per glossy ray, on average and in 32-ray warps
//! (means over the views), its GPU trace and gather times (sums over the
//! views, on a GPU), and their Hi-Z / bi-level ratios for the grids, which
//! `compare` traces both ways.

#[path = "common/json.rs"]
mod json;
use json::read;

/// A millisecond figure, or a dash where the run has none.
fn ms(v: &serde_json::Value) -> String {
    v.as_f64().map_or("—".into(), |ms| format!("{ms:.2} ms"))
}

/// `a / b` to two decimals, or a dash.
fn ratio(a: &serde_json::Value, b: &serde_json::Value) -> String {
    match (a.as_f64(), b.as_f64()) {
        (Some(a), Some(b)) if b > 0.0 => format!("{:.2}", a / b),
        _ => "—".into(),
    }
}

/// The `--compare` table of `compare.json` at `path`.
fn compare_table(path: &str) -> Result<(), Box<dyn std::error::Error>> {
    let report = read(path)?;
    let rows = report["placements"].as_array().ok_or("no placements")?;
    let mean = |row: &serde_json::Value, key: &str| {
        let cams = row["cameras"].as_array().map(Vec::as_slice).unwrap_or(&[]);
        let v: Vec<f64> = cams.iter().filter_map(|c| c[key].as_f64()).collect();
        (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64)
    };
    // Summed over the views, where every view has it (a GPU run).
    let sum = |row: &serde_json::Value, key: &str| {
        let cams = row["cameras"].as_array().map(Vec::as_slice).unwrap_or(&[]);
        let v: Option<Vec<f64>> = cams.iter().map(|c| c[key].as_f64()).collect();
        v.filter(|v| !v.is_empty()).map(|v| v.iter().sum::<f64>())
    };
    println!("| placement | tracer | probes | texel fetches / ray | in 32-ray warps | GPU trace / gather ms | Hi-Z / bi-level: fetches, warps, trace ms |");
    println!("|---|---|---:|---:|---:|---|---|");
    for row in rows {
        let name = row["name"].as_str().unwrap_or("?");
        let tracer = row["tracer"].as_str().unwrap_or("?");
        let (f, w) = (
            mean(row, "texel_fetches_per_ray"),
            mean(row, "warp_fetches_per_ray"),
        );
        let other = rows
            .iter()
            .find(|o| o["name"] == row["name"] && o["tracer"] != row["tracer"]);
        let ratios = match other {
            Some(o) if tracer.starts_with("bilevel") => {
                let r = |a: Option<f64>, b: Option<f64>| {
                    a.zip(b)
                        .map_or("—".into(), |(a, b)| format!("{:.2}", a / b))
                };
                format!(
                    "{}, {}, {}",
                    r(mean(o, "texel_fetches_per_ray"), f),
                    r(mean(o, "warp_fetches_per_ray"), w),
                    r(sum(o, "gpu_trace_ms"), sum(row, "gpu_trace_ms"))
                )
            }
            _ => String::new(),
        };
        let cell = |v: Option<f64>| v.map_or("—".into(), |v| format!("{v:.1}"));
        let gpu = match (sum(row, "gpu_trace_ms"), sum(row, "gpu_gather_ms")) {
            (Some(t), Some(g)) => format!("{t:.2} / {g:.2}"),
            _ => "—".into(),
        };
        println!(
            "| {name} | {tracer} | {} | {} | {} | {gpu} | {ratios} |",
            row["probes"],
            cell(f),
            cell(w)
        );
    }
    Ok(())
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if let [flag, path] = args.as_slice() {
        if flag == "--compare" {
            return compare_table(path);
        }
    }
    if args.is_empty() || !args.len().is_multiple_of(2) {
        return Err("usage: gpu_table NAME RUN/report.json [NAME RUN/report.json ...]".into());
    }
    println!("| run | adapter | pixels | glossy rays | texel fetches/ray bi-level → Hi-Z | in 32-ray warps | `gpu_ms` bi-level / Hi-Z (ratio) | trace bi-level / Hi-Z (ratio) | gather | variant wall ms bi-level / Hi-Z |");
    println!("|---|---|---|---|---|---|---|---|---|---|");
    for row in args.chunks(2) {
        let report = read(&row[1])?;
        let render = &report["render"];
        let (b, h) = (&render["variants"]["bilevel"], &render["variants"]["hiz"]);
        let f = |v: &serde_json::Value| v.as_f64().unwrap_or(f64::NAN);
        println!(
            "| {} | {} | {}×{} | {} | {:.1} → {:.1} | {:.1} → {:.1} | {} / {} ({}) | {} / {} ({}) | {} | {:.0} / {:.0} |",
            row[0],
            render["adapter"].as_str().unwrap_or("?"),
            render["width"],
            render["height"],
            render["glossy_rays"],
            f(&b["texel_fetches_per_ray"]),
            f(&h["texel_fetches_per_ray"]),
            f(&b["warp_fetches_per_ray"]),
            f(&h["warp_fetches_per_ray"]),
            ms(&b["gpu_ms"]),
            ms(&h["gpu_ms"]),
            ratio(&h["gpu_ms"], &b["gpu_ms"]),
            ms(&b["gpu_trace_ms"]),
            ms(&h["gpu_trace_ms"]),
            ratio(&h["gpu_trace_ms"], &b["gpu_trace_ms"]),
            ms(&h["gpu_gather_ms"]),
            f(&render["timings_ms"]["bilevel"]),
            f(&render["timings_ms"]["hiz"]),
        );
    }
    Ok(())
}
