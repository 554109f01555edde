//! Output-error refinement of an identified Abkowitz model (`shipid fit --refine`).
//!
//! Every estimator of paper 000 minimises the *equation error*: recorded forces minus the polynomial's at
//! the recorded states. A model that is best in that sense is not the best simulator — small force
//! errors integrate into heading and track drift, and a multicollinear design spreads them over terms
//! that cancel on the training states but not on the states a simulation visits. This module starts
//! from the equation-error coefficients and minimises what a user of the model sees instead: the track
//! and heading error of segment replays (the training recordings cut into segments of `horizon`,
//! each restarted from the recorded state with the recorded rudder, as `shipid diagnose` scores a
//! model), by Levenberg–Marquardt over all coefficients with a finite-difference Jacobian (columns in
//! parallel). No I/O.
//!
//! Parameters are scaled so that a unit step of any coefficient changes its DOF's force by the RMS of
//! that force on the training states: p_j = β_j s_j / c_d, with s_j the RMS of term j's monomial and c_d
//! the RMS of the DOF's polynomial force. Terms whose monomial never moves on the training data stay
//! fixed. LM never accepts a step that raises the training cost, so the result is at least as good on
//! the training segments as the equation-error start; whether it generalises is for validation on
//! other recordings to show.

use rayon::prelude::*;
use shipid_io::{PrimeScale, Recording, deriv::accelerations_or_estimate};
use shipid_model::{AbkowitzModel, Refinement};
use shipid_sim::AbkowitzDynamics;

use crate::lm::{LmPoint, lm_step};
use crate::replay::{differentiator_margin, replay_segment, segments};
use crate::validate::interp;

/// Tunables of the refinement.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RefineOptions {
    /// Segment length ÷ (L/U0); the same horizon as the diagnosis scores models with.
    pub horizon_l_over_u0: f64,
    /// Largest number of Levenberg–Marquardt iterations.
    pub max_iterations: usize,
    /// Largest number of compared samples per recording (thinned evenly; the Jacobian's size).
    pub max_samples_per_recording: usize,
    /// Stop when an iteration lowers the cost by less than this fraction.
    pub tolerance: f64,
}

impl Default for RefineOptions {
    fn default() -> Self {
        RefineOptions {
            horizon_l_over_u0: 10.0,
            max_iterations: 25,
            max_samples_per_recording: 400,
            tolerance: 1e-4,
        }
    }
}

/// Why a refinement cannot run.
#[derive(Debug, Clone, PartialEq)]
pub enum RefineError {
    NoSegments,
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

struct Problem<'a> {
    start: &'a AbkowitzModel,
    /// Equation-error samples: (recording, index, recorded accelerations).
    ee: Vec<(usize, usize, [f64; 3])>,
    /// Weights of the two costs: each starts at 1 (÷ its value at the equation-error solution), the
    /// equation error times `EQUATION_ERROR_WEIGHT`.
    w_oe: f64,
    w_ee: [f64; 3],
    recordings: &'a [Recording],
    horizon_s: f64,
    stride: Vec<usize>,
    /// (DOF, term) of each free parameter and its step in coefficient units per unit parameter.
    free: Vec<(usize, usize, f64)>,
}

