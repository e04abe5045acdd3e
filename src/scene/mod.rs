//! Scene loading: an OBJ (+ MTL) file becomes a flat list of world-space
//! triangles with per-triangle materials, ready for every later stage.
//!
//! Real assets are messy (see ../shared/scenes/README.md): quads and
//! polygons, negative indices, missing normals, hundreds of models per file,
//! missing MTL files, degenerate faces. Loading repairs what it can and says
//! so in warnings; it refuses only files with no usable triangle.

pub mod raycast;

use crate::config::UpAxis;
use crate::error::{Error, Result};
use glam::Vec3;
use std::path::{Path, PathBuf};

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
        }
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

/// A loaded scene in world space: Y up, coordinates multiplied by the config's scale.
#[derive(Debug, Clone)]
pub struct Scene {
    /// The file it came from.
    pub source: PathBuf,
    /// Triangles, counter-clockwise from the front as written in the file.
    pub triangles: Vec<[Vec3; 3]>,
    /// Unit geometric normal of each triangle, `(b-a)×(c-a)` normalized.
    pub normals: Vec<Vec3>,
    /// Index into `materials` for each triangle.
    pub material_ids: Vec<u32>,
    /// Materials; the last one is the fallback for faces without a material.
    pub materials: Vec<Material>,
    /// Bounds of all triangles.
    pub bounds: Bounds,
    /// Number of faces dropped as degenerate (zero area) or non-finite.
    pub dropped_triangles: usize,
    /// Human-readable warnings raised while loading.
    pub warnings: Vec<String>,
}

impl Scene {
    /// Builds a scene from triangles given directly (procedural scenes, tests).
    /// Degenerate and non-finite triangles are dropped as in [`load_obj`].
    pub fn from_triangles(
        source: PathBuf,
        triangles: impl IntoIterator<Item = ([Vec3; 3], u32)>,
        materials: Vec<Material>,
    ) -> Result<Scene> {
        let mut scene = Scene {
            source,
            triangles: Vec::new(),
            normals: Vec::new(),
            material_ids: Vec::new(),
            materials,
            bounds: Bounds::empty(),
            dropped_triangles: 0,
            warnings: Vec::new(),
        };
        scene.materials.push(Material::fallback());
        let fallback = (scene.materials.len() - 1) as u32;
        for (tri, material) in triangles {
            let material = if (material as usize) < scene.materials.len() {
                material
            } else {
                fallback
            };
            scene.push(tri, material);
        }
        scene.finish()?;
        Ok(scene)
    }

    fn push(&mut self, tri: [Vec3; 3], material: u32) {
        let cross = (tri[1] - tri[0]).cross(tri[2] - tri[0]);
        let finite = tri.iter().all(|v| v.is_finite());
        // Relative area test: a sliver whose area is below float resolution of
        // its edges has no usable normal.
        let scale = (tri[1] - tri[0])
            .length_squared()
            .max((tri[2] - tri[0]).length_squared());
        if !finite || !cross.is_finite() || cross.length_squared() <= 1e-12 * scale * scale {
            self.dropped_triangles += 1;
            return;
        }
        for v in tri {
            self.bounds.grow(v);
        }
        self.triangles.push(tri);
        self.normals.push(cross.normalize());
        self.material_ids.push(material);
    }

