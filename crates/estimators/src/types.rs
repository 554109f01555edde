//! Public value types: estimators, solvers, bounds, fit results.

use serde::{Deserialize, Serialize};

use crate::error::EstimatorError;

/// Condition-number threshold above which a fit is reported as [`Status::IllConditioned`]:
/// 1/√ε_mach ≈ 6.7e7. Beyond it the least-squares sensitivity κ²·ε_mach exceeds 1, i.e. the
/// weakest direction of the coefficient vector is decided by rounding rather than by the
/// data. It is applied to the *effective* condition number of each fit, see [`Fit`].
pub const ILL_CONDITIONED_THRESHOLD: f64 = 6.7e7;

/// The largest λ, α, C or ε a fit takes: 1e15, about 1/ε_mach (4.5e15). Every objective works
/// on unit-RMS columns, so the data enter it at scale one (`ZᵀZ/n` has a unit diagonal): beyond
/// 1/ε_mach, `ZᵀZ/n + λI` rounds to `λI` and the Ridge solution no longer depends on how the
/// regressors relate to each other; a Lasso α or an SVR ε that large exceeds any target a
/// prime-system fit can have (all coefficients zero), and an SVR C that large makes `½‖γ‖²`
/// vanish below the rounding of the loss (an unregularised fit, which C far smaller gives as
/// well). Such a value is a typo or a probe, never a setting; what a merely large value does to a
/// fit is said by [`explains_nothing`].
pub const MAX_HYPER_PARAMETER: f64 = 1e15;

/// A fit whose residual RMS is at least this share of the target's RMS explains (almost) nothing
/// of it: within 0.1 %, the coefficients are as good as zero (a penalty or an ε-tube that swallowed
/// the data).
pub const EXPLAINS_NOTHING_RATIO: f64 = 0.999;

/// Whether a fit explains (almost) nothing of its target: every coefficient zero, or the residual
/// RMS within 0.1 % of the target's ([`EXPLAINS_NOTHING_RATIO`]). Such a fit is solved (its status
/// may be `Ok`) but is not a model of the data: `--c 1 --epsilon 0.01` on prime forces, whose
/// spread lies inside the ε-tube, gives all zeros. A target that is itself zero has nothing to
/// explain, so it does not count.
pub fn explains_nothing(coefficients: &[f64], residual_rms: f64, target_rms: f64) -> bool {
    if target_rms.is_nan() || target_rms <= 0.0 {
        return false;
    }
    coefficients.iter().all(|&b| b == 0.0) || residual_rms >= EXPLAINS_NOTHING_RATIO * target_rms
}

/// A per-degree-of-freedom estimator and its hyper-parameters.
///
/// The objectives (documented in detail at the crate root) are, with `n` samples,
/// column RMS scales `s_j` and `γ_j = s_j β_j`:
///
/// | variant | objective |
/// |---|---|
/// | `Lsq`, `BoundedLsq` | `(1/2n)‖Φβ − y‖²` |
/// | `Ridge { lambda }` | `(1/2n)‖Φβ − y‖² + (λ/2)‖γ‖²` |
/// | `Lasso { alpha }` | `(1/2n)‖Φβ − y‖² + α‖γ‖₁` |
/// | `Svr { c, epsilon }` | `½‖γ‖² + C Σᵢ max(0, |yᵢ − φᵢβ| − ε)` |
///
/// `Lsq` and `BoundedLsq` minimise the same objective and both honour bounds when given;
/// the two names mirror the paper's "LSQ" baseline and its constrained variant.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Estimator {
    Lsq,
    BoundedLsq,
    Ridge { lambda: f64 },
    Lasso { alpha: f64 },
    Svr { c: f64, epsilon: f64 },
}

