//! The model file `kind = "mmg"`: every identified parameter with its value, bounds, prior, the prior's
//! source, standard error, the data's share of its precision and whether the data determine it; the
//! ship, added masses, propeller and rudder data; the training windows and the estimator; with
//! `fit --bootstrap N` its `[bootstrap]` replicates and with `--calibrate` the `[calibration]` factors
//! that widen them (docs/uncertainty.md). (The file
//! of a fit is built in the parent module: this one, read by `model_file`, imports no fit.)

use std::collections::BTreeMap;
use std::path::Path;

use serde::{Deserialize, Serialize};
use shipid_io::{AddedMass, Ship};
use shipid_model::{Refinement, TrainingWindow};
use shipid_sim::MmgModel;

use super::geometry::MmgGeometry;
use super::identify::{DETERMINED_SHARE, assemble};
use super::thrust::INFLOW_NAMES;
use crate::error::{PipelineError, bad_input};
use shipid_io::error::number;

/// The `kind` of an MMG model file.
pub const MMG_KIND: &str = "mmg";

/// `[propeller]` of the model file.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PropellerEntry {
    pub diameter_m: f64,
    pub x_m: f64,
    /// K_T(J) = k0 + k1 J + k2 J².
    pub k_t: [f64; 3],
    /// The rate a simulation holds [1/s] (mean recorded rate of the training windows).
    pub rate_rps: f64,
}

/// `[rudder]` of the model file.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RudderEntry {
    pub area_m2: f64,
    pub span_m: f64,
    pub x_m: f64,
}

/// `[[estimator.cv]]`: one candidate prior weight and its mean held-out cost.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CvEntry {
    pub lambda: f64,
    pub held_out_cost: f64,
}

/// `[estimator]` of the model file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MmgEstimatorEntry {
    /// `bounded-lsq` or `ridge` (the inner solve of the hull derivatives).
    pub name: String,
    pub method: String,
    /// λ, the weight of the prior.
    pub prior_weight: f64,
    pub tuned: bool,
    /// A parameter counts as determined by the data above this share of its precision.
    pub determined_share: f64,
    pub samples: usize,
    /// RMS of the prime equation-error residual [X', Y', N'].
    pub residual_rms: [f64; 3],
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub cv: Vec<CvEntry>,
    /// The cross-validation refined each fold's fit before scoring it, as the final fit was
    /// (`--tune --refine`).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub cv_folds_refined: bool,
    /// The output-error refinement after the equation error (`fit --refine`); the standard errors
    /// and data shares are then those of the equation-error estimate.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub refinement: Option<Refinement>,
    /// The propeller inflow the training windows' recorded thrust measures.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub thrust_inflow: Option<ThrustInflowEntry>,
    /// The delete-one-recording jackknife of the equation-error estimate (three or more training
    /// recordings); each parameter's `jackknife_standard_error` comes from it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub jackknife: Option<JackknifeEntry>,
}

/// `[estimator.jackknife]`: the refits with one training recording left out in turn.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct JackknifeEntry {
    pub method: String,
    /// The recording(s) each refit that succeeded left out.
    pub left_out: Vec<String>,
    /// Refits that failed, with the reason; the standard errors are over the others.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub failed: Vec<String>,
    /// Each parameter's value in every refit, in the order of `left_out`: `simulate` runs them
    /// beside the model.
    #[serde(default)]
    pub values: BTreeMap<String, Vec<f64>>,
}

/// A jackknife standard error this many times the information matrix's is reported: the samples'
/// errors are then far from independent, and the information matrix's error is not the one to read.
pub const JACKKNIFE_REPORT_RATIO: f64 = 2.0;

/// `[estimator.thrust_inflow]`: the propeller's wake parameters as the recorded thrust measures them
/// (the open-water curve inverted at K_T = T/(ρn²D⁴), 1 − w_P of the MMG wake model fitted to it).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ThrustInflowEntry {
    /// Whether the fit held its parameters there (`fit --inflow-from-thrust`); otherwise they were
    /// identified from the motion and this is the measurement beside them.
    pub held: bool,
    pub samples: usize,
    pub recordings: Vec<String>,
    /// RMS of the measured 1 − w_P about the fitted wake model [-].
    pub residual_rms: f64,
    /// w_p0, c1, c2_pos, c2_neg.
    pub values: BTreeMap<String, f64>,
    pub standard_errors: BTreeMap<String, f64>,
}

/// `[[parameter]]` of the model file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ParamEntry {
    pub name: String,
    pub value: f64,
    pub lower: f64,
    pub upper: f64,
    pub prior: f64,
    pub prior_sd: f64,
    pub prior_source: String,
    pub standard_error: f64,
    /// Share of the posterior precision that comes from the data, in [0, 1].
    pub data_share: f64,
    /// The information matrix's verdict (`data_share` above `estimator.determined_share`, off its
    /// bounds); [`ParamEntry::identifiability`] also weighs `jackknife_standard_error`.
    pub determined_by_data: bool,
    /// Spread of the refits with each training recording left out (`[estimator.jackknife]`): the
    /// standard error when the recordings' misfits are not independent samples.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub jackknife_standard_error: Option<f64>,
}

impl ParamEntry {
    /// The bound the value sits on (within 1e-3 of the bounds' width, or of the prior's sd for a
    /// one-sided bound), for a parameter the fit moved (bounds not collapsed onto one value).
    pub fn bound_reached(&self) -> Option<f64> {
        // Bounds collapsed onto one value (a held parameter), or not ordered: nothing the fit moved.
        if self.lower.partial_cmp(&self.upper) != Some(std::cmp::Ordering::Less) {
            return None;
        }
        let width = self.upper - self.lower;
        let scale = if width.is_finite() {
            width
        } else {
            self.prior_sd.abs().max(f64::MIN_POSITIVE)
        };
        [self.lower, self.upper]
            .into_iter()
            .find(|b| b.is_finite() && (self.value - b).abs() <= 1e-3 * scale)
    }
}

