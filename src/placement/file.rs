//! Probe sets read from a file: a `probes.json` an earlier run wrote
//! (`--from DIR`), or one made elsewhere (hand-placed, another tool;
//! `--probes FILE.json`) to be scored like any placement.
//!
//! Accepted: an object with a `probes` array whose entries have a
//! `position` of three numbers (world coordinates, as `probes.json` writes
//! them, docs/formats.md), optionally `cluster_size`; or a bare array of
//! `[x, y, z]`. Reading a `probes.json` back gives the positions the run
//! placed, bit for bit: the file holds `origin + p` in f64 for a scene-local
//! f32 `p`, and `(world − origin)` rounded to f32 recovers `p`.

use super::{Probe, ProbeSet};
use crate::error::{Error, Result};
use crate::scene::Scene;
use glam::DVec3;
use serde_json::Value;
use std::collections::BTreeMap;
use std::path::Path;

/// Most probes a file may hold: far beyond any placement, small enough
/// that the later stages stay within memory.
pub const MAX_PROBES: usize = 1 << 20;

/// The probe set in `path` for `scene`, named `method` in reports.
///
/// Contract: a missing or malformed file, a position that is not three
/// finite numbers, no probe at all, or more than [`MAX_PROBES`] is a user
/// error naming the file (and the entry).
pub fn read(path: &Path, scene: &Scene, method: &str) -> Result<ProbeSet> {
    from_world(&read_world(path)?, path, scene, method)
}

/// [`read`] of probes already read from `path` by [`read_world`]: their
/// world positions taken to `scene`'s coordinates.
///
/// Contract: as [`read`].
pub fn from_world(
    world: &[(DVec3, u32)],
    path: &Path,
    scene: &Scene,
    method: &str,
) -> Result<ProbeSet> {
    let probes = world
        .iter()
        .enumerate()
        .map(|(i, &(world, cluster_size))| {
            let position = scene.to_local(world);
            if !position.is_finite() {
                return Err(Error::user_file(
                    path,
                    format!("probe {i}: the position is not finite"),
                ));
            }
            Ok(Probe {
                position,
                cluster_size,
            })
        })
        .collect::<Result<Vec<_>>>()?;
    Ok(ProbeSet {
        method: method.to_string(),
        probes,
        stats: BTreeMap::new(),
        params: BTreeMap::new(),
        min_clearance: 0.0,
        fixed: 0,
    })
}

/// The `format` of a `probes.json` ([`crate::report`] writes it).
const PROBES_FORMAT: &str = "probeplace.probes";

/// The probes of `path` in world coordinates, with their cluster sizes (0
/// where the file has none), in file order: what a renderer loads beside
/// `svo.bin` and `lightfield.bin`, whose indices refer to this order.
///
/// Contract: as [`read`], without a scene.
pub fn read_world(path: &Path) -> Result<Vec<(DVec3, u32)>> {
    let bytes =
        std::fs::read(path).map_err(|e| Error::user_file(path, format!("cannot read: {e}")))?;
    parse_world(&bytes, path)
}

