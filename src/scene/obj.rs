//! The Wavefront OBJ and MTL reader: streaming, bounded, and precise about
//! where a file is wrong.
//!
//! Only what the stages use is read: vertex positions (`v`), texture
//! coordinates (`vt`), faces (`f`, any of the `v`, `v/t`, `v//n`, `v/t/n`
//! forms, negative indices relative to the vertices read so far),
//! material libraries (`mtllib`) and switches (`usemtl`); every other
//! statement is skipped, as OBJ readers do. Texture coordinates are
//! lenient, since they only colour a surface: a `vt` that is no number
//! reads as `0 0`, and a face's texture index that names no `vt` leaves
//! the face untextured; both are counted in one warning. Polygons are fan-triangulated from their first vertex, the
//! triangulation tobj and most engines apply, so a quad's two triangles
//! are `(0,1,2)` and `(0,2,3)`.
//!
//! Limits, checked before the work they bound: a line is at most
//! [`MAX_LINE_BYTES`](crate::input::MAX_LINE_BYTES), a face at most
//! [`MAX_FACE_VERTICES`] vertices, the file at most four times the memory
//! budget ([`crate::limits`]), and the vertices and triangles read so far
//! must fit the budget, checked every [`CHECK_EVERY`] lines. A NUL byte
//! ends the read at once (a binary file). Errors name the file and line.
//!
//! MTL values outside what the BSDF can use are clamped, each with a
//! warning naming the file, line and material (docs/config.md, "Scenes"):
//! `Kd` and `Ks` components to [0, 1] (non-finite: the default, 0.8 and
//! 0); `Ke` components to [0, [`MAX_EMISSION`]] (non-finite: 0); `Ns` to
//! [0, [`MAX_SHININESS`]] (non-finite: the default 1).
//!
//! Texture maps: `map_Kd`, `map_Ke` and `map_d` (the file name, relative
//! to the MTL, after the options), with the options `-o u v` (offset),
//! `-s u v` (scale) and `-clamp on`; other options are skipped with their
//! arguments. The images are decoded by [`super::texture`]. Dissolve
//! (`d`, or `Tr` as its complement) and `map_d` make a cut-out
//! ([`super::Cutout`]: rays pass where the opacity is under 0.5).

use super::Material;
use crate::error::{Error, Result};
use crate::input::{self, LineError};
use crate::limits;
use glam::DVec3;
use std::collections::HashMap;
use std::io::BufReader;
use std::path::{Path, PathBuf};

/// Most vertices one face may have. Fan triangulation is linear in it,
/// but a longer face is not a modelling polygon: it is a broken export.
pub const MAX_FACE_VERTICES: usize = 65_536;

/// Largest material library read: 64 MiB of text.
pub const MAX_MTL_BYTES: u64 = 64 << 20;

/// Largest `Ke` component kept: 10⁶ (a light a million times brighter
/// than white paper lit by it); larger ones, which single precision would
/// overflow on the way through the renderer, are clamped with a warning.
pub const MAX_EMISSION: f64 = 1e6;

/// Largest `Ns` kept: 10⁶, far past a mirror (the BSDF's roughness floor
/// is reached near Ns = 2·10⁶); larger ones are clamped with a warning.
pub const MAX_SHININESS: f64 = 1e6;

/// Lines between two checks of the memory read so far.
pub const CHECK_EVERY: usize = 1 << 20;

/// Bytes a kept triangle costs from here until the scene's BVH is built:
/// the face (16), its world-space copy (80), the scene's triangle, normal
/// and material (52) and its share of the BVH (about 100).
pub const BYTES_PER_TRIANGLE: f64 = 250.0;

/// Most warnings of one kind listed per file; the rest are counted.
const LISTED_WARNINGS: usize = 5;

/// An OBJ file as read: vertex positions in file coordinates, triangles
/// as position indices with a material index (`u32::MAX`: none), the
/// materials of its libraries, and the warnings raised.
#[derive(Debug, Default)]
pub struct ObjFile {
    /// `v` statements, in file order.
    pub positions: Vec<DVec3>,
    /// Triangles (fan-triangulated faces), in file order.
    pub triangles: Vec<([u32; 3], u32)>,
    /// Materials of every `mtllib`, in library order.
    pub materials: Vec<Material>,
    /// `vt` statements `(u, v)`, in file order (OBJ's convention: `v` up).
    pub texcoords: Vec<[f32; 2]>,
    /// Each triangle's `vt` indices (`u32::MAX`: none), parallel to
    /// `triangles`; empty when the file has no `vt` or no face names one.
    pub triangle_texcoords: Vec<[u32; 3]>,
    /// The texture maps the materials name, to be loaded.
    pub maps: Vec<MapSpec>,
    /// What was repaired or skipped, in words.
    pub warnings: Vec<String>,
}

/// Reads the OBJ at `path` and the material libraries it names (relative
/// to its directory).
///
/// Contract: see the module docs for what is read and the limits. A
/// missing MTL, or a `usemtl` of a material no library defines, is a
/// warning (those faces get the fallback material); an MTL that exists but
/// is not a regular file, or is over [`MAX_MTL_BYTES`], is an error, as is
/// any OBJ line that cannot be read (`file:LINE: problem`).
///
/// The file is parsed in parallel batches ([`parse_batched`]); a file that
/// batch parsing does not accept as it stands (any mistake, any limit) is
/// read again by [`parse`], whose messages name the first line at fault.
/// Both read each line by one grammar ([`statement`]); they differ only
/// in when a face's indices can be checked against the vertices read so
/// far (at once, or once the batch's pieces are joined).
pub fn read(path: &Path) -> Result<ObjFile> {
    let limit = limits::memory_budget().saturating_mul(4);
    let (file, _) = input::open(path, "scene file", limit)?;
    let dir = path.parent().unwrap_or(Path::new("")).to_path_buf();
    let mut library = |name: &str| read_mtl_file(&dir.join(name));
    if let Some(obj) = parse_batched(file, path, &mut library) {
        return Ok(obj);
    }
    let (file, _) = input::open(path, "scene file", limit)?;
    parse(BufReader::with_capacity(1 << 16, file), path, &mut library)
}

/// Bytes of OBJ text read per batch of [`parse_batched`], per thread.
const BATCH_BYTES_PER_THREAD: usize = 8 << 20;

/// Pieces each batch of [`parse_batched`] is cut into, per thread, so that
/// threads finishing early take more.
const PIECES_PER_THREAD: usize = 4;

