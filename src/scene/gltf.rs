//! glTF 2.0 scenes (`.gltf` with its buffers, or one `.glb`): the triangles
//! of every mesh instance of the scene's node hierarchy, their materials,
//! and the `KHR_lights_punctual` lights, in the same world space as an OBJ
//! (glTF's metres and +Y up, then the config's `scale` and `up`).
//!
//! The document is the `gltf` crate's JSON model (`gltf::json`); the rest is
//! read here, checking every index and byte range *before* it is used or
//! allocated for, so that a hostile file gets one line naming the file and
//! the node, mesh, primitive, accessor or buffer at fault (exit status 2),
//! never a panic. Why not the crate's importer and validator: its importer
//! reads buffers and images without a memory budget, and its validator and
//! GLB reader index arrays and subtract lengths the file chose without a
//! check, which fuzzing turns into panics.
//!
//! What is read (Khronos glTF 2.0 specification, 2021):
//! * **Nodes** (§3.5): the default scene's hierarchy (the first scene when
//!   none is the default; every root node when the file has no scene), each
//!   node's `matrix` or TRS, composed in f64. A mesh that several nodes name
//!   is instanced at each. A node met twice (a cycle, or two parents) is an
//!   error.
//! * **Meshes** (§3.7): every primitive of mode `TRIANGLES`,
//!   `TRIANGLE_STRIP` or `TRIANGLE_FAN`, indexed or not; points and lines
//!   are skipped with one warning. A node whose transform mirrors
//!   (negative determinant) has its triangles' winding reversed, as §3.7.4
//!   asks, so the front faces stay front faces. `POSITION` may be `FLOAT`,
//!   or (`KHR_mesh_quantization`) normalized or plain 8- or 16-bit
//!   integers; sparse accessors are applied (§3.6.2.3). Skins and morph
//!   targets are ignored: the rest pose is what is placed in.
//! * **Materials** (§3.9): the metallic-roughness model onto the bake's BSDF
//!   ([`material_of`]); `emissiveFactor` times `KHR_materials_emissive_strength`
//!   as emission. A primitive without a material gets
//!   [`Material::fallback`], as an OBJ face without one does (not the
//!   specification's white metal, which would make every untextured test
//!   asset a mirror).
//! * **Textures** (§3.8, §3.9.2, §5.26): `baseColorTexture`,
//!   `emissiveTexture` and `metallicRoughnessTexture` (blue metal, green
//!   roughness, per texel: [`super::MetalRough`]) with their samplers'
//!   wrap modes and `KHR_texture_transform`, read through the
//!   `TEXCOORD_n` set they name;
//!   each image (a buffer view, a `data:` URI or a file) decoded once
//!   ([`super::texture`]). An image that cannot be read is a warning and
//!   its material keeps its factor; a texture, image or sampler index
//!   that names nothing is an error.
//! * **Alpha** (§3.9.4): MASK with its `alphaCutoff`, from the base
//!   colour's alpha (factor × texture), as a cut-out every ray test
//!   passes through ([`super::Cutout`]); BLEND as MASK at 0.5, with one
//!   warning ([`alpha_of`]).
//! * **Lights** (`KHR_lights_punctual`): point, spot and directional
//!   lights at their nodes, as config lights ([`light_of`]).
//!
//! Buffers are the GLB's binary chunk, `data:` URIs (base64), or files
//! beside the glTF (relative URIs, percent-decoded). Every file read goes
//! through [`crate::input`] (regular files only, within the memory budget).

use super::obj::MAX_EMISSION;
use super::{file_to_world, Material};
use crate::config::numbers::{Degrees, Direction, NonNegative, Point3, Rgb};
use crate::config::params::{Light, UpAxis};
use crate::error::{Error, Result};
use crate::input;
use crate::limits;
use base64::Engine;
use super::texture::{self, Texture, TextureFile, TextureMap, Wrap};
use glam::{DMat3, DMat4, DQuat, DVec3, Vec2};
use gltf::json;
use json::accessor::{ComponentType, Type};
use json::mesh::{Mode, Semantic};
use json::validation::Checked;
use std::sync::Arc;
use std::path::Path;

/// Extensions a file may require that this reader handles (or may ignore
/// without changing the geometry or the light).
pub const SUPPORTED_EXTENSIONS: &[&str] = &[
    "KHR_lights_punctual",
    "KHR_materials_emissive_strength",
    "KHR_materials_specular",
    "KHR_mesh_quantization",
    "KHR_texture_transform",
];

/// Materials named in the warning about clamped factors; the rest are counted.
const LISTED: usize = 5;

/// Largest JSON document read: 256 MiB, and at most a 128th of the memory
/// budget, since the document model takes tens of bytes for each byte of
/// a terse JSON (`{}` is a node).
pub const MAX_JSON_BYTES: u64 = 256 << 20;

/// Most triangles one file may unfold to, counting every instance: what one
/// BVH holds ([`super::wide_bvh::MAX_PRIMITIVES`]).
fn max_triangles() -> u64 {
    super::wide_bvh::MAX_PRIMITIVES as u64
}

/// What a glTF file holds for the scene, in world coordinates (metres × the
/// config's scale, Y up), before the scene's origin is subtracted.
#[derive(Debug, Clone, Default)]
pub struct GltfFile {
    /// Each triangle's world vertices and its index into `materials`
    /// (`u32::MAX`: none, the fallback).
    pub triangles: Vec<([DVec3; 3], u32)>,
    /// The file's materials, in its order.
    pub materials: Vec<Material>,
    /// Its punctual lights, one per node that holds one.
    pub lights: Vec<Light>,
    /// Each triangle's texture coordinates, parallel to `triangles`; empty
    /// when no material has a texture.
    pub texcoords: Vec<[Vec2; 3]>,
    /// The decoded images the materials' maps index.
    pub textures: Vec<Arc<Texture>>,
    /// Every image the materials name: its uses, its size or why it was
    /// not read.
    pub files: Vec<TextureFile>,
    /// Warnings, each naming the file.
    pub warnings: Vec<String>,
}

/// Reads the glTF or GLB file at `path` ([`parse`]); external buffers are
/// read from files beside it.
///
/// Errors ([`Error::User`], naming the file): not a regular file, over the
/// memory budget, or anything [`parse`] refuses.
pub fn read(path: &Path, scale: f64, up: UpAxis) -> Result<GltfFile> {
    // The scene file and every buffer and image file it names, together,
    // within the memory budget: each is read with what is left of it as
    // its limit, so that no file is read whole past the budget, however
    // many files (or links to one file) the glTF names.
    let budget = limits::memory_budget();
    let bytes = input::read(path, "scene file", budget)?;
    let mut left = budget.saturating_sub(bytes.len() as u64);
    let dir = path.parent().unwrap_or(Path::new("")).to_path_buf();
    parse(&bytes, path, scale, up, &mut |uri: &str, what: &str| {
        let file = dir.join(uri);
        let data = input::read(&file, what, left).map_err(|e| {
            let e = e.to_string();
            match e.contains("over the limit") || e.contains("grew past the limit") {
                true => Error::User(format!(
                    "{e}: the scene file and the files it names may take {} together (the memory budget)",
                    input::bytes_text(budget)
                )),
                false => Error::User(e),
            }
        })?;
        left = left.saturating_sub(data.len() as u64);
        Ok(data)
    })
}

