//! Command-line interface (clap derive). The clap types stay here: each verb converts its
//! low-level arguments once into the validated options the rest of the program uses
//! (ripgrep's low/high args).

use std::path::{Path, PathBuf};

use anyhow::Result;
use clap::{Args, Parser, Subcommand, ValueEnum};

use crate::backend::{Backend, Local, Slurm, SlurmOptions};
use crate::bench::{BenchMode, BenchOptions};
use crate::plan::Quality;
use crate::render::CellFilter;
use crate::tune::{TuneMode, TuneOptions};

/// Parameter studies of volume photon mapping: render TOML grids of scenes and report what
/// changed and by how much.
#[derive(Debug, Parser)]
#[command(
    name = "sweep",
    version,
    override_usage = "sweep [OPTIONS] <EXPERIMENT.toml>   (same as `sweep run`)\n       sweep <COMMAND>",
    after_help = "Examples:\n  sweep experiments/artifacts.toml          run a study (same as `sweep run …`)\n  sweep render experiments/scenes/foot.toml -o out/\n  sweep datasets"
)]
pub(crate) struct Cli {
    /// Subcommand; without one, `sweep FILE.toml` runs the experiment.
    #[command(subcommand)]
    pub(crate) command: Command,
}

/// `sweep FILE.toml …` means `sweep run FILE.toml …`: inserts `run` when the first
/// positional argument is not a subcommand.
pub(crate) fn with_default_subcommand(
    mut args: Vec<std::ffi::OsString>,
) -> Vec<std::ffi::OsString> {
    use clap::CommandFactory;
    let command = Cli::command();
    let names: Vec<String> = command
        .get_subcommands()
        .flat_map(|c| {
            std::iter::once(c.get_name().to_string()).chain(c.get_all_aliases().map(str::to_string))
        })
        .chain(["help".to_string()])
        .collect();
    let first = args
        .iter()
        .skip(1)
        .position(|a| !a.to_string_lossy().starts_with('-'));
    let top_level_flag = args.iter().skip(1).any(|a| {
        let a = a.to_string_lossy();
        a == "-h" || a == "--help" || a == "-V" || a == "--version"
    });
    if let Some(i) = first
        && !names.contains(&args[i + 1].to_string_lossy().into_owned())
        && !(top_level_flag && i > 0)
    {
        args.insert(1, "run".into());
    }
    args
}

/// The command line parsed (after [`with_default_subcommand`]); a clap error ends the
/// process with clap's message and exit code.
pub(crate) fn parse(args: Vec<std::ffi::OsString>) -> Cli {
    try_parse(args).unwrap_or_else(|e| e.exit())
}

/// [`parse`] without ending the process. Every verb takes a negative number as an option's
/// value, so `--threads -1` reaches the option's own check and is refused naming the option,
/// the value and what it expects (clap read `-1` as an unknown flag: "unexpected argument
/// '-1'").
pub(crate) fn try_parse(args: Vec<std::ffi::OsString>) -> Result<Cli, clap::Error> {
    use clap::{CommandFactory, FromArgMatches};
    let command = Cli::command().mut_subcommands(|verb| verb.allow_negative_numbers(true));
    let mut matches = command.try_get_matches_from(with_default_subcommand(args))?;
    Cli::from_arg_matches_mut(&mut matches)
}

