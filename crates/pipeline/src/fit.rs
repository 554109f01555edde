//! `shipid fit`: identify an Abkowitz model from a data set.
//!
//! Steps: choose the training recordings and their windows (whole record, truncated after N overshoots,
//! or a time window) → primed samples with recorded or estimated accelerations → Φ and y per DOF →
//! the estimator per DOF (hyper-parameters fixed or tuned by blocked cross-validation) → model file.

use std::path::Path;
use std::time::Instant;

use serde::Serialize;
use shipid_estimators::{
    Bounds, Estimator, Family, Fit, Folds, Solver, Tuning, condition_number, default_epsilon_grid,
    default_grid, predict, scaled_condition_number, tune, tune_svr, vif,
};
use shipid_io::{Dataset, DatasetRecording, Manoeuvre, PrimeScale, Recording};
use shipid_model::{
    AbkowitzModel, CoefficientSet, Dof, EstimatorInfo, ModelFile, PrimeInertia, Samples, SetFile,
    TrainingWindow, design,
};
use shipid_sim::metrics::{missing_execute_reason, zigzag_events};

use crate::error::{PipelineError, bad_input};
use crate::refine::{RefineOptions, refine_output_error};

/// A set by shipped name or by path to a set file.
pub fn load_set(spec: &str) -> Result<CoefficientSet, PipelineError> {
    if let Some(s) = CoefficientSet::builtin(spec) {
        return Ok(s);
    }
    let path = Path::new(spec);
    if !path.is_file() {
        return Err(bad_input(format!(
            "unknown coefficient set `{spec}`: not one of {} and no such file",
            CoefficientSet::builtin_names().join(", ")
        )));
    }
    let text = std::fs::read_to_string(path).map_err(|e| shipid_io::InputError::read(path, &e))?;
    let file: SetFile =
        toml::from_str(&text).map_err(|e| shipid_io::InputError::toml(path, &text, &e))?;
    CoefficientSet::from_file(file).map_err(|e| bad_input(format!("{}: {e}", path.display())))
}

/// The estimator name of paper 001's sparse GP.
pub const GP: &str = "sparse-gp";

/// Which estimator, with its hyper-parameters as given on the command line.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct EstimatorSpec {
    /// lsq, bounded-lsq, ridge, lasso, svr, or sparse-gp (paper 001's sparse GP; no coefficient set).
    pub name: String,
    pub lambda: Option<f64>,
    pub alpha: Option<f64>,
    pub c: Option<f64>,
    pub epsilon: Option<f64>,
    /// Choose the hyper-parameters by blocked cross-validation (the SVR's C and ε together unless ε is
    /// given).
    pub tune: bool,
    /// Then refine all coefficients in the output-error sense ([`crate::output_error`]). Not serialised
    /// when off, so the ids of study cases stay as they were.
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub refine: bool,
    /// Similarity threshold d_gen of the sparse GP (paper 001; `sparse-gp` only). Not serialised when
    /// absent, so the ids of the polynomial estimators' study cases stay as they were.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub similarity: Option<f64>,
    /// The mmg family holds the propeller's wake at what the recorded thrust measures
    /// (`--inflow-from-thrust`; mmg only). Not serialised when off, so the ids of study cases stay as
    /// they were.
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub inflow_from_thrust: bool,
}

/// ε of the SVR when it is neither given nor tuned (`--c` without `--tune`): 1 % of the RMS of the
/// DOF's target (the ε-tube then ignores only residuals far below the force level; on noisy data give
/// ε explicitly, about the noise level). `--tune` without `--epsilon` chooses it by cross-validation
/// ([`shipid_estimators::tune_svr`]).
pub const SVR_DEFAULT_EPSILON_OF_RMS: f64 = 0.01;
/// Folds of the blocked cross-validation (contiguous in time; by recording when several are stacked).
pub const CV_FOLDS: usize = 5;

impl EstimatorSpec {
    pub fn named(name: &str) -> EstimatorSpec {
        EstimatorSpec {
            name: name.into(),
            lambda: None,
            alpha: None,
            c: None,
            epsilon: None,
            tune: false,
            refine: false,
            similarity: None,
            inflow_from_thrust: false,
        }
    }

