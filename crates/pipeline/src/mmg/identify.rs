//! Equation-error identification of the MMG model by variable projection.
//!
//! Each training sample gives the forces the motion needs, F = M a + rigid-body terms (Y&Y 2015 eq. 4
//! moved to the right), from the recorded or estimated accelerations. Given the propeller and rudder
//! parameters φ, the propeller and rudder forces are known and the hull forces F − F_P − F_R are linear
//! in the 17 hull derivatives β: the inner problem solves for β by bounded least squares (the
//! estimators crate) on the design augmented with the prior's rows. The outer problem moves φ by a
//! projected Levenberg–Marquardt on the residual that remains (variable projection), with the prior's
//! rows for φ. Both use one objective, a maximum a-posteriori estimate:
//!
//! ```text
//! J(β, φ) = Σ_dof Σ_i (e_i / s_dof)² / m + λ Σ_k ((θ_k − θ_k,prior) / σ_k,prior)²
//! ```
//! with e the prime force residual, s_dof the RMS of the prime force of that DOF, m the number of
//! samples and θ = (β, φ). The prior weight λ is given or chosen by blocked cross-validation.
//!
//! Identifiability: at the estimate, the data's information Ĵᵀ Ĵ and the prior's m λ diag(1/σ²) give the
//! posterior covariance τ²(ĴᵀĴ + mλD)⁻¹ (τ² the residual variance) and the resolution matrix
//! R = (ĴᵀĴ + mλD)⁻¹ ĴᵀĴ, whose diagonal is the share of each parameter's precision that comes from the
//! data (1: the data alone, 0: the prior alone).

use faer::Mat;
use shipid_estimators::{Bounds, Estimator, Solver};
use shipid_io::{AddedMass, Ship};
use shipid_sim::{MmgModel, MmgParameters, State};

use super::geometry::MmgGeometry;
use super::priors::{HULL_NAMES, NONLINEAR_NAMES, ParamSpec, Role};
use crate::error::{PipelineError, failed};
use crate::lm::{LmPoint, dot, lm_step, solve_small};

/// Regressors per DOF: X has R'_0 and four terms, Y and N six each.
pub const HULL_COLUMNS: [usize; 3] = [5, 6, 6];

/// A parameter is reported as determined by the data when more than this share of its posterior
/// precision comes from the data rather than from the prior.
pub const DETERMINED_SHARE: f64 = 0.5;

/// Hull derivatives per DOF (X: 5, Y: 6, N: 6), in the order of [`HULL_NAMES`].
pub type HullDerivatives = [Vec<f64>; 3];

/// φ, the hull derivatives β at φ and the outer iterations taken.
pub type Solution = (Vec<f64>, HullDerivatives, usize);

/// One training sample: state, rudder, propeller rate and the forces the motion needs.
#[derive(Debug, Clone, Copy)]
pub struct EqSample {
    pub state: State,
    pub delta_rad: f64,
    pub n_hz: f64,
    /// [X, Y, N] = M a + rigid-body terms [N, N, N m].
    pub needed: [f64; 3],
    /// Training window (recording) the sample comes from, for the cross-validation folds.
    pub group: usize,
    /// Time of the sample in its recording [s].
    pub t_s: f64,
}

/// What the estimate of one parameter is, and how much of it the data determine.
#[derive(Debug, Clone, PartialEq)]
pub struct ParamEstimate {
    pub spec: ParamSpec,
    pub value: f64,
    /// Posterior standard error.
    pub standard_error: f64,
    /// Share of the posterior precision that comes from the data, in [0, 1].
    pub data_share: f64,
    pub determined_by_data: bool,
    /// The estimate lies on one of its bounds (its standard error then describes the free problem).
    pub at_bound: bool,
}

