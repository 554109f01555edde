//! The `mmg` model family: the MMG standard method (Yasukawa & Yoshimura 2015) with its hull, propeller
//! and rudder parameters identified from free-running recordings (`docs/mmg.md`).
//!
//! - `geometry`: the known propeller and rudder data ([`MmgGeometry`]).
//! - `priors`: every identified parameter with its physical bounds and an empirical prior from the
//!   ship's main particulars, each with its source.
//! - `identify`: equation error by variable projection (hull derivatives by bounded least squares of
//!   the estimators crate inside, propeller and rudder parameters by projected Levenberg–Marquardt
//!   outside), the posterior and the data's share of each parameter's precision.
//! - `file`: the model file `kind = "mmg"` and its loader.
//! - `refine`: the output-error refinement of [`crate::refine`] over the identified parameters.
//! - `valley`: the refinements from the cross-validation grid's other prior weights, which the
//!   recordings may not tell apart from the delivered one.
//!
//! The identified model is a [`shipid_sim::MmgModel`] (a `Dynamics`) with its propeller at the mean
//! recorded rate of the training windows: the identification uses each sample's recorded `n`, a
//! simulation holds the rate constant, as free-running manoeuvring tests do.
//!
//! Module imports: `geometry` ← `priors` ← `identify` ← this file → `file`, `refine` ← `valley`.

pub mod estimator;
pub mod file;
pub mod geometry;
pub mod identify;
pub mod jackknife;
pub mod priors;
pub mod refine;
pub mod thrust;
pub mod valley;

pub use estimator::MmgEstimator;
use std::time::Instant;

use rayon::prelude::*;

use shipid_io::{AddedMass, Dataset, Recording};
use shipid_model::TrainingWindow;
use shipid_sim::{Dynamics, MmgModel, State};

pub use file::{
    CvEntry, JackknifeEntry, MMG_KIND, MmgEstimatorEntry, MmgModelFile, MmgValleyRecord,
    ParamEntry, PropellerEntry, RudderEntry, ThrustInflowEntry, ValleyStartEntry, load_mmg_model,
    load_mmg_model_if_kind, write_mmg_model_file,
};
pub use geometry::MmgGeometry;
pub use identify::{DETERMINED_SHARE, EqSample, Estimate, ParamEstimate, Problem};
pub use priors::{ParamSpec, Role, priors};
pub use refine::{ParametricMmg, refine_mmg};

use crate::error::{PipelineError, bad_input, failed};
use crate::fit::{EstimatorSpec, WindowSpec, chosen_recordings, training_window, window_range};
use crate::refine::RefineOptions;
use crate::replay::{replay_segment_in, segments};
use crate::validate::interp;
use shipid_sim::environment::KnownEnvironment;

/// The weight λ of the prior against the data.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum PriorWeight {
    Fixed(f64),
    /// Chosen from [`CV_GRID`] by blocked cross-validation (by recording when there are several).
    CrossValidated(CvCriterion),
}

/// What a held-out fold scores.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CvCriterion {
    /// The replay of the held-out part's recorded rudder from its recorded start: position RMSE ÷ L
    /// plus heading RMSE [rad] (a diverged replay adds 1). What a prediction needs; the default.
    Replay,
    /// The equation error J's data term on the held-out samples.
    EquationError,
}

/// λ without `--tune`: the prior acts only where the data say little.
pub const DEFAULT_PRIOR_WEIGHT: f64 = 1e-6;
/// The candidates of the cross-validation.
pub const CV_GRID: [f64; 5] = [1e-8, 1e-6, 1e-4, 1e-2, 1.0];
/// Most equation-error samples used: longer training windows are thinned evenly to this many.
pub const MAX_SAMPLES: usize = 10_000;
/// Blocks of the cross-validation when there is one training window.
pub const CV_BLOCKS: usize = 5;

/// What to fit.
#[derive(Debug, Clone, PartialEq)]
pub struct MmgFitOptions {
    /// Training recordings (all when empty).
    pub recordings: Vec<String>,
    pub window: WindowSpec,
    pub estimator: MmgEstimator,
    pub prior_weight: PriorWeight,
    /// Propeller rate [1/s] for recordings without an `n` column.
    pub propeller_rate_hz: Option<f64>,
    /// Hold the propeller's wake parameters (w_P0, C₁, C₂) at what the recorded thrust measures
    /// (`fit --inflow-from-thrust`) instead of identifying them from the motion; without it a recorded
    /// thrust is only reported beside the fit's values.
    pub inflow_from_thrust: bool,
    /// The output-error refinement that follows the fit (`--refine`), when it does. With a
    /// cross-validated prior weight each fold's fit is refined alike before it is scored: λ is chosen
    /// for the procedure that makes the model, not for its first step.
    pub refine_folds: Option<RefineOptions>,
}

