//! What a finished job hands back to the command line and the tests.

use serde_json::Value;
use std::path::PathBuf;

/// What a finished job wrote.
#[derive(Debug)]
pub struct Outcome {
    /// The output directory.
    pub out_dir: PathBuf,
    /// The main JSON file as written (`report.json` or `compare.json`);
    /// for `export`, which writes no report, what it wrote
    /// ([`super::export::export`]).
    pub report: Value,
    /// What the command line prints on success: the findings in a line or
    /// a few.
    pub summary: Vec<String>,
}

impl Outcome {
    /// The report's warnings.
    pub fn warnings(&self) -> Vec<String> {
        self.report["warnings"]
            .as_array()
            .map(|a| {
                a.iter()
                    .filter_map(|w| w.as_str().map(String::from))
                    .collect()
            })
            .unwrap_or_default()
    }

    /// The job's wall time in seconds.
    pub fn seconds(&self) -> f64 {
        self.report["timings_ms"]["total"].as_f64().unwrap_or(0.0) / 1e3
    }
}