/// The verbs.
#[derive(Debug, Subcommand)]
pub(crate) enum Command {
    /// List the registered datasets and where they were found on the search path.
    #[command(
        after_help = "Example:\n  sweep datasets --verify\n\nSearch path: $VOLPHOT_DATA (colon-separated), ./data, ../shared/data."
    )]
    Datasets(DatasetsArgs),
    /// Render one scene file to EXR (all layers), PNG, PFM and a JSON sidecar.
    #[command(
        after_help = "Example:\n  sweep render experiments/scenes/foot.toml -o out/foot --threads 2 --integrator reference --spp 256"
    )]
    Render(RenderArgs),
    /// Print an experiment's cells and their estimated cost without rendering.
    #[command(after_help = "Example:\n  sweep plan experiments/artifacts.toml --paper")]
    Plan(PlanArgs),
    /// Run an experiment: render every cell, compute metrics, write CSV, plots and a report.
    #[command(
        after_help = "Examples:\n  sweep run experiments/artifacts.toml\n  sweep run experiments/artifacts.toml --cells 3,7-9 --output reports/artifacts\n  sweep run experiments/artifacts.toml --backend slurm --partition short --time 00:30:00 --mem 4G"
    )]
    Run(RunArgs),
    /// Regenerate figures and the report of an output folder from its CSV and images.
    #[command(after_help = "Example:\n  sweep report reports/artifacts")]
    Report(ReportArgs),
    /// Show which cells of an output folder are done, running, failed or pending.
    #[command(after_help = "Example:\n  sweep status reports/artifacts")]
    Status(StatusArgs),
    /// Check every number a document cites from a study against the committed data.
    #[command(
        after_help = "Examples:\n  sweep claims reports/REPRODUCTION.md README.md\n  sweep claims --uncited reports/REPRODUCTION.md\n\nA cited number carries its query in a comment right after it:\n  0.157<!-- = mean(single_vs_multiple-paper: ms_share where scene=skeleton, sigma.t=6) -->\nand a comparison states what must hold on the data, for instance for every seed:\n  <!-- holds: min_over(seed: mean(s: rmse where nused=25) - mean(s: rmse where nused=150)) > 0 -->\nA sentence that calls a change an effect (or none) states the verdict of the one rule for\nan effect over seeds, a paired t-test at the 5 % level (docs/experiments.md):\n  <!-- verdict: falls over(integrator.seed: value(s: rmse where nused=150) - value(s: rmse where nused=25)) -->\nThe words are rises, falls (the 95 % interval of the mean difference lies above or below\n0), none within δ (it lies inside ±δ, the smallest effect the sentence cares about) and\nunclear within δ (anything else, always with fewer than 3 seeds); a verdict fails when the\nrule gives another word. ci_low_over, ci_high_over, t_over and n_over give the interval,\nthe t statistic and the number of seeds as numbers.\nSources are study folders (their cells.csv), CSV, JSON or TOML files inside the document's\nfolder. Aggregates: value, mean, min, max, sum, count, median, sd, se, spread, and the same\nover groups (min_over(seed: …)); + - * /, abs and parentheses combine them. Every claim\nreads data, and every value it reduces must be a finite number (a NaN is an error). A\nnumber printed with one significant digit must be exact or carry a tolerance (`= … ±\n0.5`); a number that is not data is marked `<!-- given: why -->`."
    )]
    Claims(ClaimsArgs),
    /// Write DIR/index.html: one card per study folder in DIR, the paper and the benchmarks.
    #[command(after_help = "Example:\n  sweep index reports        (then open reports/index.html)")]
    Index(IndexArgs),
    /// Benchmark the thesis's headline frame (foot, 512², 40 000 photons, nused 150).
    #[command(
        after_help = "Example:\n  sweep bench --threads 2\n  sweep bench --quick          (a smaller frame on a phantom)\n  sweep bench --reference --json reports/bench/reference-thesis.json   (the path tracer's trackers)\n  sweep bench --reference --budget --json reports/bench/reference-budget.json   (where its noise comes from)\n  sweep bench --reference --routes --counters   (each render's collisions, lookups, bricks and shadow rays counted)"
    )]
    Bench(BenchArgs),
    /// Find the best settings: Hyperband over resolution and photon count with tree-Parzen
    /// proposals; Pareto front of error against render time, best scene files per time
    /// budget, sensitivity per parameter.
    #[command(
        after_help = "Examples:\n  sweep tune experiments/tune_thesis.toml --dry-run\n  sweep tune experiments/tune_thesis.toml --output reports/tune_thesis\n  sweep tune experiments/tune_thesis.toml --backend slurm --partition short --time 00:30:00"
    )]
    Tune(TuneArgs),
    /// Write a scene for another renderer (Mitsuba 3: XML and a .vol grid).
    #[command(
        after_help = "Example:\n  sweep export experiments/scenes/phantom-head.toml --format mitsuba -o peer/\n  mitsuba -D max_depth=2 peer/phantom-head.xml      (single scattering)"
    )]
    Export(ExportArgs),
    /// Import a scene of the thesis's pbrt-v1 system (`Volume "rawvolumegrid"`,
    /// `VolumeIntegrator "volphotonmap"`, camera, film, spot and point lights) as a volphot
    /// scene file; every line that has no volphot meaning is named.
    #[command(
        after_help = "Example:\n  sweep import thesis/foot.pbrt -o experiments/scenes/foot-thesis.toml\n  sweep render experiments/scenes/foot-thesis.toml -o out/"
    )]
    Import(ImportArgs),
}

/// `sweep import`.
#[derive(Debug, Args)]
pub(crate) struct ImportArgs {
    /// The pbrt-v1 scene file.
    pub(crate) scene: PathBuf,
    /// The volphot scene file to write (paths in it are made relative to its folder).
    #[arg(short, long)]
    pub(crate) output: PathBuf,
    /// Replace an existing output file.
    #[arg(long)]
    pub(crate) force: bool,
}

/// `sweep export`.
#[derive(Debug, Args)]
pub(crate) struct ExportArgs {
    /// Scene file (TOML).
    pub(crate) scene: PathBuf,
    /// Target renderer.
    #[arg(long, value_enum)]
    pub(crate) format: ExportFormat,
    /// Output folder.
    #[arg(short, long, default_value = "export")]
    pub(crate) output: PathBuf,
    /// Image size `WIDTHxHEIGHT` (overrides the scene's camera resolution).
    #[arg(long, value_parser = parse_resolution)]
    pub(crate) resolution: Option<[u32; 2]>,
}

/// A renderer `sweep export` writes for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub(crate) enum ExportFormat {
    /// Mitsuba 3 (`volpath`; XML scene + `.vol` grid of the transferred density).
    Mitsuba,
}

/// `sweep datasets`.
#[derive(Debug, Args)]
pub(crate) struct DatasetsArgs {
    /// Verify each file's sha256 (cached per file).
    #[arg(long)]
    pub(crate) verify: bool,
}

/// Renderer choice on the command line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub(crate) enum IntegratorChoice {
    /// Volume photon mapping with ray marching.
    Photon,
    /// The unbiased reference path tracer.
    Reference,
}

