//! The walk of a DICOM folder (`[volume] dicom = "folder"`): bounded, each folder and each
//! file visited once (by device and inode), no symbolic link followed out of the folder,
//! and nothing but regular files kept — a FIFO in the folder would block the load forever
//! and a link to `/` would walk the whole file system, so neither is ever opened or walked.
//! What was left out is listed, for the record.

use std::collections::HashSet;
use std::fs::Metadata;
use std::os::unix::fs::MetadataExt;
use std::path::{Path, PathBuf};

use crate::error::{Error, Result};
use crate::util::file_kind;

/// How far a walk may go before it is refused.
#[derive(Debug, Clone, Copy)]
pub struct Limits {
    /// Directory entries looked at (files, folders, links, anything).
    pub entries: usize,
    /// Folders below the named one.
    pub depth: usize,
}

/// The walk's bounds: one study holds a few thousand files a few levels deep; a
/// folder past either bound is the wrong folder (a home directory, `/`), refused at once
/// rather than scanned for minutes.
pub const LIMITS: Limits = Limits {
    entries: 100_000,
    depth: 32,
};

/// Why an entry of the folder was not read.
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord)]
pub enum Reason {
    /// A symbolic link whose target is outside the folder (the target, for the record).
    LeadsOut(PathBuf),
    /// A symbolic link to nothing, or one of a loop of links.
    Dangling,
    /// Not a regular file: a FIFO, socket or device (its kind, for the record).
    NotRegular(&'static str),
    /// A folder or file already reached by another path (a link or hard link).
    AlreadyRead,
    /// A regular file that is not DICOM (no `DICM` magic at byte 128).
    NotDicom,
    /// A DICOM file without an image (a DICOMDIR, a report, a plan …).
    NoImage,
}

/// What a walk found.
pub struct Listing {
    /// The regular files to scan, each once, sorted.
    pub files: Vec<PathBuf>,
    /// The entries left out and why, relative to the folder.
    pub skipped: Vec<(Reason, PathBuf)>,
}

/// A file's or folder's identity: device and inode.
fn identity(meta: &Metadata) -> (u64, u64) {
    (meta.dev(), meta.ino())
}

/// The state of one walk.
struct Walk<'a> {
    /// The folder as named (for paths and messages).
    dir: &'a Path,
    /// The folder with every link resolved: a link is followed only to below it.
    root: PathBuf,
    limits: Limits,
    entries: usize,
    seen: HashSet<(u64, u64)>,
    pending: std::collections::VecDeque<(PathBuf, usize)>,
    listing: Listing,
}

/// Lists the regular files under `dir` (hidden entries skipped) within `limits`.
pub fn list(dir: &Path, limits: Limits) -> Result<Listing> {
    let not_a_folder = || {
        Error::format(
            dir,
            "not a folder; expected a folder of DICOM files (or a list of files)",
        )
    };
    let root = std::fs::canonicalize(dir).map_err(|_| not_a_folder())?;
    let meta = std::fs::metadata(&root).map_err(|e| Error::io(dir, e))?;
    if !meta.is_dir() {
        return Err(not_a_folder());
    }
    let mut walk = Walk {
        dir,
        root,
        limits,
        entries: 0,
        seen: HashSet::from([identity(&meta)]),
        pending: std::collections::VecDeque::from([(dir.to_path_buf(), 0)]),
        listing: Listing {
            files: Vec::new(),
            skipped: Vec::new(),
        },
    };
    while let Some((folder, depth)) = walk.pending.pop_front() {
        walk.folder(&folder, depth)?;
    }
    walk.listing.files.sort();
    walk.listing.skipped.sort();
    Ok(walk.listing)
}

