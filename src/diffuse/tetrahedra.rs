//! Delaunay tetrahedralization of a probe set, and the tetrahedral
//! interpolation Unity's light probes and Godot's LightmapGI blend
//! probes by (Cupisz, "Light Probe Interpolation Using Tetrahedral
//! Tessellations", GDC 2012).
//!
//! Bowyer–Watson insertion (Bowyer 1981; Watson 1981) with Shewchuk's
//! exact `orient3d` and `insphere` predicates (the `robust` crate) and an
//! infinite vertex closing the hull with "ghost" tetrahedra, so that no
//! bounding super-tetrahedron distorts the hull. Exact predicates make
//! the degenerate sets engines meet every day work: a uniform grid's
//! points are cospherical eight at a time and coplanar on every face.
//!
//! * A finite tetrahedron conflicts with a new point `p` when `p` lies
//!   strictly inside its circumsphere. With strict tests the cavity of
//!   conflicting tetrahedra is star-shaped from `p` even when points are
//!   cospherical: a point on the plane of a cavity face and inside one
//!   side's circumsphere is inside the face's circumcircle, hence inside
//!   the other side's circumsphere too, so no flat tetrahedron is made.
//! * A ghost tetrahedron (a hull face and the infinite vertex) conflicts
//!   when `p` lies strictly outside its face, or on the face's plane and
//!   inside the face's circumcircle, which is when the finite tetrahedron
//!   behind the face conflicts (Shewchuk, "Lecture Notes on Delaunay Mesh
//!   Generation" 2012, §3.6 on ghost triangles, lifted to 3D).
//! * Points are inserted in Morton order and located by a visibility walk
//!   from the last tetrahedron made; a repeated point is skipped.
//!
//! Outside the hull, engines extrapolate from the hull (Unity projects a
//! point outside onto the hull's outer cells); here a point outside takes
//! the barycentric weights of its closest point on the nearest hull
//! triangle, which is continuous across the hull and matches the
//! interpolation on it.

use glam::{DVec3, Vec3};
use robust::{insphere, orient3d, Coord3D};

/// The infinite vertex.
const INF: u32 = u32::MAX;
/// No tetrahedron.
const NONE: u32 = u32::MAX;

/// A Delaunay tetrahedralization of a point set.
#[derive(Debug, Clone)]
pub struct Tetrahedralization {
    points: Vec<DVec3>,
    /// Finite tetrahedra, positively oriented ([`orient3d`] > 0: the
    /// fourth vertex below the counter-clockwise first three), indices
    /// into the input points.
    pub tetrahedra: Vec<[u32; 4]>,
    /// Hull triangles, counter-clockwise seen from outside.
    pub hull: Vec<[u32; 3]>,
    /// The caller's point count: indices at or above it name copies
    /// ([`Tetrahedralization::spanning`]) and [`Tetrahedralization::blend_at`]
    /// folds them back.
    originals: u32,
    /// The finite tetrahedra bucketed by bounding box, for point location.
    buckets: Buckets,
    /// Each hull triangle's bounding sphere (centroid, radius), which
    /// bounds a point's distance to it from below ([`hull_weights`]).
    spheres: Vec<(DVec3, f64)>,
}

/// The bounding sphere (centroid, farthest corner) of each of `hull`'s
/// triangles of `points`.
fn spheres_of(points: &[DVec3], hull: &[[u32; 3]]) -> Vec<(DVec3, f64)> {
    hull.iter()
        .map(|t| {
            let [a, b, cc] = t.map(|i| points[i as usize]);
            let c = (a + b + cc) / 3.0;
            (c, a.distance(c).max(b.distance(c)).max(cc.distance(c)))
        })
        .collect()
}

/// A uniform grid over the points' bounding box listing, per cell, the
/// tetrahedra whose bounding boxes overlap it: a point is looked for in
/// its cell's list only, instead of in every tetrahedron.
#[derive(Debug, Clone, Default)]
struct Buckets {
    lo: DVec3,
    /// Cells per unit length along each axis.
    scale: DVec3,
    dims: [usize; 3],
    /// Cell `c`'s tetrahedra are `items[start[c]..start[c + 1]]`.
    start: Vec<u32>,
    items: Vec<u32>,
}

