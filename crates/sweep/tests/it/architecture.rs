//! The import structure CONTRIBUTING.md and `integrator/mod.rs` describe, held: no circle of
//! imports between the sibling modules of any folder of the renderer's integrators, and in
//! `sweep` the render loop and the report never reach into the backends (the `run` verb
//! builds the report; shared helpers such as `compress_ranges` live in leaves).

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

fn workspace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// A file's code without its tests and without comments.
fn code(path: &Path) -> String {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let before_tests = text.split("#[cfg(test)]").next().unwrap_or("");
    before_tests
        .lines()
        .map(|l| l.split("//").next().unwrap_or(""))
        .collect::<Vec<_>>()
        .join("\n")
}

/// The sibling modules a folder's files import through `super::name`.
fn sibling_imports(folder: &Path) -> BTreeMap<String, BTreeSet<String>> {
    let mut modules = BTreeMap::new();
    for entry in std::fs::read_dir(folder).unwrap() {
        let path = entry.unwrap().path();
        let name = path.file_stem().unwrap().to_string_lossy().into_owned();
        let file = if path.is_dir() {
            path.join("mod.rs")
        } else if path.extension().is_some_and(|e| e == "rs") && name != "mod" {
            path.clone()
        } else {
            continue;
        };
        if file.exists() {
            modules.insert(name, file);
        }
    }
    let names: BTreeSet<String> = modules.keys().cloned().collect();
    modules
        .iter()
        .map(|(name, file)| {
            let text = code(file);
            let used = text
                .match_indices("super::")
                .map(|(i, m)| {
                    text[i + m.len()..]
                        .chars()
                        .take_while(|c| c.is_alphanumeric() || *c == '_')
                        .collect::<String>()
                })
                .filter(|n| names.contains(n) && n != name)
                .collect();
            (name.clone(), used)
        })
        .collect()
}

/// A circle of imports, if there is one, as the modules along it.
fn find_cycle(edges: &BTreeMap<String, BTreeSet<String>>) -> Option<Vec<String>> {
    fn visit(
        node: &str,
        edges: &BTreeMap<String, BTreeSet<String>>,
        state: &mut BTreeMap<String, u8>,
        stack: &mut Vec<String>,
    ) -> Option<Vec<String>> {
        state.insert(node.to_string(), 1);
        stack.push(node.to_string());
        for next in edges.get(node).into_iter().flatten() {
            match state.get(next.as_str()) {
                Some(1) => {
                    let start = stack.iter().position(|n| n == next).unwrap();
                    let mut cycle = stack[start..].to_vec();
                    cycle.push(next.clone());
                    return Some(cycle);
                }
                Some(_) => {}
                None => {
                    if let Some(c) = visit(next, edges, state, stack) {
                        return Some(c);
                    }
                }
            }
        }
        stack.pop();
        state.insert(node.to_string(), 2);
        None
    }
    let mut state = BTreeMap::new();
    for node in edges.keys() {
        if !state.contains_key(node)
            && let Some(c) = visit(node, edges, &mut state, &mut Vec::new())
        {
            return Some(c);
        }
    }
    None
}

#[test]
fn the_cycle_finder_finds_a_circle() {
    let edges: BTreeMap<String, BTreeSet<String>> = [
        ("pass", vec!["marcher"]),
        ("marcher", vec!["eye_ray"]),
        ("eye_ray", vec!["pass"]),
        ("sample", vec![]),
    ]
    .into_iter()
    .map(|(k, v)| (k.to_string(), v.into_iter().map(String::from).collect()))
    .collect();
    assert_eq!(
        find_cycle(&edges).unwrap(),
        ["eye_ray", "pass", "marcher", "eye_ray"]
    );
}

#[test]
fn no_import_circle_inside_the_integrators() {
    let root = workspace().join("crates/core/src/integrator");
    for folder in [root.clone(), root.join("reference")] {
        let edges = sibling_imports(&folder);
        assert!(edges.len() > 3, "{}: no modules found", folder.display());
        if let Some(cycle) = find_cycle(&edges) {
            panic!(
                "{}: the imports run in a circle: {}; move what they share into a leaf",
                folder.display(),
                cycle.join(" → ")
            );
        }
    }
}

#[test]
fn render_and_report_never_reach_into_the_backends() {
    let src = workspace().join("crates/sweep/src");
    let mut offenders = Vec::new();
    for folder in ["render", "report"] {
        for entry in walk(&src.join(folder)) {
            if code(&entry).contains("crate::backend") {
                offenders.push(entry.display().to_string());
            }
        }
    }
    for entry in walk(&src.join("backend")) {
        if code(&entry).contains("build_report") {
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
