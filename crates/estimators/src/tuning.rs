//! Hyper-parameter tuning by blocked (contiguous-in-time) or grouped k-fold
//! cross-validation.
//!
//! Samples of a manoeuvre are strongly autocorrelated, so random folds would leak: a
//! validation sample's neighbours in time sit in the training set. Folds are therefore
//! contiguous blocks of samples, or whole recordings when group labels are given.

use faer::MatRef;
use serde::{Deserialize, Serialize};

use crate::dense::linalg::{Tall, col_of};
use crate::error::EstimatorError;
use crate::fit::fit_problem;
use crate::params::Params;
use crate::problem::{Problem, validate_data};
use crate::types::{Bounds, Estimator, Solver};

/// Estimator family whose single hyper-parameter is tuned by [`tune`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Family {
    /// Tunes λ.
    Ridge,
    /// Tunes α.
    Lasso,
    /// Tunes C at a fixed ε ([`tune_svr`] tunes both).
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
    /// The SVR's ε of this point when ε was tuned too ([`tune_svr`]); `None` when the
    /// family's other settings were fixed.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub epsilon: Option<f64>,
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
    /// The selected hyper-parameter (C for the SVR).
    pub best: f64,
    /// `family.estimator(best)`; for [`tune_svr`] the SVR with the selected C and ε.
    pub estimator: Estimator,
    /// One point per grid value, in grid order ([`tune_svr`]: C varying fastest).
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
    let candidates: Vec<Candidate> = grid
        .iter()
        .map(|&g| Candidate {
            estimator: family.estimator(g),
            param: g,
            epsilon: None,
        })
        .collect();
    let curve = cross_validate(design, y, &candidates, folds, bounds, solver)?;
    let best = select(&curve, |a, b| {
        family
            .strength(b.param)
            .total_cmp(&family.strength(a.param))
    })
    .map(|k| grid[k])
    .unwrap_or(grid[0]);
    Ok(Tuning {
        best,
        estimator: family.estimator(best),
        curve,
    })
}

/// Tunes both hyper-parameters of the linear ε-SVR by cross-validation over the product
/// of `epsilons` and C's default grid ([`default_grid`], which depends on y only), as
/// [`tune`] does for one. Exact ties go to the stronger regularisation: the smaller C,
/// then the wider tube.
///
/// ε sets which residuals the fit ignores, so with a misspecified model (a coefficient
/// set that cannot represent the data exactly) it changes where the remaining error goes,
/// not only how much noise is tolerated; the validation MSE, not a fixed fraction of the
/// target, is what chooses it then.
pub fn tune_svr(
    design: MatRef<'_, f64>,
    y: &[f64],
    epsilons: &[f64],
    folds: &Folds,
    bounds: Option<&Bounds>,
    solver: Solver,
) -> Result<Tuning, EstimatorError> {
    let c_grid = default_grid(&Family::Svr { epsilon: 0.0 }, design, y)?;
    if epsilons.is_empty() {
        return Err(EstimatorError::EmptyGrid);
    }
    let candidates: Vec<Candidate> = epsilons
        .iter()
        .flat_map(|&epsilon| {
            c_grid.iter().map(move |&c| Candidate {
                estimator: Estimator::Svr { c, epsilon },
                param: c,
                epsilon: Some(epsilon),
            })
        })
        .collect();
    let curve = cross_validate(design, y, &candidates, folds, bounds, solver)?;
    let k = select(&curve, |a, b| {
        a.param.total_cmp(&b.param).then(
            b.epsilon
                .unwrap_or(0.0)
                .total_cmp(&a.epsilon.unwrap_or(0.0)),
        )
    })
    .unwrap_or(0);
    Ok(Tuning {
        best: curve[k].param,
        estimator: candidates[k].estimator,
        curve,
    })
}

