//! What the table examples share: a run's JSON read whole, each error
//! naming the file. Included by `#[path]`, since every example is its own
//! crate.

use std::path::Path;

/// The JSON document at `path`, or an error that names it.
pub fn read(path: &str) -> Result<serde_json::Value, Box<dyn std::error::Error>> {
    let text = std::fs::read_to_string(Path::new(path)).map_err(|e| format!("{path}: {e}"))?;
    Ok(serde_json::from_str(&text).map_err(|e| format!("{path}: {e}"))?)
}
