//! `sweep bench --reference`: the path tracer's trackers side by side — CPU time to RMSE
//! 0.02 and 0.01 on the headline frame and the phantom head at σt(d_min) 80 and 6.
//!
//! Per case, a converged reference (the default tracker at `--reference-passes`, with a
//! seed no measured render uses) comes from the reference pool, rendered or refined there
//! when the pool holds fewer passes. Each tracker then renders `--seeds` images of
//! `--passes` passes; their mean squared error against the reference, with the
//! reference's own noise removed (`mse_against_noisy_reference`), and their CPU-seconds
//! give the time to an RMSE ε. Both trackers are unbiased, so the squared error falls as
//! 1/passes: `passes(ε) = passes · MSE / ε²`, and `CPU(ε) = pilot + per_pass · passes(ε)`,
//! where `pilot` is the weighted tracker's allocation pilot (measured as the first pass's
//! CPU time less a pass's).
//!
//! With `--counters` each render's last pass counts its work ([`volphot::Counter`]: null
//! and real collisions, ratio-tracking steps, density lookups, majorant bricks, shadow
//! rays) and is timed apart: the per-pass time comes from the uncounted passes, and the
//! counted pass's time beside it is what counting costs. Counting changes no bit of the
//! image, so the error is the same either way.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{Context, Result, bail};
use glam::Vec3;
use serde::Serialize;
use volphot::{
    Control, Counter, Counting, Counts, IntegratorParams, Method, ReferenceAccumulator, Scene,
    SceneParams, SearchPath, Tracker, process_cpu_seconds,
};

use super::{BenchOptions, Machine};
use crate::analyse::mse_against_noisy_reference;
use crate::plan::ReferenceMethod;
use crate::store::{ReferencePool, ReferenceRecord, VERSION, inputs_identity, reference_hash};

/// The RMSEs the time is reported for.
const TARGETS: [f64; 2] = [0.02, 0.01];
/// The trackers compared, today's first.
const TRACKERS: [Tracker; 2] = [Tracker::Delta, Tracker::Weighted];

/// The benchmark's output.
#[derive(Debug, Serialize)]
struct Report {
    machine: Machine,
    command: Vec<String>,
    threads: usize,
    cases: Vec<Case>,
}

/// One scene at one σt(d_min).
#[derive(Debug, Serialize)]
struct Case {
    scene: String,
    sigma_t: f32,
    resolution: [u32; 2],
    reference: ReferenceInfo,
    trackers: Vec<TrackerResult>,
    /// CPU time to RMSE 0.01: delta's over weighted's.
    speedup_at_001: f64,
    /// With `--routes`: the routes to a faster reference the variance budget points to,
    /// raced beside the trackers (weighted's allocation, its seeds and passes).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    routes: Vec<RouteResult>,
}

/// A route's renders of a case: the weighted tracker's renders along the route, and its
/// speed against the plain weighted tracker's.
#[derive(Debug, Serialize)]
struct RouteResult {
    route: &'static str,
    #[serde(flatten)]
    renders: TrackerResult,
    /// Weighted's CPU time to RMSE 0.01 over the route's.
    speedup_over_weighted_at_001: f64,
}

#[derive(Debug, Serialize)]
struct ReferenceInfo {
    key: String,
    passes: u32,
    tracker: Tracker,
    /// The reference's own RMSE (square root of its mean variance of the mean).
    rmse: f64,
}

/// One tracker's renders of a case.
#[derive(Debug, Serialize)]
struct TrackerResult {
    tracker: Tracker,
    passes: u32,
    seeds: Vec<SeedRun>,
    /// Means over the seeds.
    pilot_cpu_s: f64,
    cpu_per_pass_s: f64,
    rmse: f64,
    /// The CPU-seconds to each target RMSE.
    cpu_to_rmse: Vec<CpuTo>,
    /// With `--counters`: the counted passes' work and what counting cost.
    #[serde(skip_serializing_if = "Option::is_none")]
    counters: Option<CounterSummary>,
}

