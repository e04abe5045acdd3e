//! `compare.json` and `compare.csv`: every placement measured alike, and
//! the three matches Wang et al. 2019 §5 draws against uniform grids
//! (Figs. 8–12, Tables 1–2): equal probe count, equal quality and equal
//! performance.

use crate::placement::method::Role;
use crate::placement::registry::METHODS;
use crate::stages::validate::{Blocks, Metric, PerMetric};
use crate::stats::{paired_ratio_over_views, Interval, RESAMPLES};
use rayon::prelude::*;
use serde::Serialize;
use std::collections::BTreeMap;
use std::fmt::Write as _;

/// Wang et al. 2019's tracer: Hi-Z march, SVO selection.
pub const TRACER_HIZ: &str = "hiz+svo";
/// McGuire et al. 2017's tracer, for lattices: bi-level march, the cell's
/// eight probes.
pub const TRACER_BILEVEL: &str = "bilevel+grid";

/// Which kind of placement a row is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Family {
    /// Ours: a skeleton placement refined (Wang et al. 2019 §3).
    Ours,
    /// A uniform grid of the sweep (McGuire et al. 2017).
    Grid,
    /// A competitor of the list of methods (`Role::Competitor`: RTXGI's
    /// relocated grid, Silvennoinen & Lehtinen's greedy placement, Unity's
    /// adaptive probe volumes), by its `--method` word.
    Competitor(&'static str),
    /// A probe set made elsewhere (`--probes FILE.json`), scored as given.
    Given,
}

impl Family {
    /// The name in `compare.json` and `compare.csv`.
    pub fn key(self) -> &'static str {
        match self {
            Family::Ours => "ours",
            Family::Grid => "grid",
            Family::Competitor(word) => word,
            Family::Given => "given",
        }
    }

    /// The competitor's entry of the list of methods.
    fn method(self) -> Option<&'static crate::placement::method::Entry> {
        match self {
            Family::Competitor(word) => METHODS.iter().find(|m| m.word == word),
            _ => None,
        }
    }

    /// The name in tables.
    pub fn label(self) -> &'static str {
        match self {
            Family::Ours => "ours",
            Family::Grid => "uniform grid",
            Family::Competitor(word) => self.method().map_or(word, |m| m.label),
            Family::Given => "given (--probes)",
        }
    }

    /// Colour and marker in the plots.
    pub fn marker(self) -> (&'static str, &'static str) {
        match self {
            Family::Ours => ("#2a8a2a", "circle"),
            Family::Grid => ("#3060c0", "square"),
            Family::Competitor(_) => self.method().map_or(("#808080", "circle"), |m| m.marker),
            Family::Given => ("#202020", "circle"),
        }
    }

    /// Every family in the order of tables and legends: ours, the grids,
    /// the competitors in the list's order, a given set.
    pub fn all() -> Vec<Family> {
        let mut out = vec![Family::Ours, Family::Grid];
        out.extend(
            METHODS
                .iter()
                .filter(|m| m.role == Role::Competitor)
                .map(|m| Family::Competitor(m.word)),
        );
        out.push(Family::Given);
        out
    }
}

impl Serialize for Family {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.key())
    }
}

/// The quality figure the matches use, and the paired figure the
/// summaries quote: the filtered glossy MSE.
pub const QUALITY: Metric = Metric::MseGlossyFiltered;

/// The cost figure equal performance falls back to without GPU times.
pub const WORK: Metric = Metric::TexelFetchesPerRay;

/// Each paired metric's interval ([`Metric::paired`]), by key, in the
/// list's order.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Intervals(pub Vec<(Metric, Interval)>);

impl Intervals {
    /// The interval of `m`, when it is paired.
    pub fn of(&self, m: Metric) -> Option<&Interval> {
        self.0.iter().find(|(k, _)| *k == m).map(|(_, i)| i)
    }
}

impl Serialize for Intervals {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeMap;
        let mut map = s.serialize_map(Some(self.0.len()))?;
        for (m, i) in &self.0 {
            map.serialize_entry(m.entry().key, i)?;
        }
        map.end()
    }
}

/// One placement seen from one camera: the validation's figures.
pub type CameraRow = crate::stages::validate::Metrics;

