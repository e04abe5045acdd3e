//! Real spherical harmonics to band 2 (SH L2, nine coefficients per colour
//! channel): how Unity's light probes, Godot's LightmapGI probes and most
//! engines store a probe's diffuse light.
//!
//! A probe's incident radiance `L(ω)` is projected onto the nine basis
//! functions `Y_lm` (the real basis of Sloan, "Stupid Spherical Harmonics
//! Tricks" 2008, Appendix A2, in the order `Y00, Y1-1, Y10, Y11, Y2-2,
//! Y2-1, Y20, Y21, Y22`), and irradiance at normal `n` is the convolution
//! with the clamped cosine, band by band (Ramamoorthi & Hanrahan 2001,
//! "An Efficient Representation for Irradiance Environment Maps", Eq. 7–8):
//! `E(n) = Σ Â_l L_lm Y_lm(n)` with `Â0 = π`, `Â1 = 2π/3`, `Â2 = π/4`.
//! Bands 0 and 1 reproduce constant and linear radiance exactly; band 2
//! holds the clamped cosine to within 9% worst case (their §3).
//!
//! Coefficients here are the plain projections `L_lm = ∫ L Y_lm dω`; each
//! engine's own normalisation is applied where the probes are exported.

use glam::Vec3;
use std::f32::consts::PI;

/// Coefficients per colour channel.
pub const COEFFICIENTS: usize = 9;

/// The clamped cosine's coefficient per band (Ramamoorthi & Hanrahan 2001,
/// Eq. 8), indexed by band `l`.
pub const COSINE_LOBE: [f32; 3] = [PI, 2.0 * PI / 3.0, PI / 4.0];

/// Band of each of the nine coefficients.
const BAND: [usize; COEFFICIENTS] = [0, 1, 1, 1, 2, 2, 2, 2, 2];

/// The nine real SH basis functions at unit direction `d` (Sloan 2008,
/// Appendix A2; the order of the module docs).
pub fn basis(d: Vec3) -> [f32; COEFFICIENTS] {
    let (x, y, z) = (d.x, d.y, d.z);
    [
        0.282_095,
        0.488_603 * y,
        0.488_603 * z,
        0.488_603 * x,
        1.092_548 * x * y,
        1.092_548 * y * z,
        0.315_392 * (3.0 * z * z - 1.0),
        1.092_548 * x * z,
        0.546_274 * (x * x - y * y),
    ]
}

/// SH L2 radiance, RGB: `coefficients[k]` is the projection on basis
/// function `k` of each channel.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ShL2 {
    /// The nine RGB coefficients, in [`basis`] order.
    pub coefficients: [Vec3; COEFFICIENTS],
}

impl ShL2 {
    /// All zero.
    pub const ZERO: ShL2 = ShL2 {
        coefficients: [Vec3::ZERO; COEFFICIENTS],
    };

    /// Adds `weight · radiance · Y(d)`: one term of a quadrature of
    /// `∫ L Y dω` (for `n` directions uniform over the sphere, weight
    /// `4π / n`).
    ///
    /// Contract: `d` unit; allocation-free.
    pub fn add_sample(&mut self, d: Vec3, radiance: Vec3, weight: f32) {
        for (c, y) in self.coefficients.iter_mut().zip(basis(d)) {
            *c += radiance * (y * weight);
        }
    }

    /// Irradiance `E(n) = ∫ L(ω) max(0, n·ω) dω` of this radiance, by the
    /// band-limited convolution (module docs). Not clamped: a projection
    /// of very directional light can ring slightly below zero behind it.
    ///
    /// Contract: `n` unit.
    pub fn irradiance(&self, n: Vec3) -> Vec3 {
        let y = basis(n);
        let mut e = Vec3::ZERO;
        for k in 0..COEFFICIENTS {
            e += self.coefficients[k] * (COSINE_LOBE[BAND[k]] * y[k]);
        }
        e
    }

