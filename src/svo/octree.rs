//! Building the octree bottom-up and encoding it as the node array of
//! `svo.bin` (docs/formats.md).
//!
//! Like the paper's SVO (Wang et al. 2019 §4.1) only leaves carry payload.
//! Unlike its dense RGBA8 texture (Table 2: 15–243 MB), ours stores neither
//! solid nor outside space, and collapses every region a single ranked list
//! serves. Eight sibling nodes collapse into their parent when all of those
//! that hold free space are leaves and they share a probe whose relative
//! score (its score over the best probe's, [`Ranked`]) is at least
//! `collapse_quality` at every leaf below; the parent lists the probes all
//! of them list, by their worst relative score. Siblings without free space
//! do not constrain the merge: queries there are never made by a renderer.
//! Nor do leaves no probe sees: any list serves them equally badly.

use super::rank::{LeafRanker, ListOrigin, Ranked, Scratch};
use crate::error::{Error, Result};
use crate::sdf::VoxelClass;
use glam::{UVec3, Vec3};
use rayon::prelude::*;
use std::collections::{HashMap, VecDeque};
use std::sync::Mutex;

/// Marks a leaf word; the other words are inner nodes.
pub const LEAF_BIT: u32 = 1 << 31;
/// Bits of a leaf word holding the payload offset.
pub const PAYLOAD_OFFSET_BITS: u32 = 28;
/// Bits of an inner word holding the child mask.
pub const CHILD_MASK_BITS: u32 = 8;
/// Most nodes an inner word can point at (its offset field is 23 bits).
pub const MAX_NODES: usize = 1 << 23;

/// Levels at or above which the eight children are built in parallel.
const PARALLEL_LEVEL: u32 = 3;

/// A node of the tree under construction.
#[derive(Debug)]
pub enum Built {
    /// No free space below.
    Empty,
    /// One list for the whole cube.
    Leaf(Ranked),
    /// Free space no probe sees, listing the nearest probe. Any list serves
    /// it as well, so it collapses with whatever its siblings hold.
    Unseen(u32),
    /// Eight children, in the order x + 2y + 4z.
    Inner(Box<[Built; 8]>),
}

/// Leaves at the finest level, by how they got their list.
#[derive(Debug, Default, Clone, Copy, PartialEq, Eq)]
pub struct Tally {
    /// Leaves holding free space.
    pub free: u64,
    /// Of those, leaves listing the nearest probe that sees them because no
    /// probe whose influence holds them does.
    pub fallback: u64,
    /// Of those, leaves that none of their 64 nearest probes sees.
    pub blind: u64,
}

impl Tally {
    fn add(self, o: Tally) -> Tally {
        Tally {
            free: self.free + o.free,
            fallback: self.fallback + o.fallback,
            blind: self.blind + o.blind,
        }
    }
}

/// Builds the tree over a leaf grid.
pub struct Builder<'a> {
    /// Ranks single leaves.
    pub ranker: &'a LeafRanker<'a>,
    /// Leaves along x, y, z; cells beyond are outside the domain.
    pub dims: UVec3,
    /// Smallest share of the best score the first probe of a collapsed
    /// region keeps at every leaf.
    pub collapse_quality: f32,
    /// One [`Scratch`] per thread of rayon's pool, after one for any other
    /// thread ([`Builder::new`]).
    scratch: Vec<Mutex<Scratch>>,
}

