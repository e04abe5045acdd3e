//! A 4-wide BVH with uncompressed child boxes, and its single-ray
//! traversal: the acceleration structure under [`super::raycast`].
//!
//! **Why this and not obvhs's compressed wide BVH (CWBVH).** Our rays are
//! incoherent single rays on the CPU. The CWBVH (Ylitie, Karras & Laine
//! 2017, "Efficient Incoherent Ray Traversal on GPUs Using Compressed Wide
//! BVHs") was designed for GPU memory bandwidth: 8 children per node with
//! 8-bit quantized boxes, decoded per node. On the CPU the decoding and its
//! octant-ordered traversal state cost more than the memory they save;
//! the CPU ray tracers of Wald, Benthin & Boulos 2008 ("Getting Rid of
//! Packets") and Ernst & Greiner 2008 ("Multi Bounding Volume
//! Hierarchies"), and Embree since, test one ray against the four f32 boxes
//! of a node at once with SSE, children stored by coordinate ("SoA"): one
//! subtract and one multiply per slab plane for four boxes.
//!
//! **Build.** obvhs's PLOC builder and reinsertion optimizer make a binary
//! tree of one primitive per leaf, as its CWBVH builder does (same
//! parameters, so the same tree). It is then collapsed here, in O(n):
//! a bottom-up pass chooses where subtrees of at most [`MAX_LEAF`]
//! primitives become leaves, by the surface area heuristic (MacDonald &
//! Booth 1990) against keeping them as nodes; a top-down pass makes each
//! 4-wide node from a binary node by opening, while it has fewer than four
//! children, the child of largest surface area that is not to be a leaf
//! (Wald et al. 2008, §3). Leaves are ranges of a leaf-ordered primitive
//! list ([`WideBvh::order`]), so a leaf's primitives are read contiguously;
//! each starts at a multiple of [`LEAF_ALIGN`] (the list is padded with
//! [`PAD`]), so that a user can store them in blocks of four for a SIMD
//! test, as Embree does (Wald et al. 2014, "Embree: A Kernel Framework for
//! Efficient CPU Ray Tracing", ACM TOG 33(4), 2014).
//!
//! **Traversal.** One ray, a fixed stack ([`STACK`] entries, bounded by
//! the tree's depth, which the build measures), SSE node tests on x86-64
//! with a scalar fallback elsewhere. Box tests are inclusive (a box whose
//! entry equals the current bound is still visited), so that callers that
//! break ties between hits at equal distances see every such hit.
//! Directions' zero components give infinite inverse components; the NaN
//! of `0·∞` (an origin exactly on a slab plane of such an axis) is dropped
//! from the interval, never culling the box.

use obvhs::{
    aabb::Aabb,
    bvh2::{node::Bvh2Node, reinsertion::ReinsertionOptimizer, Bvh2},
    ploc::PlocBuilder,
    ray::Ray,
    Boundable, BvhBuildParams,
};
use std::ops::Range;

/// Most primitives in a leaf.
pub const MAX_LEAF: u32 = 8;

/// Every leaf's first slot is a multiple of this, and so is the length of
/// [`WideBvh::order`].
pub const LEAF_ALIGN: usize = 4;

/// The entry of [`WideBvh::order`] in a slot that no leaf holds.
pub const PAD: u32 = u32::MAX;

/// Stack entries a traversal keeps on the call stack; a tree deeper than
/// this allows (over 20 levels of 4-wide nodes; Sponza's has 13) traverses
/// with a stack on the heap instead. Each ray fills it with zeros first,
/// which at 128 entries was 2% of the ray casts' time.
const STACK: usize = 64;

/// Cost of testing one block of [`LEAF_ALIGN`] primitives, against the
/// cost of one 4-wide node test, for the leaf decision: a leaf's
/// primitives are tested a block at a time ([`LEAF_ALIGN`]).
const BLOCK_COST: f32 = 1.0;
/// Cost of each primitive of a leaf beyond its blocks' (the hits it may
/// give to sort out). On Dabrovic Sponza, 0.25 with [`BLOCK_COST`] 1 cast
/// closest-hit rays about 10% faster than a cost of 1 per primitive (the
/// model of one triangle tested at a time), with 6.2k nodes for 9.5k.
const PRIMITIVE_COST: f32 = 0.25;