/// A parameter whose data share says "prior" but which lies more than this many prior standard
/// deviations from its prior did not stay there: the prior would have held it within about 2 sd, so
/// what moved it is the data acting through parameters it is correlated with.
pub const PRIOR_HELD_SD: f64 = 2.0;

/// What a fit says of one parameter, in the order `fit` prints them.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Identifiability {
    /// On one of its bounds ([`ParamEntry::bound_reached`]): held by the bound, whatever its data
    /// share; its standard error describes the problem without the bound.
    OnBound,
    /// More than [`DETERMINED_SHARE`](super::identify::DETERMINED_SHARE) of its precision from the
    /// data, by the information matrix and by the leave-one-recording-out jackknife when there is one.
    DeterminedByData,
    /// Determined by the information matrix, but the refits without one recording spread it so far
    /// that the data hold it no tighter than its prior does (jackknife share ≤
    /// [`DETERMINED_SHARE`](super::identify::DETERMINED_SHARE)): the recordings disagree about it.
    RecordingsDisagree,
    /// Little precision of its own from the data, yet more than [`PRIOR_HELD_SD`] prior sd from its
    /// prior: moved by the parameters it is correlated with.
    MovedByCorrelated,
    /// Little precision from the data, and near its prior: it stayed there.
    PriorHeld,
}

impl Identifiability {
    /// The label in `fit --json` (`identifiability` by parameter name).
    pub fn label(self) -> &'static str {
        match self {
            Identifiability::OnBound => "on-bound",
            Identifiability::DeterminedByData => "determined-by-data",
            Identifiability::RecordingsDisagree => "recordings-disagree",
            Identifiability::MovedByCorrelated => "moved-by-correlated",
            Identifiability::PriorHeld => "prior-held",
        }
    }
}

impl ParamEntry {
    /// |value − prior| in prior standard deviations (∞ for a prior of no width).
    pub fn prior_distance_sd(&self) -> f64 {
        (self.value - self.prior).abs() / self.prior_sd.abs()
    }

    /// The share of the prior's variance the recordings' disagreement leaves out,
    /// 1 − (jackknife standard error / prior sd)², in [0, 1]; `None` without a jackknife.
    pub fn jackknife_share(&self) -> Option<f64> {
        let se = self.jackknife_standard_error?;
        Some((1.0 - (se / self.prior_sd).powi(2)).clamp(0.0, 1.0))
    }

    /// Which of [`Identifiability`]'s labels the fit's numbers support.
    pub fn identifiability(&self) -> Identifiability {
        if self.bound_reached().is_some() {
            Identifiability::OnBound
        } else if self.determined_by_data
            && self
                .jackknife_share()
                .is_some_and(|s| s <= super::identify::DETERMINED_SHARE)
        {
            Identifiability::RecordingsDisagree
        } else if self.determined_by_data {
            Identifiability::DeterminedByData
        } else if self.prior_distance_sd() > PRIOR_HELD_SD {
            Identifiability::MovedByCorrelated
        } else {
            Identifiability::PriorHeld
        }
    }
}

/// A parameter value as a summary line shows it: four significant digits.
fn short(x: f64) -> String {
    let a = x.abs();
    if a == 0.0 || (1e-3..1e5).contains(&a) {
        // Rust's shortest form of the rounded value: no trailing zeros.
        format!("{}", (x * 1e4).round() / 1e4)
    } else {
        format!("{x:.3e}")
    }
}

/// How `values` (a parameter's bootstrap replicates) fail to spread around the fit `fit`, in words;
/// `None` when they do. Two shapes: split into two groups with an empty gap between them of more
/// than half their range, each holding at least a tenth of the replicates (resamples ending in two
/// minima, or on a bound and off it); or the fit outside the central 90 % of the replicates (all of
/// them on one side of the estimate). Either way their standard deviation is not the estimate's
/// standard error. Fewer than 10 replicates say nothing about a shape.
pub fn replicate_shape(values: &[f64], fit: f64) -> Option<String> {
    let mut v: Vec<f64> = values.iter().copied().filter(|x| x.is_finite()).collect();
    if v.len() < 10 || !fit.is_finite() {
        return None;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    let range = v[n - 1] - v[0];
    if range <= 0.0 {
        return None;
    }
    let (gap_at, gap) = v
        .windows(2)
        .enumerate()
        .map(|(i, w)| (i + 1, w[1] - w[0]))
        .max_by(|a, b| a.1.total_cmp(&b.1))?;
    let tenth = n.div_ceil(10);
    if gap > 0.5 * range && gap_at >= tenth && n - gap_at >= tenth {
        let (low, high) = (&v[..gap_at], &v[gap_at..]);
        let group = |g: &[f64]| {
            format!(
                "{} … {} ({} %)",
                short(g[0]),
                short(g[g.len() - 1]),
                (100.0 * g.len() as f64 / n as f64).round()
            )
        };
        let holds = |g: &[f64]| (g[0]..=g[g.len() - 1]).contains(&fit);
        return Some(format!(
            "two groups, {} and {}{}",
            group(low),
            group(high),
            if holds(low) || holds(high) {
                format!(", the fit {} in one", short(fit))
            } else {
                format!(", neither holding the fit {}", short(fit))
            }
        ));
    }
    let q = |p: f64| shipid_uncertainty::band::quantile(&v, p);
    let (lo, hi) = (q(0.05), q(0.95));
    (!(lo..=hi).contains(&fit)).then(|| {
        format!(
            "the central 90 % [{}, {}] lies beside the fit {}",
            short(lo),
            short(hi),
            short(fit)
        )
    })
}

/// An MMG model file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MmgModelFile {
    pub shipid_version: String,
    pub kind: String,
    pub ship: Ship,
    pub added_mass: AddedMass,
    pub propeller: PropellerEntry,
    pub rudder: RudderEntry,
    pub estimator: MmgEstimatorEntry,
    #[serde(default)]
    pub training: Vec<TrainingWindow>,
    #[serde(rename = "parameter")]
    pub parameters: Vec<ParamEntry>,
    /// Block-bootstrap replicates of the parameters (`shipid fit --set mmg --bootstrap N`), from
    /// which `simulate --bands` and `validate --bands` draw their bands.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bootstrap: Option<MmgBootstrapRecord>,
    /// Inflation factors of calibrated bands over the `[bootstrap]` replicates (`shipid fit --set
    /// mmg --bootstrap N --calibrate`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub calibration: Option<shipid_model::calibration::FactorCalibrationRecord>,
    /// The refinements from the other prior weights of the cross-validation grid (`fit --set mmg
    /// --refine`), which `simulate` runs beside this model.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub valley: Option<MmgValleyRecord>,
}

