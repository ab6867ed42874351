//! `sweep bench --peer mitsuba`: the same scene rendered by volphot and by Mitsuba 3, errors
//! against a converged reference versus CPU-seconds.
//!
//! The scene is exported ([`volphot::export_mitsuba`]) and rendered by Mitsuba's `volpath`
//! (`scripts/peer_mitsuba.py`, `max_depth` 2 for single scattering and −1 for all), by
//! volphot's path tracer and by its photon-mapping integrator, each at several settings
//! and seeds. The converged reference is volphot's path tracer at many passes with a seed
//! none of the compared renders uses; its per-pixel variance of the mean is known, so the
//! mean squared error of an image against the *true* image is estimated as
//! `mean((image − reference)² − Var(reference))` (see [`mse_against_noisy_reference`]).
//! The agreement test compares Mitsuba's mean (over seeds, at the most samples) with the
//! reference's mean in units of their combined standard error.

use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode};

use anyhow::{Context, Result, bail};
use glam::Vec3;
use serde::{Deserialize, Serialize};
use volphot::{
    Control, Film, IntegratorParams, Layer, Method, ReferenceAccumulator, Scene, SceneParams,
    SearchPath, Tracker, export_mitsuba, process_cpu_seconds, read_pfm,
};

use super::BenchOptions;
use crate::analyse::mse_against_noisy_reference;

/// Which part of the light a comparison is about.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub(super) enum Part {
    /// Single scattering (Mitsuba `max_depth` 2; volphot's single layer).
    Single,
    /// Everything (Mitsuba `max_depth` −1; volphot's single + multiple layers).
    All,
}

impl Part {
    fn max_depth(self) -> i32 {
        match self {
            Part::Single => 2,
            Part::All => -1,
        }
    }
    fn name(self) -> &'static str {
        match self {
            Part::Single => "single",
            Part::All => "all",
        }
    }
}

/// The converged reference of one part: image and per-pixel variance of its mean.
pub(super) struct Reference {
    pub(super) image: Vec<Vec3>,
    pub(super) variance: Vec<Vec3>,
}

impl Reference {
    pub(super) fn mean(&self) -> f64 {
        mean_of(&self.image)
    }
    /// Standard error of the image mean (pixels independent).
    fn standard_error(&self) -> f64 {
        let n = self.variance.len() as f64;
        (self.variance.iter().map(|v| mean3(*v)).sum::<f64>()).sqrt() / n
    }
}

/// One row of the time-to-error table (means over seeds).
#[derive(Debug, Serialize)]
pub(super) struct Row {
    pub(super) renderer: String,
    pub(super) part: Part,
    pub(super) setting: String,
    pub(super) seeds: usize,
    pub(super) cpu_s: f64,
    pub(super) rmse: f64,
    /// RMSE² × CPU-s: lower is better, independent of the sample count for unbiased
    /// renderers.
    pub(super) efficiency: f64,
    pub(super) mean_ratio: f64,
}

/// How many times as efficient (RMSE²·CPU-s) a volphot renderer is as Mitsuba.
#[derive(Debug, Serialize)]
struct Ratio {
    part: Part,
    renderer: String,
    times_as_efficient: f64,
}

/// Mitsuba's mean against volphot's reference.
#[derive(Debug, Serialize)]
struct Agreement {
    part: Part,
    mitsuba_mean: f64,
    /// The standard error of Mitsuba's image mean from every pixel's spread over the seeds
    /// (pixels × (seeds − 1) degrees of freedom; pixels' noise is independent).
    mitsuba_standard_error: f64,
    /// The same from the spread of the seeds' image means alone (seeds − 1 degrees of
    /// freedom: with three seeds it can be several times too small or too large).
    mitsuba_standard_error_of_seed_means: f64,
    volphot_mean: f64,
    volphot_standard_error: f64,
    /// (Mitsuba − volphot) / combined standard error.
    z: f64,
}

