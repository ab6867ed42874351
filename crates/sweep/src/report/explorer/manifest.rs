//! The manifest inlined into `report.html`: the axes with their values, every planned cell
//! (its coordinates on the axes, status and data file) and the references. The page builds
//! its controls from it and loads a cell's data only when the cell is shown.

use serde::Serialize;

use super::Opening;
use super::data::DataIndex;
use crate::plan::PairSpec;
use crate::report::collect::{Collected, axis_value, distinct_values, matches_values, value_label};
use crate::store::PlanRecord;

/// Version of the manifest's shape, for the page.
const MANIFEST_FORMAT: u32 = 1;

#[derive(Serialize)]
pub(super) struct Manifest {
    format: u32,
    axes: Vec<Axis>,
    cells: Vec<CellEntry>,
    references: Vec<ReferenceEntry>,
    /// FLIP's magma colour map (256 RGB triples, base64), as nv-flip colours error maps.
    magma: String,
    /// The pair the page opens on (positions in `cells`): the study's own comparison.
    #[serde(skip_serializing_if = "Option::is_none")]
    start: Option<[usize; 2]>,
}

#[derive(Serialize)]
struct Axis {
    /// The scene key.
    key: String,
    /// Its last component, as plots and sheets label it.
    name: String,
    /// The values that occur, in plan order, as text.
    values: Vec<String>,
}

#[derive(Serialize)]
struct CellEntry {
    /// Index in the plan (the `cell` column of the tables).
    index: usize,
    label: String,
    /// `done`, `damaged`, `failed` or `pending`.
    status: &'static str,
    /// Index of the cell's value in each axis's `values` (`null` for an axis the cell lacks).
    coords: Vec<Option<usize>>,
    /// Data file (finished cells only).
    #[serde(skip_serializing_if = "Option::is_none")]
    data: Option<String>,
    /// Index into `references` when the cell has a usable reference.
    #[serde(skip_serializing_if = "Option::is_none")]
    reference: Option<usize>,
    /// `[width, height]` in pixels.
    #[serde(skip_serializing_if = "Option::is_none")]
    size: Option<[usize; 2]>,
    /// Stops applied before display (the scene's `film.exposure`), also those of the FLIP map.
    #[serde(skip_serializing_if = "Option::is_none")]
    exposure: Option<f32>,
    /// The layers the cell's displayed image sums.
    #[serde(skip_serializing_if = "Option::is_none")]
    shows: Option<Vec<&'static str>>,
    /// Mean FLIP error against the reference (the report's `flip` column).
    #[serde(skip_serializing_if = "Option::is_none")]
    flip: Option<f64>,
}

#[derive(Serialize)]
struct ReferenceEntry {
    key: String,
    data: String,
}

/// The pair a study is about: its first finished cell, and the finished cell that differs
/// from it only in `axis`, at that axis's last value (the swept axis's ends: single against
/// single + multiple, nused 25 against 300), not another seed of the same setting.
fn start_pair(
    plan: &PlanRecord,
    cells: &[Collected],
    data: &DataIndex,
    axis: &str,
) -> Option<[usize; 2]> {
    let done: Vec<usize> = (0..cells.len())
        .filter(|i| data.cells.contains_key(i))
        .collect();
    let a = *done.first()?;
    let last = distinct_values(cells, axis).pop()?;
    let others: Vec<&String> = plan.axes.iter().filter(|k| k.as_str() != axis).collect();
    let same_elsewhere = |b: usize| {
        others
            .iter()
            .all(|k| axis_value(&cells[a].planned, k) == axis_value(&cells[b].planned, k))
    };
    done.iter()
        .copied()
        .find(|&b| {
            b != a
                && axis_value(&cells[b].planned, axis).as_ref() == Some(&last)
                && same_elsewhere(b)
        })
        .map(|b| [a, b])
}

/// The pair a study names: its first finished cell of `pair.a`, and the finished cell of
/// `pair.b` that agrees with it on the most axes neither side names (all of them in a full
/// grid; axes zipped with a named one move with it, so they may differ).
fn named_pair(
    plan: &PlanRecord,
    cells: &[Collected],
    data: &DataIndex,
    pair: &PairSpec,
) -> Option<[usize; 2]> {
    choose_pair(
        &plan.axes,
        (0..cells.len()).filter(|i| data.cells.contains_key(i)),
        |i, k| axis_value(&cells[i].planned, k),
        pair,
    )
}