    /// Check the combination of flags before any work is done.
    pub fn validate(&self) -> Result<(), PipelineError> {
        let need = |v: Option<f64>, flag: &str| -> Result<(), PipelineError> {
            match v {
                // C = 0 drops the data term of the SVR: every coefficient would be 0.
                Some(x) if flag == "c" && x == 0.0 => {
                    Err(bad_input("--c must be > 0, got 0 (C = 0 ignores the data)"))
                }
                // The SVR's C weighs the data term: a large C is weak regularisation, and beyond
                // the cap the solver's arithmetic, not the data, decides the fit.
                Some(x)
                    if x > shipid_estimators::MAX_HYPER_PARAMETER
                        && x.is_finite()
                        && flag == "c" =>
                {
                    Err(bad_input(format!(
                        "--c {x:e} is beyond {:e}: C weighs the data against the regularisation, and a C this large swamps the solver's arithmetic in rounding (the fit would be the solver's, not the data's); for no regularisation use --estimator lsq, or --tune",
                        shipid_estimators::MAX_HYPER_PARAMETER
                    )))
                }
                Some(x) if x > shipid_estimators::MAX_HYPER_PARAMETER && x.is_finite() => {
                    Err(bad_input(format!(
                        "--{flag} {x:e} is beyond {:e}: the regularisation would drown the data in rounding (the fit would ignore them)",
                        shipid_estimators::MAX_HYPER_PARAMETER
                    )))
                }
                // --tune would choose the value given and drop it without a word.
                Some(_) if self.tune => Err(bad_input(format!(
                    "give --{flag} or --tune, not both (--tune chooses {flag} by cross-validation)"
                ))),
                Some(x) if x.is_finite() && x >= 0.0 => Ok(()),
                Some(x) => Err(bad_input(format!(
                    "--{flag} must be a non-negative number, not {x}"
                ))),
                None if self.tune => Ok(()),
                None => Err(bad_input(format!(
                    "estimator {} needs --{flag} or --tune",
                    self.name
                ))),
            }
        };
        if self.similarity.is_some() && self.name != GP {
            return Err(bad_input(
                "--similarity applies to --estimator sparse-gp only",
            ));
        }
        // A hyper-parameter the estimator has not would be silently ignored.
        let owns: &[&str] = match self.name.as_str() {
            "lsq" | "bounded-lsq" => &[],
            "ridge" => &["lambda"],
            "lasso" => &["alpha"],
            "svr" => &["c", "epsilon"],
            _ => &["lambda", "alpha", "c", "epsilon"],
        };
        for (given, flag) in [
            (self.lambda.is_some(), "lambda"),
            (self.alpha.is_some(), "alpha"),
            (self.c.is_some(), "c"),
            (self.epsilon.is_some(), "epsilon"),
        ] {
            if given && !owns.contains(&flag) && self.name != GP {
                return Err(bad_input(format!(
                    "--{flag} does not apply to --estimator {}",
                    self.name
                )));
            }
        }
        if self.tune && owns.is_empty() {
            return Err(bad_input(format!(
                "--tune does not apply to --estimator {} (it has no hyper-parameter)",
                self.name
            )));
        }
        match self.name.as_str() {
            "lsq" | "bounded-lsq" => Ok(()),
            GP => {
                for (given, flag) in [
                    (self.lambda.is_some(), "lambda"),
                    (self.alpha.is_some(), "alpha"),
                    (self.c.is_some(), "c"),
                    (self.epsilon.is_some(), "epsilon"),
                    (self.tune, "tune"),
                    (self.refine, "refine"),
                ] {
                    if given {
                        return Err(bad_input(format!(
                            "--{flag} does not apply to sparse-gp (its one setting is the similarity threshold d_gen)"
                        )));
                    }
                }
                match self.similarity {
                    Some(d) if !(d > 0.0 && d <= 1.0) => Err(bad_input(format!(
                        "--similarity must be in (0, 1], not {d}"
                    ))),
                    _ => Ok(()),
                }
            }
            "ridge" => need(self.lambda, "lambda"),
            "lasso" => need(self.alpha, "alpha"),
            "svr" => {
                need(self.c, "c")?;
                if let Some(e) = self.epsilon
                    && !(e.is_finite() && e >= 0.0)
                {
                    return Err(bad_input(format!(
                        "--epsilon must be a non-negative number, not {e}"
                    )));
                }
                if let Some(e) = self.epsilon
                    && e > shipid_estimators::MAX_HYPER_PARAMETER
                {
                    return Err(bad_input(format!(
                        "--epsilon {e:e} is beyond {:e}: the SVR's ε-tube (prime units, the same for X, Y and N) would hold every sample and the fit would ignore the data; give ε about the noise level, or --tune",
                        shipid_estimators::MAX_HYPER_PARAMETER
                    )));
                }
                Ok(())
            }
            other => Err(bad_input(format!(
                "unknown estimator `{other}`: expected lsq, bounded-lsq, ridge, lasso, svr or sparse-gp"
            ))),
        }
    }