#[derive(Debug, Serialize)]
struct PeerReport {
    /// What it ran on.
    machine: super::Machine,
    scene: String,
    resolution: [u32; 2],
    reference_passes: u32,
    mitsuba_variant: String,
    mitsuba_version: String,
    agreement: Vec<Agreement>,
    rows: Vec<Row>,
    /// Per part, each path tracer's efficiency over Mitsuba's (empty without Mitsuba).
    efficiency_vs_mitsuba: Vec<Ratio>,
}

/// One render reported by `peer_mitsuba.py`.
#[derive(Debug, Deserialize)]
struct MitsubaRun {
    max_depth: i32,
    spp: u32,
    seed: u32,
    file: PathBuf,
    cpu_s: f64,
    variant: String,
    mitsuba: String,
    /// The image read from `file`, checked by [`read_mitsuba_images`].
    #[serde(skip)]
    image: Vec<Vec3>,
}

/// Runs the comparison.
pub(crate) fn run(
    args: &BenchOptions,
    scene_path: &Path,
    params: &SceneParams,
) -> Result<ExitCode> {
    let pool = crate::render::thread_pool(args.threads)?;
    let temporary = std::env::temp_dir().join(format!("volphot-peer-{}", std::process::id()));
    let dir = args.peer_dir.clone().unwrap_or_else(|| temporary.clone());
    // The temporary folder goes however the comparison ends (an error in Mitsuba too).
    let _cleanup = args
        .peer_dir
        .is_none()
        .then(|| RemoveOnDrop(temporary.clone()));
    let base = scene_path.parent().unwrap_or(Path::new("."));
    let scene = pool.install(|| Scene::from_params(params, base, &SearchPath::from_env()))?;
    let global = pool.install(|| global_majorant(&scene, params, base))?;
    let name = scene_path
        .file_stem()
        .map_or("scene".into(), |s| s.to_string_lossy().into_owned());
    let files = export_mitsuba(&scene, &dir, &name)?;
    let passes = args.reference_passes.unwrap_or(1024);
    let threads = pool.current_num_threads();
    eprintln!(
        "peer: Mitsuba renders of {} ({} spp × {} seeds)…",
        files.scene.display(),
        join(&args.peer_spp),
        args.seeds
    );
    let mut mitsuba = run_mitsuba(args, &files.scene, &dir.join("mitsuba"), threads)?;
    read_mitsuba_images(&mut mitsuba, args, params.camera.resolution)?;
    eprintln!("peer: volphot reference ({passes} passes) and renders…");
    let report = pool.install(|| -> Result<PeerReport> {
        let references = [Part::Single, Part::All].map(|part| reference(&scene, part, passes));
        let [single, all] = references;
        let references = [(Part::Single, single?), (Part::All, all?)];
        let mut rows = Vec::new();
        let mut agreement = Vec::new();
        for (part, reference) in &references {
            rows.extend(part_rows(
                args,
                &mitsuba,
                [&scene, &global],
                *part,
                reference,
            )?);
            agreement.push(agree(&mitsuba, *part, reference, &args.peer_spp)?);
        }
        let first = mitsuba.first().context("Mitsuba rendered nothing")?;
        Ok(PeerReport {
            machine: super::Machine::describe(),
            scene: crate::store::recorded_path(scene_path),
            resolution: params.camera.resolution,
            reference_passes: passes,
            mitsuba_variant: first.variant.clone(),
            mitsuba_version: first.mitsuba.clone(),
            agreement,
            efficiency_vs_mitsuba: efficiency_vs_mitsuba(&rows),
            rows,
        })
    })?;
    print_report(&report);
    if let Some(path) = &args.json {
        volphot::write_atomic(path, serde_json::to_string_pretty(&report)?.as_bytes())?;
    }
    Ok(ExitCode::SUCCESS)
}

