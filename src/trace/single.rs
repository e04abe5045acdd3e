//! The single-probe trace of McGuire et al. 2017 §4.1 (Listing 1,
//! `singleProbeTrace`), made hierarchical as in Wang et al. 2019 §4.2.
//!
//! A 3D ray segment maps, under the octahedral projection about a probe, to
//! a polyline of at most four straight pieces: the segment is cut where it
//! crosses the three axis planes through the probe, and within one octant
//! the projection is central projection onto a flat octahedron face, which
//! keeps lines straight. Within a piece each map coordinate is a ratio of
//! two functions linear in the ray parameter t, e = N(t) / |q(t)|₁, so the
//! t at which the ray crosses a texel edge solves a linear equation: the
//! march steps from texel edge to texel edge exactly, in t.
//!
//! Each texel is a surfel (McGuire §4.1): the plane through the stored
//! point with the stored normal, which faces the probe. Over the part of
//! the ray inside the texel's cone, [t_a, t_b]:
//! - if the ray's largest radial distance there, max(r(t_a), r(t_b)) (|q|
//!   is convex), is below the level's min distance, the ray passes in front:
//!   go on (at coarse levels this skips 4ᵏ fine texels at once);
//! - else, with f(t) the signed distance to the surfel's plane (positive on
//!   the probe's side): a ray that enters in front (f(t_a) > 0) and ends
//!   behind (f(t_b) ≤ 0) **hits** where f = 0, and so does one that enters
//!   less than τ behind (f(t_a) ≥ −τ) and goes deeper (f(t_b) < f(t_a)), at
//!   t_a; one that stays in front goes on; one that enters more than τ
//!   behind has passed **behind** a surface the probe cannot see past: the
//!   probe cannot tell (**unknown**).
//!
//! τ = 2s/n, about one texel's width at the surfel's distance s, absorbs the
//! step between neighbouring surfels of a curved surface. Because the plane
//! faces the probe, crossing it from front to back means meeting its front
//! face; McGuire's back-face discrimination comes for free, and it holds
//! inside τ too: a ray within τ behind a plane and moving towards its front
//! is *leaving* a surface, not meeting one. Glossy rays start on a surface,
//! which the maps store to half precision and, on a faceted one, as the
//! plane of a neighbouring facet: their origin often lies a little behind a
//! surfel, and counting that as a hit at t = 0 read the shading point's own
//! radiance, as the probe sees it, for about 3% of the glossy rays in
//! CornellBox-Glossy (docs/method.md, "Rays that hit their own origin"). Where the
//! surface bends at a texel's edge the neighbouring surfels join the test
//! (see `surfel_test`). The coarse test is exactly the fine test's first
//! branch on bounds of the fine values, so the hierarchical march returns
//! what a texel-by-texel march returns, up to rounding in the texel spans.

use crate::lightfield::maps::decode_normal;
use crate::lightfield::{octahedral, LightField};
use glam::Vec3;

/// What one probe can say about a ray.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Probe {
    /// The ray meets a surface at `t`.
    Hit(f32),
    /// The ray reaches its end without meeting a surface.
    Miss,
    /// At `t` the ray passes behind a surface this probe sees; another probe
    /// must go on from there.
    Unknown(f32),
}

/// How the march walks one probe's distance pyramid.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum March {
    /// Texel by texel at full resolution: the reference the others must match.
    Texel,
    /// McGuire et al. 2017 §4.1 (Fig. 4), as Wang et al. 2019 §4.2 describe
    /// it: march at 1/16² resolution ([`BILEVEL_COARSE_LEVEL`]) and, where a
    /// coarse texel may hold a hit, march its full-resolution texels.
    BiLevel,
    /// Wang et al. 2019 §4.2: climb and descend the whole min pyramid,
    /// between [`top_level`] and full resolution. Where the texel holding
    /// the ray's origin cannot be passed at the top level, the origin lies
    /// at a surface (glossy rays leave one; a fallback probe resumes where
    /// the previous one lost the ray behind one): the march drops straight
    /// to full resolution and climbs from there, as Hi-Z screen-space
    /// tracing starts (Uludag 2014, which Wang cite), instead of reading
    /// every level on the way down.
    HiZ,
}

/// Pyramid level of McGuire's coarse march: 1/16 of the side, 1/16² of
/// the texels (McGuire §4.1, Fig. 4).
pub const BILEVEL_COARSE_LEVEL: usize = 4;

/// Texture reads of one surfel test: distance and normal of the texel and
/// of its four edge neighbours. The same in every march, so they are
/// counted apart from the march's own reads.
pub const SURFEL_TEST_FETCHES: u32 = 10;

