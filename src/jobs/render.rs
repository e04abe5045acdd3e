//! The `render` job: placement and bake (computed or reused), then the
//! reference's view rendered through the probes with each variant and
//! measured against the reference (Wang et al. 2019 §5.1).

use super::outcome::Outcome;
use super::run::Variant;
use super::run::{push_warnings, Job, RunOptions};
use super::{bake, place};
use crate::error::{Error, Result};
use crate::gpu::{Context, SelectionKind};
use crate::report;
use crate::report::render::{RenderReport, VariantReport};
use crate::stages::validate::{self, Tracer, ValidationView};
use crate::trace::{single::March, Lattice};
use std::collections::BTreeMap;

/// Glossy rays per pixel of `render`'s image: one, as a renderer traces.
const GLOSSY_RAYS: u32 = 1;

/// Runs `probeplace render`: place and bake (or reuse them with `--from`),
/// then render the reference's view through the probes with each variant
/// and measure it (`report.render`).
///
/// Contract: a config without `reference.camera` is a user error before
/// any work; without a GPU adapter the CPU twin traces and
/// `report.warnings` says so. Writes nothing unless everything succeeds.
pub fn render(options: &RunOptions) -> Result<Outcome> {
    let mut job = Job::new(options)?;
    let Some(camera) = job.config.reference.camera else {
        return Err(job.config_error(Error::User(
            "reference.camera: render needs a camera (the image is drawn from it and measured against the reference)".into(),
        )));
    };
    let variants = if options.variants.is_empty() {
        vec![Variant::BiLevel, Variant::HiZ]
    } else {
        options.variants.clone()
    };
    bake::precheck(&job)?;
    super::export::check_configured(&job)?;
    let prepared = job.prepare()?;
    let mut placement = place::placement(&mut job, &prepared)?;
    let baked = bake::bake_stage(&mut job, &prepared, &mut placement)?;
    let reference = baked
        .reference
        .ok_or_else(|| Error::Internal("render without a reference".into()))?;
    let mut watch = job.progress.stopwatch();
    let view = watch.time("gbuffer", || {
        ValidationView::new(&job.config, &prepared, &camera, 0, reference, GLOSSY_RAYS)
    });
    let mut warnings = Vec::new();
    let report = render_variants(
        &mut job,
        &view,
        &baked.field,
        &placement.svo,
        &variants,
        &mut watch,
        &mut warnings,
    )?;
    placement.report["render"] =
        serde_json::to_value(&report).map_err(|e| Error::Internal(e.to_string()))?;
    push_warnings(&mut placement.report, &warnings);
    super::export::add_configured(&mut job, &placement.report, &prepared.scene)?;
    placement.finish(job, &prepared)
}

/// Renders `view` through `field` with each of `variants`, adds the images
/// to the set, and returns `report.render`.
#[allow(clippy::too_many_arguments)]
fn render_variants(
    job: &mut Job,
    view: &ValidationView,
    field: &crate::lightfield::LightField,
    svo: &crate::svo::Svo,
    variants: &[Variant],
    watch: &mut crate::progress::Stopwatch,
    warnings: &mut Vec<String>,
) -> Result<RenderReport> {
    let lattice = Lattice::from_positions(&field.positions);
    if variants.contains(&Variant::BiLevel) && lattice.is_none() {
        warnings.push(
            "render: the probes are not a regular grid, so bi-level selects them with the SVO (place with --method grid:… for McGuire's grid selection)".into(),
        );
    }
    let t = std::time::Instant::now();
    let context = match job.cpu {
        true => None,
        false => Context::new()
            .map_err(|e| warnings.push(format!("render: {e}; traced on the CPU twin")))
            .ok(),
    };
    let (tracer, why) = Tracer::new(context.as_ref(), field, Some(svo), lattice.as_ref());
    if let Some(e) = why {
        warnings.push(format!("render: {e}; traced on the CPU twin"));
    }
    let adapter = match (&context, tracer.on_gpu()) {
        (Some(ctx), true) => ctx.adapter.clone(),
        _ => "cpu twin".to_string(),
    };
    watch.record("upload", t.elapsed().as_secs_f64() * 1e3);
    let size = (view.reference.width, view.reference.height);
    // The irradiance gather depends on the selection only: when both
    // variants select alike it runs once.
    let mut gathered: Vec<(SelectionKind, validate::Answers)> = Vec::new();
    let mut reports = BTreeMap::new();
    for variant in [Variant::BiLevel, Variant::HiZ] {
        if !variants.contains(&variant) {
            continue;
        }
        let name = variant.name();
        let t = std::time::Instant::now();
        let (march, kind) = match (variant, &lattice) {
            (Variant::BiLevel, Some(_)) => (March::BiLevel, SelectionKind::Grid),
            (Variant::BiLevel, None) => (March::BiLevel, SelectionKind::Svo),
            (Variant::HiZ, _) => (March::HiZ, SelectionKind::Svo),
        };
        let at = match gathered.iter().position(|(k, _)| *k == kind) {
            Some(i) => i,
            None => {
                gathered.push((kind, tracer.gather(view, kind)?));
                gathered.len() - 1
            }
        };
        let glossy = tracer.trace(view, march, kind)?;
        let v = validate::validate(view, &gathered[at].1, &glossy);
        let set = &mut job.set;
        report::add_image(
            set,
            &format!("render_{name}"),
            size,
            &v.image.full,
            view.exposure,
        )?;
        report::add_image(
            set,
            &format!("render_{name}-glossy"),
            size,
            &v.image.glossy_indirect,
            view.exposure,
        )?;
        let heat = format!("error_{name}.png");
        set.add(
            heat.clone(),
            crate::encode::png::encode_png(&view.heat_map(&v.image.glossy_indirect), &heat)?,
        );
        let selection = if kind == SelectionKind::Grid {
            "grid"
        } else {
            "svo"
        };
        reports.insert(
            name.to_string(),
            VariantReport {
                march: name,
                selection,
                metrics: v.metrics,
            },
        );
        watch.record(name, t.elapsed().as_secs_f64() * 1e3);
    }
    let timings_ms = watch.to_map_with_total();
    job.watch.record("render", timings_ms["total"]);
    Ok(RenderReport {
        adapter,
        width: size.0,
        height: size.1,
        glossy_rays: view.gbuffer.glossy.len(),
        variants: reports,
        timings_ms,
    })
}
