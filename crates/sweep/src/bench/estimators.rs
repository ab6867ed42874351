//! `sweep bench --estimators`: volphot's multiple-scattering estimators and its path
//! tracer against one converged reference of the whole image, in one run.
//!
//! Every row is a render of the scene at its own settings but the estimator's (means over
//! `--seeds` seeds): CPU-seconds, RMSE of the whole image against the reference with the
//! reference's noise removed, and for the photon estimators the same split by layer —
//! single scattering (the marcher's) and multiple scattering, with the multiple layer's
//! mean against the reference's — so that a row's error can be told apart: a bias floor
//! (the multiple layer's mean off), noise (falling as iterations are added) or the eye
//! rays' own sampling error (the single layer's, which replayed eye rays never lower).
//!
//! An iterating row also records its error after every iteration (the render is given the
//! reference), so its CPU-seconds to an error are read off that curve: the row's CPU time
//! shared out over the iterations in proportion to their measured wall time.

use std::path::Path;
use std::process::ExitCode;

use anyhow::Result;
use serde::Serialize;
use volphot::{
    Control, EyeRays, Film, Layer, MsEstimator, ProgressiveStats, RadiusRule, Scene, SceneParams,
    SearchPath,
};

use super::BenchOptions;
use super::peer::{
    Part, Reference, Row, cpu_timed, mean_of, part_of, path_rows, photon_scene, print_rows,
    reference_layers, row,
};
use crate::analyse::mse_against_noisy_reference;

/// How many photons a configuration traces per map: a multiple or a fraction of the
/// scene's `volume_photons`.
#[derive(Debug, Clone, Copy)]
enum Photons {
    Times(u64),
    Over(u64),
}

impl Photons {
    fn of(self, scene_photons: u64) -> u64 {
        match self {
            Photons::Times(k) => scene_photons.saturating_mul(k),
            Photons::Over(k) => (scene_photons / k).max(1),
        }
    }
}

/// One estimator configuration of `--estimators`.
#[derive(Debug, Clone, Copy)]
struct Config {
    name: &'static str,
    estimator: MsEstimator,
    photons: Photons,
    iterations: u32,
    eye_rays: EyeRays,
    /// The radius rule.
    radius: RadiusRule,
    /// The planes' blur half-width (`maxdist`), when not the scene's.
    blur: Option<f32>,
    /// The marching step as a multiple of the scene's.
    step: f32,
}

const fn config(
    name: &'static str,
    estimator: MsEstimator,
    photons: Photons,
    iterations: u32,
    eye_rays: EyeRays,
) -> Config {
    Config {
        name,
        estimator,
        photons,
        iterations,
        eye_rays,
        radius: RadiusRule::Auto,
        blur: None,
        step: 1.0,
    }
}

/// Iterations of the iterating rows (their error is read after each).
const ITERATIONS: u32 = 32;

/// Planes trace a tenth of the photons: every plane meets many eye rays, so each map needs
/// far fewer (and its march costs in proportion to them). Their blur is 0.01 (2.5 voxels
/// of a 256³ volume in the unit box): it only bounds the weight of grazing eye rays.
const PLANE_BLUR: f32 = 0.01;

/// Beams over fresh eye rays with radius rule `rule`.
const fn fresh_beams(name: &'static str, rule: RadiusRule) -> Config {
    use MsEstimator::Beam;
    Config {
        radius: rule,
        ..config(name, Beam, Photons::Times(1), ITERATIONS, EyeRays::Fresh)
    }
}

/// Photon planes over a tenth of the photons, fresh eye rays, the step `step` × the scene's.
const fn planes(name: &'static str, step: f32) -> Config {
    use MsEstimator::Plane;
    Config {
        blur: Some(PLANE_BLUR),
        step,
        ..config(name, Plane, Photons::Over(10), ITERATIONS, EyeRays::Fresh)
    }
}

/// The configurations compared, in the order they run.
const CONFIGS: [Config; 11] = {
    use EyeRays::{Fresh, Replayed};
    use MsEstimator::{Beam, Points, Progressive};
    use Photons::Times;
    [
        config("points", Points, Times(1), 1, Replayed),
        config("points 10× photons", Points, Times(10), 1, Replayed),
        config("progressive", Progressive, Times(1), ITERATIONS, Replayed),
        config(
            "progressive fresh",
            Progressive,
            Times(1),
            ITERATIONS,
            Fresh,
        ),
        config("beam", Beam, Times(1), 1, Replayed),
        config("beam it.", Beam, Times(1), ITERATIONS, Replayed),
        fresh_beams("beam fresh nearest", RadiusRule::Nearest),
        fresh_beams("beam fresh global", RadiusRule::Global),
        fresh_beams("beam fresh balanced", RadiusRule::Balanced),
        planes("plane fresh", 1.0),
        planes("plane fresh step ×4", 4.0),
    ]
};

