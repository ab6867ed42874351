//! Mitsuba 3 as an independent peer: a tiny exported scene rendered by Mitsuba's `volpath`
//! and by volphot's path tracer must agree in mean within 3 standard errors of their
//! combined noise, for single scattering and for all of it (`scripts/peer-mitsuba.sh`,
//! which installs Mitsuba from PyPI into its own virtual environment).
//!
//! Runs under `CI=true` (where it may not skip) or with `VOLPHOT_PEER_TEST=1`.

use std::process::Command;

use volphot_tests::{run_ok, sweep_bin, workspace};

#[test]
fn mitsuba_and_volphot_agree_in_mean() {
    if !peer_wanted("mitsuba_and_volphot_agree_in_mean") {
        return;
    }
    agree_on(&workspace().join("experiments/scenes/phantom-head.toml"));
}

/// The same under cinematic light (an area key light and a sky, exported as a `rectangle`
/// with an `area` emitter and an `envmap`) with a clip plane through the head (exported as
/// the clipped region's mesh holding the medium).
#[test]
fn mitsuba_and_volphot_agree_under_cinematic_light_with_a_clip_plane() {
    if !peer_wanted("mitsuba_and_volphot_agree_under_cinematic_light_with_a_clip_plane") {
        return;
    }
    let tmp = tempfile::tempdir().unwrap();
    let source =
        std::fs::read_to_string(workspace().join("experiments/scenes/phantom-head.toml")).unwrap();
    let lit = source.replace("[three_point]", "[three_point]\nstyle = \"cinematic\"");
    assert_ne!(lit, source, "the phantom head has a [three_point] table");
    let scene = tmp.path().join("phantom-head-cinematic-clip.toml");
    std::fs::write(
        &scene,
        format!("{lit}\n[clip]\nplane = {{ normal = [1, 0, 0], offset = 0.45 }}\n"),
    )
    .unwrap();
    agree_on(&scene);
}

fn peer_wanted(test: &str) -> bool {
    let wanted = std::env::var("VOLPHOT_PEER_TEST").is_ok_and(|v| v == "1");
    if !(volphot::test_util::required() || wanted) {
        volphot::test_util::skip(
            test,
            "set CI=true or VOLPHOT_PEER_TEST=1 to install Mitsuba 3 into a virtual environment and compare",
        );
        return false;
    }
    true
}

fn agree_on(scene: &std::path::Path) {
    let tmp = tempfile::tempdir().unwrap();
    let json = tmp.path().join("peer.json");
    let out = run_ok(
        Command::new(workspace().join("scripts/peer-mitsuba.sh"))
            .arg(scene)
            .args(["--resolution", "32x32", "--peer-spp", "64", "--seeds", "4"])
            .args(["--reference-passes", "1024", "--threads", "2", "--json"])
            .arg(&json)
            .env("VOLPHOT_SWEEP_BIN", sweep_bin()),
    );
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    let agreement = report["agreement"].as_array().unwrap();
    assert_eq!(agreement.len(), 2, "{stdout}");
    for a in agreement {
        let z = a["z"].as_f64().unwrap();
        assert!(z.abs() < 3.0, "Mitsuba and volphot disagree: {a}\n{stdout}");
        // The comparison has teeth: each side's noise is small against the mean.
        let mean = a["volphot_mean"].as_f64().unwrap();
        assert!(
            a["mitsuba_standard_error"].as_f64().unwrap() < 0.02 * mean,
            "{a}"
        );
    }
    let rows = report["rows"].as_array().unwrap();
    assert!(
        rows.iter()
            .any(|r| r["renderer"].as_str().unwrap().starts_with("mitsuba")),
        "{stdout}"
    );
}
