//! Linear HDR images as OpenEXR files, and tone-mapped previews.
//!
//! Reference renders and probe maps hold radiance, which has no upper bound:
//! PNG would clip it, and error metrics (Wang et al. 2019 §5.1 compare images
//! by mean squared error) need the linear values. OpenEXR is the format every
//! image tool reads. The writer is the smallest valid file, written by hand
//! so the crate needs no EXR dependency: one part, scan lines, no
//! compression, 32-bit float `B`, `G`, `R` channels (the format requires the
//! channel list sorted by name), one scan line per block. Layout per the
//! OpenEXR file-layout specification: magic number, version field, header
//! attributes ended by a null byte, the table of block offsets, the blocks.
//! Write the bytes with [`super::write_atomic`].

/// The OpenEXR magic number, 20000630.
const MAGIC: u32 = 20_000_630;
/// File format version 2, single-part scan-line file, short names (no flags).
const VERSION: u32 = 2;
/// `PixelType::FLOAT` in a channel list.
const PIXEL_FLOAT: i32 = 2;

/// An uncompressed scan-line OpenEXR file of the `width × height` image
/// `pixels` (linear RGB, row-major, top row first), channels stored as 32-bit
/// floats, bit for bit (NaN and infinities included).
///
/// Contract: `width` and `height` at least 1 and at most `i32::MAX`, and
/// `pixels.len() == width·height`; anything else is a programming error and
/// panics.
pub fn encode_rgb(width: u32, height: u32, pixels: &[[f32; 3]]) -> Vec<u8> {
    assert!(
        width >= 1 && height >= 1 && width <= i32::MAX as u32 && height <= i32::MAX as u32,
        "EXR size {width}x{height} out of range"
    );
    assert_eq!(
        pixels.len() as u64,
        width as u64 * height as u64,
        "pixel count does not match {width}x{height}"
    );
    let (w, h) = (width as usize, height as usize);
    let row_bytes = w * 3 * 4;
    let mut out = Vec::with_capacity(512 + h * (8 + 8 + row_bytes));
    out.extend_from_slice(&MAGIC.to_le_bytes());
    out.extend_from_slice(&VERSION.to_le_bytes());

    let mut channels = Vec::new();
    for name in [b'B', b'G', b'R'] {
        channels.extend_from_slice(&[name, 0]);
        channels.extend_from_slice(&PIXEL_FLOAT.to_le_bytes());
        // pLinear, three reserved bytes, then x and y sampling.
        channels.extend_from_slice(&[0, 0, 0, 0]);
        channels.extend_from_slice(&1i32.to_le_bytes());
        channels.extend_from_slice(&1i32.to_le_bytes());
    }
    channels.push(0);
    let window: Vec<u8> = [0, 0, width as i32 - 1, height as i32 - 1]
        .iter()
        .flat_map(|v| v.to_le_bytes())
        .collect();
    attribute(&mut out, "channels", "chlist", &channels);
    attribute(&mut out, "compression", "compression", &[0]);
    attribute(&mut out, "dataWindow", "box2i", &window);
    attribute(&mut out, "displayWindow", "box2i", &window);
    attribute(&mut out, "lineOrder", "lineOrder", &[0]);
    attribute(&mut out, "pixelAspectRatio", "float", &1f32.to_le_bytes());
    attribute(&mut out, "screenWindowCenter", "v2f", &[0; 8]);
    attribute(&mut out, "screenWindowWidth", "float", &1f32.to_le_bytes());
    out.push(0);

    let block_bytes = 4 + 4 + row_bytes;
    let first_block = out.len() + 8 * h;
    for y in 0..h {
        out.extend_from_slice(&((first_block + y * block_bytes) as u64).to_le_bytes());
    }
    for (y, row) in pixels.chunks_exact(w).enumerate() {
        out.extend_from_slice(&(y as i32).to_le_bytes());
        out.extend_from_slice(&(row_bytes as i32).to_le_bytes());
        // Channels in the header's (alphabetical) order: B, G, R.
        for c in [2, 1, 0] {
            for p in row {
                out.extend_from_slice(&p[c].to_le_bytes());
            }
        }
    }
    out
}

