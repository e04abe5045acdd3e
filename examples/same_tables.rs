//! Whether two `compare.json` (or `report.json`) files hold the same
//! figures: every value of every table, with what legitimately varies
//! between runs of the same inputs left out (`timings_ms`, `gpu_ms`,
//! `provenance`, `reused`) and fields only one file has ignored (a newer
//! build may add some). Used to check that a refactor changed no figure.
//!
//! ```sh
//! cargo run --release --example same_tables -- before/compare.json after/compare.json
//! ```
//!
//! Prints each difference by its JSON path and exits with status 1 when
//! there is one.

use serde_json::Value;
use std::process::ExitCode;

/// Keys whose values vary between runs of the same inputs.
const VARYING: [&str; 4] = ["timings_ms", "gpu_ms", "provenance", "reused"];

fn differences(a: &Value, b: &Value, path: &str, out: &mut Vec<String>) {
    match (a, b) {
        (Value::Object(x), Value::Object(y)) => {
            for (k, v) in x {
                if VARYING.contains(&k.as_str()) {
                    continue;
                }
                if let Some(w) = y.get(k) {
                    differences(v, w, &format!("{path}/{k}"), out);
                }
            }
        }
        (Value::Array(x), Value::Array(y)) if x.len() == y.len() => {
            for (i, (v, w)) in x.iter().zip(y).enumerate() {
                differences(v, w, &format!("{path}[{i}]"), out);
            }
        }
        _ if a != b => out.push(format!("{path}: {a} against {b}")),
        _ => {}
    }
}

fn read(path: &str) -> Result<Value, String> {
    let bytes = std::fs::read(path).map_err(|e| format!("{path}: {e}"))?;
    serde_json::from_slice(&bytes).map_err(|e| format!("{path}: {e}"))
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [a, b] = args.as_slice() else {
        eprintln!("usage: same_tables A.json B.json");
        return ExitCode::from(2);
    };
    let (a, b) = match (read(a), read(b)) {
        (Ok(a), Ok(b)) => (a, b),
        (Err(e), _) | (_, Err(e)) => {
            eprintln!("error: {e}");
            return ExitCode::from(2);
        }
    };
    let mut out = Vec::new();
    differences(&a, &b, "", &mut out);
    for d in &out {
        println!("{d}");
    }
    if out.is_empty() {
        println!("same figures");
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    }
}