/// The default ε grid of [`tune_svr`]: `rms(y)·[1e-3, 10^-0.5]`, six values half a decade
/// apart (0.1 %, 0.32 %, 1 %, 3.2 %, 10 %, 32 % of the target's RMS). It contains
/// `shipid fit`'s fixed default (1 %); above a third of the RMS most samples sit inside
/// the tube and the fit has little left to learn from.
pub fn default_epsilon_grid(y: &[f64]) -> Vec<f64> {
    let rms = target_rms(y);
    log_grid(1e-3, 10f64.powf(-0.5), 6)
        .into_iter()
        .map(|f| f * rms)
        .collect()
}

/// The index of the point with the least pooled MSE among those whose fits all succeeded
/// (among all points if none did); `prefer(a, b)` orders exact ties, `Less` meaning that
/// `a` is the stronger regularisation.
fn select(
    curve: &[CvPoint],
    prefer: impl Fn(&CvPoint, &CvPoint) -> std::cmp::Ordering,
) -> Option<usize> {
    let any_clean = curve.iter().any(|c| c.failed_fits == 0);
    curve
        .iter()
        .enumerate()
        .filter(|(_, c)| !any_clean || c.failed_fits == 0)
        .min_by(|(_, a), (_, b)| a.mse.total_cmp(&b.mse).then(prefer(a, b)))
        .map(|(k, _)| k)
}

/// A grid point of the cross-validation: the estimator and the labels of its [`CvPoint`].
struct Candidate {
    estimator: Estimator,
    param: f64,
    epsilon: Option<f64>,
}

/// `rms(y)`, the scale of the SVR's default grids.
fn target_rms(y: &[f64]) -> f64 {
    (y.iter().map(|v| v * v).sum::<f64>() / y.len().max(1) as f64).sqrt()
}

/// The cross-validation curve of `candidates`, in their order.
fn cross_validate(
    design: MatRef<'_, f64>,
    y: &[f64],
    candidates: &[Candidate],
    folds: &Folds,
    bounds: Option<&Bounds>,
    solver: Solver,
) -> Result<Vec<CvPoint>, EstimatorError> {
    validate_data(design, y)?;
    if candidates.is_empty() {
        return Err(EstimatorError::EmptyGrid);
    }
    let (n, p) = (design.nrows(), design.ncols());
    let mut params = Vec::with_capacity(candidates.len());
    for (g, cand) in candidates.iter().enumerate() {
        let checked = Params {
            estimator: cand.estimator,
            bounds: bounds.cloned(),
            solver,
        }
        .check();
        match checked {
            Ok(c) => params.push(c),
            Err(e @ EstimatorError::InvalidHyperParameter { .. }) => return Err(e),
            // Tuning has always judged every grid value before the bounds, and the
            // bounds' lengths against the design before their pairs: a call with several
            // faults still reports the one it reported before the checked parameters.
            Err(e) => {
                for later in &candidates[g + 1..] {
                    later.estimator.validate()?;
                }
                return Err(bounds.and_then(|b| b.validate(p).err()).unwrap_or(e));
            }
        }
    }
    // Every candidate carries the same bounds.
    params[0].check_columns(p)?;
    let sets = folds.validation_sets(n)?;

    let mut sse = vec![0.0; candidates.len()];
    let mut fold_mse = vec![Vec::with_capacity(sets.len()); candidates.len()];
    let mut failed = vec![0usize; candidates.len()];
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
        for (g, checked) in params.iter().enumerate() {
            let f = fit_problem(&pb, checked)?;
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
    Ok(candidates
        .iter()
        .enumerate()
        .map(|(g, cand)| CvPoint {
            param: cand.param,
            epsilon: cand.epsilon,
            mse: sse[g] / n as f64,
            fold_mse: std::mem::take(&mut fold_mse[g]),
            failed_fits: failed[g],
        })
        .collect())
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
            let rms = target_rms(y);
            let c0 = if rms > 0.0 { rms / n } else { 1.0 / n };
            Ok(log_grid(1e-1 * c0, 1e5 * c0, 13))
        }
    }
}