/// Reads back a file [`encode_rgb`] wrote: `(width, height, pixels)`, bit
/// for bit. `--from DIR` reuses a reference image this way.
///
/// Contract: never panics; anything but an intact file of this writer (other
/// compression, channels or layout, a truncated or edited file) is an
/// `Err` with a one-line reason.
pub fn decode_rgb(bytes: &[u8]) -> Result<(u32, u32, Vec<[f32; 3]>), String> {
    if !bytes.starts_with(&[MAGIC.to_le_bytes(), VERSION.to_le_bytes()].concat()) {
        return Err("not a scan-line OpenEXR file of probeplace".into());
    }
    let (at, window) = header(bytes).ok_or("truncated header")?;
    let (w, h) = window.ok_or("no dataWindow")?;
    let strings = string_attributes(bytes);
    if !(1..=1 << 16).contains(&w) || !(1..=1 << 16).contains(&h) {
        return Err(format!("image size {w}×{h} out of range"));
    }
    let (w, h) = (w as usize, h as usize);
    let first_block = at + 1 + 8 * h;
    let row_bytes = 12 * w;
    if bytes.len() != first_block + h * (8 + row_bytes) {
        return Err("truncated or not written by probeplace".into());
    }
    let mut pixels = vec![[0f32; 3]; w * h];
    for (y, row) in pixels.chunks_exact_mut(w).enumerate() {
        let data = first_block + y * (8 + row_bytes) + 8;
        for (k, c) in [2, 1, 0].into_iter().enumerate() {
            for (x, p) in row.iter_mut().enumerate() {
                let i = data + 4 * (k * w + x);
                p[c] = f32::from_le_bytes(bytes[i..i + 4].try_into().expect("4 bytes"));
            }
        }
    }
    if with_attributes(encode_rgb(w as u32, h as u32, &pixels), &strings) != bytes {
        return Err("not laid out as probeplace writes it".into());
    }
    Ok((w as u32, h as u32, pixels))
}

/// `bytes` (a file [`encode_rgb`] wrote) with `pairs` added to its header
/// as `string` attributes, before the header's end: where OpenEXR keeps a
/// file's metadata, so any EXR tool shows them (the run's provenance,
/// [`crate::provenance::Stamp::pairs`]). The header grows, so every entry of
/// the block-offset table moves by as much.
///
/// Contract: `bytes` is [`encode_rgb`]'s output (with or without earlier
/// attributes); anything else is returned unchanged.
pub fn with_attributes<K: AsRef<str>, V: AsRef<str>>(bytes: Vec<u8>, pairs: &[(K, V)]) -> Vec<u8> {
    let Some((header_end, h)) = header_end(&bytes) else {
        return bytes;
    };
    let mut extra = Vec::new();
    for (k, v) in pairs {
        attribute(&mut extra, k.as_ref(), "string", v.as_ref().as_bytes());
    }
    let shift = extra.len() as u64;
    let mut out = Vec::with_capacity(bytes.len() + extra.len());
    out.extend_from_slice(&bytes[..header_end]);
    out.extend_from_slice(&extra);
    out.push(0);
    let table = header_end + 1;
    for y in 0..h {
        let at = table + 8 * y;
        let offset = u64::from_le_bytes(bytes[at..at + 8].try_into().expect("8 bytes"));
        out.extend_from_slice(&(offset + shift).to_le_bytes());
    }
    out.extend_from_slice(&bytes[table + 8 * h..]);
    out
}

