//! The fewest probes that see everything (Wang et al. 2019's headline
//! claim): after refinement, fill the holes and drop the superfluous probes,
//! judged by the independent coverage measure (the `coverage` module's
//! surface samples and visibility rule), not by the atlas.
//!
//! Both steps read a visibility matrix: for every probe, the bit set of the
//! coverable samples it sees, computed once per probe with the coverage
//! module's own [`CoverageReference::sees`], so the coverage they reach is
//! exactly the coverage the report will print.
//!
//! * **Fill** is greedy set cover over candidate positions: while coverage
//!   is under the target, add the candidate that sees the most coverable
//!   samples no probe sees (ties: the earlier candidate). Candidates come in
//!   tiers of decreasing clearance (the caller's: positions where a probe
//!   may stand at the placement's clearance first, then nearer surfaces),
//!   and a tier is used only for the holes the tiers before it cannot see.
//!   With more than [`MAX_SCORED_HOLES`] holes, candidates are scored on an
//!   even subsample of them; coverage is then recounted exactly and the
//!   holes that remain are scored again, so filling ends only when the
//!   target holds or no candidate sees any remaining hole.
//! * **Prune** is reverse greedy ([`super::cover::reverse_greedy`], which
//!   the tiles' merge runs too): while some probe can go, drop the one that
//!   alone sees the fewest samples (ties: the one nearest a surface, by
//!   tier; then the one that sees fewest overall; then the later one). A
//!   probe can go when coverage without it stays at or above the target,
//!   or, when the target is out of reach, when nothing depends on it alone.
//! * **Merge** ([`CoverMatrix::merge_pairs`]) then replaces pairs of
//!   neighbours by one position that keeps the target, and pruning runs
//!   again. Both run once more after polish (src/refine/polish.rs) moves
//!   the probes, since a moved probe can leave another with nothing of its
//!   own to see; not under a `min_probes` minimum, whose extra probes are
//!   there by design.
//!
//! **Demand and the artist controls** ([`crate::placement::controls`]).
//! Each coverable sample needs a number of views, 1 unless a
//! `probe_density` region says otherwise ([`CoverMatrix::with_need`]); a
//! sample counts as covered once that many probes see it, and one that
//! needs none is not counted at all. With every need 1 this is plain
//! coverage and every step above is unchanged. The first `pinned` probes
//! (the fixed ones) are never pruned or merged; a budget (`max_probes`)
//! keeps, after pruning, the probes that give the most of the demanded
//! views ([`CoverMatrix::select`]).

use super::cover::{reverse_greedy, Prunable, Standing};
use crate::coverage::{CoverageReference, SurfaceSample};
use crate::progress::Progress;
use crate::scene::raycast::{Blocker, SceneBvh};
use glam::Vec3;
use indicatif::ProgressBar;
use kiddo::{ImmutableKdTree, SquaredEuclidean};
use rayon::prelude::*;
use std::num::NonZero;

/// A set of sample indices as 64-bit words.
pub(super) type Bits = Vec<u64>;

/// One fill pass: its live candidates (position, tier) and its budget of
/// subsampled scoring rounds (`None`: unlimited, the final pass over all
/// tiers).
type Pass = (Vec<(Vec3, usize)>, Option<usize>);

/// Most holes candidates are scored on when filling: beyond it the scoring
/// (candidates × holes visibility tests) would dominate the run on scenes
/// far from the target, and an even subsample ranks candidates as well.
pub const MAX_SCORED_HOLES: usize = 2048;

/// Nearest live probes each probe is tried with for a merge (see
/// [`CoverMatrix::merge_pairs`]): six, the face neighbours a probe has in
/// a three-dimensional arrangement, so that a probe is paired along every
/// axis, not only towards the nearest side. Three (one per axis at best)
/// left one probe too many at the configs' own seeds in the Cornell box
/// with spheres (10 vs 9) and Sponza (49 vs 48), and none of 55 runs (11
/// configs × 5 seeds) kept fewer probes than six. It is a greedy step, so
/// more pairs is not better everywhere: over the 74 runs of the generated
/// suite (docs/results.md) six kept 1478 probes against 1487, fewer in 9
/// runs and more in 6 (by 1 or 2). The extra pairs cost no measurable
/// time (BENCHMARKS.md, fifth session).
pub const MERGE_NEIGHBOURS: usize = 6;

/// Candidates nearest a pair's midpoint scored as its replacement.
pub const MERGE_CANDIDATES: usize = 256;

/// Pairs [`CoverMatrix::merge_pairs`] scores at once, in parallel. The
/// answer does not depend on it: a batch only costs the scoring of the
/// pairs after a merge in it, which are scored again after the merge.
const MERGE_BATCH: usize = 8;

/// Most 64-bit words [`CoverMatrix::select`]'s swap search scores (a
/// fraction of a second): a budget of a few probes among a hundred gets
/// hundreds of passes, one of thousands among thousands none.
pub const MAX_SWAP_WORDS: u64 = 1 << 27;

/// Viewers one task of [`CoverMatrix::columns_of`] tests from each of its
/// samples: enough that consecutive rays share their start, few enough
/// that a small matrix still makes a task for every thread.
const VIEWER_RUN: usize = 64;

/// Most 64-bit words of columns [`CoverMatrix::columns_of`] computes
/// before copying them into place (32 MiB).
const WORDS_IN_FLIGHT: usize = 1 << 22;

/// Partial scorings (on a subsample of the holes) one tier of candidates
/// gets before filling moves on to the next (see [`CoverMatrix::fill`]).
pub const SUBSAMPLES_PER_TIER: usize = 2;

fn popcount(bits: &[u64]) -> u32 {
    bits.iter().map(|w| w.count_ones()).sum()
}

fn popcount_and(a: &[u64], b: &[u64]) -> u32 {
    a.iter().zip(b).map(|(x, y)| (x & y).count_ones()).sum()
}

/// The indices of the set bits, ascending.
pub(super) fn ones(bits: &[u64]) -> impl Iterator<Item = usize> + '_ {
    bits.iter()
        .enumerate()
        .flat_map(|(w, &word)| set_bits(word).map(move |b| w * 64 + b))
}

/// The indices set in `a` or `b` (of equal length), ascending.
fn ones_either<'a>(a: &'a [u64], b: &'a [u64]) -> impl Iterator<Item = usize> + 'a {
    a.iter()
        .zip(b)
        .enumerate()
        .flat_map(|(w, (&x, &y))| set_bits(x | y).map(move |b| w * 64 + b))
}

/// The set bits of `word`, lowest first.
fn set_bits(mut word: u64) -> impl Iterator<Item = usize> {
    std::iter::from_fn(move || {
        (word != 0).then(|| {
            let b = word.trailing_zeros() as usize;
            word &= word - 1;
            b
        })
    })
}

/// The coverable samples of a coverage reference and who sees them.
pub struct CoverMatrix<'r> {
    reference: &'r CoverageReference,
    bvh: &'r SceneBvh,
    /// Indices into `reference.samples` of the coverable samples.
    coverable: Vec<usize>,
    /// Views each coverable sample needs (module docs): 1 everywhere
    /// unless [`CoverMatrix::with_need`] says otherwise.
    need: Vec<u32>,
}

/// What the caller holds fixed while filling and pruning: the first
/// `pinned` positions stay, and at most `budget` probes are kept.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Rules {
    /// The first this many input positions are never dropped.
    pub pinned: usize,
    /// The most probes kept.
    pub budget: Option<usize>,
    /// The fewest probes kept: below it, [`CoverMatrix::top_up`] adds the
    /// ones that sharpen the views most.
    pub minimum: Option<usize>,
}

/// The probes the steps after filling work on (pruning, merging, polish,
/// top-up): every position seen so far, in order (the input probes, those
/// filling added, then each one a later step added), with its view column
/// and candidate tier, whether it is alive, and how many live probes see
/// each coverable sample. A probe that moves dies and is appended again,
/// so indices never shift.
pub(super) struct Working {
    /// Positions.
    pub(super) all: Vec<Vec3>,
    /// The coverable samples each one sees.
    pub(super) cols: Vec<Bits>,
    /// The candidate tier each one came from (0 for the input probes).
    pub(super) tier_of: Vec<usize>,
    /// Whether each one is still in the set.
    pub(super) alive: Vec<bool>,
    /// Per coverable sample, the live probes that see it.
    pub(super) count: Vec<u32>,
}

impl Working {
    /// Live probes at `all`, from `tier_of`'s tiers, seeing `cols`.
    #[cfg(test)]
    pub(super) fn new(
        all: Vec<Vec3>,
        cols: Vec<Bits>,
        tier_of: Vec<usize>,
        samples: usize,
    ) -> Working {
        let mut count = vec![0u32; samples];
        for c in &cols {
            for i in ones(c) {
                count[i] += 1;
            }
        }
        Working {
            alive: vec![true; all.len()],
            all,
            cols,
            tier_of,
            count,
        }
    }