impl Buckets {
    fn new(points: &[DVec3], tets: &[[u32; 4]]) -> Buckets {
        let Some((lo, hi)) =
            points
                .iter()
                .fold(None, |acc: Option<(DVec3, DVec3)>, &p| match acc {
                    None => Some((p, p)),
                    Some((lo, hi)) => Some((lo.min(p), hi.max(p))),
                })
        else {
            return Buckets::default();
        };
        let extent = (hi - lo).max(DVec3::splat(1e-12));
        // About one cell per tetrahedron, shaped like the box.
        let side = (tets.len().max(1) as f64 / (extent.x * extent.y * extent.z)).cbrt();
        let dims = (extent * side)
            .ceil()
            .clamp(DVec3::ONE, DVec3::splat(64.0))
            .as_uvec3();
        let dims = [dims.x as usize, dims.y as usize, dims.z as usize];
        let scale = DVec3::new(dims[0] as f64, dims[1] as f64, dims[2] as f64) / extent;
        let mut b = Buckets {
            lo,
            scale,
            dims,
            start: vec![0; dims[0] * dims[1] * dims[2] + 1],
            items: Vec::new(),
        };
        let ranges: Vec<([usize; 3], [usize; 3])> = tets
            .iter()
            .map(|t| {
                let (a, z) = t
                    .iter()
                    .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(a, z), &i| {
                        (a.min(points[i as usize]), z.max(points[i as usize]))
                    });
                (b.cell(a), b.cell(z))
            })
            .collect();
        let each = |(a, z): &([usize; 3], [usize; 3]), f: &mut dyn FnMut(usize)| {
            for k in a[2]..=z[2] {
                for j in a[1]..=z[1] {
                    for i in a[0]..=z[0] {
                        f(i + dims[0] * (j + dims[1] * k));
                    }
                }
            }
        };
        for r in &ranges {
            each(r, &mut |c| b.start[c + 1] += 1);
        }
        for c in 1..b.start.len() {
            b.start[c] += b.start[c - 1];
        }
        let mut fill = b.start.clone();
        b.items = vec![0; *b.start.last().unwrap_or(&0) as usize];
        for (t, r) in ranges.iter().enumerate() {
            each(r, &mut |c| {
                b.items[fill[c] as usize] = t as u32;
                fill[c] += 1;
            });
        }
        b
    }

    /// The cell holding `p`, clamped to the grid.
    fn cell(&self, p: DVec3) -> [usize; 3] {
        let q = (p - self.lo) * self.scale;
        [0, 1, 2].map(|a| (q[a].max(0.0) as usize).min(self.dims[a] - 1))
    }

    /// The tetrahedra that may hold `p` (none outside the box).
    fn near(&self, p: DVec3) -> &[u32] {
        if self.start.is_empty() {
            return &[];
        }
        let q = (p - self.lo) * self.scale;
        let d = self.dims;
        if (0..3).any(|a| !(q[a] >= -1e-9 && q[a] <= d[a] as f64 + 1e-9)) {
            return &[];
        }
        let [i, j, k] = self.cell(p);
        let c = i + d[0] * (j + d[1] * k);
        &self.items[self.start[c] as usize..self.start[c + 1] as usize]
    }
}

fn c(p: DVec3) -> Coord3D<f64> {
    Coord3D {
        x: p.x,
        y: p.y,
        z: p.z,
    }
}

/// A Delaunay tetrahedralization under construction (Bowyer–Watson):
/// [`Tetrahedralization::new`]'s builder.
#[derive(Debug, Clone)]
pub(crate) struct Incremental {
    mesh: Mesh,
}

impl Incremental {
    /// The tetrahedralization of `points`, as [`Tetrahedralization::new`]
    /// builds it (the same mesh), kept open for insertions.
    pub(crate) fn new(points: &[Vec3]) -> Option<Incremental> {
        if points.iter().any(|p| !p.is_finite()) {
            return None;
        }
        let pts: Vec<DVec3> = points.iter().map(|p| p.as_dvec3()).collect();
        let order = crate::sampling::morton_order(points);
        let seed = initial(&pts, &order)?;
        let mut mesh = Mesh {
            points: pts,
            tets: Vec::new(),
            neighbours: Vec::new(),
            alive: Vec::new(),
            stamp: Vec::new(),
            insertion: 0,
            cavity: Vec::new(),
            faces: Vec::new(),
        };
        let [a, b, cc, d] = seed;
        let t0 = if mesh.orient([a, b, cc, d]) > 0.0 {
            [a, b, cc, d]
        } else {
            [b, a, cc, d]
        };
        // The tetrahedron, and a ghost on each face. A ghost is oriented as
        // if the infinite vertex were a point far outside its face: the
        // replaced vertex lay inside, so two finite vertices swap.
        mesh.tets.push(t0);
        mesh.neighbours.push([1, 2, 3, 4]);
        mesh.alive.push(true);
        for i in 0..4 {
            // Ghost i+1 shares with ghost j+1 the face without slots i, j.
            let mut v = Mesh::with(t0, i, INF);
            let mut nb: [u32; 4] = std::array::from_fn(|j| if i == j { 0 } else { (j + 1) as u32 });
            let (x, y) = match i {
                0 => (1, 2),
                1 => (0, 2),
                _ => (0, 1),
            };
            v.swap(x, y);
            nb.swap(x, y);
            mesh.tets.push(v);
            mesh.alive.push(true);
            mesh.neighbours.push(nb);
        }
        let mut last = 0u32;
        for &q in &order {
            let q = q as u32;
            if seed.contains(&q) {
                continue;
            }
            let start = mesh.finite_start(last);
            let Some(first) = mesh.locate(start, q) else {
                continue;
            };
            last = mesh.insert(first, q);
        }
        Some(Incremental { mesh })
    }

