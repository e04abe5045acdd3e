//! The `bake` job: the placement (computed or reused), then the light-field
//! bake (McGuire et al. 2017 §3, §5.2), the check of the tracer against ray
//! casts, and the path-traced reference when the config has a camera.

use super::outcome::Outcome;
use super::place;
use super::run::{push_warnings, Job, RunOptions};
use crate::encode::exr;
use crate::encode::png::encode_png;
use crate::error::{Error, Result};
use crate::lightfield::LightField;
use crate::render::Reference;
use crate::report;
use crate::report::bake::{
    atlas, distance_preview, normal_preview, BakeReport, DiffuseViewSet, DiffuseViewsReport,
    ReferenceReport,
};
use crate::report::sh::SH_FILE;
use crate::stages::{self, validate, Prepared};
use serde_json::Value;

/// The files of a bake, carried together when reused.
pub(crate) const FILES: [&str; 7] = [
    "radiance.exr",
    "radiance.png",
    "irradiance.exr",
    "irradiance.png",
    "distance.png",
    "normal.png",
    "lightfield.bin",
];

/// The reference's files.
pub(crate) const REFERENCE_FILES: [&str; 4] = [
    "reference.exr",
    "reference.png",
    "reference-glossy.exr",
    "reference-glossy.png",
];

/// The diffuse views' files (with a camera).
pub(crate) const DIFFUSE_VIEW_FILES: [&str; 5] = [
    "diffuse-reference.png",
    "diffuse-ours.png",
    "diffuse-ours-error.png",
    "diffuse-grid.png",
    "diffuse-grid-error.png",
];

/// Runs `probeplace bake`.
///
/// Contract: on success the output directory holds `place`'s files plus
/// `lightfield.bin`, the probe-map previews (`radiance.exr`/`.png`,
/// `irradiance.exr`/`.png`, `distance.png`, `normal.png`) and, with a
/// camera, `reference.exr`/`.png` and `reference-glossy.exr`/`.png`;
/// `report.json` has a `bake` section. With `--from DIR` the placement
/// (and a bake already there) is reused. On error nothing changes.
pub fn bake(options: &RunOptions) -> Result<Outcome> {
    let mut job = Job::new(options)?;
    precheck(&job)?;
    super::export::check_configured(&job)?;
    let prepared = job.prepare()?;
    let mut placement = place::placement(&mut job, &prepared)?;
    bake_stage(&mut job, &prepared, &mut placement)?;
    super::export::add_configured(&mut job, &placement.report, &prepared.scene)?;
    placement.finish(job, &prepared)
}

/// The bake's and the reference's limits, checked before any stage runs
/// with the probe count the config fixes (a grid's cells; any other
/// method at least one probe), so that settings no probe count could
/// bake are refused at once; [`bake_stage`] checks again with the count
/// placement gave.
pub(crate) fn precheck(job: &Job) -> Result<()> {
    let config = &job.config;
    let given = job.provenance.overrides.probes.is_some();
    let probes = match (&config.placement, given) {
        (_, true) => 1,
        (crate::config::Placement::Grid(g), false) => {
            (g.cells.0 .0 as usize) * (g.cells.1 .0 as usize) * (g.cells.2 .0 as usize)
        }
        _ => 1,
    };
    stages::bake::check(config, probes).map_err(|e| job.config_error(e))?;
    if config.reference.camera.is_some() {
        validate::check_reference(config, 1, 1.0).map_err(|e| job.config_error(e))?;
    }
    Ok(())
}

/// What the bake hands on to the validation render.
pub(crate) struct Bake {
    /// The probes' maps, in the scene's frame.
    pub field: LightField,
    /// The reference of the config's camera; `None` without one.
    pub reference: Option<Reference>,
}

