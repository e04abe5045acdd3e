//! Helpers shared by the integration tests: run the real binary, read its outputs.

use std::any::Any;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::{Mutex, OnceLock};
use std::time::{Duration, Instant};

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

// ---------------------------------------------------------------------------
// Runs shared by several tests.

/// `make()`'s value, computed once per test process for `key` and shared
/// by every test asking for `key` (tests of other keys do not wait). A
/// `make` that panics fails its test, and the next test asking retries.
pub fn shared<T: Any + Send + Sync>(key: &str, make: impl FnOnce() -> T) -> &'static T {
    type Cell = OnceLock<Box<dyn Any + Send + Sync>>;
    static CELLS: Mutex<BTreeMap<String, &'static Cell>> = Mutex::new(BTreeMap::new());
    let cell: &'static Cell = CELLS
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .entry(key.to_string())
        .or_insert_with(|| Box::leak(Box::new(OnceLock::new())));
    cell.get_or_init(|| Box::new(make()))
        .downcast_ref()
        .unwrap_or_else(|| panic!("shared {key:?} holds another type"))
}

/// A directory for shared runs, named after `key`, in this test process's
/// own directory under Cargo's `CARGO_TARGET_TMPDIR` (shared runs outlive
/// their tests, so they cannot live in a `TempDir`; the directories of
/// earlier test processes that have ended are removed on first use).
pub fn shared_dir(key: &str) -> PathBuf {
    static PROCESS_DIR: OnceLock<PathBuf> = OnceLock::new();
    let base = PROCESS_DIR.get_or_init(|| {
        let base = Path::new(env!("CARGO_TARGET_TMPDIR")).join("shared-runs");
        std::fs::create_dir_all(&base).unwrap();
        if Path::new("/proc/self").is_dir() {
            for entry in std::fs::read_dir(&base).unwrap().flatten() {
                let pid = entry.file_name().to_string_lossy().parse::<u32>();
                if pid.is_ok_and(|pid| !Path::new(&format!("/proc/{pid}")).exists()) {
                    let _ = std::fs::remove_dir_all(entry.path());
                }
            }
        }
        let dir = base.join(std::process::id().to_string());
        let _ = std::fs::remove_dir_all(&dir);
        dir
    });
    let name: String = key
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' {
                c
            } else {
                '_'
            }
        })
        .collect();
    let dir = base.join(name);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// A job's output directory and its report (`report.json`, or
/// `compare.json` for `compare`).
pub struct Shared {
    pub dir: PathBuf,
    pub report: serde_json::Value,
}

/// Runs `probeplace command config --out DIR --quiet extra…` once per test
/// process (`config` relative to the repository root, e.g. a shipped config
/// at full quality), asserting it succeeds; every test asking for the same
/// job reads its outputs. Tests must not write into `dir`: copy it first.
pub fn shared_job(command: &str, config: &str, extra: &[&str]) -> &'static Shared {
    let key = [command, config]
        .iter()
        .chain(extra)
        .copied()
        .collect::<Vec<_>>()
        .join(" ");
    shared(&key, || {
        let dir = shared_dir(&key);
        let report = match command {
            "compare" => {
                let mut args = vec![command, config, "--out", dir.to_str().unwrap(), "--quiet"];
                args.extend_from_slice(extra);
                let o = probeplace(&args);
                let stderr = String::from_utf8_lossy(&o.stderr);
                assert!(o.status.success(), "probeplace {args:?} failed: {stderr}");
                eprintln!("{key}: {stderr}");
                read_json(&dir.join("compare.json"))
            }
            _ => run_job(command, &root().join(config), &dir, extra),
        };
        Shared { dir, report }
    })
}

/// Copies the files of directory `from` into `to` (created).
pub fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for entry in std::fs::read_dir(from).unwrap() {
        let entry = entry.unwrap();
        std::fs::copy(entry.path(), to.join(entry.file_name())).unwrap();
    }
}

/// Parses a JSON file.
pub fn read_json(p: &Path) -> serde_json::Value {
    serde_json::from_slice(&std::fs::read(p).unwrap()).unwrap()
}

