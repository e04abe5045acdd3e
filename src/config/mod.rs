//! The run configuration: one RON file per run (documented field by field in
//! docs/config.md).
//!
//! Validation happens while deserializing, through small newtypes
//! ([`Positive`], [`Fraction`], [`Count`], [`Degrees`]) whose `TryFrom` rejects
//! out-of-range values. That way every mistake, an unknown field, a wrong type
//! or a value out of range, is reported with the field's path *and* the line
//! and column where the parser stood, in one line.
//!
//! By concern: the root [`Config`] and its loading here; every stage's
//! parameters in `params`; the validated numbers in `numbers`; where the
//! text writes a field in `locate`. The placement methods' parameters live
//! with their methods (`crate::placement`), re-exported here.

mod locate;
pub(crate) mod numbers;
pub(crate) mod params;

use crate::error::{Error, Result};
use locate::{check_voxel_size_word, field_before};
use serde::Deserialize;
use std::path::{Path, PathBuf};

pub use crate::export::Export;
pub use crate::placement::adaptive::AdaptiveConfig;
pub use crate::placement::greedy::GreedyParams;
pub use crate::placement::registry::Placement;
pub use crate::placement::skeleton::medial_axis::MedialAxisParams;
pub use crate::placement::skeleton::sdf_skeleton::SdfSkeletonParams;
pub use crate::placement::skeleton::surface_points::MAX_SURFACE_POINTS;
pub use locate::{locate, strip_bom};
pub use numbers::{
    short, short_all, Count, Degrees, Direction, Fraction, NonNegative, Point3, Positive,
    PowerOfTwo, Rgb, Scale, Whole,
};
pub use params::*;

/// Largest config file read: 16 MiB (a config is a page of text; its
/// longest lists, cameras and grids, are a few hundred lines).
pub const MAX_CONFIG_BYTES: u64 = 16 << 20;

/// One run's configuration, as read from a RON file.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Config {
    /// OBJ file, relative to the config file.
    #[serde(deserialize_with = "non_empty_path")]
    pub scene: PathBuf,
    /// Multiplies every coordinate of the file; all other lengths are in these scaled units.
    #[serde(default = "unit_scale")]
    pub scale: Scale,
    /// Which axis of the file points up.
    #[serde(default)]
    pub up: UpAxis,
    /// Where probes may go.
    #[serde(default)]
    pub domain: Domain,
    /// The free space that counts: what the cameras reach (default), what
    /// given points reach, or everywhere.
    #[serde(default)]
    pub reachable: Reach,
    /// The radius of a viewer that must fit through a passage for the
    /// space beyond to count as reached (world units; [`crate::reachable`]).
    /// `None`: one SDF voxel.
    #[serde(default)]
    pub viewer_radius: Option<NonNegative>,
    /// Edge length of an SDF voxel, in world units, or `Auto` (the
    /// default) to derive it from the scene.
    #[serde(default)]
    pub voxel_size: VoxelSize,
    /// Placement method; `SdfSkeleton(())` when left out.
    #[serde(default)]
    pub placement: Placement,
    /// Seed of every random choice.
    #[serde(default)]
    pub seed: u64,
    /// Output directory, relative to the config file.
    #[serde(default = "default_output", deserialize_with = "non_empty_path")]
    pub output: PathBuf,
    /// SDF classification parameters.
    #[serde(default)]
    pub sdf: SdfParams,
    /// Coverage estimation parameters.
    #[serde(default)]
    pub coverage: CoverageParams,
    /// Lights besides the scene's emissive materials.
    #[serde(default)]
    pub lights: Vec<Light>,
    /// Whether the scene file's own lights (glTF's `KHR_lights_punctual`)
    /// light the scene besides `lights` (`Use`, the default), or `lights`
    /// replace them (`Ignore`).
    #[serde(default)]
    pub scene_lights: SceneLights,
    /// Refinement, pruning and filling.
    #[serde(default)]
    pub refine: RefineParams,
    /// The sparse voxel octree of probe indices.
    #[serde(default)]
    pub svo: SvoParams,
    /// The light-field probe bake.
    #[serde(default)]
    pub bake: BakeParams,
    /// The path-traced reference image.
    #[serde(default)]
    pub reference: ReferenceParams,
    /// The comparison with uniform grids and other placements.
    #[serde(default)]
    pub compare: CompareParams,
    /// Artist control: probes kept exactly here (world coordinates), first
    /// in `probes.json`, never moved or pruned, and counted by coverage, so
    /// the placer adds only what they miss.
    #[serde(default)]
    pub fixed_probes: Vec<Point3>,
    /// Artist control: regions no probe may stand in.
    #[serde(default)]
    pub exclude: Vec<Region>,
    /// Artist control: the most probes the run may keep; above it, the
    /// placer keeps the ones that cover the most.
    #[serde(default)]
    pub max_probes: Option<Count<{ crate::limits::MAX_PROBES as u32 }>>,
    /// Artist control: the fewest probes the run keeps; below it, the
    /// placer adds the ones that sharpen the views most (needs refinement).
    #[serde(default)]
    pub min_probes: Option<Count<{ crate::limits::MAX_PROBES as u32 }>>,
    /// Artist control: regions whose surfaces must be seen by more probes
    /// (factor above 1) or fewer (below 1); overlapping factors multiply.
    #[serde(default)]
    pub probe_density: Vec<(Region, Density)>,
    /// Files for other tools that `place`, `bake` and `render` write with
    /// their outputs; none by default.
    #[serde(default)]
    pub export: Vec<Export>,
}

