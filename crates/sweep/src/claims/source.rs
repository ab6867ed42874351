//! The data a claim is checked against: a study's `cells.csv`, any CSV file (a plot's
//! points, a tune's observations), a JSON file (the committed bench) or a TOML file (a
//! study's `experiment.toml`), read once each.
//!
//! A claim names its source relative to the document's folder (or `--base`), and that is
//! where it must stay: absolute paths, `..` and symbolic links that lead outside are
//! refused, every file goes through the capped regular-file reader (no FIFO, no device,
//! no file over 16 MiB), and no error quotes more than a few escaped bytes of a value — a
//! checked document is often a pull request's, and its errors land in a public CI log.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, anyhow, bail};
use serde_json::Value;

use super::expr::{Call, Data, Filter};
use super::quote::shown;
use crate::confine::Refused;

/// One table: rows of column key → text. A CSV header `ms_share [1]` has the key
/// `ms_share` (its unit dropped), so a claim names a column as the documents do.
struct Table {
    rows: Vec<HashMap<String, String>>,
}

enum Loaded {
    Table(Table),
    Json(Value),
}

/// Files read so far, by path, under one root.
pub(crate) struct Sources {
    /// The folder relative sources start from (the document's, or `--base`).
    from: PathBuf,
    /// The folder every source must stay in (links resolved): `--base`, else the
    /// repository that holds the document, else the document's folder.
    root: PathBuf,
    loaded: HashMap<PathBuf, Loaded>,
}

/// A CSV header without its unit: `rmse [W/(m2 sr)]` → `rmse`.
fn key_of(header: &str) -> &str {
    header.split(" [").next().unwrap_or(header).trim()
}

