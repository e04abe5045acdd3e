//! Colour, emission, metal-roughness and alpha textures: decoded once at
//! load (PNG or JPEG), kept as 8-bit codes, and read at hit points with
//! bilinear filtering in linear light.
//!
//! Why textures matter to probe placement at all: the light a probe stores
//! is what the surfaces around it reflect, and their albedo decides how
//! much of it bounces (McGuire et al. 2017 §3 bakes radiance "from the
//! scene's materials"; Wang et al. 2019 §5.1 compares against path-traced
//! references of the textured scene). A stone floor whose texture averages
//! 0.3 but whose factor is 1.0 bounces three times the light it should.
//!
//! Conventions:
//! * **Texture coordinates** are glTF's (Khronos glTF 2.0 §3.9.4): `(0, 0)`
//!   is the image's top-left corner, `v` grows downwards. OBJ's `vt` have
//!   `v` growing upwards; its reader flips them (`v → 1 − v`) on the way in.
//! * **Colour**: the texels are sRGB-encoded (glTF §3.9.2 says so of base
//!   colour and emissive textures; MTL files do not say, and every tool
//!   writes sRGB images), decoded to linear by the sRGB curve (IEC
//!   61966-2-1) *before* filtering, so a black-and-white checker filters to
//!   the mean of its linear values, not to sRGB grey.
//! * **Data**: a metallic-roughness texture holds linear values (glTF
//!   §3.9.2: blue metallic, green roughness), read by
//!   [`TextureMap::sample_data`] without the sRGB curve.
//! * **Alpha** is linear too (glTF §3.9.2), kept only when the image has
//!   a channel that is not opaque everywhere, and read by
//!   [`TextureMap::sample_mask`] for cut-outs ([`super::Cutout`]).
//! * **Filtering**: bilinear between the four texels around the point,
//!   with texel centres at half-integers, wrapped per axis ([`Wrap`]). No
//!   mip-mapping: the bake and the references shoot single rays, whose
//!   footprint is a point, and their sample counts average the texture.
//!
//! Limits: a side is at most [`MAX_SIDE`] texels, and the decoded textures
//! of one scene take at most a quarter of the memory budget
//! ([`crate::limits`]): headers are read first and every size is checked
//! before anything is decoded. A texture that is missing, unreadable, not
//! a PNG or JPEG, or over a limit is not an error: the scene loads without
//! it (its factor alone is used), with one warning per file.

use glam::{Vec2, Vec3};
use rayon::prelude::*;
use std::path::{Path, PathBuf};
use std::sync::{Arc, LazyLock};

/// Longest side of a texture read: 16384 texels, the most any current GPU
/// samples (and 768 MiB decoded at that size, square).
pub const MAX_SIDE: u32 = 16384;

/// Files named in the warnings of one kind; the rest are counted.
const LISTED: usize = 5;

/// How a texture coordinate outside [0, 1] wraps (glTF §5.26 samplers'
/// `wrapS`/`wrapT`; OBJ's `-clamp on` is [`Wrap::Clamp`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Wrap {
    /// Tiles the image (glTF's default, `REPEAT`).
    #[default]
    Repeat,
    /// Repeats the edge texels (`CLAMP_TO_EDGE`).
    Clamp,
    /// Tiles the image mirrored every other time (`MIRRORED_REPEAT`).
    Mirror,
}

impl Wrap {
    /// Texel index `i` of a side of `n` texels, wrapped.
    fn index(self, i: i64, n: u32) -> usize {
        let n = n as i64;
        (match self {
            Wrap::Repeat => i.rem_euclid(n),
            Wrap::Clamp => i.clamp(0, n - 1),
            Wrap::Mirror => {
                let m = i.rem_euclid(2 * n);
                if m < n {
                    m
                } else {
                    2 * n - 1 - m
                }
            }
        }) as usize
    }
}

/// A material's use of a texture: which one, the affine map from the
/// mesh's texture coordinates to the image's (glTF's
/// `KHR_texture_transform`; OBJ's `-o` and `-s` options), and how it wraps.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TextureMap {
    /// Index into [`super::Scene::textures`].
    pub texture: u32,
    /// `u' = t[0]·u + t[1]·v + t[2]`, `v' = t[3]·u + t[4]·v + t[5]`.
    pub transform: [f32; 6],
    /// Wrapping along `u` and along `v`.
    pub wrap: [Wrap; 2],
}

