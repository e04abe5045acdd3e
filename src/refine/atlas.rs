//! The visibility atlas (Wang et al. 2019 §3.2, Fig. 4): all scene surface
//! cut into texels of near-uniform area, so that "how much of the scene a
//! probe sees" becomes a sum over texels.
//!
//! The paper unwraps the scene into one texture atlas and notes in its
//! future work that a single atlas loses detail on large scenes. Here every
//! triangle is its own chart, so no surface is ever squeezed:
//!
//! * a triangle of area `A` is cut into `n²` congruent sub-triangles by
//!   splitting each edge into `n = ceil(sqrt(A / a))` parts, where `a` is the
//!   target texel area `texel_size²`; each texel's area `A / n²` then lies in
//!   `(a/4, a]`;
//! * a triangle smaller than `a` is a single texel of its own area;
//! * every texel carries its area, and every sum over texels is
//!   area-weighted, so the fitness is an integral over the surface that does
//!   not depend on how finely small triangles are cut.
//!
//! A point maps to its texel in O(1) from its barycentric coordinates, which
//! is what lets a probe's ray hits land in the atlas (Fig. 4, right).

use crate::error::{Error, Result};
use crate::raster::RgbImage;
use crate::scene::Scene;
use glam::Vec3;

/// Most texels an atlas may have (about 400 MB of accumulators at the limit).
pub const MAX_TEXELS: u64 = 20_000_000;

/// Colour of pixels that show no texel in [`Atlas::render`].
const BACKGROUND: [u8; 3] = [24, 24, 28];

/// Per-triangle charts of near-uniform texels (module docs).
#[derive(Debug, Clone)]
pub struct Atlas {
    /// First texel of each triangle's chart; one extra entry holds the total.
    offset: Vec<u32>,
    /// Edge subdivisions `n` of each chart.
    subdivisions: Vec<u32>,
    /// Area of each texel.
    pub texel_area: Vec<f32>,
    /// Total area of all texels (the scene's one-sided area).
    pub total_area: f64,
    /// The target texel edge.
    pub texel_size: f32,
}

impl Atlas {
    /// Cuts every triangle of `scene` into texels of about `texel_size`².
    ///
    /// Contract: deterministic; every triangle owns at least one texel, and
    /// the texel areas of a triangle sum to its area. A `texel_size` that
    /// would give more than [`MAX_TEXELS`] texels is a user error naming
    /// `refine.texel_size`.
    pub fn new(scene: &Scene, texel_size: f32) -> Result<Atlas> {
        let a = (texel_size as f64) * (texel_size as f64);
        let areas: Vec<f64> = scene.triangle_areas().collect();
        let subdivisions: Vec<u32> = areas
            .iter()
            .map(|&area| (area / a).sqrt().ceil().clamp(1.0, 65_535.0) as u32)
            .collect();
        let total: u64 = subdivisions.iter().map(|&n| n as u64 * n as u64).sum();
        if total > MAX_TEXELS {
            return Err(Error::User(format!(
                "refine.texel_size: {} cuts the scene into {total} atlas texels, over the limit of {MAX_TEXELS}; raise it",
                crate::config::short(texel_size)
            )));
        }
        let mut offset = Vec::with_capacity(areas.len() + 1);
        let mut texel_area = Vec::with_capacity(total as usize);
        let mut next = 0u32;
        for (&n, &area) in subdivisions.iter().zip(&areas) {
            offset.push(next);
            let nn = n * n;
            texel_area.extend(std::iter::repeat_n((area / nn as f64) as f32, nn as usize));
            next += nn;
        }
        offset.push(next);
        Ok(Atlas {
            offset,
            subdivisions,
            texel_area,
            total_area: areas.iter().sum(),
            texel_size,
        })
    }

    /// Number of texels.
    pub fn len(&self) -> usize {
        self.texel_area.len()
    }

    /// Whether the atlas has no texel (a scene without triangles).
    pub fn is_empty(&self) -> bool {
        self.texel_area.is_empty()
    }

    /// The texel of triangle `triangle` (vertices `tri`) holding point `p`.
    ///
    /// Contract: `p` is projected onto the triangle's plane and clamped into
    /// it, so a hit point with rounding error still lands in this triangle's
    /// chart.
    pub fn texel_at(&self, triangle: u32, tri: &[Vec3; 3], p: Vec3) -> u32 {
        let (u, v) = barycentric(tri, p);
        let t = triangle as usize;
        self.offset[t] + chart_texel(self.subdivisions[t], u, v)
    }

    /// Renders one panel: every chart as a right triangle in its own square
    /// block, blocks packed in shelves, each texel painted `color(texel)`.
    /// The panel has at most about `max_pixels` pixels (blocks shrink when
    /// the atlas has more texels than that; each chart keeps at least one
    /// pixel).
    pub fn render(&self, max_pixels: u32, color: impl Fn(u32) -> [u8; 3] + Sync) -> RgbImage {
        self.paint(&self.layout(max_pixels), color)
    }

