//! Experiment files → cells: the base scene, `[set]` overrides, axes (lists and ranges),
//! zipped axes, excluded combinations and quality presets expand into validated cells;
//! reference, comparison, plot and sheet blocks are checked against the axes. Every error
//! points at the line and column of the experiment file.
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

mod axes;
mod cells;
mod checks;
mod file;
#[cfg(test)]
mod fuzz;
mod keys;
mod kind;
mod reference;
mod source;
mod tune;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use anyhow::Result;
use toml::{Table, Value};
use volphot::{Method, toml_error};

use axes::Dimension;
use file::{ExperimentFile, QualityPreset};

pub(crate) use cells::CellSpec;
pub(crate) use file::{
    CompareKind, CompareSpec, PairSpec, PlotSpec, ReferenceMethod, ReferenceSpec, ReportSpec,
    SheetLayer, SheetSpec,
};
pub(crate) use keys::{flatten_set, flatten_space, short_key, toml_to_json, value_text};
pub(crate) use kind::load_scene;
pub(crate) use reference::{reference_key, reference_params};
pub(crate) use source::Source;
pub(crate) use tune::Metric;
pub(crate) use tune::{
    Budget, Fidelity, PHOTONS_KEY, Param, ParamKind, Proposal, RESOLUTION_KEY, TuneFile, TuneSpec,
};

use crate::store::{PlanRecord, PlannedCell, VERSION, cell_hash};

/// The most cells one run plans (each is validated and hashed, and `plan.json` lists them).
pub(crate) const MAX_PLANNED_CELLS: usize = 1_000_000;

/// Quality presets that scale resolution and photon counts without editing the file.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub(crate) enum Quality {
    /// A minute-scale look (`--quick`).
    Quick,
    /// The experiment file's own settings.
    #[default]
    Default,
    /// Thesis resolution (512²) and the full grid (`--paper`).
    Paper,
}

impl Quality {
    /// The name recorded in `plan.json`.
    pub(crate) fn name(self) -> &'static str {
        match self {
            Quality::Quick => "quick",
            Quality::Default => "default",
            Quality::Paper => "paper",
        }
    }

    /// The quality `name` names (as recorded in `plan.json`).
    pub(crate) fn from_name(name: &str) -> Option<Quality> {
        [Quality::Quick, Quality::Default, Quality::Paper]
            .into_iter()
            .find(|q| q.name() == name)
    }

    /// The command-line flag that selects this quality, with a leading space (none for
    /// the default): the cells differ by quality, so a rerun must repeat it.
    pub(crate) fn flag(self) -> &'static str {
        match self {
            Quality::Quick => " --quick",
            Quality::Default => "",
            Quality::Paper => " --paper",
        }
    }
}

#[derive(Debug, Clone)]
enum BaseScene {
    File(PathBuf),
    Inline(Table),
}

/// A parsed and checked experiment file.
#[derive(Debug, Clone)]
pub(crate) struct Experiment {
    /// Name (file stem unless given).
    pub(crate) name: String,
    /// Free text.
    pub(crate) description: String,
    /// The file and its text (for located errors and the copy in the output folder).
    pub(crate) source: Source,
    /// sha256 of the file.
    pub(crate) sha256: String,
    /// Grid-size limit that requires `--yes`.
    pub(crate) max_cells: usize,
    /// Share photon maps and marches between cells.
    pub(crate) share: bool,
    /// Ground-truth configuration.
    pub(crate) reference: Option<ReferenceSpec>,
    /// Image comparisons.
    pub(crate) compare: Vec<CompareSpec>,
    /// Plot specifications (empty: automatic).
    pub(crate) plots: Vec<PlotSpec>,
    /// Contact sheets (empty: automatic).
    pub(crate) sheets: Vec<SheetSpec>,
    /// The `[tune]` section: its `[axes]` grid are the contexts every configuration is
    /// evaluated on.
    pub(crate) tune: Option<TuneSpec>,
    /// How the report is written (`[report]`).
    pub(crate) report: ReportSpec,
    base: BaseScene,
    set: Vec<(String, Value)>,
    dimensions: Vec<Dimension>,
    exclude: Vec<Vec<(String, Value)>>,
    quality: BTreeMap<String, QualityPreset>,
}

