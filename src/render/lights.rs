//! The light set and next-event estimation (direct lighting at a surface point).
//!
//! Lights are the scene's emissive triangles plus the config's lights
//! ([`crate::config::Light`]):
//!
//! * **Area lights**: every triangle whose material has a non-zero `Ke`. They
//!   emit `Ke` from **both** sides: real assets' winding is unreliable (the
//!   same reason shading is two-sided, see [`super::material`]), and a light
//!   that is dark from the side a modeller happened to wind it towards would
//!   silently turn a scene black. One triangle is chosen per sample with
//!   probability proportional to `area × luminance(Ke)` from a prefix-sum CDF,
//!   so bright large emitters get the samples. Near the triangle (within
//!   [`NEAR_RADII`] of its bounding radius) the sample is a direction drawn
//!   uniformly in the solid angle it subtends (Arvo 1995; pbrt-v4 §6.5.4),
//!   whose weight `cos θ · Ω` is at most `2π`; farther away, a point drawn
//!   uniformly on it, weighted by `cos θ cos θ_light / d²`. Area sampling
//!   alone has no bound beside the emitter: a lamp a centimetre under a
//!   ceiling lit the ceiling around it with samples thousands of times the
//!   mean, and a single such path in one probe's bake made it 100× too
//!   bright and decided a generated scene's diffuse comparison
//!   (docs/method.md, "Fireflies").
//! * **Point lights**: radiant intensity `I`, irradiance `I cos θ / d²`.
//! * **Spot lights**: a point light times a fall-off that is 1 inside
//!   `cone − edge`, 0 outside `cone` and a smoothstep of the cosine in between.
//! * **Directional lights**: irradiance `E` on a surface facing the light,
//!   arriving from `−direction`; the shadow ray runs until it has left the
//!   scene's bounds ("infinity").
//! * **Sky**: constant radiance for every direction that escapes the scene.
//!   Next-event estimation draws one cosine-weighted direction and casts a
//!   shadow ray out of the scene's bounds.
//!
//! Direct light at a surface point is the sum over the delta lights (one
//! shadow ray each), plus one area-light sample, plus one sky sample: each
//! term is an unbiased estimate, and delta lights cost one ray each.
//! Shadow rays start a small distance off the surface, proportional to the
//! scene's size ([`LightSet::epsilon`]), so that millimetre and kilometre
//! scenes behave alike.

use super::material::{cosine_hemisphere, Bsdf};
use crate::config::Light;
use crate::sampling::{point_in_triangle, sample_spherical_triangle, Sampler};
use crate::scene::raycast::SceneBvh;
use crate::scene::texture::{barycentric, interpolate, Texture, TextureMap};
use crate::scene::Scene;
use glam::{DVec3, Vec3};
use std::sync::Arc;

/// Relative luminance of linear RGB (Rec. 709 weights), the measure by which
/// area lights share the samples.
pub fn luminance(c: Vec3) -> f32 {
    0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z
}

/// An emissive triangle.
#[derive(Debug, Clone, Copy)]
struct AreaLight {
    vertices: [Vec3; 3],
    normal: Vec3,
    /// `Ke` (with an emission texture: its factor, which the texel scales).
    emission: Vec3,
    /// Index into [`LightSet::maps`] of its emission texture, or
    /// [`NO_MAP`].
    map: u32,
    /// Density of a point on this triangle in area measure: the triangle's
    /// selection probability divided by its area.
    pdf_area: f32,
    /// The triangle's selection probability.
    select: f32,
    /// Its centroid, and the distance from there to its farthest corner.
    centre: Vec3,
    radius: f32,
}

/// [`AreaLight::map`] of an untextured emitter.
const NO_MAP: u32 = u32::MAX;

/// An emitter's emission texture: the map (into [`LightSet::textures`])
/// and the triangle's texture coordinates.
#[derive(Debug, Clone)]
struct EmissionMap {
    map: TextureMap,
    texcoords: [glam::Vec2; 3],
}

/// Points farther than this many bounding radii from an emitter's centroid
/// sample it by area: its weight `cos θ_light / d²` then varies by at most
/// `((k+1)/(k−1))³ ≈ 3.4` over the triangle, and the spherical
/// construction's trigonometry (a third more bake time on the Cornell box
/// when every sample takes it) is spent only where it bounds a weight.
const NEAR_RADII: f32 = 5.0;

