//! The pipeline's composite stages, each a function from the previous
//! stage's typed product to its own, shared by every job:
//!
//! | stage | product | paper |
//! |---|---|---|
//! | [`prepare()`]: load, BVH, voxel size, SDF | [`Prepared`] | Wang et al. 2019 §3.1 |
//! | [`place()`]: placement, refinement, coverage, SVO | [`Placed`] | Wang §3.1–3.3, §4.1 |
//! | [`bake()`]: light-field maps, pyramid, irradiance | [`Baked`] | McGuire et al. 2017 §3; Wang §4.2 |
//! | [`validate::reference`]: the path-traced reference | [`crate::render::Reference`] | Wang §5.1 |
//! | [`validate::validate`]: a render through the probes, measured | [`validate::Validation`] | Wang §5.1 |
//! | [`diffuse::bench`], [`diffuse::measure`]: irradiance at receivers as engines blend probes | [`diffuse::DiffuseMeasure`] | Ramamoorthi & Hanrahan 2001; McGuire §5.2 |
//!
//! Stages compute; they never encode a file. Each product carries the wall
//! times of its steps in a [`Stopwatch`](crate::progress::Stopwatch) the job folds into its own.

pub mod bake;
pub mod diffuse;
pub mod place;
pub mod prepare;
pub mod validate;

pub use bake::{bake, Baked};
pub use place::{place, Placed};
pub use prepare::{prepare, reach_seeds, resolve_domain, resolve_voxel_size, Prepared};