fn unit_scale() -> Scale {
    Scale(1.0)
}

fn default_output() -> PathBuf {
    PathBuf::from("out")
}

/// A path field that must name something: `""` resolves to the config's
/// own directory, which as `output` the run would replace and as `scene`
/// is no file, so it is refused where it is written.
fn non_empty_path<'de, D: serde::Deserializer<'de>>(d: D) -> Result<PathBuf, D::Error> {
    let p = PathBuf::deserialize(d)?;
    if p.as_os_str().is_empty() {
        return Err(serde::de::Error::custom("must not be empty"));
    }
    Ok(p)
}

impl Config {
    /// The viewer's radius the reachable space is flooded with
    /// (`viewer_radius`, else one voxel of `voxel_size`).
    pub fn viewer_radius(&self, voxel_size: f32) -> f32 {
        self.viewer_radius.map_or(voxel_size, |r| r.0)
    }

    /// Parses `text` (the contents of `file`). Relative paths stay relative;
    /// [`Config::load`] resolves them against the config's directory.
    ///
    /// Errors are [`Error::User`] lines of the form
    /// `file:LINE:COL: field.path: problem`.
    pub fn parse(text: &str, file: &Path) -> Result<Config> {
        let text = strip_bom(text);
        let located = |span: ron::error::Span, path: &str, msg: &dyn std::fmt::Display| {
            // serde_path_to_error writes `?` for a position it could not
            // name (inside a value that never began); the line says where.
            let path = path.trim_end_matches('?').trim_end_matches('.');
            // A syntax error at the top level (`max_probes: 1.5,` reads
            // `1`, then fails at `.5`) has no path: name the field written
            // before it. Deeper, the path names the enclosing field.
            let path = match path {
                "" | "." => field_before(text, span.start.line, span.start.col).unwrap_or_default(),
                p => p.to_string(),
            };
            let field = if path.is_empty() {
                String::new()
            } else {
                format!("{path}: ")
            };
            Error::User(format!(
                "{}:{}:{}: {field}{msg}",
                file.display(),
                span.start.line,
                span.start.col
            ))
        };
        // Optional fields take plain values (`min_distance: 0.02`), not `Some(0.02)`.
        if let Some((line, col, word)) = check_voxel_size_word(text) {
            return Err(Error::User(format!(
                "{}:{line}:{col}: voxel_size: expected Auto or a voxel edge length in world units (a number greater than 0), got `{word}`",
                file.display()
            )));
        }
        let options = ron::Options::default()
            .with_default_extension(ron::extensions::Extensions::IMPLICIT_SOME);
        let mut de = ron::Deserializer::from_str_with_options(text, &options)
            .map_err(|e| located(e.span, "", &e.code))?;
        let config: Config = match serde_path_to_error::deserialize(&mut de) {
            Ok(c) => c,
            Err(e) => {
                let path = e.path().to_string();
                let spanned = de.span_error(e.into_inner());
                return Err(located(spanned.span, &path, &spanned.code));
            }
        };
        if let Err(e) = de.end() {
            let spanned = de.span_error(e);
            return Err(located(spanned.span, "", &spanned.code));
        }
        Ok(config)
    }

