//! `Solver::Qp`: every estimator as a clarabel QP, in the scaled space (the reference).
//!
//! Least-squares family, with the Householder factor `‖Zγ − y‖² = ‖Aγ − c‖² + const`
//! (A = R, k = q rows, when n > q; A = Z otherwise) and the objective multiplied by n:
//!
//! ```text
//!   variables  x = [γ (q), ρ (k), t (q, Lasso only)]
//!   minimise   ½‖ρ‖² + (nλ/2)‖γ‖² + nα Σ t
//!   subject to Aγ − ρ = c                       (zero cone)
//!              γ − t ≤ 0, −γ − t ≤ 0            (Lasso)
//!              γ ≤ hi, −γ ≤ −lo                 (finite bounds only)
//! ```
//!
//! P stays diagonal, and the size does not depend on n: this layout solved in 0.5 ms
//! where one residual variable per sample took 180 ms (see `docs/benchmarks.md`).
//!
//! SVR, the primal as written in the paper (per-sample slacks ξ, ξ*):
//!
//! ```text
//!   variables  x = [γ (q), ξ (n), ξ* (n)]
//!   minimise   ½‖γ‖² + C Σ(ξ + ξ*)
//!   subject to yᵢ − zᵢγ ≤ ε + ξᵢ,  zᵢγ − yᵢ ≤ ε + ξ*ᵢ,  ξ, ξ* ≥ 0,  box on γ
//! ```

use clarabel::algebra::CscMatrix;
use clarabel::solver::{
    DefaultSettings, DefaultSolver, IPSolver, NonnegativeConeT, SolverStatus, SupportedConeT,
    ZeroConeT,
};

use crate::dense::linalg::col;
use crate::error::EstimatorError;
use crate::problem::Problem;
use crate::solvers::solution::Solution;
use crate::types::{Estimator, Status};

/// Triplet lists in clarabel's `Ax + s = b` convention.
#[derive(Default)]
struct Triplets {
    rows: Vec<usize>,
    cols: Vec<usize>,
    vals: Vec<f64>,
}

impl Triplets {
    fn push(&mut self, r: usize, c: usize, v: f64) {
        if v != 0.0 {
            self.rows.push(r);
            self.cols.push(c);
            self.vals.push(v);
        }
    }

    fn into_csc(self, m: usize, n: usize) -> CscMatrix<f64> {
        CscMatrix::new_from_triplets(m, n, self.rows, self.cols, self.vals)
    }
}

fn push_bounds(a: &mut Triplets, b: &mut Vec<f64>, row: &mut usize, lo: &[f64], hi: &[f64]) {
    for (j, (&l, &h)) in lo.iter().zip(hi).enumerate() {
        if h.is_finite() {
            a.push(*row, j, 1.0);
            b.push(h);
            *row += 1;
        }
        if l.is_finite() {
            a.push(*row, j, -1.0);
            b.push(-l);
            *row += 1;
        }
    }
}

fn map_status(status: SolverStatus) -> Status {
    match status {
        SolverStatus::Solved => Status::Ok,
        SolverStatus::AlmostSolved => Status::ReducedAccuracy,
        SolverStatus::MaxIterations | SolverStatus::MaxTime => Status::MaxIterations,
        other => Status::SolverFailed(format!("clarabel: {other:?}")),
    }
}

struct QpData {
    /// γ = `gamma_scale` × (the first q solver variables).
    gamma_scale: f64,
    /// Tighter than clarabel's defaults (1e-8). Least squares: the compressed objective
    /// leaves out the constant part of the residual, so its gap tolerance must be finer to
    /// give J to about 1e-9 relative. SVR: J is evaluated on the returned γ with the exact
    /// hinge, which a feasibility error δ in γ moves by up to C·Σ|zᵢδ|; at large C the
    /// defaults left J 1.3e-6 above the optimum (the case pinned in
    /// tests/agreement.proptest-regressions).
    tight: bool,
    nvar: usize,
    p: CscMatrix<f64>,
    q: Vec<f64>,
    a: CscMatrix<f64>,
    b: Vec<f64>,
    cones: Vec<SupportedConeT<f64>>,
}

fn run(data: QpData, q_gamma: usize, fallback: Vec<f64>) -> Solution {
    let mut settings = DefaultSettings::<f64> {
        verbose: false,
        ..DefaultSettings::default()
    };
    if data.tight {
        settings.tol_gap_abs = 1e-12;
        settings.tol_gap_rel = 1e-11;
        settings.tol_feas = 1e-10;
    }
    let mut solver =
        match DefaultSolver::new(&data.p, &data.q, &data.a, &data.b, &data.cones, settings) {
            Ok(s) => s,
            Err(e) => {
                return Solution {
                    gamma: fallback,
                    status: Status::SolverFailed(format!("clarabel setup: {e}")),
                    iterations: 0,
                };
            }
        };
    solver.solve();
    let sol = &solver.solution;
    debug_assert_eq!(sol.x.len(), data.nvar);
    let gamma: Vec<f64> = sol.x[..q_gamma]
        .iter()
        .map(|v| v * data.gamma_scale)
        .collect();
    let finite = gamma.iter().all(|v| v.is_finite());
    let status = if finite {
        map_status(sol.status)
    } else {
        Status::SolverFailed(format!("clarabel: non-finite solution ({:?})", sol.status))
    };
    Solution {
        gamma: if finite { gamma } else { fallback },
        status,
        iterations: sol.iterations as usize,
    }
}

