//! `report.html` of `compare`: the comparison at a glance, in one
//! self-contained file (images inlined as base64 PNG, plots as inline SVG,
//! the 3D view with three.js inlined, nothing fetched), so it opens in a
//! browser with no network and can be mailed or attached to a review as it
//! is. The page frame and the helpers here (head and tail, tables,
//! figures, escaping) serve the run report too ([`super::run_html`]).
//!
//! The plots are drawn here as SVG rather than with a plotting crate: two
//! scatter plots need only axes, ticks and polylines, and hand-written SVG
//! keeps the page byte-identical from run to run without font files.

use crate::report::compare::{
    CompareReport, Comparison, Family, Matched, PlacementRow, Ratio, QUALITY, TRACER_BILEVEL,
    TRACER_HIZ,
};
use crate::report::diffuse::{DiffuseComparison, DiffuseSection};
use crate::stages::validate::{Metric, METRICS};
use crate::stats::Interval;
use std::fmt::Write as _;

pub use super::markup::{base64, escape};

/// The images of one placement, PNG-encoded.
pub struct PlacementFigures {
    /// Top and side views of the probes (as `placement.png`).
    pub views: Vec<u8>,
    /// The validation render from each camera.
    pub renders: Vec<Vec<u8>>,
    /// The glossy-error heat map from each camera.
    pub errors: Vec<Vec<u8>>,
    /// The ꟻLIP error map from each camera.
    pub flips: Vec<Vec<u8>>,
}

/// Every image of the page, PNG-encoded.
pub struct Figures {
    /// The path-traced reference from each camera.
    pub references: Vec<Vec<u8>>,
    /// Per placement, in the order of `CompareReport::placements`.
    pub placements: Vec<PlacementFigures>,
    /// The 3D view: the scene and every placement's probes.
    pub view: super::view3d::View3d,
    /// The diffuse benchmark's lit views of the first camera.
    pub lit: Option<LitFigures>,
}

/// One view lit by the probes' blended diffuse light: the reference, and
/// per placement shown its render and relative-error map.
pub(crate) struct LitFigures {
    /// The path-traced reference, PNG.
    pub reference: Vec<u8>,
    /// Per placement: its name, its render and its error map (PNG), and
    /// its mean relative error over the view's pixels.
    pub placements: Vec<(String, Vec<u8>, Vec<u8>, f64)>,
}

/// The page for `report` with `figures`.
///
/// Contract: deterministic; every `<img>` is a `data:image/png;base64` URI
/// and nothing refers outside the file; text is HTML-escaped.
pub fn page(report: &CompareReport, figures: &Figures) -> String {
    let mut h = String::with_capacity(1 << 20);
    let scene = escape(&report.scene);
    head(&mut h, &format!("probeplace compare: {}", report.scene));
    let _ = writeln!(h, "<h1>Probe placement compared: {scene}</h1>");
    let _ = writeln!(
        h,
        "<p class=\"meta\">config <code>{}</code> · seed {} · every placement traced by Wang's Hi-Z march and SVO selection (<code>hiz+svo</code>), the grids also by McGuire's bi-level march and grid selection (<code>bilevel+grid</code>), on <b>{}</b> · \
         {}×{} pixels, {} glossy rays per pixel · {} view(s), {} chosen from the scene · materials <code>{}</code> · equal performance by <code>{}</code></p>",
        escape(&report.config),
        report.seed,
        escape(&report.adapter),
        report.width,
        report.height,
        report.glossy_rays,
        report.cameras.len(),
        report.cameras.iter().filter(|c| c.chosen).count(),
        escape(&report.materials),
        report.performance_metric
    );
    summary(&mut h, report);
    if let Some(d) = &report.diffuse {
        diffuse_section(&mut h, d, figures.lit.as_ref());
    }
    ratios_table(&mut h, report);
    placements_table(&mut h, report);
    figures.view.section(
        &mut h,
        "Every placement of the table in the scene: choose one with the selector.",
    );
    matches_table(&mut h, report);

    h.push_str(
        "<h2 id=\"plots\">Error and coverage against probe count</h2>\n<div class=\"plots\">\n",
    );
    h.push_str(&plot(
        "Filtered glossy indirect MSE (lower is better)",
        "probes",
        "MSE",
        true,
        report,
        |r| r.error(),
    ));
    h.push_str(&plot(
        "Coverage (higher is better)",
        "probes",
        "coverage",
        false,
        report,
        |r| r.coverage,
    ));
    h.push_str("</div>\n");

    h.push_str("<h2 id=\"references\">Path-traced reference</h2>\n<div class=\"row\">\n");
    for (i, png) in figures.references.iter().enumerate() {
        figure(&mut h, png, &format!("view {i}"), "reference");
    }
    h.push_str("</div>\n");

    h.push_str("<h2 id=\"gallery\">Placements, renders and glossy error</h2>\n");
    let _ = writeln!(h, "<p>Top and side views: probes as dots, surface samples no probe sees in red. MSE maps: black where the glossy indirect light matches the reference, through red and yellow to white at four times its mean. ꟻLIP maps: the perceptual error of the filtered glossy indirect, dark (none) to bright (large), in ꟻLIP's magma colours. Renders and maps of the first {} view(s), for ours, the equal-count grid and the competitors; every view is measured.</p>", figures.references.len());
    for (row, fig) in report.placements.iter().zip(&figures.placements) {
        let _ = writeln!(
            h,
            "<section class=\"card {}\"><h3>{} <small>{} · {} · {} probes{}</small></h3>\n<div class=\"row\">",
            row.family.key(),
            escape(&row.name),
            row.family.label(),
            row.tracer,
            row.probes,
            Metric::paired()
                .map(|m| format!(" · {} {}", m.entry().label, m.entry().show.cell(row.means[m])))
                .collect::<String>()
        );
        figure(&mut h, &fig.views, "top and side views", "views");
        for (i, ((render, error), flip)) in fig
            .renders
            .iter()
            .zip(&fig.errors)
            .zip(&fig.flips)
            .enumerate()
        {
            figure(&mut h, render, &format!("render, view {i}"), "render");
            figure(&mut h, error, &format!("glossy MSE, view {i}"), "error");
            figure(&mut h, flip, &format!("ꟻLIP, view {i}"), "error");
        }
        h.push_str("</div></section>\n");
    }
    if !report.warnings.is_empty() {
        h.push_str("<h2>Warnings</h2>\n<ul>\n");
        for w in &report.warnings {
            let _ = writeln!(h, "<li>{}</li>", escape(w));
        }
        h.push_str("</ul>\n");
    }
    tail(&mut h, count_figures(figures), Some(&figures.view));
    h
}

