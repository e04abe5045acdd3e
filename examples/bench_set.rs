//! Issue 47's benchmark set: scenes that look like users' scenes, written
//! from what ../shared holds and from code (never committed), and `place`
//! timed on each with the stock config, as a new user would run it.
//!
//! ```text
//! cargo build --release --examples
//! target/release/examples/bench_set generate DIR
//! target/release/examples/bench_set run DIR LABEL [--bin PROBEPLACE] [--only NAME,...]
//! target/release/examples/bench_set table DIR/bench-LABEL.json [DIR/bench-BEFORE.json] [--write BENCHMARKS.md]
//! ```
//!
//! `generate` writes the scenes and their stock configs (`Auto` voxel,
//! every other field default; lights where the scene has none) into DIR:
//! Dabrovic Sponza and the Holodeck as they are, Sponza tiled 4×4 and 8×8
//! (about 1M and 4M triangles) and the Holodeck 8×8 (src/fixtures/tiling.rs),
//! a block world of 200k and one of 2M triangles
//! (src/fixtures/voxel_world.rs), a furnished office floor of 330k
//! (src/fixtures/furniture_hall.rs) and the 5M-triangle generated city
//! (src/fixtures/city.rs).
//!
//! `run` places each scene twice, at the `Auto` voxel and at half of it
//! (the finer grid a user picks for small furniture), with `probeplace
//! place CONFIG --out … -q` (the binary beside this example, or `--bin`, so
//! that today's binary and a new one run in one sitting), and writes
//! `DIR/bench-LABEL.json`: per run the wall time, the peak resident memory
//! (`wait4`'s `ru_maxrss`), the probe count, the coverage and
//! `report.json`'s stage timings.
//!
//! `table` prints BENCHMARKS.md's table from one such file, or from two
//! (a new one and a before, matched by scene and voxel, with the ratio of
//! their wall times); `--write FILE` puts it between the file's
//! `<!-- bench-set:begin -->` and `<!-- bench-set:end -->` lines instead.

#[path = "common/json.rs"]
mod json;

use probeplace::config::UpAxis;
use probeplace::fixtures::{
    city::write_city, furniture_hall::write_furniture_hall, tiling::tile_obj,
    voxel_world::write_voxel_world,
};
use serde_json::{json, Value};
use std::error::Error;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

type Result<T> = std::result::Result<T, Box<dyn Error>>;

/// ../shared, beside the repository.
fn shared() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/scenes")
}

/// Stock config text for `scene` (relative to the config), in `scale`
/// units with `up` up, lit by `lights`.
fn stock(scene: &str, scale: f64, up: &str, lights: &str) -> String {
    format!("(\n    scene: \"{scene}\",\n    scale: {scale},\n    up: {up},\n    output: \"out\",\n    lights: [{lights}],\n)\n")
}

const SUN: &str = "Directional(direction: (-0.3, -1.0, 0.25), irradiance: (6.0, 5.6, 5.0)), Sky(radiance: (0.5, 0.6, 0.8))";
const LAMP: &str = "Point(position: (1.5, 2.7, 0.0), intensity: (4.0, 3.8, 3.4))";

