//! `probes.glb`: the probes as a glTF 2.0 binary (Khronos glTF 2.0
//! specification, "GLB File Format Specification"), written by hand:
//! a JSON chunk and one binary buffer.
//!
//! Layout: node 0, `probes`, holds one child node per probe, named
//! `probe N` after its index in `probes.json`, at its world position
//! (`translation`, f64 as written in `probes.json`), drawing a shared
//! marker mesh, an octahedron whose radius is 1% of the domain's diagonal,
//! and carrying `extras`: `index`, `clearance`, `influence_box` and `fixed`
//! ([`super::source::SourceProbe::influence`]). `influence_box` is in the
//! file's frame (glTF's, world coordinates), which importers do not
//! convert: Blender turns a glTF's Y-up nodes to its Z-up but leaves custom
//! properties as they are. So each probe with an influence box also has a
//! child node `influence N` drawing the box's twelve edges (a shared
//! `LINES` mesh of the cube [−1, 1]³), translated to the box's centre
//! (relative to the probe) and scaled by its half extents: a node, which
//! every importer (Blender, Unity's and Godot's glTF importers, three.js)
//! carries into its own frame with the probe. With the scene, node `scene`
//! holds its triangles, one primitive per material with the material's
//! base colour (`Kd`, linear) and emission; its vertices are relative to
//! the scene's own origin and the node is translated there, so large world
//! coordinates keep their precision as they do in the stages.
//!
//! The frame is the world frame, which is glTF's (right-handed, +Y up);
//! glTF reads a unit as a metre. Every accessor has its exact `min` and
//! `max`, every buffer view and accessor offset is a multiple of 4, and the
//! scene primitives carry no normals, so viewers shade them flat as the
//! specification asks (§3.7.2.1).

use super::format::Format;
use super::source::Source;
use crate::scene::Scene;
use serde_json::{json, Value};

/// `ARRAY_BUFFER`: a buffer view of vertex attributes.
const ARRAY_BUFFER: u32 = 34962;
/// `FLOAT` component type.
const FLOAT: u32 = 5126;
/// Marker radius as a share of the domain's diagonal.
const MARKER_FRACTION: f64 = 0.01;
/// The markers' colour: the yellow of the probes in `placement.png`.
const MARKER_COLOUR: [f64; 4] = [1.0, 0.8, 0.1, 1.0];

/// The buffer and the JSON arrays that index into it, built together so
/// every offset is right by construction.
#[derive(Default)]
struct Builder {
    bin: Vec<u8>,
    views: Vec<Value>,
    accessors: Vec<Value>,
}

impl Builder {
    /// Appends `values` (xyz triples) as a VEC3 float accessor with its
    /// exact bounds, in a buffer view of its own; returns its index.
    fn vec3(&mut self, values: &[[f32; 3]]) -> usize {
        let offset = self.bin.len();
        let (mut lo, mut hi) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
        for v in values {
            for a in 0..3 {
                lo[a] = lo[a].min(v[a]);
                hi[a] = hi[a].max(v[a]);
                self.bin.extend_from_slice(&v[a].to_le_bytes());
            }
        }
        self.views.push(json!({
            "buffer": 0,
            "byteOffset": offset,
            "byteLength": self.bin.len() - offset,
            "target": ARRAY_BUFFER,
        }));
        // The bounds are the f32 values themselves, written as the f64
        // they convert to exactly, so a reader compares equal.
        let bound = |b: [f32; 3]| b.map(f64::from).to_vec();
        self.accessors.push(json!({
            "bufferView": self.views.len() - 1,
            "componentType": FLOAT,
            "count": values.len(),
            "type": "VEC3",
            "min": bound(lo),
            "max": bound(hi),
        }));
        self.accessors.len() - 1
    }
}

/// `LINES`: a primitive of line segments, two vertices each.
const LINES: u32 = 1;

