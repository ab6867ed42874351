//! The report's plots draw what the cells say (issue #49): no average across an axis that
//! changes what a metric means, seeds averaged with their spread, and every plot's numbers
//! written beside it.

use std::collections::HashMap;
use std::path::Path;

use volphot_tests::{read_csv, run_ok, sweep, write_experiment};

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
    let exp = write_experiment(
        dir.path(),
        "ms",
        "phantom-engine.toml",
        r#"[set]
"volume.phantom.resolution" = [24, 24, 24]
"camera.resolution" = [20, 20]
"integrator.volume_photons" = 3000
"integrator.stepsize" = 0.01
[axes]
"sigma.t" = [10, 80]
"integrator.multiple" = [false, true]
"integrator.seed" = [1, 2]
"#,
    );
    let out = dir.path().join("out");
    run_ok(sweep().arg(&exp).arg("--output").arg(&out).arg("--quiet"));
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
