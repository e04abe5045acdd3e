//! A probe set's blended error at fixed receivers, kept up to date move by
//! move: what the diffuse step ([`crate::refine::diffuse`]) scores
//! thousands of trial sets with.
//!
//! The set lives in slots: a move adds a probe in a new slot, removes the
//! probe of a slot, or puts a slot's probe somewhere else. The Delaunay
//! tetrahedralization of the moved set is built again (Bowyer–Watson over
//! a few hundred probes takes well under a millisecond), but only the
//! receivers whose blend can have changed are blended again:
//!
//! * those whose tetrahedron (or, outside the hull, hull triangle) had the
//!   moved slot as a corner: removing a vertex re-tetrahedralizes its star
//!   and nothing else;
//! * those in the box of the new position's star: inserting a point
//!   replaces the tetrahedra whose circumsphere held it by its star, and
//!   nothing else;
//! * when the hull changed, those outside it, each against the triangles
//!   new to the hull (its own triangle still there) or every triangle (its
//!   own gone).
//!
//! Every other receiver keeps a tetrahedron (or nearest hull triangle)
//! both meshes share, hence its weights and its error: the Delaunay
//! tetrahedralization of a set is unique but for cospherical ties, which
//! probes off a grid do not meet. A test checks the kept sum against a
//! blend of the whole set after random moves.

use super::tetrahedra::Tetrahedralization;
use super::{blend_irradiance, Irradiance, ProbeSh, Receiver};
use glam::Vec3;
use rayon::prelude::*;

/// Probe weights at a receiver: slot and weight, four of them.
pub(crate) type Weights = [(u32, f32); 4];

/// A receiver's error given the light blended at it: `error(k, got)` for
/// receiver `k`.
pub(crate) type ErrorOf<'a> = dyn Fn(usize, &Irradiance) -> f64 + Sync + 'a;

/// Receivers bucketed on a uniform grid, for the ones in a box.
pub(crate) struct ReceiverGrid {
    lo: Vec3,
    scale: Vec3,
    dims: [usize; 3],
    start: Vec<u32>,
    items: Vec<u32>,
}

impl ReceiverGrid {
    /// The grid over `receivers`, about two per cell.
    pub(crate) fn new(receivers: &[Receiver]) -> ReceiverGrid {
        let (lo, hi) = receivers
            .iter()
            .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), r| {
                (lo.min(r.p), hi.max(r.p))
            });
        let (lo, hi) = if receivers.is_empty() {
            (Vec3::ZERO, Vec3::ONE)
        } else {
            (lo, hi)
        };
        let extent = (hi - lo).max(Vec3::splat(1e-6));
        let side = (receivers.len().max(1) as f32 / 2.0 / (extent.x * extent.y * extent.z)).cbrt();
        let d = (extent * side).ceil().clamp(Vec3::ONE, Vec3::splat(128.0));
        let dims = [d.x as usize, d.y as usize, d.z as usize];
        let scale = d / extent;
        let cells = dims[0] * dims[1] * dims[2];
        let mut grid = ReceiverGrid {
            lo,
            scale,
            dims,
            start: vec![0; cells + 1],
            items: vec![0; receivers.len()],
        };
        let cell_of: Vec<usize> = receivers.iter().map(|r| grid.cell(r.p)).collect();
        for &c in &cell_of {
            grid.start[c + 1] += 1;
        }
        for c in 1..=cells {
            grid.start[c] += grid.start[c - 1];
        }
        let mut fill = grid.start.clone();
        for (k, &c) in cell_of.iter().enumerate() {
            grid.items[fill[c] as usize] = k as u32;
            fill[c] += 1;
        }
        grid
    }

    fn coords(&self, p: Vec3) -> [usize; 3] {
        let q = (p - self.lo) * self.scale;
        [0, 1, 2].map(|a| (q[a].max(0.0) as usize).min(self.dims[a] - 1))
    }

    fn cell(&self, p: Vec3) -> usize {
        let [i, j, k] = self.coords(p);
        i + self.dims[0] * (j + self.dims[1] * k)
    }

    /// Calls `f` with every receiver of the cells the box `lo..hi` meets
    /// (a superset of those inside it), each once.
    pub(crate) fn each_in(&self, lo: Vec3, hi: Vec3, mut f: impl FnMut(usize)) {
        let (a, b) = (self.coords(lo), self.coords(hi));
        for k in a[2]..=b[2] {
            for j in a[1]..=b[1] {
                for i in a[0]..=b[0] {
                    let c = i + self.dims[0] * (j + self.dims[1] * k);
                    for &r in &self.items[self.start[c] as usize..self.start[c + 1] as usize] {
                        f(r as usize);
                    }
                }
            }
        }
    }
}

