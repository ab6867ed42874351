//! Rendering the cells of a plan into an output folder.
//!
//! Work is shared where the renderer allows it without changing results:
//! * volumes and media are loaded once per run and shared by every cell that uses them;
//! * cells that differ only in multiple-scattering parameters (`volume_photons`, `nused`,
//!   `maxdist`, `free_path`, `estimate`, `multiple`) are rendered by ONE march that yields a
//!   film per cell — one eye-ray pass, one single-scattering layer, and per photon map one
//!   k-NN query per sample serving every `nused`/`maxdist`;
//! * cells that differ only in render-time parameters use one photon map.
//!
//! Each cell's folder is written under a temporary name and renamed when complete; a
//! rerun skips finished cells. A full run holds an exclusive lock on the output folder;
//! runs of selected cells (`--cells`, `--shard`, cluster tasks) hold a shared lock plus an
//! exclusive lock per cell, so they can work side by side.

use std::collections::HashMap;
use std::fs::File;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Instant;

use anyhow::{Context, Result};
use serde::{Deserialize, Serialize};
use volphot::film::{Film, Layer, write_png};
use volphot::integrator::{MsVariant, render_march};
use volphot::medium::Medium;
use volphot::photon_map::PhotonMap;
use volphot::render::{Provenance, build_photon_map, peak_memory_bytes};
use volphot::scene::{Scene, SceneParams, build_medium, load_volume};
use volphot::settings::Method;
use volphot::volume::Volume;
use volphot::volume::registry::SearchPath;

use crate::cells::{
    CellRecord, CellTimings, OutputDir, StagedDir, VERSION, cell_hash, clean_stale, is_done,
    volume_identity, write_record,
};
use crate::cli::Quality;
use crate::experiment::{CellSpec, Experiment, ReferenceSpec, set_key};
use crate::metrics;

/// Environment switch for tests: cell indices (comma-separated) whose rendering fails on
/// purpose, to exercise failure reporting and resubmission.
pub const FAIL_CELLS_ENV: &str = "VOLPHOT_FAIL_CELLS";

/// One planned cell as recorded in `plan.json`.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct PlannedCell {
    /// Index in the plan.
    pub index: usize,
    /// Content address.
    pub hash: String,
    /// `key = value, …`.
    pub label: String,
    /// Axis values.
    pub axes: Vec<(String, serde_json::Value)>,
    /// Reference key, when the experiment has a reference.
    pub reference: Option<String>,
    /// Key of the march this cell shares (cells with equal keys render together).
    pub march_key: String,
    /// Rendering method.
    pub method: String,
}

/// `plan.json`: everything `sweep report` and `sweep status` need to know about a run.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct PlanRecord {
    /// Experiment name.
    pub experiment: String,
    /// The experiment file as given.
    pub experiment_file: PathBuf,
    /// Its sha256.
    pub experiment_sha256: String,
    /// Quality preset.
    pub quality: String,
    /// The command line.
    pub command: Vec<String>,
    /// Program version.
    pub version: String,
    /// Axis keys in grid order.
    pub axes: Vec<String>,
    /// The cells.
    pub cells: Vec<PlannedCell>,
}

/// Options of a run.
#[derive(Debug, Clone)]
pub struct RunOptions {
    /// Output folder.
    pub output: PathBuf,
    /// Only these plan indices (None = all).
    pub selection: Option<Vec<usize>>,
    /// Groups rendered at once.
    pub jobs: usize,
    /// Hide progress bars.
    pub quiet: bool,
}

/// What a run did.
#[derive(Debug, Clone, Default)]
pub struct RunSummary {
    /// Cells in the plan.
    pub planned: usize,
    /// Cells selected for this run.
    pub selected: usize,
    /// Cells already finished before the run.
    pub skipped: usize,
    /// Cells rendered now.
    pub rendered: usize,
    /// Cells that failed (with their errors).
    pub failed: Vec<(usize, String)>,
    /// Marches run (each produced one or more cells).
    pub marches: usize,
    /// Photon maps built.
    pub photon_maps: usize,
    /// References rendered or refined.
    pub references: usize,
    /// Wall-clock seconds.
    pub seconds: f64,
}