/// The SAH cost of a leaf of `n` primitives, per unit of its half-area.
fn leaf_cost(n: u32) -> f32 {
    BLOCK_COST * n.div_ceil(LEAF_ALIGN as u32) as f32 + PRIMITIVE_COST * n as f32
}
/// Cost of one binary node of the tree being collapsed. A 4-wide node
/// replaces about three of them, but its 128 bytes are what incoherent
/// rays wait for: on Dabrovic Sponza, 2 (9.5k nodes of 66k triangles)
/// was as fast as or faster than 0.4 (18.5k nodes) and 1.
const NODE_COST: f32 = 2.0;

/// A child reference: an inner node's index, or, with [`LEAF_BIT`] set, a
/// leaf's first block of [`LEAF_ALIGN`] slots (bits 0..27) and its slot
/// count less one (bits 27..31). Counting blocks rather than slots (leaves
/// start on block boundaries) lets a tree address 2²⁹ slots.
type ChildRef = u32;
const LEAF_BIT: u32 = 1 << 31;
const FIRST_BITS: u32 = 27;
/// A node's empty slot (its box is empty too, so it is never entered), and
/// the root of an empty tree.
const EMPTY: ChildRef = u32::MAX;

/// Most primitives a tree is built over: each leaf can pad its last block,
/// so at worst every primitive takes a block of its own, and 2²⁷ blocks
/// are what a [`ChildRef`] addresses. The scene loader refuses larger
/// scenes (a tile of `probeplace split` holds a part of one).
pub const MAX_PRIMITIVES: usize = 1 << FIRST_BITS;

fn leaf_ref(first: usize, count: usize) -> ChildRef {
    assert!(
        first.is_multiple_of(LEAF_ALIGN)
            && first / LEAF_ALIGN < 1 << FIRST_BITS
            && (1..=16).contains(&count),
        "a leaf of {count} primitives at {first}"
    );
    LEAF_BIT | ((count as u32 - 1) << FIRST_BITS) | (first / LEAF_ALIGN) as u32
}

fn leaf_range(r: ChildRef) -> Range<usize> {
    let first = (r & ((1 << FIRST_BITS) - 1)) as usize * LEAF_ALIGN;
    let count = ((r & !LEAF_BIT) >> FIRST_BITS) as usize + 1;
    first..first + count
}

/// Four children's boxes by coordinate, rows `[min x, max x, min y, max y,
/// min z, max z]`, and the children. Two cache lines.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
struct Node {
    bounds: [[f32; 4]; 6],
    child: [ChildRef; 4],
}

impl Node {
    const EMPTY: Node = Node {
        bounds: [
            [f32::INFINITY; 4],
            [f32::NEG_INFINITY; 4],
            [f32::INFINITY; 4],
            [f32::NEG_INFINITY; 4],
            [f32::INFINITY; 4],
            [f32::NEG_INFINITY; 4],
        ],
        child: [EMPTY; 4],
    };

    fn set(&mut self, slot: usize, b: &Aabb, child: ChildRef) {
        for k in 0..3 {
            self.bounds[2 * k][slot] = b.min[k];
            self.bounds[2 * k + 1][slot] = b.max[k];
        }
        self.child[slot] = child;
    }
}

/// A 4-wide BVH over primitives given by their boxes.
pub struct WideBvh {
    nodes: Vec<Node>,
    root: ChildRef,
    /// Input index of the primitive in each leaf slot ([`PAD`] in the
    /// slots between leaves): leaves name ranges of slots.
    pub order: Vec<u32>,
    /// Stack entries a traversal may need: three per level of nodes.
    stack: usize,
}

/// A ray's constants for the box tests, made once per query.
#[derive(Clone, Copy, Debug)]
pub struct BoxRay {
    origin: [f32; 3],
    inv: [f32; 3],
    /// Per axis, the row of [`Node::bounds`] the ray enters by: the min
    /// row `2k` for a non-negative direction component, the max row
    /// `2k + 1` otherwise (it leaves by the other).
    near: [usize; 3],
    tmin: f32,
}

impl BoxRay {
    /// The constants of `ray` for `t ≥ ray.tmin`. Its direction must have
    /// no −0 component: a component's sign picks the entry plane, and
    /// `1/−0 = −∞` would put the exit before it. The inverse is exact:
    /// obvhs's `inv_direction` clamps components under `f32::EPSILON`,
    /// which would shorten the slab intervals of nearly axis-aligned rays
    /// and cull boxes they enter.
    pub fn new(ray: &Ray) -> BoxRay {
        let dir = ray.direction.to_array();
        BoxRay {
            origin: ray.origin.to_array(),
            inv: dir.map(|d| 1.0 / d),
            near: [0, 1, 2].map(|k| 2 * k + (dir[k] < 0.0) as usize),
            tmin: ray.tmin,
        }
    }
}

