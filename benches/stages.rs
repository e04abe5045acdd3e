//! Stage benchmarks: `cargo bench -p probeplace-benches --bench stages`.
//!
//! Each stage of `place` timed on our Cornell box fixture (tiny, 32
//! triangles) and on Dabrovic Sponza (66k triangles, read from
//! ../shared/scenes). Figures and the machine they came from are recorded in
//! BENCHMARKS.md; compare ratios within one run, the machines are shared.

use criterion::{criterion_group, criterion_main, Criterion};
use probeplace::config::{
    Config, CoverageParams, FitnessKind, MedialAxisParams, Placement, RefineParams, SdfParams,
    SdfSkeletonParams, SvoParams,
};
use probeplace::coverage::CoverageReference;
use probeplace::placement::{place, PlacementInput};
use probeplace::progress::Progress;
use probeplace::refine::{self, atlas::Atlas, fitness::AtlasState, view::Viewer};
use probeplace::scene::{load_obj, raycast::SceneBvh};
use probeplace::sdf;
use probeplace::svo;
use std::path::Path;

fn stages(c: &mut Criterion, name: &str, config: &str) {
    let root = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/.."));
    let cfg = Config::load(&root.join(config)).expect("config loads");
    let scene = load_obj(&cfg.scene, cfg.scale.0, cfg.up).expect("scene loads");
    let progress = Progress::hidden();
    let mut g = c.benchmark_group(name);
    g.sample_size(10);
    g.bench_function("load", |b| {
        b.iter(|| load_obj(&cfg.scene, cfg.scale.0, cfg.up).unwrap())
    });
    g.bench_function("bvh", |b| b.iter(|| SceneBvh::new(&scene)));
    let bvh = SceneBvh::new(&scene);
    let params = SdfParams::default();
    let build_sdf = || {
        sdf::build(
            &scene,
            &bvh,
            &scene.bounds,
            probeplace::stages::resolve_voxel_size(&cfg, &scene, &bvh, &scene.bounds).voxel_size,
            &params,
            1,
            &progress,
        )
        .unwrap()
    };
    g.bench_function("sdf", |b| b.iter(build_sdf));
    let field = build_sdf();
    let input = PlacementInput {
        scene: &scene,
        bvh: &bvh,
        sdf: &field,
        domain: &scene.bounds,
        seed: 1,
        progress: &progress,
    };
    let method = Placement::SdfSkeleton(SdfSkeletonParams::default());
    g.bench_function("sdf-skeleton", |b| {
        b.iter(|| place(&method, &input).unwrap())
    });
    let medial = Placement::MedialAxis(MedialAxisParams::default());
    g.bench_function("medial-axis", |b| {
        b.iter(|| place(&medial, &input).unwrap())
    });
    let probes = place(&method, &input).unwrap().positions();
    let cov = CoverageParams::default();
    g.bench_function("coverage", |b| {
        b.iter(|| {
            CoverageReference::by_rays(&scene, &bvh, &field, &scene.bounds, &cov, 1, &progress)
                .evaluate(&bvh, &probes, &progress)
        })
    });
    // Refinement: the whole stage on the sdf-skeleton probes, and its hot
    // loop: one probe view (32² rays), the incremental score of a moved
    // probe against the full recomputation it replaces.
    let reference =
        CoverageReference::by_rays(&scene, &bvh, &field, &scene.bounds, &cov, 1, &progress);
    let set = place(&method, &input).unwrap();
    let rp = RefineParams::default();
    g.bench_function("refine", |b| {
        b.iter(|| {
            refine::refine(&rp, set.clone(), &input, &reference, &Default::default()).unwrap()
        })
    });
    let texel = field.largest_clearance() * (4.0 * std::f32::consts::PI).sqrt() / 32.0;
    let atlas = Atlas::new(&scene, texel).unwrap();
    let viewer = Viewer::new(
        &scene,
        &bvh,
        &atlas,
        32,
        0.087,
        1.0,
        1.0,
        scene.bounds.size().length(),
    );
    g.bench_function("refine_view_1024_rays", |b| {
        b.iter(|| viewer.view(probes[0]))
    });
    let state = AtlasState::new(
        FitnessKind::Saturating,
        &atlas,
        probes.iter().map(|&p| viewer.view(p)).collect(),
    );
    let moved = viewer.view(probes[0] + glam::Vec3::splat(field.voxel_size));
    g.bench_function("refine_delta", |b| b.iter(|| state.delta(0, &moved)));
    g.bench_function("refine_recompute", |b| b.iter(|| state.recompute()));
    // The SVO of the refined probes (Wang §4.1), and its point queries:
    // 64k uniform points of the domain, free or not, as a renderer asks.
    let refined = refine::refine(&rp, set.clone(), &input, &reference, &Default::default())
        .unwrap()
        .probes;
    let sp = SvoParams::default();
    g.bench_function("svo", |b| {
        b.iter(|| svo::bake(&sp, &refined, &input).unwrap())
    });
    let tree = svo::bake(&sp, &refined, &input).unwrap().svo;
    let size = scene.bounds.size();
    let points: Vec<glam::Vec3> = (0..65_536u64)
        .map(|i| {
            let h = probeplace::sampling::hash2(9, i);
            let u = |k| probeplace::sampling::unit_f32(probeplace::sampling::hash2(h, k));
            scene.bounds.min + size * glam::Vec3::new(u(1), u(2), u(3))
        })
        .collect();
    g.throughput(criterion::Throughput::Elements(points.len() as u64));
    g.bench_function("svo_queries_64k", |b| {
        b.iter(|| {
            points
                .iter()
                .map(|&p| tree.probes_at(p).len())
                .sum::<usize>()
        })
    });
    // The light-field bake (McGuire §3, §5.2) of the first 8 refined probes (all 6 on Cornell)
    // at the config's resolution, and the CPU light-field trace (McGuire
    // Listing 1, SVO selection) of 4096 random rays, Hi-Z and texel march.
    let renderer = probeplace::render::Renderer::new(&scene, &bvh, &cfg.lights, cfg.bake.bounces.0);
    let radiance = |o: glam::Vec3, d: glam::Vec3, stream: u64| {
        renderer.radiance(o, d, &mut probeplace::sampling::Sampler::new(1, stream))
    };
    let eight: Vec<glam::Vec3> = refined.positions().into_iter().take(8).collect();
    let max_distance = scene.bounds.size().length();
    let bake = || {
        probeplace::lightfield::bake(
            &cfg.bake,
            &eight,
            &scene,
            &bvh,
            max_distance,
            1,
            &radiance,
            &progress,
        )
    };
    g.throughput(criterion::Throughput::Elements(eight.len() as u64));
    g.bench_function("lightfield_bake", |b| b.iter(bake));
    let all = refined.positions();
    let light_field = probeplace::lightfield::bake(
        &cfg.bake,
        &all,
        &scene,
        &bvh,
        max_distance,
        1,
        &|_, _, _| glam::Vec3::ZERO,
        &progress,
    )
    .field;
    let origins = svo::random_free_points(&input, 4096, 3);
    let dirs = probeplace::sampling::fibonacci_sphere(origins.len() as u32);
    let bounds = probeplace::trace::check::padded_bounds(&scene.bounds);
    let rays: Vec<(glam::Vec3, glam::Vec3, f32)> = origins
        .iter()
        .zip(&dirs)
        .map(|(&o, &d)| (o, d, bounds.exit_distance(o, d)))
        .collect();
    let selection = probeplace::trace::Selection::Svo(&tree);
    g.throughput(criterion::Throughput::Elements(rays.len() as u64));
    for (label, march) in [
        (
            "lightfield_trace_4k_rays_hiz",
            probeplace::trace::single::March::HiZ,
        ),
        (
            "lightfield_trace_4k_rays_bilevel",
            probeplace::trace::single::March::BiLevel,
        ),
        (
            "lightfield_trace_4k_rays_texel",
            probeplace::trace::single::March::Texel,
        ),
    ] {
        g.bench_function(label, |b| {
            b.iter(|| {
                let mut steps = probeplace::trace::single::Steps::default();
                rays.iter()
                    .filter(|(o, d, t)| {
                        matches!(
                            probeplace::trace::trace(
                                &light_field,
                                &selection,
                                *o,
                                *d,
                                *t,
                                march,
                                &mut steps
                            ),
                            probeplace::trace::RayOutcome::Hit { .. }
                        )
                    })
                    .count()
            })
        });
    }
    // Ray throughput: 64k rays from the domain centre, closest hit.
    let centre = (scene.bounds.min + scene.bounds.max) * 0.5;
    let dirs = probeplace::sampling::fibonacci_sphere(65_536);
    g.throughput(criterion::Throughput::Elements(dirs.len() as u64));
    g.bench_function("closest_hit_64k_rays", |b| {
        b.iter(|| {
            dirs.iter()
                .filter(|d| bvh.closest_hit(centre, **d, 0.0, f32::INFINITY).is_some())
                .count()
        })
    });
    g.finish();
}

fn cornell(c: &mut Criterion) {
    stages(c, "cornell", "configs/cornell.ron");
}

fn sponza(c: &mut Criterion) {
    stages(c, "sponza", "configs/sponza.ron");
}

criterion_group!(benches, cornell, sponza);
criterion_main!(benches);
