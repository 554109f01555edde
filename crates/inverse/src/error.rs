//! Typed errors of the inverse-identification core.

use thiserror::Error;

/// A number as a message shows it: plain within 1e-6 … 1e15, in exponent form beyond (`1e300`, not
/// three hundred digits).
pub fn readable(value: &f64) -> String {
    shipid_io::error::number(*value)
}

/// Why an inverse-identification step could not be carried out.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum InverseError {
    /// The hydrodynamic database is unusable (too few ships, a non-finite value, copies of one ship,
    /// no variation beyond rounding…).
    #[error("hydrodynamic database: {0}")]
    Database(String),
    /// A target ship particular is missing or out of range; `key` names the TOML key.
    #[error("target {target}: {key} = {}: {reason}", readable(.value))]
    Target {
        target: String,
        key: &'static str,
        value: f64,
        reason: String,
    },
    /// A motion index is non-finite, has the wrong sign for its logarithm or is beyond what a ship's
    /// manoeuvre gives.
    #[error("motion {motion}: index {key} = {}: {reason}", readable(.value))]
    Index {
        motion: String,
        key: &'static str,
        value: f64,
        reason: String,
    },
    /// The SVD of the variation matrix failed.
    #[error("SVD of the hydrodynamic variation matrix failed: {0}")]
    Svd(String),
    /// A request that does not fit the modes or the network (wrong number of weights…).
    #[error("invalid request: {0}")]
    Invalid(String),
    /// Too few simulations gave all indexes to train a network; `reasons` counts why the others
    /// were dropped.
    #[error(
        "only {valid} of {total} simulated samples are usable; at least {needed} are needed (dropped: {reasons})"
    )]
    TooFewSamples {
        valid: usize,
        total: usize,
        needed: usize,
        reasons: String,
    },
}
