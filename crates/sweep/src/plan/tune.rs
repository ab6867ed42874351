//! The `[tune]` section of an experiment file: its serde form and the validated
//! [`TuneSpec`]. Every error names the key, the value and what was expected, located in
//! the experiment file.
//!
//! ```toml
//! [tune]
//! seed = 7
//! objective = "rmse"                 # rmse | rmse_corrected | rel_mse | flip | disco_excess, or weights:
//! # objective = { rmse = 1.0, flip = 0.5 }
//! budget = { renders = 60 }          # 1..=1000000, or { seconds = 3600 } (recorded render seconds)
//! proposal = "tpe"                   # or "random"
//! random_fraction = 0.33             # share of uniform proposals once a model exists
//! time_budgets = [10, 30, 60]        # best settings per render time per frame, seconds
//!
//! [tune.fidelity]                    # Hyperband over resolution and photon count
//! resolution = [512, 512]            # the target (full fidelity)
//! min_resolution = [128, 128]        # the lowest level
//! min_photon_fraction = 0.25         # photons at the lowest level, as a fraction
//! levels = 3                         # fidelity levels (Hyperband's s_max + 1)
//! eta = 3                            # keep 1/eta per rung
//!
//! [tune.space]
//! "integrator.nused" = { int = [20, 1000], scale = "log" }
//! "integrator.maxdist" = { range = [0.01, 0.5], scale = "log" }
//! "sigma.albedo" = { range = [0.5, 0.95] }
//! "integrator.estimator" = { choices = ["points", "beam"] }
//!
//! [tune.constraints]
//! seconds_per_frame = 60             # at the target resolution
//! ```

use serde::Deserialize;
use toml::{Table, Value};

use super::Source;
use super::flatten_space;
use super::keys::scene_key;

/// The most fidelity levels (each level is a power of `eta` more work than the last).
const MAX_LEVELS: u32 = 6;

/// The largest `budget = { renders = … }`: more renders than any study here spends (the
/// thesis's tune is a few hundred) and than a search reaches in its iteration limit on a
/// small schedule, while every count planned from it stays far from overflowing.
const MAX_RENDERS: usize = 1_000_000;

/// `[tune]` as written.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct TuneFile {
    #[serde(default)]
    seed: u64,
    objective: Value,
    budget: BudgetFile,
    #[serde(default)]
    proposal: Proposal,
    #[serde(default = "default_random_fraction")]
    random_fraction: f64,
    #[serde(default)]
    time_budgets: Vec<f64>,
    fidelity: FidelityFile,
    space: Table,
    #[serde(default)]
    constraints: ConstraintsFile,
}

fn default_random_fraction() -> f64 {
    1.0 / 3.0
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct BudgetFile {
    renders: Option<usize>,
    seconds: Option<f64>,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct FidelityFile {
    resolution: [u32; 2],
    min_resolution: Option<[u32; 2]>,
    #[serde(default = "one")]
    min_photon_fraction: f64,
    #[serde(default = "default_levels")]
    levels: u32,
    #[serde(default = "default_eta")]
    eta: u32,
}

fn one() -> f64 {
    1.0
}
fn default_levels() -> u32 {
    3
}
fn default_eta() -> u32 {
    3
}

#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct ConstraintsFile {
    seconds_per_frame: Option<f64>,
}

/// How new configurations are proposed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub(crate) enum Proposal {
    /// Tree-Parzen estimator (the `tpe` crate) on the largest fidelity with enough points.
    #[default]
    Tpe,
    /// Uniform random (plain Hyperband).
    Random,
}

/// An error metric the objective sums, by its `cells.csv` column key.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Metric {
    /// Root-mean-square error against the reference.
    Rmse,
    /// The same with the reference's own noise removed (the error against the truth).
    RmseCorrected,
    /// Relative MSE against the reference.
    RelMse,
    /// Mean FLIP error against the reference.
    Flip,
    /// Disco-ball energy the reference lacks.
    DiscoExcess,
}