/// The `[tune]` section, checked against the reference it measures errors by.
fn checked_tune(source: &Source, file: &ExperimentFile) -> Result<Option<TuneSpec>> {
    let Some(t) = &file.tune else {
        return Ok(None);
    };
    let tune = TuneSpec::from_file(source, t)?;
    let Some(reference) = &file.reference else {
        return Err(source.error(
            "tune",
            "[tune] needs a [reference] section: the objective measures errors against it (e.g. [reference] method = \"path\", spp = 256)",
        ));
    };
    if reference.method != ReferenceMethod::Path
        && tune
            .objective
            .iter()
            .any(|(m, _)| *m == Metric::RmseCorrected)
    {
        return Err(source.error(
            "tune.objective",
            "`rmse_corrected` removes the reference's noise, which only a path-traced reference measures: use [reference] method = \"path\", or objective = \"rmse\"",
        ));
    }
    Ok(Some(tune))
}

impl Experiment {
    /// Reads and checks an experiment file: parse → base scene → axes and zips → exclude
    /// rules → quality presets → reference → comparisons → plots and sheets.
    pub(crate) fn load(path: &Path) -> Result<Self> {
        let text = volphot::read_text_capped(path, volphot::TEXT_INPUT_CAP, "experiment file")?;
        let file: ExperimentFile = toml::from_str(&text).map_err(|e| {
            kind::scene_given_for_experiment(path, &text)
                .unwrap_or_else(|| anyhow::anyhow!(toml_error(&e, &text, path)))
        })?;
        let source = Source {
            path: path.to_path_buf(),
            text,
        };
        let name = experiment_name(&source, &file)?;
        checks::scene_keys(&source, &file)?;
        let base = base_scene(&source, &file)?;
        let mut set = Vec::new();
        flatten_set(&file.set, "", &mut set);
        let dimensions = axes::dimensions(&source, &file.axes, &file.zip)?;
        let exclude: Vec<Vec<(String, Value)>> = file
            .exclude
            .iter()
            .map(|t| {
                let mut rule = Vec::new();
                flatten_set(t, "", &mut rule);
                rule
            })
            .collect();
        let axis_names = checks::AxisNames::new(&source, &dimensions);
        for (ei, rule) in exclude.iter().enumerate() {
            axis_names.require("exclude", ei, rule.iter().map(|(k, _)| k))?;
        }
        checks::quality_presets(&source, &file.quality)?;
        checks::reference(&source, file.reference.as_ref())?;
        checks::compare(&axis_names, &file.compare, file.reference.is_some())?;
        checks::figures(&axis_names, &file.plots, &file.sheets)?;
        if file.report.explorer_max_side == Some(0) {
            return Err(source.error(
                "report.explorer_max_side",
                "`report.explorer_max_side` = 0: expected at least 1 pixel; leave it out for the full resolution",
            ));
        }
        let tune = checked_tune(&source, &file)?;
        let tuned = tune.as_ref().map(TuneSpec::axis_keys).unwrap_or_default();
        checks::pair(&axis_names.with(&tuned), file.report.pair.as_ref())?;
        Ok(Experiment {
            name,
            description: file.description,
            sha256: volphot::sha256_bytes(source.text.as_bytes()),
            source,
            max_cells: file.max_cells,
            // A tune renders each cell alone, so its recorded time is its own.
            share: file.share && tune.is_none(),
            reference: file.reference,
            compare: file.compare,
            plots: file.plots,
            sheets: file.sheets,
            tune,
            report: file.report,
            base,
            set,
            dimensions,
            exclude,
            quality: file.quality,
        })
    }

    /// The experiment file.
    pub(crate) fn path(&self) -> &Path {
        &self.source.path
    }