    /// Appends a live probe at `p`, of tier `tier`, that sees `col`.
    pub(super) fn push(&mut self, p: Vec3, col: Bits, tier: usize) {
        for i in ones(&col) {
            self.count[i] += 1;
        }
        self.all.push(p);
        self.cols.push(col);
        self.tier_of.push(tier);
        self.alive.push(true);
    }

    /// Takes probe `k` out of the set.
    pub(super) fn kill(&mut self, k: usize) {
        self.alive[k] = false;
        for i in ones(&self.cols[k]) {
            self.count[i] -= 1;
        }
    }

    /// How many probes are alive.
    pub(super) fn live(&self) -> usize {
        self.alive.iter().filter(|&&a| a).count()
    }
}

/// One round of filling (see [`CoverMatrix::fill_and_prune`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub struct FillRound {
    /// Candidate tier filled from (0: the placement's clearance), or the
    /// number of tiers for the last sweep over all of them.
    pub tier: usize,
    /// Holes at the start of the round.
    pub holes: usize,
    /// Holes the candidates were scored on.
    pub scored: usize,
    /// Probes added.
    pub added: usize,
    /// Coverable samples covered after the round, counted exactly.
    pub covered: usize,
}

/// What filling added.
#[derive(Debug, Clone, Default, PartialEq)]
pub(super) struct Filled {
    /// Positions added, in order.
    pub(super) added: Vec<Vec3>,
    /// The candidate tier of each.
    pub(super) tiers: Vec<usize>,
    /// The rounds of filling.
    pub(super) rounds: Vec<FillRound>,
}

/// Result of [`CoverMatrix::fill_and_prune`].
#[derive(Debug, Clone, PartialEq)]
pub struct FillPrune {
    /// Final probes, as indices into `positions ++ added`.
    pub kept: Vec<usize>,
    /// The candidate tier of each kept probe (0 for the input probes).
    pub kept_tiers: Vec<usize>,
    /// Probes added by filling (some may have been pruned again).
    pub added: Vec<Vec3>,
    /// The rounds of filling, in order.
    pub rounds: Vec<FillRound>,
    /// Coverable samples the input probes see.
    pub covered_initial: usize,
    /// Coverable samples the final probes see.
    pub covered_final: usize,
    /// Coverable samples that need a view (all of them, without
    /// `probe_density`).
    pub coverable: usize,
    /// Probes kept before the budget cut them, when it did.
    pub before_budget: Option<usize>,
    /// Probes kept before the top-up added to them, when it did.
    pub before_minimum: Option<usize>,
    /// The column of each kept probe, in the order of `kept`.
    pub(super) kept_cols: Vec<Bits>,
}

