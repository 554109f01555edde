//! The report (docs/data-format.md, "Diagnosis report (JSON)") and the diagnosis that assembles it
//! from its phases: compare, judge the candidates, fit the winner on everything, conclude, locate.

use std::collections::BTreeMap;

use serde::Serialize;
use shipid_io::Dataset;
use shipid_pipeline::range::share;
use shipid_pipeline::validate::{propeller_rate_variations, recorded_rate_notes};
use shipid_sim::Effect;

use crate::compare::{Baseline, ReplayScore, outside_counts, pooled};
use crate::environment::{
    AgainstRecorded, RecordedEnvironment, RecordingWind, RevealCheck, WindageUse, against_recorded,
};
use crate::error::DiagnoseError;
use crate::families::{Family, FitResult, standard_errors};
use crate::input::{BaseRange, DiagnoseInput, DiagnoseOptions};
use crate::judge::{
    Judge, Judged, MIN_SAMPLES_FOR_HALVES, halved_recordings, rival_of, time_halves,
};
use crate::locate::{Located, Regime, locate, regimes};
use crate::verdict::Verdict;

/// One effect of a candidate: its word of the vocabulary (docs/diagnosis.md) and, for a word with
/// several forms, which form.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct EffectName {
    pub effect: &'static str,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub variant: Option<&'static str>,
}

/// A candidate effect in the report: `effect` is always a word of the vocabulary; the form of the
/// effect (`variant`) and the other members of a pair (`combined_with`) have their own fields.
#[derive(Debug, Clone, Serialize)]
pub struct Candidate {
    /// The word of the vocabulary (of the first member for a pair).
    pub effect: &'static str,
    /// The form of the effect, for `asymmetry`: `rudder_offset` or `side_force`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub variant: Option<&'static str>,
    /// The other effects of a pair, fitted together with this one.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub combined_with: Vec<EffectName>,
    /// Typical held-out relative reduction of a recording's position RMSE (1 − geometric mean of
    /// after/before over recordings), less `parsimony` per parameter.
    pub score: f64,
    /// Parameters fitted on all recordings (keys of the effect syntax; SI units, degrees).
    pub parameters: BTreeMap<String, f64>,
    /// Fraction of the mismatch above the noise floor that the effect removes on held-out recordings.
    pub explains: f64,
    /// Held-out position RMSE ÷ L with the effect.
    pub held_out_position_rmse_over_l: f64,
    pub n_parameters: usize,
    pub accepted: bool,
    /// Why a candidate that passed the held-out rules is not accepted: the evidence that it is not
    /// what differs (whole-record replays made worse, a port/starboard bias on runs turning one way).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub held_back: Option<String>,
}

#[derive(Debug, Clone, Serialize)]
pub struct Fit {
    pub position_rmse_over_l: f64,
    pub heading_rmse_deg: f64,
}

#[derive(Debug, Clone, Serialize)]
pub struct RecordingFit {
    pub recording: String,
    pub before_position_rmse_over_l: f64,
    pub after_position_rmse_over_l: f64,
    /// Fraction of the recording's states outside the base model's identification range (leverage
    /// above the largest of its training states, [`shipid_model::IdentificationRange`]), when that
    /// range is known.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub outside_identification_range: Option<f64>,
}

/// The diagnosis report (docs/data-format.md, "Diagnosis report (JSON)"; keys after `fit_after` are
/// additions).
#[derive(Debug, Clone, Serialize)]
pub struct Report {
    pub verdict: Verdict,
    pub candidates: Vec<Candidate>,
    pub located: Vec<Located>,
    pub fit_before: Fit,
    pub fit_after: Fit,
    /// The effects chosen (several when a combination was needed), in the effect syntax.
    pub effects: Vec<String>,
    /// One standard error of each chosen parameter.
    pub standard_errors: BTreeMap<String, f64>,
    /// What `standard_errors` cover and what they leave out (absent when there are none).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub standard_error_basis: Option<StandardErrorBasis>,
    /// With the verdict `wind` in its per-recording form: each recording's own wind (the runs'
    /// environment, not the model's, so `effects` is empty and no augmented model is written).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub per_recording_wind: Vec<RecordingWind>,
    pub per_recording: Vec<RecordingFit>,
    pub regimes: Vec<Regime>,
    /// Replay segment length [s] of every position/heading RMSE here.
    pub horizon_s: f64,
    /// When every recording is shorter than the asked horizon: that it was shortened to them.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub horizon_note: Option<String>,
    /// Position RMSE ÷ L expected from the recordings' noise alone.
    pub noise_floor_position_rmse_over_l: f64,
    /// The model's own held-out-style level on its training recordings, when known.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub model_level_position_rmse_over_l: Option<f64>,
    /// Fraction of all recorded states outside the base model's identification range, when known: there
    /// the base model's own forces are an extrapolation, and a mismatch left after the effect is likely
    /// the base model's.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub outside_identification_range: Option<f64>,
    pub explanation: String,
    /// What weakens the diagnosis beyond the explanation: recordings whose propeller rate varies
    /// although the model runs at one constant rate, a wind turned into forces with an assumed
    /// windage. Absent when empty.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub warnings: Vec<String>,
    /// The windage of the recorded wind and of the wind family: the data set's `[windage]`, else an
    /// assumed one (`source` says which).
    pub windage: WindageUse,
    /// The wind and current the recordings carry, taken as known inputs (part of the base model):
    /// absent when they carry none.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub recorded_environment: Option<RecordedEnvironment>,
    /// A found wind or current against the one the recordings carry (absent when the recordings carry
    /// none of what was found).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub against_recorded: Vec<AgainstRecorded>,
    /// `diagnose --reveal`: the verdict against the recorded channels that were concealed.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub reveal: Option<RevealCheck>,
    /// The model diagnosed, as given to the command (set by the caller; absent from the library).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub model: Option<String>,
    /// The data set diagnosed, as given to the command (set by the caller).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub dataset: Option<String>,
}