impl Default for MmgFitOptions {
    fn default() -> Self {
        MmgFitOptions {
            recordings: Vec::new(),
            window: WindowSpec::Whole,
            estimator: MmgEstimator::BoundedLsq,
            prior_weight: PriorWeight::Fixed(DEFAULT_PRIOR_WEIGHT),
            propeller_rate_hz: None,
            inflow_from_thrust: false,
            refine_folds: None,
        }
    }
}

/// One cross-validation candidate: λ and its mean held-out cost.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CvScore {
    pub lambda: f64,
    pub held_out_cost: f64,
}

/// The identified model, its parameters with their identifiability, and how it was found.
pub struct MmgFit {
    pub model: MmgModel,
    pub geometry: MmgGeometry,
    pub estimate: Estimate,
    pub lambda: f64,
    pub estimator: MmgEstimator,
    /// The cross-validation scores when λ was tuned.
    pub cv: Vec<CvScore>,
    /// Each fold's fit was refined before it was scored ([`MmgFitOptions::refine_folds`]).
    pub cv_folds_refined: bool,
    pub windows: Vec<TrainingWindow>,
    /// Propeller rate of the model: the (upper) median recorded rate of the training samples [1/s].
    pub propeller_rate_hz: f64,
    pub samples: usize,
    /// Usable samples before the even thinning (`samples` when none was needed).
    pub samples_available: usize,
    pub fit_time_s: f64,
    /// The propeller inflow the recorded thrust gave, when the training windows record one.
    pub inflow: Option<thrust::InflowEstimate>,
}

/// The equation-error samples of the chosen recordings and window, the windows used and their
/// recordings (one per sample group).
pub struct TrainingData {
    pub samples: Vec<EqSample>,
    /// Usable samples of the training windows before the even thinning to [`MAX_SAMPLES`].
    pub samples_available: usize,
    pub windows: Vec<TrainingWindow>,
    pub recordings: Vec<Recording>,
    /// Each training recording's recorded wind and current (`None`: calm), which its replays feel.
    pub environments: Vec<Option<KnownEnvironment>>,
}

/// The [`TrainingData`] of `opts` on `ds`.
pub fn training_samples(ds: &Dataset, opts: &MmgFitOptions) -> Result<TrainingData, PipelineError> {
    let added = ds.added_mass.ok_or_else(|| {
        bad_input(format!(
            "{}: no [added_mass] table; the MMG fit needs m_x, m_y and J_z",
            ds.path.display()
        ))
    })?;
    // Zero within rounding: a table written about the centre of gravity with the coupling that
    // cancels at midship comes back from the transform as a few 1e-6 of Y_v̇ L, not 0.
    let negligible = 1e-6 * (added.Y_vdot * ds.ship.lpp).abs();
    if added.Y_rdot.abs() > negligible || added.N_vdot.abs() > negligible {
        let cg = -ds.ship.xg * added.Y_vdot;
        return Err(bad_input(format!(
            "{}: [added_mass] has Y_rdot = {} and N_vdot = {} about midship: the MMG model has no sway–yaw added-mass coupling there. (A data set with origin = \"cg\" gives its added masses about the centre of gravity, and moving them to midship adds x_G·Y_vdot to both: about the CG, the MMG family needs Y_rdot = N_vdot = −x_G·Y_vdot = {cg:.6}.)",
            ds.path.display(),
            added.Y_rdot,
            added.N_vdot
        )));
    }
    let ship = &ds.ship;
    let m = ship.mass_kg();
    let mx = -added.X_udot;
    let my = -added.Y_vdot;
    let iz = ship.iz_midship_kg_m2() - added.N_rdot;
    let chosen = chosen_recordings(ds, &opts.recordings)?;
    let mut samples = Vec::new();
    let mut windows = Vec::new();
    let mut recordings = Vec::new();
    let mut environments = Vec::new();
    for (g, r) in chosen.iter().enumerate() {
        let range = window_range(r, ds, opts.window)?;
        recordings.push(r.recording.slice(range.clone()));
        environments.push(crate::environment::recording_environment(ds, &r.recording)?.0);
        // The recorded wind and current are known inputs: identify from what is left.
        let hydro = crate::environment::hydrodynamic_recording(ds, r, &added)?;
        let (rec, acc, estimated) = (&hydro.recording, &hydro.accelerations, hydro.estimated);
        for i in range.clone() {
            let n_hz = match (&rec.n, opts.propeller_rate_hz) {
                (Some(n), _) => n[i],
                (None, Some(n)) => n,
                (None, None) => {
                    return Err(bad_input(format!(
                        "{}: recording `{}` has no `n` column and no propeller rate is given \
                         ([propeller] rate_rps of the data set)",
                        ds.path.display(),
                        r.file
                    )));
                }
            };
            let state = State::of_recording(rec, i);
            // Slow samples (or NaN: `range::SLOW_SPEED_OVER_U0`) are skipped; a propeller turning
            // astern (n < 0) is outside the MMG propeller model, which is for ahead.
            let slow = state.speed().is_nan()
                || state.speed() <= crate::range::SLOW_SPEED_OVER_U0 * ship.u0;
            if slow || !(n_hz.is_finite() && n_hz >= 0.0) {
                continue;
            }
            let (u, v, rr) = (state.u, state.v, state.r);
            let (ud, vd, rd) = (acc.u_dot[i], acc.v_dot[i], acc.r_dot[i]);
            let needed = [
                (m + mx) * ud - (m + my) * v * rr - ship.xg * m * rr * rr,
                (m + my) * vd + (m + mx) * u * rr + ship.xg * m * rd,
                iz * rd + ship.xg * m * (vd + u * rr),
            ];
            samples.push(EqSample {
                state,
                delta_rad: rec.delta[i],
                n_hz,
                needed,
                group: g,
                t_s: rec.t[i],
            });
        }
        let t = &rec.t;
        windows.push(training_window(
            ds,
            r,
            opts.window,
            (
                t[range.start],
                t[range.end.saturating_sub(1).max(range.start)],
            ),
            estimated,
        ));
    }
    // No rank check guards the mmg fit (the priors keep it well posed), so a window without rudder
    // action, exactly constant or not, would be fitted: a straight run "determined" resistance,
    // thrust deduction and wake with zero standard errors from one force balance, and its model
    // carried no identification range to warn with.
    let delta: Vec<f64> = samples.iter().map(|s| s.delta_rad).collect();
    let spread_deg = crate::excitation::rudder_spread_deg(&delta);
    if spread_deg < crate::excitation::MIN_RUDDER_SPREAD_DEG {
        return Err(crate::excitation::rudder_unexcited_error(
            spread_deg,
            &windows,
            "the rudder and hull parameters need",
        ));
    }
    // Neighbouring samples of a smoothed acceleration carry nearly the same information; evenly
    // thinned, the problem keeps its content and the cross-validation its speed.
    let samples_available = samples.len();
    let stride = samples.len().div_ceil(MAX_SAMPLES).max(1);
    let samples: Vec<EqSample> = samples.into_iter().step_by(stride).collect();
    if samples.len() < 40 {
        return Err(bad_input(format!(
            "{}: {} usable samples in the training windows, too few for the 31 MMG parameters",
            ds.path.display(),
            samples.len()
        )));
    }
    Ok(TrainingData {
        samples,
        samples_available,
        windows,
        recordings,
        environments,
    })
}

