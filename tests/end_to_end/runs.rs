//! End-to-end: the real `sweep` binary on small real grids.

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use volphot_tests::{
    copy_tracked, data_dir, read_csv, run_ok, skip, sweep, workspace, write_experiment,
};

/// A small phantom experiment: `nused` × σt(d_min) on the engine phantom.
fn phantom_experiment(dir: &Path, resolution: u32, extra_axis: &str) -> PathBuf {
    write_experiment(
        dir,
        "e2e",
        "phantom-engine.toml",
        &format!(
            r#"
[set]
"volume.phantom.resolution" = [32, 32, 32]
"camera.resolution" = [{resolution}, {resolution}]
"integrator.volume_photons" = 4000
"integrator.stepsize" = 0.004
[axes]
"sigma.t" = [20, 60]
"integrator.nused" = [20, 80]
{extra_axis}
[reference]
spp = 8
[[compare]]
kind = "layers"
[[compare]]
kind = "reference"
"#
        ),
    )
}

fn column<'a>(headers: &[String], rows: &'a [Vec<String>], name: &str) -> Vec<&'a str> {
    let i = headers
        .iter()
        .position(|h| h == name)
        .unwrap_or_else(|| panic!("no column {name} in {headers:?}"));
    rows.iter().map(|r| r[i].as_str()).collect()
}

fn finished_cells(out: &Path) -> usize {
    std::fs::read_dir(out.join("cells"))
        .map(|d| {
            d.flatten()
                .filter(|e| e.path().join("cell.json").is_file())
                .count()
        })
        .unwrap_or(0)
}

#[test]
fn phantom_grid_runs_reports_and_resumes() {
    let tmp = tempfile::tempdir().unwrap();
    let exp = phantom_experiment(tmp.path(), 40, "");
    let out = tmp.path().join("out");
    let first = run_ok(sweep().arg("run").arg(&exp).arg("--output").arg(&out));
    let stderr = String::from_utf8_lossy(&first.stderr);
    assert!(stderr.contains("4 rendered by 2 march(es)"), "{stderr}");

    // CSV: stable columns with units, one finished row per cell, plausible values.
    let (headers, rows) = read_csv(&out.join("cells.csv"));
    assert_eq!(
        &headers[..5],
        ["cell", "hash", "status", "sigma.t", "integrator.nused"]
    );
    for h in [
        "time_render [s]",
        "nominal_mfp [% extent]",
        "empirical_mfp [% extent]",
        "rmse [W/(m2 sr)]",
        "flip [1]",
        "ssim [1]",
        "disco_energy [1]",
        "volume_sha256",
        "ms_share [1]",
    ] {
        assert!(headers.iter().any(|x| x == h), "missing column {h}");
    }
    assert_eq!(rows.len(), 4);
    assert!(
        column(&headers, &rows, "status")
            .iter()
            .all(|s| *s == "done")
    );
    // σt(d_min) = 20 in a unit box: mean free path 1/20 = 5 % of the extent.
    let mfp: Vec<f64> = column(&headers, &rows, "nominal_mfp [% extent]")
        .iter()
        .map(|v| v.parse().unwrap())
        .collect();
    let t: Vec<f64> = column(&headers, &rows, "sigma.t")
        .iter()
        .map(|v| v.parse().unwrap())
        .collect();
    for (m, t) in mfp.iter().zip(&t) {
        assert!((m - 100.0 / t).abs() < 1e-3, "{m} vs 100/{t}");
    }
    for name in [
        "mean_multiple [W/(m2 sr)]",
        "rmse [W/(m2 sr)]",
        "flip [1]",
        "empirical_mfp [% extent]",
    ] {
        for v in column(&headers, &rows, name) {
            let v: f64 = v.parse().unwrap_or_else(|_| panic!("{name} = `{v}`"));
            assert!(v.is_finite() && v > 0.0, "{name} = {v}");
        }
    }
    assert!(
        column(&headers, &rows, "volume")
            .iter()
            .all(|v| v.starts_with("phantom engine"))
    );

    // Every promised file exists and decodes.
    for f in [
        "report.md",
        "report.html",
        "cells.json",
        "plan.json",
        "experiment.toml",
    ] {
        assert!(out.join(f).is_file(), "{f}");
    }
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    assert!(
        html.contains("data:image/png;base64,"),
        "self-contained report"
    );
    for hash in column(&headers, &rows, "hash") {
        let dir = out.join("cells").join(hash);
        let film = volphot::Film::read_exr(&dir.join("film.exr")).unwrap();
        assert_eq!((film.width(), film.height()), (40, 40));
        for png in ["total.png", "single.png", "multiple.png"] {
            let img = image::open(dir.join(png)).unwrap();
            assert_eq!(img.width(), 40);
        }
        assert!(dir.join("cell.json").is_file());
    }
    let mut pngs = 0;
    for entry in walk(&out.join("figures")) {
        if entry.extension().is_some_and(|e| e == "png") {
            image::open(&entry).unwrap_or_else(|e| panic!("{}: {e}", entry.display()));
            pngs += 1;
        }
        if entry.extension().is_some_and(|e| e == "svg") {
            assert!(std::fs::read_to_string(&entry).unwrap().contains("<svg"));
        }
    }
    assert!(
        pngs >= 6,
        "contact sheets, plots and difference images: {pngs}"
    );
    let references: Vec<PathBuf> = walk(&out.join("references"))
        .into_iter()
        .filter(|p| p.ends_with("reference.exr"))
        .collect();
    assert_eq!(
        references.len(),
        2,
        "one reference per σt (shared by the nused cells)"
    );

    // Rerunning renders nothing.
    let second = run_ok(sweep().arg(&exp).arg("--output").arg(&out));
    let stderr = String::from_utf8_lossy(&second.stderr);
    assert!(stderr.contains("4 already done, 0 rendered"), "{stderr}");

    // `sweep report` regenerates from disk alone, and recomputes image statistics that an
    // older version wrote (here: a record stripped back to the pre-versioning form).
    let records: Vec<PathBuf> = walk(&out.join("cells"))
        .into_iter()
        .filter(|p| p.ends_with("cell.json"))
        .collect();
    let mut record: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&records[0]).unwrap()).unwrap();
    let fresh = record["image"].clone();
    for key in ["version", "luma_single", "luma_total"] {
        record["image"].as_object_mut().unwrap().remove(key);
    }
    record["image"]["gradient_total"] = serde_json::json!(0.0);
    std::fs::write(&records[0], serde_json::to_string(&record).unwrap()).unwrap();
    std::fs::remove_file(out.join("report.md")).unwrap();
    // Difference images of addresses the plan no longer has (a cell whose address moved)
    // are removed by the next report; the current cells' are kept.
    let figures = out.join("figures");
    std::fs::create_dir_all(figures.join("compare7")).unwrap();
    let orphans = [
        figures.join("diff").join("0123456789abcdef_amplified.png"),
        figures.join("diff").join("0123456789abcdef_compare.png"),
        figures
            .join("compare7")
            .join("0123456789abcdef_vs_fedcba9876543210.png"),
    ];
    for orphan in &orphans {
        std::fs::copy(records[0].with_file_name("total.png"), orphan).unwrap();
    }
    run_ok(sweep().arg("report").arg(&out));
    assert!(out.join("report.md").is_file());
    assert!(
        orphans.iter().all(|o| !o.exists()),
        "orphaned figures removed"
    );
    assert!(
        !figures.join("compare7").exists(),
        "empty comparison folder removed"
    );
    for hash in column(&headers, &rows, "hash") {
        for kind in ["compare", "amplified", "signed"] {
            let kept = figures.join("diff").join(format!("{hash}_{kind}.png"));
            assert!(kept.is_file(), "{}", kept.display());
        }
    }
    let refreshed: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&records[0]).unwrap()).unwrap();
    assert_eq!(refreshed["image"], fresh);
}