/// [`read_world`] of the contents `bytes` of a file named `path` (used
/// only in messages): the reader without the file system, as the fuzz
/// harness (`fuzz/harness.rs`) calls it.
///
/// Contract: as [`read_world`]; never a panic, whatever the bytes.
pub fn parse_world(bytes: &[u8], path: &Path) -> Result<Vec<(DVec3, u32)>> {
    let value: Value = serde_json::from_slice(bytes)
        .map_err(|e| Error::user_file(path, format!("not JSON: {e}")))?;
    let entries = match &value {
        Value::Array(a) => a,
        Value::Object(o) => {
            // Our own format, strictly: a report, a world index or a file
            // of another version read as probes would place the wrong set.
            let format = o.get("format").and_then(Value::as_str);
            if format != Some(PROBES_FORMAT) {
                return Err(Error::user_file(
                    path,
                    match format {
                        Some(f) => format!(
                            "is a `{f}` file, not `{PROBES_FORMAT}` (or a bare array of [x, y, z])"
                        ),
                        None => format!(
                            "has no `format`: expected `{PROBES_FORMAT}` (or a bare array of [x, y, z])"
                        ),
                    },
                ));
            }
            let version = o.get("version").and_then(Value::as_u64);
            if version != Some(crate::report::FORMAT_VERSION as u64) {
                return Err(Error::user_file(
                    path,
                    format!(
                        "`{PROBES_FORMAT}` version {}: this build reads version {}",
                        o.get("version")
                            .map_or("(none)".to_string(), |v| v.to_string()),
                        crate::report::FORMAT_VERSION
                    ),
                ));
            }
            match o.get("probes") {
                Some(Value::Array(a)) => a,
                _ => return Err(Error::user_file(path, "has no `probes` array")),
            }
        }
        _ => {
            return Err(Error::user_file(
                path,
                "expected a `probes` object or an array of [x, y, z]",
            ))
        }
    };
    if entries.is_empty() {
        return Err(Error::user_file(path, "holds no probe"));
    }
    if entries.len() > MAX_PROBES {
        return Err(Error::user_file(
            path,
            format!(
                "holds {} probes; at most {MAX_PROBES} are read",
                entries.len()
            ),
        ));
    }
    entries
        .iter()
        .enumerate()
        .map(|(i, e)| {
            let bad = |why: &str| Error::user_file(path, format!("probe {i}: {why}"));
            let (position, cluster) = match e {
                Value::Object(o) => (o.get("position"), o.get("cluster_size")),
                other => (Some(other), None),
            };
            let xyz: Vec<f64> = position
                .and_then(Value::as_array)
                .map(|a| a.iter().filter_map(Value::as_f64).collect())
                .unwrap_or_default();
            let world: [f64; 3] = xyz
                .try_into()
                .map_err(|_| bad("`position` must be three numbers"))?;
            let world = DVec3::from_array(world);
            if !world.is_finite() {
                return Err(bad("the position is not finite"));
            }
            let cluster_size = cluster
                .and_then(Value::as_u64)
                .map_or(0, |c| c.min(u32::MAX as u64) as u32);
            Ok((world, cluster_size))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::testing::room_with_box;

    #[test]
    fn positions_written_as_world_f64_read_back_bit_for_bit() {
        let mut scene = room_with_box();
        scene.origin = DVec3::new(1234.567, -0.1, 98765.4321);
        let local = [
            glam::Vec3::new(0.1, 0.2, 0.3),
            glam::Vec3::new(3.999_999, 1e-7, 2.5),
        ];
        let entries: Vec<Value> = local
            .iter()
            .map(|p| serde_json::json!({"position": scene.to_world(*p).to_array()}))
            .collect();
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("p.json");
        let text = serde_json::to_string(&serde_json::json!({
            "format": "probeplace.probes", "version": 1, "probes": entries
        }))
        .unwrap();
        std::fs::write(&path, text).unwrap();
        let set = read(&path, &scene, "file").unwrap();
        let back: Vec<glam::Vec3> = set.positions();
        assert_eq!(back, local);
    }

    #[test]
    fn a_bad_entry_is_named() {
        let scene = room_with_box();
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("p.json");
        std::fs::write(&path, "[[0,1,2],[0,1]]").unwrap();
        let e = read(&path, &scene, "file").unwrap_err().to_string();
        assert!(e.contains("probe 1"), "{e}");
        std::fs::write(&path, "[]").unwrap();
        assert!(read(&path, &scene, "file").is_err());
    }

    #[test]
    fn only_our_probes_format_at_our_version_is_read() {
        let scene = room_with_box();
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("p.json");
        let probes = serde_json::json!([{"position": [1.0, 1.0, 1.0]}]);
        let cases = [
            (
                serde_json::json!({"format": "probeplace.report", "version": 1, "probes": probes}),
                "probeplace.report",
            ),
            (
                serde_json::json!({"format": "probeplace.probes", "version": 9, "probes": probes}),
                "version 9",
            ),
            (
                serde_json::json!({"format": "probeplace.probes", "probes": probes}),
                "version (none)",
            ),
            (serde_json::json!({"probes": probes}), "no `format`"),
        ];
        for (value, says) in cases {
            std::fs::write(&path, value.to_string()).unwrap();
            let e = read(&path, &scene, "file").unwrap_err().to_string();
            assert!(e.contains("p.json") && e.contains(says), "{value}: {e}");
        }
        let good =
            serde_json::json!({"format": "probeplace.probes", "version": 1, "probes": probes});
        std::fs::write(&path, good.to_string()).unwrap();
        assert_eq!(read(&path, &scene, "file").unwrap().probes.len(), 1);
    }
}
