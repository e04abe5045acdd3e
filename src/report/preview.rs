//! `placement.png`: a quick visual check of where the probes went.
//!
//! Numbers in a report say how many probes were placed and how well they
//! cover the scene, but a technical artist wants to *see* the placement: are
//! the probes spread over the walkable space, did a cluster end up inside a
//! wall, is a room empty? This module draws two orthographic views side by
//! side — a TOP view (looking down −Y, +X to the right, −Z up the image) and a
//! SIDE view (looking along −Z, +X to the right, +Y up; or along +Z when more
//! of the scene faces that way, as for a room open towards +Z) — each showing
//! the scene's triangles with the probes drawn on top. Surfaces darken with
//! depth so that a floor and a box top facing the same way stay apart.
//!
//! It is a small software rasterizer (z-buffer, edge functions, flat shading)
//! so that no GPU or ray-tracing dependency is needed and the output is
//! bit-for-bit deterministic.
//!
//! # Cutaway by back-face culling
//!
//! Indoor scenes are closed rooms built from single-sided triangles whose
//! front faces point into the room. Seen from outside, a plain render of the
//! top view would show nothing but the roof. Culling back faces turns the
//! render into a cutaway for free: the ceiling's front normal points down, so
//! from above we see its back and drop it, while the floor (front normal up)
//! is drawn. Likewise in the side view the wall nearest the viewer faces away
//! (−Z) and disappears, revealing the far wall and the room's contents. Only
//! triangles whose front normal `(b-a)×(c-a)` points towards the viewer
//! (`n.y > 0` in the top view, `n.z > 0` in the side view) are drawn.
//!
//! # Cut plane for buildings modelled from outside
//!
//! Culling alone only opens rooms whose outside is not modelled. A whole
//! building with exterior walls and a roof facing outwards (Dabrovic Sponza
//! has a full outward-facing wall on its +Z side) would show only its facade.
//! When more than half of a view is covered by surfaces within the nearest
//! tenth of the framed box, the view is redrawn with everything nearer than
//! the box's mid-depth removed: a section through the building (kept only if
//! the section still shows something, so a lone floor is never cut away). The probe
//! markers are drawn on top of all geometry regardless of depth, so they
//! always stay visible.
//!
//! # Limitations
//!
//! Shading is flat per triangle with no lighting beyond a view-facing term,
//! and there is no anti-aliasing.

use crate::raster::RgbImage;
use glam::{DVec3, Vec3};

/// What to draw.
pub struct PreviewInput<'a> {
    /// Scene triangles in world space (Y up), counter-clockwise seen from their
    /// front side: the front normal is `(b-a)×(c-a)`. Triangles with
    /// non-finite vertices or zero area are skipped.
    pub triangles: &'a [[Vec3; 3]],
    /// Linear RGB diffuse colour per triangle (same length as `triangles`),
    /// components in `[0,1]`. Components are clamped to `[0,1]` (non-finite
    /// ones read as 0); a triangle without a colour entry is drawn mid-grey.
    pub colors: &'a [[f32; 3]],
    /// Probe positions in world space. Non-finite positions are skipped.
    pub probes: &'a [Vec3],
    /// Surface points no probe sees (coverage holes), drawn as small red marks
    /// where they lie on a visible surface of the view.
    pub holes: &'a [Vec3],
    /// Minimum corner of the box to frame (the probe domain); both views fit
    /// it with a small margin, keeping aspect ratio.
    pub bounds_min: Vec3,
    /// Maximum corner of the box to frame (the probe domain).
    pub bounds_max: Vec3,
}

/// Colour of the empty area of a view.
const BACKGROUND: [u8; 3] = [48, 48, 48];
/// Colour of the strip separating the two views.
const GAP_COLOR: [u8; 3] = [20, 20, 20];
/// Colour of the domain-bounds rectangle.
pub(crate) const BOUNDS_COLOR: [u8; 3] = [200, 200, 200];
/// Fill colour of a probe marker.
pub(crate) const PROBE_FILL: [u8; 3] = [255, 221, 0];
/// Outline colour of a probe marker.
const PROBE_OUTLINE: [u8; 3] = [0, 0, 0];
/// Linear colour used for triangles that have no entry in `colors`.
const MISSING_COLOR: [f32; 3] = [0.5, 0.5, 0.5];

/// Renders the two views side by side into one RGB image: the TOP view on the
/// left, the SIDE view on the right. Each view is `view_size`×`view_size`
/// pixels, the image is `2*view_size + gap` wide (the gap is
/// `max(4, view_size/32)` pixels) and `view_size` high. Pure function: same
/// input, same bytes.
pub fn render_preview(input: &PreviewInput, view_size: u32) -> RgbImage {
    let gap = (view_size / 32).max(4);
    let width = view_size.saturating_mul(2).saturating_add(gap);
    let mut img = RgbImage::from_pixel(width, view_size, GAP_COLOR);
    if view_size == 0 {
        return img;
    }

    let (lo, hi) = framing_box(input);
    let size = view_size as usize;
    // The two views are drawn at once, each into its own buffer, then
    // placed side by side.
    let draw = |view: Projection| -> Vec<u8> {
        let mut buf = vec![0u8; size * size * 3];
        let mut zbuf = vec![f32::NEG_INFINITY; size * size];
        let mut canvas = Canvas {
            buf: &mut buf,
            stride: size * 3,
            x0: 0,
            size,
        };
        canvas.clear(BACKGROUND);
        let frame = Frame::new(view, lo, hi, size);
        let cut = draw_scene(&mut canvas, &mut zbuf, input, view, &frame);
        draw_holes(&mut canvas, &zbuf, input.holes, view, &frame, cut);
        draw_bounds(&mut canvas, view, &frame, lo, hi);
        draw_probes(&mut canvas, input.probes, view, &frame);
        buf
    };
    let (top, side) = rayon::join(|| draw(Projection::Top), || draw(side_view(input)));
    let stride = width as usize * 3;
    let row = size * 3;
    let right = (size + gap as usize) * 3;
    let buf = img.as_raw_mut();
    for y in 0..size {
        let at = y * stride;
        buf[at..at + row].copy_from_slice(&top[y * row..(y + 1) * row]);
        buf[at + right..at + right + row].copy_from_slice(&side[y * row..(y + 1) * row]);
    }
    img
}

