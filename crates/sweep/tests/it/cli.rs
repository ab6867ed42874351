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

fn quickstart() -> String {
    concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../experiments/quickstart.toml"
    )
    .to_string()
}

/// stdout of a successful `sweep` call.
fn stdout_of(args: &[&str]) -> String {
    let out = sweep().args(args).output().unwrap();
    assert!(
        out.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// `sweep plan` leads with its summary (cells, groups, wall time at the given --jobs, the
/// output folder) and lists the cells only when asked to; the quality is named as
/// everywhere else (`default`, not `Default`).
#[test]
fn plan_prints_its_summary_first_and_the_cells_on_request() {
    let exp = quickstart();
    let text = stdout_of(&["plan", &exp, "--no-pilot"]);
    let lines: Vec<&str> = text.lines().collect();
    assert!(
        lines[0].contains("quickstart (`default` quality): 4 cells in 2 march group(s)")
            && lines[0].contains("out/quickstart"),
        "{text}"
    );
    assert!(!text.contains("Default quality"), "{text}");
    assert!(
        text.contains("estimated wall time") && text.contains("at --jobs 1"),
        "{text}"
    );
    assert!(
        !lines.iter().any(|l| l.trim_start().starts_with("index")),
        "cell rows without --list: {text}"
    );
    assert!(
        text.contains("--list"),
        "says how to list the cells: {text}"
    );
    let listed = stdout_of(&["plan", &exp, "--no-pilot", "--list", "--jobs", "3"]);
    let lines: Vec<&str> = listed.lines().collect();
    let summary = lines
        .iter()
        .position(|l| l.contains("estimated wall time") && l.contains("at --jobs 3"))
        .expect(&listed);
    let header = lines
        .iter()
        .position(|l| l.trim_start().starts_with("index"))
        .expect(&listed);
    assert!(summary < header, "summary before the rows: {listed}");
    assert_eq!(lines.len() - header - 1, 4, "one row per cell: {listed}");
    let quick = stdout_of(&["plan", &exp, "--no-pilot", "--quick"]);
    assert!(
        quick.contains("(`quick` quality)") && quick.contains("out/quickstart-quick"),
        "{quick}"
    );
}

/// The time `sweep plan` reports is the whole of it, pilot renders included, and says how
/// much of it the pilots took.
#[test]
fn plan_says_how_long_planning_took_with_its_pilots() {
    let tmp = tempfile::tempdir().unwrap();
    let scene = format!(
        "{}[camera]\nresolution = [24, 24]\n[integrator]\nvolume_photons = 500\nnused = 20\nstepsize = 0.02\n",
        volphot::test_util::SMALL_SCENE
    );
    std::fs::write(tmp.path().join("s.toml"), scene).unwrap();
    let exp = tmp.path().join("e.toml");
    std::fs::write(
        &exp,
        "name = \"tiny\"\nscene = \"s.toml\"\n[axes]\n\"integrator.nused\" = [10, 20]\n",
    )
    .unwrap();
    let text = stdout_of(&["plan", exp.to_str().unwrap()]);
    let line = text
        .lines()
        .find(|l| l.starts_with("planned in "))
        .unwrap_or_else(|| panic!("no `planned in` line: {text}"));
    let numbers: Vec<f64> = line
        .split(|c: char| !(c.is_ascii_digit() || c == '.'))
        .filter_map(|w| w.parse().ok())
        .collect();
    assert!(
        line.contains("of which") && line.contains("pilot render"),
        "{line}"
    );
    // Seconds in all, seconds of pilots, pilot renders (one march group of two cells).
    let (total, pilots, renders) = (numbers[0], numbers[1], numbers[2]);
    assert!(total >= pilots && renders == 1.0, "{line}");
}

/// The lines of `--help` that describe one option (its name line and the text under it).
fn option_block(help: &str, option: &str) -> String {
    let mut block = Vec::new();
    let mut inside = false;
    for line in help.lines() {
        let trimmed = line.trim_start();
        if trimmed.starts_with('-') {
            inside = trimmed.contains(option);
        }
        if inside {
            block.push(line);
        }
    }
    block.join("\n")
}

/// Help texts name the folders `--paper` and `--quick` write to, show comma-separated
/// defaults as they are typed, and state each default once; `sweep render`'s default
/// output folder is ignored by git.
#[test]
fn help_texts_say_where_output_goes_and_each_default_once() {
    let run = stdout_of(&["run", "--help"]);
    let output = option_block(&run, "--output");
    assert!(
        output.contains("<name>-paper") && output.contains("<name>-quick"),
        "{output}"
    );
    for verb in ["run", "tune"] {
        let help = stdout_of(&[verb, "--help"]);
        let jobs = option_block(&help, "--jobs");
        assert_eq!(
            jobs.to_lowercase().matches("default").count(),
            1,
            "{verb} --jobs: {jobs}"
        );
    }
    let bench = stdout_of(&["bench", "--help"]);
    let spp = option_block(&bench, "--peer-spp");
    assert!(spp.contains("[default: 4,16,64]"), "{spp}");
    let render = stdout_of(&["render", "--help"]);
    let out = option_block(&render, "--output");
    let default = out
        .split("[default: ")
        .nth(1)
        .and_then(|s| s.split(']').next())
        .expect(&out);
    let gitignore =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../../.gitignore")).unwrap();
    let folder = default.trim_end_matches('/');
    assert!(
        gitignore
            .lines()
            .any(|l| l == format!("/{folder}/") || l == format!("/{folder}")),
        "`sweep render`'s default output `{default}` is not in .gitignore"
    );
}

/// `sweep bench --runs N` renders each configuration N times: mean ± σ and min in the
/// table, every run's times in the JSON; one run by default.
#[test]
fn bench_repeats_each_configuration_and_keeps_every_run() {
    let tmp = tempfile::tempdir().unwrap();
    let json = tmp.path().join("bench.json");
    let common = [
        "bench",
        "--quick",
        "--resolution",
        "16x16",
        "--threads",
        "1",
        "--json",
        json.to_str().unwrap(),
    ];
    let mut args = common.to_vec();
    args.extend(["--only", "marched,exact", "--runs", "3"]);
    let text = stdout_of(&args);
    assert!(text.contains("mean ± σ") && text.contains("min"), "{text}");
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let measurements = report["measurements"].as_array().unwrap();
    assert_eq!(measurements.len(), 2);
    for m in measurements {
        let runs: Vec<f64> = m["runs"]
            .as_array()
            .unwrap()
            .iter()
            .map(|r| r["render_s"].as_f64().unwrap())
            .collect();
        assert_eq!(runs.len(), 3, "{m}");
        assert!(runs.iter().all(|t| *t > 0.0), "{runs:?}");
        let mean = runs.iter().sum::<f64>() / 3.0;
        let sd = (runs.iter().map(|t| (t - mean).powi(2)).sum::<f64>() / 2.0).sqrt();
        let min = runs.iter().cloned().fold(f64::INFINITY, f64::min);
        let close = |a: &serde_json::Value, b: f64| (a.as_f64().unwrap() - b).abs() < 1e-9;
        assert!(close(&m["render"]["mean"], mean), "{m}");
        assert!(close(&m["render"]["stddev"], sd), "{m}");
        assert!(close(&m["render"]["min"], min), "{m}");
        let row = text
            .lines()
            .find(|l| l.starts_with(m["configuration"].as_str().unwrap()))
            .unwrap();
        assert!(row.contains('±'), "{row}");
    }
    // Another set of configurations is another bench: it replaces the file only when told.
    let mut args = common.to_vec();
    args.extend(["--only", "marched", "--force"]);
    stdout_of(&args);
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let m = &report["measurements"][0];
    assert_eq!(m["runs"].as_array().unwrap().len(), 1, "{m}");
    assert!(m["render"]["stddev"].is_null(), "no σ of one run: {m}");
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

/// `sweep bench --reference --sigma-t 10 --seeds 2` on [`BENCH_SCENE`] (written to `dir`
/// once), with the pool and the JSON in `dir`, and `args` after.
fn bench_reference(dir: &std::path::Path, args: &[&str]) -> std::process::Output {
    let scene = dir.join("s.toml");
    if !scene.exists() {
        std::fs::write(&scene, BENCH_SCENE).unwrap();
    }
    sweep()
        .args(["bench", "--reference", "--sigma-t", "10", "--seeds", "2"])
        .args(args)
        .arg("--scene")
        .arg(&scene)
        .arg("--reference-pool")
        .arg(dir.join("pool"))
        .arg("--json")
        .arg(dir.join("b.json"))
        .output()
        .unwrap()
}

#[test]
fn bench_reference_compares_the_trackers_against_a_pooled_reference() {
    let tmp = tempfile::tempdir().unwrap();
    let json = tmp.path().join("b.json");
    let bench = |reference_passes: &str| {
        let out = bench_reference(
            tmp.path(),
            &["--passes", "4", "--reference-passes", reference_passes],
        );
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
            .map(|r| r["target"].as_f64().unwrap())
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
fn bench_reference_races_the_routes_beside_the_trackers() {
    let tmp = tempfile::tempdir().unwrap();
    let json = tmp.path().join("b.json");
    let out = bench_reference(
        tmp.path(),
        &["--routes", "--passes", "4", "--reference-passes", "16"],
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let routes = report["cases"][0]["routes"].as_array().unwrap();
    let names: Vec<&str> = routes
        .iter()
        .map(|r| r["route"].as_str().unwrap())
        .collect();
    assert_eq!(
        names,
        [
            "stratified eye samples",
            "visibility-weighted light choice",
            "both"
        ]
    );
    // A scene this small takes less CPU time than the clock resolves, so only the errors
    // (every seed rendered against the reference) and the ratio's presence are checked here.
    for r in routes {
        let seeds = r["seeds"].as_array().unwrap();
        assert_eq!(seeds.len(), 2, "{r}");
        for seed in seeds {
            let mse = seed["mse"].as_f64().unwrap();
            assert!(mse.is_finite() && mse > 0.0, "{r}");
        }
        // A ratio of two unresolved CPU times is 0/0, which JSON writes as null.
        let speedup = &r["speedup_over_weighted_at_001"];
        assert!(speedup.is_f64() || speedup.is_null(), "{r}");
        assert_eq!(r["tracker"], "weighted", "{r}");
    }
}

#[test]
fn bench_reference_counts_each_render_s_work_in_its_last_pass() {
    let tmp = tempfile::tempdir().unwrap();
    let json = tmp.path().join("b.json");
    let bench = |passes: &str| {
        bench_reference(
            tmp.path(),
            &["--counters", "--passes", passes, "--reference-passes", "16"],
        )
    };
    // The first pass and the counted one are timed apart: two passes leave none to time.
    let out = bench("2");
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("--counters") && err.contains("3"), "{err}");
    let out = bench("4");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        stdout.contains("null_collisions") && stdout.contains("counting's cost"),
        "{stdout}"
    );
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    for t in report["cases"][0]["trackers"].as_array().unwrap() {
        let rows = t["counters"]["means"].as_array().unwrap();
        let value = |name: &str| {
            let row = rows.iter().find(|r| r["counter"] == name).unwrap();
            row["per_pass"].as_f64().unwrap()
        };
        assert!(value("samples") > 0.0, "{t}");
        assert!(value("real_collisions") > 0.0, "{t}");
        assert!(value("shadow_rays") > 0.0, "{t}");
        assert!(value("bricks_stepped") >= value("empty_bricks"), "{t}");
        for seed in t["seeds"].as_array().unwrap() {
            assert!(
                seed["counted_pass"]["cpu_s"].as_f64().unwrap() >= 0.0,
                "{t}"
            );
            assert_eq!(seed["counted_pass"]["counts"].as_array().unwrap().len(), 11);
        }
    }
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
    // Without `--reference` one σt is set on the benchmarked scene, never several.
    let out = sweep()
        .args(["bench", "--quick", "--sigma-t", "6,80"])
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("--reference"));
}
