//! Placement methods and the probe set they produce.
//!
//! Every method is a function from the shared scene representation (scene,
//! BVH, SDF, domain) to a [`ProbeSet`]; coverage and reports treat all methods
//! alike, so comparisons between them are fair.
//!
//! Besides the paper's methods (in [`crate::skeleton`]) and McGuire's grid
//! (here), two competitors live in their own modules: [`relocate`], the grid
//! with RTXGI/DDGI probe relocation and classification that current engines
//! ship, and [`greedy`], Silvennoinen & Lehtinen 2017's greedy thinning of
//! voxels near surfaces.

pub mod adaptive;
pub mod controls;
pub mod file;
pub mod greedy;
pub mod relocate;

use crate::config::{GridParams, Placement};
use crate::error::Result;
use crate::scene::Bounds;
use crate::sdf::Sdf;
use crate::skeleton;
use glam::Vec3;
use std::collections::BTreeMap;

pub use crate::probes::{PlacementInput, Probe, ProbeSet};

/// Runs the configured placement method.
pub fn place(method: &Placement, input: &PlacementInput) -> Result<ProbeSet> {
    Ok(match method {
        Placement::Grid(g) => ProbeSet {
            method: method.name(),
            probes: grid(g, input.domain),
            stats: BTreeMap::new(),
            params: BTreeMap::new(),
            min_clearance: grid_min_clearance(input.sdf),
            fixed: 0,
        },
        Placement::SdfSkeleton(p) => skeleton::sdf_skeleton(p, input)?,
        Placement::MedialAxis(p) => skeleton::medial_axis(p, input)?,
        Placement::Relocated(g) => relocate::relocated_grid(g, input)?,
        Placement::Greedy(p) => greedy::greedy(p, input)?,
        Placement::Adaptive(a) => adaptive::adaptive(
            &adaptive::AdaptiveParams {
                min_spacing: a.min_spacing.0,
                levels: a.levels.0,
            },
            input,
        )?,
    })
}

/// The clearance refinement keeps for grid-based sets. A grid has no
/// clearance rule of its own: refinement keeps its probes where the
/// coverage measure's reference points may be (one voxel from a surface).
pub fn grid_min_clearance(sdf: &Sdf) -> f32 {
    crate::coverage::REFERENCE_MIN_CLEARANCE_VOXELS * sdf.voxel_size
}

/// Uniform grids shaped like a domain of `size`: for k = 1..=`max_cells`
/// cells along the longest axis, the other axes get as many cells as keep
/// the cells closest to cubes (at least one). Sorted by probe count, then
/// dimensions; duplicates removed.
pub fn cubic_grid_sweep(size: Vec3, max_cells: u32) -> Vec<GridParams> {
    let longest = size.max_element();
    let mut grids: Vec<[u32; 3]> = (1..=max_cells)
        .map(|k| {
            let cell = longest / k as f32;
            (size / cell).round().max(Vec3::ONE).as_uvec3().to_array()
        })
        .collect();
    grids.sort_by_key(|g| (g[0] * g[1] * g[2], *g));
    grids.dedup();
    grids
        .into_iter()
        .filter_map(|g| GridParams::new(g).ok())
        .collect()
}

/// McGuire et al. 2017's uniform grid: the domain divided into N×M×K cells,
/// one probe at each cell centre, x fastest, then y, then z.
pub fn grid(params: &GridParams, domain: &Bounds) -> Vec<Probe> {
    let n = [params.cells.0 .0, params.cells.1 .0, params.cells.2 .0];
    let cell = domain.size() / Vec3::new(n[0] as f32, n[1] as f32, n[2] as f32);
    let mut probes = Vec::with_capacity((n[0] * n[1] * n[2]) as usize);
    for z in 0..n[2] {
        for y in 0..n[1] {
            for x in 0..n[0] {
                probes.push(Probe {
                    position: domain.min + (Vec3::new(x as f32, y as f32, z as f32) + 0.5) * cell,
                    cluster_size: 0,
                });
            }
        }
    }
    probes
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::Count;

    #[test]
    fn grid_probes_sit_at_cell_centres() {
        let d = Bounds {
            min: Vec3::ZERO,
            max: Vec3::new(4.0, 2.0, 2.0),
        };
        let p = grid(
            &GridParams {
                cells: (Count(2), Count(1), Count(2)),
            },
            &d,
        );
        let pos: Vec<Vec3> = p.iter().map(|p| p.position).collect();
        assert_eq!(
            pos,
            vec![
                Vec3::new(1.0, 1.0, 0.5),
                Vec3::new(3.0, 1.0, 0.5),
                Vec3::new(1.0, 1.0, 1.5),
                Vec3::new(3.0, 1.0, 1.5)
            ]
        );
    }
}
