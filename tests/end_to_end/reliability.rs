//! Inputs and events that used to hang, exhaust memory, block a folder or silently change
//! the picture (issue "Reliability"), each through the real `sweep` binary.

use std::fs::File;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::Duration;

use volphot_tests::{read_csv, run_ok, sweep, workspace, write_experiment};

/// A small grid on the engine phantom: σt × nused, with a reference (four cells, two
/// marches).
fn grid(dir: &Path, name: &str) -> PathBuf {
    write_experiment(
        dir,
        name,
        "phantom-engine.toml",
        r#"
[set]
"volume.phantom.resolution" = [24, 24, 24]
"camera.resolution" = [24, 24]
"integrator.volume_photons" = 3000
"integrator.stepsize" = 0.006
[axes]
"sigma.t" = [20, 60]
"integrator.nused" = [20, 80]
[reference]
spp = 4
"#,
    )
}

/// Runs `cmd`, killing it after `seconds` (a hang is a failure, not a stuck test).
pub(crate) fn output_within(cmd: &mut Command, seconds: u64) -> Output {
    let child = cmd
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("sweep starts");
    let id = child.id();
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let _ = tx.send(child.wait_with_output());
    });
    match rx.recv_timeout(Duration::from_secs(seconds)) {
        Ok(out) => out.expect("sweep output"),
        Err(_) => {
            let _ = Command::new("kill").arg("-9").arg(id.to_string()).status();
            panic!("{cmd:?} did not finish within {seconds} s");
        }
    }
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Every cell folder's `film.exr`, by hash.
fn films(out: &Path) -> Vec<(String, Vec<u8>)> {
    let mut v: Vec<(String, Vec<u8>)> = std::fs::read_dir(out.join("cells"))
        .unwrap()
        .flatten()
        .filter(|e| e.path().join("cell.json").is_file())
        .map(|e| {
            (
                e.file_name().to_string_lossy().into_owned(),
                std::fs::read(e.path().join("film.exr")).unwrap(),
            )
        })
        .collect();
    v.sort();
    v
}

fn hashes(out: &Path) -> Vec<String> {
    let plan: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("plan.json")).unwrap()).unwrap();
    plan["cells"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| c["hash"].as_str().unwrap().to_string())
        .collect()
}

#[test]
fn case1_huge_sigma_is_refused_at_once_and_a_runaway_cell_times_out() {
    let tmp = tempfile::tempdir().unwrap();
    // The reproduction as found: σt = 1e30 never finished.
    let scene = tmp.path().join("dense.toml");
    std::fs::write(
        &scene,
        "[volume]\nphantom = { name = \"engine\", resolution = [24, 24, 24] }\n[sigma]\nt = 1e30\n[camera]\nresolution = [32, 32]\n[three_point]\n[integrator]\nvolume_photons = 2000\nstepsize = 0.01\n",
    )
    .unwrap();
    let o = output_within(
        sweep().arg("render").arg(&scene).arg("-o").arg(tmp.path()),
        120,
    );
    assert_eq!(o.status.code(), Some(2));
    let e = stderr(&o);
    assert!(
        e.contains("dense.toml:4:5") && e.contains("`sigma.t`") && e.contains("mean free path"),
        "{e}"
    );

    // --cell-timeout: the expensive cell fails with the limit, the cheap one finishes.
    let exp = write_experiment(
        tmp.path(),
        "timeout",
        "phantom-engine.toml",
        r#"
[set]
"volume.phantom.resolution" = [24, 24, 24]
"integrator.volume_photons" = 2000
[[zip]]
"camera.resolution" = [[16, 16], [400, 400]]
"integrator.stepsize" = [0.01, 0.0002]
"#,
    );
    let out = tmp.path().join("timeout-out");
    let o = output_within(
        sweep()
            .arg(&exp)
            .arg("--output")
            .arg(&out)
            .arg("--cell-timeout")
            .arg("2"),
        300,
    );
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let e = stderr(&o);
    assert!(e.contains("1 rendered") && e.contains("1 failed"), "{e}");
    assert!(e.contains("time limit of 2 s"), "{e}");
    let (h, rows) = read_csv(&out.join("cells.csv"));
    let status = h.iter().position(|c| c == "status").unwrap();
    let states: Vec<&str> = rows.iter().map(|r| r[status].as_str()).collect();
    assert_eq!(states, ["done", "failed"]);
}

