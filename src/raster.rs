//! 8-bit RGB images: the previews, atlas panels, tone-mapped renders and
//! error maps that the runs write as PNG.
//!
//! [`RgbImage`] is a plain pixel buffer. It replaces the `image` crate's
//! type of the same name: nothing here needs more than the buffer and a
//! PNG encoder, and `image` 0.25 with the colour-management crates it
//! always compiles (`moxcms`, `pxfm`) took about a minute of CPU time in a
//! clean build. The encoder (`encode::png::encode_png`) is the `png` crate's,
//! the one `image` wraps, set up as `image` set it up, so the files are
//! byte for byte those `image` wrote.

/// An RGB image with 8 bits per channel, row by row from the top, 3 bytes
/// a pixel (R, G, B) with no padding between rows: the layout of an 8-bit
/// RGB PNG's pixel data, and of the `image` crate's `RgbImage`, which it
/// replaces.
///
/// Contract: the buffer holds exactly `3 · width · height` bytes. Pixel
/// access out of bounds is a programming error and panics.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct RgbImage {
    width: u32,
    height: u32,
    raw: Vec<u8>,
}

/// Bytes of a `width × height` RGB image; panics when they do not fit in
/// memory's address space.
fn byte_len(width: u32, height: u32) -> usize {
    (width as usize)
        .checked_mul(height as usize)
        .and_then(|n| n.checked_mul(3))
        .unwrap_or_else(|| panic!("a {width}×{height} image does not fit in memory"))
}

impl RgbImage {
    /// A black `width × height` image.
    pub fn new(width: u32, height: u32) -> Self {
        Self::from_pixel(width, height, [0; 3])
    }

    /// A `width × height` image of one colour.
    pub fn from_pixel(width: u32, height: u32, pixel: [u8; 3]) -> Self {
        let n = byte_len(width, height) / 3;
        Self {
            width,
            height,
            raw: pixel.repeat(n),
        }
    }

    /// A `width × height` image whose pixel `(x, y)` is `f(x, y)`, called
    /// row by row from the top.
    pub fn from_fn(width: u32, height: u32, mut f: impl FnMut(u32, u32) -> [u8; 3]) -> Self {
        let mut raw = Vec::with_capacity(byte_len(width, height));
        for y in 0..height {
            for x in 0..width {
                raw.extend_from_slice(&f(x, y));
            }
        }
        Self { width, height, raw }
    }

    /// The image of `raw` (the layout of [`RgbImage`]), or `None` unless
    /// it holds exactly `3 · width · height` bytes.
    pub fn from_raw(width: u32, height: u32, raw: Vec<u8>) -> Option<Self> {
        let n = (width as usize)
            .checked_mul(height as usize)
            .and_then(|n| n.checked_mul(3))?;
        (raw.len() == n).then_some(Self { width, height, raw })
    }

    /// Width in pixels.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Height in pixels.
    pub fn height(&self) -> u32 {
        self.height
    }

    /// `(width, height)` in pixels.
    pub fn dimensions(&self) -> (u32, u32) {
        (self.width, self.height)
    }

    /// Byte offset of pixel `(x, y)`; panics outside the image.
    fn at(&self, x: u32, y: u32) -> usize {
        assert!(
            x < self.width && y < self.height,
            "pixel ({x}, {y}) outside the {}×{} image",
            self.width,
            self.height
        );
        (y as usize * self.width as usize + x as usize) * 3
    }

    /// The pixel at column `x`, row `y` (0 is the top row).
    pub fn get_pixel(&self, x: u32, y: u32) -> [u8; 3] {
        let i = self.at(x, y);
        [self.raw[i], self.raw[i + 1], self.raw[i + 2]]
    }

    /// Sets the pixel at column `x`, row `y` (0 is the top row).
    pub fn put_pixel(&mut self, x: u32, y: u32, pixel: [u8; 3]) {
        let i = self.at(x, y);
        self.raw[i..i + 3].copy_from_slice(&pixel);
    }

    /// The pixels row by row from the top.
    pub fn pixels(&self) -> impl ExactSizeIterator<Item = [u8; 3]> + '_ {
        self.raw.chunks_exact(3).map(|p| [p[0], p[1], p[2]])
    }

    /// The pixels row by row from the top, to write.
    pub fn pixels_mut(&mut self) -> impl ExactSizeIterator<Item = &mut [u8; 3]> + '_ {
        self.raw
            .chunks_exact_mut(3)
            .map(|p| p.try_into().expect("chunks of 3 bytes"))
    }

    /// The bytes, in the layout of [`RgbImage`].
    pub fn as_raw(&self) -> &[u8] {
        &self.raw
    }

    /// The bytes, in the layout of [`RgbImage`], to write.
    pub fn as_raw_mut(&mut self) -> &mut [u8] {
        &mut self.raw
    }

    /// The bytes, in the layout of [`RgbImage`].
    pub fn into_raw(self) -> Vec<u8> {
        self.raw
    }

    /// Copies `top` into this image with its top-left corner at `(x, y)`;
    /// what falls outside this image is left out (as the `image` crate's
    /// `imageops::replace` did).
    pub fn replace(&mut self, top: &RgbImage, x: u32, y: u32) {
        let w = top.width.min(self.width.saturating_sub(x)) as usize;
        let h = top.height.min(self.height.saturating_sub(y));
        if w == 0 {
            return;
        }
        for row in 0..h {
            let from = row as usize * top.width as usize * 3;
            let to = self.at(x, y + row);
            self.raw[to..to + 3 * w].copy_from_slice(&top.raw[from..from + 3 * w]);
        }
    }
}

