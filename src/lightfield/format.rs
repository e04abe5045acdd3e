//! `lightfield.bin`: the baked probe maps, byte by byte in docs/formats.md.
//!
//! | offset | bytes | field |
//! |---|---|---|
//! | 0 | 8 | magic `PROBELFB` |
//! | 8 | 4 | version (1) |
//! | 12 | 4 | probe count P |
//! | 16 | 4 | map side n |
//! | 20 | 4 | pyramid levels L (log2 n + 1) |
//! | 24 | 4 | irradiance side m |
//! | 28 | 4 | `max_distance` (f32) |
//! | 32 | 32 | provenance: config hash, scene hash, seed, tool hash (u64 × 4, [`crate::provenance`]); zero in files of older builds |
//! | 64 | 12P | probe positions, world space (3 × f32) |
//! | … | 6Pn² | radiance (3 × f16) |
//! | … | 4Pn² | normal (2 × f16, octahedral) |
//! | … | 2Pn² | radial distance (f16, +∞ = nothing seen) |
//! | … | 4P(n>>k)² per level k | (min, max) distance (2 × f16) |
//! | … | 6Pm² | irradiance (3 × f16) |
//! | … | 4Pm² | moments E\[r\], E\[r²\] (2 × f16) |
//! | end − 4 | 4 | CRC-32 of every byte before it |
//!
//! All little-endian; each section holds the probes one after another and
//! each map row by row from texel (0, 0). Every value in memory is already
//! rounded to half precision, so writing and reading lose nothing, except
//! that positions are written in world coordinates (`frame + position`,
//! rounded to f32) and read back with `frame` zero.

use super::LightField;
use glam::{DVec3, Vec3};
use half::f16;

/// File signature.
pub const MAGIC: &[u8; 8] = b"PROBELFB";
/// Layout version written and understood.
pub const VERSION: u32 = 1;
/// Header size in bytes.
pub const HEADER_BYTES: usize = 64;

fn put_halves(out: &mut Vec<u8>, values: impl IntoIterator<Item = f32>) {
    for v in values {
        out.extend_from_slice(&f16::from_f32(v).to_le_bytes());
    }
}

/// Size in bytes of the file for `probes` probes of side `n`, irradiance side `m`.
pub fn file_bytes(probes: usize, n: u32, m: u32) -> usize {
    let levels: usize = (0..=n.trailing_zeros())
        .map(|k| ((n >> k) * (n >> k)) as usize)
        .sum();
    HEADER_BYTES + probes * (12 + 12 * (n * n) as usize + 4 * levels + 10 * (m * m) as usize) + 4
}

/// Serializes `field`.
pub fn to_bytes(field: &LightField) -> Vec<u8> {
    let p = field.positions.len();
    let mut out = Vec::with_capacity(file_bytes(p, field.resolution, field.irradiance_resolution));
    out.extend_from_slice(MAGIC);
    for w in [
        VERSION,
        p as u32,
        field.resolution,
        field.pyramid.len() as u32,
        field.irradiance_resolution,
    ] {
        out.extend_from_slice(&w.to_le_bytes());
    }
    out.extend_from_slice(&field.max_distance.to_le_bytes());
    out.extend_from_slice(&field.provenance);
    for q in &field.positions {
        for c in (field.frame + q.as_dvec3()).as_vec3().to_array() {
            out.extend_from_slice(&c.to_le_bytes());
        }
    }
    put_halves(&mut out, field.radiance.iter().flatten().copied());
    put_halves(&mut out, field.normal.iter().flatten().copied());
    put_halves(&mut out, field.distance.iter().copied());
    for level in &field.pyramid {
        put_halves(&mut out, level.iter().flatten().copied());
    }
    put_halves(&mut out, field.irradiance.iter().flatten().copied());
    put_halves(&mut out, field.moments.iter().flatten().copied());
    let crc = crc32fast::hash(&out);
    out.extend_from_slice(&crc.to_le_bytes());
    out
}

