//! BENCHMARKS.md's table of GPU tracer runs, from the runs' JSON:
//! `cargo run --release --example gpu_table -- NAME RUN/report.json [NAME
//! RUN/report.json ...]` prints one Markdown row per `render` run: its
//! adapter and frame size, the glossy rays traced, each variant's texel
//! fetches per ray (on average and in 32-ray warps), the GPU time of each
//! variant's glossy trace and of the irradiance gather (timestamp queries;
//! none for the CPU twin, and no split in runs before the trace and the
//! gather were timed apart), and each variant's wall time
//! (`render.timings_ms`).

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

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
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
