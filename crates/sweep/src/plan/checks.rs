//! Consistency checks of an experiment file beyond its types: every key an exclude rule,
//! comparison, plot or sheet names must be an axis, every plotted metric must exist, and
//! each block must have what its kind needs. Errors point at the block in the file.

use std::collections::BTreeMap;

use anyhow::Result;

use toml::{Table, Value};

use super::axes::Dimension;
use super::file::{
    CompareKind, CompareSpec, ExperimentFile, PairSpec, PlotSpec, QualityPreset, ReferenceSpec,
    SheetSpec,
};
use super::keys::{flatten_axes, flatten_set, scene_key};
use super::source::Source;
use crate::analyse::{is_metric, metric_keys};

/// The axes of a grid, for checking references to them.
pub(crate) struct AxisNames<'a> {
    source: &'a Source,
    names: Vec<&'a str>,
}

impl<'a> AxisNames<'a> {
    pub(crate) fn new(source: &'a Source, dimensions: &'a [Dimension]) -> Self {
        AxisNames {
            source,
            names: dimensions
                .iter()
                .flat_map(|d| d.keys.iter().map(String::as_str))
                .collect(),
        }
    }

    /// These axes and `extra` (a tune's searched and fidelity keys).
    pub(crate) fn with(mut self, extra: &'a [String]) -> Self {
        self.names.extend(extra.iter().map(String::as_str));
        self
    }

    /// Every key in `keys` must be an axis; the error names block `table[index]`.
    pub(crate) fn require<'k>(
        &self,
        table: &str,
        index: usize,
        keys: impl IntoIterator<Item = &'k String>,
    ) -> Result<()> {
        match keys.into_iter().find(|k| !self.names.contains(&k.as_str())) {
            Some(k) => Err(self.source.error(
                table,
                format!(
                    "{table}[{index}]: `{k}` is not an axis (axes: {})",
                    self.names.join(", ")
                ),
            )),
            None => Ok(()),
        }
    }
}

/// Every key that names a scene setting (`[set]`, `[axes]`, `[[zip]]`, the quality presets'
/// `set` and `axes`, `[reference]`'s `set`) is a dotted path of names; the error points at it.
pub(crate) fn scene_keys(source: &Source, file: &ExperimentFile) -> Result<()> {
    let mut keys: Vec<(String, String)> = Vec::new();
    let mut add = |at: &str, flat: Vec<(String, Value)>| {
        keys.extend(flat.into_iter().map(|(k, _)| (at.to_string(), k)));
    };
    let flat = |table: &Table, leaf: fn(&Table, &str, &mut Vec<(String, Value)>)| {
        let mut v = Vec::new();
        leaf(table, "", &mut v);
        v
    };
    add("set", flat(&file.set, flatten_set));
    add("axes", flat(&file.axes, flatten_axes));
    for zip in &file.zip {
        add("zip", flat(zip, flatten_axes));
    }
    for (name, preset) in &file.quality {
        add(&format!("quality.{name}"), flat(&preset.set, flatten_set));
        add(&format!("quality.{name}"), flat(&preset.axes, flatten_axes));
    }
    if let Some(r) = &file.reference {
        add("reference", flat(&r.set, flatten_set));
    }
    for (at, key) in keys {
        scene_key(&key).map_err(|m| {
            let at = if at.contains('.') {
                at
            } else {
                format!("{at}.{key}")
            };
            source.error(&at, m)
        })?;
    }
    Ok(())
}

/// Only `quick` and `paper` presets exist.
pub(crate) fn quality_presets(
    source: &Source,
    presets: &BTreeMap<String, QualityPreset>,
) -> Result<()> {
    match presets.keys().find(|q| *q != "quick" && *q != "paper") {
        Some(q) => Err(source.error(
            &format!("quality.{q}"),
            format!("unknown quality preset `{q}` (expected quick or paper)"),
        )),
        None => Ok(()),
    }
}

/// A reference needs at least one sample per pixel.
pub(crate) fn reference(source: &Source, reference: Option<&ReferenceSpec>) -> Result<()> {
    if reference.is_some_and(|r| r.spp == 0) {
        return Err(source.error("reference.spp", "`reference.spp` = 0: expected at least 1"));
    }
    Ok(())
}

/// Each `[[compare]]` block has what its kind needs.
pub(crate) fn compare(
    axes: &AxisNames<'_>,
    compare: &[CompareSpec],
    has_reference: bool,
) -> Result<()> {
    for (ci, c) in compare.iter().enumerate() {
        match c.kind {
            CompareKind::Layers => {}
            CompareKind::Reference if !has_reference => {
                return Err(axes.source.error(
                    "compare",
                    format!("compare[{ci}]: kind = \"reference\" needs a [reference] table"),
                ));
            }
            CompareKind::Reference => {}
            CompareKind::Axis => {
                let axis = c.axis.as_ref().ok_or_else(|| {
                    axes.source.error(
                        "compare",
                        format!("compare[{ci}]: kind = \"axis\" needs `axis`"),
                    )
                })?;
                axes.require("compare", ci, [axis])?;
                if c.b.is_none() {
                    return Err(axes.source.error(
                        "compare",
                        format!(
                            "compare[{ci}]: kind = \"axis\" needs `b` (the value compared against)"
                        ),
                    ));
                }
            }
        }
    }
    Ok(())
}

/// `[report] pair`: each side names axes, at least one, and the two sides differ.
pub(crate) fn pair(axes: &AxisNames<'_>, pair: Option<&PairSpec>) -> Result<()> {
    let Some(pair) = pair else {
        return Ok(());
    };
    for (side, table) in [("a", &pair.a), ("b", &pair.b)] {
        if table.is_empty() {
            return Err(axes.source.error(
                "pair",
                format!("report.pair.{side} is empty: expected the axis values of the setting the study compares, e.g. {{ \"integrator.multiple\" = false }}"),
            ));
        }
        axes.require(&format!("report.pair.{side}"), 0, table.keys())?;
    }
    if pair.a == pair.b {
        return Err(axes.source.error(
            "pair",
            "report.pair.a and report.pair.b are the same setting: expected the two sides of the study's comparison",
        ));
    }
    Ok(())
}

/// Plots name axes and metrics; sheets name axes.
pub(crate) fn figures(
    axes: &AxisNames<'_>,
    plots: &[PlotSpec],
    sheets: &[SheetSpec],
) -> Result<()> {
    for (pi, p) in plots.iter().enumerate() {
        axes.require(
            "plots",
            pi,
            std::iter::once(&p.x)
                .chain(&p.series)
                .chain(p.filter.keys()),
        )?;
        if let Some(y) = p.y.iter().find(|y| !is_metric(y)) {
            return Err(axes.source.error(
                "plots",
                format!(
                    "plots[{pi}]: `{y}` is not a metric (metrics: {})",
                    metric_keys()
                ),
            ));
        }
    }
    for (si, s) in sheets.iter().enumerate() {
        axes.require(
            "sheets",
            si,
            std::iter::once(&s.rows)
                .chain(&s.cols)
                .chain(s.filter.keys()),
        )?;
    }
    Ok(())
}