/// The PNG at `p` as 8-bit RGB, decoded with the `png` crate whatever its
/// colour type: palettes and depths below 8 expanded, 16-bit samples cut to
/// their high byte, alpha dropped and grey repeated (what the `image`
/// crate's `open(p)?.to_rgb8()`, which the tests used, gave for the 8-bit
/// PNGs they read).
pub fn read_png(p: &Path) -> probeplace::raster::RgbImage {
    let file = std::fs::File::open(p).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
    let mut decoder = png::Decoder::new(std::io::BufReader::new(file));
    decoder.set_transformations(png::Transformations::normalize_to_color8());
    let mut reader = decoder
        .read_info()
        .unwrap_or_else(|e| panic!("{}: {e}", p.display()));
    let mut buf = vec![
        0;
        reader
            .output_buffer_size()
            .expect("a PNG that fits in memory")
    ];
    let frame = reader
        .next_frame(&mut buf)
        .unwrap_or_else(|e| panic!("{}: {e}", p.display()));
    buf.truncate(frame.buffer_size());
    let (color, depth) = reader.output_color_type();
    assert_eq!(depth, png::BitDepth::Eight, "{}", p.display());
    let rgb = match color {
        png::ColorType::Rgb => buf,
        png::ColorType::Rgba => buf
            .chunks_exact(4)
            .flat_map(|c| [c[0], c[1], c[2]])
            .collect(),
        png::ColorType::Grayscale => buf.iter().flat_map(|&g| [g; 3]).collect(),
        png::ColorType::GrayscaleAlpha => buf.chunks_exact(2).flat_map(|c| [c[0]; 3]).collect(),
        png::ColorType::Indexed => unreachable!("EXPAND turns palettes into RGB"),
    };
    probeplace::raster::RgbImage::from_raw(frame.width, frame.height, rgb).unwrap_or_else(|| {
        panic!(
            "{}: not {}×{} pixels",
            p.display(),
            frame.width,
            frame.height
        )
    })
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

/// `config`'s probes (with `method`, unrefined, when given) and their light
/// field baked at the config's resolution, with a radiance that is a colour
/// per direction (so that a texel read from the wrong place reads the wrong
/// colour), computed once per test process: the GPU twin tests and the
/// tracer tests read the same bakes.
pub fn baked_probes(
    config: &str,
    method: Option<&str>,
) -> &'static (
    probeplace::jobs::place::PlaceRun,
    probeplace::lightfield::LightField,
) {
    shared(&format!("baked {config} {method:?}"), || {
        use probeplace::jobs::{self, RunOptions};
        use probeplace::provenance::Overrides;
        let path = root().join(config);
        let cfg = probeplace::config::Config::load(&path).unwrap();
        // The run is kept, never committed, so it holds its output
        // directory's claim for the whole process: one directory per run,
        // not the config's, which other runs of the process write.
        let key: String = format!("{config}-{method:?}")
            .chars()
            .map(|c| if c.is_ascii_alphanumeric() { c } else { '-' })
            .collect();
        let claims = root().join("target/test-claims").join(key);
        std::fs::create_dir_all(&claims).unwrap();
        let options = RunOptions {
            config: Some(path.clone()),
            out: Some(claims.join("out")),
            overrides: Overrides {
                method: method.map(String::from),
                no_refine: method.is_some(),
                ..Overrides::default()
            },
            ..RunOptions::default()
        };
        let run = jobs::place::compute(&options).unwrap();
        let p = &run.prepared;
        let field = probeplace::lightfield::bake(
            &cfg.bake,
            &run.probes.positions(),
            &p.scene,
            &p.bvh,
            p.domain.size().length(),
            cfg.seed,
            &|_, d, _| (d + glam::Vec3::ONE) * 0.5,
            &probeplace::progress::Progress::hidden(),
        )
        .field;
        (run, field)
    })
}

/// The shipped config `config` as loaded, and its scene prepared (scene,
/// domain, BVH, SDF), once per test process.
pub fn prepared(
    config: &str,
) -> &'static (probeplace::config::Config, probeplace::stages::Prepared) {
    shared(&format!("prepared {config}"), || {
        let path = root().join(config);
        let text = std::fs::read_to_string(&path).unwrap();
        let cfg = probeplace::config::Config::from_text(&text, &path).unwrap();
        let progress = probeplace::progress::Progress::hidden();
        let p = probeplace::stages::prepare(&cfg, &path, &text, &progress).unwrap();
        (cfg, p)
    })
}

/// Rec. 709 luminance of an RGB triple in a report.
pub fn luminance(v: &serde_json::Value) -> f64 {
    let c: Vec<f64> = serde_json::from_value(v.clone()).unwrap();
    0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]
}

