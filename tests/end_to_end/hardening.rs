//! The fourth reliability round: the newest verbs (`claims`, `index`, `--update`), the
//! published HTML and the remaining loose inputs, each case through the real `sweep` as a
//! new user — or a hostile contributor — would meet it. Each test names its case.

use std::os::unix::fs::PermissionsExt as _;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use volphot_tests::{run_ok, sweep, workspace, write_experiment};

use crate::reliability::output_within;

fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// `sweep claims ARGS` run from `dir`, killed after 30 s.
fn claims_in(dir: &Path, args: &[&str]) -> Output {
    let mut c = Command::new(volphot_tests::sweep_bin());
    c.current_dir(dir).arg("claims").args(args);
    output_within(&mut c, 30)
}

/// A folder with a small study `s` and a document `doc.md` holding `text`.
fn document(text: &str) -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let study = dir.path().join("docs").join("s");
    std::fs::create_dir_all(&study).unwrap();
    std::fs::write(
        study.join("cells.csv"),
        "cell,nused,seed,rmse [1]\n0,25,1,0.0312\n1,150,1,0.0125\n",
    )
    .unwrap();
    let doc = dir.path().join("docs").join("doc.md");
    std::fs::write(&doc, text).unwrap();
    (dir, doc)
}

/// Case 1: a document read files outside its folder and printed their values.
#[test]
fn claims_read_only_inside_the_documents_folder_and_quote_no_values() {
    let (dir, doc) = document("");
    std::fs::write(
        dir.path().join("id_ed25519.csv"),
        "k,v\nkey,-----BEGIN OPENSSH PRIVATE KEY-----\n",
    )
    .unwrap();
    std::os::unix::fs::symlink(dir.path(), dir.path().join("docs").join("up")).unwrap();
    std::fs::write(
        dir.path().join("docs").join("auth.json"),
        r#"{"auth": {"token": "ghp_secret_token_value"}}"#,
    )
    .unwrap();
    std::fs::write(
        dir.path().join("docs").join("pw.csv"),
        "user,password\nroot,correct-horse-battery\n",
    )
    .unwrap();
    std::fs::write(
        &doc,
        "a 1<!-- = value(../id_ed25519.csv: v) --> b 2<!-- = value(/etc/passwd: x) -->\n\
         c 3<!-- = value(up/id_ed25519.csv: v) --> d 4<!-- = value(auth.json: auth) -->\n\
         e 5<!-- = value(pw.csv: password) --> f 6<!-- = value(auth.json: auth.token) -->\n",
    )
    .unwrap();
    let out = claims_in(dir.path(), &["docs/doc.md"]);
    let text = stdout(&out) + &stderr(&out);
    assert!(!out.status.success(), "{text}");
    for secret in ["OPENSSH", "ghp_secret", "correct-horse", "root:x"] {
        assert!(!text.contains(secret), "`{secret}` printed:\n{text}");
    }
    assert_eq!(text.matches("leads outside").count(), 2, "{text}");
    assert!(text.contains("must be a relative path"), "{text}");
}

/// Case 5: `--update` rewrote CRLF, replaced a link by a file, dropped the mode.
#[test]
fn update_keeps_line_endings_the_link_and_the_mode() {
    let (dir, doc) = document("");
    let real = dir.path().join("docs").join("real.md");
    std::fs::write(
        &real,
        "RMSE 0.0321<!-- = value(s: rmse where nused=25) -->\r\nnext line\r\n",
    )
    .unwrap();
    std::fs::set_permissions(&real, std::fs::Permissions::from_mode(0o444)).unwrap();
    std::fs::remove_file(&doc).unwrap();
    std::os::unix::fs::symlink("real.md", &doc).unwrap();
    let out = claims_in(dir.path(), &["--update", "docs/doc.md"]);
    assert!(out.status.success(), "{}", stdout(&out));
    assert!(
        std::fs::symlink_metadata(&doc)
            .unwrap()
            .file_type()
            .is_symlink()
    );
    assert_eq!(
        std::fs::read_to_string(&real).unwrap(),
        "RMSE 0.0312<!-- = value(s: rmse where nused=25) -->\r\nnext line\r\n"
    );
    let mode = std::fs::metadata(&real).unwrap().permissions().mode() & 0o777;
    assert_eq!(mode, 0o444);
}

