//! Experiment files: a base scene plus axes, expanded into cells.
//!
//! ```toml
//! name = "artifacts"
//! scene = "scenes/foot.toml"            # base scene (path relative to this file)
//! max_cells = 100                        # larger grids need --yes
//!
//! [set]                                  # overrides applied to every cell
//! "camera.resolution" = [256, 256]
//!
//! [axes]                                 # Cartesian product, in this order
//! "integrator.nused" = [25, 50, 150, 300]
//! "sigma.t" = { from = 6, to = 300, steps = 5, scale = "log" }
//!
//! [[zip]]                                # axes that move together (one axis of pairs)
//! "sigma.t" = [40, 80]
//! "integrator.nused" = [50, 150]
//!
//! [[exclude]]                            # drop cells matching every key
//! "sigma.t" = 300
//! "integrator.nused" = 25
//!
//! [quality.quick]                        # `--quick`: overrides and axis replacements
//! set = { "camera.resolution" = [96, 96] }
//! [quality.paper]                        # `--paper`
//! axes = { "integrator.nused" = [25, 50, 100, 150, 200, 300] }
//!
//! [reference]                            # ground truth, shared by cells with equal physics
//! method = "path"                        # or "photon"
//! spp = 256
//!
//! [[compare]]                            # image pairs to difference
//! kind = "layers"                        # single vs single+multiple (thesis Fig. 18)
//! ```
//!
//! Axis keys are scene key paths (`integrator.nused`, `sigma.t`, `volume.dataset`, …) or
//! `scene` (a list of scene files). Keys may be quoted (`"sigma.t"`) or written as nested
//! tables (`sigma.t`).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use serde::{Deserialize, Serialize};
use toml::{Table, Value};
use volphot::scene::{SceneParams, line_col, locate, toml_error, validate_params};

use crate::cli::Quality;

/// A parsed experiment file.
#[derive(Debug, Clone)]
pub struct Experiment {
    /// Name (file stem unless given).
    pub name: String,
    /// Free text.
    pub description: String,
    /// The experiment file.
    pub path: PathBuf,
    /// Its text (for locating errors and hashing).
    pub source: String,
    /// sha256 of the file.
    pub sha256: String,
    /// Grid-size limit that requires `--yes`.
    pub max_cells: usize,
    /// Share photon maps and marches between cells.
    pub share: bool,
    /// Ground-truth configuration.
    pub reference: Option<ReferenceSpec>,
    /// Image comparisons.
    pub compare: Vec<CompareSpec>,
    /// Plot specifications (empty: automatic).
    pub plots: Vec<PlotSpec>,
    /// Contact sheets (empty: automatic).
    pub sheets: Vec<SheetSpec>,
    base: BaseScene,
    set: Vec<(String, Value)>,
    dimensions: Vec<Dimension>,
    exclude: Vec<Vec<(String, Value)>>,
    quality: BTreeMap<String, QualityPreset>,
}

#[derive(Debug, Clone)]
enum BaseScene {
    File(PathBuf),
    Inline(Table),
}

/// One dimension of the grid: a single axis, or a zip group of axes of equal length.
#[derive(Debug, Clone, PartialEq)]
struct Dimension {
    keys: Vec<String>,
    /// `values[i][k]` is the value of `keys[k]` at position `i`.
    values: Vec<Vec<Value>>,
}

#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct QualityPreset {
    #[serde(default)]
    set: Table,
    #[serde(default)]
    axes: Table,
}

/// How the ground truth is made.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ReferenceSpec {
    /// `path` (the reference path tracer) or `photon` (a photon-mapping render with many
    /// photons).
    #[serde(default = "default_reference_method")]
    pub method: String,
    /// Path-tracer samples per pixel.
    #[serde(default = "default_reference_spp")]
    pub spp: u32,
    /// `photon`: photons.
    #[serde(default)]
    pub volume_photons: Option<u64>,
    /// `photon`: photons per estimate.
    #[serde(default)]
    pub nused: Option<u32>,
    /// Further overrides of the reference scene.
    #[serde(default)]
    pub set: Table,
}

fn default_reference_method() -> String {
    "path".into()
}
fn default_reference_spp() -> u32 {
    256
}

