//! Tiles: a world cut into boxes that are placed one job each and joined
//! again (`probeplace split` and `probeplace merge`).
//!
//! Open worlds outgrow one machine; engines already stream probe volumes
//! per region, and Wald et al. 2005 spread their radiance samples of 350M
//! triangles over a cluster of PCs. A tile is one box of an `N × M × K`
//! grid over the world's domain:
//!
//! * its **core** is its cell of the grid: every point of the world lies in
//!   exactly one core (half-open cells, the world's upper faces closed), and
//!   the core's owner is the tile whose results count there;
//! * its **box** is the core grown by the **margin** on every side (cut to
//!   the world's domain): the tile's placement sees the geometry and places
//!   probes there, so that what stands near a cut is seen from both sides,
//!   as one placement over the whole world would. The margin is the reach
//!   a probe's influence needs beyond the core (issue 22: at least the
//!   largest clearance plus the coverage reach), see [`default_margin`].
//!
//! The split itself ([`split_obj`]) streams the OBJ: it reads one line at
//! a time, keeps the vertex positions (24 bytes each) and never the
//! triangles, and writes every triangle whose bounding box touches a
//! tile's box into that tile's OBJ, in world coordinates (scale and up
//! axis applied), so each tile job loads only its own part of the world.

use crate::config::UpAxis;
use crate::error::{Error, Result};
use crate::input::{self, LineError};
use crate::scene::file_to_world;
use glam::{DVec3, UVec3};
use std::collections::HashMap;
use std::io::{BufReader, BufWriter, Write};
use std::path::{Path, PathBuf};

/// Most tiles one split may make (one Slurm array task each).
pub const MAX_TILES: u32 = 4096;

/// An axis-aligned box in world coordinates, f64 like the config's points.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct WorldBox {
    /// Lower corner.
    pub min: [f64; 3],
    /// Upper corner.
    pub max: [f64; 3],
}

impl WorldBox {
    /// Whether `p` lies in the box (closed).
    pub fn contains(&self, p: DVec3) -> bool {
        (0..3).all(|k| p[k] >= self.min[k] && p[k] <= self.max[k])
    }

    /// Whether the boxes `[lo, hi]` and this one share a point.
    fn touches(&self, lo: DVec3, hi: DVec3) -> bool {
        (0..3).all(|k| lo[k] <= self.max[k] && hi[k] >= self.min[k])
    }

    /// Edge lengths.
    pub fn size(&self) -> DVec3 {
        DVec3::from_array(self.max) - DVec3::from_array(self.min)
    }
}

/// One tile of a [`TileGrid`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tile {
    /// Index in the array job: `x + N (y + M z)`.
    pub index: u32,
    /// Grid cell (x, y, z).
    pub cell: UVec3,
    /// The cell: the part of the world this tile owns.
    pub core: WorldBox,
    /// The core grown by the margin, cut to the world: what the tile places over.
    pub outer: WorldBox,
}

/// An `N × M × K` grid of tiles over a world box, with a margin.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TileGrid {
    /// The world's domain.
    pub world: WorldBox,
    /// Tiles along x, y, z.
    pub counts: UVec3,
    /// How far each tile's box reaches beyond its core.
    pub margin: f64,
}

/// Parses `NxMxK` (each at least 1, at most [`MAX_TILES`] in all).
pub fn parse_counts(text: &str) -> std::result::Result<UVec3, String> {
    let parts: Vec<&str> = text.split(['x', 'X']).collect();
    let bad = || {
        format!("--tiles: {text:?} is not NxMxK (three whole numbers of at least 1, such as 2x1x2)")
    };
    if parts.len() != 3 {
        return Err(bad());
    }
    let mut n = [0u32; 3];
    for (slot, part) in n.iter_mut().zip(&parts) {
        *slot = part.trim().parse().map_err(|_| bad())?;
        if *slot == 0 {
            return Err(bad());
        }
    }
    let total = n.iter().map(|&v| v as u64).product::<u64>();
    if total > MAX_TILES as u64 {
        return Err(format!(
            "--tiles: {text} makes {total} tiles, over the limit of {MAX_TILES}"
        ));
    }
    Ok(UVec3::from_array(n))
}