/// Opens a page: the doctype, the head (title, the style sheet, a content
/// policy that forbids every fetch, the error log's listeners) and
/// `<body>`.
///
/// The policy makes "self-contained" checkable: images may only be
/// `data:` URIs, scripts only inline or the `blob:` modules of the 3D view
/// ([`super::view3d`]), and anything else the page tried to load would be
/// refused and logged.
pub(crate) fn head(h: &mut String, title: &str) {
    let _ = write!(
        h,
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n\
         <meta http-equiv=\"Content-Security-Policy\" content=\"{POLICY}\">\n\
         <title>{}</title>\n<style>{STYLE}{}</style>\n<script>{ERRORS}</script>\n</head>\n<body>\n",
        escape(title),
        super::view3d::STYLE
    );
}

/// Closes a page: the error log, the line saying how many of its
/// `figures` images decoded, the 3D view's data and scripts (when it has
/// one), `</body>`.
pub(crate) fn tail(h: &mut String, figures: usize, view: Option<&super::view3d::View3d>) {
    let _ = writeln!(
        h,
        "<pre id=\"page-errors\" data-count=\"0\" hidden></pre>\n\
         <p class=\"meta\" id=\"figures\">{figures} figures inlined.</p>\n<script>{CHECK}</script>"
    );
    if let Some(v) = view {
        v.scripts(h);
    }
    h.push_str("</body>\n</html>\n");
}

/// The page's content policy: nothing may be fetched.
const POLICY: &str = "default-src 'none'; img-src data:; style-src 'unsafe-inline'; script-src 'unsafe-inline' blob:";

/// Collects the page's errors (script errors, failed loads, refused
/// fetches, rejected promises, `console.error`) into `#page-errors`,
/// whose `data-count` says how many there were, so that a reader (or a
/// headless browser) sees a broken page as broken.
const ERRORS: &str = "(function(){var log=[];function show(){var e=document.getElementById('page-errors');\
if(!e){return;}e.textContent=log.join('\\n');e.dataset.count=log.length;e.hidden=log.length===0;}\
function add(m){log.push(String(m));show();}\
window.addEventListener('error',function(e){var t=e.target;if(t&&t!==window&&(t.src||t.href)){add('failed to load '+(t.src||t.href).slice(0,80));}\
else{add('error: '+e.message+' ('+(e.filename||'').slice(0,60)+':'+(e.lineno||0)+')');}},true);\
window.addEventListener('unhandledrejection',function(e){add('unhandled rejection: '+(e.reason&&e.reason.message||e.reason));});\
document.addEventListener('securitypolicyviolation',function(e){add('refused by the page policy: '+e.blockedURI+' ('+e.violatedDirective+')');});\
var ce=console.error;console.error=function(){add('console.error: '+Array.prototype.map.call(arguments,String).join(' '));return ce.apply(console,arguments);};\
document.addEventListener('DOMContentLoaded',show);})();";

/// Marks the page with how many of its images decoded, so a reader (or a
/// headless browser) sees at once whether the file arrived whole.
const CHECK: &str = "window.addEventListener('load',function(){var i=document.images,n=0;\
for(var k=0;k<i.length;k++){if(i[k].complete&&i[k].naturalWidth>0){n++;}}\
var p=document.getElementById('figures');p.dataset.decoded=n;p.dataset.total=i.length;\
p.textContent=n+' of '+i.length+' figures decoded.';});";