/// Triangles subtending less than this (steradians) are sampled by area:
/// pbrt-v4's `MinSphericalSampleArea` (§12.3.5), below which the spherical
/// construction loses precision and area sampling's weight varies little.
const MIN_SOLID_ANGLE: f64 = 3e-4;

impl AreaLight {
    /// A point on the triangle drawn uniformly by the solid angle it
    /// subtends at `p` ([`sample_spherical_triangle`]): the point, the unit
    /// direction to it and the solid angle. `None` where the triangle is
    /// too small or too oblique for that, and area sampling takes over.
    fn by_solid_angle(&self, p: Vec3, u: glam::Vec2) -> Option<(Vec3, Vec3, f32)> {
        if p.distance_squared(self.centre) > (NEAR_RADII * self.radius).powi(2) {
            return None;
        }
        let t = self.vertices.map(|v| v.as_dvec3());
        let o = p.as_dvec3();
        let (w, omega) =
            sample_spherical_triangle(o, &t, [u.x as f64, u.y as f64], MIN_SOLID_ANGLE)?;
        let normal = (t[1] - t[0]).cross(t[2] - t[0]);
        let along = (t[0] - o).dot(normal) / w.dot(normal);
        let y = o + w * along;
        (along > 0.0 && along.is_finite()).then(|| (y.as_vec3(), w.as_vec3(), omega as f32))
    }
}

#[derive(Debug, Clone, Copy)]
struct PointLight {
    position: Vec3,
    intensity: Vec3,
}

#[derive(Debug, Clone, Copy)]
struct SpotLight {
    position: Vec3,
    axis: Vec3,
    intensity: Vec3,
    /// Half-angle of the cone, radians.
    outer: f32,
    /// Half-angle of the fully lit core, `cone − edge` (at least 0), radians.
    inner: f32,
    cos_outer: f32,
    cos_inner: f32,
}

impl SpotLight {
    /// Share of the axial intensity emitted at cosine `c` from the axis: a
    /// smoothstep in angle, so that `edge_degrees` is the width of the fall-off.
    fn falloff(&self, c: f32) -> f32 {
        if c >= self.cos_inner {
            1.0
        } else if c <= self.cos_outer {
            0.0
        } else {
            let t = ((self.outer - c.clamp(-1.0, 1.0).acos()) / (self.outer - self.inner))
                .clamp(0.0, 1.0);
            t * t * (3.0 - 2.0 * t)
        }
    }
}

#[derive(Debug, Clone, Copy)]
struct DirectionalLight {
    /// Unit direction towards the light (the opposite of travel).
    to_light: Vec3,
    irradiance: Vec3,
}

/// Every light of a scene, ready for next-event estimation (module docs).
#[derive(Debug, Clone)]
pub struct LightSet {
    area: Vec<AreaLight>,
    /// Emission textures of the textured emitters.
    maps: Vec<EmissionMap>,
    /// The scene's textures, which `maps` index (shared, not copied).
    textures: Vec<Arc<Texture>>,
    /// Normalized prefix sums of the area lights' `area × luminance(Ke)`
    /// (`Ke ×` its texture's mean for a textured emitter).
    cdf: Vec<f32>,
    points: Vec<PointLight>,
    spots: Vec<SpotLight>,
    directionals: Vec<DirectionalLight>,
    sky: Vec3,
    epsilon: f32,
    center: Vec3,
    diagonal: f32,
}