impl<'r> CoverMatrix<'r> {
    /// The matrix over `reference`'s coverable samples.
    pub fn new(reference: &'r CoverageReference, bvh: &'r SceneBvh) -> CoverMatrix<'r> {
        let coverable: Vec<usize> = (0..reference.samples.len())
            .filter(|&i| reference.coverable[i])
            .collect();
        let need = vec![1; coverable.len()];
        CoverMatrix {
            reference,
            bvh,
            coverable,
            need,
        }
    }

    /// The matrix with each coverable sample needing `need(index, position)`
    /// views (`index` into the reference's samples).
    pub fn with_need(mut self, need: impl Fn(usize, Vec3) -> u32) -> CoverMatrix<'r> {
        self.need = self
            .coverable
            .iter()
            .map(|&i| need(i, self.reference.samples[i].position))
            .collect();
        self
    }

    /// Coverable samples that need at least one view.
    pub fn demanded(&self) -> usize {
        self.need.iter().filter(|&&n| n > 0).count()
    }

    /// Samples with as many views in `count` as they need (and needing one).
    pub(super) fn satisfied(&self, count: &[u32]) -> usize {
        count
            .iter()
            .zip(&self.need)
            .filter(|&(&c, &n)| n > 0 && c >= n)
            .count()
    }

    /// Per coverable sample, 1 where `seen` (one flag per sample of the
    /// reference) says some probe sees it, else 0: the view counts of a
    /// probe set known only by whether it sees each sample, enough for
    /// [`CoverMatrix::fill`] when every need is 1.
    pub(super) fn counts_of_seen(&self, seen: &[bool]) -> Vec<u32> {
        self.coverable.iter().map(|&i| seen[i] as u32).collect()
    }

    /// Whether sample `i` still needs a view, by `count`.
    fn open(&self, count: &[u32], i: usize) -> bool {
        count[i] < self.need[i]
    }

    /// Keeps, of the probes at `positions`, the first `pinned` and then
    /// greedily the one that gives the most demanded views still missing
    /// (ties: the earlier), until `budget` probes are kept or none adds
    /// anything; then trades kept probes for others while that covers more
    /// (a 1-swap local search). Returns the kept indices, ascending.
    pub fn select(&self, positions: &[Vec3], pinned: usize, budget: usize) -> Vec<usize> {
        self.select_columns(&self.columns(positions), pinned, budget)
    }

    fn select_columns(&self, cols: &[Bits], pinned: usize, budget: usize) -> Vec<usize> {
        let mut count = vec![0u32; self.len()];
        let mut chosen = vec![false; cols.len()];
        let take = |k: usize, count: &mut [u32], chosen: &mut [bool]| {
            chosen[k] = true;
            for i in ones(&cols[k]) {
                count[i] += 1;
            }
        };
        for k in 0..pinned.min(cols.len()) {
            take(k, &mut count, &mut chosen);
        }
        let mut kept = pinned.min(cols.len());
        while kept < budget {
            let mut open: Bits = vec![0; count.len().div_ceil(64)];
            for i in 0..count.len() {
                if self.open(&count, i) {
                    open[i / 64] |= 1 << (i % 64);
                }
            }
            let (best, gain) = (0..cols.len())
                .filter(|&k| !chosen[k])
                .map(|k| (k, popcount_and(&cols[k], &open)))
                .fold((usize::MAX, 0), |acc, x| if x.1 > acc.1 { x } else { acc });
            if gain == 0 {
                break;
            }
            take(best, &mut count, &mut chosen);
            kept += 1;
        }
        self.swap_search(cols, pinned, &mut count, &mut chosen);
        (0..cols.len()).filter(|&k| chosen[k]).collect()
    }

    /// A 1-swap local search after the greedy choice: trades a chosen
    /// (unpinned) probe for an unchosen one while that raises the demanded
    /// samples covered, the best trade first (ties: the smallest pair).
    /// Every trade raises the count, so it ends; it also stops after
    /// [`MAX_SWAP_WORDS`] words of scoring, so a large budget stays cheap.
    fn swap_search(&self, cols: &[Bits], pinned: usize, count: &mut [u32], chosen: &mut [bool]) {
        let covers = |c: u32, n: u32| (n > 0 && c >= n) as i64;
        let words = count.len().div_ceil(64) as u64;
        let mut spent = 0u64;
        loop {
            let ins: Vec<usize> = (pinned..cols.len()).filter(|&k| chosen[k]).collect();
            let outs: Vec<usize> = (0..cols.len()).filter(|&k| !chosen[k]).collect();
            spent += ins.len() as u64 * outs.len() as u64 * words;
            if spent > MAX_SWAP_WORDS {
                break;
            }
            let count_now: &[u32] = count;
            let best = ins
                .par_iter()
                .flat_map_iter(|&k| outs.iter().map(move |&c| (k, c)))
                .map(|(k, c)| {
                    let mut delta = 0i64;
                    for (w, (&a, &b)) in cols[k].iter().zip(&cols[c]).enumerate() {
                        let mut differ = a ^ b;
                        while differ != 0 {
                            let t = differ.trailing_zeros();
                            differ &= differ - 1;
                            let i = w * 64 + t as usize;
                            let after = if a >> t & 1 == 1 {
                                count_now[i] - 1
                            } else {
                                count_now[i] + 1
                            };
                            delta +=
                                covers(after, self.need[i]) - covers(count_now[i], self.need[i]);
                        }
                    }
                    (delta, k, c)
                })
                .filter(|&(delta, _, _)| delta > 0)
                .min_by_key(|&(delta, k, c)| (std::cmp::Reverse(delta), k, c));
            let Some((_, k, c)) = best else { break };
            chosen[k] = false;
            for i in ones(&cols[k]) {
                count[i] -= 1;
            }
            chosen[c] = true;
            for i in ones(&cols[c]) {
                count[i] += 1;
            }
        }
    }

    /// Number of coverable samples.
    pub fn len(&self) -> usize {
        self.coverable.len()
    }

    /// Whether there is no coverable sample.
    pub fn is_empty(&self) -> bool {
        self.coverable.is_empty()
    }

    /// Columns of all coverable samples for every viewer (see
    /// [`CoverMatrix::columns_of`]).
    pub(super) fn columns(&self, viewers: &[Vec3]) -> Vec<Bits> {
        let all: Vec<usize> = (0..self.len()).collect();
        self.columns_of(viewers, &all, &ProgressBar::hidden())
    }

    /// [`CoverMatrix::columns_of`] of `viewers` over `subset`, for viewers
    /// whose columns over the samples `earlier.0` are `earlier.1`: only the
    /// samples of `subset` not among those are tested.
    pub(super) fn columns_after(
        &self,
        viewers: &[Vec3],
        subset: &[usize],
        earlier: (&[usize], &[Bits]),
        bar: &ProgressBar,
    ) -> Vec<Bits> {
        let (before, before_cols) = earlier;
        let mut slot = vec![u32::MAX; self.len()];
        for (b, &i) in before.iter().enumerate() {
            slot[i] = b as u32;
        }
        let fresh: Vec<usize> = subset
            .iter()
            .copied()
            .filter(|&i| slot[i] == u32::MAX)
            .collect();
        let fresh_cols = self.columns_of(viewers, &fresh, bar);
        let bit = |bits: &Bits, b: usize| bits[b / 64] >> (b % 64) & 1 == 1;
        before_cols
            .par_iter()
            .zip(&fresh_cols)
            .map(|(old, new)| {
                let mut bits = vec![0u64; subset.len().div_ceil(64)];
                let mut f = 0;
                for (b, &i) in subset.iter().enumerate() {
                    let seen = match slot[i] {
                        u32::MAX => {
                            f += 1;
                            bit(new, f - 1)
                        }
                        s => bit(old, s as usize),
                    };
                    if seen {
                        bits[b / 64] |= 1 << (b % 64);
                    }
                }
                bits
            })
            .collect()
    }

    /// For each of `viewers`, the coverable samples among `subset` (indices
    /// into `self.coverable`) it sees, as bits over `subset`; `bar` counts
    /// the tasks done.
    ///
    /// Computed sample by sample, not viewer by viewer (whether a viewer
    /// sees a sample does not depend on the order): a task takes a word of
    /// 64 samples and a run of [`VIEWER_RUN`] viewers (in a Morton order of
    /// their positions) and tests the whole run from each sample in turn.
    /// A segment's traversal starts at the sample, and hole samples are
    /// mostly hidden by geometry near them, so consecutive rays from one
    /// sample revisit the same nodes and triangles: on a 5.4M-triangle city
    /// block, 1024 fill candidates against 1793 holes took 0.4 s on one
    /// thread this way and 1 s a column per candidate (whose rays start all
    /// over the scene).
    /// Words go in blocks of at most [`WORDS_IN_FLIGHT`] words over all
    /// viewers, so the results in flight stay a bounded copy of the columns.
    /// A worker's memories of blockers ([`SceneBvh::occluded_between`]: one
    /// for the sample, one per place in the run) carry over from task to
    /// task rather than starting empty every 64 samples: a column of one
    /// new probe (a fill pick, a merge, a polish move) is 640 tasks on
    /// Dabrovic Sponza, and the walls around the probe hide it from the
    /// next word's samples too. The answers do not depend on what a memory
    /// holds; on Sponza refinement's traversals fell from 3.10M to 2.94M.
    pub(super) fn columns_of(
        &self,
        viewers: &[Vec3],
        subset: &[usize],
        bar: &ProgressBar,
    ) -> Vec<Bits> {
        let words = subset.len().div_ceil(64);
        let mut cols: Vec<Bits> = vec![vec![0; words]; viewers.len()];
        let order = crate::sampling::morton_order(viewers);
        let runs: Vec<&[usize]> = order.chunks(VIEWER_RUN).collect();
        let block = (WORDS_IN_FLIGHT / viewers.len().max(1)).max(1);
        bar.set_length((words * runs.len()) as u64);
        for first in (0..words).step_by(block) {
            let tasks: Vec<(usize, &[usize])> = (first..(first + block).min(words))
                .flat_map(|w| runs.iter().map(move |&run| (w, run)))
                .collect();
            let done: Vec<Vec<u64>> = tasks
                .par_iter()
                .map_init(
                    || (Blocker::default(), vec![Blocker::default(); VIEWER_RUN]),
                    |(near_sample, near_viewer), &(w, run)| {
                        let mut bits = vec![0u64; run.len()];
                        let samples = &subset[w * 64..(w * 64 + 64).min(subset.len())];
                        for (bit, &i) in samples.iter().enumerate() {
                            let s = self.sample(i);
                            for ((slot, &v), near) in
                                bits.iter_mut().zip(run).zip(near_viewer.iter_mut())
                            {
                                if self.reference.sees_between::<false>(
                                    self.bvh,
                                    viewers[v],
                                    s,
                                    near_sample,
                                    near,
                                ) {
                                    *slot |= 1 << bit;
                                }
                            }
                        }
                        bar.inc(1);
                        bits
                    },
                )
                .collect();
            for (&(w, run), bits) in tasks.iter().zip(&done) {
                for (&v, &b) in run.iter().zip(bits) {
                    cols[v][w] = b;
                }
            }
        }
        cols
    }

    /// For the probes at `viewers`: the coverable samples some of them sees,
    /// and the mean incidence angle (degrees) of each covered sample's best
    /// view, lower being better and 0 head-on (§3.2 "Probe View
    /// Distortion"; `None` when nothing is covered).
    ///
    /// Each sample tries its viewers best view first and stops at the
    /// first that sees it: that one is its best view, so the answer is
    /// [`CoverMatrix::summary_of`]'s over all columns, without testing
    /// every viewer against every sample.
    pub fn summary(&self, viewers: &[Vec3]) -> (usize, Option<f64>) {
        let best: Vec<Option<f32>> = (0..self.len())
            .into_par_iter()
            .map_init(
                || (Vec::new(), Blocker::default()),
                |(order, blocker): &mut (Vec<(f32, usize)>, Blocker), i| {
                    let s = self.sample(i);
                    order.clear();
                    order.extend(
                        viewers
                            .iter()
                            .enumerate()
                            .map(|(k, &v)| (view_cos(s, v), k)),
                    );
                    order.sort_unstable_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
                    order
                        .iter()
                        .find(|&&(_, k)| self.reference.sees_from(self.bvh, viewers[k], s, blocker))
                        .map(|&(c, _)| c)
                },
            )
            .collect();
        mean_incidence(best)
    }

    /// [`CoverMatrix::summary`] of the probes at `viewers` whose columns
    /// (as [`CoverMatrix::columns`] gives them) are `cols`.
    pub(super) fn summary_of(&self, viewers: &[Vec3], cols: &[Bits]) -> (usize, Option<f64>) {
        let best: Vec<Option<f32>> = (0..self.len())
            .into_par_iter()
            .with_min_len(256)
            .map(|i| {
                let s = self.sample(i);
                cols.iter()
                    .zip(viewers)
                    .filter(|(c, _)| c[i / 64] >> (i % 64) & 1 == 1)
                    .map(|(_, &v)| view_cos(s, v))
                    .reduce(f32::max)
            })
            .collect();
        mean_incidence(best)
    }

    /// Fills and prunes (module docs) the probes at `positions` towards
    /// `target` (a share of the coverable samples), filling from the
    /// candidate `tiers` in order (see [`CoverMatrix::fill`]).
    ///
    /// Contract: deterministic; if the input or filling reaches the target,
    /// the final probes do too; the final probes never see fewer samples
    /// than `min(target, what positions ++ added see)` requires. When the
    /// last tier holds every reference point of the coverage measure, filling
    /// reaches the target whatever the input (every coverable sample is seen
    /// by some reference point).
    #[allow(clippy::too_many_arguments)]
    pub fn fill_and_prune(
        &self,
        positions: &[Vec3],
        tiers: &[Vec<Vec3>],
        target: f64,
        fill: bool,
        prune: bool,
        rules: Rules,
        progress: &Progress,
    ) -> FillPrune {
        let m = self.len();
        let demanded = self.demanded();
        let target_count = ((target * demanded as f64).ceil() as usize).min(demanded);
        let mut cols = self.columns(positions);
        let mut count = vec![0u32; m];
        for c in &cols {
            for i in ones(c) {
                count[i] += 1;
            }
        }
        let covered_initial = self.satisfied(&count);
        let mut filled = Filled::default();
        if fill {
            filled = self.fill(
                tiers,
                target_count,
                MAX_SCORED_HOLES,
                &mut cols,
                &mut count,
                progress,
            );
        }
        let mut tier_of = vec![0usize; positions.len()];
        tier_of.extend(&filled.tiers);
        let mut all: Vec<Vec3> = positions.to_vec();
        all.extend(&filled.added);
        let mut w = Working {
            alive: vec![true; cols.len()],
            all,
            cols,
            tier_of,
            count,
        };
        let mut covered = self.satisfied(&w.count);
        let pinned = rules.pinned.min(positions.len());
        let mut changed = 0;
        if prune {
            let merged;
            (covered, merged) = self.prune_and_merge(tiers, &mut w, pinned, covered, target_count);
            changed += merged;
        }
        // The budget coverage does not need goes where views sharpen most
        // (topup.rs), before polish moves them all.
        let mut before_minimum = None;
        if let Some(minimum) = rules.minimum {
            let live = w.live();
            let added = self.top_up(tiers, &mut w, minimum);
            before_minimum = (added > 0).then_some(live);
            changed += added;
        }
        if prune {
            changed += self.polish(tiers, &mut w, pinned, target_count);
            // Polish's moves can leave a probe, or a pair, with nothing of
            // its own to see; a top-up's probes are there for the minimum.
            if rules.minimum.is_none() {
                let merged;
                covered = self.satisfied(&w.count);
                (covered, merged) =
                    self.prune_and_merge(tiers, &mut w, pinned, covered, target_count);
                changed += merged;
            }
        }
        if changed > 0 {
            filled.added = w.all[positions.len()..].to_vec();
            filled.tiers = w.tier_of[positions.len()..].to_vec();
            covered = self.satisfied(&w.count);
        }
        let mut kept: Vec<usize> = (0..w.cols.len()).filter(|&k| w.alive[k]).collect();
        let mut before_budget = None;
        if let Some(budget) = rules.budget.filter(|&b| kept.len() > b) {
            // Every probe seen so far is a candidate, pruned ones too: under
            // a budget, one probe that sees much can beat two that pruning
            // kept for what only they see.
            before_budget = Some(kept.len());
            kept = self.select_columns(&w.cols, pinned, budget);
            let mut sel = vec![0u32; m];
            for &k in &kept {
                for i in ones(&w.cols[k]) {
                    sel[i] += 1;
                }
            }
            covered = self.satisfied(&sel);
        }
        let kept_tiers = kept.iter().map(|&k| w.tier_of[k]).collect();
        let kept_cols = kept.iter().map(|&k| w.cols[k].clone()).collect();
        FillPrune {
            kept,
            kept_tiers,
            added: filled.added,
            rounds: filled.rounds,
            covered_initial,
            covered_final: covered,
            coverable: demanded,
            before_budget,
            before_minimum,
            kept_cols,
        }
    }

    /// Pruning, then pair merges, then pruning again if a pair merged:
    /// returns how many samples the live probes of `w` cover (`covered`
    /// before) and how many pairs merged.
    fn prune_and_merge(
        &self,
        tiers: &[Vec<Vec3>],
        w: &mut Working,
        pinned: usize,
        covered: usize,
        target_count: usize,
    ) -> (usize, usize) {
        let covered = self.prune_greedy(w, pinned, covered, target_count);
        let merged = self.merge_pairs(tiers, w, pinned, covered, target_count);
        if merged == 0 {
            return (covered, 0);
        }
        let covered = self.satisfied(&w.count);
        (self.prune_greedy(w, pinned, covered, target_count), merged)
    }

    /// Greedy set cover of the holes (coverable samples with `count` 0)
    /// from the candidate tiers, in order, until `target_count` samples are
    /// covered; appends the added probes' columns to `cols` and their
    /// counts to `count`.
    ///
    /// A tier's candidates are scored on an even subsample of at most
    /// `max_scored` of the holes. Each round adds candidates greedily on
    /// the subsample's uncovered holes (each standing for its share of the
    /// real ones) until the estimate reaches the target, then recounts the
    /// holes exactly; the next round goes on from the same scores with the
    /// share updated, and a fresh subsample of the holes that remain is
    /// scored only when the old one is used up. A subsample that yields
    /// nothing gives way to the next disjoint one. A tier gets at most
    /// [`SUBSAMPLES_PER_TIER`] subsamples of a partial scoring (beyond them
    /// its candidates see too few of the remaining holes to be worth the
    /// scoring, and the nearer tiers see them better); a last sweep over
    /// every tier's candidates has no such limit and ends only when none of
    /// them sees any remaining hole, every hole having been scored. So
    /// filling never stops on a subsample: it stops when the target holds
    /// or no candidate sees a remaining hole.
    pub(super) fn fill(
        &self,
        tiers: &[Vec<Vec3>],
        target_count: usize,
        max_scored: usize,
        cols: &mut Vec<Bits>,
        count: &mut [u32],
        progress: &Progress,
    ) -> Filled {
        let mut out = Filled::default();
        let demanded = self.demanded();
        let mut covered = self.satisfied(count);
        let tagged = |t: usize| tiers[t].iter().map(move |&p| (p, t));
        let mut passes: Vec<Pass> = (0..tiers.len())
            .map(|t| (tagged(t).collect(), Some(SUBSAMPLES_PER_TIER)))
            .collect();
        passes.push(((0..tiers.len()).flat_map(tagged).collect(), None));
        for (pass, (mut live, mut budget)) in passes.into_iter().enumerate() {
            // Candidates that see none of the holes, all of them scored,
            // never will: holes only shrink.
            let mut phase = 0;
            // The pass's last subsample and, for each live candidate, its
            // column over it: holes scored then are not scored again.
            let mut scored: Option<(Vec<usize>, Vec<Bits>)> = None;
            while covered < target_count && !live.is_empty() {
                let holes: Vec<usize> = (0..count.len()).filter(|&i| self.open(count, i)).collect();
                let stride = holes.len().div_ceil(max_scored).max(1);
                if phase >= stride {
                    break;
                }
                if stride > 1 {
                    match budget.as_mut() {
                        Some(0) => break,
                        Some(b) => *b -= 1,
                        None => {}
                    }
                }
                let sub: Vec<usize> = holes.iter().copied().skip(phase).step_by(stride).collect();
                let bar = progress.bar("refine: fill", 0);
                let at: Vec<Vec3> = live.iter().map(|&(c, _)| c).collect();
                let cand_cols = match &scored {
                    Some((before, cols)) => self.columns_after(&at, &sub, (before, cols), &bar),
                    None => self.columns_of(&at, &sub, &bar),
                };
                bar.finish_and_clear();
                let mut remaining: Bits = vec![0; sub.len().div_ceil(64)];
                for i in 0..sub.len() {
                    remaining[i / 64] |= 1 << (i % 64);
                }
                let mut any = false;
                let mut picked = vec![false; live.len()];
                while covered < target_count {
                    let holes_now = demanded - covered;
                    let weight = holes_now as f64 / popcount(&remaining).max(1) as f64;
                    let picks =
                        greedy_on(&cand_cols, &mut remaining, covered, weight, target_count);
                    if picks.is_empty() {
                        break;
                    }
                    any = true;
                    let positions: Vec<Vec3> = picks.iter().map(|&j| live[j].0).collect();
                    for &j in &picks {
                        picked[j] = true;
                    }
                    for c in self.columns(&positions) {
                        for i in ones(&c) {
                            count[i] += 1;
                        }
                        cols.push(c);
                    }
                    covered = self.satisfied(count);
                    out.rounds.push(FillRound {
                        tier: pass,
                        holes: holes_now,
                        scored: sub.len(),
                        added: picks.len(),
                        covered,
                    });
                    out.tiers.extend(picks.iter().map(|&j| live[j].1));
                    out.added.extend(positions);
                }
                // A candidate stands for one view: once added it is not a
                // candidate again (with every need 1 it would see no hole).
                let keep: Vec<bool> = cand_cols
                    .iter()
                    .zip(&picked)
                    .map(|(c, &p)| !p && (stride > 1 || c.iter().any(|&w| w != 0)))
                    .collect();
                live = live
                    .iter()
                    .zip(&keep)
                    .filter(|(_, &k)| k)
                    .map(|(&p, _)| p)
                    .collect();
                let kept_cols = cand_cols
                    .into_iter()
                    .zip(&keep)
                    .filter(|(_, &k)| k)
                    .map(|(c, _)| c)
                    .collect();
                scored = Some((sub, kept_cols));
                phase = if any { 0 } else { phase + 1 };
            }
        }
        out
    }

    /// Merges pairs of neighbouring probes into one (a local search after
    /// pruning, which only ever drops one probe at a time): for each live
    /// probe and each of its [`MERGE_NEIGHBOURS`] nearest live probes, the
    /// samples only the two of them see are scored against the
    /// [`MERGE_CANDIDATES`] candidates (of every tier) nearest the pair's
    /// midpoint; when one candidate sees enough of them to keep the target,
    /// it replaces the pair (the nearest tier first, then the most seen;
    /// ties: the earlier candidate). Repeats until no pair merges. Appends
    /// the new probes to `all`, `cols` and `tier_of`; returns how many pairs
    /// were merged.
    fn merge_pairs(
        &self,
        tiers: &[Vec<Vec3>],
        w: &mut Working,
        pinned: usize,
        covered: usize,
        target_count: usize,
    ) -> usize {
        self.merge_pairs_in(tiers, w, pinned, (covered, target_count), MERGE_BATCH)
    }

    /// [`CoverMatrix::merge_pairs`], scoring `batch` pairs at once.
    fn merge_pairs_in(
        &self,
        tiers: &[Vec<Vec3>],
        w: &mut Working,
        pinned: usize,
        (mut covered, target_count): (usize, usize),
        batch: usize,
    ) -> usize {
        // The candidates of every tier, and the tier of each.
        let points: Vec<Vec3> = tiers.iter().flatten().copied().collect();
        let tier: Vec<usize> = tiers
            .iter()
            .enumerate()
            .flat_map(|(t, c)| std::iter::repeat_n(t, c.len()))
            .collect();
        if points.is_empty() {
            return 0;
        }
        let pool = NearestPoints::new(&points, MERGE_CANDIDATES);
        let mut merged = 0;
        let mut tried = std::collections::BTreeSet::new();
        'restart: loop {
            let live: Vec<usize> = (0..w.all.len())
                .filter(|&k| w.alive[k] && k >= pinned)
                .collect();
            let pairs = neighbour_pairs(&w.all, &live, &tried);
            // Pairs are scored a batch at a time, in parallel; the first
            // of a batch, in scan order, that merges is taken, and those
            // after it are tried again after the merge, as a scan that
            // stops at the merge would.
            for batch in pairs.chunks(batch.max(1)) {
                let found: Vec<Option<usize>> = batch
                    .par_iter()
                    .map(|&(i, j)| self.replacement(&pool, &tier, w, (i, j), covered, target_count))
                    .collect();
                for (&(i, j), c) in batch.iter().zip(found) {
                    tried.insert((i.min(j), i.max(j)));
                    let Some(c) = c else { continue };
                    w.kill(i);
                    w.kill(j);
                    let col = self.columns(&[points[c]]).remove(0);
                    w.push(points[c], col, tier[c]);
                    covered = self.satisfied(&w.count);
                    merged += 1;
                    continue 'restart;
                }
            }
            return merged;
        }
    }

    /// The candidate of `pool` (its index; `tier` holds each one's tier)
    /// that replaces the live probes `i` and `j` of `w` in
    /// [`CoverMatrix::merge_pairs`], or `None`: of the
    /// [`MERGE_CANDIDATES`] nearest their midpoint, one that sees
    /// enough of the samples only `i` and `j` cover to keep `covered` at
    /// `target_count` (the nearest tier first, then the most seen; ties:
    /// the earlier candidate).
    fn replacement(
        &self,
        pool: &NearestPoints,
        tier: &[usize],
        w: &Working,
        (i, j): (usize, usize),
        covered: usize,
        target_count: usize,
    ) -> Option<usize> {
        // Samples covered now that would not be without i and j, those of
        // them one replacement can restore, and how many of them it must
        // restore to keep the target.
        let (cols, count) = (&w.cols, &w.count);
        let mine = |s: usize| {
            ((cols[i][s / 64] >> (s % 64) & 1) + (cols[j][s / 64] >> (s % 64) & 1)) as u32
        };
        // Only samples i or j sees can depend on them.
        let only: Vec<usize> = ones_either(&cols[i], &cols[j])
            .filter(|&s| {
                let n = self.need[s];
                n > 0 && count[s] >= n && count[s] - mine(s) < n
            })
            .collect();
        let repairable: Vec<usize> = only
            .iter()
            .copied()
            .filter(|&s| count[s] - mine(s) + 1 >= self.need[s])
            .collect();
        let need = only
            .len()
            .saturating_sub(covered - target_count.min(covered));
        let cands = pool.nearest(0.5 * (w.all[i] + w.all[j]));
        // Only a candidate that sees at least `need` of the repairable
        // samples can win: one that misses more than `spare` of them is
        // dropped at that miss, since its score can no longer reach `need`.
        let spare = repairable.len().saturating_sub(need);
        let scores: Vec<Option<u32>> = cands
            .par_iter()
            .map(|&(_, c)| {
                let mut missed = 0;
                for &s in &repairable {
                    if !self.sees_sample(pool.points[c], s) {
                        missed += 1;
                        if missed > spare {
                            return None;
                        }
                    }
                }
                Some((repairable.len() - missed) as u32)
            })
            .collect();
        cands
            .iter()
            .zip(&scores)
            .filter_map(|(c, g)| g.map(|g| (c, g)))
            .filter(|&(_, g)| g as usize >= need)
            .min_by_key(|&((_, c), g)| (tier[*c], std::cmp::Reverse(g), *c))
            .map(|(&(_, c), _)| c)
    }

    /// Coverable sample `i` (index into the coverable samples).
    pub(super) fn sample(&self, i: usize) -> &SurfaceSample {
        &self.reference.samples[self.coverable[i]]
    }

    /// Those of the coverable `samples` a probe at `viewer` sees.
    pub(super) fn seen_among(&self, viewer: Vec3, samples: &[usize]) -> Vec<usize> {
        let mut blocker = Blocker::default();
        samples
            .iter()
            .copied()
            .filter(|&i| self.reference.sees_from(self.bvh, viewer, self.sample(i), &mut blocker))
            .collect()
    }

    /// Whether a probe at `viewer` sees every one of the coverable
    /// `samples` (indices into the coverable ones) but at most `spare`
    /// (stops once it misses more).
    pub(super) fn sees_all_but(&self, viewer: Vec3, samples: &[usize], spare: usize) -> bool {
        let mut blocker = Blocker::default();
        let mut missed = 0;
        for &i in samples {
            if !self.reference.sees_from(self.bvh, viewer, self.sample(i), &mut blocker) {
                missed += 1;
                if missed > spare {
                    return false;
                }
            }
        }
        true
    }

    /// Views coverable sample `i` needs.
    pub(super) fn needs(&self, i: usize) -> u32 {
        self.need[i]
    }

    /// Whether coverable sample `i` and `viewer` face each other
    /// ([`CoverageReference::faces`]): whether seeing it casts a segment.
    pub(super) fn faces_sample(&self, viewer: Vec3, i: usize) -> bool {
        self.reference.faces(viewer, self.sample(i))
    }

    /// Whether `viewer` sees coverable sample `i`.
    pub(super) fn sees_sample(&self, viewer: Vec3, i: usize) -> bool {
        self.reference.sees(self.bvh, viewer, self.sample(i))
    }
}

