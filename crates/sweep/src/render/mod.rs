//! Cells → films: rendering the selected, unfinished cells of a plan into an output folder.
//!
//! Work is shared where the renderer allows it without changing results:
//! * volumes and media are loaded once per run and shared by every cell that uses them;
//! * cells that differ only in multiple-scattering parameters (`volume_photons`, `nused`,
//!   `maxdist`, `free_path`, `estimate`, `multiple`) are rendered by ONE march that yields a
//!   film per cell — one eye-ray pass, one single-scattering layer, and per photon map one
//!   k-NN query per sample serving every `nused`/`maxdist`;
//! * cells that differ only in render-time parameters use one photon map.
//!
//! References are rendered first (every cell's metrics need its reference). Each cell's
//! folder is written under a temporary name and renamed when complete; a rerun skips
//! finished cells.

mod group;
mod job;
mod reference;
mod scenes;

use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;

use anyhow::Result;
use volphot::{Method, SearchPath};

use group::{CellWarning, GroupContext, GroupOutcome, render_group};
pub(crate) use group::{FAIL_CELLS_ENV, PANIC_CELLS_ENV};
use job::Job;
pub(crate) use job::non_finite;
use reference::{ReferenceJob, ensure_reference};
pub(crate) use scenes::Caches;

use crate::plan::{CellSpec, Experiment};
use crate::store::{
    CellState, OutputDir, PlanRecord, ReferencePool, cell_state, clean_stale, hostname,
};

/// Which cells of a plan a run renders.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) enum Selection {
    /// Every cell.
    All,
    /// These plan indices (sorted, unique).
    Cells(Vec<usize>),
}

impl Selection {
    /// The selected indices of a plan with `planned` cells.
    pub(crate) fn indices(&self, planned: usize) -> Vec<usize> {
        match self {
            Selection::All => (0..planned).collect(),
            Selection::Cells(v) => v.clone(),
        }
    }
}

/// The cells a run asks for, parsed from `--cells` or `--shard`; checked against the plan
/// by [`CellFilter::resolve`].
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) enum CellFilter {
    /// Every cell.
    All,
    /// `--cells 3,7-9`: inclusive ranges, with the text as given (for errors).
    Cells {
        text: String,
        ranges: Vec<(usize, usize)>,
    },
    /// `--shard i/n`: the cells whose index is `i` modulo `n`.
    Shard { index: usize, count: usize },
}

impl CellFilter {
    /// Parses `3,7-9`.
    pub(crate) fn parse_cells(text: &str) -> Result<Self> {
        let mut ranges = Vec::new();
        for part in text.split(',').map(str::trim).filter(|p| !p.is_empty()) {
            let (a, b) = part.split_once('-').unwrap_or((part, part));
            let parse = |s: &str| -> Result<usize> {
                s.trim().parse::<usize>().map_err(|_| {
                    anyhow::anyhow!(
                        "--cells `{text}`: `{}` is not a cell index (expected e.g. 3,7-9)",
                        s.trim()
                    )
                })
            };
            let (a, b) = (parse(a)?, parse(b)?);
            anyhow::ensure!(a <= b, "--cells `{text}`: range {a}-{b} is reversed");
            ranges.push((a, b));
        }
        anyhow::ensure!(!ranges.is_empty(), "--cells `{text}`: no cells selected");
        Ok(CellFilter::Cells {
            text: text.to_string(),
            ranges,
        })
    }

    /// Parses `i/n` (0-based shard `i` of `n`).
    pub(crate) fn parse_shard(text: &str) -> Result<Self> {
        let (index, count) = text
            .split_once('/')
            .and_then(|(i, n)| {
                Some((
                    i.trim().parse::<usize>().ok()?,
                    n.trim().parse::<usize>().ok()?,
                ))
            })
            .ok_or_else(|| anyhow::anyhow!("--shard `{text}`: expected i/n, e.g. 2/8"))?;
        anyhow::ensure!(
            count >= 1 && index < count,
            "--shard `{text}`: need 0 <= i < n"
        );
        Ok(CellFilter::Shard { index, count })
    }