/// Parses the glTF JSON or GLB in `bytes` (named `path` in messages);
/// `external(uri, what)` returns the bytes of a buffer or an image stored
/// in a file (the URI percent-decoded, relative to the glTF's folder;
/// `what` is `"glTF buffer"` or `"glTF image"`, for its messages).
///
/// Contract: every triangle of the default scene's mesh instances in
/// node order, each primitive's in its index order (strips and fans
/// unrolled as §3.7.2.1 orders them), in world coordinates; every value
/// read from the file has been checked against what it indexes, so no
/// input panics. Errors name the file and the object at fault.
pub fn parse(
    bytes: &[u8],
    path: &Path,
    scale: f64,
    up: UpAxis,
    external: &mut dyn FnMut(&str, &str) -> Result<Vec<u8>>,
) -> Result<GltfFile> {
    let fail = |msg: String| Error::user_file(path, msg);
    let (json_bytes, bin) = container(bytes).map_err(&fail)?;
    let json_limit = MAX_JSON_BYTES.min(limits::memory_budget() / 128);
    if json_bytes.len() as u64 > json_limit {
        return Err(fail(format!(
            "its JSON is {}, over the limit of {}",
            input::bytes_text(json_bytes.len() as u64),
            input::bytes_text(json_limit)
        )));
    }
    let root: json::Root = serde_json::from_slice(json_bytes)
        .map_err(|e| fail(format!("not a glTF 2.0 document: {e}")))?;
    if !root.asset.version.starts_with("2.") {
        return Err(fail(format!(
            "glTF version {:?}; probeplace reads glTF 2.x",
            root.asset.version
        )));
    }
    for ext in &root.extensions_required {
        if !SUPPORTED_EXTENSIONS.contains(&ext.as_str()) {
            let hint = match ext.as_str() {
                "KHR_draco_mesh_compression" | "EXT_meshopt_compression" => {
                    " (compressed geometry: export the file without compression)"
                }
                _ => "",
            };
            return Err(fail(format!(
                "requires the extension {ext}, which probeplace does not read{hint}"
            )));
        }
    }
    // Extensions the file uses but does not require: the reader goes on
    // without them (as §3.12 allows), and says which, once.
    let mut skipped: Vec<&str> = Vec::new();
    for ext in &root.extensions_used {
        if !SUPPORTED_EXTENSIONS.contains(&ext.as_str()) && !skipped.contains(&ext.as_str()) {
            skipped.push(ext);
        }
    }
    let mut early_warnings = Vec::new();
    if !skipped.is_empty() {
        let shown: Vec<String> = skipped
            .iter()
            .map(|e| e.chars().take(64).collect::<String>().escape_debug().to_string())
            .collect();
        early_warnings.push(format!(
            "{}: extension(s) {} not applied: what they add to materials or geometry is left out",
            path.display(),
            super::first_of(&shown, LISTED)
        ));
    }
    let mut reader = Reader {
        root: &root,
        path,
        bin,
        buffers: vec![None; root.buffers.len()],
        external,
        positions: vec![None; root.accessors.len()],
        decoded: 0,
    };
    let mut out = GltfFile {
        warnings: early_warnings,
        ..GltfFile::default()
    };
    let mut clamped = Vec::new();
    for (i, m) in root.materials.iter().enumerate() {
        let (material, was_clamped) = material_of(i, m);
        if was_clamped {
            clamped.push(named(i, m.name.as_deref()));
        }
        out.materials.push(material);
    }
    if !clamped.is_empty() {
        out.warnings.push(format!(
            "{}: material(s) {}: a factor out of range (or not finite) was clamped",
            path.display(),
            super::first_of(&clamped, LISTED)
        ));
    }
    let unread = specular_textures(&root);
    if !unread.is_empty() {
        out.warnings.push(format!(
            "{}: material(s) {}: KHR_materials_specular's textures are not applied (its factors are)",
            path.display(),
            super::first_of(&unread, LISTED)
        ));
    }
    let sets = reader.textures(&mut out)?;
    let (instances, light_nodes) = hierarchy(&root, path, &mut out.warnings)?;

    // The triangles every instance unfolds to, counted before anything is
    // allocated for them.
    let mut total: u64 = 0;
    let mut skipped = 0usize;
    for &(mesh, _) in &instances {
        for (p, prim) in root.meshes[mesh].primitives.iter().enumerate() {
            match triangle_count(&root, mesh, p, prim).map_err(&fail)? {
                Some(n) => total = total.saturating_add(n),
                None => skipped += 1,
            }
        }
    }
    if total > max_triangles() {
        return Err(fail(format!(
            "{total} triangles with every instance, more than the {} one BVH holds (`probeplace split` tiles OBJ scenes: export this one as OBJ to split it)",
            max_triangles()
        )));
    }
    limits::check_memory(
        "scene",
        &format!("{} ({total} triangles)", path.display()),
        total as f64 * super::obj::BYTES_PER_TRIANGLE,
    )?;
    if skipped > 0 {
        out.warnings.push(format!(
            "{}: skipped {skipped} primitive instance(s) of points or lines (only triangles are surfaces)",
            path.display()
        ));
    }

    // Each mesh's primitives decoded once, however many nodes instance it.
    let textured = out.materials.iter().any(Material::is_textured);
    let mut decoded: Vec<Option<Vec<Option<Primitive>>>> = vec![None; root.meshes.len()];
    out.triangles.reserve(total as usize);
    for &(mesh, world) in &instances {
        if decoded[mesh].is_none() {
            let prims = root.meshes[mesh]
                .primitives
                .iter()
                .enumerate()
                .map(|(p, prim)| reader.primitive(mesh, p, prim, &sets))
                .collect::<Result<Vec<_>>>()?;
            decoded[mesh] = Some(prims);
        }
        let mirrored = DMat3::from_mat4(world).determinant() < 0.0;
        let to_world = |p: glam::Vec3| file_to_world(world.transform_point3(p.as_dvec3()), scale, up);
        for prim in decoded[mesh].iter().flatten().flatten() {
            let material = prim.material;
            for t in prim.triangles() {
                let [a, b, c] = t.map(|i| to_world(prim.positions[i as usize]));
                let tri = if mirrored { [a, c, b] } else { [a, b, c] };
                out.triangles.push((tri, material));
                if textured {
                    let uv = |i: u32| prim.texcoords.get(i as usize).copied().unwrap_or(Vec2::ZERO);
                    let [a, b, c] = t.map(uv);
                    out.texcoords.push(if mirrored { [a, c, b] } else { [a, b, c] });
                }
            }
        }
    }

    let lights = root
        .extensions
        .as_ref()
        .and_then(|e| e.khr_lights_punctual.as_ref())
        .map(|l| l.lights.as_slice())
        .unwrap_or(&[]);
    let mut ranged = 0;
    for (node, light, world) in light_nodes {
        let Some(l) = lights.get(light) else {
            return Err(fail(format!(
                "node {}: light {light} does not exist (the file defines {})",
                node_name(&root, node),
                lights.len()
            )));
        };
        if l.range.is_some() {
            ranged += 1;
        }
        out.lights.push(light_of(l, light, world, scale, up).map_err(&fail)?);
    }
    if ranged > 0 {
        out.warnings.push(format!(
            "{}: {ranged} light(s) give a range; the bake lights by the inverse square law without a cut-off",
            path.display()
        ));
    }
    Ok(out)
}

/// The files beside the glTF or GLB at `path` that it names and that exist:
/// its buffers' and images' relative URIs, in the order of the file. What
/// a run reads besides the scene file (its provenance hashes them). Best
/// effort: a file that cannot be read or parsed names none, and the loader
/// then says why.
pub fn external_files(path: &Path) -> Vec<std::path::PathBuf> {
    // The memory budget, as the loader's: a file past it names none,
    // and the loader refuses it.
    let limit = limits::memory_budget();
    let Ok(bytes) = input::read(path, "scene file", limit) else {
        return Vec::new();
    };
    let Ok((json, _)) = container(&bytes) else {
        return Vec::new();
    };
    #[derive(serde::Deserialize)]
    struct Uris {
        #[serde(default)]
        buffers: Vec<Named>,
        #[serde(default)]
        images: Vec<Named>,
    }
    #[derive(serde::Deserialize)]
    struct Named {
        uri: Option<String>,
    }
    let Ok(doc) = serde_json::from_slice::<Uris>(json) else {
        return Vec::new();
    };
    let dir = path.parent().unwrap_or(Path::new(""));
    let mut out: Vec<std::path::PathBuf> = Vec::new();
    for uri in doc.buffers.iter().chain(&doc.images).filter_map(|n| n.uri.as_deref()) {
        if uri.starts_with("data:") || uri.contains("://") {
            continue;
        }
        if let Some(p) = percent_decode(uri).map(|u| dir.join(u)) {
            if p.is_file() && !out.contains(&p) {
                out.push(p);
            }
        }
    }
    out
}

