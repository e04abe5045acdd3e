//! `report.html` of `place`, `bake` and `render`: the run's figures from
//! `report.json`, its 3D view ([`super::view3d`]) and every image it wrote,
//! captioned, in one self-contained page (the frame, tables and figures of
//! [`super::html`]).
//!
//! The figures are those of the report as written, read into types
//! ([`super::figures::RunFigures`]), since a job that reuses a placement
//! (`--from`) has its figures only there. Everything on the page is deterministic but the `#timings`
//! section, which holds what `report.json`'s determinism leaves out too:
//! `timings_ms` (every one of them), GPU times and the list of reused
//! files.

use super::figures::{Num, Ordered, RunFigures};
use super::html::{self, bytes, escape, sci};
use super::view3d::{self, View3d};
use crate::error::Result;
use crate::output::commit::OutputSet;
use crate::scene::{Bounds, Scene};
use crate::sdf::Sdf;
use crate::stages::validate::METRICS;
use crate::svo::Svo;
use glam::{DVec3, Vec3};
use std::fmt::Write as _;

/// The page of the run whose `report.json` reads as `r`, with the images
/// in `set` and `view`.
///
/// Contract: deterministic outside `#timings`; every image is a `data:`
/// URI; missing sections of the report (no refinement, no bake) leave
/// their tables out.
pub fn page(r: &RunFigures, set: &OutputSet, view: &View3d) -> Result<String> {
    let mut h = String::with_capacity(4 << 20);
    let job = r.job();
    let scene = text(&r.scene.path);
    html::head(&mut h, &format!("probeplace {job}: {scene}"));
    let p = &r.provenance;
    let _ = writeln!(
        h,
        "<h1>probeplace {job}: {}</h1>\n<p class=\"meta\">config <code>{}</code> · seed {} · method <b>{}</b> · {} · config hash {} · scene hash {}</p>",
        escape(&scene),
        escape(&text(&r.config)),
        raw(r.seed),
        escape(&text(&r.method)),
        escape(&text(&p.tool)),
        escape(&text(&p.config_hash)),
        escape(&text(&p.scene_hash)),
    );
    summary(&mut h, r);
    view.section(
        &mut h,
        "The scene with the run's probes, coloured by clearance, and its coverage holes.",
    );
    placement_tables(&mut h, r);
    diffuse_table(&mut h, r);
    controls_table(&mut h, r);
    svo_table(&mut h, r);
    bake_table(&mut h, r);
    render_table(&mut h, r);
    let shown = images(&mut h, r, set)?;
    warnings(&mut h, r);
    timings(&mut h, r);
    html::tail(&mut h, shown, Some(view));
    Ok(h)
}

/// The 3D view of a run: `scene` over `domain`, its probes at `positions`
/// (local coordinates) indexed by `svo` and scored against `sdf`, and the
/// coverage holes the report `r` keeps (`coverage_holes`, world
/// coordinates: the same whether the placement was computed or reused).
pub fn view(
    scene: &Scene,
    domain: &Bounds,
    sdf: &Sdf,
    r: &RunFigures,
    positions: &[Vec3],
    svo: &Svo,
) -> View3d {
    let holes: Vec<Vec3> = r
        .coverage_holes
        .iter()
        .map(|&c| scene.to_local(DVec3::from_array(c)))
        .collect();
    let total = r.holes() as usize;
    let set = view3d::ProbeSet::new(&text(&r.method), positions, sdf, svo, &holes, total);
    View3d::new(scene, domain, vec![set])
}

/// A string of the report (`?` when absent).
fn text(v: &Option<String>) -> String {
    v.as_deref().unwrap_or("?").to_string()
}

/// A number as JSON writes it (`null` when absent).
fn raw(v: Option<Num>) -> String {
    match v {
        Some(Num::Whole(n)) => n.to_string(),
        Some(Num::Negative(n)) => n.to_string(),
        Some(Num::Real(x)) => {
            serde_json::Number::from_f64(x).map_or("null".into(), |n| n.to_string())
        }
        None => "null".into(),
    }
}