    /// What the store checks an output folder's owner by.
    pub(crate) fn owner(&self) -> crate::store::Owner<'_> {
        crate::store::Owner {
            name: &self.name,
            path: &self.source.path,
            sha256: &self.sha256,
        }
    }

    /// The folder holding the experiment file (base for relative paths).
    pub(crate) fn base_dir(&self) -> PathBuf {
        self.source
            .path
            .parent()
            .map(Path::to_path_buf)
            .unwrap_or_else(|| PathBuf::from("."))
    }

    /// Axis keys in grid order (a tune's cells add the searched and fidelity keys).
    pub(crate) fn axis_keys(&self, quality: Quality) -> Vec<String> {
        let mut keys: Vec<String> = self
            .dimensions_for(quality)
            .map(|d| d.iter().flat_map(|d| d.keys.clone()).collect())
            .unwrap_or_default();
        if let Some(tune) = &self.tune {
            keys.extend(tune.axis_keys());
        }
        keys
    }

    fn preset(&self, quality: Quality) -> Option<&QualityPreset> {
        match quality {
            Quality::Quick => self.quality.get("quick"),
            Quality::Paper => self.quality.get("paper"),
            Quality::Default => None,
        }
    }

    /// The cells of the grid with their content addresses. The grid's size is checked
    /// before any cell is built: at most `max_cells` cells unless `yes`, and never more
    /// than [`MAX_PLANNED_CELLS`]; two cells of one address are refused.
    pub(crate) fn plan_with_hashes(
        &self,
        quality: Quality,
        yes: bool,
    ) -> Result<(Vec<CellSpec>, Vec<String>)> {
        let size = self.grid_size(quality)?;
        anyhow::ensure!(
            size <= MAX_PLANNED_CELLS,
            "{}: the grid has {size} cells, more than the {MAX_PLANNED_CELLS} a run can plan; split the study into several experiments",
            self.path().display()
        );
        anyhow::ensure!(
            size <= self.max_cells || yes,
            "{}: the grid has {size} cells, more than max_cells = {}; check it with `sweep plan {}` and pass --yes to run it",
            self.path().display(),
            self.max_cells,
            self.path().display()
        );
        let cells = self.plan(quality)?;
        self.refuse_ignored_axes(quality, &cells)?;
        let hashes = cells
            .iter()
            .map(|c| cell_hash(&c.params, &c.base_dir))
            .collect::<Result<Vec<_>>>()?;
        self.distinct_scenes(quality, &cells, &hashes)?;
        Ok((cells, hashes))
    }

    /// Whether every cell ignores the `[integrator]` key of `key` (`integrator.eye_rays` →
    /// `eye_rays`; [`volphot::SceneParams::ignored_integrator_keys`]).
    fn ignored_by_every_cell(cells: &[CellSpec], key: &str) -> bool {
        key.strip_prefix("integrator.").is_some_and(|k| {
            !cells.is_empty()
                && cells
                    .iter()
                    .all(|c| c.params.ignored_integrator_keys().contains(&k))
        })
    }

    /// Why the cells ignore `key`: the first cell's lights (for `light_samples`), its
    /// estimator, or no multiple scattering.
    fn why_ignored(cells: &[CellSpec], key: &str) -> String {
        let p = &cells[0].params;
        let i = &p.integrator;
        if key == "integrator.light_samples" {
            if !i.single {
                "with single = false".to_string()
            } else {
                "every light is a spot or point light, which is evaluated, never sampled"
                    .to_string()
            }
        } else if !i.multiple {
            "with multiple = false".to_string()
        } else {
            format!(
                "with estimator = {:?}",
                format!("{:?}", i.estimator).to_lowercase()
            )
        }
    }

    /// An axis that no cell reads is an error: its values would render one image under as
    /// many addresses, and the report would read timing noise as its effect.
    fn refuse_ignored_axes(&self, quality: Quality, cells: &[CellSpec]) -> Result<()> {
        // A search's base grid is all point estimates; its proposals set the rest.
        if self.tune.is_some() || cells.is_empty() {
            return Ok(());
        }
        for key in self.axis_keys(quality) {
            if Self::ignored_by_every_cell(cells, &key) {
                return Err(self.source.error(
                    &key,
                    format!(
                        "`{key}` is an axis, but no cell reads it ({}): its values would render the same image under as many addresses; sweep it where it is read ({}) or drop the axis",
                        Self::why_ignored(cells, &key),
                        if key == "integrator.light_samples" {
                            "area, environment or sky lights, single = true"
                        } else {
                            "progressive, beam or plane estimators, multiple = true"
                        }
                    ),
                ));
            }
        }
        Ok(())
    }

    /// The `[set]` keys no cell reads, as warnings: they change nothing.
    pub(crate) fn ignored_settings(
        &self,
        quality: Quality,
        cells: &[CellSpec],
    ) -> Result<Vec<String>> {
        if self.tune.is_some() || cells.is_empty() {
            return Ok(Vec::new());
        }
        let mut set = self.set.clone();
        if let Some(preset) = self.preset(quality) {
            keys::flatten_set(&preset.set, "", &mut set);
        }
        Ok(set
            .iter()
            .filter(|(key, _)| Self::ignored_by_every_cell(cells, key))
            .map(|(key, _)| {
                format!(
                    "`{key}` is set, but no cell reads it ({}): it changes nothing",
                    Self::why_ignored(cells, key)
                )
            })
            .collect())
    }

    /// The record of a plan (`plan.json`): cells, hashes, references and march keys.
    pub(crate) fn plan_record(
        &self,
        cells: &[CellSpec],
        hashes: &[String],
        quality: Quality,
    ) -> Result<PlanRecord> {
        let mut planned = Vec::new();
        for (spec, hash) in cells.iter().zip(hashes) {
            let reference = self
                .reference
                .as_ref()
                .map(|r| reference_key(spec, r))
                .transpose()?;
            planned.push(PlannedCell {
                index: spec.index,
                hash: hash.clone(),
                label: spec.label(),
                axes: spec
                    .axes
                    .iter()
                    .map(|(k, v)| (k.clone(), toml_to_json(v)))
                    .collect(),
                reference,
                march_key: volphot::sha256_bytes(volphot::march_key(&spec.params).as_bytes())[..12]
                    .to_string(),
                method: match spec.params.integrator.method {
                    Method::Photon => "photon".into(),
                    Method::Reference => "reference".into(),
                },
            });
        }
        Ok(PlanRecord {
            experiment: self.name.clone(),
            experiment_file: self.source.path.clone(),
            experiment_sha256: self.sha256.clone(),
            quality: quality.name().into(),
            command: crate::store::recorded_command(),
            version: VERSION.to_string(),
            axes: self.axis_keys(quality),
            cells: planned,
        })
    }
}