/// [`named_pair`] over cells `done` (in order) whose axis values `value(cell, key)` gives.
fn choose_pair(
    axes: &[String],
    done: impl Iterator<Item = usize> + Clone,
    value: impl Fn(usize, &str) -> Option<serde_json::Value>,
    pair: &PairSpec,
) -> Option<[usize; 2]> {
    let a = done
        .clone()
        .find(|&i| matches_values(&pair.a, |k| value(i, k)))?;
    let free: Vec<&String> = axes
        .iter()
        .filter(|k| !pair.a.contains_key(k.as_str()) && !pair.b.contains_key(k.as_str()))
        .collect();
    let agreement = |b: usize| free.iter().filter(|k| value(a, k) == value(b, k)).count();
    // The first of the best: `max_by_key` keeps the last of equals, so walk backwards.
    let candidates: Vec<usize> = done
        .filter(|&b| b != a && matches_values(&pair.b, |k| value(b, k)))
        .collect();
    let b = candidates.into_iter().rev().max_by_key(|&b| agreement(b))?;
    Some([a, b])
}

/// The opening `pair` names in a page's manifest (its axes, their values as text, each
/// cell's coordinates and whether its data are there), for [`super::reopen_page`]: a clone
/// holds the page but not the cells it was built from.
pub(super) fn reopen(manifest: &mut serde_json::Value, pair: &PairSpec) -> anyhow::Result<()> {
    let no_values = Vec::new();
    let axes: Vec<(&str, &Vec<serde_json::Value>)> = manifest["axes"]
        .as_array()
        .unwrap_or(&no_values)
        .iter()
        .map(|a| {
            let values = a["values"].as_array().unwrap_or(&no_values);
            (a["key"].as_str().unwrap_or_default(), values)
        })
        .collect();
    let cells = manifest["cells"].as_array().unwrap_or(&no_values);
    let keys: Vec<String> = axes.iter().map(|(k, _)| k.to_string()).collect();
    let value = |cell: usize, key: &str| {
        let axis = axes.iter().position(|(k, _)| *k == key)?;
        let at = cells[cell]["coords"][axis].as_u64()? as usize;
        axes[axis].1.get(at).map(plan_value)
    };
    let done = (0..cells.len()).filter(|&i| cells[i].get("data").is_some());
    let start = choose_pair(&keys, done, value, pair).ok_or_else(|| {
        anyhow::anyhow!(
            "no finished cell of report.pair.a = {} has a finished cell of report.pair.b = {} beside it",
            pair.a,
            pair.b
        )
    })?;
    manifest["start"] = serde_json::json!(start);
    Ok(())
}

/// An axis value as the plan held it, from the text a manifest shows: read back as JSON
/// where it is a number, a flag or a list, else the text.
fn plan_value(shown: &serde_json::Value) -> serde_json::Value {
    let text = shown.as_str().unwrap_or_default();
    serde_json::from_str(text).unwrap_or_else(|_| serde_json::Value::String(text.into()))
}

impl Manifest {
    /// The manifest of the collected cells and their data files.
    pub(super) fn new(
        plan: &PlanRecord,
        cells: &[Collected],
        data: &DataIndex,
        opening: Option<Opening<'_>>,
    ) -> Self {
        let axes: Vec<(String, Vec<serde_json::Value>)> = plan
            .axes
            .iter()
            .map(|key| (key.clone(), distinct_values(cells, key)))
            .collect();
        let references: Vec<&String> = data.references.keys().collect();
        let start = match opening {
            Some(Opening::Named(pair)) => named_pair(plan, cells, data, pair),
            Some(Opening::Axis(axis)) => start_pair(plan, cells, data, axis),
            None => None,
        };
        let entries = cells
            .iter()
            .enumerate()
            .map(|(position, c)| {
                let coords = axes
                    .iter()
                    .map(|(key, values)| {
                        let v = axis_value(&c.planned, key)?;
                        values.iter().position(|x| *x == v)
                    })
                    .collect();
                let d = data.cells.get(&position);
                CellEntry {
                    index: c.planned.index,
                    label: c.planned.label.clone(),
                    status: c.status(),
                    coords,
                    data: d.map(|d| d.path.clone()),
                    reference: d
                        .and_then(|d| d.reference.as_ref())
                        .and_then(|k| references.iter().position(|r| *r == k)),
                    size: d.map(|d| d.size),
                    exposure: d.map(|d| d.exposure),
                    shows: d.map(|d| d.shows.names()),
                    flip: c.reference.as_ref().map(|r| r.flip),
                }
            })
            .collect();
        Manifest {
            format: MANIFEST_FORMAT,
            axes: axes
                .into_iter()
                .map(|(key, values)| Axis {
                    name: crate::plan::short_key(&key).to_string(),
                    key,
                    values: values.iter().map(value_label).collect(),
                })
                .collect(),
            cells: entries,
            references: data
                .references
                .iter()
                .map(|(key, path)| ReferenceEntry {
                    key: key.clone(),
                    data: path.clone(),
                })
                .collect(),
            magma: super::pack::base64(&nv_flip::magma_lut().to_vec()),
            start,
        }
    }

    /// The manifest as JSON that is safe inside a `<script>` element: `<` is escaped, so
    /// no label can close the element.
    pub(super) fn to_script_json(&self) -> anyhow::Result<String> {
        Ok(serde_json::to_string(self)?.replace('<', "\\u003c"))
    }
}