/// Cosine of the angle between `sample`'s normal and its view of `viewer`
/// (1 head-on).
fn view_cos(sample: &SurfaceSample, viewer: Vec3) -> f32 {
    sample
        .normal
        .dot((viewer - sample.position).normalize_or_zero())
}

/// The number of samples with a best view in `best` (each sample's
/// [`view_cos`], `None` unseen) and the mean incidence angle (degrees) of
/// those views, summed in sample order.
fn mean_incidence(best: impl IntoIterator<Item = Option<f32>>) -> (usize, Option<f64>) {
    let (mut sum, mut count) = (0.0f64, 0usize);
    for c in best.into_iter().flatten() {
        sum += c.clamp(-1.0, 1.0).acos().to_degrees() as f64;
        count += 1;
    }
    (count, (count > 0).then(|| sum / count as f64))
}

/// The `k` points of a fixed set nearest a query point, found with a k-d
/// tree but exactly those a full scan would choose: least
/// `distance_squared` first, ties to the lower index.
struct NearestPoints<'a> {
    points: &'a [Vec3],
    tree: Option<ImmutableKdTree<f32, 3>>,
    k: usize,
}

/// Points beyond `k` a tree query fetches, so that the `k` nearest by our
/// own distance can be told apart from the rest despite the tree's own
/// rounding of distances.
const NEAREST_SLACK: usize = 16;

