//! What this machine can do, read at run time, and the checks every stage
//! makes *before* it allocates or loops over a number the user chose.
//!
//! Memory: the budget is half of the memory available when the run starts
//! (`MemAvailable`, the cgroup's `memory.max` less its usage, and the
//! address-space limit `ulimit -v` less what the process already maps,
//! whichever is least), so that a config asking for more is refused in one
//! line naming its field instead of dying in the allocator. Work: each
//! stage estimates its seconds on this machine's threads from measured
//! per-core rates (BENCHMARKS.md, "Limits") and refuses configs whose
//! estimate exceeds [`work_limit_seconds`], so that no accepted config
//! runs for hours. `PROBEPLACE_MEMORY` (bytes, or with a K/M/G suffix)
//! lowers the memory budget; `PROBEPLACE_WORK_LIMIT` (seconds, `0` for
//! none) replaces the work limit.

use crate::error::{Error, Result};
use crate::input::bytes_text;
use std::sync::OnceLock;

/// Most probes a placement may hand to the later stages (refinement,
/// coverage, SVO, bake): 2¹⁶. A grid of 2²⁰ probes took over five minutes
/// in the SVO and coverage stages alone (BENCHMARKS.md, "Limits").
pub const MAX_PROBES: usize = 65_536;

/// Default estimated seconds one stage may take: 5 minutes.
pub const WORK_LIMIT_SECONDS: f64 = 300.0;

/// The bytes this run may allocate in one stage (module docs), read once.
pub fn memory_budget() -> u64 {
    static BUDGET: OnceLock<u64> = OnceLock::new();
    *BUDGET.get_or_init(|| {
        let mut available = [
            meminfo_available(),
            cgroup_available(),
            address_space_available(),
        ]
        .into_iter()
        .flatten()
        .min()
        .unwrap_or(8 << 30)
            / 2;
        if let Some(cap) = std::env::var("PROBEPLACE_MEMORY")
            .ok()
            .and_then(|v| parse_bytes(&v))
        {
            available = available.min(cap);
        }
        available
    })
}

/// The estimated seconds a stage may take (module docs); `f64::INFINITY`
/// when `PROBEPLACE_WORK_LIMIT=0`.
pub fn work_limit_seconds() -> f64 {
    match std::env::var("PROBEPLACE_WORK_LIMIT")
        .ok()
        .and_then(|v| v.trim().parse::<f64>().ok())
    {
        Some(0.0) => f64::INFINITY,
        Some(v) if v > 0.0 => v,
        _ => WORK_LIMIT_SECONDS,
    }
}

/// Refuses (a user error naming `field`) when `bytes` exceed the
/// [`memory_budget`]; `what` says what needs them ("the bake of 4096
/// probes at 512² maps").
pub fn check_memory(field: &str, what: &str, bytes: f64) -> Result<()> {
    let budget = memory_budget();
    if bytes > budget as f64 {
        return Err(Error::User(format!(
            "{field}: {what} needs about {} of memory; this run may use {} (half the memory available{}); lower it",
            bytes_text(bytes.min(u64::MAX as f64) as u64),
            bytes_text(budget),
            if std::env::var_os("PROBEPLACE_MEMORY").is_some() {
                ", capped by PROBEPLACE_MEMORY"
            } else {
                ""
            }
        )));
    }
    Ok(())
}

/// Primitives a ray tests on average in the scenes the [`rate`]s were
/// measured on, times the margin they already allow (twice Dabrovic
/// Sponza's 28.5 by the surface-area heuristic; the Cornell box's is
/// 10.3): a scene whose rays test more is slowed by as much
/// ([`set_ray_tests`]).
pub const RATED_RAY_TESTS: f64 = 64.0;

thread_local! {
    /// [`set_ray_tests`]' factor for the job on this thread.
    static RAY_COST: std::cell::Cell<f64> = const { std::cell::Cell::new(1.0) };
}

/// Records, for the estimates this thread makes from now on, that the
/// scene's rays test `tests` primitives on average
/// ([`crate::scene::raycast::SceneBvh::expected_tests`]). Every stage's
/// rate is then divided by `tests /` [`RATED_RAY_TESTS`] when that is
/// above 1: a pile of overlapping triangles (a mesh instanced thousands
/// of times at nearly one place) makes every ray that reaches it test
/// them all, and the stages that cast rays slow down with it, which the
/// estimates must see before they start, not after hours. Called by the
/// preparation of each job, on the job's thread.
pub fn set_ray_tests(tests: f64) {
    let factor = if tests.is_finite() {
        (tests / RATED_RAY_TESTS).max(1.0)
    } else {
        1.0
    };
    RAY_COST.with(|c| c.set(factor));
}