/// `[valley]` of an mmg model file: the fit at every other prior weight of the cross-validation grid,
/// each refined like this model, with its cost on this model's refinement objective.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MmgValleyRecord {
    /// What the starts are, in words.
    pub method: String,
    /// A start is in the valley when its cost ratio is at most 1 + this.
    pub cost_tolerance: f64,
    #[serde(rename = "start")]
    pub starts: Vec<ValleyStartEntry>,
}

/// `[[valley.start]]`: one start, refined (its cost ratio and parameter values) or failed (why).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ValleyStartEntry {
    /// λ of the equation-error fit it was refined from.
    pub prior_weight: f64,
    /// Its refinement's cost ÷ this model's, both on this model's refinement objective.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cost_ratio: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub failed: Option<String>,
    /// The refined parameters by name (every `[[parameter]]`).
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub values: BTreeMap<String, f64>,
}

impl ValleyStartEntry {
    /// Whether it ended within the record's tolerance of this model's cost.
    pub fn in_valley(&self, tolerance: f64) -> bool {
        self.failed.is_none() && self.cost_ratio.is_some_and(|c| c <= 1.0 + tolerance)
    }
}

/// What the replicates of an mmg `[bootstrap]` are, which decides how a band is drawn from them.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ReplicateKind {
    /// Re-identifications on moving-block resamples of the training data (`shipid fit --bootstrap`):
    /// a sample of the estimator's distribution, banded by its percentiles.
    #[default]
    BlockBootstrap,
    /// The kept members of an inverse ensemble (`shipid inverse`): a few tens of equally plausible
    /// answers, banded by order statistics so that every member, the delivered one included, lies
    /// inside.
    InverseEnsemble,
}

/// `[bootstrap]` of an mmg model file: the parameter uncertainty by a moving-block bootstrap, or the
/// members of an inverse ensemble (`replicate_kind`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MmgBootstrapRecord {
    /// What the replicates are (absent in files written before 0.3.0: a block bootstrap).
    #[serde(default)]
    pub replicate_kind: ReplicateKind,
    /// How the replicates were drawn and re-identified, in words.
    pub method: String,
    /// Seed of the replicate draws (SplitMix64 per replicate).
    pub seed: u64,
    /// Samples per block, and why that length.
    pub block_rows: usize,
    pub block_reason: String,
    /// Replicates whose re-identification failed (not stored).
    pub rejected: usize,
    /// Bootstrap standard error per parameter (the units of its `value`).
    pub standard_error: BTreeMap<String, f64>,
    /// Parameter names in the order of the rows and columns of `correlation`.
    pub order: Vec<String>,
    pub correlation: Vec<Vec<f64>>,
    /// Replicate values per parameter; entry k of every list belongs to replicate k.
    pub replicates: BTreeMap<String, Vec<f64>>,
}

impl MmgBootstrapRecord {
    /// The replicates as values in the order of `parameters`, checked: every parameter has as many
    /// finite replicates as the others, within its bounds, and no unknown name is given. A fault is
    /// (key under `[bootstrap]`, message).
    pub fn parameter_vectors(
        &self,
        parameters: &[ParamEntry],
    ) -> Result<Vec<Vec<f64>>, (String, String)> {
        if let Some(extra) = self
            .replicates
            .keys()
            .find(|k| !parameters.iter().any(|p| &p.name == *k))
        {
            return Err((
                format!("bootstrap.replicates.{extra}"),
                "is not a parameter of the model".into(),
            ));
        }
        let mut count: Option<(usize, &str)> = None;
        let mut columns = Vec::with_capacity(parameters.len());
        for p in parameters {
            let key = format!("bootstrap.replicates.{}", p.name);
            let values = self.replicates.get(&p.name).ok_or_else(|| {
                (
                    key.clone(),
                    "missing: no replicates of this parameter".into(),
                )
            })?;
            match count {
                None => count = Some((values.len(), &p.name)),
                Some((n, first)) if n != values.len() => {
                    return Err((
                        key,
                        format!("has {} replicates, {first} has {n}", values.len()),
                    ));
                }
                Some(_) => {}
            }
            if let Some(v) = values
                .iter()
                .find(|v| !(v.is_finite() && (p.lower..=p.upper).contains(*v)))
            {
                return Err((
                    key,
                    format!(
                        "replicate value {v} is not a finite number within the bounds [{}, {}]",
                        p.lower, p.upper
                    ),
                ));
            }
            columns.push(values);
        }
        let n = count.map_or(0, |(n, _)| n);
        Ok((0..n)
            .map(|k| columns.iter().map(|c| c[k]).collect())
            .collect())
    }
}

/// Propeller and rudder sizes no ship has in a model file, as (key, message): the data set's checks
/// (`shipid_io::dataset::hardware_fault`), so a model file cannot carry what a data set may not.
pub fn hardware_fault(
    ship: &Ship,
    propeller: &PropellerEntry,
    rudder: &RudderEntry,
) -> Option<(&'static str, String)> {
    if let Some(fault) = shipid_io::dataset::hardware_fault_placed(
        ship,
        Some((propeller.diameter_m, propeller.x_m)),
        Some((rudder.area_m2, rudder.span_m, rudder.x_m)),
    ) {
        return Some(fault);
    }
    // The curve a data set may not carry either (K_T × 100, rising with J).
    shipid_io::open_water::k_t_coefficients_problem(&propeller.k_t)
        .map(|why| ("propeller.k_t", why))
}