fn walk(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    if let Ok(entries) = std::fs::read_dir(dir) {
        for e in entries.flatten() {
            let p = e.path();
            if p.is_dir() {
                out.extend(walk(&p));
            } else {
                out.push(p);
            }
        }
    }
    out
}

#[test]
fn killed_run_resumes_with_nothing_lost() {
    let tmp = tempfile::tempdir().unwrap();
    // Eight cells in four marches; big enough that the run takes several seconds.
    let exp = phantom_experiment(tmp.path(), 96, "\"integrator.spp\" = [1, 2]");
    let out = tmp.path().join("out");
    let mut child = sweep()
        .arg(&exp)
        .arg("--output")
        .arg(&out)
        .arg("--quiet")
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let start = Instant::now();
    while finished_cells(&out) == 0 && start.elapsed() < Duration::from_secs(120) {
        std::thread::sleep(Duration::from_millis(20));
    }
    child.kill().unwrap();
    child.wait().unwrap();
    let before = finished_cells(&out);
    assert!((1..8).contains(&before), "killed after {before} of 8 cells");
    // No half-written cell folders: every cell folder has its record.
    for e in std::fs::read_dir(out.join("cells")).unwrap().flatten() {
        let name = e.file_name().to_string_lossy().into_owned();
        if e.path().is_dir() && !name.starts_with('.') {
            assert!(
                e.path().join("cell.json").is_file(),
                "half-written cell {name}"
            );
        }
    }
    let resumed = run_ok(sweep().arg(&exp).arg("--output").arg(&out));
    let stderr = String::from_utf8_lossy(&resumed.stderr);
    assert!(
        stderr.contains(&format!("{before} already done, {} rendered", 8 - before)),
        "{stderr}"
    );
    assert_eq!(finished_cells(&out), 8);
    let leftovers: Vec<String> = std::fs::read_dir(out.join("cells"))
        .unwrap()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.contains(".tmp-"))
        .collect();
    assert!(
        leftovers.is_empty(),
        "stale temporary folders: {leftovers:?}"
    );
}

