//! What every job shares: its options, the run it belongs to (config,
//! provenance, output set), the earlier run it reuses (`--from`), and its
//! outcome.

use super::outcome::Outcome;
use super::split;
use crate::config::{Config, GridParams, Placement};
use crate::error::{Error, Result};
use crate::output::commit::{self, OutputSet};
use crate::output::manifest;
use crate::page::figures::RunFigures;
use crate::page::view3d::View3d;
use crate::progress::{Progress, Stopwatch};
use crate::provenance::{self, Overrides, Provenance};
use crate::stages::{self, Prepared};
use serde_json::Value;
use std::path::{Path, PathBuf};

/// What the command line gives a job.
#[derive(Debug, Clone, Default)]
pub struct RunOptions {
    /// The RON config; `None` with `from`: the config the earlier run used.
    pub config: Option<PathBuf>,
    /// A config already loaded from `config` and changed by the caller (a
    /// sweep, a test), run instead of the file's. Its changes enter the
    /// config hash, so `--from` on its outputs with the file alone is
    /// refused.
    pub loaded: Option<Config>,
    /// An earlier run's output directory to reuse (`--from`).
    pub from: Option<PathBuf>,
    /// Output directory instead of the config's `output` (default with
    /// `from`: that directory).
    pub out: Option<PathBuf>,
    /// The command line's changes to the config.
    pub overrides: Overrides,
    /// Progress bars and stage lines.
    pub progress: Progress,
    /// Trace on the CPU twin even where a GPU adapter exists.
    pub cpu: bool,
    /// `render`'s variants, in order (empty: both).
    pub variants: Vec<Variant>,
    /// `compare`'s grids instead of the config's (or the sweep).
    pub grids: Option<Vec<GridParams>>,
    /// `compare`'s benchmarks: both, or the one named (`--only`).
    pub benchmarks: Benchmarks,
}

/// Which of `compare`'s benchmarks run.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum Benchmarks {
    /// The diffuse benchmark and the glossy one.
    #[default]
    Both,
    /// Diffuse light as engines blend probes, on the scene's own materials.
    Diffuse,
    /// Glossy light through our light-field tracer, on `compare.materials`.
    Glossy,
}

impl Benchmarks {
    /// Whether the diffuse benchmark runs.
    pub fn diffuse(self) -> bool {
        self != Benchmarks::Glossy
    }

    /// Whether the glossy benchmark runs.
    pub fn glossy(self) -> bool {
        self != Benchmarks::Diffuse
    }
}

/// An earlier run's output directory (`--from`).
pub(crate) struct Earlier {
    /// The directory.
    pub dir: PathBuf,
    /// Its provenance.
    pub provenance: Provenance,
    /// Its `report.json`; `None` when it holds a `compare` run only.
    pub report: Option<Value>,
    /// Its `manifest.json`, every file checked against it.
    pub manifest: manifest::Manifest,
}

impl Earlier {
    /// Reads the provenance of the run in `dir`; messages start with
    /// `label`, how the command line named the directory (`--from`).
    fn open(dir: &Path, label: &str) -> Result<Earlier> {
        if !dir.is_dir() {
            return Err(Error::user_file(
                dir,
                format!("{label}: no such output directory"),
            ));
        }
        let read = |name: &str| -> Option<Value> {
            serde_json::from_slice(
                &crate::input::read(&dir.join(name), name, crate::limits::memory_budget()).ok()?,
            )
            .ok()
        };
        let report = read("report.json");
        let main = report
            .clone()
            .or_else(|| read("compare.json"))
            .ok_or_else(|| {
                Error::user_file(
                    dir,
                    format!("{label}: holds no report.json or compare.json of probeplace"),
                )
            })?;
        let provenance: Provenance = serde_json::from_value(main["provenance"].clone()).map_err(|_| {
            Error::user_file(
                dir,
                format!("{label}: its report has no provenance (written by an older probeplace); run it again"),
            )
        })?;
        let manifest = manifest::verify(dir, "run the earlier job again")?;
        if manifest.provenance.as_ref() != Some(&crate::provenance::Stamp::of(&provenance)) {
            return Err(Error::user_file(
                &dir.join(manifest::NAME),
                format!("{label}: records another run than the report beside it; run the earlier job again"),
            ));
        }
        Ok(Earlier {
            dir: dir.to_path_buf(),
            provenance,
            report,
            manifest,
        })
    }

    /// Whether the directory holds `name` as a file of its run (listed in
    /// its manifest, and checked against it): a file put there since is
    /// never reused.
    pub fn has(&self, name: &str) -> bool {
        self.manifest.lists(name)
    }