    /// Bounds of the set apply to every estimator but plain LSQ (the unconstrained baseline).
    pub fn uses_bounds(&self) -> bool {
        self.name != "lsq"
    }
}

/// Which part of each training recording is used.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub enum WindowSpec {
    Whole,
    /// From the start to the peak of overshoot N (zig-zags only).
    Overshoots(u32),
    /// From `start_s` to `end_s` [s].
    Time {
        start_s: f64,
        end_s: f64,
    },
}

impl WindowSpec {
    /// Short label for tables and legends: "whole", "4 OS", "0-120 s".
    pub fn label(self) -> String {
        match self {
            WindowSpec::Whole => "whole".into(),
            WindowSpec::Overshoots(n) => format!("{n} OS"),
            WindowSpec::Time { start_s, end_s } => format!("{start_s}-{end_s} s"),
        }
    }
}

/// The sample range of a recording for a window, and the overshoot count when truncated by overshoots.
pub fn window_range(
    r: &DatasetRecording,
    ds: &Dataset,
    window: WindowSpec,
) -> Result<std::ops::Range<usize>, PipelineError> {
    let rec = &r.recording;
    let end_at = |t_end: f64| rec.t.partition_point(|&t| t <= t_end);
    match window {
        WindowSpec::Whole => Ok(0..rec.len()),
        WindowSpec::Time { start_s, end_s } => {
            let lo = rec.t.partition_point(|&t| t < start_s);
            let hi = end_at(end_s);
            if hi <= lo + 10 {
                let span = match (rec.t.first(), rec.t.last()) {
                    (Some(a), Some(b)) => format!(" (the recording runs {a}–{b} s)"),
                    _ => String::new(),
                };
                return Err(bad_input(format!(
                    "{}: time window {start_s}–{end_s} s holds {} samples, too few to fit{span}",
                    r.file,
                    hi.saturating_sub(lo)
                )));
            }
            Ok(lo..hi)
        }
        WindowSpec::Overshoots(n) => {
            let Manoeuvre::ZigZag {
                rudder_deg,
                check_deg,
                side,
            } = r.manoeuvre
            else {
                // Truncation is a zig-zag notion; other manoeuvres of a combination (a turning circle
                // stacked with a zig-zag, paper 000 §3.5) are used whole.
                return Ok(0..rec.len());
            };
            let ev = zigzag_events(rec, rudder_deg, check_deg, side, &ds.ship);
            let have = ev.as_ref().map_or(0, |e| e.overshoots.len());
            if n == 0 || have < n as usize {
                let why = missing_execute_reason(rec, rudder_deg, side)
                    .map_or(String::new(), |w| format!(": {w}"));
                return Err(bad_input(format!(
                    "{}: {n} overshoots requested but the record has {have}{why}",
                    r.file
                )));
            }
            let t_end = ev
                .map(|e| e.overshoots[n as usize - 1].t_s)
                .unwrap_or(f64::INFINITY);
            Ok(0..end_at(t_end))
        }
    }
}

/// Everything learnt about one DOF's regression.
#[derive(Debug, Clone, Serialize)]
pub struct DofReport {
    pub dof: Dof,
    pub names: Vec<String>,
    pub fit: Fit,
    /// RMS of y − Φβ (prime force or moment).
    pub residual_rms: f64,
    /// RMS of y, for scale.
    pub target_rms: f64,
    pub condition_number: Option<f64>,
    pub scaled_condition_number: Option<f64>,
    pub vif: Vec<Option<f64>>,
    pub tuning: Option<Tuning>,
}

/// A fit whose training data say nothing about some coefficients: the windows used and, per DOF,
/// the regressors that are identically zero in them ([`shipid_estimators::Status::RankDeficient`]).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct NoInformation {
    /// "recording t0–t1 s" per training window.
    pub windows: Vec<String>,
    /// (DOF, names of its zero regressors), for the DOFs that have any.
    pub regressors: Vec<(Dof, Vec<String>)>,
}

impl std::fmt::Display for NoInformation {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let regressors: Vec<String> = self
            .regressors
            .iter()
            .map(|(dof, names)| format!("{dof}: {}", names.join(", ")))
            .collect();
        write!(
            f,
            "rank-deficient: the training window ({}) carries no information on {} (identically zero or exactly collinear there; e.g. the window ends before the rudder first moves, or just after): widen the window or choose other recordings",
            self.windows.join("; "),
            regressors.join("; ")
        )
    }
}