/// The children of `node` whose boxes `ray` enters within `[tmin, tmax]`
/// (bit `i` of the mask for child `i`), and each child's entry distance.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn enter(node: &Node, ray: &BoxRay, tmax: f32) -> (u32, [f32; 4]) {
    use std::arch::x86_64::*;
    let mut entry = [0.0f32; 4];
    // SAFETY: SSE is part of every x86-64 target's baseline; the loads
    // read 16-byte rows of `node.bounds` and the store writes the 16
    // bytes of `entry` (unaligned loads and stores have no alignment
    // requirement).
    let mask = unsafe {
        let mut near = _mm_set1_ps(ray.tmin);
        let mut far = _mm_set1_ps(tmax);
        for k in 0..3 {
            let o = _mm_set1_ps(ray.origin[k]);
            let inv = _mm_set1_ps(ray.inv[k]);
            let n = ray.near[k];
            let t0 = _mm_mul_ps(_mm_sub_ps(_mm_loadu_ps(node.bounds[n].as_ptr()), o), inv);
            let t1 = _mm_mul_ps(
                _mm_sub_ps(_mm_loadu_ps(node.bounds[n ^ 1].as_ptr()), o),
                inv,
            );
            // MAXPS and MINPS return their second operand when either is
            // NaN, so a NaN plane distance leaves the interval as it was.
            near = _mm_max_ps(t0, near);
            far = _mm_min_ps(t1, far);
        }
        _mm_storeu_ps(entry.as_mut_ptr(), near);
        _mm_movemask_ps(_mm_cmple_ps(near, far)) as u32
    };
    (mask, entry)
}

/// The scalar [`enter`], for other architectures.
#[cfg(not(target_arch = "x86_64"))]
#[inline(always)]
fn enter(node: &Node, ray: &BoxRay, tmax: f32) -> (u32, [f32; 4]) {
    let mut mask = 0;
    let mut entry = [0.0f32; 4];
    for i in 0..4 {
        let (mut near, mut far) = (ray.tmin, tmax);
        for k in 0..3 {
            let n = ray.near[k];
            let t0 = (node.bounds[n][i] - ray.origin[k]) * ray.inv[k];
            let t1 = (node.bounds[n ^ 1][i] - ray.origin[k]) * ray.inv[k];
            // `max` and `min` return the other operand for a NaN one.
            near = t0.max(near);
            far = t1.min(far);
        }
        mask |= ((near <= far) as u32) << i;
        entry[i] = near;
    }
    (mask, entry)
}

/// The children of `node` in `mask` (at least one) with their `entry`
/// distances, nearest first (an insertion sort of at most four), and how
/// many they are.
#[inline(always)]
fn nearest_first(node: &Node, mask: u32, entry: &[f32; 4]) -> ([(ChildRef, f32); 4], usize) {
    let mut hit = [(0, 0.0f32); 4];
    let mut n = 0;
    let mut m = mask;
    while m != 0 {
        let i = m.trailing_zeros() as usize;
        m &= m - 1;
        let mut j = n;
        while j > 0 && hit[j - 1].1 > entry[i] {
            hit[j] = hit[j - 1];
            j -= 1;
        }
        hit[j] = (node.child[i], entry[i]);
        n += 1;
    }
    (hit, n)
}

impl WideBvh {
    /// Builds the tree over `prims` (their boxes) with obvhs's PLOC and
    /// reinsertion parameters from `params`. Deterministic. Panics with
    /// more than [`MAX_PRIMITIVES`] primitives, which the scene loader
    /// refuses first.
    pub fn build<T: Boundable>(prims: &[T], params: BvhBuildParams) -> WideBvh {
        if prims.is_empty() {
            return WideBvh {
                nodes: Vec::new(),
                root: EMPTY,
                order: Vec::new(),
                stack: 0,
            };
        }
        if ploc_would_stall(prims) {
            return collapse(&median_split(prims));
        }
        let mut bvh2 = PlocBuilder::with_capacity(prims.len()).build(
            params.ploc_search_distance,
            prims,
            (0..prims.len() as u32).collect(),
            params.sort_precision,
            params.search_depth_threshold,
        );
        ReinsertionOptimizer::default().run(&mut bvh2, params.reinsertion_batch_ratio, None);
        collapse(&bvh2)
    }

