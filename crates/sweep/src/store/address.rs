//! Content addresses: a cell is stored under the first 16 hex digits of the sha256 of the
//! program version, its effective scene parameters and the identity of its volume (sha256
//! of the file, or the phantom's parameters), so a rerun finds finished cells and a changed
//! input never reuses a stale one.

use std::path::Path;

use anyhow::{Context, Result};
use volphot::SceneParams;

use super::VERSION;

/// The identity of a cell's volume without loading it.
pub(crate) fn volume_identity(params: &SceneParams, base: &Path) -> Result<String> {
    let v = &params.volume;
    if let Some(d) = &v.dataset {
        let info = volphot::find_dataset(d)?;
        return Ok(info.sha256.to_string());
    }
    if let Some(p) = &v.phantom {
        return Ok(format!("phantom:{}:{}", p.name, p.describe()));
    }
    if let Some(f) = &v.file {
        let path = base.join(f);
        return volphot::sha256_cached(&path)
            .with_context(|| format!("hashing volume file {}", path.display()));
    }
    Ok(String::new())
}

/// The content address of a cell: version, effective parameters, volume (and transfer
/// function file) identity.
/// `base` resolves the scene's relative file paths.
pub(crate) fn cell_hash(params: &SceneParams, base: &Path) -> Result<String> {
    let mut text = format!("volphot-sweep {VERSION}\n");
    text += &serde_json::to_string(params)?;
    text += "\n";
    text += &volume_identity(params, base)?;
    if let Some(f) = &params.transfer.file {
        let path = base.join(f);
        text += "\n";
        text += &volphot::sha256_cached(&path).unwrap_or_else(|_| path.display().to_string());
    }
    Ok(volphot::sha256_bytes(text.as_bytes())[..16].to_string())
}

/// The content address of a reference: its scene (with the samples per pixel reset, so a
/// reference can be refined in place) and the identity of the volume it renders.
pub(crate) fn reference_hash(params: &SceneParams, volume_identity: &str) -> Result<String> {
    let mut p = params.clone();
    p.integrator.reference_spp = 1;
    let text = format!(
        "volphot-reference {VERSION}\n{}\n{volume_identity}",
        serde_json::to_string(&p)?,
    );
    Ok(volphot::sha256_bytes(text.as_bytes())[..16].to_string())
}
