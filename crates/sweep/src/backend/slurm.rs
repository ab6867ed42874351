//! Scale-out on Slurm: one job array over the plan's cells plus a collect job.
//!
//! `sweep run FILE --backend slurm` plans the grid, writes `plan.json`, groups the cells
//! that are not finished into array tasks (cells sharing a march stay together, and the
//! array never exceeds the cluster's `MaxArraySize`), writes `slurm/array.sh` and
//! `slurm/collect.sh` into the output folder, and submits
//!
//! ```text
//! sbatch --parsable --array=0-N%K … slurm/array.sh
//! sbatch --parsable --dependency=afterany:<array> … slurm/collect.sh
//! ```
//!
//! Each task runs `sweep run FILE --cells <its cells> --output OUT --no-report` — the same
//! cell runner as a local run — and writes finished cells atomically into the shared
//! output folder. `afterany` (not `afterok`) lets the collect job run and report missing
//! cells even when a task fails. Resubmitting renders only cells without a `cell.json`.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

use anyhow::{Context, Result};
use serde::{Deserialize, Serialize};

use super::{Backend, Outcome, Run};
use crate::plan::{CellSpec, Experiment, Quality};
use crate::store::{OutputDir, VERSION, cell_hash, check_owner, is_done, write_plan};

/// Slurm options of `sweep run --backend slurm`, validated.
#[derive(Debug, Clone, Default)]
pub(crate) struct SlurmOptions {
    /// Partition (`sbatch --partition`).
    pub(crate) partition: Option<String>,
    /// Time limit per task (`sbatch --time`).
    pub(crate) time: Option<String>,
    /// Memory per task (`sbatch --mem`).
    pub(crate) mem: Option<String>,
    /// CPUs per task (`sbatch --cpus-per-task`), also the task's `--threads`.
    pub(crate) cpus_per_task: Option<u32>,
    /// At most this many array tasks at once.
    pub(crate) max_concurrent: Option<u32>,
    /// Extra arguments passed to every sbatch call.
    pub(crate) sbatch_args: Vec<String>,
    /// Cells per array task (default: by shared march, fitted to `MaxArraySize`).
    pub(crate) cells_per_task: Option<usize>,
    /// Write the scripts and print the sbatch lines without submitting.
    pub(crate) dry_run: bool,
    /// Block until the collect job has finished.
    pub(crate) wait: bool,
    /// `--cell-timeout` for the tasks' `sweep run`.
    pub(crate) cell_timeout: Option<std::time::Duration>,
    /// `--reference-pool` for the tasks' `sweep run` (absolute).
    pub(crate) reference_pool: Option<PathBuf>,
}

/// Submits the run as a Slurm job array plus a collect job.
pub(crate) struct Slurm {
    pub(crate) options: SlurmOptions,
}

/// `slurm/jobs.json`: every submission made for an output folder.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub(crate) struct JobsRecord {
    /// Submissions, oldest first.
    pub(crate) submissions: Vec<Submission>,
}

/// One submission.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub(crate) struct Submission {
    /// Array job id.
    pub(crate) array_job: String,
    /// Collect job id.
    pub(crate) collect_job: String,
    /// Array tasks.
    pub(crate) tasks: usize,
    /// Cells submitted.
    pub(crate) cells: Vec<usize>,
    /// Unix time of submission.
    pub(crate) submitted_at: u64,
}

/// The scripts and sbatch command lines of a submission.
#[derive(Debug, Clone)]
pub(crate) struct SubmissionPlan {
    /// Cells per task (plan indices).
    pub(crate) tasks: Vec<Vec<usize>>,
    /// `slurm/array.sh` contents.
    pub(crate) array_script: String,
    /// `slurm/collect.sh` contents.
    pub(crate) collect_script: String,
    /// sbatch arguments for the array (before the script path).
    pub(crate) array_args: Vec<String>,
    /// sbatch arguments for the collect job (the dependency is added at submission).
    pub(crate) collect_args: Vec<String>,
    /// The folder holding the scripts.
    pub(crate) dir: PathBuf,
}

