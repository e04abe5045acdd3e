//! The `relocated:NxMxK` method: McGuire's uniform grid with the probe
//! relocation and classification of RTXGI / DDGI (Majercik et al. 2019,
//! "Dynamic Diffuse Global Illumination with Ray-Traced Irradiance Fields",
//! JCGT 8(2), §5 "Probe relocation" and the RTXGI SDK's
//! `ProbeRelocationCS` / `ProbeClassificationCS`).
//!
//! **Why it is here.** It is what users of current engines get: a grid that
//! needs no scene analysis, repaired by a few rays per probe. Comparing our
//! placement against the bare grid alone would flatter us, since no engine
//! ships a bare grid any more.
//!
//! Per probe, starting at its cell centre ([`super::grid`]):
//!
//! 1. **Survey**: cast the fixed set of [`RAYS`] directions ([`directions`]:
//!    a spherical Fibonacci set, unrotated, the same for every probe, so the
//!    result never depends on a seed or on thread scheduling) and record the
//!    share of back-face hits and the closest back-face and front-face hits.
//! 2. **Relocate** (RTXGI's rule): if more than [`BACKFACE_FRACTION`] of the
//!    rays hit back faces the probe is inside geometry, and it moves along
//!    the closest back-face hit to that hit's distance plus the minimum
//!    front-face distance, so it lands in front of that surface at the
//!    clearance the next rule asks for. Otherwise, if the closest front face
//!    is nearer than the minimum front-face distance, it moves straight away
//!    from it by the shortfall. The minimum front-face distance is
//!    0.1 × the smallest cell side (RTXGI leaves it to the user; a tenth of
//!    the spacing is the common setting), but never less than one SDF voxel,
//!    the clearance refinement keeps for grids ([`super::grid_min_clearance`]).
//! 3. **Clamp** the total offset to [`MAX_OFFSET_FRACTION`] (45%) of the
//!    cell on each axis, so a probe never leaves its cell and the grid stays
//!    a grid for trilinear lookup. RTXGI instead *rejects* a move that leaves
//!    the ellipsoid of radius 0.45 cells; clamping per axis keeps the axis
//!    that crosses the surface when another axis is too long, which relocates
//!    more probes out of walls and never fewer.
//! 4. **Repeat** steps 1–3 from the new position, up to [`PASSES`] passes
//!    in all, stopping early when a pass leaves the offset unchanged. RTXGI
//!    re-runs relocation every frame, each time from the current offset, so
//!    a probe pushed through a back face and onto another surface (a probe
//!    on a stair's tread lifted against the next riser) moves on off it in
//!    the following frames; the passes are those frames.
//! 5. **Classify** by the survey from the final position: the probe is
//!    switched off (dropped) when it is still inside (back-face share over
//!    the threshold), or when none of its rays hits a front face within the
//!    cell diagonal, i.e. it sees no surface its irradiance could usefully
//!    light (RTXGI's "no geometry in the probe's voxel" test).

use super::grid::{grid, grid_min_clearance};
use crate::config::params::GridParams;
use crate::error::{Error, Result};
use crate::placement::method::{Method, Role};
use crate::probes::{PlacementInput, Probe, ProbeSet};
use crate::sampling::fibonacci_sphere;
use crate::scene::raycast::SceneBvh;
use glam::Vec3;
use indicatif::ParallelProgressIterator;
use rayon::prelude::*;
use std::collections::BTreeMap;

/// Rays per probe survey (RTXGI's fixed relocation rays are a subset of its
/// 256 per-probe rays; here all 256 take part).
pub const RAYS: u32 = 256;
/// A probe is inside geometry when more than this share of its rays hit
/// back faces (RTXGI's `probeBackfaceThreshold` default, and our SDF's rule).
pub const BACKFACE_FRACTION: f32 = 0.25;
/// Largest offset from the cell centre, per axis, as a share of the cell
/// (RTXGI's 0.45).
pub const MAX_OFFSET_FRACTION: f32 = 0.45;
/// Minimum front-face distance as a share of the smallest cell side.
pub const MIN_FRONTFACE_CELL_FRACTION: f32 = 0.1;
/// Most relocation passes per probe (RTXGI's frames of relocation).
pub const PASSES: u32 = 4;

/// The fixed, well-spread survey directions: [`RAYS`] unit vectors of a
/// spherical Fibonacci set, unrotated.
///
/// Contract: the same vectors, in the same order, on every call.
pub fn directions() -> Vec<Vec3> {
    fibonacci_sphere(RAYS)
}

/// What one probe's rays saw.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Survey {
    /// Rays cast.
    pub rays: u32,
    /// Rays whose first hit was a back face.
    pub backfaces: u32,
    /// Distance and direction of the closest back-face hit.
    pub closest_backface: Option<(f32, Vec3)>,
    /// Distance and direction of the closest front-face hit.
    pub closest_frontface: Option<(f32, Vec3)>,
}

