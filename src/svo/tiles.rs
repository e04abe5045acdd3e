//! Renumbering a tile's octree to the world's probe indices (`merge`,
//! [`crate::tiles`]).

use super::Svo;

impl Svo {
    /// Makes the tree list `global[i]` wherever it listed probe `i`, out of
    /// `probe_count` probes in all: a tile's tree, baked over the probes in
    /// its box, then names the world's probes, as a streamed region's
    /// volume must.
    ///
    /// Contract: the order of every leaf's list is kept; `global` must have
    /// an entry for every index the tree lists, each below `probe_count`.
    pub fn renumber(&mut self, global: &[u32], probe_count: u32) {
        for p in &mut self.payload {
            *p = global[*p as usize];
        }
        self.probe_count = probe_count;
    }
}
