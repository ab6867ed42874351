//! The data a claim is checked against: a study's `cells.csv`, any CSV file (a plot's
//! points, a tune's observations), a JSON file (the committed bench) or a TOML file (a
//! study's `experiment.toml`), read once each.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, anyhow, bail};
use serde_json::Value;

use super::expr::{Call, Filter};

/// One table: rows of column key → text. A CSV header `ms_share [1]` has the key
/// `ms_share` (its unit dropped), so a claim names a column as the documents do.
struct Table {
    rows: Vec<HashMap<String, String>>,
}

enum Loaded {
    Table(Table),
    Json(Value),
}

/// Files read so far, by path.
#[derive(Default)]
pub(crate) struct Sources {
    loaded: HashMap<PathBuf, Loaded>,
}

/// A CSV header without its unit: `rmse [W/(m2 sr)]` → `rmse`.
fn key_of(header: &str) -> &str {
    header.split(" [").next().unwrap_or(header).trim()
}

fn read_table(path: &Path) -> Result<Table> {
    let mut reader =
        csv::Reader::from_path(path).with_context(|| format!("reading {}", path.display()))?;
    let headers: Vec<String> = reader
        .headers()
        .with_context(|| format!("reading {}", path.display()))?
        .iter()
        .map(|h| key_of(h).to_string())
        .collect();
    let mut rows = Vec::new();
    for record in reader.records() {
        let record = record.with_context(|| format!("reading {}", path.display()))?;
        rows.push(
            headers
                .iter()
                .cloned()
                .zip(record.iter().map(str::to_string))
                .collect(),
        );
    }
    Ok(Table { rows })
}

/// Whether a cell's text matches a filter's value: numbers by value, a scene path also by
/// its file name (`foot` matches `scenes/foot.toml`), anything else as text.
fn same(cell: &str, wanted: &str) -> bool {
    if let (Ok(a), Ok(b)) = (cell.parse::<f64>(), wanted.parse::<f64>()) {
        return (a - b).abs() <= 1e-9 * a.abs().max(b.abs()).max(1e-300);
    }
    cell == wanted
        || Path::new(cell)
            .file_stem()
            .is_some_and(|stem| stem == wanted && cell.ends_with(".toml"))
}

fn passes(filters: &[Filter], field: impl Fn(&str) -> Option<String>) -> Result<bool> {
    for f in filters {
        let cell = field(&f.key).ok_or_else(|| anyhow!("no column `{}`", f.key))?;
        if same(&cell, &f.value) == f.negated {
            return Ok(false);
        }
    }
    Ok(true)
}

impl Sources {
    /// The values a call reduces: the column of every matching row that has a number there
    /// (an empty cell is a metric undefined for that row, not a 0).
    pub(crate) fn values(&mut self, base: &Path, call: &Call) -> Result<Vec<f64>> {
        let mut path = base.join(&call.source);
        if path.is_dir() {
            path = path.join("cells.csv");
        }
        if !self.loaded.contains_key(&path) {
            let extension = path.extension().and_then(|e| e.to_str()).unwrap_or("");
            let loaded = if extension == "json" {
                let text = volphot::read_text_capped(&path, volphot::TEXT_INPUT_CAP, "JSON file")?;
                Loaded::Json(
                    serde_json::from_str(&text)
                        .with_context(|| format!("{}: not JSON", path.display()))?,
                )
            } else if extension == "toml" {
                // An experiment's own settings (a study's `experiment.toml`), read as JSON.
                let text = volphot::read_text_capped(&path, volphot::TEXT_INPUT_CAP, "TOML file")?;
                let table: toml::Table = text
                    .parse()
                    .with_context(|| format!("{}: not TOML", path.display()))?;
                Loaded::Json(serde_json::to_value(table)?)
            } else {
                Loaded::Table(read_table(&path)?)
            };
            self.loaded.insert(path.clone(), loaded);
        }
        match &self.loaded[&path] {
            Loaded::Table(t) => table_values(t, call),
            Loaded::Json(v) => json_values(v, call),
        }
        .with_context(|| format!("in {}", path.display()))
    }
}

fn table_values(table: &Table, call: &Call) -> Result<Vec<f64>> {
    if table
        .rows
        .first()
        .is_some_and(|r| !r.contains_key(&call.column))
    {
        bail!("no column `{}`", call.column);
    }
    let mut values = Vec::new();
    for row in &table.rows {
        if !passes(&call.filters, |k| row.get(k).cloned())? {
            continue;
        }
        let text = &row[&call.column];
        if text.is_empty() {
            continue;
        }
        values.push(
            text.parse()
                .map_err(|_| anyhow!("`{}` = {text:?} is not a number", call.column))?,
        );
    }
    Ok(values)
}

/// Follows the dotted path; every array on the way is filtered by the filters its elements
/// carry (each element an object whose fields, dotted, the filters name): `cases.trackers.x
/// | scene=foot, tracker=delta` picks the foot's case and, inside it, delta's entry. Every
/// filter must name a field of the elements of some array on the way.
fn json_values(root: &Value, call: &Call) -> Result<Vec<f64>> {
    let segments: Vec<&str> = call.column.split('.').collect();
    let mut values = Vec::new();
    let mut used = vec![false; call.filters.len()];
    walk(root, &segments, call, &mut used, &mut values)?;
    if let Some(k) = used.iter().position(|u| !u) {
        bail!(
            "filter `{}`: no array on the way to `{}` has elements with that field",
            call.filters[k].key,
            call.column
        );
    }
    Ok(values)
}

