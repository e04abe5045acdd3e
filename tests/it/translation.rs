//! Placement does not depend on where the scene sits or in which units its
//! file is written: the Cornell box at the origin, 1 km and 100 km away, and
//! converted from millimetres to metres, gets the same probes, shifted.
//!
//! Before every stage worked relative to the scene's own origin, f32 world
//! coordinates turned the box's 6 probes into 48 at 1 km and 300 at 100 km:
//! the occlusion tests' epsilons (a thousandth of a voxel) fell below one ulp.

use crate::common::*;
use std::path::{Path, PathBuf};

/// One placement of the Cornell box.
struct Case {
    name: &'static str,
    /// Added to every vertex of the millimetre file, in millimetres.
    shift_mm: [f64; 3],
    /// Whether the file is converted to metres (and `scale` set to 1).
    metres: bool,
}

impl Case {
    /// The shift in world units (metres).
    fn shift_m(&self) -> [f64; 3] {
        self.shift_mm.map(|c| c * 1e-3)
    }
}

const CASES: [Case; 4] = [
    Case {
        name: "origin",
        shift_mm: [0.0; 3],
        metres: false,
    },
    Case {
        name: "1km",
        shift_mm: [1e6, 0.3e6, -0.7e6],
        metres: false,
    },
    Case {
        name: "100km",
        shift_mm: [1e8, 0.3e8, -0.7e8],
        metres: false,
    },
    Case {
        name: "metres",
        shift_mm: [0.0; 3],
        metres: true,
    },
];

/// The fixture's OBJ text with every `v x y z` line shifted by `shift_mm`
/// and divided by `divide`, printed with enough decimals that the file holds
/// the shifted coordinates exactly (the fixture has at most four decimals).
fn shifted_obj(obj: &str, shift_mm: [f64; 3], divide: f64) -> String {
    obj.lines()
        .map(|line| match line.strip_prefix("v ") {
            Some(rest) => {
                let v: Vec<f64> = rest
                    .split_whitespace()
                    .map(|c| c.parse().unwrap())
                    .collect();
                assert_eq!(v.len(), 3, "{line}");
                let c: Vec<String> = (0..3)
                    .map(|i| format!("{:.9}", (v[i] + shift_mm[i]) / divide))
                    .collect();
                format!("v {}\n", c.join(" "))
            }
            None => format!("{line}\n"),
        })
        .collect()
}

/// Replaces every `key: (x, y, z)` point of the RON text by itself plus
/// `shift`: config points are world coordinates, so they move with the scene.
fn shift_points(ron: &str, key: &str, shift: [f64; 3]) -> String {
    let pattern = format!("{key}: (");
    let mut out = String::new();
    let mut rest = ron;
    while let Some(at) = rest.find(&pattern) {
        let start = at + pattern.len();
        let end = start + rest[start..].find(')').unwrap();
        let v: Vec<f64> = rest[start..end]
            .split(',')
            .map(|c| c.trim().parse().unwrap())
            .collect();
        assert_eq!(v.len(), 3, "{key} in {ron}");
        out += &rest[..start];
        out += &format!(
            "{:.6}, {:.6}, {:.6}",
            v[0] + shift[0],
            v[1] + shift[1],
            v[2] + shift[2]
        );
        rest = &rest[end..];
    }
    out + rest
}

/// The artist controls of [`controls_place_alike_wherever_the_box_sits`],
/// for the box at the origin (metres): a fixed probe, an exclude box, a
/// budget and a density over the left half; `point` turns a point of the
/// box into the case's world coordinates.
fn controls(point: impl Fn([f64; 3]) -> [f64; 3]) -> Vec<(&'static str, String)> {
    let p = |v: [f64; 3]| {
        let w = point(v);
        format!("({:.6}, {:.6}, {:.6})", w[0], w[1], w[2])
    };
    let region = |lo, hi| format!("Box((min: {}, max: {}))", p(lo), p(hi));
    vec![
        ("fixed_probes", format!("[{}]", p([0.1, 0.45, 0.1]))),
        (
            "exclude",
            format!("[{}]", region([0.3, 0.3, 0.3], [0.5, 0.5, 0.5])),
        ),
        ("max_probes", "6".into()),
        (
            "probe_density",
            format!("[({}, 2.0)]", region([-1.0, -1.0, -1.0], [0.278, 2.0, 2.0])),
        ),
    ]
}

