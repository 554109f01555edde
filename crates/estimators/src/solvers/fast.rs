//! `Solver::Fast`: special-purpose solvers in the scaled space (q = number of non-zero
//! columns).
//!
//! * LSQ: corrected semi-normal equations when the Gram eigenvalues put κ(Z) ≤ 1e5;
//!   otherwise one QR (CholeskyQR2 when provably accurate, Householder otherwise) and a
//!   triangular solve; SVD minimum-norm solution when R is numerically singular.
//! * Ridge: Cholesky of `G + λI` (G = ZᵀZ/n) while `κ(G + λI) ≤ (q + λ)/λ ≤ 1e10`; below
//!   that λ the normal equations would lose too many digits and the QR of `[R; √(nλ) I]`
//!   is used instead.
//! * Bounded LSQ: the semi-normal solution when it lies inside the box (then it is the
//!   bounded minimiser too), otherwise:
//! * Bounds and the ℓ1 penalty: the exact active-set method of [`crate::solvers::active_set`],
//!   least-squares mode (QR of R's free columns) for bounded LSQ, Gram mode for Lasso and
//!   bounded Ridge, with a least-squares-mode rerun when a Lasso face was singular.
//! * SVR: [`crate::solvers::svr`].

use faer::Mat;

use crate::dense::linalg::{
    LsFactor, SmallQr, cholesky, cholesky_solve, gram, min_norm_lstsq, residual, zt_v,
};
use crate::error::EstimatorError;
use crate::problem::Problem;
use crate::solvers::active_set::{self, BoxL1};
use crate::solvers::solution::{Solution, is_unbounded, max_active_set_iterations};
use crate::types::{Estimator, Status};

pub(crate) fn solve(
    pb: &Problem,
    estimator: &Estimator,
    lo: &[f64],
    hi: &[f64],
) -> Result<Solution, EstimatorError> {
    match *estimator {
        Estimator::Lsq | Estimator::BoundedLsq => lsq(pb, lo, hi),
        Estimator::Ridge { lambda: 0.0 } => lsq(pb, lo, hi),
        Estimator::Ridge { lambda } => ridge(pb, lambda, lo, hi),
        Estimator::Lasso { alpha: 0.0 } => lsq(pb, lo, hi),
        Estimator::Lasso { alpha } => lasso(pb, alpha, lo, hi),
        Estimator::Svr { c, epsilon } => crate::solvers::svr::solve(pb, c, epsilon, lo, hi),
    }
}

/// Unconstrained least-squares solution of `A x ≈ c`: back substitution when A is a
/// non-singular triangular R, SVD minimum-norm solution otherwise.
fn unconstrained_ls(pb: &Problem, ls: &LsFactor) -> Result<Vec<f64>, EstimatorError> {
    let q = pb.q();
    let triangular = pb.n > q;
    if triangular {
        let a = &ls.a;
        let dmax = (0..q).map(|j| a[(j, j)].abs()).fold(0.0, f64::max);
        let dmin = (0..q)
            .map(|j| a[(j, j)].abs())
            .fold(f64::INFINITY, f64::min);
        if dmin > 1e3 * q as f64 * f64::EPSILON * dmax {
            let mut x = ls.c.clone();
            for i in (0..q).rev() {
                let mut s = x[i];
                for j in i + 1..q {
                    s -= a[(i, j)] * x[j];
                }
                x[i] = s / a[(i, i)];
            }
            return Ok(x);
        }
    }
    min_norm_lstsq(ls.a.as_ref(), &ls.c)
}

fn outcome_status(converged: bool) -> Status {
    if converged {
        Status::Ok
    } else {
        Status::MaxIterations
    }
}

/// Runs the active-set method in least-squares mode on `½‖Ax − c‖² + α_ls‖x‖₁`.
fn ls_active_set(
    a: &Mat<f64>,
    c: &[f64],
    alpha_ls: f64,
    lo: &[f64],
    hi: &[f64],
    x0: &[f64],
) -> Solution {
    let h = gram(a.as_ref());
    let b: Vec<f64> = (0..a.ncols())
        .map(|j| (0..a.nrows()).map(|i| a[(i, j)] * c[i]).sum())
        .collect();
    let prob = BoxL1 {
        h: h.as_ref(),
        b: &b,
        alpha: alpha_ls,
        lo,
        hi,
        ls: Some((a, c)),
        chol_rel_tol: 1e-14,
    };
    let out = active_set::solve(&prob, x0, max_active_set_iterations(a.ncols()));
    Solution {
        gamma: out.x,
        status: outcome_status(out.converged),
        iterations: out.iterations,
    }
}

fn lsq(pb: &Problem, lo: &[f64], hi: &[f64]) -> Result<Solution, EstimatorError> {
    // An unconstrained minimiser inside the box is the bounded one too (the usual case for
    // sign bounds on these designs), so bounded LSQ tries the cheap path first as well.
    if pb.n > pb.q()
        && let Some(x) = seminormal_lsq(pb)?
        && x.iter()
            .zip(lo.iter().zip(hi))
            .all(|(v, (l, h))| l <= v && v <= h)
    {
        return Ok(Solution {
            gamma: x,
            status: Status::Ok,
            iterations: 2,
        });
    }
    let ls = pb.fast_ls();
    let x0 = unconstrained_ls(pb, ls)?;
    if is_unbounded(lo, hi) {
        return Ok(Solution {
            gamma: x0,
            status: Status::Ok,
            iterations: 1,
        });
    }
    Ok(ls_active_set(&ls.a, &ls.c, 0.0, lo, hi, &x0))
}

