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
//! m² × 64² per probe however large the radiance map is. Its weights (the
//! cosine and the cosine power of every pair of texels) are the same for
//! every probe and computed once per bake (`Kernel`). Rays that escape
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

/// Bytes of kernel entries ([`Kernel`]) built at once: the normals are
/// convolved in chunks whose kernels fit, so a 256² irradiance map costs
/// no more memory than the default 32².
const KERNEL_BYTES: usize = 32 << 20;

/// Solid angle of each texel of the `side`×`side` source map: the sum of
/// the `n`×`n` map's texel solid angles `omega` over its footprint, in the
/// map's row order (so every probe's sums, and this one, agree to the bit).
fn source_weights(n: u32, side: u32, omega: &[f32]) -> Vec<f32> {
    let f = n / side;
    let mut weight = vec![0.0f32; (side * side) as usize];
    for y in 0..n {
        for x in 0..n {
            weight[((y / f) * side + x / f) as usize] += omega[(y * n + x) as usize];
        }
    }
    weight
}

/// A probe's maps averaged down to side `side` with the solid angles
/// `weight` ([`source_weights`]): per source texel, its radiance, mean r
/// and mean r², side by side for the convolution's reads.
struct Footprint {
    texels: Vec<(Vec3, f32, f32)>,
}

fn downsample(
    n: u32,
    side: u32,
    omega: &[f32],
    weight: &[f32],
    radiance: &[[f32; 3]],
    distance: &[f32],
    cap: f32,
) -> Footprint {
    let f = n / side;
    let len = (side * side) as usize;
    let mut texels = vec![(Vec3::ZERO, 0.0f32, 0.0f32); len];
    for y in 0..n {
        for x in 0..n {
            let i = (y * n + x) as usize;
            let t = &mut texels[((y / f) * side + x / f) as usize];
            let w = omega[i];
            let r = distance[i].min(cap);
            t.0 += Vec3::from(radiance[i]) * w;
            t.1 += r * w;
            t.2 += r * r * w;
        }
    }
    for (t, &w) in texels.iter_mut().zip(weight) {
        t.0 /= w;
        t.1 /= w;
        t.2 /= w;
    }
    Footprint { texels }
}

/// One source texel's part in an irradiance texel's sums: its index, its
/// cosine-weighted solid angle c·ω and its lobe weight c^k·ω.
#[derive(Clone, Copy)]
struct Term {
    j: u32,
    cosine: f32,
    lobe: f32,
}

/// The convolution's weights for a run of irradiance texels. They depend
/// on the two maps' sides and the lobe exponent alone, never on a probe,
/// so they are computed once per bake instead of once per probe (the
/// cosine power dominated the convolution's time). Each texel keeps the
/// source texels in its upper hemisphere (c > 0), in source order, and the
/// sum of their lobe weights, the moments' normalizer.
struct Kernel {
    /// `terms[starts[t]..starts[t + 1]]` are texel t's terms.
    starts: Vec<usize>,
    terms: Vec<Term>,
    lobe_sums: Vec<f32>,
}

impl Kernel {
    fn new(normals: &[Vec3], dirs: &[Vec3], weight: &[f32], exponent: f32) -> Kernel {
        let rows: Vec<(Vec<Term>, f32)> = normals
            .par_iter()
            .map(|nrm| {
                let mut terms = Vec::new();
                let mut wsum = 0.0f32;
                for (j, (d, &w)) in dirs.iter().zip(weight).enumerate() {
                    let c = nrm.dot(*d);
                    if c <= 0.0 {
                        continue;
                    }
                    let lobe = c.powf(exponent) * w;
                    wsum += lobe;
                    terms.push(Term {
                        j: j as u32,
                        cosine: c * w,
                        lobe,
                    });
                }
                (terms, wsum)
            })
            .collect();
        let mut k = Kernel {
            starts: Vec::with_capacity(rows.len() + 1),
            terms: Vec::with_capacity(rows.iter().map(|r| r.0.len()).sum()),
            lobe_sums: Vec::with_capacity(rows.len()),
        };
        k.starts.push(0);
        for (terms, wsum) in rows {
            k.terms.extend(terms);
            k.starts.push(k.terms.len());
            k.lobe_sums.push(wsum);
        }
        k
    }

    /// Irradiance texel `t`'s E and moments from the footprint `src` (a
    /// lobe without weight reads as `cap`, as an escape).
    fn texel(&self, t: usize, src: &Footprint, cap: f32) -> ([f32; 3], [f32; 2]) {
        let (mut sum, mut m1, mut m2) = (Vec3::ZERO, 0.0f32, 0.0f32);
        for term in &self.terms[self.starts[t]..self.starts[t + 1]] {
            let (radiance, r, r2) = src.texels[term.j as usize];
            sum += radiance * term.cosine;
            m1 += r * term.lobe;
            m2 += r2 * term.lobe;
        }
        let wsum = self.lobe_sums[t];
        let (a, b) = if wsum > 0.0 {
            (m1 / wsum, m2 / wsum)
        } else {
            (cap, cap * cap)
        };
        (
            [to_half(sum.x), to_half(sum.y), to_half(sum.z)],
            [to_half(a), to_half(b)],
        )
    }
}

