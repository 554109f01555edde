//! Input validation, column scaling and the data shared by both solver families.

use std::cell::OnceCell;

use faer::{Mat, MatRef};

use crate::dense::linalg::{
    LsFactor, Tall, cholesky_qr2, col_of, gram, householder_factor, residual, sym_eig_extremes,
    zt_v,
};
use crate::error::EstimatorError;
use crate::types::{Bounds, Estimator};

/// Checks shape and finiteness of a design and a target (the design's columns before the target).
pub(crate) fn validate_data(design: MatRef<'_, f64>, y: &[f64]) -> Result<(), EstimatorError> {
    check_shape(design, y)?;
    validate_design(design)?;
    check_target(y)
}

pub(crate) fn validate_design(design: MatRef<'_, f64>) -> Result<(), EstimatorError> {
    let (n, p) = (design.nrows(), design.ncols());
    if n == 0 || p == 0 {
        return Err(EstimatorError::EmptyDesign { rows: n, cols: p });
    }
    for j in 0..p {
        check_finite_column(&col_of(design, j), j)?;
    }
    Ok(())
}

fn check_finite_column(c: &[f64], j: usize) -> Result<(), EstimatorError> {
    if c.iter().all(|v| v.is_finite()) {
        return Ok(());
    }
    let (row, &value) = c
        .iter()
        .enumerate()
        .find(|(_, v)| !v.is_finite())
        .unwrap_or((0, &f64::NAN));
    Err(EstimatorError::NonFinite {
        what: "design",
        row,
        column: Some(j),
        value,
    })
}

/// Root mean square: [`rms_fast`] when it applies, otherwise after division by the
/// largest magnitude (far from overflow and underflow).
fn rms(c: &[f64]) -> f64 {
    if let Some(v) = rms_fast(c) {
        return v;
    }
    let m = c.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    if m == 0.0 {
        return 0.0;
    }
    let n = c.len() as f64;
    let s: f64 = c.iter().map(|v| (v / m) * (v / m)).sum();
    m * (s / n).sqrt()
}

/// Root mean square in one pass, `None` unless the sum of squares is finite and far from
/// underflow and overflow (then every value is finite too, since NaN and ±∞ propagate
/// into the sum; the caller falls back to the checked, rescaled [`rms`]). This is the
/// common case, and one pass instead of three (finite check, maximum, sum) is a visible
/// share of a least-squares fit.
fn rms_fast(c: &[f64]) -> Option<f64> {
    let mut acc = [0.0f64; 8];
    let chunks = c.chunks_exact(8);
    let tail: f64 = chunks.remainder().iter().map(|v| v * v).sum();
    for ch in chunks {
        for (a, v) in acc.iter_mut().zip(ch) {
            *a += v * v;
        }
    }
    let s =
        ((acc[0] + acc[1]) + (acc[2] + acc[3])) + ((acc[4] + acc[5]) + (acc[6] + acc[7])) + tail;
    // Squares of values below 1e-150 may underflow unnoticed, and a sum above 1e290 is
    // close to overflow: both go through the rescaled path.
    (s.is_finite() && (1e-150..=1e290).contains(&s)).then(|| (s / c.len() as f64).sqrt())
}

/// The checks of [`Problem::new`] in its order (shape, target, then design columns), for
/// callers that need no scaled copy.
pub(crate) fn validate_problem_data(
    design: MatRef<'_, f64>,
    y: &[f64],
) -> Result<(), EstimatorError> {
    check_shape(design, y)?;
    check_target(y)?;
    validate_design(design)
}

/// A non-empty design with one target value per row; returns (n, p).
fn check_shape(design: MatRef<'_, f64>, y: &[f64]) -> Result<(usize, usize), EstimatorError> {
    let (n, p) = (design.nrows(), design.ncols());
    if n == 0 || p == 0 {
        return Err(EstimatorError::EmptyDesign { rows: n, cols: p });
    }
    if y.len() != n {
        return Err(EstimatorError::LengthMismatch {
            what: "target y (rows of the design)",
            expected: n,
            got: y.len(),
        });
    }
    Ok((n, p))
}

/// The first non-finite target value, if any, as an error.
fn check_target(y: &[f64]) -> Result<(), EstimatorError> {
    check_finite("target y", y)
}

