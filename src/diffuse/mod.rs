//! Diffuse light as engines take it from probes: receivers, their
//! path-traced irradiance, each probe's SH L2, and the error of a lookup.
//!
//! Engines use probes mainly for diffuse irradiance (Unity's light probes
//! and Adaptive Probe Volumes, Godot's LightmapGI, DDGI). This stage
//! measures a placement the way they use it, beside the glossy
//! light-field measure of Wang et al. 2019 §5:
//!
//! * **Receivers** ([`receivers`]): surface points the views see (their
//!   primary hits, lifted off the surface, with the normal), and points in
//!   the free space a viewer can reach ([`crate::reachable`]) with random
//!   normals, where dynamic objects take their light.
//! * **Reference irradiance** at each: `E = ∫ L cos dω` by cosine-weighted
//!   path tracing with the bake's transport ([`Renderer::radiance_parts`],
//!   the same light a probe records), in two parts, as engines bake them:
//!   **baked** (what a mixed-lighting probe holds, Unity's Baked Indirect:
//!   emitters and the sky seen directly, and every reflection; not the
//!   point, spot and directional lights' direct light, which a real-time
//!   renderer shades analytically, McGuire et al. 2017 §1) and **total**
//!   (the baked part and those lights' direct light: what a fully baked
//!   probe holds, [`Renderer::delta_arrivals`]).
//! * **Probe SH** ([`bake_sh`]): each probe's incident radiance projected
//!   to SH L2 ([`sh`]), its baked part by rays, the delta lights' direct
//!   light exactly.
//! * **Lookups**: SH blended by tetrahedral interpolation over a Delaunay
//!   tetrahedralization of the valid probes ([`tetrahedra`]; Unity's and
//!   Godot's blend, with probes in solid removed as their validity tests
//!   do), and McGuire's irradiance gather
//!   ([`crate::trace::gather::irradiance_at`]) by the placement's own
//!   selection.
//! * **Errors** ([`Errors`]): per receiver the relative error of the
//!   luminance, against a floor of [`DARK_FLOOR`] of the mean so that black
//!   corners do not dominate, and whether its baked light is 2× too much
//!   or too little (a leak).

pub(crate) mod moves;
pub mod sh;
pub mod tetrahedra;

use crate::render::integrator::Renderer;
use crate::render::lights::luminance;
use crate::render::material::cosine_hemisphere;
use crate::sampling::{fibonacci_sphere, hash2, random_rotation, unit_f32, Sampler};
use glam::Vec3;
use rayon::prelude::*;
pub use sh::{ProbeLight, ProbeSh, ShL2};

/// A receiver's relative error is taken against at least this share of the
/// mean reference luminance of its set: a receiver a hundred times darker
/// than the mean would otherwise weigh a hundred times more for the same
/// absolute error, and noise in its reference would decide the figure.
pub const DARK_FLOOR: f64 = 0.05;

/// A receiver lit this many times too much, or too little, by a lookup
/// counts as a leak (light through a wall, or a probe's shadow spilled).
pub const LEAK_RATIO: f64 = 2.0;

/// The six axes, in the order +x, −x, +y, −y, +z, −z: the normals a
/// point in free space is judged along.
pub const AXES: [Vec3; 6] = [
    Vec3::X,
    Vec3::NEG_X,
    Vec3::Y,
    Vec3::NEG_Y,
    Vec3::Z,
    Vec3::NEG_Z,
];

/// Receivers per group of free-space receivers that the intervals resample
/// as one cluster.
pub const FREE_GROUP: usize = 32;

/// A point that takes light from the probes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Receiver {
    /// Where (lifted off the surface for surface receivers).
    pub p: Vec3,
    /// Unit normal of the surface, or of the imagined object's surface.
    pub n: Vec3,
    /// The cluster the intervals resample it with: its view for surface
    /// receivers, a run of [`FREE_GROUP`] for free ones.
    pub group: u32,
}

/// Irradiance at a receiver, RGB.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Irradiance {
    /// All the light arriving: the baked part and the point, spot and
    /// directional lights' direct light (a fully baked probe's).
    pub total: Vec3,
    /// All but those lights' direct light: what a mixed-lighting probe
    /// holds (Unity's Baked Indirect; module docs).
    pub baked: Vec3,
}

