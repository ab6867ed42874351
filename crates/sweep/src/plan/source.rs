//! The experiment file's text and path, for errors that point at a line and column.

use std::path::{Path, PathBuf};

use volphot::{line_col, locate};

/// An experiment file: its path and text.
#[derive(Debug, Clone)]
pub(crate) struct Source {
    /// The experiment file.
    pub(crate) path: PathBuf,
    /// Its text.
    pub(crate) text: String,
}

impl Source {
    /// An error at `key_path` (`table.key`; quoted or nested) in this file.
    pub(crate) fn error(&self, key_path: &str, message: impl std::fmt::Display) -> anyhow::Error {
        located(&self.path, &self.text, key_path, message)
    }
}

/// An error located in the experiment file.
pub(crate) fn located(
    exp_path: &Path,
    src: &str,
    key_path: &str,
    message: impl std::fmt::Display,
) -> anyhow::Error {
    let (line, column) = locate_key(src, key_path).unwrap_or((1, 1));
    anyhow::anyhow!("{}:{line}:{column}: {message}", exp_path.display())
}

/// Locates `table.key` where `key` may be written quoted (`"a.b"`) or nested (`a.b`).
fn locate_key(src: &str, key_path: &str) -> Option<(usize, usize)> {
    if let Some((table, rest)) = key_path.split_once('.') {
        // Try the quoted form first: find `"rest"` after the table header.
        let quoted = format!("\"{rest}\"");
        if let Some(start) = src
            .find(&format!("[{table}]"))
            .or_else(|| src.find(&format!("{table} =")))
            && let Some(off) = src[start..].find(&quoted)
        {
            return Some(line_col(src, start + off));
        }
    }
    locate(src, key_path)
}
