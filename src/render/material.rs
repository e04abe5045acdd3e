//! The BSDF built from an MTL material: a Lambertian lobe plus one glossy
//! microfacet lobe, the split McGuire et al. 2017 §5.1 uses ("factor the BRDF
//! into two terms": a Lambertian distribution and a glossy lobe), which is
//! also the split Wang et al. 2019 §5.1 needs to measure glossy indirect light
//! on its own.
//!
//! `f(wo, wi) = kd'/π + Ks · D(h) · G₂(wo, wi) / (4 |n·wo| |n·wi|)`
//!
//! * **Roughness.** MTL files give a Phong exponent `Ns`, not a microfacet
//!   roughness. Walter et al. 2007 (*Microfacet Models for Refraction through
//!   Rough Surfaces*, §5.2) match a Phong lobe of exponent `Ns` to a Beckmann
//!   lobe of roughness `α = sqrt(2 / (Ns + 2))`; we apply the same
//!   correspondence to GGX (Trowbridge–Reitz), whose shape is close to
//!   Beckmann's near the peak. `Ns = 10` gives `α ≈ 0.41`, `Ns = 40`
//!   (CornellBox-Glossy's boxes and sphere) `α ≈ 0.22`, `Ns = 1000` `α ≈ 0.045`.
//!   `α` is kept above [`MIN_ALPHA`]: a sharper lobe is a mirror, which `D`'s
//!   single-precision evaluation cannot represent.
//! * **Distribution and shadowing.** GGX `D` with the Smith
//!   *height-correlated* masking–shadowing `G₂ = 1 / (1 + Λ(wo) + Λ(wi))`
//!   (Heitz 2014, *Understanding the Masking-Shadowing Function*, §6): it is
//!   symmetric in `wo` and `wi`, so the BSDF stays reciprocal, and never
//!   exceeds the masking term `G₁(wo)` the sampler divides by.
//! * **No Fresnel.** MTL's `Ks` is the specular reflectance an artist chose;
//!   we use it as a constant Fresnel term (`F ≡ Ks`) rather than as Schlick's
//!   `F0`. Schlick would brighten every glossy surface to white at grazing
//!   angles, which assets authored for Phong shading do not expect, and a
//!   constant `F` keeps the lobe's albedo at most `Ks` for the energy rule below.
//! * **Energy.** Single-scattering GGX with `F ≡ Ks` reflects at most `Ks`
//!   (`G₂ ≤ G₁`, and reflections below the horizon are lost). Real assets
//!   often have `max Kd + max Ks > 1` (CornellBox-Glossy's short box:
//!   `Kd 0.525`, `Ks 0.8`), which would reflect more light than arrives.
//!   Both are first clamped to [0, 1]; then, where `max Kd + max Ks > 1`, the
//!   diffuse lobe is scaled to `kd' = Kd · (1 − max Ks) / max Kd`, so that
//!   `max kd' + max Ks = 1` and every channel's albedo is at most 1.
//!   Materials that already conserve energy keep their `Kd` unchanged.
//! * **Two-sided.** Real assets have unreliable winding (Sponza has no normals
//!   and faces of both orientations), so the shading normal is the geometric
//!   normal flipped to the side of the outgoing direction
//!   ([`shading_normal`]); both sides reflect alike. Light arriving from the
//!   other side is not transmitted (`f = 0`).
//!
//! Sampling treats the lobes separately, so that the caller can pick one by
//! its albedo or follow each on its own (the glossy-indirect split): the
//! diffuse lobe by cosine-weighted hemisphere sampling, the glossy lobe by
//! sampling GGX's distribution of visible normals (Heitz 2018, *Sampling the
//! GGX Distribution of Visible Normals*), whose weight `Ks · G₂/G₁(wo)` is
//! bounded by `Ks`: no fireflies from the sampler itself.

use crate::scene::Material;
use glam::{Vec2, Vec3};
use std::f32::consts::{FRAC_1_PI, PI};

