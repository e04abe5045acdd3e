//! The readers outside Rust against the Rust writer and reader: the Python
//! package (`python/`) and the C header (`include/probeplace.h`) answer
//! `probes_at` as `Svo::probes_at` does on 10 000 points per real scene,
//! the Python light-field reader reads every value `LightField::read`
//! reads, and damaged files (truncated, each header field wrong, bad
//! checksums, indices out of range, cycles, hostile well-checksummed
//! nonsense) are refused by all three readers alike, with Rust's reasons,
//! and the files Rust accepts are accepted.
//!
//! Each test writes its cases and a manifest into a temporary directory,
//! then runs `python3 -m pytest -q python/tests` (the manifest named by
//! `PROBEPLACE_READERS_MANIFEST`) and the C program `tests/c/readers.c`,
//! built once per process with `gcc -fsanitize=address,undefined`. Without
//! python3 (numpy, pytest) or gcc a test prints `SKIPPED …` for that
//! reader and passes, except under `CI`, where it fails.

use crate::common::*;
use glam::Vec3;
use probeplace::lightfield::LightField;
use probeplace::sampling::{hash2, unit_f32};
use probeplace::svo::{format, Svo};
use probeplace::trace::gather::blend_weights;
use probeplace::trace::{Lattice, Selection};
use serde_json::{json, Value};
use std::path::{Path, PathBuf};
use std::process::Command;

/// Points per scene in the `probes_at` comparison.
const POINTS: usize = 10_000;

/// The padding of an answer's unused slots (as Python's `NO_PROBE`).
const NO_PROBE: u32 = u32::MAX;

/// A required tool is absent: fail under CI, else say so and skip.
fn missing(test: &str, what: &str) {
    assert!(
        std::env::var_os("CI").is_none(),
        "{test}: {what} is required under CI (.ci/run installs it)"
    );
    eprintln!("SKIPPED {test}: no {what}");
}

/// Whether python3 with numpy and pytest is there (see [`missing`]).
fn python(test: &str) -> bool {
    let ok = Command::new("python3")
        .args(["-c", "import numpy, pytest"])
        .output()
        .is_ok_and(|o| o.status.success());
    if !ok {
        missing(
            test,
            "python3 with numpy and pytest (pip install numpy pytest)",
        );
    }
    ok
}

/// The C test program, built once per process with the sanitizers (see
/// [`missing`] when there is no gcc).
fn c_program(test: &str) -> Option<&'static Path> {
    let built: &Option<PathBuf> = shared("readers: C program", || {
        Command::new("gcc").arg("--version").output().ok()?;
        let exe = shared_dir("readers-c").join("readers");
        let start = std::time::Instant::now();
        let o = Command::new("gcc")
            .args([
                "-std=c99",
                "-Wall",
                "-Wextra",
                "-Werror",
                "-pedantic",
                "-O1",
                "-g",
                "-fsanitize=address,undefined",
                "-fno-sanitize-recover=all",
                "-fno-omit-frame-pointer",
                "-ffp-contract=off",
                "-Iinclude",
                "tests/c/readers.c",
                "-lm",
                "-o",
            ])
            .arg(&exe)
            .current_dir(root())
            .output()
            .expect("gcc runs");
        assert!(
            o.status.success(),
            "gcc failed on tests/c/readers.c: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        eprintln!(
            "gcc with sanitizers: {:.1} s",
            start.elapsed().as_secs_f64()
        );
        Some(exe)
    });
    if built.is_none() {
        missing(test, "gcc");
    }
    built.as_deref()
}

/// Runs the C program with `args`; returns its stdout, asserting it
/// succeeded.
fn run_c(exe: &Path, args: &[&Path]) -> String {
    let start = std::time::Instant::now();
    let o = Command::new(exe)
        .arg(args[0])
        .args(&args[1..])
        .env("ASAN_OPTIONS", "abort_on_error=0:halt_on_error=1")
        .env("UBSAN_OPTIONS", "halt_on_error=1:print_stacktrace=1")
        .output()
        .expect("the C test program runs");
    let stdout = String::from_utf8_lossy(&o.stdout).into_owned();
    assert!(
        o.status.success(),
        "C reader failed ({:?}): {stdout}\n{}",
        o.status,
        String::from_utf8_lossy(&o.stderr)
    );
    eprintln!(
        "C reader {:?}: {:.2} s",
        args[0],
        start.elapsed().as_secs_f64()
    );
    stdout
}

/// Writes `manifest` beside its cases and runs the pytest suite on it,
/// asserting that it passes and that it verified exactly the cases
/// `expected` names (`section:name`; pytest appends each case it checked
/// to the manifest's `verified` file).
fn pytest(dir: &Path, mut manifest: Value, expected: Vec<String>) {
    let path = dir.join("manifest.json");
    let verified = dir.join("verified.txt");
    manifest["verified"] = json!(verified);
    std::fs::write(&path, serde_json::to_vec_pretty(&manifest).unwrap()).unwrap();
    let start = std::time::Instant::now();
    // Under timeout(1): a reader blocking on a FIFO fails the test, never
    // stalls it.
    let o = Command::new("timeout")
        .args([
            "--signal=KILL",
            &PYTEST_SECONDS.to_string(),
            "python3",
            "-m",
            "pytest",
            "-q",
            "-p",
            "no:cacheprovider",
            "python/tests",
        ])
        .current_dir(root())
        .env("PROBEPLACE_READERS_MANIFEST", &path)
        .env("PYTHONPATH", root().join("python"))
        .env("PYTHONDONTWRITEBYTECODE", "1")
        .output()
        .expect("python3 runs");
    let out = String::from_utf8_lossy(&o.stdout).into_owned();
    assert!(
        o.status.code().is_some(),
        "pytest killed after {PYTEST_SECONDS} s (a reader blocked?):\n{out}"
    );
    assert!(
        o.status.success(),
        "pytest failed:\n{out}\n{}",
        String::from_utf8_lossy(&o.stderr)
    );
    eprintln!(
        "pytest on {} cases: {:.2} s",
        expected.len(),
        start.elapsed().as_secs_f64()
    );
    let text = std::fs::read_to_string(&verified).unwrap_or_default();
    let mut done: Vec<&str> = text.lines().collect();
    let mut expected: Vec<&str> = expected.iter().map(String::as_str).collect();
    done.sort_unstable();
    expected.sort_unstable();
    assert_eq!(
        done, expected,
        "pytest verified other cases than given: {out}"
    );
}

/// Seconds one pytest run may take before it is killed (the slowest,
/// Sponza's comparisons, take a few).
const PYTEST_SECONDS: u64 = 300;

/// Little-endian bytes of `words`.
fn le_bytes<T: Copy, const N: usize>(words: &[T], to: impl Fn(T) -> [u8; N]) -> Vec<u8> {
    words.iter().flat_map(|&w| to(w)).collect()
}

/// `points` as the C and Python tests read them: f32 x, y, z each.
fn write_points(path: &Path, points: &[Vec3]) {
    let flat: Vec<f32> = points.iter().flat_map(|p| p.to_array()).collect();
    std::fs::write(path, le_bytes(&flat, f32::to_le_bytes)).unwrap();
}

/// Rust's answers for `points`: per point the count, then 8 slots
/// ([`NO_PROBE`] past the count). Returns how many were not empty.
fn write_answers(path: &Path, svo: &Svo, points: &[Vec3]) -> usize {
    let mut words = Vec::with_capacity(9 * points.len());
    let mut non_empty = 0;
    for &p in points {
        let list = svo.probes_at(p);
        non_empty += !list.is_empty() as usize;
        words.push(list.len() as u32);
        words.extend((0..8).map(|k| list.get(k).copied().unwrap_or(NO_PROBE)));
    }
    std::fs::write(path, le_bytes(&words, u32::to_le_bytes)).unwrap();
    non_empty
}

/// `x` with its bit pattern one up (`step` 1: a unit in the last place away
/// from zero) or one down (`step` 2: toward zero; ±0 stays), or as it is.
fn nudge(x: f32, step: u64) -> f32 {
    let bits = x.to_bits();
    match step {
        1 => f32::from_bits(bits + 1),
        2 if bits & 0x7FFF_FFFF != 0 => f32::from_bits(bits - 1),
        _ => x,
    }
}