/// A photon row's error split by layer, and its error after each iteration (means over
/// seeds).
#[derive(Debug, Serialize)]
struct Detail {
    /// The configuration's name (`setting` without its photon count).
    name: &'static str,
    setting: String,
    single_rmse: f64,
    multiple_rmse: f64,
    multiple_mean_ratio: f64,
    /// Per iteration: CPU-seconds so far and the RMSE of the image then against the
    /// reference, its noise removed (empty for one-pass rows).
    curve: Vec<(f64, f64)>,
}

#[derive(Debug, Serialize)]
struct EstimatorReport {
    machine: super::Machine,
    scene: String,
    resolution: [u32; 2],
    reference_passes: u32,
    rows: Vec<Row>,
    details: Vec<Detail>,
    /// Each row's CPU-seconds to RMSE 0.02 and 0.01.
    time_to_rmse: Vec<TimeTo>,
}

/// Runs the comparison.
pub(crate) fn run(
    args: &BenchOptions,
    scene_path: &Path,
    params: &SceneParams,
) -> Result<ExitCode> {
    let pool = crate::render::thread_pool(args.threads)?;
    let base = scene_path.parent().unwrap_or(Path::new("."));
    let scene = pool.install(|| Scene::from_params(params, base, &SearchPath::from_env()))?;
    let passes = args.reference_passes.unwrap_or(1024);
    eprintln!("estimators: reference ({passes} passes) and renders…");
    let (rows, details) = pool.install(|| -> Result<_> {
        let references = reference_layers(&scene, passes)?;
        let mut rows = path_rows(
            &scene,
            Part::All,
            &references[0],
            &args.peer_spp,
            args.seeds,
        )?;
        let (photon_rows, details) = estimator_rows(&scene, &references, args.seeds)?;
        rows.extend(photon_rows);
        Ok((rows, details))
    })?;
    let report = EstimatorReport {
        machine: super::Machine::describe(),
        scene: crate::store::recorded_path(scene_path),
        resolution: params.camera.resolution,
        reference_passes: passes,
        time_to_rmse: time_to_rmse(&rows, &details),
        rows,
        details,
    };
    print_rows(&report.rows);
    print_layers(&report.details);
    print_time_to_error(&report.time_to_rmse);
    if let Some(path) = &args.json {
        volphot::write_atomic(path, serde_json::to_string_pretty(&report)?.as_bytes())?;
    }
    Ok(ExitCode::SUCCESS)
}

/// One seed's render of a configuration: its film, CPU-seconds and iterations.
struct Run {
    film: Film,
    cpu_s: f64,
    progressive: Option<ProgressiveStats>,
}

/// Every configuration at `seeds` seeds: its row of the whole image and its details.
fn estimator_rows(
    scene: &Scene,
    references: &[Reference; 3],
    seeds: u32,
) -> Result<(Vec<Row>, Vec<Detail>)> {
    let photons = scene.integrator().volume_photons;
    let (mut rows, mut details) = (Vec::new(), Vec::new());
    for c in CONFIGS {
        let runs = (0..seeds as u64)
            .map(|k| render_config(scene, c, k, &references[0].image))
            .collect::<Result<Vec<Run>>>()?;
        let setting = format!("{} ({} photons)", c.name, c.photons.of(photons));
        let images: Vec<_> = runs
            .iter()
            .map(|r| (part_of(&r.film, Part::All), r.cpu_s))
            .collect();
        rows.push(row(
            "volphot photon",
            Part::All,
            setting.clone(),
            &references[0],
            &images,
        ));
        details.push(detail(c.name, setting, &runs, references));
    }
    Ok((rows, details))
}

/// Configuration `c` rendered with seed offset `k`, given the whole image's reference so
/// that an iterating render records its error after each iteration.
fn render_config(scene: &Scene, c: Config, k: u64, reference: &[glam::Vec3]) -> Result<Run> {
    let photons = scene.integrator().volume_photons;
    let seed = scene.integrator().seed.wrapping_add(1 + k);
    let s = photon_scene(scene, Part::All, seed, |i| {
        i.estimator = c.estimator;
        i.volume_photons = c.photons.of(photons);
        i.photons_per_iteration = 0;
        i.iterations = c.iterations;
        i.eye_rays = c.eye_rays;
        i.radius = c.radius;
        i.maxdist = c.blur.unwrap_or(i.maxdist);
        i.stepsize *= c.step;
    })?;
    // The thinning probes are a fixed cost the path tracer does not pay: left out.
    let control = Control::none().without_error_probes();
    let control = if s.integrator().iterates() {
        control.with_reference(reference)
    } else {
        control
    };
    let (out, cpu_s) = cpu_timed(|| Ok(volphot::render(&s, &control)?))?;
    Ok(Run {
        film: out.film,
        cpu_s,
        progressive: out.record.progressive,
    })
}

