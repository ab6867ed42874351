//! What a tune writes into `OUTPUT/tune/`: `observations.csv`, the Pareto front
//! (`pareto.csv`, `pareto.png`, `pareto.svg`), the best scenes per time budget
//! (`best*.toml`), `sensitivity.csv` and `report.md`; and the plan `--dry-run` prints.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{Context, Result};

use super::analysis::{bins_for, epsilon_squared, pareto_front, spearman};
use super::cells::TuneCells;
use super::evaluation::Evaluation;
use super::hyperband::{MAX_ITERATIONS, bracket_renders, brackets_within, schedule};
use crate::plan::Experiment;
use crate::plan::{Budget, ParamKind, Proposal, TuneSpec};
use crate::report::{Panel, Plot, Point, Series, write_plot};
use crate::store::OutputDir;

/// What the search did.
pub(crate) struct Summary<'a> {
    /// Every evaluation, in order.
    pub(crate) evaluations: &'a [Evaluation],
    /// The cells.
    pub(crate) cells: &'a TuneCells<'a>,
    /// Cells this run rendered.
    pub(crate) rendered: usize,
    /// Recorded render seconds of all cells.
    pub(crate) spent_seconds: f64,
}

/// The best configuration within a time budget (`None`: any time).
struct Best<'a> {
    budget: Option<f64>,
    eval: Option<&'a Evaluation>,
    files: Vec<String>,
}

/// One parameter's sensitivity.
struct Sensitivity {
    key: String,
    epsilon2: Option<f64>,
    rho: Option<f64>,
    points: usize,
}

/// Writes every tune output; returns the path of `tune/report.md`.
pub(crate) fn write(
    exp: &Experiment,
    spec: &TuneSpec,
    out: &OutputDir,
    summary: &Summary<'_>,
) -> Result<PathBuf> {
    let dir = out.root().join("tune");
    std::fs::create_dir_all(&dir).with_context(|| format!("creating {}", dir.display()))?;
    write_observations(&dir, spec, summary)?;
    let top = top_level(spec, summary.evaluations);
    let points: Vec<(f64, f64)> = top.iter().map(|e| (e.error, e.seconds)).collect();
    let front: Vec<&Evaluation> = pareto_front(&points).into_iter().map(|i| top[i]).collect();
    write_front(&dir, spec, summary, &front)?;
    plot_front(&dir, spec, &top, &front)?;
    let mut best = best_per_budget(spec, &top);
    for b in &mut best {
        b.files = write_best(&dir, exp, spec, summary.cells, b)?;
    }
    let (level, sample, sensitivity) = sensitivity(spec, summary.evaluations);
    write_sensitivity(&dir, &sensitivity)?;
    let report = TuneReport {
        exp,
        spec,
        summary,
        front: &front,
        best: &best,
        sensitivity: &sensitivity,
        sensitivity_level: level,
        sensitivity_sample: sample,
    }
    .markdown();
    let path = dir.join("report.md");
    volphot::write_atomic(&path, report.as_bytes())?;
    Ok(path)
}

/// Evaluations at the target level with a finite error, one per distinct set of cells
/// (a configuration proposed twice counts once), in evaluation order.
fn top_level<'a>(spec: &TuneSpec, evals: &'a [Evaluation]) -> Vec<&'a Evaluation> {
    let mut seen = std::collections::BTreeSet::new();
    evals
        .iter()
        .filter(|e| e.level == spec.fidelity.top() && e.error.is_finite())
        .filter(|e| seen.insert(e.cells.clone()))
        .collect()
}

fn csv_bytes(rows: Vec<Vec<String>>) -> Result<Vec<u8>> {
    let mut w = csv::Writer::from_writer(Vec::new());
    for row in rows {
        w.write_record(&row)?;
    }
    w.into_inner().map_err(|e| anyhow::anyhow!("{e}"))
}

fn number(v: f64) -> String {
    if v.is_finite() {
        format!("{v:.6e}")
    } else {
        "inf".into()
    }
}

fn hashes(cells: &TuneCells<'_>, e: &Evaluation) -> String {
    e.cells
        .iter()
        .map(|&i| cells.hashes[i].as_str())
        .collect::<Vec<_>>()
        .join(" ")
}

