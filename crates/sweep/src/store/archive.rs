//! What an output folder's tables record as finished. A study committed to git keeps its
//! `cells.csv` and `cells.json` but not its `cells/` (films and records stay where they
//! were rendered), so on a fresh clone a finished cell is known only from those tables. A
//! report built from the folder alone would turn every such cell into a pending one and
//! overwrite what the tables record (issue #45, case 1); this module finds those cells so
//! that `sweep report` refuses and `sweep status` says what they are.

use std::collections::BTreeSet;

use super::{CellState, OutputDir, PlanRecord, cell_state};

/// Hashes of the cells that the folder's `cells.json` (or, when that cannot be read,
/// `cells.csv`) records as `done`. Empty when neither exists or neither can be read.
pub(crate) fn recorded_done(out: &OutputDir) -> BTreeSet<String> {
    from_json(out).or_else(|| from_csv(out)).unwrap_or_default()
}

fn from_json(out: &OutputDir) -> Option<BTreeSet<String>> {
    let text = volphot::read_text_capped(
        &out.root().join("cells.json"),
        64 << 20,
        "cells table (cells.json)",
    )
    .ok()?;
    let rows: Vec<serde_json::Map<String, serde_json::Value>> = serde_json::from_str(&text).ok()?;
    Some(
        rows.iter()
            .filter(|row| row.get("status").and_then(|s| s.as_str()) == Some("done"))
            .filter_map(|row| Some(row.get("hash")?.as_str()?.to_string()))
            .collect(),
    )
}

fn from_csv(out: &OutputDir) -> Option<BTreeSet<String>> {
    let mut reader = csv::Reader::from_path(out.root().join("cells.csv")).ok()?;
    let headers = reader.headers().ok()?.clone();
    let column = |name: &str| headers.iter().position(|h| h == name);
    let (hash, status) = (column("hash")?, column("status")?);
    Some(
        reader
            .records()
            .filter_map(|r| r.ok())
            .filter(|r| r.get(status) == Some("done"))
            .filter_map(|r| r.get(hash).map(str::to_string))
            .collect(),
    )
}

/// Plan indices of the cells recorded as done whose data are not in the folder at all (no
/// `cells/<hash>/`): a report would lose their results. (A cell whose files are there but
/// altered is *damaged*, which the report shows and `sweep run` repairs.)
pub(crate) fn recorded_but_absent(out: &OutputDir, plan: &PlanRecord) -> Vec<usize> {
    let recorded = recorded_done(out);
    if recorded.is_empty() {
        return Vec::new();
    }
    plan.cells
        .iter()
        .filter(|c| recorded.contains(&c.hash))
        .filter(|c| matches!(cell_state(&out.cell(&c.hash)), CellState::Missing))
        .map(|c| c.index)
        .collect()
}