fn read_table(path: &Path, text: &str) -> Result<Table> {
    let mut reader = csv::Reader::from_reader(text.as_bytes());
    let headers: Vec<String> = reader
        .headers()
        .map_err(|e| csv_error(path, &e))?
        .iter()
        .map(|h| key_of(h).to_string())
        .collect();
    let mut rows = Vec::new();
    for record in reader.records() {
        let record = record.map_err(|e| csv_error(path, &e))?;
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

/// A CSV error by its position only.
fn csv_error(path: &Path, e: &csv::Error) -> anyhow::Error {
    let at = e
        .position()
        .map_or(String::new(), |p| format!(" at line {}", p.line()));
    let what = match e.kind() {
        csv::ErrorKind::UnequalLengths {
            expected_len, len, ..
        } => {
            format!("a record has {len} fields where the header has {expected_len}")
        }
        _ => "not CSV".to_string(),
    };
    anyhow!("{}{at}: {what}", path.display())
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

/// The sources of one document, answering its claims' calls.
pub(crate) struct DocumentData<'a> {
    pub(crate) sources: &'a mut Sources,
}

impl Data for DocumentData<'_> {
    fn values(&mut self, call: &Call) -> Result<Vec<f64>> {
        Ok(self
            .sources
            .rows(call)?
            .into_iter()
            .map(|(v, _)| v)
            .collect())
    }

    fn distinct(&mut self, call: &Call, key: &str) -> Result<Vec<String>> {
        let mut out: Vec<String> = Vec::new();
        for (_, g) in self.sources.rows_grouped(call, key)? {
            if !out.contains(&g) {
                out.push(g);
            }
        }
        Ok(out)
    }
}

impl Sources {
    /// Sources relative to `from`, confined to `root` (links in both resolved once here).
    pub(crate) fn new(from: &Path, root: &Path) -> Result<Self> {
        let canonical = |p: &Path| {
            std::fs::canonicalize(p).with_context(|| format!("the claims' folder {}", p.display()))
        };
        Ok(Sources {
            from: canonical(from)?,
            root: canonical(root)?,
            loaded: HashMap::new(),
        })
    }

    /// The file a call's source names, inside the root.
    fn resolve(&self, source: &str) -> Result<PathBuf> {
        let relative = Path::new(source);
        if relative.is_absolute() || source.is_empty() {
            bail!(
                "source `{source}` must be a relative path (to the document's folder), inside {}",
                self.root.display()
            );
        }
        let inside = |path: &Path| -> Result<PathBuf> {
            crate::confine::inside(path, &self.root).map_err(|refused| match refused {
                Refused::Missing(path) => {
                    anyhow!("source `{source}`: {} does not exist", path.display())
                }
                Refused::Outside { root, .. } => anyhow!(
                    "source `{source}` leads outside {} (after resolving `..` and links); claims read only the document's repository",
                    root.display()
                ),
                Refused::Hidden(_) => {
                    anyhow!("source `{source}` is a hidden file or inside a hidden folder")
                }
            })
        };
        let mut path = inside(&self.from.join(relative))?;
        if path.is_dir() {
            path = inside(&path.join("cells.csv"))?;
        }
        Ok(path)
    }

    fn load(&mut self, source: &str) -> Result<&Loaded> {
        let path = self.resolve(source)?;
        if !self.loaded.contains_key(&path) {
            let extension = path.extension().and_then(|e| e.to_str()).unwrap_or("");
            let text = volphot::read_text_capped(&path, volphot::TEXT_INPUT_CAP, "claim source")?;
            let loaded = match extension {
                "json" => Loaded::Json(serde_json::from_str(&text).map_err(|e| {
                    anyhow!(
                        "{}: not JSON (line {}, column {})",
                        path.display(),
                        e.line(),
                        e.column()
                    )
                })?),
                // An experiment's own settings (a study's `experiment.toml`), read as JSON.
                "toml" => {
                    let table: toml::Table = text.parse().map_err(|e: toml::de::Error| {
                        let line = e.span().map_or(1, |s| volphot::line_col(&text, s.start).0);
                        anyhow!("{}: not TOML (line {line})", path.display())
                    })?;
                    Loaded::Json(serde_json::to_value(table)?)
                }
                _ => Loaded::Table(read_table(&path, &text)?),
            };
            self.loaded.insert(path.clone(), loaded);
        }
        Ok(&self.loaded[&path])
    }

    /// The values a call reduces: the column of every matching row that has a number there
    /// (an empty cell is a metric undefined for that row, not a 0).
    pub(crate) fn rows(&mut self, call: &Call) -> Result<Vec<(f64, String)>> {
        self.rows_grouped(call, "")
    }

    /// Like [`Sources::rows`], each value with the text of field `key` of its row (empty
    /// `key`: no field).
    fn rows_grouped(&mut self, call: &Call, key: &str) -> Result<Vec<(f64, String)>> {
        let source = call.source.clone();
        match self.load(&source)? {
            Loaded::Table(t) => table_values(t, call, key),
            Loaded::Json(v) => json_values(v, call, key),
        }
        .with_context(|| format!("in `{source}`"))
    }
}

fn table_values(table: &Table, call: &Call, key: &str) -> Result<Vec<(f64, String)>> {
    if let Some(first) = table.rows.first() {
        for wanted in [call.column.as_str(), key] {
            if !wanted.is_empty() && !first.contains_key(wanted) {
                bail!("no column `{wanted}`");
            }
        }
    }
    let mut values = Vec::new();
    for (i, row) in table.rows.iter().enumerate() {
        if !passes(&call.filters, |k| row.get(k).cloned())? {
            continue;
        }
        let text = &row[&call.column];
        if text.is_empty() {
            continue;
        }
        let value: f64 = text
            .parse()
            .map_err(|_| anyhow!("`{}` holds {}, not a number", call.column, shown(text)))?;
        // `NaN` and `inf` parse as numbers; no aggregate may sort, skip or average them.
        if !value.is_finite() {
            bail!(
                "`{}` holds {} in record {} (after the header), not a finite number: an undefined metric is an empty cell",
                call.column,
                shown(text),
                i + 1
            );
        }
        let group = if key.is_empty() {
            String::new()
        } else {
            row[key].clone()
        };
        values.push((value, group));
    }
    Ok(values)
}

/// Follows the dotted path; every array on the way is filtered by the filters its elements
/// carry (each element an object whose fields, dotted, the filters name): `cases.trackers.x
/// where scene=foot, tracker=delta` picks the foot's case and, inside it, delta's entry.
/// Every filter must name a field of the elements of some array on the way. A `key` names
/// the group of each value: the field of the array elements that carry it.
fn json_values(root: &Value, call: &Call, key: &str) -> Result<Vec<(f64, String)>> {
    let segments: Vec<&str> = call.column.split('.').collect();
    let mut walk = Walk {
        call,
        key,
        used: vec![false; call.filters.len()],
        key_seen: key.is_empty(),
        out: Vec::new(),
    };
    walk.walk(root, &segments, "")?;
    if let Some(k) = walk.used.iter().position(|u| !u) {
        bail!(
            "filter `{}`: no array on the way to `{}` has elements with that field",
            call.filters[k].key,
            call.column
        );
    }
    if !walk.key_seen {
        bail!(
            "`{key}`: no array on the way to `{}` has elements with that field",
            call.column
        );
    }
    Ok(walk.out)
}

struct Walk<'a> {
    call: &'a Call,
    key: &'a str,
    used: Vec<bool>,
    key_seen: bool,
    out: Vec<(f64, String)>,
}

