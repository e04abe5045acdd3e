//! `cargo +nightly fuzz run lightfield`: the body is `harness::lightfield` (fuzz/harness.rs).
#![no_main]

#[path = "../harness.rs"]
mod harness;

libfuzzer_sys::fuzz_target!(|data: &[u8]| harness::lightfield(data));