/// Converts a TOML value to JSON for records.
pub fn toml_to_json(v: &toml::Value) -> serde_json::Value {
    serde_json::to_value(v).unwrap_or(serde_json::Value::Null)
}

fn axes_json(spec: &CellSpec) -> Vec<(String, serde_json::Value)> {
    spec.axes
        .iter()
        .map(|(k, v)| (k.clone(), toml_to_json(v)))
        .collect()
}

/// Parameters that only change the multiple-scattering layer (cells differing only in
/// these share a march).
pub fn march_key(params: &SceneParams) -> String {
    let mut p = params.clone();
    p.integrator.volume_photons = 0;
    p.integrator.nused = 1;
    p.integrator.maxdist = 1.0;
    p.integrator.free_path = volphot::settings::FreePath::Delta;
    p.integrator.estimate = volphot::settings::Estimate::Masked;
    p.integrator.multiple = false;
    p.integrator.reference_spp = 1;
    serde_json::to_string(&p).expect("scene params serialise")
}

/// Parameters that determine a photon map.
fn photon_key(params: &SceneParams) -> String {
    let mut p = params.clone();
    let i = &mut p.integrator;
    i.nused = 1;
    i.maxdist = 1.0;
    i.estimate = volphot::settings::Estimate::Masked;
    i.multiple = true;
    i.single = true;
    i.emission = false;
    i.spp = 1;
    i.shadow = volphot::settings::ShadowEstimator::March;
    i.quadrature = volphot::settings::Quadrature::Exact;
    i.termination = 0.0;
    i.shadow_cache = 0;
    i.ms_cache = 0;
    i.reference_spp = 1;
    p.camera.resolution = [1, 1];
    p.camera.fov = 1.0;
    p.film = Default::default();
    serde_json::to_string(&p).expect("scene params serialise")
}

/// The scene a reference renders: the cell's physics (volume, transfer function, σ,
/// camera, lights) with the reference's own integrator settings — none of the cell's — so
/// every cell with the same physics shares one reference. It renders every layer; a
/// comparison picks the layers the cell shows.
pub fn reference_params(params: &SceneParams, spec: &ReferenceSpec) -> Result<SceneParams> {
    let mut p = params.clone();
    let mut integrator = volphot::settings::IntegratorParams {
        single: true,
        multiple: true,
        emission: true,
        // Independent noise: a seed no cell uses by default.
        seed: 0x005e_ed0f_5eed,
        ..Default::default()
    };
    match spec.method.as_str() {
        "path" => {
            integrator.method = Method::Reference;
            integrator.reference_spp = spec.spp;
        }
        _ => {
            integrator.method = Method::Photon;
            if let Some(n) = spec.volume_photons {
                integrator.volume_photons = n;
            }
            if let Some(n) = spec.nused {
                integrator.nused = n;
            }
        }
    }
    p.integrator = integrator;
    let mut table = toml::Table::try_from(&p).context("serialising scene")?;
    let mut set = Vec::new();
    crate::experiment::flatten_set(&spec.set, "", &mut set);
    for (k, v) in set {
        set_key(&mut table, &k, v).map_err(anyhow::Error::msg)?;
    }
    let text = toml::to_string(&table)?;
    let p: SceneParams =
        toml::from_str(&text).map_err(|e| anyhow::anyhow!("reference scene: {}", e.message()))?;
    volphot::scene::validate_params(&p).map_err(|e| anyhow::anyhow!("reference scene: {e}"))?;
    Ok(p)
}

/// The content address of a cell's reference: physics + reference settings (not its spp,
/// so a reference can be refined in place).
pub fn reference_key(spec: &CellSpec, reference: &ReferenceSpec) -> Result<String> {
    let mut p = reference_params(&spec.params, reference)?;
    p.integrator.reference_spp = 1;
    let text = format!(
        "volphot-reference {VERSION}\n{}\n{}",
        serde_json::to_string(&p)?,
        volume_identity(&spec.params, &spec.base_dir)?
    );
    Ok(volphot::checksum::sha256_bytes(text.as_bytes())[..16].to_string())
}

