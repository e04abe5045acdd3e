//! Every stage's parameters as the config writes them: the scene
//! (`up`, `domain`, `voxel_size`, regions), placement and its methods, the
//! SDF, coverage, refinement, the SVO, lights, cameras, bake, reference,
//! compare and exports. Each validates while it deserializes, through the
//! [`super::numbers`] types, so a mistake names its field and position.

use super::numbers::{
    short, short_all, Count, Degrees, Direction, Fraction, NonNegative, Point3, Positive,
    PowerOfTwo, Rgb, Whole,
};
use crate::error::Result;
use serde::Deserialize;

/// The SDF's voxel edge: chosen from the scene (`Auto`, the default; see
/// the `resolution` module) or given in world units.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum VoxelSize {
    /// Derived from the domain's volume and the scene's narrowest gaps.
    #[default]
    Auto,
    /// This edge length (world units).
    Fixed(Positive),
}

/// RON hands a bare identifier to `deserialize_any` as a unit, without its
/// name, so `Auto` arrives as `()`; [`super::Config::parse`] checks beforehand
/// that the identifier written is `Auto` (`locate::check_voxel_size_word`).
impl<'de> Deserialize<'de> for VoxelSize {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct Visitor;
        impl serde::de::Visitor<'_> for Visitor {
            type Value = VoxelSize;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("Auto or a voxel edge length in world units (a number greater than 0)")
            }
            fn visit_unit<E: serde::de::Error>(self) -> Result<VoxelSize, E> {
                Ok(VoxelSize::Auto)
            }
            fn visit_f64<E: serde::de::Error>(self, v: f64) -> Result<VoxelSize, E> {
                Positive::try_from(v)
                    .map(VoxelSize::Fixed)
                    .map_err(E::custom)
            }
            fn visit_u64<E: serde::de::Error>(self, v: u64) -> Result<VoxelSize, E> {
                self.visit_f64(v as f64)
            }
            fn visit_i64<E: serde::de::Error>(self, v: i64) -> Result<VoxelSize, E> {
                self.visit_f64(v as f64)
            }
        }
        d.deserialize_any(Visitor)
    }
}

/// Most grid cells along one axis.
pub const MAX_GRID_CELLS_PER_AXIS: u32 = 1024;
/// Most probes a grid may have.
pub const MAX_GRID_PROBES: u64 = crate::limits::MAX_PROBES as u64;

/// Which axis of the scene file points up. Internally everything is Y-up.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize, serde::Serialize)]
pub enum UpAxis {
    /// The file is Y-up (OBJ's usual convention, and all scenes of McGuire's archive).
    #[default]
    Y,
    /// The file is Z-up (common in CAD exports); it is rotated to Y-up on load.
    Z,
}

/// Which free space probes, coverage and receivers consider: the space a
/// viewer can reach ([`crate::reachable`]).
#[derive(Debug, Clone, PartialEq, Default, Deserialize)]
pub enum Reach {
    /// The space the config's cameras reach (`reference.camera`,
    /// `compare.cameras`); without a camera, the largest connected free
    /// region. Sealed voids are left out.
    #[default]
    Cameras,
    /// The space reached from these points (world coordinates), besides
    /// the cameras.
    From(Vec<Point3>),
    /// All free space, sealed voids included (Wang et al. 2019 §3.1).
    Everywhere,
}

/// The region of space in which probes may be placed and the SDF is built.
#[derive(Debug, Clone, Copy, PartialEq, Default, Deserialize)]
pub enum Domain {
    /// The scene's bounding box.
    #[default]
    Auto,
    /// An explicit box in world coordinates (after `scale` and `up`).
    Box(BoxDomain),
}

/// An explicit axis-aligned box in world coordinates, `min < max` on every
/// axis; f64 like every config point ([`Point3`]).
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(try_from = "RawBox")]
pub struct BoxDomain {
    /// Lower corner.
    pub min: [f64; 3],
    /// Upper corner.
    pub max: [f64; 3],
}