/// Cases 7 and 10: deep or long queries overflowed the stack; `1e400` agreed with 5.
#[test]
fn deep_queries_and_numbers_beyond_a_double_are_errors() {
    let deep = format!("{}1{}", "(".repeat(20_000), ")".repeat(20_000));
    let minus = format!("{}1", "-".repeat(200_000));
    let sum = vec!["1"; 200_000].join("+");
    let (dir, _) = document(&format!(
        "a 1<!-- = {deep} --> b 1<!-- = {minus} -->\nc 1<!-- = {sum} -->\n\
         d 1e400<!-- = 5 --> e 1e-400<!-- = 0 --> f 2·10⁻¹⁰⁹⁷²⁶²⁵⁷²<!-- = 0 -->\n"
    ));
    let out = claims_in(dir.path(), &["docs/doc.md"]);
    assert_eq!(out.status.code(), Some(1), "{}", stderr(&out));
    let text = stdout(&out);
    assert!(text.contains("6 cannot be checked"), "{text}");
    let out = claims_in(dir.path(), &["--update", "docs/doc.md"]);
    assert_eq!(out.status.code(), Some(1), "{}", stderr(&out));
    let after = std::fs::read_to_string(dir.path().join("docs/doc.md")).unwrap();
    assert!(
        !after.contains("inf"),
        "--update wrote an infinity: {after}"
    );
}

/// Case 9: a FIFO, `/dev/zero` or a sparse 3 GiB file as a source hung or allocated.
#[test]
fn fifos_devices_and_huge_sources_fail_at_once() {
    let (dir, _) = document(
        "a 1<!-- = value(fifo.csv: v) --> b 1<!-- = value(sparse.csv: v) -->\n\
         c 1<!-- = value(zero.csv: v) -->\n",
    );
    let docs = dir.path().join("docs");
    assert!(
        Command::new("mkfifo")
            .arg(docs.join("fifo.csv"))
            .status()
            .unwrap()
            .success()
    );
    std::fs::File::create(docs.join("sparse.csv"))
        .unwrap()
        .set_len(3 << 30)
        .unwrap();
    std::os::unix::fs::symlink("/dev/zero", docs.join("zero.csv")).unwrap();
    let out = claims_in(dir.path(), &["docs/doc.md"]);
    let text = stdout(&out);
    assert!(text.contains("FIFO"), "{text}");
    assert!(text.contains("more than the 16 MiB"), "{text}");
    assert!(text.contains("leads outside"), "{text}");
}

