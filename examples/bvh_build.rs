//! BVH build time against scenes whose triangles defeat a builder that
//! pairs by centroid: `cargo run --release --example bvh_build -- [N ...]`.
//!
//! For each count N, three scenes of N triangles are built: `coincident`
//! (one triangle N times, as a mesh instanced N times at one place),
//! `nested` (triangles about one centre, each a little larger than the
//! last), `line` (one triangle repeated at unit steps along x, exactly
//! representable, so that neighbours' costs tie) and `soup` (a seeded
//! random soup, the ordinary case). Prints the seconds of
//! [`SceneBvh::new`] for each.

use glam::Vec3;
use probeplace::sampling::{hash2, unit_f32};
use probeplace::scene::{raycast::SceneBvh, Material, Scene};
use std::time::Instant;

/// A seeded point in [0, 1)³.
fn point(h: u64) -> Vec3 {
    Vec3::new(
        unit_f32(hash2(h, 1)),
        unit_f32(hash2(h, 2)),
        unit_f32(hash2(h, 3)),
    )
}

fn main() {
    let counts: Vec<usize> = std::env::args()
        .skip(1)
        .map(|a| a.parse().expect("a triangle count"))
        .collect();
    let counts = if counts.is_empty() {
        vec![24_000, 48_000, 96_000]
    } else {
        counts
    };
    let tri = [Vec3::ZERO, Vec3::X, Vec3::Y];
    println!(
        "{:>10} {:>12} {:>12} {:>12} {:>12} {:>12}",
        "triangles", "coincident", "nested", "line", "grid", "soup"
    );
    for n in counts {
        let scenes: [(&str, Vec<[Vec3; 3]>); 5] = [
            ("coincident", vec![tri; n]),
            (
                "nested",
                (0..n)
                    .map(|i| tri.map(|v| (v - 0.5) * (1.0 + i as f32 * 1e-3)))
                    .collect(),
            ),
            (
                "line",
                (0..n)
                    .map(|i| tri.map(|v| v + Vec3::X * i as f32))
                    .collect(),
            ),
            ("grid", {
                let side = (n as f64).cbrt().ceil() as usize;
                (0..n)
                    .map(|i| {
                        let at = Vec3::new(
                            (i % side) as f32,
                            (i / side % side) as f32,
                            (i / side / side) as f32,
                        );
                        tri.map(|v| v * 0.5 + at)
                    })
                    .collect()
            }),
            (
                "soup",
                (0..n as u64)
                    .map(|i| {
                        let c = point(hash2(7, i)) * 100.0;
                        let e = |k: u64| (point(hash2(hash2(7, i), k)) - 0.5) * 0.5;
                        [c + e(1), c + e(2), c + e(3)]
                    })
                    .collect(),
            ),
        ];
        let mut line = format!("{n:>10}");
        for (name, tris) in scenes {
            let scene = Scene::from_triangles(
                name.into(),
                tris.into_iter().map(|t| (t, 0)),
                vec![Material::fallback()],
            )
            .unwrap();
            let t0 = Instant::now();
            let bvh = SceneBvh::new(&scene);
            std::hint::black_box(&bvh);
            line += &format!(" {:>11.3}s", t0.elapsed().as_secs_f64());
        }
        println!("{line}");
    }
}