    /// The tetrahedralization as it stands.
    fn finish(self) -> Tetrahedralization {
        let mesh = self.mesh;
        let tetrahedra: Vec<[u32; 4]> = mesh
            .tets
            .iter()
            .zip(&mesh.alive)
            .filter(|&(v, &alive)| alive && !v.contains(&INF))
            .map(|(v, _)| *v)
            .collect();
        let hull = mesh.hull();
        Tetrahedralization {
            originals: mesh.points.len() as u32,
            buckets: Buckets::new(&mesh.points, &tetrahedra),
            spheres: spheres_of(&mesh.points, &hull),
            points: mesh.points,
            tetrahedra,
            hull,
        }
    }

}

/// The weights of `q` in tetrahedron `t` of `points` when it lies inside
/// (within rounding), vertex indices folded by `originals`.
fn inside_weights(
    points: &[DVec3],
    t: &[u32; 4],
    q: DVec3,
    originals: u32,
) -> Option<[(u32, f32); 4]> {
    const SLACK: f64 = -1e-9;
    let w = barycentric(points, t, q);
    if w.iter().all(|&x| x >= SLACK) {
        let w = w.map(|x| x.max(0.0));
        let s: f64 = w.iter().sum();
        return Some([0, 1, 2, 3].map(|k| (t[k] % originals, (w[k] / s) as f32)));
    }
    None
}

/// Barycentric weights of `p` in tetrahedron `t` of `points`.
fn barycentric(points: &[DVec3], t: &[u32; 4], p: DVec3) -> [f64; 4] {
    let [a, b, cc, d] = t.map(|i| points[i as usize]);
    let vol = (b - a).dot((cc - a).cross(d - a));
    let w1 = (p - a).dot((cc - a).cross(d - a)) / vol;
    let w2 = (b - a).dot((p - a).cross(d - a)) / vol;
    let w3 = (b - a).dot((cc - a).cross(p - a)) / vol;
    [1.0 - w1 - w2 - w3, w1, w2, w3]
}

/// The weights of `q`'s closest point on the nearest of the `hull`
/// triangles of `points` (a fourth weight of 0), indices folded by
/// `originals`; the first nearest in `hull`'s order on ties.
///
/// A triangle's distance is at least its bounding sphere's
/// (`|q − c| − r`): that bound, a few flops, is taken for every triangle,
/// and the exact closest point (Ericson's, some tens) only for those whose
/// bound does not exceed the best distance found, from the smallest bound
/// up. Receivers outside the hull were half of the diffuse step's time
/// when every triangle was measured exactly.
fn hull_weights(
    points: &[DVec3],
    hull: &[[u32; 3]],
    spheres: &[(DVec3, f64)],
    q: DVec3,
    originals: u32,
) -> [(u32, f32); 4] {
    nearest_among(points, hull, spheres, q, originals).1
}

/// [`hull_weights`] with the squared distance; `spheres` bound `hull`'s
/// triangles ([`spheres_of`]).
fn nearest_among(
    points: &[DVec3],
    hull: &[[u32; 3]],
    spheres: &[(DVec3, f64)],
    q: DVec3,
    originals: u32,
) -> (f64, [(u32, f32); 4]) {
    let none = [(0u32, 1.0f32), (0, 0.0), (0, 0.0), (0, 0.0)];
    let bound = |k: usize| (q.distance(spheres[k].0) - spheres[k].1).max(0.0);
    let Some((first, _)) = (0..hull.len())
        .map(|k| (k, bound(k)))
        .min_by(|a, b| a.1.total_cmp(&b.1))
    else {
        return (f64::INFINITY, none);
    };
    let exact = |k: usize| {
        let [a, b, cc] = hull[k].map(|i| points[i as usize]);
        let (x, w) = closest_on_triangle(q, a, b, cc);
        (x.distance_squared(q), w)
    };
    let (mut best, mut at, mut weights) = {
        let (d, w) = exact(first);
        (d, first, w)
    };
    for k in 0..hull.len() {
        if k == first {
            continue;
        }
        let lo = bound(k);
        if lo * lo > best {
            continue;
        }
        let (d, w) = exact(k);
        if d < best || (d == best && k < at) {
            (best, at, weights) = (d, k, w);
        }
    }
    let tri = hull[at];
    let o = originals;
    (
        best,
        [
            (tri[0] % o, weights[0] as f32),
            (tri[1] % o, weights[1] as f32),
            (tri[2] % o, weights[2] as f32),
            (tri[0] % o, 0.0),
        ],
    )
}