/// The margin when none is given: half the longest tile edge, and at
/// least 8 voxels.
///
/// The margin has to hold what a probe near the cut sees of the core and
/// what sees it: the clearance it keeps from surfaces, and the rooms it
/// shares with the core; and the tile's SDF is unreliable near its cut
/// faces, where rays escape through the missing world. Neither reach is
/// known before the tiles are placed. Half the tile edge lets a probe at
/// the middle of a core see across a cut as far as the core reaches the
/// other way; on Dabrovic Sponza in 2×1×2 tiles a quarter of the edge
/// merged to 81 probes and twice that to 64 (one machine: 51; docs/tiles.md).
/// The voxel floor keeps a thin tile's skeleton whole.
pub fn default_margin(world: &WorldBox, counts: UVec3, voxel_size: f64) -> f64 {
    let edge = world.size() / counts.as_dvec3();
    (0.5 * edge.max_element()).max(8.0 * voxel_size)
}

impl TileGrid {
    /// Number of tiles.
    pub fn len(&self) -> u32 {
        self.counts.x * self.counts.y * self.counts.z
    }

    /// Whether the grid has no tile (never, for parsed counts).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Tile `index` (`x + N (y + M z)`).
    pub fn tile(&self, index: u32) -> Tile {
        let c = self.counts;
        let cell = UVec3::new(index % c.x, (index / c.x) % c.y, index / (c.x * c.y));
        let lo = DVec3::from_array(self.world.min);
        let size = self.world.size() / c.as_dvec3();
        let min = lo + size * cell.as_dvec3();
        // The last cell ends exactly at the world's upper corner.
        let max = DVec3::from_array(std::array::from_fn(|k| {
            if cell[k] + 1 == c[k] {
                self.world.max[k]
            } else {
                lo[k] + size[k] * (cell[k] + 1) as f64
            }
        }));
        let core = WorldBox {
            min: min.to_array(),
            max: max.to_array(),
        };
        let outer = WorldBox {
            min: (min - self.margin).max(lo).to_array(),
            max: (max + self.margin)
                .min(DVec3::from_array(self.world.max))
                .to_array(),
        };
        Tile {
            index,
            cell,
            core,
            outer,
        }
    }

    /// Every tile, by index.
    pub fn tiles(&self) -> Vec<Tile> {
        (0..self.len()).map(|i| self.tile(i)).collect()
    }

    /// The tile whose core owns `p`: cells are half-open, except that the
    /// world's upper faces belong to the last cells; points beyond the
    /// world go to the nearest cell.
    pub fn owner(&self, p: DVec3) -> u32 {
        let lo = DVec3::from_array(self.world.min);
        let size = self.world.size() / self.counts.as_dvec3();
        let cell = UVec3::from_array(std::array::from_fn(|k| {
            let f = ((p[k] - lo[k]) / size[k]).floor();
            if f.is_finite() {
                f.clamp(0.0, (self.counts[k] - 1) as f64) as u32
            } else {
                0
            }
        }));
        cell.x + self.counts.x * (cell.y + self.counts.y * cell.z)
    }
}

/// What [`split_obj`] wrote for each tile.
#[derive(Debug, Clone, Default)]
pub struct TileGeometry {
    /// Triangles written.
    pub triangles: u64,
    /// Vertices written.
    pub vertices: u64,
}

/// The world box of the OBJ at `path` under `scale` and `up`, by streaming
/// its `v` lines.
///
/// Contract: the bounds of every vertex; a file without vertices, or a line
/// that cannot be read, is a user error naming the file (and line).
pub fn stream_bounds(path: &Path, scale: f64, up: UpAxis) -> Result<WorldBox> {
    let mut bounds = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
    for_each_line(path, &mut |n, words| {
        if words.first() == Some(&"v") {
            let p = file_to_world(vertex(path, n, words)?, scale, up);
            bounds = (bounds.0.min(p), bounds.1.max(p));
        }
        Ok(())
    })?;
    if !bounds.0.is_finite() {
        return Err(Error::user_file(path, "scene file has no vertices"));
    }
    Ok(WorldBox {
        min: bounds.0.to_array(),
        max: bounds.1.to_array(),
    })
}

