//! Collinearity diagnostics: variance inflation factors, condition numbers and per-term
//! contributions (paper 000 §2.5).

use faer::{Mat, MatRef};

use crate::dense::linalg::{Tall, col_of, condition_from_singular_values, singular_values};
use crate::error::EstimatorError;
use crate::problem::{check_coefficients, column_scales, validate_design};

/// Variance inflation factor of every column: `VIF_j = 1/(1 − R²_j)`, with `R²_j` from
/// regressing column j on all other non-constant columns *and an intercept* (the standard
/// centred definition, equal to the j-th diagonal entry of the inverse correlation
/// matrix).
///
/// A constant column (zero centred spread, e.g. the intercept column of Y_0) has no VIF:
/// `None`; it is also left out of the other columns' regressions, since the intercept
/// already spans it. Columns that are exactly collinear get `Some(f64::INFINITY)`.
///
/// Computed from a QR of the standardised columns, `diag((RᵀR)⁻¹)` = squared row norms of
/// R⁻¹, which avoids forming and inverting the correlation matrix.
pub fn vif(design: MatRef<'_, f64>) -> Result<Vec<Option<f64>>, EstimatorError> {
    validate_design(design)?;
    let (n, p) = (design.nrows(), design.ncols());
    let nf = n as f64;
    let mut keep = Vec::new();
    let mut centred_cols: Vec<Vec<f64>> = Vec::new();
    let scales = column_scales(design)?;
    for (j, &scale) in scales.iter().enumerate() {
        let mean = design.col(j).iter().sum::<f64>() / nf;
        let c: Vec<f64> = design.col(j).iter().map(|v| v - mean).collect();
        let sd = (c.iter().map(|v| v * v).sum::<f64>() / nf).sqrt();
        // Relative test: a column like Δu' at a constant speed is constant up to rounding.
        if sd > 1e-12 * scale {
            keep.push(j);
            centred_cols.push(c.into_iter().map(|v| v / (sd * nf.sqrt())).collect());
        }
    }
    let mut out = vec![None; p];
    let k = keep.len();
    if k == 0 {
        return Ok(out);
    }
    if n <= k {
        // After centring the rank is at most n − 1 < k: every column is explained.
        for &j in &keep {
            out[j] = Some(f64::INFINITY);
        }
        return Ok(out);
    }
    let mut x = Tall::zeros(n, k);
    for (t, c) in centred_cols.iter().enumerate() {
        x.col_mut(t).copy_from_slice(c);
    }
    let qr = x.as_ref().qr();
    let r = qr.thin_R();
    // R⁻¹ column by column (upper triangular), then squared row norms.
    let mut rinv = Mat::<f64>::zeros(k, k);
    let mut singular = false;
    for c in 0..k {
        for i in (0..=c).rev() {
            let mut s = if i == c { 1.0 } else { 0.0 };
            for t in i + 1..=c {
                s -= r[(i, t)] * rinv[(t, c)];
            }
            if r[(i, i)] == 0.0 {
                singular = true;
                break;
            }
            rinv[(i, c)] = s / r[(i, i)];
        }
    }
    for (t, &j) in keep.iter().enumerate() {
        let v: f64 = (t..k).map(|c| rinv[(t, c)] * rinv[(t, c)]).sum();
        out[j] = Some(if singular || !v.is_finite() {
            f64::INFINITY
        } else {
            v
        });
    }
    Ok(out)
}

/// Condition number σ_max/σ_min of the raw design (by SVD); infinite when rank deficient.
pub fn condition_number(design: MatRef<'_, f64>) -> Result<f64, EstimatorError> {
    validate_design(design)?;
    let s = singular_values(design)?;
    Ok(condition_from_singular_values(&s, design.ncols()))
}

/// Condition number of the design after dividing every column by its RMS (the space in
/// which the estimators regularise); infinite when a column is zero.
pub fn scaled_condition_number(design: MatRef<'_, f64>) -> Result<f64, EstimatorError> {
    let scales = column_scales(design)?;
    if scales.contains(&0.0) {
        return Ok(f64::INFINITY);
    }
    let mut z = Tall::zeros(design.nrows(), design.ncols());
    for (j, &s) in scales.iter().enumerate() {
        for (d, v) in z.col_mut(j).iter_mut().zip(col_of(design, j).iter()) {
            *d = v / s;
        }
    }
    let s = singular_values(z.as_ref())?;
    Ok(condition_from_singular_values(&s, design.ncols()))
}

/// Per-term contributions `φ_ij β_j` (n × p): the force or moment each coefficient carries
/// at each sample, for spotting cancelling terms.
pub fn contributions(design: MatRef<'_, f64>, beta: &[f64]) -> Result<Mat<f64>, EstimatorError> {
    validate_design(design)?;
    check_coefficients(beta, design.ncols())?;
    Ok(Mat::<f64>::from_fn(
        design.nrows(),
        design.ncols(),
        |i, j| design[(i, j)] * beta[j],
    ))
}