/// One placement, measured.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PlacementRow {
    /// Unique name, e.g. `sdf-skeleton` or `grid:4x2x4`.
    pub name: String,
    /// What kind of placement it is.
    pub family: Family,
    /// The tracer: `hiz+svo` (Wang et al. 2019) for every placement, and
    /// for each grid a second row with `bilevel+grid` (McGuire et al. 2017).
    pub tracer: &'static str,
    /// Probes placed.
    pub probes: usize,
    /// Fraction of the coverable surface some probe sees (the `place` measure).
    pub coverage: f64,
    /// Probes standing in solid space (SDF).
    pub probes_in_solid: usize,
    /// Bytes of the baked probe maps (`lightfield.bin`'s payload).
    pub probe_bytes: u64,
    /// Bytes of the SVO of probe indices (Wang et al. 2019 §4.1).
    pub svo_bytes: u64,
    /// Each metric's mean over cameras ([`crate::stages::validate::registry`]),
    /// by key. The matches compare [`QUALITY`]: at the sample counts a
    /// comparison can afford, the unfiltered MSE is mostly Monte Carlo
    /// noise that every placement shares; filtering leaves the errors
    /// placement causes.
    #[serde(flatten)]
    pub means: PerMetric<f64>,
    /// Mean over cameras of the distance from each shading point to the
    /// nearest probe that sees it ([`crate::stages::validate::shading_probe_distance`],
    /// world units): the parallax a glossy lookup suffers grows with it.
    /// `null` where no probe sees any shading point.
    pub shading_probe_distance: Option<f64>,
    /// Sum over cameras of [`CameraRow::gpu_ms`], where every camera has it.
    pub gpu_ms: Option<f64>,
    /// One row per camera, in the order of `CompareReport::cameras`.
    pub cameras: Vec<CameraRow>,
    /// The method's own statistics (what relocation moved, what the
    /// greedy removal kept, what refinement pruned).
    pub stats: BTreeMap<String, f64>,
    /// Per camera, the errors per pixel block the intervals resample (not
    /// written).
    #[serde(skip)]
    pub blocks: Vec<Blocks>,
    /// Diffuse light at the receivers ([`crate::diffuse`]); `null` when
    /// `compare.diffuse` measures no receiver.
    pub diffuse: Option<DiffuseRow>,
}

/// One lookup's mean relative irradiance errors ([`crate::diffuse::Errors`])
/// and its leaks; `null` where it has no such receivers or part.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DiffuseLookup {
    /// Total irradiance at the surface receivers.
    pub surface_total: Option<f64>,
    /// Indirect irradiance at the surface receivers.
    pub surface_indirect: Option<f64>,
    /// Total irradiance at the free-space receivers.
    pub free_total: Option<f64>,
    /// Indirect irradiance at the free-space receivers.
    pub free_indirect: Option<f64>,
    /// Share of every receiver lit [`crate::diffuse::LEAK_RATIO`] times too
    /// much or too little (total irradiance).
    pub leak_fraction: Option<f64>,
}

impl DiffuseLookup {
    fn of(m: &crate::stages::diffuse::Measured) -> DiffuseLookup {
        use crate::diffuse::mean;
        let leaks: Vec<f64> = m.surface.leak.iter().chain(&m.free.leak).copied().collect();
        DiffuseLookup {
            surface_total: mean(&m.surface.total),
            surface_indirect: mean(&m.surface.indirect),
            free_total: mean(&m.free.total),
            free_indirect: mean(&m.free.indirect),
            leak_fraction: mean(&leaks),
        }
    }
}

/// A placement's diffuse light as engines blend it.
#[derive(Debug, Clone, Serialize)]
pub struct DiffuseRow {
    /// SH L2 per probe blended over a Delaunay tetrahedralization of the
    /// valid probes (Unity's light probes, Godot's LightmapGI): the same
    /// for both rows of a grid.
    pub sh_tetrahedra: DiffuseLookup,
    /// McGuire et al. 2017 §5.2's irradiance gather with Chebyshev
    /// visibility, by the row's selection: every probe by inverse square
    /// distance (`hiz+svo`), or trilinear over the grid cell's eight
    /// (`bilevel+grid`, DDGI's blend). Total light only.
    pub gather: DiffuseLookup,
    /// Probes the SH blend drops as standing in solid.
    pub invalid_probes: usize,
    /// Probes in open space that no camera reaches (sealed voids,
    /// [`crate::reachable`]).
    pub unreachable_probes: usize,
    /// The errors per receiver the intervals resample (not written).
    #[serde(skip)]
    pub errors: crate::stages::diffuse::Measured,
}

