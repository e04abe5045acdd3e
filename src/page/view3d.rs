//! The interactive 3D view of `report.html` (every run's page and
//! `compare`'s): the scene's mesh, the probes coloured by clearance, the
//! coverage holes as red points, and on hover a probe's figures and its
//! influence box, drawn with three.js in the browser.
//!
//! Everything travels inside the page, so that it opens offline from
//! `file://`: three.js (vendored from npm, `vendor/README.md`) as text in
//! non-executed `<script>` blocks that `view3d.js` turns into `blob:` module
//! URLs, and the data as one JSON block of base64 typed arrays:
//!
//! - the mesh, quantized to u16 per axis over the scene's bounds (about
//!   1/65 535 of its size; vertices merged where they quantize alike) and
//!   indexed with u16 or u32, grouped by material; at most
//!   [`TRIANGLE_BUDGET`] triangles, the largest kept when a scene has more
//!   (the page says so);
//! - per probe: position, clearance (the SDF at its voxel, as in
//!   `probes.json`) and its influence box, which here is the box of the SVO
//!   leaf cells whose lists name it ([`Svo::listings`]): where a renderer
//!   reading `svo.bin` consults the probe, fallback cells included; at most
//!   [`PROBE_BUDGET`] probes a set, every k-th beyond;
//! - the coverage holes, at most [`crate::report::HOLE_SAMPLE`] a set.
//!
//! Coordinates are the scene's local ones (world minus
//! [`Scene::origin`], which the page adds back for the figures it shows),
//! in f32 as the stages compute them. The page is deterministic: the same
//! inputs give the same bytes.

use super::markup::{base64, escape};
use crate::scene::{Bounds, Scene};
use crate::sdf::Sdf;
use crate::svo::Svo;
use glam::Vec3;
use serde::Serialize;
use std::collections::HashMap;
use std::fmt::Write as _;
use std::hash::{BuildHasherDefault, Hasher};

/// Most triangles the view draws; beyond it, the largest are kept.
pub const TRIANGLE_BUDGET: usize = 100_000;

/// Most probes a set draws; beyond it, every k-th.
pub const PROBE_BUDGET: usize = 20_000;

/// three.js's core (vendored, `vendor/README.md`).
pub(crate) const THREE_CORE: &str = include_str!("vendor/three.core.min.js");
/// three.js's WebGL renderer module; imports the core as `./three.core.min.js`.
pub(crate) const THREE_MODULE: &str = include_str!("vendor/three.module.min.js");
/// three.js's orbit controls addon; imports `three`.
pub(crate) const ORBIT_CONTROLS: &str = include_str!("vendor/OrbitControls.js");
/// The viewer: reads the data block, loads three.js, draws, answers hovers.
const VIEWER: &str = include_str!("view3d.js");

/// Colours of the view, sRGB: clearance from near a surface (first) to
/// the largest clearance of the page (last), evenly spaced.
const CLEARANCE_RAMP: [[u8; 3]; 5] = [
    [70, 110, 255],
    [0, 200, 220],
    [80, 220, 100],
    [240, 230, 60],
    [255, 255, 255],
];
/// A probe in solid space (negative clearance).
const SOLID: [u8; 3] = [255, 0, 255];
/// A probe outside the SDF's grid (no clearance).
const OUTSIDE: [u8; 3] = [140, 140, 140];
/// A probe's influence box on hover.
const BOX: [u8; 3] = [255, 150, 40];
/// The domain's frame, as in `placement.png`.
const DOMAIN: [u8; 3] = crate::report::preview::BOUNDS_COLOR;
/// The coverage holes, as in `placement.png`.
const HOLE: [u8; 3] = crate::report::preview::HOLE_COLOR;
/// The background.
const BACKGROUND: [u8; 3] = [30, 34, 40];

/// The mesh, encoded for the page.
#[derive(Debug, Clone, Serialize)]
pub struct Mesh {
    /// The scene's triangles.
    pub triangles: usize,
    /// Triangles drawn (at most [`TRIANGLE_BUDGET`]; those that quantize
    /// to a line are left out too).
    pub shown: usize,
    /// Distinct quantized vertices.
    pub vertices: usize,
    /// Lower corner of the quantization box (local coordinates).
    pub min: [f32; 3],
    /// Its size: vertex = min + q / 65 535 · size.
    pub size: [f32; 3],
    /// Base64 of the vertices, u16 × 3 little-endian each.
    pub positions: String,
    /// 2 or 4: the width of an index.
    pub index_bytes: u32,
    /// Base64 of the indices, three per triangle, little-endian.
    pub indices: String,
    /// Per material, in index order: `start` and `count` in indices and
    /// the diffuse colour (linear; the emission, scaled to 1, for lights).
    pub groups: Vec<Group>,
}