/// The twelve edges of the cube [−1, 1]³ as line segments (24 vertices).
fn cube_edges() -> Vec<[f32; 3]> {
    let mut out = Vec::new();
    for axis in 0..3 {
        for (u, v) in [(-1.0, -1.0), (-1.0, 1.0), (1.0, -1.0), (1.0, 1.0)] {
            let mut a = [0.0f32; 3];
            a[(axis + 1) % 3] = u;
            a[(axis + 2) % 3] = v;
            let mut b = a;
            a[axis] = -1.0;
            b[axis] = 1.0;
            out.extend([a, b]);
        }
    }
    out
}

/// The marker octahedron of radius `r`: 8 flat faces, wound
/// counter-clockwise seen from outside; positions and normals.
fn octahedron(r: f32) -> (Vec<[f32; 3]>, Vec<[f32; 3]>) {
    let (mut positions, mut normals) = (Vec::new(), Vec::new());
    let n = 1.0 / 3f32.sqrt();
    for face in 0..8u32 {
        let s =
            [face & 1, (face >> 1) & 1, (face >> 2) & 1].map(|b| if b == 0 { 1.0 } else { -1.0 });
        let a = [s[0] * r, 0.0, 0.0];
        let b = [0.0, s[1] * r, 0.0];
        let c = [0.0, 0.0, s[2] * r];
        // (b − a) × (c − a) points along s·(s₀s₁s₂): swap when that is inward.
        let tri = if s[0] * s[1] * s[2] > 0.0 {
            [a, b, c]
        } else {
            [a, c, b]
        };
        positions.extend(tri);
        normals.extend([[s[0] * n, s[1] * n, s[2] * n]; 3]);
    }
    (positions, normals)
}

/// `probes.glb`: the probes alone.
pub struct Glb;

impl Format for Glb {
    const WORD: &'static str = "glb";
    const FILE: &'static str = "probes.glb";
    const ABOUT: &'static str =
        "glTF 2.0, one node per probe with a marker mesh, for Blender, three.js and any glTF viewer";

    fn encode(source: &Source, _: Option<&Scene>) -> Result<Vec<u8>, String> {
        Ok(encode(source, None))
    }
}

/// `probes.glb` with the scene's triangles (`--format glb --scene`).
pub struct GlbWithScene;

impl Format for GlbWithScene {
    const WORD: &'static str = "glb";
    const FILE: &'static str = "probes.glb";
    const ABOUT: &'static str =
        "as `Glb`, with the scene's triangles too, one material per base colour";
    const SCENE: bool = true;

    fn encode(source: &Source, scene: Option<&Scene>) -> Result<Vec<u8>, String> {
        Ok(encode(source, scene))
    }
}