/// The JSON and the binary chunk of a GLB (§4.4), or the whole input as
/// JSON (a UTF-8 byte order mark skipped).
fn container(bytes: &[u8]) -> std::result::Result<(&[u8], Option<&[u8]>), String> {
    if !bytes.starts_with(b"glTF") {
        return Ok((bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes), None));
    }
    let word = |at: usize| -> Option<u32> {
        bytes
            .get(at..at + 4)
            .map(|w| u32::from_le_bytes([w[0], w[1], w[2], w[3]]))
    };
    let (Some(version), Some(length)) = (word(4), word(8)) else {
        return Err("a GLB shorter than its 12-byte header".into());
    };
    if version != 2 {
        return Err(format!("GLB version {version}; probeplace reads version 2"));
    }
    let length = length as usize;
    if length > bytes.len() || length < 12 {
        return Err(format!(
            "the GLB header gives a length of {length} bytes; the file has {}",
            bytes.len()
        ));
    }
    let mut at = 12;
    let mut json = None;
    let mut bin = None;
    while at < length {
        let (Some(chunk_len), Some(kind)) = (word(at), word(at + 4)) else {
            return Err(format!("a GLB chunk header cut short at byte {at}"));
        };
        let start = at + 8;
        let end = start
            .checked_add(chunk_len as usize)
            .filter(|&e| e <= length)
            .ok_or_else(|| {
                format!("the GLB chunk at byte {at} claims {chunk_len} bytes, past the end of the file")
            })?;
        match kind {
            0x4E4F_534A if json.is_none() => json = Some(&bytes[start..end]),
            0x004E_4942 if bin.is_none() && json.is_some() => bin = Some(&bytes[start..end]),
            _ if json.is_none() => return Err("the first GLB chunk is not JSON".into()),
            _ => {}
        }
        at = end;
    }
    let json = json.ok_or("a GLB without a JSON chunk")?;
    Ok((json, bin))
}

/// The node's index and name for messages: `3 (“Chair”)`.
fn node_name(root: &json::Root, node: usize) -> String {
    named(node, root.nodes.get(node).and_then(|n| n.name.as_deref()))
}

fn mesh_name(root: &json::Root, mesh: usize) -> String {
    named(mesh, root.meshes.get(mesh).and_then(|m| m.name.as_deref()))
}

fn named(index: usize, name: Option<&str>) -> String {
    match name {
        Some(n) if !n.is_empty() => format!("{index} (`{}`)", n.chars().take(60).collect::<String>()),
        _ => index.to_string(),
    }
}

/// The mesh instances (mesh index and world transform) and the light nodes
/// (node, light index, world transform) of the scene to read, in depth-first
/// node order.
#[allow(clippy::type_complexity)]
fn hierarchy(
    root: &json::Root,
    path: &Path,
    warnings: &mut Vec<String>,
) -> Result<(Vec<(usize, DMat4)>, Vec<(usize, usize, DMat4)>)> {
    let fail = |msg: String| Error::user_file(path, msg);
    let roots: Vec<usize> = match (root.scene, root.scenes.is_empty()) {
        (Some(s), _) => {
            let scene = root.scenes.get(s.value()).ok_or_else(|| {
                fail(format!("the default scene {} does not exist (the file has {})", s.value(), root.scenes.len()))
            })?;
            scene.nodes.iter().map(|n| n.value()).collect()
        }
        (None, false) => root.scenes[0].nodes.iter().map(|n| n.value()).collect(),
        (None, true) => {
            let mut child = vec![false; root.nodes.len()];
            for n in &root.nodes {
                for c in n.children.iter().flatten() {
                    if let Some(slot) = child.get_mut(c.value()) {
                        *slot = true;
                    }
                }
            }
            if !root.nodes.is_empty() {
                warnings.push(format!(
                    "{}: no scene is defined; every root node is read",
                    path.display()
                ));
            }
            (0..root.nodes.len()).filter(|&i| !child[i]).collect()
        }
    };
    let mut seen = vec![false; root.nodes.len()];
    let mut instances = Vec::new();
    let mut lights = Vec::new();
    let mut stack: Vec<(usize, DMat4)> = roots.into_iter().rev().map(|n| (n, DMat4::IDENTITY)).collect();
    while let Some((n, parent)) = stack.pop() {
        let Some(node) = root.nodes.get(n) else {
            return Err(fail(format!("node {n} does not exist (the file has {})", root.nodes.len())));
        };
        if std::mem::replace(&mut seen[n], true) {
            return Err(fail(format!(
                "node {} is reached twice in the scene's hierarchy (a cycle, or two parents)",
                node_name(root, n)
            )));
        }
        let world = parent * local_transform(node).ok_or_else(|| {
            fail(format!(
                "node {}: its transform is not finite, or its rotation is zero",
                node_name(root, n)
            ))
        })?;
        if !world.is_finite() {
            return Err(fail(format!(
                "node {}: its world transform overflows",
                node_name(root, n)
            )));
        }
        if let Some(m) = node.mesh {
            if m.value() >= root.meshes.len() {
                return Err(fail(format!(
                    "node {}: mesh {} does not exist (the file has {})",
                    node_name(root, n),
                    m.value(),
                    root.meshes.len()
                )));
            }
            instances.push((m.value(), world));
        }
        if let Some(l) = node.extensions.as_ref().and_then(|e| e.khr_lights_punctual.as_ref()) {
            lights.push((n, l.light.value(), world));
        }
        for c in node.children.iter().flatten().rev() {
            stack.push((c.value(), world));
        }
    }
    Ok((instances, lights))
}

/// A node's local transform (§3.5.2): its matrix, or T·R·S; `None` when a
/// value is not finite.
fn local_transform(node: &json::Node) -> Option<DMat4> {
    let m = if let Some(m) = node.matrix {
        DMat4::from_cols_array(&m.map(f64::from))
    } else {
        let t = node.translation.map_or(DVec3::ZERO, |t| DVec3::from(t.map(f64::from)));
        let s = node.scale.map_or(DVec3::ONE, |s| DVec3::from(s.map(f64::from)));
        let q = node
            .rotation
            .map_or(DQuat::IDENTITY, |r| DQuat::from_array(r.0.map(f64::from)));
        if !q.is_finite() || q.length_squared() == 0.0 {
            return None;
        }
        DMat4::from_scale_rotation_translation(s, q.normalize(), t)
    };
    m.is_finite().then_some(m)
}

/// The metallic-roughness material `m` (§3.9.2) as the bake's BSDF sees it
/// ([`crate::render::material`]), by its factors
/// ([`super::MetalRough::lobes`]; its textures are applied by
/// [`Reader::textures`]). Emission is `emissiveFactor` times
/// `KHR_materials_emissive_strength`. Out-of-range values are clamped as
/// MTL values are; the flag says whether any was.
pub fn material_of(index: usize, m: &json::Material) -> (Material, bool) {
    let name = m.name.clone().unwrap_or_else(|| format!("material {index}"));
    let ((base, metallic, roughness), mut clamped) = factors(m);
    let strength = m
        .extensions
        .as_ref()
        .and_then(|e| e.emissive_strength.as_ref())
        .map_or(1.0, |s| s.emissive_strength.0 as f64);
    let emission = m.emissive_factor.0.map(|e| {
        let v = e as f64 * strength;
        if !v.is_finite() || !(0.0..=MAX_EMISSION).contains(&v) {
            clamped = true;
        }
        if v.is_finite() {
            v.clamp(0.0, MAX_EMISSION)
        } else {
            0.0
        }
    });
    // An alpha cutoff below 0 (§5.19: at least 0) reads as 0 in
    // [`alpha_of`], and is said as the factors are.
    if m.alpha_cutoff.is_some_and(|c| !(c.0 >= 0.0 && c.0.is_finite())) {
        clamped = true;
    }
    let (f0, f0_clamped) = dielectric_f0(m);
    clamped |= f0_clamped;
    let (diffuse, specular, shininess) = super::MetalRough::lobes(base, metallic, roughness, f0);
    let material = Material {
        name,
        diffuse,
        specular,
        shininess,
        emission: emission.map(|e| e as f32),
        ..Material::fallback()
    };
    (material, clamped)
}