fn write_observations(dir: &Path, spec: &TuneSpec, summary: &Summary<'_>) -> Result<()> {
    let mut header: Vec<String> = [
        "id",
        "iteration",
        "bracket",
        "rung",
        "level",
        "width",
        "height",
        "photon_fraction",
        "origin",
    ]
    .map(String::from)
    .to_vec();
    header.extend(spec.space.iter().map(|p| p.key.clone()));
    header.extend(["error", "seconds_per_frame", "feasible", "cells"].map(String::from));
    let mut rows = vec![header];
    for e in summary.evaluations {
        let [w, h] = spec.fidelity.resolution(e.level);
        let mut row = vec![
            e.id.clone(),
            e.iteration.to_string(),
            e.bracket.to_string(),
            e.rung.to_string(),
            e.level.to_string(),
            w.to_string(),
            h.to_string(),
            format!("{:.4}", spec.fidelity.photon_fraction(e.level)),
            e.origin.name().into(),
        ];
        row.extend(spec.space.iter().zip(&e.values).map(|(p, &v)| p.text(v)));
        row.extend([
            number(e.error),
            number(e.seconds),
            e.feasible.to_string(),
            hashes(summary.cells, e),
        ]);
        rows.push(row);
    }
    volphot::write_atomic(&dir.join("observations.csv"), &csv_bytes(rows)?)?;
    Ok(())
}

fn write_front(
    dir: &Path,
    spec: &TuneSpec,
    summary: &Summary<'_>,
    front: &[&Evaluation],
) -> Result<()> {
    let mut header: Vec<String> = ["id", "error", "seconds_per_frame", "feasible"]
        .map(String::from)
        .to_vec();
    header.extend(spec.space.iter().map(|p| p.key.clone()));
    header.push("cells".into());
    let mut rows = vec![header];
    for e in front {
        let mut row = vec![
            e.id.clone(),
            number(e.error),
            number(e.seconds),
            e.feasible.to_string(),
        ];
        row.extend(spec.space.iter().zip(&e.values).map(|(p, &v)| p.text(v)));
        row.push(hashes(summary.cells, e));
        rows.push(row);
    }
    volphot::write_atomic(&dir.join("pareto.csv"), &csv_bytes(rows)?)?;
    Ok(())
}

fn spread(values: impl Iterator<Item = f64>) -> f64 {
    let v: Vec<f64> = values.filter(|v| v.is_finite() && *v > 0.0).collect();
    let lo = v.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = v.iter().copied().fold(0.0, f64::max);
    if v.is_empty() { 1.0 } else { hi / lo }
}

fn plot_front(
    dir: &Path,
    spec: &TuneSpec,
    top: &[&Evaluation],
    front: &[&Evaluation],
) -> Result<()> {
    // Points by time, each with its cells (the report's explorer links points to them).
    let series = |name: &str, evals: &[&Evaluation], points_only: bool| {
        let mut sorted: Vec<&Evaluation> = evals.to_vec();
        sorted.sort_by(|a, b| {
            a.seconds
                .total_cmp(&b.seconds)
                .then(a.error.total_cmp(&b.error))
        });
        Series {
            name: name.into(),
            points: sorted
                .iter()
                .map(|e| Point {
                    x: e.seconds,
                    y: e.error,
                    spread: None,
                    cells: e.cells.clone(),
                })
                .collect(),
            points_only,
        }
    };
    let [w, h] = spec.fidelity.resolution;
    let objective = objective_text(spec);
    let plot = Plot {
        title: format!("Pareto front: {objective} against render time ({w}×{h})"),
        x_label: "render seconds per frame (predicted at the target resolution)".into(),
        y_label: objective,
        panels: vec![Panel {
            title: String::new(),
            series: vec![
                series("evaluated at the target level", top, true),
                series("Pareto front", front, false),
            ],
        }],
        log_x: spread(top.iter().map(|e| e.seconds)) > 20.0,
        log_y: spread(top.iter().map(|e| e.error)) > 20.0,
    };
    write_plot(&dir.join("pareto"), &plot)?;
    Ok(())
}

fn objective_text(spec: &TuneSpec) -> String {
    spec.objective
        .iter()
        .map(|(m, w)| {
            if *w == 1.0 {
                m.key().to_string()
            } else {
                format!("{w}·{}", m.key())
            }
        })
        .collect::<Vec<_>>()
        .join(" + ")
}

