//! A CPU path tracer: the radiance that light-field probes store, and the
//! ground-truth images they are judged against.
//!
//! McGuire et al. 2017 §3 bake, for each probe, the radiance arriving from
//! every direction of its octahedral map; [`Renderer::radiance`] computes one
//! path sample of exactly that, for any origin and direction. Wang et al.
//! 2019 §5.1 measure a placement by the error of the *glossy indirect*
//! component against a Monte Carlo path-traced reference;
//! [`render_reference`] renders the full image and that component side by
//! side ([`Renderer::radiance_split`]), splitting the BSDF into its
//! Lambertian and glossy terms as McGuire et al. 2017 §5.1 do.
//!
//! | concept | module |
//! |---|---|
//! | BSDF: Lambertian + GGX from MTL `Kd`/`Ks`/`Ns` | [`material`] |
//! | lights and next-event estimation | [`lights`] |
//! | path integrator | [`integrator`] |
//! | pinhole camera | [`camera`] |
//! | reference image | [`reference`](mod@reference) |
//!
//! Everything is deterministic: each pixel (or probe texel) draws from its
//! own counter-based [`crate::sampling::Sampler`] stream, so the same seed
//! gives the same bits whatever the thread schedule.

pub mod camera;
pub mod flip;
pub mod integrator;
pub mod lights;
pub mod material;
pub mod probes;
pub mod reference;
pub mod views;

pub use camera::Camera;
pub use integrator::{Renderer, Split};
pub use lights::LightSet;
pub use material::{Bsdf, BsdfSample, Lobes};
pub use reference::{render_reference, Reference};