/// The bake of `placement`: reused from `--from DIR` when it holds one,
/// else computed; adds its files to the set and `bake` to the report.
pub(crate) fn bake_stage(
    job: &mut Job,
    prepared: &Prepared,
    placement: &mut place::BasePlacement,
) -> Result<Bake> {
    if let Some(b) = load(job, prepared, placement)? {
        return Ok(b);
    }
    let config = &job.config;
    let positions = placement.probes.positions();
    // The reference was checked by `precheck`; the bake again, now that
    // placement has fixed the probe count, and both with the lights the
    // scene file brought.
    let lit = stages::bake::lit_by_scene(config, &prepared.scene);
    stages::bake::check(&lit, positions.len()).map_err(|e| job.config_error(e))?;
    if config.reference.camera.is_some() {
        validate::check_reference(&lit, 1, 1.0).map_err(|e| job.config_error(e))?;
    }
    let mut watch = job.progress.stopwatch();
    let baked = stages::bake(config, prepared, &positions, &job.progress);
    watch.absorb(&baked.timings);
    let mut field = baked.field;
    field.provenance = job.provenance.to_bytes();
    let tracer = watch.time("tracer_check", || {
        stages::bake::check_tracer(config, prepared, &field, &placement.svo, &job.progress)
    });
    let mut warnings = baked.warnings;
    let reference = match &config.reference.camera {
        Some(camera) => Some(watch.time("reference", || {
            validate::reference(config, prepared, camera, 0)
        })),
        None => {
            warnings.push(
                "bake: no reference.camera in the config; the reference image is skipped".into(),
            );
            None
        }
    };
    let light = watch.time("sh", || {
        stages::bake::probe_light(config, prepared, &positions)
    });
    // The camera's view lit by the probes' blended diffuse light, and by
    // the equal-count grid's, beside the path tracer's (the run page's
    // diffuse figures).
    let views = config.reference.camera.as_ref().map(|camera| {
        watch.time("diffuse_views", || {
            let view = stages::diffuse::lit_view(config, prepared, camera, 0, DIFFUSE_VIEW_RAYS);
            let sh: Vec<crate::diffuse::ProbeSh> = light.iter().map(|l| l.sh).collect();
            let mut renders = vec![view.render_set(prepared, "ours", &positions, &sh)];
            if let Some((name, at, grid_sh)) = stages::diffuse::LitView::grid_beside(
                config,
                prepared,
                positions.len(),
                config.bake.sh_rays.0,
                config.seed ^ stages::bake::SH_STREAMS,
            ) {
                renders.push(view.render_set(prepared, &name, &at, &grid_sh));
            }
            (view, renders)
        })
    });
    add_files(job, &field, reference.as_ref())?;
    if let Some((view, renders)) = &views {
        add_diffuse_views(job, view, renders)?;
    }
    let rays = job.config.bake.sh_rays.0;
    job.set.add(
        SH_FILE,
        crate::report::sh::encode(
            &job.provenance,
            rays,
            job.config.bake.sh_direct == crate::config::ShDirect::Include,
            &light,
        ),
    );
    let timings = watch.to_map_with_total();
    job.watch.record("bake", timings["total"]);
    let r = &job.config.reference;
    let report = BakeReport {
        resolution: field.resolution,
        irradiance_resolution: field.irradiance_resolution,
        probes: positions.len(),
        samples: job.config.bake.samples.0,
        bounces: job.config.bake.bounces.0,
        bytes: field.bytes(),
        area_lights: baked.area_lights,
        config_lights: job.config.lights.len(),
        scene_lights: prepared.scene.lights.len(),
        tracer,
        sh_rays: rays,
        sh_axis_error: crate::report::bake::sh_axis_error(&light),
        diffuse_views: views.as_ref().map(|(view, renders)| DiffuseViewsReport {
            width: view.width,
            height: view.height,
            rays: DIFFUSE_VIEW_RAYS,
            sets: renders
                .iter()
                .map(|r| DiffuseViewSet {
                    name: r.name.clone(),
                    probes: r.probes,
                    mean_error: r.mean_error,
                })
                .collect(),
        }),
        reference: reference.as_ref().map(|image| ReferenceReport {
            width: image.width,
            height: image.height,
            samples_per_pixel: r.samples_per_pixel.0,
            bounces: r.bounces.0,
            mean: image.mean(),
            glossy_indirect_mean: image.glossy_mean(),
        }),
        timings_ms: timings,
    };
    placement.report["bake"] =
        serde_json::to_value(&report).map_err(|e| Error::Internal(e.to_string()))?;
    push_warnings(&mut placement.report, &warnings);
    Ok(Bake { field, reference })
}

/// Paths per pixel of the diffuse views' reference.
const DIFFUSE_VIEW_RAYS: u32 = 64;

/// Adds the diffuse views: `diffuse-reference.png`, and per set its
/// render and error map (`diffuse-ours.png`, `diffuse-ours-error.png`,
/// `diffuse-grid.png`, `diffuse-grid-error.png`).
fn add_diffuse_views(
    job: &mut Job,
    view: &stages::diffuse::LitView,
    renders: &[stages::diffuse::LitRender],
) -> Result<()> {
    let reference = view.reference();
    let exposure = validate::auto_exposure(&reference);
    let (w, h) = (view.width, view.height);
    let tonemapped = |pixels: &[[f32; 3]], name: &str| {
        encode_png(&crate::raster::tonemap(pixels, w, h, exposure), name)
    };
    let [reference_png, sets @ ..] = DIFFUSE_VIEW_FILES;
    job.set
        .add(reference_png, tonemapped(&reference, reference_png)?);
    for (r, files) in renders.iter().zip(sets.chunks(2)) {
        job.set.add(files[0], tonemapped(&r.image, files[0])?);
        job.set.add(
            files[1],
            encode_png(&stages::diffuse::error_map(&r.error, w, h), files[1])?,
        );
    }
    Ok(())
}

