//! Scene loading: an OBJ (+ MTL) file becomes a flat list of triangles with
//! per-triangle materials, ready for every later stage.
//!
//! Coordinates: the file is read, scaled and turned Y-up in f64, then stored
//! in f32 *relative to the scene's own origin* ([`Scene::origin`], the lower
//! corner of its bounding box), not in absolute world coordinates. Every stage
//! computes in these local coordinates, so that a scene gives the same
//! result wherever it sits: f32 world coordinates 1 km from the world origin
//! are only good to 61 µm, 100 km away to 7.8 mm, and the stages' epsilons
//! (a thousandth of a voxel in occlusion tests) would drown in that rounding.
//! Config inputs are world coordinates, converted once by
//! [`Scene::to_local`]; outputs go back through [`Scene::to_world`].
//!
//! Real assets are messy (see ../shared/scenes/README.md): quads and
//! polygons, negative indices, missing normals, hundreds of models per file,
//! missing MTL files, degenerate faces. Loading repairs what it can and says
//! so in warnings; it refuses only files with no usable triangle.

pub mod gltf;
pub mod obj;
pub mod raycast;
pub mod texture;
pub mod watertight;
mod wide_bvh;

use crate::config::params::UpAxis;
use crate::error::{Error, Result};
use glam::{DVec3, Vec2, Vec3};
use rayon::prelude::*;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// The subset of an MTL material that the lighting stages use
/// (McGuire et al. 2017 §3 bakes radiance from Lambertian + glossy surfaces).
#[derive(Debug, Clone, PartialEq)]
pub struct Material {
    /// Material name from the MTL file (`default` for the fallback).
    pub name: String,
    /// Diffuse albedo `Kd`.
    pub diffuse: [f32; 3],
    /// Specular colour `Ks`.
    pub specular: [f32; 3],
    /// Phong exponent `Ns`.
    pub shininess: f32,
    /// Emitted radiance `Ke`.
    pub emission: [f32; 3],
    /// A colour texture (`map_Kd`, glTF's `baseColorTexture`): the diffuse
    /// albedo at a point is `diffuse ×` its texel ([`texture`] module docs).
    pub diffuse_map: Option<texture::TextureMap>,
    /// An emission texture (`map_Ke`, glTF's `emissiveTexture`): the
    /// emitted radiance at a point is `emission ×` its texel.
    pub emission_map: Option<texture::TextureMap>,
    /// glTF's metallic-roughness parameters, where the material has a
    /// `metallicRoughnessTexture`: its BSDF is then made per texel
    /// ([`Scene::colours_at`]), and `diffuse`, `specular` and `shininess`
    /// hold the lobes of the texture's mean metal and roughness (for what
    /// reads a material without a point: previews, exports).
    pub metal_rough: Option<MetalRough>,
    /// Where rays pass through the surface (glTF's `alphaMode` MASK, an
    /// MTL's `map_d` or `d`): every ray test of the scene skips it there
    /// ([`raycast::SceneBvh`]).
    pub cutout: Option<Cutout>,
}

/// glTF's metallic-roughness material (§3.9.2) with a
/// `metallicRoughnessTexture`: at a point, metal is `metallic ×` the
/// texel's blue channel and roughness `roughness ×` its green one (raw
/// values, not sRGB), and the base colour `base ×` the colour texture's
/// texel ([`Material::diffuse_map`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MetalRough {
    /// `baseColorFactor`'s colour.
    pub base: [f32; 3],
    /// `metallicFactor`.
    pub metallic: f32,
    /// `roughnessFactor`.
    pub roughness: f32,
    /// A dielectric's specular reflectance `F0`: 0.04, or what
    /// `KHR_materials_specular`'s factors make it.
    pub f0: [f32; 3],
    /// The `metallicRoughnessTexture`.
    pub map: texture::TextureMap,
}

impl MetalRough {
    /// The BSDF's `(Kd, Ks, Ns)` of base colour `base`, metal `metallic`
    /// and roughness `roughness` (each in [0, 1]) and a dielectric's
    /// specular reflectance `f0`: a dielectric's base colour is its
    /// diffuse albedo beside a specular reflectance of `f0` (the
    /// specification's 4%, unless `KHR_materials_specular` says
    /// otherwise), a metal's base colour its specular reflectance and no
    /// diffuse, mixed by `metallic`; the GGX roughness `α = roughness²` is
    /// stored as the Phong exponent `Ns = 2/α² − 2` that
    /// [`crate::render::material::alpha_from_shininess`] maps back.
    pub fn lobes(
        base: [f64; 3],
        metallic: f64,
        roughness: f64,
        f0: [f64; 3],
    ) -> ([f32; 3], [f32; 3], f32) {
        let alpha = roughness * roughness;
        let shininess = if alpha > 0.0 {
            (2.0 / (alpha * alpha) - 2.0).min(obj::MAX_SHININESS)
        } else {
            obj::MAX_SHININESS
        };
        (
            base.map(|b| (b * (1.0 - metallic)) as f32),
            [0, 1, 2].map(|c| (f0[c] * (1.0 - metallic) + base[c] * metallic) as f32),
            shininess as f32,
        )
    }
}

/// Where a surface lets rays through: its alpha, `factor ×` the map's
/// (the alpha channel; with `grey`, a map without one is read by its
/// first channel, as an MTL's `map_d` often is), is below `cutoff`
/// (glTF §3.9.4's `alphaMode` MASK: "rendered fully opaque" at or above
/// the cutoff, "fully transparent" below it). BLEND and an MTL's
/// dissolve are read as MASK at 0.5: a ray either passes or stops.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cutout {
    /// The alpha where the map is opaque (`baseColorFactor`'s alpha, `d`).
    pub factor: f32,
    /// The alpha texture, if any.
    pub map: Option<texture::TextureMap>,
    /// Whether a map without an alpha channel is read by its first channel.
    pub grey: bool,
    /// Alpha at and above which the surface stops rays (`alphaCutoff`).
    pub cutoff: f32,
}

impl Cutout {
    /// Whether the surface stops rays at texture coordinates `uv`.
    ///
    /// Contract: the map indexes `textures`; allocation-free.
    #[inline]
    pub fn opaque_at(&self, textures: &[Arc<texture::Texture>], uv: Vec2) -> bool {
        let a = match self.map {
            Some(m) => textures[m.texture as usize].sample_alpha(m.apply(uv), m.wrap, self.grey),
            None => 1.0,
        };
        self.factor * a >= self.cutoff
    }

    /// Whether the surface lets every ray through (no map, and its factor
    /// under the cutoff).
    pub fn everywhere(&self) -> bool {
        self.map.is_none() && self.factor < self.cutoff
    }
}

