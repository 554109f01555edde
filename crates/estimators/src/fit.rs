//! The `fit` entry point, the objective evaluator and the status logic shared by both
//! solver families.

use faer::{Mat, MatRef};

use crate::dense::kernels;
use crate::dense::linalg::col_of;
use crate::dense::linalg::{
    condition_from_singular_values, singular_values, sym_eig_extremes, sym_eig_min_vector,
};
use crate::error::EstimatorError;
use crate::params::{CheckedParams, Params};
use crate::problem::{
    Problem, check_coefficients, column_scales, validate_design, validate_problem_data,
};
use crate::solvers::direct;
use crate::solvers::fast;
use crate::solvers::qp;
use crate::solvers::solution::Solution;
use crate::types::{Bounds, Estimator, Fit, Solver, Status, status_from};

/// Fits one degree of freedom: `y ≈ Φβ` with the given estimator, optional bounds on the
/// unscaled coefficients, and solver family: [`Params::check`] and [`CheckedParams::fit`]
/// in one call.
///
/// Errors are returned only for invalid input (empty design, length mismatches, NaN or
/// infinite values, invalid bounds or hyper-parameters); how the solve went is in
/// [`Fit::status`].
pub fn fit(
    design: MatRef<'_, f64>,
    y: &[f64],
    estimator: &Estimator,
    bounds: Option<&Bounds>,
    solver: Solver,
) -> Result<Fit, EstimatorError> {
    let params = Params {
        estimator: *estimator,
        bounds: bounds.cloned(),
        solver,
    };
    match params.check() {
        Ok(checked) => checked.fit(design, y),
        Err(e @ EstimatorError::InvalidHyperParameter { .. }) => Err(e),
        // This entry point has always judged the bounds after the data, and their lengths
        // against the design before their pairs: a call with several faults still reports
        // the one it reported before the checked parameters existed.
        Err(e) => {
            validate_problem_data(design, y)?;
            Err(bounds
                .and_then(|b| b.validate(design.ncols()).err())
                .unwrap_or(e))
        }
    }
}

impl CheckedParams {
    /// Fits one degree of freedom with these settings (see [`fit`]); the data are checked
    /// here, the settings were checked by [`Params::check`].
    pub fn fit(&self, design: MatRef<'_, f64>, y: &[f64]) -> Result<Fit, EstimatorError> {
        let estimator = self.estimator();
        if self.solver() == Solver::Fast
            && matches!(
                estimator,
                Estimator::Lsq
                    | Estimator::BoundedLsq
                    | Estimator::Ridge { lambda: 0.0 }
                    | Estimator::Lasso { alpha: 0.0 }
            )
            && let Some(result) = direct::try_lsq(design, y, self)
        {
            return result;
        }
        let pb = Problem::new(design, y)?;
        self.check_columns(pb.p)?;
        let mut f = fit_problem(&pb, self)?;
        if !matches!(estimator, Estimator::Svr { .. }) {
            // The same evaluation as `objective()`, so that the two agree to the last bit
            // on this path (the direct path's J agrees to rounding).
            f.objective = ls_objective(design, y, estimator, &f.coefficients, &pb.scales);
        }
        Ok(f)
    }
}

/// `(1/2n)‖y − Φβ‖²` on the raw design, by the same kernel as the direct LSQ path.
pub(crate) fn half_mse_raw(design: MatRef<'_, f64>, y: &[f64], beta: &[f64]) -> f64 {
    let columns: Vec<std::borrow::Cow<'_, [f64]>> =
        (0..design.ncols()).map(|j| col_of(design, j)).collect();
    let cols: Vec<&[f64]> = columns.iter().map(|c| c.as_ref()).collect();
    0.5 * kernels::residual_norm(&cols, y, beta) / y.len() as f64
}

/// The objective of a least-squares-family estimator at the unscaled `beta`, penalties on
/// `γ_j = s_j β_j`.
fn ls_objective(
    design: MatRef<'_, f64>,
    y: &[f64],
    estimator: &Estimator,
    beta: &[f64],
    scales: &[f64],
) -> f64 {
    let half_mse = half_mse_raw(design, y, beta);
    let gamma = beta.iter().zip(scales).map(|(b, s)| b * s);
    match *estimator {
        Estimator::Ridge { lambda } => half_mse + 0.5 * lambda * gamma.map(|g| g * g).sum::<f64>(),
        Estimator::Lasso { alpha } => half_mse + alpha * gamma.map(|g| g.abs()).sum::<f64>(),
        _ => half_mse,
    }
}

/// `fit` on an already validated problem (the bounds' length checked against it).
pub(crate) fn fit_problem(pb: &Problem, params: &CheckedParams) -> Result<Fit, EstimatorError> {
    let (estimator, bounds, solver) = (params.estimator(), params.bounds(), params.solver());
    let (lo, hi) = pb.scaled_bounds(bounds);
    let sol = if pb.q() == 0 {
        Solution {
            gamma: Vec::new(),
            status: Status::Ok,
            iterations: 0,
        }
    } else {
        match solver {
            Solver::Fast => fast::solve(pb, estimator, &lo, &hi)?,
            Solver::Qp => qp::solve(pb, estimator, &lo, &hi)?,
        }
    };
    let coefficients = pb.unscale(&sol.gamma, bounds);
    let objective = pb.objective(estimator, &coefficients);
    let condition_number = effective_condition(pb, estimator, &sol.gamma, &lo, &hi)?;
    // A zero column is left out of the solve and of the condition number, so neither
    // would show that the data say nothing about its coefficient.
    let status = match sol.status {
        Status::Ok if !pb.zero_columns.is_empty() => Status::RankDeficient {
            zero_columns: pb.zero_columns.clone(),
        },
        s => status_from(s, condition_number),
    };
    Ok(Fit {
        coefficients,
        objective,
        status,
        iterations: sol.iterations,
        solver,
        estimator: *estimator,
        condition_number,
        zero_columns: pb.zero_columns.clone(),
    })
}