impl MmgModelFile {
    /// The lines `shipid fit --set mmg` prints below its first line: residuals, the parameters the
    /// data determine and those that stayed at their prior (with their data share).
    pub fn summary(&self) -> Vec<String> {
        let e = &self.estimator;
        let mut lines = vec![format!(
            "  prior weight λ = {:e}{}; equation-error residual RMS X' {:.3e}, Y' {:.3e}, N' {:.3e}",
            e.prior_weight,
            match (e.tuned, e.cv_folds_refined) {
                (true, true) => " (cross-validated, every fold's fit refined as this one)",
                (true, false) => " (cross-validated)",
                _ => "",
            },
            e.residual_rms[0],
            e.residual_rms[1],
            e.residual_rms[2]
        )];
        if let Some(r) = &e.refinement {
            lines.push(format!(
                "  refined: segment-replay position RMSE {:.4} L → {:.4} L, heading {:.3}° → {:.3}° ({} iterations)",
                r.before_position_rmse_over_l,
                r.after_position_rmse_over_l,
                r.before_heading_rmse_deg,
                r.after_heading_rmse_deg,
                r.iterations
            ));
        }
        if let Some(v) = &self.valley {
            let kept: Vec<&ValleyStartEntry> = v
                .starts
                .iter()
                .filter(|s| s.in_valley(v.cost_tolerance))
                .collect();
            let ratios = |s: &[&ValleyStartEntry]| {
                s.iter()
                    .map(|s| {
                        format!(
                            "λ = {:e}: {}",
                            s.prior_weight,
                            s.cost_ratio.map_or("failed".into(), |c| format!("{c:.3}"))
                        )
                    })
                    .collect::<Vec<_>>()
                    .join(", ")
            };
            let all: Vec<&ValleyStartEntry> = v.starts.iter().collect();
            lines.push(format!(
                "  valley: {} of {} refinements from the other prior weights end within {:.0} % of this cost ({}){}",
                kept.len(),
                v.starts.len(),
                100.0 * v.cost_tolerance,
                ratios(&all),
                if kept.is_empty() {
                    ": one minimum"
                } else {
                    "; `simulate` runs them beside this model"
                }
            ));
        }
        if let Some(t) = &e.thrust_inflow {
            let measured = |name: &String, v: &f64| {
                let se = t.standard_errors.get(name).copied().unwrap_or(f64::NAN);
                // A thrust record without the drift that sets C₁ and C₂ (a straight run, a few
                // samples) leaves them undetermined: "± inf" would read as a number.
                let value = if se.is_finite() {
                    format!("{name} {v:.3} ± {se:.3}")
                } else {
                    format!("{name} {v:.3} (undetermined: no standard error)")
                };
                match (t.held, self.parameters.iter().find(|p| &p.name == name)) {
                    (false, Some(p)) => format!("{value} (fit {:.3})", p.value),
                    _ => value,
                }
            };
            lines.push(format!(
                "  the recorded thrust ({} samples) measures {}{}",
                t.samples,
                INFLOW_NAMES
                    .iter()
                    .filter_map(|n| t.values.get_key_value(*n))
                    .map(|(n, v)| measured(n, v))
                    .collect::<Vec<_>>()
                    .join(", "),
                if t.held {
                    ": held there"
                } else {
                    "; --inflow-from-thrust holds them there"
                }
            ));
        }
        let on_bound: Vec<String> = self
            .parameters
            .iter()
            .filter_map(|p| p.bound_reached().map(|b| format!("{} = {b}", p.name)))
            .collect();
        if !on_bound.is_empty() {
            lines.push(format!(
                "  on a bound ({}): {} — the data push these past the range the bounds allow; what they stand in for may be missing from the structure, and their standard errors describe the problem without the bound, not these estimates (docs/mmg.md, Identifiability)",
                on_bound.len(),
                on_bound.join(", ")
            ));
        }
        let held: Vec<String> = self
            .parameters
            .iter()
            .filter_map(|p| {
                super::priors::regression_outside(&p.prior_source)
                    .map(|raw| format!("{} (gives {raw}, held at {})", p.name, p.prior))
            })
            .collect();
        if !held.is_empty() {
            lines.push(format!(
                "  priors outside their regression ({}): {} — this ship lies outside the ships the regression was fitted on (or past the bound's sign): the prior is a guess; each `prior_source` says so",
                held.len(),
                held.join(", ")
            ));
        }
        let of = |label: Identifiability| -> Vec<&ParamEntry> {
            self.parameters
                .iter()
                .filter(|p| p.identifiability() == label)
                .collect()
        };
        let data = of(Identifiability::DeterminedByData);
        lines.push(format!(
            "  determined by the data ({}): {}",
            data.len(),
            data.iter()
                .map(|p| p.name.as_str())
                .collect::<Vec<_>>()
                .join(", ")
        ));
        if let Some(j) = &e.jackknife {
            let wide: Vec<String> = self
                .parameters
                .iter()
                .filter(|p| p.identifiability() != Identifiability::OnBound)
                .filter_map(|p| {
                    let jse = p.jackknife_standard_error?;
                    (jse > JACKKNIFE_REPORT_RATIO * p.standard_error).then(|| {
                        format!(
                            "{} ± {} (information ± {})",
                            p.name,
                            short(jse),
                            short(p.standard_error)
                        )
                    })
                })
                .collect();
            let refits = j.left_out.len();
            lines.push(if wide.is_empty() {
                format!(
                    "  leave-one-recording-out ({refits} refits): no parameter spreads more than {JACKKNIFE_REPORT_RATIO} times its standard error"
                )
            } else {
                format!(
                    "  leave-one-recording-out ({refits} refits{}): the recordings disagree more than the information matrix allows about ({}) {} — read these standard errors, not the information matrix's, which counts every sample as independent",
                    if j.failed.is_empty() {
                        String::new()
                    } else {
                        format!(", {} failed: {}", j.failed.len(), j.failed.join("; "))
                    },
                    wide.len(),
                    wide.join(", ")
                )
            });
            let disputed = of(Identifiability::RecordingsDisagree);
            if !disputed.is_empty() {
                lines.push(format!(
                    "  not determined: the recordings disagree ({}): {} — without one recording each moves about as far as its prior allows",
                    disputed.len(),
                    disputed
                        .iter()
                        .map(|p| format!(
                            "{} (jackknife ± {}, prior sd {})",
                            p.name,
                            short(p.jackknife_standard_error.unwrap_or(f64::NAN)),
                            short(p.prior_sd)
                        ))
                        .collect::<Vec<_>>()
                        .join(", ")
                ));
            }
        }
        let moved = of(Identifiability::MovedByCorrelated);
        if !moved.is_empty() {
            lines.push(format!(
                "  weakly determined, moved by correlated parameters ({}): {} — the data determine a combination of these with others, not each alone: each is far from its prior although the data give it little precision of its own",
                moved.len(),
                moved
                    .iter()
                    .map(|p| format!(
                        "{} = {} (data share {:.2}, {:.1} prior sd from its prior {})",
                        p.name,
                        short(p.value),
                        p.data_share,
                        p.prior_distance_sd(),
                        short(p.prior)
                    ))
                    .collect::<Vec<_>>()
                    .join(", ")
            ));
        }
        let prior = of(Identifiability::PriorHeld);
        lines.push(format!(
            "  prior-held ({}): {}",
            prior.len(),
            if prior.is_empty() {
                "none".to_string()
            } else {
                prior
                    .iter()
                    .map(|p| format!("{} (data share {:.2})", p.name, p.data_share))
                    .collect::<Vec<_>>()
                    .join(", ")
            }
        ));
        if let Some(b) = &self.bootstrap {
            let odd: Vec<String> = self
                .parameters
                .iter()
                .filter_map(|p| {
                    let values = b.replicates.get(&p.name)?;
                    replicate_shape(values, p.value).map(|s| format!("{}: {s}", p.name))
                })
                .collect();
            if !odd.is_empty() {
                lines.push(format!(
                    "  bootstrap replicates that do not spread around the fit ({}): {} — their standard errors describe no spread about the estimate; the resamples end in other minima or on bounds",
                    odd.len(),
                    odd.join("; ")
                ));
            }
        }
        lines
    }

