//! The reference a cell is measured against: the cell's physics with the reference's own
//! integrator settings, and its content address.

use anyhow::{Context, Result};
use volphot::{IntegratorParams, Method, SceneParams, validate_params};

use super::keys::{flatten_set, set_key};
use super::{CellSpec, ReferenceMethod, ReferenceSpec};
use crate::store::{inputs_identity, reference_hash};

/// The scene a reference renders: the cell's physics (volume, transfer function, σ,
/// camera, lights) with the reference's own integrator settings — none of the cell's — so
/// every cell with the same physics shares one reference. It renders every layer; a
/// comparison picks the layers the cell shows.
pub(crate) fn reference_params(params: &SceneParams, spec: &ReferenceSpec) -> Result<SceneParams> {
    let mut p = params.clone();
    let mut integrator = IntegratorParams {
        single: true,
        multiple: true,
        emission: true,
        // Independent noise: a seed no cell uses by default.
        seed: 0x005e_ed0f_5eed,
        ..Default::default()
    };
    match spec.method {
        ReferenceMethod::Path => {
            integrator.method = Method::Reference;
            integrator.reference_spp = spec.spp;
        }
        ReferenceMethod::Photon => {
            integrator.method = Method::Photon;
            if let Some(n) = spec.volume_photons {
                integrator.volume_photons = n;
            }
            if let Some(n) = spec.nused {
                integrator.nused = n;
            }
        }
    }
    p.integrator = integrator;
    let mut table = toml::Table::try_from(&p).context("serialising scene")?;
    let mut set = Vec::new();
    flatten_set(&spec.set, "", &mut set);
    for (k, v) in set {
        set_key(&mut table, &k, v).map_err(anyhow::Error::msg)?;
    }
    let text = toml::to_string(&table)?;
    let p: SceneParams =
        toml::from_str(&text).map_err(|e| anyhow::anyhow!("reference scene: {}", e.message()))?;
    validate_params(&p).map_err(|e| anyhow::anyhow!("reference scene: {e}"))?;
    Ok(p)
}

/// The content address of a cell's reference: physics + reference settings (not its spp,
/// so a reference can be refined in place).
pub(crate) fn reference_key(spec: &CellSpec, reference: &ReferenceSpec) -> Result<String> {
    let p = reference_params(&spec.params, reference)?;
    reference_hash(&p, &inputs_identity(&spec.params, &spec.base_dir)?)
}