/// The scene with one majorant brick over the whole grid: Mitsuba 3.9.1's `heterogeneous`
/// medium bounds the whole grid by one majorant, so this row shows how much of the ratio is
/// the majorant grid and how much the tracker.
fn global_majorant(scene: &Scene, params: &SceneParams, base: &Path) -> Result<Scene> {
    let mut p = params.clone();
    p.volume.brick_size = scene
        .medium()
        .density_grid()
        .dims()
        .into_iter()
        .max()
        .unwrap_or(1);
    Ok(Scene::from_params(&p, base, &SearchPath::from_env())?)
}

/// Every renderer's rows for one part of the light: Mitsuba's, the path tracer's on the
/// scene and on its copy under one global majorant, the photon renderer's.
fn part_rows(
    args: &BenchOptions,
    mitsuba: &[MitsubaRun],
    [scene, global]: [&Scene; 2],
    part: Part,
    reference: &Reference,
) -> Result<Vec<Row>> {
    let mut rows = mitsuba_rows(mitsuba, part, reference, &args.peer_spp)?;
    rows.extend(path_rows(
        scene,
        part,
        reference,
        &args.peer_spp,
        args.seeds,
    )?);
    rows.extend(tracker_rows(
        "volphot path (global majorant)",
        global,
        Tracker::Weighted,
        part,
        reference,
        &args.peer_spp,
        args.seeds,
    )?);
    rows.extend(photon_rows(scene, part, reference, args.seeds)?);
    Ok(rows)
}

/// Removes a temporary folder when dropped.
struct RemoveOnDrop(PathBuf);

