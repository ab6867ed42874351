//! The search: Hyperband iterations of brackets of successive halving; each rung's cells
//! go through the run's backend, its results decide who is promoted.

use std::collections::BTreeMap;
use std::process::ExitCode;

use anyhow::{Context, Result};
use indicatif::ProgressBar;

use super::cells::{CellResult, TuneCells};
use super::evaluation::Evaluation;
use super::hyperband::{MAX_ITERATIONS, Rung, bracket_renders, schedule};
use super::propose::{Observed, Origin, propose, stream};
use super::{TuneOptions, output};
use crate::backend::Run;
use crate::plan::{Budget, TuneSpec};
use crate::plan::{Experiment, Quality};
use crate::render::{CellFilter, Selection};
use crate::store::{OutputDir, cell_hash, check_owner, is_done, lock_tune, read_plan, write_plan};

/// A configuration alive in a bracket.
struct Config {
    id: String,
    values: Vec<f64>,
    origin: Origin,
}

/// The search, then the tune outputs and the reports.
pub(super) fn search(
    exp: &Experiment,
    spec: &TuneSpec,
    out: OutputDir,
    opts: &TuneOptions,
) -> Result<ExitCode> {
    let _lock = lock_tune(&out)?;
    check_owner(&out, &exp.owner())?;
    let cells = TuneCells::new(exp, spec)?;
    let multi = crate::progress::multi(opts.quiet);
    let (len, unit) = match spec.budget {
        Budget::Renders(n) => (n as u64, "renders"),
        Budget::Seconds(s) => (s.ceil() as u64, "render-s"),
    };
    let mut s = Search {
        exp,
        spec,
        cells,
        out,
        opts,
        evals: Vec::new(),
        cell_seconds: BTreeMap::new(),
        planned: 0,
        rendered: 0,
        bar: crate::progress::bar(&multi, len, "tune", unit),
    };
    s.hyperband()?;
    s.bar.finish_and_clear();
    s.finish()
}

struct Search<'a> {
    exp: &'a Experiment,
    spec: &'a TuneSpec,
    cells: TuneCells<'a>,
    out: OutputDir,
    opts: &'a TuneOptions,
    evals: Vec<Evaluation>,
    /// Recorded seconds of every finished cell seen.
    cell_seconds: BTreeMap<usize, f64>,
    /// Evaluations × contexts of the brackets started (the `renders` budget).
    planned: usize,
    /// Cells this run rendered.
    rendered: usize,
    bar: ProgressBar,
}

