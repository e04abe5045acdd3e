//! The SDF's voxel size, chosen for the user (`voxel_size: Auto`).
//!
//! Wang et al. 2019 §3.1 voxelize the scene at a resolution the user picks
//! per scene. A user running the tool on a scene nobody tuned for should not
//! have to: the voxel size follows from the scene itself, by three rules,
//! each a length that scales with the scene (so a scene in millimetres and
//! the same scene in metres get the same grid up to scale, and translating
//! it changes nothing):
//!
//! * **budget**: the edge that cuts the domain into [`TARGET_VOXELS`]
//!   cubes, `∛(V / TARGET_VOXELS)`; the cost of every later stage grows with
//!   the voxel count, so the budget bounds the run time on any scene;
//! * **thin domains**: at most `shortest axis / MIN_VOXELS_ACROSS`, so a flat
//!   domain (a ground plane and its clutter, one storey of a wide building)
//!   still has room for a skeleton across its height;
//! * **feature size**: the scene's narrow free spaces (under tables and
//!   beds, between pews, doorways) hold probes only where a voxel is a
//!   fraction of their width. Rays from [`FEATURE_SAMPLES`] area-uniform
//!   surface samples along their front normals measure the free gap in
//!   front of each (to the next front face; escapes and contacts, such as a
//!   box's bottom resting on a floor, are left out); the
//!   [`FEATURE_PERCENTILE`] of the gaps is the scene's feature size, and the
//!   edge is at most `feature / FEATURE_VOXELS`.
//!
//! The smallest of the three wins, but never below the edge that gives
//! [`MAX_AUTO_VOXELS`] cubes (four times the budget), so that a scene of
//! fine clutter cannot blow up the run.

use crate::coverage::sample_surface;
use crate::sampling::hash2;
use crate::scene::raycast::SceneBvh;
use crate::scene::{Bounds, Scene};
use rayon::prelude::*;

/// Voxels the budget rule aims at: 2¹⁸, about a 64³ grid.
pub const TARGET_VOXELS: f64 = 262_144.0;

/// Most voxels the feature rule may ask for: 2²⁰.
pub const MAX_AUTO_VOXELS: f64 = 1_048_576.0;

/// Fewest voxels across the domain's shortest axis (thin-domain rule).
pub const MIN_VOXELS_ACROSS: f32 = 16.0;

/// Voxels across the scene's feature size: a gap of 4 voxels holds a probe
/// at 1–2 voxels from both sides.
pub const FEATURE_VOXELS: f32 = 4.0;

/// Share of the surface (by area) whose free gap is narrower than the
/// feature size.
pub const FEATURE_PERCENTILE: f64 = 0.1;

/// Surface samples whose gaps are measured.
pub const FEATURE_SAMPLES: usize = 4096;

/// How the voxel size was chosen, for `report.json` (`resolution`).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Resolution {
    /// The voxel edge used (world units).
    pub voxel_size: f32,
    /// `auto` or `config`.
    pub source: &'static str,
    /// The budget rule's edge (`null` when given in the config).
    pub from_budget: Option<f32>,
    /// The thin-domain rule's edge.
    pub from_thinness: Option<f32>,
    /// The scene's feature size (`null` when no gap was measured).
    pub feature_size: Option<f32>,
    /// The feature rule's edge.
    pub from_feature: Option<f32>,
    /// The least edge the rules may give ([`MAX_AUTO_VOXELS`]).
    pub floor: Option<f32>,
}

impl Resolution {
    /// A voxel size the config gave.
    pub fn fixed(voxel_size: f32) -> Resolution {
        Resolution {
            voxel_size,
            source: "config",
            from_budget: None,
            from_thinness: None,
            feature_size: None,
            from_feature: None,
            floor: None,
        }
    }
}

/// The rules that need only the domain's size: the budget's edge, the
/// thin-domain edge and the floor (module docs).
fn domain_rules(size: glam::Vec3) -> (f32, f32, f32) {
    let diagonal = size.length().max(f32::MIN_POSITIVE);
    // A degenerate axis (a flat scene) counts as a hundredth of the
    // diagonal, so the volume stays positive.
    let axes = size.max(glam::Vec3::splat(1e-2 * diagonal));
    let volume = axes.x as f64 * axes.y as f64 * axes.z as f64;
    let from_budget = (volume / TARGET_VOXELS).cbrt() as f32;
    let floor = (volume / MAX_AUTO_VOXELS).cbrt() as f32;
    let from_thinness = axes.min_element() / MIN_VOXELS_ACROSS;
    (from_budget, from_thinness, floor)
}

/// The voxel size `split` gives every tile of a world whose config leaves
/// it `Auto`: the budget and thin-domain rules over the whole world's
/// domain, so that tiles share one grid pitch and together spend the
/// budget one machine would. The feature rule needs the whole scene's
/// geometry, which a split never loads; a world with narrow gaps should
/// give `voxel_size` (docs/tiles.md).
pub(crate) fn auto_from_domain(world: &crate::tiles::WorldBox) -> f32 {
    let (budget, thinness, floor) = domain_rules(world.size().as_vec3());
    budget.min(thinness).max(floor)
}

