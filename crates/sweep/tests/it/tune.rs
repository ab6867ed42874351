//! `sweep tune` end to end on a tiny phantom: it finds the optimum of a space the test
//! sweeps exhaustively with a fraction of the renders, proposes the same configurations
//! for the same seed, renders nothing on a rerun, and rejects bad `[tune]` sections with
//! errors that name the key.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use volphot_tests::{read_csv, run_ok, sweep, workspace, write_experiment};

/// The exhaustively swept key and its values.
const NUSED: std::ops::RangeInclusive<i64> = 2..=201;
/// Target resolution of the search test.
const SIDE: u32 = 32;

/// An experiment on the engine phantom at `side`² with the given extra tables.
fn experiment(dir: &Path, name: &str, side: u32, tables: &str) -> PathBuf {
    let tables = format!(
        r#"max_cells = 1000
[set]
"volume.phantom.resolution" = [24, 24, 24]
"camera.resolution" = [{side}, {side}]
"integrator.volume_photons" = 20000
"integrator.maxdist" = 0.5
"integrator.stepsize" = 0.004
"sigma.t" = 60
[reference]
spp = 256
{tables}"#
    );
    write_experiment(dir, name, "phantom-engine.toml", &tables)
}

fn tune_tables(seed: u64, renders: usize, side: u32, space: &str) -> String {
    let min = side / 2;
    format!(
        r#"
[tune]
seed = {seed}
objective = "rmse"
budget = {{ renders = {renders} }}
[tune.fidelity]
resolution = [{side}, {side}]
min_resolution = [{min}, {min}]
min_photon_fraction = 0.5
levels = 2
eta = 3
[tune.space]
{space}
"#
    )
}

fn col(header: &[String], name: &str) -> usize {
    header
        .iter()
        .position(|h| h == name || h.starts_with(&format!("{name} [")))
        .unwrap_or_else(|| panic!("no column {name} in {header:?}"))
}

fn finished_cells(out: &Path) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(out.join("cells"))
        .map(|d| {
            d.flatten()
                .map(|e| e.path().join("cell.json"))
                .filter(|p| p.is_file())
                .collect()
        })
        .unwrap_or_default();
    v.sort();
    v
}