impl<'a> NearestPoints<'a> {
    fn new(points: &'a [Vec3], k: usize) -> NearestPoints<'a> {
        let k = k.min(points.len());
        // A tree pays only when it can leave most points out.
        let tree = (2 * (k + NEAREST_SLACK) <= points.len())
            .then(|| {
                let rows: Vec<[f32; 3]> = points.iter().map(|p| p.to_array()).collect();
                ImmutableKdTree::<f32, 3>::new_from_slice(&rows).ok()
            })
            .flatten();
        NearestPoints { points, tree, k }
    }

    /// `(distance², index)` of the `k` points nearest `q` (ties: lower
    /// index), in index order.
    fn nearest(&self, q: Vec3) -> Vec<(f32, usize)> {
        let order = |a: &(f32, usize), b: &(f32, usize)| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1));
        let mut cands = self
            .by_tree(q, order)
            .unwrap_or_else(|| self.scan(q, order));
        cands.sort_unstable_by_key(|&(_, c)| c);
        cands
    }

    /// [`NearestPoints::nearest`] from the tree (unsorted), or `None` when
    /// there is none or it would fetch most points. Points at exactly the
    /// `k`-th distance (a query between lattice points has whole shells of
    /// them) may be left out of a query of `k` and a few more; then one
    /// twice as large is made.
    fn by_tree(
        &self,
        q: Vec3,
        order: impl Fn(&(f32, usize), &(f32, usize)) -> std::cmp::Ordering,
    ) -> Option<Vec<(f32, usize)>> {
        let tree = self.tree.as_ref()?;
        let k = self.k;
        if k == 0 {
            return None;
        }
        let mut n = k + NEAREST_SLACK;
        while 2 * n <= self.points.len() {
            let found = tree
                .query(&q.to_array())
                .nearest_n::<SquaredEuclidean<f32>>(NonZero::new(n)?)
                .execute();
            let farthest = found.iter().map(|r| r.distance).fold(0.0f32, f32::max);
            let mut cands: Vec<(f32, usize)> = found
                .iter()
                .map(|r| {
                    let i = r.item as usize;
                    (self.points[i].distance_squared(q), i)
                })
                .collect();
            cands.sort_unstable_by(&order);
            // Every point left out is at least `farthest` away by the
            // tree's reckoning; ours differs by rounding only, so the `k`
            // nearest are all here when the `k`-th is clearly nearer.
            if cands[k - 1].0 * (1.0 + 1e-4) + f32::MIN_POSITIVE < farthest {
                cands.truncate(k);
                return Some(cands);
            }
            n *= 2;
        }
        None
    }

    /// [`NearestPoints::nearest`] by a scan of every point (unsorted).
    fn scan(
        &self,
        q: Vec3,
        order: impl Fn(&(f32, usize), &(f32, usize)) -> std::cmp::Ordering,
    ) -> Vec<(f32, usize)> {
        let mut cands: Vec<(f32, usize)> = self
            .points
            .iter()
            .enumerate()
            .map(|(i, p)| (p.distance_squared(q), i))
            .collect();
        if self.k < cands.len() && self.k > 0 {
            cands.select_nth_unstable_by(self.k - 1, &order);
        }
        cands.truncate(self.k);
        cands
    }
}