/// A number as a table shows it: whole numbers as they are, others
/// with four significant digits; `–` when absent.
fn num(v: Option<Num>) -> String {
    match v {
        Some(Num::Whole(n)) => n.to_string(),
        Some(Num::Negative(n)) => n.to_string(),
        Some(Num::Real(x)) => {
            if x != 0.0 && (x.abs() < 1e-3 || x.abs() >= 1e6) {
                sci(x)
            } else {
                let s = format!("{x:.4}");
                let s = s.trim_end_matches('0');
                s.trim_end_matches('.').to_string()
            }
        }
        None => "–".into(),
    }
}

/// A fraction as a percentage with two decimals.
fn pct(v: Option<f64>) -> String {
    v.map_or("–".into(), |x| format!("{:.2}%", 100.0 * x))
}

/// `[x, y, z]` as `(x, y, z)`.
fn triple(v: &Option<Vec<Num>>) -> String {
    match v {
        Some(a) => format!(
            "({})",
            a.iter()
                .map(|&x| num(Some(x)))
                .collect::<Vec<_>>()
                .join(", ")
        ),
        None => "–".into(),
    }
}

/// A table of (figure, value, what it means) rows.
fn figures_table(h: &mut String, id: &str, title: &str, rows: Vec<[String; 3]>) {
    let _ = writeln!(
        h,
        "<h2 id=\"{id}-section\">{title}</h2>\n<div class=\"figures\">"
    );
    let rows: Vec<Vec<String>> = rows.into_iter().map(Vec::from).collect();
    html::table(h, id, &["figure", "value", "meaning"], &rows);
    h.push_str("</div>\n");
}

/// One row of a figures table; `meaning` is escaped, `value` is HTML.
fn row(name: &str, value: String, meaning: &str) -> [String; 3] {
    [escape(name), value, escape(meaning)]
}

/// The placement's headline figures.
fn summary(h: &mut String, r: &RunFigures) {
    let d = &r.coverage_detail;
    let holes = r.holes();
    let source = r.resolution.as_ref().and_then(|res| res.source.clone());
    let scene = &r.scene;
    let rows = vec![
        row(
            "method",
            escape(&text(&r.method)),
            "the placement method; +refine when refinement ran (Wang et al. 2019 §3.3)",
        ),
        row("probes", num(r.probe_count), "probes placed"),
        row(
            "coverage",
            format!("<b>{}</b> ± {}", pct(r.coverage), pct(r.coverage_ci95)),
            "share of the coverable surface some probe sees, with its 95% interval",
        ),
        row(
            "coverage holes",
            holes.to_string(),
            "coverable surface samples no probe sees (red in the views)",
        ),
        row(
            "coverable surface",
            format!(
                "{} of {} samples ({})",
                num(d.coverable_samples),
                num(d.samples),
                pct(d.coverable_fraction)
            ),
            "surface some free point sees; the rest counts for no method",
        ),
        row(
            "in solid",
            num(r.probes_in_solid),
            "probes inside objects or walls",
        ),
        row(
            "near surfaces",
            num(r.probes_below_clearance),
            "probes filling placed below the placement's clearance",
        ),
        row(
            "outside the scene",
            num(r.probes_outside_scene),
            "probes in voxels classified outside",
        ),
        row(
            "outside the domain",
            num(r.probes_outside_domain),
            "probes outside the domain box",
        ),
        row(
            "best view incidence",
            r.best_view_incidence_deg
                .map_or("–".into(), |v| format!("{v:.1}°")),
            "mean angle of each covered sample's best view (0° head-on)",
        ),
        row(
            "voxel size",
            format!("{} ({})", num(r.sdf.voxel_size), escape(&text(&source))),
            "the SDF's voxel edge, and whether the config gave it or it was chosen from the scene",
        ),
        row("SDF grid", triple(&r.sdf.dims), "voxels along x, y, z"),
        row(
            "scene",
            format!(
                "{} triangles ({} dropped), area {}",
                num(scene.triangles),
                num(scene.dropped_triangles),
                num(scene.area)
            ),
            "usable triangles, faces dropped as degenerate, one-sided surface area",
        ),
        row(
            "domain",
            format!("{} to {}", triple(&r.domain.min), triple(&r.domain.max)),
            "where probes may go (world coordinates)",
        ),
    ];
    figures_table(h, "summary-table", "Summary", rows);
}

