//! Output-error refinement of an identified model (`shipid fit --refine`): the Abkowitz polynomial,
//! and any family that implements [`Parametric`] (the MMG family does).
//!
//! Every estimator of paper 000 minimises the *equation error*: recorded forces minus the polynomial's at
//! the recorded states. A model that is best in that sense is not the best simulator — small force
//! errors integrate into heading and track drift, and a multicollinear design spreads them over terms
//! that cancel on the training states but not on the states a simulation visits. This module starts
//! from the equation-error coefficients and minimises what a user of the model sees instead: the track
//! and heading error of segment replays (the training recordings cut into segments of `horizon`,
//! each restarted from the recorded state with the recorded rudder, as `shipid diagnose` scores a
//! model), by Levenberg–Marquardt over all coefficients. No I/O.
//!
//! The Jacobian comes from forward sensitivities: each segment is replayed once with ∂x/∂θ integrated
//! alongside the state by the same RK4 stages ([`replay_segment_sensitivities`]), segments in parallel
//! — the exact derivative of the discretised replay, where a finite-difference Jacobian replayed every
//! segment once per coefficient (65 replays of the training data per iteration for full74). The
//! refinement is generic over [`Parametric`] models, so any parameterised family refines the same way;
//! [`refine_output_error`] is the Abkowitz entry point.
//!
//! Parameters are scaled by [`Parametric::parameter_units`] so that a unit step of any of them matters
//! as much on the training states. For the polynomial a unit step changes the coefficient's DOF force
//! by the RMS of that force: p_j = β_j s_j / c_d, with s_j the RMS of term j's monomial and c_d the RMS
//! of the DOF's polynomial force. Parameters the training data do not move (a monomial that is zero
//! there) stay fixed; bounds ([`Parametric::parameter_bounds`]) hold by projection. LM never accepts a step that raises the training cost, so the result is at least as good on
//! the training segments as the equation-error start; whether it generalises is for validation on
//! other recordings to show.

use rayon::prelude::*;
use shipid_io::{Recording, Windage, deriv::accelerations_or_estimate};
use shipid_model::{AbkowitzModel, Refinement};
use shipid_sim::dynamics::{FiniteDifferences, MassMatrix, Parametric, State};
use shipid_sim::environment::assumed_windage;
use shipid_sim::{AbkowitzDynamics, KnownEnvironment};

use crate::lm::{LmPoint, Normal, lm_step_normal};
use crate::replay::{
    SegmentSensitivities, differentiator_margin, replay_segment_in,
    replay_segment_sensitivities_in, segments,
};
use crate::validate::interp;

/// Tunables of the refinement.
#[derive(Debug, Clone, PartialEq)]
pub struct RefineOptions {
    /// Segment length ÷ (L/U0); the same horizon as the diagnosis scores models with.
    pub horizon_l_over_u0: f64,
    /// Largest number of Levenberg–Marquardt iterations.
    pub max_iterations: usize,
    /// Largest number of compared samples per recording (thinned evenly; the Jacobian's size).
    pub max_samples_per_recording: usize,
    /// Stop when an iteration lowers the cost by less than this fraction.
    pub tolerance: f64,
    /// Windage of the recordings' recorded wind (the data set's `[windage]`); `None`: assumed
    /// ([`assumed_windage`]). Recordings without a recorded wind do not use it.
    pub windage: Option<Windage>,
}

impl RefineOptions {
    /// The defaults with the windage of `ds` (its `[windage]`, else assumed).
    pub fn for_dataset(ds: &shipid_io::Dataset) -> RefineOptions {
        RefineOptions {
            windage: ds.windage.clone(),
            ..RefineOptions::default()
        }
    }
}

impl Default for RefineOptions {
    fn default() -> Self {
        RefineOptions {
            horizon_l_over_u0: 10.0,
            max_iterations: 25,
            max_samples_per_recording: 400,
            tolerance: 1e-4,
            windage: None,
        }
    }
}

/// Why a refinement cannot run.
#[derive(Debug, Clone, PartialEq)]
pub enum RefineError {
    NoSegments,
    /// A recording's recorded wind or current cannot be used.
    Environment(String),
}

impl std::fmt::Display for RefineError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            RefineError::NoSegments => {
                write!(
                    f,
                    "no training recording is long enough for a replay segment"
                )
            }
            RefineError::Environment(why) => write!(f, "recorded environment: {why}"),
        }
    }
}

impl std::error::Error for RefineError {}

