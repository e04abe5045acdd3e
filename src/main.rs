//! The `probeplace` command line: parses arguments and calls the library.

use clap::{Args, CommandFactory, Parser, Subcommand, ValueEnum};
use probeplace::jobs::{self, Outcome, RunOptions, Variant};
use probeplace::progress::Progress;
use probeplace::provenance::Overrides;
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
    command: Option<Command>,
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

/// `compare --only`.
#[derive(Clone, Copy, ValueEnum)]
enum OnlyArg {
    /// Diffuse light as engines blend probes (SH L2 over tetrahedra), on the scene's own materials.
    Diffuse,
    /// Glossy light through the light-field tracer, on `compare.materials`.
    Glossy,
}

/// `export --format`: the words of the library's list of formats.
fn format_values() -> clap::builder::PossibleValuesParser {
    let values: Vec<clap::builder::PossibleValue> = jobs::export::formats()
        .into_iter()
        .map(|(word, file, about)| {
            clap::builder::PossibleValue::new(word)
                .help(format!("{file}: {}", about.replace('`', "")))
        })
        .collect();
    values.into()
}

/// What every job shares: the config, the earlier run, the overrides.
#[derive(Args)]
struct RunArgs {
    /// The run's RON config file (optional with --from: the earlier run's).
    config: Option<PathBuf>,
    /// Output directory (default: the --from directory, else the config's `output`).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Placement method: `sdf-skeleton`, `medial-axis`, `grid:NxMxK`, `relocated:NxMxK`,
    /// `greedy:SPACING` or `adaptive:MIN_SPACING` (default: the config's).
    #[arg(long)]
    method: Option<String>,
    /// Score the probes of FILE.json (a probes.json, or an array of [x, y, z]) instead of placing.
    #[arg(long, value_name = "FILE.json", conflicts_with = "method")]
    probes: Option<PathBuf>,
    /// Random seed (default: the config's).
    #[arg(long)]
    seed: Option<u64>,
    /// No progress, no stage lines and no summary.
    #[arg(short, long)]
    quiet: bool,
    /// Skip refinement, filling and pruning (the config's `refine.enabled: false`).
    #[arg(long)]
    no_refine: bool,
}

/// `--from`, for the jobs that can reuse an earlier run.
#[derive(Args)]
struct FromArg {
    /// Reuse what an earlier run wrote in DIR (probes, SVO, light field, reference) instead of recomputing it.
    #[arg(long, value_name = "DIR")]
    from: Option<PathBuf>,
}

