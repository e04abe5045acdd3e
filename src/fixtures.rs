//! Test scenes generated in code, as Wavefront OBJ + MTL text.
//!
//! probeplace needs a few small, well-understood scenes to test probe placement
//! and coverage on, and we ship only scenes that we build ourselves: no
//! third-party model files are copied into the repository. Each scene is written
//! out by the functions below, deterministically (the same bytes on every call),
//! so the text can be checked in, regenerated, or written to a temporary
//! directory by a test.
//!
//! * [`cornell_box`] rebuilds the Cornell box from the measurements published by
//!   the Cornell University Program of Computer Graphics ("Cornell Box data", in
//!   millimetres). It is the classic closed-ish room with two blocks.
//! * [`pillared_hall`] imitates the "Iconic Temple" scene of Wang et al. 2019: a
//!   large hall with two rows of pillars and a stair up to a raised platform,
//!   which gives many occluders and a level change.
//! * [`two_rooms`] is two rooms joined by one doorway in a thick wall, to test
//!   that probes find (and see through) the opening between the rooms.
//!
//! Conventions shared by every scene: Y is up; faces are quads with 1-based
//! absolute vertex indices; every face is counter-clockwise seen from the free
//! space, so its geometric normal `(b - a) × (c - a)` points into the free space.
//! Room shells (floors, ceilings, walls) are single-sided and face inward; solid
//! objects (blocks, pillars, steps, wall pieces, tables) are closed and face
//! outward. Numbers are printed with at most four decimals and trailing zeros
//! removed.

use std::fmt::Write as _;

/// A point in scene units.
type Vec3 = [f64; 3];

/// A planar four-sided face, counter-clockwise seen from the side it faces.
type Quad = [Vec3; 4];

/// One generated scene: the OBJ text (which references `<name>.mtl` through `mtllib`) and its MTL text.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ObjFixture {
    /// File stem of the scene, e.g. `cornell_box` for `cornell_box.obj` / `cornell_box.mtl`.
    pub name: &'static str,
    /// Contents of `<name>.obj`.
    pub obj: String,
    /// Contents of `<name>.mtl`.
    pub mtl: String,
}

/// Every fixture, in a fixed order: cornell_box, pillared_hall, two_rooms.
pub fn all() -> Vec<ObjFixture> {
    vec![cornell_box(), pillared_hall(), two_rooms()]
}

/// The Cornell box, in millimetres with Y up, from the published measurements of
/// the Cornell University Program of Computer Graphics.
///
/// The room spans about 556 × 548.8 × 559.2 mm; its front (z = 0) is open. It
/// holds a short block (165 mm) and a tall block (330 mm), and an area light just
/// below the ceiling (lowered from the published y = 548.8 to 548.7 so that it does
/// not coincide with the ceiling). Blocks have no bottom faces, as in the data.
pub fn cornell_box() -> ObjFixture {
    const NAME: &str = "cornell_box";
    const LIGHT_Y: f64 = 548.7;
    let header = [
        "Scene: the Cornell box: floor, ceiling, back, left and right walls, a ceiling light,",
        "a short and a tall block. Source: the Cornell box measurements published by the",
        "Cornell University Program of Computer Graphics (\"Cornell Box data\"), in millimetres.",
        "Units: millimetres, Y up. The front (z = 0) is open. The light is lowered from",
        "y = 548.8 to y = 548.7 so that it does not coincide with the ceiling.",
    ];

    let mut obj = ObjBuilder::new(NAME, &header);
    obj.object(
        "floor",
        "white",
        &[[
            [552.8, 0.0, 0.0],
            [0.0, 0.0, 0.0],
            [0.0, 0.0, 559.2],
            [549.6, 0.0, 559.2],
        ]],
    );
    obj.object(
        "ceiling",
        "white",
        &[[
            [556.0, 548.8, 0.0],
            [556.0, 548.8, 559.2],
            [0.0, 548.8, 559.2],
            [0.0, 548.8, 0.0],
        ]],
    );
    obj.object(
        "light",
        "light",
        &[[
            [343.0, LIGHT_Y, 227.0],
            [343.0, LIGHT_Y, 332.0],
            [213.0, LIGHT_Y, 332.0],
            [213.0, LIGHT_Y, 227.0],
        ]],
    );
    obj.object(
        "back_wall",
        "white",
        &[[
            [549.6, 0.0, 559.2],
            [0.0, 0.0, 559.2],
            [0.0, 548.8, 559.2],
            [556.0, 548.8, 559.2],
        ]],
    );
    obj.object(
        "right_wall",
        "green",
        &[[
            [0.0, 0.0, 559.2],
            [0.0, 0.0, 0.0],
            [0.0, 548.8, 0.0],
            [0.0, 548.8, 559.2],
        ]],
    );
    obj.object(
        "left_wall",
        "red",
        &[[
            [552.8, 0.0, 0.0],
            [549.6, 0.0, 559.2],
            [556.0, 548.8, 559.2],
            [556.0, 548.8, 0.0],
        ]],
    );
    obj.object(
        "short_block",
        "white",
        &prism(
            [[130.0, 65.0], [82.0, 225.0], [240.0, 272.0], [290.0, 114.0]],
            165.0,
        ),
    );
    obj.object(
        "tall_block",
        "white",
        &prism(
            [
                [423.0, 247.0],
                [265.0, 296.0],
                [314.0, 456.0],
                [472.0, 406.0],
            ],
            330.0,
        ),
    );

    let mut mtl = MtlBuilder::new(NAME, &header);
    mtl.material("white", [0.73, 0.73, 0.73], [0.0; 3]);
    mtl.material("red", [0.63, 0.065, 0.05], [0.0; 3]);
    mtl.material("green", [0.14, 0.45, 0.091], [0.0; 3]);
    mtl.material("light", [0.78, 0.78, 0.78], [17.0, 12.0, 4.0]);

    ObjFixture {
        name: NAME,
        obj: obj.finish(),
        mtl: mtl.finish(),
    }
}