/// Largest error one compared sample contributes (position ÷ L, heading in rad): a segment that runs
/// away counts as this much wrong, so one divergence cannot dominate the cost.
const CAP: f64 = 1.0;

/// Weight of the equation error against the replay error (both ÷ their values at the start). Replays
/// alone let the coefficients drift to whatever reproduces the six training trajectories, and such a
/// model answered a changed rudder timing (a rudder lag) with twice the error of the equation-error
/// model; keeping the force fit in the cost keeps the model's force field where the data put it.
const EQUATION_ERROR_WEIGHT: f64 = 1.0;

/// Residual of an equation error that cannot be evaluated (the model fails at a recorded state).
const EE_FAILED: f64 = 1e3;

/// A refined model and what the refinement did.
#[derive(Debug, Clone)]
pub struct Refined<P> {
    pub model: P,
    pub refinement: Refinement,
    /// The cost LM minimised (replay part ÷ its start value + equation error ÷ its start value ×
    /// `EQUATION_ERROR_WEIGHT`) at the start and at the result.
    pub cost_before: f64,
    pub cost_after: f64,
}

/// One replay segment: recording, first and end sample.
#[derive(Debug, Clone, Copy)]
struct Segment {
    recording: usize,
    a: usize,
    b: usize,
}

struct Problem<'a, P> {
    start: &'a P,
    theta0: Vec<f64>,
    /// Equation-error samples: (recording, index, recorded accelerations).
    ee: Vec<(usize, usize, [f64; 3])>,
    /// Weights of the two costs: each starts at 1 (÷ its value at the equation-error solution), the
    /// equation error times `EQUATION_ERROR_WEIGHT`.
    w_oe: f64,
    w_ee: [f64; 3],
    recordings: &'a [Recording],
    /// Each recording's known wind and current (`None`: calm), felt by its replays.
    environments: Vec<Option<KnownEnvironment>>,
    /// The recordings with velocities through the water: the states of the equation errors.
    hydrodynamic: Vec<Recording>,
    segments: Vec<Segment>,
    stride: Vec<usize>,
    lpp: f64,
    /// (parameter index, its step per unit of p) of each free parameter.
    free: Vec<(usize, f64)>,
    /// Every parameter's bounds ([`Parametric::parameter_bounds`]).
    bounds: Vec<(f64, f64)>,
    /// Replay position (÷ L) and heading \[deg\] RMSE of the start.
    before_rmse: (f64, f64),
}

