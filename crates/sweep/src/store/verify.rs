//! Whether a finished cell (or reference) is really whole: its record parses and every file
//! it lists has the recorded size and sha256. A truncated, missing or bit-flipped file
//! makes the cell *damaged*: `sweep run` renders it again and says why, `sweep status`
//! lists it, the report shows it as damaged.

use std::path::Path;

use super::checksum::first_mismatch;
use super::records::{CellRecord, read_record};

/// The files a cell folder must hold besides its record.
pub(crate) const CELL_FILES: [&str; 4] = ["film.exr", "total.png", "single.png", "multiple.png"];

/// A cell folder's state.
#[derive(Debug)]
pub(crate) enum CellState {
    /// Not rendered (no record).
    Missing,
    /// Finished, every file as written.
    Done(Box<CellRecord>),
    /// A record exists but the cell is not whole: why.
    Damaged(String),
}

/// Reads and verifies a cell folder. Records written before files were checksummed are
/// accepted when every file exists.
pub(crate) fn cell_state(dir: &Path) -> CellState {
    if !dir.join("cell.json").is_file() {
        return CellState::Missing;
    }
    let record = match read_record(dir) {
        Ok(r) => r,
        Err(e) => return CellState::Damaged(format!("{e:#}")),
    };
    let problem = if record.files.is_empty() {
        CELL_FILES
            .iter()
            .find(|f| !dir.join(f).is_file())
            .map(|f| format!("{f} is missing"))
    } else {
        first_mismatch(dir, &record.files)
    };
    match problem {
        None => CellState::Done(Box::new(record)),
        Some(p) => CellState::Damaged(p),
    }
}

/// Whether a cell has finished and is whole (see [`cell_state`]).
pub(crate) fn is_done(dir: &Path) -> bool {
    matches!(cell_state(dir), CellState::Done(_))
}