impl TextureMap {
    /// The identity transform.
    pub const IDENTITY: [f32; 6] = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0];

    /// Texture `texture`, untransformed, repeating.
    pub fn new(texture: u32) -> TextureMap {
        TextureMap {
            texture,
            transform: Self::IDENTITY,
            wrap: [Wrap::Repeat; 2],
        }
    }

    /// The image coordinates of mesh coordinates `uv`.
    pub fn apply(&self, uv: Vec2) -> Vec2 {
        let t = &self.transform;
        Vec2::new(
            t[0] * uv.x + t[1] * uv.y + t[2],
            t[3] * uv.x + t[4] * uv.y + t[5],
        )
    }

    /// The linear colour of `textures[self.texture]` at mesh coordinates `uv`.
    ///
    /// Contract: `self.texture` indexes `textures` (the scene's loaders
    /// guarantee it). Finite, each channel in [0, 1].
    pub fn sample(&self, textures: &[Arc<Texture>], uv: Vec2) -> Vec3 {
        textures[self.texture as usize].sample(self.apply(uv), self.wrap)
    }
}

/// The sRGB transfer function's inverse, per 8-bit code (IEC 61966-2-1).
static LINEAR: LazyLock<[f32; 256]> = LazyLock::new(|| {
    std::array::from_fn(|i| {
        let c = i as f64 / 255.0;
        (if c <= 0.04045 {
            c / 12.92
        } else {
            ((c + 0.055) / 1.055).powf(2.4)
        }) as f32
    })
});

/// The linear value of 8-bit sRGB code `c`.
pub fn srgb_to_linear(c: u8) -> f32 {
    LINEAR[c as usize]
}

/// A decoded image: 8-bit sRGB texels, rows from the top.
#[derive(Clone)]
pub struct Texture {
    /// Where it came from (a file path, or a glTF image), for messages.
    pub name: String,
    /// Width in texels.
    pub width: u32,
    /// Height in texels.
    pub height: u32,
    texels: Vec<[u8; 3]>,
    /// Per texel, its alpha; empty where the image has none (or it is
    /// 255 everywhere).
    alpha: Vec<u8>,
    mean: Vec3,
}

impl std::fmt::Debug for Texture {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "Texture({}, {}×{})", self.name, self.width, self.height)
    }
}

impl PartialEq for Texture {
    fn eq(&self, other: &Texture) -> bool {
        (self.width, self.height, &self.texels, &self.alpha)
            == (other.width, other.height, &other.texels, &other.alpha)
    }
}

impl Texture {
    /// A texture of `width × height` sRGB texels, rows from the top.
    ///
    /// Contract: `texels.len() == width × height`, both sides in
    /// 1..=[`MAX_SIDE`]; panics otherwise (callers are the decoders, which
    /// check, and tests).
    pub fn from_srgb8(name: String, width: u32, height: u32, texels: Vec<[u8; 3]>) -> Texture {
        assert!((1..=MAX_SIDE).contains(&width) && (1..=MAX_SIDE).contains(&height));
        assert_eq!(texels.len(), width as usize * height as usize);
        let sum = texels
            .par_chunks(1 << 16)
            .map(|c| {
                c.iter().fold([0.0f64; 3], |mut s, t| {
                    for k in 0..3 {
                        s[k] += srgb_to_linear(t[k]) as f64;
                    }
                    s
                })
            })
            .collect::<Vec<_>>()
            .into_iter()
            .fold([0.0f64; 3], |a, b| [a[0] + b[0], a[1] + b[1], a[2] + b[2]]);
        let n = texels.len() as f64;
        Texture {
            name,
            width,
            height,
            mean: Vec3::new((sum[0] / n) as f32, (sum[1] / n) as f32, (sum[2] / n) as f32),
            texels,
            alpha: Vec::new(),
        }
    }

    /// This texture with `alpha` (one value per texel, rows from the top)
    /// as its alpha channel; one that is 255 everywhere is not kept.
    ///
    /// Contract: `alpha.len() == width × height`; panics otherwise.
    pub fn with_alpha(mut self, alpha: Vec<u8>) -> Texture {
        assert_eq!(alpha.len(), self.texels.len());
        self.alpha = if alpha.iter().all(|&a| a == 255) { Vec::new() } else { alpha };
        self
    }

    /// Whether the image has an alpha channel that is not opaque everywhere.
    pub fn has_alpha(&self) -> bool {
        !self.alpha.is_empty()
    }

