//! The `probeplace` command line: parses arguments and calls the library.

use clap::{Parser, Subcommand};
use std::io::IsTerminal;
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(Parser)]
#[command(
    name = "probeplace",
    version,
    about = "Places light-field probes in a 3D scene"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Place probes as the config says; write probes.json, report.json and placement.png.
    Place {
        /// The run's RON config file.
        config: PathBuf,
        /// Output directory (default: the config's `output`).
        #[arg(long)]
        out: Option<PathBuf>,
        /// Placement method: `sdf-skeleton` or `grid:NxMxK` (default: the config's).
        #[arg(long)]
        method: Option<String>,
        /// Random seed (default: the config's).
        #[arg(long)]
        seed: Option<u64>,
        /// No progress bars and no summary.
        #[arg(long)]
        quiet: bool,
    },
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match cli.command {
        Command::Place {
            config,
            out,
            method,
            seed,
            quiet,
        } => {
            let options = probeplace::pipeline::PlaceOptions {
                out,
                method,
                seed,
                progress: !quiet && std::io::stderr().is_terminal(),
            };
            match probeplace::pipeline::place(&config, &options) {
                Ok(outcome) => {
                    for w in &outcome.report.warnings {
                        eprintln!("warning: {w}");
                    }
                    if !quiet {
                        let r = &outcome.report;
                        println!(
                            "{}: {} probes, coverage {:.2}% ± {:.2}%, {} in solid; wrote {} in {:.1} s",
                            r.method,
                            r.probe_count,
                            100.0 * r.coverage,
                            100.0 * r.coverage_ci95,
                            r.probes_in_solid,
                            outcome.out_dir.display(),
                            r.timings_ms.get("total").copied().unwrap_or(0.0) / 1e3
                        );
                    }
                    ExitCode::SUCCESS
                }
                Err(e) => {
                    eprintln!("error: {e}");
                    ExitCode::from(e.exit_code() as u8)
                }
            }
        }
    }
}
