//! The light-field ray trace of McGuire et al. 2017 §4 (Listing 1,
//! `lightFieldTrace`) on the CPU: choose a probe, march the ray through its
//! maps ([`single`]), and while the answer is *unknown* advance the ray to
//! where that probe lost sight of it and choose the next probe.
//!
//! Two ways of choosing ([`Selection`]):
//! - **Grid** (McGuire §4.1, Fig. 3): the eight probes of the grid cell
//!   holding the ray's current origin, starting with the one closest to the
//!   ray's line and then i′ = (i + 3) mod 8, the order that always moves to
//!   a far probe; a new cell restarts the choice.
//! - **SVO** (Wang et al. 2019 §4.1): the ranked candidates the octree
//!   lists for the leaf holding the ray's current origin; once they are
//!   spent, the nearest probes not tried yet, up to [`MAX_PROBES_PER_RAY`].
//!
//! This is the CPU twin of the GPU tracer: same march, same selection.

pub mod check;
pub mod gather;
pub mod single;

use crate::lightfield::{octahedral, LightField};
use crate::svo::Svo;
use glam::{IVec3, Vec3};
use std::collections::HashMap;

/// What the light field says about a ray.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum RayOutcome {
    /// The ray hits a surface at `t`, as seen by probe `probe`.
    Hit {
        /// Distance along the ray.
        t: f32,
        /// The probe whose maps resolved it.
        probe: u32,
    },
    /// The ray leaves the scene.
    Miss {
        /// The probe that saw it leave.
        probe: u32,
    },
    /// No candidate probe could follow the ray past `t`; McGuire §4.1 then
    /// takes the last observed point as the hit.
    Unknown {
        /// Where the last probe lost sight of the ray.
        t: f32,
        /// That probe; `None` when no probe was a candidate at all.
        probe: Option<u32>,
    },
}

impl RayOutcome {
    /// Where the ray's radiance is read (McGuire §4.1): the probe that
    /// resolved it and the texel (`y·n + x`) of its maps that looks at the
    /// ray's end. A hit reads the texel seeing the hit point; an unknown
    /// ray, the texel seeing the last point observed; a miss, the texel
    /// looking along the ray, which sees what lies beyond the scene.
    /// `None` for an unknown ray no probe was a candidate for.
    ///
    /// Contract: `origin`, `dir` are the traced ray's; the GPU kernels read
    /// the same texel.
    pub fn lookup(&self, field: &LightField, origin: Vec3, dir: Vec3) -> Option<(u32, u32)> {
        let (probe, toward) = match *self {
            RayOutcome::Hit { t, probe }
            | RayOutcome::Unknown {
                t,
                probe: Some(probe),
            } => (probe, origin + dir * t - field.positions[probe as usize]),
            RayOutcome::Miss { probe } => (probe, dir),
            RayOutcome::Unknown { probe: None, .. } => return None,
        };
        let n = field.resolution;
        let (x, y) = octahedral::texel_of(toward, n);
        Some((probe, y * n + x))
    }
}