#[test]
fn a_second_run_on_the_same_folder_is_refused() {
    let tmp = tempfile::tempdir().unwrap();
    let exp = phantom_experiment(tmp.path(), 16, "");
    let out = tmp.path().join("out");
    std::fs::create_dir_all(&out).unwrap();
    let lock = std::fs::File::create(out.join(".lock")).unwrap();
    lock.lock().unwrap();
    let o = sweep()
        .arg(&exp)
        .arg("--output")
        .arg(&out)
        .output()
        .unwrap();
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("being written by another sweep run"));
}

#[test]
fn experiment_errors_name_file_line_and_key() {
    let tmp = tempfile::tempdir().unwrap();
    let exp = tmp.path().join("bad.toml");
    let scene = workspace().join("experiments/scenes/phantom-engine.toml");
    std::fs::write(
        &exp,
        format!(
            "scene = \"{}\"\n[axes]\n\"integrator.nused\" = [50, -3]\n",
            scene.display()
        ),
    )
    .unwrap();
    let o = sweep().arg("plan").arg(&exp).output().unwrap();
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("bad.toml:3:1") && err.contains("integrator.nused"),
        "{err}"
    );
}

#[test]
fn render_writes_layers_png_pfm_and_sidecar() {
    let tmp = tempfile::tempdir().unwrap();
    let scene = workspace().join("experiments/scenes/phantom-head.toml");
    run_ok(
        sweep()
            .args(["render"])
            .arg(&scene)
            .arg("-o")
            .arg(tmp.path())
            .args([
                "--resolution",
                "32x24",
                "--threads",
                "1",
                "--seed",
                "5",
                "-q",
            ]),
    );
    let film = volphot::Film::read_exr(&tmp.path().join("phantom-head.exr")).unwrap();
    assert_eq!((film.width(), film.height()), (32, 24));
    assert!(film.mean(volphot::Layer::Multiple) > 0.0);
    image::open(tmp.path().join("phantom-head.png")).unwrap();
    assert!(tmp.path().join("phantom-head.pfm").is_file());
    let json: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(tmp.path().join("phantom-head.json")).unwrap(),
    )
    .unwrap();
    assert_eq!(json["volume"]["kind"], "phantom");
    assert_eq!(json["scene"]["integrator"]["seed"], 5);
    assert_eq!(json["threads"], 1);
    assert!(json["timings"]["render"].as_f64().unwrap() > 0.0);
    assert!(json["photons"]["stored"].as_u64().unwrap() > 0);
    assert!(json["sigma"]["mean_free_path_percent"].as_f64().unwrap() > 0.0);
}

/// A cache is an approximation: a cell rendered with one records the error the cache was
/// measured to have, and the report lists it; cells without a cache record none. Thinning
/// (on by default) is measured in every cell, and the report gives its largest error.
/// A tiny engine phantom scene: σt(d_min) `t`, `photons` traced, `nused` per estimate.
fn tiny_scene(dir: &Path, name: &str, t: f64, photons: u32, nused: u32) -> PathBuf {
    let path = dir.join(format!("{name}.toml"));
    let text = format!(
        r#"[volume]
phantom = {{ name = "engine", resolution = [16, 16, 16] }}
[sigma]
mapping = "thesis"
t = {t}
albedo = 0.8
[camera]
eye = [2.0, -1.4, 1.6]
look_at = [0.5, 0.5, 0.5]
up = [0, 0, 1]
fov = 30
resolution = [16, 16]
[three_point]
key_intensity = 40
[integrator]
volume_photons = {photons}
nused = {nused}
stepsize = 0.01
"#
    );
    std::fs::write(&path, text).unwrap();
    path
}

/// `sweep render` of `scene`: its stderr and its sidecar's `warnings` (as text).
fn render_warnings(scene: &Path, out: &Path) -> (String, Vec<String>) {
    let o = run_ok(
        sweep()
            .arg("render")
            .arg(scene)
            .arg("-o")
            .arg(out)
            .arg("-q"),
    );
    let stem = scene.file_stem().unwrap().to_string_lossy().into_owned();
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join(format!("{stem}.json"))).unwrap())
            .unwrap();
    let warnings = json["warnings"]
        .as_array()
        .map(|w| w.iter().map(|v| v.as_str().unwrap().to_string()).collect())
        .unwrap_or_default();
    (String::from_utf8_lossy(&o.stderr).into_owned(), warnings)
}