/// The triangulation under construction.
#[derive(Debug, Clone)]
struct Mesh {
    points: Vec<DVec3>,
    tets: Vec<[u32; 4]>,
    /// Neighbour across the face opposite each vertex.
    neighbours: Vec<[u32; 4]>,
    alive: Vec<bool>,
    /// Per tetrahedron, the insertion whose cavity last took it
    /// ([`Mesh::insert`]): a membership test without hashing, which took a
    /// sixth of `Tetrahedralization::new`'s time as a hash set.
    stamp: Vec<u32>,
    /// The current insertion's number, for `stamp`.
    insertion: u32,
    /// The cavity's tetrahedra and its open faces (keyed by the two
    /// vertices besides the new point, with the tetrahedron and slot),
    /// kept between insertions so that none allocates.
    cavity: Vec<u32>,
    faces: Vec<((u32, u32), (u32, usize))>,
}

impl Mesh {
    /// `last` when it is a live finite tetrahedron, else the newest one:
    /// where a point's walk starts.
    fn finite_start(&self, last: u32) -> u32 {
        if self.alive[last as usize] && !self.tets[last as usize].contains(&INF) {
            last
        } else {
            (0..self.tets.len() as u32)
                .rev()
                .find(|&t| self.alive[t as usize] && !self.tets[t as usize].contains(&INF))
                .expect("a finite tetrahedron")
        }
    }

    /// The hull's triangles, counter-clockwise seen from outside: the
    /// finite faces of the live ghost tetrahedra.
    fn hull(&self) -> Vec<[u32; 3]> {
        let mut hull = Vec::new();
        for (t, v) in self.tets.iter().enumerate() {
            if !self.alive[t] {
                continue;
            }
            if let Some(k) = v.iter().position(|&x| x == INF) {
                // orient(v with q at k) > 0 for q outside. Moving q
                // from slot k to the last is an odd permutation for k
                // even, so orient(f, q) > 0 outside for k odd; a face
                // counter-clockwise from outside has orient(f, q) < 0
                // there, so for k odd two vertices swap.
                let f: Vec<u32> = (0..4).filter(|&m| m != k).map(|m| v[m]).collect();
                hull.push(if k % 2 == 1 {
                    [f[1], f[0], f[2]]
                } else {
                    [f[0], f[1], f[2]]
                });
            }
        }
        hull
    }

    fn orient(&self, t: [u32; 4]) -> f64 {
        let p = |i: u32| c(self.points[i as usize]);
        orient3d(p(t[0]), p(t[1]), p(t[2]), p(t[3]))
    }

    /// `t` with vertex `i` replaced by point `q`'s index.
    fn with(t: [u32; 4], i: usize, q: u32) -> [u32; 4] {
        let mut u = t;
        u[i] = q;
        u
    }

    /// Whether tetrahedron `t` conflicts with point `q` (module docs).
    fn conflicts(&self, t: u32, q: u32) -> bool {
        let v = self.tets[t as usize];
        match v.iter().position(|&x| x == INF) {
            None => {
                let p = |i: u32| c(self.points[i as usize]);
                insphere(p(v[0]), p(v[1]), p(v[2]), p(v[3]), p(q)) > 0.0
            }
            Some(k) => {
                let o = self.orient(Self::with(v, k, q));
                if o != 0.0 {
                    return o > 0.0;
                }
                let behind = self.neighbours[t as usize][k];
                let w = self.tets[behind as usize];
                let p = |i: u32| c(self.points[i as usize]);
                insphere(p(w[0]), p(w[1]), p(w[2]), p(w[3]), p(q)) > 0.0
            }
        }
    }