/// Identify the MMG model of `ds` with its `[propeller]` and `[rudder]` tables and the priors of
/// [`priors`]; recordings without an `n` column take the table's `rate_rps` unless `opts` gives a rate.
pub fn fit_mmg_dataset(ds: &Dataset, opts: &MmgFitOptions) -> Result<MmgFit, PipelineError> {
    let geometry = MmgGeometry::of_dataset(ds)?;
    let mut opts = opts.clone();
    if opts.propeller_rate_hz.is_none() {
        opts.propeller_rate_hz = ds.propeller.as_ref().and_then(|p| p.rate_rps);
    }
    fit_mmg(ds, &geometry, &opts)
}

/// Identify the MMG model of `ds` with the given propeller and rudder and the priors of [`priors`].
pub fn fit_mmg(
    ds: &Dataset,
    geometry: &MmgGeometry,
    opts: &MmgFitOptions,
) -> Result<MmgFit, PipelineError> {
    let added = ds
        .added_mass
        .ok_or_else(|| bad_input(format!("{}: no [added_mass] table", ds.path.display())))?;
    fit_mmg_with_priors(ds, geometry, opts, priors(&ds.ship, geometry, &added))
}

/// [`fit_mmg`] with given priors (e.g. deliberately wrong ones, to test what the data determine).
pub fn fit_mmg_with_priors(
    ds: &Dataset,
    geometry: &MmgGeometry,
    opts: &MmgFitOptions,
    specs: Vec<ParamSpec>,
) -> Result<MmgFit, PipelineError> {
    geometry.check(
        ds.ship.lpp,
        &format!("{}: propeller/rudder", ds.path.display()),
    )?;
    if let PriorWeight::Fixed(l) = opts.prior_weight
        && !(l.is_finite() && l > 0.0)
    {
        return Err(bad_input(format!(
            "the prior weight λ must be a positive number, not {l}"
        )));
    }
    let TrainingData {
        samples,
        samples_available,
        windows,
        recordings,
        environments,
    } = training_samples(ds, opts)?;
    // A recorded thrust measures the propeller's inflow. Held there (on request), its four parameters
    // no longer trade against the rudder's inflow in the equation error; otherwise the measurement
    // is reported beside what the motion gave them.
    let mut specs = specs;
    let (samples_of_thrust, thrust_recordings) = thrust::inflow_of_windows(
        &recordings,
        &environments,
        windows.iter().map(|w| w.recording.as_str()),
        opts.propeller_rate_hz,
        &ds.ship,
        geometry,
    );
    let mut inflow = thrust::estimate_inflow(&samples_of_thrust, &specs, thrust_recordings);
    match (&mut inflow, opts.inflow_from_thrust) {
        (Some(estimate), true) => {
            thrust::hold_inflow(&mut specs, estimate);
            estimate.held = true;
        }
        (None, true) => {
            return Err(bad_input(format!(
                "--inflow-from-thrust: no training window of {} records a usable propeller thrust (a `thrust` column with the propeller turning and the ship above {:.0} % of U0, at least {} samples)",
                ds.path.display(),
                100.0 * thrust::SLOW_SHARE,
                thrust::MIN_SAMPLES
            )));
        }
        _ => {}
    }
    let added = ds.added_mass.unwrap_or_default();
    // The median: a mean takes in whatever dropout or spike the recording checks let through.
    let n_hz: Vec<f64> = samples.iter().map(|s| s.n_hz).collect();
    let rate = shipid_io::consistency::upper_median(&n_hz).unwrap_or(f64::NAN);
    let problem = Problem::new(
        ds.ship,
        added,
        *geometry,
        samples,
        specs,
        opts.estimator == MmgEstimator::BoundedLsq,
    )?;
    let started = Instant::now();
    let all: Vec<usize> = (0..problem.samples.len()).collect();
    let (lambda, cv, start) = match opts.prior_weight {
        PriorWeight::Fixed(l) => (l, Vec::new(), problem.prior_phi()),
        PriorWeight::CrossValidated(criterion) => {
            let folds = Folds {
                recordings: &recordings,
                environments: &environments,
                criterion,
                rate_hz: rate,
                refine: opts.refine_folds.as_ref(),
            };
            cross_validate(&problem, &all, &folds)?
        }
    };
    let (phi, beta, iterations) = problem.solve(&start, &all, lambda)?;
    let estimate = problem.estimate(&phi, &beta, lambda, iterations)?;
    let fit_time_s = started.elapsed().as_secs_f64();
    let theta: Vec<f64> = estimate.params.iter().map(|p| p.value).collect();
    let model = MmgModel::at_rate(ds.ship, problem.parameters(&theta), rate)
        .map_err(|e| failed(format!("the identified MMG model is unusable: {e}")))?;
    Ok(MmgFit {
        model,
        geometry: *geometry,
        estimate,
        lambda,
        estimator: opts.estimator,
        // The equation-error criterion scores the folds' equation error, which a refinement does
        // not change: only replayed folds are refined.
        cv_folds_refined: opts.refine_folds.is_some()
            && opts.prior_weight == PriorWeight::CrossValidated(CvCriterion::Replay),
        cv,
        windows,
        propeller_rate_hz: rate,
        samples: problem.samples.len(),
        samples_available,
        fit_time_s,
        inflow,
    })
}