/// Unbounded LSQ from the Gram matrix alone when that is accurate: Cholesky of
/// `G = ZᵀZ/n` plus one step of iterative refinement on the true residual (corrected
/// semi-normal equations, Björck 1987). With κ(Z) ≤ 1e5 the first solve carries a relative
/// error of at most κ²ε ≈ 1e-6, which the refinement step squares away, so the result is
/// as accurate as a QR solution at a third of the cost (one Gram product instead of
/// CholeskyQR2's three). `None` for worse-conditioned designs, which go through QR.
fn seminormal_lsq(pb: &Problem) -> Result<Option<Vec<f64>>, EstimatorError> {
    let (emin, emax) = pb.gram_extremes()?;
    if emin.is_nan() || emin <= 1e-10 * emax {
        return Ok(None);
    }
    let gd = pb.gram();
    let Some(l) = cholesky(gd.g.as_ref(), 0.0) else {
        return Ok(None);
    };
    let mut x = gd.b.clone();
    cholesky_solve(&l, &mut x);
    let r = residual(&pb.z, &pb.y, &x);
    let inv_n = 1.0 / pb.n as f64;
    let mut dx: Vec<f64> = zt_v(&pb.z, &r).into_iter().map(|v| v * inv_n).collect();
    cholesky_solve(&l, &mut dx);
    for (xi, d) in x.iter_mut().zip(&dx) {
        *xi += d;
    }
    Ok(Some(x))
}

fn ridge(pb: &Problem, lambda: f64, lo: &[f64], hi: &[f64]) -> Result<Solution, EstimatorError> {
    let q = pb.q();
    let unbounded = is_unbounded(lo, hi);
    if lambda >= 1e-10 * q as f64 {
        let gd = pb.gram();
        let h = Mat::<f64>::from_fn(q, q, |i, j| {
            gd.g[(i, j)] + if i == j { lambda } else { 0.0 }
        });
        if let Some(l) = cholesky(h.as_ref(), 0.0) {
            let mut x = gd.b.clone();
            cholesky_solve(&l, &mut x);
            if unbounded {
                return Ok(Solution {
                    gamma: x,
                    status: Status::Ok,
                    iterations: 1,
                });
            }
            let prob = BoxL1 {
                h: h.as_ref(),
                b: &gd.b,
                alpha: 0.0,
                lo,
                hi,
                ls: None,
                chol_rel_tol: 0.0,
            };
            let out = active_set::solve(&prob, &x, max_active_set_iterations(q));
            return Ok(Solution {
                gamma: out.x,
                status: outcome_status(out.converged),
                iterations: out.iterations,
            });
        }
    }
    // Tiny λ: ½‖Aγ − c‖² + (nλ/2)‖γ‖² = ½‖[A; √(nλ) I]γ − [c; 0]‖².
    let ls = pb.fast_ls();
    let k = ls.a.nrows();
    let root = (pb.n as f64 * lambda).sqrt();
    let a_aug = Mat::<f64>::from_fn(k + q, q, |i, j| {
        if i < k {
            ls.a[(i, j)]
        } else if i - k == j {
            root
        } else {
            0.0
        }
    });
    let mut c_aug = ls.c.clone();
    c_aug.resize(k + q, 0.0);
    let qr = SmallQr::new(a_aug.clone());
    let x0 = if qr.is_full_rank(1e-15) {
        let mut x = c_aug.clone();
        qr.apply_qt(&mut x);
        x.truncate(q);
        qr.solve_r(&mut x);
        x
    } else {
        min_norm_lstsq(a_aug.as_ref(), &c_aug)?
    };
    if unbounded {
        return Ok(Solution {
            gamma: x0,
            status: Status::Ok,
            iterations: 1,
        });
    }
    Ok(ls_active_set(&a_aug, &c_aug, 0.0, lo, hi, &x0))
}

fn lasso(pb: &Problem, alpha: f64, lo: &[f64], hi: &[f64]) -> Result<Solution, EstimatorError> {
    let q = pb.q();
    let gd = pb.gram();
    let prob = BoxL1 {
        h: gd.g.as_ref(),
        b: &gd.b,
        alpha,
        lo,
        hi,
        ls: None,
        chol_rel_tol: 1e-14,
    };
    // Starting from zero adds coordinates in order of usefulness, which is what makes
    // the active-set method cheap for sparse Lasso solutions.
    let out = active_set::solve(&prob, &vec![0.0; q], max_active_set_iterations(q));
    if out.singular_faces == 0 {
        return Ok(Solution {
            gamma: out.x,
            status: outcome_status(out.converged),
            iterations: out.iterations,
        });
    }
    // Some face was numerically singular in the Gram form: finish in least-squares form,
    // ½‖Aγ − c‖² + nα‖γ‖₁ (the objective times n), from the Gram solution.
    let ls = pb.fast_ls();
    let mut sol = ls_active_set(&ls.a, &ls.c, pb.n as f64 * alpha, lo, hi, &out.x);
    sol.iterations += out.iterations;
    Ok(sol)
}