    fn geometry(&self) -> MmgGeometry {
        MmgGeometry {
            propeller_diameter_m: self.propeller.diameter_m,
            propeller_x_m: self.propeller.x_m,
            k_t: self.propeller.k_t,
            rudder_area_m2: self.rudder.area_m2,
            rudder_span_m: self.rudder.span_m,
            rudder_x_m: self.rudder.x_m,
        }
    }

    /// The model this file describes; a fault names the file and the key.
    pub fn to_model(&self, path: &Path) -> Result<MmgModel, PipelineError> {
        let at =
            |key: String, msg: String| bad_input(format!("{}: key `{key}`: {msg}", path.display()));
        if self.kind != MMG_KIND {
            return Err(at(
                "kind".into(),
                format!("expected \"{MMG_KIND}\", not \"{}\"", self.kind),
            ));
        }
        // The sim crate's list, which the identification's names are held equal to
        // (`identified_parameter_names_are_the_model_file_names`).
        let known = &shipid_sim::mmg::MODEL_FILE_NAMES;
        for (i, p) in self.parameters.iter().enumerate() {
            if !known.contains(&p.name.as_str()) {
                return Err(at(
                    format!("parameter[{i}].name"),
                    format!(
                        "unknown MMG parameter `{}` (expected one of {})",
                        p.name,
                        known.join(", ")
                    ),
                ));
            }
            if self.parameters[..i].iter().any(|q| q.name == p.name) {
                return Err(at(
                    format!("parameter[{i}].name"),
                    format!("`{}` is given twice", p.name),
                ));
            }
            if !p.value.is_finite() {
                return Err(at(
                    format!("parameter[{i}].value"),
                    format!("must be a finite number, not {}", number(p.value)),
                ));
            }
            for (field, bound) in [("lower", p.lower), ("upper", p.upper)] {
                if bound.is_nan() {
                    return Err(at(
                        format!("parameter[{i}].{field}"),
                        format!(
                            "{}: must be a bound ({} for none), not NaN",
                            p.name,
                            if field == "lower" { "-inf" } else { "inf" }
                        ),
                    ));
                }
            }
            if p.lower > p.upper {
                return Err(at(
                    format!("parameter[{i}].lower"),
                    format!(
                        "{}: the lower bound {} is above the upper bound {}: reversed?",
                        p.name,
                        number(p.lower),
                        number(p.upper)
                    ),
                ));
            }
            if p.value < p.lower || p.value > p.upper {
                return Err(at(
                    format!("parameter[{i}].value"),
                    format!(
                        "{} = {} is outside its bounds [{}, {}]",
                        p.name,
                        number(p.value),
                        number(p.lower),
                        number(p.upper)
                    ),
                ));
            }
        }
        if let Some(missing) = known
            .iter()
            .find(|n| !self.parameters.iter().any(|p| p.name == **n))
        {
            return Err(at("parameter".into(), format!("no entry for `{missing}`")));
        }
        if self.added_mass.Y_rdot != 0.0 || self.added_mass.N_vdot != 0.0 {
            return Err(at(
                "added_mass".into(),
                "Y_rdot and N_vdot must be 0: the MMG model has no sway–yaw added-mass coupling"
                    .into(),
            ));
        }
        for (key, value) in [
            ("propeller.diameter_m", self.propeller.diameter_m),
            ("rudder.area_m2", self.rudder.area_m2),
            ("rudder.span_m", self.rudder.span_m),
        ] {
            if !(value.is_finite() && value > 0.0) {
                return Err(at(
                    key.into(),
                    format!("must be a positive number, not {}", number(value)),
                ));
            }
        }
        if let Some((key, msg)) = hardware_fault(&self.ship, &self.propeller, &self.rudder) {
            return Err(at(key.into(), msg));
        }
        for (key, value) in [
            ("propeller.x_m", self.propeller.x_m),
            ("rudder.x_m", self.rudder.x_m),
        ] {
            if !(value.is_finite() && value.abs() <= self.ship.lpp) {
                return Err(at(
                    key.into(),
                    format!(
                        "must be a position within the ship length {} m, not {}",
                        self.ship.lpp,
                        number(value)
                    ),
                ));
            }
        }
        let rate = self.propeller.rate_rps;
        // A model runs at its own rate wherever `--propeller-rate` is not given: 0 cannot run
        // straight at all, and a rate in rpm diverged with exit 1 where the data set refuses it.
        if !(rate.is_finite() && rate > 0.0) {
            return Err(at(
                "propeller.rate_rps".into(),
                format!("must be a finite rate > 0, not {}", number(rate)),
            ));
        }
        if let Some(msg) =
            shipid_io::consistency::rate_rps_problem(rate, self.propeller.diameter_m, self.ship.u0)
        {
            return Err(at("propeller.rate_rps".into(), msg));
        }
        if let Some((key, msg)) = self.metadata_fault() {
            return Err(at(key, msg));
        }
        let geometry = self.geometry();
        geometry.check(
            self.ship.lpp,
            &format!("{}: [propeller]/[rudder]", path.display()),
        )?;
        let get = |name: &str| {
            self.parameters
                .iter()
                .find(|p| p.name == name)
                .map_or(f64::NAN, |p| p.value)
        };
        let params = assemble(&self.ship, &self.added_mass, &geometry, &get);
        MmgModel::at_rate(self.ship, params, self.propeller.rate_rps).map_err(|e| {
            let index = match &e {
                shipid_sim::MmgError::OutsideDomain { name, .. } => {
                    self.parameters.iter().position(|p| p.name == *name)
                }
                _ => None,
            };
            match index {
                Some(i) => bad_input(format!(
                    "{}: key `parameter[{i}].value`: {e}; no model file may carry it",
                    path.display()
                )),
                None => bad_input(format!("{}: {e}", path.display())),
            }
        })
    }
}