impl Walk<'_> {
    /// Looks at every entry of `folder` (`depth` levels below the named one) in name order;
    /// with the folders taken breadth first, of two paths to one file the shallower (then
    /// the first by name) is kept, whatever order the disk lists them in.
    fn folder(&mut self, folder: &Path, depth: usize) -> Result<()> {
        let mut entries = Vec::new();
        for entry in std::fs::read_dir(folder).map_err(|e| Error::io(folder, e))? {
            entries.push(entry.map_err(|e| Error::io(folder, e))?);
            self.entries += 1;
            if self.entries > self.limits.entries {
                return Err(Error::format(
                    self.dir,
                    format!(
                        "more than {} entries (files, folders, links) below the folder; expected the folder of one \
                         study or series — name that folder, or list its files",
                        self.limits.entries
                    ),
                ));
            }
        }
        entries.sort_by_key(|e| e.file_name());
        for entry in &entries {
            let path = entry.path();
            let hidden = entry.file_name().to_string_lossy().starts_with('.');
            if !hidden && let Some(meta) = self.resolve(entry, &path)? {
                self.add(path, &meta, depth)?;
            }
        }
        Ok(())
    }

    /// The metadata of what `entry` is, following a symbolic link only to inside the
    /// folder; `None` (noted as skipped) for a link that leads out or nowhere.
    fn resolve(&mut self, entry: &std::fs::DirEntry, path: &Path) -> Result<Option<Metadata>> {
        let own = entry.metadata().map_err(|e| Error::io(path, e))?;
        if !own.file_type().is_symlink() {
            return Ok(Some(own));
        }
        let Ok(target) = std::fs::canonicalize(path) else {
            self.skip(Reason::Dangling, path);
            return Ok(None);
        };
        if !target.starts_with(&self.root) {
            self.skip(Reason::LeadsOut(target), path);
            return Ok(None);
        }
        match std::fs::metadata(&target) {
            Ok(meta) => Ok(Some(meta)),
            Err(_) => {
                self.skip(Reason::Dangling, path);
                Ok(None)
            }
        }
    }

    /// Queues a folder, keeps a regular file, skips anything else or anything seen.
    fn add(&mut self, path: PathBuf, meta: &Metadata, depth: usize) -> Result<()> {
        let (is_dir, is_file) = (meta.is_dir(), meta.is_file());
        if !is_dir && !is_file {
            self.skip(Reason::NotRegular(file_kind(meta.file_type())), &path);
            return Ok(());
        }
        if !self.seen.insert(identity(meta)) {
            self.skip(Reason::AlreadyRead, &path);
            return Ok(());
        }
        if is_file {
            self.listing.files.push(path);
            return Ok(());
        }
        if depth + 1 > self.limits.depth {
            return Err(Error::format(
                self.dir,
                format!(
                    "folders nested more than {} levels deep ({} is one); expected the folder of one study or \
                     series — name a folder nearer the slices, or list its files",
                    self.limits.depth,
                    path.display()
                ),
            ));
        }
        self.pending.push_back((path, depth + 1));
        Ok(())
    }

    fn skip(&mut self, reason: Reason, path: &Path) {
        let relative = path.strip_prefix(self.dir).unwrap_or(path);
        self.listing.skipped.push((reason, relative.to_path_buf()));
    }
}

impl Reason {
    /// What entries skipped for this reason are, in the record.
    fn label(&self) -> &'static str {
        match self {
            Reason::LeadsOut(_) => "symbolic link(s) leading out of the folder, not followed",
            Reason::Dangling => "dangling or looping symbolic link(s)",
            Reason::NotRegular(kind) => kind,
            Reason::AlreadyRead => "entries reaching a folder or file already read, read once",
            Reason::NotDicom => "file(s) that are not DICOM (no DICM magic at byte 128)",
            Reason::NoImage => {
                "DICOM file(s) without an image (no Rows: a DICOMDIR, report, plan …)"
            }
        }
    }
}

/// One clause for the record: each kind of skipped entry (sorted, so each kind is one
/// run), counted, with a few names.
pub fn describe_skipped(skipped: &[(Reason, PathBuf)]) -> String {
    const SHOWN: usize = 3;
    let mut parts = Vec::new();
    let mut rest = skipped;
    while let Some((first, _)) = rest.first() {
        let same = rest
            .iter()
            .take_while(|(r, _)| r.label() == first.label())
            .count();
        let names: Vec<String> = rest[..same]
            .iter()
            .take(SHOWN)
            .map(|(r, p)| match r {
                Reason::LeadsOut(target) => format!("{} -> {}", p.display(), target.display()),
                _ => p.display().to_string(),
            })
            .collect();
        let more = if same > SHOWN { ", …" } else { "" };
        parts.push(format!(
            "{same} × {} ({}{more})",
            first.label(),
            names.join(", ")
        ));
        rest = &rest[same..];
    }
    parts.join("; ")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_entry_limit_names_the_folder_and_the_limit() {
        let dir = tempfile::tempdir().unwrap();
        for i in 0..6 {
            std::fs::write(dir.path().join(format!("f{i}")), "x").unwrap();
        }
        let limits = Limits {
            entries: 5,
            depth: 2,
        };
        let err = list(dir.path(), limits).err().unwrap().to_string();
        assert!(
            err.starts_with(&dir.path().display().to_string())
                && err.contains("more than 5 entries"),
            "{err}"
        );
        let six = Limits {
            entries: 6,
            ..limits
        };
        assert_eq!(list(dir.path(), six).unwrap().files.len(), 6);
    }

    #[test]
    fn the_depth_limit_counts_folders_below_the_named_one() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::create_dir_all(dir.path().join("a/b")).unwrap();
        std::fs::write(dir.path().join("a/b/f"), "x").unwrap();
        let at = |depth| Limits {
            entries: 100,
            depth,
        };
        assert_eq!(list(dir.path(), at(2)).unwrap().files.len(), 1);
        let err = list(dir.path(), at(1)).err().unwrap().to_string();
        assert!(
            err.contains("more than 1 levels") && err.contains("a/b"),
            "{err}"
        );
    }

    #[test]
    fn skipped_entries_are_counted_by_kind_with_a_few_names() {
        let skipped: Vec<(Reason, PathBuf)> = vec![
            (Reason::LeadsOut("/".into()), "root".into()),
            (Reason::Dangling, "a".into()),
            (Reason::Dangling, "b".into()),
            (Reason::Dangling, "c".into()),
            (Reason::Dangling, "d".into()),
        ];
        assert_eq!(
            describe_skipped(&skipped),
            "1 × symbolic link(s) leading out of the folder, not followed (root -> /); \
             4 × dangling or looping symbolic link(s) (a, b, c, …)"
        );
    }
}
