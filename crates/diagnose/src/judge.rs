//! Judge: every candidate is fitted to half of the recordings and judged by the segment-replay
//! position error on the other half, then the halves swap, so each recording is held out once. The
//! acceptance, parsimony, pairing and near-rival rules are here (docs/diagnosis.md, "How it decides").
//!
//! The folds are either every other recording or, on a data set cut into time halves
//! ([`time_halves`]), the recordings' first halves and their second halves: a single recording is
//! judged that way, and so is a wind of its own on each recording ([`Judge::per_recording_wind`]),
//! whose parameters cannot be predicted from the other recordings, only from the other half of
//! the same one.

use rayon::prelude::*;
use shipid_io::{Dataset, DatasetRecording, Manoeuvre};
use shipid_sim::{Dynamics, Effect};

use crate::compare::{Baseline, Composite, ReplayScore, combine, pooled, replay_scores};
use crate::families::{Family, FitResult, fit_families, start_grid};
use crate::input::{DiagnoseInput, DiagnoseOptions};
use crate::verdict::Verdict;

/// A candidate judged across the folds: per-recording held-out scores, and the parameters
/// fitted to each fold (by fold index).
type CrossFit = (Vec<ReplayScore>, Vec<(usize, Vec<f64>)>);

/// One fold's fit: the fold trained on, its parameters, and the held-out recordings' scores.
type FoldFit = (usize, Vec<f64>, Vec<(usize, ReplayScore)>);

/// The base model and the held-out evaluation of a set of effects against it.
pub(crate) struct Judge<'a> {
    base: &'a (dyn Dynamics + Send + Sync),
    base_effects: &'a [Effect],
    baseline: &'a Baseline,
    opts: &'a DiagnoseOptions,
    /// Every other recording: the two halves that are fitted and held out in turn (on a baseline of
    /// [`time_halves`], the first halves and the second halves).
    folds: [Vec<usize>; 2],
}

/// A candidate with its assessment and its cross fit (held-out scores, and the fold fits that warm
/// start its final fit).
pub(crate) struct Judged {
    pub families: Vec<Family>,
    pub assessed: Assessed,
    pub cross: CrossFit,
    /// Why a candidate that passed the held-out rules is nevertheless not accepted (the evidence
    /// that it is not what differs), for the report.
    pub held_back: Option<String>,
    /// Whether it had passed the held-out rules when it was held back (what the explanation says).
    pub passed_held_out: bool,
}

