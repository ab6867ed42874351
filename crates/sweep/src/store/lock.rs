//! Locks in an output folder: a full run holds the folder's `.lock` exclusively; runs of
//! selected cells (`--cells`, `--shard`, cluster tasks) and `sweep report` hold it shared,
//! plus an exclusive lock per cell (`cells/.<hash>.lock`) or reference
//! (`references/<key>.lock`), so they can work side by side. A `sweep tune` search holds
//! `.tune.lock` exclusively besides, so a second search on the folder is refused.

use std::fs::File;
use std::io::Write as _;
use std::path::Path;

use anyhow::{Context, Result};

use super::OutputDir;

/// Holds the output folder's lock for the duration of a run.
pub(crate) struct FolderLock {
    _file: File,
}

/// Locks the output folder: exclusively for a full run, shared for a run of selected cells.
pub(crate) fn lock_folder(out: &OutputDir, exclusive: bool) -> Result<FolderLock> {
    std::fs::create_dir_all(out.root())
        .with_context(|| format!("creating {}", out.root().display()))?;
    let path = out.root().join(".lock");
    let file = lock_file(&path)?;
    let result = if exclusive {
        file.try_lock()
    } else {
        file.try_lock_shared()
    };
    match result {
        Ok(()) => Ok(FolderLock { _file: file }),
        Err(std::fs::TryLockError::WouldBlock) => anyhow::bail!(
            "{} is being written by another sweep run (lock {}); wait for it or choose another --output",
            out.root().display(),
            path.display()
        ),
        Err(std::fs::TryLockError::Error(e)) => {
            Err(e).with_context(|| format!("locking {}", path.display()))
        }
    }
}

/// Holds an output folder's tune lock for the duration of a search.
pub(crate) struct TuneLock {
    _file: File,
}

/// Locks the output folder for one `sweep tune` search, or fails at once naming the
/// search that holds it. Two searches on one folder would each find cells the other is
/// rendering, count them as failed and promote other configurations than one search. The
/// rungs of a search (and its Slurm array tasks) still take the folder lock shared, so
/// this is a lock file of its own; its holder writes its process id into it for the
/// error of the next.
pub(crate) fn lock_tune(out: &OutputDir) -> Result<TuneLock> {
    std::fs::create_dir_all(out.root())
        .with_context(|| format!("creating {}", out.root().display()))?;
    let path = out.root().join(".tune.lock");
    let mut file = lock_file(&path)?;
    match file.try_lock() {
        Ok(()) => {
            file.set_len(0)
                .and_then(|()| write!(file, "{}", std::process::id()))
                .with_context(|| format!("writing {}", path.display()))?;
            Ok(TuneLock { _file: file })
        }
        Err(std::fs::TryLockError::WouldBlock) => anyhow::bail!(
            "{} is being tuned by another `sweep tune`{}; wait for it to finish or tune into another --output (lock {})",
            out.root().display(),
            lock_holder(&path).map_or(String::new(), |pid| format!(" (process {pid})")),
            path.display()
        ),
        Err(std::fs::TryLockError::Error(e)) => {
            Err(e).with_context(|| format!("locking {}", path.display()))
        }
    }
}

/// The process id a lock's holder wrote into it, if it reads as one.
fn lock_holder(path: &Path) -> Option<u32> {
    volphot::read_text_capped(path, 32, "lock file")
        .ok()?
        .trim()
        .parse()
        .ok()
}

/// An exclusive lock on one cell, held while it is rendered and written.
pub(crate) struct CellLock {
    _file: File,
}

fn lock_file(path: &Path) -> Result<File> {
    File::options()
        .create(true)
        .truncate(false)
        .write(true)
        .open(path)
        .with_context(|| format!("opening {}", path.display()))
}

/// Locks cell `hash` unless another process holds it (then `None`: it is being rendered).
pub(crate) fn try_lock_cell(out: &OutputDir, hash: &str) -> Result<Option<CellLock>> {
    let file = lock_file(&out.cell_lock(hash))?;
    Ok(file.try_lock().is_ok().then_some(CellLock { _file: file }))
}

/// Whether another process holds cell `hash`'s lock right now.
pub(crate) fn cell_is_locked(out: &OutputDir, hash: &str) -> bool {
    File::options()
        .write(true)
        .open(out.cell_lock(hash))
        .ok()
        .is_some_and(|f| f.try_lock().is_err())
}

/// An exclusive lock on one reference.
pub(crate) struct ReferenceLock {
    _file: File,
}

/// Locks reference `key`, waiting while another process renders it.
pub(crate) fn lock_reference(out: &OutputDir, key: &str) -> Result<ReferenceLock> {
    std::fs::create_dir_all(out.root().join("references"))?;
    lock_path(&out.root().join("references").join(format!("{key}.lock")))
}

/// Locks the file at `path` exclusively, waiting while another process holds it.
pub(super) fn lock_path(path: &Path) -> Result<ReferenceLock> {
    let file = lock_file(path)?;
    file.lock()
        .with_context(|| format!("locking {}", path.display()))?;
    Ok(ReferenceLock { _file: file })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn folder_locks_exclude_full_runs_and_share_partial_ones() {
        let tmp = tempfile::tempdir().unwrap();
        let out = OutputDir::new(tmp.path());
        let full = lock_folder(&out, true).unwrap();
        let err = lock_folder(&out, false).err().expect("locked").to_string();
        assert!(err.contains("being written by another sweep run"), "{err}");
        drop(full);
        let a = lock_folder(&out, false).unwrap();
        let _b = lock_folder(&out, false).expect("shared locks coexist");
        assert!(lock_folder(&out, true).is_err());
        drop(a);
    }

    #[test]
    fn a_tune_lock_names_its_holder_and_leaves_the_folder_lock_to_the_rungs() {
        let tmp = tempfile::tempdir().unwrap();
        let out = OutputDir::new(tmp.path());
        let held = lock_tune(&out).unwrap();
        let err = lock_tune(&out).err().expect("held").to_string();
        assert!(err.contains(&tmp.path().display().to_string()), "{err}");
        assert!(
            err.contains(&format!("(process {})", std::process::id())),
            "{err}"
        );
        let _rung = lock_folder(&out, false).expect("a rung of the search");
        drop(held);
        // A test of another thread forking a child at this moment holds a copy of the
        // descriptor (and so the lock) until the child execs and closes it: free again
        // within moments, not necessarily at once.
        let mut again = lock_tune(&out);
        for _ in 0..100 {
            if again.is_ok() {
                break;
            }
            std::thread::sleep(std::time::Duration::from_millis(20));
            again = lock_tune(&out);
        }
        again.expect("free again");
    }

    #[test]
    fn a_cell_lock_is_held_by_one_process_at_a_time() {
        let tmp = tempfile::tempdir().unwrap();
        let out = OutputDir::new(tmp.path());
        std::fs::create_dir_all(tmp.path().join("cells")).unwrap();
        assert!(!cell_is_locked(&out, "abc"));
        let lock = try_lock_cell(&out, "abc").unwrap().expect("free");
        assert!(try_lock_cell(&out, "abc").unwrap().is_none());
        assert!(cell_is_locked(&out, "abc"));
        drop(lock);
        assert!(!cell_is_locked(&out, "abc"));
    }
}
