//! The documented field lists against the files the suite writes, so the
//! docs cannot drift from the tool: every table of docs/formats.md that
//! lists a file's fields names exactly the fields the file has, the
//! documented `compare.csv` header is the one written, and the field table
//! of docs/config.md names exactly the fields the config parser accepts.

use crate::common::*;
use serde_json::Value;
use std::collections::BTreeSet;

fn doc(name: &str) -> String {
    std::fs::read_to_string(root().join("docs").join(name)).unwrap()
}

/// The lines of the section of `text` whose heading line starts with
/// `heading` (`## \`report.json\``), up to the next heading of any level.
fn section<'a>(text: &'a str, heading: &str) -> Vec<&'a str> {
    let mut lines = text.lines().skip_while(|l| !l.starts_with(heading));
    assert!(lines.next().is_some(), "no heading {heading:?}");
    lines.take_while(|l| !l.starts_with('#')).collect()
}

/// The tables of a section, in order: each a list of rows, each row its
/// cells (header and rule rows left out).
fn tables(lines: &[&str]) -> Vec<Vec<Vec<String>>> {
    let mut out: Vec<Vec<Vec<String>>> = Vec::new();
    let mut open = false;
    for line in lines {
        let t = line.trim();
        if !t.starts_with('|') {
            open = false;
            continue;
        }
        let cells: Vec<String> = t
            .trim_matches('|')
            .split(" | ")
            .map(|c| c.trim().to_string())
            .collect();
        if !open {
            out.push(Vec::new());
            open = true;
            continue; // the header
        }
        if cells[0].starts_with("---") {
            continue;
        }
        out.last_mut().unwrap().push(cells);
    }
    out
}

/// The backticked spans of `cell`.
fn ticked(cell: &str) -> Vec<String> {
    cell.split('`')
        .enumerate()
        .filter(|(i, _)| i % 2 == 1)
        .map(|(_, s)| s.to_string())
        .collect()
}

/// The field paths a table's first column names: each backticked span,
/// with `a {b, c}` read as `a.b` and `a.c`.
fn names(table: &[Vec<String>]) -> Vec<String> {
    let mut out = Vec::new();
    for row in table {
        for span in ticked(&row[0]) {
            match span.split_once(" {") {
                Some((base, rest)) => {
                    for sub in rest.trim_end_matches('}').split(',') {
                        out.push(format!("{base}.{}", sub.trim()));
                    }
                }
                None => out.push(span),
            }
        }
    }
    out
}

fn keys(v: &Value) -> BTreeSet<String> {
    v.as_object()
        .unwrap_or_else(|| panic!("not an object: {v}"))
        .keys()
        .cloned()
        .collect()
}

/// The value at a documented path (`scene.bounds.min`, `probes[].index`:
/// the first element of an array).
fn at<'a>(v: &'a Value, path: &str) -> Option<&'a Value> {
    path.split('.')
        .try_fold(v, |v, step| match step.strip_suffix("[]") {
            Some(name) => v.get(name)?.get(0),
            None => v.get(step),
        })
}

/// Checks that the table's top-level names are exactly `value`'s keys
/// (`except` aside: fields documented elsewhere), and that every dotted
/// path it names exists. `what` names the table in messages.
fn same_fields(what: &str, table: &[Vec<String>], value: &Value, except: &[&str]) {
    let documented: Vec<String> = names(table);
    let tops: BTreeSet<String> = documented
        .iter()
        .map(|n| n.split(['.', '[']).next().unwrap().to_string())
        .collect();
    let actual: BTreeSet<String> = keys(value)
        .into_iter()
        .filter(|k| !except.contains(&k.as_str()))
        .collect();
    let undocumented: Vec<_> = actual.difference(&tops).collect();
    let absent: Vec<_> = tops.difference(&actual).collect();
    assert!(
        undocumented.is_empty() && absent.is_empty(),
        "{what}: fields written but not documented: {undocumented:?}; documented but not written: {absent:?}"
    );
    for path in documented.iter().filter(|n| n.contains(['.', '['])) {
        assert!(
            at(value, path).is_some(),
            "{what}: documented {path} is not in the file"
        );
    }
}

/// The table of `heading`'s section, number `index`.
fn table(text: &str, heading: &str, index: usize) -> Vec<Vec<String>> {
    tables(&section(text, heading))
        .into_iter()
        .nth(index)
        .unwrap_or_else(|| panic!("{heading}: no table {index}"))
}

