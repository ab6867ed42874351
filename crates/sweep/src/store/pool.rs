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
use volphot::ReferenceAccumulator;

use super::lock::{ReferenceLock, lock_path};
use super::{
    FileCheck, ReferenceRecord, StagedDir, first_mismatch, read_reference_record,
    write_reference_record,
};

/// The accumulator state's file in `<key>/state/`.
const STATE_FILE: &str = "state.bin";

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

    /// The record of the pool's reference `key` at `passes`, when it is there and checks
    /// out (`Err`: why it does not).
    pub(crate) fn finished(
        &self,
        key: &str,
        passes: u32,
    ) -> Result<Option<ReferenceRecord>, String> {
        verified_reference(&self.film(key, passes), "reference.exr")
    }

    /// The record of `key`'s accumulator state, when it is there and checks out (`Err`: why
    /// it does not).
    pub(crate) fn saved_state(&self, key: &str) -> Result<Option<ReferenceRecord>, String> {
        verified_reference(&self.state(key), STATE_FILE)
    }

    /// `key`'s accumulator state (check it with [`Self::saved_state`] first).
    pub(crate) fn read_state(&self, key: &str) -> Result<ReferenceAccumulator> {
        Ok(ReferenceAccumulator::read_state(
            &self.state(key).join(STATE_FILE),
        )?)
    }

    /// Replaces `key`'s accumulator state by `accumulator`, recorded as `record` says.
    pub(crate) fn keep_state(
        &self,
        key: &str,
        accumulator: &ReferenceAccumulator,
        mut record: ReferenceRecord,
    ) -> Result<()> {
        let staged = StagedDir::new(&self.state(key))?;
        accumulator.write_state(&staged.path().join(STATE_FILE))?;
        record.files = vec![FileCheck::of(staged.path(), STATE_FILE)?];
        write_reference_record(staged.path(), &record)?;
        staged.commit()
    }

    /// The passes of reference `key` the pool holds toward `passes`: all of them when it
    /// holds the `passes`-pass reference, its state's when that has no more.
    pub(crate) fn held_passes(&self, key: &str, passes: u32) -> u32 {
        if let Ok(Some(_)) = self.finished(key, passes) {
            return passes;
        }
        match self.saved_state(key) {
            Ok(Some(state)) if state.passes <= passes => state.passes,
            _ => 0,
        }
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