/// Writes every scene and its config into `dir`; the configs' names are
/// the scenes' names in the tables.
fn generate(dir: &Path) -> Result<()> {
    std::fs::create_dir_all(dir)?;
    let write = |name: &str, text: String| std::fs::write(dir.join(format!("{name}.ron")), text);
    let sponza = shared().join("dabrovic_sponza/sponza.obj");
    let holodeck = shared().join("holodeck/holodeck.obj");
    for (name, src, scale) in [("sponza", &sponza, 1.0), ("holodeck", &holodeck, 0.01)] {
        let lights = if name == "sponza" { SUN } else { LAMP };
        write(
            name,
            stock(
                &src.canonicalize()?.display().to_string(),
                scale,
                "Y",
                lights,
            ),
        )?;
        eprintln!("{name}: {}", src.display());
    }
    for (name, src, n, scale) in [
        ("sponza-4x4", &sponza, 4, 1.0),
        ("sponza-8x8", &sponza, 8, 1.0),
        ("holodeck-8x8", &holodeck, 8, 0.01),
    ] {
        let t = tile_obj(src, &dir.join(name), name, [n, n], UpAxis::Y, 0.1)?;
        let lights = if scale == 1.0 { SUN } else { LAMP };
        write(
            name,
            stock(&format!("{name}/{name}.obj"), scale, "Y", lights),
        )?;
        eprintln!("{name}: {} triangles", t.triangles);
    }
    for (name, triangles) in [("voxel-world-200k", 200_000), ("voxel-world-2m", 2_000_000)] {
        let w = write_voxel_world(&dir.join(name), 1, triangles)?;
        write(
            name,
            stock(&format!("{name}/voxel-world-1.obj"), 1.0, "Y", SUN),
        )?;
        eprintln!(
            "{name}: {} triangles, {} columns a side",
            w.triangles, w.side
        );
    }
    let h = write_furniture_hall(&dir.join("furniture-hall"), 1, 330_000)?;
    write(
        "furniture-hall",
        stock("furniture-hall/furniture-hall-1.obj", 0.01, "Y", LAMP),
    )?;
    eprintln!(
        "furniture-hall: {} triangles, {} rooms, {} chairs",
        h.triangles, h.rooms, h.chairs
    );
    std::fs::create_dir_all(dir.join("city"))?;
    let c = write_city(&dir.join("city"), 1, 5_000_000)?;
    write("city", stock("city/city-1.obj", 1.0, "Y", SUN))?;
    eprintln!("city: {} triangles", c.triangles);
    Ok(())
}

/// The scenes of `dir`, in the tables' order.
const SCENES: [&str; 9] = [
    "sponza",
    "holodeck",
    "holodeck-8x8",
    "voxel-world-200k",
    "furniture-hall",
    "sponza-4x4",
    "voxel-world-2m",
    "sponza-8x8",
    "city",
];

/// Runs `bin place config --out out -q`; its wall seconds and peak
/// resident memory in MiB.
fn timed_place(bin: &Path, config: &Path, out: &Path) -> Result<(f64, f64)> {
    let start = Instant::now();
    let mut child = Command::new(bin)
        .arg("place")
        .arg(config)
        .arg("--out")
        .arg(out)
        .arg("-q")
        .stderr(std::process::Stdio::piped())
        .spawn()?;
    // Warnings and errors, read to the end (the child's exit closes it)
    // before reaping it.
    let mut err = String::new();
    if let Some(pipe) = child.stderr.as_mut() {
        std::io::Read::read_to_string(pipe, &mut err)?;
    }
    eprint!("{err}");
    let mut status = 0;
    // SAFETY: an all-zero rusage is a valid value to be overwritten, and
    // the pid is our own child, not yet reaped.
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    let pid = unsafe { libc::wait4(child.id() as libc::pid_t, &mut status, 0, &mut usage) };
    let wall = start.elapsed().as_secs_f64();
    if pid < 0 || !libc::WIFEXITED(status) || libc::WEXITSTATUS(status) != 0 {
        let last = err.lines().last().unwrap_or("").trim();
        return Err(format!(
            "exit {} after {wall:.1} s: {last}",
            libc::WEXITSTATUS(status)
        )
        .into());
    }
    Ok((wall, usage.ru_maxrss as f64 / 1024.0))
}

/// `config`'s text with `voxel_size: v` added.
fn with_voxel(text: &str, v: f64) -> String {
    text.replacen("(\n", &format!("(\n    voxel_size: {v},\n"), 1)
}

