//! Which kind of placement a row of `compare` is: ours, a grid of the
//! sweep, a competitor of the list of methods, or a set given by file.

use crate::placement::method::Role;
use crate::placement::registry::METHODS;
use serde::Serialize;

/// Which kind of placement a row is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Family {
    /// Ours: a skeleton placement refined (Wang et al. 2019 §3).
    Ours,
    /// A uniform grid of the sweep (McGuire et al. 2017).
    Grid,
    /// A competitor of the list of methods (`Role::Competitor`: RTXGI's
    /// relocated grid, Silvennoinen & Lehtinen's greedy placement, Unity's
    /// adaptive probe volumes), by its `--method` word.
    Competitor(&'static str),
    /// A probe set made elsewhere (`--probes FILE.json`), scored as given.
    Given,
}

impl Family {
    /// The name in `compare.json` and `compare.csv`.
    pub fn key(self) -> &'static str {
        match self {
            Family::Ours => "ours",
            Family::Grid => "grid",
            Family::Competitor(word) => word,
            Family::Given => "given",
        }
    }

    /// The competitor's entry of the list of methods.
    fn method(self) -> Option<&'static crate::placement::method::Entry> {
        match self {
            Family::Competitor(word) => METHODS.iter().find(|m| m.word == word),
            _ => None,
        }
    }

    /// The name in tables.
    pub fn label(self) -> &'static str {
        match self {
            Family::Ours => "ours",
            Family::Grid => "uniform grid",
            Family::Competitor(word) => self.method().map_or(word, |m| m.label),
            Family::Given => "given (--probes)",
        }
    }

    /// Colour and marker in the plots.
    pub fn marker(self) -> (&'static str, &'static str) {
        match self {
            Family::Ours => ("#2a8a2a", "circle"),
            Family::Grid => ("#3060c0", "square"),
            Family::Competitor(_) => self.method().map_or(("#808080", "circle"), |m| m.marker),
            Family::Given => ("#202020", "circle"),
        }
    }

    /// Every family in the order of tables and legends: ours, the grids,
    /// the competitors in the list's order, a given set.
    pub fn all() -> Vec<Family> {
        let mut out = vec![Family::Ours, Family::Grid];
        out.extend(
            METHODS
                .iter()
                .filter(|m| m.role == Role::Competitor)
                .map(|m| Family::Competitor(m.word)),
        );
        out.push(Family::Given);
        out
    }
}

impl Serialize for Family {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.key())
    }
}
