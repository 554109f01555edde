//! Hyper-parameter tuning by blocked (contiguous-in-time) or grouped k-fold
//! cross-validation.
//!
//! Samples of a manoeuvre are strongly autocorrelated, so random folds would leak: a
//! validation sample's neighbours in time sit in the training set. Folds are therefore
//! contiguous blocks of samples, or whole recordings when group labels are given.

use faer::MatRef;
use serde::{Deserialize, Serialize};

use crate::error::EstimatorError;
use crate::fit::fit_problem;
use crate::linalg::{Tall, col_of};
use crate::problem::{Problem, validate_data};
use crate::types::{Bounds, Estimator, Solver};

/// Estimator family whose single hyper-parameter is tuned.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Family {
    /// Tunes λ.
    Ridge,
    /// Tunes α.
    Lasso,
    /// Tunes C at a fixed ε.
    Svr { epsilon: f64 },
}

impl Family {
    /// The estimator with hyper-parameter `param`.
    pub fn estimator(&self, param: f64) -> Estimator {
        match *self {
            Family::Ridge => Estimator::Ridge { lambda: param },
            Family::Lasso => Estimator::Lasso { alpha: param },
            Family::Svr { epsilon } => Estimator::Svr { c: param, epsilon },
        }
    }

    /// Larger means more regularisation (used to break ties).
    fn strength(&self, param: f64) -> f64 {
        match self {
            Family::Ridge | Family::Lasso => param,
            Family::Svr { .. } => -param,
        }
    }
}

/// How samples are split into validation folds.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Folds {
    /// `k` contiguous blocks of (almost) equal length, in sample order.
    Blocked { k: usize },
    /// One label per sample; each distinct label is one fold (e.g. one recording of a
    /// stacked data set).
    Groups(Vec<usize>),
}

impl Folds {
    /// The validation index sets, each sorted. Every sample is in exactly one.
    pub fn validation_sets(&self, n: usize) -> Result<Vec<Vec<usize>>, EstimatorError> {
        match self {
            Folds::Blocked { k } => {
                let k = *k;
                if k < 2 || k > n {
                    return Err(EstimatorError::InvalidFolds(format!(
                        "{k} blocks for {n} samples (need 2 ≤ k ≤ n)"
                    )));
                }
                Ok((0..k)
                    .map(|f| (f * n / k..(f + 1) * n / k).collect())
                    .collect())
            }
            Folds::Groups(labels) => {
                if labels.len() != n {
                    return Err(EstimatorError::LengthMismatch {
                        what: "fold group labels",
                        expected: n,
                        got: labels.len(),
                    });
                }
                let mut distinct: Vec<usize> = labels.clone();
                distinct.sort_unstable();
                distinct.dedup();
                if distinct.len() < 2 {
                    return Err(EstimatorError::InvalidFolds(
                        "group labels must contain at least two distinct values".into(),
                    ));
                }
                Ok(distinct
                    .iter()
                    .map(|&g| (0..n).filter(|&i| labels[i] == g).collect())
                    .collect())
            }
        }
    }
}

/// Cross-validation result for one grid value.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CvPoint {
    pub param: f64,
    /// Pooled validation mean squared error: Σ over folds of the squared errors / n.
    pub mse: f64,
    /// Validation MSE of each fold.
    pub fold_mse: Vec<f64>,
    /// Fits whose status was not `Ok`/`IllConditioned`.
    pub failed_fits: usize,
}

/// Outcome of [`tune`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Tuning {
    /// The selected hyper-parameter.
    pub best: f64,
    /// `family.estimator(best)`.
    pub estimator: Estimator,
    /// One point per grid value, in grid order.
    pub curve: Vec<CvPoint>,
}