/// Named as the type it becomes, which messages name.
#[derive(Deserialize)]
#[serde(deny_unknown_fields, rename = "BoxDomain")]
struct RawBox {
    min: [f64; 3],
    max: [f64; 3],
}

impl TryFrom<RawBox> for BoxDomain {
    type Error = String;
    fn try_from(b: RawBox) -> Result<Self, String> {
        let finite = b
            .min
            .iter()
            .chain(&b.max)
            .all(|v| v.is_finite() && v.abs() <= f32::MAX as f64);
        if !finite || (0..3).any(|i| b.min[i] >= b.max[i]) {
            return Err(format!(
                "box needs finite min < max on every axis (below 3e38 in size), got min {} max {}",
                short_all(&b.min),
                short_all(&b.max)
            ));
        }
        Ok(BoxDomain {
            min: b.min,
            max: b.max,
        })
    }
}

/// A region of space an artist control applies to, written as the domain
/// is: `Box((min: (x, y, z), max: (x, y, z)))`, in world coordinates.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
pub enum Region {
    /// An axis-aligned box; a point on its faces is inside.
    Box(BoxDomain),
}

/// How many times over a `probe_density` region asks its surfaces to be
/// seen: a finite number from 0 to [`MAX_DENSITY`].
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(try_from = "f64")]
pub struct Density(pub f32);

/// Largest `probe_density` factor: a point blends at most
/// [`SvoParams::max_probes`] (8) probes, so more views of a surface than
/// that add probes no lookup uses.
pub const MAX_DENSITY: f32 = 8.0;

impl TryFrom<f64> for Density {
    type Error = String;
    fn try_from(v: f64) -> Result<Self, String> {
        if v.is_finite() && (0.0..=MAX_DENSITY as f64).contains(&v) {
            Ok(Density(v as f32))
        } else {
            Err(format!(
                "a density factor must lie in [0, {}], got {}",
                short(MAX_DENSITY as f64),
                short(v)
            ))
        }
    }
}

/// Parameters of the uniform grid (McGuire et al. 2017, §4: probes on a regular grid).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(try_from = "RawGrid")]
pub struct GridParams {
    /// Number of cells along x, y and z; one probe at each cell centre.
    pub cells: (
        Count<MAX_GRID_CELLS_PER_AXIS>,
        Count<MAX_GRID_CELLS_PER_AXIS>,
        Count<MAX_GRID_CELLS_PER_AXIS>,
    ),
}

/// Named as the type it becomes, which messages name.
#[derive(Deserialize)]
#[serde(deny_unknown_fields, rename = "GridParams")]
struct RawGrid {
    cells: (
        Count<MAX_GRID_CELLS_PER_AXIS>,
        Count<MAX_GRID_CELLS_PER_AXIS>,
        Count<MAX_GRID_CELLS_PER_AXIS>,
    ),
}

impl TryFrom<RawGrid> for GridParams {
    type Error = String;
    fn try_from(g: RawGrid) -> Result<Self, String> {
        let total = g.cells.0 .0 as u64 * g.cells.1 .0 as u64 * g.cells.2 .0 as u64;
        if total > MAX_GRID_PROBES {
            return Err(format!(
                "a grid of {total} probes exceeds the limit of {MAX_GRID_PROBES}"
            ));
        }
        Ok(GridParams { cells: g.cells })
    }
}

impl GridParams {
    /// The probes of the grid: one per cell (McGuire et al. 2017 place a
    /// probe at each cell's centre).
    pub fn probes(&self) -> usize {
        self.cells.0 .0 as usize * self.cells.1 .0 as usize * self.cells.2 .0 as usize
    }

    /// The cell counts as written on the command line, e.g. `4x4x4`.
    pub fn dims_text(&self) -> String {
        format!(
            "{}x{}x{}",
            self.cells.0 .0, self.cells.1 .0, self.cells.2 .0
        )
    }

