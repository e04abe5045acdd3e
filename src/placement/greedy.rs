//! The `greedy:SPACING` method: Silvennoinen & Lehtinen 2017, "Real-time
//! Global Illumination by Precomputed Local Reconstruction from Sparse
//! Radiance Probes" (ACM TOG 36(6)), §4.1 "Probe Locations and Radii".
//!
//! **Why it is here.** It is the published placement closest to ours in
//! aim (sparse probes that see every surface) and the simplest to state:
//! one parameter, the spacing ρ, and no visibility reasoning at all. It is a
//! competitor for the comparison, implemented as the paper describes:
//!
//! 1. **Voxelize and flood-fill the empty interior.** Our SDF already does
//!    both: its free class is the empty space inside the scene (solid and
//!    outside-the-scene voxels are excluded), so no flood fill is run here.
//! 2. **Candidates: empty voxels with non-empty neighbours.** The paper's
//!    voxelization marks voxels that hold geometry. With an SDF a voxel
//!    *may* hold geometry when its centre lies within half a voxel diagonal
//!    of a surface (the cube's circumradius), and is solid when it lies
//!    behind surfaces; those are the non-empty voxels. An empty voxel is a
//!    free one at least one voxel from every surface (so it provably holds
//!    none, and a probe there keeps the clearance refinement keeps for
//!    grids). A candidate is an empty voxel with a non-empty voxel among its
//!    26 neighbours ([`candidates`]). Outside-the-scene voxels (the sky, the
//!    open front of the Cornell box) are neither: the edge of the scene is
//!    not a surface to light. This differs from "free voxels with a non-free
//!    neighbour" on purpose: walls at the domain's boundary (every room whose
//!    domain is its bounding box) have no voxel beyond them in the grid, and
//!    a thin free layer (distance under a voxel) would otherwise stand
//!    between the candidates and the surface.
//! 3. **Kernel density** at every candidate, with eq. 10's weight
//!    w(t) = 2t³ − 3t² + 1 for t = |x − p|/ρ ≤ 1 ([`kernel_weight`]).
//! 4. **Remove** the candidate of highest density, subtract its weight from
//!    its neighbours, and repeat until the target count remains
//!    ([`thin`]). Ties go to the lower index, so the result is deterministic.
//! 5. **Target count**, "to avoid introducing additional parameters": the
//!    number of points of a regular grid covering the domain with spacing ρ,
//!    one point per cell, ⌈extent/ρ⌉ per axis ([`covering_grid_count`]).
//!
//! Candidates near surfaces number 10⁵ and more in a detailed scene; above
//! [`MAX_CANDIDATES`] a seeded, uniform subsample is kept (which leaves the
//! candidates' density, and so what gets removed first, unchanged in
//! expectation), and the stats say so (`candidates` versus
//! `candidates_used`). The paper computes a radius per probe set afterwards
//! for its own interpolation (N_overlap = 10); our probes carry no radius,
//! so that step has no counterpart here.

use super::grid::grid_min_clearance;
use crate::config::numbers::Positive;
use crate::error::{Error, Result};
use crate::placement::method::{length_argument, Method, Role};
use crate::probes::{PlacementInput, Probe, ProbeSet};
use crate::sampling::hash2;
use crate::scene::Bounds;
use crate::sdf::{Sdf, VoxelClass};
use glam::{IVec3, Vec3};
use kiddo::{ImmutableKdTree, SquaredEuclidean};
use rayon::prelude::*;
use serde::Deserialize;
use std::cmp::Ordering;
use std::collections::{BTreeMap, BinaryHeap};

/// Parameters of the greedy voxel placement (Silvennoinen & Lehtinen 2017,
/// §4.1 "Probe Locations and Radii").
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GreedyParams {
    /// The paper's ρ_probes (world units): the radius of the density
    /// kernel, and the spacing of the regular grid over the domain whose
    /// point count is the number of probes kept.
    pub spacing: Positive,
}