/// The work of the counted passes (one a seed), means over the seeds.
#[derive(Debug, Serialize)]
struct CounterSummary {
    /// The counted pass's CPU-seconds.
    counted_pass_cpu_s: f64,
    /// Its time over an uncounted pass's (`cpu_per_pass_s`), less 1.
    counting_cost: f64,
    /// Every counter, in `volphot::Counter::ALL`'s order.
    means: Vec<CounterMean>,
}

/// One counter's mean count in a pass, and per sample traced.
#[derive(Debug, Serialize)]
struct CounterMean {
    counter: &'static str,
    per_pass: f64,
    per_sample: f64,
}

/// The CPU-seconds to an RMSE.
#[derive(Debug, Serialize)]
struct CpuTo {
    target: f64,
    cpu_s: f64,
}

/// One render: its seed, CPU time split into the first pass and the rest, and its error.
#[derive(Debug, Serialize)]
struct SeedRun {
    seed: u64,
    first_pass_cpu_s: f64,
    /// The passes after the first, but the counted one.
    other_passes_cpu_s: f64,
    mse: f64,
    /// With `--counters`: the last pass, counted and timed apart.
    #[serde(skip_serializing_if = "Option::is_none")]
    counted_pass: Option<CountedPass>,
}

/// A pass traced with its work counted: its CPU time and every counter's count.
#[derive(Debug, Serialize)]
struct CountedPass {
    cpu_s: f64,
    #[serde(serialize_with = "counts_by_name")]
    counts: Counts,
}

/// `counts` as `[{counter, count}]` rows, in [`Counter::ALL`]'s order.
fn counts_by_name<S: serde::Serializer>(counts: &Counts, s: S) -> Result<S::Ok, S::Error> {
    #[derive(Serialize)]
    struct Row {
        counter: &'static str,
        count: u64,
    }
    s.collect_seq(counts.iter().map(|(c, count)| Row {
        counter: c.name(),
        count,
    }))
}

/// The converged reference of a case: image (all layers) and variance of its mean.
struct Reference {
    image: Vec<Vec3>,
    variance: Vec<Vec3>,
    info: ReferenceInfo,
}

/// Runs the comparison (`--budget` runs [`super::budget::run`] instead).
pub(crate) fn run(args: &BenchOptions) -> Result<ExitCode> {
    if args.passes < 2 {
        bail!(
            "--passes {}: expected at least 2 (the first pass is timed apart)",
            args.passes
        );
    }
    if args.counters && args.passes < 3 {
        bail!(
            "--passes {} with --counters: expected at least 3 (the first pass and the counted last one are timed apart from the others)",
            args.passes
        );
    }
    let pool = ReferencePool::new(
        args.reference_pool
            .clone()
            .unwrap_or_else(|| PathBuf::from("reports/reference-pool")),
    );
    let threads = crate::render::thread_pool(args.threads)?;
    let mut cases = Vec::new();
    for scene_path in scenes(args)? {
        let (params, _) = crate::plan::load_scene(&scene_path)
            .with_context(|| format!("benchmark scene {}", scene_path.display()))?;
        for &t in &args.sigma_t {
            let params = case_params(&params, t, args)
                .with_context(|| format!("{} at σt(d_min) {t}", scene_path.display()))?;
            let case = threads.install(|| measure_case(args, &scene_path, &params, t, &pool))?;
            print_case(&case);
            cases.push(case);
        }
    }
    let report = Report {
        machine: Machine::describe(),
        command: crate::store::recorded_command(),
        threads: threads.current_num_threads(),
        cases,
    };
    print_summary(&report.cases);
    if let Some(path) = &args.json {
        volphot::write_atomic(path, serde_json::to_string_pretty(&report)?.as_bytes())?;
    }
    Ok(ExitCode::SUCCESS)
}

/// The scenes: `--scene`, or the headline frame and the phantom head.
pub(super) fn scenes(args: &BenchOptions) -> Result<Vec<PathBuf>> {
    if let Some(s) = &args.scene {
        return Ok(vec![s.clone()]);
    }
    ["foot.toml", "phantom-head.toml"]
        .iter()
        .map(|s| super::default_scene(s))
        .collect()
}

