//! The `export` job: an earlier run's probes written for other tools
//! (the formats of `export::registry`: glTF, Godot, Unity, DDGI), and the
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
use crate::error::{Error, Result};
use crate::export::format::{words, Planned};
use crate::export::{Export, Source, FORMATS};
use crate::progress::Progress;
use crate::scene::Scene;
use serde_json::{json, Value};
use std::path::PathBuf;

/// The formats `--format` names: each word once, in the list's order,
/// with the file it writes and what that is for (the first format of the
/// word, the one without the scene).
pub fn formats() -> Vec<(&'static str, &'static str, &'static str)> {
    words(FORMATS)
        .into_iter()
        .filter_map(|w| FORMATS.iter().find(|f| f.word == w))
        .map(|f| (f.word, f.file, f.about))
        .collect()
}

/// What `probeplace export` is given.
#[derive(Debug, Clone, Default)]
pub struct ExportOptions {
    /// The earlier run's output directory.
    pub dir: PathBuf,
    /// The formats by their `--format` words (`export::FORMATS`), in the order
    /// given.
    pub formats: Vec<String>,
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
        let words = words(FORMATS);
        if self.formats.is_empty() {
            return Err(Error::User(format!(
                "--format: name at least one of {}",
                words.join(", ")
            )));
        }
        let mut out = Vec::new();
        for word in &self.formats {
            let e = Export::of_word(word, self.scene).ok_or_else(|| {
                Error::User(format!(
                    "--format {word}: unknown format; expected one of {}",
                    words.join(", ")
                ))
            })?;
            if !out.contains(&e) {
                out.push(e);
            }
        }
        if self.scene && !out.iter().any(|e| e.entry().scene) {
            let holders: Vec<&str> = FORMATS.iter().filter(|f| f.scene).map(|f| f.word).collect();
            let holders = holders.join(", ");
            return Err(Error::User(format!(
                "--scene: only the {holders} export holds the scene mesh; add {holders} to --format"
            )));
        }
        Ok(out)
    }
}

/// Runs `probeplace export`.
///
/// Contract: on success the output directory holds every file of `dir`
/// and the exports asked for (replacing earlier exports of the same
/// names); `Outcome::report` lists them under `exports`. A format the run
/// cannot give (a `ddgi` of a placement that is not an unrefined grid)
/// among others that it can is left out, decided before anything is
/// written, with a warning in `Outcome::report`'s `warnings`. A directory that is not a `place`, `bake` or
/// `render` output, whose files are not of one run, or whose scene or
/// config changed since, only formats it cannot give, and `--scene`
/// without `glb` are user errors; on error nothing changes.
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
    // Before the scene is read, and before anything is written: the
    // formats this run cannot give (a DDGI volume of a placement that is
    // no grid). Alone they are refused; among others they are left out,
    // each said in one warning line, and the others written.
    let (exports, refused): (Vec<Export>, Vec<(Export, String)>) = {
        let mut ok = Vec::new();
        let mut no = Vec::new();
        for &e in &exports {
            match e.refuses(&source) {
                Some(why) => no.push((e, why)),
                None => ok.push(e),
            }
        }
        (ok, no)
    };
    if exports.is_empty() {
        let (e, why) = &refused[0];
        return Err(refusal(&dir, *e, why));
    }
    let warnings: Vec<String> = refused
        .iter()
        .map(|(e, why)| format!("--format {}: not written: {why}", e.entry().word))
        .collect();
    let scene = match exports.iter().any(|e| e.entry().scene) {
        true => Some(job.watch.try_time("load", || {
            crate::scene::load(&job.config.scene, job.config.scale.0, job.config.up)
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
    crate::output::commit::commit(&job.claim, &job.set)?;
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
            "warnings": warnings,
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
        _ => Error::user_file(dir, format!("--format {}: {message}", export.entry().word)),
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
        let bytes = e.encode(source, scene).map_err(|m| (e, m))?;
        let name = e.entry().file;
        written.push((name, bytes.len()));
        job.set.add(name, bytes);
    }
    job.watch
        .record("export", started.elapsed().as_secs_f64() * 1e3);
    Ok(written)
}

/// Refuses, before any stage, a config whose `export` list the run cannot
/// write ([`crate::export::format::Format::refuses_plan`]: a DDGI volume
/// needs a grid whose probes stay in their cells).
pub(crate) fn check_configured(job: &Job) -> Result<()> {
    let c = &job.config;
    let plan = Planned {
        placement: &c.placement,
        refined: c.refine.enabled,
        controlled: !c.fixed_probes.is_empty() || !c.exclude.is_empty() || c.max_probes.is_some(),
        probes_file: job.provenance.overrides.probes.is_some(),
    };
    for &e in &c.export {
        if let Some(why) = e.refuses_plan(&plan) {
            return Err(job.config_error(Error::User(format!("export: {e:?} {why}"))));
        }
    }
    Ok(())
}

/// Adds the config's exports to `job`'s set, computed from the set's own
/// `probes.json` and `svo.bin` and the run's `report` (so they equal what
/// `probeplace export` gives on the committed directory); `scene` is the
/// run's, for the formats that hold it.
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