/// Writes `case`'s scene and a config with configs/cornell.ron's fields
/// (scene and scale aside, points shifted with the scene), at test quality,
/// with the [`controls`] when `with_controls`, into `dir`; returns the
/// config's path.
fn write_case(dir: &Path, case: &Case, with_controls: bool) -> PathBuf {
    let fixture = probeplace::fixtures::cornell_box();
    let divide = if case.metres { 1e3 } else { 1.0 };
    let obj = shifted_obj(&fixture.obj, case.shift_mm, divide);
    std::fs::write(dir.join(format!("{}.obj", case.name)), obj).unwrap();
    std::fs::write(dir.join(format!("{}.mtl", fixture.name)), &fixture.mtl).unwrap();

    let original = std::fs::read_to_string(root().join("configs/cornell.ron")).unwrap();
    assert!(original.contains("domain: Auto"), "{original}");
    let scale = if case.metres { "1.0" } else { "0.001" };
    let mut replaced = [false; 2];
    let mut text: String = original
        .lines()
        .map(|line| {
            let key = line.trim_start();
            if key.starts_with("scene:") {
                replaced[0] = true;
                format!("    scene: \"{}.obj\",\n", case.name)
            } else if key.starts_with("scale:") {
                replaced[1] = true;
                format!("    scale: {scale},\n")
            } else {
                format!("{line}\n")
            }
        })
        .collect();
    assert_eq!(
        replaced, [true; 2],
        "configs/cornell.ron lost its scene or scale line"
    );
    for key in ["position", "look_at"] {
        text = shift_points(&text, key, case.shift_m());
    }
    // Invariance holds at any quality: the cases run at test quality.
    let mut quality = test_quality_fields(&text);
    if with_controls {
        let shift = case.shift_m();
        quality.extend(controls(|v| [0, 1, 2].map(|i| v[i] + shift[i])));
    }
    let fields: Vec<(&str, &str)> = quality.iter().map(|(k, v)| (*k, v.as_str())).collect();
    let text = set_ron_fields(&text, &fields);
    let path = dir.join(format!("{}.ron", case.name));
    std::fs::write(&path, text).unwrap();
    path
}

/// A JSON array of three numbers.
fn point(v: &serde_json::Value) -> [f64; 3] {
    serde_json::from_value(v.clone()).unwrap()
}

fn distance(a: [f64; 3], b: [f64; 3]) -> f64 {
    (0..3).map(|i| (a[i] - b[i]).powi(2)).sum::<f64>().sqrt()
}

#[test]
fn cornell_box_places_alike_wherever_it_sits_and_whatever_its_units() {
    let runs = place_cases(false);
    assert!(
        runs[0].0["warnings"].as_array().unwrap().is_empty(),
        "{}",
        runs[0].0
    );
    assert_alike(&runs);
}

/// The artist controls hold wherever the box sits and whatever its units:
/// the fixed probe stands exactly at its (shifted) point, and the rest is
/// the same placement, shifted.
#[test]
fn controls_place_alike_wherever_the_box_sits() {
    let runs = place_cases(true);
    assert_alike(&runs);
    for (case, (report, probes)) in CASES.iter().zip(&runs) {
        let shift = case.shift_m();
        let fixed = [0.1 + shift[0], 0.45 + shift[1], 0.1 + shift[2]];
        let first = &probes["probes"][0];
        assert_eq!(first["fixed"], true, "{}", case.name);
        assert!(
            distance(point(&first["position"]), fixed) < 1e-6,
            "{}: {}",
            case.name,
            first
        );
        assert_eq!(report["controls"], runs[0].0["controls"], "{}", case.name);
    }
    assert!(
        runs[0].0["controls"]["samples_with_density"]
            .as_u64()
            .unwrap()
            > 0
    );
}

/// `place` of every case; its report and probes.json.
fn place_cases(with_controls: bool) -> Vec<(serde_json::Value, serde_json::Value)> {
    let dir = tempfile::tempdir().unwrap();
    CASES
        .iter()
        .map(|case| {
            let config = write_case(dir.path(), case, with_controls);
            let out = dir.path().join(format!("out-{}", case.name));
            let report = place(&config, &out, &[]);
            (report, read_json(&out.join("probes.json")))
        })
        .collect()
}

/// Every case has the origin's probe count, coverage and warnings, and its
/// probes are the origin's, shifted, each matched once.
fn assert_alike(runs: &[(serde_json::Value, serde_json::Value)]) {
    let (first, first_probes) = &runs[0];
    let count = first["probe_count"].as_u64().unwrap();
    assert!(count > 0);
    let originals: Vec<[f64; 3]> = first_probes["probes"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| point(&p["position"]))
        .collect();
    for (case, (report, probes)) in CASES.iter().zip(runs) {
        let name = case.name;
        assert_eq!(report["probe_count"].as_u64().unwrap(), count, "{name}");
        let (a, b) = (
            report["coverage"].as_f64().unwrap(),
            first["coverage"].as_f64().unwrap(),
        );
        assert!((a - b).abs() <= 1e-9, "{name}: coverage {a} against {b}");
        assert_eq!(report["warnings"], first["warnings"], "{name}");

        let shift = case.shift_m();
        let moved = |p: [f64; 3]| [p[0] + shift[0], p[1] + shift[1], p[2] + shift[2]];
        // Bounds are written in world coordinates: the original's, shifted.
        for key in ["min", "max"] {
            let (got, want) = (
                point(&report["scene"]["bounds"][key]),
                moved(point(&first["scene"]["bounds"][key])),
            );
            assert!(
                distance(got, want) < 1e-3,
                "{name}: bounds {got:?} against {want:?}"
            );
        }
        // Every probe is the original's plus the shift, each matched once.
        let mut matched = vec![false; originals.len()];
        for p in probes["probes"].as_array().unwrap() {
            let got = point(&p["position"]);
            let (nearest, d) = originals
                .iter()
                .enumerate()
                .map(|(i, &o)| (i, distance(got, moved(o))))
                .min_by(|x, y| x.1.total_cmp(&y.1))
                .unwrap();
            assert!(
                d < 1e-3,
                "{name}: probe {got:?} is {d} m from the nearest original"
            );
            assert!(
                !matched[nearest],
                "{name}: two probes match original {nearest}"
            );
            matched[nearest] = true;
        }
    }
}