impl Problem<'_> {
    fn model(&self, p: &[f64]) -> Option<AbkowitzModel> {
        let mut c = self.start.coefficients.clone();
        for (&(d, j, unit), &x) in self.free.iter().zip(p) {
            c[d][j] += x * unit;
        }
        AbkowitzModel::new(
            self.start.set.clone(),
            c,
            self.start.ship,
            self.start.added_mass,
        )
        .ok()
    }

    /// Equation-error residuals [m/s², m/s², rad/s²] (unweighted) at the thinned samples.
    fn equation_errors(&self, m: &AbkowitzModel) -> Vec<[f64; 3]> {
        self.ee
            .iter()
            .map(|&(k, i, a)| {
                let rec = &self.recordings[k];
                let f = m.accelerations(rec.u[i], rec.v[i], rec.r[i], rec.delta[i]);
                std::array::from_fn(|d| {
                    let e = a[d] - f[d];
                    if e.is_finite() { e } else { 1e3 }
                })
            })
            .collect()
    }

    /// Weighted residuals: [Δx/L, Δy/L, Δψ] at the compared samples of every segment (capped), then
    /// the equation errors.
    fn residuals(&self, p: &[f64]) -> Vec<f64> {
        let mut out = self.replay_residuals(p);
        out.iter_mut().for_each(|x| *x *= self.w_oe);
        match self.model(p) {
            Some(m) => {
                for e in self.equation_errors(&m) {
                    (0..3).for_each(|d| out.push(e[d] * self.w_ee[d]));
                }
            }
            None => out.extend(std::iter::repeat_n(1e3, 3 * self.ee.len())),
        }
        out
    }

    /// Replay residuals [Δx/L, Δy/L, Δψ] at the compared samples of every segment (capped).
    fn replay_residuals(&self, p: &[f64]) -> Vec<f64> {
        let model = self.model(p).map(AbkowitzDynamics);
        let lpp = self.start.ship.lpp;
        let mut out = Vec::new();
        for (rec, &stride) in self.recordings.iter().zip(&self.stride) {
            for (a, b) in segments(rec, self.horizon_s) {
                let sim = model.as_ref().map(|m| replay_segment(m, rec, a, b).0);
                let t0 = rec.t[a];
                for i in (a..b).filter(|i| (i - a) % stride == 0) {
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
            }
        }
        out
    }
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
    let ship = start.ship;
    let horizon_s = opts.horizon_l_over_u0 * ship.lpp / ship.u0;
    if recordings.iter().all(|r| segments(r, horizon_s).is_empty()) {
        return Err(RefineError::NoSegments);
    }
    // One thinning per recording for the compared replay samples, the equation errors and the scales.
    let stride: Vec<usize> = recordings
        .iter()
        .map(|r| r.len().div_ceil(opts.max_samples_per_recording).max(1))
        .collect();
    // Scales of the parameters from the training states.
    let s = PrimeScale::of(&ship);
    let mut states = Vec::new();
    for (rec, &step) in recordings.iter().zip(&stride) {
        for i in (0..rec.len()).step_by(step) {
            states.push((
                s.delta_u_prime(rec.u[i]),
                s.velocity_prime(rec.v[i]),
                s.yaw_rate_prime(rec.r[i]),
                rec.delta[i],
            ));
        }
    }
    let n = states.len().max(1) as f64;
    let mut free = Vec::new();
    for d in 0..3 {
        let force_rms = (states
            .iter()
            .map(|&(du, v, r, dl)| start.forces_prime(du, v, r, dl)[d].powi(2))
            .sum::<f64>()
            / n)
            .sqrt();
        for (j, m) in start.set.terms[d].iter().enumerate() {
            let term_rms = (states
                .iter()
                .map(|&(du, v, r, dl)| m.eval(du, v, r, dl).powi(2))
                .sum::<f64>()
                / n)
                .sqrt();
            if term_rms > 1e-12 && force_rms > 0.0 {
                free.push((d, j, force_rms / term_rms));
            }
        }
    }
    let mut ee = Vec::new();
    for (k, rec) in recordings.iter().enumerate() {
        let (acc, _) = accelerations_or_estimate(rec, &ship);
        let n = rec.len();
        let margin = differentiator_margin(n);
        for i in (margin..n.saturating_sub(margin)).step_by(stride[k]) {
            ee.push((k, i, [acc.u_dot[i], acc.v_dot[i], acc.r_dot[i]]));
        }
    }
    let mut problem = Problem {
        start,
        ee,
        w_oe: 1.0,
        w_ee: [0.0; 3],
        recordings,
        horizon_s,
        stride,
        free,
    };
    let oe0 = problem.replay_residuals(&vec![0.0; problem.free.len()]);
    let oe0_cost = oe0.iter().map(|x| x * x).sum::<f64>().max(1e-300);
    problem.w_oe = 1.0 / oe0_cost.sqrt();
    let ee0 = problem.equation_errors(start);
    for d in 0..3 {
        // Each DOF's equation error counts a third of the weight.
        let c = ee0.iter().map(|e| e[d] * e[d]).sum::<f64>().max(1e-300);
        problem.w_ee[d] = (EQUATION_ERROR_WEIGHT / 3.0 / c).sqrt();
    }
    let k = problem.free.len();
    let p = vec![0.0; k];
    let r = problem.residuals(&p);
    let (before_pos, before_psi) = rmse(&oe0);
    let cost = r.iter().map(|x| x * x).sum::<f64>();
    let mut at = LmPoint { p, r, cost };
    let mut lambda = 1e-2;
    let mut iterations = 0;
    // Forward differences: the replays are deterministic, so a small step is clean.
    let h = 1e-5;
    for _ in 0..opts.max_iterations {
        iterations += 1;
        let jac: Vec<Vec<f64>> = (0..k)
            .into_par_iter()
            .map(|j| {
                let mut q = at.p.clone();
                q[j] += h;
                let rq = problem.residuals(&q);
                rq.iter().zip(&at.r).map(|(a, b)| (a - b) / h).collect()
            })
            .collect();
        let step = lm_step(
            &jac,
            &mut at,
            &mut lambda,
            10,
            |_| {},
            |q| problem.residuals(q),
        );
        if !step.is_some_and(|rel| rel > opts.tolerance) {
            break;
        }
    }
    let p = at.p;
    let (after_pos, after_psi) = rmse(&problem.replay_residuals(&p));
    let model = problem.model(&p).unwrap_or_else(|| start.clone());
    Ok((
        model,
        Refinement {
            method: "output error: Levenberg–Marquardt on segment replays".into(),
            horizon_l_over_u0: opts.horizon_l_over_u0,
            iterations,
            before_position_rmse_over_l: before_pos,
            after_position_rmse_over_l: after_pos,
            before_heading_rmse_deg: before_psi,
            after_heading_rmse_deg: after_psi,
        },
    ))
}
