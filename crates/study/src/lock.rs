//! One writer per output folder: `shipid run` holds an OS advisory lock on `<out>/.shipid-run.lock`
//! while it writes there, so a second run into the same folder refuses at once instead of racing the
//! first over the same case files and tables.
//!
//! The lock is the kernel's (`flock`), not the file's existence: it goes with the process, so a run
//! killed with `kill -9` leaves the file but not the lock, and the next run takes it over (and says
//! so, naming the pid that held it). The file holds the holder's pid for the messages.

use std::fs::{File, OpenOptions, TryLockError};
use std::io::{Read, Seek, Write};
use std::path::{Path, PathBuf};

use crate::error::StudyError;

/// The lock file's name inside the output folder.
pub const LOCK_FILE: &str = ".shipid-run.lock";

/// Held while a run writes into its folder; released (and the file removed) when dropped.
#[derive(Debug)]
pub struct RunLock {
    path: PathBuf,
    /// The pid recorded by a holder that ended without releasing the lock (killed), if any.
    pub taken_over_from: Option<u32>,
    /// Never read: holding it open holds the OS lock. Dropped after `Drop::drop` removed the file,
    /// so the lock is released last.
    _held: File,
}

impl RunLock {
    /// Takes the lock of `out` (creating the folder), or refuses with [`StudyError::Locked`] when
    /// another process holds it.
    pub fn acquire(out: &Path) -> Result<RunLock, StudyError> {
        let path = out.join(LOCK_FILE);
        let io = |source| StudyError::Io {
            path: path.clone(),
            source,
        };
        std::fs::create_dir_all(out).map_err(|source| StudyError::Io {
            path: out.to_path_buf(),
            source,
        })?;
        // Opened for writing, a link planted at the lock's name would have its target truncated
        // and overwritten with a pid (or created): refused, never followed.
        if std::fs::symlink_metadata(&path).is_ok_and(|m| m.file_type().is_symlink()) {
            return Err(StudyError::Link {
                target: std::fs::read_link(&path).unwrap_or_default(),
                path,
            });
        }
        // A holder removes the file (while still locked) when it finishes; a run that opened the old
        // file just before must not take the lock of a file that is gone, so it checks and retries.
        for _ in 0..100 {
            let mut file = OpenOptions::new()
                .read(true)
                .write(true)
                .create(true)
                .truncate(false)
                .open(&path)
                .map_err(io)?;
            match file.try_lock() {
                Ok(()) => {}
                Err(TryLockError::WouldBlock) => {
                    return Err(StudyError::Locked {
                        path: path.clone(),
                        holder: read_pid(&mut file),
                    });
                }
                Err(TryLockError::Error(e)) => return Err(io(e)),
            }
            if !same_file(&file, &path) {
                continue;
            }
            let taken_over_from = read_pid(&mut file);
            file.set_len(0).map_err(io)?;
            file.rewind().map_err(io)?;
            writeln!(file, "pid {}", std::process::id()).map_err(io)?;
            file.sync_all().map_err(io)?;
            return Ok(RunLock {
                path,
                taken_over_from,
                _held: file,
            });
        }
        Err(io(std::io::Error::other(
            "the lock file kept being replaced by other runs",
        )))
    }

    /// The lock file's path.
    pub fn path(&self) -> &Path {
        &self.path
    }
}

impl Drop for RunLock {
    fn drop(&mut self) {
        // Removed while still locked (the file handle closes after this), so a waiting run sees
        // that its handle is stale and retries on a new file.
        let _ = std::fs::remove_file(&self.path);
    }
}

/// The pid a lock file records (`pid N`), if it holds one.
fn read_pid(file: &mut File) -> Option<u32> {
    let mut text = String::new();
    file.rewind().ok()?;
    file.read_to_string(&mut text).ok()?;
    text.trim().strip_prefix("pid ")?.trim().parse().ok()
}

#[cfg(unix)]
fn same_file(file: &File, path: &Path) -> bool {
    use std::os::unix::fs::MetadataExt;
    // The path itself, not what it points to: a link swapped in after the check above is not the
    // opened file, so the run retries rather than write through it.
    match (file.metadata(), std::fs::symlink_metadata(path)) {
        (Ok(a), Ok(b)) => a.dev() == b.dev() && a.ino() == b.ino(),
        _ => false,
    }
}

#[cfg(not(unix))]
fn same_file(_file: &File, path: &Path) -> bool {
    path.is_file()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_second_lock_of_one_folder_is_refused_naming_the_holder_and_released_on_drop() {
        let dir = tempfile::tempdir().unwrap();
        let first = RunLock::acquire(dir.path()).unwrap();
        assert_eq!(first.taken_over_from, None);
        match RunLock::acquire(dir.path()) {
            Err(StudyError::Locked { path, holder }) => {
                assert_eq!(path, dir.path().join(LOCK_FILE));
                assert_eq!(holder, Some(std::process::id()));
            }
            other => panic!("{other:?}"),
        }
        drop(first);
        assert!(!dir.path().join(LOCK_FILE).exists(), "removed on release");
        let again = RunLock::acquire(dir.path()).unwrap();
        assert_eq!(again.taken_over_from, None);
    }

    #[test]
    fn a_lock_file_left_by_a_killed_run_is_taken_over_naming_its_pid() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join(LOCK_FILE), "pid 4000000\n").unwrap();
        let lock = RunLock::acquire(dir.path()).unwrap();
        assert_eq!(lock.taken_over_from, Some(4_000_000));
        let text = std::fs::read_to_string(lock.path()).unwrap();
        assert_eq!(text, format!("pid {}\n", std::process::id()));
    }
}