/// The placement method's own figures and refinement's.
fn placement_tables(h: &mut String, r: &RunFigures) {
    let mut rows = Vec::new();
    for (m, what) in [
        (&r.placement_stats, "a count of the method's steps"),
        (&r.placement_params, "a parameter as used"),
    ] {
        for (k, v) in m.iter().flat_map(|m| &m.0) {
            rows.push(row(k, num(Some(*v)), what));
        }
    }
    if !rows.is_empty() {
        figures_table(h, "placement-table", "Placement method", rows);
    }
    let Some(f) = &r.refine else {
        return;
    };
    let arrow = |a: Option<f64>, b: Option<f64>| format!("{} → {}", pct(a), pct(b));
    let rows = vec![
        row("iterations", num(f.iterations), "sweeps over all probes"),
        row(
            "proposals",
            format!(
                "{} ({} accepted, {} illegal)",
                num(f.proposals),
                num(f.accepted),
                num(f.rejected_illegal)
            ),
            "moves proposed, accepted by the Gibbs test, refused as illegal positions",
        ),
        row(
            "coverage",
            arrow(f.coverage_initial, f.coverage_final),
            "before and after refinement, filling and pruning",
        ),
        row(
            "atlas coverage",
            arrow(f.atlas_coverage_initial, f.atlas_coverage_final),
            "share of the atlas the probes' rays see (atlas.png)",
        ),
        row(
            "probes",
            format!(
                "{} → {} ({} removed, {} added)",
                num(f.probes_initial),
                num(f.probes_final),
                num(f.removed),
                num(f.added)
            ),
            "pruning removes, filling adds",
        ),
        row(
            "fitness R",
            format!("{} → {}", num(f.r_initial), num(f.r_final)),
            "eq. 1 of Wang et al. 2019, area-weighted (comparable within a scene)",
        ),
        row(
            "fill rounds",
            f.fill_rounds.as_ref().map_or(0, Vec::len).to_string(),
            "rounds of filling",
        ),
    ];
    figures_table(h, "refine-table", "Refinement", rows);
}

/// What the diffuse step did, when it ran (`report.json`'s `diffuse`):
/// its training scores and its figures on receivers it never saw.
fn diffuse_table(h: &mut String, r: &RunFigures) {
    let Some(d) = &r.diffuse else {
        return;
    };
    let rows = vec![
        row(
            "probes",
            format!(
                "{} → {} ({} inserted, {} moved, {} removed)",
                num(d.probes_before),
                num(d.probes_after),
                num(d.inserted),
                num(d.relocated),
                num(d.removed)
            ),
            "coverage's probes in, the diffuse step's out: probes inserted, moved and removed where the engines' blend of their SH (tetrahedra) lit the training receivers better",
        ),
        row(
            "receivers",
            format!(
                "{} on surfaces, {} in free space; {} held out",
                num(d.surface_points),
                num(d.free_points),
                num(d.validation_points)
            ),
            "the receivers the step scored, and those it never saw, drawn from the seed",
        ),
        row(
            "held-out error",
            format!("{} → {}", pct(d.validation_before), pct(d.validation_after)),
            "mean relative error of the blended baked light at the held-out surface receivers, before and after",
        ),
        row(
            "held-out leaks",
            format!("{} → {}", pct(d.leaks_before), pct(d.leaks_after)),
            "share of the held-out surface receivers lit 2× too much or too little, before and after",
        ),
        row(
            "training error",
            format!("{} → {}", pct(d.error_before), pct(d.error_after)),
            "the objective at the training receivers (relative error plus one per leak), before and after: a training score",
        ),
        row(
            "stopped",
            escape(&text(&d.stopped)),
            "why insertion stopped: budget (max_probes or growth), gain, no gain, no candidate or no light",
        ),
    ];
    figures_table(h, "diffuse-table", "Diffuse step", rows);
}

