//! Placement methods and the probe set they produce.
//!
//! Every method is a function from the shared scene representation (scene,
//! BVH, SDF, domain) to a [`ProbeSet`]; coverage and reports treat all methods
//! alike, so comparisons between them are fair.
//!
//! A method is one file implementing [`Method`] and one line of the list in
//! [`registry`], from which its config form ([`Placement`]), its
//! `--method` form, its name and its row in docs/config.md derive
//! (docs/layout.md, "Adding a placement method"). The list: the paper's
//! two (Wang et al. 2019 §3.1, in `skeleton`), McGuire's grid ([`grid`]),
//! and three competitors: [`relocate`], the grid with RTXGI/DDGI probe
//! relocation and classification that current engines ship, [`greedy`],
//! Silvennoinen & Lehtinen 2017's greedy thinning of voxels near surfaces,
//! and [`adaptive`], Unity's Adaptive Probe Volumes.

pub mod adaptive;
pub mod controls;
pub mod file;
pub mod greedy;
pub mod grid;
pub mod method;
pub mod registry;
pub mod relocate;
pub(crate) mod skeleton;

use crate::error::Result;

pub use crate::probes::{PlacementInput, Probe, ProbeSet};
pub use grid::{cubic_grid_sweep, grid, grid_min_clearance};
pub use method::{Entry, Method, Role};
pub use registry::{Placement, METHODS};

/// Runs the configured placement method ([`Placement::place`]).
pub fn place(method: &Placement, input: &PlacementInput) -> Result<ProbeSet> {
    method.place(input)
}