impl<P: Parametric> Problem<'_, P> {
    fn model(&self, p: &[f64]) -> Option<P> {
        self.start
            .with_parameters(&theta_at(&self.theta0, &self.free, p, &self.bounds))
    }

    /// The compared samples of a segment: indices into its recording.
    fn compared(&self, seg: &Segment) -> impl Iterator<Item = usize> + use<'_, P> {
        let (a, stride) = (seg.a, self.stride[seg.recording]);
        (seg.a..seg.b).filter(move |i| (i - a) % stride == 0)
    }

    /// The state through the water at sample `i` of recording `k` (what the model's hydrodynamics
    /// see).
    fn state(&self, k: usize, i: usize) -> State {
        State::of_recording(&self.hydrodynamic[k], i)
    }

    /// Equation-error residuals [m/s², m/s², rad/s²] (unweighted) at the thinned samples.
    fn equation_errors(&self, m: &P) -> Vec<[f64; 3]> {
        self.ee
            .iter()
            .map(|&(k, i, a)| {
                let f = m
                    .accelerations(&self.state(k, i), self.recordings[k].delta[i])
                    .unwrap_or([f64::NAN; 3]);
                std::array::from_fn(|d| {
                    let e = a[d] - f[d];
                    if e.is_finite() { e } else { EE_FAILED }
                })
            })
            .collect()
    }

    /// Weighted residuals of a model (`None`: the parameters make none): [Δx/L, Δy/L, Δψ] at the
    /// compared samples of every segment (capped), then the equation errors.
    fn residuals_of(&self, model: Option<&P>) -> Vec<f64> {
        let mut out = self.replay_residuals(model);
        out.iter_mut().for_each(|x| *x *= self.w_oe);
        match model {
            Some(m) => {
                for e in self.equation_errors(m) {
                    (0..3).for_each(|d| out.push(e[d] * self.w_ee[d]));
                }
            }
            None => out.extend(std::iter::repeat_n(EE_FAILED, 3 * self.ee.len())),
        }
        out
    }

    fn residuals(&self, p: &[f64]) -> Vec<f64> {
        self.residuals_of(self.model(p).as_ref())
    }

    /// Replay residuals [Δx/L, Δy/L, Δψ] at the compared samples of every segment (capped), segments
    /// in parallel.
    fn replay_residuals(&self, model: Option<&P>) -> Vec<f64> {
        let lpp = self.lpp;
        let per_segment: Vec<Vec<f64>> = self
            .segments
            .par_iter()
            .map(|seg| {
                let rec = &self.recordings[seg.recording];
                let env = self.environments[seg.recording].as_ref();
                let sim = model.map(|m| replay_segment_in(m, env, rec, seg.a, seg.b).0);
                let t0 = rec.t[seg.a];
                let mut out = Vec::new();
                for i in self.compared(seg) {
                    let t = rec.t[i] - t0;
                    match &sim {
                        Some(s) if !s.is_empty() && t <= s.t[s.t.len() - 1] + 1e-9 => {
                            let at = |y: &[f64]| interp(&s.t, y, t);
                            out.push(((at(&s.x0) - rec.x0[i]) / lpp).clamp(-CAP, CAP));
                            out.push(((at(&s.y0) - rec.y0[i]) / lpp).clamp(-CAP, CAP));
                            out.push((at(&s.psi) - rec.psi[i]).clamp(-CAP, CAP));
                        }
                        _ => out.extend([CAP; 3]),
                    }
                }
                out
            })
            .collect();
        per_segment.concat()
    }

    /// Normal equations JᵀJ, −Jᵀr of [`Problem::residuals`] at `p` with residuals `r` there. J's rows
    /// come from the forward sensitivities of each segment (replay rows) and analytically (equation
    /// errors); a capped residual, a sample past a divergence or a failed equation error has a zero
    /// row, as it does not move with p. Each block of rows (a segment, the equation errors) is
    /// reduced to its share of JᵀJ in parallel, and the shares are added in block order, so the sum
    /// does not depend on the thread count.
    fn normal_equations(&self, p: &[f64], r: &[f64]) -> Normal {
        let n = self.free.len();
        let Some(model) = self.model(p) else {
            return Normal {
                jtj: vec![vec![0.0; n]; n],
                neg_jtr: vec![0.0; n],
            };
        };
        // First residual of each block.
        let mut offsets = Vec::with_capacity(self.segments.len() + 1);
        let mut offset = 0;
        for seg in &self.segments {
            offsets.push(offset);
            offset += 3 * self.compared(seg).count();
        }
        offsets.push(offset);
        let shares: Vec<(Vec<f64>, Vec<f64>)> = (0..=self.segments.len())
            .into_par_iter()
            .map(|block| {
                let rows = match self.segments.get(block) {
                    Some(seg) => self.replay_rows(&model, seg),
                    None => self.equation_error_rows(&model),
                };
                normal_share(&rows, &r[offsets[block]..], n)
            })
            .collect();
        let mut jtj = vec![0.0; n * n];
        let mut jtr = vec![0.0; n];
        for (share_jtj, share_jtr) in &shares {
            jtj.iter_mut().zip(share_jtj).for_each(|(x, y)| *x += y);
            jtr.iter_mut().zip(share_jtr).for_each(|(x, y)| *x += y);
        }
        // Only the upper triangle was accumulated.
        let jtj = (0..n)
            .map(|a| (0..n).map(|b| jtj[a.min(b) * n + a.max(b)]).collect())
            .collect();
        Normal {
            jtj,
            neg_jtr: jtr.iter().map(|x| -x).collect(),
        }
    }

    /// Rows of J (row-major, one column per free parameter) for the replay residuals of a segment.
    fn replay_rows(&self, model: &P, seg: &Segment) -> Vec<f64> {
        let n = self.free.len();
        let lpp = self.lpp;
        let rec = &self.recordings[seg.recording];
        let env = self.environments[seg.recording].as_ref();
        let sens = replay_segment_sensitivities_in(model, env, rec, seg.a, seg.b, &self.free);
        let t0 = rec.t[seg.a];
        let scale = [1.0 / lpp, 1.0 / lpp, 1.0];
        let mut rows = Vec::new();
        for i in self.compared(seg) {
            let recorded = [rec.x0[i] / lpp, rec.y0[i] / lpp, rec.psi[i]];
            match pose_at(&sens, rec.t[i] - t0) {
                Some((pose, d_pose)) => {
                    for axis in 0..3 {
                        let live = (pose[axis] * scale[axis] - recorded[axis]).abs() < CAP;
                        let w = if live { scale[axis] * self.w_oe } else { 0.0 };
                        rows.extend((0..n).map(|j| d_pose[3 * j + axis] * w));
                    }
                }
                None => rows.extend(std::iter::repeat_n(0.0, 3 * n)),
            }
        }
        rows
    }

    /// Rows of J for the equation errors: −w ∂a/∂p at the recorded states.
    fn equation_error_rows(&self, model: &P) -> Vec<f64> {
        let n = self.free.len();
        let mut d_state = [[0.0; 3]; 3];
        let mut d_theta = vec![[0.0; 3]; self.theta0.len()];
        let mut rows = Vec::with_capacity(3 * n * self.ee.len());
        let fd = (!model.analytic_sensitivities())
            .then(|| FiniteDifferences::new(model, self.free.iter().map(|&(j, _)| j)));
        for &(k, i, a) in &self.ee {
            let x = self.state(k, i);
            let delta = self.recordings[k].delta[i];
            let f = match &fd {
                Some(fd) => fd.sensitivities(&x, delta, &mut d_state, &mut d_theta),
                None => model.sensitivities(&x, delta, &mut d_state, &mut d_theta),
            };
            for d in 0..3 {
                let live = f.as_ref().is_ok_and(|f| (a[d] - f[d]).is_finite());
                let w = if live { -self.w_ee[d] } else { 0.0 };
                rows.extend(self.free.iter().map(|&(j, unit)| d_theta[j][d] * unit * w));
            }
        }
        rows
    }
}

