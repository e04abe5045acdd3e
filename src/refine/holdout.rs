//! Coverage that holds on samples the placer never saw.
//!
//! Filling and pruning ([`super::prune`]) fit a fixed set of surface
//! samples, the training stream ([`Stream::Train`]), and stop the moment
//! the coverage target holds on it. That figure is a training score: the
//! surface between the samples is seen less well than the samples
//! themselves, since every fill position was chosen because it sees
//! particular samples, and the last ones chosen see little else. Wang et
//! al. 2019 promise full geometric visibility coverage of the *surface*
//! (§2, §3.2), so the placer must meet its target on samples it did not
//! choose its probes by. This step does so by active sampling:
//!
//! 1. **Free under any judgement.** Every probe (but the fixed ones, which
//!    are the artist's) is judged by [`stands_free`], rays of its own that
//!    share nothing with the run's SDF; one that fails is dropped.
//! 2. **A fresh round.** A new stream of samples ([`Stream::Check`]),
//!    judged coverable by the training measure's own reference points
//!    ([`CoverageReference::resampled`]), measures the probes. When the
//!    lower end of its 95% interval reaches the target, the placement
//!    holds and the step ends.
//! 3. **Fill its holes.** Otherwise the round's holes (coverable samples no
//!    probe sees) are filled by the same greedy set cover as training
//!    ([`CoverMatrix::fill`]), from the training's candidates (the
//!    measure's reference points among them), to a target with a margin
//!    ([`FILL_MARGIN`]): half of what the target leaves unseen. Each position
//!    filling picks is judged as in 1; one that fails is refused and the
//!    round filled again without it. Then a new round (2), at most
//!    [`MAX_CHECK_ROUNDS`] in all, unless this round's coverage (not its
//!    interval's lower end) had reached the target already: filling only
//!    adds views, so the probes now see at least what the round measured
//!    on the surface the round sampled, and another round, as dear as
//!    the validation itself, would only confirm it (on Dabrovic Sponza it
//!    was a tenth of `place`'s time).
//!
//! The figure to judge the result by comes from yet another stream
//! ([`Stream::Validation`]), never shown to the placer, so neither the
//! training set nor the rounds' holes, which the placer did see, can flatter
//! it. Under a `max_probes` budget the target is not the goal, so no round
//! should run (step 1 still does).
//!
//! [`super::refine`] runs this step after filling and pruning. What it
//! costs and adds on the shipped scenes is in docs/method.md ("Coverage on
//! samples the placer never saw") and BENCHMARKS.md.

use super::prune::{Bits, CoverMatrix, MAX_SCORED_HOLES};
use crate::coverage::{ratio_ci95, stands_free, CoverageReference, Stream};
use crate::placement::PlacementInput;
use glam::Vec3;
use rayon::prelude::*;
use serde::Serialize;

pub use crate::coverage::MAX_CHECK_ROUNDS;

/// A round's holes are filled until at most this share of what the target
/// allows stays unseen (target 99.9%: filled to 99.95%): a round that only
/// just met the target on its own samples would leave the next round, and
/// the validation, as likely under the target as over it.
pub const FILL_MARGIN: f64 = 0.5;

/// Times a round is filled again after [`stands_free`] refused a position
/// it picked.
const REFILLS: usize = 4;

/// One fresh round of samples (module docs).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct CheckRound {
    /// Which round (0 first).
    pub round: u32,
    /// Coverable samples of the round.
    pub coverable_samples: usize,
    /// Of them, those some probe saw when the round began.
    pub covered_samples: usize,
    /// Their ratio: the coverage the probes had on samples they were not
    /// placed by.
    pub coverage: f64,
    /// Half-width of its 95% interval.
    pub ci95: f64,
    /// Probes filling added for the round's holes.
    pub added: usize,
    /// Positions filling picked that [`stands_free`] refused.
    pub refused: usize,
}

impl CheckRound {
    /// Round `round` before filling: `covered` of `coverable` samples seen.
    pub fn measured(round: u32, covered: usize, coverable: usize) -> CheckRound {
        let (coverage, ci95) = ratio_ci95(covered, coverable);
        CheckRound {
            round,
            coverable_samples: coverable,
            covered_samples: covered,
            coverage,
            ci95,
            added: 0,
            refused: 0,
        }
    }

    /// Whether the probes hold `target` on this round: the lower end of
    /// its interval reaches it (or nothing is coverable), so nothing is
    /// filled and no round follows.
    pub fn holds(&self, target: f64) -> bool {
        self.coverable_samples == 0 || self.coverage - self.ci95 >= target
    }