/// λ from [`CV_GRID`] by blocked cross-validation: whole recordings held out when there are several
/// (at most [`CV_BLOCKS`] folds), otherwise [`CV_BLOCKS`] contiguous blocks; the folds in parallel. Each λ is fitted on all data first (warm start from the
/// previous λ), its folds start there. Returns λ, the scores and the full-data φ of the chosen λ.
fn cross_validate(
    problem: &Problem,
    all: &[usize],
    how: &Folds,
) -> Result<(f64, Vec<CvScore>, Vec<f64>), PipelineError> {
    let groups = problem.samples.iter().map(|s| s.group).max().unwrap_or(0) + 1;
    let folds: Vec<(Vec<usize>, Vec<usize>)> = if groups >= EXTRAPOLATION_MIN_RECORDINGS {
        extrapolation_folds(problem, all, groups)
    } else if groups > 1 {
        // Whole recordings are held out; more than CV_BLOCKS recordings share folds round-robin.
        (0..groups.min(CV_BLOCKS))
            .map(|f| {
                all.iter()
                    .copied()
                    .filter(|&i| problem.samples[i].group % CV_BLOCKS == f)
                    .collect()
            })
            .map(|held| complement_fold(all, held))
            .collect()
    } else {
        let n = all.len();
        (0..CV_BLOCKS)
            .map(|b| {
                complement_fold(
                    all,
                    all[b * n / CV_BLOCKS..(b + 1) * n / CV_BLOCKS].to_vec(),
                )
            })
            .collect()
    };
    let mut start = problem.prior_phi();
    let mut scores = Vec::new();
    let mut best: Option<(f64, f64, Vec<f64>)> = None;
    for &lambda in &CV_GRID {
        let (phi, _, _) = problem.solve(&start, all, lambda)?;
        let held_out: Vec<f64> = folds
            .par_iter()
            .map(|(train, held)| {
                let (phi_k, beta_k, _) = problem.solve(&phi, train, lambda)?;
                match how.criterion {
                    CvCriterion::EquationError => problem.data_cost(&phi_k, &beta_k, held),
                    CvCriterion::Replay => {
                        let model = problem.model_of(&phi_k, &beta_k, how.rate_hz)?;
                        let model = match how.refine {
                            Some(opts) => {
                                refine_fold(problem, model, &phi_k, &beta_k, train, how, opts)?
                            }
                            None => model,
                        };
                        Ok(replay_score(
                            &model,
                            problem,
                            held,
                            how.recordings,
                            how.environments,
                        ))
                    }
                }
            })
            .collect::<Result<_, _>>()?;
        let score = held_out.iter().sum::<f64>() / folds.len() as f64;
        scores.push(CvScore {
            lambda,
            held_out_cost: score,
        });
        if best.as_ref().is_none_or(|b| score < b.1) {
            best = Some((lambda, score, phi.clone()));
        }
        start = phi;
    }
    let (lambda, _, phi) = best.ok_or_else(|| failed("mmg: empty cross-validation grid"))?;
    Ok((lambda, scores, phi))
}

