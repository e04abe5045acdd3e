//! The fuzz targets on the stable toolchain, for CI: the bodies of
//! `fuzz/harness.rs` (the same functions the cargo-fuzz binaries run) on
//!
//! * every committed input: `fuzz/seeds/TARGET/*`, the regression inputs
//!   `fuzz/regressions/TARGET/*` (minimized crashers of earlier fuzzing,
//!   each once a panic) and the seeds the harness generates;
//! * a built-in mutation loop per target (bit flips, byte insertions and
//!   deletions, interesting words, splices of two inputs), driven by a
//!   fixed-seed PRNG, for a fixed time: [`SECONDS`], or
//!   `PROBEPLACE_FUZZ_SECONDS` when set.
//!
//! Both tests walk [`TARGETS`], so a target added to the harness is
//! replayed and mutated here without a new test.
//!
//! An input that panics is written to `target/fuzz-failures/` and named in
//! the failure; copied to `fuzz/regressions/TARGET/` with the fix, it is
//! replayed from then on. docs/fuzzing.md has the libFuzzer runs.

#[path = "../../fuzz/harness.rs"]
mod harness;

use crate::common::root;
use harness::{Rng, Target, TARGETS};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::PathBuf;
use std::time::{Duration, Instant};

/// Seconds of mutation per target in CI.
const SECONDS: f64 = 2.0;

/// Longest input the mutation loop makes.
const MAX_LEN: usize = 1 << 16;

/// The committed inputs of `name` under `fuzz/DIR/name/`, sorted by name.
fn committed(dir: &str, name: &str) -> Vec<(PathBuf, Vec<u8>)> {
    let dir = root().join("fuzz").join(dir).join(name);
    let Ok(entries) = std::fs::read_dir(&dir) else {
        return Vec::new();
    };
    let mut files: Vec<PathBuf> = entries
        .map(|e| e.unwrap().path())
        .filter(|p| p.is_file())
        .collect();
    files.sort();
    files
        .into_iter()
        .map(|p| {
            let bytes = std::fs::read(&p).unwrap();
            (p, bytes)
        })
        .collect()
}

/// Every input to start from for `name`: committed seeds, regressions and
/// generated seeds.
fn inputs(name: &str) -> Vec<(PathBuf, Vec<u8>)> {
    let mut all = committed("seeds", name);
    all.extend(committed("regressions", name));
    for (t, file, bytes) in harness::generated_seeds() {
        if t == name {
            all.push((PathBuf::from(format!("generated:{file}")), bytes));
        }
    }
    all
}

/// Runs `body` on `data`; on a panic, writes `data` to
/// `target/fuzz-failures/NAME-CRC` and fails naming that file and `what`.
fn check(name: &str, body: Target, data: &[u8], what: &str) {
    if catch_unwind(AssertUnwindSafe(|| body(data))).is_ok() {
        return;
    }
    let dir = root().join("target/fuzz-failures");
    std::fs::create_dir_all(&dir).unwrap();
    let crc = probeplace::svo::format::crc32(data);
    let file = dir.join(format!("{name}-{crc:08x}"));
    std::fs::write(&file, data).unwrap();
    panic!(
        "fuzz target {name} panicked on {what} ({} bytes, written to {})",
        data.len(),
        file.display()
    );
}

/// Every committed and generated input of every target, once.
#[test]
fn replay() {
    for &(name, body) in TARGETS {
        let inputs = inputs(name);
        assert!(!inputs.is_empty(), "{name} has no seed");
        for (path, data) in &inputs {
            check(name, body, data, &path.display().to_string());
        }
    }
}

/// Every generated seed is a valid input, so that the fuzzers start from
/// files the readers accept; the committed seeds are those bytes.
#[test]
fn seeds_are_accepted_and_committed() {
    for (t, file, bytes) in harness::generated_seeds() {
        let ok = match t {
            "svo" => probeplace::svo::format::from_bytes(&bytes).is_ok(),
            "lightfield" => probeplace::lightfield::format::from_bytes(&bytes).is_ok(),
            "probes" => probeplace::placement::file::parse_world(&bytes, "s.json".as_ref()).is_ok(),
            "gltf" => probeplace::scene::gltf::parse(
                &bytes,
                "s.glb".as_ref(),
                1.0,
                Default::default(),
                &mut |_: &str, _: &str| {
                    Err(probeplace::error::Error::User("no external file".into()))
                },
            )
            .is_ok_and(|f| !f.triangles.is_empty()),
            other => panic!("a generated seed for {other}"),
        };
        assert!(ok, "seed {t}/{file} is refused");
        let committed = root().join("fuzz/seeds").join(t).join(&file);
        assert_eq!(
            std::fs::read(&committed).ok().as_deref(),
            Some(&bytes[..]),
            "{} differs from the generated seed: run `cargo test --release -- fuzz::write_seeds --ignored`",
            committed.display()
        );
    }
    let configs = committed("seeds", "config");
    assert!(configs.len() >= 3);
    for (path, text) in configs {
        let text = String::from_utf8(text).unwrap();
        probeplace::config::Config::parse(&text, &path).unwrap();
    }
}