/// `sweep render`.
#[derive(Debug, Args)]
pub(crate) struct RenderArgs {
    /// Scene file (TOML).
    pub(crate) scene: PathBuf,
    /// Output folder.
    #[arg(short, long, default_value = "out")]
    pub(crate) output: PathBuf,
    /// Worker threads (default: all cores).
    #[arg(long, value_name = "N", value_parser = parse_threads)]
    pub(crate) threads: Option<usize>,
    /// Random seed (overrides the scene).
    #[arg(long)]
    pub(crate) seed: Option<u64>,
    /// Samples per pixel (eye rays for `photon`, paths for `reference`).
    #[arg(long)]
    pub(crate) spp: Option<u32>,
    /// Renderer (overrides the scene's `integrator.method`).
    #[arg(long, value_enum)]
    pub(crate) integrator: Option<IntegratorChoice>,
    /// Image size `WIDTHxHEIGHT` (overrides the scene's camera resolution).
    #[arg(long, value_parser = parse_resolution)]
    pub(crate) resolution: Option<[u32; 2]>,
    /// Write even where a file `sweep render` did not make would be replaced (a study's
    /// `plan.json` or `cells.json`, any other file of the same name), or into a study's
    /// folder. Without it those are refused before rendering; the files of an earlier
    /// render of the same scene are always replaced.
    #[arg(long)]
    pub(crate) force: bool,
    /// Hide the progress bar.
    #[arg(long, short)]
    pub(crate) quiet: bool,
}

/// Parses `512x512`.
pub(crate) fn parse_resolution(s: &str) -> Result<[u32; 2], String> {
    let (w, h) = s
        .split_once(['x', 'X'])
        .ok_or_else(|| format!("`{s}`: expected WIDTHxHEIGHT, e.g. 512x512"))?;
    let parse = |v: &str| {
        v.trim()
            .parse::<u32>()
            .ok()
            .filter(|n| (1..=16384).contains(n))
            .ok_or_else(|| format!("`{s}`: expected WIDTHxHEIGHT with integers in 1..=16384"))
    };
    Ok([parse(w)?, parse(h)?])
}

/// Quality flags shared by `plan` and `run`.
#[derive(Debug, Clone, Args)]
pub(crate) struct QualityArgs {
    /// Minute-scale preview: lower resolution and fewer photons.
    #[arg(long, conflicts_with = "paper")]
    pub(crate) quick: bool,
    /// Thesis resolution (512×512) and the paper grid.
    #[arg(long)]
    pub(crate) paper: bool,
}

impl QualityArgs {
    /// The selected preset.
    pub(crate) fn quality(&self) -> Quality {
        if self.quick {
            Quality::Quick
        } else if self.paper {
            Quality::Paper
        } else {
            Quality::Default
        }
    }
}

/// `sweep plan`.
#[derive(Debug, Args)]
pub(crate) struct PlanArgs {
    /// Experiment file (TOML).
    pub(crate) experiment: PathBuf,
    #[command(flatten)]
    pub(crate) quality: QualityArgs,
    /// Also print the sbatch lines a Slurm run would submit.
    #[arg(long)]
    pub(crate) slurm: bool,
    /// After the summary, list every cell: index, address, estimated seconds, axis values.
    #[arg(long)]
    pub(crate) list: bool,
    /// Plan a grid larger than the experiment's `max_cells` (as `sweep run --yes`).
    #[arg(long, short)]
    pub(crate) yes: bool,
    /// March groups rendered at once, as `sweep run --jobs`: the wall time is estimated for
    /// it.
    #[arg(long, default_value_t = 1)]
    pub(crate) jobs: usize,
    /// Worker threads per job, as `sweep run --threads` (default: all cores); the pilots
    /// render on as many.
    #[arg(long, value_name = "N", value_parser = parse_threads)]
    pub(crate) threads: Option<usize>,
    /// Count references the pool (`sweep run --reference-pool`) already holds as done, and
    /// those it holds at fewer samples per pixel as refined from there.
    #[arg(long, value_name = "DIR")]
    pub(crate) reference_pool: Option<PathBuf>,
    /// Estimate from the model calibrated on one frame instead of timing pilot renders
    /// (each march group at 32 pixels a side on this machine, about 1/250 of a 512² run):
    /// instant, but 0.8–2.6× off at the median of the committed studies.
    #[arg(long)]
    pub(crate) no_pilot: bool,
}

/// Where cells are rendered.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, ValueEnum)]
pub(crate) enum BackendChoice {
    /// On this machine.
    #[default]
    Local,
    /// As a Slurm job array plus a collect job.
    Slurm,
}

/// Slurm options of `sweep run --backend slurm`.
#[derive(Debug, Clone, Args, Default)]
pub(crate) struct SlurmArgs {
    /// Partition (`sbatch --partition`).
    #[arg(long)]
    pub(crate) partition: Option<String>,
    /// Time limit per task (`sbatch --time`), e.g. 00:30:00.
    #[arg(long)]
    pub(crate) time: Option<String>,
    /// Memory per task (`sbatch --mem`), e.g. 4G.
    #[arg(long)]
    pub(crate) mem: Option<String>,
    /// CPUs per task (`sbatch --cpus-per-task`).
    #[arg(long)]
    pub(crate) cpus_per_task: Option<u32>,
    /// At most this many array tasks at once (`--array=0-N%K`).
    #[arg(long)]
    pub(crate) max_concurrent: Option<u32>,
    /// Extra argument passed to every sbatch call (repeatable).
    #[arg(long = "sbatch-arg", allow_hyphen_values = true)]
    pub(crate) sbatch_args: Vec<String>,
    /// Cells per array task (default: grouped by shared photon map, and so that the array
    /// fits the cluster's MaxArraySize).
    #[arg(long)]
    pub(crate) cells_per_task: Option<usize>,
}