/// Parses `3,7-9` into indices.
pub fn parse_selection(text: &str, planned: usize) -> Result<Vec<usize>> {
    let mut out = Vec::new();
    for part in text.split(',').map(str::trim).filter(|p| !p.is_empty()) {
        let (a, b) = match part.split_once('-') {
            Some((a, b)) => (a.trim(), b.trim()),
            None => (part, part),
        };
        let parse = |s: &str| -> Result<usize> {
            s.parse::<usize>().map_err(|_| {
                anyhow::anyhow!("--cells `{text}`: `{s}` is not a cell index (expected e.g. 3,7-9)")
            })
        };
        let (a, b) = (parse(a)?, parse(b)?);
        anyhow::ensure!(a <= b, "--cells `{text}`: range {a}-{b} is reversed");
        anyhow::ensure!(
            b < planned,
            "--cells `{text}`: cell {b} does not exist (the plan has cells 0-{})",
            planned.saturating_sub(1)
        );
        out.extend(a..=b);
    }
    anyhow::ensure!(!out.is_empty(), "--cells `{text}`: no cells selected");
    out.sort_unstable();
    out.dedup();
    Ok(out)
}

/// Parses `i/n` into the plan indices of shard `i` (0-based) of `n`.
pub fn parse_shard(text: &str, planned: usize) -> Result<Vec<usize>> {
    let (i, n) = text
        .split_once('/')
        .and_then(|(i, n)| {
            Some((
                i.trim().parse::<usize>().ok()?,
                n.trim().parse::<usize>().ok()?,
            ))
        })
        .ok_or_else(|| anyhow::anyhow!("--shard `{text}`: expected i/n, e.g. 2/8"))?;
    anyhow::ensure!(n >= 1 && i < n, "--shard `{text}`: need 0 <= i < n");
    Ok((0..planned).filter(|c| c % n == i).collect())
}

/// Holds the output folder's lock for the duration of a run.
pub struct FolderLock {
    _file: File,
}

/// Locks the output folder: exclusively for a full run, shared for a run of selected cells.
pub fn lock_folder(out: &OutputDir, exclusive: bool) -> Result<FolderLock> {
    std::fs::create_dir_all(out.root())
        .with_context(|| format!("creating {}", out.root().display()))?;
    let path = out.root().join(".lock");
    let file = File::options()
        .create(true)
        .truncate(false)
        .write(true)
        .open(&path)
        .with_context(|| format!("opening {}", path.display()))?;
    let result = if exclusive {
        file.try_lock()
    } else {
        file.try_lock_shared()
    };
    match result {
        Ok(()) => Ok(FolderLock { _file: file }),
        Err(std::fs::TryLockError::WouldBlock) => anyhow::bail!(
            "{} is being written by another sweep run (lock {}); wait for it or choose another --output",
            out.root().display(),
            path.display()
        ),
        Err(std::fs::TryLockError::Error(e)) => {
            Err(e).with_context(|| format!("locking {}", path.display()))
        }
    }
}

/// Writes the plan record (idempotent: the same plan writes the same content).
pub fn write_plan(
    exp: &Experiment,
    cells: &[CellSpec],
    hashes: &[String],
    out: &OutputDir,
    quality: Quality,
) -> Result<PlanRecord> {
    let mut planned = Vec::new();
    for (spec, hash) in cells.iter().zip(hashes) {
        let reference = exp
            .reference
            .as_ref()
            .map(|r| reference_key(spec, r))
            .transpose()?;
        planned.push(PlannedCell {
            index: spec.index,
            hash: hash.clone(),
            label: spec.label(),
            axes: axes_json(spec),
            reference,
            march_key: volphot::checksum::sha256_bytes(march_key(&spec.params).as_bytes())[..12]
                .to_string(),
            method: match spec.params.integrator.method {
                Method::Photon => "photon".into(),
                Method::Reference => "reference".into(),
            },
        });
    }
    let record = PlanRecord {
        experiment: exp.name.clone(),
        experiment_file: exp.path.clone(),
        experiment_sha256: exp.sha256.clone(),
        quality: format!("{quality:?}").to_lowercase(),
        command: std::env::args().collect(),
        version: VERSION.to_string(),
        axes: exp.axis_keys(quality),
        cells: planned,
    };
    volphot::fsutil::write_atomic(&out.root().join("experiment.toml"), exp.source.as_bytes())?;
    volphot::fsutil::write_atomic(
        &out.plan(),
        serde_json::to_string_pretty(&record)?.as_bytes(),
    )?;
    Ok(record)
}