    /// Parses `NxMxK` (the part after `method:` on the command line) with
    /// the same limits as the config file. The error is the reason alone,
    /// naming `method` in its example; the caller adds the context.
    pub fn parse_dims(dims: &str, method: &str) -> Result<GridParams, String> {
        let parts: Vec<&str> = dims.split('x').collect();
        if parts.len() != 3 {
            return Err(format!("expected {method}:NxMxK, e.g. {method}:4x4x4"));
        }
        let mut n = [1u32; 3];
        for (slot, part) in n.iter_mut().zip(&parts) {
            *slot = part.parse().map_err(|_| {
                format!("grid dimensions must be whole numbers, e.g. {method}:4x4x4")
            })?;
        }
        GridParams::new(n)
    }

    /// `cells[0] × cells[1] × cells[2]` cells, each within the per-axis and
    /// total limits; the error says which is broken.
    pub fn new(cells: [u32; 3]) -> Result<GridParams, String> {
        let mut n = [Count(1); 3];
        for (slot, &c) in n.iter_mut().zip(&cells) {
            *slot = Count::try_from(c as u64)?;
        }
        GridParams::try_from(RawGrid {
            cells: (n[0], n[1], n[2]),
        })
    }
}

/// How the SDF classifies voxels (see `sdf` module docs).
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SdfParams {
    /// Rays cast from each voxel centre to classify it (at most 1024).
    pub rays_per_voxel: Count<1024>,
    /// A voxel is solid when more than this share of its rays hit back faces.
    pub solid_backface_fraction: Fraction,
    /// A voxel is outside the scene when more than this share of its rays escape.
    pub outside_escape_fraction: Fraction,
}

impl Default for SdfParams {
    fn default() -> Self {
        SdfParams {
            rays_per_voxel: Count(32),
            solid_backface_fraction: Fraction(0.25),
            outside_escape_fraction: Fraction(0.5),
        }
    }
}

/// How coverage is estimated (see `coverage` module docs).
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct CoverageParams {
    /// Coverable area-uniform surface samples to collect. 40 000 keeps the
    /// 95% interval within ±0.5% for any coverage (1.96·sqrt(0.25/40000) = 0.0049).
    /// At most 5 000 000.
    pub samples: Count<5_000_000>,
    /// About how many lattice points over the domain decide what is
    /// coverable (`coverage::free_points`; at most 1 000 000).
    pub reference_points: Count<1_000_000>,
    /// A surface point counts as seen only under this incidence angle.
    pub max_incidence_deg: Degrees,
}

impl Default for CoverageParams {
    fn default() -> Self {
        CoverageParams {
            samples: Count(40_000),
            reference_points: Count(4096),
            max_incidence_deg: Degrees(85.0),
        }
    }
}

/// Which fitness the refinement maximizes (see the `refine` module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, serde::Serialize)]
pub enum FitnessKind {
    /// Each atlas texel is credited once, by the probe that sees it best:
    /// `π_ij = max_k (w1·Ω^k_ij + w2·d^k_ij)·V^k_ij`, with the per-view terms
    /// whose probe averages are Wang et al.'s Ω̄_k and d̄_k.
    Saturating,
    /// Wang et al. 2019 eq. 2 as written: `π_ij = Σ_k (w1·Ω̄_k + w2·d̄_k)·V^k_ij`.
    AsWritten,
}