/// A block's share of the normal equations: the upper triangle of Jᵀ_b J_b (row-major n × n) and
/// Jᵀ_b r_b, from its rows (row-major, n wide) and its residuals (the first rows of `r`).
fn normal_share(rows: &[f64], r: &[f64], n: usize) -> (Vec<f64>, Vec<f64>) {
    let mut jtj = vec![0.0; n * n];
    let mut jtr = vec![0.0; n];
    for (row, &ri) in rows.chunks_exact(n.max(1)).zip(r) {
        for (a, &ja) in row.iter().enumerate() {
            if ja == 0.0 {
                continue;
            }
            jtr[a] += ja * ri;
            jtj[a * n + a..(a + 1) * n]
                .iter_mut()
                .zip(&row[a..])
                .for_each(|(x, &jb)| *x += ja * jb);
        }
    }
    (jtj, jtr)
}

/// Pose and its sensitivities at `t` \[s\] from the segment's start, interpolated between steps as the
/// residuals interpolate the replay ([`interp`]); `None` past the replay's end.
fn pose_at(s: &SegmentSensitivities, t: f64) -> Option<([f64; 3], Vec<f64>)> {
    let last = s.t.len().checked_sub(1)?;
    if t > s.t[last] + 1e-9 {
        return None;
    }
    let i = s.t.partition_point(|&x| x <= t);
    if i == 0 || i > last {
        let k = i.min(last);
        return Some((s.pose[k], s.pose_sensitivity[k].clone()));
    }
    let w = (t - s.t[i - 1]) / (s.t[i] - s.t[i - 1]);
    let lerp = |a: f64, b: f64| a + w * (b - a);
    let pose = std::array::from_fn(|k| lerp(s.pose[i - 1][k], s.pose[i][k]));
    let d = s.pose_sensitivity[i - 1]
        .iter()
        .zip(&s.pose_sensitivity[i])
        .map(|(&a, &b)| lerp(a, b))
        .collect();
    Some((pose, d))
}

/// Position (÷ L) and heading [deg] RMSE of a residual vector.
fn rmse(r: &[f64]) -> (f64, f64) {
    let n = (r.len() / 3).max(1) as f64;
    let pos = r.chunks(3).map(|c| c[0] * c[0] + c[1] * c[1]).sum::<f64>();
    let psi = r.chunks(3).map(|c| c[2] * c[2]).sum::<f64>();
    ((pos / n).sqrt(), (psi / n).sqrt().to_degrees())
}

/// Refine `start` on `recordings` (the training windows, over ground, recorded rudder).
pub fn refine_output_error(
    start: &AbkowitzModel,
    recordings: &[Recording],
    opts: &RefineOptions,
) -> Result<(AbkowitzModel, Refinement), RefineError> {
    let refined = refine(&AbkowitzDynamics(start.clone()), recordings, opts)?;
    Ok((refined.model.0, refined.refinement))
}

