//! The fifth reliability round, the `sweep` binary's part: a committed study or bench is
//! never replaced by a verb that did not make it, an axis the renderer ignores is refused,
//! the peer's images are checked before they are compared, a report inlines no file from
//! outside its folder, and arguments are read before any work. Each test names its row.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use volphot_tests::{run_ok, sweep, sweep_bin, workspace, write_experiment};

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// A scene that renders in a moment: a 16³ sphere under the three-point spots, 16².
const TINY: &str = r#"[volume]
phantom = { name = "sphere", resolution = [16, 16, 16] }
[sigma]
t = 20
[camera]
resolution = [16, 16]
[three_point]
[integrator]
volume_photons = 1000
stepsize = 0.02
"#;

/// `TINY` written as `dir/NAME.toml`.
fn tiny_scene(dir: &Path, name: &str) -> PathBuf {
    let path = dir.join(format!("{name}.toml"));
    std::fs::write(&path, TINY).unwrap();
    path
}

/// Runs `sweep ARGS` from `dir` and expects it to fail; its stderr.
fn refused<S: AsRef<std::ffi::OsStr> + std::fmt::Debug>(dir: &Path, args: &[S]) -> String {
    let out = sweep().current_dir(dir).args(args).output().unwrap();
    assert!(
        !out.status.success(),
        "sweep {args:?} should have been refused: {}",
        stderr(&out)
    );
    stderr(&out)
}

/// Row 6: `sweep render cells.toml -o STUDY` (or a scene named `plan`) silently replaced a
/// committed study's `cells.json` / `plan.json`; then `sweep status` failed on the study.
#[test]
fn render_never_replaces_a_file_it_did_not_make() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let study = d.join("study");
    std::fs::create_dir_all(&study).unwrap();
    for file in ["plan.json", "cells.json"] {
        std::fs::copy(
            workspace().join("reports/quickstart").join(file),
            study.join(file),
        )
        .unwrap();
    }
    let before: Vec<Vec<u8>> = ["plan.json", "cells.json"]
        .iter()
        .map(|f| std::fs::read(study.join(f)).unwrap())
        .collect();
    for name in ["cells", "plan"] {
        tiny_scene(d, name);
        let scene = format!("{name}.toml");
        let err = refused(d, &["render", &scene, "-o", "study", "--quiet"]);
        assert!(
            err.contains("--force") && err.contains("study"),
            "{name}: {err}"
        );
    }
    let after: Vec<Vec<u8>> = ["plan.json", "cells.json"]
        .iter()
        .map(|f| std::fs::read(study.join(f)).unwrap())
        .collect();
    assert!(before == after, "the study's records changed");
    // Outside a study, a scene named `plan` renders, and renders again over its own files.
    for _ in 0..2 {
        run_ok(
            sweep()
                .current_dir(d)
                .args(["render", "plan.toml", "-o", "own", "--quiet"]),
        );
    }
    assert!(d.join("own/plan.exr").is_file());
    // A picture of the user's in the way is named, and replaced only with --force.
    std::fs::create_dir_all(d.join("pictures")).unwrap();
    std::fs::write(d.join("pictures/cells.png"), "mine").unwrap();
    let err = refused(d, &["render", "cells.toml", "-o", "pictures", "--quiet"]);
    assert!(
        err.contains("cells.png") && err.contains("--force"),
        "{err}"
    );
    assert_eq!(
        std::fs::read(d.join("pictures/cells.png")).unwrap(),
        b"mine"
    );
    run_ok(sweep().current_dir(d).args([
        "render",
        "cells.toml",
        "-o",
        "pictures",
        "--force",
        "--quiet",
    ]));
    assert_ne!(
        std::fs::read(d.join("pictures/cells.png")).unwrap(),
        b"mine"
    );
}

/// Row 7: `sweep bench … --json reports/bench/headline.json` on a 16² scene replaced the
/// committed headline bench with another scene's without a word.
#[test]
fn bench_json_is_replaced_only_by_the_same_bench() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::create_dir_all(d.join("bench")).unwrap();
    let headline = d.join("bench/headline.json");
    std::fs::copy(workspace().join("reports/bench/headline.json"), &headline).unwrap();
    let committed = std::fs::read(&headline).unwrap();
    tiny_scene(d, "tiny");
    let bench = |extra: &[&str], json: &str| -> Vec<String> {
        let mut args: Vec<String> = ["bench", "--scene", "tiny.toml", "--only", "marched"]
            .iter()
            .map(|s| s.to_string())
            .collect();
        args.extend(extra.iter().map(|s| s.to_string()));
        args.extend(["--json".to_string(), json.to_string()]);
        args
    };
    let err = refused(d, &bench(&[], "bench/headline.json"));
    assert!(
        err.contains("--json bench/headline.json")
            && err.contains("scene tiny.toml here, foot.toml there")
            && err.contains("--force"),
        "{err}"
    );
    assert_eq!(std::fs::read(&headline).unwrap(), committed);
    // The same bench measured again replaces its own file; another size does not.
    let run = |extra: &[&str]| {
        let args = bench(extra, "bench/tiny.json");
        sweep().current_dir(d).args(&args).output().unwrap()
    };
    assert!(run(&[]).status.success());
    assert!(run(&["--runs", "2"]).status.success());
    let other = run(&["--resolution", "8x8"]);
    assert!(
        !other.status.success() && stderr(&other).contains("resolution"),
        "{}",
        stderr(&other)
    );
    assert!(run(&["--resolution", "8x8", "--force"]).status.success());
    // A file `sweep bench` did not write is refused too.
    std::fs::write(d.join("bench/notes.json"), "{\"mine\": 1}").unwrap();
    let err = refused(d, &bench(&[], "bench/notes.json"));
    assert!(err.contains("did not write it"), "{err}");
    assert_eq!(
        std::fs::read_to_string(d.join("bench/notes.json")).unwrap(),
        "{\"mine\": 1}"
    );
}

