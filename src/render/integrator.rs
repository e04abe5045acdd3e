//! The path-tracing integrator: radiance along a ray, and its split into the
//! full image and the glossy indirect component for reference renders.
//!
//! Design, and why:
//!
//! * **Next-event estimation only, no MIS.** Every vertex estimates direct
//!   light by sampling the lights ([`LightSet::direct`]); rays drawn from the
//!   BSDF never add the emission (or sky) they happen to hit. Each light path
//!   is therefore counted exactly once, by the vertex before the light (the
//!   one exception: emission seen directly from the ray's origin is added at
//!   the first surface), and "direct" and "indirect" stay cleanly separated,
//!   which the glossy indirect split (Wang et al. 2019 §5.1) relies on. The
//!   price is noise on very sharp glossy reflections of small lights, and on
//!   light reflected by glossy surfaces onto diffuse ones, which MIS (or
//!   photon mapping) would reduce. Surfaces right beside an emitter, where
//!   light sampling by area has no bound, are sampled by solid angle
//!   instead ([`super::lights`]), which MIS would otherwise be needed for.
//! * **Fixed path length, no Russian roulette.** A path has exactly
//!   `1 + bounces` vertices (fewer only when it escapes or meets a black
//!   surface), so the cost of a probe texel is predictable and the estimate
//!   is the exact `bounces`-truncated solution, as the bake's configuration
//!   promises (`bounces: 0` is direct light only).
//! * **One lobe per bounce**, chosen with probability proportional to its
//!   albedo weight ([`Bsdf::diffuse_probability`]) and divided by that
//!   probability, which keeps the estimator unbiased at one ray per bounce.
//! * **Allocation-free.** [`Renderer::radiance`] is what the probe bake calls
//!   for every texel: it touches only the stack and the prebuilt tables.

use super::lights::LightSet;
use super::material::{shading_normal, Bsdf};
use crate::config::Light;
use crate::sampling::Sampler;
use crate::scene::raycast::SceneBvh;
use crate::scene::Scene;
use glam::Vec3;

/// A reference-render sample: the full radiance and its glossy indirect part.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Split {
    /// Emission + direct + diffuse indirect + glossy indirect.
    pub full: Vec3,
    /// Indirect light reflected by the first surface's glossy lobe only
    /// (Wang et al. 2019 §5.1's error measure).
    pub glossy_indirect: Vec3,
}

/// Emitted radiance from a material's (or a texel's) `Ke`: negative or
/// non-finite components count as 0.
fn emission_of(ke: [f32; 3]) -> Vec3 {
    Vec3::from(ke.map(|v| if v.is_finite() { v.max(0.0) } else { 0.0 }))
}

/// Which lobe a bounce follows.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Lobe {
    /// One lobe, chosen by albedo.
    Either,
    Diffuse,
    Glossy,
}

/// A surface point seen along a ray.
#[derive(Debug, Clone, Copy)]
pub struct Vertex {
    /// The point.
    pub p: Vec3,
    /// Shading normal, facing `wo`.
    pub n: Vec3,
    /// Direction back along the ray.
    pub wo: Vec3,
    /// Index into the scene's materials.
    pub material: usize,
    /// The BSDF here: the material's, its diffuse albedo times its colour
    /// texture's texel where it has one ([`crate::scene::texture`]).
    pub bsdf: Bsdf,
    /// The emitted radiance here: `Ke`, times its emission texture's texel
    /// where it has one.
    pub emission: Vec3,
}

/// A path tracer over one scene (module docs).
pub struct Renderer<'a> {
    scene: &'a Scene,
    bvh: &'a SceneBvh,
    lights: LightSet,
    bsdfs: Vec<Bsdf>,
    emission: Vec<Vec3>,
    bounces: u32,
}