impl Survey {
    /// Share of the rays that hit back faces (0 when no ray was cast).
    pub fn backface_fraction(&self) -> f32 {
        if self.rays == 0 {
            0.0
        } else {
            self.backfaces as f32 / self.rays as f32
        }
    }

    /// Whether the probe counts as inside geometry (RTXGI's rule).
    pub fn inside(&self) -> bool {
        self.backface_fraction() > BACKFACE_FRACTION
    }
}

/// Casts every direction of `dirs` from `origin` and records the result.
///
/// Contract: rays run from `t > 0` to infinity; misses count towards
/// `rays` only; of equally close hits the earliest direction in `dirs`
/// wins, so the survey is a pure function of its inputs.
pub fn survey(bvh: &SceneBvh, origin: Vec3, dirs: &[Vec3]) -> Survey {
    let mut s = Survey {
        rays: dirs.len() as u32,
        backfaces: 0,
        closest_backface: None,
        closest_frontface: None,
    };
    for &d in dirs {
        let Some(hit) = bvh.closest_hit(origin, d, 0.0, f32::INFINITY) else {
            continue;
        };
        let slot = if hit.backface {
            s.backfaces += 1;
            &mut s.closest_backface
        } else {
            &mut s.closest_frontface
        };
        if slot.is_none_or(|(t, _)| hit.t < t) {
            *slot = Some((hit.t, d));
        }
    }
    s
}

/// The lengths that steer relocation and classification of one grid.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rules {
    /// A probe nearer than this to a front face moves away from it; a probe
    /// inside lands this far beyond the back face it crosses.
    pub min_frontface_distance: f32,
    /// Largest offset from the cell centre along each axis.
    pub max_offset: Vec3,
    /// A probe that sees no front face within this distance is switched off
    /// (the cell diagonal).
    pub max_surface_distance: f32,
}

impl Rules {
    /// The module's rules for cells of size `cell`, with SDF voxels of
    /// edge `voxel_size` (the floor of the minimum front-face distance).
    pub fn new(cell: Vec3, voxel_size: f32) -> Rules {
        Rules {
            min_frontface_distance: (MIN_FRONTFACE_CELL_FRACTION * cell.min_element())
                .max(voxel_size),
            max_offset: MAX_OFFSET_FRACTION * cell,
            max_surface_distance: cell.length(),
        }
    }
}

/// RTXGI's relocation offset for a probe with survey `s`, before clamping:
/// through the closest back face when inside, away from the closest front
/// face when too near it, zero otherwise.
pub fn relocation_offset(s: &Survey, min_frontface_distance: f32) -> Vec3 {
    if s.inside() {
        if let Some((t, d)) = s.closest_backface {
            return d * (t + min_frontface_distance);
        }
    } else if let Some((t, d)) = s.closest_frontface {
        if t < min_frontface_distance {
            return -d * (min_frontface_distance - t);
        }
    }
    Vec3::ZERO
}

/// What became of one grid probe.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ProbeFate {
    /// Kept at `position`; `moved` when relocation moved it.
    On {
        /// Final position (within the cell).
        position: Vec3,
        /// Whether it left the cell centre.
        moved: bool,
    },
    /// Switched off: still inside geometry after relocation.
    OffInside,
    /// Switched off: no front face within the cell diagonal.
    OffNoSurface,
}

/// Relocates and classifies the probe of the cell centred at `centre`.
///
/// Contract: an `On` position differs from `centre` by at most
/// `rules.max_offset` on each axis (so it stays in its cell); a probe is
/// `On` only if the survey from its final position is not inside and has a
/// front-face hit within `rules.max_surface_distance`; at most [`PASSES`]
/// relocation passes; deterministic.
pub fn relocate_probe(bvh: &SceneBvh, centre: Vec3, rules: &Rules, dirs: &[Vec3]) -> ProbeFate {
    let mut offset = Vec3::ZERO;
    let mut last = survey(bvh, centre, dirs);
    for _ in 0..PASSES {
        let next = (offset + relocation_offset(&last, rules.min_frontface_distance))
            .clamp(-rules.max_offset, rules.max_offset);
        if next == offset {
            break;
        }
        offset = next;
        last = survey(bvh, centre + offset, dirs);
    }
    if last.inside() {
        ProbeFate::OffInside
    } else if last
        .closest_frontface
        .is_none_or(|(t, _)| t > rules.max_surface_distance)
    {
        ProbeFate::OffNoSurface
    } else {
        ProbeFate::On {
            position: centre + offset,
            moved: offset != Vec3::ZERO,
        }
    }
}

/// The `relocated:NxMxK` method, a competitor: [`relocated_grid`].
pub struct Relocated;

