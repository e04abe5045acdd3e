//! The jobs the command line runs, each a short composition of
//! [`crate::stages`]:
//!
//! | job | stages | writes |
//! |---|---|---|
//! | [`place()`] | prepare → place | `probes.json`, `svo.bin`, `placement.png`, `atlas.png`, `report.json`, `report.html` |
//! | [`bake()`] | … → bake → reference | + `lightfield.bin`, map previews, `reference*` |
//! | [`render()`] | … → validate per variant | + `render_*`, `error_*` |
//! | [`compare()`] | prepare → (place → bake → validate per camera) per placement | `compare.json`, `compare.csv`, `report.html` |
//! | [`inspect()`] | — | nothing: checks an output directory |
//! | [`export()`] | — | + `probes.glb`, `probes.tscn`, `probes.unity.json`, `ddgi.json`: an earlier run's probes for other tools |
//!
//! `bake`, `render` and `compare` take `--from DIR`: what an earlier run
//! wrote there (probes, SVO, light field, reference) is loaded instead of
//! recomputed, and carried into the new output set unchanged, when its
//! provenance ([`crate::provenance`]) is the run's and its `manifest.json`
//! ([`crate::output::manifest`]) vouches for every file; otherwise the run
//! is refused with one line naming the difference or the file. A job's outputs are
//! committed as one set ([`crate::output::commit`]): the output directory
//! holds one run, whole, or the previous one.

pub mod bake;
pub mod compare;
pub mod export;
pub mod inspect;
pub mod merge;
mod outcome;
pub mod place;
pub mod render;
pub(crate) mod run;
pub mod split;

pub use bake::bake;
pub use compare::compare;
pub use export::{export, ExportOptions};
pub use inspect::{inspect, Inspection};
pub use merge::{merge, MergeOptions};
pub use place::place;
pub use render::render;
pub use split::{split, SplitOptions};

pub use outcome::Outcome;
pub use run::{Benchmarks, RunOptions, Variant};

#[cfg(test)]
mod tests {
    use crate::output::names::is_output_name;

    #[test]
    fn every_file_a_job_or_an_export_writes_is_named_as_the_tools() {
        // What a directory without a readable manifest is judged by
        // (crate::output::names): a name missing there would make the next
        // run into such a directory refuse a file the tool wrote.
        let mut names: Vec<String> = [
            &super::place::FILES[..],
            &super::bake::FILES[..],
            &super::bake::REFERENCE_FILES[..],
            &super::bake::DIFFUSE_VIEW_FILES[..],
            &[crate::report::sh::SH_FILE],
            &[
                "report.json",
                "report.html",
                "compare.json",
                "compare.csv",
                "diffuse.csv",
                "world.json",
            ],
        ]
        .concat()
        .into_iter()
        .map(String::from)
        .collect();
        names.extend(
            crate::export::Export::ALL
                .iter()
                .map(|e| e.entry().file.to_string()),
        );
        for view in ["front", "cam-2"] {
            names.push(format!("render_{view}.png"));
            names.push(format!("render_{view}-glossy.exr"));
            names.push(format!("error_{view}.png"));
        }
        names.push("tile-007.svo.bin".into());
        for name in &names {
            assert!(is_output_name(name), "{name}");
        }
    }
}