impl Search<'_> {
    /// Runs Hyperband iterations while the budget allows a bracket; stops early when an
    /// iteration found no new cell (a small space is exhausted).
    fn hyperband(&mut self) -> Result<()> {
        let f = &self.spec.fidelity;
        let brackets = schedule(f.levels, f.eta);
        for iteration in 0..MAX_ITERATIONS {
            let cells_before = self.cells.cells.len();
            let mut started = false;
            for bracket in &brackets {
                if !self.budget_allows(bracket) {
                    continue;
                }
                started = true;
                self.bracket(iteration, bracket)?;
            }
            if !started || self.cells.cells.len() == cells_before {
                break;
            }
        }
        Ok(())
    }

    fn spent_seconds(&self) -> f64 {
        self.cell_seconds.values().sum()
    }

    fn budget_allows(&self, bracket: &[Rung]) -> bool {
        match self.spec.budget {
            Budget::Renders(n) => {
                self.planned + bracket_renders(bracket) * self.cells.contexts.len() <= n
            }
            Budget::Seconds(s) => self.spent_seconds() < s,
        }
    }

    /// One bracket: propose its configurations, then evaluate and halve rung by rung.
    fn bracket(&mut self, iteration: u32, bracket: &[Rung]) -> Result<()> {
        let s = (bracket.len() - 1) as u32;
        let history: Vec<Observed<'_>> = self
            .evals
            .iter()
            .map(|e| Observed {
                id: &e.id,
                level: e.level,
                values: &e.values,
                loss: e.loss(),
            })
            .collect();
        let mut rng = stream(self.spec.seed, iteration, s);
        let proposals = propose(self.spec, &history, bracket[0].configs, &mut rng)?;
        self.planned += bracket_renders(bracket) * self.cells.contexts.len();
        let mut live: Vec<Config> = proposals
            .into_iter()
            .enumerate()
            .map(|(k, (values, origin))| Config {
                id: format!("i{iteration}-b{s}-c{k:03}"),
                values,
                origin,
            })
            .collect();
        for (r, rung) in bracket.iter().enumerate() {
            let losses = self.rung(&live, iteration, s, r as u32, rung.level)?;
            let Some(next) = bracket.get(r + 1) else {
                break;
            };
            live = promote(live, &losses, next.configs);
            if live.is_empty() {
                break;
            }
        }
        Ok(())
    }

    /// Evaluates the live configurations at a level; returns their losses.
    fn rung(
        &mut self,
        live: &[Config],
        iteration: u32,
        bracket: u32,
        rung: u32,
        level: u32,
    ) -> Result<Vec<f64>> {
        let contexts = self.cells.contexts.len();
        let mut per_config = Vec::with_capacity(live.len());
        for c in live {
            let cells = (0..contexts)
                .map(|ctx| self.cells.cell(ctx, &c.values, level))
                .collect::<Result<Vec<usize>>>();
            // A combination the renderer rejects (e.g. an estimator with an estimate it
            // cannot use) is a failed evaluation, not the end of the search.
            per_config.push(cells.unwrap_or_else(|e| {
                self.bar
                    .suspend(|| eprintln!("{}: not a valid scene, counted as failed: {e:#}", c.id));
                Vec::new()
            }));
        }
        self.dispatch(&per_config.concat())?;
        let mut losses = Vec::with_capacity(live.len());
        for (c, cells) in live.iter().zip(per_config) {
            let results: Vec<CellResult> = cells
                .iter()
                .map(|&i| self.cells.result(&self.out, i, level))
                .collect();
            for (&i, r) in cells.iter().zip(&results) {
                self.cell_seconds.insert(i, r.seconds);
            }
            let seconds = results.iter().map(|r| r.target_seconds).fold(0.0, f64::max);
            let eval = Evaluation {
                id: c.id.clone(),
                iteration,
                bracket,
                rung,
                level,
                values: c.values.clone(),
                origin: c.origin,
                cells,
                error: geometric_mean(results.iter().map(|r| r.error)),
                seconds,
                feasible: self.spec.max_seconds.is_none_or(|m| seconds <= m),
            };
            losses.push(eval.loss());
            self.evals.push(eval);
        }
        self.bar.set_position(match self.spec.budget {
            Budget::Renders(_) => self.planned as u64,
            Budget::Seconds(_) => self.spent_seconds() as u64,
        });
        self.bar.set_message(format!(
            "bracket {bracket} rung {rung} (level {level}), best {}",
            self.best_text()
        ));
        Ok(losses)
    }

    fn best_text(&self) -> String {
        let top = self.spec.fidelity.top();
        self.evals
            .iter()
            .filter(|e| e.level == top && e.loss().is_finite())
            .map(|e| e.error)
            .min_by(f64::total_cmp)
            .map_or("–".into(), |e| format!("{e:.4}"))
    }

    /// Renders the cells that are not finished through the backend.
    fn dispatch(&mut self, indices: &[usize]) -> Result<()> {
        let mut pending: Vec<usize> = indices
            .iter()
            .copied()
            .filter(|&i| !is_done(&self.out.cell(&self.cells.hashes[i])))
            .collect();
        pending.sort_unstable();
        pending.dedup();
        if pending.is_empty() {
            return Ok(());
        }
        let run = Run {
            experiment: self.exp,
            cells: &self.cells.cells,
            hashes: &self.cells.hashes,
            quality: Quality::Default,
            output: self.out.clone(),
            selection: Selection::Cells(pending.clone()),
            quiet: self.opts.quiet,
            cell_timeout: self.opts.cell_timeout,
            reference_pool: None,
        };
        let backend = &self.opts.backend;
        self.bar.suspend(|| backend.execute(&run))?;
        self.rendered += pending
            .iter()
            .filter(|&&i| is_done(&self.out.cell(&self.cells.hashes[i])))
            .count();
        Ok(())
    }

    /// Writes the plan (every cell), the tune outputs and the reports.
    fn finish(self) -> Result<ExitCode> {
        anyhow::ensure!(
            !self.evals.is_empty(),
            "{}: the budget allows no bracket (the smallest needs {} renders per context); raise [tune] budget",
            self.exp.path().display(),
            schedule(self.spec.fidelity.levels, self.spec.fidelity.eta)
                .iter()
                .map(|b| bracket_renders(b))
                .min()
                .unwrap_or(1)
        );
        let plan = self
            .exp
            .plan_record(&self.cells.cells, &self.cells.hashes, Quality::Default)?;
        write_plan(&self.out, &plan, &self.exp.source.text)?;
        let summary = output::Summary {
            evaluations: &self.evals,
            cells: &self.cells,
            rendered: self.rendered,
            spent_seconds: self.spent_seconds(),
        };
        let tune_report = output::write(self.exp, self.spec, &self.out, &summary)?;
        eprintln!("tune report: {}", tune_report.display());
        if self.opts.report {
            let report = crate::report::build_report(&self.out)?;
            eprintln!("report: {}", report.display());
        }
        Ok(ExitCode::SUCCESS)
    }
}