/// The receivers of a comparison with their reference irradiance.
#[derive(Debug, Clone, Default)]
pub struct Receivers {
    /// Surface points the views see.
    pub surface: Vec<Receiver>,
    /// Points in reachable free space.
    pub free: Vec<Receiver>,
    /// Reference at each surface receiver.
    pub surface_reference: Vec<Irradiance>,
    /// Reference at each free receiver.
    pub free_reference: Vec<Irradiance>,
}

/// The surface receivers of one view: `count` of its primary hits
/// (`queries`: lifted point and normal), evenly strided, in pixel order.
pub fn surface_receivers(queries: &[crate::gpu::Query], count: usize, group: u32) -> Vec<Receiver> {
    if queries.is_empty() || count == 0 {
        return Vec::new();
    }
    let take = count.min(queries.len());
    (0..take)
        .map(|k| {
            let q = &queries[k * queries.len() / take];
            Receiver {
                p: Vec3::from(q.origin),
                n: Vec3::from(q.dir),
                group,
            }
        })
        .collect()
}

/// `count` receivers in the reached voxels of `sdf` that keep at least a
/// voxel from every surface, each jittered within its voxel (which keeps
/// it in free space) with a uniformly random normal; drawn from `seed`.
/// Fewer when no voxel qualifies.
pub fn free_receivers(
    sdf: &crate::sdf::Sdf,
    reachable: &crate::reachable::Reachable,
    count: usize,
    seed: u64,
) -> Vec<Receiver> {
    let h = sdf.voxel_size;
    let voxels: Vec<usize> = (0..sdf.len())
        .filter(|&i| reachable.mask[i] && sdf.distance[i] >= h)
        .collect();
    if voxels.is_empty() {
        return Vec::new();
    }
    (0..count as u64)
        .map(|k| {
            let key = hash2(seed, k);
            let v = voxels[(hash2(key, 0) % voxels.len() as u64) as usize];
            let jitter = Vec3::new(
                unit_f32(hash2(key, 1)),
                unit_f32(hash2(key, 2)),
                unit_f32(hash2(key, 3)),
            ) - 0.5;
            Receiver {
                p: sdf.center(v) + jitter * h,
                n: crate::sampling::uniform_direction(key, 4),
                group: (k as usize / FREE_GROUP) as u32,
            }
        })
        .collect()
}

/// Reference irradiance at each receiver: `rays` cosine-weighted paths
/// (stratified on a √rays grid), `E = π/rays · Σ L` for the baked part
/// but the emissive surfaces seen directly, which as many samples of the
/// emitters give instead ([`Renderer::sample_emitter`]: a small lamp
/// that cosine-weighted rays find by chance made a receiver's reference
/// noisier than any placement's error near it), and the delta lights'
/// direct light exactly (one shadow ray each) added for the total.
/// Stream `seed` per receiver index.
///
/// Contract: deterministic whatever the thread count; finite and
/// non-negative; `baked ≤ total` per channel.
pub fn reference(
    renderer: &Renderer,
    receivers: &[Receiver],
    rays: u32,
    seed: u64,
) -> Vec<Irradiance> {
    let side = (rays as f32).sqrt().ceil().max(1.0) as u32;
    let n = side * side;
    let lift = renderer.lights().epsilon();
    receivers
        .par_iter()
        .enumerate()
        .map(|(i, r)| {
            let mut sampler = Sampler::new(seed, i as u64);
            let (mut baked, mut emitted) = (Vec3::ZERO, Vec3::ZERO);
            for k in 0..n {
                let j = sampler.next_2d();
                let u = glam::Vec2::new(
                    ((k % side) as f32 + j.x) / side as f32,
                    ((k / side) as f32 + j.y) / side as f32,
                );
                let d = cosine_hemisphere(r.n, u);
                let (e, l) = renderer.radiance_parts_without_emitters(r.p, d, &mut sampler);
                baked += e + l;
                if let Some((wi, v)) = renderer.sample_emitter(r.p, r.n * lift, &mut sampler) {
                    emitted += v * r.n.dot(wi).max(0.0);
                }
            }
            let baked = clean(baked * (std::f32::consts::PI / n as f32) + emitted / n as f32);
            let mut direct = Vec3::ZERO;
            renderer.delta_arrivals(r.p, r.n * lift, |wi, e| {
                direct += e * r.n.dot(wi).max(0.0);
            });
            Irradiance {
                total: clean(baked + direct).max(baked),
                baked,
            }
        })
        .collect()
}