    /// The primitives a ray tests on average, by the surface-area
    /// heuristic (MacDonald & Booth 1990): a random line through the root's
    /// box crosses a box inside it with the ratio of their surface areas,
    /// so each leaf adds its primitive count times its area over the
    /// root's. Deterministic and one pass over the nodes: what a scene's
    /// rays cost against another's, whatever they are cast for. A pile of
    /// overlapping triangles (instances nearly at one place) no tree can
    /// separate makes it grow with the pile; 0 for an empty tree.
    pub fn expected_tests(&self) -> f64 {
        if self.nodes.is_empty() || self.root & LEAF_BIT != 0 {
            return self.order.len().min(16) as f64;
        }
        let area = |node: &Node, k: usize| -> f64 {
            let e = [
                node.bounds[1][k] - node.bounds[0][k],
                node.bounds[3][k] - node.bounds[2][k],
                node.bounds[5][k] - node.bounds[4][k],
            ]
            .map(|d| d.max(0.0) as f64);
            e[0] * e[1] + e[1] * e[2] + e[2] * e[0]
        };
        let root = &self.nodes[self.root as usize];
        let mut lo = [f32::INFINITY; 3];
        let mut hi = [f32::NEG_INFINITY; 3];
        for k in 0..4 {
            if root.child[k] == EMPTY {
                continue;
            }
            for a in 0..3 {
                lo[a] = lo[a].min(root.bounds[2 * a][k]);
                hi[a] = hi[a].max(root.bounds[2 * a + 1][k]);
            }
        }
        let e = [0, 1, 2].map(|a| (hi[a] - lo[a]).max(0.0) as f64);
        let whole = e[0] * e[1] + e[1] * e[2] + e[2] * e[0];
        if !(whole > 0.0) {
            return self.order.len() as f64;
        }
        let mut tests = 0.0;
        let mut todo = vec![self.root];
        while let Some(n) = todo.pop() {
            let node = &self.nodes[n as usize];
            for k in 0..4 {
                let c = node.child[k];
                if c == EMPTY {
                    continue;
                }
                if c & LEAF_BIT != 0 {
                    tests += leaf_range(c).len() as f64 * area(node, k) / whole;
                } else {
                    todo.push(c);
                }
            }
        }
        tests
    }

    /// Visits the leaves whose boxes the ray enters within `[tmin, bound]`,
    /// nearest entry first, calling `leaf` with each one's slots; `leaf`
    /// returns the bound from then on (the distance of the best hit so
    /// far, say), which culls the leaves and nodes entered beyond it.
    /// `touch` is called with the slots of each leaf whose box the ray
    /// enters as soon as its parent is tested, before it is visited (if it
    /// is), to start loading its primitives ([`WideBvh::prefetch`]).
    #[inline]
    pub fn closest<T: Fn(Range<usize>), F: FnMut(Range<usize>) -> f32>(
        &self,
        ray: &BoxRay,
        bound: f32,
        touch: T,
        leaf: F,
    ) {
        if self.stack > STACK {
            self.closest_with(&mut vec![(0, 0.0); self.stack], ray, bound, touch, leaf);
        } else {
            self.closest_with(&mut [(0, 0.0); STACK], ray, bound, touch, leaf);
        }
    }