const STYLE: &str = "body{font-family:system-ui,sans-serif;margin:1.5em;color:#222;max-width:1400px}\
table{border-collapse:collapse;margin:1em 0;font-size:0.9em}th,td{border:1px solid #ccc;padding:3px 8px;text-align:right}\
th{background:#f2f2f2}td:first-child,th:first-child{text-align:left}tr.ours td{background:#eaf5ea;font-weight:600}\
.meta{color:#555;font-size:0.9em}.row{display:flex;flex-wrap:wrap;gap:8px}figure{margin:0}\
figcaption{font-size:0.8em;color:#555}img{display:block;max-width:100%;image-rendering:auto}\
.card{border:1px solid #ddd;border-radius:6px;padding:6px 10px;margin:10px 0}.card.ours{border-color:#5a5}\
h3 small{font-weight:normal;color:#666}.plots{display:flex;flex-wrap:wrap;gap:16px}\
.summary li{margin:0.3em 0}figure.run{max-width:620px}figure.run figcaption{font-size:0.85em;margin-top:3px}\
.sw{display:inline-block;width:11px;height:11px;margin:0 3px 0 6px;vertical-align:-1px;border:1px solid #888}\
.grad{display:inline-block;width:120px;height:11px;margin:0 4px;vertical-align:-1px;border:1px solid #888}\
#page-errors{color:#900;background:#fee;padding:6px;white-space:pre-wrap}\
.figures td:last-child,.figures th:last-child{text-align:left;color:#555}\
figure.small img{width:320px;image-rendering:pixelated}";

fn count_figures(f: &Figures) -> usize {
    f.references.len()
        + f.placements
            .iter()
            .map(|p| 1 + p.renders.len() + p.errors.len() + p.flips.len())
            .sum::<usize>()
}

/// One sentence per match of each of our placements.
fn summary(h: &mut String, report: &CompareReport) {
    h.push_str("<h2 id=\"summary\">Summary</h2>\n<ul class=\"summary\">\n");
    for c in &report.comparisons {
        if !ours_or_given(report, c) {
            continue;
        }
        let _ = write!(
            h,
            "<li><b>{}</b> ({} probes, filtered glossy MSE {}): ",
            escape(&c.placement),
            c.probes,
            sci(c.error)
        );
        for r in c.ratios.iter().filter(|r| r.family == Family::Grid) {
            let _ = write!(
                h,
                "at equal count, {} ({} probes) on <code>{}</code> has {} ({}); ",
                escape(&r.against),
                r.probes,
                r.tracer,
                r.intervals
                    .0
                    .iter()
                    .map(|(m, i)| format!("{} the {}", interval(i), m.entry().label))
                    .collect::<Vec<_>>()
                    .join(" and "),
                verdict(r)
            );
        }
        if c.equal_count.is_none() {
            h.push_str("no grid to match the count; ");
        }
        match (&c.equal_quality, c.probe_ratio_at_equal_quality) {
            (Some(m), Some(r)) => {
                let _ = write!(
                    h,
                    "for equal quality a grid needs {} ({} probes, <b>{:.2}×</b> as many); ",
                    escape(&m.grid),
                    m.probes,
                    r
                );
            }
            _ => {
                let largest = report
                    .placements
                    .iter()
                    .filter(|p| p.family == Family::Grid)
                    .map(|p| p.probes)
                    .max()
                    .unwrap_or(0);
                let _ = write!(
                    h,
                    "<b>no grid of the sweep reaches its quality</b> (largest: {largest} probes); "
                );
            }
        }
        match (&c.equal_performance, c.error_ratio_at_equal_performance) {
            (Some(m), Some(r)) => {
                let _ = writeln!(
                    h,
                    "at equal performance, {} has {:.2}× the error.</li>",
                    escape(&m.grid),
                    r
                );
            }
            _ => h.push_str("no grid to match the performance.</li>\n"),
        }
    }
    h.push_str("</ul>\n");
}

/// Whether `c` matches one of ours or a `--probes` set.
fn ours_or_given(report: &CompareReport, c: &Comparison) -> bool {
    report
        .placements
        .iter()
        .any(|p| p.name == c.placement && matches!(p.family, Family::Ours | Family::Given))
}

/// `value× [lo, hi]`, bold when the interval excludes 1.
fn interval(i: &Interval) -> String {
    let text = format!("{:.2}× [{:.2}, {:.2}]", i.value, i.lo, i.hi);
    if i.excludes_one() {
        format!("<b>{text}</b>")
    } else {
        text
    }
}

/// What a ratio's intervals say.
fn verdict(r: &Ratio) -> &'static str {
    match (r.win, r.loss) {
        (true, _) => "ours wins",
        (_, true) => "ours loses",
        _ => "no clear difference",
    }
}

/// A ratio with its interval, or a dash.
fn maybe_interval(i: &Option<Interval>) -> String {
    i.as_ref().map_or_else(|| "–".into(), interval)
}

/// A mean relative error as a percentage, or a dash.
fn percent(v: Option<f64>) -> String {
    v.map_or_else(|| "–".into(), |x| format!("{:.1}%", 100.0 * x))
}

