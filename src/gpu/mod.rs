//! The GPU validation tracer (Wang et al. 2019 §4.2, step 5 of the
//! method): the light-field trace of McGuire et al. 2017 §4 in WGSL compute
//! kernels, run with wgpu, with a CPU twin for every kernel.
//!
//! | kernel (src/gpu/shaders/) | what it does | CPU twin |
//! |---|---|---|
//! | `trace.wgsl`: `trace_rays` | one ray through the probes, bi-level or Hi-Z march, grid or SVO selection; radiance at the end | [`twin::trace_rays`] ([`crate::trace`]) |
//! | `irradiance.wgsl`: `gather_irradiance` | diffuse irradiance at a point from the irradiance probes (McGuire §5.2) | [`twin::gather_irradiance`] ([`crate::trace::gather`]) |
//! | `common.wgsl` | bindings, octahedral mapping, SVO and grid lookups | [`crate::lightfield::octahedral`], [`crate::svo::Svo::probes_at`], [`crate::trace::Lattice`] |
//!
//! The probe maps live in 2D texture arrays, one layer per probe, at the
//! half precision of `lightfield.bin` (so the GPU reads exactly the values
//! the CPU twin reads); the distance pyramid's minima are the mip levels of
//! one texture. Probe positions, the SVO's node and payload words, and the
//! grid's probe indices are storage buffers. Queries run in batches of at
//! most [`BATCH`], which keeps every storage binding under lavapipe's
//! 128 MiB cap.

pub mod context;
mod interface;
pub mod tracer;
pub mod twin;

pub use context::Context;
pub use interface::{kind, Query, Record, SelectionKind, BATCH};
pub use tracer::ProbeTracer;