/// `sweep run` (also `sweep FILE.toml`).
#[derive(Debug, Clone, Args)]
pub(crate) struct RunArgs {
    /// Experiment file (TOML).
    pub(crate) experiment: PathBuf,
    #[command(flatten)]
    pub(crate) quality: QualityArgs,
    /// Output folder (default: `out/<name>/`, or `out/<name>-quick/` with --quick and
    /// `out/<name>-paper/` with --paper; `<name>` is the experiment's).
    #[arg(short, long)]
    pub(crate) output: Option<PathBuf>,
    /// Render only these cells, e.g. `3,7-9` (for outside schedulers).
    #[arg(long, conflicts_with = "shard")]
    pub(crate) cells: Option<String>,
    /// Render only shard i of n (0-based), e.g. `2/8`.
    #[arg(long)]
    pub(crate) shard: Option<String>,
    /// March groups rendered at once (each on all threads, or on `--threads`).
    #[arg(long, default_value_t = 1)]
    pub(crate) jobs: usize,
    /// Worker threads (default: all cores).
    #[arg(long, value_name = "N", value_parser = parse_threads)]
    pub(crate) threads: Option<usize>,
    /// Accept a grid larger than the experiment's `max_cells` limit.
    #[arg(long, short)]
    pub(crate) yes: bool,
    /// Hide progress bars.
    #[arg(long, short)]
    pub(crate) quiet: bool,
    /// Skip building the report after rendering (outside schedulers collect later).
    #[arg(long)]
    pub(crate) no_report: bool,
    /// Time limit per render, in seconds: a cell (or a march of cells that share one pass,
    /// or a reference) still running after it is stopped and recorded as failed, and the
    /// rest of the grid goes on.
    #[arg(long, value_name = "SECONDS", value_parser = parse_timeout)]
    pub(crate) cell_timeout: Option<std::time::Duration>,
    /// Share path-traced references with other studies through this folder: one another
    /// study rendered at the same samples per pixel is copied from it, one rendered at
    /// fewer is refined (to the image a whole run gives, bit for bit).
    #[arg(long, value_name = "DIR")]
    pub(crate) reference_pool: Option<PathBuf>,
    /// Where cells are rendered.
    #[arg(long, value_enum, default_value_t = BackendChoice::Local)]
    pub(crate) backend: BackendChoice,
    #[command(flatten)]
    pub(crate) slurm: SlurmArgs,
    /// Slurm: print the sbatch lines and write the scripts without submitting.
    #[arg(long)]
    pub(crate) dry_run: bool,
    /// Slurm: block with a progress bar until the collect job has finished.
    #[arg(long)]
    pub(crate) wait: bool,
}

/// `sweep tune`.
#[derive(Debug, Clone, Args)]
pub(crate) struct TuneArgs {
    /// Experiment file with a `[tune]` section.
    pub(crate) experiment: PathBuf,
    /// Output folder (default: `out/<experiment name>/`).
    #[arg(short, long)]
    pub(crate) output: Option<PathBuf>,
    /// Check the file and every searched key, print the Hyperband schedule and what the
    /// budget allows, and render nothing.
    #[arg(long)]
    pub(crate) dry_run: bool,
    /// Cells rendered at once (local backend; each on all threads, or on `--threads`).
    #[arg(long, default_value_t = 1)]
    pub(crate) jobs: usize,
    /// Worker threads (default: all cores).
    #[arg(long, value_name = "N", value_parser = parse_threads)]
    pub(crate) threads: Option<usize>,
    /// Hide progress bars.
    #[arg(long, short)]
    pub(crate) quiet: bool,
    /// Skip building the reports (array tasks; `sweep report DIR` builds them later).
    #[arg(long)]
    pub(crate) no_report: bool,
    /// Time limit per render, in seconds (a cell still running after it fails, which
    /// counts as an infinite error).
    #[arg(long, value_name = "SECONDS", value_parser = parse_timeout)]
    pub(crate) cell_timeout: Option<std::time::Duration>,
    /// Where each rung is rendered (Slurm: one job array per rung, waited for).
    #[arg(long, value_enum, default_value_t = BackendChoice::Local)]
    pub(crate) backend: BackendChoice,
    #[command(flatten)]
    pub(crate) slurm: SlurmArgs,
    /// Render only these cells of the output folder's `plan.json` (what a Slurm array
    /// task of a tune runs).
    #[arg(long, hide = true)]
    pub(crate) cells: Option<String>,
}

/// `sweep report`.
#[derive(Debug, Args)]
pub(crate) struct ReportArgs {
    /// Output folder of a run.
    pub(crate) dir: PathBuf,
    /// Change only where the explorer in `report.html` opens, to the folder's
    /// `experiment.toml` `[report] pair`: a clone holds a committed study's page and pixel
    /// data but not the cells' data, so the rest of its report cannot be rebuilt there.
    #[arg(long)]
    pub(crate) explorer_opening: bool,
}

/// `sweep status`.
#[derive(Debug, Args)]
pub(crate) struct StatusArgs {
    /// Output folder of a run.
    pub(crate) dir: PathBuf,
}

/// `sweep index`.
#[derive(Debug, Args)]
pub(crate) struct IndexArgs {
    /// The folder holding the study folders (`reports`).
    pub(crate) dir: PathBuf,
}

/// `sweep claims`.
#[derive(Debug, Args)]
pub(crate) struct ClaimsArgs {
    /// Markdown documents whose cited numbers are checked.
    #[arg(required = true)]
    pub(crate) documents: Vec<PathBuf>,
    /// Rewrite every number that differs from its data, in the same form (same decimals).
    #[arg(long, conflicts_with = "uncited")]
    pub(crate) update: bool,
    /// Print every claim, not only those that differ or cannot be checked.
    #[arg(long, short)]
    pub(crate) verbose: bool,
    /// Resolve the claims' sources against this folder instead of each document's own
    /// (sources must stay inside it).
    #[arg(long, value_name = "DIR")]
    pub(crate) base: Option<PathBuf>,
    /// A document without any claim is not an error.
    #[arg(long)]
    pub(crate) allow_empty: bool,
    /// List the numbers that look measured (a decimal, or a unit such as %, ×, s) and carry
    /// no `=` claim, and the comments that hide text from the review (never closed, or not
    /// rendered as one comment); fails when there is any.
    #[arg(long)]
    pub(crate) uncited: bool,
}