    /// `name` in the directory.
    pub fn path(&self, name: &str) -> PathBuf {
        self.dir.join(name)
    }
}

/// A job under way: its config, provenance, destination and output set.
pub(crate) struct Job {
    /// The config as run (overrides applied).
    pub config: Config,
    /// The config file, for messages and the report.
    pub config_path: PathBuf,
    /// The placement the config file's text gives, before `--method`: a
    /// placement error points at its line only when that one ran.
    pub written_placement: Option<Placement>,
    /// What ties the outputs together.
    pub provenance: Provenance,
    /// Where the outputs go.
    pub out_dir: PathBuf,
    /// The output directory, checked and locked for this run.
    pub claim: commit::Claim,
    /// The run reused, when `--from` was given.
    pub earlier: Option<Earlier>,
    /// Bars and stage lines.
    pub progress: Progress,
    /// The job's stage times.
    pub watch: Stopwatch,
    /// The files to commit.
    pub set: OutputSet,
    /// Names of the files reused from `earlier`.
    pub reused: Vec<String>,
    /// Trace on the CPU twin.
    pub cpu: bool,
    /// The world positions and cluster sizes of `--probes`, read (and
    /// checked) before any stage.
    pub given: Option<Vec<(glam::DVec3, u32)>>,
}

impl Job {
    /// Resolves the config (the given one, or the earlier run's), applies
    /// the overrides, and checks the destination and the earlier run
    /// before any expensive stage.
    pub fn new(options: &RunOptions) -> Result<Job> {
        Job::new_as(options, "--from")
    }

    /// [`Job::new`] whose messages about the earlier run start with
    /// `label`, how the command line named its directory.
    pub fn new_as(options: &RunOptions, label: &str) -> Result<Job> {
        let earlier = options
            .from
            .as_deref()
            .map(|d| Earlier::open(d, label))
            .transpose()?;
        let (config_path, text, mut overrides) = match (&options.config, &earlier) {
            (Some(path), _) => {
                let text =
                    crate::input::read_text(path, "config", crate::config::MAX_CONFIG_BYTES)?;
                (path.clone(), text, Overrides::default())
            }
            (None, Some(e)) => (
                reload_path(&e.provenance),
                e.provenance.config_text.clone(),
                e.provenance.overrides.clone(),
            ),
            (None, None) => {
                return Err(Error::User(
                    "no config given: name a config file, or an earlier run with --from DIR".into(),
                ))
            }
        };
        merge_overrides(&mut overrides, &options.overrides)?;
        let mut config = match &options.loaded {
            Some(c) => c.clone(),
            None => Config::from_text(&text, &config_path)?,
        };
        let written_placement = match &options.loaded {
            Some(_) => Config::parse(&text, &config_path).ok().map(|c| c.placement),
            None => Some(config.placement),
        };
        apply(&mut config, &overrides)?;
        let files = provenance::inputs::input_files(&config, &overrides);
        let provenance = Provenance::of_files(&config, &config_path, &text, &overrides, &files)?;
        // A `--probes` file that is not ours, or not probes, is refused here,
        // before the first stage, not after the scene's SDF and coverage.
        let given = match &overrides.probes {
            Some(path) => Some(crate::placement::file::read_world(path)?),
            None => None,
        };
        if let Some(e) = &earlier {
            if let Some(why) = provenance.mismatch(&e.provenance) {
                return Err(Error::user_file(
                    &e.dir,
                    format!("{label}: {why}; its outputs cannot be reused by this run"),
                ));
            }
        }
        let out_dir = match (&options.out, &earlier) {
            (Some(o), _) if o.as_os_str().is_empty() => {
                return Err(Error::User("--out: must not be empty".into()))
            }
            (Some(o), _) => o.clone(),
            (None, Some(e)) => e.dir.clone(),
            (None, None) => config.output.clone(),
        };
        let mut inputs = vec![config_path.clone()];
        inputs.extend(files.into_iter().map(|f| f.path));
        if let Some(e) = &earlier {
            commit::check_apart(&e.dir, &out_dir, label)?;
        }
        split::check_outside_tiles(&out_dir, Some(&config_path))?;
        let claim = commit::claim(&out_dir, &inputs)?;
        let set = OutputSet::of(&provenance);
        Ok(Job {
            config,
            config_path,
            written_placement,
            provenance,
            out_dir,
            claim,
            earlier,
            progress: options.progress,
            watch: options.progress.stopwatch(),
            set,
            reused: Vec::new(),
            cpu: options.cpu,
            given,
        })
    }