/// `count` seeded points over the tree's leaves and 5% beyond each face:
/// a third uniform, a third on leaf boundaries (`origin + k·leaf` rounded
/// to f32, then perhaps one unit in the last place either side: where an
/// f32 operation done otherwise than Rust does it picks the other leaf),
/// a third on a boundary along one axis only; and the first few special
/// (non-finite, the corners exactly).
fn query_points(svo: &Svo, count: usize, seed: u64) -> Vec<Vec3> {
    let size = svo.dims.as_vec3() * svo.leaf_size;
    let (lo, pad) = (svo.origin, size * 0.05);
    let mut points: Vec<Vec3> = (0..count as u64)
        .map(|i| {
            let h = hash2(seed, i);
            let u = |k: u64| unit_f32(hash2(h, k));
            let uniform = lo - pad + (size + 2.0 * pad) * Vec3::new(u(1), u(2), u(3));
            let boundary = |axis: usize| {
                let dims = svo.dims.to_array()[axis] as f32;
                let k = (u(4 + axis as u64) * (dims + 4.0)).floor() - 2.0;
                let x = lo.to_array()[axis] + k * svo.leaf_size;
                nudge(x, hash2(h, 8 + axis as u64) % 3)
            };
            match i % 3 {
                0 => uniform,
                1 => Vec3::new(boundary(0), boundary(1), boundary(2)),
                _ => {
                    let mut p = uniform.to_array();
                    let axis = (hash2(h, 11) % 3) as usize;
                    p[axis] = boundary(axis);
                    Vec3::from_array(p)
                }
            }
        })
        .collect();
    let hi = lo + size;
    let special = [
        Vec3::splat(f32::NAN),
        Vec3::new(lo.x, f32::NAN, lo.z),
        Vec3::splat(f32::INFINITY),
        Vec3::splat(f32::NEG_INFINITY),
        Vec3::new(f32::MAX, lo.y, lo.z),
        Vec3::new(-0.0, -0.0, -0.0),
        lo,
        hi,
        (lo + hi) * 0.5,
    ];
    for (p, s) in points.iter_mut().zip(special) {
        *p = s;
    }
    points
}

/// The shared `place` run of `config`, and its tree read back.
fn placed(config: &str) -> (&'static Shared, Svo) {
    if config != "configs/cornell.ron" {
        shared_scenes();
    }
    let run = shared_job("place", config, &[]);
    let svo = Svo::read(&run.dir.join("svo.bin")).unwrap();
    (run, svo)
}

/// A manifest entry checking the output directory `dir` as one run:
/// Python's `open_run` must accept it, with `svo`'s provenance, and read
/// `probes.json`'s positions bit for bit as Rust's reader does.
fn run_entry(name: &str, dir: &Path, svo: &Svo, cases: &Path) -> Value {
    let inspected = probeplace::jobs::inspect(dir).unwrap();
    let world = probeplace::placement::file::read_world(&dir.join("probes.json")).unwrap();
    assert_eq!(world.len(), svo.probe_count as usize);
    let flat: Vec<f64> = world.iter().flat_map(|(p, _)| p.to_array()).collect();
    let positions = cases.join(format!("{name}.positions.f64"));
    std::fs::write(&positions, le_bytes(&flat, f64::to_le_bytes)).unwrap();
    json!({
        "name": name,
        "dir": dir,
        "provenance": hex(&svo.provenance),
        "probes": svo.probe_count,
        "cluster_size": world.iter().map(|w| w.1).collect::<Vec<_>>(),
        "positions": positions,
        "lightfield": inspected.light_field.is_some(),
    })
}

/// `bytes` as lower-case hex, as Python's `bytes.hex()` writes them.
fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

/// Python and C answer as Rust on [`POINTS`] points of `config`'s tree
/// (the shared `place` run), and Python reads its directory as one run.
fn probes_at_agree(test: &str, config: &str) {
    let (run, svo) = placed(config);
    let name = Path::new(config).file_stem().unwrap().to_string_lossy();
    let cases = tempfile::tempdir().unwrap();
    let points = query_points(&svo, POINTS, 0x09EA_DE25 ^ svo.probe_count as u64);
    let (pts, answers) = (
        cases.path().join("points.f32"),
        cases.path().join("answers.u32"),
    );
    write_points(&pts, &points);
    let non_empty = write_answers(&answers, &svo, &points);
    // Enough of both kinds of answer that agreeing on them means something.
    assert!(
        non_empty >= POINTS / 10 && POINTS - non_empty >= POINTS / 20,
        "{config}: {non_empty} of {POINTS} points list probes"
    );
    let svo_path = run.dir.join("svo.bin");
    if let Some(exe) = c_program(test) {
        let out = run_c(exe, &[Path::new("answers"), &svo_path, &pts, &answers]);
        assert!(out.contains(", 0 differ from Rust"), "{out}");
        eprintln!("{test}: C: {}", out.trim());
    }
    if python(test) {
        let manifest = json!({
            "probes_at": [{
                "name": name, "svo": svo_path, "points": pts, "answers": answers,
                "count": POINTS, "non_empty": non_empty,
            }],
            "runs": [run_entry(&name, &run.dir, &svo, cases.path())],
        });
        let expected = vec![format!("probes_at:{name}"), format!("run:{name}")];
        pytest(cases.path(), manifest, expected);
    }
}

#[test]
fn cornell_probes_at_agrees_in_python_and_c() {
    probes_at_agree(
        "readers::cornell_probes_at_agrees_in_python_and_c",
        "configs/cornell.ron",
    );
}

#[test]
fn holodeck_probes_at_agrees_in_python_and_c() {
    probes_at_agree(
        "readers::holodeck_probes_at_agrees_in_python_and_c",
        "configs/holodeck.ron",
    );
}

#[test]
fn sponza_probes_at_agrees_in_python_and_c() {
    probes_at_agree(
        "readers::sponza_probes_at_agrees_in_python_and_c",
        "configs/sponza.ron",
    );
}

/// Every value of `field` in file order, as f32: positions, radiance,
/// normals, distances, each pyramid level, irradiance, moments.
fn field_values(field: &LightField) -> Vec<f32> {
    let mut v: Vec<f32> = field.positions.iter().flat_map(|p| p.to_array()).collect();
    v.extend(field.radiance.iter().flatten());
    v.extend(field.normal.iter().flatten());
    v.extend(&field.distance);
    for level in &field.pyramid {
        v.extend(level.iter().flatten());
    }
    v.extend(field.irradiance.iter().flatten());
    v.extend(field.moments.iter().flatten());
    v
}

/// A manifest entry asking Python to read `path` as Rust read `field`:
/// the header's figures, and every value (dumped to `dump` as f32).
fn field_entry(name: &str, path: &Path, field: &LightField, dump: &Path) -> Value {
    std::fs::write(dump, le_bytes(&field_values(field), f32::to_le_bytes)).unwrap();
    json!({
        "name": name,
        "path": path,
        "dump": dump,
        "probes": field.positions.len(),
        "resolution": field.resolution,
        "irradiance_resolution": field.irradiance_resolution,
        "levels": field.pyramid.len(),
        "max_distance_bits": field.max_distance.to_bits(),
        "provenance": hex(&field.provenance),
    })
}

/// Python reads every value of the light fields of the bakes `runs`
/// (name, output directory) as `LightField::read` does, and each directory
/// as one run; one pytest run for them all.
fn light_fields_agree(runs: &[(&str, &Path)]) {
    let cases = tempfile::tempdir().unwrap();
    let (mut fields, mut dirs, mut expected) = (Vec::new(), Vec::new(), Vec::new());
    for &(name, dir) in runs {
        let path = dir.join("lightfield.bin");
        let field = LightField::read(&path).unwrap();
        let svo = Svo::read(&dir.join("svo.bin")).unwrap();
        let dump = cases.path().join(format!("{name}.f32"));
        fields.push(field_entry(name, &path, &field, &dump));
        dirs.push(run_entry(name, dir, &svo, cases.path()));
        expected.extend([format!("lightfield:{name}"), format!("run:{name}")]);
    }
    let manifest = json!({ "lightfields": fields, "runs": dirs });
    pytest(cases.path(), manifest, expected);
}