    /// Where [`Atlas::render`] puts each chart's block for `max_pixels`:
    /// it depends on the charts alone, so panels of one atlas share it.
    pub fn layout(&self, max_pixels: u32) -> Layout {
        let n_sq: f64 = self.subdivisions.iter().map(|&n| (n as f64).powi(2)).sum();
        // Pixels per texel edge; the 0.5 leaves room for the empty upper
        // halves of the blocks.
        let scale = (0.5 * max_pixels as f64 / n_sq.max(1.0)).sqrt().min(8.0);
        let block: Vec<u32> = self
            .subdivisions
            .iter()
            .map(|&n| ((n as f64 * scale).round() as u32).max(1))
            .collect();
        let area: f64 = block.iter().map(|&b| (b as f64).powi(2)).sum();
        let max_block = block.iter().copied().max().unwrap_or(1);
        let width = ((area.sqrt() * 1.05).ceil() as u32).max(max_block).max(1);
        // Shelf packing: blocks left to right, largest first (ties: the
        // earlier chart), a new shelf when one is full.
        let mut placed = vec![(0u32, 0u32); block.len()];
        let mut shelves: Vec<Shelf> = Vec::new();
        let (mut x, mut y, mut shelf) = (0u32, 0u32, 0u32);
        for t in largest_first(&block, max_block) {
            let b = block[t];
            if x + b > width {
                x = 0;
                y += shelf;
                shelf = 0;
            }
            if x == 0 {
                shelves.push(Shelf {
                    y,
                    height: 0,
                    charts: Vec::new(),
                });
            }
            if let Some(s) = shelves.last_mut() {
                s.height = s.height.max(b);
                s.charts.push(t as u32);
            }
            placed[t] = (x, y);
            x += b;
            shelf = shelf.max(b);
        }
        Layout {
            width,
            height: (y + shelf).max(1),
            block,
            placed,
            shelves,
        }
    }

    /// A panel of `layout`, each texel painted `color(texel)`: shelves are
    /// bands of whole rows that no two share, painted in parallel.
    pub fn paint(&self, layout: &Layout, color: impl Fn(u32) -> [u8; 3] + Sync) -> RgbImage {
        use rayon::prelude::*;
        let width = layout.width as usize;
        let mut img = RgbImage::from_pixel(layout.width, layout.height, BACKGROUND);
        let mut bands: Vec<(&Shelf, &mut [u8])> = Vec::with_capacity(layout.shelves.len());
        let mut rest: &mut [u8] = img.as_raw_mut();
        for shelf in &layout.shelves {
            let (band, tail) =
                std::mem::take(&mut rest).split_at_mut(shelf.height as usize * width * 3);
            bands.push((shelf, band));
            rest = tail;
        }
        bands.into_par_iter().for_each(|(shelf, band)| {
            for &t in &shelf.charts {
                let t = t as usize;
                let (x0, y0) = layout.placed[t];
                let b = layout.block[t];
                for py in 0..b {
                    for px in 0..b {
                        let u = (px as f32 + 0.5) / b as f32;
                        // Image rows grow downwards; v grows upwards.
                        let v = (b - 1 - py) as f32 / b as f32 + 0.5 / b as f32;
                        if u + v > 1.0 && b > 1 {
                            continue;
                        }
                        let texel = self.offset[t] + chart_texel(self.subdivisions[t], u, v);
                        let at = ((y0 - shelf.y + py) as usize * width + (x0 + px) as usize) * 3;
                        band[at..at + 3].copy_from_slice(&color(texel));
                    }
                }
            }
        });
        img
    }
}

/// The block layout of [`Atlas::render`] (see [`Atlas::layout`]).
pub struct Layout {
    width: u32,
    height: u32,
    /// Block edge of each chart, in pixels.
    block: Vec<u32>,
    /// Upper left corner of each chart's block.
    placed: Vec<(u32, u32)>,
    shelves: Vec<Shelf>,
}

/// One shelf of blocks: its top row, its height and its charts.
struct Shelf {
    y: u32,
    height: u32,
    charts: Vec<u32>,
}

/// Chart indices by decreasing `block` (at most `max_block`), ties by
/// index: the order a sort by `(Reverse(block), index)` gives, by counting.
fn largest_first(block: &[u32], max_block: u32) -> Vec<usize> {
    let mut start = vec![0usize; max_block as usize + 2];
    for &b in block {
        start[(max_block - b) as usize + 1] += 1;
    }
    for i in 1..start.len() {
        start[i] += start[i - 1];
    }
    let mut order = vec![0usize; block.len()];
    for (t, &b) in block.iter().enumerate() {
        let slot = &mut start[(max_block - b) as usize];
        order[*slot] = t;
        *slot += 1;
    }
    order
}

