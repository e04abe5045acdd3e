//! An adaptive baseline after Unity's Adaptive Probe Volumes (issue 21:
//! "the strongest honest baselines"), as Unity documents them: probes come
//! in **bricks** of 4×4×4, a brick spanning three probe spacings; bricks
//! are **subdivided** three ways per axis where geometry is near, from the
//! coarsest spacing down to the finest, and kept coarse in empty space;
//! probes inside geometry are pushed out (**virtual offset**) or dropped.
//!
//! Here, with `min_spacing` s₀ and `levels` L:
//!
//! 1. Level k (0 finest) has probe spacing s_k = s₀·3^k and bricks of edge
//!    3·s_k. The domain is tiled by bricks of level L−1 from its lower
//!    corner.
//! 2. A brick is subdivided into 27 bricks of the level below when a
//!    surface crosses it (an SDF voxel inside it lies within half a voxel
//!    diagonal of one), and dropped when all its voxels are solid. Level-0
//!    bricks and bricks no surface crosses stay.
//! 3. Every kept brick puts a probe at each of its 4×4×4 lattice points
//!    (points shared by neighbouring bricks count once; the lattice of level
//!    k is a sublattice of level 0's, so points are keyed by their level-0
//!    coordinates), clipped to the domain.
//! 4. A probe in a free voxel at least the grids' minimum clearance from
//!    every surface stays. One in a solid voxel, or nearer a surface than
//!    that (a lattice point on a floor or a wall, where Unity's validity
//!    test finds half its rays hitting the surface's back), moves by virtual
//!    offset: up the SDF, one voxel at a time to the neighbour farthest from
//!    a surface, until it stands in a free voxel that far from every
//!    surface; a probe that gets no further than half its brick's spacing
//!    from where it started, or stands outside the scene, is dropped
//!    (Unity's invalid probes, left to dilation).
//!
//! `--method adaptive:MIN_SPACING` or `placement: Adaptive((min_spacing:
//! s, levels: 3))`; not yet among `compare`'s competitors.

use super::grid::grid_min_clearance;
use crate::config::numbers::{short, Count, Positive};
use crate::error::{Error, Result};
use crate::placement::method::{length_argument, Method, Role};
use crate::probes::{PlacementInput, Probe, ProbeSet};
use crate::sdf::{Sdf, VoxelClass};
use glam::{IVec3, Vec3};
use serde::Deserialize;
use std::collections::BTreeMap;

/// Parameters of the adaptive (APV-style) baseline.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AdaptiveConfig {
    /// The finest probe spacing (world units).
    pub min_spacing: Positive,
    /// Subdivision levels: the coarsest spacing is `min_spacing` × 3^(levels − 1).
    #[serde(default = "default_adaptive_levels")]
    pub levels: Count<4>,
}

fn default_adaptive_levels() -> Count<4> {
    Count(DEFAULT_LEVELS)
}

/// The `adaptive:MIN_SPACING` method, a competitor: [`adaptive`].
pub struct Adaptive;

impl Method for Adaptive {
    type Params = AdaptiveConfig;
    const WORD: &'static str = "adaptive";
    const TAKES_ARGUMENT: bool = true;
    const FORM: &'static str = "adaptive:MIN_SPACING";
    const ABOUT: &'static str = "Unity's Adaptive Probe Volumes, as documented: bricks of 4×4×4 probes subdivided where geometry is near, probes in geometry pushed out or dropped";
    const ROLE: Role = Role::Competitor;
    const LABEL: &'static str = "adaptive (Unity APV)";
    const MARKER: (&'static str, &'static str) = ("#20a0a0", "diamond");

    /// The minimum spacing whose count is nearest `count`, at the default
    /// levels.
    fn at_count(
        input: &PlacementInput,
        _: &[(usize, crate::config::params::GridParams)],
        count: usize,
    ) -> Option<AdaptiveConfig> {
        spacing_for_count(input, DEFAULT_LEVELS, count.max(1)).map(|min_spacing| AdaptiveConfig {
            min_spacing: Positive(min_spacing),
            levels: Count(DEFAULT_LEVELS),
        })
    }

    fn name(params: &AdaptiveConfig) -> String {
        format!("adaptive:{}", short(params.min_spacing.0))
    }

    fn parse_cli(
        argument: Option<&str>,
        base: Option<&AdaptiveConfig>,
    ) -> std::result::Result<AdaptiveConfig, String> {
        let min_spacing = length_argument(argument, "minimum spacing", "adaptive:0.5")?;
        let levels = base.map_or_else(default_adaptive_levels, |a| a.levels);
        Ok(AdaptiveConfig {
            min_spacing,
            levels,
        })
    }