    /// The selection in a plan of `planned` cells; a cell beyond the plan is an error.
    pub(crate) fn resolve(&self, planned: usize) -> Result<Selection> {
        match self {
            CellFilter::All => Ok(Selection::All),
            CellFilter::Cells { text, ranges } => {
                let mut out = Vec::new();
                for &(a, b) in ranges {
                    anyhow::ensure!(
                        b < planned,
                        "--cells `{text}`: cell {b} does not exist (the plan has cells 0-{})",
                        planned.saturating_sub(1)
                    );
                    out.extend(a..=b);
                }
                out.sort_unstable();
                out.dedup();
                Ok(Selection::Cells(out))
            }
            CellFilter::Shard { index, count } => Ok(Selection::Cells(
                (0..planned).filter(|c| c % count == *index).collect(),
            )),
        }
    }
}

/// Options of a run, validated.
#[derive(Debug, Clone)]
pub(crate) struct RenderOptions {
    /// Output folder.
    pub(crate) output: OutputDir,
    /// The cells to render.
    pub(crate) selection: Selection,
    /// Groups rendered at once.
    pub(crate) jobs: usize,
    /// Hide progress bars.
    pub(crate) quiet: bool,
    /// Time limit per render (a march group or a reference).
    pub(crate) time_limit: Option<std::time::Duration>,
    /// References shared with other output folders (`--reference-pool`).
    pub(crate) reference_pool: Option<ReferencePool>,
}

/// What a run did.
#[derive(Debug, Clone, Default)]
pub(crate) struct RunSummary {
    /// Cells in the plan.
    pub(crate) planned: usize,
    /// Cells selected for this run.
    pub(crate) selected: usize,
    /// Cells already finished before the run.
    pub(crate) skipped: usize,
    /// Cells found damaged (and rendered again).
    pub(crate) damaged: usize,
    /// Cells left to another run that was rendering them.
    pub(crate) busy: usize,
    /// Cells rendered now.
    pub(crate) rendered: usize,
    /// Cells that failed (with their errors).
    pub(crate) failed: Vec<(usize, String)>,
    /// Marches run (each produced one or more cells).
    pub(crate) marches: usize,
    /// Photon maps built.
    pub(crate) photon_maps: usize,
    /// References rendered or refined.
    pub(crate) references: usize,
    /// Wall-clock seconds.
    pub(crate) seconds: f64,
}

