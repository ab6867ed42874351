//! `sweep claims --update`: rewriting a document in place without losing a byte.
//!
//! The document is read once, under an exclusive lock on the file itself, and the new text
//! is computed from that same read: two `--update`s of one document wait for each other,
//! and edits are never applied at positions of another version of the text. The new text
//! replaces the file atomically (a temporary sibling renamed over it) with the old file's
//! permissions; a symbolic link is followed, so its target is rewritten and the link stays.

use std::fs::File;
use std::io::Read as _;
use std::os::unix::fs::MetadataExt as _;
use std::path::Path;

use anyhow::{Context, Result, bail};

/// Runs `work` on the document's text under its lock; writes back the text it returns, if
/// any. Returns what `work` returned beside the text.
pub(crate) fn locked<T>(
    path: &Path,
    work: impl FnOnce(&str) -> Result<(T, Option<String>)>,
) -> Result<T> {
    let target = std::fs::canonicalize(path)
        .with_context(|| format!("{}: cannot resolve the document", path.display()))?;
    let (file, text) = lock_and_read(&target)?;
    let (result, new) = work(&text)?;
    if let Some(new) = new {
        let permissions = file
            .metadata()
            .with_context(|| format!("reading {}", target.display()))?
            .permissions();
        let tmp = volphot::temp_sibling(&target);
        let written = (|| -> std::io::Result<()> {
            std::fs::write(&tmp, new.as_bytes())?;
            std::fs::set_permissions(&tmp, permissions)?;
            File::open(&tmp)?.sync_all()?;
            std::fs::rename(&tmp, &target)
        })();
        if let Err(e) = written {
            let _ = std::fs::remove_file(&tmp);
            return Err(e).with_context(|| format!("rewriting {}", target.display()));
        }
    }
    // The lock goes with the file, after the rename: a waiting update then finds that the
    // path names a new file and reads that one.
    drop(file);
    Ok(result)
}

/// Opens `target`, waits for its exclusive lock and reads it whole. The lock is taken on
/// the file the path names when the lock is granted: if another update renamed a new
/// file over the path meanwhile, the old one is let go and the new one locked instead.
fn lock_and_read(target: &Path) -> Result<(File, String)> {
    for _ in 0..100 {
        let (mut file, length) = volphot::open_regular(target, "Markdown document")?;
        if length > volphot::TEXT_INPUT_CAP {
            bail!(
                "{}: {length} bytes is more than the {} allowed for a Markdown document",
                target.display(),
                volphot::byte_size(volphot::TEXT_INPUT_CAP)
            );
        }
        if let Err(std::fs::TryLockError::WouldBlock) = file.try_lock() {
            eprintln!(
                "{}: waiting for another `sweep claims --update` of it",
                target.display()
            );
            file.lock()
                .with_context(|| format!("locking {}", target.display()))?;
        }
        let opened = file.metadata()?;
        let now =
            std::fs::metadata(target).with_context(|| format!("reading {}", target.display()))?;
        if (opened.dev(), opened.ino()) != (now.dev(), now.ino()) {
            continue;
        }
        let mut bytes = Vec::new();
        (&mut file)
            .take(volphot::TEXT_INPUT_CAP + 1)
            .read_to_end(&mut bytes)
            .with_context(|| format!("reading {}", target.display()))?;
        let text = String::from_utf8(bytes).map_err(|e| {
            anyhow::anyhow!(
                "{}: not UTF-8 text (byte {} is not valid UTF-8)",
                target.display(),
                e.utf8_error().valid_up_to()
            )
        })?;
        return Ok((file, text));
    }
    bail!(
        "{}: replaced 100 times while waiting for its lock; is something rewriting it in a loop?",
        target.display()
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::os::unix::fs::PermissionsExt as _;

    /// Case 5 of the fourth reliability round: `--update` rewrote CRLF, replaced a link by
    /// a file and dropped the mode.
    #[test]
    fn keeps_line_endings_mode_and_the_link() {
        let dir = tempfile::tempdir().unwrap();
        let real = dir.path().join("real.md");
        let link = dir.path().join("link.md");
        std::fs::write(&real, "a 1\r\nb 2\r\n").unwrap();
        std::fs::set_permissions(&real, std::fs::Permissions::from_mode(0o444)).unwrap();
        std::os::unix::fs::symlink("real.md", &link).unwrap();
        locked(&link, |text| Ok(((), Some(text.replace("b 2", "b 3"))))).unwrap();
        assert!(
            std::fs::symlink_metadata(&link)
                .unwrap()
                .file_type()
                .is_symlink()
        );
        assert_eq!(std::fs::read_to_string(&real).unwrap(), "a 1\r\nb 3\r\n");
        let mode = std::fs::metadata(&real).unwrap().permissions().mode() & 0o777;
        assert_eq!(mode, 0o444);
    }

    /// Case 5 and 8: two concurrent updates each read the text once, one after the other.
    #[test]
    fn concurrent_updates_wait_for_each_other() {
        let dir = tempfile::tempdir().unwrap();
        let doc = dir.path().join("d.md");
        std::fs::write(&doc, "n 0\n").unwrap();
        let threads: Vec<_> = (0..4)
            .map(|_| {
                let doc = doc.clone();
                std::thread::spawn(move || {
                    locked(&doc, |text| {
                        let n: u32 = text.trim()[2..].parse().unwrap();
                        std::thread::sleep(std::time::Duration::from_millis(50));
                        Ok(((), Some(format!("n {}\n", n + 1))))
                    })
                    .unwrap();
                })
            })
            .collect();
        for t in threads {
            t.join().unwrap();
        }
        assert_eq!(std::fs::read_to_string(&doc).unwrap(), "n 4\n");
    }
}