    /// How many of the round's samples filling must see: the target plus
    /// [`FILL_MARGIN`] of the shortfall it allows.
    pub fn fill_goal(&self, target: f64) -> usize {
        let goal = target + FILL_MARGIN * (1.0 - target);
        let n = self.coverable_samples;
        ((goal * n as f64).ceil() as usize).min(n)
    }

    /// Whether no round follows this filled one: it added nothing, or its
    /// coverage (not its interval's lower end) had reached `target`.
    pub fn is_last(&self, target: f64) -> bool {
        self.added == 0 || self.coverage >= target
    }
}

/// What [`hold`] did to a probe set.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Held {
    /// Indices of the probes dropped for standing in solid.
    pub dropped: Vec<usize>,
    /// Probes added, with their candidate tier.
    pub added: Vec<(Vec3, usize)>,
    /// The rounds, in order.
    pub rounds: Vec<CheckRound>,
}

/// What [`hold`] works with besides the probes.
pub struct HoldInput<'a> {
    /// The scene, its BVH and SDF, the seed and progress.
    pub input: &'a PlacementInput<'a>,
    /// The measure training fitted: each round measures as it does
    /// (the same reference points and views a sample needs) on fresh
    /// samples.
    pub training: &'a CoverageReference,
    /// The coverage parameters of every round (the config's, as training's).
    pub params: &'a crate::config::CoverageParams,
    /// The fill candidates, by tier (the training's).
    pub tiers: &'a [Vec<Vec3>],
    /// The coverage target.
    pub target: f64,
    /// Views a sample at a position needs (`probe_density`,
    /// [`crate::placement::controls::Controls::need`]): a round asks one
    /// view of every sample that needs any, none of the others.
    pub need: &'a (dyn Fn(usize, Vec3) -> u32 + Sync),
    /// Whether rounds run and fill (false: only step 1 of the module docs).
    pub fill: bool,
    /// The first round's samples, when the caller measured them already
    /// ([`CoverageReference::resampled`] on [`Stream::Check`] 0; they
    /// depend on no probe): [`super::refine`]
    /// measures them while its sweeps leave a core idle.
    pub first_round: Option<&'a CoverageReference>,
}

/// Judges `probes` (the first `pinned` are never dropped) and runs the
/// rounds of the module docs. A round counts only the samples that need a
/// view (`need`), so a `probe_density` of 0 is honoured as in training.
///
/// Contract: deterministic for the same inputs and seed; no probe it adds
/// fails [`stands_free`] or its tier's [`super::may_stand`]; it never
/// moves a probe; a round whose interval reaches the target ends it, and
/// a round whose coverage does is the last.
pub fn hold(h: &HoldInput, probes: &[Vec3], pinned: usize) -> Held {
    let (bvh, voxel) = (h.input.bvh, h.input.sdf.voxel_size);
    let free: Vec<bool> = probes
        .par_iter()
        .map(|&p| stands_free(bvh, voxel, p))
        .collect();
    let mut held = Held {
        dropped: (pinned..probes.len()).filter(|&k| !free[k]).collect(),
        ..Held::default()
    };
    if !h.fill {
        return held;
    }
    let mut live: Vec<Vec3> = (0..probes.len())
        .filter(|k| !held.dropped.contains(k))
        .map(|k| probes[k])
        .collect();
    let params = *h.params;
    for round in 0..MAX_CHECK_ROUNDS {
        let built;
        let check = match (round, h.first_round) {
            (0, Some(first)) => first,
            _ => {
                built = h.training.resampled(h.input, &params, Stream::Check(round));
                &built
            }
        };
        let bar = h.input.progress.bar("refine: check round", 0);
        let seen = check.seen_where_coverable(bvh, &live, &bar);
        bar.finish_and_clear();
        let matrix = CoverMatrix::new(check, bvh).with_need(|i, p| (h.need)(i, p).min(1));
        let mut count = matrix.counts_of_seen(&seen);
        let mut record = CheckRound::measured(round, matrix.satisfied(&count), matrix.demanded());
        if record.holds(h.target) {
            held.rounds.push(record);
            break;
        }
        // The training's candidates, the measure's reference points among
        // them (a round's are training's).
        let mut tiers: Vec<Vec<Vec3>> = h.tiers.to_vec();
        let target_count = record.fill_goal(h.target);
        let before = count.clone();
        let mut added = Vec::new();
        for _ in 0..REFILLS {
            count.copy_from_slice(&before);
            let mut cols: Vec<Bits> = Vec::new();
            let filled = matrix.fill(
                &tiers,
                target_count,
                MAX_SCORED_HOLES,
                &mut cols,
                &mut count,
                h.input.progress,
            );
            let refused: Vec<Vec3> = filled
                .added
                .par_iter()
                .copied()
                .filter(|&p| !stands_free(bvh, voxel, p))
                .collect();
            added = filled.added.into_iter().zip(filled.tiers).collect();
            if refused.is_empty() {
                break;
            }
            record.refused += refused.len();
            for tier in &mut tiers {
                tier.retain(|p| !refused.contains(p));
            }
            added.retain(|(p, _)| !refused.contains(p));
        }
        record.added = added.len();
        held.rounds.push(record);
        live.extend(added.iter().map(|&(p, _)| p));
        held.added.extend(added);
        if record.is_last(h.target) {
            break;
        }
    }
    held
}