/// A face's triangle as [`parse_batched`] holds it before the vertices of
/// the pieces before its own are counted: each index is resolved when
/// non-negative (below [`FAR`]), and otherwise `RELATIVE + r` for a
/// negative face index that names the `r`-th vertex after the piece's
/// start (`r` negative: before it), `|r| < FAR`.
type PendingTriangle = ([i64; 3], u32);

/// Bound on the indices [`parse_batched`] resolves itself: no file within
/// the memory budget has this many vertices, so [`parse`] refuses any
/// index beyond it.
const FAR: i64 = 1 << 40;

/// Offset of relative indices in a [`PendingTriangle`].
const RELATIVE: i64 = -(1 << 42);

/// A texture map an MTL names: which material and slot, the image file
/// (relative to the MTL's folder, resolved), and how it is applied.
#[derive(Debug, Clone, PartialEq)]
pub struct MapSpec {
    /// Index into [`ObjFile::materials`].
    pub material: usize,
    /// Which map: `map_Kd`, `map_Ke` or `map_d`.
    pub slot: MapSlot,
    /// The image file, relative to the MTL's folder.
    pub file: PathBuf,
    /// The file as the MTL writes it (for the other places it is looked
    /// for: [`super::texture::locate_map`]).
    pub written: PathBuf,
    /// Offset and scale (`-o`, `-s`), and whether it clamps (`-clamp on`).
    pub offset: [f32; 2],
    /// Scale `-s`.
    pub scale: [f32; 2],
    /// `-clamp on`.
    pub clamp: bool,
}

/// Which of a material's maps an MTL statement sets.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MapSlot {
    /// `map_Kd`: the diffuse colour texture.
    Colour,
    /// `map_Ke`: the emission texture.
    Emission,
    /// `map_d`: the dissolve (alpha) texture, a cut-out.
    Alpha,
}

impl MapSlot {
    /// Its use as `report.json` names it ([`super::texture::USES`]).
    pub fn name(self) -> &'static str {
        match self {
            MapSlot::Colour => "colour",
            MapSlot::Emission => "emission",
            MapSlot::Alpha => "alpha",
        }
    }
}

/// A face corner's texture index as [`parse_batched`] holds it before the
/// pieces before its own are counted: [`PendingTriangle`]'s encoding, or
/// [`NO_TEXCOORD`].
const NO_TEXCOORD: i64 = i64::MIN;

/// What one piece of a batch holds, in file order.
#[derive(Default)]
struct Piece {
    positions: Vec<DVec3>,
    texcoords: Vec<[f32; 2]>,
    /// Texture indices of `triangles`, in the same encoding (or [`NO_TEXCOORD`]).
    triangle_texcoords: Vec<[i64; 3]>,
    /// `vt` statements that were no numbers.
    bad_texcoords: usize,
    /// Triangles, with the `usemtl` statement of this piece in force
    /// (index into `usemtl`), or [`INHERITED`] before the first.
    triangles: Vec<PendingTriangle>,
    /// The most, over the positive face indices, of the index resolved
    /// less the piece's vertices before its face: the pieces before must
    /// hold more vertices than this for every index to name a vertex read
    /// so far.
    reach_back: i64,
    /// Names of the `usemtl` statements, in order.
    usemtl: Vec<String>,
    /// Library names of the `mtllib` statements, in order.
    mtllib: Vec<Vec<String>>,
}

/// A triangle's material when no `usemtl` of its piece precedes it.
const INHERITED: u32 = u32::MAX;

/// [`parse`] of the text of `reader`, a batch of lines at a time, each
/// batch cut into pieces parsed in parallel, then joined in file order:
/// vertex counts, the `usemtl` in force and the `mtllib` statements (whose
/// libraries `library` loads) carry from piece to piece as [`parse`]
/// carries them from line to line.
///
/// Contract: `Some` only of text [`parse`] reads without error, and then
/// exactly what it gives; `None` for anything else (a read error, a NUL
/// byte, a line over [`input::MAX_LINE_BYTES`], any statement [`parse`]
/// refuses, the memory budget reached, a library that fails to load), for
/// [`parse`] to say what and where.
fn parse_batched(
    reader: impl std::io::Read,
    name: &Path,
    library: &mut dyn FnMut(&str) -> Result<Library>,
) -> Option<ObjFile> {
    let threads = rayon::current_num_threads().max(1);
    parse_batches(
        reader,
        name,
        library,
        BATCH_BYTES_PER_THREAD * threads,
        threads * PIECES_PER_THREAD,
    )
}