    /// The mean of each channel's raw value (`code / 255`, no sRGB curve)
    /// over the whole image: a metallic-roughness texture's mean metal and
    /// roughness, for what reads a material without a point.
    pub fn mean_data(&self) -> Vec3 {
        let sum = self
            .texels
            .par_chunks(1 << 16)
            .map(|c| c.iter().fold([0u64; 3], |s, t| [0, 1, 2].map(|k| s[k] + t[k] as u64)))
            .collect::<Vec<_>>()
            .into_iter()
            .fold([0u64; 3], |a, b| [a[0] + b[0], a[1] + b[1], a[2] + b[2]]);
        let n = self.texels.len() as f64 * 255.0;
        Vec3::from_array(sum.map(|s| (s as f64 / n) as f32))
    }

    /// The texels, 8-bit sRGB, rows from the top.
    pub fn texels(&self) -> &[[u8; 3]] {
        &self.texels
    }

    /// The mean linear colour over the whole image: what the light sampler
    /// weighs a textured emitter by, and the colour previews show.
    pub fn mean(&self) -> Vec3 {
        self.mean
    }

    /// Linear colour of texel `(x, y)`, decoded by `lut` ([`LINEAR`],
    /// dereferenced once per sample rather than once per channel).
    #[inline(always)]
    fn texel(&self, lut: &[f32; 256], x: usize, y: usize) -> Vec3 {
        let t = self.texels[y * self.width as usize + x];
        Vec3::new(lut[t[0] as usize], lut[t[1] as usize], lut[t[2] as usize])
    }

    /// The bilinearly filtered linear colour at image coordinates `uv`
    /// (module docs), wrapped by `wrap` per axis. Non-finite coordinates
    /// read as 0.
    ///
    /// Contract: finite, each channel in [0, 1]; allocation-free.
    #[inline]
    pub fn sample(&self, uv: Vec2, wrap: [Wrap; 2]) -> Vec3 {
        let lut: &[f32; 256] = &LINEAR;
        self.filter(uv, wrap, |x, y| self.texel(lut, x, y)).min(Vec3::ONE)
    }

    /// [`Texture::sample`] of the raw values (`code / 255`), without the
    /// sRGB curve: a data texture's (metallic-roughness).
    #[inline]
    pub fn sample_data(&self, uv: Vec2, wrap: [Wrap; 2]) -> Vec3 {
        self.filter(uv, wrap, |x, y| {
            let t = self.texels[y * self.width as usize + x];
            Vec3::new(t[0] as f32, t[1] as f32, t[2] as f32) * (1.0 / 255.0)
        })
        .min(Vec3::ONE)
    }

    /// The filtered alpha at `uv` (as [`Texture::sample`]), in [0, 1]:
    /// the alpha channel where the image has one; else 1, or with
    /// `grey` the first channel's raw value (an MTL `map_d` given as a
    /// grey image).
    #[inline]
    pub fn sample_alpha(&self, uv: Vec2, wrap: [Wrap; 2], grey: bool) -> f32 {
        let w = self.width as usize;
        let v = if self.has_alpha() {
            self.filter(uv, wrap, |x, y| Vec3::splat(self.alpha[y * w + x] as f32))
        } else if grey {
            self.filter(uv, wrap, |x, y| Vec3::splat(self.texels[y * w + x][0] as f32))
        } else {
            return 1.0;
        };
        (v.x * (1.0 / 255.0)).clamp(0.0, 1.0)
    }

    /// The bilinear filter of `texel` at image coordinates `uv`, wrapped
    /// by `wrap`; non-finite coordinates read as 0. At least 0 per channel
    /// (the callers clamp the top of their own range).
    #[inline(always)]
    fn filter(&self, uv: Vec2, wrap: [Wrap; 2], texel: impl Fn(usize, usize) -> Vec3) -> Vec3 {
        let finite = |v: f32| if v.is_finite() { v.clamp(-1e9, 1e9) } else { 0.0 };
        let x = finite(uv.x) * self.width as f32 - 0.5;
        let y = finite(uv.y) * self.height as f32 - 0.5;
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let (x0, y0) = (x0 as i64, y0 as i64);
        let xs = [wrap[0].index(x0, self.width), wrap[0].index(x0 + 1, self.width)];
        let ys = [wrap[1].index(y0, self.height), wrap[1].index(y0 + 1, self.height)];
        let top = texel(xs[0], ys[0]) * (1.0 - fx) + texel(xs[1], ys[0]) * fx;
        let bottom = texel(xs[0], ys[1]) * (1.0 - fx) + texel(xs[1], ys[1]) * fx;
        let v = top * (1.0 - fy) + bottom * fy;
        v.max(Vec3::ZERO)
    }

