//! Difference images: single vs single + multiple scattering for every cell (the thesis's
//! amplified difference, Fig. 18), and pairs of cells that differ only in one axis.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use glam::Vec3;
use volphot::{Film, Layer};

use super::Figures;
use super::collect::{Collected, axis_value, value_label};
use super::figures::{
    Rgb8, Tile, amplified_difference, auto_gain, contact_sheet, sig3, signed_difference,
};
use super::table::{Field, Table};
use crate::analyse::{compare, displayed, luminance};
use crate::plan::{CompareKind, CompareSpec, Experiment, short_key, toml_to_json};
use crate::store::{CellRecord, OutputDir, PlanRecord};

/// Single vs single + multiple: the difference is the multiple-scattering layer. One gain
/// for all cells, so amplified images compare across the grid.
pub(crate) fn layer_differences(
    out: &OutputDir,
    cells: &[Collected],
    experiment: &Experiment,
    figures: &mut Figures,
) -> Result<()> {
    let Some(spec) = experiment
        .compare
        .iter()
        .find(|c| c.kind == CompareKind::Layers)
    else {
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
    let multiple = || {
        films
            .iter()
            .flat_map(|(_, f)| f.layer(Layer::Multiple).iter().map(|v| luminance(*v)))
    };
    let gain = spec
        .gain
        .unwrap_or_else(|| auto_gain(&multiple().collect::<Vec<f32>>(), exposure));
    let scale = multiple().fold(0.0f32, f32::max).max(1e-9);
    figures.diff_legend = format!(
        "Each cell's differences at full size: amplified, |single + multiple − single| × {} (the multiple-scattering layer, thesis Fig. 18); signed, single + multiple − single in red where it adds light, full red at {} (the brightest multiple layer of the grid).",
        sig3(gain),
        sig3(scale)
    );
    for (c, film) in &films {
        let path = layer_difference(out, c, film, gain, scale, exposure)?;
        figures.diffs.push((
            format!(
                "{}: single vs single + multiple (amplified difference × {})",
                c.planned.label,
                sig3(gain)
            ),
            path.clone(),
        ));
        let [_, amplified, signed] = written_with(&path)
            .try_into()
            .expect("a sheet comes with two differences");
        figures.diff_images.push((
            c.planned.label.clone(),
            vec![
                (format!("amplified × {}", sig3(gain)), amplified),
                ("signed".to_string(), signed),
            ],
        ));
    }
    Ok(())
}

/// Writes one cell's amplified and signed differences and its side-by-side sheet (single,
/// single + multiple, difference: thesis Figs. 17/18); returns the sheet's path.
fn layer_difference(
    out: &OutputDir,
    c: &Collected,
    film: &Film,
    gain: f32,
    scale: f32,
    exposure: f32,
) -> Result<std::path::PathBuf> {
    let dir = out.figures().join("diff");
    let (w, h) = (film.width(), film.height());
    let with = film.combine(&[Layer::Single, Layer::Multiple]);
    let without = film.combine(&[Layer::Single]);
    let amp = amplified_difference(&with, &without, w, h, gain, exposure);
    let signed = signed_difference(&with, &without, w, h, scale);
    amp.write_png(&dir.join(format!("{}_amplified.png", c.planned.hash)))?;
    signed.write_png(&dir.join(format!("{}_signed.png", c.planned.hash)))?;
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
            caption: format!("difference × {}", sig3(gain)),
        },
    ];
    let sheet = contact_sheet(&c.planned.label, &tiles, 3, 320);
    let path = dir.join(format!("{}_compare.png", c.planned.hash));
    sheet.write_png(&path)?;
    Ok(path)
}

/// Removes the difference images this report did not write, and comparison folders left
/// empty: a cell whose address moved (a changed plan or renderer) leaves the figures of its
/// old address behind, which no report shows and a committed report should not carry.
pub(crate) fn remove_unlisted(out: &OutputDir, figures: &Figures) -> Result<()> {
    let written: BTreeSet<PathBuf> = figures
        .diffs
        .iter()
        .flat_map(|(_, sheet)| written_with(sheet))
        .collect();
    let Ok(entries) = std::fs::read_dir(out.figures()) else {
        return Ok(());
    };
    let folders = entries
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.is_dir() && is_difference_folder(p));
    for folder in folders {
        let listing =
            std::fs::read_dir(&folder).with_context(|| format!("listing {}", folder.display()))?;
        for file in listing.flatten().map(|e| e.path()) {
            let hidden = file
                .file_name()
                .is_some_and(|n| n.to_string_lossy().starts_with('.'));
            if !hidden && file.extension().is_some_and(|e| e == "png") && !written.contains(&file) {
                std::fs::remove_file(&file)
                    .with_context(|| format!("removing {}", file.display()))?;
            }
        }
        if std::fs::read_dir(&folder).is_ok_and(|mut d| d.next().is_none()) {
            std::fs::remove_dir(&folder)
                .with_context(|| format!("removing {}", folder.display()))?;
        }
    }
    Ok(())
}

/// The files written with a listed figure: a layer difference's sheet
/// (`<hash>_compare.png`) comes with its amplified and signed differences.
fn written_with(sheet: &Path) -> Vec<PathBuf> {
    let name = sheet.file_name().map(|n| n.to_string_lossy().into_owned());
    match name.as_deref().and_then(|n| n.strip_suffix("_compare.png")) {
        Some(hash) => ["compare", "amplified", "signed"]
            .iter()
            .map(|kind| sheet.with_file_name(format!("{hash}_{kind}.png")))
            .collect(),
        None => vec![sheet.to_path_buf()],
    }
}