/// The best feasible configuration per time budget (and overall), lowest error first,
/// ties by id.
fn best_per_budget<'a>(spec: &TuneSpec, top: &[&'a Evaluation]) -> Vec<Best<'a>> {
    let budgets = spec
        .time_budgets
        .iter()
        .map(|&t| Some(t))
        .chain(std::iter::once(None));
    budgets
        .map(|budget| Best {
            budget,
            eval: top
                .iter()
                .filter(|e| e.feasible && budget.is_none_or(|t| e.seconds <= t))
                .min_by(|a, b| a.error.total_cmp(&b.error).then_with(|| a.id.cmp(&b.id)))
                .copied(),
            files: Vec::new(),
        })
        .collect()
}

/// `best-<T>s[-<context>].toml` (or `best[-<context>].toml`): the full scene at the
/// target level, ready for `sweep render`.
fn write_best(
    dir: &Path,
    exp: &Experiment,
    spec: &TuneSpec,
    cells: &TuneCells<'_>,
    best: &Best<'_>,
) -> Result<Vec<String>> {
    let Some(e) = best.eval else {
        return Ok(Vec::new());
    };
    let stem = match best.budget {
        Some(t) => format!("best-{t}s"),
        None => "best".into(),
    };
    let [w, h] = spec.fidelity.resolution;
    let mut files = Vec::new();
    for ctx in 0..cells.contexts.len() {
        let name = match cells.context_name(ctx) {
            n if n.is_empty() => format!("{stem}.toml"),
            n => format!("{stem}-{n}.toml"),
        };
        let table = cells.scene_table(ctx, &e.values)?;
        let within = best.budget.map_or("any render time".into(), |t| {
            format!("at most {t} s per frame")
        });
        let text = format!(
            "# The best settings `sweep tune` found for {within} at {w}×{h}\n# (experiment `{}`, seed {}, configuration {}: {} = {:.6}, {:.2} s per frame predicted).\n# Context: {}. Relative paths resolve against {}.\n\n{}",
            exp.name,
            spec.seed,
            e.id,
            objective_text(spec),
            e.error,
            e.seconds,
            cells.contexts[ctx].label(),
            cells.contexts[ctx].base_dir.display(),
            toml::to_string(&table).context("serialising the best scene")?
        );
        volphot::write_atomic(&dir.join(&name), text.as_bytes())?;
        files.push(name);
    }
    Ok(files)
}

/// ε² and Spearman ρ of ln(error) per parameter, at the level with the most finite
/// evaluations; on the uniform proposals alone when there are at least 8 of them there
/// (model proposals cluster near good values and bias the marginal means).
fn sensitivity(spec: &TuneSpec, evals: &[Evaluation]) -> (u32, &'static str, Vec<Sensitivity>) {
    let finite = |e: &&Evaluation| e.error.is_finite() && e.error > 0.0;
    let level = (0..spec.fidelity.levels)
        .max_by_key(|&l| {
            let n = evals.iter().filter(finite).filter(|e| e.level == l).count();
            (n, std::cmp::Reverse(l))
        })
        .unwrap_or(0);
    let at: Vec<&Evaluation> = evals
        .iter()
        .filter(finite)
        .filter(|e| e.level == level)
        .collect();
    let random: Vec<&Evaluation> = at
        .iter()
        .copied()
        .filter(|e| e.origin == super::propose::Origin::Random)
        .collect();
    let (sample, name) = if random.len() >= 8 {
        (random, "uniform proposals")
    } else {
        (at, "all proposals")
    };
    let y: Vec<f64> = sample.iter().map(|e| e.error.ln()).collect();
    let mut rows: Vec<Sensitivity> = spec
        .space
        .iter()
        .enumerate()
        .map(|(j, p)| {
            let x: Vec<f64> = sample.iter().map(|e| p.encode(e.values[j])).collect();
            Sensitivity {
                key: p.key.clone(),
                epsilon2: epsilon_squared(&x, &y, bins_for(x.len()), p.is_choice()),
                rho: if p.is_choice() {
                    None
                } else {
                    spearman(&x, &y)
                },
                points: x.len(),
            }
        })
        .collect();
    rows.sort_by(|a, b| {
        b.epsilon2
            .unwrap_or(-1.0)
            .total_cmp(&a.epsilon2.unwrap_or(-1.0))
            .then_with(|| a.key.cmp(&b.key))
    });
    (level, name, rows)
}

fn optional(v: Option<f64>) -> String {
    v.map_or("–".into(), |v| format!("{v:.3}"))
}

