//! The thesis's qualitative claims that our own measurements support (see
//! `reports/REPRODUCTION.md`), checked on small, fast phantom grids through the real
//! `sweep` binary, so that a regression in the renderer or a metric shows up in CI.

use std::collections::HashMap;
use std::path::PathBuf;

use volphot_tests::{read_csv, run_ok, sweep, write_experiment};

/// Runs a small experiment on a phantom scene; returns rows keyed by column name.
fn run_grid(name: &str, scene: &str, set: &str, axes: &str) -> Vec<HashMap<String, String>> {
    let tmp = tempfile::tempdir().unwrap();
    let exp = write_experiment(
        tmp.path(),
        name,
        scene,
        &format!("[set]\n{set}\n[axes]\n{axes}"),
    );
    let out: PathBuf = tmp.path().join("out");
    run_ok(sweep().arg(&exp).arg("--output").arg(&out).arg("--quiet"));
    let (headers, rows) = read_csv(&out.join("cells.csv"));
    rows.into_iter()
        .map(|row| headers.iter().cloned().zip(row).collect())
        .collect()
}

fn value(rows: &[HashMap<String, String>], key: &str, value: &str, column: &str) -> f64 {
    let row = rows
        .iter()
        .find(|r| r[key] == value)
        .unwrap_or_else(|| panic!("no row with {key} = {value}"));
    row[column]
        .parse()
        .unwrap_or_else(|_| panic!("{column} = {}", row[column]))
}

const SMALL: &str = r#""volume.phantom.resolution" = [64, 64, 64]
"camera.resolution" = [96, 96]
"integrator.stepsize" = 0.002
"integrator.volume_photons" = 20000"#;

#[test]
fn c1_disco_balls_fade_as_nused_grows() {
    let rows = run_grid(
        "c1",
        "phantom-engine.toml",
        &format!("{SMALL}\n\"sigma.t\" = 80"),
        "\"integrator.nused\" = [25, 50, 150]",
    );
    let score: Vec<f64> = ["25", "50", "150"]
        .iter()
        .map(|n| value(&rows, "integrator.nused", n, "disco_energy [1]"))
        .collect();
    assert!(
        score[0] > score[1] && score[1] > score[2],
        "disco score should fall from nused 25 over 50 to 150: {score:?}"
    );
}

#[test]
fn c2_denser_media_shorten_the_photons_free_paths() {
    let rows = run_grid(
        "c2",
        "phantom-engine.toml",
        SMALL,
        "\"sigma.t\" = [6, 80, 290]",
    );
    let mfp: Vec<f64> = ["6", "80", "290"]
        .iter()
        .map(|t| value(&rows, "sigma.t", t, "empirical_mfp [% extent]"))
        .collect();
    assert!(
        mfp[0] > mfp[1] && mfp[1] > mfp[2],
        "empirical mean free path should fall with σt: {mfp:?}"
    );
    let nominal = value(&rows, "sigma.t", "80", "nominal_mfp [% extent]");
    assert!(
        (nominal - 1.25).abs() < 1e-6,
        "1/80 of the unit extent: {nominal}"
    );
}

#[test]
fn thesis_free_path_rule_moves_photons() {
    let rows = run_grid(
        "fp",
        "phantom-foot.toml",
        &format!("{SMALL}\n\"sigma.t\" = 80"),
        "\"integrator.free_path\" = [\"thesis\", \"delta\"]",
    );
    let thesis = value(
        &rows,
        "integrator.free_path",
        "thesis",
        "empirical_mfp [% extent]",
    );
    let delta = value(
        &rows,
        "integrator.free_path",
        "delta",
        "empirical_mfp [% extent]",
    );
    assert!(
        (thesis / delta - 1.0).abs() > 0.05,
        "thesis {thesis} vs delta {delta}"
    );
}

#[test]
fn c8_multiple_scattering_adds_light_and_lights_dark_regions() {
    let rows = run_grid(
        "c8",
        "phantom-engine.toml",
        &format!("{SMALL}\n\"sigma.t\" = 80"),
        "\"integrator.multiple\" = [true]",
    );
    let share = value(&rows, "integrator.multiple", "true", "ms_share [1]");
    let lit = value(&rows, "integrator.multiple", "true", "lit_by_multiple [1]");
    assert!(share > 0.1, "multiple-scattering share {share}");
    assert!(
        lit > 0.0,
        "pixels dark under direct light but lit with multiple scattering: {lit}"
    );
}

#[test]
fn c4_multiple_scattering_share_grows_with_albedo() {
    let rows = run_grid(
        "c4",
        "phantom-engine.toml",
        &format!("{SMALL}\n\"sigma.t\" = 80"),
        "\"sigma.albedo\" = [0.5, 0.8, 0.95]",
    );
    let share: Vec<f64> = ["0.5", "0.8", "0.95"]
        .iter()
        .map(|a| value(&rows, "sigma.albedo", a, "ms_share [1]"))
        .collect();
    assert!(share[0] < share[1] && share[1] < share[2], "{share:?}");
}