#[test]
fn tune_finds_the_exhaustive_optimum_within_0_1_percent_with_a_fifth_of_the_renders() {
    let tmp = tempfile::tempdir().unwrap();
    // The exhaustive sweep: every nused at the target resolution, full photons.
    let values: Vec<String> = NUSED.map(|n| n.to_string()).collect();
    let grid = experiment(
        tmp.path(),
        "grid",
        SIDE,
        &format!("[axes]\n\"integrator.nused\" = [{}]\n", values.join(", ")),
    );
    let grid_out = tmp.path().join("grid");
    run_ok(
        sweep()
            .args(["run", "--quiet", "--threads", "2", "--no-report"])
            .arg(&grid)
            .arg("-o")
            .arg(&grid_out),
    );
    run_ok(sweep().arg("report").arg(&grid_out));
    let (h, rows) = read_csv(&grid_out.join("cells.csv"));
    let (nused, rmse) = (col(&h, "integrator.nused"), col(&h, "rmse"));
    let exhaustive: Vec<(i64, f64)> = rows
        .iter()
        .map(|r| (r[nused].parse().unwrap(), r[rmse].parse().unwrap()))
        .collect();
    assert_eq!(exhaustive.len(), values.len());
    let (best_n, best) = exhaustive
        .iter()
        .copied()
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .unwrap();
    let worst = exhaustive.iter().map(|e| e.1).fold(0.0, f64::max);
    // The landscape is not flat, so finding its optimum means something.
    assert!(
        worst > 1.5 * best,
        "rmse {best} (nused {best_n}) to {worst}"
    );

    // The tune: at most 20 % of the exhaustive renders, low levels included.
    let budget = values.len() / 5;
    let space = format!(
        "\"integrator.nused\" = {{ int = [{}, {}], scale = \"log\" }}",
        NUSED.start(),
        NUSED.end()
    );
    let tune = experiment(
        tmp.path(),
        "tune",
        SIDE,
        &tune_tables(3, budget, SIDE, &space),
    );
    let out = tmp.path().join("tune");
    run_ok(
        sweep()
            .args(["tune", "--quiet", "--threads", "2"])
            .arg(&tune)
            .arg("-o")
            .arg(&out),
    );
    let renders = finished_cells(&out).len();
    assert!(renders <= budget, "{renders} renders > {budget}");
    let (h, rows) = read_csv(&out.join("tune/pareto.csv"));
    let (key, error) = (col(&h, "integrator.nused"), col(&h, "error"));
    let (found_n, found): (i64, f64) = rows
        .iter()
        .map(|r| (r[key].parse().unwrap(), r[error].parse::<f64>().unwrap()))
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .expect("a Pareto front");
    // Same cell, same error: the tune's evaluation is the grid's cell.
    let grid_error = exhaustive.iter().find(|e| e.0 == found_n).unwrap().1;
    assert!(
        (found - grid_error).abs() <= 1e-5 * grid_error,
        "{found} vs grid {grid_error}"
    );
    // Stated tolerance: within 0.1 % of the exhaustive optimum's RMSE. The landscape is
    // flat near its optimum, so 0.1 % is a small share of the settings (checked), and the
    // test prints how often a uniform random search with as many full-resolution renders
    // would land there.
    let close = exhaustive.iter().filter(|e| e.1 <= 1.001 * best).count();
    assert!(
        close * 10 <= exhaustive.len(),
        "{close} settings within 0.1 %: too easy"
    );
    assert!(
        found <= 1.001 * best,
        "tune found nused {found_n} with rmse {found}, the optimum is nused {best_n} with {best} ({renders} renders of {budget})"
    );
    let (h, rows) = read_csv(&out.join("tune/observations.csv"));
    let (level, cells) = (col(&h, "level"), col(&h, "cells"));
    let full: std::collections::BTreeSet<&str> = rows
        .iter()
        .filter(|r| r[level] == "1")
        .map(|r| r[cells].as_str())
        .collect();
    let n = exhaustive.len();
    let miss: f64 = (0..full.len())
        .map(|i| (n - close - i) as f64 / (n - i) as f64)
        .product();
    eprintln!(
        "tune: nused {found_n} rmse {found:.6} with {renders} renders ({} at full resolution; budget {budget}); exhaustive: nused {best_n} rmse {best:.6} with {n} renders; {close} settings within 0.1 %, which uniform random search with {} full renders hits with probability {:.2}",
        full.len(),
        full.len(),
        1.0 - miss
    );
    // Outputs: best scene file, sensitivity, the report links the tune report.
    let best_scene = std::fs::read_to_string(out.join("tune/best.toml")).unwrap();
    assert!(
        best_scene.contains(&format!("nused = {found_n}")),
        "{best_scene}"
    );
    // Ready to use: it renders as it is.
    run_ok(
        sweep()
            .args(["render", "--quiet", "--threads", "2"])
            .arg(out.join("tune/best.toml"))
            .arg("-o")
            .arg(tmp.path().join("best")),
    );
    assert!(
        std::fs::read_to_string(out.join("report.md"))
            .unwrap()
            .contains("tune/report.md")
    );
    assert!(out.join("tune/pareto.svg").is_file() && out.join("tune/pareto.png").is_file());
    let (h, rows) = read_csv(&out.join("tune/sensitivity.csv"));
    assert_eq!(rows[0][col(&h, "parameter")], "integrator.nused");
}

