//! `sweep render`: one scene to EXR + PNG + PFM + JSON.

use std::path::Path;
use std::process::ExitCode;

use anyhow::{Context, Result};
use volphot::{Layer, Method, Scene, SearchPath, load_params, locate_error, write_png};

use crate::cli::{IntegratorChoice, RenderArgs};

/// Renders the scene and writes its files into the output folder.
pub(crate) fn run(args: &RenderArgs) -> Result<ExitCode> {
    let (mut params, _) = load_params(&args.scene)?;
    if let Some(seed) = args.seed {
        params.integrator.seed = seed;
    }
    if let Some(method) = args.integrator {
        params.integrator.method = match method {
            IntegratorChoice::Photon => Method::Photon,
            IntegratorChoice::Reference => Method::Reference,
        };
    }
    if let Some(spp) = args.spp {
        match params.integrator.method {
            Method::Photon => params.integrator.spp = spp,
            Method::Reference => params.integrator.reference_spp = spp,
        }
    }
    if let Some(resolution) = args.resolution {
        params.camera.resolution = resolution;
    }
    let pool = super::thread_pool(args.threads)?;
    let base = args.scene.parent().unwrap_or(Path::new("."));
    let output = pool.install(|| -> Result<_> {
        let scene = Scene::from_params(&params, base, &SearchPath::from_env()).map_err(|e| {
            locate_error(
                e,
                &std::fs::read_to_string(&args.scene).unwrap_or_default(),
                &args.scene,
            )
        })?;
        let multi = crate::progress::multi(args.quiet);
        let bar = crate::progress::bar(
            &multi,
            volphot::progress_rows(scene.integrator(), scene.camera().height()),
            "render",
            "rows",
        );
        let progress = |rows| bar.set_position(rows);
        let out = volphot::render(&scene, &volphot::Control::new(&progress))?;
        bar.finish_and_clear();
        Ok(out)
    })?;
    anyhow::ensure!(output.film.is_finite(), "render produced non-finite values");
    let stem = args
        .scene
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "render".into());
    std::fs::create_dir_all(&args.output)
        .with_context(|| format!("creating {}", args.output.display()))?;
    let film = &output.film;
    let (w, h) = (film.width(), film.height());
    let exposure = params.film.exposure;
    film.write_exr(&args.output.join(format!("{stem}.exr")))?;
    film.write_pfm(&args.output.join(format!("{stem}.pfm")))?;
    write_png(
        &args.output.join(format!("{stem}.png")),
        w,
        h,
        &film.total(),
        exposure,
    )?;
    write_png(
        &args.output.join(format!("{stem}_single.png")),
        w,
        h,
        film.layer(Layer::Single),
        exposure,
    )?;
    let json = serde_json::to_string_pretty(&output.record)?;
    volphot::write_atomic(&args.output.join(format!("{stem}.json")), json.as_bytes())?;
    let t = &output.record.timings;
    eprintln!(
        "{stem}: {w}×{h} in {:.2} s (photons {:.2} s, tree {:.2} s, render {:.2} s); mean radiance single {:.4}, multiple {:.4} → {}",
        t.total,
        t.photon_tracing,
        t.tree_build,
        t.render,
        film.mean(Layer::Single),
        film.mean(Layer::Multiple),
        args.output.display()
    );
    Ok(ExitCode::SUCCESS)
}
