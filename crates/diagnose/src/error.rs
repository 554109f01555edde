//! Why a diagnosis cannot be made.

use thiserror::Error;

/// Why [`crate::diagnose`] returns no report.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum DiagnoseError {
    /// No recording has the 20 samples a replay segment and the differentiator need.
    #[error("no recording with at least 20 samples to diagnose")]
    NothingToDiagnose,
    /// Every recording is shorter than the shortest replay horizon.
    #[error(
        "every recording is too short to replay in segments: the longest lasts {longest_s:.1} s, a segment needs at least {needed_s:.1} s (0.5 L/U0)"
    )]
    TooShort { longest_s: f64, needed_s: f64 },
    /// The model with its own effects cannot be built.
    #[error("the model with its own effects cannot be built")]
    Model,
    /// A recording's recorded wind or current cannot be used as a known input.
    #[error("`{recording}`: its recorded environment cannot be used: {reason}")]
    Environment { recording: String, reason: String },
}