/// The acceptance's bake: the suite's shared full-quality Cornell bake.
#[test]
fn cornell_light_field_reads_alike_in_python() {
    if python("readers::cornell_light_field_reads_alike_in_python") {
        let run = shared_job("bake", "configs/cornell.ron", &[]);
        light_fields_agree(&[("cornell", &run.dir)]);
    }
}

/// Holodeck and Sponza baked at test quality (16² maps, one sample a
/// texel, and the overlay's lighter coverage and refinement), once per
/// test process: a full-quality bake of either takes minutes, and what a
/// reader reads does not depend on the quality.
fn test_quality_bakes(test: &str) -> &'static [(&'static str, PathBuf); 2] {
    shared("readers: test-quality bakes", || {
        shared_scenes();
        ["holodeck", "sponza"].map(|scene| {
            let out = shared_dir(&format!("readers-test-quality-{scene}"));
            let config = test_quality(&format!("configs/{scene}.ron"), &[]);
            let start = std::time::Instant::now();
            run_job("bake", config.path(), &out, &[]);
            eprintln!(
                "{test}: test-quality bake of {scene}: {:.1} s",
                start.elapsed().as_secs_f64()
            );
            (scene, out)
        })
    })
}

/// Python reads the Holodeck and Sponza light fields as Rust does
/// ([`test_quality_bakes`]).
#[test]
#[ignore = "full tier (about 6 s): cargo test --release -- --include-ignored"]
fn holodeck_and_sponza_light_fields_read_alike_in_python() {
    let test = "readers::holodeck_and_sponza_light_fields_read_alike_in_python";
    if !python(test) {
        return;
    }
    let [(a, a_dir), (b, b_dir)] = test_quality_bakes(test);
    light_fields_agree(&[(a, a_dir), (b, b_dir)]);
}

// ---------------------------------------------------------------------------
// The diffuse blend's probes and weights.

/// Points per case in the blend comparison.
const BLEND_POINTS: usize = 4000;

/// `count` seeded points, each with a normal, where the blend of `field`
/// is asked: a quarter uniform over the probes' box and a margin around it
/// as wide as the box, a quarter uniform inside it, a quarter at a probe
/// (exactly, or one unit in the last place off on one axis: r = 0 and r
/// tiny), a quarter on a plane through a probe (on a grid, a cell face,
/// where a trilinear weight is 0 and the cell changes), those last ones
/// again one unit in the last place either side. Normals are uniform, one
/// in ten along an axis; the first points and normals are special
/// (non-finite, huge, zero, negative zero, not of unit length), which the
/// readers must answer as Rust does.
fn blend_queries(field: &LightField, count: usize, seed: u64) -> (Vec<Vec3>, Vec<Vec3>) {
    let probes = &field.positions;
    let lo = probes.iter().fold(Vec3::INFINITY, |a, &b| a.min(b));
    let hi = probes.iter().fold(Vec3::NEG_INFINITY, |a, &b| a.max(b));
    let size = (hi - lo).max(Vec3::splat(0.1));
    let mut points = Vec::with_capacity(count);
    let mut normals = Vec::with_capacity(count);
    for i in 0..count as u64 {
        let h = hash2(seed, i);
        let u = |k: u64| {
            Vec3::new(
                unit_f32(hash2(h, k)),
                unit_f32(hash2(h, k + 1)),
                unit_f32(hash2(h, k + 2)),
            )
        };
        let probe = probes[(hash2(h, 10) % probes.len() as u64) as usize];
        let axis = (hash2(h, 11) % 3) as usize;
        let p = match i % 4 {
            0 => lo - size + 3.0 * size * u(1),
            1 => lo + size * u(1),
            2 => {
                let mut p = probe.to_array();
                p[axis] = nudge(p[axis], hash2(h, 12) % 3);
                Vec3::from_array(p)
            }
            _ => {
                let mut p = (lo + size * u(1)).to_array();
                p[axis] = nudge(probe.to_array()[axis], hash2(h, 12) % 3);
                Vec3::from_array(p)
            }
        };
        let n = if i % 10 == 9 {
            let mut a = [0.0; 3];
            a[axis] = if h & 1 == 0 { 1.0 } else { -1.0 };
            Vec3::from_array(a)
        } else {
            probeplace::sampling::uniform_direction(seed ^ 0x4E0, i)
        };
        points.push(p);
        normals.push(n);
    }
    let inside = (lo + hi) * 0.5;
    let special = [
        (Vec3::splat(f32::NAN), Vec3::Y),
        (Vec3::new(inside.x, f32::NAN, inside.z), Vec3::Y),
        (Vec3::splat(f32::INFINITY), Vec3::Y),
        (Vec3::new(f32::NEG_INFINITY, inside.y, inside.z), Vec3::X),
        (Vec3::new(f32::MAX, inside.y, inside.z), Vec3::X),
        (Vec3::new(-0.0, -0.0, -0.0), Vec3::Z),
        (inside, Vec3::splat(f32::NAN)),
        (inside, Vec3::ZERO),
        (inside, Vec3::new(0.0, 3.0, 0.0)),
        (probes[0], Vec3::new(-0.0, -1.0, -0.0)),
        (lo, Vec3::NEG_Y),
        (hi, Vec3::Y),
    ];
    for (k, (p, n)) in special.into_iter().enumerate() {
        points[k] = p;
        normals[k] = n;
    }
    (points, normals)
}

/// Rust's blend at each point: the count of terms (0 where the weights
/// sum to no positive number), then per term its probe and the bits of its
/// weight ([`NO_PROBE`] and 0 past the count). Returns how many points
/// have terms.
fn write_blend_answers(
    path: &Path,
    field: &LightField,
    selection: &Selection,
    terms: usize,
    points: &[Vec3],
    normals: &[Vec3],
) -> usize {
    let mut words = Vec::with_capacity((1 + 2 * terms) * points.len());
    let mut out = Vec::new();
    let mut non_empty = 0;
    for (&p, &n) in points.iter().zip(normals) {
        blend_weights(field, selection, p, n, &mut out);
        assert!(
            out.is_empty() || out.len() == terms,
            "{p}: {} terms",
            out.len()
        );
        non_empty += !out.is_empty() as usize;
        words.push(out.len() as u32);
        for k in 0..terms {
            let (probe, w) = out.get(k).copied().unwrap_or((NO_PROBE, 0.0));
            words.extend([probe, w.to_bits()]);
        }
    }
    std::fs::write(path, le_bytes(&words, u32::to_le_bytes)).unwrap();
    non_empty
}

/// One blend case: `name`, the run directory `dir` (its `lightfield.bin`
/// and `svo.bin`), and whether to blend on the grid its probes form (the
/// bi-level render's selection on a grid) or with the SVO selection.
struct BlendCase<'a> {
    name: &'a str,
    dir: &'a Path,
    grid: bool,
}