impl PartialEq for DiffuseRow {
    fn eq(&self, o: &Self) -> bool {
        self.sh_tetrahedra == o.sh_tetrahedra
            && self.gather == o.gather
            && self.invalid_probes == o.invalid_probes
            && self.unreachable_probes == o.unreachable_probes
    }
}

impl DiffuseRow {
    /// The row of a placement measured as `m`, with the gather `gather`.
    pub fn new(
        m: &crate::stages::diffuse::DiffuseMeasure,
        gather: &crate::stages::diffuse::Measured,
    ) -> DiffuseRow {
        DiffuseRow {
            sh_tetrahedra: DiffuseLookup::of(&m.sh),
            gather: DiffuseLookup::of(gather),
            invalid_probes: m.invalid_probes,
            unreachable_probes: m.unreachable_probes,
            errors: m.sh.clone(),
        }
    }
}

/// A rival's diffuse errors over ours with the SH tetrahedral lookup, each
/// with its 95% paired-bootstrap interval over receiver groups (views for
/// surface receivers, runs of [`crate::diffuse::FREE_GROUP`] in free
/// space); above 1, ours has the lower error. `null` where a set is empty,
/// ours has no error there, or a resample has none (rare leaks).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DiffuseRatio {
    /// Indirect irradiance at surface receivers.
    pub surface_indirect: Option<Interval>,
    /// Total irradiance at surface receivers.
    pub surface_total: Option<Interval>,
    /// Indirect irradiance at free-space receivers.
    pub free_indirect: Option<Interval>,
    /// Total irradiance at free-space receivers.
    pub free_total: Option<Interval>,
    /// Leaking receivers, surface and free together.
    pub leak_fraction: Option<Interval>,
    /// The surface indirect interval lies wholly above 1.
    pub win: bool,
    /// It lies wholly below 1.
    pub loss: bool,
}

/// The diffuse ratios of `rival` over `ours`, when both have them.
fn diffuse_ratio(rival: &PlacementRow, ours: &PlacementRow, seed: u64) -> Option<DiffuseRatio> {
    let (a, b) = (
        &rival.diffuse.as_ref()?.errors,
        &ours.diffuse.as_ref()?.errors,
    );
    let interval = |x: &crate::diffuse::Errors,
                    y: &crate::diffuse::Errors,
                    f: fn(&crate::diffuse::Errors) -> &Vec<f64>| {
        let (num, den) = (x.by_group(f(x)), y.by_group(f(y)));
        let paired = !den.is_empty()
            && num.len() == den.len()
            && num.iter().zip(&den).all(|(p, q)| p.len() == q.len());
        let sum: f64 = den.iter().flatten().sum();
        // Rare events (a few leaking receivers) can resample to a zero
        // denominator: no interval then, rather than an infinite one.
        (paired && sum > 0.0)
            .then(|| paired_ratio_over_views(&num, &den, RESAMPLES, seed))
            .filter(|i| i.value.is_finite() && i.lo.is_finite() && i.hi.is_finite())
    };
    let leaks = |e: &crate::stages::diffuse::Measured| {
        let mut all = e.surface.clone();
        all.leak.extend(&e.free.leak);
        let offset = all.group.iter().max().map_or(0, |g| g + 1);
        all.group.extend(e.free.group.iter().map(|g| g + offset));
        all
    };
    let surface_indirect = interval(&a.surface, &b.surface, |e| &e.indirect);
    Some(DiffuseRatio {
        win: surface_indirect.is_some_and(|i| i.lo > 1.0),
        loss: surface_indirect.is_some_and(|i| i.hi < 1.0),
        surface_indirect,
        surface_total: interval(&a.surface, &b.surface, |e| &e.total),
        free_indirect: interval(&a.free, &b.free, |e| &e.indirect),
        free_total: interval(&a.free, &b.free, |e| &e.total),
        leak_fraction: interval(&leaks(a), &leaks(b), |e| &e.leak),
    })
}

/// The diffuse evaluation's set-up, in `compare.json`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DiffuseSetup {
    /// Surface receivers (primary hits of the views).
    pub surface_receivers: usize,
    /// Receivers in reachable free space.
    pub free_receivers: usize,
    /// Paths per receiver's reference.
    pub reference_rays: u32,
    /// Directions per probe's SH projection.
    pub probe_rays: u32,
    /// Indirect bounces of the references and the probes (the bake's).
    pub bounces: u32,
    /// Share of the open voxels no camera reaches (sealed voids, regions
    /// cut off by geometry): no free receiver stands there.
    pub unreachable_fraction: f64,
    /// Mean luminance of the reference irradiance, total and indirect, at
    /// the surface receivers.
    pub surface_reference_mean: [f64; 2],
    /// The same at the free receivers.
    pub free_reference_mean: [f64; 2],
}

