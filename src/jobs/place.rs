//! The `place` job: prepare → coverage reference → place (placement,
//! refinement, coverage, SVO) → outputs; and the placement part of every
//! later job, computed or loaded from `--from DIR`.

use super::outcome::Outcome;
use super::run::{Job, RunOptions};
use crate::coverage::CoverageReference;
use crate::error::{Error, Result};
use crate::placement::{self, ProbeSet};
use crate::report::{
    self, hole_sample, BoundsRecord, ProbesFile, ReachRecord, Report, SceneRecord, FORMAT_VERSION,
};
use crate::stages::{self, Placed, Prepared};
use crate::svo::{self, Svo, SvoReport};
use serde_json::Value;

/// The files of a placement, carried together when reused.
pub(crate) const FILES: [&str; 4] = ["probes.json", "svo.bin", "placement.png", "atlas.png"];

/// Runs `probeplace place`.
///
/// Contract: on success the output directory holds exactly `probes.json`,
/// `svo.bin`, `placement.png`, `report.json`, `report.html` and (refined)
/// `atlas.png`, all of one provenance; on any error it is as it was. User mistakes come back
/// as [`Error::User`] naming the file or field.
pub fn place(options: &RunOptions) -> Result<Outcome> {
    compute(options)?.commit()
}

/// A placement computed but not yet written: what `place` writes and what
/// a caller (a sweep, a test) reads before committing it. It holds its
/// output directory's claim (the lock every run takes on it) until it is
/// committed or dropped: another run into that directory meanwhile is
/// refused.
pub struct PlaceRun {
    pub(crate) job: Job,
    /// Scene, domain, BVH and SDF.
    pub prepared: Prepared,
    /// The coverage measure the run was scored by.
    pub reference: CoverageReference,
    /// The probes placed.
    pub probes: ProbeSet,
    /// Their octree of probe indices.
    pub svo: Svo,
    /// `report.json` as it will be written (timings aside).
    pub report: Report,
}

impl PlaceRun {
    /// The config as run (overrides applied).
    pub fn config(&self) -> &crate::config::Config {
        &self.job.config
    }

    /// Writes the run's outputs as one set.
    pub fn commit(mut self) -> Result<Outcome> {
        let value = to_value(&self.report)?;
        super::export::add_configured(&mut self.job, &value, &self.prepared.scene)?;
        let (prepared, probes, svo) = (&self.prepared, &self.probes, &self.svo);
        self.job
            .finish_run(value, |figures| view(prepared, figures, probes, svo))
    }
}

/// Runs every stage of `place` without writing anything.
pub fn compute(options: &RunOptions) -> Result<PlaceRun> {
    let mut job = Job::new(options)?;
    super::export::check_configured(&job)?;
    let prepared = job.prepare()?;
    let (reference, placed) = compute_placed(&mut job, &prepared)?;
    let (probes, svo, report) = encode(&mut job, &prepared, placed)?;
    Ok(PlaceRun {
        job,
        prepared,
        reference,
        probes,
        svo,
        report,
    })
}

/// The 3D view of `report.html` for the placement `probes` (with its
/// `svo`, in the scene's frame) whose report reads as `figures`.
pub(crate) fn view(
    prepared: &Prepared,
    figures: &crate::page::figures::RunFigures,
    probes: &ProbeSet,
    svo: &Svo,
) -> crate::page::view3d::View3d {
    crate::page::run_html::view(
        &prepared.scene,
        &prepared.domain,
        &prepared.sdf,
        figures,
        &probes.positions(),
        svo,
    )
}

/// The placement a later job builds on.
pub(crate) struct BasePlacement {
    /// The probes.
    pub probes: ProbeSet,
    /// Their SVO, in the scene's frame.
    pub svo: Svo,
    /// `report.json` so far.
    pub report: Value,
}

impl BasePlacement {
    /// Finishes the run of a job built on this placement (`bake`,
    /// `render`): its `report.json`, and `report.html` with the 3D view.
    pub fn finish(self, job: Job, prepared: &Prepared) -> Result<Outcome> {
        let (probes, svo) = (&self.probes, &self.svo);
        job.finish_run(self.report, |figures| view(prepared, figures, probes, svo))
    }
}