/// The experiment's name (the file stem unless given): a plain name, because it becomes the
/// default output folder `out/<name>/`.
fn experiment_name(source: &Source, file: &ExperimentFile) -> Result<String> {
    let (name, given) = match &file.name {
        Some(n) => (n.clone(), true),
        None => (
            source
                .path
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_default(),
            false,
        ),
    };
    let plain = !name.is_empty()
        && name.len() <= 100
        && name
            .chars()
            .next()
            .is_some_and(|c| c.is_ascii_alphanumeric())
        && name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || matches!(c, '-' | '_' | '.'));
    if plain {
        return Ok(name);
    }
    let expected = "a plain name of letters, digits, `-`, `_` and `.`, starting with a letter or digit (it names the output folder out/<name>/)";
    Err(if given {
        source.error("name", format!("`name` = {name:?}: expected {expected}"))
    } else {
        source.error(
            "name",
            format!(
                "the file name gives the experiment name {name:?}; add `name = \"…\"`: {expected}"
            ),
        )
    })
}

/// The base scene: a file, an inline table, or (with a `scene` axis) none.
fn base_scene(source: &Source, file: &ExperimentFile) -> Result<BaseScene> {
    match &file.scene {
        Some(Value::String(s)) => Ok(BaseScene::File(PathBuf::from(s))),
        Some(Value::Table(t)) => Ok(BaseScene::Inline(t.clone())),
        Some(other) => Err(source.error(
            "scene",
            format!("`scene` = {other}: expected a scene file path or an inline table"),
        )),
        None => {
            let mut axes = Vec::new();
            keys::flatten_axes(&file.axes, "", &mut axes);
            if !axes.iter().any(|(k, _)| k == "scene") {
                return Err(source.error(
                    "scene",
                    "missing `scene`: a base scene file, an inline [scene] table, or a `scene` axis",
                ));
            }
            Ok(BaseScene::Inline(Table::new()))
        }
    }
}