/// A 2-D space on a cheap scene: same seed, same proposals and ids; another seed, others.
#[test]
fn same_seed_same_proposals_and_a_rerun_renders_nothing() {
    let tmp = tempfile::tempdir().unwrap();
    let space = "\"integrator.nused\" = { int = [2, 60], scale = \"log\" }\n\"integrator.maxdist\" = { range = [0.05, 0.5] }";
    let mut runs = Vec::new();
    for (name, seed) in [("a", 5), ("b", 5), ("c", 6)] {
        let tables = tune_tables(seed, 14, 12, space);
        let exp = experiment(tmp.path(), "seeded", 12, &tables);
        let out = tmp.path().join(name);
        run_ok(
            sweep()
                .args(["tune", "--quiet", "--threads", "2", "--no-report"])
                .arg(&exp)
                .arg("-o")
                .arg(&out),
        );
        runs.push(out);
    }
    let proposals = |out: &Path| {
        let (h, rows) = read_csv(&out.join("tune/observations.csv"));
        let keep: Vec<usize> = [
            "id",
            "level",
            "integrator.nused",
            "integrator.maxdist",
            "error",
        ]
        .iter()
        .map(|k| col(&h, k))
        .collect();
        rows.iter()
            .map(|r| keep.iter().map(|&i| r[i].clone()).collect::<Vec<_>>())
            .collect::<Vec<_>>()
    };
    let (a, b, c) = (
        proposals(&runs[0]),
        proposals(&runs[1]),
        proposals(&runs[2]),
    );
    assert!(a.len() >= 6, "{a:?}");
    assert_eq!(a, b, "same seed");
    assert_ne!(a, c, "another seed");

    // Resume: the same command again renders nothing and decides the same.
    let first = finished_cells(&runs[0]);
    let mtimes: Vec<_> = first
        .iter()
        .map(|p| std::fs::metadata(p).unwrap().modified().unwrap())
        .collect();
    let exp = tmp.path().join("seeded.toml");
    std::fs::write(
        &exp,
        std::fs::read_to_string(&exp)
            .unwrap()
            .replace("seed = 6", "seed = 5"),
    )
    .unwrap();
    run_ok(
        sweep()
            .args(["tune", "--quiet", "--no-report"])
            .arg(&exp)
            .arg("-o")
            .arg(&runs[0]),
    );
    assert_eq!(finished_cells(&runs[0]), first);
    let again: Vec<_> = first
        .iter()
        .map(|p| std::fs::metadata(p).unwrap().modified().unwrap())
        .collect();
    assert_eq!(mtimes, again, "no cell was rendered again");
    assert_eq!(proposals(&runs[0]), a);
    let report = std::fs::read_to_string(runs[0].join("tune/report.md")).unwrap();
    assert!(report.contains("(0 rendered by the last run"), "{report}");

    // What a Slurm array task of the tune runs: cells of plan.json, rebuilt from the
    // experiment; a removed cell comes back.
    let lost = first[2].parent().unwrap().to_path_buf();
    std::fs::remove_dir_all(&lost).unwrap();
    let plan: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(runs[0].join("plan.json")).unwrap()).unwrap();
    let hash = lost.file_name().unwrap().to_string_lossy().into_owned();
    let index = plan["cells"]
        .as_array()
        .unwrap()
        .iter()
        .find(|c| c["hash"] == hash.as_str())
        .map(|c| c["index"].to_string())
        .unwrap();
    run_ok(
        sweep()
            .args(["tune", "--quiet", "--no-report", "--cells", &index])
            .arg(&exp)
            .arg("-o")
            .arg(&runs[0]),
    );
    assert_eq!(
        finished_cells(&runs[0]),
        first,
        "cell {index} ({hash}) rendered again"
    );
}