fn clean(v: Vec3) -> Vec3 {
    if v.is_finite() {
        v.max(Vec3::ZERO)
    } else {
        Vec3::ZERO
    }
}

/// Each probe's incident radiance projected to SH L2 ([`sh`]): its baked
/// and indirect parts from `rays` directions spread evenly over the sphere
/// (the emissive surfaces they would see directly by as many samples of
/// the emitters instead, as [`reference`] takes them)
/// (a spherical Fibonacci set, turned by a rotation drawn from the probe's
/// position and `seed`, so a probe at the same place gets the same rays
/// whatever placement it is part of: common random numbers between
/// placements), and the delta lights' direct light exactly.
///
/// Contract: deterministic whatever the thread count; finite.
pub fn bake_sh(renderer: &Renderer, probes: &[Vec3], rays: u32, seed: u64) -> Vec<ProbeSh> {
    let dirs = fibonacci_sphere(rays.max(1));
    let w = 4.0 * std::f32::consts::PI / dirs.len() as f32;
    probes
        .par_iter()
        .map(|&p| {
            let key = hash2(
                hash2(seed, p.x.to_bits() as u64),
                ((p.y.to_bits() as u64) << 32) | p.z.to_bits() as u64,
            );
            let rot = random_rotation(key);
            let mut sampler = Sampler::new(key, 0x5A);
            let mut out = ProbeSh::default();
            for &d in &dirs {
                let d = rot * d;
                let (e, l) = renderer.radiance_parts_without_emitters(p, d, &mut sampler);
                let (e, l) = (clean(e), clean(l));
                out.baked.add_sample(d, e + l, w);
                out.indirect.add_sample(d, l, w);
            }
            // The emitters seen directly, by sampling them: one sample per
            // direction.
            let share = 1.0 / dirs.len() as f32;
            for _ in 0..dirs.len() {
                if let Some((wi, v)) = renderer.sample_emitter(p, Vec3::ZERO, &mut sampler) {
                    out.baked.add_sample(wi, clean(v), share);
                }
            }
            renderer.delta_arrivals(p, Vec3::ZERO, |wi, e| {
                if e.is_finite() {
                    out.direct.add_sample(wi, e, 1.0);
                }
            });
            out
        })
        .collect()
}

/// Irradiance by SH L2 blended over a Delaunay tetrahedralization of the
/// valid probes, as Unity's light probes and Godot's LightmapGI blend them.
pub struct ShLookup {
    sh: Vec<ProbeSh>,
    blend: Blend,
}

/// How the valid probes' SH are weighted at a point.
enum Blend {
    /// Barycentric over the tetrahedron containing it (or the hull face
    /// nearest it).
    Tetrahedra(tetrahedra::Tetrahedralization),
    /// One probe (or all at one point): its light.
    Nearest(Vec<Vec3>),
    /// No valid probe: black.
    None,
}

impl ShLookup {
    /// The lookup over the probes at `positions` with SH `sh` whose `valid`
    /// flag is set (engines drop probes that stand in geometry).
    ///
    /// Contract: the three slices have the same length.
    pub fn new(positions: &[Vec3], sh: &[ProbeSh], valid: &[bool]) -> ShLookup {
        let keep: Vec<usize> = (0..positions.len()).filter(|&i| valid[i]).collect();
        let points: Vec<Vec3> = keep.iter().map(|&i| positions[i]).collect();
        let sh: Vec<ProbeSh> = keep.iter().map(|&i| sh[i]).collect();
        let blend = if points.is_empty() {
            Blend::None
        } else {
            match tetrahedra::Tetrahedralization::spanning(&points) {
                Some(t) => Blend::Tetrahedra(t),
                None => Blend::Nearest(points),
            }
        };
        ShLookup { sh, blend }
    }

    /// Irradiance at `r`, total and baked, clamped at zero (SH ringing).
    pub fn irradiance(&self, r: &Receiver) -> Irradiance {
        self.irradiance_inside(r).0
    }

