//! The core's import structure as CONTRIBUTING.md states it: no circle of imports between
//! any two of its files, and each stage importing only the stages below it (the film, then
//! volume → medium → scene → photon → integrator → render). The checker is shared with the
//! sweep's tests (`architecture/check.rs`); its own tests below feed it each form of import
//! an earlier checker missed.

mod check;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use check::{
    Graph, Module, against_layers, assert_no_circle, assert_stage_order, circles, code, graph_of,
    map_mismatches, section, source_graph,
};

/// The core's stages, lowest first: a stage's files may import only the stages before it
/// (modules outside the list — `math`, `util`, `error`, `control`, `counters` — are the
/// ground every stage stands on). The film is the sink the integrators write into, so it
/// sits below them and knows no stage.
const CORE_LAYERS: [&str; 7] = [
    "film",
    "volume",
    "medium",
    "scene",
    "photon",
    "integrator",
    "render",
];

fn core_graph() -> Graph {
    source_graph(&Path::new(env!("CARGO_MANIFEST_DIR")).join("src"))
}

#[test]
fn the_core_has_no_import_circle() {
    assert_no_circle(&core_graph());
}

#[test]
fn each_core_stage_imports_only_the_stages_below_it() {
    assert_stage_order(&core_graph(), &CORE_LAYERS);
}

/// A crate of `files` (module path as `a/b`, the root as ``) with their code.
fn fake(files: &[(&str, &str)]) -> Graph {
    let module = |m: &str| -> Module {
        m.split('/')
            .filter(|s| !s.is_empty())
            .map(String::from)
            .collect()
    };
    let paths: BTreeMap<Module, PathBuf> = files
        .iter()
        .map(|(m, _)| (module(m), PathBuf::from(format!("{m}.rs"))))
        .collect();
    let texts: BTreeMap<Module, String> = files.iter().map(|(m, t)| (module(m), code(t))).collect();
    graph_of(paths, &texts)
}

fn edge(graph: &Graph, from: &str, to: &str) -> bool {
    let split = |m: &str| -> Module { m.split('/').map(String::from).collect() };
    graph
        .edges
        .get(&split(from))
        .is_some_and(|e| e.contains_key(&split(to)))
}

/// The forms the checker of `use super::NAME` lines alone did not see: a grouped
/// `use super::{pass::X, …}`, a `crate::` path written inline, a folder's `mod.rs`, a
/// nested group, a name reached through a front door's `pub use` (and its glob) — each
/// makes the edge it should, and a circle through them is found.
#[test]
fn the_checker_sees_every_form_of_import() {
    let graph = fake(&[
        ("", "mod a; mod z; pub use a::Open;"),
        (
            "a",
            "mod b; mod pass; mod inner; mod globbed;\npub use inner::Open;\npub use globbed::*;\nuse self::b::Q;",
        ),
        (
            "a/b",
            "use super::{pass::X, y};\npub struct Q;\nuse super::R;",
        ),
        (
            "a/pass",
            "pub struct X;\nfn f() { let _ = crate::a::b::Q; }",
        ),
        ("a/inner", "pub struct Open;"),
        ("a/globbed", "pub fn far() {}"),
        (
            "z",
            "use crate::{a::{Open, far}, q};\n// use crate::a::b::Q;\nconst S: &str = \"crate::a::pass::X\";\n#[cfg(test)]\nmod tests { use crate::a::pass::X; }",
        ),
    ]);
    assert!(
        edge(&graph, "a/b", "a/pass"),
        "grouped `use super::{{pass::X}}`"
    );
    assert!(edge(&graph, "a/pass", "a/b"), "inline `crate::a::b::Q`");
    assert!(
        edge(&graph, "a", "a/b"),
        "a `mod.rs` file's `use self::b::Q`"
    );
    assert!(
        edge(&graph, "a/b", "a"),
        "`use super::R` reaching the front door"
    );
    assert!(
        edge(&graph, "z", "a/inner"),
        "nested group through `pub use`"
    );
    assert!(
        edge(&graph, "z", "a/globbed"),
        "a name through `pub use globbed::*`"
    );
    assert!(!edge(&graph, "z", "a/b"), "a comment is not an import");
    assert!(
        !edge(&graph, "z", "a/pass"),
        "neither a string nor a test module"
    );
    assert!(!edge(&graph, "", "a/inner"), "a re-export is not an edge");
    let found = circles(&graph);
    assert_eq!(found.len(), 1, "{found:?}");
    for member in ["a,", "a/b", "a/pass"] {
        assert!(found[0].contains(member), "{member} in {found:?}");
    }
}

/// A stage that imports one above it is named, with the names it imports; the other way
/// round, and modules outside the stages, pass.
#[test]
fn the_checker_names_an_import_against_the_stages() {
    let graph = fake(&[
        ("", "mod volume; mod medium; mod math;"),
        ("volume", "use crate::medium::Sigma;\nuse crate::math::Vec;"),
        ("medium", "use crate::volume::Volume;\npub struct Sigma;"),
        ("math", "use crate::medium::Sigma;"),
    ]);
    let found = against_layers(&graph, &["volume", "medium"]);
    assert_eq!(found.len(), 1, "{found:?}");
    assert!(found[0].starts_with("volume → medium (Sigma)"), "{found:?}");
}

/// CONTRIBUTING.md's map of the library names every module of the tree, and nothing that
/// is not there (the integrators' folder keeps its own map in `integrator/mod.rs`).
#[test]
fn the_map_of_the_library_matches_the_tree() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let contributing = std::fs::read_to_string(root.join("../../CONTRIBUTING.md")).unwrap();
    let map = section(&contributing, "### The library");
    let found = map_mismatches(&root.join("src"), map, &["integrator"], &[]);
    assert!(
        found.is_empty(),
        "CONTRIBUTING.md, The library:\n{}",
        found.join("\n")
    );
}
