//! The house's layout: no import circle among the files of src/
//! (docs/layout.md, "Imports").
//!
//! An import is a `use` declaration or a path that starts with `crate::`,
//! `super::` or `self::`, outside `#[cfg(test)]` items and comments; it
//! points at the file of the longest module prefix it names (`use
//! crate::svo::rank::Ranked` at src/svo/rank.rs, `use crate::svo::Svo` at
//! src/svo/mod.rs). A parent's `mod child;` and its calls into `child::`
//! are the parent owning the child, not imports; a parent's `pub use
//! child::X` is one, so a child that imports from its parent's file while
//! the parent re-exports it is a circle.

use crate::common::root;
use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

/// A module's path within the crate (`["svo", "rank"]`).
type Module = Vec<String>;
/// Each module and the modules it imports.
type Edges = BTreeMap<Module, BTreeSet<Module>>;

/// A module path (`["svo", "rank"]`) to its file, for every file of `dir`.
fn modules(dir: &Path) -> BTreeMap<Vec<String>, String> {
    let mut out = BTreeMap::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for entry in std::fs::read_dir(&d).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                stack.push(path);
                continue;
            }
            if path.extension().is_none_or(|e| e != "rs") {
                continue;
            }
            let rel = path.strip_prefix(dir).unwrap().with_extension("");
            let mut m: Vec<String> = rel
                .components()
                .map(|c| c.as_os_str().to_string_lossy().into_owned())
                .collect();
            if m.last().is_some_and(|l| l == "mod") || m == ["lib"] {
                m.pop();
            }
            if m == ["main"] {
                continue; // the binary imports the library by its name
            }
            out.insert(m, path.to_string_lossy().into_owned());
        }
    }
    out
}

/// `text` without comments, string and char literals' contents, and
/// `#[cfg(test)]` items (a `mod tests { … }` or a single `use …;`).
fn code(text: &str) -> String {
    let b = text.as_bytes();
    let mut out = String::with_capacity(text.len());
    let mut i = 0;
    while i < b.len() {
        if b[i..].starts_with(b"//") {
            while i < b.len() && b[i] != b'\n' {
                i += 1;
            }
        } else if b[i..].starts_with(b"/*") {
            i = text[i..].find("*/").map_or(b.len(), |e| i + e + 2);
        } else if b[i] == b'r'
            && matches!(b.get(i + 1), Some(b'"' | b'#'))
            && !text[..i]
                .chars()
                .next_back()
                .is_some_and(|c| c.is_alphanumeric() || c == '_')
        {
            // A raw string: r"…", r#"…"#.
            let hashes = b[i + 1..].iter().take_while(|&&c| c == b'#').count();
            let close = format!("\"{}", "#".repeat(hashes));
            let open = i + 1 + hashes + 1;
            i = text[open..]
                .find(&close)
                .map_or(b.len(), |e| open + e + close.len());
            out.push_str("\"\"");
        } else if b[i] == b'"' {
            // A string; an escaped quote is skipped.
            i += 1;
            while i < b.len() && b[i] != b'"' {
                i += if b[i] == b'\\' { 2 } else { 1 };
            }
            i += 1;
            out.push_str("\"\"");
        } else if b[i] == b'\'' && i + 2 < b.len() && (b[i + 2] == b'\'' || b[i + 1] == b'\\') {
            // A char literal ('x', '\n', '\''), not a lifetime.
            i += if b[i + 1] == b'\\' { 3 } else { 1 };
            while i < b.len() && b[i] != b'\'' {
                i += 1;
            }
            i += 1;
        } else {
            let c = text[i..].chars().next().unwrap();
            out.push(c);
            i += c.len_utf8();
        }
    }
    // Drop `#[cfg(test)]` items.
    while let Some(at) = out.find("#[cfg(test)]") {
        let rest = &out[at..];
        let end = match (rest.find('{'), rest.find(';')) {
            (Some(open), semi) if semi.is_none_or(|s| open < s) => {
                let mut depth = 0;
                let mut end = rest.len();
                for (k, c) in rest[open..].char_indices() {
                    match c {
                        '{' => depth += 1,
                        '}' => {
                            depth -= 1;
                            if depth == 0 {
                                end = open + k + 1;
                                break;
                            }
                        }
                        _ => {}
                    }
                }
                end
            }
            (_, Some(semi)) => semi + 1,
            _ => rest.len(),
        };
        out.replace_range(at..at + end, "");
    }
    out
}

