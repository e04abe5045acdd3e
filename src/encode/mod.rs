//! The file encoders, each a function from an in-memory product to bytes:
//! [`png`] (8-bit previews), [`exr`] (linear renders), [`json`] (reports
//! and tables). They know nothing of jobs or output sets; the output
//! commit ([`crate::output`]) stamps the provenance into their bytes.

pub mod exr;
pub mod json;
pub mod png;