impl Material {
    /// The material given to faces whose material is missing: light grey, matte.
    pub fn fallback() -> Material {
        Material {
            name: "default".into(),
            diffuse: [0.8; 3],
            specular: [0.0; 3],
            shininess: 1.0,
            emission: [0.0; 3],
            diffuse_map: None,
            emission_map: None,
            metal_rough: None,
            cutout: None,
        }
    }

    /// Whether anything of it varies over the surface (a texture map of
    /// colour, emission, metal and roughness, or alpha): its triangles
    /// then need texture coordinates.
    pub fn is_textured(&self) -> bool {
        self.diffuse_map.is_some()
            || self.emission_map.is_some()
            || self.metal_rough.is_some()
            || self.cutout.is_some_and(|c| c.map.is_some())
    }

    /// The texture maps it reads, each with its use (for messages and
    /// `report.json`'s list of textures).
    pub fn maps(&self) -> impl Iterator<Item = (&'static str, texture::TextureMap)> + '_ {
        [
            ("colour", self.diffuse_map),
            ("emission", self.emission_map),
            ("metal-roughness", self.metal_rough.map(|m| m.map)),
            ("alpha", self.cutout.and_then(|c| c.map)),
        ]
        .into_iter()
        .filter_map(|(what, m)| m.map(|m| (what, m)))
    }
}

/// An axis-aligned box.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Bounds {
    /// Lower corner.
    pub min: Vec3,
    /// Upper corner.
    pub max: Vec3,
}

impl Bounds {
    /// The empty box, identity of [`Bounds::grow`].
    pub fn empty() -> Bounds {
        Bounds {
            min: Vec3::splat(f32::INFINITY),
            max: Vec3::splat(f32::NEG_INFINITY),
        }
    }

    /// Extends the box to contain `p`.
    pub fn grow(&mut self, p: Vec3) {
        self.min = self.min.min(p);
        self.max = self.max.max(p);
    }

    /// Edge lengths.
    pub fn size(&self) -> Vec3 {
        self.max - self.min
    }

    /// Distance from `p` (inside the box) along `d` to the box's boundary;
    /// 0 from outside, +∞ for a zero direction.
    pub fn exit_distance(&self, p: Vec3, d: Vec3) -> f32 {
        let mut t = f32::INFINITY;
        for axis in 0..3 {
            if d[axis] > 0.0 {
                t = t.min((self.max[axis] - p[axis]) / d[axis]);
            } else if d[axis] < 0.0 {
                t = t.min((self.min[axis] - p[axis]) / d[axis]);
            }
        }
        t.max(0.0)
    }

    /// Whether `p` lies inside or on the box.
    pub fn contains(&self, p: Vec3) -> bool {
        p.cmpge(self.min).all() && p.cmple(self.max).all()
    }
}

/// A loaded scene: Y up, coordinates multiplied by the config's scale, stored
/// relative to [`Scene::origin`] (module docs).
#[derive(Debug, Clone)]
pub struct Scene {
    /// The file it came from.
    pub source: PathBuf,
    /// World position of the local coordinates' zero: `world = local + origin`.
    /// For a loaded file, the lower corner of its triangles' bounding box
    /// (computed in f64), so that local coordinates are no larger than the
    /// scene, hence as precise in f32 as its size allows, wherever it sits;
    /// zero for [`Scene::from_triangles`].
    ///
    /// Why the corner rather than the centre, which would gain one bit: the
    /// corner is the domain's and the SDF's lower corner, which thus stays
    /// exact in world coordinates (`svo.bin`'s origin, `report.json`'s
    /// bounds), and a scene modelled from the world origin, as most are, has
    /// local coordinates equal to its world ones, so its results do not move.
    pub origin: DVec3,
    /// Triangles in local coordinates, counter-clockwise from the front as
    /// written in the file.
    pub triangles: Vec<[Vec3; 3]>,
    /// Unit geometric normal of each triangle, `(b-a)×(c-a)` normalized.
    pub normals: Vec<Vec3>,
    /// Index into `materials` for each triangle.
    pub material_ids: Vec<u32>,
    /// Materials; the last one is the fallback for faces without a material.
    pub materials: Vec<Material>,
    /// Bounds of all triangles, in local coordinates.
    pub bounds: Bounds,
    /// Number of faces dropped as degenerate (zero area) or non-finite.
    pub dropped_triangles: usize,
    /// Number of faces dropped as exact copies of an earlier one
    /// ([`coincident_copies`]).
    pub coincident_triangles: usize,
    /// Human-readable warnings raised while loading.
    pub warnings: Vec<String>,
    /// Lights the file defines (glTF's `KHR_lights_punctual`), in world
    /// coordinates like the config's: every renderer lights the scene with
    /// them besides the config's `lights` ([`crate::render::lights::LightSet`]),
    /// unless the config's `scene_lights` is `Ignore`. An OBJ has none.
    pub lights: Vec<crate::config::params::Light>,
    /// The file format it was read from: `"obj"` ([`load_obj`]), `"gltf"`
    /// ([`load_gltf`]), or `"generated"` for triangles given in code.
    pub format: &'static str,
    /// Texture coordinates of each triangle's corners (glTF's convention:
    /// [`texture`] module docs), or empty when no material has a texture
    /// (most scenes: their triangles then carry none).
    pub texcoords: Vec<[Vec2; 3]>,
    /// The decoded textures the materials' maps index.
    pub textures: Vec<Arc<texture::Texture>>,
    /// Every image file the materials name, read or not: what
    /// `report.json` lists and the summary line counts.
    pub texture_files: Vec<texture::TextureFile>,
}

impl Scene {
    /// Builds a scene from triangles given directly in local coordinates
    /// (procedural scenes, tests), with [`Scene::origin`] zero, so local and
    /// world coordinates agree. Degenerate and non-finite triangles are
    /// dropped as in [`load_obj`].
    pub fn from_triangles(
        source: PathBuf,
        triangles: impl IntoIterator<Item = ([Vec3; 3], u32)>,
        materials: Vec<Material>,
    ) -> Result<Scene> {
        Scene::assemble(source, DVec3::ZERO, 0, triangles, materials, Vec::new())
    }

    /// [`Scene::from_triangles`] with texture coordinates for each triangle
    /// and the `textures` its materials' maps index (procedural scenes and
    /// tests of textured materials).
    ///
    /// Contract: every map of `materials` indexes `textures`; an error
    /// ([`Error::User`]) otherwise.
    pub fn from_textured_triangles(
        source: PathBuf,
        triangles: impl IntoIterator<Item = ([Vec3; 3], u32, [Vec2; 3])>,
        materials: Vec<Material>,
        textures: Vec<Arc<texture::Texture>>,
    ) -> Result<Scene> {
        let (triangles, uvs): (Vec<_>, Vec<_>) =
            triangles.into_iter().map(|(t, m, uv)| ((t, m), uv)).unzip();
        let bad = materials
            .iter()
            .flat_map(|m| m.maps())
            .any(|(_, m)| m.texture as usize >= textures.len());
        if bad {
            return Err(Error::user_file(&source, "a material's texture map names no texture"));
        }
        let mut scene = Scene::assemble(source, DVec3::ZERO, 0, triangles, materials, uvs)?;
        scene.textures = textures;
        Ok(scene)
    }

