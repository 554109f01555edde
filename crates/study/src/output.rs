//! The output folder's own entries must be its own: a symbolic link planted inside it (`figures` →
//! elsewhere, `cases/<id>` → elsewhere, `.shipid-run.lock` → a file) would have a run write, or
//! remove stale figures, outside the folder it was given. The folder itself may be a link: the
//! user named it.

use std::path::{Path, PathBuf};

use crate::error::StudyError;
use crate::lock::LOCK_FILE;

/// Refuses the links among what a run or `shipid plot` writes into `out`: `cases/`, each entry of
/// `cases/`, `figures/`, each entry of `figures/` (a figure is written through its path, so a link
/// there would be followed), and the lock file. The first found is named with its target.
pub fn refuse_links(out: &Path) -> Result<(), StudyError> {
    let mut candidates: Vec<PathBuf> = vec![out.join(LOCK_FILE)];
    for sub in ["cases", "figures"] {
        let dir = out.join(sub);
        candidates.push(dir.clone());
        // Only a real folder is listed: a linked one is refused above without looking into it.
        if is_link(&dir) {
            continue;
        }
        if let Ok(entries) = std::fs::read_dir(&dir) {
            let mut inside: Vec<PathBuf> = entries.flatten().map(|e| e.path()).collect();
            inside.sort();
            candidates.extend(inside);
        }
    }
    match candidates.into_iter().find(|p| is_link(p)) {
        Some(path) => {
            let target = std::fs::read_link(&path).unwrap_or_default();
            Err(StudyError::Link { path, target })
        }
        None => Ok(()),
    }
}

/// Whether `path` is a symbolic link (not followed).
pub fn is_link(path: &Path) -> bool {
    std::fs::symlink_metadata(path).is_ok_and(|m| m.file_type().is_symlink())
}