impl<'a> Judge<'a> {
    pub fn new(
        input: &DiagnoseInput<'a>,
        baseline: &'a Baseline,
        opts: &'a DiagnoseOptions,
    ) -> Judge<'a> {
        let n = baseline.prep.len();
        let folds = if n >= 2 {
            [(0..n).step_by(2).collect(), (1..n).step_by(2).collect()]
        } else {
            [vec![0], vec![]]
        };
        Judge {
            base: input.base,
            base_effects: input.base_effects,
            baseline,
            opts,
            folds,
        }
    }

    /// Segment-replay scores of the base with `effects` on the recordings `idx`; an impossible
    /// combination scores infinitely badly.
    fn score(&self, effects: &[Effect], idx: &[usize]) -> Vec<ReplayScore> {
        let c = Composite {
            base: self.base,
            effects: combine(self.base_effects, effects),
        };
        let Some(model) = c.model() else {
            return idx
                .iter()
                .map(|_| ReplayScore {
                    sum_sq_pos: f64::INFINITY,
                    count: 1,
                    ..Default::default()
                })
                .collect();
        };
        replay_scores(&model, &self.baseline.prep, idx, self.baseline.horizon_s)
    }

    /// Fit on one fold, score on the other, both ways: per-recording held-out scores and the
    /// parameters fitted to each fold.
    /// `alone[k]` holds each family's parameters fitted alone to fold k, where known (see
    /// [`start_grid`]).
    fn cross(&self, families: &[Family], alone: &[Vec<Option<&[f64]>>; 2]) -> CrossFit {
        // The two folds in parallel: a wind's grid of starts makes one candidate's folds the longest
        // tasks of a diagnosis.
        let folds: Vec<FoldFit> = (0..2)
            .into_par_iter()
            .filter(|&k| !self.folds[1 - k].is_empty())
            .map(|k| {
                let (train, test) = (&self.folds[k], &self.folds[1 - k]);
                let (effects, fit) = fit_families(
                    self.base,
                    self.base_effects,
                    families,
                    &self.baseline.prep,
                    train,
                    &self.baseline.scale,
                    &self.baseline.windage,
                    start_grid(families, &alone[k]),
                    3,
                );
                let sc = self.score(&effects, test);
                if std::env::var_os("SHIPID_DEBUG").is_some() {
                    eprintln!(
                        "fold {k}: {:?} -> {:?}",
                        effects.iter().map(|e| e.to_string()).collect::<Vec<_>>(),
                        sc.iter()
                            .map(|s| s.position_rmse() / self.base.ship().lpp)
                            .collect::<Vec<_>>()
                    );
                }
                (k, fit.params, test.iter().copied().zip(sc).collect())
            })
            .collect();
        let mut out = vec![ReplayScore::default(); self.baseline.prep.len()];
        let mut fitted = Vec::new();
        for (k, params, scores) in folds {
            fitted.push((k, params));
            scores.into_iter().for_each(|(i, s)| out[i] = s);
        }
        (out, fitted)
    }

    /// Typical per-recording change: the geometric mean of after/before over recordings, so that one
    /// recording the base model already fits badly (or where a segment runs away) cannot decide alone.
    fn typical_ratio(&self, idx: &[usize], scores: &[ReplayScore]) -> f64 {
        let before_each = &self.baseline.before_each;
        let logs: Vec<f64> = idx
            .iter()
            .map(|&i| {
                let b = before_each[i].position_rmse().max(1e-12);
                (scores[i].position_rmse().max(1e-12) / b).ln()
            })
            .collect();
        (logs.iter().sum::<f64>() / logs.len().max(1) as f64).exp()
    }

    /// Whether the typical recording of each half improves by at least 10 %: an effect that helps
    /// only where it was fitted is not one.
    fn fold_ok(&self, scores: &[ReplayScore]) -> bool {
        self.folds
            .iter()
            .filter(|f| !f.is_empty())
            .all(|f| self.typical_ratio(f, scores) < 0.9)
    }

    /// The held-out assessment of a candidate with `k` parameters from its per-recording held-out
    /// `scores`.
    fn assess(&self, k: usize, scores: &[ReplayScore]) -> Assessed {
        let b = self.baseline;
        let lpp = b.ship.lpp;
        let all: Vec<usize> = (0..b.prep.len()).collect();
        let after_l = pooled(scores).position_rmse() / lpp;
        let gain = 1.0 - self.typical_ratio(&all, scores);
        let excess = (b.before_l - b.noise_floor).max(1e-300);
        let explains = ((b.before_l - after_l) / excess).clamp(0.0, 1.0);
        let mut drops: Vec<f64> = (0..scores.len())
            .map(|i| (b.before_each[i].position_rmse() - scores[i].position_rmse()) / lpp)
            .collect();
        drops.sort_by(f64::total_cmp);
        let median_drop = drops.get(drops.len() / 2).copied().unwrap_or(0.0);
        let accepted =
            gain >= self.opts.min_gain && self.fold_ok(scores) && median_drop > 2.0 * b.noise_floor;
        Assessed {
            n_parameters: k,
            after_l,
            score: gain - self.opts.parsimony * k as f64,
            explains,
            accepted,
        }
    }

    /// Every single effect judged held-out, then pairs where one effect alone leaves a real mismatch
    /// (see [`Judge::pair_lead`]): the candidates, and the index of the winner if any.
    pub fn candidates(&self, mismatch_is_real: bool) -> (Vec<Judged>, Option<usize>) {
        let mut judged = self.singles();
        self.hold_back_one_sided(&mut judged);
        let best = best_accepted(&judged);
        let order = by_score(&judged);
        let Some((lead, none_passed)) = self.pair_lead(&judged, &order, best, mismatch_is_real)
        else {
            return (judged, best);
        };
        let pairs = self.pairs(&judged, &order, lead, none_passed);
        judged.extend(pairs);
        self.hold_back_one_sided(&mut judged);
        let best = best_accepted(&judged);
        (judged, best)
    }

    /// An `asymmetry` (a port/starboard bias), alone or in a pair, is not accepted (nor named as the
    /// closest) on recordings that turn to one side
    /// only (see [`turns_both_ways`]): there a constant side force, yaw moment or rudder offset is the
    /// same to the fit as a ship that answers its rudder differently (a smaller rudder, other
    /// damping), and the recordings cannot tell the two apart.
    fn hold_back_one_sided(&self, judged: &mut [Judged]) {
        if turns_both_ways(&self.baseline.prep, &self.baseline.ship) {
            return;
        }
        for j in judged.iter_mut() {
            let named = j.families.iter().any(|f| f.verdict() == Verdict::Asymmetry);
            if named && j.held_back.is_none() {
                j.passed_held_out = j.assessed.accepted;
                j.assessed.accepted = false;
                j.held_back = Some(
                    "the recordings turn to one side only, where a port/starboard bias cannot be told from a ship that answers its rudder differently (rudder size, damping): runs turning to both sides would tell"
                        .to_string(),
                );
            }
        }
    }

    /// Every family alone, judged held-out (in parallel).
    fn singles(&self) -> Vec<Judged> {
        let single: Vec<(Family, CrossFit)> = Family::ALL
            .par_iter()
            .map(|&f| (f, self.cross(&[f], &Default::default())))
            .collect();
        single
            .into_iter()
            .map(|(f, cross)| Judged {
                families: vec![f],
                assessed: self.assess(f.dim(), &cross.0),
                cross,
                held_back: None,
                passed_held_out: false,
            })
            .collect()
    }

    /// The single effect to pair the others with, and whether none passed alone; `None` when no pair
    /// is needed. A combination is tried when one effect alone leaves a real mismatch: the winner paired
    /// with every other effect when it leaves more than half of the mismatch; when no single effect is
    /// accepted although the mismatch is real, the best-scoring single paired with every other (its
    /// partner may make things worse alone, as a wind beside a current does) and the second with the
    /// third (two concealed effects can each explain too little alone to pass).
    fn pair_lead(
        &self,
        judged: &[Judged],
        order: &[usize],
        best: Option<usize>,
        mismatch_is_real: bool,
    ) -> Option<(usize, bool)> {
        match best {
            Some(b) => {
                let a = &judged[b].assessed;
                (a.explains < 0.5 && a.after_l > 3.0 * self.baseline.noise_floor)
                    .then_some((b, false))
            }
            None if mismatch_is_real => order.first().map(|&i| (i, true)),
            None => None,
        }
    }

    /// The pairs with the single `lead` (and, when `none_passed`, of the second and third best),
    /// judged held-out (in parallel).
    fn pairs(
        &self,
        judged: &[Judged],
        order: &[usize],
        lead: usize,
        none_passed: bool,
    ) -> Vec<Judged> {
        let after_l = judged[lead].assessed.after_l;
        let first = judged[lead].families[0];
        let mut pairs: Vec<Vec<Family>> = Family::ALL
            .iter()
            .filter(|&&f| f.verdict() != first.verdict())
            .map(|&f| vec![first, f])
            .collect();
        if let (true, [_, second, third, ..]) = (none_passed, order) {
            let (f, g) = (judged[*second].families[0], judged[*third].families[0]);
            if f.verdict() != g.verdict() {
                pairs.push(vec![f, g]);
            }
        }
        // A single effect's parameters fitted to fold k (from its cross fit).
        let fold_fit = |f: Family, k: usize| -> Option<&[f64]> {
            let single = judged.iter().find(|j| j.families[..] == [f])?;
            single
                .cross
                .1
                .iter()
                .find(|(fk, _)| *fk == k)
                .map(|(_, p)| p.as_slice())
        };
        let crosses: Vec<(Vec<Family>, CrossFit)> = pairs
            .into_par_iter()
            .map(|fams| {
                // The members' own fits to the same fold are starts (see `start_grid`).
                let alone = [0, 1].map(|k| fams.iter().map(|&f| fold_fit(f, k)).collect());
                let s = self.cross(&fams, &alone);
                (fams, s)
            })
            .collect();
        crosses
            .into_iter()
            .map(|(fams, cross)| {
                let k = fams.iter().map(|f| f.dim()).sum();
                let mut a = self.assess(k, &cross.0);
                // A pair must beat the single effect clearly, on the held-out recordings.
                a.accepted = a.accepted && a.after_l < 0.7 * after_l;
                Judged {
                    families: fams,
                    assessed: a,
                    cross,
                    held_back: None,
                    passed_held_out: false,
                }
            })
            .collect()
    }

    /// `families` judged held-out on this judge's folds (on a baseline of [`time_halves`]: the same
    /// criterion as [`Judge::per_recording_wind`], which must beat it clearly).
    pub fn judge_families(&self, families: &[Family]) -> Judged {
        let cross = self.cross(families, &Default::default());
        Judged {
            families: families.to_vec(),
            assessed: self.assess(families.iter().map(|f| f.dim()).sum(), &cross.0),
            cross,
            held_back: None,
            passed_held_out: false,
        }
    }

    /// A wind of its own on each recording, on a baseline of [`time_halves`] (units 2i and 2i + 1
    /// are recording i's halves): each recording's wind fitted on one of its halves and judged on
    /// the other, then swapped, so every half is held out once from data its wind was not fitted on.
    /// A recording's parameters touch only its own residuals, so the joint fit is one small fit per
    /// recording and half (in parallel). Returns the candidate (2 parameters per recording) and,
    /// per recording, its wind refitted on both halves (warm-started from the two half fits).
    pub fn per_recording_wind(&self) -> (Judged, Vec<(Effect, FitResult)>) {
        let n_units = self.baseline.prep.len();
        let recordings = n_units / 2;
        let family = [Family::WindPerRecording];
        let fit_on = |idx: &[usize], starts: Vec<Vec<f64>>, refine: usize| {
            fit_families(
                self.base,
                self.base_effects,
                &family,
                &self.baseline.prep,
                idx,
                &self.baseline.scale,
                &self.baseline.windage,
                starts,
                refine,
            )
        };
        let halves: Vec<(usize, Vec<f64>, ReplayScore)> = (0..n_units)
            .into_par_iter()
            .map(|train| {
                let test = train ^ 1;
                let (effects, fit) = fit_on(&[train], start_grid(&family, &[]), 3);
                let score = self.score(&effects, &[test]);
                (train, fit.params, score[0])
            })
            .collect();
        let mut scores = vec![ReplayScore::default(); n_units];
        let mut fitted = Vec::with_capacity(n_units);
        for (train, params, score) in halves {
            scores[train ^ 1] = score;
            fitted.push((train, params));
        }
        let finals: Vec<(Effect, FitResult)> = (0..recordings)
            .into_par_iter()
            .map(|i| {
                let warm = fitted
                    .iter()
                    .filter(|(u, _)| u / 2 == i)
                    .map(|(_, p)| p.clone())
                    .collect();
                let (mut effects, fit) = fit_on(&[2 * i, 2 * i + 1], warm, 1);
                (effects.remove(0), fit)
            })
            .collect();
        let assessed = self.assess(Family::WindPerRecording.dim() * recordings, &scores);
        (
            Judged {
                families: family.to_vec(),
                assessed,
                cross: (scores, fitted),
                held_back: None,
                passed_held_out: false,
            },
            finals,
        )
    }

    /// Parameters fitted on all recordings for every candidate (all are reported; the winner's are the
    /// model), from its fold fits: the grid of starts was searched there already.
    pub fn final_fits(&self, judged: &[Judged]) -> Vec<(Vec<Effect>, FitResult)> {
        let all: Vec<usize> = (0..self.baseline.prep.len()).collect();
        judged
            .par_iter()
            .map(|j| {
                let warm = j.cross.1.iter().map(|(_, p)| p.clone()).collect();
                fit_families(
                    self.base,
                    self.base_effects,
                    &j.families,
                    &self.baseline.prep,
                    &all,
                    &self.baseline.scale,
                    &self.baseline.windage,
                    warm,
                    1,
                )
            })
            .collect()
    }
}