/// A render outside what its own settings can resolve says so on stderr and in its record:
/// fewer stored photons than 10 × nused (each estimate then gathers a large part of the
/// map), or a nominal mean free path longer than the volume (nearly transparent). A render
/// within them says nothing.
#[test]
fn renders_outside_what_their_settings_resolve_warn() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    let few = tiny_scene(dir, "few", 80.0, 300, 300);
    let (err, warnings) = render_warnings(&few, &dir.join("few"));
    assert!(
        err.contains("warning") && err.contains("nused 300") && err.contains("photons"),
        "{err}"
    );
    assert!(
        warnings.len() == 1 && warnings[0].contains("nused 300"),
        "{warnings:?}"
    );
    let thin = tiny_scene(dir, "thin", 0.2, 20000, 20);
    let (err, warnings) = render_warnings(&thin, &dir.join("thin"));
    assert!(
        err.contains("warning") && err.contains("mean free path") && err.contains("500"),
        "{err}"
    );
    assert!(
        warnings.iter().any(|w| w.contains("mean free path")),
        "{warnings:?}"
    );
    let fine = tiny_scene(dir, "fine", 80.0, 20000, 20);
    let (err, warnings) = render_warnings(&fine, &dir.join("fine"));
    assert!(!err.contains("warning"), "{err}");
    assert!(warnings.is_empty(), "{warnings:?}");
    // A cell of a run records its warnings and prints them.
    let (out, err) = run_few_photons(dir, "[10, 300]");
    assert!(
        err.contains("warning: cell 1") && err.contains("nused 300") && !err.contains("cell 0"),
        "{err}"
    );
    for (i, (warned, record)) in recorded_warnings(&out).iter().enumerate() {
        assert_eq!(*warned, i == 1, "cell {i}: {record}");
    }
}

/// A run of `few.toml` (written by [`tiny_scene`] in `dir`) over `integrator.nused` =
/// `nused`: its output folder and stderr.
fn run_few_photons(dir: &Path, nused: &str) -> (PathBuf, String) {
    let exp = dir.join("e.toml");
    std::fs::write(
        &exp,
        format!(
            "name = \"warned\"\nscene = \"few.toml\"\n[axes]\n\"integrator.nused\" = {nused}\n"
        ),
    )
    .unwrap();
    let out = dir.join("out");
    let o = run_ok(sweep().arg(&exp).arg("--output").arg(&out).arg("--quiet"));
    (out, String::from_utf8_lossy(&o.stderr).into_owned())
}

/// Per cell of the run in `out`, in plan order: whether its record keeps a warning, and the
/// record.
fn recorded_warnings(out: &Path) -> Vec<(bool, serde_json::Value)> {
    let cells: Vec<serde_json::Value> =
        serde_json::from_str(&std::fs::read_to_string(out.join("cells.json")).unwrap()).unwrap();
    cells
        .iter()
        .map(|cell| {
            let hash = cell["hash"].as_str().unwrap();
            let record: serde_json::Value = serde_json::from_str(
                &std::fs::read_to_string(out.join("cells").join(hash).join("cell.json")).unwrap(),
            )
            .unwrap();
            let warned = record["warnings"].as_array().is_some_and(|w| !w.is_empty());
            (warned, record)
        })
        .collect()
}

#[test]
fn a_run_prints_each_kind_of_warning_in_full_a_few_times_and_names_the_other_cells_once() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    tiny_scene(dir, "few", 80.0, 300, 300);
    let (out, err) = run_few_photons(dir, "[10, 300, 310, 320, 330, 340, 350]");
    // Six cells store too few photons (cell 0, nused 10, does not): three in full, then one
    // line naming the other three.
    let full: Vec<&str> = err
        .lines()
        .filter(|l| l.starts_with("warning: cell "))
        .collect();
    assert_eq!(full.len(), 3, "{err}");
    assert!(
        full.iter().all(|l| l.contains("photons stored for nused")),
        "{err}"
    );
    let rest: Vec<&str> = err
        .lines()
        .filter(|l| {
            l.starts_with(
                "warning: 3 more cell(s) with fewer than 10 × nused photons stored: cells ",
            )
        })
        .collect();
    assert_eq!(rest.len(), 1, "{err}");
    let named: Vec<usize> = rest[0]
        .split("cells ")
        .nth(1)
        .and_then(|t| t.split(' ').next())
        .unwrap()
        .split(',')
        .flat_map(|part| match part.split_once('-') {
            Some((a, b)) => (a.parse().unwrap()..=b.parse().unwrap()).collect::<Vec<usize>>(),
            None => vec![part.parse().unwrap()],
        })
        .collect();
    let printed: Vec<usize> = full
        .iter()
        .map(|l| {
            l["warning: cell ".len()..]
                .split(' ')
                .next()
                .unwrap()
                .parse()
                .unwrap()
        })
        .collect();
    let mut all: Vec<usize> = named.iter().chain(&printed).copied().collect();
    all.sort_unstable();
    assert_eq!(all, vec![1, 2, 3, 4, 5, 6], "{err}");
    // Every warned cell keeps its warning in its record, printed or not.
    for (i, (warned, record)) in recorded_warnings(&out).iter().enumerate() {
        assert_eq!(*warned, i != 0, "cell {i}: {record}");
    }
}

