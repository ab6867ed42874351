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
mod archive;
mod checksum;
mod lock;
mod pool;
mod records;
mod staging;
mod verify;

use std::path::{Path, PathBuf};

pub(crate) use address::{VERSION, cell_hash, inputs_identity, reference_hash};
pub(crate) use archive::recorded_but_absent;
pub(crate) use checksum::{FileCheck, first_mismatch};
pub(crate) use lock::{
    CellLock, cell_is_locked, lock_folder, lock_reference, lock_tune, try_lock_cell,
};
pub(crate) use pool::{ReferencePool, verified_reference};
pub(crate) use records::*;
pub(crate) use staging::{StagedDir, clean_stale};
pub(crate) use verify::{CELL_FILES, CellState, cell_state, is_done};

/// A path as a record keeps it: relative to the working folder when inside it, else `…/`
/// and its file name (no folder of the machine that wrote the record).
pub(crate) fn recorded_path(path: &Path) -> String {
    if !path.is_absolute() {
        return path.display().to_string();
    }
    match std::env::current_dir()
        .ok()
        .and_then(|c| path.strip_prefix(c).ok().map(Path::to_path_buf))
    {
        Some(rel) => rel.display().to_string(),
        None => format!(
            "…/{}",
            path.file_name()
                .map_or(String::new(), |f| f.to_string_lossy().into_owned())
        ),
    }
}

/// The command line as a record keeps it: the program as `sweep`, every argument that is an
/// absolute path inside the working folder relative to it, and one outside it as `…/` and
/// its file name, so that a committed record carries no path of the machine that wrote it
/// (`/home/…/target/release/sweep`, `/root/.cache/…/python`).
pub(crate) fn recorded_command() -> Vec<String> {
    let cwd = std::env::current_dir().ok();
    std::env::args()
        .enumerate()
        .map(|(i, a)| {
            if i == 0 {
                return "sweep".to_string();
            }
            let path = std::path::Path::new(&a);
            if !path.is_absolute() {
                return a;
            }
            match cwd.as_deref().and_then(|c| path.strip_prefix(c).ok()) {
                Some(rel) => rel.display().to_string(),
                None => format!(
                    "…/{}",
                    path.file_name()
                        .map_or(String::new(), |f| f.to_string_lossy().into_owned())
                ),
            }
        })
        .collect()
}

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

pub(crate) use volphot::hostname;

/// What a sweep output folder holds at its top level.
const OUTPUT_ENTRIES: [&str; 14] = [
    ".lock",
    "plan.json",
    "experiment.toml",
    "cells",
    "references",
    "figures",
    "failed",
    "slurm",
    "cells.csv",
    "cells.json",
    "report.md",
    "report.html",
    "explorer",
    "tune",
];

/// What [`check_owner`] asks of an experiment: its name, its file and that file's sha256.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Owner<'a> {
    /// The experiment's `name`.
    pub(crate) name: &'a str,
    /// The experiment file.
    pub(crate) path: &'a std::path::Path,
    /// The file's content hash.
    pub(crate) sha256: &'a str,
}

/// Refuses an output folder that belongs to another experiment: its `plan.json` names
/// another, or the same name from another file with other content (a different study that
/// happens to share the name would replace its cells, tables and reports); or a folder
/// that holds anything a sweep run did not write. A new or empty folder, one of this
/// experiment file (edited or not), or one written from a copy of it, is fine.
pub(crate) fn check_owner(out: &OutputDir, experiment: &Owner<'_>) -> anyhow::Result<()> {
    if let Ok(plan) = read_plan(out) {
        anyhow::ensure!(
            plan.experiment == experiment.name,
            "{} holds the cells of experiment `{}` (from {}), not `{}`; choose another --output or remove that folder",
            out.root().display(),
            plan.experiment,
            plan.experiment_file.display(),
            experiment.name
        );
        let same_file = match (
            std::fs::canonicalize(&plan.experiment_file),
            std::fs::canonicalize(experiment.path),
        ) {
            (Ok(a), Ok(b)) => a == b,
            _ => false,
        };
        anyhow::ensure!(
            same_file || plan.experiment_sha256 == experiment.sha256,
            "{} holds the cells of experiment `{}` from {} (sha256 {}…), and {} is another file with other content under the same name; choose another --output, or remove that folder to replace its study",
            out.root().display(),
            plan.experiment,
            plan.experiment_file.display(),
            &plan.experiment_sha256.get(..12).unwrap_or(""),
            experiment.path.display(),
        );
        return Ok(());
    }
    let Ok(entries) = std::fs::read_dir(out.root()) else {
        return Ok(());
    };
    let foreign: Vec<String> = entries
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| !OUTPUT_ENTRIES.contains(&n.as_str()) && !n.starts_with('.'))
        .collect();
    anyhow::ensure!(
        foreign.is_empty(),
        "{} is not a sweep output folder and not empty (it holds {}); choose a new or empty --output",
        out.root().display(),
        foreign
            .iter()
            .take(5)
            .map(|n| format!("`{n}`"))
            .collect::<Vec<_>>()
            .join(", ")
    );
    Ok(())
}
