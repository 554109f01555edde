//! The study crate's error.

use std::path::PathBuf;

use shipid_io::InputError;

/// Why a study could not be loaded, run or written.
#[derive(Debug, thiserror::Error)]
pub enum StudyError {
    /// The study file (or a file it names) is wrong; the message names the file and key.
    #[error(transparent)]
    Input(#[from] InputError),
    /// Reading or writing a result file failed.
    #[error("{}: {source}", path.display())]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    /// Another run holds the output folder's lock.
    #[error(
        "{}: another shipid run{} is writing into this folder; wait for it to finish or give another --out",
        path.display(),
        holder.map(|p| format!(" (pid {p})")).unwrap_or_default()
    )]
    Locked { path: PathBuf, holder: Option<u32> },
    /// The study is larger than a run takes without the user's consent (`--allow-large`).
    #[error(
        "{}: {why}: nothing was run; give --allow-large to run them all",
        path.display()
    )]
    TooLarge { path: PathBuf, why: String },
    /// The output folder holds the results of another study (or of an older version of this one).
    #[error("{}: {message}", path.display())]
    NotThisStudy { path: PathBuf, message: String },
    /// A symbolic link inside the output folder where a run writes: followed, it would write (or
    /// remove) outside the folder.
    #[error(
        "{}: a symbolic link (to {}) inside the output folder; shipid writes there and will not follow it out of the folder: remove the link or give another --out",
        path.display(),
        target.display()
    )]
    Link { path: PathBuf, target: PathBuf },
    /// A result table could not be written or read.
    #[error("{}: {message}", path.display())]
    Table { path: PathBuf, message: String },
}

impl StudyError {
    /// Whether the user's input is to blame.
    pub fn is_bad_input(&self) -> bool {
        matches!(
            self,
            StudyError::Input(_)
                | StudyError::Locked { .. }
                | StudyError::TooLarge { .. }
                | StudyError::NotThisStudy { .. }
                | StudyError::Link { .. }
        )
    }
}