    /// `Σ w_i · sh_i`: the blend a probe lookup makes.
    pub fn blend<'a>(terms: impl IntoIterator<Item = (&'a ShL2, f32)>) -> ShL2 {
        let mut out = ShL2::ZERO;
        for (sh, w) in terms {
            for (o, c) in out.coefficients.iter_mut().zip(&sh.coefficients) {
                *o += *c * w;
            }
        }
        out
    }

    /// Every coefficient finite.
    pub fn is_finite(&self) -> bool {
        self.coefficients.iter().all(|c| c.is_finite())
    }

    /// The coefficients as Unity's `SphericalHarmonicsL2` holds them,
    /// `[channel][coefficient]` (`sh[channel, coefficient]` in C#), for
    /// radiance given in the world frame (right-handed, +Y up) and a probe
    /// used in Unity's left-handed frame, `(-x, y, z)`.
    ///
    /// Unity stores irradiance over π, already multiplied by each basis
    /// function's constant, so that its shader evaluates a normal with
    /// bare polynomials (Unity Manual, "Light Probes: Technical
    /// information"; `ShadeSH9` in UnityCG.cginc packs `unity_SHA*` as the
    /// x, y, z and constant terms, `unity_SHB*` as xy, yz, z², xz and
    /// `unity_SHC` as x² − y²): coefficient `k` is `Â_l · L_k · c_k / π`
    /// with [`COSINE_LOBE`]'s `Â_l` and `c_k` the constant of [`basis`]
    /// function `k`, whose order (y, z, x in band 1) Unity shares. A
    /// uniform sky of radiance `L` gives `[L, 0, …]`, which is what
    /// `SphericalHarmonicsL2.AddAmbientLight(L)` adds. The mirror
    /// `x → −x` flips the terms odd in x (x, xy, xz).
    pub fn unity_coefficients(&self) -> [[f32; COEFFICIENTS]; 3] {
        const C: [f32; COEFFICIENTS] = [
            0.282_095, 0.488_603, 0.488_603, 0.488_603, 1.092_548, 1.092_548, 0.315_392, 1.092_548,
            0.546_274,
        ];
        const MIRROR: [f32; COEFFICIENTS] = [1.0, 1.0, 1.0, -1.0, -1.0, 1.0, 1.0, -1.0, 1.0];
        let mut out = [[0.0; COEFFICIENTS]; 3];
        for k in 0..COEFFICIENTS {
            let f = COSINE_LOBE[BAND[k]] * C[k] / PI * MIRROR[k];
            for (c, row) in out.iter_mut().enumerate() {
                row[k] = self.coefficients[k][c] * f;
            }
        }
        out
    }
}

/// A probe's diffuse light: its incident radiance in SH L2, in the parts
/// engines bake apart.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ProbeSh {
    /// What a probe of a mixed-lighting bake holds (Unity's Baked
    /// Indirect, Godot's LightmapGI with dynamic lights): everything the
    /// probe's rays see (emitters, the sky, light surfaces reflect), but
    /// not the point, spot and directional lights' direct light, which
    /// the renderer shades itself (`sh.json`'s `total`).
    pub baked: ShL2,
    /// Light reflected at least once (`sh.json`'s `indirect`).
    pub indirect: ShL2,
    /// The point, spot and directional lights' direct light at the probe,
    /// projected exactly: each a delta of irradiance `e` from direction
    /// `wi`, coefficients `e · Y(wi)`. A fully baked probe holds
    /// `baked + direct` ([`ProbeSh::total`]).
    pub direct: ShL2,
}

impl ProbeSh {
    /// All the light at the probe: what a fully baked probe holds.
    pub fn total(&self) -> ShL2 {
        ShL2::blend([(&self.baked, 1.0), (&self.direct, 1.0)])
    }
}