/// Reads `plan.json` of an output folder.
pub fn read_plan(out: &OutputDir) -> Result<PlanRecord> {
    let text = std::fs::read_to_string(out.plan()).with_context(|| {
        format!(
            "{}: no plan.json (is this the output folder of a sweep run?)",
            out.root().display()
        )
    })?;
    serde_json::from_str(&text).with_context(|| format!("parsing {}", out.plan().display()))
}

/// The cached value under `key`, or `make`'s, stored for the next caller. The lock is not
/// held while `make` runs (loading a volume takes seconds); two cells racing for the same
/// key both build it and the second insert wins, which is harmless.
fn cached<T>(
    cache: &Mutex<HashMap<String, Arc<T>>>,
    key: &str,
    make: impl FnOnce() -> Result<T>,
) -> Result<Arc<T>> {
    if let Some(v) = cache.lock().expect("cache lock").get(key) {
        return Ok(Arc::clone(v));
    }
    let v = Arc::new(make()?);
    cache
        .lock()
        .expect("cache lock")
        .insert(key.to_string(), Arc::clone(&v));
    Ok(v)
}

/// Loaded volumes and media, shared by every cell of a run.
#[derive(Default)]
struct Caches {
    volumes: Mutex<HashMap<String, Arc<Volume>>>,
    media: Mutex<HashMap<String, Arc<Medium>>>,
}

impl Caches {
    fn scene(&self, params: &SceneParams, base: &Path, search: &SearchPath) -> Result<Scene> {
        let volume_key = format!(
            "{}|{}",
            base.display(),
            serde_json::to_string(&params.volume)?
        );
        let volume = cached(&self.volumes, &volume_key, || {
            load_volume(&params.volume, base, search).map_err(Into::into)
        })?;
        let medium_key = format!(
            "{volume_key}|{}|{}|{}",
            serde_json::to_string(&params.transfer)?,
            serde_json::to_string(&params.sigma)?,
            serde_json::to_string(&params.phase)?
        );
        let medium = cached(&self.media, &medium_key, || {
            build_medium(params, &volume, base).map_err(Into::into)
        })?;
        Ok(Scene::assemble(params, medium, volume.source().clone())?)
    }
}

/// What rendering one march group produced.
#[derive(Default)]
struct GroupOutcome {
    rendered: usize,
    photon_maps: usize,
    failures: Vec<(usize, String)>,
}

/// A cell to render now.
struct Job {
    spec: CellSpec,
    hash: String,
    reference: Option<String>,
}