impl DofReport {
    /// The regressors the training data say nothing about, when there are any: identically zero
    /// columns ([`shipid_estimators::Status::RankDeficient`]), or, when the effective condition
    /// number is infinite (columns exactly collinear in floating point), those with an infinite VIF
    /// (all of them when the VIFs do not single any out).
    pub fn uninformative(&self) -> Option<Vec<String>> {
        match &self.fit.status {
            shipid_estimators::Status::RankDeficient { zero_columns } => Some(
                zero_columns
                    .iter()
                    .filter_map(|&j| self.names.get(j).cloned())
                    .collect(),
            ),
            shipid_estimators::Status::IllConditioned { condition_number }
                if !condition_number.is_finite() =>
            {
                let collinear: Vec<String> = self
                    .names
                    .iter()
                    .zip(&self.vif)
                    .filter(|(_, v)| v.is_some_and(|v| !v.is_finite()))
                    .map(|(n, _)| n.clone())
                    .collect();
                Some(if collinear.is_empty() {
                    self.names.clone()
                } else {
                    collinear
                })
            }
            _ => None,
        }
    }
}

/// The result of a fit.
pub struct FitOutput {
    pub model: AbkowitzModel,
    pub file: ModelFile,
    pub dofs: Vec<DofReport>,
    /// Wall time of the estimator solves including tuning and the output-error refinement [s] (not
    /// loading or building Φ).
    pub fit_time_s: f64,
    /// The primed training samples (stacked windows), e.g. for the model's identification range.
    pub training: Samples,
}

/// The named recordings of `ds` (all of them when `recordings` is empty); a name the data set does not
/// have is bad input that lists the names it has.
pub(crate) fn chosen_recordings<'a>(
    ds: &'a Dataset,
    recordings: &[String],
) -> Result<Vec<&'a DatasetRecording>, PipelineError> {
    let chosen: Vec<&DatasetRecording> = if recordings.is_empty() {
        ds.recordings.iter().collect()
    } else {
        recordings
            .iter()
            .map(|f| {
                ds.recording(f).ok_or_else(|| {
                    bad_input(format!(
                        "recording `{f}` is not in {} (it has: {})",
                        ds.path.display(),
                        ds.recordings
                            .iter()
                            .map(|r| r.file.as_str())
                            .collect::<Vec<_>>()
                            .join(", ")
                    ))
                })
            })
            .collect::<Result<_, _>>()?
    };
    if chosen.is_empty() {
        return Err(bad_input(format!(
            "{} has no recordings",
            ds.path.display()
        )));
    }
    // A recording named twice would be fitted with twice the weight, silently.
    if let Some((_, r)) = chosen
        .iter()
        .enumerate()
        .find(|(i, r)| chosen[..*i].iter().any(|o| o.file == r.file))
    {
        return Err(bad_input(format!(
            "recording `{}` is named twice in --recordings",
            r.file
        )));
    }
    Ok(chosen)
}

pub use crate::excitation::{
    MIN_RUDDER_SPREAD_DEG, rudder_spread_deg, rudder_unexcited, rudder_unexcited_error,
};

/// The training samples of the chosen recordings and window, and the windows used.
pub fn training_samples(
    ds: &Dataset,
    recordings: &[String],
    window: WindowSpec,
) -> Result<(Samples, Vec<TrainingWindow>), PipelineError> {
    let chosen = chosen_recordings(ds, recordings)?;
    if matches!(window, WindowSpec::Overshoots(_))
        && !chosen
            .iter()
            .any(|r| matches!(r.manoeuvre, Manoeuvre::ZigZag { .. }))
    {
        return Err(bad_input(
            "--overshoots truncates zig-zags, and none of the training recordings is one",
        ));
    }
    let scale = PrimeScale::of(&ds.ship);
    let mut samples = Samples::default();
    let mut windows = Vec::new();
    for (g, r) in chosen.iter().enumerate() {
        let range = window_range(r, ds, window)?;
        // Accelerations are estimated on the whole record, then windowed, so the cut does not add
        // end effects of the differentiator. A recorded wind and current are known inputs: the
        // polynomial is fitted to what is left (velocities through the water, accelerations without
        // the wind's), through the mass matrix the model simulates with.
        let hydro =
            crate::environment::hydrodynamic_recording(ds, r, &ds.added_mass.unwrap_or_default())?;
        let (acc, estimated) = (hydro.accelerations, hydro.estimated);
        let rec = hydro.recording.slice(range.clone());
        let acc = shipid_io::Accelerations {
            u_dot: acc.u_dot[range.clone()].to_vec(),
            v_dot: acc.v_dot[range.clone()].to_vec(),
            r_dot: acc.r_dot[range.clone()].to_vec(),
        };
        samples.push(&rec, &acc, &scale, g);
        windows.push(training_window(
            ds,
            r,
            window,
            (rec.t[0], *rec.t.last().unwrap_or(&rec.t[0])),
            estimated,
        ));
    }
    Ok((samples, windows))
}