/// The estimate with its identifiability.
#[derive(Debug, Clone)]
pub struct Estimate {
    pub params: Vec<ParamEstimate>,
    /// RMS of the prime force residual per DOF [X', Y', N'].
    pub residual_rms: [f64; 3],
    /// RMS of the prime forces the motion needs, per DOF (the residual's scale).
    pub force_rms: [f64; 3],
    /// Outer Levenberg–Marquardt iterations.
    pub iterations: usize,
}

/// The identification problem: samples with their regressors and the parameters' priors.
pub struct Problem {
    pub ship: Ship,
    pub added: AddedMass,
    pub geometry: MmgGeometry,
    pub samples: Vec<EqSample>,
    pub specs: Vec<ParamSpec>,
    /// Bounded least squares on the hull derivatives (`true`) or their unbounded prior-centred ridge.
    pub bounded: bool,
    /// Per sample: the hull regressors of X, Y and N and the prime scale q = ½ρLdU².
    rows: Vec<([Vec<f64>; 3], f64)>,
    scales: [f64; 3],
    hull_idx: [Vec<usize>; 3],
    nl_idx: Vec<usize>,
}

impl Problem {
    pub fn new(
        ship: Ship,
        added: AddedMass,
        geometry: MmgGeometry,
        samples: Vec<EqSample>,
        specs: Vec<ParamSpec>,
        bounded: bool,
    ) -> Result<Problem, PipelineError> {
        let mut hull_idx: [Vec<usize>; 3] = Default::default();
        for (d, idx) in hull_idx.iter_mut().enumerate() {
            for (c, name) in HULL_NAMES[d].iter().take(HULL_COLUMNS[d]).enumerate() {
                let k = specs
                    .iter()
                    .position(|s| s.role == Role::Hull { dof: d, column: c })
                    .ok_or_else(|| failed(format!("no prior for {name}")))?;
                idx.push(k);
            }
        }
        let nl_idx = NONLINEAR_NAMES
            .iter()
            .map(|n| {
                specs
                    .iter()
                    .position(|s| s.name == *n)
                    .ok_or_else(|| failed(format!("no prior for {n}")))
            })
            .collect::<Result<Vec<_>, _>>()?;
        let l = ship.lpp;
        let half_rho_l_d = 0.5 * ship.rho * l * ship.draft;
        let rows: Vec<([Vec<f64>; 3], f64)> = samples
            .iter()
            .map(|s| {
                let u = s.state.speed();
                let vp = s.state.v / u;
                let rp = s.state.r * l / u;
                let lateral = vec![
                    vp,
                    rp,
                    vp * vp * vp,
                    vp * vp * rp,
                    vp * rp * rp,
                    rp * rp * rp,
                ];
                (
                    [
                        vec![-1.0, vp * vp, vp * rp, rp * rp, vp * vp * vp * vp],
                        lateral.clone(),
                        lateral,
                    ],
                    half_rho_l_d * u * u,
                )
            })
            .collect();
        let mut scales = [0.0; 3];
        for (d, scale) in scales.iter_mut().enumerate() {
            let lever = if d == 2 { l } else { 1.0 };
            let ms = samples
                .iter()
                .zip(&rows)
                .map(|(s, (_, q))| (s.needed[d] / (q * lever)).powi(2))
                .sum::<f64>()
                / samples.len().max(1) as f64;
            *scale = ms.sqrt().max(1e-12);
        }
        Ok(Problem {
            ship,
            added,
            geometry,
            samples,
            specs,
            bounded,
            rows,
            scales,
            hull_idx,
            nl_idx,
        })
    }

    /// The MMG parameters of θ (all parameters in the order of `specs`).
    pub fn parameters(&self, theta: &[f64]) -> MmgParameters {
        let get = |name: &str| {
            self.specs
                .iter()
                .position(|s| s.name == name)
                .map_or(0.0, |k| theta[k])
        };
        assemble(&self.ship, &self.added, &self.geometry, &get)
    }