/// Refuses (a user error naming `field`) when `work` units at `per_core`
/// units per second on each of this run's threads would take longer than
/// [`work_limit_seconds`]; `per_core` is divided by the scene's ray cost
/// ([`set_ray_tests`]).
pub fn check_work(field: &str, what: &str, work: f64, per_core: f64) -> Result<()> {
    let threads = rayon::current_num_threads().max(1) as f64;
    let cost = RAY_COST.with(|c| c.get());
    let seconds = work * cost / (per_core * threads);
    let limit = work_limit_seconds();
    if seconds > limit {
        let why = if cost > 1.0 {
            format!(
                " (the scene's rays each test about {:.0} triangles, {cost:.0}x what the rates assume: overlapping triangles no tree separates, such as copies of a mesh at nearly one place)",
                cost * RATED_RAY_TESTS
            )
        } else {
            String::new()
        };
        return Err(Error::User(format!(
            "{field}: {what} would take about {} on {} thread(s){why}, over the limit of {} (PROBEPLACE_WORK_LIMIT=0 lifts it); lower it",
            duration_text(seconds),
            threads,
            duration_text(limit)
        )));
    }
    Ok(())
}

/// Per-core rates of the stages' inner loops, measured on this project's
/// 2-core VM in release builds (BENCHMARKS.md, "Limits": the runs and
/// commands). Each is taken on the slower of Dabrovic Sponza (66k
/// triangles) and the Cornell box, then halved, so that estimates err
/// towards refusing less than a twice slower scene would need.
pub mod rate {
    /// SDF voxels classified per core-second at 32 rays a voxel (Sponza:
    /// 591k voxels in 2.39 s on 2 threads).
    pub const SDF_VOXELS: f64 = 6.0e4;
    /// SVO leaves ranked per core-second (Sponza: 464k cells, 1.95 s).
    pub const SVO_CELLS: f64 = 6.0e4;
    /// Probe-influence rays of the SVO per core-second (Cornell: 16 384
    /// probes × 32² directions, 4.4 s).
    pub const SVO_PROBE_RAYS: f64 = 1.0e6;
    /// Leaf-probe pairs of the SVO's ranking per core-second: a leaf
    /// filters and bounds every probe whose influence reaches it, so the
    /// octree grows as the leaves the influence regions hold, leaves ×
    /// probes where every region holds the whole domain (Cornell at voxel
    /// 0.02: 21 952 leaves × 65 536 probes, 13.7 s on 2 threads).
    pub const SVO_LEAF_PROBE_PAIRS: f64 = 2.6e7;
    /// Coverage sample-to-viewer segments per core-second (Sponza: 26.8 M
    /// segments, 0.6 s).
    pub const COVERAGE_SEGMENTS: f64 = 1.0e7;
    /// Path vertices (paths × (1 + bounces)) of the probe bake and the
    /// reference per core-second (Sponza: 9.8 M in 9.3 s, and 19.7 M in
    /// 27.3 s).
    pub const PATH_VERTICES: f64 = 1.8e5;
    /// Irradiance and moment convolution terms (probes × irradiance texels
    /// × radiance texels) per core-second (Sponza: 8.4e8 in 2.0 s).
    pub const CONVOLUTION_TERMS: f64 = 1.0e8;
    /// Rays of refinement's views per core-second, eight corners' and a
    /// proposal's per probe step (a 1M-triangle tiled Sponza at half its
    /// `Auto` voxel: 1 227 probes, 6 sweeps, 3 072 rays a step, 7.4 s on 2
    /// threads).
    pub const REFINE_RAYS: f64 = 7.5e5;
    /// Atlas texel updates of refinement per core-second: a step's view
    /// of `directions²` rays times the probes sharing each texel (the
    /// Cornell box: `grid:16x16x1` and `grid:32x32x1`, 256 and 1 024
    /// probes seeing all its 4 216 texels, 20 sweeps, 3.7 s and 32.7 s;
    /// the difference is the sharing, 62 against 248 probes a texel).
    pub const REFINE_TEXEL_UPDATES: f64 = 5.0e7;
    /// Fill-and-prune sample views, `coverage samples × (probes + 16)`,
    /// per core-second (Cornell: 1 M samples, 5 probes, 24 s; not halved,
    /// as the Gibbs term already over-estimates larger sets).
    pub const REFINE_SAMPLE_VIEWS: f64 = 4.4e5;
    /// Views of refinement's filling, pruning and check rounds per
    /// core-second, counting only the sample–probe pairs that face each
    /// other, those that cast a segment: `samples × (probes + 16) × the
    /// facing share` (the Cornell box at 1 M samples, 10 probes, 85% of the
    /// pairs facing: 3.9 s of filling on 2 threads, 2026-12-07; the
    /// 4M-triangle tiled Sponza ran at 1.4 times that rate).
    pub const REFINE_FACING_VIEWS: f64 = 1.45e6;
}

