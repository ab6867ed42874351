//! Fixtures shared by the test suites of every crate in the workspace (feature
//! `test-util`): small phantom scenes, the dataset search path as tests see it, how a
//! test that cannot run here says so, and an allocation probe for parser tests.

use std::io::Write as _;
use std::path::{Path, PathBuf};

use crate::{Scene, SceneParams, SearchPath};

/// A minimal scene: an 8³ sphere phantom lit by the three-point preset (every other key
/// at its default). Tests append tables or replace lines to vary it.
pub const SMALL_SCENE: &str =
    "[volume]\nphantom = { name = \"sphere\", resolution = [8, 8, 8] }\n[three_point]\n";

/// A small scattering scene: a sphere (σt = 3, albedo 0.8, mean free path 33 % of the box)
/// lit by one spot light.
pub const SPOT_SPHERE: &str = r#"
[volume]
phantom = { name = "sphere", resolution = [24, 24, 24], radius = 0.4 }
[sigma]
mapping = "thesis"
t = 3
albedo = 0.8
[camera]
eye = [0.5, -1.8, 0.5]
look_at = [0.5, 0.5, 0.5]
up = [0, 0, 1]
fov = 36
resolution = [20, 20]
[[lights]]
type = "spot"
position = [-0.8, -0.6, 1.6]
target = [0.5, 0.5, 0.5]
intensity = 10
cone_angle = 14
beam_width = 12
[integrator]
stepsize = 0.002
maxdist = 0.25
reference_spp = 1024
"#;

/// [`SPOT_SPHERE`] with σt = `sigma_t` in every channel and the single-scattering albedo
/// `albedo` per channel (the explicit mapping): a dense, coloured medium.
pub fn spot_sphere_with_albedo(sigma_t: f32, albedo: [f32; 3]) -> Scene {
    let thesis = "mapping = \"thesis\"\nt = 3\nalbedo = 0.8";
    assert!(
        SPOT_SPHERE.contains(thesis),
        "SPOT_SPHERE's [sigma] table changed"
    );
    let explicit = format!(
        "mapping = \"explicit\"\nsigma_a = {:?}\nsigma_s = {:?}",
        albedo.map(|a| sigma_t * (1.0 - a)),
        albedo.map(|a| sigma_t * a)
    );
    scene(&SPOT_SPHERE.replace(thesis, &explicit))
}

/// Builds a scene from inline TOML (phantoms only, so no data files are needed).
pub fn scene(src: &str) -> Scene {
    let params = SceneParams::from_toml(src, Path::new("inline.toml")).expect("valid test scene");
    Scene::from_params(&params, Path::new("."), &SearchPath::new(vec![])).expect("scene builds")
}

/// The workspace root.
pub fn workspace_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../..")
        .canonicalize()
        .unwrap_or_else(|_| Path::new(env!("CARGO_MANIFEST_DIR")).join("../.."))
}

/// The dataset search path for tests: the standard one plus folders relative to the
/// workspace root, so `cargo test` finds `../shared/data` from any crate directory.
pub fn search_path() -> SearchPath {
    let root = workspace_root();
    SearchPath::from_env().with_extra([root.join("data"), root.join("../shared/data")])
}

/// The folder that holds the real datasets, if any.
pub fn real_data_dir() -> Option<PathBuf> {
    search_path()
        .folders()
        .iter()
        .find(|d| d.join("engine_256x256x128_uint8.raw").is_file())
        .cloned()
}

/// Whether tests must run everything they can: under `CI=true` a missing dependency is a
/// failure, not a skip.
pub fn required() -> bool {
    std::env::var("CI")
        .map(|v| v == "true" || v == "1")
        .unwrap_or(false)
}

/// Reports that `test` cannot run here and why. Under `CI=true` it fails instead. The note
/// goes straight to the process's stderr (not the test harness's captured output), so a
/// skipped test never reads as a silent pass:
///
/// ```text
/// SKIPPED html_report_renders_in_chromium: no Chromium (install `chromium` or set $CHROMIUM)
/// ```
pub fn skip(test: &str, reason: &str) {
    assert!(!required(), "CI=true but {test} cannot run: {reason}");
    let mut err = std::io::stderr().lock();
    let _ = writeln!(err, "SKIPPED {test}: {reason}");
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
    mse.sqrt() / crate::mean_rgb(b)
}

pub mod alloc;
pub mod dicom;
pub mod nifti;