/// The `string` attributes of an EXR header, as (name, value).
pub fn string_attributes(bytes: &[u8]) -> Vec<(String, String)> {
    let mut found = Vec::new();
    walk_header(bytes, |name, kind, value| {
        if kind == b"string" {
            found.push((
                String::from_utf8_lossy(name).into_owned(),
                String::from_utf8_lossy(value).into_owned(),
            ));
        }
    });
    found
}

/// The position of the null byte that ends the header, and the image's
/// width and height from its `dataWindow` (`None` without one); `None`
/// for a truncated or foreign header.
fn header(bytes: &[u8]) -> Option<(usize, Option<(i64, i64)>)> {
    let mut window = None;
    let end = walk_header(bytes, |name, _, value| {
        if name == b"dataWindow" && value.len() == 16 {
            let v = |i: usize| i32::from_le_bytes(value[i..i + 4].try_into().expect("4 bytes"));
            window = Some((
                v(8) as i64 - v(0) as i64 + 1,
                v(12) as i64 - v(4) as i64 + 1,
            ));
        }
    })?;
    Some((end, window))
}

/// The position of the null byte that ends the header, and the image's
/// height (the block-offset table's length), of a file of this writer.
fn header_end(bytes: &[u8]) -> Option<(usize, usize)> {
    let (end, (_, h)) = match header(bytes)? {
        (end, Some(window)) => (end, window),
        _ => return None,
    };
    let h = usize::try_from(h).ok()?;
    (bytes.len() >= end + 1 + 8 * h).then_some((end, h))
}

/// Calls `each(name, type, value)` for every header attribute; the
/// position of the header's closing null byte, `None` for a truncated or
/// foreign header.
fn walk_header(bytes: &[u8], mut each: impl FnMut(&[u8], &[u8], &[u8])) -> Option<usize> {
    let word = |at: usize| -> Option<u32> {
        Some(u32::from_le_bytes(bytes.get(at..at + 4)?.try_into().ok()?))
    };
    if word(0) != Some(MAGIC) || word(4) != Some(VERSION) {
        return None;
    }
    let mut at = 8;
    loop {
        let name_end = bytes.get(at..)?.iter().position(|&b| b == 0)?;
        if name_end == 0 {
            return Some(at);
        }
        let kind_start = at + name_end + 1;
        let kind_end = bytes.get(kind_start..)?.iter().position(|&b| b == 0)?;
        let size_at = kind_start + kind_end + 1;
        let size = word(size_at)? as usize;
        let value = bytes.get(size_at + 4..size_at.checked_add(4 + size)?)?;
        each(
            &bytes[at..at + name_end],
            &bytes[kind_start..kind_start + kind_end],
            value,
        );
        at = size_at + 4 + size;
    }
}

/// Appends one header attribute: name, type name, size, value.
fn attribute(out: &mut Vec<u8>, name: &str, kind: &str, value: &[u8]) {
    out.extend_from_slice(name.as_bytes());
    out.push(0);
    out.extend_from_slice(kind.as_bytes());
    out.push(0);
    out.extend_from_slice(&(value.len() as i32).to_le_bytes());
    out.extend_from_slice(value);
}

#[cfg(test)]
mod tests {
    use super::*;
    use ::exr::prelude::*;
    use std::io::Cursor;

