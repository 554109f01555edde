//! The pipeline's error: either the user's input is wrong (exit 2 at the command line) or something
//! that was given correctly could not be computed or written (exit 1).

use shipid_io::InputError;

/// Why a pipeline step could not run.
#[derive(Debug, thiserror::Error)]
pub enum PipelineError {
    /// A file, key or argument is wrong; the message names it.
    #[error(transparent)]
    Input(#[from] InputError),
    /// A value given by the user is wrong; the message names the flag, key or file.
    #[error("{0}")]
    BadInput(String),
    /// The input was fine but the work failed (a write, an internal simulation that must not fail).
    #[error("{0}")]
    Failed(String),
}

impl PipelineError {
    /// Whether the user's input is to blame (as opposed to a failed computation or write).
    pub fn is_bad_input(&self) -> bool {
        matches!(self, PipelineError::Input(_) | PipelineError::BadInput(_))
    }
}

/// Shorthand for an input error with a message.
pub fn bad_input(msg: impl std::fmt::Display) -> PipelineError {
    PipelineError::BadInput(msg.to_string())
}

/// Shorthand for a failure to compute or write.
pub fn failed(msg: impl std::fmt::Display) -> PipelineError {
    PipelineError::Failed(msg.to_string())
}