/// The scene at σt(d_min) = `t` (its σ mapping must be the thesis's) and the chosen size,
/// rendering every layer with the path tracer.
pub(super) fn case_params(
    params: &SceneParams,
    t: f32,
    args: &BenchOptions,
) -> Result<SceneParams> {
    let mut p = params.clone();
    super::with_sigma_t(&mut p, t)?;
    super::set_lighting(&mut p, args.lighting)?;
    if args.quick {
        p.camera.resolution = [128, 128];
    }
    if let Some(r) = args.resolution {
        p.camera.resolution = r;
    }
    p.integrator = IntegratorParams {
        method: Method::Reference,
        single: true,
        multiple: true,
        seed: p.integrator.seed,
        ..IntegratorParams::default()
    };
    volphot::validate_params(&p)?;
    Ok(p)
}

/// `params` with another tracker and seed.
fn with(params: &SceneParams, tracker: Tracker, seed: u64) -> SceneParams {
    let mut p = params.clone();
    p.integrator.tracker = tracker;
    p.integrator.seed = seed;
    p
}

/// The reference and both trackers' renders of one case.
fn measure_case(
    args: &BenchOptions,
    scene_path: &Path,
    params: &SceneParams,
    sigma_t: f32,
    pool: &ReferencePool,
) -> Result<Case> {
    let base = scene_path.parent().unwrap_or(Path::new("."));
    let search = SearchPath::from_env();
    let reference_params = with(
        params,
        Tracker::Weighted,
        params.integrator.seed + 1_000_003,
    );
    let reference = pooled_reference(args, &reference_params, base, &search, pool)?;
    let mut trackers = Vec::new();
    // Every seed's render of one tracker (and route), each scene built and prepared first.
    let seed_runs = |tracker: Tracker, route: Option<volphot::Route>| {
        (0..u64::from(args.seeds))
            .map(|k| {
                let p = with(params, tracker, params.integrator.seed + 1 + k);
                let scene = Scene::from_params(&p, base, &search)?;
                scene.medium().prepare();
                measure_render(&scene, args.passes, route, &reference, args.counters)
            })
            .collect::<Result<Vec<_>>>()
    };
    for tracker in TRACKERS {
        trackers.push(summarise(tracker, args.passes, seed_runs(tracker, None)?));
    }
    let at = |t: &TrackerResult| t.cpu_to_rmse.last().map_or(f64::NAN, |r| r.cpu_s);
    let mut routes = Vec::new();
    if args.routes {
        for route in volphot::Route::ALL.into_iter().skip(1) {
            let runs = seed_runs(Tracker::Weighted, Some(route))?;
            let r = summarise(Tracker::Weighted, args.passes, runs);
            routes.push(RouteResult {
                route: route.name(),
                speedup_over_weighted_at_001: at(&trackers[1]) / at(&r),
                renders: r,
            });
        }
    }
    Ok(Case {
        routes,
        scene: crate::store::recorded_path(scene_path),
        sigma_t,
        resolution: params.camera.resolution,
        reference: reference.info,
        speedup_at_001: at(&trackers[0]) / at(&trackers[1]),
        trackers,
    })
}

/// The pool's reference of `params` at `--reference-passes` (default 1024), rendered or
/// refined there first when it holds fewer; a state with more passes is used as it is.
fn pooled_reference(
    args: &BenchOptions,
    params: &SceneParams,
    base: &Path,
    search: &SearchPath,
    pool: &ReferencePool,
) -> Result<Reference> {
    let passes = args.reference_passes.unwrap_or(1024);
    let key = reference_hash(params, &inputs_identity(params, base)?)?;
    let _lock = pool.lock(&key)?;
    let saved = pool.saved_state(&key).unwrap_or_else(|why| {
        eprintln!("reference {key} in the pool is damaged ({why}); rendering it again");
        None
    });
    let scene = Scene::from_params(params, base, search)?;
    let (mut acc, mut seconds) = match &saved {
        Some(record) => (pool.read_state(&key)?, record.seconds),
        None => {
            let [w, h] = params.camera.resolution;
            (ReferenceAccumulator::new(w as usize, h as usize), 0.0)
        }
    };
    if acc.passes() < passes {
        eprintln!(
            "bench reference: {key}, {} → {passes} passes…",
            acc.passes()
        );
        seconds += acc.add_passes(&scene, passes - acc.passes(), &Control::none())?;
        let record = ReferenceRecord {
            files: Vec::new(),
            key: key.clone(),
            method: ReferenceMethod::Path,
            passes: acc.passes(),
            seconds,
            scene: params.clone(),
            volume: scene.volume_source().clone(),
            version: VERSION.to_string(),
        };
        pool.keep_state(&key, &acc, record)?;
    }
    let variance = acc
        .total_variance()
        .context("the reference's total variance")?;
    let rmse = volphot::mean_rgb(&variance).sqrt();
    Ok(Reference {
        image: acc.film().total(),
        info: ReferenceInfo {
            key,
            passes: acc.passes(),
            tracker: params.integrator.tracker,
            rmse,
        },
        variance,
    })
}

