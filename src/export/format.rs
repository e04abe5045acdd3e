//! What an export format is: one type implementing [`Format`], listed once
//! in [`super::registry`]. The config's `export` list, `--format`, the file
//! name, the refusals and docs/formats.md's table of formats all derive
//! from that list (docs/layout.md, "Adding an export format").

use super::source::Source;
use crate::placement::registry::Placement;
use crate::scene::Scene;

/// What a run is about to place, which a format may refuse before any
/// stage runs (the config's `export` list).
#[derive(Debug, Clone, Copy)]
pub struct Planned<'a> {
    /// The placement method.
    pub placement: &'a Placement,
    /// Whether refinement moves, adds and removes probes.
    pub refined: bool,
    /// Whether artist controls (`fixed_probes`, `exclude`, `max_probes`)
    /// add probes or take them away.
    pub controlled: bool,
    /// Whether the probes come from a file (`--probes`), not the method.
    pub probes_file: bool,
}

/// One export format: a file for another tool, computed from one run's
/// files ([`Source`]).
///
/// Contract: [`Format::encode`] is deterministic in its arguments; every
/// refusal is one line, the reason alone (the caller names the run and
/// the format), led by the input file at fault (`probes.json: …`) when
/// one is.
pub trait Format {
    /// The word `--format` takes (`glb`). Two formats may share a word
    /// when one of them holds the scene ([`Format::SCENE`]): `--scene`
    /// picks it.
    const WORD: &'static str;
    /// The file it is written as (`probes.glb`).
    const FILE: &'static str;
    /// One line for `--help` and the docs' table: what the file is, for
    /// which tool.
    const ABOUT: &'static str;
    /// Whether it holds the scene's triangles, so needs the scene read.
    const SCENE: bool = false;

    /// Why a run of this plan cannot have this file, checked before any
    /// stage; `None` when it can. The reason follows the format's name:
    /// "export: Ddgi {reason}".
    fn refuses_plan(_plan: &Planned) -> Option<String> {
        None
    }

    /// Why `source` cannot have this file, checked before the scene is
    /// read; `None` when it can.
    fn refuses(_source: &Source) -> Option<String> {
        None
    }

    /// The file's bytes; `scene` is the run's scene when [`Format::SCENE`].
    fn encode(source: &Source, scene: Option<&Scene>) -> Result<Vec<u8>, String>;
}

/// A format of the list, as the command line and the docs see it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Entry {
    /// The config's variant name (`Glb`).
    pub variant: &'static str,
    /// [`Format::WORD`].
    pub word: &'static str,
    /// [`Format::FILE`].
    pub file: &'static str,
    /// [`Format::ABOUT`].
    pub about: &'static str,
    /// [`Format::SCENE`].
    pub scene: bool,
}

/// The `--format` words of `entries`, each once, in order.
pub fn words(entries: &[Entry]) -> Vec<&'static str> {
    let mut out: Vec<&'static str> = Vec::new();
    for e in entries {
        if !out.contains(&e.word) {
            out.push(e.word);
        }
    }
    out
}

/// Declares the list of export formats: each line `Variant => Type` makes
/// `Variant` an entry of the config's `export` list
/// ([`super::registry::Export`]) and routes its word, file, refusals and
/// bytes to `Type`.
macro_rules! formats {
    ($($variant:ident => $format:ty),+ $(,)?) => {
        /// A file for another tool, written with a run's outputs (the
        /// config's `export` list, or `probeplace export DIR --format …`):
        /// one variant per format of the list in this file, each
        /// described by its `FORMATS` entry; docs/engines.md says how
        /// each is used, docs/formats.md what each holds.
        #[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Deserialize)]
        #[allow(missing_docs)]
        pub enum Export {
            $($variant,)+
        }

        /// Every format of the list, in its order.
        pub const FORMATS: &[$crate::export::format::Entry] = &[
            $($crate::export::format::Entry {
                variant: stringify!($variant),
                word: <$format as $crate::export::format::Format>::WORD,
                file: <$format as $crate::export::format::Format>::FILE,
                about: <$format as $crate::export::format::Format>::ABOUT,
                scene: <$format as $crate::export::format::Format>::SCENE,
            },)+
        ];

        impl Export {
            /// Every format, in the list's order.
            pub const ALL: &[Export] = &[$(Export::$variant,)+];

            /// Its entry of `FORMATS`.
            pub fn entry(self) -> &'static $crate::export::format::Entry {
                &FORMATS[self as usize]
            }

            /// The format `--format WORD` names, the one holding the scene
            /// when `scene` and there is one; `None` for an unknown word.
            pub fn of_word(word: &str, scene: bool) -> Option<Export> {
                let of = |s: bool| {
                    Export::ALL
                        .iter()
                        .copied()
                        .find(|e| e.entry().word == word && e.entry().scene == s)
                };
                match scene {
                    true => of(true).or_else(|| of(false)),
                    false => of(false).or_else(|| of(true)),
                }
            }

            /// See [`Format::refuses_plan`]($crate::export::format::Format::refuses_plan).
            pub fn refuses_plan(self, plan: &$crate::export::format::Planned) -> Option<String> {
                use $crate::export::format::Format;
                match self {
                    $(Export::$variant => <$format>::refuses_plan(plan),)+
                }
            }

            /// See [`Format::refuses`]($crate::export::format::Format::refuses).
            pub fn refuses(self, source: &$crate::export::source::Source) -> Option<String> {
                use $crate::export::format::Format;
                match self {
                    $(Export::$variant => <$format>::refuses(source),)+
                }
            }

            /// The file's bytes; `scene` is the run's scene, which a
            /// format holding it needs.
            pub fn encode(
                self,
                source: &$crate::export::source::Source,
                scene: Option<&$crate::scene::Scene>,
            ) -> Result<Vec<u8>, String> {
                use $crate::export::format::Format;
                match self {
                    $(Export::$variant => {
                        if <$format>::SCENE && scene.is_none() {
                            return Err("the scene mesh needs the run's scene".into());
                        }
                        <$format>::encode(source, scene)
                    })+
                }
            }
        }
    };
}

pub(crate) use formats;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn words_are_listed_once_in_order() {
        let e = |word, scene| Entry {
            variant: "V",
            word,
            file: "f",
            about: "",
            scene,
        };
        assert_eq!(
            words(&[e("a", false), e("a", true), e("b", false)]),
            ["a", "b"]
        );
    }
}