#[test]
fn cached_cells_record_and_report_their_measured_error() {
    let tmp = tempfile::tempdir().unwrap();
    let exp = write_experiment(
        tmp.path(),
        "caches",
        "phantom-engine.toml",
        r#"
[set]
"volume.phantom.resolution" = [32, 32, 32]
"camera.resolution" = [32, 32]
"integrator.volume_photons" = 3000
"integrator.stepsize" = 0.004
[axes]
"integrator.shadow_cache" = [0, 16]
"integrator.ms_cache" = [0, 16]
"#,
    );
    let out = tmp.path().join("out");
    run_ok(sweep().arg("run").arg(&exp).arg("--output").arg(&out));
    let mut with_error = 0;
    for entry in std::fs::read_dir(out.join("cells")).unwrap().flatten() {
        let Ok(text) = std::fs::read_to_string(entry.path().join("cell.json")) else {
            continue;
        };
        let record: serde_json::Value = serde_json::from_str(&text).unwrap();
        let integrator = &record["scene"]["integrator"];
        let shadow = integrator["shadow_cache"].as_u64().unwrap() > 0;
        let ms = integrator["ms_cache"].as_u64().unwrap() > 0;
        let error = &record["cache_error"];
        assert_eq!(integrator["thin_below"], 0.5, "the default thins");
        let thinning = &error["thinning"];
        assert_eq!(thinning["pixels"], 32 * 32, "{error}");
        for layer in ["single", "multiple"] {
            let p99 = thinning[layer]["p99"].as_f64().unwrap();
            assert!(p99 >= 0.0 && p99 <= thinning[layer]["max"].as_f64().unwrap());
            // Without caches both layers are interpolated behind the front.
            assert!(shadow || ms || p99 > 0.0, "{layer}: {error}");
        }
        if shadow || ms {
            with_error += 1;
            assert!(error["probes"].as_u64().unwrap() > 100, "{error}");
            assert_eq!(error["shadow"].is_null(), !shadow, "{error}");
            assert_eq!(error["multiple"].is_null(), !ms, "{error}");
            for part in ["shadow", "multiple"] {
                if let Some(p99) = error[part]["p99"].as_f64() {
                    // A 16-node lattice on a 32³ engine is coarse: the error is real.
                    assert!(p99 > 0.0 && p99 <= error[part]["max"].as_f64().unwrap());
                }
            }
        }
    }
    assert_eq!(with_error, 3);
    let report = std::fs::read_to_string(out.join("report.md")).unwrap();
    assert!(report.contains("## Caches"), "{report}");
    let (caches, thinning) = report
        .split_once("## Thinning")
        .expect("a thinning section");
    assert_eq!(caches.matches("| shadow_cache = 16").count(), 2, "{report}");
    assert!(thinning.contains("| multiple | 4 |"), "{report}");
    assert!(
        report.contains("4 of 4 finished cell(s) thinned"),
        "{report}"
    );
    let csv = std::fs::read_to_string(out.join("cells.csv")).unwrap();
    assert!(csv.contains("thinning_p99_multiple [1]"), "{csv}");
}

#[test]
fn the_report_counts_the_marches_rendered_and_reruns_at_its_quality() {
    let tmp = tempfile::tempdir().unwrap();
    for (share, marches) in [("false", 2), ("true", 1)] {
        let name = format!("share-{share}");
        let exp = write_experiment(
            tmp.path(),
            &name,
            "phantom-engine.toml",
            &format!(
                r#"share = {share}
[set]
"volume.phantom.resolution" = [32, 32, 32]
"integrator.volume_photons" = 2000
"integrator.stepsize" = 0.004
[axes]
"integrator.nused" = [25, 50]
"#
            ),
        );
        let out = tmp.path().join(&name);
        run_ok(
            sweep()
                .arg("run")
                .arg(&exp)
                .arg("--quick")
                .arg("--output")
                .arg(&out),
        );
        let report = std::fs::read_to_string(out.join("report.md")).unwrap();
        // The cells share a march key either way; only `share = true` renders them in one.
        assert!(
            report.contains(&format!(
                "2 finished cells came from about {marches} march(es)"
            )),
            "{report}"
        );
        assert!(
            report.contains(&format!(
                "{} --quick --output {}",
                exp.display(),
                out.display()
            )),
            "{report}"
        );
    }
}