/// One check round of the merge: of `coverable` fresh core samples the
/// kept probes saw `covered`; `holes` lists, for each of the rest, the
/// positions that see it (empty where none does). When the round's
/// interval reaches `target` nothing is added; else positions are kept,
/// each the one named by most of the open holes (ties: the higher `tier`,
/// then the lower index), until the round's coverage reaches the target
/// plus [`FILL_MARGIN`] of its shortfall, as one
/// machine's refinement fills (above). A round whose coverage had
/// reached the target is the last (filling only adds views).
pub(crate) fn fill_round(
    round: u32,
    (coverable, covered, holes): (usize, usize, &[Vec<u32>]),
    kept: &mut [bool],
    tier: &[u8],
    target: f64,
) -> CheckRound {
    let mut record = CheckRound::measured(round, covered, coverable);
    if record.holds(target) {
        return record;
    }
    let want = record.fill_goal(target);
    let mut open: Vec<&Vec<u32>> = holes.iter().collect();
    let mut have = covered;
    while have < want {
        let mut gain = vec![0u32; kept.len()];
        for l in &open {
            for &k in l.iter() {
                gain[k as usize] += 1;
            }
        }
        let best = (0..kept.len())
            .filter(|&k| !kept[k] && gain[k] > 0)
            .max_by_key(|&k| (gain[k], tier[k], std::cmp::Reverse(k)));
        let Some(k) = best else {
            break;
        };
        kept[k] = true;
        record.added += 1;
        have += gain[k] as usize;
        open.retain(|l| !l.contains(&(k as u32)));
    }
    record
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::{Count, CoverageParams, Degrees};
    use crate::progress::Progress;
    use crate::scene::testing::{input_over, room_sdf};

    /// Filling that fits only its training samples stops short on samples
    /// it never saw; the rounds reach the target there. A room crossed by
    /// louvres of thin slats (the generated `slats` kind), with few training
    /// samples: fill's last positions see little but them.
    #[test]
    fn fill_on_training_alone_falls_short_on_held_out_samples_and_the_rounds_reach_the_target() {
        use crate::fixtures::generated::{generate, Kind};
        let dir = tempfile::tempdir().unwrap();
        let g = generate(Kind::Slats, 1);
        let path = g.write(dir.path()).unwrap();
        let scene = crate::scene::load_obj(&path.with_extension("obj"), g.scale, g.up).unwrap();
        let (bvh, sdf) = crate::scene::testing::bvh_and_sdf(&scene, 0.1, 5);
        let hidden = Progress::hidden();
        let params = |samples: u32| CoverageParams {
            samples: Count(samples),
            reference_points: Count(2048),
            max_incidence_deg: Degrees(85.0),
        };
        let reference = |samples: u32, stream: Stream| {
            CoverageReference::by_rays(
                &scene,
                &bvh,
                &sdf,
                &scene.bounds,
                &params(samples),
                stream.seed(5),
                &hidden,
            )
        };
        let training = reference(300, Stream::Train);
        let held_out = reference(20_000, Stream::Validation);
        let input = input_over(&scene, &bvh, &sdf, 5, &hidden);
        let tier_of =
            |p: Vec3| (crate::coverage::surface_distance(&sdf, p) >= sdf.voxel_size).then_some(0);
        let tiers = vec![training
            .references
            .iter()
            .copied()
            .filter(|&p| tier_of(p).is_some())
            .collect::<Vec<_>>()];
        // One probe in the middle of the room, then fill on the training
        // samples alone, to the very last of them.
        let start = vec![scene.bounds.min + 0.5 * scene.bounds.size()];
        let matrix = CoverMatrix::new(&training, &bvh);
        let fp = matrix.fill_and_prune(
            &start,
            &tiers,
            1.0,
            true,
            true,
            super::super::prune::Rules::default(),
            &hidden,
        );
        let all: Vec<Vec3> = start.iter().chain(&fp.added).copied().collect();
        let fitted: Vec<Vec3> = fp.kept.iter().map(|&k| all[k]).collect();
        assert_eq!(fp.covered_final, fp.coverable, "training is fitted whole");
        let target = 0.999;
        let before = held_out.evaluate(&bvh, &fitted, &hidden);
        assert!(
            before.coverage + before.ci95 < target,
            "fitted to its training samples, held out: {:.4} ± {:.4}",
            before.coverage,
            before.ci95
        );
        let held = hold(
            &HoldInput {
                input: &input,
                training: &training,
                params: &params(20_000),
                tiers: &tiers,
                target,
                need: &|_, _| 1,
                fill: true,
                first_round: None,
            },
            &fitted,
            0,
        );
        assert!(!held.added.is_empty(), "{:?}", held.rounds);
        // The last round met the target by its interval, or by its own
        // coverage before its holes were filled.
        let last = held.rounds.last().unwrap();
        assert!(
            last.coverage - last.ci95 >= target || (last.coverage >= target && last.added > 0),
            "{:?}",
            held.rounds
        );
        let mut after: Vec<Vec3> = (0..fitted.len())
            .filter(|k| !held.dropped.contains(k))
            .map(|k| fitted[k])
            .collect();
        after.extend(held.added.iter().map(|&(p, _)| p));
        let measured = held_out.evaluate(&bvh, &after, &hidden);
        assert!(
            measured.coverage >= target - measured.ci95,
            "held out after the rounds: {:.5} ± {:.5}",
            measured.coverage,
            measured.ci95
        );
        assert!(measured.coverage > before.coverage);
    }

    /// A probe in a solid box is dropped by its own rays, whatever the
    /// SDF's seed, unless it is pinned; a free one stays.
    #[test]
    fn probes_in_solid_are_dropped_unless_pinned() {
        let (scene, bvh, sdf) = room_sdf(0.25, 2);
        let hidden = Progress::hidden();
        let input = input_over(&scene, &bvh, &sdf, 5, &hidden);
        let inside_box = Vec3::new(1.5, 0.5, 1.5);
        let open = Vec3::new(3.0, 2.0, 3.0);
        let params = CoverageParams {
            samples: Count(500),
            ..CoverageParams::default()
        };
        let training = CoverageReference::by_rays(
            &scene,
            &bvh,
            &sdf,
            &scene.bounds,
            &params,
            Stream::Train.seed(5),
            &hidden,
        );
        let h = HoldInput {
            input: &input,
            training: &training,
            params: &params,
            tiers: &[],
            target: 0.999,
            need: &|_, _| 1,
            fill: false,
            first_round: None,
        };
        assert_eq!(hold(&h, &[open, inside_box], 0).dropped, vec![1]);
        assert!(hold(&h, &[inside_box, open], 1).dropped.is_empty());
    }

    /// A round whose interval reaches the target adds nothing; one short of
    /// it keeps the positions that see the most holes (ties: the higher
    /// tier) until the target plus half its shortfall holds.
    #[test]
    fn a_round_fills_its_holes_to_the_target_and_margin() {
        let target = 0.99;
        // 1000 samples, 995 seen: 99.5% ± 0.44%, its lower end over 0.99.
        let mut kept = vec![true, false, false, false];
        let r = fill_round(0, (1000, 995, &[]), &mut kept, &[0; 4], target);
        assert_eq!((r.added, r.coverage), (0, 0.995));
        // 1000 samples, 980 seen; holes: probe 1 sees 12 of them, probes
        // 2 and 3 the same 6 others (3 of the higher tier), none the last 2.
        let mut holes: Vec<Vec<u32>> = vec![vec![1]; 12];
        holes.extend(vec![vec![2, 3]; 6]);
        holes.extend(vec![vec![]; 2]);
        let tier = [0, 0, 0, 1];
        let r = fill_round(1, (1000, 980, &holes), &mut kept, &tier, target);
        // The goal, 99.5%: 995 of 1000, so 1 (992), then 3 (998).
        assert_eq!(r.added, 2);
        assert_eq!(kept, vec![true, true, false, true]);
        assert_eq!(r.covered_samples, 980);
        // No position sees what is left: nothing more to add.
        let mut kept = vec![true, false, false, false];
        let r = fill_round(2, (100, 50, &vec![vec![]; 50]), &mut kept, &tier, target);
        assert_eq!(r.added, 0);
    }
}