pub(crate) use crate::input::MIN_SAMPLES_FOR_HALVES;

/// `ds` with every recording cut into its first and second half in time, interleaved (recording i's
/// halves are units 2i and 2i + 1, so the judge's alternating folds are the first halves and the
/// second halves; names say which half; a second half is a free run: it does not start with the
/// manoeuvre's execute). Recordings too short to diagnose are left out, as the diagnosis leaves them
/// out; `None` when one that remains is too short to be cut.
pub(crate) fn time_halves(ds: &Dataset) -> Option<Dataset> {
    let mut recordings = Vec::new();
    for r in halved_recordings(ds) {
        let n = r.recording.len();
        if n < MIN_SAMPLES_FOR_HALVES {
            return None;
        }
        let half = |range: std::ops::Range<usize>, manoeuvre| {
            let rec = r.recording.slice(range);
            DatasetRecording {
                file: format!(
                    "{} [{:.1}–{:.1} s]",
                    r.file,
                    rec.t.first().copied().unwrap_or(0.0),
                    rec.t.last().copied().unwrap_or(0.0)
                ),
                manoeuvre,
                recording: rec,
            }
        };
        recordings.push(half(0..n / 2, r.manoeuvre));
        recordings.push(half(n / 2..n, Manoeuvre::Free));
    }
    (!recordings.is_empty()).then(|| Dataset {
        recordings,
        ..ds.clone()
    })
}