    /// Decoded bytes a `width × height` texture takes at most (three
    /// colour channels and an alpha).
    pub fn bytes(width: u32, height: u32) -> u64 {
        width as u64 * height as u64 * 4
    }
}

/// The image formats read.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Format {
    Png,
    Jpeg,
}

/// The format of `bytes` by its signature (not by its name or MIME type,
/// which files get wrong).
fn format_of(bytes: &[u8]) -> Option<Format> {
    if bytes.starts_with(b"\x89PNG\r\n\x1a\n") {
        Some(Format::Png)
    } else if bytes.starts_with(&[0xFF, 0xD8, 0xFF]) {
        Some(Format::Jpeg)
    } else {
        None
    }
}

/// The format and size of the image in `bytes`, from its header alone.
fn header(bytes: &[u8]) -> Result<(Format, u32, u32), String> {
    let format = format_of(bytes).ok_or("not a PNG or JPEG image")?;
    let (w, h) = match format {
        Format::Png => {
            let reader = png::Decoder::new(std::io::Cursor::new(bytes))
                .read_info()
                .map_err(|e| format!("a broken PNG ({e})"))?;
            let info = reader.info();
            (info.width, info.height)
        }
        Format::Jpeg => {
            let mut d = zune_jpeg::JpegDecoder::new(zune_jpeg::zune_core::bytestream::ZCursor::new(bytes));
            d.decode_headers().map_err(|e| format!("a broken JPEG ({e:?})"))?;
            let (w, h) = d.dimensions().ok_or("a JPEG without a size")?;
            (w as u32, h as u32)
        }
    };
    if w == 0 || h == 0 || w > MAX_SIDE || h > MAX_SIDE {
        return Err(format!("{w}×{h} texels, over the limit of {MAX_SIDE} a side"));
    }
    Ok((format, w, h))
}

/// Decodes the PNG or JPEG in `bytes` (named `name`): 8-bit sRGB texels
/// (16-bit PNGs rounded to 8 bits, grey expanded to RGB, palettes
/// expanded), and the alpha channel where the PNG has one (or a
/// transparent colour) that is not opaque everywhere.
///
/// Errors: a message without the name (the caller adds it): not a PNG or
/// JPEG, broken, or over [`MAX_SIDE`].
pub fn decode(bytes: &[u8], name: String) -> Result<Texture, String> {
    let (format, width, height) = header(bytes)?;
    let n = width as usize * height as usize;
    let mut alpha: Vec<u8> = Vec::new();
    let texels: Vec<[u8; 3]> = match format {
        Format::Png => {
            // The decoder's own limit (64 MiB by default) would refuse a
            // 4K RGBA texture; the size is already checked against ours.
            let limits = png::Limits {
                bytes: n.saturating_mul(8).saturating_add(1 << 20),
            };
            let mut d = png::Decoder::new_with_limits(std::io::Cursor::new(bytes), limits);
            d.set_transformations(png::Transformations::normalize_to_color8());
            let mut reader = d.read_info().map_err(|e| format!("a broken PNG ({e})"))?;
            let size = reader.output_buffer_size().ok_or("a PNG too large to decode")?;
            let mut buf = vec![0u8; size];
            let frame = reader
                .next_frame(&mut buf)
                .map_err(|e| format!("a broken PNG ({e})"))?;
            let channels = frame.color_type.samples();
            let line = frame.line_size;
            let mut out = Vec::with_capacity(n);
            let has_alpha = channels == 2 || channels == 4;
            if has_alpha {
                alpha.reserve_exact(n);
            }
            for y in 0..height as usize {
                let row = &buf[y * line..];
                for x in 0..width as usize {
                    let p = &row[x * channels..(x + 1) * channels];
                    out.push(match channels {
                        1 | 2 => [p[0]; 3],
                        _ => [p[0], p[1], p[2]],
                    });
                    if has_alpha {
                        alpha.push(p[channels - 1]);
                    }
                }
            }
            out
        }
        Format::Jpeg => {
            use zune_jpeg::zune_core::{colorspace::ColorSpace, options::DecoderOptions};
            let options = DecoderOptions::default()
                .jpeg_set_out_colorspace(ColorSpace::RGB)
                .set_max_width(MAX_SIDE as usize)
                .set_max_height(MAX_SIDE as usize);
            let mut d = zune_jpeg::JpegDecoder::new_with_options(
                zune_jpeg::zune_core::bytestream::ZCursor::new(bytes),
                options,
            );
            let rgb = d.decode().map_err(|e| format!("a broken JPEG ({e:?})"))?;
            if rgb.len() != 3 * n {
                return Err(format!("a JPEG that decodes to {} bytes, not {}", rgb.len(), 3 * n));
            }
            rgb.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect()
        }
    };
    let texture = Texture::from_srgb8(name, width, height, texels);
    Ok(if alpha.is_empty() { texture } else { texture.with_alpha(alpha) })
}