/// Renders the selected, unfinished cells of `cells` into the output folder.
pub(crate) fn render_cells(
    exp: &Experiment,
    cells: &[CellSpec],
    plan: &PlanRecord,
    opts: &RenderOptions,
) -> Result<RunSummary> {
    let start = Instant::now();
    let out = &opts.output;
    std::fs::create_dir_all(out.root().join("cells"))?;
    clean_stale(&out.root().join("cells"));
    clean_stale(&out.root().join("references"));
    let selected = opts.selection.indices(cells.len());
    let mut summary = RunSummary {
        planned: cells.len(),
        selected: selected.len(),
        ..Default::default()
    };
    let (jobs, done) = select_jobs(&selected, cells, plan, out, &mut summary);
    // Finished cells still check their reference: one whose `spp` was raised since is
    // refined, and the report then recomputes their errors against it.
    let refine = exp.reference.is_some() && !done.is_empty();
    if !jobs.is_empty() || refine {
        let search = SearchPath::from_env();
        let caches = Caches::default();
        let multi = crate::progress::multi(opts.quiet);
        let ctx = GroupContext {
            out,
            caches: &caches,
            search: &search,
            fail_on: &cells_from_env(FAIL_CELLS_ENV),
            panic_on: &cells_from_env(PANIC_CELLS_ENV),
            time_limit: opts.time_limit,
            pool: opts.reference_pool.as_ref(),
        };
        let (references, failed) = render_references(exp, jobs.iter().chain(&done), &ctx, &multi);
        summary.references = references;
        // Cells whose reference failed fail with it; the others go on.
        let (jobs, without_reference): (Vec<Job>, Vec<Job>) = jobs.into_iter().partition(|j| {
            j.reference
                .as_ref()
                .is_none_or(|k| !failed.iter().any(|(f, _)| f == k))
        });
        let mut outcomes = Vec::new();
        if !without_reference.is_empty() {
            let outcome = GroupOutcome {
                failures: without_reference
                    .iter()
                    .map(|j| {
                        let key = j.reference.as_deref().unwrap_or_default();
                        let (_, e) = failed
                            .iter()
                            .find(|(f, _)| f == key)
                            .expect("failed reference");
                        (j.spec.index, format!("its reference {key} failed: {e}"))
                    })
                    .collect(),
                ..Default::default()
            };
            record_failures(&without_reference, &outcome, out, &multi);
            outcomes.push(outcome);
        }
        let groups = march_groups(jobs, exp.share);
        outcomes.extend(render_groups(&groups, &ctx, opts.jobs, &multi));
        for outcome in outcomes {
            summary.rendered += outcome.rendered;
            summary.busy += outcome.busy;
            summary.skipped += outcome.done_elsewhere;
            summary.photon_maps += outcome.photon_maps;
            summary.marches += usize::from(outcome.rendered > 0);
            summary.failed.extend(outcome.failures);
        }
        summary.failed.sort();
    }
    summary.seconds = start.elapsed().as_secs_f64();
    Ok(summary)
}

/// The selected cells to render, and those already finished that have a reference
/// (every finished cell counts as skipped; damaged ones are rendered again).
fn select_jobs(
    selected: &[usize],
    cells: &[CellSpec],
    plan: &PlanRecord,
    out: &OutputDir,
    summary: &mut RunSummary,
) -> (Vec<Job>, Vec<Job>) {
    let (mut jobs, mut done) = (Vec::new(), Vec::new());
    for &i in selected {
        let job = Job {
            spec: cells[i].clone(),
            hash: plan.cells[i].hash.clone(),
            reference: plan.cells[i].reference.clone(),
        };
        match cell_state(&out.cell(&plan.cells[i].hash)) {
            CellState::Done(_) => {
                summary.skipped += 1;
                if job.reference.is_some() {
                    done.push(job);
                }
                continue;
            }
            CellState::Damaged(why) => {
                eprintln!("cell {i} is damaged ({why}); rendering it again");
                summary.damaged += 1;
            }
            CellState::Missing => {}
        }
        jobs.push(job);
    }
    (jobs, done)
}

/// Cells named by a test switch ([`FAIL_CELLS_ENV`], [`PANIC_CELLS_ENV`]).
fn cells_from_env(var: &str) -> Vec<usize> {
    std::env::var(var)
        .ok()
        .map(|v| v.split(',').filter_map(|s| s.trim().parse().ok()).collect())
        .unwrap_or_default()
}

/// Renders the references the jobs need, each once; returns how many were rendered and
/// which failed (with their errors).
fn render_references<'a>(
    exp: &Experiment,
    jobs: impl Iterator<Item = &'a Job>,
    ctx: &GroupContext<'_>,
    multi: &indicatif::MultiProgress,
) -> (usize, Vec<(String, String)>) {
    let Some(spec) = &exp.reference else {
        return (0, Vec::new());
    };
    let mut needed: Vec<(&Job, &String)> = Vec::new();
    for job in jobs {
        if let Some(key) = &job.reference
            && !needed.iter().any(|(_, k)| *k == key)
        {
            needed.push((job, key));
        }
    }
    let mut rendered = 0;
    let mut failed = Vec::new();
    for (job, key) in needed {
        let reference = ReferenceJob {
            out: ctx.out,
            key,
            cell: &job.spec,
            spec,
        };
        match ensure_reference(&reference, ctx, multi) {
            Ok(true) => rendered += 1,
            Ok(false) => {}
            Err(e) => {
                multi.suspend(|| eprintln!("reference {key} failed: {e:#}"));
                failed.push((key.clone(), format!("{e:#}")));
            }
        }
    }
    (rendered, failed)
}

