//! Light-field probes end to end (McGuire et al. 2017 §3–§5): the min/max
//! pyramid is conservative and the CPU tracer finds the hits exact ray
//! casts find, on the Cornell boxes and Holodeck, with both probe
//! selections; `bake` writes what it documents and its reference converges.

use crate::common::*;
use probeplace::lightfield::{pyramid, LightField};
use probeplace::svo;
use probeplace::trace::single::March;
use probeplace::trace::{check, Lattice, Selection};
use std::path::Path;

/// Rays per scene and selection in the tracer comparison.
const RAYS: usize = 6000;

/// Places probes for `config` (with `method`, unrefined when a grid), bakes
/// them at the config's resolution, and checks the pyramid and the tracer.
/// Returns the tracer's agreement. Radiance plays no part in tracing: the
/// bakes are the GPU tests' (`baked_probes`).
fn check_scene(config: &str, method: Option<&str>) -> check::Agreement {
    let (run, field) = baked_probes(config, method);
    let p = &run.prepared;
    let positions = &field.positions;
    let n = field.resolution;
    let checked = pyramid::verify(n, &field.distance, &field.pyramid, 2 * n * n)
        .unwrap_or_else(|e| panic!("{config}: pyramid not conservative: {e}"));
    assert_eq!(
        checked,
        (positions.len() as u64) * 2 * (n * n) as u64 * field.pyramid.len() as u64
    );

    let progress = probeplace::progress::Progress::hidden();
    let input = p.placement_input(run.config().seed, &progress);
    let origins = svo::random_free_points(&input, RAYS, 0x5EED_0F0A);
    let lattice;
    let selection = match method {
        Some(_) => {
            lattice = Lattice::from_positions(positions).expect("a grid run gives a lattice");
            Selection::Grid(&lattice)
        }
        None => Selection::Svo(&run.svo),
    };
    let [a, flat] = [March::HiZ, March::Texel]
        .map(|m| check::compare(field, &selection, &p.scene, &p.bvh, &origins, 77, m));
    // Same answers up to rounding: texel spans computed at different levels
    // differ in the last bits, which can tip a ray grazing a texel's edge.
    assert_eq!(a.seen, flat.seen);
    assert!(
        a.agree.abs_diff(flat.agree) * 1000 <= a.seen
            && a.unknown.abs_diff(flat.unknown) * 1000 <= a.seen,
        "{config}: the Hi-Z march must answer as the texel march does: {a:?} vs {flat:?}"
    );
    assert!(
        a.fine_steps < flat.fine_steps,
        "{config}: {a:?} vs {flat:?}"
    );
    eprintln!("{config} {method:?}: {a:?}, rate {:.4}", a.rate());
    assert!(a.seen as f64 >= 0.8 * RAYS as f64, "{config}: {a:?}");
    // The tracer answers what an exact ray cast does for 98.5% of the
    // rays some probe sees or more: 98.75% on our Cornell box's three
    // probes (2026-12-05), 98.9–99.5% on the scenes' earlier, larger sets.
    assert!(a.rate() >= 0.985, "{config} {method:?}: {a:?}");
    a
}

#[test]
fn tracer_and_pyramid_on_our_cornell_box() {
    check_scene("configs/cornell.ron", None);
    check_scene("configs/cornell.ron", Some("grid:4x4x4"));
}

#[test]
fn tracer_and_pyramid_on_cornell_glossy() {
    shared_scenes();
    check_scene("configs/cornell-glossy.ron", None);
    check_scene("configs/cornell-glossy.ron", Some("grid:6x6x6"));
}

#[test]
#[ignore = "full tier (about 10 s): cargo test --release -- --include-ignored"]
fn tracer_and_pyramid_on_holodeck() {
    shared_scenes();
    check_scene("configs/holodeck.ron", None);
    check_scene("configs/holodeck.ron", Some("grid:8x3x5"));
}

