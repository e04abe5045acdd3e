//! Every file name a probeplace job writes into an output directory.
//!
//! A directory is replaced whole by the next run into it ([`super::commit`]),
//! so the commit must know which of its files the tool wrote. A directory
//! with a manifest that reads cleanly says so itself: every file is listed.
//! One without (written before manifests existed, or whose manifest was
//! deleted, truncated or is of another version) has only the names to go
//! by: a file whose name no job writes is the user's, and the run is
//! refused rather than deleting it. This is that list; the tests of
//! [`crate::jobs`] check that every name a job or an export writes is on
//! it, so a new output cannot be forgotten here.

/// Names a job writes as they are.
const EXACT: &[&str] = &[
    super::manifest::NAME,
    // Every run.
    "report.json",
    "report.html",
    // place
    "probes.json",
    "svo.bin",
    "placement.png",
    "atlas.png",
    // bake
    "radiance.exr",
    "radiance.png",
    "irradiance.exr",
    "irradiance.png",
    "distance.png",
    "normal.png",
    "lightfield.bin",
    "sh.json",
    "reference.exr",
    "reference.png",
    "reference-glossy.exr",
    "reference-glossy.png",
    "diffuse-reference.png",
    "diffuse-ours.png",
    "diffuse-ours-error.png",
    "diffuse-grid.png",
    "diffuse-grid-error.png",
    // compare
    "compare.json",
    "compare.csv",
    "diffuse.csv",
    // merge
    "world.json",
    // export
    "probes.glb",
    "probes.tscn",
    "probes.unity.json",
    "ddgi.json",
];

/// Names a job makes from a variable part: `(prefix, suffix)`, the part
/// between them a view, variant or tile name (non-empty, no `/`).
const PATTERNS: &[(&str, &str)] = &[
    // render: each view's images and error map.
    ("render_", ".png"),
    ("render_", ".exr"),
    ("error_", ".png"),
    // merge: each tile's SVO.
    ("tile-", ".svo.bin"),
];

/// Whether a job of this build writes files named `name` (module docs).
pub fn is_output_name(name: &str) -> bool {
    EXACT.contains(&name)
        || PATTERNS.iter().any(|(prefix, suffix)| {
            name.len() > prefix.len() + suffix.len()
                && name.starts_with(prefix)
                && name.ends_with(suffix)
                && !name.contains('/')
        })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn outputs_are_named_and_a_users_files_are_not() {
        for name in [
            "probes.json",
            "render_front.png",
            "error_a.png",
            "tile-003.svo.bin",
        ] {
            assert!(is_output_name(name), "{name}");
        }
        for name in [
            "notes.txt",
            "render_.png",
            "probes.json.bak",
            "scene.obj",
            ".hidden",
            "tile-.svo.bin",
        ] {
            assert!(!is_output_name(name), "{name}");
        }
    }
}
