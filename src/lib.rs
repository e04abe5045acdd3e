#![warn(missing_docs)]
// The internal modules' items that only the tests, examples and benchmarks
// use are `pub` for them (the `testkit` feature makes those modules
// public); without the feature nothing outside the crate reaches them, so
// the default build does not lint them as dead (the feature build, where
// they are public, never did).
#![cfg_attr(not(feature = "testkit"), allow(dead_code, unused_imports))]
//! probeplace: decides where to put light-field probes in a 3D scene.
//!
//! The pipeline follows Wang et al. 2019, *Fast Non-uniform Radiance Probe
//! Placement and Tracing* (I3D), for probes in the sense of McGuire et al.
//! 2017, *Real-Time Global Illumination using Precomputed Light Field Probes*:
//!
//! | stage | module | paper |
//! |---|---|---|
//! | load the scene | `scene` | — |
//! | ray casting, watertight ray/triangle test | `scene::raycast`, `scene::watertight` | Woop, Benthin & Wald 2013 |
//! | voxel size chosen from the scene | `resolution` (internal) | — |
//! | signed distance field | `sdf` | Wang §3.1 |
//! | skeletons (SDF, medial axis) and clustering | `skeleton` (internal; the methods through [`placement`]) | Wang §3.1, Figs. 2–3; Ma et al. 2012 |
//! | uniform grid baseline | [`placement`] | McGuire §4 |
//! | coverage | `coverage` | Wang §2, §3.2 |
//! | refinement, filling, pruning | `refine` | Wang §3.2–3.3, eqs. 1–3, Figs. 4–6 |
//! | octahedral probe maps | [`lightfield`] | McGuire §3 |
//! | sparse voxel octree of probe indices | [`svo`] | Wang §4.1, Fig. 7 |
//! | path tracing: probe radiance, reference images | `render` | McGuire §3, §5.1; Wang §5.1 |
//! | light-field probe bake: maps, pyramid, irradiance | [`lightfield`] | McGuire §3, §5.2; Wang §4.2 |
//! | light-field ray tracing on the CPU | `trace` | McGuire §4, Listing 1 |
//! | light-field ray tracing on the GPU (wgpu): bi-level and Hi-Z | `gpu` | McGuire §4, §5.2; Wang §4.2 |
//! | validation renders against the reference | `render::probes` | Wang §5.1 |
//! | competing placements: relocated grid, greedy voxels | [`placement`] | RTXGI; Silvennoinen & Lehtinen 2017 §4.1 |
//! | comparisons against grids and competitors | [`jobs::compare()`] | Wang §5, Figs. 8–12, Tables 1–2 |
//! | stock-config runs on any scene against the grids | `generality` (the `testkit` feature) | Wang §5, Table 1 |
//! | outputs, the HTML reports and their 3D view | `report`, `page`, `export`, `encode` (internal; the files in docs/formats.md) | — |
//!
//! `stages` composes them into typed products; [`jobs`] composes the
//! stages into what the command line runs; the `probeplace` binary is a
//! thin shell over the jobs.
//!
//! # The public API
//!
//! What a renderer and a pipeline need: the config ([`config`]), placing
//! as a library call ([`jobs`]), the probe set and its file
//! ([`placement`]), the readers of the binary outputs ([`svo`],
//! [`lightfield`]) and the diffuse blend over them ([`blend_weights`]),
//! provenance ([`provenance`]) and the tile grid
//! ([`tiles`]). The stages' modules (`scene`, `sdf`, `coverage`, `refine`,
//! `render`, `trace`, `gpu`, `raster`, `sampling`, `stages`) are internal;
//! the `testkit` feature, which the tests, examples and benchmarks turn
//! on, makes them public for them, with the generated scenes.
//!
//! # A renderer's view
//!
//! Place probes (here a small grid, for speed), then load what a renderer
//! needs from the output directory: the probes, in `probes.json` order, and
//! the octree that names up to four of them for any point.
//!
//! ```
//! use probeplace::jobs::{self, RunOptions};
//! use probeplace::provenance::Overrides;
//! use probeplace::svo::Svo;
//!
//! let out = std::env::temp_dir().join(format!("probeplace-doc-{}", std::process::id()));
//! let options = RunOptions {
//!     config: Some("configs/cornell.ron".into()),
//!     out: Some(out.clone()),
//!     overrides: Overrides {
//!         method: Some("grid:2x2x2".into()),
//!         no_refine: true,
//!         ..Overrides::default()
//!     },
//!     ..RunOptions::default()
//! };
//! jobs::place(&options)?;
//!
//! let probes = probeplace::placement::file::read_world(&out.join("probes.json"))?;
//! let svo = Svo::read(&out.join("svo.bin"))?;
//! assert_eq!(probes.len(), 8);
//! assert_eq!(svo.probe_count as usize, probes.len());
//!
//! // The middle of the box, in world coordinates (a read tree's frame).
//! let centre = (probes.iter().map(|(p, _)| *p).sum::<glam::DVec3>() / 8.0).as_vec3();
//! let nearby = svo.probes_at(centre);
//! assert!(!nearby.is_empty() && nearby.len() <= 4);
//! assert!(nearby.iter().all(|&i| (i as usize) < probes.len()));
//! # std::fs::remove_dir_all(&out).ok();
//! # Ok::<(), probeplace::Error>(())
//! ```

/// Declares the stages' modules: `pub(crate)` in the default library,
/// `pub` with the `testkit` feature, for the tests, examples, benchmarks
/// and fuzz targets ("The public API" above).
macro_rules! stage_modules {
    ($($name:ident),+ $(,)?) => {$(
        #[cfg(feature = "testkit")]
        pub mod $name;
        #[cfg(not(feature = "testkit"))]
        pub(crate) mod $name;
    )+};
}

stage_modules!(
    coverage, diffuse, gpu, raster, reachable, refine, render, sampling, scene, sdf, stages, trace
);

pub mod config;
#[cfg(test)]
mod doc_blocks;
pub(crate) mod encode;
pub mod error;
pub(crate) mod export;
/// The test scenes we generate in code and the generality check: for the
/// tests, examples and benchmarks (`features = ["testkit"]`), not in the
/// default library.
#[cfg(any(test, feature = "testkit"))]
pub mod fixtures;
#[cfg(any(test, feature = "testkit"))]
pub mod generality;
pub(crate) mod input;
pub mod jobs;
pub mod lightfield;
pub(crate) mod limits;
pub(crate) mod output;
pub(crate) mod page;
pub mod placement;
pub(crate) mod probes;
pub mod progress;
pub mod provenance;
pub(crate) mod report;
pub(crate) mod resolution;
pub(crate) mod stats;
pub mod svo;
pub mod tiles;

pub use error::{Error, Result};

/// The diffuse blend a renderer shades with, as the validation renders do
/// (McGuire et al. 2017 §5.2): for a point and a normal, the probes of a
/// read [`lightfield::LightField`] and their normalized weights, on a grid
/// ([`Selection::Grid`] of [`Lattice::from_positions`]) or over every probe
/// ([`Selection::Svo`] of the run's [`svo::Svo`]); Python's
/// `probeplace.blend_weights` and C's `pp_blend_weights` give the same bits
/// (docs/formats.md, "Blend weights").
pub use trace::gather::blend_weights;
pub use trace::{Lattice, Selection};
