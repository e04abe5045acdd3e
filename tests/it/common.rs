//! Helpers shared by the integration tests: run the real binary, read its outputs.

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
    run_job("place", config, out, extra)
}

/// Runs job `command` (`place` or `bake`) on `config` into `out` (quietly),
/// asserts it succeeded, and returns the parsed report.
pub fn run_job(command: &str, config: &Path, out: &Path, extra: &[&str]) -> serde_json::Value {
    let mut args = vec![
        command,
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

/// The `svo` section of a report meets the bar on any scene: a
/// tree, far smaller than the paper's dense texture, that lists a probe for
/// every free cell.
pub fn assert_svo_sound(r: &serde_json::Value, scene: &str) {
    let s = &r["svo"];
    let bytes = s["bytes"].as_u64().unwrap();
    let dense = s["dense_bytes"].as_u64().unwrap();
    assert!(
        bytes * 16 <= dense,
        "{scene}: svo {bytes} bytes against {dense} dense"
    );
    assert!(s["nodes"].as_u64().unwrap() >= 1, "{scene}");
    assert!(s["free_cells"].as_u64().unwrap() > 0, "{scene}");
    assert!(
        s["leaves_without_visible_probe"].as_u64().unwrap() <= s["free_cells"].as_u64().unwrap(),
        "{scene}"
    );
}

/// The GPU context for GPU tests. Without an adapter the test skips with a
/// visible message, except under CI (`CI` set), where it fails: CI installs
/// lavapipe, so a missing adapter there is a broken set-up, not a skip.
pub fn gpu_context(test: &str) -> Option<probeplace::gpu::Context> {
    match probeplace::gpu::Context::new() {
        Ok(ctx) => {
            eprintln!("{test}: GPU adapter {}", ctx.adapter);
            Some(ctx)
        }
        Err(e) if std::env::var_os("CI").is_some() => {
            panic!("{test}: GPU tests need an adapter under CI (install mesa-vulkan-drivers, WGPU_BACKEND=vulkan): {e}")
        }
        Err(e) => {
            eprintln!("SKIPPED {test}: {e}");
            None
        }
    }
}

/// Places `config`'s probes (with `method`, unrefined, when given), then
/// bakes their light field at the config's resolution with `radiance`.
pub fn place_and_bake(
    config: &str,
    method: Option<&str>,
    radiance: &probeplace::lightfield::maps::RadianceFn,
) -> (
    probeplace::pipeline::PlaceRun,
    probeplace::lightfield::LightField,
) {
    use probeplace::pipeline::{self, PlaceOptions};
    let path = root().join(config);
    let cfg = probeplace::config::Config::load(&path).unwrap();
    let options = PlaceOptions {
        method: method.map(String::from),
        no_refine: method.is_some(),
        ..PlaceOptions::default()
    };
    let run = pipeline::compute_place(cfg.clone(), &path, &options).unwrap();
    let p = &run.prepared;
    let field = probeplace::lightfield::bake(
        &cfg.bake,
        &run.probes.positions(),
        &p.scene,
        &p.bvh,
        p.domain.size().length(),
        cfg.seed,
        radiance,
        &probeplace::progress::Progress::hidden(),
    )
    .field;
    (run, field)
}

/// Rec. 709 luminance of an RGB triple in a report.
pub fn luminance(v: &serde_json::Value) -> f64 {
    let c: Vec<f64> = serde_json::from_value(v.clone()).unwrap();
    0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]
}