/// The default output folder: `out/<experiment name>/` (with a quality suffix). A run lands
/// beside the repository's committed studies, never on them: `reports/` is regenerated on
/// purpose (`scripts/reproduce.sh`), so running the main job leaves a clone's files as they
/// were.
pub(crate) fn default_output(exp: &Experiment, quality: Quality) -> std::path::PathBuf {
    let name = match quality {
        Quality::Default => exp.name.clone(),
        Quality::Quick => format!("{}-quick", exp.name),
        Quality::Paper => format!("{}-paper", exp.name),
    };
    std::path::Path::new("out").join(name)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
        let p = dir.join(name);
        std::fs::write(&p, text).unwrap();
        p
    }

    fn scene() -> String {
        format!(
            "{}[camera]\nresolution = [64, 64]\n",
            volphot::test_util::SMALL_SCENE
        )
    }

    #[test]
    fn product_zip_exclude_and_ranges() {
        let dir = tempfile::tempdir().unwrap();
        write(dir.path(), "s.toml", &scene());
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
        write(dir.path(), "s.toml", &scene());
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
            (
                "scene = \"s.toml\"\n[axes]\n\"../../integrator/nused\" = [5]\n",
                "e.toml:3",
                "`../../integrator/nused` is not a scene key",
            ),
            (
                "scene = \"s.toml\"\n[set]\n\"integrator..nused\" = 5\n",
                "e.toml:3",
                "`integrator..nused` is not a scene key",
            ),
            (
                "scene = \"s.toml\"\n[[zip]]\n\"sigma.t \" = [1, 2]\n\"integrator.nused\" = [5, 6]\n",
                "e.toml:3",
                "`sigma.t ` is not a scene key",
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

    /// Each case: the experiment (after `scene = "s.toml"` unless it names scenes on an
    /// axis), the quality planned, and what the error must say.
    #[test]
    fn repeated_values_and_identical_scenes_are_refused() {
        let dir = tempfile::tempdir().unwrap();
        write(dir.path(), "s.toml", &scene());
        write(dir.path(), "t.toml", &scene());
        let base = "scene = \"s.toml\"\n";
        let cases: [(String, Quality, &[&str]); 5] = [
            (
                format!("{base}[axes]\n\"integrator.nused\" = [25, 50, 25]\n"),
                Quality::Default,
                &["e.toml:3", "`integrator.nused`", "25", "positions 1 and 3"],
            ),
            (
                format!("{base}[axes]\n\"sigma.t\" = [80, 40, 80.0]\n"),
                Quality::Default,
                &["e.toml:3", "`sigma.t`", "80", "positions 1 and 3"],
            ),
            (
                format!(
                    "{base}[[zip]]\n\"sigma.t\" = [40, 80, 40]\n\"integrator.nused\" = [5, 6, 5]\n"
                ),
                Quality::Default,
                &["e.toml:", "zip[0]", "sigma.t = 40", "positions 1 and 3"],
            ),
            (
                format!(
                    "{base}[axes]\n\"integrator.nused\" = [5, 6]\n[quality.quick]\naxes = {{ \"integrator.nused\" = [10, 10] }}\n"
                ),
                Quality::Quick,
                &[
                    "e.toml:",
                    "quality",
                    "`integrator.nused`",
                    "10",
                    "positions 1 and 2",
                ],
            ),
            (
                "[axes]\nscene = [\"s.toml\", \"t.toml\"]\n\"integrator.nused\" = [5, 6]\n".into(),
                Quality::Default,
                &[
                    "e.toml:2",
                    "`scene`",
                    "s.toml",
                    "t.toml",
                    "positions 1 and 2",
                    "same scene",
                ],
            ),
        ];
        for (text, quality, expected) in &cases {
            let p = write(dir.path(), "e.toml", text);
            let err = Experiment::load(&p).and_then(|e| e.plan_with_hashes(*quality, true));
            let msg = format!(
                "{:#}",
                err.err().unwrap_or_else(|| panic!("accepted:\n{text}"))
            );
            for what in *expected {
                assert!(msg.contains(what), "`{msg}` lacks `{what}` for\n{text}");
            }
        }
        // Distinct files and values plan as before.
        let p = write(
            dir.path(),
            "e.toml",
            "[axes]\nscene = [\"s.toml\"]\n\"integrator.nused\" = [5, 6]\n",
        );
        let (cells, _) = Experiment::load(&p)
            .unwrap()
            .plan_with_hashes(Quality::Default, true)
            .unwrap();
        assert_eq!(cells.len(), 2);
    }
}
