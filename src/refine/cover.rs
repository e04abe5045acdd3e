//! Set cover: the one reverse greedy ([`reverse_greedy`], Wang et al.
//! 2019 §3.3, by the order [`Standing`]) that prunes both refinement's bit
//! matrix of one scene ([`super::prune`]) and the visibility lists below,
//! and the partial set cover over those lists ([`cover`]): the fewest
//! probes such that enough samples are seen by a kept one. Merging tiles
//! (`probeplace merge`, docs/tiles.md) keeps the union of the tiles'
//! probes this way, with exchanges that find smaller covers; its check
//! rounds fill the holes fresh samples show as one machine's refinement
//! fills ([`super::holdout::fill_round`]).

use rayon::prelude::*;
use std::cmp::Reverse;
use std::collections::BTreeMap;

/// A probe's standing in reverse greedy ([`reverse_greedy`]), ordered so
/// that the least goes first: the probe that alone covers the fewest
/// samples, then the one nearest a surface (the higher tier: a probe stands
/// close to a surface only where no other serves), then the one that sees
/// the fewest, then the later one. Refinement's prune (Wang et al. 2019
/// §3.3, [`super::prune`]) and the merge's cover ([`cover`]) weigh their
/// probes by this one order.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub(crate) struct Standing {
    /// Samples no other kept probe covers (with demand, that lose their
    /// cover without it).
    alone: usize,
    /// The tier, reversed.
    tier: Reverse<usize>,
    /// Samples it sees.
    seen: usize,
    /// The probe's index, reversed.
    probe: Reverse<usize>,
}

impl Standing {
    /// Probe `probe` of tier `tier`, which sees `seen` samples, `alone` of
    /// them alone.
    pub(crate) fn new(probe: usize, alone: usize, tier: usize, seen: usize) -> Standing {
        Standing {
            alone,
            tier: Reverse(tier),
            seen,
            probe: Reverse(probe),
        }
    }
}

/// A set of kept probes that reverse greedy prunes.
pub(crate) trait Prunable {
    /// The least [`Standing`] among the probes that may go (kept, and not
    /// pinned), or `None` when there are none.
    fn weakest(&self) -> Option<Standing>;
    /// Takes `probe` out of the set.
    fn drop_probe(&mut self, probe: usize);
}

/// Reverse greedy pruning (Wang et al. 2019 §3.3): while some probe can
/// go, drop the weakest ([`Standing`]). A probe can go when the covered
/// samples, `covered` to begin with, stay at `target` or more; when the
/// target is out of reach, when nothing depends on it alone. Returns the
/// samples the kept probes cover.
pub(crate) fn reverse_greedy(set: &mut impl Prunable, mut covered: usize, target: usize) -> usize {
    // Covered only falls while it stays at the target, so this bound holds
    // throughout.
    let need = target.min(covered);
    // The weakest has the fewest samples alone: when it cannot go, no
    // other can.
    while let Some(w) = set.weakest() {
        if covered - w.alone < need {
            break;
        }
        set.drop_probe(w.probe.0);
        covered -= w.alone;
    }
    covered
}

/// Partial set cover: which probes to keep so that at least `need` of the
/// lists name a kept one (every list names some probe).
///
/// 1. **Greedy**: while fewer are covered, keep the probe named by the
///    most lists no kept probe is named by (ties: the lower index).
/// 2. **Prune** ([`reverse_greedy`], refinement's prune too): while some
///    kept probe can go, drop the weakest [`Standing`] (the one that alone
///    covers the fewest lists). A probe can go when the covered lists stay
///    at `need` or more.
/// 3. **Swap two for one**: while some pair of kept probes can be
///    replaced by one other probe with `need` still met, replace the first
///    such pair (in index order) by the probe that covers the most of what
///    only the pair covered (ties: the lower index), and prune again.
/// 4. **Shrink** ([`CoverLists::shrink`]): drop the probe that alone covers the
///    fewest lists, then climb back to `need` by exchanging one kept probe
///    for one other, each exchange covering more lists; repeat while the
///    climb succeeds, and keep the last cover that met `need`.
///
/// Greedy alone is a logarithmic approximation; on the union of
/// Dabrovic Sponza's four tiles it kept 63 probes where an exact integer
/// program over the same lists needs 60, and with the offered positions
/// the swaps and the shrink close the rest and more (docs/tiles.md).
/// Stopping at `need` is refinement's rule: filling stops at the coverage
/// target, not at the last hard-to-see sample. Deterministic: the searches
/// run in parallel, but each takes the best move by a total order.
pub(crate) fn cover(probes: usize, lists: &[Vec<u32>], tier: &[u8], need: usize) -> Vec<bool> {
    let c = CoverLists::new(probes, lists, tier);
    let mut kept = c.greedy_cover(need);
    c.prune_cover(&mut kept, need);
    while let Some((a, b, k)) = c.swap_two_for_one(&kept, need) {
        kept[a] = false;
        kept[b] = false;
        kept[k] = true;
        c.prune_cover(&mut kept, need);
    }
    c.shrink(&mut kept, need);
    kept
}