/// Convolves every probe's `n`×`n` radiance and distance maps into `m`×`m`
/// irradiance and moment maps.
///
/// Contract: `radiance` and `distance` hold `probes × n²` entries; `n` and
/// `m` are powers of two; `exponent` > 0; `cap` > 0 replaces infinite
/// distances. A constant radiance L gives E = πL everywhere; a constant
/// distance r gives moments (r, r²). Deterministic whatever the thread
/// count.
pub fn convolve(
    n: u32,
    m: u32,
    radiance: &[[f32; 3]],
    distance: &[f32],
    exponent: f32,
    cap: f32,
) -> Irradiance {
    let sides = Convolution {
        n,
        m,
        exponent,
        cap,
        kernel_bytes: KERNEL_BYTES,
    };
    sides.run(radiance, distance)
}

/// [`convolve`]'s sides, lobe and cap, and the most bytes of kernel it
/// builds at once.
struct Convolution {
    n: u32,
    m: u32,
    exponent: f32,
    cap: f32,
    kernel_bytes: usize,
}

impl Convolution {
    fn run(&self, radiance: &[[f32; 3]], distance: &[f32]) -> Irradiance {
        let Convolution {
            n,
            m,
            exponent,
            cap,
            kernel_bytes,
        } = *self;
        let texels = (n * n) as usize;
        let side = n.min(SOURCE_SIDE);
        let omega = octahedral::texel_solid_angles(n);
        let weight = source_weights(n, side, &omega);
        let dirs = octahedral::texel_directions(side);
        let normals = octahedral::texel_directions(m);
        let probes = radiance.len() / texels;
        let per_map = normals.len();
        let mut out = Irradiance {
            irradiance: vec![[0.0; 3]; probes * per_map],
            moments: vec![[0.0; 2]; probes * per_map],
        };
        // About half the source texels face each normal.
        let per_normal = (dirs.len() / 2 + 1) * std::mem::size_of::<Term>();
        let chunk = (kernel_bytes / per_normal).clamp(1, per_map);
        for first in (0..per_map).step_by(chunk) {
            let run = first..(first + chunk).min(per_map);
            let kernel = Kernel::new(&normals[run.clone()], &dirs, &weight, exponent);
            out.irradiance
                .par_chunks_mut(per_map)
                .zip(out.moments.par_chunks_mut(per_map))
                .zip(radiance.par_chunks(texels).zip(distance.par_chunks(texels)))
                .for_each(|((e, mo), (rad, dist))| {
                    let src = downsample(n, side, &omega, &weight, rad, dist, cap);
                    for (t, i) in run.clone().enumerate() {
                        (e[i], mo[i]) = kernel.texel(t, &src, cap);
                    }
                });
        }
        out
    }
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

    /// The sums as written in McGuire §5.2, each probe and texel on its
    /// own: the kernel, shared by all probes and built in chunks, must give
    /// the same bits.
    #[test]
    fn the_shared_kernel_gives_each_probes_own_sums() {
        let (n, m, k, cap) = (32u32, 8u32, 50.0f32, 40.0f32);
        let texels = (n * n) as usize;
        let h = |i: usize, s: u64| crate::sampling::unit_f32(crate::sampling::hash2(s, i as u64));
        let radiance: Vec<[f32; 3]> = (0..3 * texels)
            .map(|i| [h(i, 1) * 5.0, h(i, 2), h(i, 3) * 0.1])
            .collect();
        let distance: Vec<f32> = (0..3 * texels)
            .map(|i| match h(i, 4) {
                u if u < 0.1 => f32::INFINITY,
                u => 0.5 + 30.0 * u,
            })
            .collect();
        let omega = octahedral::texel_solid_angles(n);
        let side = n.min(SOURCE_SIDE);
        let weight = source_weights(n, side, &omega);
        let dirs = octahedral::texel_directions(side);
        let mut want = Irradiance {
            irradiance: Vec::new(),
            moments: Vec::new(),
        };
        for p in 0..3 {
            let range = p * texels..(p + 1) * texels;
            let src = downsample(
                n,
                side,
                &omega,
                &weight,
                &radiance[range.clone()],
                &distance[range],
                cap,
            );
            for nrm in octahedral::texel_directions(m) {
                let (mut e, mut w, mut m1, mut m2) = (Vec3::ZERO, 0.0f32, 0.0f32, 0.0f32);
                for (j, d) in dirs.iter().enumerate() {
                    let c = nrm.dot(*d);
                    if c > 0.0 {
                        let (l, r, r2) = src.texels[j];
                        e += l * (c * weight[j]);
                        let lobe = c.powf(k) * weight[j];
                        w += lobe;
                        m1 += r * lobe;
                        m2 += r2 * lobe;
                    }
                }
                want.irradiance
                    .push([to_half(e.x), to_half(e.y), to_half(e.z)]);
                want.moments.push([to_half(m1 / w), to_half(m2 / w)]);
            }
        }
        for bytes in [usize::MAX, 1, 5 * std::mem::size_of::<Term>() * texels] {
            let sides = Convolution {
                n,
                m,
                exponent: k,
                cap,
                kernel_bytes: bytes,
            };
            let got = sides.run(&radiance, &distance);
            assert_eq!(got.irradiance, want.irradiance, "{bytes} bytes of kernel");
            assert_eq!(got.moments, want.moments, "{bytes} bytes of kernel");
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
