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
pub mod grid;
pub mod relocate;

use crate::config::Placement;
use crate::error::Result;
use crate::skeleton;
use std::collections::BTreeMap;

pub use crate::probes::{PlacementInput, Probe, ProbeSet};
pub use grid::{cubic_grid_sweep, grid, grid_min_clearance};

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
