//! `sh.json`: each probe's diffuse light as engines store it (`bake`):
//! SH L2 of its incident radiance (`total`: what a mixed-lighting probe
//! holds, every light but the point, spot and directional lights' direct
//! light; and its `indirect` part, reflected at least once), and the
//! path-traced irradiance at the probe along the six axes.
//!
//! The coefficients are plain projections `L_lm = ∫ L Y_lm dω` on the real
//! basis of [`crate::diffuse::sh`] (Sloan 2008, order `Y00, Y1-1 (y),
//! Y10 (z), Y11 (x), Y2-2 (xy), Y2-1 (yz), Y20, Y21 (xz), Y22`), in the
//! run's world frame; the irradiance at normal `n` is `Σ Â_l L_lm Y_lm(n)`
//! with `Â = π, 2π/3, π/4`. The exports convert them to each engine's
//! convention (`crate::export`).

use crate::diffuse::sh::ProbeLight;
use crate::diffuse::sh::ProbeSh;
use crate::diffuse::sh::{ShL2, COEFFICIENTS};
use crate::provenance::Provenance;
use glam::Vec3;
use serde::Deserialize;
use serde_json::json;

/// Which light the SH holds, in the words every export and docs/engines.md
/// use (a test holds them to this): an engine that is not told bakes its
/// lights' direct light nowhere, and dynamic objects go nearly dark.
pub const SH_HOLDS: &str = "The SH holds what a mixed-lighting probe holds: emitters, the sky and every reflection, but no direct light from point, spot or directional lights. Keep those lights Mixed (Baked Indirect) or Realtime, so the engine shades their direct light itself.";

/// [`SH_HOLDS`] for a bake with `bake.sh_direct: Include`.
pub const SH_HOLDS_ALL: &str = "The SH holds all the light at the probe, the direct light of point, spot and directional lights included (bake.sh_direct: Include). Set those lights to Baked, or leave them out of the engine's shading of probe-lit objects, so their direct light is not counted twice.";

/// The sentence of [`SH_HOLDS`] or [`SH_HOLDS_ALL`] that says which
/// light a bake holds: with the delta lights' direct light (`bake.sh_direct:
/// Include`) or without.
pub fn holds(direct_included: bool) -> &'static str {
    if direct_included {
        SH_HOLDS_ALL
    } else {
        SH_HOLDS
    }
}

/// `sh.json`'s `sh_direct`, as `bake.sh_direct` names it (the config's own
/// type is not used here: the exports, which read this file, lie below the
/// config in the module graph).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize, serde::Serialize)]
enum Direct {
    #[default]
    Exclude,
    Include,
}

/// The file's name in an output set.
pub(crate) const SH_FILE: &str = "sh.json";

/// The `format` of `sh.json`.
pub const FORMAT: &str = "probeplace.sh";

/// `sh.json` for `light` (its `total` holding the delta lights' direct
/// light, or not), one entry per probe in `probes.json` order.
pub fn encode(
    provenance: &Provenance,
    rays: u32,
    direct_included: bool,
    light: &[ProbeLight],
) -> Vec<u8> {
    let sh_direct = if direct_included {
        Direct::Include
    } else {
        Direct::Exclude
    };
    let rows =
        |sh: &ShL2| -> Vec<[f32; 3]> { sh.coefficients.iter().map(|c| c.to_array()).collect() };
    let probes: Vec<_> = light
        .iter()
        .map(|l| {
            json!({
                "total": rows(&l.sh.baked),
                "indirect": rows(&l.sh.indirect),
                "irradiance_axes": l.irradiance_axes.map(|e| e.to_array()),
            })
        })
        .collect();
    crate::encode::json::json_rows(
        &json!({
            "format": FORMAT,
            "version": 1,
            "provenance": provenance,
            "basis": "real SH L2 (Sloan 2008): Y00, Y1-1 (y), Y10 (z), Y11 (x), Y2-2 (xy), Y2-1 (yz), Y20 (3z²-1), Y21 (xz), Y22 (x²-y²); coefficients ∫ L Y dω of incident radiance, RGB",
            "frame": "world: right-handed, +Y up",
            "axes": "+x, -x, +y, -y, +z, -z",
            "rays": rays,
            "sh_direct": sh_direct,
            "holds": holds(direct_included),
            "count": light.len(),
            "probes": probes,
        }),
        "probes",
        1,
    )
}