/// How the cross-validation scores a prior weight.
struct Folds<'a> {
    /// The training windows, by sample group.
    recordings: &'a [Recording],
    environments: &'a [Option<KnownEnvironment>],
    criterion: CvCriterion,
    rate_hz: f64,
    /// Refine each fold's fit on its training part before scoring it (as `--refine` does the final fit).
    refine: Option<&'a RefineOptions>,
}

/// A fold's fit refined in the output-error sense on its training part: the stretches of consecutive
/// training samples, each a slice of its recording (a held-out block inside a recording splits it).
fn refine_fold(
    problem: &Problem,
    model: MmgModel,
    phi: &[f64],
    beta: &[Vec<f64>; 3],
    train: &[usize],
    how: &Folds,
    opts: &RefineOptions,
) -> Result<MmgModel, PipelineError> {
    let mut parts: Vec<Recording> = Vec::new();
    let mut run: Option<(usize, f64, f64, usize)> = None;
    let close = |run: Option<(usize, f64, f64, usize)>, parts: &mut Vec<Recording>| {
        if let Some((g, t0, t1, _)) = run
            && let Some(rec) = how.recordings.get(g)
        {
            let lo = rec.t.partition_point(|&t| t < t0);
            let hi = rec.t.partition_point(|&t| t <= t1);
            if hi > lo + 10 {
                parts.push(rec.slice(lo..hi));
            }
        }
    };
    for &i in train {
        let s = &problem.samples[i];
        run = match run {
            Some((g, t0, _, last)) if g == s.group && i == last + 1 => Some((g, t0, s.t_s, i)),
            other => {
                close(other, &mut parts);
                Some((s.group, s.t_s, s.t_s, i))
            }
        };
    }
    close(run, &mut parts);
    let specs: Vec<&ParamSpec> = problem.specs.iter().collect();
    let theta = problem.theta_of(phi, beta);
    let start = ParametricMmg::new(
        model,
        problem.added,
        problem.geometry,
        how.rate_hz,
        &specs,
        &theta,
    );
    let refined = crate::refine::refine(&start, &parts, opts)
        .map_err(|e| failed(format!("--refine in a cross-validation fold: {e}")))?;
    Ok(refined.model.model().clone())
}

/// From this many training recordings on, the cross-validation holds out the largest-amplitude ones
/// (see [`extrapolation_folds`]); with fewer there is nothing smaller to train on.
pub const EXTRAPOLATION_MIN_RECORDINGS: usize = 3;

/// (training, held-out) sample indices: the held-out ones and everything else.
fn complement_fold(all: &[usize], held: Vec<usize>) -> (Vec<usize>, Vec<usize>) {
    let train = all
        .iter()
        .copied()
        .filter(|i| held.binary_search(i).is_err())
        .collect();
    (train, held)
}

/// Folds that test extrapolation in amplitude: recordings ranked by their largest non-dimensional
/// yaw rate |r| L / U; fold k holds out the k-th largest (k < [`CV_BLOCKS`], at least one recording
/// left to train on) and trains on the recordings ranked below it only. A prediction outside the
/// training range (a turning circle from zig-zags, a large zig-zag from small ones) is what the prior
/// weight has to serve; holding out recordings at random rewards in-range interpolation, where the
/// weakest prior always wins.
fn extrapolation_folds(
    problem: &Problem,
    all: &[usize],
    groups: usize,
) -> Vec<(Vec<usize>, Vec<usize>)> {
    let l = problem.ship.lpp;
    let mut amplitude = vec![0.0_f64; groups];
    for s in &problem.samples {
        let speed = s.state.u.hypot(s.state.v);
        if speed > 0.0 {
            let r_prime = (s.state.r * l / speed).abs();
            amplitude[s.group] = amplitude[s.group].max(r_prime);
        }
    }
    let mut ranked: Vec<usize> = (0..groups).collect();
    // Descending; ties by recording order so the folds never depend on sort stability.
    ranked.sort_by(|&a, &b| amplitude[b].total_cmp(&amplitude[a]).then(a.cmp(&b)));
    (0..CV_BLOCKS.min(groups - 1))
        .map(|k| {
            let below = &ranked[k + 1..];
            let in_group = |g: usize| {
                all.iter()
                    .copied()
                    .filter(move |&i| problem.samples[i].group == g)
            };
            let held: Vec<usize> = in_group(ranked[k]).collect();
            let mut train: Vec<usize> = below.iter().flat_map(|&g| in_group(g)).collect();
            train.sort_unstable();
            (train, held)
        })
        .collect()
}

