//! The `probeplace` command line: parses arguments and calls the library.

use clap::{Args, Parser, Subcommand, ValueEnum};
use probeplace::pipeline::{PlaceOptions, PlaceOutcome, RenderOptions, Variant};
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

/// `render --variant`.
#[derive(Clone, Copy, ValueEnum)]
enum Variants {
    /// Wang et al. 2019: Hi-Z march, SVO selection.
    Hiz,
    /// McGuire et al. 2017: bi-level march, grid selection.
    Bilevel,
    /// Both, for comparison.
    Both,
}

/// What `place`, `bake` and `render` share: the config and the overrides of its fields.
#[derive(Args)]
struct RunArgs {
    /// The run's RON config file.
    config: PathBuf,
    /// Output directory (default: the config's `output`).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Placement method: `sdf-skeleton`, `medial-axis`, `grid:NxMxK`, `relocated:NxMxK` or
    /// `greedy:SPACING` (default: the config's).
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
}

#[derive(Subcommand)]
enum Command {
    /// Place probes as the config says; write probes.json, svo.bin, report.json and placement.png.
    Place(RunArgs),
    /// Place probes as `place` does, then bake their light-field maps and the path-traced reference image.
    Bake(RunArgs),
    /// Place and bake as `bake` does, then render the reference's view through the probes on the GPU (bi-level and Hi-Z) and measure it against the reference.
    Render {
        #[command(flatten)]
        run: RunArgs,
        /// Which tracer to render with.
        #[arg(long, value_enum, default_value = "both")]
        variant: Variants,
        /// Trace on the CPU twin even where a GPU adapter exists.
        #[arg(long)]
        cpu: bool,
    },
    /// Compare our placements (sdf-skeleton and medial-axis, refined) with a sweep of uniform grids, a relocated grid (RTXGI) and greedy voxel placement (Silvennoinen & Lehtinen 2017) at equal count, quality and performance; write compare.json, compare.csv and report.html.
    Compare {
        /// The run's RON config file (it needs `reference.camera`).
        config: PathBuf,
        /// Output directory (default: the config's `output`).
        #[arg(long)]
        out: Option<PathBuf>,
        /// Grids to compare with, e.g. `2x2x2,4x2x4` (default: the config's `compare.grids`, else a sweep around our probe count).
        #[arg(long)]
        grids: Option<String>,
        /// Random seed (default: the config's).
        #[arg(long)]
        seed: Option<u64>,
        /// Trace on the CPU twin even where a GPU adapter exists.
        #[arg(long)]
        cpu: bool,
        /// No progress bars and no summary.
        #[arg(long)]
        quiet: bool,
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
        Command::Place(args) => run(args, probeplace::pipeline::place, |r| {
            format!(
                "{}: {} probes, coverage {:.2}% ± {:.2}%, {} in solid, {} near surfaces; voxel {:.4} ({})",
                r.method,
                r.probe_count,
                100.0 * r.coverage,
                100.0 * r.coverage_ci95,
                r.probes_in_solid,
                r.probes_below_clearance,
                r.sdf.voxel_size,
                r.resolution.map_or("config", |x| x.source)
            )
        }),
        Command::Bake(args) => run(args, probeplace::pipeline::bake, |r| {
            match &r.bake {
            Some(b) => format!(
                "{}: {} probes baked at {}² ({:.1} MB), tracer agrees with ray casts on {:.2}% of seen hits",
                r.method,
                b.probes,
                b.resolution,
                b.bytes as f64 / 1e6,
                100.0 * b.tracer.rate()
            ),
            None => format!("{}: {} probes", r.method, r.probe_count),
        }
        }),
        Command::Render {
            run: args,
            variant,
            cpu,
        } => {
            let render = RenderOptions {
                variants: match variant {
                    Variants::Hiz => vec![Variant::HiZ],
                    Variants::Bilevel => vec![Variant::BiLevel],
                    Variants::Both => vec![Variant::BiLevel, Variant::HiZ],
                },
                cpu,
            };
            run(
                args,
                |path, options| probeplace::pipeline::render(path, options, &render),
                |r| match &r.render {
                    Some(x) => {
                        let parts: Vec<String> = x
                            .variants
                            .iter()
                            .map(|(name, v)| {
                                format!(
                                    "{name} mse_glossy {:.3e}, {:.1} texel fetches/ray{}",
                                    v.mse_glossy,
                                    v.texel_fetches_per_ray,
                                    v.gpu_ms.map_or(String::new(), |ms| format!(", {ms:.1} ms"))
                                )
                            })
                            .collect();
                        format!(
                            "{}: {}×{} on {}: {}",
                            r.method,
                            x.width,
                            x.height,
                            x.adapter,
                            parts.join("; ")
                        )
                    }
                    None => format!("{}: {} probes", r.method, r.probe_count),
                },
            )
        }
        Command::Compare {
            config,
            out,
            grids,
            seed,
            cpu,
            quiet,
        } => {
            let grids = match grids.as_deref().map(probeplace::compare::parse_grids) {
                Some(Err(e)) => return fail(e),
                Some(Ok(g)) => Some(g),
                None => None,
            };
            let options = probeplace::compare::CompareOptions {
                out,
                seed,
                grids,
                cpu,
                progress: !quiet && std::io::stderr().is_terminal(),
            };
            match probeplace::compare::compare(&config, &options) {
                Ok(outcome) => {
                    for w in &outcome.report.warnings {
                        eprintln!("warning: {w}");
                    }
                    if !quiet {
                        for line in probeplace::report::compare::summary(&outcome.report) {
                            println!("{line}");
                        }
                        println!(
                            "wrote {} in {:.1} s",
                            outcome.out_dir.join("report.html").display(),
                            outcome
                                .report
                                .timings_ms
                                .get("total")
                                .copied()
                                .unwrap_or(0.0)
                                / 1e3
                        );
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

/// Runs a job (`place` or `bake`) with the command line's overrides, prints
/// its warnings and, unless quiet, `summary` of its report with where it
/// wrote and how long it took.
fn run(
    args: RunArgs,
    job: impl Fn(&std::path::Path, &PlaceOptions) -> probeplace::Result<PlaceOutcome>,
    summary: impl Fn(&probeplace::report::Report) -> String,
) -> ExitCode {
    let options = PlaceOptions {
        out: args.out,
        method: args.method,
        seed: args.seed,
        progress: !args.quiet && std::io::stderr().is_terminal(),
        no_refine: args.no_refine,
    };
    match job(&args.config, &options) {
        Ok(outcome) => {
            for w in &outcome.report.warnings {
                eprintln!("warning: {w}");
            }
            if !args.quiet {
                let r = &outcome.report;
                println!(
                    "{}; wrote {} in {:.1} s",
                    summary(r),
                    outcome.out_dir.display(),
                    r.timings_ms.get("total").copied().unwrap_or(0.0) / 1e3
                );
            }
            ExitCode::SUCCESS
        }
        Err(e) => fail(e),
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