/// The layers' errors (RMSE against the reference's layers, its noise removed), the
/// multiple layer's mean against the reference's, and the error curve, over the seeds.
fn detail(
    name: &'static str,
    setting: String,
    runs: &[Run],
    references: &[Reference; 3],
) -> Detail {
    let n = runs.len() as f64;
    let rmse = |layer: Layer, reference: &Reference| {
        let mse = runs
            .iter()
            .map(|r| {
                let image = r.film.layer(layer);
                mse_against_noisy_reference(image, &reference.image, &reference.variance)
            })
            .sum::<f64>()
            / n;
        mse.max(0.0).sqrt()
    };
    let multiple = runs
        .iter()
        .map(|r| mean_of(r.film.layer(Layer::Multiple)))
        .sum::<f64>()
        / n;
    Detail {
        name,
        single_rmse: rmse(Layer::Single, &references[1]),
        multiple_rmse: rmse(Layer::Multiple, &references[2]),
        multiple_mean_ratio: multiple / references[2].mean(),
        curve: curve(runs, &references[0]),
        setting,
    }
}

/// The error curve of iterating runs: after iteration `i`, the mean over the seeds of the
/// CPU-seconds so far (each run's CPU time shared out over its iterations in proportion to
/// their wall time: march, and tracing and trees spread evenly) and of the squared RMSE,
/// less the reference's mean variance (its noise), as an RMSE.
fn curve(runs: &[Run], reference: &Reference) -> Vec<(f64, f64)> {
    let stats: Vec<&ProgressiveStats> =
        runs.iter().filter_map(|r| r.progressive.as_ref()).collect();
    if stats.len() != runs.len() || stats.iter().any(|s| s.errors.is_empty()) {
        return Vec::new();
    }
    let noise = reference
        .variance
        .iter()
        .map(|v| (v.x + v.y + v.z) as f64 / 3.0)
        .sum::<f64>()
        / reference.variance.len().max(1) as f64;
    let len = stats.iter().map(|s| s.errors.len()).min().unwrap_or(0);
    let n = runs.len() as f64;
    (0..len)
        .map(|i| {
            let (mut cpu, mut mse) = (0.0, 0.0);
            for (run, s) in runs.iter().zip(&stats) {
                cpu += run.cpu_s * share_until(s, i);
                mse += s.errors[i] * s.errors[i] - noise;
            }
            (cpu / n, (mse / n).max(0.0).sqrt())
        })
        .collect()
}

/// The share of a render's time spent in its iterations up to `i` (0-based): their march
/// seconds, and tracing and trees spread evenly over the iterations.
fn share_until(s: &ProgressiveStats, i: usize) -> f64 {
    let count = s.march_seconds_each.len().max(1) as f64;
    let even = (s.photon_seconds + s.tree_seconds) / count;
    let total = s.march_seconds + s.photon_seconds + s.tree_seconds;
    if total <= 0.0 {
        return (i + 1) as f64 / count;
    }
    let so_far: f64 = s
        .march_seconds_each
        .iter()
        .take(i + 1)
        .map(|m| m + even)
        .sum();
    so_far / total
}

fn print_layers(details: &[Detail]) {
    println!(
        "{:<46} {:>12} {:>14} {:>14}",
        "by layer", "single RMSE", "multiple RMSE", "multiple/ref"
    );
    for d in details {
        println!(
            "  {:<44} {:>12.3e} {:>14.3e} {:>14.4}",
            d.setting, d.single_rmse, d.multiple_rmse, d.multiple_mean_ratio
        );
    }
}

/// The CPU-seconds one row needs for an RMSE, as the JSON records it (`None`: not reached).
#[derive(Debug, Serialize)]
struct TimeTo {
    /// The configuration's name (`path tracer` for the path tracer).
    name: &'static str,
    setting: String,
    target: f64,
    cpu_s: Option<f64>,
    /// The iteration that first reached it (iterating rows).
    iteration: Option<usize>,
    /// `cpu_s` over the path tracer's.
    times_path: Option<f64>,
}

/// The RMSEs the time is reported for.
const TARGETS: [f64; 2] = [0.02, 0.01];