/// The diffuse benchmark: what it measured with, ours against each rival
/// at equal count, the count ours needs for the grid's error, the curve of
/// error against count, every placement's figures, and the lit views.
fn diffuse_section(h: &mut String, d: &DiffuseSection, lit: Option<&LitFigures>) {
    let s = &d.setup;
    let e = &s.emitters;
    let mut lights: Vec<String> = e
        .emissive_materials
        .iter()
        .map(|m| {
            format!(
                "emissive material <code>{}</code> (Ke {:.3} {:.3} {:.3}, {} triangles)",
                escape(&m.name),
                m.emission[0],
                m.emission[1],
                m.emission[2],
                m.triangles
            )
        })
        .collect();
    for (n, what) in [
        (e.point_lights, "point"),
        (e.spot_lights, "spot"),
        (e.directional_lights, "directional"),
    ] {
        if n > 0 {
            lights.push(format!("{n} {what} light(s)"));
        }
    }
    if e.sky {
        lights.push("a sky".into());
    }
    if lights.is_empty() {
        lights.push("nothing: every probe is black".into());
    }
    let _ = writeln!(
        h,
        "<h2 id=\"diffuse\">Diffuse light, as engines blend probes</h2>\n<p>On the scene's own materials, as engines bake probe light. Irradiance at {} surface points the views see and {} points in the free space the cameras reach ({:.1}% of the open space is cut off from them and holds no receiver), against a path-traced reference of {} paths each ({} bounces, the bake's). Each probe's light in SH L2 ({} directions) is blended over a Delaunay tetrahedralization of the probes that do not stand in solid, as Unity and Godot blend light probes. <b>Baked</b> light is what a mixed-lighting probe holds (everything but the point, spot and directional lights' direct light, which the renderer shades itself); <b>total</b> adds that direct light. Errors are mean relative errors of the luminance (against at least 5% of the mean); a leak is a receiver whose baked light is 2× too much or too little. Ratios are the rival's error over ours at equal count (above 1: ours is better) with 95% intervals from a paired bootstrap over views (surface) and runs of receivers (free space).</p>\n<p>Lit by: {}. The blend's own limit, a probe at every surface receiver: {} baked surface error.</p>",
        s.surface_receivers,
        s.free_receivers,
        100.0 * s.unreachable_fraction,
        s.reference_rays,
        s.bounces,
        s.probe_rays,
        lights.join("; "),
        percent(s.limit)
    );
    h.push_str("<table id=\"diffuse-ratios\">\n<tr><th>ours</th><th>rival</th><th>kind</th><th>probes</th><th>baked, surface</th><th>total, surface</th><th>baked, free space</th><th>total, free space</th><th>leaks, surface</th><th>leaks, free space</th><th>verdict</th></tr>\n");
    for c in &d.comparisons {
        let _ = writeln!(
            h,
            "<tr class=\"{}\"><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>",
            c.family.key(),
            escape(&c.ours),
            escape(&c.rival),
            c.family.label(),
            c.probes,
            maybe_interval(&c.surface_baked),
            maybe_interval(&c.surface_total),
            maybe_interval(&c.free_baked),
            maybe_interval(&c.free_total),
            maybe_interval(&c.surface_leaks),
            maybe_interval(&c.free_leaks),
            diffuse_verdict(c),
        );
    }
    h.push_str("</table>\n");
    if let Some(q) = &d.equal_error {
        let _ = match (q.ours_probes, q.count_ratio) {
            (Some(n), Some(r)) => writeln!(
                h,
                "<p id=\"equal-error\"><b>Equal error.</b> {} reaches the error of {} ({} probes, baked surface error {}) with {}{:.1} probes: <b>{:.2}×</b> the grid's count.</p>",
                escape(&q.ours),
                escape(&q.grid),
                q.grid_probes,
                percent(Some(q.grid_error)),
                if q.bound { "at most " } else { "" },
                n,
                r
            ),
            _ => writeln!(
                h,
                "<p id=\"equal-error\"><b>Equal error.</b> No count of {} measured reaches the error of {} ({} probes, baked surface error {}).</p>",
                escape(&q.ours),
                escape(&q.grid),
                q.grid_probes,
                percent(Some(q.grid_error))
            ),
        };
    }
    h.push_str("<div class=\"plots\">\n");
    let points: Vec<Point> = d
        .placements
        .iter()
        .filter_map(|r| {
            let y = r.surface.baked?;
            (y.is_finite() && y > 0.0).then_some(Point {
                family: r.family,
                name: &r.name,
                tracer: "",
                probes: r.probes,
                y,
            })
        })
        .collect();
    h.push_str(&plot_of(
        "Baked diffuse error at surface receivers (lower is better)",
        "probes",
        "mean relative error",
        true,
        &points,
        Join::EveryFamily,
    ));
    h.push_str("</div>\n");
    h.push_str("<table id=\"diffuse-placements\">\n<tr><th>placement</th><th>kind</th><th>probes</th><th>in solid</th><th>in sealed space</th><th>idle</th><th>baked, surface</th><th>total, surface</th><th>leaks, surface</th><th>baked, free</th><th>total, free</th><th>leaks, free</th></tr>\n");
    for r in &d.placements {
        let _ = writeln!(
            h,
            "<tr class=\"{}\"><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>",
            r.family.key(),
            escape(&r.name),
            r.family.label(),
            r.probes,
            r.invalid_probes,
            r.unreachable_probes,
            r.idle_probes,
            percent(r.surface.baked),
            percent(r.surface.total),
            percent(r.surface.leaks),
            percent(r.free.baked),
            percent(r.free.total),
            percent(r.free.leaks),
        );
    }
    h.push_str("</table>\n");
    if let Some(l) = lit {
        h.push_str("<h3 id=\"diffuse-views\">The first view lit by each placement's blended diffuse light</h3>\n<p>Each pixel: its emission and the point, spot and directional lights' direct light, plus its albedo times the baked irradiance, from the path tracer (reference) or from the probes' SH blended over tetrahedra. Error maps: the relative error of the baked irradiance, black at 0, through red and yellow to white at 100% and more.</p>\n<div class=\"row\">\n");
        figure(h, &l.reference, "reference", "reference");
        h.push_str("</div>\n");
        for (name, render, error, mean) in &l.placements {
            let _ = writeln!(
                h,
                "<div class=\"row\"><h4>{} <small>mean relative error over the view {}</small></h4>",
                escape(name),
                percent(Some(*mean))
            );
            figure(h, render, &format!("{name}: lit by its probes"), "render");
            figure(h, error, &format!("{name}: relative error"), "error");
            h.push_str("</div>\n");
        }
    }
}

