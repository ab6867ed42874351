//! Tables of results and their exporters (after hyperfine's `Exporter`): CSV, JSON and
//! Markdown, and the `cells.csv` table itself (one row per cell, units in the header).

use std::fmt::Write as _;

use anyhow::Result;

use super::collect::Collected;
use super::escape::md_text;
use crate::analyse::METRIC_COLUMNS;
use crate::store::PlanRecord;

/// A table value.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Field {
    /// Text.
    Text(String),
    /// A number.
    Number(f64),
    /// No value.
    Empty,
}

impl Field {
    pub(crate) fn text(&self) -> String {
        match self {
            Field::Text(s) => s.clone(),
            Field::Number(v) => format_number(*v),
            Field::Empty => String::new(),
        }
    }
}

fn format_number(v: f64) -> String {
    if v == v.trunc() && v.abs() < 1e15 {
        format!("{v:.0}")
    } else if v.abs() >= 1e-3 && v.abs() < 1e6 {
        format!("{v:.6}")
            .trim_end_matches('0')
            .trim_end_matches('.')
            .to_string()
    } else {
        format!("{v:.6e}")
    }
}

/// A table of results.
#[derive(Debug, Clone, Default)]
pub(crate) struct Table {
    /// Column headers (with units).
    pub(crate) headers: Vec<String>,
    /// Rows.
    pub(crate) rows: Vec<Vec<Field>>,
}

/// Writes a [`Table`] in one format (after hyperfine's exporters).
pub(crate) trait Exporter {
    /// Serialises the table.
    fn serialize(&self, table: &Table) -> Result<Vec<u8>>;
}

/// Comma-separated values with a header row.
pub(crate) struct CsvExporter;
/// An array of objects keyed by header.
pub(crate) struct JsonExporter;
/// A GitHub-flavoured Markdown table of selected columns.
pub(crate) struct MarkdownExporter {
    /// Column indices to include (all when empty).
    pub(crate) columns: Vec<usize>,
}

impl Exporter for CsvExporter {
    fn serialize(&self, table: &Table) -> Result<Vec<u8>> {
        let mut w = csv::Writer::from_writer(Vec::new());
        w.write_record(&table.headers)?;
        for row in &table.rows {
            w.write_record(row.iter().map(Field::text))?;
        }
        w.into_inner().map_err(|e| anyhow::anyhow!("{e}"))
    }
}

impl Exporter for JsonExporter {
    fn serialize(&self, table: &Table) -> Result<Vec<u8>> {
        let rows: Vec<serde_json::Map<String, serde_json::Value>> = table
            .rows
            .iter()
            .map(|row| {
                table
                    .headers
                    .iter()
                    .zip(row)
                    .map(|(h, f)| {
                        let v = match f {
                            Field::Text(s) => serde_json::Value::String(s.clone()),
                            Field::Number(n) => serde_json::json!(n),
                            Field::Empty => serde_json::Value::Null,
                        };
                        (h.clone(), v)
                    })
                    .collect()
            })
            .collect();
        Ok(serde_json::to_vec_pretty(&rows)?)
    }
}

impl Exporter for MarkdownExporter {
    fn serialize(&self, table: &Table) -> Result<Vec<u8>> {
        let cols: Vec<usize> = if self.columns.is_empty() {
            (0..table.headers.len()).collect()
        } else {
            self.columns.clone()
        };
        let mut s = String::new();
        let _ = writeln!(
            s,
            "| {} |",
            cols.iter()
                .map(|&c| md_text(&table.headers[c]))
                .collect::<Vec<_>>()
                .join(" | ")
        );
        let _ = writeln!(s, "|{}", cols.iter().map(|_| "---|").collect::<String>());
        for row in &table.rows {
            let _ = writeln!(
                s,
                "| {} |",
                cols.iter()
                    .map(|&c| md_text(&row[c].text()))
                    .collect::<Vec<_>>()
                    .join(" | ")
            );
        }
        Ok(s.into_bytes())
    }
}