/// [`parse_batched`] with batches of `batch` bytes (more when a line is
/// longer) cut into `pieces` pieces.
fn parse_batches(
    mut reader: impl std::io::Read,
    name: &Path,
    library: &mut dyn FnMut(&str) -> Result<Library>,
    batch: usize,
    pieces: usize,
) -> Option<ObjFile> {
    use rayon::prelude::*;
    use std::io::Read;
    let mut obj = ObjFile::default();
    let mut materials = MaterialState::default();
    let mut current = u32::MAX;
    let mut text: Vec<u8> = Vec::new();
    let mut bad_texcoords = 0usize;
    loop {
        let before = text.len();
        (&mut reader)
            .take(batch as u64)
            .read_to_end(&mut text)
            .ok()?;
        let end = text.len() == before;
        let cut = if end {
            text.len()
        } else {
            match text.iter().rposition(|&b| b == b'\n') {
                Some(i) => i + 1,
                None if text.len() > input::MAX_LINE_BYTES => return None,
                None => continue,
            }
        };
        let rest = text.split_off(cut);
        if rest.len() > input::MAX_LINE_BYTES || text.contains(&0) {
            return None;
        }
        let parsed: Vec<Option<Piece>> = line_pieces(&text, pieces)
            .into_par_iter()
            .map(parse_piece)
            .collect();
        let parsed: Vec<Piece> = parsed.into_iter().collect::<Option<_>>()?;
        // Each piece's first vertex, and the `usemtl` in force at its start
        // with what its own `usemtl` statements name, in file order.
        let mut joins: Vec<(i64, u32, Vec<u32>)> = Vec::with_capacity(parsed.len());
        let mut texcoord_bases: Vec<i64> = Vec::with_capacity(parsed.len());
        let mut base = obj.positions.len() as i64;
        let mut texcoord_base = obj.texcoords.len() as i64;
        for piece in &parsed {
            if piece.reach_back >= base {
                return None;
            }
            let events: Vec<u32> = piece.usemtl.iter().map(|m| materials.used(m)).collect();
            let inherited = current;
            current = events.last().copied().unwrap_or(current);
            joins.push((base, inherited, events));
            texcoord_bases.push(texcoord_base);
            base += piece.positions.len() as i64;
            texcoord_base += piece.texcoords.len() as i64;
        }
        let resolved: Vec<Vec<([u32; 3], u32)>> = parsed
            .par_iter()
            .zip(&joins)
            .map(|(piece, (base, inherited, events))| {
                piece
                    .triangles
                    .iter()
                    .map(|&(t, m)| {
                        let mut tri = [0u32; 3];
                        for (slot, i) in tri.iter_mut().zip(t) {
                            let resolved = if i >= 0 { i } else { base + (i - RELATIVE) };
                            if resolved < 0 || resolved > u32::MAX as i64 {
                                return None;
                            }
                            *slot = resolved as u32;
                        }
                        let material = if m == INHERITED {
                            *inherited
                        } else {
                            events[m as usize]
                        };
                        Some((tri, material))
                    })
                    .collect()
            })
            .collect::<Option<_>>()?;
        for ((piece, triangles), texcoord_base) in parsed.into_iter().zip(resolved).zip(texcoord_bases) {
            let before = obj.triangles.len();
            obj.positions.extend(piece.positions);
            obj.triangles.extend(triangles);
            obj.texcoords.extend(piece.texcoords);
            bad_texcoords += piece.bad_texcoords;
            for (k, t) in piece.triangle_texcoords.iter().enumerate() {
                let t = t.map(|i| match i {
                    NO_TEXCOORD => u32::MAX,
                    i if i >= 0 => u32::try_from(i).unwrap_or(u32::MAX),
                    i => u32::try_from(texcoord_base + (i - RELATIVE)).unwrap_or(u32::MAX),
                });
                push_texcoords(&mut obj.triangle_texcoords, before + k, t);
            }
            for libs in &piece.mtllib {
                let libs = libs.iter().map(String::as_str);
                materials.load(&mut obj, libs, library).ok()?;
            }
        }
        if read_bytes(&obj) > limits::memory_budget() as f64
            || obj.triangles.len() > super::wide_bvh::MAX_PRIMITIVES
        {
            return None;
        }
        if end {
            break;
        }
        text = rest;
    }
    materials.resolve(&mut obj, name);
    check_texcoords(&mut obj, name, bad_texcoords);
    Some(obj)
}

/// `text` (whole lines) cut into about `n` pieces of whole lines.
fn line_pieces(text: &[u8], n: usize) -> Vec<&[u8]> {
    let size = text.len().div_ceil(n.max(1)).max(1);
    let mut pieces = Vec::new();
    let mut start = 0;
    while start < text.len() {
        let mut end = (start + size).min(text.len());
        while end < text.len() && text[end - 1] != b'\n' {
            end += 1;
        }
        pieces.push(&text[start..end]);
        start = end;
    }
    pieces
}

/// The statements of one piece of whole lines, as [`parse`] reads them;
/// `None` where it would refuse one (or a line is over the limit).
fn parse_piece(text: &[u8]) -> Option<Piece> {
    let mut piece = Piece {
        reach_back: i64::MIN,
        ..Piece::default()
    };
    let mut face: Vec<i64> = Vec::new();
    let mut corners_uv: Vec<i64> = Vec::new();
    for mut line in text.split(|&b| b == b'\n') {
        if line.len() > input::MAX_LINE_BYTES {
            return None;
        }
        if line.last() == Some(&b'\r') {
            line = &line[..line.len() - 1];
        }
        let text = String::from_utf8_lossy(line);
        match statement(uncommented(&text), &mut face, &mut corners_uv).ok()? {
            Statement::Vertex(p) => piece.positions.push(p),
            Statement::TexCoord(uv) => match uv {
                Some(uv) => piece.texcoords.push(uv),
                None => {
                    piece.texcoords.push([0.0; 2]);
                    piece.bad_texcoords += 1;
                }
            },
            Statement::Face => {
                let vts = piece.texcoords.len() as i64;
                for i in corners_uv.iter_mut() {
                    *i = match *i {
                        0 => NO_TEXCOORD,
                        i if !(-FAR..=FAR).contains(&i) => NO_TEXCOORD,
                        i if i > 0 => i - 1,
                        i => RELATIVE + vts + i,
                    };
                }
                let count = piece.positions.len() as i64;
                for i in face.iter_mut() {
                    *i = match *i {
                        0 => return None,
                        i if !(-FAR..=FAR).contains(&i) => return None,
                        i if i > 0 => {
                            piece.reach_back = piece.reach_back.max(i - 1 - count);
                            i - 1
                        }
                        i => RELATIVE + count + i,
                    };
                }
                let material = piece.usemtl.len() as u32;
                let material = material.checked_sub(1).unwrap_or(INHERITED);
                for k in 1..face.len() - 1 {
                    piece
                        .triangles
                        .push(([face[0], face[k], face[k + 1]], material));
                    piece.triangle_texcoords.push([
                        corners_uv[0],
                        corners_uv[k],
                        corners_uv[k + 1],
                    ]);
                }
            }
            Statement::UseMtl(name) => piece.usemtl.push(name.to_string()),
            Statement::MtlLib(words) => piece.mtllib.push(words.map(str::to_string).collect()),
            Statement::Skipped => {}
        }
    }
    Some(piece)
}