    /// The `--probes` set in `scene`'s coordinates, `None` without one.
    pub fn given_probes(
        &self,
        scene: &crate::scene::Scene,
    ) -> Result<Option<crate::probes::ProbeSet>> {
        match (&self.given, &self.provenance.overrides.probes) {
            (Some(world), Some(path)) => Ok(Some(crate::placement::file::from_world(
                world, path, scene, "file",
            )?)),
            _ => Ok(None),
        }
    }

    /// The stages before placement, timed.
    pub fn prepare(&mut self) -> Result<Prepared> {
        let prepared = stages::prepare(
            &self.config,
            &self.config_path,
            &self.provenance.config_text,
            &self.progress,
        )?;
        self.watch.absorb(&prepared.timings);
        Ok(prepared)
    }

    /// `e`, an error of a stage that names a config field, prefixed with
    /// the config file and, where the file writes the field, its line and
    /// column ([`Error::in_config`]).
    pub fn config_error(&self, e: Error) -> Error {
        self.config_error_of(e, &self.config.placement)
    }

    /// [`Job::config_error`] of a stage that ran `placement`. A placement
    /// error gets the file alone, no line, when that placement is not the
    /// file's (another `--method`, or a job that runs other methods too):
    /// the line would point at a method that did not run.
    pub fn config_error_of(&self, e: Error, placement: &Placement) -> Error {
        let written = self.written_placement.as_ref() == Some(placement);
        match e {
            Error::User(m) if !written && m.starts_with("placement") => {
                Error::User(m).in_file(&self.config_path)
            }
            e => e.in_config(&self.config_path, &self.provenance.config_text),
        }
    }

    /// Carries `names` of the earlier run (those it has) into the set.
    pub fn carry(&mut self, names: &[&str]) {
        let Some(e) = &self.earlier else { return };
        for name in names {
            if let (Some(entry), Some(id)) =
                (e.manifest.files.get(*name), e.manifest.seen.get(*name))
            {
                self.set
                    .carry_checked(*name, e.path(name), entry.clone(), *id);
                if !self.reused.iter().any(|r| r == name) {
                    self.reused.push(name.to_string());
                }
            }
        }
    }

    /// Finishes `report` (timings, what was reused) as `name` and commits
    /// the whole set, `summary` the lines the command line prints.
    pub fn finish_with(
        self,
        name: &str,
        mut report: Value,
        summary: Vec<String>,
    ) -> Result<Outcome> {
        self.stamp(&mut report);
        self.write(name, report, summary)
    }

    /// Finishes a run's `report` (`place`, `bake`, `render`) as
    /// `report.json`, writes `report.html` beside it (its figures, read
    /// once, the images of the set, and the 3D view `view` makes of the
    /// figures), and commits the whole set.
    pub fn finish_run(
        mut self,
        mut report: Value,
        view: impl FnOnce(&RunFigures) -> View3d,
    ) -> Result<Outcome> {
        self.stamp(&mut report);
        let figures =
            RunFigures::read(&report).map_err(|m| Error::Internal(format!("report.json: {m}")))?;
        let page = crate::page::run_html::page(&figures, &self.set, &view(&figures))?;
        self.set.add("report.html", page.into_bytes());
        let summary = summary(&report);
        self.write("report.json", report, summary)
    }

    /// Sets the report's `timings_ms` (this run's stages only: what it
    /// reused took no time) and `reused`.
    fn stamp(&self, report: &mut Value) {
        let mut timings = serde_json::Map::new();
        for (k, v) in self.watch.to_map() {
            timings.insert(k, v.into());
        }
        timings.insert("total".into(), self.watch.elapsed_ms().into());
        report["timings_ms"] = Value::Object(timings);
        report["reused"] = self.reused.clone().into();
    }

    /// Adds `report` as `name` and commits the set.
    fn write(mut self, name: &str, report: Value, summary: Vec<String>) -> Result<Outcome> {
        self.set.add(name, crate::encode::json::to_json(&report)?);
        commit::commit(&self.claim, &self.set)?;
        Ok(Outcome {
            out_dir: self.out_dir,
            report,
            summary,
        })
    }
}

/// The config path to reload a run from: as it was given when run from
/// the same directory (so reports name it alike), else made absolute.
fn reload_path(p: &Provenance) -> PathBuf {
    let given = &p.config_given;
    if given.is_absolute() || std::env::current_dir().ok().as_deref() == Some(p.cwd.as_path()) {
        given.clone()
    } else {
        p.cwd.join(given)
    }
}