fn run(dir: &Path, label: &str, bin: &Path, only: Option<Vec<String>>) -> Result<()> {
    let mut runs = Vec::new();
    for scene in SCENES {
        if only.as_ref().is_some_and(|o| !o.iter().any(|s| s == scene)) {
            continue;
        }
        let config = dir.join(format!("{scene}.ron"));
        let text = std::fs::read_to_string(&config)
            .map_err(|e| format!("{}: {e} (run `generate` first)", config.display()))?;
        let mut auto = None;
        for voxel in ["auto", "half"] {
            let cfg = if voxel == "auto" {
                config.clone()
            } else if auto.is_none() {
                runs.push(json!({"scene": scene, "voxel": voxel, "failed": "not run: the Auto run failed"}));
                continue;
            } else {
                let half = dir.join(format!("{scene}-half.ron"));
                std::fs::write(&half, with_voxel(&text, auto.unwrap_or(f64::NAN) / 2.0))?;
                half
            };
            let out = dir.join("out").join(format!("{label}-{scene}-{voxel}"));
            let (wall, peak) = match timed_place(bin, &cfg, &out) {
                Ok(measured) => measured,
                Err(e) => {
                    // A refusal (the work limit, say) is a result: the row
                    // says so, and the set goes on.
                    eprintln!("{scene} {voxel}: {e}");
                    runs.push(json!({"scene": scene, "voxel": voxel, "failed": e.to_string()}));
                    continue;
                }
            };
            let report = json::read(&out.join("report.json").display().to_string())?;
            let size = report["resolution"]["voxel_size"]
                .as_f64()
                .unwrap_or(f64::NAN);
            auto.get_or_insert(size);
            eprintln!(
                "{scene} {voxel}: {wall:.1} s, {peak:.0} MiB, {} probes, voxel {size:.3}",
                report["probe_count"]
            );
            runs.push(json!({
                "scene": scene,
                "voxel": voxel,
                "voxel_size": size,
                "triangles": report["scene"]["triangles"],
                "wall_s": wall,
                "peak_mib": peak,
                "probes": report["probe_count"],
                "coverage": report["coverage"],
                "coverage_ci95": report["coverage_ci95"],
                "timings_ms": report["timings_ms"],
            }));
            write_runs(dir, label, bin, &runs)?;
        }
    }
    let path = write_runs(dir, label, bin, &runs)?;
    println!("{}", path.display());
    Ok(())
}

/// Writes `DIR/bench-LABEL.json` with `runs` (after every run, so that a
/// set stopped early keeps what it measured).
fn write_runs(dir: &Path, label: &str, bin: &Path, runs: &[Value]) -> Result<PathBuf> {
    let host = std::fs::read_to_string("/etc/hostname").unwrap_or_default();
    let doc = json!({
        "label": label,
        "binary": bin.display().to_string(),
        "machine": format!("{} ({} CPUs)", host.trim(), std::thread::available_parallelism().map_or(0, |n| n.get())),
        "runs": runs,
    });
    let path = dir.join(format!("bench-{label}.json"));
    std::fs::write(&path, serde_json::to_string_pretty(&doc)? + "\n")?;
    Ok(path)
}

/// Whether timing `key` is a part of a stage (`refine_fill`), not a stage.
fn is_part(key: &str) -> bool {
    key.starts_with("refine_") || key.starts_with("diffuse_")
}

/// Refinement's sweeps, fill and check rounds, in seconds, where timed.
fn refine_parts(timings: &Value) -> String {
    let s = |k: &str| timings[k].as_f64().map(|ms| format!("{:.1}", ms / 1000.0));
    match (s("refine_sweeps"), s("refine_fill"), s("refine_rounds")) {
        (Some(a), Some(b), Some(c)) => format!("{a} / {b} / {c}"),
        _ => "—".into(),
    }
}

/// The three slowest stages of a run, `name s` each.
fn slowest(timings: &Value) -> String {
    let mut stages: Vec<(&str, f64)> = timings
        .as_object()
        .map(|m| {
            m.iter()
                .filter(|(k, _)| *k != "total" && !is_part(k))
                .filter_map(|(k, v)| Some((k.as_str(), v.as_f64()?)))
                .collect()
        })
        .unwrap_or_default();
    stages.sort_by(|a, b| b.1.total_cmp(&a.1).then(a.0.cmp(b.0)));
    stages
        .iter()
        .take(3)
        .map(|(k, ms)| format!("{k} {:.1}", ms / 1000.0))
        .collect::<Vec<_>>()
        .join(", ")
}

