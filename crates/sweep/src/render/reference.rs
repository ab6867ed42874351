//! References: rendered (or refined to more samples) under their own lock, so parallel
//! runs and cluster tasks share one reference per physics; with a reference pool
//! ([`ReferencePool`]) studies share them too.

use std::path::Path;
use std::time::Instant;

use anyhow::{Context, Result};
use volphot::{Film, ReferenceAccumulator, Scene, SceneParams, write_png};

use super::group::GroupContext;
use super::job::non_finite;
use crate::plan::{CellSpec, ReferenceMethod, ReferenceSpec, reference_params};
use crate::store::{
    FileCheck, OutputDir, ReferencePool, ReferenceRecord, StagedDir, VERSION, lock_reference,
    verified_reference, write_reference_record,
};

/// What a reference needs: where it goes, the cell that defines its physics, how it is made.
pub(crate) struct ReferenceJob<'a> {
    pub(crate) out: &'a OutputDir,
    pub(crate) key: &'a str,
    pub(crate) cell: &'a CellSpec,
    pub(crate) spec: &'a ReferenceSpec,
}

/// Renders (or refines) a reference under its own lock, through the reference pool when
/// there is one; returns whether it was rendered here (not found ready).
pub(crate) fn ensure_reference(
    job: &ReferenceJob<'_>,
    ctx: &GroupContext<'_>,
    multi: &indicatif::MultiProgress,
) -> Result<bool> {
    let dir = job.out.reference(job.key);
    // Blocking: another task may be rendering this reference right now.
    let lock = lock_reference(job.out, job.key)?;
    let existing = unless_damaged(
        verified_reference(&dir, "reference.exr"),
        &format!("reference {}", job.key),
        "rendering it again",
        multi,
    );
    if let Some(r) = &existing
        && (job.spec.method != ReferenceMethod::Path || r.passes >= job.spec.spp)
    {
        return Ok(false);
    }
    let params = reference_params(&job.cell.params, job.spec)?;
    let scene = ctx.caches.scene(&params, &job.cell.base_dir, ctx.search)?;
    let rendered = match (job.spec.method, ctx.pool) {
        (ReferenceMethod::Path, Some(pool)) => from_pool(job, &scene, &params, pool, ctx, multi)?,
        _ => {
            let resumed = existing
                .map(|r| -> Result<_> {
                    let film = Film::read_exr(&dir.join("reference.exr"))?;
                    let acc = ReferenceAccumulator::resume(&scene, &film, r.passes)?;
                    Ok((acc, r.seconds))
                })
                .transpose()?;
            let made = render(job, &scene, resumed, ctx, multi)?;
            write_reference(&dir, &made.film, &scene, &made.record(job, params, &scene))?;
            true
        }
    };
    drop(lock);
    Ok(rendered)
}

/// A reference just rendered: its film, passes and the seconds spent on it in total.
struct Made {
    film: Film,
    passes: u32,
    seconds: f64,
    /// The path tracer's accumulator (`None` for a photon-mapped reference).
    accumulator: Option<ReferenceAccumulator>,
}

impl Made {
    fn record(
        &self,
        job: &ReferenceJob<'_>,
        scene_params: SceneParams,
        scene: &Scene,
    ) -> ReferenceRecord {
        ReferenceRecord {
            files: Vec::new(),
            key: job.key.to_string(),
            method: job.spec.method,
            passes: self.passes,
            seconds: self.seconds,
            scene: scene_params,
            volume: scene.volume_source().clone(),
            version: VERSION.to_string(),
        }
    }
}

/// Renders the reference, path-traced on from `resumed` (an accumulator and the seconds
/// already spent on it) when given.
fn render(
    job: &ReferenceJob<'_>,
    scene: &Scene,
    resumed: Option<(ReferenceAccumulator, f64)>,
    ctx: &GroupContext<'_>,
    multi: &indicatif::MultiProgress,
) -> Result<Made> {
    let bar = crate::progress::bar(multi, scene.camera().height() as u64, "reference", "rows");
    let start = Instant::now();
    let progress = |rows| bar.set_position(rows);
    let control = ctx.control(&progress);
    let before = resumed.as_ref().map_or(0.0, |(_, s)| *s);
    let (film, passes, accumulator) = match job.spec.method {
        ReferenceMethod::Path => {
            let mut acc = match resumed {
                Some((acc, _)) => acc,
                None => ReferenceAccumulator::new(
                    scene.camera().width() as usize,
                    scene.camera().height() as usize,
                ),
            };
            let more = job.spec.spp - acc.passes();
            acc.add_passes(scene, more, &control)?;
            (acc.film(), acc.passes(), Some(acc))
        }
        ReferenceMethod::Photon => (volphot::render(scene, &control)?.film, 0, None),
    };
    bar.finish_and_clear();
    multi.remove(&bar);
    if !film.is_finite() {
        return Err(non_finite(
            &format!("reference {}", job.key),
            &film,
            scene.params(),
        ));
    }
    Ok(Made {
        film,
        passes,
        seconds: before + start.elapsed().as_secs_f64(),
        accumulator,
    })
}