/// Counters of one trace, for benchmarks and the render report.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Steps {
    /// Texels visited at level 0.
    pub fine: u32,
    /// Texels visited above level 0.
    pub coarse: u32,
    /// Surfel tests run (each reads [`SURFEL_TEST_FETCHES`] texels).
    pub surfels: u32,
    /// Probes consulted ([`crate::trace::trace`] counts them).
    pub probes: u32,
}

impl Steps {
    /// The march's texture reads: one per pyramid texel visited, at any
    /// level. This is where the marches differ (Wang §4.2: "fewer steps on
    /// average compared to bi-scale marching").
    pub fn march_fetches(&self) -> u32 {
        self.fine + self.coarse
    }

    /// The surfel tests' texture reads, the same whichever march found the
    /// texels to test.
    pub fn surfel_fetches(&self) -> u32 {
        SURFEL_TEST_FETCHES * self.surfels
    }

    /// Probes consulted after the first: McGuire's probe switches.
    pub fn switches(&self) -> u32 {
        self.probes.saturating_sub(1)
    }
}

/// One polyline piece: the ray within one octant of the probe.
struct Piece {
    /// e.x = (nx0 + nx1 t) / (d0 + d1 t), e.y likewise.
    nx: [f32; 2],
    ny: [f32; 2],
    den: [f32; 2],
    /// Motion of e.x, e.y along increasing t: +1, −1 or 0.
    sx: i32,
    sy: i32,
}

impl Piece {
    fn new(a: Vec3, d: Vec3, mid: Vec3) -> Piece {
        let s = Vec3::new(sgn(mid.x), sgn(mid.y), sgn(mid.z));
        let den = [s.dot(a), s.dot(d)];
        let (nx, ny) = if mid.z >= 0.0 {
            ([a.x, d.x], [a.y, d.y])
        } else {
            (
                [s.x * (den[0] - s.y * a.y), s.x * (den[1] - s.y * d.y)],
                [s.y * (den[0] - s.x * a.x), s.y * (den[1] - s.x * d.x)],
            )
        };
        let motion = |n: [f32; 2]| {
            let m = n[1] * den[0] - n[0] * den[1];
            if m > 0.0 {
                1
            } else if m < 0.0 {
                -1
            } else {
                0
            }
        };
        Piece {
            sx: motion(nx),
            sy: motion(ny),
            nx,
            ny,
            den,
        }
    }

    fn at(&self, t: f32) -> (f32, f32) {
        let dn = self.den[0] + self.den[1] * t;
        (
            (self.nx[0] + self.nx[1] * t) / dn,
            (self.ny[0] + self.ny[1] * t) / dn,
        )
    }

    /// The t at which the coordinate `n` equals `c`.
    fn crossing(&self, n: [f32; 2], c: f32) -> f32 {
        let k = n[1] - c * self.den[1];
        if k == 0.0 {
            f32::INFINITY
        } else {
            (c * self.den[0] - n[0]) / k
        }
    }
}

fn sgn(v: f32) -> f32 {
    if v >= 0.0 {
        1.0
    } else {
        -1.0
    }
}

/// Texel index of map coordinate `e` at side `side`, nudged in the direction
/// of motion so a point on an edge belongs to the texel being entered.
fn cell(e: f32, side: u32, motion: i32) -> i64 {
    let x = (e + 1.0) * 0.5 * side as f32 + motion as f32 * 1e-4;
    (x.floor() as i64).clamp(0, side as i64 - 1)
}

/// What the fine test decides for one texel.
enum Texel {
    /// The ray passes in front.
    Pass,
    /// The ray meets the surface at this t.
    Hit(f32),
    /// The ray enters the texel behind the surface.
    Behind,
}

/// The first t in [t_a, t_b] where f, linear from `fa` to `fb`, is negative.
fn onset(fa: f32, fb: f32, ta: f32, tb: f32) -> Option<f32> {
    if fa < 0.0 {
        Some(ta)
    } else if fb < 0.0 {
        Some(ta + (tb - ta) * fa / (fa - fb))
    } else {
        None
    }
}