/// One of the two orthographic views.
#[derive(Clone, Copy, Debug)]
enum Projection {
    /// Looking down −Y: +X right, −Z up the image, depth grows with +Y.
    Top,
    /// Looking along −Z: +X right, +Y up the image, depth grows with +Z.
    Side,
    /// Looking along +Z: −X right, +Y up the image, depth grows with −Z.
    SideReverse,
}

/// The side view that shows more: looking along −Z unless looking along +Z
/// faces more front-facing area (a room open towards +Z, like the Cornell
/// box with its open front at z = 0, shows its back wall only from there).
fn side_view(input: &PreviewInput) -> Projection {
    let mut facing = 0.0f64;
    for tri in input.triangles {
        if tri.iter().all(|p| p.is_finite()) {
            let [a, b, c] = tri.map(|p| p.as_dvec3());
            facing += (b - a).cross(c - a).z;
        }
    }
    // `facing` > 0: more area faces +Z, i.e. towards a viewer looking along −Z.
    if facing < 0.0 {
        Projection::SideReverse
    } else {
        Projection::Side
    }
}

impl Projection {
    /// Maps a world vector to `[right, up, towards viewer]` view coordinates.
    fn axes(self, p: DVec3) -> [f64; 3] {
        match self {
            Projection::Top => [p.x, -p.z, p.y],
            Projection::Side => [p.x, p.y, p.z],
            Projection::SideReverse => [-p.x, p.y, -p.z],
        }
    }
}

/// The world box both views frame: the input bounds when they are finite,
/// otherwise the box around all finite vertices and probes (or a unit box).
fn framing_box(input: &PreviewInput) -> (DVec3, DVec3) {
    let (a, b) = (input.bounds_min.as_dvec3(), input.bounds_max.as_dvec3());
    if a.is_finite() && b.is_finite() {
        return (a.min(b), b.max(a));
    }
    let mut lo = DVec3::splat(f64::INFINITY);
    let mut hi = DVec3::splat(f64::NEG_INFINITY);
    let points = input
        .triangles
        .iter()
        .flatten()
        .chain(input.probes)
        .filter(|p| p.is_finite());
    for p in points {
        lo = lo.min(p.as_dvec3());
        hi = hi.max(p.as_dvec3());
    }
    if lo.cmple(hi).all() {
        (lo, hi)
    } else {
        (DVec3::splat(-0.5), DVec3::splat(0.5))
    }
}

/// Orthographic mapping from view coordinates to continuous pixel
/// coordinates of one view (pixel `(x, y)` covers `[x, x+1)×[y, y+1)`).
struct Frame {
    center_u: f64,
    center_v: f64,
    scale: f64,
    half: f64,
    /// Probe marker radius in pixels.
    probe_radius: f64,
    /// Depth range of the framed box, nearest to the viewer last.
    depth_range: (f64, f64),
}

impl Frame {
    /// Fits the box `lo..hi` into a `size`×`size` view with a margin.
    fn new(view: Projection, lo: DVec3, hi: DVec3, size: usize) -> Self {
        let (a, b) = (view.axes(lo), view.axes(hi));
        let (u0, u1) = (a[0].min(b[0]), a[0].max(b[0]));
        let (v0, v1) = (a[1].min(b[1]), a[1].max(b[1]));
        let (center_u, center_v) = (0.5 * (u0 + u1), 0.5 * (v0 + v1));
        let size_f = size as f64;
        let probe_radius = (size_f / 120.0).max(3.0);
        let margin = (probe_radius + 2.0).max(0.04 * size_f);
        let avail = (size_f - 2.0 * margin).max(1.0);
        // A flat or point-like box has no extent in this view: fall back to
        // the box's largest extent, then to one world unit.
        let tiny = 1e-9 * (1.0 + center_u.abs().max(center_v.abs()));
        let usable = |e: f64| e > tiny;
        let extent = [(u1 - u0).max(v1 - v0), (hi - lo).max_element()]
            .into_iter()
            .find(|&e| usable(e))
            .unwrap_or(1.0);
        Self {
            center_u,
            center_v,
            scale: avail / extent,
            half: 0.5 * size_f,
            probe_radius,
            depth_range: (a[2].min(b[2]), a[2].max(b[2])),
        }
    }

    /// Brightness factor for a surface at view depth `d`: 1 at the near side
    /// of the framed box, 0.6 at its far side (clamped outside it).
    fn depth_cue(&self, d: f64) -> f64 {
        let (far, near) = self.depth_range;
        if near.partial_cmp(&far) != Some(std::cmp::Ordering::Greater) {
            return 1.0;
        }
        0.6 + 0.4 * ((d - far) / (near - far)).clamp(0.0, 1.0)
    }