/// One probe moved.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Move {
    /// A probe in a new slot.
    Add(Vec3, ProbeSh),
    /// The probe of a slot gone.
    Remove(usize),
    /// A slot's probe stands somewhere else, with other light.
    Relocate(usize, Vec3, ProbeSh),
}

/// The mesh of the live slots.
struct Mesh {
    tet: Tetrahedralization,
    /// Slot of each of the mesh's points.
    slot: Vec<u32>,
    /// The hull's triangles as sorted slot triples, sorted; empty for a
    /// flat set (whose slab is blended in full).
    hull: Vec<[u32; 3]>,
    /// The mesh's own triangle of each of `hull`'s keys, in their order.
    hull_tri: Vec<[u32; 3]>,
}

impl Mesh {
    /// The mesh over the live slots; `None` when they do not span a
    /// tetrahedralization ([`Tetrahedralization::spanning`]).
    fn new(positions: &[Vec3], live: &[bool]) -> Option<Mesh> {
        let slot: Vec<u32> = (0..positions.len() as u32)
            .filter(|&s| live[s as usize])
            .collect();
        let points: Vec<Vec3> = slot.iter().map(|&s| positions[s as usize]).collect();
        let tet = Tetrahedralization::spanning(&points)?;
        let mut keyed: Vec<([u32; 3], [u32; 3])> = if tet.is_flat() {
            Vec::new()
        } else {
            tet.hull
                .iter()
                .map(|t| {
                    let mut k = t.map(|i| slot[i as usize]);
                    k.sort_unstable();
                    (k, *t)
                })
                .collect()
        };
        keyed.sort_unstable();
        let (hull, hull_tri) = keyed.into_iter().unzip();
        Some(Mesh {
            tet,
            slot,
            hull,
            hull_tri,
        })
    }

    /// `w`'s mesh indices as slots.
    fn to_slots(&self, w: [(u32, f32); 4]) -> Weights {
        w.map(|(i, x)| (self.slot[i as usize], x))
    }

    /// The blend at `p`, in slots, and whether `p` lies in a tetrahedron.
    fn blend_at(&self, p: Vec3) -> (Weights, bool) {
        let (w, inside) = self.tet.blend_at(p);
        (self.to_slots(w), inside)
    }

    /// The mesh's triangle of hull key `key`, when the hull has it.
    fn triangle(&self, key: &[u32; 3]) -> Option<[u32; 3]> {
        self.hull.binary_search(key).ok().map(|i| self.hull_tri[i])
    }
}

/// A trial move's outcome: the new mesh and the receivers it changed.
pub(crate) struct Trial {
    mv: Move,
    mesh: Option<Mesh>,
    /// Receiver, its new weights, whether inside, its new error.
    changed: Vec<(u32, Weights, bool, f64)>,
    sum: f64,
}

impl Trial {
    /// The mean error after the move.
    pub(crate) fn mean(&self, receivers: usize) -> f64 {
        self.sum / receivers.max(1) as f64
    }

}

/// The blended error of a probe set at fixed receivers (module docs).
pub(crate) struct BlendedErrors<'a> {
    receivers: &'a [Receiver],
    grid: &'a ReceiverGrid,
    error_of: &'a ErrorOf<'a>,
    positions: Vec<Vec3>,
    sh: Vec<ProbeSh>,
    live: Vec<bool>,
    mesh: Option<Mesh>,
    weights: Vec<Weights>,
    inside: Vec<bool>,
    errors: Vec<f64>,
    sum: f64,
}