impl Walk<'_> {
    fn walk(&mut self, v: &Value, path: &[&str], group: &str) -> Result<()> {
        if let Value::Array(items) = v {
            let carried = |field: &str| {
                !items.is_empty() && items.iter().all(|i| json_field(i, field).is_some())
            };
            // The filters this array's elements carry (all of them carry the field).
            let mut here: Vec<Filter> = Vec::new();
            for (k, f) in self.call.filters.iter().enumerate() {
                if carried(&f.key) {
                    self.used[k] = true;
                    here.push(f.clone());
                }
            }
            let groups_here = !self.key.is_empty() && carried(self.key);
            self.key_seen |= groups_here;
            for item in items {
                if passes(&here, |k| json_field(item, k))? {
                    let g = if groups_here {
                        json_field(item, self.key).unwrap_or_default()
                    } else {
                        group.to_string()
                    };
                    self.walk(item, path, &g)?;
                }
            }
            return Ok(());
        }
        let Some((head, rest)) = path.split_first() else {
            return match v {
                Value::Number(n) => {
                    self.out
                        .push((n.as_f64().unwrap_or(f64::NAN), group.to_string()));
                    Ok(())
                }
                Value::Null => Ok(()),
                other => bail!("`{}` is {}, not a number", self.call.column, kind(other)),
            };
        };
        let next = v
            .get(head)
            .ok_or_else(|| anyhow!("no field `{head}` on the way to `{}`", self.call.column))?;
        self.walk(next, rest, group)
    }
}