impl LightSet {
    /// Collects `scene`'s emissive triangles, the lights its file defines
    /// ([`Scene::lights`]) and the config's `lights`, whose positions (world
    /// coordinates) it takes to the scene's local ones. Several sky lights add up. Negative or non-finite `Ke`
    /// components count as 0; triangles of zero luminance are not lights.
    ///
    /// A triangle with an emission texture emits `Ke ×` the texel at each
    /// point: it is chosen by its area times the luminance of `Ke ×` the
    /// texture's mean, and the texel at the sampled point scales what it
    /// gives, which keeps the estimate unbiased (any selection weight that
    /// is positive wherever the emission is will do; one near its mean
    /// keeps the variance down).
    pub fn new(scene: &Scene, lights: &[Light]) -> LightSet {
        let diagonal = scene.bounds.size().length().max(1e-6);
        let mut area = Vec::new();
        let mut maps = Vec::new();
        let mut weights = Vec::new();
        for (i, tri) in scene.triangles.iter().enumerate() {
            let m = &scene.materials[scene.material_ids[i] as usize];
            let emission = Vec3::from(
                m.emission
                    .map(|v| if v.is_finite() { v.max(0.0) } else { 0.0 }),
            );
            let mean = m
                .emission_map
                .map_or(Vec3::ONE, |map| scene.textures[map.texture as usize].mean());
            let tri_area = 0.5 * (tri[1] - tri[0]).cross(tri[2] - tri[0]).length();
            let weight = tri_area as f64 * luminance(emission * mean) as f64;
            if weight > 0.0 && weight.is_finite() {
                let centre = (tri[0] + tri[1] + tri[2]) / 3.0;
                let map = match m.emission_map {
                    Some(map) => {
                        maps.push(EmissionMap {
                            map,
                            texcoords: scene.texcoords.get(i).copied().unwrap_or_default(),
                        });
                        (maps.len() - 1) as u32
                    }
                    None => NO_MAP,
                };
                area.push(AreaLight {
                    vertices: *tri,
                    normal: scene.normals[i],
                    emission,
                    map,
                    pdf_area: 0.0,
                    select: 0.0,
                    centre,
                    radius: tri.iter().map(|&v| v.distance(centre)).fold(0.0, f32::max),
                });
                weights.push((weight, tri_area));
            }
        }
        let total: f64 = weights.iter().map(|w| w.0).sum();
        let mut acc = 0.0f64;
        let mut cdf: Vec<f32> = weights
            .iter()
            .map(|w| {
                acc += w.0;
                (acc / total) as f32
            })
            .collect();
        if let Some(last) = cdf.last_mut() {
            *last = 1.0;
        }
        // Each triangle's density is the probability the search in `direct`
        // actually gives it (the f32 CDF's step), divided by its area.
        for (i, (light, w)) in area.iter_mut().zip(&weights).enumerate() {
            let before = if i == 0 { 0.0 } else { cdf[i - 1] };
            light.select = cdf[i] - before;
            light.pdf_area = light.select / w.1;
        }
        let mut set = LightSet {
            area,
            maps,
            textures: scene.textures.clone(),
            cdf,
            points: Vec::new(),
            spots: Vec::new(),
            directionals: Vec::new(),
            sky: Vec3::ZERO,
            epsilon: 1e-4 * diagonal,
            center: 0.5 * (scene.bounds.min + scene.bounds.max),
            diagonal,
        };
        for light in scene.lights.iter().chain(lights) {
            match *light {
                Light::Point {
                    position,
                    intensity,
                } => set.points.push(PointLight {
                    position: scene.to_local(DVec3::from(position.0)),
                    intensity: Vec3::from(intensity.0),
                }),
                Light::Spot {
                    position,
                    direction,
                    intensity,
                    cone_degrees,
                    edge_degrees,
                } => {
                    let outer = cone_degrees.0.to_radians();
                    let inner = (cone_degrees.0 - edge_degrees.0).max(0.0).to_radians();
                    set.spots.push(SpotLight {
                        position: scene.to_local(DVec3::from(position.0)),
                        axis: Vec3::from(direction.0).normalize(),
                        intensity: Vec3::from(intensity.0),
                        outer,
                        inner,
                        cos_outer: outer.cos(),
                        cos_inner: inner.cos(),
                    })
                }
                Light::Directional {
                    direction,
                    irradiance,
                } => set.directionals.push(DirectionalLight {
                    to_light: -Vec3::from(direction.0).normalize(),
                    irradiance: Vec3::from(irradiance.0),
                }),
                Light::Sky { radiance } => set.sky += Vec3::from(radiance.0),
            }
        }
        set
    }

    /// The sky's radiance (zero without a sky light): what a ray that
    /// escapes the scene sees.
    pub fn sky(&self) -> Vec3 {
        self.sky
    }