/// What the artist controls did, when the config set any
/// (`report.json`'s `controls`).
fn controls_table(h: &mut String, r: &RunFigures) {
    let c = &r.controls;
    if !c.any() {
        return;
    }
    let rows = vec![
        row(
            "fixed probes",
            num(c.fixed_probes),
            "the config's fixed_probes: the first probes, never moved or pruned",
        ),
        row(
            "excluded",
            num(c.excluded),
            "placement probes dropped for standing in an exclude box",
        ),
        row(
            "budget",
            format!(
                "{} (before it: {})",
                num(c.max_probes),
                num(c.probes_before_budget)
            ),
            "max_probes, and the probes the run had before the budget cut them",
        ),
        row(
            "floor",
            format!(
                "{} (before it: {})",
                num(c.min_probes),
                num(c.probes_before_minimum)
            ),
            "min_probes, and the probes the coverage target needed before the top-up added those that sharpen the views most",
        ),
        row(
            "density regions",
            format!(
                "{} ({} samples)",
                num(c.density_regions),
                num(c.samples_with_density)
            ),
            "probe_density boxes, and the coverage samples whose demand they change",
        ),
        row(
            "demand met",
            pct(c.demand_met),
            "samples seen as many times as their density asks",
        ),
    ];
    figures_table(h, "controls-table", "Artist controls", rows);
}

/// The SVO's figures.
fn svo_table(h: &mut String, r: &RunFigures) {
    let Some(s) = &r.svo else {
        return;
    };
    let rows = vec![
        row(
            "nodes",
            format!(
                "{} ({} leaves), depth {}",
                num(s.nodes),
                num(s.leaves),
                num(s.depth)
            ),
            "inner nodes and leaves of svo.bin; the root is 2^depth leaves along an edge",
        ),
        row(
            "size",
            format!(
                "{} (dense texture: {})",
                bytes(s.bytes.unwrap_or(0)),
                bytes(s.dense_bytes.unwrap_or(0))
            ),
            "svo.bin against the paper's dense RGBA8 texture at the same leaf size",
        ),
        row(
            "leaf size",
            format!("{} over {}", num(s.leaf_size), triple(&s.dims)),
            "leaf edge and leaves along x, y, z",
        ),
        row(
            "free cells",
            format!(
                "{} ({} by fallback)",
                num(s.free_cells),
                num(s.fallback_cells)
            ),
            "leaf cells holding free space; fallback cells list the nearest probe that sees them",
        ),
        row(
            "without a visible probe",
            num(s.leaves_without_visible_probe),
            "free cells none of their 64 nearest probes sees (on open scenes mostly above the roof)",
        ),
        row(
            "distinct lists",
            num(s.distinct_lists),
            "different probe lists in the payload",
        ),
        row(
            "first probe visible",
            pct(s.first_probe_visible),
            "random free points whose first listed probe sees them",
        ),
    ];
    figures_table(h, "svo-table", "Sparse voxel octree (svo.bin)", rows);
}