#[test]
fn bad_tune_sections_are_located_errors() {
    let tmp = tempfile::tempdir().unwrap();
    let good_space = "\"integrator.nused\" = { int = [2, 60] }";
    let cases: Vec<(String, &str)> = vec![
        (
            tune_tables(1, 10, SIDE, good_space).replace("\"rmse\"", "\"psnr\""),
            "unknown metric `psnr`",
        ),
        (
            tune_tables(1, 10, SIDE, good_space)
                .replace("{ renders = 10 }", "{ renders = 10, seconds = 5 }"),
            "exactly one of `renders`",
        ),
        (
            tune_tables(1, 10, SIDE, "\"integrator.nused\" = { int = [60, 2] }"),
            "int [60, 2]: expected lo < hi",
        ),
        (
            tune_tables(
                1,
                10,
                SIDE,
                "\"integrator.maxdist\" = { range = [0, 0.5], scale = \"log\" }",
            ),
            "lo > 0",
        ),
        (
            tune_tables(1, 10, SIDE, "\"integrator.nused\" = { choices = [5] }"),
            "at least two values",
        ),
        (
            tune_tables(1, 10, SIDE, "\"integrator.nused\" = { between = [1, 2] }"),
            "integrator.nused",
        ),
        (
            tune_tables(
                1,
                10,
                SIDE,
                "\"camera.resolution\" = { choices = [[8, 8], [16, 16]] }",
            ),
            "cannot be searched",
        ),
        (
            tune_tables(1, 10, SIDE, good_space).replace("levels = 2", "levels = 9"),
            "levels in 1..=6",
        ),
        (
            tune_tables(1, 10, SIDE, good_space)
                .replace("min_resolution = [16, 16]", "min_resolution = [48, 48]"),
            "min_resolution",
        ),
        (
            tune_tables(1, 10, SIDE, "\"integrator.nsued\" = { int = [2, 60] }"),
            "nsued",
        ),
        (
            tune_tables(1, 10, SIDE, "\"../integrator/nused\" = { int = [2, 60] }"),
            "`../integrator/nused` is not a scene key",
        ),
        (
            tune_tables(1, 10, SIDE, "\"integrator.nused\" = { int = [0, 60] }"),
            "nused",
        ),
        (
            tune_tables(1, 1, SIDE, good_space),
            "budget allows no bracket",
        ),
    ];
    for (i, (tables, expected)) in cases.iter().enumerate() {
        let exp = experiment(tmp.path(), &format!("bad{i}"), SIDE, tables);
        let out = sweep()
            .args(["tune", "--dry-run"])
            .arg(&exp)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "case {i} passed:\n{tables}");
        assert!(
            err.contains(expected),
            "case {i}: `{err}` lacks `{expected}`"
        );
        assert!(
            err.contains(&format!("bad{i}.toml")),
            "case {i}: `{err}` names no file"
        );
    }
    // Without a reference there is nothing to measure against; a photon-mapping reference
    // has no variance for `rmse_corrected` to remove.
    let with_reference = |name: &str, objective: &str, reference: &str| {
        let tables = tune_tables(1, 10, SIDE, good_space).replace("\"rmse\"", objective);
        let exp = experiment(tmp.path(), name, SIDE, &tables);
        let text = std::fs::read_to_string(&exp)
            .unwrap()
            .replace("[reference]\nspp = 256\n", reference);
        std::fs::write(&exp, text).unwrap();
        let out = sweep()
            .args(["tune", "--dry-run"])
            .arg(&exp)
            .output()
            .unwrap();
        (exp, String::from_utf8_lossy(&out.stderr).into_owned())
    };
    let (exp, err) = with_reference("noref", "\"rmse\"", "");
    assert!(err.contains("needs a [reference]"), "{err}");
    let photon = "[reference]\nmethod = \"photon\"\n";
    let (_, err) = with_reference("photonref", "\"rmse_corrected\"", photon);
    assert!(
        err.contains("rmse_corrected") && err.contains("photonref.toml"),
        "{err}"
    );
    // `sweep run` refuses a tune experiment; `sweep tune` a grid.
    let out = sweep().args(["run"]).arg(&exp).output().unwrap();
    assert!(!out.status.success());
}

#[test]
fn the_thesis_study_plans() {
    let file = workspace().join("experiments/tune_thesis.toml");
    let tmp = tempfile::tempdir().unwrap();
    let out = run_ok(
        sweep()
            .args(["tune", "--dry-run"])
            .arg(&file)
            .arg("-o")
            .arg(tmp.path()),
    );
    let text = String::from_utf8_lossy(&out.stdout);
    for expected in [
        "7 key(s) on 2 context(s)",
        "level 2: 512×512",
        "bracket s=2: 9 × level 0",
        "constraint: at most 60 s",
    ] {
        assert!(text.contains(expected), "`{expected}` not in:\n{text}");
    }
    assert!(
        std::fs::read_dir(tmp.path()).unwrap().next().is_none(),
        "a dry run writes nothing"
    );
}

/// The longest any `sweep` of these tests may take before it counts as a hang.
const HANG: std::time::Duration = std::time::Duration::from_secs(30);

/// Runs `cmd` to its end, its output in files under `dir`; a run past [`HANG`] is killed
/// and fails the test.
fn run_bounded(cmd: &mut Command, dir: &Path, name: &str) -> Output {
    let (stdout, stderr) = (
        dir.join(format!("{name}.out")),
        dir.join(format!("{name}.err")),
    );
    let mut child = cmd
        .stdout(std::fs::File::create(&stdout).unwrap())
        .stderr(std::fs::File::create(&stderr).unwrap())
        .spawn()
        .expect("sweep starts");
    let start = std::time::Instant::now();
    let status = loop {
        if let Some(status) = child.try_wait().unwrap() {
            break status;
        }
        if start.elapsed() > HANG {
            let _ = child.kill();
            let _ = child.wait();
            panic!("{cmd:?} gave no answer within {HANG:?} (a hang)");
        }
        std::thread::sleep(std::time::Duration::from_millis(20));
    };
    Output {
        status,
        stdout: std::fs::read(stdout).unwrap(),
        stderr: std::fs::read(stderr).unwrap(),
    }
}