/// The first non-finite entry of the vector `what`, if any, as an error.
pub(crate) fn check_finite(what: &'static str, v: &[f64]) -> Result<(), EstimatorError> {
    match v.iter().enumerate().find(|(_, x)| !x.is_finite()) {
        Some((row, &value)) => Err(EstimatorError::NonFinite {
            what,
            row,
            column: None,
            value,
        }),
        None => Ok(()),
    }
}

/// Coefficients given by the caller (to evaluate or predict with): one per design column,
/// all finite.
pub(crate) fn check_coefficients(beta: &[f64], p: usize) -> Result<(), EstimatorError> {
    if beta.len() != p {
        return Err(EstimatorError::LengthMismatch {
            what: "coefficients (columns of the design)",
            expected: p,
            got: beta.len(),
        });
    }
    check_finite("coefficients", beta)
}

/// Root mean square of every column: the column scales `s_j` of the documented objectives.
pub fn column_scales(design: MatRef<'_, f64>) -> Result<Vec<f64>, EstimatorError> {
    validate_design(design)?;
    Ok(rms_columns(design))
}

fn rms_columns(design: MatRef<'_, f64>) -> Vec<f64> {
    (0..design.ncols())
        .map(|j| rms(&col_of(design, j)))
        .collect()
}

/// Gram data of the scaled design: `G = ZᵀZ/n`, `b = Zᵀy/n`.
pub(crate) struct GramData {
    pub(crate) g: Mat<f64>,
    pub(crate) b: Vec<f64>,
}

/// A validated regression problem in the scaled space.
///
/// `z` holds only the non-zero columns (`active`), each divided by its RMS, so `ZᵀZ/n` has
/// a unit diagonal. Decompositions are computed on first use and shared by every fit on
/// the same data (the tuning loop fits many hyper-parameters per fold).
pub(crate) struct Problem {
    pub(crate) n: usize,
    pub(crate) p: usize,
    pub(crate) scales: Vec<f64>,
    pub(crate) active: Vec<usize>,
    pub(crate) zero_columns: Vec<usize>,
    pub(crate) z: Tall,
    pub(crate) y: Vec<f64>,
    gram: OnceCell<GramData>,
    gram_extremes: OnceCell<(f64, f64)>,
    fast_ls: OnceCell<LsFactor>,
    reference_ls: OnceCell<LsFactor>,
}

impl Problem {
    pub(crate) fn new(design: MatRef<'_, f64>, y: &[f64]) -> Result<Self, EstimatorError> {
        let (n, p) = check_shape(design, y)?;
        check_target(y)?;
        let mut scales = vec![0.0; p];
        for (j, scale) in scales.iter_mut().enumerate() {
            let c = col_of(design, j);
            // A finite sum of squares proves the column finite; otherwise find the bad value.
            *scale = match rms_fast(&c) {
                Some(v) => v,
                None => {
                    check_finite_column(&c, j)?;
                    rms(&c)
                }
            };
        }
        let active: Vec<usize> = (0..p).filter(|&j| scales[j] > 0.0).collect();
        let zero_columns: Vec<usize> = (0..p).filter(|&j| scales[j] == 0.0).collect();
        let mut data = Vec::with_capacity(n * active.len());
        for &j in &active {
            let s = scales[j];
            let c = col_of(design, j);
            if s >= 1e-300 {
                let inv = 1.0 / s;
                data.extend(c.iter().map(|v| v * inv));
            } else {
                // 1/s would overflow for a subnormal scale.
                data.extend(c.iter().map(|v| v / s));
            }
        }
        let z = Tall::from_column_major(data, n, active.len());
        Ok(Problem {
            n,
            p,
            scales,
            active,
            zero_columns,
            z,
            y: y.to_vec(),
            gram: OnceCell::new(),
            gram_extremes: OnceCell::new(),
            fast_ls: OnceCell::new(),
            reference_ls: OnceCell::new(),
        })
    }

    /// Number of non-zero columns (the dimension of the scaled problem).
    pub(crate) fn q(&self) -> usize {
        self.active.len()
    }

    pub(crate) fn gram(&self) -> &GramData {
        self.gram.get_or_init(|| {
            let inv_n = 1.0 / self.n as f64;
            let mut g = gram(self.z.as_ref());
            for j in 0..g.ncols() {
                for i in 0..g.nrows() {
                    g[(i, j)] *= inv_n;
                }
            }
            let b = zt_v(&self.z, &self.y)
                .into_iter()
                .map(|v| v * inv_n)
                .collect();
            GramData { g, b }
        })
    }

