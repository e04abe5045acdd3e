//! The benchmarks' package: `cargo bench -p probeplace-benches` runs
//! `stages.rs`. It is a package of its own so that the test build of
//! probeplace (`cargo test --release`) never compiles criterion; this
//! library is empty because Cargo wants one target besides the benchmark.
