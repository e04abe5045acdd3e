//! A run's outputs on disk: the set a job commits whole
//! ([`commit`]: staged, synced and swapped in one exchange) and the
//! manifest every set carries and every reader checks ([`manifest`]).
//! The encoders of the files themselves live in [`crate::report`]; this
//! room only decides what reaches the output directory, and when.

pub mod commit;
pub mod manifest;
pub mod names;