/// What a diffuse comparison's surface interval says.
fn diffuse_verdict(c: &DiffuseComparison) -> &'static str {
    match (c.win, c.loss) {
        (true, _) => "ours wins",
        (_, true) => "ours loses",
        _ => "no clear difference",
    }
}

/// Every ratio of our placements against their rivals, with intervals.
fn ratios_table(h: &mut String, report: &CompareReport) {
    h.push_str("<h2 id=\"ratios\">Ours against each rival at about equal count</h2>\n<p>Each ratio is the rival's pooled error over ours (above 1: ours is better), with its 95% interval from a two-stage paired bootstrap over views and 16-pixel blocks; it is a win only when every interval lies above 1. Ours is traced with <code>hiz+svo</code>; the rival's tracer is given: a grid on <code>hiz+svo</code> isolates placement, on <code>bilevel+grid</code> it is what engines trace today.</p>\n<table id=\"ratios-table\">\n<tr><th>ours</th><th>probes</th><th>rival</th><th>kind</th><th>tracer</th><th>probes</th>");
    for m in Metric::paired() {
        let _ = write!(h, "<th>{} ratio</th>", m.entry().label);
    }
    h.push_str("<th>verdict</th></tr>\n");
    for c in &report.comparisons {
        if !ours_or_given(report, c) {
            continue;
        }
        for r in &c.ratios {
            let _ = writeln!(
                h,
                "<tr class=\"{}\"><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td>{}<td>{}</td></tr>",
                r.family.key(),
                escape(&c.placement),
                c.probes,
                escape(&r.against),
                r.family.label(),
                r.tracer,
                r.probes,
                r.intervals
                    .0
                    .iter()
                    .map(|(_, i)| format!("<td>{}</td>", interval(i)))
                    .collect::<String>(),
                verdict(r)
            );
        }
    }
    h.push_str("</table>\n");
}

fn placements_table(h: &mut String, report: &CompareReport) {
    h.push_str("<h2 id=\"placements\">Placements</h2>\n<table id=\"placements-table\">\n<tr><th>placement</th><th>kind</th><th>probes</th><th>coverage</th><th>in solid</th><th>probe data</th><th>SVO</th><th>tracer</th>");
    for m in METRICS {
        let _ = write!(h, "<th>{}</th>", m.label);
    }
    h.push_str("<th>GPU ms</th>");
    let cams = report.cameras.len();
    if cams > 1 {
        for i in 0..cams {
            let _ = write!(h, "<th>{} view {i}</th>", QUALITY.entry().label);
        }
    }
    h.push_str("</tr>\n");
    for r in &report.placements {
        let _ = write!(
            h,
            "<tr class=\"{}\"><td>{}</td><td>{}</td><td>{}</td><td>{:.2}%</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td>{}<td>{}</td>",
            r.family.key(),
            escape(&r.name),
            r.family.label(),
            r.probes,
            100.0 * r.coverage,
            r.probes_in_solid,
            bytes(r.probe_bytes),
            bytes(r.svo_bytes),
            r.tracer,
            Metric::ALL
                .iter()
                .map(|&m| format!("<td>{}</td>", m.entry().show.cell(r.means[m])))
                .collect::<String>(),
            r.gpu_ms.map(|v| format!("{v:.1}")).unwrap_or_else(|| "–".into()),
        );
        if cams > 1 {
            for c in &r.cameras {
                let _ = write!(
                    h,
                    "<td>{}</td>",
                    QUALITY.entry().show.cell(c.figures[QUALITY])
                );
            }
        }
        h.push_str("</tr>\n");
    }
    h.push_str("</table>\n");
}

fn matches_table(h: &mut String, report: &CompareReport) {
    h.push_str("<h2 id=\"matches\">Matched grids</h2>\n<p>Equal count: the grid nearest in probe count. Errors are the glossy MSE after a 7×7 box filter of render and reference (sampling noise filtered out, as Wang et al. compare filtered glossy components). Equal quality: the smallest grid whose error is at or below the placement's. Equal performance: the grid nearest in ");
    h.push_str(report.performance_metric);
    h.push_str(".</p>\n<table id=\"matches-table\">\n<tr><th>placement</th><th>probes</th><th>equal count (hiz+svo)</th><th>grid error / ours</th><th>equal count (bilevel+grid)</th><th>grid error / ours</th><th>equal quality (hiz+svo)</th><th>grid probes / ours</th><th>equal quality (bilevel+grid)</th><th>grid probes / ours</th><th>equal performance (bilevel+grid)</th><th>grid error / ours</th></tr>\n");
    let cell = |m: &Option<Matched>| match m {
        Some(m) => format!("{} ({} probes)", escape(&m.grid), m.probes),
        None => "none in the sweep".into(),
    };
    let ratio = |r: Option<f64>| r.map(|v| format!("{v:.2}×")).unwrap_or_else(|| "–".into());
    for c in &report.comparisons {
        let Comparison {
            placement, probes, ..
        } = c;
        let class = report
            .placements
            .iter()
            .find(|p| &p.name == placement)
            .map(|p| p.family.key())
            .unwrap_or("");
        let _ = writeln!(
            h,
            "<tr class=\"{class}\"><td>{}</td><td>{probes}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>",
            escape(placement),
            cell(&c.equal_count),
            ratio(c.error_ratio_at_equal_count),
            cell(&c.equal_count_engine),
            ratio(c.error_ratio_at_equal_count_engine),
            cell(&c.equal_quality),
            ratio(c.probe_ratio_at_equal_quality),
            cell(&c.equal_quality_engine),
            ratio(c.probe_ratio_at_equal_quality_engine),
            cell(&c.equal_performance),
            ratio(c.error_ratio_at_equal_performance),
        );
    }
    h.push_str("</table>\n");
}