/// Where the image file an MTL names is: `file` itself when it exists,
/// else the one file in its folder whose name differs only in letter case
/// (the first by name, should several): OBJ files made on Windows or
/// macOS spell names as their file systems ignore case (Dabrovic Sponza's
/// MTL names `SP_LUK.JPG` for `sp_luk.JPG`). The second value is true when
/// the spelling differs, for the warning that says which file was used.
/// `None`: no such file.
pub fn locate(file: &Path) -> Option<(PathBuf, bool)> {
    if file.is_file() {
        return Some((file.to_path_buf(), false));
    }
    let name = file.file_name()?.to_str()?;
    let dir = match file.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let mut found: Vec<PathBuf> = std::fs::read_dir(dir)
        .ok()?
        .filter_map(|e| e.ok())
        .filter(|e| {
            e.file_name()
                .to_str()
                .is_some_and(|n| n.to_lowercase() == name.to_lowercase())
        })
        .map(|e| file.with_file_name(e.file_name()))
        .filter(|p| p.is_file())
        .collect();
    found.sort();
    found.into_iter().next().map(|p| (p, true))
}

/// Where an MTL's texture map was found ([`locate_map`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Found {
    /// Where the MTL names it (relative to the MTL's folder).
    AsNamed,
    /// There, in another letter case.
    Respelt,
    /// Relative to the OBJ's folder (the MTL is elsewhere).
    BesideObj,
    /// Its file name alone, in the MTL's folder.
    InMtlFolder,
}

/// Where the image an MTL's `map_*` statement names is: `file` (the name
/// as written, `written`, joined to the MTL's folder) as [`locate`] finds
/// it; else `written` relative to the OBJ's folder `obj_dir` (exporters
/// that write paths relative to the OBJ while the MTL sits elsewhere);
/// else its file name alone (after the last `/` or `\`) in the MTL's
/// folder (a path from the author's machine, the image shipped beside
/// the MTL). `None`: none of
/// these.
pub fn locate_map(file: &Path, written: &Path, obj_dir: &Path) -> Option<(PathBuf, Found)> {
    if let Some((at, respelt)) = locate(file) {
        return Some((at, if respelt { Found::Respelt } else { Found::AsNamed }));
    }
    if written.is_relative() {
        let beside = obj_dir.join(written);
        if beside != file {
            if let Some((at, _)) = locate(&beside) {
                return Some((at, Found::BesideObj));
            }
        }
    }
    // The last component, whichever separator the author's system used.
    let name = written.to_str()?.rsplit(['/', '\\']).next().filter(|n| !n.is_empty())?;
    let flat = file.with_file_name(name);
    if flat != file {
        if let Some((at, _)) = locate(&flat) {
            return Some((at, Found::InMtlFolder));
        }
    }
    None
}