/// A pillared hall in metres with Y up, imitating the "Iconic Temple" scene of
/// Wang et al. 2019.
///
/// The hall spans x 0..24, y 0..8, z 0..14. Two rows of five 0.8 × 0.8 m pillars
/// (floor to ceiling, at z = 3.5 and z = 10.5) line the nave. At the +x end a
/// stone platform (x 20..24, full width, 1.5 m high) is reached by a 6 m wide
/// flight of five 0.3 m risers: four step boxes (0.5 m run each, x 18..20) and
/// the platform edge. One 3 × 2 m emissive panel hangs 1 cm below the ceiling.
pub fn pillared_hall() -> ObjFixture {
    const NAME: &str = "pillared_hall";
    const HALL: Vec3 = [24.0, 8.0, 14.0];
    const PILLAR_HALF: f64 = 0.4;
    const PILLAR_XS: [f64; 5] = [3.0, 6.5, 10.0, 13.5, 17.0];
    const PILLAR_ZS: [f64; 2] = [3.5, 10.5];
    const PLATFORM_X: f64 = 20.0;
    const PLATFORM_H: f64 = 1.5;
    const RISE: f64 = 0.3;
    const RUN: f64 = 0.5;
    const STEPS: usize = 4;
    const STAIR_Z: [f64; 2] = [4.0, 10.0];
    let header = [
        "Scene: a pillared hall imitating the \"Iconic Temple\" scene of Wang et al. 2019:",
        "a 24 m x 14 m x 8 m hall (x 0..24, z 0..14), two rows of five 0.8 m square pillars,",
        "a 1.5 m stone platform at the +x end reached by a 6 m wide stair of five 0.3 m",
        "risers (four step boxes and the platform edge), one emissive ceiling panel and a",
        "polished (glossy) floor.",
        "Units: metres, Y up.",
    ];

    let mut obj = ObjBuilder::new(NAME, &header);
    let shell = room_shell([0.0; 3], HALL);
    obj.object("floor", "floor", &[shell.floor]);
    obj.object("ceiling", "walls", &[shell.ceiling]);
    obj.object("walls", "walls", &shell.walls);
    obj.object(
        "light",
        "light",
        &[axis_rect(
            1,
            HALL[1] - 0.01,
            [8.0, 0.0, 6.0],
            [11.0, 0.0, 8.0],
            false,
        )],
    );
    for (row, z) in PILLAR_ZS.iter().enumerate() {
        for (col, x) in PILLAR_XS.iter().enumerate() {
            let min = [x - PILLAR_HALF, 0.0, z - PILLAR_HALF];
            let max = [x + PILLAR_HALF, HALL[1], z + PILLAR_HALF];
            obj.object(
                &format!("pillar_{}", row * PILLAR_XS.len() + col),
                "stone",
                &solid_box(min, max, Caps::Open),
            );
        }
    }
    for step in 0..STEPS {
        let x0 = PLATFORM_X - (STEPS - step) as f64 * RUN;
        let min = [x0, 0.0, STAIR_Z[0]];
        let max = [x0 + RUN, (step + 1) as f64 * RISE, STAIR_Z[1]];
        obj.object(
            &format!("step_{step}"),
            "stone",
            &solid_box(min, max, Caps::Closed),
        );
    }
    obj.object(
        "platform",
        "stone",
        &solid_box(
            [PLATFORM_X, 0.0, 0.0],
            [HALL[0], PLATFORM_H, HALL[2]],
            Caps::Closed,
        ),
    );

    let mut mtl = MtlBuilder::new(NAME, &header);
    // Polished stone: the glossy reflections the comparisons measure.
    mtl.glossy_material("floor", [0.36, 0.32, 0.28], [0.3; 3], 60.0);
    mtl.material("walls", [0.75, 0.72, 0.66], [0.0; 3]);
    mtl.material("stone", [0.6, 0.58, 0.54], [0.0; 3]);
    mtl.material("light", [0.8, 0.8, 0.8], [10.0, 10.0, 10.0]);

    ObjFixture {
        name: NAME,
        obj: obj.finish(),
        mtl: mtl.finish(),
    }
}