/// The triangles of one material.
#[derive(Debug, Clone, Serialize)]
pub struct Group {
    /// First index.
    pub start: u32,
    /// Indices (three per triangle).
    pub count: u32,
    /// Linear RGB.
    pub color: [f32; 3],
}

/// A hasher for the 48-bit packed quantized vertices of [`Mesh::new`]:
/// one multiply (the keys are not chosen by an adversary), where the
/// default SipHash was most of the mesh's time on Dabrovic Sponza.
#[derive(Default)]
struct PackedHasher(u64);

impl Hasher for PackedHasher {
    fn finish(&self) -> u64 {
        self.0
    }

    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 = (self.0.rotate_left(8) ^ b as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15);
        }
    }

    fn write_u64(&mut self, v: u64) {
        self.0 = (v ^ v >> 29).wrapping_mul(0x9E37_79B9_7F4A_7C15);
        self.0 ^= self.0 >> 32;
    }
}

impl Mesh {
    /// The mesh of `scene`, at most [`TRIANGLE_BUDGET`] triangles.
    pub fn new(scene: &Scene) -> Mesh {
        let kept = kept_triangles(scene, TRIANGLE_BUDGET);
        let (min, size) = (scene.bounds.min, scene.bounds.size());
        let quantize = |p: Vec3| -> [u16; 3] {
            let u =
                ((p - min) / size.max(Vec3::splat(f32::MIN_POSITIVE))).clamp(Vec3::ZERO, Vec3::ONE);
            (u * 65535.0).round().to_array().map(|c| c as u16)
        };
        let mut index_of: HashMap<u64, u32, BuildHasherDefault<PackedHasher>> = HashMap::default();
        let mut vertices: Vec<[u16; 3]> = Vec::new();
        let mut indices: Vec<u32> = Vec::with_capacity(3 * kept.len());
        let mut groups: Vec<Group> = Vec::new();
        let mut current = None;
        for t in kept {
            let corners = scene.triangles[t].map(|p| {
                let q = quantize(p);
                let key = q[0] as u64 | (q[1] as u64) << 16 | (q[2] as u64) << 32;
                *index_of.entry(key).or_insert_with(|| {
                    vertices.push(q);
                    vertices.len() as u32 - 1
                })
            });
            if corners[0] == corners[1] || corners[1] == corners[2] || corners[0] == corners[2] {
                continue;
            }
            let material = scene.material_ids[t];
            if current != Some(material) {
                current = Some(material);
                groups.push(Group {
                    start: indices.len() as u32,
                    count: 0,
                    color: colour_of(scene, &scene.materials[material as usize]),
                });
            }
            indices.extend(corners);
            if let Some(g) = groups.last_mut() {
                g.count += 3;
            }
        }
        let index_bytes = if vertices.len() <= u16::MAX as usize {
            2
        } else {
            4
        };
        let index_data: Vec<u8> = if index_bytes == 2 {
            indices
                .iter()
                .flat_map(|&i| (i as u16).to_le_bytes())
                .collect()
        } else {
            indices.iter().flat_map(|&i| i.to_le_bytes()).collect()
        };
        let position_data: Vec<u8> = vertices
            .iter()
            .flatten()
            .flat_map(|c| c.to_le_bytes())
            .collect();
        Mesh {
            triangles: scene.triangles.len(),
            shown: indices.len() / 3,
            vertices: vertices.len(),
            min: min.to_array(),
            size: size.to_array(),
            positions: base64(&position_data),
            index_bytes,
            indices: base64(&index_data),
            groups,
        }
    }
}

/// The triangles the view draws, by material then file order: all of
/// them within `budget`, else the `budget` largest (ties by index), so
/// that walls and floors stay and small detail goes.
fn kept_triangles(scene: &Scene, budget: usize) -> Vec<usize> {
    let mut kept: Vec<usize> = (0..scene.triangles.len()).collect();
    if kept.len() > budget {
        let areas: Vec<f64> = scene.triangle_areas().collect();
        kept.sort_by(|&a, &b| areas[b].total_cmp(&areas[a]).then(a.cmp(&b)));
        kept.truncate(budget);
    }
    kept.sort_by_key(|&t| (scene.material_ids[t], t));
    kept
}

