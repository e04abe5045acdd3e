//! The `export` job: an earlier run's probes written for other tools
//! (`report::export`: glTF, Godot, Unity, DDGI), and the
//! config's `export` list, which `place`, `bake` and `render` honour.
//!
//! `probeplace export DIR` reads DIR as `--from DIR` does (`Job::new_as`):
//! the run's config is rebuilt from its provenance and the scene hashed
//! again, so a directory whose scene or config has changed since is
//! refused in one line; `probes.json`, `svo.bin` and `report.json` must be
//! of that one run. The exports then join every file of DIR in a new
//! output set, committed whole into DIR (or `--out`), so the directory
//! still holds one run, now with its exports.

use super::outcome::Outcome;
use super::run::{Job, RunOptions};
use crate::config::{Export, Placement};
use crate::error::{Error, Result};
use crate::progress::Progress;
use crate::report::export::{self as encode, Source};
use crate::scene::Scene;
use serde_json::{json, Value};
use std::path::PathBuf;

/// An export format as the command line names it (`--format`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Format {
    /// `probes.glb`.
    Glb,
    /// `probes.tscn`.
    Tscn,
    /// `probes.unity.json`.
    Unity,
    /// `ddgi.json`.
    Ddgi,
}

/// What `probeplace export` is given.
#[derive(Debug, Clone, Default)]
pub struct ExportOptions {
    /// The earlier run's output directory.
    pub dir: PathBuf,
    /// The formats, in the order given.
    pub formats: Vec<Format>,
    /// Put the scene's triangles into `probes.glb` (`--scene`).
    pub scene: bool,
    /// Where to write (default: `dir`).
    pub out: Option<PathBuf>,
    /// Stage lines.
    pub progress: Progress,
}

impl ExportOptions {
    /// The exports asked for, each once, in order.
    fn exports(&self) -> Result<Vec<Export>> {
        if self.formats.is_empty() {
            return Err(Error::User(
                "--format: name at least one of glb, tscn, unity, ddgi".into(),
            ));
        }
        if self.scene && !self.formats.contains(&Format::Glb) {
            return Err(Error::User(
                "--scene: only the glb export holds the scene mesh; add glb to --format".into(),
            ));
        }
        let mut out = Vec::new();
        for f in &self.formats {
            let e = match f {
                Format::Glb if self.scene => Export::GlbWithScene,
                Format::Glb => Export::Glb,
                Format::Tscn => Export::Tscn,
                Format::Unity => Export::Unity,
                Format::Ddgi => Export::Ddgi,
            };
            if !out.contains(&e) {
                out.push(e);
            }
        }
        Ok(out)
    }
}

/// Runs `probeplace export`.
///
/// Contract: on success the output directory holds every file of `dir`
/// and the exports asked for (replacing earlier exports of the same
/// names); `Outcome::report` lists them under `exports`. A directory that
/// is not a `place`, `bake` or `render` output, whose files are not of one
/// run, or whose scene or config changed since, a `ddgi` of a placement
/// that is not an unrefined grid, and `--scene` without `glb` are user
/// errors; on error nothing changes.
pub fn export(options: &ExportOptions) -> Result<Outcome> {
    let exports = options.exports()?;
    let run = RunOptions {
        from: Some(options.dir.clone()),
        out: options.out.clone(),
        progress: options.progress,
        ..RunOptions::default()
    };
    let mut job = Job::new_as(&run, "export")?;
    let dir = options.dir.clone();
    let earlier = job.earlier.as_ref().expect("export reads an earlier run");
    let Some(report) = earlier.report.clone() else {
        return Err(Error::user_file(
            &dir,
            "export: holds a compare run, which keeps no probe set of its own; export a place, bake or render output",
        ));
    };
    let read = |name: &str| -> Result<Vec<u8>> {
        let path = dir.join(name);
        if !path.is_file() {
            return Err(Error::user_file(
                &path,
                "missing, though report.json is there: the directory holds part of a run (run the job again)",
            ));
        }
        crate::input::read(&path, name, crate::limits::memory_budget())
    };
    let (probes, svo) = (read("probes.json")?, read("svo.bin")?);
    let sh = match dir.join(crate::report::sh::SH_FILE).is_file() {
        true => Some(read(crate::report::sh::SH_FILE)?),
        false => None,
    };
    let source = Source::read(&probes, &report, &svo)
        .and_then(|s| s.with_light(sh.as_deref()))
        .map_err(|m| match m.split_once(": ") {
            Some((file, why)) => Error::user_file(&dir.join(file), why),
            None => Error::user_file(&dir, m),
        })?;
    if exports.contains(&Export::Ddgi) && !encode::ddgi::has_volume(&source.method) {
        // Before the scene is read: the cheap refusal first.
        let why = encode::ddgi::encode(&source).err().unwrap_or_default();
        return Err(refusal(&dir, Export::Ddgi, &why));
    }
    let scene = match exports.contains(&Export::GlbWithScene) {
        true => Some(job.watch.try_time("load", || {
            crate::scene::load_obj(&job.config.scene, job.config.scale.0, job.config.up)
        })?),
        false => None,
    };
    // The run's files as its manifest lists them (checked when the job
    // opened the directory), not whatever else lies there.
    let names: Vec<String> = earlier.manifest.files.keys().cloned().collect();
    let names: Vec<&str> = names.iter().map(String::as_str).collect();
    job.carry(&names);
    let written =
        add(&mut job, &exports, &source, scene.as_ref()).map_err(|(e, m)| refusal(&dir, e, &m))?;
    crate::output::commit::commit(&job.out_dir, &job.set, &job.inputs)?;
    let summary = vec![format!(
        "exported {} probes of {}: {}",
        source.probes.len(),
        source.method,
        written
            .iter()
            .map(|(name, bytes)| format!("{name} ({})", size(*bytes)))
            .collect::<Vec<_>>()
            .join(", ")
    )];
    Ok(Outcome {
        out_dir: job.out_dir.clone(),
        report: json!({
            "exports": written.iter().map(|(n, _)| *n).collect::<Vec<_>>(),
            "warnings": Value::Array(Vec::new()),
            "timings_ms": { "total": job.watch.elapsed_ms() },
        }),
        summary,
    })
}