/// Parameters of the position refinement and the pruning and filling that
/// follow it (Wang et al. 2019 §3.2–3.3; `refine` module docs). Lengths left
/// out scale with the scene.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RefineParams {
    /// Run the refinement stage at all (`--no-refine` turns it off).
    pub enabled: bool,
    /// The fitness to maximize.
    pub fitness: FitnessKind,
    /// w1 of eq. 2: weight of the view-distortion term Ω (cosine of incidence).
    pub w_orientation: NonNegative,
    /// w2 of eq. 2: weight of the distance term d (distance over the domain diagonal).
    pub w_distance: NonNegative,
    /// Side of the octahedral direction map each probe is evaluated with:
    /// `directions`² rays per probe position (at most 256).
    pub directions: Count<256>,
    /// Side of the octahedral direction map the eight corners of a
    /// probe's support cube are scored with during the sweeps: the corners
    /// only shape the linear models a proposal is drawn from, and the
    /// proposal itself is scored with `directions` (Wang et al. 2019 §3.3
    /// subsamples view directions during optimization). `None`: half of
    /// `directions`, at least 8 and at most `directions`.
    pub corner_directions: Option<Count<256>>,
    /// Edge of an atlas texel (world units). `None`: the spacing of the
    /// probe's directions at the scene's largest clearance.
    pub texel_size: Option<Positive>,
    /// Most sweeps over all probes.
    pub iterations: Count<10_000>,
    /// The sweeps end after this many in a row without a new best set
    /// (the gibbs module's step 6); `iterations` or more runs them all.
    pub patience: Count<10_000>,
    /// First step of every probe (world units). `None`: half the
    /// scene's largest clearance.
    pub initial_step: Option<Positive>,
    /// A probe whose step falls below this stops moving (world units). `None`: 1 voxel.
    pub min_step: Option<Positive>,
    /// Exponent β of the acceptance test ξ < (R(P′)/R(P))^β. `None`: the
    /// probe count, which makes one probe's move as decisive as if it were
    /// alone (β = 1 is the paper's rule).
    pub acceptance_exponent: Option<Positive>,
    /// Coverage that filling must reach and pruning must keep, as a share
    /// of the coverable area measured by the `coverage` stage.
    pub coverage_target: Fraction,
    /// Drop probes the coverage target does not need.
    pub prune: bool,
    /// Add probes where coverage falls short of the target.
    pub fill: bool,
    /// Free positions tried when filling, besides the coverage reference
    /// points (at most 1 000 000).
    pub fill_candidates: Count<1_000_000>,
    /// No probe moves or is added nearer than this to a surface (world
    /// units). `None`: the placement method's own threshold.
    pub min_clearance: Option<Positive>,
    /// What the refined set is made to serve (`crate::refine::diffuse`).
    pub objective: Objective,
    /// The diffuse step's training set and stopping rule.
    pub diffuse: DiffuseSearch,
}

/// What refinement makes the probe set serve.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, serde::Serialize)]
pub enum Objective {
    /// Every surface seen by a probe (Wang et al. 2019 §3.2–3.3): the
    /// light-field tracer's need.
    Coverage,
    /// Coverage first, then probes added where blending the probes' SH
    /// over Delaunay tetrahedra, as engines do, misses the diffuse light
    /// (`crate::refine::diffuse`).
    Both,
}

/// `refine.diffuse`: the diffuse step of [`Objective::Both`]
/// (`crate::refine::diffuse`).
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct DiffuseSearch {
    /// Receivers on surfaces that reachable free space faces, half of
    /// them held out.
    pub surface_points: Whole<65536>,
    /// Receivers in reachable free space, half of them held out.
    pub free_points: Whole<65536>,
    /// Paths per receiver's reference, and directions per probe's SH
    /// projection.
    pub rays: Count<65536>,
    /// Without `max_probes` or `min_probes`, insertion stops once the best
    /// insertion lowers the training error by less than this share of the
    /// error per probe (the error over the probe count): the least
    /// elasticity of the error against the count worth a probe.
    pub gain: NonNegative,
    /// Without `max_probes`, the most probes the step adds, as a share of
    /// the probes coverage placed.
    pub growth: NonNegative,
}