/// Chooses the voxel size for `domain` of `scene` (module docs).
///
/// Contract: deterministic for `(scene, domain, seed)`; positive and
/// finite; scales with the scene (the same scene scaled by `s` gives `s`
/// times the size, to float rounding); the grid it gives has at most about
/// [`MAX_AUTO_VOXELS`] voxels.
pub fn auto(scene: &Scene, bvh: &SceneBvh, domain: &Bounds, seed: u64) -> Resolution {
    let (from_budget, from_thinness, floor) = domain_rules(domain.size());
    let feature_size = feature_size(scene, bvh, domain, floor, seed);
    let from_feature = feature_size.map(|f| f / FEATURE_VOXELS);
    let voxel_size = from_budget
        .min(from_thinness)
        .min(from_feature.unwrap_or(f32::INFINITY))
        .max(floor);
    Resolution {
        voxel_size,
        source: "auto",
        from_budget: Some(from_budget),
        from_thinness: Some(from_thinness),
        feature_size,
        from_feature,
        floor: Some(floor),
    }
}

/// The [`FEATURE_PERCENTILE`] of the free gaps in front of area-uniform
/// surface samples inside `domain` (module docs); gaps narrower than
/// `finest` (which no allowed voxel resolves) and escaping rays are left
/// out. `None` when no gap remains.
fn feature_size(
    scene: &Scene,
    bvh: &SceneBvh,
    domain: &Bounds,
    finest: f32,
    seed: u64,
) -> Option<f32> {
    if scene.triangles.is_empty() {
        return None;
    }
    let samples = sample_surface(scene, FEATURE_SAMPLES, hash2(seed, 0xFEA7));
    let eps = 1e-4 * domain.size().length();
    let mut gaps: Vec<f32> = samples
        .par_iter()
        .filter(|s| domain.contains(s.position))
        .filter_map(|s| {
            let hit = bvh.closest_hit(s.position, s.normal, eps, f32::INFINITY)?;
            (!hit.backface && hit.t >= finest).then_some(hit.t)
        })
        .collect();
    if gaps.is_empty() {
        return None;
    }
    gaps.sort_unstable_by(f32::total_cmp);
    let k = ((gaps.len() - 1) as f64 * FEATURE_PERCENTILE).round() as usize;
    Some(gaps[k])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::testing::room_with_box;
    use crate::scene::Material;
    use glam::Vec3;

    fn scaled(scene: &Scene, s: f32) -> Scene {
        let tris = scene
            .triangles
            .iter()
            .map(|t| ([t[0] * s, t[1] * s, t[2] * s], 0));
        Scene::from_triangles("s".into(), tris, vec![Material::fallback()]).unwrap()
    }

    #[test]
    fn auto_size_scales_with_the_scene_and_respects_its_bounds() {
        let room = room_with_box();
        let pick = |scene: &Scene| {
            let bvh = SceneBvh::new(scene);
            auto(scene, &bvh, &scene.bounds, 3)
        };
        let m = pick(&room);
        assert_eq!(m.source, "auto");
        assert!(m.voxel_size >= m.floor.unwrap() && m.voxel_size <= m.from_budget.unwrap());
        let voxels = room.bounds.size() / m.voxel_size;
        assert!(voxels.x * voxels.y * voxels.z <= 1.01 * MAX_AUTO_VOXELS as f32);
        for s in [1e-3, 1e3] {
            let k = pick(&scaled(&room, s));
            let ratio = k.voxel_size / (s * m.voxel_size);
            assert!((ratio - 1.0).abs() < 1e-3, "scale {s}: {ratio}");
        }
        assert_eq!(pick(&room), m);
    }

    /// A slot a tenth of the room's height, taking most of the surface,
    /// sets the size by the feature rule.
    #[test]
    fn narrow_gaps_refine_the_grid() {
        let quad = |a: Vec3, b: Vec3, c: Vec3, d: Vec3| [([a, b, c], 0), ([a, c, d], 0)];
        // Two large parallel plates 0.2 apart facing each other, in a room
        // of 4 x 2 x 4 (the room's own walls face inward).
        let mut tris: Vec<([Vec3; 3], u32)> =
            room_with_box().triangles.iter().map(|t| (*t, 0)).collect();
        let (lo, hi) = (1.5, 1.7);
        tris.extend(quad(
            Vec3::new(0.0, lo, 0.0),
            Vec3::new(0.0, lo, 4.0),
            Vec3::new(4.0, lo, 4.0),
            Vec3::new(4.0, lo, 0.0),
        ));
        tris.extend(quad(
            Vec3::new(0.0, hi, 0.0),
            Vec3::new(4.0, hi, 0.0),
            Vec3::new(4.0, hi, 4.0),
            Vec3::new(0.0, hi, 4.0),
        ));
        let scene = Scene::from_triangles("slot".into(), tris, vec![Material::fallback()]).unwrap();
        let bvh = SceneBvh::new(&scene);
        let r = auto(&scene, &bvh, &scene.bounds, 1);
        let f = r.feature_size.unwrap();
        assert!((f - 0.2).abs() < 1e-3, "feature {f}");
        assert_eq!(r.voxel_size, (f / FEATURE_VOXELS).max(r.floor.unwrap()));
    }
}