/// The input files of the run an error may name.
const INPUTS: [&str; 3] = ["probes.json", "report.json", "svo.bin"];

/// A user error about the run in `dir`: `message` is led by the name of
/// the file at fault (`probes.json: …`), which then leads the line as a
/// path, or else is the reason `export` could not be written.
fn refusal(dir: &std::path::Path, export: Export, message: &str) -> Error {
    match message.split_once(": ") {
        Some((file, why)) if INPUTS.contains(&file) => Error::user_file(&dir.join(file), why),
        _ => Error::user_file(dir, format!("--format {}: {message}", format_name(export))),
    }
}

/// `n` bytes, short.
fn size(n: usize) -> String {
    match n {
        n if n >= 1 << 20 => format!("{:.1} MB", n as f64 / 1e6),
        n if n >= 1 << 10 => format!("{:.1} kB", n as f64 / 1e3),
        n => format!("{n} B"),
    }
}

/// Encodes `exports` of `source` into the job's set; returns each file's
/// name and size. The error is the export that failed and its reason.
fn add(
    job: &mut Job,
    exports: &[Export],
    source: &Source,
    scene: Option<&Scene>,
) -> std::result::Result<Vec<(&'static str, usize)>, (Export, String)> {
    let started = std::time::Instant::now();
    let mut written = Vec::new();
    for &e in exports {
        let bytes = encode::encode(e, source, scene).map_err(|m| (e, m))?;
        let name = encode::file_name(e);
        written.push((name, bytes.len()));
        job.set.add(name, bytes);
    }
    job.watch
        .record("export", started.elapsed().as_secs_f64() * 1e3);
    Ok(written)
}

/// The `--format` word of `e`.
fn format_name(e: Export) -> &'static str {
    match e {
        Export::Glb | Export::GlbWithScene => "glb",
        Export::Tscn => "tscn",
        Export::Unity => "unity",
        Export::Ddgi => "ddgi",
    }
}

/// Refuses, before any stage, a config whose `export` list the run cannot
/// write: `Ddgi` needs a `Grid` or `Relocated` placement without
/// refinement, whose probes stay in their cells.
pub(crate) fn check_configured(job: &Job) -> Result<()> {
    let c = &job.config;
    let grid = matches!(c.placement, Placement::Grid(_) | Placement::Relocated(_));
    let controlled = !c.fixed_probes.is_empty() || !c.exclude.is_empty() || c.max_probes.is_some();
    let plain =
        grid && !c.refine.enabled && !controlled && job.provenance.overrides.probes.is_none();
    if c.export.contains(&Export::Ddgi) && !plain {
        let why = if grid && controlled {
            "fixed_probes, exclude and max_probes add probes to the grid or take cells from it"
        } else if grid {
            "refinement moves, adds and removes probes (set refine: (enabled: false), or --no-refine)"
        } else {
            "this run places by another method"
        };
        return Err(job.config_error(Error::User(format!(
            "export: Ddgi needs a Grid or Relocated placement whose probes stay in their cells; {why}"
        ))));
    }
    Ok(())
}

/// Adds the config's exports to `job`'s set, computed from the set's own
/// `probes.json` and `svo.bin` and the run's `report` (so they equal what
/// `probeplace export` gives on the committed directory); `scene` is the
/// run's, for [`Export::GlbWithScene`].
pub(crate) fn add_configured(job: &mut Job, report: &Value, scene: &Scene) -> Result<()> {
    if job.config.export.is_empty() {
        return Ok(());
    }
    let missing = |name: &str| Error::Internal(format!("export: the run wrote no {name}"));
    let probes = job
        .set
        .contents("probes.json")?
        .ok_or_else(|| missing("probes.json"))?;
    let svo = job
        .set
        .contents("svo.bin")?
        .ok_or_else(|| missing("svo.bin"))?;
    let sh = job.set.contents(crate::report::sh::SH_FILE)?;
    let source = Source::read(&probes, report, &svo)
        .and_then(|s| s.with_light(sh.as_deref()))
        .map_err(Error::Internal)?;
    let exports = job.config.export.clone();
    add(job, &exports, &source, Some(scene))
        .map(|_| ())
        .map_err(|(e, m)| job.config_error(Error::User(format!("export: {e:?}: {m}"))))
}