/// What every step of [`cover`] reads: the lists (one per sample, the
/// probes that see it), the same by probe (the lists each probe is named
/// by, ascending), and each probe's tier.
struct CoverLists<'a> {
    lists: &'a [Vec<u32>],
    by_probe: Vec<Vec<u32>>,
    tier: &'a [u8],
}

impl<'a> CoverLists<'a> {
    /// `lists` over `probes` probes of tiers `tier`, indexed by probe.
    fn new(probes: usize, lists: &'a [Vec<u32>], tier: &'a [u8]) -> CoverLists<'a> {
        let mut by_probe: Vec<Vec<u32>> = vec![Vec::new(); probes];
        for (l, list) in lists.iter().enumerate() {
            for &k in list {
                by_probe[k as usize].push(l as u32);
            }
        }
        by_probe.iter_mut().for_each(Vec::shrink_to_fit);
        CoverLists {
            lists,
            by_probe,
            tier,
        }
    }

    /// Step 4 of [`cover`]: a local search for a smaller cover.
    ///
    /// Greedy, prune and pair swaps each stop where no single move keeps
    /// `need` met, but a cover one probe smaller is often a few exchanges
    /// away: dropping a probe opens a hole that no other probe fills alone,
    /// yet moving one kept probe over to a position that sees that hole and
    /// most of what the moved probe saw leaves a smaller hole, and so on. So
    /// the probe that alone covers the fewest lists is dropped (the weakest
    /// [`Standing`]) and [`CoverLists::climb`] exchanges
    /// probes until `need` holds again; when it cannot, the last cover that
    /// met `need` stands.
    /// On generated storeys-1's four tiles this took the merge from 35 probes
    /// to 29 (one machine keeps 30), where a cover bound by the tier rule
    /// needed at least 31 (its LP relaxation: 30.5; docs/tiles.md).
    fn shrink(&self, kept: &mut [bool], need: usize) {
        loop {
            let (views, _) = self.kept_views(kept);
            let Some(weakest) = self.standings(kept, &views).min() else {
                return;
            };
            let drop = weakest.probe.0;
            let mut trial = kept.to_vec();
            trial[drop] = false;
            if !self.climb(&mut trial, need) {
                return;
            }
            kept.copy_from_slice(&trial);
        }
    }

    /// Exchanges of one kept probe `a` for one other `c`, each the exchange
    /// that covers the most more lists (ties: `c` of the higher tier, so
    /// nearer no surface than it must; then the lower `a`, the lower `c`),
    /// until at least `need` lists are covered. Returns whether they are;
    /// `false` when no exchange covers more.
    fn climb(&self, kept: &mut [bool], need: usize) -> bool {
        use std::cmp::Reverse;
        loop {
            let (views, covered) = self.kept_views(kept);
            if covered >= need {
                return true;
            }
            // What each other probe would add by itself: the uncovered lists
            // it is named by. An exchange gains only through these, since
            // what `a` alone covered is at most regained.
            let mut gain = vec![0u32; kept.len()];
            for (list, _) in self.lists.iter().zip(&views).filter(|(_, &v)| v == 0) {
                for &c in list {
                    gain[c as usize] += 1;
                }
            }
            let gainers: Vec<usize> = (0..kept.len())
                .filter(|&c| gain[c] > 0 && !kept[c])
                .collect();
            let ids: Vec<usize> = (0..kept.len()).filter(|&k| kept[k]).collect();
            let best = ids
                .par_iter()
                .filter_map(|&a| {
                    // Of the lists `a` alone covers, how many each probe is named by.
                    let mut regained = vec![0u32; kept.len()];
                    let mut lost = 0i64;
                    for &l in &self.by_probe[a] {
                        if views[l as usize] == 1 {
                            lost += 1;
                            for &c in &self.lists[l as usize] {
                                regained[c as usize] += 1;
                            }
                        }
                    }
                    gainers
                        .iter()
                        .map(|&c| {
                            let delta = gain[c] as i64 + regained[c] as i64 - lost;
                            (delta, Reverse(self.tier[c]), Reverse(a), Reverse(c))
                        })
                        .max()
                })
                .max();
            match best {
                Some((delta, _, Reverse(a), Reverse(c))) if delta > 0 => {
                    kept[a] = false;
                    kept[c] = true;
                }
                _ => return false,
            }
        }
    }

    /// Step 1 of [`cover`]: greedy with the tier rule, where a probe serves
    /// only the lists in which no probe of a higher tier (a lower number) is
    /// named.
    fn greedy_cover(&self, need: usize) -> Vec<bool> {
        let probes = self.by_probe.len();
        let first: Vec<u8> = self
            .lists
            .iter()
            .map(|list| {
                list.iter()
                    .map(|&k| self.tier[k as usize])
                    .min()
                    .unwrap_or(0)
            })
            .collect();
        let serves = |k: usize, l: u32| self.tier[k] == first[l as usize];
        let mut kept = vec![false; probes];
        let mut open: Vec<bool> = vec![true; self.lists.len()];
        let mut gain: Vec<usize> = (0..probes)
            .map(|k| self.by_probe[k].iter().filter(|&&l| serves(k, l)).count())
            .collect();
        let mut covered = 0;
        while covered < need {
            let best = (0..probes)
                .filter(|&k| !kept[k] && gain[k] > 0)
                .max_by(|&a, &b| gain[a].cmp(&gain[b]).then(b.cmp(&a)));
            let Some(k) = best else { break };
            kept[k] = true;
            for &l in self.by_probe[k].iter().filter(|&&l| serves(k, l)) {
                if std::mem::replace(&mut open[l as usize], false) {
                    covered += 1;
                    for &other in &self.lists[l as usize] {
                        if serves(other as usize, l) {
                            gain[other as usize] -= 1;
                        }
                    }
                }
            }
        }
        kept
    }

    /// How many kept probes each of the `lists` lists names, and how many
    /// lists are covered: counted over the kept probes' own lists in
    /// `by_probe`, a few dozen where the lists hold every candidate.
    fn kept_views(&self, kept: &[bool]) -> (Vec<u32>, usize) {
        let mut views = vec![0u32; self.lists.len()];
        for own in self
            .by_probe
            .iter()
            .zip(kept)
            .filter(|(_, &k)| k)
            .map(|(o, _)| o)
        {
            for &l in own {
                views[l as usize] += 1;
            }
        }
        let covered = views.iter().filter(|&&v| v > 0).count();
        (views, covered)
    }

    /// The [`Standing`] of every kept probe (`views` from
    /// [`CoverLists::kept_views`]).
    fn standings<'s>(
        &'s self,
        kept: &'s [bool],
        views: &'s [u32],
    ) -> impl Iterator<Item = Standing> + 's {
        (0..kept.len()).filter(|&k| kept[k]).map(move |k| {
            let own = &self.by_probe[k];
            let alone = own.iter().filter(|&&l| views[l as usize] == 1).count();
            Standing::new(k, alone, self.tier[k] as usize, own.len())
        })
    }

    /// Step 2 of [`cover`]: [`reverse_greedy`] over the kept probes.
    fn prune_cover(&self, kept: &mut [bool], need: usize) {
        let (views, covered) = self.kept_views(kept);
        reverse_greedy(
            &mut KeptLists {
                lists: self,
                kept,
                views,
            },
            covered,
            need,
        );
    }

    /// Step 3 of [`cover`]: the first pair `(a, b)` of kept probes and the
    /// probe `c` to keep instead, if any.
    fn swap_two_for_one(&self, kept: &[bool], need: usize) -> Option<(usize, usize, usize)> {
        let (views, covered) = self.kept_views(kept);
        let slack = covered.saturating_sub(need);
        let ids: Vec<usize> = (0..kept.len()).filter(|&k| kept[k]).collect();
        // The lists only `a`, or only `a` and `b`, cover: what a swap must
        // cover again (less the slack).
        let alone: Vec<Vec<u32>> = ids
            .iter()
            .map(|&a| {
                self.by_probe[a]
                    .iter()
                    .copied()
                    .filter(|&l| views[l as usize] == 1)
                    .collect()
            })
            .collect();
        let mut shared: BTreeMap<(usize, usize), Vec<u32>> = BTreeMap::new();
        for (l, list) in self.lists.iter().enumerate() {
            if views[l] == 2 {
                let mut two = list.iter().map(|&k| k as usize).filter(|&k| kept[k]);
                if let (Some(a), Some(b)) = (two.next(), two.next()) {
                    shared.entry((a, b)).or_default().push(l as u32);
                }
            }
        }
        let pairs: Vec<(usize, usize)> = (0..ids.len())
            .flat_map(|i| (i + 1..ids.len()).map(move |j| (i, j)))
            .collect();
        let sees = |c: usize, l: u32| self.by_probe[c].binary_search(&l).is_ok();
        pairs.par_iter().find_map_first(|&(i, j)| {
            let (a, b) = (ids[i], ids[j]);
            let mut must: Vec<u32> = alone[i].iter().chain(&alone[j]).copied().collect();
            if let Some(both) = shared.get(&(a, b)) {
                must.extend(both);
            }
            if must.len() <= slack {
                // Prune would already have dropped one of them.
                return None;
            }
            // A replacement misses at most `slack` of `must`, so it sees one
            // of the first `slack + 1`.
            let mut options: Vec<usize> = must[..=slack]
                .iter()
                .flat_map(|&l| self.lists[l as usize].iter().map(|&k| k as usize))
                .filter(|&k| !kept[k])
                .collect();
            options.sort_unstable();
            options.dedup();
            options
                .into_iter()
                .filter_map(|c| {
                    let mut missed = 0;
                    for &l in &must {
                        if !sees(c, l) {
                            missed += 1;
                            if missed > slack {
                                return None;
                            }
                        }
                    }
                    Some((missed, c))
                })
                .min()
                .map(|(_, c)| (a, b, c))
        })
    }
}