fn write_sensitivity(dir: &Path, rows: &[Sensitivity]) -> Result<()> {
    let mut out = vec![
        ["parameter", "epsilon2", "spearman_rho", "points"]
            .map(String::from)
            .to_vec(),
    ];
    for r in rows {
        out.push(vec![
            r.key.clone(),
            optional(r.epsilon2),
            optional(r.rho),
            r.points.to_string(),
        ]);
    }
    volphot::write_atomic(&dir.join("sensitivity.csv"), &csv_bytes(out)?)?;
    Ok(())
}

/// Spearman ρ between the errors of the configurations evaluated at two consecutive
/// levels: do cheap renders rank like expensive ones?
fn fidelity_agreement(spec: &TuneSpec, evals: &[Evaluation]) -> Vec<(u32, usize, Option<f64>)> {
    (0..spec.fidelity.top())
        .map(|l| {
            let pairs: Vec<(f64, f64)> = evals
                .iter()
                .filter(|a| a.level == l && a.error.is_finite())
                .filter_map(|a| {
                    evals
                        .iter()
                        .find(|b| b.id == a.id && b.level == l + 1 && b.error.is_finite())
                        .map(|b| (a.error, b.error))
                })
                .collect();
            let (x, y): (Vec<f64>, Vec<f64>) = pairs.into_iter().unzip();
            (l, x.len(), spearman(&x, &y))
        })
        .collect()
}

/// `tune/report.md`.
struct TuneReport<'a> {
    exp: &'a Experiment,
    spec: &'a TuneSpec,
    summary: &'a Summary<'a>,
    front: &'a [&'a Evaluation],
    best: &'a [Best<'a>],
    sensitivity: &'a [Sensitivity],
    sensitivity_level: u32,
    sensitivity_sample: &'static str,
}

