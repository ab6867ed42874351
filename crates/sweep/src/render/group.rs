//! One march group: cells that differ only in multiple-scattering settings, rendered by one
//! [`volphot::render_shared`] call and written in parallel, each cell in its own folder (film,
//! PNGs, record, metrics).

use anyhow::Result;
use glam::Vec3;
use rayon::prelude::*;
use volphot::{Film, Layer, Provenance, Scene, SearchPath, SharedFilm, SharedRender, write_png};

use super::job::{Job, non_finite};
use super::scenes::Caches;
use crate::analyse::{analyse_cell, compare_with_reference, displayed};
use crate::store::{
    CELL_FILES, CellLock, CellRecord, CellTimings, FileCheck, OutputDir, ReferencePool, StagedDir,
    VERSION, hostname, is_done, try_lock_cell, write_record,
};

/// Environment switch for tests: cell indices (comma-separated) whose rendering fails on
/// purpose, to exercise failure reporting and resubmission.
pub(crate) const FAIL_CELLS_ENV: &str = "VOLPHOT_FAIL_CELLS";

/// Environment switch for tests: cell indices whose rendering panics on purpose, to check
/// that a panic fails only its cells.
pub(crate) const PANIC_CELLS_ENV: &str = "VOLPHOT_PANIC_CELLS";

/// What rendering one march group produced.
#[derive(Default)]
pub(crate) struct GroupOutcome {
    pub(crate) rendered: usize,
    /// Cells another process was rendering (locked), left to it.
    pub(crate) busy: usize,
    /// Cells another process finished meanwhile.
    pub(crate) done_elsewhere: usize,
    pub(crate) photon_maps: usize,
    pub(crate) failures: Vec<(usize, String)>,
    /// What finished cells' settings cannot resolve.
    pub(crate) warnings: Vec<CellWarning>,
}

/// A warning of a finished cell (see `volphot::render_warnings`).
pub(crate) struct CellWarning {
    /// Plan index.
    pub(crate) index: usize,
    /// `key = value, …`.
    pub(crate) label: String,
    /// The warning.
    pub(crate) warning: volphot::RenderWarning,
}

/// Where a group is rendered and with what.
pub(crate) struct GroupContext<'a> {
    pub(crate) out: &'a OutputDir,
    pub(crate) caches: &'a Caches,
    pub(crate) search: &'a SearchPath,
    pub(crate) fail_on: &'a [usize],
    /// Cells whose rendering panics on purpose ([`PANIC_CELLS_ENV`]).
    pub(crate) panic_on: &'a [usize],
    /// Time limit per render (a march group or a reference).
    pub(crate) time_limit: Option<std::time::Duration>,
    /// References shared with other output folders.
    pub(crate) pool: Option<&'a ReferencePool>,
}

impl GroupContext<'_> {
    /// The control of one render: progress to `progress`, stopped at the time limit.
    pub(crate) fn control<'p>(&self, progress: &'p (dyn Fn(u64) + Sync)) -> volphot::Control<'p> {
        let control = volphot::Control::new(progress);
        match self.time_limit {
            Some(limit) => control.with_time_limit(limit),
            None => control,
        }
    }
}

/// The converged image the group's iterating cells (progressive or beam estimator) are
/// measured against after every iteration: their common reference's displayed layers.
/// `None` without such cells or when they do not share one reference.
fn progressive_reference(jobs: &[(&Job, CellLock)], out: &OutputDir) -> Result<Option<Vec<Vec3>>> {
    let iterating: Vec<&Job> = jobs
        .iter()
        .map(|(j, _)| *j)
        .filter(|j| j.spec.params.integrator.iterates())
        .collect();
    let Some(key) = iterating.first().and_then(|j| j.reference.clone()) else {
        return Ok(None);
    };
    if iterating.iter().any(|j| j.reference.as_ref() != Some(&key)) {
        return Ok(None);
    }
    let film = Film::read_exr(&out.reference(&key).join("reference.exr"))?;
    let emission = iterating[0].spec.params.integrator.emission;
    Ok(Some(displayed(&film, true, emission)))
}

