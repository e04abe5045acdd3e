//! What a placement method is: one type implementing [`Method`], listed
//! once in [`super::registry`]. The config form (`placement: Variant(..)`),
//! the `--method` grammar, the method's name in reports, the docs' table of
//! methods and the methods `compare` runs as ours all derive from that
//! list (docs/layout.md, "Adding a placement method").

use crate::config::params::GridParams;
use crate::error::Result;
use crate::probes::{PlacementInput, ProbeSet};

/// How `compare` uses a method.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Role {
    /// Ours (Wang et al. 2019 §3.1): placed, refined, and held against the
    /// others.
    Ours,
    /// A uniform grid: the sweep of grids `compare` measures.
    Grid,
    /// A competitor `compare` places at our probe count.
    Competitor,
    /// Not part of `compare`'s line-up (a method being tried out).
    None,
}

/// One placement method.
///
/// Contract: [`Method::place`] is deterministic in `input` (seed
/// included) whatever the thread count; [`Method::parse_cli`] refuses in
/// one line, without the `--method TEXT: ` prefix the registry adds.
pub trait Method {
    /// Its parameters, as the config writes them inside the variant
    /// (`placement: Grid((cells: (4, 2, 4)))`).
    type Params: Copy;
    /// The word `--method` takes and reports name it by (`sdf-skeleton`).
    const WORD: &'static str;
    /// Whether `--method` takes an argument after `WORD:` (`grid:4x2x4`).
    const TAKES_ARGUMENT: bool;
    /// The `--method` form the usage and the unknown-method message show
    /// (`grid:NxMxK`).
    const FORM: &'static str;
    /// One line for the docs' table of methods: what it is, after whom.
    const ABOUT: &'static str;
    /// How `compare` uses it.
    const ROLE: Role;
    /// Its name in `compare`'s tables and legends (`greedy (Silvennoinen
    /// & Lehtinen)`).
    const LABEL: &'static str = Self::WORD;
    /// Its colour and marker (`circle`, `square`, `diamond`, `triangle`)
    /// in `compare`'s plots.
    const MARKER: (&'static str, &'static str) = ("#808080", "circle");

    /// The configured method's name in reports (`grid:4x2x4`).
    fn name(params: &Self::Params) -> String;

    /// Parameters from the `--method` argument (`None` without one), where
    /// `base` holds the config's own parameters when the config already
    /// names this method (they fill what the argument does not give).
    fn parse_cli(
        argument: Option<&str>,
        base: Option<&Self::Params>,
    ) -> std::result::Result<Self::Params, String>;

    /// Places the probes.
    fn place(params: &Self::Params, input: &PlacementInput) -> Result<ProbeSet>;

    /// For a [`Role::Competitor`]: the parameters that place about
    /// `count` probes over `input`, given the grids `compare` swept (each
    /// with the probes it placed); `None` where none do, and for every
    /// other role. `compare` places each competitor so, at our count.
    fn at_count(
        _input: &PlacementInput,
        _grids: &[(usize, GridParams)],
        _count: usize,
    ) -> Option<Self::Params> {
        None
    }
}

/// A method of the list, as the command line, the docs and `compare` see
/// it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Entry {
    /// The config's variant name (`SdfSkeleton`).
    pub variant: &'static str,
    /// [`Method::WORD`].
    pub word: &'static str,
    /// [`Method::FORM`].
    pub form: &'static str,
    /// [`Method::ABOUT`].
    pub about: &'static str,
    /// [`Method::ROLE`].
    pub role: Role,
    /// [`Method::LABEL`].
    pub label: &'static str,
    /// [`Method::MARKER`].
    pub marker: (&'static str, &'static str),
}

/// The argument of `text` for a method of `word`: `Some(None)` for the
/// bare word of a method without arguments, `Some(Some(arg))` for
/// `word:arg` of one with, `None` when `text` names another method.
pub(crate) fn argument<'a>(text: &'a str, word: &str, takes: bool) -> Option<Option<&'a str>> {
    match takes {
        false => (text == word).then_some(None),
        true => text
            .strip_prefix(word)
            .and_then(|rest| rest.strip_prefix(':'))
            .map(Some),
    }
}

/// A length in world units given as a `--method` argument
/// (`greedy:0.5`): `what` names it in the refusals, `example` shows a
/// well-formed argument.
pub(crate) fn length_argument(
    argument: Option<&str>,
    what: &str,
    example: &str,
) -> std::result::Result<crate::config::numbers::Positive, String> {
    let v: f64 = argument
        .unwrap_or("")
        .parse()
        .map_err(|_| format!("the {what} must be a number in world units, e.g. {example}"))?;
    crate::config::numbers::Positive::try_from(v).map_err(|e| format!("spacing {e}"))
}