/// The colour a material is drawn in: its diffuse albedo, or for an
/// emitter its emission scaled to a largest channel of 1, each times the
/// mean of its texture where it has one.
fn colour_of(scene: &Scene, m: &crate::scene::Material) -> [f32; 3] {
    let mean = |map: Option<crate::scene::texture::TextureMap>, c: [f32; 3]| match map {
        Some(map) => (glam::Vec3::from(c) * scene.textures[map.texture as usize].mean()).to_array(),
        None => c,
    };
    let emission = mean(m.emission_map, m.emission);
    let e = emission.iter().copied().fold(0.0f32, f32::max);
    if e > 0.0 {
        emission.map(|c| c / e)
    } else {
        mean(m.diffuse_map, m.diffuse)
    }
}

/// One probe set of the view (a run's placement, or one of `compare`'s).
#[derive(Debug, Clone, Serialize)]
pub struct ProbeSet {
    /// Its name, e.g. `sdf-skeleton+refine` or `grid:4x2x4`.
    pub name: String,
    /// Probes in the set.
    pub probes: usize,
    /// Probes drawn (at most [`PROBE_BUDGET`]).
    pub shown: usize,
    /// Base64 of `shown` records of 13 little-endian f32: index, position
    /// (3), clearance (NaN outside the grid), influence box min (3) and
    /// max (3) (NaN when no leaf lists the probe), leaf cells listing it,
    /// and cells listing it first.
    pub data: String,
    /// Coverage holes in all (coverable samples no probe sees).
    pub holes: usize,
    /// Holes drawn.
    pub holes_shown: usize,
    /// Base64 of the holes drawn, 3 little-endian f32 each.
    pub hole_data: String,
    /// Largest clearance of the set's probes (0 when none is positive).
    #[serde(skip)]
    pub max_clearance: f32,
}

/// Floats of one probe record in [`ProbeSet::data`].
const PROBE_RECORD: usize = 13;

impl ProbeSet {
    /// The set `name` of probes at `positions` (local coordinates), indexed
    /// by `svo` (in the same frame), scored against `sdf`, with `holes`
    /// (already sampled) of `holes_total`.
    pub fn new(
        name: &str,
        positions: &[Vec3],
        sdf: &Sdf,
        svo: &Svo,
        holes: &[Vec3],
        holes_total: usize,
    ) -> ProbeSet {
        let listings = svo.listings();
        let step = positions.len().div_ceil(PROBE_BUDGET).max(1);
        let mut floats: Vec<f32> = Vec::new();
        let mut max_clearance = 0.0f32;
        let mut shown = 0;
        for (i, &p) in positions.iter().enumerate().step_by(step) {
            let clearance = sdf.voxel_at(p).map_or(f32::NAN, |v| sdf.distance[v]);
            if clearance.is_finite() {
                max_clearance = max_clearance.max(clearance);
            }
            floats.push(i as f32);
            floats.extend(p.to_array());
            floats.push(clearance);
            match listings.get(i).filter(|l| l.cells > 0) {
                Some(l) => {
                    let lo = svo.origin + l.lo.as_vec3() * svo.leaf_size;
                    let hi = svo.origin + l.hi.as_vec3() * svo.leaf_size;
                    floats.extend(lo.to_array());
                    floats.extend(hi.to_array());
                    floats.extend([l.cells as f32, l.first as f32]);
                }
                None => floats.extend([f32::NAN; 6].into_iter().chain([0.0, 0.0])),
            }
            shown += 1;
        }
        debug_assert_eq!(floats.len(), shown * PROBE_RECORD);
        ProbeSet {
            name: name.to_string(),
            probes: positions.len(),
            shown,
            data: floats_base64(&floats),
            holes: holes_total,
            holes_shown: holes.len(),
            hole_data: floats_base64(&holes.iter().flat_map(|h| h.to_array()).collect::<Vec<_>>()),
            max_clearance,
        }
    }
}

/// Base64 of `v` as little-endian f32.
fn floats_base64(v: &[f32]) -> String {
    let bytes: Vec<u8> = v.iter().flat_map(|f| f.to_le_bytes()).collect();
    base64(&bytes)
}