    /// Number of emissive triangles.
    pub fn area_light_count(&self) -> usize {
        self.area.len()
    }

    /// Whether there is no light at all: every image would be black.
    pub fn is_empty(&self) -> bool {
        self.area.is_empty()
            && self.points.is_empty()
            && self.spots.is_empty()
            && self.directionals.is_empty()
            && self.sky == Vec3::ZERO
    }

    /// Offset of ray origins from surfaces and shrink of shadow-ray ends:
    /// `1e-4 ×` the scene's bounding-box diagonal.
    pub fn epsilon(&self) -> f32 {
        self.epsilon
    }

    /// A point along `dir` from `from` that lies outside the scene's bounds:
    /// the end of a shadow ray towards an infinitely distant light.
    fn beyond_scene(&self, from: Vec3, dir: Vec3) -> Vec3 {
        from + dir * ((from - self.center).length() + self.diagonal)
    }

    /// One-sample estimate of the direct light reflected towards `wo` at
    /// surface point `p` with shading normal `n` (facing `wo`) and BSDF `bsdf`:
    /// every delta light, one area-light sample, one sky sample (module docs).
    ///
    /// Distances and cosines are measured from `p` itself; only the shadow
    /// rays start [`LightSet::epsilon`] off the surface, so the offset does not
    /// bias the light's falloff.
    ///
    /// Contract: `n` and `wo` unit with `n·wo ≥ 0`; `p` on the surface.
    /// Allocation-free; draws a fixed number of values from `sampler` for a
    /// given light set (3 for the area lights if any, 2 for the sky if any).
    pub fn direct(
        &self,
        bvh: &SceneBvh,
        p: Vec3,
        n: Vec3,
        wo: Vec3,
        bsdf: &Bsdf,
        sampler: &mut Sampler,
    ) -> Vec3 {
        self.direct_split(bvh, p, n, wo, bsdf, sampler).0
    }

    /// [`LightSet::direct`] (first) with, second, the part of it that the
    /// glossy lobe reflects from emissive surfaces (the area lights). A
    /// light-field probe stores the emission of the surface it sees, so a
    /// probe-traced glossy ray returns exactly that light; the reference's
    /// glossy split counts it too, or the probes would be charged for
    /// light the reference leaves out (Wang et al. 2019 §5.1 compares the
    /// glossy indirect images).
    ///
    /// Contract: as [`LightSet::direct`]; the first value is bit-for-bit
    /// what [`LightSet::direct`] returns and draws the same samples.
    #[allow(clippy::too_many_arguments)]
    pub fn direct_split(
        &self,
        bvh: &SceneBvh,
        p: Vec3,
        n: Vec3,
        wo: Vec3,
        bsdf: &Bsdf,
        sampler: &mut Sampler,
    ) -> (Vec3, Vec3) {
        let eps = self.epsilon;
        let origin = p + n * eps;
        let mut sum = self.direct_delta(bvh, p, n, wo, bsdf);
        let mut area_glossy = Vec3::ZERO;
        if !self.area.is_empty() {
            let (light, y, wi, num, den) = self.pick_emitter(p, sampler);
            let k = n.dot(wi) * num / den;
            if k > 0.0 && k.is_finite() && !bvh.occluded(origin, y, eps) {
                let f = bsdf.eval(n, wo, wi);
                let emission = self.emission_at(light, y);
                sum += emission * f.total() * k;
                area_glossy += emission * f.glossy * k;
            }
        }
        if self.sky != Vec3::ZERO {
            // Cosine-weighted: L f cos / (cos / π) = π f L.
            let wi = cosine_hemisphere(n, sampler.next_2d());
            if !bvh.occluded(origin, self.beyond_scene(origin, wi), eps) {
                sum += self.sky * bsdf.eval(n, wo, wi).total() * std::f32::consts::PI;
            }
        }
        (sum, area_glossy)
    }

