//! Expanding the grid into cells: the Cartesian product of the dimensions (last one
//! fastest) minus excluded combinations; each cell's scene is the base scene with `[set]`,
//! the quality preset and its axis values applied, validated with errors that point at the
//! experiment file.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use toml::{Table, Value};
use volphot::{SceneParams, toml_error, validate_params};

use super::axes::{Dimension, axis_values};
use super::keys::{
    flatten_axes, flatten_set, get_key, set_key, short_key, value_text, values_equal,
};
use super::{BaseScene, Experiment, Quality};

/// One cell of the grid.
#[derive(Debug, Clone)]
pub(crate) struct CellSpec {
    /// Position in the plan.
    pub(crate) index: usize,
    /// Axis values of this cell, in grid order.
    pub(crate) axes: Vec<(String, Value)>,
    /// The effective scene.
    pub(crate) params: SceneParams,
    /// Folder for resolving the scene's relative paths.
    pub(crate) base_dir: PathBuf,
}

impl CellSpec {
    /// `key = value, …` for captions.
    pub(crate) fn label(&self) -> String {
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
    pub(crate) fn axis(&self, key: &str) -> Option<&Value> {
        self.axes.iter().find(|(k, _)| k == key).map(|(_, v)| v)
    }
}

impl Experiment {
    /// The grid's dimensions for a quality preset (its axis replacements applied).
    pub(crate) fn dimensions_for(&self, quality: Quality) -> Result<Vec<Dimension>> {
        let mut dims = self.dimensions.clone();
        let Some(preset) = self.preset(quality) else {
            return Ok(dims);
        };
        let mut replacements = Vec::new();
        flatten_axes(&preset.axes, "", &mut replacements);
        for (key, spec) in replacements {
            let values = axis_values(&spec).map_err(|m| {
                self.source
                    .error("quality", format!("quality axis `{key}`: {m}"))
            })?;
            let replacement = Dimension::single(key.clone(), values);
            if let Some(m) = replacement.repeat() {
                return Err(self.source.error("quality", format!("quality axis {m}")));
            }
            if let Some(d) = dims.iter_mut().find(|d| d.keys == [key.clone()]) {
                d.values = replacement.values;
            } else if dims.iter().any(|d| d.keys.contains(&key)) {
                return Err(self.source.error(
                    "quality",
                    format!(
                        "quality axis `{key}` is part of a [[zip]] group and cannot be replaced alone"
                    ),
                ));
            } else {
                dims.push(replacement);
            }
        }
        Ok(dims)
    }

    /// The number of cells the grid has for a quality preset (combinations that no exclude
    /// rule drops), counted without building any cell; grids beyond
    /// [`MAX_COMBINATIONS`] are refused before counting.
    pub(crate) fn grid_size(&self, quality: Quality) -> Result<usize> {
        let dims = self.dimensions_for(quality)?;
        let total = combinations(&dims)?;
        // Each exclude rule as (dimension, key position, value) triples.
        let rules: Vec<Vec<(usize, usize, &Value)>> = self
            .exclude
            .iter()
            .map(|rule| {
                rule.iter()
                    .filter_map(|(k, v)| {
                        dims.iter().enumerate().find_map(|(di, d)| {
                            d.keys.iter().position(|dk| dk == k).map(|ki| (di, ki, v))
                        })
                    })
                    .collect()
            })
            .collect();
        let mut index = vec![0usize; dims.len()];
        let mut count = 0;
        for _ in 0..total {
            let excluded = rules.iter().any(|rule| {
                rule.iter()
                    .all(|&(di, ki, v)| values_equal(&dims[di].values[index[di]][ki], v))
            });
            count += usize::from(!excluded);
            advance(&mut index, &dims);
        }
        Ok(count)
    }

    /// Expands the grid into cells for a quality preset; every cell's scene is validated and
    /// errors point at the experiment file. Check [`Experiment::grid_size`] first: this
    /// builds every cell.
    pub(crate) fn plan(&self, quality: Quality) -> Result<Vec<CellSpec>> {
        let dims = self.dimensions_for(quality)?;
        let total = combinations(&dims)?;
        let mut cells = Vec::new();
        let mut index = vec![0usize; dims.len()];
        for _ in 0..total {
            let mut axes: Vec<(String, Value)> = Vec::new();
            for (d, &i) in dims.iter().zip(&index) {
                for (k, v) in d.keys.iter().zip(&d.values[i]) {
                    axes.push((k.clone(), v.clone()));
                }
            }
            advance(&mut index, &dims);
            if self.excluded(&axes) {
                continue;
            }
            cells.push(self.cell(cells.len(), axes, quality)?);
        }
        if cells.is_empty() {
            return Err(self.source.error(
                "exclude",
                format!("the grid is empty: {total} combination(s), all excluded"),
            ));
        }
        Ok(cells)
    }

