//! Exact primal active-set method for the p-dimensional problem
//!
//! ```text
//!     min_x  ½ xᵀHx − bᵀx + α‖x‖₁    s.t.  lo ≤ x ≤ hi,      H ⪰ 0 (q × q)
//! ```
//!
//! which covers bounded LSQ, bounded Ridge, Lasso (with or without bounds) and the box-QP
//! Newton steps of the SVR solver. Every coordinate is either *fixed* (at a bound, or at
//! zero when α > 0) or *free* on one sign piece, where the objective is a smooth quadratic.
//! Each iteration minimises over the free coordinates (the "face"), walks towards that
//! minimiser until a free coordinate reaches the edge of its piece (it becomes fixed), and
//! at a face minimiser releases the fixed coordinate whose one-sided directional
//! derivative is most negative. With q ≲ 50 every face solve is a few microseconds, and the
//! method ends at an exact KKT point — unlike coordinate descent, whose convergence rate
//! degrades with the condition number of H (κ up to 1e12 on Abkowitz designs).
//!
//! Face systems are solved either from H by Cholesky ("Gram mode") or, when a
//! least-squares factor `H = AᵀA, b = Aᵀc` is supplied, by a QR of the free columns of A
//! ("least-squares mode"), whose error grows with κ(A) instead of κ(A)².

use faer::{Mat, MatRef};

use crate::dense::linalg::{SmallQr, cholesky, cholesky_solve};

/// The problem data. `ls`, when given, must satisfy `H = AᵀA` and `b = Aᵀc`.
pub(crate) struct BoxL1<'a> {
    pub(crate) h: MatRef<'a, f64>,
    pub(crate) b: &'a [f64],
    pub(crate) alpha: f64,
    pub(crate) lo: &'a [f64],
    pub(crate) hi: &'a [f64],
    pub(crate) ls: Option<(&'a Mat<f64>, &'a [f64])>,
    /// Relative pivot tolerance of the Gram-mode Cholesky (see [`cholesky`]).
    pub(crate) chol_rel_tol: f64,
}

pub(crate) struct Outcome {
    pub(crate) x: Vec<f64>,
    pub(crate) iterations: usize,
    pub(crate) converged: bool,
    /// Number of face systems that were numerically singular and were solved with a
    /// small diagonal shift instead.
    pub(crate) singular_faces: usize,
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum State {
    Lower,
    Upper,
    Zero,
    /// Free on the piece with this sign (`0.0` when α = 0: no sign pieces).
    Free(f64),
}

impl BoxL1<'_> {
    fn dim(&self) -> usize {
        self.b.len()
    }

    /// The sign-piece interval of a free coordinate.
    fn piece(&self, j: usize, sign: f64) -> (f64, f64) {
        if sign > 0.0 {
            (self.lo[j].max(0.0), self.hi[j])
        } else if sign < 0.0 {
            (self.lo[j], self.hi[j].min(0.0))
        } else {
            (self.lo[j], self.hi[j])
        }
    }

    fn gradient(&self, x: &[f64]) -> Vec<f64> {
        let q = self.dim();
        (0..q)
            .map(|i| {
                let mut s = -self.b[i];
                for (j, &xj) in x.iter().enumerate() {
                    s += self.h[(i, j)] * xj;
                }
                s
            })
            .collect()
    }

    /// Minimiser over the free coordinates `free` (with signs) with the others fixed.
    /// Returns the solution and whether the face system was singular.
    fn face_solve(
        &self,
        x: &[f64],
        free: &[usize],
        signs: &[f64],
        fixed: &[usize],
    ) -> (Vec<f64>, bool) {
        let k = free.len();
        if let Some((a, c)) = self.ls {
            // min ½‖A_F x_F − (c − A_B x_B)‖² + α s_Fᵀ x_F.
            let m = a.nrows();
            if m >= k {
                let mut rt = c.to_vec();
                for &j in fixed {
                    if x[j] != 0.0 {
                        for (i, ri) in rt.iter_mut().enumerate() {
                            *ri -= a[(i, j)] * x[j];
                        }
                    }
                }
                let af = Mat::<f64>::from_fn(m, k, |i, t| a[(i, free[t])]);
                let qr = SmallQr::new(af);
                if qr.is_full_rank(1e-13) {
                    qr.apply_qt(&mut rt);
                    rt.truncate(k);
                    if self.alpha != 0.0 {
                        let mut w: Vec<f64> = signs.iter().map(|s| self.alpha * s).collect();
                        qr.solve_rt(&mut w);
                        for (r, wi) in rt.iter_mut().zip(&w) {
                            *r -= wi;
                        }
                    }
                    qr.solve_r(&mut rt);
                    debug_assert_eq!(qr.ncols(), k);
                    return (rt, false);
                }
            }
        }
        let mut rhs: Vec<f64> = free
            .iter()
            .zip(signs)
            .map(|(&i, &s)| {
                let mut v = self.b[i] - self.alpha * s;
                for &j in fixed {
                    v -= self.h[(i, j)] * x[j];
                }
                v
            })
            .collect();
        let hff = Mat::<f64>::from_fn(k, k, |r, t| self.h[(free[r], free[t])]);
        if let Some(l) = cholesky(hff.as_ref(), self.chol_rel_tol) {
            cholesky_solve(&l, &mut rhs);
            return (rhs, false);
        }
        // Numerically singular face: a small shift still gives a descent direction, and
        // the ratio test below keeps the iterate feasible.
        let maxdiag = (0..k)
            .map(|r| hff[(r, r)].abs())
            .fold(0.0, f64::max)
            .max(f64::MIN_POSITIVE);
        let mut shift = 1e-12 * maxdiag;
        loop {
            let hs =
                Mat::<f64>::from_fn(k, k, |r, t| hff[(r, t)] + if r == t { shift } else { 0.0 });
            if let Some(l) = cholesky(hs.as_ref(), 0.0) {
                cholesky_solve(&l, &mut rhs);
                return (rhs, true);
            }
            shift *= 100.0;
            if shift > 1e6 * maxdiag {
                // Cannot happen for finite symmetric input; stay put rather than panic.
                return (free.iter().map(|&j| x[j]).collect(), true);
            }
        }
    }
}

