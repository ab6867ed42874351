//! The report's plots draw what the cells say (issue #49): no average across an axis that
//! changes what a metric means, seeds averaged with their spread, and every plot's numbers
//! written beside it.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use volphot_tests::{read_csv, run_ok, sweep, write_experiment};

/// Runs a tiny grid on the engine phantom (24³ voxels, 20² pixels) with `tables` after
/// its `[set]`; returns the output folder.
fn tiny_grid(dir: &Path, name: &str, tables: &str) -> PathBuf {
    let exp = write_experiment(
        dir,
        name,
        "phantom-engine.toml",
        &format!(
            "[set]\n\"volume.phantom.resolution\" = [24, 24, 24]\n\"camera.resolution\" = [20, 20]\n\"integrator.volume_photons\" = 3000\n\"integrator.stepsize\" = 0.01\n{tables}"
        ),
    );
    let out = dir.join("out");
    run_ok(sweep().arg(&exp).arg("--output").arg(&out).arg("--quiet"));
    out
}

/// Rows of a CSV file keyed by column name.
fn rows(path: &Path) -> Vec<HashMap<String, String>> {
    let (headers, rows) = read_csv(path);
    rows.into_iter()
        .map(|row| headers.iter().cloned().zip(row).collect())
        .collect()
}

fn number(row: &HashMap<String, String>, column: &str) -> f64 {
    row[column]
        .parse()
        .unwrap_or_else(|_| panic!("{column} = {:?}", row[column]))
}

/// A grid with `multiple = [false, true]` and two seeds: the multiple-scattering share is
/// undefined without multiple scattering, so its plot shows exactly the `multiple = true`
/// cells, each point the mean of its two seeds with their min and max. (Before, the plot
/// averaged the share over both values of `multiple`, halving every value.)
#[test]
fn ms_share_plot_shows_the_multiple_cells_and_their_seed_spread() {
    let dir = tempfile::tempdir().unwrap();
    let out = tiny_grid(
        dir.path(),
        "ms",
        r#"[axes]
"sigma.t" = [10, 80]
"integrator.multiple" = [false, true]
"integrator.seed" = [1, 2]
"#,
    );
    let cells = rows(&out.join("cells.csv"));
    for c in &cells {
        if c["integrator.multiple"] == "false" {
            assert_eq!(
                c["ms_share [1]"], "",
                "ms_share of a single-only cell: {c:?}"
            );
        }
    }
    let plot = out.join("figures/plots/p0_ms_share_vs_sigma_t.csv");
    assert!(plot.is_file(), "no data file beside the plot");
    let points = rows(&plot);
    assert_eq!(points.len(), 2, "one point per σt: {points:?}");
    for p in &points {
        let x = number(p, "x");
        let behind: Vec<f64> = cells
            .iter()
            .filter(|c| c["integrator.multiple"] == "true" && number(c, "sigma.t") == x)
            .map(|c| number(c, "ms_share [1]"))
            .collect();
        assert_eq!(behind.len(), 2, "two seeds at σt {x}");
        let mean = behind.iter().sum::<f64>() / 2.0;
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-5 * b.abs().max(1e-9);
        assert!(close(number(p, "y"), mean), "{p:?} against {behind:?}");
        assert!(close(number(p, "y_min"), behind[0].min(behind[1])), "{p:?}");
        assert!(close(number(p, "y_max"), behind[0].max(behind[1])), "{p:?}");
        assert_eq!(p["n_cells"], "2");
        assert!(mean > 0.0);
    }
    // The title says what is fixed and what is averaged.
    let md = std::fs::read_to_string(out.join("report.md")).unwrap();
    assert!(
        md.contains("ms_share vs σt(d_min) — multiple = true; mean of 2 seeds"),
        "{md}"
    );
    // An error plot without a reference is not drawn; every plot has its data file.
    for entry in std::fs::read_dir(out.join("figures/plots"))
        .unwrap()
        .flatten()
    {
        let path = entry.path();
        if path.extension().is_some_and(|e| e == "png") {
            assert!(path.with_extension("csv").is_file(), "{path:?} has no data");
        }
    }
}

/// The mean of `column` over the cells (seeds) with these axis values.
fn mean_of(cells: &[HashMap<String, String>], at: &[(&str, &str)], column: &str) -> f64 {
    let values: Vec<f64> = cells
        .iter()
        .filter(|c| {
            at.iter()
                .all(|(k, v)| number(c, k) == v.parse::<f64>().unwrap())
        })
        .map(|c| number(c, column))
        .collect();
    assert!(!values.is_empty(), "no cells at {at:?}");
    values.iter().sum::<f64>() / values.len() as f64
}

