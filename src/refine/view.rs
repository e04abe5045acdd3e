//! What one probe position sees, mapped onto the atlas (Wang et al. 2019
//! §3.2, Fig. 4): the per-probe visibility `V^k_ij` and the per-probe terms
//! Ω̄_k (view distortion) and d̄_k (distance to surface).
//!
//! Visibility is derived the way a light-field probe of finite resolution
//! stores the scene: one ray through the centre of each texel of an
//! `n`×`n` octahedral directional map (McGuire et al. 2017 §3), the paper's
//! "subsampled view directions" when `n` is below the bake resolution. The
//! surface point `p(ω)` each ray hits marks its atlas texel as seen, unless
//! the probe views it from behind or at more than the coverage stage's
//! largest incidence angle, the grazing views §3.2 warns distort lookups.
//! A texel between two rays' footprints is not seen: that is precisely what
//! a probe of that resolution misses.

use super::atlas::Atlas;
use crate::lightfield::octahedral;
use crate::scene::raycast::SceneBvh;
use crate::scene::Scene;
use glam::Vec3;
use rayon::prelude::*;

/// Rays per parallel work item.
const RAY_CHUNK: usize = 64;

/// What one chunk of rays saw: texels with qualities, Σ Ω, Σ d.
type ChunkView = (Vec<(u32, f32)>, f64, f64);

/// One probe position's view of the atlas.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ProbeView {
    /// Texels seen, ascending, each with the quality of its best view
    /// `w1·Ω + w2·d` (per-view terms; see [`Viewer`]).
    pub texels: Vec<(u32, f32)>,
    /// Ω̄_k: the mean over all directions of `max(0, −ω·n_p(ω))` (misses
    /// and back faces count 0).
    pub omega_bar: f32,
    /// d̄_k: the mean over all directions of `|p̄ − p(ω)|` over the domain
    /// diagonal (misses count 0).
    pub d_bar: f32,
    /// The probe's score in eq. 2: `w1·Ω̄_k + w2·d̄_k`.
    pub score: f32,
}

/// Casts a probe's directional map from any position.
pub struct Viewer<'a> {
    scene: &'a Scene,
    bvh: &'a SceneBvh,
    atlas: &'a Atlas,
    directions: Vec<Vec3>,
    min_cos: f32,
    w_orientation: f32,
    w_distance: f32,
    inv_diagonal: f32,
}

impl<'a> Viewer<'a> {
    /// A viewer with `n`×`n` octahedral directions, crediting texels seen at
    /// incidence cosines of at least `min_cos`. Distances are divided by
    /// `diagonal` (the domain's), so that `w_orientation` and `w_distance`
    /// weigh unit-free terms on any scene.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        scene: &'a Scene,
        bvh: &'a SceneBvh,
        atlas: &'a Atlas,
        n: u32,
        min_cos: f32,
        w_orientation: f32,
        w_distance: f32,
        diagonal: f32,
    ) -> Viewer<'a> {
        Viewer {
            scene,
            bvh,
            atlas,
            directions: octahedral::texel_directions(n),
            min_cos,
            w_orientation,
            w_distance,
            inv_diagonal: 1.0 / diagonal.max(f32::MIN_POSITIVE),
        }
    }

    /// Number of directions per view.
    pub fn ray_count(&self) -> usize {
        self.directions.len()
    }

    /// The view from `p` (module docs).
    ///
    /// Contract: deterministic; `texels` is sorted by texel with no
    /// duplicates, each texel keeping the best quality among the rays that
    /// hit it.
    pub fn view(&self, p: Vec3) -> ProbeView {
        let parts: Vec<ChunkView> = self
            .directions
            .par_chunks(RAY_CHUNK)
            .map(|dirs| {
                let mut texels = Vec::with_capacity(dirs.len());
                let (mut omega, mut dist) = (0.0f64, 0.0f64);
                for &w in dirs {
                    let Some(hit) = self.bvh.closest_hit(p, w, 0.0, f32::INFINITY) else {
                        continue;
                    };
                    let cos = -w.dot(self.scene.normals[hit.triangle as usize]);
                    let d = hit.t * self.inv_diagonal;
                    dist += d as f64;
                    if cos <= 0.0 {
                        continue;
                    }
                    omega += cos as f64;
                    if cos >= self.min_cos {
                        let tri = &self.scene.triangles[hit.triangle as usize];
                        let texel = self.atlas.texel_at(hit.triangle, tri, p + w * hit.t);
                        texels.push((texel, self.w_orientation * cos + self.w_distance * d));
                    }
                }
                (texels, omega, dist)
            })
            .collect();
        let mut texels = Vec::with_capacity(self.directions.len());
        let (mut omega, mut dist) = (0.0f64, 0.0f64);
        for (t, o, d) in parts {
            texels.extend(t);
            omega += o;
            dist += d;
        }
        texels.sort_unstable_by(|a, b| a.0.cmp(&b.0).then(b.1.total_cmp(&a.1)));
        texels.dedup_by_key(|e| e.0);
        let n = self.directions.len().max(1) as f64;
        let omega_bar = (omega / n) as f32;
        let d_bar = (dist / n) as f32;
        ProbeView {
            texels,
            omega_bar,
            d_bar,
            score: self.w_orientation * omega_bar + self.w_distance * d_bar,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::testing::room_sdf;

    #[test]
    fn a_centred_probe_sees_the_room_and_a_cornered_one_sees_it_worse() {
        let (scene, bvh, _) = room_sdf(0.25, 1);
        let atlas = Atlas::new(&scene, 0.25).unwrap();
        let viewer = Viewer::new(&scene, &bvh, &atlas, 32, 0.087, 1.0, 1.0, 4.0 * 3f32.sqrt());
        let centre = viewer.view(Vec3::new(3.0, 2.0, 3.0));
        let corner = viewer.view(Vec3::new(3.8, 3.8, 3.8));
        assert!(centre.texels.windows(2).all(|w| w[0].0 < w[1].0));
        // Every ray from inside a closed room hits something, from the front.
        assert!(
            centre.omega_bar > 0.4 && centre.omega_bar <= 1.0,
            "{}",
            centre.omega_bar
        );
        assert!(centre.d_bar > 0.0);
        // In a corner, the three nearest walls are seen at grazing angles.
        assert!(corner.omega_bar < centre.omega_bar);
        let area = |v: &ProbeView| -> f32 {
            v.texels
                .iter()
                .map(|&(t, _)| atlas.texel_area[t as usize])
                .sum()
        };
        assert!(
            area(&centre) > 0.5 * scene.area() as f32 * 0.6,
            "{}",
            area(&centre)
        );
        assert_eq!(centre, viewer.view(Vec3::new(3.0, 2.0, 3.0)));
    }
}