/// Groups jobs that share a march (photon-mapping cells with equal [`volphot::march_key`]
/// when the experiment shares work).
fn march_groups(jobs: Vec<Job>, share: bool) -> Vec<Vec<Job>> {
    group_by_march(jobs, share, |j| &j.spec)
}

/// Groups `items` whose cells share a march, in the order of their first member: the
/// groups a run renders with one `render_shared` call each (`sweep plan` costs the same).
pub(crate) fn group_by_march<T>(
    items: Vec<T>,
    share: bool,
    spec: impl Fn(&T) -> &CellSpec,
) -> Vec<Vec<T>> {
    let mut groups: Vec<(String, Vec<T>)> = Vec::new();
    for item in items {
        let params = &spec(&item).params;
        let key = volphot::march_key(params);
        let shareable = share && params.integrator.method == Method::Photon;
        match groups.iter_mut().find(|(k, g)| {
            shareable && spec(&g[0]).params.integrator.method == Method::Photon && *k == key
        }) {
            Some((_, g)) => g.push(item),
            None => groups.push((key, vec![item])),
        }
    }
    groups.into_iter().map(|(_, g)| g).collect()
}

/// Renders the groups, `jobs` at a time, each with its own progress bar; failures are
/// written to `failed/<hash>.txt` and reported.
fn render_groups(
    groups: &[Vec<Job>],
    ctx: &GroupContext<'_>,
    jobs: usize,
    multi: &indicatif::MultiProgress,
) -> Vec<GroupOutcome> {
    let total = groups.iter().map(Vec::len).sum::<usize>() as u64;
    let overall = crate::progress::bar(multi, total, "cells", "cells");
    let next = AtomicUsize::new(0);
    let results: Mutex<Vec<GroupOutcome>> = Mutex::new(Vec::new());
    let warning_log = WarningLog::default();
    let render_one = |group: &[Job]| -> GroupOutcome {
        let integrators: Vec<_> = group
            .iter()
            .map(|j| j.spec.params.integrator.clone())
            .collect();
        let rows = group[0].spec.params.camera.resolution[1];
        let bar = crate::progress::bar(
            multi,
            volphot::shared_progress_units(&integrators, rows),
            &format!("cell {}", group[0].spec.index),
            "rows",
        );
        // A panic fails the group's cells like an error does; the rest of the grid goes on.
        let outcome = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            render_group(group, ctx, &|rows| bar.set_position(rows))
        }))
        .unwrap_or_else(|payload| Err(anyhow::anyhow!("panicked: {}", panic_message(&payload))));
        bar.finish_and_clear();
        multi.remove(&bar);
        let outcome = outcome.unwrap_or_else(|e| GroupOutcome {
            failures: group
                .iter()
                .map(|j| (j.spec.index, format!("{e:#}")))
                .collect(),
            ..Default::default()
        });
        record_failures(group, &outcome, ctx.out, multi);
        for w in &outcome.warnings {
            warning_log.note(w, multi);
        }
        overall.inc(group.len() as u64);
        outcome
    };
    std::thread::scope(|scope| {
        for _ in 0..jobs.max(1).min(groups.len()) {
            scope.spawn(|| {
                while let Some(group) = groups.get(next.fetch_add(1, Ordering::Relaxed)) {
                    let r = render_one(group);
                    results.lock().unwrap_or_else(|e| e.into_inner()).push(r);
                }
            });
        }
    });
    overall.finish_and_clear();
    warning_log.finish(multi);
    results.into_inner().unwrap_or_else(|e| e.into_inner())
}

/// How many cells a run warns about in full per kind of warning.
const WARNED_IN_FULL: usize = 3;