fn figure(h: &mut String, png: &[u8], caption: &str, class: &str) {
    figure_with(h, png, caption, &escape(caption), class);
}

/// A figure: the PNG inlined, `alt` text (escaped here) and a caption
/// already in HTML.
pub(crate) fn figure_with(h: &mut String, png: &[u8], alt: &str, caption_html: &str, class: &str) {
    let _ = writeln!(
        h,
        "<figure class=\"{class}\"><img alt=\"{}\" src=\"data:image/png;base64,{}\"><figcaption>{caption_html}</figcaption></figure>",
        escape(alt),
        base64(png),
    );
}

/// A table with `id`, a header row of `header` (escaped) and `rows` of
/// cells already in HTML, the first column left-aligned.
pub(crate) fn table(h: &mut String, id: &str, header: &[&str], rows: &[Vec<String>]) {
    let _ = write!(h, "<table id=\"{id}\">\n<tr>");
    for c in header {
        let _ = write!(h, "<th>{}</th>", escape(c));
    }
    h.push_str("</tr>\n");
    for r in rows {
        h.push_str("<tr>");
        for c in r {
            let _ = write!(h, "<td>{c}</td>");
        }
        h.push_str("</tr>\n");
    }
    h.push_str("</table>\n");
}

/// Plot area and margins of the SVG plots, in pixels.
const PLOT_W: f64 = 560.0;
const PLOT_H: f64 = 340.0;
const LEFT: f64 = 70.0;
const BOTTOM: f64 = 45.0;
const TOP: f64 = 30.0;
const RIGHT: f64 = 170.0;

/// A point of a plot: its placement, its probe count (x) and its value (y).
struct Point<'a> {
    family: Family,
    name: &'a str,
    /// The tracer of a glossy row; empty for the diffuse benchmark's.
    tracer: &'a str,
    probes: usize,
    y: f64,
}

/// Which points a plot joins by lines.
#[derive(Clone, Copy, PartialEq)]
enum Join {
    /// The grid sweep on each tracer (the glossy plots).
    GridByTracer,
    /// Every family's points, by count (the diffuse curves).
    EveryFamily,
}

/// A scatter plot of `y(row)` against probe count (log scale), the grid
/// sweep joined by a line; `log_y` puts y on a log scale too.
fn plot(
    title: &str,
    x_label: &str,
    y_label: &str,
    log_y: bool,
    report: &CompareReport,
    y: impl Fn(&PlacementRow) -> f64,
) -> String {
    let points: Vec<Point> = report
        .placements
        .iter()
        .map(|r| Point {
            family: r.family,
            name: &r.name,
            tracer: r.tracer,
            probes: r.probes,
            y: y(r),
        })
        .collect();
    plot_of(title, x_label, y_label, log_y, &points, Join::GridByTracer)
}

/// A scatter plot of `points` (probe count on a log scale), joined as
/// `join` says; `log_y` puts y on a log scale too.
fn plot_of(
    title: &str,
    x_label: &str,
    y_label: &str,
    log_y: bool,
    points: &[Point],
    join: Join,
) -> String {
    let points: Vec<&Point> = points
        .iter()
        .filter(|p| p.y.is_finite() && (!log_y || p.y > 0.0))
        .collect();
    let mut s = String::new();
    plot_header(&mut s, title);
    if points.is_empty() {
        s.push_str("</svg>\n");
        return s;
    }
    let frame = PlotFrame {
        xs: Axis::new(points.iter().map(|p| p.probes.max(1) as f64), true),
        ys: Axis::new(points.iter().map(|p| p.y), log_y),
    };
    plot_axes(&mut s, &frame, x_label, y_label);
    plot_lines(&mut s, &frame, &points, join);
    plot_points(&mut s, &frame, &points, join);
    plot_legend(&mut s, &points, join);
    s.push_str("</svg>\n");
    s
}

/// Width and height of the whole SVG, margins included.
const SVG_SIZE: (f64, f64) = (LEFT + PLOT_W + RIGHT, TOP + PLOT_H + BOTTOM);

/// Opens the SVG: its size, a white background and `title` centred over the plot area.
fn plot_header(s: &mut String, title: &str) {
    let (w, hgt) = SVG_SIZE;
    let _ = writeln!(
        s,
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{w}\" height=\"{hgt}\" viewBox=\"0 0 {w} {hgt}\" font-family=\"sans-serif\" font-size=\"12\">"
    );
    s.push_str("<rect width=\"100%\" height=\"100%\" fill=\"#fff\"/>\n");
    let _ = writeln!(
        s,
        "<text x=\"{}\" y=\"18\" text-anchor=\"middle\" font-size=\"14\">{}</text>",
        LEFT + PLOT_W / 2.0,
        escape(title)
    );
}