impl<'a> BlendedErrors<'a> {
    /// The errors of the probes at `positions` with light `sh` (one slot
    /// each, in order) at `receivers` (bucketed by `grid`).
    ///
    /// Contract: `positions` and `sh` of the same length; deterministic.
    pub(crate) fn new(
        receivers: &'a [Receiver],
        grid: &'a ReceiverGrid,
        error_of: &'a ErrorOf<'a>,
        positions: &[Vec3],
        sh: &[ProbeSh],
    ) -> BlendedErrors<'a> {
        let mut b = BlendedErrors {
            receivers,
            grid,
            error_of,
            positions: positions.to_vec(),
            sh: sh.to_vec(),
            live: vec![true; positions.len()],
            mesh: None,
            weights: vec![[(0, 0.0); 4]; receivers.len()],
            inside: vec![false; receivers.len()],
            errors: vec![0.0; receivers.len()],
            sum: 0.0,
        };
        b.mesh = Mesh::new(&b.positions, &b.live);
        let all = b.blend_all(b.mesh.as_ref(), &b.sh, &b.live, &b.positions);
        for (k, (w, inside, e)) in all.into_iter().enumerate() {
            b.weights[k] = w;
            b.inside[k] = inside;
            b.errors[k] = e;
        }
        b.sum = b.errors.iter().sum();
        b
    }

    /// The mean error over the receivers.
    pub(crate) fn mean(&self) -> f64 {
        self.sum / self.receivers.len().max(1) as f64
    }

    /// Each receiver's error.
    pub(crate) fn errors(&self) -> &[f64] {
        &self.errors
    }

    /// Live slots' positions, in slot order.
    pub(crate) fn live_positions(&self) -> Vec<Vec3> {
        (0..self.positions.len())
            .filter(|&s| self.live[s])
            .map(|s| self.positions[s])
            .collect()
    }

    /// Every slot (live or not).
    pub(crate) fn slots(&self) -> usize {
        self.positions.len()
    }

    /// Whether slot `s` holds a probe.
    pub(crate) fn is_live(&self, s: usize) -> bool {
        self.live[s]
    }

    /// Slot `s`'s position.
    pub(crate) fn position(&self, s: usize) -> Vec3 {
        self.positions[s]
    }

    /// Slot `s`'s light.
    pub(crate) fn light(&self, s: usize) -> ProbeSh {
        self.sh[s]
    }

    /// Live probes.
    pub(crate) fn count(&self) -> usize {
        self.live.iter().filter(|&&l| l).count()
    }

    /// Every receiver blended by `mesh` (or, without one, by the nearest
    /// live probe; black without any).
    fn blend_all(
        &self,
        mesh: Option<&Mesh>,
        sh: &[ProbeSh],
        live: &[bool],
        positions: &[Vec3],
    ) -> Vec<(Weights, bool, f64)> {
        self.receivers
            .par_iter()
            .enumerate()
            .map(|(k, r)| {
                let (w, inside) = match mesh {
                    Some(m) => m.blend_at(r.p),
                    None => match nearest_live(positions, live, r.p) {
                        Some(s) => ([(s, 1.0), (s, 0.0), (s, 0.0), (s, 0.0)], false),
                        None => {
                            return ([(0, 0.0); 4], false, (self.error_of)(k, &Irradiance::default()));
                        }
                    },
                };
                let got = blend_irradiance(sh, &w, r.n);
                (w, inside, (self.error_of)(k, &got))
            })
            .collect()
    }

    /// The errors after move `mv`, without making it (module docs).
    ///
    /// Contract: a `Remove` or `Relocate` names a live slot; the result
    /// equals a blend of the whole moved set but for cospherical ties.
    pub(crate) fn trial(&self, mv: Move) -> Trial {
        let mut positions = self.positions.clone();
        let mut sh = self.sh.clone();
        let mut live = self.live.clone();
        let (gone, placed) = match mv {
            Move::Add(p, l) => {
                positions.push(p);
                sh.push(l);
                live.push(true);
                (None, Some(positions.len() - 1))
            }
            Move::Remove(s) => {
                live[s] = false;
                (Some(s), None)
            }
            Move::Relocate(s, p, l) => {
                positions[s] = p;
                sh[s] = l;
                (Some(s), Some(s))
            }
        };
        let mesh = Mesh::new(&positions, &live);
        // Without a mesh before or after, or a flat one: blend them all.
        let whole = match (&self.mesh, &mesh) {
            (Some(a), Some(b)) => a.tet.is_flat() || b.tet.is_flat(),
            _ => true,
        };
        if whole {
            let all = self.blend_all(mesh.as_ref(), &sh, &live, &positions);
            let changed: Vec<(u32, Weights, bool, f64)> = all
                .into_iter()
                .enumerate()
                .map(|(k, (w, i, e))| (k as u32, w, i, e))
                .collect();
            let sum = changed.iter().map(|c| c.3).sum();
            return Trial { mv, mesh, changed, sum };
        }
        let (old, new) = (self.mesh.as_ref().unwrap(), mesh.as_ref().unwrap());
        let n = self.receivers.len();
        let mut touched = vec![false; n];
        // The moved slot's old star.
        if let Some(s) = gone {
            let s = s as u32;
            for (k, w) in self.weights.iter().enumerate() {
                if w.iter().any(|&(i, _)| i == s) {
                    touched[k] = true;
                }
            }
        }
        // The new position's star.
        if let Some(s) = placed {
            let m = new.slot.iter().position(|&x| x as usize == s);
            if let Some(m) = m {
                let m = m as u32;
                let (mut lo, mut hi) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
                for t in new.tet.tetrahedra.iter().filter(|t| t.contains(&m)) {
                    for &v in t {
                        let p = positions[new.slot[v as usize] as usize];
                        lo = lo.min(p);
                        hi = hi.max(p);
                    }
                }
                if lo.x <= hi.x {
                    let pad = 1e-4 * (hi - lo).max_element().max(1e-6);
                    self.grid
                        .each_in(lo - pad, hi + pad, |k| touched[k] = true);
                }
            }
        }
        // A hull that changed (other triangles, or a corner moved): the
        // receivers outside it. Its fresh triangles are those new to it
        // and those of the moved slot.
        let on = |hull: &[[u32; 3]], s: Option<usize>| {
            s.is_some_and(|s| hull.iter().any(|t| t.contains(&(s as u32))))
        };
        let hull_changed = old.hull != new.hull || on(&new.hull, placed) || on(&old.hull, gone);
        let fresh: Vec<[u32; 3]> = if hull_changed {
            new.hull
                .iter()
                .filter(|t| {
                    old.hull.binary_search(t).is_err()
                        || placed.is_some_and(|s| t.contains(&(s as u32)))
                })
                .copied()
                .collect()
        } else {
            Vec::new()
        };
        let fresh_tris: Vec<[u32; 3]> = fresh.iter().filter_map(|k| new.triangle(k)).collect();
        let fresh_spheres = new.tet.spheres(&fresh_tris);
        let candidates: Vec<u32> = (0..n as u32)
            .filter(|&k| touched[k as usize] || (hull_changed && !self.inside[k as usize]))
            .collect();
        let changed: Vec<(u32, Weights, bool, f64)> = candidates
            .par_iter()
            .with_min_len(64)
            .map(|&k| {
                let r = &self.receivers[k as usize];
                let (w, inside) = if touched[k as usize] {
                    new.blend_at(r.p)
                } else {
                    // Outside the old hull and away from the moved
                    // slots: still outside. Its own triangle, if the new
                    // hull keeps it, against the triangles new to it.
                    let own = self.weights[k as usize].map(|(i, _)| i);
                    let mut key = [own[0], own[1], own[2]];
                    key.sort_unstable();
                    match new.triangle(&key) {
                        Some(tri) => {
                            let (d_own, w_own) = new.tet.distance_to(tri, r.p);
                            let (d_new, w_new) =
                                new.tet.nearest_on(&fresh_tris, &fresh_spheres, r.p);
                            let w = if d_new < d_own { w_new } else { w_own };
                            (new.to_slots(w), false)
                        }
                        None => new.blend_at(r.p),
                    }
                };
                let got = blend_irradiance(&sh, &w, r.n);
                (k, w, inside, (self.error_of)(k as usize, &got))
            })
            .collect();
        let sum = self.sum + changed.iter().map(|c| c.3 - self.errors[c.0 as usize]).sum::<f64>();
        Trial { mv, mesh, changed, sum }
    }

    /// Makes the move of `trial`, which [`BlendedErrors::trial`] made of
    /// this very state.
    pub(crate) fn apply(&mut self, trial: Trial) {
        match trial.mv {
            Move::Add(p, l) => {
                self.positions.push(p);
                self.sh.push(l);
                self.live.push(true);
            }
            Move::Remove(s) => self.live[s] = false,
            Move::Relocate(s, p, l) => {
                self.positions[s] = p;
                self.sh[s] = l;
            }
        }
        self.mesh = trial.mesh;
        for (k, w, inside, e) in trial.changed {
            let k = k as usize;
            self.weights[k] = w;
            self.inside[k] = inside;
            self.errors[k] = e;
        }
        // Summed again rather than carried: no drift over many moves.
        self.sum = self.errors.iter().sum();
    }
}