#[derive(Subcommand)]
enum Command {
    /// Place probes as the config says; write probes.json, svo.bin, report.json and placement.png.
    Place(RunArgs),
    /// Place probes (or reuse --from), then bake their light-field maps and the path-traced reference image.
    Bake {
        #[command(flatten)]
        run: RunArgs,
        #[command(flatten)]
        from: FromArg,
    },
    /// Place and bake (or reuse --from), then render the reference's view through the probes (bi-level and Hi-Z) and measure it against the reference.
    Render {
        #[command(flatten)]
        run: RunArgs,
        #[command(flatten)]
        from: FromArg,
        /// Which tracer to render with.
        #[arg(long, value_enum, default_value = "both")]
        variant: Variants,
        /// Trace on the CPU twin even where a GPU adapter exists.
        #[arg(long)]
        cpu: bool,
    },
    /// Compare our placements with a sweep of uniform grids, a relocated grid (RTXGI) and greedy voxel placement (Silvennoinen & Lehtinen 2017) at equal count, quality and performance; write compare.json, compare.csv and report.html.
    Compare {
        #[command(flatten)]
        run: RunArgs,
        #[command(flatten)]
        from: FromArg,
        /// Grids to compare with, e.g. `2x2x2,4x2x4` (default: the config's `compare.grids`, else a sweep around our probe count).
        #[arg(long)]
        grids: Option<String>,
        /// Trace on the CPU twin even where a GPU adapter exists.
        #[arg(long)]
        cpu: bool,
        /// Run one benchmark only: `diffuse` (engines' SH blend, the scene's own materials) or `glossy` (our light-field tracer, `compare.materials`).
        #[arg(long, value_enum)]
        only: Option<OnlyArg>,
    },
    /// Write an earlier run's probes for other tools: glTF (.glb), Godot (.tscn), Unity, DDGI (docs/engines.md).
    Export {
        /// An output directory of place, bake or render.
        dir: PathBuf,
        /// Formats to write, comma-separated.
        #[arg(long, value_parser = format_values(), value_delimiter = ',', required = true)]
        format: Vec<String>,
        /// Put the scene's triangles, with their base colours, into probes.glb.
        #[arg(long)]
        scene: bool,
        /// Output directory (default: DIR); it gets DIR's files and the exports.
        #[arg(long)]
        out: Option<PathBuf>,
        /// No stage lines and no summary.
        #[arg(short, long)]
        quiet: bool,
    },
    /// Cut the world into tiles with overlapping margins: one tile job each (OBJ and config), split.json, and submit.sh for a Slurm array (docs/tiles.md).
    Split {
        /// The world's RON config file.
        config: PathBuf,
        /// Tiles along x, y and z, e.g. 2x1x2.
        #[arg(long, value_name = "NxMxK")]
        tiles: String,
        /// The directory to write the tiles to.
        #[arg(long)]
        out: PathBuf,
        /// How far each tile reaches beyond its own cell, in world units (default: a quarter of the longest tile edge, at least 8 voxels).
        #[arg(long, allow_negative_numbers = true)]
        margin: Option<f64>,
        /// CPUs each tile job asks the scheduler for.
        #[arg(long, default_value_t = 2)]
        cpus: u32,
        /// No summary.
        #[arg(short, long)]
        quiet: bool,
    },
    /// Join the placed tiles of a split: world.json, probes.json, report.json and one svo.bin per tile, in DIR/world (docs/tiles.md).
    Merge {
        /// The directory `split` wrote.
        dir: PathBuf,
        /// Output directory (default: DIR/world).
        #[arg(long)]
        out: Option<PathBuf>,
        /// Also bake one svo.bin over the whole world (loads the whole world).
        #[arg(long)]
        single: bool,
        /// No stage lines and no summary.
        #[arg(short, long)]
        quiet: bool,
    },
    /// Summarize an svo.bin (or the one in an output directory, with its lightfield.bin) after checking that the directory holds one run.
    Inspect {
        /// An output directory of `place` or `bake`, or an svo.bin file.
        path: PathBuf,
        /// Check only: print nothing, answer with the exit status.
        #[arg(short, long)]
        quiet: bool,
    },
}