// ---------------------------------------------------------------------------
// Test-quality overlays of the shipped configs.
//
// The suite runs in two tiers. The full-quality claims (ours beats the
// grids, the reference converges, the real-scene acceptance bars,
// generality) run the shipped configs as they are, once each, their
// results shared by every assertion that reads them. Plumbing,
// determinism, CPU/GPU twin and report-shape tests run on an overlay of a
// shipped config at test quality: the same scene, camera, lights and
// placement, with small maps and few samples, since what they assert holds
// at any quality.

/// The test-quality bake: 16² maps (8² irradiance), one path per texel, one
/// bounce, 64 directions per probe's SH. `BakeParams` allows maps down to 8².
pub const TEST_BAKE: &str =
    "(resolution: 16, irradiance_resolution: 8, samples: 1, bounces: 1, sh_rays: 64)";

/// The test-quality reference image, set inside the config's own
/// `reference` (so its camera stays).
pub const TEST_REFERENCE: [(&str, &str); 3] = [
    ("width", "64"),
    ("height", "48"),
    ("samples_per_pixel", "8"),
];

/// The test-quality `compare`, set inside the config's own `compare`: two
/// chosen views besides the config's camera.
pub const TEST_COMPARE: [(&str, &str); 3] = [
    ("glossy_rays", "2"),
    ("views", "2"),
    ("diffuse", TEST_DIFFUSE),
];

/// The test-quality diffuse evaluation: a quarter of the receivers and
/// rays.
pub const TEST_DIFFUSE: &str =
    "(surface_receivers: 256, free_receivers: 128, reference_rays: 256, probe_rays: 256)";

/// The test-quality coverage measure (a tenth of the samples: a 95%
/// interval of about ±1.6% instead of ±0.5%), set inside the config's own
/// `coverage`.
pub const TEST_COVERAGE: [(&str, &str); 2] = [("samples", "4000"), ("reference_points", "1024")];

/// Test-quality refinement: a quarter of the sweeps, then filling and
/// pruning as usual, and a quarter of the diffuse step's training set at
/// half its rays; set inside the config's own `refine`.
pub const TEST_REFINE: [(&str, &str); 2] = [
    ("iterations", "5"),
    (
        "diffuse",
        "(surface_points: 512, free_points: 256, rays: 64)",
    ),
];

/// A config written for one test into a temporary directory, which lives as
/// long as this value.
pub struct Overlay {
    path: PathBuf,
    _dir: tempfile::TempDir,
}

impl Overlay {
    /// The config file (named as the shipped one).
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The config file as a command-line argument.
    pub fn arg(&self) -> &str {
        self.path.to_str().expect("a UTF-8 temporary path")
    }

    /// The config as loaded (paths resolved).
    pub fn load(&self) -> probeplace::config::Config {
        probeplace::config::Config::load(&self.path).unwrap()
    }
}

/// `config` (a shipped config, relative to the repository root) with each
/// `(field, value)` of `set` in place of its top-level field of that name,
/// or added where it has none (`value` is RON text: `"(resolution: 16)"`,
/// `"0.995"`). Its `scene` and `output`, relative to the shipped file, are
/// made absolute (`output` is added where the config leaves it to its
/// default), so the overlay reads the same scene and names the same output
/// from wherever it is written; `set` may name them too. The result must
/// load as a config whose scene exists, or this panics showing it.
pub fn overlay(config: &str, set: &[(&str, &str)]) -> Overlay {
    let source = root().join(config);
    let text =
        std::fs::read_to_string(&source).unwrap_or_else(|e| panic!("{}: {e}", source.display()));
    let base = source.parent().unwrap();
    let mut fields: Vec<(&str, String)> = Vec::new();
    for key in ["scene", "output"] {
        if set.iter().any(|(k, _)| *k == key) {
            continue;
        }
        // Without an `output`, the shipped config writes to `out` beside itself.
        let relative = match ron_field(&text, key) {
            Some(value) => ron_string_value(&value),
            None if key == "output" => "out".to_string(),
            None => panic!("{config} has no scene"),
        };
        let absolute = probeplace::config::normalize(&base.join(relative));
        fields.push((key, ron_string(&absolute.to_string_lossy())));
    }
    fields.extend(set.iter().map(|&(k, v)| (k, v.to_string())));
    let fields: Vec<(&str, &str)> = fields.iter().map(|(k, v)| (*k, v.as_str())).collect();
    let text = set_ron_fields(&text, &fields);

    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join(source.file_name().unwrap());
    std::fs::write(&path, &text).unwrap();
    match probeplace::config::Config::load(&path) {
        Ok(c) => assert!(
            c.scene.is_file(),
            "overlay of {config}: scene {} is missing (the real scenes need ../shared beside the repository)",
            c.scene.display()
        ),
        Err(e) => panic!("overlay of {config} is not a valid config: {e}\n{text}"),
    }
    Overlay { path, _dir: dir }
}

