//! What a ray costs in a scene, as the work estimates see it:
//! `cargo run --release --example ray_cost -- SCENE...` prints each
//! scene's triangles (exact copies dropped) and the primitives a ray tests
//! on average by the surface-area heuristic
//! ([`SceneBvh::expected_tests`]). The estimates scale every stage's rate
//! by this over 64 (`limits::RATED_RAY_TESTS`) where it is larger
//! (BENCHMARKS.md, "Coincident and overlapping triangles").

use probeplace::config::UpAxis;
use probeplace::scene::{self, raycast::SceneBvh};
use std::path::Path;

fn main() {
    for path in std::env::args().skip(1) {
        match scene::load(Path::new(&path), 1.0, UpAxis::Y) {
            Ok(s) => {
                let bvh = SceneBvh::new(&s);
                println!(
                    "{path}: {} triangles ({} copies dropped), {:.1} tests a ray",
                    s.triangles.len(),
                    s.coincident_triangles,
                    bvh.expected_tests()
                );
            }
            Err(e) => println!("{path}: {e}"),
        }
    }
}
