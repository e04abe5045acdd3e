//! Files for other tools: a run's probes as a glTF 2.0 binary for Blender
//! and three.js ([`gltf`]), a Godot 4 scene ([`godot`]), the flat list the
//! Unity importer reads ([`unity`]) and a DDGI volume description
//! ([`ddgi`]). docs/formats.md specifies each file, docs/engines.md says
//! how each is loaded.
//!
//! Every export is computed from the files of one run, `probes.json`,
//! `report.json` and `svo.bin` ([`Source::read`]), whether the run writes
//! them (the config's `export` list) or `probeplace export DIR` reads them
//! later: both give the same bytes.
//!
//! **Frame.** All four are in the run's world frame (docs/formats.md): the
//! OBJ's right-handed frame, scaled by `scale` and turned Y-up for `up: Z`
//! files. glTF and Godot use the same right-handed, Y-up frame, so no
//! conversion is made; glTF takes a unit to be a metre, so a scene in
//! other units is exported at the `scale` its config gives. The Unity
//! file stays in world coordinates too; its importer negates x, as Unity's
//! own OBJ, FBX and glTF importers do. The DDGI volume uses RTXGI's
//! right-handed Y-up convention.
//!
//! **Formats.** Each format is one file implementing [`format::Format`]
//! and one line of [`registry`], the list the config's `export` field,
//! `--format` and docs/formats.md's table of formats derive from
//! (docs/layout.md, "Adding an export format").

pub mod ddgi;
pub mod format;
pub mod gltf;
pub mod godot;
pub mod registry;
pub mod source;
pub mod unity;

pub use registry::{Export, FORMATS};
pub use source::Source;
