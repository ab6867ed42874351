//! Fault injection: runs killed at many moments, finished cells damaged, the output folder's
//! file system filled up. In every case a rerun completes and its images equal those of an
//! uninterrupted run, and nothing half-written is ever taken for finished.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

use volphot_tests::{run_ok, skip, sweep, write_experiment};

/// Eight cells in four marches with a reference: a couple of seconds per full run.
fn experiment(dir: &Path) -> PathBuf {
    write_experiment(
        dir,
        "faults",
        "phantom-engine.toml",
        r#"
[set]
"volume.phantom.resolution" = [24, 24, 24]
"camera.resolution" = [40, 40]
"integrator.volume_photons" = 4000
"integrator.stepsize" = 0.004
[axes]
"sigma.t" = [20, 60]
"integrator.nused" = [20, 80]
"integrator.spp" = [1, 2]
[reference]
spp = 4
[[compare]]
kind = "layers"
"#,
    )
}

/// Every finished cell's `film.exr` by hash, and the names of what is not whole.
fn finished(out: &Path) -> (Vec<(String, Vec<u8>)>, Vec<String>) {
    let mut films = Vec::new();
    let mut temporaries = Vec::new();
    for e in std::fs::read_dir(out.join("cells"))
        .into_iter()
        .flatten()
        .flatten()
    {
        let name = e.file_name().to_string_lossy().into_owned();
        if name.contains(".tmp-") {
            temporaries.push(name);
        } else if e.path().join("cell.json").is_file() {
            films.push((name, std::fs::read(e.path().join("film.exr")).unwrap()));
        }
    }
    films.sort();
    (films, temporaries)
}

#[test]
fn killed_damaged_and_starved_runs_recover_to_the_uninterrupted_result() {
    let tmp = tempfile::tempdir().unwrap();
    let exp = experiment(tmp.path());
    let clean = tmp.path().join("clean");
    let start = Instant::now();
    run_ok(sweep().arg(&exp).arg("--output").arg(&clean).arg("--quiet"));
    let full_run = start.elapsed();
    let (expected, _) = finished(&clean);
    assert_eq!(expected.len(), 8);

    // Kill at moments spread over a run (planning, references, marches, writing, report).
    let out = tmp.path().join("killed");
    let mut kills = 0;
    let mut state = 0x9e37_79b9_7f4a_7c15u64;
    while kills < 12 {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        let fraction = (state % 1000) as f64 / 1000.0;
        let delay = full_run.mul_f64(0.05 + 0.9 * fraction);
        let mut child = sweep()
            .arg(&exp)
            .arg("--output")
            .arg(&out)
            .arg("--quiet")
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::null())
            .spawn()
            .unwrap();
        std::thread::sleep(delay);
        let _ = child.kill();
        let _ = child.wait();
        kills += 1;
        // Whatever the moment, a cell that looks finished is whole.
        if out.join("plan.json").is_file() {
            let status = run_ok(sweep().arg("status").arg(&out));
            let text = String::from_utf8_lossy(&status.stdout).into_owned();
            assert!(
                text.contains("damaged      0"),
                "after kill {kills}: {text}"
            );
        }
    }
    run_ok(sweep().arg(&exp).arg("--output").arg(&out).arg("--quiet"));
    let (films, temporaries) = finished(&out);
    assert_eq!(films, expected, "after {kills} kills");
    assert!(temporaries.is_empty(), "{temporaries:?}");
    assert!(out.join("report.html").is_file());

    // Damage: a truncated film and a flipped bit in another.
    let cells = out.join("cells");
    let damaged: Vec<PathBuf> = std::fs::read_dir(&cells)
        .unwrap()
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.join("film.exr").is_file())
        .take(2)
        .collect();
    let film = std::fs::read(damaged[0].join("film.exr")).unwrap();
    std::fs::write(damaged[0].join("film.exr"), &film[..film.len() - 10]).unwrap();
    let mut flipped = std::fs::read(damaged[1].join("film.exr")).unwrap();
    flipped[100] ^= 1;
    std::fs::write(damaged[1].join("film.exr"), flipped).unwrap();
    run_ok(sweep().arg(&exp).arg("--output").arg(&out).arg("--quiet"));
    assert_eq!(finished(&out).0, expected, "after damage");

    starved_file_system(&exp, &expected);
}

/// The output folder on a tiny tmpfs: the run fails with a clear error and finishes nothing
/// half-written; with room again, the rerun completes.
fn starved_file_system(exp: &Path, expected: &[(String, Vec<u8>)]) {
    let root = std::process::Command::new("id")
        .arg("-u")
        .output()
        .is_ok_and(|o| String::from_utf8_lossy(&o.stdout).trim() == "0");
    if !root {
        skip(
            "fault injection on a full file system",
            "mounting a tmpfs needs root",
        );
        return;
    }
    let mount = tempfile::tempdir().unwrap();
    let mounted = Command::new("mount")
        .args(["-t", "tmpfs", "-o", "size=600k", "tmpfs"])
        .arg(mount.path())
        .status()
        .is_ok_and(|s| s.success());
    if !mounted {
        skip(
            "fault injection on a full file system",
            "this machine refuses to mount a tmpfs",
        );
        return;
    }
    let result = std::panic::catch_unwind(|| {
        let out = mount.path().join("out");
        let o = sweep()
            .arg(exp)
            .arg("--output")
            .arg(&out)
            .arg("--quiet")
            .output()
            .unwrap();
        assert!(!o.status.success(), "a full disk must fail the run");
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(err.contains("No space left on device"), "{err}");
        let (_, temporaries) = finished(&out);
        assert!(temporaries.is_empty(), "{temporaries:?}");
        let status = run_ok(sweep().arg("status").arg(&out));
        assert!(String::from_utf8_lossy(&status.stdout).contains("damaged      0"));
        let grown = Command::new("mount")
            .args(["-o", "remount,size=64m"])
            .arg(mount.path())
            .status()
            .unwrap();
        assert!(grown.success());
        run_ok(sweep().arg(exp).arg("--output").arg(&out).arg("--quiet"));
        assert_eq!(finished(&out).0, expected, "after a full disk");
    });
    let _ = Command::new("umount").arg(mount.path()).status();
    std::thread::sleep(Duration::from_millis(10));
    if let Err(e) = result {
        std::panic::resume_unwind(e);
    }
}