/// `probes.glb` of `source`, with `scene`'s triangles when given.
///
/// Contract: a valid glTF 2.0 binary (the Khronos validator reports no
/// error or warning: tests/it/export.rs) whose probe nodes are exactly the
/// probes of `source`, in order; deterministic.
pub fn encode(source: &Source, scene: Option<&Scene>) -> Vec<u8> {
    let mut b = Builder::default();
    let radius = (MARKER_FRACTION * source.diagonal()).max(f64::MIN_POSITIVE) as f32;
    let (positions, normals) = octahedron(radius);
    let marker_positions = b.vec3(&positions);
    let marker_normals = b.vec3(&normals);
    let box_edges = b.vec3(&cube_edges());
    let mut materials = vec![json!({
        "name": "probe marker",
        "pbrMetallicRoughness": {
            "baseColorFactor": MARKER_COLOUR,
            "metallicFactor": 0.0,
            "roughnessFactor": 1.0,
        },
        "emissiveFactor": [MARKER_COLOUR[0], MARKER_COLOUR[1], MARKER_COLOUR[2]],
    })];
    let mut meshes = vec![
        json!({
            "name": "probe marker",
            "primitives": [{
                "attributes": { "POSITION": marker_positions, "NORMAL": marker_normals },
                "material": 0,
            }],
        }),
        json!({
            "name": "influence box",
            "primitives": [{ "attributes": { "POSITION": box_edges }, "mode": LINES, "material": 0 }],
        }),
    ];
    // Probe `i`'s node is `1 + i`; the influence boxes' nodes follow them.
    let mut box_nodes: Vec<Value> = Vec::new();
    let mut probe_nodes: Vec<Value> = source
        .probes
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let mut node = json!({
                "name": format!("probe {i}"),
                "translation": p.position,
                "mesh": 0,
                "extras": {
                    "index": i,
                    "clearance": p.clearance,
                    "influence_box": p.influence,
                    "fixed": p.fixed,
                },
            });
            // After a bake: the probe's light as `sh.json` gives it (glTF's
            // frame is the run's world frame).
            if let Some(light) = &source.light {
                node["extras"]["sh_l2"] = sh_rows(&light[i].sh.baked);
            }
            node
        })
        .collect();
    let first_box = 1 + probe_nodes.len();
    for (i, p) in source.probes.iter().enumerate() {
        if let Some(bx) = &p.influence {
            let centre: Vec<f64> = (0..3)
                .map(|a| 0.5 * (bx.min[a] + bx.max[a]) - p.position[a])
                .collect();
            let half: Vec<f64> = (0..3).map(|a| 0.5 * (bx.max[a] - bx.min[a])).collect();
            probe_nodes[i]["children"] = json!([first_box + box_nodes.len()]);
            box_nodes.push(json!({
                "name": format!("influence {i}"),
                "translation": centre,
                "scale": half,
                "mesh": 1,
            }));
        }
    }
    let mut nodes = vec![json!({
        "name": "probes",
        "children": (1..=probe_nodes.len()).collect::<Vec<_>>(),
        "extras": {
            "method": source.method,
            "count": probe_nodes.len(),
            "sh_holds": source.light.as_ref().map(|_| crate::report::sh::holds(source.direct_included)),
        },
    })];
    nodes.extend(probe_nodes);
    nodes.extend(box_nodes);
    let mut roots = vec![0];
    if let Some(scene) = scene {
        let primitives = scene_primitives(scene, &mut b, &mut materials);
        if !primitives.is_empty() {
            meshes.push(json!({ "name": "scene", "primitives": primitives }));
            nodes.push(json!({
                "name": "scene",
                "translation": scene.origin.to_array(),
                "mesh": meshes.len() - 1,
            }));
            roots.push(nodes.len() - 1);
        }
    }
    let gltf = json!({
        "asset": {
            "version": "2.0",
            "generator": crate::provenance::TOOL,
            "extras": { "provenance": super::source::provenance_summary(&source.provenance) },
        },
        "scene": 0,
        "scenes": [{ "name": "probeplace", "nodes": roots }],
        "nodes": nodes,
        "meshes": meshes,
        "materials": materials,
        "accessors": b.accessors,
        "bufferViews": b.views,
        "buffers": [{ "byteLength": b.bin.len() }],
    });
    glb(
        &serde_json::to_vec(&gltf).expect("a JSON value serializes"),
        &b.bin,
    )
}

