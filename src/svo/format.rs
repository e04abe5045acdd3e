//! `svo.bin`, byte by byte (docs/formats.md has the same table for readers
//! in other languages). Every number is little-endian.
//!
//! | offset | size | field |
//! |---|---|---|
//! | 0 | 8 | magic `PROBESVO` |
//! | 8 | 4 | version (u32, [`VERSION`]) |
//! | 12 | 12 | origin: world-space lower corner of leaf (0,0,0), f32 × 3 |
//! | 24 | 4 | leaf size, f32 |
//! | 28 | 4 | depth (u32): the root cube is 2^depth leaves along an edge |
//! | 32 | 12 | leaves along x, y, z over the domain, u32 × 3 |
//! | 44 | 4 | probe count (u32): every index is below it |
//! | 48 | 4 | most probes per leaf (u32, 1..=8) |
//! | 52 | 4 | leaves without a visible probe (u32) |
//! | 56 | 4 | node count N (u32, ≥ 1) |
//! | 60 | 4 | payload count M (u32) |
//! | 64 | 24 | origin again, f64 × 3: exact, for readers that need it |
//! | 88 | 32 | provenance: config hash, scene hash, seed, tool hash (u64 × 4, [`crate::provenance`]) |
//! | 120 | 4N | nodes (u32 each; node 0 is the root) |
//! | 120+4N | 4M | payload: probe indices (u32 each) |
//! | 120+4N+4M | 4 | CRC-32 (IEEE, as zlib's `crc32`) of every byte before it |
//!
//! Version 2 added the f64 origin and the provenance (bytes 64–119);
//! everything before them is where version 1 had it.
//!
//! A node word with bit 31 set is a leaf: bits 28–30 hold the list length
//! minus one and bits 0–27 the offset of the list in the payload. Otherwise
//! it is an inner node: bits 0–7 are a child mask (bit `x + 2y + 4z` for the
//! child at offset (x, y, z) within the parent's cube) and bits 8–30 the
//! index of its first stored child; only children whose bit is set are
//! stored, consecutively, in bit order. A root word of 0 is an empty tree.

use super::octree::{CHILD_MASK_BITS, LEAF_BIT, PAYLOAD_OFFSET_BITS};
use super::Svo;
use glam::{DVec3, UVec3, Vec3};

/// The file's first eight bytes.
pub const MAGIC: &[u8; 8] = b"PROBESVO";
/// The version this build writes and reads.
pub const VERSION: u32 = 2;
/// Bytes before the node array.
pub const HEADER_BYTES: usize = 120;
/// Bytes of the trailing checksum.
pub const CHECKSUM_BYTES: usize = 4;

/// CRC-32 (IEEE 802.3, as zlib's `crc32`) of `bytes`, by the `crc32fast` crate.
pub fn crc32(bytes: &[u8]) -> u32 {
    crc32fast::hash(bytes)
}

/// The bytes of `svo.bin` for `svo`, its origin in world coordinates
/// ([`Svo::world_origin`] rounded to f32: exact to about 6e-8 of its distance
/// from the world origin, docs/formats.md).
pub fn to_bytes(svo: &Svo) -> Vec<u8> {
    let mut out = Vec::with_capacity(svo.bytes() as usize);
    out.extend_from_slice(MAGIC);
    let origin = svo.world_origin().as_vec3();
    let words = [
        VERSION,
        origin.x.to_bits(),
        origin.y.to_bits(),
        origin.z.to_bits(),
        svo.leaf_size.to_bits(),
        svo.depth,
        svo.dims.x,
        svo.dims.y,
        svo.dims.z,
        svo.probe_count,
        svo.max_probes,
        svo.leaves_without_visible_probe,
        svo.nodes.len() as u32,
        svo.payload.len() as u32,
    ];
    for w in &words {
        out.extend_from_slice(&w.to_le_bytes());
    }
    for c in svo.world_origin().to_array() {
        out.extend_from_slice(&c.to_le_bytes());
    }
    out.extend_from_slice(&svo.provenance);
    for w in svo.nodes.iter().chain(&svo.payload) {
        out.extend_from_slice(&w.to_le_bytes());
    }
    let crc = crc32(&out);
    out.extend_from_slice(&crc.to_le_bytes());
    out
}