pub(crate) fn solve(
    pb: &Problem,
    estimator: &Estimator,
    lo: &[f64],
    hi: &[f64],
) -> Result<Solution, EstimatorError> {
    let q = pb.q();
    let origin: Vec<f64> = (0..q).map(|j| 0.0f64.clamp(lo[j], hi[j])).collect();
    match *estimator {
        Estimator::Svr { c, epsilon } => {
            if c == 0.0 {
                return Ok(Solution {
                    gamma: origin,
                    status: Status::Ok,
                    iterations: 0,
                });
            }
            Ok(run(svr_data(pb, c, epsilon, lo, hi), q, origin))
        }
        Estimator::Lsq | Estimator::BoundedLsq => Ok(run(ls_data(pb, 0.0, 0.0, lo, hi), q, origin)),
        Estimator::Ridge { lambda } => Ok(run(ls_data(pb, lambda, 0.0, lo, hi), q, origin)),
        Estimator::Lasso { alpha } => Ok(run(ls_data(pb, 0.0, alpha, lo, hi), q, origin)),
    }
}

fn ls_data(pb: &Problem, lambda: f64, alpha: f64, lo: &[f64], hi: &[f64]) -> QpData {
    let q = pb.q();
    let n = pb.n as f64;
    let ls = pb.reference_ls();
    // Solve for γ' = γ/σ with σ = ‖y‖, which makes the objective O(1) whatever the units
    // of y, so that clarabel's absolute gap tolerance means the same on every data set.
    let sigma = {
        let s = pb.y.iter().map(|v| v * v).sum::<f64>().sqrt();
        if s > 0.0 { s } else { 1.0 }
    };
    let lo: Vec<f64> = lo.iter().map(|v| v / sigma).collect();
    let hi: Vec<f64> = hi.iter().map(|v| v / sigma).collect();
    let k = ls.a.nrows();
    let lasso = alpha > 0.0;
    let nvar = q + k + if lasso { q } else { 0 };

    let mut p = Triplets::default();
    for j in 0..q {
        p.push(j, j, n * lambda);
    }
    for i in 0..k {
        p.push(q + i, q + i, 1.0);
    }
    let mut lin = vec![0.0; nvar];
    if lasso {
        for v in &mut lin[q + k..] {
            *v = n * alpha / sigma;
        }
    }

    let mut a = Triplets::default();
    let mut b = Vec::new();
    for i in 0..k {
        for j in 0..q {
            a.push(i, j, ls.a[(i, j)]);
        }
        a.push(i, q + i, -1.0);
        b.push(ls.c[i] / sigma);
    }
    let mut row = k;
    if lasso {
        for j in 0..q {
            a.push(row, j, 1.0);
            a.push(row, q + k + j, -1.0);
            b.push(0.0);
            a.push(row + 1, j, -1.0);
            a.push(row + 1, q + k + j, -1.0);
            b.push(0.0);
            row += 2;
        }
    }
    push_bounds(&mut a, &mut b, &mut row, &lo, &hi);
    let mut cones = vec![ZeroConeT(k)];
    if row > k {
        cones.push(NonnegativeConeT(row - k));
    }
    QpData {
        gamma_scale: sigma,
        tight: true,
        nvar,
        p: p.into_csc(nvar, nvar),
        q: lin,
        a: a.into_csc(row, nvar),
        b,
        cones,
    }
}

fn svr_data(pb: &Problem, c: f64, eps: f64, lo: &[f64], hi: &[f64]) -> QpData {
    let q = pb.q();
    let n = pb.n;
    let nvar = q + 2 * n;
    let mut p = Triplets::default();
    for j in 0..q {
        p.push(j, j, 1.0);
    }
    let mut lin = vec![c; nvar];
    for v in &mut lin[..q] {
        *v = 0.0;
    }
    let mut a = Triplets::default();
    let mut b = Vec::with_capacity(4 * n + 2 * q);
    for j in 0..q {
        let zj = col(&pb.z, j);
        for (i, &zij) in zj.iter().enumerate() {
            // −zᵢγ − ξᵢ ≤ ε − yᵢ  and  zᵢγ − ξ*ᵢ ≤ ε + yᵢ
            a.push(i, j, -zij);
            a.push(n + i, j, zij);
        }
    }
    for i in 0..n {
        a.push(i, q + i, -1.0);
        a.push(n + i, q + n + i, -1.0);
        a.push(2 * n + i, q + i, -1.0);
        a.push(3 * n + i, q + n + i, -1.0);
    }
    for i in 0..n {
        b.push(eps - pb.y[i]);
    }
    for i in 0..n {
        b.push(eps + pb.y[i]);
    }
    b.extend(std::iter::repeat_n(0.0, 2 * n));
    let mut row = 4 * n;
    push_bounds(&mut a, &mut b, &mut row, lo, hi);
    QpData {
        gamma_scale: 1.0,
        tight: true,
        nvar,
        p: p.into_csc(nvar, nvar),
        q: lin,
        a: a.into_csc(row, nvar),
        b,
        cones: vec![NonnegativeConeT(row)],
    }
}