/// One primitive per material of `scene` that any triangle uses, in
/// material order, its vertices relative to the scene's origin; adds the
/// materials to `materials`.
fn scene_primitives(scene: &Scene, b: &mut Builder, materials: &mut Vec<Value>) -> Vec<Value> {
    let mut by_material: Vec<Vec<[f32; 3]>> = vec![Vec::new(); scene.materials.len()];
    for (t, &m) in scene.triangles.iter().zip(&scene.material_ids) {
        if let Some(list) = by_material.get_mut(m as usize) {
            list.extend(t.iter().map(|v| v.to_array()));
        }
    }
    let mut primitives = Vec::new();
    for (m, vertices) in by_material.iter().enumerate() {
        if vertices.is_empty() {
            continue;
        }
        let material = &scene.materials[m];
        let accessor = b.vec3(vertices);
        // glTF's emissive factor lies in [0, 1]: the emission's colour,
        // scaled down when brighter (an MTL `Ke` is radiance, unbounded).
        let e = material.emission.map(f64::from);
        let peak = e.iter().copied().fold(1.0, f64::max);
        let colour = material.diffuse.map(|c| f64::from(c).clamp(0.0, 1.0));
        materials.push(json!({
            "name": material.name,
            "pbrMetallicRoughness": {
                "baseColorFactor": [colour[0], colour[1], colour[2], 1.0],
                "metallicFactor": 0.0,
                "roughnessFactor": 1.0,
            },
            "emissiveFactor": e.map(|c| (c / peak).clamp(0.0, 1.0)),
            // Scenes are seen from inside: rooms' walls face in, and a
            // viewer outside should see them too.
            "doubleSided": true,
        }));
        primitives.push(json!({
            "attributes": { "POSITION": accessor },
            "material": materials.len() - 1,
        }));
    }
    primitives
}

/// The GLB container: the 12-byte header, the JSON chunk padded with
/// spaces and the binary chunk padded with zeros, each to 4 bytes.
pub(crate) fn glb(json: &[u8], bin: &[u8]) -> Vec<u8> {
    let pad = |n: usize| (4 - n % 4) % 4;
    let json_len = json.len() + pad(json.len());
    let bin_len = bin.len() + pad(bin.len());
    let total = 12 + 8 + json_len + if bin.is_empty() { 0 } else { 8 + bin_len };
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(json_len as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(json);
    out.extend(std::iter::repeat_n(b' ', pad(json.len())));
    if !bin.is_empty() {
        out.extend_from_slice(&(bin_len as u32).to_le_bytes());
        out.extend_from_slice(b"BIN\0");
        out.extend_from_slice(bin);
        out.extend(std::iter::repeat_n(0u8, pad(bin.len())));
    }
    debug_assert_eq!(out.len(), total);
    out
}

/// SH L2 coefficients as nine `[r, g, b]` rows ([`crate::report::sh`]).
pub(crate) fn sh_rows(sh: &crate::diffuse::sh::ShL2) -> Value {
    json!(sh
        .coefficients
        .iter()
        .map(|c| c.to_array())
        .collect::<Vec<_>>())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_octahedron_faces_outward_with_unit_normals() {
        let (p, n) = octahedron(2.0);
        assert_eq!((p.len(), n.len()), (24, 24));
        for (tri, normal) in p.chunks(3).zip(n.chunks(3)) {
            let v = |a: [f32; 3]| glam::Vec3::from(a);
            let cross = (v(tri[1]) - v(tri[0])).cross(v(tri[2]) - v(tri[0]));
            let centre = (v(tri[0]) + v(tri[1]) + v(tri[2])) / 3.0;
            assert!(cross.dot(centre) > 0.0, "{tri:?} winds inward");
            assert!((v(normal[0]).length() - 1.0).abs() < 1e-6);
            assert!(cross.normalize().dot(v(normal[0])) > 0.9999);
        }
    }

    #[test]
    fn the_container_is_padded_and_sized() {
        let out = glb(b"{\"a\":1}", &[1, 2, 3, 4, 5, 6, 7, 8]);
        assert_eq!(&out[..4], b"glTF");
        assert_eq!(out.len() % 4, 0);
        assert_eq!(
            u32::from_le_bytes(out[8..12].try_into().unwrap()) as usize,
            out.len()
        );
        assert_eq!(u32::from_le_bytes(out[12..16].try_into().unwrap()), 8);
        assert_eq!(&out[16..20], b"JSON");
        assert_eq!(&out[20..28], b"{\"a\":1} ");
        assert_eq!(&out[32..36], b"BIN\0");
    }
}