impl Metric {
    const ALL: [Metric; 5] = [
        Metric::Rmse,
        Metric::RmseCorrected,
        Metric::RelMse,
        Metric::Flip,
        Metric::DiscoExcess,
    ];

    /// The metric column key (`crate::analyse::METRIC_COLUMNS`).
    pub(crate) fn key(self) -> &'static str {
        match self {
            Metric::Rmse => "rmse",
            Metric::RmseCorrected => "rmse_corrected",
            Metric::RelMse => "rel_mse",
            Metric::Flip => "flip",
            Metric::DiscoExcess => "disco_excess",
        }
    }

    fn parse(name: &str) -> Option<Metric> {
        let name = match name {
            "relmse" => "rel_mse",
            "disco" => "disco_excess",
            other => other,
        };
        Metric::ALL.into_iter().find(|m| m.key() == name)
    }
}

/// What the search spends.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Budget {
    /// Evaluated cells (renders), finished ones included, so a rerun replays the same run.
    Renders(usize),
    /// Render seconds of the evaluated cells as their records state them.
    Seconds(f64),
}

/// The kind and range of one searched scene key.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum ParamKind {
    /// A real number in `[lo, hi]`, searched in log space when `log`.
    Float { lo: f64, hi: f64, log: bool },
    /// An integer in `[lo, hi]`, searched in log space when `log`.
    Int { lo: i64, hi: i64, log: bool },
    /// One of these values.
    Choice(Vec<Value>),
}

/// One searched scene key.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Param {
    /// The scene key path.
    pub(crate) key: String,
    /// Its kind and range.
    pub(crate) kind: ParamKind,
}

/// Resolution and photon count across fidelity levels.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Fidelity {
    /// The target resolution (the top level).
    pub(crate) resolution: [u32; 2],
    /// The lowest level's resolution.
    pub(crate) min_resolution: [u32; 2],
    /// Photons at the lowest level as a fraction of the configuration's.
    pub(crate) min_photon_fraction: f64,
    /// Number of levels (Hyperband's s_max + 1).
    pub(crate) levels: u32,
    /// Reduction factor: each level costs about `eta` times the one below, and a rung keeps
    /// the best 1/eta.
    pub(crate) eta: u32,
}

/// The validated `[tune]` section.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct TuneSpec {
    /// Seed of every proposal.
    pub(crate) seed: u64,
    /// Weighted metrics, summed.
    pub(crate) objective: Vec<(Metric, f64)>,
    /// What the search may spend.
    pub(crate) budget: Budget,
    /// Proposal method.
    pub(crate) proposal: Proposal,
    /// Share of uniform proposals once a model exists.
    pub(crate) random_fraction: f64,
    /// Render seconds per frame for the best-settings files (ascending).
    pub(crate) time_budgets: Vec<f64>,
    /// Fidelity levels.
    pub(crate) fidelity: Fidelity,
    /// Searched keys, in file order.
    pub(crate) space: Vec<Param>,
    /// Largest render seconds per frame at the target resolution.
    pub(crate) max_seconds: Option<f64>,
}

/// The photon count key: scaled by the fidelity level.
pub(crate) const PHOTONS_KEY: &str = "integrator.volume_photons";
/// The resolution key: set by the fidelity level.
pub(crate) const RESOLUTION_KEY: &str = "camera.resolution";