/// One render, timed: the first pass apart (it runs the weighted tracker's pilot) from the
/// rest, and its error against the reference. With a `route`, the weighted tracker along
/// that route to a faster reference; without, the scene's own tracker. `counted`: the last
/// pass counts its work and is timed apart from the others.
fn measure_render(
    scene: &Scene,
    passes: u32,
    route: Option<volphot::Route>,
    reference: &Reference,
    counted: bool,
) -> Result<SeedRun> {
    let cpu = || process_cpu_seconds().context("CPU time is not available here");
    let camera = scene.camera();
    let mut acc = ReferenceAccumulator::new(camera.width() as usize, camera.height() as usize);
    let add = |acc: &mut ReferenceAccumulator, n: u32, control: &Control<'_>| match route {
        Some(route) => acc.add_passes_route(scene, n, route, control),
        None => acc.add_passes(scene, n, control),
    };
    let none = Control::none();
    let start = cpu()?;
    add(&mut acc, 1, &none)?;
    let first = cpu()?;
    add(&mut acc, passes - 1 - u32::from(counted), &none)?;
    let end = cpu()?;
    let counted_pass = if counted {
        let counting = Counting::new();
        add(&mut acc, 1, &Control::none().with_counting(&counting))?;
        Some(CountedPass {
            cpu_s: cpu()? - end,
            counts: counting.total(),
        })
    } else {
        None
    };
    let image = acc.film().total();
    Ok(SeedRun {
        seed: scene.integrator().seed,
        first_pass_cpu_s: first - start,
        other_passes_cpu_s: end - first,
        mse: mse_against_noisy_reference(&image, &reference.image, &reference.variance),
        counted_pass,
    })
}

/// Means over the seeds and the extrapolated CPU time to each target RMSE.
fn summarise(tracker: Tracker, passes: u32, seeds: Vec<SeedRun>) -> TrackerResult {
    let n = seeds.len() as f64;
    let mean = |f: &dyn Fn(&SeedRun) -> f64| seeds.iter().map(f).sum::<f64>() / n;
    // The counted pass (`--counters`) is timed apart from the other passes.
    let counted = u32::from(seeds.iter().any(|s| s.counted_pass.is_some()));
    let per_pass = mean(&|s| s.other_passes_cpu_s) / f64::from(passes - 1 - counted);
    let pilot = (mean(&|s| s.first_pass_cpu_s) - per_pass).max(0.0);
    let mse = mean(&|s| s.mse).max(0.0);
    let cpu_to_rmse = TARGETS
        .iter()
        .map(|&e| CpuTo {
            target: e,
            cpu_s: pilot + per_pass * f64::from(passes) * mse / (e * e),
        })
        .collect();
    TrackerResult {
        tracker,
        passes,
        pilot_cpu_s: pilot,
        cpu_per_pass_s: per_pass,
        rmse: mse.sqrt(),
        cpu_to_rmse,
        counters: counter_summary(&seeds, per_pass),
        seeds,
    }
}

/// The counted passes' means over the seeds (`None` when no pass was counted), and their
/// time over `per_pass`, an uncounted pass's.
fn counter_summary(seeds: &[SeedRun], per_pass: f64) -> Option<CounterSummary> {
    let counted: Vec<&CountedPass> = seeds
        .iter()
        .filter_map(|s| s.counted_pass.as_ref())
        .collect();
    if counted.is_empty() {
        return None;
    }
    let n = counted.len() as f64;
    let mean = |c: Counter| counted.iter().map(|p| p.counts.get(c) as f64).sum::<f64>() / n;
    let samples = mean(Counter::Samples);
    let cpu = counted.iter().map(|p| p.cpu_s).sum::<f64>() / n;
    Some(CounterSummary {
        counted_pass_cpu_s: cpu,
        counting_cost: cpu / per_pass - 1.0,
        means: Counter::ALL
            .into_iter()
            .map(|c| CounterMean {
                counter: c.name(),
                per_pass: mean(c),
                per_sample: mean(c) / samples,
            })
            .collect(),
    })
}