/// Which map of a material a texture is.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Slot {
    Colour,
    Emission,
    MetalRough,
}

impl Slot {
    /// Its use as `report.json` names it ([`texture::USES`]).
    fn name(self) -> &'static str {
        match self {
            Slot::Colour => "colour",
            Slot::Emission => "emission",
            Slot::MetalRough => "metal-roughness",
        }
    }
}

/// A dielectric's specular reflectance `F0` in `m`: 0.04, or with
/// `KHR_materials_specular` `min(0.04 · specularColorFactor, 1) ·
/// specularFactor` per channel (the extension's factors; its textures are
/// not read). The flag says whether a factor was negative or not finite
/// (read as its default, 1).
fn dielectric_f0(m: &json::Material) -> ([f64; 3], bool) {
    let Some(s) = m.extensions.as_ref().and_then(|e| e.specular.as_ref()) else {
        return ([0.04; 3], false);
    };
    let mut clamped = false;
    let mut ok = |v: f32| -> f64 {
        if v.is_finite() && v >= 0.0 {
            v as f64
        } else {
            clamped = true;
            1.0
        }
    };
    let factor = ok(s.specular_factor.0).min(1.0);
    let colour = s.specular_color_factor.0.map(&mut ok);
    (colour.map(|c| (0.04 * c).min(1.0) * factor), clamped)
}

/// Names of the materials whose `KHR_materials_specular` has a texture,
/// which the reader does not apply (its factors alone are used).
fn specular_textures(root: &json::Root) -> Vec<String> {
    root.materials
        .iter()
        .enumerate()
        .filter(|(_, m)| {
            m.extensions
                .as_ref()
                .and_then(|e| e.specular.as_ref())
                .is_some_and(|s| s.specular_texture.is_some() || s.specular_color_texture.is_some())
        })
        .map(|(i, m)| named(i, m.name.as_deref()))
        .collect()
}

/// `m`'s base colour, metallic and roughness factors, each clamped to
/// [0, 1] (a non-finite one at its default, 1), and whether any was out
/// of range: what [`material_of`] and the metal-roughness map read.
fn factors(m: &json::Material) -> (([f64; 3], f64, f64), bool) {
    let pbr = &m.pbr_metallic_roughness;
    let mut clamped = false;
    let mut unit = |v: f32| -> f64 {
        clamped |= !(0.0..=1.0).contains(&v);
        (if v.is_finite() { v } else { 1.0 }).clamp(0.0, 1.0) as f64
    };
    let read = (
        [0, 1, 2].map(|c| unit(pbr.base_color_factor.0[c])),
        unit(pbr.metallic_factor.0),
        unit(pbr.roughness_factor.0),
    );
    (read, clamped)
}

/// The cut-out of `m`'s alpha mode (§3.9.4), `None` where rays stop
/// everywhere: OPAQUE; or MASK (and BLEND, read as MASK at 0.5) whose
/// alpha, `baseColorFactor`'s times the colour texture's alpha channel
/// (`colour`, if it was read and has one), is at the cutoff everywhere.
/// `alphaCutoff` defaults to 0.5; a non-finite one is 0.5, a negative
/// one 0.
fn alpha_of(
    m: &json::Material,
    colour: Option<TextureMap>,
    textures: &[Arc<Texture>],
) -> Option<super::Cutout> {
    use json::material::AlphaMode;
    let cutoff = match m.alpha_mode {
        Checked::Valid(AlphaMode::Mask) => m.alpha_cutoff.map_or(0.5, |c| c.0),
        Checked::Valid(AlphaMode::Blend) => 0.5,
        _ => return None,
    };
    let cutoff = if cutoff.is_finite() { cutoff.max(0.0) } else { 0.5 };
    let factor = m.pbr_metallic_roughness.base_color_factor.0[3];
    let factor = if factor.is_finite() { factor.clamp(0.0, 1.0) } else { 1.0 };
    let map = colour.filter(|c| textures[c.texture as usize].has_alpha());
    let cut = super::Cutout {
        factor,
        map,
        grey: false,
        cutoff,
    };
    (map.is_some() || cut.everywhere()).then_some(cut)
}

/// A `KHR_lights_punctual` light at the node whose world transform is
/// `world`, as a config light: the light's position is the node's origin,
/// its direction the node's −Z; colour × intensity is the point and spot
/// lights' radiant intensity and the directional light's irradiance (the
/// extension's candela and lux, one for one, as the config's lights take
/// them); a spot's cone is its outer cone angle, and its fall-off band the
/// outer less the inner angle.
fn light_of(
    l: &json::extensions::scene::khr_lights_punctual::Light,
    index: usize,
    world: DMat4,
    scale: f64,
    up: UpAxis,
) -> std::result::Result<Light, String> {
    use json::extensions::scene::khr_lights_punctual::Type as Kind;
    let what = || format!("light {}", named(index, l.name.as_deref()));
    // Each factor on its own: a negative colour times a negative
    // intensity is a positive product, but neither is a light.
    if let Some(c) = l.color.iter().position(|c| !c.is_finite() || *c < 0.0) {
        return Err(format!(
            "{}: color[{c}] is {}; each colour component must be finite and at least 0",
            what(),
            l.color[c]
        ));
    }
    if !l.intensity.is_finite() || l.intensity < 0.0 {
        return Err(format!(
            "{}: intensity is {}; it must be finite and at least 0",
            what(),
            l.intensity
        ));
    }
    let colour = l.color.map(|c| c * l.intensity);
    if colour.iter().any(|c| !c.is_finite()) {
        return Err(format!("{}: colour × intensity overflows", what()));
    }
    let position = file_to_world(world.transform_point3(DVec3::ZERO), scale, up);
    let axis = file_to_world(world.transform_vector3(DVec3::NEG_Z), 1.0, up);
    let direction = || -> std::result::Result<Direction, String> {
        let d = axis.normalize_or_zero().as_vec3();
        if d == glam::Vec3::ZERO || !d.is_finite() {
            return Err(format!("{}: its node's transform collapses its direction", what()));
        }
        Ok(Direction(d.to_array()))
    };
    let rgb = Rgb(colour);
    Ok(match l.type_ {
        Checked::Valid(Kind::Point) => Light::Point {
            position: Point3(position.to_array()),
            intensity: rgb,
        },
        Checked::Valid(Kind::Directional) => Light::Directional {
            direction: direction()?,
            irradiance: rgb,
        },
        Checked::Valid(Kind::Spot) => {
            let (inner, outer) = l
                .spot
                .as_ref()
                .map_or((0.0, std::f32::consts::FRAC_PI_4), |s| (s.inner_cone_angle, s.outer_cone_angle));
            if !(inner >= 0.0 && inner < outer && outer <= std::f32::consts::FRAC_PI_2) {
                return Err(format!(
                    "{}: its cone angles must satisfy 0 ≤ inner < outer ≤ π/2 (inner {inner}, outer {outer})",
                    what()
                ));
            }
            Light::Spot {
                position: Point3(position.to_array()),
                direction: direction()?,
                intensity: rgb,
                cone_degrees: Degrees(outer.to_degrees()),
                edge_degrees: NonNegative((outer - inner).to_degrees()),
            }
        }
        Checked::Invalid => return Err(format!("{}: its type is not directional, point or spot", what())),
    })
}