    /// Projects a world point to `[pixel x, pixel y, depth]` (depth grows
    /// towards the viewer).
    fn project(&self, view: Projection, p: DVec3) -> [f64; 3] {
        let [u, v, d] = view.axes(p);
        [
            self.half + (u - self.center_u) * self.scale,
            self.half - (v - self.center_v) * self.scale,
            d,
        ]
    }
}

/// A square view inside the output image's raw RGB bytes.
struct Canvas<'b> {
    buf: &'b mut [u8],
    /// Bytes per image row.
    stride: usize,
    /// Horizontal pixel offset of the view in the image.
    x0: usize,
    /// View width and height in pixels.
    size: usize,
}

impl Canvas<'_> {
    /// Sets pixel `(x, y)` of the view; both must be `< size`.
    #[inline]
    fn put(&mut self, x: usize, y: usize, rgb: [u8; 3]) {
        let i = y * self.stride + (self.x0 + x) * 3;
        self.buf[i..i + 3].copy_from_slice(&rgb);
    }

    /// Fills the whole view with one colour.
    fn clear(&mut self, rgb: [u8; 3]) {
        for y in 0..self.size {
            for x in 0..self.size {
                self.put(x, y, rgb);
            }
        }
    }
}

/// Inclusive range of pixel indices in `0..size` whose centres `i + 0.5`
/// lie within `[lo, hi]`, or `None` when it is empty.
fn pixel_span(lo: f64, hi: f64, size: usize) -> Option<(usize, usize)> {
    let first = (lo - 0.5).ceil().max(0.0);
    let last = (hi - 0.5).floor().min(size as f64 - 1.0);
    // NaN comparisons are false, so non-finite spans are rejected too.
    if first <= last {
        Some((first as usize, last as usize))
    } else {
        None
    }
}

/// Edge function `w(x, y) = a·x + b·y + c` of a screen-space edge.
#[derive(Clone, Copy)]
struct Edge {
    a: f64,
    b: f64,
    c: f64,
}

impl Edge {
    /// The edge from `p` to `q`, positive on its left in a y-up frame.
    ///
    /// The coefficients are always computed from the lexicographically
    /// smaller endpoint and then negated if needed, so two triangles sharing
    /// an edge evaluate exactly opposite values at every pixel: a pixel centre
    /// on a shared edge is covered by at least one of them and no cracks open.
    fn new(p: [f64; 3], q: [f64; 3]) -> Self {
        let swap = (q[0], q[1]) < (p[0], p[1]);
        let (p, q) = if swap { (q, p) } else { (p, q) };
        let (dx, dy) = (q[0] - p[0], q[1] - p[1]);
        let e = Edge {
            a: -dy,
            b: dx,
            c: dy * p[0] - dx * p[1],
        };
        if swap {
            e.negate()
        } else {
            e
        }
    }

    fn negate(self) -> Self {
        Edge {
            a: -self.a,
            b: -self.b,
            c: -self.c,
        }
    }
}

/// Rasterizes every front-facing, finite, non-degenerate triangle of the view.
fn draw_triangles(
    canvas: &mut Canvas,
    zbuf: &mut [f32],
    input: &PreviewInput,
    view: Projection,
    frame: &Frame,
    cut: f32,
) {
    for (i, tri) in input.triangles.iter().enumerate() {
        if !tri.iter().all(|p| p.is_finite()) {
            continue;
        }
        let [a, b, c] = tri.map(|p| p.as_dvec3());
        let normal = (b - a).cross(c - a);
        let len = normal.length();
        let facing = view.axes(normal)[2];
        // Back faces, edge-on and zero-area triangles are skipped.
        if !(facing > 0.0 && len > 0.0 && len.is_finite()) {
            continue;
        }
        let depth = view.axes((a + b + c) / 3.0)[2];
        let rgb = shade(input.colors.get(i), facing / len, frame.depth_cue(depth));
        let p = [a, b, c].map(|v| frame.project(view, v));
        rasterize(canvas, zbuf, p, rgb, cut);
    }
}

/// Draws the scene's triangles, cutting the view open at mid-depth when a
/// facade hides it (module docs), unless the facade was all there was to see.
/// Returns the depth beyond which nothing was drawn.
fn draw_scene(
    canvas: &mut Canvas,
    zbuf: &mut [f32],
    input: &PreviewInput,
    view: Projection,
    frame: &Frame,
) -> f64 {
    draw_triangles(canvas, zbuf, input, view, frame, f32::INFINITY);
    if facade_share(zbuf, frame) <= FACADE_SHARE_LIMIT {
        return f64::INFINITY;
    }
    let drawn = drawn_pixels(zbuf);
    let (far, near) = frame.depth_range;
    let mut redraw = |cut: f64, zbuf: &mut [f32]| {
        zbuf.fill(f32::NEG_INFINITY);
        canvas.clear(BACKGROUND);
        draw_triangles(canvas, zbuf, input, view, frame, cut as f32);
    };
    let cut = 0.5 * (far + near);
    redraw(cut, zbuf);
    if (drawn_pixels(zbuf) as f64) < CUT_KEEPS * drawn as f64 {
        redraw(f64::INFINITY, zbuf);
        return f64::INFINITY;
    }
    cut
}

/// Colour of a coverage-hole mark.
pub(crate) const HOLE_COLOR: [u8; 3] = [235, 40, 40];