/// One OBJ statement, as the grammar both readers share reads it
/// ([`statement`]); what it means (the vertices it names, the material in
/// force) is left to the reader.
enum Statement<'a> {
    /// `v x y z`.
    Vertex(DVec3),
    /// `vt u [v [w]]` (`None`: not numbers).
    TexCoord(Option<[f32; 2]>),
    /// `f i j k …`: the face's position indices as written (1-based,
    /// negative relative to the vertices read so far) are in the buffer
    /// [`statement`] was given, its texture indices (0: none, or not an
    /// index) in the second.
    Face,
    /// `usemtl NAME` (the rest of the line).
    UseMtl(&'a str),
    /// `mtllib A B …`.
    MtlLib(std::str::SplitAsciiWhitespace<'a>),
    /// A blank line, a comment, or a statement the stages do not use.
    Skipped,
}

/// Why a line is no OBJ statement.
enum Problem<'a> {
    /// A vertex of this many coordinates, not 3.
    VertexCoordinates(usize),
    /// A vertex coordinate that is no number.
    Coordinate(&'a str),
    /// A face vertex that is no index.
    Index(&'a str),
    /// A face of more than [`MAX_FACE_VERTICES`] vertices.
    FaceTooLong,
    /// A face of this many vertices, fewer than 3.
    FaceTooShort(usize),
}

/// `line` without its comment (from the first `#`).
fn uncommented(line: &str) -> &str {
    line.split('#').next().unwrap_or("")
}

/// Reads one line (its comment removed: [`uncommented`]) as an OBJ
/// statement: the grammar of the module docs, which [`parse`] and the
/// batched reader share. A face's indices go into `face`, as written.
fn statement<'a>(
    text: &'a str,
    face: &mut Vec<i64>,
    texcoords: &mut Vec<i64>,
) -> std::result::Result<Statement<'a>, Problem<'a>> {
    let mut words = text.split_ascii_whitespace();
    let Some(keyword) = words.next() else {
        return Ok(Statement::Skipped);
    };
    Ok(match keyword {
        "v" => {
            let mut c = [0.0f64; 3];
            for (i, slot) in c.iter_mut().enumerate() {
                let w = words.next().ok_or(Problem::VertexCoordinates(i))?;
                *slot = w.parse().map_err(|_| Problem::Coordinate(w))?;
            }
            Statement::Vertex(DVec3::from_array(c))
        }
        "vt" => {
            let mut c = [0.0f32; 2];
            let mut ok = true;
            for (i, slot) in c.iter_mut().enumerate() {
                match words.next().map(str::parse::<f32>) {
                    Some(Ok(v)) if v.is_finite() => *slot = v,
                    None if i == 1 => {}
                    _ => ok = false,
                }
            }
            Statement::TexCoord(ok.then_some(c))
        }
        "f" => {
            face.clear();
            texcoords.clear();
            for w in words {
                if face.len() == MAX_FACE_VERTICES {
                    return Err(Problem::FaceTooLong);
                }
                let mut parts = w.split('/');
                let index = parts.next().unwrap_or("");
                face.push(index.parse().map_err(|_| Problem::Index(w))?);
                texcoords.push(parts.next().and_then(|t| t.parse().ok()).unwrap_or(0));
            }
            if face.len() < 3 {
                return Err(Problem::FaceTooShort(face.len()));
            }
            Statement::Face
        }
        "usemtl" => Statement::UseMtl(rest_of(text, keyword)),
        "mtllib" => Statement::MtlLib(words),
        _ => Statement::Skipped,
    })
}

/// What loading one material library gave.
pub enum Library {
    /// Its text.
    Text(PathBuf, String),
    /// It does not exist or could not be read: a warning.
    Missing(String),
}

fn read_mtl_file(path: &Path) -> Result<Library> {
    if !path.exists() {
        return Ok(Library::Missing(format!(
            "{}: material library not found; its materials get the default",
            path.display()
        )));
    }
    let bytes = input::read(path, "material library", MAX_MTL_BYTES)?;
    if let Some(at) = bytes.iter().position(|&b| b == 0) {
        let line = 1 + bytes[..at].iter().filter(|&&b| b == b'\n').count();
        return Err(input::not_text(path, line, "an MTL"));
    }
    Ok(Library::Text(
        path.to_path_buf(),
        String::from_utf8_lossy(&bytes).into_owned(),
    ))
}

/// Parses OBJ text from `reader` (`name` for messages); `library` loads a
/// `mtllib` by the name the file gives. See [`read`].
pub fn parse(
    mut reader: impl std::io::BufRead,
    name: &Path,
    library: &mut dyn FnMut(&str) -> Result<Library>,
) -> Result<ObjFile> {
    let mut obj = ObjFile::default();
    let mut materials = MaterialState::default();
    let mut current = u32::MAX;
    let mut line = Vec::new();
    let mut face: Vec<i64> = Vec::new();
    let mut corners: Vec<u32> = Vec::new();
    let mut face_texcoords: Vec<i64> = Vec::new();
    let mut corner_texcoords: Vec<u32> = Vec::new();
    let mut bad_texcoords = 0usize;
    let mut n = 0usize;
    let at = |n: usize, msg: String| Error::User(format!("{}:{n}: {msg}", name.display()));
    loop {
        n += 1;
        let more = input::next_line(&mut reader, &mut line)
            .map_err(|e| Error::user_file(name, format!("cannot read scene file: {e}")))?;
        match more {
            Ok(false) => break,
            Ok(true) => {}
            Err(LineError::Binary) => return Err(input::not_text(name, n, "an OBJ")),
            Err(LineError::TooLong) => {
                return Err(at(
                    n,
                    format!(
                        "line longer than {}; not an OBJ a modeller writes",
                        input::bytes_text(input::MAX_LINE_BYTES as u64)
                    ),
                ))
            }
        }
        if n.is_multiple_of(CHECK_EVERY) {
            let bytes = read_bytes(&obj);
            limits::check_memory(
                "scene",
                &format!(
                    "{} after {} lines ({} vertices, {} triangles so far)",
                    name.display(),
                    n,
                    obj.positions.len(),
                    obj.triangles.len()
                ),
                bytes,
            )?;
            if obj.triangles.len() > super::wide_bvh::MAX_PRIMITIVES {
                return Err(at(
                    n,
                    format!(
                        "more than {} triangles, the most one BVH holds; split the scene into tiles (`probeplace split`)",
                        super::wide_bvh::MAX_PRIMITIVES
                    ),
                ));
            }
        }
        let text = String::from_utf8_lossy(&line);
        let parsed = statement(uncommented(&text), &mut face, &mut face_texcoords).map_err(|p| {
            at(
                n,
                match p {
                    Problem::VertexCoordinates(i) => {
                        format!("a vertex needs 3 coordinates, found {i}")
                    }
                    Problem::Coordinate(w) => {
                        format!("vertex coordinate `{}` is not a number", short(w))
                    }
                    Problem::Index(w) => format!("face vertex `{}` is not an index", short(w)),
                    Problem::FaceTooLong => {
                        format!("a face of more than {MAX_FACE_VERTICES} vertices")
                    }
                    Problem::FaceTooShort(k) => {
                        format!("a face needs at least 3 vertices, found {k}")
                    }
                },
            )
        })?;
        match parsed {
            Statement::Vertex(p) => obj.positions.push(p),
            Statement::TexCoord(uv) => {
                if uv.is_none() {
                    bad_texcoords += 1;
                }
                obj.texcoords.push(uv.unwrap_or([0.0; 2]));
            }
            Statement::Face => {
                let vts = obj.texcoords.len() as i64;
                corner_texcoords.clear();
                for &i in &face_texcoords {
                    corner_texcoords.push(match i {
                        0 => u32::MAX,
                        i if i > 0 => u32::try_from(i - 1).unwrap_or(u32::MAX),
                        i => u32::try_from(vts + i).unwrap_or(u32::MAX),
                    });
                }
                let count = obj.positions.len() as i64;
                corners.clear();
                for &i in &face {
                    let resolved = if i > 0 { i - 1 } else { count + i };
                    if i == 0 || resolved < 0 || resolved >= count {
                        return Err(at(
                            n,
                            format!(
                                "face vertex index {i} does not name one of the {count} vertices read so far"
                            ),
                        ));
                    }
                    corners.push(resolved as u32);
                }
                for k in 1..corners.len() - 1 {
                    let t = [corner_texcoords[0], corner_texcoords[k], corner_texcoords[k + 1]];
                    push_texcoords(&mut obj.triangle_texcoords, obj.triangles.len(), t);
                    obj.triangles
                        .push(([corners[0], corners[k], corners[k + 1]], current));
                }
            }
            Statement::UseMtl(m) => current = materials.used(m),
            Statement::MtlLib(words) => materials.load(&mut obj, words, library)?,
            Statement::Skipped => {}
        }
    }
    materials.resolve(&mut obj, name);
    check_texcoords(&mut obj, name, bad_texcoords);
    Ok(obj)
}

/// Memory what is read so far takes, and will take until the BVH is
/// built: 24 bytes a vertex, [`BYTES_PER_TRIANGLE`] a triangle, and its
/// texture indices (12) and the `vt` (8 each) where the file has them.
fn read_bytes(obj: &ObjFile) -> f64 {
    obj.positions.len() as f64 * 24.0
        + obj.triangles.len() as f64 * BYTES_PER_TRIANGLE
        + obj.triangle_texcoords.len() as f64 * 12.0
        + obj.texcoords.len() as f64 * 8.0
}

/// Records triangle `index`'s texture indices `t` in `all`, which holds
/// none until the first triangle that has one (a file without texture
/// coordinates spends no memory on them), then one per triangle.
fn push_texcoords(all: &mut Vec<[u32; 3]>, index: usize, t: [u32; 3]) {
    if all.is_empty() && t == [u32::MAX; 3] {
        return;
    }
    all.resize(index, [u32::MAX; 3]);
    all.push(t);
}

/// What both readers do once the file is read: texture indices that name
/// no `vt` become none, and the repairs are counted in one warning; the
/// indices are one per triangle, or none at all when no `vt` is read or
/// no face names one.
fn check_texcoords(obj: &mut ObjFile, name: &Path, bad: usize) {
    if obj.texcoords.is_empty() {
        obj.triangle_texcoords = Vec::new();
        return;
    }
    if !obj.triangle_texcoords.is_empty() {
        obj.triangle_texcoords.resize(obj.triangles.len(), [u32::MAX; 3]);
    }
    let n = obj.texcoords.len();
    let mut unnamed = 0usize;
    for t in obj.triangle_texcoords.iter_mut() {
        for i in t.iter_mut() {
            if *i != u32::MAX && *i as usize >= n {
                *i = u32::MAX;
                unnamed += 1;
            }
        }
    }
    if bad + unnamed > 0 {
        obj.warnings.push(format!(
            "{}: {bad} `vt` statement(s) that are not numbers (read as 0 0) and {unnamed} face corner(s) whose texture index names no `vt` (left untextured)",
            name.display()
        ));
    }
}

/// What both OBJ readers keep of materials while they read: the libraries
/// loaded, the names they define, and the names `usemtl` gave in order.
/// Triangles carry an index into `used` until [`MaterialState::resolve`]
/// maps them to library materials, once every library is read (a
/// `usemtl` may come before the `mtllib` that defines it).
#[derive(Default)]
struct MaterialState {
    /// Library material name → index into `ObjFile::materials`.
    names: HashMap<String, u32>,
    /// Libraries already read, by the name the OBJ gives.
    loaded: Vec<String>,
    /// Names in first-`usemtl` order.
    used: Vec<String>,
}

impl MaterialState {
    /// The index of `name` among the `usemtl` names, added when new.
    fn used(&mut self, name: &str) -> u32 {
        match self.used.iter().position(|u| u == name) {
            Some(i) => i as u32,
            None => {
                self.used.push(name.to_string());
                (self.used.len() - 1) as u32
            }
        }
    }

    /// Loads the libraries `libs` of one `mtllib` statement not loaded yet,
    /// in order, into `obj` (materials and warnings).
    fn load<'a>(
        &mut self,
        obj: &mut ObjFile,
        libs: impl Iterator<Item = &'a str>,
        library: &mut dyn FnMut(&str) -> Result<Library>,
    ) -> Result<()> {
        for lib in libs {
            if self.loaded.iter().any(|l| l == lib) {
                continue;
            }
            self.loaded.push(lib.to_string());
            match library(lib)? {
                Library::Missing(w) => obj.warnings.push(w),
                Library::Text(path, text) => {
                    let (materials, maps, mut warnings) = parse_mtl(&text, &path);
                    let first = obj.materials.len();
                    obj.maps.extend(maps.into_iter().map(|mut m| {
                        m.material += first;
                        m
                    }));
                    for m in materials {
                        self.names
                            .insert(m.name.clone(), obj.materials.len() as u32);
                        obj.materials.push(m);
                    }
                    obj.warnings.append(&mut warnings);
                }
            }
        }
        Ok(())
    }

    /// Maps the triangles' `usemtl` indices to library materials, and warns
    /// of the names no library defines (`name`: the OBJ).
    fn resolve(self, obj: &mut ObjFile, name: &Path) {
        let mut unknown: Vec<&str> = Vec::new();
        let map: Vec<u32> = self
            .used
            .iter()
            .map(|u| {
                self.names.get(u).copied().unwrap_or_else(|| {
                    unknown.push(u);
                    u32::MAX
                })
            })
            .collect();
        for (_, m) in obj.triangles.iter_mut() {
            if *m != u32::MAX {
                *m = map[*m as usize];
            }
        }
        if !unknown.is_empty() && !obj.materials.is_empty() {
            obj.warnings.push(format!(
                "{}: usemtl names material(s) no library defines ({}); those faces get the default",
                name.display(),
                listed(&unknown)
            ));
        }
    }
}