/// Renders the selected, unfinished cells of `cells` into `out`.
pub fn render_cells(
    exp: &Experiment,
    cells: &[CellSpec],
    hashes: &[String],
    plan: &PlanRecord,
    opts: &RunOptions,
) -> Result<RunSummary> {
    let start = Instant::now();
    let out = OutputDir::new(&opts.output);
    std::fs::create_dir_all(out.root().join("cells"))?;
    clean_stale(&out.root().join("cells"));
    clean_stale(&out.root().join("references"));
    let fail_on: Vec<usize> = std::env::var(FAIL_CELLS_ENV)
        .ok()
        .map(|v| v.split(',').filter_map(|s| s.trim().parse().ok()).collect())
        .unwrap_or_default();
    let selected: Vec<usize> = match &opts.selection {
        Some(s) => s.clone(),
        None => (0..cells.len()).collect(),
    };
    let mut summary = RunSummary {
        planned: cells.len(),
        selected: selected.len(),
        ..Default::default()
    };
    let mut jobs = Vec::new();
    for &i in &selected {
        let dir = out.cell(&hashes[i]);
        if is_done(&dir) {
            summary.skipped += 1;
            continue;
        }
        jobs.push(Job {
            spec: cells[i].clone(),
            hash: hashes[i].clone(),
            reference: plan.cells[i].reference.clone(),
        });
    }
    if jobs.is_empty() {
        summary.seconds = start.elapsed().as_secs_f64();
        return Ok(summary);
    }
    let search = SearchPath::from_env();
    let caches = Caches::default();
    let multi = crate::progress::multi(opts.quiet);
    let overall = crate::progress::bar(&multi, jobs.len() as u64, "cells", "cells");

    // References first: every cell's metrics need its reference.
    if let Some(spec) = &exp.reference {
        let mut needed: Vec<(&Job, String)> = Vec::new();
        for job in &jobs {
            if let Some(key) = &job.reference
                && !needed.iter().any(|(_, k)| k == key)
            {
                needed.push((job, key.clone()));
            }
        }
        for (job, key) in needed {
            if ensure_reference(&out, &key, &job.spec, spec, &caches, &search, &multi)? {
                summary.references += 1;
            }
        }
    }

    // Group cells that share a march.
    let mut groups: Vec<Vec<Job>> = Vec::new();
    for job in jobs {
        let key = march_key(&job.spec.params);
        let shareable = exp.share && job.spec.params.integrator.method == Method::Photon;
        match groups.iter_mut().find(|g| {
            shareable
                && exp.share
                && g[0].spec.params.integrator.method == Method::Photon
                && march_key(&g[0].spec.params) == key
        }) {
            Some(g) => g.push(job),
            None => groups.push(vec![job]),
        }
    }
    let next = AtomicUsize::new(0);
    let results: Mutex<Vec<GroupOutcome>> = Mutex::new(Vec::new());
    let render_group = |group: &[Job]| -> GroupOutcome {
        let bar = crate::progress::bar(
            &multi,
            group[0].spec.params.camera.resolution[1] as u64,
            &format!("cell {}", group[0].spec.index),
            "rows",
        );
        let outcome = render_group(group, &out, &caches, &search, &fail_on, &|rows| {
            bar.set_position(rows)
        });
        bar.finish_and_clear();
        multi.remove(&bar);
        let outcome = outcome.unwrap_or_else(|e| GroupOutcome {
            failures: group
                .iter()
                .map(|j| (j.spec.index, format!("{e:#}")))
                .collect(),
            ..Default::default()
        });
        for (index, message) in &outcome.failures {
            let job = group
                .iter()
                .find(|j| j.spec.index == *index)
                .expect("failed job is in its group");
            let text = format!(
                "cell {index} ({}) failed on {}:\n{message}\n",
                job.spec.label(),
                crate::cells::hostname()
            );
            let _ = volphot::fsutil::write_atomic(&out.failure(&job.hash), text.as_bytes());
            multi.suspend(|| eprintln!("cell {index} failed: {message}"));
        }
        overall.inc(group.len() as u64);
        outcome
    };
    std::thread::scope(|scope| {
        for _ in 0..opts.jobs.max(1).min(groups.len()) {
            scope.spawn(|| {
                loop {
                    let g = next.fetch_add(1, Ordering::Relaxed);
                    let Some(group) = groups.get(g) else {
                        break;
                    };
                    let r = render_group(group);
                    results.lock().expect("results lock").push(r);
                }
            });
        }
    });
    overall.finish_and_clear();
    for outcome in results.into_inner().expect("results lock") {
        summary.rendered += outcome.rendered;
        summary.photon_maps += outcome.photon_maps;
        summary.marches += usize::from(outcome.rendered > 0);
        summary.failed.extend(outcome.failures);
    }
    summary.failed.sort();
    summary.seconds = start.elapsed().as_secs_f64();
    Ok(summary)
}