/// Two rooms joined by a doorway, in metres with Y up.
///
/// Each room is 6 m (x) × 3 m (y) × 5 m (z): room A spans x 0..6, a 0.2 m thick
/// dividing wall spans x 6..6.2, and room B spans x 6.2..12.2 (z 0..5 for all).
/// The dividing wall is three closed boxes (z 0..2, z 3..5, and a lintel over
/// y 2.1..3) around a 1 m × 2.1 m door centred in it, so the door's jambs and the
/// lintel's underside are real faces. Room A has a 1 × 1 m ceiling light; room B
/// has a 1.2 × 0.75 × 0.8 m box table at its centre.
pub fn two_rooms() -> ObjFixture {
    const NAME: &str = "two_rooms";
    const ROOM: Vec3 = [6.0, 3.0, 5.0];
    const WALL: f64 = 0.2;
    const DOOR_W: f64 = 1.0;
    const DOOR_H: f64 = 2.1;
    const TABLE: Vec3 = [1.2, 0.75, 0.8];
    let header = [
        "Scene: two 6 m x 3 m x 5 m rooms side by side along x (x 0..6 and 6.2..12.2),",
        "separated by a 0.2 m wall with a 1 m x 2.1 m door centred in it; a ceiling light",
        "in the first room and a 1.2 m x 0.75 m x 0.8 m table in the second.",
        "Units: metres, Y up.",
    ];

    let total = [2.0 * ROOM[0] + WALL, ROOM[1], ROOM[2]];
    let wall_x = [ROOM[0], ROOM[0] + WALL];
    let door_z = [(ROOM[2] - DOOR_W) / 2.0, (ROOM[2] + DOOR_W) / 2.0];
    let room_b_centre = [wall_x[1] + ROOM[0] / 2.0, ROOM[2] / 2.0];

    let mut obj = ObjBuilder::new(NAME, &header);
    let shell = room_shell([0.0; 3], total);
    obj.object("floor", "floor", &[shell.floor]);
    obj.object("ceiling", "walls", &[shell.ceiling]);
    obj.object("walls", "walls", &shell.walls);
    obj.object(
        "light",
        "light",
        &[axis_rect(
            1,
            ROOM[1] - 0.01,
            [ROOM[0] / 2.0 - 0.5, 0.0, ROOM[2] / 2.0 - 0.5],
            [ROOM[0] / 2.0 + 0.5, 0.0, ROOM[2] / 2.0 + 0.5],
            false,
        )],
    );
    obj.object(
        "divider_left",
        "walls",
        &solid_box(
            [wall_x[0], 0.0, 0.0],
            [wall_x[1], ROOM[1], door_z[0]],
            Caps::Closed,
        ),
    );
    obj.object(
        "divider_right",
        "walls",
        &solid_box(
            [wall_x[0], 0.0, door_z[1]],
            [wall_x[1], ROOM[1], ROOM[2]],
            Caps::Closed,
        ),
    );
    obj.object(
        "divider_lintel",
        "walls",
        &solid_box(
            [wall_x[0], DOOR_H, door_z[0]],
            [wall_x[1], ROOM[1], door_z[1]],
            Caps::Closed,
        ),
    );
    obj.object(
        "table",
        "wood",
        &solid_box(
            [
                room_b_centre[0] - TABLE[0] / 2.0,
                0.0,
                room_b_centre[1] - TABLE[2] / 2.0,
            ],
            [
                room_b_centre[0] + TABLE[0] / 2.0,
                TABLE[1],
                room_b_centre[1] + TABLE[2] / 2.0,
            ],
            Caps::Closed,
        ),
    );

    let mut mtl = MtlBuilder::new(NAME, &header);
    mtl.material("floor", [0.5, 0.45, 0.4], [0.0; 3]);
    mtl.material("walls", [0.8, 0.8, 0.78], [0.0; 3]);
    mtl.material("wood", [0.45, 0.3, 0.18], [0.0; 3]);
    mtl.material("light", [0.8, 0.8, 0.8], [10.0, 10.0, 10.0]);

    ObjFixture {
        name: NAME,
        obj: obj.finish(),
        mtl: mtl.finish(),
    }
}

