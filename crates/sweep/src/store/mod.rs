//! The output folder: where a run's cells, references, plan and report live, and how they
//! are addressed, locked and written.
//!
//! ```text
//! OUTPUT/plan.json  experiment.toml  cells.csv  cells.json  report.md  report.html  figures/
//! OUTPUT/cells/<hash>/{film.exr, total.png, single.png, multiple.png, cell.json, vs-<ref>.json}
//! OUTPUT/references/<key>/{reference.exr, reference.png, reference.json}
//! OUTPUT/failed/<hash>.txt   OUTPUT/slurm/
//! ```

mod address;
mod lock;
mod records;
mod staging;

use std::path::{Path, PathBuf};

pub(crate) use address::{cell_hash, reference_hash, volume_identity};
pub(crate) use lock::{CellLock, cell_is_locked, lock_folder, lock_reference, try_lock_cell};
pub(crate) use records::*;
pub(crate) use staging::{StagedDir, clean_stale};

/// Program version recorded in every output.
pub(crate) const VERSION: &str = env!("CARGO_PKG_VERSION");

/// Paths inside an output folder.
#[derive(Debug, Clone)]
pub(crate) struct OutputDir {
    root: PathBuf,
}

impl OutputDir {
    /// The output folder.
    pub(crate) fn new(root: impl Into<PathBuf>) -> Self {
        OutputDir { root: root.into() }
    }

    /// The folder itself.
    pub(crate) fn root(&self) -> &Path {
        &self.root
    }

    /// `cells/<hash>`.
    pub(crate) fn cell(&self, hash: &str) -> PathBuf {
        self.root.join("cells").join(hash)
    }

    /// `references/<key>`.
    pub(crate) fn reference(&self, key: &str) -> PathBuf {
        self.root.join("references").join(key)
    }

    /// `cells/.<hash>.lock`: the lock a process holds while rendering the cell.
    pub(crate) fn cell_lock(&self, hash: &str) -> PathBuf {
        self.root.join("cells").join(format!(".{hash}.lock"))
    }

    /// `failed/<hash>.txt`: the error of a failed cell.
    pub(crate) fn failure(&self, hash: &str) -> PathBuf {
        self.root.join("failed").join(format!("{hash}.txt"))
    }

    /// `figures/`.
    pub(crate) fn figures(&self) -> PathBuf {
        self.root.join("figures")
    }

    /// The plan written by `run` (`plan.json`).
    pub(crate) fn plan(&self) -> PathBuf {
        self.root.join("plan.json")
    }
}

/// This machine's host name (cells rendered on a cluster record where they ran).
pub(crate) fn hostname() -> String {
    std::fs::read_to_string("/proc/sys/kernel/hostname")
        .map(|h| h.trim().to_string())
        .ok()
        .filter(|h| !h.is_empty())
        .or_else(|| std::env::var("HOSTNAME").ok())
        .unwrap_or_else(|| "localhost".into())
}