/// The fine test of texel (`x`, `y`) for the ray from `q.0` to `q.1`
/// (relative to the probe) over `span` = (t_a, t_b); see the module docs.
///
/// Where a surface bends at the texel's edge, the texel's own surfel does
/// not describe all of its cone: past a crease or a convex edge part of the
/// cone sees the neighbour's surface. So the four edge neighbours' surfels
/// join the test when they are continuous with this one: *concave* (each
/// surfel's point lies in front of the other's plane: the surface is the
/// nearer plane, and crossing the neighbour's plane is a hit) or *convex*
/// (each lies behind the other's plane: the surface is the farther plane,
/// the ray meets it once behind both, and a ray in front of the neighbour's
/// plane is not yet behind the surface). Any other pair is a depth
/// discontinuity, where the neighbour says nothing about this cone.
fn surfel_test(
    field: &LightField,
    probe: usize,
    x: u32,
    y: u32,
    q: (Vec3, Vec3),
    span: (f32, f32),
) -> Texel {
    let n = field.resolution;
    let index = field.index(probe, x, y);
    let s = field.distance[index];
    let nrm = decode_normal(field.normal[index]);
    let centre = octahedral::texel_direction(x, y, n) * s;
    let fa = nrm.dot(q.0 - centre);
    let fb = nrm.dot(q.1 - centre);
    let tau = 2.0 * s / n as f32;
    let eps = 1e-3 * s;
    let (ta, tb) = span;
    // A plane is met by a ray that crosses it from front to back, or that
    // enters within τ behind it and goes deeper; not by one moving towards
    // its front, which is leaving a surface (module docs).
    let meets = |fa: f32, fb: f32| fb <= 0.0 && (fa > 0.0 || (fa >= -tau && fb < fa));
    let mut hit = if meets(fa, fb) {
        Some(if fa <= 0.0 {
            ta
        } else {
            ta + (tb - ta) * fa / (fa - fb)
        })
    } else {
        None
    };
    let mut shielded = false;
    // Across a convex edge the solid lies behind both planes: while the ray
    // is in front of a convex neighbour's plane it is outside the surface,
    // whatever the own plane says. `gate`: the first t at which the ray is
    // behind every such neighbour's plane (`None`: not within the span).
    let mut gate = Some(ta);
    for (dx, dy) in [(-1i64, 0i64), (1, 0), (0, -1), (0, 1)] {
        let (nx, ny) = octahedral::wrap_texel(x as i64 + dx, y as i64 + dy, n);
        let k = field.index(probe, nx, ny);
        let sk = field.distance[k];
        if !sk.is_finite() {
            continue;
        }
        let nk = decode_normal(field.normal[k]);
        let ck = octahedral::texel_direction(nx, ny, n) * sk;
        let (own_of_k, k_of_own) = (nrm.dot(ck - centre), nk.dot(centre - ck));
        let ga = nk.dot(q.0 - ck);
        let gb = nk.dot(q.1 - ck);
        if own_of_k >= -eps && k_of_own >= -eps {
            if meets(ga, gb) {
                let tk = if ga <= 0.0 {
                    ta
                } else {
                    ta + (tb - ta) * ga / (ga - gb)
                };
                hit = Some(hit.map_or(tk, |h: f32| h.min(tk)));
            }
        } else if own_of_k < eps && k_of_own < eps && ga >= 0.0 {
            shielded = true;
            let t1 = onset(ga, gb, ta, tb);
            gate = gate.zip(t1).map(|(g, t)| g.max(t));
            if let (Some(t0), Some(t1)) = (onset(fa, fb, ta, tb), t1) {
                let tk = t0.max(t1);
                hit = Some(hit.map_or(tk, |h: f32| h.min(tk)));
            }
        }
    }
    let hit = hit.zip(gate).map(|(h, g)| h.max(g));
    match hit {
        Some(t) => Texel::Hit(t.clamp(ta, tb)),
        None if fa < -tau && !shielded => Texel::Behind,
        None => Texel::Pass,
    }
}

/// The highest pyramid level the Hi-Z march starts from: side 8 or more,
/// as Wang §4.2 avoids the coarsest levels.
pub fn top_level(n: u32) -> usize {
    n.trailing_zeros().saturating_sub(3) as usize
}

/// The coarsest level a march uses, and where every piece starts: 0 for
/// [`March::Texel`], McGuire's coarse level (capped at the map's) for
/// [`March::BiLevel`], [`top_level`] for [`March::HiZ`].
pub fn start_level(n: u32, march: March) -> usize {
    match march {
        March::Texel => 0,
        March::BiLevel => BILEVEL_COARSE_LEVEL.min(n.trailing_zeros() as usize),
        March::HiZ => top_level(n),
    }
}

/// Traces the ray `origin + t·dir`, `t` in [`t0`, `t1`], through probe
/// `probe`'s maps, walking the min pyramid as `march` says.
///
/// Contract: `dir` is unit length and `t1` finite. `Hit(t)` and
/// `Unknown(t)` have t in [`t0`, `t1`]. All marches agree (see module docs)
/// up to rounding in the texel spans; they differ in `steps`.
#[allow(clippy::too_many_arguments)]
pub fn trace(
    field: &LightField,
    probe: usize,
    origin: Vec3,
    dir: Vec3,
    t0: f32,
    t1: f32,
    march: March,
    steps: &mut Steps,
) -> Probe {
    let a = origin - field.positions[probe];
    // Cut at the axis planes through the probe: at most four pieces.
    let mut cuts = [t0, t1, t1, t1, t1];
    let mut k = 1;
    for i in 0..3 {
        if dir[i] != 0.0 {
            let t = -a[i] / dir[i];
            if t > t0 && t < t1 {
                cuts[k] = t;
                k += 1;
            }
        }
    }
    cuts[k] = t1;
    cuts[1..k].sort_by(f32::total_cmp);
    for (i, w) in cuts[..=k].windows(2).enumerate() {
        let (ta, tb) = (w[0], w[1]);
        if tb <= ta {
            continue;
        }
        let mid = a + dir * (0.5 * (ta + tb));
        if mid.length_squared() == 0.0 {
            continue;
        }
        let piece = Piece::new(a, dir, mid);
        let at_origin = i == 0;
        if let Some(r) = march_piece(
            field,
            probe,
            a,
            dir,
            &piece,
            (ta, tb),
            (march, at_origin),
            steps,
        ) {
            return r;
        }
    }
    Probe::Miss
}