/// Smallest GGX roughness used: below it, `D`'s peak (`1/(π α²)`) overflows
/// the precision that reflection directions are computed with.
pub const MIN_ALPHA: f32 = 1e-3;

/// The GGX roughness `α = sqrt(2 / (Ns + 2))` for Phong exponent `ns`
/// (Walter et al. 2007 §5.2, Phong ↔ Beckmann, applied to GGX; module docs).
///
/// Contract: negative or non-finite exponents are treated as 0 (the roughest
/// lobe, `α = 1`); the result lies in `[MIN_ALPHA, 1]`.
pub fn alpha_from_shininess(ns: f32) -> f32 {
    let ns = if ns.is_finite() { ns.max(0.0) } else { 0.0 };
    (2.0 / (ns + 2.0)).sqrt().max(MIN_ALPHA)
}

/// Specular reflectance each channel of [`all_glossy`] gives at least.
pub const ALL_GLOSSY_SPECULAR: f32 = 0.5;

/// `materials` made all glossy for measurement (`compare.materials:
/// AllGlossy(α)`; Wang et al. 2019 §5.2 render "*all* surfaces as glossy
/// for the purpose of benchmarking"): every material's Phong exponent
/// becomes the one whose GGX roughness is `alpha` (the inverse of
/// [`alpha_from_shininess`], `Ns = 2/α² − 2`), and each channel of its
/// specular colour is raised to at least [`ALL_GLOSSY_SPECULAR`]. Diffuse
/// colour and emission stay; the BSDF's energy rule (module docs) then
/// dims the diffuse lobe where the two would reflect more than arrives.
///
/// Contract: `alpha` in [0, 1]; below [`MIN_ALPHA`] it is a mirror.
pub fn all_glossy(materials: &mut [Material], alpha: f32) {
    let alpha = alpha.clamp(MIN_ALPHA, 1.0);
    let shininess = 2.0 / (alpha * alpha) - 2.0;
    for m in materials {
        // The benchmark's lobes are the material's own: a metal-roughness
        // texture's per-texel lobes give way to its mean's, made glossy.
        m.metal_rough = None;
        m.shininess = shininess;
        for c in &mut m.specular {
            *c = c.max(ALL_GLOSSY_SPECULAR);
        }
    }
}

/// The geometric normal `geometric` flipped, if needed, to face `wo` (the
/// direction towards the viewer): the shading normal of two-sided shading.
///
/// Contract: `geometric` is unit; the result is unit with `result·wo ≥ 0`.
pub fn shading_normal(geometric: Vec3, wo: Vec3) -> Vec3 {
    if geometric.dot(wo) < 0.0 {
        -geometric
    } else {
        geometric
    }
}

/// A cosine-distributed direction about the unit normal `n` from two uniforms
/// in [0, 1)² (Malley's method: uniform on the disc, lifted to the
/// hemisphere). Its density is `cos θ / π`; `cos θ > 0` always.
pub fn cosine_hemisphere(n: Vec3, u: Vec2) -> Vec3 {
    let r = u.x.sqrt();
    let phi = 2.0 * PI * u.y;
    let (s, c) = phi.sin_cos();
    let z = (1.0 - u.x).max(0.0).sqrt();
    let (t, b) = n.any_orthonormal_pair();
    (t * (r * c) + b * (r * s) + n * z).normalize()
}

/// The value of each lobe of `f(wo, wi)` (per channel, without the cosine).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Lobes {
    /// The Lambertian part `kd'/π`.
    pub diffuse: Vec3,
    /// The GGX part `Ks · D · G₂ / (4 |n·wo| |n·wi|)`.
    pub glossy: Vec3,
}

impl Lobes {
    /// `f` itself: the sum of the lobes.
    pub fn total(&self) -> Vec3 {
        self.diffuse + self.glossy
    }
}