/// The placement of `job`: loaded from `--from DIR` when that holds one,
/// else computed; its files join the job's output set either way.
pub(crate) fn placement(job: &mut Job, prepared: &Prepared) -> Result<BasePlacement> {
    if let Some(loaded) = load(job, prepared)? {
        return Ok(loaded);
    }
    let (_, placed) = compute_placed(job, prepared)?;
    let (probes, svo, report) = encode(job, prepared, placed)?;
    Ok(BasePlacement {
        probes,
        svo,
        report: to_value(&report)?,
    })
}

/// The coverage reference and the place stage, timed.
fn compute_placed(job: &mut Job, prepared: &Prepared) -> Result<(CoverageReference, Placed)> {
    let config = &job.config;
    let progress = job.progress;
    let reference = job.watch.time("coverage_reference", || {
        prepared.coverage_reference(
            &config.coverage,
            crate::coverage::Stream::Validation,
            config.seed,
            &progress,
        )
    });
    let given = job.given_probes(&prepared.scene)?;
    let placed = stages::place(config, prepared, &reference, given, &progress)
        .map_err(|e| job.config_error(e))?;
    job.watch.absorb(&placed.timings);
    Ok((reference, placed))
}

/// Adds the placement's files to the job's set and builds its report.
fn encode(job: &mut Job, prepared: &Prepared, placed: Placed) -> Result<(ProbeSet, Svo, Report)> {
    let scene_name = job.config.scene.display().to_string();
    let png = job.watch.time("preview", || {
        let image = report::placement_views(
            &prepared.scene,
            &prepared.domain,
            &placed.probes.positions(),
            &placed.holes,
            report::PREVIEW_VIEW_SIZE,
        );
        crate::encode::png::encode_png(&image, "placement.png")
    })?;
    let probes_file = ProbesFile::new(
        &placed.probes,
        &prepared.scene,
        &prepared.sdf,
        &scene_name,
        &job.config,
        &job.provenance,
    );
    let report = assemble_report(job, prepared, &placed, placed.svo.1.clone());
    let (mut svo, _) = placed.svo;
    svo.provenance = job.provenance.to_bytes();
    job.set
        .add("probes.json", crate::encode::json::to_json(&probes_file)?);
    job.set.add("svo.bin", svo.to_bytes());
    job.set.add("placement.png", png);
    if let Some((_, atlas)) = &placed.refined {
        job.set.add(
            "atlas.png",
            crate::encode::png::encode_png(atlas, "atlas.png")?,
        );
    }
    Ok((placed.probes, svo, report))
}

/// The placement `--from DIR` holds, checked and moved into the scene's
/// frame; `None` without `--from` or when the directory holds none.
pub(crate) fn load(job: &mut Job, prepared: &Prepared) -> Result<Option<BasePlacement>> {
    let Some(e) = &job.earlier else {
        return Ok(None);
    };
    let (Some(report), true, true) = (&e.report, e.has("probes.json"), e.has("svo.bin")) else {
        return Ok(None);
    };
    // The page reads the report's figures when this job finishes: a report
    // they do not read from is refused now, before any stage runs.
    crate::page::figures::RunFigures::read(report)
        .map_err(|m| Error::user_file(&e.path("report.json"), m))?;
    let probes_path = e.path("probes.json");
    let method = report["method"].as_str().unwrap_or("file").to_string();
    let probes = placement::file::read(&probes_path, &prepared.scene, &method)?;
    let probes_json: Value = serde_json::from_slice(&crate::input::read(
        &probes_path,
        "probes.json",
        crate::limits::memory_budget(),
    )?)
    .map_err(|x| Error::user_file(&probes_path, x))?;
    if probes_json["provenance"] != report["provenance"] {
        return Err(mixed(&probes_path));
    }
    let svo_path = e.path("svo.bin");
    let bytes = crate::input::read(&svo_path, "svo.bin", crate::limits::memory_budget())?;
    let mut svo = svo::format::from_bytes(&bytes).map_err(|m| Error::user_file(&svo_path, m))?;
    if svo.provenance != job.provenance.to_bytes()
        || svo.probe_count as usize != probes.probes.len()
    {
        return Err(mixed(&svo_path));
    }
    svo.origin = (svo::format::exact_origin(&bytes) - prepared.scene.origin).as_vec3();
    svo.frame = prepared.scene.origin;
    let report = report.clone();
    job.carry(&FILES);
    Ok(Some(BasePlacement {
        probes,
        svo,
        report,
    }))
}

/// The error of a file whose provenance is not its directory's.
pub(crate) fn mixed(path: &std::path::Path) -> Error {
    Error::user_file(
        path,
        "--from: comes from another run than the report beside it; run the earlier job again",
    )
}