/// The `greedy:SPACING` method, a competitor: [`greedy`].
pub struct Greedy;

impl Method for Greedy {
    type Params = GreedyParams;
    const WORD: &'static str = "greedy";
    const TAKES_ARGUMENT: bool = true;
    const FORM: &'static str = "greedy:SPACING";
    const ABOUT: &'static str = "Silvennoinen & Lehtinen 2017 §4.1: candidate voxels near surfaces thinned greedily by kernel density";
    const ROLE: Role = Role::Competitor;
    const LABEL: &'static str = "greedy (Silvennoinen & Lehtinen)";
    const MARKER: (&'static str, &'static str) = ("#a03090", "triangle");

    /// The spacing that gives about `count` probes over the domain.
    fn at_count(
        input: &PlacementInput,
        _: &[(usize, crate::config::params::GridParams)],
        count: usize,
    ) -> Option<GreedyParams> {
        Some(GreedyParams {
            spacing: Positive(spacing_for_count(input.domain, count.max(1))),
        })
    }

    fn name(params: &GreedyParams) -> String {
        format!("greedy:{}", crate::config::numbers::short(params.spacing.0))
    }

    fn parse_cli(
        argument: Option<&str>,
        _: Option<&GreedyParams>,
    ) -> std::result::Result<GreedyParams, String> {
        let spacing = length_argument(argument, "spacing", "greedy:0.5")?;
        Ok(GreedyParams { spacing })
    }

    fn place(params: &GreedyParams, input: &PlacementInput) -> Result<ProbeSet> {
        greedy(params, input)
    }
}

/// Most candidates the thinning works on; more are subsampled (seeded).
pub const MAX_CANDIDATES: usize = 20_000;

/// Relative slack under which an extent that is a whole number of
/// spacings (up to float rounding) does not gain an extra grid point. It is
/// relative, so coincident steps of different axes (4/2 and 2/1) stay
/// coincident and [`spacing_for_count`] sees no slivers between them.
const COVER_SLACK: f64 = 1e-5;

/// Silvennoinen & Lehtinen's eq. 10: w(t) = 2t³ − 3t² + 1 on [0, 1], zero
/// beyond (and at t = 1). A smooth step from 1 at the centre to 0 at the rim.
pub fn kernel_weight(t: f32) -> f32 {
    if (0.0..1.0).contains(&t) {
        (2.0 * t - 3.0) * t * t + 1.0
    } else {
        0.0
    }
}

/// Points of the regular grid that covers `domain` with spacing `spacing`:
/// ⌈extent/spacing⌉ per axis (at least 1; an extent within a relative 10⁻⁵
/// of a whole number of spacings counts as that number), multiplied;
/// saturates instead of overflowing. The paper's target probe count.
pub fn covering_grid_count(domain: &Bounds, spacing: f32) -> u64 {
    let e = domain.size();
    (0..3)
        .map(|a| {
            let cells = (e[a] as f64 / spacing as f64 * (1.0 - COVER_SLACK)).ceil();
            if cells.is_nan() {
                1
            } else {
                cells.max(1.0) as u64
            }
        })
        .fold(1u64, u64::saturating_mul)
}