    /// The part of [`LightSet::direct`] from the delta lights: every point,
    /// spot and directional light, with its shadow ray. Deterministic (no
    /// samples drawn).
    ///
    /// Contract: as [`LightSet::direct`].
    pub fn direct_delta(&self, bvh: &SceneBvh, p: Vec3, n: Vec3, wo: Vec3, bsdf: &Bsdf) -> Vec3 {
        let eps = self.epsilon;
        let origin = p + n * eps;
        let mut sum = Vec3::ZERO;
        for light in &self.points {
            sum += self.delta(bvh, p, n, wo, bsdf, light.position, light.intensity);
        }
        for light in &self.spots {
            let from_light = (p - light.position).normalize_or_zero();
            let k = light.falloff(from_light.dot(light.axis));
            if k > 0.0 {
                sum += self.delta(bvh, p, n, wo, bsdf, light.position, light.intensity * k);
            }
        }
        for light in &self.directionals {
            let wi = light.to_light;
            let cos = n.dot(wi);
            if cos > 0.0 && !bvh.occluded(origin, self.beyond_scene(origin, wi), eps) {
                sum += light.irradiance * bsdf.eval(n, wo, wi).total() * cos;
            }
        }
        sum
    }

    /// One sample of the emissive triangles' light arriving at `p`,
    /// drawn as [`LightSet::direct`] draws its area-light sample (a
    /// triangle by power, a point on it by solid angle near it and by area
    /// farther off): the unit direction `wi` towards the sampled point and
    /// the radiance arriving from it over that direction's density in
    /// solid angle (zero when the point is hidden, shadow ray from
    /// `p + offset`). Its mean over samples of `value · g(wi)` estimates
    /// `∫ L_e g dω` over the sphere, without the variance of rays that
    /// must hit a small emitter by chance: the irradiance along a normal
    /// (`g = max(0, n·wi)`) or an SH projection (`g = Y(wi)`).
    /// `None` without emissive triangles.
    ///
    /// Contract: draws three values from `sampler`; allocation-free.
    pub fn sample_emitter(
        &self,
        bvh: &SceneBvh,
        p: Vec3,
        offset: Vec3,
        sampler: &mut Sampler,
    ) -> Option<(Vec3, Vec3)> {
        if self.area.is_empty() {
            return None;
        }
        let eps = self.epsilon;
        let (light, y, wi, num, den) = self.pick_emitter(p, sampler);
        let weight = num / den;
        if !(weight > 0.0 && weight.is_finite()) || bvh.occluded(p + offset, y, eps) {
            return Some((wi, Vec3::ZERO));
        }
        Some((wi, self.emission_at(light, y) * weight))
    }

    /// One point `y` on an area emitter, seen from `p`, drawn as both
    /// [`LightSet::direct_split`] and [`LightSet::sample_emitter`] draw it:
    /// the triangle by power, then by solid angle where it subtends enough
    /// of the sphere (no `1/d²` weight to blow up beside the emitter), else
    /// by area (module docs). Returns the emitter, `y`, the unit direction
    /// `wi` to it, and the sample's weight per unit of `cos θ` as a ratio
    /// `num / den` (`Ω / select`, or `cos θ_light / (d² pdf_area)`), kept
    /// apart so a caller multiplies its own cosine in first.
    ///
    /// Contract: `self.area` is not empty; draws three values.
    fn pick_emitter(&self, p: Vec3, sampler: &mut Sampler) -> (&AreaLight, Vec3, Vec3, f32, f32) {
        let u = sampler.next_f32();
        let uv = sampler.next_2d();
        let i = self
            .cdf
            .partition_point(|&c| c <= u)
            .min(self.area.len() - 1);
        let light = &self.area[i];
        match light.by_solid_angle(p, uv) {
            Some((y, wi, omega)) => (light, y, wi, omega, light.select),
            None => {
                let y = point_in_triangle(&light.vertices, uv.x, uv.y);
                let to = y - p;
                let d2 = to.length_squared();
                let wi = to / d2.sqrt();
                let cos_light = light.normal.dot(wi).abs();
                (light, y, wi, cos_light, d2 * light.pdf_area)
            }
        }
    }

    /// The radiance `light` emits at its point `y` (its emission texture
    /// applied, where it has one).
    fn emission_at(&self, light: &AreaLight, y: Vec3) -> Vec3 {
        match self.maps.get(light.map as usize) {
            Some(m) => {
                let uv = interpolate(&m.texcoords, barycentric(&light.vertices, y));
                light.emission * m.map.sample(&self.textures, uv)
            }
            None => light.emission,
        }
    }

