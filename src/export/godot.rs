//! `probes.tscn`: a Godot 4 text scene (format 3, Godot's "TSCN file
//! format") whose root `Node3D`, `Probes`, holds one `LightmapProbe` per
//! probe. `LightmapGI` bakes light at every `LightmapProbe` of the scene it
//! bakes, and with `generate_probes_subdiv` disabled at those alone, so
//! Godot's dynamic objects are lit from the positions we chose.
//!
//! Each probe node is named `probe N` after its index in `probes.json`
//! and placed by an identity-basis `Transform3D` at its world position;
//! Godot's frame is ours (right-handed, +Y up), so nothing is converted.
//! Its index, clearance, `fixed` (a boolean, on every probe) and
//! influence box ([`super::source::SourceProbe::influence`], an `AABB` of
//! position and size in that same frame, on probes that have one) are kept
//! as node metadata, the run's provenance as the root's. The scene has no resources, so the header has no
//! `load_steps` (the format omits it then).

use super::format::Format;
use super::source::Source;
use std::fmt::Write;

/// `probes.tscn`.
pub struct Tscn;

impl Format for Tscn {
    const WORD: &'static str = "tscn";
    const FILE: &'static str = "probes.tscn";
    const ABOUT: &'static str = "a Godot 4 scene, one `LightmapProbe` per probe";

    fn encode(source: &Source, _: Option<&crate::scene::Scene>) -> Result<Vec<u8>, String> {
        Ok(encode(source).into_bytes())
    }
}

/// `probes.tscn` of `source`.
///
/// Contract: one root node and one `LightmapProbe` child per probe, in
/// order, with unique names; deterministic.
pub fn encode(source: &Source) -> String {
    let p = &source.provenance;
    let mut out = String::from("[gd_scene format=3]\n\n[node name=\"Probes\" type=\"Node3D\"]\n");
    let _ = writeln!(out, "metadata/probeplace_tool = {}", quoted(&p.tool));
    let _ = writeln!(
        out,
        "metadata/probeplace_method = {}",
        quoted(&source.method)
    );
    let _ = writeln!(
        out,
        "metadata/probeplace_config_hash = {}",
        quoted(&p.config_hash)
    );
    let _ = writeln!(
        out,
        "metadata/probeplace_scene_hash = {}",
        quoted(&p.scene_hash)
    );
    let _ = writeln!(out, "metadata/probeplace_seed = {}", p.seed);
    for (i, probe) in source.probes.iter().enumerate() {
        let [x, y, z] = probe.position;
        let _ = write!(
            out,
            "\n[node name=\"probe {i}\" type=\"LightmapProbe\" parent=\".\"]\ntransform = Transform3D(1, 0, 0, 0, 1, 0, 0, 0, 1, {}, {}, {})\nmetadata/index = {i}\n",
            real(x),
            real(y),
            real(z)
        );
        if let Some(c) = probe.clearance {
            let _ = writeln!(out, "metadata/clearance = {}", real(c));
        }
        let _ = writeln!(out, "metadata/fixed = {}", probe.fixed);
        if let Some(b) = &probe.influence {
            let _ = writeln!(
                out,
                "metadata/influence_box = AABB({}, {}, {}, {}, {}, {})",
                real(b.min[0]),
                real(b.min[1]),
                real(b.min[2]),
                real(b.max[0] - b.min[0]),
                real(b.max[1] - b.min[1]),
                real(b.max[2] - b.min[2])
            );
        }
    }
    out
}

/// A Godot string literal.
fn quoted(s: &str) -> String {
    format!("\"{}\"", s.replace('\\', "\\\\").replace('"', "\\\""))
}

/// A finite number as Godot's parser reads it: Rust's shortest round-trip
/// decimal, never in exponent form.
fn real(v: f64) -> String {
    let s = format!("{v}");
    if s.contains('.') || s.contains("inf") || s.contains("NaN") {
        s
    } else {
        format!("{s}.0")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_and_strings_read_back() {
        assert_eq!(real(1.0), "1.0");
        assert_eq!(real(-0.25), "-0.25");
        assert_eq!(real(1e-7).parse::<f64>().unwrap(), 1e-7);
        assert!(!real(1e-7).contains('e'));
        assert_eq!(quoted("a\"b\\c"), "\"a\\\"b\\\\c\"");
    }
}
