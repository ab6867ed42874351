//! Helpers shared by the integration tests.
#![allow(dead_code)]

use std::path::{Path, PathBuf};

use volphot::SearchPath;
use volphot::{Scene, SceneParams};

/// Builds a scene from inline TOML (phantoms only, so no data files are needed).
pub fn scene(src: &str) -> Scene {
    let params = SceneParams::from_toml(src, Path::new("inline.toml")).expect("valid test scene");
    Scene::from_params(&params, Path::new("."), &SearchPath::new(vec![])).expect("scene builds")
}

/// The workspace root (two levels above this crate).
pub fn workspace_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// The dataset search path for tests: the standard one plus folders relative to the
/// workspace root, so `cargo test` finds `../shared/data` from any crate directory.
pub fn search_path() -> SearchPath {
    let root = workspace_root();
    SearchPath::from_env().with_extra([root.join("data"), root.join("../shared/data")])
}

/// Whether real-data tests must run: under CI they may not skip silently.
pub fn require_real_data() -> bool {
    std::env::var("CI")
        .map(|v| v == "true" || v == "1")
        .unwrap_or(false)
}

/// Relative root-mean-square difference of two images, normalised by the mean of `b`.
pub fn relative_rmse(a: &[glam::Vec3], b: &[glam::Vec3]) -> f64 {
    let n = a.len() as f64;
    let mse: f64 = a
        .iter()
        .zip(b)
        .map(|(x, y)| {
            let d = *x - *y;
            (d.x as f64).powi(2) + (d.y as f64).powi(2) + (d.z as f64).powi(2)
        })
        .sum::<f64>()
        / (3.0 * n);
    mse.sqrt() / volphot::mean_rgb(b)
}
