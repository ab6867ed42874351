//! The size and sha256 of a file as written, and whether it still is: what a finished
//! cell's or reference's record lists for each of its files.

use std::path::Path;

use anyhow::{Context, Result};
use serde::{Deserialize, Serialize};

/// The size and checksum of one file of a finished cell or reference.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub(crate) struct FileCheck {
    /// File name inside the folder.
    pub(crate) name: String,
    /// Size in bytes.
    pub(crate) bytes: u64,
    /// sha256, lowercase hex.
    pub(crate) sha256: String,
}

impl FileCheck {
    /// Measures `dir/name`.
    pub(crate) fn of(dir: &Path, name: &str) -> Result<Self> {
        let path = dir.join(name);
        let bytes = std::fs::metadata(&path)
            .with_context(|| format!("reading {}", path.display()))?
            .len();
        Ok(FileCheck {
            name: name.to_string(),
            bytes,
            sha256: volphot::sha256_file(&path)?,
        })
    }

    /// Why `dir/name` does not match this check, if it does not.
    pub(crate) fn mismatch(&self, dir: &Path) -> Option<String> {
        let path = dir.join(&self.name);
        let bytes = match std::fs::metadata(&path) {
            Ok(m) if m.is_file() => m.len(),
            _ => return Some(format!("{} is missing", self.name)),
        };
        if bytes != self.bytes {
            return Some(format!(
                "{} is {bytes} bytes, {} were written",
                self.name, self.bytes
            ));
        }
        match volphot::sha256_file(&path) {
            Ok(sum) if sum == self.sha256 => None,
            Ok(_) => Some(format!(
                "{}'s sha256 differs from the one written",
                self.name
            )),
            Err(e) => Some(format!("{} cannot be read: {e}", self.name)),
        }
    }
}

/// Checks every file of a folder (`None` when all match).
pub(crate) fn first_mismatch(dir: &Path, files: &[FileCheck]) -> Option<String> {
    files.iter().find_map(|f| f.mismatch(dir))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_check_sees_truncation_flips_and_absence() {
        let tmp = tempfile::tempdir().unwrap();
        let dir = tmp.path();
        std::fs::write(dir.join("a.bin"), [7u8; 100]).unwrap();
        let check = FileCheck::of(dir, "a.bin").unwrap();
        assert_eq!(check.mismatch(dir), None);
        let mut flipped = [7u8; 100];
        flipped[50] ^= 1;
        std::fs::write(dir.join("a.bin"), flipped).unwrap();
        assert!(check.mismatch(dir).unwrap().contains("sha256"));
        std::fs::write(dir.join("a.bin"), [7u8; 60]).unwrap();
        assert!(check.mismatch(dir).unwrap().contains("60 bytes, 100"));
        std::fs::remove_file(dir.join("a.bin")).unwrap();
        assert!(check.mismatch(dir).unwrap().contains("missing"));
    }
}