    /// [`ShLookup::irradiance`], and whether `r` lies in a tetrahedron of
    /// the blend (false outside the hull, and for blends of fewer than
    /// four probes that span space).
    pub(crate) fn irradiance_inside(&self, r: &Receiver) -> (Irradiance, bool) {
        let (weights, inside): ([(u32, f32); 4], bool) = match &self.blend {
            Blend::None => return (Irradiance::default(), false),
            Blend::Tetrahedra(t) => t.blend_at(r.p),
            Blend::Nearest(points) => {
                let i = (0..points.len())
                    .min_by(|&a, &b| {
                        points[a]
                            .distance_squared(r.p)
                            .total_cmp(&points[b].distance_squared(r.p))
                    })
                    .unwrap_or(0) as u32;
                ([(i, 1.0), (i, 0.0), (i, 0.0), (i, 0.0)], false)
            }
        };
        (blend_irradiance(&self.sh, &weights, r.n), inside)
    }
}

/// The irradiance along `n` of the probes' SH `sh` blended by `weights`,
/// total and baked, clamped at zero (SH ringing).
pub(crate) fn blend_irradiance(sh: &[ProbeSh], weights: &[(u32, f32); 4], n: Vec3) -> Irradiance {
    let mix = |f: fn(&ProbeSh) -> &ShL2| {
        ShL2::blend(weights.iter().map(|&(i, w)| (f(&sh[i as usize]), w))).irradiance(n)
    };
    let baked = clean(mix(|s| &s.baked));
    let direct = mix(|s| &s.direct);
    Irradiance {
        total: clean(baked + direct),
        baked,
    }
}

/// The floor of the relative error over a set of reference irradiances:
/// [`DARK_FLOOR`] of their mean luminance (at least 1e-12, so that a dark
/// set divides by no zero).
pub fn dark_floor(reference: impl IntoIterator<Item = Vec3>) -> f64 {
    let (sum, n) = reference.into_iter().fold((0.0f64, 0usize), |(s, n), e| {
        (s + luminance(e) as f64, n + 1)
    });
    (DARK_FLOOR * sum / n.max(1) as f64).max(1e-12)
}

/// Whether a receiver lit `got` where `want` is its reference is lit
/// [`LEAK_RATIO`] times too much or too little, both sides floored at
/// `floor` (a dark corner's noise is no leak).
pub fn leaks(got: Vec3, want: Vec3, floor: f64) -> bool {
    let ratio = (luminance(got) as f64).max(floor) / (luminance(want) as f64).max(floor);
    ratio >= LEAK_RATIO || ratio <= 1.0 / LEAK_RATIO
}

/// `|L(got) − L(want)| / max(L(want), floor)` in luminance: a receiver's
/// relative error against its reference (module docs).
pub fn relative_error(got: Vec3, want: Vec3, floor: f64) -> f64 {
    (luminance(got) as f64 - luminance(want) as f64).abs() / (luminance(want) as f64).max(floor)
}

/// One lookup's errors at every receiver of one set (surface or free).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Errors {
    /// Relative error of the total irradiance's luminance per receiver.
    pub total: Vec<f64>,
    /// The same for the baked part (what a mixed-lighting probe holds).
    pub baked: Vec<f64>,
    /// 1 where the receiver's baked light is off by [`LEAK_RATIO`] or
    /// more, either way, else 0.
    pub leak: Vec<f64>,
    /// Each receiver's group.
    pub group: Vec<u32>,
}

impl Errors {
    /// `got` against `reference` at `receivers` (module docs).
    ///
    /// Contract: the three slices have the same length.
    pub fn measure(receivers: &[Receiver], reference: &[Irradiance], got: &[Irradiance]) -> Errors {
        let ft = dark_floor(reference.iter().map(|e| e.total));
        let fb = dark_floor(reference.iter().map(|e| e.baked));
        let mut out = Errors::default();
        for ((r, want), g) in receivers.iter().zip(reference).zip(got) {
            out.total.push(relative_error(g.total, want.total, ft));
            out.baked.push(relative_error(g.baked, want.baked, fb));
            out.leak.push(leaks(g.baked, want.baked, fb) as u8 as f64);
            out.group.push(r.group);
        }
        out
    }

