//! McGuire et al. 2017's uniform grid, and the sweeps of grids that every
//! comparison holds our placements against: the smallest grid reaching a
//! coverage (Wang et al. 2019 §5, Table 1), and grids around a probe count
//! (`compare`).

use crate::config::params::GridParams;
use crate::coverage::CoverageReference;
use crate::error::Result;
use crate::placement::method::{Method, Role};
use crate::probes::Probe;
use crate::probes::{PlacementInput, ProbeSet};
use crate::progress::Progress;
use crate::scene::raycast::SceneBvh;
use crate::scene::Bounds;
use crate::sdf::Sdf;
use glam::Vec3;
use std::collections::BTreeMap;

/// The `grid:NxMxK` method, the uniform grid engines use today: [`grid`].
pub struct Grid;

impl Method for Grid {
    type Params = GridParams;
    const WORD: &'static str = "grid";
    const TAKES_ARGUMENT: bool = true;
    const FORM: &'static str = "grid:NxMxK";
    const ABOUT: &'static str =
        "McGuire et al. 2017 §4: the domain cut into N×M×K cells, a probe at each cell's centre";
    const ROLE: Role = Role::Grid;

    fn name(params: &GridParams) -> String {
        format!("grid:{}", params.dims_text())
    }

    fn parse_cli(
        argument: Option<&str>,
        _: Option<&GridParams>,
    ) -> std::result::Result<GridParams, String> {
        GridParams::parse_dims(argument.unwrap_or(""), "grid")
    }

    fn place(params: &GridParams, input: &PlacementInput) -> Result<ProbeSet> {
        Ok(ProbeSet {
            method: Self::name(params),
            probes: grid(params, input.domain),
            stats: BTreeMap::new(),
            params: BTreeMap::new(),
            min_clearance: grid_min_clearance(input.sdf),
            fixed: 0,
        })
    }
}

/// McGuire et al. 2017's uniform grid: the domain divided into N×M×K cells,
/// one probe at each cell centre, x fastest, then y, then z.
pub fn grid(params: &GridParams, domain: &Bounds) -> Vec<Probe> {
    let n = [params.cells.0 .0, params.cells.1 .0, params.cells.2 .0];
    let cell = domain.size() / Vec3::new(n[0] as f32, n[1] as f32, n[2] as f32);
    let mut probes = Vec::with_capacity((n[0] * n[1] * n[2]) as usize);
    for z in 0..n[2] {
        for y in 0..n[1] {
            for x in 0..n[0] {
                probes.push(Probe {
                    position: domain.min + (Vec3::new(x as f32, y as f32, z as f32) + 0.5) * cell,
                    cluster_size: 0,
                });
            }
        }
    }
    probes
}

/// The clearance refinement keeps for grid-based sets. A grid has no
/// clearance rule of its own: refinement keeps its probes where the
/// coverage measure's reference points may be (one voxel from a surface).
pub fn grid_min_clearance(sdf: &Sdf) -> f32 {
    crate::coverage::REFERENCE_MIN_CLEARANCE_VOXELS * sdf.voxel_size
}

/// Uniform grids shaped like a domain of `size`: for k = 1..=`max_cells`
/// cells along the longest axis, the other axes get as many cells as keep
/// the cells closest to cubes (at least one). Sorted by probe count, then
/// dimensions; duplicates removed.
pub fn cubic_grid_sweep(size: Vec3, max_cells: u32) -> Vec<GridParams> {
    let longest = size.max_element();
    let mut grids: Vec<[u32; 3]> = (1..=max_cells)
        .map(|k| {
            let cell = longest / k as f32;
            (size / cell).round().max(Vec3::ONE).as_uvec3().to_array()
        })
        .collect();
    grids.sort_by_key(|g| (g[0] * g[1] * g[2], *g));
    grids.dedup();
    grids
        .into_iter()
        .filter_map(|g| GridParams::new(g).ok())
        .collect()
}

