//! `cargo +nightly fuzz run gltf`: the body is `harness::gltf` (fuzz/harness.rs).
#![no_main]

#[path = "../harness.rs"]
mod harness;

libfuzzer_sys::fuzz_target!(|data: &[u8]| harness::gltf(data));
