//! `sweep import`: a thesis pbrt-v1 scene as a volphot scene file.

use std::path::Path;
use std::process::ExitCode;

use anyhow::{Result, bail};
use volphot::{import_pbrt, write_atomic};

use crate::cli::ImportArgs;

/// Reads the pbrt file, writes the TOML (atomically; nothing is written on an error) and
/// lists every unmapped line on stderr.
pub(crate) fn run(args: &ImportArgs) -> Result<ExitCode> {
    if args.output.exists() && !args.force {
        bail!(
            "{}: exists (pass --force to replace it)",
            args.output.display()
        );
    }
    let folder = match args.output.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    let import = import_pbrt(&args.scene, folder)?;
    std::fs::create_dir_all(folder)?;
    write_atomic(&args.output, import.to_toml().as_bytes())?;
    for note in &import.notes {
        eprintln!("note: {note}");
    }
    for line in &import.unmapped {
        eprintln!("not mapped: {line}");
    }
    println!(
        "wrote {} ({} light(s); {} statement(s) or parameter(s) not mapped)",
        args.output.display(),
        import.params.lights.len(),
        import.unmapped.len()
    );
    Ok(ExitCode::SUCCESS)
}