/// `sweep bench`.
#[derive(Debug, Args)]
pub(crate) struct BenchArgs {
    /// A small frame on the foot phantom instead of the real foot at 512².
    #[arg(long)]
    pub(crate) quick: bool,
    /// Worker threads of the multi-threaded runs (default: all cores).
    #[arg(long, value_name = "N", value_parser = parse_threads)]
    pub(crate) threads: Option<usize>,
    /// Scene to benchmark instead of the headline frame.
    #[arg(long)]
    pub(crate) scene: Option<PathBuf>,
    /// Run only these configurations (comma-separated; default: all).
    #[arg(long, value_enum, value_delimiter = ',')]
    pub(crate) only: Vec<BenchConfig>,
    /// Renders of each configuration: the table shows the render time's mean ± σ and min,
    /// the JSON every run's times.
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=1000))]
    pub(crate) runs: u32,
    /// Passes of the path tracer: in the efficiency comparison (default 16) and for the
    /// converged reference of `--peer`, `--estimators` and `--reference` (default 1024).
    #[arg(long, value_parser = clap::value_parser!(u32).range(2..=1_000_000))]
    pub(crate) reference_passes: Option<u32>,
    /// Compare with a peer renderer instead: the scene exported, rendered by both at several
    /// sample counts, errors against a converged reference versus CPU-seconds.
    #[arg(long, value_enum)]
    pub(crate) peer: Option<Peer>,
    /// Compare the multiple-scattering estimators instead (points at the scene's photons
    /// and 10×, progressive, beam and progressive beams over replayed or fresh eye rays and
    /// each radius rule, photon planes) with the path tracer: RMSE of the whole image
    /// against a converged reference versus CPU-seconds, each layer's error, and the
    /// CPU-seconds to RMSE 0.02 and 0.01 read off each iterating row's error curve.
    #[arg(long, conflicts_with = "peer")]
    pub(crate) estimators: bool,
    /// Compare the path tracer's trackers instead (delta, the tracer before issue #47, and
    /// weighted, the default): CPU time to RMSE 0.02 and 0.01 against a converged reference
    /// kept in the reference pool, on the headline frame and the phantom head (or
    /// `--scene`) at each `--sigma-t`.
    #[arg(long, conflicts_with_all = ["peer", "estimators", "only"])]
    pub(crate) reference: bool,
    /// σt(d_min) (the scene's σ mapping must be the thesis's): with `--reference` the
    /// values compared (comma-separated, default 80,6); otherwise one value, set on the
    /// benchmarked scene.
    #[arg(long, value_delimiter = ',', value_parser = parse_sigma_t)]
    pub(crate) sigma_t: Vec<f32>,
    /// With `--reference`: passes of each measured render (the first is timed apart, as
    /// it holds the weighted tracker's pilot).
    #[arg(long, default_value_t = 32, requires = "reference", value_parser = clap::value_parser!(u32).range(2..=100_000))]
    pub(crate) passes: u32,
    /// With `--reference`: the variance budget of the default tracker instead — where its
    /// noise comes from (pixel footprint, first free path, transmittance, light choice,
    /// roulette, multiple-scattering paths), by pixel class, and the CPU time of each part.
    #[arg(long, requires = "reference")]
    pub(crate) budget: bool,
    /// With `--reference`: also race the routes to a faster reference (stratified eye
    /// samples, a visibility-weighted light choice, both) against the trackers.
    #[arg(long, requires = "reference", conflicts_with = "budget")]
    pub(crate) routes: bool,
    /// With `--reference`: count each render's work in its last pass (null and real
    /// collisions, ratio-tracking steps, density lookups, majorant bricks, shadow rays),
    /// timed apart from the other passes, so that what counting costs is measured beside
    /// it; the image is the same to the bit.
    #[arg(long, requires = "reference", conflicts_with = "budget")]
    pub(crate) counters: bool,
    /// With `--budget`: samples per pixel of each of its rungs.
    #[arg(long, default_value_t = 16, requires = "budget", value_parser = clap::value_parser!(u32).range(2..=4096))]
    pub(crate) budget_samples: u32,
    /// With `--reference`: where converged references are kept and found again (default
    /// reports/reference-pool, as `sweep run --reference-pool`).
    #[arg(long, value_name = "DIR", requires = "reference")]
    pub(crate) reference_pool: Option<PathBuf>,
    /// Python with Mitsuba 3 installed (default: $VOLPHOT_MITSUBA_PYTHON, else python3);
    /// `scripts/peer-mitsuba.sh` makes one.
    #[arg(long)]
    pub(crate) python: Option<PathBuf>,
    /// Samples per pixel of the peer comparison's renders (comma-separated).
    #[arg(long, value_delimiter = ',', default_value = "4,16,64", value_parser = clap::value_parser!(u32).range(1..=65_536))]
    pub(crate) peer_spp: Vec<u32>,
    /// Seeds per setting of the peer comparison (the spread of their means is the noise).
    #[arg(long, default_value_t = 4, value_parser = clap::value_parser!(u32).range(2..=64))]
    pub(crate) seeds: u32,
    /// Image size `WIDTHxHEIGHT` (overrides the scene's).
    #[arg(long, value_parser = parse_resolution)]
    pub(crate) resolution: Option<[u32; 2]>,
    /// Keep the peer comparison's files here (default: a temporary folder).
    #[arg(long)]
    pub(crate) peer_dir: Option<PathBuf>,
    /// Write the measurements as JSON here. An existing file is replaced only by the same
    /// bench measured again (the same kind, scene, image size, σt, lighting and
    /// configurations, as its recorded command line says); another bench's file, or a file
    /// `sweep bench` did not write, is refused before any work unless --force.
    #[arg(long)]
    pub(crate) json: Option<PathBuf>,
    /// Replace the --json file whatever it holds.
    #[arg(long, requires = "json")]
    pub(crate) force: bool,
    /// Write `--json` inside the repository even with uncommitted changes (its `commit`
    /// then ends in `-dirty`).
    #[arg(long, requires = "json")]
    pub(crate) allow_dirty: bool,
    /// Light the scene's `[three_point]` layout in this style (default: as the scene says).
    #[arg(long, value_enum)]
    pub(crate) lighting: Option<Lighting>,
}