/// Reads `svo.bin` from `bytes`: a tree in world coordinates (`frame` zero).
///
/// Contract: never panics and never reads out of bounds, whatever the
/// bytes; any file this build did not write intact is an `Err` with a
/// one-line reason (truncated, corrupted, wrong version, not an SVO). A
/// returned [`Svo`] answers every query within its arrays.
pub fn from_bytes(bytes: &[u8]) -> Result<Svo, String> {
    let minimum = HEADER_BYTES + CHECKSUM_BYTES;
    if bytes.len() < 8 || &bytes[..8] != MAGIC {
        return Err("not a probeplace SVO file (its first bytes are not PROBESVO)".into());
    }
    if bytes.len() < minimum {
        return Err(format!(
            "truncated: {} bytes, but the header alone takes {minimum}",
            bytes.len()
        ));
    }
    let word = |i: usize| u32::from_le_bytes([bytes[i], bytes[i + 1], bytes[i + 2], bytes[i + 3]]);
    let version = word(8);
    if version != VERSION {
        return Err(format!(
            "unsupported version {version}: this probeplace reads version {VERSION}"
        ));
    }
    let node_count = word(56) as u64;
    let payload_count = word(60) as u64;
    let expected = minimum as u64 + 4 * (node_count + payload_count);
    let len = bytes.len() as u64;
    if len < expected {
        return Err(format!(
            "truncated: {len} bytes, but its header announces {expected}"
        ));
    }
    if len > expected {
        return Err(format!(
            "corrupted: {len} bytes, but its header announces {expected}"
        ));
    }
    let body = bytes.len() - CHECKSUM_BYTES;
    if crc32(&bytes[..body]) != word(body) {
        return Err("corrupted: the checksum does not match the contents".into());
    }
    let f = |i: usize| f32::from_bits(word(i));
    let nodes_at = HEADER_BYTES;
    let payload_at = nodes_at + 4 * node_count as usize;
    let svo = Svo {
        origin: Vec3::new(f(12), f(16), f(20)),
        frame: DVec3::ZERO,
        leaf_size: f(24),
        depth: word(28),
        dims: UVec3::new(word(32), word(36), word(40)),
        probe_count: word(44),
        max_probes: word(48),
        leaves_without_visible_probe: word(52),
        provenance: bytes[88..120].try_into().expect("32 bytes"),
        nodes: (0..node_count as usize)
            .map(|i| word(nodes_at + 4 * i))
            .collect(),
        payload: (0..payload_count as usize)
            .map(|i| word(payload_at + 4 * i))
            .collect(),
    };
    validate(&svo)?;
    Ok(svo)
}

/// The exact world origin of a `svo.bin` that [`from_bytes`] accepted
/// (bytes 64–87), for a reader that moves the tree into its own frame.
pub fn exact_origin(bytes: &[u8]) -> DVec3 {
    let f = |i: usize| f64::from_le_bytes(bytes[i..i + 8].try_into().expect("8 bytes"));
    DVec3::new(f(64), f(72), f(80))
}