/// The bake's figures, after `bake` and `render`.
fn bake_table(h: &mut String, r: &RunFigures) {
    let Some(b) = &r.bake else {
        return;
    };
    let t = &b.tracer;
    let seen = t.seen.map_or(0.0, Num::as_f64);
    let agree = if seen > 0.0 {
        format!("{:.2}%", 100.0 * t.agree.map_or(0.0, Num::as_f64) / seen)
    } else {
        "–".into()
    };
    let mut rows = vec![
        row(
            "maps",
            format!(
                "{}² (irradiance {}²)",
                num(b.resolution),
                num(b.irradiance_resolution)
            ),
            "side of each probe's radiance, normal and distance maps, and of its irradiance maps",
        ),
        row(
            "probes",
            format!(
                "{}, {} paths a texel, {} bounces",
                num(b.probes),
                num(b.samples),
                num(b.bounces)
            ),
            "probes baked, radiance paths per texel, indirect bounces",
        ),
        row(
            "lightfield.bin",
            bytes(b.bytes.unwrap_or(0)),
            "size of the baked probes",
        ),
        row(
            "lights",
            format!(
                "{} emissive triangles, {} scene file lights, {} config lights",
                num(b.area_lights),
                num(b.scene_lights),
                num(b.config_lights)
            ),
            "what lights the scene",
        ),
        row(
            "tracer agreement",
            format!(
                "<b>{agree}</b> of {} seen rays ({} rays, {} unknown)",
                num(t.seen),
                num(t.rays),
                num(t.unknown)
            ),
            "the CPU light-field tracer against exact ray casts: hits within two texels",
        ),
        row(
            "escaping rays",
            format!(
                "{} ({} called a miss)",
                num(t.escaping),
                num(t.escaping_missed)
            ),
            "rays that truly leave the scene, and those the tracer calls a miss",
        ),
    ];
    if let Some(f) = &b.reference {
        rows.push(row(
            "reference",
            format!(
                "{}×{}, {} paths a pixel, {} bounces; mean {}, glossy {}",
                num(f.width),
                num(f.height),
                num(f.samples_per_pixel),
                num(f.bounces),
                triple(&f.mean),
                triple(&f.glossy_indirect_mean)
            ),
            "the path-traced reference of the config's camera",
        ));
    }
    if let Some(v) = &b.diffuse_views {
        let sets: Vec<String> = v
            .sets
            .iter()
            .map(|x| {
                format!(
                    "{} ({} probes) {}",
                    escape(&text(&x.name)),
                    num(x.probes),
                    pct(x.mean_error)
                )
            })
            .collect();
        rows.push(row(
            "diffuse views",
            format!(
                "{}×{}, {} paths a pixel; mean relative error {}",
                num(v.width),
                num(v.height),
                num(v.rays),
                sets.join(", ")
            ),
            "the camera's view lit by the probes' SH blended over tetrahedra, against the path tracer's baked light (diffuse-*.png): ours and the uniform grid of about our count",
        ));
    }
    figures_table(h, "bake-table", "Light-field bake (lightfield.bin)", rows);
}

/// The validation render's figures per variant, after `render`.
fn render_table(h: &mut String, r: &RunFigures) {
    let Some((x, variants)) = r
        .render
        .as_ref()
        .and_then(|x| Some((x, &x.variants.as_ref()?.0)))
    else {
        return;
    };
    let _ = writeln!(
        h,
        "<h2 id=\"render-table-section\">Validation render</h2>\n<p class=\"meta\">{}×{} pixels, {} glossy rays, on <b>{}</b>; errors against the reference (Wang et al. 2019 §5.1).</p>",
        num(x.width),
        num(x.height),
        num(x.glossy_rays),
        escape(&text(&x.adapter))
    );
    let rows: Vec<Vec<String>> = variants
        .iter()
        .map(|(name, v)| {
            let mut row = vec![
                escape(name),
                format!(
                    "{} + {}",
                    escape(&text(&v.march)),
                    escape(&text(&v.selection))
                ),
            ];
            // One column per metric of the list.
            row.extend(METRICS.iter().map(|m| match v.metric(m.key) {
                Some(x) => m.show.cell(x),
                None => "–".into(),
            }));
            row.extend([
                num(v.surfel_fetches_per_ray),
                num(v.warp_fetches_per_ray),
                num(v.probe_switches_per_ray),
                format!(
                    "{} / {} / {}",
                    num(v.unresolved_rays),
                    num(v.hits),
                    num(v.misses)
                ),
            ]);
            row
        })
        .collect();
    let mut heads = vec!["variant", "march + selection"];
    heads.extend(METRICS.iter().map(|m| m.label));
    heads.extend([
        "surfel fetches / ray",
        "texel fetches / ray in 32-ray warps",
        "probe switches / ray",
        "unresolved / hits / misses",
    ]);
    html::table(h, "render-table", &heads, &rows);
}

/// A colour swatch.
fn swatch(c: [u8; 3]) -> String {
    format!(
        "<i class=\"sw\" style=\"background:#{:02x}{:02x}{:02x}\"></i>",
        c[0], c[1], c[2]
    )
}