/// The Hi-Z level after the ray leaves a texel at `level` by an edge that is
/// also an edge `shared` levels up. Climbing into the texel the ray was
/// just sent down from would read it again only to descend again, so the
/// march climbs one level only when it leaves that parent texel too.
/// (Climbing all `shared` levels at once was measured and reads more
/// texels: the coarser texels near a surface send the ray down again.)
fn climb(level: usize, shared: u32, top: usize, march: March) -> usize {
    match march {
        March::HiZ if shared == 0 => level,
        March::HiZ => (level + 1).min(top),
        _ => top,
    }
}

/// Marches one piece over `span`; `None` when it reaches its end.
/// `at_origin`: the piece starts at the ray's origin.
///
/// Hi-Z climbs one level after each texel the ray passes and descends one
/// where it may not pass. Bi-level jumps from its coarse level straight to
/// level 0 and marches full-resolution texels until the ray leaves the
/// coarse texel (`coarse_end`), then returns to the coarse level.
#[allow(clippy::too_many_arguments)]
fn march_piece(
    field: &LightField,
    probe: usize,
    a: Vec3,
    d: Vec3,
    piece: &Piece,
    span: (f32, f32),
    (march, at_origin): (March, bool),
    steps: &mut Steps,
) -> Option<Probe> {
    let (ta, tb) = span;
    let n = field.resolution;
    let top = start_level(n, march);
    let mut level = top;
    let mut coarse_end = ta;
    let mut t = ta;
    let radius = |t: f32| (a + d * t).length();
    // A guard against non-progress from rounding: a piece crosses at most
    // 2n texels per level, each visited at most twice on the way up and down.
    let mut budget = 16 * n as usize * (top + 1) + 64;
    while t < tb && budget > 0 {
        budget -= 1;
        let side = n >> level;
        let (ex, ey) = piece.at(t);
        let ix = cell(ex, side, piece.sx);
        let iy = cell(ey, side, piece.sy);
        // Exit of this texel: the first of its edges the ray reaches.
        // The edge the ray leaves by, and how many levels up that edge is
        // still a texel edge: the levels whose texel the ray leaves too.
        let mut exit = tb;
        let mut shared = 0u32;
        for (motion, i, n_coord) in [(piece.sx, ix, piece.nx), (piece.sy, iy, piece.ny)] {
            if motion == 0 {
                continue;
            }
            let next = if motion > 0 { i + 1 } else { i };
            let c = piece.crossing(n_coord, 2.0 * next as f32 / side as f32 - 1.0);
            if c > t {
                let levels = (next as u32).trailing_zeros();
                if c < exit {
                    exit = c;
                    shared = levels;
                } else if c == exit {
                    shared = shared.max(levels);
                }
            }
        }
        let side_texels = (side * side) as usize;
        let index = probe * side_texels + (iy as u32 * side + ix as u32) as usize;
        let lo = field.pyramid[level][index][0];
        let in_front = radius(t).max(radius(exit)) < lo;
        if level > 0 {
            steps.coarse += 1;
            if in_front {
                t = exit;
                level = climb(level, shared, top, march);
            } else if march == March::BiLevel || (at_origin && t == ta) {
                coarse_end = exit;
                level = 0;
            } else {
                level -= 1;
            }
            continue;
        }
        steps.fine += 1;
        if !in_front {
            steps.surfels += 1;
            let q = (a + d * t, a + d * exit);
            match surfel_test(field, probe, ix as u32, iy as u32, q, (t, exit)) {
                Texel::Pass => {}
                Texel::Hit(th) => return Some(Probe::Hit(th)),
                Texel::Behind => return Some(Probe::Unknown(t)),
            }
        }
        t = exit;
        level = match march {
            March::Texel => 0,
            March::BiLevel if t < coarse_end => 0,
            March::BiLevel => top,
            March::HiZ => climb(level, shared, top, march),
        };
    }
    // Out of steps before the end: rounding stalled the march; say so
    // rather than claim a miss.
    (t < tb).then_some(Probe::Unknown(t))
}