/// How the next probe is chosen.
pub enum Selection<'a> {
    /// A regular grid of probes (McGuire's placement).
    Grid(&'a Lattice),
    /// The SVO's ranked lists.
    Svo(&'a Svo),
}

/// A regular lattice of probes recognized from their positions.
#[derive(Debug, Clone)]
pub struct Lattice {
    /// Position of lattice point (0, 0, 0).
    pub origin: Vec3,
    /// Spacing per axis (1 where the axis has one layer).
    pub spacing: Vec3,
    /// Points per axis.
    pub dims: IVec3,
    index: HashMap<(i32, i32, i32), u32>,
}

impl Lattice {
    /// Recognizes `positions` as a full regular grid (any order).
    ///
    /// Contract: `None` unless the positions are finite, at least one, and
    /// exactly the points of an nx×ny×nz lattice with constant spacing per
    /// axis (to 1e-4 relative). The Python and C readers recognize the same lattices
    /// (`probeplace.Lattice.from_positions`, `pp_lattice_from_positions`).
    pub fn from_positions(positions: &[Vec3]) -> Option<Lattice> {
        if positions.is_empty() || !positions.iter().all(|p| p.is_finite()) {
            return None;
        }
        let mut axes = [Vec::new(), Vec::new(), Vec::new()];
        let scale = positions
            .iter()
            .fold(0.0f32, |m, p| m.max(p.abs().max_element()))
            .max(1e-6);
        let tol = 1e-4 * scale;
        for p in positions {
            for (i, axis) in axes.iter_mut().enumerate() {
                if !axis.iter().any(|&v: &f32| (v - p[i]).abs() <= tol) {
                    axis.push(p[i]);
                }
            }
        }
        let mut origin = Vec3::ZERO;
        let mut spacing = Vec3::ONE;
        let mut dims = IVec3::ONE;
        for (i, axis) in axes.iter_mut().enumerate() {
            axis.sort_by(f32::total_cmp);
            origin[i] = axis[0];
            dims[i] = axis.len() as i32;
            if axis.len() > 1 {
                spacing[i] = (axis[axis.len() - 1] - axis[0]) / (axis.len() - 1) as f32;
                if axis
                    .windows(2)
                    .any(|w| ((w[1] - w[0]) - spacing[i]).abs() > tol)
                {
                    return None;
                }
            }
        }
        // In i64: three axes of a few thousand distinct values each (any
        // placement off a grid) overflow an i32 product.
        if dims.x as i64 * dims.y as i64 * dims.z as i64 != positions.len() as i64 {
            return None;
        }
        let mut index = HashMap::new();
        for (k, p) in positions.iter().enumerate() {
            let c = ((*p - origin) / spacing).round().as_ivec3();
            // A point rounding outside the lattice (possible only where the
            // spacing nears the tolerance) would leave a lattice point
            // without a probe, which `corner` could not find.
            if c.cmplt(IVec3::ZERO).any() || c.cmpge(dims).any() {
                return None;
            }
            index.insert((c.x, c.y, c.z), k as u32);
        }
        (index.len() == positions.len()).then_some(Lattice {
            origin,
            spacing,
            dims,
            index,
        })
    }

    /// The cell (lower lattice corner) whose cube of eight probes holds `p`,
    /// clamped to the lattice.
    pub fn cell(&self, p: Vec3) -> IVec3 {
        let c = ((p - self.origin) / self.spacing).floor().as_ivec3();
        c.clamp(IVec3::ZERO, (self.dims - 2).max(IVec3::ZERO))
    }

    /// The probe index of every lattice point, x fastest, then y, then z:
    /// the table the GPU kernels read.
    pub fn dense_index(&self) -> Vec<u32> {
        let d = self.dims;
        let mut out = Vec::with_capacity((d.x * d.y * d.z) as usize);
        for z in 0..d.z {
            for y in 0..d.y {
                for x in 0..d.x {
                    out.push(self.index[&(x, y, z)]);
                }
            }
        }
        out
    }

    /// Probe at corner `i` (0..8, bit 0 = +x, bit 1 = +y, bit 2 = +z) of
    /// `cell`; corners beyond a one-layer axis fold onto the layer.
    pub fn corner(&self, cell: IVec3, i: u32) -> u32 {
        let o = IVec3::new((i & 1) as i32, ((i >> 1) & 1) as i32, ((i >> 2) & 1) as i32);
        let c = (cell + o).min(self.dims - 1);
        self.index[&(c.x, c.y, c.z)]
    }
}

/// Most probes one trace consults before it gives up.
pub const MAX_PROBES_PER_RAY: usize = 16;

/// Traces `origin + t·dir`, t in [0, `t_max`], through the light field.
///
/// Contract: `dir` is unit length, `t_max` finite (the ray's exit from the
/// scene's bounds). `march` chooses how each probe's maps are walked. The
/// result does not depend on anything but the arguments; `steps` adds the
/// work done (and the probes consulted) to what it holds.
pub fn trace(
    field: &LightField,
    selection: &Selection,
    origin: Vec3,
    dir: Vec3,
    t_max: f32,
    march: single::March,
    steps: &mut single::Steps,
) -> RayOutcome {
    let mut t = 0.0f32;
    let mut tried: [u32; MAX_PROBES_PER_RAY] = [u32::MAX; MAX_PROBES_PER_RAY];
    let mut count = 0;
    // Grid state: the current cell and the last corner used in it.
    let mut grid_cell = IVec3::splat(i32::MIN);
    let mut corner = 0u32;
    let mut corners_used = 0u32;
    while count < MAX_PROBES_PER_RAY {
        let here = origin + dir * t;
        let next = match selection {
            Selection::Svo(svo) => svo
                .probes_at(here)
                .iter()
                .copied()
                .find(|p| !tried[..count].contains(p))
                .or_else(|| nearest_untried(field, here, &tried[..count])),
            Selection::Grid(lattice) => {
                let cell = lattice.cell(here);
                if cell != grid_cell {
                    grid_cell = cell;
                    corners_used = 0;
                    corner = closest_corner(field, lattice, cell, here, dir, &tried[..count]);
                } else {
                    corner = (corner + 3) % 8;
                }
                let mut found = None;
                while corners_used < 8 {
                    corners_used += 1;
                    let p = lattice.corner(cell, corner);
                    if !tried[..count].contains(&p) {
                        found = Some(p);
                        break;
                    }
                    corner = (corner + 3) % 8;
                }
                found
            }
        };
        let Some(probe) = next else {
            let last = count.checked_sub(1).map(|i| tried[i]);
            return RayOutcome::Unknown { t, probe: last };
        };
        tried[count] = probe;
        count += 1;
        steps.probes += 1;
        match single::trace(field, probe as usize, origin, dir, t, t_max, march, steps) {
            single::Probe::Hit(th) => return RayOutcome::Hit { t: th, probe },
            single::Probe::Miss => return RayOutcome::Miss { probe },
            single::Probe::Unknown(tu) => t = tu.max(t),
        }
    }
    RayOutcome::Unknown {
        t,
        probe: Some(tried[count - 1]),
    }
}

/// The probe nearest to `p` not tried yet: the SVO's fallback once a
/// leaf's ranked candidates are spent (an extension of Wang §4.1, whose
/// lists stop at four).
fn nearest_untried(field: &LightField, p: Vec3, tried: &[u32]) -> Option<u32> {
    (0..field.positions.len() as u32)
        .filter(|i| !tried.contains(i))
        .min_by(|&i, &j| {
            let di = field.positions[i as usize].distance_squared(p);
            let dj = field.positions[j as usize].distance_squared(p);
            di.total_cmp(&dj).then(i.cmp(&j))
        })
}

/// The corner of `cell` whose probe lies closest to the ray's line
/// (McGuire §4.1: it nearly always gives the shortest polyline), among the
/// untried ones.
fn closest_corner(
    field: &LightField,
    lattice: &Lattice,
    cell: IVec3,
    p: Vec3,
    dir: Vec3,
    tried: &[u32],
) -> u32 {
    let mut best = (f32::INFINITY, 0u32);
    for i in 0..8 {
        let probe = lattice.corner(cell, i);
        if tried.contains(&probe) {
            continue;
        }
        let v = field.positions[probe as usize] - p;
        let d2 = (v - dir * v.dot(dir)).length_squared();
        if d2 < best.0 {
            best = (d2, i);
        }
    }
    best.1
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::{BakeParams, PowerOfTwo};
    use crate::lightfield;
    use crate::progress::Progress;
    use crate::sampling::{hash2, unit_f32};
    use crate::scene::raycast::SceneBvh;
    use crate::scene::testing::room_with_box;

    fn grid_field(n: u32) -> (crate::scene::Scene, SceneBvh, LightField) {
        let scene = room_with_box();
        let bvh = SceneBvh::new(&scene);
        let mut probes = Vec::new();
        for z in 0..3 {
            for y in 0..2 {
                for x in 0..3 {
                    probes.push(Vec3::new(
                        0.6 + 1.4 * x as f32,
                        1.3 + 1.8 * y as f32,
                        0.6 + 1.4 * z as f32,
                    ));
                }
            }
        }
        let params = BakeParams {
            resolution: PowerOfTwo(n),
            ..BakeParams::default()
        };
        let field = lightfield::bake(
            &params,
            &probes,
            &scene,
            &bvh,
            8.0,
            1,
            &|_, _, _| Vec3::ZERO,
            &Progress::hidden(),
        )
        .field;
        (scene, bvh, field)
    }

    fn free_points(count: usize) -> Vec<Vec3> {
        (0..count as u64)
            .map(|i| {
                Vec3::new(
                    unit_f32(hash2(9, 3 * i)),
                    unit_f32(hash2(9, 3 * i + 1)),
                    unit_f32(hash2(9, 3 * i + 2)),
                ) * 3.9
                    + 0.05
            })
            .filter(|p| !(p.x > 0.95 && p.x < 2.05 && p.z > 0.95 && p.z < 2.05 && p.y < 1.05))
            .collect()
    }

    #[test]
    fn lattice_is_recognized_in_any_order() {
        let (_, _, field) = grid_field(8);
        let mut shuffled = field.positions.clone();
        shuffled.reverse();
        let l = Lattice::from_positions(&shuffled).unwrap();
        assert_eq!(l.dims, IVec3::new(3, 2, 3));
        assert_eq!(l.cell(Vec3::new(2.1, 5.0, 0.0)), IVec3::new(1, 0, 0));
        let p = l.corner(IVec3::new(1, 0, 1), 7);
        assert!((shuffled[p as usize] - Vec3::new(3.4, 3.1, 3.4)).length() < 1e-5);
        let mut broken = shuffled.clone();
        broken[3].x += 0.3;
        assert!(Lattice::from_positions(&broken).is_none());
        assert!(Lattice::from_positions(&shuffled[1..]).is_none());
        assert!(Lattice::from_positions(&[]).is_none());
        broken[3].x = f32::NAN;
        assert!(Lattice::from_positions(&broken).is_none());
        // 1300 distinct values on every axis: 1300³ overflowed the i32
        // count check (a panic with debug assertions).
        let cloud: Vec<Vec3> = (0..1300u32)
            .map(|i| Vec3::new(i as f32, (i * 7 % 1300) as f32, (i * 11 % 1300) as f32))
            .collect();
        assert!(Lattice::from_positions(&cloud).is_none());
    }

    #[test]
    fn grid_trace_agrees_with_ray_casts() {
        let (scene, bvh, field) = grid_field(128);
        let lattice = Lattice::from_positions(&field.positions).unwrap();
        let origins = free_points(4000);
        let a = check::compare(
            &field,
            &Selection::Grid(&lattice),
            &scene,
            &bvh,
            &origins,
            4,
            single::March::HiZ,
        );
        assert!(a.seen > 3000, "{a:?}");
        assert!(a.rate() >= 0.99, "{a:?}");
        assert_eq!(a.escaping, 0, "the room is closed");
    }

    #[test]
    fn every_march_equals_the_texel_march() {
        let (scene, _, field) = grid_field(64);
        let origins = free_points(3000);
        let mut fetches = [0u64; 3];
        for (i, &o) in origins.iter().enumerate() {
            let d = crate::sampling::fibonacci_sphere(3000)[i];
            let t_max = scene.bounds.exit_distance(o, d);
            for probe in [0, 7, 17] {
                let mut steps = [single::Steps::default(); 3];
                let marches = [
                    single::March::Texel,
                    single::March::BiLevel,
                    single::March::HiZ,
                ];
                let out: Vec<single::Probe> = marches
                    .iter()
                    .zip(steps.iter_mut())
                    .map(|(&m, s)| single::trace(&field, probe, o, d, 0.0, t_max, m, s))
                    .collect();
                for k in 1..3 {
                    match (out[0], out[k]) {
                        (single::Probe::Hit(a), single::Probe::Hit(b))
                        | (single::Probe::Unknown(a), single::Probe::Unknown(b)) => {
                            assert!(
                                (a - b).abs() <= 1e-4 * (1.0 + a),
                                "ray {i} probe {probe} {:?}: {:?} vs {:?}",
                                marches[k],
                                out[0],
                                out[k]
                            )
                        }
                        (x, y) => assert_eq!(x, y, "ray {i} probe {probe} {:?}", marches[k]),
                    }
                    assert_eq!(
                        steps[0].surfels, steps[k].surfels,
                        "the same texels are tested"
                    );
                }
                for k in 0..3 {
                    fetches[k] += steps[k].march_fetches() as u64;
                }
            }
        }
        // Texel > bi-level > Hi-Z in texels read (Wang §4.2).
        assert!(
            fetches[1] < fetches[0] && fetches[2] < fetches[1],
            "{fetches:?}"
        );
    }
}