/// `text` after `keyword` and its whitespace, trimmed (names may hold spaces).
fn rest_of<'a>(text: &'a str, keyword: &str) -> &'a str {
    text.trim_start()[keyword.len()..].trim()
}

/// The first [`LISTED_WARNINGS`] of `items`, then how many more.
fn listed(items: &[&str]) -> String {
    let mut s = items
        .iter()
        .take(LISTED_WARNINGS)
        .map(|i| format!("`{i}`"))
        .collect::<Vec<_>>()
        .join(", ");
    if items.len() > LISTED_WARNINGS {
        s.push_str(&format!(" and {} more", items.len() - LISTED_WARNINGS));
    }
    s
}

/// At most 40 characters of a word, for messages about it.
fn short(word: &str) -> String {
    if word.chars().count() > 40 {
        format!("{}…", word.chars().take(40).collect::<String>())
    } else {
        word.to_string()
    }
}

/// The materials of one MTL text (`path` for messages), the texture maps
/// they name (image files relative to `path`'s folder) and the warnings
/// its values raised (module docs: what is clamped, which map options
/// are read).
pub fn parse_mtl(text: &str, path: &Path) -> (Vec<Material>, Vec<MapSpec>, Vec<String>) {
    let mut materials: Vec<Material> = Vec::new();
    let mut maps: Vec<MapSpec> = Vec::new();
    let dir = path.parent().unwrap_or(Path::new(""));
    let mut warnings: Vec<String> = Vec::new();
    // Per material, its dissolve: (given by `d`?, opacity).
    let mut dissolve: HashMap<usize, (bool, f32)> = HashMap::new();
    let mut repaired = 0usize;
    let mut warn = |w: String| {
        repaired += 1;
        if repaired <= LISTED_WARNINGS {
            warnings.push(w);
        }
    };
    for (i, raw) in text.lines().enumerate() {
        let line = raw.split('#').next().unwrap_or("");
        let mut words = line.split_ascii_whitespace();
        let Some(keyword) = words.next() else {
            continue;
        };
        if keyword == "newmtl" {
            let mut m = Material::fallback();
            m.name = rest_of(line, keyword).to_string();
            materials.push(m);
            continue;
        }
        let slot = materials.len().wrapping_sub(1);
        let Some(m) = materials.last_mut() else {
            continue;
        };
        let here = |what: String| {
            format!(
                "{}:{}: material `{}`: {what}",
                path.display(),
                i + 1,
                m.name
            )
        };
        let which = match keyword {
            "map_Kd" => Some(MapSlot::Colour),
            "map_Ke" => Some(MapSlot::Emission),
            "map_d" => Some(MapSlot::Alpha),
            _ => None,
        };
        if let Some(which) = which {
            maps.retain(|m| !(m.material == slot && m.slot == which));
            match map_statement(rest_of(line, keyword)) {
                Some((file, offset, scale, clamp)) => maps.push(MapSpec {
                    material: slot,
                    slot: which,
                    file: dir.join(&file),
                    written: PathBuf::from(file),
                    offset,
                    scale,
                    clamp,
                }),
                None => warn(here(format!("{keyword} names no file; ignored"))),
            }
            continue;
        }
        let values: Vec<&str> = words.collect();
        match keyword {
            "Kd" | "Ks" | "Ke" => {
                let Some(rgb) = colour(&values) else {
                    warn(here(format!(
                        "{keyword} `{}` is not 1 or 3 numbers; ignored",
                        short(&values.join(" "))
                    )));
                    continue;
                };
                let (default, max) = match keyword {
                    "Kd" => (0.8, 1.0),
                    "Ks" => (0.0, 1.0),
                    _ => (0.0, MAX_EMISSION),
                };
                let mut out = [0.0f32; 3];
                let mut notes = Vec::new();
                for (o, v) in out.iter_mut().zip(rgb) {
                    let fixed = if !v.is_finite() {
                        if keyword == "Ke" {
                            0.0
                        } else {
                            default
                        }
                    } else {
                        v.clamp(0.0, max)
                    };
                    if fixed != v {
                        notes.push(format!("{v} → {fixed}"));
                    }
                    *o = fixed as f32;
                }
                if !notes.is_empty() {
                    warn(here(format!(
                        "{keyword} out of range ({}); clamped",
                        notes.join(", ")
                    )));
                }
                match keyword {
                    "Kd" => m.diffuse = out,
                    "Ks" => m.specular = out,
                    _ => m.emission = out,
                }
            }
            // Dissolve: `d` is the opacity, `Tr` (as many exporters
            // write it) its complement; `d` wins where both are given.
            // Read as a cut-out at 0.5 (`Material::cutout`): under it,
            // rays pass the material everywhere.
            "d" | "Tr" => match values.iter().find(|w| **w != "-halo").and_then(|v| v.parse::<f64>().ok()) {
                Some(v) if v.is_finite() => {
                    let d = if keyword == "d" { v } else { 1.0 - v };
                    if !(0.0..=1.0).contains(&d) {
                        warn(here(format!("{keyword} {v} out of range; clamped")));
                    }
                    let given_d = dissolve.get(&slot).is_some_and(|&(by_d, _)| by_d);
                    if keyword == "d" || !given_d {
                        dissolve.insert(slot, (keyword == "d", d.clamp(0.0, 1.0) as f32));
                    }
                }
                _ => warn(here(format!(
                    "{keyword} `{}` is not a number; ignored",
                    short(&values.join(" "))
                ))),
            },
            "Ns" => match values.first().and_then(|v| v.parse::<f64>().ok()) {
                Some(v) if (0.0..=MAX_SHININESS).contains(&v) => m.shininess = v as f32,
                Some(v) => {
                    let fixed = if !v.is_finite() {
                        1.0
                    } else {
                        v.clamp(0.0, MAX_SHININESS)
                    };
                    warn(here(format!("Ns {v} out of range; {fixed} used")));
                    m.shininess = fixed as f32;
                }
                None => warn(here(format!(
                    "Ns `{}` is not a number; ignored",
                    short(&values.join(" "))
                ))),
            },
            _ => {}
        }
    }
    if repaired > LISTED_WARNINGS {
        warnings.push(format!(
            "{}: and {} more value(s) clamped",
            path.display(),
            repaired - LISTED_WARNINGS
        ));
    }
    let mut invisible: Vec<String> = Vec::new();
    for (&i, &(_, d)) in &dissolve {
        if d < 1.0 {
            let cut = super::Cutout {
                factor: d,
                map: None,
                grey: true,
                cutoff: 0.5,
            };
            if cut.everywhere() {
                invisible.push(format!("`{}` ({d})", materials[i].name));
            }
            materials[i].cutout = Some(cut);
        }
    }
    if !invisible.is_empty() {
        invisible.sort();
        warnings.push(format!(
            "{}: material(s) {} have an opacity (`d`, or 1 − `Tr`) under 0.5: rays pass through them everywhere, as through a cut-out",
            path.display(),
            super::first_of(&invisible, LISTED_WARNINGS)
        ));
    }
    (materials, maps, warnings)
}