/// What the standard errors of a found effect cover: the recordings' scatter about the fit, with the
/// base model held fixed. The base model's own error is left out: a base that misfits its own training
/// data (a sparse GP at 0.0034 L) passes a bias on to the parameters that these errors do not show
/// (h/T 1.669 ± 0.008 for a true 1.6).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct StandardErrorBasis {
    /// What they cover.
    pub covers: &'static str,
    /// What they leave out.
    pub leaves_out: &'static str,
    /// The base model's own level on its training data (position RMSE ÷ L), when known: the size of
    /// what is left out.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub base_model_level_over_l: Option<f64>,
}

impl StandardErrorBasis {
    fn of(base_model_level_over_l: Option<f64>) -> StandardErrorBasis {
        StandardErrorBasis {
            covers: "the recordings' scatter about the fit, the base model held fixed",
            leaves_out: "the base model's own error, which a base that misfits its own training data passes on to the parameters as a bias these errors do not show",
            base_model_level_over_l,
        }
    }

    /// The basis in one sentence (printed, and in the augmented model's `source`).
    pub fn sentence(&self) -> String {
        let level = self.base_model_level_over_l.map_or(String::new(), |l| {
            format!(" (its own level on its training data: {l:.4} L)")
        });
        format!(
            "covers {}; leaves out {}{level}",
            self.covers, self.leaves_out
        )
    }
}

/// The explanation mentions the identification range when at least this fraction of the recorded
/// states lies outside it (and the mismatch is real).
const OUTSIDE_WORTH_SAYING: f64 = 0.05;

/// Diagnose `ds` against the model (see the crate docs), each recording with its recorded wind and
/// current as known inputs; refused when there is nothing to diagnose (no recording long enough), the
/// model with its own effects cannot be built or a recorded environment cannot be used.
pub fn diagnose(
    input: &DiagnoseInput,
    ds: &Dataset,
    opts: &DiagnoseOptions,
) -> Result<Report, DiagnoseError> {
    // Candidates are fitted on one half of the recordings and judged on the other: a single
    // recording is judged in two halves of its time instead (the judge's time-halves folds), so
    // that one run (with its own wind, say) can be diagnosed on its own.
    let (fitted, horizon_note) = opts.fitted_to(ds)?;
    let opts = &fitted;
    let halves;
    // Warnings and the recorded environment are the whole recording's.
    let whole = ds;
    let ds = match ds.recordings.as_slice() {
        [one] if one.recording.len() >= MIN_SAMPLES_FOR_HALVES => match time_halves(ds) {
            Some(h) => {
                halves = h;
                &halves
            }
            None => ds,
        },
        _ => ds,
    };
    let cut = !std::ptr::eq(ds, whole);
    let baseline = Baseline::of(input, ds, opts)?;
    let real_threshold = baseline.real_threshold(input.model_level_over_l, opts);
    let judge = Judge::new(input, &baseline, opts);
    let mismatch_is_real = baseline.before_l > real_threshold;
    let (mut judged, best) = judge.candidates(mismatch_is_real);
    let finals = judge.final_fits(&judged);
    let own_misfit = input
        .model_level_over_l
        .is_some_and(|level| baseline.before_l <= OWN_MISFIT_FACTOR * level);
    let best = if own_misfit {
        best
    } else {
        whole_checked(input, whole, &baseline, &mut judged, &finals, best)
    };
    // A wind of its own on each run is tried only where a real mismatch needs explaining: runs whose
    // winds are recorded (or calm) keep `none` without a family of many parameters being fitted, and
    // a winner that leaves no real mismatch (one wind for all, say) leaves nothing for it.
    let left_is_real = best.is_none_or(|b| judged[b].assessed.after_l > real_threshold);
    let mut own = if mismatch_is_real && left_is_real && !cut && baseline.prep.len() >= 2 {
        own_winds(input, ds, opts, &judged, best)?
    } else {
        None
    };
    // Each run's own wind, too, must make its whole-record replay better, not only the halves.
    if let Some(o) = own.as_mut().filter(|o| o.chosen) {
        let check = WholeCheck::of(input, whole, &baseline.windage, |file| {
            o.effects
                .iter()
                .filter(|(f, _)| f == file)
                .map(|(_, e)| e.clone())
                .collect()
        });
        if !check.improves() {
            o.chosen = false;
            o.judged.held_back = Some(check.reason());
        }
    }
    let conclusion = match (own.as_ref().filter(|o| o.chosen), best) {
        (Some(o), _) => conclude_own_winds(&baseline, o),
        (None, Some(b)) => match input.model_level_over_l {
            Some(level) if own_misfit => conclude_own_misfit(&baseline, &judged, b, level),
            _ => conclude_effect(&baseline, &judged, &finals, b),
        },
        (None, None) => conclude_nothing(
            &baseline,
            &judged,
            real_threshold,
            input.model_level_over_l,
            opts,
        ),
    };
    let mut conclusion = conclusion;
    // "They were in one wind" backs a verdict of one wind for all; beside any other verdict it would
    // assert a wind the diagnosis did not find.
    if let Some(sentence) = own.as_ref().and_then(|o| o.agreement.as_ref())
        && conclusion.verdict == Verdict::Wind
    {
        conclusion.explanation = format!("{}; {sentence}", conclusion.explanation);
    }
    if let Some(o) = own.as_ref().filter(|o| !o.chosen)
        && let Some(why) = &o.judged.held_back
    {
        conclusion.explanation = format!(
            "{}; {} is not taken either: {why}",
            conclusion.explanation,
            Family::WindPerRecording.describe()
        );
    }
    let mut report = assemble(
        input,
        &baseline,
        &judged,
        &finals,
        conclusion,
        real_threshold,
    );
    if let Some(o) = &own {
        report.candidates.push(o.candidate());
        if o.chosen {
            report.per_recording_wind = o.winds.clone();
        }
    }
    // A model that takes the propeller rate replays every recording at its recorded rate; any other
    // runs at one rate and is warned about recordings whose rate varies.
    report.warnings = if input.base.takes_propeller_rate() {
        recorded_rate_notes(input.base.propeller_rate_hz(), &whole.recordings)
    } else {
        propeller_rate_variations(&whole.recordings)
            .iter()
            .map(ToString::to_string)
            .collect()
    };
    let found: Vec<Effect> = report
        .effects
        .iter()
        .filter_map(|e| e.parse().ok())
        .collect();
    report.against_recorded = against_recorded(&found, &report.per_recording_wind, whole);
    for a in &report.against_recorded {
        report.explanation = format!("{}; {}", report.explanation, a.sentence());
    }
    report.horizon_note = horizon_note;
    report.recorded_environment = RecordedEnvironment::of(whole);
    let wind_used = report
        .recorded_environment
        .as_ref()
        .is_some_and(|e| !e.wind.is_empty())
        || report.verdict == Verdict::Wind
        || found.iter().any(|e| matches!(e, Effect::Wind(_)));
    if baseline.windage.is_assumed() && wind_used {
        report.warnings.push(format!(
            "{}: the data set has no [windage] table: the recorded wind and the wind family use an assumed windage ({}); give [windage] (docs/data-format.md) for the ship's own",
            ds.path.display(),
            shipid_sim::environment::ASSUMED_WINDAGE_SOURCE
        ));
    }
    Ok(report)
}