    /// `values` split by group, in group order (the clusters of
    /// [`crate::stats::paired_ratio_over_views`]).
    pub fn by_group(&self, values: &[f64]) -> Vec<Vec<f64>> {
        let groups = self
            .group
            .iter()
            .map(|&g| g as usize + 1)
            .max()
            .unwrap_or(0);
        let mut out = vec![Vec::new(); groups];
        for (&g, &v) in self.group.iter().zip(values) {
            out[g as usize].push(v);
        }
        out.retain(|g| !g.is_empty());
        out
    }
}

/// Mean of `v`, `None` when empty.
pub fn mean(v: &[f64]) -> Option<f64> {
    (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::{Light, Point3, Rgb};
    use crate::scene::raycast::SceneBvh;
    use crate::scene::testing::room_with_box;

    /// The 4 m room with its box, lit by a point light near the ceiling
    /// and an emissive square on the ceiling (so that both the indirect
    /// part and emitters seen directly count).
    fn lit_room() -> (crate::scene::Scene, SceneBvh, Vec<Light>) {
        let mut scene = room_with_box();
        let mut lamp = crate::scene::Material::fallback();
        lamp.emission = [4.0, 4.0, 4.0];
        let id = scene.materials.len() as u32;
        scene.materials.push(lamp);
        let y = 3.99;
        let (a, b) = (1.5, 2.5);
        for t in [
            [Vec3::new(a, y, a), Vec3::new(b, y, a), Vec3::new(b, y, b)],
            [Vec3::new(a, y, a), Vec3::new(b, y, b), Vec3::new(a, y, b)],
        ] {
            scene.triangles.push(t);
            scene.normals.push(Vec3::NEG_Y);
            scene.material_ids.push(id);
        }
        let bvh = SceneBvh::new(&scene);
        let light = Light::Point {
            position: Point3([3.0, 3.5, 3.0]),
            intensity: Rgb([20.0, 20.0, 20.0]),
        };
        (scene, bvh, vec![light])
    }

    #[test]
    fn a_probe_under_a_uniform_sky_gives_unitys_ambient_coefficients() {
        // One known light, the published answer: a probe that sees only a
        // sky of radiance L has Unity coefficients [L, 0, …] (what
        // SphericalHarmonicsL2.AddAmbientLight(L) holds) and irradiance πL
        // facing any way. The scene is one small triangle far below.
        let scene = crate::scene::Scene::from_triangles(
            "speck".into(),
            [(
                [
                    Vec3::new(0.0, -100.0, 0.0),
                    Vec3::new(0.01, -100.0, 0.0),
                    Vec3::new(0.0, -100.0, 0.01),
                ],
                0,
            )],
            vec![crate::scene::Material::fallback()],
        )
        .unwrap();
        let bvh = SceneBvh::new(&scene);
        let sky = [Light::Sky {
            radiance: Rgb([0.25, 0.5, 1.0]),
        }];
        let r = Renderer::new(&scene, &bvh, &sky, 2);
        let sh = bake_sh(&r, &[Vec3::ZERO], 1024, 3)[0];
        let u = sh.baked.unity_coefficients();
        for (c, want) in [0.25f32, 0.5, 1.0].into_iter().enumerate() {
            assert!((u[c][0] - want).abs() < 1e-3 * want, "{:?}", u[c]);
            assert!(
                u[c][1..].iter().all(|v| v.abs() < 1e-3 * want),
                "{:?}",
                u[c]
            );
        }
        assert_eq!(sh.indirect, ShL2::ZERO, "nothing reflects");
        assert_eq!(sh.direct, ShL2::ZERO, "no point, spot or directional light");
        let e = sh.baked.irradiance(Vec3::new(0.6, 0.0, 0.8));
        assert!((e.z - std::f32::consts::PI).abs() < 2e-3, "{e}");
    }

    #[test]
    fn a_probe_at_a_receiver_reproduces_its_reference() {
        // The probe's SH, evaluated at the receiver's own normal, is the
        // receiver's irradiance up to L2's truncation and noise: the bake,
        // the projection and the reference measure the same light.
        let (scene, bvh, lights) = lit_room();
        let r = Renderer::new(&scene, &bvh, &lights, 2);
        let receivers: Vec<Receiver> = [
            (Vec3::new(3.0, 1.5, 3.0), Vec3::Y),
            (Vec3::new(0.5, 2.0, 3.0), Vec3::X),
            (Vec3::new(3.2, 0.6, 0.8), Vec3::new(0.0, 0.6, 0.8)),
            (Vec3::new(2.5, 3.0, 1.0), Vec3::NEG_Y),
        ]
        .iter()
        .map(|&(p, n)| Receiver { p, n, group: 0 })
        .collect();
        let reference = reference(&r, &receivers, 4096, 9);
        for (x, want) in receivers.iter().zip(&reference) {
            assert!(luminance(want.baked) > 0.0);
            // The point light at (3, 3.5, 3) is above the first three
            // receivers (the second sees it at a slant): its direct light
            // is in the total, not in the baked part.
            if x.n != Vec3::NEG_Y {
                assert!(luminance(want.total) > 1.05 * luminance(want.baked), "{x:?}: {want:?}");
            } else {
                assert_eq!(want.total, want.baked, "facing away from the light");
            }
            let sh = bake_sh(&r, &[x.p], 4096, 3);
            let lookup = ShLookup::new(&[x.p], &sh, &[true]);
            let got = lookup.irradiance(x);
            for (g, w) in [(got.total, want.total), (got.baked, want.baked)] {
                let rel = (luminance(g) - luminance(w)).abs() / luminance(w);
                assert!(rel < 0.12, "{x:?}: {g} vs {w} ({rel:.3})");
            }
        }
        // Facing up beside the lamp, the emitter seen directly is baked
        // light: more than the reflected part alone.
        let up = bake_sh(&r, &[receivers[0].p], 4096, 3)[0];
        let reflected = luminance(up.indirect.irradiance(Vec3::Y));
        assert!(luminance(up.baked.irradiance(Vec3::Y)) > 1.02 * reflected);
    }

    #[test]
    fn errors_and_leaks_follow_their_definitions() {
        let rs: Vec<Receiver> = (0..4)
            .map(|i| Receiver {
                p: Vec3::ZERO,
                n: Vec3::Y,
                group: i / 2,
            })
            .collect();
        let e = |v: f32| Irradiance {
            total: Vec3::splat(v),
            baked: Vec3::splat(v / 2.0),
        };
        let reference = [e(1.0), e(1.0), e(1.0), e(1.0)];
        let got = [e(1.0), e(1.5), e(2.0), e(0.25)];
        let m = Errors::measure(&rs, &reference, &got);
        assert_eq!(m.total.len(), 4);
        for errors in [&m.total, &m.baked] {
            for (a, b) in errors.iter().zip([0.0, 0.5, 1.0, 0.75]) {
                assert!((a - b).abs() < 1e-5, "{errors:?}");
            }
        }
        assert_eq!(m.leak, vec![0.0, 0.0, 1.0, 1.0]);
        assert_eq!(m.by_group(&m.leak), vec![vec![0.0, 0.0], vec![1.0, 1.0]]);
        // A black reference is measured against the floor, not divided by 0.
        let dark = [e(0.0), e(1.0), e(1.0), e(1.0)];
        let m = Errors::measure(&rs, &dark, &[e(0.0); 4]);
        assert!(m.total.iter().chain(&m.baked).all(|x| x.is_finite()));
        // Leaks are judged on the baked light: lit 2× too much there, with
        // the total right, is a leak.
        let odd = Irradiance {
            total: Vec3::ONE,
            baked: Vec3::ONE,
        };
        let m = Errors::measure(&rs[..1], &[e(1.0)], &[odd]);
        assert_eq!(m.leak, vec![1.0]);
    }

    #[test]
    fn free_receivers_stand_in_reached_free_space() {
        let (scene, bvh, _) = lit_room();
        let (_, sdf) = crate::scene::testing::bvh_and_sdf(&scene, 0.25, 1);
        let reach = crate::reachable::reachable(&sdf, &bvh, &[Vec3::new(3.0, 2.0, 3.0)], 0.0);
        let rs = free_receivers(&sdf, &reach, 200, 4);
        assert_eq!(rs.len(), 200);
        for r in &rs {
            assert!(reach.contains(&sdf, r.p), "{r:?}");
            assert!(crate::coverage::stands_free(&bvh, sdf.voxel_size, r.p));
            assert!((r.n.length() - 1.0).abs() < 1e-4);
        }
        assert_eq!(rs, free_receivers(&sdf, &reach, 200, 4));
    }
}