impl SubmissionPlan {
    /// The sbatch lines as a shell user would type them.
    pub(crate) fn describe(&self) -> String {
        let array = self.dir.join("array.sh");
        let collect = self.dir.join("collect.sh");
        format!(
            "{} tasks over {} cells\nsbatch {} {}\nsbatch {} --dependency=afterany:<array job id> {}",
            self.tasks.len(),
            self.tasks.iter().map(Vec::len).sum::<usize>(),
            shell_join(&self.array_args),
            array.display(),
            shell_join(&self.collect_args),
            collect.display()
        )
    }
}

fn shell_quote(s: &str) -> String {
    if !s.is_empty()
        && s.chars()
            .all(|c| c.is_ascii_alphanumeric() || "-_./=:,%@+".contains(c))
    {
        s.to_string()
    } else {
        format!("'{}'", s.replace('\'', "'\\''"))
    }
}

fn shell_join(args: &[String]) -> String {
    args.iter()
        .map(|a| shell_quote(a))
        .collect::<Vec<_>>()
        .join(" ")
}

/// The cluster's `MaxArraySize` (`scontrol show config`), or Slurm's default 1001.
pub(crate) fn max_array_size() -> usize {
    Command::new("scontrol")
        .args(["show", "config"])
        .output()
        .ok()
        .and_then(|o| {
            String::from_utf8_lossy(&o.stdout)
                .lines()
                .find(|l| l.trim_start().starts_with("MaxArraySize"))
                .and_then(|l| l.split('=').nth(1))
                .and_then(|v| v.trim().parse().ok())
        })
        .unwrap_or(1001)
}

/// Groups cells into array tasks: cells that share a march stay in one task (they render
/// together), then tasks are merged until the array fits `max_tasks`.
pub(crate) fn group_cells(
    cells: &[&CellSpec],
    cells_per_task: Option<usize>,
    max_tasks: usize,
) -> Vec<Vec<usize>> {
    let mut groups: Vec<(String, Vec<usize>)> = Vec::new();
    for c in cells {
        let key = volphot::march_key(&c.params);
        match groups.iter_mut().find(|(k, _)| *k == key) {
            Some((_, v)) => v.push(c.index),
            None => groups.push((key, vec![c.index])),
        }
    }
    let mut tasks: Vec<Vec<usize>> = match cells_per_task {
        Some(n) => {
            let n = n.max(1);
            let all: Vec<usize> = groups.into_iter().flat_map(|(_, v)| v).collect();
            all.chunks(n).map(<[usize]>::to_vec).collect()
        }
        None => groups.into_iter().map(|(_, v)| v).collect(),
    };
    let max_tasks = max_tasks.max(1);
    if tasks.len() > max_tasks {
        // Merge neighbouring tasks evenly so the array fits.
        let per = tasks.len().div_ceil(max_tasks);
        tasks = tasks.chunks(per).map(|c| c.concat()).collect();
    }
    tasks
}

/// Builds the scripts and sbatch arguments for the cells in `pending` (all when `None`).
pub(crate) fn plan_submission(
    exp: &Experiment,
    cells: &[CellSpec],
    output: &Path,
    options: &SlurmOptions,
    quality: Quality,
    pending: Option<&[usize]>,
) -> Result<SubmissionPlan> {
    let output = absolute(output);
    let dir = output.join("slurm");
    let selected: Vec<&CellSpec> = cells
        .iter()
        .filter(|c| pending.is_none_or(|p| p.contains(&c.index)))
        .collect();
    let tasks = group_cells(&selected, options.cells_per_task, max_array_size());
    let exe = std::env::current_exe().context("locating the sweep executable")?;
    let scripts = Scripts {
        // A tune's cells are not the grid's: its tasks rebuild them from plan.json.
        verb: if exp.tune.is_some() { "tune" } else { "run" },
        exe: &exe,
        experiment: &absolute(exp.path()),
        output: &output,
        logs: &dir.join("logs"),
    };
    let array_script = scripts.array(cells, &tasks, quality, options);
    let collect_script = scripts.collect();
    let (array_args, collect_args) = sbatch_args(&exp.name, &tasks, options, scripts.logs);
    Ok(SubmissionPlan {
        tasks,
        array_script,
        collect_script,
        array_args,
        collect_args,
        dir,
    })
}

