//! The list of placement methods: one line per method, `Variant => Type`,
//! where `Type` implements [`super::method::Method`] in the method's own
//! file. The config form (`placement: Variant((..))`), `--method`, the
//! reports' names, the docs' table of methods (`docs::`) and the methods
//! `compare` runs as ours derive from it (docs/layout.md, "Adding a
//! placement method").

use super::method::methods;

methods! {
    SdfSkeleton => super::skeleton::sdf_skeleton::SdfSkeleton,
    MedialAxis => super::skeleton::medial_axis::MedialAxis,
    Grid => super::grid::Grid,
    Relocated => super::relocate::Relocated,
    Greedy => super::greedy::Greedy,
    Adaptive => super::adaptive::Adaptive,
}

impl Default for Placement {
    /// Ours, Wang et al. 2019's SDF skeleton, with its defaults.
    fn default() -> Self {
        Placement::SdfSkeleton(Default::default())
    }
}

/// Adding a method, walked through with a toy: the type in `toy` (its own
/// file in the crate) and the one line `Toy => super::toy::Toy` of a list
/// give it a config form, a `--method` form, a name, a place in the
/// unknown-method message and the docs' table, and a placement.
#[cfg(test)]
mod tests {
    mod toy {
        use crate::error::Result;
        use crate::placement::method::{Method, Role};
        use crate::probes::{PlacementInput, Probe, ProbeSet};
        use std::collections::BTreeMap;

        /// One probe at the domain's centre, raised by `lift`.
        #[derive(Debug, Clone, Copy, PartialEq, Default, serde::Deserialize)]
        #[serde(deny_unknown_fields, default)]
        pub struct ToyParams {
            pub lift: f32,
        }

        pub struct Toy;

        impl Method for Toy {
            type Params = ToyParams;
            const WORD: &'static str = "toy";
            const TAKES_ARGUMENT: bool = true;
            const FORM: &'static str = "toy:LIFT";
            const ABOUT: &'static str = "one probe at the domain's centre";
            const ROLE: Role = Role::None;

            fn name(p: &ToyParams) -> String {
                format!("toy:{}", p.lift)
            }

            fn parse_cli(
                argument: Option<&str>,
                _: Option<&ToyParams>,
            ) -> std::result::Result<ToyParams, String> {
                let lift = argument
                    .unwrap_or("")
                    .parse()
                    .map_err(|_| "the lift must be a number".to_string())?;
                Ok(ToyParams { lift })
            }

            fn place(p: &ToyParams, input: &PlacementInput) -> Result<ProbeSet> {
                let position = (input.domain.min + input.domain.max) * 0.5 + glam::Vec3::Y * p.lift;
                Ok(ProbeSet {
                    method: Self::name(p),
                    probes: vec![Probe {
                        position,
                        cluster_size: 0,
                    }],
                    stats: BTreeMap::new(),
                    params: BTreeMap::new(),
                    min_clearance: input.sdf.voxel_size,
                    fixed: 0,
                })
            }
        }
    }

    mod list {
        use crate::placement::method::methods;

        methods! {
            SdfSkeleton => crate::placement::skeleton::sdf_skeleton::SdfSkeleton,
            Toy => super::toy::Toy,
        }
    }

    use list::{Placement, METHODS};
    use toy::ToyParams;

    #[test]
    fn a_toy_method_is_one_type_and_one_line_of_the_list() {
        // The config form, with the method's own field checks.
        let p: Placement = ron::from_str("Toy((lift: 0.5))").unwrap();
        assert_eq!(p, Placement::Toy(ToyParams { lift: 0.5 }));
        assert!(ron::from_str::<Placement>("Toy((height: 1))").is_err());
        // The `--method` grammar, the name, and the refusals.
        let q = Placement::parse_cli("toy:0.25", &p).unwrap();
        assert_eq!(q, Placement::Toy(ToyParams { lift: 0.25 }));
        assert_eq!(q.name(), "toy:0.25");
        let e = Placement::parse_cli("toy:high", &p)
            .unwrap_err()
            .to_string();
        assert_eq!(e, "--method toy:high: the lift must be a number");
        let e = Placement::parse_cli("nope", &p).unwrap_err().to_string();
        assert!(e.ends_with("expected sdf-skeleton or toy:LIFT"), "{e}");
        // The docs' table and compare's line-up read the list.
        let words: Vec<&str> = METHODS.iter().map(|m| m.word).collect();
        assert_eq!(words, ["sdf-skeleton", "toy"]);
        assert_eq!(METHODS[1].variant, "Toy");
        // It places.
        let (scene, bvh, sdf) = crate::scene::testing::room_sdf(0.25, 1);
        let progress = crate::progress::Progress::hidden();
        let input = crate::scene::testing::input_over(&scene, &bvh, &sdf, 1, &progress);
        let set = q.place(&input).unwrap();
        // No rule for a probe count: `compare` does not run it as a competitor.
        assert_eq!(Placement::at_count("Toy", &input, &[], 5), None);
        assert_eq!(set.method, "toy:0.25");
        assert_eq!(set.probes.len(), 1);
        assert_eq!(
            set.probes[0].position.y,
            (scene.bounds.min.y + scene.bounds.max.y) * 0.5 + 0.25
        );
    }

    /// The crate's own list: the config forms and `--method` forms that
    /// docs/config.md and the README name.
    #[test]
    fn the_list_reads_the_config_and_command_line_forms_it_always_read() {
        use super::{Placement, METHODS};
        let variants: Vec<&str> = METHODS.iter().map(|m| m.variant).collect();
        assert_eq!(
            variants,
            [
                "SdfSkeleton",
                "MedialAxis",
                "Grid",
                "Relocated",
                "Greedy",
                "Adaptive"
            ]
        );
        let base = Placement::default();
        for (text, name) in [
            ("sdf-skeleton", "sdf-skeleton"),
            ("medial-axis", "medial-axis"),
            ("grid:4x2x4", "grid:4x2x4"),
            ("relocated:2x2x2", "relocated:2x2x2"),
            ("greedy:0.5", "greedy:0.5"),
            ("adaptive:0.25", "adaptive:0.25"),
        ] {
            assert_eq!(Placement::parse_cli(text, &base).unwrap().name(), name);
        }
        let e = Placement::parse_cli("octree", &base)
            .unwrap_err()
            .to_string();
        assert_eq!(
            e,
            "--method octree: unknown method; expected sdf-skeleton, medial-axis, grid:NxMxK, relocated:NxMxK, greedy:SPACING or adaptive:MIN_SPACING"
        );
    }
}