/// The cells' warnings as a run prints them: each kind in full for its first
/// [`WARNED_IN_FULL`] cells, then the other cells with it named once at the end — a grid of
/// hundreds of under-resolved cells would otherwise repeat one paragraph hundreds of times.
/// Each cell's record (`cells/<hash>/cell.json`, `warnings`) keeps its own in full.
#[derive(Default)]
struct WarningLog {
    /// Per kind, in the order first met: how many were printed, and the cells not printed.
    kinds: Mutex<Vec<(&'static str, usize, Vec<usize>)>>,
}

impl WarningLog {
    /// Prints `w` in full, or counts it when its kind was printed often enough.
    fn note(&self, w: &CellWarning, multi: &indicatif::MultiProgress) {
        let mut kinds = self.kinds.lock().unwrap_or_else(|e| e.into_inner());
        let kind = w.warning.kind();
        let at = match kinds.iter().position(|(k, _, _)| *k == kind) {
            Some(at) => at,
            None => {
                kinds.push((kind, 0, Vec::new()));
                kinds.len() - 1
            }
        };
        let (_, printed, unprinted) = &mut kinds[at];
        if *printed < WARNED_IN_FULL {
            *printed += 1;
            multi.suspend(|| eprintln!("warning: cell {} ({}): {}", w.index, w.label, w.warning));
        } else {
            unprinted.push(w.index);
        }
    }

    /// Names the cells whose warnings were counted, not printed.
    fn finish(self, multi: &indicatif::MultiProgress) {
        let kinds = self.kinds.into_inner().unwrap_or_else(|e| e.into_inner());
        for (kind, _, mut cells) in kinds.into_iter().filter(|(_, _, c)| !c.is_empty()) {
            cells.sort_unstable();
            multi.suspend(|| {
                eprintln!(
                    "warning: {} more cell(s) with {kind}: cells {} (each cell's record, cells/<hash>/cell.json, has its warning in full)",
                    cells.len(),
                    crate::ranges::compress_ranges(&cells)
                )
            });
        }
    }
}

/// The message of a panic payload (`panic!` with a literal or a formatted string).
fn panic_message(payload: &Box<dyn std::any::Any + Send>) -> String {
    payload
        .downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| payload.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "(no message)".into())
}

/// Writes each failed cell's error to `failed/<hash>.txt` and prints it.
fn record_failures(
    group: &[Job],
    outcome: &GroupOutcome,
    out: &OutputDir,
    multi: &indicatif::MultiProgress,
) {
    for (index, message) in &outcome.failures {
        let Some(job) = group.iter().find(|j| j.spec.index == *index) else {
            continue;
        };
        let text = format!(
            "cell {index} ({}) failed on {}:\n{message}\n",
            job.spec.label(),
            hostname()
        );
        let _ = volphot::write_atomic(&out.failure(&job.hash), text.as_bytes());
        multi.suspend(|| eprintln!("cell {index} failed: {message}"));
    }
}

