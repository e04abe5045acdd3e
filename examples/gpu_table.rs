//! BENCHMARKS.md's table of GPU tracer runs, from the runs' JSON:
//! `cargo run --release --example gpu_table -- NAME RUN/report.json [NAME
//! RUN/report.json ...]` prints one Markdown row per `render` run: its
//! adapter and frame size, the glossy rays traced, each variant's texel
//! fetches per ray and GPU time (`gpu_ms`, timestamp queries; none for the
//! CPU twin), and each variant's wall time (`render.timings_ms`).

#[path = "common/json.rs"]
mod json;
use json::read;

/// A `gpu_ms` figure, or a dash where the run had no GPU.
fn gpu_ms(v: &serde_json::Value) -> String {
    v["gpu_ms"]
        .as_f64()
        .map_or("—".into(), |ms| format!("{ms:.2} ms"))
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.is_empty() || !args.len().is_multiple_of(2) {
        return Err("usage: gpu_table NAME RUN/report.json [NAME RUN/report.json ...]".into());
    }
    println!("| run | adapter | pixels | glossy rays | texel fetches/ray bi-level → Hi-Z | `gpu_ms` bi-level | `gpu_ms` Hi-Z | Hi-Z / bi-level | variant wall ms bi-level / Hi-Z |");
    println!("|---|---|---|---|---|---|---|---|---|");
    for row in args.chunks(2) {
        let report = read(&row[1])?;
        let render = &report["render"];
        let (b, h) = (&render["variants"]["bilevel"], &render["variants"]["hiz"]);
        let ratio = match (h["gpu_ms"].as_f64(), b["gpu_ms"].as_f64()) {
            (Some(h), Some(b)) if b > 0.0 => format!("{:.2}", h / b),
            _ => "—".into(),
        };
        let f = |v: &serde_json::Value| v.as_f64().unwrap_or(f64::NAN);
        println!(
            "| {} | {} | {}×{} | {} | {:.1} → {:.1} | {} | {} | {} | {:.0} / {:.0} |",
            row[0],
            render["adapter"].as_str().unwrap_or("?"),
            render["width"],
            render["height"],
            render["glossy_rays"],
            f(&b["texel_fetches_per_ray"]),
            f(&h["texel_fetches_per_ray"]),
            gpu_ms(b),
            gpu_ms(h),
            ratio,
            f(&render["timings_ms"]["bilevel"]),
            f(&render["timings_ms"]["hiz"]),
        );
    }
    Ok(())
}