/// What the diagnosis concludes, before the report is laid out.
struct Conclusion {
    verdict: Verdict,
    effects: Vec<Effect>,
    standard_errors: BTreeMap<String, f64>,
    /// Held-out scores per recording without the chosen effects and with them (the model's own when
    /// there are none), judged the way the winner was.
    before_scores: Vec<ReplayScore>,
    after_scores: Vec<ReplayScore>,
    explanation: String,
}

/// The winner `b` of the candidates: its word, its effects fitted on all recordings with their
/// standard errors, and how much it explains (and which rival explains nearly as much).
fn conclude_effect(
    baseline: &Baseline,
    judged: &[Judged],
    finals: &[(Vec<Effect>, FitResult)],
    b: usize,
) -> Conclusion {
    let winner = &judged[b];
    let a = &winner.assessed;
    let (effects, fit) = &finals[b];
    let rival = rival_of(judged, b).map(|i| {
        let r = &judged[i].assessed;
        format!(
            "; but {} explains nearly as much ({:.0} %, score {:.3} against {:.3}): these recordings hardly tell the two apart with this model",
            describe(&judged[i].families),
            100.0 * r.explains,
            r.score,
            a.score
        )
    });
    Conclusion {
        verdict: winner.families[0].verdict(),
        effects: effects.clone(),
        standard_errors: standard_errors(
            &winner.families,
            effects,
            fit,
            &baseline.ship,
            &baseline.windage,
        ),
        before_scores: baseline.before_each.clone(),
        after_scores: winner.cross.0.clone(),
        explanation: format!(
            "{} explains {:.0} % of the held-out mismatch (position RMSE {:.4} L → {:.4} L, noise floor {:.4} L){}",
            describe(&winner.families),
            100.0 * a.explains,
            baseline.before_l,
            a.after_l,
            baseline.noise_floor,
            rival.unwrap_or_default()
        ),
    }
}

/// A candidate in prose, in the words of the vocabulary: `wind together with current`.
fn describe(families: &[crate::families::Family]) -> String {
    families
        .iter()
        .map(|f| f.describe())
        .collect::<Vec<_>>()
        .join(" together with ")
}

impl Candidate {
    /// A short title for tables: the word, its form in brackets, `+` and the other members of a
    /// pair (`asymmetry [rudder_offset] + current`).
    pub fn title(&self) -> String {
        let one = |effect: &str, variant: Option<&str>| match variant {
            Some(v) => format!("{effect} [{v}]"),
            None => effect.to_string(),
        };
        std::iter::once(one(self.effect, self.variant))
            .chain(self.combined_with.iter().map(|e| one(e.effect, e.variant)))
            .collect::<Vec<_>>()
            .join(" + ")
    }
}

/// Held-out error within this factor of the model's own level (its segment replays on its training
/// recordings): the recordings are reproduced as well as the training data were. Effect-free
/// recordings of another noise seed come within 1 % of the level; a concealed effect that raises the
/// error by more than a tenth is still named.
const OWN_MISFIT_FACTOR: f64 = 1.1;

/// An effect was accepted, but the recordings differ from the model no more than its own training
/// data do: the shape the effect takes out is the model's own misfit (a symmetric polynomial of a
/// port/starboard asymmetric ship, say), present in the training data as much, and not something
/// these recordings add. Named, not applied: the verdict is `none`.
fn conclude_own_misfit(
    baseline: &Baseline,
    judged: &[Judged],
    b: usize,
    level_over_l: f64,
) -> Conclusion {
    let a = &judged[b].assessed;
    Conclusion {
        verdict: Verdict::None,
        effects: Vec::new(),
        standard_errors: BTreeMap::new(),
        before_scores: baseline.before_each.clone(),
        after_scores: baseline.before_each.clone(),
        explanation: format!(
            "the recordings differ from the model no more than its own training data do (held-out position RMSE {:.4} L against its own level {level_over_l:.4} L): {} would take out {:.0} % of it ({:.4} → {:.4} L), but that shape is the model's own misfit, in its training data as much, not an effect these recordings add; a model structure that has it (refit), not an augmented model, is the remedy",
            baseline.before_l,
            describe(&judged[b].families),
            100.0 * a.explains,
            baseline.before_l,
            a.after_l
        ),
    }
}

/// A held-out position RMSE [÷ L] below which there is no mismatch to explain (exact data replay
/// within integration error, about 1e-7 L).
const NOTHING_TO_EXPLAIN_L: f64 = 1e-5;

/// A model's own level beyond this many noise floors is a misfit of its training data, not their
/// noise.
const OWN_MISFIT_BEYOND_NOISE: f64 = 5.0;