impl FitOutput {
    /// Which regressors carry no information in the training windows, when any DOF's fit is
    /// rank deficient; such a fit is no model.
    pub fn no_information(&self) -> Option<NoInformation> {
        let regressors: Vec<(Dof, Vec<String>)> = self
            .dofs
            .iter()
            .filter_map(|d| d.uninformative().map(|names| (d.dof, names)))
            .collect();
        if regressors.is_empty() {
            return None;
        }
        let windows = self
            .file
            .training
            .iter()
            .map(|w| format!("{} {}–{} s", w.recording, w.t_start_s, w.t_end_s))
            .collect();
        Some(NoInformation {
            windows,
            regressors,
        })
    }
}

/// The model file's record of one training recording: its window [s] and how its accelerations were
/// obtained (shared by the Abkowitz and the sparse-GP fits).
pub fn training_window(
    ds: &Dataset,
    r: &DatasetRecording,
    window: WindowSpec,
    (t_start_s, t_end_s): (f64, f64),
    estimated: bool,
) -> TrainingWindow {
    TrainingWindow {
        // Absolute here; the writer of the model file makes it relative to where the file goes.
        dataset: crate::model_file::absolute_path(&ds.path)
            .display()
            .to_string(),
        dataset_hash: crate::model_file::training_hash(&ds.path, &r.file).ok(),
        recording: r.file.clone(),
        t_start_s,
        t_end_s,
        overshoots: match (window, r.manoeuvre) {
            (WindowSpec::Overshoots(n), Manoeuvre::ZigZag { .. }) => Some(n),
            _ => None,
        },
        accelerations: if estimated {
            estimated_accelerations_text(&r.recording.t, &ds.ship)
        } else {
            "recorded".into()
        },
    }
}

/// How a recording's accelerations were estimated, with the window its sampling gave them (a coarse
/// sampling lengthens it beyond the one asked for, and the file would otherwise state a window never
/// used).
fn estimated_accelerations_text(t: &[f64], ship: &shipid_io::Ship) -> String {
    let w = shipid_io::deriv::EstimationWindow::of(t, ship);
    let l_over_u0 = ship.lpp / ship.u0;
    let asked = if w.too_coarse() {
        format!(
            "; {:.3} L/U0 asked for, the sampling is too coarse for it",
            w.requested_s / l_over_u0
        )
    } else {
        String::new()
    };
    format!(
        "estimated: local cubic least squares (Savitzky–Golay), window {:.3} L/U0 ({} samples {} s apart{asked})",
        w.effective_s / l_over_u0,
        w.samples,
        shipid_io::units::fmt_sig(w.step_s),
    )
}

/// A warning for each chosen recording whose accelerations are estimated over a window much longer
/// than the one asked for (its sampling too coarse, [`shipid_io::deriv::EstimationWindow`]): the fit
/// then learns smeared accelerations, and nothing else would say so.
pub fn acceleration_window_notes(
    ds: &Dataset,
    recordings: &[String],
) -> Result<Vec<String>, PipelineError> {
    let l_over_u0 = ds.ship.lpp / ds.ship.u0;
    Ok(chosen_recordings(ds, recordings)?
        .into_iter()
        .filter(|r| r.recording.accelerations.is_none())
        .filter_map(|r| {
            let w = shipid_io::deriv::EstimationWindow::of(&r.recording.t, &ds.ship);
            w.too_coarse().then(|| {
                format!(
                    "{}: sampled every {} s, too coarse for the accelerations the fit estimates: their smoothing window spans {} samples, {:.3} s ({:.3} L/U0), {:.1} × the {:.3} L/U0 ({:.3} s) asked for, and smears the manoeuvre's accelerations; record u_dot, v_dot and r_dot, or sample faster",
                    r.file,
                    shipid_io::units::fmt_sig(w.step_s),
                    w.samples,
                    w.effective_s,
                    w.effective_s / l_over_u0,
                    w.effective_s / w.requested_s,
                    w.requested_s / l_over_u0,
                    w.requested_s,
                )
            })
        })
        .collect())
}