/// [`overlay`] at test quality ([`test_quality_fields`]), then the fields
/// of `set` (whole).
pub fn test_quality(config: &str, set: &[(&str, &str)]) -> Overlay {
    let text = std::fs::read_to_string(root().join(config)).unwrap();
    let mut fields = test_quality_fields(&text);
    for &(k, v) in set {
        fields.retain(|(f, _)| *f != k);
        fields.push((k, v.to_string()));
    }
    let fields: Vec<(&str, &str)> = fields.iter().map(|(k, v)| (*k, v.as_str())).collect();
    overlay(config, &fields)
}

/// The top-level fields that put the RON config `text` at test quality:
/// [`TEST_BAKE`], then [`TEST_REFERENCE`], [`TEST_COMPARE`],
/// [`TEST_COVERAGE`] and [`TEST_REFINE`] within the config's own fields of
/// those names (so that its camera, coverage target and the like stay).
pub fn test_quality_fields(text: &str) -> Vec<(&'static str, String)> {
    let within = |field: &str, values: &[(&str, &str)]| {
        set_ron_fields(
            &ron_field(text, field).unwrap_or_else(|| "()".into()),
            values,
        )
    };
    vec![
        ("bake", TEST_BAKE.to_string()),
        ("reference", within("reference", &TEST_REFERENCE)),
        ("compare", within("compare", &TEST_COMPARE)),
        ("coverage", within("coverage", &TEST_COVERAGE)),
        ("refine", within("refine", &TEST_REFINE)),
    ]
}

/// A RON string literal holding `s`.
fn ron_string(s: &str) -> String {
    format!("\"{}\"", s.replace('\\', "\\\\").replace('"', "\\\""))
}

/// The text of a RON string literal (`"…"`, with `\\` and `\"` escapes).
fn ron_string_value(literal: &str) -> String {
    let inner = literal
        .strip_prefix('"')
        .and_then(|s| s.strip_suffix('"'))
        .unwrap_or_else(|| panic!("not a plain RON string: {literal}"));
    let mut out = String::new();
    let mut chars = inner.chars();
    while let Some(c) = chars.next() {
        out.push(if c == '\\' { chars.next().unwrap() } else { c });
    }
    out
}

/// What a RON token is, as far as finding fields needs.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Tok {
    Open,
    Close,
    Comma,
    Colon,
    Ident,
    Other,
}

/// The significant tokens of RON `text`, with their byte ranges: comments
/// (`//…`, nested `/* … */`) and whitespace skipped, strings, raw strings and
/// characters whole, so that brackets and colons inside them do not count.
fn ron_tokens(text: &str) -> Vec<(Tok, usize, usize)> {
    let b = text.as_bytes();
    let quoted = |mut i: usize, q: u8| {
        i += 1;
        while i < b.len() && b[i] != q {
            i += if b[i] == b'\\' { 2 } else { 1 };
        }
        assert!(i < b.len(), "unterminated literal in {text}");
        i + 1
    };
    let mut out = Vec::new();
    let mut i = 0;
    while i < b.len() {
        let start = i;
        let tok = match b[i] {
            c if c.is_ascii_whitespace() => {
                i += 1;
                continue;
            }
            b'/' if b.get(i + 1) == Some(&b'/') => {
                while i < b.len() && b[i] != b'\n' {
                    i += 1;
                }
                continue;
            }
            b'/' if b.get(i + 1) == Some(&b'*') => {
                let mut depth = 0;
                loop {
                    assert!(i < b.len(), "unterminated comment in {text}");
                    if b[i..].starts_with(b"/*") {
                        depth += 1;
                        i += 2;
                    } else if b[i..].starts_with(b"*/") {
                        depth -= 1;
                        i += 2;
                        if depth == 0 {
                            break;
                        }
                    } else {
                        i += 1;
                    }
                }
                continue;
            }
            b'"' => {
                i = quoted(i, b'"');
                Tok::Other
            }
            b'\'' => {
                i = quoted(i, b'\'');
                Tok::Other
            }
            b'r' if matches!(b.get(i + 1), Some(b'"' | b'#')) => {
                let hashes = b[i + 1..].iter().take_while(|&&c| c == b'#').count();
                let close: Vec<u8> = std::iter::once(b'"')
                    .chain(std::iter::repeat_n(b'#', hashes))
                    .collect();
                let body = i + 2 + hashes;
                let end = b[body..]
                    .windows(close.len())
                    .position(|w| w == close.as_slice())
                    .unwrap_or_else(|| panic!("unterminated raw string in {text}"));
                i = body + end + close.len();
                Tok::Other
            }
            b'(' | b'[' | b'{' => {
                i += 1;
                Tok::Open
            }
            b')' | b']' | b'}' => {
                i += 1;
                Tok::Close
            }
            b',' => {
                i += 1;
                Tok::Comma
            }
            b':' => {
                i += 1;
                Tok::Colon
            }
            c if c.is_ascii_alphabetic() || c == b'_' => {
                while i < b.len() && (b[i].is_ascii_alphanumeric() || b[i] == b'_') {
                    i += 1;
                }
                Tok::Ident
            }
            _ => {
                // Numbers and anything else: up to the next structural byte.
                i += 1;
                while i < b.len() && !b"()[]{},:\"'/".contains(&b[i]) && !b[i].is_ascii_whitespace()
                {
                    i += 1;
                }
                Tok::Other
            }
        };
        out.push((tok, start, i));
    }
    out
}