/// Builds a rayon pool with `threads` workers (all cores when `None`).
pub(crate) fn thread_pool(threads: Option<usize>) -> Result<rayon::ThreadPool> {
    let mut builder = rayon::ThreadPoolBuilder::new();
    if let Some(n) = threads {
        builder = builder.num_threads(n);
    }
    // The pool's error carries the system's error as its source too: shown once.
    builder.build().map_err(|e| {
        anyhow::anyhow!(
            "cannot start {} worker threads: {e}; ask for fewer with --threads",
            threads.map_or("the default number of".to_string(), |n| n.to_string())
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::store::{read_record, write_plan};

    #[test]
    fn cell_filters_parse_and_resolve_against_the_plan() {
        let f = CellFilter::parse_cells("3, 7-9,8").unwrap();
        assert_eq!(f.resolve(10).unwrap(), Selection::Cells(vec![3, 7, 8, 9]));
        let e = f.resolve(9).unwrap_err().to_string();
        assert!(
            e.contains("cell 9 does not exist (the plan has cells 0-8)"),
            "{e}"
        );
        for (bad, says) in [
            ("9-7", "reversed"),
            ("x", "not a cell index"),
            (",", "no cells"),
        ] {
            let e = CellFilter::parse_cells(bad).unwrap_err().to_string();
            assert!(e.contains(says), "{bad}: {e}");
        }
        let shard = CellFilter::parse_shard("1/3").unwrap();
        assert_eq!(shard.resolve(7).unwrap(), Selection::Cells(vec![1, 4]));
        assert!(CellFilter::parse_shard("3/3").is_err());
        assert_eq!(CellFilter::All.resolve(2).unwrap().indices(2), vec![0, 1]);
    }

    /// An experiment of four 24² cells (two σt × two nused) on the sphere phantom.
    fn experiment(dir: &std::path::Path) -> Experiment {
        let scene = format!(
            "{}[camera]\nresolution = [24, 24]\n[integrator]\nvolume_photons = 2000\nstepsize = 0.01\n",
            volphot::test_util::SMALL_SCENE
        );
        std::fs::write(dir.join("s.toml"), scene).unwrap();
        let exp =
            "scene = \"s.toml\"\n[axes]\n\"sigma.t\" = [5, 20]\n\"integrator.nused\" = [10, 40]\n";
        std::fs::write(dir.join("e.toml"), exp).unwrap();
        Experiment::load(&dir.join("e.toml")).unwrap()
    }

    fn jobs(exp: &Experiment) -> Vec<Job> {
        let (cells, hashes) = exp
            .plan_with_hashes(crate::plan::Quality::Default, false)
            .unwrap();
        cells
            .into_iter()
            .zip(hashes)
            .map(|(spec, hash)| Job {
                spec,
                hash,
                reference: None,
            })
            .collect()
    }

    #[test]
    fn cells_that_differ_only_in_multiple_scattering_share_a_march() {
        let tmp = tempfile::tempdir().unwrap();
        let exp = experiment(tmp.path());
        let groups = march_groups(jobs(&exp), true);
        let sizes: Vec<usize> = groups.iter().map(Vec::len).collect();
        assert_eq!(sizes, [2, 2], "one march per σt, serving both nused");
        for g in &groups {
            let t = g[0].spec.params.sigma.t;
            assert!(g.iter().all(|j| j.spec.params.sigma.t == t));
        }
        assert_eq!(march_groups(jobs(&exp), false).len(), 4, "share = false");
    }

    #[test]
    fn render_cells_writes_each_cell_once_and_skips_finished_ones() {
        let tmp = tempfile::tempdir().unwrap();
        let exp = experiment(tmp.path());
        let (cells, hashes) = exp
            .plan_with_hashes(crate::plan::Quality::Default, false)
            .unwrap();
        let plan = exp
            .plan_record(&cells, &hashes, crate::plan::Quality::Default)
            .unwrap();
        let out = OutputDir::new(tmp.path().join("out"));
        std::fs::create_dir_all(out.root()).unwrap();
        write_plan(&out, &plan, &exp.source.text).unwrap();
        let options = RenderOptions {
            output: out.clone(),
            selection: Selection::All,
            jobs: 1,
            quiet: true,
            time_limit: None,
            reference_pool: None,
        };
        let first = render_cells(&exp, &cells, &plan, &options).unwrap();
        assert_eq!((first.rendered, first.marches, first.skipped), (4, 2, 0));
        assert!(first.failed.is_empty(), "{:?}", first.failed);
        for (cell, hash) in cells.iter().zip(&hashes) {
            let record = read_record(&out.cell(hash)).unwrap();
            assert_eq!(record.index, cell.index);
            assert_eq!(record.timings.march_shared_by, 2);
            // Each cell records its own parameters, not those of the march it shared.
            assert_eq!(record.provenance.scene, cell.params);
            assert!(record.mean_multiple > 0.0);
        }
        let again = render_cells(&exp, &cells, &plan, &options).unwrap();
        assert_eq!((again.rendered, again.skipped), (0, 4));
    }
}
