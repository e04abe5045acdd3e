//! The fitness `R(P) = Σ_ij π_ij` of a probe set (Wang et al. 2019 eq. 1)
//! and the per-texel accumulators that make one probe's move cheap to score.
//!
//! Two texel fitnesses (see [`FitnessKind`]):
//!
//! * **as written**, eq. 2: `π_ij = Σ_k (w1·Ω̄_k + w2·d̄_k)·V^k_ij`. Each
//!   probe adds its own score to every texel it sees, so `R` is a sum of
//!   independent per-probe terms: probes do not compete for texels, and two
//!   probes seeing the same wall score twice;
//! * **saturating**: `π_ij = max_k (w1·Ω^k_ij + w2·d^k_ij)·V^k_ij`. A texel
//!   is credited once, by its best view, so a probe gains only by seeing
//!   what no other probe sees as well, which is what coverage asks for.
//!
//! Texel terms are weighted by texel area (see the atlas module).
//!
//! Accumulators: every texel keeps the list of probes that see it with their
//! qualities, the best and second-best quality and the best probe, and the
//! sum of the scores of the probes that see it. The marginal value of probe
//! `k` at a candidate position, `R(P′) − R(P ∖ k)`, then reads only the
//! texels the candidate sees (saturating: `max(0, q − best other)`, where
//! the best other is the second best when `k` is the best); committing a
//! move touches only the texels of the old and new views.

use super::atlas::Atlas;
use super::view::ProbeView;
use crate::config::FitnessKind;

/// Per-texel accumulators and the current fitness of a probe set.
pub struct AtlasState<'a> {
    kind: FitnessKind,
    atlas: &'a Atlas,
    views: Vec<ProbeView>,
    /// Per texel: the probes that see it, with their qualities.
    contributors: Vec<Vec<(u32, f32)>>,
    /// Per texel: best quality (0 when unseen).
    best: Vec<f32>,
    /// Per texel: the probe with the best quality (`u32::MAX` when unseen).
    best_probe: Vec<u32>,
    /// Per texel: second-best quality (0 when fewer than two probes see it).
    second: Vec<f32>,
    /// Per texel: sum of the scores of the probes that see it (eq. 2).
    score_sum: Vec<f64>,
    r: f64,
}