/// The first grid of [`cubic_grid_sweep`] (up to `max_cells`
/// cells along the domain's longest axis, by probe count, and at most
/// `max_probes` probes when given) whose coverage, by `reference`, reaches
/// `coverage`, with that coverage; `None` when no grid of the sweep does.
/// The "smallest grid at the same coverage" that our placements must beat
/// (Wang et al. 2019 §5, Table 1).
pub fn smallest_grid_reaching(
    domain: &Bounds,
    bvh: &SceneBvh,
    reference: &CoverageReference,
    coverage: f64,
    max_cells: u32,
    max_probes: Option<usize>,
    progress: &Progress,
) -> Option<(GridParams, f64)> {
    cubic_grid_sweep(domain.size(), max_cells)
        .into_iter()
        .take_while(|g| max_probes.is_none_or(|n| g.probes() <= n))
        .find_map(|g| {
            let positions: Vec<glam::Vec3> = grid(&g, domain).iter().map(|p| p.position).collect();
            let c = reference.evaluate(bvh, &positions, progress).coverage;
            (c >= coverage).then_some((g, c))
        })
}

/// Most a grid cell's longest edge may exceed its shortest for
/// [`grid_near_count`]: engines' probe volumes are shaped by the artist, not
/// forced to cubes, but a cell twice as long one way as another is as far
/// as a sensible volume goes.
pub const MAX_CELL_ASPECT: f32 = 2.0;

/// The uniform grid whose probe count is nearest `count` among those whose
/// cells' longest edge is at most [`MAX_CELL_ASPECT`] times their shortest;
/// ties go to the most nearly cubic cells, then to the larger count. `None`
/// when no such grid has between half and twice `count` probes (a domain
/// far from cubic).
///
/// **Why.** Equal count is the comparison Wang et al. 2019 headline (§5.2,
/// Table 1), and rounding the cube root of a volume per axis can land far
/// from it: on the Holodeck (8.3 × 3 × 5) the near-cubic grid for 16 probes
/// has 24, while 4 × 2 × 2 has cells of 2.1 × 1.5 × 2.5.
pub fn grid_near_count(domain: &Bounds, count: usize) -> Option<GridParams> {
    let size = domain.size().max(Vec3::splat(1e-6));
    let count = count.max(1) as u64;
    let (lo, hi) = (count.div_ceil(2), count * 2);
    let aspect = |n: [u64; 3]| {
        let cell = size / Vec3::new(n[0] as f32, n[1] as f32, n[2] as f32);
        cell.max_element() / cell.min_element()
    };
    let [x, y, z] = (1..=hi)
        .flat_map(|x| (1..=hi / x).flat_map(move |y| (1..=hi / (x * y)).map(move |z| [x, y, z])))
        .map(|n| (n, n.iter().product::<u64>(), aspect(n)))
        .filter(|&(_, n, a)| n >= lo && a <= MAX_CELL_ASPECT)
        .min_by(|(_, n, a), (_, m, b)| {
            n.abs_diff(count)
                .cmp(&m.abs_diff(count))
                .then(a.total_cmp(b))
                .then(m.cmp(n))
        })?
        .0;
    GridParams::new([x as u32, y as u32, z as u32]).ok()
}

/// Uniform grids from a quarter to four times `count` probes, in steps of
/// 2× (√2 around `count`), each with cells as near cubic as the domain
/// allows, and at `count` itself the grid of [`grid_near_count`]; distinct
/// and by probe count. Eight times would bake twice the probes of all the
/// others together (on Dabrovic Sponza a third of the comparison's time),
/// so `--grids` asks for larger grids by name.
///
/// Contract: at least one grid; every grid within the config's limits.
pub fn grid_sweep(domain: &Bounds, count: usize) -> Vec<GridParams> {
    let size = domain.size().max(Vec3::splat(1e-6));
    let volume = (size.x * size.y * size.z) as f64;
    let factors = [
        0.25,
        0.5,
        std::f64::consts::FRAC_1_SQRT_2,
        1.0,
        std::f64::consts::SQRT_2,
        2.0,
        4.0,
    ];
    let mut out: Vec<(u64, GridParams)> = Vec::new();
    for f in factors {
        let n = (count.max(1) as f64 * f).max(1.0);
        let spacing = (volume / n).cbrt() as f32;
        let cells = (size / spacing).round().max(Vec3::ONE);
        let rounded = GridParams::new([cells.x as u32, cells.y as u32, cells.z as u32]);
        let near = (f == 1.0).then(|| grid_near_count(domain, count)).flatten();
        let Some(g) = near.or(rounded.ok()) else {
            continue;
        };
        let probes = g.probes() as u64;
        if !out.iter().any(|(_, o)| *o == g) {
            out.push((probes, g));
        }
    }
    out.sort_by_key(|(n, g)| (*n, g.cells.0 .0, g.cells.1 .0, g.cells.2 .0));
    out.into_iter().map(|(_, g)| g).collect()
}