/// The two axes of a plot, mapping data to SVG coordinates.
struct PlotFrame {
    xs: Axis,
    ys: Axis,
}

impl PlotFrame {
    /// SVG x of data x.
    fn px(&self, x: f64) -> f64 {
        LEFT + self.xs.unit(x) * PLOT_W
    }

    /// SVG y of data y.
    fn py(&self, v: f64) -> f64 {
        TOP + (1.0 - self.ys.unit(v)) * PLOT_H
    }
}

/// The plot area's border, the grid lines and labels of the ticks on both
/// axes, and the axis labels.
fn plot_axes(s: &mut String, frame: &PlotFrame, x_label: &str, y_label: &str) {
    let _ = writeln!(
        s,
        "<rect x=\"{LEFT}\" y=\"{TOP}\" width=\"{PLOT_W}\" height=\"{PLOT_H}\" fill=\"none\" stroke=\"#888\"/>"
    );
    for t in frame.xs.ticks() {
        let x = frame.px(t);
        let _ = writeln!(
            s,
            "<line x1=\"{x:.1}\" y1=\"{TOP}\" x2=\"{x:.1}\" y2=\"{:.1}\" stroke=\"#eee\"/><text x=\"{x:.1}\" y=\"{:.1}\" text-anchor=\"middle\">{}</text>",
            TOP + PLOT_H,
            TOP + PLOT_H + 16.0,
            tick_label(t)
        );
    }
    for t in frame.ys.ticks() {
        let yy = frame.py(t);
        let _ = writeln!(
            s,
            "<line x1=\"{LEFT}\" y1=\"{yy:.1}\" x2=\"{:.1}\" y2=\"{yy:.1}\" stroke=\"#eee\"/><text x=\"{:.1}\" y=\"{:.1}\" text-anchor=\"end\">{}</text>",
            LEFT + PLOT_W,
            LEFT - 6.0,
            yy + 4.0,
            tick_label(t)
        );
    }
    let _ = writeln!(
        s,
        "<text x=\"{}\" y=\"{}\" text-anchor=\"middle\">{}</text><text transform=\"translate(16 {}) rotate(-90)\" text-anchor=\"middle\">{}</text>",
        LEFT + PLOT_W / 2.0,
        SVG_SIZE.1 - 8.0,
        escape(x_label),
        TOP + PLOT_H / 2.0,
        escape(y_label)
    );
}

/// The lines joining the points `join` names, in order of probe count,
/// where a line has more than one point.
fn plot_lines(s: &mut String, frame: &PlotFrame, points: &[&Point], join: Join) {
    let lines: Vec<(Family, &str, &str)> = match join {
        Join::GridByTracer => vec![
            (Family::Grid, TRACER_HIZ, ""),
            (Family::Grid, TRACER_BILEVEL, " stroke-dasharray=\"5 3\""),
        ],
        Join::EveryFamily => Family::all().into_iter().map(|f| (f, "", "")).collect(),
    };
    for (family, tracer, dash) in lines {
        let mut on: Vec<&&Point> = points
            .iter()
            .filter(|p| p.family == family && p.tracer == tracer)
            .collect();
        on.sort_by(|a, b| a.probes.cmp(&b.probes).then(a.y.total_cmp(&b.y)));
        if on.len() > 1 {
            let line: Vec<String> = on
                .iter()
                .map(|p| {
                    format!(
                        "{:.1},{:.1}",
                        frame.px(p.probes.max(1) as f64),
                        frame.py(p.y)
                    )
                })
                .collect();
            let what = match join {
                Join::GridByTracer => format!("grids on {tracer}"),
                Join::EveryFamily => family.label().to_string(),
            };
            let _ = writeln!(
                s,
                "<polyline fill=\"none\" stroke=\"{}\" stroke-width=\"1.5\"{dash} points=\"{}\"><title>{}</title></polyline>",
                family.marker().0,
                line.join(" "),
                escape(&what)
            );
        }
    }
}

/// A marker per point with a tooltip, and beside every point not on a
/// line its placement's name.
fn plot_points(s: &mut String, frame: &PlotFrame, points: &[&Point], join: Join) {
    for p in points {
        let (color, shape) = p.family.marker();
        let (cx, cy) = (frame.px(p.probes.max(1) as f64), frame.py(p.y));
        let tracer = if p.tracer.is_empty() {
            String::new()
        } else {
            format!(" ({})", p.tracer)
        };
        let _ = writeln!(
            s,
            "{}<title>{}{}: {} probes, {}</title></g>",
            marker(shape, color, cx, cy),
            escape(p.name),
            tracer,
            p.probes,
            sci(p.y)
        );
        if join == Join::GridByTracer && p.family != Family::Grid {
            let _ = writeln!(
                s,
                "<text x=\"{:.1}\" y=\"{:.1}\" font-size=\"10\" fill=\"{color}\">{}</text>",
                cx + 7.0,
                cy - 6.0,
                escape(p.name)
            );
        }
    }
}