/// Renders (or refines) a reference under its own lock; returns whether work was done.
fn ensure_reference(
    out: &OutputDir,
    key: &str,
    cell: &CellSpec,
    spec: &ReferenceSpec,
    caches: &Caches,
    search: &SearchPath,
    multi: &indicatif::MultiProgress,
) -> Result<bool> {
    let dir = out.reference(key);
    std::fs::create_dir_all(out.root().join("references"))?;
    let lock_path = out.root().join("references").join(format!("{key}.lock"));
    let lock = File::options()
        .create(true)
        .truncate(false)
        .write(true)
        .open(&lock_path)?;
    // Blocking: another task may be rendering this reference right now.
    lock.lock()
        .with_context(|| format!("locking {}", lock_path.display()))?;
    let params = reference_params(&cell.params, spec)?;
    let existing = read_reference_record(&dir).ok();
    let wanted = spec.spp;
    if let Some(r) = &existing
        && (spec.method != "path" || r.passes >= wanted)
    {
        return Ok(false);
    }
    let scene = caches.scene(&params, &cell.base_dir, search)?;
    let bar = crate::progress::bar(multi, scene.camera().height() as u64, "reference", "rows");
    let start = Instant::now();
    let (film, passes) = if spec.method == "path" {
        let mut acc = match &existing {
            Some(r) => volphot::reference::ReferenceAccumulator::from_film(
                &Film::read_exr(&dir.join("reference.exr"))?,
                r.passes,
            )?,
            None => volphot::reference::ReferenceAccumulator::new(
                scene.camera().width() as usize,
                scene.camera().height() as usize,
            ),
        };
        let more = wanted - acc.passes();
        acc.add_passes(&scene, more, &|rows| bar.set_position(rows))?;
        (acc.film(), acc.passes())
    } else {
        let out = volphot::render::render(&scene, &|rows| bar.set_position(rows))?;
        (out.film, 0)
    };
    bar.finish_and_clear();
    multi.remove(&bar);
    anyhow::ensure!(film.is_finite(), "reference {key} has non-finite pixels");
    let staged = StagedDir::new(&dir)?;
    film.write_exr(&staged.path().join("reference.exr"))?;
    let (w, h) = (film.width(), film.height());
    write_png(
        &staged.path().join("reference.png"),
        w,
        h,
        &film.total(),
        params.film.exposure,
    )?;
    let record = ReferenceRecord {
        key: key.to_string(),
        method: spec.method.clone(),
        passes,
        seconds: start.elapsed().as_secs_f64() + existing.as_ref().map_or(0.0, |r| r.seconds),
        scene: params,
        volume: scene.volume_source().clone(),
        version: VERSION.to_string(),
    };
    volphot::fsutil::write_atomic(
        &staged.path().join("reference.json"),
        serde_json::to_string_pretty(&record)?.as_bytes(),
    )?;
    if dir.exists() {
        std::fs::remove_dir_all(&dir)?;
    }
    staged.commit()?;
    drop(lock);
    Ok(true)
}

/// `references/<key>/reference.json`.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct ReferenceRecord {
    /// Content address.
    pub key: String,
    /// `path` or `photon`.
    pub method: String,
    /// Path-tracer samples per pixel accumulated.
    pub passes: u32,
    /// Seconds spent on it in total.
    pub seconds: f64,
    /// The scene it rendered.
    pub scene: SceneParams,
    /// Volume provenance.
    pub volume: volphot::volume::VolumeSource,
    /// Program version.
    pub version: String,
}

/// Reads a reference's record.
pub fn read_reference_record(dir: &Path) -> Result<ReferenceRecord> {
    let path = dir.join("reference.json");
    let text =
        std::fs::read_to_string(&path).with_context(|| format!("reading {}", path.display()))?;
    Ok(serde_json::from_str(&text)?)
}