impl<'a> Builder<'a> {
    /// The builder of the tree over `dims` leaves, for the current rayon pool.
    pub fn new(ranker: &'a LeafRanker<'a>, dims: UVec3, collapse_quality: f32) -> Builder<'a> {
        Builder {
            ranker,
            dims,
            collapse_quality,
            scratch: (0..=rayon::current_num_threads())
                .map(|_| Mutex::new(Scratch::default()))
                .collect(),
        }
    }

    /// The subtree whose cube is `cell` at `level` (2^level leaves along an
    /// edge), considering only `candidates`; `scratch` serves the serial
    /// part of the descent.
    pub fn build(
        &self,
        level: u32,
        cell: UVec3,
        candidates: &[u32],
        scratch: &mut Scratch,
    ) -> (Built, Tally) {
        let first = cell << level;
        if first.cmpge(self.dims).any() {
            return (Built::Empty, Tally::default());
        }
        if level == 0 {
            return self.leaf(first, candidates, scratch);
        }
        let ranker = self.ranker;
        let size = ranker.leaf_size * (1u32 << level) as f32;
        let lo = ranker.origin + first.as_vec3() * ranker.leaf_size;
        if self.holds_no_free_space(lo, size) {
            return (Built::Empty, Tally::default());
        }
        let hi = lo + size;
        let kept: Vec<u32> = candidates
            .iter()
            .copied()
            .filter(|&k| ranker.influence[k as usize].overlaps(lo, hi))
            .collect();
        // A leaf with no candidate still needs its fallback, so an empty
        // candidate list does not stop the descent.
        let child = |c: u32| -> UVec3 {
            let o = UVec3::new(c & 1, (c >> 1) & 1, c >> 2);
            (cell << 1) + o
        };
        let parts: Vec<(Built, Tally)> = if level > PARALLEL_LEVEL {
            (0..8u32)
                .into_par_iter()
                .map(|c| self.build(level - 1, child(c), &kept, &mut Scratch::default()))
                .collect()
        } else if level == PARALLEL_LEVEL {
            (0..8u32)
                .into_par_iter()
                .map(|c| self.build_serial(level - 1, child(c), &kept))
                .collect()
        } else {
            (0..8)
                .map(|c| self.build(level - 1, child(c), &kept, scratch))
                .collect()
        };
        let tally = parts
            .iter()
            .fold(Tally::default(), |acc, (_, t)| acc.add(*t));
        let children: [Built; 8] = parts
            .into_iter()
            .map(|(b, _)| b)
            .collect::<Vec<_>>()
            .try_into()
            .unwrap_or_else(|_| unreachable!("eight children"));
        (collapse(children, self.collapse_quality), tally)
    }

    /// [`Builder::build`] of a subtree built on one thread, with that
    /// thread's [`Scratch`]: its blocker memories
    /// ([`crate::scene::raycast::Blocker`]) carry over from the last
    /// subtree the thread built, usually the one beside it, rather than
    /// starting empty every 64 leaves. The answers do not depend on what
    /// a memory holds, so neither does the tree. (The serial descent never
    /// calls into rayon, so a thread cannot find its own scratch in use;
    /// were it so, a fresh one would serve.)
    fn build_serial(&self, level: u32, cell: UVec3, candidates: &[u32]) -> (Built, Tally) {
        let slot = rayon::current_thread_index().map_or(0, |i| i + 1);
        match self.scratch.get(slot).map(|m| m.try_lock()) {
            Some(Ok(mut scratch)) => self.build(level, cell, candidates, &mut scratch),
            _ => self.build(level, cell, candidates, &mut Scratch::default()),
        }
    }

    /// The leaf at `cell` (inside the grid).
    fn leaf(&self, cell: UVec3, candidates: &[u32], scratch: &mut Scratch) -> (Built, Tally) {
        match self.ranker.rank(cell, candidates, scratch) {
            None => (Built::Empty, Tally::default()),
            Some((r, source)) => (
                if source == ListOrigin::Blind {
                    Built::Unseen(r.probes()[0])
                } else {
                    Built::Leaf(r)
                },
                Tally {
                    free: 1,
                    fallback: u64::from(source == ListOrigin::Fallback),
                    blind: u64::from(source == ListOrigin::Blind),
                },
            ),
        }
    }

    /// Whether the SDF proves that the cube `lo..lo+size` has no free
    /// space: no surface crosses it and its centre is solid. (An outside
    /// centre proves nothing: an opening to the sky joins free and outside
    /// space without a surface between them.)
    fn holds_no_free_space(&self, lo: Vec3, size: f32) -> bool {
        self.ranker.sdf.clear_cube_class(lo + 0.5 * size, size) == Some(VoxelClass::Solid)
    }
}

/// `children` as one node: empty when all are, a leaf when they collapse
/// (module docs), otherwise an inner node.
pub fn collapse(children: [Built; 8], collapse_quality: f32) -> Built {
    let mut shared: Option<Ranked> = None;
    let mut unseen: Option<u32> = None;
    let mut mergeable = true;
    for c in &children {
        match c {
            Built::Empty => {}
            Built::Unseen(k) => {
                unseen.get_or_insert(*k);
            }
            Built::Leaf(r) => {
                shared = Some(match shared {
                    None => *r,
                    Some(s) => s.intersect(r),
                });
            }
            Built::Inner(_) => mergeable = false,
        }
    }
    match shared {
        None if mergeable => unseen.map_or(Built::Empty, Built::Unseen),
        Some(s) if mergeable && !s.is_empty() && s.quality()[0] >= collapse_quality => {
            Built::Leaf(s)
        }
        _ => Built::Inner(Box::new(children)),
    }
}