/// The style of the three-point layout's lights (`sweep bench --lighting`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub(crate) enum Lighting {
    /// Key, fill and rim spot lights (the thesis's).
    Spots,
    /// A soft area key light and a sky (cinematic rendering's light).
    Cinematic,
}

impl Lighting {
    fn style(self) -> volphot::LightingStyle {
        match self {
            Lighting::Spots => volphot::LightingStyle::Spots,
            Lighting::Cinematic => volphot::LightingStyle::Cinematic,
        }
    }
}

/// A peer renderer `sweep bench --peer` compares with.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub(crate) enum Peer {
    /// Mitsuba 3 (`volpath`), through `scripts/peer_mitsuba.py`.
    Mitsuba,
}

/// A configuration `sweep bench --only` names: the bench's own, with the name and help it
/// gives (the list lives once, in `bench`; the command line only reads it).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct BenchConfig(crate::bench::BenchConfig);

impl ValueEnum for BenchConfig {
    fn value_variants<'a>() -> &'a [Self] {
        static ALL: std::sync::LazyLock<Vec<BenchConfig>> = std::sync::LazyLock::new(|| {
            crate::bench::BenchConfig::ALL
                .iter()
                .map(|&c| BenchConfig(c))
                .collect()
        });
        &ALL
    }

    fn to_possible_value(&self) -> Option<clap::builder::PossibleValue> {
        Some(clap::builder::PossibleValue::new(self.0.name()).help(self.0.help()))
    }
}

/// Parses `--cell-timeout` (seconds, > 0).
fn parse_timeout(s: &str) -> Result<std::time::Duration, String> {
    s.trim()
        .parse::<f64>()
        .ok()
        .filter(|v| v.is_finite() && *v > 0.0 && *v <= 1e7)
        .map(std::time::Duration::from_secs_f64)
        .ok_or_else(|| format!("`{s}`: expected a time limit in seconds, > 0 (e.g. 600)"))
}

/// Largest `--threads` accepted: more workers than this only add scheduling overhead.
const MAX_THREADS: usize = 1024;

/// Reads `--threads` for every verb alike: 1 to [`MAX_THREADS`] worker threads (omitting
/// it uses every core; 0 is not a way to say so).
fn parse_threads(text: &str) -> Result<usize, String> {
    text.trim()
        .parse::<usize>()
        .ok()
        .filter(|n| (1..=MAX_THREADS).contains(n))
        .ok_or_else(|| {
            format!(
                "`{text}`: expected a number of worker threads in 1..={MAX_THREADS} (omit --threads to use every core)"
            )
        })
}

impl SlurmArgs {
    /// The validated Slurm options.
    pub(crate) fn options(
        &self,
        cell_timeout: Option<std::time::Duration>,
        reference_pool: Option<&Path>,
        dry_run: bool,
        wait: bool,
    ) -> SlurmOptions {
        SlurmOptions {
            partition: self.partition.clone(),
            time: self.time.clone(),
            mem: self.mem.clone(),
            cpus_per_task: self.cpus_per_task,
            max_concurrent: self.max_concurrent,
            sbatch_args: self.sbatch_args.clone(),
            cells_per_task: self.cells_per_task,
            dry_run,
            wait,
            cell_timeout,
            reference_pool: reference_pool
                .map(|p| std::path::absolute(p).unwrap_or_else(|_| p.to_path_buf())),
        }
    }
}

impl RunArgs {
    /// The cells to render: `--cells` ranges, a `--shard`, or all.
    pub(crate) fn cell_filter(&self) -> Result<CellFilter> {
        match (&self.cells, &self.shard) {
            (Some(c), _) => CellFilter::parse_cells(c),
            (None, Some(s)) => CellFilter::parse_shard(s),
            (None, None) => Ok(CellFilter::All),
        }
    }

    /// The backend, chosen once.
    pub(crate) fn backend(&self) -> Result<Box<dyn Backend>> {
        // Without this check the local backend ignored `--dry-run` and rendered every cell.
        anyhow::ensure!(
            !self.dry_run || self.backend == BackendChoice::Slurm,
            "--dry-run writes Slurm job scripts without submitting them: with --backend local it has nothing to hold back; use `sweep plan EXPERIMENT` to list the cells and their cost without rendering, or --backend slurm --dry-run"
        );
        backend(
            self.backend,
            self.jobs,
            self.threads,
            self.slurm.options(
                self.cell_timeout,
                self.reference_pool.as_deref(),
                self.dry_run,
                self.wait,
            ),
        )
    }
}

