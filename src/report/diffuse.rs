//! `compare.json`'s `diffuse`: every placement's diffuse light as engines
//! blend it (SH L2 over Delaunay tetrahedra, on the scene's own
//! materials; [`crate::diffuse`]), the ratios of ours against each rival
//! at equal count with their intervals, and the count at which ours
//! reaches the equal-count grid's error.

use super::family::Family;
use crate::diffuse::{mean, Errors};
use crate::stages::diffuse::{Emitters, Measured};
use crate::stats::{paired_ratio_over_views, Interval, RESAMPLES};
use serde::Serialize;

/// The diffuse benchmark's section of `compare.json`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DiffuseSection {
    /// Receivers, rays and the scene's emitters.
    pub setup: DiffuseSetup,
    /// Every placement measured: ours at their own counts and at the
    /// rivals' and the curve's, the grid sweep, each competitor at each
    /// count of the sweep.
    pub placements: Vec<DiffusePlacement>,
    /// Ours against each rival at equal count, with intervals.
    pub comparisons: Vec<DiffuseComparison>,
    /// The probes ours needs to reach the equal-count grid's error.
    pub equal_error: Option<EqualError>,
}

/// The diffuse evaluation's set-up.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DiffuseSetup {
    /// Always `scene`: engines bake probe light with the scene's albedo
    /// (`compare.materials` changes only the glossy benchmark).
    pub materials: &'static str,
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
    /// Mean luminance of the reference irradiance at the surface
    /// receivers.
    pub surface_reference_mean: Parts,
    /// The same at the free receivers.
    pub free_reference_mean: Parts,
    /// What lights the scene.
    pub emitters: Emitters,
    /// The blend's own limit: the mean relative error of the baked light
    /// at the surface receivers with a probe at every one of them (each
    /// receiver then takes its own probe's SH alone): what SH L2 and the
    /// rays' noise leave, which no placement removes.
    pub limit: Option<f64>,
}

/// A figure for the total light and its baked part.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Parts {
    /// All the light (the delta lights' direct light included).
    pub total: f64,
    /// What a mixed-lighting probe holds.
    pub baked: f64,
}

/// Mean errors at one set of receivers.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Figures {
    /// Mean relative error of the total irradiance's luminance.
    pub total: Option<f64>,
    /// The same for the baked part (the headline).
    pub baked: Option<f64>,
    /// Share of receivers whose baked light is 2× too much or too little.
    pub leaks: Option<f64>,
}

impl Figures {
    fn of(e: &Errors) -> Figures {
        Figures {
            total: mean(&e.total),
            baked: mean(&e.baked),
            leaks: mean(&e.leak),
        }
    }
}

/// One placement's diffuse light.
#[derive(Debug, Clone, Serialize)]
pub struct DiffusePlacement {
    /// Unique name: the method's (`sdf-skeleton`, `grid:4x2x4`, …), and
    /// `METHOD@N` for ours placed with exactly `N` probes.
    pub name: String,
    /// What kind of placement it is.
    pub family: Family,
    /// Probes placed.
    pub probes: usize,
    /// Probes dropped from the blend as standing in solid.
    pub invalid_probes: usize,
    /// Probes in open space no camera reaches (sealed voids).
    pub unreachable_probes: usize,
    /// Probes that see no reachable free space at all.
    pub idle_probes: usize,
    /// At the surface receivers.
    pub surface: Figures,
    /// At the free receivers.
    pub free: Figures,
    /// The errors per receiver the intervals resample (not written).
    #[serde(skip)]
    pub errors: Measured,
    /// Where its probes stand, for the page's figures (not written).
    #[serde(skip)]
    pub positions: Vec<glam::Vec3>,
}

impl PartialEq for DiffusePlacement {
    fn eq(&self, o: &Self) -> bool {
        self.name == o.name
            && self.family == o.family
            && self.probes == o.probes
            && self.invalid_probes == o.invalid_probes
            && self.unreachable_probes == o.unreachable_probes
            && self.idle_probes == o.idle_probes
            && self.surface == o.surface
            && self.free == o.free
    }
}

impl DiffusePlacement {
    /// The row of a placement measured as `m`.
    pub fn new(
        name: &str,
        family: Family,
        positions: Vec<glam::Vec3>,
        m: crate::stages::diffuse::DiffuseMeasure,
    ) -> DiffusePlacement {
        DiffusePlacement {
            name: name.to_string(),
            family,
            probes: positions.len(),
            positions,
            invalid_probes: m.invalid_probes,
            unreachable_probes: m.unreachable_probes,
            idle_probes: m.idle_probes,
            surface: Figures::of(&m.tetrahedra.surface),
            free: Figures::of(&m.tetrahedra.free),
            errors: m.tetrahedra,
        }
    }