/// An image comparison.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CompareSpec {
    /// `layers` (single vs single + multiple), `reference` (each cell vs the ground truth) or
    /// `axis` (cells that differ only in `axis`: value `a` vs value `b`).
    pub kind: String,
    /// `axis`: the axis key.
    #[serde(default)]
    pub axis: Option<String>,
    /// `axis`: the value compared (all other values when absent).
    #[serde(default)]
    pub a: Option<Value>,
    /// `axis`: the value compared against.
    #[serde(default)]
    pub b: Option<Value>,
    /// Gain of the brightness-amplified difference image (default: automatic, printed).
    #[serde(default)]
    pub gain: Option<f32>,
}

/// A metric-vs-axis plot.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PlotSpec {
    /// Axis key on the x axis.
    pub x: String,
    /// Metric columns on the y axis (one figure each).
    pub y: Vec<String>,
    /// Axis whose values give one line each.
    #[serde(default)]
    pub series: Option<String>,
    /// Logarithmic x axis.
    #[serde(default)]
    pub log_x: bool,
    /// Logarithmic y axis.
    #[serde(default)]
    pub log_y: bool,
    /// Only cells with these axis values (e.g. `{ scene = "scenes/foot.toml" }`).
    #[serde(default, rename = "where")]
    pub filter: Table,
}

/// A contact sheet: images in a grid labelled by axis values.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SheetSpec {
    /// Axis along the rows.
    pub rows: String,
    /// Axis along the columns.
    #[serde(default)]
    pub cols: Option<String>,
    /// `total`, `single`, `multiple` or `diff`.
    #[serde(default = "default_layer")]
    pub layer: String,
    /// Only cells with these axis values.
    #[serde(default, rename = "where")]
    pub filter: Table,
}