/// The problem of refining `start`: segments, thinning, parameter units and cost weights.
fn problem<'a, P: Parametric>(
    start: &'a P,
    recordings: &'a [Recording],
    opts: &RefineOptions,
) -> Result<Problem<'a, P>, RefineError> {
    let ship = *start.ship();
    let horizon_s = opts.horizon_l_over_u0 * ship.lpp / ship.u0;
    let segments: Vec<Segment> = recordings
        .iter()
        .enumerate()
        .flat_map(|(k, rec)| {
            segments(rec, horizon_s)
                .into_iter()
                .map(move |(a, b)| Segment { recording: k, a, b })
        })
        .collect();
    if segments.is_empty() {
        return Err(RefineError::NoSegments);
    }
    let windage = opts
        .windage
        .clone()
        .unwrap_or_else(|| assumed_windage(&ship));
    let environments = recordings
        .iter()
        .map(|rec| KnownEnvironment::of_recording(rec, Some(&windage), &ship))
        .collect::<Result<Vec<_>, _>>()
        .map_err(|e| RefineError::Environment(e.to_string()))?;
    let hydrodynamic: Vec<Recording> = recordings
        .iter()
        .zip(&environments)
        .map(|(rec, env)| match env {
            Some(env) => env.water_relative(rec),
            None => rec.clone(),
        })
        .collect();
    // One thinning per recording for the compared replay samples, the equation errors and the units.
    let stride: Vec<usize> = recordings
        .iter()
        .map(|r| r.len().div_ceil(opts.max_samples_per_recording).max(1))
        .collect();
    let mut states = Vec::new();
    for (rec, &step) in hydrodynamic.iter().zip(&stride) {
        for i in (0..rec.len()).step_by(step) {
            states.push((State::of_recording(rec, i), rec.delta[i]));
        }
    }
    // A parameter whose bounds collapse onto one value is known (the mmg family's inflow held at the
    // recorded thrust's): not refined.
    let bounds = start.parameter_bounds();
    let free: Vec<(usize, f64)> = start
        .parameter_units(&states)
        .into_iter()
        .enumerate()
        .filter(|&(j, _)| bounds.get(j).is_none_or(|(lo, hi)| lo < hi))
        .filter_map(|(j, unit)| Some((j, unit?)))
        .collect();
    let mut ee = Vec::new();
    let mass = MassMatrix::new(&ship, start.added_mass());
    for (k, rec) in hydrodynamic.iter().enumerate() {
        let (acc, _) = accelerations_or_estimate(rec, &ship);
        // The recorded wind's accelerations are known: the model's equation error is against the
        // rest (as the fit that gave the start identified it).
        let wind = match &environments[k] {
            Some(env) if env.has_wind() => env
                .wind_accelerations(&recordings[k], &mass)
                .ok_or_else(|| RefineError::Environment("singular mass matrix".into()))?,
            _ => Vec::new(),
        };
        let n = rec.len();
        let margin = differentiator_margin(n);
        for i in (margin..n.saturating_sub(margin)).step_by(stride[k]) {
            let w = wind.get(i).copied().unwrap_or([0.0; 3]);
            ee.push((
                k,
                i,
                [
                    acc.u_dot[i] - w[0],
                    acc.v_dot[i] - w[1],
                    acc.r_dot[i] - w[2],
                ],
            ));
        }
    }
    let mut problem = Problem {
        start,
        theta0: start.parameters(),
        ee,
        w_oe: 1.0,
        w_ee: [0.0; 3],
        recordings,
        environments,
        hydrodynamic,
        segments,
        stride,
        lpp: ship.lpp,
        free,
        bounds,
        before_rmse: (0.0, 0.0),
    };
    let oe0 = problem.replay_residuals(Some(start));
    problem.before_rmse = rmse(&oe0);
    let oe0_cost = oe0.iter().map(|x| x * x).sum::<f64>().max(1e-300);
    problem.w_oe = 1.0 / oe0_cost.sqrt();
    let ee0 = problem.equation_errors(start);
    for d in 0..3 {
        // Each DOF's equation error counts a third of the weight.
        let c = ee0.iter().map(|e| e[d] * e[d]).sum::<f64>().max(1e-300);
        problem.w_ee[d] = (EQUATION_ERROR_WEIGHT / 3.0 / c).sqrt();
    }
    Ok(problem)
}