    /// The point, spot and directional lights' light arriving at `p`, one
    /// call of `arrive(wi, e)` per light that reaches it: `wi` the unit
    /// direction towards the light, `e` the irradiance it gives a surface
    /// facing it head-on (`I / d²`, the spot's fall-off applied; a
    /// directional light's irradiance). Shadow rays start at `p + offset`
    /// (a surface point's lift along its normal; zero in free space).
    /// What a fully baked probe or receiver holds of them and a
    /// mixed-lighting one leaves to the renderer (crate::diffuse).
    ///
    /// Contract: deterministic (no samples drawn); allocation-free.
    pub fn delta_arrivals(
        &self,
        bvh: &SceneBvh,
        p: Vec3,
        offset: Vec3,
        mut arrive: impl FnMut(Vec3, Vec3),
    ) {
        let eps = self.epsilon;
        let origin = p + offset;
        let mut point = |at: Vec3, intensity: Vec3| {
            let to = at - p;
            let d2 = to.length_squared();
            if d2 > 0.0 && d2.is_finite() && !bvh.occluded(origin, at, eps) {
                arrive(to / d2.sqrt(), intensity / d2);
            }
        };
        for light in &self.points {
            point(light.position, light.intensity);
        }
        for light in &self.spots {
            let from_light = (p - light.position).normalize_or_zero();
            let k = light.falloff(from_light.dot(light.axis));
            if k > 0.0 {
                point(light.position, light.intensity * k);
            }
        }
        for light in &self.directionals {
            let wi = light.to_light;
            if !bvh.occluded(origin, self.beyond_scene(origin, wi), eps) {
                arrive(wi, light.irradiance);
            }
        }
    }