/// Loads the images `count` names, for one scene: `fetch(i)` gives image
/// `i`'s bytes and its name for messages (or why it could not be read).
/// Headers are read first; images are then taken in order while their
/// decoded sizes fit the scene's texture budget (a quarter of the memory
/// budget), and decoded in parallel.
///
/// Contract: the textures loaded, in image order, and for each image its
/// index among them (`None`: not loaded, what a material map then lacks);
/// the warnings name each image not loaded (the first [`LISTED`] of each
/// kind, then a count). Deterministic: which images fit does not depend on
/// the thread count. Never an error: a scene loads without its textures.
pub fn load_images(
    count: usize,
    mut fetch: impl FnMut(usize, u64) -> (String, Result<Vec<u8>, String>),
) -> LoadedImages {
    let budget = crate::limits::memory_budget() / 4;
    let mut used = 0u64;
    // The files' bytes, held until they are decoded, count against the
    // same budget: `fetch` reads no file past what is left of it.
    let mut read = 0u64;
    let mut failed: Vec<String> = Vec::new();
    let mut over: Vec<String> = Vec::new();
    let mut pending: Vec<(usize, String, Vec<u8>)> = Vec::new();
    let mut status: Vec<Result<[u32; 2], String>> = vec![Err(String::new()); count];
    for i in 0..count {
        let (name, bytes) = fetch(i, budget.saturating_sub(read));
        let bytes = bytes.map_err(|why| one_line(&why));
        if let Ok(b) = &bytes {
            read += b.len() as u64;
        }
        let bytes = match bytes.and_then(|b| header(&b).map(|h| (b, h))) {
            Ok((b, (_, w, h))) => {
                let need = Texture::bytes(w, h);
                if used + need > budget {
                    status[i] = Err(format!(
                        "over the texture budget ({}, a quarter of the memory budget)",
                        crate::input::bytes_text(budget)
                    ));
                    over.push(name);
                    continue;
                }
                used += need;
                b
            }
            Err(why) => {
                // A header's error too: zune-jpeg's for tables cut short
                // ends in a line break.
                let why = one_line(&why);
                status[i] = Err(why.clone());
                failed.push(format!("{name}: {why}"));
                continue;
            }
        };
        pending.push((i, name, bytes));
    }
    let decoded: Vec<(usize, String, Result<Texture, String>)> = pending
        .into_par_iter()
        .map(|(i, name, bytes)| {
            let t = decode(&bytes, name.clone());
            (i, name, t)
        })
        .collect();
    let mut textures = Vec::new();
    let mut index: Vec<Option<u32>> = vec![None; count];
    for (i, name, t) in decoded {
        match t {
            Ok(t) => {
                index[i] = Some(textures.len() as u32);
                status[i] = Ok([t.width, t.height]);
                textures.push(Arc::new(t));
            }
            Err(why) => {
                let why = one_line(&why);
                status[i] = Err(why.clone());
                failed.push(format!("{name}: {why}"));
            }
        }
    }
    let mut warnings: Vec<String> = failed
        .iter()
        .take(LISTED)
        .map(|f| format!("{f}; the texture is not used (its material's factor alone is)"))
        .collect();
    if failed.len() > LISTED {
        warnings.push(format!(
            "and {} more texture(s) not read; their materials' factors alone are used",
            failed.len() - LISTED
        ));
    }
    if !over.is_empty() {
        let more = match over.len().saturating_sub(LISTED) {
            0 => String::new(),
            n => format!(" and {n} more"),
        };
        warnings.push(format!(
            "textures {}{more} not read: the scene's textures would take more than {} (a quarter of this run's memory budget); their materials' factors alone are used",
            over.iter().take(LISTED).map(|n| format!("`{n}`")).collect::<Vec<_>>().join(", "),
            crate::input::bytes_text(budget)
        ));
    }
    LoadedImages {
        textures,
        index,
        status,
        warnings,
    }
}

/// `text` on one line: a decoder's message (zune-jpeg's truncated-data
/// error holds a line break) made one warning line, its runs of white
/// space one space.
pub fn one_line(text: &str) -> String {
    text.split_whitespace().collect::<Vec<_>>().join(" ")
}

/// What [`load_images`] gives.
pub struct LoadedImages {
    /// The textures decoded, in image order.
    pub textures: Vec<Arc<Texture>>,
    /// Per image, its index in `textures` (`None`: not loaded).
    pub index: Vec<Option<u32>>,
    /// Per image, its size in texels, or why it was not read.
    pub status: Vec<Result<[u32; 2], String>>,
    /// One per image not loaded (the first few of each kind, then a count).
    pub warnings: Vec<String>,
}

/// One image a scene's materials name, as `report.json` lists it.
#[derive(Debug, Clone, PartialEq)]
pub struct TextureFile {
    /// The file (or the glTF image) as messages name it.
    pub name: String,
    /// What the materials use it for (`colour`, `emission`,
    /// `metal-roughness`, `alpha`), each once, in that order.
    pub uses: Vec<&'static str>,
    /// Its size in texels, or why it was not read.
    pub status: Result<[u32; 2], String>,
}

impl TextureFile {
    /// Adds `what` to its uses, keeping the order of [`USES`].
    pub fn add_use(&mut self, what: &'static str) {
        if !self.uses.contains(&what) {
            self.uses.push(what);
            self.uses.sort_by_key(|u| USES.iter().position(|k| k == u));
        }
    }
}

/// The uses of a texture, in the order lists give them.
pub const USES: [&str; 4] = ["colour", "emission", "metal-roughness", "alpha"];