/// The backend of a choice, with `--jobs` and `--threads` checked.
fn backend(
    choice: BackendChoice,
    jobs: usize,
    threads: Option<usize>,
    slurm: SlurmOptions,
) -> Result<Box<dyn Backend>> {
    anyhow::ensure!(
        jobs >= 1,
        "--jobs {jobs}: expected at least 1 march group at a time"
    );
    Ok(match choice {
        BackendChoice::Local => Box::new(Local { jobs, threads }),
        BackendChoice::Slurm => Box::new(Slurm { options: slurm }),
    })
}

/// Reads a σt as a 64-bit number and refuses what a 32-bit float cannot hold: `1e39`
/// would otherwise become infinity and be reported as `inf`, not as what was typed.
fn parse_sigma_t(text: &str) -> Result<f32, String> {
    let v: f64 = text
        .trim()
        .parse()
        .map_err(|_| format!("`{text}`: expected a number"))?;
    if !(v.is_finite() && v > 0.0 && v <= f64::from(f32::MAX)) {
        return Err(format!(
            "`{text}`: expected a finite σt(d_min) > 0 and at most {:e} (a 32-bit float)",
            f32::MAX
        ));
    }
    Ok(v as f32)
}

/// A folder a verb will write into: refused before any work when it, or a folder on its
/// way, is a file (the error came only after a whole bench, as "File exists").
pub(crate) fn check_output_folder(flag: &str, path: &Path) -> Result<()> {
    for ancestor in path.ancestors().filter(|a| !a.as_os_str().is_empty()) {
        match std::fs::metadata(ancestor) {
            Ok(m) if m.is_dir() => return Ok(()),
            Ok(_) if ancestor == path => anyhow::bail!(
                "{flag} {}: is a file; expected a folder (new or one this verb wrote)",
                path.display()
            ),
            Ok(_) => anyhow::bail!(
                "{flag} {}: {} is a file, so no folder can be made below it",
                path.display(),
                ancestor.display()
            ),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => continue,
            Err(e) => {
                return Err(anyhow::Error::new(e).context(format!("{flag} {}", path.display())));
            }
        }
    }
    Ok(())
}

/// A file a verb will write: not a folder, and its folder can be made.
pub(crate) fn check_output_file(flag: &str, path: &Path) -> Result<()> {
    anyhow::ensure!(
        !path.is_dir(),
        "{flag} {}: is a folder; expected a file name",
        path.display()
    );
    for ancestor in path
        .ancestors()
        .skip(1)
        .filter(|a| !a.as_os_str().is_empty())
    {
        match std::fs::metadata(ancestor) {
            Ok(m) if m.is_dir() => return Ok(()),
            Ok(_) => anyhow::bail!(
                "{flag} {}: {} is a file, so no folder can be made below it",
                path.display(),
                ancestor.display()
            ),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => continue,
            Err(e) => {
                return Err(anyhow::Error::new(e).context(format!("{flag} {}", path.display())));
            }
        }
    }
    Ok(())
}

/// What a bench measures, as its command line says: two command lines with equal
/// measures re-measure one bench (more runs, seeds or threads measure it more precisely).
#[derive(Debug)]
struct Measures {
    /// The scene: its resolved path when the file exists here, and its file name (a path
    /// recorded outside the working folder keeps only its name, `…/foot.toml`).
    scene: (Option<PathBuf>, String),
    /// `(name, value)` of every other option that decides what is measured.
    fields: Vec<(&'static str, String)>,
}

impl Measures {
    /// What differs, as `name A here, B there`.
    fn differences(&self, other: &Measures) -> Vec<String> {
        let same_scene = match (&self.scene.0, &other.scene.0) {
            (Some(a), Some(b)) => a == b,
            _ => self.scene.1 == other.scene.1,
        };
        let scene =
            (!same_scene).then(|| format!("scene {} here, {} there", self.scene.1, other.scene.1));
        scene
            .into_iter()
            .chain(
                self.fields
                    .iter()
                    .zip(&other.fields)
                    .filter(|(a, b)| a.1 != b.1)
                    .map(|(a, b)| format!("{} {} here, {} there", a.0, a.1, b.1)),
            )
            .collect()
    }
}

impl BenchArgs {
    /// The kind of bench, as `--help` names it.
    fn kind(&self) -> &'static str {
        match (self.peer, self.estimators, self.reference) {
            (Some(Peer::Mitsuba), _, _) => "--peer mitsuba",
            (None, true, _) => "--estimators",
            (None, false, true) if self.budget => "--reference --budget",
            (None, false, true) if self.routes => "--reference --routes",
            (None, false, true) => "--reference",
            (None, false, false) => "the configurations",
        }
    }