/// Formats a number with at most four decimals, trailing zeros and `-0` removed.
fn num(x: f64) -> String {
    let text = format!("{x:.4}");
    let text = if text.contains('.') {
        text.trim_end_matches('0').trim_end_matches('.')
    } else {
        text.as_str()
    };
    if text == "-0" {
        "0".to_owned()
    } else {
        text.to_owned()
    }
}

/// Writes the comment header shared by OBJ and MTL files.
fn write_header(out: &mut String, file: &str, lines: &[&str]) {
    let _ = writeln!(
        out,
        "# {file} - generated by probeplace's src/fixtures.rs; do not edit by hand."
    );
    for line in lines {
        let _ = writeln!(out, "# {line}");
    }
}

/// Accumulates OBJ text object by object, keeping track of vertex numbering.
struct ObjBuilder {
    text: String,
    vertex_count: usize,
}

impl ObjBuilder {
    fn new(name: &str, header: &[&str]) -> Self {
        let mut text = String::new();
        write_header(&mut text, &format!("{name}.obj"), header);
        text.push_str(
            "# Faces are counter-clockwise seen from the free space (normals point into it).\n",
        );
        let _ = writeln!(text, "mtllib {name}.mtl");
        Self {
            text,
            vertex_count: 0,
        }
    }

    /// Writes one object: its vertices (shared between its faces), material and faces.
    fn object(&mut self, name: &str, material: &str, quads: &[Quad]) {
        let mut vertices: Vec<String> = Vec::new();
        let mut faces: Vec<[usize; 4]> = Vec::new();
        for quad in quads {
            let mut face = [0; 4];
            for (slot, p) in face.iter_mut().zip(quad) {
                let line = format!("v {} {} {}", num(p[0]), num(p[1]), num(p[2]));
                *slot = match vertices.iter().position(|v| *v == line) {
                    Some(i) => i,
                    None => {
                        vertices.push(line);
                        vertices.len() - 1
                    }
                };
            }
            faces.push(face);
        }
        let _ = writeln!(self.text, "\no {name}");
        for line in &vertices {
            let _ = writeln!(self.text, "{line}");
        }
        let _ = writeln!(self.text, "usemtl {material}");
        let base = self.vertex_count + 1;
        for [a, b, c, d] in faces {
            let _ = writeln!(
                self.text,
                "f {} {} {} {}",
                base + a,
                base + b,
                base + c,
                base + d
            );
        }
        self.vertex_count += vertices.len();
    }

    fn finish(self) -> String {
        self.text
    }
}

/// Accumulates MTL text.
struct MtlBuilder {
    text: String,
}

impl MtlBuilder {
    fn new(name: &str, header: &[&str]) -> Self {
        let mut text = String::new();
        write_header(&mut text, &format!("{name}.mtl"), header);
        let _ = writeln!(text, "# Materials for {name}.obj.");
        Self { text }
    }

    /// Writes a diffuse material with emission `ke` (zero for non-emitters).
    fn material(&mut self, name: &str, kd: Vec3, ke: Vec3) {
        let rgb = |c: Vec3| format!("{} {} {}", num(c[0]), num(c[1]), num(c[2]));
        let _ = writeln!(self.text, "\nnewmtl {name}");
        let _ = writeln!(self.text, "Kd {}", rgb(kd));
        let _ = writeln!(self.text, "Ks 0 0 0");
        let _ = writeln!(self.text, "Ns 10");
        let _ = writeln!(self.text, "Ke {}", rgb(ke));
    }

    /// Writes a material with a GGX glossy lobe: specular colour `ks` and
    /// Phong exponent `ns` (`render::material::alpha_from_shininess`).
    fn glossy_material(&mut self, name: &str, kd: Vec3, ks: Vec3, ns: f64) {
        let rgb = |c: Vec3| format!("{} {} {}", num(c[0]), num(c[1]), num(c[2]));
        let _ = writeln!(self.text, "\nnewmtl {name}");
        let _ = writeln!(self.text, "Kd {}", rgb(kd));
        let _ = writeln!(self.text, "Ks {}", rgb(ks));
        let _ = writeln!(self.text, "Ns {}", num(ns));
        let _ = writeln!(self.text, "Ke 0 0 0");
    }

    fn finish(self) -> String {
        self.text
    }
}