    fn place(params: &AdaptiveConfig, input: &PlacementInput) -> Result<ProbeSet> {
        adaptive(
            &AdaptiveParams {
                min_spacing: params.min_spacing.0,
                levels: params.levels.0,
            },
            input,
        )
    }
}

/// Most lattice points the bricks may give before validation: beyond it a
/// `min_spacing` is too fine for the domain.
pub const MAX_POINTS: usize = 4 * crate::limits::MAX_PROBES;

/// The levels of an `Adaptive` placement when the config gives none, and
/// those `compare` gives its adaptive baseline.
pub const DEFAULT_LEVELS: u32 = 3;

/// Bisection steps [`spacing_for_count`] takes on the log of the spacing.
pub const SPACING_STEPS: u32 = 40;

/// The minimum spacing, between one SDF voxel and the domain's diagonal,
/// whose probe count at `levels` is nearest `target` (ties: the larger
/// count), found by bisection on its logarithm (the count falls as the
/// spacing grows, though not strictly); `None` when no spacing places a
/// probe.
pub fn spacing_for_count(input: &PlacementInput, levels: u32, target: usize) -> Option<f32> {
    let count = |s: f32| {
        adaptive(
            &AdaptiveParams {
                min_spacing: s,
                levels,
            },
            input,
        )
        .map(|set| set.probes.len())
        .ok()
    };
    let (mut lo, mut hi) = (
        input.sdf.voxel_size.ln(),
        input.domain.size().length().max(input.sdf.voxel_size).ln(),
    );
    let mut best: Option<(usize, usize, f32)> = None;
    for _ in 0..SPACING_STEPS {
        let mid = 0.5 * (lo + hi);
        let s = mid.exp();
        match count(s) {
            Some(n) => {
                let key = (n.abs_diff(target), usize::MAX - n);
                if best.is_none_or(|(d, m, _)| key < (d, m)) {
                    best = Some((key.0, key.1, s));
                }
                if n > target {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            // Too fine (over the point limit) or no probe at all.
            None => lo = mid,
        }
    }
    best.map(|(_, _, s)| s)
}

/// The baseline's parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AdaptiveParams {
    /// The finest probe spacing s₀ (world units).
    pub min_spacing: f32,
    /// Subdivision levels L: the coarsest spacing is s₀·3^(L−1).
    pub levels: u32,
}

/// The adaptive baseline's probes (module docs), ordered by their level-0
/// lattice coordinates (z, then y, then x).
///
/// Contract: deterministic; every probe stands in a free voxel inside the
/// domain. Errors: more than [`MAX_POINTS`] lattice points, or no probe
/// left, are user errors naming `adaptive`.
pub fn adaptive(params: &AdaptiveParams, input: &PlacementInput) -> Result<ProbeSet> {
    let (sdf, domain) = (input.sdf, input.domain);
    let s0 = params.min_spacing;
    let top = params.levels.max(1) - 1;
    let unit = |k: u32| 3i32.pow(k);
    let edge = |k: u32| 3.0 * s0 * unit(k) as f32;
    let tiles = (domain.size() / edge(top))
        .ceil()
        .as_ivec3()
        .max(IVec3::ONE);
    // Level-0 coordinates → the finest level giving the point.
    let mut points: BTreeMap<(i32, i32, i32), u32> = BTreeMap::new();
    let mut bricks = vec![0u64; top as usize + 1];
    let mut stack: Vec<(IVec3, u32)> = Vec::new();
    for z in 0..tiles.z {
        for y in 0..tiles.y {
            for x in 0..tiles.x {
                stack.push((IVec3::new(x, y, z) * 3 * unit(top), top));
            }
        }
    }
    while let Some((lo, k)) = stack.pop() {
        let low = domain.min + lo.as_vec3() * s0;
        let (surface, all_solid) = survey(sdf, low, low + Vec3::splat(edge(k)));
        if all_solid {
            continue;
        }
        if k > 0 && surface {
            for c in 0..27 {
                let offset = IVec3::new(c % 3, (c / 3) % 3, c / 9) * 3 * unit(k - 1);
                stack.push((lo + offset, k - 1));
            }
            continue;
        }
        bricks[k as usize] += 1;
        for c in 0..64 {
            let p = lo + IVec3::new(c % 4, (c / 4) % 4, c / 16) * unit(k);
            let level = points.entry((p.z, p.y, p.x)).or_insert(k);
            *level = (*level).min(k);
        }
        if points.len() > MAX_POINTS {
            return Err(Error::User(format!(
                "adaptive: a minimum spacing of {} gives over {MAX_POINTS} probe positions in this domain; raise it",
                short(s0)
            )));
        }
    }
    let clearance = grid_min_clearance(sdf);
    let (mut moved, mut dropped, mut outside) = (0u64, 0u64, 0u64);
    let mut probes = Vec::new();
    for (&(z, y, x), &k) in &points {
        let start = domain.min + Vec3::new(x as f32, y as f32, z as f32) * s0;
        if !domain.contains(start) {
            outside += 1;
            continue;
        }
        match virtual_offset(sdf, start, clearance, 0.5 * s0 * unit(k) as f32) {
            Some(p) => {
                moved += (p != start) as u64;
                probes.push(Probe {
                    position: p,
                    cluster_size: 0,
                });
            }
            None => dropped += 1,
        }
    }
    if probes.is_empty() {
        return Err(Error::User(
            "adaptive: every probe stands in solid or outside the scene; check the domain".into(),
        ));
    }
    let mut stats: BTreeMap<&'static str, u64> = BTreeMap::from([
        ("lattice_points", points.len() as u64),
        ("outside_domain", outside),
        ("moved", moved),
        ("dropped", dropped),
    ]);
    const NAMES: [&str; 4] = [
        "bricks_level_0",
        "bricks_level_1",
        "bricks_level_2",
        "bricks_level_3",
    ];
    for (k, &n) in bricks.iter().enumerate().take(NAMES.len()) {
        stats.insert(NAMES[k], n);
    }
    Ok(ProbeSet {
        method: format!("adaptive:{}", short(s0)),
        probes,
        stats,
        params: BTreeMap::from([("min_spacing", s0 as f64), ("levels", params.levels as f64)]),
        min_clearance: clearance,
        fixed: 0,
    })
}