/// Adds `lightfield.bin`, the map previews and the reference's images.
fn add_files(job: &mut Job, field: &LightField, reference: Option<&Reference>) -> Result<()> {
    let set = &mut job.set;
    set.add("lightfield.bin", field.to_bytes());
    let probes = field.positions.len();
    let (w, h, rad) = atlas(field.resolution, probes, |i| field.radiance[i]);
    report::add_image(set, "radiance", (w, h), &rad, validate::auto_exposure(&rad))?;
    let (w, h, irr) = atlas(field.irradiance_resolution, probes, |i| field.irradiance[i]);
    report::add_image(
        set,
        "irradiance",
        (w, h),
        &irr,
        validate::auto_exposure(&irr),
    )?;
    set.add(
        "distance.png",
        encode_png(&distance_preview(field), "distance.png")?,
    );
    set.add(
        "normal.png",
        encode_png(&normal_preview(field), "normal.png")?,
    );
    if let Some(image) = reference {
        let exposure = validate::auto_exposure(&image.full);
        let size = (image.width, image.height);
        report::add_image(set, "reference", size, &image.full, exposure)?;
        report::add_image(
            set,
            "reference-glossy",
            size,
            &image.glossy_indirect,
            exposure,
        )?;
    }
    Ok(())
}

/// The bake `--from DIR` holds for `placement`, when the placement came
/// from there too and the directory has a bake (and the reference the
/// config's camera needs).
pub(crate) fn load(
    job: &mut Job,
    prepared: &Prepared,
    placement: &place::BasePlacement,
) -> Result<Option<Bake>> {
    let Some(e) = &job.earlier else {
        return Ok(None);
    };
    let has_camera = job.config.reference.camera.is_some();
    let placed_there = job.reused.iter().any(|r| r == "probes.json");
    let baked_there = matches!(placement.report.get("bake"), Some(Value::Object(_)));
    if !placed_there
        || !baked_there
        || !e.has("lightfield.bin")
        || !e.has(SH_FILE)
        || (has_camera && !e.has("reference.exr"))
    {
        return Ok(None);
    }
    let path = e.path("lightfield.bin");
    let mut field = LightField::read(&path)?;
    if field.provenance != job.provenance.to_bytes()
        || field.positions.len() != placement.probes.probes.len()
    {
        return Err(place::mixed(&path));
    }
    // The file holds world positions in f32; the probes' own positions are
    // the exact ones the bake used.
    field.positions = placement.probes.positions();
    field.frame = prepared.scene.origin;
    let reference = if has_camera {
        Some(read_reference(e)?)
    } else {
        None
    };
    let sh_path = e.path(SH_FILE);
    let bytes = crate::input::read(&sh_path, SH_FILE, crate::limits::memory_budget())?;
    crate::report::sh::decode(&bytes, &job.provenance, placement.probes.probes.len())
        .map_err(|m| Error::user_file(&sh_path, m.trim_start_matches("sh.json: ")))?;
    job.carry(&FILES);
    job.carry(&[SH_FILE]);
    job.carry(&REFERENCE_FILES);
    job.carry(&DIFFUSE_VIEW_FILES);
    Ok(Some(Bake { field, reference }))
}

/// The reference images of an earlier run.
pub(crate) fn read_reference(e: &super::run::Earlier) -> Result<Reference> {
    // The manifest vouches for the bytes; the file's own header for the
    // run, so an image copied in with its manifest entry is still refused.
    let read = |name: &str| {
        let path = e.path(name);
        let bytes = crate::input::read(&path, "reference image", crate::limits::memory_budget())?;
        if let Some(why) =
            crate::provenance::Stamp::of(&e.provenance).mismatch(&exr::string_attributes(&bytes))
        {
            return Err(Error::user_file(&path, format!("--from: {why}")));
        }
        exr::decode_rgb(&bytes).map_err(|m| Error::user_file(&path, m))
    };
    let (width, height, full) = read("reference.exr")?;
    let (w, h, glossy_indirect) = read("reference-glossy.exr")?;
    if (w, h) != (width, height) {
        return Err(place::mixed(&e.path("reference-glossy.exr")));
    }
    Ok(Reference {
        width,
        height,
        full,
        glossy_indirect,
    })
}