    /// The model of (φ, β) with its propeller at `rate_hz`.
    pub fn model_of(
        &self,
        phi: &[f64],
        beta: &[Vec<f64>; 3],
        rate_hz: f64,
    ) -> Result<MmgModel, PipelineError> {
        MmgModel::at_rate(
            self.ship,
            self.parameters(&self.theta_of(phi, beta)),
            rate_hz,
        )
        .map_err(|e| failed(format!("the identified MMG model is unusable: {e}")))
    }

    /// θ (hull derivatives, then the others, in the order of `specs`) from φ and β.
    pub fn theta_of(&self, phi: &[f64], beta: &[Vec<f64>; 3]) -> Vec<f64> {
        let mut theta: Vec<f64> = self.specs.iter().map(|s| s.prior).collect();
        for (k, &i) in self.nl_idx.iter().enumerate() {
            theta[i] = phi[k];
        }
        for (idx, b) in self.hull_idx.iter().zip(beta) {
            for (&i, &value) in idx.iter().zip(b) {
                theta[i] = value;
            }
        }
        theta
    }

    /// Prime targets of the hull regression, y = (F − F_P − F_R)/q, per DOF for the samples `idx`.
    fn hull_targets(&self, phi: &[f64], idx: &[usize]) -> Result<[Vec<f64>; 3], PipelineError> {
        // Hull derivatives at zero: the model then gives the propeller and rudder forces alone.
        let zero: [Vec<f64>; 3] = std::array::from_fn(|d| vec![0.0; HULL_COLUMNS[d]]);
        let theta = self.theta_of(phi, &zero);
        let model = MmgModel::at_rate(self.ship, self.parameters(&theta), 0.0)
            .map_err(|e| failed(format!("mmg: {e}")))?;
        let l = self.ship.lpp;
        let mut y: [Vec<f64>; 3] = Default::default();
        for &i in idx {
            let s = &self.samples[i];
            let f = model
                .forces_at_rate(&s.state, s.delta_rad, s.n_hz)
                .map_err(|e| failed(format!("mmg: {e}")))?;
            let q = self.rows[i].1;
            y[0].push((s.needed[0] - f.propeller_x - f.rudder[0]) / q);
            y[1].push((s.needed[1] - f.rudder[1]) / q);
            y[2].push((s.needed[2] - f.rudder[2]) / (q * l));
        }
        Ok(y)
    }

    /// The inner problem at φ: hull derivatives per DOF and the residual vector (data rows of every
    /// DOF, then the prior rows of β and φ), for the samples `idx`.
    fn inner(
        &self,
        phi: &[f64],
        idx: &[usize],
        lambda: f64,
    ) -> Result<([Vec<f64>; 3], Vec<f64>), PipelineError> {
        let y = self.hull_targets(phi, idx)?;
        let m = idx.len();
        let data_w = 1.0 / (m as f64).sqrt();
        let mut beta: [Vec<f64>; 3] = Default::default();
        let mut resid = Vec::with_capacity(3 * m + self.specs.len());
        let mut prior_rows = Vec::new();
        for d in 0..3 {
            let p = HULL_COLUMNS[d];
            let specs: Vec<&ParamSpec> = self.hull_idx[d].iter().map(|&k| &self.specs[k]).collect();
            let w = data_w / self.scales[d];
            let a = Mat::from_fn(m + p, p, |row, col| {
                if row < m {
                    self.rows[idx[row]].0[d][col] * w
                } else if row - m == col {
                    lambda.sqrt() / specs[col].prior_sd
                } else {
                    0.0
                }
            });
            let b: Vec<f64> = (0..m)
                .map(|row| y[d][row] * w)
                .chain(specs.iter().map(|s| lambda.sqrt() * s.prior / s.prior_sd))
                .collect();
            let bounds = if self.bounded {
                Bounds::new(
                    specs.iter().map(|s| s.lower).collect(),
                    specs.iter().map(|s| s.upper).collect(),
                )
                .map_err(|e| failed(format!("mmg bounds: {e}")))?
            } else {
                Bounds::unbounded(p)
            };
            let est = if self.bounded {
                Estimator::BoundedLsq
            } else {
                Estimator::Lsq
            };
            let fit = shipid_estimators::fit(a.as_ref(), &b, &est, Some(&bounds), Solver::Fast)
                .map_err(|e| failed(format!("mmg hull derivatives: {e}")))?;
            for row in 0..m {
                let pred: f64 = (0..p).map(|c| a[(row, c)] * fit.coefficients[c]).sum();
                resid.push(b[row] - pred);
            }
            for (c, s) in specs.iter().enumerate() {
                prior_rows.push(lambda.sqrt() * (fit.coefficients[c] - s.prior) / s.prior_sd);
            }
            beta[d] = fit.coefficients;
        }
        resid.extend(prior_rows);
        for (k, &i) in self.nl_idx.iter().enumerate() {
            let s = &self.specs[i];
            resid.push(lambda.sqrt() * (phi[k] - s.prior) / s.prior_sd);
        }
        Ok((beta, resid))
    }