/// Over the voxels whose centres lie in the box `lo..hi`: whether a
/// surface crosses one (its distance within half a voxel diagonal), and
/// whether all of them are solid (none is when the box holds no centre).
fn survey(sdf: &Sdf, lo: Vec3, hi: Vec3) -> (bool, bool) {
    let first = ((lo - sdf.origin) / sdf.voxel_size - 0.5)
        .ceil()
        .max(Vec3::ZERO)
        .as_uvec3();
    let last = ((hi - sdf.origin) / sdf.voxel_size - 0.5).floor();
    if last.cmplt(Vec3::ZERO).any() {
        return (false, false);
    }
    let last = last.as_uvec3().min(sdf.dims - 1);
    let crossing = 0.5 * 3f32.sqrt() * sdf.voxel_size;
    let (mut surface, mut all_solid, mut any) = (false, true, false);
    for z in first.z..=last.z {
        for y in first.y..=last.y {
            for x in first.x..=last.x {
                let v = sdf.index(glam::UVec3::new(x, y, z));
                any = true;
                surface |= sdf.distance[v].abs() <= crossing;
                all_solid &= sdf.class[v] == VoxelClass::Solid;
                if surface && !all_solid {
                    return (true, false);
                }
            }
        }
    }
    (surface, any && all_solid)
}

/// The SDF at `p`'s voxel: positive in free space, negative in solid, the
/// domain's edge (no surface known) beyond the grid.
fn signed_distance(sdf: &Sdf, p: Vec3) -> f32 {
    match sdf.voxel_at(p) {
        Some(v) if sdf.class[v] == VoxelClass::Solid => -sdf.distance[v].abs(),
        Some(v) => sdf.distance[v],
        None => f32::INFINITY,
    }
}