/// Renders one march group.
fn render_group(
    group: &[Job],
    out: &OutputDir,
    caches: &Caches,
    search: &SearchPath,
    fail_on: &[usize],
    progress: &(dyn Fn(u64) + Sync),
) -> Result<GroupOutcome> {
    let mut failures = Vec::new();
    // Per-cell locks: skip cells another process is rendering right now.
    let mut jobs: Vec<(&Job, File)> = Vec::new();
    for job in group {
        if fail_on.contains(&job.spec.index) {
            failures.push((
                job.spec.index,
                format!("failure injected by {FAIL_CELLS_ENV}"),
            ));
            continue;
        }
        let dir = out.cell(&job.hash);
        let lock_path = out.root().join("cells").join(format!(".{}.lock", job.hash));
        let lock = File::options()
            .create(true)
            .truncate(false)
            .write(true)
            .open(&lock_path)?;
        if lock.try_lock().is_err() || is_done(&dir) {
            continue;
        }
        jobs.push((job, lock));
    }
    if jobs.is_empty() {
        return Ok(GroupOutcome {
            failures,
            ..Default::default()
        });
    }
    let first = &jobs[0].0.spec;
    let method = first.params.integrator.method;
    // The group's scene: any cell's (they differ only in multiple-scattering settings),
    // with multiple scattering on when any cell wants it.
    let mut params = first.params.clone();
    params.integrator.multiple = jobs.iter().any(|(j, _)| j.spec.params.integrator.multiple);
    let scene = caches.scene(&params, &first.base_dir, search)?;
    let mut maps: Vec<(String, PhotonMap)> = Vec::new();
    let mut variants = Vec::new();
    let mut film_of = Vec::new();
    if method == Method::Photon {
        for (job, _) in &jobs {
            let p = &job.spec.params;
            if !p.integrator.multiple {
                film_of.push(None);
                continue;
            }
            let key = photon_key(p);
            let map_index = match maps.iter().position(|(k, _)| *k == key) {
                Some(i) => i,
                None => {
                    let s = scene.with_integrator(p.integrator.clone())?;
                    maps.push((key, build_photon_map(&s)));
                    maps.len() - 1
                }
            };
            film_of.push(Some(variants.len()));
            variants.push(MsVariant {
                map: map_index,
                nused: p.integrator.nused,
                maxdist: p.integrator.maxdist,
                estimate: p.integrator.estimate,
            });
        }
    }
    let (films, march_stats_seconds) = match method {
        Method::Photon => {
            let map_refs: Vec<&PhotonMap> = maps.iter().map(|(_, m)| m).collect();
            let out = render_march(&scene, &map_refs, &variants, progress)?;
            (out.films, out.stats.seconds)
        }
        Method::Reference => {
            let out = volphot::render::render(&scene, progress)?;
            (vec![out.film], out.record.timings.render)
        }
    };
    let mut rendered = 0;
    // The per-cell locks in `jobs` are held until the cells are written.
    for (k, (job, _lock)) in jobs.iter().enumerate() {
        let film = match (method, film_of.get(k).copied().flatten()) {
            (Method::Photon, Some(i)) => films[i].clone(),
            (Method::Photon, None) => {
                let mut f = films[0].clone();
                f.set_layer(
                    Layer::Multiple,
                    vec![glam::Vec3::ZERO; f.width() * f.height()],
                );
                f
            }
            (Method::Reference, _) => films[0].clone(),
        };
        let map = film_of
            .get(k)
            .copied()
            .flatten()
            .map(|i| &maps[variants[i].map].1);
        let map_shared_by = match film_of.get(k).copied().flatten() {
            Some(i) => variants.iter().filter(|v| v.map == variants[i].map).count(),
            None => 0,
        };
        let timings = CellTimings {
            photon_tracing: map.map_or(0.0, |m| m.stats().seconds),
            tree_build: map.map_or(0.0, |m| m.build_seconds()),
            render: march_stats_seconds,
            metrics: 0.0,
            march_shared_by: jobs.len(),
            map_shared_by,
        };
        match write_cell(
            job,
            &scene,
            &film,
            map.map(|m| m.stats().clone()),
            timings,
            out,
        ) {
            Ok(()) => rendered += 1,
            Err(e) => failures.push((job.spec.index, format!("{e:#}"))),
        }
    }
    Ok(GroupOutcome {
        rendered,
        photon_maps: maps.len(),
        failures,
    })
}

