//! Irradiance probes with filtered distance moments (McGuire et al. 2017
//! §3 and §5.2).
//!
//! Each irradiance texel, for the normal n through its centre, holds the
//! cosine-convolved irradiance E(n) = ∫ L(ω) max(0, n·ω) dω over the
//! probe's radiance map, and the first two moments of radial distance,
//! E\[r\] and E\[r²\], averaged with a cosine-power lobe max(0, n·ω)^k: the
//! inputs of the Chebyshev visibility test (variance σ² = |E\[r\]² − E\[r²\]|,
//! §5.2) that weights probes when irradiance is interpolated.
//!
//! The integrals are sums over a source map of side min(n, 64): radiance,
//! r and r² are first averaged over 2×2 blocks, weighted by texel solid
//! angle (exact, since octahedral footprints nest), so the convolution costs
//! m² × 64² per probe however large the radiance map is. Rays that escape
//! count as `max_distance` (the domain's diagonal) in the moments.

use super::maps::to_half;
use super::octahedral;
use glam::Vec3;
use rayon::prelude::*;

/// Largest side of the source map the convolutions sum over.
pub const SOURCE_SIDE: u32 = 64;

/// Irradiance and distance moments of every probe.
pub struct Irradiance {
    /// E(n) per texel (RGB, half precision), probes one after another.
    pub irradiance: Vec<[f32; 3]>,
    /// (E\[r\], E\[r²\]) per texel (half precision).
    pub moments: Vec<[f32; 2]>,
}

/// One probe's irradiance and moment maps.
type ProbeMaps = (Vec<[f32; 3]>, Vec<[f32; 2]>);

/// A probe's maps averaged down to side `side`: solid angle, direction of
/// the footprint's centre, radiance, mean r and mean r².
struct Footprint {
    weight: Vec<f32>,
    dir: Vec<Vec3>,
    radiance: Vec<Vec3>,
    r: Vec<f32>,
    r2: Vec<f32>,
}

fn downsample(
    n: u32,
    side: u32,
    omega: &[f32],
    radiance: &[[f32; 3]],
    distance: &[f32],
    cap: f32,
) -> Footprint {
    let f = n / side;
    let len = (side * side) as usize;
    let mut s = Footprint {
        weight: vec![0.0; len],
        dir: octahedral::texel_directions(side),
        radiance: vec![Vec3::ZERO; len],
        r: vec![0.0; len],
        r2: vec![0.0; len],
    };
    for y in 0..n {
        for x in 0..n {
            let i = (y * n + x) as usize;
            let j = ((y / f) * side + x / f) as usize;
            let w = omega[i];
            let r = distance[i].min(cap);
            s.weight[j] += w;
            s.radiance[j] += Vec3::from(radiance[i]) * w;
            s.r[j] += r * w;
            s.r2[j] += r * r * w;
        }
    }
    for j in 0..len {
        let w = s.weight[j];
        s.radiance[j] /= w;
        s.r[j] /= w;
        s.r2[j] /= w;
    }
    s
}

/// Convolves every probe's `n`×`n` radiance and distance maps into `m`×`m`
/// irradiance and moment maps.
///
/// Contract: `radiance` and `distance` hold `probes × n²` entries; `n` and
/// `m` are powers of two; `exponent` > 0; `cap` > 0 replaces infinite
/// distances. A constant radiance L gives E = πL everywhere; a constant
/// distance r gives moments (r, r²).
pub fn convolve(
    n: u32,
    m: u32,
    radiance: &[[f32; 3]],
    distance: &[f32],
    exponent: f32,
    cap: f32,
) -> Irradiance {
    let texels = (n * n) as usize;
    let side = n.min(SOURCE_SIDE);
    let omega = octahedral::texel_solid_angles(n);
    let normals = octahedral::texel_directions(m);
    let per_probe: Vec<ProbeMaps> = radiance
        .par_chunks(texels)
        .zip(distance.par_chunks(texels))
        .map(|(rad, dist)| {
            let src = downsample(n, side, &omega, rad, dist, cap);
            let mut e = Vec::with_capacity(normals.len());
            let mut mo = Vec::with_capacity(normals.len());
            for nrm in &normals {
                let (mut sum, mut wsum, mut m1, mut m2) = (Vec3::ZERO, 0.0f32, 0.0f32, 0.0f32);
                for j in 0..src.dir.len() {
                    let c = nrm.dot(src.dir[j]);
                    if c <= 0.0 {
                        continue;
                    }
                    let w = src.weight[j];
                    sum += src.radiance[j] * (c * w);
                    let lobe = c.powf(exponent) * w;
                    wsum += lobe;
                    m1 += src.r[j] * lobe;
                    m2 += src.r2[j] * lobe;
                }
                e.push([to_half(sum.x), to_half(sum.y), to_half(sum.z)]);
                let (a, b) = if wsum > 0.0 {
                    (m1 / wsum, m2 / wsum)
                } else {
                    (cap, cap * cap)
                };
                mo.push([to_half(a), to_half(b)]);
            }
            (e, mo)
        })
        .collect();
    let mut out = Irradiance {
        irradiance: Vec::with_capacity(per_probe.len() * normals.len()),
        moments: Vec::with_capacity(per_probe.len() * normals.len()),
    };
    for (e, mo) in per_probe {
        out.irradiance.extend(e);
        out.moments.extend(mo);
    }
    out
}

