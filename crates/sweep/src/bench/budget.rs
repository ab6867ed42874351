//! `sweep bench --reference --budget`: where the reference path tracer's noise comes from
//! and what each part of a path costs, on the headline frame and the phantom head at each
//! `--sigma-t` ([`volphot::reference_budget`]); every route for a faster reference is
//! chosen, ordered and judged by it. The JSON (`--json`) holds every number with the
//! machine, for `sweep claims`.

use std::path::Path;
use std::process::ExitCode;

use anyhow::{Context, Result};
use serde::Serialize;
use volphot::{Control, PixelClass, Scene, SearchPath};

use super::{BenchOptions, Machine};

/// The budget's output.
#[derive(Debug, Serialize)]
struct Report {
    machine: Machine,
    command: Vec<String>,
    threads: usize,
    /// Samples per pixel of each rung (and of each replicate).
    samples: u32,
    cases: Vec<Case>,
}

/// One scene at one σt(d_min).
#[derive(Debug, Serialize)]
struct Case {
    scene: String,
    sigma_t: f32,
    resolution: [u32; 2],
    /// Production's variance per sample of a pixel (averaged over pixels, channels
    /// averaged): the total and each layer.
    variance_per_sample: Layers,
    /// Production's CPU seconds per pass of one sample per pixel, and its split.
    cpu_per_pass_s: f64,
    cpu: CpuSplit,
    classes: Vec<Class>,
    sources: Vec<SourceRow>,
    /// The sources' sum over production's variance: 1 by construction (the footprint is
    /// the remainder), a check of the arithmetic, not a measurement.
    closure: f64,
    /// Each rung of the ladder as a route: what it removes, at what CPU cost.
    routes: Vec<Route>,
}

/// Production's CPU seconds per pass by part of the path.
#[derive(Debug, Serialize)]
struct CpuSplit {
    eye_rays_s: f64,
    single_shadow_rays_s: f64,
    multiple_paths_s: f64,
}

#[derive(Debug, Serialize)]
struct Layers {
    total: f64,
    single: f64,
    multiple: f64,
}

#[derive(Debug, Serialize)]
struct Class {
    class: &'static str,
    pixels: usize,
    /// Production's variance per sample, averaged over the class's pixels.
    variance: f64,
    /// The class's share of the image's summed variance.
    share: f64,
}

#[derive(Debug, Serialize)]
struct SourceRow {
    source: &'static str,
    variance: f64,
    share: f64,
    classes: Vec<ClassValue>,
}

#[derive(Debug, Serialize)]
struct ClassValue {
    class: &'static str,
    variance: f64,
}

#[derive(Debug, Serialize)]
struct Route {
    route: &'static str,
    replaces: &'static str,
    variance: f64,
    cpu_per_pass_s: f64,
    /// The image's mean and its standard error (every rung estimates the same image).
    mean: f64,
    mean_se: f64,
    /// Production's variance × cost with samples allocated by the noise over this
    /// route's: its predicted speed-up to a given RMSE.
    predicted_speedup: f64,
}

/// Runs the budget.
pub(crate) fn run(args: &BenchOptions) -> Result<ExitCode> {
    let pool = crate::render::thread_pool(args.threads)?;
    let mut cases = Vec::new();
    for scene_path in super::reference::scenes(args)? {
        let (params, _) = crate::plan::load_scene(&scene_path)
            .with_context(|| format!("benchmark scene {}", scene_path.display()))?;
        for &t in &args.sigma_t {
            let params = super::reference::case_params(&params, t, args)
                .with_context(|| format!("{} at σt(d_min) {t}", scene_path.display()))?;
            let base = scene_path.parent().unwrap_or(Path::new("."));
            let case = pool.install(|| -> Result<Case> {
                let scene = Scene::from_params(&params, base, &SearchPath::from_env())?;
                scene.medium().prepare();
                eprintln!(
                    "budget: {} at σt(d_min) {t}, {}², {} samples per pixel and rung…",
                    scene_path.display(),
                    params.camera.resolution[0],
                    args.budget_samples
                );
                let budget =
                    volphot::reference_budget(&scene, args.budget_samples, &Control::none())?;
                Ok(case(&scene_path, t, params.camera.resolution, &budget))
            })?;
            print_case(&case);
            cases.push(case);
        }
    }
    let report = Report {
        machine: Machine::describe(),
        command: crate::store::recorded_command(),
        threads: pool.current_num_threads(),
        samples: args.budget_samples,
        cases,
    };
    if let Some(path) = &args.json {
        volphot::write_atomic(path, serde_json::to_string_pretty(&report)?.as_bytes())?;
    }
    Ok(ExitCode::SUCCESS)
}

