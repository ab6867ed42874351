//! The sweep's import structure as CONTRIBUTING.md states it: no circle of imports between
//! any two of its files, each stage importing only the stages below it (store → analyse →
//! plan → render → report), and the render loop and the report never reaching into the
//! backends (the `run` verb builds the report; shared helpers such as `compress_ranges`
//! live in leaves). The checker is the core's (`crates/core/tests/it/architecture/check.rs`),
//! whose tests feed it every form of import.

#[path = "../../../core/tests/it/architecture/check.rs"]
mod check;

use std::path::{Path, PathBuf};

use check::{
    Graph, assert_no_circle, assert_stage_order, code, map_mismatches, section, source_graph,
};

/// The sweep's stages, lowest first: a stage's files may import only the stages before it.
/// The store knows no stage; the metrics (`analyse`) are what a plan may name and what a
/// render measures, so they sit below both; the drivers (`commands`, `backend`, `tune`,
/// `bench`, `cost`, `claims`) stand on all of them.
const SWEEP_LAYERS: [&str; 5] = ["store", "analyse", "plan", "render", "report"];

fn workspace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn sweep_graph() -> Graph {
    source_graph(&workspace().join("crates/sweep/src"))
}

#[test]
fn the_sweep_has_no_import_circle() {
    assert_no_circle(&sweep_graph());
}

#[test]
fn each_sweep_stage_imports_only_the_stages_below_it() {
    assert_stage_order(&sweep_graph(), &SWEEP_LAYERS);
}

/// CONTRIBUTING.md's map of the binary names every module of the tree, and nothing that
/// is not there (`commands/` holds one module per verb).
#[test]
fn the_map_of_the_binary_matches_the_tree() {
    let contributing = std::fs::read_to_string(workspace().join("CONTRIBUTING.md")).unwrap();
    let map = section(&contributing, "### The binary");
    let found = map_mismatches(
        &workspace().join("crates/sweep/src"),
        map,
        &[],
        &["commands"],
    );
    assert!(
        found.is_empty(),
        "CONTRIBUTING.md, The binary:\n{}",
        found.join("\n")
    );
}

#[test]
fn render_and_report_never_reach_into_the_backends() {
    let src = workspace().join("crates/sweep/src");
    let mut offenders = Vec::new();
    for folder in ["render", "report"] {
        for entry in walk(&src.join(folder)) {
            if code(&std::fs::read_to_string(&entry).unwrap()).contains("crate::backend") {
                offenders.push(entry.display().to_string());
            }
        }
    }
    for entry in walk(&src.join("backend")) {
        if code(&std::fs::read_to_string(&entry).unwrap()).contains("build_report") {
            offenders.push(format!("{} (builds the report)", entry.display()));
        }
    }
    assert!(offenders.is_empty(), "{offenders:#?}");
}

fn walk(folder: &Path) -> Vec<PathBuf> {
    let mut files = Vec::new();
    for entry in std::fs::read_dir(folder).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            files.extend(walk(&path));
        } else if path.extension().is_some_and(|e| e == "rs") {
            files.push(path);
        }
    }
    files
}