/// The legend right of the plot area: a marker and label for each family
/// that has points.
fn plot_legend(s: &mut String, points: &[&Point], join: Join) {
    let mut ly = TOP + 10.0;
    for f in Family::all() {
        if !points.iter().any(|p| p.family == f) {
            continue;
        }
        let (color, shape) = f.marker();
        let lx = LEFT + PLOT_W + 16.0;
        let _ = writeln!(
            s,
            "{}</g><text x=\"{:.1}\" y=\"{:.1}\" font-size=\"11\">{}</text>",
            marker(shape, color, lx, ly),
            lx + 10.0,
            ly + 4.0,
            escape(&match (f, join) {
                (Family::Grid, Join::GridByTracer) => format!("{} (dashed: bilevel)", f.label()),
                _ => f.label().to_string(),
            })
        );
        ly += 18.0;
    }
}

/// An open `<g>` holding a marker at (x, y); the caller closes it.
fn marker(shape: &str, color: &str, x: f64, y: f64) -> String {
    let body = match shape {
        "circle" => format!("<circle cx=\"{x:.1}\" cy=\"{y:.1}\" r=\"5\"/>"),
        "square" => format!(
            "<rect x=\"{:.1}\" y=\"{:.1}\" width=\"8\" height=\"8\"/>",
            x - 4.0,
            y - 4.0
        ),
        "diamond" => format!(
            "<polygon points=\"{:.1},{:.1} {:.1},{:.1} {:.1},{:.1} {:.1},{:.1}\"/>",
            x,
            y - 6.0,
            x + 6.0,
            y,
            x,
            y + 6.0,
            x - 6.0,
            y
        ),
        _ => format!(
            "<polygon points=\"{:.1},{:.1} {:.1},{:.1} {:.1},{:.1}\"/>",
            x,
            y - 6.0,
            x + 6.0,
            y + 5.0,
            x - 6.0,
            y + 5.0
        ),
    };
    format!("<g fill=\"{color}\" stroke=\"#fff\" stroke-width=\"0.8\">{body}")
}

/// A plot axis: a padded range, linear or logarithmic.
struct Axis {
    lo: f64,
    hi: f64,
    log: bool,
}

impl Axis {
    fn new(values: impl Iterator<Item = f64>, log: bool) -> Axis {
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for v in values {
            let v = if log { v.log10() } else { v };
            lo = lo.min(v);
            hi = hi.max(v);
        }
        let pad = if hi > lo { 0.06 * (hi - lo) } else { 0.5 };
        Axis {
            lo: lo - pad,
            hi: hi + pad,
            log,
        }
    }

    /// Position of `v` along the axis, 0 to 1.
    fn unit(&self, v: f64) -> f64 {
        let v = if self.log { v.log10() } else { v };
        (v - self.lo) / (self.hi - self.lo)
    }

    /// Tick values inside the range: 1, 2, 5 × 10ᵏ on a log axis (decades
    /// alone when they are enough), about six round steps on a linear one.
    fn ticks(&self) -> Vec<f64> {
        if self.log {
            let decades = self.hi - self.lo;
            let mantissas: &[f64] = if decades > 3.0 {
                &[1.0]
            } else {
                &[1.0, 2.0, 5.0]
            };
            let mut out = Vec::new();
            for k in (self.lo.floor() as i32)..=(self.hi.ceil() as i32) {
                for m in mantissas {
                    let v = m * 10f64.powi(k);
                    if (self.lo..=self.hi).contains(&v.log10()) {
                        out.push(v);
                    }
                }
            }
            out
        } else {
            let raw = (self.hi - self.lo) / 6.0;
            let mag = 10f64.powf(raw.log10().floor());
            let step = [1.0, 2.0, 5.0, 10.0]
                .iter()
                .map(|m| m * mag)
                .find(|s| *s >= raw)
                .unwrap_or(10.0 * mag);
            let mut v = (self.lo / step).ceil() * step;
            let mut out = Vec::new();
            while v <= self.hi {
                out.push(v);
                v += step;
            }
            out
        }
    }
}

fn tick_label(v: f64) -> String {
    if v != 0.0 && (v.abs() < 1e-2 || v.abs() >= 1e5) {
        format!("{v:.0e}")
    } else if v.fract() == 0.0 {
        format!("{v:.0}")
    } else {
        let s = format!("{v:.3}");
        s.trim_end_matches('0').to_string()
    }
}

/// `v` in scientific notation with three significant digits.
pub(crate) fn sci(v: f64) -> String {
    format!("{v:.3e}")
}

/// A byte count in B, KiB or MiB.
pub(crate) fn bytes(b: u64) -> String {
    match b {
        0..=9_999 => format!("{b} B"),
        10_000..=9_999_999 => format!("{:.1} KiB", b as f64 / 1024.0),
        _ => format!("{:.1} MiB", b as f64 / (1024.0 * 1024.0)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn log_ticks_are_round_and_inside_the_range() {
        let a = Axis::new([3.0, 250.0].into_iter(), true);
        let t = a.ticks();
        assert!(t.contains(&10.0) && t.contains(&100.0), "{t:?}");
        assert!(t.iter().all(|v| (a.lo..=a.hi).contains(&v.log10())));
        let lin = Axis::new([0.91, 1.0].into_iter(), false);
        let t = lin.ticks();
        assert!(t.len() >= 3 && t.len() <= 12, "{t:?}");
    }
}