/// A spacing ρ whose covering grid over `domain` has the point count
/// nearest to `count` (ties: the fewer points), so that `greedy` can place
/// "as many probes as" another method.
///
/// Contract: `covering_grid_count(domain, spacing_for_count(domain, n))` is
/// the count nearest `n` that any spacing gives. Every count is reached by
/// a range of spacings; the (geometric) middle of that range is returned,
/// away from its ends so that rounding cannot tip the count. `count` 0 is
/// taken as 1; a count of 1 gets the domain's largest extent; a domain
/// without extent on any axis (one point at every spacing) gets 1.
pub fn spacing_for_count(domain: &Bounds, count: usize) -> f32 {
    let target = count.max(1) as u64;
    let e = domain.size();
    let largest = e.max_element();
    if largest.is_nan() || largest <= 0.0 {
        return 1.0;
    }
    // The count is a nonincreasing step function of ρ whose steps start at
    // ρ = extent·(1 − slack)/k of some axis (where it has k cells): between
    // two consecutive such breakpoints the count is constant.
    let mut breaks: Vec<f64> = Vec::new();
    for a in 0..3 {
        if e[a] <= 0.0 {
            continue;
        }
        for k in 1u64.. {
            let b = e[a] as f64 * (1.0 - COVER_SLACK) / k as f64;
            breaks.push(b);
            if covering_grid_count(domain, b as f32) > target.saturating_mul(2) {
                break;
            }
        }
    }
    breaks.sort_by(f64::total_cmp);
    breaks.dedup_by(|b, a| *b - *a <= 1e-9 * *a);
    // Above the last breakpoint the count is 1.
    let mut best = (
        largest,
        covering_grid_count(domain, largest).abs_diff(target),
    );
    for w in breaks.windows(2) {
        let rho = (w[0] * w[1]).sqrt() as f32;
        let diff = covering_grid_count(domain, rho).abs_diff(target);
        if diff < best.1 || (diff == best.1 && rho > best.0) {
            best = (rho, diff);
        }
    }
    best.0
}

/// The candidate voxels (module docs, step 2): free voxels at least one
/// voxel from every surface with a solid voxel, or a voxel within half a
/// voxel diagonal of a surface, among their 26 neighbours.
///
/// Contract: ascending voxel indices; every candidate is free and its
/// centre at least [`grid_min_clearance`] from the nearest surface.
pub fn candidates(sdf: &Sdf) -> Vec<usize> {
    let clearance = grid_min_clearance(sdf);
    let half_diagonal = 0.5 * 3f32.sqrt() * sdf.voxel_size;
    let non_empty =
        |j: usize| sdf.class[j] == VoxelClass::Solid || sdf.distance[j].abs() <= half_diagonal;
    let dims = sdf.dims.as_ivec3();
    (0..sdf.len())
        .into_par_iter()
        .filter(|&i| {
            if sdf.class[i] != VoxelClass::Free || sdf.distance[i] < clearance {
                return false;
            }
            let v = sdf.coords(i).as_ivec3();
            for dz in -1..=1 {
                for dy in -1..=1 {
                    for dx in -1..=1 {
                        let n = v + IVec3::new(dx, dy, dz);
                        if n.cmplt(IVec3::ZERO).any() || n.cmpge(dims).any() {
                            continue;
                        }
                        if non_empty(sdf.index(n.as_uvec3())) {
                            return true;
                        }
                    }
                }
            }
            false
        })
        .collect()
}

/// A density-ordered heap entry: highest density first, then lowest index.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Entry {
    density: f64,
    index: u32,
}

impl Eq for Entry {}

impl Ord for Entry {
    fn cmp(&self, other: &Self) -> Ordering {
        self.density
            .total_cmp(&other.density)
            .then(other.index.cmp(&self.index))
    }
}

