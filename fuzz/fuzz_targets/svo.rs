//! `cargo +nightly fuzz run svo`: the body is `harness::svo` (fuzz/harness.rs).
#![no_main]

#[path = "../harness.rs"]
mod harness;

libfuzzer_sys::fuzz_target!(|data: &[u8]| harness::svo(data));
