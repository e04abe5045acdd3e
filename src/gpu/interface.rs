//! What the kernels take and return, laid out as their WGSL structs:
//! queries in, records out, in batches of at most [`BATCH`].

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
    /// ([`crate::trace::RayOutcome::lookup`]).
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