/// Writes the generated seeds to `fuzz/seeds/TARGET/` and copies
/// `configs/*.ron` to `fuzz/seeds/config/`.
#[test]
#[ignore = "writes fuzz/seeds; run by hand after a format change"]
fn write_seeds() {
    for (t, file, bytes) in harness::generated_seeds() {
        let dir = root().join("fuzz/seeds").join(t);
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join(file), bytes).unwrap();
    }
    let dir = root().join("fuzz/seeds/config");
    std::fs::create_dir_all(&dir).unwrap();
    for e in std::fs::read_dir(root().join("configs")).unwrap() {
        let p = e.unwrap().path();
        if p.extension().is_some_and(|x| x == "ron") {
            std::fs::copy(&p, dir.join(p.file_name().unwrap())).unwrap();
        }
    }
}

/// Words a mutation writes over four aligned bytes: the edges of the
/// header fields' ranges and the SVO's node bits.
const INTERESTING: [u32; 14] = [
    0,
    1,
    2,
    7,
    8,
    23,
    24,
    0x7F,
    0xFF,
    1 << 14,
    1 << 28,
    1 << 31,
    0x7FFF_FFFF,
    u32::MAX,
];

/// Text a mutation inserts: RON and JSON punctuation and words.
const TOKENS: [&[u8]; 16] = [
    b"(",
    b")",
    b"[",
    b"]",
    b"{",
    b"}",
    b",",
    b":",
    b"\"",
    b"voxel_size: ",
    b"Auto",
    b"Some(",
    b"1e400",
    b"-0.0",
    b"NaN",
    b"\xC3\xA9",
];

/// One random edit of `data`; `other` is another input to splice from.
fn edit(rng: &mut Rng, data: &mut Vec<u8>, other: &[u8]) {
    match rng.below(9) {
        0 | 1 if !data.is_empty() => {
            let i = rng.below(data.len());
            data[i] ^= 1 << rng.below(8);
        }
        2 if !data.is_empty() => {
            let i = rng.below(data.len());
            data[i] = rng.next() as u8;
        }
        3 => {
            let i = rng.below(data.len() + 1);
            data.insert(i, rng.next() as u8);
        }
        4 if !data.is_empty() => {
            let i = rng.below(data.len());
            let n = (1 + rng.below(8)).min(data.len() - i);
            data.drain(i..i + n);
        }
        5 if data.len() >= 4 => {
            let i = rng.below(data.len() / 4) * 4;
            let w = INTERESTING[rng.below(INTERESTING.len())];
            let w = if rng.below(2) == 0 {
                w
            } else {
                w.wrapping_add(rng.below(3) as u32).wrapping_sub(1)
            };
            data[i..i + 4].copy_from_slice(&w.to_le_bytes());
        }
        6 => {
            let i = rng.below(data.len() + 1);
            let t = TOKENS[rng.below(TOKENS.len())];
            data.splice(i..i, t.iter().copied());
        }
        7 if !other.is_empty() => {
            let cut = rng.below(data.len() + 1);
            let from = rng.below(other.len());
            data.truncate(cut);
            data.extend_from_slice(&other[from..]);
        }
        _ if !data.is_empty() => {
            // Duplicate or drop a chunk of up to 64 bytes.
            let i = rng.below(data.len());
            let n = (1 + rng.below(64)).min(data.len() - i);
            if rng.below(2) == 0 {
                let chunk = data[i..i + n].to_vec();
                data.splice(i..i, chunk);
            } else {
                data.drain(i..i + n);
            }
        }
        _ => data.push(rng.next() as u8),
    }
    data.truncate(MAX_LEN);
}

/// Mutates the inputs of `name` for the fixed time; returns the executions.
fn mutation_loop(name: &str) -> u64 {
    let body = TARGETS.iter().find(|(n, _)| *n == name).unwrap().1;
    let seconds = std::env::var("PROBEPLACE_FUZZ_SECONDS")
        .ok()
        .and_then(|s| s.parse::<f64>().ok())
        .unwrap_or(SECONDS);
    let mut pool: Vec<Vec<u8>> = inputs(name).into_iter().map(|(_, b)| b).collect();
    let seeds = pool.len();
    let mut rng = Rng::new(0x5EED_F022 ^ svo_crc(name.as_bytes()));
    let start = Instant::now();
    let limit = Duration::from_secs_f64(seconds);
    let mut runs = 0u64;
    while start.elapsed() < limit {
        for _ in 0..64 {
            let mut data = pool[rng.below(pool.len())].clone();
            let other = pool[rng.below(pool.len())].clone();
            for _ in 0..1 + rng.below(4) {
                edit(&mut rng, &mut data, &other);
            }
            check(name, body, &data, &format!("mutant {runs}"));
            runs += 1;
            // Keep some mutants to stack further edits on (the seeds stay).
            if rng.below(8) == 0 {
                if pool.len() < seeds + 256 {
                    pool.push(data);
                } else {
                    let i = seeds + rng.below(256);
                    pool[i] = data;
                }
            }
        }
    }
    eprintln!(
        "fuzz::{name}: {runs} mutants in {:.1} s",
        start.elapsed().as_secs_f64()
    );
    runs
}

fn svo_crc(b: &[u8]) -> u64 {
    probeplace::svo::format::crc32(b) as u64
}

/// The mutation loop on every target, [`SECONDS`] each.
#[test]
fn mutate() {
    for &(name, _) in TARGETS {
        assert!(mutation_loop(name) > 0);
    }
}
