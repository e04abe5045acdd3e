//! Artist controls: what a technical artist pins, forbids, caps or
//! weights by hand, the way engine bakers let them (Unity's probe
//! adjustment volumes, Godot's `LightmapProbe`, RTXGI's volumes).
//!
//! The config's four fields, resolved into the scene's local frame:
//!
//! * `fixed_probes`: probes that stand exactly where given. They come first
//!   in the probe set ([`ProbeSet::fixed`]); refinement never moves them
//!   ([`crate::refine::gibbs`] skips them), pruning never drops them, and
//!   the fitness and the cover matrix count what they see, so the placer
//!   adds only what they miss (Wang et al. 2019 §3.3 maximizes the union's
//!   fitness; a pinned probe is a term of it that does not move).
//! * `exclude`: boxes no probe may stand in: the placement's probes inside
//!   one are dropped, refinement may not move a probe into one, filling
//!   adds none there.
//! * `max_probes`: a budget. Above it the placer keeps, greedily, the
//!   probes that cover the most of what is still uncovered (the classic
//!   (1 − 1/e) approximation of maximum coverage, Nemhauser, Wolsey and
//!   Fisher 1978), the fixed probes first.
//! * `min_probes`: a floor. When coverage needs fewer probes, the placer
//!   adds the ones that lower the texel footprint of the views most
//!   ([`crate::refine::topup`]): a budget spent, not left unused, and the
//!   way to place exactly `N` probes (with `max_probes: N`) for a comparison
//!   at equal count (Wang et al. 2019 §5.2).
//! * `probe_density`: boxes whose surfaces must be seen by more (factor
//!   above 1) or fewer (below 1) probes. Coverage is Wang's criterion
//!   (§2: every surface point seen by some probe); a factor `d` makes each
//!   coverage sample inside the box need `⌊d⌋` views, and one more with
//!   probability `d − ⌊d⌋` (a seeded hash per sample), so `d = 2` asks for
//!   two probes on every surface there, `d = 0.5` for one on half the
//!   samples, and `d = 0` for none. Filling and pruning work to that demand
//!   ([`crate::refine::prune`]); probes then crowd where it is high and thin
//!   out where it is low. Overlapping factors multiply.

use crate::config::{Config, Region};
use crate::error::{Error, Result};
use crate::placement::{Probe, ProbeSet};
use crate::sampling::{hash2, unit_f32};
use crate::scene::{Bounds, Scene};
use crate::sdf::{Sdf, VoxelClass};
use glam::{DVec3, Vec3};

/// The artist controls of a run, in the scene's local frame (module docs).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Controls {
    /// Where the fixed probes stand, in the config's order.
    pub fixed: Vec<Vec3>,
    /// Boxes no probe may stand in.
    pub exclude: Vec<Bounds>,
    /// The most probes the run keeps.
    pub max_probes: Option<usize>,
    /// The fewest probes the run keeps.
    pub min_probes: Option<usize>,
    /// Boxes and their density factors.
    pub density: Vec<(Bounds, f32)>,
    /// Seed of the per-sample draws of fractional densities.
    pub seed: u64,
}

/// What the controls did, for `report.json` (docs/formats.md, `controls`).
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct ControlsReport {
    /// Fixed probes in the output (the first this many of `probes.json`).
    pub fixed_probes: usize,
    /// Probes of the placement dropped for standing in an `exclude` box.
    pub excluded: usize,
    /// The budget, when one was set.
    pub max_probes: Option<usize>,
    /// Probes before the budget was applied (`null` when it was not
    /// needed: the run kept no more than `max_probes` anyway).
    pub probes_before_budget: Option<usize>,
    /// The floor, when one was set.
    pub min_probes: Option<usize>,
    /// Probes before the top-up added to them (`null` when it did not:
    /// coverage needed `min_probes` or more anyway).
    pub probes_before_minimum: Option<usize>,
    /// `probe_density` regions.
    pub density_regions: usize,
    /// Coverage samples whose demand is not one view (inside a
    /// `probe_density` region with a factor other than 1).
    pub samples_with_density: usize,
    /// Share of the demanded views the final probes give (1 − holes, where
    /// a sample needing `k` views counts as covered once `k` probes see
    /// it); `null` without refinement or a budget.
    pub demand_met: Option<f64>,
}

fn region_bounds(region: &Region, scene: &Scene) -> Bounds {
    match region {
        Region::Box(b) => Bounds {
            min: scene.to_local(DVec3::from_array(b.min)),
            max: scene.to_local(DVec3::from_array(b.max)),
        },
    }
}

impl Controls {
    /// The controls of `config`, in `scene`'s local frame.
    pub fn new(config: &Config, scene: &Scene) -> Controls {
        Controls {
            fixed: config
                .fixed_probes
                .iter()
                .map(|p| scene.to_local(DVec3::from_array(p.0)))
                .collect(),
            exclude: config
                .exclude
                .iter()
                .map(|r| region_bounds(r, scene))
                .collect(),
            max_probes: config.max_probes.map(|n| n.0 as usize),
            min_probes: config.min_probes.map(|n| n.0 as usize),
            density: config
                .probe_density
                .iter()
                .map(|(r, d)| (region_bounds(r, scene), d.0))
                .collect(),
            seed: config.seed,
        }
    }

    /// Whether no control is set.
    pub fn is_empty(&self) -> bool {
        self.fixed.is_empty()
            && self.exclude.is_empty()
            && self.max_probes.is_none()
            && self.min_probes.is_none()
            && self.density.is_empty()
    }

    /// Whether `p` lies in an `exclude` box.
    pub fn excluded(&self, p: Vec3) -> bool {
        self.exclude.iter().any(|b| b.contains(p))
    }