/// Parses a `lightfield.bin` image, checking magic, version, size, CRC and
/// that the header's sizes are consistent, and never panicking.
pub fn from_bytes(bytes: &[u8]) -> Result<LightField, String> {
    if bytes.len() < HEADER_BYTES + 4 {
        return Err(format!(
            "truncated: {} bytes, shorter than a header",
            bytes.len()
        ));
    }
    if &bytes[..8] != MAGIC {
        return Err("not a probeplace light-field file (bad magic)".into());
    }
    let word = |at: usize| u32::from_le_bytes(bytes[at..at + 4].try_into().expect("4 bytes"));
    let version = word(8);
    if version != VERSION {
        return Err(format!(
            "version {version}; this build reads version {VERSION}"
        ));
    }
    let (p, n, levels, m) = (word(12) as usize, word(16), word(20), word(24));
    let max_distance = f32::from_bits(word(28));
    if !n.is_power_of_two() || !m.is_power_of_two() || n > 1 << 14 || m > 1 << 14 {
        return Err(format!("map sides {n} and {m} must be powers of two"));
    }
    if levels != n.trailing_zeros() + 1 {
        return Err(format!("{levels} pyramid levels for side {n}"));
    }
    let want = (p as u128)
        * (12
            + 12 * (n as u128 * n as u128)
            + 4 * (0..levels).map(|k| ((n >> k) as u128).pow(2)).sum::<u128>()
            + 10 * (m as u128 * m as u128))
        + HEADER_BYTES as u128
        + 4;
    if want != bytes.len() as u128 {
        return Err(format!(
            "{} bytes where the header implies {want}",
            bytes.len()
        ));
    }
    let body = bytes.len() - 4;
    if crc32fast::hash(&bytes[..body]) != word(body) {
        return Err("checksum mismatch: the file is damaged".into());
    }
    let mut at = HEADER_BYTES;
    let mut f32s = |count: usize| {
        let v: Vec<f32> = bytes[at..at + 4 * count]
            .chunks_exact(4)
            .map(|c| f32::from_le_bytes(c.try_into().expect("4 bytes")))
            .collect();
        at += 4 * count;
        v
    };
    let positions: Vec<Vec3> = f32s(3 * p).chunks_exact(3).map(Vec3::from_slice).collect();
    let mut halves = |count: usize| {
        let v: Vec<f32> = bytes[at..at + 2 * count]
            .chunks_exact(2)
            .map(|c| f16::from_le_bytes([c[0], c[1]]).to_f32())
            .collect();
        at += 2 * count;
        v
    };
    let texels = p * (n * n) as usize;
    let irr = p * (m * m) as usize;
    let radiance = halves(3 * texels)
        .chunks_exact(3)
        .map(|c| [c[0], c[1], c[2]])
        .collect();
    let normal = halves(2 * texels)
        .chunks_exact(2)
        .map(|c| [c[0], c[1]])
        .collect();
    let distance = halves(texels);
    let pyramid = (0..levels)
        .map(|k| {
            let side = (n >> k) as usize;
            halves(2 * p * side * side)
                .chunks_exact(2)
                .map(|c| [c[0], c[1]])
                .collect()
        })
        .collect();
    let irradiance = halves(3 * irr)
        .chunks_exact(3)
        .map(|c| [c[0], c[1], c[2]])
        .collect();
    let moments = halves(2 * irr)
        .chunks_exact(2)
        .map(|c| [c[0], c[1]])
        .collect();
    Ok(LightField {
        resolution: n,
        irradiance_resolution: m,
        max_distance,
        positions,
        frame: DVec3::ZERO,
        radiance,
        normal,
        distance,
        pyramid,
        irradiance,
        moments,
        provenance: bytes[32..64].try_into().expect("32 bytes"),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::{BakeParams, Count, PowerOfTwo};
    use crate::progress::Progress;
    use crate::scene::raycast::SceneBvh;
    use crate::scene::testing::room_with_box;

    fn small_field() -> LightField {
        let scene = room_with_box();
        let bvh = SceneBvh::new(&scene);
        let params = BakeParams {
            resolution: PowerOfTwo(16),
            irradiance_resolution: PowerOfTwo(8),
            samples: Count(2),
            ..BakeParams::default()
        };
        let probes = [Vec3::new(0.5, 2.0, 0.5), Vec3::new(3.0, 1.0, 3.0)];
        super::super::bake(
            &params,
            &probes,
            &scene,
            &bvh,
            7.0,
            3,
            &|_, d, _| d.abs() * 2.0,
            &Progress::hidden(),
        )
        .field
    }

    #[test]
    fn round_trip_is_exact_and_sized_as_documented() {
        let field = small_field();
        let bytes = to_bytes(&field);
        assert_eq!(bytes.len(), field.bytes());
        assert_eq!(bytes.len(), file_bytes(2, 16, 8));
        let back = from_bytes(&bytes).unwrap();
        assert_eq!(back, field);
        assert_eq!(to_bytes(&back), bytes);
    }

    #[test]
    fn positions_are_written_in_world_coordinates() {
        let mut field = small_field();
        field.frame = DVec3::new(1e5, 2.5, -3e4);
        let back = from_bytes(&to_bytes(&field)).unwrap();
        assert_eq!(back.frame, DVec3::ZERO);
        for (b, p) in back.positions.iter().zip(&field.positions) {
            assert_eq!(*b, (field.frame + p.as_dvec3()).as_vec3());
        }
        assert_eq!(back.radiance, field.radiance);
    }

    #[test]
    fn damaged_files_are_refused() {
        let bytes = to_bytes(&small_field());
        assert!(from_bytes(&bytes[..bytes.len() - 1])
            .unwrap_err()
            .contains("bytes"));
        assert!(from_bytes(&bytes[..30]).unwrap_err().contains("truncated"));
        let mut flipped = bytes.clone();
        flipped[HEADER_BYTES + 100] ^= 4;
        assert!(from_bytes(&flipped).unwrap_err().contains("checksum"));
        let mut newer = bytes.clone();
        newer[8] = 2;
        assert!(from_bytes(&newer).unwrap_err().contains("version"));
        let mut other = bytes.clone();
        other[..8].copy_from_slice(b"PROBESVO");
        assert!(from_bytes(&other).unwrap_err().contains("magic"));
        let mut lying = bytes;
        lying[16] = 32;
        assert!(from_bytes(&lying).is_err());
    }
}