fn absolute(p: &Path) -> PathBuf {
    std::path::absolute(p).unwrap_or_else(|_| p.to_path_buf())
}

/// Paths the job scripts name.
struct Scripts<'a> {
    verb: &'static str,
    exe: &'a Path,
    experiment: &'a Path,
    output: &'a Path,
    logs: &'a Path,
}

impl Scripts<'_> {
    /// `slurm/array.sh`: task i renders `CELLS[i]`; a failed task leaves its stderr beside
    /// every cell it did not finish.
    fn array(
        &self,
        cells: &[CellSpec],
        tasks: &[Vec<usize>],
        quality: Quality,
        options: &SlurmOptions,
    ) -> String {
        let quality_flag = quality.flag();
        let mut threads = options
            .cpus_per_task
            .map(|c| format!(" --threads {c}"))
            .unwrap_or_default();
        if let Some(limit) = options.cell_timeout {
            threads += &format!(" --cell-timeout {}", limit.as_secs_f64());
        }
        if let Some(pool) = &options.reference_pool {
            threads += &format!(
                " --reference-pool {}",
                shell_quote(&pool.display().to_string())
            );
        }
        let task_cells: Vec<String> = tasks
            .iter()
            .map(|t| format!("\"{}\"", crate::ranges::compress_ranges(t)))
            .collect();
        let hashes: Vec<String> = tasks
            .iter()
            .map(|t| {
                let h: Vec<String> = t
                    .iter()
                    .map(|&i| cell_hash(&cells[i].params, &cells[i].base_dir).unwrap_or_default())
                    .collect();
                format!("\"{}\"", h.join(" "))
            })
            .collect();
        format!(
            r#"#!/bin/bash
# Generated by `sweep run --backend slurm` ({version}); resubmit by hand with the
# sbatch line in README or by rerunning `sweep run … --backend slurm`.
# Task i renders the cells CELLS[i] of {exp} into {out}.
set -u
CELLS=({cells})
HASHES=({hashes})
task=${{SLURM_ARRAY_TASK_ID:?run me as a Slurm array task}}
{exe} {verb} {exp} --output {out} --cells "${{CELLS[$task]}}" --no-report --quiet{quality}{threads}
status=$?
if [ $status -ne 0 ]; then
  # Keep this task's stderr beside every cell it did not finish, for the report.
  err={logs}/task-${{SLURM_ARRAY_JOB_ID}}_${{task}}.err
  mkdir -p {out}/failed
  for h in ${{HASHES[$task]}}; do
    if [ ! -f {out}/cells/$h/cell.json ]; then
      cp "$err" {out}/failed/$h.stderr 2>/dev/null || true
      [ -f {out}/failed/$h.txt ] || echo "array task $SLURM_ARRAY_JOB_ID/$task exited with status $status; stderr: {out}/failed/$h.stderr" > {out}/failed/$h.txt
    fi
  done
fi
exit $status
"#,
            version = VERSION,
            verb = self.verb,
            exp = shell_quote(&self.experiment.display().to_string()),
            out = shell_quote(&self.output.display().to_string()),
            cells = task_cells.join(" "),
            hashes = hashes.join(" "),
            exe = shell_quote(&self.exe.display().to_string()),
            quality = quality_flag,
            threads = threads,
            logs = shell_quote(&self.logs.display().to_string()),
        )
    }

    /// `slurm/collect.sh`: gathers finished cells into the report.
    fn collect(&self) -> String {
        format!(
            "#!/bin/bash\n# Generated by `sweep run --backend slurm`: gathers finished cells into cells.csv and the report.\nset -u\n{} report {}\n",
            shell_quote(&self.exe.display().to_string()),
            shell_quote(&self.output.display().to_string())
        )
    }
}

