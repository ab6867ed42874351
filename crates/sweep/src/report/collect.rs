//! Collecting an output folder: every planned cell's record, errors against its reference
//! (computed now when missing) and failure, read from disk alone.

use std::collections::HashMap;
use std::path::Path;

use anyhow::Result;
use volphot::Film;

use crate::analyse::{compare_with_reference, displayed, image_stats};
use crate::store::{
    CellRecord, CellState, IMAGE_STATS_VERSION, OutputDir, PlanRecord, PlannedCell,
    ReferenceMetrics, cell_state, read_plan, read_reference_metrics, read_reference_record,
    write_record,
};

/// One cell's collected state.
pub(crate) struct Collected {
    /// From the plan.
    pub(crate) planned: PlannedCell,
    /// Its record when finished.
    pub(crate) record: Option<CellRecord>,
    /// Errors against the reference.
    pub(crate) reference: Option<ReferenceMetrics>,
    /// Error text of a failed attempt.
    pub(crate) failure: Option<String>,
    /// Why a finished cell is not whole (a file missing, truncated or altered).
    pub(crate) damaged: Option<String>,
}

impl Collected {
    /// `done`, `damaged`, `failed` or `pending`.
    pub(crate) fn status(&self) -> &'static str {
        if self.record.is_some() {
            "done"
        } else if self.damaged.is_some() {
            "damaged"
        } else if self.failure.is_some() {
            "failed"
        } else {
            "pending"
        }
    }
}

/// Reads every planned cell's state; computes missing reference metrics when possible.
pub(crate) fn collect(out: &OutputDir) -> Result<(PlanRecord, Vec<Collected>)> {
    let plan = read_plan(out)?;
    let mut cells = Vec::new();
    // Each reference's passes, read once (many cells share a reference).
    let mut passes_of: HashMap<String, Option<u32>> = HashMap::new();
    for p in &plan.cells {
        let dir = out.cell(&p.hash);
        // The film is read only if something has to be recomputed from it, and then once.
        let mut film = None;
        let (record, damaged) = match cell_state(&dir) {
            CellState::Done(record) => {
                let mut record = *record;
                if record.image.version != IMAGE_STATS_VERSION {
                    refresh_image_stats(&dir, &mut record, cell_film(&dir, &mut film)?)?;
                }
                (Some(record), None)
            }
            CellState::Damaged(why) => (None, Some(why)),
            CellState::Missing => (None, None),
        };
        let mut reference = None;
        if let (Some(r), Some(key)) = (&record, &p.reference) {
            let passes = *passes_of.entry(key.clone()).or_insert_with(|| {
                read_reference_record(&out.reference(key))
                    .ok()
                    .map(|rec| rec.passes)
            });
            reference = read_reference_metrics(&dir, key, passes);
            if reference.is_none() && passes.is_some() {
                let film = cell_film(&dir, &mut film)?;
                compare_with_reference(out, &p.hash, key, &r.provenance.scene, film)?;
                reference = read_reference_metrics(&dir, key, passes);
            }
        }
        let failure = if record.is_none() {
            volphot::read_text_capped(&out.failure(&p.hash), 1 << 20, "failure note").ok()
        } else {
            None
        };
        cells.push(Collected {
            planned: p.clone(),
            record,
            reference,
            failure,
            damaged,
        });
    }
    Ok((plan, cells))
}

/// A cell's `film.exr`, read on first use.
fn cell_film<'a>(dir: &Path, film: &'a mut Option<Film>) -> Result<&'a Film> {
    if film.is_none() {
        *film = Some(Film::read_exr(&dir.join("film.exr"))?);
    }
    Ok(film.as_ref().expect("just read"))
}

/// Recomputes a record's image statistics from its film (they are cheap next to the
/// render) and stores the updated record, so older outputs gain newer columns.
fn refresh_image_stats(dir: &Path, record: &mut CellRecord, film: &Film) -> Result<()> {
    let p = &record.provenance.scene;
    let shown = displayed(film, p.integrator.multiple, p.integrator.emission);
    record.image = image_stats(film, &shown, p.film.exposure);
    write_record(dir, record)
}

/// Whether a cell's axis values match a `where` table (numbers compare by value).
pub(crate) fn matches(c: &PlannedCell, filter: &toml::Table) -> bool {
    matches_values(filter, |k| axis_value(c, k))
}

/// Whether the axis values `value(key)` pass `filter` (see [`matches()`]).
pub(crate) fn matches_values(
    filter: &toml::Table,
    value: impl Fn(&str) -> Option<serde_json::Value>,
) -> bool {
    filter.iter().all(|(k, v)| {
        let Some(have) = value(k) else {
            return false;
        };
        match crate::plan::toml_to_json(v) {
            // A list of values where the axis holds single values: any of them (an axis
            // whose values are lists, such as a resolution, matches the list itself).
            serde_json::Value::Array(any) if !have.is_array() => {
                any.iter().any(|want| same_value(&have, want))
            }
            want => same_value(&have, &want),
        }
    })
}

fn same_value(a: &serde_json::Value, b: &serde_json::Value) -> bool {
    match (a, b) {
        (serde_json::Value::Number(a), serde_json::Value::Number(b)) => a.as_f64() == b.as_f64(),
        (a, b) => a == b,
    }
}

pub(crate) fn axis_value(c: &PlannedCell, key: &str) -> Option<serde_json::Value> {
    c.axes
        .iter()
        .find(|(k, _)| k == key)
        .map(|(_, v)| v.clone())
}

pub(crate) fn value_label(v: &serde_json::Value) -> String {
    match v {
        serde_json::Value::String(s) => s.clone(),
        other => other.to_string(),
    }
}

pub(crate) fn numeric(v: &serde_json::Value) -> Option<f64> {
    v.as_f64()
}

/// The distinct values of axis `key` among `cells`, in plan order.
pub(crate) fn distinct_values<'a, C: std::borrow::Borrow<Collected> + 'a>(
    cells: impl IntoIterator<Item = &'a C>,
    key: &str,
) -> Vec<serde_json::Value> {
    let mut out: Vec<serde_json::Value> = Vec::new();
    for c in cells {
        if let Some(v) = axis_value(&c.borrow().planned, key)
            && !out.contains(&v)
        {
            out.push(v);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cell(axes: &[(&str, serde_json::Value)]) -> PlannedCell {
        PlannedCell {
            index: 0,
            hash: String::new(),
            label: String::new(),
            axes: axes
                .iter()
                .map(|(k, v)| (k.to_string(), v.clone()))
                .collect(),
            reference: None,
            march_key: String::new(),
            method: "photon".into(),
        }
    }

    #[test]
    fn a_list_in_where_matches_any_of_its_values_unless_the_axis_holds_lists() {
        let filter = |text: &str| -> toml::Table { toml::from_str(text).unwrap() };
        let c = cell(&[
            ("integrator.stored_photons", serde_json::json!(20000)),
            ("camera.resolution", serde_json::json!([256, 256])),
        ]);
        assert!(matches(
            &c,
            &filter("\"integrator.stored_photons\" = [0, 20000]")
        ));
        assert!(matches(
            &c,
            &filter("\"integrator.stored_photons\" = 20000.0")
        ));
        assert!(!matches(
            &c,
            &filter("\"integrator.stored_photons\" = [0, 507]")
        ));
        assert!(matches(&c, &filter("\"camera.resolution\" = [256, 256]")));
        assert!(!matches(&c, &filter("\"camera.resolution\" = [256, 512]")));
        assert!(!matches(&c, &filter("\"integrator.seed\" = [1, 2]")));
    }
}