impl<'a> Renderer<'a> {
    /// A renderer for `scene` (whose BVH is `bvh`) lit by its emissive
    /// triangles and `lights`, following `bounces` indirect bounces after the
    /// first surface (0: emission and direct light only).
    pub fn new(
        scene: &'a Scene,
        bvh: &'a SceneBvh,
        lights: &[Light],
        bounces: u32,
    ) -> Renderer<'a> {
        let emission = scene.materials.iter().map(|m| emission_of(m.emission)).collect();
        Renderer {
            scene,
            bvh,
            lights: LightSet::new(scene, lights),
            bsdfs: scene.materials.iter().map(Bsdf::from_material).collect(),
            emission,
            bounces,
        }
    }

    /// The scene it renders.
    pub fn scene(&self) -> &'a Scene {
        self.scene
    }

    /// The lights this renderer samples.
    pub fn lights(&self) -> &LightSet {
        &self.lights
    }

    /// Indirect bounces after the first surface.
    pub fn bounces(&self) -> u32 {
        self.bounces
    }

    /// Direct light at `v` from the point, spot and directional lights only
    /// ([`LightSet::direct_delta`]): what a real-time renderer shades
    /// analytically, leaving emissive surfaces and the sky to its probes.
    pub fn direct_delta(&self, v: &Vertex) -> Vec3 {
        self.lights
            .direct_delta(self.bvh, v.p, v.n, v.wo, &v.bsdf)
    }

    /// One sample of the emissive triangles' light arriving at `p`
    /// ([`LightSet::sample_emitter`]), shadow ray from `p + offset`.
    pub fn sample_emitter(&self, p: Vec3, offset: Vec3, sampler: &mut Sampler) -> Option<(Vec3, Vec3)> {
        self.lights.sample_emitter(self.bvh, p, offset, sampler)
    }

    /// [`Renderer::radiance_parts`] with the emission of an emissive
    /// surface hit left out of the first part (the sky kept): for an
    /// estimate that takes the emitters' light by sampling them
    /// ([`Renderer::sample_emitter`]) instead, each light counted once.
    ///
    /// Contract: as [`Renderer::radiance_parts`], drawing the same samples.
    pub fn radiance_parts_without_emitters(
        &self,
        origin: Vec3,
        dir: Vec3,
        sampler: &mut Sampler,
    ) -> (Vec3, Vec3) {
        self.parts(origin, dir, false, sampler)
    }

    /// The point, spot and directional lights' light arriving at `p`
    /// ([`LightSet::delta_arrivals`]), shadow rays from `p + offset`.
    pub fn delta_arrivals(&self, p: Vec3, offset: Vec3, arrive: impl FnMut(Vec3, Vec3)) {
        self.lights.delta_arrivals(self.bvh, p, offset, arrive)
    }

    /// One path sample of the radiance arriving at `origin` from direction
    /// `dir`, i.e. leaving the first surface hit along `origin + t·dir`
    /// towards `origin`: its emission `Ke` (both sides), the direct light
    /// there, and up to [`Renderer::bounces`] indirect bounces. A ray that
    /// escapes sees the sky (black without a sky light).
    ///
    /// Contract: `dir` unit. Unbiased for the `bounces`-truncated radiance;
    /// deterministic given the sampler's state; allocation-free.
    pub fn radiance(&self, origin: Vec3, dir: Vec3, sampler: &mut Sampler) -> Vec3 {
        let (emitted, reflected) = self.radiance_parts(origin, dir, sampler);
        emitted + reflected
    }

    /// [`Renderer::radiance`] in two parts: what the first surface emits
    /// (or the sky, when the ray escapes), and what it reflects (direct
    /// light there and the bounces). The second is the indirect light a
    /// point at `origin` receives from that direction; the diffuse
    /// evaluation ([`crate::diffuse`]) scores probes on it apart.
    ///
    /// Contract: as [`Renderer::radiance`], whose value is the sum, from
    /// the same sampler draws.
    pub fn radiance_parts(&self, origin: Vec3, dir: Vec3, sampler: &mut Sampler) -> (Vec3, Vec3) {
        self.parts(origin, dir, true, sampler)
    }

    /// [`Renderer::radiance_parts`], the first surface's emission counted
    /// when `emitters`.
    fn parts(&self, origin: Vec3, dir: Vec3, emitters: bool, sampler: &mut Sampler) -> (Vec3, Vec3) {
        let Some(v) = self.intersect(origin, dir) else {
            return (self.lights.sky(), Vec3::ZERO);
        };
        let mut reflected = self.direct(&v, sampler);
        if self.bounces > 0 {
            if let Some((wi, weight)) = self.sample_lobe(&v, Lobe::Either, sampler) {
                reflected += self.trace(self.spawn(&v), wi, weight, self.bounces, sampler);
            }
        }
        (if emitters { v.emission } else { Vec3::ZERO }, reflected)
    }

    /// One sample of a camera ray's radiance, split as Wang et al. 2019 §5.1
    /// and McGuire et al. 2017 §5.1 do: at the first surface, direct light is
    /// estimated as in [`Renderer::radiance`], then the diffuse lobe and the
    /// glossy lobe are each sampled once (not one chosen by albedo), and each
    /// path continues for `bounces − 1` further bounces. `glossy_indirect` is
    /// thereby an unbiased estimate of the light the glossy lobe reflects
    /// from other surfaces: the glossy bounce, plus the glossy part of the
    /// area lights' direct light ([`LightSet::direct_split`]), which is what
    /// a probe-traced glossy ray returns. Delta lights and the sky stay
    /// direct light. `full` adds emission, direct and diffuse indirect.
    ///
    /// Contract: as [`Renderer::radiance`]; `glossy_indirect` is exactly 0
    /// where the first surface has no glossy lobe, and `full` has the same
    /// expectation as [`Renderer::radiance`].
    pub fn radiance_split(&self, origin: Vec3, dir: Vec3, sampler: &mut Sampler) -> Split {
        let Some(v) = self.intersect(origin, dir) else {
            return Split {
                full: self.lights.sky(),
                glossy_indirect: Vec3::ZERO,
            };
        };
        let (direct, area_glossy) =
            self.lights
                .direct_split(self.bvh, v.p, v.n, v.wo, &v.bsdf, sampler);
        let mut full = v.emission + direct;
        let mut glossy_indirect = area_glossy;
        if self.bounces > 0 {
            let start = self.spawn(&v);
            if let Some((wi, weight)) = self.sample_lobe(&v, Lobe::Diffuse, sampler) {
                full += self.trace(start, wi, weight, self.bounces, sampler);
            }
            if let Some((wi, weight)) = self.sample_lobe(&v, Lobe::Glossy, sampler) {
                let reflected = self.trace(start, wi, weight, self.bounces, sampler);
                glossy_indirect += reflected;
                full += reflected;
            }
        }
        Split {
            full,
            glossy_indirect,
        }
    }

    /// The light carried back along a path that leaves `origin` along `dir`
    /// with throughput `throughput`: direct light at each of up to `vertices`
    /// further surfaces, bouncing between them by one albedo-chosen lobe.
    fn trace(
        &self,
        mut origin: Vec3,
        mut dir: Vec3,
        mut throughput: Vec3,
        vertices: u32,
        sampler: &mut Sampler,
    ) -> Vec3 {
        let mut l = Vec3::ZERO;
        for k in 0..vertices {
            let Some(v) = self.intersect(origin, dir) else {
                break;
            };
            l += throughput * self.direct(&v, sampler);
            if k + 1 == vertices {
                break;
            }
            let Some((wi, weight)) = self.sample_lobe(&v, Lobe::Either, sampler) else {
                break;
            };
            throughput *= weight;
            origin = self.spawn(&v);
            dir = wi;
        }
        l
    }

    /// The first surface along `origin + t·dir`, t ≥ 0.
    pub fn intersect(&self, origin: Vec3, dir: Vec3) -> Option<Vertex> {
        let hit = self.bvh.closest_hit(origin, dir, 0.0, f32::INFINITY)?;
        let tri = hit.triangle as usize;
        let wo = -dir;
        let p = origin + dir * hit.t;
        let material = self.scene.material_ids[tri] as usize;
        let m = &self.scene.materials[material];
        let (bsdf, emission) = if m.is_textured() {
            let uv = self.scene.texcoord_at(tri, p);
            let (kd, ks, ns) = self.scene.colours_at(m, uv);
            (
                Bsdf::from_colours(kd, ks, ns),
                emission_of(self.scene.emission_at(m, uv)),
            )
        } else {
            (self.bsdfs[material], self.emission[material])
        };
        Some(Vertex {
            p,
            n: shading_normal(self.scene.normals[tri], wo),
            wo,
            material,
            bsdf,
            emission,
        })
    }

    /// Origin of rays leaving `v` on its shading side, lifted off the surface.
    pub fn spawn(&self, v: &Vertex) -> Vec3 {
        v.p + v.n * self.lights.epsilon()
    }

    fn direct(&self, v: &Vertex, sampler: &mut Sampler) -> Vec3 {
        self.lights
            .direct(self.bvh, v.p, v.n, v.wo, &v.bsdf, sampler)
    }

    /// A bounce direction at `v` and the throughput factor it carries
    /// (`f cos / pdf`, divided by the lobe's selection probability for
    /// [`Lobe::Either`]). Draws three values from `sampler` whatever the
    /// outcome, so that later draws do not depend on which lobe was taken.
    fn sample_lobe(&self, v: &Vertex, lobe: Lobe, sampler: &mut Sampler) -> Option<(Vec3, Vec3)> {
        let bsdf = &v.bsdf;
        let choice = sampler.next_f32();
        let u = sampler.next_2d();
        let (diffuse, scale) = match lobe {
            Lobe::Diffuse => (true, 1.0),
            Lobe::Glossy => (false, 1.0),
            Lobe::Either => {
                let pd = bsdf.diffuse_probability;
                if choice < pd {
                    (true, 1.0 / pd)
                } else {
                    (false, 1.0 / (1.0 - pd))
                }
            }
        };
        let sample = if diffuse {
            bsdf.sample_diffuse(v.n, v.wo, u)
        } else {
            bsdf.sample_glossy(v.n, v.wo, u)
        }?;
        Some((sample.wi, sample.weight * scale))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::{Point3, Rgb, UpAxis};
    use crate::scene::Material;
    use std::f32::consts::PI;

    fn matte(kd: f32, ke: f32) -> Material {
        Material {
            name: "matte".into(),
            diffuse: [kd; 3],
            specular: [0.0; 3],
            shininess: 1.0,
            emission: [ke; 3],
            diffuse_map: None,
            emission_map: None,
            metal_rough: None,
            cutout: None,
        }
    }

    /// The square y = 0, |x|, |z| ≤ `s`, as two triangles facing up.
    fn floor(s: f32) -> [[Vec3; 3]; 2] {
        [
            [
                Vec3::new(-s, 0.0, -s),
                Vec3::new(-s, 0.0, s),
                Vec3::new(s, 0.0, s),
            ],
            [
                Vec3::new(-s, 0.0, -s),
                Vec3::new(s, 0.0, s),
                Vec3::new(s, 0.0, -s),
            ],
        ]
    }

    /// A point light above a large diffuse floor: direct radiance is
    /// `Kd/π · I cos θ / d²` exactly.
    #[test]
    fn point_light_on_a_floor_matches_the_analytic_radiance() {
        let floor = floor(100.0).map(|t| (t, 0));
        let scene = Scene::from_triangles("floor".into(), floor, vec![matte(0.6, 0.0)]).unwrap();
        let bvh = SceneBvh::new(&scene);
        let light = Light::Point {
            position: Point3([1.0, 2.0, 0.5]),
            intensity: Rgb([10.0, 5.0, 2.0]),
        };
        for bounces in [0, 2] {
            let r = Renderer::new(&scene, &bvh, &[light], bounces);
            let eye = Vec3::new(-1.0, 1.5, -2.0);
            let target = Vec3::new(0.3, 0.0, 0.2);
            let dir = (target - eye).normalize();
            let got = r.radiance(eye, dir, &mut Sampler::new(1, 0));
            let to_light = Vec3::new(1.0, 2.0, 0.5) - target;
            let d2 = to_light.length_squared();
            let cos = to_light.y / d2.sqrt();
            let want = Vec3::new(10.0, 5.0, 2.0) * (0.6 / PI * cos / d2);
            assert!(
                ((got - want) / want).abs().max_element() < 0.01,
                "bounces {bounces}: {got} vs {want}"
            );
        }
    }

    /// An icosphere subdivided `levels` times, radius `r`.
    fn icosphere(levels: u32, r: f32) -> Vec<[Vec3; 3]> {
        let t = (1.0 + 5f32.sqrt()) / 2.0;
        let v = [
            [-1.0, t, 0.0],
            [1.0, t, 0.0],
            [-1.0, -t, 0.0],
            [1.0, -t, 0.0],
            [0.0, -1.0, t],
            [0.0, 1.0, t],
            [0.0, -1.0, -t],
            [0.0, 1.0, -t],
            [t, 0.0, -1.0],
            [t, 0.0, 1.0],
            [-t, 0.0, -1.0],
            [-t, 0.0, 1.0],
        ]
        .map(|p| Vec3::from(p).normalize());
        let faces = [
            [0, 11, 5],
            [0, 5, 1],
            [0, 1, 7],
            [0, 7, 10],
            [0, 10, 11],
            [1, 5, 9],
            [5, 11, 4],
            [11, 10, 2],
            [10, 7, 6],
            [7, 1, 8],
            [3, 9, 4],
            [3, 4, 2],
            [3, 2, 6],
            [3, 6, 8],
            [3, 8, 9],
            [4, 9, 5],
            [2, 4, 11],
            [6, 2, 10],
            [8, 6, 7],
            [9, 8, 1],
        ];
        let mut tris: Vec<[Vec3; 3]> = faces.iter().map(|f| f.map(|i| v[i])).collect();
        for _ in 0..levels {
            tris = tris
                .iter()
                .flat_map(|&[a, b, c]| {
                    let (ab, bc, ca) = (
                        (a + b).normalize(),
                        (b + c).normalize(),
                        (c + a).normalize(),
                    );
                    [[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]]
                })
                .collect();
        }
        tris.iter().map(|t| t.map(|p| p * r)).collect()
    }

    /// Furnace: inside a closed cavity whose walls all emit `Le` and reflect
    /// diffusely with albedo `a`, each vertex adds `a` times the last one's
    /// light, so with `b` bounces the radiance is
    /// `Le (1 + a + … + a^(b+1)) = Le (1 − a^(b+2)) / (1 − a)` (emission,
    /// direct light, then `b` indirect bounces).
    #[test]
    fn closed_emitting_cavity_matches_the_geometric_series() {
        let (le, a) = (0.7f32, 0.8f32);
        let scene = Scene::from_triangles(
            "sphere".into(),
            icosphere(3, 2.0).into_iter().map(|t| (t, 0)),
            vec![matte(a, le)],
        )
        .unwrap();
        let bvh = SceneBvh::new(&scene);
        for bounces in [0u32, 1, 4] {
            let r = Renderer::new(&scene, &bvh, &[], bounces);
            let n = 4000u64;
            let sum: f64 = (0..n)
                .map(|i| {
                    let mut s = Sampler::new(9, i);
                    let d = crate::render::material::cosine_hemisphere(
                        Vec3::new(0.2, 0.9, 0.3).normalize(),
                        s.next_2d(),
                    );
                    let origin = Vec3::new(0.3, -0.2, 0.5);
                    r.radiance(origin, d, &mut s).x as f64
                })
                .sum();
            let got = sum / n as f64;
            let want = le as f64 * (1.0 - (a as f64).powi(bounces as i32 + 2)) / (1.0 - a as f64);
            assert!(
                (got / want - 1.0).abs() < 0.01,
                "bounces {bounces}: {got} vs {want}"
            );
        }
    }

    /// Two estimators of the same direct light on the Cornell fixture's floor:
    /// next-event estimation of the area light, and brute-force cosine
    /// sampling of the hemisphere that adds the emission it hits.
    #[test]
    fn area_light_sampling_agrees_with_brute_force_emission() {
        let path =
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/cornell_box.obj");
        let scene = crate::scene::load_obj(&path, 0.001, UpAxis::Y).unwrap();
        let bvh = SceneBvh::new(&scene);
        let r = Renderer::new(&scene, &bvh, &[], 0);
        assert_eq!(r.lights().area_light_count(), 2);
        for floor in [
            glam::DVec3::new(0.28, 0.0, 0.28),
            glam::DVec3::new(0.1, 0.0, 0.45),
        ] {
            let floor = scene.to_local(floor);
            let eye = floor + Vec3::new(0.01, 0.2, -0.15);
            let dir = (floor - eye).normalize();
            let v = r.intersect(eye, dir).unwrap();
            assert!(scene.to_world(v.p).y.abs() < 1e-4 && v.n.y > 0.99);
            // The light covers about 1.5% of the floor's cosine-weighted
            // hemisphere: brute force needs far more samples for 1% noise.
            let (n_nee, n_brute) = (100_000u64, 2_000_000u64);
            let mut nee = Vec3::ZERO.as_dvec3();
            for i in 0..n_nee {
                nee += r.direct(&v, &mut Sampler::new(5, i)).as_dvec3();
            }
            let mut brute = Vec3::ZERO.as_dvec3();
            let bsdf = &v.bsdf;
            let mut s = Sampler::new(6, 0);
            for _ in 0..n_brute {
                let sample = bsdf.sample_diffuse(v.n, v.wo, s.next_2d()).unwrap();
                if let Some(hit) = r.intersect(r.spawn(&v), sample.wi) {
                    brute += (sample.weight * hit.emission).as_dvec3();
                }
            }
            let (nee, brute) = (nee / n_nee as f64, brute / n_brute as f64);
            assert!(nee.x > 0.01, "{nee}");
            assert!(
                ((nee - brute) / nee).abs().max_element() < 0.03,
                "at {floor}: NEE {nee} vs brute force {brute}"
            );
        }
    }

    /// Area lights emit from both sides: a floor under an emitter lights up
    /// the same whichever way the emitter is wound.
    #[test]
    fn emitters_shine_from_both_sides() {
        let floor = floor(50.0);
        let down = [
            Vec3::new(-0.5, 1.0, -0.5),
            Vec3::new(0.5, 1.0, 0.5),
            Vec3::new(-0.5, 1.0, 0.5),
        ];
        let up = [down[0], down[2], down[1]];
        let radiance_below = |emitter: [Vec3; 3]| {
            let scene = Scene::from_triangles(
                "t".into(),
                [(floor[0], 0), (floor[1], 0), (emitter, 1)],
                vec![matte(0.5, 0.0), matte(0.0, 2.0)],
            )
            .unwrap();
            let bvh = SceneBvh::new(&scene);
            let r = Renderer::new(&scene, &bvh, &[], 0);
            let eye = Vec3::new(0.1, 0.5, -1.0);
            let dir = (Vec3::new(0.0, 0.0, 0.1) - eye).normalize();
            (0..20_000u64)
                .map(|i| r.radiance(eye, dir, &mut Sampler::new(3, i)).x as f64)
                .sum::<f64>()
                / 20_000.0
        };
        let (a, b) = (radiance_below(down), radiance_below(up));
        // The sampled points differ with the vertex order, so the estimates
        // agree statistically, not bit for bit.
        assert!(a > 0.01, "{a}");
        assert!((a / b - 1.0).abs() < 0.01, "wound down {a}, wound up {b}");
    }

    /// An emitter seen in a glossy floor is glossy indirect light in the
    /// split, as it is for a probe-traced glossy ray: its mean equals the
    /// emission met by rays drawn from the glossy lobe alone.
    #[test]
    fn split_counts_emitters_seen_in_the_glossy_lobe() {
        let floor = floor(50.0);
        let quad = [
            [
                Vec3::new(-1.0, 1.0, -1.0),
                Vec3::new(1.0, 1.0, 1.0),
                Vec3::new(-1.0, 1.0, 1.0),
            ],
            [
                Vec3::new(-1.0, 1.0, -1.0),
                Vec3::new(1.0, 1.0, -1.0),
                Vec3::new(1.0, 1.0, 1.0),
            ],
        ];
        let polished = Material {
            name: "polished".into(),
            diffuse: [0.2; 3],
            specular: [0.5; 3],
            shininess: 50.0,
            emission: [0.0; 3],
            diffuse_map: None,
            emission_map: None,
            metal_rough: None,
            cutout: None,
        };
        let scene = Scene::from_triangles(
            "t".into(),
            [(floor[0], 0), (floor[1], 0), (quad[0], 1), (quad[1], 1)],
            vec![polished, matte(0.0, 3.0)],
        )
        .unwrap();
        let bvh = SceneBvh::new(&scene);
        let r = Renderer::new(&scene, &bvh, &[], 1);
        let eye = Vec3::new(0.0, 0.6, -1.5);
        let dir = (Vec3::new(0.0, 0.0, 0.3) - eye).normalize();
        let v = r.intersect(eye, dir).unwrap();
        let n = 200_000u64;
        let (mut split, mut lobe) = (0.0f64, 0.0f64);
        for i in 0..n {
            split += r
                .radiance_split(eye, dir, &mut Sampler::new(4, i))
                .glossy_indirect
                .x as f64;
            let mut s = Sampler::new(5, i);
            if let Some(g) = v.bsdf.sample_glossy(v.n, v.wo, s.next_2d()) {
                if let Some(hit) = r.intersect(r.spawn(&v), g.wi) {
                    lobe += (hit.emission * g.weight).x as f64;
                }
            }
        }
        let (split, lobe) = (split / n as f64, lobe / n as f64);
        assert!(lobe > 0.05, "the floor reflects the emitter: {lobe}");
        assert!(
            (split / lobe - 1.0).abs() < 0.03,
            "glossy indirect {split} vs emission through the glossy lobe {lobe}"
        );
    }

    /// `radiance_split` follows both lobes at the first surface where
    /// `radiance` picks one by albedo: their means must agree.
    #[test]
    fn split_full_has_the_same_mean_as_radiance() {
        let glossy = Material {
            name: "glossy".into(),
            diffuse: [0.5, 0.4, 0.3],
            specular: [0.4; 3],
            shininess: 20.0,
            emission: [0.0; 3],
            diffuse_map: None,
            emission_map: None,
            metal_rough: None,
            cutout: None,
        };
        let tris = crate::scene::testing::room_with_box_triangles();
        let scene = Scene::from_triangles(
            "room".into(),
            tris.into_iter()
                .enumerate()
                .map(|(i, t)| (t, u32::from(i >= 12))),
            vec![glossy, matte(0.7, 0.0)],
        )
        .unwrap();
        let bvh = SceneBvh::new(&scene);
        let light = Light::Point {
            position: Point3([3.0, 3.5, 3.0]),
            intensity: Rgb([4.0; 3]),
        };
        let r = Renderer::new(&scene, &bvh, &[light], 3);
        let eye = Vec3::new(3.5, 2.0, 0.5);
        let dir = (Vec3::new(2.5, 0.0, 3.0) - eye).normalize();
        let n = 100_000u64;
        let (mut one, mut split, mut glossy_part) = (0.0f64, 0.0f64, 0.0f64);
        for i in 0..n {
            one += r.radiance(eye, dir, &mut Sampler::new(1, i)).y as f64;
            let s = r.radiance_split(eye, dir, &mut Sampler::new(2, i));
            split += s.full.y as f64;
            glossy_part += s.glossy_indirect.y as f64;
        }
        let (one, split, glossy_part) = (one / n as f64, split / n as f64, glossy_part / n as f64);
        assert!(
            glossy_part > 0.0 && glossy_part < split,
            "{glossy_part} {split}"
        );
        assert!(
            (one / split - 1.0).abs() < 0.02,
            "radiance {one} vs split {split}"
        );
    }

    #[test]
    fn escaping_rays_see_the_sky_and_nothing_else() {
        let scene = crate::scene::testing::room_with_box();
        let bvh = SceneBvh::new(&scene);
        let sky = Light::Sky {
            radiance: Rgb([0.25, 0.5, 1.0]),
        };
        let outside = Vec3::new(10.0, 10.0, 10.0);
        let away = Vec3::new(0.3, 0.8, 0.1).normalize();
        let lit = Renderer::new(&scene, &bvh, &[sky], 2);
        assert_eq!(
            lit.radiance(outside, away, &mut Sampler::new(0, 0)),
            Vec3::new(0.25, 0.5, 1.0)
        );
        let dark = Renderer::new(&scene, &bvh, &[], 2);
        assert_eq!(
            dark.radiance(outside, away, &mut Sampler::new(0, 0)),
            Vec3::ZERO
        );
        // Inside the closed room no shadow ray reaches the sky.
        let inside = Vec3::new(3.0, 2.0, 3.0);
        for i in 0..64 {
            let d =
                crate::render::material::cosine_hemisphere(Vec3::Y, Sampler::new(1, i).next_2d());
            assert_eq!(lit.radiance(inside, d, &mut Sampler::new(2, i)), Vec3::ZERO);
        }
    }
}
