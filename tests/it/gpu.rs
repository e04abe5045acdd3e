//! The GPU kernels against their CPU twins, on real scenes: the bi-level
//! and Hi-Z traces (McGuire et al. 2017 §4; Wang et al. 2019 §4.2) agree
//! with the CPU tracer, and with each other, on hit/miss and on the texel
//! a hit is read from; the irradiance gather (McGuire §5.2) matches its
//! twin, and so do the blend weights it uses; and Hi-Z reads fewer texels
//! than bi-level.

use crate::common::*;
use probeplace::gpu::{kind, twin, ProbeTracer, Query, Record, SelectionKind};
use probeplace::jobs::place::PlaceRun;
use probeplace::lightfield::LightField;
use probeplace::sampling::uniform_direction;
use probeplace::svo;
use probeplace::trace::check::padded_bounds;
use probeplace::trace::single::March;
use probeplace::trace::{Lattice, Selection};

/// Rays per scene in the comparisons.
const RAYS: usize = 6000;

/// Places `config`'s probes (or a grid, for `method`) and bakes a light
/// field whose radiance is a colour per direction, so that a wrong texel
/// reads a wrong colour (shared with the tracer tests of `lightfield`).
fn scene(config: &str, method: Option<&str>) -> &'static (PlaceRun, LightField) {
    baked_probes(config, method)
}

/// Random rays from free points, each to the padded bounds.
fn rays(run: &PlaceRun) -> Vec<Query> {
    let p = &run.prepared;
    let progress = probeplace::progress::Progress::hidden();
    let input = p.placement_input(1, &progress);
    let bounds = padded_bounds(&p.scene.bounds);
    svo::random_free_points(&input, RAYS, 0x6EF0)
        .into_iter()
        .enumerate()
        .map(|(i, o)| {
            let d = uniform_direction(17, i as u64);
            Query {
                origin: o.to_array(),
                t_max: bounds.exit_distance(o, d),
                dir: d.to_array(),
                pad: 0.0,
            }
        })
        .collect()
}

/// Share of records that agree on hit/miss/unknown and, for hits, on the
/// probe and texel.
fn agreement(a: &[Record], b: &[Record]) -> f64 {
    assert_eq!(a.len(), b.len());
    let same = a
        .iter()
        .zip(b)
        .filter(|(x, y)| {
            x.kind == y.kind && (x.kind != kind::HIT || (x.probe, x.texel) == (y.probe, y.texel))
        })
        .count();
    same as f64 / a.len() as f64
}

fn mean_fetches(r: &[Record]) -> f64 {
    r.iter().map(|x| x.fetches as f64).sum::<f64>() / r.len() as f64
}

/// Every comparison of the issue on one scene and selection.
fn compare(test: &str, config: &str, method: Option<&str>) {
    let Some(ctx) = gpu_context(test) else {
        return;
    };
    let (run, field) = scene(config, method);
    let lattice = method.map(|_| Lattice::from_positions(&field.positions).unwrap());
    let (selection, kind_of) = match &lattice {
        Some(l) => (Selection::Grid(l), SelectionKind::Grid),
        None => (Selection::Svo(&run.svo), SelectionKind::Svo),
    };
    let tracer = ProbeTracer::new(&ctx, field, Some(&run.svo), lattice.as_ref()).unwrap();
    let queries = rays(run);
    let mut gpu = Vec::new();
    for march in [March::BiLevel, March::HiZ] {
        let cpu = twin::trace_rays(field, &selection, &queries, march);
        let (g, _) = tracer.trace_rays(&queries, march, kind_of).unwrap();
        let rate = agreement(&cpu, &g);
        let hits = g.iter().filter(|r| r.kind == kind::HIT).count();
        let same_fetches = cpu
            .iter()
            .zip(&g)
            .filter(|(a, b)| (a.fetches, a.surfels, a.probes) == (b.fetches, b.surfels, b.probes))
            .count();
        eprintln!(
            "{config} {method:?} {march:?}: GPU vs CPU agree {rate:.4}, {hits} hits, fetches/ray GPU {:.1} CPU {:.1}, equal counts {same_fetches}",
            mean_fetches(&g),
            mean_fetches(&cpu)
        );
        assert!(hits * 2 > RAYS, "{config}: most rays should hit: {hits}");
        assert!(
            rate >= 0.99,
            "{config} {march:?}: GPU and CPU agree on {rate}"
        );
        assert!(
            same_fetches * 100 >= 98 * RAYS,
            "{config} {march:?}: fetch counts differ: {same_fetches}"
        );
        let radiance_ok = cpu
            .iter()
            .zip(&g)
            .filter(|(a, b)| a.kind == b.kind && a.texel == b.texel && a.probe == b.probe)
            .all(|(a, b)| a.radiance == b.radiance);
        assert!(
            radiance_ok,
            "{config}: the same texel must read the same radiance"
        );
        gpu.push(g);
    }
    let between = agreement(&gpu[0], &gpu[1]);
    let (bilevel, hiz) = (mean_fetches(&gpu[0]), mean_fetches(&gpu[1]));
    eprintln!("{config} {method:?}: bi-level vs Hi-Z agree {between:.4}; fetches {bilevel:.1} vs {hiz:.1}");
    assert!(
        between >= 0.99,
        "{config}: bi-level and Hi-Z agree on {between}"
    );
    assert!(hiz < bilevel, "{config}: Hi-Z should read fewer texels");

    // Irradiance at the ray origins, facing along the rays.
    let cpu = twin::gather_irradiance(field, &selection, &queries);
    let (g, _) = tracer.gather_irradiance(&queries, kind_of).unwrap();
    let close = cpu
        .iter()
        .zip(&g)
        .filter(|(a, b)| {
            (0..3).all(|c| {
                (a.radiance[c] - b.radiance[c]).abs() <= 1e-3 * (1.0 + a.radiance[c].abs())
            })
        })
        .count();
    eprintln!("{config} {method:?}: irradiance within 1e-3 on {close}/{RAYS}");
    assert!(
        close * 1000 >= 999 * RAYS,
        "{config}: irradiance differs: {close}"
    );
    assert!(cpu
        .iter()
        .all(|r| r.radiance.iter().all(|v| v.is_finite() && *v >= 0.0)));
    blend_weights_agree(
        &ctx.adapter,
        &format!("{config} {method:?}"),
        &tracer,
        field,
        &selection,
        kind_of,
        &queries,
    );
}

