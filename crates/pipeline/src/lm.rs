//! Levenberg–Marquardt steps shared by the effect fits of the diagnosis and the output-error
//! refinement, which differ in their Jacobians, bounds and stopping rules; and the small dense solve
//! they need. No I/O.

use rayon::prelude::*;

pub fn solve_small(a: &[Vec<f64>], b: &[f64]) -> Option<Vec<f64>> {
    let n = b.len();
    let mut m: Vec<Vec<f64>> = a
        .iter()
        .zip(b)
        .map(|(row, &bi)| {
            let mut r = row.clone();
            r.push(bi);
            r
        })
        .collect();
    for col in 0..n {
        let piv = (col..n).max_by(|&i, &j| m[i][col].abs().total_cmp(&m[j][col].abs()))?;
        if m[piv][col].abs() < 1e-300 {
            return None;
        }
        m.swap(col, piv);
        let (upper, lower) = m.split_at_mut(col + 1);
        let pivot_row = &upper[col];
        for row in lower.iter_mut() {
            let f = row[col] / pivot_row[col];
            row.iter_mut()
                .zip(pivot_row)
                .skip(col)
                .for_each(|(x, p)| *x -= f * p);
        }
    }
    let mut x = vec![0.0; n];
    for row in (0..n).rev() {
        let s: f64 = (row + 1..n).map(|k| m[row][k] * x[k]).sum();
        x[row] = (m[row][n] - s) / m[row][row];
    }
    x.iter().all(|v| v.is_finite()).then_some(x)
}

/// Where a Levenberg–Marquardt iteration stands: parameters, residuals and their sum of squares.
pub struct LmPoint {
    pub p: Vec<f64>,
    pub r: Vec<f64>,
    pub cost: f64,
}

/// The normal equations of a linearised least-squares problem: JᵀJ (k × k) and −Jᵀr.
pub struct Normal {
    pub jtj: Vec<Vec<f64>>,
    pub neg_jtr: Vec<f64>,
}

/// One Levenberg–Marquardt step from `at` with the Jacobian `jac` (one row per parameter): solves
/// (JᵀJ + λ diag JᵀJ) δ = −Jᵀr, projects p + δ with `project` and moves `at` there when the cost
/// drops (then λ ← max(0.3 λ, 1e-9)); otherwise λ grows tenfold and it tries again, at most `tries`
/// times. Returns the relative cost decrease of the accepted step, `None` when none lowered the cost.
/// Shared by the effect fits of the diagnosis and the output-error refinement, which differ in their
/// Jacobians, bounds and stopping rules.
pub fn lm_step(
    jac: &[Vec<f64>],
    at: &mut LmPoint,
    lambda: &mut f64,
    tries: usize,
    project: impl Fn(&mut Vec<f64>),
    residuals: impl Fn(&[f64]) -> Vec<f64>,
) -> Option<f64> {
    let k = jac.len();
    let jtj: Vec<Vec<f64>> = (0..k)
        .into_par_iter()
        .map(|a| (0..k).map(|b| dot(&jac[a], &jac[b])).collect())
        .collect();
    let neg_jtr: Vec<f64> = (0..k).map(|a| -dot(&jac[a], &at.r)).collect();
    lm_step_normal(
        &Normal { jtj, neg_jtr },
        at,
        lambda,
        tries,
        project,
        residuals,
    )
}

/// [`lm_step`] from the normal equations, for callers that accumulate them without storing J (the
/// refinement, whose J has ten thousand rows).
pub fn lm_step_normal(
    normal: &Normal,
    at: &mut LmPoint,
    lambda: &mut f64,
    tries: usize,
    project: impl Fn(&mut Vec<f64>),
    residuals: impl Fn(&[f64]) -> Vec<f64>,
) -> Option<f64> {
    let Normal { jtj, neg_jtr } = normal;
    let k = jtj.len();
    for _ in 0..tries {
        let mut a = jtj.clone();
        (0..k).for_each(|i| a[i][i] += *lambda * jtj[i][i].max(1e-12));
        let Some(step) = solve_small(&a, neg_jtr) else {
            *lambda *= 10.0;
            continue;
        };
        let mut q: Vec<f64> = at.p.iter().zip(&step).map(|(a, b)| a + b).collect();
        project(&mut q);
        let rq = residuals(&q);
        let cq = rq.iter().map(|x| x * x).sum::<f64>();
        if cq < at.cost {
            let rel = (at.cost - cq) / at.cost.max(1e-300);
            *at = LmPoint {
                p: q,
                r: rq,
                cost: cq,
            };
            *lambda = (*lambda * 0.3).max(1e-9);
            return Some(rel);
        }
        *lambda *= 10.0;
    }
    None
}

pub fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}