/// A direction drawn from one lobe.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BsdfSample {
    /// The incoming direction (unit, on the side of the shading normal).
    pub wi: Vec3,
    /// `f_lobe(wo, wi) · cos θi / pdf(wi)`: the factor by which the path's
    /// throughput is multiplied.
    pub weight: Vec3,
    /// The lobe's density of `wi` (solid angle measure).
    pub pdf: f32,
}

/// The two-lobe BSDF of one material (module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Bsdf {
    /// Diffuse albedo after the energy rule (`kd'`).
    pub diffuse: Vec3,
    /// Specular colour `Ks`, clamped to [0, 1].
    pub specular: Vec3,
    /// GGX roughness from `Ns`.
    pub alpha: f32,
    /// Probability of following the diffuse lobe when one lobe is chosen by
    /// albedo: `mean(kd') / (mean(kd') + mean(Ks))`, 0 for a black material.
    pub diffuse_probability: f32,
}

impl Bsdf {
    /// The BSDF of `material`: `Kd`, `Ks` clamped to [0, 1], the diffuse lobe
    /// scaled where `max Kd + max Ks > 1`, `α` from `Ns` (module docs).
    pub fn from_material(material: &Material) -> Bsdf {
        Bsdf::from_colours(material.diffuse, material.specular, material.shininess)
    }

    /// [`Bsdf::from_material`] of a material's `Kd`, `Ks` and `Ns` given
    /// apart: what a textured hit point uses, its `Kd` times the texel.
    pub fn from_colours(diffuse: [f32; 3], specular: [f32; 3], shininess: f32) -> Bsdf {
        let clamp01 = |c: [f32; 3]| {
            Vec3::from(c.map(|v| {
                if v.is_finite() {
                    v.clamp(0.0, 1.0)
                } else {
                    0.0
                }
            }))
        };
        let kd = clamp01(diffuse);
        let ks = clamp01(specular);
        let (kd_max, ks_max) = (kd.max_element(), ks.max_element());
        let diffuse = if kd_max + ks_max > 1.0 {
            kd * ((1.0 - ks_max) / kd_max)
        } else {
            kd
        };
        let (wd, wg) = (diffuse.element_sum(), ks.element_sum());
        Bsdf {
            diffuse,
            specular: ks,
            alpha: alpha_from_shininess(shininess),
            diffuse_probability: if wd + wg > 0.0 { wd / (wd + wg) } else { 0.0 },
        }
    }

    /// Whether the diffuse lobe reflects anything.
    pub fn has_diffuse(&self) -> bool {
        self.diffuse != Vec3::ZERO
    }

    /// Whether the glossy lobe reflects anything.
    pub fn has_glossy(&self) -> bool {
        self.specular != Vec3::ZERO
    }

    /// Both lobes of `f(wo, wi)` at a point with shading normal `n`.
    ///
    /// Contract: `n`, `wo`, `wi` unit, both directions pointing away from the
    /// surface. Zero unless both lie strictly on `n`'s side (no transmission).
    /// Symmetric in `wo` and `wi` (reciprocity).
    pub fn eval(&self, n: Vec3, wo: Vec3, wi: Vec3) -> Lobes {
        let (co, ci) = (n.dot(wo), n.dot(wi));
        if co <= 0.0 || ci <= 0.0 {
            return Lobes {
                diffuse: Vec3::ZERO,
                glossy: Vec3::ZERO,
            };
        }
        let glossy = if self.has_glossy() {
            let h = (wo + wi).normalize();
            let d = ggx_d(n.dot(h), self.alpha);
            let g2 = 1.0 / (1.0 + smith_lambda(co, self.alpha) + smith_lambda(ci, self.alpha));
            self.specular * (d * g2 / (4.0 * co * ci))
        } else {
            Vec3::ZERO
        };
        Lobes {
            diffuse: self.diffuse * FRAC_1_PI,
            glossy,
        }
    }