/// The table of `heading`'s section that follows the line `label`.
fn table_after(text: &str, heading: &str, label: &str) -> Vec<Vec<String>> {
    let lines = section(text, heading);
    let from = lines
        .iter()
        .position(|l| l.trim() == label)
        .unwrap_or_else(|| panic!("{heading}: no line {label:?}"));
    tables(&lines[from..]).remove(0)
}

/// The rows of docs/formats.md's table of metrics (`### Metrics`): every
/// metric's key, heading, whether it is paired, and what it measures.
/// The tables that say "the metrics' keys" document these fields.
fn metric_rows(formats: &str) -> Vec<Vec<String>> {
    table(formats, "### Metrics", 0)
}

/// `rows` and the metrics' rows (only the paired ones when `paired`).
fn with_metrics(rows: &[Vec<String>], formats: &str, paired: bool) -> Vec<Vec<String>> {
    let mut out: Vec<Vec<String>> = rows
        .iter()
        .filter(|r| !r[0].starts_with("the metrics' keys") && !r[0].starts_with("each paired"))
        .cloned()
        .collect();
    out.extend(
        metric_rows(formats)
            .into_iter()
            .filter(|r| !paired || r[2] == "yes"),
    );
    out
}

/// Every file a job writes carries format, version and provenance, which
/// the headings and the provenance table document.
const COMMON: [&str; 3] = ["format", "version", "provenance"];

#[test]
fn probes_json_and_the_provenance_match_their_tables() {
    let formats = doc("formats.md");
    let dir = &shared_job("place", "configs/cornell.ron", &[]).dir;
    let probes = read_json(&dir.join("probes.json"));
    let heading = "## `probes.json`";
    assert!(
        formats.contains(&format!(
            "(format `{}`, version {})",
            probes["format"].as_str().unwrap(),
            probes["version"]
        )),
        "the probes.json heading names its format and version"
    );
    same_fields(
        "probes.json",
        &table(&formats, heading, 0),
        &probes,
        &COMMON,
    );
    let record: Vec<Vec<String>> = table(&formats, heading, 0)
        .into_iter()
        .filter(|r| r[0].starts_with("`probes[]."))
        .map(|mut r| {
            r[0] = r[0].replace("probes[].", "");
            r
        })
        .collect();
    same_fields("probes.json probes[]", &record, &probes["probes"][0], &[]);
    same_fields(
        "provenance",
        &table(&formats, "# Output formats", 0),
        &probes["provenance"],
        &[],
    );
    // Every placement method the command line takes is named.
    let o = probeplace(&[
        "place",
        "configs/cornell.ron",
        "--method",
        "bogus",
        "--out",
        "/nonexistent/x",
    ]);
    let message = String::from_utf8_lossy(&o.stderr);
    let methods = message.split("expected ").nth(1).expect("the method list");
    let row = table(&formats, heading, 0)
        .into_iter()
        .find(|r| r[0] == "`method`")
        .expect("a method row");
    for m in methods
        .trim()
        .split([',', ' '])
        .filter(|m| !m.is_empty() && *m != "or")
    {
        let stem = m.split(':').next().unwrap();
        assert!(
            row[1].contains(&format!("`{stem}")),
            "probes.json's method row lacks {m}: {}",
            row[1]
        );
    }
}

#[test]
fn report_json_matches_its_tables_after_place_and_render() {
    let formats = doc("formats.md");
    let heading = "## `report.json`";
    let place = &shared_job("place", "configs/cornell.ron", &[]).report;
    same_fields("report.json", &table(&formats, heading, 0), place, &COMMON);
    same_fields(
        "report.json refine",
        &table(&formats, "### `refine`", 0),
        &place["refine"],
        &[],
    );
    same_fields(
        "report.json svo",
        &table(&formats, "### `svo`", 0),
        &place["svo"],
        &[],
    );
    same_fields(
        "report.json controls",
        &table(&formats, "### `controls`", 0),
        &place["controls"],
        &[],
    );
    let render = &shared_job("render", "configs/cornell-glossy.ron", &[]).report;
    same_fields(
        "report.json after render",
        &table(&formats, heading, 0),
        render,
        &COMMON,
    );
    same_fields(
        "report.json bake",
        &table(&formats, "### `bake`", 0),
        &render["bake"],
        &[],
    );
    same_fields(
        "report.json render",
        &table(&formats, "### `render`", 0),
        &render["render"],
        &[],
    );
    let variants = render["render"]["variants"].as_object().unwrap();
    assert!(!variants.is_empty());
    for (name, v) in variants {
        same_fields(
            &format!("report.json render.variants.{name}"),
            &with_metrics(
                &table_after(&formats, "### `render`", "Per variant:"),
                &formats,
                false,
            ),
            v,
            &[],
        );
    }
}