/// Python and C blend as Rust's `trace::gather::blend_weights` does, bit
/// for bit, on [`BLEND_POINTS`] points and normals per case, reading the
/// files of each run; and they recognize the probes as a grid where Rust's
/// `Lattice::from_positions` does, and only there.
fn blend_weights_agree(test: &str, cases: &[BlendCase]) {
    let dir = tempfile::tempdir().unwrap();
    let mut entries = Vec::new();
    let mut c_runs = Vec::new();
    for case in cases {
        let field_path = case.dir.join("lightfield.bin");
        let svo_path = case.dir.join("svo.bin");
        let field = LightField::read(&field_path).unwrap();
        let svo = Svo::read(&svo_path).unwrap();
        let lattice = Lattice::from_positions(&field.positions);
        let (selection, terms) = match (&lattice, case.grid) {
            (Some(l), true) => (Selection::Grid(l), 8),
            (None, true) => panic!("{}: the probes are not a grid", case.name),
            (_, false) => (Selection::Svo(&svo), field.positions.len()),
        };
        let seed = 0xB1E4D ^ field.positions.len() as u64;
        let (points, normals) = blend_queries(&field, BLEND_POINTS, seed);
        let files = ["points.f32", "normals.f32", "blend.u32"]
            .map(|f| dir.path().join(format!("{}.{f}", case.name)));
        write_points(&files[0], &points);
        write_points(&files[1], &normals);
        let start = std::time::Instant::now();
        let non_empty =
            write_blend_answers(&files[2], &field, &selection, terms, &points, &normals);
        eprintln!(
            "{test}: {}: Rust blends {terms} terms at {BLEND_POINTS} points in {:.3} s",
            case.name,
            start.elapsed().as_secs_f64()
        );
        // Every point but the special ones has weights.
        assert!(non_empty + 12 >= BLEND_POINTS, "{}: {non_empty}", case.name);
        let is_grid = if lattice.is_some() {
            "grid"
        } else {
            "not-grid"
        };
        c_runs.push((
            [
                field_path.clone(),
                svo_path.clone(),
                PathBuf::from(if case.grid { "grid" } else { "svo" }),
                files[0].clone(),
                files[1].clone(),
                files[2].clone(),
            ],
            is_grid,
        ));
        entries.push(json!({
            "name": case.name, "lightfield": field_path, "svo": svo_path,
            "grid": case.grid, "is_grid": lattice.is_some(),
            "points": files[0], "normals": files[1], "answers": files[2],
            "count": BLEND_POINTS, "terms": terms, "non_empty": non_empty,
        }));
    }
    if let Some(exe) = c_program(test) {
        for (args, is_grid) in &c_runs {
            let mut all: Vec<&Path> = vec![Path::new("blend")];
            all.extend(args.iter().map(PathBuf::as_path));
            let out = run_c(exe, &all);
            assert!(out.contains(", 0 differ from Rust"), "{out}");
            assert!(out.contains(&format!("probes: {is_grid}")), "{out}");
            eprintln!("{test}: C: {}", out.trim());
        }
    }
    if python(test) {
        let expected = cases.iter().map(|c| format!("blend:{}", c.name)).collect();
        pytest(dir.path(), json!({ "blend": entries }), expected);
    }
}

/// The shared full-quality Cornell bake (SDF-skeleton probes: the SVO
/// selection), and a Cornell bake of a 4 × 3 × 4 grid with both
/// selections: the grid of its bi-level render, the SVO of its Hi-Z render.
#[test]
fn cornell_blend_weights_agree_in_python_and_c() {
    let placed = shared_job("bake", "configs/cornell.ron", &[]);
    let grid = shared_job(
        "bake",
        "configs/cornell.ron",
        &["--method", "grid:4x3x4", "--no-refine"],
    );
    blend_weights_agree(
        "readers::cornell_blend_weights_agree_in_python_and_c",
        &[
            BlendCase {
                name: "cornell",
                dir: &placed.dir,
                grid: false,
            },
            BlendCase {
                name: "cornell-grid",
                dir: &grid.dir,
                grid: true,
            },
            BlendCase {
                name: "cornell-grid-svo",
                dir: &grid.dir,
                grid: false,
            },
        ],
    );
}

/// The blends of Holodeck's and Sponza's placed probes (the SVO selection,
/// over more probes than Cornell's), on their test-quality bakes.
#[test]
#[ignore = "full tier (about 8 s): cargo test --release -- --include-ignored"]
fn holodeck_and_sponza_blend_weights_agree_in_python_and_c() {
    let test = "readers::holodeck_and_sponza_blend_weights_agree_in_python_and_c";
    let cases = test_quality_bakes(test)
        .each_ref()
        .map(|(scene, dir)| BlendCase {
            name: scene,
            dir,
            grid: false,
        });
    blend_weights_agree(test, &cases);
}

// ---------------------------------------------------------------------------
// Damaged files.

/// Reads the little-endian u32 at `at`.
fn word(b: &[u8], at: usize) -> u32 {
    u32::from_le_bytes(b[at..at + 4].try_into().unwrap())
}

/// Sets the little-endian u32 at `at` to `w`.
fn set_word(b: &mut [u8], at: usize, w: u32) {
    b[at..at + 4].copy_from_slice(&w.to_le_bytes());
}

/// `b` with its trailing CRC-32 made to match again.
fn fixed(mut b: Vec<u8>) -> Vec<u8> {
    let end = b.len() - 4;
    let crc = format::crc32(&b[..end]);
    b[end..].copy_from_slice(&crc.to_le_bytes());
    b
}

/// `b` with the u32 at `at` set to `w`, checksum fixed.
fn with_word(b: &[u8], at: usize, w: u32) -> Vec<u8> {
    let mut b = b.to_vec();
    set_word(&mut b, at, w);
    fixed(b)
}

/// A checksummed `svo.bin` of `depth`, `dims`, `probes` probes at most
/// `max` a leaf, and the given nodes and payload: trees no bake writes.
fn svo_file(
    depth: u32,
    dims: [u32; 3],
    probes: u32,
    max: u32,
    nodes: &[u32],
    payload: &[u32],
) -> Vec<u8> {
    let mut b = format::MAGIC.to_vec();
    let header = [format::VERSION, 0, 0, 0, 1f32.to_bits(), depth];
    let header = header.into_iter().chain(dims).chain([
        probes,
        max,
        0,
        nodes.len() as u32,
        payload.len() as u32,
    ]);
    b.extend(header.flat_map(u32::to_le_bytes));
    b.resize(format::HEADER_BYTES, 0);
    b.extend(nodes.iter().chain(payload).flat_map(|w| w.to_le_bytes()));
    b.extend([0; 4]);
    fixed(b)
}

const LEAF: u32 = 1 << 31;

/// What Rust must say of the named variants of [`svo_variants`]: each is
/// the fault its name claims (`accepted` for fields no check reads).
const SVO_EXPECTED: &[(&str, &str)] = &[
    ("truncated-7", "not a probeplace SVO"),
    (
        "truncated-123",
        "truncated: 123 bytes, but the header alone",
    ),
    ("truncated-124", "but its header announces"),
    ("longer", "corrupted: "),
    ("magic", "not a probeplace SVO"),
    ("version-3", "unsupported version 3"),
    ("origin-nan", "the origin is not finite"),
    ("origin-neg-inf", "the origin is not finite"),
    ("leaf-neg-zero", "leaf size -0 is not positive"),
    ("leaf-nan", "leaf size NaN is not positive"),
    ("depth-24", "depth 24 exceeds 23"),
    ("depth-short", "leaves do not fit a root"),
    ("dims-zero", "leaves do not fit a root"),
    ("dims-over-root", "leaves do not fit a root"),
    ("too-many-leaves", "leaves are more than the 64000000"),
    ("max-probes-zero", "0 probes per leaf is outside 1..=8"),
    ("max-probes-nine", "9 probes per leaf is outside 1..=8"),
    ("max-probes-one", "lists beyond the payload"),
    ("probe-count-zero", "probe index"),
    ("probe-count-at-max-index", "probe index"),
    ("node-count-more", "truncated"),
    ("crc-flipped", "checksum"),
    ("node-flipped", "checksum"),
    ("child-past-array", "points outside the node array"),
    ("child-index-max", "points outside the node array"),
    ("cycle-to-itself", "points outside the node array"),
    ("cycle-to-root", "points outside the node array"),
    ("shared-child", "shares a child with another node"),
    ("orphan", "node 1 has no parent"),
    ("root-empty", "node 1 has no parent"),
    ("inner-empty", "has no child"),
    ("leaf-offset-past-payload", "lists beyond the payload"),
    ("leaf-eight-probes", "lists beyond the payload"),
    ("probe-index", "probe index"),
    ("synthetic-no-root", "there is no root node"),
    (
        "synthetic-below-leaf-level",
        "node 0 has children below the leaf level",
    ),
    (
        "synthetic-chain-too-deep",
        "node 3 has children below the leaf level",
    ),
    (
        "synthetic-self-loop",
        "node 0 points outside the node array",
    ),
    ("synthetic-chain", "accepted"),
    ("synthetic-empty-tree", "accepted"),
    ("blind-leaves", "accepted"),
    ("exact-origin", "accepted"),
    ("provenance", "accepted"),
];