    /// A tetrahedron in conflict with point `q`, walking from `start`;
    /// `None` when `q` repeats a vertex.
    fn locate(&self, start: u32, q: u32) -> Option<u32> {
        let p = self.points[q as usize];
        let mut t = start;
        let limit = 4 * self.tets.len() + 16;
        for _ in 0..limit {
            let v = self.tets[t as usize];
            if v.contains(&INF) {
                return Some(t);
            }
            let mut moved = false;
            for i in 0..4 {
                if self.orient(Self::with(v, i, q)) < 0.0 {
                    t = self.neighbours[t as usize][i];
                    moved = true;
                    break;
                }
            }
            if !moved {
                if v.iter().any(|&x| self.points[x as usize] == p) {
                    return None;
                }
                return Some(t);
            }
        }
        // Not reached for a Delaunay mesh (visibility walks terminate);
        // kept as a guard: scan.
        (0..self.tets.len() as u32).find(|&t| self.alive[t as usize] && self.conflicts(t, q))
    }

    /// Inserts point `q` into the cavity grown from `first`; returns one new
    /// tetrahedron.
    fn insert(&mut self, first: u32, q: u32) -> u32 {
        self.insertion += 1;
        let mark = self.insertion;
        self.stamp.resize(self.tets.len(), 0);
        let mut cavity = std::mem::take(&mut self.cavity);
        cavity.clear();
        cavity.push(first);
        self.stamp[first as usize] = mark;
        let mut k = 0;
        while k < cavity.len() {
            let t = cavity[k];
            k += 1;
            for i in 0..4 {
                let n = self.neighbours[t as usize][i];
                if self.stamp[n as usize] != mark && self.conflicts(n, q) {
                    self.stamp[n as usize] = mark;
                    cavity.push(n);
                }
            }
        }
        // One new tetrahedron per boundary face of the cavity. The new
        // ones are stamped 0: never in this cavity.
        let mut faces = std::mem::take(&mut self.faces);
        faces.clear();
        let mut last = NONE;
        for &t in &cavity {
            for i in 0..4 {
                let outside = self.neighbours[t as usize][i];
                if self.stamp[outside as usize] == mark {
                    continue;
                }
                let v = Self::with(self.tets[t as usize], i, q);
                let id = self.tets.len() as u32;
                self.tets.push(v);
                self.alive.push(true);
                self.stamp.push(0);
                let mut nb = [NONE; 4];
                nb[i] = outside;
                self.neighbours.push(nb);
                let back = self.neighbours[outside as usize]
                    .iter()
                    .position(|&x| x == t)
                    .expect("the neighbour links back");
                self.neighbours[outside as usize][back] = id;
                // The three faces through q: keyed by their other two vertices.
                for j in (0..4).filter(|&j| j != i) {
                    let mut others = (0..4).filter(|&m| m != i && m != j).map(|m| v[m]);
                    let (a, b) = (others.next().unwrap(), others.next().unwrap());
                    let key = (a.min(b), a.max(b));
                    match faces.iter().position(|(k, _)| *k == key) {
                        Some(f) => {
                            let (_, (u, uj)) = faces.swap_remove(f);
                            self.neighbours[id as usize][j] = u;
                            self.neighbours[u as usize][uj] = id;
                        }
                        None => faces.push((key, (id, j))),
                    }
                }
                last = id;
            }
        }
        for &t in &cavity {
            self.alive[t as usize] = false;
        }
        debug_assert!(faces.is_empty(), "the cavity's boundary is closed");
        self.cavity = cavity;
        self.faces = faces;
        last
    }
}

impl Tetrahedralization {
    /// The Delaunay tetrahedralization of `points` (module docs).
    ///
    /// Contract: `None` when fewer than four points span space (all
    /// coplanar, collinear or repeated) or a coordinate is not finite;
    /// otherwise the finite tetrahedra are positively oriented, fill the
    /// convex hull without overlap, and no point lies strictly inside a
    /// tetrahedron's circumsphere; repeated points are left out.
    /// Deterministic.
    pub fn new(points: &[Vec3]) -> Option<Tetrahedralization> {
        Some(Incremental::new(points)?.finish())
    }