/// θ at the step `p` of the refinement: `theta0` moved by `p` in the units of `free` (parameter index,
/// its step per unit of p), each parameter within `bounds` (missing: free). The projection of p onto the
/// bounds in those units is not enough on its own: θ0 + ((hi − θ0) / unit) · unit can round to just past
/// hi, and a model file holding such a value is refused when it is read.
pub fn theta_at(
    theta0: &[f64],
    free: &[(usize, f64)],
    p: &[f64],
    bounds: &[(f64, f64)],
) -> Vec<f64> {
    let mut theta = theta0.to_vec();
    for (&(j, unit), &x) in free.iter().zip(p) {
        let (lo, hi) = bounds
            .get(j)
            .copied()
            .unwrap_or((f64::NEG_INFINITY, f64::INFINITY));
        theta[j] = (theta[j] + x * unit).max(lo).min(hi);
    }
    theta
}

/// The refinement's cost (as in [`Refined::cost_after`]) of `candidate` on the problem of refining
/// `start`: how benchmarks compare refinements of the same start made by different code.
pub fn refinement_cost<P: Parametric>(
    start: &P,
    candidate: &P,
    recordings: &[Recording],
    opts: &RefineOptions,
) -> Result<f64, RefineError> {
    refinement_costs(start, &[candidate], recordings, opts).map(|c| c[0])
}

/// [`refinement_cost`] of every candidate, on one problem (its segments, thinning and the start's
/// normalisation are built once).
pub fn refinement_costs<P: Parametric>(
    start: &P,
    candidates: &[&P],
    recordings: &[Recording],
    opts: &RefineOptions,
) -> Result<Vec<f64>, RefineError> {
    let problem = problem(start, recordings, opts)?;
    Ok(candidates
        .iter()
        .map(|c| problem.residuals_of(Some(*c)).iter().map(|x| x * x).sum())
        .collect())
}

/// Refine any parameterised model `start` on `recordings` (the training windows, over ground,
/// recorded rudder) by Levenberg–Marquardt on segment replays plus the equation error, with the
/// Jacobian from forward sensitivities. Parameters move within [`Parametric::parameter_bounds`].
pub fn refine<P: Parametric>(
    start: &P,
    recordings: &[Recording],
    opts: &RefineOptions,
) -> Result<Refined<P>, RefineError> {
    let problem = problem(start, recordings, opts)?;
    let bounds = start.parameter_bounds();
    // Bounds in the units of p (a unit is positive, so the order holds).
    let p_bounds: Vec<(f64, f64)> = problem
        .free
        .iter()
        .map(|&(j, unit)| {
            let (lo, hi) = bounds
                .get(j)
                .copied()
                .unwrap_or((f64::NEG_INFINITY, f64::INFINITY));
            let t0 = problem.theta0[j];
            ((lo - t0) / unit, (hi - t0) / unit)
        })
        .collect();
    let project = |q: &mut Vec<f64>| {
        for (x, &(lo, hi)) in q.iter_mut().zip(&p_bounds) {
            *x = x.max(lo).min(hi);
        }
    };
    let k = problem.free.len();
    let p = vec![0.0; k];
    let r = problem.residuals(&p);
    let cost = r.iter().map(|x| x * x).sum::<f64>();
    let cost_before = cost;
    let mut at = LmPoint { p, r, cost };
    let mut lambda = 1e-2;
    let mut iterations = 0;
    for _ in 0..opts.max_iterations {
        iterations += 1;
        let normal = problem.normal_equations(&at.p, &at.r);
        let step = lm_step_normal(&normal, &mut at, &mut lambda, 10, project, |q| {
            problem.residuals(q)
        });
        if !step.is_some_and(|rel| rel > opts.tolerance) {
            break;
        }
    }
    let model = problem.model(&at.p).unwrap_or_else(|| start.clone());
    let (before_pos, before_psi) = problem.before_rmse;
    let (after_pos, after_psi) = rmse(&problem.replay_residuals(Some(&model)));
    Ok(Refined {
        model,
        refinement: Refinement {
            method: "output error: Levenberg–Marquardt on segment replays".into(),
            horizon_l_over_u0: opts.horizon_l_over_u0,
            iterations,
            before_position_rmse_over_l: before_pos,
            after_position_rmse_over_l: after_pos,
            before_heading_rmse_deg: before_psi,
            after_heading_rmse_deg: after_psi,
        },
        cost_before,
        cost_after: at.cost,
    })
}