/// Damaged variants of the `svo.bin` image `good`: every kind the Rust
/// reader refuses, and changes it accepts (fields it does not check),
/// each named.
fn svo_variants(good: &[u8]) -> Vec<(String, Vec<u8>)> {
    let mut out: Vec<(String, Vec<u8>)> = Vec::new();
    let len = good.len();
    let (n, m) = (word(good, 56) as usize, word(good, 60) as usize);
    let node = |i: usize| word(good, format::HEADER_BYTES + 4 * i);
    let node_at = |i: usize| format::HEADER_BYTES + 4 * i;
    let payload_at = format::HEADER_BYTES + 4 * n;
    for cut in [0, 7, 8, 64, 119, 123, 124, 125, len / 2, len - 4, len - 1] {
        out.push((format!("truncated-{cut}"), good[..cut].to_vec()));
    }
    let mut longer = good.to_vec();
    longer.push(0);
    out.push(("longer".into(), longer.clone()));
    out.push(("longer-fixed".into(), fixed(longer)));
    let mut magic = good.to_vec();
    magic[7] = b'P';
    out.push(("magic".into(), magic));
    // Every header word flipped, checksum left: the CRC (or, for the counts,
    // the length) must catch it.
    for at in (8..format::HEADER_BYTES).step_by(4) {
        let mut b = good.to_vec();
        b[at + 1] ^= 0x40;
        out.push((format!("flipped-{at}"), b));
    }
    let f = f32::to_bits;
    let depth = word(good, 28);
    let probes = word(good, 44);
    // Each checked header field wrong, checksum fixed.
    for (name, at, w) in [
        ("version-1", 8, 1),
        ("version-3", 8, 3),
        ("version-max", 8, u32::MAX),
        ("origin-nan", 12, f(f32::NAN)),
        ("origin-inf", 16, f(f32::INFINITY)),
        ("origin-neg-inf", 20, f(f32::NEG_INFINITY)),
        ("leaf-zero", 24, f(0.0)),
        ("leaf-neg-zero", 24, f(-0.0)),
        ("leaf-negative", 24, f(-1.5)),
        ("leaf-tiny-negative", 24, f(-1e-45)),
        ("leaf-huge-negative", 24, f(-3.4e38)),
        ("leaf-nan", 24, f(f32::NAN)),
        ("leaf-inf", 24, f(f32::INFINITY)),
        ("depth-24", 28, 24),
        ("depth-max", 28, u32::MAX),
        ("depth-short", 28, depth - 1),
        ("dims-zero", 32, 0),
        ("dims-over-root", 36, (1 << depth) + 1),
        ("probe-count-zero", 44, 0),
        ("max-probes-zero", 48, 0),
        ("max-probes-nine", 48, 9),
        ("max-probes-one", 48, 1),
        ("node-count-more", 56, n as u32 + 1),
        ("payload-count-less", 60, m as u32 - 1),
        // Fields the reader does not check: accepted, same answers.
        ("blind-leaves", 52, 12345),
        ("exact-origin", 64, 0x3FF0_0000),
        ("provenance", 100, 0xDEAD_BEEF),
    ] {
        out.push((name.into(), with_word(good, at, w)));
    }
    let max_payload = (0..m)
        .map(|i| word(good, payload_at + 4 * i))
        .max()
        .unwrap();
    out.push((
        "probe-count-at-max-index".into(),
        with_word(good, 44, max_payload),
    ));
    let mut deep = with_word(good, 28, 23);
    for at in [32, 36, 40] {
        set_word(&mut deep, at, 1 << 23);
    }
    out.push(("too-many-leaves".into(), fixed(deep)));
    // Checksums.
    let mut b = good.to_vec();
    b[len - 2] ^= 1;
    out.push(("crc-flipped".into(), b));
    let mut b = good.to_vec();
    b[node_at(n / 2) + 2] ^= 8;
    out.push(("node-flipped".into(), b));
    let mut b = good.to_vec();
    b[payload_at] ^= 1;
    out.push(("payload-flipped".into(), b));
    // Indices out of range, cycles, shared and missing parents, checksum fixed.
    let inner: Vec<usize> = (0..n)
        .filter(|&i| node(i) & LEAF == 0 && node(i) & 0xFF != 0)
        .collect();
    let leaves: Vec<usize> = (0..n).filter(|&i| node(i) & LEAF != 0).collect();
    assert!(
        inner.len() >= 2 && !leaves.is_empty(),
        "a tree with inner nodes"
    );
    let with_first =
        |i: usize, first: u32| with_word(good, node_at(i), (node(i) & 0xFF) | (first << 8));
    let (a, z) = (inner[0], *inner.last().unwrap());
    out.push(("child-past-array".into(), with_first(z, n as u32)));
    out.push(("child-index-max".into(), with_first(a, (1 << 23) - 1)));
    out.push(("cycle-to-itself".into(), with_first(z, z as u32)));
    out.push(("cycle-to-root".into(), with_first(z, 0)));
    // Two parents a < b with a's children after b: b taking a's children
    // passes the order check and must be caught sharing them.
    let (p, q) = inner
        .iter()
        .flat_map(|&p| inner.iter().map(move |&q| (p, q)))
        .find(|&(p, q)| p < q && (node(p) >> 8) as usize > q)
        .expect("two parents before the first one's children");
    out.push(("shared-child".into(), with_first(q, node(p) >> 8)));
    out.push(("orphan".into(), with_first(a, (node(a) >> 8) + 1)));
    out.push(("root-empty".into(), with_word(good, node_at(0), 0)));
    out.push(("inner-empty".into(), with_word(good, node_at(z), 0)));
    out.push((
        "leaf-as-empty-inner".into(),
        with_word(good, node_at(leaves[0]), 0),
    ));
    let leaf = leaves[leaves.len() / 2];
    out.push((
        "leaf-offset-past-payload".into(),
        with_word(good, node_at(leaf), LEAF | m as u32),
    ));
    out.push((
        "leaf-eight-probes".into(),
        with_word(good, node_at(leaf), node(leaf) | (7 << 28)),
    ));
    out.push((
        "leaf-offset-max".into(),
        with_word(good, node_at(leaf), LEAF | 0x0FFF_FFFF),
    ));
    out.push(("probe-index".into(), with_word(good, payload_at, probes)));
    out.push((
        "probe-index-max".into(),
        with_word(good, payload_at + 4 * (m - 1), u32::MAX),
    ));
    // Trees no bake writes.
    let child = |first: u32| 1 | (first << 8);
    out.push((
        "synthetic-no-root".into(),
        svo_file(0, [1; 3], 1, 1, &[], &[]),
    ));
    out.push((
        "synthetic-empty-tree".into(),
        svo_file(2, [4, 3, 1], 1, 1, &[0], &[]),
    ));
    out.push((
        "synthetic-below-leaf-level".into(),
        svo_file(0, [1; 3], 1, 1, &[child(1), LEAF], &[0]),
    ));
    // A chain one level deeper than the tree: the walk must stop at depth.
    let chain: Vec<u32> = (1..=4).map(child).chain([LEAF]).collect();
    out.push((
        "synthetic-chain-too-deep".into(),
        svo_file(3, [8; 3], 1, 1, &chain, &[0]),
    ));
    let chain: Vec<u32> = (1..=3).map(child).chain([LEAF]).collect();
    out.push((
        "synthetic-chain".into(),
        svo_file(3, [8; 3], 1, 1, &chain, &[0]),
    ));
    out.push((
        "synthetic-self-loop".into(),
        svo_file(3, [8; 3], 1, 1, &[child(0)], &[]),
    ));
    // Hostile: one to three bytes after the magic replaced, checksum fixed
    // (as src/svo/mod.rs's own test), so the structure, not the CRC, must
    // refuse them; some survive and must answer as Rust does.
    for i in 0..240u64 {
        let mut b = good.to_vec();
        for j in 0..(1 + i % 3) {
            let h = hash2(0x0BAD_5EED ^ i, j);
            let at = 8 + (h as usize % (len - 12));
            b[at] = (h >> 32) as u8;
        }
        out.push((format!("hostile-{i}"), fixed(b)));
    }
    out
}