/// The whole view: one mesh, one or more probe sets.
pub struct View3d {
    /// World position of the local coordinates' zero.
    pub origin: [f64; 3],
    /// The probe domain (local).
    pub domain: Bounds,
    /// The scene.
    pub mesh: Mesh,
    /// The probe sets, the first shown first.
    pub sets: Vec<ProbeSet>,
}

/// The JSON block the viewer reads.
#[derive(Serialize)]
struct Data<'a> {
    origin: [f64; 3],
    domain: [[f32; 3]; 2],
    mesh: &'a Mesh,
    sets: &'a [ProbeSet],
    record: usize,
    colours: Colours,
}

/// The view's colours (sRGB) and the clearance scale.
#[derive(Serialize)]
struct Colours {
    clearance_max: f32,
    ramp: [[u8; 3]; 5],
    solid: [u8; 3],
    outside: [u8; 3],
    hole: [u8; 3],
    box_: [u8; 3],
    domain: [u8; 3],
    background: [u8; 3],
}

impl View3d {
    /// The view of `scene` over `domain` with `sets`.
    pub fn new(scene: &Scene, domain: &Bounds, sets: Vec<ProbeSet>) -> View3d {
        View3d {
            origin: scene.origin.to_array(),
            domain: *domain,
            mesh: Mesh::new(scene),
            sets,
        }
    }

    /// The largest clearance over every set: one colour scale for the page.
    fn clearance_max(&self) -> f32 {
        self.sets
            .iter()
            .map(|s| s.max_clearance)
            .fold(0.0, f32::max)
    }

    /// The section of the page: controls, canvas, legend and notes. The
    /// data and scripts go at the end of the body ([`View3d::scripts`]).
    pub fn section(&self, h: &mut String, intro: &str) {
        let _ = writeln!(
            h,
            "<section id=\"view3d\">\n<h2>3D view</h2>\n<p>{intro} Drag to orbit, right-drag (or shift-drag) to pan, scroll to zoom; hover a probe for its figures and its influence box.</p>"
        );
        h.push_str("<div class=\"v3-bar\">");
        if self.sets.len() > 1 {
            h.push_str("<label>placement <select id=\"v3-set\">");
            for (i, s) in self.sets.iter().enumerate() {
                let _ = write!(
                    h,
                    "<option value=\"{i}\">{} ({} probes)</option>",
                    escape(&s.name),
                    s.probes
                );
            }
            h.push_str("</select></label>");
        }
        h.push_str(
            "<label><input type=\"checkbox\" id=\"v3-mesh\" checked> scene</label>\
             <label><input type=\"checkbox\" id=\"v3-holes\" checked> holes</label>\
             <label><input type=\"checkbox\" id=\"v3-xray\"> x-ray</label>\
             <label><input type=\"checkbox\" id=\"v3-backfaces\"> back faces</label>\
             <label>cut above <input type=\"range\" id=\"v3-cut\" min=\"0\" max=\"1000\" value=\"1000\"></label>\
             <button type=\"button\" id=\"v3-reset\">reset view</button></div>\n",
        );
        h.push_str(
            "<div class=\"v3-stage\"><canvas id=\"v3-canvas\"></canvas><div id=\"v3-info\" class=\"v3-info\">Hover a probe.</div></div>\n",
        );
        self.legend(h);
        let m = &self.mesh;
        let mesh_note = if m.shown < m.triangles {
            format!(
                "<b>The mesh is reduced</b>: the {} largest of its {} triangles are drawn, to keep the page small.",
                m.shown, m.triangles
            )
        } else {
            format!("The mesh: all {} triangles.", m.triangles)
        };
        let _ = writeln!(
            h,
            "<p class=\"meta\">{mesh_note} Back faces are hidden unless asked for, which opens closed rooms seen from outside (as in <code>placement.png</code>); \
             x-ray shows the scene faint, probes and holes through it; “cut above” hides everything above a height. <span id=\"v3-note\"></span> <span id=\"v3-xray-note\"></span></p>\n\
             <p id=\"v3-status\" data-state=\"loading\">Loading the 3D view (it needs JavaScript and WebGL)…</p>\n</section>"
        );
    }