/// Checks every invariant [`Svo::probes_at`] relies on.
pub fn validate(svo: &Svo) -> Result<(), String> {
    let bad = |what: String| Err(format!("corrupted: {what}"));
    if !svo.origin.is_finite() {
        return bad("the origin is not finite".into());
    }
    if !(svo.leaf_size.is_finite() && svo.leaf_size > 0.0) {
        return bad(format!("leaf size {} is not positive", svo.leaf_size));
    }
    if svo.depth > 23 {
        return bad(format!("depth {} exceeds 23", svo.depth));
    }
    let side = 1u64 << svo.depth;
    if svo.dims.min_element() == 0 || svo.dims.max_element() as u64 > side {
        return bad(format!(
            "{:?} leaves do not fit a root of {side} leaves",
            svo.dims.to_array()
        ));
    }
    // No bake writes more leaves than an SDF grid may hold (`sdf::grid_dims`);
    // beyond that the leaf count overflows what `Svo::dense_bytes` computes.
    let leaves = svo.dims.x as u128 * svo.dims.y as u128 * svo.dims.z as u128;
    if leaves > crate::sdf::MAX_VOXELS as u128 {
        return bad(format!(
            "{:?} leaves are more than the {} a tree may have",
            svo.dims.to_array(),
            crate::sdf::MAX_VOXELS
        ));
    }
    if !(1..=8).contains(&svo.max_probes) {
        return bad(format!(
            "{} probes per leaf is outside 1..=8",
            svo.max_probes
        ));
    }
    if svo.nodes.is_empty() {
        return bad("there is no root node".into());
    }
    if let Some(p) = svo.payload.iter().find(|&&p| p >= svo.probe_count) {
        return bad(format!(
            "probe index {p} is not below the probe count {}",
            svo.probe_count
        ));
    }
    // Levels of the nodes: each node is reached exactly once, from a parent
    // stored before it, so the walk below visits every node.
    let n = svo.nodes.len();
    let mut level: Vec<Option<u32>> = vec![None; n];
    level[0] = Some(svo.depth);
    for (i, &w) in svo.nodes.iter().enumerate() {
        let Some(l) = level[i] else {
            return bad(format!("node {i} has no parent"));
        };
        if w & LEAF_BIT != 0 {
            let count = ((w >> PAYLOAD_OFFSET_BITS) & 7) as u64 + 1;
            let offset = (w & ((1 << PAYLOAD_OFFSET_BITS) - 1)) as u64;
            if count > svo.max_probes as u64 || offset + count > svo.payload.len() as u64 {
                return bad(format!("leaf {i} lists beyond the payload"));
            }
            continue;
        }
        let mask = w & 0xFF;
        if mask == 0 {
            if i != 0 {
                return bad(format!("inner node {i} has no child"));
            }
            continue;
        }
        if l == 0 {
            return bad(format!("node {i} has children below the leaf level"));
        }
        let first = (w >> CHILD_MASK_BITS) as usize;
        let count = mask.count_ones() as usize;
        if first <= i || first + count > n {
            return bad(format!("node {i} points outside the node array"));
        }
        for slot in &mut level[first..first + count] {
            if slot.is_some() {
                return bad(format!("node {i} shares a child with another node"));
            }
            *slot = Some(l - 1);
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn crc_matches_the_standard_check_value() {
        assert_eq!(crc32(b"123456789"), 0xCBF4_3926);
        assert_eq!(crc32(b""), 0);
    }

    /// An empty tree of `depth` over `dims` leaves, checksummed.
    fn empty_tree(depth: u32, dims: [u32; 3]) -> Vec<u8> {
        let mut b = MAGIC.to_vec();
        let words = [VERSION, 0, 0, 0, 1f32.to_bits(), depth];
        let words = words.into_iter().chain(dims).chain([1, 1, 0, 1, 0]);
        b.extend(words.flat_map(u32::to_le_bytes));
        b.resize(HEADER_BYTES + 4, 0);
        let crc = crc32(&b);
        b.extend_from_slice(&crc.to_le_bytes());
        b
    }

    #[test]
    fn more_leaves_than_a_bake_writes_are_refused() {
        assert!(from_bytes(&empty_tree(2, [4, 3, 1])).is_ok());
        // 2^69 leaves: `Svo::dense_bytes` overflowed u64 on them (found
        // writing the fuzz harness, fuzz/regressions/svo/dense-bytes-overflow).
        let err = from_bytes(&empty_tree(23, [1 << 23; 3])).unwrap_err();
        assert!(err.contains("more than the 64000000"), "{err}");
        assert!(from_bytes(&empty_tree(9, [400, 400, 400])).is_ok());
        assert!(from_bytes(&empty_tree(9, [400, 400, 401])).is_err());
    }
}