/// A probe's diffuse light as engines store it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ProbeLight {
    /// Its incident radiance in SH L2 (`diffuse::bake_sh`).
    pub sh: ProbeSh,
    /// Path-traced irradiance (total) at the probe for a surface facing
    /// each of `diffuse::AXES`: what the SH's irradiance should be near.
    pub irradiance_axes: [Vec3; 6],
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::fibonacci_sphere;

    /// Projects `radiance` with `n` evenly spread directions.
    fn project(n: u32, radiance: impl Fn(Vec3) -> Vec3) -> ShL2 {
        let mut sh = ShL2::ZERO;
        let w = 4.0 * PI / n as f32;
        for d in fibonacci_sphere(n) {
            sh.add_sample(d, radiance(d), w);
        }
        sh
    }

    /// Unity's shader evaluation of one channel at its normal `n` (in
    /// Unity's frame): `ShadeSH9`'s polynomials over the stored
    /// coefficients, as UnityCG.cginc packs them.
    fn shade_sh9(sh: &[f32; COEFFICIENTS], n: Vec3) -> f32 {
        let sha = glam::Vec4::new(sh[3], sh[1], sh[2], sh[0] - sh[6]);
        let shb = glam::Vec4::new(sh[4], sh[5], 3.0 * sh[6], sh[7]);
        sha.dot(n.extend(1.0))
            + shb.dot(glam::Vec4::new(n.x * n.y, n.y * n.z, n.z * n.z, n.x * n.z))
            + sh[8] * (n.x * n.x - n.y * n.y)
    }

    #[test]
    fn unity_coefficients_follow_unitys_convention() {
        // A uniform sky: AddAmbientLight's coefficients.
        let sky = project(4096, |_| Vec3::new(0.5, 1.0, 2.0));
        let u = sky.unity_coefficients();
        for (c, want) in [0.5, 1.0, 2.0].into_iter().enumerate() {
            assert!((u[c][0] - want).abs() < 1e-3 * want, "{:?}", u[c]);
            assert!(u[c][1..].iter().all(|v| v.abs() < 1e-3), "{:?}", u[c]);
        }
        // Light from one side (+x, and a little +y): Unity's shader at the
        // mirrored normal gives E/π of ours at the world normal.
        let lobe = project(4096, |d| {
            Vec3::splat((d.dot(Vec3::new(0.8, 0.6, 0.0)) - 0.5).max(0.0) * 3.0)
        });
        let u = lobe.unity_coefficients();
        for n in crate::sampling::fibonacci_sphere(64) {
            let ours = lobe.irradiance(n).x / PI;
            let unity = shade_sh9(&u[0], Vec3::new(-n.x, n.y, n.z));
            assert!((ours - unity).abs() < 1e-4, "{n}: {ours} vs {unity}");
        }
        // And the light lands on Unity's side: brightest facing -x there.
        assert!(shade_sh9(&u[0], Vec3::NEG_X) > 5.0 * shade_sh9(&u[0], Vec3::X).max(0.01));
    }

    #[test]
    fn the_basis_is_orthonormal() {
        let dirs = fibonacci_sphere(20_000);
        let w = 4.0 * PI / dirs.len() as f32;
        for i in 0..COEFFICIENTS {
            for j in 0..COEFFICIENTS {
                let dot: f32 = dirs.iter().map(|&d| basis(d)[i] * basis(d)[j] * w).sum();
                let want = if i == j { 1.0 } else { 0.0 };
                assert!((dot - want).abs() < 2e-3, "<Y{i}, Y{j}> = {dot}");
            }
        }
    }

    #[test]
    fn constant_radiance_gives_pi_times_it_at_every_normal() {
        let sh = project(4096, |_| Vec3::new(1.0, 2.0, 0.5));
        for n in fibonacci_sphere(50) {
            let e = sh.irradiance(n);
            assert!(
                (e - Vec3::new(1.0, 2.0, 0.5) * PI).abs().max_element() < 2e-3,
                "{e}"
            );
        }
    }

    #[test]
    fn linear_radiance_is_reproduced_exactly() {
        // L = a + b·(d·z): E(n) = π a + (2π/3) b (n·z) (bands 0 and 1).
        let (a, b) = (1.0f32, 0.6f32);
        let sh = project(8192, |d| Vec3::splat(a + b * d.z));
        for n in fibonacci_sphere(50) {
            let want = PI * a + 2.0 * PI / 3.0 * b * n.z;
            let e = sh.irradiance(n).x;
            assert!((e - want).abs() < 3e-3, "n {n}: {e} vs {want}");
        }
    }

    #[test]
    fn a_hemisphere_of_light_is_close_to_the_exact_irradiance() {
        // Radiance 1 from the upper hemisphere: the exact irradiance at a
        // normal at angle θ from z is π (1 + cos θ) / 2. L2 holds it to a
        // few percent of π (Ramamoorthi & Hanrahan's bound is 9% of the
        // clamped cosine).
        let sh = project(16_384, |d| Vec3::splat(if d.z > 0.0 { 1.0 } else { 0.0 }));
        for n in fibonacci_sphere(64) {
            let want = PI * (1.0 + n.z) / 2.0;
            let e = sh.irradiance(n).x;
            assert!((e - want).abs() < 0.1 * PI, "n {n}: {e} vs {want}");
        }
        // Straight up and straight down are exact to band 1 plus the
        // band-2 term, which vanishes for a hemisphere's Y20 (odd-free).
        assert!((sh.irradiance(Vec3::Z).x - PI).abs() < 0.02 * PI);
    }

    #[test]
    fn blending_is_linear() {
        let a = project(1024, |_| Vec3::ONE);
        let b = project(1024, |d| Vec3::splat(d.x.max(0.0)));
        let m = ShL2::blend([(&a, 0.25), (&b, 0.75)]);
        let n = Vec3::new(0.6, 0.0, 0.8);
        let want = a.irradiance(n) * 0.25 + b.irradiance(n) * 0.75;
        assert!((m.irradiance(n) - want).abs().max_element() < 1e-5);
    }
}
