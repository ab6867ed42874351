//! The experiment file as written: its tables and their serde types. Choices are enums, so
//! an unknown value is a located TOML error that lists the allowed ones.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};
use toml::{Table, Value};

pub(crate) use crate::store::ReferenceMethod;

/// The file's top level.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct ExperimentFile {
    pub(crate) name: Option<String>,
    #[serde(default)]
    pub(crate) description: String,
    pub(crate) scene: Option<Value>,
    #[serde(default = "default_max_cells")]
    pub(crate) max_cells: usize,
    #[serde(default = "default_true")]
    pub(crate) share: bool,
    #[serde(default)]
    pub(crate) set: Table,
    #[serde(default)]
    pub(crate) axes: Table,
    #[serde(default)]
    pub(crate) zip: Vec<Table>,
    #[serde(default)]
    pub(crate) exclude: Vec<Table>,
    #[serde(default)]
    pub(crate) quality: BTreeMap<String, QualityPreset>,
    pub(crate) reference: Option<ReferenceSpec>,
    #[serde(default)]
    pub(crate) compare: Vec<CompareSpec>,
    #[serde(default)]
    pub(crate) plots: Vec<PlotSpec>,
    #[serde(default)]
    pub(crate) sheets: Vec<SheetSpec>,
    /// `sweep tune`: objective, budget, fidelity and search space.
    pub(crate) tune: Option<super::TuneFile>,
    /// How the report is written.
    #[serde(default)]
    pub(crate) report: ReportSpec,
}

/// `[report]`: how the report is written.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct ReportSpec {
    /// The explorer's pixel data at most this many pixels on the long side: larger images
    /// are averaged over square bins (the readout then says so). The committed studies set
    /// it, so that every study opens in the explorer from a clone at a size git can carry;
    /// unset, the data are at the full resolution.
    #[serde(default)]
    pub(crate) explorer_max_side: Option<usize>,
    /// The comparison the study was made for; the explorer opens on it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub(crate) pair: Option<PairSpec>,
}

/// `[report] pair = { a = { … }, b = { … } }`: the two settings a study compares, each a
/// set of axis values (a list: any of them). The explorer opens on the first finished cell
/// of `a` against the cell of `b` that agrees with it on every axis neither side names.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct PairSpec {
    /// The first setting (the explorer's A).
    pub(crate) a: Table,
    /// The second (B).
    pub(crate) b: Table,
}

fn default_max_cells() -> usize {
    200
}

fn default_true() -> bool {
    true
}

/// `[quality.quick]` / `[quality.paper]`: overrides and axis replacements.
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct QualityPreset {
    #[serde(default)]
    pub(crate) set: Table,
    #[serde(default)]
    pub(crate) axes: Table,
}

/// How the ground truth is made.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct ReferenceSpec {
    /// `path` (the reference path tracer) or `photon` (a photon-mapping render with many
    /// photons).
    #[serde(default)]
    pub(crate) method: ReferenceMethod,
    /// Path-tracer samples per pixel.
    #[serde(default = "default_reference_spp")]
    pub(crate) spp: u32,
    /// `photon`: photons.
    #[serde(default)]
    pub(crate) volume_photons: Option<u64>,
    /// `photon`: photons per estimate.
    #[serde(default)]
    pub(crate) nused: Option<u32>,
    /// Further overrides of the reference scene.
    #[serde(default)]
    pub(crate) set: Table,
}

fn default_reference_spp() -> u32 {
    256
}

/// What a `[[compare]]` block compares.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub(crate) enum CompareKind {
    /// Single vs single + multiple scattering of each cell (thesis Fig. 18).
    Layers,
    /// Each cell against the ground truth.
    Reference,
    /// Cells that differ only in `axis`: value `a` against value `b`.
    Axis,
}

/// An image comparison.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct CompareSpec {
    /// What is compared.
    pub(crate) kind: CompareKind,
    /// `axis`: the axis key.
    #[serde(default)]
    pub(crate) axis: Option<String>,
    /// `axis`: the value compared (all other values when absent).
    #[serde(default)]
    pub(crate) a: Option<Value>,
    /// `axis`: the value compared against.
    #[serde(default)]
    pub(crate) b: Option<Value>,
    /// Gain of the brightness-amplified difference image (default: automatic, printed).
    #[serde(default)]
    pub(crate) gain: Option<f32>,
}

/// A metric-vs-axis plot.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct PlotSpec {
    /// Axis key on the x axis.
    pub(crate) x: String,
    /// Metric columns on the y axis (one figure each).
    pub(crate) y: Vec<String>,
    /// Axis whose values give one line each.
    #[serde(default)]
    pub(crate) series: Option<String>,
    /// Logarithmic x axis.
    #[serde(default)]
    pub(crate) log_x: bool,
    /// Logarithmic y axis.
    #[serde(default)]
    pub(crate) log_y: bool,
    /// Only cells with these axis values (e.g. `{ scene = "scenes/foot.toml" }`).
    #[serde(default, rename = "where")]
    pub(crate) filter: Table,
}

/// Which image a contact sheet shows.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub(crate) enum SheetLayer {
    /// What the cell displays.
    #[default]
    Total,
    /// Single scattering only.
    Single,
    /// The multiple-scattering layer.
    Multiple,
    /// The amplified difference single vs single + multiple.
    Diff,
}

impl SheetLayer {
    /// The name used in file names and titles.
    pub(crate) fn name(self) -> &'static str {
        match self {
            SheetLayer::Total => "total",
            SheetLayer::Single => "single",
            SheetLayer::Multiple => "multiple",
            SheetLayer::Diff => "diff",
        }
    }
}

/// A contact sheet: images in a grid labelled by axis values.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct SheetSpec {
    /// Axis along the rows.
    pub(crate) rows: String,
    /// Axis along the columns.
    #[serde(default)]
    pub(crate) cols: Option<String>,
    /// Which image each tile shows.
    #[serde(default)]
    pub(crate) layer: SheetLayer,
    /// Only cells with these axis values.
    #[serde(default, rename = "where")]
    pub(crate) filter: Table,
}