    /// Builds a scene from triangles in world coordinates (f64): the origin
    /// is the lower corner of the usable triangles' bounding box, and the triangles
    /// are stored relative to it. Degenerate and non-finite triangles are
    /// dropped as in [`load_obj`], before the bounds are taken, so that a
    /// stray face cannot pull the origin away from the scene.
    pub fn from_world_triangles(
        source: PathBuf,
        triangles: impl IntoIterator<Item = ([DVec3; 3], u32)>,
        materials: Vec<Material>,
    ) -> Result<Scene> {
        let all: Vec<([DVec3; 3], u32)> = triangles.into_iter().collect();
        Scene::from_world(source, all.len(), |i| all[i], materials, Vec::new())
    }

    /// [`Scene::from_world_triangles`] of the `n` triangles `triangle(0)`,
    /// `triangle(1)`, … The tests and conversions run in parallel (millions
    /// of triangles in a large scene); the origin is the minimum taken in
    /// file order, so that which of a −0 and a +0 it keeps does not depend
    /// on how the work was split. `texcoords` is empty, or holds the `n`
    /// triangles' texture coordinates.
    fn from_world(
        source: PathBuf,
        n: usize,
        triangle: impl Fn(usize) -> ([DVec3; 3], u32) + Sync,
        materials: Vec<Material>,
        mut texcoords: Vec<[Vec2; 3]>,
    ) -> Result<Scene> {
        let kept: Vec<bool> = (0..n)
            .into_par_iter()
            .map(|i| usable(&triangle(i).0))
            .collect();
        let dropped = kept.iter().filter(|&&k| !k).count();
        let origin = (0..n)
            .filter(|&i| kept[i])
            .flat_map(|i| triangle(i).0)
            .reduce(DVec3::min)
            .unwrap_or(DVec3::ZERO);
        // Every triangle converted (a count known in advance fills the
        // vector in place), the dropped ones then taken out.
        let mut local: Vec<([Vec3; 3], u32)> = (0..n)
            .into_par_iter()
            .map(|i| {
                let (tri, material) = triangle(i);
                (tri.map(|v| (v - origin).as_vec3()), material)
            })
            .collect();
        if dropped > 0 {
            let mut keep = kept.iter();
            local.retain(|_| keep.next() == Some(&true));
            if !texcoords.is_empty() {
                let mut keep = kept.iter();
                texcoords.retain(|_| keep.next() == Some(&true));
            }
        }
        Scene::assemble(source, origin, dropped, local, materials, texcoords)
    }

    /// The world position of local point `p`, in f64 (for outputs).
    pub fn to_world(&self, p: Vec3) -> DVec3 {
        self.origin + p.as_dvec3()
    }

    /// The local coordinates of world point `p` (for inputs): the
    /// difference is taken in f64, then rounded once to f32.
    pub fn to_local(&self, p: DVec3) -> Vec3 {
        (p - self.origin).as_vec3()
    }

    /// A scene with `origin` from local `triangles`, `dropped` faces already
    /// dropped by the caller; `texcoords` empty or one per triangle, kept
    /// only when a material has a texture map.
    fn assemble(
        source: PathBuf,
        origin: DVec3,
        dropped: usize,
        triangles: impl IntoIterator<Item = ([Vec3; 3], u32)>,
        materials: Vec<Material>,
        texcoords: Vec<[Vec2; 3]>,
    ) -> Result<Scene> {
        let mut scene = Scene {
            source,
            origin,
            triangles: Vec::new(),
            normals: Vec::new(),
            material_ids: Vec::new(),
            materials,
            bounds: Bounds::empty(),
            dropped_triangles: dropped,
            coincident_triangles: 0,
            warnings: Vec::new(),
            lights: Vec::new(),
            format: "generated",
            texcoords: Vec::new(),
            textures: Vec::new(),
            texture_files: Vec::new(),
        };
        let textured = scene.materials.iter().any(Material::is_textured);
        scene.materials.push(Material::fallback());
        let fallback = (scene.materials.len() - 1) as u32;
        // The arrays are filled in parallel, in order; the bounds grow in
        // order, so that which of a −0 and a +0 they keep does not depend
        // on how the work was split.
        let mut triangles: Vec<([Vec3; 3], u32)> = triangles.into_iter().collect();
        let mut texcoords = texcoords;
        let copies = coincident_copies(&triangles);
        if !copies.is_empty() {
            scene.coincident_triangles = copies.len();
            let mut copy = vec![false; triangles.len()];
            for &i in &copies {
                copy[i as usize] = true;
            }
            let mut it = copy.iter();
            triangles.retain(|_| it.next() == Some(&false));
            if !texcoords.is_empty() {
                let mut it = copy.iter();
                texcoords.retain(|_| it.next() == Some(&false));
            }
        }
        let normals: Vec<Option<Vec3>> = triangles
            .par_iter()
            .map(|(tri, _)| usable_normal(tri))
            .collect();
        let materials = scene.materials.len();
        let material = |m: u32| {
            if (m as usize) < materials {
                m
            } else {
                fallback
            }
        };
        let texcoords = if textured && texcoords.len() == triangles.len() {
            texcoords
        } else {
            Vec::new()
        };
        if normals.iter().all(Option::is_some) {
            scene.triangles = triangles.par_iter().map(|&(tri, _)| tri).collect();
            scene.material_ids = triangles.par_iter().map(|&(_, m)| material(m)).collect();
            scene.normals = normals.par_iter().map(|n| n.unwrap_or_default()).collect();
            scene.texcoords = texcoords;
        } else {
            for (i, ((tri, m), normal)) in triangles.into_iter().zip(normals).enumerate() {
                let Some(normal) = normal else {
                    scene.dropped_triangles += 1;
                    continue;
                };
                scene.triangles.push(tri);
                scene.normals.push(normal);
                scene.material_ids.push(material(m));
                if let Some(uv) = texcoords.get(i) {
                    scene.texcoords.push(*uv);
                }
            }
        }
        for tri in &scene.triangles {
            for &v in tri {
                scene.bounds.grow(v);
            }
        }
        scene.finish()?;
        Ok(scene)
    }

