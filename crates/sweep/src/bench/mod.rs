//! `sweep bench`: the thesis's headline frame, configurations side by side in one run; the
//! peer and estimator comparisons are in [`peer`].
//!
//! foot (256³), 512×512, 40 000 photons, nused 150, maxdist 0.1, stepsize 0.0005, three-point
//! spot lights, single + multiple (the thesis needed 2500–3000 s on a 2006 Xeon, §8.2).
//! Each configuration renders the same frame; all are compared with the `marched` one (the
//! thesis's integrator as v0.1 ran it) layer by layer: bias of the mean and the 99th
//! percentile of the per-pixel relative error. `efficiency` compares single scattering with
//! the path tracer's: mean squared error against the true image (estimated from the path
//! tracer's own mean and variance, its noise removed) times CPU-seconds.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{Context, Result};
use serde::Serialize;
use volphot::{
    CacheError, Control, DEFAULT_THIN_BELOW, ErrorBound, Film, IntegratorParams, Layer,
    ReferenceAccumulator, Scene, SearchPath, ShadowEstimator, build_photon_map, peak_memory_bytes,
    process_cpu_seconds,
};

mod budget;
mod estimators;
mod machine;

pub(crate) use machine::check_clean_for;
mod peer;
mod reference;

pub(crate) use machine::Machine;

use crate::analyse::{Agreement, agreement, mse_against_noisy_reference};

/// A configuration of the headline frame (see `sweep bench --help` for each).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum BenchConfig {
    /// The thesis's integrator as v0.1 ran it (what the others are compared with).
    Marched,
    /// Exact optical depth, filled along each eye ray; every gather.
    Exact,
    /// Exact optical depth at every sample.
    EverySample,
    /// The default: gathers and fills thinned by eye transmittance.
    Thinned,
    /// The default on one thread.
    OneThread,
    /// The transmittance and scattering caches.
    Cached,
    /// The default under cinematic light (area key light and sky).
    Cinematic,
    /// Single scattering: the marcher against the path tracer.
    Efficiency,
}

impl BenchConfig {
    /// Every configuration, in the order the table lists them.
    pub(crate) const ALL: [BenchConfig; 8] = [
        BenchConfig::Marched,
        BenchConfig::Exact,
        BenchConfig::EverySample,
        BenchConfig::Thinned,
        BenchConfig::OneThread,
        BenchConfig::Cached,
        BenchConfig::Cinematic,
        BenchConfig::Efficiency,
    ];

    /// The name `--only` and the table use.
    pub(crate) fn name(self) -> &'static str {
        match self {
            BenchConfig::Marched => "marched",
            BenchConfig::Exact => "exact",
            BenchConfig::EverySample => "every-sample",
            BenchConfig::Thinned => "thinned",
            BenchConfig::OneThread => "one-thread",
            BenchConfig::Cached => "cached",
            BenchConfig::Cinematic => "cinematic",
            BenchConfig::Efficiency => "efficiency",
        }
    }

    /// What it measures, as `sweep bench --help` says.
    pub(crate) fn help(self) -> &'static str {
        match self {
            BenchConfig::Marched => {
                "The thesis's integrator as v0.1 ran it: shadow rays marched with the step, no caches (what the others are compared with)"
            }
            BenchConfig::Exact => {
                "Exact optical depth, filled along each eye ray; every gather (`thin_below = 0`)"
            }
            BenchConfig::EverySample => {
                "Exact optical depth at every sample (no interpolation at all)"
            }
            BenchConfig::Thinned => {
                "The default: `exact` with gathers and optical-depth fills spaced out behind the front, by eye transmittance (`thin_below = 0.5`)"
            }
            BenchConfig::OneThread => "The default on one thread (the thread scaling)",
            BenchConfig::Cached => {
                "The transmittance and scattering caches (128 nodes): fast, not exact"
            }
            BenchConfig::Cinematic => {
                "The default under cinematic light: the `[three_point]` layout as a soft area key light and a sky (`three_point.style = \"cinematic\"`)"
            }
            BenchConfig::Efficiency => {
                "Single scattering only: the marcher against the path tracer, RMSE² × CPU-s"
            }
        }
    }
}