/// The sbatch arguments of the array and of the collect job (its dependency is added at
/// submission).
fn sbatch_args(
    name: &str,
    tasks: &[Vec<usize>],
    options: &SlurmOptions,
    logs: &Path,
) -> (Vec<String>, Vec<String>) {
    let mut common = vec![
        "--parsable".to_string(),
        format!("--chdir={}", absolute(Path::new(".")).display()),
    ];
    let named = [
        ("partition", options.partition.clone()),
        ("time", options.time.clone()),
        ("mem", options.mem.clone()),
        (
            "cpus-per-task",
            options.cpus_per_task.map(|c| c.to_string()),
        ),
    ];
    for (flag, value) in named {
        if let Some(v) = value {
            common.push(format!("--{flag}={v}"));
        }
    }
    common.extend(options.sbatch_args.iter().cloned());
    let mut array_args = common.clone();
    array_args.push(format!("--job-name=sweep-{name}"));
    let throttle = options
        .max_concurrent
        .map(|k| format!("%{k}"))
        .unwrap_or_default();
    array_args.push(format!(
        "--array=0-{}{throttle}",
        tasks.len().saturating_sub(1)
    ));
    array_args.push(format!(
        "--output={}",
        logs.join("task-%A_%a.out").display()
    ));
    array_args.push(format!("--error={}", logs.join("task-%A_%a.err").display()));
    let mut collect_args = common;
    collect_args.push(format!("--job-name=sweep-{name}-collect"));
    collect_args.push(format!(
        "--output={}",
        logs.join("collect-%j.out").display()
    ));
    collect_args.push(format!("--error={}", logs.join("collect-%j.err").display()));
    (array_args, collect_args)
}

fn sbatch(args: &[String], script: &Path) -> Result<String> {
    let output = Command::new("sbatch")
        .args(args)
        .arg(script)
        .output()
        .context("running sbatch (is Slurm installed and SLURM_CONF set?)")?;
    anyhow::ensure!(
        output.status.success(),
        "sbatch {} {} failed: {}",
        shell_join(args),
        script.display(),
        String::from_utf8_lossy(&output.stderr).trim()
    );
    let text = String::from_utf8_lossy(&output.stdout);
    let id = text.trim().split(';').next().unwrap_or("").to_string();
    anyhow::ensure!(
        !id.is_empty() && id.chars().all(|c| c.is_ascii_digit()),
        "sbatch printed `{}`, expected a job id",
        text.trim()
    );
    Ok(id)
}

fn read_jobs(out: &OutputDir) -> JobsRecord {
    volphot::read_text_capped(
        &out.root().join("slurm").join("jobs.json"),
        volphot::TEXT_INPUT_CAP,
        "Slurm jobs record",
    )
    .ok()
    .and_then(|t| serde_json::from_str(&t).ok())
    .unwrap_or_default()
}

/// Job ids still known to `squeue` among `ids`.
fn queued(ids: &[String]) -> Option<Vec<(String, String)>> {
    if ids.is_empty() {
        return Some(Vec::new());
    }
    let output = Command::new("squeue")
        .args(["-h", "-o", "%i %T", "-j", &ids.join(",")])
        .output()
        .ok()?;
    if !output.status.success() {
        // squeue rejects ids it no longer knows; treat as finished.
        return Some(Vec::new());
    }
    Some(
        String::from_utf8_lossy(&output.stdout)
            .lines()
            .filter_map(|l| {
                l.split_once(' ')
                    .map(|(a, b)| (a.to_string(), b.to_string()))
            })
            .collect(),
    )
}

/// Prints the Slurm jobs recorded for an output folder and their states.
pub(crate) fn print_jobs(out: &OutputDir) {
    let jobs = read_jobs(out);
    let Some(last) = jobs.submissions.last() else {
        return;
    };
    let ids = vec![last.array_job.clone(), last.collect_job.clone()];
    match queued(&ids) {
        Some(q) if q.is_empty() => println!(
            "  slurm: array {} and collect {} have left the queue",
            last.array_job, last.collect_job
        ),
        Some(q) => {
            for (id, state) in q {
                println!("  slurm: job {id} {state}");
            }
        }
        None => println!(
            "  slurm: squeue not available; last submission array {} collect {}",
            last.array_job, last.collect_job
        ),
    }
}

