//! docs/results.md, generated from the JSON the runs wrote:
//!
//! ```sh
//! cargo run --release --example results -- out/results out/compare out/generality --lit out/lit
//! ```
//!
//! reads every `report.json` (`probeplace place`, `bake`, `render`) and
//! `compare.json` (`probeplace compare`) under the given directories, and
//! `generality.json` (`cargo run --release --example generality -- DIR`;
//! a directory holding one is not searched further, so its per-run
//! `report.json` files stay out of the placement tables), and writes
//! `docs/results.md` with the plots of each comparison beside it
//! (`docs/compare-<config>-mse.svg`, `docs/compare-<config>-coverage.svg`).
//!
//! Options: `--output FILE` writes the Markdown there instead (the plots go
//! beside it); `--check` writes nothing and exits with status 1 when the
//! files on disk differ from what the JSON gives; `--lit DIR` reads the
//! `compare.json` files under DIR as the lit generated scenes at seeds
//! outside the suite (`gen_scenes --lit --seeds`), summarised in a section
//! of their own rather than one section per scene.
//!
//! The output depends on the JSON alone: rows are sorted, floats have fixed
//! formats, and nothing that varies between runs (timings, `gpu_ms`, input
//! paths) is shown, so the same JSON gives byte-identical files. The JSON is
//! read as `serde_json::Value` by the field names of docs/formats.md, not
//! through the library's structs.

use serde_json::Value;
use std::cmp::Ordering;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

type Error = Box<dyn std::error::Error>;