/// The triangles a primitive makes (`None`: not a triangle mode), from its
/// accessors' counts alone.
fn triangle_count(
    root: &json::Root,
    mesh: usize,
    p: usize,
    prim: &json::mesh::Primitive,
) -> std::result::Result<Option<u64>, String> {
    let at = || format!("mesh {}, primitive {p}", mesh_name(root, mesh));
    let mode = match prim.mode {
        Checked::Valid(m) => m,
        Checked::Invalid => return Err(format!("{}: its mode is not one of glTF's", at())),
    };
    let accessor = match prim.indices {
        Some(i) => i,
        None => *prim
            .attributes
            .get(&Checked::Valid(Semantic::Positions))
            .ok_or_else(|| format!("{}: it has no POSITION", at()))?,
    };
    let n = root
        .accessors
        .get(accessor.value())
        .ok_or_else(|| format!("{}: accessor {} does not exist", at(), accessor.value()))?
        .count
        .0;
    Ok(match mode {
        Mode::Triangles => Some(n / 3),
        Mode::TriangleStrip | Mode::TriangleFan => Some(n.saturating_sub(2)),
        _ => None,
    })
}

/// A decoded primitive: its vertices (in the mesh's frame) and the vertex
/// indices of its triangles, as the file orders them.
#[derive(Debug, Clone)]
struct Primitive {
    positions: Arc<Vec<glam::Vec3>>,
    /// Texture coordinates of the set its material's maps read (empty:
    /// untextured, or the primitive has none).
    texcoords: Vec<Vec2>,
    indices: Vec<u32>,
    mode: Mode,
    material: u32,
}

impl Primitive {
    /// Its triangles' vertex indices (§3.7.2.1: strips alternate their
    /// winding so every triangle keeps the first's orientation; fans
    /// share the first vertex).
    fn triangles(&self) -> impl Iterator<Item = [u32; 3]> + '_ {
        let ix = &self.indices;
        let n = match self.mode {
            Mode::Triangles => ix.len() / 3,
            _ => ix.len().saturating_sub(2),
        };
        (0..n).map(move |i| match self.mode {
            Mode::Triangles => [ix[3 * i], ix[3 * i + 1], ix[3 * i + 2]],
            Mode::TriangleStrip if i % 2 == 0 => [ix[i], ix[i + 1], ix[i + 2]],
            Mode::TriangleStrip => [ix[i + 1], ix[i], ix[i + 2]],
            _ => [ix[0], ix[i + 1], ix[i + 2]],
        })
    }
}

/// Reads accessors' data from the file's buffers, loading each buffer the
/// first time it is needed.
struct Reader<'a> {
    root: &'a json::Root,
    path: &'a Path,
    bin: Option<&'a [u8]>,
    buffers: Vec<Option<Arc<Vec<u8>>>>,
    external: &'a mut dyn FnMut(&str, &str) -> Result<Vec<u8>>,
    /// Each POSITION accessor's vertices, decoded once however many
    /// primitives share it.
    positions: Vec<Option<Arc<Vec<glam::Vec3>>>>,
    /// Bytes decoded so far (buffers, accessors' elements, vertices,
    /// indices and texture coordinates), against the memory budget
    /// ([`Reader::charge`]).
    decoded: u64,
}

/// A buffer view: its buffer's bytes, its offset and length there, and its
/// byte stride.
type ViewBytes = (Arc<Vec<u8>>, usize, usize, Option<usize>);

/// An accessor's elements as plain numbers, before they are assembled.
struct Elements {
    data: Arc<Vec<u8>>,
    /// Byte offset of element 0 in `data`, and between elements.
    offset: usize,
    stride: usize,
    count: usize,
    component: ComponentType,
    components: usize,
    normalized: bool,
}

impl Elements {
    /// Component `c` of element `i` as f64 (normalized integers mapped to
    /// [-1, 1] or [0, 1] as §3.11 says).
    fn get(&self, i: usize, c: usize) -> f64 {
        let size = component_size(self.component);
        let at = self.offset + i * self.stride + c * size;
        let b = &self.data[at..at + size];
        let norm = self.normalized;
        match self.component {
            ComponentType::F32 => f32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
            ComponentType::U32 => u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
            ComponentType::I8 if norm => (b[0] as i8 as f64 / 127.0).max(-1.0),
            ComponentType::I8 => b[0] as i8 as f64,
            ComponentType::U8 if norm => b[0] as f64 / 255.0,
            ComponentType::U8 => b[0] as f64,
            ComponentType::I16 if norm => (i16::from_le_bytes([b[0], b[1]]) as f64 / 32767.0).max(-1.0),
            ComponentType::I16 => i16::from_le_bytes([b[0], b[1]]) as f64,
            ComponentType::U16 if norm => u16::from_le_bytes([b[0], b[1]]) as f64 / 65535.0,
            ComponentType::U16 => u16::from_le_bytes([b[0], b[1]]) as f64,
        }
    }
}

fn component_size(c: ComponentType) -> usize {
    match c {
        ComponentType::I8 | ComponentType::U8 => 1,
        ComponentType::I16 | ComponentType::U16 => 2,
        ComponentType::U32 | ComponentType::F32 => 4,
    }
}