/// Rays that leave a surface, as the validation renders' glossy rays do,
/// must not be answered with a hit at their own origin. The check above
/// starts its rays in free space and never saw this: in CornellBox-Glossy
/// (a faceted sphere, boxes) a glossy ray's origin often lies a little
/// behind a surfel's plane (half precision, or a neighbouring facet's
/// plane), and the surfel test took that as a hit at t = 0 for 5.6% of
/// these rays (from the glossy sphere and box), which then read the
/// shading point's own radiance (docs/method.md, "Rays that hit their own
/// origin"); 0.5% since.
#[test]
fn rays_leaving_surfaces_do_not_hit_their_origin() {
    use probeplace::sampling::uniform_direction;
    use probeplace::trace::{single::Steps, trace, RayOutcome};
    shared_scenes();
    let (run, field) = baked_probes("configs/cornell-glossy.ron", None);
    let p = &run.prepared;
    let progress = probeplace::progress::Progress::hidden();
    let input = p.placement_input(run.config().seed, &progress);
    let starts = svo::random_free_points(&input, 4 * RAYS, 0x0516_1A55);
    let diag = p.scene.bounds.size().length();
    let bounds = check::padded_bounds(&p.scene.bounds);
    let (mut rays, mut at_origin) = (0usize, 0usize);
    for (i, &s) in starts.iter().enumerate() {
        // A surface point seen from free space, lifted off it as the
        // renders lift their shading points, and a direction leaving it.
        let towards = uniform_direction(0x5EF, i as u64);
        let Some(h) = p
            .bvh
            .closest_hit(s, towards, 0.0, bounds.exit_distance(s, towards))
        else {
            continue;
        };
        // Glossy rays leave glossy surfaces: the sphere and the short box.
        let material = &p.scene.materials[p.scene.material_ids[h.triangle as usize] as usize];
        if material.specular.iter().all(|&k| k == 0.0) {
            continue;
        }
        let mut n = p.scene.normals[h.triangle as usize];
        if n.dot(towards) > 0.0 {
            n = -n;
        }
        let o = s + towards * h.t + n * (1e-4 * diag);
        let mut d = uniform_direction(0x0A11, i as u64);
        if d.dot(n) < 0.0 {
            d = -d;
        }
        let t_max = bounds.exit_distance(o, d);
        let truth = p.bvh.closest_hit(o, d, 0.0, t_max).map_or(t_max, |h| h.t);
        if truth < 0.02 * diag {
            continue;
        }
        rays += 1;
        let mut steps = Steps::default();
        let out = trace(
            field,
            &Selection::Svo(&run.svo),
            o,
            d,
            t_max,
            March::HiZ,
            &mut steps,
        );
        if matches!(out, RayOutcome::Hit { t, .. } if t < 0.005 * diag) {
            at_origin += 1;
        }
    }
    let share = at_origin as f64 / rays.max(1) as f64;
    eprintln!(
        "cornell-glossy: {at_origin} of {rays} rays leaving surfaces hit at their origin ({:.2}%)",
        100.0 * share
    );
    assert!(rays > RAYS / 4, "{rays}");
    assert!(
        share < 0.01,
        "{at_origin} of {rays} rays leaving surfaces hit at their origin"
    );
}

/// What a bake wrote into `dir` is what its report `r` says: the light
/// field, its previews, the reference images, the placement's files, the
/// bake's timings and tracer check.
fn assert_bake_outputs(config: &str, r: &serde_json::Value, dir: &Path) {
    let bk = &r["bake"];
    let field = LightField::read(&dir.join("lightfield.bin")).unwrap();
    assert_eq!(
        field.positions.len() as u64,
        r["probe_count"].as_u64().unwrap()
    );
    assert_eq!(bk["resolution"].as_u64().unwrap(), field.resolution as u64);
    assert_eq!(
        bk["bytes"].as_u64().unwrap(),
        std::fs::metadata(dir.join("lightfield.bin")).unwrap().len()
    );
    assert!(
        field.radiance.iter().any(|c| c.iter().any(|&v| v > 0.0)),
        "{config}: black probes"
    );
    assert!(field
        .radiance
        .iter()
        .flatten()
        .all(|v| v.is_finite() && *v >= 0.0));
    for name in [
        "radiance.exr",
        "radiance.png",
        "irradiance.exr",
        "irradiance.png",
        "distance.png",
        "normal.png",
        "reference.exr",
        "reference.png",
        "reference-glossy.exr",
        "reference-glossy.png",
        "probes.json",
        "svo.bin",
    ] {
        assert!(dir.join(name).is_file(), "{config}: {name} missing");
    }
    for step in [
        "geometry",
        "radiance",
        "pyramid",
        "irradiance",
        "reference",
        "total",
    ] {
        assert!(bk["timings_ms"][step].as_f64().unwrap() >= 0.0, "{step}");
    }
    assert!(bk["tracer"]["seen"].as_u64().unwrap() > 0);
}