/// A grid picked by one of the three matches.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Matched {
    /// The grid's name.
    pub grid: String,
    /// Its probe count.
    pub probes: usize,
    /// Its error ([`PlacementRow::error`]).
    pub error: f64,
    /// Its performance figure (see [`CompareReport::performance_metric`]).
    pub performance: f64,
}

/// One rival's errors over a placement's, with 95% intervals.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Ratio {
    /// The rival placement's name.
    pub against: String,
    /// Its family.
    pub family: Family,
    /// The tracer of its row (the placement's own is always `hiz+svo`).
    pub tracer: &'static str,
    /// Its probe count.
    pub probes: usize,
    /// Each paired metric's pooled error over ours, with its interval:
    /// above 1, ours has the lower error.
    #[serde(flatten)]
    pub intervals: Intervals,
    /// Every interval lies wholly above 1: ours wins on every paired
    /// metric.
    pub win: bool,
    /// Every interval lies wholly below 1: the rival wins on every one.
    pub loss: bool,
    /// The diffuse errors, SH over tetrahedra (`null` without the
    /// diffuse evaluation).
    pub diffuse: Option<DiffuseRatio>,
}

/// The three matches for one placement.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Comparison {
    /// The placement matched.
    pub placement: String,
    /// Its probe count.
    pub probes: usize,
    /// Its error ([`PlacementRow::error`]).
    pub error: f64,
    /// The grid whose probe count is nearest (ties: the larger grid), on
    /// the same tracer (`hiz+svo`): placement alone.
    pub equal_count: Option<Matched>,
    /// `equal_count`'s error over ours: above 1, ours has lower error.
    pub error_ratio_at_equal_count: Option<f64>,
    /// The same grid on McGuire's tracer (`bilevel+grid`): what engines
    /// trace today.
    pub equal_count_engine: Option<Matched>,
    /// `equal_count_engine`'s error over ours.
    pub error_ratio_at_equal_count_engine: Option<f64>,
    /// The smallest grid whose error is at or below ours on the same
    /// tracer; `None` when no grid of the sweep reaches our quality.
    pub equal_quality: Option<Matched>,
    /// `equal_quality`'s probe count over ours: above 1, ours needs fewer.
    pub probe_ratio_at_equal_quality: Option<f64>,
    /// The same on McGuire's tracer.
    pub equal_quality_engine: Option<Matched>,
    /// `equal_quality_engine`'s probe count over ours.
    pub probe_ratio_at_equal_quality_engine: Option<f64>,
    /// The grid, on McGuire's tracer, whose performance figure is nearest
    /// ours (the paper's equal-performance match: today's engine at our
    /// cost).
    pub equal_performance: Option<Matched>,
    /// `equal_performance`'s error over ours.
    pub error_ratio_at_equal_performance: Option<f64>,
    /// Every rival at about our count, with intervals: the equal-count
    /// grid on each tracer, and each non-grid placement of another family
    /// (relocated, greedy, adaptive; for ours also the other method).
    pub ratios: Vec<Ratio>,
}

/// A camera the placements are measured from.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CameraRecord {
    /// Eye position, world coordinates as in the config.
    pub position: [f64; 3],
    /// Point looked at, world coordinates as in the config.
    pub look_at: [f64; 3],
    /// Vertical field of view.
    pub fov_degrees: f32,
    /// Chosen from the scene (`compare.views`) rather than given.
    pub chosen: bool,
    /// Mean of the reference's glossy indirect component, per channel.
    pub reference_glossy_mean: [f64; 3],
}