/// The grid of `grids` (with their probe counts) nearest `count` probes;
/// ties to the larger, as the equal-count match takes them.
pub(crate) fn nearest_grid(
    grids: &[(usize, GridParams)],
    count: usize,
) -> Option<&(usize, GridParams)> {
    grids
        .iter()
        .min_by_key(|(n, _)| (n.abs_diff(count), usize::MAX - n))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::Count;

    fn count(g: &GridParams) -> u32 {
        g.probes() as u32
    }

    #[test]
    fn grid_probes_sit_at_cell_centres() {
        let d = Bounds {
            min: Vec3::ZERO,
            max: Vec3::new(4.0, 2.0, 2.0),
        };
        let p = grid(
            &GridParams {
                cells: (Count(2), Count(1), Count(2)),
            },
            &d,
        );
        let pos: Vec<Vec3> = p.iter().map(|p| p.position).collect();
        assert_eq!(
            pos,
            vec![
                Vec3::new(1.0, 1.0, 0.5),
                Vec3::new(3.0, 1.0, 0.5),
                Vec3::new(1.0, 1.0, 1.5),
                Vec3::new(3.0, 1.0, 1.5)
            ]
        );
    }

    #[test]
    fn sweep_spans_a_quarter_to_four_times_the_count_in_order() {
        let domain = Bounds {
            min: Vec3::ZERO,
            max: Vec3::new(24.0, 8.0, 14.0),
        };
        let sweep = grid_sweep(&domain, 20);
        let counts: Vec<u32> = sweep.iter().map(count).collect();
        assert!(counts.windows(2).all(|w| w[0] <= w[1]), "{counts:?}");
        assert!(counts[0] <= 10, "{counts:?}");
        assert!(*counts.last().unwrap() >= 50, "{counts:?}");
        assert!(*counts.last().unwrap() <= 120, "{counts:?}");
        // Rounding cells to whole numbers moves counts, but one grid stays
        // within a factor of two of the target.
        assert!(counts.iter().any(|&c| (10..=40).contains(&c)), "{counts:?}");
        // Cells stay near cubic: the long axis gets the most cells.
        let last = sweep.last().unwrap();
        assert!(last.cells.0 .0 > last.cells.1 .0);
    }

    #[test]
    fn the_equal_count_grid_has_the_count_where_a_sensible_shape_has_it() {
        let holodeck = Bounds {
            min: Vec3::ZERO,
            max: Vec3::new(8.3, 3.0, 5.0),
        };
        let g = grid_near_count(&holodeck, 16).unwrap();
        assert_eq!(count(&g), 16, "{g:?}");
        assert!(grid_sweep(&holodeck, 16).contains(&g));
        // Cells stay within the aspect bound, whatever the count.
        for n in 1..80 {
            let g = grid_near_count(&holodeck, n).unwrap();
            let c = [g.cells.0 .0, g.cells.1 .0, g.cells.2 .0];
            let cell = holodeck.size() / Vec3::new(c[0] as f32, c[1] as f32, c[2] as f32);
            assert!(
                cell.max_element() <= MAX_CELL_ASPECT * cell.min_element(),
                "{n}: {c:?}"
            );
            assert!(
                count(&g).abs_diff(n as u32) <= (n as u32).div_ceil(4),
                "{n}: {c:?}"
            );
        }
        // A prime count in a cube: the nearest sensible grid, not 1 × 1 × 7.
        let cube = Bounds {
            min: Vec3::ZERO,
            max: Vec3::ONE,
        };
        assert_eq!(count(&grid_near_count(&cube, 7).unwrap()), 8);
        // A sliver no grid of sensible cells fits near one probe.
        let sliver = Bounds {
            min: Vec3::ZERO,
            max: Vec3::new(100.0, 1.0, 1.0),
        };
        assert!(grid_near_count(&sliver, 1).is_none());
    }

    #[test]
    fn sweep_of_a_tiny_count_starts_at_one_probe() {
        let domain = Bounds {
            min: Vec3::ZERO,
            max: Vec3::ONE,
        };
        let sweep = grid_sweep(&domain, 1);
        assert_eq!(count(&sweep[0]), 1);
        assert!(sweep.iter().all(|g| count(g) >= 1));
    }
}