/// What `sweep bench` compares.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum BenchMode {
    /// The configurations side by side.
    Configurations,
    /// volphot against Mitsuba 3.
    Peer,
    /// The multiple-scattering estimators against the path tracer.
    Estimators,
    /// The path tracer's trackers against each other.
    Reference,
}

/// The validated options of `sweep bench`.
#[derive(Debug, Clone)]
pub(crate) struct BenchOptions {
    /// What is compared.
    pub(crate) mode: BenchMode,
    /// A small frame on the foot phantom instead of the real foot at 512².
    pub(crate) quick: bool,
    /// Worker threads of the multi-threaded runs (all cores when `None`).
    pub(crate) threads: Option<usize>,
    /// Scene to benchmark instead of the headline frame.
    pub(crate) scene: Option<PathBuf>,
    /// The configurations to run (all when empty).
    pub(crate) only: Vec<BenchConfig>,
    /// Renders of each configuration (at least 1).
    pub(crate) runs: u32,
    /// Passes of the path tracer.
    pub(crate) reference_passes: Option<u32>,
    /// Python with Mitsuba 3 installed.
    pub(crate) python: Option<PathBuf>,
    /// Samples per pixel of the peer comparison's renders.
    pub(crate) peer_spp: Vec<u32>,
    /// Seeds per setting of the peer comparison.
    pub(crate) seeds: u32,
    /// Image size (overrides the scene's).
    pub(crate) resolution: Option<[u32; 2]>,
    /// Where the peer comparison's files are kept (a temporary folder when `None`).
    pub(crate) peer_dir: Option<PathBuf>,
    /// Where the measurements are written as JSON.
    pub(crate) json: Option<PathBuf>,
    /// σt(d_min) values of the tracker comparison, or the one σt(d_min) set on the scene of
    /// the other modes (the scene's own when empty).
    pub(crate) sigma_t: Vec<f32>,
    /// Passes of each measured render of the tracker comparison.
    pub(crate) passes: u32,
    /// Where converged references are kept (the tracker comparison).
    pub(crate) reference_pool: Option<PathBuf>,
    /// With the reference mode: the variance budget instead of the trackers' race.
    pub(crate) budget: bool,
    /// Samples per pixel of each rung of the budget.
    pub(crate) budget_samples: u32,
    /// With the reference mode: race the routes to a faster reference too.
    pub(crate) routes: bool,
    /// With the reference mode: count each render's work in its last pass, timed apart.
    pub(crate) counters: bool,
    /// The style of the scene's `[three_point]` lights (the scene's own when `None`).
    pub(crate) lighting: Option<volphot::LightingStyle>,
}

/// The times of one render of a configuration.
#[derive(Debug, Clone, Copy, Serialize)]
struct RunTimes {
    photon_tracing_s: f64,
    render_s: f64,
    cpu_s: Option<f64>,
}

/// Mean, standard deviation (of a sample: `n − 1`; none for one run), min and max of a
/// configuration's times over its runs, as hyperfine reports them.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
struct Spread {
    mean: f64,
    stddev: Option<f64>,
    min: f64,
    max: f64,
}

