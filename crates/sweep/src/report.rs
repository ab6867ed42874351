//! Collecting finished cells into `cells.csv`, figures, `report.md` and a self-contained
//! `report.html`. Works from the output folder alone, so `sweep report DIR` regenerates
//! everything without rendering.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use volphot::film::{Film, Layer};

use crate::cells::{
    CellRecord, IMAGE_STATS_VERSION, METRIC_COLUMNS, OutputDir, ReferenceMetrics, is_done,
    read_record, read_reference_metrics, write_record,
};
use crate::experiment::{Experiment, PlotSpec, SheetSpec};
use crate::figures::{
    Rgb8, Tile, amplified_difference, auto_gain, contact_sheet, sig3, signed_difference,
};
use crate::metrics;
use crate::plots::{Plot, Series, write_plot};
use crate::runner::{
    PlanRecord, PlannedCell, compute_reference_metrics, read_plan, read_reference_record,
};

/// A table value.
#[derive(Debug, Clone, PartialEq)]
pub enum Field {
    /// Text.
    Text(String),
    /// A number.
    Number(f64),
    /// No value.
    Empty,
}

impl Field {
    fn text(&self) -> String {
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
pub struct Table {
    /// Column headers (with units).
    pub headers: Vec<String>,
    /// Rows.
    pub rows: Vec<Vec<Field>>,
}

/// Writes a [`Table`] in one format (after hyperfine's exporters).
pub trait Exporter {
    /// Serialises the table.
    fn serialize(&self, table: &Table) -> Result<Vec<u8>>;
}

/// Comma-separated values with a header row.
pub struct CsvExporter;
/// An array of objects keyed by header.
pub struct JsonExporter;
/// A GitHub-flavoured Markdown table of selected columns.
pub struct MarkdownExporter {
    /// Column indices to include (all when empty).
    pub columns: Vec<usize>,
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
                .map(|&c| table.headers[c].replace('|', "\\|"))
                .collect::<Vec<_>>()
                .join(" | ")
        );
        let _ = writeln!(s, "|{}", cols.iter().map(|_| "---|").collect::<String>());
        for row in &table.rows {
            let _ = writeln!(
                s,
                "| {} |",
                cols.iter()
                    .map(|&c| row[c].text().replace('|', "\\|"))
                    .collect::<Vec<_>>()
                    .join(" | ")
            );
        }
        Ok(s.into_bytes())
    }
}

/// One cell's collected state.
pub struct Collected {
    /// From the plan.
    pub planned: PlannedCell,
    /// Its record when finished.
    pub record: Option<CellRecord>,
    /// Errors against the reference.
    pub reference: Option<ReferenceMetrics>,
    /// Error text of a failed attempt.
    pub failure: Option<String>,
}

impl Collected {
    /// `done`, `failed` or `pending`.
    pub fn status(&self) -> &'static str {
        if self.record.is_some() {
            "done"
        } else if self.failure.is_some() {
            "failed"
        } else {
            "pending"
        }
    }
}

