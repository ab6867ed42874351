//! `sweep datasets`: the registry and what the search path holds.

use std::process::ExitCode;

use anyhow::Result;
use volphot::{SearchPath, survey_datasets};

use crate::cli::DatasetsArgs;

/// Prints one line per registered dataset.
pub(crate) fn run(args: &DatasetsArgs) -> Result<ExitCode> {
    let search = SearchPath::from_env();
    println!(
        "search path: {}",
        search
            .folders()
            .iter()
            .map(|f| f.display().to_string())
            .collect::<Vec<_>>()
            .join(", ")
    );
    println!(
        "{:<9} {:<13} {:<6} {:<9} location",
        "name", "dims", "type", "sha256"
    );
    for status in survey_datasets(&search, args.verify) {
        let info = status.info;
        let dims = format!("{}x{}x{}", info.dims[0], info.dims[1], info.dims[2]);
        let check = match status.verified {
            Some(true) => "ok",
            Some(false) => "MISMATCH",
            None if status.path.is_some() => "unchecked",
            None => "-",
        };
        let location = status
            .path
            .as_ref()
            .map(|p| p.display().to_string())
            .unwrap_or_else(|| format!("missing ({})", info.file));
        println!(
            "{:<9} {:<13} {:<6} {:<9} {location}",
            info.name, dims, info.voxel, check
        );
        println!("          {}", info.note);
    }
    Ok(ExitCode::SUCCESS)
}