#[test]
fn real_dataset_grid_records_checksums() {
    let Some(data) = data_dir() else {
        skip(
            "real_dataset_grid_records_checksums",
            "real datasets not found (set VOLPHOT_DATA)",
        );
        return;
    };
    let tmp = tempfile::tempdir().unwrap();
    let scene = workspace().join("experiments/scenes/engine.toml");
    let exp = tmp.path().join("real.toml");
    std::fs::write(
        &exp,
        format!(
            "scene = \"{}\"\n[set]\n\"camera.resolution\" = [40, 40]\n\"integrator.volume_photons\" = 3000\n\"integrator.stepsize\" = 0.004\n[axes]\n\"integrator.nused\" = [20, 80]\n",
            scene.display()
        ),
    )
    .unwrap();
    let out = tmp.path().join("out");
    run_ok(
        sweep()
            .arg(&exp)
            .arg("--output")
            .arg(&out)
            .env("VOLPHOT_DATA", &data),
    );
    let (headers, rows) = read_csv(&out.join("cells.csv"));
    assert_eq!(rows.len(), 2);
    for sha in column(&headers, &rows, "volume_sha256") {
        assert_eq!(
            sha,
            "15cf29cdde69cd6c8b5ab9eeef4d1bb21f276056da4111cb5069ebfbe5b6ff90"
        );
    }
    assert!(
        column(&headers, &rows, "volume")
            .iter()
            .all(|v| *v == "engine")
    );
}

/// A progressive cell in an experiment with a reference records its error after every
/// iteration and stops at `integrator.target_rmse`: a target every iteration meets stops
/// after the first; without one all iterations run.
#[test]
fn progressive_cells_stop_at_their_target_error_against_the_reference() {
    let tmp = tempfile::tempdir().unwrap();
    let exp = write_experiment(
        tmp.path(),
        "target",
        "phantom-head.toml",
        r#"
[set]
"volume.phantom.resolution" = [24, 24, 24]
"camera.resolution" = [16, 16]
"integrator.volume_photons" = 2000
"integrator.stepsize" = 0.01
"integrator.estimator" = "progressive"
"integrator.iterations" = 4
[axes]
"integrator.target_rmse" = [0, 1000]
[reference]
method = "path"
spp = 16
"#,
    );
    let out = tmp.path().join("out");
    run_ok(sweep().arg("run").arg(&exp).arg("--output").arg(&out));
    let mut seen = 0;
    for entry in std::fs::read_dir(out.join("cells")).unwrap().flatten() {
        let Ok(text) = std::fs::read_to_string(entry.path().join("cell.json")) else {
            continue;
        };
        let record: serde_json::Value = serde_json::from_str(&text).unwrap();
        // Not written when 0 (the content address of a cell without a target is unchanged).
        let target = record["scene"]["integrator"]["target_rmse"]
            .as_f64()
            .unwrap_or(0.0);
        let p = &record["progressive"];
        let errors = p["errors"].as_array().unwrap();
        if target > 0.0 {
            assert_eq!(
                (p["iterations"].as_u64(), p["stopped"].as_str()),
                (Some(1), Some("target-rmse")),
                "{p}"
            );
            assert_eq!(errors.len(), 1, "{p}");
        } else {
            assert_eq!(
                (p["iterations"].as_u64(), p["stopped"].as_str()),
                (Some(4), Some("iterations")),
                "{p}"
            );
            assert_eq!(errors.len(), 4, "{p}");
        }
        seen += 1;
    }
    assert_eq!(seen, 2);
}

#[test]
fn the_corrected_error_removes_the_reference_noise_and_follows_a_refined_reference() {
    let tmp = tempfile::tempdir().unwrap();
    let write = |spp: u32| {
        write_experiment(
            tmp.path(),
            "noise",
            "phantom-engine.toml",
            &format!(
                r#"
[set]
"volume.phantom.resolution" = [24, 24, 24]
"camera.resolution" = [32, 32]
"integrator.volume_photons" = 20000
"integrator.stepsize" = 0.004
"sigma.t" = 20
[axes]
"integrator.nused" = [20, 80]
[reference]
method = "path"
spp = {spp}
"#
            ),
        )
    };
    let out = tmp.path().join("out");
    let errors = |spp: u32| -> Vec<(f64, f64)> {
        run_ok(sweep().arg("run").arg(write(spp)).arg("--output").arg(&out));
        let (headers, rows) = read_csv(&out.join("cells.csv"));
        let rmse = column(&headers, &rows, "rmse [W/(m2 sr)]");
        let corrected = column(&headers, &rows, "rmse_corrected [W/(m2 sr)]");
        rmse.iter()
            .zip(&corrected)
            .map(|(r, c)| (r.parse().unwrap(), c.parse().unwrap()))
            .collect()
    };
    // A noisy reference (16 samples per pixel), then the same reference refined to 256.
    // (Deterministic: the same seeds give the same numbers on every run.)
    let noisy = errors(16);
    let refined = errors(256);
    for (i, (&(r16, c16), &(r256, c256))) in noisy.iter().zip(&refined).enumerate() {
        let all = format!("cell {i}: (rmse, corrected) {noisy:?} → {refined:?}");
        assert!(c16 < r16 && c256 < r256 && c16 > 0.0, "{all}");
        // The raw error falls as the reference's noise does (the metrics followed the
        // refined reference); the correction removes more of the noisier reference's
        // noise; the corrected error is the image's own, whatever the reference's samples
        // (to within the noise of the variance estimate itself).
        assert!(r16 > 1.3 * r256, "{all}");
        assert!(r16 - c16 > 3.0 * (r256 - c256), "{all}");
        assert!((c16 - c256).abs() < 0.5 * (r16 - r256), "{all}");
    }
}