fn table(new: &Value, before: Option<&Value>) -> String {
    let mut t = String::new();
    let label = new["label"].as_str().unwrap_or("?");
    t.push_str(&format!(
        "`{label}` ({}):\n\n| scene | triangles | voxel | probes | coverage | wall s | peak MiB | slowest stages (s) | refine: sweeps / fill / rounds (s) |",
        new["machine"].as_str().unwrap_or("?")
    ));
    if let Some(b) = before {
        t.push_str(&format!(
            " `{}` wall s | ratio |",
            b["label"].as_str().unwrap_or("?")
        ));
    }
    t.push_str("\n|---|---:|---|---:|---|---:|---:|---|---|");
    if before.is_some() {
        t.push_str("---:|---:|");
    }
    t.push('\n');
    for r in new["runs"].as_array().into_iter().flatten() {
        let f = |k: &str| r[k].as_f64().unwrap_or(f64::NAN);
        if let Some(e) = r["failed"].as_str() {
            // The row's four cells, then empty ones to the table's width.
            let width = if before.is_some() { 11 } else { 9 };
            t.push_str(&format!(
                "| {} | | {} | failed: {} |{}\n",
                r["scene"].as_str().unwrap_or("?"),
                r["voxel"].as_str().unwrap_or("?"),
                e.replace('|', "/"),
                " |".repeat(width - 4)
            ));
            continue;
        }
        t.push_str(&format!(
            "| {} | {} | {} {:.3} | {} | {:.2}% ± {:.2}% | {:.1} | {:.0} | {} | {} |",
            r["scene"].as_str().unwrap_or("?"),
            r["triangles"],
            r["voxel"].as_str().unwrap_or("?"),
            f("voxel_size"),
            r["probes"],
            100.0 * f("coverage"),
            100.0 * f("coverage_ci95"),
            f("wall_s"),
            f("peak_mib"),
            slowest(&r["timings_ms"]),
            refine_parts(&r["timings_ms"]),
        ));
        if let Some(b) = before {
            let old = b["runs"]
                .as_array()
                .into_iter()
                .flatten()
                .find(|o| o["scene"] == r["scene"] && o["voxel"] == r["voxel"]);
            match old.and_then(|o| o["wall_s"].as_f64()) {
                Some(w) => t.push_str(&format!(" {w:.1} | {:.2} |", f("wall_s") / w)),
                None => t.push_str(" — | — |"),
            }
        }
        t.push('\n');
    }
    t
}

fn main() -> Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let usage = "usage: bench_set generate DIR | run DIR LABEL [--bin PROBEPLACE] [--only NAME,...] | table NEW.json [BEFORE.json] [--write FILE]";
    let flag = |name: &str| {
        args.iter()
            .position(|a| a == name)
            .and_then(|i| args.get(i + 1))
            .cloned()
    };
    match args.first().map(String::as_str) {
        Some("generate") if args.len() == 2 => generate(Path::new(&args[1])),
        Some("run") if args.len() >= 3 => {
            let bin = match flag("--bin") {
                Some(b) => PathBuf::from(b),
                None => std::env::current_exe()?
                    .parent()
                    .and_then(Path::parent)
                    .ok_or("no binary beside this example")?
                    .join("probeplace"),
            };
            let only = flag("--only").map(|o| o.split(',').map(str::to_owned).collect());
            run(Path::new(&args[1]), &args[2], &bin, only)
        }
        Some("table") if args.len() >= 2 => {
            let new = json::read(&args[1])?;
            let before = match args.get(2).filter(|a| !a.starts_with("--")) {
                Some(b) => Some(json::read(b)?),
                None => None,
            };
            let t = table(&new, before.as_ref());
            match flag("--write") {
                Some(file) => {
                    let text =
                        std::fs::read_to_string(&file).map_err(|e| format!("{file}: {e}"))?;
                    let (begin, end) = ("<!-- bench-set:begin -->\n", "<!-- bench-set:end -->");
                    let a = text
                        .find(begin)
                        .ok_or(format!("{file}: no {}", begin.trim()))?
                        + begin.len();
                    let b = text[a..].find(end).ok_or(format!("{file}: no {end}"))? + a;
                    std::fs::write(&file, format!("{}\n{t}\n{}", &text[..a], &text[b..]))?;
                    Ok(())
                }
                None => {
                    print!("{t}");
                    Ok(())
                }
            }
        }
        _ => Err(usage.into()),
    }
}