impl Spread {
    fn of(values: &[f64]) -> Spread {
        let n = values.len().max(1) as f64;
        let mean = values.iter().sum::<f64>() / n;
        let stddev = (values.len() > 1)
            .then(|| (values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt());
        Spread {
            mean,
            stddev,
            min: values.iter().copied().fold(f64::INFINITY, f64::min),
            max: values.iter().copied().fold(f64::NEG_INFINITY, f64::max),
        }
    }
}

/// One configuration's runs.
#[derive(Debug, Serialize)]
struct Measurement {
    configuration: String,
    scene: String,
    resolution: [u32; 2],
    threads: usize,
    photons_stored: u64,
    /// Means over the runs.
    photon_tracing_s: f64,
    render_s: f64,
    cpu_s: Option<f64>,
    /// The render time over the runs, and every run's times.
    render: Spread,
    runs: Vec<RunTimes>,
    samples: u64,
    shadow_queries: u64,
    gathers: u64,
    mean_single: f64,
    mean_multiple: f64,
    /// Against the `marched` configuration, when it ran.
    single_vs_marched: Option<Agreement>,
    multiple_vs_marched: Option<Agreement>,
    cache_error: Option<CacheError>,
    peak_memory_mib: Option<f64>,
    #[serde(skip)]
    film: Film,
}

/// The single-scattering efficiency comparison.
#[derive(Debug, Serialize)]
struct Efficiency {
    marcher_cpu_s: f64,
    marcher_rmse: f64,
    marcher_efficiency: f64,
    path_passes: u32,
    path_cpu_s: f64,
    path_rmse: f64,
    path_efficiency: f64,
}

#[derive(Debug, Serialize)]
struct BenchReport {
    /// What it ran on.
    machine: Machine,
    measurements: Vec<Measurement>,
    speedup_two_threads: Option<f64>,
    efficiency: Option<Efficiency>,
}

/// Sets the one `--sigma-t` given on the scene (which must map σ as the thesis does).
fn set_sigma_t(params: &mut volphot::SceneParams, sigma_t: &[f32]) -> Result<()> {
    match sigma_t {
        [] => Ok(()),
        [t] => {
            with_sigma_t(params, *t)?;
            volphot::validate_params(params)?;
            Ok(())
        }
        many => anyhow::bail!(
            "--sigma-t {many:?}: expected one value here (several are compared only with --reference)"
        ),
    }
}

/// Sets σt(d_min) = `t` on a scene whose σ mapping is the thesis's (the only one where
/// σt(d_min) is a setting).
fn with_sigma_t(params: &mut volphot::SceneParams, t: f32) -> Result<()> {
    anyhow::ensure!(
        params.sigma.mapping == volphot::MappingKind::Thesis,
        "--sigma-t {t} sets σt(d_min), which needs [sigma] mapping = \"thesis\", not {:?}",
        params.sigma.mapping
    );
    params.sigma.t = Some(t);
    Ok(())
}

/// The headline scene: the foot preset, or the foot phantom at 256² with `--quick`.
fn headline(args: &BenchOptions) -> Result<PathBuf> {
    if let Some(s) = &args.scene {
        return Ok(s.clone());
    }
    default_scene(if args.quick {
        "phantom-foot.toml"
    } else {
        "foot.toml"
    })
}

/// A bench's default scene `experiments/scenes/NAME`: in the working folder (a checkout),
/// else in the checkout that holds this binary (`target/release/sweep`), found through the
/// binary's own location — never through the folder it was built in, which a copied binary
/// does not have.
pub(super) fn default_scene(name: &str) -> Result<PathBuf> {
    let relative = Path::new("experiments/scenes").join(name);
    if relative.is_file() {
        return Ok(relative);
    }
    let exe = std::env::current_exe().ok();
    exe.iter()
        .flat_map(|e| e.ancestors().skip(1))
        .map(|a| a.join(&relative))
        .find(|p| p.is_file())
        .with_context(|| {
            format!(
                "the default scene {} is neither in the working folder nor in a checkout that holds this binary ({}); run from the volphot checkout or name a scene with --scene",
                relative.display(),
                exe.map_or("?".into(), |e| e.display().to_string())
            )
        })
}

/// Sets the style of the scene's `[three_point]` lights (`--lighting`).
pub(super) fn set_lighting(
    params: &mut volphot::SceneParams,
    lighting: Option<volphot::LightingStyle>,
) -> Result<()> {
    let Some(style) = lighting else {
        return Ok(());
    };
    let Some(tp) = params.three_point.as_mut() else {
        anyhow::bail!(
            "--lighting: the scene has no [three_point] table whose lights it could restyle"
        );
    };
    tp.style = style;
    Ok(())
}

/// The integrator of a configuration, from the scene's own (thinning off unless the
/// configuration is the default: `thinned`, `one-thread` or `efficiency`).
fn configure(config: BenchConfig, base: &IntegratorParams) -> IntegratorParams {
    let mut s = base.clone();
    s.thin_below = 0.0;
    match config {
        BenchConfig::Marched => {
            s.shadow = ShadowEstimator::March;
            (s.shadow_cache, s.ms_cache) = (0, 0);
        }
        BenchConfig::Exact => {
            s.shadow = ShadowEstimator::Exact;
            (s.shadow_cache, s.ms_cache) = (0, 0);
        }
        BenchConfig::EverySample => {
            s.shadow = ShadowEstimator::Exact;
            s.shadow_stride = 0;
            (s.shadow_cache, s.ms_cache) = (0, 0);
        }
        BenchConfig::Thinned | BenchConfig::OneThread | BenchConfig::Cinematic => {
            s.shadow = ShadowEstimator::Exact;
            s.thin_below = DEFAULT_THIN_BELOW;
            (s.shadow_cache, s.ms_cache) = (0, 0);
        }
        BenchConfig::Cached => (s.shadow_cache, s.ms_cache) = (128, 128),
        BenchConfig::Efficiency => {
            s.shadow = ShadowEstimator::Exact;
            s.thin_below = DEFAULT_THIN_BELOW;
            (s.shadow_cache, s.ms_cache) = (0, 0);
            s.multiple = false;
        }
    }
    s
}

/// Runs the benchmark.
pub(crate) fn run(args: &BenchOptions) -> Result<ExitCode> {
    if args.mode == BenchMode::Reference {
        // The variance budget is a reference bench of its own (`--reference --budget`).
        return if args.budget {
            budget::run(args)
        } else {
            reference::run(args)
        };
    }
    let scene_path = headline(args)?;
    let (mut params, _) = crate::plan::load_scene(&scene_path)
        .with_context(|| format!("benchmark scene {}", scene_path.display()))?;
    if args.quick {
        params.camera.resolution = [256, 256];
    }
    if let Some(resolution) = args.resolution {
        params.camera.resolution = resolution;
    }
    set_sigma_t(&mut params, &args.sigma_t)
        .with_context(|| format!("benchmark scene {}", scene_path.display()))?;
    set_lighting(&mut params, args.lighting)
        .with_context(|| format!("benchmark scene {}", scene_path.display()))?;
    match args.mode {
        BenchMode::Peer => return peer::run(args, &scene_path, &params),
        BenchMode::Estimators => return estimators::run(args, &scene_path, &params),
        BenchMode::Configurations | BenchMode::Reference => {}
    }
    let pool = crate::render::thread_pool(args.threads)?;
    let single_pool = crate::render::thread_pool(Some(1))?;
    let base = scene_path.parent().unwrap_or(Path::new("."));
    let scene = pool.install(|| Scene::from_params(&params, base, &SearchPath::from_env()))?;
    let configs: Vec<BenchConfig> = BenchConfig::ALL
        .into_iter()
        .filter(|c| args.only.is_empty() || args.only.contains(c))
        .collect();
    let mut report = BenchReport {
        machine: Machine::describe(),
        measurements: Vec::new(),
        speedup_two_threads: None,
        efficiency: None,
    };
    for &config in configs.iter().filter(|c| **c != BenchConfig::Efficiency) {
        let lit = if config == BenchConfig::Cinematic {
            scene.with_lighting_style(volphot::LightingStyle::Cinematic)?
        } else {
            scene.clone()
        };
        let s = lit.with_integrator(configure(config, scene.integrator()))?;
        let pool = if config == BenchConfig::OneThread {
            &single_pool
        } else {
            &pool
        };
        let m = pool.install(|| measure(config.name(), &s, &scene_path, args.runs))?;
        report.measurements.push(m);
    }
    compare_with_marched(&mut report.measurements);
    print_measurements(&report.measurements);
    report.speedup_two_threads = speedup(&report.measurements);
    if configs.contains(&BenchConfig::Efficiency) {
        let s = scene.with_integrator(configure(BenchConfig::Efficiency, scene.integrator()))?;
        let e = pool.install(|| efficiency(&s, args.reference_passes.unwrap_or(16)))?;
        print_efficiency(&e);
        report.efficiency = Some(e);
    }
    if let Some(path) = &args.json {
        volphot::write_atomic(path, serde_json::to_string_pretty(&report)?.as_bytes())?;
    }
    Ok(ExitCode::SUCCESS)
}

/// Renders `scene` `runs` times with the photon integrator, each timed in wall and CPU
/// seconds (the film is the last run's: every run renders the same image).
fn measure(name: &str, scene: &Scene, scene_path: &Path, runs: u32) -> Result<Measurement> {
    let [w, h] = scene.params().camera.resolution;
    eprintln!(
        "bench {name}: {} at {w}×{h} on {} thread(s), {runs} run(s)…",
        scene_path.display(),
        rayon::current_num_threads()
    );
    let mut times = Vec::with_capacity(runs as usize);
    let mut last = None;
    for _ in 0..runs.max(1) {
        let cpu_start = process_cpu_seconds();
        let map = build_photon_map(scene, &Control::none())?;
        let out = volphot::render_march(scene, &[&map], &[], &Control::none())?;
        let cpu_s = process_cpu_seconds()
            .zip(cpu_start)
            .map(|(end, start)| end - start);
        times.push(RunTimes {
            photon_tracing_s: map.stats().seconds,
            render_s: out.stats.seconds,
            cpu_s,
        });
        last = Some((map, out));
    }
    let (map, out) = last.expect("at least one run");
    let film = out.films.into_iter().next().expect("one film");
    let mean = |f: fn(&RunTimes) -> Option<f64>| {
        let values: Option<Vec<f64>> = times.iter().map(f).collect();
        values.map(|v| Spread::of(&v).mean)
    };
    let render = Spread::of(&times.iter().map(|t| t.render_s).collect::<Vec<_>>());
    Ok(Measurement {
        configuration: name.into(),
        scene: crate::store::recorded_path(scene_path),
        resolution: [w, h],
        threads: rayon::current_num_threads(),
        photons_stored: map.stats().stored,
        photon_tracing_s: mean(|t| Some(t.photon_tracing_s)).unwrap_or_default(),
        render_s: render.mean,
        cpu_s: mean(|t| t.cpu_s),
        render,
        runs: times,
        samples: out.stats.samples,
        shadow_queries: out.stats.shadow_queries,
        gathers: out.stats.gathers,
        mean_single: film.mean(Layer::Single),
        mean_multiple: film.mean(Layer::Multiple),
        single_vs_marched: None,
        multiple_vs_marched: None,
        cache_error: out.cache_errors.into_iter().next().flatten(),
        peak_memory_mib: peak_memory_bytes().map(|b| b as f64 / 1048576.0),
        film,
    })
}

/// Fills each measurement's agreement with the `marched` one.
fn compare_with_marched(measurements: &mut [Measurement]) {
    let Some(marched) = measurements
        .iter()
        .find(|m| m.configuration == "marched")
        .map(|m| m.film.clone())
    else {
        return;
    };
    for m in measurements.iter_mut() {
        m.single_vs_marched = agreement(m.film.layer(Layer::Single), marched.layer(Layer::Single));
        m.multiple_vs_marched = agreement(
            m.film.layer(Layer::Multiple),
            marched.layer(Layer::Multiple),
        );
    }
}

/// Render time on one thread over render time on the pool, when both ran.
fn speedup(measurements: &[Measurement]) -> Option<f64> {
    let time = |name: &str| {
        measurements
            .iter()
            .find(|m| m.configuration == name)
            .map(|m| m.render_s)
    };
    let (one, many) = (time("one-thread")?, time("thinned")?);
    let threads = measurements
        .iter()
        .find(|m| m.configuration == "thinned")?
        .threads;
    println!(
        "thread scaling: the default (thinned) on {threads} thread(s) is {:.2}× one thread",
        one / many
    );
    Some(one / many)
}

fn print_measurements(measurements: &[Measurement]) {
    let pct = |a: Option<Agreement>| match a {
        Some(a) => format!("{:+7.2} % {:6.2} %", 100.0 * a.mean, 100.0 * a.p99),
        None => format!("{:>18}", "—"),
    };
    println!(
        "{:<13} {:>3} {:>17} {:>7} {:>9} {:>10} {:>10} | {:^18} | {:^18}",
        "config",
        "thr",
        "render s mean ± σ",
        "min",
        "CPU s",
        "samples/s",
        "shadow/smp",
        "single: bias, p99",
        "multiple: bias, p99"
    );
    for m in measurements {
        let sd = m
            .render
            .stddev
            .map_or(format!("{:>6}", "—"), |sd| format!("{sd:>6.2}"));
        println!(
            "{:<13} {:>3} {:>8.2} ± {sd} {:>7.2} {:>9.2} {:>10.3e} {:>10.2} | {} | {}",
            m.configuration,
            m.threads,
            m.render.mean,
            m.render.min,
            m.cpu_s.unwrap_or(f64::NAN),
            m.samples as f64 / m.render_s.max(1e-9),
            m.shadow_queries as f64 / m.samples.max(1) as f64,
            pct(m.single_vs_marched),
            pct(m.multiple_vs_marched)
        );
        if let Some(e) = &m.cache_error {
            for (what, b) in [("shadow", e.shadow), ("scattering", e.multiple)] {
                print_bound(&format!("{what} cache measured at {} probes", e.probes), b);
            }
            if let Some(t) = &e.thinning {
                for (what, b) in [("single", t.single), ("multiple", t.multiple)] {
                    print_bound(
                        &format!("thinning measured at {} pixels, {what}", t.pixels),
                        b,
                    );
                }
            }
        }
    }
}

/// One measured error bound (a cache's or thinning's), under its configuration's row.
fn print_bound(what: &str, bound: Option<ErrorBound>) {
    if let Some(b) = bound {
        println!(
            "{:<13} {what}: bias {:+.2} %, p99 {:.2} %, max {:.1} %",
            "",
            100.0 * b.mean,
            100.0 * b.p99,
            100.0 * b.max
        );
    }
}

/// Single scattering: the marcher's squared error times CPU-seconds against the path
/// tracer's (whose mean squared error at `n` passes is its per-pass variance over `n`, so
/// its efficiency does not depend on `n`).
fn efficiency(scene: &Scene, passes: u32) -> Result<Efficiency> {
    eprintln!("bench efficiency: single scattering, marcher vs path tracer ({passes} passes)…");
    let cpu = || process_cpu_seconds().context("CPU time is not available here");
    let start = cpu()?;
    let out = volphot::render_march(scene, &[], &[], &Control::none())?;
    let marcher_cpu_s = cpu()? - start;
    let camera = scene.camera();
    let mut reference =
        ReferenceAccumulator::new(camera.width() as usize, camera.height() as usize);
    let start = cpu()?;
    reference.add_passes(scene, passes, &Control::none())?;
    let path_cpu_s = cpu()? - start;
    let reference = reference.film();
    let variance = reference
        .variance(Layer::Single)
        .context("the path tracer's film keeps its variance")?;
    let marcher_mse = mse_against_noisy_reference(
        out.films[0].layer(Layer::Single),
        reference.layer(Layer::Single),
        variance,
    );
    // Variance of the mean at `passes` = the path tracer's own mean squared error.
    let path_mse = variance
        .iter()
        .map(|v| (v.x + v.y + v.z) as f64)
        .sum::<f64>()
        / (3 * variance.len()) as f64;
    Ok(Efficiency {
        marcher_cpu_s,
        marcher_rmse: marcher_mse.max(0.0).sqrt(),
        marcher_efficiency: marcher_mse.max(0.0) * marcher_cpu_s,
        path_passes: passes,
        path_cpu_s,
        path_rmse: path_mse.sqrt(),
        path_efficiency: path_mse * path_cpu_s,
    })
}

fn print_efficiency(e: &Efficiency) {
    println!(
        "single scattering, RMSE² × CPU-s (lower is better): marcher {:.3e} (RMSE {:.3e} in {:.1} CPU-s), path tracer {:.3e} (RMSE {:.3e} at {} passes in {:.1} CPU-s); the marcher is {:.2}× as efficient",
        e.marcher_efficiency,
        e.marcher_rmse,
        e.marcher_cpu_s,
        e.path_efficiency,
        e.path_rmse,
        e.path_passes,
        e.path_cpu_s,
        e.path_efficiency / e.marcher_efficiency.max(f64::MIN_POSITIVE)
    );
}