/// The recordings [`time_halves`] cuts, in its order: recording i of these is units 2i and 2i + 1.
pub(crate) fn halved_recordings(ds: &Dataset) -> impl Iterator<Item = &DatasetRecording> {
    ds.recordings
        .iter()
        .filter(|r| r.recording.len() >= shipid_io::table::MIN_SAMPLES)
}

/// Smallest share of the turning samples (|r'| > [`TURNING_R_PRIME`]) that must turn to each side for a
/// port/starboard bias to be told from a change in how the ship answers its rudder.
const TURNING_SHARE_EACH_SIDE: f64 = 0.1;

/// Non-dimensional yaw rate r' = r L / U0 beyond which a sample is turning (the regimes' limit).
const TURNING_R_PRIME: f64 = 0.1;

/// Share of all samples that must turn for the recordings' turning to count (below it they run mostly
/// straight, where a change in how the ship answers its rudder hardly acts and a bias stands out).
const TURNING_SHARE_TO_COUNT: f64 = 0.2;

/// Whether the recordings turn to both sides (or hardly turn): of their samples that turn, at least
/// [`TURNING_SHARE_EACH_SIDE`] to port and as many to starboard (a zig-zag does; a turning circle
/// alone does not). A bias is the same whichever way the ship turns; a changed rudder or damping
/// acts with the turn: only turns both ways separate them.
pub(crate) fn turns_both_ways(prep: &[crate::compare::Prepared], ship: &shipid_io::Ship) -> bool {
    let (mut port, mut starboard, mut all) = (0usize, 0usize, 0usize);
    for p in prep {
        all += p.rec.r.len();
        for &r in &p.rec.r {
            let r_prime = r * ship.lpp / ship.u0;
            if r_prime < -TURNING_R_PRIME {
                port += 1;
            } else if r_prime > TURNING_R_PRIME {
                starboard += 1;
            }
        }
    }
    let turning = (port + starboard) as f64;
    turning < TURNING_SHARE_TO_COUNT * all as f64
        || port.min(starboard) as f64 >= TURNING_SHARE_EACH_SIDE * turning
}