    fn finish(&mut self) -> Result<()> {
        if self.coincident_triangles > 0 {
            self.warnings.push(format!(
                "{}: dropped {} triangle(s) that repeat an earlier one exactly (the same three corners, wound alike), as copies of a mesh placed twice at one place do; a copy adds no surface, only work",
                self.source.display(),
                self.coincident_triangles
            ));
        }
        if self.dropped_triangles > 0 {
            self.warnings.push(format!(
                "{}: dropped {} degenerate or non-finite triangle(s)",
                self.source.display(),
                self.dropped_triangles
            ));
        }
        if self.triangles.is_empty() {
            return Err(Error::user_file(
                &self.source,
                "scene has no usable triangle (empty, or every face degenerate or non-finite)",
            ));
        }
        if self.triangles.len() > wide_bvh::MAX_PRIMITIVES {
            return Err(Error::user_file(
                &self.source,
                format!(
                    "{} triangles, more than the {} one BVH holds; split the scene into tiles (`probeplace split`)",
                    self.triangles.len(),
                    wide_bvh::MAX_PRIMITIVES
                ),
            ));
        }
        Ok(())
    }

    /// The texture coordinates at local point `p` of triangle `triangle`
    /// (interpolated from its corners'), or zero where the scene has none.
    ///
    /// Contract: `triangle` indexes [`Scene::triangles`]; `p` on (or near)
    /// its plane. Allocation-free.
    pub fn texcoord_at(&self, triangle: usize, p: Vec3) -> Vec2 {
        match self.texcoords.get(triangle) {
            Some(uv) => texture::interpolate(uv, texture::barycentric(&self.triangles[triangle], p)),
            None => Vec2::ZERO,
        }
    }

    /// Whether triangle `triangle` is surface at local point `p` (on it):
    /// everywhere but in a cut-out's holes ([`Cutout`]), which every ray
    /// passes and coverage does not sample.
    ///
    /// Contract: `triangle` indexes [`Scene::triangles`]; allocation-free.
    #[inline]
    pub fn opaque_at(&self, triangle: usize, p: Vec3) -> bool {
        match self.materials[self.material_ids[triangle] as usize].cutout {
            None => true,
            Some(c) => c.opaque_at(&self.textures, self.texcoord_at(triangle, p)),
        }
    }

    /// The BSDF's `(Kd, Ks, Ns)` of `material` at texture coordinates
    /// `uv`: [`Scene::diffuse_at`] with the material's `Ks` and `Ns`, or
    /// for a metallic-roughness material ([`MetalRough`]) the lobes of
    /// its base colour, metal and roughness at the texel.
    ///
    /// Contract: the material's maps index [`Scene::textures`];
    /// allocation-free.
    #[inline]
    pub fn colours_at(&self, material: &Material, uv: Vec2) -> ([f32; 3], [f32; 3], f32) {
        let Some(mr) = material.metal_rough else {
            return (self.diffuse_at(material, uv), material.specular, material.shininess);
        };
        let base = match material.diffuse_map {
            Some(map) => Vec3::from(mr.base) * map.sample(&self.textures, uv),
            None => Vec3::from(mr.base),
        };
        let d = self.textures[mr.map.texture as usize].sample_data(mr.map.apply(uv), mr.map.wrap);
        MetalRough::lobes(
            base.as_dvec3().to_array(),
            (mr.metallic * d.z) as f64,
            (mr.roughness * d.y) as f64,
            mr.f0.map(f64::from),
        )
    }

    /// The diffuse colour factor of `material` at texture coordinates `uv`:
    /// `Kd` times its colour texture's texel, if it has one.
    pub fn diffuse_at(&self, material: &Material, uv: Vec2) -> [f32; 3] {
        match material.diffuse_map {
            Some(map) => (Vec3::from(material.diffuse) * map.sample(&self.textures, uv)).to_array(),
            None => material.diffuse,
        }
    }

    /// The emission of `material` at texture coordinates `uv`: `Ke` times
    /// its emission texture's texel, if it has one.
    pub fn emission_at(&self, material: &Material, uv: Vec2) -> [f32; 3] {
        match material.emission_map {
            Some(map) => (Vec3::from(material.emission) * map.sample(&self.textures, uv)).to_array(),
            None => material.emission,
        }
    }

    /// Total surface area (one side of each triangle).
    pub fn area(&self) -> f64 {
        self.triangle_areas().sum()
    }

    /// Area of each triangle, in order.
    pub fn triangle_areas(&self) -> impl Iterator<Item = f64> + '_ {
        self.triangles
            .iter()
            .map(|t| 0.5 * (t[1] - t[0]).cross(t[2] - t[0]).length() as f64)
    }
}

/// The unit normal of a local triangle, or `None` when it is not finite or
/// is degenerate: a relative area test, since a sliver whose area is below
/// float resolution of its edges has no usable normal.
fn usable_normal(tri: &[Vec3; 3]) -> Option<Vec3> {
    if !tri.iter().all(|v| v.is_finite()) {
        return None;
    }
    let cross = (tri[1] - tri[0]).cross(tri[2] - tri[0]);
    let scale = (tri[1] - tri[0])
        .length_squared()
        .max((tri[2] - tri[0]).length_squared());
    let bound = 1e-12 * scale * scale;
    if cross.is_finite() && cross.length_squared().is_finite() && bound.is_finite() {
        return (cross.length_squared() > bound).then(|| cross.normalize());
    }
    // Edges near 1e19 and beyond: their squares overflow f32, and a normal
    // normalized from an infinite length is zero (the fuzzer's
    // `nonunit-normal.glb`). In f64 no f32 input overflows.
    let [a, b, c] = tri.map(|v| v.as_dvec3());
    let cross = (b - a).cross(c - a);
    let scale = (b - a).length_squared().max((c - a).length_squared());
    if cross.length_squared() <= 1e-12 * scale * scale {
        return None;
    }
    let n = cross.normalize().as_vec3();
    ((n.length() - 1.0).abs() < 1e-4).then_some(n)
}

/// The indices of the triangles that repeat an earlier one exactly: the
/// same three corners (bit for bit) in the same cyclic order, so a
/// back-to-back pair (a two-sided sheet) is kept. Such copies (a mesh
/// instanced many times at one place) add no surface, but every stage
/// pays for each: the SDF's band and every ray that reaches them test
/// them all. Found by sorting hashes of the corners rotated to start at
/// the least one, then comparing the triangles of equal hashes exactly;
/// the first in file order is kept. Sorted ascending; empty for most
/// scenes, at the cost of one parallel sort.
fn coincident_copies(triangles: &[([Vec3; 3], u32)]) -> Vec<u32> {
    let canonical = |t: &[Vec3; 3]| -> [u32; 9] {
        let bits = t.map(|v| v.to_array().map(|c| if c == 0.0 { 0 } else { c.to_bits() }));
        let first = (0..3).min_by_key(|&k| bits[k]).unwrap_or(0);
        let mut key = [0u32; 9];
        for k in 0..3 {
            key[3 * k..3 * k + 3].copy_from_slice(&bits[(first + k) % 3]);
        }
        key
    };
    let mut hashed: Vec<(u64, u32)> = triangles
        .par_iter()
        .enumerate()
        .map(|(i, (t, _))| {
            // FNV-1a over the canonical corners.
            let mut h: u64 = 0xcbf2_9ce4_8422_2325;
            for w in canonical(t) {
                for b in w.to_le_bytes() {
                    h = (h ^ b as u64).wrapping_mul(0x0100_0000_01b3);
                }
            }
            (h, i as u32)
        })
        .collect();
    hashed.par_sort_unstable();
    let mut copies = Vec::new();
    let mut run = 0;
    while run < hashed.len() {
        let mut end = run + 1;
        while end < hashed.len() && hashed[end].0 == hashed[run].0 {
            end += 1;
        }
        if end - run > 1 {
            // Equal hashes: sorted by corners, then file order, every
            // triangle after the first of equal corners is a copy (a hash
            // collision has other corners and is kept).
            let mut keys: Vec<([u32; 9], u32)> = hashed[run..end]
                .iter()
                .map(|&(_, i)| (canonical(&triangles[i as usize].0), i))
                .collect();
            keys.sort_unstable();
            for pair in keys.windows(2) {
                if pair[1].0 == pair[0].0 {
                    copies.push(pair[1].1);
                }
            }
        }
        run = end;
    }
    copies.sort_unstable();
    copies
}