/// `compare.json`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CompareReport {
    /// `"probeplace.compare"`.
    pub format: &'static str,
    /// Format version.
    pub version: u32,
    /// What ties the report to the run's other outputs.
    pub provenance: crate::provenance::Provenance,
    /// The config file.
    pub config: String,
    /// The scene file.
    pub scene: String,
    /// The seed.
    pub seed: u64,
    /// The tracer's adapter (`cpu twin` without one).
    pub adapter: String,
    /// What the matches compare errors by: `mse_glossy_filtered`.
    pub quality_metric: &'static str,
    /// `gpu_ms` where a hardware GPU timed every placement, else
    /// `texel_fetches_per_ray` (lavapipe's times measure a CPU).
    pub performance_metric: &'static str,
    /// Render size.
    pub width: u32,
    /// Render size.
    pub height: u32,
    /// Glossy rays per pixel.
    pub glossy_rays: u32,
    /// The surfaces rendered: `scene`, or `all-glossy:α`.
    pub materials: String,
    /// The cameras.
    pub cameras: Vec<CameraRecord>,
    /// Every placement, ours first, then the grids by count, then the others.
    pub placements: Vec<PlacementRow>,
    /// The three matches for every placement that is not a sweep grid.
    pub comparisons: Vec<Comparison>,
    /// The diffuse evaluation's receivers and rays (`null` without it).
    pub diffuse: Option<DiffuseSetup>,
    /// Problems worth knowing.
    pub warnings: Vec<String>,
    /// Wall time per step (ms).
    pub timings_ms: BTreeMap<String, f64>,
}

impl PlacementRow {
    /// The quality figure the matches use: the mean of [`QUALITY`].
    pub fn error(&self) -> f64 {
        self.means[QUALITY]
    }

    /// The figure equal performance matches on.
    pub fn performance(&self, metric: &str) -> f64 {
        match metric {
            "gpu_ms" => self.gpu_ms.unwrap_or(f64::NAN),
            _ => self.means[WORK],
        }
    }
}

/// The metric equal performance uses: GPU time where every placement has
/// one from hardware, else texel fetches per ray.
pub fn performance_metric(adapter: &str, rows: &[PlacementRow]) -> &'static str {
    let software = ["llvmpipe", "lavapipe", "swiftshader", "cpu twin", "warp"]
        .iter()
        .any(|s| adapter.to_lowercase().contains(s));
    if !software && rows.iter().all(|r| r.gpu_ms.is_some()) {
        "gpu_ms"
    } else {
        WORK.entry().key
    }
}

/// The three matches of every non-grid row against the grid rows, and its
/// ratios against every rival with intervals (seeded by `seed`).
///
/// Contract: deterministic; rows with family [`Family::Grid`] form the
/// sweep, one row per grid and tracer; an empty sweep gives matches of
/// `None`; rows without blocks get ratios without spread.
pub fn comparisons(rows: &[PlacementRow], metric: &str, seed: u64) -> Vec<Comparison> {
    let sweep = |tracer: &str| {
        let mut g: Vec<&PlacementRow> = rows
            .iter()
            .filter(|r| r.family == Family::Grid && r.tracer == tracer)
            .collect();
        g.sort_by(|a, b| a.probes.cmp(&b.probes).then(a.name.cmp(&b.name)));
        g
    };
    let (same, engine) = (sweep(TRACER_HIZ), sweep(TRACER_BILEVEL));
    let matched = |g: &PlacementRow| Matched {
        grid: g.name.clone(),
        probes: g.probes,
        error: g.error(),
        performance: g.performance(metric),
    };
    let nearest = |grids: &[&'_ PlacementRow], n: usize| -> Option<usize> {
        (0..grids.len()).min_by(|&a, &b| {
            let (a, b) = (grids[a], grids[b]);
            a.probes
                .abs_diff(n)
                .cmp(&b.probes.abs_diff(n))
                .then(b.probes.cmp(&a.probes))
        })
    };
    let ratio = |a: f64, b: f64| (b > 0.0).then_some(a / b);
    rows.iter()
        .filter(|r| r.family != Family::Grid)
        .map(|r| {
            let equal_count = nearest(&same, r.probes).map(|i| same[i]);
            let equal_count_engine = nearest(&engine, r.probes).map(|i| engine[i]);
            let equal_quality = same.iter().find(|g| g.error() <= r.error());
            let equal_quality_engine = engine.iter().find(|g| g.error() <= r.error());
            let ours = r.performance(metric);
            let equal_performance = engine
                .iter()
                .filter(|g| g.performance(metric).is_finite())
                .min_by(|a, b| {
                    let da = (a.performance(metric) - ours).abs();
                    let db = (b.performance(metric) - ours).abs();
                    da.total_cmp(&db).then(a.probes.cmp(&b.probes))
                });
            let mut rivals: Vec<&PlacementRow> =
                equal_count.into_iter().chain(equal_count_engine).collect();
            if matches!(r.family, Family::Ours | Family::Given) {
                rivals.extend(rows.iter().filter(|o| {
                    let itself = o.family == r.family && o.name == r.name;
                    !(itself || matches!(o.family, Family::Grid | Family::Given))
                }));
            }
            let ratios = rivals
                .par_iter()
                .map(|o| ratio_against(o, r, seed))
                .collect();
            Comparison {
                placement: r.name.clone(),
                probes: r.probes,
                error: r.error(),
                error_ratio_at_equal_count: equal_count.and_then(|m| ratio(m.error(), r.error())),
                error_ratio_at_equal_count_engine: equal_count_engine
                    .and_then(|m| ratio(m.error(), r.error())),
                probe_ratio_at_equal_quality: equal_quality
                    .and_then(|m| ratio(m.probes as f64, r.probes as f64)),
                probe_ratio_at_equal_quality_engine: equal_quality_engine
                    .and_then(|m| ratio(m.probes as f64, r.probes as f64)),
                error_ratio_at_equal_performance: equal_performance
                    .and_then(|m| ratio(m.error(), r.error())),
                equal_count: equal_count.map(matched),
                equal_count_engine: equal_count_engine.map(matched),
                equal_quality: equal_quality.map(|g| matched(g)),
                equal_quality_engine: equal_quality_engine.map(|g| matched(g)),
                equal_performance: equal_performance.map(|g| matched(g)),
                ratios,
            }
        })
        .collect()
}

