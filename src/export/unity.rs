//! `probes.unity.json`: the probes as the Unity importer
//! (`integrations/unity/ProbeplaceImporter.cs`) reads them into a
//! `LightProbeGroup`.
//!
//! Unity's `JsonUtility` reads only what maps onto a `[Serializable]`
//! class: no nulls, no nested arrays, no 64-bit unsigned numbers. So this
//! file is flat: strings, two whole numbers and two arrays of floats,
//! `positions`, three per probe in `probes.json` order, and `sh`, each
//! probe's `SphericalHarmonicsL2` (27 floats) after a bake, empty before. Its schema is
//! `integrations/unity/probes.unity.schema.json`, and the importer's class
//! declares the same fields (tests/it/export.rs checks both).
//!
//! The positions stay in world coordinates (right-handed, +Y up); the
//! importer converts them to Unity's left-handed frame by negating x, as
//! Unity's own OBJ, FBX and glTF importers do, so the probes land on a
//! scene imported into Unity from its OBJ or from `probes.glb`.

use super::format::Format;
use super::source::Source;
use serde_json::json;

/// The `format` the importer checks.
pub const FORMAT: &str = "probeplace.unity";

/// `probes.unity.json`.
pub struct Unity;

impl Format for Unity {
    const WORD: &'static str = "unity";
    const FILE: &'static str = "probes.unity.json";
    const ABOUT: &'static str =
        "the flat probe list the Unity importer (integrations/unity) reads into a `LightProbeGroup`";

    fn encode(source: &Source, _: Option<&crate::scene::Scene>) -> Result<Vec<u8>, String> {
        Ok(encode(source))
    }
}

/// `probes.unity.json` of `source`.
pub fn encode(source: &Source) -> Vec<u8> {
    let p = &source.provenance;
    let positions: Vec<f64> = source.probes.iter().flat_map(|q| q.position).collect();
    // Each probe's SphericalHarmonicsL2, channel by channel, in Unity's
    // convention and frame ([`crate::diffuse::ShL2::unity_coefficients`]); empty before a
    // bake (JsonUtility has no null).
    let sh: Vec<f32> = source
        .light
        .iter()
        .flatten()
        .flat_map(|l| l.sh.baked.unity_coefficients().into_iter().flatten())
        .collect();
    crate::encode::json::json_tables(
        &json!({
            "format": FORMAT,
            "version": 1,
            "tool": p.tool,
            "config_hash": p.config_hash,
            "scene_hash": p.scene_hash,
            // A string: JsonUtility has no unsigned 64-bit field.
            "seed": p.seed.to_string(),
            "method": source.method,
            "frame": "world: right-handed, +Y up; Unity (left-handed) = (-x, y, z)",
            "count": source.probes.len(),
            "sh_convention": format!(
                "SphericalHarmonicsL2[channel, coefficient]: 27 floats a probe, r0..r8 g0..g8 b0..b8, in Unity's frame (x negated) and convention (irradiance over pi, basis constants folded in), for LightProbes.bakedProbes; empty before a bake. {}",
                crate::report::sh::holds(source.direct_included)
            ),
            "positions": positions,
            "sh": sh,
        }),
        &[("positions", 3), ("sh", 27)],
    )
}
