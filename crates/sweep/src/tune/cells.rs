//! Configurations → cells (one per context, at a fidelity level), and finished cells →
//! the objective and the render time per frame predicted at the target resolution.

use std::collections::HashMap;

use anyhow::Result;
use toml::Value;
use volphot::Film;

use crate::analyse::{METRIC_COLUMNS, compare_with_reference};
use crate::plan::{CellSpec, Experiment, Quality, reference_key};
use crate::plan::{PHOTONS_KEY, RESOLUTION_KEY, TuneSpec};
use crate::store::{
    CellRecord, OutputDir, cell_hash, read_record, read_reference_metrics, read_reference_record,
};

/// The cells of a tune, in the order they were first needed (their plan indices).
pub(crate) struct TuneCells<'a> {
    exp: &'a Experiment,
    spec: &'a TuneSpec,
    /// The experiment's grid: every configuration is evaluated on each.
    pub(crate) contexts: Vec<CellSpec>,
    /// Every cell so far.
    pub(crate) cells: Vec<CellSpec>,
    /// Their content addresses.
    pub(crate) hashes: Vec<String>,
    by_hash: HashMap<String, usize>,
}

/// What one finished (or failed) cell says.
#[derive(Debug, Clone, Copy)]
pub(crate) struct CellResult {
    /// The objective (+∞ when the cell failed or a metric is missing).
    pub(crate) error: f64,
    /// Photon tracing + kd-tree + march seconds as recorded (0 when failed).
    pub(crate) seconds: f64,
    /// Those seconds predicted at the target level: the photon part divided by the
    /// level's photon fraction, the march part scaled by the pixel count.
    pub(crate) target_seconds: f64,
}

impl<'a> TuneCells<'a> {
    /// The contexts of a tune experiment (its `[axes]` grid; one cell without axes).
    pub(crate) fn new(exp: &'a Experiment, spec: &'a TuneSpec) -> Result<Self> {
        let (contexts, _) = exp.plan_with_hashes(Quality::Default, false)?;
        Ok(TuneCells {
            exp,
            spec,
            contexts,
            cells: Vec::new(),
            hashes: Vec::new(),
            by_hash: HashMap::new(),
        })
    }

    /// The axis values of a configuration on a context at a level: the context's, the
    /// searched keys', the resolution and (when scaled) the photon count.
    pub(crate) fn axes(&self, context: usize, values: &[f64], level: u32) -> Vec<(String, Value)> {
        let ctx = &self.contexts[context];
        let f = &self.spec.fidelity;
        let fraction = f.photon_fraction(level);
        let scaled = |photons: f64| Value::Integer((photons * fraction).round().max(1.0) as i64);
        let mut axes = ctx.axes.clone();
        for (p, &v) in self.spec.space.iter().zip(values) {
            let value = if p.key == PHOTONS_KEY {
                scaled(v)
            } else {
                p.value(v)
            };
            axes.push((p.key.clone(), value));
        }
        let [w, h] = f.resolution(level);
        axes.push((
            RESOLUTION_KEY.into(),
            Value::Array(vec![Value::from(i64::from(w)), Value::from(i64::from(h))]),
        ));
        if self.spec.scales_photons() && !self.spec.space.iter().any(|p| p.key == PHOTONS_KEY) {
            axes.push((
                PHOTONS_KEY.into(),
                scaled(ctx.params.integrator.volume_photons as f64),
            ));
        }
        axes
    }

    /// The plan index of a configuration's cell on a context at a level (added when new).
    pub(crate) fn cell(&mut self, context: usize, values: &[f64], level: u32) -> Result<usize> {
        let axes = self.axes(context, values, level);
        let spec = self.exp.cell(self.cells.len(), axes, Quality::Default)?;
        let hash = cell_hash(&spec.params, &spec.base_dir)?;
        if let Some(&i) = self.by_hash.get(&hash) {
            return Ok(i);
        }
        let i = self.cells.len();
        self.by_hash.insert(hash.clone(), i);
        self.cells.push(spec);
        self.hashes.push(hash);
        Ok(i)
    }

    /// The objective and the times of a cell.
    pub(crate) fn result(&self, out: &OutputDir, index: usize, level: u32) -> CellResult {
        let failed = CellResult {
            error: f64::INFINITY,
            seconds: 0.0,
            target_seconds: f64::INFINITY,
        };
        let dir = out.cell(&self.hashes[index]);
        let Ok(record) = read_record(&dir) else {
            return failed;
        };
        let t = &record.timings;
        let photon_part = t.photon_tracing + t.tree_build;
        let f = &self.spec.fidelity;
        let [w, h] = f.resolution(level);
        let [tw, th] = f.resolution;
        let pixels = f64::from(tw) * f64::from(th) / (f64::from(w) * f64::from(h));
        CellResult {
            error: self.objective(out, index, &record).unwrap_or(f64::INFINITY),
            seconds: photon_part + t.render,
            target_seconds: photon_part / f.photon_fraction(level) + t.render * pixels,
        }
    }

    /// The weighted sum of the objective's metric columns for a finished cell; its errors
    /// against the reference are computed now if the render did not store them.
    fn objective(&self, out: &OutputDir, index: usize, record: &CellRecord) -> Option<f64> {
        let reference = self.exp.reference.as_ref()?;
        let key = reference_key(&self.cells[index], reference).ok()?;
        let hash = &self.hashes[index];
        let dir = out.cell(hash);
        let passes = read_reference_record(&out.reference(&key))
            .ok()
            .map(|r| r.passes);
        let mut metrics = read_reference_metrics(&dir, &key, passes);
        if metrics.is_none() && passes.is_some() {
            let film = Film::read_exr(&dir.join("film.exr")).ok()?;
            compare_with_reference(out, hash, &key, &record.provenance.scene, &film).ok()?;
            metrics = read_reference_metrics(&dir, &key, passes);
        }
        let metrics = metrics?;
        let mut sum = 0.0;
        for (metric, weight) in &self.spec.objective {
            let column = METRIC_COLUMNS.iter().find(|c| c.key == metric.key())?;
            sum += weight * (column.value)(record, Some(&metrics))?;
        }
        sum.is_finite().then_some(sum)
    }

    /// The scene table of a configuration on a context at the target level (for the
    /// best-settings files).
    pub(crate) fn scene_table(&self, context: usize, values: &[f64]) -> Result<toml::Table> {
        let axes = self.axes(context, values, self.spec.fidelity.top());
        Ok(self.exp.cell_table(&axes, Quality::Default)?.0)
    }

    /// A short name of a context for file names (`foot`, `engine`, …; empty for one).
    pub(crate) fn context_name(&self, context: usize) -> String {
        if self.contexts.len() <= 1 {
            return String::new();
        }
        let ctx = &self.contexts[context];
        let parts: Vec<String> = ctx
            .axes
            .iter()
            .map(|(_, v)| {
                let text = crate::plan::value_text(v);
                match text.strip_suffix(".toml") {
                    Some(path) => path.rsplit('/').next().unwrap_or(path).to_string(),
                    None => text,
                }
            })
            .collect();
        parts
            .join("_")
            .chars()
            .map(|c| {
                if c.is_ascii_alphanumeric() || c == '.' {
                    c
                } else {
                    '-'
                }
            })
            .collect()
    }
}
