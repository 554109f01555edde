//! Typed errors for invalid input to the GP. Optimiser outcomes are not errors: they are reported in
//! [`crate::Training`].

use thiserror::Error;

/// Invalid input to sparsification, training or prediction.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum GpError {
    /// No training points, or points with no input dimension.
    #[error("empty data: {points} points with {dims} input dimensions")]
    Empty { points: usize, dims: usize },

    /// Two inputs whose sizes must match do not.
    #[error("length mismatch for {what}: expected {expected}, got {got}")]
    LengthMismatch {
        what: &'static str,
        expected: usize,
        got: usize,
    },

    /// A NaN or infinite value in the data.
    #[error("non-finite value {value} in {what} at index {index}")]
    NonFinite {
        what: &'static str,
        index: usize,
        value: f64,
    },

    /// A hyper-parameter or option outside its domain (length scales and standard deviations must be
    /// positive and finite, the similarity threshold in (0, 1]).
    #[error("invalid {what}: {value}")]
    InvalidParameter { what: &'static str, value: f64 },

    /// K + σ_n² I is not numerically positive definite for these hyper-parameters.
    #[error(
        "the covariance matrix is not positive definite (noise std {noise_std} too small for the data?)"
    )]
    NotPositiveDefinite { noise_std: f64 },
}