/// The node array and payload of `root` (docs/formats.md): nodes in
/// breadth-first order, each inner node's stored children consecutive and
/// after it; identical lists (cut to `max_probes`) stored once.
///
/// Contract: fails with a user error naming `svo.leaf_size` when the tree
/// outgrows the format's 23-bit node offsets or 28-bit payload offsets.
pub fn encode(root: &Built, max_probes: usize) -> Result<(Vec<u32>, Vec<u32>)> {
    let mut nodes = vec![0u32];
    let mut payload: Vec<u32> = Vec::new();
    let mut lists: HashMap<Vec<u32>, u32> = HashMap::new();
    let mut queue: VecDeque<(&Built, usize)> = VecDeque::from([(root, 0)]);
    let too_big = || {
        Error::User(
            "svo.leaf_size: the octree outgrows svo.bin's offsets (8M nodes); use a larger leaf_size"
                .into(),
        )
    };
    while let Some((node, at)) = queue.pop_front() {
        nodes[at] = match node {
            Built::Empty => 0,
            Built::Leaf(_) | Built::Unseen(_) => {
                let list = match node {
                    Built::Leaf(r) => &r.probes()[..r.len().min(max_probes)],
                    Built::Unseen(k) => std::slice::from_ref(k),
                    _ => unreachable!("a leaf"),
                };
                let offset = match lists.get(list) {
                    Some(&o) => o,
                    None => {
                        let o = payload.len() as u32;
                        payload.extend_from_slice(list);
                        lists.insert(list.to_vec(), o);
                        o
                    }
                };
                if offset >= 1 << PAYLOAD_OFFSET_BITS {
                    return Err(too_big());
                }
                LEAF_BIT | ((list.len() as u32 - 1) << PAYLOAD_OFFSET_BITS) | offset
            }
            Built::Inner(children) => {
                let base = nodes.len();
                let mut mask = 0u32;
                for (c, child) in children.iter().enumerate() {
                    if !matches!(child, Built::Empty) {
                        mask |= 1 << c;
                        queue.push_back((child, nodes.len()));
                        nodes.push(0);
                    }
                }
                if nodes.len() > MAX_NODES {
                    return Err(too_big());
                }
                ((base as u32) << CHILD_MASK_BITS) | mask
            }
        };
    }
    Ok((nodes, payload))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A leaf listing `items` with relative scores 1, 0.9, 0.8, ...
    fn leaf(items: &[u32]) -> Built {
        let scored: Vec<(u32, f32)> = items
            .iter()
            .enumerate()
            .map(|(i, &p)| (p, 1.0 - 0.1 * i as f32))
            .collect();
        Built::Leaf(Ranked::from_items(&scored))
    }

    #[test]
    fn siblings_sharing_a_good_first_probe_collapse() {
        let kids = [
            leaf(&[1, 2]),
            leaf(&[1, 3]),
            Built::Empty,
            leaf(&[1, 2, 3]),
            Built::Empty,
            Built::Empty,
            Built::Empty,
            Built::Empty,
        ];
        match collapse(kids, 0.5) {
            Built::Leaf(r) => assert_eq!(r.probes(), &[1]),
            other => panic!("expected a leaf, got {other:?}"),
        }
    }

    #[test]
    fn siblings_without_a_shared_probe_stay_apart() {
        let kids = [
            leaf(&[1]),
            leaf(&[2]),
            Built::Empty,
            Built::Empty,
            Built::Empty,
            Built::Empty,
            Built::Empty,
            Built::Empty,
        ];
        assert!(matches!(collapse(kids, 0.5), Built::Inner(_)));
        let empty: [Built; 8] = std::array::from_fn(|_| Built::Empty);
        assert!(matches!(collapse(empty, 0.5), Built::Empty));
    }

    #[test]
    fn unseen_leaves_take_their_siblings_list() {
        let mut kids: [Built; 8] = std::array::from_fn(|_| Built::Empty);
        kids[0] = Built::Unseen(9);
        kids[3] = leaf(&[1, 2]);
        match collapse(kids, 0.5) {
            Built::Leaf(r) => assert_eq!(r.probes(), &[1, 2]),
            other => panic!("expected a leaf, got {other:?}"),
        }
        let mut kids: [Built; 8] = std::array::from_fn(|_| Built::Empty);
        kids[2] = Built::Unseen(9);
        kids[5] = Built::Unseen(4);
        assert!(matches!(collapse(kids, 0.5), Built::Unseen(9)));
    }

    #[test]
    fn a_shared_probe_too_far_behind_blocks_the_collapse() {
        // Probe 2 is shared but scores 0.3 of the best at the first leaf.
        let a = Ranked::from_items(&[(1, 1.0), (2, 0.3)]);
        let b = Ranked::single(2);
        let mut kids: [Built; 8] = std::array::from_fn(|_| Built::Empty);
        kids[0] = Built::Leaf(a);
        kids[1] = Built::Leaf(b);
        assert!(matches!(collapse(kids, 0.5), Built::Inner(_)));
        let mut kids: [Built; 8] = std::array::from_fn(|_| Built::Empty);
        kids[0] = Built::Leaf(a);
        kids[1] = Built::Leaf(b);
        assert!(matches!(collapse(kids, 0.25), Built::Leaf(_)));
    }

    #[test]
    fn encoding_is_breadth_first_and_shares_lists() {
        let mut inner: [Built; 8] = std::array::from_fn(|_| Built::Empty);
        inner[0] = leaf(&[4, 5]);
        inner[7] = leaf(&[4, 5]);
        let mut kids: [Built; 8] = std::array::from_fn(|_| Built::Empty);
        kids[2] = Built::Inner(Box::new(inner));
        kids[5] = leaf(&[6]);
        let root = Built::Inner(Box::new(kids));
        let (nodes, payload) = encode(&root, 4).unwrap();
        assert_eq!(nodes.len(), 5);
        assert_eq!(nodes[0], (1 << CHILD_MASK_BITS) | (1 << 2) | (1 << 5));
        assert_eq!(nodes[1], (3 << CHILD_MASK_BITS) | 1 | (1 << 7));
        assert_eq!(nodes[2] & LEAF_BIT, LEAF_BIT);
        assert_eq!(nodes[3], nodes[4], "identical lists share one payload");
        assert_eq!(payload.len(), 3);
    }
}