/// Marks each hole that lies on the surface drawn at its pixel (within 2% of
/// the view's depth range) and was not cut away, as a 2×2 red square.
fn draw_holes(
    canvas: &mut Canvas,
    zbuf: &[f32],
    holes: &[Vec3],
    view: Projection,
    frame: &Frame,
    cut: f64,
) {
    let (far, near) = frame.depth_range;
    let tolerance = 0.02 * (near - far).max(1e-9);
    let size = canvas.size as f64;
    for h in holes.iter().filter(|p| p.is_finite()) {
        let [x, y, d] = frame.project(view, h.as_dvec3());
        if !(x >= 0.0 && y >= 0.0 && x < size && y < size) || d > cut {
            continue;
        }
        let (px, py) = (x as usize, y as usize);
        let z = f64::from(zbuf[py * canvas.size + px]);
        if !z.is_finite() || d < z - tolerance {
            continue;
        }
        for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
            if px + dx < canvas.size && py + dy < canvas.size {
                canvas.put(px + dx, py + dy, HOLE_COLOR);
            }
        }
    }
}

/// Share of the drawn pixels taken by surfaces in the nearest
/// [`FACADE_DEPTH`] of the framed box: high when an outer wall or roof faces
/// the viewer and hides everything behind it.
fn facade_share(zbuf: &[f32], frame: &Frame) -> f64 {
    let (far, near) = frame.depth_range;
    let limit = (near - FACADE_DEPTH * (near - far)) as f32;
    let facade = zbuf
        .iter()
        .filter(|&&z| z.is_finite() && z >= limit)
        .count();
    facade as f64 / drawn_pixels(zbuf).max(1) as f64
}

/// Pixels some surface was drawn on.
fn drawn_pixels(zbuf: &[f32]) -> usize {
    zbuf.iter().filter(|z| z.is_finite()).count()
}

/// The cut view is kept only when it still shows at least this share of the
/// uncut view's drawn pixels.
const CUT_KEEPS: f64 = 0.25;

/// Depth band, as a share of the box, that counts as a facade.
const FACADE_DEPTH: f64 = 0.1;
/// A view whose facade share exceeds this is redrawn cut at mid-depth.
const FACADE_SHARE_LIMIT: f64 = 0.5;

/// Fills the pixels whose centres lie inside the projected triangle `p` and
/// are nearer than what the z-buffer holds.
fn rasterize(canvas: &mut Canvas, zbuf: &mut [f32], p: [[f64; 3]; 3], rgb: [u8; 3], cut: f32) {
    let size = canvas.size;
    let min_x = p[0][0].min(p[1][0]).min(p[2][0]);
    let max_x = p[0][0].max(p[1][0]).max(p[2][0]);
    let min_y = p[0][1].min(p[1][1]).min(p[2][1]);
    let max_y = p[0][1].max(p[1][1]).max(p[2][1]);
    let (Some((x_first, x_last)), Some((y_first, y_last))) = (
        pixel_span(min_x, max_x, size),
        pixel_span(min_y, max_y, size),
    ) else {
        return;
    };

    // Edge i is opposite vertex i, so w_i / area is vertex i's barycentric.
    let mut edges = [
        Edge::new(p[1], p[2]),
        Edge::new(p[2], p[0]),
        Edge::new(p[0], p[1]),
    ];
    let mut area = edges[0].a * p[0][0] + edges[0].b * p[0][1] + edges[0].c;
    if !(area.abs() > 0.0 && area.is_finite()) {
        return;
    }
    if area < 0.0 {
        edges = edges.map(Edge::negate);
        area = -area;
    }
    let inv_area = 1.0 / area;
    let [e0, e1, e2] = edges;
    let (z0, z1, z2) = (p[0][2], p[1][2], p[2][2]);

    for y in y_first..=y_last {
        let py = y as f64 + 0.5;
        let (r0, r1, r2) = (e0.b * py + e0.c, e1.b * py + e1.c, e2.b * py + e2.c);
        let zrow = &mut zbuf[y * size..(y + 1) * size];
        for (x, zslot) in zrow.iter_mut().enumerate().take(x_last + 1).skip(x_first) {
            let px = x as f64 + 0.5;
            let (w0, w1, w2) = (e0.a * px + r0, e1.a * px + r1, e2.a * px + r2);
            if w0 < 0.0 || w1 < 0.0 || w2 < 0.0 {
                continue;
            }
            let depth = ((w0 * z0 + w1 * z1 + w2 * z2) * inv_area) as f32;
            if depth > *zslot && depth <= cut {
                *zslot = depth;
                canvas.put(x, y, rgb);
            }
        }
    }
}

/// Flat shading: `colour × (0.35 + 0.65·|cos|) × cue`, converted to 8-bit
/// sRGB; `cue` in (0, 1] darkens surfaces far from the viewer so that floors
/// and box tops facing the same way stay distinguishable.
fn shade(color: Option<&[f32; 3]>, cos: f64, cue: f64) -> [u8; 3] {
    let k = (0.35 + 0.65 * cos.abs().min(1.0)) * cue;
    color.copied().unwrap_or(MISSING_COLOR).map(|ch| {
        let linear = if ch.is_finite() {
            f64::from(ch.clamp(0.0, 1.0))
        } else {
            0.0
        };
        linear_to_srgb8(linear * k)
    })
}

/// The sRGB transfer function (≈ gamma 1/2.2) for a linear value in `[0,1]`.
fn linear_to_srgb8(x: f64) -> u8 {
    let s = if x <= 0.003_130_8 {
        12.92 * x
    } else {
        1.055 * x.powf(1.0 / 2.4) - 0.055
    };
    (s.clamp(0.0, 1.0) * 255.0 + 0.5) as u8
}