fn walk(
    v: &Value,
    path: &[&str],
    call: &Call,
    used: &mut [bool],
    out: &mut Vec<f64>,
) -> Result<()> {
    if let Value::Array(items) = v {
        // The filters this array's elements carry (all of them carry the field).
        let here: Vec<Filter> = call
            .filters
            .iter()
            .enumerate()
            .filter(|(_, f)| {
                !items.is_empty() && items.iter().all(|i| json_field(i, &f.key).is_some())
            })
            .map(|(k, f)| {
                used[k] = true;
                f.clone()
            })
            .collect();
        for item in items {
            if passes(&here, |k| json_field(item, k))? {
                walk(item, path, call, used, out)?;
            }
        }
        return Ok(());
    }
    let Some((head, rest)) = path.split_first() else {
        return match v {
            Value::Number(n) => {
                out.push(n.as_f64().unwrap_or(f64::NAN));
                Ok(())
            }
            Value::Null => Ok(()),
            other => bail!("`{}` is {other}, not a number", call.column),
        };
    };
    let next = v
        .get(head)
        .ok_or_else(|| anyhow!("no field `{head}` on the way to `{}`", call.column))?;
    walk(next, rest, call, used, out)
}

/// A dotted field of a JSON object as text (for filters).
fn json_field(item: &Value, key: &str) -> Option<String> {
    let mut v = item;
    for part in key.split('.') {
        v = v.get(part)?;
    }
    Some(match v {
        Value::String(s) => s.clone(),
        other => other.to_string(),
    })
}

#[cfg(test)]
mod tests {
    use super::super::expr::{Aggregate, parse};
    use super::*;

    fn call(text: &str) -> Call {
        match parse(text).unwrap() {
            super::super::expr::Expr::Call(c) => c,
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn csv_columns_by_key_with_filters_and_undefined_cells_skipped() {
        let dir = tempfile::tempdir().unwrap();
        let study = dir.path().join("s");
        std::fs::create_dir(&study).unwrap();
        std::fs::write(
            study.join("cells.csv"),
            "cell,scene,sigma.t,integrator.multiple,ms_share [1]\n\
             0,scenes/foot.toml,80,false,\n\
             1,scenes/foot.toml,80,true,0.5\n\
             2,scenes/foot.toml,80.0,true,0.25\n\
             3,scenes/engine.toml,80,true,0.9\n",
        )
        .unwrap();
        let mut sources = Sources::default();
        let c = call("mean(s: ms_share | scene=foot, sigma.t=80)");
        let v = sources.values(dir.path(), &c).unwrap();
        assert_eq!(v, vec![0.5, 0.25]);
        assert_eq!(c.aggregate.apply(&v).unwrap(), 0.375);
        let v = sources
            .values(dir.path(), &call("count(s: cell | scene!=foot)"))
            .unwrap();
        assert_eq!(v, vec![3.0]);
        let e = sources
            .values(dir.path(), &call("mean(s: rmse)"))
            .unwrap_err();
        assert!(format!("{e:#}").contains("no column `rmse`"), "{e:#}");
        let _ = Aggregate::Value;
    }

    #[test]
    fn json_paths_filter_the_first_array() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(
            dir.path().join("b.json"),
            r#"{"machine": {"cores": 2}, "configurations": [
                {"name": "thinned", "render": {"seconds": 9.5}},
                {"name": "cached", "render": {"seconds": 4.0}}]}"#,
        )
        .unwrap();
        let mut sources = Sources::default();
        let v = sources
            .values(
                dir.path(),
                &call("value(b.json: configurations.render.seconds | name=cached)"),
            )
            .unwrap();
        assert_eq!(v, vec![4.0]);
        let v = sources
            .values(dir.path(), &call("value(b.json: machine.cores)"))
            .unwrap();
        assert_eq!(v, vec![2.0]);
    }

    #[test]
    fn json_filters_apply_at_the_array_whose_elements_carry_them() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(
            dir.path().join("r.json"),
            r#"{"cases": [
                {"scene": "foot", "trackers": [{"tracker": "delta", "cpu": 8.0}, {"tracker": "weighted", "cpu": 5.0}]},
                {"scene": "head", "trackers": [{"tracker": "delta", "cpu": 3.0}, {"tracker": "weighted", "cpu": 2.0}]}]}"#,
        )
        .unwrap();
        let mut sources = Sources::default();
        let mut values = |q: &str| sources.values(dir.path(), &call(q));
        assert_eq!(
            values("value(r.json: cases.trackers.cpu | scene=head, tracker=delta)").unwrap(),
            vec![3.0]
        );
        assert_eq!(
            values("sum(r.json: cases.trackers.cpu | tracker=weighted)").unwrap(),
            vec![5.0, 2.0]
        );
        let e = values("value(r.json: cases.trackers.cpu | colour=red)").unwrap_err();
        assert!(format!("{e:#}").contains("filter `colour`"), "{e:#}");
    }
}