    /// Extreme eigenvalues (min, max) of `G = ZᵀZ/n`.
    pub(crate) fn gram_extremes(&self) -> Result<(f64, f64), EstimatorError> {
        if let Some(&e) = self.gram_extremes.get() {
            return Ok(e);
        }
        let e = sym_eig_extremes(self.gram().g.as_ref())?;
        Ok(*self.gram_extremes.get_or_init(|| e))
    }

    /// Least-squares factor for the fast solvers: CholeskyQR2 when it is provably
    /// accurate, Householder otherwise.
    pub(crate) fn fast_ls(&self) -> &LsFactor {
        self.fast_ls.get_or_init(|| {
            cholesky_qr2(&self.z, &self.y).unwrap_or_else(|| self.reference_ls().clone())
        })
    }

    /// Least-squares factor for the reference QP: always Householder, so that the
    /// reference does not share the fast path's factorisation.
    pub(crate) fn reference_ls(&self) -> &LsFactor {
        self.reference_ls
            .get_or_init(|| householder_factor(&self.z, &self.y))
    }

    /// True when a least-squares factor has been computed.
    pub(crate) fn has_ls(&self) -> bool {
        self.fast_ls.get().is_some() || self.reference_ls.get().is_some()
    }

    /// Whichever least-squares factor already exists (for diagnostics), else the fast one.
    pub(crate) fn any_ls(&self) -> &LsFactor {
        if let Some(f) = self.fast_ls.get() {
            f
        } else if let Some(f) = self.reference_ls.get() {
            f
        } else {
            self.fast_ls()
        }
    }

    /// Bounds of the scaled coefficients `γ_k = s_j β_j` of the active columns.
    pub(crate) fn scaled_bounds(&self, bounds: Option<&Bounds>) -> (Vec<f64>, Vec<f64>) {
        match bounds {
            None => (
                vec![f64::NEG_INFINITY; self.q()],
                vec![f64::INFINITY; self.q()],
            ),
            Some(b) => self
                .active
                .iter()
                .map(|&j| (b.lower[j] * self.scales[j], b.upper[j] * self.scales[j]))
                .unzip(),
        }
    }

    /// Unscaled coefficients from scaled ones, clamped to the bounds (the division by the
    /// scale can move a coefficient held at a bound by an ulp).
    pub(crate) fn unscale(&self, gamma: &[f64], bounds: Option<&Bounds>) -> Vec<f64> {
        let mut beta = vec![0.0; self.p];
        for (k, &j) in self.active.iter().enumerate() {
            beta[j] = gamma[k] / self.scales[j];
        }
        if let Some(b) = bounds {
            for (j, v) in beta.iter_mut().enumerate() {
                *v = v.clamp(b.lower[j], b.upper[j]);
            }
        }
        beta
    }

    /// Scaled coefficients of the active columns.
    pub(crate) fn scale(&self, beta: &[f64]) -> Vec<f64> {
        self.active
            .iter()
            .map(|&j| beta[j] * self.scales[j])
            .collect()
    }

    /// The documented objective of `estimator` at the unscaled coefficients `beta`.
    pub(crate) fn objective(&self, estimator: &Estimator, beta: &[f64]) -> f64 {
        let gamma = self.scale(beta);
        let r = residual(&self.z, &self.y, &gamma);
        let n = self.n as f64;
        let half_mse = || 0.5 * r.iter().map(|v| v * v).sum::<f64>() / n;
        match *estimator {
            Estimator::Lsq | Estimator::BoundedLsq => half_mse(),
            Estimator::Ridge { lambda } => {
                half_mse() + 0.5 * lambda * gamma.iter().map(|g| g * g).sum::<f64>()
            }
            Estimator::Lasso { alpha } => {
                half_mse() + alpha * gamma.iter().map(|g| g.abs()).sum::<f64>()
            }
            Estimator::Svr { c, epsilon } => {
                0.5 * gamma.iter().map(|g| g * g).sum::<f64>()
                    + c * r.iter().map(|v| (v.abs() - epsilon).max(0.0)).sum::<f64>()
            }
        }
    }
}
