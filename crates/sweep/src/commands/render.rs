//! `sweep render`: one scene to EXR + PNG + PFM + JSON.

use std::path::Path;
use std::process::ExitCode;

use anyhow::{Context, Result};
use volphot::{
    Layer, Method, RenderOutput, Scene, SceneParams, SearchPath, locate_error, write_png,
};

use crate::cli::{IntegratorChoice, RenderArgs};

/// Renders the scene and writes its files into the output folder.
pub(crate) fn run(args: &RenderArgs) -> Result<ExitCode> {
    crate::cli::check_output_folder("--output", &args.output)?;
    let stem = args
        .scene
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "render".into());
    if !args.force {
        check_replaces_only_renders(&args.output, &stem)?;
    }
    let params = scene_params(args)?;
    let output = render_scene(args, &params)?;
    if !output.film.is_finite() {
        return Err(crate::render::non_finite(&stem, &output.film, &params));
    }
    write_outputs(&args.output, &stem, &output, params.film.exposure)?;
    for warning in &output.record.warnings {
        eprintln!("warning: {stem}: {warning}");
    }
    let film = &output.film;
    let t = &output.record.timings;
    eprintln!(
        "{stem}: {}×{} in {:.2} s (photons {:.2} s, tree {:.2} s, render {:.2} s); mean radiance single {:.4}, multiple {:.4} → {}",
        film.width(),
        film.height(),
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

/// The files a render of a scene named `stem` writes, its sidecar first.
fn output_names(stem: &str) -> [String; 5] {
    [
        format!("{stem}.json"),
        format!("{stem}.exr"),
        format!("{stem}.pfm"),
        format!("{stem}.png"),
        format!("{stem}_single.png"),
    ]
}

/// Whether `file` is the JSON sidecar of a `sweep render` (a render record: the scene, the
/// timings, the threads), not a study's `plan.json` or `cells.json` or anything else.
fn is_render_sidecar(file: &Path) -> bool {
    let Ok(text) = volphot::read_text_capped(file, volphot::TEXT_INPUT_CAP, "render record") else {
        return false;
    };
    serde_json::from_str::<serde_json::Value>(&text).is_ok_and(|v| {
        v.as_object().is_some_and(|record| {
            ["scene", "timings", "threads", "version"]
                .iter()
                .all(|key| record.contains_key(*key))
        })
    })
}

/// Refuses, before any work, a render that would replace a file `sweep render` did not
/// make — a study's `plan.json` or `cells.json` when the scene is named `plan` or `cells`,
/// a picture of the user's — or write into a study's folder (it holds a `plan.json`). The
/// files of an earlier render of the same scene (its sidecar `STEM.json` a render record)
/// are replaced; `--force` replaces anything.
fn check_replaces_only_renders(folder: &Path, stem: &str) -> Result<()> {
    let names = output_names(stem);
    let plan = folder.join("plan.json");
    anyhow::ensure!(
        !plan.exists() || names.contains(&"plan.json".to_string()),
        "--output {}: holds a study of `sweep run` ({}); `sweep render` writes into a folder of its own: choose another --output, or pass --force to write into the study",
        folder.display(),
        plan.display()
    );
    let sidecar = folder.join(&names[0]);
    let ours = is_render_sidecar(&sidecar);
    let foreign: Vec<&String> = names
        .iter()
        .filter(|name| !ours && folder.join(name).symlink_metadata().is_ok())
        .collect();
    if let Some(first) = foreign.first() {
        anyhow::bail!(
            "--output {}: would replace {}, which no earlier `sweep render` of `{stem}` wrote ({}); choose another --output, or pass --force to replace {}",
            folder.display(),
            folder.join(first).display(),
            if sidecar.symlink_metadata().is_ok() {
                format!("{} is not a render record", names[0])
            } else {
                format!("no render record {} beside it", names[0])
            },
            if foreign.len() == 1 {
                "it".to_string()
            } else {
                format!("all {}", foreign.len())
            }
        );
    }
    Ok(())
}

/// The scene file's parameters with the command line's overrides applied.
fn scene_params(args: &RenderArgs) -> Result<SceneParams> {
    let (mut params, _) = crate::plan::load_scene(&args.scene)?;
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
    Ok(params)
}

/// Builds the scene (errors located in the scene file) and renders it on the asked
/// threads, with a progress bar over the image rows.
fn render_scene(args: &RenderArgs, params: &SceneParams) -> Result<RenderOutput> {
    let pool = super::thread_pool(args.threads)?;
    let base = args.scene.parent().unwrap_or(Path::new("."));
    pool.install(|| -> Result<_> {
        let scene = Scene::from_params(params, base, &SearchPath::from_env()).map_err(|e| {
            locate_error(
                e,
                &volphot::read_text_capped(&args.scene, volphot::TEXT_INPUT_CAP, "scene file")
                    .unwrap_or_default(),
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
    })
}

/// Writes `STEM.exr` (every layer), `STEM.pfm`, `STEM.png`, `STEM_single.png` and the
/// record `STEM.json` into `folder`.
fn write_outputs(folder: &Path, stem: &str, output: &RenderOutput, exposure: f32) -> Result<()> {
    std::fs::create_dir_all(folder).with_context(|| format!("creating {}", folder.display()))?;
    let film = &output.film;
    let (w, h) = (film.width(), film.height());
    film.write_exr(&folder.join(format!("{stem}.exr")))?;
    film.write_pfm(&folder.join(format!("{stem}.pfm")))?;
    write_png(
        &folder.join(format!("{stem}.png")),
        w,
        h,
        &film.total(),
        exposure,
    )?;
    write_png(
        &folder.join(format!("{stem}_single.png")),
        w,
        h,
        film.layer(Layer::Single),
        exposure,
    )?;
    let json = serde_json::to_string_pretty(&output.record)?;
    volphot::write_atomic(&folder.join(format!("{stem}.json")), json.as_bytes()).map_err(Into::into)
}