/// Tunes the hyper-parameter of `family` over `grid` by cross-validation.
///
/// Each fold fits on the other folds (column scales recomputed on the training part, as
/// `fit` does) and scores the unscaled coefficients on its own samples. The selected
/// value minimises the pooled validation MSE among grid values whose fits all succeeded
/// (all values if none did); exact ties go to the stronger regularisation.
pub fn tune(
    design: MatRef<'_, f64>,
    y: &[f64],
    family: &Family,
    grid: &[f64],
    folds: &Folds,
    bounds: Option<&Bounds>,
    solver: Solver,
) -> Result<Tuning, EstimatorError> {
    validate_data(design, y)?;
    if grid.is_empty() {
        return Err(EstimatorError::EmptyGrid);
    }
    for &g in grid {
        family.estimator(g).validate()?;
    }
    let (n, p) = (design.nrows(), design.ncols());
    if let Some(b) = bounds {
        b.validate(p)?;
    }
    let sets = folds.validation_sets(n)?;

    let mut sse = vec![0.0; grid.len()];
    let mut fold_mse = vec![Vec::with_capacity(sets.len()); grid.len()];
    let mut failed = vec![0usize; grid.len()];
    let mut in_fold = vec![false; n];
    for val in &sets {
        in_fold.iter_mut().for_each(|v| *v = false);
        for &i in val {
            in_fold[i] = true;
        }
        let train: Vec<usize> = (0..n).filter(|&i| !in_fold[i]).collect();
        let mut xt = Tall::zeros(train.len(), p);
        for j in 0..p {
            let src = col_of(design, j);
            for (d, &i) in xt.col_mut(j).iter_mut().zip(&train) {
                *d = src[i];
            }
        }
        let yt: Vec<f64> = train.iter().map(|&i| y[i]).collect();
        let pb = Problem::new(xt.as_ref(), &yt)?;
        for (g, &param) in grid.iter().enumerate() {
            let f = fit_problem(&pb, &family.estimator(param), bounds, solver)?;
            if !f.status.is_solved() {
                failed[g] += 1;
            }
            let pred = predict_rows(design, val, &f.coefficients);
            let s: f64 = val
                .iter()
                .zip(&pred)
                .map(|(&i, pr)| (y[i] - pr) * (y[i] - pr))
                .sum();
            sse[g] += s;
            fold_mse[g].push(s / val.len() as f64);
        }
    }
    let curve: Vec<CvPoint> = grid
        .iter()
        .enumerate()
        .map(|(g, &param)| CvPoint {
            param,
            mse: sse[g] / n as f64,
            fold_mse: fold_mse[g].clone(),
            failed_fits: failed[g],
        })
        .collect();
    let any_clean = curve.iter().any(|c| c.failed_fits == 0);
    let best = curve
        .iter()
        .filter(|c| !any_clean || c.failed_fits == 0)
        .min_by(|a, b| {
            a.mse.total_cmp(&b.mse).then(
                family
                    .strength(b.param)
                    .total_cmp(&family.strength(a.param)),
            )
        })
        .map(|c| c.param)
        .unwrap_or(grid[0]);
    Ok(Tuning {
        best,
        estimator: family.estimator(best),
        curve,
    })
}

/// `Φβ` on the rows `rows`.
fn predict_rows(design: MatRef<'_, f64>, rows: &[usize], beta: &[f64]) -> Vec<f64> {
    let mut out = vec![0.0; rows.len()];
    for (j, &b) in beta.iter().enumerate() {
        if b != 0.0 {
            let c = col_of(design, j);
            for (o, &i) in out.iter_mut().zip(rows) {
                *o += b * c[i];
            }
        }
    }
    out
}

/// `points` values from `lo` to `hi`, equally spaced in log10.
pub fn log_grid(lo: f64, hi: f64, points: usize) -> Vec<f64> {
    match points {
        0 => Vec::new(),
        1 => vec![lo],
        _ => {
            let (a, b) = (lo.log10(), hi.log10());
            (0..points)
                .map(|k| 10f64.powf(a + (b - a) * k as f64 / (points - 1) as f64))
                .collect()
        }
    }
}

/// A default log grid for `family` on this data, increasing:
///
/// * Ridge: λ ∈ [1e-8, 1e2], 21 values. With unit-RMS columns `ZᵀZ/n` has a unit
///   diagonal, so λ compares directly with its eigenvalues, independent of data and n.
/// * Lasso: α ∈ α_max·[1e-6, 1], 25 values, where `α_max = max_j |z_jᵀy|/n` is the
///   smallest α whose (unbounded) solution is all zeros.
/// * SVR: C ∈ C₀·[1e-1, 1e5], 13 values, with `C₀ = rms(y)/n`: the C at which
///   `C Σ|θ|`-sized coefficients reach the size of the data (the KKT conditions give
///   `γ = Σ θᵢ zᵢ` with `|θᵢ| ≤ C`).
pub fn default_grid(
    family: &Family,
    design: MatRef<'_, f64>,
    y: &[f64],
) -> Result<Vec<f64>, EstimatorError> {
    validate_data(design, y)?;
    let n = y.len() as f64;
    match family {
        Family::Ridge => Ok(log_grid(1e-8, 1e2, 21)),
        Family::Lasso => {
            let pb = Problem::new(design, y)?;
            let amax = pb.gram().b.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            let amax = if amax > 0.0 { amax } else { 1.0 };
            Ok(log_grid(1e-6 * amax, amax, 25))
        }
        Family::Svr { epsilon } => {
            Estimator::Svr {
                c: 0.0,
                epsilon: *epsilon,
            }
            .validate()?;
            let rms = (y.iter().map(|v| v * v).sum::<f64>() / n).sqrt();
            let c0 = if rms > 0.0 { rms / n } else { 1.0 / n };
            Ok(log_grid(1e-1 * c0, 1e5 * c0, 13))
        }
    }
}