/// The accepted candidate with the highest score.
pub(crate) fn best_accepted(judged: &[Judged]) -> Option<usize> {
    judged
        .iter()
        .enumerate()
        .filter(|(_, j)| j.assessed.accepted)
        .max_by(|x, y| x.1.assessed.score.total_cmp(&y.1.assessed.score))
        .map(|(i, _)| i)
}

/// Candidate indices, the highest score first.
fn by_score(judged: &[Judged]) -> Vec<usize> {
    let mut order: Vec<usize> = (0..judged.len()).collect();
    order.sort_by(|&x, &y| {
        judged[y]
            .assessed
            .score
            .total_cmp(&judged[x].assessed.score)
    });
    order
}

/// A candidate's held-out assessment.
pub(crate) struct Assessed {
    pub n_parameters: usize,
    /// Pooled held-out position RMSE ÷ L with the effect.
    pub after_l: f64,
    /// Typical relative improvement less the parsimony charge.
    pub score: f64,
    /// Fraction of the mismatch above the noise floor that the effect removes.
    pub explains: f64,
    pub accepted: bool,
}

/// A winner's score may be this close to a rival's (as a share of the winner's) before the report says
/// the recordings hardly tell the two apart.
const NEAR_TIE_SHARE: f64 = 0.25;

/// The accepted candidate that names none of the winner's words and scores within
/// [`NEAR_TIE_SHARE`] of it (the best such one), as an index into `words`/`scores`/`accepted`.
/// Why: the verdict is one word, and with a base whose own error is large where the recordings go
/// (manoeuvres it was not identified from), a current and a wind from the same side can explain the
/// same share of the mismatch; the verdict then rests on a few thousandths of score, and the user
/// should read that rather than a confident word.
fn near_rival<W: PartialEq>(
    winner: usize,
    words: &[Vec<W>],
    scores: &[f64],
    accepted: &[bool],
) -> Option<usize> {
    let w = scores[winner];
    (0..scores.len())
        .filter(|&i| {
            i != winner
                && accepted[i]
                && !words[i].iter().any(|x| words[winner].contains(x))
                && scores[i] >= w - NEAR_TIE_SHARE * w.abs()
        })
        .max_by(|&x, &y| scores[x].total_cmp(&scores[y]))
}