/// Writes the part of the OBJ at `path` that touches each tile's box to
/// `outputs[i]` (one per tile of `grid`, by index), in world coordinates,
/// with `mtllib` lines naming `libraries_as` followed by the library's name
/// as the source gives it. Returns what each tile got, and the material
/// libraries the source names (relative to its directory).
///
/// Contract: streams the source once; holds its vertex positions and
/// texture coordinates and, per tile, the maps from source to tile vertex
/// and `vt`; every triangle whose bounding box touches a tile's closed box
/// is written to that tile, with the material and the texture
/// coordinates the source gives it (a corner whose texture index names no
/// `vt` read so far is written without one, as the scene reader leaves
/// it untextured), and nothing else is.
pub fn split_obj(
    path: &Path,
    scale: f64,
    up: UpAxis,
    grid: &TileGrid,
    outputs: &[PathBuf],
    libraries_as: &str,
) -> Result<(Vec<TileGeometry>, Vec<String>)> {
    let tiles = grid.tiles();
    let mut writers = Vec::with_capacity(outputs.len());
    for out in outputs {
        let file = std::fs::File::create(out).map_err(|e| Error::io(out, e))?;
        writers.push(BufWriter::with_capacity(1 << 16, file));
    }
    let mut positions: Vec<DVec3> = Vec::new();
    let mut texcoords: Vec<String> = Vec::new();
    let mut local: Vec<HashMap<u32, u32>> = vec![HashMap::new(); tiles.len()];
    let mut local_vt: Vec<HashMap<u32, u32>> = vec![HashMap::new(); tiles.len()];
    let mut face_vt: Vec<Option<u32>> = Vec::new();
    let mut geometry = vec![TileGeometry::default(); tiles.len()];
    let mut material: Option<String> = None;
    let mut written_material: Vec<Option<String>> = vec![None; tiles.len()];
    let mut libraries: Vec<String> = Vec::new();
    let mut face: Vec<u32> = Vec::new();
    let mut line_out = String::new();
    let mut io_error: Option<(usize, std::io::Error)> = None;
    for_each_line(path, &mut |n, words| {
        match words.first().copied() {
            Some("v") => positions.push(file_to_world(vertex(path, n, words)?, scale, up)),
            // Kept as written: texture coordinates are not moved by the
            // scale or the up axis.
            Some("vt") => texcoords.push(words[1..].join(" ")),
            Some("usemtl") => material = words.get(1).map(|s| s.to_string()),
            Some("mtllib") => {
                for name in &words[1..] {
                    if !libraries.iter().any(|l| l == name) {
                        libraries.push(name.to_string());
                        for (t, w) in writers.iter_mut().enumerate() {
                            if let Err(e) = writeln!(w, "mtllib {libraries_as}{name}") {
                                io_error.get_or_insert((t, e));
                            }
                        }
                    }
                }
            }
            Some("f") => {
                face.clear();
                face_vt.clear();
                for w in &words[1..] {
                    face.push(face_index(path, n, w, positions.len())?);
                    face_vt.push(texcoord_index(w, texcoords.len()));
                }
                if face.len() < 3 {
                    return Err(Error::User(format!(
                        "{}:{n}: a face needs at least 3 vertices",
                        path.display()
                    )));
                }
                for k in 1..face.len() - 1 {
                    let tri = [face[0], face[k], face[k + 1]];
                    let tri_vt = [face_vt[0], face_vt[k], face_vt[k + 1]];
                    let p = tri.map(|i| positions[i as usize]);
                    let (lo, hi) = (p[0].min(p[1]).min(p[2]), p[0].max(p[1]).max(p[2]));
                    for (t, tile) in tiles.iter().enumerate() {
                        if !tile.outer.touches(lo, hi) {
                            continue;
                        }
                        line_out.clear();
                        if written_material[t] != material {
                            if let Some(m) = &material {
                                line_out.push_str(&format!("usemtl {m}\n"));
                            }
                            written_material[t] = material.clone();
                        }
                        let mut ids = [0u32; 3];
                        for (slot, &i) in ids.iter_mut().zip(&tri) {
                            let next = local[t].len() as u32 + 1;
                            *slot = *local[t].entry(i).or_insert_with(|| {
                                let q = positions[i as usize];
                                line_out.push_str(&format!("v {} {} {}\n", q.x, q.y, q.z));
                                next
                            });
                        }
                        let mut corners = [String::new(), String::new(), String::new()];
                        for (c, (id, vt)) in corners.iter_mut().zip(ids.iter().zip(tri_vt)) {
                            *c = id.to_string();
                            if let Some(vt) = vt {
                                let next = local_vt[t].len() as u32 + 1;
                                let v = *local_vt[t].entry(vt).or_insert_with(|| {
                                    line_out.push_str(&format!("vt {}\n", texcoords[vt as usize]));
                                    next
                                });
                                c.push_str(&format!("/{v}"));
                            }
                        }
                        line_out
                            .push_str(&format!("f {} {} {}\n", corners[0], corners[1], corners[2]));
                        geometry[t].triangles += 1;
                        if let Err(e) = writers[t].write_all(line_out.as_bytes()) {
                            io_error.get_or_insert((t, e));
                        }
                    }
                }
            }
            _ => {}
        }
        Ok(())
    })?;
    if let Some((t, e)) = io_error {
        return Err(Error::io(&outputs[t], e));
    }
    for (t, (w, out)) in writers.iter_mut().zip(outputs).enumerate() {
        w.flush().map_err(|e| Error::io(out, e))?;
        geometry[t].vertices = local[t].len() as u64;
    }
    Ok((geometry, libraries))
}

