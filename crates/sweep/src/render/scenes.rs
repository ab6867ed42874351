//! Volumes and media loaded once per run and shared by every cell that uses them.

use std::collections::HashMap;
use std::path::Path;
use std::sync::{Arc, Mutex};

use anyhow::Result;
use volphot::{Medium, Scene, SceneParams, SearchPath, Volume, build_medium, load_volume};

/// The cached value under `key`, or `make`'s, stored for the next caller. The lock is not
/// held while `make` runs (loading a volume takes seconds); two cells racing for the same
/// key both build it and the second insert wins, which is harmless.
fn cached<T>(
    cache: &Mutex<HashMap<String, Arc<T>>>,
    key: &str,
    make: impl FnOnce() -> Result<T>,
) -> Result<Arc<T>> {
    if let Some(v) = cache.lock().unwrap_or_else(|e| e.into_inner()).get(key) {
        return Ok(Arc::clone(v));
    }
    let v = Arc::new(make()?);
    cache
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .insert(key.to_string(), Arc::clone(&v));
    Ok(v)
}

/// Loaded volumes and media, shared by every cell of a run.
#[derive(Default)]
pub(crate) struct Caches {
    volumes: Mutex<HashMap<String, Arc<Volume>>>,
    media: Mutex<HashMap<String, Arc<Medium>>>,
}

impl Caches {
    pub(crate) fn scene(
        &self,
        params: &SceneParams,
        base: &Path,
        search: &SearchPath,
    ) -> Result<Scene> {
        let volume_key = format!(
            "{}|{}",
            base.display(),
            serde_json::to_string(&params.volume)?
        );
        let volume = cached(&self.volumes, &volume_key, || {
            load_volume(&params.volume, base, search).map_err(Into::into)
        })?;
        // Everything `build_medium` reads besides the volume: a key that missed one (the
        // clip) would hand one cell another's medium.
        // A clip in the view's space moves with the camera.
        let view = if params.clip.space == volphot::ClipSpace::View {
            serde_json::to_string(&params.camera)?
        } else {
            String::new()
        };
        let medium_key = format!(
            "{volume_key}|{}|{}|{}|{}|{view}",
            serde_json::to_string(&params.transfer)?,
            serde_json::to_string(&params.sigma)?,
            serde_json::to_string(&params.phase)?,
            serde_json::to_string(&params.clip)?
        );
        let medium = cached(&self.media, &medium_key, || {
            build_medium(params, &volume, base).map_err(Into::into)
        })?;
        Ok(Scene::assemble(
            params,
            medium,
            volume.source().clone(),
            base,
        )?)
    }
}
