//! The estimators of the mmg family's hull derivatives, by name. No I/O.

use crate::error::{PipelineError, bad_input};

/// How the hull derivatives are solved inside: bounded least squares on the prior-augmented design
/// (the physical sign bounds of the priors hold), or the same without bounds (a ridge toward the
/// prior).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MmgEstimator {
    BoundedLsq,
    Ridge,
}

impl MmgEstimator {
    pub fn name(self) -> &'static str {
        match self {
            MmgEstimator::BoundedLsq => "bounded-lsq",
            MmgEstimator::Ridge => "ridge",
        }
    }

    /// `bounded-lsq` or `ridge`.
    pub fn parse(name: &str) -> Result<MmgEstimator, PipelineError> {
        match name {
            "bounded-lsq" => Ok(MmgEstimator::BoundedLsq),
            "ridge" => Ok(MmgEstimator::Ridge),
            other => Err(bad_input(format!(
                "estimator `{other}` does not apply to --set mmg: expected bounded-lsq or ridge"
            ))),
        }
    }
}
