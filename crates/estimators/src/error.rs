//! Typed errors for invalid input. Solver outcomes are not errors: they are reported in
//! [`crate::Status`].

use thiserror::Error;

/// Invalid input to an estimator, a tuning run or a diagnostic.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum EstimatorError {
    /// The design has no rows or no columns.
    #[error("empty design: {rows} rows x {cols} columns")]
    EmptyDesign { rows: usize, cols: usize },

    /// Two inputs that must have matching sizes do not.
    #[error("length mismatch for {what}: expected {expected}, got {got}")]
    LengthMismatch {
        what: &'static str,
        expected: usize,
        got: usize,
    },

    /// A NaN or infinite value in the design (`column` is `Some`) or in a vector.
    #[error("non-finite value {value} in {what} at row {row}{}", column.map(|c| format!(", column {c}")).unwrap_or_default())]
    NonFinite {
        what: &'static str,
        row: usize,
        column: Option<usize>,
        value: f64,
    },

    /// A bound pair with `lower > upper`, a NaN bound, `lower = +inf` or `upper = -inf`.
    #[error("invalid bounds for coefficient {index}: lower {lower}, upper {upper}")]
    InvalidBounds {
        index: usize,
        lower: f64,
        upper: f64,
    },

    /// A hyper-parameter that is negative, NaN, infinite or beyond
    /// [`crate::MAX_HYPER_PARAMETER`].
    #[error(
        "hyper-parameter {name} = {} must be finite, >= 0 and <= 1e15",
        readable(*value)
    )]
    InvalidHyperParameter { name: &'static str, value: f64 },

    /// A cross-validation fold specification that cannot be used.
    #[error("invalid folds: {0}")]
    InvalidFolds(String),

    /// A solver name other than `qp` and `fast`.
    #[error("unknown solver `{0}`: expected qp or fast")]
    UnknownSolver(String),

    /// An empty tuning grid.
    #[error("the tuning grid is empty")]
    EmptyGrid,

    /// A dense decomposition inside faer did not converge (faer's own error types do not
    /// implement `std::error::Error`, so they are carried as text).
    #[error("decomposition failed: {0}")]
    Decomposition(String),
}

impl From<faer::linalg::solvers::SvdError> for EstimatorError {
    fn from(e: faer::linalg::solvers::SvdError) -> Self {
        EstimatorError::Decomposition(format!("SVD: {e:?}"))
    }
}

impl From<faer::linalg::solvers::EvdError> for EstimatorError {
    fn from(e: faer::linalg::solvers::EvdError) -> Self {
        EstimatorError::Decomposition(format!("self-adjoint eigendecomposition: {e:?}"))
    }
}

/// A value as a reader takes it in: `1e300` rather than its 301 digits.
fn readable(x: f64) -> String {
    if x.is_finite() && x != 0.0 && !(1e-4..1e6).contains(&x.abs()) {
        format!("{x:e}")
    } else {
        format!("{x}")
    }
}