fn default_layer() -> String {
    "total".into()
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct ExperimentFile {
    name: Option<String>,
    #[serde(default)]
    description: String,
    scene: Option<Value>,
    #[serde(default = "default_max_cells")]
    max_cells: usize,
    #[serde(default = "default_true")]
    share: bool,
    #[serde(default)]
    set: Table,
    #[serde(default)]
    axes: Table,
    #[serde(default)]
    zip: Vec<Table>,
    #[serde(default)]
    exclude: Vec<Table>,
    #[serde(default)]
    quality: BTreeMap<String, QualityPreset>,
    reference: Option<ReferenceSpec>,
    #[serde(default)]
    compare: Vec<CompareSpec>,
    #[serde(default)]
    plots: Vec<PlotSpec>,
    #[serde(default)]
    sheets: Vec<SheetSpec>,
}

fn default_max_cells() -> usize {
    200
}
fn default_true() -> bool {
    true
}

/// An error located in the experiment file.
fn located(
    exp_path: &Path,
    src: &str,
    key_path: &str,
    message: impl std::fmt::Display,
) -> anyhow::Error {
    let (line, column) = locate_key(src, key_path).unwrap_or((1, 1));
    anyhow::anyhow!("{}:{line}:{column}: {message}", exp_path.display())
}

/// Locates `table.key` where `key` may be written quoted (`"a.b"`) or nested (`a.b`).
fn locate_key(src: &str, key_path: &str) -> Option<(usize, usize)> {
    if let Some((table, rest)) = key_path.split_once('.') {
        // Try the quoted form first: find `"rest"` after the table header.
        let quoted = format!("\"{rest}\"");
        if let Some(start) = src
            .find(&format!("[{table}]"))
            .or_else(|| src.find(&format!("{table} =")))
            && let Some(off) = src[start..].find(&quoted)
        {
            return Some(line_col(src, start + off));
        }
    }
    locate(src, key_path)
}

/// Flattens nested axis tables into dotted keys; leaves are arrays or range tables.
fn flatten_axes(table: &Table, prefix: &str, out: &mut Vec<(String, Value)>) {
    for (k, v) in table {
        let key = if prefix.is_empty() {
            k.clone()
        } else {
            format!("{prefix}.{k}")
        };
        match v {
            Value::Table(t) if !t.contains_key("from") => flatten_axes(t, &key, out),
            other => out.push((key, other.clone())),
        }
    }
}

/// Flattens nested override tables into `(dotted key, value)`.
pub fn flatten_set(table: &Table, prefix: &str, out: &mut Vec<(String, Value)>) {
    for (k, v) in table {
        let key = if prefix.is_empty() {
            k.clone()
        } else {
            format!("{prefix}.{k}")
        };
        match v {
            // A table value is recursed into unless it is an inline value for a key that
            // takes a table (phantom, box): those are set whole.
            Value::Table(t) if !matches!(k.as_str(), "phantom" | "box") => {
                flatten_set(t, &key, out)
            }
            other => out.push((key, other.clone())),
        }
    }
}

/// Expands an axis spec (a list, or `{ from, to, steps, scale }`) into values.
fn axis_values(spec: &Value) -> std::result::Result<Vec<Value>, String> {
    match spec {
        Value::Array(a) => {
            if a.is_empty() {
                Err("an axis needs at least one value".into())
            } else {
                Ok(a.clone())
            }
        }
        Value::Table(t) => {
            for k in t.keys() {
                if !["from", "to", "steps", "scale"].contains(&k.as_str()) {
                    return Err(format!(
                        "unknown range key `{k}` (expected from, to, steps, scale)"
                    ));
                }
            }
            let num = |k: &str| -> std::result::Result<(f64, bool), String> {
                match t.get(k) {
                    Some(Value::Integer(i)) => Ok((*i as f64, true)),
                    Some(Value::Float(f)) if f.is_finite() => Ok((*f, false)),
                    Some(other) => Err(format!("`{k}` = {other}: expected a number")),
                    None => Err(format!("range needs `{k}`")),
                }
            };
            let (from, from_int) = num("from")?;
            let (to, to_int) = num("to")?;
            let steps = match t.get("steps") {
                Some(Value::Integer(n)) if *n >= 1 && *n <= 10_000 => *n as usize,
                Some(other) => {
                    return Err(format!(
                        "`steps` = {other}: expected an integer in [1, 10000]"
                    ));
                }
                None => return Err("range needs `steps`".into()),
            };
            let log = match t.get("scale").map(|v| v.as_str()) {
                None | Some(Some("linear")) => false,
                Some(Some("log")) => true,
                Some(_) => return Err("`scale`: expected \"linear\" or \"log\"".into()),
            };
            if log && (from <= 0.0 || to <= 0.0) {
                return Err(format!("log range needs from, to > 0 (got {from}, {to})"));
            }
            let integer = from_int && to_int;
            let mut values = Vec::new();
            for i in 0..steps {
                let f = if steps == 1 {
                    0.0
                } else {
                    i as f64 / (steps - 1) as f64
                };
                let v = if log {
                    (from.ln() + f * (to.ln() - from.ln())).exp()
                } else {
                    from + f * (to - from)
                };
                let value = if integer {
                    Value::Integer(v.round() as i64)
                } else {
                    // Six significant digits keep labels and cell hashes readable.
                    Value::Float(format!("{v:.6e}").parse().unwrap_or(v))
                };
                if !values.contains(&value) {
                    values.push(value);
                }
            }
            Ok(values)
        }
        other => Err(format!(
            "{other}: expected a list of values or {{ from, to, steps, scale }}"
        )),
    }
}

impl Experiment {
    /// Reads and validates an experiment file.
    pub fn load(path: &Path) -> Result<Self> {
        let source =
            std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
        let file: ExperimentFile =
            toml::from_str(&source).map_err(|e| anyhow::anyhow!(toml_error(&e, &source, path)))?;
        let name = file.name.clone().unwrap_or_else(|| {
            path.file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_else(|| "experiment".into())
        });
        let base = match &file.scene {
            Some(Value::String(s)) => BaseScene::File(PathBuf::from(s)),
            Some(Value::Table(t)) => BaseScene::Inline(t.clone()),
            Some(other) => {
                return Err(located(
                    path,
                    &source,
                    "scene",
                    format!("`scene` = {other}: expected a scene file path or an inline table"),
                ));
            }
            None => {
                let mut axes = Vec::new();
                flatten_axes(&file.axes, "", &mut axes);
                if !axes.iter().any(|(k, _)| k == "scene") {
                    return Err(located(
                        path,
                        &source,
                        "scene",
                        "missing `scene`: a base scene file, an inline [scene] table, or a `scene` axis",
                    ));
                }
                BaseScene::Inline(Table::new())
            }
        };
        let mut set = Vec::new();
        flatten_set(&file.set, "", &mut set);
        let mut dimensions = Vec::new();
        let mut axes = Vec::new();
        flatten_axes(&file.axes, "", &mut axes);
        for (key, spec) in &axes {
            let values = axis_values(spec).map_err(|m| {
                located(
                    path,
                    &source,
                    &format!("axes.{key}"),
                    format!("axis `{key}`: {m}"),
                )
            })?;
            dimensions.push(Dimension {
                keys: vec![key.clone()],
                values: values.into_iter().map(|v| vec![v]).collect(),
            });
        }
        for (zi, zip) in file.zip.iter().enumerate() {
            let mut zaxes = Vec::new();
            flatten_axes(zip, "", &mut zaxes);
            let mut keys = Vec::new();
            let mut columns = Vec::new();
            for (key, spec) in &zaxes {
                let values = axis_values(spec).map_err(|m| {
                    located(
                        path,
                        &source,
                        &format!("zip.{key}"),
                        format!("zip[{zi}] axis `{key}`: {m}"),
                    )
                })?;
                keys.push(key.clone());
                columns.push(values);
            }
            let len = columns.first().map(|c| c.len()).unwrap_or(0);
            if let Some((k, c)) = keys.iter().zip(&columns).find(|(_, c)| c.len() != len) {
                return Err(located(
                    path,
                    &source,
                    &format!("zip.{k}"),
                    format!(
                        "zip[{zi}]: axis `{k}` has {} values but `{}` has {len}; zipped axes move together and need equal lengths",
                        c.len(),
                        keys[0]
                    ),
                ));
            }
            if len == 0 {
                return Err(located(path, &source, "zip", format!("zip[{zi}] is empty")));
            }
            dimensions.push(Dimension {
                keys,
                values: (0..len)
                    .map(|i| columns.iter().map(|c| c[i].clone()).collect())
                    .collect(),
            });
        }
        let mut seen = std::collections::HashSet::new();
        for d in &dimensions {
            for k in &d.keys {
                if !seen.insert(k.clone()) {
                    return Err(located(
                        path,
                        &source,
                        &format!("axes.{k}"),
                        format!("axis `{k}` is given twice (in [axes] and/or [[zip]])"),
                    ));
                }
            }
        }
        let exclude = file
            .exclude
            .iter()
            .map(|t| {
                let mut v = Vec::new();
                flatten_set(t, "", &mut v);
                v
            })
            .collect::<Vec<_>>();
        // Every key an exclude rule, compare, plot or sheet refers to must be an axis.
        let axis_names = dimensions
            .iter()
            .flat_map(|d| d.keys.iter().map(String::as_str))
            .collect::<Vec<_>>()
            .join(", ");
        let require_axes = |table: &str, index: usize, keys: Vec<&String>| -> Result<()> {
            match keys.into_iter().find(|k| !seen.contains(*k)) {
                Some(k) => Err(located(
                    path,
                    &source,
                    table,
                    format!("{table}[{index}]: `{k}` is not an axis (axes: {axis_names})"),
                )),
                None => Ok(()),
            }
        };
        for (ei, rule) in exclude.iter().enumerate() {
            require_axes("exclude", ei, rule.iter().map(|(k, _)| k).collect())?;
        }
        for q in file.quality.keys() {
            if q != "quick" && q != "paper" {
                return Err(located(
                    path,
                    &source,
                    &format!("quality.{q}"),
                    format!("unknown quality preset `{q}` (expected quick or paper)"),
                ));
            }
        }
        if let Some(r) = &file.reference {
            if r.method != "path" && r.method != "photon" {
                return Err(located(
                    path,
                    &source,
                    "reference.method",
                    format!(
                        "`reference.method` = \"{}\": expected \"path\" or \"photon\"",
                        r.method
                    ),
                ));
            }
            if r.spp == 0 {
                return Err(located(
                    path,
                    &source,
                    "reference.spp",
                    "`reference.spp` = 0: expected at least 1",
                ));
            }
        }
        for (ci, c) in file.compare.iter().enumerate() {
            match c.kind.as_str() {
                "layers" | "reference" => {}
                "axis" => {
                    let axis = c.axis.as_ref().ok_or_else(|| {
                        located(
                            path,
                            &source,
                            "compare",
                            format!("compare[{ci}]: kind = \"axis\" needs `axis`"),
                        )
                    })?;
                    require_axes("compare", ci, vec![axis])?;
                    if c.b.is_none() {
                        return Err(located(
                            path,
                            &source,
                            "compare",
                            format!(
                                "compare[{ci}]: kind = \"axis\" needs `b` (the value compared against)"
                            ),
                        ));
                    }
                }
                other => {
                    return Err(located(
                        path,
                        &source,
                        "compare",
                        format!(
                            "compare[{ci}]: kind = \"{other}\": expected layers, reference or axis"
                        ),
                    ));
                }
            }
            if c.kind == "reference" && file.reference.is_none() {
                return Err(located(
                    path,
                    &source,
                    "compare",
                    format!("compare[{ci}]: kind = \"reference\" needs a [reference] table"),
                ));
            }
        }
        for (pi, p) in file.plots.iter().enumerate() {
            require_axes(
                "plots",
                pi,
                std::iter::once(&p.x)
                    .chain(&p.series)
                    .chain(p.filter.keys())
                    .collect(),
            )?;
            for y in &p.y {
                if !crate::cells::METRIC_COLUMNS.iter().any(|m| m.key == y) {
                    return Err(located(
                        path,
                        &source,
                        "plots",
                        format!(
                            "plots[{pi}]: `{y}` is not a metric (metrics: {})",
                            crate::cells::METRIC_COLUMNS
                                .iter()
                                .map(|m| m.key)
                                .collect::<Vec<_>>()
                                .join(", ")
                        ),
                    ));
                }
            }
        }
        for (si, s) in file.sheets.iter().enumerate() {
            require_axes(
                "sheets",
                si,
                std::iter::once(&s.rows)
                    .chain(&s.cols)
                    .chain(s.filter.keys())
                    .collect(),
            )?;
            if !["total", "single", "multiple", "diff"].contains(&s.layer.as_str()) {
                return Err(located(
                    path,
                    &source,
                    "sheets",
                    format!(
                        "sheets[{si}]: layer = \"{}\": expected total, single, multiple or diff",
                        s.layer
                    ),
                ));
            }
        }
        Ok(Experiment {
            name,
            description: file.description,
            path: path.to_path_buf(),
            sha256: volphot::checksum::sha256_bytes(source.as_bytes()),
            source,
            max_cells: file.max_cells,
            share: file.share,
            reference: file.reference,
            compare: file.compare,
            plots: file.plots,
            sheets: file.sheets,
            base,
            set,
            dimensions,
            exclude,
            quality: file.quality,
        })
    }

    /// The folder holding the experiment file (base for relative paths).
    pub fn base_dir(&self) -> PathBuf {
        self.path
            .parent()
            .map(Path::to_path_buf)
            .unwrap_or_else(|| PathBuf::from("."))
    }

    /// Axis keys in grid order.
    pub fn axis_keys(&self, quality: Quality) -> Vec<String> {
        self.dimensions_for(quality)
            .map(|d| d.iter().flat_map(|d| d.keys.clone()).collect())
            .unwrap_or_default()
    }

    fn dimensions_for(&self, quality: Quality) -> Result<Vec<Dimension>> {
        let mut dims = self.dimensions.clone();
        if let Some(preset) = self.preset(quality) {
            let mut replacements = Vec::new();
            flatten_axes(&preset.axes, "", &mut replacements);
            for (key, spec) in replacements {
                let values = axis_values(&spec).map_err(|m| {
                    located(
                        &self.path,
                        &self.source,
                        "quality",
                        format!("quality axis `{key}`: {m}"),
                    )
                })?;
                match dims.iter_mut().find(|d| d.keys == [key.clone()]) {
                    Some(d) => d.values = values.into_iter().map(|v| vec![v]).collect(),
                    None => {
                        if dims.iter().any(|d| d.keys.contains(&key)) {
                            return Err(located(
                                &self.path,
                                &self.source,
                                "quality",
                                format!(
                                    "quality axis `{key}` is part of a [[zip]] group and cannot be replaced alone"
                                ),
                            ));
                        }
                        dims.push(Dimension {
                            keys: vec![key],
                            values: values.into_iter().map(|v| vec![v]).collect(),
                        })
                    }
                }
            }
        }
        Ok(dims)
    }

    fn preset(&self, quality: Quality) -> Option<&QualityPreset> {
        match quality {
            Quality::Quick => self.quality.get("quick"),
            Quality::Paper => self.quality.get("paper"),
            Quality::Default => None,
        }
    }

    fn base_table(&self, scene_file: Option<&str>) -> Result<(Table, PathBuf)> {
        let dir = self.base_dir();
        let load = |rel: &Path| -> Result<(Table, PathBuf)> {
            let path = dir.join(rel);
            let text = std::fs::read_to_string(&path).with_context(|| {
                format!("{}: reading scene {}", self.path.display(), path.display())
            })?;
            let table: Table = text
                .parse()
                .map_err(|e: toml::de::Error| anyhow::anyhow!(toml_error(&e, &text, &path)))?;
            let base = path
                .parent()
                .map(Path::to_path_buf)
                .unwrap_or_else(|| PathBuf::from("."));
            Ok((table, base))
        };
        match (scene_file, &self.base) {
            (Some(f), _) => load(Path::new(f)),
            (None, BaseScene::File(f)) => load(f),
            (None, BaseScene::Inline(t)) => Ok((t.clone(), dir)),
        }
    }

    /// Expands the grid into cells for a quality preset; every cell's scene is validated and
    /// errors point at the experiment file.
    pub fn plan(&self, quality: Quality) -> Result<Vec<CellSpec>> {
        let dims = self.dimensions_for(quality)?;
        let total: usize = dims.iter().map(|d| d.values.len()).product();
        let mut cells = Vec::new();
        let mut index = vec![0usize; dims.len()];
        for _ in 0..total {
            let mut axes: Vec<(String, Value)> = Vec::new();
            for (d, &i) in dims.iter().zip(&index) {
                for (k, v) in d.keys.iter().zip(&d.values[i]) {
                    axes.push((k.clone(), v.clone()));
                }
            }
            // Advance the odometer (last dimension fastest).
            for pos in (0..dims.len()).rev() {
                index[pos] += 1;
                if index[pos] < dims[pos].values.len() {
                    break;
                }
                index[pos] = 0;
            }
            if self.exclude.iter().any(|rule| {
                rule.iter()
                    .all(|(k, v)| axes.iter().any(|(ak, av)| ak == k && values_equal(av, v)))
            }) {
                continue;
            }
            cells.push(self.cell(cells.len(), axes, quality)?);
        }
        if cells.is_empty() {
            return Err(located(
                &self.path,
                &self.source,
                "exclude",
                format!("the grid is empty: {total} combination(s), all excluded"),
            ));
        }
        Ok(cells)
    }

    fn cell(&self, index: usize, axes: Vec<(String, Value)>, quality: Quality) -> Result<CellSpec> {
        let scene_file = axes
            .iter()
            .find(|(k, _)| k == "scene")
            .map(|(_, v)| match v {
                Value::String(s) => Ok(s.clone()),
                other => Err(located(
                    &self.path,
                    &self.source,
                    "axes.scene",
                    format!("`scene` axis value {other}: expected a scene file path"),
                )),
            });
        let scene_file = scene_file.transpose()?;
        let (mut table, base_dir) = self.base_table(scene_file.as_deref())?;
        for (k, v) in &self.set {
            set_key(&mut table, k, v.clone())
                .map_err(|m| located(&self.path, &self.source, &format!("set.{k}"), m))?;
        }
        apply_quality_defaults(&mut table, quality, self.preset(quality).is_some());
        if let Some(preset) = self.preset(quality) {
            let mut set = Vec::new();
            flatten_set(&preset.set, "", &mut set);
            for (k, v) in set {
                set_key(&mut table, &k, v)
                    .map_err(|m| located(&self.path, &self.source, "quality", m))?;
            }
        }
        for (k, v) in &axes {
            if k == "scene" {
                continue;
            }
            set_key(&mut table, k, v.clone())
                .map_err(|m| located(&self.path, &self.source, &format!("axes.{k}"), m))?;
        }
        let describe = || {
            axes.iter()
                .map(|(k, v)| format!("{k} = {v}"))
                .collect::<Vec<_>>()
                .join(", ")
        };
        let text = toml::to_string(&table).context("serialising cell scene")?;
        let params: SceneParams = toml::from_str(&text).map_err(|e| {
            let message = e.message().trim().to_string();
            // The key behind the complaint: from the error's position in the generated scene,
            // or (unknown keys) from the name the reader quotes.
            let key = e
                .span()
                .and_then(|s| volphot::scene::key_at(&text, s.start));
            let culprit = axes
                .iter()
                .map(|(k, _)| (k.clone(), format!("axes.{k}")))
                .chain(
                    self.set
                        .iter()
                        .map(|(k, _)| (k.clone(), format!("set.{k}"))),
                )
                .find(|(k, _)| {
                    Some(k) == key.as_ref() || message.contains(&format!("`{}`", short_key(k)))
                });
            let at = culprit
                .as_ref()
                .map(|(_, at)| at.clone())
                .unwrap_or_else(|| "axes".into());
            let named = key.map(|k| format!("`{k}`: ")).unwrap_or_default();
            located(
                &self.path,
                &self.source,
                &at,
                format!("cell {index} ({}): {named}{message}", describe()),
            )
        })?;
        validate_params(&params).map_err(|e| {
            let key = match &e {
                volphot::Error::Parameter { key, .. } => key.clone(),
                _ => String::new(),
            };
            let where_ = if axes.iter().any(|(k, _)| *k == key) {
                format!("axes.{key}")
            } else {
                format!("set.{key}")
            };
            located(
                &self.path,
                &self.source,
                &where_,
                format!("cell {index} ({}): {e}", describe()),
            )
        })?;
        Ok(CellSpec {
            index,
            axes,
            params,
            base_dir,
        })
    }
}

/// Compares axis values, treating 80 and 80.0 as equal.
pub fn values_equal(a: &Value, b: &Value) -> bool {
    match (a, b) {
        (Value::Integer(x), Value::Float(y)) | (Value::Float(y), Value::Integer(x)) => {
            (*x as f64) == *y
        }
        _ => a == b,
    }
}

/// Sets a dotted key in a table, creating intermediate tables.
pub fn set_key(table: &mut Table, key: &str, value: Value) -> std::result::Result<(), String> {
    let parts: Vec<&str> = key.split('.').collect();
    let mut t = table;
    for (i, part) in parts.iter().enumerate() {
        if i == parts.len() - 1 {
            t.insert(part.to_string(), value);
            return Ok(());
        }
        let entry = t
            .entry(part.to_string())
            .or_insert_with(|| Value::Table(Table::new()));
        t = match entry {
            Value::Table(inner) => inner,
            other => {
                return Err(format!(
                    "cannot set `{key}`: `{}` is {other}, not a table",
                    parts[..=i].join(".")
                ));
            }
        };
    }
    Ok(())
}

/// Reads a dotted key from a table.
pub fn get_key<'a>(table: &'a Table, key: &str) -> Option<&'a Value> {
    let mut parts = key.split('.').peekable();
    let mut t = table;
    while let Some(part) = parts.next() {
        let v = t.get(part)?;
        if parts.peek().is_none() {
            return Some(v);
        }
        t = v.as_table()?;
    }
    None
}