#[test]
fn case2_a_huge_grid_is_refused_before_any_cell_is_built() {
    let tmp = tempfile::tempdir().unwrap();
    // 10⁷ combinations; the last value of `nused` is invalid, so expanding the grid would
    // end in a validation error instead of the size check.
    let exp = write_experiment(
        tmp.path(),
        "huge",
        "phantom-engine.toml",
        r#"
[axes]
"integrator.maxdist" = { from = 0.05, to = 0.5, steps = 10 }
"integrator.stepsize" = { from = 0.001, to = 0.01, steps = 10 }
"sigma.t" = { from = 6, to = 300, steps = 10 }
"integrator.volume_photons" = { from = 1000, to = 100000, steps = 10 }
"integrator.seed" = { from = 1, to = 10, steps = 10 }
"camera.fov" = { from = 20, to = 40, steps = 10 }
"integrator.nused" = [10, 20, 30, 40, 50, 60, 70, 80, 90, 0]
"#,
    );
    for args in [vec!["run"], vec!["run", "--yes"]] {
        let o = output_within(
            sweep()
                .args(&args)
                .arg(&exp)
                .arg("--output")
                .arg(tmp.path().join("o")),
            60,
        );
        assert_eq!(o.status.code(), Some(2));
        let e = stderr(&o);
        assert!(
            e.contains("10000000 cells") && e.contains("1000000"),
            "{args:?}: {e}"
        );
    }
    let o = output_within(sweep().arg("plan").arg(&exp), 60);
    assert!(o.status.success());
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(
        text.contains("10000000 cells") && text.contains("not expanded"),
        "{text}"
    );
    assert!(!tmp.path().join("o").exists(), "nothing written");
}

#[test]
fn case3_render_sidecars_record_the_normalisation() {
    let tmp = tempfile::tempdir().unwrap();
    // A signed 16-bit CT (air −1024, a bone cube): the default shows the cube, not a block.
    let n = 12usize;
    let mut bytes = Vec::new();
    for i in 0..n * n * n {
        let (x, y, z) = (i % n, (i / n) % n, i / (n * n));
        let v: i16 = if [x, y, z].iter().all(|c| (4..8).contains(c)) {
            1200
        } else {
            -1024
        };
        bytes.extend_from_slice(&v.to_le_bytes());
    }
    std::fs::write(tmp.path().join("ct.raw"), bytes).unwrap();
    let scene = tmp.path().join("ct.toml");
    std::fs::write(
        &scene,
        "[volume]\nfile = \"ct.raw\"\ndims = [12, 12, 12]\nvoxel = \"i16\"\n[camera]\nresolution = [16, 16]\n[three_point]\n[integrator]\nvolume_photons = 1000\nstepsize = 0.01\n",
    )
    .unwrap();
    run_ok(
        sweep()
            .arg("render")
            .arg(&scene)
            .arg("-o")
            .arg(tmp.path())
            .arg("--quiet"),
    );
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(tmp.path().join("ct.json")).unwrap())
            .unwrap();
    assert_eq!(json["normalization"]["method"], "min-max", "{json}");
    assert_eq!(json["normalization"]["raw_lo"], -1024.0);
    assert_eq!(json["normalization"]["raw_hi"], 1200.0);
}