/// Row 14: `integrator.light_samples = [1, 4]` on a scene of spots only gave two addresses
/// of byte-identical images, and the report credited timing noise to the axis.
#[test]
fn an_axis_of_light_samples_under_spot_lights_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let axis = "[axes]\n\"integrator.light_samples\" = [1, 4]\n";
    let spots = write_experiment(dir.path(), "spots", "phantom-engine.toml", axis);
    let out = sweep().arg("plan").arg(&spots).output().unwrap();
    let err = stderr(&out);
    assert!(
        !out.status.success() && err.contains("light_samples") && err.contains("spot"),
        "{err}"
    );
    // Under the cinematic lights (an area key light and a sky) it is read, and planned.
    let cinematic = write_experiment(
        dir.path(),
        "cinematic",
        "phantom-engine.toml",
        &format!("[set]\n\"three_point.style\" = \"cinematic\"\n{axis}"),
    );
    run_ok(sweep().arg("plan").arg(&cinematic));
}

/// Row 15: the peer's Python returned an 8 × 4 image for a 16 × 16 render, and it was
/// compared anyway ("136884× Mitsuba's efficiency").
#[test]
fn a_peer_image_of_another_size_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    tiny_scene(d, "tiny");
    // A stand-in for Mitsuba's Python: every render it is asked for, as an 8 × 4 PFM.
    let fake = d.join("fake-python");
    std::fs::write(
        &fake,
        r#"#!/bin/sh
out=""; spp=""; seeds=""
while [ $# -gt 0 ]; do
  case "$1" in --out) out=$2; shift;; --spp) spp=$2; shift;; --seeds) seeds=$2; shift;; esac
  shift
done
mkdir -p "$out"
for d in 2 -1; do for s in $(echo "$spp" | tr , ' '); do i=0; while [ $i -lt "$seeds" ]; do
  f="$out/m$d-$s-$i.pfm"
  { printf 'PF\n8 4\n-1.0\n'; n=0; while [ $n -lt 96 ]; do printf '\000\000\000\077'; n=$((n+1)); done; } > "$f"
  echo "{\"max_depth\": $d, \"spp\": $s, \"seed\": $i, \"file\": \"$f\", \"cpu_s\": 0.001, \"variant\": \"scalar_rgb\", \"mitsuba\": \"3.9.1\"}"
  i=$((i+1)); done; done; done
"#,
    )
    .unwrap();
    use std::os::unix::fs::PermissionsExt as _;
    std::fs::set_permissions(&fake, std::fs::Permissions::from_mode(0o755)).unwrap();
    let err = refused(
        d,
        &[
            "bench",
            "--peer",
            "mitsuba",
            "--scene",
            "tiny.toml",
            "--python",
            fake.to_str().unwrap(),
            "--peer-spp",
            "1",
            "--seeds",
            "2",
            "--reference-passes",
            "2",
        ],
    );
    assert!(
        err.contains("8×4") && err.contains("16×16"),
        "the error names both sizes: {err}"
    );
}

/// A report inlined every image its Markdown named as a lone paragraph, wherever it was:
/// a description's `![x](/home/…/secret)` put that file into `report.html` as base64.
#[test]
fn a_report_inlines_no_file_from_outside_its_folder() {
    use base64::Engine as _;
    let dir = tempfile::tempdir().unwrap();
    let secret = dir.path().join("secret.png");
    let content = b"SECRET-CONTENT-0123456789-not-a-figure";
    std::fs::write(&secret, content).unwrap();
    let description = format!(
        "A study.\n\n![absolute]({})\n\n![up](../secret.png)\n",
        secret.display()
    );
    let exp = write_experiment(
        dir.path(),
        "leak",
        "phantom-engine.toml",
        &format!(
            "description = {description:?}\n[set]\n\"volume.phantom.resolution\" = [16, 16, 16]\n\"camera.resolution\" = [16, 16]\n\"integrator.volume_photons\" = 1000\n\"integrator.stepsize\" = 0.01\n[axes]\n\"sigma.t\" = [20, 60]\n"
        ),
    );
    let out = dir.path().join("out");
    run_ok(
        sweep()
            .arg("run")
            .arg(&exp)
            .arg("-o")
            .arg(&out)
            .arg("--quiet"),
    );
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    let encoded = base64::engine::general_purpose::STANDARD.encode(content);
    assert!(
        !html.contains(&encoded[..24]),
        "the secret file was inlined into report.html"
    );
}