/// Arguments each texture-map option of the MTL format takes (Wavefront's
/// MTL specification, "Texture map statements"); `-o`, `-s` and `-t` take
/// one to three numbers, counted as they come.
fn option_arguments(option: &str) -> Option<usize> {
    Some(match option {
        "-blendu" | "-blendv" | "-cc" | "-clamp" | "-imfchan" | "-texres" | "-type" => 1,
        "-bm" | "-boost" => 1,
        "-mm" => 2,
        "-o" | "-s" | "-t" => 3,
        _ => return None,
    })
}

/// A `map_Kd`/`map_Ke` statement's arguments: the file (the rest after
/// the options, so that names with spaces survive), the `-o` offset, the
/// `-s` scale and `-clamp on`. `None` when no file name is left.
fn map_statement(args: &str) -> Option<(String, [f32; 2], [f32; 2], bool)> {
    let mut offset = [0.0f32; 2];
    let mut scale = [1.0f32; 2];
    let mut clamp = false;
    let mut rest = args.trim();
    while rest.starts_with('-') {
        let (option, after) = rest.split_once(char::is_whitespace).unwrap_or((rest, ""));
        let Some(count) = option_arguments(option) else {
            break;
        };
        rest = after.trim_start();
        let mut numbers = Vec::new();
        for k in 0..count {
            let (word, after) = rest.split_once(char::is_whitespace).unwrap_or((rest, ""));
            // -o, -s and -t take up to three numbers; stop at the first word
            // that is not one.
            let number = word.parse::<f32>().ok().filter(|v| v.is_finite());
            if count == 3 && k > 0 && number.is_none() {
                break;
            }
            if option == "-clamp" {
                clamp = word == "on";
            }
            numbers.push(number.unwrap_or(0.0));
            rest = after.trim_start();
        }
        match option {
            "-o" => offset = [numbers[0], numbers.get(1).copied().unwrap_or(0.0)],
            "-s" => scale = [numbers[0], numbers.get(1).copied().unwrap_or(1.0)],
            _ => {}
        }
    }
    (!rest.is_empty()).then(|| (rest.to_string(), offset, scale, clamp))
}

