//! A real single-node Slurm cluster (Debian's packages, started by
//! `scripts/slurm-local.sh`): a grid through `--backend slurm --wait` must give the same
//! CSV and images as a local run; a task that fails on purpose is reported and only its
//! cell is resubmitted; `sweep tune --backend slurm` submits its rungs as job arrays and
//! decides exactly as a local tune. The cluster is always stopped, also when an assertion fails.
//!
//! Runs under `CI=true` (where it may not skip) or with `VOLPHOT_SLURM_TEST=1`.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

use volphot_tests::{read_csv, run_ok, sweep, workspace, write_experiment};

/// Starts the cluster in its own folder and ports; stops it on drop.
struct Cluster {
    dir: PathBuf,
    conf: PathBuf,
}

impl Cluster {
    fn script() -> PathBuf {
        workspace().join("scripts/slurm-local.sh")
    }

    fn command(&self, verb: &str) -> Command {
        let mut c = Command::new(Self::script());
        c.arg(verb)
            .env("VOLPHOT_SLURM_DIR", &self.dir)
            .env("VOLPHOT_SLURM_CTLD_PORT", "6917")
            .env("VOLPHOT_SLURM_D_PORT", "6918");
        c
    }

    fn start(dir: &Path) -> Result<Self, String> {
        let cluster = Cluster {
            dir: dir.to_path_buf(),
            conf: dir.join("slurm.conf"),
        };
        let out = cluster
            .command("start")
            .output()
            .map_err(|e| e.to_string())?;
        if !out.status.success() {
            // Stop whatever did start before reporting.
            let _ = cluster.command("stop").output();
            return Err(format!(
                "slurm-local.sh start failed:\n{}",
                String::from_utf8_lossy(&out.stderr)
            ));
        }
        Ok(cluster)
    }
}

impl Drop for Cluster {
    fn drop(&mut self) {
        let out = self.command("stop").output();
        if let Ok(o) = out
            && !o.status.success()
        {
            eprintln!(
                "slurm-local.sh stop: {}",
                String::from_utf8_lossy(&o.stderr)
            );
        }
    }
}

/// What each array task may use on the one-node test cluster.
const TASK_RESOURCES: [&str; 6] = [
    "--max-concurrent",
    "2",
    "--cpus-per-task",
    "1",
    "--mem",
    "500M",
];

fn enabled() -> bool {
    let ci = std::env::var("CI").is_ok_and(|v| v == "true" || v == "1");
    ci || std::env::var("VOLPHOT_SLURM_TEST").is_ok_and(|v| v == "1")
}

fn experiment(dir: &Path) -> PathBuf {
    write_experiment(
        dir,
        "slurm-e2e",
        "phantom-foot.toml",
        r#"
[set]
"volume.phantom.resolution" = [32, 32, 32]
"camera.resolution" = [32, 32]
"integrator.volume_photons" = 3000
"integrator.stepsize" = 0.004
[axes]
"sigma.t" = [20, 40, 80]
"integrator.nused" = [20, 60]
[[compare]]
kind = "layers"
"#,
    )
}

/// cells.csv without the columns that legitimately differ between runs: timings, memory,
/// host, and how many cells shared a march (a resubmitted cell renders alone; its image
/// is the same).
fn stable_csv(path: &Path) -> Vec<Vec<String>> {
    let (headers, rows) = read_csv(path);
    let keep: Vec<usize> = headers
        .iter()
        .enumerate()
        .filter(|(_, h)| {
            !(h.starts_with("time_")
                || h.starts_with("peak_memory")
                || h.starts_with("march_shared_by")
                || *h == "host")
        })
        .map(|(i, _)| i)
        .collect();
    std::iter::once(&headers)
        .chain(&rows)
        .map(|row| keep.iter().map(|&i| row[i].clone()).collect())
        .collect()
}

fn cell_dirs(out: &Path) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(out.join("cells"))
        .unwrap()
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.join("cell.json").is_file())
        .collect();
    v.sort();
    v
}