#[test]
fn compare_json_and_csv_match_their_docs() {
    let formats = doc("formats.md");
    let Shared { dir, report } = crate::compare::cornell_glossy_test_quality();
    let heading = "## `compare.json`";
    assert!(
        formats.contains(&format!(
            "(format `{}`, version {}",
            report["format"].as_str().unwrap(),
            report["version"]
        )),
        "the compare.json heading names its format and version"
    );
    same_fields(
        "compare.json",
        &table(&formats, heading, 0),
        report,
        &COMMON,
    );
    let per = with_metrics(
        &table_after(&formats, heading, "Per placement:"),
        &formats,
        false,
    );
    for p in report["placements"].as_array().unwrap() {
        same_fields(
            &format!("compare.json placement {}", p["name"]),
            &per,
            p,
            &[],
        );
        let cameras = per
            .iter()
            .find(|r| r[0] == "`cameras`")
            .expect("a cameras row");
        let mut listed: BTreeSet<String> = ticked(&cameras[1]).into_iter().collect();
        listed.extend(metric_rows(&formats).iter().flat_map(|r| ticked(&r[0])));
        for k in keys(&p["cameras"][0]) {
            assert!(
                listed.contains(&k),
                "compare.json placements[].cameras[].{k} is not documented"
            );
        }
    }
    // Every ratio's fields, and the interval's.
    let per_ratio = with_metrics(
        &table_after(&formats, heading, "Per ratio:"),
        &formats,
        true,
    );
    let ratios: Vec<&Value> = report["comparisons"]
        .as_array()
        .unwrap()
        .iter()
        .flat_map(|c| c["ratios"].as_array().unwrap())
        .collect();
    assert!(!ratios.is_empty(), "no ratios");
    for r in ratios {
        same_fields("compare.json ratio", &per_ratio, r, &[]);
        for k in keys(&r["flip"]) {
            assert!(
                ["value", "lo", "hi"].contains(&k.as_str()),
                "interval field {k} is not documented"
            );
        }
    }
    // The diffuse benchmark's fields, and diffuse.csv's header.
    let diffuse = "### The diffuse benchmark";
    let d = &report["diffuse"];
    same_fields("compare.json diffuse", &table(&formats, diffuse, 0), d, &[]);
    same_fields(
        "compare.json diffuse.setup",
        &table_after(&formats, diffuse, "Set-up:"),
        &d["setup"],
        &[],
    );
    for p in d["placements"].as_array().unwrap() {
        same_fields(
            &format!("compare.json diffuse placement {}", p["name"]),
            &table_after(&formats, diffuse, "Per placement:"),
            p,
            &[],
        );
    }
    for c in d["comparisons"].as_array().unwrap() {
        same_fields(
            &format!("compare.json diffuse comparison {}", c["rival"]),
            &table_after(&formats, diffuse, "Per comparison:"),
            c,
            &[],
        );
    }
    let csv = std::fs::read_to_string(dir.join("diffuse.csv")).unwrap();
    let documented = section(&formats, "## `diffuse.csv`").join(" ");
    let columns = ticked(&documented)
        .into_iter()
        .find(|s| s.contains(", "))
        .expect("the documented columns");
    assert_eq!(
        columns.replace(' ', ""),
        csv.lines().next().unwrap(),
        "diffuse.csv's columns"
    );
    // The documented header is the header written, in order.
    let csv = std::fs::read_to_string(dir.join("compare.csv")).unwrap();
    let header = csv.lines().next().unwrap();
    let documented = section(&formats, "## `compare.csv`").join(" ");
    let columns = ticked(&documented)
        .into_iter()
        .find(|s| s.contains(", "))
        .expect("the documented columns");
    assert_eq!(columns.replace(' ', ""), header, "compare.csv's columns");
}