impl Backend for Slurm {
    fn execute(&self, run: &Run<'_>) -> Result<Outcome> {
        let (exp, out) = (run.experiment, &run.output);
        check_owner(out, &exp.owner())?;
        std::fs::create_dir_all(out.root().join("slurm").join("logs"))?;
        let plan = exp.plan_record(run.cells, run.hashes, run.quality)?;
        write_plan(out, &plan, &exp.source.text)?;
        let selected = run.selection.indices(run.cells.len());
        let pending: Vec<usize> = selected
            .into_iter()
            .filter(|&i| !is_done(&out.cell(&run.hashes[i])))
            .collect();
        if pending.is_empty() {
            eprintln!("{}: all {} cells are finished", exp.name, run.cells.len());
            return Ok(Outcome::Rendered { failed: 0 });
        }
        // Cells that failed before get a fresh start.
        for &i in &pending {
            let _ = std::fs::remove_file(out.failure(&run.hashes[i]));
            let _ = std::fs::remove_file(
                out.root()
                    .join("failed")
                    .join(format!("{}.stderr", run.hashes[i])),
            );
        }
        let plan = plan_submission(
            exp,
            run.cells,
            out.root(),
            &self.options,
            run.quality,
            Some(&pending),
        )?;
        let array = plan.dir.join("array.sh");
        let collect = plan.dir.join("collect.sh");
        write_script(&array, &plan.array_script)?;
        write_script(&collect, &plan.collect_script)?;
        if self.options.dry_run {
            println!("{}", plan.describe());
            return Ok(Outcome::Submitted { failed: 0 });
        }
        let jobs = submit(out, &plan, &pending)?;
        if !self.options.wait {
            return Ok(Outcome::Submitted { failed: 0 });
        }
        wait(out, run.hashes, &pending, &jobs, run.quiet)?;
        Ok(summarize(&exp.name, out, run.hashes, &pending, &jobs[1]))
    }
}

/// Submits the array and the collect job and records them in `slurm/jobs.json`; returns
/// their ids.
fn submit(out: &OutputDir, plan: &SubmissionPlan, pending: &[usize]) -> Result<[String; 2]> {
    let array_job = sbatch(&plan.array_args, &plan.dir.join("array.sh"))?;
    let mut collect_args = plan.collect_args.clone();
    collect_args.push(format!("--dependency=afterany:{array_job}"));
    let collect_job = sbatch(&collect_args, &plan.dir.join("collect.sh"))?;
    let mut jobs = read_jobs(out);
    jobs.submissions.push(Submission {
        array_job: array_job.clone(),
        collect_job: collect_job.clone(),
        tasks: plan.tasks.len(),
        cells: pending.to_vec(),
        submitted_at: std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map(|d| d.as_secs())
            .unwrap_or(0),
    });
    volphot::write_atomic(
        &out.root().join("slurm").join("jobs.json"),
        serde_json::to_string_pretty(&jobs)?.as_bytes(),
    )?;
    println!(
        "submitted array job {array_job} ({} tasks, {} cells) and collect job {collect_job}",
        plan.tasks.len(),
        pending.len()
    );
    println!("status: sweep status {}", out.root().display());
    Ok([array_job, collect_job])
}

/// After waiting: how many submitted cells finished and whether the report was written.
fn summarize(
    name: &str,
    out: &OutputDir,
    hashes: &[String],
    pending: &[usize],
    collect_job: &str,
) -> Outcome {
    let done = pending
        .iter()
        .filter(|&&i| is_done(&out.cell(&hashes[i])))
        .count();
    let failed = pending.len() - done;
    let collect_ok = out.root().join("report.html").is_file();
    eprintln!(
        "{name}: {done} of {} submitted cells finished, {failed} failed; collect job {collect_job} {}",
        pending.len(),
        if collect_ok {
            "wrote the report"
        } else {
            "did not write a report"
        }
    );
    Outcome::Submitted {
        failed: failed + usize::from(!collect_ok),
    }
}

fn write_script(path: &Path, text: &str) -> Result<()> {
    volphot::write_atomic(path, text.as_bytes())?;
    use std::os::unix::fs::PermissionsExt;
    std::fs::set_permissions(path, std::fs::Permissions::from_mode(0o755))?;
    Ok(())
}