/// A gradient bar through `stops` (CSS colours).
fn gradient(stops: &str) -> String {
    format!("<i class=\"grad\" style=\"background:linear-gradient(to right,{stops})\"></i>")
}

/// The run's images in the order of the files list of docs/formats.md,
/// each with what it shows and what to look for; returns how many.
fn images(h: &mut String, r: &RunFigures, set: &OutputSet) -> Result<usize> {
    use crate::refine::{SEEN, UNSEEN};
    use crate::report::preview::{BOUNDS_COLOR, HOLE_COLOR, PROBE_FILL};
    let mut list: Vec<(String, String)> = vec![
        (
            "placement.png".into(),
            format!(
                "<b>placement.png</b>: top view (left, looking down −Y, +X right) and side view (right). {}probes, {}coverage holes (coverable surface samples no probe sees), {}the domain; surfaces darken with distance, back faces are culled. Look for red clusters: surface no probe sees.",
                swatch(PROBE_FILL),
                swatch(HOLE_COLOR),
                swatch(BOUNDS_COLOR)
            ),
        ),
        (
            "atlas.png".into(),
            format!(
                "<b>atlas.png</b>: the visibility atlas (Wang et al. 2019 Fig. 5) before refinement (left) and after (right), one chart per triangle. {}seen by some probe, {}seen by none. Look for red charts that turn green on the right; speckle is what a probe's rays miss between them.",
                swatch(SEEN),
                swatch(UNSEEN)
            ),
        ),
        (
            "radiance.png".into(),
            "<b>radiance.png</b>: each probe's radiance map (octahedral, McGuire et al. 2017 §3), tiled row by row from probe 0 at the top left, auto-exposed. Each tile is what its probe sees all around.".into(),
        ),
        (
            "irradiance.png".into(),
            "<b>irradiance.png</b>: each probe's irradiance map, the radiance integrated over the cosine lobe, tiled as the radiance; smooth by construction.".into(),
        ),
        (
            "distance.png".into(),
            format!(
                "<b>distance.png</b>: the distance to the surface each texel sees, {} bright near to dark far, {}nothing seen (the ray escapes).",
                gradient("#fff,#000"),
                swatch([40, 60, 160])
            ),
        ),
        (
            "normal.png".into(),
            "<b>normal.png</b>: the normal of the surface each texel sees, x, y, z mapped from [−1, 1] to red, green, blue (so +Y up is green).".into(),
        ),
        (
            "reference.png".into(),
            "<b>reference.png</b>: the path-traced reference from the config's camera, the image the renders are measured against.".into(),
        ),
        (
            "reference-glossy.png".into(),
            "<b>reference-glossy.png</b>: its glossy indirect part (light the glossy lobe reflects after at least one bounce), at the same exposure; the errors are measured on it.".into(),
        ),
        (
            "diffuse-reference.png".into(),
            "<b>diffuse-reference.png</b>: the camera's view lit as a renderer with probes lights it: each pixel's emission and the point, spot and directional lights' direct light, plus its albedo times the baked irradiance (every light but those), here path-traced. Compare the two renders below with it.".into(),
        ),
        (
            "diffuse-ours.png".into(),
            "<b>diffuse-ours.png</b>: the same view with the baked irradiance from this run's probes' SH blended over tetrahedra, as Unity and Godot blend light probes.".into(),
        ),
        (
            "diffuse-ours-error.png".into(),
            format!("<b>diffuse-ours-error.png</b>: its relative error of the baked irradiance per pixel, {} from 0 (black) through red and yellow to 100% and more (white). Look for bright patches: light leaking through walls, shadows washed out.", gradient("#000 0%,#f00 33.3%,#ff0 66.7%,#fff 100%")),
        ),
        (
            "diffuse-grid.png".into(),
            "<b>diffuse-grid.png</b>: the same view lit by the uniform grid of about this run's probe count (its name and count in the bake table), blended alike.".into(),
        ),
        (
            "diffuse-grid-error.png".into(),
            "<b>diffuse-grid-error.png</b>: the grid's relative error, on the same scale.".into(),
        ),
    ];
    if let Some(variants) = r.render.as_ref().and_then(|x| x.variants.as_ref()) {
        let heat = gradient("#000 0%,#f00 33.3%,#ff0 66.7%,#fff 100%");
        for (name, _) in &variants.0 {
            let name = escape(name);
            list.push((
                format!("render_{name}.png"),
                format!("<b>render_{name}.png</b>: the camera's view rendered through the probes ({name} march): direct light, the probes' irradiance and one glossy ray a pixel. Compare with reference.png."),
            ));
            list.push((
                format!("render_{name}-glossy.png"),
                format!("<b>render_{name}-glossy.png</b>: its glossy indirect part. Compare with reference-glossy.png."),
            ));
            list.push((
                format!("error_{name}.png"),
                format!("<b>error_{name}.png</b>: |luminance(glossy − reference glossy)|, {heat} from 0 (black) through red and yellow to 4× the reference glossy mean (white). Look for bright areas: where the probes misjudge reflections."),
            ));
        }
    }
    h.push_str("<h2 id=\"images\">Images</h2>\n<div class=\"row\">\n");
    let mut shown = 0;
    for (name, caption) in &list {
        let Some(png) = set.contents(name)? else {
            continue;
        };
        // Small images (the maps of a few probes, a test-size render) are
        // scaled up, pixels kept sharp.
        let class = match png_width(&png) {
            Some(w) if w < SMALL => "run small",
            _ => "run",
        };
        html::figure_with(h, &png, name, caption, class);
        shown += 1;
    }
    h.push_str("</div>\n");
    Ok(shown)
}

