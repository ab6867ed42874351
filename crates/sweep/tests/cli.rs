//! The command line itself: help texts and argument errors.

use std::process::Command;

fn sweep() -> Command {
    Command::new(env!("CARGO_BIN_EXE_sweep"))
}

#[test]
fn every_verb_has_help_with_an_example() {
    for verb in [
        "datasets", "render", "plan", "run", "report", "status", "bench", "tune",
    ] {
        let out = sweep().args([verb, "--help"]).output().unwrap();
        assert!(out.status.success(), "{verb} --help");
        let text = String::from_utf8_lossy(&out.stdout);
        assert!(
            text.contains("Example"),
            "{verb} --help lacks an example:\n{text}"
        );
    }
}

#[test]
fn bad_arguments_are_clear_errors() {
    let out = sweep().args(["render", "missing.toml"]).output().unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("missing.toml"), "{err}");
    let out = sweep()
        .args(["render", "x.toml", "--resolution", "12xQ"])
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("WIDTHxHEIGHT"));
    // `sweep FILE.toml` is `sweep run FILE.toml`.
    let out = sweep().args(["nope.toml", "--quick"]).output().unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("nope.toml"));
}

#[test]
fn a_local_dry_run_is_refused_instead_of_rendering() {
    let tmp = tempfile::tempdir().unwrap();
    let experiment = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../experiments/quickstart.toml"
    );
    let out = sweep()
        .args(["run", experiment, "--dry-run", "--output"])
        .arg(tmp.path().join("out"))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && err.contains("sweep plan"), "{err}");
    assert!(
        !tmp.path().join("out/cells").exists(),
        "cells were rendered"
    );
}

#[test]
fn a_reference_pool_inside_the_output_folder_is_refused() {
    let tmp = tempfile::tempdir().unwrap();
    let experiment = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../experiments/quickstart.toml"
    );
    let out = tmp.path().join("out");
    let result = sweep()
        .args(["run", experiment, "--output"])
        .arg(&out)
        .arg("--reference-pool")
        .arg(out.join("references"))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&result.stderr);
    assert!(
        !result.status.success() && err.contains("inside the output folder"),
        "{err}"
    );
    assert!(!out.join("cells").exists(), "cells were rendered");
}

/// A scene file given where an experiment file belongs, or the other way round, is named
/// for what it is, with the verb that takes it.
#[test]
fn a_file_of_the_other_kind_is_named_with_the_verb_that_takes_it() {
    let root = concat!(env!("CARGO_MANIFEST_DIR"), "/../../experiments/");
    let experiment = format!("{root}quickstart.toml");
    let tune = format!("{root}tune_thesis.toml");
    let scene = format!("{root}scenes/phantom-engine.toml");
    let tmp = tempfile::tempdir().unwrap();
    let cases: [(Vec<&str>, &str, &[&str]); 8] = [
        (
            vec!["render", &experiment],
            "quickstart.toml",
            &["is an experiment file", "sweep run"],
        ),
        (
            vec!["render", &tune],
            "tune_thesis.toml",
            &["is an experiment file", "sweep tune"],
        ),
        (
            vec!["export", &experiment, "--format", "mitsuba"],
            "quickstart.toml",
            &["is an experiment file", "sweep run"],
        ),
        (
            vec!["bench", "--scene", &experiment],
            "quickstart.toml",
            &["is an experiment file", "sweep run"],
        ),
        (
            vec!["run", &scene],
            "phantom-engine.toml",
            &["is a scene file", "sweep render"],
        ),
        (
            vec![&scene],
            "phantom-engine.toml",
            &["is a scene file", "sweep render"],
        ),
        (
            vec!["plan", &scene],
            "phantom-engine.toml",
            &["is a scene file", "sweep render"],
        ),
        (
            vec!["tune", &scene],
            "phantom-engine.toml",
            &["is a scene file", "sweep render"],
        ),
    ];
    for (args, file, expected) in cases {
        let mut cmd = sweep();
        cmd.args(&args);
        if !matches!(args[0], "bench" | "plan") {
            cmd.arg("-o").arg(tmp.path().join("out"));
        }
        let out = cmd.output().unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{args:?} succeeded");
        assert!(err.contains(file), "{args:?}: `{err}` names no file");
        for what in expected {
            assert!(err.contains(what), "{args:?}: `{err}` lacks `{what}`");
        }
        assert!(!err.contains("unknown field"), "{args:?}: {err}");
    }
}

