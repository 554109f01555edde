//! Why a diagnosis cannot be made.

use thiserror::Error;

/// Why [`crate::diagnose`] returns no report.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum DiagnoseError {
    /// No recording has the 20 samples a replay segment and the differentiator need.
    #[error("no recording with at least 20 samples to diagnose")]
    NothingToDiagnose,
    /// The model with its own effects cannot be built.
    #[error("the model with its own effects cannot be built")]
    Model,
    /// A recording's recorded wind or current cannot be used as a known input.
    #[error("`{recording}`: its recorded environment cannot be used: {reason}")]
    Environment { recording: String, reason: String },
}
