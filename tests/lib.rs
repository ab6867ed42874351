//! Helpers for the end-to-end tests: locating the `sweep` binary, the workspace, and data.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// The workspace root.
pub fn workspace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("tests/ has a parent")
        .to_path_buf()
}

/// Copies what git tracks under `folder` of the workspace into `dest` (same relative
/// paths): what a fresh clone holds there. Returns the copied paths, or `None` when git
/// lists nothing (not a checkout, or git missing).
pub fn copy_tracked(folder: &str, dest: &Path) -> Option<Vec<PathBuf>> {
    let out = Command::new("git")
        .args(["ls-files", "-z", folder])
        .current_dir(workspace())
        .output()
        .ok()
        .filter(|o| o.status.success())?;
    let files: Vec<PathBuf> = out
        .stdout
        .split(|b| *b == 0)
        .filter(|f| !f.is_empty())
        .map(|f| PathBuf::from(std::str::from_utf8(f).expect("a UTF-8 path")))
        .collect();
    if files.is_empty() {
        return None;
    }
    for rel in &files {
        let to = dest.join(rel);
        std::fs::create_dir_all(to.parent().expect("a file has a folder")).unwrap();
        std::fs::copy(workspace().join(rel), &to).unwrap();
    }
    Some(files)
}

/// The `sweep` binary built by this `cargo test` run (same profile as the tests), or
/// `$VOLPHOT_SWEEP_BIN`.
pub fn sweep_bin() -> PathBuf {
    if let Some(p) = std::env::var_os("VOLPHOT_SWEEP_BIN") {
        return PathBuf::from(p);
    }
    // target/<profile>/deps/<test> → target/<profile>/sweep
    let exe = std::env::current_exe().expect("test executable path");
    let dir = exe
        .parent()
        .and_then(Path::parent)
        .expect("target/<profile>");
    let bin = dir.join("sweep");
    assert!(
        bin.is_file(),
        "{} not found: build it with `cargo build -p volphot-sweep` (cargo test --workspace builds it) or set VOLPHOT_SWEEP_BIN",
        bin.display()
    );
    bin
}

/// A `sweep` command run from the workspace root, with the data search path set.
pub fn sweep() -> Command {
    let mut c = Command::new(sweep_bin());
    c.current_dir(workspace());
    c
}

/// Runs and returns the output, panicking with both streams when the exit status differs.
pub fn run_ok(cmd: &mut Command) -> Output {
    let out = cmd.output().expect("sweep runs");
    assert!(
        out.status.success(),
        "{cmd:?} failed ({}):\nstdout:\n{}\nstderr:\n{}",
        out.status,
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

pub use volphot::test_util::{real_data_dir as data_dir, skip};

/// Writes `dir/<name>.toml`: an experiment called `name` on the scene preset
/// `experiments/scenes/<scene>`, followed by `tables` (its `[set]`, `[axes]`, … tables).
pub fn write_experiment(dir: &Path, name: &str, scene: &str, tables: &str) -> PathBuf {
    let scene = workspace().join("experiments/scenes").join(scene);
    let path = dir.join(format!("{name}.toml"));
    let text = format!(
        "name = \"{name}\"\nscene = \"{}\"\n{tables}\n",
        scene.display()
    );
    std::fs::write(&path, text).expect("experiment file written");
    path
}

/// A CSV file's header and rows.
pub fn read_csv(path: &Path) -> (Vec<String>, Vec<Vec<String>>) {
    let mut r =
        csv::Reader::from_path(path).unwrap_or_else(|e| panic!("reading {}: {e}", path.display()));
    let headers = r
        .headers()
        .expect("CSV header")
        .iter()
        .map(str::to_string)
        .collect();
    let rows = r
        .records()
        .map(|rec| rec.expect("CSV row").iter().map(str::to_string).collect())
        .collect();
    (headers, rows)
}