/// The best `keep` configurations by (loss, id); infinite losses are never promoted.
fn promote(live: Vec<Config>, losses: &[f64], keep: usize) -> Vec<Config> {
    let mut ranked: Vec<(f64, Config)> = losses
        .iter()
        .copied()
        .zip(live)
        .filter(|(l, _)| l.is_finite())
        .collect();
    ranked.sort_by(|a, b| a.0.total_cmp(&b.0).then_with(|| a.1.id.cmp(&b.1.id)));
    ranked.into_iter().take(keep).map(|(_, c)| c).collect()
}

/// The geometric mean (each context counts by its relative change); +∞ if any is.
pub(crate) fn geometric_mean(values: impl Iterator<Item = f64>) -> f64 {
    let (mut sum, mut n) = (0.0, 0usize);
    for v in values {
        if !v.is_finite() {
            return f64::INFINITY;
        }
        sum += v.max(1e-300).ln();
        n += 1;
    }
    if n == 0 {
        f64::INFINITY
    } else {
        (sum / n as f64).exp()
    }
}

/// A Slurm array task of a tune: renders cells of the output folder's `plan.json`, rebuilt
/// from the experiment file and checked against their recorded addresses.
pub(super) fn render_planned(
    exp: &Experiment,
    out: &OutputDir,
    filter: &CellFilter,
    opts: &TuneOptions,
) -> Result<ExitCode> {
    let plan = read_plan(out)?;
    let mut cells = Vec::with_capacity(plan.cells.len());
    let mut hashes = Vec::with_capacity(plan.cells.len());
    for p in &plan.cells {
        let axes = p
            .axes
            .iter()
            .map(|(k, v)| {
                toml::Value::try_from(v)
                    .with_context(|| format!("plan.json cell {}: axis `{k}` = {v}", p.index))
                    .map(|v| (k.clone(), v))
            })
            .collect::<Result<Vec<_>>>()?;
        let spec = exp.cell(p.index, axes, Quality::Default)?;
        let hash = cell_hash(&spec.params, &spec.base_dir)?;
        anyhow::ensure!(
            hash == p.hash,
            "{}: cell {} ({}) has address {hash} from {}, but the plan recorded {}; the experiment or the program changed since the tune planned it, so rerun `sweep tune`",
            out.plan().display(),
            p.index,
            p.label,
            exp.path().display(),
            p.hash
        );
        cells.push(spec);
        hashes.push(hash);
    }
    let outcome = opts.backend.execute(&Run {
        experiment: exp,
        cells: &cells,
        hashes: &hashes,
        quality: Quality::Default,
        output: out.clone(),
        selection: filter.resolve(cells.len())?,
        quiet: opts.quiet,
        cell_timeout: opts.cell_timeout,
        reference_pool: None,
    })?;
    Ok(outcome.exit_code())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn promotion_ranks_by_loss_then_id_and_drops_failures() {
        let live: Vec<Config> = ["c2", "c0", "c1", "c3"]
            .iter()
            .map(|id| Config {
                id: id.to_string(),
                values: vec![],
                origin: Origin::Random,
            })
            .collect();
        let kept = promote(live, &[0.5, 0.5, f64::INFINITY, 0.1], 3);
        let ids: Vec<&str> = kept.iter().map(|c| c.id.as_str()).collect();
        assert_eq!(ids, vec!["c3", "c0", "c2"]);
        assert!((geometric_mean([1.0, 4.0].into_iter()) - 2.0).abs() < 1e-12);
        assert!(geometric_mean([1.0, f64::INFINITY].into_iter()).is_infinite());
    }
}