/// Chebyshev's upper bound on the chance that a point at distance `r` from
/// the probe is visible from it, given the moments (McGuire §5.2, after
/// variance shadow maps): 1 when r ≤ E\[r\], else σ² / (σ² + (r − E\[r\])²).
pub fn chebyshev_visibility(moments: [f32; 2], r: f32) -> f32 {
    let mean = moments[0];
    if r <= mean {
        return 1.0;
    }
    let variance = (moments[1] - mean * mean).abs().max(1e-6);
    let d = r - mean;
    variance / (variance + d * d)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f32::consts::PI;

    fn convolve_fn(
        n: u32,
        m: u32,
        l: impl Fn(Vec3) -> Vec3,
        r: impl Fn(Vec3) -> f32,
    ) -> Irradiance {
        let dirs = octahedral::texel_directions(n);
        let rad: Vec<[f32; 3]> = dirs.iter().map(|&d| l(d).into()).collect();
        let dist: Vec<f32> = dirs.iter().map(|&d| r(d)).collect();
        convolve(n, m, &rad, &dist, 50.0, 100.0)
    }

    #[test]
    fn constant_radiance_gives_pi_times_radiance() {
        let out = convolve_fn(64, 16, |_| Vec3::new(1.0, 2.0, 0.5), |_| 3.0);
        for (e, mo) in out.irradiance.iter().zip(&out.moments) {
            assert!((e[0] - PI).abs() < 0.01 * PI, "{e:?}");
            assert!((e[1] - 2.0 * PI).abs() < 0.02 * PI, "{e:?}");
            assert!(
                (mo[0] - 3.0).abs() < 3e-3 && (mo[1] - 9.0).abs() < 1e-2,
                "{mo:?}"
            );
        }
    }

    #[test]
    fn linear_radiance_gives_the_analytic_irradiance() {
        // L(ω) = 1 + a·ω: E(n) = π + (2π/3) a·n.
        let a = Vec3::new(0.3, -0.5, 0.4);
        let m = 16;
        let out = convolve_fn(128, m, |d| Vec3::splat(1.0 + a.dot(d)), |_| 1.0);
        for (e, nrm) in out.irradiance.iter().zip(octahedral::texel_directions(m)) {
            let want = PI + 2.0 * PI / 3.0 * a.dot(nrm);
            assert!(
                (e[0] - want).abs() < 0.01 * want,
                "{nrm:?}: {} vs {want}",
                e[0]
            );
        }
    }

    #[test]
    fn moments_follow_the_lobe_and_cap_escapes() {
        // Distance 1 in the upper hemisphere, escapes below: a texel facing
        // up sees mostly 1, facing down mostly the cap.
        let out = convolve_fn(
            64,
            8,
            |_| Vec3::ONE,
            |d| if d.z > 0.0 { 1.0 } else { f32::INFINITY },
        );
        for (mo, nrm) in out.moments.iter().zip(octahedral::texel_directions(8)) {
            if nrm.z > 0.5 {
                assert!(mo[0] < 1.5, "{nrm:?} {mo:?}");
            } else if nrm.z < -0.5 {
                assert!(mo[0] > 95.0, "{nrm:?} {mo:?}");
            }
            assert!(
                mo[1] + 1e-3 >= mo[0] * mo[0] * 0.999,
                "variance must be non-negative: {mo:?}"
            );
        }
    }

    #[test]
    fn chebyshev_is_one_in_front_and_falls_behind() {
        let mo = [2.0, 4.5];
        assert_eq!(chebyshev_visibility(mo, 1.0), 1.0);
        let a = chebyshev_visibility(mo, 2.5);
        let b = chebyshev_visibility(mo, 4.0);
        assert!(a < 1.0 && b < a && b > 0.0);
    }
}