/// The cells of a group this process renders, locked, and what became of the others.
struct Claimed<'g> {
    /// The cells to render, each with its lock (held until the cell is written).
    jobs: Vec<(&'g Job, CellLock)>,
    failures: Vec<(usize, String)>,
    busy: usize,
    done_elsewhere: usize,
}

impl<'g> Claimed<'g> {
    /// Locks each cell of `group` that no other process is rendering or has finished
    /// (failing the ones [`FAIL_CELLS_ENV`] names).
    fn lock(group: &'g [Job], ctx: &GroupContext<'_>) -> Result<Self> {
        let mut claimed = Claimed {
            jobs: Vec::new(),
            failures: Vec::new(),
            busy: 0,
            done_elsewhere: 0,
        };
        for job in group {
            if ctx.fail_on.contains(&job.spec.index) {
                let why = format!("failure injected by {FAIL_CELLS_ENV}");
                claimed.failures.push((job.spec.index, why));
                continue;
            }
            let Some(lock) = try_lock_cell(ctx.out, &job.hash)? else {
                claimed.busy += 1;
                continue;
            };
            if is_done(&ctx.out.cell(&job.hash)) {
                claimed.done_elsewhere += 1;
            } else {
                claimed.jobs.push((job, lock));
            }
        }
        Ok(claimed)
    }

    /// The group's outcome before any cell is rendered (releasing the locks).
    fn into_outcome(self) -> GroupOutcome {
        GroupOutcome {
            failures: self.failures,
            busy: self.busy,
            done_elsewhere: self.done_elsewhere,
            ..Default::default()
        }
    }
}

/// Renders one march group.
pub(crate) fn render_group(
    group: &[Job],
    ctx: &GroupContext<'_>,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<GroupOutcome> {
    // Per-cell locks: skip cells another process is rendering right now.
    let mut claimed = Claimed::lock(group, ctx)?;
    let jobs = &claimed.jobs;
    if jobs.is_empty() {
        return Ok(claimed.into_outcome());
    }
    // The group's scene: any cell's (they differ only in multiple-scattering settings),
    // with multiple scattering on when any cell wants it.
    let first = &jobs[0].0.spec;
    let mut params = first.params.clone();
    params.integrator.multiple = jobs.iter().any(|(j, _)| j.spec.params.integrator.multiple);
    let scene = ctx.caches.scene(&params, &first.base_dir, ctx.search)?;
    let integrators: Vec<_> = jobs
        .iter()
        .map(|(j, _)| j.spec.params.integrator.clone())
        .collect();
    if let Some((job, _)) = jobs
        .iter()
        .find(|(j, _)| ctx.panic_on.contains(&j.spec.index))
    {
        panic!(
            "panic injected by {PANIC_CELLS_ENV} in cell {}",
            job.spec.index
        );
    }
    let reference = progressive_reference(jobs, ctx.out)?;
    let control = ctx.control(progress);
    let control = match &reference {
        Some(image) => control.with_reference(image),
        None => control,
    };
    let shared = volphot::render_shared(&scene, &integrators, &control)?;
    let (rendered, failed, warnings) = write_cells(jobs, &shared, &scene, ctx.out);
    claimed.failures.extend(failed);
    Ok(GroupOutcome {
        rendered,
        photon_maps: shared.photon_maps,
        warnings,
        ..claimed.into_outcome()
    })
}