/// An 8-bit sRGB preview of linear `pixels` (`width × height`, row-major):
/// each channel multiplied by `exposure` (a linear factor, 1 = unchanged),
/// encoded with the sRGB transfer function, clamped to [0, 1] and rounded.
/// NaN becomes black.
///
/// Contract: `pixels.len() == width·height`, else it panics.
pub fn tonemap(pixels: &[[f32; 3]], width: u32, height: u32, exposure: f32) -> RgbImage {
    assert_eq!(
        pixels.len() as u64,
        width as u64 * height as u64,
        "pixel count does not match {width}x{height}"
    );
    let mut img = RgbImage::new(width, height);
    for (out, p) in img.pixels_mut().zip(pixels) {
        *out = p.map(|c| srgb_byte(c * exposure));
    }
    img
}

/// The sRGB encoding of linear `c` as a byte.
fn srgb_byte(c: f32) -> u8 {
    let c = if c.is_nan() { 0.0 } else { c.clamp(0.0, 1.0) };
    let v = if c <= 0.003_130_8 {
        12.92 * c
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    };
    (v * 255.0 + 0.5).clamp(0.0, 255.0) as u8
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pixels_are_rgb_row_by_row() {
        let img = RgbImage::from_fn(3, 2, |x, y| [x as u8, y as u8, 7]);
        assert_eq!(img.dimensions(), (3, 2));
        assert_eq!(img.as_raw().len(), 18);
        assert_eq!(img.get_pixel(2, 1), [2, 1, 7]);
        assert_eq!(&img.as_raw()[15..18], &[2, 1, 7]);
        let all: Vec<[u8; 3]> = img.pixels().collect();
        assert_eq!(all[4], [1, 1, 7]);
        let mut copy = RgbImage::from_raw(3, 2, img.clone().into_raw()).unwrap();
        assert_eq!(copy, img);
        copy.put_pixel(0, 1, [9, 9, 9]);
        assert_eq!(copy.get_pixel(0, 1), [9, 9, 9]);
        for p in copy.pixels_mut() {
            p[2] = 0;
        }
        assert!(copy.pixels().all(|p| p[2] == 0));
        assert!(RgbImage::from_raw(3, 2, vec![0; 17]).is_none());
        assert!(RgbImage::from_raw(u32::MAX, u32::MAX, Vec::new()).is_none());
        assert_eq!(RgbImage::new(2, 2).as_raw(), &[0; 12]);
        assert_eq!(RgbImage::from_pixel(0, 5, [1, 2, 3]).as_raw(), &[] as &[u8]);
    }

    #[test]
    fn replace_copies_and_clips() {
        let mut img = RgbImage::from_pixel(4, 3, [0; 3]);
        let top = RgbImage::from_fn(2, 2, |x, y| [1 + x as u8, 1 + y as u8, 5]);
        img.replace(&top, 1, 0);
        assert_eq!(img.get_pixel(1, 0), [1, 1, 5]);
        assert_eq!(img.get_pixel(2, 1), [2, 2, 5]);
        assert_eq!(img.get_pixel(0, 0), [0; 3]);
        assert_eq!(img.get_pixel(3, 0), [0; 3]);
        // Past the right and bottom edges: the part inside is copied.
        img.replace(&top, 3, 2);
        assert_eq!(img.get_pixel(3, 2), [1, 1, 5]);
        img.replace(&top, 4, 0);
        img.replace(&top, 0, 3);
        assert_eq!(img.pixels().filter(|p| p[2] == 5).count(), 5);
    }

    #[test]
    #[should_panic(expected = "outside")]
    fn reading_outside_panics() {
        RgbImage::new(2, 2).get_pixel(2, 0);
    }

    #[test]
    fn tonemap_applies_exposure_and_srgb() {
        let px = [[0.0, 0.5, 1.0], [0.22, 2.0, f32::NAN]];
        let img = tonemap(&px, 2, 1, 1.0);
        assert_eq!(img.get_pixel(0, 0), [0, 188, 255]);
        // sRGB(0.22) ≈ 0.506; over-range clamps; NaN is black.
        assert_eq!(img.get_pixel(1, 0), [129, 255, 0]);
        let darker = tonemap(&px, 2, 1, 0.5);
        assert_eq!(darker.get_pixel(0, 0)[2], 188);
        assert_eq!(darker.get_pixel(1, 0)[1], 255);
    }
}