#[derive(Deserialize)]
struct File {
    format: String,
    version: u32,
    provenance: Provenance,
    /// Absent in files written before the option: they excluded it.
    #[serde(default)]
    sh_direct: Direct,
    probes: Vec<ProbeIn>,
}

#[derive(Deserialize)]
struct ProbeIn {
    total: Vec<[f32; 3]>,
    indirect: Vec<[f32; 3]>,
    irradiance_axes: [[f32; 3]; 6],
}

/// The probes' light of `sh.json` bytes, and whether it holds the delta
/// lights' direct light,
/// checked to be of the run of `provenance` (its config and scene hashes)
/// and to hold `probes` probes. The error is the reason alone, led by
/// `sh.json:`.
pub fn decode(
    bytes: &[u8],
    provenance: &Provenance,
    probes: usize,
) -> Result<(Vec<ProbeLight>, bool), String> {
    let f: File = serde_json::from_slice(bytes)
        .map_err(|e| format!("sh.json: not a probeplace SH file: {e}"))?;
    if f.format != FORMAT || f.version != 1 {
        return Err(format!(
            "sh.json: format {:?} version {}, expected {FORMAT:?} version 1",
            f.format, f.version
        ));
    }
    // The run's identity (config and scene hashes), as the binary files
    // carry it: a `bake --from` names its config otherwise than the
    // `place` whose probes it bakes.
    if f.provenance.to_bytes() != provenance.to_bytes() || f.probes.len() != probes {
        return Err(
            "sh.json: comes from another run than report.json beside it; run the job again".into(),
        );
    }
    let sh = |rows: &[[f32; 3]], i: usize| -> Result<ShL2, String> {
        if rows.len() != COEFFICIENTS || rows.iter().flatten().any(|v| !v.is_finite()) {
            return Err(format!(
                "sh.json: probe {i} has not 9 finite RGB coefficients"
            ));
        }
        Ok(ShL2 {
            coefficients: std::array::from_fn(|k| Vec3::from(rows[k])),
        })
    };
    let light = f
        .probes
        .iter()
        .enumerate()
        .map(|(i, p)| {
            Ok(ProbeLight {
                sh: ProbeSh {
                    baked: sh(&p.total, i)?,
                    indirect: sh(&p.indirect, i)?,
                    direct: ShL2::ZERO,
                },
                irradiance_axes: p.irradiance_axes.map(Vec3::from),
            })
        })
        .collect::<Result<Vec<_>, String>>()?;
    Ok((light, f.sh_direct == Direct::Include))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn light(k: f32) -> ProbeLight {
        let mut sh = ShL2::ZERO;
        for (i, c) in sh.coefficients.iter_mut().enumerate() {
            *c = Vec3::new(k, 2.0 * k, i as f32 * 0.25);
        }
        ProbeLight {
            sh: ProbeSh {
                baked: sh,
                indirect: ShL2::ZERO,
                direct: ShL2::ZERO,
            },
            irradiance_axes: [Vec3::splat(k); 6],
        }
    }

    #[test]
    fn sh_json_reads_back_and_refuses_another_run() {
        let p = Provenance {
            tool: crate::provenance::TOOL.into(),
            config_hash: "00000000000000aa".into(),
            seed: 1,
            scene_hash: "0000000000000001".into(),
            config_given: "c.ron".into(),
            cwd: Default::default(),
            config_text: String::new(),
            overrides: Default::default(),
        };
        let probes = [light(0.5), light(1.5)];
        let bytes = encode(&p, 64, true, &probes);
        let back = decode(&bytes, &p, 2).unwrap();
        assert_eq!(back, (probes.to_vec(), true));
        // A file from before the option holds no direct light.
        let mut old: serde_json::Value = serde_json::from_slice(&bytes).unwrap();
        old.as_object_mut().unwrap().remove("sh_direct");
        let old = old.to_string();
        assert!(!decode(old.as_bytes(), &p, 2).unwrap().1);
        let e = decode(&bytes, &p, 3).unwrap_err();
        assert!(e.starts_with("sh.json: comes from another run"), "{e}");
        let mut other = p.clone();
        other.config_hash = "00000000000000ab".into();
        assert!(decode(&bytes, &other, 2).is_err());
        let e = decode(b"{\"format\": 1}", &p, 2).unwrap_err();
        assert!(e.starts_with("sh.json: not a probeplace SH file"), "{e}");
        let text = String::from_utf8(bytes)
            .unwrap()
            .replacen("[0.5,1.0,0.0]", "[0.5,1.0]", 1);
        assert!(decode(text.as_bytes(), &p, 2).is_err());
    }
}
