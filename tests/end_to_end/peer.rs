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
    let wanted = std::env::var("VOLPHOT_PEER_TEST").is_ok_and(|v| v == "1");
    if !(volphot::test_util::required() || wanted) {
        volphot::test_util::skip(
            "mitsuba_and_volphot_agree_in_mean",
            "set CI=true or VOLPHOT_PEER_TEST=1 to install Mitsuba 3 into a virtual environment and compare",
        );
        return;
    }
    let tmp = tempfile::tempdir().unwrap();
    let json = tmp.path().join("peer.json");
    let out = run_ok(
        Command::new(workspace().join("scripts/peer-mitsuba.sh"))
            .arg(workspace().join("experiments/scenes/phantom-head.toml"))
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