    fn clamp_phi(&self, phi: &mut [f64]) {
        for (k, &i) in self.nl_idx.iter().enumerate() {
            let s = &self.specs[i];
            phi[k] = phi[k].clamp(s.lower, s.upper);
        }
    }

    /// The prior centre of φ, inside the bounds.
    pub fn prior_phi(&self) -> Vec<f64> {
        let mut phi: Vec<f64> = self.nl_idx.iter().map(|&i| self.specs[i].prior).collect();
        self.clamp_phi(&mut phi);
        phi
    }

    /// Forward-difference step of φ_k, away from a bound it would cross.
    fn fd_step(&self, phi: &[f64], k: usize) -> f64 {
        let s = &self.specs[self.nl_idx[k]];
        let h = 1e-6 * s.prior_sd;
        if phi[k] + h > s.upper { -h } else { h }
    }

    /// Minimise J over φ (β solved inside) from `start`, on the samples `idx`. Returns φ, β and the
    /// outer iterations.
    pub fn solve(
        &self,
        start: &[f64],
        idx: &[usize],
        lambda: f64,
    ) -> Result<Solution, PipelineError> {
        const MAX_ITERATIONS: usize = 200;
        let mut phi = start.to_vec();
        self.clamp_phi(&mut phi);
        let (_, r) = self.inner(&phi, idx, lambda)?;
        let cost = r.iter().map(|x| x * x).sum();
        let mut at = LmPoint { p: phi, r, cost };
        let mut damping = 1e-3;
        let mut iterations = 0;
        let residuals = |q: &[f64]| -> Vec<f64> {
            self.inner(q, idx, lambda)
                .map(|(_, r)| r)
                .unwrap_or_else(|_| vec![f64::INFINITY])
        };
        while iterations < MAX_ITERATIONS {
            iterations += 1;
            let mut jac = Vec::with_capacity(at.p.len());
            for k in 0..at.p.len() {
                if self.specs[self.nl_idx[k]].is_held() {
                    jac.push(vec![0.0; at.r.len()]);
                    continue;
                }
                let h = self.fd_step(&at.p, k);
                let mut q = at.p.clone();
                q[k] += h;
                let rq = self.inner(&q, idx, lambda)?.1;
                jac.push(
                    rq.iter()
                        .zip(&at.r)
                        .map(|(a, b)| (a - b) / h)
                        .collect::<Vec<f64>>(),
                );
            }
            // Parameters on a bound whose gradient pushes them out are held there for this step.
            let grad: Vec<f64> = jac.iter().map(|j| dot(j, &at.r)).collect();
            for (k, j) in jac.iter_mut().enumerate() {
                let s = &self.specs[self.nl_idx[k]];
                let pushes_out =
                    (at.p[k] <= s.lower && grad[k] > 0.0) || (at.p[k] >= s.upper && grad[k] < 0.0);
                if pushes_out {
                    j.iter_mut().for_each(|x| *x = 0.0);
                }
            }
            let step = lm_step(
                &jac,
                &mut at,
                &mut damping,
                12,
                |q| self.clamp_phi(q),
                residuals,
            );
            match step {
                Some(rel) if rel > 1e-12 => {}
                _ => break,
            }
        }
        let (beta, _) = self.inner(&at.p, idx, lambda)?;
        Ok((at.p, beta, iterations))
    }