/// The live slot nearest `p` (the lowest on ties).
fn nearest_live(positions: &[Vec3], live: &[bool], p: Vec3) -> Option<u32> {
    (0..positions.len())
        .filter(|&s| live[s])
        .min_by(|&a, &b| {
            positions[a]
                .distance_squared(p)
                .total_cmp(&positions[b].distance_squared(p))
        })
        .map(|s| s as u32)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::diffuse::ShL2;
    use crate::sampling::{hash2, unit_f32};

    fn point(k: u64, b: u64) -> Vec3 {
        Vec3::new(
            unit_f32(hash2(hash2(k, b), 0)),
            unit_f32(hash2(hash2(k, b), 1)),
            unit_f32(hash2(hash2(k, b), 2)),
        ) * 4.0
    }

    /// Light that varies with position, so that every move changes some
    /// receiver's blend.
    fn light_at(p: Vec3) -> ProbeSh {
        let mut baked = ShL2::ZERO;
        baked.coefficients[0] = Vec3::splat(1.0 + p.x);
        baked.coefficients[1] = Vec3::splat(0.3 * p.y - 0.5);
        baked.coefficients[3] = Vec3::splat(0.2 * p.z);
        ProbeSh {
            baked,
            ..ProbeSh::default()
        }
    }

    #[test]
    fn moves_score_as_a_blend_of_the_whole_moved_set() {
        let receivers: Vec<Receiver> = (0..600)
            .map(|k| Receiver {
                // Some receivers outside every probe's box.
                p: point(k, 7) * 1.3 - 0.6,
                n: crate::sampling::uniform_direction(k, 3),
                group: 0,
            })
            .collect();
        let grid = ReceiverGrid::new(&receivers);
        let want = |p: Vec3| 1.0 + p.x * 0.5;
        let error_of = |k: usize, got: &Irradiance| {
            (crate::render::lights::luminance(got.baked) as f64 - want(receivers[k].p) as f64).abs()
        };
        let positions: Vec<Vec3> = (0..12).map(|k| point(k, 1)).collect();
        let sh: Vec<ProbeSh> = positions.iter().map(|&p| light_at(p)).collect();
        let mut b = BlendedErrors::new(&receivers, &grid, &error_of, &positions, &sh);
        for step in 0..60u64 {
            let live: Vec<usize> = (0..b.slots()).filter(|&s| b.is_live(s)).collect();
            let pick = live[(hash2(step, 9) % live.len() as u64) as usize];
            let p = point(step, 2) * 1.4 - 0.8;
            let mv = match step % 3 {
                0 => Move::Add(p, light_at(p)),
                1 if live.len() > 5 => Move::Remove(pick),
                _ => Move::Relocate(pick, p, light_at(p)),
            };
            let t = b.trial(mv);
            let tried = t.mean(receivers.len());
            b.apply(t);
            // A fresh blend of the moved set.
            let (pos, lights): (Vec<Vec3>, Vec<ProbeSh>) = (0..b.slots())
                .filter(|&s| b.is_live(s))
                .map(|s| (b.positions[s], b.sh[s]))
                .unzip();
            let whole = BlendedErrors::new(&receivers, &grid, &error_of, &pos, &lights);
            assert!(
                (tried - whole.mean()).abs() <= 1e-5 * whole.mean().max(1e-3),
                "step {step} ({mv:?}): {tried} vs {}",
                whole.mean()
            );
            assert!((b.mean() - whole.mean()).abs() <= 1e-5 * whole.mean().max(1e-3));
        }
    }
}