/// Barycentric coordinates `(b1, b2)` of point `p` in triangle `t`
/// (`p ≈ t0 + b1 (t1 − t0) + b2 (t2 − t0)`), by the projection onto the
/// triangle's plane (Ericson, *Real-Time Collision Detection*, §3.4).
/// Zero for a degenerate triangle.
pub fn barycentric(t: &[Vec3; 3], p: Vec3) -> (f32, f32) {
    let (e1, e2, d) = (t[1] - t[0], t[2] - t[0], p - t[0]);
    let (d11, d12, d22) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
    let (dp1, dp2) = (d.dot(e1), d.dot(e2));
    let den = d11 * d22 - d12 * d12;
    if den.abs() <= f32::MIN_POSITIVE || !den.is_finite() {
        return (0.0, 0.0);
    }
    ((d22 * dp1 - d12 * dp2) / den, (d11 * dp2 - d12 * dp1) / den)
}

/// The texture coordinates `uv` interpolated at barycentric `(b1, b2)`.
pub fn interpolate(uv: &[Vec2; 3], (b1, b2): (f32, f32)) -> Vec2 {
    uv[0] + (uv[1] - uv[0]) * b1 + (uv[2] - uv[0]) * b2
}

#[cfg(test)]
mod tests {
    use super::*;

    fn checker() -> Texture {
        // 2×2: white, black / black, white.
        Texture::from_srgb8(
            "checker".into(),
            2,
            2,
            vec![[255; 3], [0; 3], [0; 3], [255; 3]],
        )
    }

    #[test]
    fn a_file_is_found_as_named_or_in_another_letter_case() {
        let dir = tempfile::tempdir().unwrap();
        let at = |n: &str| dir.path().join(n);
        std::fs::write(at("exact.png"), b"x").unwrap();
        std::fs::write(at("sp_luk.JPG"), b"x").unwrap();
        std::fs::write(at("Twice.png"), b"x").unwrap();
        std::fs::write(at("twice.PNG"), b"x").unwrap();
        std::fs::create_dir(at("folder.png")).unwrap();
        assert_eq!(locate(&at("exact.png")), Some((at("exact.png"), false)));
        assert_eq!(locate(&at("SP_LUK.JPG")), Some((at("sp_luk.JPG"), true)));
        // Several spellings: the first by name, whatever the directory's order.
        assert_eq!(locate(&at("TWICE.png")), Some((at("Twice.png"), true)));
        // Folders and absent files are not images.
        assert_eq!(locate(&at("FOLDER.png")), None);
        assert_eq!(locate(&at("gone.png")), None);
        assert_eq!(locate(&dir.path().join("no_dir").join("a.png")), None);
    }

    #[test]
    fn srgb_decoding_matches_the_standard_curve() {
        assert_eq!(srgb_to_linear(0), 0.0);
        assert_eq!(srgb_to_linear(255), 1.0);
        // sRGB 0.5 is linear 0.214 (IEC 61966-2-1).
        assert!((srgb_to_linear(128) - 0.2158605).abs() < 1e-6);
        assert!((srgb_to_linear(10) - 10.0 / 255.0 / 12.92).abs() < 1e-7);
    }

    #[test]
    fn texel_centres_read_exactly_and_midpoints_average_in_linear_light() {
        let t = checker();
        assert_eq!(t.sample(Vec2::new(0.25, 0.25), [Wrap::Repeat; 2]), Vec3::ONE);
        assert_eq!(t.sample(Vec2::new(0.75, 0.25), [Wrap::Repeat; 2]), Vec3::ZERO);
        // Half way between a white and a black texel: linear 0.5, not sRGB grey.
        let mid = t.sample(Vec2::new(0.5, 0.25), [Wrap::Repeat; 2]);
        assert!((mid - Vec3::splat(0.5)).abs().max_element() < 1e-6, "{mid}");
        assert_eq!(t.mean(), Vec3::splat(0.5));
    }

    #[test]
    fn wrap_modes_follow_the_gltf_sampler() {
        let ramp = Texture::from_srgb8("ramp".into(), 4, 1, vec![[0; 3], [85; 3], [170; 3], [255; 3]]);
        let at = |u: f32, w: Wrap| ramp.sample(Vec2::new(u, 0.5), [w, Wrap::Clamp]).x;
        let texel = |i: u8| srgb_to_linear(i);
        // Texel centres of the next tile.
        assert_eq!(at(1.125, Wrap::Repeat), texel(0));
        assert_eq!(at(1.125, Wrap::Clamp), texel(255));
        assert_eq!(at(1.125, Wrap::Mirror), texel(255));
        assert_eq!(at(1.375, Wrap::Mirror), texel(170));
        assert_eq!(at(-0.125, Wrap::Mirror), texel(0));
        assert_eq!(at(-0.125, Wrap::Repeat), texel(255));
        assert_eq!(at(f32::NAN, Wrap::Repeat), at(0.0, Wrap::Repeat));
        assert!(at(1e30, Wrap::Repeat).is_finite());
    }