/// CPU-seconds each row needs for RMSE 0.02 and 0.01: the path tracer's extrapolated from
/// its efficiency (unbiased: MSE ∝ 1/time), the photon estimators' where measured (the
/// first iteration at the target, for iterating rows; their error has a bias floor, so
/// more time does not lower it by a known law).
fn time_to_rmse(rows: &[Row], details: &[Detail]) -> Vec<TimeTo> {
    let best_path = rows
        .iter()
        .filter(|r| r.renderer == "volphot path")
        .map(|r| r.efficiency)
        .fold(f64::INFINITY, f64::min);
    let mut out = Vec::new();
    for target in TARGETS {
        let path_cpu = best_path / (target * target);
        out.push(TimeTo {
            name: "path tracer",
            setting: "path tracer".into(),
            target,
            cpu_s: path_cpu.is_finite().then_some(path_cpu),
            iteration: None,
            times_path: Some(1.0),
        });
        let photon_rows = rows.iter().filter(|r| r.renderer == "volphot photon");
        for (r, d) in photon_rows.zip(details) {
            let reached = time_to(r, d, target);
            out.push(TimeTo {
                name: d.name,
                setting: r.setting.clone(),
                target,
                cpu_s: reached.map(|(cpu, _)| cpu),
                iteration: reached.and_then(|(_, i)| i),
                times_path: reached
                    .map(|(cpu, _)| cpu / path_cpu)
                    .filter(|x| x.is_finite()),
            });
        }
    }
    out
}

fn print_time_to_error(times: &[TimeTo]) {
    println!(
        "CPU-seconds to reach RMSE 0.02 / 0.01 (the path tracer's extrapolated from its best RMSE²·CPU-s):"
    );
    let reach = |t: &TimeTo| match t.cpu_s {
        Some(cpu) => format!(
            "{cpu:.1}{} (×{:.2} the path tracer)",
            t.iteration
                .map_or(String::new(), |i| format!(" at it. {i}")),
            t.times_path.unwrap_or(f64::NAN)
        ),
        None => "not reached".into(),
    };
    let at = |target: f64| times.iter().filter(move |t| t.target == target);
    for (a, b) in at(TARGETS[0]).zip(at(TARGETS[1])) {
        println!("  {:<46} {} / {}", a.setting, reach(a), reach(b));
    }
}

/// The CPU-seconds at which a row first reaches RMSE `target` (and the iteration, for an
/// iterating row), or `None`.
fn time_to(row: &Row, detail: &Detail, target: f64) -> Option<(f64, Option<usize>)> {
    if detail.curve.is_empty() {
        return (row.rmse <= target).then_some((row.cpu_s, None));
    }
    let i = detail.curve.iter().position(|&(_, e)| e <= target)?;
    Some((detail.curve[i].0, Some(i + 1)))
}

#[cfg(test)]
mod tests {
    use super::super::peer::tests::{image_of, path_traced_scene};
    use super::*;

    /// Every estimator row is a photon-mapping render whatever the scene's method: on a
    /// path-traced scene it differs from the path tracer's row, 10× photons differ from
    /// the scene's photons, and each iterating row has an error curve whose CPU time grows.
    #[test]
    fn estimator_rows_map_photons_on_a_scene_that_asks_for_the_path_tracer() {
        let scene = path_traced_scene();
        let references = reference_layers(&scene, 2).unwrap();
        let path = path_rows(&scene, Part::All, &references[0], &[4], 1).unwrap();
        let (rows, details) = estimator_rows(&scene, &references, 1).unwrap();
        assert_eq!((rows.len(), details.len()), (CONFIGS.len(), CONFIGS.len()));
        for row in &rows {
            assert_ne!(image_of(row), image_of(&path[0]), "{}", row.setting);
        }
        assert_ne!(image_of(&rows[0]), image_of(&rows[1]), "10× photons");
        for (c, d) in CONFIGS.iter().zip(&details) {
            assert!(d.multiple_mean_ratio > 0.0, "{}: {d:?}", d.setting);
            let iterates = c.estimator.iterates();
            assert_eq!(
                d.curve.len(),
                if iterates { c.iterations as usize } else { 0 }
            );
            assert!(d.curve.windows(2).all(|w| w[1].0 >= w[0].0), "{d:?}");
        }
    }

    #[test]
    fn the_time_is_shared_out_by_each_iterations_wall_time() {
        let s = ProgressiveStats {
            march_seconds_each: vec![3.0, 1.0],
            march_seconds: 4.0,
            photon_seconds: 1.0,
            tree_seconds: 1.0,
            ..Default::default()
        };
        assert!((share_until(&s, 0) - 4.0 / 6.0).abs() < 1e-12);
        assert!((share_until(&s, 1) - 1.0).abs() < 1e-12);
    }
}