#[test]
fn studies_share_references_through_a_pool_and_get_the_images_they_would_alone() {
    let tmp = tempfile::tempdir().unwrap();
    // Three studies of one scene that ask for 16, 4 and 24 samples per pixel.
    let study = |name: &str, spp: u32| {
        write_experiment(
            tmp.path(),
            name,
            "phantom-engine.toml",
            &format!(
                r#"
[set]
"volume.phantom.resolution" = [24, 24, 24]
"camera.resolution" = [24, 24]
"integrator.volume_photons" = 2000
"integrator.stepsize" = 0.004
"sigma.t" = 20
[reference]
method = "path"
spp = {spp}
"#
            ),
        )
    };
    let studies = [("a", 16), ("b", 4), ("c", 24)].map(|(n, spp)| (n, study(n, spp)));
    let pool = tmp.path().join("pool");
    let run = |exp: &Path, out: &Path, pooled: bool| {
        let mut cmd = sweep();
        cmd.arg("run").arg(exp).arg("--output").arg(out);
        if pooled {
            cmd.arg("--reference-pool").arg(&pool);
        }
        String::from_utf8_lossy(&run_ok(&mut cmd).stderr).into_owned()
    };
    let reference = |out: &Path| {
        let dir = std::fs::read_dir(out.join("references"))
            .unwrap()
            .flatten()
            .find(|e| e.path().is_dir())
            .expect("a reference folder")
            .path();
        let key = dir.file_name().unwrap().to_string_lossy().into_owned();
        (key, std::fs::read(dir.join("reference.exr")).unwrap())
    };
    for (name, exp) in &studies {
        let alone = tmp.path().join(format!("{name}-alone"));
        let pooled = tmp.path().join(format!("{name}-pooled"));
        run(exp, &alone, false);
        let stderr = run(exp, &pooled, true);
        let ((key, alone_exr), (pooled_key, pooled_exr)) = (reference(&alone), reference(&pooled));
        assert_eq!(key, pooled_key);
        // `c` (24) is refined from the 16-pass state `a` left; `b` (4) rendered anew.
        assert!(
            alone_exr == pooled_exr,
            "study {name}: the pooled reference differs from the one rendered alone"
        );
        assert!(stderr.contains("1 reference(s) rendered"), "{stderr}");
        let state = std::fs::read_to_string(pool.join(&key).join("state/reference.json")).unwrap();
        let passes = if *name == "c" { 24 } else { 16 };
        assert!(state.contains(&format!("\"passes\": {passes}")), "{state}");
    }
    // Another output folder of study `a` takes its reference from the pool as it is.
    let again = tmp.path().join("a-again");
    let stderr = run(&studies[0].1, &again, true);
    assert!(stderr.contains("0 reference(s) rendered"), "{stderr}");
    let (key, exr) = reference(&again);
    assert!(exr == reference(&tmp.path().join("a-alone")).1);
    let mut kept: Vec<String> = std::fs::read_dir(pool.join(&key))
        .unwrap()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    kept.sort();
    assert_eq!(kept, ["16", "24", "4", "state"]);
    // A damaged state is said so and left out: `c` is rendered whole, to the same image.
    let state = pool.join(&key).join("state/state.bin");
    let mut bytes = std::fs::read(&state).unwrap();
    let last = bytes.len() - 1;
    bytes[last] ^= 1;
    std::fs::write(&state, bytes).unwrap();
    std::fs::remove_dir_all(pool.join(&key).join("24")).unwrap();
    let redone = tmp.path().join("c-again");
    let stderr = run(&studies[2].1, &redone, true);
    assert!(
        stderr.contains("is damaged") && stderr.contains("rendering without it"),
        "{stderr}"
    );
    assert!(reference(&redone).1 == reference(&tmp.path().join("c-alone")).1);
    // The plan counts what the pool holds: `a`'s 16 passes whole, 24 of 48 in part.
    let planned = |exp: &Path| {
        let out = run_ok(
            sweep()
                .arg("plan")
                .arg(exp)
                .arg("--reference-pool")
                .arg(&pool),
        );
        String::from_utf8_lossy(&out.stdout).into_owned()
    };
    let whole = planned(&studies[0].1);
    assert!(whole.contains("holds 1 of them and 0 in part"), "{whole}");
    let part = planned(&study("d", 48));
    assert!(part.contains("holds 0 of them and 1 in part"), "{part}");
}

