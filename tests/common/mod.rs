//! Helpers shared by the integration tests: run the real binary, read its outputs.

#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// The repository root.
pub fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// ../shared/scenes beside the repository. Tests that need it fail loudly
/// when it is missing: CI always has it, and a silent skip would hide a gap.
pub fn shared_scenes() -> PathBuf {
    let p = root().join("../shared/scenes");
    assert!(
        p.is_dir(),
        "{} is missing: the real-scene tests need ../shared beside the repository",
        p.display()
    );
    p
}

/// Runs `probeplace` with `args`.
pub fn probeplace(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_probeplace"))
        .args(args)
        .current_dir(root())
        .output()
        .expect("the probeplace binary runs")
}

/// Runs `place` on `config` into `out` (quietly) and returns the parsed report.
pub fn place(config: &Path, out: &Path, extra: &[&str]) -> serde_json::Value {
    let mut args = vec![
        "place",
        config.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--quiet",
    ];
    args.extend_from_slice(extra);
    let o = probeplace(&args);
    assert!(
        o.status.success(),
        "probeplace {args:?} failed: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    read_json(&out.join("report.json"))
}

/// Parses a JSON file.
pub fn read_json(p: &Path) -> serde_json::Value {
    serde_json::from_slice(&std::fs::read(p).unwrap()).unwrap()
}