    fn finish(&mut self) -> Result<()> {
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
        Ok(())
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

/// Maps a file-space point to world space: scale, then rotate Z-up files to Y-up.
pub fn to_world(p: Vec3, scale: f32, up: UpAxis) -> Vec3 {
    let p = p * scale;
    match up {
        UpAxis::Y => p,
        UpAxis::Z => Vec3::new(p.x, p.z, -p.y),
    }
}

/// Inverse of [`to_world`]: world space back to the OBJ file's coordinates.
pub fn to_file(p: Vec3, scale: f32, up: UpAxis) -> Vec3 {
    let p = match up {
        UpAxis::Y => p,
        UpAxis::Z => Vec3::new(p.x, -p.z, p.y),
    };
    p / scale
}

/// Loads an OBJ file into world space.
///
/// Contract: every stage works with geometric normals (the winding's
/// `(b-a)×(c-a)`), whether or not the file has normals: placement and
/// coverage need the side a face is seen from, not a smoothed shading normal.
/// Quads and polygons are fan-triangulated by tobj; negative
/// indices are resolved; faces are kept in file order; degenerate or
/// non-finite triangles are dropped and counted in one warning; a missing or
/// unreadable MTL is a warning and every face gets [`Material::fallback`].
/// Errors ([`Error::User`], naming the file): unreadable file, malformed OBJ,
/// no usable triangle.
pub fn load_obj(path: &Path, scale: f32, up: UpAxis) -> Result<Scene> {
    if !path.is_file() {
        return Err(Error::user_file(path, "scene file not found"));
    }
    let options = tobj::LoadOptions {
        triangulate: true,
        single_index: false,
        ignore_points: true,
        ignore_lines: true,
    };
    let (models, materials) = quietly(|| tobj::load_obj(path, &options))
        .ok_or_else(|| Error::user_file(path, "malformed OBJ or MTL (the parser gave up)"))?
        .map_err(|e| Error::user_file(path, format!("malformed OBJ: {e}")))?;
    let mut warnings = Vec::new();
    let materials: Vec<Material> = match materials {
        Ok(ms) => ms
            .into_iter()
            .map(|m| Material {
                name: m.name,
                diffuse: m.diffuse.unwrap_or([0.8; 3]),
                specular: m.specular.unwrap_or([0.0; 3]),
                shininess: m.shininess.unwrap_or(1.0),
                emission: m.emissive.unwrap_or([0.0; 3]),
            })
            .collect(),
        Err(e) => {
            warnings.push(format!(
                "{}: material library not loaded ({e}); using the default material",
                path.display()
            ));
            Vec::new()
        }
    };
    let triangles = models.iter().flat_map(|model| {
        let mesh = &model.mesh;
        let material = mesh.material_id.map_or(u32::MAX, |m| m as u32);
        let vertex = move |i: u32| {
            let i = i as usize * 3;
            to_world(
                Vec3::new(
                    mesh.positions[i],
                    mesh.positions[i + 1],
                    mesh.positions[i + 2],
                ),
                scale,
                up,
            )
        };
        mesh.indices
            .chunks_exact(3)
            .map(move |f| ([vertex(f[0]), vertex(f[1]), vertex(f[2])], material))
    });
    let mut scene = Scene::from_triangles(path.to_path_buf(), triangles, materials)?;
    warnings.append(&mut scene.warnings);
    scene.warnings = warnings;
    Ok(scene)
}

/// Runs `f`, turning a panic inside the OBJ/MTL parser into `None` without
/// printing it: tobj 4 unwraps on some malformed MTL lines (e.g. `Ke 1 2`),
/// and a user mistake must never surface as a panic.
fn quietly<T>(f: impl FnOnce() -> T + std::panic::UnwindSafe) -> Option<T> {
    let hook = std::panic::take_hook();
    std::panic::set_hook(Box::new(|_| {}));
    let result = std::panic::catch_unwind(f).ok();
    std::panic::set_hook(hook);
    result
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

    /// Runs placement `method` over `scene`'s bounds with seed 5.
    pub fn place_in(
        method: &Placement,
        scene: &Scene,
        bvh: &SceneBvh,
        sdf: &Sdf,
    ) -> crate::Result<ProbeSet> {
        crate::placement::place(
            method,
            &PlacementInput {
                scene,
                bvh,
                sdf,
                domain: &scene.bounds,
                seed: 5,
                progress: &Progress::hidden(),
            },
        )
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
    fn quads_negative_indices_and_missing_mtl() {
        let dir = tempfile::tempdir().unwrap();
        let p = write(
            dir.path(),
            "q.obj",
            "mtllib nope.mtl\nv 0 0 0\nv 1 0 0\nv 1 0 1\nv 0 0 1\nusemtl x\nf -4 -1 -2 -3\n",
        );
        let s = load_obj(&p, 2.0, UpAxis::Y).unwrap();
        assert_eq!(s.triangles.len(), 2);
        assert_eq!(s.bounds.max, Vec3::new(2.0, 0.0, 2.0));
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
        let p = Vec3::new(1.0, 2.0, 3.0);
        let w = to_world(p, 2.0, UpAxis::Z);
        assert_eq!(w, Vec3::new(2.0, 6.0, -4.0));
        assert_eq!(to_file(w, 2.0, UpAxis::Z), p);
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