/// Fit a set with an estimator on a data set.
pub fn fit_dataset(
    ds: &Dataset,
    set: CoefficientSet,
    spec: &EstimatorSpec,
    recordings: &[String],
    window: WindowSpec,
    solver: Solver,
) -> Result<FitOutput, PipelineError> {
    spec.validate()?;
    let added = ds.added_mass.ok_or_else(|| {
        bad_input(format!(
            "{}: no [added_mass] table; the acceleration derivatives must be known to fit",
            ds.path.display()
        ))
    })?;
    let (samples, windows) = training_samples(ds, recordings, window)?;
    rudder_unexcited(&samples.delta, &windows, "a rudder derivative needs")?;
    let inertia = PrimeInertia::new(&ds.ship, &added, &set);
    let folds = if windows.len() > 1 {
        Folds::Groups(samples.group.clone())
    } else {
        Folds::Blocked { k: CV_FOLDS }
    };
    let mut reports = Vec::new();
    let mut coefficients: [Vec<f64>; 3] = Default::default();
    let mut hyper = std::collections::BTreeMap::new();
    let mut fit_time_s = 0.0;
    for dof in Dof::ALL {
        let d = design(&set, dof, &samples, &inertia);
        check_design_finite(ds, &windows, &samples, &d)?;
        // As many samples as coefficients are interpolated, not identified: full68 on 22 samples
        // wrote a model with a residual of 3e-18 and status "ill-conditioned" (mmg refuses alike).
        if d.y.len() <= d.names.len() {
            return Err(bad_input(format!(
                "{}: {} usable samples in the training windows, no more than the {} {dof} coefficients of {}: they would be interpolated, not identified (no residual, no error estimate); give longer windows or more recordings",
                ds.path.display(),
                d.y.len(),
                d.names.len(),
                set.name
            )));
        }
        let bounds = if spec.uses_bounds() && set.has_bounds(dof) {
            let (lo, hi): (Vec<f64>, Vec<f64>) = d.bounds.iter().copied().unzip();
            Some(Bounds::new(lo, hi).map_err(|e| bad_input(format!("{dof} bounds: {e}")))?)
        } else {
            None
        };
        let target_rms = rms(&d.y);
        let started = Instant::now();
        let (estimator, tuning) =
            resolve_estimator(spec, &d, target_rms, &folds, bounds.as_ref(), solver)?;
        let fit = shipid_estimators::fit(d.phi.as_ref(), &d.y, &estimator, bounds.as_ref(), solver)
            .map_err(|e| bad_input(format!("{dof}: {e}")))?;
        fit_time_s += started.elapsed().as_secs_f64();
        for (k, v) in hyper_of(&estimator) {
            hyper.insert(format!("{k}_{dof}"), v);
        }
        let pred = predict(d.phi.as_ref(), &fit.coefficients).unwrap_or_default();
        let resid: Vec<f64> = pred.iter().zip(&d.y).map(|(p, y)| y - p).collect();
        coefficients[dof.index()] = fit.coefficients.clone();
        reports.push(DofReport {
            dof,
            names: d.names.clone(),
            residual_rms: rms(&resid),
            target_rms,
            condition_number: condition_number(d.phi.as_ref()).ok(),
            scaled_condition_number: scaled_condition_number(d.phi.as_ref()).ok(),
            vif: vif(d.phi.as_ref()).unwrap_or_default(),
            fit,
            tuning,
        });
    }
    let model = AbkowitzModel::new(set, coefficients, ds.ship, added)
        .map_err(|e| bad_input(format!("identified model is unusable: {e}")))?;
    let info = EstimatorInfo {
        name: spec.name.clone(),
        solver: solver.name().into(),
        hyper,
        tuned: spec.tune,
        refinement: None,
    };
    let rank_deficient = reports.iter().any(|d| d.uninformative().is_some());
    // A rank-deficient fit is no model (see `FitOutput::no_information`): nothing to refine.
    let (model, info) = if spec.refine && !rank_deficient {
        let recs: Vec<Recording> = windows
            .iter()
            .filter_map(|w| {
                let r = &ds.recording(&w.recording)?.recording;
                let lo = r.t.partition_point(|&t| t < w.t_start_s);
                let hi = r.t.partition_point(|&t| t <= w.t_end_s);
                Some(r.slice(lo..hi))
            })
            .collect();
        let started = Instant::now();
        let (refined, how) = refine_output_error(&model, &recs, &RefineOptions::for_dataset(ds))
            .map_err(|e| bad_input(format!("--refine: {e}")))?;
        fit_time_s += started.elapsed().as_secs_f64();
        let info = EstimatorInfo {
            refinement: Some(how),
            ..info
        };
        (refined, info)
    } else {
        (model, info)
    };
    let mut file = ModelFile::from_model(&model, info, windows);
    file.environment =
        crate::environment::environment_record(ds, &chosen_recordings(ds, recordings)?);
    Ok(FitOutput {
        model,
        file,
        dofs: reports,
        fit_time_s,
        training: samples,
    })
}