/// The commands that regenerate the inputs and this file; printed at the top
/// of docs/results.md.
const REGENERATE: &str = "\
cargo build --release
for c in configs/*.ron; do
    n=$(basename \"$c\" .ron)
    ./target/release/probeplace place \"$c\" --out \"out/results/$n\" --quiet
done
for n in cornell-glossy two-rooms pillared-hall holodeck sponza; do
    ./target/release/probeplace compare \"configs/$n.ron\" --cpu --out \"out/compare/$n\" --quiet
done
cargo run --release --example generality -- out/generality
cargo run --release --example gen_scenes -- out/lit --lit --seeds 71
for c in out/lit/*-71.ron; do
    ./target/release/probeplace compare \"$c\" --only diffuse --out \"out/lit/$(basename \"$c\" .ron)\" --quiet
done
cargo run --release --example results -- out/results out/compare out/generality --lit out/lit
";

const DASH: &str = "–";

fn main() {
    if let Err(e) = run() {
        eprintln!("error: {e}");
        std::process::exit(2);
    }
}

fn run() -> Result<(), Error> {
    let mut output: Option<PathBuf> = None;
    let mut check = false;
    let mut dirs: Vec<PathBuf> = Vec::new();
    let mut lit: Vec<PathBuf> = Vec::new();
    let mut args = std::env::args_os().skip(1);
    while let Some(a) = args.next() {
        match a.to_str() {
            Some("--output") => output = Some(args.next().ok_or("--output needs a file")?.into()),
            Some("--check") => check = true,
            Some("--lit") => lit.push(args.next().ok_or("--lit needs a directory")?.into()),
            Some("-h" | "--help") => {
                println!("usage: cargo run --release --example results -- [--output FILE] [--check] [--lit DIR] DIR...");
                return Ok(());
            }
            _ => dirs.push(a.into()),
        }
    }
    if dirs.is_empty() {
        return Err(
            "usage: cargo run --release --example results -- [--output FILE] [--check] [--lit DIR] DIR..."
                .into(),
        );
    }
    let output =
        output.unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/results.md"));

    let mut inputs = Inputs::default();
    for dir in &dirs {
        inputs.collect_root(dir)?;
    }
    for dir in &lit {
        let mut held_out = Inputs::default();
        held_out.collect_root(dir)?;
        if held_out.compares.is_empty() {
            return Err(format!("--lit {}: no compare.json under it", dir.display()).into());
        }
        inputs.lit.append(&mut held_out.compares);
    }
    if inputs.reports.is_empty() && inputs.compares.is_empty() && inputs.generality.is_empty() {
        return Err(
            "no report.json, compare.json or generality.json under the given directories".into(),
        );
    }

    let files = render(&mut inputs);
    let out_dir = output.parent().unwrap_or(Path::new("."));
    let default_output = output == Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/results.md");
    let mut all: Vec<(PathBuf, String)> = vec![(output.clone(), files.markdown)];
    // The README's generality sentence, between its markers.
    if default_output {
        let readme = Path::new(env!("CARGO_MANIFEST_DIR")).join("README.md");
        let mut text = std::fs::read_to_string(&readme)?;
        for (markers, block) in README_BLOCKS.iter().zip([&files.generality]) {
            if block.is_empty() {
                continue;
            }
            text = splice(&text, *markers, block).ok_or_else(|| {
                format!(
                    "{}: no `{}` … `{}` block to fill",
                    readme.display(),
                    markers.0,
                    markers.1
                )
            })?;
        }
        all.push((readme, text));
    }
    for (name, svg) in files.plots {
        all.push((out_dir.join(name), svg));
    }
    if check {
        let mut stale = 0;
        for (path, text) in &all {
            if std::fs::read_to_string(path).ok().as_deref() != Some(text.as_str()) {
                eprintln!("{}: differs from what the JSON gives", path.display());
                stale += 1;
            }
        }
        if stale > 0 {
            std::process::exit(1);
        }
        eprintln!("{} file(s) up to date", all.len());
    } else {
        for (path, text) in &all {
            std::fs::write(path, text)?;
            eprintln!("wrote {}", path.display());
        }
    }
    Ok(())
}

// ---------------------------------------------------------------- inputs

#[derive(Default)]
struct Inputs {
    reports: Vec<Value>,
    compares: Vec<Value>,
    generality: Vec<Value>,
    /// `compare.json` of the lit generated scenes at held-out seeds.
    lit: Vec<Value>,
}

impl Inputs {
    /// [`Inputs::collect`] of a directory given on the command line, which
    /// must be one.
    fn collect_root(&mut self, dir: &Path) -> Result<(), Error> {
        if !dir.is_dir() {
            return Err(format!("{}: not a directory", dir.display()).into());
        }
        self.collect(dir)
    }

    fn collect(&mut self, dir: &Path) -> Result<(), Error> {
        let generality = dir.join("generality.json");
        if generality.is_file() {
            match read_json(&generality)? {
                Value::Array(rows) => self.generality.extend(rows),
                _ => return Err(format!("{}: not an array of rows", generality.display()).into()),
            }
            return Ok(());
        }
        let report = dir.join("report.json");
        if report.is_file() {
            let v = read_json(&report)?;
            expect_format(&report, &v, "probeplace.report")?;
            self.reports.push(v);
        }
        let compare = dir.join("compare.json");
        if compare.is_file() {
            let v = read_json(&compare)?;
            expect_format(&compare, &v, "probeplace.compare")?;
            self.compares.push(v);
        }
        let mut subdirs: Vec<PathBuf> = std::fs::read_dir(dir)?
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.is_dir())
            .collect();
        subdirs.sort();
        for d in subdirs {
            self.collect(&d)?;
        }
        Ok(())
    }
}

fn read_json(path: &Path) -> Result<Value, Error> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
    serde_json::from_str(&text).map_err(|e| format!("{}: {e}", path.display()).into())
}

fn expect_format(path: &Path, v: &Value, format: &str) -> Result<(), Error> {
    match v.get("format").and_then(Value::as_str) {
        Some(f) if f == format => Ok(()),
        other => Err(format!("{}: format {other:?}, expected {format:?}", path.display()).into()),
    }
}

// ---------------------------------------------------------------- values

/// The value at a dotted path (`svo.bytes`).
fn at<'a>(v: &'a Value, path: &str) -> Option<&'a Value> {
    path.split('.')
        .try_fold(v, |v, k| v.get(k))
        .filter(|v| !v.is_null())
}

/// The array at `path`, empty where there is none.
fn array<'a>(v: &'a Value, path: &str) -> &'a [Value] {
    at(v, path)
        .and_then(Value::as_array)
        .map(Vec::as_slice)
        .unwrap_or_default()
}

/// The comparison of our default method in compare report `c`.
fn ours_comparison(c: &Value) -> Option<&Value> {
    array(c, "comparisons")
        .iter()
        .find(|x| text(x, "placement") == OURS_DEFAULT)
}

fn num(v: &Value, path: &str) -> Option<f64> {
    at(v, path).and_then(Value::as_f64)
}

fn text(v: &Value, path: &str) -> String {
    match at(v, path) {
        Some(Value::String(s)) => s.clone(),
        Some(other) => other.to_string(),
        None => DASH.to_string(),
    }
}

/// A config's name: the stem of `config` (`configs/cornell.ron` → `cornell`).
fn config_name(v: &Value) -> String {
    let c = text(v, "config");
    Path::new(&c)
        .file_stem()
        .map_or(c.clone(), |s| s.to_string_lossy().into_owned())
}

// ---------------------------------------------------------------- formats

fn int(x: Option<f64>) -> String {
    x.map_or(DASH.into(), |x| format!("{}", x.round() as i64))
}

fn fixed(x: Option<f64>, digits: usize) -> String {
    x.map_or(DASH.into(), |x| format!("{x:.digits$}"))
}

fn pct(x: Option<f64>, digits: usize) -> String {
    x.map_or(DASH.into(), |x| format!("{:.digits$}%", 100.0 * x))
}

/// `5.367e-06`: four significant digits, a signed two-digit exponent.
fn sci(x: Option<f64>) -> String {
    let Some(x) = x else { return DASH.into() };
    if x == 0.0 {
        return "0".into();
    }
    let s = format!("{x:.3e}");
    let (m, e) = s.split_once('e').unwrap_or((&s, "0"));
    let e: i32 = e.parse().unwrap_or(0);
    format!("{m}e{}{:02}", if e < 0 { '-' } else { '+' }, e.abs())
}

fn ratio(x: Option<f64>) -> String {
    x.map_or(DASH.into(), |x| format!("{x:.2}×"))
}

fn mib(x: Option<f64>) -> String {
    x.map_or(DASH.into(), |x| format!("{:.1} MiB", x / (1024.0 * 1024.0)))
}

fn kib(x: Option<f64>) -> String {
    x.map_or(DASH.into(), |x| format!("{:.1} KiB", x / 1024.0))
}

/// Orders names with their numbers by value: `units-5` before `units-10`.
fn natural(a: &str, b: &str) -> Ordering {
    fn chunks(s: &str) -> Vec<(bool, String)> {
        let mut out: Vec<(bool, String)> = Vec::new();
        for c in s.chars() {
            let d = c.is_ascii_digit();
            match out.last_mut() {
                Some((ld, t)) if *ld == d => t.push(c),
                _ => out.push((d, c.to_string())),
            }
        }
        out
    }
    let (ca, cb) = (chunks(a), chunks(b));
    for (x, y) in ca.iter().zip(&cb) {
        let o = match (x.0, y.0) {
            (true, true) => {
                let (tx, ty) = (x.1.trim_start_matches('0'), y.1.trim_start_matches('0'));
                tx.len().cmp(&ty.len()).then_with(|| tx.cmp(ty))
            }
            _ => x.1.cmp(&y.1),
        };
        if o != Ordering::Equal {
            return o;
        }
    }
    ca.len().cmp(&cb.len()).then_with(|| a.cmp(b))
}

// ---------------------------------------------------------------- tables

struct Table {
    header: Vec<&'static str>,
    /// `true` for right-aligned (numeric) columns.
    right: Vec<bool>,
    rows: Vec<Vec<String>>,
}

impl Table {
    fn new(columns: &[(&'static str, bool)]) -> Table {
        Table {
            header: columns.iter().map(|c| c.0).collect(),
            right: columns.iter().map(|c| c.1).collect(),
            rows: Vec::new(),
        }
    }

    /// Bolds, among `rows`, the cells of column `col` showing the best of
    /// `values` (lowest or highest); every row whose cell reads the same as
    /// the best one's is bolded, so ties at the shown precision all are.
    /// Nothing is marked among fewer than two values.
    fn mark_best(&mut self, rows: &[usize], col: usize, values: &[Option<f64>], lower: bool) {
        let known: Vec<(usize, f64)> = rows
            .iter()
            .zip(values)
            .filter_map(|(&r, v)| v.filter(|v| v.is_finite()).map(|v| (r, v)))
            .collect();
        if known.len() < 2 {
            return;
        }
        let best = known
            .iter()
            .copied()
            .reduce(|a, b| {
                let better = if lower { b.1 < a.1 } else { b.1 > a.1 };
                if better {
                    b
                } else {
                    a
                }
            })
            .map(|(r, _)| self.rows[r][col].clone())
            .unwrap_or_default();
        for &(r, _) in &known {
            if self.rows[r][col] == best {
                self.rows[r][col] = format!("**{best}**");
            }
        }
    }

    fn markdown(&self) -> String {
        let mut s = format!("| {} |\n|", self.header.join(" | "));
        for &r in &self.right {
            s.push_str(if r { "---:|" } else { "---|" });
        }
        s.push('\n');
        for row in &self.rows {
            let _ = writeln!(s, "| {} |", row.join(" | "));
        }
        s
    }
}

// ---------------------------------------------------------------- the file

struct Files {
    markdown: String,
    plots: Vec<(String, String)>,
    /// README.md's sentence on the generality table, its generated block.
    generality: String,
}

/// The markers of README.md's generated block: the sentence on the
/// generality table (the comparisons live in docs/results.md alone).
const README_BLOCKS: [(&str, &str); 1] = [(
    "<!-- results:generality begin (examples/results.rs writes this block) -->",
    "<!-- results:generality end -->",
)];

/// `text` with the block between the markers `(begin, end)` replaced by
/// `block`; `None` without both markers.
fn splice(text: &str, (begin, end): (&str, &str), block: &str) -> Option<String> {
    let start = text.find(begin)? + begin.len();
    let stop = start + text[start..].find(end)?;
    Some(format!("{}\n{block}{}", &text[..start], &text[stop..]))
}

/// Our default method.
const OURS_DEFAULT: &str = "sdf-skeleton";

/// `shading_probe_distance` of the placement `name` of compare `c`.
fn distance_of(c: &Value, name: &str) -> Option<f64> {
    at(c, "placements")?
        .as_array()?
        .iter()
        .find(|p| text(p, "name") == name)
        .and_then(|p| num(p, "shading_probe_distance"))
}

/// The comparison of ours (`natural`, or one of `at_counts`) whose probe
/// count is nearest the rival of ratio `r` (ties to `natural`), with its
/// ratio against that rival on the same tracer; `natural` and `r` when no
/// run at another count holds that rival.
fn nearest_count<'a>(
    natural: &'a Value,
    at_counts: &[&'a Value],
    r: &'a Value,
) -> (&'a Value, &'a Value) {
    let probes = |v: &Value| num(v, "probes").unwrap_or(f64::NAN);
    let gap = |v: &Value| (probes(v) - probes(r)).abs();
    at_counts
        .iter()
        .filter(|y| gap(y) < gap(natural))
        .filter_map(|y| {
            let same = at(y, "ratios")?.as_array()?.iter().find(|s| {
                text(s, "against") == text(r, "against") && text(s, "tracer") == text(r, "tracer")
            })?;
            Some((*y, same))
        })
        .min_by(|a, b| gap(a.0).total_cmp(&gap(b.0)))
        .unwrap_or((natural, r))
}

/// One table of every comparison: our default method against each rival
/// at about its count, with intervals and tracers, and what they add up to.
fn compare_summary(compares: &[Value]) -> String {
    let columns: Vec<(&'static str, bool)> = [
        ("config", false),
        ("materials", false),
        ("views", true),
        ("ours", true),
    ]
    .into_iter()
    .chain(RATIO_COLUMNS)
    .chain([("shading → probe, ours / rival", false)])
    .collect();
    let mut t = Table::new(&columns);
    let (mut scenes, mut grid_wins, mut strong) = (0, 0, 0);
    let mut readings: Vec<String> = Vec::new();
    for c in compares {
        let comparisons = array(c, "comparisons");
        let Some(x) = ours_comparison(c) else {
            continue;
        };
        // Ours placed again at a rival's count (`METHOD@COUNT`): each rival
        // is set against the run of ours whose count is nearest its own.
        let at_counts: Vec<&Value> = comparisons
            .iter()
            .filter(|y| {
                text(y, "placement")
                    .strip_prefix(OURS_DEFAULT)
                    .is_some_and(|rest| rest.starts_with('@'))
            })
            .collect();
        scenes += 1;
        let ratios: Vec<(&Value, &Value)> = at(x, "ratios")
            .and_then(Value::as_array)
            .map(|a| {
                a.iter()
                    .filter(|r| text(r, "family") != "ours")
                    .map(|r| nearest_count(x, &at_counts, r))
                    .collect()
            })
            .unwrap_or_default();
        let same_grid = ratios
            .iter()
            .find(|(_, r)| text(r, "family") == "grid" && text(r, "tracer") == "hiz+svo");
        if same_grid.is_some_and(|(_, r)| r["win"] == true) {
            grid_wins += 1;
        }
        let words = competitor_words();
        let competitors: Vec<&Value> = ratios
            .iter()
            .map(|&(_, r)| r)
            .filter(|r| words.contains(&text(r, "family").as_str()))
            .collect();
        if !competitors.is_empty()
            && competitors
                .iter()
                .all(|r| num(r, "mse_glossy_filtered.value").is_some_and(|v| v >= 1.25))
        {
            strong += 1;
        }
        let views = at(c, "cameras")
            .and_then(Value::as_array)
            .map_or(0, Vec::len);
        readings.push(scene_reading(c, x, &ratios));
        for (x, r) in ratios {
            t.rows.push(
                vec![
                    format!("`{}`", config_name(c)),
                    at(c, "materials")
                        .and_then(Value::as_str)
                        .unwrap_or("scene")
                        .to_string(),
                    views.to_string(),
                    int(num(x, "probes")),
                ]
                .into_iter()
                .chain(ratio_cells(r))
                .chain([format!(
                    "{} / {}",
                    fixed(distance_of(c, &text(x, "placement")), 2),
                    fixed(distance_of(c, &text(r, "against")), 2)
                )])
                .collect(),
            );
        }
    }
    if scenes == 0 {
        return String::new();
    }
    let mut md = String::new();
    let _ = writeln!(
        md,
        "Our `{OURS_DEFAULT}` against each rival at its probe count, per comparison (where the \
         grid nearest our count has another, ours is placed again with exactly that many \
         probes, `min_probes` = `max_probes`, and the `ours` column shows it): the \
         rival's pooled error over ours (above 1: ours is better) with its 95% interval (a \
         two-stage paired bootstrap over views and 16-pixel blocks; bold where it excludes 1), \
         and the rival's tracer (ours is always `hiz+svo`; a grid on `hiz+svo` isolates \
         placement, on `bilevel+grid` it is what engines trace today). The last column is \
         the mean distance from the views' shading points to the nearest probe that sees \
         them, for ours and for the rival (world units; lower means less parallax in \
         glossy lookups). Generated by \
         `examples/results.rs` from the `compare.json` files ([docs/results.md](docs/results.md) \
         has every figure).\n"
    );
    md.push_str(&t.markdown());
    let _ = writeln!(
        md,
        "\nAt equal count on the same tracer, ours has lower filtered MSE and ꟻLIP than the \
         uniform grid, both intervals above 1, in **{grid_wins} of {scenes}** comparisons; the \
         point estimate of its filtered MSE is at most 0.8× that of every competitor \
         (relocated, greedy, adaptive) in **{strong} of {scenes}**, intervals aside.\n"
    );
    let _ = writeln!(
        md,
        "Per scene, each rival's verdict read from its two intervals (better or worse: \
         the interval lies wholly above or below 1; a metric named alone is the only one \
         whose interval does):\n"
    );
    for r in &readings {
        let _ = writeln!(md, "- {r}");
    }
    md.push('\n');
    md
}

/// The diffuse benchmark of every comparison (docs/method.md, "Diffuse
/// light"): ours against each rival at equal count by SH L2 over Delaunay
/// tetrahedra on the scene's own materials, with intervals; the count ours
/// needs for the equal-count grid's error; then how often ours meets the
/// bars of issue 68. `plots` gets each comparison's curve of error
/// against count (`diffuse-NAME.svg`, for docs/), and the returned
/// markdown links them.
fn diffuse_summary(compares: &[Value], plots: &mut Vec<(String, String)>, tag: &str) -> String {
    let columns = [
        ("config", false),
        ("ours", false),
        ("rival", false),
        ("probes", true),
        ("baked, surface", false),
        ("total, surface", false),
        ("baked, free", false),
        ("leaks, surface", false),
        ("ours: baked surface error, leaks", false),
    ];
    let mut t = Table::new(&columns);
    let (mut scenes, mut grid_bar, mut rivals_bar, mut leak_bar, mut count_bar) = (0, 0, 0, 0, 0);
    let mut equal_error: Vec<String> = Vec::new();
    let mut curves: Vec<String> = Vec::new();
    for c in compares {
        let Some(d) = at(c, "diffuse").filter(|d| !d.is_null()) else {
            continue;
        };
        let comparisons = array(d, "comparisons");
        if comparisons.is_empty() {
            continue;
        }
        scenes += 1;
        let name = config_name(c);
        let placements = array(d, "placements");
        let row_of = |n: &str| placements.iter().find(|p| text(p, "name") == n);
        let mut rivals_met = true;
        for x in comparisons {
            let ours = row_of(&text(x, "ours"));
            let ours_cell = format!(
                "{} · {}",
                pct(ours.and_then(|o| num(o, "surface.baked")), 1),
                pct(ours.and_then(|o| num(o, "surface.leaks")), 1)
            );
            let value = num(x, "surface_baked.value");
            let lo = num(x, "surface_baked.lo");
            // Ours at most a fraction `f` of the rival's error, the
            // interval excluding 1.
            let within =
                |f: f64| value.is_some_and(|v| v * f >= 1.0) && lo.is_some_and(|lo| lo > 1.0);
            if text(x, "family") == "grid" {
                if within(0.6) {
                    grid_bar += 1;
                }
                if num(x, "surface_leaks.value").is_some_and(|v| v >= 2.0) {
                    leak_bar += 1;
                }
            } else if !within(0.8) {
                rivals_met = false;
            }
            t.rows.push(vec![
                format!("`{name}`"),
                format!("`{}`", text(x, "ours")),
                format!("`{}` ({})", text(x, "rival"), text(x, "family")),
                int(num(x, "probes")),
                interval(at(x, "surface_baked")),
                interval(at(x, "surface_total")),
                interval(at(x, "free_baked")),
                interval(at(x, "surface_leaks")),
                ours_cell,
            ]);
        }
        if rivals_met {
            rivals_bar += 1;
        }
        if let Some(q) = at(d, "equal_error").filter(|q| !q.is_null()) {
            let r = num(q, "count_ratio");
            if r.is_some_and(|r| r <= 0.5) {
                count_bar += 1;
            }
            equal_error.push(match (num(q, "ours_probes"), r) {
                (Some(n), Some(r)) => format!(
                    "- `{name}`: `{}` ({} probes, baked surface error {}) is reached with {}{n:.1} of our probes: **{}** its count",
                    text(q, "grid"),
                    int(num(q, "grid_probes")),
                    pct(num(q, "grid_error"), 1),
                    if q["bound"].as_bool() == Some(true) { "at most " } else { "" },
                    ratio(Some(r))
                ),
                _ => format!(
                    "- `{name}`: no count of ours measured reaches `{}`'s error ({})",
                    text(q, "grid"),
                    pct(num(q, "grid_error"), 1)
                ),
            });
        }
        if let Some(svg) = diffuse_plot(
            placements,
            num(d, "setup.limit"),
            &format!("baked diffuse error at surface receivers against probe count, {name}"),
        ) {
            let file = format!("diffuse-{tag}{name}.svg");
            curves.push(format!(
                "![baked diffuse error against probe count, {name}]({file})"
            ));
            plots.push((file, svg));
        }
    }
    if scenes == 0 {
        return String::new();
    }
    let mut md = String::new();
    let _ = writeln!(
        md,
        "Diffuse light as engines blend probes, on the scene's own materials: each \
         probe's light in SH L2, blended over a Delaunay tetrahedralization of the probes \
         not in solid (Unity, Godot), at surface points the views see and points in the \
         free space the cameras reach, against a path-traced reference (docs/method.md, \
         \"Diffuse light\"). *Baked* is what a mixed-lighting probe holds (all but the \
         point, spot and directional lights' direct light); *total* adds that light. Each \
         cell is the rival's mean relative error over ours at equal count (ours placed \
         again with exactly the rival's count; above 1: ours is better) with its 95% \
         paired-bootstrap interval over views (surface) or runs of receivers (free); \
         *leaks* compares the share of receivers lit 2× too much or too little. The last \
         column is ours alone. Generated by `examples/results.rs` from the \
         `compare.json` files.\n"
    );
    md.push_str(&t.markdown());
    let _ = writeln!(
        md,
        "\nAt equal count, ours has at most 0.6× the uniform grid's baked surface error, \
         the interval excluding 1, in **{grid_bar} of {scenes}** scenes; at most 0.8× \
         every other rival's (relocated, greedy, adaptive) in **{rivals_bar} of {scenes}**; \
         at most half the grid's surface leak share in **{leak_bar} of {scenes}**; and \
         reaches the equal-count grid's error with at most half its count in \
         **{count_bar} of {scenes}** (issue 68's bars).\n"
    );
    if !equal_error.is_empty() {
        md.push_str("The count ours needs for the equal-count grid's error (interpolated in log count along our curve):\n\n");
        for e in &equal_error {
            let _ = writeln!(md, "{e}");
        }
        md.push('\n');
    }
    if !curves.is_empty() {
        md.push_str("Error against probe count, every method (ours at several budgets, the grid sweep, each competitor at each count of the sweep; dashed, the blend's limit: a probe at every receiver, `diffuse.setup.limit`):\n\n");
        for cv in &curves {
            let _ = writeln!(md, "{cv}\n");
        }
    }
    md
}

/// The colour of a family's curve in [`diffuse_plot`].
fn family_colour(f: &str) -> &'static str {
    match f {
        "ours" => "#2a8a2a",
        "grid" => "#3060c0",
        "relocated" => "#c07020",
        "greedy" => "#a03090",
        "adaptive" => "#c03030",
        _ => "#606060",
    }
}

/// An SVG plot's opening: the canvas `w`×`h`, white, `title` centred
/// above, and the frame of the plot area (`pw`×`ph` at `left`, `top`).
fn svg_frame(w: f64, h: f64, left: f64, top: f64, pw: f64, ph: f64, title: &str) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{w}\" height=\"{h}\" viewBox=\"0 0 {w} {h}\" font-family=\"sans-serif\" font-size=\"12\">"
    );
    s.push_str("<rect width=\"100%\" height=\"100%\" fill=\"#fff\"/>\n");
    let _ = writeln!(
        s,
        "<text x=\"{:.1}\" y=\"20\" text-anchor=\"middle\" font-size=\"14\">{}</text>",
        left + pw / 2.0,
        xml(title)
    );
    let _ = writeln!(
        s,
        "<rect x=\"{left}\" y=\"{top}\" width=\"{pw}\" height=\"{ph}\" fill=\"none\" stroke=\"#888\"/>"
    );
    s
}

/// Every family's baked surface error against probe count (both log), a
/// line and markers per family.
fn diffuse_plot(placements: &[Value], limit: Option<f64>, title: &str) -> Option<String> {
    let pts: Vec<(String, f64, f64)> = placements
        .iter()
        .filter_map(|p| {
            let e = num(p, "surface.baked")?;
            let n = num(p, "probes")?;
            (n > 0.0 && e > 0.0).then(|| (text(p, "family"), n, e))
        })
        .collect();
    if pts.len() < 2 {
        return None;
    }
    let (w, h, left, right, top, bottom) = (800.0, 420.0, 80.0, 140.0, 36.0, 50.0);
    let (mut x0, mut x1, mut y0, mut y1) = (
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
    );
    for (_, n, e) in &pts {
        x0 = x0.min(n.log10());
        x1 = x1.max(n.log10());
        y0 = y0.min(e.log10());
        y1 = y1.max(e.log10());
    }
    // The blend's own limit (a probe at every receiver), drawn across:
    // how far every placement stands from what the lookup allows.
    let limit = limit.filter(|&l| l > 0.0);
    if let Some(l) = limit {
        y0 = y0.min(l.log10());
    }
    let pad = |a: f64, b: f64| {
        if b - a < 1e-9 {
            (a - 0.5, b + 0.5)
        } else {
            (a - 0.05 * (b - a), b + 0.05 * (b - a))
        }
    };
    let ((x0, x1), (y0, y1)) = (pad(x0, x1), pad(y0, y1));
    let (pw, ph) = (w - left - right, h - top - bottom);
    let px = |n: f64| left + (n.log10() - x0) / (x1 - x0) * pw;
    let py = |e: f64| top + (1.0 - (e.log10() - y0) / (y1 - y0)) * ph;
    let mut s = svg_frame(w, h, left, top, pw, ph, title);
    // Ticks at 1, 2, 5 × 10^k.
    for (axis_lo, axis_hi, vertical) in [(x0, x1, true), (y0, y1, false)] {
        for k in (axis_lo.floor() as i32)..=(axis_hi.ceil() as i32) {
            for m in [1.0, 2.0, 5.0] {
                let v: f64 = m * 10f64.powi(k);
                if !(axis_lo..=axis_hi).contains(&v.log10()) {
                    continue;
                }
                let label = if v >= 1.0 {
                    format!("{v:.0}")
                } else {
                    format!("{v}")
                };
                if vertical {
                    let x = px(v);
                    let _ = writeln!(s, "<line x1=\"{x:.1}\" y1=\"{top}\" x2=\"{x:.1}\" y2=\"{:.1}\" stroke=\"#eee\"/><text x=\"{x:.1}\" y=\"{:.1}\" text-anchor=\"middle\">{label}</text>", top + ph, top + ph + 16.0);
                } else {
                    let y = py(v);
                    let _ = writeln!(s, "<line x1=\"{left}\" y1=\"{y:.1}\" x2=\"{:.1}\" y2=\"{y:.1}\" stroke=\"#eee\"/><text x=\"{:.1}\" y=\"{:.1}\" text-anchor=\"end\">{label}</text>", left + pw, left - 6.0, y + 4.0);
                }
            }
        }
    }
    let _ = writeln!(
        s,
        "<text x=\"{:.1}\" y=\"{:.1}\" text-anchor=\"middle\">probes</text><text transform=\"translate(16 {:.1}) rotate(-90)\" text-anchor=\"middle\">mean relative error</text>",
        left + pw / 2.0,
        h - 8.0,
        top + ph / 2.0
    );
    let mut ly = top + 10.0;
    for f in ["ours", "grid", "relocated", "greedy", "adaptive"] {
        let mut line: Vec<&(String, f64, f64)> = pts.iter().filter(|p| p.0 == f).collect();
        if line.is_empty() {
            continue;
        }
        line.sort_by(|a, b| a.1.total_cmp(&b.1).then(a.2.total_cmp(&b.2)));
        let colour = family_colour(f);
        if line.len() > 1 {
            let coords: Vec<String> = line
                .iter()
                .map(|p| format!("{:.1},{:.1}", px(p.1), py(p.2)))
                .collect();
            let _ = writeln!(
                s,
                "<polyline fill=\"none\" stroke=\"{colour}\" stroke-width=\"1.5\" points=\"{}\"/>",
                coords.join(" ")
            );
        }
        for p in &line {
            let _ = writeln!(
                s,
                "<circle cx=\"{:.1}\" cy=\"{:.1}\" r=\"3.5\" fill=\"{colour}\"/>",
                px(p.1),
                py(p.2)
            );
        }
        let lx = left + pw + 16.0;
        let _ = writeln!(s, "<circle cx=\"{lx:.1}\" cy=\"{ly:.1}\" r=\"4\" fill=\"{colour}\"/><text x=\"{:.1}\" y=\"{:.1}\">{f}</text>", lx + 10.0, ly + 4.0);
        ly += 18.0;
    }
    if let Some(l) = limit {
        let y = py(l);
        let _ = writeln!(s, "<line x1=\"{left}\" y1=\"{y:.1}\" x2=\"{:.1}\" y2=\"{y:.1}\" stroke=\"#555\" stroke-dasharray=\"6 4\"/>", left + pw);
        let lx = left + pw + 16.0;
        let _ = writeln!(s, "<line x1=\"{:.1}\" y1=\"{ly:.1}\" x2=\"{:.1}\" y2=\"{ly:.1}\" stroke=\"#555\" stroke-dasharray=\"6 4\"/><text x=\"{:.1}\" y=\"{:.1}\">the blend's limit</text>", lx - 6.0, lx + 6.0, lx + 10.0, ly + 4.0);
        let _ = writeln!(s, "<text x=\"{:.1}\" y=\"{:.1}\" font-size=\"10\">(a probe at</text><text x=\"{:.1}\" y=\"{:.1}\" font-size=\"10\">every receiver)</text>", lx + 10.0, ly + 18.0, lx + 10.0, ly + 30.0);
    }
    s.push_str("</svg>\n");
    Some(s)
}

/// A metric's verdict from its interval: `Some(true)` when it lies wholly
/// above 1 (ours better), `Some(false)` wholly below, `None` otherwise.
fn metric_verdict(i: Option<&Value>) -> Option<bool> {
    let (lo, hi) = (i.and_then(|i| num(i, "lo"))?, i.and_then(|i| num(i, "hi"))?);
    (lo > 1.0 || hi < 1.0).then_some(lo > 1.0)
}

/// The verdict on one rival, in words, from both metrics' intervals.
fn rival_words(r: &Value) -> String {
    let named = |v: Option<bool>| match v {
        Some(true) => "better",
        Some(false) => "worse",
        None => "",
    };
    let mse = metric_verdict(at(r, "mse_glossy_filtered"));
    let flip = metric_verdict(at(r, "flip"));
    match (mse, flip) {
        (None, None) => "no clear difference".into(),
        (a, b) if a == b => format!("ours {}", named(a)),
        (Some(a), None) => format!("ours {} by filtered MSE only", named(Some(a))),
        (None, Some(b)) => format!("ours {} by ꟻLIP only", named(Some(b))),
        (a, b) => format!("ours {} by filtered MSE, {} by ꟻLIP", named(a), named(b)),
    }
}

/// One line of the per-scene reading: our count, then each rival of
/// `ratios` (each set against the run of ours nearest its count) with its
/// verdict, in the table's order.
fn scene_reading(c: &Value, ours: &Value, ratios: &[(&Value, &Value)]) -> String {
    let mut parts: Vec<String> = Vec::new();
    for (x, r) in ratios {
        let family = text(r, "family");
        let who = match (family.as_str(), text(r, "tracer").as_str()) {
            ("grid", "bilevel+grid") => "the grid as engines trace it".to_string(),
            ("grid", _) => "the grid on our tracer".to_string(),
            (f, _) => f.to_string(),
        };
        let count = if num(x, "probes") == num(ours, "probes") {
            String::new()
        } else {
            format!(" (ours at {})", int(num(x, "probes")))
        };
        parts.push(format!("against {who}{count}, {}", rival_words(r)));
    }
    format!(
        "**`{}`**, ours {} probes: {}.",
        config_name(c),
        int(num(ours, "probes")),
        parts.join("; ")
    )
}

fn render(inputs: &mut Inputs) -> Files {
    let mut md = String::new();
    md.push_str("# Results\n\n");
    md.push_str(
        "<!-- Generated by examples/results.rs from report.json, compare.json and \
         generality.json; do not edit by hand. -->\n\n",
    );
    md.push_str(
        "Every figure below is generated from the JSON the runs write (schemas in \
         [formats.md](formats.md)); none is typed. Nothing that varies between runs \
         (timings, GPU times) is shown, so the same JSON gives the same file, byte for \
         byte. Every coverage figure is the validation measure, `report.json`'s \
         `coverage`: surface samples the placer never saw, against reference points \
         free by their own rays (formats.md, \"What coverage means\"), not the \
         training score the placer fitted. To regenerate, from the repository root \
         (the real scenes are read from `../shared/scenes`):\n\n",
    );
    let _ = write!(md, "```sh\n{REGENERATE}```\n\n");
    md.push_str(
        "`cargo run --release --example results -- --check DIR...` exits with status 1 \
         when the committed files differ from what the JSON gives. Best values per \
         column are in **bold** (among the rows of one scene); nothing is left out \
         where another placement beats ours.\n\n",
    );
    let _ = writeln!(
        md,
        "Inputs: {} `report.json`, {} `compare.json`, {} generality rows, {} lit generated \
         `compare.json`.\n",
        inputs.reports.len(),
        inputs.compares.len(),
        inputs.generality.len(),
        inputs.lit.len()
    );

    inputs.reports.sort_by(|a, b| {
        natural(&config_name(a), &config_name(b))
            .then_with(|| text(a, "method").cmp(&text(b, "method")))
            .then_with(|| a.to_string().cmp(&b.to_string()))
    });
    inputs.compares.sort_by(|a, b| {
        natural(&config_name(a), &config_name(b)).then_with(|| a.to_string().cmp(&b.to_string()))
    });

    let summary = compare_summary(&inputs.compares);
    if !summary.is_empty() {
        md.push_str("## Comparisons at a glance\n\n");
        md.push_str(&summary.replace("](docs/results.md)", "](results.md)"));
        md.push('\n');
    }
    let mut plots = Vec::new();
    let diffuse = diffuse_summary(&inputs.compares, &mut plots, "");
    if !diffuse.is_empty() {
        md.push_str("## Diffuse light at a glance\n\n");
        md.push_str(&diffuse);
    }
    inputs.lit.sort_by(|a, b| {
        natural(&config_name(a), &config_name(b)).then_with(|| a.to_string().cmp(&b.to_string()))
    });
    let lit_diffuse = diffuse_summary(&inputs.lit, &mut plots, "lit-");
    if !lit_diffuse.is_empty() {
        md.push_str("## Lit generated scenes at seeds outside the suite\n\n");
        md.push_str(
            "Every kind of generated scene at a seed no test or default was tuned on, with \
             the generator's sun and sky (`gen_scenes --lit --seeds`; their own lamps \
             too, where they have them), compared with the stock config by `compare --only \
             diffuse`: diffuse light, the columns of the table above. Their materials are \
             matte, so there is no glossy light to measure.\n\n",
        );
        md.push_str(&lit_diffuse);
    }
    if !inputs.reports.is_empty() {
        placement_section(&mut md, &inputs.reports);
        svo_section(&mut md, &inputs.reports);
        bake_section(&mut md, &inputs.reports);
        render_section(&mut md, &inputs.reports);
    }
    for c in &inputs.compares {
        compare_section(&mut md, c, &mut plots);
    }
    let mut generality = String::new();
    if !inputs.generality.is_empty() {
        generality = generality_section(&mut md, &mut inputs.generality);
    }
    // One trailing newline.
    while md.ends_with("\n\n") {
        md.pop();
    }
    Files {
        markdown: md,
        plots,
        generality,
    }
}

/// Row indices grouped by config name (rows are sorted, so groups are runs).
fn groups(reports: &[&Value]) -> Vec<Vec<usize>> {
    let mut out: Vec<Vec<usize>> = Vec::new();
    for (i, r) in reports.iter().enumerate() {
        match out.last_mut() {
            Some(g) if config_name(reports[g[0]]) == config_name(r) => g.push(i),
            _ => out.push(vec![i]),
        }
    }
    out
}

fn mark_groups(
    t: &mut Table,
    rows: &[&Value],
    col: usize,
    value: impl Fn(&Value) -> Option<f64>,
    lower: bool,
) {
    for g in groups(rows) {
        let values: Vec<Option<f64>> = g.iter().map(|&i| value(rows[i])).collect();
        t.mark_best(&g, col, &values, lower);
    }
}

fn placement_section(md: &mut String, reports: &[Value]) {
    let rows: Vec<&Value> = reports.iter().collect();
    md.push_str("## Placement (`probeplace place`)\n\n");
    md.push_str(
        "One row per `report.json`. *Placed → final*: probes before and after \
         refinement's sweeps, filling and pruning. *Coverage*: the share of the \
         coverable surface some probe sees, with its 95% interval (docs/method.md, \
         \"Coverage\"). *Below clearance*: probes filling placed nearer to a surface \
         than the placement's clearance. *Incidence*: mean incidence of each covered \
         sample's best view (lower is less grazing).\n\n",
    );
    let mut t = Table::new(&[
        ("config", false),
        ("method", false),
        ("triangles", true),
        ("voxel", true),
        ("placed → final", true),
        ("probes", true),
        ("coverage ± 95%", true),
        ("in solid", true),
        ("outside scene", true),
        ("below clearance", true),
        ("incidence", true),
    ]);
    for r in &rows {
        let placed = match (
            num(r, "refine.probes_initial"),
            num(r, "refine.probes_final"),
        ) {
            (Some(a), Some(b)) => format!("{} → {}", int(Some(a)), int(Some(b))),
            _ => DASH.into(),
        };
        let coverage = match num(r, "coverage_ci95") {
            Some(ci) => format!("{} ± {:.2}", pct(num(r, "coverage"), 2), 100.0 * ci),
            None => pct(num(r, "coverage"), 2),
        };
        t.rows.push(vec![
            format!("`{}`", config_name(r)),
            text(r, "method"),
            int(num(r, "scene.triangles")),
            format!(
                "{} ({})",
                fixed(num(r, "sdf.voxel_size"), 4),
                text(r, "resolution.source")
            ),
            placed,
            int(num(r, "probe_count")),
            coverage,
            int(num(r, "probes_in_solid")),
            int(num(r, "probes_outside_scene")),
            int(num(r, "probes_below_clearance")),
            num(r, "best_view_incidence_deg").map_or(DASH.into(), |x| format!("{x:.1}°")),
        ]);
    }
    mark_groups(&mut t, &rows, 5, |r| num(r, "probe_count"), true);
    mark_groups(&mut t, &rows, 6, |r| num(r, "coverage"), false);
    mark_groups(&mut t, &rows, 7, |r| num(r, "probes_in_solid"), true);
    md.push_str(&t.markdown());
    md.push('\n');
    let mut warnings = String::new();
    for r in &rows {
        if let Some(Value::Array(ws)) = at(r, "warnings") {
            for w in ws {
                let _ = writeln!(
                    warnings,
                    "- `{}` ({}): {}",
                    config_name(r),
                    text(r, "method"),
                    w.as_str().map_or(w.to_string(), str::to_string)
                );
            }
        }
    }
    if warnings.is_empty() {
        md.push_str("No run warned.\n\n");
    } else {
        md.push_str("Warnings:\n\n");
        md.push_str(&warnings);
        md.push('\n');
    }
}

fn svo_section(md: &mut String, reports: &[Value]) {
    let rows: Vec<&Value> = reports.iter().filter(|r| at(r, "svo").is_some()).collect();
    if rows.is_empty() {
        return;
    }
    md.push_str("## The SVO of probe indices (`report.json` `svo`)\n\n");
    md.push_str(
        "*Dense*: what the paper's storage would take, an RGBA8 3D texture at the same \
         leaf size (Wang Table 2). *Fallback*: free cells no probe whose influence region \
         overlaps them sees. *Unseen*: free cells none of their 64 nearest probes sees. *First sees*: share of \
         10 000 random free points whose first listed probe is unoccluded from them.\n\n",
    );
    let mut t = Table::new(&[
        ("config", false),
        ("method", false),
        ("probes", true),
        ("leaf", true),
        ("free cells", true),
        ("nodes", true),
        ("leaves", true),
        ("svo.bin", true),
        ("dense", true),
        ("smaller", true),
        ("fallback", true),
        ("unseen", true),
        ("first sees", true),
    ]);
    for r in &rows {
        let smaller = match (num(r, "svo.dense_bytes"), num(r, "svo.bytes")) {
            (Some(d), Some(b)) if b > 0.0 => format!("{:.0}×", d / b),
            _ => DASH.into(),
        };
        t.rows.push(vec![
            format!("`{}`", config_name(r)),
            text(r, "method"),
            int(num(r, "probe_count")),
            fixed(num(r, "svo.leaf_size"), 4),
            int(num(r, "svo.free_cells")),
            int(num(r, "svo.nodes")),
            int(num(r, "svo.leaves")),
            int(num(r, "svo.bytes")),
            int(num(r, "svo.dense_bytes")),
            smaller,
            int(num(r, "svo.fallback_cells")),
            int(num(r, "svo.leaves_without_visible_probe")),
            pct(num(r, "svo.first_probe_visible"), 2),
        ]);
    }
    mark_groups(&mut t, &rows, 7, |r| num(r, "svo.bytes"), true);
    mark_groups(
        &mut t,
        &rows,
        11,
        |r| num(r, "svo.leaves_without_visible_probe"),
        true,
    );
    mark_groups(
        &mut t,
        &rows,
        12,
        |r| num(r, "svo.first_probe_visible"),
        false,
    );
    md.push_str(&t.markdown());
    md.push('\n');
}

fn bake_section(md: &mut String, reports: &[Value]) {
    let rows: Vec<&Value> = reports.iter().filter(|r| at(r, "bake").is_some()).collect();
    if rows.is_empty() {
        return;
    }
    md.push_str("## Light-field bake (`report.json` `bake`)\n\n");
    md.push_str(
        "The bake's check of the CPU light-field tracer against exact ray casts: *seen*, \
         rays whose true hit some probe sees; *agree*, of those, traced hits within two \
         texels' width; *unknown*, of those, traces no probe could finish.\n\n",
    );
    let mut t = Table::new(&[
        ("config", false),
        ("method", false),
        ("probes", true),
        ("map side", true),
        ("lightfield.bin", true),
        ("rays", true),
        ("seen", true),
        ("agree", true),
        ("unknown", true),
    ]);
    for r in &rows {
        let agree = match (num(r, "bake.tracer.agree"), num(r, "bake.tracer.seen")) {
            (Some(a), Some(s)) if s > 0.0 => pct(Some(a / s), 2),
            _ => DASH.into(),
        };
        t.rows.push(vec![
            format!("`{}`", config_name(r)),
            text(r, "method"),
            int(num(r, "bake.probes")),
            int(num(r, "bake.resolution")),
            mib(num(r, "bake.bytes")),
            int(num(r, "bake.tracer.rays")),
            int(num(r, "bake.tracer.seen")),
            agree,
            int(num(r, "bake.tracer.unknown")),
        ]);
    }
    md.push_str(&t.markdown());
    md.push('\n');
}

fn render_section(md: &mut String, reports: &[Value]) {
    let rows: Vec<&Value> = reports
        .iter()
        .filter(|r| at(r, "render").is_some())
        .collect();
    if rows.is_empty() {
        return;
    }
    md.push_str("## Validation renders (`report.json` `render`)\n\n");
    md.push_str("One glossy ray per pixel, against the path-traced reference.\n\n");
    let mut t = Table::new(&[
        ("config", false),
        ("method", false),
        ("adapter", false),
        ("size", true),
        ("glossy rays", true),
        ("variant", false),
        ("texel fetches / ray", true),
        ("unresolved rays", true),
        ("mse_glossy", true),
        ("mse_full", true),
    ]);
    for r in &rows {
        let Some(Value::Object(variants)) = at(r, "render.variants") else {
            continue;
        };
        let mut names: Vec<&String> = variants.keys().collect();
        names.sort();
        for name in names {
            let v = &variants[name];
            t.rows.push(vec![
                format!("`{}`", config_name(r)),
                text(r, "method"),
                text(r, "render.adapter"),
                format!(
                    "{}×{}",
                    int(num(r, "render.width")),
                    int(num(r, "render.height"))
                ),
                int(num(r, "render.glossy_rays")),
                format!("{name} ({}+{})", text(v, "march"), text(v, "selection")),
                fixed(num(v, "texel_fetches_per_ray"), 1),
                int(num(v, "unresolved_rays")),
                sci(num(v, "mse_glossy")),
                sci(num(v, "mse_full")),
            ]);
        }
    }
    md.push_str(&t.markdown());
    md.push('\n');
}

// ---------------------------------------------------------------- compare

/// The `family` of compare's competitors: the `--method` words of the
/// placement registry's `Role::Competitor` methods, in its order.
fn competitor_words() -> Vec<&'static str> {
    use probeplace::placement::{Role, METHODS};
    METHODS
        .iter()
        .filter(|m| m.role == Role::Competitor)
        .map(|m| m.word)
        .collect()
}

/// Where a family's rows stand in tables: ours, the grids, the
/// competitors in the registry's order, then a given set.
fn family_rank(f: &str) -> usize {
    let mut order = vec!["ours", "grid"];
    order.extend(competitor_words());
    order.iter().position(|x| *x == f).unwrap_or(order.len())
}

/// Mean over cameras of a per-camera figure.
fn camera_mean(p: &Value, key: &str) -> Option<f64> {
    let cams = at(p, "cameras")?.as_array()?;
    let xs: Vec<f64> = cams.iter().filter_map(|c| num(c, key)).collect();
    (!xs.is_empty() && xs.len() == cams.len()).then(|| xs.iter().sum::<f64>() / xs.len() as f64)
}

fn compare_section(md: &mut String, c: &Value, plots: &mut Vec<(String, String)>) {
    let name = config_name(c);
    let quality = at(c, "quality_metric")
        .and_then(Value::as_str)
        .unwrap_or("mse_glossy")
        .to_string();
    let perf = text(c, "performance_metric");
    let scene = text(c, "scene");
    let scene_file = Path::new(&scene)
        .file_name()
        .map_or(scene.clone(), |s| s.to_string_lossy().into_owned());
    let cameras = at(c, "cameras")
        .and_then(Value::as_array)
        .map_or(0, Vec::len);
    let chosen = at(c, "cameras")
        .and_then(Value::as_array)
        .map_or(0, |a| a.iter().filter(|v| v["chosen"] == true).count());
    let materials = at(c, "materials")
        .and_then(Value::as_str)
        .unwrap_or("scene")
        .to_string();

    let _ = writeln!(md, "## Compare: `{name}`\n");
    let _ = writeln!(
        md,
        "`probeplace compare {}` on `{scene_file}`: {}×{}, {} glossy rays per pixel, \
         {cameras} view{} ({chosen} chosen from the scene), materials `{materials}`, seed {}, \
         traced on `{}`. Quality is `{quality}` (glossy \
         indirect MSE after a 7×7 box filter of both images: Wang Fig. 8; unfiltered it \
         is mostly Monte Carlo noise, the same for every placement), pooled as the mean \
         over views; *ꟻLIP* is the mean perceptual error of the same images tone mapped; \
         performance `{perf}`. *Tracer*: `hiz+svo` is Wang's Hi-Z march with SVO \
         selection, which every placement is traced with; `bilevel+grid` is McGuire's \
         bi-level march with the cell's 8 probes, as engines trace grids today, which the \
         grids are also traced with. *Unresolved rays*: glossy rays every candidate probe \
         lost (answered by the last probe's radiance). *Shading → probe*: the mean distance \
         from each view's shading points to the nearest probe that sees them (world units): \
         a glossy lookup returns the hit's radiance as that probe sees it, so its parallax \
         grows with this distance. *Rank*: by `{quality}`, 1 is best.\n",
        text(c, "config"),
        int(num(c, "width")),
        int(num(c, "height")),
        int(num(c, "glossy_rays")),
        if cameras == 1 { "" } else { "s" },
        text(c, "seed"),
        text(c, "adapter"),
    );

    let mut placements: Vec<&Value> = at(c, "placements")
        .and_then(Value::as_array)
        .map(|a| a.iter().collect())
        .unwrap_or_default();
    // Stable: within a family the file's order (ours as compare ran them,
    // the grids by probe count).
    placements.sort_by_key(|p| family_rank(&text(p, "family")));
    let error: Vec<Option<f64>> = placements.iter().map(|p| num(p, &quality)).collect();
    let mut order: Vec<usize> = (0..placements.len())
        .filter(|&i| error[i].is_some())
        .collect();
    order.sort_by(|&a, &b| {
        error[a]
            .unwrap_or(f64::INFINITY)
            .total_cmp(&error[b].unwrap_or(f64::INFINITY))
            .then_with(|| a.cmp(&b))
    });
    let mut rank = vec![None; placements.len()];
    for (k, &i) in order.iter().enumerate() {
        rank[i] = Some(k + 1);
    }

    let mut t = Table::new(&[
        ("placement", false),
        ("tracer", false),
        ("probes", true),
        ("coverage", true),
        ("in solid", true),
        ("probe data", true),
        ("SVO", true),
        ("texel fetches / ray", true),
        ("unresolved rays", true),
        ("shading → probe", true),
        ("glossy MSE", true),
        ("filtered glossy MSE", true),
        ("relative MSE", true),
        ("ꟻLIP", true),
        ("rank", true),
    ]);
    for (i, p) in placements.iter().enumerate() {
        let family = text(p, "family");
        let label = if family == "ours" {
            format!("`{}` (ours)", text(p, "name"))
        } else {
            format!("`{}`", text(p, "name"))
        };
        t.rows.push(vec![
            label,
            text(p, "tracer"),
            int(num(p, "probes")),
            pct(num(p, "coverage"), 2),
            int(num(p, "probes_in_solid")),
            mib(num(p, "probe_bytes")),
            kib(num(p, "svo_bytes")),
            fixed(num(p, "texel_fetches_per_ray"), 1),
            pct(camera_mean(p, "unresolved_fraction"), 3),
            fixed(num(p, "shading_probe_distance"), 2),
            sci(num(p, "mse_glossy")),
            sci(num(p, "mse_glossy_filtered")),
            sci(num(p, "mse_glossy_relative")),
            fixed(num(p, "flip"), 4),
            rank[i].map_or(DASH.into(), |r| r.to_string()),
        ]);
    }
    let all: Vec<usize> = (0..placements.len()).collect();
    let col = |f: &dyn Fn(&Value) -> Option<f64>| -> Vec<Option<f64>> {
        placements.iter().map(|p| f(p)).collect()
    };
    t.mark_best(&all, 3, &col(&|p| num(p, "coverage")), false);
    t.mark_best(&all, 4, &col(&|p| num(p, "probes_in_solid")), true);
    t.mark_best(&all, 7, &col(&|p| num(p, "texel_fetches_per_ray")), true);
    t.mark_best(
        &all,
        8,
        &col(&|p| camera_mean(p, "unresolved_fraction")),
        true,
    );
    t.mark_best(&all, 9, &col(&|p| num(p, "shading_probe_distance")), true);
    t.mark_best(&all, 10, &col(&|p| num(p, "mse_glossy")), true);
    t.mark_best(&all, 11, &col(&|p| num(p, "mse_glossy_filtered")), true);
    t.mark_best(&all, 12, &col(&|p| num(p, "mse_glossy_relative")), true);
    t.mark_best(&all, 13, &col(&|p| num(p, "flip")), true);
    md.push_str(&t.markdown());
    md.push('\n');

    // What the figures say, from the figures.
    if let Some(&best) = order.first() {
        let _ = writeln!(
            md,
            "- Lowest `{quality}`: `{}` ({}), {}.",
            text(placements[best], "name"),
            text(placements[best], "family"),
            sci(error[best])
        );
    }
    for (i, p) in placements.iter().enumerate() {
        if text(p, "family") != "ours" {
            continue;
        }
        let Some(e) = error[i] else { continue };
        let better: Vec<String> = order
            .iter()
            .filter(|&&j| error[j].is_some_and(|x| x < e))
            .map(|&j| {
                format!(
                    "`{}` ({} probes)",
                    text(placements[j], "name"),
                    int(num(placements[j], "probes"))
                )
            })
            .collect();
        let _ = writeln!(
            md,
            "- `{}` ({} probes): rank {} of {}; {}.",
            text(p, "name"),
            int(num(p, "probes")),
            rank[i].unwrap_or(0),
            order.len(),
            if better.is_empty() {
                "no placement has lower error".to_string()
            } else {
                format!("lower error: {}", better.join(", "))
            }
        );
    }
    md.push('\n');

    // The matches.
    let comparisons: Vec<&Value> = at(c, "comparisons")
        .and_then(Value::as_array)
        .map(|a| a.iter().collect())
        .unwrap_or_default();
    if !comparisons.is_empty() {
        let _ = writeln!(
            md,
            "Matches against the grid sweep. *Error ratio*: the grid's `{quality}` over the \
             placement's (above 1: the placement has lower error; below 1 the grid wins). \
             *Equal count*: the grid nearest in probe count (ties to the larger); *equal \
             quality*: the smallest grid with at most the placement's error, and its probe \
             count over the placement's; *equal performance*: the grid nearest in \
             `{perf}`.\n"
        );
        let mut m = Table::new(&[
            ("placement", false),
            ("probes", true),
            ("error", true),
            ("equal count, hiz+svo", false),
            ("error ratio", true),
            ("equal count, bilevel+grid", false),
            ("error ratio", true),
            ("equal quality, hiz+svo", false),
            ("probe ratio", true),
            ("equal quality, bilevel+grid", false),
            ("probe ratio", true),
            ("equal performance, bilevel+grid", false),
            ("error ratio", true),
        ]);
        let grid = |g: Option<&Value>| match g {
            Some(g) => format!("`{}` ({} probes)", text(g, "grid"), int(num(g, "probes"))),
            None => "none in the sweep".to_string(),
        };
        let error_ratio = |x: Option<f64>| match x {
            Some(x) if x < 1.0 => format!("{} (grid wins)", ratio(Some(x))),
            x => ratio(x),
        };
        let mut comparisons = comparisons;
        comparisons.sort_by(|a, b| {
            let fa = placements
                .iter()
                .position(|p| text(p, "name") == text(a, "placement"));
            let fb = placements
                .iter()
                .position(|p| text(p, "name") == text(b, "placement"));
            fa.cmp(&fb)
                .then_with(|| text(a, "placement").cmp(&text(b, "placement")))
        });
        for x in comparisons.iter().copied() {
            let probe_ratio = |key: &str| match num(x, key) {
                Some(r) if r < 1.0 => format!("{} (grid wins)", ratio(Some(r))),
                r => ratio(r),
            };
            m.rows.push(vec![
                format!("`{}`", text(x, "placement")),
                int(num(x, "probes")),
                sci(num(x, "error").or_else(|| num(x, "mse_glossy"))),
                grid(at(x, "equal_count")),
                error_ratio(num(x, "error_ratio_at_equal_count")),
                grid(at(x, "equal_count_engine")),
                error_ratio(num(x, "error_ratio_at_equal_count_engine")),
                grid(at(x, "equal_quality")),
                probe_ratio("probe_ratio_at_equal_quality"),
                grid(at(x, "equal_quality_engine")),
                probe_ratio("probe_ratio_at_equal_quality_engine"),
                grid(at(x, "equal_performance")),
                error_ratio(num(x, "error_ratio_at_equal_performance")),
            ]);
        }
        md.push_str(&m.markdown());
        md.push('\n');
        ratios_table(md, &placements, &comparisons);
    }

    if let Some(w) = at(c, "warnings")
        .and_then(Value::as_array)
        .filter(|w| !w.is_empty())
    {
        md.push_str("Warnings: ");
        let ws: Vec<String> = w
            .iter()
            .map(|w| w.as_str().map_or(w.to_string(), str::to_string))
            .collect();
        md.push_str(&ws.join("; "));
        md.push_str(".\n\n");
    }

    // The plots.
    let points: Vec<Point> = placements
        .iter()
        .filter_map(|p| {
            Some(Point {
                name: text(p, "name"),
                grid: text(p, "family") == "grid",
                engine: text(p, "tracer") == "bilevel+grid",
                ours: text(p, "family") == "ours",
                probes: num(p, "probes")?,
                error: num(p, &quality),
                coverage: num(p, "coverage"),
            })
        })
        .collect();
    let mse_name = format!("compare-{name}-mse.svg");
    let cov_name = format!("compare-{name}-coverage.svg");
    if let Some(svg) = plot(
        &points,
        |p| p.error,
        true,
        &format!("{quality} against probe count, {name} (lower is better)"),
    ) {
        let _ = writeln!(
            md,
            "![{quality} against probe count, {name}]({mse_name})\n\nThe grid sweep on `hiz+svo` solid, on `bilevel+grid` dashed.\n"
        );
        plots.push((mse_name, svg));
    }
    if let Some(svg) = plot(
        &points,
        |p| p.coverage.map(|c| 100.0 * c),
        false,
        &format!("coverage (%) against probe count, {name}"),
    ) {
        let _ = writeln!(md, "![coverage against probe count, {name}]({cov_name})\n");
        plots.push((cov_name, svg));
    }
}

/// `value× [lo, hi]` of a ratio with its interval; bold when the interval
/// excludes 1.
fn interval(i: Option<&Value>) -> String {
    let (Some(v), Some(lo), Some(hi)) = (
        i.and_then(|i| num(i, "value")),
        i.and_then(|i| num(i, "lo")),
        i.and_then(|i| num(i, "hi")),
    ) else {
        return DASH.into();
    };
    let t = format!("{v:.2}× [{lo:.2}, {hi:.2}]");
    if metric_verdict(i).is_some() {
        format!("**{t}**")
    } else {
        t
    }
}

/// The columns of [`ratio_cells`].
const RATIO_COLUMNS: [(&str, bool); 6] = [
    ("rival", false),
    ("tracer", false),
    ("probes", true),
    ("filtered MSE ratio", false),
    ("ꟻLIP ratio", false),
    ("verdict", false),
];

/// The cells of a ratio: the rival, its tracer and count, both ratios with
/// their intervals, and the verdict.
fn ratio_cells(r: &Value) -> [String; 6] {
    [
        format!("`{}` ({})", text(r, "against"), text(r, "family")),
        text(r, "tracer"),
        int(num(r, "probes")),
        interval(at(r, "mse_glossy_filtered")),
        interval(at(r, "flip")),
        verdict(r).to_string(),
    ]
}

/// The verdict of a ratio: both intervals above 1, below 1, or neither.
fn verdict(x: &Value) -> &'static str {
    match (x["win"].as_bool(), x["loss"].as_bool()) {
        (Some(true), _) => "ours better",
        (_, Some(true)) => "ours worse",
        _ => "no clear difference",
    }
}

/// Our placements against every rival, with intervals (`ratios`).
fn ratios_table(md: &mut String, placements: &[&Value], comparisons: &[&Value]) {
    let ours: Vec<&&Value> = comparisons
        .iter()
        .filter(|x| {
            placements.iter().any(|p| {
                text(p, "name") == text(x, "placement")
                    && matches!(text(p, "family").as_str(), "ours" | "given")
            })
        })
        .collect();
    if ours.is_empty() {
        return;
    }
    md.push_str(
        "Ours against each rival at about equal count: the rival's pooled error over ours \
         (above 1: ours is better) with its 95% interval, a two-stage paired bootstrap over \
         views and 16-pixel blocks; bold where the interval excludes 1. Ours is traced with \
         `hiz+svo`; a grid on `hiz+svo` isolates placement, on `bilevel+grid` it is what \
         engines trace today.\n\n",
    );
    let columns: Vec<(&'static str, bool)> = [("ours", false), ("probes", true)]
        .into_iter()
        .chain(RATIO_COLUMNS)
        .collect();
    let mut t = Table::new(&columns);
    for x in ours {
        for r in at(x, "ratios")
            .and_then(Value::as_array)
            .into_iter()
            .flatten()
        {
            t.rows.push(
                vec![format!("`{}`", text(x, "placement")), int(num(x, "probes"))]
                    .into_iter()
                    .chain(ratio_cells(r))
                    .collect(),
            );
        }
    }
    md.push_str(&t.markdown());
    md.push('\n');
}

struct Point {
    name: String,
    grid: bool,
    /// Traced with McGuire's bi-level tracer (a grid's second row).
    engine: bool,
    ours: bool,
    probes: f64,
    error: Option<f64>,
    coverage: Option<f64>,
}

/// A scatter plot of `y` against probe count (log x; log y when `log_y`):
/// the grids as a line, every other placement as a labelled dot.
fn plot(
    points: &[Point],
    y: impl Fn(&Point) -> Option<f64>,
    log_y: bool,
    title: &str,
) -> Option<String> {
    let pts: Vec<(&Point, f64, f64)> = points
        .iter()
        .filter_map(|p| {
            let v = y(p)?;
            (p.probes > 0.0 && v.is_finite() && (!log_y || v > 0.0)).then_some((p, p.probes, v))
        })
        .collect();
    if pts.len() < 2 {
        return None;
    }
    let (w, h, left, right, top, bottom) = (800.0, 420.0, 80.0, 180.0, 36.0, 50.0);
    let tx = |x: f64| x.log10();
    let ty = |v: f64| if log_y { v.log10() } else { v };
    let (mut x0, mut x1) = (f64::INFINITY, f64::NEG_INFINITY);
    let (mut y0, mut y1) = (f64::INFINITY, f64::NEG_INFINITY);
    for &(_, x, v) in &pts {
        x0 = x0.min(tx(x));
        x1 = x1.max(tx(x));
        y0 = y0.min(ty(v));
        y1 = y1.max(ty(v));
    }
    let pad = |a: f64, b: f64| {
        if b - a < 1e-9 {
            (a - 0.5, b + 0.5)
        } else {
            (a - 0.05 * (b - a), b + 0.05 * (b - a))
        }
    };
    let (x0, x1) = pad(x0, x1);
    let (y0, y1) = pad(y0, y1);
    let pw = w - left - right;
    let ph = h - top - bottom;
    let px = |x: f64| left + (tx(x) - x0) / (x1 - x0) * pw;
    let py = |v: f64| top + (1.0 - (ty(v) - y0) / (y1 - y0)) * ph;

    let mut s = svg_frame(w, h, left, top, pw, ph, title);
    // x ticks: 1, 2, 5 × powers of ten inside the range.
    for e in -1..6 {
        for m in [1.0, 2.0, 5.0] {
            let x = m * 10f64.powi(e);
            let lx = tx(x);
            if lx < x0 || lx > x1 {
                continue;
            }
            let xp = px(x);
            let _ = writeln!(
                s,
                "<line x1=\"{xp:.1}\" y1=\"{top}\" x2=\"{xp:.1}\" y2=\"{:.1}\" stroke=\"#eee\"/><text x=\"{xp:.1}\" y=\"{:.1}\" text-anchor=\"middle\">{}</text>",
                top + ph,
                top + ph + 16.0,
                x
            );
        }
    }
    // y ticks.
    let yticks: Vec<f64> = if log_y {
        let mut v = Vec::new();
        for e in (y0.floor() as i32)..=(y1.ceil() as i32) {
            for m in [1.0, 2.0, 5.0] {
                let t = m * 10f64.powi(e);
                if ty(t) >= y0 && ty(t) <= y1 {
                    v.push(t);
                }
            }
        }
        v
    } else {
        let span = y1 - y0;
        let step = [0.1, 0.2, 0.5, 1.0, 2.0, 5.0, 10.0, 20.0, 50.0]
            .into_iter()
            .find(|s| span / s <= 8.0)
            .unwrap_or(100.0);
        let mut v = Vec::new();
        let mut t = (y0 / step).ceil() * step;
        while t <= y1 {
            v.push(t);
            t += step;
        }
        v
    };
    for t in yticks {
        let yp = py(t);
        let label = if log_y {
            let e = t.log10().floor() as i32;
            format!("{}e{}", (t / 10f64.powi(e)).round(), e)
        } else {
            format!("{t:.1}")
        };
        let _ = writeln!(
            s,
            "<line x1=\"{left}\" y1=\"{yp:.1}\" x2=\"{:.1}\" y2=\"{yp:.1}\" stroke=\"#eee\"/><text x=\"{:.1}\" y=\"{:.1}\" text-anchor=\"end\">{label}</text>",
            left + pw,
            left - 6.0,
            yp + 4.0
        );
    }
    let _ = writeln!(
        s,
        "<text x=\"{:.1}\" y=\"{:.1}\" text-anchor=\"middle\">probes</text>",
        left + pw / 2.0,
        h - 12.0
    );
    // The grid sweep as a line per tracer: solid on Wang's, dashed on
    // McGuire's.
    for (engine, dash) in [(false, ""), (true, " stroke-dasharray=\"5 3\"")] {
        let mut grid: Vec<&(&Point, f64, f64)> = pts
            .iter()
            .filter(|p| p.0.grid && p.0.engine == engine)
            .collect();
        grid.sort_by(|a, b| a.1.total_cmp(&b.1));
        if grid.len() > 1 {
            let line: Vec<String> = grid
                .iter()
                .map(|p| format!("{:.1},{:.1}", px(p.1), py(p.2)))
                .collect();
            let _ = writeln!(
                s,
                "<polyline fill=\"none\" stroke=\"#888\" stroke-width=\"1.5\"{dash} points=\"{}\"/>",
                line.join(" ")
            );
        }
    }
    for (p, x, v) in &pts {
        let colour = if p.ours {
            "#3060c0"
        } else if p.grid {
            "#888"
        } else {
            "#d07020"
        };
        let _ = writeln!(
            s,
            "<circle cx=\"{:.1}\" cy=\"{:.1}\" r=\"4\" fill=\"{colour}\"><title>{}</title></circle>",
            px(*x),
            py(*v),
            xml(&p.name)
        );
    }
    // Labels for every non-grid placement, in a legend column on the right
    // (labels beside the dots would overlap).
    // Sorted top to bottom so that the leader lines cross little.
    let mut labelled: Vec<&(&Point, f64, f64)> = pts.iter().filter(|p| !p.0.grid).collect();
    labelled.sort_by(|a, b| {
        py(a.2)
            .total_cmp(&py(b.2))
            .then_with(|| a.0.name.cmp(&b.0.name))
    });
    let mut ly = top + 10.0;
    for (p, x, v) in labelled {
        let colour = if p.ours { "#3060c0" } else { "#d07020" };
        let _ = writeln!(
            s,
            "<line x1=\"{:.1}\" y1=\"{:.1}\" x2=\"{:.1}\" y2=\"{ly:.1}\" stroke=\"{colour}\" stroke-width=\"0.5\"/><text x=\"{:.1}\" y=\"{:.1}\" fill=\"{colour}\">{}</text>",
            px(*x),
            py(*v),
            left + pw + 8.0,
            left + pw + 10.0,
            ly + 4.0,
            xml(&p.name)
        );
        ly += 18.0;
    }
    let _ = writeln!(
        s,
        "<text x=\"{:.1}\" y=\"{:.1}\" fill=\"#888\">grids (line)</text>",
        left + pw + 10.0,
        ly + 4.0
    );
    s.push_str("</svg>\n");
    Some(s)
}

fn xml(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

// ---------------------------------------------------------------- generality

/// Writes the generality table into `md`; returns README.md's sentence
/// on it.
fn generality_section(md: &mut String, rows: &mut [Value]) -> String {
    rows.sort_by(|a, b| {
        natural(&text(a, "scene"), &text(b, "scene"))
            .then_with(|| text(a, "method").cmp(&text(b, "method")))
            .then_with(|| a.to_string().cmp(&b.to_string()))
    });
    md.push_str("## Any scene: the stock config against uniform grids\n\n");
    md.push_str(
        "`cargo run --release --example generality -- out/generality`: the stock config \
         (nothing but the scene, its scale and up axis; voxel size chosen from the scene) \
         with both of our methods on the generated scenes of \
         `probeplace::fixtures::generated::suite()` and on every config of `configs/` \
         with its `voxel_size` removed, then the sweep of uniform grids shaped like the \
         domain (1 to 16 cells along its longest axis) for the smallest one reaching the \
         same coverage, scored by the same samples. *Fewer than grid*: ours needs fewer \
         probes than that grid, or no grid of the sweep reaches our coverage.\n\n",
    );
    let mut t = Table::new(&[
        ("scene", false),
        ("method", false),
        ("triangles", true),
        ("voxel", true),
        ("probes", true),
        ("coverage", true),
        ("in solid", true),
        ("below clearance", true),
        ("warnings", true),
        ("smallest grid reaching it", false),
        ("fewer than grid", false),
    ]);
    let mut beaten: Vec<String> = Vec::new();
    let mut short: Vec<String> = Vec::new();
    let mut solid = 0;
    let mut warned: Vec<String> = Vec::new();
    for r in rows.iter() {
        let probes = num(r, "probes");
        let grid = at(r, "smallest_grid").and_then(Value::as_array);
        let (grid_text, grid_probes) = match grid {
            Some(g) if g.len() == 3 => {
                let n = g[1].as_f64();
                (
                    format!(
                        "{} = {} ({})",
                        g[0].as_str().unwrap_or(DASH),
                        int(n),
                        pct(g[2].as_f64(), 2)
                    ),
                    n,
                )
            }
            _ => (
                match num(r, "grid_probe_limit") {
                    Some(n) => format!("none of at most {} probes", int(Some(n))),
                    None => "none up to 16 cells".to_string(),
                },
                None,
            ),
        };
        let wins = match (probes, grid_probes) {
            (_, None) => true,
            (Some(p), Some(g)) => p < g,
            (None, Some(_)) => false,
        };
        let label = format!("{} {}", text(r, "scene"), text(r, "method"));
        if !wins {
            beaten.push(label.clone());
        }
        if num(r, "coverage").is_some_and(|c| c < 0.999) {
            short.push(format!("{label} ({})", pct(num(r, "coverage"), 3)));
        }
        if num(r, "probes_in_solid").is_some_and(|n| n > 0.0) {
            solid += 1;
        }
        let nw = at(r, "warnings")
            .and_then(Value::as_array)
            .map_or(0, Vec::len);
        if nw > 0 {
            warned.push(format!("{label} ({nw})"));
        }
        t.rows.push(vec![
            text(r, "scene"),
            text(r, "method"),
            int(num(r, "triangles")),
            format!(
                "{} ({})",
                fixed(num(r, "voxel_size"), 4),
                text(r, "voxel_source")
            ),
            int(probes),
            pct(num(r, "coverage"), 2),
            int(num(r, "probes_in_solid")),
            int(num(r, "probes_below_clearance")),
            nw.to_string(),
            grid_text,
            if wins { "yes".into() } else { "**no**".into() },
        ]);
    }
    md.push_str(&t.markdown());
    md.push('\n');
    let n = rows.len();
    let scenes = rows
        .iter()
        .map(|r| text(r, "scene"))
        .collect::<std::collections::BTreeSet<_>>()
        .len();
    let methods = rows
        .iter()
        .map(|r| text(r, "method"))
        .collect::<std::collections::BTreeSet<_>>()
        .len();
    let readme = format!(
        "On placement alone, the stock config (nothing but the scene; the coverage \
         objective, before the diffuse step) needs fewer probes \
         than the smallest uniform grid reaching the same coverage (validation coverage: \
         samples the placer never saw), or no grid of the sweep \
         (up to 16 cells along the longest axis) reaches it, on **{} of the {n} rows** of \
         the generality table ({scenes} scenes, generated and every config, by {methods} \
         methods; [docs/results.md](docs/results.md), \"Any scene\").\n",
        n - beaten.len()
    );
    let _ = writeln!(
        md,
        "- Fewer probes than the smallest grid reaching the same coverage (or no grid \
         reaching it): {} of {n} rows{}.",
        n - beaten.len(),
        if beaten.is_empty() {
            String::new()
        } else {
            format!("; not: {}", beaten.join(", "))
        }
    );
    let _ = writeln!(
        md,
        "- Coverage below 99.9%: {}.",
        if short.is_empty() {
            "none".to_string()
        } else {
            short.join(", ")
        }
    );
    let _ = writeln!(
        md,
        "- Rows with a probe in solid: {solid}; rows with warnings (how many): {}.\n",
        if warned.is_empty() {
            "none".to_string()
        } else {
            warned.join(", ")
        }
    );
    readme
}