/// A tiny scene for `bench --reference`: the thesis's σ mapping on a phantom.
const BENCH_SCENE: &str = r#"
[volume]
phantom = { name = "sphere", resolution = [16, 16, 16], radius = 0.4 }
[sigma]
mapping = "thesis"
t = 10
[camera]
resolution = [16, 16]
[three_point]
"#;

#[test]
fn bench_reference_compares_the_trackers_against_a_pooled_reference() {
    let tmp = tempfile::tempdir().unwrap();
    let scene = tmp.path().join("s.toml");
    std::fs::write(&scene, BENCH_SCENE).unwrap();
    let (pool, json) = (tmp.path().join("pool"), tmp.path().join("b.json"));
    let bench = |reference_passes: &str| {
        let out = sweep()
            .args(["bench", "--reference", "--sigma-t", "10", "--passes", "4"])
            .args([
                "--seeds",
                "2",
                "--reference-passes",
                reference_passes,
                "--scene",
            ])
            .arg(&scene)
            .arg("--reference-pool")
            .arg(&pool)
            .arg("--json")
            .arg(&json)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr).into_owned();
        assert!(out.status.success(), "{err}");
        err
    };
    let first = bench("16");
    assert!(first.contains("0 → 16 passes"), "{first}");
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    for key in ["cpu", "os", "rustc", "commit"] {
        assert!(
            report["machine"][key]
                .as_str()
                .is_some_and(|s| !s.is_empty()),
            "machine.{key}: {report}"
        );
    }
    assert!(report["machine"]["cores"].as_u64().unwrap() >= 1);
    let case = &report["cases"][0];
    assert_eq!(case["sigma_t"], 10.0);
    assert_eq!(case["reference"]["passes"], 16);
    let trackers: Vec<&str> = (case["trackers"].as_array().unwrap().iter())
        .map(|t| t["tracker"].as_str().unwrap())
        .collect();
    assert_eq!(trackers, ["delta", "weighted"]);
    for t in case["trackers"].as_array().unwrap() {
        let targets: Vec<f64> = (t["cpu_to_rmse"].as_array().unwrap().iter())
            .map(|r| r[0].as_f64().unwrap())
            .collect();
        assert_eq!(targets, [0.02, 0.01]);
        assert_eq!(t["seeds"].as_array().unwrap().len(), 2);
    }
    // Found in the pool the second time; refined from there when more passes are asked.
    let again = bench("16");
    assert!(!again.contains("passes…"), "{again}");
    let refined = bench("24");
    assert!(refined.contains("16 → 24 passes"), "{refined}");
}

#[test]
fn bench_reference_needs_the_thesis_mapping() {
    let tmp = tempfile::tempdir().unwrap();
    let scene = tmp.path().join("s.toml");
    let explicit = BENCH_SCENE.replace(
        "mapping = \"thesis\"\nt = 10",
        "mapping = \"explicit\"\nsigma_a = [1, 1, 1]\nsigma_s = [4, 4, 4]",
    );
    std::fs::write(&scene, explicit).unwrap();
    let out = sweep()
        .args(["bench", "--reference", "--sigma-t", "6", "--scene"])
        .arg(&scene)
        .arg("--reference-pool")
        .arg(tmp.path().join("pool"))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(
        err.contains("s.toml") && err.contains("mapping = \"thesis\"") && err.contains("6"),
        "{err}"
    );
    // The tracker comparison's options need `--reference`.
    let out = sweep().args(["bench", "--sigma-t", "6"]).output().unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("--reference"));
}