impl Estimator {
    /// Short lower-case name, e.g. for tables.
    pub fn name(&self) -> &'static str {
        match self {
            Estimator::Lsq => "lsq",
            Estimator::BoundedLsq => "bounded_lsq",
            Estimator::Ridge { .. } => "ridge",
            Estimator::Lasso { .. } => "lasso",
            Estimator::Svr { .. } => "svr",
        }
    }

    pub(crate) fn validate(&self) -> Result<(), EstimatorError> {
        let check = |name: &'static str, value: f64| {
            if value.is_finite() && (0.0..=MAX_HYPER_PARAMETER).contains(&value) {
                Ok(())
            } else {
                Err(EstimatorError::InvalidHyperParameter { name, value })
            }
        };
        match *self {
            Estimator::Lsq | Estimator::BoundedLsq => Ok(()),
            Estimator::Ridge { lambda } => check("lambda", lambda),
            Estimator::Lasso { alpha } => check("alpha", alpha),
            Estimator::Svr { c, epsilon } => {
                check("c", c)?;
                check("epsilon", epsilon)
            }
        }
    }
}

/// Which algorithm solves the problem. Both minimise the same objective.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Solver {
    /// Reference: the problem as a convex QP solved by clarabel's interior-point method,
    /// the way the paper used CVXPY.
    Qp,
    /// Special-purpose solvers: QR / Cholesky for LSQ and Ridge, an exact active-set method
    /// for bounds and the ℓ1 penalty, smoothed Newton with continuation plus an exact
    /// active-set finish for SVR.
    Fast,
}

impl Solver {
    /// The solver's name on the command line, in study files and in model files.
    pub fn name(self) -> &'static str {
        match self {
            Solver::Qp => "qp",
            Solver::Fast => "fast",
        }
    }
}

impl std::str::FromStr for Solver {
    type Err = EstimatorError;

    /// The inverse of [`Solver::name`].
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "qp" => Ok(Solver::Qp),
            "fast" => Ok(Solver::Fast),
            other => Err(EstimatorError::UnknownSolver(other.into())),
        }
    }
}

/// Per-coefficient bounds `lower[j] ≤ β_j ≤ upper[j]` on the *unscaled* coefficients.
/// Infinite entries mean "no bound".
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Bounds {
    pub lower: Vec<f64>,
    pub upper: Vec<f64>,
}

impl Bounds {
    /// Checked constructor: equal lengths, no NaN, `lower ≤ upper`, `lower < +∞`, `upper > −∞`.
    pub fn new(lower: Vec<f64>, upper: Vec<f64>) -> Result<Self, EstimatorError> {
        let b = Bounds { lower, upper };
        b.validate_pairs()?;
        Ok(b)
    }

    /// No bound on any of `p` coefficients.
    pub fn unbounded(p: usize) -> Self {
        Bounds {
            lower: vec![f64::NEG_INFINITY; p],
            upper: vec![f64::INFINITY; p],
        }
    }

    pub fn len(&self) -> usize {
        self.lower.len()
    }

    pub fn is_empty(&self) -> bool {
        self.lower.is_empty()
    }

    /// True when no coefficient is bounded on either side.
    pub fn is_unbounded(&self) -> bool {
        self.lower.iter().all(|&l| l == f64::NEG_INFINITY)
            && self.upper.iter().all(|&u| u == f64::INFINITY)
    }

    /// True when every coefficient lies within its bounds.
    pub fn contains(&self, beta: &[f64]) -> bool {
        beta.len() == self.len()
            && beta
                .iter()
                .zip(self.lower.iter().zip(&self.upper))
                .all(|(&b, (&l, &u))| l <= b && b <= u)
    }

    /// Against a design of `p` columns: the lengths first, then the pairs.
    pub(crate) fn validate(&self, p: usize) -> Result<(), EstimatorError> {
        if self.lower.len() != p {
            return Err(EstimatorError::LengthMismatch {
                what: "lower bounds",
                expected: p,
                got: self.lower.len(),
            });
        }
        self.validate_pairs()
    }