    /// Every cell must be a scene of its own: two cells under one address would be planned
    /// and rendered as one, and the run would report the second as left to another run.
    /// Repeated values are refused with the axes; this finds what only the scenes show,
    /// such as two scene files with the same content, or a value another key makes moot.
    pub(crate) fn distinct_scenes(
        &self,
        quality: Quality,
        cells: &[CellSpec],
        hashes: &[String],
    ) -> Result<()> {
        let mut first: HashMap<&str, usize> = HashMap::with_capacity(hashes.len());
        for (j, hash) in hashes.iter().enumerate() {
            if let Some(&i) = first.get(hash.as_str()) {
                return Err(self.same_scene(quality, &cells[i], &cells[j], hash));
            }
            first.insert(hash, j);
        }
        Ok(())
    }

    /// Two cells with one address: the axis values they differ in, with their positions
    /// (and for scene files, both files).
    fn same_scene(
        &self,
        quality: Quality,
        a: &CellSpec,
        b: &CellSpec,
        hash: &str,
    ) -> anyhow::Error {
        let dims = self.dimensions_for(quality).unwrap_or_default();
        let position = |key: &str, value: &Value| {
            dims.iter().find_map(|d| {
                let k = d.keys.iter().position(|dk| dk == key)?;
                d.values.iter().position(|row| values_equal(&row[k], value))
            })
        };
        let differ: Vec<(&str, &Value, &Value)> = a
            .axes
            .iter()
            .zip(&b.axes)
            .filter(|((_, x), (_, y))| !values_equal(x, y))
            .map(|((k, x), (_, y))| (k.as_str(), x, y))
            .collect();
        let what: Vec<String> = differ
            .iter()
            .map(|&(key, x, y)| {
                let at = match (position(key, x), position(key, y)) {
                    (Some(p), Some(q)) => format!(" (positions {} and {})", p + 1, q + 1),
                    _ => String::new(),
                };
                if key == "scene" {
                    let file =
                        |v: &Value| self.base_dir().join(value_text(v)).display().to_string();
                    format!(
                        "the scene files {} and {} of axis `scene`{at} hold the same scene",
                        file(x),
                        file(y)
                    )
                } else {
                    format!("`{key}` = {x} and {y}{at} make the same scene")
                }
            })
            .collect();
        let at = differ
            .first()
            .map_or("axes".to_string(), |(k, _, _)| format!("axes.{k}"));
        self.source.error(
            &at,
            format!(
                "cells {} ({}) and {} ({}) are the same scene (address {hash}): {}; every cell must render a scene of its own, so remove one of the values, or drop one of the two combinations with [[exclude]]",
                a.index,
                a.label(),
                b.index,
                b.label(),
                what.join("; ")
            ),
        )
    }

    /// Whether an exclude rule matches every one of its keys in `axes`.
    fn excluded(&self, axes: &[(String, Value)]) -> bool {
        self.exclude.iter().any(|rule| {
            rule.iter()
                .all(|(k, v)| axes.iter().any(|(ak, av)| ak == k && values_equal(av, v)))
        })
    }

    /// The scene table of one cell: base scene, `[set]`, quality preset, axis values.
    pub(crate) fn cell_table(
        &self,
        axes: &[(String, Value)],
        quality: Quality,
    ) -> Result<(Table, PathBuf)> {
        let scene_file = axes
            .iter()
            .find(|(k, _)| k == "scene")
            .map(|(_, v)| match v {
                Value::String(s) => Ok(s.clone()),
                other => Err(self.source.error(
                    "axes.scene",
                    format!("`scene` axis value {other}: expected a scene file path"),
                )),
            })
            .transpose()?;
        let (mut table, base_dir) = self.base_table(scene_file.as_deref())?;
        for (k, v) in &self.set {
            set_key(&mut table, k, v.clone())
                .map_err(|m| self.source.error(&format!("set.{k}"), m))?;
        }
        apply_quality_defaults(&mut table, quality, self.preset(quality).is_some());
        if let Some(preset) = self.preset(quality) {
            let mut set = Vec::new();
            flatten_set(&preset.set, "", &mut set);
            for (k, v) in set {
                set_key(&mut table, &k, v).map_err(|m| self.source.error("quality", m))?;
            }
        }
        for (k, v) in axes.iter().filter(|(k, _)| k != "scene") {
            set_key(&mut table, k, v.clone())
                .map_err(|m| self.source.error(&format!("axes.{k}"), m))?;
        }
        Ok((table, base_dir))
    }