/// Presets that apply when the experiment does not define its own: `--quick` renders at a
/// quarter of the resolution (at least 64 pixels), `--paper` at the thesis's 512×512.
fn apply_quality_defaults(table: &mut Table, quality: Quality, has_own_preset: bool) {
    if has_own_preset {
        return;
    }
    let resolution = get_key(table, "camera.resolution")
        .and_then(|v| v.as_array())
        .and_then(|a| Some([a.first()?.as_integer()?, a.get(1)?.as_integer()?]))
        .unwrap_or([512, 512]);
    let new = match quality {
        Quality::Default => return,
        Quality::Quick => resolution.map(|n| (n / 4).max(64)),
        Quality::Paper => [512, 512],
    };
    let _ = set_key(
        table,
        "camera.resolution",
        Value::Array(new.iter().map(|&n| Value::Integer(n)).collect()),
    );
}

/// One cell of the grid.
#[derive(Debug, Clone)]
pub struct CellSpec {
    /// Position in the plan.
    pub index: usize,
    /// Axis values of this cell, in grid order.
    pub axes: Vec<(String, Value)>,
    /// The effective scene.
    pub params: SceneParams,
    /// Folder for resolving the scene's relative paths.
    pub base_dir: PathBuf,
}

impl CellSpec {
    /// `key = value, …` for captions.
    pub fn label(&self) -> String {
        if self.axes.is_empty() {
            return "base scene".into();
        }
        self.axes
            .iter()
            .map(|(k, v)| format!("{} = {}", short_key(k), value_text(v)))
            .collect::<Vec<_>>()
            .join(", ")
    }

