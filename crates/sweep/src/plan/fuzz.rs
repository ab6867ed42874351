//! Property-based tests of the experiment parser: generated experiment files mix valid and
//! invalid tables, axes, ranges, zips, exclusions, presets, references, comparisons, plots
//! and sheets. Every file must be accepted or rejected within a time bound, without a
//! panic, and every rejection must point into the experiment file; a run must see both
//! accepted and rejected files.
//!
//! CI runs a few thousand cases; `cargo test --release -p volphot-sweep fuzz -- --ignored`
//! runs 100 000.

use std::path::Path;

use proptest::prelude::*;

use super::{Experiment, Quality};
use crate::fuzz::run;

const CI_CASES: u32 = 1500;
const LONG_CASES: u32 = 100_000;

fn value() -> impl Strategy<Value = String> {
    prop_oneof![
        Just("[25, 150]".to_string()),
        Just("[0, 5]".to_string()),
        Just("[]".to_string()),
        Just("[1e30]".to_string()),
        Just("[\"a\", 2]".to_string()),
        Just("{ from = 6, to = 300, steps = 3, scale = \"log\" }".to_string()),
        Just("{ from = 0, to = 300, steps = 3, scale = \"log\" }".to_string()),
        Just("{ from = 6, to = 300 }".to_string()),
        Just("{ from = 6, to = 300, steps = 100000 }".to_string()),
        Just("{ from = 1, to = 2, steps = 2, scale = \"cubic\" }".to_string()),
        Just("{ from = nan, to = 2, steps = 2 }".to_string()),
        Just("{ junk = 1 }".to_string()),
        Just("3".to_string()),
        Just("\"text\"".to_string()),
        Just("[[16, 16], [24, 24]]".to_string()),
    ]
}

fn key() -> impl Strategy<Value = &'static str> {
    prop::sample::select(vec![
        "\"integrator.nused\"",
        "\"sigma.t\"",
        "\"integrator.maxdist\"",
        "\"camera.resolution\"",
        "\"integrator.nsued\"",
        "\"volume.phantom.resolution\"",
        "scene",
        "\"a.b.c\"",
    ])
}

fn table_block() -> impl Strategy<Value = String> {
    let kv = (key(), value())
        .prop_map(|(k, v)| format!("{k} = {v}"))
        .boxed();
    prop_oneof![
        prop::collection::vec(kv.clone(), 0..4).prop_map(|l| format!("[axes]\n{}", l.join("\n"))),
        prop::collection::vec(kv.clone(), 0..3).prop_map(|l| format!("[[zip]]\n{}", l.join("\n"))),
        prop::collection::vec(kv.clone(), 0..3).prop_map(|l| format!("[set]\n{}", l.join("\n"))),
        (key(), prop_oneof![Just("25"), Just("80.0"), Just("\"x\"")])
            .prop_map(|(k, v)| format!("[[exclude]]\n{k} = {v}")),
        prop_oneof![Just("quick"), Just("paper"), Just("fast")].prop_map(|q| format!(
            "[quality.{q}]\nset = {{ \"camera.resolution\" = [16, 16] }}\naxes = {{ \"integrator.nused\" = [10] }}"
        )),
        (prop_oneof![Just("path"), Just("photon"), Just("magic")], 0u32..3)
            .prop_map(|(m, spp)| format!("[reference]\nmethod = \"{m}\"\nspp = {spp}")),
        (prop_oneof![Just("layers"), Just("reference"), Just("axis"), Just("bogus")], any::<bool>(), any::<bool>())
            .prop_map(|(k, axis, b)| format!(
                "[[compare]]\nkind = \"{k}\"\n{}{}",
                if axis { "axis = \"integrator.nused\"\n" } else { "" },
                if b { "b = 150" } else { "" }
            )),
        (prop_oneof![Just("rmse"), Just("ms_share"), Just("no_such_metric")], key())
            .prop_map(|(y, x)| format!("[[plots]]\nx = {x}\ny = [\"{y}\"]")),
        (key(), prop_oneof![Just("total"), Just("diff"), Just("depth")])
            .prop_map(|(rows, layer)| format!("[[sheets]]\nrows = {rows}\nlayer = \"{layer}\"")),
    ]
}

fn experiment_text() -> impl Strategy<Value = String> {
    (
        prop_oneof![6 => Just("\"fuzz\""), 1 => Just("\"../up\""), 1 => Just("\"\""), 1 => Just("7")],
        prop_oneof![
            6 => Just("\"s.toml\"".to_string()),
            1 => Just("\"missing.toml\"".to_string()),
            3 => Just("{ volume = { phantom = { name = \"sphere\", resolution = [8, 8, 8] } }, three_point = {} }".to_string()),
            1 => Just("5".to_string()),
        ],
        prop_oneof![4 => Just(""), 1 => Just("max_cells = 4\n"), 1 => Just("share = false\n"), 1 => Just("bogus = 1\n")],
        prop::collection::vec(table_block(), 0..5),
    )
        .prop_map(|(name, scene, top, blocks)| {
            format!("name = {name}\nscene = {scene}\n{top}{}\n", blocks.join("\n"))
        })
}

/// Loads, counts and (for small grids) expands an experiment file; a rejection must point
/// into the file.
fn check(dir: &Path, text: String) -> Result<bool, String> {
    let path = dir.join("e.toml");
    std::fs::write(&path, &text).unwrap();
    let result = Experiment::load(&path).and_then(|e| {
        let size = e.grid_size(Quality::Default)?;
        if size <= 50 {
            e.plan_with_hashes(Quality::Default, true)?;
            e.plan_with_hashes(Quality::Quick, true)?;
        }
        Ok(())
    });
    match result {
        Ok(()) => Ok(true),
        Err(e) => {
            let message = format!("{e:#}");
            if message.contains(&path.display().to_string()) {
                Ok(false)
            } else {
                Err(format!("unlocated error `{message}` for\n{text}"))
            }
        }
    }
}

/// Writes the base scene the generated files name, then fuzzes [`check`] on them.
fn fuzz(cases: u32) {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("s.toml"),
        format!(
            "{}[camera]\nresolution = [8, 8]\n",
            volphot::test_util::SMALL_SCENE
        ),
    )
    .unwrap();
    run(
        "experiment_files",
        dir.path(),
        cases,
        experiment_text(),
        check,
    );
}

#[test]
fn fuzz_experiment_files() {
    fuzz(CI_CASES);
}

#[test]
#[ignore = "long run: cargo test --release -p volphot-sweep fuzz -- --ignored"]
fn fuzz_experiment_files_long() {
    fuzz(LONG_CASES);
}