/// Writes a finished cell: film, PNGs, metrics, record.
fn write_cell(
    job: &Job,
    scene: &Scene,
    film: &Film,
    photons: Option<volphot::photon::PhotonStats>,
    mut timings: CellTimings,
    out: &OutputDir,
) -> Result<()> {
    anyhow::ensure!(
        film.is_finite(),
        "cell {} rendered non-finite pixels",
        job.spec.index
    );
    let p = &job.spec.params;
    let metrics_start = Instant::now();
    let disco = metrics::disco(film);
    let shown = metrics::displayed(film, p.integrator.multiple, p.integrator.emission);
    let image = metrics::image_stats(film, &shown, p.film.exposure);
    timings.metrics = metrics_start.elapsed().as_secs_f64();
    let staged = StagedDir::new(&out.cell(&job.hash))?;
    let dir = staged.path();
    let (w, h) = (film.width(), film.height());
    let exposure = p.film.exposure;
    film.write_exr(&dir.join("film.exr"))?;
    write_png(&dir.join("total.png"), w, h, &shown, exposure)?;
    write_png(
        &dir.join("single.png"),
        w,
        h,
        film.layer(Layer::Single),
        exposure,
    )?;
    write_png(
        &dir.join("multiple.png"),
        w,
        h,
        film.layer(Layer::Multiple),
        exposure,
    )?;
    let record = CellRecord {
        index: job.spec.index,
        hash: job.hash.clone(),
        label: job.spec.label(),
        axes: axes_json(&job.spec),
        provenance: Provenance::of(scene),
        photons,
        timings,
        peak_memory_bytes: peak_memory_bytes(),
        mean_single: film.mean(Layer::Single),
        mean_multiple: film.mean(Layer::Multiple),
        mean_emission: film.mean(Layer::Emission),
        disco,
        image,
        version: VERSION.to_string(),
        threads: rayon::current_num_threads(),
        host: crate::cells::hostname(),
    };
    write_record(dir, &record)?;
    staged.commit()?;
    let _ = std::fs::remove_file(out.failure(&job.hash));
    if let Some(key) = &job.reference {
        compute_reference_metrics(out, &job.hash, key, p, film)?;
    }
    Ok(())
}

/// Computes and stores `vs-<reference>.json` for a cell, if the reference exists. The
/// reference shows the same layers as the cell (single only for `multiple = false`).
pub fn compute_reference_metrics(
    out: &OutputDir,
    hash: &str,
    key: &str,
    params: &SceneParams,
    film: &Film,
) -> Result<()> {
    let ref_dir = out.reference(key);
    if read_reference_record(&ref_dir).is_err() {
        return Ok(());
    }
    let reference = Film::read_exr(&ref_dir.join("reference.exr"))?;
    let [w, h] = params.camera.resolution.map(|n| n as usize);
    anyhow::ensure!(
        reference.width() == w && reference.height() == h,
        "reference {key} is {}×{}, cell is {w}×{h}",
        reference.width(),
        reference.height()
    );
    let ref_img = metrics::displayed(
        &reference,
        params.integrator.multiple,
        params.integrator.emission,
    );
    let shown = metrics::displayed(film, params.integrator.multiple, params.integrator.emission);
    let mut m = metrics::compare(&shown, &ref_img, w, h, params.film.exposure, key);
    if params.integrator.multiple {
        let excess = metrics::disco_excess(film, &reference);
        m.disco_excess = excess.energy;
        m.disco_excess_blobs = excess.blobs;
    }
    volphot::fsutil::write_atomic(
        &out.cell(hash).join(format!("vs-{key}.json")),
        serde_json::to_string_pretty(&m)?.as_bytes(),
    )?;
    Ok(())
}

/// Plans an experiment and computes content addresses.
pub fn plan_with_hashes(
    exp: &Experiment,
    quality: Quality,
) -> Result<(Vec<CellSpec>, Vec<String>)> {
    let cells = exp.plan(quality)?;
    let hashes = cells.iter().map(cell_hash).collect::<Result<Vec<_>>>()?;
    Ok((cells, hashes))
}

/// The default output folder: `reports/<experiment name>/` (with a quality suffix).
pub fn default_output(exp: &Experiment, quality: Quality) -> PathBuf {
    let name = match quality {
        Quality::Default => exp.name.clone(),
        Quality::Quick => format!("{}-quick", exp.name),
        Quality::Paper => format!("{}-paper", exp.name),
    };
    Path::new("reports").join(name)
}