/// Whether a world-space triangle is finite and not degenerate: the test
/// of [`Scene::from_triangles`], in f64.
fn usable(tri: &[DVec3; 3]) -> bool {
    let (e1, e2) = (tri[1] - tri[0], tri[2] - tri[0]);
    let cross = e1.cross(e2);
    let scale = e1.length_squared().max(e2.length_squared());
    tri.iter().all(|v| v.is_finite())
        && cross.is_finite()
        && cross.length_squared() > 1e-12 * scale * scale
}

/// Maps a point of the OBJ file to world space: scale, then rotate Z-up
/// files to Y-up. In f64, like the parsed file, so that nothing is lost
/// before the scene's origin is subtracted.
pub fn file_to_world(p: DVec3, scale: f64, up: UpAxis) -> DVec3 {
    let p = p * scale;
    match up {
        UpAxis::Y => p,
        UpAxis::Z => DVec3::new(p.x, p.z, -p.y),
    }
}

/// Inverse of [`file_to_world`]: world space back to the OBJ file's coordinates.
pub fn world_to_file(p: DVec3, scale: f64, up: UpAxis) -> DVec3 {
    let p = match up {
        UpAxis::Y => p,
        UpAxis::Z => DVec3::new(p.x, -p.z, p.y),
    };
    p / scale
}

/// Loads an OBJ file: world space (file coordinates × `scale`, Y up), stored
/// relative to the lower corner of the scene's bounding box
/// ([`Scene::from_world_triangles`]).
///
/// Contract: every stage works with geometric normals (the winding's
/// `(b-a)×(c-a)`), whether or not the file has normals: placement and
/// coverage need the side a face is seen from, not a smoothed shading normal.
/// The file is read by [`obj::read`] (its limits and repairs); quads and
/// polygons are fan-triangulated; negative indices are resolved; faces
/// are kept in file order; degenerate or non-finite triangles are dropped
/// and counted in one warning; a missing MTL is a warning and its faces
/// get [`Material::fallback`].
/// Errors ([`Error::User`], naming the file and line): not a regular
/// file, malformed OBJ, a limit exceeded, no usable triangle.
pub fn load_obj(path: &Path, scale: f64, up: UpAxis) -> Result<Scene> {
    let obj::ObjFile {
        positions,
        triangles,
        mut materials,
        mut warnings,
        texcoords,
        triangle_texcoords,
        maps,
    } = obj::read(path)?;
    let obj_dir = path.parent().unwrap_or(Path::new(""));
    let (textures, texture_files) = obj_textures(&mut materials, &maps, obj_dir, &mut warnings);
    let textured = materials.iter().any(Material::is_textured);
    let uvs: Vec<[Vec2; 3]> = if textured && !triangle_texcoords.is_empty() {
        triangle_texcoords
            .par_iter()
            .map(|t| {
                t.map(|i| match texcoords.get(i as usize) {
                    // OBJ's v grows upwards, the image's rows downwards.
                    Some(&[u, v]) => Vec2::new(u, 1.0 - v),
                    None => Vec2::ZERO,
                })
            })
            .collect()
    } else {
        Vec::new()
    };
    drop((texcoords, triangle_texcoords));
    let world: Vec<DVec3> = positions
        .par_iter()
        .map(|&p| file_to_world(p, scale, up))
        .collect();
    drop(positions);
    let triangle = |i: usize| {
        let (t, material) = triangles[i];
        (t.map(|v| world[v as usize]), material)
    };
    let mut scene =
        Scene::from_world(path.to_path_buf(), triangles.len(), triangle, materials, uvs)?;
    warnings.append(&mut scene.warnings);
    scene.warnings = warnings;
    scene.format = "obj";
    scene.textures = textures;
    scene.texture_files = texture_files;
    Ok(scene)
}

