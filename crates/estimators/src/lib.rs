//! Per-degree-of-freedom regression estimators for Abkowitz coefficient identification
//! (paper 000 §2.4), cross-validated hyper-parameter tuning, and collinearity diagnostics.
//!
//! Pure numerics: no I/O, no panics on user data. Invalid input gives an
//! [`EstimatorError`]; how a solve went is a [`Status`] inside the [`Fit`].
//!
//! # Problem and objectives
//!
//! One degree of freedom regresses a target `y` (n samples) on a design `Φ` (n × p) of
//! monomials, `y ≈ Φβ`, optionally with bounds `lower ≤ β ≤ upper` on the coefficients.
//!
//! **Column scaling.** Every column is divided by its root mean square
//! `s_j = √(Σᵢ Φᵢⱼ²/n)`: `Z = Φ diag(s)⁻¹`, `γ_j = s_j β_j`, so `Φβ = Zγ` and `ZᵀZ/n` has a
//! unit diagonal. Penalties act on γ (the scaled space); coefficients are always
//! *reported unscaled* (β, prime system). RMS rather than standard deviation because
//! the design has no separate intercept: a constant column (Y_0, N_0) is a regressor like
//! any other and is penalised like any other. Scaling leaves the unregularised LSQ
//! solution unchanged.
//!
//! **Objectives** (all hyper-parameters ≥ 0; `n` = number of samples):
//!
//! ```text
//!   LSQ, bounded LSQ   J(β) = (1/2n)‖Φβ − y‖²
//!   Ridge              J(β) = (1/2n)‖Φβ − y‖² + (λ/2) Σ_j (s_j β_j)²
//!   Lasso              J(β) = (1/2n)‖Φβ − y‖² + α Σ_j s_j |β_j|
//!   ε-SVR (linear)     J(β) = ½ Σ_j (s_j β_j)² + C Σᵢ max(0, |yᵢ − φᵢβ| − ε)
//! ```
//!
//! The least-squares term is a *mean* (the scikit-learn Lasso convention, 1/(2n)), for
//! all four least-squares estimators alike, so λ and α do not depend on n: a value
//! tuned on cross-validation folds transfers to the full data, and stacked recordings
//! keep their meaning. Relative to scikit-learn on the scaled design with
//! `fit_intercept=False`: `alpha` is `Lasso(alpha)` unchanged, λ is `Ridge(alpha = nλ)`,
//! and C, ε are `LinearSVR(C, epsilon, loss="epsilon_insensitive")`. SVR keeps the paper's (and LIBSVM's)
//! per-sample sum, `C Σ ξ`, with ε in the units of y; its slack form
//! `min ½‖γ‖² + C Σ(ξᵢ + ξᵢ*)` s.t. `yᵢ − φᵢβ ≤ ε + ξᵢ`, `φᵢβ − yᵢ ≤ ε + ξᵢ*`, `ξ, ξ* ≥ 0`
//! has exactly the value J above at its optimum. None of the problems has a separate
//! intercept.
//!
//! A column that is identically zero carries no information: it is left out of the solve
//! and its coefficient is the value of `[lower, upper]` closest to 0
//! ([`Fit::zero_columns`]), and the fit's status is [`Status::RankDeficient`].
//!
//! # Solvers
//!
//! Every estimator exists twice ([`Solver`]); both minimise the same J:
//!
//! * `Qp` — the reference, a clarabel QP. The least-squares family is compressed to a
//!   problem of size ≈ 2p–3p through a Householder R factor (`solvers::qp`); SVR is the full
//!   primal with per-sample slacks.
//! * `Fast` — LSQ by the corrected semi-normal equations (Cholesky of `ZᵀZ/n` plus one
//!   refinement step) when κ(Z) ≤ 1e5, by QR otherwise (CholeskyQR2 when provably
//!   accurate, Householder else; SVD minimum norm when rank deficient); Ridge by Cholesky
//!   of `ZᵀZ/n + λI` (QR of `[R; √(nλ)I]` for tiny λ); bounds and the ℓ1 penalty by an
//!   exact primal active-set method in the p-dimensional space (in place of coordinate
//!   descent, whose rate collapses at the κ(ZᵀZ) ≈ 1e8–1e12 of Abkowitz designs); SVR by
//!   a primal-dual interior-point method with q × q normal equations whose iterates feed
//!   an exact KKT finish (or are accepted on a certified duality gap), with Newton steps
//!   on a smoothed ε-insensitive loss under continuation as the fallback (`solvers::svr`).
//!
//! [`Fit::objective`] is always J evaluated at the returned coefficients, so the two
//! solvers can be compared directly. [`Status::IllConditioned`] flags fits whose effective
//! condition number exceeds [`ILL_CONDITIONED_THRESHOLD`] (1/√ε_mach ≈ 6.7e7).
//!
//! # Public API
//!
//! * [`fit()`], [`objective()`], [`predict()`] — fitting and evaluation; [`Params`] and its
//!   [`Params::check`] into [`CheckedParams`], whose [`CheckedParams::fit`] is the same
//!   fit with the settings validated once, up front;
//! * [`tune()`], [`Folds`], [`Family`], [`default_grid()`] — blocked / grouped k-fold
//!   cross-validation over a log grid;
//! * [`vif()`], [`condition_number()`], [`scaled_condition_number()`],
//!   [`contributions()`] — diagnostics;
//! * [`column_scales()`] — the `s_j` above.
//!
//! # Module map
//!
//! Each line uses only itself and the lines below it, and no two files import each other
//! (`scripts/import_cycles.py` checks), so any layer can be read and tested on its own:
//!
//! * `fit`, `tuning`, `diagnostics` — the entry points; `fit` owns unscaling, the status
//!   and the effective condition number, so that a solver only has to minimise J;
//! * `solvers` — `direct` (two-pass LSQ on Φ), `fast`, `active_set`, `svr` (with `ipm`
//!   and `data`), `qp`, and `solution`, the scaled-space result they all return;
//! * `params` (settings checked once) and `problem` (data validation, column scaling, the
//!   scaled problem both solver families share);
//! * `dense` — `kernels` (fused column passes and the one `dispatch!` that picks AVX-512,
//!   AVX2 + FMA or the baseline at run time), `small_eig`, `linalg`: fenced, they know
//!   nothing about estimators;
//! * `types` and `error` — the public value types and errors.
//!
//! faer runs with its global parallelism setting; call
//! `faer::set_global_parallelism(faer::Par::Seq)` when fits run in parallel (rayon) or
//! for single-core timings.
//!
//! ```
//! use faer::Mat;
//! use shipid_estimators::{Estimator, Solver, fit};
//!
//! let phi = Mat::<f64>::from_fn(50, 2, |i, j| ((i + 1) as f64 * 0.1).powi(j as i32 + 1));
//! let y: Vec<f64> = (0..50).map(|i| 2.0 * phi[(i, 0)] - 0.5 * phi[(i, 1)]).collect();
//! let f = fit(phi.as_ref(), &y, &Estimator::Lsq, None, Solver::Fast).unwrap();
//! assert!((f.coefficients[0] - 2.0).abs() < 1e-10);
//! assert!((f.coefficients[1] + 0.5).abs() < 1e-10);
//! ```

mod dense;
mod diagnostics;
mod error;
mod fit;
mod params;
mod problem;
mod solvers;
mod tuning;
mod types;

pub use diagnostics::{condition_number, contributions, scaled_condition_number, vif};
pub use error::EstimatorError;
pub use fit::{fit, objective, predict};
pub use params::{CheckedParams, Params};
pub use problem::column_scales;
pub use tuning::{
    CvPoint, Family, Folds, Tuning, default_epsilon_grid, default_grid, log_grid, tune, tune_svr,
};
pub use types::{
    Bounds, EXPLAINS_NOTHING_RATIO, Estimator, Fit, ILL_CONDITIONED_THRESHOLD, MAX_HYPER_PARAMETER,
    Solver, Status, explains_nothing,
};

/// Re-exported so that callers use the same faer version for designs.
pub use faer;