impl Reader<'_> {
    fn fail(&self, msg: String) -> Error {
        Error::user_file(self.path, msg)
    }

    /// Counts `bytes` more of decoded data (for `what`, in messages)
    /// against the memory budget, before they are allocated: a file of a
    /// few KB can name accessors of millions of elements without data
    /// (zeros, §3.6.2.3), or share one large accessor among many
    /// primitives, so every allocation the file's counts size is counted,
    /// and the file refused in one line rather than the allocator
    /// aborting the run.
    fn charge(&mut self, bytes: u64, what: &dyn Fn() -> String) -> Result<()> {
        let budget = limits::memory_budget();
        let total = self.decoded.saturating_add(bytes);
        if total > budget {
            return Err(self.fail(format!(
                "{}: decoding it needs {} more, {} in all, over this run's memory budget of {}",
                what(),
                input::bytes_text(bytes),
                input::bytes_text(total),
                input::bytes_text(budget)
            )));
        }
        self.decoded = total;
        Ok(())
    }

    /// Buffer `b`'s bytes (checked to hold its `byteLength`).
    fn buffer(&mut self, b: usize, at: &dyn Fn() -> String) -> Result<Arc<Vec<u8>>> {
        let Some(json) = self.root.buffers.get(b) else {
            return Err(self.fail(format!("{}: buffer {b} does not exist", at())));
        };
        if let Some(data) = &self.buffers[b] {
            return Ok(data.clone());
        }
        let data: Vec<u8> = match json.uri.as_deref() {
            None => match (b, self.bin) {
                (0, Some(bin)) => bin.to_vec(),
                _ => {
                    return Err(self.fail(format!(
                        "buffer {b} has no uri and is not a GLB's binary chunk"
                    )))
                }
            },
            Some("") => return Err(self.fail(format!("buffer {b} has an empty uri"))),
            Some(uri) if uri.starts_with("data:") => {
                data_uri(uri).map_err(|e| self.fail(format!("buffer {b}: {e}")))?
            }
            Some(uri) if uri.contains("://") => {
                return Err(self.fail(format!(
                    "buffer {b}: {uri:?} is not a file beside the glTF; probeplace reads no URL"
                )))
            }
            Some(uri) => {
                let name = percent_decode(uri)
                    .ok_or_else(|| self.fail(format!("buffer {b}: its uri {uri:?} is malformed")))?;
                (self.external)(&name, "glTF buffer").map_err(|e| self.fail(format!("buffer {b} ({uri:?}): {e}")))?
            }
        };
        if (data.len() as u64) < json.byte_length.0 {
            return Err(self.fail(format!(
                "buffer {b} holds {} bytes, fewer than its byteLength of {}",
                data.len(),
                json.byte_length.0
            )));
        }
        self.charge(data.len() as u64, &|| format!("buffer {b}"))?;
        let data = Arc::new(data);
        self.buffers[b] = Some(data.clone());
        Ok(data)
    }

    /// The bytes of buffer view `v` (checked to lie in its buffer).
    fn view(&mut self, v: usize, at: &dyn Fn() -> String) -> Result<ViewBytes> {
        let Some(view) = self.root.buffer_views.get(v) else {
            return Err(self.fail(format!("{}: buffer view {v} does not exist", at())));
        };
        let data = self.buffer(view.buffer.value(), at)?;
        let offset = view.byte_offset.map_or(0, |o| o.0);
        let length = view.byte_length.0;
        let declared = self.root.buffers[view.buffer.value()].byte_length.0;
        if offset.checked_add(length).is_none_or(|end| end > declared) {
            return Err(self.fail(format!(
                "{}: buffer view {v} (bytes {offset}..+{length}) runs past its buffer's {declared} bytes",
                at()
            )));
        }
        let stride = view.byte_stride.map(|s| s.0);
        Ok((data, offset as usize, length as usize, stride))
    }

    /// Accessor `a`'s elements, checked: its type `want`, its component type
    /// one of `allowed`, every element within its buffer view.
    fn elements(
        &mut self,
        a: usize,
        want: Type,
        allowed: &[ComponentType],
        at: &dyn Fn() -> String,
    ) -> Result<Elements> {
        let root = self.root;
        let Some(acc) = root.accessors.get(a) else {
            return Err(self.fail(format!("{}: accessor {a} does not exist", at())));
        };
        let here = || format!("{}: accessor {a}", at());
        if acc.type_ != Checked::Valid(want) {
            return Err(self.fail(format!("{} is not of type {want:?}", here())));
        }
        let component = match acc.component_type {
            Checked::Valid(c) if allowed.contains(&c.0) => c.0,
            _ => {
                return Err(self.fail(format!(
                    "{}: its component type must be one of {allowed:?}",
                    here()
                )))
            }
        };
        let components = match want {
            Type::Scalar => 1,
            Type::Vec2 => 2,
            Type::Vec3 => 3,
            _ => 4,
        };
        let size = component_size(component);
        let elem = size * components;
        let count = acc.count.0;
        let offset = acc.byte_offset.map_or(0, |o| o.0);
        let mut out = match acc.buffer_view {
            Some(v) => {
                let (data, view_offset, view_len, stride) = self.view(v.value(), &here)?;
                let stride = stride.unwrap_or(elem);
                if stride < elem {
                    return Err(self.fail(format!(
                        "{}: its view's byteStride {stride} is shorter than an element ({elem} bytes)",
                        here()
                    )));
                }
                let end = if count == 0 {
                    Some(0)
                } else {
                    (count - 1)
                        .checked_mul(stride as u64)
                        .and_then(|s| s.checked_add(offset))
                        .and_then(|s| s.checked_add(elem as u64))
                };
                if end.is_none_or(|e| e > view_len as u64) {
                    return Err(self.fail(format!(
                        "{}: {count} elements from byte {offset} run past its buffer view's {view_len} bytes",
                        here()
                    )));
                }
                Elements {
                    data,
                    offset: view_offset + offset as usize,
                    stride,
                    count: count as usize,
                    component,
                    components,
                    normalized: acc.normalized,
                }
            }
            None => {
                // All zeros (§3.6.2.3), at most what the scene could use.
                if count > 3 * max_triangles() {
                    return Err(self.fail(format!("{}: {count} elements without data", here())));
                }
                self.charge(count * elem as u64, &here)?;
                Elements {
                    data: Arc::new(vec![0; count as usize * elem]),
                    offset: 0,
                    stride: elem,
                    count: count as usize,
                    component,
                    components,
                    normalized: acc.normalized,
                }
            }
        };
        if let Some(sparse) = &acc.sparse {
            self.apply_sparse(&mut out, sparse, &here)?;
        }
        Ok(out)
    }

    /// Writes a sparse accessor's substitutions (§3.6.2.3) into `out`.
    fn apply_sparse(
        &mut self,
        out: &mut Elements,
        sparse: &json::accessor::sparse::Sparse,
        here: &dyn Fn() -> String,
    ) -> Result<()> {
        let n = sparse.count.0;
        if n > out.count as u64 {
            return Err(self.fail(format!(
                "{}: {n} sparse values for {} elements",
                here(),
                out.count
            )));
        }
        let n = n as usize;
        let index_type = match sparse.indices.component_type {
            Checked::Valid(c) if matches!(c.0, ComponentType::U8 | ComponentType::U16 | ComponentType::U32) => c.0,
            _ => return Err(self.fail(format!("{}: its sparse indices must be unsigned integers", here()))),
        };
        let read_range = |me: &mut Self, v: usize, offset: u64, elem: usize| -> Result<Vec<u8>> {
            let (data, view_offset, view_len, _) = me.view(v, here)?;
            let len = (n as u64).checked_mul(elem as u64).and_then(|l| l.checked_add(offset));
            if len.is_none_or(|l| l > view_len as u64) {
                return Err(me.fail(format!("{}: its sparse data run past their buffer view", here())));
            }
            let start = view_offset + offset as usize;
            Ok(data[start..start + n * elem].to_vec())
        };
        let isize = component_size(index_type);
        let idx = read_range(self, sparse.indices.buffer_view.value(), sparse.indices.byte_offset.0, isize)?;
        let elem = component_size(out.component) * out.components;
        let vals = read_range(self, sparse.values.buffer_view.value(), sparse.values.byte_offset.0, elem)?;
        // Dense and tightly packed from here on.
        self.charge((out.count * elem) as u64, here)?;
        let mut dense = Vec::with_capacity(out.count * elem);
        for i in 0..out.count {
            let at = out.offset + i * out.stride;
            dense.extend_from_slice(&out.data[at..at + elem]);
        }
        for k in 0..n {
            let b = &idx[k * isize..(k + 1) * isize];
            let i = match isize {
                1 => b[0] as usize,
                2 => u16::from_le_bytes([b[0], b[1]]) as usize,
                _ => u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as usize,
            };
            if i >= out.count {
                return Err(self.fail(format!(
                    "{}: sparse index {i} is past its {} elements",
                    here(),
                    out.count
                )));
            }
            dense[i * elem..(i + 1) * elem].copy_from_slice(&vals[k * elem..(k + 1) * elem]);
        }
        out.data = Arc::new(dense);
        out.offset = 0;
        out.stride = elem;
        Ok(())
    }

    /// The images the materials' `baseColorTexture`, `emissiveTexture` and
    /// `metallicRoughnessTexture` name, loaded ([`texture::load_images`]:
    /// each image once, within the texture budget; one that fails is a
    /// warning and its material keeps its factor), into `out.textures`,
    /// and the maps set on `out.materials` (glTF §3.9.2, §5.26 samplers'
    /// wrap modes, `KHR_texture_transform`); then each material's alpha
    /// mode as a cut-out ([`alpha_of`]). Returns each material's texture
    /// coordinate set (`TEXCOORD_n`), `None` for an untextured one.
    ///
    /// Errors: a texture, image or sampler index that names nothing.
    fn textures(&mut self, out: &mut GltfFile) -> Result<Vec<Option<u32>>> {
        let root = self.root;
        // (material, slot, info) of every map, checked.
        let mut uses: Vec<(usize, Slot, &json::texture::Info)> = Vec::new();
        let mut images: Vec<usize> = Vec::new();
        for (i, m) in root.materials.iter().enumerate() {
            let pbr = &m.pbr_metallic_roughness;
            let slots = [
                (Slot::Colour, pbr.base_color_texture.as_ref(), "baseColorTexture"),
                (Slot::Emission, m.emissive_texture.as_ref(), "emissiveTexture"),
                (Slot::MetalRough, pbr.metallic_roughness_texture.as_ref(), "metallicRoughnessTexture"),
            ];
            for (slot, info, what) in slots {
                let Some(info) = info else { continue };
                let here = || format!("material {}: {what}", named(i, m.name.as_deref()));
                let t = info.index.value();
                let Some(tex) = root.textures.get(t) else {
                    return Err(self.fail(format!("{}: texture {t} does not exist (the file has {})", here(), root.textures.len())));
                };
                let image = tex.source.value();
                if image >= root.images.len() {
                    return Err(self.fail(format!("{}: texture {t}'s image {image} does not exist (the file has {})", here(), root.images.len())));
                }
                // An image in a buffer view that does not exist is a bad
                // index, refused as every other (not a warning).
                if let Some(v) = root.images[image].buffer_view {
                    if v.value() >= root.buffer_views.len() {
                        return Err(self.fail(format!(
                            "{}: texture {t}'s image {image}: buffer view {} does not exist (the file has {})",
                            here(),
                            v.value(),
                            root.buffer_views.len()
                        )));
                    }
                }
                if let Some(s) = tex.sampler {
                    if s.value() >= root.samplers.len() {
                        return Err(self.fail(format!("{}: texture {t}'s sampler {} does not exist", here(), s.value())));
                    }
                }
                if !images.contains(&image) {
                    images.push(image);
                }
                uses.push((i, slot, info));
            }
        }
        let path = self.path;
        let names: Vec<String> = images
            .iter()
            .map(|&i| {
                let image = &root.images[i];
                match (&image.name, &image.uri) {
                    (_, Some(uri)) if !uri.starts_with("data:") => format!("{}: image {i} ({uri:?})", path.display()),
                    (Some(n), _) => format!("{}: image {i} ({n:?})", path.display()),
                    _ => format!("{}: image {i}", path.display()),
                }
            })
            .collect();
        let mut loaded = texture::load_images(images.len(), |k, _| (names[k].clone(), self.image_bytes(images[k])));
        out.warnings.append(&mut loaded.warnings);
        out.textures = loaded.textures;
        let index = loaded.index;
        out.files = names
            .into_iter()
            .zip(loaded.status)
            .map(|(name, status)| TextureFile { name, uses: Vec::new(), status })
            .collect();
        let mut sets: Vec<Option<u32>> = vec![None; root.materials.len()];
        let mut mixed: Vec<String> = Vec::new();
        // Each material's colour image, among `images`.
        let mut colour_image: Vec<Option<usize>> = vec![None; root.materials.len()];
        for (i, slot, info) in uses {
            let tex = &root.textures[info.index.value()];
            let k = images.iter().position(|&im| im == tex.source.value()).unwrap_or(0);
            out.files[k].add_use(slot.name());
            if slot == Slot::Colour {
                colour_image[i] = Some(k);
            }
            let Some(texture) = index[k] else { continue };
            let transform = info.extensions.as_ref().and_then(|e| e.texture_transform.as_ref());
            let set = transform.and_then(|t| t.tex_coord).unwrap_or(info.tex_coord);
            let wrap = |w: &Checked<json::texture::WrappingMode>| match w {
                Checked::Valid(json::texture::WrappingMode::ClampToEdge) => Wrap::Clamp,
                Checked::Valid(json::texture::WrappingMode::MirroredRepeat) => Wrap::Mirror,
                _ => Wrap::Repeat,
            };
            let wraps = tex
                .sampler
                .map(|s| &root.samplers[s.value()])
                .map_or([Wrap::Repeat; 2], |s| [wrap(&s.wrap_s), wrap(&s.wrap_t)]);
            let map = TextureMap {
                texture,
                transform: transform.map_or(TextureMap::IDENTITY, |t| {
                    // KHR_texture_transform: T · R · S, R = [cos sin; −sin cos].
                    let finite = |v: f32, d: f32| if v.is_finite() { v } else { d };
                    let (o, r, sc) = (t.offset.0, finite(t.rotation.0, 0.0), t.scale.0);
                    let (sin, cos) = r.sin_cos();
                    let (sx, sy) = (finite(sc[0], 1.0), finite(sc[1], 1.0));
                    [cos * sx, sin * sy, finite(o[0], 0.0), -sin * sx, cos * sy, finite(o[1], 0.0)]
                }),
                wrap: wraps,
            };
            let m = &mut out.materials[i];
            match slot {
                Slot::Colour => m.diffuse_map = Some(map),
                Slot::Emission => m.emission_map = Some(map),
                Slot::MetalRough => {
                    let ((base, metallic, roughness), _) = factors(&root.materials[i]);
                    let (f0, _) = dielectric_f0(&root.materials[i]);
                    // What reads the material without a point sees the
                    // lobes of the texture's mean metal and roughness.
                    let mean = out.textures[texture as usize].mean_data();
                    let (d, sp, ns) = super::MetalRough::lobes(
                        base,
                        metallic * mean.z as f64,
                        roughness * mean.y as f64,
                        f0,
                    );
                    (m.diffuse, m.specular, m.shininess) = (d, sp, ns);
                    m.metal_rough = Some(super::MetalRough {
                        base: base.map(|b| b as f32),
                        metallic: metallic as f32,
                        roughness: roughness as f32,
                        f0: f0.map(|f| f as f32),
                        map,
                    });
                }
            }
            match sets[i] {
                Some(s) if s != set => mixed.push(m.name.clone()),
                Some(_) => {}
                None => sets[i] = Some(set),
            }
        }
        if !mixed.is_empty() {
            out.warnings.push(format!(
                "{}: material(s) {} read their textures through different TEXCOORD sets; all use the first one's",
                path.display(),
                mixed.iter().take(LISTED).map(|n| format!("`{n}`")).collect::<Vec<_>>().join(", ")
            ));
        }
        // Alpha: a cut-out where the mode asks for one.
        let mut blend: Vec<String> = Vec::new();
        for (i, m) in root.materials.iter().enumerate() {
            if m.alpha_mode == Checked::Valid(json::material::AlphaMode::Blend) {
                blend.push(named(i, m.name.as_deref()));
            }
            let material = &mut out.materials[i];
            material.cutout = alpha_of(m, material.diffuse_map, &out.textures);
            if let (Some(_), Some(k)) = (material.cutout.and_then(|c| c.map), colour_image[i]) {
                out.files[k].add_use("alpha");
            }
        }
        if !blend.is_empty() {
            out.warnings.push(format!(
                "{}: material(s) {} blend by alpha (`alphaMode` BLEND): rays read them as MASK at alpha 0.5, passing where alpha is under it",
                path.display(),
                super::first_of(&blend, LISTED)
            ));
        }
        Ok(sets)
    }

    /// The bytes of image `i`: its buffer view, its `data:` URI, or the
    /// file beside the glTF its URI names; `Err` says why not, in words.
    fn image_bytes(&mut self, i: usize) -> std::result::Result<Vec<u8>, String> {
        let image = &self.root.images[i];
        let strip = |e: Error| {
            let e = e.to_string();
            let prefix = format!("{}: ", self.path.display());
            e.strip_prefix(&prefix).unwrap_or(&e).to_string()
        };
        if let Some(v) = image.buffer_view {
            let at = || format!("image {i}");
            let (data, offset, len, _) = self.view(v.value(), &at).map_err(strip)?;
            return Ok(data[offset..offset + len].to_vec());
        }
        match image.uri.as_deref() {
            None => Err("neither a uri nor a buffer view".into()),
            Some(uri) if uri.starts_with("data:") => data_uri(uri),
            Some(uri) if uri.contains("://") => Err("a URL; probeplace reads only files beside the glTF".into()),
            Some(uri) => {
                let name = percent_decode(uri).ok_or("its uri is malformed")?;
                (self.external)(&name, "glTF image").map_err(|e| e.to_string())
            }
        }
    }

    /// Primitive `p` of mesh `mesh`, decoded (`None`: not triangles), with
    /// the texture coordinates of the set `sets` gives its material.
    fn primitive(
        &mut self,
        mesh: usize,
        p: usize,
        prim: &json::mesh::Primitive,
        sets: &[Option<u32>],
    ) -> Result<Option<Primitive>> {
        let root = self.root;
        let at = || format!("mesh {}, primitive {p}", mesh_name(root, mesh));
        let mode = match prim.mode {
            Checked::Valid(m @ (Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan)) => m,
            _ => return Ok(None),
        };
        let material = match prim.material {
            None => u32::MAX,
            Some(m) if m.value() < root.materials.len() => m.value() as u32,
            Some(m) => {
                return Err(self.fail(format!(
                    "{}: material {} does not exist (the file has {})",
                    at(),
                    m.value(),
                    root.materials.len()
                )))
            }
        };
        let Some(&pos) = prim.attributes.get(&Checked::Valid(Semantic::Positions)) else {
            return Err(self.fail(format!("{}: it has no POSITION", at())));
        };
        let at_pos = || format!("{} POSITION", at());
        use ComponentType::*;
        let positions = match self.positions.get(pos.value()).cloned().flatten() {
            Some(p) => p,
            None => {
                let e = self.elements(pos.value(), Type::Vec3, &[F32, I8, U8, I16, U16], &at_pos)?;
                self.charge(e.count as u64 * 12, &|| format!("{}: accessor {}", at_pos(), pos.value()))?;
                let p: Arc<Vec<glam::Vec3>> = Arc::new(
                    (0..e.count)
                        .map(|i| glam::DVec3::new(e.get(i, 0), e.get(i, 1), e.get(i, 2)).as_vec3())
                        .collect(),
                );
                if let Some(slot) = self.positions.get_mut(pos.value()) {
                    *slot = Some(p.clone());
                }
                p
            }
        };
        let indices: Vec<u32> = match prim.indices {
            Some(ix) => {
                let at_ix = || format!("{} indices", at());
                let e = self.elements(ix.value(), Type::Scalar, &[U8, U16, U32], &at_ix)?;
                self.charge(e.count as u64 * 4, &at_ix)?;
                let mut out = Vec::with_capacity(e.count);
                for i in 0..e.count {
                    let v = e.get(i, 0) as u64;
                    if v >= positions.len() as u64 {
                        return Err(self.fail(format!(
                            "{}: index {i} of accessor {} names vertex {v}; POSITION holds {}",
                            at(),
                            ix.value(),
                            positions.len()
                        )));
                    }
                    out.push(v as u32);
                }
                out
            }
            None => {
                if positions.len() > u32::MAX as usize {
                    return Err(self.fail(format!("{}: too many vertices", at())));
                }
                self.charge(positions.len() as u64 * 4, &at_pos)?;
                (0..positions.len() as u32).collect()
            }
        };
        let set = sets.get(material as usize).copied().flatten();
        let texcoords = match set.and_then(|n| prim.attributes.get(&Checked::Valid(Semantic::TexCoords(n)))) {
            Some(&uv) => {
                let at_uv = || format!("{} TEXCOORD_{}", at(), set.unwrap_or(0));
                // Normalized 8/16-bit, or (KHR_mesh_quantization) plain
                // integers, which a texture transform then scales.
                let e = self.elements(uv.value(), Type::Vec2, &[F32, I8, U8, I16, U16], &at_uv)?;
                self.charge(e.count as u64 * 8, &at_uv)?;
                (0..e.count)
                    .map(|i| Vec2::new(e.get(i, 0) as f32, e.get(i, 1) as f32))
                    .collect()
            }
            None => Vec::new(),
        };
        Ok(Some(Primitive {
            positions,
            texcoords,
            indices,
            mode,
            material,
        }))
    }
}

