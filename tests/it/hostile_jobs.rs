//! Refusals up front and messages that name the real cause (issue 70):
//! a job refuses what it cannot do before the work that comes before it
//! (`compare` before its references), names the field that is the cause
//! (the lights and bounces of a bake, not its maps; a `reachable` point,
//! by its index), and does not refuse what the docs promise to accept
//! (`compare.diffuse` with no receivers). Each refusal holds the contract
//! of [`refused_in`]: exit 2, one line, nothing written, under a timeout.

use crate::common::*;
use crate::hostile::{Scratch, CUBE_ROOM};
use std::process::Command;
use std::time::Duration;

/// A camera for the scratch room, with a tiny reference: the views'
/// references cost next to nothing.
const CAMERA: &str = "reference: (camera: (position: (1, 1, 0.3), look_at: (1, 1, 1.5)), width: 16, height: 12, samples_per_pixel: 4),\ncoverage: (samples: 2000, reference_points: 512),\n";

/// `compare` refuses a `min_probes` top-up it cannot make as `place`
/// does, with `place`'s words, in about `place`'s time: before choosing
/// views or making their references.
#[test]
fn compare_refuses_a_top_up_it_cannot_make_before_its_references() {
    let s = Scratch::new();
    // Large references, which the old compare made before refusing.
    s.config(
        "cmp.ron",
        "reference: (camera: (position: (1, 1, 0.3), look_at: (1, 1, 1.5)), width: 320, height: 240, samples_per_pixel: 256),\ncompare: (views: 4),\nmin_probes: 60000,\n",
    );
    let place = refused_in(s.dir.path(), &["place", "cmp.ron"], &[]);
    assert!(place.line.contains("min_probes: "), "{}", place.line);
    let compare = refused_in(s.dir.path(), &["compare", "cmp.ron", "--cpu"], &[]);
    assert_eq!(compare.line, place.line, "compare words it otherwise");
    assert!(
        compare.took < place.took * 3 + Duration::from_secs(2),
        "compare took {:?}, place {:?}",
        compare.took,
        place.took
    );
}

/// `compare.diffuse` with both receiver counts 0 is no diffuse
/// evaluation, as docs/config.md says: accepted, and nothing of it runs,
/// however costly its probe projections would have been.
#[test]
fn compare_with_no_diffuse_receivers_runs_no_diffuse_evaluation() {
    let s = Scratch::new();
    s.config(
        "cmp.ron",
        &format!("{CAMERA}compare: (diffuse: (surface_receivers: 0, free_receivers: 0, probe_rays: 65536)),\nlights: [Point(position: (1, 1.5, 1), intensity: (1, 1, 1))],\n"),
    );
    // A 5 s work limit: the old estimate of the probes' projections
    // alone (1000 probes at 65 536 rays) ran far past it.
    let o = Command::new("timeout")
        .args(["--signal=KILL", "120"])
        .arg(env!("CARGO_BIN_EXE_probeplace"))
        .args([
            "compare", "cmp.ron", "--cpu", "--quiet", "--only", "diffuse", "--out", "c",
        ])
        .env("PROBEPLACE_WORK_LIMIT", "5")
        .current_dir(s.dir.path())
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(0), "{stderr}");
    let r = read_json(&s.path("c/compare.json"));
    assert!(
        r["diffuse"].is_null() || r["diffuse"].as_array().is_some_and(|d| d.is_empty()),
        "a diffuse evaluation ran: {}",
        r["diffuse"]
    );
}

/// A comparison whose bakes are too much work because every path vertex
/// of many bounces casts a shadow ray to each of many lights is refused
/// naming `bake.bounces` and `lights`, not `bake.resolution` with advice
/// to lower the probe counts (the same bakes without bounces and with
/// one light fit).
#[test]
fn a_bake_too_big_for_its_lights_and_bounces_names_them() {
    let s = Scratch::new();
    let lights: Vec<String> = (0..1000)
        .map(|i| {
            let x = 0.2 + 1.6 * (i % 17) as f64 / 16.0;
            let z = 0.2 + 1.6 * (i / 17) as f64 / 60.0;
            format!("Point(position: ({x}, 1.8, {z}), intensity: (0.01, 0.01, 0.01))")
        })
        .collect();
    s.config(
        "cmp.ron",
        &format!(
            "reference: (camera: (position: (1, 1, 0.3), look_at: (1, 1, 1.5)), width: 8, height: 6, samples_per_pixel: 1),\ncoverage: (samples: 2000, reference_points: 512),\nbake: (resolution: 32, samples: 1, bounces: 8),\nrefine: (diffuse: (surface_points: 0, free_points: 0)),\nlights: [{}],\n",
            lights.join(", ")
        ),
    );
    let r = refused_in(
        s.dir.path(),
        &["compare", "cmp.ron", "--cpu", "--only", "glossy"],
        &[("PROBEPLACE_WORK_LIMIT", "5")],
    );
    assert!(
        r.line.contains("bake.bounces, lights: ")
            && r.line.contains("8 bounces")
            && r.line.contains("1000 point, spot and directional lights")
            && !r.line.contains("lower the probe counts"),
        "{}",
        r.line
    );
}

/// A `reachable` point beyond the domain, or inside solid geometry, is
/// refused naming the field, the point's index and why: skipped, it left
/// no seed, and all free space (sealed voids too) counted instead.
#[test]
fn a_reachable_point_outside_the_domain_or_in_solid_is_refused() {
    let s = Scratch::new();
    // The room with a closed box inside it: solid from 0.6 to 1.4.
    let mut boxed = CUBE_ROOM.to_string();
    boxed += "v 0.6 0.6 0.6\nv 1.4 0.6 0.6\nv 1.4 0.6 1.4\nv 0.6 0.6 1.4\nv 0.6 1.4 0.6\nv 1.4 1.4 0.6\nv 1.4 1.4 1.4\nv 0.6 1.4 1.4\n";
    boxed +=
        "f 9 10 11 12\nf 13 16 15 14\nf 9 13 14 10\nf 10 14 15 11\nf 11 15 16 12\nf 12 16 13 9\n";
    s.write("boxed.obj", &boxed);
    for (extra, index, why) in [
        (
            "reachable: From([(0.3, 0.3, 0.3), (9, 1, 1)]),\n",
            "point 1 (9, 1, 1)",
            "is outside the domain",
        ),
        (
            "reachable: From([(1, 1, 1)]),\n",
            "point 0 (1, 1, 1)",
            "is inside solid geometry",
        ),
    ] {
        s.write(
            "reach.ron",
            &format!("(\n    scene: \"boxed.obj\",\n    voxel_size: 0.1,\n    output: \"out\",\n{extra})\n"),
        );
        let r = refused_in(s.dir.path(), &["place", "reach.ron"], &[]);
        assert!(
            r.line.contains("reachable: ") && r.line.contains(index) && r.line.contains(why),
            "{extra}: {}",
            r.line
        );
    }
}