    /// Data cost Σ_dof Σ_i (e_i/s_dof)² / m of (φ, β) on the samples `idx` (the held-out score).
    pub fn data_cost(
        &self,
        phi: &[f64],
        beta: &[Vec<f64>; 3],
        idx: &[usize],
    ) -> Result<f64, PipelineError> {
        let y = self.hull_targets(phi, idx)?;
        let mut sum = 0.0;
        for d in 0..3 {
            for (row, &i) in idx.iter().enumerate() {
                let pred = dot(&self.rows[i].0[d], &beta[d]);
                sum += ((y[d][row] - pred) / self.scales[d]).powi(2);
            }
        }
        Ok(sum / idx.len().max(1) as f64)
    }

    /// Every parameter's estimate, standard error and data share at (φ, β) fitted on all samples.
    pub fn estimate(
        &self,
        phi: &[f64],
        beta: &[Vec<f64>; 3],
        lambda: f64,
        iterations: usize,
    ) -> Result<Estimate, PipelineError> {
        let all: Vec<usize> = (0..self.samples.len()).collect();
        let m = all.len();
        let theta = self.theta_of(phi, beta);
        let y = self.hull_targets(phi, &all)?;
        // Unweighted residuals ê = e/s_dof, stacked X, Y, N, and their Jacobian column by parameter.
        let mut resid = Vec::with_capacity(3 * m);
        for d in 0..3 {
            for (row, target) in self.rows.iter().zip(&y[d]) {
                resid.push((target - dot(&row.0[d], &beta[d])) / self.scales[d]);
            }
        }
        let p = self.specs.len();
        let mut jac = vec![vec![0.0; 3 * m]; p];
        for d in 0..3 {
            for (c, &k) in self.hull_idx[d].iter().enumerate() {
                for row in 0..m {
                    jac[k][d * m + row] = -self.rows[row].0[d][c] / self.scales[d];
                }
            }
        }
        for (k, &i) in self.nl_idx.iter().enumerate() {
            if self.specs[i].is_held() {
                continue;
            }
            let h = self.fd_step(phi, k);
            let mut q = phi.to_vec();
            q[k] += h;
            let yq = self.hull_targets(&q, &all)?;
            for d in 0..3 {
                for row in 0..m {
                    jac[i][d * m + row] = (yq[d][row] - y[d][row]) / (h * self.scales[d]);
                }
            }
        }
        let info: Vec<Vec<f64>> = (0..p)
            .map(|a| (0..p).map(|b| dot(&jac[a], &jac[b])).collect())
            .collect();
        let mut precision = info.clone();
        for (k, row) in precision.iter_mut().enumerate() {
            // A held parameter has no row in the data's information: known, it is decoupled.
            row[k] += if self.specs[k].is_held() {
                1.0
            } else {
                m as f64 * lambda / self.specs[k].prior_sd.powi(2)
            };
        }
        // Columns of the inverse precision, one small solve each.
        let mut inverse = vec![vec![0.0; p]; p];
        for k in 0..p {
            let mut e = vec![0.0; p];
            e[k] = 1.0;
            let col = solve_small(&precision, &e)
                .ok_or_else(|| failed("mmg: the posterior precision is singular"))?;
            for (row, v) in col.into_iter().enumerate() {
                inverse[row][k] = v;
            }
        }
        let share: Vec<f64> = (0..p)
            .map(|k| dot(&inverse[k], &(0..p).map(|j| info[j][k]).collect::<Vec<_>>()))
            .map(|s| s.clamp(0.0, 1.0))
            .collect();
        let dof_used: f64 = share.iter().sum();
        let sse: f64 = resid.iter().map(|x| x * x).sum();
        let tau2 = sse / ((3 * m) as f64 - dof_used).max(1.0);
        let mut residual_rms = [0.0; 3];
        for (d, out) in residual_rms.iter_mut().enumerate() {
            let ms = resid[d * m..(d + 1) * m].iter().map(|x| x * x).sum::<f64>() / m as f64;
            *out = ms.sqrt() * self.scales[d];
        }
        let params = self
            .specs
            .iter()
            .enumerate()
            .map(|(k, spec)| match spec.is_held() {
                // Determined by other data (the recorded thrust), whose standard error its prior
                // width carries.
                true => ParamEstimate {
                    spec: spec.clone(),
                    value: theta[k],
                    standard_error: spec.prior_sd,
                    data_share: 1.0,
                    determined_by_data: true,
                    at_bound: false,
                },
                false => {
                    let at_bound = theta[k] <= spec.lower || theta[k] >= spec.upper;
                    ParamEstimate {
                        spec: spec.clone(),
                        value: theta[k],
                        standard_error: (tau2 * inverse[k][k]).max(0.0).sqrt(),
                        data_share: share[k],
                        // A parameter on its bound is held there by the bound, not by the data:
                        // its share and standard error describe the problem without the bound.
                        determined_by_data: share[k] > DETERMINED_SHARE && !at_bound,
                        at_bound,
                    }
                }
            })
            .collect();
        Ok(Estimate {
            params,
            residual_rms,
            force_rms: self.scales,
            iterations,
        })
    }
}