/// Greedy picks among candidates whose columns over a subsample of the
/// holes are `cand_cols`, on the subsample's holes still in `remaining`
/// (cleared as they are covered): the candidate that covers the most, each
/// hole counting `weight` real ones (ties: the earlier candidate), until
/// `covered` plus the estimate reaches `target_count` or no candidate
/// covers anything. Returns the picks' indices.
fn greedy_on(
    cand_cols: &[Bits],
    remaining: &mut Bits,
    covered: usize,
    weight: f64,
    target_count: usize,
) -> Vec<usize> {
    let mut picks = Vec::new();
    let mut estimate = covered as f64;
    while (estimate as usize) < target_count {
        let (best, gain) = cand_cols
            .iter()
            .enumerate()
            .map(|(j, c)| (j, popcount_and(c, remaining)))
            .fold((usize::MAX, 0), |acc, x| if x.1 > acc.1 { x } else { acc });
        if gain == 0 {
            break;
        }
        for (r, c) in remaining.iter_mut().zip(&cand_cols[best]) {
            *r &= !c;
        }
        estimate += gain as f64 * weight;
        picks.push(best);
    }
    picks
}

impl CoverMatrix<'_> {
    /// Reverse greedy pruning (module docs, [`reverse_greedy`]) of the live
    /// probes of `w` past the first `pinned`; `covered` is how many samples
    /// are covered. Kills the probes dropped and returns what the rest cover.
    fn prune_greedy(
        &self,
        w: &mut Working,
        pinned: usize,
        covered: usize,
        target_count: usize,
    ) -> usize {
        let mut live = LiveProbes {
            matrix: self,
            w,
            pinned,
        };
        reverse_greedy(&mut live, covered, target_count)
    }
}

/// The live probes of a [`Working`] past the first `pinned`, as
/// [`reverse_greedy`] prunes them.
struct LiveProbes<'m, 'r, 'w> {
    matrix: &'m CoverMatrix<'r>,
    w: &'w mut Working,
    pinned: usize,
}

impl Prunable for LiveProbes<'_, '_, '_> {
    fn weakest(&self) -> Option<Standing> {
        let (w, need) = (&self.w, &self.matrix.need);
        // Samples that lose their cover with one view fewer.
        let mut once: Bits = vec![0; w.count.len().div_ceil(64)];
        for (i, &c) in w.count.iter().enumerate() {
            if need[i] > 0 && c == need[i] {
                once[i / 64] |= 1 << (i % 64);
            }
        }
        (self.pinned..w.cols.len())
            .filter(|&k| w.alive[k])
            .map(|k| {
                let col = &w.cols[k];
                let alone = popcount_and(col, &once) as usize;
                Standing::new(k, alone, w.tier_of[k], popcount(col) as usize)
            })
            .min()
    }

    fn drop_probe(&mut self, probe: usize) {
        self.w.kill(probe);
    }
}

/// Counts, per coverable sample, how many of `viewers` see it (what a
/// [`Working`]'s `count` must hold for its live probes).
#[cfg(test)]
pub(super) fn views(matrix: &CoverMatrix, viewers: &[Vec3]) -> Vec<u32> {
    let mut count = vec![0u32; matrix.len()];
    for c in matrix.columns(viewers) {
        for i in ones(&c) {
            count[i] += 1;
        }
    }
    count
}