/// One field of a RON struct: its name, where it starts (its name), its
/// value's byte range, where it ends (past its comma, when it has one).
#[derive(Debug)]
struct RonField {
    name: String,
    start: usize,
    value: std::ops::Range<usize>,
    end: usize,
    comma: bool,
}

/// The fields of the RON struct `text` (`( … )`, perhaps named and among
/// comments) at nesting depth 1, and the offset of its closing parenthesis.
fn ron_struct(text: &str) -> (Vec<RonField>, usize) {
    let toks = ron_tokens(text);
    let open = toks
        .iter()
        .position(|t| t.0 == Tok::Open)
        .unwrap_or_else(|| panic!("not a RON struct: {text}"));
    assert!(
        open <= 1
            && toks[..open].iter().all(|t| t.0 == Tok::Ident)
            && &text[toks[open].1..toks[open].2] == "(",
        "not a RON struct: {text}"
    );
    let tok = |k: usize| {
        *toks
            .get(k)
            .unwrap_or_else(|| panic!("unbalanced RON struct: {text}"))
    };
    let mut fields = Vec::new();
    let mut k = open + 1;
    loop {
        let (t, s, e) = tok(k);
        if t == Tok::Close {
            assert!(
                toks[k + 1..].is_empty(),
                "text after the RON struct: {text}"
            );
            return (fields, s);
        }
        assert!(
            t == Tok::Ident && tok(k + 1).0 == Tok::Colon,
            "expected a field name at byte {s} of {text}"
        );
        let name = text[s..e].to_string();
        k += 2;
        let value_start = tok(k).1;
        let mut value_end = value_start;
        let mut depth = 0;
        loop {
            let (t, _, te) = tok(k);
            match t {
                Tok::Comma | Tok::Close if depth == 0 => break,
                Tok::Open => depth += 1,
                Tok::Close => depth -= 1,
                _ => {}
            }
            value_end = te;
            k += 1;
        }
        assert!(
            value_end > value_start,
            "field {name} has no value in {text}"
        );
        let (comma, end) = match tok(k) {
            (Tok::Comma, _, ce) => {
                k += 1;
                (true, ce)
            }
            _ => (false, value_end),
        };
        fields.push(RonField {
            name,
            start: s,
            value: value_start..value_end,
            end,
            comma,
        });
    }
}

/// The RON text of field `name` of the RON struct `text` (at depth 1 only).
pub fn ron_field(text: &str, name: &str) -> Option<String> {
    let (fields, _) = ron_struct(text);
    let mut found = fields.iter().filter(|f| f.name == name);
    let field = found.next()?;
    assert!(found.next().is_none(), "field {name} twice in {text}");
    Some(text[field.value.clone()].to_string())
}