fn main() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) => return usage_error(e),
    };
    let Some(command) = cli.command else {
        // A bare `probeplace` is a usage mistake: help on stderr, status 2.
        let _ = Cli::command().write_help(&mut std::io::stderr());
        return ExitCode::from(2);
    };
    match command {
        Command::Place(run) => job(run, None, |o| jobs::place(&o)),
        Command::Bake { run, from } => job(run, from.from, |o| jobs::bake(&o)),
        Command::Render {
            run,
            from,
            variant,
            cpu,
        } => job(run, from.from, |mut o| {
            o.cpu = cpu;
            o.variants = match variant {
                Variants::Hiz => vec![Variant::HiZ],
                Variants::Bilevel => vec![Variant::BiLevel],
                Variants::Both => vec![Variant::BiLevel, Variant::HiZ],
            };
            jobs::render(&o)
        }),
        Command::Compare {
            run,
            from,
            grids,
            cpu,
            only,
        } => {
            let grids = match grids.as_deref().map(jobs::compare::parse_grids) {
                Some(Err(e)) => return fail(e),
                other => other.map(|g| g.expect("checked")),
            };
            job(run, from.from, |mut o| {
                o.cpu = cpu;
                o.grids = grids.clone();
                o.benchmarks = match only {
                    None => jobs::Benchmarks::Both,
                    Some(OnlyArg::Diffuse) => jobs::Benchmarks::Diffuse,
                    Some(OnlyArg::Glossy) => jobs::Benchmarks::Glossy,
                };
                jobs::compare(&o)
            })
        }
        Command::Export {
            dir,
            format,
            scene,
            out,
            quiet,
        } => {
            let options = jobs::ExportOptions {
                dir,
                formats: format,
                scene,
                out,
                progress: Progress::new(false)
                    .with_lines(!quiet && !std::io::stderr().is_terminal()),
            };
            report(jobs::export(&options), quiet)
        }
        Command::Split {
            config,
            tiles,
            out,
            margin,
            cpus,
            quiet,
        } => {
            let tiles = match probeplace::tiles::parse_counts(&tiles) {
                Ok(t) => t,
                Err(e) => return fail(probeplace::Error::User(e)),
            };
            if cpus == 0 {
                return fail(probeplace::Error::User("--cpus: must be at least 1".into()));
            }
            let options = jobs::SplitOptions {
                config,
                tiles,
                out,
                margin,
                cpus,
            };
            report(jobs::split(&options), quiet)
        }
        Command::Merge {
            dir,
            out,
            single,
            quiet,
        } => {
            let options = jobs::MergeOptions {
                dir,
                out,
                single,
                progress: Progress::new(false)
                    .with_lines(!quiet && !std::io::stderr().is_terminal()),
            };
            report(jobs::merge(&options), quiet)
        }
        Command::Inspect { path, quiet } => match jobs::inspect(&path) {
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

/// Runs `run` with the command line's options; prints the warnings and,
/// unless quiet, the summary with where it wrote and how long it took.
fn job(
    args: RunArgs,
    from: Option<PathBuf>,
    run: impl FnOnce(RunOptions) -> probeplace::Result<Outcome>,
) -> ExitCode {
    let terminal = std::io::stderr().is_terminal();
    let options = RunOptions {
        config: args.config,
        from,
        out: args.out,
        overrides: Overrides {
            method: args.method,
            seed: args.seed,
            no_refine: args.no_refine,
            probes: args.probes,
        },
        progress: Progress::new(!args.quiet && terminal).with_lines(!args.quiet && !terminal),
        ..RunOptions::default()
    };
    report(run(options), args.quiet)
}

/// Prints a job's warnings and, unless quiet, its summary with where it
/// wrote and how long it took; returns the exit status.
fn report(result: probeplace::Result<Outcome>, quiet: bool) -> ExitCode {
    match result {
        Ok(outcome) => {
            for w in outcome.warnings() {
                eprintln!("warning: {w}");
            }
            if !quiet {
                for line in &outcome.summary {
                    println!("{line}");
                }
                println!(
                    "wrote {} in {:.1} s",
                    outcome.out_dir.display(),
                    outcome.seconds()
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

/// Help and version go out as clap renders them; a usage mistake becomes
/// clap's message folded into one line, clap's `tip:` lines kept after it,
/// and exit status 2, like every user error.
fn usage_error(e: clap::Error) -> ExitCode {
    use clap::error::ErrorKind;
    if matches!(e.kind(), ErrorKind::DisplayHelp | ErrorKind::DisplayVersion) {
        let _ = e.print();
        return ExitCode::SUCCESS;
    }
    if e.kind() == ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand {
        let _ = e.print();
        return ExitCode::from(2);
    }
    let rendered = e.render().to_string();
    let mut message = Vec::new();
    let mut tips = Vec::new();
    for line in rendered.lines().map(str::trim).filter(|l| !l.is_empty()) {
        if line.starts_with("tip:") {
            tips.push(line);
        } else if line.starts_with("Usage:") || line.starts_with("For more information") {
            continue;
        } else {
            message.push(line);
        }
    }
    eprintln!("{} (see probeplace --help)", message.join(" "));
    for tip in tips {
        eprintln!("  {tip}");
    }
    ExitCode::from(2)
}