#[test]
fn case4_damaged_cells_are_seen_and_rendered_again() {
    let tmp = tempfile::tempdir().unwrap();
    let exp = grid(tmp.path(), "damage");
    let out = tmp.path().join("out");
    run_ok(sweep().arg(&exp).arg("--output").arg(&out).arg("--quiet"));
    let original = films(&out);
    let h = hashes(&out);
    let cell = |i: usize| out.join("cells").join(&h[i]);
    // Truncate a film, remove a PNG, flip a bit, truncate a record; damage a reference.
    let film = std::fs::read(cell(0).join("film.exr")).unwrap();
    std::fs::write(cell(0).join("film.exr"), &film[..film.len() / 2]).unwrap();
    std::fs::remove_file(cell(1).join("total.png")).unwrap();
    let mut flipped = std::fs::read(cell(2).join("film.exr")).unwrap();
    let mid = flipped.len() / 2;
    flipped[mid] ^= 0x10;
    std::fs::write(cell(2).join("film.exr"), flipped).unwrap();
    let record = std::fs::read(cell(3).join("cell.json")).unwrap();
    std::fs::write(cell(3).join("cell.json"), &record[..record.len() / 3]).unwrap();
    let reference = std::fs::read_dir(out.join("references"))
        .unwrap()
        .flatten()
        .find(|e| e.path().is_dir())
        .unwrap()
        .path();
    std::fs::remove_file(reference.join("reference.exr")).unwrap();

    let status = run_ok(sweep().arg("status").arg(&out));
    let text = String::from_utf8_lossy(&status.stdout);
    assert!(text.contains("damaged      4"), "{text}");
    assert!(
        text.contains("film.exr is") && text.contains("total.png is missing"),
        "{text}"
    );
    let rerun = run_ok(sweep().arg(&exp).arg("--output").arg(&out).arg("--quiet"));
    let e = stderr(&rerun);
    assert!(
        e.contains("4 damaged cell(s) rendered again") && e.contains("4 rendered"),
        "{e}"
    );
    assert!(e.contains("reference.exr is missing"), "{e}");
    assert_eq!(
        films(&out),
        original,
        "re-rendered cells equal the originals"
    );
    let again = run_ok(sweep().arg(&exp).arg("--output").arg(&out).arg("--quiet"));
    assert!(stderr(&again).contains("4 already done, 0 rendered"));
}

#[test]
fn case5_experiment_names_are_plain_and_folders_are_not_shared() {
    let tmp = tempfile::tempdir().unwrap();
    let scene = workspace().join("experiments/scenes/phantom-engine.toml");
    for bad in ["../../escape", "/abs/path", "", "a b"] {
        let path = tmp.path().join("e.toml");
        std::fs::write(
            &path,
            format!(
                "name = {bad:?}\nscene = {:?}\n",
                scene.display().to_string()
            ),
        )
        .unwrap();
        let o = output_within(sweep().arg("plan").arg(&path), 60);
        assert_eq!(o.status.code(), Some(2), "{bad:?}");
        let e = stderr(&o);
        assert!(
            e.contains("e.toml:1:") && e.contains("plain name"),
            "{bad:?}: {e}"
        );
    }
    let out = tmp.path().join("shared");
    let first = grid(tmp.path(), "first");
    run_ok(
        sweep()
            .arg(&first)
            .arg("--output")
            .arg(&out)
            .arg("--quiet")
            .arg("--no-report"),
    );
    let second = grid(tmp.path(), "second");
    let o = output_within(sweep().arg(&second).arg("--output").arg(&out), 60);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains("holds the cells of experiment `first`"),
        "{}",
        stderr(&o)
    );
    // Nor a folder of other things.
    let other = tmp.path().join("other");
    std::fs::create_dir_all(&other).unwrap();
    std::fs::write(other.join("notes.txt"), "mine").unwrap();
    let o = output_within(sweep().arg(&second).arg("--output").arg(&other), 60);
    assert!(stderr(&o).contains("not a sweep output folder") && stderr(&o).contains("notes.txt"));
}

