//! PNG: the previews, atlas panels and tone-mapped renders as 8-bit RGB
//! files, and the run's provenance in their `tEXt` chunks.

use crate::error::{Error, Result};
use crate::raster::RgbImage;

/// PNG bytes of `image`, which will be written as `name`.
///
/// An 8-bit RGB PNG, encoded by the `png` crate with fast compression and
/// adaptive filtering: the settings of the `image` crate's PNG encoder,
/// which wrote these files before, so the bytes are the same.
pub fn encode_png(image: &RgbImage, name: &str) -> Result<Vec<u8>> {
    let fail = |e: png::EncodingError| Error::Internal(format!("encoding {name}: {e}"));
    let mut bytes = Vec::new();
    let mut encoder = png::Encoder::new(&mut bytes, image.width(), image.height());
    encoder.set_color(png::ColorType::Rgb);
    encoder.set_depth(png::BitDepth::Eight);
    // In this order: `set_compression` also sets a filter.
    encoder.set_compression(png::Compression::Fast);
    encoder.set_filter(png::Filter::Adaptive);
    let mut writer = encoder.write_header().map_err(fail)?;
    writer.write_image_data(image.as_raw()).map_err(fail)?;
    writer.finish().map_err(fail)?;
    Ok(bytes)
}

/// `bytes` (a PNG) with a `tEXt` chunk per pair of `pairs` after its
/// header chunk, where PNG keeps a file's metadata (PNG spec §11.3.4.3):
/// the run's provenance ([`crate::provenance::Stamp::pairs`]), which image viewers
/// show. Keywords are 1–79 Latin-1 characters; ours are ASCII.
///
/// Contract: `bytes` starts with the signature and an `IHDR` chunk, as
/// [`encode_png`]'s output does; anything else is returned unchanged.
pub fn png_with_text<K: AsRef<str>, V: AsRef<str>>(bytes: Vec<u8>, pairs: &[(K, V)]) -> Vec<u8> {
    // Signature (8 bytes), then IHDR: length, type, 13 bytes, CRC.
    const AFTER_IHDR: usize = 8 + 4 + 4 + 13 + 4;
    if bytes.len() < AFTER_IHDR || &bytes[12..16] != b"IHDR" {
        return bytes;
    }
    let mut out = Vec::with_capacity(bytes.len() + 64 * pairs.len());
    out.extend_from_slice(&bytes[..AFTER_IHDR]);
    for (k, v) in pairs {
        let mut body = b"tEXt".to_vec();
        body.extend_from_slice(k.as_ref().as_bytes());
        body.push(0);
        body.extend_from_slice(v.as_ref().as_bytes());
        out.extend_from_slice(&((body.len() - 4) as u32).to_be_bytes());
        out.extend_from_slice(&body);
        out.extend_from_slice(&crc32fast::hash(&body).to_be_bytes());
    }
    out.extend_from_slice(&bytes[AFTER_IHDR..]);
    out
}
