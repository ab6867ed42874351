//! Staging: a cell or reference folder is filled under a temporary sibling name and renamed
//! into place when complete, so an interrupted run leaves no half-written folder; stale
//! temporary folders of dead processes on this host are removed on the next run.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};

use super::hostname;

/// A cell folder being filled: a temporary sibling renamed into place by [`StagedDir::commit`].
pub(crate) struct StagedDir {
    tmp: PathBuf,
    target: PathBuf,
}

impl StagedDir {
    /// Creates `.<target>.tmp-<host>-<pid>` (removing a stale one).
    pub(crate) fn new(target: &Path) -> Result<Self> {
        let name = target
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        let tmp =
            target.with_file_name(format!(".{name}.tmp-{}-{}", hostname(), std::process::id()));
        let _ = std::fs::remove_dir_all(&tmp);
        std::fs::create_dir_all(&tmp).with_context(|| format!("creating {}", tmp.display()))?;
        Ok(StagedDir {
            tmp,
            target: target.to_path_buf(),
        })
    }

    /// Where to write files.
    pub(crate) fn path(&self) -> &Path {
        &self.tmp
    }

    /// Renames the folder into place, replacing what was there (an unfinished or damaged
    /// folder: the caller holds the cell's lock and decided to render it).
    pub(crate) fn commit(self) -> Result<()> {
        if self.target.exists() {
            std::fs::remove_dir_all(&self.target)
                .with_context(|| format!("replacing {}", self.target.display()))?;
        }
        std::fs::rename(&self.tmp, &self.target)
            .with_context(|| format!("moving {} to {}", self.tmp.display(), self.target.display()))
    }
}

impl Drop for StagedDir {
    fn drop(&mut self) {
        // Not committed (error or panic): leave nothing half-written behind.
        let _ = std::fs::remove_dir_all(&self.tmp);
    }
}

/// Removes temporary files and folders (`….tmp-HOST-PID…`) left in `dir` by processes of
/// this host that no longer run: a killed render's staged cell, a killed report's half-written
/// figure. Other hosts' temporaries (a shared file system on a cluster) are left alone.
pub(crate) fn clean_stale(dir: &Path) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for entry in entries.flatten() {
        if volphot::is_stale_temp(&entry.file_name().to_string_lossy()) {
            let path = entry.path();
            let _ = if path.is_dir() {
                std::fs::remove_dir_all(&path)
            } else {
                std::fs::remove_file(&path)
            };
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_staged_folder_appears_whole_or_not_at_all() {
        let tmp = tempfile::tempdir().unwrap();
        let target = tmp.path().join("cell");
        let staged = StagedDir::new(&target).unwrap();
        std::fs::write(staged.path().join("film.exr"), b"x").unwrap();
        assert!(!target.exists(), "nothing visible before commit");
        staged.commit().unwrap();
        assert!(target.join("film.exr").is_file());
        // Dropped without commit (an error or a panic): the temporary folder is removed.
        let other = tmp.path().join("other");
        let staged = StagedDir::new(&other).unwrap();
        let tmp_path = staged.path().to_path_buf();
        drop(staged);
        assert!(!tmp_path.exists() && !other.exists());
    }

    #[test]
    fn stale_folders_of_dead_processes_on_this_host_are_removed() {
        let tmp = tempfile::tempdir().unwrap();
        let host = hostname();
        // A pid that cannot exist (above pid_max) and this process's own pid.
        let dead = tmp.path().join(format!(".a.tmp-{host}-4294967295"));
        let alive = tmp
            .path()
            .join(format!(".b.tmp-{host}-{}", std::process::id()));
        let foreign = tmp.path().join(".c.tmp-another-host-4294967295");
        for d in [&dead, &alive, &foreign] {
            std::fs::create_dir_all(d).unwrap();
        }
        clean_stale(tmp.path());
        assert!(!dead.exists());
        assert!(alive.exists(), "a running process's folder stays");
        assert!(foreign.exists(), "other hosts' folders are left alone");
    }
}
