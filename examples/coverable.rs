//! How the coverage measure's denominator moves when its reference set
//! doubles: for each config given, the validation stream's coverable
//! fraction (coverable share of the surface samples) with the config's
//! `coverage.reference_points` and with twice as many, and the coverage of
//! the run's probes by each (docs/formats.md, "What coverage means").
//!
//! ```sh
//! cargo run --release --example coverable -- configs/sponza.ron out/sponza/probes.json
//! ```
//!
//! Arguments come in pairs, a config and the `probes.json` of its run.
//! Prints one JSON object per pair.

use probeplace::config::{Config, Count};
use probeplace::coverage::{CoverageReference, Stream};
use probeplace::progress::Progress;
use std::path::Path;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.is_empty() || !args.len().is_multiple_of(2) {
        return Err("usage: coverable CONFIG PROBES.json [CONFIG PROBES.json ...]".into());
    }
    for pair in args.chunks(2) {
        let path = Path::new(&pair[0]);
        let text = std::fs::read_to_string(path)?;
        let config = Config::from_text(&text, path)?;
        let hidden = Progress::hidden();
        let prepared = probeplace::stages::prepare(&config, path, &text, &hidden)?;
        let probes =
            probeplace::placement::file::read(Path::new(&pair[1]), &prepared.scene, "file")?
                .positions();
        let mut rows = Vec::new();
        for factor in [1u32, 2] {
            let mut params = config.coverage;
            params.reference_points = Count(params.reference_points.0 * factor);
            let reference = CoverageReference::by_rays(
                &prepared.scene,
                &prepared.bvh,
                &prepared.sdf,
                &prepared.domain,
                &params,
                Stream::Validation.seed(config.seed),
                &hidden,
            );
            let c = reference.evaluate(&prepared.bvh, &probes, &hidden);
            rows.push(format!(
                "{{\"reference_points\": {}, \"coverable_fraction\": {:.5}, \"coverage\": {:.5}, \"ci95\": {:.5}}}",
                c.reference_points, c.coverable_fraction, c.coverage, c.ci95
            ));
        }
        println!(
            "{{\"config\": {:?}, \"probes\": {}, \"measures\": [{}]}}",
            pair[0],
            probes.len(),
            rows.join(", ")
        );
    }
    Ok(())
}