/// Condition number the status is judged on (see [`Fit::condition_number`]).
fn effective_condition(
    pb: &Problem,
    estimator: &Estimator,
    gamma: &[f64],
    lo: &[f64],
    hi: &[f64],
) -> Result<Option<f64>, EstimatorError> {
    let (lambda, lasso) = match *estimator {
        Estimator::Svr { .. } => return Ok(None),
        Estimator::Ridge { lambda } => (lambda, false),
        Estimator::Lasso { alpha } => (0.0, alpha > 0.0),
        Estimator::Lsq | Estimator::BoundedLsq => (0.0, false),
    };
    let gmax = gamma.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    // Interior-point solutions approach bounds and zeros only to within the solver
    // tolerance, hence the relative margin.
    let free: Vec<usize> = (0..gamma.len())
        .filter(|&j| {
            let at = |b: f64| b.is_finite() && (gamma[j] - b).abs() <= 1e-8 * gmax.max(b.abs());
            let zero = lasso && gamma[j].abs() <= 1e-8 * gmax;
            !(at(lo[j]) || at(hi[j]) || zero)
        })
        .collect();
    if free.is_empty() {
        return Ok(Some(1.0));
    }
    let k = free.len();
    if lambda > 0.0 || lasso || !pb.has_ls() {
        // The Gram eigenvalues resolve κ(Z_F) reliably up to about 1e4, a Rayleigh quotient
        // on Z_F up to 1e6; beyond that the singular values of the least-squares factor
        // decide.
        let (emin, emax) = if k == pb.q() {
            pb.gram_extremes()?
        } else {
            let g = &pb.gram().g;
            let gff = Mat::<f64>::from_fn(k, k, |r, t| g[(free[r], free[t])]);
            sym_eig_extremes(gff.as_ref())?
        };
        if emin > 1e-8 * emax {
            return Ok(Some(((emax + lambda) / (emin + lambda)).sqrt()));
        }
        if emin > 1e-12 * emax {
            // κ(Z_F) up to 1e6 without a QR and an SVD of the design (which cost more than
            // the least-squares solve itself): the Gram's smallest eigenvalue carries an
            // absolute error of about ε·λ_max, but the Rayleigh quotient ‖Z_F v‖²/n of its
            // eigenvector v, evaluated on Z_F itself, is accurate to about (ε·κ(G))²
            // relative, since v's error is orthogonal to v to first order.
            let g = &pb.gram().g;
            let gff = Mat::<f64>::from_fn(k, k, |r, t| g[(free[r], free[t])]);
            let (_, emax, v) = sym_eig_min_vector(gff.as_ref())?;
            let mut zv = vec![0.0; pb.n];
            for (t, &j) in free.iter().enumerate() {
                let vt = v[t];
                for (o, &x) in zv.iter_mut().zip(pb.z.col(j)) {
                    *o += vt * x;
                }
            }
            let rq = zv.iter().map(|x| x * x).sum::<f64>() / pb.n as f64;
            return Ok(Some(((emax + lambda) / (rq + lambda)).sqrt()));
        }
    }
    let ls = pb.any_ls();
    let af = Mat::<f64>::from_fn(ls.a.nrows(), k, |i, t| ls.a[(i, free[t])]);
    let s = singular_values(af.as_ref())?;
    if lambda == 0.0 {
        return Ok(Some(condition_from_singular_values(&s, k)));
    }
    let n = pb.n as f64;
    let smax = s.first().copied().unwrap_or(0.0);
    let smin = if s.len() < k { 0.0 } else { s[s.len() - 1] };
    Ok(Some(
        ((smax * smax / n + lambda) / (smin * smin / n + lambda)).sqrt(),
    ))
}

/// The documented objective of `estimator` (see [`Estimator`]) at the unscaled
/// coefficients `beta`, whatever their origin. Bounds are constraints, not part of it.
pub fn objective(
    design: MatRef<'_, f64>,
    y: &[f64],
    estimator: &Estimator,
    beta: &[f64],
) -> Result<f64, EstimatorError> {
    estimator.validate()?;
    if let Estimator::Svr { .. } = estimator {
        let pb = Problem::new(design, y)?;
        check_coefficients(beta, pb.p)?;
        return Ok(pb.objective(estimator, beta));
    }
    validate_problem_data(design, y)?;
    check_coefficients(beta, design.ncols())?;
    let scales = match estimator {
        Estimator::Ridge { .. } | Estimator::Lasso { .. } => column_scales(design)?,
        _ => Vec::new(),
    };
    Ok(ls_objective(design, y, estimator, beta, &scales))
}

/// `Φβ`.
pub fn predict(design: MatRef<'_, f64>, beta: &[f64]) -> Result<Vec<f64>, EstimatorError> {
    validate_design(design)?;
    check_coefficients(beta, design.ncols())?;
    let mut out = vec![0.0; design.nrows()];
    for (j, &b) in beta.iter().enumerate() {
        if b != 0.0 {
            for (o, &x) in out.iter_mut().zip(design.col(j).iter()) {
                *o += b * x;
            }
        }
    }
    Ok(out)
}
