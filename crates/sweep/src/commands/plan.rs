//! `sweep plan`: the cells of an experiment and a rough cost estimate.

use std::process::ExitCode;

use anyhow::Result;
use volphot::{Method, SceneParams};

use crate::cli::PlanArgs;
use crate::plan::Experiment;

/// Rough wall-clock seconds for one cell on a 2-core machine.
///
/// Calibrated on the foot preset (σt(d_min) = 80, three spot lights, stepsize 0.0005):
/// about 100 µs per eye ray and light for single scattering and 160 µs per eye ray for
/// multiple scattering at nused = 150; both scale with the number of marching steps
/// (1/stepsize). Reference paths cost about 40 µs per sample. Real volumes and σ vary this
/// by a factor of a few: the estimate orders plans, it does not promise times.
pub(crate) fn estimate_seconds(p: &SceneParams) -> f64 {
    let [w, h] = p.camera.resolution;
    let pixels = w as f64 * h as f64;
    let i = &p.integrator;
    let steps = 0.0005 / i.stepsize as f64;
    let lights = (p.lights.len() + if p.three_point.is_some() { 3 } else { 0 }).max(1) as f64;
    match i.method {
        Method::Reference => pixels * i.reference_spp as f64 * 40e-6,
        Method::Photon => {
            let single = if i.single { 100e-6 * lights } else { 0.0 };
            let multiple = if i.multiple {
                160e-6 * (i.nused as f64 / 150.0).sqrt()
            } else {
                0.0
            };
            let cache = if i.shadow_cache > 0 || i.ms_cache > 0 {
                0.25
            } else {
                1.0
            };
            pixels * i.spp as f64 * steps * (single + multiple) * cache
                + i.volume_photons as f64 * 2e-6
        }
    }
}

/// Prints the plan.
pub(crate) fn run(args: &PlanArgs) -> Result<ExitCode> {
    let start = std::time::Instant::now();
    let exp = Experiment::load(&args.experiment)?;
    let quality = args.quality.quality();
    if exp.tune.is_some() {
        println!(
            "{}: has a [tune] section; these are the contexts every configuration is rendered on, and `sweep tune {} --dry-run` shows the search",
            exp.name,
            args.experiment.display()
        );
    }
    let size = exp.grid_size(quality)?;
    if size > exp.max_cells && !args.yes {
        println!(
            "{} ({:?} quality): {size} cells, more than max_cells = {}; not expanded (pass --yes to list them; `sweep run` will ask for --yes too)",
            exp.name, quality, exp.max_cells
        );
        return Ok(ExitCode::SUCCESS);
    }
    let (cells, hashes) = exp.plan_with_hashes(quality, true)?;
    let plan_seconds = start.elapsed().as_secs_f64();
    println!(
        "{} ({:?} quality): {} cells",
        exp.name,
        quality,
        cells.len()
    );
    println!("{:>5}  {:<16}  {:>9}  cell", "index", "hash", "est. [s]");
    let mut total = 0.0;
    let mut marches = std::collections::HashSet::new();
    for (c, hash) in cells.iter().zip(&hashes) {
        let est = estimate_seconds(&c.params);
        // Cells sharing a march cost roughly one march plus their gathers.
        marches.insert(if exp.share {
            volphot::march_key(&c.params)
        } else {
            hash.clone()
        });
        total += est;
        println!("{:>5}  {:<16}  {:>9.1}  {}", c.index, hash, est, c.label());
    }
    println!(
        "estimated {:.0} s of rendering if every cell were rendered alone (rough, 2 cores); the cells form {} march group(s) that share eye rays. Planned in {:.3} s.",
        total,
        marches.len(),
        plan_seconds
    );
    if cells.len() > exp.max_cells {
        println!(
            "note: {} cells exceed the experiment's max_cells = {}; `sweep run` will ask for --yes",
            cells.len(),
            exp.max_cells
        );
    }
    if args.slurm {
        let out = crate::plan::default_output(&exp, quality);
        let script = crate::backend::plan_submission(
            &exp,
            &cells,
            &out,
            &crate::backend::SlurmOptions::default(),
            quality,
            None,
        )?;
        println!("\n{}", script.describe());
    }
    Ok(ExitCode::SUCCESS)
}