/// A dry run answers promptly whatever the budget: one no search could spend is refused
/// with the key, the value and the range, and the largest accepted one is planned.
#[test]
fn a_dry_run_answers_promptly_for_any_render_budget() {
    let tmp = tempfile::tempdir().unwrap();
    let space = "\"integrator.nused\" = { int = [2, 60] }";
    let huge = experiment(
        tmp.path(),
        "huge",
        12,
        &tune_tables(1, 1_000_000_000_000_000_000, 12, space),
    );
    let out = run_bounded(
        sweep().args(["tune", "--dry-run"]).arg(&huge),
        tmp.path(),
        "huge",
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{err}");
    for expected in [
        "huge.toml:",
        "`budget`",
        "renders = 1000000000000000000",
        "1..=1000000",
    ] {
        assert!(err.contains(expected), "`{expected}` not in: {err}");
    }
    let largest = experiment(
        tmp.path(),
        "largest",
        12,
        &tune_tables(1, 1_000_000, 12, space),
    );
    let out = run_bounded(
        sweep()
            .args(["tune", "--dry-run"])
            .arg(&largest)
            .arg("-o")
            .arg(tmp.path().join("largest")),
        tmp.path(),
        "largest",
    );
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    // Two levels, η = 3: brackets of 3 + 1 and of 2 renders, so 6 per iteration, and the
    // search stops after 10 000 iterations whatever the budget.
    assert!(
        text.contains("budget 1000000 renders: 20000 bracket(s), at most 60000 renders"),
        "{text}"
    );
}

/// Two searches on one folder would render each other's cells and count a cell the other
/// is rendering as failed: the second is refused at once, naming the folder and the first.
#[test]
fn a_second_tune_on_a_folder_being_tuned_is_refused() {
    let tmp = tempfile::tempdir().unwrap();
    let space = "\"integrator.nused\" = { int = [2, 60], scale = \"log\" }\n\"integrator.maxdist\" = { range = [0.05, 0.5] }";
    let exp = experiment(tmp.path(), "twice", 16, &tune_tables(5, 30, 16, space));
    let out = tmp.path().join("out");
    let args = |c: &mut Command| {
        c.args(["tune", "--quiet", "--threads", "1", "--no-report"])
            .arg(&exp)
            .arg("-o")
            .arg(&out);
    };
    let mut first_cmd = sweep();
    args(&mut first_cmd);
    let mut first = first_cmd
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    // Once a cell is finished the first search is under way.
    let start = std::time::Instant::now();
    while finished_cells(&out).is_empty() {
        assert!(
            first.try_wait().unwrap().is_none(),
            "the first tune ended before finishing a cell"
        );
        if start.elapsed() > 4 * HANG {
            let _ = first.kill();
            panic!("the first tune finished no cell within {:?}", 4 * HANG);
        }
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    let mut second_cmd = sweep();
    args(&mut second_cmd);
    let second = run_bounded(&mut second_cmd, tmp.path(), "second");
    let first_running = first.try_wait().unwrap().is_none();
    let first_status = first.wait().unwrap();
    assert!(
        first_running,
        "the first tune ended before the second was refused; raise its budget"
    );
    assert!(first_status.success(), "the first tune failed");
    let err = String::from_utf8_lossy(&second.stderr);
    assert!(!second.status.success(), "the second tune ran: {err}");
    for expected in [
        out.display().to_string(),
        "sweep tune".into(),
        format!("process {}", first.id()),
    ] {
        assert!(err.contains(&expected), "`{expected}` not in: {err}");
    }
    // The first search saw every cell it rendered finished.
    let (h, rows) = read_csv(&out.join("tune/observations.csv"));
    let error = col(&h, "error");
    assert!(
        rows.iter()
            .all(|r| r[error].parse::<f64>().unwrap().is_finite()),
        "{rows:?}"
    );
}
