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
    /// Place probes as the config says; write probes.json, svo.bin, report.json and placement.png.
    Place {
        /// The run's RON config file.
        config: PathBuf,
        /// Output directory (default: the config's `output`).
        #[arg(long)]
        out: Option<PathBuf>,
        /// Placement method: `sdf-skeleton`, `medial-axis` or `grid:NxMxK` (default: the config's).
        #[arg(long)]
        method: Option<String>,
        /// Random seed (default: the config's).
        #[arg(long)]
        seed: Option<u64>,
        /// No progress bars and no summary.
        #[arg(long)]
        quiet: bool,
        /// Skip refinement, filling and pruning (the config's `refine.enabled: false`).
        #[arg(long)]
        no_refine: bool,
    },
    /// Place probes as `place` does, then bake their light-field maps and the path-traced reference image.
    Bake {
        /// The run's RON config file.
        config: PathBuf,
        /// Output directory (default: the config's `output`).
        #[arg(long)]
        out: Option<PathBuf>,
        /// Placement method: `sdf-skeleton`, `medial-axis` or `grid:NxMxK` (default: the config's).
        #[arg(long)]
        method: Option<String>,
        /// Random seed (default: the config's).
        #[arg(long)]
        seed: Option<u64>,
        /// No progress bars and no summary.
        #[arg(long)]
        quiet: bool,
        /// Skip refinement, filling and pruning (the config's `refine.enabled: false`).
        #[arg(long)]
        no_refine: bool,
    },
    /// Summarize an svo.bin (or the one in an output directory, with its lightfield.bin) after checking it.
    Inspect {
        /// An output directory of `place` or `bake`, or an svo.bin file.
        path: PathBuf,
        /// Check only: print nothing, answer with the exit status.
        #[arg(long)]
        quiet: bool,
    },
}

fn main() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) => return usage_error(e),
    };
    match cli.command {
        Command::Place {
            config,
            out,
            method,
            seed,
            quiet,
            no_refine,
        } => {
            let options = probeplace::pipeline::PlaceOptions {
                out,
                method,
                seed,
                progress: !quiet && std::io::stderr().is_terminal(),
                no_refine,
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
                Err(e) => fail(e),
            }
        }
        Command::Bake {
            config,
            out,
            method,
            seed,
            quiet,
            no_refine,
        } => {
            let options = probeplace::pipeline::PlaceOptions {
                out,
                method,
                seed,
                progress: !quiet && std::io::stderr().is_terminal(),
                no_refine,
            };
            match probeplace::pipeline::bake(&config, &options) {
                Ok(outcome) => {
                    for w in &outcome.report.warnings {
                        eprintln!("warning: {w}");
                    }
                    if !quiet {
                        let r = &outcome.report;
                        if let Some(b) = &r.bake {
                            println!(
                                "{}: {} probes baked at {}² ({:.1} MB), tracer agrees with ray casts on {:.2}% of seen hits; wrote {} in {:.1} s",
                                r.method,
                                b.probes,
                                b.resolution,
                                b.bytes as f64 / 1e6,
                                100.0 * b.tracer.rate(),
                                outcome.out_dir.display(),
                                r.timings_ms.get("total").copied().unwrap_or(0.0) / 1e3
                            );
                        }
                    }
                    ExitCode::SUCCESS
                }
                Err(e) => fail(e),
            }
        }
        Command::Inspect { path, quiet } => match probeplace::pipeline::inspect(&path) {
            Ok(inspection) => {
                if !quiet {
                    println!("{inspection}");
                }
                ExitCode::SUCCESS
            }
            Err(e) => fail(e),
        },
    }
}

/// Prints `e` in one line and returns its exit status.
fn fail(e: probeplace::Error) -> ExitCode {
    eprintln!("error: {e}");
    ExitCode::from(e.exit_code() as u8)
}

/// Help and version go out as clap renders them; a usage mistake becomes one
/// line (clap's message, folded) and exit status 2, like every user error.
fn usage_error(e: clap::Error) -> ExitCode {
    use clap::error::ErrorKind;
    if matches!(
        e.kind(),
        ErrorKind::DisplayHelp
            | ErrorKind::DisplayVersion
            | ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand
    ) {
        let _ = e.print();
        return ExitCode::SUCCESS;
    }
    let rendered = e.render().to_string();
    let message: Vec<&str> = rendered
        .lines()
        .take_while(|l| !l.trim().is_empty())
        .map(str::trim)
        .collect();
    eprintln!("{} (see probeplace --help)", message.join(" "));
    ExitCode::from(2)
}