/// Where a probe starting at `p` ends (module docs, step 4), or `None`.
fn virtual_offset(sdf: &Sdf, p: Vec3, clearance: f32, reach: f32) -> Option<Vec3> {
    let good = |v: usize| sdf.class[v] == VoxelClass::Free && sdf.distance[v] >= clearance;
    let start = sdf.voxel_at(p)?;
    match sdf.class[start] {
        VoxelClass::Free if sdf.distance[start] >= clearance => return Some(p),
        VoxelClass::Outside => return None,
        VoxelClass::Free | VoxelClass::Solid => {}
    }
    let mut at = sdf.coords(start).as_ivec3();
    for _ in 0..((reach / sdf.voxel_size).floor() as usize) {
        let next = (0..27)
            .map(|c| at + IVec3::new(c % 3 - 1, (c / 3) % 3 - 1, c / 9 - 1))
            .filter(|c| c.cmpge(IVec3::ZERO).all() && c.cmplt(sdf.dims.as_ivec3()).all())
            .max_by(|a, b| {
                let d = |c: &IVec3| signed_distance(sdf, sdf.center(sdf.index(c.as_uvec3())));
                d(a).total_cmp(&d(b)).then(b.to_array().cmp(&a.to_array()))
            })?;
        if next == at {
            return None;
        }
        at = next;
        let v = sdf.index(at.as_uvec3());
        if good(v) {
            let q = sdf.center(v);
            return ((q - p).length() <= reach).then_some(q);
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::progress::Progress;
    use crate::scene::testing::room_sdf;

    fn run(min_spacing: f32, levels: u32) -> (ProbeSet, Sdf) {
        run_in(room_sdf(0.125, 2), min_spacing, levels)
    }

    /// A 12-unit hall with a unit box in its middle: open space to stay
    /// coarse in.
    fn hall() -> (crate::scene::Scene, crate::scene::raycast::SceneBvh, Sdf) {
        use crate::scene::testing::{add_box, bvh_and_sdf};
        let mut tris = Vec::new();
        add_box(&mut tris, Vec3::ZERO, Vec3::splat(12.0), true);
        add_box(&mut tris, Vec3::splat(5.5), Vec3::splat(6.5), false);
        let scene = crate::scene::Scene::from_triangles(
            "hall".into(),
            tris.into_iter().map(|t| (t, 0)),
            vec![crate::scene::Material::fallback()],
        )
        .unwrap();
        let (bvh, sdf) = bvh_and_sdf(&scene, 0.25, 2);
        (scene, bvh, sdf)
    }

    fn run_in(
        (scene, bvh, sdf): (crate::scene::Scene, crate::scene::raycast::SceneBvh, Sdf),
        min_spacing: f32,
        levels: u32,
    ) -> (ProbeSet, Sdf) {
        let progress = Progress::hidden();
        let input = PlacementInput {
            scene: &scene,
            bvh: &bvh,
            sdf: &sdf,
            domain: &scene.bounds,
            seed: 1,
            progress: &progress,
        };
        (
            adaptive(
                &AdaptiveParams {
                    min_spacing,
                    levels,
                },
                &input,
            )
            .unwrap(),
            sdf,
        )
    }

    #[test]
    fn one_level_is_a_lattice_of_the_spacing() {
        let (set, sdf) = run(0.5, 1);
        for p in &set.probes {
            let v = sdf.voxel_at(p.position).unwrap();
            assert_eq!(sdf.class[v], VoxelClass::Free);
        }
        // Unmoved probes lie on the 0.5 lattice from the room's corner.
        let s = &set.stats;
        let unmoved = s["lattice_points"] - s["outside_domain"] - s["moved"] - s["dropped"];
        let on_lattice = set
            .probes
            .iter()
            .filter(|p| (p.position / 0.5).round() * 0.5 == p.position)
            .count() as u64;
        assert_eq!(on_lattice, unmoved);
        assert_eq!(set.probes.len() as u64, unmoved + s["moved"]);
        assert!(!set.stats.contains_key("bricks_level_1"));
    }

    /// Two levels: probes crowd around the box in the hall's middle and
    /// thin out in the open, fewer in all than the finest lattice.
    #[test]
    fn bricks_subdivide_where_geometry_is_near() {
        let (fine, _) = run_in(hall(), 0.25, 1);
        let (set, sdf) = run_in(hall(), 0.25, 2);
        assert!(
            set.probes.len() < fine.probes.len(),
            "{} vs {}",
            set.probes.len(),
            fine.probes.len()
        );
        assert!(set.stats["bricks_level_0"] > 0 && set.stats["bricks_level_1"] > 0);
        let near = |p: &Probe| {
            let v = sdf.voxel_at(p.position).unwrap();
            sdf.distance[v] < 0.5
        };
        let (n_near, n_fine_near) = (
            set.probes.iter().filter(|p| near(p)).count(),
            fine.probes.iter().filter(|p| near(p)).count(),
        );
        // Near surfaces the adaptive set keeps most of the finest lattice.
        assert!(
            2 * n_near >= n_fine_near,
            "{n_near} of {n_fine_near} near surfaces"
        );
        for p in &set.probes {
            assert!(sdf.class[sdf.voxel_at(p.position).unwrap()] == VoxelClass::Free);
        }
    }
}