/// Case 11: a claim typo, an unclosed claim, and a document without claims passed.
#[test]
fn malformed_claims_and_empty_documents_fail() {
    let (dir, doc) =
        document("x 1<!-- value(s: rmse where nused=25) --> y 2<!-- = count(s: cell)\n");
    let out = claims_in(dir.path(), &["docs/doc.md"]);
    assert_eq!(out.status.code(), Some(1));
    let text = stdout(&out);
    assert!(text.contains("reads like a claim"), "{text}");
    assert!(text.contains("never closed"), "{text}");
    std::fs::write(&doc, "no numbers cited\n").unwrap();
    let out = claims_in(dir.path(), &["docs/doc.md"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(stderr(&out).contains("no claims"), "{}", stderr(&out));
    let out = claims_in(dir.path(), &["--allow-empty", "docs/doc.md"]);
    assert!(out.status.success(), "{}", stderr(&out));
}

/// Case 6: another experiment file of the same name replaced a committed study.
#[test]
fn another_experiment_of_the_same_name_cannot_take_a_study_folder() {
    let dir = tempfile::tempdir().unwrap();
    let copy = dir.path().join("quickstart");
    volphot_tests::copy_tracked("reports/quickstart", dir.path()).expect("a checkout");
    let copy_src = dir.path().join("reports/quickstart");
    std::fs::rename(&copy_src, &copy).unwrap();
    let before: Vec<(PathBuf, Vec<u8>)> = walk(&copy);
    let exp = write_experiment(
        dir.path(),
        "quickstart",
        "phantom-engine.toml",
        "[set]\n\"camera.resolution\" = [16, 16]\n",
    );
    let out = output_within(
        sweep()
            .arg("run")
            .arg(&exp)
            .arg("-o")
            .arg(&copy)
            .arg("--quiet"),
        120,
    );
    assert!(!out.status.success());
    assert!(
        stderr(&out).contains("another file with other content"),
        "{}",
        stderr(&out)
    );
    assert_eq!(walk(&copy), before, "the study folder changed");
}

fn walk(dir: &Path) -> Vec<(PathBuf, Vec<u8>)> {
    let mut files = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(d).unwrap().flatten() {
            let p = e.path();
            if p.is_dir() {
                stack.push(p);
            } else if !p.file_name().unwrap().to_string_lossy().starts_with('.') {
                files.push((p.clone(), std::fs::read(&p).unwrap()));
            }
        }
    }
    files.sort();
    files
}

/// A one-cell scene render's stderr, with `integrator` lines added.
fn render_warnings(integrator: &str) -> String {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("s.toml");
    std::fs::write(
        &scene,
        format!(
            "[volume]\nphantom = {{ name = \"engine\", resolution = [24, 24, 24] }}\n[sigma]\nt = 80\n\
             [camera]\nresolution = [16, 16]\n[three_point]\n[integrator]\nstepsize = 0.01\n{integrator}\n"
        ),
    )
    .unwrap();
    let out = run_ok(
        sweep()
            .arg("render")
            .arg(&scene)
            .arg("-o")
            .arg(dir.path().join("o"))
            .arg("--quiet"),
    );
    stderr(&out)
}

/// Case 12: warnings advised past the photon limit, named the wrong key, warned planes
/// about nused, and kept silent over a black multiple-scattering layer.
#[test]
fn render_warnings_name_the_key_that_sets_the_photons() {
    let text = render_warnings(
        "estimator = \"progressive\"\nphotons_per_iteration = 10\niterations = 2\nvolume_photons = 4000000\nseed = 3",
    );
    assert!(text.contains("photons_per_iteration"), "{text}");
    assert!(!text.contains("volume_photons ≥"), "{text}");
    let text = render_warnings("estimator = \"plane\"\nvolume_photons = 100");
    assert!(!text.contains("nused"), "{text}");
    let text = render_warnings("maxdist = 1e-30");
    assert!(text.contains("raise maxdist"), "{text}");
}

/// Case 13: an axis the estimator ignores rendered one image under four addresses.
#[test]
fn an_axis_the_estimator_ignores_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let exp = write_experiment(
        dir.path(),
        "ignored",
        "phantom-engine.toml",
        "[axes]\n\"integrator.eye_rays\" = [\"replayed\", \"fresh\"]\n\"integrator.radius\" = [\"global\", \"nearest\"]\n",
    );
    let out = sweep().arg("plan").arg(&exp).output().unwrap();
    assert!(!out.status.success());
    assert!(
        stderr(&out).contains("no cell reads it (with estimator = \"points\")"),
        "{}",
        stderr(&out)
    );
    let exp = write_experiment(
        dir.path(),
        "set",
        "phantom-engine.toml",
        "[set]\n\"integrator.alpha\" = 0.5\n\"camera.resolution\" = [8, 8]\n[axes]\n\"sigma.t\" = [20, 60]\n",
    );
    let out = run_ok(sweep().arg("plan").arg(&exp).arg("--no-pilot"));
    assert!(
        stderr(&out).contains("`integrator.alpha` is set, but no cell reads it"),
        "{}",
        stderr(&out)
    );
}

/// Case 14: `bench --threads 0` ran on every core where `run --threads 0` was refused.
#[test]
fn every_verb_takes_the_same_thread_counts() {
    for verb in [
        &["bench", "--quick"][..],
        &["render", "x.toml", "-o", "o"],
        &["run", "x.toml"],
        &["plan", "x.toml"],
        &["tune", "x.toml"],
    ] {
        for n in ["0", "100000"] {
            let out = sweep().args(verb).args(["--threads", n]).output().unwrap();
            assert_eq!(out.status.code(), Some(2), "{verb:?} --threads {n}");
            assert!(
                stderr(&out).contains("expected a number of worker threads in 1..=1024"),
                "{verb:?} --threads {n}: {}",
                stderr(&out)
            );
        }
    }
}