    /// Reads and parses the config at `file`, then resolves `scene` and
    /// `output` against the config file's directory.
    pub fn load(file: &Path) -> Result<Config> {
        let text = crate::input::read_text(file, "config", MAX_CONFIG_BYTES)?;
        Config::from_text(&text, file)
    }

    /// [`Config::parse`] of `text` as the contents of `file`, with the
    /// relative paths resolved against `file`'s directory as
    /// [`Config::load`] does (used to rebuild a run's config from its
    /// provenance).
    pub fn from_text(text: &str, file: &Path) -> Result<Config> {
        let mut config = Config::parse(text, file)?;
        let dir = file.parent().unwrap_or(Path::new(""));
        config.scene = normalize(&dir.join(&config.scene));
        config.output = normalize(&dir.join(&config.output));
        Ok(config)
    }
}

/// Removes `.` and resolvable `..` components without touching the file
/// system, so messages say `fixtures/a.obj` rather than `configs/../fixtures/a.obj`.
pub fn normalize(path: &Path) -> PathBuf {
    use std::path::Component;
    let mut out: Vec<Component> = Vec::new();
    for c in path.components() {
        match c {
            Component::CurDir => {}
            Component::ParentDir if matches!(out.last(), Some(Component::Normal(_))) => {
                out.pop();
            }
            other => out.push(other),
        }
    }
    if out.is_empty() {
        PathBuf::from(".")
    } else {
        out.iter().collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const MINIMAL: &str = r#"(
        scene: "a.obj",
        voxel_size: 0.1,
        placement: SdfSkeleton(()),
    )"#;

    fn parse(text: &str) -> Result<Config> {
        Config::parse(text, Path::new("c.ron"))
    }

    fn user_message(r: Result<Config>) -> String {
        match r {
            Err(Error::User(m)) => m,
            other => panic!("expected a user error, got {other:?}"),
        }
    }

    #[test]
    fn a_syntax_error_names_the_field_it_is_in() {
        // `1.5` reads as `1`, then `.5` is a syntax error with no path.
        let m = user_message(parse("(\n    scene: \"a.obj\",\n    max_probes: 1.5,\n)"));
        assert!(m.starts_with("c.ron:3:18: max_probes: "), "{m}");
        let m = user_message(parse(
            "(\n    scene: \"a:b.obj\", refine: (iterations: 2 3),\n)",
        ));
        assert!(m.contains(":2:") && m.contains("refine: "), "{m}");
        // A `:` inside a string is no field; nothing before it, no name.
        assert_eq!(
            field_before("    x: \"y: z\" ]", 1, 16).as_deref(),
            Some("x")
        );
        assert_eq!(field_before("  ]", 1, 3), None);
        assert_eq!(field_before("", 9, 3), None);
    }

    #[test]
    fn minimal_config_takes_documented_defaults() {
        let c = parse(MINIMAL).unwrap();
        assert_eq!(c.scale, Scale(1.0));
        assert_eq!(c.up, UpAxis::Y);
        assert_eq!(c.domain, Domain::Auto);
        assert_eq!(c.sdf, SdfParams::default());
        assert_eq!(c.coverage.samples, Count(40_000));
        assert_eq!(c.placement.name(), "sdf-skeleton");
        assert_eq!(c.voxel_size, VoxelSize::Fixed(Positive(0.1)));
        let stock = parse("(scene: \"a.obj\")").unwrap();
        assert_eq!(stock.voxel_size, VoxelSize::Auto);
        assert_eq!(stock.placement, Placement::default());
    }

    #[test]
    fn voxel_size_takes_auto_or_a_length() {
        let with =
            |v: &str| parse(&MINIMAL.replace("voxel_size: 0.1", &format!("voxel_size: {v}")));
        assert_eq!(with("Auto").unwrap().voxel_size, VoxelSize::Auto);
        assert_eq!(
            with("2").unwrap().voxel_size,
            VoxelSize::Fixed(Positive(2.0))
        );
        for bad in [
            "Automatic",
            "0",
            "-0.5",
            "\"0.1\"",
            "Auto(0.1)",
            "inf",
            "(0.1)",
        ] {
            let m = user_message(with(bad));
            assert!(m.starts_with("c.ron:3:"), "{bad}: {m}");
            assert!(m.contains("voxel_size"), "{bad}: {m}");
        }
    }

    #[test]
    fn unknown_field_names_field_line_and_column() {
        let m = user_message(parse("(\n  scene: \"a.obj\",\n  voxel_sise: 0.1,\n)"));
        assert!(m.starts_with("c.ron:3:"), "{m}");
        assert!(m.contains("voxel_sise"), "{m}");
    }

    #[test]
    fn out_of_range_value_names_field_and_position() {
        let text = MINIMAL.replace("voxel_size: 0.1", "voxel_size: -0.1");
        let m = user_message(parse(&text));
        assert!(m.contains("voxel_size"), "{m}");
        assert!(m.contains("greater than 0"), "{m}");
        assert!(m.starts_with("c.ron:3:"), "{m}");
    }

    #[test]
    fn wrong_type_is_reported() {
        let text = MINIMAL.replace("voxel_size: 0.1", "voxel_size: \"big\"");
        let m = user_message(parse(&text));
        assert!(m.contains("voxel_size"), "{m}");
    }

    #[test]
    fn nested_fields_are_validated() {
        let text = MINIMAL.replace(
            "placement: SdfSkeleton(())",
            "placement: Grid((cells: (2, 0, 2)))",
        );
        let m = user_message(parse(&text));
        assert!(m.contains("placement") && m.contains("from 1 to"), "{m}");
        let text = MINIMAL.replace(
            "voxel_size: 0.1,",
            "voxel_size: 0.1, coverage: (samples: 900000000),",
        );
        let m = user_message(parse(&text));
        assert!(
            m.contains("coverage.samples") && m.contains("5000000"),
            "{m}"
        );
        let text = MINIMAL.replace(
            "voxel_size: 0.1,",
            "voxel_size: 0.1, domain: Box((min: (0,0,0), max: (1,0,1))),",
        );
        let m = user_message(parse(&text));
        assert!(m.contains("domain") && m.contains("min < max"), "{m}");
    }

    #[test]
    fn medial_axis_parameters_parse_and_validate() {
        let text = MINIMAL.replace(
            "placement: SdfSkeleton(())",
            "placement: MedialAxis((precluster_radius: 0.5, precluster_angle_deg: 45, max_iterations: 10))",
        );
        let c = parse(&text).unwrap();
        let Placement::MedialAxis(p) = c.placement else {
            panic!("{:?}", c.placement)
        };
        assert_eq!(p.precluster_radius, Some(Positive(0.5)));
        assert_eq!(p.precluster_angle_deg, Degrees(45.0));
        assert_eq!(p.max_iterations, Count(10));
        assert_eq!(p.cluster_radius, MedialAxisParams::default().cluster_radius);
        let text = MINIMAL.replace(
            "placement: SdfSkeleton(())",
            "placement: MedialAxis((min_separation_deg: 120))",
        );
        let m = user_message(parse(&text));
        assert!(
            m.contains("placement.MedialAxis.min_separation_deg") && m.contains("90"),
            "{m}"
        );
    }

    #[test]
    fn trailing_garbage_is_an_error() {
        let m = user_message(parse(&format!("{MINIMAL} )")));
        assert!(m.starts_with("c.ron:"), "{m}");
    }

    #[test]
    fn paths_are_normalized_lexically() {
        assert_eq!(
            normalize(Path::new("configs/../fixtures/a.obj")),
            Path::new("fixtures/a.obj")
        );
        assert_eq!(
            normalize(Path::new("configs/../../shared/x")),
            Path::new("../shared/x")
        );
        assert_eq!(normalize(Path::new("./a/./b")), Path::new("a/b"));
        assert_eq!(normalize(Path::new("/r/a/../b")), Path::new("/r/b"));
        assert_eq!(normalize(Path::new("a/..")), Path::new("."));
    }

    #[test]
    fn cli_method_parsing() {
        let base = Placement::SdfSkeleton(SdfSkeletonParams::default());
        let g = Placement::parse_cli("grid:4x2x3", &base).unwrap();
        assert_eq!(g.name(), "grid:4x2x3");
        assert!(Placement::parse_cli("grid:4x2", &base).is_err());
        assert!(Placement::parse_cli("grid:0x2x2", &base).is_err());
        assert!(Placement::parse_cli("voronoi", &base).is_err());
        assert!(Placement::parse_cli("grid:2000x1x1", &base).is_err());
        assert!(Placement::parse_cli("grid:1024x1024x2", &base).is_err());
        assert!(Placement::parse_cli("grid:256x256x1", &base).is_ok());
        assert!(Placement::parse_cli("grid:1024x1024x1", &base).is_err());
        assert_eq!(Placement::parse_cli("sdf-skeleton", &g).unwrap(), base);
        let m = Placement::parse_cli("medial-axis", &base).unwrap();
        assert_eq!(m, Placement::MedialAxis(MedialAxisParams::default()));
        assert_eq!(m.name(), "medial-axis");
        let tuned = Placement::MedialAxis(MedialAxisParams {
            cluster_radius: Positive(3.0),
            ..MedialAxisParams::default()
        });
        assert_eq!(Placement::parse_cli("medial-axis", &tuned).unwrap(), tuned);
    }

    fn cli_error(text: &str) -> String {
        let base = Placement::SdfSkeleton(SdfSkeletonParams::default());
        match Placement::parse_cli(text, &base) {
            Err(Error::User(m)) => {
                assert!(!m.contains('\n'), "one line: {m}");
                assert!(m.starts_with(&format!("--method {text}: ")), "{m}");
                m
            }
            other => panic!("{text}: expected a user error, got {other:?}"),
        }
    }

    #[test]
    fn cli_competitor_methods_round_trip_and_reject_mistakes() {
        let base = Placement::SdfSkeleton(SdfSkeletonParams::default());
        let r = Placement::parse_cli("relocated:2x3x4", &base).unwrap();
        assert_eq!(
            r,
            Placement::Relocated(GridParams {
                cells: (Count(2), Count(3), Count(4))
            })
        );
        assert_eq!(r.name(), "relocated:2x3x4");
        assert_eq!(Placement::parse_cli(&r.name(), &base).unwrap(), r);
        let g = Placement::parse_cli("greedy:0.5", &base).unwrap();
        assert_eq!(
            g,
            Placement::Greedy(GreedyParams {
                spacing: Positive(0.5)
            })
        );
        assert_eq!(g.name(), "greedy:0.5");
        assert_eq!(Placement::parse_cli(&g.name(), &base).unwrap(), g);
        let g = Placement::parse_cli("greedy:0.15", &base).unwrap();
        assert_eq!(g.name(), "greedy:0.15");

        let m = cli_error("greedy:-1");
        assert!(m.contains("greater than 0"), "{m}");
        let m = cli_error("greedy:abc");
        assert!(m.contains("greedy:0.5"), "{m}");
        assert!(cli_error("greedy:0").contains("greater than 0"));
        assert!(cli_error("greedy:").contains("greedy:0.5"));
        let m = cli_error("relocated:2x2");
        assert!(m.contains("relocated:NxMxK"), "{m}");
        let m = cli_error("relocated:2xax2");
        assert!(
            m.contains("whole numbers") && m.contains("relocated:4x4x4"),
            "{m}"
        );
        assert!(cli_error("relocated:0x2x2").contains("from 1 to"));
        assert!(cli_error("relocated:1024x1024x2").contains("exceeds"));
        let m = cli_error("voronoi");
        assert!(
            m.contains("relocated:NxMxK") && m.contains("greedy:SPACING"),
            "{m}"
        );
        // The adaptive baseline keeps the config's levels.
        let a = Placement::parse_cli("adaptive:0.25", &base).unwrap();
        assert_eq!(a.name(), "adaptive:0.25");
        assert_eq!(Placement::parse_cli(&a.name(), &base).unwrap(), a);
        let two = Placement::Adaptive(AdaptiveConfig {
            min_spacing: Positive(1.0),
            levels: Count(2),
        });
        match Placement::parse_cli("adaptive:0.5", &two).unwrap() {
            Placement::Adaptive(c) => assert_eq!((c.min_spacing.0, c.levels.0), (0.5, 2)),
            other => panic!("{other:?}"),
        }
        assert!(cli_error("adaptive:-1").contains("greater than 0"));
        assert!(cli_error("adaptive:x").contains("adaptive:0.5"));
    }

    #[test]
    fn competitor_methods_parse_from_ron() {
        let text = MINIMAL.replace(
            "placement: SdfSkeleton(())",
            "placement: Relocated((cells: (4, 4, 4)))",
        );
        assert_eq!(parse(&text).unwrap().placement.name(), "relocated:4x4x4");
        let text = MINIMAL.replace(
            "placement: SdfSkeleton(())",
            "placement: Greedy((spacing: 0.5))",
        );
        assert_eq!(parse(&text).unwrap().placement.name(), "greedy:0.5");
        let text = MINIMAL.replace(
            "placement: SdfSkeleton(())",
            "placement: Greedy((spacing: -0.5))",
        );
        let m = user_message(parse(&text));
        assert!(
            m.contains("placement.Greedy.spacing") && m.contains("greater than 0"),
            "{m}"
        );
        let text = MINIMAL.replace(
            "placement: SdfSkeleton(())",
            "placement: Greedy((spacing: 0.5, radius: 2))",
        );
        let m = user_message(parse(&text));
        assert!(m.contains("radius"), "{m}");
        let text = MINIMAL.replace(
            "placement: SdfSkeleton(())",
            "placement: Relocated((cells: (4, 4)))",
        );
        assert!(user_message(parse(&text)).contains("placement"));
    }

    /// Every struct and every struct variant of the config, each with an
    /// unknown field `bogus` on line 3, and the path the message must name.
    const UNKNOWN_FIELD_CASES: [(&str, &str); 23] = [
        ("bogus: 1,", "bogus"),
        ("domain: Box((min: (0, 0, 0), max: (1, 1, 1), bogus: 1)),", "domain.Box.bogus"),
        ("placement: SdfSkeleton((bogus: 1)),", "placement.SdfSkeleton.bogus"),
        ("placement: MedialAxis((bogus: 1)),", "placement.MedialAxis.bogus"),
        ("placement: Grid((cells: (1, 1, 1), bogus: 1)),", "placement.Grid.bogus"),
        ("placement: Relocated((cells: (1, 1, 1), bogus: 1)),", "placement.Relocated.bogus"),
        ("placement: Greedy((spacing: 1, bogus: 1)),", "placement.Greedy.bogus"),
        ("sdf: (bogus: 1),", "sdf.bogus"),
        ("coverage: (bogus: 1),", "coverage.bogus"),
        ("refine: (bogus: 1),", "refine.bogus"),
        ("svo: (bogus: 1),", "svo.bogus"),
        ("bake: (bogus: 1),", "bake.bogus"),
        ("reference: (bogus: 1),", "reference.bogus"),
        ("reference: (camera: (position: (0, 0, 0), look_at: (1, 1, 1), bogus: 1)),", "reference.camera.bogus"),
        ("compare: (bogus: 1),", "compare.bogus"),
        ("compare: (grids: [(cells: (1, 1, 1), bogus: 1)]),", "compare.grids[0].bogus"),
        ("compare: (cameras: [(position: (0, 0, 0), look_at: (1, 1, 1), bogus: 1)]),", "compare.cameras[0].bogus"),
        ("lights: [Point(position: (0, 0, 0), intensity: (1, 1, 1), bogus: 1)],", "lights[0].Point.bogus"),
        ("lights: [Spot(position: (0, 0, 0), direction: (0, -1, 0), intensity: (1, 1, 1), cone_degrees: 30, edge_degree: 20)],", "lights[0].Spot.edge_degree"),
        ("lights: [Sky(radiance: (1, 1, 1)), Spot(position: (0, 0, 0), direction: (0, -1, 0), intensity: (1, 1, 1), cone_degrees: 30, bogus: 1)],", "lights[1].Spot.bogus"),
        ("lights: [Directional(direction: (0, -1, 0), irradiance: (1, 1, 1), bogus: 1)],", "lights[0].Directional.bogus"),
        ("lights: [Sky(radiance: (1, 1, 1), bogus: 1)],", "lights[0].Sky.bogus"),
        ("lights: [Sky(radiance: (1, 1, 1)), Sky(radiance: (1, 1, 1), bogus: 1)],", "lights[1].Sky.bogus"),
    ];

    #[test]
    fn every_struct_and_variant_refuses_unknown_fields() {
        for (field, path) in UNKNOWN_FIELD_CASES {
            let text = format!("(\n    scene: \"a.obj\",\n    {field}\n)");
            let m = user_message(parse(&text));
            let name = path.rsplit('.').next().unwrap();
            assert!(m.contains(&format!("{path}: ")), "{field}: {m}");
            assert!(m.contains(&format!("`{name}`")), "{field}: {m}");
            // The column RON reports lies on the unknown name (where it
            // stands after reading it), which the locator finds too.
            let (line, col) = locate(&text, path).expect(path);
            assert_eq!(line, 3, "{path}");
            let end = col + name.chars().count();
            let at = m.strip_prefix("c.ron:3:").expect(&m);
            let reported: usize = at.split(':').next().unwrap().parse().expect(&m);
            assert!(
                (col..=end).contains(&reported),
                "{path}: {m}, name at {col}"
            );
        }
    }

    #[test]
    fn a_byte_order_mark_is_skipped_and_columns_count_after_it() {
        let plain = parse(MINIMAL).unwrap();
        assert_eq!(parse(&format!("\u{feff}{MINIMAL}")).unwrap(), plain);
        let bad = "(scene: \"a.obj\", voxel_size: -1)";
        let without = user_message(parse(bad));
        let with = user_message(parse(&format!("\u{feff}{bad}")));
        assert!(without.starts_with("c.ron:1:"), "{without}");
        assert_eq!(with, without);
        assert_eq!(
            locate(&format!("\u{feff}{bad}"), "voxel_size"),
            Some((1, 18))
        );
        // A mark anywhere else is no mark: still an error.
        assert!(parse(&format!(" \u{feff}{MINIMAL}")).is_err());
    }

    #[test]
    fn empty_paths_are_refused_where_written() {
        let text = "(\n    scene: \"a.obj\",\n    output: \"\",\n)";
        let m = user_message(parse(text));
        assert!(m.starts_with("c.ron:3:"), "{m}");
        assert!(m.ends_with("output: must not be empty"), "{m}");
        let m = user_message(parse("(\n    scene: \"\",\n)"));
        assert!(
            m.starts_with("c.ron:2:") && m.ends_with("scene: must not be empty"),
            "{m}"
        );
        assert_eq!(
            parse("(scene: \"a.obj\", output: \"o\")").unwrap().output,
            Path::new("o")
        );
    }

    #[test]
    fn short_numbers() {
        assert_eq!(short(1e300), "1e300");
        assert_eq!(short(1e-300), "1e-300");
        assert_eq!(short(-5.0), "-5");
        assert_eq!(short(0.25), "0.25");
        assert_eq!(short(1.5e-12), "1.5e-12");
        assert_eq!(short(-2.5e7), "-2.5e7");
        assert_eq!(short(999_999.0), "999999");
        assert_eq!(short(1e6), "1e6");
        assert_eq!(short(0.0001), "0.0001");
        assert_eq!(short(0.00005), "5e-5");
        assert_eq!(short(0.0), "0");
        assert_eq!(short(f64::INFINITY), "inf");
        assert_eq!(short(f64::NEG_INFINITY), "-inf");
        assert_eq!(short(f64::NAN), "NaN");
        // An f32 prints its own shortest digits, not its f64 widening's.
        assert_eq!(short(0.1f32), "0.1");
        assert_eq!(short(3e38f32), "3e38");
        assert_eq!(short_all(&[0.0, 1e300, 2.5]), "(0, 1e300, 2.5)");
    }

    #[test]
    fn huge_and_tiny_numbers_are_refused_in_short_form() {
        for (value, shown) in [
            ("1e300", "1e300"),
            ("1e-300", "1e-300"),
            ("-1e300", "-1e300"),
        ] {
            let m = user_message(parse(&MINIMAL.replace("0.1", value)));
            assert!(m.starts_with("c.ron:3:") && m.contains("voxel_size"), "{m}");
            assert!(m.ends_with(&format!("got {shown}")), "{m}");
            assert!(m.len() < 160, "{m}");
        }
        // An angle that single precision rounds to 0 is no angle.
        let text = MINIMAL.replace(
            "placement: SdfSkeleton(())",
            "placement: MedialAxis((precluster_angle_deg: 1e-300))",
        );
        let m = user_message(parse(&text));
        assert!(
            m.contains("precluster_angle_deg") && m.ends_with("got 1e-300"),
            "{m}"
        );
        let text = MINIMAL.replace(
            "voxel_size: 0.1,",
            "voxel_size: 0.1, domain: Box((min: (0, 0, 0), max: (1, 1e300, 1))),",
        );
        let m = user_message(parse(&text));
        assert!(m.contains("(1, 1e300, 1)") && m.len() < 200, "{m}");
    }

    /// A config with comments, strings holding brackets and field names,
    /// nested variants, lists and raw strings, for [`locate`].
    const TRICKY: &str = r##"// voxel_size: 1 in a comment
(
    /* placement: Grid((cells: (1, 1, 1))), /* nested */ still a comment */
    scene: "room(.obj: [x",
    voxel_size: 0.1,
    placement: SdfSkeleton((
        min_distance: 0.4,
    )),
    output: r#"out"put: ("#,
    lights: [
        Sky(radiance: (1, 1, 1)),
        Spot(position: (0, 1.5e-3, -2), direction: (0, -1, 0), intensity: (1, 1, 1), cone_degrees: 30),
    ],
    reference: (camera: Some((position: (0, 0, 0), look_at: (1, 1, 1)))),
    compare: (grids: [(cells: (1, 2, 3))], cameras: []),
)
"##;

    #[test]
    fn locate_finds_fields_as_messages_name_them() {
        assert_eq!(locate(TRICKY, "voxel_size"), Some((5, 5)));
        assert_eq!(locate(TRICKY, "scene"), Some((4, 5)));
        assert_eq!(locate(TRICKY, "placement"), Some((6, 5)));
        assert_eq!(locate(TRICKY, "placement.min_distance"), Some((7, 9)));
        assert_eq!(
            locate(TRICKY, "placement.SdfSkeleton.min_distance"),
            Some((7, 9))
        );
        assert_eq!(locate(TRICKY, "output"), Some((9, 5)));
        assert_eq!(locate(TRICKY, "lights"), Some((10, 5)));
        assert_eq!(locate(TRICKY, "lights[0]"), Some((11, 9)));
        assert_eq!(locate(TRICKY, "lights[1]"), Some((12, 9)));
        assert_eq!(
            locate(TRICKY, "lights[1].Spot.cone_degrees"),
            Some((12, 86))
        );
        assert_eq!(locate(TRICKY, "lights[1].cone_degrees"), Some((12, 86)));
        assert_eq!(locate(TRICKY, "lights[0].radiance"), Some((11, 13)));
        assert_eq!(locate(TRICKY, "reference.camera"), Some((14, 17)));
        assert_eq!(locate(TRICKY, "reference.camera.look_at"), Some((14, 52)));
        assert_eq!(locate(TRICKY, "compare.grids[0].cells"), Some((15, 24)));
        assert_eq!(locate(TRICKY, "compare.cameras"), Some((15, 44)));
    }

    #[test]
    fn locate_finds_nothing_that_is_not_written() {
        // Defaults, fields only in comments or strings, wrong nesting.
        for path in [
            "seed",
            "domain",
            "refine.texel_size",
            "placement.Grid.cells",
            "placement.cluster_radius",
            "lights[2]",
            "lights[0].position",
            "min_distance",
            "cells",
            "reference.width",
            "compare.cameras[0]",
            "",
            "voxel_size.",
            "lights[x]",
            "lights]",
        ] {
            assert_eq!(locate(TRICKY, path), None, "{path}");
        }
        assert_eq!(locate("(", "scene"), None);
        assert_eq!(locate("(scene: \"unterminated", "voxel_size"), None);
    }

    #[test]
    fn the_locator_agrees_with_the_parser_on_every_shipped_config() {
        // Each top-level field the parser read from a shipped config is
        // found on the line that writes `NAME:`, ignoring comments.
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("configs");
        let mut checked = 0;
        for entry in std::fs::read_dir(dir).unwrap() {
            let path = entry.unwrap().path();
            if path.extension().is_none_or(|e| e != "ron") {
                continue;
            }
            let text = std::fs::read_to_string(&path).unwrap();
            parse(&text).unwrap();
            for field in [
                "scene",
                "voxel_size",
                "placement",
                "output",
                "lights",
                "reference",
            ] {
                let written = text.lines().enumerate().find(|(_, l)| {
                    let code = l.split("//").next().unwrap();
                    code.trim_start().starts_with(&format!("{field}:"))
                });
                let found = locate(&text, field);
                match written {
                    Some((n, l)) => {
                        let col = l.len() - l.trim_start().len() + 1;
                        assert_eq!(found, Some((n + 1, col)), "{}: {field}", path.display());
                        checked += 1;
                    }
                    None => assert_eq!(found, None, "{}: {field}", path.display()),
                }
            }
        }
        assert!(checked > 5, "{checked}");
    }
}