/// Calls `f` with the line number and the words of every line of `path`.
fn for_each_line(path: &Path, f: &mut dyn FnMut(usize, &[&str]) -> Result<()>) -> Result<()> {
    let (file, _) = input::open(path, "scene file", u64::MAX)?;
    let mut reader = BufReader::with_capacity(1 << 20, file);
    let mut line = Vec::new();
    let mut n = 0usize;
    loop {
        n += 1;
        let more = input::next_line(&mut reader, &mut line)
            .map_err(|e| Error::user_file(path, format!("cannot read scene file: {e}")))?;
        match more {
            Ok(false) => return Ok(()),
            Ok(true) => {}
            Err(LineError::TooLong) => {
                return Err(Error::User(format!(
                    "{}:{n}: line too long",
                    path.display()
                )))
            }
            Err(LineError::Binary) => return Err(input::not_text(path, n, "an OBJ")),
        }
        let text = String::from_utf8_lossy(&line);
        let words: Vec<&str> = text.split_whitespace().collect();
        f(n, &words)?;
    }
}

/// The position of a `v` line.
fn vertex(path: &Path, n: usize, words: &[&str]) -> Result<DVec3> {
    let mut p = [0.0f64; 3];
    for (k, slot) in p.iter_mut().enumerate() {
        *slot = words
            .get(k + 1)
            .and_then(|w| w.parse::<f64>().ok())
            .filter(|v| v.is_finite())
            .ok_or_else(|| {
                Error::User(format!(
                    "{}:{n}: a vertex needs three finite numbers",
                    path.display()
                ))
            })?;
    }
    Ok(DVec3::from_array(p))
}

/// The 0-based position index of a face corner (`v`, `v/t`, `v//n`,
/// `v/t/n`; negative: relative to the `read` vertices so far).
fn face_index(path: &Path, n: usize, word: &str, read: usize) -> Result<u32> {
    let bad = |what: &str| {
        Error::User(format!(
            "{}:{n}: face index {word:?} {what}",
            path.display()
        ))
    };
    let i: i64 = word
        .split('/')
        .next()
        .unwrap_or("")
        .parse()
        .map_err(|_| bad("is not a whole number"))?;
    let resolved = if i < 0 { read as i64 + i } else { i - 1 };
    if i == 0 || resolved < 0 || resolved >= read as i64 {
        return Err(bad("names no vertex read so far"));
    }
    Ok(resolved as u32)
}