#[test]
fn slurm_array_matches_local_run_and_resubmits_only_failures() {
    if !enabled() {
        volphot_tests::skip(
            "slurm_array_matches_local_run_and_resubmits_only_failures",
            "set CI=true or VOLPHOT_SLURM_TEST=1 to start a local Slurm cluster (needs root and Debian's slurm packages)",
        );
        return;
    }
    let start = Instant::now();
    let tmp = tempfile::tempdir().unwrap();
    let cluster = match Cluster::start(&tmp.path().join("cluster")) {
        Ok(c) => c,
        Err(e) => panic!("{e}"),
    };
    let exp = experiment(tmp.path());
    let slurm = |out: &Path, extra: &[&str]| {
        let mut c = sweep();
        c.arg(&exp)
            .arg("--output")
            .arg(out)
            .args(["--backend", "slurm", "--wait", "--quiet"])
            .args(TASK_RESOURCES)
            .args(extra)
            .env("SLURM_CONF", &cluster.conf);
        c
    };

    // 1. Local and Slurm runs of the same file agree.
    let local = tmp.path().join("local");
    run_ok(sweep().arg(&exp).arg("--output").arg(&local).arg("--quiet"));
    let remote = tmp.path().join("remote");
    let t0 = Instant::now();
    run_ok(&mut slurm(&remote, &[]));
    eprintln!("slurm run: {:.1} s", t0.elapsed().as_secs_f64());
    assert_eq!(
        stable_csv(&local.join("cells.csv")),
        stable_csv(&remote.join("cells.csv"))
    );
    let (a, b) = (cell_dirs(&local), cell_dirs(&remote));
    assert_eq!(a.len(), 6);
    assert_eq!(
        a.iter()
            .map(|p| p.file_name().unwrap().to_owned())
            .collect::<Vec<_>>(),
        b.iter()
            .map(|p| p.file_name().unwrap().to_owned())
            .collect::<Vec<_>>(),
        "same content addresses"
    );
    for (x, y) in a.iter().zip(&b) {
        assert_eq!(
            std::fs::read(x.join("film.exr")).unwrap(),
            std::fs::read(y.join("film.exr")).unwrap(),
            "{}",
            x.display()
        );
    }
    for figure in [
        "figures/sheet0_total_0.png",
        "figures/sheet1_multiple_0.png",
    ] {
        assert_eq!(
            std::fs::read(local.join(figure)).unwrap(),
            std::fs::read(remote.join(figure)).unwrap(),
            "{figure}"
        );
    }
    assert!(remote.join("report.html").is_file() && remote.join("slurm/array.sh").is_file());

    // 2. One task fails on purpose: reported, then only that cell is resubmitted.
    let flaky = tmp.path().join("flaky");
    let failed = slurm(&flaky, &[])
        .env("VOLPHOT_FAIL_CELLS", "2")
        .output()
        .unwrap();
    assert!(!failed.status.success(), "a failed cell makes the run fail");
    let report = std::fs::read_to_string(flaky.join("report.md")).unwrap();
    assert!(
        report.contains("## Failures") && report.contains("cell 2"),
        "{report}"
    );
    let status = run_ok(
        sweep()
            .arg("status")
            .arg(&flaky)
            .env("SLURM_CONF", &cluster.conf),
    );
    let status = String::from_utf8_lossy(&status.stdout);
    assert!(status.contains("failed       1  2"), "{status}");
    run_ok(&mut slurm(&flaky, &[]));
    let jobs: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(flaky.join("slurm/jobs.json")).unwrap())
            .unwrap();
    let submissions = jobs["submissions"].as_array().unwrap();
    assert_eq!(submissions.len(), 2);
    assert_eq!(
        submissions[1]["cells"],
        serde_json::json!([2]),
        "only the failed cell is resubmitted"
    );
    assert_eq!(cell_dirs(&flaky).len(), 6);
    assert_eq!(
        stable_csv(&flaky.join("cells.csv")),
        stable_csv(&local.join("cells.csv"))
    );

    // 3. `sweep tune` puts each rung of its search on the cluster as one job array and
    //    decides exactly as a local tune does.
    let tune = write_experiment(
        tmp.path(),
        "slurm-tune",
        "phantom-engine.toml",
        r#"
max_cells = 100
[set]
"volume.phantom.resolution" = [16, 16, 16]
"camera.resolution" = [12, 12]
"integrator.volume_photons" = 4000
"integrator.stepsize" = 0.008
"sigma.t" = 60
[reference]
spp = 32
[tune]
seed = 3
objective = "rmse"
budget = { renders = 8 }
[tune.fidelity]
resolution = [12, 12]
min_resolution = [6, 6]
min_photon_fraction = 0.5
levels = 2
eta = 3
[tune.space]
"integrator.nused" = { int = [2, 40], scale = "log" }
"#,
    );
    let tune_local = tmp.path().join("tune-local");
    run_ok(
        sweep()
            .args(["tune", "--quiet", "--no-report"])
            .arg(&tune)
            .arg("-o")
            .arg(&tune_local),
    );
    let tune_remote = tmp.path().join("tune-remote");
    run_ok(
        sweep()
            .args(["tune", "--quiet", "--no-report", "--backend", "slurm"])
            .args(TASK_RESOURCES)
            .arg(&tune)
            .arg("-o")
            .arg(&tune_remote)
            .env("SLURM_CONF", &cluster.conf),
    );
    let observations = |out: &Path| {
        let (h, rows) = read_csv(&out.join("tune/observations.csv"));
        let keep: Vec<usize> = ["id", "level", "integrator.nused", "error"]
            .iter()
            .map(|k| {
                h.iter()
                    .position(|x| x == k)
                    .unwrap_or_else(|| panic!("{k}"))
            })
            .collect();
        rows.iter()
            .map(|r| keep.iter().map(|&i| r[i].clone()).collect::<Vec<_>>())
            .collect::<Vec<_>>()
    };
    let local_obs = observations(&tune_local);
    assert!(local_obs.len() >= 4, "{local_obs:?}");
    assert_eq!(
        local_obs,
        observations(&tune_remote),
        "same proposals, same errors"
    );
    let jobs: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(tune_remote.join("slurm/jobs.json")).unwrap(),
    )
    .unwrap();
    let rungs = jobs["submissions"].as_array().unwrap();
    assert!(rungs.len() >= 2, "one job array per rung: {jobs}");
    eprintln!("slurm test: {:.1} s", start.elapsed().as_secs_f64());
    drop(cluster);
}