/// `r g b`, or one value for all three.
fn colour(values: &[&str]) -> Option<[f64; 3]> {
    let parsed: Option<Vec<f64>> = values.iter().map(|v| v.parse().ok()).collect();
    match parsed?.as_slice() {
        [v] => Some([*v; 3]),
        [r, g, b] => Some([*r, *g, *b]),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse_text(text: &str, mtl: &str) -> Result<ObjFile> {
        let mtl = mtl.to_string();
        parse(
            std::io::Cursor::new(text.as_bytes().to_vec()),
            Path::new("t.obj"),
            &mut |name: &str| {
                Ok(if name == "t.mtl" {
                    Library::Text(PathBuf::from("t.mtl"), mtl.clone())
                } else {
                    Library::Missing(format!("{name}: not found"))
                })
            },
        )
    }

    fn error(text: &str) -> String {
        parse_text(text, "").unwrap_err().to_string()
    }

    #[test]
    fn polygons_fan_from_their_first_vertex_and_indices_resolve() {
        let o = parse_text(
            "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1/1/1 2//2 3/3 4\nf -4 -3 -2\n",
            "",
        )
        .unwrap();
        let tris: Vec<[u32; 3]> = o.triangles.iter().map(|t| t.0).collect();
        assert_eq!(tris, [[0, 1, 2], [0, 2, 3], [0, 1, 2]]);
        assert!(o.triangles.iter().all(|t| t.1 == u32::MAX));
    }

    #[test]
    fn materials_resolve_by_name_and_bad_values_are_clamped_with_a_warning() {
        let mtl = "newmtl red\nKd 5 0.5 NaN\nKe inf 1 -2\nNs -5\nnewmtl shiny\nKs 0.5\nNs 200\nnewmtl sun\nKe 1e300 2 3\nNs 1e300\n";
        let o = parse_text(
            "mtllib t.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl shiny\nf 1 2 3\nusemtl red\nf 1 2 3\nusemtl nope\nf 1 2 3\n",
            mtl,
        )
        .unwrap();
        let ids: Vec<u32> = o.triangles.iter().map(|t| t.1).collect();
        assert_eq!(ids, [1, 0, u32::MAX]);
        let red = &o.materials[0];
        assert_eq!(red.diffuse, [1.0, 0.5, 0.8]);
        assert_eq!(red.emission, [0.0, 1.0, 0.0]);
        assert_eq!(red.shininess, 0.0);
        assert_eq!(o.materials[1].specular, [0.5; 3]);
        assert_eq!(o.materials[1].shininess, 200.0);
        assert_eq!(o.materials[2].emission, [1e6, 2.0, 3.0]);
        assert_eq!(o.materials[2].shininess, 1e6);
        let w = o.warnings.join("\n");
        assert!(
            w.contains("t.mtl:2: material `red`: Kd out of range"),
            "{w}"
        );
        assert!(w.contains("t.mtl:3: material `red`: Ke"), "{w}");
        assert!(w.contains("t.mtl:4: material `red`: Ns -5"), "{w}");
        assert!(w.contains("`nope`"), "{w}");
    }

    #[test]
    fn mistakes_name_their_line() {
        assert_eq!(
            error("v 0 0 0\nv 1 x 0\n"),
            "t.obj:2: vertex coordinate `x` is not a number"
        );
        assert_eq!(
            error("v 0 0\n"),
            "t.obj:1: a vertex needs 3 coordinates, found 2"
        );
        assert!(error("v 0 0 0\nf 1 2 3\n").starts_with("t.obj:2: face vertex index 2"));
        assert!(error("v 0 0 0\n# c\nf 1 0 1\n").starts_with("t.obj:3: face vertex index 0"));
        assert_eq!(
            error("v 0 0 0\nf 1 1\n"),
            "t.obj:2: a face needs at least 3 vertices, found 2"
        );
        assert!(error("v 0 0 0\nf a b c\n").contains("`a` is not an index"));
        assert!(error("# ok\n\0\0\0").starts_with("t.obj:2: binary data"));
    }

    #[test]
    fn a_huge_face_is_refused_without_triangulating_it() {
        let mut text = String::from("v 0 0 0\nv 1 0 0\nv 0 1 0\nf");
        for i in 0..MAX_FACE_VERTICES + 1 {
            text.push_str(&format!(" {}", i % 3 + 1));
        }
        let e = error(&text);
        assert!(
            e.starts_with("t.obj:4: a face of more than 65536 vertices"),
            "{e}"
        );
    }

    /// What [`parse_batches`] gives for `text` in batches of `batch` bytes
    /// cut into `pieces`, beside what [`parse`] gives: equal (and
    /// `Some`), or `None` where [`parse`] refuses the text.
    fn batched_matches(text: &str, mtl: &str, batch: usize, pieces: usize) -> bool {
        let mtl = mtl.to_string();
        let mut library = |name: &str| {
            Ok(if name == "t.mtl" {
                Library::Text(PathBuf::from("t.mtl"), mtl.clone())
            } else {
                Library::Missing(format!("{name}: not found"))
            })
        };
        let batched = parse_batches(
            text.as_bytes(),
            Path::new("t.obj"),
            &mut library,
            batch,
            pieces,
        );
        match (parse_text(text, &mtl), batched) {
            (Ok(a), Some(b)) => {
                assert_eq!(a.positions, b.positions, "{text:?}");
                assert_eq!(a.triangles, b.triangles, "{text:?}");
                assert_eq!(a.materials, b.materials, "{text:?}");
                assert_eq!(a.warnings, b.warnings, "{text:?}");
                assert_eq!(a.texcoords, b.texcoords, "{text:?}");
                assert_eq!(a.triangle_texcoords, b.triangle_texcoords, "{text:?}");
                assert_eq!(a.maps, b.maps, "{text:?}");
                true
            }
            (Err(_), None) => false,
            (a, b) => panic!("{text:?}: parse {a:?}, batched {}", b.is_some()),
        }
    }

    /// Batches and pieces cut anywhere between lines give what the line
    /// reader gives: indices relative to vertices of earlier pieces,
    /// `usemtl` in force across a cut, libraries, CRLF, comments, a last
    /// line without its newline; and every text the line reader refuses
    /// is refused.
    #[test]
    fn batched_parsing_reads_what_the_line_reader_reads() {
        let mtl = "newmtl red\nKd 1 0 0\nnewmtl blue\nKd 0 0 5\n";
        let good = [
            "mtllib t.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl blue\nf 1 2 3\nv 0 0 1\r\nf -1 -2 -3 1\n# c\nusemtl red\nf 2 3 4 # tail\nmtllib x.mtl t.mtl\nusemtl nope\nf -4 -3 -2\nusemtl blue\nf 1/1/1 2//2 3/3",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 3 2 1\n\n\nv 1 1 1\nf -1 -2 -3\n",
            "v 1e300 -0 0\nv 1 0 0 1\nv 0 1 0\nvt 0 0\nf 1 2 3\n",
            "",
            "# nothing\n",
            // Texture coordinates: relative, forward, missing, malformed.
            "vt 0 0\nvt 1 0\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/1 2/-1 3/3\nvt 0.5 x\nvt 0.25\nf 1/-2 2/4 3/-1\nf 1/x 2//1 3/0\nvt 1 1 1\n",
        ];
        let bad = [
            "v 0 0 0\nv 1 x 0\n",
            "v 0 0 0\nf 1 2 3\n",
            "v 0 0 0\nv 1 0 0\nf 1 2 -3\n",
            "v 0 0 0\nv 1 0 0\nv 1 1 0\nf 1 0 2\n",
            "v 0 0 0\nf 1 1\n",
            "v 0 0 0\nv 1 0 0\nv 1 1 0\nf 1 2 99999999999999999999\n",
            "v 0 0 0\nv 1 0 0\nv 1 1 0\nf 1 2 -1099511627777\n",
            "# ok\n\0\0\0",
        ];
        for batch in [1, 5, 17, 64, 1 << 20] {
            for pieces in [1, 2, 3, 7] {
                for text in good {
                    assert!(batched_matches(text, mtl, batch, pieces), "{text:?}");
                }
                for text in bad {
                    assert!(!batched_matches(text, mtl, batch, pieces), "{text:?}");
                }
            }
        }
    }

    #[test]
    fn texture_coordinates_resolve_and_bad_ones_leave_corners_untextured() {
        let obj = parse_text(
            "mtllib t.mtl\nvt 0 0\nvt 1 0\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1/1 2/-1 3/3 4/9\nvt 0.5 x\nf 1/-3 2 3/-1\n",
            "newmtl a\nmap_Kd -s 2 3 -o 0.5 -blendu off -clamp on my file.png\nmap_Ke glow.jpg\nnewmtl b\nmap_Kd -bm 1\n",
        )
        .unwrap();
        assert_eq!(obj.texcoords, [[0.0, 0.0], [1.0, 0.0], [0.0, 0.0]]);
        let none = u32::MAX;
        // A quad's two triangles; then a face whose middle corner has none.
        assert_eq!(
            obj.triangle_texcoords,
            [[0, 1, 2], [0, 2, none], [0, none, 2]]
        );
        assert!(obj.warnings.iter().any(|w| w.contains("1 `vt` statement(s) that are not numbers")
            && w.contains("1 face corner(s) whose texture index names no `vt`")), "{:?}", obj.warnings);
        let file = |m: &MapSpec| m.file.to_string_lossy().into_owned();
        assert_eq!(obj.maps.len(), 2, "{:?}", obj.maps);
        assert_eq!((file(&obj.maps[0]), obj.maps[0].slot), ("my file.png".into(), MapSlot::Colour));
        assert_eq!((obj.maps[0].scale, obj.maps[0].offset, obj.maps[0].clamp), ([2.0, 3.0], [0.5, 0.0], true));
        assert_eq!((file(&obj.maps[1]), obj.maps[1].slot), ("glow.jpg".into(), MapSlot::Emission));
        // `map_Kd -bm 1` names no file.
        assert!(obj.warnings.iter().any(|w| w.contains("material `b`: map_Kd names no file")), "{:?}", obj.warnings);
    }

    #[test]
    fn statements_the_stages_do_not_use_are_skipped() {
        let o = parse_text(
            "# c\no a\ng b\ns 1\nvt 0 0\nvn 0 0 1\nv 0 0 0 1\nv 1 0 0 0.5 0.5 0.5\nv 0 1 0\nl 1 2\np 1\nf 1 2 3 # tail\n",
            "",
        )
        .unwrap();
        assert_eq!(o.positions.len(), 3);
        assert_eq!(o.triangles.len(), 1);
    }
}