/// Damaged variants of the `lightfield.bin` image `good` (see [`svo_variants`]).
fn light_field_variants(good: &[u8]) -> Vec<(String, Vec<u8>)> {
    let mut out: Vec<(String, Vec<u8>)> = Vec::new();
    let len = good.len();
    for cut in [0, 8, 30, 67, 68, 100, len / 2, len - 4, len - 1] {
        out.push((format!("truncated-{cut}"), good[..cut].to_vec()));
    }
    let mut longer = good.to_vec();
    longer.push(0);
    out.push(("longer".into(), fixed(longer)));
    let mut magic = good.to_vec();
    magic[..8].copy_from_slice(format::MAGIC);
    out.push(("magic-of-svo".into(), magic));
    for at in (8..64).step_by(4) {
        let mut b = good.to_vec();
        b[at] ^= 0x20;
        out.push((format!("flipped-{at}"), b));
    }
    let (p, n, levels, m) = (
        word(good, 12),
        word(good, 16),
        word(good, 20),
        word(good, 24),
    );
    for (name, at, w) in [
        ("version-0", 8, 0),
        ("version-2", 8, 2),
        ("probes-more", 12, p + 1),
        ("probes-zero", 12, 0),
        ("side-three", 16, 3),
        ("side-zero", 16, 0),
        ("side-huge", 16, 1 << 15),
        ("side-halved", 16, n / 2),
        ("irradiance-six", 24, 6),
        ("irradiance-zero", 24, 0),
        ("irradiance-huge", 24, 1 << 15),
        ("levels-more", 20, levels + 1),
        ("levels-less", 20, levels - 1),
        ("irradiance-doubled", 24, 2 * m),
        // Fields the reader does not check: accepted.
        ("max-distance-nan", 28, f32::NAN.to_bits()),
        ("provenance", 40, 0x0BAD_F00D),
        ("first-radiance", 64 + 12 * p as usize, 0x3C00_3C00),
    ] {
        out.push((name.into(), with_word(good, at, w)));
    }
    for (name, at) in [
        ("position-flipped", 70),
        ("map-flipped", len / 2),
        ("crc-flipped", len - 1),
    ] {
        let mut b = good.to_vec();
        b[at] ^= 2;
        out.push((name.into(), b));
    }
    out
}

/// Damaged and hand-made `probes.json` texts, from `good` (a real one).
fn probes_variants(good: &[u8]) -> Vec<(String, Vec<u8>)> {
    let mut out: Vec<(String, Vec<u8>)> = [
        ("empty", ""),
        ("not-json", "{"),
        ("nan", "[[0, NaN, 1]]"),
        ("bare-empty", "[]"),
        ("no-format", "{}"),
        ("no-probes", "{\"format\": \"probeplace.probes\", \"version\": 1}"),
        ("probes-not-array", "{\"format\": \"probeplace.probes\", \"version\": 1, \"probes\": 3}"),
        ("a-report", "{\"format\": \"probeplace.report\", \"version\": 1, \"probes\": [[0, 1, 2]]}"),
        ("version-9", "{\"format\": \"probeplace.probes\", \"version\": 9, \"probes\": [[0, 1, 2]]}"),
        ("version-string", "{\"format\": \"probeplace.probes\", \"version\": \"1\", \"probes\": [[0, 1, 2]]}"),
        ("string", "\"probes\""),
        ("two-numbers", "[[0, 1]]"),
        ("four-numbers", "[[0, 1, 2, 3]]"),
        ("a-string-among-three", "[[0, \"x\", 2]]"),
        ("no-position", "{\"format\": \"probeplace.probes\", \"version\": 1, \"probes\": [{\"cluster_size\": 3}]}"),
        ("position-object", "{\"format\": \"probeplace.probes\", \"version\": 1, \"probes\": [{\"position\": {\"x\": 1}}]}"),
        ("overflow", "[[0, 0, 1e999]]"),
        // Accepted: Rust's reader keeps the numbers among the entries.
        ("bare", "[[0, 1, 2], [3.5, -4, 5e3]]"),
        ("a-string-among-four", "[[0, \"x\", 1, 2]]"),
        ("clusters", "{\"format\": \"probeplace.probes\", \"version\": 1, \"probes\": [{\"position\": [1, 2, 3], \"cluster_size\": 7}, {\"position\": [1, 2, 4], \"cluster_size\": -1}, {\"position\": [0, 0, 0], \"cluster_size\": 99999999999}]}"),
    ]
    .into_iter()
    .map(|(name, text)| (name.to_string(), text.as_bytes().to_vec()))
    .collect();
    out.push(("truncated".into(), good[..good.len() / 2].to_vec()));
    out.push((
        "not-utf8".into(),
        [&good[..10], &[0xFF, 0xFE], &good[10..]].concat(),
    ));
    out
}