fn case(scene: &Path, sigma_t: f32, resolution: [u32; 2], b: &volphot::Budget) -> Case {
    let production = &b.variants[0];
    let pixels: usize = b.class_pixels.iter().sum();
    let classes = PixelClass::ALL
        .iter()
        .enumerate()
        .map(|(k, c)| Class {
            class: c.name(),
            pixels: b.class_pixels[k],
            variance: production.by_class[k],
            share: production.by_class[k] * b.class_pixels[k] as f64
                / (production.variance.total * pixels as f64).max(f64::MIN_POSITIVE),
        })
        .collect();
    let sources = b
        .sources
        .iter()
        .map(|s| SourceRow {
            source: s.name,
            variance: s.variance,
            share: s.share,
            classes: PixelClass::ALL
                .iter()
                .enumerate()
                .map(|(k, c)| ClassValue {
                    class: c.name(),
                    variance: s.by_class[k],
                })
                .collect(),
        })
        .collect();
    let routes = b
        .variants
        .iter()
        .map(|v| Route {
            route: v.name,
            replaces: v.replaces,
            variance: v.variance.total,
            cpu_per_pass_s: v.cpu_per_pass_s,
            mean: v.mean.0,
            mean_se: v.mean.1,
            predicted_speedup: production.allocated_variance_cost
                / v.allocated_variance_cost.max(f64::MIN_POSITIVE),
        })
        .collect();
    Case {
        scene: crate::store::recorded_path(scene),
        sigma_t,
        resolution,
        variance_per_sample: Layers {
            total: production.variance.total,
            single: production.variance.single,
            multiple: production.variance.multiple,
        },
        cpu_per_pass_s: production.cpu_per_pass_s,
        cpu: CpuSplit {
            eye_rays_s: b.cpu.eye_rays_s,
            single_shadow_rays_s: b.cpu.single_shadow_rays_s,
            multiple_paths_s: b.cpu.multiple_paths_s,
        },
        classes,
        sources,
        closure: b.closure,
        routes,
    }
}

fn print_case(c: &Case) {
    println!(
        "\n{} at σt(d_min) {}: variance per sample {:.3e} (single {:.3e}, multiple {:.3e}), {:.3} CPU-s a pass (eye rays {:.3}, single shadow rays {:.3}, multiple paths {:.3}); sources sum to {:.2} of it",
        c.scene,
        c.sigma_t,
        c.variance_per_sample.total,
        c.variance_per_sample.single,
        c.variance_per_sample.multiple,
        c.cpu_per_pass_s,
        c.cpu.eye_rays_s,
        c.cpu.single_shadow_rays_s,
        c.cpu.multiple_paths_s,
        c.closure
    );
    println!("{:<26} {:>12} {:>7}", "source", "variance", "share");
    for s in &c.sources {
        println!(
            "{:<26} {:>12.3e} {:>6.1}%",
            s.source,
            s.variance,
            100.0 * s.share
        );
    }
    println!(
        "{:<30} {:>12} {:>10} {:>10}",
        "route (cumulative)", "variance", "CPU-s/pass", "speed-up"
    );
    for r in &c.routes {
        println!(
            "{:<30} {:>12.3e} {:>10.3} {:>9.2}×",
            r.route, r.variance, r.cpu_per_pass_s, r.predicted_speedup
        );
    }
}