#[test]
fn config_md_names_every_config_field() {
    let config = doc("config.md");
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bogus.ron");
    std::fs::write(&path, "(scene: \"x.obj\", not_a_field: 1)").unwrap();
    let o = probeplace(&["place", path.to_str().unwrap()]);
    let message = String::from_utf8_lossy(&o.stderr);
    let expected = message
        .split("expected one of")
        .nth(1)
        .expect("the field list");
    let fields: BTreeSet<String> = ticked(expected).into_iter().collect();
    assert!(fields.contains("scene") && fields.len() > 10, "{message}");
    let documented: BTreeSet<String> = names(&table(&config, "## Fields", 0)).into_iter().collect();
    assert_eq!(
        documented, fields,
        "config.md's field table against the parser"
    );
    // The "every field" example is a config the parser takes.
    let example = config
        .split("Every field:\n\n```ron\n")
        .nth(1)
        .and_then(|s| s.split("```").next())
        .expect("the every-field example");
    let scene = root().join("fixtures/cornell_box.obj");
    let text = example.replace("\"../fixtures/cornell_box.obj\"", &format!("{scene:?}"));
    probeplace::config::Config::parse(&text, std::path::Path::new("config.md"))
        .unwrap_or_else(|e| panic!("config.md's every-field example: {e}"));
}

/// docs/config.md's table of placement methods is the registry's list
/// (`probeplace::placement::METHODS`), row for row: a method added to the
/// list without its row, or a row left for a removed one, fails here with
/// the block to paste.
#[test]
fn the_methods_table_is_the_registrys_list() {
    use probeplace::placement::{Role, METHODS};
    let mut block =
        String::from("| config | `--method` | what | in `compare` |\n|---|---|---|---|\n");
    for m in METHODS {
        let role = match m.role {
            Role::Ours => "ours",
            Role::Grid => "the grid sweep",
            Role::Competitor => "at our probe count",
            Role::None => "—",
        };
        block += &format!(
            "| `{}((…))` | `{}` | {} | {} |\n",
            m.variant, m.form, m.about, role
        );
    }
    let text = doc("config.md");
    let (begin, end) = ("<!-- methods begin", "<!-- methods end -->");
    let start = text.find(begin).expect("the methods block");
    let start = start + text[start..].find("-->\n").unwrap() + 4;
    let stop = text.find(end).expect("the methods block's end");
    assert_eq!(
        &text[start..stop],
        block,
        "docs/config.md's methods table is not the registry's; the block:\n{block}"
    );
}

/// The README stays a short manual (issue 46): at most 12 000 bytes, the
/// long guides in docs/.
#[test]
fn the_readme_stays_under_twelve_thousand_bytes() {
    let bytes = std::fs::read(root().join("README.md")).unwrap().len();
    assert!(bytes <= 12_000, "README.md is {bytes} bytes");
}

/// docs/layout.md's table of the full tier names exactly the tests marked
/// `#[ignore = "full tier …"]` in tests/it, each once, with what the CI
/// tier keeps of its claim: a test moved to the full tier is written down.
#[test]
fn the_full_tier_table_is_the_tests_marked_full_tier() {
    let mut marked = BTreeSet::new();
    for entry in std::fs::read_dir(root().join("tests/it")).unwrap() {
        let path = entry.unwrap().path();
        let module = path.file_stem().unwrap().to_string_lossy().into_owned();
        let text = std::fs::read_to_string(&path).unwrap();
        let mut lines = text.lines();
        while let Some(line) = lines.next() {
            if !line.trim().starts_with("#[ignore = \"full tier") {
                continue;
            }
            let name = lines
                .find_map(|l| l.trim().strip_prefix("fn "))
                .and_then(|l| l.split('(').next())
                .unwrap_or_else(|| panic!("{}: no fn after a full-tier mark", path.display()));
            assert!(marked.insert(format!("{module}::{name}")));
        }
    }
    let rows = table(&doc("layout.md"), "## Test tiers", 0);
    let listed: Vec<String> = rows.iter().map(|r| ticked(&r[0]).concat()).collect();
    let set: BTreeSet<String> = listed.iter().cloned().collect();
    assert_eq!(set.len(), listed.len(), "a test listed twice: {listed:?}");
    assert_eq!(
        set, marked,
        "docs/layout.md's full-tier table against the marks"
    );
    for row in &rows {
        assert!(
            !row[1].is_empty(),
            "{}: what does the CI tier keep?",
            row[0]
        );
    }
}