    /// The headline figure: mean relative error of the baked light at the
    /// surface receivers (infinite without any).
    pub fn error(&self) -> f64 {
        self.surface.baked.unwrap_or(f64::INFINITY)
    }
}

/// A rival's errors over ours at equal count, each with its 95%
/// paired-bootstrap interval over receiver groups (views for surface
/// receivers, runs of [`crate::diffuse::FREE_GROUP`] in free space);
/// above 1, ours has the lower error. `null` where a set is empty, ours
/// has no error there, or a resample has none (rare leaks).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DiffuseComparison {
    /// Our placement (at the rival's count).
    pub ours: String,
    /// The rival placement.
    pub rival: String,
    /// Its family.
    pub family: Family,
    /// The probes of both.
    pub probes: usize,
    /// Baked light at surface receivers: the headline.
    pub surface_baked: Option<Interval>,
    /// Total light at surface receivers.
    pub surface_total: Option<Interval>,
    /// Baked light at free receivers.
    pub free_baked: Option<Interval>,
    /// Total light at free receivers.
    pub free_total: Option<Interval>,
    /// Leaking surface receivers.
    pub surface_leaks: Option<Interval>,
    /// Leaking free receivers.
    pub free_leaks: Option<Interval>,
    /// The surface baked interval lies wholly above 1.
    pub win: bool,
    /// It lies wholly below 1.
    pub loss: bool,
}

impl DiffuseComparison {
    /// `rival` over `ours` (module docs), seeded by `seed`.
    pub fn new(ours: &DiffusePlacement, rival: &DiffusePlacement, seed: u64) -> DiffuseComparison {
        let (a, b) = (&rival.errors, &ours.errors);
        let surface_baked = interval(&a.surface, &b.surface, |e| &e.baked, seed);
        DiffuseComparison {
            ours: ours.name.clone(),
            rival: rival.name.clone(),
            family: rival.family,
            probes: rival.probes,
            win: surface_baked.is_some_and(|i| i.lo > 1.0),
            loss: surface_baked.is_some_and(|i| i.hi < 1.0),
            surface_baked,
            surface_total: interval(&a.surface, &b.surface, |e| &e.total, seed),
            free_baked: interval(&a.free, &b.free, |e| &e.baked, seed),
            free_total: interval(&a.free, &b.free, |e| &e.total, seed),
            surface_leaks: interval(&a.surface, &b.surface, |e| &e.leak, seed),
            free_leaks: interval(&a.free, &b.free, |e| &e.leak, seed),
        }
    }
}

/// The ratio of `x`'s mean of `f` over `y`'s, with its interval over
/// receiver groups; `None` where unpaired, empty or zero.
fn interval(x: &Errors, y: &Errors, f: fn(&Errors) -> &Vec<f64>, seed: u64) -> Option<Interval> {
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
}

/// How many of our probes reach the equal-count grid's error.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct EqualError {
    /// Our method.
    pub ours: String,
    /// The grid of the sweep nearest our count.
    pub grid: String,
    /// Its probes.
    pub grid_probes: usize,
    /// Its error (baked light, surface receivers).
    pub grid_error: f64,
    /// Our count at that error, interpolated in log count between the two
    /// counts of ours around the crossing (the first, from the smallest);
    /// `null` when no count of ours measured reaches it.
    pub ours_probes: Option<f64>,
    /// `ours_probes` over `grid_probes`: below 1, ours needs fewer.
    pub count_ratio: Option<f64>,
    /// Whether our smallest count measured already reaches it: then
    /// `ours_probes` is that count, an upper bound.
    pub bound: bool,
}