/// The paths a `use` tree names (`a::{b, c::{d, e}}` → a::b, a::c::d,
/// a::c::e), each as its segments.
fn use_paths(prefix: &[String], tree: &str, out: &mut Vec<Vec<String>>) {
    let mut depth = 0;
    let mut start = 0;
    let mut parts = Vec::new();
    for (k, c) in tree.char_indices() {
        match c {
            '{' => depth += 1,
            '}' => depth -= 1,
            ',' if depth == 0 => {
                parts.push(&tree[start..k]);
                start = k + 1;
            }
            _ => {}
        }
    }
    parts.push(&tree[start..]);
    for part in parts.iter().map(|p| p.trim()).filter(|p| !p.is_empty()) {
        let segments = |s: &str| -> Vec<String> {
            s.split("::")
                .map(|x| x.trim().to_string())
                .filter(|x| !x.is_empty())
                .collect()
        };
        if let (Some(open), true) = (part.find('{'), part.ends_with('}')) {
            let mut p = prefix.to_vec();
            p.extend(segments(&part[..open]));
            use_paths(&p, &part[open + 1..part.len() - 1], out);
        } else {
            let mut p = prefix.to_vec();
            p.extend(segments(part.split(" as ").next().unwrap()));
            out.push(p);
        }
    }
}

/// The paths `code` imports: its `use` trees and its `crate::`, `super::`
/// and `self::` paths.
fn imports(code: &str) -> Vec<Vec<String>> {
    let mut out = Vec::new();
    let word = |c: char| c.is_alphanumeric() || c == '_';
    let mut at = 0;
    while let Some(k) = code[at..].find("use ") {
        let s = at + k;
        at = s + 4;
        if code[..s].chars().next_back().is_some_and(word) {
            continue;
        }
        if let Some(end) = code[s..].find(';') {
            use_paths(&[], &code[s + 4..s + end], &mut out);
        }
    }
    for root in ["crate::", "super::", "self::"] {
        let mut at = 0;
        while let Some(k) = code[at..].find(root) {
            let s = at + k;
            at = s + root.len();
            if code[..s]
                .chars()
                .next_back()
                .is_some_and(|c| word(c) || c == ':')
            {
                continue;
            }
            let len = code[s..]
                .find(|c: char| !(word(c) || c == ':'))
                .unwrap_or(code.len() - s);
            let path: Vec<String> = code[s..s + len]
                .split("::")
                .filter(|x| !x.is_empty())
                .map(String::from)
                .collect();
            // `super::{a, b}` is a use tree, read above.
            if path.len() > 1 {
                out.push(path);
            }
        }
    }
    out
}

/// The module file an import `path` of module `from` points at: the
/// longest module prefix of its absolute form. `None` for other crates.
fn target(
    files: &BTreeMap<Vec<String>, String>,
    from: &[String],
    path: &[String],
) -> Option<Vec<String>> {
    let mut abs: Vec<String> = match path.first().map(String::as_str) {
        Some("crate") => path[1..].to_vec(),
        Some("super" | "self") => {
            let mut m = from.to_vec();
            let mut rest = path;
            while let Some(first) = rest.first() {
                match first.as_str() {
                    "super" => {
                        m.pop();
                    }
                    "self" => {}
                    _ => break,
                }
                rest = &rest[1..];
            }
            m.extend(rest.iter().cloned());
            m
        }
        // A `use child::…` of a module's own child.
        Some(first) if files.contains_key(&[from.to_vec(), vec![first.to_string()]].concat()) => {
            [from, path].concat()
        }
        _ => return None,
    };
    while !abs.is_empty() && !files.contains_key(&abs) {
        abs.pop();
    }
    (!abs.is_empty()).then_some(abs)
}