    /// Light reflected at `p` from a point source of intensity `intensity` at `at`.
    #[allow(clippy::too_many_arguments)]
    fn delta(
        &self,
        bvh: &SceneBvh,
        p: Vec3,
        n: Vec3,
        wo: Vec3,
        bsdf: &Bsdf,
        at: Vec3,
        intensity: Vec3,
    ) -> Vec3 {
        let to = at - p;
        let d2 = to.length_squared();
        if d2 <= 0.0 {
            return Vec3::ZERO;
        }
        let wi = to / d2.sqrt();
        let cos = n.dot(wi);
        if cos <= 0.0 || bvh.occluded(p + n * self.epsilon, at, self.epsilon) {
            return Vec3::ZERO;
        }
        intensity * bsdf.eval(n, wo, wi).total() * (cos / d2)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::{Degrees, Direction, NonNegative, Point3, Rgb};
    use crate::scene::Material;

    fn emissive(ke: [f32; 3]) -> Material {
        Material {
            name: "light".into(),
            diffuse: [0.0; 3],
            specular: [0.0; 3],
            shininess: 1.0,
            emission: ke,
            diffuse_map: None,
            emission_map: None,
            metal_rough: None,
            cutout: None,
        }
    }

    #[test]
    fn area_lights_are_chosen_by_power() {
        // Two emitters: unit right triangles, the second 3x as bright.
        let a = [Vec3::ZERO, Vec3::X, Vec3::Z];
        let b = a.map(|v| v + Vec3::Y);
        let dark = [Vec3::ZERO, Vec3::X, Vec3::Y];
        let scene = Scene::from_triangles(
            "t".into(),
            [(a, 0), (b, 1), (dark, 2)],
            vec![emissive([1.0; 3]), emissive([3.0; 3]), emissive([0.0; 3])],
        )
        .unwrap();
        let set = LightSet::new(&scene, &[]);
        assert_eq!(set.area_light_count(), 2);
        assert!((set.cdf[0] - 0.25).abs() < 1e-6 && set.cdf[1] == 1.0);
        assert!((set.area[0].pdf_area - 0.25 / 0.5).abs() < 1e-6);
        assert!((set.area[1].pdf_area - 0.75 / 0.5).abs() < 1e-6);
        assert!(!set.is_empty());
        assert!(LightSet::new(&scene, &[])
            .area
            .iter()
            .all(|l| l.emission != Vec3::ZERO));
    }

    #[test]
    fn a_ceiling_beside_a_lamp_gets_bounded_samples_of_the_exact_light() {
        // A 0.5 m lamp a centimetre under a ceiling, as generated and real
        // interiors hang them; it shines from both sides, so the ceiling
        // beside and above it is lit from a few millimetres away. Drawn by
        // area, a sample there weighs `cos θ_light / d²`: thousands of times
        // the mean, one such path a firefly that decided a scene's diffuse
        // figures. By solid angle every sample is at most `2π Le ρ/π` over
        // the triangle's selection probability.
        let ke = 10.0;
        let (lo, hi, y) = (-0.25f32, 0.25f32, 0.99f32);
        let lamp = [
            [
                Vec3::new(lo, y, lo),
                Vec3::new(hi, y, lo),
                Vec3::new(hi, y, hi),
            ],
            [
                Vec3::new(lo, y, lo),
                Vec3::new(hi, y, hi),
                Vec3::new(lo, y, hi),
            ],
        ];
        let ceiling = [
            Vec3::new(-2.0, 1.0, -2.0),
            Vec3::new(2.0, 1.0, -2.0),
            Vec3::new(0.0, 1.0, 2.0),
        ];
        let mut wall = Material::fallback();
        wall.diffuse = [0.8; 3];
        let scene = Scene::from_triangles(
            "t".into(),
            [(lamp[0], 0), (lamp[1], 0), (ceiling, 1)],
            vec![emissive([ke; 3]), wall],
        )
        .unwrap();
        let bvh = SceneBvh::new(&scene);
        let set = LightSet::new(&scene, &[]);
        let bsdf = Bsdf::from_material(&scene.materials[1]);
        let n = Vec3::NEG_Y;
        for p in [
            Vec3::new(0.0, 1.0, 0.0),
            Vec3::new(0.253, 1.0, 0.0),
            Vec3::new(0.25, 1.0, 0.26),
        ] {
            let exact: f64 = lamp
                .iter()
                .map(|t| {
                    crate::sampling::projected_solid_angle(
                        p.as_dvec3(),
                        n.as_dvec3(),
                        &t.map(|v| v.as_dvec3()),
                    )
                })
                .sum::<f64>()
                * (ke * 0.8 / std::f32::consts::PI) as f64;
            let bound = 2.0 * ke * 0.8 / 0.5 + 1e-3;
            let mut sampler = Sampler::new(7, p.x.to_bits() as u64);
            let (mut sum, mut max, count) = (0.0f64, 0.0f32, 20_000);
            for _ in 0..count {
                let l = set.direct(&bvh, p, n, n, &bsdf, &mut sampler).x;
                sum += l as f64;
                max = max.max(l);
            }
            let mean = sum / count as f64;
            assert!(max <= bound, "{p:?}: a sample of {max}, bound {bound}");
            assert!(
                (mean - exact).abs() < 0.03 * exact,
                "{p:?}: {mean} vs {exact}"
            );
        }
    }

    #[test]
    fn spot_falloff_is_smooth_between_inner_and_outer_cone() {
        let scene = crate::scene::testing::room_with_box();
        let spot = Light::Spot {
            position: Point3([1.0; 3]),
            direction: Direction([0.0, -1.0, 0.0]),
            intensity: Rgb([1.0; 3]),
            cone_degrees: Degrees(30.0),
            edge_degrees: NonNegative(10.0),
        };
        let set = LightSet::new(
            &scene,
            &[
                spot,
                Light::Sky {
                    radiance: Rgb([0.5; 3]),
                },
            ],
        );
        let s = &set.spots[0];
        let at = |deg: f32| s.falloff(deg.to_radians().cos());
        assert_eq!(at(0.0), 1.0);
        assert_eq!(at(19.9), 1.0);
        assert_eq!(at(30.1), 0.0);
        assert!((at(25.0) - 0.5).abs() < 0.05, "{}", at(25.0));
        assert!(at(22.0) > at(25.0) && at(25.0) > at(28.0));
        assert_eq!(set.sky(), Vec3::splat(0.5));
    }
}