    /// The density factor at `p`: the product of those of the regions
    /// holding it, 1 outside them all.
    pub fn density_at(&self, p: Vec3) -> f32 {
        self.density
            .iter()
            .filter(|(b, _)| b.contains(p))
            .map(|&(_, d)| d)
            .product()
    }

    /// Views coverage sample `index`, at `p`, needs (module docs): 1
    /// outside every density region; else `⌊d⌋`, plus one with probability
    /// `d − ⌊d⌋`, drawn from the seed and the index.
    pub fn need(&self, index: usize, p: Vec3) -> u32 {
        if self.density.is_empty() {
            return 1;
        }
        let d = self.density_at(p);
        let whole = d.floor();
        let extra = unit_f32(hash2(hash2(self.seed, 0xDE75), index as u64)) < d - whole;
        whole as u32 + extra as u32
    }

    /// Checks the controls against the run's SDF and domain, before any
    /// placement. Errors name the field and the entry: a fixed probe
    /// outside the domain, in a solid voxel, inside an `exclude` box or
    /// repeating an earlier one; more fixed probes than `max_probes`;
    /// `min_probes` above `max_probes`.
    pub fn check(&self, config: &Config, sdf: &Sdf, domain: &Bounds) -> Result<()> {
        let world = |i: usize| crate::config::short_all(&config.fixed_probes[i].0);
        for (i, &p) in self.fixed.iter().enumerate() {
            let at = format!("fixed_probes[{i}]: {}", world(i));
            if !domain.contains(p) {
                return Err(Error::User(format!("{at} is outside the domain")));
            }
            if let Some(v) = sdf.voxel_at(p) {
                if sdf.class[v] == VoxelClass::Solid {
                    return Err(Error::User(format!(
                        "{at} stands in solid (its SDF voxel is inside an object); move it into free space"
                    )));
                }
            }
            if let Some(j) = self.exclude.iter().position(|b| b.contains(p)) {
                return Err(Error::User(format!("{at} lies inside exclude[{j}]")));
            }
            if let Some(j) = self.fixed[..i].iter().position(|&q| q == p) {
                return Err(Error::User(format!("{at} repeats fixed_probes[{j}]")));
            }
        }
        if let Some(n) = self.max_probes {
            if self.fixed.len() > n {
                return Err(Error::User(format!(
                    "max_probes: {n} is fewer than the {} fixed_probes",
                    self.fixed.len()
                )));
            }
        }
        if let (Some(min), Some(max)) = (self.min_probes, self.max_probes) {
            if min > max {
                return Err(Error::User(format!(
                    "min_probes: {min} is more than max_probes: {max}"
                )));
            }
        }
        Ok(())
    }

    /// `probes` with those inside an `exclude` box dropped and the fixed
    /// probes put first ([`ProbeSet::fixed`]); and how many were dropped.
    pub fn apply(&self, mut probes: ProbeSet) -> (ProbeSet, usize) {
        let before = probes.probes.len();
        probes.probes.retain(|p| !self.excluded(p.position));
        let excluded = before - probes.probes.len();
        let fixed = self.fixed.iter().map(|&position| Probe {
            position,
            cluster_size: 0,
        });
        probes.probes.splice(0..0, fixed);
        probes.fixed = self.fixed.len();
        (probes, excluded)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn unit_box(min: f32, max: f32) -> Bounds {
        Bounds {
            min: Vec3::splat(min),
            max: Vec3::splat(max),
        }
    }

    #[test]
    fn densities_multiply_and_need_matches_them_on_average() {
        let c = Controls {
            density: vec![(unit_box(0.0, 2.0), 2.0), (unit_box(1.0, 3.0), 0.75)],
            ..Controls::default()
        };
        assert_eq!(c.density_at(Vec3::splat(0.5)), 2.0);
        assert_eq!(c.density_at(Vec3::splat(1.5)), 1.5);
        assert_eq!(c.density_at(Vec3::splat(2.5)), 0.75);
        assert_eq!(c.density_at(Vec3::splat(5.0)), 1.0);
        assert_eq!(c.need(7, Vec3::splat(0.5)), 2);
        assert_eq!(c.need(7, Vec3::splat(5.0)), 1);
        // 1.5 views: one or two, two about half the time.
        let needs: Vec<u32> = (0..4000).map(|i| c.need(i, Vec3::splat(1.5))).collect();
        assert!(needs.iter().all(|&n| n == 1 || n == 2));
        let mean = needs.iter().sum::<u32>() as f64 / needs.len() as f64;
        assert!((mean - 1.5).abs() < 0.05, "mean need {mean}");
        let zero = Controls {
            density: vec![(unit_box(0.0, 1.0), 0.0)],
            ..Controls::default()
        };
        assert_eq!(zero.need(3, Vec3::splat(0.5)), 0);
    }

    #[test]
    fn apply_drops_excluded_probes_and_puts_fixed_ones_first() {
        let c = Controls {
            fixed: vec![Vec3::splat(9.0)],
            exclude: vec![unit_box(0.0, 1.0)],
            ..Controls::default()
        };
        let probe = |x: f32| Probe {
            position: Vec3::splat(x),
            cluster_size: 3,
        };
        let set = ProbeSet {
            method: "test".into(),
            probes: vec![probe(0.5), probe(2.0), probe(1.0), probe(4.0)],
            stats: Default::default(),
            params: Default::default(),
            min_clearance: 0.0,
            fixed: 0,
        };
        let (out, excluded) = c.apply(set);
        assert_eq!(excluded, 2, "a probe on the box's face is inside it");
        assert_eq!(out.fixed, 1);
        assert_eq!(
            out.positions(),
            vec![Vec3::splat(9.0), Vec3::splat(2.0), Vec3::splat(4.0)]
        );
    }
}