/// The unclear ones: each error names the key or flag, the value and the fix, before any
/// work is done.
#[test]
fn loose_inputs_get_errors_that_name_them_before_work() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("af");
    std::fs::write(&file, "").unwrap();
    let cases: Vec<(Vec<String>, &str)> = vec![
        (
            vec![
                "bench".into(),
                "--quick".into(),
                "--json".into(),
                format!("{}/x.json", file.display()),
            ],
            "is a file, so no folder can be made below it",
        ),
        (
            vec![
                "bench".into(),
                "--reference".into(),
                "--reference-pool".into(),
                file.display().to_string(),
            ],
            "is a file; expected a folder",
        ),
        (
            vec![
                "bench".into(),
                "--peer".into(),
                "mitsuba".into(),
                "--peer-spp".into(),
                "0".into(),
            ],
            "0 is not in 1..=65536",
        ),
        (
            vec![
                "bench".into(),
                "--quick".into(),
                "--sigma-t".into(),
                "1e39".into(),
            ],
            "`1e39`: expected a finite σt(d_min) > 0",
        ),
        (
            vec![
                "run".into(),
                "experiments/quickstart.toml".into(),
                "-o".into(),
                file.display().to_string(),
            ],
            "is a file; expected a folder",
        ),
    ];
    for (args, says) in cases {
        let out = output_within(sweep().args(&args), 20);
        assert!(!out.status.success(), "{args:?}");
        assert!(stderr(&out).contains(says), "{args:?}: {}", stderr(&out));
    }
    let scene = dir.path().join("bright.toml");
    std::fs::write(
        &scene,
        "[volume]\nphantom = { name = \"sphere\", resolution = [8, 8, 8] }\n[sigma]\nt = 10\n[camera]\nresolution = [8, 8]\n[three_point]\nkey_intensity = 3e38\n",
    )
    .unwrap();
    let out = sweep()
        .arg("render")
        .arg(&scene)
        .arg("-o")
        .arg(dir.path().join("o"))
        .output()
        .unwrap();
    assert!(
        stderr(&out).contains("key_intensity") && stderr(&out).contains("at most 1e20"),
        "{}",
        stderr(&out)
    );
    std::fs::write(
        &scene,
        "[volume]\nphantom = { name = \"sphere\", resolution = [8, 8, 8] }\n[sigma]\nt = 1e39\n",
    )
    .unwrap();
    let out = sweep()
        .arg("render")
        .arg(&scene)
        .arg("-o")
        .arg(dir.path().join("o"))
        .output()
        .unwrap();
    assert!(
        stderr(&out).contains("`sigma.t` = 1e39 is beyond what a 32-bit float holds"),
        "{}",
        stderr(&out)
    );
    let exp = write_experiment(
        dir.path(),
        "zero",
        "phantom-engine.toml",
        "[report]\nexplorer_max_side = 0\n",
    );
    let out = sweep().arg("plan").arg(&exp).output().unwrap();
    assert!(
        stderr(&out).contains("`report.explorer_max_side` = 0"),
        "{}",
        stderr(&out)
    );
}

/// "Also": the binary found its scripts and default scenes through the folder it was built
/// in. A copy elsewhere names what it looked for.
#[test]
fn a_copied_binary_does_not_reach_the_build_folder() {
    let dir = tempfile::tempdir().unwrap();
    let copy = dir.path().join("sweep");
    std::fs::copy(volphot_tests::sweep_bin(), &copy).unwrap();
    let out = Command::new(&copy)
        .current_dir(dir.path())
        .args(["bench", "--quick", "--runs", "1"])
        .output()
        .unwrap();
    assert!(!out.status.success());
    let text = stderr(&out);
    assert!(
        text.contains("neither in the working folder nor in a checkout that holds this binary"),
        "{text}"
    );
    assert!(
        !text.contains(&workspace().display().to_string()),
        "the copy looked in the build folder: {text}"
    );
}

/// "Also": one study with a broken `plan.json` failed the whole index.
#[test]
fn the_index_skips_a_broken_study_and_names_it() {
    let dir = tempfile::tempdir().unwrap();
    volphot_tests::copy_tracked("reports/quickstart", dir.path()).expect("a checkout");
    volphot_tests::copy_tracked("reports/cost", dir.path()).expect("a checkout");
    let reports = dir.path().join("reports");
    std::fs::write(reports.join("cost").join("plan.json"), "{broken").unwrap();
    let out = run_ok(sweep().arg("index").arg(&reports));
    assert!(stderr(&out).contains("skipped cost"), "{}", stderr(&out));
    let html = std::fs::read_to_string(reports.join("index.html")).unwrap();
    assert!(html.contains("./quickstart/report.html"), "{html}");
}