/// Polls `squeue` until the jobs have left the queue, with a progress bar of finished cells.
fn wait(
    out: &OutputDir,
    hashes: &[String],
    pending: &[usize],
    jobs: &[String],
    quiet: bool,
) -> Result<()> {
    let multi = crate::progress::multi(quiet);
    let bar = crate::progress::bar(&multi, pending.len() as u64, "slurm", "cells");
    let start = Instant::now();
    loop {
        let done = pending
            .iter()
            .filter(|&&i| is_done(&out.cell(&hashes[i])))
            .count();
        bar.set_position(done as u64);
        match queued(jobs) {
            Some(q) if q.is_empty() => break,
            Some(_) => {}
            None => anyhow::bail!("squeue is not available to follow jobs {}", jobs.join(",")),
        }
        std::thread::sleep(Duration::from_millis(
            if start.elapsed() < Duration::from_secs(10) {
                250
            } else {
                1000
            },
        ));
    }
    bar.finish_and_clear();
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Experiment `name` (its `text`) over a small scene in `dir`.
    fn experiment(dir: &Path, name: &str, text: &str) -> Experiment {
        let scene = format!(
            "{}[camera]\nresolution = [8, 8]\n",
            volphot::test_util::SMALL_SCENE
        );
        std::fs::write(dir.join("s.toml"), scene).unwrap();
        let path = dir.join(format!("{name}.toml"));
        std::fs::write(&path, text).unwrap();
        Experiment::load(&path).unwrap()
    }

    /// The line of `array.sh` that runs a task's cells.
    fn task_line(exp: &Experiment, dir: &Path, options: &SlurmOptions) -> String {
        let cells = exp.plan(Quality::Default).unwrap();
        let plan = plan_submission(exp, &cells, dir, options, Quality::Default, None).unwrap();
        let line = plan.array_script.lines().find(|l| l.contains("--cells"));
        line.unwrap().to_string()
    }

    #[test]
    fn a_tunes_array_tasks_rebuild_its_cells_with_sweep_tune() {
        let dir = tempfile::tempdir().unwrap();
        let grid =
            "scene = \"s.toml\"\n[axes]\n\"integrator.nused\" = [5, 9]\n[reference]\nspp = 4\n";
        let tune = format!(
            "{grid}[tune]\nobjective = \"rmse\"\nbudget = {{ renders = 4 }}\n[tune.fidelity]\nresolution = [8, 8]\nlevels = 1\n[tune.space]\n\"integrator.maxdist\" = {{ range = [0.1, 0.5] }}\n"
        );
        for (name, text, verb) in [
            ("grid", grid.to_string(), " run "),
            ("tune", tune, " tune "),
        ] {
            let exp = experiment(dir.path(), name, &text);
            let line = task_line(&exp, dir.path(), &SlurmOptions::default());
            assert!(line.contains(verb), "{name}: {line}");
            assert!(line.contains("--no-report"), "{name}: {line}");
        }
    }

    #[test]
    fn array_tasks_share_the_runs_reference_pool() {
        let dir = tempfile::tempdir().unwrap();
        let exp = experiment(
            dir.path(),
            "grid",
            "scene = \"s.toml\"\n[reference]\nspp = 4\n",
        );
        let line = task_line(&exp, dir.path(), &SlurmOptions::default());
        assert!(!line.contains("--reference-pool"), "{line}");
        let pooled = SlurmOptions {
            reference_pool: Some(PathBuf::from("/shared/reference pool")),
            ..SlurmOptions::default()
        };
        let line = task_line(&exp, dir.path(), &pooled);
        assert!(
            line.contains(" --reference-pool '/shared/reference pool'"),
            "{line}"
        );
    }

    #[test]
    fn quoting() {
        assert_eq!(shell_quote("/a/b-c.toml"), "/a/b-c.toml");
        assert_eq!(shell_quote("a b"), "'a b'");
        assert_eq!(shell_quote("it's"), "'it'\\''s'");
    }
}