/// `figures/diff` and `figures/compare<N>`, the folders this module writes.
fn is_difference_folder(path: &Path) -> bool {
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned());
    match name.as_deref() {
        Some("diff") => true,
        Some(n) => n
            .strip_prefix("compare")
            .is_some_and(|i| !i.is_empty() && i.bytes().all(|b| b.is_ascii_digit())),
        None => false,
    }
}

/// Cells differing only in one axis: value `a` against value `b`.
pub(crate) fn axis_comparisons(
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
        .filter(|(_, c)| c.kind == CompareKind::Axis)
    {
        let pairs = AxisPairs::new(plan, spec);
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
            let Some(b) = pairs.partner(a, cells) else {
                continue;
            };
            let (row, path) = pairs.compare(out, &dir, a, b)?;
            figures
                .diffs
                .push((format!("{} vs {}", a.planned.label, b.planned.label), path));
            table.rows.push(row);
        }
        figures.comparisons.push((pairs.title(), table));
    }
    Ok(())
}

/// One `kind = "axis"` comparison.
struct AxisPairs<'a> {
    spec: &'a CompareSpec,
    axis: String,
    a_value: Option<serde_json::Value>,
    b_value: Option<serde_json::Value>,
    others: Vec<&'a String>,
}

impl<'a> AxisPairs<'a> {
    fn new(plan: &'a PlanRecord, spec: &'a CompareSpec) -> Self {
        let axis = spec.axis.clone().unwrap_or_default();
        AxisPairs {
            spec,
            a_value: spec.a.as_ref().map(toml_to_json),
            b_value: spec.b.as_ref().map(toml_to_json),
            others: plan.axes.iter().filter(|k| **k != axis).collect(),
            axis,
        }
    }

    /// The `b` cell for cell `a`: same values on every other axis, `b` on this one.
    fn partner<'c>(&self, a: &Collected, cells: &'c [Collected]) -> Option<&'c Collected> {
        let av = axis_value(&a.planned, &self.axis)?;
        if Some(&av) == self.b_value.as_ref() || self.a_value.as_ref().is_some_and(|x| *x != av) {
            return None;
        }
        cells.iter().find(|c| {
            c.record.is_some()
                && axis_value(&c.planned, &self.axis) == self.b_value
                && self
                    .others
                    .iter()
                    .all(|k| axis_value(&c.planned, k) == axis_value(&a.planned, k))
        })
    }

    /// Errors and difference images of `a` against `b`: the table row and the figure.
    fn compare(
        &self,
        out: &OutputDir,
        dir: &std::path::Path,
        a: &Collected,
        b: &Collected,
    ) -> Result<(Vec<Field>, std::path::PathBuf)> {
        let (ra, rb) = (
            a.record.as_ref().expect("done"),
            b.record.as_ref().expect("done"),
        );
        let (ia, w, h) = shown(out, a, ra)?;
        let (ib, _, _) = shown(out, b, rb)?;
        let exposure = ra.provenance.scene.film.exposure;
        let m = compare(&ia, &ib, None, [w, h], exposure, &b.planned.hash);
        let diffs: Vec<f32> = ia
            .iter()
            .zip(&ib)
            .map(|(x, y)| luminance((*x - *y).abs()))
            .collect();
        let scale = diffs.iter().cloned().fold(0.0f32, f32::max).max(1e-9);
        let gain = self
            .spec
            .gain
            .unwrap_or_else(|| auto_gain(&diffs, exposure));
        let tiles = [
            self.tile(
                out,
                a,
                "a",
                axis_value(&a.planned, &self.axis).unwrap_or_default(),
            ),
            self.tile(out, b, "b", self.b_value.clone().unwrap_or_default()),
            Tile {
                image: Some(signed_difference(&ia, &ib, w, h, scale)),
                caption: "a − b (signed)".into(),
            },
            Tile {
                image: Some(amplified_difference(&ia, &ib, w, h, gain, exposure)),
                caption: format!("|a − b| × {}", sig3(gain)),
            },
        ];
        let path = dir.join(format!("{}_vs_{}.png", a.planned.hash, b.planned.hash));
        contact_sheet(&a.planned.label, &tiles, 4, 256).write_png(&path)?;
        let row = vec![
            Field::Text(a.planned.label.clone()),
            Field::Text(b.planned.label.clone()),
            Field::Number(m.rmse),
            Field::Number(m.flip),
            Field::Number(ra.disco.energy - rb.disco.energy),
            Field::Number(ra.mean_multiple - rb.mean_multiple),
        ];
        Ok((row, path))
    }

    fn tile(&self, out: &OutputDir, c: &Collected, name: &str, value: serde_json::Value) -> Tile {
        Tile {
            image: Rgb8::read_png(&out.cell(&c.planned.hash).join("total.png")).ok(),
            caption: format!(
                "{name}: {} = {}",
                short_key(&self.axis),
                value_label(&value)
            ),
        }
    }

    /// The comparison's title in the report.
    fn title(&self) -> String {
        format!(
            "`{}`: {} vs {}",
            self.axis,
            self.a_value
                .as_ref()
                .map_or("each value".to_string(), value_label),
            self.b_value.as_ref().map_or(String::new(), value_label)
        )
    }
}

/// The image a cell displays, from its film, with the film's size.
fn shown(out: &OutputDir, c: &Collected, r: &CellRecord) -> Result<(Vec<Vec3>, usize, usize)> {
    let film = Film::read_exr(&out.cell(&c.planned.hash).join("film.exr"))?;
    let image = displayed(
        &film,
        r.provenance.scene.integrator.multiple,
        r.provenance.scene.integrator.emission,
    );
    Ok((image, film.width(), film.height()))
}
