//! References: rendered (or refined to more samples) under their own lock, so parallel
//! runs and cluster tasks share one reference per physics.

use std::time::Instant;

use anyhow::Result;
use volphot::{Film, ReferenceAccumulator, Scene, write_png};

use super::group::GroupContext;
use crate::plan::{CellSpec, ReferenceMethod, ReferenceSpec, reference_params};
use crate::store::{
    FileCheck, OutputDir, ReferenceRecord, StagedDir, VERSION, first_mismatch, lock_reference,
    read_reference_record, write_reference_record,
};

/// What a reference needs: where it goes, the cell that defines its physics, how it is made.
pub(crate) struct ReferenceJob<'a> {
    pub(crate) out: &'a OutputDir,
    pub(crate) key: &'a str,
    pub(crate) cell: &'a CellSpec,
    pub(crate) spec: &'a ReferenceSpec,
}

/// Renders (or refines) a reference under its own lock; returns whether work was done.
pub(crate) fn ensure_reference(
    job: &ReferenceJob<'_>,
    ctx: &GroupContext<'_>,
    multi: &indicatif::MultiProgress,
) -> Result<bool> {
    let dir = job.out.reference(job.key);
    // Blocking: another task may be rendering this reference right now.
    let lock = lock_reference(job.out, job.key)?;
    let params = reference_params(&job.cell.params, job.spec)?;
    let existing = match read_reference_record(&dir) {
        Ok(r) => match first_mismatch(&dir, &r.files).or_else(|| {
            (!dir.join("reference.exr").is_file()).then(|| "reference.exr is missing".into())
        }) {
            None => Some(r),
            Some(why) => {
                multi.suspend(|| {
                    eprintln!(
                        "reference {} is damaged ({why}); rendering it again",
                        job.key
                    )
                });
                None
            }
        },
        Err(_) => None,
    };
    if let Some(r) = &existing
        && (job.spec.method != ReferenceMethod::Path || r.passes >= job.spec.spp)
    {
        return Ok(false);
    }
    let scene = ctx.caches.scene(&params, &job.cell.base_dir, ctx.search)?;
    let bar = crate::progress::bar(multi, scene.camera().height() as u64, "reference", "rows");
    let start = Instant::now();
    let progress = |rows| bar.set_position(rows);
    let control = ctx.control(&progress);
    let (film, passes) = match job.spec.method {
        ReferenceMethod::Path => {
            let mut acc = match &existing {
                Some(r) => ReferenceAccumulator::from_film(
                    &Film::read_exr(&dir.join("reference.exr"))?,
                    r.passes,
                )?,
                None => ReferenceAccumulator::new(
                    scene.camera().width() as usize,
                    scene.camera().height() as usize,
                ),
            };
            let more = job.spec.spp - acc.passes();
            acc.add_passes(&scene, more, &control)?;
            (acc.film(), acc.passes())
        }
        ReferenceMethod::Photon => (volphot::render(&scene, &control)?.film, 0),
    };
    bar.finish_and_clear();
    multi.remove(&bar);
    anyhow::ensure!(
        film.is_finite(),
        "reference {} has non-finite pixels",
        job.key
    );
    let record = ReferenceRecord {
        files: Vec::new(),
        key: job.key.to_string(),
        method: job.spec.method,
        passes,
        seconds: start.elapsed().as_secs_f64() + existing.as_ref().map_or(0.0, |r| r.seconds),
        scene: params,
        volume: scene.volume_source().clone(),
        version: VERSION.to_string(),
    };
    write_reference(&dir, &film, &scene, &record)?;
    drop(lock);
    Ok(true)
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