/// An axis-aligned rectangle in the plane `p[axis] == at`, spanning `min..max` on
/// the other two axes, wound so its normal is `+axis` if `positive`, else `-axis`.
fn axis_rect(axis: usize, at: f64, min: Vec3, max: Vec3, positive: bool) -> Quad {
    // (u, v, axis) is a cyclic permutation of (x, y, z), so u × v = +axis.
    let u = (axis + 1) % 3;
    let v = (axis + 2) % 3;
    let corner = |cu: f64, cv: f64| {
        let mut p = [0.0; 3];
        p[axis] = at;
        p[u] = cu;
        p[v] = cv;
        p
    };
    let a = corner(min[u], min[v]);
    let b = corner(max[u], min[v]);
    let c = corner(max[u], max[v]);
    let d = corner(min[u], max[v]);
    if positive {
        [a, b, c, d]
    } else {
        [a, d, c, b]
    }
}

/// Whether a solid box gets its bottom and top faces.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Caps {
    /// All six faces.
    Closed,
    /// Only the four vertical faces (for pillars between floor and ceiling).
    Open,
}

/// The faces of a solid axis-aligned box, facing outward.
fn solid_box(min: Vec3, max: Vec3, caps: Caps) -> Vec<Quad> {
    let mut quads = Vec::with_capacity(6);
    for axis in [0, 2, 1] {
        if axis == 1 && caps == Caps::Open {
            continue;
        }
        quads.push(axis_rect(axis, min[axis], min, max, false));
        quads.push(axis_rect(axis, max[axis], min, max, true));
    }
    quads
}

/// The single-sided, inward-facing shell of an axis-aligned room.
struct RoomShell {
    floor: Quad,
    ceiling: Quad,
    walls: [Quad; 4],
}

fn room_shell(min: Vec3, max: Vec3) -> RoomShell {
    RoomShell {
        floor: axis_rect(1, min[1], min, max, true),
        ceiling: axis_rect(1, max[1], min, max, false),
        walls: [
            axis_rect(0, min[0], min, max, true),
            axis_rect(0, max[0], min, max, false),
            axis_rect(2, min[2], min, max, true),
            axis_rect(2, max[2], min, max, false),
        ],
    }
}