/// MMG parameters from the identified ones (`get` by name), the known added masses (as MMG primes)
/// and the propeller and rudder data.
pub fn assemble(
    ship: &Ship,
    added: &AddedMass,
    geometry: &MmgGeometry,
    get: &dyn Fn(&str) -> f64,
) -> MmgParameters {
    let half_rho_l2_d = 0.5 * ship.rho * ship.lpp * ship.lpp * ship.draft;
    let g = geometry;
    let l = ship.lpp;
    MmgParameters {
        r0: get("r0"),
        x_vv: get("x_vv"),
        x_vr: get("x_vr"),
        x_rr: get("x_rr"),
        x_vvvv: get("x_vvvv"),
        y_v: get("y_v"),
        y_r: get("y_r"),
        y_vvv: get("y_vvv"),
        y_vvr: get("y_vvr"),
        y_vrr: get("y_vrr"),
        y_rrr: get("y_rrr"),
        n_v: get("n_v"),
        n_r: get("n_r"),
        n_vvv: get("n_vvv"),
        n_vvr: get("n_vvr"),
        n_vrr: get("n_vrr"),
        n_rrr: get("n_rrr"),
        m_x: -added.X_udot / half_rho_l2_d,
        m_y: -added.Y_vdot / half_rho_l2_d,
        j_z: -added.N_rdot / (half_rho_l2_d * l * l),
        propeller_diameter_m: g.propeller_diameter_m,
        t_p: get("t_p"),
        w_p0: get("w_p0"),
        k_t: g.k_t,
        x_p: g.propeller_x_m / l,
        c1: get("c1"),
        c2_pos: get("c2_pos"),
        c2_neg: get("c2_neg"),
        rudder_span_m: g.rudder_span_m,
        rudder_area_m2: g.rudder_area_m2,
        t_r: get("t_r"),
        a_h: get("a_h"),
        x_h: get("x_h"),
        x_r: g.rudder_x_m / l,
        epsilon: get("epsilon"),
        kappa: get("kappa"),
        l_r: get("l_r"),
        gamma_r_neg: get("gamma_r_neg"),
        gamma_r_pos: get("gamma_r_pos"),
        f_alpha: get("f_alpha"),
    }
}