/// No candidate accepted: `unexplained` when the mismatch is real, else `none`.
/// A rejected candidate that explains at least this share of the mismatch is named beside a `none`
/// or `unexplained` verdict: the recordings' noise, not the effect's absence, may be what held it back.
const NEAR_MISS_EXPLAINS: f64 = 0.5;

/// The best of `candidates` by the report's ranking: the highest score, then the lowest held-out
/// position RMSE (not clipped, unlike `explains`), then fewer parameters.
fn closest<'a>(candidates: impl Iterator<Item = &'a Judged>) -> Option<&'a Judged> {
    candidates.min_by(|x, y| ranking(&x.assessed, &y.assessed))
}

/// The report's ranking of two assessments: `Less` when `x` ranks before `y`.
fn ranking(x: &crate::judge::Assessed, y: &crate::judge::Assessed) -> std::cmp::Ordering {
    y.score
        .total_cmp(&x.score)
        .then(x.after_l.total_cmp(&y.after_l))
        .then(x.n_parameters.cmp(&y.n_parameters))
}

fn conclude_nothing(
    baseline: &Baseline,
    judged: &[Judged],
    real_threshold: f64,
    model_level_over_l: Option<f64>,
    opts: &DiagnoseOptions,
) -> Conclusion {
    let before_l = baseline.before_l;
    let real = before_l > real_threshold;
    let name = |j: &Judged| {
        j.families
            .iter()
            .map(|f| match f.variant() {
                Some(v) => format!("{} [{v}]", f.word()),
                None => f.word().to_string(),
            })
            .collect::<Vec<_>>()
            .join(" + ")
    };
    // Candidates that passed the held-out rules but were held back by other evidence: said first,
    // with that evidence (the best by the report's ranking).
    let held_back = closest(
        judged
            .iter()
            .filter(|j| j.held_back.is_some() && j.passed_held_out),
    )
        .map_or(String::new(), |j| {
            format!(
                ". {} explains {:.0} % of the held-out segment mismatch ({before_l:.4} → {:.4} L) but is not the verdict: {}",
                name(j),
                100.0 * j.assessed.explains,
                j.assessed.after_l,
                j.held_back.as_deref().unwrap_or_default()
            )
        });
    // A share of nothing is no evidence: on exact data "explains 100 % (0.0000 → 0.0000 L)" read as
    // a near miss.
    let something_to_explain = before_l > NOTHING_TO_EXPLAIN_L.max(baseline.noise_floor);
    let near_miss = closest(judged.iter().filter(|j| {
        something_to_explain
            && j.held_back.is_none()
            && j.assessed.explains >= NEAR_MISS_EXPLAINS
    }))
    .map_or(String::new(), |j| {
        format!(
            ". Closest: {} explains {:.0} % of it held out ({before_l:.4} → {:.4} L) but was not accepted: its gain is within what the recordings' noise (floor {:.4} L) can make; more or cleaner recordings would tell whether it is there",
            name(j),
            100.0 * j.assessed.explains,
            j.assessed.after_l,
            baseline.noise_floor
        )
    });
    let near_miss = format!("{held_back}{near_miss}");
    let any_held_back = judged
        .iter()
        .any(|j| j.held_back.is_some() && j.passed_held_out);
    Conclusion {
        verdict: if real {
            Verdict::Unexplained
        } else {
            Verdict::None
        },
        effects: Vec::new(),
        standard_errors: BTreeMap::new(),
        before_scores: baseline.before_each.clone(),
        after_scores: baseline.before_each.clone(),
        explanation: if real {
            if !any_held_back {
                format!(
                    "held-out position RMSE {before_l:.4} L exceeds the model's own level and the noise ({real_threshold:.4} L), and no effect of the library reduces it by {:.0} % in both halves{near_miss}",
                    100.0 * opts.min_gain
                )
            } else {
                format!(
                    "held-out position RMSE {before_l:.4} L exceeds the model's own level and the noise ({real_threshold:.4} L), and no effect of the library explains it{near_miss}"
                )
            }
        } else {
            // A model that does not reproduce its own training data makes the threshold its own:
            // "none" then says only that nothing larger than that misfit is there. A model exact but
            // for the noise has a level of a few noise floors (the reference on noisy runs: 2.5).
            let own_bound = model_level_over_l
                .filter(|level| {
                    *level > OWN_MISFIT_BEYOND_NOISE * baseline.noise_floor
                        && opts.real_mismatch_factor * level >= 0.5 * real_threshold
                })
                .map_or(String::new(), |level| {
                    format!(
                        ". Most of that threshold is the model's own misfit of its training data ({level:.4} L): an effect that moves these recordings by less cannot be told from it, and a model that reproduces its training data better would resolve smaller effects"
                    )
                });
            format!(
                "no effect reduces the mismatch beyond the noise; position RMSE {before_l:.4} L is within the model's own level and the noise ({real_threshold:.4} L = {:.0} × the model's own level + 3 × the noise floor + what replays resolve){near_miss}{own_bound}",
                opts.real_mismatch_factor
            )
        },
    }
}

/// Every candidate as reported, with its parameters fitted on all recordings (keys prefixed by the
/// effect's kind when a candidate holds several effects).
fn candidates(judged: &[Judged], finals: &[(Vec<Effect>, FitResult)]) -> Vec<Candidate> {
    judged
        .iter()
        .zip(finals)
        .map(|(j, (effects, _))| {
            let a = &j.assessed;
            let (first, others) = j
                .families
                .split_first()
                .map_or((None, &[][..]), |(f, o)| (Some(*f), o));
            Candidate {
                effect: first.map_or(Verdict::Unexplained.word(), |f| f.word()),
                variant: first.and_then(|f| f.variant()),
                combined_with: others
                    .iter()
                    .map(|f| EffectName {
                        effect: f.word(),
                        variant: f.variant(),
                    })
                    .collect(),
                score: a.score,
                parameters: effects
                    .iter()
                    .flat_map(|e| {
                        let multi = effects.len() > 1;
                        e.parameters().into_iter().map(move |(k, v)| {
                            let key = if multi {
                                format!("{}.{k}", e.kind())
                            } else {
                                k.to_string()
                            };
                            (key, v)
                        })
                    })
                    .collect(),
                explains: a.explains,
                held_out_position_rmse_over_l: a.after_l,
                n_parameters: a.n_parameters,
                accepted: a.accepted,
                held_back: j.held_back.clone(),
            }
        })
        .collect()
}