/// Seconds in words: `45 s`, `12 min`, `3.2 h`, `4.1e3 days`.
pub fn duration_text(seconds: f64) -> String {
    if !seconds.is_finite() {
        "forever".into()
    } else if seconds < 120.0 {
        format!("{seconds:.0} s")
    } else if seconds < 7200.0 {
        format!("{:.0} min", seconds / 60.0)
    } else if seconds < 172_800.0 {
        format!("{:.1} h", seconds / 3600.0)
    } else {
        let days = seconds / 86_400.0;
        if days < 1e4 {
            format!("{days:.0} days")
        } else {
            format!("{days:.1e} days")
        }
    }
}

/// `8G`, `512M`, `4096K` or plain bytes.
fn parse_bytes(text: &str) -> Option<u64> {
    let t = text.trim();
    let (digits, shift) = match t.chars().last()? {
        'K' | 'k' => (&t[..t.len() - 1], 10),
        'M' | 'm' => (&t[..t.len() - 1], 20),
        'G' | 'g' => (&t[..t.len() - 1], 30),
        _ => (t, 0),
    };
    digits.trim().parse::<u64>().ok()?.checked_mul(1 << shift)
}

/// `MemAvailable` of /proc/meminfo, in bytes.
fn meminfo_available() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    kib_field(&text, "MemAvailable:")
}

fn kib_field(text: &str, name: &str) -> Option<u64> {
    let line = text.lines().find(|l| l.starts_with(name))?;
    let kib: u64 = line[name.len()..]
        .trim()
        .trim_end_matches("kB")
        .trim()
        .parse()
        .ok()?;
    Some(kib * 1024)
}

/// The cgroup v2 limit less the current usage, when a limit is set.
fn cgroup_available() -> Option<u64> {
    let max = std::fs::read_to_string("/sys/fs/cgroup/memory.max").ok()?;
    let max: u64 = max.trim().parse().ok()?;
    let current: u64 = std::fs::read_to_string("/sys/fs/cgroup/memory.current")
        .ok()?
        .trim()
        .parse()
        .ok()?;
    Some(max.saturating_sub(current))
}

/// `RLIMIT_AS` (what `ulimit -v` sets) less the address space mapped now.
fn address_space_available() -> Option<u64> {
    let mut limit = libc::rlimit {
        rlim_cur: 0,
        rlim_max: 0,
    };
    // SAFETY: getrlimit writes the struct it is given and nothing else.
    if unsafe { libc::getrlimit(libc::RLIMIT_AS, &mut limit) } != 0
        || limit.rlim_cur == libc::RLIM_INFINITY
    {
        return None;
    }
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let mapped = kib_field(&status, "VmSize:").unwrap_or(0);
    Some(limit.rlim_cur.saturating_sub(mapped))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn byte_counts_and_durations_read_as_written() {
        assert_eq!(parse_bytes("8G"), Some(8 << 30));
        assert_eq!(parse_bytes("512 M"), Some(512 << 20));
        assert_eq!(parse_bytes("512M"), Some(512 << 20));
        assert_eq!(parse_bytes("1000"), Some(1000));
        assert_eq!(parse_bytes("x"), None);
        assert_eq!(duration_text(45.0), "45 s");
        assert_eq!(duration_text(900.0), "15 min");
        assert_eq!(duration_text(3.0 * 3600.0), "3.0 h");
        assert_eq!(duration_text(1e12), "1.2e7 days");
    }

    #[test]
    fn the_budget_is_positive_and_checks_refuse_beyond_it() {
        let budget = memory_budget();
        assert!(budget > 0);
        assert!(check_memory("bake.resolution", "x", budget as f64 / 2.0).is_ok());
        let e = check_memory("bake.resolution", "the bake", budget as f64 * 4.0)
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with("bake.resolution: the bake needs about "),
            "{e}"
        );
        let e = check_work("coverage.samples", "coverage", 1e30, 1e6)
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with("coverage.samples: coverage would take about "),
            "{e}"
        );
        assert!(check_work("coverage.samples", "coverage", 1.0, 1e6).is_ok());
    }

    #[test]
    fn proc_fields_parse() {
        assert_eq!(
            kib_field(
                "MemTotal: 10 kB\nMemAvailable:   2048 kB\n",
                "MemAvailable:"
            ),
            Some(2048 * 1024)
        );
    }
}