/// Segment-replay horizon of the replay criterion ÷ (L/U0): the output-error refinement's and the
/// diagnosis's, long enough for the hull forces to show, short enough not to drift off.
pub const CV_REPLAY_HORIZON_L_OVER_U0: f64 = 10.0;

/// Mean replay error of `model` over the held-out parts: per recording, the span of its held-out
/// samples cut into segments of [`CV_REPLAY_HORIZON_L_OVER_U0`], each replayed with the recorded
/// rudder from the recorded state; RMS over the compared samples of position error ÷ L plus heading
/// error [rad], a diverged segment counting 1.
fn replay_score(
    model: &MmgModel,
    problem: &Problem,
    held: &[usize],
    recordings: &[Recording],
    environments: &[Option<KnownEnvironment>],
) -> f64 {
    let mut spans: Vec<(usize, f64, f64)> = Vec::new();
    for &i in held {
        let s = &problem.samples[i];
        match spans.iter_mut().find(|(g, _, _)| *g == s.group) {
            Some(span) => {
                span.1 = span.1.min(s.t_s);
                span.2 = span.2.max(s.t_s);
            }
            None => spans.push((s.group, s.t_s, s.t_s)),
        }
    }
    let ship = *model.ship();
    let horizon_s = CV_REPLAY_HORIZON_L_OVER_U0 * ship.lpp / ship.u0;
    let (mut sum_sq, mut count) = (0.0, 0usize);
    for &(g, t0, t1) in &spans {
        let Some(rec) = recordings.get(g) else {
            continue;
        };
        let lo = rec.t.partition_point(|&t| t < t0);
        let hi = rec.t.partition_point(|&t| t <= t1);
        if hi <= lo + 10 {
            continue;
        }
        let part = rec.slice(lo..hi);
        for (a, b) in segments(&part, horizon_s) {
            let env = environments.get(g).and_then(Option::as_ref);
            let (sim, completed) = replay_segment_in(model, env, &part, a, b);
            let t_start = part.t[a];
            for i in a..b {
                let t = part.t[i] - t_start;
                let e = if !completed || sim.is_empty() || t > *sim.t.last().unwrap_or(&0.0) + 1e-9
                {
                    1.0
                } else {
                    let at = |y: &[f64]| interp(&sim.t, y, t);
                    let dp = (at(&sim.x0) - part.x0[i]).hypot(at(&sim.y0) - part.y0[i]) / ship.lpp;
                    (dp + (at(&sim.psi) - part.psi[i]).abs()).min(1.0)
                };
                sum_sq += e * e;
                count += 1;
            }
        }
    }
    if count == 0 {
        return f64::INFINITY;
    }
    (sum_sq / count as f64).sqrt()
}

/// The set name that selects this family on the command line and in studies.
pub const SET_NAME: &str = "mmg";

impl MmgFitOptions {
    /// The options of `shipid fit --set mmg`: `--estimator bounded-lsq|ridge`, `--lambda` (the prior
    /// weight) or `--tune` (cross-validated by segment replays); the other estimators' settings are
    /// refused.
    pub fn from_spec(
        spec: &EstimatorSpec,
        recordings: &[String],
        window: WindowSpec,
    ) -> Result<MmgFitOptions, PipelineError> {
        let estimator = MmgEstimator::parse(&spec.name)?;
        for (given, flag) in [
            (spec.alpha.is_some(), "alpha"),
            (spec.c.is_some(), "c"),
            (spec.epsilon.is_some(), "epsilon"),
            (spec.similarity.is_some(), "similarity"),
        ] {
            if given {
                return Err(bad_input(format!("--{flag} does not apply to --set mmg")));
            }
        }
        let prior_weight = match (spec.lambda, spec.tune) {
            (Some(_), true) => {
                return Err(bad_input(
                    "--set mmg: give the prior weight --lambda or --tune, not both",
                ));
            }
            (Some(l), false) if l.is_finite() && l > 0.0 => PriorWeight::Fixed(l),
            (Some(l), false) => {
                return Err(bad_input(format!(
                    "--lambda (the prior weight of --set mmg) must be a positive number, not {l}"
                )));
            }
            (None, true) => PriorWeight::CrossValidated(CvCriterion::Replay),
            (None, false) => PriorWeight::Fixed(DEFAULT_PRIOR_WEIGHT),
        };
        Ok(MmgFitOptions {
            recordings: recordings.to_vec(),
            window,
            estimator,
            prior_weight,
            propeller_rate_hz: None,
            inflow_from_thrust: spec.inflow_from_thrust,
            refine_folds: None,
        })
    }
}