/// Whether `v` is a version as shipid writes it: up to three numbers separated by dots, with an
/// optional `-pre` or `+build` suffix.
pub fn is_version(v: &str) -> bool {
    let core = v.split(['-', '+']).next().unwrap_or("");
    let parts: Vec<&str> = core.split('.').collect();
    parts.len() <= 3
        && parts
            .iter()
            .all(|p| !p.is_empty() && p.bytes().all(|b| b.is_ascii_digit()))
}

impl MmgModelFile {
    /// The first fault (key, message) of what the file says about its fit rather than its model:
    /// the version, the estimator's weights and each parameter's uncertainty statements, which
    /// reports and users read as the fit's identifiability. The rules are those the writers keep
    /// (`fit` and `inverse`); a hand edit that breaks one passed on a wrong uncertainty statement.
    fn metadata_fault(&self) -> Option<(String, String)> {
        if !is_version(&self.shipid_version) {
            return Some((
                "shipid_version".into(),
                format!(
                    "\"{}\" is not a version (MAJOR.MINOR.PATCH, as `shipid fit` writes it)",
                    self.shipid_version
                ),
            ));
        }
        if let Some(fault) = shipid_model::training_fault(&self.training) {
            return Some(fault);
        }
        let e = &self.estimator;
        if let Some(fault) = self.left_out_fault() {
            return Some(fault);
        }
        // Written by `fit` (whose estimators these are), rather than `inverse` or by hand.
        let fitted = super::estimator::MmgEstimator::parse(&e.name).is_ok();
        if !(e.prior_weight.is_finite() && e.prior_weight >= 0.0) {
            return Some((
                "estimator.prior_weight".into(),
                format!(
                    "must be a finite weight λ ≥ 0, not {}",
                    number(e.prior_weight)
                ),
            ));
        }
        if !(0.0..=1.0).contains(&e.determined_share) {
            return Some((
                "estimator.determined_share".into(),
                format!(
                    "must be a share in [0, 1], not {}",
                    number(e.determined_share)
                ),
            ));
        }
        for (i, p) in self.parameters.iter().enumerate() {
            let key = |field: &str| format!("parameter[{i}].{field}");
            let name = &p.name;
            // +∞ is an undetermined parameter (a held inflow whose recorded thrust lacked the
            // drift that sets it); NaN or a negative error is no statement at all.
            if p.standard_error.is_nan() || p.standard_error < 0.0 {
                return Some((
                    key("standard_error"),
                    format!(
                        "{name}: must be a standard error ≥ 0, not {}",
                        number(p.standard_error)
                    ),
                ));
            }
            if let Some(se) = p.jackknife_standard_error
                && !(se.is_finite() && se >= 0.0)
            {
                return Some((
                    key("jackknife_standard_error"),
                    format!(
                        "{name}: must be a finite standard error ≥ 0, not {}",
                        number(se)
                    ),
                ));
            }
            // A fit's priors all have a width (a held inflow's at least 1e-9); a file that was not
            // fitted with priors (`inverse`, a published model) writes 0 for "no prior" and +∞ for
            // a prior of no weight.
            let floor_ok = if fitted {
                p.prior_sd > 0.0
            } else {
                p.prior_sd >= 0.0
            };
            if p.prior_sd.is_nan() || !floor_ok {
                return Some((
                    key("prior_sd"),
                    format!(
                        "{name}: must be a prior standard deviation {} (estimator `{}`), not {}",
                        if fitted { "> 0" } else { "≥ 0" },
                        e.name,
                        number(p.prior_sd)
                    ),
                ));
            }
            if p.prior_sd.is_finite()
                && !(p.prior.is_finite() && (p.lower..=p.upper).contains(&p.prior))
            {
                return Some((
                    key("prior"),
                    format!(
                        "{name}: prior {} is outside the bounds [{}, {}]: the fit holds a prior within them",
                        number(p.prior),
                        number(p.lower),
                        number(p.upper)
                    ),
                ));
            }
            if !(0.0..=1.0).contains(&p.data_share) {
                return Some((
                    key("data_share"),
                    format!(
                        "{name}: must be a share of the precision in [0, 1], not {}",
                        number(p.data_share)
                    ),
                ));
            }
            if p.determined_by_data && p.data_share <= e.determined_share {
                return Some((
                    key("determined_by_data"),
                    format!(
                        "{name}: true, but its data_share {} is not above estimator.determined_share = {}: the data do not determine it",
                        number(p.data_share),
                        number(e.determined_share)
                    ),
                ));
            }
            // Without a refinement the values are the equation error's, whose flag is share above
            // determined_share and off the bounds; a refinement moves values (off a bound, too)
            // and keeps the equation error's flags.
            let off_bounds = p.lower < p.value && p.value < p.upper;
            if e.refinement.is_none()
                && !p.determined_by_data
                && p.data_share > e.determined_share
                && off_bounds
            {
                return Some((
                    key("determined_by_data"),
                    format!(
                        "{name}: false, but its data_share {} is above estimator.determined_share = {} and it is off its bounds: the data determine it",
                        number(p.data_share),
                        number(e.determined_share)
                    ),
                ));
            }
        }
        None
    }