/// Points whose every blend weight the GPU computes against the CPU, per
/// scene: each is as many queries as the blend has terms, and each query
/// weighs them all again.
const BLEND_POINTS: usize = 400;

/// The kernel `blend_weights` (the weights `gather_irradiance` blends with)
/// against `trace::gather::blend_weights` at the first [`BLEND_POINTS`]
/// ray origins (facing along the rays) and at the first probes (r = 0):
/// the same probe for every term, and the same weight bit for bit on
/// lavapipe (llvmpipe: IEEE division and square root, no fused
/// multiply-add, as CI runs it), within [`BLEND_ULPS`] units of 1.0 in
/// the last place on other adapters (WGSL allows f32 division 2.5 ULP and
/// `length` its own error, and a GPU compiler may fuse a multiply and an
/// add).
fn blend_weights_agree(
    adapter: &str,
    label: &str,
    tracer: &ProbeTracer,
    field: &LightField,
    selection: &Selection,
    kind_of: SelectionKind,
    queries: &[Query],
) {
    let terms = match selection {
        Selection::Grid(_) => 8,
        Selection::Svo(_) => field.positions.len(),
    };
    let at_probes = field.positions.iter().take(8).map(|q| Query {
        origin: q.to_array(),
        t_max: 0.0,
        dir: [0.0, 1.0, 0.0],
        pad: 0.0,
    });
    let points: Vec<Query> = queries[..BLEND_POINTS]
        .iter()
        .copied()
        .chain(at_probes)
        .collect();
    let expanded: Vec<Query> = points
        .iter()
        .flat_map(|q| {
            (0..terms).map(|k| Query {
                t_max: k as f32,
                ..*q
            })
        })
        .collect();
    let start = std::time::Instant::now();
    let cpu = twin::blend_weights(field, selection, &expanded);
    let cpu_s = start.elapsed().as_secs_f64();
    let start = std::time::Instant::now();
    let (gpu, _) = tracer.blend_weights(&expanded, kind_of).unwrap();
    let gpu_s = start.elapsed().as_secs_f64();
    let mut exact = 0;
    let mut worst = (0.0f32, 0usize);
    for (i, (a, b)) in cpu.iter().zip(&gpu).enumerate() {
        assert_eq!(
            (a.probe, a.texel),
            (b.probe, b.texel),
            "{label}: term {i}: probes differ"
        );
        assert_ne!(a.probe, u32::MAX, "{label}: term {i} has no weight");
        exact += (a.t.to_bits() == b.t.to_bits()) as usize;
        let err = (a.t - b.t).abs() / f32::EPSILON;
        if err > worst.0 {
            worst = (err, i);
        }
    }
    eprintln!(
        "{label}: blend weights of {} points × {terms} terms: {exact} of {} bit for bit, worst {:.1} ε (term {}: CPU {} GPU {}); CPU {cpu_s:.2} s, GPU {gpu_s:.2} s",
        points.len(),
        expanded.len(),
        worst.0,
        worst.1,
        cpu[worst.1].t,
        gpu[worst.1].t
    );
    if adapter.contains("llvmpipe") {
        assert_eq!(
            exact,
            expanded.len(),
            "{label}: lavapipe's weights are Rust's bits"
        );
    }
    assert!(
        worst.0 <= BLEND_ULPS,
        "{label}: a GPU blend weight differs by {} ε",
        worst.0
    );
}

/// How far (in units of f32::EPSILON) a GPU's blend weight may stray from
/// Rust's where the adapter's arithmetic is not IEEE's: some ten roundings
/// of up to 2.5 ULP each, with margin.
const BLEND_ULPS: f32 = 64.0;

#[test]
fn kernels_match_their_twins_on_cornell_glossy() {
    shared_scenes();
    compare(
        "kernels_match_their_twins_on_cornell_glossy",
        "configs/cornell-glossy.ron",
        None,
    );
}

#[test]
fn kernels_match_their_twins_on_holodeck() {
    shared_scenes();
    compare(
        "kernels_match_their_twins_on_holodeck",
        "configs/holodeck.ron",
        None,
    );
}

#[test]
fn kernels_match_their_twins_on_a_grid() {
    compare(
        "kernels_match_their_twins_on_a_grid",
        "configs/cornell.ron",
        Some("grid:4x4x4"),
    );
}