impl Method for Relocated {
    type Params = GridParams;
    const WORD: &'static str = "relocated";
    const TAKES_ARGUMENT: bool = true;
    const FORM: &'static str = "relocated:NxMxK";
    const ABOUT: &'static str = "RTXGI/DDGI (Majercik et al. 2019): the uniform grid with its probes moved out of geometry within their cells, and switched off where they stay inside or see no surface";
    const ROLE: Role = Role::Competitor;
    const LABEL: &'static str = "grid, relocated (RTXGI)";
    const MARKER: (&'static str, &'static str) = ("#c07020", "diamond");

    fn name(params: &GridParams) -> String {
        format!("relocated:{}", params.dims_text())
    }

    /// The swept grid whose probe count is nearest `count`, relocated.
    fn at_count(
        _: &PlacementInput,
        grids: &[(usize, GridParams)],
        count: usize,
    ) -> Option<GridParams> {
        super::grid::nearest_grid(grids, count).map(|&(_, g)| g)
    }

    fn parse_cli(
        argument: Option<&str>,
        _: Option<&GridParams>,
    ) -> std::result::Result<GridParams, String> {
        GridParams::parse_dims(argument.unwrap_or(""), "relocated")
    }

    fn place(params: &GridParams, input: &PlacementInput) -> Result<ProbeSet> {
        relocated_grid(params, input)
    }
}