/// The pairs [`CoverMatrix::merge_pairs`] tries, of the probes at `all`
/// whose indices are `live`: each live probe with its
/// [`MERGE_NEIGHBOURS`] nearest live ones (ties: the lower index), in
/// the order of that scan, nearest first, each pair once and none of
/// those already `tried` (keyed lower index first).
fn neighbour_pairs(
    all: &[Vec3],
    live: &[usize],
    tried: &std::collections::BTreeSet<(usize, usize)>,
) -> Vec<(usize, usize)> {
    // The nearest of every live probe from one k-d tree over them, as the
    // full scan would choose them ([`NearestPoints`]): merging restarts
    // this after every merge, and a scan of all pairs each time was half
    // of refinement's fill on a 1,400-probe furnished floor. The probe
    // itself is among its own nearest (distance 0), so one more is asked.
    let at: Vec<Vec3> = live.iter().map(|&k| all[k]).collect();
    let tree = NearestPoints::new(&at, MERGE_NEIGHBOURS + 1);
    let order = |a: &(f32, usize), b: &(f32, usize)| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1));
    let near: Vec<Vec<(f32, usize)>> = at
        .par_iter()
        .map(|&p| {
            let mut near = tree.nearest(p);
            near.sort_by(order);
            near
        })
        .collect();
    let mut pairs: Vec<(usize, usize)> = Vec::new();
    let mut listed = std::collections::BTreeSet::new();
    for (a, &i) in live.iter().enumerate() {
        // `live` ascends, so the tree's order of its indices is the
        // probes' order.
        let nearest = near[a].iter().filter(|&&(_, b)| b != a).take(MERGE_NEIGHBOURS);
        for &(_, b) in nearest {
            let j = live[b];
            let key = (i.min(j), i.max(j));
            if !tried.contains(&key) && listed.insert(key) {
                pairs.push((i, j));
            }
        }
    }
    pairs
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::{Count, CoverageParams, Degrees};
    use crate::scene::testing::room_sdf;

    /// The points of a cubic lattice of `side`³ points `spacing` apart,
    /// x fastest: whole shells of points at equal distances.
    fn lattice_points(side: usize, spacing: f32) -> Vec<Vec3> {
        (0..side * side * side)
            .map(|i| {
                Vec3::new((i % side) as f32, (i / side % side) as f32, (i / (side * side)) as f32)
                    * spacing
            })
            .collect()
    }

    /// The k-d tree's `k` nearest points are the full scan's, ties
    /// included: on a lattice (many points at exactly equal distances from
    /// lattice and mid-lattice queries), with duplicated points, far from
    /// the origin, and with fewer points than the tree needs.
    #[test]
    fn nearest_points_are_the_full_scans() {
        use crate::sampling::{cube_point, hash2};
        let scan = |points: &[Vec3], q: Vec3, k: usize| -> Vec<(f32, usize)> {
            let mut all: Vec<(f32, usize)> = points
                .iter()
                .enumerate()
                .map(|(i, p)| (p.distance_squared(q), i))
                .collect();
            all.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
            all.truncate(k);
            all.sort_by_key(|&(_, i)| i);
            all
        };
        let lattice = lattice_points(10, 0.25);
        let mut doubled = lattice.clone();
        doubled.extend(lattice.iter().step_by(3));
        let random: Vec<Vec3> = (0..3000).map(|i| 4.0 * cube_point(hash2(9, i))).collect();
        // Far from the origin, where coordinates keep few fractional bits.
        let far: Vec<Vec3> = lattice
            .iter()
            .map(|&p| p + Vec3::new(1e5, -3e4, 7e4))
            .collect();
        let mut trees = 0;
        for points in [&lattice, &doubled, &random, &far, &lattice[..40].to_vec()] {
            for k in [1, 7, 64, 256] {
                let near = NearestPoints::new(points, k);
                trees += usize::from(near.tree.is_some());
                for j in 0..60u64 {
                    let q = if j < 30 {
                        // Lattice points and the midpoints between them.
                        points[(hash2(j, 1) % points.len() as u64) as usize]
                            + Vec3::new(0.125, 0.0, 0.125) * (j % 2) as f32
                    } else {
                        points[0] + 2.0 * cube_point(hash2(j, 2))
                    };
                    assert_eq!(near.nearest(q), scan(points, q, k), "k {k} at {q}");
                }
            }
        }
        assert!(trees >= 16, "{trees} of 20 used the tree");
    }

    /// Merging's pairs from the k-d tree are those of a scan of every
    /// pair: on a lattice (whole shells of equal distances), with
    /// duplicated probes, with dead probes and pairs already tried, and
    /// with fewer probes than the tree needs.
    #[test]
    fn neighbour_pairs_are_the_full_scans() {
        use crate::sampling::{cube_point, hash2};
        let scan = |all: &[Vec3], live: &[usize], tried: &std::collections::BTreeSet<(usize, usize)>| {
            let mut pairs = Vec::new();
            let mut listed = std::collections::BTreeSet::new();
            for &i in live {
                let mut near: Vec<(f32, usize)> = live
                    .iter()
                    .filter(|&&j| j != i)
                    .map(|&j| (all[i].distance_squared(all[j]), j))
                    .collect();
                near.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
                for &(_, j) in near.iter().take(MERGE_NEIGHBOURS) {
                    let key = (i.min(j), i.max(j));
                    if !tried.contains(&key) && listed.insert(key) {
                        pairs.push((i, j));
                    }
                }
            }
            pairs
        };
        let lattice = lattice_points(7, 0.5);
        let mut doubled = lattice.clone();
        doubled.extend(lattice.iter().step_by(2));
        doubled.extend(lattice.iter().step_by(5));
        let random: Vec<Vec3> = (0..800).map(|i| 3.0 * cube_point(hash2(4, i))).collect();
        for all in [&lattice, &doubled, &random, &lattice[..9].to_vec()] {
            let every: Vec<usize> = (0..all.len()).collect();
            let some: Vec<usize> = (0..all.len()).filter(|&k| !hash2(7, k as u64).is_multiple_of(3)).collect();
            let mut tried = std::collections::BTreeSet::new();
            for (n, &(i, j)) in scan(all, &every, &tried).iter().enumerate() {
                if n % 4 == 0 {
                    tried.insert((i.min(j), i.max(j)));
                }
            }
            for live in [&every, &some] {
                for tried in [&std::collections::BTreeSet::new(), &tried] {
                    let want = scan(all, live, tried);
                    assert!(!want.is_empty());
                    assert_eq!(neighbour_pairs(all, live, tried), want);
                }
            }
        }
    }

    /// The test room's BVH and a small coverage reference over it.
    fn room_reference() -> (SceneBvh, CoverageReference) {
        let (scene, bvh, sdf) = room_sdf(0.25, 2);
        let params = CoverageParams {
            samples: Count(4000),
            reference_points: Count(512),
            max_incidence_deg: Degrees(85.0),
        };
        let reference = CoverageReference::new(&scene, &bvh, &sdf, &params, 2, &Progress::hidden());
        (bvh, reference)
    }

    /// A probe is paired with its six nearest probes and no more: here
    /// its nearest seven are each one probe of a tight cluster (whose own
    /// nearest are all its cluster mates), so a pair with the sixth comes
    /// only from the probe's own list, and a pair with the seventh would
    /// come only from a longer one.
    #[test]
    fn merge_pairs_a_probe_with_its_six_nearest() {
        let mut all = vec![Vec3::ZERO];
        let mut heads = Vec::new();
        // Seven directions far apart, heads at distances 10.00, 10.01, …, 10.06.
        let dirs = [
            Vec3::X,
            -Vec3::X,
            Vec3::Y,
            -Vec3::Y,
            Vec3::Z,
            -Vec3::Z,
            Vec3::new(1.0, 1.0, 1.0).normalize(),
        ];
        for (k, d) in dirs.iter().enumerate() {
            let head = d * (10.0 + 0.01 * k as f32);
            heads.push(all.len());
            all.push(head);
            // Seven mates about half a unit beyond the head, on a ring
            // around its direction: nearer it than probe 0, farther from
            // probe 0 than every head.
            let (u, v) = d.any_orthonormal_pair();
            for m in 0..7 {
                let a = m as f32 * std::f32::consts::TAU / 7.0;
                all.push(head + *d * 0.5 + 0.1 * (a.cos() * u + a.sin() * v));
            }
        }
        let live: Vec<usize> = (0..all.len()).collect();
        let none = std::collections::BTreeSet::new();
        let pairs = neighbour_pairs(&all, &live, &none);
        let paired = |a: usize, b: usize| pairs.contains(&(a, b)) || pairs.contains(&(b, a));
        for (k, &h) in heads.iter().enumerate() {
            assert_eq!(paired(0, h), k < 6, "probe 0 with head {k}");
        }
        // Each pair once; pairs already tried are left out.
        let keys: std::collections::BTreeSet<(usize, usize)> =
            pairs.iter().map(|&(i, j)| (i.min(j), i.max(j))).collect();
        assert_eq!(keys.len(), pairs.len(), "a pair listed twice");
        let tried: std::collections::BTreeSet<(usize, usize)> =
            keys.iter().copied().take(10).collect();
        let rest = neighbour_pairs(&all, &live, &tried);
        assert_eq!(rest.len(), pairs.len() - 10);
        assert!(rest
            .iter()
            .all(|&(i, j)| !tried.contains(&(i.min(j), i.max(j)))));
    }

    /// Scoring pairs in batches changes nothing: the merges, the probes
    /// they add and the coverage are those of scoring one pair at a time.
    #[test]
    fn merges_scored_in_batches_are_those_scored_one_by_one() {
        let (bvh, reference) = room_reference();
        let matrix = CoverMatrix::new(&reference, &bvh);
        // A crowded lattice of probes, many pairs of which one can replace.
        let positions: Vec<Vec3> = (0..18)
            .map(|i| {
                Vec3::new(
                    1.0 + (i % 3) as f32,
                    1.0 + (i / 3 % 2) as f32,
                    1.0 + (i / 6) as f32,
                )
            })
            .collect();
        let tiers = [reference.references.clone()];
        let run = |batch: usize| {
            let cols = matrix.columns(&positions);
            let mut w = Working::new(
                positions.clone(),
                cols,
                vec![0; positions.len()],
                matrix.len(),
            );
            let covered = matrix.satisfied(&w.count);
            let target = (0.999 * covered as f64) as usize;
            let merged = matrix.merge_pairs_in(&tiers, &mut w, 2, (covered, target), batch);
            (merged, w.all, w.alive, w.count)
        };
        let one = run(1);
        assert!(one.0 >= 2, "{} merges", one.0);
        for batch in [2, 3, 8, 64] {
            assert_eq!(run(batch), one, "batch {batch}");
        }
    }

    #[test]
    fn fill_reaches_the_target_and_prune_drops_duplicates() {
        let (bvh, reference) = room_reference();
        let p = Progress::hidden();
        let matrix = CoverMatrix::new(&reference, &bvh);
        let one = Vec3::new(3.0, 2.0, 3.0);
        // Three copies of one probe: two are superfluous; the hole behind
        // the box needs a new probe.
        let positions = [one, one, one];
        let tiers = [reference.references.clone()];
        let r = matrix.fill_and_prune(&positions, &tiers, 0.999, true, true, Rules::default(), &p);
        assert!(r.covered_initial < matrix.len());
        assert!(!r.added.is_empty());
        assert!(
            r.covered_final as f64 >= 0.999 * matrix.len() as f64,
            "{r:?}"
        );
        let copies = r.kept.iter().filter(|&&k| k < 3).count();
        assert!(copies <= 1, "{r:?}");
        // The matrix agrees with the coverage stage's own evaluation.
        let mut final_positions: Vec<Vec3> = positions.to_vec();
        final_positions.extend(&r.added);
        let kept: Vec<Vec3> = r.kept.iter().map(|&k| final_positions[k]).collect();
        let cov = reference.evaluate(&bvh, &kept, &p);
        assert_eq!(cov.covered_samples, r.covered_final);
        assert_eq!(matrix.summary(&kept).0, r.covered_final);
        // Best view first gives what every column gives, incidence too.
        let many: Vec<Vec3> = reference.references.iter().step_by(16).copied().collect();
        for viewers in [&kept[..], &many[..]] {
            let cols = matrix.columns(viewers);
            assert_eq!(matrix.summary(viewers), matrix.summary_of(viewers, &cols));
        }
        // Without filling or pruning nothing changes.
        let same = matrix.fill_and_prune(
            &positions,
            &tiers,
            0.999,
            false,
            false,
            Rules::default(),
            &p,
        );
        assert_eq!(same.kept, vec![0, 1, 2]);
        assert_eq!(same.covered_final, same.covered_initial);
    }

    /// The case the old single pass got wrong: candidates scored on a
    /// subsample of the holes, filling stopped once the subsample (or the
    /// estimate from it) was covered, and the holes between the sampled
    /// ones were never looked at again. Its first round is that pass.
    #[test]
    fn fill_rescores_the_holes_a_subsample_left() {
        let (bvh, reference) = room_reference();
        let p = Progress::hidden();
        let matrix = CoverMatrix::new(&reference, &bvh);
        let m = matrix.len();
        // One probe in a corner behind the box: most of the room is a hole.
        let positions = [Vec3::new(0.4, 0.4, 0.4)];
        let mut cols = matrix.columns(&positions);
        let mut count = vec![0u32; m];
        for i in ones(&cols[0]) {
            count[i] += 1;
        }
        let target = m; // every coverable sample
        let tiers = [reference.references.clone()];
        let filled = matrix.fill(&tiers, target, 4, &mut cols, &mut count, &p);
        assert!(filled.rounds.len() >= 2, "{:?}", filled.rounds);
        assert!(filled.rounds[0].scored <= 4);
        assert!(
            filled.rounds[0].covered < target,
            "the single pass reached the target: {:?}",
            filled.rounds
        );
        let covered = count.iter().filter(|&&c| c > 0).count();
        assert_eq!(covered, target, "{:?}", filled.rounds);
        assert_eq!(filled.rounds.last().unwrap().covered, covered);
        assert_eq!(
            filled.added.len(),
            filled.rounds.iter().map(|r| r.added).sum::<usize>()
        );
    }

    /// Tiers are used in order, and only for what the tiers before cannot
    /// see: with an empty first tier, everything comes from the second;
    /// with the references first, the second tier adds nothing.
    #[test]
    fn tiers_fill_only_what_earlier_tiers_cannot_see() {
        let (bvh, reference) = room_reference();
        let p = Progress::hidden();
        let matrix = CoverMatrix::new(&reference, &bvh);
        let positions = [Vec3::new(3.0, 2.0, 3.0)];
        let refs = reference.references.clone();
        let later = matrix.fill_and_prune(
            &positions,
            &[vec![], refs.clone()],
            1.0,
            true,
            true,
            Rules::default(),
            &p,
        );
        assert_eq!(later.covered_final, matrix.len());
        assert!(later.rounds.iter().all(|r| r.tier == 1));
        let first = matrix.fill_and_prune(
            &positions,
            &[refs.clone(), refs],
            1.0,
            true,
            true,
            Rules::default(),
            &p,
        );
        assert_eq!(first.covered_final, matrix.len());
        assert!(
            first.rounds.iter().all(|r| r.tier == 0),
            "{:?}",
            first.rounds
        );
        assert!(first.kept_tiers.iter().all(|&t| t == 0));
    }

    /// Pruning drops one probe at a time; merging replaces two by one.
    /// Pruning alone keeps more of eight low probes than pruning with
    /// merges, and both keep the target.
    #[test]
    fn merging_pairs_needs_fewer_probes_than_pruning_alone() {
        let (bvh, reference) = room_reference();
        let p = Progress::hidden();
        let matrix = CoverMatrix::new(&reference, &bvh);
        let m = matrix.len();
        // Eight low probes around the walls: each sees the room from a
        // poor angle, so several are needed where one higher up would do.
        let positions: Vec<Vec3> = [
            (0.4, 0.4),
            (2.0, 0.4),
            (3.6, 0.4),
            (3.6, 2.0),
            (3.6, 3.6),
            (2.0, 3.6),
            (0.4, 3.6),
            (0.4, 2.0),
        ]
        .iter()
        .map(|&(x, z)| Vec3::new(x, 0.4, z))
        .collect();
        let target = 0.9;
        let target_count = (target * m as f64).ceil() as usize;
        let mut w = Working::new(positions.clone(), matrix.columns(&positions), vec![0; 8], m);
        let covered = w.count.iter().filter(|&&c| c > 0).count();
        assert!(
            covered >= target_count,
            "the eight probes should cover the room"
        );
        matrix.prune_greedy(&mut w, 0, covered, target_count);
        let pruned = w.live();
        let tiers = [reference.references.clone()];
        let r = matrix.fill_and_prune(&positions, &tiers, target, true, true, Rules::default(), &p);
        assert!(r.covered_final >= target_count, "{r:?}");
        assert!(
            r.kept.len() < pruned,
            "merged {} against pruned {pruned}",
            r.kept.len()
        );
        let mut all = positions.clone();
        all.extend(&r.added);
        let kept: Vec<Vec3> = r.kept.iter().map(|&k| all[k]).collect();
        assert_eq!(
            reference.evaluate(&bvh, &kept, &p).covered_samples,
            r.covered_final
        );
    }

    /// Pinned probes survive pruning though superfluous; a need of two views
    /// makes filling add probes until each demanded sample has two, and
    /// pruning keep them, with no candidate added twice.
    #[test]
    fn pinned_probes_stay_and_a_need_of_two_gets_two_views() {
        let (bvh, reference) = room_reference();
        let p = Progress::hidden();
        let tiers = [reference.references.clone()];
        let one = Vec3::new(3.0, 2.0, 3.0);
        let positions = [one, one, one];
        let matrix = CoverMatrix::new(&reference, &bvh);
        let pinned = Rules {
            pinned: 2,
            budget: None,
            minimum: None,
        };
        let r = matrix.fill_and_prune(&positions, &tiers, 0.999, true, true, pinned, &p);
        assert!(r.kept.starts_with(&[0, 1]), "{r:?}");
        assert!(!r.kept.contains(&2), "the unpinned copy goes: {r:?}");

        let one_probe = |m: &CoverMatrix| {
            m.fill_and_prune(&[one], &tiers, 0.999, true, true, Rules::default(), &p)
        };
        let single = one_probe(&matrix);
        let twice = CoverMatrix::new(&reference, &bvh).with_need(|_, _| 2);
        let r = one_probe(&twice);
        let mut all = vec![one];
        all.extend(&r.added);
        let kept: Vec<Vec3> = r.kept.iter().map(|&k| all[k]).collect();
        let count = views(&twice, &kept);
        assert_eq!(count.iter().filter(|&&c| c >= 2).count(), r.covered_final);
        assert!(r.covered_final > twice.len() / 2, "{r:?}");
        assert!(
            kept.len() > single.kept.len(),
            "{} against {}",
            kept.len(),
            single.kept.len()
        );
        for (i, a) in r.added.iter().enumerate() {
            assert!(!r.added[..i].contains(a), "candidate {a} added twice");
        }
        // A need of 0 asks for nothing.
        let none = CoverMatrix::new(&reference, &bvh).with_need(|_, _| 0);
        assert_eq!(none.demanded(), 0);
    }

    /// A budget keeps the pinned probe and then, greedily, the probes that
    /// see the most of what is left; each added probe adds something.
    #[test]
    fn select_keeps_the_pinned_and_then_the_widest_views() {
        let (bvh, reference) = room_reference();
        let matrix = CoverMatrix::new(&reference, &bvh);
        let corner = Vec3::new(0.4, 0.4, 0.4);
        let positions: Vec<Vec3> = vec![
            corner,
            corner,
            Vec3::new(3.0, 2.0, 3.0),
            Vec3::new(2.0, 3.0, 2.0),
            Vec3::new(3.6, 0.4, 0.4),
        ];
        let covered = |ks: &[usize]| {
            let ps: Vec<Vec3> = ks.iter().map(|&k| positions[k]).collect();
            views(&matrix, &ps).iter().filter(|&&c| c > 0).count()
        };
        let kept = matrix.select(&positions, 1, 2);
        assert_eq!(kept.len(), 2);
        assert_eq!(kept[0], 0);
        assert!(covered(&kept) > covered(&kept[..1]));
        // A larger budget stops where nothing more is seen.
        let all = matrix.select(&positions, 1, 5);
        assert!(!all.contains(&1), "a copy of the pinned probe adds nothing");
        assert_eq!(covered(&all), covered(&[0, 1, 2, 3, 4]));
        // The first pick is the probe that adds the most to the pinned one.
        let best = (1..positions.len())
            .map(|k| covered(&[0, k]))
            .max()
            .unwrap();
        assert_eq!(covered(&kept[..2]), best);
    }
}