/// Outlines the framing box with one-pixel light-grey lines.
fn draw_bounds(canvas: &mut Canvas, view: Projection, frame: &Frame, lo: DVec3, hi: DVec3) {
    let a = frame.project(view, lo);
    let b = frame.project(view, hi);
    let size = canvas.size as f64;
    // Pixel index of a continuous coordinate, kept one pixel outside the
    // view at most so that far-away edges are simply not drawn.
    let px = |v: f64| v.floor().clamp(-1.0, size) as i64;
    let (x0, x1) = (px(a[0].min(b[0])), px(a[0].max(b[0])));
    let (y0, y1) = (px(a[1].min(b[1])), px(a[1].max(b[1])));
    let n = canvas.size as i64;
    let inside = |v: i64| (0..n).contains(&v);
    for x in x0.max(0)..=x1.min(n - 1) {
        for y in [y0, y1].into_iter().filter(|&y| inside(y)) {
            canvas.put(x as usize, y as usize, BOUNDS_COLOR);
        }
    }
    for y in y0.max(0)..=y1.min(n - 1) {
        for x in [x0, x1].into_iter().filter(|&x| inside(x)) {
            canvas.put(x as usize, y as usize, BOUNDS_COLOR);
        }
    }
}

/// Draws every finite probe as a yellow disc with a one-pixel black outline,
/// on top of the geometry and clipped to the view.
fn draw_probes(canvas: &mut Canvas, probes: &[Vec3], view: Projection, frame: &Frame) {
    let r = frame.probe_radius;
    let (outer, inner) = (r * r, (r - 1.0) * (r - 1.0));
    for probe in probes.iter().filter(|p| p.is_finite()) {
        let [cx, cy, _] = frame.project(view, probe.as_dvec3());
        let (Some((x_first, x_last)), Some((y_first, y_last))) = (
            pixel_span(cx - r, cx + r, canvas.size),
            pixel_span(cy - r, cy + r, canvas.size),
        ) else {
            continue;
        };
        for y in y_first..=y_last {
            let dy = y as f64 + 0.5 - cy;
            for x in x_first..=x_last {
                let dx = x as f64 + 0.5 - cx;
                let d2 = dx * dx + dy * dy;
                if d2 <= inner {
                    canvas.put(x, y, PROBE_FILL);
                } else if d2 <= outer {
                    canvas.put(x, y, PROBE_OUTLINE);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::vec3;

    const SIZE: u32 = 128;

    /// Left edge of the side view in the image.
    fn side_x0(size: u32) -> u32 {
        size + (size / 32).max(4)
    }

    /// Axis-aligned quad as two triangles, counter-clockwise seen from the
    /// side its `normal` points to.
    fn quad(center: Vec3, half: f32, normal: Vec3) -> [[Vec3; 3]; 2] {
        // Two tangents (t, s) with t × s = normal.
        let (t, s) = if normal.y.abs() > 0.5 {
            (Vec3::Z, Vec3::X)
        } else if normal.z.abs() > 0.5 {
            (Vec3::X, Vec3::Y)
        } else {
            (Vec3::Y, Vec3::Z)
        };
        let (t, s) = if t.cross(s).dot(normal) > 0.0 {
            (t, s)
        } else {
            (s, t)
        };
        let (t, s) = (t * half, s * half);
        let (a, b, c, d) = (
            center - t - s,
            center + t - s,
            center + t + s,
            center - t + s,
        );
        [[a, b, c], [a, c, d]]
    }

    fn render(tris: &[[Vec3; 3]], colors: &[[f32; 3]], probes: &[Vec3], size: u32) -> RgbImage {
        render_preview(
            &PreviewInput {
                triangles: tris,
                colors,
                probes,
                holes: &[],
                bounds_min: Vec3::splat(-1.0),
                bounds_max: Vec3::splat(1.0),
            },
            size,
        )
    }

    fn px(img: &RgbImage, x: u32, y: u32) -> [u8; 3] {
        img.get_pixel(x, y)
    }

    /// Which channels are lit: compares colours independently of shading.
    fn lit(c: [u8; 3]) -> [bool; 3] {
        c.map(|v| v > 100)
    }

    fn is_yellow(c: [u8; 3]) -> bool {
        c[0] > 200 && c[1] > 180 && c[2] < 80
    }

    #[test]
    fn side_view_turns_towards_the_open_side() {
        // Only a back wall facing -Z (a room open towards -Z... seen from -Z):
        // the side view looks along +Z and shows it.
        let wall = quad(vec3(0.0, 0.0, 1.0), 1.0, Vec3::NEG_Z);
        let img = render(&wall, &[[0.0, 1.0, 0.0]; 2], &[], SIZE);
        assert_eq!(
            lit(px(&img, side_x0(SIZE) + SIZE / 2, SIZE / 2)),
            [false, true, false]
        );
    }

    #[test]
    fn buildings_modelled_from_outside_are_cut_open() {
        // A roof facing up at the top of the box hides a red floor inside.
        let mut tris = quad(vec3(0.0, 1.0, 0.0), 1.0, Vec3::Y).to_vec();
        tris.extend(quad(vec3(0.0, -0.5, 0.0), 0.8, Vec3::Y));
        let colors = [
            [0.0, 0.0, 1.0],
            [0.0, 0.0, 1.0],
            [1.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
        ];
        let img = render(&tris, &colors, &[], SIZE);
        assert_eq!(
            lit(px(&img, SIZE / 2, SIZE / 2)),
            [true, false, false],
            "roof not cut away"
        );
        // A floor near the top but not covering most of the view stays (no cut).
        let small_roof = quad(vec3(0.8, 1.0, 0.8), 0.1, Vec3::Y);
        let mut tris = small_roof.to_vec();
        tris.extend(quad(vec3(0.0, -0.5, 0.0), 0.5, Vec3::Y));
        let img = render(&tris, &colors, &[], SIZE);
        assert_eq!(lit(px(&img, SIZE / 2, SIZE / 2)), [true, false, false]);
        // World 0.8 is 47 pixels from the centre (see view_orientation).
        assert_eq!(
            lit(px(&img, SIZE / 2 + 47, SIZE / 2 + 47)),
            [false, false, true],
            "small roof should stay"
        );
    }

    #[test]
    fn holes_show_on_visible_surfaces_only() {
        // A floor at y = -1 and a roof quad at y = 0.5 over its left half (x < 0).
        let mut tris = quad(vec3(0.0, -1.0, 0.0), 1.0, Vec3::Y).to_vec();
        tris.extend(quad(vec3(-0.5, 0.5, 0.0), 0.5, Vec3::Y));
        let colors = [[0.2; 3]; 4];
        let holes = [vec3(0.5, -1.0, 0.0), vec3(-0.5, -1.0, 0.0)];
        let img = render_preview(
            &PreviewInput {
                triangles: &tris,
                colors: &colors,
                probes: &[],
                holes: &holes,
                bounds_min: Vec3::splat(-1.0),
                bounds_max: Vec3::splat(1.0),
            },
            SIZE,
        );
        // 0.5 world units is about 29 pixels from the centre (0.8 is 47).
        let visible = px(&img, SIZE / 2 + 29, SIZE / 2);
        let hidden = px(&img, SIZE / 2 - 29, SIZE / 2);
        assert_eq!(visible, HOLE_COLOR, "hole on the open floor is marked");
        assert_ne!(hidden, HOLE_COLOR, "hole under the roof is not");
    }

    #[test]
    fn image_dimensions() {
        let img = render(&[], &[], &[], 100);
        assert_eq!(img.dimensions(), (2 * 100 + 4, 100));
        let img = render(&[], &[], &[], 512);
        assert_eq!(img.dimensions(), (2 * 512 + 16, 512));
        assert_eq!(render(&[], &[], &[], 0).height(), 0);
    }

    #[test]
    fn floor_shows_through_culled_ceiling() {
        let mut tris = quad(vec3(0.0, -1.0, 0.0), 1.0, Vec3::Y).to_vec();
        tris.extend(quad(vec3(0.0, 1.0, 0.0), 1.0, Vec3::NEG_Y));
        let colors = [
            [1.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 0.0, 1.0],
            [0.0, 0.0, 1.0],
        ];
        let img = render(&tris, &colors, &[], SIZE);
        assert_eq!(lit(px(&img, SIZE / 2, SIZE / 2)), [true, false, false]);

        // The ceiling alone is invisible from above.
        let img = render(&tris[2..], &colors[2..], &[], SIZE);
        assert_eq!(px(&img, SIZE / 2, SIZE / 2), BACKGROUND);

        // Flipped to face up (and lowered out of the facade band, so no cut),
        // the higher quad occludes the floor whatever the drawing order: the
        // z-buffer works.
        let mut flipped: Vec<_> = quad(vec3(0.0, 0.5, 0.0), 1.0, Vec3::Y).to_vec();
        flipped.extend_from_slice(&tris[..2]);
        let colors = [
            [0.0, 0.0, 1.0],
            [0.0, 0.0, 1.0],
            [1.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
        ];
        let img = render(&flipped, &colors, &[], SIZE);
        assert_eq!(lit(px(&img, SIZE / 2, SIZE / 2)), [false, false, true]);
    }

    #[test]
    fn side_view_culls_near_wall() {
        // Back wall at z=-1 faces +Z (towards the viewer), front wall at z=+1
        // faces -Z (into the room) and must be culled.
        let mut tris = quad(vec3(0.0, 0.0, -1.0), 1.0, Vec3::Z).to_vec();
        tris.extend(quad(vec3(0.0, 0.0, 1.0), 1.0, Vec3::NEG_Z));
        let colors = [
            [0.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0],
            [0.0, 0.0, 1.0],
        ];
        let img = render(&tris, &colors, &[], SIZE);
        assert_eq!(
            lit(px(&img, side_x0(SIZE) + SIZE / 2, SIZE / 2)),
            [false, true, false]
        );
        // Walls are edge-on in the top view, which stays empty.
        assert_eq!(px(&img, SIZE / 2, SIZE / 2), BACKGROUND);
    }

    #[test]
    fn shading_darkens_tilted_faces() {
        // Front normal (0, 4, 4): cos = 0.707 in both views.
        let slope = [[
            vec3(-1.0, -1.0, 1.0),
            vec3(1.0, -1.0, 1.0),
            vec3(0.0, 1.0, -1.0),
        ]];
        let img = render(&slope, &[[1.0, 1.0, 1.0]], &[], SIZE);
        // Centroid (0, -1/3, 1/3) in the box [-1, 1]³: depth cue 0.6 + 0.4·(1/3)
        // from above and 0.6 + 0.4·(2/3) from the side.
        let lit = 0.35 + 0.65 * std::f64::consts::FRAC_1_SQRT_2;
        let top = linear_to_srgb8(lit * (0.6 + 0.4 / 3.0));
        let side = linear_to_srgb8(lit * (0.6 + 0.8 / 3.0));
        assert!(top > 120 && top < side && side < 250, "{top} {side}");
        assert_eq!(px(&img, SIZE / 2, SIZE / 2), [top; 3]);
        assert_eq!(px(&img, side_x0(SIZE) + SIZE / 2, SIZE / 2), [side; 3]);
        // Face-on white at the near side of the box is full white.
        let floor = quad(Vec3::Y, 1.0, Vec3::Y);
        let img = render(&floor, &[[1.0; 3]; 2], &[], SIZE);
        assert_eq!(px(&img, SIZE / 2, SIZE / 2), [255; 3]);
    }

    #[test]
    fn probe_at_centre_is_yellow_in_both_views() {
        let floor = quad(vec3(0.0, -1.0, 0.0), 1.0, Vec3::Y);
        let wall = quad(vec3(0.0, 0.0, -1.0), 1.0, Vec3::Z);
        let tris = [floor[0], floor[1], wall[0], wall[1]];
        let colors = [[0.2, 0.2, 0.8]; 4];
        let img = render(&tris, &colors, &[Vec3::ZERO], SIZE);
        assert!(is_yellow(px(&img, SIZE / 2, SIZE / 2)));
        assert!(is_yellow(px(&img, side_x0(SIZE) + SIZE / 2, SIZE / 2)));
        // Without the probe, the same pixels show geometry.
        let img = render(&tris, &colors, &[], SIZE);
        assert!(!is_yellow(px(&img, SIZE / 2, SIZE / 2)));
        assert!(!is_yellow(px(&img, side_x0(SIZE) + SIZE / 2, SIZE / 2)));
    }

    #[test]
    fn view_orientation() {
        // +X is to the right in both views, +Z is down in the top view, +Y is
        // up in the side view.
        let img = render(&[], &[], &[vec3(0.8, 0.0, 0.0)], SIZE);
        assert!(is_yellow(px(&img, SIZE / 2 + 47, SIZE / 2)));
        assert!(is_yellow(px(&img, side_x0(SIZE) + SIZE / 2 + 47, SIZE / 2)));
        let img = render(&[], &[], &[vec3(0.0, 0.0, 0.8)], SIZE);
        assert!(is_yellow(px(&img, SIZE / 2, SIZE / 2 + 47)));
        let img = render(&[], &[], &[vec3(0.0, 0.8, 0.0)], SIZE);
        assert!(is_yellow(px(&img, side_x0(SIZE) + SIZE / 2, SIZE / 2 - 47)));
    }

    #[test]
    fn probes_are_drawn_over_geometry_and_clipped() {
        // A probe below the floor is still visible from above.
        let floor = quad(vec3(0.0, 0.0, 0.0), 1.0, Vec3::Y);
        let img = render(&floor, &[[1.0; 3]; 2], &[vec3(0.0, -0.5, 0.0)], SIZE);
        assert!(is_yellow(px(&img, SIZE / 2, SIZE / 2)));
        // A probe just outside the bounds, still in the view, is drawn.
        let img = render(&[], &[], &[vec3(1.08, 0.0, 0.0)], SIZE);
        assert!(is_yellow(px(&img, SIZE - 1, SIZE / 2)));
        // One straddling the view's edge is clipped there and does not spill
        // into the gap or the other view.
        let img = render(&[], &[], &[vec3(1.12, 0.0, 0.0)], SIZE);
        assert_eq!(px(&img, SIZE - 1, SIZE / 2), PROBE_OUTLINE);
        for y in 0..SIZE {
            for x in SIZE..side_x0(SIZE) + 2 {
                assert_ne!(px(&img, x, y), PROBE_OUTLINE, "({x}, {y})");
            }
        }
        // Ones entirely outside leave the image untouched.
        let far = render(&[], &[], &[vec3(1.3, 0.0, 0.0), vec3(1e30, 0.0, 0.0)], SIZE);
        let empty = render(&[], &[], &[], SIZE);
        assert_eq!(far.as_raw(), empty.as_raw());
    }

    #[test]
    fn deterministic() {
        let mut tris = Vec::new();
        let mut colors = Vec::new();
        for i in 0..50 {
            let f = i as f32 / 50.0;
            tris.push([
                vec3(f - 1.0, f, -1.0 + f),
                vec3(1.0 - f, f * 0.5, 0.3),
                vec3(0.1, -f, 1.0 - f),
            ]);
            colors.push([f, 1.0 - f, 0.5]);
        }
        let probes = [vec3(0.2, 0.3, 0.4), vec3(-0.9, 0.9, 0.0)];
        let a = render(&tris, &colors, &probes, SIZE);
        let b = render(&tris, &colors, &probes, SIZE);
        assert_eq!(a.as_raw(), b.as_raw());
    }

    #[test]
    fn empty_scene_draws_background_bounds_and_probes() {
        let img = render(&[], &[], &[Vec3::ZERO], SIZE);
        assert_eq!(px(&img, 1, 1), BACKGROUND);
        assert_eq!(px(&img, side_x0(SIZE) + 1, 1), BACKGROUND);
        assert_eq!(px(&img, SIZE, 1), GAP_COLOR);
        assert!(is_yellow(px(&img, SIZE / 2, SIZE / 2)));
        // The bounds rectangle crosses the middle row in both views.
        let row: Vec<_> = (0..SIZE).map(|x| px(&img, x, SIZE / 2)).collect();
        assert_eq!(row.iter().filter(|&&c| c == BOUNDS_COLOR).count(), 2);
        let row: Vec<_> = (0..SIZE)
            .map(|x| px(&img, side_x0(SIZE) + x, SIZE / 2))
            .collect();
        assert_eq!(row.iter().filter(|&&c| c == BOUNDS_COLOR).count(), 2);
    }

    #[test]
    fn degenerate_and_non_finite_input_is_skipped() {
        let floor = quad(vec3(0.0, -1.0, 0.0), 1.0, Vec3::Y);
        let clean = render(&floor, &[[0.3, 0.6, 0.9]; 2], &[Vec3::ZERO], SIZE);
        let p = vec3(0.1, 0.5, 0.1);
        let nan = f32::NAN;
        let tris = [
            [p, p, p],
            [p, p + Vec3::X, p + 2.0 * Vec3::X],
            [
                vec3(nan, 0.5, 0.0),
                vec3(1.0, 0.5, 0.0),
                vec3(0.0, 0.5, 1.0),
            ],
            [vec3(0.0, f32::INFINITY, 0.0), Vec3::X, Vec3::Z],
            floor[0],
            floor[1],
        ];
        let colors = [[1.0, 0.0, 0.0]; 4]
            .into_iter()
            .chain([[0.3, 0.6, 0.9]; 2])
            .collect::<Vec<_>>();
        let probes = [Vec3::ZERO, Vec3::splat(nan), Vec3::splat(f32::INFINITY)];
        let dirty = render(&tris, &colors, &probes, SIZE);
        assert_eq!(clean.as_raw(), dirty.as_raw());
    }

    #[test]
    fn flat_or_broken_bounds_do_not_divide_by_zero() {
        let floor = quad(Vec3::ZERO, 1.0, Vec3::Y);
        let colors = [[1.0, 0.0, 0.0]; 2];
        for (lo, hi) in [
            (vec3(-1.0, 0.0, -1.0), vec3(1.0, 0.0, 1.0)),
            (Vec3::ZERO, Vec3::ZERO),
            (vec3(0.0, -1.0, 0.0), vec3(0.0, 1.0, 0.0)),
            (Vec3::splat(f32::NAN), Vec3::ONE),
            (Vec3::splat(1.0), Vec3::splat(-1.0)),
        ] {
            let img = render_preview(
                &PreviewInput {
                    triangles: &floor,
                    colors: &colors,
                    probes: &[],
                    holes: &[],
                    bounds_min: lo,
                    bounds_max: hi,
                },
                SIZE,
            );
            assert_eq!(img.dimensions(), (2 * SIZE + 4, SIZE));
            assert_eq!(
                lit(px(&img, SIZE / 2 + 1, SIZE / 2 + 1)),
                [true, false, false],
                "{lo} {hi}"
            );
        }
    }

    #[test]
    fn missing_or_bad_colours_do_not_panic() {
        let floor = quad(Vec3::ZERO, 1.0, Vec3::Y);
        let img = render(&floor, &[], &[], SIZE);
        // The floor at y = 0 lies mid-depth in [-1, 1]³: depth cue 0.8.
        let grey = linear_to_srgb8(0.5 * 0.8);
        assert_eq!(px(&img, SIZE / 2, SIZE / 2), [grey; 3]);
        let img = render(&floor, &[[f32::NAN, 2.0, -1.0]; 2], &[], SIZE);
        assert_eq!(px(&img, SIZE / 2, SIZE / 2), [0, linear_to_srgb8(0.8), 0]);
    }

    #[test]
    fn no_cracks_in_jittered_mesh() {
        // A floor split into many thin, irregular triangles: every pixel
        // inside it must be covered.
        let n = 23;
        let mut grid = vec![Vec3::ZERO; (n + 1) * (n + 1)];
        let mut state = 12345u32;
        let mut rand = || {
            state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (state >> 8) as f32 / (1u32 << 24) as f32 - 0.5
        };
        for j in 0..=n {
            for i in 0..=n {
                let mut x = -1.0 + 2.0 * i as f32 / n as f32;
                let mut z = -1.0 + 2.0 * j as f32 / n as f32;
                if i > 0 && i < n && j > 0 && j < n {
                    x += rand() * 0.6 / n as f32;
                    z += rand() * 0.6 / n as f32;
                }
                grid[j * (n + 1) + i] = vec3(x, rand() * 0.01, z);
            }
        }
        let mut tris = Vec::new();
        for j in 0..n {
            for i in 0..n {
                let v = |a: usize, b: usize| grid[(j + b) * (n + 1) + i + a];
                // Counter-clockwise seen from above (+Y): a → (a + Z) → (a + X).
                tris.push([v(0, 0), v(0, 1), v(1, 1)]);
                tris.push([v(0, 0), v(1, 1), v(1, 0)]);
            }
        }
        assert!(tris
            .iter()
            .all(|t| (t[1] - t[0]).cross(t[2] - t[0]).y > 0.0));
        let colors = vec![[1.0, 1.0, 1.0]; tris.len()];
        let img = render(&tris, &colors, &[], 300);
        let frame = Frame::new(Projection::Top, DVec3::splat(-1.0), DVec3::splat(1.0), 300);
        let [x0, y0, _] = frame.project(Projection::Top, DVec3::new(-1.0, 0.0, -1.0));
        let [x1, y1, _] = frame.project(Projection::Top, DVec3::new(1.0, 0.0, 1.0));
        let (x0, y0) = (x0.ceil() as u32 + 1, y0.ceil() as u32 + 1);
        let (x1, y1) = (x1.floor() as u32 - 1, y1.floor() as u32 - 1);
        assert!(x1 > x0 + 200 && y1 > y0 + 200);
        for y in y0..y1 {
            for x in x0..x1 {
                let c = px(&img, x, y);
                assert!(c[0] > 200, "crack at ({x}, {y}): {c:?}");
            }
        }
    }
}
