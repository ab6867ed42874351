//! `sweep bench`: the thesis's headline frame, timed.
//!
//! foot (256³), 512×512, 40 000 photons, nused 150, maxdist 0.1, stepsize 0.0005, three-point
//! spot lights, single + multiple. The thesis needed 2500–3000 s on a 2006 Xeon (§8.2).
//! Runs once with the caches (`shadow_cache`, `ms_cache`) and once without.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{Context, Result};
use serde::Serialize;
use volphot::{
    Control, Layer, Scene, SearchPath, build_photon_map, load_params, peak_memory_bytes,
};

use crate::cli::BenchArgs;

#[derive(Debug, Serialize)]
struct Measurement {
    configuration: String,
    scene: String,
    resolution: [u32; 2],
    threads: usize,
    photons_emitted: u64,
    photons_stored: u64,
    photon_tracing_s: f64,
    photons_per_s: f64,
    tree_build_s: f64,
    render_s: f64,
    total_s: f64,
    samples: u64,
    samples_per_s: f64,
    gathers: u64,
    shadow_queries: u64,
    mean_single: f64,
    mean_multiple: f64,
    peak_memory_mib: Option<f64>,
}

/// The headline scene: the foot preset, or the foot phantom at 256² with `--quick`.
fn headline(args: &BenchArgs) -> PathBuf {
    if let Some(s) = &args.scene {
        return s.clone();
    }
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../experiments/scenes");
    let local = Path::new("experiments/scenes");
    let base = if local.is_dir() {
        local.to_path_buf()
    } else {
        dir
    };
    base.join(if args.quick {
        "phantom-foot.toml"
    } else {
        "foot.toml"
    })
}

/// Runs the benchmark.
pub(crate) fn run(args: &BenchArgs) -> Result<ExitCode> {
    let scene_path = headline(args);
    let (mut params, _) = load_params(&scene_path)
        .with_context(|| format!("benchmark scene {}", scene_path.display()))?;
    if args.quick {
        params.camera.resolution = [256, 256];
    }
    let pool = super::thread_pool(args.threads)?;
    let base = scene_path.parent().unwrap_or(Path::new("."));
    let scene = pool.install(|| Scene::from_params(&params, base, &SearchPath::from_env()))?;
    let mut configurations = vec![("cached", 128u32, 128u32)];
    if !args.cached_only {
        configurations.push(("uncached", 0, 0));
    }
    let mut results = Vec::new();
    for (name, shadow_cache, ms_cache) in configurations {
        let mut integrator = scene.integrator().clone();
        integrator.shadow_cache = shadow_cache;
        integrator.ms_cache = ms_cache;
        let s = scene.with_integrator(integrator)?;
        eprintln!(
            "bench {name}: {} at {}×{} on {} thread(s)…",
            scene_path.display(),
            params.camera.resolution[0],
            params.camera.resolution[1],
            pool.current_num_threads()
        );
        let m = pool.install(|| -> Result<Measurement> {
            let start = std::time::Instant::now();
            let map = build_photon_map(&s, &Control::none())?;
            let out = volphot::render_march(&s, &[&map], &[], &Control::none())?;
            let total = start.elapsed().as_secs_f64();
            let film = &out.films[0];
            Ok(Measurement {
                configuration: name.into(),
                scene: scene_path.display().to_string(),
                resolution: params.camera.resolution,
                threads: rayon::current_num_threads(),
                photons_emitted: map.stats().emitted,
                photons_stored: map.stats().stored,
                photon_tracing_s: map.stats().seconds,
                photons_per_s: map.stats().emitted as f64 / map.stats().seconds.max(1e-9),
                tree_build_s: map.build_seconds(),
                render_s: out.stats.seconds,
                total_s: total,
                samples: out.stats.samples,
                samples_per_s: out.stats.samples as f64 / out.stats.seconds.max(1e-9),
                gathers: out.stats.gathers,
                shadow_queries: out.stats.shadow_queries,
                mean_single: film.mean(Layer::Single),
                mean_multiple: film.mean(Layer::Multiple),
                peak_memory_mib: peak_memory_bytes().map(|b| b as f64 / 1048576.0),
            })
        })?;
        println!(
            "{:<9} total {:>7.2} s | photons {:>7.3} s ({:.2e}/s, {} stored) | tree {:.3} s | render {:>7.2} s, {:.2e} samples/s | peak {:.0} MiB",
            m.configuration,
            m.total_s,
            m.photon_tracing_s,
            m.photons_per_s,
            m.photons_stored,
            m.tree_build_s,
            m.render_s,
            m.samples_per_s,
            m.peak_memory_mib.unwrap_or(f64::NAN)
        );
        results.push(m);
    }
    if results.len() == 2 {
        let (c, u) = (&results[0], &results[1]);
        println!(
            "cache error: mean single {:+.2} %, mean multiple {:+.2} % (cached vs uncached)",
            100.0 * (c.mean_single / u.mean_single - 1.0),
            100.0 * (c.mean_multiple / u.mean_multiple - 1.0)
        );
    }
    if let Some(path) = &args.json {
        volphot::write_atomic(path, serde_json::to_string_pretty(&results)?.as_bytes())?;
    }
    Ok(ExitCode::SUCCESS)
}