/// Runs the active-set method from `x0` (projected onto the box).
pub(crate) fn solve(p: &BoxL1<'_>, x0: &[f64], max_iter: usize) -> Outcome {
    let q = p.dim();
    let use_signs = p.alpha > 0.0;
    let mut x: Vec<f64> = (0..q).map(|j| x0[j].clamp(p.lo[j], p.hi[j])).collect();
    let mut state: Vec<State> = (0..q)
        .map(|j| {
            if x[j] == p.lo[j] {
                State::Lower
            } else if x[j] == p.hi[j] {
                State::Upper
            } else if use_signs && x[j] == 0.0 {
                State::Zero
            } else if use_signs {
                State::Free(x[j].signum())
            } else {
                State::Free(0.0)
            }
        })
        .collect();

    let bmax = p.b.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let hmax = (0..q).fold(0.0f64, |m, j| m.max(p.h[(j, j)].abs()));
    let mut iterations = 0;
    let mut singular_faces = 0;
    let mut converged = false;

    while iterations < max_iter {
        iterations += 1;
        let free: Vec<usize> = (0..q)
            .filter(|&j| matches!(state[j], State::Free(_)))
            .collect();
        let fixed: Vec<usize> = (0..q)
            .filter(|&j| !matches!(state[j], State::Free(_)))
            .collect();
        if !free.is_empty() {
            let signs: Vec<f64> = free
                .iter()
                .map(|&j| match state[j] {
                    State::Free(s) => s,
                    _ => 0.0,
                })
                .collect();
            let (target, singular) = p.face_solve(&x, &free, &signs, &fixed);
            singular_faces += singular as usize;
            // Ratio test along x_F → target.
            let mut t_max = 1.0;
            let mut blocking: Option<(usize, f64, bool)> = None;
            for (t, &j) in free.iter().enumerate() {
                let d = target[t] - x[j];
                if d == 0.0 {
                    continue;
                }
                let (plo, phi) = p.piece(j, signs[t]);
                let (edge, to_hi) = if d < 0.0 { (plo, false) } else { (phi, true) };
                if edge.is_infinite() {
                    continue;
                }
                let step = ((edge - x[j]) / d).max(0.0);
                if step < t_max {
                    t_max = step;
                    blocking = Some((j, edge, to_hi));
                }
            }
            for (t, &j) in free.iter().enumerate() {
                x[j] += t_max * (target[t] - x[j]);
            }
            if let Some((j, edge, to_hi)) = blocking {
                x[j] = edge;
                state[j] = if to_hi {
                    if edge == p.hi[j] {
                        State::Upper
                    } else {
                        State::Zero
                    }
                } else if edge == p.lo[j] {
                    State::Lower
                } else {
                    State::Zero
                };
                // Keep the other free coordinates inside their pieces despite rounding.
                for (t, &jj) in free.iter().enumerate() {
                    if jj != j {
                        let (plo, phi) = p.piece(jj, signs[t]);
                        x[jj] = x[jj].clamp(plo, phi);
                    }
                }
                continue;
            }
        }

        // Face minimiser reached: look for a fixed coordinate worth releasing.
        let g = p.gradient(&x);
        let xmax = x.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let tol = 1e-11 * (bmax + p.alpha + hmax * xmax) + f64::MIN_POSITIVE;
        let mut best: Option<(usize, f64, f64)> = None;
        for j in 0..q {
            // (directional derivative, sign of the piece entered)
            let candidates: [(f64, f64); 2] = match state[j] {
                State::Free(_) => continue,
                State::Zero => [(g[j] + p.alpha, 1.0), (-g[j] + p.alpha, -1.0)],
                State::Lower => {
                    if p.lo[j] == p.hi[j] {
                        continue;
                    }
                    let s = if p.lo[j] >= 0.0 { 1.0 } else { -1.0 };
                    [(g[j] + p.alpha * s, s), (f64::INFINITY, 0.0)]
                }
                State::Upper => {
                    if p.lo[j] == p.hi[j] {
                        continue;
                    }
                    let s = if p.hi[j] > 0.0 { 1.0 } else { -1.0 };
                    [(-g[j] - p.alpha * s, s), (f64::INFINITY, 0.0)]
                }
            };
            for (deriv, sign) in candidates {
                if deriv < -tol && best.is_none_or(|(_, bd, _)| deriv < bd) {
                    best = Some((j, deriv, sign));
                }
            }
        }
        match best {
            None => {
                converged = true;
                break;
            }
            Some((j, _, sign)) => {
                state[j] = State::Free(if use_signs { sign } else { 0.0 });
            }
        }
    }
    Outcome {
        x,
        iterations,
        converged,
        singular_faces,
    }
}