/// Every regressor and target finite, or bad input naming the recording file, its line and the
/// regressor: a recorded value can be finite and still overflow in a cubic term (|v| = 1e120).
fn check_design_finite(
    ds: &Dataset,
    windows: &[TrainingWindow],
    samples: &Samples,
    d: &shipid_model::Design,
) -> Result<(), PipelineError> {
    let bad = (0..d.phi.ncols())
        .flat_map(|j| (0..d.phi.nrows()).map(move |i| (i, j)))
        .find(|&(i, j)| !d.phi[(i, j)].is_finite())
        .map(|(i, j)| (i, d.names[j].clone(), d.phi[(i, j)]))
        .or_else(|| {
            d.y.iter().position(|y| !y.is_finite()).map(|i| {
                (
                    i,
                    format!("the {} target (inertia × acceleration)", d.dof),
                    d.y[i],
                )
            })
        });
    let Some((row, what, value)) = bad else {
        return Ok(());
    };
    let recording = samples
        .group
        .get(row)
        .and_then(|&g| windows.get(g))
        .and_then(|w| ds.recording(&w.recording));
    let place = match recording {
        Some(r) => {
            let path = ds.path.parent().unwrap_or(Path::new("")).join(&r.file);
            let index = r.recording.t.partition_point(|&t| t < samples.t[row]);
            match data_line(&path, index) {
                Some(line) => format!("{}, line {line}", path.display()),
                None => format!("{} (t = {} s)", path.display(), samples.t[row]),
            }
        }
        None => format!("{} (training sample {row})", ds.path.display()),
    };
    Err(bad_input(format!(
        "{place}: {what} is {value}: a recorded value of this row is too large for the model's terms (there du' = {:.3e}, v' = {:.3e}, r' = {:.3e}, delta = {:.3e} rad)",
        samples.du[row], samples.v[row], samples.r[row], samples.delta[row]
    )))
}

/// The line (1-based) of data row `index` in a recording CSV, counted as its reader does:
/// comments and blank lines before the header, the header, then non-blank lines.
fn data_line(path: &Path, index: usize) -> Option<usize> {
    let text = std::fs::read_to_string(path).ok()?;
    let mut lines = text.lines().enumerate().skip_while(|(_, l)| {
        let l = l.trim();
        l.starts_with('#') || l.is_empty()
    });
    lines.next()?; // the header
    lines
        .filter(|(_, l)| !l.trim().is_empty())
        .nth(index)
        .map(|(k, _)| k + 1)
}

/// The estimator of `spec` on this DOF's design, tuning what `--tune` leaves open: λ, α, or the
/// SVR's C and ε together (C alone when ε is given). `target_rms` scales the SVR's default ε.
fn resolve_estimator(
    spec: &EstimatorSpec,
    d: &shipid_model::Design,
    target_rms: f64,
    folds: &Folds,
    bounds: Option<&Bounds>,
    solver: Solver,
) -> Result<(Estimator, Option<Tuning>), PipelineError> {
    let epsilon = spec
        .epsilon
        .unwrap_or(SVR_DEFAULT_EPSILON_OF_RMS * target_rms);
    let family = match spec.name.as_str() {
        "lsq" => return Ok((Estimator::Lsq, None)),
        "bounded-lsq" => return Ok((Estimator::BoundedLsq, None)),
        "ridge" => match spec.lambda {
            Some(lambda) if !spec.tune => return Ok((Estimator::Ridge { lambda }, None)),
            _ => Family::Ridge,
        },
        "lasso" => match spec.alpha {
            Some(alpha) if !spec.tune => return Ok((Estimator::Lasso { alpha }, None)),
            _ => Family::Lasso,
        },
        "svr" => match (spec.c, spec.epsilon) {
            (Some(c), _) if !spec.tune => return Ok((Estimator::Svr { c, epsilon }, None)),
            (_, None) => {
                let t = tune_svr(
                    d.phi.as_ref(),
                    &d.y,
                    &default_epsilon_grid(&d.y),
                    folds,
                    bounds,
                    solver,
                )
                .map_err(|e| bad_input(format!("{}: tuning: {e}", d.dof)))?;
                return Ok((t.estimator, Some(t)));
            }
            _ => Family::Svr { epsilon },
        },
        other => return Err(bad_input(format!("unknown estimator `{other}`"))),
    };
    let grid = default_grid(&family, d.phi.as_ref(), &d.y)
        .map_err(|e| bad_input(format!("{}: {e}", d.dof)))?;
    let t = tune(d.phi.as_ref(), &d.y, &family, &grid, folds, bounds, solver)
        .map_err(|e| bad_input(format!("{}: tuning: {e}", d.dof)))?;
    Ok((t.estimator, Some(t)))
}