impl TuneSpec {
    /// Validates `[tune]`; errors point at its keys in the experiment file.
    pub(crate) fn from_file(source: &Source, file: &TuneFile) -> anyhow::Result<Self> {
        let err = |key: &str, msg: String| source.error(&format!("tune.{key}"), msg);
        let objective = objective(&file.objective).map_err(|m| err("objective", m))?;
        let budget = budget(&file.budget).map_err(|m| err("budget", m))?;
        anyhow::ensure!(
            (0.0..=1.0).contains(&file.random_fraction),
            err(
                "random_fraction",
                format!(
                    "`random_fraction` = {}: expected a share in 0..=1",
                    file.random_fraction
                )
            )
        );
        let mut time_budgets = file.time_budgets.clone();
        if let Some(t) = time_budgets.iter().find(|t| !(t.is_finite() && **t > 0.0)) {
            return Err(err(
                "time_budgets",
                format!("`time_budgets` holds {t}: expected seconds > 0"),
            ));
        }
        time_budgets.sort_by(f64::total_cmp);
        time_budgets.dedup();
        let max_seconds = file.constraints.seconds_per_frame;
        if let Some(s) = max_seconds.filter(|s| !(s.is_finite() && *s > 0.0)) {
            return Err(err(
                "constraints",
                format!("`seconds_per_frame` = {s}: expected seconds > 0"),
            ));
        }
        Ok(TuneSpec {
            seed: file.seed,
            objective,
            budget,
            proposal: file.proposal,
            random_fraction: file.random_fraction,
            time_budgets,
            fidelity: fidelity(&file.fidelity).map_err(|m| err("fidelity", m))?,
            space: space(source, &file.space)?,
            max_seconds,
        })
    }

    /// The keys a tune cell sets besides its context: the searched keys, the resolution
    /// and (when scaled or searched) the photon count.
    pub(crate) fn axis_keys(&self) -> Vec<String> {
        let mut keys: Vec<String> = self.space.iter().map(|p| p.key.clone()).collect();
        keys.push(RESOLUTION_KEY.into());
        if self.scales_photons() && !keys.iter().any(|k| k == PHOTONS_KEY) {
            keys.push(PHOTONS_KEY.into());
        }
        keys
    }

    /// Whether lower levels trace fewer photons.
    pub(crate) fn scales_photons(&self) -> bool {
        self.fidelity.min_photon_fraction < 1.0
    }
}

/// `budget = { renders = 60 }` or `{ seconds = 3600 }`.
fn budget(file: &BudgetFile) -> Result<Budget, String> {
    match (file.renders, file.seconds) {
        (Some(n), None) if (1..=MAX_RENDERS).contains(&n) => Ok(Budget::Renders(n)),
        (Some(n), None) => Err(format!(
            "`budget` = {{ renders = {n} }}: expected renders in 1..={MAX_RENDERS}"
        )),
        (None, Some(s)) if s.is_finite() && s > 0.0 => Ok(Budget::Seconds(s)),
        _ => Err(format!(
            "`budget`: expected exactly one of `renders` (an integer in 1..={MAX_RENDERS}) or `seconds` (> 0), e.g. {{ renders = 60 }}"
        )),
    }
}

/// `objective = "rmse"` or `{ rmse = 1.0, flip = 0.5 }`.
fn objective(value: &Value) -> Result<Vec<(Metric, f64)>, String> {
    let names = Metric::ALL.map(Metric::key).join(", ");
    let metric = |name: &str| {
        Metric::parse(name)
            .ok_or_else(|| format!("`objective`: unknown metric `{name}`; expected one of {names}"))
    };
    match value {
        Value::String(s) => Ok(vec![(metric(s)?, 1.0)]),
        Value::Table(t) if !t.is_empty() => t
            .iter()
            .map(|(k, w)| {
                let w = w.as_float().or_else(|| w.as_integer().map(|i| i as f64));
                match w {
                    Some(w) if w.is_finite() && w > 0.0 => Ok((metric(k)?, w)),
                    _ => Err(format!(
                        "`objective.{k}`: expected a weight > 0, e.g. {{ {k} = 1.0 }}"
                    )),
                }
            })
            .collect(),
        other => Err(format!(
            "`objective` = {other}: expected a metric name ({names}) or a table of weights, e.g. {{ rmse = 1.0, flip = 0.5 }}"
        )),
    }
}