/// A vertical prism standing on y = 0 with the given top outline (x, z), which
/// must be counter-clockwise seen from above: the top face and the four sides,
/// all facing outward, and no bottom face.
fn prism(top: [[f64; 2]; 4], height: f64) -> Vec<Quad> {
    let at = |i: usize, y: f64| [top[i % 4][0], y, top[i % 4][1]];
    let mut quads = vec![[at(0, height), at(1, height), at(2, height), at(3, height)]];
    for i in 0..4 {
        quads.push([at(i, 0.0), at(i + 1, 0.0), at(i + 1, height), at(i, height)]);
    }
    quads
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::BTreeSet;

    /// One polygon of a parsed OBJ file.
    struct Face {
        object: String,
        /// 1-based indices as written.
        indices: Vec<i64>,
        /// How many vertices had been defined when the face was read.
        defined: usize,
    }

    /// What the tests need from an OBJ file.
    struct Mesh {
        vertices: Vec<Vec3>,
        faces: Vec<Face>,
        mtllibs: Vec<String>,
        materials: BTreeSet<String>,
    }

    /// A fan triangle, tagged with the object it belongs to.
    struct Tri {
        object: String,
        p: [Vec3; 3],
    }

    fn parse_obj(text: &str) -> Mesh {
        let mut mesh = Mesh {
            vertices: Vec::new(),
            faces: Vec::new(),
            mtllibs: Vec::new(),
            materials: BTreeSet::new(),
        };
        let mut object = String::new();
        for line in text.lines() {
            let mut words = line.split_whitespace();
            match words.next() {
                Some("v") => {
                    let c: Vec<f64> = words.map(|w| w.parse().unwrap()).collect();
                    assert_eq!(c.len(), 3, "bad vertex line {line:?}");
                    mesh.vertices.push([c[0], c[1], c[2]]);
                }
                Some("f") => {
                    let indices: Vec<i64> = words
                        .map(|w| w.split('/').next().unwrap().parse().unwrap())
                        .collect();
                    assert!(indices.len() >= 3, "short face {line:?}");
                    mesh.faces.push(Face {
                        object: object.clone(),
                        indices,
                        defined: mesh.vertices.len(),
                    });
                }
                Some("o") | Some("g") => object = words.collect::<Vec<_>>().join(" "),
                Some("usemtl") => {
                    mesh.materials.insert(words.next().unwrap().to_owned());
                }
                Some("mtllib") => mesh.mtllibs.push(words.next().unwrap().to_owned()),
                Some(w) if w.starts_with('#') => {}
                None => {}
                Some(other) => panic!("unexpected OBJ statement {other:?}"),
            }
        }
        mesh
    }

    fn mtl_materials(text: &str) -> BTreeSet<String> {
        text.lines()
            .filter_map(|l| l.strip_prefix("newmtl "))
            .map(str::to_owned)
            .collect()
    }

    fn triangles(mesh: &Mesh) -> Vec<Tri> {
        let mut tris = Vec::new();
        for face in &mesh.faces {
            let p = |i: usize| mesh.vertices[face.indices[i] as usize - 1];
            for i in 1..face.indices.len() - 1 {
                tris.push(Tri {
                    object: face.object.clone(),
                    p: [p(0), p(i), p(i + 1)],
                });
            }
        }
        tris
    }

    fn sub(a: Vec3, b: Vec3) -> Vec3 {
        [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
    }

    fn cross(a: Vec3, b: Vec3) -> Vec3 {
        [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ]
    }

    fn dot(a: Vec3, b: Vec3) -> f64 {
        a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
    }

    fn unit(a: Vec3) -> Vec3 {
        let len = dot(a, a).sqrt();
        [a[0] / len, a[1] / len, a[2] / len]
    }

    /// Geometric normal (b - a) × (c - a), normalised.
    fn normal(t: &Tri) -> Vec3 {
        unit(cross(sub(t.p[1], t.p[0]), sub(t.p[2], t.p[0])))
    }

    fn centroid(points: &[Vec3]) -> Vec3 {
        let n = points.len() as f64;
        let s = points
            .iter()
            .fold([0.0; 3], |s, p| [s[0] + p[0], s[1] + p[1], s[2] + p[2]]);
        [s[0] / n, s[1] / n, s[2] / n]
    }

    /// The distinct vertices used by one object's faces.
    fn object_vertices(mesh: &Mesh, object: &str) -> Vec<Vec3> {
        let used: BTreeSet<i64> = mesh
            .faces
            .iter()
            .filter(|f| f.object == object)
            .flat_map(|f| f.indices.iter().copied())
            .collect();
        used.iter()
            .map(|&i| mesh.vertices[i as usize - 1])
            .collect()
    }

    fn objects(mesh: &Mesh) -> BTreeSet<String> {
        mesh.faces.iter().map(|f| f.object.clone()).collect()
    }

    /// Names of the single-sided room-shell objects (inward facing) of a fixture;
    /// every other object is a closed solid.
    fn shell_objects(name: &str) -> &'static [&'static str] {
        match name {
            "cornell_box" => &[
                "floor",
                "ceiling",
                "light",
                "back_wall",
                "right_wall",
                "left_wall",
            ],
            "pillared_hall" | "two_rooms" => &["floor", "ceiling", "walls", "light"],
            other => panic!("unknown fixture {other}"),
        }
    }

    /// Does the segment from `a` to `b` cross the triangle (Möller–Trumbore)?
    fn segment_hits(a: Vec3, b: Vec3, t: &Tri) -> bool {
        let dir = sub(b, a);
        let e1 = sub(t.p[1], t.p[0]);
        let e2 = sub(t.p[2], t.p[0]);
        let pv = cross(dir, e2);
        let det = dot(e1, pv);
        if det.abs() < 1e-12 {
            return false;
        }
        let tv = sub(a, t.p[0]);
        let u = dot(tv, pv) / det;
        let qv = cross(tv, e1);
        let v = dot(dir, qv) / det;
        let s = dot(e2, qv) / det;
        u >= 0.0 && v >= 0.0 && u + v <= 1.0 && (0.0..=1.0).contains(&s)
    }

    #[test]
    fn all_lists_the_fixtures_in_order() {
        let names: Vec<_> = all().iter().map(|f| f.name).collect();
        assert_eq!(names, ["cornell_box", "pillared_hall", "two_rooms"]);
    }

    #[test]
    fn output_is_deterministic() {
        assert_eq!(cornell_box(), cornell_box());
        assert_eq!(pillared_hall(), pillared_hall());
        assert_eq!(two_rooms(), two_rooms());
        assert_eq!(all(), all());
    }

    #[test]
    fn text_is_tidy_and_headed() {
        for fx in all() {
            for (file, text) in [("obj", &fx.obj), ("mtl", &fx.mtl)] {
                assert!(
                    text.ends_with('\n'),
                    "{}.{file} lacks a final newline",
                    fx.name
                );
                for line in text.lines() {
                    assert_eq!(line, line.trim_end(), "{}.{file}: trailing space", fx.name);
                    assert!(!line.contains('\t'), "{}.{file}: tab", fx.name);
                }
                let first = text.lines().next().unwrap();
                assert!(first.starts_with(&format!("# {}.{file} ", fx.name)));
                assert!(first.contains("generated by probeplace's src/fixtures.rs"));
                assert!(text.lines().nth(1).unwrap().starts_with("# Scene: "));
            }
            let mesh = parse_obj(&fx.obj);
            assert_eq!(mesh.mtllibs, [format!("{}.mtl", fx.name)]);
        }
        let cornell = cornell_box();
        for text in [&cornell.obj, &cornell.mtl] {
            assert!(text.contains("Cornell University Program of Computer Graphics"));
            assert!(text.contains("millimetres"));
        }
    }

    #[test]
    fn numbers_have_a_fixed_format() {
        assert_eq!(num(552.8), "552.8");
        assert_eq!(num(0.065), "0.065");
        assert_eq!(num(17.0), "17");
        assert_eq!(num(-0.0), "0");
        assert_eq!(num(-0.00001), "0");
        assert_eq!(num(1.0 / 3.0), "0.3333");
    }

    #[test]
    fn face_indices_are_in_range_and_faces_not_degenerate() {
        for fx in all() {
            let mesh = parse_obj(&fx.obj);
            assert!(!mesh.faces.is_empty());
            for face in &mesh.faces {
                for &i in &face.indices {
                    assert!(
                        i >= 1 && i as usize <= face.defined,
                        "{}: index {i} out of range in {}",
                        fx.name,
                        face.object
                    );
                }
            }
            for tri in triangles(&mesh) {
                let e1 = sub(tri.p[1], tri.p[0]);
                let e2 = sub(tri.p[2], tri.p[0]);
                let area2 = dot(cross(e1, e2), cross(e1, e2)).sqrt();
                let scale = dot(e1, e1).max(dot(e2, e2));
                assert!(
                    area2 > 1e-6 * scale,
                    "{}: degenerate triangle in {}",
                    fx.name,
                    tri.object
                );
            }
        }
    }

    #[test]
    fn fan_triangles_of_a_face_agree() {
        for fx in all() {
            let mesh = parse_obj(&fx.obj);
            for face in &mesh.faces {
                let p = |i: usize| mesh.vertices[face.indices[i] as usize - 1];
                let n = |i: usize| unit(cross(sub(p(i), p(0)), sub(p(i + 1), p(0))));
                for i in 2..face.indices.len() - 1 {
                    assert!(dot(n(1), n(i)) > 0.99, "{}: {} bent", fx.name, face.object);
                }
            }
        }
    }

    #[test]
    fn triangle_counts() {
        // Cornell box: floor, ceiling, light, back, right and left wall are 6
        // quads; each block is a top and four sides (no bottom), 2 × 5 = 10
        // quads. 16 quads fan into 32 triangles.
        assert_eq!(triangles(&parse_obj(&cornell_box().obj)).len(), 32);
        // Hall: 6 shell quads + 1 light; 10 pillars × 4 sides = 40; 4 steps and
        // the platform × 6 faces = 30. 77 quads, 154 triangles.
        assert_eq!(triangles(&parse_obj(&pillared_hall().obj)).len(), 154);
        // Two rooms: 6 shell quads + 1 light; 3 divider boxes and the table ×
        // 6 faces = 24. 31 quads, 62 triangles.
        assert_eq!(triangles(&parse_obj(&two_rooms().obj)).len(), 62);
    }

    #[test]
    fn cornell_key_surfaces_face_the_right_way() {
        let mesh = parse_obj(&cornell_box().obj);
        let expected = [
            ("floor", [0.0, 1.0, 0.0]),
            ("ceiling", [0.0, -1.0, 0.0]),
            ("light", [0.0, -1.0, 0.0]),
            ("back_wall", [0.0, 0.0, -1.0]),
            ("right_wall", [1.0, 0.0, 0.0]),
            ("left_wall", [-1.0, 0.0, 0.0]),
        ];
        for (object, dir) in expected {
            let tris: Vec<_> = triangles(&mesh)
                .into_iter()
                .filter(|t| t.object == object)
                .collect();
            assert_eq!(tris.len(), 2, "{object}");
            for t in &tris {
                assert!(dot(normal(t), dir) > 0.99, "{object} faces {:?}", normal(t));
            }
        }
        let light_y = object_vertices(&mesh, "light")[0][1];
        assert!(light_y < 548.8 && light_y > 548.0);
    }

    #[test]
    fn shells_face_the_room_centre_and_solids_face_outward() {
        for fx in all() {
            let mesh = parse_obj(&fx.obj);
            let shells = shell_objects(fx.name);
            let names = objects(&mesh);
            for s in shells {
                assert!(names.contains(*s), "{}: no {s}", fx.name);
            }
            let shell_points: Vec<Vec3> = shells
                .iter()
                .flat_map(|s| object_vertices(&mesh, s))
                .collect();
            let room_centre = centroid(&shell_points);
            let tris = triangles(&mesh);
            for name in &names {
                let is_shell = shells.contains(&name.as_str());
                let solid_centre = centroid(&object_vertices(&mesh, name));
                for t in tris.iter().filter(|t| &t.object == name) {
                    let n = normal(t);
                    let c = centroid(&t.p);
                    if is_shell {
                        assert!(
                            dot(n, sub(room_centre, c)) > 0.0,
                            "{}: {name} faces away from the room",
                            fx.name
                        );
                    } else {
                        assert!(
                            dot(n, sub(c, solid_centre)) > 0.0,
                            "{}: {name} faces into itself",
                            fx.name
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn solids_are_the_expected_objects() {
        let solids = |fx: ObjFixture| -> Vec<String> {
            let shells = shell_objects(fx.name);
            objects(&parse_obj(&fx.obj))
                .into_iter()
                .filter(|o| !shells.contains(&o.as_str()))
                .collect()
        };
        assert_eq!(solids(cornell_box()), ["short_block", "tall_block"]);
        let hall = solids(pillared_hall());
        assert_eq!(hall.iter().filter(|o| o.starts_with("pillar_")).count(), 10);
        assert_eq!(hall.iter().filter(|o| o.starts_with("step_")).count(), 4);
        assert!(hall.contains(&"platform".to_owned()));
        assert_eq!(hall.len(), 15);
        assert_eq!(
            solids(two_rooms()),
            ["divider_left", "divider_lintel", "divider_right", "table"]
        );
    }

    #[test]
    fn every_vertex_lies_within_the_shell() {
        let bounds = [
            ([0.0, 0.0, 0.0], [556.0, 548.8, 559.2]),
            ([0.0, 0.0, 0.0], [24.0, 8.0, 14.0]),
            ([0.0, 0.0, 0.0], [12.2, 3.0, 5.0]),
        ];
        for (fx, (min, max)) in all().into_iter().zip(bounds) {
            let mesh = parse_obj(&fx.obj);
            for v in &mesh.vertices {
                for k in 0..3 {
                    assert!(
                        v[k] >= min[k] - 1e-9 && v[k] <= max[k] + 1e-9,
                        "{}: {v:?} outside",
                        fx.name
                    );
                }
            }
        }
    }

    #[test]
    fn mtl_defines_every_used_material() {
        for fx in all() {
            let used = parse_obj(&fx.obj).materials;
            let defined = mtl_materials(&fx.mtl);
            assert!(!used.is_empty());
            assert!(
                used.is_subset(&defined),
                "{}: {used:?} vs {defined:?}",
                fx.name
            );
            let emissive: Vec<_> = fx
                .mtl
                .lines()
                .filter(|l| l.starts_with("Ke ") && *l != "Ke 0 0 0")
                .collect();
            assert_eq!(emissive.len(), 1, "{}: one emitter", fx.name);
        }
        assert!(cornell_box().mtl.contains("Kd 0.63 0.065 0.05"));
        assert!(cornell_box().mtl.contains("Ke 17 12 4"));
        assert!(pillared_hall().mtl.contains("Ke 10 10 10"));
    }

    #[test]
    fn the_doorway_is_open_and_has_real_jambs_and_lintel() {
        let mesh = parse_obj(&two_rooms().obj);
        let tris = triangles(&mesh);
        let blocked = |a: Vec3, b: Vec3| tris.iter().any(|t| segment_hits(a, b, t));
        // Room A's centre sees room B's centre through the door, at 1 m height.
        assert!(!blocked([3.0, 1.0, 2.5], [9.1, 1.0, 2.5]));
        // Beside the door, and above it, the wall blocks the view.
        assert!(blocked([3.0, 1.0, 1.0], [9.1, 1.0, 1.0]));
        assert!(blocked([3.0, 1.0, 4.0], [9.1, 1.0, 4.0]));
        assert!(blocked([3.0, 2.5, 2.5], [9.1, 2.5, 2.5]));

        let has_face = |object: &str, dir: Vec3, axis: usize, at: f64| {
            tris.iter().any(|t| {
                t.object == object
                    && dot(normal(t), dir) > 0.99
                    && t.p.iter().all(|p| (p[axis] - at).abs() < 1e-9)
            })
        };
        assert!(has_face("divider_left", [0.0, 0.0, 1.0], 2, 2.0));
        assert!(has_face("divider_right", [0.0, 0.0, -1.0], 2, 3.0));
        assert!(has_face("divider_lintel", [0.0, -1.0, 0.0], 1, 2.1));
    }

    #[test]
    fn only_the_first_room_is_lit() {
        let mesh = parse_obj(&two_rooms().obj);
        for v in object_vertices(&mesh, "light") {
            assert!(v[0] < 6.0 && v[1] > 2.9 && v[1] < 3.0);
        }
    }
}
