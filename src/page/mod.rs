//! The pages a run writes beside its reports: `report.html` of `place`,
//! `bake` and `render` ([`run_html`], from `report.json` read into
//! [`figures::RunFigures`]) and of `compare`
//! ([`html`], from `compare.json`), with the 3D view of the scene and its
//! probes ([`view3d`], three.js vendored in `vendor/`) and what both share
//! to write markup ([`markup`]). Self-contained: they open offline from
//! `file://` (docs/formats.md, "`report.html`").

pub mod figures;
pub mod html;
pub(crate) mod markup;
pub mod run_html;
pub mod view3d;
