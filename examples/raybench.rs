//! Ray throughput of [`SceneBvh`] on one core:
//! `cargo run --release --example raybench -- SCENE.obj [REPEATS]`.
//!
//! Closest hits: 1M rays from 50 points spread through the scene's middle
//! (Sponza's atrium and galleries), each in a random direction (an octahedral map's random
//! point). Occlusion: 1M segments between random pairs of free points
//! (points seen from the middle's vertical line). Prints rays/s and a
//! checksum of the answers, so that two builds can be compared.

use glam::Vec3;
use probeplace::config::UpAxis;
use probeplace::sampling::{hash2, unit_f32};
use probeplace::scene::{load_obj, raycast::SceneBvh};
use std::time::Instant;

/// The unit vector of the octahedral map's point `(u, v)` in `[-1, 1]²`.
fn octahedral(u: f32, v: f32) -> Vec3 {
    let z = 1.0 - u.abs() - v.abs();
    let (x, y) = if z >= 0.0 {
        (u, v)
    } else {
        ((1.0 - v.abs()) * u.signum(), (1.0 - u.abs()) * v.signum())
    };
    Vec3::new(x, y, z).normalize()
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let path = std::path::PathBuf::from(&args[1]);
    let repeats: usize = args.get(2).map_or(3, |s| s.parse().unwrap());
    let scene = load_obj(&path, 1.0, UpAxis::Y).unwrap();
    let t0 = Instant::now();
    let bvh = SceneBvh::new(&scene);
    eprintln!(
        "{} triangles, BVH built in {:.1} ms",
        scene.triangles.len(),
        t0.elapsed().as_secs_f64() * 1e3
    );
    let (lo, size) = (scene.bounds.min, scene.bounds.size());
    let at = |h: u64| {
        let f = Vec3::new(
            0.05 + 0.9 * unit_f32(hash2(h, 1)),
            0.05 + 0.9 * unit_f32(hash2(h, 2)),
            0.05 + 0.9 * unit_f32(hash2(h, 3)),
        );
        lo + size * f
    };
    // Free: seen from a point of the middle's vertical line (in the open
    // atrium), so that the set does not depend on ties between hits.
    let free = |p: Vec3| {
        (1..8).any(|k| {
            let c = lo + size * Vec3::new(0.5, k as f32 / 8.0, 0.5);
            !bvh.occluded(c, p, 1e-4)
        })
    };
    let points: Vec<Vec3> = (0..)
        .map(|i| at(hash2(7, i)))
        .filter(|&p| free(p))
        .take(2000)
        .collect();
    const N: u64 = 1_000_000;
    let rays: Vec<(Vec3, Vec3)> = (0..N)
        .map(|i| {
            let h = hash2(8, i);
            let u = 2.0 * unit_f32(hash2(h, 1)) - 1.0;
            let v = 2.0 * unit_f32(hash2(h, 2)) - 1.0;
            (points[(i % 50) as usize * 40], octahedral(u, v))
        })
        .collect();
    let segments: Vec<(Vec3, Vec3)> = (0..N)
        .map(|i| {
            let h = hash2(9, i);
            let a = points[(hash2(h, 1) % points.len() as u64) as usize];
            let b = points[(hash2(h, 2) % points.len() as u64) as usize];
            (a, b)
        })
        .collect();
    for _ in 0..repeats {
        let t0 = Instant::now();
        let (mut hits, mut sum_t, mut sum_tri) = (0u64, 0f64, 0u64);
        for &(o, d) in &rays {
            if let Some(h) = bvh.closest_hit(o, d, 0.0, f32::INFINITY) {
                hits += 1;
                sum_t += h.t as f64;
                sum_tri = sum_tri.wrapping_add(h.triangle as u64 * (h.t.to_bits() as u64 | 1));
            }
        }
        let closest = N as f64 / t0.elapsed().as_secs_f64();
        let t0 = Instant::now();
        let blocked = segments
            .iter()
            .filter(|&&(a, b)| bvh.occluded(a, b, 1e-4))
            .count();
        let occluded = N as f64 / t0.elapsed().as_secs_f64();
        println!(
            "closest {:.3} Mrays/s  occluded {:.3} Mrays/s  | hits {hits} sum_t {sum_t:.6} tri_sum {sum_tri:x} blocked {blocked}",
            closest / 1e6,
            occluded / 1e6
        );
    }
}