    /// The value of an axis in this cell.
    #[cfg(test)]
    pub fn axis(&self, key: &str) -> Option<&Value> {
        self.axes.iter().find(|(k, _)| k == key).map(|(_, v)| v)
    }
}

/// The last segment of a key path (`integrator.nused` → `nused`).
pub fn short_key(key: &str) -> &str {
    key.rsplit('.').next().unwrap_or(key)
}

/// A value as plain text (strings without quotes).
pub fn value_text(v: &Value) -> String {
    match v {
        Value::String(s) => s.clone(),
        Value::Float(f) => format!("{f}"),
        other => other.to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
        let p = dir.join(name);
        std::fs::write(&p, text).unwrap();
        p
    }

    const SCENE: &str = "[volume]\nphantom = { name = \"sphere\", resolution = [8, 8, 8] }\n[three_point]\n[camera]\nresolution = [64, 64]\n";

    #[test]
    fn product_zip_exclude_and_ranges() {
        let dir = tempfile::tempdir().unwrap();
        write(dir.path(), "s.toml", SCENE);
        let exp = write(
            dir.path(),
            "e.toml",
            r#"
scene = "s.toml"
[axes]
integrator.nused = [25, 150]
"sigma.t" = { from = 6, to = 300, steps = 3, scale = "log" }
[[zip]]
"integrator.maxdist" = [0.05, 0.1]
"integrator.volume_photons" = [1000, 2000]
[[exclude]]
"integrator.nused" = 25
"sigma.t" = 300
"#,
        );
        let e = Experiment::load(&exp).unwrap();
        let cells = e.plan(Quality::Default).unwrap();
        // 2 × 3 × 2 = 12, minus the 2 cells with nused 25 and t 300.
        assert_eq!(cells.len(), 10);
        let t_values: Vec<String> = cells
            .iter()
            .map(|c| value_text(c.axis("sigma.t").unwrap()))
            .collect();
        assert!(
            t_values.contains(&"6".to_string()) && t_values.contains(&"42".to_string()),
            "{t_values:?}"
        );
        let c = &cells[1];
        assert_eq!(c.params.integrator.nused, 25);
        assert_eq!(c.params.integrator.maxdist, 0.1);
        assert_eq!(c.params.integrator.volume_photons, 2000);
        // --quick quarters the resolution (min 64), --paper is 512².
        assert_eq!(
            e.plan(Quality::Quick).unwrap()[0].params.camera.resolution,
            [64, 64]
        );
        assert_eq!(
            e.plan(Quality::Paper).unwrap()[0].params.camera.resolution,
            [512, 512]
        );
    }

    #[test]
    fn errors_point_at_the_experiment_file() {
        let dir = tempfile::tempdir().unwrap();
        write(dir.path(), "s.toml", SCENE);
        let cases = [
            (
                "scene = \"s.toml\"\n[axes]\n\"integrator.nused\" = [0, 5]\n",
                "e.toml:3:1",
                "`integrator.nused` = 0",
            ),
            (
                "scene = \"s.toml\"\nmax_cell = 3\n",
                "e.toml:2:1",
                "max_cell",
            ),
            (
                "scene = \"s.toml\"\n[axes]\n\"sigma.t\" = { from = 6, to = 300 }\n",
                "e.toml:3",
                "steps",
            ),
            (
                "scene = \"s.toml\"\n[[zip]]\na = [1, 2]\nb = [1]\n",
                "e.toml:",
                "equal lengths",
            ),
            (
                "scene = \"s.toml\"\n[axes]\n\"integrator.nused\" = [5]\n[[exclude]]\n\"integrator.nused\" = 5\n",
                "e.toml:",
                "empty",
            ),
            ("scene = \"missing.toml\"\n", "e.toml", "missing.toml"),
            (
                "scene = \"s.toml\"\n[axes]\n\"integrator.nsued\" = [5]\n",
                "e.toml:3",
                "nsued",
            ),
        ];
        for (text, at, what) in cases {
            let p = write(dir.path(), "e.toml", text);
            let err = Experiment::load(&p).and_then(|e| e.plan(Quality::Default).map(|_| ()));
            let msg = format!("{:#}", err.unwrap_err());
            assert!(msg.contains(at), "{msg} should contain {at}");
            assert!(msg.contains(what), "{msg} should name {what}");
        }
    }
}