/// The explanation with what weakens the conclusion: recordings the effect makes worse, and, when the
/// mismatch is real, recorded states outside the base model's identification range, where the base
/// model's own forces are an extrapolation.
fn with_caveats(
    input: &DiagnoseInput,
    baseline: &Baseline,
    c: &Conclusion,
    outside_all: Option<f64>,
    real_threshold: f64,
) -> String {
    let prep = &baseline.prep;
    let worse: Vec<&str> = prep
        .iter()
        .zip(c.before_scores.iter().zip(&c.after_scores))
        .filter(|(_, (b, a))| a.position_rmse() > 1.1 * b.position_rmse())
        .map(|(p, _)| p.file.as_str())
        .collect();
    let explanation = if worse.is_empty() || !c.verdict.names_effect() {
        c.explanation.clone()
    } else {
        format!(
            "{}; but it makes {} of {} recordings worse ({}), so part of the mismatch is not this effect",
            c.explanation,
            worse.len(),
            prep.len(),
            worse.join(", ")
        )
    };
    match outside_all {
        Some(f) if f >= OUTSIDE_WORTH_SAYING && baseline.before_l > real_threshold => format!(
            "{explanation}; {:.0} % of the recorded states lie outside the base model's identification range ({}), where its own forces are extrapolated: part of any mismatch left there is the base model's",
            100.0 * f,
            input.identification_range.map_or("", BaseRange::criterion)
        ),
        _ => explanation,
    }
}

/// The report of the conclusion `c`, with every candidate, the located windows and regimes, and the
/// share of states outside the base model's identification range.
fn assemble(
    input: &DiagnoseInput,
    baseline: &Baseline,
    judged: &[Judged],
    finals: &[(Vec<Effect>, FitResult)],
    c: Conclusion,
    real_threshold: f64,
) -> Report {
    let (ship, prep) = (&baseline.ship, &baseline.prep);
    let lpp = ship.lpp;
    let outside: Option<Vec<(usize, usize)>> = input
        .identification_range
        .map(|range| outside_counts(range, prep, ship));
    let outside_all = outside
        .as_ref()
        .map(|c| share(c.iter().fold((0, 0), |(o, t), &(co, ct)| (o + co, t + ct))));
    let explanation = with_caveats(input, baseline, &c, outside_all, real_threshold);
    let per_recording = prep
        .iter()
        .zip(c.before_scores.iter().zip(&c.after_scores))
        .enumerate()
        .map(|(k, (p, (b, a)))| RecordingFit {
            recording: p.file.clone(),
            before_position_rmse_over_l: b.position_rmse() / lpp,
            after_position_rmse_over_l: a.position_rmse() / lpp,
            outside_identification_range: outside.as_ref().map(|c| share(c[k])),
        })
        .collect();
    let after = pooled(&c.after_scores);
    let before = pooled(&c.before_scores);
    Report {
        verdict: c.verdict,
        candidates: candidates(judged, finals),
        // Windows locate a mismatch: where there is none (the held-out error within the model's own
        // level and the noise), the running mean's excursions are the residual's own texture (on
        // noise-free data, the differentiator's), not a mismatch, and none is listed.
        located: if baseline.before_l > real_threshold {
            locate(prep, &baseline.residuals, &baseline.scale, ship)
        } else {
            Vec::new()
        },
        fit_before: Fit {
            position_rmse_over_l: before.position_rmse() / lpp,
            heading_rmse_deg: before.heading_rmse_rad().to_degrees(),
        },
        fit_after: Fit {
            position_rmse_over_l: after.position_rmse() / lpp,
            heading_rmse_deg: after.heading_rmse_rad().to_degrees(),
        },
        effects: c.effects.iter().map(|e| e.to_string()).collect(),
        standard_error_basis: (!c.standard_errors.is_empty())
            .then(|| StandardErrorBasis::of(input.model_level_over_l)),
        standard_errors: c.standard_errors,
        per_recording_wind: Vec::new(),
        per_recording,
        regimes: regimes(prep, &baseline.residuals, &baseline.scale, ship),
        horizon_s: baseline.horizon_s,
        horizon_note: None,
        noise_floor_position_rmse_over_l: baseline.noise_floor,
        model_level_position_rmse_over_l: input.model_level_over_l,
        outside_identification_range: outside_all,
        explanation,
        warnings: Vec::new(),
        windage: WindageUse::of(&baseline.windage),
        recorded_environment: None,
        against_recorded: Vec::new(),
        reveal: None,
        model: None,
        dataset: None,
    }
}

/// How much clearer than its rivals a wind of its own on each recording must be: its held-out
/// position RMSE at most this share of the best rival's, on the same time halves (as a pair must be
/// of its single effect: many parameters fit noise and a model's own error too).
const OWN_WINDS_CLEARLY_BETTER: f64 = 0.7;

/// A wind of its own on each recording, judged on the recordings' time halves against its rivals
/// judged the same way: one wind for all, and the winner on the whole recordings, if another.
struct OwnWinds {
    /// When the runs' own winds agree (one wind), a sentence saying so: the form is then not chosen.
    agreement: Option<String>,
    judged: Judged,
    /// The data set cut into time halves and the model against it.
    halves: Baseline,
    /// Per recording (in the order of the diagnosed recordings), its wind.
    winds: Vec<RecordingWind>,
    /// Per recording, its file and its wind as an effect.
    effects: Vec<(String, Effect)>,
    /// The best rival on the same halves: its description and held-out position RMSE ÷ L.
    rival: (String, f64),
    /// Accepted on its own and clearly better than every rival.
    chosen: bool,
}