    /// A jackknife refit that names a recording the fit did not train on: each refit leaves out
    /// training recordings (`a.csv + b.csv` when grouped), and a report reads `left_out` as which.
    fn left_out_fault(&self) -> Option<(String, String)> {
        let j = self.estimator.jackknife.as_ref()?;
        // Without training windows (a file written before they were stored) there is nothing to
        // compare with.
        if self.training.is_empty() {
            return None;
        }
        for (k, group) in j.left_out.iter().enumerate() {
            if let Some(name) = group
                .split(" + ")
                .find(|n| !self.training.iter().any(|w| w.recording == *n))
            {
                return Some((
                    format!("estimator.jackknife.left_out[{k}]"),
                    format!(
                        "names \"{name}\", which is not a training recording of this model (`training[*].recording`: {})",
                        self.training
                            .iter()
                            .map(|w| w.recording.as_str())
                            .collect::<Vec<_>>()
                            .join(", ")
                    ),
                ));
            }
        }
        None
    }

    /// The model of this file's ship, added masses, propeller and rudder with the parameter values
    /// `values` (in the order of `[[parameter]]`); `key` names them in a fault.
    fn model_with(
        &self,
        values: &[f64],
        path: &Path,
        key: &str,
    ) -> Result<MmgModel, PipelineError> {
        let get = |name: &str| {
            self.parameters
                .iter()
                .position(|p| p.name == name)
                .map_or(f64::NAN, |k| values[k])
        };
        let params = assemble(&self.ship, &self.added_mass, &self.geometry(), &get);
        MmgModel::at_rate(self.ship, params, self.propeller.rate_rps)
            .map_err(|e| bad_input(format!("{}: key `{key}`: {e}", path.display())))
    }

    /// The starts of `[valley]` within its tolerance, as (λ of the start, cost ratio, model); none
    /// without a `[valley]`. The file's point model must load (check it with
    /// [`MmgModelFile::to_model`] first); a fault names the file and the key.
    pub fn valley_models(&self, path: &Path) -> Result<Vec<(f64, f64, MmgModel)>, PipelineError> {
        let Some(record) = &self.valley else {
            return Ok(Vec::new());
        };
        let at =
            |key: String, msg: String| bad_input(format!("{}: key `{key}`: {msg}", path.display()));
        if !(record.cost_tolerance.is_finite() && record.cost_tolerance >= 0.0) {
            return Err(at(
                "valley.cost_tolerance".into(),
                format!("must be a finite number ≥ 0, not {}", record.cost_tolerance),
            ));
        }
        let mut models = Vec::new();
        for (i, start) in record.starts.iter().enumerate() {
            let key = |field: &str| format!("valley.start[{i}].{field}");
            if let Some(c) = start.cost_ratio
                && !(c.is_finite() && c > 0.0)
            {
                return Err(at(
                    key("cost_ratio"),
                    format!("must be a positive number, not {c}"),
                ));
            }
            if !start.in_valley(record.cost_tolerance) {
                continue;
            }
            if let Some(extra) = start
                .values
                .keys()
                .find(|k| !self.parameters.iter().any(|p| &p.name == *k))
            {
                return Err(at(
                    key(&format!("values.{extra}")),
                    "is not a parameter of the model".into(),
                ));
            }
            let mut values = Vec::with_capacity(self.parameters.len());
            for p in &self.parameters {
                let v = *start.values.get(&p.name).ok_or_else(|| {
                    at(
                        key(&format!("values.{}", p.name)),
                        "missing: a start in the valley gives every parameter".into(),
                    )
                })?;
                if !(v.is_finite() && (p.lower..=p.upper).contains(&v)) {
                    return Err(at(
                        key(&format!("values.{}", p.name)),
                        format!(
                            "{v} is not a finite number within the bounds [{}, {}]",
                            p.lower, p.upper
                        ),
                    ));
                }
                values.push(v);
            }
            let model = self.model_with(&values, path, &key("values"))?;
            models.push((start.prior_weight, start.cost_ratio.unwrap_or(1.0), model));
        }
        Ok(models)
    }