/// The RON struct `text` with each `(field, value)` of `set` in place of
/// its field of that name (at depth 1), or added before its closing
/// parenthesis where it has none. The rest of the text, comments included,
/// is kept.
pub fn set_ron_fields(text: &str, set: &[(&str, &str)]) -> String {
    for (i, (name, _)) in set.iter().enumerate() {
        assert!(
            set[..i].iter().all(|(n, _)| n != name),
            "field {name} set twice"
        );
    }
    let (fields, close) = ron_struct(text);
    let replaced = |f: &RonField| set.iter().any(|(n, _)| *n == f.name);
    // A field alone on its line goes with its line.
    let whole_line = |f: &RonField| {
        let from = text[..f.start].rfind('\n').map_or(0, |n| n + 1);
        let to = text[f.end..]
            .find('\n')
            .map_or(text.len(), |n| f.end + n + 1);
        let blank = |s: &str| s.trim().is_empty();
        match blank(&text[from..f.start]) && blank(&text[f.end..to]) {
            true => (from, to),
            false => (f.start, f.end),
        }
    };
    let mut edits: Vec<(usize, usize, String)> = fields
        .iter()
        .filter(|f| replaced(f))
        .map(|f| {
            let (from, to) = whole_line(f);
            (from, to, String::new())
        })
        .collect();
    if let Some(last) = fields.iter().rfind(|f| !replaced(f)) {
        if !last.comma {
            edits.push((last.value.end, last.value.end, ",".into()));
        }
    }
    // Multi-line structs get one field a line, indented as their first.
    let line_start = text[..close].rfind('\n').map_or(0, |n| n + 1);
    let multi_line = text[line_start..close].trim().is_empty() && line_start > 0;
    let insertion = if multi_line {
        let indent = fields.first().map_or("    ".to_string(), |f| {
            let from = text[..f.start].rfind('\n').map_or(0, |n| n + 1);
            text[from..f.start].to_string()
        });
        let lines: String = set
            .iter()
            .map(|(n, v)| format!("{indent}{n}: {v},\n"))
            .collect();
        (line_start, lines)
    } else {
        let items: String = set.iter().map(|(n, v)| format!(" {n}: {v},")).collect();
        (close, items + " ")
    };
    edits.push((insertion.0, insertion.0, insertion.1));
    // From the end backwards; at one offset the edit made later first, so
    // that it lands after the earlier one (the new fields after the comma).
    let mut out = text.to_string();
    let mut order: Vec<usize> = (0..edits.len()).collect();
    order.sort_by_key(|&i| std::cmp::Reverse((edits[i].0, i)));
    for i in order {
        let (start, end, with) = &edits[i];
        out.replace_range(*start..*end, with);
    }
    out
}

#[test]
fn set_ron_fields_replaces_adds_and_keeps_the_rest() {
    let text = "// a (comment) with: colons\n(\n    scene: \"a.obj\", // b: (c\n    bake: (resolution: 128, samples: 4),\n    reference: (\n        camera: (position: (0, 1, 2), look_at: (0, 1, 0)),\n        samples_per_pixel: 256,\n    ),\n    label: \"x)y,z: [\",\n    seed: 1\n)\n";
    let out = set_ron_fields(text, &[("bake", "(resolution: 16)"), ("voxel_size", "0.5")]);
    assert_eq!(ron_field(&out, "bake").as_deref(), Some("(resolution: 16)"));
    assert_eq!(ron_field(&out, "voxel_size").as_deref(), Some("0.5"));
    assert_eq!(ron_field(&out, "label").as_deref(), Some("\"x)y,z: [\""));
    assert_eq!(ron_field(&out, "seed").as_deref(), Some("1"));
    assert!(
        out.contains("// b: (c") && out.starts_with("// a (comment)"),
        "{out}"
    );
    assert_eq!(out.matches("bake:").count(), 1, "{out}");
    // Nested: the same operation on a field's own struct.
    let reference = ron_field(text, "reference").unwrap();
    let smaller = set_ron_fields(&reference, &[("samples_per_pixel", "8"), ("width", "64")]);
    assert_eq!(
        ron_field(&smaller, "samples_per_pixel").as_deref(),
        Some("8")
    );
    assert_eq!(ron_field(&smaller, "width").as_deref(), Some("64"));
    assert_eq!(
        ron_field(&smaller, "camera").as_deref(),
        Some("(position: (0, 1, 2), look_at: (0, 1, 0))")
    );
    // One line, and a last field without its comma.
    let one = set_ron_fields(
        "Config(scene: \"a.obj\", seed: 3)",
        &[("seed", "4"), ("up", "Z")],
    );
    let parsed = probeplace::config::Config::parse(&one, Path::new("one.ron")).unwrap();
    assert_eq!(
        (parsed.seed, parsed.up),
        (4, probeplace::config::UpAxis::Z),
        "{one}"
    );
    let kept = set_ron_fields("(scene: \"a.obj\", seed: 3)", &[("up", "Z")]);
    let parsed = probeplace::config::Config::parse(&kept, Path::new("kept.ron")).unwrap();
    assert_eq!(
        (parsed.seed, parsed.up),
        (3, probeplace::config::UpAxis::Z),
        "{kept}"
    );
    assert_eq!(
        set_ron_fields("()", &[("width", "64")]).replace(' ', ""),
        "(width:64,)"
    );
}