/// The bytes of a `data:` URI (RFC 2397), which glTF allows only in
/// base64; `Err` says why not, in words.
fn data_uri(uri: &str) -> std::result::Result<Vec<u8>, String> {
    let (head, body) = uri.split_once(',').unwrap_or((uri, ""));
    if !head.ends_with(";base64") {
        return Err("a data URI that is not base64".into());
    }
    base64::engine::general_purpose::STANDARD
        .decode(body.trim())
        .map_err(|e| format!("its base64 data URI is malformed: {e}"))
}

/// A URI reference's percent-escapes decoded (RFC 3986 §2.1); `None` when
/// an escape is malformed or the result is not UTF-8.
fn percent_decode(uri: &str) -> Option<String> {
    let bytes = uri.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        if bytes[i] == b'%' {
            let hex = std::str::from_utf8(bytes.get(i + 1..i + 3)?).ok()?;
            out.push(u8::from_str_radix(hex, 16).ok()?);
            i += 3;
        } else {
            out.push(bytes[i]);
            i += 1;
        }
    }
    String::from_utf8(out).ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn percent_escapes_decode() {
        assert_eq!(percent_decode("a%20b.bin").as_deref(), Some("a b.bin"));
        assert_eq!(percent_decode("plain.bin").as_deref(), Some("plain.bin"));
        assert_eq!(percent_decode("bad%2"), None);
        assert_eq!(percent_decode("bad%zz"), None);
    }

    #[test]
    fn strips_and_fans_keep_the_first_triangles_winding() {
        let p = |mode| Primitive {
            positions: Arc::new(vec![glam::Vec3::ZERO; 5]),
            texcoords: Vec::new(),
            indices: vec![0, 1, 2, 3, 4],
            mode,
            material: 0,
        };
        let strip: Vec<_> = p(Mode::TriangleStrip).triangles().collect();
        assert_eq!(strip, vec![[0, 1, 2], [2, 1, 3], [2, 3, 4]]);
        let fan: Vec<_> = p(Mode::TriangleFan).triangles().collect();
        assert_eq!(fan, vec![[0, 1, 2], [0, 2, 3], [0, 3, 4]]);
        let list: Vec<_> = p(Mode::Triangles).triangles().collect();
        assert_eq!(list, vec![[0, 1, 2]]);
    }

    #[test]
    fn metallic_roughness_maps_onto_the_bsdf() {
        let mut m: json::Material = serde_json::from_str(
            r#"{"pbrMetallicRoughness":{"baseColorFactor":[0.5,0.25,1,1],"metallicFactor":0,"roughnessFactor":1},"emissiveFactor":[1,0.5,0]}"#,
        )
        .unwrap();
        let (d, clamped) = material_of(0, &m);
        assert!(!clamped);
        assert_eq!(d.diffuse, [0.5, 0.25, 1.0]);
        assert_eq!(d.specular, [0.04; 3]);
        assert_eq!(crate::render::material::alpha_from_shininess(d.shininess), 1.0);
        assert_eq!(d.emission, [1.0, 0.5, 0.0]);
        m.pbr_metallic_roughness.metallic_factor.0 = 1.0;
        m.pbr_metallic_roughness.roughness_factor.0 = 0.5;
        let (metal, _) = material_of(0, &m);
        assert_eq!(metal.diffuse, [0.0; 3]);
        assert_eq!(metal.specular, [0.5, 0.25, 1.0]);
        let alpha = crate::render::material::alpha_from_shininess(metal.shininess);
        assert!((alpha - 0.25).abs() < 1e-6, "{alpha}");
        m.pbr_metallic_roughness.base_color_factor.0[0] = f32::NAN;
        let (nan, clamped) = material_of(3, &m);
        assert!(clamped);
        assert_eq!(nan.specular[0], 1.0, "a non-finite base colour is glTF's default, 1");
    }

    #[test]
    fn glb_chunks_are_bounded_by_the_file() {
        let mut glb = b"glTF".to_vec();
        glb.extend(2u32.to_le_bytes());
        glb.extend(24u32.to_le_bytes());
        glb.extend(100u32.to_le_bytes());
        glb.extend(0x4E4F_534Au32.to_le_bytes());
        glb.extend(b"{}{}");
        assert!(container(&glb).unwrap_err().contains("past the end"));
        glb[12..16].copy_from_slice(&4u32.to_le_bytes());
        assert_eq!(container(&glb).unwrap(), (&b"{}{}"[..], None));
        for length in [5u32, 25] {
            glb[8..12].copy_from_slice(&length.to_le_bytes());
            assert!(container(&glb).unwrap_err().contains("header gives a length"));
        }
        assert!(container(b"glTF\x02\0\0").is_err());
        glb[8..12].copy_from_slice(&24u32.to_le_bytes());
        glb[16..20].copy_from_slice(b"BIN\0");
        assert!(container(&glb).unwrap_err().contains("not JSON"));
    }
}