/// Every file Rust refuses, Python and C refuse too, with Rust's reasons
/// (Python: the same message; C: the error code for it), and every file it
/// accepts they accept and answer alike. ASan and UBSan watch the C reader
/// throughout.
#[test]
fn damaged_files_are_refused_by_every_reader() {
    let test = "readers::damaged_files_are_refused_by_every_reader";
    let (place, svo) = placed("configs/cornell.ron");
    let bake = shared_job("bake", "configs/cornell.ron", &[]);
    let cases = tempfile::tempdir().unwrap();
    let dir = cases.path();
    let points = query_points(&svo, 2000, 0x0DA3_A6ED);
    let pts = dir.join("points.f32");
    write_points(&pts, &points);
    let mut entries: Vec<Value> = Vec::new();
    let mut c_list = String::new();
    let (mut refused, mut accepted) = (0, 0);

    let good = std::fs::read(place.dir.join("svo.bin")).unwrap();
    for (name, bytes) in svo_variants(&good) {
        let path = dir.join(format!("svo-{name}.bin"));
        std::fs::write(&path, &bytes).unwrap();
        let mut entry = json!({"kind": "svo", "name": name, "path": path, "points": pts});
        match Svo::read(&path) {
            Ok(tree) => {
                let answers = dir.join(format!("svo-{name}.answers"));
                write_answers(&answers, &tree, &points);
                entry["answers"] = json!(answers);
                c_list += &format!("{}\t{}\n", path.display(), answers.display());
                accepted += 1;
            }
            Err(e) => {
                entry["error"] = json!(e.to_string());
                c_list += &format!("{}\n", path.display());
                refused += 1;
            }
        }
        if let Some((_, want)) = SVO_EXPECTED.iter().find(|(n, _)| *n == name) {
            let got = entry["error"].as_str().unwrap_or("accepted");
            assert!(
                got.contains(want),
                "svo {name}: expected {want:?}, Rust says {got:?}"
            );
        }
        entries.push(entry);
    }
    for (name, _) in SVO_EXPECTED {
        assert!(
            entries.iter().any(|e| e["name"] == *name),
            "no variant {name}"
        );
    }
    let field_good = std::fs::read(bake.dir.join("lightfield.bin")).unwrap();
    // The C reader blends on every light field it accepts, as Rust does.
    let bake_svo_path = bake.dir.join("svo.bin");
    let bake_svo = Svo::read(&bake_svo_path).unwrap();
    let good_field = LightField::read(&bake.dir.join("lightfield.bin")).unwrap();
    let (blend_points, blend_normals) = blend_queries(&good_field, 300, 0x0DA3_B1E4);
    let blend_files = [dir.join("blend-points.f32"), dir.join("blend-normals.f32")];
    write_points(&blend_files[0], &blend_points);
    write_points(&blend_files[1], &blend_normals);
    let mut c_fields = String::new();
    for (name, bytes) in light_field_variants(&field_good) {
        let path = dir.join(format!("lightfield-{name}.bin"));
        std::fs::write(&path, &bytes).unwrap();
        let mut entry = json!({"kind": "lightfield", "name": name, "path": path});
        match LightField::read(&path) {
            Ok(field) => {
                let dump = dir.join(format!("lightfield-{name}.f32"));
                entry["field"] = field_entry(&name, &path, &field, &dump);
                let answers = dir.join(format!("lightfield-{name}.blend"));
                let terms = field.positions.len();
                let selection = Selection::Svo(&bake_svo);
                let (p, n) = (&blend_points, &blend_normals);
                write_blend_answers(&answers, &field, &selection, terms, p, n);
                c_fields += &format!(
                    "{}\t{}\t{}\n",
                    path.display(),
                    bake_svo_path.display(),
                    answers.display()
                );
                accepted += 1;
            }
            Err(e) => {
                entry["error"] = json!(e.to_string());
                c_fields += &format!("{}\n", path.display());
                refused += 1;
            }
        }
        entries.push(entry);
    }
    let probes_good = std::fs::read(place.dir.join("probes.json")).unwrap();
    for (name, bytes) in probes_variants(&probes_good) {
        let path = dir.join(format!("probes-{name}.json"));
        std::fs::write(&path, &bytes).unwrap();
        let mut entry = json!({"kind": "probes", "name": name, "path": path});
        match probeplace::placement::file::read_world(&path) {
            Ok(world) => {
                let flat: Vec<f64> = world.iter().flat_map(|(p, _)| p.to_array()).collect();
                entry["positions"] = json!(flat);
                entry["cluster_size"] = json!(world.iter().map(|w| w.1).collect::<Vec<_>>());
                accepted += 1;
            }
            Err(e) => {
                // serde_json's and Python's parse errors differ in words.
                let message = e.to_string();
                entry["exact"] = json!(!message.contains(": not JSON: "));
                entry["error"] = json!(message);
                refused += 1;
            }
        }
        entries.push(entry);
    }
    for (name, dir) in run_variants(dir, &place.dir, &bake.dir) {
        let mut entry = json!({"kind": "run", "name": name, "path": dir});
        match probeplace::jobs::inspect(&dir) {
            Ok(_) => accepted += 1,
            Err(e) => {
                entry["error"] = json!(e.to_string());
                refused += 1;
            }
        }
        entries.push(entry);
    }
    eprintln!("{test}: {refused} damaged files refused by Rust, {accepted} accepted");
    assert!(
        refused >= 100 && accepted >= 10,
        "{refused} refused, {accepted} accepted"
    );

    if let Some(exe) = c_program(test) {
        let list = dir.join("c-cases.txt");
        std::fs::write(&list, &c_list).unwrap();
        let out = run_c(exe, &[Path::new("check"), &list, &pts]);
        assert_c_codes(&out, &entries, "svo", c_code);
        let list = dir.join("c-lightfields.txt");
        std::fs::write(&list, &c_fields).unwrap();
        let args = [
            Path::new("check-lightfield"),
            &list,
            &blend_files[0],
            &blend_files[1],
        ];
        let out = run_c(exe, &args);
        assert_c_codes(&out, &entries, "lightfield", c_field_code);
    }
    if python(test) {
        let expected = entries
            .iter()
            .map(|e| {
                format!(
                    "damaged:{}:{}",
                    e["kind"].as_str().unwrap(),
                    e["name"].as_str().unwrap()
                )
            })
            .collect();
        pytest(dir, json!({ "damaged": entries }), expected);
    }
}

/// The C error code for a reason `lightfield::format::from_bytes` gives.
/// Checks the C checker's output `out` (a `path\tCODE` line per file)
/// against every entry of kind `kind`: the code `code_of` gives Rust's
/// reason (without the path), or `PP_OK` where Rust read the file.
fn assert_c_codes(out: &str, entries: &[Value], kind: &str, code_of: fn(&str) -> &'static str) {
    let codes: std::collections::BTreeMap<&str, &str> =
        out.lines().filter_map(|l| l.split_once('\t')).collect();
    for e in entries.iter().filter(|e| e["kind"] == kind) {
        let path = e["path"].as_str().unwrap();
        let code = codes
            .get(path)
            .unwrap_or_else(|| panic!("C said nothing of {path}: {out}"));
        let want = match e["error"].as_str() {
            None => "PP_OK",
            Some(message) => code_of(message.strip_prefix(&format!("{path}: ")).unwrap()),
        };
        assert_eq!(*code, want, "{}: {}", e["name"], e["error"]);
    }
}

fn c_field_code(reason: &str) -> &'static str {
    let table = [
        ("truncated", "PP_ERR_TRUNCATED"),
        ("bad magic", "PP_ERR_NOT_LIGHTFIELD"),
        ("this build reads version", "PP_ERR_VERSION"),
        ("must be powers of two", "PP_ERR_MAP_SIDE"),
        ("pyramid levels for side", "PP_ERR_LEVELS"),
        ("where the header implies", "PP_ERR_LENGTH"),
        ("checksum mismatch", "PP_ERR_CHECKSUM"),
    ];
    table
        .iter()
        .find(|(needle, _)| reason.contains(needle))
        .unwrap_or_else(|| panic!("no C code for {reason:?}"))
        .1
}

/// The C error code for a reason `format::from_bytes` gives.
fn c_code(reason: &str) -> &'static str {
    let table = [
        ("not a probeplace SVO", "PP_ERR_NOT_SVO"),
        ("truncated", "PP_ERR_TRUNCATED"),
        ("unsupported version", "PP_ERR_VERSION"),
        ("corrupted: the checksum", "PP_ERR_CHECKSUM"),
        ("corrupted: the origin", "PP_ERR_ORIGIN"),
        ("corrupted: leaf size", "PP_ERR_LEAF_SIZE"),
        ("corrupted: depth", "PP_ERR_DEPTH"),
        ("leaves do not fit a root", "PP_ERR_DIMS"),
        ("leaves are more than", "PP_ERR_TOO_MANY_LEAVES"),
        ("probes per leaf is outside", "PP_ERR_MAX_PROBES"),
        ("there is no root", "PP_ERR_NO_ROOT"),
        ("corrupted: probe index", "PP_ERR_PROBE_INDEX"),
        ("lists beyond the payload", "PP_ERR_LEAF_LIST"),
        ("has no parent", "PP_ERR_ORPHAN_NODE"),
        ("has no child", "PP_ERR_EMPTY_INNER"),
        ("below the leaf level", "PP_ERR_BELOW_LEAF_LEVEL"),
        ("points outside the node array", "PP_ERR_CHILD_INDEX"),
        ("shares a child", "PP_ERR_SHARED_CHILD"),
        ("bytes, but its header announces", "PP_ERR_TOO_LONG"),
    ];
    // "truncated: … announces" is the short file; "corrupted: … announces" the long one.
    if reason.starts_with("corrupted: ") && reason.contains("bytes, but its header announces") {
        return "PP_ERR_TOO_LONG";
    }
    table
        .iter()
        .find(|(needle, _)| reason.contains(needle))
        .unwrap_or_else(|| panic!("no C code for {reason:?}"))
        .1
}

/// Output directories that are not one whole run, made from copies of the
/// `place` run `place` and the `bake` run `bake` under `dir`; and the two
/// intact, which every reader accepts.
fn run_variants(dir: &Path, place: &Path, bake: &Path) -> Vec<(String, PathBuf)> {
    let mut out = Vec::new();
    let mut copy = |name: &str, from: &Path, edit: &dyn Fn(&Path)| {
        let to = dir.join(format!("run-{name}"));
        copy_dir(from, &to);
        edit(&to);
        out.push((name.to_string(), to));
    };
    copy("place", place, &|_| {});
    copy("bake", bake, &|_| {});
    copy("no-svo", place, &|d| {
        std::fs::remove_file(d.join("svo.bin")).unwrap()
    });
    copy("no-probes", place, &|d| {
        std::fs::remove_file(d.join("probes.json")).unwrap()
    });
    copy("bake-without-light-field", bake, &|d| {
        std::fs::remove_file(d.join("lightfield.bin")).unwrap()
    });
    copy("probes-of-another-run", place, &|d| {
        edit_json(&d.join("probes.json"), &|v| {
            v["provenance"]["seed"] = json!(77)
        })
    });
    copy("report-of-another-run", bake, &|d| {
        edit_json(&d.join("report.json"), &|v| {
            v["provenance"]["config_hash"] = json!("0123456789abcdef")
        })
    });
    copy("one-probe-less", place, &|d| {
        edit_json(&d.join("probes.json"), &|v| {
            v["probes"].as_array_mut().unwrap().pop();
        })
    });
    copy("light-field-of-another-run", bake, &|d| {
        let path = d.join("lightfield.bin");
        let b = std::fs::read(&path).unwrap();
        std::fs::write(&path, with_word(&b, 32, word(&b, 32) ^ 1)).unwrap();
    });
    out
}