/// The per-recording wind family on `ds` cut into time halves (`None` when a recording is too short
/// to be cut), with `best` the winner among the whole recordings' `judged` candidates.
fn own_winds(
    input: &DiagnoseInput,
    ds: &Dataset,
    opts: &DiagnoseOptions,
    judged: &[Judged],
    best: Option<usize>,
) -> Result<Option<OwnWinds>, DiagnoseError> {
    let Some(cut) = time_halves(ds) else {
        return Ok(None);
    };
    let halves = Baseline::of(input, &cut, opts)?;
    let judge = Judge::new(input, &halves, opts);
    let (own, finals) = judge.per_recording_wind();
    let mut rivals = vec![vec![Family::Wind]];
    if let Some(b) = best.filter(|&b| judged[b].families != [Family::Wind]) {
        rivals.push(judged[b].families.clone());
    }
    let rival = rivals
        .iter()
        .map(|f| (describe(f), judge.judge_families(f).assessed.after_l))
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .unwrap_or_else(|| (describe(&[Family::Wind]), f64::INFINITY));
    let lpp = halves.ship.lpp;
    let winds = finals
        .iter()
        .enumerate()
        .filter_map(|(i, (effect, fit))| {
            let Effect::Wind(w) = effect else {
                return None;
            };
            let se = standard_errors(
                &[Family::Wind],
                std::slice::from_ref(effect),
                fit,
                &halves.ship,
                &halves.windage,
            );
            let units = [2 * i, 2 * i + 1];
            let before = pooled(&units.map(|u| halves.before_each[u]));
            let after = pooled(&units.map(|u| own.cross.0[u]));
            Some(RecordingWind {
                recording: halved_recordings(ds)
                    .nth(i)
                    .map_or_else(String::new, |r| r.file.clone()),
                speed_m_s: w.speed_m_s,
                from_deg: w.from_deg,
                speed_standard_error_m_s: se.get("speed").copied(),
                from_standard_error_deg: se.get("from_deg").copied(),
                before_position_rmse_over_l: before.position_rmse() / lpp,
                after_position_rmse_over_l: after.position_rmse() / lpp,
            })
        })
        .collect::<Vec<RecordingWind>>();
    // Runs that all found about one wind were in one wind: the per-recording form's extra gain is what
    // the wind-force model lacks (another ship's wind coefficients), taken up run by run.
    let effects = finals
        .iter()
        .zip(halved_recordings(ds))
        .map(|((e, _), r)| (r.file.clone(), e.clone()))
        .collect();
    let agreement = winds_agree(&winds);
    let chosen = own.assessed.accepted
        && own.assessed.after_l < OWN_WINDS_CLEARLY_BETTER * rival.1
        && agreement.is_none();
    Ok(Some(OwnWinds {
        agreement,
        judged: own,
        halves,
        winds,
        effects,
        rival,
        chosen,
    }))
}

/// Largest departure of a run's own wind from the runs' mean direction [deg] and mean speed
/// [fraction] within which the runs were in one wind.
const ONE_WIND_DIRECTION_DEG: f64 = 15.0;
const ONE_WIND_SPEED_FRACTION: f64 = 0.25;

/// `Some(sentence)` when every run's own wind is within [`ONE_WIND_DIRECTION_DEG`] of the mean
/// direction and [`ONE_WIND_SPEED_FRACTION`] of the mean speed: the runs were in one wind.
fn winds_agree(winds: &[RecordingWind]) -> Option<String> {
    if winds.len() < 2 {
        return None;
    }
    let n = winds.len() as f64;
    let mean_speed = winds.iter().map(|w| w.speed_m_s).sum::<f64>() / n;
    let (s, c) = winds.iter().fold((0.0, 0.0), |(s, c), w| {
        let (ws, wc) = w.from_deg.to_radians().sin_cos();
        (s + ws, c + wc)
    });
    let mean_from = s.atan2(c).to_degrees().rem_euclid(360.0);
    let direction_off = winds
        .iter()
        .map(|w| crate::angle_difference_deg(w.from_deg, mean_from).abs())
        .fold(0.0, f64::max);
    let speed_off = winds
        .iter()
        .map(|w| (w.speed_m_s / mean_speed - 1.0).abs())
        .fold(0.0, f64::max);
    let (lo, hi) = winds.iter().fold((f64::INFINITY, 0.0_f64), |(lo, hi), w| {
        (lo.min(w.speed_m_s), hi.max(w.speed_m_s))
    });
    (mean_speed > 0.0
        && direction_off <= ONE_WIND_DIRECTION_DEG
        && speed_off <= ONE_WIND_SPEED_FRACTION)
        .then(|| {
            format!(
                "the runs' own winds agree ({lo:.2}–{hi:.2} m/s, within {direction_off:.0}° of {mean_from:.0}°): they were in one wind, and what a wind of its own on each run takes up beyond it is what the wind-force model lacks, not another wind"
            )
        })
}

impl OwnWinds {
    /// The candidate as reported: parameters keyed `<recording>.speed` and `<recording>.from_deg`.
    fn candidate(&self) -> Candidate {
        let a = &self.judged.assessed;
        Candidate {
            effect: Family::WindPerRecording.word(),
            variant: Family::WindPerRecording.variant(),
            combined_with: Vec::new(),
            score: a.score,
            parameters: self
                .winds
                .iter()
                .flat_map(|w| {
                    [
                        (format!("{}.speed", w.recording), w.speed_m_s),
                        (format!("{}.from_deg", w.recording), w.from_deg),
                    ]
                })
                .collect(),
            explains: a.explains,
            held_out_position_rmse_over_l: a.after_l,
            n_parameters: a.n_parameters,
            accepted: self.chosen,
            held_back: self.judged.held_back.clone(),
        }
    }

    /// Scores per recording of the halves pooled back into recordings (before, after).
    fn per_recording_scores(&self) -> (Vec<ReplayScore>, Vec<ReplayScore>) {
        let pool = |s: &[ReplayScore]| -> Vec<ReplayScore> { s.chunks(2).map(pooled).collect() };
        (pool(&self.halves.before_each), pool(&self.judged.cross.0))
    }
}