/// `rival`'s pooled errors over `ours`, with two-stage bootstrap intervals
/// over views and blocks.
fn ratio_against(rival: &PlacementRow, ours: &PlacementRow, seed: u64) -> Ratio {
    let interval = |m: Metric| {
        let f = |b: &Blocks| -> Vec<f64> { b[m].clone() };
        let paired = rival.blocks.len() == ours.blocks.len()
            && !ours.blocks.is_empty()
            && rival
                .blocks
                .iter()
                .zip(&ours.blocks)
                .all(|(a, b)| a[m].len() == b[m].len() && !a[m].is_empty());
        if paired {
            let num: Vec<Vec<f64>> = rival.blocks.iter().map(f).collect();
            let den: Vec<Vec<f64>> = ours.blocks.iter().map(f).collect();
            paired_ratio_over_views(&num, &den, RESAMPLES, seed)
        } else {
            let v = rival.means[m] / ours.means[m];
            Interval {
                value: v,
                lo: v,
                hi: v,
            }
        }
    };
    let intervals = Intervals(Metric::paired().map(|m| (m, interval(m))).collect());
    Ratio {
        against: rival.name.clone(),
        family: rival.family,
        tracer: rival.tracer,
        probes: rival.probes,
        win: intervals.0.iter().all(|(_, i)| i.lo > 1.0),
        loss: intervals.0.iter().all(|(_, i)| i.hi < 1.0),
        intervals,
        diffuse: diffuse_ratio(rival, ours, seed),
    }
}

/// One line per placement of ours: its three matches, for the terminal.
pub fn summary(report: &CompareReport) -> Vec<String> {
    report
        .comparisons
        .iter()
        .filter(|c| {
            report
                .placements
                .iter()
                .any(|p| p.name == c.placement && matches!(p.family, Family::Ours | Family::Given))
        })
        .map(|c| {
            let count: Vec<String> = c
                .ratios
                .iter()
                .filter(|r| r.family == Family::Grid)
                .map(|r| {
                    let m = r.intervals.of(QUALITY).expect("the quality metric is paired");
                    format!(
                        "{} on {} has {:.2}× [{:.2}, {:.2}] the error",
                        r.against, r.tracer, m.value, m.lo, m.hi
                    )
                })
                .collect();
            let count = if count.is_empty() {
                "no grid".to_string()
            } else {
                count.join(", ")
            };
            let quality = match (&c.equal_quality, c.probe_ratio_at_equal_quality) {
                (Some(m), Some(r)) => format!("{} ({} probes, {r:.2}×)", m.grid, m.probes),
                _ => "no grid of the sweep".into(),
            };
            let perf = match (&c.equal_performance, c.error_ratio_at_equal_performance) {
                (Some(m), Some(r)) => format!("{} has {r:.2}× the error", m.grid),
                _ => "no grid".into(),
            };
            let diffuse = c
                .ratios
                .iter()
                .filter(|r| r.family == Family::Grid && r.tracer == TRACER_HIZ)
                .find_map(|r| {
                    let i = r.diffuse.as_ref()?.surface_indirect?;
                    Some(format!(
                        "; diffuse (SH over tetrahedra): {} has {:.2}× [{:.2}, {:.2}] the indirect surface error",
                        r.against, i.value, i.lo, i.hi
                    ))
                })
                .unwrap_or_default();
            format!(
                "{}: {} probes, filtered glossy MSE {:.3e}; equal count: {count}; equal quality: {quality}; equal {}: {perf}{diffuse}",
                c.placement, c.probes, c.error, report.performance_metric
            )
        })
        .collect()
}