    /// The colour legend: the clearance ramp with its scale, the special
    /// probe colours, holes and boxes.
    fn legend(&self, h: &mut String) {
        let stops: Vec<String> = CLEARANCE_RAMP
            .iter()
            .enumerate()
            .map(|(i, c)| {
                format!(
                    "{} {:.0}%",
                    css(*c),
                    100.0 * i as f64 / (CLEARANCE_RAMP.len() - 1) as f64
                )
            })
            .collect();
        let _ = writeln!(
            h,
            "<div class=\"legend\" id=\"v3-legend\"><span>probe clearance (distance to the nearest surface): 0</span>\
             <span class=\"ramp\" style=\"background:linear-gradient(to right,{})\"></span><span>{:.3}</span>\
             <span><i class=\"dot\" style=\"background:{}\"></i>in solid</span>\
             <span><i class=\"dot\" style=\"background:{}\"></i>outside the SDF grid</span>\
             <span><i class=\"sq\" style=\"background:{}\"></i>coverage hole (a coverable surface sample no probe sees)</span>\
             <span><i class=\"box\" style=\"border-color:{}\"></i>influence box of the probe under the pointer: the SVO leaf cells that list it</span>\
             <span><i class=\"box\" style=\"border-color:{}\"></i>domain</span></div>",
            stops.join(","),
            self.clearance_max(),
            css(SOLID),
            css(OUTSIDE),
            css(HOLE),
            css(BOX),
            css(DOMAIN),
        );
    }

    /// The data block, three.js and the viewer, for the end of the body.
    pub fn scripts(&self, h: &mut String) {
        let data = Data {
            origin: self.origin,
            domain: [self.domain.min.to_array(), self.domain.max.to_array()],
            mesh: &self.mesh,
            sets: &self.sets,
            record: PROBE_RECORD,
            colours: Colours {
                clearance_max: self.clearance_max(),
                ramp: CLEARANCE_RAMP,
                solid: SOLID,
                outside: OUTSIDE,
                hole: HOLE,
                box_: BOX,
                domain: DOMAIN,
                background: BACKGROUND,
            },
        };
        // `</` only occurs inside JSON strings (names), where `<\/` reads
        // the same; the block cannot end early.
        let json = serde_json::to_string(&data)
            .unwrap_or_default()
            .replace("</", "<\\/");
        let _ = writeln!(
            h,
            "<script type=\"application/json\" id=\"v3-data\">{json}</script>"
        );
        for (id, text) in [
            ("v3-three-core", THREE_CORE),
            ("v3-three", THREE_MODULE),
            ("v3-orbit", ORBIT_CONTROLS),
        ] {
            debug_assert!(inert(text), "{id} would end its script block");
            let _ = writeln!(
                h,
                "<script type=\"text/x-probeplace-module\" id=\"{id}\">{text}</script>"
            );
        }
        let _ = writeln!(h, "<script>{VIEWER}</script>");
    }
}

/// Whether `text` can sit in a `<script>` block as it is: no `</script`,
/// and no `<!--` or `<script` that would change how the HTML parser reads
/// the block (the vendored files are checked by a test).
fn inert(text: &str) -> bool {
    let lower = text.to_ascii_lowercase();
    !lower.contains("</script") && !lower.contains("<!--") && !lower.contains("<script")
}

/// `#rrggbb`.
fn css(c: [u8; 3]) -> String {
    format!("#{:02x}{:02x}{:02x}", c[0], c[1], c[2])
}

