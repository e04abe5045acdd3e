//! `cargo +nightly fuzz run obj`: the body is `harness::obj` (fuzz/harness.rs).
#![no_main]

#[path = "../harness.rs"]
mod harness;

libfuzzer_sys::fuzz_target!(|data: &[u8]| harness::obj(data));