/// The texture index of face corner `word` (`v/t`, `v/t/n`), resolved as
/// the scene reader resolves it (negative: relative to the `read` `vt`
/// so far), or `None` where it has none or it names no `vt` read so far.
fn texcoord_index(word: &str, read: usize) -> Option<u32> {
    let i: i64 = word.split('/').nth(1)?.parse().ok()?;
    let resolved = if i < 0 { read as i64 + i } else { i - 1 };
    (i != 0 && (0..read as i64).contains(&resolved)).then_some(resolved as u32)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid() -> TileGrid {
        TileGrid {
            world: WorldBox {
                min: [0.0, 0.0, 0.0],
                max: [4.0, 2.0, 4.0],
            },
            counts: UVec3::new(2, 1, 2),
            margin: 0.5,
        }
    }

    #[test]
    fn cores_partition_the_world_and_boxes_add_the_margin() {
        let g = grid();
        assert_eq!(g.len(), 4);
        let t = g.tile(3);
        assert_eq!(t.cell, UVec3::new(1, 0, 1));
        assert_eq!(t.core.min, [2.0, 0.0, 2.0]);
        assert_eq!(t.core.max, [4.0, 2.0, 4.0]);
        assert_eq!(t.outer.min, [1.5, 0.0, 1.5]);
        assert_eq!(t.outer.max, [4.0, 2.0, 4.0]);
        // Every point has one owner, the tile whose core holds it.
        for (p, owner) in [
            ([0.0, 0.0, 0.0], 0),
            ([2.0, 1.0, 0.5], 1),
            ([1.999, 1.0, 2.0], 2),
            ([4.0, 2.0, 4.0], 3),
        ] {
            let p = DVec3::from_array(p);
            assert_eq!(g.owner(p), owner, "{p}");
            assert!(g.tile(owner).core.contains(p));
        }
        assert_eq!(parse_counts("2x1x2"), Ok(UVec3::new(2, 1, 2)));
        for bad in ["2x2", "0x1x1", "axbxc", "100x100x100"] {
            assert!(
                parse_counts(bad).unwrap_err().starts_with("--tiles: "),
                "{bad}"
            );
        }
    }

    #[test]
    fn split_writes_each_triangle_to_the_tiles_it_touches() {
        let dir = tempfile::tempdir().unwrap();
        let src = dir.path().join("s.obj");
        // Two triangles: one near the origin (tile 0 only), one straddling
        // x = 2 at z = 0.2 (tiles 0 and 1), in Z-up centimetres.
        std::fs::write(
            &src,
            "mtllib s.mtl\nv 10 -20 50\nv 50 -20 50\nv 10 -60 50\nusemtl a\nf 1 2 3\nv 150 -20 50\nv 250 -20 50\nv 150 -40 50\nusemtl b\nf -3/1 -2/2 -1/3\n",
        )
        .unwrap();
        let g = grid();
        assert_eq!(
            stream_bounds(&src, 0.01, UpAxis::Z).unwrap(),
            WorldBox {
                min: [0.1, 0.5, 0.2],
                max: [2.5, 0.5, 0.6]
            }
        );
        let outs: Vec<PathBuf> = (0..4)
            .map(|i| dir.path().join(format!("t{i}.obj")))
            .collect();
        let (geometry, libs) = split_obj(&src, 0.01, UpAxis::Z, &g, &outs, "../").unwrap();
        assert_eq!(libs, ["s.mtl"]);
        let counts: Vec<u64> = geometry.iter().map(|g| g.triangles).collect();
        assert_eq!(counts, [2, 1, 0, 0]);
        let t1 = std::fs::read_to_string(&outs[1]).unwrap();
        assert!(
            t1.starts_with("mtllib ../s.mtl\nusemtl b\nv 1.5 0.5 0.2\n"),
            "{t1}"
        );
        assert!(t1.ends_with("f 1 2 3\n"), "{t1}");
        let bad = dir.path().join("bad.obj");
        std::fs::write(&bad, "v 0 0 0\nf 1 2 3\n").unwrap();
        let e = split_obj(&bad, 1.0, UpAxis::Y, &g, &outs, "")
            .unwrap_err()
            .to_string();
        assert!(e.contains("bad.obj:2: face index \"2\""), "{e}");
    }

    #[test]
    fn split_tiles_keep_their_faces_texture_coordinates() {
        let dir = tempfile::tempdir().unwrap();
        let src = dir.path().join("s.obj");
        // A quad straddling x = 2 (both tiles of the bottom row), textured
        // by relative and absolute indices; a corner naming no `vt`.
        std::fs::write(
            &src,
            "v 1 0 1\nv 3 0 1\nv 3 0 0.5\nv 1 0 0.5\nvt 0.1 0.2\nvt 0.9 0.2 0\nvt 0.9 0.8\nf 1/1 2/-2 3/3/1 4/7\nvt 0.5 0.5\nf 4/-1 3/3 1/1\n",
        )
        .unwrap();
        let outs: Vec<PathBuf> = (0..4)
            .map(|i| dir.path().join(format!("t{i}.obj")))
            .collect();
        split_obj(&src, 1.0, UpAxis::Y, &grid(), &outs, "").unwrap();
        let t0 = std::fs::read_to_string(&outs[0]).unwrap();
        assert_eq!(
            t0,
            "v 1 0 1\nv 3 0 1\nv 3 0 0.5\nvt 0.1 0.2\nvt 0.9 0.2 0\nvt 0.9 0.8\nf 1/1 2/2 3/3\n\
             v 1 0 0.5\nf 1/1 3/3 4\n\
             vt 0.5 0.5\nf 4/4 3/3 1/1\n"
        );
        // The tile reads back with the source's texture coordinates.
        let read = |p: &Path| crate::scene::obj::read(p).unwrap();
        let (a, b) = (read(&src), read(&outs[0]));
        let uvs = |o: &crate::scene::obj::ObjFile| -> Vec<[Option<[f32; 2]>; 3]> {
            o.triangle_texcoords
                .iter()
                .map(|t| t.map(|i| o.texcoords.get(i as usize).copied()))
                .collect()
        };
        assert_eq!(uvs(&a), uvs(&b));
    }
}