/// Row 21: `--threads -1` said "unexpected argument '-1'", not naming `--threads`; so did
/// every numeric option given a negative number.
#[test]
fn a_negative_number_is_refused_by_its_option() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    tiny_scene(d, "tiny");
    let exp = write_experiment(
        d,
        "e",
        "phantom-engine.toml",
        "[axes]\n\"sigma.t\" = [20, 60]\n",
    );
    let exp = exp.to_str().unwrap();
    for (args, option, expected) in [
        (
            vec!["render", "tiny.toml", "--threads", "-1"],
            "--threads",
            "1..=1024",
        ),
        (vec!["render", "tiny.toml", "--seed", "-3"], "--seed", ""),
        (vec!["run", exp, "--threads", "-1"], "--threads", "1..=1024"),
        (vec!["run", exp, "--jobs", "-2"], "--jobs", ""),
        (vec![exp, "--jobs", "-2"], "--jobs", ""),
        (vec!["bench", "--runs", "-1"], "--runs", ""),
        (vec!["bench", "--sigma-t", "-6"], "--sigma-t", "σt"),
        (
            vec!["tune", exp, "--threads", "-4"],
            "--threads",
            "1..=1024",
        ),
    ] {
        let err = refused(d, &args);
        assert!(
            err.contains(option) && err.contains(expected) && !err.contains("unexpected argument"),
            "{args:?}: {err}"
        );
    }
}

/// Row 20: `scripts/peer_offset.py nope.xml` (or `--translate a,b`) ended in a traceback
/// about `drjit` before its arguments were read, and `scripts/peer-mitsuba.sh` with a
/// missing scene installed Mitsuba (and, as root, a Debian package) before it looked.
#[test]
fn the_peer_scripts_read_their_arguments_first() {
    let python_here = Command::new("python3")
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success());
    if !python_here {
        volphot::test_util::skip(
            "the_peer_scripts_read_their_arguments_first",
            "no python3 on the PATH",
        );
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let scene = d.join("scene.xml");
    std::fs::write(&scene, "<scene version=\"3.0.0\"/>").unwrap();
    let scripts = workspace().join("scripts");
    let cases: [(&str, Vec<&str>, &str); 5] = [
        ("peer_offset.py", vec!["nope.xml"], "nope.xml"),
        (
            "peer_offset.py",
            vec!["scene.xml", "--translate", "a,b"],
            "--translate",
        ),
        (
            "peer_offset.py",
            vec!["scene.xml", "--seeds", "1"],
            "--seeds",
        ),
        (
            "peer_mitsuba.py",
            vec!["nope.xml", "--out", "o"],
            "nope.xml",
        ),
        (
            "peer_mitsuba.py",
            vec!["scene.xml", "--out", "o", "--spp", "4,x"],
            "--spp",
        ),
    ];
    for (script, args, named) in cases {
        let out = Command::new("python3")
            .arg(scripts.join(script))
            .args(&args)
            .current_dir(d)
            .output()
            .unwrap();
        let err = stderr(&out);
        assert!(
            out.status.code() == Some(2) && err.contains(named) && !err.contains("Traceback"),
            "{script} {args:?}: {err}"
        );
    }
    // The shell script: stand-ins for python3 and apt-get note any call.
    let bin = d.join("bin");
    std::fs::create_dir_all(&bin).unwrap();
    for tool in ["python3", "apt-get"] {
        let path = bin.join(tool);
        std::fs::write(
            &path,
            format!(
                "#!/bin/sh\necho called > \"{}/{tool}.called\"\nexit 1\n",
                d.display()
            ),
        )
        .unwrap();
        use std::os::unix::fs::PermissionsExt as _;
        std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o755)).unwrap();
    }
    let path = format!(
        "{}:{}",
        bin.display(),
        std::env::var("PATH").unwrap_or_default()
    );
    let out = Command::new(scripts.join("peer-mitsuba.sh"))
        .arg(d.join("missing.toml"))
        .current_dir(d)
        .env("PATH", path)
        .env("VOLPHOT_PEER_VENV", d.join("venv"))
        .env("VOLPHOT_SWEEP_BIN", sweep_bin())
        .output()
        .unwrap();
    let err = stderr(&out);
    assert!(
        !out.status.success() && err.contains("missing.toml"),
        "{err}"
    );
    for tool in ["python3", "apt-get"] {
        assert!(
            !d.join(format!("{tool}.called")).exists(),
            "{tool} ran before the scene was checked: {err}"
        );
    }
    assert!(!d.join("venv").exists(), "{err}");
}