/// The README's first command (`sweep experiments/quickstart.toml`, here on a copy of the
/// tracked `experiments/` folder) writes only under `out/`: no tracked file changes and
/// nothing lands elsewhere, so a fresh clone's `git status` stays clean (`out/` is ignored).
#[test]
fn the_main_job_writes_only_under_out() {
    let dir = tempfile::tempdir().unwrap();
    let Some(tracked) = copy_tracked("experiments", dir.path()) else {
        skip(
            "the_main_job_writes_only_under_out",
            "not a git checkout: `git ls-files experiments` lists nothing",
        );
        return;
    };
    let before: std::collections::BTreeMap<PathBuf, Vec<u8>> = tracked
        .into_iter()
        .map(|rel| {
            let bytes = std::fs::read(dir.path().join(&rel)).unwrap();
            (rel, bytes)
        })
        .collect();
    run_ok(
        sweep()
            .current_dir(dir.path())
            .args(["experiments/quickstart.toml", "--quiet"]),
    );
    assert!(dir.path().join("out/quickstart/report.html").is_file());
    for (rel, bytes) in &before {
        assert_eq!(
            &std::fs::read(dir.path().join(rel)).unwrap(),
            bytes,
            "{} changed",
            rel.display()
        );
    }
    let mut others = Vec::new();
    let mut stack = vec![dir.path().to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap().flatten() {
            let p = e.path();
            let rel = p.strip_prefix(dir.path()).unwrap().to_path_buf();
            if rel.starts_with("out") {
                continue;
            }
            if p.is_dir() {
                stack.push(p);
            } else if !before.contains_key(&rel) {
                others.push(rel);
            }
        }
    }
    assert!(others.is_empty(), "written outside out/: {others:?}");
}

#[test]
fn a_clip_plane_offset_is_a_sweep_axis() {
    // A plane moving through the engine phantom: each offset is its own cell (its own
    // content address), the more it cuts away the less medium scatters light, and a cut
    // that keeps nothing is named with its key before any rendering.
    let tmp = tempfile::tempdir().unwrap();
    let exp = write_experiment(
        tmp.path(),
        "clip",
        "phantom-engine.toml",
        r#"
[set]
"volume.phantom.resolution" = [32, 32, 32]
"camera.resolution" = [24, 24]
"integrator.multiple" = false
"integrator.stepsize" = 0.004
"clip.plane.normal" = [0, 0, -1]
[axes]
"clip.plane.offset" = [-1.0, -0.5, -0.05]
"#,
    );
    let out = tmp.path().join("out");
    run_ok(sweep().arg(&exp).arg("--quiet").arg("--output").arg(&out));
    let (headers, rows) = read_csv(&out.join("cells.csv"));
    assert_eq!(rows.len(), 3);
    assert_eq!(finished_cells(&out), 3, "one cell per offset");
    let number = |name: &str| -> Vec<f64> {
        column(&headers, &rows, name)
            .iter()
            .map(|v| v.parse().unwrap())
            .collect()
    };
    assert_eq!(
        number("clip.plane.offset"),
        [-1.0, -0.5, -0.05],
        "{headers:?}"
    );
    // normal (0, 0, −1) keeps z ≤ −offset (in the box's fractions): the first keeps all,
    // the last a slice at the bottom, which scatters far less light to the eye.
    let means = number("mean_single [W/(m2 sr)]");
    assert!(
        means[0] != means[1] && means[1] != means[2] && means[2] < 0.5 * means[0],
        "single-scattering means along the cut: {means:?}"
    );
    let bad = write_experiment(
        tmp.path(),
        "clip_bad",
        "phantom-engine.toml",
        "[set]\n\"clip.plane.normal\" = [0, 0, -1]\n\"clip.plane.offset\" = 2.0\n",
    );
    let failed = sweep()
        .arg(&bad)
        .arg("--quiet")
        .arg("--output")
        .arg(tmp.path().join("bad"))
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&failed.stderr);
    assert!(
        !failed.status.success() && stderr.contains("clip.plane"),
        "{stderr}"
    );
}