/// Loads the images an OBJ's materials map (each file once, however many
/// materials name it) and sets the materials' [`texture::TextureMap`]s;
/// a map whose image did not load is left out, with a warning
/// ([`texture::load_images`]). Each file is looked for where the MTL
/// names it, then as [`texture::locate_map`] says; one warning names the
/// files found in another letter case, one those found elsewhere.
/// Returns the textures and the list of files `report.json` gives.
fn obj_textures(
    materials: &mut [Material],
    maps: &[obj::MapSpec],
    obj_dir: &Path,
    warnings: &mut Vec<String>,
) -> (Vec<Arc<texture::Texture>>, Vec<texture::TextureFile>) {
    let mut files: Vec<&obj::MapSpec> = Vec::new();
    for m in maps {
        if !files.iter().any(|f| f.file == m.file) {
            files.push(m);
        }
    }
    let limit = crate::limits::memory_budget();
    let located: Vec<Option<(PathBuf, texture::Found)>> = files
        .iter()
        .map(|f| texture::locate_map(&f.file, &f.written, obj_dir))
        .collect();
    let name_of = |p: &Path| p.file_name().unwrap_or_default().to_string_lossy().into_owned();
    let found = |how: texture::Found, show: &dyn Fn(&obj::MapSpec, &Path) -> String| -> Vec<String> {
        files
            .iter()
            .zip(&located)
            .filter_map(|(f, l)| match l {
                Some((at, h)) if *h == how => Some(show(f, at)),
                _ => None,
            })
            .collect()
    };
    let respelt = found(texture::Found::Respelt, &|f, at| {
        format!("{} as {}", name_of(&f.file), name_of(at))
    });
    if !respelt.is_empty() {
        let dir = files[0].file.parent().map(|d| d.display().to_string()).unwrap_or_default();
        warnings.push(format!(
            "{dir}: {} texture(s) found in another letter case: {}",
            respelt.len(),
            first_of(&respelt, 5)
        ));
    }
    let mut moved = found(texture::Found::BesideObj, &|f, at| {
        format!("{} at {} (beside the OBJ)", f.written.display(), at.display())
    });
    moved.extend(found(texture::Found::InMtlFolder, &|f, at| {
        format!("{} at {} (in the MTL's folder)", f.written.display(), at.display())
    }));
    if !moved.is_empty() {
        warnings.push(format!(
            "{} texture(s) not where the MTL names them (relative to its folder) but found elsewhere: {}",
            moved.len(),
            first_of(&moved, 5)
        ));
    }
    let names: Vec<String> = files.iter().map(|f| f.file.display().to_string()).collect();
    let mut images = texture::load_images(files.len(), |i, left| {
        let name = names[i].clone();
        let Some((at, _)) = &located[i] else {
            // Not found, or there but not to be opened (a symbolic-link
            // loop): the OS's reason, rather than "not found".
            return match crate::input::open(&files[i].file, "texture", 0) {
                Err(e) if !e.to_string().ends_with("texture not found") => {
                    let e = e.to_string();
                    let shown = format!("{}: ", files[i].file.display());
                    (name, Err(e.strip_prefix(&shown).unwrap_or(&e).to_string()))
                }
                _ => (name, Err("texture not found".into())),
            };
        };
        let bytes = crate::input::read(at, "texture", limit.min(left)).map_err(|e| {
            let e = e.to_string();
            let shown = at.display().to_string();
            e.strip_prefix(&format!("{shown}: ")).unwrap_or(&e).to_string()
        });
        (name, bytes)
    });
    warnings.append(&mut images.warnings);
    let mut list: Vec<texture::TextureFile> = files
        .iter()
        .zip(&located)
        .zip(images.status)
        .map(|((f, l), status)| texture::TextureFile {
            // The file read, where one was found.
            name: l.as_ref().map_or_else(|| f.file.display().to_string(), |(at, _)| at.display().to_string()),
            uses: Vec::new(),
            status,
        })
        .collect();
    for m in maps {
        let file = files.iter().position(|f| f.file == m.file).unwrap_or(0);
        list[file].add_use(m.slot.name());
        let Some(texture) = images.index[file] else {
            continue;
        };
        let [su, sv] = m.scale;
        let [ou, ov] = m.offset;
        // MTL's `-s`/`-o` act in OBJ's v-up coordinates; the scene stores
        // v flipped (`w = 1 − v`), so `1 − (sv (1 − w) + ov)`.
        let map = texture::TextureMap {
            texture,
            transform: [su, 0.0, ou, 0.0, sv, 1.0 - sv - ov],
            wrap: [if m.clamp {
                texture::Wrap::Clamp
            } else {
                texture::Wrap::Repeat
            }; 2],
        };
        let slot = &mut materials[m.material];
        match m.slot {
            obj::MapSlot::Colour => slot.diffuse_map = Some(map),
            obj::MapSlot::Emission => slot.emission_map = Some(map),
            obj::MapSlot::Alpha => {
                let cut = slot.cutout.get_or_insert(Cutout {
                    factor: 1.0,
                    map: None,
                    grey: true,
                    cutoff: 0.5,
                });
                cut.map = Some(map);
            }
        }
    }
    (images.textures, list)
}

/// The scene format of `path`: glTF 2.0 for a `.gltf` or `.glb` name (any
/// case) or a regular file that starts with GLB's magic bytes, OBJ
/// otherwise. The file is opened as [`crate::input::open`] opens it, so a
/// FIFO or a device is never read (nor waited on): it is an "OBJ", whose
/// reader then refuses it in words.
pub fn is_gltf(path: &Path) -> bool {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    if matches!(ext.as_deref(), Some("gltf" | "glb")) {
        return true;
    }
    let mut magic = [0u8; 4];
    crate::input::open(path, "scene file", u64::MAX)
        .and_then(|(mut f, _)| {
            std::io::Read::read_exact(&mut f, &mut magic).map_err(|e| Error::io(path, e))
        })
        .is_ok_and(|_| &magic == b"glTF")
}

/// Loads the scene file at `path`, glTF 2.0 or OBJ ([`is_gltf`]):
/// [`load_gltf`] or [`load_obj`].
pub fn load(path: &Path, scale: f64, up: UpAxis) -> Result<Scene> {
    if is_gltf(path) {
        load_gltf(path, scale, up)
    } else {
        load_obj(path, scale, up)
    }
}

/// Loads a glTF 2.0 file (`.gltf` with its buffers, or `.glb`): the
/// triangles of the default scene's mesh instances, with their materials
/// and the file's punctual lights ([`gltf::read`] says what is read and
/// how). glTF is in metres with +Y up; `scale` and `up` still apply, as
/// for an OBJ, after the node transforms. The scene is then built as
/// [`load_obj`] builds one (origin, dropped triangles, warnings).
pub fn load_gltf(path: &Path, scale: f64, up: UpAxis) -> Result<Scene> {
    let gltf::GltfFile {
        triangles,
        materials,
        lights,
        mut warnings,
        texcoords,
        textures,
        files,
    } = gltf::read(path, scale, up)?;
    let n = triangles.len();
    let mut scene =
        Scene::from_world(path.to_path_buf(), n, |i| triangles[i], materials, texcoords)?;
    scene.textures = textures;
    scene.texture_files = files;
    warnings.append(&mut scene.warnings);
    scene.warnings = warnings;
    scene.lights = lights;
    scene.format = "gltf";
    Ok(scene)
}

/// The first `most` of `items` joined by commas, then how many more: how
/// every loader's warning names a long list (`a, b and 3 more`).
pub(crate) fn first_of(items: &[impl AsRef<str>], most: usize) -> String {
    let shown: Vec<&str> = items.iter().take(most).map(AsRef::as_ref).collect();
    match items.len().saturating_sub(most) {
        0 => shown.join(", "),
        n => format!("{} and {n} more", shown.join(", ")),
    }
}
/// Small analytic scenes shared by the unit tests of several stages.
#[cfg(test)]
pub mod testing {
    use super::raycast::SceneBvh;
    use super::{Material, Scene};
    use crate::config::{Placement, SdfParams};
    use crate::placement::{PlacementInput, ProbeSet};
    use crate::progress::Progress;
    use crate::sdf::{self, Sdf};
    use glam::Vec3;

    /// [`room_with_box`] with its BVH and its SDF at `voxel` (default SDF parameters).
    pub fn room_sdf(voxel: f32, seed: u64) -> (Scene, SceneBvh, Sdf) {
        let scene = room_with_box();
        let (bvh, sdf) = bvh_and_sdf(&scene, voxel, seed);
        (scene, bvh, sdf)
    }

