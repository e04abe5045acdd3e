//! JSON: pretty-printed with a trailing newline, and files that stay
//! readable at 65 536 rows, their long arrays a few elements a line
//! (`probes.json`, `sh.json` and the engine exports).

use crate::error::{Error, Result};
use serde::Serialize;
use serde_json::Value;

/// Serializes `value` as pretty JSON with a trailing newline.
pub fn to_json<T: Serialize>(value: &T) -> Result<Vec<u8>> {
    let mut bytes = serde_json::to_vec_pretty(value)
        .map_err(|e| Error::Internal(format!("serializing JSON: {e}")))?;
    bytes.push(b'\n');
    Ok(bytes)
}

/// Serializes the object `value` as pretty JSON with a trailing newline,
/// except that its array `rows` (its last field) is written `per_line`
/// elements a line: a file of 65 536 probes stays readable and small.
pub(crate) fn json_rows(value: &Value, rows: &str, per_line: usize) -> Vec<u8> {
    json_tables(value, &[(rows, per_line)])
}

/// [`json_rows`] for several arrays, written last in the order given, each
/// with its own `per_line`.
pub(crate) fn json_tables(value: &Value, tables: &[(&str, usize)]) -> Vec<u8> {
    let mut head = value.clone();
    let columns: Vec<(&str, usize, Vec<Value>)> = tables
        .iter()
        .map(|&(key, per_line)| {
            let items = head
                .as_object_mut()
                .and_then(|o| o.remove(key))
                .and_then(|v| v.as_array().cloned())
                .unwrap_or_default();
            (key, per_line, items)
        })
        .collect();
    let mut text = serde_json::to_string_pretty(&head).expect("a JSON value serializes");
    text.truncate(text.trim_end_matches('}').trim_end().len());
    for (rows, per_line, items) in columns {
        let lines: Vec<String> = items
            .chunks(per_line.max(1))
            .map(|line| {
                let cells: Vec<String> = line
                    .iter()
                    .map(|v| serde_json::to_string(v).expect("a JSON value serializes"))
                    .collect();
                format!("    {}", cells.join(", "))
            })
            .collect();
        let key = serde_json::to_string(rows).expect("a string serializes");
        let sep = if text.ends_with('{') { "" } else { "," };
        if lines.is_empty() {
            text += &format!("{sep}\n  {key}: []");
        } else {
            text += &format!("{sep}\n  {key}: [\n{}\n  ]", lines.join(",\n"));
        }
    }
    text += "\n}\n";
    text.into_bytes()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rows_are_one_a_line_and_the_file_parses_back() {
        let v = serde_json::json!({"a": 1, "b": {"c": [1, 2]}, "rows": [[1, 2, 3], {"x": null}]});
        let text = String::from_utf8(json_rows(&v, "rows", 1)).unwrap();
        assert_eq!(serde_json::from_str::<Value>(&text).unwrap(), v, "{text}");
        assert!(
            text.contains("\n    [1,2,3],\n    {\"x\":null}\n  ]\n}\n"),
            "{text}"
        );
        let empty = serde_json::json!({"rows": []});
        let text = String::from_utf8(json_rows(&empty, "rows", 1)).unwrap();
        assert_eq!(
            serde_json::from_str::<Value>(&text).unwrap(),
            empty,
            "{text}"
        );
        let flat = serde_json::json!({"n": 2, "rows": [1.5, 2, 3, 4, 5, 6.25]});
        let text = String::from_utf8(json_rows(&flat, "rows", 3)).unwrap();
        assert_eq!(
            serde_json::from_str::<Value>(&text).unwrap(),
            flat,
            "{text}"
        );
        assert!(
            text.contains("\n    1.5, 2, 3,\n    4, 5, 6.25\n"),
            "{text}"
        );
    }
}