/// Lays the command line's `new` overrides over the earlier run's `base`.
fn merge_overrides(base: &mut Overrides, new: &Overrides) -> Result<()> {
    if new.method.is_some() {
        base.method = new.method.clone();
    }
    if new.seed.is_some() {
        base.seed = new.seed;
    }
    base.no_refine |= new.no_refine;
    if let Some(p) = &new.probes {
        let abs = std::path::absolute(p).map_err(|e| Error::user_file(p, e))?;
        base.probes = Some(abs);
    }
    Ok(())
}

/// Applies `overrides` to `config`.
fn apply(config: &mut Config, overrides: &Overrides) -> Result<()> {
    if let Some(m) = &overrides.method {
        config.placement = Placement::parse_cli(m, &config.placement)?;
    }
    if let Some(s) = overrides.seed {
        config.seed = s;
    }
    if overrides.no_refine {
        config.refine.enabled = false;
    }
    Ok(())
}

/// Appends `warnings` to the report's `warnings`.
pub(crate) fn push_warnings(report: &mut Value, warnings: &[String]) {
    if let Some(a) = report["warnings"].as_array_mut() {
        a.extend(warnings.iter().map(|w| Value::String(w.clone())));
    }
}

/// The summary line of a `report.json`: the placement, and what the bake
/// and the render found when they ran.
fn summary(r: &Value) -> Vec<String> {
    let f = |v: &Value| v.as_f64().unwrap_or(f64::NAN);
    // The validation figure first; the training score, when one was
    // fitted, beside it.
    let train = r["coverage_train"]
        .as_f64()
        .map_or(String::new(), |t| format!(" (training {:.2}%)", 100.0 * t));
    // What the diffuse step did, beside the count: coverage's probes in,
    // and the held-out error of the blended diffuse light it lowered.
    let d = &r["diffuse"];
    let diffuse = match (
        d["probes_before"].as_u64(),
        d["validation_before"].as_f64(),
        d["validation_after"].as_f64(),
    ) {
        (Some(n), Some(a), Some(b)) => format!(
            " ({n} for coverage; diffuse error {:.0}% → {:.0}% held out)",
            100.0 * a,
            100.0 * b
        ),
        _ => String::new(),
    };
    let mut line = format!(
        "{}: {} probes{diffuse}, coverage {:.2}% ± {:.2}% on unseen samples{train}, {} in solid, {} near surfaces; voxel {:.4} ({})",
        r["method"].as_str().unwrap_or("?"),
        r["probe_count"],
        100.0 * f(&r["coverage"]),
        100.0 * f(&r["coverage_ci95"]),
        r["probes_in_solid"],
        r["probes_below_clearance"],
        f(&r["sdf"]["voxel_size"]),
        r["resolution"]["source"].as_str().unwrap_or("config"),
    );
    // What the scene's textures came to, where its materials name any.
    if let Some(t) = r["scene"]["textures"].as_array().filter(|t| !t.is_empty()) {
        let read = t.iter().filter(|t| t["missing"].is_null()).count();
        line += &format!("; textures: {read} of {} read", t.len());
    }
    let b = &r["bake"];
    if b.is_object() {
        let seen = f(&b["tracer"]["seen"]);
        let rate = if seen > 0.0 {
            f(&b["tracer"]["agree"]) / seen
        } else {
            1.0
        };
        line += &format!(
            "; baked at {}² ({:.1} MB), tracer agrees with ray casts on {:.2}% of seen hits",
            b["resolution"],
            f(&b["bytes"]) / 1e6,
            100.0 * rate
        );
    }
    let x = &r["render"];
    if let Some(variants) = x["variants"].as_object() {
        let parts: Vec<String> = variants
            .iter()
            .map(|(name, v)| {
                let ms = v["gpu_ms"]
                    .as_f64()
                    .map_or(String::new(), |ms| format!(", {ms:.1} ms"));
                format!(
                    "{name} mse_glossy {:.3e}, {:.1} texel fetches/ray{ms}",
                    f(&v["mse_glossy"]),
                    f(&v["texel_fetches_per_ray"])
                )
            })
            .collect();
        line += &format!(
            "; rendered {}×{} on {}: {}",
            x["width"],
            x["height"],
            x["adapter"].as_str().unwrap_or("?"),
            parts.join("; ")
        );
    }
    vec![line]
}

/// The marches `render` can run (`--variant`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Variant {
    /// McGuire et al. 2017 §4.1: bi-level march, grid selection where the
    /// probes form a grid (else the SVO's).
    BiLevel,
    /// Wang et al. 2019 §4.2: Hi-Z march, SVO selection.
    HiZ,
}

impl Variant {
    /// The name in file names and the report.
    pub fn name(self) -> &'static str {
        match self {
            Variant::BiLevel => "bilevel",
            Variant::HiZ => "hiz",
        }
    }
}