impl Default for DiffuseSearch {
    fn default() -> Self {
        DiffuseSearch {
            surface_points: Whole(2048),
            free_points: Whole(1024),
            rays: Count(128),
            gain: NonNegative(0.02),
            growth: NonNegative(1.0),
        }
    }
}

impl Default for RefineParams {
    fn default() -> Self {
        RefineParams {
            enabled: true,
            fitness: FitnessKind::Saturating,
            w_orientation: NonNegative(1.0),
            w_distance: NonNegative(1.0),
            directions: Count(32),
            corner_directions: None,
            texel_size: None,
            iterations: Count(20),
            patience: Count(5),
            initial_step: None,
            min_step: None,
            acceptance_exponent: None,
            coverage_target: Fraction(0.999),
            prune: true,
            fill: true,
            fill_candidates: Count(8192),
            min_clearance: None,
            objective: Objective::Both,
            diffuse: DiffuseSearch::default(),
        }
    }
}

/// How the sparse voxel octree of probe indices is baked (Wang et al. 2019
/// §4.1; `svo` module docs). Lengths left out scale with the scene.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SvoParams {
    /// Edge of an octree leaf (world units). `None`: the SDF voxel size.
    pub leaf_size: Option<Positive>,
    /// Most probe indices a leaf lists (at most 8).
    pub max_probes: Count<8>,
    /// Side of the octahedral direction map whose radial distances give
    /// each probe's influence region: `directions`² rays per probe (at most 256).
    pub directions: Count<256>,
    /// Neighbouring leaves collapse into one when a single ranked list serves
    /// them all: every listed probe sees every leaf, and the first one scores
    /// at least this share of the best probe's score at each leaf. 1 keeps
    /// the best probe first everywhere; lower values give smaller octrees.
    pub collapse_quality: Fraction,
}

impl Default for SvoParams {
    fn default() -> Self {
        SvoParams {
            leaf_size: None,
            max_probes: Count(4),
            directions: Count(32),
            collapse_quality: Fraction(0.5),
        }
    }
}

/// A light for the lighting stages (probe bake, reference render). Emissive
/// materials (`Ke`) of the scene are area lights in addition to these.
/// Unknown fields are refused as in every struct: a misspelt optional field
/// (`edge_degree`) would otherwise leave its default in force unnoticed.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum Light {
    /// A point light at `position` with RGB radiant `intensity` (W/sr).
    Point {
        /// Position in world units.
        position: Point3,
        /// Radiant intensity per channel.
        intensity: Rgb,
    },
    /// A spot light: a point light restricted to a cone about `direction`.
    Spot {
        /// Position in world units.
        position: Point3,
        /// Axis of the cone, pointing where the light shines.
        direction: Direction,
        /// Radiant intensity per channel on the axis.
        intensity: Rgb,
        /// Half-angle of the cone in degrees; nothing is emitted outside it.
        cone_degrees: Degrees,
        /// Width in degrees of the smooth fall-off inside the cone's edge.
        #[serde(default = "spot_edge")]
        edge_degrees: NonNegative,
    },
    /// A distant light (the sun) travelling along `direction`, giving
    /// `irradiance` (W/m²) on a surface facing it.
    Directional {
        /// Direction the light travels.
        direction: Direction,
        /// Irradiance per channel on a surface perpendicular to the light.
        irradiance: Rgb,
    },
    /// Constant radiance arriving from every direction that escapes the
    /// scene (a uniform sky; scenes open to the outside, such as Sponza).
    Sky {
        /// Radiance per channel.
        radiance: Rgb,
    },
}

/// `scene_lights`: what becomes of the lights a scene file defines.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize, serde::Serialize)]
pub enum SceneLights {
    /// The file's lights shine besides the config's `lights`.
    #[default]
    Use,
    /// Only the config's `lights` (and emissive materials) shine.
    Ignore,
}

fn spot_edge() -> NonNegative {
    NonNegative(5.0)
}