/// The verdict `wind` in its per-recording form: each recording's own wind (no model effect: the
/// winds are the runs' environment), held-out figures from the recordings' time halves.
fn conclude_own_winds(baseline: &Baseline, o: &OwnWinds) -> Conclusion {
    let a = &o.judged.assessed;
    let (before_scores, after_scores) = o.per_recording_scores();
    Conclusion {
        verdict: Verdict::Wind,
        effects: Vec::new(),
        standard_errors: BTreeMap::new(),
        before_scores,
        after_scores,
        explanation: format!(
            "{} explains {:.0} % of the held-out mismatch, each recording's wind fitted on one half of its time and judged on the other (position RMSE {:.4} L → {:.4} L, against {:.4} L for {} judged the same way; noise floor {:.4} L): the winds are the runs' environment, not the model's, so the model is not augmented",
            Family::WindPerRecording.describe(),
            100.0 * a.explains,
            o.halves.before_l,
            a.after_l,
            o.rival.1,
            o.rival.0,
            baseline.noise_floor
        ),
    }
}

/// The winner by the held-out rules, if its effects fitted on all recordings also make the
/// whole-record replays better ([`WholeCheck`]); else the next accepted one that does, the others
/// held back with the evidence. A segment replay restarts from the recorded state every 10 L/U0, so an
/// effect can take out a short-term misfit of another cause (a smaller rudder shows as a tail wind on
/// zig-zags) while its force, acting the whole run, drives the ship off: a real effect brings the whole
/// run closer too.
fn whole_checked(
    input: &DiagnoseInput,
    whole: &Dataset,
    baseline: &Baseline,
    judged: &mut [Judged],
    finals: &[(Vec<Effect>, FitResult)],
    mut best: Option<usize>,
) -> Option<usize> {
    while let Some(b) = best {
        if let Some(why) = along_the_course_of_one_run(whole, &finals[b].0) {
            judged[b].assessed.accepted = false;
            judged[b].passed_held_out = true;
            judged[b].held_back = Some(why);
            best = crate::judge::best_accepted(judged);
            continue;
        }
        let check = WholeCheck::of(input, whole, &baseline.windage, |_| finals[b].0.clone());
        if check.improves() {
            return Some(b);
        }
        judged[b].assessed.accepted = false;
        judged[b].passed_held_out = true;
        judged[b].held_back = Some(check.reason());
        best = crate::judge::best_accepted(judged);
    }
    None
}

/// A wind within this angle [deg] of the approach course's axis (from ahead or astern) is
/// symmetric to port and starboard.
const ALONG_THE_COURSE_DEG: f64 = 10.0;

/// Heading sweep [deg] below which a run keeps near its approach course (a zig-zag; a turning circle
/// turns through every heading).
const NEAR_THE_COURSE_SWEEP_DEG: f64 = 180.0;

/// On one run that keeps near its approach course (a zig-zag), a wind from ahead or astern is the one
/// wind that is the same to port and starboard, and so the one a change of the ship that is the same
/// to both sides (its rudder, its damping) can pass for: a tail wind of a few m/s takes out much of a
/// smaller rudder's zig-zag misfit, and the whole-record replay gets better with it too. Other runs
/// (whose whole-record replays it would make worse) or a run through every heading tell them apart;
/// one zig-zag cannot. The reason, when `effects` hold such a wind on such a run.
fn along_the_course_of_one_run(whole: &Dataset, effects: &[Effect]) -> Option<String> {
    let [run] = whole.recordings.as_slice() else {
        return None;
    };
    let psi = &run.recording.psi;
    let (lo, hi) = psi
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &p| {
            (lo.min(p), hi.max(p))
        });
    let course = psi.first()?.to_degrees();
    let sweep_deg = (hi - lo).to_degrees();
    if sweep_deg.is_nan() || sweep_deg >= NEAR_THE_COURSE_SWEEP_DEG {
        return None;
    }
    effects.iter().find_map(|e| {
        let Effect::Wind(w) = e else { return None };
        let off = crate::angle_difference_deg(w.from_deg, course)
            .abs()
            .min(crate::angle_difference_deg(w.from_deg, course + 180.0).abs());
        (off <= ALONG_THE_COURSE_DEG).then(|| {
            format!(
                "a wind from {:.0}°, within {off:.0}° of {}'s approach course ({:.0}°), is the same to port and starboard, and on one run that keeps near its course a change of the ship that is the same to both sides (rudder size, damping) passes for it: one run cannot tell them apart; runs with other manoeuvres (a turning circle) would",
                w.from_deg,
                run.file,
                course.rem_euclid(360.0)
            )
        })
    })
}

/// Whole-record replays (what `shipid validate` reports) of the base and of the base with a
/// candidate's effects, per recording: (file, before, after) position RMSE ÷ L.
struct WholeCheck {
    pairs: Vec<(String, f64, f64)>,
}

/// A candidate must bring the typical recording's whole-record replay (geometric mean of
/// after/before) below this share of the base's: at least 10 % better, as each held-out half must be.
/// On the concealed-effect benchmark real effects bring it to 0.03–0.75; a tail wind standing in for
/// a smaller rudder on zig-zags made it 1.6–2.1 (several recordings) or 0.92 (shallow water on one run).
const WHOLE_TYPICAL_RATIO: f64 = 0.9;

