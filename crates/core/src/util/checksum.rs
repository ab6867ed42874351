//! sha256 of data files.
//!
//! * [`sha256_content`] — what provenance and content addresses use: the file's bytes,
//!   hashed once per process (a replaced file, even of the same size and modification
//!   time, gets its new hash in the next run);
//! * [`sha256_cached`] — for `sweep datasets --verify` only: cached across runs by
//!   (canonical path, size, modification time) in a small JSON file in `$VOLPHOT_CACHE`,
//!   `$XDG_CACHE_HOME/volphot` or `~/.cache/volphot`.

use std::collections::BTreeMap;
use std::io::Read;
use std::path::{Path, PathBuf};
use std::time::UNIX_EPOCH;

use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};

use crate::error::{Error, Result};

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
struct Entry {
    size: u64,
    mtime_ns: u128,
    sha256: String,
}

/// The folder that holds volphot's caches, if one can be determined.
pub fn cache_dir() -> Option<PathBuf> {
    if let Some(dir) = std::env::var_os("VOLPHOT_CACHE") {
        return Some(PathBuf::from(dir));
    }
    if let Some(dir) = std::env::var_os("XDG_CACHE_HOME") {
        return Some(PathBuf::from(dir).join("volphot"));
    }
    std::env::var_os("HOME").map(|h| PathBuf::from(h).join(".cache").join("volphot"))
}

/// sha256 of a file's bytes, lowercase hex, without any cache.
pub fn sha256_file(path: &Path) -> Result<String> {
    let mut file = std::fs::File::open(path).map_err(|e| Error::io(path, e))?;
    let mut hasher = Sha256::new();
    let mut buf = vec![0u8; 1 << 20];
    loop {
        let n = file.read(&mut buf).map_err(|e| Error::io(path, e))?;
        if n == 0 {
            break;
        }
        hasher.update(&buf[..n]);
    }
    Ok(hex(&hasher.finalize()))
}

/// sha256 of a file's bytes, computed once per process per file (keyed by its canonical
/// path, size and modification time within this process only).
pub fn sha256_content(path: &Path) -> Result<String> {
    use std::collections::HashMap;
    use std::sync::{Mutex, OnceLock};
    type Key = (PathBuf, u64, u128);
    static MEMO: OnceLock<Mutex<HashMap<Key, String>>> = OnceLock::new();
    let meta = std::fs::metadata(path).map_err(|e| Error::io(path, e))?;
    let key = (
        std::fs::canonicalize(path).unwrap_or_else(|_| path.to_path_buf()),
        meta.len(),
        meta.modified()
            .ok()
            .and_then(|t| t.duration_since(UNIX_EPOCH).ok())
            .map_or(0, |d| d.as_nanos()),
    );
    let memo = MEMO.get_or_init(Default::default);
    if let Some(sum) = memo.lock().unwrap_or_else(|e| e.into_inner()).get(&key) {
        return Ok(sum.clone());
    }
    let sum = sha256_file(path)?;
    memo.lock()
        .unwrap_or_else(|e| e.into_inner())
        .insert(key, sum.clone());
    Ok(sum)
}

/// sha256 of some bytes, lowercase hex.
pub fn sha256_bytes(bytes: &[u8]) -> String {
    hex(&Sha256::digest(bytes))
}

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

/// sha256 of a file, served from the cache when the file's size and mtime are unchanged.
pub fn sha256_cached(path: &Path) -> Result<String> {
    let meta = std::fs::metadata(path).map_err(|e| Error::io(path, e))?;
    let canonical = std::fs::canonicalize(path).unwrap_or_else(|_| path.to_path_buf());
    let mtime_ns = meta
        .modified()
        .ok()
        .and_then(|t| t.duration_since(UNIX_EPOCH).ok())
        .map(|d| d.as_nanos())
        .unwrap_or(0);
    let key = canonical.display().to_string();
    let cache_file = cache_dir().map(|d| d.join("sha256.json"));
    let mut cache: BTreeMap<String, Entry> = cache_file
        .as_ref()
        .and_then(|f| std::fs::read_to_string(f).ok())
        .and_then(|text| serde_json::from_str(&text).ok())
        .unwrap_or_default();
    if let Some(entry) = cache.get(&key)
        && entry.size == meta.len()
        && entry.mtime_ns == mtime_ns
    {
        return Ok(entry.sha256.clone());
    }
    let sha256 = sha256_file(path)?;
    if let Some(cache_file) = cache_file {
        cache.insert(
            key,
            Entry {
                size: meta.len(),
                mtime_ns,
                sha256: sha256.clone(),
            },
        );
        // A cache that cannot be written only costs time later; it is not an error.
        if let Ok(text) = serde_json::to_string_pretty(&cache) {
            let _ = crate::util::write_atomic(&cache_file, text.as_bytes());
        }
    }
    Ok(sha256)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn known_digest() {
        assert_eq!(
            sha256_bytes(b"abc"),
            "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"
        );
    }

    #[test]
    fn file_digest_matches_bytes() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("x.bin");
        std::fs::write(&p, b"abc").unwrap();
        assert_eq!(sha256_file(&p).unwrap(), sha256_bytes(b"abc"));
        assert_eq!(sha256_cached(&p).unwrap(), sha256_bytes(b"abc"));
    }
}