/// The `cells.csv` table.
pub(crate) fn cells_table(plan: &PlanRecord, cells: &[Collected]) -> Table {
    let mut headers: Vec<String> = vec!["cell".into(), "hash".into(), "status".into()];
    headers.extend(plan.axes.iter().cloned());
    headers.extend(
        [
            "method",
            "seed",
            "volume",
            "volume_sha256",
            "transfer",
            "sigma_mapping",
            "version",
            "host",
            "reference",
        ]
        .iter()
        .map(|s| s.to_string()),
    );
    headers.extend(METRIC_COLUMNS.iter().map(|m| m.header.to_string()));
    let rows = cells
        .iter()
        .map(|c| {
            let mut row = vec![
                Field::Number(c.planned.index as f64),
                Field::Text(c.planned.hash.clone()),
                Field::Text(c.status().into()),
            ];
            for axis in &plan.axes {
                let v = c
                    .planned
                    .axes
                    .iter()
                    .find(|(k, _)| k == axis)
                    .map(|(_, v)| v);
                row.push(match v {
                    Some(serde_json::Value::Number(n)) => {
                        n.as_f64().map_or(Field::Empty, Field::Number)
                    }
                    Some(serde_json::Value::String(s)) => Field::Text(s.clone()),
                    Some(other) => Field::Text(other.to_string()),
                    None => Field::Empty,
                });
            }
            let text = |s: Option<String>| s.map_or(Field::Empty, Field::Text);
            let r = c.record.as_ref();
            row.push(Field::Text(c.planned.method.clone()));
            row.push(r.map_or(Field::Empty, |r| {
                Field::Number(r.provenance.scene.integrator.seed as f64)
            }));
            row.push(text(r.map(|r| {
                match &r.provenance.volume {
                    volphot::VolumeSource::File { dataset, path, .. } => dataset
                        .clone()
                        .unwrap_or_else(|| path.display().to_string()),
                    volphot::VolumeSource::Phantom { name, parameters } => {
                        format!("phantom {name} ({parameters})")
                    }
                }
            })));
            row.push(text(r.map(|r| r.provenance.volume.identity())));
            row.push(text(r.map(|r| r.provenance.transfer.clone())));
            row.push(text(r.map(|r| r.provenance.sigma_mapping.clone())));
            row.push(text(r.map(|r| r.version.clone())));
            row.push(text(r.map(|r| r.host.clone())));
            row.push(text(c.planned.reference.clone()));
            for m in METRIC_COLUMNS {
                row.push(
                    r.and_then(|r| (m.value)(r, c.reference.as_ref()))
                        .map_or(Field::Empty, Field::Number),
                );
            }
            row
        })
        .collect();
    Table { headers, rows }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn table() -> Table {
        Table {
            headers: vec!["cell".into(), "name".into(), "rmse [W/(m2 sr)]".into()],
            rows: vec![
                vec![
                    Field::Number(0.0),
                    Field::Text("a, b".into()),
                    Field::Number(0.125),
                ],
                vec![Field::Number(1.0), Field::Text("c".into()), Field::Empty],
            ],
        }
    }

    #[test]
    fn exporters_write_every_row() {
        let csv = String::from_utf8(CsvExporter.serialize(&table()).unwrap()).unwrap();
        assert_eq!(csv, "cell,name,rmse [W/(m2 sr)]\n0,\"a, b\",0.125\n1,c,\n");
        let json: serde_json::Value =
            serde_json::from_slice(&JsonExporter.serialize(&table()).unwrap()).unwrap();
        assert_eq!(json[1]["rmse [W/(m2 sr)]"], serde_json::Value::Null);
        let md = String::from_utf8(
            MarkdownExporter {
                columns: vec![0, 2],
            }
            .serialize(&table())
            .unwrap(),
        )
        .unwrap();
        assert!(md.starts_with("| cell | rmse [W/(m2 sr)] |\n|---|---|\n| 0 | 0.125 |"));
    }
}