    /// Density of [`Bsdf::sample_diffuse`] drawing `wi`: `max(0, n·wi) / π`.
    pub fn pdf_diffuse(&self, n: Vec3, wi: Vec3) -> f32 {
        n.dot(wi).max(0.0) * FRAC_1_PI
    }

    /// Density of [`Bsdf::sample_glossy`] drawing `wi` (solid angle, over the
    /// whole sphere): `G₁(wo) · D(h) / (4 n·wo)` for the half vector `h` of a
    /// reflection about a visible microfacet, else 0. Its integral over the
    /// upper hemisphere is below 1 by the share of samples lost below the horizon.
    pub fn pdf_glossy(&self, n: Vec3, wo: Vec3, wi: Vec3) -> f32 {
        let co = n.dot(wo);
        let sum = wo + wi;
        if co <= 0.0 || sum.length_squared() < 1e-12 {
            return 0.0;
        }
        let h = sum.normalize();
        let nh = n.dot(h);
        if nh <= 0.0 || wo.dot(h) <= 0.0 {
            return 0.0;
        }
        let g1 = 1.0 / (1.0 + smith_lambda(co, self.alpha));
        g1 * ggx_d(nh, self.alpha) / (4.0 * co)
    }

    /// A direction from the diffuse lobe, cosine-weighted; `weight = kd'`.
    /// `None` when the lobe is black or `wo` lies below the surface.
    pub fn sample_diffuse(&self, n: Vec3, wo: Vec3, u: Vec2) -> Option<BsdfSample> {
        if !self.has_diffuse() || n.dot(wo) <= 0.0 {
            return None;
        }
        let wi = cosine_hemisphere(n, u);
        Some(BsdfSample {
            wi,
            weight: self.diffuse,
            pdf: self.pdf_diffuse(n, wi),
        })
    }

    /// A direction from the glossy lobe by sampling GGX's visible normals
    /// (Heitz 2018, listing 1) and reflecting `wo` about the microfacet;
    /// `weight = Ks · G₂(wo, wi) / G₁(wo) ≤ Ks`. `None` when the lobe is
    /// black, `wo` lies below the surface, or the reflection points below it
    /// (that share of the lobe is lost, not redistributed).
    pub fn sample_glossy(&self, n: Vec3, wo: Vec3, u: Vec2) -> Option<BsdfSample> {
        let co = n.dot(wo);
        if !self.has_glossy() || co <= 0.0 {
            return None;
        }
        let (t, b) = n.any_orthonormal_pair();
        let a = self.alpha;
        let v = Vec3::new(wo.dot(t), wo.dot(b), co);
        // Stretch the view to the unit-roughness configuration.
        let vh = Vec3::new(a * v.x, a * v.y, v.z).normalize();
        let lensq = vh.x * vh.x + vh.y * vh.y;
        let t1 = if lensq > 0.0 {
            Vec3::new(-vh.y, vh.x, 0.0) / lensq.sqrt()
        } else {
            Vec3::X
        };
        let t2 = vh.cross(t1);
        let r = u.x.sqrt();
        let (sp, cp) = (2.0 * PI * u.y).sin_cos();
        let p1 = r * cp;
        let s = 0.5 * (1.0 + vh.z);
        let p2 = (1.0 - s) * (1.0 - p1 * p1).max(0.0).sqrt() + s * (r * sp);
        let nh = t1 * p1 + t2 * p2 + vh * (1.0 - p1 * p1 - p2 * p2).max(0.0).sqrt();
        // Unstretch: the microfacet normal in the local frame.
        let m = Vec3::new(a * nh.x, a * nh.y, nh.z.max(0.0)).normalize();
        let m = t * m.x + b * m.y + n * m.z;
        let wi = (2.0 * wo.dot(m) * m - wo).normalize();
        let ci = n.dot(wi);
        if ci <= 0.0 || !wi.is_finite() {
            return None;
        }
        let (lo, li) = (smith_lambda(co, a), smith_lambda(ci, a));
        let weight = self.specular * ((1.0 + lo) / (1.0 + lo + li));
        Some(BsdfSample {
            wi,
            weight,
            pdf: self.pdf_glossy(n, wo, wi),
        })
    }
}