    #[inline(always)]
    fn closest_with<T: Fn(Range<usize>), F: FnMut(Range<usize>) -> f32>(
        &self,
        stack: &mut [(ChildRef, f32)],
        ray: &BoxRay,
        mut bound: f32,
        touch: T,
        mut leaf: F,
    ) {
        let mut sp = 0;
        let mut cur = self.root;
        'visit: loop {
            if cur & LEAF_BIT == 0 {
                let node = &self.nodes[cur as usize];
                let (mask, entry) = enter(node, ray, bound);
                if mask != 0 {
                    self.prefetch(node, mask, &touch);
                    let first = mask.trailing_zeros() as usize;
                    if mask & (mask - 1) == 0 {
                        cur = node.child[first];
                        continue 'visit;
                    }
                    let (hit, n) = nearest_first(node, mask, &entry);
                    for &h in hit[1..n].iter().rev() {
                        stack[sp] = h;
                        sp += 1;
                    }
                    cur = hit[0].0;
                    continue 'visit;
                }
            } else if cur != EMPTY {
                bound = leaf(leaf_range(cur));
            }
            loop {
                if sp == 0 {
                    return;
                }
                sp -= 1;
                let (next, entry) = stack[sp];
                if entry <= bound {
                    cur = next;
                    continue 'visit;
                }
            }
        }
    }

    /// Starts loading the children of `node` in `mask`, so that their
    /// cache misses overlap rather than follow one another as the
    /// traversal reaches them: inner nodes here, leaves by `touch`.
    #[inline(always)]
    fn prefetch<T: Fn(Range<usize>)>(&self, node: &Node, mask: u32, touch: &T) {
        let mut m = mask;
        while m != 0 {
            let c = node.child[m.trailing_zeros() as usize];
            m &= m - 1;
            if c & LEAF_BIT == 0 {
                prefetch(&self.nodes[c as usize]);
            } else if c != EMPTY {
                touch(leaf_range(c));
            }
        }
    }

    /// Whether `leaf` returns true for some leaf whose box the ray enters
    /// within `[tmin, tmax]`; it stops at the first. `touch` as in
    /// [`WideBvh::closest`].
    ///
    /// With `NEAREST_FIRST` the entered children are visited in order of
    /// their entry distance, as [`WideBvh::closest`] visits them, so that
    /// the leaf that answers is usually one near the ray's origin; without
    /// it, in the node's order, which costs no sort. The answer is the
    /// same either way when `leaf` answers by the leaf alone.
    #[inline]
    pub fn any<const NEAREST_FIRST: bool, T: Fn(Range<usize>), F: FnMut(Range<usize>) -> bool>(
        &self,
        ray: &BoxRay,
        tmax: f32,
        touch: T,
        leaf: F,
    ) -> bool {
        if self.stack > STACK {
            self.any_with::<NEAREST_FIRST, T, F>(&mut vec![0; self.stack], ray, tmax, touch, leaf)
        } else {
            self.any_with::<NEAREST_FIRST, T, F>(&mut [0; STACK], ray, tmax, touch, leaf)
        }
    }

    #[inline(always)]
    fn any_with<const NEAREST_FIRST: bool, T: Fn(Range<usize>), F: FnMut(Range<usize>) -> bool>(
        &self,
        stack: &mut [ChildRef],
        ray: &BoxRay,
        tmax: f32,
        touch: T,
        mut leaf: F,
    ) -> bool {
        let mut sp = 0;
        let mut cur = self.root;
        loop {
            if cur & LEAF_BIT == 0 {
                let node = &self.nodes[cur as usize];
                let (mask, entry) = enter(node, ray, tmax);
                if mask != 0 {
                    self.prefetch(node, mask, &touch);
                    let first = mask.trailing_zeros() as usize;
                    if mask & (mask - 1) == 0 {
                        cur = node.child[first];
                        continue;
                    }
                    if !NEAREST_FIRST {
                        let mut mask = mask & (mask - 1);
                        cur = node.child[first];
                        while mask != 0 {
                            stack[sp] = node.child[mask.trailing_zeros() as usize];
                            sp += 1;
                            mask &= mask - 1;
                        }
                        continue;
                    }
                    let (hit, n) = nearest_first(node, mask, &entry);
                    for &(child, _) in hit[1..n].iter().rev() {
                        stack[sp] = child;
                        sp += 1;
                    }
                    cur = hit[0].0;
                    continue;
                }
            } else if cur != EMPTY && leaf(leaf_range(cur)) {
                return true;
            }
            if sp == 0 {
                return false;
            }
            sp -= 1;
            cur = stack[sp];
        }
    }
}

