//! The generated blocks of docs/: a table a list of the crate writes
//! (the export formats, the compare metrics) between `<!-- NAME begin …
//! -->` and `<!-- NAME end -->`, which the lists' tests hold against the
//! list.

/// Checks that the block `name` of `docs/DOC` is `block`, and fails with
/// the block to paste where it is not.
pub(crate) fn assert_doc_block(doc: &str, name: &str, block: &str) {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("docs")
        .join(doc);
    let text = std::fs::read_to_string(&path).unwrap();
    let (begin, end) = (format!("<!-- {name} begin"), format!("<!-- {name} end -->"));
    let start = text
        .find(&begin)
        .unwrap_or_else(|| panic!("docs/{doc} has no {name} block"));
    let start = start + text[start..].find("-->\n").unwrap() + 4;
    let stop = text.find(&end).expect("the block's end");
    assert_eq!(
        &text[start..stop],
        block,
        "docs/{doc}'s {name} table is not its list's; the block:\n{block}"
    );
}