impl PartialOrd for Entry {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

/// Greedy thinning (module docs, steps 3–4): of `points`, keeps `keep` by
/// repeatedly removing the point of highest kernel density (eq. 10 weights
/// of the other remaining points within `radius`), ties to the lower index.
///
/// Contract: returns ascending indices into `points`, `min(keep,
/// points.len())` of them; deterministic (neighbour sums in f64, in the k-d
/// tree's fixed traversal order).
///
/// Densities only fall as points go, so the max-heap holds one entry per
/// point whose key is an *upper bound* of its current (density, index):
/// a popped entry whose density is stale goes back with the current one,
/// and a popped entry that is current is the true maximum (every other key
/// bounds its point from above), ties included. That keeps the heap at one
/// entry per point instead of one per density update; the work is one
/// radius query per point and per removal.
pub fn thin(points: &[Vec3], radius: f32, keep: usize) -> Vec<usize> {
    if keep >= points.len() {
        return (0..points.len()).collect();
    }
    let coords: Vec<[f32; 3]> = points.iter().map(|p| p.to_array()).collect();
    let tree = ImmutableKdTree::<f32, 3>::new_from_slice(&coords)
        .expect("a k-d tree builds from the candidates");
    let r2 = radius * radius;
    let neighbours = |i: usize| {
        tree.query(&coords[i])
            .within::<SquaredEuclidean<f32>>(r2)
            .unsorted()
            .execute()
            .into_iter()
            .map(|n| {
                (
                    n.item as usize,
                    kernel_weight(n.distance.sqrt() / radius) as f64,
                )
            })
            .filter(move |&(j, w)| j != i && w > 0.0)
    };
    let mut density: Vec<f64> = (0..points.len())
        .into_par_iter()
        .map(|i| neighbours(i).map(|(_, w)| w).sum())
        .collect();
    let mut heap: BinaryHeap<Entry> = density
        .iter()
        .enumerate()
        .map(|(i, &d)| Entry {
            density: d,
            index: i as u32,
        })
        .collect();
    let mut alive = vec![true; points.len()];
    let mut remaining = points.len();
    while remaining > keep {
        let Some(e) = heap.pop() else { break };
        let i = e.index as usize;
        if !alive[i] {
            continue;
        }
        if e.density.to_bits() != density[i].to_bits() {
            heap.push(Entry {
                density: density[i],
                index: e.index,
            });
            continue;
        }
        alive[i] = false;
        remaining -= 1;
        for (j, w) in neighbours(i) {
            if alive[j] {
                density[j] -= w;
            }
        }
    }
    (0..points.len()).filter(|&i| alive[i]).collect()
}

/// Places probes by the module's method with ρ = `params.spacing`.
///
/// Contract: every probe stands at the centre of a candidate voxel (free,
/// at least one voxel from every surface, next to a non-empty voxel); there
/// are `min(covering_grid_count(domain, ρ), candidates used)` of them, in
/// ascending voxel order; deterministic for a given `input.seed` (which
/// only matters when candidates exceed [`MAX_CANDIDATES`]). Stats:
/// `candidates`, `candidates_used`, `removed`, `target`; params: `spacing`,
/// `voxel_size`. Errors ([`Error::User`]) when there is no candidate, or
/// when ρ is below the voxel size.
pub fn greedy(params: &GreedyParams, input: &PlacementInput) -> Result<ProbeSet> {
    let sdf = input.sdf;
    let rho = params.spacing.0;
    // Candidates are voxel centres; a kernel narrower than one voxel sees
    // no neighbour, removes nothing, and keeps every candidate as a probe.
    if rho < sdf.voxel_size {
        return Err(Error::User(format!(
            "placement.spacing: greedy:{} is below the voxel size {}, where the kernel of eq. 10 reaches no neighbouring candidate and every candidate would be kept; use a spacing of at least {}",
            crate::config::numbers::short(rho),
            sdf.voxel_size,
            sdf.voxel_size
        )));
    }
    let all = candidates(sdf);
    if all.is_empty() {
        return Err(Error::User(format!(
            "placement greedy:{rho}: no free voxel lies next to a surface; check the domain or lower the voxel_size"
        )));
    }
    let used = subsample(&all, MAX_CANDIDATES, input.seed);
    let points: Vec<Vec3> = used.iter().map(|&i| sdf.center(i)).collect();
    let target = covering_grid_count(input.domain, rho);
    let keep = target.min(used.len() as u64) as usize;
    let kept = thin(&points, rho, keep);
    let probes = kept
        .iter()
        .map(|&k| Probe {
            position: points[k],
            cluster_size: 0,
        })
        .collect();
    Ok(ProbeSet {
        method: format!("greedy:{rho}"),
        probes,
        stats: BTreeMap::from([
            ("candidates", all.len() as u64),
            ("candidates_used", used.len() as u64),
            ("removed", (used.len() - kept.len()) as u64),
            ("target", target),
        ]),
        params: BTreeMap::from([
            ("spacing", rho as f64),
            ("voxel_size", sdf.voxel_size as f64),
        ]),
        min_clearance: grid_min_clearance(sdf),
        fixed: 0,
    })
}

/// At most `cap` of the ascending `items`, chosen uniformly by a hash of
/// (`seed`, item), returned ascending; all of them when they fit.
fn subsample(items: &[usize], cap: usize, seed: u64) -> Vec<usize> {
    if items.len() <= cap {
        return items.to_vec();
    }
    let mut keyed: Vec<(u64, usize)> = items.iter().map(|&i| (hash2(seed, i as u64), i)).collect();
    keyed.select_nth_unstable(cap - 1);
    let mut out: Vec<usize> = keyed[..cap].iter().map(|&(_, i)| i).collect();
    out.sort_unstable();
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::{Placement, Positive};
    use crate::scene::testing::{add_box, bvh_and_sdf, place_in, room_sdf};
    use crate::scene::{Material, Scene};

    fn empty_room(size: f32) -> Scene {
        let mut tris = Vec::new();
        add_box(&mut tris, Vec3::ZERO, Vec3::splat(size), true);
        Scene::from_triangles(
            "room".into(),
            tris.into_iter().map(|t| (t, 0)),
            vec![Material::fallback()],
        )
        .unwrap()
    }

    fn greedy_at(spacing: f32) -> Placement {
        Placement::Greedy(GreedyParams {
            spacing: Positive(spacing),
        })
    }

    fn min_pairwise(p: &[Vec3]) -> f32 {
        let mut m = f32::INFINITY;
        for i in 0..p.len() {
            for j in i + 1..p.len() {
                m = m.min(p[i].distance(p[j]));
            }
        }
        m
    }

    #[test]
    fn kernel_is_eq_10() {
        assert_eq!(kernel_weight(0.0), 1.0);
        assert!((kernel_weight(0.5) - 0.5).abs() < 1e-6);
        assert_eq!(kernel_weight(1.0), 0.0);
        assert_eq!(kernel_weight(1.5), 0.0);
    }

    #[test]
    fn keeps_the_target_count_next_to_surfaces_and_spread() {
        // A 4 m room with a 1 m box, ρ = 1: the covering grid has 4³ = 64
        // points, far fewer than the candidates along walls and box.
        let (scene, bvh, sdf) = room_sdf(0.125, 3);
        let set = place_in(&greedy_at(1.0), &scene, &bvh, &sdf).unwrap();
        assert_eq!(set.method, "greedy:1");
        assert_eq!(set.stats["target"], 64);
        assert_eq!(set.probes.len(), 64);
        assert!(set.stats["candidates"] > 1000, "{:?}", set.stats);
        assert_eq!(set.stats["candidates"], set.stats["candidates_used"]);
        assert_eq!(
            set.stats["removed"],
            set.stats["candidates_used"] - 64,
            "{:?}",
            set.stats
        );
        let cand = candidates(&sdf);
        for p in &set.probes {
            let v = sdf.voxel_at(p.position).unwrap();
            assert_eq!(sdf.class[v], VoxelClass::Free);
            assert!(cand.binary_search(&v).is_ok(), "{}", p.position);
            assert_eq!(sdf.center(v), p.position);
            // Next to a surface: within a couple of voxels of it.
            assert!(sdf.distance[v] <= 3.0 * sdf.voxel_size, "{}", p.position);
            assert!(sdf.distance[v] >= sdf.voxel_size, "{}", p.position);
        }
        // Spread: neighbouring candidates are a voxel apart, the kept ones
        // about ρ/2 or more.
        let positions = set.positions();
        let spread = min_pairwise(&positions);
        assert!(spread >= 0.5, "closest pair {spread}");
        // Deterministic, in ascending voxel order.
        let again = place_in(&greedy_at(1.0), &scene, &bvh, &sdf).unwrap();
        assert_eq!(set, again);
        let voxels: Vec<usize> = positions
            .iter()
            .map(|&p| sdf.voxel_at(p).unwrap())
            .collect();
        assert!(voxels.windows(2).all(|w| w[0] < w[1]));
    }

    #[test]
    fn keeps_every_candidate_when_the_target_exceeds_them() {
        let scene = empty_room(2.0);
        let (bvh, sdf) = bvh_and_sdf(&scene, 0.25, 1);
        // ρ of one voxel: the kernel reaches no neighbour (t = 1 gives 0).
        let set = place_in(&greedy_at(0.25), &scene, &bvh, &sdf).unwrap();
        assert_eq!(set.stats["removed"], 0);
        assert_eq!(set.probes.len() as u64, set.stats["candidates"]);
    }

    #[test]
    fn thinning_removes_the_densest_first_and_breaks_ties_by_index() {
        // A tight pair and a lone point: one of the pair goes, the lower
        // index at equal density.
        let p = [
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(0.1, 0.0, 0.0),
            Vec3::new(5.0, 0.0, 0.0),
        ];
        assert_eq!(thin(&p, 1.0, 2), vec![1, 2]);
        // A cluster of three and a pair: the cluster's middle point goes first.
        let q = [
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(0.2, 0.0, 0.0),
            Vec3::new(0.4, 0.0, 0.0),
            Vec3::new(9.0, 0.0, 0.0),
            Vec3::new(9.5, 0.0, 0.0),
        ];
        assert_eq!(thin(&q, 1.0, 4), vec![0, 2, 3, 4]);
        assert_eq!(thin(&q, 1.0, 9), vec![0, 1, 2, 3, 4]);
    }

    #[test]
    fn subsampling_is_seeded_and_capped() {
        let items: Vec<usize> = (0..1000).map(|i| 3 * i).collect();
        let a = subsample(&items, 100, 7);
        assert_eq!(a.len(), 100);
        assert!(a.windows(2).all(|w| w[0] < w[1]));
        assert!(a.iter().all(|i| i % 3 == 0));
        assert_eq!(a, subsample(&items, 100, 7));
        assert_ne!(a, subsample(&items, 100, 8));
        assert_eq!(subsample(&items, 5000, 7), items);
    }

    #[test]
    fn spacing_for_count_round_trips() {
        let d = Bounds {
            min: Vec3::ZERO,
            max: Vec3::new(4.0, 2.0, 3.0),
        };
        assert_eq!(covering_grid_count(&d, 1.0), 24);
        assert_eq!(covering_grid_count(&d, 0.5), 8 * 4 * 6);
        assert_eq!(covering_grid_count(&d, 100.0), 1);
        for rho in [1.0f32, 0.5, 0.37, 0.1] {
            let n = covering_grid_count(&d, rho);
            let back = spacing_for_count(&d, n as usize);
            assert_eq!(covering_grid_count(&d, back), n, "ρ {rho} → {back}");
        }
        // The nearest count any spacing gives (checked against a fine scan
        // of spacings), and close to the request once counts are dense.
        for n in [1u64, 7, 50, 123, 1000, 5000] {
            let got = covering_grid_count(&d, spacing_for_count(&d, n as usize));
            for i in 0..20_000 {
                let rho = 0.01 * 500f32.powf(i as f32 / 20_000.0);
                let other = covering_grid_count(&d, rho);
                assert!(
                    other.abs_diff(n) >= got.abs_diff(n),
                    "asked {n}: got {got}, but ρ {rho} gives {other}"
                );
            }
            if n >= 1000 {
                assert!(
                    (got as f64 / n as f64 - 1.0).abs() < 0.1,
                    "asked {n}, the spacing gives {got}"
                );
            }
        }
        assert_eq!(spacing_for_count(&d, 0), 4.0);
        let flat = Bounds {
            min: Vec3::ZERO,
            max: Vec3::new(2.0, 0.0, 2.0),
        };
        assert_eq!(covering_grid_count(&flat, spacing_for_count(&flat, 16)), 16);
    }
}