    /// What this command line measures ([`Measures`]).
    fn measures(&self) -> Measures {
        let scene = self.scene.clone().unwrap_or_else(|| {
            Path::new("experiments/scenes").join(if self.quick {
                "phantom-foot.toml"
            } else {
                "foot.toml"
            })
        });
        let name = scene
            .file_name()
            .map_or(String::new(), |n| n.to_string_lossy().into_owned());
        let scene = (std::fs::canonicalize(&scene).ok(), name);
        let sigma_t = if self.sigma_t.is_empty() && self.reference {
            vec![80.0, 6.0]
        } else {
            self.sigma_t.clone()
        };
        let named = |v: Option<clap::builder::PossibleValue>| {
            v.map_or(String::new(), |v| v.get_name().to_string())
        };
        let mut only: Vec<String> = self
            .only
            .iter()
            .map(|c| named(c.to_possible_value()))
            .collect();
        only.sort();
        let list = |items: Vec<String>, none: &str| {
            if items.is_empty() {
                none.to_string()
            } else {
                items.join(",")
            }
        };
        let fields = vec![
            ("kind", self.kind().to_string()),
            ("quick", self.quick.to_string()),
            (
                "resolution",
                self.resolution
                    .map_or("the scene's".to_string(), |[w, h]| format!("{w}x{h}")),
            ),
            (
                "sigma-t",
                list(sigma_t.iter().map(f32::to_string).collect(), "the scene's"),
            ),
            (
                "lighting",
                self.lighting
                    .map_or("the scene's".to_string(), |l| named(l.to_possible_value())),
            ),
            ("only", list(only, "all")),
        ];
        Measures { scene, fields }
    }

    /// Refuses, before any work, a `--json` file that holds something else than this bench
    /// measured before: another bench's measurements (told by its recorded command line),
    /// or a file `sweep bench` did not write. `--force` replaces it anyway.
    fn check_replaces_only_this_bench(&self, json: &Path) -> Result<()> {
        if self.force || json.symlink_metadata().is_err() {
            return Ok(());
        }
        let recorded = recorded_bench(json);
        let advice = "name another file, or pass --force to replace it";
        let Some((command, old)) = recorded else {
            anyhow::bail!(
                "--json {}: exists, and `sweep bench` did not write it (no recorded `sweep bench` command line in it); {advice}",
                json.display()
            );
        };
        let differences = self.measures().differences(&old.measures());
        anyhow::ensure!(
            differences.is_empty(),
            "--json {}: holds another bench (`{}`): {}; {advice}",
            json.display(),
            command.join(" "),
            differences.join(", ")
        );
        Ok(())
    }

    /// The validated options of `sweep bench`: where it writes is checked before it works.
    pub(crate) fn options(&self) -> Result<BenchOptions> {
        if let Some(json) = &self.json {
            check_output_file("--json", json)?;
            self.check_replaces_only_this_bench(json)?;
            crate::bench::check_clean_for(json, self.allow_dirty)?;
        }
        if let Some(pool) = &self.reference_pool {
            check_output_folder("--reference-pool", pool)?;
        }
        if let Some(dir) = &self.peer_dir {
            check_output_folder("--peer-dir", dir)?;
        }
        let mode = match (self.peer, self.estimators, self.reference) {
            (Some(Peer::Mitsuba), _, _) => BenchMode::Peer,
            (None, true, _) => BenchMode::Estimators,
            (None, false, true) => BenchMode::Reference,
            (None, false, false) => BenchMode::Configurations,
        };
        Ok(BenchOptions {
            mode,
            quick: self.quick,
            threads: self.threads,
            scene: self.scene.clone(),
            only: self.only.iter().map(|c| c.0).collect(),
            runs: self.runs,
            reference_passes: self.reference_passes,
            python: self.python.clone(),
            peer_spp: self.peer_spp.clone(),
            seeds: self.seeds,
            resolution: self.resolution,
            peer_dir: self.peer_dir.clone(),
            json: self.json.clone(),
            sigma_t: if self.sigma_t.is_empty() && self.reference {
                vec![80.0, 6.0]
            } else {
                self.sigma_t.clone()
            },
            passes: self.passes,
            reference_pool: self.reference_pool.clone(),
            budget: self.budget,
            budget_samples: self.budget_samples,
            routes: self.routes,
            counters: self.counters,
            lighting: self.lighting.map(Lighting::style),
        })
    }
}

/// The command line a bench JSON recorded (`machine.command`) and its arguments, when it
/// is one of `sweep bench` that this version reads.
fn recorded_bench(json: &Path) -> Option<(Vec<String>, BenchArgs)> {
    let text = volphot::read_text_capped(json, volphot::TEXT_INPUT_CAP, "bench JSON").ok()?;
    let value: serde_json::Value = serde_json::from_str(&text).ok()?;
    let command: Vec<String> = value
        .pointer("/machine/command")?
        .as_array()?
        .iter()
        .map(|a| a.as_str().map(str::to_string))
        .collect::<Option<_>>()?;
    match try_parse(command.iter().map(Into::into).collect())
        .ok()?
        .command
    {
        Command::Bench(bench) => Some((command, bench)),
        _ => None,
    }
}

impl TuneArgs {
    /// The validated options of `sweep tune`.
    pub(crate) fn options(&self) -> Result<TuneOptions> {
        if let Some(output) = &self.output {
            check_output_folder("--output", output)?;
        }
        let mode = match (&self.cells, self.dry_run) {
            (Some(_), true) => anyhow::bail!("--cells and --dry-run: expected at most one"),
            (Some(c), false) => {
                anyhow::ensure!(
                    self.backend == BackendChoice::Local,
                    "--cells {c}: renders cells of the plan here; expected --backend local"
                );
                TuneMode::Cells(CellFilter::parse_cells(c)?)
            }
            (None, true) => TuneMode::DryRun,
            (None, false) => TuneMode::Search,
        };
        // A tune waits for each rung: its results decide the next.
        let slurm = self.slurm.options(self.cell_timeout, None, false, true);
        Ok(TuneOptions {
            experiment: self.experiment.clone(),
            output: self.output.clone(),
            mode,
            backend: backend(self.backend, self.jobs, self.threads, slurm)?,
            quiet: self.quiet,
            report: !self.no_report,
            cell_timeout: self.cell_timeout,
        })
    }
}