/// The kept probes of [`CoverLists`] and how many of them each list
/// names, as [`reverse_greedy`] prunes them.
struct KeptLists<'c, 'a, 'k> {
    lists: &'c CoverLists<'a>,
    kept: &'k mut [bool],
    views: Vec<u32>,
}

impl Prunable for KeptLists<'_, '_, '_> {
    fn weakest(&self) -> Option<Standing> {
        self.lists.standings(self.kept, &self.views).min()
    }

    fn drop_probe(&mut self, probe: usize) {
        self.kept[probe] = false;
        for &l in &self.lists.by_probe[probe] {
            self.views[l as usize] -= 1;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reverse_greedy_drops_the_weakest_first_and_out_of_reach_only_what_nothing_needs() {
        // Probe 2 sees what 0 and 1 see, and nothing alone; 3 sees one list
        // alone, as 0 and 1 do, but it is of the nearer tier.
        let lists = vec![vec![0], vec![0, 2], vec![1], vec![1, 2], vec![3]];
        let tiers = [0, 0, 0, 1];
        let c = CoverLists::new(4, &lists, &tiers);
        let prune = |target: usize| {
            let mut kept = vec![true; 4];
            let (views, covered) = c.kept_views(&kept);
            let mut set = KeptLists {
                lists: &c,
                kept: &mut kept,
                views,
            };
            let covered = reverse_greedy(&mut set, covered, target);
            (kept, covered)
        };
        // Everything needed: only 2 goes.
        assert_eq!(prune(5), (vec![true, true, false, true], 5));
        // A target past every list (out of reach): still only 2, which
        // nothing depends on alone.
        assert_eq!(prune(9), (vec![true, true, false, true], 5));
        // One list to spare: 2 goes (nothing alone), then of the three that
        // each see one list alone, 3, of the nearer tier.
        assert_eq!(prune(4), (vec![true, true, false, false], 4));
        // The order itself: fewest alone, then the nearer tier, then the
        // fewest seen, then the later probe.
        let w = |k, alone, tier, seen| Standing::new(k, alone, tier, seen);
        assert!(w(5, 0, 0, 9) < w(1, 1, 1, 1));
        assert!(w(5, 1, 1, 9) < w(1, 1, 0, 1));
        assert!(w(5, 1, 0, 2) < w(1, 1, 0, 3));
        assert!(w(5, 1, 0, 2) < w(1, 1, 0, 2));
    }

    #[test]
    fn the_cover_keeps_the_fewest_probes_that_reach_the_count() {
        // Probe 2 sees three samples, 3 one of them and one more, 1 a
        // sample 2 sees, 0 and 4 nothing listed.
        let lists = vec![vec![1, 2], vec![2], vec![2, 3], vec![3]];
        assert_eq!(
            cover(5, &lists, &[0; 5], 4),
            [false, false, true, true, false]
        );
        // Three of the four lists are enough with 2 alone.
        assert_eq!(
            cover(5, &lists, &[0; 5], 3),
            [false, false, true, false, false]
        );
        // 0 sees three samples and is taken first; 2 then covers the last.
        let lists = vec![vec![0, 1], vec![0, 1], vec![0, 2], vec![2]];
        assert_eq!(cover(3, &lists, &[0; 3], 4), [true, false, true]);
        assert_eq!(cover(2, &[], &[0; 5], 0), [false, false]);
    }

    #[test]
    fn a_cover_one_smaller_two_exchanges_away_is_found() {
        // Greedy keeps 0, then 1, then 5; each of the three alone sees two
        // lists, so none can go, and no pair has one probe that sees all
        // that the pair alone sees. Shrinking drops 1 (alone in two lists,
        // named by fewest), exchanges 0 for 3 (one list more), then 5 for
        // 4: two probes, the optimum.
        let lists = vec![
            vec![0, 4, 5],
            vec![0, 3],
            vec![4, 5],
            vec![1, 3],
            vec![0, 3],
            vec![0, 4, 5],
            vec![1, 4],
            vec![3, 5],
        ];
        let c = CoverLists::new(6, &lists, &[0; 6]);
        let mut kept = c.greedy_cover(8);
        c.prune_cover(&mut kept, 8);
        assert_eq!(kept, [true, true, false, false, false, true]);
        assert_eq!(c.swap_two_for_one(&kept, 8), None);
        assert_eq!(
            cover(6, &lists, &[0; 6], 8),
            [false, false, false, true, true, false]
        );
        // From every probe kept, shrinking alone also ends at two; from
        // the optimum, where no climb after a drop reaches the count
        // again, the cover stands.
        let mut one = vec![true; 6];
        c.shrink(&mut one, 8);
        assert_eq!(one.iter().filter(|&&k| k).count(), 2);
        let mut none = [false, false, false, true, true, false];
        c.shrink(&mut none, 8);
        assert_eq!(none, [false, false, false, true, true, false]);
    }

    #[test]
    fn two_kept_probes_give_way_to_one_that_sees_what_they_alone_saw() {
        // Greedy takes 1 (four lists), then 0 and 3; each then sees a list
        // no other kept probe sees, so pruning keeps all three. 2 sees
        // everything only 0 and 1 see, and 2 with 3 see every list.
        let lists = vec![
            vec![0, 1, 2],
            vec![1, 3, 4],
            vec![3],
            vec![0, 1, 2],
            vec![0, 2, 4],
            vec![3, 4],
            vec![1, 2, 4],
        ];
        let c = CoverLists::new(5, &lists, &[0; 5]);
        let mut kept = c.greedy_cover(7);
        c.prune_cover(&mut kept, 7);
        assert_eq!(kept, [true, true, false, true, false]);
        assert_eq!(c.swap_two_for_one(&kept, 7), Some((0, 1, 2)));
        assert_eq!(
            cover(5, &lists, &[0; 5], 7),
            [false, false, true, true, false]
        );
        // A lower tier serves greedy only where no higher one sees: with
        // 2 and 3 in tier 1, greedy starts from 1 and 4, and the swaps
        // still end at two probes.
        assert_eq!(
            cover(5, &lists, &[0, 0, 1, 1, 0], 7)
                .iter()
                .filter(|&&k| k)
                .count(),
            2
        );
    }
}