    #[test]
    fn decoding_gives_back_every_bit_and_refuses_edits() {
        let mut px = test_image(5, 3);
        px[4] = [f32::NAN, f32::INFINITY, -0.0];
        let bytes = encode_rgb(5, 3, &px);
        let (w, h, back) = decode_rgb(&bytes).unwrap();
        assert_eq!((w, h), (5, 3));
        let bits = |v: &[[f32; 3]]| v.iter().flatten().map(|f| f.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&back), bits(&px));
        assert!(decode_rgb(&bytes[..bytes.len() - 1]).is_err());
        assert!(decode_rgb(&bytes[..20]).is_err());
        assert!(decode_rgb(b"").is_err());
    }

    fn test_image(w: u32, h: u32) -> Vec<[f32; 3]> {
        (0..w * h)
            .map(|i| {
                let (x, y) = ((i % w) as f32, (i / w) as f32);
                [x * 0.25 + y, 1e-3 * x * y, 1000.0 - y * 17.5]
            })
            .collect()
    }

    type Read = Image<Layer<AnyChannels<FlatSamples>>>;

    fn read_back(bytes: &[u8]) -> Read {
        read()
            .no_deep_data()
            .largest_resolution_level()
            .all_channels()
            .first_valid_layer()
            .all_attributes()
            .pedantic()
            .from_buffered(Cursor::new(bytes))
            .expect("the exr crate reads our file")
    }

    #[test]
    fn exr_round_trips_through_the_exr_crate() {
        let (w, h) = (7u32, 5u32);
        let pixels = test_image(w, h);
        let bytes = encode_rgb(w, h, &pixels);
        let img = read_back(&bytes);
        let layer = &img.layer_data;
        assert_eq!(layer.size.0, w as usize);
        assert_eq!(layer.size.1, h as usize);
        assert_eq!(layer.encoding.compression, Compression::Uncompressed);
        assert_eq!(layer.encoding.line_order, LineOrder::Increasing);
        assert_eq!(img.attributes.display_window.size.0, w as usize);
        assert_eq!(img.attributes.pixel_aspect, 1.0);
        let names: Vec<String> = layer
            .channel_data
            .list
            .iter()
            .map(|c| c.name.to_string())
            .collect();
        assert_eq!(names, ["B", "G", "R"]);
        for (ch, c) in layer.channel_data.list.iter().zip([2usize, 1, 0]) {
            let FlatSamples::F32(values) = &ch.sample_data else {
                panic!("channel {} is not f32", ch.name);
            };
            let want: Vec<f32> = pixels.iter().map(|p| p[c]).collect();
            assert_eq!(values, &want, "channel {}", ch.name);
        }
    }

    #[test]
    fn string_attributes_are_read_by_the_exr_crate_and_by_decode() {
        let (w, h) = (4u32, 3u32);
        let pixels = test_image(w, h);
        let pairs = [
            ("probeplace.seed", "7"),
            ("probeplace.tool", "probeplace 0.1.0"),
        ];
        let bytes = with_attributes(encode_rgb(w, h, &pixels), &pairs);
        let img = read_back(&bytes);
        let other: Vec<(String, String)> = img
            .attributes
            .other
            .iter()
            .chain(img.layer_data.attributes.other.iter())
            .filter_map(|(k, v)| match v {
                AttributeValue::Text(t) => Some((k.to_string(), t.to_string())),
                _ => None,
            })
            .collect();
        for (k, v) in pairs {
            assert!(other.contains(&(k.to_string(), v.to_string())), "{other:?}");
        }
        let FlatSamples::F32(r) = &img.layer_data.channel_data.list[2].sample_data else {
            panic!("R is not f32");
        };
        assert_eq!(r[5], pixels[5][0], "the offsets moved with the header");
        assert_eq!(decode_rgb(&bytes).unwrap().2, pixels);
        assert_eq!(string_attributes(&bytes).len(), 2);
        assert!(decode_rgb(&bytes[..bytes.len() - 2]).is_err());
    }

    #[test]
    fn one_pixel_and_special_values_survive() {
        let pixels = [[f32::INFINITY, -0.0, 65504.5]];
        let img = read_back(&encode_rgb(1, 1, &pixels));
        let r = &img.layer_data.channel_data.list[2];
        assert_eq!(r.sample_data, FlatSamples::F32(vec![f32::INFINITY]));
        let b = &img.layer_data.channel_data.list[0];
        assert_eq!(b.sample_data, FlatSamples::F32(vec![65504.5]));
    }

    #[test]
    #[should_panic(expected = "pixel count")]
    fn wrong_pixel_count_is_refused() {
        encode_rgb(2, 2, &[[0.0; 3]; 3]);
    }
}