fn print_case(case: &Case) {
    println!(
        "{} at {}×{}, σt(d_min) {}: reference {} passes ({:?}, RMSE {:.2e})",
        case.scene,
        case.resolution[0],
        case.resolution[1],
        case.sigma_t,
        case.reference.passes,
        case.reference.tracker,
        case.reference.rmse
    );
    println!(
        "  {:<9} {:>6} {:>9} {:>11} {:>10} {:>13} {:>13}",
        "tracker", "passes", "pilot s", "CPU s/pass", "RMSE", "CPU s → 0.02", "CPU s → 0.01"
    );
    for t in &case.trackers {
        println!(
            "  {:<9} {:>6} {:>9.2} {:>11.3} {:>10.3e} {:>13.1} {:>13.1}",
            format!("{:?}", t.tracker).to_lowercase(),
            t.passes,
            t.pilot_cpu_s,
            t.cpu_per_pass_s,
            t.rmse,
            t.cpu_to_rmse[0].cpu_s,
            t.cpu_to_rmse[1].cpu_s
        );
    }
    for r in &case.routes {
        println!(
            "  {:<9} {:>6} {:>9.2} {:>11.3} {:>10.3e} {:>13.1} {:>13.1}   {:.2}× weighted's speed ({})",
            "route",
            r.renders.passes,
            r.renders.pilot_cpu_s,
            r.renders.cpu_per_pass_s,
            r.renders.rmse,
            r.renders.cpu_to_rmse[0].cpu_s,
            r.renders.cpu_to_rmse[1].cpu_s,
            r.speedup_over_weighted_at_001,
            r.route
        );
    }
    print_counters(case);
    println!(
        "  weighted is {:.2}× as fast to RMSE 0.01",
        case.speedup_at_001
    );
}

/// With `--counters`: the counted passes' work per sample traced (samples per pass in the
/// first row), one column per tracker and route, and what counting cost.
fn print_counters(case: &Case) {
    let trackers = case
        .trackers
        .iter()
        .map(|t| (format!("{:?}", t.tracker).to_lowercase(), t));
    let routes = case
        .routes
        .iter()
        .map(|r| (r.route.to_string(), &r.renders));
    let columns: Vec<(String, &CounterSummary)> = trackers
        .chain(routes)
        .filter_map(|(name, t)| t.counters.as_ref().map(|c| (name, c)))
        .collect();
    if columns.is_empty() {
        return;
    }
    print!("  {:<24}", "work per sample");
    for (name, _) in &columns {
        print!(" {name:>12.12}");
    }
    println!();
    for (i, counter) in Counter::ALL.into_iter().enumerate() {
        let (label, per_pass) = match counter {
            Counter::Samples => ("samples (per pass)".to_string(), true),
            other => (other.name().to_string(), false),
        };
        print!("  {label:<24}");
        for (_, c) in &columns {
            let m = &c.means[i];
            print!(
                " {:>12.3}",
                if per_pass { m.per_pass } else { m.per_sample }
            );
        }
        println!();
    }
    print!("  {:<24}", "counting's cost");
    for (_, c) in &columns {
        print!(" {:>11.1}%", 100.0 * c.counting_cost);
    }
    println!();
}

fn print_summary(cases: &[Case]) {
    println!("CPU time to RMSE 0.01, delta → weighted:");
    for c in cases {
        let at = |i: usize| c.trackers[i].cpu_to_rmse[1].cpu_s;
        println!(
            "  {:<40} σt {:>4}: {:>8.1} s → {:>8.1} s ({:.2}×)",
            c.scene,
            c.sigma_t,
            at(0),
            at(1),
            c.speedup_at_001
        );
    }
}