/// Starts loading the cache lines of `*p` (a hint: nothing is read; none
/// off x86-64).
#[inline(always)]
pub(super) fn prefetch<T>(p: &T) {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
        let p = p as *const T as *const i8;
        for line in (0..size_of::<T>()).step_by(64) {
            // SAFETY: a prefetch is only a hint and reads nothing; `p +
            // line` lies within `*p`.
            unsafe { _mm_prefetch(p.add(line), _MM_HINT_T0) };
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = p;
}

/// Longest run of PLOC's sorted order without a merge, times the sum of
/// such runs over [`STALL_RUN`], above which [`ploc_would_stall`] says
/// PLOC would take quadratic time: 2²⁶ (a run of 8 192 among as many).
const STALL_WORK: u64 = 1 << 26;
/// Runs without a merge up to this long are PLOC's ordinary case.
const STALL_RUN: u64 = 64;

/// Whether PLOC (obvhs's builder) would take time quadratic in the
/// primitives: it merges only the pairs of neighbours in Morton order
/// that choose each other, and where many neighbouring primitives' pair
/// costs tie or run monotonically (coincident triangles, as a mesh
/// instanced many times at one place makes; boxes nested about one
/// centre; equal boxes at exactly equal steps) every one of them points
/// the same way and each pass merges one pair at the run's end: 96k
/// coincident triangles took 23 s, and doubling them quadrupled it
/// (BENCHMARKS.md, "BVH build"). This reads the Morton order as PLOC's
/// first passes do (search distance one: node `i` points right when
/// `cost(i, i+1) ≤ cost(i−1, i)`, a pair merges where they point at
/// each other) and measures the runs between merges. O(n log n).
fn ploc_would_stall<T: Boundable>(prims: &[T]) -> bool {
    if (prims.len() as u64) < 2 * STALL_RUN {
        return false;
    }
    let boxes: Vec<Aabb> = prims.iter().map(Boundable::aabb).collect();
    let mut total = Aabb::empty();
    for b in &boxes {
        total.extend(b.min);
        total.extend(b.max);
    }
    let size = (total.max - total.min).max(glam::Vec3A::splat(f32::MIN_POSITIVE));
    let spread = |v: u64| -> u64 {
        // 21 bits to every third bit of 63.
        let mut x = v & 0x1f_ffff;
        x = (x | x << 32) & 0x1f_0000_0000_ffff;
        x = (x | x << 16) & 0x1f_0000_ff00_00ff;
        x = (x | x << 8) & 0x100f_00f0_0f00_f00f;
        x = (x | x << 4) & 0x10c3_0c30_c30c_30c3;
        x = (x | x << 2) & 0x1249_2492_4924_9249;
        x
    };
    let mut order: Vec<(u64, u32)> = boxes
        .iter()
        .enumerate()
        .map(|(i, b)| {
            let c = ((b.min + b.max) * 0.5 - total.min) / size;
            let q = c.to_array().map(|v| (v.clamp(0.0, 1.0) * 2_097_151.0) as u64);
            (spread(q[0]) << 2 | spread(q[1]) << 1 | spread(q[2]), i as u32)
        })
        .collect();
    order.sort_unstable();
    let cost: Vec<f32> = order
        .windows(2)
        .map(|w| boxes[w[0].1 as usize].union(&boxes[w[1].1 as usize]).half_area())
        .collect();
    let (mut longest, mut stuck, mut since) = (0u64, 0u64, 0u64);
    let mut end_run = |run: u64| {
        longest = longest.max(run);
        if run > STALL_RUN {
            stuck += run;
        }
    };
    for i in 0..cost.len() {
        since += 1;
        let before = if i == 0 { f32::INFINITY } else { cost[i - 1] };
        let after = cost.get(i + 1).copied().unwrap_or(f32::INFINITY);
        if cost[i] <= before && cost[i] < after {
            end_run(since);
            since = 0;
        }
    }
    end_run(since + 1);
    longest.saturating_mul(stuck) > STALL_WORK
}

/// A binary tree of one primitive per leaf over `prims`, split top-down at
/// the median of the centroids along their longest extent (by index
/// where they coincide): depth ⌈log₂ n⌉, O(n log n) whatever the input,
/// the fallback where PLOC would stall ([`ploc_would_stall`]).
/// Deterministic (ties go by index). Children of node `k` lie at its
/// `first_index` and the next, as [`collapse`] reads them.
fn median_split<T: Boundable>(prims: &[T]) -> Bvh2 {
    let boxes: Vec<Aabb> = prims.iter().map(Boundable::aabb).collect();
    let mut index: Vec<u32> = (0..prims.len() as u32).collect();
    let mut nodes = vec![Bvh2Node::new(Aabb::empty(), 0, 0); 1];
    nodes.reserve(2 * prims.len());
    let mut todo = vec![(0usize, 0usize, prims.len())];
    while let Some((node, start, end)) = todo.pop() {
        let mut bounds = Aabb::empty();
        let mut centres = Aabb::empty();
        for &i in &index[start..end] {
            let b = &boxes[i as usize];
            bounds.extend(b.min);
            bounds.extend(b.max);
            centres.extend((b.min + b.max) * 0.5);
        }
        if end - start == 1 {
            nodes[node] = Bvh2Node::new(bounds, 1, start as u32);
            continue;
        }
        let extent = centres.max - centres.min;
        let axis = if extent.x >= extent.y && extent.x >= extent.z {
            0
        } else if extent.y >= extent.z {
            1
        } else {
            2
        };
        let mid = (start + end) / 2;
        if extent[axis] > 0.0 {
            let key = |i: &u32| {
                let b = &boxes[*i as usize];
                (b.min[axis] + b.max[axis], *i)
            };
            index[start..end].select_nth_unstable_by(mid - start, |a, b| {
                let (ka, kb) = (key(a), key(b));
                ka.0.total_cmp(&kb.0).then(ka.1.cmp(&kb.1))
            });
        }
        let first = nodes.len();
        nodes.push(Bvh2Node::new(Aabb::empty(), 0, 0));
        nodes.push(Bvh2Node::new(Aabb::empty(), 0, 0));
        nodes[node] = Bvh2Node::new(bounds, 0, first as u32);
        todo.push((first + 1, mid, end));
        todo.push((first, start, mid));
    }
    Bvh2 {
        nodes,
        primitive_indices: index,
        ..Bvh2::default()
    }
}

/// The 4-wide tree of `bvh2` (a tree of one primitive per leaf, root at
/// node 0); see the module docs.
fn collapse(bvh2: &Bvh2) -> WideBvh {
    let nodes2 = &bvh2.nodes;
    // Pre-order, so that reversed it visits children before parents.
    let mut pre = Vec::with_capacity(nodes2.len());
    let mut todo = vec![0u32];
    while let Some(n) = todo.pop() {
        pre.push(n);
        let node = &nodes2[n as usize];
        if !node.is_leaf() {
            todo.push(node.first_index + 1);
            todo.push(node.first_index);
        }
    }
    // Per binary node: its primitives, its SAH cost (in half-areas), and
    // whether it is to be a leaf.
    let mut count = vec![0u32; nodes2.len()];
    let mut cost = vec![0.0f32; nodes2.len()];
    let mut is_leaf = vec![false; nodes2.len()];
    for &n in pre.iter().rev() {
        let node = &nodes2[n as usize];
        let area = node.aabb.half_area();
        let n = n as usize;
        if node.is_leaf() {
            count[n] = node.prim_count;
            cost[n] = area * leaf_cost(node.prim_count);
            is_leaf[n] = true;
        } else {
            let (l, r) = (node.first_index as usize, node.first_index as usize + 1);
            count[n] = count[l] + count[r];
            let split = NODE_COST * area + cost[l] + cost[r];
            let whole = area * leaf_cost(count[n]);
            if count[n] <= MAX_LEAF && whole <= split {
                cost[n] = whole;
                is_leaf[n] = true;
            } else {
                cost[n] = split;
            }
        }
    }
    let mut bvh = WideBvh {
        nodes: Vec::new(),
        root: EMPTY,
        order: Vec::with_capacity(bvh2.primitive_indices.len()),
        stack: 0,
    };
    // Appends the primitives under binary node `n` to `order`, returning
    // the leaf's reference.
    let emit = |order: &mut Vec<u32>, n: u32| -> ChildRef {
        order.resize(order.len().next_multiple_of(LEAF_ALIGN), PAD);
        let first = order.len();
        let mut todo = vec![n];
        while let Some(n) = todo.pop() {
            let node = &nodes2[n as usize];
            if node.is_leaf() {
                let prims =
                    node.first_index as usize..(node.first_index + node.prim_count) as usize;
                order.extend_from_slice(&bvh2.primitive_indices[prims]);
            } else {
                todo.push(node.first_index + 1);
                todo.push(node.first_index);
            }
        }
        leaf_ref(first, order.len() - first)
    };
    if is_leaf[0] {
        bvh.root = emit(&mut bvh.order, 0);
        bvh.order
            .resize(bvh.order.len().next_multiple_of(LEAF_ALIGN), PAD);
        return bvh;
    }
    bvh.root = 0;
    bvh.nodes.push(Node::EMPTY);
    // (binary node, wide node made from it, its depth)
    let mut todo = vec![(0u32, 0u32, 1usize)];
    let mut depth = 0;
    while let Some((n, wide, d)) = todo.pop() {
        depth = depth.max(d);
        let first = nodes2[n as usize].first_index;
        let mut children = vec![first, first + 1];
        while children.len() < 4 {
            let open = children
                .iter()
                .enumerate()
                .filter(|&(_, &c)| !is_leaf[c as usize])
                .max_by(|a, b| {
                    let area = |c: u32| nodes2[c as usize].aabb.half_area();
                    area(*a.1).total_cmp(&area(*b.1))
                })
                .map(|(i, _)| i);
            let Some(i) = open else { break };
            let c = nodes2[children[i] as usize].first_index;
            children[i] = c;
            children.insert(i + 1, c + 1);
        }
        for (slot, &c) in children.iter().enumerate() {
            let r = if is_leaf[c as usize] {
                emit(&mut bvh.order, c)
            } else {
                let i = bvh.nodes.len() as u32;
                bvh.nodes.push(Node::EMPTY);
                todo.push((c, i, d + 1));
                i
            };
            bvh.nodes[wide as usize].set(slot, &nodes2[c as usize].aabb, r);
        }
    }
    bvh.order
        .resize(bvh.order.len().next_multiple_of(LEAF_ALIGN), PAD);
    // Each level of nodes pushes at most three entries.
    bvh.stack = 3 * depth + 1;
    bvh
}

#[cfg(test)]
mod tests {

    use glam::Vec3;

    #[test]
    fn a_pile_no_tree_separates_costs_a_ray_the_whole_pile() {
        // Unit quads' triangles side by side along x cost a ray a handful
        // of tests; the same count stacked 1e-6 apart costs it the stack.
        let quad = |x: f32, y: f32| {
            [
                [Vec3::new(x, y, 0.0), Vec3::new(x + 1.0, y, 0.0), Vec3::new(x + 1.0, y, 1.0)],
                [Vec3::new(x, y, 0.0), Vec3::new(x + 1.0, y, 1.0), Vec3::new(x, y, 1.0)],
            ]
        };
        let n = 2000;
        let row: Vec<[Vec3; 3]> = (0..n).flat_map(|i| quad(i as f32, 0.0)).collect();
        let pile: Vec<[Vec3; 3]> = (0..n).flat_map(|i| quad(0.0, i as f32 * 1e-6)).collect();
        let cost = |tris: &[[Vec3; 3]]| {
            let prims: Vec<obvhs::triangle::Triangle> = tris
                .iter()
                .map(|t| obvhs::triangle::Triangle {
                    v0: t[0].into(),
                    v1: t[1].into(),
                    v2: t[2].into(),
                })
                .collect();
            WideBvh::build(&prims, BvhBuildParams::medium_build()).expected_tests()
        };
        let (row, pile) = (cost(&row), cost(&pile));
        assert!(row < 50.0, "{row}");
        assert!(pile > 0.5 * (2 * n) as f64, "{pile}");
    }

    use super::*;

    #[test]
    fn leaf_references_reach_every_block_and_keep_their_range() {
        // The last block a reference addresses, and a leaf of 16 slots
        // (the most a count field holds) at the first.
        let last = (MAX_PRIMITIVES - 1) * LEAF_ALIGN;
        for (first, count) in [(0, 1), (0, 16), (4, 3), (last, 8), (last, 1)] {
            let r = leaf_ref(first, count);
            assert!(r & LEAF_BIT != 0 && r != EMPTY);
            assert_eq!(leaf_range(r), first..first + count);
        }
    }

    #[test]
    #[should_panic(expected = "a leaf of 1 primitives")]
    fn a_leaf_off_a_block_boundary_is_refused() {
        leaf_ref(2, 1);
    }

    #[test]
    fn the_tree_does_not_depend_on_the_thread_count() {
        // obvhs builds in parallel (its `parallel` feature): boxes of a
        // seeded soup, a tenth of them repeated (equal Morton codes and
        // equal reinsertion gains, where an unstable sort could order
        // them either way), built in pools of 1, 2 and 3 threads.
        use crate::sampling::{cube_point, hash2};
        use obvhs::triangle::Triangle;
        let tris: Vec<Triangle> = (0..20_000u64)
            .map(|i| {
                let h = hash2(77, if i % 10 == 0 { i / 10 } else { i });
                let c = cube_point(h);
                let e = |k: u64| (cube_point(hash2(h, k)) - 0.5) * 0.02;
                Triangle {
                    v0: (c + e(1)).into(),
                    v1: (c + e(2)).into(),
                    v2: (c + e(3)).into(),
                }
            })
            .collect();
        // Both presets SceneBvh uses (FAST_BUILD_TRIANGLES).
        for preset in [BvhBuildParams::medium_build(), BvhBuildParams::fast_build()] {
            let build = |threads: usize| {
                let pool = rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .build()
                    .unwrap();
                let bvh = pool.install(|| WideBvh::build(&tris, preset));
                (
                    bvh.order.clone(),
                    format!("{:?}", bvh.nodes),
                    bvh.root,
                    bvh.stack,
                )
            };
            let one = build(1);
            assert!(one.0.len() >= tris.len());
            for threads in [2, 3] {
                assert!(
                    build(threads) == one,
                    "the tree built on {threads} threads differs"
                );
            }
        }
    }
}