    /// One validated cell: the base scene with `[set]`, the quality preset and `axes`.
    pub(crate) fn cell(
        &self,
        index: usize,
        axes: Vec<(String, Value)>,
        quality: Quality,
    ) -> Result<CellSpec> {
        let (table, base_dir) = self.cell_table(&axes, quality)?;
        let describe = || {
            axes.iter()
                .map(|(k, v)| format!("{k} = {v}"))
                .collect::<Vec<_>>()
                .join(", ")
        };
        let text = toml::to_string(&table).context("serialising cell scene")?;
        let params: SceneParams = toml::from_str(&text)
            .map_err(|e| self.scene_type_error(&e, &text, index, &axes, &describe()))?;
        validate_params(&params).map_err(|e| {
            let key = match &e {
                volphot::Error::Parameter { key, .. } => key.clone(),
                _ => String::new(),
            };
            let at = if axes.iter().any(|(k, _)| *k == key) {
                format!("axes.{key}")
            } else {
                format!("set.{key}")
            };
            self.source
                .error(&at, format!("cell {index} ({}): {e}", describe()))
        })?;
        Ok(CellSpec {
            index,
            axes,
            params,
            base_dir,
        })
    }

    /// A type error in a cell's generated scene, pointed at the axis or `[set]` key behind
    /// it: found from the error's position in the generated text, or (unknown keys) from
    /// the name the reader quotes.
    fn scene_type_error(
        &self,
        e: &toml::de::Error,
        text: &str,
        index: usize,
        axes: &[(String, Value)],
        described: &str,
    ) -> anyhow::Error {
        let message = e.message().trim().to_string();
        let key = e.span().and_then(|s| volphot::key_at(text, s.start));
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
        self.source
            .error(&at, format!("cell {index} ({described}): {named}{message}"))
    }

    /// The base scene as a table, and the folder its relative paths resolve against.
    fn base_table(&self, scene_file: Option<&str>) -> Result<(Table, PathBuf)> {
        let dir = self.base_dir();
        let load = |rel: &Path| -> Result<(Table, PathBuf)> {
            // A scene the experiment names is read inside the experiment's folder: a link
            // there may not lead out of it (as the files a scene names are confined).
            let path = volphot::confined(&dir, rel, "the experiment's folder")
                .with_context(|| format!("{}: reading its scene", self.source.path.display()))?;
            let text = volphot::read_text_capped(&path, volphot::TEXT_INPUT_CAP, "scene file")
                .with_context(|| format!("{}: reading its scene", self.source.path.display()))?;
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
}

/// Grids with more combinations than this (before exclusions) are refused outright: even
/// counting them would take minutes, and no study needs them.
pub(crate) const MAX_COMBINATIONS: u128 = 100_000_000;

/// The number of combinations of the dimensions (before exclusions), refused beyond
/// [`MAX_COMBINATIONS`].
fn combinations(dims: &[Dimension]) -> Result<usize> {
    let total = dims
        .iter()
        .try_fold(1u128, |acc, d| acc.checked_mul(d.values.len() as u128))
        .unwrap_or(u128::MAX);
    anyhow::ensure!(
        total <= MAX_COMBINATIONS,
        "the grid has {} combinations of its axes ({}), more than {MAX_COMBINATIONS} that sweep will count; split the study into several experiments or use fewer values per axis",
        if total == u128::MAX {
            "over 2^128".to_string()
        } else {
            total.to_string()
        },
        dims.iter()
            .map(|d| format!("{} × {}", d.keys.join("+"), d.values.len()))
            .collect::<Vec<_>>()
            .join(", ")
    );
    Ok(total as usize)
}

/// Advances the odometer `index` over `dims` (last dimension fastest).
fn advance(index: &mut [usize], dims: &[Dimension]) {
    for pos in (0..dims.len()).rev() {
        index[pos] += 1;
        if index[pos] < dims[pos].values.len() {
            break;
        }
        index[pos] = 0;
    }
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