/// A pinhole camera for the reference render.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(try_from = "RawCamera")]
pub struct CameraParams {
    /// Eye position (world units).
    pub position: Point3,
    /// A point the camera looks at.
    pub look_at: Point3,
    /// Up direction of the image; must not be parallel to the view.
    pub up: Direction,
    /// Vertical field of view in degrees, in (0, 180).
    pub fov_degrees: f32,
}

/// Named as the type it becomes, which messages name.
#[derive(Deserialize)]
#[serde(deny_unknown_fields, rename = "CameraParams")]
struct RawCamera {
    position: Point3,
    look_at: Point3,
    #[serde(default = "y_up")]
    up: Direction,
    #[serde(default = "default_fov")]
    fov_degrees: f64,
}

fn y_up() -> Direction {
    Direction([0.0, 1.0, 0.0])
}

fn default_fov() -> f64 {
    40.0
}

impl TryFrom<RawCamera> for CameraParams {
    type Error = String;
    fn try_from(r: RawCamera) -> Result<Self, String> {
        let view: Vec<f64> = (0..3).map(|i| r.look_at.0[i] - r.position.0[i]).collect();
        let len = view.iter().map(|c| c * c).sum::<f64>().sqrt();
        if len.is_nan() || len <= 0.0 {
            return Err("look_at must differ from position".into());
        }
        let u = r.up.0.map(f64::from);
        let cross = [
            view[1] * u[2] - view[2] * u[1],
            view[2] * u[0] - view[0] * u[2],
            view[0] * u[1] - view[1] * u[0],
        ];
        if cross.iter().map(|c| c * c).sum::<f64>().sqrt() < 1e-4 * len {
            return Err("up must not be parallel to the view direction".into());
        }
        let fov = r.fov_degrees as f32;
        if r.fov_degrees.is_nan() || !(fov > 0.0 && fov < 180.0) {
            return Err(format!(
                "fov_degrees must lie strictly between 0 and 180, got {}",
                short(r.fov_degrees)
            ));
        }
        Ok(CameraParams {
            position: r.position,
            look_at: r.look_at,
            up: r.up,
            fov_degrees: fov,
        })
    }
}

/// The light-field probe bake (McGuire et al. 2017 §3 and §5.2; `lightfield`
/// module docs).
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct BakeParams {
    /// Side of each probe's octahedral radiance, normal and distance maps.
    /// The papers use 512–1024; 128 is plenty for validation.
    pub resolution: PowerOfTwo<8, 2048>,
    /// Side of each probe's irradiance and distance-moment maps (McGuire
    /// §3: 32² to 128² suffice).
    pub irradiance_resolution: PowerOfTwo<8, 256>,
    /// Path samples averaged into each radiance texel.
    pub samples: Count<65536>,
    /// Indirect bounces after the surface a probe sees (0: direct light only).
    pub bounces: Whole<64>,
    /// Exponent of the cosine-power lobe that filters the distance moments
    /// (McGuire §5.2).
    pub moment_exponent: Positive,
    /// Directions per probe's SH L2 projection (`sh.json`), and paths per
    /// axis of the reference irradiance beside it.
    pub sh_rays: Count<65536>,
    /// Whether the SH holds the point, spot and directional lights'
    /// direct light (engines that want fully baked probes) or not (a
    /// mixed-lighting bake, the default).
    pub sh_direct: ShDirect,
}

/// `bake.sh_direct`: which light `sh.json` and the exports' SH hold.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize, serde::Serialize)]
pub enum ShDirect {
    /// What a mixed-lighting probe holds (Unity's Baked Indirect):
    /// emitters, the sky and every reflection, not the point, spot and
    /// directional lights' direct light, which the engine shades.
    #[default]
    Exclude,
    /// All the light at the probe (Unity's Baked lights, a fully baked
    /// probe): the delta lights' direct light too, projected exactly.
    Include,
}

