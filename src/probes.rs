//! The probe set every placement method produces, and what every method
//! reads: the types the placement methods ([`crate::placement`],
//! `placement::skeleton`) share, kept apart so neither module depends on the
//! other.

use crate::progress::Progress;
use crate::scene::raycast::SceneBvh;
use crate::scene::{Bounds, Scene};
use crate::sdf::Sdf;
use glam::Vec3;
use std::collections::BTreeMap;

/// One probe.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Probe {
    /// Position, relative to the scene's origin ([`Scene::to_world`]).
    pub position: Vec3,
    /// How many skeleton points (sdf-skeleton voxels, medial-axis balls) the
    /// probe's cluster holds; 0 for grid probes.
    pub cluster_size: u32,
}

/// The output of a placement stage.
#[derive(Debug, Clone, PartialEq)]
pub struct ProbeSet {
    /// Method name as on the command line, e.g. `grid:4x4x4`.
    pub method: String,
    /// The probes, in a deterministic order.
    pub probes: Vec<Probe>,
    /// What the method's steps kept and dropped (e.g. `preclusters`,
    /// `dropped_small`), for `report.json`; empty for grids.
    pub stats: BTreeMap<&'static str, u64>,
    /// The method's parameters as used, defaults resolved to world units
    /// (lengths) or degrees, for `report.json`; empty for grids.
    pub params: BTreeMap<&'static str, f64>,
    /// The nearest a probe may stand to a surface under the method's own
    /// rule (world units): what refinement must keep to (Wang et al. 2019
    /// §3.1 culls voxels near surfaces for the same reason).
    pub min_clearance: f32,
    /// The first this many probes are the config's `fixed_probes`
    /// ([`crate::placement::controls`]): no stage moves or drops them.
    pub fixed: usize,
}

impl ProbeSet {
    /// Probe positions only.
    pub fn positions(&self) -> Vec<Vec3> {
        self.probes.iter().map(|p| p.position).collect()
    }
}

/// Everything a placement method may read.
pub struct PlacementInput<'a> {
    /// The scene.
    pub scene: &'a Scene,
    /// Its BVH.
    pub bvh: &'a SceneBvh,
    /// SDF of the domain.
    pub sdf: &'a Sdf,
    /// Where probes may go.
    pub domain: &'a Bounds,
    /// Seed for random choices.
    pub seed: u64,
    /// Progress bars.
    pub progress: &'a Progress,
}
