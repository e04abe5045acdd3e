//! What every export is computed from: one run's `probes.json`,
//! `report.json` and `svo.bin` ([`Source::read`]), with `sh.json` when the
//! run baked.

use crate::provenance::Provenance;
use crate::svo::Svo;
use glam::DVec3;
use serde::{Deserialize, Serialize};
use serde_json::Value;

/// An axis-aligned box in world coordinates.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct WorldBox {
    /// Lower corner.
    pub min: [f64; 3],
    /// Upper corner.
    pub max: [f64; 3],
}

/// One probe as the exports see it.
#[derive(Debug, Clone, PartialEq)]
pub struct SourceProbe {
    /// World position, as `probes.json` writes it (f64).
    pub position: [f64; 3],
    /// Distance to the nearest surface; `None` outside the SDF grid.
    pub clearance: Option<f64>,
    /// The probe's **influence box**: the bounding box of the `svo.bin`
    /// leaves that list the probe, i.e. of the points for which a renderer
    /// querying the octree may shade with it. It is the box of Wang et al.
    /// 2019 §4.1 (median radial distance per face, clipped to the domain)
    /// cut down to the cells that see the probe and rank it among their
    /// best `svo.max_probes`, widened by the cells that fall back to it
    /// and by collapsed leaves; `None` when no leaf lists the probe.
    pub influence: Option<WorldBox>,
    /// One of the config's `fixed_probes`, placed by hand.
    pub fixed: bool,
}

/// What every export is computed from: one run's probes, report and octree.
#[derive(Debug, Clone)]
pub struct Source {
    /// The run's provenance.
    pub provenance: Provenance,
    /// The method as `report.json` names it (`relocated:4x4x4`,
    /// `sdf-skeleton+refine`, …).
    pub method: String,
    /// `report.json`'s `domain`.
    pub domain: WorldBox,
    /// The probes, in `probes.json` order.
    pub probes: Vec<SourceProbe>,
    /// `report.json`'s `placement_stats`.
    pub stats: serde_json::Map<String, Value>,
    /// Each probe's diffuse light (`sh.json`, written by `bake`); `None`
    /// for a run that did not bake.
    pub light: Option<Vec<crate::diffuse::sh::ProbeLight>>,
    /// Whether `light` holds the delta lights' direct light (`sh.json`'s
    /// `sh_direct: Include`).
    pub direct_included: bool,
}

/// The fields of `probes.json` the exports read.
#[derive(Deserialize)]
struct ProbesIn {
    format: String,
    provenance: Provenance,
    probes: Vec<ProbeIn>,
}

#[derive(Deserialize)]
struct ProbeIn {
    position: [f64; 3],
    clearance: Option<f64>,
    #[serde(default)]
    fixed: bool,
}

impl Source {
    /// The source of a run from its `probes.json` and `svo.bin` bytes and
    /// its report. The error is the reason alone, led by the name of the
    /// file at fault; the caller adds the directory.
    ///
    /// Contract: the three must be of one run (the same provenance, the
    /// octree indexing as many probes as the file lists), every position
    /// finite; otherwise `Err`.
    pub fn read(probes_json: &[u8], report: &Value, svo_bytes: &[u8]) -> Result<Source, String> {
        let probes: ProbesIn = serde_json::from_slice(probes_json)
            .map_err(|e| format!("probes.json: not a probeplace probes file: {e}"))?;
        if probes.format != "probeplace.probes" {
            return Err(format!(
                "probes.json: format is {:?}, expected \"probeplace.probes\"",
                probes.format
            ));
        }
        let provenance: Provenance =
            serde_json::from_value(report["provenance"].clone()).map_err(|_| {
                "report.json: has no provenance (written by an older probeplace); run the job again"
                    .to_string()
            })?;
        if probes.provenance != provenance {
            return Err(
                "probes.json: comes from another run than report.json beside it; run the job again"
                    .into(),
            );
        }
        let svo = crate::svo::format::from_bytes(svo_bytes).map_err(|m| format!("svo.bin: {m}"))?;
        if svo.provenance != provenance.to_bytes()
            || svo.probe_count as usize != probes.probes.len()
        {
            return Err(
                "svo.bin: comes from another run than report.json beside it; run the job again"
                    .into(),
            );
        }
        let corner = |k: &str| -> Result<[f64; 3], String> {
            serde_json::from_value::<[f64; 3]>(report["domain"][k].clone())
                .ok()
                .filter(|c| c.iter().all(|v| v.is_finite()))
                .ok_or_else(|| format!("report.json: domain.{k} is not three finite numbers"))
        };
        let domain = WorldBox {
            min: corner("min")?,
            max: corner("max")?,
        };
        if let Some(i) = probes
            .probes
            .iter()
            .position(|p| !p.position.iter().all(|v| v.is_finite()))
        {
            return Err(format!("probes.json: probe {i} has no finite position"));
        }
        let origin = crate::svo::format::exact_origin(svo_bytes);
        let influence = influence_boxes(&svo, origin, probes.probes.len());
        Ok(Source {
            provenance,
            method: report["method"].as_str().unwrap_or("file").to_string(),
            domain,
            probes: probes
                .probes
                .into_iter()
                .zip(influence)
                .map(|(p, influence)| SourceProbe {
                    position: p.position,
                    clearance: p.clearance,
                    influence,
                    fixed: p.fixed,
                })
                .collect(),
            stats: report["placement_stats"]
                .as_object()
                .cloned()
                .unwrap_or_default(),
            light: None,
            direct_included: false,
        })
    }

    /// This source with the probes' light of `sh_json` (`sh.json`'s bytes)
    /// when given. The error is the reason alone, led by `sh.json:`.
    ///
    /// Contract: the file must be of this run and hold every probe.
    pub fn with_light(mut self, sh_json: Option<&[u8]>) -> Result<Source, String> {
        if let Some(bytes) = sh_json {
            let (light, direct_included) =
                crate::report::sh::decode(bytes, &self.provenance, self.probes.len())?;
            self.light = Some(light);
            self.direct_included = direct_included;
        }
        Ok(self)
    }

    /// The diagonal of the domain.
    pub fn diagonal(&self) -> f64 {
        (DVec3::from(self.domain.max) - DVec3::from(self.domain.min)).length()
    }
}

/// Each probe's influence box ([`SourceProbe::influence`]) from the leaves
/// of `svo`, whose leaf (0, 0, 0) starts at the world point `origin`.
fn influence_boxes(svo: &Svo, origin: DVec3, probes: usize) -> Vec<Option<WorldBox>> {
    let mut cells: Vec<Option<(glam::UVec3, glam::UVec3)>> = svo
        .listings()
        .into_iter()
        .map(|l| (l.cells > 0).then_some((l.lo, l.hi)))
        .collect();
    cells.resize(probes, None);
    let leaf = f64::from(svo.leaf_size);
    cells
        .into_iter()
        .map(|c| {
            c.map(|(lo, hi)| WorldBox {
                min: (origin + lo.as_dvec3() * leaf).to_array(),
                max: (origin + hi.as_dvec3() * leaf).to_array(),
            })
        })
        .collect()
}

/// The provenance facts every export repeats: what ties it to the run.
pub(crate) fn provenance_summary(p: &Provenance) -> Value {
    serde_json::json!({
        "tool": p.tool,
        "config_hash": p.config_hash,
        "seed": p.seed,
        "scene_hash": p.scene_hash,
    })
}
