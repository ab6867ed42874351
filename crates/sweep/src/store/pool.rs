//! A reference pool: path-traced references shared by the output folders of several
//! studies (`sweep run --reference-pool DIR`), so a scene that two studies compare against
//! is traced once, at the larger sample count, instead of once per study.
//!
//! ```text
//! DIR/<key>/<passes>/{reference.exr, reference.png, reference.json}   a finished reference
//! DIR/<key>/state/{state.bin, reference.json}   the accumulator after the most passes yet
//! DIR/<key>.lock
//! ```
//!
//! A study that asks for `n` passes gets the pool's `n`-pass reference, or one refined to
//! `n` passes from the largest state below `n`. States are exact
//! ([`volphot::ReferenceAccumulator::write_state`]), so the image is the one a study alone
//! would render, bit for bit, whichever studies ran first.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};

use super::lock::{ReferenceLock, lock_path};
use super::{ReferenceRecord, first_mismatch, read_reference_record};

/// The accumulator state's file in `<key>/state/`.
pub(crate) const STATE_FILE: &str = "state.bin";

/// A folder of references shared between output folders.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct ReferencePool {
    root: PathBuf,
}

impl ReferencePool {
    /// The pool in `root` (created when first written).
    pub(crate) fn new(root: impl Into<PathBuf>) -> Self {
        ReferencePool { root: root.into() }
    }

    /// The pool's folder.
    pub(crate) fn root(&self) -> &Path {
        &self.root
    }

    /// `<key>/<passes>`: the reference `key` at `passes` samples per pixel.
    pub(crate) fn film(&self, key: &str, passes: u32) -> PathBuf {
        self.root.join(key).join(passes.to_string())
    }

    /// `<key>/state`: the accumulator of `key` after the most passes rendered yet.
    pub(crate) fn state(&self, key: &str) -> PathBuf {
        self.root.join(key).join("state")
    }

    /// Locks `key` in the pool, waiting while another process (another study, a cluster
    /// task) renders it.
    pub(crate) fn lock(&self, key: &str) -> Result<ReferenceLock> {
        std::fs::create_dir_all(&self.root)
            .with_context(|| format!("creating the reference pool {}", self.root.display()))?;
        lock_path(&self.root.join(format!("{key}.lock")))
    }
}

/// The record of the finished reference in `dir` when it and every file it lists check
/// out; why not otherwise (`Ok(None)`: there is none).
pub(crate) fn verified_reference(
    dir: &Path,
    data: &str,
) -> Result<Option<ReferenceRecord>, String> {
    let Ok(record) = read_reference_record(dir) else {
        return Ok(None);
    };
    let missing = (!dir.join(data).is_file()).then(|| format!("{data} is missing"));
    match first_mismatch(dir, &record.files).or(missing) {
        None => Ok(Some(record)),
        Some(why) => Err(why),
    }
}