    #[test]
    fn texture_transforms_offset_rotate_and_scale() {
        let m = TextureMap {
            texture: 0,
            transform: [2.0, 0.0, 0.5, 0.0, 3.0, -1.0],
            wrap: [Wrap::Repeat; 2],
        };
        assert_eq!(m.apply(Vec2::new(1.0, 1.0)), Vec2::new(2.5, 2.0));
    }

    #[test]
    fn png_and_jpeg_decode_and_bad_images_are_refused_in_words() {
        let mut png_bytes = Vec::new();
        {
            let mut e = png::Encoder::new(&mut png_bytes, 2, 1);
            e.set_color(png::ColorType::Grayscale);
            e.set_depth(png::BitDepth::Sixteen);
            let mut w = e.write_header().unwrap();
            w.write_image_data(&[0xFF, 0xFF, 0x00, 0x00]).unwrap();
        }
        let t = decode(&png_bytes, "a.png".into()).unwrap();
        assert_eq!((t.width, t.height), (2, 1));
        assert_eq!(t.sample(Vec2::new(0.25, 0.5), [Wrap::Clamp; 2]), Vec3::ONE);
        assert!(decode(b"GIF89a", "a.gif".into()).unwrap_err().contains("not a PNG or JPEG"));
        assert!(decode(&png_bytes[..20], "cut.png".into()).unwrap_err().contains("broken PNG"));
        assert!(decode(&[0xFF, 0xD8, 0xFF, 0xE0, 0], "cut.jpg".into())
            .unwrap_err()
            .contains("broken JPEG"));
        // A header that claims 100000 × 100000 texels is refused before
        // anything is allocated for them.
        let mut huge = png_bytes.clone();
        huge[16..20].copy_from_slice(&100_000u32.to_be_bytes());
        huge[20..24].copy_from_slice(&100_000u32.to_be_bytes());
        let crc = crc32fast::hash(&huge[12..29]);
        huge[29..33].copy_from_slice(&crc.to_be_bytes());
        assert!(decode(&huge, "huge.png".into()).unwrap_err().contains("over the limit"), "{:?}", decode(&huge, "huge.png".into()));
    }

    #[test]
    fn a_4k_rgba_png_decodes_past_the_png_crates_default_limit() {
        let (w, h) = (4096u32, 4097u32);
        let mut bytes = Vec::new();
        {
            let mut e = png::Encoder::new(&mut bytes, w, h);
            e.set_color(png::ColorType::Rgba);
            e.set_compression(png::Compression::Fast);
            let mut wr = e.write_header().unwrap();
            wr.write_image_data(&vec![200u8; (w * h * 4) as usize]).unwrap();
        }
        let t = decode(&bytes, "4k.png".into()).unwrap();
        assert_eq!((t.width, t.height), (w, h));
        assert_eq!(t.texels()[0], [200; 3]);
    }

    #[test]
    fn barycentrics_interpolate_the_corners() {
        let t = [Vec3::ZERO, Vec3::X, Vec3::Y];
        let uv = [Vec2::new(0.0, 0.0), Vec2::new(1.0, 0.0), Vec2::new(0.0, 2.0)];
        let p = Vec3::new(0.25, 0.5, 0.0);
        let b = barycentric(&t, p);
        assert_eq!(b, (0.25, 0.5));
        assert_eq!(interpolate(&uv, b), Vec2::new(0.25, 1.0));
        assert_eq!(barycentric(&[Vec3::ZERO; 3], p), (0.0, 0.0));
    }

    #[test]
    fn missing_and_broken_images_warn_once_each_and_load_nothing() {
        let LoadedImages { textures, index, warnings, .. } = load_images(3, |i, _| match i {
            0 => ("gone.png".into(), Err("not found".into())),
            1 => ("junk.png".into(), Ok(b"junk".to_vec())),
            _ => ("ok.png".into(), Err("not found".into())),
        });
        assert!(textures.is_empty() && index.iter().all(Option::is_none));
        assert_eq!(warnings.len(), 3, "{warnings:?}");
        assert!(warnings[0].starts_with("gone.png: not found"), "{warnings:?}");
    }
}