/// Rewrites the JSON file at `path` through `edit`.
fn edit_json(path: &Path, edit: &dyn Fn(&mut Value)) {
    let mut v = read_json(path);
    edit(&mut v);
    std::fs::write(path, serde_json::to_vec_pretty(&v).unwrap()).unwrap();
}

/// Rust's read bound is half the memory available: capped here, so that
/// the table's oversize file (64 GiB and a byte) is over it on any
/// machine, as it is over the Python and C readers' 64 GiB.
const MEMORY: (&str, &str) = ("PROBEPLACE_MEMORY", "8G");

/// Seconds a C reader may take over the shared table's cases.
const C_SECONDS: u64 = 30;

/// Builds case `case` of tests/cases/readers.json in `dir` from the shared
/// runs `place` and `bake`: a copy of the case's run with its `make` done
/// to its `file`. Returns the directory.
fn build_case(case: &Value, dir: &Path, place: &Path, bake: &Path) -> PathBuf {
    let name = case["name"].as_str().unwrap();
    let (run, other) = match case["run"].as_str().unwrap() {
        "place" => (place, bake),
        "bake" => (bake, place),
        r => panic!("{name}: no run {r}"),
    };
    let to = dir.join(name);
    copy_dir(run, &to);
    let file = case["file"].as_str().unwrap();
    let path = to.join(file);
    let gone = || std::fs::remove_file(&path).unwrap();
    match case["make"].as_str().unwrap() {
        "nothing" => {}
        "fifo" => {
            gone();
            let c = std::ffi::CString::new(path.to_str().unwrap()).unwrap();
            // SAFETY: a valid NUL-terminated path.
            assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o600) }, 0);
        }
        "zero" => {
            gone();
            std::os::unix::fs::symlink("/dev/zero", &path).unwrap();
        }
        "dir" => {
            gone();
            std::fs::create_dir(&path).unwrap();
        }
        "truncate" => {
            let b = std::fs::read(&path).unwrap();
            std::fs::write(&path, &b[..b.len() / 2]).unwrap();
        }
        "oversize" => {
            // Sparse: nothing of it is on disk, and no reader may read it.
            let f = std::fs::OpenOptions::new().write(true).open(&path).unwrap();
            f.set_len((1 << 36) + 1).unwrap();
        }
        "edit" => edit_json(&path, &|v| {
            let x = &mut v["probes"][0]["position"][0];
            *x = json!(x.as_f64().unwrap() + 0.125);
        }),
        "remove" => gone(),
        "foreign" => {
            let from = other.join(file);
            assert!(from.is_file(), "{name}: the other run has no {file}");
            std::fs::copy(from, &path).unwrap();
        }
        "link" => {
            let outside = dir.join(format!("{name}-{file}"));
            std::fs::rename(&path, &outside).unwrap();
            std::os::unix::fs::symlink(&outside, &path).unwrap();
        }
        "manifest-version" => edit_json(&path, &|v| v["version"] = json!(2)),
        "manifest-run" => edit_json(&path, &|v| {
            let seed = v["provenance"]["seed"].as_u64().unwrap();
            v["provenance"]["seed"] = json!(seed + 1);
        }),
        m => panic!("{name}: no make {m}"),
    }
    to
}

/// tests/cases/readers.json: hostile and damaged output directories (a
/// FIFO, /dev/zero, a directory, a truncated or an oversize file, an
/// edited probes.json, a missing manifest, another run's reference EXR…),
/// each refused by every reader with the expected words (C: the expected
/// code) or accepted, as the table says. Every reader runs under a
/// timeout: a blocking open or an endless read fails the test.
#[test]
fn a_shared_table_of_hostile_runs_is_refused_alike_by_every_reader() {
    let test = "readers::a_shared_table_of_hostile_runs_is_refused_alike_by_every_reader";
    let table = read_json(&root().join("tests/cases/readers.json"));
    let cases = table["cases"].as_array().unwrap();
    let place = shared_job("place", "configs/cornell.ron", &[]);
    let bake = shared_job("bake", "configs/cornell.ron", &[]);
    let scratch = tempfile::tempdir().unwrap();
    let dir = scratch.path();
    let mut py = Vec::new();
    let mut c_paths: [(&str, Vec<(PathBuf, String)>); 2] =
        [("svo", vec![]), ("lightfield", vec![])];
    for case in cases {
        let name = case["name"].as_str().unwrap();
        let run = build_case(case, dir, &place.dir, &bake.dir);
        let expect = &case["expect"];
        let rel = run.strip_prefix(dir).unwrap().to_str().unwrap();
        let want = expect["rust"].as_str().unwrap();
        if want == "accepted" {
            let o = Command::new("timeout")
                .args(["--signal=KILL", &REFUSAL_SECONDS.to_string()])
                .arg(env!("CARGO_BIN_EXE_probeplace"))
                .args(["inspect", rel])
                .env(MEMORY.0, MEMORY.1)
                .current_dir(dir)
                .output()
                .unwrap();
            assert!(
                o.status.success(),
                "{name}: inspect refused: {}",
                String::from_utf8_lossy(&o.stderr)
            );
        } else {
            let r = refused_in(dir, &["inspect", rel], &[MEMORY]);
            assert!(
                r.line.starts_with(&format!("error: {rel}/")) && r.line.contains(want),
                "{name}: Rust says {:?}, not {want:?}",
                r.line
            );
        }
        if let Some(want) = expect["python"].as_str() {
            py.push(json!({"name": name, "dir": run, "expect": want}));
        }
        if let Some(code) = expect["c"].as_str() {
            let file = case["file"].as_str().unwrap();
            let kind = if file == "svo.bin" { 0 } else { 1 };
            assert!(
                file == "svo.bin" || file == "lightfield.bin",
                "{name}: C reads {file}?"
            );
            c_paths[kind].1.push((run.join(file), code.to_string()));
        }
    }
    eprintln!("{test}: Rust: {} cases as the table says", cases.len());
    if let Some(exe) = c_program(test) {
        for (kind, paths) in &c_paths {
            let start = std::time::Instant::now();
            let o = Command::new("timeout")
                .args(["--signal=KILL", &C_SECONDS.to_string()])
                .arg(exe)
                .args(["open", kind])
                .args(paths.iter().map(|p| &p.0))
                .env("ASAN_OPTIONS", "abort_on_error=0:halt_on_error=1")
                .env("UBSAN_OPTIONS", "halt_on_error=1:print_stacktrace=1")
                .output()
                .unwrap();
            let out = String::from_utf8_lossy(&o.stdout).into_owned();
            assert!(
                o.status.success(),
                "C reader ({kind}) failed or was killed after {C_SECONDS} s ({:?}): {out}\n{}",
                o.status,
                String::from_utf8_lossy(&o.stderr)
            );
            let codes: std::collections::BTreeMap<&str, &str> =
                out.lines().filter_map(|l| l.split_once('\t')).collect();
            for (path, want) in paths {
                let got = codes.get(path.to_str().unwrap());
                assert_eq!(got, Some(&want.as_str()), "C on {path:?}: {out}");
            }
            eprintln!(
                "{test}: C {kind}: {} cases, {:.2} s",
                paths.len(),
                start.elapsed().as_secs_f64()
            );
        }
    }
    if python(test) {
        let expected = py
            .iter()
            .map(|c| format!("table:{}", c["name"].as_str().unwrap()))
            .collect();
        pytest(dir, json!({ "table": py }), expected);
    }
}