/// Every config in `configs/`, sorted (at least ten; the real scenes among
/// them need ../shared).
pub fn shipped_configs() -> Vec<PathBuf> {
    shared_scenes();
    let mut configs: Vec<_> = std::fs::read_dir(root().join("configs"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "ron"))
        .collect();
    configs.sort();
    assert!(configs.len() >= 10);
    configs
}

/// Every shipped config's test-quality overlay is the shipped config but for
/// the fields it sets: same scene (read from the overlay's directory), same
/// camera, lights, placement and output.
#[test]
fn test_quality_overlays_change_only_what_they_set() {
    for path in shipped_configs() {
        let name = format!("configs/{}", path.file_name().unwrap().to_string_lossy());
        let shipped = probeplace::config::Config::load(&path).unwrap();
        let o = test_quality(&name, &[("seed", "7")]);
        let mut c = o.load();
        assert!(c.scene.is_absolute() && c.output.is_absolute(), "{name}");
        assert_eq!(c.bake.resolution.0, 16, "{name}");
        assert_eq!(c.reference.samples_per_pixel.0, 8, "{name}");
        assert_eq!(c.compare.glossy_rays.0, 2, "{name}");
        assert_eq!(c.compare.views.0, 2, "{name}");
        assert_eq!(c.seed, 7, "{name}");
        (c.bake, c.seed) = (shipped.bake, shipped.seed);
        (
            c.reference.width,
            c.reference.height,
            c.reference.samples_per_pixel,
        ) = (
            shipped.reference.width,
            shipped.reference.height,
            shipped.reference.samples_per_pixel,
        );
        (c.compare.glossy_rays, c.compare.views) =
            (shipped.compare.glossy_rays, shipped.compare.views);
        assert_eq!(c.compare.diffuse.reference_rays.0, 256, "{name}");
        c.compare.diffuse = shipped.compare.diffuse;
        assert_eq!(c.coverage.samples.0, 4000, "{name}");
        assert_eq!(c.refine.iterations.0, 5, "{name}");
        (c.coverage.samples, c.coverage.reference_points) =
            (shipped.coverage.samples, shipped.coverage.reference_points);
        c.refine.iterations = shipped.refine.iterations;
        assert_eq!(c.refine.diffuse.rays.0, 64, "{name}");
        c.refine.diffuse = shipped.refine.diffuse;
        assert_eq!(c, shipped, "{name}");
    }
}

// The refusal contract of a user mistake (exit 2, one line, nothing
// written), shared by the bad-input and hostile-input suites.

/// Seconds any refusal may take (the bound).
pub const REFUSAL_SECONDS: u64 = 10;

/// What a refused run printed.
pub struct Refusal {
    /// The one error line.
    pub line: String,
    /// How long the run took.
    pub took: Duration,
}

/// The memory budget a refusal runs under unless its case sets
/// `PROBEPLACE_MEMORY` itself.
pub const REFUSAL_BUDGET: &str = "1G";

/// `PROBEPLACE_MEMORY`'s forms (`1G`, `512M`, bytes) in bytes.
pub fn budget_bytes(text: &str) -> u64 {
    let t = text.trim();
    let (digits, shift) = match t.chars().last() {
        Some('K' | 'k') => (&t[..t.len() - 1], 10),
        Some('M' | 'm') => (&t[..t.len() - 1], 20),
        Some('G' | 'g') => (&t[..t.len() - 1], 30),
        _ => (t, 0),
    };
    digits.trim().parse::<u64>().expect("a budget") << shift
}

