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