/// A figure for a table cell: blank when absent.
fn cell(v: Option<f64>) -> String {
    v.map(|x| format!("{x:.6}")).unwrap_or_default()
}

/// `compare.csv`: one line per placement and camera, a header first; one
/// column per metric of the list, in its order.
pub fn to_csv(report: &CompareReport) -> String {
    let keys: Vec<&str> = crate::stages::validate::METRICS
        .iter()
        .map(|m| m.key)
        .collect();
    let mut out = format!(
        "placement,family,tracer,camera,chosen,probes,coverage,probes_in_solid,probe_bytes,svo_bytes,{},gpu_ms,sh_surface_total,sh_surface_indirect,sh_free_total,sh_free_indirect,sh_leak_fraction,gather_surface_total,gather_free_total,gather_leak_fraction,invalid_probes,unreachable_probes\n",
        keys.join(",")
    );
    for p in &report.placements {
        // The placement's diffuse figures, the same on each camera's line.
        let diffuse = match &p.diffuse {
            Some(d) => {
                let (s, g) = (&d.sh_tetrahedra, &d.gather);
                [
                    cell(s.surface_total),
                    cell(s.surface_indirect),
                    cell(s.free_total),
                    cell(s.free_indirect),
                    cell(s.leak_fraction),
                    cell(g.surface_total),
                    cell(g.free_total),
                    cell(g.leak_fraction),
                    d.invalid_probes.to_string(),
                    d.unreachable_probes.to_string(),
                ]
                .join(",")
            }
            None => ",,,,,,,,,".to_string(),
        };
        for (i, c) in p.cameras.iter().enumerate() {
            let gpu = c.gpu_ms.map(|v| format!("{v:.3}")).unwrap_or_default();
            let figures: Vec<String> = Metric::ALL
                .iter()
                .map(|&m| m.entry().show.csv(c.figures[m]))
                .collect();
            let _ = writeln!(
                out,
                "{},{},{},{i},{},{},{:.6},{},{},{},{},{gpu},{diffuse}",
                p.name,
                p.family.key(),
                p.tracer,
                report.cameras.get(i).is_some_and(|c| c.chosen),
                p.probes,
                p.coverage,
                p.probes_in_solid,
                p.probe_bytes,
                p.svo_bytes,
                figures.join(","),
            );
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(name: &str, family: Family, probes: usize, mse: f64, fetches: f64) -> PlacementRow {
        PlacementRow {
            name: name.into(),
            family,
            tracer: "hiz+svo",
            probes,
            coverage: 1.0,
            probes_in_solid: 0,
            probe_bytes: 0,
            svo_bytes: 0,
            means: PerMetric::from_fn(|m| match m {
                WORK => fetches,
                Metric::UnresolvedFraction => 0.0,
                _ => mse,
            }),
            gpu_ms: None,
            shading_probe_distance: None,
            cameras: vec![],
            stats: BTreeMap::new(),
            blocks: vec![],
            diffuse: None,
        }
    }

    /// `row` on McGuire's tracer.
    fn engine(name: &str, probes: usize, mse: f64, fetches: f64) -> PlacementRow {
        PlacementRow {
            tracer: TRACER_BILEVEL,
            ..row(name, Family::Grid, probes, mse, fetches)
        }
    }

    /// Blocks of `views` views whose every block is `scale` times a
    /// pattern shared by all placements (common random numbers).
    fn blocks(scale: f64, views: usize) -> Vec<Blocks> {
        (0..views)
            .map(|v| {
                let e: Vec<f64> = (0..50)
                    .map(|i| scale * (1.0 + ((i * 7 + v) % 11) as f64))
                    .collect();
                let mut b = Blocks::default();
                b[Metric::MseGlossyFiltered] = e.clone();
                b[Metric::Flip] = e;
                b
            })
            .collect()
    }

    #[test]
    fn ratios_carry_intervals_and_call_a_win_only_when_both_exclude_one() {
        let mut ours = row("ours", Family::Ours, 10, 1.0, 20.0);
        ours.blocks = blocks(1.0, 4);
        let mut grid = row("g8", Family::Grid, 8, 2.0, 30.0);
        grid.blocks = blocks(2.0, 4);
        let mut greedy = row("greedy", Family::Competitor("greedy"), 10, 1.0, 20.0);
        greedy.blocks = blocks(1.0, 4);
        // Worse in half the views, better in the rest: no verdict.
        let mut adaptive = row("adaptive", Family::Competitor("adaptive"), 10, 1.0, 20.0);
        adaptive.blocks = (0..4)
            .map(|v| blocks(if v % 2 == 0 { 0.4 } else { 1.6 }, 1).remove(0))
            .collect();
        let rows = vec![ours, grid, greedy, adaptive];
        let c = &comparisons(&rows, "texel_fetches_per_ray", 1)[0];
        let by = |n: &str| c.ratios.iter().find(|r| r.against == n).unwrap();
        let g = by("g8");
        let of = |r: &Ratio, m: Metric| *r.intervals.of(m).unwrap();
        assert_eq!((of(g, QUALITY).value, g.tracer), (2.0, TRACER_HIZ));
        assert!(g.win && !g.loss && of(g, QUALITY).lo > 1.0);
        let tie = by("greedy");
        let flip = of(tie, Metric::Flip);
        assert_eq!((flip.lo, flip.hi), (1.0, 1.0));
        assert!(!tie.win && !tie.loss);
        let mixed = by("adaptive");
        assert!(of(mixed, QUALITY).lo < 1.0 && of(mixed, QUALITY).hi > 1.0);
        assert!(!mixed.win && !mixed.loss);
        assert_eq!(c.ratios.len(), 3, "one equal-count grid, two competitors");
    }

    #[test]
    fn matches_pick_nearest_count_smallest_equal_quality_and_nearest_cost() {
        let rows = vec![
            row("ours", Family::Ours, 10, 2.0, 20.0),
            row("g8", Family::Grid, 8, 5.0, 30.0),
            row("g12", Family::Grid, 12, 3.0, 21.0),
            row("g27", Family::Grid, 27, 1.9, 18.0),
            row("g64", Family::Grid, 64, 1.0, 15.0),
            engine("g8", 8, 50.0, 30.0),
            engine("g12", 12, 30.0, 21.0),
            engine("g27", 27, 1.9, 18.0),
        ];
        let c = &comparisons(&rows, "texel_fetches_per_ray", 1)[0];
        // 8 and 12 are both 2 away: the larger grid wins the tie.
        assert_eq!(c.equal_count.as_ref().unwrap().grid, "g12");
        assert_eq!(c.error_ratio_at_equal_count, Some(1.5));
        assert_eq!(c.equal_quality.as_ref().unwrap().grid, "g27");
        assert_eq!(c.probe_ratio_at_equal_quality, Some(2.7));
        assert_eq!(c.equal_performance.as_ref().unwrap().grid, "g12");
        // McGuire's tracer: its own equal-count and equal-quality grids.
        assert_eq!(c.error_ratio_at_equal_count_engine, Some(15.0));
        assert_eq!(c.equal_quality_engine.as_ref().unwrap().grid, "g27");
        assert_eq!(c.equal_performance.as_ref().unwrap().error, 30.0);
    }

    #[test]
    fn no_grid_reaching_our_quality_gives_none() {
        let rows = vec![
            row("ours", Family::Ours, 10, 0.5, 20.0),
            row("g8", Family::Grid, 8, 5.0, 30.0),
            row("reloc", Family::Competitor("relocated"), 7, 6.0, 30.0),
        ];
        let cs = comparisons(&rows, "texel_fetches_per_ray", 1);
        assert_eq!(cs.len(), 2, "grids are not matched against themselves");
        assert!(cs[0].equal_quality.is_none());
        assert_eq!(cs[1].equal_quality.as_ref().unwrap().grid, "g8");
    }

    #[test]
    fn software_adapters_fall_back_to_texel_fetches() {
        let mut rows = vec![row("g", Family::Grid, 8, 1.0, 3.0)];
        rows[0].gpu_ms = Some(2.0);
        assert_eq!(
            performance_metric("llvmpipe (LLVM 15.0.6, 256 bits) (Vulkan)", &rows),
            "texel_fetches_per_ray"
        );
        assert_eq!(performance_metric("NVIDIA H100 (Vulkan)", &rows), "gpu_ms");
        rows[0].gpu_ms = None;
        assert_eq!(
            performance_metric("NVIDIA H100 (Vulkan)", &rows),
            "texel_fetches_per_ray"
        );
    }
}