    /// The refits of `[estimator.jackknife]` as models, each named by what it left out (none without
    /// one, or without stored values); every parameter needs a finite value within its bounds per
    /// refit. A fault names the file and the key.
    pub fn jackknife_models(&self, path: &Path) -> Result<Vec<(String, MmgModel)>, PipelineError> {
        let Some(j) = &self.estimator.jackknife else {
            return Ok(Vec::new());
        };
        if j.values.is_empty() {
            return Ok(Vec::new());
        }
        let at =
            |key: String, msg: String| bad_input(format!("{}: key `{key}`: {msg}", path.display()));
        if let Some(extra) = j
            .values
            .keys()
            .find(|k| !self.parameters.iter().any(|p| &p.name == *k))
        {
            return Err(at(
                format!("estimator.jackknife.values.{extra}"),
                "is not a parameter of the model".into(),
            ));
        }
        let mut columns = Vec::with_capacity(self.parameters.len());
        for p in &self.parameters {
            let key = format!("estimator.jackknife.values.{}", p.name);
            let values = j.values.get(&p.name).ok_or_else(|| {
                at(
                    key.clone(),
                    "missing: every refit gives every parameter".into(),
                )
            })?;
            if values.len() != j.left_out.len() {
                return Err(at(
                    key,
                    format!(
                        "has {} values for the {} refits of `left_out`",
                        values.len(),
                        j.left_out.len()
                    ),
                ));
            }
            if let Some(v) = values
                .iter()
                .find(|v| !(v.is_finite() && (p.lower..=p.upper).contains(*v)))
            {
                return Err(at(
                    key,
                    format!(
                        "{v} is not a finite number within the bounds [{}, {}]",
                        p.lower, p.upper
                    ),
                ));
            }
            columns.push(values);
        }
        j.left_out
            .iter()
            .enumerate()
            .map(|(k, name)| {
                let values: Vec<f64> = columns.iter().map(|c| c[k]).collect();
                let key = format!("estimator.jackknife.values[{k}]");
                Ok((name.clone(), self.model_with(&values, path, &key)?))
            })
            .collect()
    }

    /// `[bootstrap]`, `[calibration]`, `[valley]` and the jackknife's refits checked as `--bands` and
    /// `simulate` use them,
    /// whichever command reads the file: a NaN replicate read without `--bands` went unsaid while
    /// the same file's bands were refused. A fault names the file and the key.
    pub fn check_optional_tables(&self, path: &Path) -> Result<(), PipelineError> {
        let at =
            |key: String, msg: String| bad_input(format!("{}: key `{key}`: {msg}", path.display()));
        if let Some(record) = &self.bootstrap {
            record
                .parameter_vectors(&self.parameters)
                .map_err(|(key, msg)| at(key, msg))?;
        }
        if let Some(record) = &self.calibration {
            record.check().map_err(|e| at(e.key, e.reason))?;
            if let Some((key, msg)) = crate::metric_family::factor_cap_fault(
                record.factors.iter().map(|(k, f)| (k, f.factor)),
            ) {
                return Err(at(key, msg));
            }
        }
        self.valley_models(path)?;
        self.jackknife_models(path)?;
        Ok(())
    }

    /// The models of the `[bootstrap]` replicates (the file's point model must load: check it with
    /// [`MmgModelFile::to_model`] first); a fault names the file and the key.
    pub fn replicate_models(&self, path: &Path) -> Result<Vec<MmgModel>, PipelineError> {
        let record = self.bootstrap.as_ref().ok_or_else(|| {
            bad_input(format!(
                "{}: key `bootstrap`: missing: --bands needs replicates; refit with `shipid fit … \
                 --set mmg --bootstrap 200`",
                path.display()
            ))
        })?;
        let vectors = record
            .parameter_vectors(&self.parameters)
            .map_err(|(key, msg)| bad_input(format!("{}: key `{key}`: {msg}", path.display())))?;
        vectors
            .iter()
            .map(|values| self.model_with(values, path, "bootstrap.replicates"))
            .collect()
    }
}

/// The TOML text of a model file, with a comment on what it is.
pub fn write_mmg_model_file(file: &MmgModelFile) -> Result<String, PipelineError> {
    let body =
        toml::to_string(file).map_err(|e| crate::error::failed(format!("mmg model file: {e}")))?;
    Ok(format!(
        "# MMG model (Yasukawa & Yoshimura 2015 structure) identified by shipid {} from free-running \
         recordings.\n# Each [[parameter]]: value, bounds, prior with its source, standard error, \
         the data's share of its precision\n# and whether the data determine it (share > {DETERMINED_SHARE}). \
         docs/mmg.md explains the fields.\n{body}",
        env!("CARGO_PKG_VERSION")
    ))
}

/// The model of `text` when its `kind` is `mmg`; `None` for any other kind (or text that is not TOML,
/// which the other readers then name).
pub fn load_mmg_model_if_kind(path: &Path, text: &str) -> Result<Option<MmgModel>, PipelineError> {
    let is_mmg = toml::from_str::<toml::Table>(text)
        .ok()
        .and_then(|t| {
            t.get("kind")
                .and_then(|k| k.as_str().map(|k| k == MMG_KIND))
        })
        .unwrap_or(false);
    if !is_mmg {
        return Ok(None);
    }
    load_mmg_model(path, text).map(Some)
}

/// The model of an MMG model file's text (`path` names it in errors). Its optional tables are checked
/// too ([`MmgModelFile::check_optional_tables`]): every command reads them through here.
pub fn load_mmg_model(path: &Path, text: &str) -> Result<MmgModel, PipelineError> {
    let file: MmgModelFile =
        toml::from_str(text).map_err(|e| crate::toml_text::toml_error(path, text, &e))?;
    let model = file.to_model(path)?;
    file.check_optional_tables(path)?;
    Ok(model)
}
