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
pub mod tracer;
pub mod twin;

pub use context::Context;
pub use tracer::ProbeTracer;

use bytemuck::{Pod, Zeroable};

/// Most queries one dispatch handles: 48 MiB of records, 32 MiB of queries.
pub const BATCH: usize = 1 << 20;

/// One query: a ray (`origin`, `t_max`, unit `dir`) for `trace_rays`; a
/// shading point (`origin`) and its unit normal (`dir`) for
/// `gather_irradiance`. Layout of WGSL `Query`.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub struct Query {
    /// Ray origin or shading point.
    pub origin: [f32; 3],
    /// End of the ray (unused by `gather_irradiance`).
    pub t_max: f32,
    /// Unit ray direction or surface normal.
    pub dir: [f32; 3],
    /// Padding to 32 bytes.
    pub pad: f32,
}

/// How a traced ray ended: [`Record::kind`] values.
pub mod kind {
    /// A probe saw the ray hit a surface.
    pub const HIT: u32 = 0;
    /// A probe saw the ray leave the scene.
    pub const MISS: u32 = 1;
    /// Every candidate probe lost sight of the ray.
    pub const UNKNOWN: u32 = 2;
    /// No probe was a candidate at all.
    pub const NO_PROBE: u32 = 3;
}

/// What a kernel returns per query. Layout of WGSL `Record`.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub struct Record {
    /// One of [`kind`].
    pub kind: u32,
    /// The probe whose maps answered (`u32::MAX` for [`kind::NO_PROBE`]).
    pub probe: u32,
    /// Texel `y·n + x` of that probe's maps the radiance was read from
    /// ([`crate::trace::Outcome::lookup`]).
    pub texel: u32,
    /// Where along the ray the trace ended.
    pub t: f32,
    /// Pyramid texels visited ([`crate::trace::single::Steps::march_fetches`]).
    pub fetches: u32,
    /// Probes consulted.
    pub probes: u32,
    /// Surfel tests run ([`crate::trace::single::Steps::surfels`]).
    pub surfels: u32,
    /// Padding.
    pub pad: u32,
    /// Radiance read at the end of the ray (`trace_rays`) or irradiance at
    /// the point (`gather_irradiance`); alpha is 1.
    pub radiance: [f32; 4],
}

/// Which probes a trace consults: [`crate::trace::Selection`] without the
/// data, for the kernels' parameters.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SelectionKind {
    /// The grid cell's eight probes (McGuire §4.1).
    Grid,
    /// The SVO's ranked lists (Wang §4.1).
    Svo,
}