#[test]
fn case6_images_do_not_depend_on_which_cells_share_a_run() {
    let tmp = tempfile::tempdir().unwrap();
    let exp = grid(tmp.path(), "identity");
    let whole = tmp.path().join("whole");
    run_ok(sweep().arg(&exp).arg("--output").arg(&whole).arg("--quiet"));
    let sharded = tmp.path().join("sharded");
    for shard in ["0/2", "1/2"] {
        run_ok(
            sweep()
                .arg(&exp)
                .arg("--output")
                .arg(&sharded)
                .arg("--shard")
                .arg(shard)
                .arg("--quiet"),
        );
    }
    assert_eq!(films(&sharded), films(&whole), "--shard");
    // One deleted cell rendered alone (as `--cells` or a resumed run does).
    let h = hashes(&whole);
    std::fs::remove_dir_all(whole.join("cells").join(&h[1])).unwrap();
    run_ok(
        sweep()
            .arg(&exp)
            .arg("--output")
            .arg(&whole)
            .arg("--cells")
            .arg("1")
            .arg("--quiet"),
    );
    assert_eq!(
        films(&whole),
        films(&sharded),
        "--cells 1 after deleting it"
    );
}

#[test]
fn case7_a_nan_voxel_is_named_at_load() {
    let tmp = tempfile::tempdir().unwrap();
    let mut bytes = Vec::new();
    for i in 0..27 {
        let v = if i == 13 { f32::NAN } else { 0.5 };
        bytes.extend_from_slice(&v.to_le_bytes());
    }
    std::fs::write(tmp.path().join("nan.raw"), bytes).unwrap();
    let scene = tmp.path().join("nan.toml");
    std::fs::write(
        &scene,
        "[volume]\nfile = \"nan.raw\"\ndims = [3, 3, 3]\nvoxel = \"f32\"\n[three_point]\n",
    )
    .unwrap();
    let o = output_within(
        sweep().arg("render").arg(&scene).arg("-o").arg(tmp.path()),
        60,
    );
    assert_eq!(o.status.code(), Some(2));
    let e = stderr(&o);
    assert!(
        e.contains("nan.raw") && e.contains("voxel 13") && e.contains("x = 1, y = 1, z = 1"),
        "{e}"
    );
}

#[test]
fn case8_minor_failures_are_clear() {
    let tmp = tempfile::tempdir().unwrap();
    let exp = grid(tmp.path(), "minor");
    // Each error names the flag and the value given and says what is allowed (clap's
    // wording for a value parser: `invalid value '10000' for '--threads <N>'`).
    for (flag, value, says) in [
        (
            "--threads",
            "10000",
            "'--threads <N>': `10000`: expected a number of worker threads in 1..=1024",
        ),
        ("--jobs", "0", "--jobs 0"),
    ] {
        let o = output_within(
            sweep()
                .arg(&exp)
                .arg(flag)
                .arg(value)
                .arg("--output")
                .arg(tmp.path().join("x")),
            60,
        );
        assert_eq!(o.status.code(), Some(2), "{flag}");
        assert!(stderr(&o).contains(says), "{flag}: {}", stderr(&o));
    }
    // `sweep report` on a folder that is not an output folder writes nothing there.
    let plain = tmp.path().join("plain");
    std::fs::create_dir_all(&plain).unwrap();
    let o = output_within(sweep().arg("report").arg(&plain), 60);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("no plan.json"), "{}", stderr(&o));
    assert_eq!(
        std::fs::read_dir(&plain).unwrap().count(),
        0,
        "no .lock left"
    );
    // A killed report's temporaries are removed by the next report.
    let out = tmp.path().join("out");
    run_ok(sweep().arg(&exp).arg("--output").arg(&out).arg("--quiet"));
    let host = volphot::hostname();
    let stale = [
        out.join(format!(".report.md.tmp-{host}-4294967295.0")),
        out.join("figures")
            .join(format!(".sheet0_total_0.png.tmp-{host}-4294967295.3")),
    ];
    for s in &stale {
        std::fs::write(s, "half").unwrap();
    }
    run_ok(sweep().arg("report").arg(&out));
    assert!(
        stale.iter().all(|s| !s.exists()),
        "stale temporaries removed"
    );
    // Overlapping `--cells` runs: a cell another run holds is counted, not lost.
    let h = hashes(&out);
    std::fs::remove_dir_all(out.join("cells").join(&h[2])).unwrap();
    std::fs::remove_dir_all(out.join("cells").join(&h[3])).unwrap();
    let lock = File::options()
        .create(true)
        .truncate(false)
        .write(true)
        .open(out.join("cells").join(format!(".{}.lock", h[3])))
        .unwrap();
    lock.lock().unwrap();
    let o = run_ok(
        sweep()
            .arg(&exp)
            .arg("--output")
            .arg(&out)
            .arg("--cells")
            .arg("1-3")
            .arg("--quiet"),
    );
    let e = stderr(&o);
    assert!(
        e.contains("3 of 4 cells selected; 1 already done, 1 rendered")
            && e.contains("1 cell(s) left to another run"),
        "{e}"
    );
    drop(lock);
}

