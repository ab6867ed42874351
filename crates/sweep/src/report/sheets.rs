//! Contact sheets: a grid of cell images, rows and columns along two axes, one sheet per
//! combination of the remaining axes (at most 12), captions naming the axis values.

use anyhow::Result;

use super::Figures;
use super::collect::{Collected, axis_value, distinct_values, matches, value_label};
use super::figures::{Rgb8, Tile, contact_sheet};
use crate::plan::{Experiment, SheetLayer, SheetSpec, short_key};
use crate::store::{OutputDir, PlanRecord};

/// The experiment's sheets, or by default `total` and `multiple` over the first two axes.
fn sheet_specs(plan: &PlanRecord, experiment: &Experiment) -> Vec<SheetSpec> {
    if !experiment.sheets.is_empty() || experiment.tune.is_some() {
        return experiment.sheets.clone();
    }
    let mut specs = Vec::new();
    if let Some(rows) = plan.axes.first() {
        for layer in [SheetLayer::Total, SheetLayer::Multiple] {
            specs.push(SheetSpec {
                rows: rows.clone(),
                cols: plan.axes.get(1).cloned(),
                layer,
                filter: Default::default(),
            });
        }
    }
    specs
}

/// Writes every contact sheet into `figures/`.
pub(crate) fn contact_sheets(
    out: &OutputDir,
    plan: &PlanRecord,
    cells: &[Collected],
    experiment: &Experiment,
    figures: &mut Figures,
) -> Result<()> {
    let specs = sheet_specs(plan, experiment);
    if experiment.tune.is_some() && specs.is_empty() {
        // A tune's cells are scattered, not a grid; its report links the best scenes.
        return Ok(());
    }
    if specs.is_empty() {
        return single_image(out, plan, cells, figures);
    }
    for (si, spec) in specs.iter().enumerate() {
        let selected: Vec<&Collected> = cells
            .iter()
            .filter(|c| matches(&c.planned, &spec.filter))
            .collect();
        let sheets = Sheets {
            out,
            spec,
            cells: &selected,
        };
        for (ci, combo) in sheets.combinations(plan).iter().take(12).enumerate() {
            let (title, sheet) = sheets.render(&plan.experiment, combo);
            let path = out
                .figures()
                .join(format!("sheet{si}_{}_{ci}.png", spec.layer.name()));
            sheet.write_png(&path)?;
            figures.sheets.push((title, path));
        }
    }
    Ok(())
}

/// No axes: one image.
fn single_image(
    out: &OutputDir,
    plan: &PlanRecord,
    cells: &[Collected],
    figures: &mut Figures,
) -> Result<()> {
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
    Ok(())
}

type Combination = Vec<(String, serde_json::Value)>;

/// The sheets of one specification.
struct Sheets<'a> {
    out: &'a OutputDir,
    spec: &'a SheetSpec,
    cells: &'a [&'a Collected],
}

impl Sheets<'_> {
    /// The combinations of the axes that are neither rows nor columns, in plan order.
    fn combinations(&self, plan: &PlanRecord) -> Vec<Combination> {
        let spec = self.spec;
        let rest: Vec<&String> = plan
            .axes
            .iter()
            .filter(|a| **a != spec.rows && Some(*a) != spec.cols.as_ref())
            .collect();
        let mut combos: Vec<Combination> = Vec::new();
        for c in self.cells {
            let combo: Combination = rest
                .iter()
                .filter_map(|k| axis_value(&c.planned, k).map(|v| ((*k).clone(), v)))
                .collect();
            if !combos.contains(&combo) {
                combos.push(combo);
            }
        }
        combos
    }

    /// The sheet for one combination, with its title.
    fn render(&self, experiment: &str, combo: &Combination) -> (String, Rgb8) {
        let spec = self.spec;
        let row_values = distinct_values(self.cells.iter().copied(), &spec.rows);
        let col_values = spec
            .cols
            .as_ref()
            .map(|k| distinct_values(self.cells.iter().copied(), k))
            .unwrap_or_else(|| vec![serde_json::Value::Null]);
        let tile = if col_values.len() > 6 { 160 } else { 256 };
        let mut tiles = Vec::new();
        for rv in &row_values {
            for cv in &col_values {
                tiles.push(self.tile(combo, rv, cv));
            }
        }
        let fixed = combo
            .iter()
            .map(|(k, v)| format!("{} = {}", short_key(k), value_label(v)))
            .collect::<Vec<_>>()
            .join(", ");
        let title = format!(
            "{} — {}{}",
            experiment,
            spec.layer.name(),
            if fixed.is_empty() {
                String::new()
            } else {
                format!(" ({fixed})")
            }
        );
        let sheet = contact_sheet(&title, &tiles, col_values.len(), tile);
        (title, sheet)
    }

    /// The tile at row value `rv` and column value `cv`.
    fn tile(&self, combo: &Combination, rv: &serde_json::Value, cv: &serde_json::Value) -> Tile {
        let spec = self.spec;
        let found = self.cells.iter().find(|c| {
            axis_value(&c.planned, &spec.rows).as_ref() == Some(rv)
                && spec
                    .cols
                    .as_ref()
                    .is_none_or(|k| axis_value(&c.planned, k).as_ref() == Some(cv))
                && combo
                    .iter()
                    .all(|(k, v)| axis_value(&c.planned, k).as_ref() == Some(v))
        });
        let mut caption = format!("{} = {}", short_key(&spec.rows), value_label(rv));
        if let Some(k) = &spec.cols {
            caption += &format!(", {} = {}", short_key(k), value_label(cv));
        }
        let image = match found {
            Some(c) if c.record.is_some() => {
                let file = match spec.layer {
                    SheetLayer::Diff => self
                        .out
                        .figures()
                        .join("diff")
                        .join(format!("{}_amplified.png", c.planned.hash)),
                    layer => self
                        .out
                        .cell(&c.planned.hash)
                        .join(format!("{}.png", layer.name())),
                };
                Rgb8::read_png(&file).ok()
            }
            _ => None,
        };
        Tile { image, caption }
    }
}