impl TuneReport<'_> {
    fn markdown(&self) -> String {
        let mut s = String::new();
        self.header(&mut s);
        self.best_table(&mut s);
        self.front_table(&mut s);
        self.sensitivity_table(&mut s);
        self.fidelity_table(&mut s);
        s
    }

    fn header(&self, s: &mut String) {
        let (spec, sum) = (self.spec, self.summary);
        let f = &spec.fidelity;
        let _ = writeln!(s, "# Tune: {}\n", self.exp.name);
        let proposal = match spec.proposal {
            Proposal::Tpe => format!(
                "tree-Parzen proposals (the `tpe` crate, one estimator per parameter, fitted on the largest level with at least d + 3 evaluations; {:.0} % uniform draws)",
                100.0 * spec.random_fraction
            ),
            Proposal::Random => "uniform proposals".into(),
        };
        let _ = writeln!(
            s,
            "Hyperband over {} fidelity level(s) (η = {}) with {proposal}; seed {}.\n",
            f.levels, f.eta, spec.seed
        );
        let contexts = &sum.cells.contexts;
        let _ = writeln!(
            s,
            "- objective: `{}` against the reference{}",
            objective_text(spec),
            if contexts.len() > 1 {
                format!(
                    ", geometric mean over {} contexts ({})",
                    contexts.len(),
                    contexts
                        .iter()
                        .map(|c| c.label())
                        .collect::<Vec<_>>()
                        .join("; ")
                )
            } else {
                String::new()
            }
        );
        let [w, h] = f.resolution;
        let _ = writeln!(
            s,
            "- constraint: {}; render time = photon tracing + kd-tree + march as each cell records it, predicted at {w}×{h} by dividing the photon part by the level's photon fraction and scaling the march by the pixel count",
            spec.max_seconds.map_or("none".into(), |m| format!(
                "at most {m} s per frame at {w}×{h}"
            ))
        );
        let budget = match spec.budget {
            Budget::Renders(n) => format!("{n} renders"),
            Budget::Seconds(t) => format!("{t} recorded render seconds"),
        };
        let distinct: std::collections::BTreeSet<usize> = sum
            .evaluations
            .iter()
            .flat_map(|e| e.cells.iter().copied())
            .collect();
        let _ = writeln!(
            s,
            "- budget: {budget}; used {} evaluations, {} distinct cells ({} rendered by the last run, the rest found finished), {:.1} s of recorded render time",
            sum.evaluations.len(),
            distinct.len(),
            sum.rendered,
            sum.spent_seconds
        );
        for l in 0..f.levels {
            let [lw, lh] = f.resolution(l);
            let _ = writeln!(
                s,
                "- level {l}: {lw}×{lh}, photons × {:.3}",
                f.photon_fraction(l)
            );
        }
        let _ = writeln!(
            s,
            "\nFiles: [observations.csv](observations.csv) (every evaluation), [pareto.csv](pareto.csv), [sensitivity.csv](sensitivity.csv); every evaluation is a cell of [the experiment's report](../report.md).\n"
        );
    }

    fn param_headers(&self) -> String {
        self.spec
            .space
            .iter()
            .map(|p| format!(" `{}` |", p.key))
            .collect()
    }

    fn param_cells(&self, e: &Evaluation) -> String {
        self.spec
            .space
            .iter()
            .zip(&e.values)
            .map(|(p, &v)| format!(" {} |", p.text(v)))
            .collect()
    }

    fn best_table(&self, s: &mut String) {
        let _ = writeln!(s, "## Best settings per time budget\n");
        let _ = writeln!(
            s,
            "| budget | configuration | {} | s/frame |{} scene files |",
            objective_text(self.spec),
            self.param_headers()
        );
        let _ = writeln!(
            s,
            "|---|---|---|---|{}---|",
            "---|".repeat(self.spec.space.len())
        );
        for b in self.best {
            let budget = b.budget.map_or("any".into(), |t| format!("≤ {t} s"));
            match b.eval {
                Some(e) => {
                    let files: Vec<String> =
                        b.files.iter().map(|f| format!("[{f}]({f})")).collect();
                    let _ = writeln!(
                        s,
                        "| {budget} | {} | {:.5} | {:.2} |{} {} |",
                        e.id,
                        e.error,
                        e.seconds,
                        self.param_cells(e),
                        files.join(", ")
                    );
                }
                None => {
                    let _ = writeln!(
                        s,
                        "| {budget} | none evaluated at the target level fits | – | – |{} – |",
                        " – |".repeat(self.spec.space.len())
                    );
                }
            }
        }
        s.push('\n');
    }

    fn front_table(&self, s: &mut String) {
        let _ = writeln!(s, "## Pareto front: error against render time\n");
        let _ = writeln!(
            s,
            "Configurations evaluated at the target level that no other beats in both error and time.\n\n![Pareto front](pareto.svg)\n"
        );
        let _ = writeln!(
            s,
            "| configuration | {} | s/frame | feasible |{}",
            objective_text(self.spec),
            self.param_headers()
        );
        let _ = writeln!(
            s,
            "|---|---|---|---|{}",
            "---|".repeat(self.spec.space.len())
        );
        for e in self.front {
            let _ = writeln!(
                s,
                "| {} | {:.5} | {:.2} | {} |{}",
                e.id,
                e.error,
                e.seconds,
                if e.feasible { "yes" } else { "no" },
                self.param_cells(e)
            );
        }
        s.push('\n');
    }

    fn sensitivity_table(&self, s: &mut String) {
        let _ = writeln!(s, "## Sensitivity: which knobs matter\n");
        let _ = writeln!(
            s,
            "ε² is the bias-corrected correlation ratio of ln(error) over quantile bins of each parameter (its model-space value; categories for choices): the share of the variance explained by that parameter alone, about 0 for an irrelevant one, and it sees interior optima that a rank correlation misses. Spearman ρ gives the direction (positive: larger values, larger error). Interactions are not attributed: 1 − Σε² is interaction plus noise. Computed at level {} on the {} ({} points).\n",
            self.sensitivity_level,
            self.sensitivity_sample,
            self.sensitivity.first().map_or(0, |r| r.points)
        );
        let _ = writeln!(s, "| parameter | ε² | Spearman ρ |\n|---|---|---|");
        for r in self.sensitivity {
            let _ = writeln!(
                s,
                "| `{}` | {} | {} |",
                r.key,
                optional(r.epsilon2),
                optional(r.rho)
            );
        }
        s.push('\n');
    }

    fn fidelity_table(&self, s: &mut String) {
        let rows = fidelity_agreement(self.spec, self.summary.evaluations);
        if rows.is_empty() {
            return;
        }
        let _ = writeln!(s, "## Do cheap renders rank like expensive ones?\n");
        let _ = writeln!(
            s,
            "Spearman ρ between the errors of the configurations promoted from one level to the next. Below about 0.5 the low levels mislead: raise `min_resolution` or `min_photon_fraction`.\n\n| levels | configurations | ρ |\n|---|---|---|"
        );
        for (l, n, rho) in rows {
            let _ = writeln!(s, "| {l} → {} | {n} | {} |", l + 1, optional(rho));
        }
        s.push('\n');
    }
}

