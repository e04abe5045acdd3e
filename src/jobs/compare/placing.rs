//! How `compare` places what it measures: ours refined, the rivals as
//! their methods place them, and what an earlier run (`--from`) placed.

use crate::config::{Config, Materials, Placement};
use crate::coverage::CoverageReference;
use crate::error::Result;
use crate::jobs::run::Job;
use crate::lightfield::LightField;
use crate::placement::ProbeSet;
use crate::progress::Progress;
use crate::stages::{self, Placed, Prepared};
use crate::svo::Svo;
use std::collections::BTreeMap;

/// A placement to measure: its probes and what an earlier run already
/// built for them.
pub(super) struct Candidate {
    pub probes: ProbeSet,
    pub stats: BTreeMap<String, f64>,
    pub svo: Svo,
    pub field: Option<LightField>,
}

/// What every placement of a benchmark is placed over.
pub(super) struct Over<'a> {
    /// The config (its materials the benchmark's).
    pub config: &'a Config,
    pub prepared: &'a Prepared,
    pub coverage: &'a CoverageReference,
    pub progress: Progress,
}

impl Over<'_> {
    /// Our `method` placed and refined whatever the config says (§3.3),
    /// with `exactly` that many probes when given (`min_probes` and
    /// `max_probes` both), and refinement's final coverage among its
    /// stats. Errors are the `job`'s config errors.
    pub fn refined(&self, job: &Job, method: &str, exactly: Option<usize>) -> Result<Candidate> {
        let mut c = self.config.clone();
        c.placement = Placement::parse_cli(method, &self.config.placement)?;
        c.refine.enabled = true;
        if let Some(n) = exactly {
            c.min_probes = Some(crate::config::Count(n as u32));
            c.max_probes = c.min_probes;
        }
        let placed = stages::place(&c, self.prepared, self.coverage, None, &self.progress)
            .map_err(|e| job.config_error_of(e, &c.placement))?;
        let mut stats = stats_of(&placed.probes);
        if let Some((r, _)) = &placed.refined {
            stats.insert("refine_coverage_final".into(), r.coverage_final);
        }
        Ok(Candidate {
            probes: placed.probes,
            stats,
            svo: placed.svo.0,
            field: None,
        })
    }

    /// `method` placed without refinement.
    pub fn plain(&self, method: Placement) -> Result<Placed> {
        let mut c = self.config.clone();
        c.placement = method;
        c.refine.enabled = false;
        stages::place(&c, self.prepared, self.coverage, None, &self.progress)
    }
}

/// A fresh placement as a candidate.
pub(super) fn candidate_of(placed: Placed) -> Candidate {
    Candidate {
        stats: stats_of(&placed.probes),
        probes: placed.probes,
        svo: placed.svo.0,
        field: None,
    }
}

/// Our `method`'s probes, SVO and light field from `--from DIR`, when that
/// run placed them refined with this method on the scene's own materials;
/// its files are carried. A light field is kept only when `materials` are
/// the scene's (a bake of the scene's own materials does not serve
/// all-glossy ones).
pub(super) fn reuse(
    job: &mut Job,
    method: &str,
    prepared: &Prepared,
    materials: Materials,
) -> Result<Option<Candidate>> {
    let Some(e) = &job.earlier else {
        return Ok(None);
    };
    let Some(report) = e.report.clone() else {
        return Ok(None);
    };
    // Ours are refined: the earlier run's method is ours with `+refine`.
    let refined = format!("{method}+refine");
    if report["method"].as_str() != Some(refined.as_str()) || report["refine"].is_null() {
        return Ok(None);
    }
    let Some(placement) = super::super::place::load(job, prepared)? else {
        return Ok(None);
    };
    let bake = super::super::bake::load(job, prepared, &placement)?;
    job.carry(&["report.json"]);
    let mut stats = BTreeMap::new();
    for key in ["placement_stats", "placement_params"] {
        if let Some(m) = report[key].as_object() {
            stats.extend(m.iter().filter_map(|(k, v)| Some((k.clone(), v.as_f64()?))));
        }
    }
    if let Some(f) = report["refine"]["coverage_final"].as_f64() {
        stats.insert("refine_coverage_final".into(), f);
    }
    Ok(Some(Candidate {
        probes: placement.probes,
        stats,
        svo: placement.svo,
        field: bake
            .filter(|_| materials == Materials::Scene)
            .map(|b| b.field),
    }))
}

/// `ProbeSet::stats` and `params` as report numbers.
pub(super) fn stats_of(probes: &ProbeSet) -> BTreeMap<String, f64> {
    probes
        .stats
        .iter()
        .map(|(k, v)| (k.to_string(), *v as f64))
        .chain(probes.params.iter().map(|(k, v)| (k.to_string(), *v)))
        .collect()
}