impl Drop for RemoveOnDrop {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

fn join(values: &[u32]) -> String {
    values
        .iter()
        .map(u32::to_string)
        .collect::<Vec<_>>()
        .join(",")
}

fn mean3(v: Vec3) -> f64 {
    (v.x as f64 + v.y as f64 + v.z as f64) / 3.0
}

pub(super) fn mean_of(image: &[Vec3]) -> f64 {
    image.iter().map(|v| mean3(*v)).sum::<f64>() / image.len() as f64
}

/// The scene for one part: single scattering only, or everything (no emission: Mitsuba's
/// medium does not emit, and the export refuses emitting scenes).
fn scene_for(scene: &Scene, part: Part, seed: u64) -> Result<Scene> {
    let mut integrator = scene.integrator().clone();
    integrator.multiple = part == Part::All;
    integrator.seed = seed;
    Ok(scene.with_integrator(integrator)?)
}

/// The scene of a "volphot photon" row: the photon-mapping integrator whatever method the
/// scene itself asks for (a scene with `method = "reference"` would otherwise make every
/// photon row a path-traced render), on one part and seed, with the row's settings.
pub(super) fn photon_scene(
    scene: &Scene,
    part: Part,
    seed: u64,
    settings: impl FnOnce(&mut IntegratorParams),
) -> Result<Scene> {
    let mut integrator = scene.integrator().clone();
    integrator.multiple = part == Part::All;
    integrator.seed = seed;
    integrator.method = Method::Photon;
    settings(&mut integrator);
    Ok(scene.with_integrator(integrator)?)
}

/// A part of a film: the single layer, or single + multiple.
pub(super) fn part_of(film: &Film, part: Part) -> Vec<Vec3> {
    match part {
        Part::Single => film.layer(Layer::Single).to_vec(),
        Part::All => film.combine(&[Layer::Single, Layer::Multiple]),
    }
}

/// The converged reference: volphot's path tracer with a seed no compared render uses.
fn reference(scene: &Scene, part: Part, passes: u32) -> Result<Reference> {
    let (film, acc) = reference_film(scene, part, passes)?;
    let variance = match part {
        Part::Single => film
            .variance(Layer::Single)
            .context("reference variance")?
            .to_vec(),
        Part::All => acc.total_variance().context("reference total variance")?,
    };
    Ok(Reference {
        image: part_of(&film, part),
        variance,
    })
}

/// The converged reference of the whole image and of its single and multiple layers, from
/// one path-traced film.
pub(super) fn reference_layers(scene: &Scene, passes: u32) -> Result<[Reference; 3]> {
    let (film, acc) = reference_film(scene, Part::All, passes)?;
    let layer = |l: Layer| -> Result<Reference> {
        Ok(Reference {
            image: film.layer(l).to_vec(),
            variance: film.variance(l).context("reference variance")?.to_vec(),
        })
    };
    let all = Reference {
        image: part_of(&film, Part::All),
        variance: acc.total_variance().context("reference total variance")?,
    };
    Ok([all, layer(Layer::Single)?, layer(Layer::Multiple)?])
}

/// The path tracer's film of `part` at `passes` passes and its accumulator.
fn reference_film(scene: &Scene, part: Part, passes: u32) -> Result<(Film, ReferenceAccumulator)> {
    let s = scene_for(scene, part, scene.integrator().seed.wrapping_add(1_000_003))?;
    let camera = s.camera();
    let mut acc = ReferenceAccumulator::new(camera.width() as usize, camera.height() as usize);
    acc.add_passes(&s, passes, &Control::none())?;
    Ok((acc.film(), acc))
}

/// Runs `peer_mitsuba.py` for both parts and every spp and seed.
fn run_mitsuba(
    args: &BenchOptions,
    xml: &Path,
    out: &Path,
    threads: usize,
) -> Result<Vec<MitsubaRun>> {
    let python = args
        .python
        .clone()
        .or_else(|| std::env::var_os("VOLPHOT_MITSUBA_PYTHON").map(PathBuf::from))
        .unwrap_or_else(|| PathBuf::from("python3"));
    let script = peer_script(out)?;
    let output = Command::new(&python)
        .arg(&script)
        .arg(xml)
        .arg("--out")
        .arg(out)
        .args(["--max-depth", "2,-1", "--spp", &join(&args.peer_spp)])
        .args([
            "--seeds",
            &args.seeds.to_string(),
            "--threads",
            &threads.to_string(),
        ])
        .output()
        .with_context(|| {
            format!(
                "starting {} (make one with scripts/peer-mitsuba.sh)",
                python.display()
            )
        })?;
    if !output.status.success() {
        bail!(
            "{} {} failed ({}): {}\n(is Mitsuba 3 installed for it? scripts/peer-mitsuba.sh makes a virtual environment with it)",
            python.display(),
            script.display(),
            output.status,
            String::from_utf8_lossy(&output.stderr).trim()
        );
    }
    String::from_utf8_lossy(&output.stdout)
        .lines()
        .filter(|l| l.starts_with('{'))
        .map(|l| {
            serde_json::from_str(l).with_context(|| format!("reading Mitsuba's report line {l}"))
        })
        .collect()
}

/// Reads every image Mitsuba wrote, before any volphot render: one for each part, sample
/// count and seed asked for, each of the requested `[width, height]` and finite. An image of
/// another size was compared pixel by pixel over the shorter of the two and reported as
/// "136884× Mitsuba's efficiency".
fn read_mitsuba_images(runs: &mut [MitsubaRun], args: &BenchOptions, size: [u32; 2]) -> Result<()> {
    for part in [Part::Single, Part::All] {
        for &spp in &args.peer_spp {
            for seed in 0..args.seeds {
                anyhow::ensure!(
                    runs.iter()
                        .any(|r| r.max_depth == part.max_depth() && r.spp == spp && r.seed == seed),
                    "Mitsuba reported no render of max_depth {}, {spp} spp, seed {seed} (the peer script's output lacks it)",
                    part.max_depth()
                );
            }
        }
    }
    for run in runs.iter_mut() {
        let (width, height, image) = read_pfm(&run.file)
            .with_context(|| format!("reading Mitsuba's image {}", run.file.display()))?;
        anyhow::ensure!(
            [width, height] == size.map(|n| n as usize),
            "Mitsuba's image {} is {width}×{height}, but {}×{} was rendered; the peer's images must have the requested size to be compared",
            run.file.display(),
            size[0],
            size[1]
        );
        if let Some(at) = image.iter().position(|v| !v.is_finite()) {
            bail!(
                "Mitsuba's image {} holds a non-finite value at pixel ({}, {}): {:?}; it cannot be compared",
                run.file.display(),
                at % width,
                at / width,
                image[at]
            );
        }
        run.image = image;
    }
    Ok(())
}

/// The Mitsuba driver (`scripts/peer_mitsuba.py`), built into the binary and written
/// beside the exported scene: a `sweep` copied to another machine runs the script of its
/// own version, never one looked up through the folder it was built in.
const PEER_SCRIPT: &str = include_str!("../../../../scripts/peer_mitsuba.py");

fn peer_script(folder: &Path) -> Result<PathBuf> {
    let path = folder.join("peer_mitsuba.py");
    volphot::write_atomic(&path, PEER_SCRIPT.as_bytes())?;
    Ok(path)
}

/// A row from several seeds' images and CPU-seconds.
pub(super) fn row(
    renderer: &str,
    part: Part,
    setting: String,
    reference: &Reference,
    runs: &[(Vec<Vec3>, f64)],
) -> Row {
    let n = runs.len() as f64;
    let mse = runs
        .iter()
        .map(|(image, _)| mse_against_noisy_reference(image, &reference.image, &reference.variance))
        .sum::<f64>()
        / n;
    let cpu_s = runs.iter().map(|r| r.1).sum::<f64>() / n;
    let mean = runs.iter().map(|(image, _)| mean_of(image)).sum::<f64>() / n;
    Row {
        renderer: renderer.into(),
        part,
        setting,
        seeds: runs.len(),
        cpu_s,
        rmse: mse.max(0.0).sqrt(),
        efficiency: mse.max(0.0) * cpu_s,
        mean_ratio: mean / reference.mean(),
    }
}

fn mitsuba_rows(
    runs: &[MitsubaRun],
    part: Part,
    reference: &Reference,
    spps: &[u32],
) -> Result<Vec<Row>> {
    let mut rows = Vec::new();
    for &spp in spps {
        let images = runs
            .iter()
            .filter(|r| r.max_depth == part.max_depth() && r.spp == spp)
            .map(|r| (r.image.clone(), r.cpu_s))
            .collect::<Vec<_>>();
        let variant = runs.first().map_or("", |r| r.variant.as_str());
        rows.push(row(
            &format!("mitsuba {variant}"),
            part,
            format!("{spp} spp"),
            reference,
            &images,
        ));
    }
    Ok(rows)
}

/// CPU-seconds of `f`, all threads.
pub(super) fn cpu_timed<T>(f: impl FnOnce() -> Result<T>) -> Result<(T, f64)> {
    let start = process_cpu_seconds().context("CPU time is not available here")?;
    let value = f()?;
    Ok((value, process_cpu_seconds().unwrap_or(start) - start))
}

/// The path tracer's rows: the default tracker (`volphot path`) and today's before issue
/// #47 (`volphot path (delta)`), at each spp.
pub(super) fn path_rows(
    scene: &Scene,
    part: Part,
    reference: &Reference,
    spps: &[u32],
    seeds: u32,
) -> Result<Vec<Row>> {
    let mut rows = Vec::new();
    for (renderer, tracker) in [
        ("volphot path", Tracker::Weighted),
        ("volphot path (delta)", Tracker::Delta),
    ] {
        rows.extend(tracker_rows(
            renderer, scene, tracker, part, reference, spps, seeds,
        )?);
    }
    Ok(rows)
}

/// One tracker's rows on `scene`: every sample count, `seeds` seeds each.
fn tracker_rows(
    renderer: &str,
    scene: &Scene,
    tracker: Tracker,
    part: Part,
    reference: &Reference,
    spps: &[u32],
    seeds: u32,
) -> Result<Vec<Row>> {
    let mut rows = Vec::new();
    for &spp in spps {
        let runs = (0..seeds as u64)
            .map(|k| {
                let mut integrator = scene.integrator().clone();
                integrator.multiple = part == Part::All;
                integrator.seed = scene.integrator().seed.wrapping_add(1 + k);
                integrator.tracker = tracker;
                let s = scene.with_integrator(integrator)?;
                let (film, cpu) =
                    cpu_timed(|| Ok(volphot::render_reference(&s, spp, &Control::none())?.0))?;
                Ok((part_of(&film, part), cpu))
            })
            .collect::<Result<Vec<_>>>()?;
        rows.push(row(renderer, part, format!("{spp} spp"), reference, &runs));
    }
    Ok(rows)
}

/// Per part, each volphot path tracer's efficiency (its best RMSE²·CPU-s) over Mitsuba's
/// best: how many times less CPU it needs for the same error.
fn efficiency_vs_mitsuba(rows: &[Row]) -> Vec<Ratio> {
    let best = |part: Part, name: &dyn Fn(&str) -> bool| {
        rows.iter()
            .filter(|r| r.part == part && name(&r.renderer) && r.efficiency > 0.0)
            .map(|r| r.efficiency)
            .fold(f64::INFINITY, f64::min)
    };
    let mut ratios = Vec::new();
    for part in [Part::Single, Part::All] {
        let mitsuba = best(part, &|r| r.starts_with("mitsuba"));
        for renderer in [
            "volphot path",
            "volphot path (delta)",
            "volphot path (global majorant)",
        ] {
            let volphot = best(part, &|r| r == renderer);
            if mitsuba.is_finite() && volphot.is_finite() {
                ratios.push(Ratio {
                    part,
                    renderer: renderer.into(),
                    times_as_efficient: mitsuba / volphot,
                });
            }
        }
    }
    ratios
}

/// The photon-mapping integrator at the scene's settings and with 4× the photons.
fn photon_rows(scene: &Scene, part: Part, reference: &Reference, seeds: u32) -> Result<Vec<Row>> {
    let base = scene.integrator().volume_photons;
    let mut rows = Vec::new();
    for (setting, photons) in [
        ("scene's settings", base),
        ("4× photons", base.saturating_mul(4)),
    ] {
        let runs = (0..seeds as u64)
            .map(|k| {
                let seed = scene.integrator().seed.wrapping_add(1 + k);
                let s = photon_scene(scene, part, seed, |integrator| {
                    integrator.volume_photons = photons;
                })?;
                let (out, cpu) = cpu_timed(|| Ok(volphot::render(&s, &Control::none())?))?;
                Ok((part_of(&out.film, part), cpu))
            })
            .collect::<Result<Vec<_>>>()?;
        let setting = format!("{setting} ({photons} photons)");
        rows.push(row("volphot photon", part, setting, reference, &runs));
        if part == Part::Single {
            break; // single scattering does not use the photon map
        }
    }
    Ok(rows)
}

/// Mitsuba's mean at the most samples (over seeds) against the reference's.
fn agree(
    runs: &[MitsubaRun],
    part: Part,
    reference: &Reference,
    spps: &[u32],
) -> Result<Agreement> {
    let spp = *spps.iter().max().context("--peer-spp is empty")?;
    let images = runs
        .iter()
        .filter(|r| r.max_depth == part.max_depth() && r.spp == spp)
        .map(|r| r.image.clone())
        .collect::<Vec<Vec<Vec3>>>();
    if images.len() < 2 {
        bail!(
            "the agreement needs at least 2 Mitsuba seeds at {spp} spp, got {}",
            images.len()
        );
    }
    let means: Vec<f64> = images.iter().map(|i| mean_of(i)).collect();
    let n = means.len() as f64;
    let mean = means.iter().sum::<f64>() / n;
    let spread = (means.iter().map(|m| (m - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
    let mitsuba_standard_error_of_seed_means = spread / n.sqrt();
    // Per pixel: the variance over seeds of its value (channels averaged); the image
    // mean of the seeds' average has variance Σ var / (pixels² · seeds).
    let pixels = images[0].len();
    let summed_variance: f64 = (0..pixels)
        .map(|p| {
            let values: Vec<f64> = images.iter().map(|i| mean3(i[p])).collect();
            let m = values.iter().sum::<f64>() / n;
            values.iter().map(|v| (v - m).powi(2)).sum::<f64>() / (n - 1.0)
        })
        .sum();
    let mitsuba_standard_error = (summed_variance / n).sqrt() / pixels as f64;
    let volphot_standard_error = reference.standard_error();
    let combined = mitsuba_standard_error.hypot(volphot_standard_error);
    Ok(Agreement {
        part,
        mitsuba_mean: mean,
        mitsuba_standard_error,
        mitsuba_standard_error_of_seed_means,
        volphot_mean: reference.mean(),
        volphot_standard_error,
        z: (mean - reference.mean()) / combined.max(f64::MIN_POSITIVE),
    })
}

fn print_report(r: &PeerReport) {
    println!(
        "{} at {}×{}, Mitsuba {} ({}), reference: volphot path tracer at {} passes",
        r.scene,
        r.resolution[0],
        r.resolution[1],
        r.mitsuba_version,
        r.mitsuba_variant,
        r.reference_passes
    );
    for a in &r.agreement {
        println!(
            "agreement, {}: Mitsuba mean {:.6} ± {:.6}, volphot {:.6} ± {:.6}, z = {:+.2}",
            a.part.name(),
            a.mitsuba_mean,
            a.mitsuba_standard_error,
            a.volphot_mean,
            a.volphot_standard_error,
            a.z
        );
    }
    print_rows(&r.rows);
    for ratio in &r.efficiency_vs_mitsuba {
        println!(
            "{}, {}: {:.2}× Mitsuba's efficiency (best RMSE²·CPU-s of each)",
            ratio.part.name(),
            ratio.renderer,
            ratio.times_as_efficient
        );
    }
}

pub(super) fn print_rows(rows: &[Row]) {
    println!(
        "{:<22} {:<6} {:<34} {:>8} {:>10} {:>12} {:>8}",
        "renderer", "part", "setting", "CPU s", "RMSE", "RMSE²·CPU-s", "mean/ref"
    );
    for row in rows {
        println!(
            "{:<22} {:<6} {:<34} {:>8.2} {:>10.3e} {:>12.3e} {:>8.4}",
            row.renderer,
            row.part.name(),
            row.setting,
            row.cpu_s,
            row.rmse,
            row.efficiency,
            row.mean_ratio
        );
    }
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;

    /// A tiny scene that asks for the path tracer (`method = "reference"`, 4 spp).
    pub(in crate::bench) fn path_traced_scene() -> Scene {
        let src = volphot::test_util::SPOT_SPHERE
            .replace("resolution = [20, 20]", "resolution = [8, 8]")
            .replace(
                "reference_spp = 1024",
                "reference_spp = 4\nmethod = \"reference\"\nvolume_photons = 2000",
            );
        volphot::test_util::scene(&src)
    }

    pub(in crate::bench) fn image_of(row: &Row) -> (f64, f64) {
        (row.rmse, row.mean_ratio)
    }

    /// Every "volphot photon" row is a photon-mapping render whatever the scene's method:
    /// on a path-traced scene it differs from the path tracer's row at the scene's spp, and
    /// 4× photons differ from the scene's photons.
    #[test]
    fn photon_rows_map_photons_on_a_scene_that_asks_for_the_path_tracer() {
        let scene = path_traced_scene();
        let reference = reference(&scene, Part::All, 2).unwrap();
        let path = path_rows(&scene, Part::All, &reference, &[4], 1).unwrap();
        let photon = photon_rows(&scene, Part::All, &reference, 1).unwrap();
        assert_eq!(photon.len(), 2);
        for row in &photon {
            assert_ne!(image_of(row), image_of(&path[0]), "{}", row.setting);
        }
        assert_ne!(image_of(&photon[0]), image_of(&photon[1]), "4× photons");
    }
}
