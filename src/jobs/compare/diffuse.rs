//! `compare`'s diffuse benchmark: every placement's diffuse light as
//! engines blend it (SH L2 over Delaunay tetrahedra, [`crate::diffuse`]),
//! on the scene's own materials, at the surface receivers the views see
//! and the free receivers the cameras reach.
//!
//! What it places and measures, all with the same receivers and the same
//! rays (common random numbers: a probe at the same place gets the same
//! light in every placement):
//! - **ours** at their own counts (each method of ours, refined);
//! - **the grid sweep** (or the grids named), and **each competitor at
//!   each count of the sweep** ([`crate::placement::Method::at_count`]):
//!   every method's curve of error against count;
//! - **ours again at exactly each rival's count** at about ours, and at
//!   each count of the sweep up to twice ours (`METHOD@N`, with
//!   `min_probes` = `max_probes` = `N`): the equal-count comparisons and
//!   our curve.
//!
//! From them: each rival's errors over ours at equal count with 95%
//! intervals ([`DiffuseComparison`]), and how many of our probes reach the
//! equal-count grid's error ([`EqualError`]). Only SH is baked per
//! placement, so the whole benchmark costs a fraction of the glossy one.

use super::placing::{candidate_of, Over};
use crate::config::{GridParams, Placement};
use crate::error::{Error, Result};
use crate::jobs::run::Job;
use crate::page::html::LitFigures;
use crate::placement::grid::nearest_grid;
use crate::placement::method::Role;
use crate::placement::registry::METHODS;
use crate::report::compare::Family;
use crate::report::diffuse::{
    DiffuseComparison, DiffusePlacement, DiffuseSection, DiffuseSetup, EqualError, Parts,
};
use crate::stages::{self, diffuse::Bench};
use glam::Vec3;

/// What the benchmark measured, with what the page shows of it.
pub(super) struct Measured {
    /// The section of `compare.json`.
    pub section: DiffuseSection,
    /// The lit views of the first camera for the page: the reference,
    /// then per placement shown its name, render and error map (PNG).
    pub figures: Option<LitFigures>,
    /// Problems worth knowing.
    pub warnings: Vec<String>,
}