/// The equation-error problem `fit` was made on (the training samples of `opts` in `ds`, its priors,
/// bounds and estimator) and its propeller and rudder parameters φ, where every refit of it starts
/// (the bootstrap's replicates, the jackknife's refits).
pub(crate) fn refit_problem(
    ds: &Dataset,
    fit: &MmgFit,
    opts: &MmgFitOptions,
) -> Result<(Problem, Vec<f64>), PipelineError> {
    let added = ds
        .added_mass
        .ok_or_else(|| bad_input(format!("{}: no [added_mass] table", ds.path.display())))?;
    let mut opts = opts.clone();
    if opts.propeller_rate_hz.is_none() {
        opts.propeller_rate_hz = ds.propeller.as_ref().and_then(|p| p.rate_rps);
    }
    let samples = training_samples(ds, &opts)?.samples;
    let specs: Vec<ParamSpec> = fit.estimate.params.iter().map(|p| p.spec.clone()).collect();
    let value_of = |name: &str| {
        fit.estimate
            .params
            .iter()
            .find(|p| p.spec.name == name)
            .map_or(f64::NAN, |p| p.value)
    };
    let start: Vec<f64> = priors::NONLINEAR_NAMES
        .iter()
        .map(|n| value_of(n))
        .collect();
    let problem = Problem::new(
        ds.ship,
        added,
        fit.geometry,
        samples,
        specs,
        fit.estimator == MmgEstimator::BoundedLsq,
    )?;
    Ok((problem, start))
}

/// `shipid fit --set mmg`: the fit of `ds` (propeller and rudder from its tables), refined when asked,
/// and its model file (the caller anchors its training paths to where it writes it,
/// `model_file::anchor_training`, which imports this module's loader).
pub fn fit_mmg_model_file(
    ds: &Dataset,
    opts: &MmgFitOptions,
    refine_after: bool,
) -> Result<(MmgFit, MmgModelFile), PipelineError> {
    let added = ds.added_mass.ok_or_else(|| {
        bad_input(format!(
            "{}: no [added_mass] table; the MMG fit needs m_x, m_y and J_z",
            ds.path.display()
        ))
    })?;
    let refine = RefineOptions::for_dataset(ds);
    let mut opts = opts.clone();
    if refine_after {
        opts.refine_folds = Some(refine.clone());
    }
    let fit = fit_mmg_dataset(ds, &opts)?;
    // Of the equation-error estimate, as its standard errors are: a refinement moves the values,
    // not what the recordings say about them.
    let jackknife = jackknife::recording_jackknife(ds, &fit, &opts)?;
    if !refine_after {
        let mut file = model_file(&fit, added);
        if let Some(j) = &jackknife {
            add_jackknife(&mut file, j, None);
        }
        return Ok((fit, file));
    }
    let started = Instant::now();
    let recordings = fit_recordings(&fit, ds);
    let (mut refined, how) = refine_mmg(&fit, added, &recordings, &refine)?;
    // The valley comes with the thorough path (a cross-validated λ): the other candidates are
    // refined too, which costs as many refinements again as there are; a fixed λ stays one.
    let starts = match opts.prior_weight {
        PriorWeight::CrossValidated(_) => Some(valley::refine_valley(
            ds,
            &opts,
            &fit,
            &refined,
            added,
            &recordings,
            &refine,
        )?),
        PriorWeight::Fixed(_) => None,
    };
    refined.fit_time_s += started.elapsed().as_secs_f64();
    let mut file = model_file(&refined, added);
    if let Some(j) = &jackknife {
        // The refits are equation-error fits: as they were, their predictions spread about the
        // unrefined fit, not this model (on the default data the refined turn lay outside the
        // whole range). Each is carried by this model's own refinement step.
        let step: Vec<f64> = refined
            .estimate
            .params
            .iter()
            .zip(&fit.estimate.params)
            .map(|(r, e)| r.value - e.value)
            .collect();
        add_jackknife(&mut file, j, Some(&step));
    }
    file.estimator.refinement = Some(how);
    file.valley = starts.as_deref().map(valley_record);
    Ok((refined, file))
}

/// Each parameter's jackknife standard error and `[estimator.jackknife]` into `file`; with
/// `refinement_step` (the refined minus the equation-error values, per parameter) each refit is
/// moved by it, kept within the bounds.
fn add_jackknife(
    file: &mut MmgModelFile,
    j: &jackknife::RecordingJackknife,
    refinement_step: Option<&[f64]>,
) {
    for (p, se) in file.parameters.iter_mut().zip(&j.standard_errors) {
        p.jackknife_standard_error = Some(*se);
    }
    let base = "delete-one-recording jackknife: the equation-error fit repeated with each training \
                recording left out (same priors, prior weight and start), standard error \
                √((g − 1)/g Σ (θ₋ᵢ − θ̄)²) over the g refits";
    let method = match refinement_step {
        None => base.to_string(),
        Some(_) => format!(
            "{base}; each refit then moved by this model's refinement step (its refined minus its \
             equation-error values, within the bounds), so that they spread about the refined model \
             (the refits themselves are not refined: a first-order transfer)"
        ),
    };
    let carried = |k: usize, v: f64| match refinement_step {
        Some(step) => {
            let p = &file.parameters[k];
            (v + step[k]).clamp(p.lower, p.upper)
        }
        None => v,
    };
    file.estimator.jackknife = Some(JackknifeEntry {
        method,
        left_out: j.refits.iter().map(|(name, _)| name.clone()).collect(),
        failed: j.failed.clone(),
        values: file
            .parameters
            .iter()
            .enumerate()
            .map(|(k, p)| {
                let values = j
                    .refits
                    .iter()
                    .map(|(_, theta)| carried(k, theta[k]))
                    .collect();
                (p.name.clone(), values)
            })
            .collect(),
    });
}