#[test]
fn case8_a_replaced_volume_file_of_the_same_size_and_time_is_a_new_cell() {
    let tmp = tempfile::tempdir().unwrap();
    let n = 8usize;
    let volume = tmp.path().join("v.raw");
    let write = |seed: u8| {
        let bytes: Vec<u8> = (0..n * n * n)
            .map(|i| ((i as u8).wrapping_mul(seed)) | 1)
            .collect();
        std::fs::write(&volume, bytes).unwrap();
    };
    write(3);
    let scene = tmp.path().join("v.toml");
    std::fs::write(&scene, "[volume]\nfile = \"v.raw\"\ndims = [8, 8, 8]\nvoxel = \"u8\"\n[camera]\nresolution = [16, 16]\n[three_point]\n[integrator]\nvolume_photons = 1000\nstepsize = 0.01\n").unwrap();
    let exp = tmp.path().join("v-exp.toml");
    std::fs::write(
        &exp,
        format!(
            "name = \"replaced\"\nscene = {:?}\n",
            scene.display().to_string()
        ),
    )
    .unwrap();
    let out = tmp.path().join("out");
    run_ok(sweep().arg(&exp).arg("--output").arg(&out).arg("--quiet"));
    let before = hashes(&out);
    let modified = std::fs::metadata(&volume).unwrap().modified().unwrap();
    write(5);
    File::options()
        .write(true)
        .open(&volume)
        .unwrap()
        .set_modified(modified)
        .unwrap();
    let o = run_ok(sweep().arg(&exp).arg("--output").arg(&out).arg("--quiet"));
    assert!(
        stderr(&o).contains("0 already done, 1 rendered"),
        "{}",
        stderr(&o)
    );
    assert_ne!(hashes(&out), before);
}

#[test]
fn a_panicking_cell_fails_alone() {
    let tmp = tempfile::tempdir().unwrap();
    let exp = grid(tmp.path(), "panic");
    let out = tmp.path().join("out");
    let o = output_within(
        sweep()
            .arg(&exp)
            .arg("--output")
            .arg(&out)
            .arg("--quiet")
            .env("VOLPHOT_PANIC_CELLS", "0"),
        300,
    );
    assert_eq!(o.status.code(), Some(1));
    let e = stderr(&o);
    // Cells 0 and 1 share a march: both fail with the panic; the other march renders.
    assert!(
        e.contains("2 rendered")
            && e.contains("2 failed")
            && e.contains("panicked: panic injected"),
        "{e}"
    );
}

/// An experiment or scene path that names a device, a FIFO or a folder is refused at once,
/// naming it and what was expected (issue #45, case 4): `sweep plan /dev/zero` read until
/// memory ran out, and `sweep render` of a FIFO blocked forever.
#[test]
fn experiment_and_scene_paths_must_be_regular_files() {
    let dir = tempfile::tempdir().unwrap();
    let fifo = dir.path().join("pipe.toml");
    assert!(
        Command::new("mkfifo")
            .arg(&fifo)
            .status()
            .unwrap()
            .success()
    );
    let out_dir = dir.path().join("out");
    let runs: [(Vec<&std::ffi::OsStr>, &[&str]); 4] = [
        (
            vec!["plan".as_ref(), "/dev/zero".as_ref()],
            &["/dev/zero", "character device", "experiment file"],
        ),
        (
            vec!["run".as_ref(), fifo.as_os_str()],
            &["pipe.toml", "FIFO", "experiment file"],
        ),
        (
            vec![
                "render".as_ref(),
                fifo.as_os_str(),
                "-o".as_ref(),
                out_dir.as_os_str(),
            ],
            &["pipe.toml", "FIFO", "scene file"],
        ),
        (
            vec!["plan".as_ref(), dir.path().as_os_str()],
            &["a folder", "experiment file"],
        ),
    ];
    for (args, words) in runs {
        let out = output_within(sweep().args(&args), 30);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{args:?} succeeded");
        for w in words {
            assert!(stderr.contains(w), "{args:?}: {stderr:?} lacks {w:?}");
        }
    }
}