/// Places probes by the module's method: the `params` grid over the
/// domain, relocated and classified.
///
/// Contract: probes come in grid order (x fastest), switched-off probes
/// left out; each lies in its own cell, within 45% of the cell of its
/// centre per axis; the result depends only on the scene and the domain,
/// not on the seed or the thread count. Stats: `grid_probes`, `relocated`
/// (moved and kept on), `switched_off_inside`, `switched_off_no_surface`.
/// `min_clearance` is the grid's. Errors ([`Error::User`]) when every
/// probe is switched off.
pub fn relocated_grid(params: &GridParams, input: &PlacementInput) -> Result<ProbeSet> {
    let cells = grid(params, input.domain);
    let n = Vec3::new(
        params.cells.0 .0 as f32,
        params.cells.1 .0 as f32,
        params.cells.2 .0 as f32,
    );
    let rules = Rules::new(input.domain.size() / n, input.sdf.voxel_size);
    let dirs = directions();
    let bar = input
        .progress
        .bar("relocating grid probes", cells.len() as u64);
    let outcomes: Vec<ProbeFate> = cells
        .par_iter()
        .progress_with(bar)
        .map(|p| relocate_probe(input.bvh, p.position, &rules, &dirs))
        .collect();
    let mut probes = Vec::new();
    let (mut relocated, mut inside, mut no_surface) = (0u64, 0u64, 0u64);
    for o in &outcomes {
        match *o {
            ProbeFate::On { position, moved } => {
                relocated += moved as u64;
                probes.push(Probe {
                    position,
                    cluster_size: 0,
                });
            }
            ProbeFate::OffInside => inside += 1,
            ProbeFate::OffNoSurface => no_surface += 1,
        }
    }
    let name = format!("relocated:{}", params.dims_text());
    if probes.is_empty() {
        return Err(Error::User(format!(
            "placement {name}: every probe is switched off ({inside} stay inside geometry, {no_surface} see no surface within a cell diagonal); use more cells"
        )));
    }
    Ok(ProbeSet {
        method: name,
        probes,
        stats: BTreeMap::from([
            ("grid_probes", cells.len() as u64),
            ("relocated", relocated),
            ("switched_off_inside", inside),
            ("switched_off_no_surface", no_surface),
        ]),
        params: BTreeMap::from([
            ("rays", RAYS as f64),
            ("passes", PASSES as f64),
            ("backface_fraction", BACKFACE_FRACTION as f64),
            ("max_offset_fraction", MAX_OFFSET_FRACTION as f64),
            (
                "min_frontface_distance",
                rules.min_frontface_distance as f64,
            ),
            ("max_surface_distance", rules.max_surface_distance as f64),
        ]),
        min_clearance: grid_min_clearance(input.sdf),
        fixed: 0,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::{Count, Placement};
    use crate::scene::testing::{add_box, bvh_and_sdf, place_in};
    use crate::scene::{Material, Scene};
    use crate::sdf::VoxelClass;

    fn scene(tris: Vec<[Vec3; 3]>) -> Scene {
        Scene::from_triangles(
            "t".into(),
            tris.into_iter().map(|t| (t, 0)),
            vec![Material::fallback()],
        )
        .unwrap()
    }

    fn cells(n: u32) -> GridParams {
        GridParams {
            cells: (Count(n), Count(n), Count(n)),
        }
    }

    /// A 4 m room with a solid box that swallows the grid probe at
    /// (1.5, 0.5, 1.5) off its centre: 0.3 m from the box's −x and −z faces.
    fn room_with_offset_box() -> Scene {
        let mut tris = Vec::new();
        add_box(&mut tris, Vec3::ZERO, Vec3::splat(4.0), true);
        add_box(
            &mut tris,
            Vec3::new(1.2, 0.0, 1.2),
            Vec3::new(2.6, 1.0, 2.6),
            false,
        );
        scene(tris)
    }

    #[test]
    fn probe_inside_a_solid_box_moves_out_within_its_cell() {
        let s = room_with_offset_box();
        let (bvh, sdf) = bvh_and_sdf(&s, 0.1, 1);
        let centre = Vec3::new(1.5, 0.5, 1.5);
        let dirs = directions();
        assert!(survey(&bvh, centre, &dirs).inside());
        let rules = Rules::new(Vec3::ONE, sdf.voxel_size);
        let ProbeFate::On { position, moved } = relocate_probe(&bvh, centre, &rules, &dirs) else {
            panic!("the probe should be relocated and kept");
        };
        assert!(moved);
        assert!(!survey(&bvh, position, &dirs).inside(), "{position}");
        let v = sdf.voxel_at(position).unwrap();
        assert_eq!(sdf.class[v], VoxelClass::Free, "{position}");
        assert!(
            (position - centre)
                .abs()
                .cmple(Vec3::splat(0.45 + 1e-6))
                .all(),
            "{position}"
        );
        // The same through the method: the probe is kept, moved, and no
        // kept probe is inside.
        let set = place_in(&Placement::Relocated(cells(4)), &s, &bvh, &sdf).unwrap();
        assert_eq!(set.method, "relocated:4x4x4");
        assert!(set.probes.iter().any(|p| p.position == position));
        assert!(set.stats["relocated"] >= 1);
        for p in &set.probes {
            assert!(!survey(&bvh, p.position, &dirs).inside(), "{}", p.position);
        }
    }

    #[test]
    fn probes_far_from_every_surface_are_switched_off() {
        // An 8 m room, 1 m cells: the cell diagonal is 1.73 m, so the 4³
        // probes 2.5 m or more from every wall see no surface near enough.
        let mut tris = Vec::new();
        add_box(&mut tris, Vec3::ZERO, Vec3::splat(8.0), true);
        let s = scene(tris);
        let (bvh, sdf) = bvh_and_sdf(&s, 0.25, 1);
        let set = place_in(&Placement::Relocated(cells(8)), &s, &bvh, &sdf).unwrap();
        assert_eq!(set.stats["grid_probes"], 512);
        assert_eq!(set.stats["switched_off_no_surface"], 64);
        assert_eq!(set.stats["switched_off_inside"], 0);
        assert_eq!(set.stats["relocated"], 0);
        assert_eq!(set.probes.len(), 448);
        let open = Vec3::new(3.5, 4.5, 3.5);
        assert!(set.probes.iter().all(|p| p.position != open));
        assert!(set
            .probes
            .iter()
            .any(|p| p.position == Vec3::new(0.5, 4.5, 3.5)));
    }

    #[test]
    fn relocation_is_deterministic_and_keeps_grid_order() {
        let s = room_with_offset_box();
        let (bvh, sdf) = bvh_and_sdf(&s, 0.1, 1);
        let a = place_in(&Placement::Relocated(cells(4)), &s, &bvh, &sdf).unwrap();
        let b = place_in(&Placement::Relocated(cells(4)), &s, &bvh, &sdf).unwrap();
        assert_eq!(a, b);
        // Each kept probe stays in its own cell, so grid order (x fastest)
        // survives: cell indices strictly increase.
        let cell_index = |p: Vec3| {
            let c = p.floor();
            (c.x + 4.0 * (c.y + 4.0 * c.z)) as i32
        };
        let idx: Vec<i32> = a.probes.iter().map(|p| cell_index(p.position)).collect();
        assert!(idx.windows(2).all(|w| w[0] < w[1]), "{idx:?}");
    }

    #[test]
    fn offsets_follow_rtxgi_rules() {
        let inside = Survey {
            rays: 4,
            backfaces: 2,
            closest_backface: Some((0.3, Vec3::X)),
            closest_frontface: Some((0.05, Vec3::Y)),
        };
        assert_eq!(relocation_offset(&inside, 0.1), Vec3::X * 0.4);
        let near = Survey {
            backfaces: 1,
            ..inside
        };
        let o = relocation_offset(&near, 0.1);
        assert!((o - Vec3::NEG_Y * 0.05).length() < 1e-6, "{o}");
        let clear = Survey {
            closest_frontface: Some((0.5, Vec3::Y)),
            ..near
        };
        assert_eq!(relocation_offset(&clear, 0.1), Vec3::ZERO);
    }
}