/// Barycentric coordinates `(u, v)` of `p` projected onto `tri` (weights of
/// the second and third vertex), clamped into the triangle.
fn barycentric(tri: &[Vec3; 3], p: Vec3) -> (f32, f32) {
    let e0 = tri[1] - tri[0];
    let e1 = tri[2] - tri[0];
    let w = p - tri[0];
    let (d00, d01, d11) = (e0.dot(e0), e0.dot(e1), e1.dot(e1));
    let (d20, d21) = (w.dot(e0), w.dot(e1));
    let denom = d00 * d11 - d01 * d01;
    if denom <= 0.0 || !denom.is_finite() {
        return (0.0, 0.0);
    }
    let u = ((d11 * d20 - d01 * d21) / denom).max(0.0);
    let v = ((d00 * d21 - d01 * d20) / denom).max(0.0);
    let s = u + v;
    if s > 1.0 {
        (u / s, v / s)
    } else {
        (u, v)
    }
}

/// Index of the sub-triangle holding barycentric `(u, v)` in a chart cut
/// `n` times along each edge.
///
/// Row `i = floor(u·n)` holds cells `j = 0..n−i`; each cell has a lower
/// sub-triangle (index `2j`) and, except the last of the row, an upper one
/// (`2j+1`). Row `i` starts at `i·(2n − i)`, so the chart's `n²` texels are
/// numbered densely.
fn chart_texel(n: u32, u: f32, v: f32) -> u32 {
    let fu = (u * n as f32).clamp(0.0, n as f32 - 1e-3);
    let fv = (v * n as f32).clamp(0.0, n as f32 - 1e-3);
    let i = (fu as u32).min(n - 1);
    let j = (fv as u32).min(n - 1 - i);
    let upper = i + j < n - 1 && (fu - i as f32) + (fv - j as f32) > 1.0;
    i * (2 * n - i) + 2 * j + upper as u32
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::{hash2, point_in_triangle, unit_f32};
    use crate::scene::testing::room_with_box;

    #[test]
    fn chart_texels_are_numbered_densely_and_equal_in_area() {
        for n in 1..9u32 {
            let mut hits = vec![0u32; (n * n) as usize];
            // A fine uniform sampling of the triangle u, v ≥ 0, u + v ≤ 1.
            let m = 400;
            for a in 0..m {
                for b in 0..m - a {
                    let (u, v) = ((a as f32 + 0.33) / m as f32, (b as f32 + 0.33) / m as f32);
                    let t = chart_texel(n, u, v);
                    assert!(t < n * n, "n={n}: {t}");
                    hits[t as usize] += 1;
                }
            }
            let mean = hits.iter().sum::<u32>() as f32 / hits.len() as f32;
            for (t, &h) in hits.iter().enumerate() {
                assert!(
                    (h as f32 - mean).abs() < 0.1 * mean,
                    "n={n}: texel {t} got {h}, mean {mean}"
                );
            }
        }
    }

    #[test]
    fn texel_areas_are_near_uniform_and_sum_to_the_scene_area() {
        let scene = room_with_box();
        let atlas = Atlas::new(&scene, 0.3).unwrap();
        assert!((atlas.total_area - scene.area()).abs() < 1e-6 * scene.area());
        let sum: f64 = atlas.texel_area.iter().map(|&a| a as f64).sum();
        assert!((sum - scene.area()).abs() < 1e-3, "{sum}");
        let target = 0.09f32;
        for &a in &atlas.texel_area {
            assert!(a <= target * 1.0001, "{a}");
            assert!(a > target / 4.0, "{a}");
        }
        // A point maps into its own triangle's chart.
        for (t, tri) in scene.triangles.iter().enumerate() {
            for k in 0..20u64 {
                let h = hash2(t as u64, k);
                let p = point_in_triangle(tri, unit_f32(hash2(h, 0)), unit_f32(hash2(h, 1)));
                let texel = atlas.texel_at(t as u32, tri, p);
                assert!(texel >= atlas.offset[t] && texel < atlas.offset[t + 1]);
            }
        }
    }

    #[test]
    fn an_absurd_texel_size_is_a_user_error() {
        let scene = room_with_box();
        match Atlas::new(&scene, 1e-4) {
            Err(Error::User(m)) => assert!(m.starts_with("refine.texel_size"), "{m}"),
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn rendering_paints_every_texel() {
        let scene = room_with_box();
        let atlas = Atlas::new(&scene, 0.5).unwrap();
        let img = atlas.render(200_000, |t| [(t % 251) as u8, (t / 251 % 251) as u8, 255]);
        let mut seen = vec![false; atlas.len()];
        for p in img.pixels() {
            if p[2] == 255 {
                seen[p[0] as usize + 251 * p[1] as usize] = true;
            }
        }
        assert!(
            seen.iter().all(|&s| s),
            "{} of {}",
            seen.iter().filter(|&&s| s).count(),
            seen.len()
        );
        assert!(img.width() as u64 * img.height() as u64 <= 400_000);
    }
}
