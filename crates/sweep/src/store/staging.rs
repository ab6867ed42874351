//! Staging: a cell or reference folder is filled under a temporary sibling name and renamed
//! into place when complete, so an interrupted run leaves no half-written folder; stale
//! temporary folders of dead processes on this host are removed on the next run.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};

use super::{hostname, is_done};

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

    /// Renames the folder into place (replacing an unfinished one).
    pub(crate) fn commit(self) -> Result<()> {
        if self.target.exists() && !is_done(&self.target) {
            let _ = std::fs::remove_dir_all(&self.target);
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

/// Removes temporary folders left by processes of this host that no longer run. Folders
/// of other hosts (a shared file system on a cluster) are left alone.
pub(crate) fn clean_stale(dir: &Path) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    let host = hostname();
    for entry in entries.flatten() {
        let name = entry.file_name().to_string_lossy().into_owned();
        let Some((_, owner)) = name.rsplit_once(".tmp-") else {
            continue;
        };
        let Some((owner_host, pid)) = owner.rsplit_once('-') else {
            continue;
        };
        if owner_host == host
            && let Ok(pid) = pid.parse::<u32>()
            && !Path::new(&format!("/proc/{pid}")).exists()
        {
            let _ = std::fs::remove_dir_all(entry.path());
        }
    }
}