/// Copies `from` into `to` without its `cells/`, `references/` and lock: what a fresh clone
/// holds of a committed study.
fn copy_as_cloned(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for entry in std::fs::read_dir(from).unwrap().flatten() {
        let name = entry.file_name();
        if ["cells", "references", ".lock", ".cache"]
            .iter()
            .any(|n| name == *n)
        {
            continue;
        }
        let target = to.join(&name);
        if entry.file_type().unwrap().is_dir() {
            copy_as_cloned(&entry.path(), &target);
        } else {
            std::fs::copy(entry.path(), &target).unwrap();
        }
    }
}

/// Every file under `dir` with its bytes, sorted by path.
fn snapshot(dir: &Path) -> Vec<(PathBuf, Vec<u8>)> {
    let mut files = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for entry in std::fs::read_dir(&d).unwrap().flatten() {
            if entry.file_type().unwrap().is_dir() {
                stack.push(entry.path());
            } else {
                files.push((entry.path(), std::fs::read(entry.path()).unwrap()));
            }
        }
    }
    files.sort();
    files
}

/// `sweep report` on a committed study in a fresh clone (its tables, no `cells/`) used to
/// exit 0 and rewrite `cells.csv` with every `done` row turned `pending`, and the report and
/// contact sheets with "missing" tiles (issue #45, case 1). It must refuse, write nothing,
/// and say how to get the data back; `sweep status` must say the cells are recorded done.
#[test]
fn report_on_a_cloned_study_keeps_its_recorded_results() {
    let dir = tempfile::tempdir().unwrap();
    let study = dir.path().join("quickstart");
    copy_as_cloned(&workspace().join("reports/quickstart"), &study);
    let before = snapshot(&study);
    let recorded = before
        .iter()
        .find(|(p, _)| p.ends_with("cells.csv"))
        .map(|(_, b)| String::from_utf8_lossy(b).matches(",done,").count())
        .unwrap();
    assert!(
        recorded > 0,
        "the committed quickstart records no done cell"
    );
    let out = output_within(sweep().arg("report").arg(&study), 60);
    let err = stderr(&out);
    assert!(!out.status.success(), "sweep report succeeded: {err}");
    for w in [
        "recorded as done",
        "Nothing was written",
        "sweep run experiments/quickstart.toml",
    ] {
        assert!(err.contains(w), "{err:?} lacks {w:?}");
    }
    assert!(
        snapshot(&study) == before,
        "sweep report changed the folder"
    );
    let status = output_within(sweep().arg("status").arg(&study), 60);
    let text = String::from_utf8_lossy(&status.stdout);
    assert!(
        text.contains(&format!("recorded {recorded:>5}")),
        "status does not count {recorded} recorded cells:\n{text}"
    );
    // A tuning study's cells come back from its plan, not from a new search (which would
    // propose other settings).
    let tuned = dir.path().join("tune_foot");
    copy_as_cloned(&workspace().join("reports/tune_foot"), &tuned);
    let cells = std::fs::read_to_string(tuned.join("cells.csv"))
        .unwrap()
        .lines()
        .count()
        - 1;
    let before = snapshot(&tuned);
    let out = output_within(sweep().arg("report").arg(&tuned), 60);
    let err = stderr(&out);
    assert!(!out.status.success(), "sweep report succeeded: {err}");
    let want = format!(
        "sweep tune experiments/tune_foot.toml --cells 0-{} --output",
        cells - 1
    );
    assert!(err.contains(&want), "{err:?} lacks {want:?}");
    assert!(
        snapshot(&tuned) == before,
        "sweep report changed the folder"
    );
}

