//! The `medial-axis` method end to end (placement alone, `--no-refine`):
//! acceptance on the Cornell box and Sponza, and its density control (Wang et al. 2019 Fig. 3: pre-clustering
//! more coarsely gives fewer probes) on several scenes.

use crate::common::*;
use probeplace::config::{MedialAxisParams, Placement, Positive};
use probeplace::placement;
use probeplace::progress::Progress;
use probeplace::sdf;

/// Probe counts of `medial-axis` on `config` for each pre-clustering radius
/// (in voxels), everything else at its defaults; the SDF is built once
/// (and shared with the SVO tests).
fn counts_by_precluster_radius(config: &str, radii_voxels: &[f32]) -> Vec<usize> {
    let (config, prepared) = prepared(config);
    let progress = Progress::hidden();
    let (input, sdf) = (
        prepared.placement_input(config.seed, &progress),
        &prepared.sdf,
    );
    radii_voxels
        .iter()
        .map(|&r| {
            let method = Placement::MedialAxis(MedialAxisParams {
                precluster_radius: Some(Positive(r * prepared.sdf.voxel_size)),
                ..MedialAxisParams::default()
            });
            let set = placement::place(&method, &input).unwrap();
            // Every run keeps the method's own guarantee.
            for p in &set.probes {
                let v = sdf.voxel_at(p.position).expect("probe inside the grid");
                assert_eq!(sdf.class[v], sdf::VoxelClass::Free);
            }
            set.probes.len()
        })
        .collect()
}

fn assert_falls(scene: &str, counts: &[usize]) {
    assert!(
        counts.windows(2).all(|w| w[0] >= w[1]),
        "{scene}: probe counts must not rise with the pre-clustering radius: {counts:?}"
    );
    assert!(
        counts[0] > counts[counts.len() - 1],
        "{scene}: coarser pre-clustering must end with fewer probes: {counts:?}"
    );
}

const RADII_VOXELS: [f32; 5] = [2.0, 4.0, 8.0, 16.0, 32.0];

#[test]
fn probe_count_falls_with_precluster_radius_on_the_cornell_box() {
    let counts = counts_by_precluster_radius("configs/cornell.ron", &RADII_VOXELS);
    eprintln!("cornell {counts:?}");
    assert_falls("cornell", &counts);
}

#[test]
fn probe_count_falls_with_precluster_radius_in_the_pillared_hall() {
    let counts = counts_by_precluster_radius("configs/pillared-hall.ron", &RADII_VOXELS);
    eprintln!("pillared hall {counts:?}");
    assert_falls("pillared hall", &counts);
}

#[test]
fn probe_count_falls_with_precluster_radius_in_the_holodeck() {
    shared_scenes();
    let counts = counts_by_precluster_radius("configs/holodeck.ron", &RADII_VOXELS);
    eprintln!("holodeck {counts:?}");
    assert_falls("holodeck", &counts);
}

#[test]
fn cornell_box_acceptance() {
    let out = tempfile::tempdir().unwrap();
    let r = place(
        &root().join("configs/cornell.ron"),
        out.path(),
        &["--method", "medial-axis", "--no-refine"],
    );
    assert_eq!(r["method"], "medial-axis");
    assert_eq!(r["probes_in_solid"], 0);
    assert_eq!(r["probes_outside_scene"], 0);
    assert_eq!(r["probes_outside_domain"], 0);
    let cov = r["coverage"].as_f64().unwrap();
    assert!(cov >= 0.95, "coverage {cov}");
    let stats = &r["placement_stats"];
    assert!(stats["preclusters"].as_u64().unwrap() < stats["oriented_points"].as_u64().unwrap());
    assert_eq!(
        r["probe_count"].as_u64().unwrap() as usize,
        read_json(&out.path().join("probes.json"))["probes"]
            .as_array()
            .unwrap()
            .len()
    );
    assert!(out.path().join("placement.png").is_file());
}

#[test]
fn dabrovic_sponza_acceptance() {
    shared_scenes();
    let out = tempfile::tempdir().unwrap();
    let r = place(
        &root().join("configs/sponza.ron"),
        out.path(),
        &["--method", "medial-axis", "--no-refine"],
    );
    assert_eq!(r["probes_in_solid"], 0);
    assert_eq!(r["probes_outside_scene"], 0);
    let cov = r["coverage"].as_f64().unwrap();
    assert!(cov >= 0.9, "coverage {cov}");
    // Sponza's curtains and banners are single sheets with air on both sides.
    assert!(r["placement_stats"]["two_sided_points"].as_u64().unwrap() > 0);
}