/// Runs the benchmark over `over` (the scene's own materials) against
/// `bench`: `ours` are our methods' placements at their own counts, the
/// default method's first; `named` the grids the user named (else the
/// sweep around our count).
pub(super) fn run(
    job: &mut Job,
    over: &Over,
    bench: &Bench,
    ours: &[(&'static str, &crate::placement::ProbeSet)],
    named: Option<&[GridParams]>,
    lit: Option<&stages::diffuse::LitView>,
) -> Result<Measured> {
    let config = over.config;
    let mut rows: Vec<DiffusePlacement> = Vec::new();
    let mut warnings = Vec::new();
    let measure = |name: &str, family: Family, positions: &[Vec3]| -> DiffusePlacement {
        let valid = crate::coverage::probes_free(
            &over.prepared.bvh,
            over.prepared.sdf.voxel_size,
            positions,
        );
        let m = stages::diffuse::measure(config, over.prepared, bench, positions, &valid);
        DiffusePlacement::new(name, family, positions.to_vec(), m)
    };
    let (default_method, default_set) = ours[0];
    for &(method, probes) in ours {
        let t = std::time::Instant::now();
        rows.push(measure(method, Family::Ours, &probes.positions()));
        job.watch.record(
            &format!("diffuse {method}"),
            t.elapsed().as_secs_f64() * 1e3,
        );
    }
    let n = default_set.probes.len();
    // The grids: placed plainly, each measured.
    let grids: Vec<GridParams> = match named {
        Some(g) => g.to_vec(),
        None => crate::placement::grid::grid_sweep(&over.prepared.domain, n),
    };
    let mut counted: Vec<(usize, GridParams)> = Vec::new();
    for g in &grids {
        let t = std::time::Instant::now();
        let method = Placement::Grid(*g);
        let name = method.name();
        let placed = over.plain(method)?;
        counted.push((placed.probes.probes.len(), *g));
        rows.push(measure(&name, Family::Grid, &placed.probes.positions()));
        job.watch
            .record(&format!("diffuse {name}"), t.elapsed().as_secs_f64() * 1e3);
    }
    let nearest = nearest_grid(&counted, n).map(|&(k, _)| k);
    // Each competitor at each count of the sweep; the one at our count
    // (the grid's nearest) is its equal-count rival.
    let input = over.prepared.placement_input(config.seed, &over.progress);
    let mut rivals: Vec<usize> = Vec::new();
    if let Some(i) = rows
        .iter()
        .position(|r| r.family == Family::Grid && Some(r.probes) == nearest)
    {
        rivals.push(i);
    }
    for m in METHODS.iter().filter(|m| m.role == Role::Competitor) {
        let mut counts: Vec<usize> = counted.iter().map(|&(k, _)| k).collect();
        counts.sort_unstable();
        counts.dedup();
        for k in counts {
            let Some(method) = Placement::at_count(m.variant, &input, &counted, k) else {
                continue;
            };
            let name = method.name();
            let known = rows.iter().position(|r| r.name == name);
            let row = match known {
                Some(i) => Some(i),
                None => {
                    let t = std::time::Instant::now();
                    // Every probe switched off, no candidate voxel, or too
                    // many probes: a finding, not a failure.
                    let at = match over.plain(method) {
                        Err(Error::User(e)) => {
                            warnings.push(format!("compare: diffuse: {name}: {e}"));
                            None
                        }
                        Err(e) => return Err(e),
                        Ok(placed) => {
                            let c = candidate_of(placed);
                            rows.push(measure(
                                &name,
                                Family::Competitor(m.word),
                                &c.probes.positions(),
                            ));
                            Some(rows.len() - 1)
                        }
                    };
                    job.watch
                        .record(&format!("diffuse {name}"), t.elapsed().as_secs_f64() * 1e3);
                    at
                }
            };
            if Some(k) == nearest {
                rivals.extend(row);
            }
        }
    }
    rivals.dedup();
    // Ours again at each rival's count and along the sweep, up to twice
    // ours.
    let mut counts: Vec<usize> = rivals.iter().map(|&i| rows[i].probes).collect();
    counts.extend(counted.iter().map(|&(k, _)| k).filter(|&k| k <= 2 * n));
    counts.sort_unstable();
    counts.dedup();
    for k in counts {
        if k == n || k == 0 {
            continue;
        }
        let name = format!("{default_method}@{k}");
        let t = std::time::Instant::now();
        match over.refined(job, default_method, Some(k)) {
            Err(Error::User(e)) => warnings.push(format!("compare: diffuse: {name}: {e}")),
            Err(e) => return Err(e),
            Ok(c) => rows.push(measure(&name, Family::Ours, &c.probes.positions())),
        }
        job.watch
            .record(&format!("diffuse {name}"), t.elapsed().as_secs_f64() * 1e3);
    }
    // Ours at each rival's count against it.
    let ours_rows: Vec<&DiffusePlacement> = rows
        .iter()
        .filter(|r| {
            r.family == Family::Ours
                && (r.name == default_method || r.name.starts_with(&format!("{default_method}@")))
        })
        .collect();
    let comparisons: Vec<DiffuseComparison> = rivals
        .iter()
        .filter_map(|&i| {
            let rival = &rows[i];
            let ours = ours_rows.iter().find(|o| o.probes == rival.probes)?;
            Some(DiffuseComparison::new(ours, rival, config.seed))
        })
        .collect();
    let equal_error = nearest
        .and_then(|k| {
            rows.iter()
                .find(|r| r.family == Family::Grid && r.probes == k)
        })
        .map(|g| EqualError::new(g, &ours_rows, default_method));
    let figures = match lit {
        Some(view) => Some(lit_figures(
            config,
            over,
            view,
            &rows,
            &comparisons,
            default_method,
        )?),
        None => None,
    };
    let r = &bench.receivers;
    let mean = |v: &[crate::diffuse::Irradiance]| {
        let k = v.len().max(1) as f64;
        let lum = |x: Vec3| crate::render::lights::luminance(x) as f64;
        Parts {
            total: v.iter().map(|e| lum(e.total)).sum::<f64>() / k,
            baked: v.iter().map(|e| lum(e.baked)).sum::<f64>() / k,
        }
    };
    let d = &config.compare.diffuse;
    // A probe at every surface receiver: the blend's own limit.
    let at: Vec<Vec3> = r.surface.iter().map(|x| x.p).collect();
    let limit = (!at.is_empty()).then(|| {
        let m = stages::diffuse::measure(config, over.prepared, bench, &at, &vec![true; at.len()]);
        crate::diffuse::mean(&m.tetrahedra.surface.baked).unwrap_or(0.0)
    });
    let setup = DiffuseSetup {
        materials: "scene",
        surface_receivers: r.surface.len(),
        free_receivers: r.free.len(),
        reference_rays: d.reference_rays.0,
        probe_rays: d.probe_rays.0,
        bounces: config.bake.bounces.0,
        unreachable_fraction: bench.reachable.excluded_fraction(),
        surface_reference_mean: mean(&r.surface_reference),
        free_reference_mean: mean(&r.free_reference),
        emitters: stages::diffuse::emitters(config, &over.prepared.scene),
        limit,
    };
    Ok(Measured {
        section: DiffuseSection {
            setup,
            placements: rows,
            comparisons,
            equal_error,
        },
        figures,
        warnings,
    })
}

/// The lit views of `view` for ours (`method`) and each rival it is
/// compared with (the probes placed again: the rows keep no positions).
fn lit_figures(
    config: &crate::config::Config,
    over: &Over,
    view: &stages::diffuse::LitView,
    rows: &[DiffusePlacement],
    comparisons: &[DiffuseComparison],
    method: &str,
) -> Result<LitFigures> {
    use crate::encode::png::encode_png;
    let reference = view.reference();
    let exposure = crate::stages::validate::auto_exposure(&reference);
    let png = |pixels: &[[f32; 3]], what: &str| {
        encode_png(
            &crate::raster::tonemap(pixels, view.width, view.height, exposure),
            what,
        )
    };
    let mut placements = Vec::new();
    let mut shown: Vec<&str> = Vec::new();
    if let Some(c) = comparisons.iter().find(|c| c.family == Family::Grid) {
        shown.push(&c.ours);
        shown.push(&c.rival);
    }
    shown.extend(
        comparisons
            .iter()
            .filter(|c| c.family != Family::Grid)
            .map(|c| c.rival.as_str()),
    );
    if shown.is_empty() {
        shown.push(method);
    }
    shown.dedup();
    for name in shown {
        let Some(row) = rows.iter().find(|r| r.name == name) else {
            continue;
        };
        let positions = &row.positions;
        let valid = crate::coverage::probes_free(
            &over.prepared.bvh,
            over.prepared.sdf.voxel_size,
            positions,
        );
        let renderer = over.prepared.renderer(config);
        let sh = crate::diffuse::bake_sh(
            &renderer,
            positions,
            config.compare.diffuse.probe_rays.0,
            config.seed ^ 0x5A5A,
        );
        let lookup = crate::diffuse::ShLookup::new(positions, &sh, &valid);
        let (image, error) = view.render(&lookup);
        let mean = error.iter().map(|&e| e as f64).sum::<f64>() / error.len().max(1) as f64;
        placements.push((
            row.name.clone(),
            png(&image, "diffuse render")?,
            encode_png(
                &stages::diffuse::error_map(&error, view.width, view.height),
                "diffuse error map",
            )?,
            mean,
        ));
    }
    Ok(LitFigures {
        reference: png(&reference, "diffuse reference")?,
        placements,
    })
}