    /// [`Tetrahedralization::new`], or for points that do not span space
    /// (a one-layer grid, a row of probes) the tetrahedralization of the
    /// points and three copies moved a thousandth of their extent along x,
    /// y and z: a slab around their plane (or a prism around their line),
    /// whose outer faces are the plane's own Delaunay triangles. A point
    /// off the plane then takes the barycentric weights of its projection
    /// on the triangle below it, as a blind blend of a flat set would, and
    /// not the nearest probe's light alone. `None` only without two
    /// distinct finite points.
    pub fn spanning(points: &[Vec3]) -> Option<Tetrahedralization> {
        if let Some(t) = Tetrahedralization::new(points) {
            return Some(t);
        }
        if points.iter().any(|p| !p.is_finite()) {
            return None;
        }
        let (lo, hi) = points
            .iter()
            .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), &p| {
                (lo.min(p), hi.max(p))
            });
        let extent = (hi - lo).max_element();
        // Also false for NaN.
        if extent.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
            return None;
        }
        let d = 1e-3 * extent;
        let mut all = points.to_vec();
        for offset in [Vec3::X * d, Vec3::Y * d, Vec3::Z * d] {
            all.extend(points.iter().map(|&p| p + offset));
        }
        let mut t = Tetrahedralization::new(&all)?;
        t.originals = points.len() as u32;
        Some(t)
    }

    /// The probes and weights that blend at `p`: the four corners of the
    /// tetrahedron holding it with its barycentric weights, or outside the
    /// hull the corners of the nearest hull triangle with the weights of
    /// `p`'s closest point on it (a fourth weight of 0).
    ///
    /// Contract: weights non-negative, summing to 1; deterministic.
    #[cfg(test)]
    pub fn weights(&self, p: Vec3) -> [(u32, f32); 4] {
        self.blend_at(p).0
    }

    /// The probes and weights that blend at `p` (the corners of the
    /// tetrahedron holding it with its barycentric weights, or outside the
    /// hull the corners of the nearest hull triangle with the weights of
    /// `p`'s closest point on it, a fourth weight of 0), and whether `p`
    /// lies in a tetrahedron.
    ///
    /// Contract: weights non-negative, summing to 1; deterministic.
    pub fn blend_at(&self, p: Vec3) -> ([(u32, f32); 4], bool) {
        let q = p.as_dvec3();
        for &t in self.buckets.near(q) {
            let t = &self.tetrahedra[t as usize];
            if let Some(w) = inside_weights(&self.points, t, q, self.originals) {
                return (w, true);
            }
        }
        (
            hull_weights(&self.points, &self.hull, &self.spheres, q, self.originals),
            false,
        )
    }
}

impl Tetrahedralization {
    /// Whether it was built over copies of flat points
    /// ([`Tetrahedralization::spanning`]), whose hull is a slab's.
    pub(crate) fn is_flat(&self) -> bool {
        self.originals as usize != self.points.len()
    }

    /// The squared distance from `p` to its closest point on the nearest
    /// of `triangles` (of this tetrahedralization's points) and that
    /// point's weights ([`Tetrahedralization::blend_at`] outside the hull,
    /// over these triangles alone; the first nearest on ties).
    pub(crate) fn nearest_on(
        &self,
        triangles: &[[u32; 3]],
        spheres: &[(DVec3, f64)],
        p: Vec3,
    ) -> (f64, [(u32, f32); 4]) {
        nearest_among(&self.points, triangles, spheres, p.as_dvec3(), self.originals)
    }

    /// The squared distance from `p` to its closest point on triangle
    /// `tri` (of this tetrahedralization's points) and that point's
    /// weights, as [`Tetrahedralization::nearest_on`] gives them.
    pub(crate) fn distance_to(&self, tri: [u32; 3], p: Vec3) -> (f64, [(u32, f32); 4]) {
        let spheres = [(DVec3::ZERO, f64::INFINITY)];
        nearest_among(&self.points, &[tri], &spheres, p.as_dvec3(), self.originals)
    }

    /// The bounding spheres of `triangles` (of this tetrahedralization's
    /// points), for [`Tetrahedralization::nearest_on`].
    pub(crate) fn spheres(&self, triangles: &[[u32; 3]]) -> Vec<(DVec3, f64)> {
        spheres_of(&self.points, triangles)
    }
}

/// Four points of `order` that span space, the first found: the first
/// point, the next distinct one, the next off their line, the next off
/// their plane.
fn initial(pts: &[DVec3], order: &[usize]) -> Option<[u32; 4]> {
    let a = *order.first()?;
    let b = *order.iter().find(|&&i| pts[i] != pts[a])?;
    let cc = *order
        .iter()
        .find(|&&i| (pts[b] - pts[a]).cross(pts[i] - pts[a]) != DVec3::ZERO)?;
    let d = *order
        .iter()
        .find(|&&i| orient3d(c(pts[a]), c(pts[b]), c(pts[cc]), c(pts[i])) != 0.0)?;
    Some([a as u32, b as u32, cc as u32, d as u32])
}