/// GGX (Trowbridge–Reitz) normal distribution for `cos θh = nh`.
fn ggx_d(nh: f32, alpha: f32) -> f32 {
    if nh <= 0.0 {
        return 0.0;
    }
    let a2 = alpha * alpha;
    let k = nh * nh * (a2 - 1.0) + 1.0;
    a2 / (PI * k * k)
}

/// Smith's Λ for GGX at `cos θ = c` (`c > 0`): `(−1 + sqrt(1 + α² tan²θ)) / 2`.
fn smith_lambda(c: f32, alpha: f32) -> f32 {
    let c2 = c * c;
    let tan2 = ((1.0 - c2) / c2).max(0.0);
    0.5 * ((1.0 + alpha * alpha * tan2).sqrt() - 1.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn all_glossy_gives_every_material_the_roughness_asked_for() {
        let mut ms = vec![Material::fallback(), Material::fallback()];
        ms[1].specular = [0.9, 0.2, 0.7];
        ms[1].shininess = 1000.0;
        all_glossy(&mut ms, 0.3);
        for m in &ms {
            assert!((alpha_from_shininess(m.shininess) - 0.3).abs() < 1e-5);
            assert_eq!(m.diffuse, [0.8; 3]);
        }
        assert_eq!(ms[0].specular, [0.5; 3]);
        assert_eq!(ms[1].specular, [0.9, 0.5, 0.7]);
        let bsdf = Bsdf::from_material(&ms[0]);
        assert!(bsdf.has_glossy() && bsdf.has_diffuse());
        assert!((bsdf.alpha - 0.3).abs() < 1e-5);
    }
    use crate::sampling::Sampler;

    fn material(kd: f32, ks: f32, ns: f32) -> Material {
        Material {
            name: "m".into(),
            diffuse: [kd; 3],
            specular: [ks; 3],
            shininess: ns,
            emission: [0.0; 3],
            diffuse_map: None,
            emission_map: None,
            metal_rough: None,
            cutout: None,
        }
    }

    /// CornellBox-Glossy's materials (its MTL file), plus the extremes.
    fn test_materials() -> Vec<Material> {
        let m = |kd: [f32; 3], ks: f32, ns: f32| Material {
            name: "m".into(),
            diffuse: kd,
            specular: [ks; 3],
            shininess: ns,
            emission: [0.0; 3],
            diffuse_map: None,
            emission_map: None,
            metal_rough: None,
            cutout: None,
        };
        vec![
            m([0.486, 0.631, 0.663], 0.9, 40.0),
            m([0.525, 0.51, 0.48], 0.8, 40.0),
            m([0.63, 0.065, 0.05], 0.0, 10.0),
            m([0.725, 0.71, 0.68], 0.0, 10.0),
            material(1.0, 1.0, 1.0),
            material(1.0, 1.0, 1000.0),
            material(1.0, 0.0, 1.0),
            material(0.0, 1.0, 10.0),
            material(0.0, 1.0, 0.0),
        ]
    }

    /// `d` flipped, if needed, to `n`'s side.
    fn toward(n: Vec3, d: Vec3) -> Vec3 {
        if d.dot(n) < 0.0 {
            -d
        } else {
            d
        }
    }

    /// A uniform direction on the unit sphere.
    fn sphere_dir(u: Vec2) -> Vec3 {
        let z = 1.0 - 2.0 * u.x;
        let r = (1.0 - z * z).max(0.0).sqrt();
        let (s, c) = (2.0 * PI * u.y).sin_cos();
        Vec3::new(r * c, r * s, z)
    }

    #[test]
    fn alpha_follows_walters_phong_mapping() {
        assert!((alpha_from_shininess(10.0) - (2.0f32 / 12.0).sqrt()).abs() < 1e-7);
        assert!((alpha_from_shininess(40.0) - (2.0f32 / 42.0).sqrt()).abs() < 1e-7);
        assert_eq!(alpha_from_shininess(0.0), 1.0);
        assert_eq!(alpha_from_shininess(-5.0), 1.0);
        assert_eq!(alpha_from_shininess(1e12), MIN_ALPHA);
        let b = Bsdf::from_material(&material(0.5, 0.5, 10.0));
        assert_eq!(b.alpha, alpha_from_shininess(10.0));
    }

    #[test]
    fn energy_rule_scales_only_excess_diffuse() {
        let glossy_box = Bsdf::from_material(&test_materials()[1]);
        // max Kd 0.525 + Ks 0.8 > 1: diffuse scaled by 0.2 / 0.525.
        let k = 0.2 / 0.525;
        assert!(
            (glossy_box.diffuse - Vec3::new(0.525, 0.51, 0.48) * k)
                .abs()
                .max_element()
                < 1e-6
        );
        let fine = Bsdf::from_material(&material(0.5, 0.3, 10.0));
        assert_eq!(fine.diffuse, Vec3::splat(0.5));
        let extreme = Bsdf::from_material(&material(1.0, 1.0, 10.0));
        assert_eq!(extreme.diffuse, Vec3::ZERO);
        assert_eq!(extreme.diffuse_probability, 0.0);
        let matte = Bsdf::from_material(&material(0.7, 0.0, 10.0));
        assert_eq!(matte.diffuse_probability, 1.0);
    }

    #[test]
    fn evaluation_is_reciprocal_and_one_sided() {
        let n = Vec3::new(0.3, 0.9, -0.2).normalize();
        let mut s = Sampler::new(1, 0);
        for m in test_materials() {
            let b = Bsdf::from_material(&m);
            for _ in 0..200 {
                let wo = toward(n, sphere_dir(s.next_2d()));
                let wi = toward(n, sphere_dir(s.next_2d()));
                let (f1, f2) = (b.eval(n, wo, wi), b.eval(n, wi, wo));
                let tol = 1e-5 * f1.total().max_element().max(1.0);
                assert!(
                    (f1.total() - f2.total()).abs().max_element() <= tol,
                    "{f1:?} {f2:?}"
                );
                assert_eq!(b.eval(n, wo, -wi).total(), Vec3::ZERO);
            }
        }
    }

    /// Monte Carlo check that each pdf is the density its sampler draws from:
    /// integrated over the sphere with uniform directions it gives 1, and over
    /// the upper hemisphere the share of samples the sampler keeps (all for
    /// the diffuse lobe; the glossy lobe loses reflections below the horizon).
    #[test]
    fn sampling_pdfs_integrate_to_their_samplers_mass() {
        let n = Vec3::Y;
        let b = Bsdf::from_material(&material(0.5, 0.5, 40.0));
        let rough = Bsdf::from_material(&material(0.5, 0.5, 2.0));
        let mut s = Sampler::new(2, 0);
        for (bsdf, wo) in [
            (b, Vec3::Y),
            (b, Vec3::new(0.6, 0.8, 0.0)),
            (rough, Vec3::new(0.0, 0.3, 0.954).normalize()),
        ] {
            let n_mc = 1_000_000;
            let (mut diffuse, mut glossy, mut glossy_up) = (0.0f64, 0.0f64, 0.0f64);
            for _ in 0..n_mc {
                let wi = sphere_dir(s.next_2d());
                diffuse += bsdf.pdf_diffuse(n, wi) as f64;
                let g = bsdf.pdf_glossy(n, wo, wi) as f64;
                glossy += g;
                if wi.dot(n) > 0.0 {
                    glossy_up += g;
                }
            }
            let sphere = 4.0 * std::f64::consts::PI / n_mc as f64;
            let (diffuse, glossy, glossy_up) =
                (diffuse * sphere, glossy * sphere, glossy_up * sphere);
            assert!(
                (diffuse - 1.0).abs() < 0.01,
                "diffuse pdf integrates to {diffuse}"
            );
            assert!(
                (glossy - 1.0).abs() < 0.02,
                "glossy pdf integrates to {glossy} (wo {wo})"
            );
            let n_draw = 200_000;
            let kept = (0..n_draw)
                .filter(|_| bsdf.sample_glossy(n, wo, s.next_2d()).is_some())
                .count() as f64
                / n_draw as f64;
            assert!(
                (glossy_up - kept).abs() < 0.02,
                "glossy pdf over the hemisphere {glossy_up}, sampler keeps {kept} (wo {wo})"
            );
            assert!(kept > 0.6 && kept <= 1.0);
        }
    }

    /// White furnace: the sampled estimator's mean weight (one lobe chosen by
    /// albedo) is the directional albedo, agrees with a uniform-direction
    /// integral of `f cos θ`, and never exceeds 1.
    #[test]
    fn albedo_is_at_most_one_and_matches_evaluation() {
        let n = Vec3::Z;
        let mut s = Sampler::new(3, 0);
        for m in test_materials() {
            let b = Bsdf::from_material(&m);
            for wo in [
                Vec3::Z,
                Vec3::new(0.5, 0.0, 0.866),
                Vec3::new(0.95, 0.0, 0.312),
            ] {
                let wo = wo.normalize();
                let count = 200_000;
                let mut sampled = Vec3::ZERO.as_dvec3();
                let mut integrated = Vec3::ZERO.as_dvec3();
                for _ in 0..count {
                    let pd = b.diffuse_probability;
                    let sample = if s.next_f32() < pd {
                        b.sample_diffuse(n, wo, s.next_2d()).map(|x| x.weight / pd)
                    } else {
                        b.sample_glossy(n, wo, s.next_2d())
                            .map(|x| x.weight / (1.0 - pd))
                    };
                    sampled += sample.unwrap_or(Vec3::ZERO).as_dvec3();
                    let wi = toward(n, sphere_dir(s.next_2d()));
                    integrated += (b.eval(n, wo, wi).total() * wi.dot(n) * 2.0 * PI).as_dvec3();
                }
                let (sampled, integrated) = (sampled / count as f64, integrated / count as f64);
                assert!(
                    sampled.max_element() <= 1.0 + 1e-3,
                    "{m:?} {wo}: albedo {sampled}"
                );
                // The uniform estimator is noisy for sharp lobes: compare with
                // a tolerance that grows with the lobe's peak.
                let tol = if b.alpha < 0.1 { 0.15 } else { 0.03 };
                assert!(
                    (sampled - integrated).abs().max_element() < tol,
                    "{m:?} {wo}: sampled {sampled} vs integrated {integrated}"
                );
            }
        }
    }

    #[test]
    fn glossy_lobe_peaks_at_the_mirror_direction() {
        let n = Vec3::Y;
        let b = Bsdf::from_material(&material(0.0, 1.0, 200.0));
        let wo = Vec3::new(0.6, 0.8, 0.0);
        let mirror = Vec3::new(-0.6, 0.8, 0.0);
        let off = Vec3::new(-0.3, 0.8, 0.52).normalize();
        assert!(b.eval(n, wo, mirror).glossy.x > 10.0 * b.eval(n, wo, off).glossy.x);
        let mut s = Sampler::new(4, 0);
        let mean: Vec3 = (0..1000)
            .filter_map(|_| b.sample_glossy(n, wo, s.next_2d()))
            .map(|x| x.wi)
            .sum();
        assert!(mean.normalize().dot(mirror) > 0.99, "{mean}");
    }
}