/// What a JSON value is, without its content.
fn kind(v: &Value) -> String {
    match v {
        Value::String(s) => shown(s),
        Value::Bool(_) => "true or false".into(),
        Value::Object(o) => format!("an object of {} fields", o.len()),
        Value::Array(a) => format!("an array of {} elements", a.len()),
        Value::Null | Value::Number(_) => "a number".into(),
    }
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
    use super::super::expr::{Aggregate, Expr, parse};
    use super::*;

    fn call(text: &str) -> Call {
        match parse(text).unwrap() {
            Expr::Call(c) => c,
            other => panic!("{other:?}"),
        }
    }

    fn values(sources: &mut Sources, q: &str) -> Result<Vec<f64>> {
        DocumentData { sources }.values(&call(q))
    }

    #[test]
    fn csv_columns_by_key_with_filters_and_undefined_cells_skipped() {
        let dir = tempfile::tempdir().unwrap();
        let study = dir.path().join("s");
        std::fs::create_dir(&study).unwrap();
        std::fs::write(
            study.join("cells.csv"),
            "cell,scene,sigma.t,integrator.multiple,ms_share [1],seed\n\
             0,scenes/foot.toml,80,false,,1\n\
             1,scenes/foot.toml,80,true,0.5,1\n\
             2,scenes/foot.toml,80.0,true,0.25,2\n\
             3,scenes/engine.toml,80,true,0.9,1\n",
        )
        .unwrap();
        let mut sources = Sources::new(dir.path(), dir.path()).unwrap();
        let v = values(
            &mut sources,
            "mean(s: ms_share where scene=foot, sigma.t=80)",
        )
        .unwrap();
        assert_eq!(v, vec![0.5, 0.25]);
        assert_eq!(Aggregate::Mean.apply(&v).unwrap(), 0.375);
        let v = values(&mut sources, "count(s: cell where scene!=foot)").unwrap();
        assert_eq!(v, vec![3.0]);
        let e = values(&mut sources, "mean(s: rmse)").unwrap_err();
        assert!(format!("{e:#}").contains("no column `rmse`"), "{e:#}");
        let groups = DocumentData {
            sources: &mut sources,
        }
        .distinct(&call("mean(s: ms_share where scene=foot)"), "seed")
        .unwrap();
        assert_eq!(groups, vec!["1".to_string(), "2".to_string()]);
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
        let mut sources = Sources::new(dir.path(), dir.path()).unwrap();
        let v = values(
            &mut sources,
            "value(b.json: configurations.render.seconds where name=cached)",
        )
        .unwrap();
        assert_eq!(v, vec![4.0]);
        let v = values(&mut sources, "value(b.json: machine.cores)").unwrap();
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
        let mut sources = Sources::new(dir.path(), dir.path()).unwrap();
        assert_eq!(
            values(
                &mut sources,
                "value(r.json: cases.trackers.cpu where scene=head, tracker=delta)"
            )
            .unwrap(),
            vec![3.0]
        );
        assert_eq!(
            values(
                &mut sources,
                "sum(r.json: cases.trackers.cpu where tracker=weighted)"
            )
            .unwrap(),
            vec![5.0, 2.0]
        );
        let e = values(
            &mut sources,
            "value(r.json: cases.trackers.cpu where colour=red)",
        )
        .unwrap_err();
        assert!(format!("{e:#}").contains("filter `colour`"), "{e:#}");
        let groups = DocumentData {
            sources: &mut sources,
        }
        .distinct(&call("mean(r.json: cases.trackers.cpu)"), "scene")
        .unwrap();
        assert_eq!(groups, vec!["foot".to_string(), "head".to_string()]);
    }

    /// Case 1 of the fourth reliability round: a document could read any file and print
    /// its values in errors.
    #[test]
    fn sources_stay_inside_the_folder_and_errors_do_not_quote_values() {
        let dir = tempfile::tempdir().unwrap();
        let docs = dir.path().join("docs");
        std::fs::create_dir(&docs).unwrap();
        let secret = dir.path().join("secret.csv");
        std::fs::write(&secret, "k,v\nkey,-----BEGIN PRIVATE KEY-----\n").unwrap();
        std::os::unix::fs::symlink(dir.path(), docs.join("up")).unwrap();
        std::fs::write(
            docs.join("creds.json"),
            r#"{"auth": {"token": "hunter2-very-secret"}}"#,
        )
        .unwrap();
        std::fs::write(docs.join("c.csv"), "k,v\na,password=hunter2\n").unwrap();
        let mut sources = Sources::new(&docs, &docs).unwrap();
        for (q, says) in [
            ("value(../secret.csv: v)", "leads outside"),
            ("value(/etc/passwd: v)", "relative path"),
            ("value(up/secret.csv: v)", "leads outside"),
            ("value(creds.json: auth)", "an object of 1 fields"),
            ("value(creds.json: auth.token)", "19-byte text"),
            ("value(c.csv: v)", "16-byte text starting `pas…`"),
        ] {
            let e = format!("{:#}", values(&mut sources, q).unwrap_err());
            assert!(e.contains(says), "{q}: {e}");
            for secret in ["hunter2", "PRIVATE", "password"] {
                assert!(!e.contains(secret), "{q} quotes its data: {e}");
            }
        }
    }

    /// Case 9: a FIFO or a device as a source fails at once.
    #[test]
    fn a_fifo_or_a_device_is_refused_at_once() {
        let dir = tempfile::tempdir().unwrap();
        let fifo = dir.path().join("f.csv");
        assert!(
            std::process::Command::new("mkfifo")
                .arg(&fifo)
                .status()
                .unwrap()
                .success()
        );
        std::os::unix::fs::symlink("/dev/zero", dir.path().join("z.csv")).unwrap();
        let mut sources = Sources::new(dir.path(), dir.path()).unwrap();
        let e = format!("{:#}", values(&mut sources, "value(f.csv: v)").unwrap_err());
        assert!(e.contains("FIFO"), "{e}");
        let e = format!("{:#}", values(&mut sources, "value(z.csv: v)").unwrap_err());
        assert!(e.contains("outside"), "{e}");
    }
}
