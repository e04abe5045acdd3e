//! `cargo +nightly fuzz run probes`: the body is `harness::probes` (fuzz/harness.rs).
#![no_main]

#[path = "../harness.rs"]
mod harness;

libfuzzer_sys::fuzz_target!(|data: &[u8]| harness::probes(data));