impl EqualError {
    /// From the grid's row and our rows (any order).
    pub fn new(grid: &DiffusePlacement, ours: &[&DiffusePlacement], method: &str) -> EqualError {
        let target = grid.error();
        let mut curve: Vec<(usize, f64)> = ours.iter().map(|r| (r.probes, r.error())).collect();
        curve.sort_by(|a, b| a.0.cmp(&b.0).then(a.1.total_cmp(&b.1)));
        curve.dedup_by_key(|p| p.0);
        let mut found = None;
        let mut bound = false;
        for (k, &(n, e)) in curve.iter().enumerate() {
            if e <= target {
                found = Some(match k {
                    0 => {
                        bound = true;
                        n as f64
                    }
                    _ => {
                        let (n0, e0) = curve[k - 1];
                        // e0 > target >= e: interpolate in log count.
                        let t = ((e0 - target) / (e0 - e)).clamp(0.0, 1.0);
                        ((n0 as f64).ln() + t * ((n as f64).ln() - (n0 as f64).ln())).exp()
                    }
                });
                break;
            }
        }
        EqualError {
            ours: method.to_string(),
            grid: grid.name.clone(),
            grid_probes: grid.probes,
            grid_error: target,
            ours_probes: found,
            count_ratio: found.map(|n| n / grid.probes as f64),
            bound,
        }
    }
}

/// `diffuse.csv`: one line per placement of `d`, a header first.
pub fn to_csv(d: &DiffuseSection) -> String {
    use std::fmt::Write as _;
    let cell = |v: Option<f64>| v.map(|x| format!("{x:.6}")).unwrap_or_default();
    let mut out = String::from("placement,family,probes,invalid_probes,unreachable_probes,idle_probes,surface_baked,surface_total,surface_leaks,free_baked,free_total,free_leaks\n");
    for r in &d.placements {
        let _ = writeln!(
            out,
            "{},{},{},{},{},{},{},{},{},{},{},{}",
            r.name,
            r.family.key(),
            r.probes,
            r.invalid_probes,
            r.unreachable_probes,
            r.idle_probes,
            cell(r.surface.baked),
            cell(r.surface.total),
            cell(r.surface.leaks),
            cell(r.free.baked),
            cell(r.free.total),
            cell(r.free.leaks),
        );
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(name: &str, probes: usize, baked: f64) -> DiffusePlacement {
        DiffusePlacement {
            name: name.into(),
            family: Family::Ours,
            probes,
            invalid_probes: 0,
            unreachable_probes: 0,
            idle_probes: 0,
            surface: Figures {
                total: Some(baked),
                baked: Some(baked),
                leaks: Some(0.0),
            },
            free: Figures {
                total: None,
                baked: None,
                leaks: None,
            },
            errors: Measured::default(),
            positions: Vec::new(),
        }
    }

    #[test]
    fn the_equal_error_count_interpolates_in_log_count() {
        let grid = row("grid:4x4x4", 64, 0.2);
        let ours = [
            row("a@8", 8, 0.4),
            row("a@32", 32, 0.1),
            row("a@16", 16, 0.3),
        ];
        let refs: Vec<&DiffusePlacement> = ours.iter().collect();
        let e = EqualError::new(&grid, &refs, "a");
        // Between 16 (0.3) and 32 (0.1), half way: √(16·32).
        let want = (16.0f64 * 32.0).sqrt();
        assert!((e.ours_probes.unwrap() - want).abs() < 1e-9, "{e:?}");
        assert!((e.count_ratio.unwrap() - want / 64.0).abs() < 1e-12);
        assert!(!e.bound);
        // Reached at once: an upper bound.
        let e = EqualError::new(&row("g", 64, 0.5), &refs, "a");
        assert_eq!((e.ours_probes, e.bound), (Some(8.0), true));
        // Never reached.
        let e = EqualError::new(&row("g", 64, 0.05), &refs, "a");
        assert_eq!((e.ours_probes, e.count_ratio), (None, None));
    }

    #[test]
    fn ratios_pair_receivers_by_group() {
        let errors = |v: &[f64]| Errors {
            total: v.to_vec(),
            baked: v.to_vec(),
            leak: vec![1.0; 4],
            group: vec![0, 0, 1, 1],
        };
        let mut a = row("ours", 4, 0.25);
        a.errors.surface = errors(&[0.1, 0.2, 0.3, 0.4]);
        let mut b = row("grid", 4, 0.5);
        b.family = Family::Grid;
        b.errors.surface = errors(&[0.2, 0.4, 0.6, 0.8]);
        let c = DiffuseComparison::new(&a, &b, 7);
        let i = c.surface_baked.unwrap();
        assert!(
            (i.value - 2.0).abs() < 1e-9 && (i.lo - 2.0).abs() < 1e-9,
            "{i:?}"
        );
        assert!(c.win && !c.loss);
        assert_eq!(c.free_baked, None, "no free receivers");
        assert!((c.surface_leaks.unwrap().value - 1.0).abs() < 1e-12);
    }
}