/// User strings in `report.md` are text, never markup (issue #45, case 8): the description
/// and a scene path given as an axis value used to land there as live HTML.
#[test]
fn report_md_escapes_user_strings() {
    const ATTACK: &str = "\"><img src=x onerror=alert(1)>";
    let dir = tempfile::tempdir().unwrap();
    let scene_text =
        std::fs::read_to_string(workspace().join("experiments/scenes/phantom-engine.toml"))
            .unwrap();
    let odd = format!("odd{ATTACK} | x.toml");
    std::fs::write(dir.path().join("plain.toml"), &scene_text).unwrap();
    std::fs::write(
        dir.path().join(&odd),
        scene_text.replace("t = 80", "t = 40"),
    )
    .unwrap();
    let experiment = dir.path().join("escape.toml");
    std::fs::write(
        &experiment,
        format!(
            "name = \"escape\"\ndescription = '''Renders `iterations` maps. {ATTACK}'''\n\
             scene = \"plain.toml\"\n[set]\n\"volume.phantom.resolution\" = [16, 16, 16]\n\
             \"camera.resolution\" = [12, 12]\n\"integrator.volume_photons\" = 500\n\
             \"integrator.stepsize\" = 0.02\n[axes]\nscene = [\"plain.toml\", {}]\n",
            serde_json::to_string(&odd).unwrap()
        ),
    )
    .unwrap();
    let out = dir.path().join("out");
    run_ok(
        sweep()
            .arg("run")
            .arg(&experiment)
            .arg("--output")
            .arg(&out)
            .arg("--quiet"),
    );
    let md = std::fs::read_to_string(out.join("report.md")).unwrap();
    assert!(!md.contains("<img"), "raw HTML in report.md:\n{md}");
    assert!(
        md.contains("`iterations`"),
        "the description's Markdown was lost:\n{md}"
    );
    assert!(md.contains("&lt;img src=x onerror=alert(1)&gt;"), "{md}");
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    assert!(!html.contains("<img src=x"), "live HTML in report.html");
}

/// A scene an experiment names is read inside the experiment's folder: a symbolic link
/// there (`scenes -> /somewhere/else`) may not carry the name out of it, as the files a
/// scene names may not leave the scene's folder. A name whose text leads out
/// (`../elsewhere/plain.toml`) is the author's choice and is read.
#[test]
fn a_scene_an_experiment_names_is_confined_to_its_folder() {
    let dir = tempfile::tempdir().unwrap();
    let scene_text =
        std::fs::read_to_string(workspace().join("experiments/scenes/phantom-engine.toml"))
            .unwrap();
    let (study, elsewhere) = (dir.path().join("study"), dir.path().join("elsewhere"));
    std::fs::create_dir_all(&study).unwrap();
    std::fs::create_dir_all(&elsewhere).unwrap();
    std::fs::write(elsewhere.join("plain.toml"), &scene_text).unwrap();
    std::os::unix::fs::symlink(&elsewhere, study.join("scenes")).unwrap();
    let experiment = |scene: &str| {
        let path = study.join("linked.toml");
        std::fs::write(
            &path,
            format!(
                "name = \"linked\"\nscene = \"{scene}\"\n[set]\n\"volume.phantom.resolution\" = [16, 16, 16]\n\
                 \"camera.resolution\" = [12, 12]\n[axes]\n\"integrator.nused\" = [25, 50]\n"
            ),
        )
        .unwrap();
        path
    };
    let out = output_within(sweep().arg("plan").arg(experiment("scenes/plain.toml")), 30);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "a linked scene was read: {stderr}");
    for word in [
        "scenes/plain.toml",
        "leads out of the experiment's folder",
        "linked.toml",
    ] {
        assert!(stderr.contains(word), "{stderr:?} lacks {word:?}");
    }
    run_ok(
        sweep()
            .arg("plan")
            .arg(experiment("../elsewhere/plain.toml")),
    );
}