/// Runs `probeplace ARGS` in `dir` under `timeout`, with the environment's
/// extra `env` pairs, and checks the refusal contract: exit 2 within
/// [`REFUSAL_SECONDS`], no panic, one `error: ` line (besides the stage
/// lines of stages that finished), and `dir/out` absent or empty.
///
/// Every refusal runs with an address-space limit (`ulimit -v`) of its
/// memory budget (`PROBEPLACE_MEMORY`, [`REFUSAL_BUDGET`] unless `env`
/// gives one) plus 512 MiB (issue 70): an allocation the budget did not
/// count fails, and the run aborts instead of being refused.
pub fn refused_in(dir: &Path, args: &[&str], env: &[(&str, &str)]) -> Refusal {
    let start = Instant::now();
    let budget = env
        .iter()
        .find(|(k, _)| *k == "PROBEPLACE_MEMORY")
        .map_or(REFUSAL_BUDGET, |(_, v)| *v);
    let limit_kib = (budget_bytes(budget) + (512 << 20)) >> 10;
    let mut cmd = Command::new("timeout");
    cmd.arg("--signal=KILL")
        .arg(REFUSAL_SECONDS.to_string())
        .args([
            "sh",
            "-c",
            &format!("ulimit -v {limit_kib} && exec \"$0\" \"$@\""),
        ])
        .arg(env!("CARGO_BIN_EXE_probeplace"))
        .args(args)
        .env("PROBEPLACE_MEMORY", budget)
        .current_dir(dir);
    for (k, v) in env {
        cmd.env(k, v);
    }
    let o = cmd.output().expect("timeout(1) runs");
    let took = start.elapsed();
    let stderr = String::from_utf8_lossy(&o.stderr).into_owned();
    assert!(
        o.status.code().is_some(),
        "killed (a hang past {REFUSAL_SECONDS} s or an abort): {:?} {args:?}; stderr: {stderr}",
        o.status
    );
    assert_eq!(
        o.status.code(),
        Some(2),
        "expected exit 2 for {args:?}; stderr: {stderr}"
    );
    assert!(!stderr.contains("panicked"), "panic: {stderr}");
    let lines: Vec<&str> = stderr
        .trim_end()
        .lines()
        .filter(|l| !(l.starts_with("probeplace: ") && l.contains(" done in ")))
        .collect();
    assert_eq!(lines.len(), 1, "one line expected for {args:?}: {stderr}");
    assert!(lines[0].starts_with("error: "), "{stderr}");
    let out = dir.join("out");
    if out.is_dir() {
        let left: Vec<_> = std::fs::read_dir(&out).unwrap().collect();
        assert!(left.is_empty(), "{args:?} wrote into out/: {left:?}");
    }
    Refusal {
        line: lines[0].to_string(),
        took,
    }
}

/// Rewrites `dir`'s `manifest.json` for the files now there, as a user
/// who edits a file and its manifest entry alike would: what a test needs
/// to reach the checks behind the manifest (a file of another run, a
/// damaged header) on their own.
pub fn reseal(dir: &Path) {
    let path = dir.join("manifest.json");
    let mut manifest: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&path).unwrap()).unwrap();
    let mut files = serde_json::Map::new();
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n != "manifest.json")
        .collect();
    names.sort();
    for name in names {
        let bytes = std::fs::read(dir.join(&name)).unwrap();
        files.insert(
            name,
            serde_json::json!({ "bytes": bytes.len(), "sha256": sha256_hex(&bytes) }),
        );
    }
    manifest["files"] = serde_json::Value::Object(files);
    std::fs::write(&path, serde_json::to_vec_pretty(&manifest).unwrap()).unwrap();
}

/// SHA-256 of `bytes`, 64 hex digits, as `sha256sum` prints it.
pub fn sha256_hex(bytes: &[u8]) -> String {
    use sha2::Digest;
    sha2::Sha256::digest(bytes)
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect()
}

/// Asserts that `files` (an output directory's, by name) hold a
/// `manifest.json` that lists exactly the other files, each with its size
/// and SHA-256: the set is whole and of one commit.
pub fn assert_manifest_holds(files: &BTreeMap<String, Vec<u8>>) {
    let manifest: serde_json::Value = serde_json::from_slice(
        files
            .get("manifest.json")
            .expect("the set has a manifest.json"),
    )
    .unwrap();
    let listed = manifest["files"].as_object().unwrap();
    let names: Vec<&String> = files.keys().filter(|n| *n != "manifest.json").collect();
    assert_eq!(
        listed.keys().collect::<Vec<_>>(),
        names,
        "manifest.json lists other files"
    );
    for (name, entry) in listed {
        let bytes = &files[name];
        assert_eq!(entry["bytes"], bytes.len(), "{name}");
        assert_eq!(entry["sha256"], sha256_hex(bytes), "{name}");
    }
}

/// Every file of `dir`, by name, with its bytes (each must be a regular
/// file).
pub fn dir_files(dir: &Path) -> BTreeMap<String, Vec<u8>> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| {
            let e = e.unwrap();
            assert!(
                e.file_type().unwrap().is_file(),
                "{:?} is not a file",
                e.path()
            );
            (
                e.file_name().to_string_lossy().into_owned(),
                std::fs::read(e.path()).unwrap(),
            )
        })
        .collect()
}