impl<'a> AtlasState<'a> {
    /// Accumulators for probes with the given views.
    pub fn new(kind: FitnessKind, atlas: &'a Atlas, views: Vec<ProbeView>) -> AtlasState<'a> {
        let n = atlas.len();
        let mut state = AtlasState {
            kind,
            atlas,
            views: Vec::with_capacity(views.len()),
            contributors: vec![Vec::new(); n],
            best: vec![0.0; n],
            best_probe: vec![u32::MAX; n],
            second: vec![0.0; n],
            score_sum: vec![0.0; n],
            r: 0.0,
        };
        for (k, view) in views.into_iter().enumerate() {
            for &(t, q) in &view.texels {
                state.contributors[t as usize].push((k as u32, q));
                state.score_sum[t as usize] += view.score as f64;
            }
            state.views.push(view);
        }
        for t in 0..n {
            state.update_best(t);
        }
        state.r = state.recompute();
        state
    }

    /// The current fitness `R(P)`.
    pub fn r(&self) -> f64 {
        self.r
    }

    /// Number of probes.
    pub fn len(&self) -> usize {
        self.views.len()
    }

    /// Whether there are no probes.
    pub fn is_empty(&self) -> bool {
        self.views.is_empty()
    }

    /// The current view of probe `k`.
    pub fn view(&self, k: usize) -> &ProbeView {
        &self.views[k]
    }

    /// `R(P)` from scratch, from the accumulators' inputs (the views).
    pub fn recompute(&self) -> f64 {
        fitness_of(self.kind, self.atlas, &self.views)
    }

    /// Area of the texels in `view`.
    fn seen_area(&self, view: &ProbeView) -> f64 {
        view_area(self.atlas, view)
    }

    /// `R(P′) − R(P ∖ k)`, where `P′` gives probe `k` the view `view`: what
    /// probe `k` adds to the fitness from there. Never negative.
    pub fn marginal(&self, k: usize, view: &ProbeView) -> f64 {
        match self.kind {
            FitnessKind::AsWritten => view.score as f64 * self.seen_area(view),
            FitnessKind::Saturating => view
                .texels
                .iter()
                .map(|&(t, q)| {
                    let t = t as usize;
                    let other = if self.best_probe[t] == k as u32 {
                        self.second[t]
                    } else {
                        self.best[t]
                    };
                    (q - other).max(0.0) as f64 * self.atlas.texel_area[t] as f64
                })
                .sum(),
        }
    }

    /// `R(P′) − R(P)` for moving probe `k` to a position with view `view`.
    pub fn delta(&self, k: usize, view: &ProbeView) -> f64 {
        self.marginal(k, view) - self.marginal(k, &self.views[k])
    }

    /// Moves probe `k` to a position with view `view`, updating only the
    /// texels either view touches.
    pub fn commit(&mut self, k: usize, view: ProbeView) {
        self.r += self.delta(k, &view);
        let old = std::mem::take(&mut self.views[k]);
        for &(t, _) in &old.texels {
            let list = &mut self.contributors[t as usize];
            if let Some(i) = list.iter().position(|&(p, _)| p == k as u32) {
                list.swap_remove(i);
            }
            self.score_sum[t as usize] -= old.score as f64;
        }
        for &(t, q) in &view.texels {
            self.contributors[t as usize].push((k as u32, q));
            self.score_sum[t as usize] += view.score as f64;
        }
        for &(t, _) in old.texels.iter().chain(&view.texels) {
            self.update_best(t as usize);
        }
        self.views[k] = view;
    }

    /// Recomputes texel `t`'s best, best probe and second best.
    fn update_best(&mut self, t: usize) {
        let (mut best, mut probe, mut second) = (0.0f32, u32::MAX, 0.0f32);
        for &(p, q) in &self.contributors[t] {
            if q > best || (q == best && p < probe) {
                second = best;
                best = q;
                probe = p;
            } else if q > second {
                second = q;
            }
        }
        self.best[t] = best;
        self.best_probe[t] = probe;
        self.second[t] = second;
    }

    /// Best quality of texel `t`, or `None` when no probe sees it.
    pub fn best_quality(&self, t: usize) -> Option<f32> {
        (self.best_probe[t] != u32::MAX).then_some(self.best[t])
    }

    /// Share of the atlas area some probe sees.
    pub fn seen_share(&self) -> f64 {
        seen_share_of(self.atlas, |t| self.best_probe[t] != u32::MAX)
    }

    /// Per-texel fitness `π_ij` (area-weighted) as the accumulators hold it.
    pub fn texel_fitness(&self, t: usize) -> f64 {
        let area = self.atlas.texel_area[t] as f64;
        match self.kind {
            FitnessKind::AsWritten => self.score_sum[t] * area,
            FitnessKind::Saturating => self.best[t] as f64 * area,
        }
    }
}

/// `R(P)` of probes with `views` (§3.3, eq. 2 as written, or saturating):
/// what [`AtlasState::recompute`] sums, in the same order.
pub(super) fn fitness_of(kind: FitnessKind, atlas: &Atlas, views: &[ProbeView]) -> f64 {
    match kind {
        FitnessKind::AsWritten => views
            .iter()
            .map(|v| v.score as f64 * view_area(atlas, v))
            .sum(),
        FitnessKind::Saturating => {
            let mut best = vec![0.0f32; atlas.len()];
            for v in views {
                for &(t, q) in &v.texels {
                    best[t as usize] = best[t as usize].max(q);
                }
            }
            best.iter()
                .zip(&atlas.texel_area)
                .map(|(&b, &a)| b as f64 * a as f64)
                .sum()
        }
    }
}

/// Area of the texels in `view`.
fn view_area(atlas: &Atlas, view: &ProbeView) -> f64 {
    view.texels
        .iter()
        .map(|&(t, _)| atlas.texel_area[t as usize] as f64)
        .sum()
}

/// Share of `atlas`'s area in the texels `seen` holds true for.
fn seen_share_of(atlas: &Atlas, seen: impl Fn(usize) -> bool) -> f64 {
    let area: f64 = (0..atlas.len())
        .filter(|&t| seen(t))
        .map(|t| atlas.texel_area[t] as f64)
        .sum();
    area / atlas.total_area.max(f64::MIN_POSITIVE)
}

/// What the report and the atlas image read of a set of probes' views:
/// `R(P)` and the texels some probe sees, the figures of an
/// [`AtlasState`] of the same views without the accumulators a sweep
/// updates (per texel, the probes that see it and four running figures:
/// over 400 MB, and about half a second to build, on a 9M-texel atlas).
pub(crate) struct AtlasSummary {
    r: f64,
    seen: Vec<bool>,
    seen_share: f64,
}

impl AtlasSummary {
    /// The summary of probes with `views` over `atlas`.
    pub fn new(kind: FitnessKind, atlas: &Atlas, views: &[ProbeView]) -> AtlasSummary {
        let mut seen = vec![false; atlas.len()];
        for v in views {
            for &(t, _) in &v.texels {
                seen[t as usize] = true;
            }
        }
        AtlasSummary {
            r: fitness_of(kind, atlas, views),
            seen_share: seen_share_of(atlas, |t| seen[t]),
            seen,
        }
    }

    /// `R(P)`, as [`AtlasState::r`] gives it.
    pub fn r(&self) -> f64 {
        self.r
    }

    /// Whether some probe sees texel `t`.
    pub fn sees(&self, t: usize) -> bool {
        self.seen[t]
    }