/// The view's styles, part of the page's style sheet.
pub(crate) const STYLE: &str = ".v3-bar{display:flex;flex-wrap:wrap;gap:14px;align-items:center;margin:6px 0;font-size:0.9em}\
.v3-stage{position:relative;max-width:1100px}#v3-canvas{display:block;width:100%;height:620px;border-radius:4px;background:#1e2228}\
.v3-info{position:absolute;left:8px;top:8px;max-width:60%;padding:4px 8px;background:rgba(0,0,0,0.6);color:#eee;font-size:0.8em;border-radius:4px;white-space:pre-line;pointer-events:none}\
.legend{display:flex;flex-wrap:wrap;gap:6px 16px;align-items:center;font-size:0.8em;color:#444;margin:6px 0}\
.legend .ramp{display:inline-block;width:160px;height:12px;border:1px solid #999}\
.legend i{display:inline-block;width:11px;height:11px;margin-right:4px;vertical-align:-1px}\
.legend i.dot{border-radius:50%}.legend i.box{border:2px solid;width:9px;height:9px}\
#v3-status{font-size:0.85em;color:#555}#v3-status[data-state=failed]{color:#b00}";

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::testing::room_with_box;

    #[test]
    fn vendored_files_inline_safely() {
        for (name, text) in [
            ("three.core.min.js", THREE_CORE),
            ("three.module.min.js", THREE_MODULE),
            ("OrbitControls.js", ORBIT_CONTROLS),
            ("view3d.js", VIEWER),
        ] {
            assert!(inert(text), "{name} cannot be inlined in a <script> block");
        }
        // The imports view3d.js rewrites to blob: URLs.
        assert!(THREE_MODULE.contains("\"./three.core.min.js\""));
        assert!(ORBIT_CONTROLS.contains("from 'three'"));
    }

    #[test]
    fn vendored_files_match_their_recorded_sha256() {
        use sha2::Digest as _;
        let readme = include_str!("vendor/README.md");
        let files: [(&str, &[u8]); 4] = [
            ("three.core.min.js", THREE_CORE.as_bytes()),
            ("three.module.min.js", THREE_MODULE.as_bytes()),
            ("OrbitControls.js", ORBIT_CONTROLS.as_bytes()),
            ("LICENSE", include_bytes!("vendor/LICENSE")),
        ];
        for (name, bytes) in files {
            let row = readme
                .lines()
                .find(|l| l.starts_with(&format!("| `{name}` |")))
                .unwrap_or_else(|| panic!("vendor/README.md has no row for {name}"));
            let recorded = row
                .split('`')
                .rev()
                .nth(1)
                .unwrap_or_else(|| panic!("no digest in {row:?}"));
            let actual: String = sha2::Sha256::digest(bytes)
                .iter()
                .map(|b| format!("{b:02x}"))
                .collect();
            assert_eq!(actual, recorded, "{name} differs from the vendored file");
        }
    }

    /// The mesh of a scene decodes to its triangles, within quantization.
    #[test]
    fn mesh_round_trips_within_quantization() {
        use base64::Engine as _;
        let scene = room_with_box();
        let mesh = Mesh::new(&scene);
        assert_eq!(mesh.shown, scene.triangles.len());
        let decode = |s: &str| base64::engine::general_purpose::STANDARD.decode(s).unwrap();
        let q: Vec<u16> = decode(&mesh.positions)
            .chunks(2)
            .map(|c| u16::from_le_bytes([c[0], c[1]]))
            .collect();
        assert_eq!(q.len(), 3 * mesh.vertices);
        assert_eq!(mesh.index_bytes, 2);
        let idx: Vec<usize> = decode(&mesh.indices)
            .chunks(2)
            .map(|c| u16::from_le_bytes([c[0], c[1]]) as usize)
            .collect();
        let (min, size) = (Vec3::from(mesh.min), Vec3::from(mesh.size));
        let vertex = |i: usize| {
            min + Vec3::new(q[3 * i] as f32, q[3 * i + 1] as f32, q[3 * i + 2] as f32) / 65535.0
                * size
        };
        let tolerance = size.max_element() / 65535.0;
        // Every drawn triangle is one of the scene's, corner for corner.
        for t in idx.chunks(3) {
            let drawn = [vertex(t[0]), vertex(t[1]), vertex(t[2])];
            assert!(
                scene.triangles.iter().any(|s| s
                    .iter()
                    .zip(&drawn)
                    .all(|(a, b)| a.distance(*b) <= tolerance)),
                "{drawn:?} is no triangle of the scene"
            );
        }
        let grouped: u32 = mesh.groups.iter().map(|g| g.count).sum();
        assert_eq!(grouped as usize, idx.len());
        // Shared corners are stored once.
        assert!(mesh.vertices < 3 * scene.triangles.len());
    }

    #[test]
    fn over_the_budget_the_largest_triangles_stay() {
        let scene = room_with_box();
        let kept = kept_triangles(&scene, 4);
        assert_eq!(kept.len(), 4);
        let areas: Vec<f64> = scene.triangle_areas().collect();
        let smallest_kept = kept.iter().map(|&t| areas[t]).fold(f64::INFINITY, f64::min);
        let left_out = (0..areas.len()).filter(|t| !kept.contains(t));
        assert!(left_out.into_iter().all(|t| areas[t] <= smallest_kept));
    }

    #[test]
    fn samples_are_bounded_and_spread() {
        let holes: Vec<u32> = (0..10_000).collect();
        let s = crate::report::hole_sample(&holes);
        assert!(s.len() <= crate::report::HOLE_SAMPLE && s.len() > crate::report::HOLE_SAMPLE / 2);
        assert_eq!(s[0], 0);
        assert!(*s.last().unwrap() > 9_000);
        assert_eq!(crate::report::hole_sample(&holes[..7]), holes[..7].to_vec());
    }
}