/// A report as the JSON value later jobs extend.
fn to_value(report: &Report) -> Result<Value> {
    serde_json::to_value(report).map_err(|e| Error::Internal(format!("serializing JSON: {e}")))
}

/// The place job's report (`report.json`), assembled from the stages'
/// products, with the warnings their figures call for.
fn assemble_report(job: &Job, prepared: &Prepared, placed: &Placed, svo: SvoReport) -> Report {
    let (config, scene, sdf) = (&job.config, &prepared.scene, &prepared.sdf);
    let (coverage, health, probes) = (&placed.coverage, &placed.health, &placed.probes);
    let mut warnings = scene.warnings.clone();
    warnings.extend(placed.warnings.iter().cloned());
    if health.probes_in_solid > 0 {
        warnings.push(format!(
            "{} probe(s) stand in solid space",
            health.probes_in_solid
        ));
    }
    let refine = placed.refined.as_ref().map(|(r, _)| r.clone());
    if let Some(r) = &refine {
        let target = config.refine.coverage_target.0 as f64;
        if let (Some(before), Some(budget)) = (r.probes_before_budget, config.max_probes) {
            warnings.push(format!(
                "max_probes: {}: {} probes, of the {before} the coverage target needs, reach {:.2}% coverage (target {:.2}%)",
                budget.0,
                r.probes_final,
                100.0 * r.coverage_final,
                100.0 * target
            ));
        } else if config.refine.fill && r.coverage_final < target {
            warnings.push(format!(
                "refine: coverage {:.2}% is short of the target {:.2}%: no position at least {:.3} from every surface sees the rest; lower refine.min_clearance (or remove it) to reach it",
                100.0 * r.coverage_final,
                100.0 * target,
                r.params["min_fill_clearance"]
            ));
        }
        if let Some(min) = config.min_probes.filter(|m| r.probes_final < m.0 as usize) {
            warnings.push(format!(
                "min_probes: {}: {} probes: no further fill position sharpens any view (the coverage target needs {})",
                min.0,
                r.probes_final,
                r.probes_before_minimum.unwrap_or(r.probes_final)
            ));
        }
    }
    Report {
        format: "probeplace.report",
        version: FORMAT_VERSION,
        provenance: job.provenance.clone(),
        method: probes.method.clone(),
        seed: config.seed,
        config: job.config_path.display().to_string(),
        probe_count: probes.probes.len(),
        coverage: coverage.coverage,
        coverage_ci95: coverage.ci95,
        coverage_train: placed.coverage_train,
        probes_in_solid: health.probes_in_solid,
        probes_in_solid_sdf: health.probes_in_solid_sdf,
        idle_probes: prepared.reachable.as_ref().map(|reach| {
            crate::stages::diffuse::idle_probes(prepared, reach, &probes.positions())
                .iter()
                .filter(|&&i| i)
                .count()
        }),
        probes_outside_scene: health.probes_outside_scene,
        probes_outside_domain: health.probes_outside_domain,
        probes_below_clearance: refine.as_ref().map_or(0, |r| r.probes_below_clearance),
        best_view_incidence_deg: refine
            .as_ref()
            .and_then(|r| r.best_view_incidence_deg_final),
        scene: SceneRecord {
            path: config.scene.display().to_string(),
            format: scene.format,
            lights: scene.lights.len(),
            triangles: scene.triangles.len(),
            dropped_triangles: scene.dropped_triangles,
            bounds: BoundsRecord::world(&scene.bounds, scene),
            area: scene.area(),
            emitters: crate::stages::diffuse::emitters(config, scene),
            textures: crate::report::TextureRecord::of(scene),
        },
        domain: BoundsRecord::world(&prepared.domain, scene),
        sdf: sdf.into(),
        resolution: Some(prepared.resolution),
        reachable: prepared.reachable.as_ref().map(ReachRecord::from),
        coverage_detail: *coverage,
        coverage_holes: hole_sample(&placed.holes)
            .iter()
            .map(|h| scene.to_world(*h).to_array())
            .collect(),
        placement_stats: probes.stats.clone(),
        placement_params: probes.params.clone(),
        refine,
        diffuse: placed.diffuse.clone(),
        controls: placed.controls.clone(),
        svo: Some(svo),
        bake: None,
        render: None,
        timings_ms: job.watch.to_map(),
        warnings,
    }
}