/// The `[valley]` of a model file from its starts.
fn valley_record(starts: &[valley::ValleyStart]) -> MmgValleyRecord {
    MmgValleyRecord {
        method: "the equation-error fit at every other prior weight of the cross-validation grid, \
                 refined like this model on the same training windows; cost_ratio: its refinement \
                 cost ÷ this model's, on this model's refinement objective"
            .into(),
        cost_tolerance: valley::VALLEY_COST_TOLERANCE,
        starts: starts
            .iter()
            .map(|s| match &s.outcome {
                valley::ValleyOutcome::Refined { cost_ratio, values } => ValleyStartEntry {
                    prior_weight: s.prior_weight,
                    cost_ratio: Some(*cost_ratio),
                    failed: None,
                    values: values.clone(),
                },
                valley::ValleyOutcome::Failed(why) => ValleyStartEntry {
                    prior_weight: s.prior_weight,
                    cost_ratio: None,
                    failed: Some(why.clone()),
                    values: Default::default(),
                },
            })
            .collect(),
    }
}

/// The training windows of a fit as recordings (for the refinement).
fn fit_recordings(fit: &MmgFit, ds: &Dataset) -> Vec<Recording> {
    fit.windows
        .iter()
        .filter_map(|w| {
            let r = &ds.recording(&w.recording)?.recording;
            let lo = r.t.partition_point(|&t| t < w.t_start_s);
            let hi = r.t.partition_point(|&t| t <= w.t_end_s);
            Some(r.slice(lo..hi))
        })
        .collect()
}

/// The model file of a fit.
pub fn model_file(fit: &MmgFit, added: AddedMass) -> MmgModelFile {
    let g = &fit.geometry;
    MmgModelFile {
        shipid_version: env!("CARGO_PKG_VERSION").into(),
        kind: MMG_KIND.into(),
        ship: *fit.model.ship(),
        added_mass: added,
        propeller: PropellerEntry {
            diameter_m: g.propeller_diameter_m,
            x_m: g.propeller_x_m,
            k_t: g.k_t,
            rate_rps: fit.propeller_rate_hz,
        },
        rudder: RudderEntry {
            area_m2: g.rudder_area_m2,
            span_m: g.rudder_span_m,
            x_m: g.rudder_x_m,
        },
        estimator: MmgEstimatorEntry {
            name: fit.estimator.name().into(),
            method:
                "equation error, variable projection: hull derivatives by the estimator on the \
                     prior-augmented design inside, propeller and rudder parameters by projected \
                     Levenberg–Marquardt outside; maximum a posteriori with the priors"
                    .into(),
            prior_weight: fit.lambda,
            tuned: !fit.cv.is_empty(),
            determined_share: DETERMINED_SHARE,
            samples: fit.samples,
            residual_rms: fit.estimate.residual_rms,
            cv: fit
                .cv
                .iter()
                .map(|c| CvEntry {
                    lambda: c.lambda,
                    held_out_cost: c.held_out_cost,
                })
                .collect(),
            cv_folds_refined: fit.cv_folds_refined,
            refinement: None,
            thrust_inflow: fit.inflow.as_ref().map(|t| {
                let named = |x: &[f64; 4]| {
                    thrust::INFLOW_NAMES
                        .iter()
                        .zip(x)
                        .map(|(n, v)| (n.to_string(), *v))
                        .collect()
                };
                ThrustInflowEntry {
                    held: t.held,
                    samples: t.samples,
                    recordings: t.recordings.clone(),
                    residual_rms: t.residual_rms,
                    values: named(&t.values),
                    standard_errors: named(&t.standard_errors),
                }
            }),
            jackknife: None,
        },
        training: fit.windows.clone(),
        parameters: fit
            .estimate
            .params
            .iter()
            .map(|p| ParamEntry {
                name: p.spec.name.into(),
                value: p.value,
                lower: p.spec.lower,
                upper: p.spec.upper,
                prior: p.spec.prior,
                prior_sd: p.spec.prior_sd,
                prior_source: p.spec.source.clone(),
                standard_error: p.standard_error,
                data_share: p.data_share,
                determined_by_data: p.determined_by_data,
                jackknife_standard_error: None,
            })
            .collect(),
        bootstrap: None,
        calibration: None,
        valley: None,
    }
}

/// The TOML text of a fit's model file.
pub fn write_mmg_model(fit: &MmgFit, added: AddedMass) -> Result<String, PipelineError> {
    write_mmg_model_file(&model_file(fit, added))
}