/// Images narrower than this many pixels are shown at this width.
const SMALL: u32 = 320;

/// The width of a PNG, from its header (`IHDR`, bytes 16–19).
fn png_width(png: &[u8]) -> Option<u32> {
    let w = png.get(16..20)?;
    Some(u32::from_be_bytes([w[0], w[1], w[2], w[3]]))
}

/// The run's warnings.
fn warnings(h: &mut String, r: &RunFigures) {
    if r.warnings.is_empty() {
        return;
    }
    h.push_str("<h2 id=\"warnings\">Warnings</h2>\n<ul>\n");
    for x in &r.warnings {
        let _ = writeln!(h, "<li>{}</li>", escape(x));
    }
    h.push_str("</ul>\n");
}

/// Every timing of the report, the GPU times and the reused files: the
/// one section that differs between runs of the same inputs.
fn timings(h: &mut String, r: &RunFigures) {
    h.push_str("<section id=\"timings\">\n<h2>Timings</h2>\n");
    let mut rows = Vec::new();
    let mut add = |prefix: &str, t: Option<&Ordered<Num>>| {
        for (k, v) in t.iter().flat_map(|m| &m.0) {
            rows.push(vec![escape(&format!("{prefix}{k}")), num(Some(*v))]);
        }
    };
    let (bake, render) = (r.bake.as_ref(), r.render.as_ref());
    add("", r.timings_ms.as_ref());
    add("bake.", bake.and_then(|b| b.timings_ms.as_ref()));
    add("render.", render.and_then(|x| x.timings_ms.as_ref()));
    if let Some(variants) = render.and_then(|x| x.variants.as_ref()) {
        for (name, v) in &variants.0 {
            for (key, ms) in [
                ("gpu_ms", v.gpu_ms),
                ("gpu_trace_ms", v.gpu_trace_ms),
                ("gpu_gather_ms", v.gpu_gather_ms),
            ] {
                if ms.is_some() {
                    rows.push(vec![escape(&format!("render.{name}.{key}")), num(ms)]);
                }
            }
        }
    }
    html::table(h, "timings-table", &["stage", "ms"], &rows);
    let reused: Vec<String> = r.reused.iter().map(|v| escape(v)).collect();
    if !reused.is_empty() {
        let _ = writeln!(
            h,
            "<p class=\"meta\">Reused from the earlier run (<code>--from</code>): {}.</p>",
            reused.join(", ")
        );
    }
    h.push_str("</section>\n");
}