/// The acceptance, at the shipped config's quality: bake and reference
/// complete, the files are what the report says, and the reference
/// converges: the means of two seeds' references agree within 5%. `first`
/// is a run with the config's own seed (1), shared with other tests; the
/// run with seed 2 is made here. Returns the first run's report.
fn bake_converges(config: &str, first: &'static Shared) -> &'static serde_json::Value {
    assert_eq!(
        first.report["seed"], 1,
        "{config}: the first run has seed 1"
    );
    let b = tempfile::tempdir().unwrap();
    let ra = &first.report;
    let rb = run_job("bake", &root().join(config), b.path(), &["--seed", "2"]);
    assert_bake_outputs(config, ra, &first.dir);
    assert_bake_outputs(config, &rb, b.path());
    let (ma, mb) = (
        luminance(&ra["bake"]["reference"]["mean"]),
        luminance(&rb["bake"]["reference"]["mean"]),
    );
    assert!(ma > 0.0, "{config}: black reference");
    assert!(
        (ma - mb).abs() <= 0.05 * ma.max(mb),
        "{config}: reference means {ma} and {mb} differ by more than 5%"
    );
    ra
}

#[test]
#[ignore = "full tier (about 8 s): cargo test --release -- --include-ignored"]
fn cornell_fixture_bakes_and_its_reference_converges() {
    let config = "configs/cornell.ron";
    bake_converges(config, shared_job("bake", config, &[]));
}

/// The suite's shared bake of our all-diffuse box: its outputs are what its
/// report says, and its reference holds no glossy indirect light at all.
#[test]
fn cornell_fixture_bakes_without_glossy_light() {
    let config = "configs/cornell.ron";
    let run = shared_job("bake", config, &[]);
    assert_bake_outputs(config, &run.report, &run.dir);
    assert_eq!(
        luminance(&run.report["bake"]["reference"]["glossy_indirect_mean"]),
        0.0
    );
}

#[test]
fn cornell_glossy_bakes_and_its_reference_converges() {
    shared_scenes();
    // `render` bakes first: its run is the acceptance render's.
    let config = "configs/cornell-glossy.ron";
    let r = bake_converges(config, shared_job("render", config, &[]));
    assert!(luminance(&r["bake"]["reference"]["glossy_indirect_mean"]) > 0.0);
}

/// Same config and seed: byte-identical maps and images; and `inspect`
/// checks and summarizes the light field beside the SVO, and refuses a
/// damaged one in one line. At test quality.
#[test]
fn bake_is_deterministic_and_inspect_checks_the_light_field() {
    let config = test_quality("configs/cornell.ron", &[]);
    let (first, again) = (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
    let r = run_job("bake", config.path(), first.path(), &[]);
    run_job("bake", config.path(), again.path(), &[]);
    assert_bake_outputs("cornell (test quality)", &r, first.path());
    for name in [
        "lightfield.bin",
        "reference.exr",
        "reference-glossy.exr",
        "radiance.png",
        "svo.bin",
    ] {
        assert!(
            std::fs::read(first.path().join(name)).unwrap()
                == std::fs::read(again.path().join(name)).unwrap(),
            "{name} differs between two runs of the same config"
        );
    }
    let resolution = config.load().bake.resolution.0;
    assert_eq!(r["bake"]["resolution"], resolution);
    let o = probeplace(&["inspect", again.path().to_str().unwrap()]);
    let text = String::from_utf8_lossy(&o.stdout).into_owned();
    assert!(
        o.status.success()
            && text.contains(&format!(
                "lightfield.bin: {} probes, {resolution}² maps",
                r["probe_count"]
            )),
        "{text}"
    );
    let lf = again.path().join("lightfield.bin");
    let mut bytes = std::fs::read(&lf).unwrap();
    let mid = bytes.len() / 2;
    bytes[mid] ^= 1;
    std::fs::write(&lf, bytes).unwrap();
    let o = probeplace(&["inspect", again.path().to_str().unwrap(), "--quiet"]);
    let e = String::from_utf8_lossy(&o.stderr).into_owned();
    assert_eq!(o.status.code(), Some(2), "{e}");
    assert!(
        e.contains("lightfield.bin") && e.contains("checksum") && e.trim().lines().count() == 1,
        "{e}"
    );
    assert!(o.stdout.is_empty());
}