/// The SVR's tube half-width ε [units of the target: prime force or moment], given or chosen by
/// cross-validation; `None` for the other estimators.
pub fn svr_epsilon(e: &Estimator) -> Option<f64> {
    match *e {
        Estimator::Svr { epsilon, .. } => Some(epsilon),
        _ => None,
    }
}

fn hyper_of(e: &Estimator) -> Vec<(&'static str, f64)> {
    match *e {
        Estimator::Lsq | Estimator::BoundedLsq => vec![],
        Estimator::Ridge { lambda } => vec![("lambda", lambda)],
        Estimator::Lasso { alpha } => vec![("alpha", alpha)],
        Estimator::Svr { c, epsilon } => vec![("c", c), ("epsilon", epsilon)],
    }
}

/// The `[environment]` record of a fit of `ds` on `recordings` (all when empty), as
/// [`crate::environment::environment_record`].
pub fn fit_environment_record(
    ds: &Dataset,
    recordings: &[String],
) -> Result<Option<shipid_model::EnvironmentRecord>, PipelineError> {
    Ok(crate::environment::environment_record(
        ds,
        &chosen_recordings(ds, recordings)?,
    ))
}

/// What a fit of `ds` on `recordings` (all when empty) says about their recorded environment: the
/// warning for an assumed windage, then per recording with a wind or current that it is removed and
/// with which windage. Empty for calm recordings.
pub fn fit_environment_notes(
    ds: &Dataset,
    recordings: &[String],
) -> Result<Vec<String>, PipelineError> {
    let chosen = chosen_recordings(ds, recordings)?;
    let windage = crate::environment::ChosenWindage::of_dataset(ds);
    let mut notes = Vec::new();
    if windage.is_assumed() && chosen.iter().any(|r| r.recording.wind.is_some()) {
        notes.push(crate::environment::assumed_windage_warning(ds));
    }
    notes.extend(crate::environment::environment_notes(
        ds,
        chosen.iter().copied(),
        &windage,
        "the fit removes it before identification and",
    ));
    Ok(notes)
}

pub use crate::validate::rms;

#[cfg(test)]
mod tests {
    use super::*;

    fn clock(step_s: f64, samples: usize) -> Vec<f64> {
        (0..samples).map(|i| i as f64 * step_s).collect()
    }

    /// Regression: the model file stated "window 0.300 L/U0" for estimated accelerations whatever the
    /// sampling, while the differentiator takes at least 3 samples a side: at 5 s sampling the window
    /// used was 30 s (5.05 L/U0), at 1 s 6 s.
    #[test]
    fn the_stated_acceleration_window_is_the_one_the_sampling_gives() {
        for (step_s, window) in [
            (0.1, "window 0.303 L/U0 (19 samples 0.1 s apart)"),
            (
                1.0,
                "window 1.011 L/U0 (7 samples 1 s apart; 0.300 L/U0 asked for, the sampling is too coarse for it)",
            ),
            (
                5.0,
                "window 5.053 L/U0 (7 samples 5 s apart; 0.300 L/U0 asked for",
            ),
        ] {
            let text =
                estimated_accelerations_text(&clock(step_s, 100), &shipid_sim::kvlcc2_ship());
            assert!(
                text.starts_with("estimated: local cubic least squares (Savitzky–Golay), ")
                    && text.contains(window),
                "{step_s} s: {text}"
            );
        }
    }
}