/// The report opens with what each axis changed and by how much: one sentence per main
/// metric, each context (the other axis's values) apart, repeated seeds by their mean; the
/// percentage is that of the cells' own numbers in `cells.csv`. Two seeds are too few for
/// the effect rule: no change is called an effect, each is unclear.
#[test]
fn the_report_says_what_each_axis_changed_and_by_how_much() {
    let dir = tempfile::tempdir().unwrap();
    let out = tiny_grid(
        dir.path(),
        "changes",
        r#"[axes]
"sigma.t" = [10, 80]
"integrator.nused" = [10, 80]
"integrator.seed" = [1, 2]
"#,
    );
    let cells = rows(&out.join("cells.csv"));
    let md = std::fs::read_to_string(out.join("report.md")).unwrap();
    let section = md
        .split("## What changed")
        .nth(1)
        .and_then(|s| s.split("\n## ").next())
        .unwrap_or_else(|| panic!("no `What changed` section:\n{md}"));
    assert!(
        md.find("## What changed") < md.find("## Grid"),
        "the section is near the top"
    );
    let bullet = |axis: &str| {
        section
            .lines()
            .find(|l| l.starts_with(&format!("- `{axis}`")))
            .unwrap_or_else(|| panic!("no sentence on {axis}:\n{section}"))
            .to_string()
    };
    assert!(
        !section.contains("`integrator.seed`"),
        "seeds are not an axis to compare"
    );
    let nused = bullet("integrator.nused");
    assert!(
        nused.starts_with("- `integrator.nused` 10 → 80 "),
        "{nused}"
    );
    let sentences: Vec<&str> = nused
        .trim_start_matches("- ")
        .split(". ")
        .map(|s| s.trim_end_matches('.'))
        .collect();
    assert!((1..=2).contains(&sentences.len()), "{nused}");
    for sentence in sentences {
        let rest = sentence
            .split_once(" changes `")
            .unwrap_or_else(|| panic!("not `… changes `metric` by …`: `{sentence}`"))
            .1;
        let (metric, rest) = rest.split_once('`').unwrap();
        let column = cells[0]
            .keys()
            .find(|k| k.starts_with(&format!("{metric} [")))
            .unwrap_or_else(|| panic!("{metric} is not a column"))
            .clone();
        let list = rest.split_once(" by ").unwrap().1;
        let items: Vec<&str> = list.split(", ").collect();
        assert_eq!(items.len(), 2, "one number per σt: `{sentence}`");
        for item in items {
            let (number_text, context) = item
                .split_once(" % at σt(d_min) ")
                .unwrap_or_else(|| panic!("`{item}` of `{sentence}` is not `N % at σt(d_min) V`"));
            let (t, verdict) = context
                .split_once(" (")
                .unwrap_or_else(|| panic!("`{item}` of `{sentence}` has no verdict"));
            assert_eq!(verdict, "unclear: 2 seeds)", "{sentence}");
            let before = mean_of(
                &cells,
                &[("sigma.t", t), ("integrator.nused", "10")],
                &column,
            );
            let after = mean_of(
                &cells,
                &[("sigma.t", t), ("integrator.nused", "80")],
                &column,
            );
            let change = 100.0 * (after - before) / before.abs();
            let stated: f64 = number_text
                .replace('−', "-")
                .trim_start_matches('+')
                .parse()
                .unwrap();
            assert!((stated - change).abs() <= 0.6, "{sentence}: {change}");
        }
    }
    bullet("sigma.t");
}

/// Every difference image the report writes is linked from `report.md`, with a caption
/// (so `report.html` shows it too): the amplified and signed differences of each cell.
#[test]
fn every_difference_image_is_linked_from_the_report() {
    let dir = tempfile::tempdir().unwrap();
    let exp = write_experiment(
        dir.path(),
        "diffs",
        "phantom-engine.toml",
        r#"[set]
"volume.phantom.resolution" = [16, 16, 16]
"camera.resolution" = [16, 16]
"integrator.volume_photons" = 2000
"integrator.stepsize" = 0.02
[axes]
"integrator.nused" = [10, 40]
[[compare]]
kind = "layers"
"#,
    );
    let out = dir.path().join("out");
    run_ok(sweep().arg(&exp).arg("--output").arg(&out).arg("--quiet"));
    let md = std::fs::read_to_string(out.join("report.md")).unwrap();
    let section = md
        .split("## Difference images")
        .nth(1)
        .unwrap_or_else(|| panic!("no `Difference images` section:\n{md}"));
    let mut written = 0;
    for entry in std::fs::read_dir(out.join("figures/diff"))
        .unwrap()
        .flatten()
    {
        let name = entry.file_name().to_string_lossy().into_owned();
        let link = format!("](figures/diff/{name})");
        let line = section
            .lines()
            .find(|l| l.contains(&link))
            .unwrap_or_else(|| panic!("{name} is linked from nowhere:\n{section}"));
        let caption = line.split(&link).next().unwrap();
        assert!(caption.len() > 8, "{name} has no caption: {line}");
        written += 1;
    }
    assert_eq!(written, 6, "compare, amplified and signed for 2 cells");
}
