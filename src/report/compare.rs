//! `compare.json` and `compare.csv`: every placement measured alike, and
//! the three matches Wang et al. 2019 §5 draws against uniform grids
//! (Figs. 8–12, Tables 1–2): equal probe count, equal quality and equal
//! performance.

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

pub use super::family::Family;

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
    /// Mean of the reference's glossy indirect component, per channel
    /// (`null` without the glossy benchmark, which renders it).
    pub reference_glossy_mean: Option<[f64; 3]>,
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
    /// The diffuse benchmark: every placement's diffuse light as engines
    /// blend it, on the scene's own materials (`null` when it did not run:
    /// `--only glossy`, or no receiver asked for).
    pub diffuse: Option<super::diffuse::DiffuseSection>,
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
            format!(
                "{}: {} probes, filtered glossy MSE {:.3e}; equal count: {count}; equal quality: {quality}; equal {}: {perf}",
                c.placement, c.probes, c.error, report.performance_metric
            )
        })
        .collect()
}

/// `compare.csv`: one line per placement and camera, a header first; one
/// column per metric of the list, in its order.
pub fn to_csv(report: &CompareReport) -> String {
    let keys: Vec<&str> = crate::stages::validate::METRICS
        .iter()
        .map(|m| m.key)
        .collect();
    let mut out = format!(
        "placement,family,tracer,camera,chosen,probes,coverage,probes_in_solid,probe_bytes,svo_bytes,{},gpu_ms\n",
        keys.join(",")
    );
    for p in &report.placements {
        for (i, c) in p.cameras.iter().enumerate() {
            let gpu = c.gpu_ms.map(|v| format!("{v:.3}")).unwrap_or_default();
            let figures: Vec<String> = Metric::ALL
                .iter()
                .map(|&m| m.entry().show.csv(c.figures[m]))
                .collect();
            let _ = writeln!(
                out,
                "{},{},{},{i},{},{},{:.6},{},{},{},{},{gpu}",
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