/// `sweep tune --dry-run`: checks every searched key at both ends of its range on every
/// context and level, prints the levels, the schedule and what the budget allows.
pub(crate) fn dry_run(exp: &Experiment, spec: &TuneSpec, out: &OutputDir) -> Result<ExitCode> {
    let mut cells = TuneCells::new(exp, spec)?;
    let checked = check_space(spec, &mut cells)?;
    let f = &spec.fidelity;
    println!(
        "{}: tune {} key(s) on {} context(s), objective {}; {checked} cells checked",
        exp.name,
        spec.space.len(),
        cells.contexts.len(),
        objective_text(spec)
    );
    for l in 0..f.levels {
        let [w, h] = f.resolution(l);
        println!(
            "  level {l}: {w}×{h}, photons × {:.3}",
            f.photon_fraction(l)
        );
    }
    let brackets = schedule(f.levels, f.eta);
    for b in &brackets {
        let rungs: Vec<String> = b
            .iter()
            .map(|r| format!("{} × level {}", r.configs, r.level))
            .collect();
        println!(
            "  bracket s={}: {} ({} renders per context)",
            b.len() - 1,
            rungs.join(" → "),
            bracket_renders(b)
        );
    }
    let contexts = cells.contexts.len();
    match spec.budget {
        Budget::Renders(n) => {
            let (started, planned) = brackets_within(&brackets, contexts, n);
            let smallest = brackets
                .iter()
                .map(|b| bracket_renders(b))
                .min()
                .unwrap_or(1);
            anyhow::ensure!(
                started > 0,
                "{}: `budget` = {{ renders = {n} }}: the budget allows no bracket (the smallest needs {} renders on {contexts} context(s)); expected at least that many",
                exp.path().display(),
                smallest * contexts
            );
            let limit = if started == brackets.len() * MAX_ITERATIONS as usize {
                format!("; the search stops after {MAX_ITERATIONS} Hyperband iterations")
            } else {
                String::new()
            };
            println!(
                "  budget {n} renders: {started} bracket(s), at most {planned} renders (fewer when a proposal repeats a cell){limit}"
            );
        }
        Budget::Seconds(t) => println!(
            "  budget {t} recorded render seconds: brackets start while less has been spent; one Hyperband iteration is {} renders",
            brackets.iter().map(|b| bracket_renders(b)).sum::<usize>() * contexts
        ),
    }
    if let Some(m) = spec.max_seconds {
        println!(
            "  constraint: at most {m} s per frame at {}×{}",
            f.resolution[0], f.resolution[1]
        );
    }
    println!("  output: {}", out.root().display());
    Ok(ExitCode::SUCCESS)
}

/// Builds (and so validates) a cell for every context at the lowest and the target level
/// with every key at the low and at the high end of its range, and every choice.
fn check_space(spec: &TuneSpec, cells: &mut TuneCells<'_>) -> Result<usize> {
    let ends = |high: bool| -> Vec<f64> {
        spec.space
            .iter()
            .map(|p| match &p.kind {
                ParamKind::Float { lo, hi, .. } => {
                    if high {
                        *hi
                    } else {
                        *lo
                    }
                }
                ParamKind::Int { lo, hi, .. } => (if high { *hi } else { *lo }) as f64,
                ParamKind::Choice(c) => {
                    if high {
                        (c.len() - 1) as f64
                    } else {
                        0.0
                    }
                }
            })
            .collect()
    };
    let mut configs = vec![ends(false), ends(true)];
    for (j, p) in spec.space.iter().enumerate() {
        if let ParamKind::Choice(c) = &p.kind {
            for k in 1..c.len().saturating_sub(1) {
                let mut v = ends(false);
                v[j] = k as f64;
                configs.push(v);
            }
        }
    }
    let mut checked = 0;
    for ctx in 0..cells.contexts.len() {
        for level in [0, spec.fidelity.top()] {
            for values in &configs {
                cells.cell(ctx, values, level).with_context(|| {
                    format!(
                        "[tune.space] at level {level} on context `{}`: {}",
                        cells.contexts[ctx].label(),
                        spec.space
                            .iter()
                            .zip(values)
                            .map(|(p, &v)| format!("{} = {}", p.key, p.text(v)))
                            .collect::<Vec<_>>()
                            .join(", ")
                    )
                })?;
                checked += 1;
            }
        }
    }
    Ok(checked)
}