/// Reads every planned cell's state; computes missing reference metrics when possible.
pub fn collect(out: &OutputDir) -> Result<(PlanRecord, Vec<Collected>)> {
    let plan = read_plan(out)?;
    let mut cells = Vec::new();
    for p in &plan.cells {
        let dir = out.cell(&p.hash);
        // The film is read only if something has to be recomputed from it, and then once.
        let mut film = None;
        let record = if is_done(&dir) {
            let mut record = read_record(&dir)?;
            if record.image.version != IMAGE_STATS_VERSION {
                refresh_image_stats(&dir, &mut record, cell_film(&dir, &mut film)?)?;
            }
            Some(record)
        } else {
            None
        };
        let mut reference = None;
        if let (Some(r), Some(key)) = (&record, &p.reference) {
            reference = read_reference_metrics(&dir, key);
            if reference.is_none() && read_reference_record(&out.reference(key)).is_ok() {
                let film = cell_film(&dir, &mut film)?;
                compute_reference_metrics(out, &p.hash, key, &r.provenance.scene, film)?;
                reference = read_reference_metrics(&dir, key);
            }
        }
        let failure = if record.is_none() {
            std::fs::read_to_string(out.failure(&p.hash)).ok()
        } else {
            None
        };
        cells.push(Collected {
            planned: p.clone(),
            record,
            reference,
            failure,
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
    let shown = metrics::displayed(film, p.integrator.multiple, p.integrator.emission);
    record.image = metrics::image_stats(film, &shown, p.film.exposure);
    write_record(dir, record)
}

/// The `cells.csv` table.
pub fn cells_table(plan: &PlanRecord, cells: &[Collected]) -> Table {
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
                    volphot::volume::VolumeSource::File { dataset, path, .. } => dataset
                        .clone()
                        .unwrap_or_else(|| path.display().to_string()),
                    volphot::volume::VolumeSource::Phantom { name, parameters } => {
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

/// Whether a cell's axis values match a `where` table (numbers compare by value).
fn matches(c: &PlannedCell, filter: &toml::Table) -> bool {
    filter.iter().all(|(k, v)| {
        let want = crate::runner::toml_to_json(v);
        match (axis_value(c, k), want) {
            (Some(a), b) if a == b => true,
            (Some(serde_json::Value::Number(a)), serde_json::Value::Number(b)) => {
                a.as_f64() == b.as_f64()
            }
            _ => false,
        }
    })
}

fn axis_value(c: &PlannedCell, key: &str) -> Option<serde_json::Value> {
    c.axes
        .iter()
        .find(|(k, _)| k == key)
        .map(|(_, v)| v.clone())
}

fn value_label(v: &serde_json::Value) -> String {
    match v {
        serde_json::Value::String(s) => s.clone(),
        other => other.to_string(),
    }
}

fn numeric(v: &serde_json::Value) -> Option<f64> {
    v.as_f64()
}

/// Everything a report links to.
#[derive(Default)]
struct Figures {
    sheets: Vec<(String, PathBuf)>,
    diffs: Vec<(String, PathBuf)>,
    plots: Vec<(String, PathBuf)>,
    comparisons: Vec<(String, Table)>,
}

/// Builds `cells.csv`, `cells.json`, figures, `report.md` and `report.html`.
pub fn build_report(out: &OutputDir) -> Result<PathBuf> {
    let (plan, cells) = collect(out)?;
    let table = cells_table(&plan, &cells);
    volphot::fsutil::write_atomic(
        &out.root().join("cells.csv"),
        &CsvExporter.serialize(&table)?,
    )?;
    volphot::fsutil::write_atomic(
        &out.root().join("cells.json"),
        &JsonExporter.serialize(&table)?,
    )?;
    let experiment = Experiment::load(&out.root().join("experiment.toml"))
        .with_context(|| format!("{}: reading the experiment copy", out.root().display()))?;
    std::fs::create_dir_all(out.figures())?;
    let mut figures = Figures::default();
    contact_sheets(out, &plan, &cells, &experiment, &mut figures)?;
    layer_differences(out, &cells, &experiment, &mut figures)?;
    axis_comparisons(out, &plan, &cells, &experiment, &mut figures)?;
    plots(out, &plan, &cells, &experiment, &mut figures)?;
    let markdown = markdown(out, &plan, &cells, &table, &experiment, &figures);
    volphot::fsutil::write_atomic(&out.root().join("report.md"), markdown.as_bytes())?;
    let html = html(out.root(), &markdown)?;
    let path = out.root().join("report.html");
    volphot::fsutil::write_atomic(&path, html.as_bytes())?;
    Ok(path)
}

fn sheet_specs(plan: &PlanRecord, experiment: &Experiment) -> Vec<SheetSpec> {
    if !experiment.sheets.is_empty() {
        return experiment.sheets.clone();
    }
    let mut specs = Vec::new();
    if let Some(rows) = plan.axes.first() {
        for layer in ["total", "multiple"] {
            specs.push(SheetSpec {
                rows: rows.clone(),
                cols: plan.axes.get(1).cloned(),
                layer: layer.into(),
                filter: Default::default(),
            });
        }
    }
    specs
}

fn distinct_values<'a, C: std::borrow::Borrow<Collected> + 'a>(
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

fn contact_sheets(
    out: &OutputDir,
    plan: &PlanRecord,
    cells: &[Collected],
    experiment: &Experiment,
    figures: &mut Figures,
) -> Result<()> {
    let specs = sheet_specs(plan, experiment);
    if specs.is_empty() {
        // No axes: one image.
        if let Some(c) = cells.first().filter(|c| c.record.is_some()) {
            let img = Rgb8::read_png(&out.cell(&c.planned.hash).join("total.png"))?;
            let sheet = contact_sheet(
                &plan.experiment,
                &[Tile {
                    image: Some(img),
                    caption: c.planned.label.clone(),
                }],
                1,
                384,
            );
            let path = out.figures().join("sheet_total.png");
            sheet.write_png(&path)?;
            figures.sheets.push(("the rendered image".into(), path));
        }
        return Ok(());
    }
    for (si, spec) in specs.iter().enumerate() {
        let selected: Vec<&Collected> = cells
            .iter()
            .filter(|c| matches(&c.planned, &spec.filter))
            .collect();
        let cells = selected.as_slice();
        let rest: Vec<&String> = plan
            .axes
            .iter()
            .filter(|a| **a != spec.rows && Some(*a) != spec.cols.as_ref())
            .collect();
        // One sheet per combination of the remaining axes (at most 12).
        let mut combos: Vec<Vec<(String, serde_json::Value)>> = Vec::new();
        for c in cells {
            let combo: Vec<(String, serde_json::Value)> = rest
                .iter()
                .filter_map(|k| axis_value(&c.planned, k).map(|v| ((*k).clone(), v)))
                .collect();
            if !combos.contains(&combo) {
                combos.push(combo);
            }
        }
        let row_values = distinct_values(cells, &spec.rows);
        let col_values = spec
            .cols
            .as_ref()
            .map(|k| distinct_values(cells, k))
            .unwrap_or_else(|| vec![serde_json::Value::Null]);
        let tile = if col_values.len() > 6 { 160 } else { 256 };
        for (ci, combo) in combos.iter().take(12).enumerate() {
            let mut tiles = Vec::new();
            for rv in &row_values {
                for cv in &col_values {
                    let found = cells.iter().find(|c| {
                        axis_value(&c.planned, &spec.rows).as_ref() == Some(rv)
                            && spec
                                .cols
                                .as_ref()
                                .is_none_or(|k| axis_value(&c.planned, k).as_ref() == Some(cv))
                            && combo
                                .iter()
                                .all(|(k, v)| axis_value(&c.planned, k).as_ref() == Some(v))
                    });
                    let mut caption = format!(
                        "{} = {}",
                        crate::experiment::short_key(&spec.rows),
                        value_label(rv)
                    );
                    if let Some(k) = &spec.cols {
                        caption += &format!(
                            ", {} = {}",
                            crate::experiment::short_key(k),
                            value_label(cv)
                        );
                    }
                    let image = match found {
                        Some(c) if c.record.is_some() => {
                            let file = match spec.layer.as_str() {
                                "diff" => out
                                    .figures()
                                    .join("diff")
                                    .join(format!("{}_amplified.png", c.planned.hash)),
                                layer => out.cell(&c.planned.hash).join(format!("{layer}.png")),
                            };
                            Rgb8::read_png(&file).ok()
                        }
                        _ => None,
                    };
                    tiles.push(Tile { image, caption });
                }
            }
            let fixed = combo
                .iter()
                .map(|(k, v)| format!("{} = {}", crate::experiment::short_key(k), value_label(v)))
                .collect::<Vec<_>>()
                .join(", ");
            let title = format!(
                "{} — {}{}",
                plan.experiment,
                spec.layer,
                if fixed.is_empty() {
                    String::new()
                } else {
                    format!(" ({fixed})")
                }
            );
            let sheet = contact_sheet(&title, &tiles, col_values.len(), tile);
            let path = out
                .figures()
                .join(format!("sheet{si}_{}_{ci}.png", spec.layer));
            sheet.write_png(&path)?;
            figures.sheets.push((title, path));
        }
    }
    Ok(())
}

/// Single vs single + multiple: the difference is the multiple-scattering layer. One gain
/// for all cells, so amplified images compare across the grid.
fn layer_differences(
    out: &OutputDir,
    cells: &[Collected],
    experiment: &Experiment,
    figures: &mut Figures,
) -> Result<()> {
    let Some(spec) = experiment.compare.iter().find(|c| c.kind == "layers") else {
        return Ok(());
    };
    let dir = out.figures().join("diff");
    std::fs::create_dir_all(&dir)?;
    let mut films = Vec::new();
    for c in cells.iter().filter(|c| {
        c.record
            .as_ref()
            .is_some_and(|r| r.provenance.scene.integrator.multiple)
    }) {
        let film = Film::read_exr(&out.cell(&c.planned.hash).join("film.exr"))?;
        films.push((c, film));
    }
    if films.is_empty() {
        return Ok(());
    }
    let exposure = films[0]
        .0
        .record
        .as_ref()
        .map_or(0.0, |r| r.provenance.scene.film.exposure);
    let gain = spec.gain.unwrap_or_else(|| {
        let all: Vec<f32> = films
            .iter()
            .flat_map(|(_, f)| {
                f.layer(Layer::Multiple)
                    .iter()
                    .map(|v| crate::metrics::luminance(*v))
            })
            .collect();
        auto_gain(&all, exposure)
    });
    let scale = films
        .iter()
        .flat_map(|(_, f)| {
            f.layer(Layer::Multiple)
                .iter()
                .map(|v| crate::metrics::luminance(*v))
        })
        .fold(0.0f32, f32::max)
        .max(1e-9);
    for (c, film) in &films {
        let (w, h) = (film.width(), film.height());
        let with = film.combine(&[Layer::Single, Layer::Multiple]);
        let without = film.combine(&[Layer::Single]);
        let amp = amplified_difference(&with, &without, w, h, gain, exposure);
        let signed = signed_difference(&with, &without, w, h, scale);
        let amp_path = dir.join(format!("{}_amplified.png", c.planned.hash));
        amp.write_png(&amp_path)?;
        signed.write_png(&dir.join(format!("{}_signed.png", c.planned.hash)))?;
        // Side by side: single, single + multiple, amplified difference (thesis Figs. 17/18).
        let single = Rgb8::read_png(&out.cell(&c.planned.hash).join("single.png"))?;
        let total = Rgb8::read_png(&out.cell(&c.planned.hash).join("total.png"))?;
        let tiles = [
            Tile {
                image: Some(single),
                caption: "single scattering".into(),
            },
            Tile {
                image: Some(total),
                caption: "single + multiple".into(),
            },
            Tile {
                image: Some(amp),
                caption: format!("difference × {}", crate::figures::sig3(gain)),
            },
        ];
        let sheet = contact_sheet(&c.planned.label, &tiles, 3, 320);
        let path = dir.join(format!("{}_compare.png", c.planned.hash));
        sheet.write_png(&path)?;
        figures.diffs.push((
            format!(
                "{}: single vs single + multiple (amplified difference × {})",
                c.planned.label,
                crate::figures::sig3(gain)
            ),
            path,
        ));
    }
    Ok(())
}

/// Cells differing only in one axis: value `a` against value `b`.
fn axis_comparisons(
    out: &OutputDir,
    plan: &PlanRecord,
    cells: &[Collected],
    experiment: &Experiment,
    figures: &mut Figures,
) -> Result<()> {
    for (ci, spec) in experiment
        .compare
        .iter()
        .enumerate()
        .filter(|(_, c)| c.kind == "axis")
    {
        let axis = spec.axis.clone().unwrap_or_default();
        let b_value = spec.b.as_ref().map(crate::runner::toml_to_json);
        let a_value = spec.a.as_ref().map(crate::runner::toml_to_json);
        let others: Vec<&String> = plan.axes.iter().filter(|k| **k != axis).collect();
        let mut table = Table {
            headers: vec![
                "a".into(),
                "b".into(),
                "rmse(a, b) [W/(m2 sr)]".into(),
                "flip(a, b) [1]".into(),
                "Δ disco_energy [1]".into(),
                "Δ mean_multiple [W/(m2 sr)]".into(),
            ],
            rows: Vec::new(),
        };
        let dir = out.figures().join(format!("compare{ci}"));
        std::fs::create_dir_all(&dir)?;
        for a in cells.iter().filter(|c| c.record.is_some()) {
            let Some(av) = axis_value(&a.planned, &axis) else {
                continue;
            };
            if Some(&av) == b_value.as_ref() || a_value.as_ref().is_some_and(|x| *x != av) {
                continue;
            }
            let Some(b) = cells.iter().find(|c| {
                c.record.is_some()
                    && axis_value(&c.planned, &axis) == b_value
                    && others
                        .iter()
                        .all(|k| axis_value(&c.planned, k) == axis_value(&a.planned, k))
            }) else {
                continue;
            };
            let (ra, rb) = (
                a.record.as_ref().expect("done"),
                b.record.as_ref().expect("done"),
            );
            let fa = Film::read_exr(&out.cell(&a.planned.hash).join("film.exr"))?;
            let fb = Film::read_exr(&out.cell(&b.planned.hash).join("film.exr"))?;
            let (w, h) = (fa.width(), fa.height());
            let ia = crate::metrics::displayed(
                &fa,
                ra.provenance.scene.integrator.multiple,
                ra.provenance.scene.integrator.emission,
            );
            let ib = crate::metrics::displayed(
                &fb,
                rb.provenance.scene.integrator.multiple,
                rb.provenance.scene.integrator.emission,
            );
            let m = crate::metrics::compare(
                &ia,
                &ib,
                w,
                h,
                ra.provenance.scene.film.exposure,
                &b.planned.hash,
            );
            let diffs: Vec<f32> = ia
                .iter()
                .zip(&ib)
                .map(|(x, y)| crate::metrics::luminance((*x - *y).abs()))
                .collect();
            let scale = diffs.iter().cloned().fold(0.0f32, f32::max).max(1e-9);
            let gain = spec
                .gain
                .unwrap_or_else(|| auto_gain(&diffs, ra.provenance.scene.film.exposure));
            let signed = signed_difference(&ia, &ib, w, h, scale);
            let amp = amplified_difference(&ia, &ib, w, h, gain, ra.provenance.scene.film.exposure);
            let tiles = [
                Tile {
                    image: Rgb8::read_png(&out.cell(&a.planned.hash).join("total.png")).ok(),
                    caption: format!(
                        "a: {} = {}",
                        crate::experiment::short_key(&axis),
                        value_label(&axis_value(&a.planned, &axis).unwrap_or_default())
                    ),
                },
                Tile {
                    image: Rgb8::read_png(&out.cell(&b.planned.hash).join("total.png")).ok(),
                    caption: format!(
                        "b: {} = {}",
                        crate::experiment::short_key(&axis),
                        value_label(b_value.as_ref().unwrap_or(&serde_json::Value::Null))
                    ),
                },
                Tile {
                    image: Some(signed),
                    caption: "a − b (signed)".into(),
                },
                Tile {
                    image: Some(amp),
                    caption: format!("|a − b| × {}", sig3(gain)),
                },
            ];
            let path = dir.join(format!("{}_vs_{}.png", a.planned.hash, b.planned.hash));
            contact_sheet(&a.planned.label, &tiles, 4, 256).write_png(&path)?;
            figures
                .diffs
                .push((format!("{} vs {}", a.planned.label, b.planned.label), path));
            table.rows.push(vec![
                Field::Text(a.planned.label.clone()),
                Field::Text(b.planned.label.clone()),
                Field::Number(m.rmse),
                Field::Number(m.flip),
                Field::Number(ra.disco.energy - rb.disco.energy),
                Field::Number(ra.mean_multiple - rb.mean_multiple),
            ]);
        }
        figures.comparisons.push((
            format!(
                "`{axis}`: {} vs {}",
                a_value
                    .as_ref()
                    .map_or("each value".to_string(), value_label),
                b_value.as_ref().map_or(String::new(), value_label)
            ),
            table,
        ));
    }
    Ok(())
}

fn plot_specs(plan: &PlanRecord, cells: &[Collected], experiment: &Experiment) -> Vec<PlotSpec> {
    if !experiment.plots.is_empty() {
        return experiment.plots.clone();
    }
    let has_reference = cells.iter().any(|c| c.reference.is_some());
    let mut specs = Vec::new();
    for x in &plan.axes {
        let values = distinct_values(cells, x);
        if values.len() < 2 || !values.iter().all(|v| numeric(v).is_some()) {
            continue;
        }
        let positive = values.iter().all(|v| numeric(v).is_some_and(|n| n > 0.0));
        let spread = values
            .iter()
            .filter_map(numeric)
            .fold(f64::NEG_INFINITY, f64::max)
            / values
                .iter()
                .filter_map(numeric)
                .fold(f64::INFINITY, f64::min);
        let mut y = vec![
            "disco_energy".to_string(),
            "ms_share".into(),
            "time_render".into(),
        ];
        if has_reference {
            y.insert(0, "rmse".into());
            y.insert(1, "flip".into());
        }
        specs.push(PlotSpec {
            x: x.clone(),
            y,
            series: plan.axes.iter().find(|a| *a != x).cloned(),
            log_x: positive && spread > 20.0,
            log_y: false,
            filter: Default::default(),
        });
    }
    specs
}

fn plots(
    out: &OutputDir,
    plan: &PlanRecord,
    cells: &[Collected],
    experiment: &Experiment,
    figures: &mut Figures,
) -> Result<()> {
    let dir = out.figures().join("plots");
    std::fs::create_dir_all(&dir)?;
    for (pi, spec) in plot_specs(plan, cells, experiment).iter().enumerate() {
        let selected: Vec<&Collected> = cells
            .iter()
            .filter(|c| matches(&c.planned, &spec.filter))
            .collect();
        for metric in &spec.y {
            let Some(column) = METRIC_COLUMNS.iter().find(|m| m.key == metric) else {
                continue;
            };
            // series value → x → values (averaged over the remaining axes).
            let mut lines: BTreeMap<String, BTreeMap<i64, (f64, Vec<f64>)>> = BTreeMap::new();
            // Series in the order of the axis values (plan order), not alphabetically.
            let mut order: Vec<String> = Vec::new();
            for c in &selected {
                let (Some(r), Some(x)) = (
                    &c.record,
                    axis_value(&c.planned, &spec.x).as_ref().and_then(numeric),
                ) else {
                    continue;
                };
                let Some(y) = (column.value)(r, c.reference.as_ref()) else {
                    continue;
                };
                let name = spec
                    .series
                    .as_ref()
                    .and_then(|s| {
                        axis_value(&c.planned, s).map(|v| {
                            format!("{} = {}", crate::experiment::short_key(s), value_label(&v))
                        })
                    })
                    .unwrap_or_default();
                let key = (x * 1e6).round() as i64;
                if !order.contains(&name) {
                    order.push(name.clone());
                }
                lines
                    .entry(name)
                    .or_default()
                    .entry(key)
                    .or_insert((x, Vec::new()))
                    .1
                    .push(y);
            }
            if lines.is_empty() {
                continue;
            }
            let series: Vec<Series> = order
                .into_iter()
                .filter_map(|name| lines.remove(&name).map(|pts| (name, pts)))
                .map(|(name, pts)| Series {
                    name,
                    points: pts
                        .into_values()
                        .map(|(x, ys)| (x, ys.iter().sum::<f64>() / ys.len() as f64))
                        .collect(),
                })
                .collect();
            let averaged =
                plan.axes.len() > 1 + usize::from(spec.series.is_some()) + spec.filter.len();
            let fixed = spec
                .filter
                .iter()
                .map(|(k, v)| {
                    format!(
                        "{} = {}",
                        crate::experiment::short_key(k),
                        crate::experiment::value_text(v)
                    )
                })
                .collect::<Vec<_>>()
                .join(", ");
            let plot = Plot {
                title: format!(
                    "{metric} vs {}{}{}",
                    crate::experiment::short_key(&spec.x),
                    if fixed.is_empty() {
                        String::new()
                    } else {
                        format!(" ({fixed})")
                    },
                    if averaged {
                        ", mean over other axes"
                    } else {
                        ""
                    }
                ),
                x_label: spec.x.clone(),
                y_label: column.header.to_string(),
                series,
                log_x: spec.log_x,
                log_y: spec.log_y,
            };
            let stem = dir.join(format!("p{pi}_{}_vs_{}", metric, spec.x.replace('.', "_")));
            write_plot(&stem, &plot)?;
            figures
                .plots
                .push((plot.title.clone(), stem.with_extension("png")));
        }
    }
    Ok(())
}

fn rel(root: &Path, path: &Path) -> String {
    path.strip_prefix(root)
        .unwrap_or(path)
        .display()
        .to_string()
}

fn markdown(
    out: &OutputDir,
    plan: &PlanRecord,
    cells: &[Collected],
    table: &Table,
    experiment: &Experiment,
    figures: &Figures,
) -> String {
    let root = out.root();
    let mut s = String::new();
    let done = cells.iter().filter(|c| c.record.is_some()).count();
    let failed: Vec<&Collected> = cells.iter().filter(|c| c.status() == "failed").collect();
    let _ = writeln!(s, "# {}\n", plan.experiment);
    if !experiment.description.is_empty() {
        let _ = writeln!(s, "{}\n", experiment.description.trim());
    }
    let _ = writeln!(
        s,
        "- cells: {} planned, {done} done, {} failed, {} pending",
        cells.len(),
        failed.len(),
        cells.len() - done - failed.len()
    );
    let _ = writeln!(
        s,
        "- quality preset: `{}`; program version {}",
        plan.quality, plan.version
    );
    let _ = writeln!(
        s,
        "- experiment file: `{}` (sha256 `{}`)",
        plan.experiment_file.display(),
        plan.experiment_sha256
    );
    let _ = writeln!(s, "- command: `{}`", plan.command.join(" "));
    let _ = writeln!(
        s,
        "- rerun: `sweep run {} --output {}` (finished cells are skipped); regenerate this report: `sweep report {}`\n",
        plan.experiment_file.display(),
        root.display(),
        root.display()
    );

    let _ = writeln!(s, "## Grid\n");
    for axis in &plan.axes {
        let values: Vec<String> = distinct_values(cells, axis)
            .iter()
            .map(value_label)
            .collect();
        let _ = writeln!(s, "- `{axis}`: {}", values.join(", "));
    }
    let marches: std::collections::HashSet<&String> = cells
        .iter()
        .filter(|c| c.record.is_some())
        .map(|c| &c.planned.march_key)
        .collect();
    let maps: usize = cells
        .iter()
        .filter_map(|c| c.record.as_ref())
        .filter(|r| r.timings.map_shared_by > 0)
        .map(|r| 1.0 / r.timings.map_shared_by as f64)
        .sum::<f64>()
        .round() as usize;
    let with_maps = cells
        .iter()
        .filter_map(|c| c.record.as_ref())
        .filter(|r| r.timings.map_shared_by > 0)
        .count();
    let _ = writeln!(
        s,
        "\nShared work: {done} finished cells came from {} march(es) (one eye-ray pass each) and about {maps} photon map(s) for the {with_maps} cells with multiple scattering; rendered one by one they would need {done} marches and {with_maps} maps.\n",
        marches.len()
    );

    let _ = writeln!(s, "## Provenance\n");
    let mut volumes: Vec<String> = cells
        .iter()
        .filter_map(|c| c.record.as_ref())
        .map(|r| r.provenance.volume.describe())
        .collect();
    volumes.sort();
    volumes.dedup();
    for v in volumes {
        let _ = writeln!(s, "- volume: {v}");
    }
    let mut refs: Vec<&String> = cells
        .iter()
        .filter_map(|c| c.planned.reference.as_ref())
        .collect();
    refs.sort();
    refs.dedup();
    for key in refs {
        if let Ok(r) = read_reference_record(&out.reference(key)) {
            let _ = writeln!(
                s,
                "- reference `{key}`: {} with {} samples per pixel ({:.1} s)",
                r.method, r.passes, r.seconds
            );
        } else {
            let _ = writeln!(s, "- reference `{key}`: not rendered");
        }
    }
    let mut section = |title: &str, items: &[(String, PathBuf)]| {
        if items.is_empty() {
            return;
        }
        let _ = writeln!(s, "\n## {title}\n");
        for (caption, path) in items {
            let _ = writeln!(s, "![{caption}]({})\n\n*{caption}*\n", rel(root, path));
        }
    };
    section("Contact sheets", &figures.sheets);
    section("Plots", &figures.plots);
    section("Difference images", &figures.diffs);
    for (title, t) in &figures.comparisons {
        let _ = writeln!(s, "\n### Comparison {title}\n");
        let _ = writeln!(
            s,
            "{}",
            String::from_utf8_lossy(
                &MarkdownExporter { columns: vec![] }
                    .serialize(t)
                    .unwrap_or_default()
            )
        );
    }
    let _ = writeln!(s, "\n## Cells\n");
    let mut columns: Vec<usize> = vec![0, 2];
    columns.extend(3..3 + plan.axes.len());
    for key in [
        "empirical_mfp",
        "nominal_mfp",
        "mean_single",
        "mean_multiple",
        "ms_share",
        "rmse",
        "flip",
        "ssim",
        "disco_energy",
        "disco_blobs",
        "time_render",
    ] {
        if let Some(i) = METRIC_COLUMNS.iter().position(|m| m.key == key) {
            let col = table.headers.len() - METRIC_COLUMNS.len() + i;
            if table.rows.iter().any(|r| r[col] != Field::Empty) {
                columns.push(col);
            }
        }
    }
    let _ = writeln!(
        s,
        "{}",
        String::from_utf8_lossy(
            &MarkdownExporter { columns }
                .serialize(table)
                .unwrap_or_default()
        )
    );
    let _ = writeln!(
        s,
        "All columns, with units: [cells.csv](cells.csv) ([cells.json](cells.json)).\n"
    );
    if !failed.is_empty() {
        let _ = writeln!(s, "## Failures\n");
        for c in failed {
            let first = c
                .failure
                .as_deref()
                .unwrap_or("")
                .lines()
                .take(6)
                .collect::<Vec<_>>()
                .join("\n    ");
            let _ = writeln!(
                s,
                "- cell {} ({}): see `{}`\n\n    {first}\n",
                c.planned.index,
                c.planned.label,
                rel(root, &out.failure(&c.planned.hash))
            );
        }
    }
    s
}

/// Turns the report's Markdown into a self-contained HTML page (images inlined).
fn html(root: &Path, markdown: &str) -> Result<String> {
    use base64::Engine as _;
    let esc = |t: &str| {
        t.replace('&', "&amp;")
            .replace('<', "&lt;")
            .replace('>', "&gt;")
    };
    let inline = |t: &str| -> String {
        // `code`, [text](link)
        let mut out = String::new();
        let mut code = false;
        for (i, part) in esc(t).split('`').enumerate() {
            if i > 0 {
                out += if code { "</code>" } else { "<code>" };
                code = !code;
            }
            out += part;
        }
        let mut result = String::new();
        let mut rest = out.as_str();
        while let Some(start) = rest.find('[') {
            let Some(mid) = rest[start..].find("](") else {
                break;
            };
            let Some(end) = rest[start + mid..].find(')') else {
                break;
            };
            result += &rest[..start];
            let text = &rest[start + 1..start + mid];
            let href = &rest[start + mid + 2..start + mid + end];
            result += &format!("<a href=\"{href}\">{text}</a>");
            rest = &rest[start + mid + end + 1..];
        }
        result += rest;
        result
    };
    let mut body = String::new();
    let mut in_table = false;
    let mut in_list = false;
    let lines: Vec<&str> = markdown.lines().collect();
    for (li, line) in lines.iter().enumerate() {
        let trimmed = line.trim();
        if in_table && !trimmed.starts_with('|') {
            body += "</table>\n";
            in_table = false;
        }
        if in_list && !trimmed.starts_with("- ") {
            body += "</ul>\n";
            in_list = false;
        }
        if let Some(h) = trimmed.strip_prefix("### ") {
            body += &format!("<h3>{}</h3>\n", inline(h));
        } else if let Some(h) = trimmed.strip_prefix("## ") {
            body += &format!("<h2>{}</h2>\n", inline(h));
        } else if let Some(h) = trimmed.strip_prefix("# ") {
            body += &format!("<h1>{}</h1>\n", inline(h));
        } else if let Some(img) = trimmed.strip_prefix("![") {
            let (alt, src) = img.split_once("](").unwrap_or(("", ""));
            let src = src.trim_end_matches(')');
            let bytes =
                std::fs::read(root.join(src)).with_context(|| format!("embedding {src}"))?;
            let data = base64::engine::general_purpose::STANDARD.encode(bytes);
            body += &format!(
                "<figure><img alt=\"{}\" src=\"data:image/png;base64,{data}\"></figure>\n",
                esc(alt)
            );
        } else if trimmed.starts_with('|') {
            let is_rule = trimmed.chars().all(|c| matches!(c, '|' | '-' | ' '));
            if is_rule {
                continue;
            }
            let header = !in_table
                && lines
                    .get(li + 1)
                    .is_some_and(|n| n.trim().starts_with("|-") || n.trim().starts_with("|--"));
            if !in_table {
                body += "<table>\n";
                in_table = true;
            }
            let tag = if header { "th" } else { "td" };
            let cells: Vec<String> = trimmed
                .trim_matches('|')
                .split(" | ")
                .map(|c| format!("<{tag}>{}</{tag}>", inline(c.trim())))
                .collect();
            body += &format!("<tr>{}</tr>\n", cells.join(""));
        } else if let Some(item) = trimmed.strip_prefix("- ") {
            if !in_list {
                body += "<ul>\n";
                in_list = true;
            }
            body += &format!("<li>{}</li>\n", inline(item));
        } else if trimmed.starts_with('*') && trimmed.ends_with('*') && trimmed.len() > 2 {
            body += &format!(
                "<p class=\"caption\">{}</p>\n",
                inline(trimmed.trim_matches('*'))
            );
        } else if !trimmed.is_empty() {
            let tag = if line.starts_with("    ") { "pre" } else { "p" };
            body += &format!("<{tag}>{}</{tag}>\n", inline(trimmed));
        }
    }
    if in_table {
        body += "</table>\n";
    }
    if in_list {
        body += "</ul>\n";
    }
    Ok(format!(
        "<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>volphot report</title><style>\
body{{font-family:sans-serif;max-width:1200px;margin:2em auto;padding:0 1em;color:#222}}\
table{{border-collapse:collapse;font-size:0.85em;margin:1em 0}}td,th{{border:1px solid #ccc;padding:2px 6px;text-align:right}}\
th{{background:#eee}}img{{max-width:100%}}figure{{margin:1em 0 0 0}}.caption{{font-style:italic;color:#555;margin-top:0.2em}}\
code{{background:#f3f3f3;padding:0 3px}}</style></head><body>\n{body}</body></html>\n"
    ))
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