/// Writes the cells of a shared render: how many were written, the ones that failed, and
/// the written cells' warnings.
///
/// Each cell's metrics and files are its own and single-threaded, so the cells are
/// written in parallel (a 512² cell takes seconds; a group of 54 took minutes one by one).
fn write_cells(
    jobs: &[(&Job, CellLock)],
    shared: &SharedRender,
    scene: &Scene,
    out: &OutputDir,
) -> (usize, Vec<(usize, String)>, Vec<CellWarning>) {
    let written: Vec<Result<Vec<volphot::RenderWarning>>> = jobs
        .par_iter()
        .zip(shared.films.par_iter())
        .map(|((job, _lock), result)| {
            let timings = CellTimings {
                photon_tracing: result.photon_seconds,
                tree_build: result.tree_seconds,
                render: shared.render_seconds,
                metrics: 0.0,
                march_shared_by: jobs.len(),
                map_shared_by: result.map_shared_by,
            };
            write_cell(job, scene, result, timings, out)
        })
        .collect();
    let mut rendered = 0;
    let (mut failures, mut warned) = (Vec::new(), Vec::new());
    for ((job, _lock), outcome) in jobs.iter().zip(written) {
        match outcome {
            Ok(warnings) => {
                rendered += 1;
                warned.extend(warnings.into_iter().map(|warning| CellWarning {
                    index: job.spec.index,
                    label: job.spec.label(),
                    warning,
                }));
            }
            Err(e) => failures.push((job.spec.index, format!("{e:#}"))),
        }
    }
    (rendered, failures, warned)
}

/// Writes a finished cell: film, PNGs, metrics, record; returns the record's warnings.
fn write_cell(
    job: &Job,
    scene: &Scene,
    result: &SharedFilm,
    mut timings: CellTimings,
    out: &OutputDir,
) -> Result<Vec<volphot::RenderWarning>> {
    let film = &result.film;
    if !film.is_finite() {
        return Err(non_finite(
            &format!("cell {}", job.spec.index),
            film,
            &job.spec.params,
        ));
    }
    let p = &job.spec.params;
    let analysis = analyse_cell(film, p);
    timings.metrics = analysis.seconds;
    let staged = StagedDir::new(&out.cell(&job.hash))?;
    let dir = staged.path();
    let (w, h) = (film.width(), film.height());
    let exposure = p.film.exposure;
    film.write_exr(&dir.join("film.exr"))?;
    write_png(&dir.join("total.png"), w, h, &analysis.shown, exposure)?;
    for layer in [Layer::Single, Layer::Multiple] {
        let file = dir.join(format!("{}.png", layer.name()));
        write_png(&file, w, h, film.layer(layer), exposure)?;
    }
    // The march's scene is any cell's of the group; each cell records its own parameters.
    let mut provenance = Provenance::of(scene);
    provenance.scene = p.clone();
    let warnings = volphot::render_warnings(
        &p.integrator,
        p.sigma.mapping,
        &provenance.sigma,
        result.photons.as_ref(),
        Some(film.mean(Layer::Multiple)),
    );
    let record = CellRecord {
        index: job.spec.index,
        hash: job.hash.clone(),
        label: job.spec.label(),
        axes: job.axes_json(),
        provenance,
        photons: result.photons.clone(),
        cache_error: result.cache_error.clone(),
        progressive: result.progressive.clone(),
        timings,
        peak_memory_bytes: volphot::peak_memory_bytes(),
        mean_single: film.mean(Layer::Single),
        mean_multiple: film.mean(Layer::Multiple),
        mean_emission: film.mean(Layer::Emission),
        disco: analysis.disco,
        image: analysis.image,
        version: VERSION.to_string(),
        threads: rayon::current_num_threads(),
        host: hostname(),
        files: CELL_FILES
            .iter()
            .map(|f| FileCheck::of(dir, f))
            .collect::<Result<_>>()?,
        warnings: warnings.iter().map(ToString::to_string).collect(),
    };
    write_record(dir, &record)?;
    staged.commit()?;
    let _ = std::fs::remove_file(out.failure(&job.hash));
    if let Some(key) = &job.reference {
        compare_with_reference(out, &job.hash, key, p, film)?;
    }
    Ok(warnings)
}