    /// Without a design: upper bounds as many as lower bounds, and every pair usable.
    pub(crate) fn validate_pairs(&self) -> Result<(), EstimatorError> {
        if self.upper.len() != self.lower.len() {
            return Err(EstimatorError::LengthMismatch {
                what: "upper bounds",
                expected: self.lower.len(),
                got: self.upper.len(),
            });
        }
        for (index, (&lower, &upper)) in self.lower.iter().zip(&self.upper).enumerate() {
            let ok = !lower.is_nan()
                && !upper.is_nan()
                && lower <= upper
                && lower < f64::INFINITY
                && upper > f64::NEG_INFINITY;
            if !ok {
                return Err(EstimatorError::InvalidBounds {
                    index,
                    lower,
                    upper,
                });
            }
        }
        Ok(())
    }
}

/// The solver's status, turned into `IllConditioned` when the effective condition number
/// exceeds [`ILL_CONDITIONED_THRESHOLD`] (or is NaN). Here rather than with the fit logic
/// because the direct LSQ path, below it, judges its fits by the same rule.
pub(crate) fn status_from(status: Status, condition_number: Option<f64>) -> Status {
    match (status, condition_number) {
        (Status::Ok, Some(k)) if k.is_nan() || k > ILL_CONDITIONED_THRESHOLD => {
            Status::IllConditioned {
                condition_number: k,
            }
        }
        (s, _) => s,
    }
}

/// Outcome of a solve. Only `Ok`, `IllConditioned` and `RankDeficient` carry a solution
/// that met the solver's own accuracy criterion; the others carry the best iterate found.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "status", rename_all = "snake_case")]
pub enum Status {
    Ok,
    /// Solved, but the effective condition number (see [`Fit::condition_number`]) exceeds
    /// [`ILL_CONDITIONED_THRESHOLD`]: weakly determined coefficient combinations are not
    /// reliable even though the objective value is.
    IllConditioned {
        condition_number: f64,
    },
    /// clarabel stopped at its reduced-accuracy tolerances (`AlmostSolved`).
    ReducedAccuracy,
    /// Iteration (or time) limit reached.
    MaxIterations,
    /// The solver failed; the text says how.
    SolverFailed(String),
    /// Solved, but some columns of the design are identically zero: the data say nothing
    /// about their coefficients, which are set to the value of `[lower, upper]` closest to 0
    /// (e.g. a window that ends before the rudder first moves). Not a usable model.
    RankDeficient {
        /// The zero columns (indices into the design), as [`Fit::zero_columns`].
        zero_columns: Vec<usize>,
    },
}

impl Status {
    /// `Ok`, `IllConditioned` or `RankDeficient`: the solver met its accuracy criterion
    /// (for a rank-deficient design on the columns that carry information).
    pub fn is_solved(&self) -> bool {
        matches!(
            self,
            Status::Ok | Status::IllConditioned { .. } | Status::RankDeficient { .. }
        )
    }

    /// `Ok` or `IllConditioned`: every coefficient is determined by the data.
    pub fn is_identified(&self) -> bool {
        matches!(self, Status::Ok | Status::IllConditioned { .. })
    }
}

/// Result of one fit.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Fit {
    /// Unscaled coefficients β (prime system), one per design column.
    pub coefficients: Vec<f64>,
    /// The documented objective (see [`Estimator`]) evaluated at `coefficients`: the value
    /// [`crate::objective`] gives, to the last bit except on the direct LSQ path, which
    /// updates its refinement step's residual sum of squares algebraically (to rounding).
    pub objective: f64,
    pub status: Status,
    /// Interior-point iterations (`Qp`); active-set iterations, Newton steps or 1 for a
    /// direct factorisation (`Fast`).
    pub iterations: usize,
    pub solver: Solver,
    pub estimator: Estimator,
    /// Effective condition number the status is judged on, in the column-scaled space:
    /// κ(Z_F) of the columns not held at a bound (LSQ, bounded LSQ) or not zero (Lasso);
    /// √((σ²_max + nλ)/(σ²_min + nλ)) of those columns for Ridge; `None` for SVR, whose
    /// ½‖γ‖² term makes it well posed for any design.
    pub condition_number: Option<f64>,
    /// Columns that are identically zero. They carry no information; their coefficient is
    /// set to the value in `[lower, upper]` closest to 0 (the minimum-norm choice).
    pub zero_columns: Vec<usize>,
}