    /// `scene`'s BVH and its SDF over its bounds at `voxel` (default SDF parameters).
    pub fn bvh_and_sdf(scene: &Scene, voxel: f32, seed: u64) -> (SceneBvh, Sdf) {
        let bvh = SceneBvh::new(scene);
        let sdf = sdf::build(
            scene,
            &bvh,
            &scene.bounds,
            voxel,
            &SdfParams::default(),
            seed,
            &Progress::hidden(),
        )
        .expect("the test scene's SDF builds");
        (bvh, sdf)
    }

    /// The placement input over `scene`'s bounds with `seed`.
    pub fn input_over<'a>(
        scene: &'a Scene,
        bvh: &'a SceneBvh,
        sdf: &'a Sdf,
        seed: u64,
        progress: &'a Progress,
    ) -> PlacementInput<'a> {
        PlacementInput {
            scene,
            bvh,
            sdf,
            domain: &scene.bounds,
            seed,
            progress,
        }
    }

    /// Runs placement `method` over `scene`'s bounds with seed 5.
    pub fn place_in(
        method: &Placement,
        scene: &Scene,
        bvh: &SceneBvh,
        sdf: &Sdf,
    ) -> crate::Result<ProbeSet> {
        crate::placement::place(method, &input_over(scene, bvh, sdf, 5, &Progress::hidden()))
    }

    /// A closed room (single-sided walls facing inward) with a solid box inside
    /// (faces outward), all axis-aligned.
    pub fn room_with_box() -> Scene {
        Scene::from_triangles(
            "room".into(),
            room_with_box_triangles().into_iter().map(|t| (t, 0)),
            vec![Material::fallback()],
        )
        .unwrap()
    }

    /// The triangles of [`room_with_box`]: the 4 m room's walls, then the
    /// 1 m box's faces.
    pub fn room_with_box_triangles() -> Vec<[Vec3; 3]> {
        let mut tris = Vec::new();
        add_box(&mut tris, Vec3::ZERO, Vec3::splat(4.0), true);
        add_box(
            &mut tris,
            Vec3::new(1.0, 0.0, 1.0),
            Vec3::new(2.0, 1.0, 2.0),
            false,
        );
        tris
    }

    /// Adds the 12 triangles of box `[lo, hi]`, normals inward when `inward`.
    pub fn add_box(out: &mut Vec<[Vec3; 3]>, lo: Vec3, hi: Vec3, inward: bool) {
        let corner = |i: usize| {
            Vec3::new(
                if i & 1 == 0 { lo.x } else { hi.x },
                if i & 2 == 0 { lo.y } else { hi.y },
                if i & 4 == 0 { lo.z } else { hi.z },
            )
        };
        // Faces as corner quads, counter-clockwise seen from outside.
        let quads = [
            [0, 2, 3, 1], // -z
            [4, 5, 7, 6], // +z
            [0, 4, 6, 2], // -x
            [1, 3, 7, 5], // +x
            [0, 1, 5, 4], // -y
            [2, 6, 7, 3], // +y
        ];
        for q in quads {
            let [a, b, c, d] = q.map(corner);
            if inward {
                out.push([a, c, b]);
                out.push([a, d, c]);
            } else {
                out.push([a, b, c]);
                out.push([a, c, d]);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Write;

    fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
        let p = dir.join(name);
        std::fs::File::create(&p)
            .unwrap()
            .write_all(text.as_bytes())
            .unwrap();
        p
    }

    #[test]
    fn long_lists_are_named_in_part_and_counted() {
        assert_eq!(first_of(&["a", "b"], 5), "a, b");
        assert_eq!(first_of(&["a", "b", "c"], 2), "a, b and 1 more");
        assert_eq!(first_of(&Vec::<String>::new(), 2), "");
    }

    #[test]
    fn a_textured_triangle_reads_its_texels_where_a_point_falls() {
        // Left texel black, right texel white, clamped; the triangle's
        // corners at u = 0, 1, 0.
        let t = texture::Texture::from_srgb8("t".into(), 2, 1, vec![[0; 3], [255; 3]]);
        let mut m = Material::fallback();
        m.diffuse = [0.5; 3];
        m.diffuse_map = Some(texture::TextureMap {
            wrap: [texture::Wrap::Clamp; 2],
            ..texture::TextureMap::new(0)
        });
        let tri = [Vec3::ZERO, Vec3::X, Vec3::Z];
        let uv = [Vec2::new(0.0, 0.5), Vec2::new(1.0, 0.5), Vec2::new(0.0, 0.5)];
        let s = Scene::from_textured_triangles("t".into(), [(tri, 0, uv)], vec![m.clone()], vec![Arc::new(t.clone())])
            .unwrap();
        let at = |x: f32| s.diffuse_at(&s.materials[0], s.texcoord_at(0, Vec3::new(x, 0.0, 0.1)))[0];
        assert_eq!(at(0.1), 0.0);
        assert_eq!(at(0.8), 0.5);
        assert!((at(0.5) - 0.25).abs() < 1e-6, "{}", at(0.5));
        // A map that names no texture is refused.
        let e = Scene::from_textured_triangles("t".into(), [(tri, 0, uv)], vec![m], vec![]).unwrap_err();
        assert!(e.to_string().contains("names no texture"), "{e}");
    }

    #[test]
    fn quads_negative_indices_and_missing_mtl() {
        let dir = tempfile::tempdir().unwrap();
        let p = write(
            dir.path(),
            "q.obj",
            "mtllib nope.mtl\nv 0 0 0\nv 1 0 0\nv 1 0 1\nv 0 0 1\nusemtl x\nf -4 -1 -2 -3\n",
        );
        let s = load_obj(&p, 2.0, UpAxis::Y).unwrap();
        assert_eq!(s.triangles.len(), 2);
        // Stored relative to the bounding box's lower corner, here the
        // world origin: local and world coordinates agree.
        assert_eq!(s.origin, DVec3::ZERO);
        assert_eq!(s.bounds.max, Vec3::new(2.0, 0.0, 2.0));
        assert_eq!(s.to_world(s.bounds.max), DVec3::new(2.0, 0.0, 2.0));
        assert!(
            s.warnings.iter().any(|w| w.contains("material")),
            "{:?}",
            s.warnings
        );
        assert_eq!(s.materials[s.material_ids[0] as usize].name, "default");
        // Winding (0,0,0)->(0,0,1)->(1,0,1) gives a +Y normal.
        assert!(s.normals[0].y > 0.99);
    }

    #[test]
    fn exact_copies_are_dropped_and_a_back_to_back_pair_is_kept() {
        let a = [Vec3::ZERO, Vec3::X, Vec3::Y];
        let rotated = [Vec3::X, Vec3::Y, Vec3::ZERO];
        let reversed = [Vec3::ZERO, Vec3::Y, Vec3::X];
        let nudged = [Vec3::ZERO, Vec3::X, Vec3::new(0.0, 1.0, 1e-6)];
        let tris: Vec<([Vec3; 3], u32)> = [a, reversed, a, rotated, nudged, a]
            .into_iter()
            .map(|t| (t, 0))
            .collect();
        // A copy in another cyclic order is the same face; the reversed
        // one is the back of a sheet; the nudged one is other geometry.
        assert_eq!(coincident_copies(&tris), [2, 3, 5]);
        let scene = Scene::from_triangles("t.obj".into(), tris.clone(), Vec::new()).unwrap();
        assert_eq!(scene.triangles.len(), 3);
        assert_eq!(scene.coincident_triangles, 3);
        assert!(scene.warnings.iter().any(|w| w.contains("dropped 3 triangle(s) that repeat")));
    }

    #[test]
    fn degenerate_and_nan_faces_are_dropped_with_a_warning() {
        let dir = tempfile::tempdir().unwrap();
        let p = write(
            dir.path(),
            "d.obj",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 2 0 0\nv nan 0 0\nf 1 2 3\nf 1 2 4\nf 1 5 3\n",
        );
        let s = load_obj(&p, 1.0, UpAxis::Y).unwrap();
        assert_eq!(s.triangles.len(), 1);
        assert_eq!(s.dropped_triangles, 2);
        assert!(s.warnings.iter().any(|w| w.contains("dropped 2")));
    }

    #[test]
    fn z_up_files_are_rotated_to_y_up() {
        let p = DVec3::new(1.0, 2.0, 3.0);
        let w = file_to_world(p, 2.0, UpAxis::Z);
        assert_eq!(w, DVec3::new(2.0, 6.0, -4.0));
        assert_eq!(world_to_file(w, 2.0, UpAxis::Z), p);
    }

    /// A tetrahedron with coordinates that f32 cannot hold exactly, its
    /// corners shifted by `offset`, as OBJ text with enough decimals that
    /// the file itself is exact to the nanometre.
    fn tetrahedron_obj(offset: DVec3) -> String {
        let corners = [
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(1.234567, 0.0, 0.1),
            DVec3::new(0.3, 0.987654, -0.2),
            DVec3::new(0.4, 0.3, 1.111111),
        ];
        let mut text = String::new();
        for c in corners {
            let v = c + offset;
            text += &format!("v {:.9} {:.9} {:.9}\n", v.x, v.y, v.z);
        }
        text + "f 1 3 2\nf 1 2 4\nf 2 3 4\nf 1 4 3\n"
    }

    #[test]
    fn scenes_far_from_the_origin_keep_their_shape() {
        let dir = tempfile::tempdir().unwrap();
        let offset = DVec3::new(1e5, -2e5, 3e5);
        let near = load_obj(
            &write(dir.path(), "near.obj", &tetrahedron_obj(DVec3::ZERO)),
            1.0,
            UpAxis::Y,
        )
        .unwrap();
        let far = load_obj(
            &write(dir.path(), "far.obj", &tetrahedron_obj(offset)),
            1.0,
            UpAxis::Y,
        )
        .unwrap();
        assert_eq!(far.triangles.len(), 4);
        assert!((far.origin - near.origin - offset).abs().max_element() < 1e-9);
        for (a, b) in near.triangles.iter().zip(&far.triangles) {
            for (i, j) in [(0, 1), (0, 2), (1, 2)] {
                let (ea, eb) = (a[j] - a[i], b[j] - b[i]);
                assert!((ea - eb).abs().max_element() < 1e-6, "{ea} against {eb}");
            }
            // Local coordinates are the same; world ones are the file's.
            for (va, vb) in a.iter().zip(b) {
                assert!((*va - *vb).abs().max_element() < 1e-6);
                let back = far.to_world(*vb) - offset;
                assert!((back - near.to_world(*va)).abs().max_element() < 1e-6);
            }
        }
        for (a, b) in near.normals.iter().zip(&far.normals) {
            assert!((*a - *b).abs().max_element() < 1e-6, "{a} against {b}");
        }
        assert!((near.area() - far.area()).abs() < 1e-6 * near.area());
    }

    #[test]
    fn local_and_world_coordinates_convert_both_ways() {
        let dir = tempfile::tempdir().unwrap();
        let offset = DVec3::new(1e6, 3e5, -7e5);
        let s = load_obj(
            &write(dir.path(), "t.obj", &tetrahedron_obj(offset)),
            1.0,
            UpAxis::Y,
        )
        .unwrap();
        // The origin is the bounding box's lower corner, exact in world
        // coordinates.
        assert_eq!(s.bounds.min, Vec3::ZERO);
        assert!(
            (s.origin - offset - DVec3::new(0.0, 0.0, -0.2))
                .abs()
                .max_element()
                < 1e-9
        );
        assert_eq!(s.to_world(s.bounds.min), s.origin);
        let world = DVec3::new(1e6 + 0.5, 3e5 + 0.25, -7e5 - 0.125);
        let local = s.to_local(world);
        assert!((s.to_world(local) - world).abs().max_element() < 1e-7);
        // Local points round-trip exactly: to_world is exact in f64.
        for p in [Vec3::ZERO, Vec3::new(0.3, -0.7, 1e-3), s.bounds.max] {
            assert_eq!(s.to_local(s.to_world(p)), p);
        }
        let procedural = testing::room_with_box();
        assert_eq!(procedural.origin, DVec3::ZERO);
        assert_eq!(
            procedural.to_world(Vec3::new(1.0, 2.0, 3.0)),
            DVec3::new(1.0, 2.0, 3.0)
        );
    }

    #[test]
    fn unusable_files_are_user_errors() {
        let dir = tempfile::tempdir().unwrap();
        for (name, text) in [
            ("empty.obj", ""),
            ("nan.obj", "v nan 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"),
            ("bad.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n"),
            ("junk.obj", "v zero one two\nf 1 2 3\n"),
        ] {
            let p = write(dir.path(), name, text);
            match load_obj(&p, 1.0, UpAxis::Y) {
                Err(Error::User(m)) => assert!(m.contains(name), "{m}"),
                other => panic!("{name}: expected a user error, got {other:?}"),
            }
        }
        assert!(matches!(
            load_obj(&dir.path().join("missing.obj"), 1.0, UpAxis::Y),
            Err(Error::User(_))
        ));
    }

    #[test]
    fn malformed_mtl_is_a_warning_not_a_panic() {
        let dir = tempfile::tempdir().unwrap();
        write(dir.path(), "m.mtl", "newmtl a\nKe 1 2\n");
        let p = write(
            dir.path(),
            "m.obj",
            "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl a\nf 1 2 3\n",
        );
        match load_obj(&p, 1.0, UpAxis::Y) {
            Ok(s) => assert_eq!(s.triangles.len(), 1),
            Err(Error::User(m)) => assert!(m.contains("m.obj"), "{m}"),
            Err(e) => panic!("{e:?}"),
        }
    }
}