/// The closest point to `p` on triangle `abc` and its barycentric weights
/// (Ericson, "Real-Time Collision Detection" 2005, §5.1.5).
fn closest_on_triangle(p: DVec3, a: DVec3, b: DVec3, c: DVec3) -> (DVec3, [f64; 3]) {
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return (a, [1.0, 0.0, 0.0]);
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return (b, [0.0, 1.0, 0.0]);
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let v = d1 / (d1 - d3);
        return (a + ab * v, [1.0 - v, v, 0.0]);
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return (c, [0.0, 0.0, 1.0]);
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let w = d2 / (d2 - d6);
        return (a + ac * w, [1.0 - w, 0.0, w]);
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return (b + (c - b) * w, [0.0, 1.0 - w, w]);
    }
    let denom = 1.0 / (va + vb + vc);
    let (v, w) = (vb * denom, vc * denom);
    (a + ab * v + ac * w, [1.0 - v - w, v, w])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::{hash2, unit_f32};
    use std::collections::HashMap;

    fn grid(nx: u32, ny: u32, nz: u32, h: f32) -> Vec<Vec3> {
        let mut p = Vec::new();
        for z in 0..nz {
            for y in 0..ny {
                for x in 0..nx {
                    p.push(Vec3::new(x as f32, y as f32, z as f32) * h);
                }
            }
        }
        p
    }

    fn random(n: u64, seed: u64) -> Vec<Vec3> {
        (0..n)
            .map(|i| {
                Vec3::new(
                    unit_f32(hash2(seed, 3 * i)),
                    unit_f32(hash2(seed, 3 * i + 1)),
                    unit_f32(hash2(seed, 3 * i + 2)),
                ) * 10.0
            })
            .collect()
    }

    /// Volume of a tetrahedron, positive for [`orient3d`]'s positive
    /// orientation (Shewchuk's: `d` below the counter-clockwise `abc`, the
    /// opposite of the right-handed triple product).
    fn volume(t: &Tetrahedralization, v: &[u32; 4]) -> f64 {
        let [a, b, c, d] = v.map(|i| t.points[i as usize]);
        -(b - a).dot((c - a).cross(d - a)) / 6.0
    }

    /// Every tetrahedron positive, Delaunay against every point, the
    /// volumes summing to `hull_volume`, and the hull closed.
    fn check(points: &[Vec3], hull_volume: f64) -> Tetrahedralization {
        let t = Tetrahedralization::new(points).expect("spans space");
        let mut total = 0.0;
        for v in &t.tetrahedra {
            let vol = volume(&t, v);
            assert!(vol > 0.0, "flat or inverted {v:?}");
            total += vol;
            let p = |i: u32| c(t.points[i as usize]);
            for q in 0..points.len() as u32 {
                assert!(
                    insphere(p(v[0]), p(v[1]), p(v[2]), p(v[3]), p(q)) <= 0.0,
                    "point {q} inside the circumsphere of {v:?}"
                );
            }
        }
        assert!(
            (total - hull_volume).abs() < 1e-9 * hull_volume,
            "volume {total} vs {hull_volume}"
        );
        // Every hull edge is shared by exactly two hull triangles, in
        // opposite directions.
        let mut edges = HashMap::new();
        for tri in &t.hull {
            for k in 0..3 {
                *edges.entry((tri[k], tri[(k + 1) % 3])).or_insert(0) += 1;
            }
        }
        for (&(a, b), &n) in &edges {
            assert_eq!(n, 1, "edge {a}-{b} repeated");
            assert_eq!(edges.get(&(b, a)), Some(&1), "edge {a}-{b} open");
        }
        // Hull triangles face outwards: every point on their inner side.
        for tri in &t.hull {
            let [a, b, cc] = tri.map(|i| c(t.points[i as usize]));
            for q in &t.points {
                assert!(
                    orient3d(a, b, cc, c(*q)) >= 0.0,
                    "hull face {tri:?} faces in"
                );
            }
        }
        t
    }

    #[test]
    fn grids_are_tetrahedralized_despite_cospherical_points() {
        for (nx, ny, nz, h) in [
            (2, 2, 2, 1.0),
            (4, 3, 2, 1.0),
            (7, 3, 2, 0.5),
            (5, 5, 5, 0.3),
        ] {
            let p = grid(nx, ny, nz, h as f32);
            // The box of the f32 corners (0.3 is not exact in f32).
            let far = p[p.len() - 1].as_dvec3();
            let v = far.x * far.y * far.z;
            let t = check(&p, v);
            assert!(!t.tetrahedra.is_empty());
        }
    }

    #[test]
    fn random_points_and_repeats() {
        let mut p = random(300, 7);
        let t = Tetrahedralization::new(&p).unwrap();
        let vol: f64 = t.tetrahedra.iter().map(|v| volume(&t, v)).sum();
        check(&p, vol);
        let before = t.tetrahedra.len();
        p.extend(random(300, 7));
        let again = check(&p, vol);
        assert_eq!(again.tetrahedra.len(), before, "repeats add nothing");
    }

    /// Points inserted one at a time into an open mesh give the mesh
    /// built from all of them (random points: the Delaunay mesh is
    /// unique), and each insertion's star holds the new point.
    #[test]
    fn flat_and_tiny_sets_are_refused() {
        assert!(Tetrahedralization::new(&grid(4, 4, 1, 1.0)).is_none());
        assert!(Tetrahedralization::new(&grid(5, 1, 1, 1.0)).is_none());
        assert!(Tetrahedralization::new(&[Vec3::ZERO; 6]).is_none());
        assert!(Tetrahedralization::new(&[]).is_none());
        assert!(Tetrahedralization::new(&[Vec3::NAN, Vec3::ONE, Vec3::X, Vec3::Y]).is_none());
    }

    #[test]
    fn interpolation_reproduces_linear_functions_inside_and_is_deterministic() {
        let p = random(60, 3);
        let t = Tetrahedralization::new(&p).unwrap();
        let f = |x: Vec3| 1.0 + 2.0 * x.x - 0.5 * x.y + 0.25 * x.z;
        for q in random(200, 11) {
            let w = t.weights(q);
            let sum: f32 = w.iter().map(|x| x.1).sum();
            assert!((sum - 1.0).abs() < 1e-5);
            assert!(w.iter().all(|x| x.1 >= 0.0));
            let inside = t.tetrahedra.iter().any(|v| {
                barycentric(&t.points, v, q.as_dvec3())
                    .iter()
                    .all(|&b| b >= 0.0)
            });
            if inside {
                let got: f32 = w.iter().map(|&(i, x)| x * f(p[i as usize])).sum();
                assert!((got - f(q)).abs() < 1e-3, "{got} vs {}", f(q));
            }
        }
        let again = Tetrahedralization::new(&p).unwrap();
        assert_eq!(again.tetrahedra, t.tetrahedra);
    }

    #[test]
    fn flat_sets_blend_like_their_plane_triangulation() {
        // A one-layer grid at y = 1: a point above or below a triangle
        // takes its projection's barycentric weights, so a linear function
        // of x and z is reproduced; a row of probes interpolates along it.
        let p: Vec<Vec3> = grid(4, 3, 1, 1.0)
            .into_iter()
            .map(|q| Vec3::new(q.x, 1.0, q.y))
            .collect();
        let t = Tetrahedralization::spanning(&p).unwrap();
        let f = |x: Vec3| 2.0 + x.x - 0.5 * x.z;
        for q in [
            Vec3::new(0.3, 0.0, 0.6),
            Vec3::new(2.5, 3.0, 1.2),
            Vec3::new(1.0, -1.0, 1.9),
        ] {
            let w = t.weights(q);
            assert!(w.iter().all(|&(i, x)| (i as usize) < p.len() && x >= 0.0));
            let got: f32 = w.iter().map(|&(i, x)| x * f(p[i as usize])).sum();
            assert!((got - f(q)).abs() < 0.01, "{q}: {got} vs {}", f(q));
        }
        let row: Vec<Vec3> = (0..5).map(|i| Vec3::new(i as f32, 0.0, 0.0)).collect();
        let t = Tetrahedralization::spanning(&row).unwrap();
        let w = t.weights(Vec3::new(1.25, 2.0, -1.0));
        let got: f32 = w.iter().map(|&(i, x)| x * row[i as usize].x).sum();
        assert!((got - 1.25).abs() < 0.01, "{w:?}");
        assert!(Tetrahedralization::spanning(&[Vec3::ONE; 3]).is_none());
    }

    #[test]
    fn outside_the_hull_the_nearest_face_is_used() {
        let p = grid(2, 2, 2, 1.0);
        let t = Tetrahedralization::new(&p).unwrap();
        // Above the top face's centre: the top four corners (two of them on
        // its diagonal) share the weight; no bottom corner takes any.
        let w = t.weights(Vec3::new(0.5, 0.5, 3.0));
        for (i, x) in w {
            if x > 0.0 {
                assert_eq!(p[i as usize].z, 1.0, "{w:?}");
            }
        }
        let got: Vec3 = w.iter().map(|&(i, x)| p[i as usize] * x).sum();
        assert!((got - Vec3::new(0.5, 0.5, 1.0)).length() < 1e-5, "{got}");
    }
}
