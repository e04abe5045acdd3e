//! The integration tests, in one binary (as ripgrep's): every module below
//! was a binary of its own, and each linked the whole crate, wgpu included.
//! `cargo test --release -- MODULE::` runs one module, e.g.
//! `cargo test --release -- refine:: --nocapture`.

mod browser;
mod common;

mod bad_input;
mod compare;
mod controls;
mod docs;
mod export;
mod fuzz;
mod generality;
mod gltf;
mod gpu;
mod hostile;
mod hostile_jobs;
mod hostile_output;
mod hostile_scene;
mod jobs;
mod layout;
mod lightfield;
mod medial_axis;
mod place;
mod readers;
mod real_scenes;
mod refine;
mod render;
mod report_html;
mod svo;
mod textures;
mod threejs;
mod tiles;
mod translation;