/// [`near_rival`] of the winner `winner` among `judged`, its words the verdicts of its families.
pub(crate) fn rival_of(judged: &[Judged], winner: usize) -> Option<usize> {
    let words: Vec<Vec<Verdict>> = judged
        .iter()
        .map(|j| j.families.iter().map(|f| f.verdict()).collect())
        .collect();
    let scores: Vec<f64> = judged.iter().map(|j| j.assessed.score).collect();
    let accepted: Vec<bool> = judged.iter().map(|j| j.assessed.accepted).collect();
    near_rival(winner, &words, &scores, &accepted)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The default data set with its recordings cut to `lengths` samples (all of them when `None`).
    fn default_data(lengths: &[Option<usize>]) -> Dataset {
        let path = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../data/kvlcc2-mmg/dataset.toml"
        );
        let mut ds = Dataset::load(std::path::Path::new(path)).unwrap();
        ds.recordings.truncate(lengths.len());
        for (r, n) in ds.recordings.iter_mut().zip(lengths) {
            if let Some(n) = *n {
                r.recording = r.recording.slice(0..n);
            }
        }
        ds
    }

    /// `time_halves` of recordings of `lengths`: `None`, or per unit (recording, first sample's
    /// time, sample count, manoeuvre is a free run).
    fn check_halves(lengths: &[Option<usize>], expected: Option<&[(usize, usize, bool)]>) {
        let ds = default_data(lengths);
        let got = time_halves(&ds).map(|h| {
            h.recordings
                .iter()
                .map(|u| {
                    let whole = ds
                        .recordings
                        .iter()
                        .position(|r| u.file.starts_with(&format!("{} [", r.file)))
                        .unwrap();
                    (whole, u.recording.len(), u.manoeuvre == Manoeuvre::Free)
                })
                .collect::<Vec<_>>()
        });
        assert_eq!(got.as_deref(), expected, "{lengths:?}");
    }

    #[test]
    fn time_halves_interleave_each_recordings_first_and_second_half() {
        // Units 2i and 2i + 1 are recording i's halves, so the alternating folds are the first
        // halves and the second halves; a second half is a free run.
        check_halves(
            &[Some(100), Some(201)],
            Some(&[
                (0, 50, false),
                (0, 50, true),
                (1, 100, false),
                (1, 101, true),
            ]),
        );
        // A recording too short to diagnose at all is left out, as the diagnosis leaves it out.
        check_halves(
            &[Some(100), Some(19), Some(80)],
            Some(&[(0, 50, false), (0, 50, true), (2, 40, false), (2, 40, true)]),
        );
        // One that is diagnosed but too short to be cut: no time halves.
        check_halves(&[Some(100), Some(79)], None);
    }

    fn check_rival(candidates: &[(&str, f64, bool)], winner: usize, expected: Option<usize>) {
        let words: Vec<Vec<&str>> = candidates
            .iter()
            .map(|c| c.0.split('+').collect())
            .collect();
        let scores: Vec<f64> = candidates.iter().map(|c| c.1).collect();
        let accepted: Vec<bool> = candidates.iter().map(|c| c.2).collect();
        assert_eq!(
            near_rival(winner, &words, &scores, &accepted),
            expected,
            "{candidates:?}"
        );
    }

    #[test]
    fn a_near_tie_names_the_rival_word_and_a_clear_win_does_not() {
        // The head wind off the base's manoeuvres (bench/diagnose-unseen.sh, seed 39).
        check_rival(
            &[
                ("current", 0.400, true),
                ("wind", 0.397, true),
                ("rudder_lag", -0.06, false),
            ],
            0,
            Some(1),
        );
        // Clear win; the runner-up scores less than three quarters of the winner.
        check_rival(&[("current", 0.70, true), ("wind", 0.50, true)], 0, None);
        // Not accepted: no rival.
        check_rival(&[("current", 0.40, true), ("wind", 0.39, false)], 0, None);
        // A pair or a variant holding the winner's word is no rival.
        check_rival(
            &[
                ("wind", 0.36, true),
                ("wind+asymmetry", 0.45, true),
                ("asymmetry", 0.1, true),
            ],
            0,
            None,
        );
        // The best of several rivals.
        check_rival(
            &[
                ("current", 0.40, true),
                ("wind", 0.33, true),
                ("shallow_water", 0.38, true),
            ],
            0,
            Some(2),
        );
    }
}
