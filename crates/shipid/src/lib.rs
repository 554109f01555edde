//! The `shipid` command line: glue between the crates. Each subcommand lives in its own module and
//! returns an [`Outcome`] or a [`CliError`]; `main` turns them into output and exit codes
//! (0 all ok, 1 some case failed, 2 bad input).

pub mod diagnose_cmd;
pub mod fit_cmd;
pub mod import;
pub mod inverse_cmd;
pub mod metrics_cmd;
pub mod outputs;
pub mod print;
pub mod report_cmd;
pub mod simulate_cmd;
pub mod study_cmd;
pub mod validate_cmd;

use std::fmt;

/// How a command ended when it ran to completion.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Outcome {
    /// Everything succeeded.
    Ok,
    /// It ran, but some cases (simulations, fits) failed or diverged; their status is in the output.
    SomeFailed,
}

/// A command that could not run.
#[derive(Debug)]
pub enum CliError {
    /// The user's input is wrong (file, key, argument): exit code 2.
    BadInput(anyhow::Error),
    /// Something else failed (writing results …): exit code 1.
    Failed(anyhow::Error),
}

impl fmt::Display for CliError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            CliError::BadInput(e) | CliError::Failed(e) => write!(f, "{e:#}"),
        }
    }
}

impl CliError {
    pub fn exit_code(&self) -> i32 {
        match self {
            CliError::BadInput(_) => 2,
            CliError::Failed(_) => 1,
        }
    }
}

impl CliError {
    /// A library error as the exit code it deserves: the user's input (2) or a failure (1).
    fn classified(e: impl Into<anyhow::Error>, is_bad_input: bool) -> CliError {
        if is_bad_input {
            CliError::BadInput(e.into())
        } else {
            CliError::Failed(e.into())
        }
    }
}

impl From<shipid_pipeline::PipelineError> for CliError {
    fn from(e: shipid_pipeline::PipelineError) -> Self {
        let bad = e.is_bad_input();
        CliError::classified(e, bad)
    }
}

impl From<shipid_study::StudyError> for CliError {
    fn from(e: shipid_study::StudyError) -> Self {
        let bad = e.is_bad_input();
        CliError::classified(e, bad)
    }
}

impl From<shipid_io::InputError> for CliError {
    fn from(e: shipid_io::InputError) -> Self {
        CliError::BadInput(e.into())
    }
}

/// Shorthand for an input error with a message.
pub fn bad_input(msg: impl fmt::Display) -> CliError {
    CliError::BadInput(anyhow::anyhow!("{msg}"))
}

/// Shorthand for a failure to write or compute.
pub fn failed(e: impl Into<anyhow::Error>) -> CliError {
    CliError::Failed(e.into())
}

/// A failure whose message is all there is to say.
pub fn failed_msg(msg: impl fmt::Display) -> CliError {
    CliError::Failed(anyhow::anyhow!("{msg}"))
}

/// A failed write, naming the file (an `io::Error` alone says only "No such file or directory").
pub fn write_failed(path: &std::path::Path, e: impl fmt::Display) -> CliError {
    CliError::Failed(anyhow::anyhow!("cannot write {}: {e}", path.display()))
}

/// A result computed but not written: the message says what is lost, so a failure after minutes of
/// work is not mistaken for a failure before it.
pub fn not_saved(path: &std::path::Path, e: impl fmt::Display, what: &str) -> CliError {
    CliError::Failed(anyhow::anyhow!(
        "cannot write {}: {e}: {what} was computed but not saved; give a writable path and run again",
        path.display()
    ))
}