/// The import graph of src/: module → the modules it imports.
fn graph(src: &Path) -> (BTreeMap<Module, String>, Edges) {
    let files = modules(src);
    let mut edges = BTreeMap::new();
    for (m, path) in &files {
        let text = code(&std::fs::read_to_string(path).unwrap());
        let to: BTreeSet<Vec<String>> = imports(&text)
            .iter()
            .filter_map(|p| target(&files, m, p))
            .filter(|t| t != m)
            .collect();
        edges.insert(m.clone(), to);
    }
    (files, edges)
}

/// One circle of `edges`, as the files around it, if there is any
/// (depth-first search for a back edge).
fn circle(edges: &Edges) -> Option<Vec<Module>> {
    #[derive(Clone, Copy, PartialEq)]
    enum Mark {
        New,
        Open,
        Done,
    }
    fn visit(
        m: &Module,
        edges: &Edges,
        marks: &mut BTreeMap<Module, Mark>,
        path: &mut Vec<Module>,
    ) -> Option<Vec<Module>> {
        marks.insert(m.clone(), Mark::Open);
        path.push(m.clone());
        for t in edges.get(m).into_iter().flatten() {
            match marks.get(t).copied().unwrap_or(Mark::New) {
                Mark::Open => {
                    let from = path.iter().position(|p| p == t).unwrap();
                    return Some(path[from..].to_vec());
                }
                Mark::New => {
                    if let Some(c) = visit(t, edges, marks, path) {
                        return Some(c);
                    }
                }
                Mark::Done => {}
            }
        }
        path.pop();
        marks.insert(m.clone(), Mark::Done);
        None
    }
    let mut marks = BTreeMap::new();
    for m in edges.keys() {
        if marks.get(m).copied().unwrap_or(Mark::New) == Mark::New {
            if let Some(c) = visit(m, edges, &mut marks, &mut Vec::new()) {
                return Some(c);
            }
        }
    }
    None
}

#[test]
fn no_import_circle_among_the_files_of_src() {
    let (files, edges) = graph(&root().join("src"));
    assert!(files.len() > 100, "{} files", files.len());
    // The reader sees the imports it must: a few known ones.
    let has = |from: &[&str], to: &[&str]| {
        let v = |p: &[&str]| p.iter().map(|s| s.to_string()).collect::<Vec<_>>();
        edges[&v(from)].contains(&v(to))
    };
    assert!(has(&["jobs", "place"], &["stages"]));
    assert!(has(&["error"], &["config", "locate"]));
    assert!(has(&["output", "commit"], &["encode", "png"]));
    if let Some(c) = circle(&edges) {
        let top = root();
        let names: Vec<String> = c
            .iter()
            .map(|m| {
                let path = Path::new(&files[m]);
                path.strip_prefix(&top)
                    .unwrap_or(path)
                    .display()
                    .to_string()
            })
            .collect();
        panic!("an import circle: {} → {}", names.join(" → "), names[0]);
    }
}

/// The checker finds a circle where there is one: two files of a module
/// that import each other, one through its parent's re-export.
#[test]
fn the_circle_check_finds_a_planted_circle() {
    let dir = tempfile::tempdir().unwrap();
    let src = dir.path();
    let write = |p: &str, text: &str| {
        let path = src.join(p);
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        std::fs::write(path, text).unwrap();
    };
    write("lib.rs", "pub mod a;\npub mod b;\n");
    write("a/mod.rs", "mod x;\npub use x::X;\n// use crate::b;\n");
    write(
        "a/x.rs",
        "pub struct X;\nfn f() -> crate::b::Y { todo!() }\n",
    );
    write(
        "b.rs",
        "use crate::a::X;\npub struct Y;\n#[cfg(test)]\nmod tests {\n    use crate::a::x;\n}\n",
    );
    let (_, edges) = graph(src);
    let c = circle(&edges).expect("a → a/x → b → a");
    assert_eq!(c.len(), 3, "{c:?}");
    // The comment and the test module import nothing.
    write(
        "b.rs",
        "pub struct Y;\n#[cfg(test)]\nmod tests {\n    use crate::a::X;\n}\n",
    );
    let (_, edges) = graph(src);
    assert_eq!(circle(&edges), None);
}
