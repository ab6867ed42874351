//! `sweep export`: a scene for another renderer.

use std::path::Path;
use std::process::ExitCode;

use anyhow::Result;
use volphot::{Scene, SearchPath, export_mitsuba, locate_error};

use crate::cli::{ExportArgs, ExportFormat};

/// Loads the scene (validated as for a render) and writes it in the chosen format.
pub(crate) fn run(args: &ExportArgs) -> Result<ExitCode> {
    let (mut params, _) = crate::plan::load_scene(&args.scene)?;
    if let Some(resolution) = args.resolution {
        params.camera.resolution = resolution;
    }
    let base = args.scene.parent().unwrap_or(Path::new("."));
    let scene = Scene::from_params(&params, base, &SearchPath::from_env()).map_err(|e| {
        locate_error(
            e,
            &volphot::read_text_capped(&args.scene, volphot::TEXT_INPUT_CAP, "scene file")
                .unwrap_or_default(),
            &args.scene,
        )
    })?;
    let name = args
        .scene
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "scene".into());
    match args.format {
        ExportFormat::Mitsuba => {
            let files = export_mitsuba(&scene, &args.output, &name)?;
            println!(
                "wrote {} and {} (render with Mitsuba 3: max_depth=2 for single scattering, -1 for all)",
                files.scene.display(),
                files.grid.display()
            );
        }
    }
    Ok(ExitCode::SUCCESS)
}