/// The forms of `entries` as one phrase: `a, b or c`.
pub(crate) fn forms(entries: &[Entry]) -> String {
    let forms: Vec<&str> = entries.iter().map(|e| e.form).collect();
    match forms.split_last() {
        Some((last, rest)) if !rest.is_empty() => format!("{} or {last}", rest.join(", ")),
        _ => forms.join(""),
    }
}

/// Declares the list of placement methods: each line `Variant => Type`
/// makes `Variant(Type::Params)` a variant of [`super::registry::Placement`]
/// and routes its name, `--method` form and placement to `Type`.
macro_rules! methods {
    ($($variant:ident => $method:ty),+ $(,)?) => {
        /// The placement method a config (`placement: Variant((..))`) or
        /// `--method` chooses, with its parameters: one variant per method
        /// of the list in this file, each variant's parameters its
        /// method's [`Method::Params`](super::method::Method::Params).
        #[derive(Debug, Clone, Copy, PartialEq, serde::Deserialize)]
        #[allow(missing_docs)]
        pub enum Placement {
            $($variant(<$method as $crate::placement::method::Method>::Params),)+
        }

        /// Every method of the list, in its order.
        pub const METHODS: &[$crate::placement::method::Entry] = &[
            $($crate::placement::method::Entry {
                variant: stringify!($variant),
                word: <$method as $crate::placement::method::Method>::WORD,
                form: <$method as $crate::placement::method::Method>::FORM,
                about: <$method as $crate::placement::method::Method>::ABOUT,
                role: <$method as $crate::placement::method::Method>::ROLE,
                label: <$method as $crate::placement::method::Method>::LABEL,
                marker: <$method as $crate::placement::method::Method>::MARKER,
            },)+
        ];

        impl Placement {
            /// The method's name as written on the command line and in
            /// reports.
            pub fn name(&self) -> String {
                use $crate::placement::method::Method;
                match self {
                    $(Placement::$variant(p) => <$method>::name(p),)+
                }
            }

            /// Places the probes of this method over `input`.
            pub fn place(
                &self,
                input: &$crate::probes::PlacementInput,
            ) -> $crate::error::Result<$crate::probes::ProbeSet> {
                use $crate::placement::method::Method;
                match self {
                    $(Placement::$variant(p) => <$method>::place(p, input),)+
                }
            }

            /// The method of the list named `variant` with the parameters
            /// that place about `count` probes ([`Method::at_count`](
            /// $crate::placement::method::Method::at_count)); `None` for a
            /// method that has no such rule, or where it finds none.
            pub fn at_count(
                variant: &str,
                input: &$crate::probes::PlacementInput,
                grids: &[(usize, $crate::config::params::GridParams)],
                count: usize,
            ) -> Option<Placement> {
                use $crate::placement::method::Method;
                $(
                    if variant == stringify!($variant) {
                        return <$method>::at_count(input, grids, count).map(Placement::$variant);
                    }
                )+
                None
            }

            /// Parses a method given on the command line (a form of
            /// [`METHODS`]); `base` supplies the method's parameters when
            /// the config already uses that method, otherwise they take
            /// their defaults.
            pub fn parse_cli(text: &str, base: &Placement) -> $crate::error::Result<Placement> {
                use $crate::placement::method::{argument, Method};
                let bad = |why: &str| $crate::error::Error::User(format!("--method {text}: {why}"));
                $(
                    if let Some(arg) = argument(
                        text,
                        <$method>::WORD,
                        <$method>::TAKES_ARGUMENT,
                    ) {
                        #[allow(unreachable_patterns)]
                        let base = match base {
                            Placement::$variant(p) => Some(p),
                            _ => None,
                        };
                        return <$method>::parse_cli(arg, base)
                            .map(Placement::$variant)
                            .map_err(|e| bad(&e));
                    }
                )+
                Err(bad(&format!(
                    "unknown method; expected {}",
                    $crate::placement::method::forms(METHODS)
                )))
            }
        }
    };
}

pub(crate) use methods;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn arguments_follow_the_word_and_a_colon_only_where_taken() {
        assert_eq!(argument("grid:4x4x4", "grid", true), Some(Some("4x4x4")));
        assert_eq!(argument("grid", "grid", true), None);
        assert_eq!(argument("gridiron:2", "grid", true), None);
        assert_eq!(argument("medial-axis", "medial-axis", false), Some(None));
        assert_eq!(argument("medial-axis:2", "medial-axis", false), None);
    }

    #[test]
    fn forms_read_as_a_list() {
        let e = |form| Entry {
            variant: "V",
            word: "w",
            form,
            about: "",
            role: Role::None,
            label: "",
            marker: ("", ""),
        };
        assert_eq!(forms(&[e("a")]), "a");
        assert_eq!(forms(&[e("a"), e("b"), e("c")]), "a, b or c");
    }
}