    /// Share of the atlas area some probe sees, as
    /// [`AtlasState::seen_share`] gives it.
    pub fn seen_share(&self) -> f64 {
        self.seen_share
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::refine::view::Viewer;
    use crate::scene::testing::room_sdf;
    use glam::Vec3;

    #[test]
    fn accumulator_updates_equal_a_full_recomputation() {
        let (scene, bvh, _) = room_sdf(0.25, 1);
        let atlas = Atlas::new(&scene, 0.2).unwrap();
        let viewer = Viewer::new(&scene, &bvh, &atlas, 24, 0.087, 1.0, 1.0, 7.0);
        let start = [
            Vec3::new(0.6, 0.6, 0.6),
            Vec3::new(3.0, 2.0, 3.0),
            Vec3::new(3.3, 3.1, 0.7),
        ];
        let moves = [
            (0, Vec3::new(0.7, 2.5, 0.5)),
            (1, Vec3::new(2.5, 1.5, 3.5)),
            (0, Vec3::new(3.4, 3.2, 0.8)),
            (2, Vec3::new(0.5, 3.5, 3.5)),
            (1, Vec3::new(3.0, 2.0, 3.0)),
        ];
        for kind in [FitnessKind::Saturating, FitnessKind::AsWritten] {
            let views: Vec<ProbeView> = start.iter().map(|&p| viewer.view(p)).collect();
            let mut state = AtlasState::new(kind, &atlas, views);
            let mut positions = start;
            for &(k, p) in &moves {
                let view = viewer.view(p);
                let predicted = state.r() + state.delta(k, &view);
                state.commit(k, view);
                positions[k] = p;
                let fresh = AtlasState::new(
                    kind,
                    &atlas,
                    positions.iter().map(|&p| viewer.view(p)).collect(),
                );
                assert!((state.r() - fresh.r()).abs() < 1e-9 * fresh.r(), "{kind:?}");
                assert!((predicted - fresh.r()).abs() < 1e-9 * fresh.r());
                assert!((state.recompute() - fresh.r()).abs() < 1e-9 * fresh.r());
                for t in 0..atlas.len() {
                    assert!(
                        (state.texel_fitness(t) - fresh.texel_fitness(t)).abs() < 1e-9,
                        "{kind:?} texel {t}"
                    );
                    assert_eq!(state.best_quality(t), fresh.best_quality(t));
                }
            }
        }
    }

    /// The summary gives an accumulated state's figures, bit for bit: its
    /// fitness under both kinds, the texels seen and their share of the
    /// area, for no probe, one, and probes that share texels.
    #[test]
    fn a_summary_gives_the_states_figures() {
        let (scene, bvh, _) = room_sdf(0.25, 1);
        let atlas = Atlas::new(&scene, 0.2).unwrap();
        let viewer = Viewer::new(&scene, &bvh, &atlas, 24, 0.087, 1.0, 1.0, 7.0);
        let sets: [&[Vec3]; 3] = [
            &[],
            &[Vec3::new(3.0, 2.0, 3.0)],
            &[
                Vec3::new(0.6, 0.6, 0.6),
                Vec3::new(3.0, 2.0, 3.0),
                Vec3::new(3.3, 3.1, 0.7),
                Vec3::new(3.0, 2.0, 3.0),
            ],
        ];
        for kind in [FitnessKind::Saturating, FitnessKind::AsWritten] {
            for positions in sets {
                let views: Vec<ProbeView> = positions.iter().map(|&p| viewer.view(p)).collect();
                let summary = AtlasSummary::new(kind, &atlas, &views);
                let state = AtlasState::new(kind, &atlas, views);
                assert_eq!(summary.r().to_bits(), state.r().to_bits());
                assert_eq!(summary.seen_share().to_bits(), state.seen_share().to_bits());
                for t in 0..atlas.len() {
                    assert_eq!(summary.sees(t), state.best_quality(t).is_some(), "texel {t}");
                }
                assert_eq!(summary.seen_share() > 0.0, !positions.is_empty());
            }
        }
    }

    #[test]
    fn saturating_credits_a_texel_once_and_as_written_twice() {
        let (scene, bvh, _) = room_sdf(0.25, 1);
        let atlas = Atlas::new(&scene, 0.2).unwrap();
        let viewer = Viewer::new(&scene, &bvh, &atlas, 24, 0.087, 1.0, 1.0, 7.0);
        let p = Vec3::new(3.0, 2.0, 3.0);
        for kind in [FitnessKind::Saturating, FitnessKind::AsWritten] {
            let one = AtlasState::new(kind, &atlas, vec![viewer.view(p)]);
            let two = AtlasState::new(kind, &atlas, vec![viewer.view(p), viewer.view(p)]);
            match kind {
                FitnessKind::Saturating => {
                    assert!((two.r() - one.r()).abs() < 1e-9 * one.r());
                    // A duplicate probe adds nothing at the margin.
                    assert_eq!(two.marginal(1, two.view(1)), 0.0);
                }
                FitnessKind::AsWritten => assert!((two.r() - 2.0 * one.r()).abs() < 1e-9 * one.r()),
            }
            // 576 rays light at most 576 of the ~2500 texels.
            assert!(
                one.seen_share() > 0.1 && one.seen_share() <= 1.0,
                "{}",
                one.seen_share()
            );
        }
    }
}