impl WholeCheck {
    /// Each recording of `whole` replayed whole by the base and by the base with `effects_of(file)`.
    fn of(
        input: &DiagnoseInput,
        whole: &Dataset,
        windage: &shipid_pipeline::environment::ChosenWindage,
        effects_of: impl Fn(&str) -> Vec<Effect>,
    ) -> WholeCheck {
        let n = whole.recordings.len();
        let envs = crate::compare::environments(whole, windage)
            .ok()
            .filter(|e| e.len() == n)
            .unwrap_or_else(|| vec![None; n]);
        let base = crate::compare::Composite {
            base: input.base,
            effects: input.base_effects.to_vec(),
        };
        let pairs = whole
            .recordings
            .iter()
            .zip(&envs)
            .filter_map(|(r, env)| {
                let with = crate::compare::Composite {
                    base: input.base,
                    effects: crate::compare::combine(input.base_effects, &effects_of(&r.file)),
                };
                let (m0, m1) = (base.model()?, with.model()?);
                let before = crate::compare::whole_replay(&m0, &r.recording, env.as_ref())?;
                let after = crate::compare::whole_replay(&m1, &r.recording, env.as_ref())?;
                Some((r.file.clone(), before, after))
            })
            .collect();
        WholeCheck { pairs }
    }

    /// Geometric mean over recordings of after/before (recordings the base cannot replay left out;
    /// 1 when none is left).
    fn typical_ratio(&self) -> f64 {
        let logs: Vec<f64> = self
            .pairs
            .iter()
            .filter(|p| p.1.is_finite())
            .map(|p| (p.2.max(1e-12) / p.1.max(1e-12)).ln())
            .collect();
        if logs.is_empty() {
            return 1.0;
        }
        (logs.iter().sum::<f64>() / logs.len() as f64).exp()
    }

    /// Whether the typical whole-record replay gets better (nothing to replay: no evidence against).
    fn improves(&self) -> bool {
        self.pairs.is_empty() || self.typical_ratio() < WHOLE_TYPICAL_RATIO
    }

    /// The evidence against, in prose.
    fn reason(&self) -> String {
        let worse: Vec<String> = self
            .pairs
            .iter()
            .filter(|p| p.2.is_nan() || p.2 > p.1)
            .map(|p| format!("{} {:.2} → {:.2} L", p.0, p.1, p.2))
            .collect();
        format!(
            "with it the whole-record replays get worse, not better (typical recording × {:.2}; {}), so it takes out a short-term misfit in the segments without being what differs: these recordings cannot tell what the model lacks",
            self.typical_ratio(),
            worse.join(", ")
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn winds(pairs: &[(f64, f64)]) -> Vec<RecordingWind> {
        pairs
            .iter()
            .enumerate()
            .map(|(i, &(speed_m_s, from_deg))| RecordingWind {
                recording: format!("r{i}.csv"),
                speed_m_s,
                from_deg,
                speed_standard_error_m_s: Some(0.08),
                from_standard_error_deg: Some(1.0),
                before_position_rmse_over_l: 0.2,
                after_position_rmse_over_l: 0.1,
            })
            .collect()
    }

    /// `(name, score, held-out RMSE ÷ L, parameters)` ranked by the report's ranking: the names in
    /// order.
    fn check_ranking(candidates: &[(&str, f64, f64, usize)], expected: &[&str]) {
        let mut got: Vec<(&str, crate::judge::Assessed)> = candidates
            .iter()
            .map(|&(name, score, after_l, n_parameters)| {
                let a = crate::judge::Assessed {
                    n_parameters,
                    after_l,
                    score,
                    explains: 1.0,
                    accepted: false,
                };
                (name, a)
            })
            .collect();
        got.sort_by(|x, y| ranking(&x.1, &y.1));
        let names: Vec<&str> = got.iter().map(|(n, _)| *n).collect();
        assert_eq!(names, expected, "{candidates:?}");
    }

    /// Probe finding 5: "Closest:" named the first of the candidates whose clipped `explains` was 1
    /// (asymmetry, 0.0021 L, score 0.543) over the better current (0.0018 L, score 0.600), and a pair
    /// of four parameters (score 0.467) over a single effect (0.537). The closest is the best by
    /// score, then held-out RMSE, then fewer parameters.
    #[test]
    fn closest_is_the_best_by_score_then_held_out_rmse_then_parameters() {
        check_ranking(
            &[
                ("asymmetry", 0.543, 0.0021, 2),
                ("current", 0.600, 0.0018, 2),
            ],
            &["current", "asymmetry"],
        );
        check_ranking(
            &[
                ("current+wind", 0.467, 0.0900, 4),
                ("current", 0.537, 0.0980, 2),
            ],
            &["current", "current+wind"],
        );
        // Equal scores: the lower held-out error; then fewer parameters.
        check_ranking(
            &[("wind", 0.5, 0.0030, 2), ("current", 0.5, 0.0020, 2)],
            &["current", "wind"],
        );
        check_ranking(
            &[("pair", 0.5, 0.0020, 4), ("single", 0.5, 0.0020, 1)],
            &["single", "pair"],
        );
    }

    /// Regression (a probe's ship in one steady wind of 4 m/s from 240° with its own wind-force
    /// model): the per-recording form explained 57 % against one wind's 32 % and was the verdict,
    /// with eight winds of 3.4–4.1 m/s from 234–248° (each ±1°: the spread is the force model's,
    /// not the weather's). Runs that found about one wind were in one wind.
    #[test]
    fn runs_that_found_about_one_wind_were_in_one_wind() {
        let probe = [
            (4.07, 234.5),
            (4.03, 235.5),
            (3.87, 240.1),
            (3.80, 240.8),
            (3.94, 248.2),
            (3.93, 248.1),
            (3.41, 237.9),
            (3.44, 239.4),
        ];
        let sentence = winds_agree(&winds(&probe)).expect("one wind");
        assert!(sentence.contains("they were in one wind"), "{sentence}");
        // Through north the mean direction wraps, and the runs still agree.
        assert!(winds_agree(&winds(&[(3.0, 355.0), (3.2, 5.0), (3.1, 0.0)])).is_some());
        // Winds from different sides, or of different strength, are each run's own.
        assert!(winds_agree(&winds(&[(3.5, 10.0), (3.5, 80.0), (3.5, 200.0)])).is_none());
        assert!(winds_agree(&winds(&[(1.5, 240.0), (4.5, 240.0)])).is_none());
        assert!(winds_agree(&winds(&[(3.0, 240.0)])).is_none());
    }
}