fn fidelity(f: &FidelityFile) -> Result<Fidelity, String> {
    let min = f.min_resolution.unwrap_or(f.resolution);
    let ok = |r: [u32; 2]| r.iter().all(|n| (1..=16384).contains(n));
    if !ok(f.resolution) || !ok(min) || min[0] > f.resolution[0] || min[1] > f.resolution[1] {
        return Err(format!(
            "`resolution` = {:?}, `min_resolution` = {min:?}: expected sizes in 1..=16384 with min_resolution no larger than resolution",
            f.resolution
        ));
    }
    if !(f.min_photon_fraction > 0.0 && f.min_photon_fraction <= 1.0) {
        return Err(format!(
            "`min_photon_fraction` = {}: expected a fraction in (0, 1]",
            f.min_photon_fraction
        ));
    }
    if !(1..=MAX_LEVELS).contains(&f.levels) || !(2..=8).contains(&f.eta) {
        return Err(format!(
            "`levels` = {}, `eta` = {}: expected levels in 1..={MAX_LEVELS} and eta in 2..=8",
            f.levels, f.eta
        ));
    }
    Ok(Fidelity {
        resolution: f.resolution,
        min_resolution: min,
        min_photon_fraction: f.min_photon_fraction,
        levels: f.levels,
        eta: f.eta,
    })
}

/// `[tune.space]`: every key's kind and range.
fn space(source: &Source, table: &Table) -> anyhow::Result<Vec<Param>> {
    let mut flat = Vec::new();
    flatten_space(table, "", &mut flat);
    let mut params = Vec::new();
    for (key, value) in flat {
        scene_key(&key).map_err(|m| source.error(&format!("tune.space.{key}"), m))?;
        let kind = param_kind(&value)
            .map_err(|m| source.error(&format!("tune.space.{key}"), format!("`{key}`: {m}")))?;
        if key == RESOLUTION_KEY || key == "scene" {
            return Err(source.error(
                &format!("tune.space.{key}"),
                format!("`{key}` cannot be searched: the resolution is the fidelity ([tune.fidelity]) and scenes are contexts ([axes])"),
            ));
        }
        params.push(Param { key, kind });
    }
    if params.is_empty() {
        return Err(source.error(
            "tune.space",
            "[tune.space] is empty: expected at least one key, e.g. \"integrator.nused\" = { int = [20, 1000], scale = \"log\" }",
        ));
    }
    Ok(params)
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct ParamFile {
    range: Option<[f64; 2]>,
    int: Option<[i64; 2]>,
    choices: Option<Vec<Value>>,
    #[serde(default)]
    scale: Scale,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize)]
#[serde(rename_all = "kebab-case")]
enum Scale {
    #[default]
    Linear,
    Log,
}

fn param_kind(value: &Value) -> Result<ParamKind, String> {
    let expected = "expected { range = [lo, hi] }, { int = [lo, hi] } (either with scale = \"log\") or { choices = [a, b, …] }";
    let file: ParamFile = value
        .clone()
        .try_into()
        .map_err(|e: toml::de::Error| format!("{}; {expected}", e.message().trim()))?;
    let log = file.scale == Scale::Log;
    match (file.range, file.int, file.choices) {
        (Some([lo, hi]), None, None) => {
            if !(lo.is_finite() && hi.is_finite() && lo < hi && (!log || lo > 0.0)) {
                return Err(format!(
                    "range [{lo}, {hi}]: expected finite lo < hi{}",
                    if log {
                        " with lo > 0 for scale = \"log\""
                    } else {
                        ""
                    }
                ));
            }
            Ok(ParamKind::Float { lo, hi, log })
        }
        (None, Some([lo, hi]), None) => {
            if !(lo < hi && (!log || lo > 0)) {
                return Err(format!(
                    "int [{lo}, {hi}]: expected lo < hi{}",
                    if log {
                        " with lo > 0 for scale = \"log\""
                    } else {
                        ""
                    }
                ));
            }
            Ok(ParamKind::Int { lo, hi, log })
        }
        (None, None, Some(c)) => {
            if c.len() < 2 || log {
                return Err(format!(
                    "choices: expected at least two values and no scale (got {} value(s))",
                    c.len()
                ));
            }
            Ok(ParamKind::Choice(c))
        }
        _ => Err(expected.to_string()),
    }
}