impl Default for BakeParams {
    fn default() -> Self {
        BakeParams {
            resolution: PowerOfTwo(128),
            irradiance_resolution: PowerOfTwo(32),
            samples: Count(4),
            bounces: Whole(2),
            moment_exponent: Positive(50.0),
            sh_rays: Count(1024),
            sh_direct: ShDirect::Exclude,
        }
    }
}

/// The path-traced reference image (Wang et al. 2019 §5.1 measures error on
/// glossy indirect light against such an image).
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ReferenceParams {
    /// The camera; without one, `bake` skips the reference and says so.
    pub camera: Option<CameraParams>,
    /// Image width in pixels.
    pub width: Count<8192>,
    /// Image height in pixels.
    pub height: Count<8192>,
    /// Paths per pixel.
    pub samples_per_pixel: Count<1_000_000>,
    /// Indirect bounces after the first surface (0: direct light only).
    pub bounces: Whole<64>,
}

impl Default for ReferenceParams {
    fn default() -> Self {
        ReferenceParams {
            camera: None,
            width: Count(320),
            height: Count(240),
            samples_per_pixel: Count(64),
            bounces: Whole(3),
        }
    }
}

/// `probeplace compare` (Wang et al. 2019 §5: equal-count, equal-quality
/// and equal-performance comparisons against uniform grids).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct CompareParams {
    /// The uniform grids to compare against; empty: a sweep from a quarter
    /// to four times our probe count, in steps of about 2×.
    pub grids: Vec<GridParams>,
    /// Cameras besides `reference.camera`; every placement is rendered and
    /// measured from each.
    pub cameras: Vec<CameraParams>,
    /// Glossy rays per pixel of the validation renders. Placements differ
    /// by less than one ray's noise, so `compare` averages several.
    pub glossy_rays: Count<256>,
    /// Views `compare` chooses from the scene alone, besides the cameras
    /// (`render::views`): seeded, spread over the free space, at eye height
    /// over a floor, each looking at much of the coverable surface.
    pub views: Whole<64>,
    /// The surfaces the comparison renders with: the scene's own, or all
    /// glossy (Wang et al. 2019 §5.2 benchmark every surface glossy).
    pub materials: Materials,
    /// The diffuse evaluation: irradiance at receivers, as engines blend
    /// probes ([`crate::diffuse`]).
    pub diffuse: DiffuseParams,
}

/// `compare.diffuse`: how many receivers the diffuse evaluation measures
/// and how many rays each reference and each probe's SH take.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct DiffuseParams {
    /// Surface receivers, shared among the views (0: no diffuse
    /// evaluation).
    pub surface_receivers: Whole<65536>,
    /// Receivers in the free space a viewer reaches.
    pub free_receivers: Whole<65536>,
    /// Cosine-weighted paths per receiver's reference irradiance.
    pub reference_rays: Count<65536>,
    /// Directions per probe's SH L2 projection.
    pub probe_rays: Count<65536>,
}

impl Default for DiffuseParams {
    fn default() -> Self {
        DiffuseParams {
            surface_receivers: Whole(1024),
            free_receivers: Whole(512),
            reference_rays: Count(1024),
            probe_rays: Count(1024),
        }
    }
}

impl Default for CompareParams {
    fn default() -> Self {
        CompareParams {
            grids: Vec::new(),
            cameras: Vec::new(),
            glossy_rays: Count(8),
            views: Whole(8),
            materials: Materials::Scene,
            diffuse: DiffuseParams::default(),
        }
    }
}

/// What surfaces `compare` measures on.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
pub enum Materials {
    /// The scene's MTL materials as they are.
    Scene,
    /// Every material given a glossy lobe of this GGX roughness α
    /// (`render::material::all_glossy`), as Wang et al. 2019 §5.2 render
    /// "*all* surfaces as glossy for the purpose of benchmarking": in a
    /// nearly matte scene one view cannot otherwise tell placements apart.
    AllGlossy(Fraction),
}