/// Copies the pool's reference of the job's passes into the output folder, rendering it
/// into the pool first when the pool lacks it; returns whether it was rendered.
fn from_pool(
    job: &ReferenceJob<'_>,
    scene: &Scene,
    params: &SceneParams,
    pool: &ReferencePool,
    ctx: &GroupContext<'_>,
    multi: &indicatif::MultiProgress,
) -> Result<bool> {
    // Blocking: another study or task may be rendering it into the pool right now.
    let _pool_lock = pool.lock(job.key)?;
    let pooled = pool.film(job.key, job.spec.spp);
    let found = pool.finished(job.key, job.spec.spp);
    let what = pooled.display().to_string();
    let rendered = unless_damaged(found, &what, "rendering it again", multi).is_none();
    if rendered {
        render_into_pool(job, scene, params, pool, ctx, multi)?;
    }
    copy_reference(&pooled, &job.out.reference(job.key))?;
    Ok(rendered)
}

/// Renders the job's passes into the pool, refined from the pool's state when it holds no
/// more passes than wanted (the same bits as a whole run), and keeps the new state when it
/// holds more passes than the old.
fn render_into_pool(
    job: &ReferenceJob<'_>,
    scene: &Scene,
    params: &SceneParams,
    pool: &ReferencePool,
    ctx: &GroupContext<'_>,
    multi: &indicatif::MultiProgress,
) -> Result<()> {
    let what = pool.state(job.key).display().to_string();
    let state = unless_damaged(
        pool.saved_state(job.key),
        &what,
        "rendering without it",
        multi,
    );
    let resumed = match &state {
        Some(r) if r.passes <= job.spec.spp => Some((pool.read_state(job.key)?, r.seconds)),
        _ => None,
    };
    let made = render(job, scene, resumed, ctx, multi)?;
    let record = made.record(job, params.clone(), scene);
    write_reference(&pool.film(job.key, made.passes), &made.film, scene, &record)?;
    if let Some(acc) = &made.accumulator
        && state.is_none_or(|r| r.passes < made.passes)
    {
        pool.keep_state(job.key, acc, record)?;
    }
    Ok(())
}

/// The record `found`, or `None` with a line saying why `what` was passed over and what
/// happens `then` when it is damaged.
fn unless_damaged(
    found: Result<Option<ReferenceRecord>, String>,
    what: &str,
    then: &str,
    multi: &indicatif::MultiProgress,
) -> Option<ReferenceRecord> {
    found.unwrap_or_else(|why| {
        multi.suspend(|| eprintln!("{what} is damaged ({why}); {then}"));
        None
    })
}

/// Copies a finished reference folder (its images and record) to `to`, replacing it.
fn copy_reference(from: &Path, to: &Path) -> Result<()> {
    let staged = StagedDir::new(to)?;
    for name in ["reference.exr", "reference.png", "reference.json"] {
        std::fs::copy(from.join(name), staged.path().join(name)).with_context(|| {
            format!("copying {} to {}", from.join(name).display(), to.display())
        })?;
    }
    staged.commit()
}

/// Writes `reference.exr`, `reference.png` and `reference.json` into a staged folder and
/// replaces the old reference with it.
fn write_reference(
    dir: &std::path::Path,
    film: &Film,
    scene: &Scene,
    record: &ReferenceRecord,
) -> Result<()> {
    let staged = StagedDir::new(dir)?;
    film.write_exr(&staged.path().join("reference.exr"))?;
    write_png(
        &staged.path().join("reference.png"),
        film.width(),
        film.height(),
        &film.total(),
        scene.film().exposure,
    )?;
    let mut record = record.clone();
    record.files = ["reference.exr", "reference.png"]
        .iter()
        .map(|f| FileCheck::of(staged.path(), f))
        .collect::<Result<_>>()?;
    write_reference_record(staged.path(), &record)?;
    if dir.exists() {
        std::fs::remove_dir_all(dir)?;
    }
    staged.commit()
}
