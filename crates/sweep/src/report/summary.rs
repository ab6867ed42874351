//! `report.md`'s "What changed" section: for each axis, its first value against its last,
//! in the main metrics it moves most, one sentence per metric ("`integrator.nused` 25 → 150
//! lowers `disco_energy` by 62 % at σt(d_min) 80, 18 % at σt(d_min) 20").
//!
//! The numbers are the cells' own (the extractors of `cells.csv`). Cells that differ in
//! another axis are never averaged together: each combination of the other axes' values
//! is a case of its own, named in the sentence; only cells that repeat another with a new
//! seed are averaged (their mean is compared), as the plots do. With several seeds each
//! case's change is also taken seed by seed: it is beyond the seed spread only when every
//! seed moves the same way and their mean change exceeds twice its standard error; a change
//! inside the spread is marked so, and with one seed the spread is said to be unmeasured.
//! Axes whose values are not numbers or switches (the dataset, an estimator, a rule) have
//! no first and last value to compare and get no sentence.

use std::fmt::Write as _;

use super::collect::{Collected, axis_value, distinct_values};
use super::escape::{md_code, md_text};
use super::plots::{axis_name, is_seed_axis, value_name};
use crate::analyse::METRIC_COLUMNS;

/// The metrics a sentence may be about: each entry's first metric that any cell has (the
/// noise-corrected error before the raw one, the excess over the reference's disco score
/// before the plain one), in order of preference when two move alike.
const MAIN_METRICS: [&[&str]; 4] = [
    &["rmse_corrected", "rmse"],
    &["disco_excess", "disco_energy"],
    &["ms_share"],
    &["time_render"],
];

/// Sentences per axis at most: the metrics that axis moves most.
const PER_AXIS: usize = 2;

/// A change smaller than this, in percent, leaves a metric as it was (timing noise and
/// rounding move a metric by that much between identical cells).
const UNCHANGED: f64 = 0.5;

/// Cases (combinations of the other axes) a sentence names one by one; more are given by
/// their range and median, so that a sentence stays a sentence.
const LISTED: usize = 3;

/// One case's change of a metric from the axis's first value to its last, in percent.
struct Change {
    /// The other axes' values, as the sentence names them (empty: the only case).
    case: String,
    percent: f64,
    /// Whether the change is beyond its seed spread (`None`: one seed, not measured).
    beyond: Option<bool>,
}

/// Whether paired changes (one per seed) are beyond their spread: all of one sign, and
/// their mean more than twice its standard error. `None` with fewer than two seeds.
fn beyond_spread(per_seed: &[f64]) -> Option<bool> {
    let n = per_seed.len();
    if n < 2 {
        return None;
    }
    let mean = per_seed.iter().sum::<f64>() / n as f64;
    let sd = (per_seed.iter().map(|p| (p - mean).powi(2)).sum::<f64>() / (n as f64 - 1.0)).sqrt();
    let one_sign = per_seed.iter().all(|p| *p > 0.0) || per_seed.iter().all(|p| *p < 0.0);
    Some(one_sign && mean.abs() > 2.0 * sd / (n as f64).sqrt())
}

/// Whether an axis's values can be first and last of something: numbers and switches.
fn ordered(values: &[serde_json::Value]) -> bool {
    values.iter().all(|v| v.is_number() || v.is_boolean())
}

/// The section, or nothing when no axis has two values among the finished cells.
pub(crate) fn what_changed(axes: &[String], cells: &[Collected]) -> String {
    let done: Vec<&Collected> = cells.iter().filter(|c| c.record.is_some()).collect();
    let bullets: Vec<String> = axes
        .iter()
        .filter(|a| !is_seed_axis(a))
        .filter(|a| ordered(&distinct_values(done.iter().copied(), a)))
        .filter_map(|a| axis_bullet(a, axes, &done))
        .collect();
    if bullets.is_empty() {
        return String::new();
    }
    let seeds = seed_count(axes, &done);
    let mut s = String::from("## What changed\n\n");
    let _ = writeln!(
        s,
        "Each axis from its first value to its last, in the two main metrics (`rmse` or `rmse_corrected` against the reference, `disco_excess` or `disco_energy`, `ms_share`, `time_render`) it moves most. Cells that differ in another axis are compared apart; axes of names (the dataset, an estimator) are not compared. {} [cells.csv](cells.csv) has every value.\n",
        if seeds > 1 {
            format!(
                "Cells repeated with {seeds} seeds are compared by their mean, and a change is marked within the seed spread unless every seed moves the same way by more than twice the standard error of their mean."
            )
        } else {
            "Every setting was rendered with one seed: the seed spread is not measured, and a change of a few percent may be noise.".to_string()
        }
    );
    for b in bullets {
        let _ = writeln!(s, "- {b}");
    }
    s.push('\n');
    s
}

/// The sentences on one axis, or `None` when it has one value or no metric changed
/// measurably in any case.
fn axis_bullet(axis: &str, axes: &[String], done: &[&Collected]) -> Option<String> {
    let values = distinct_values(done.iter().copied(), axis);
    let (first, last) = (values.first()?, values.last()?);
    if values.len() < 2 {
        return None;
    }
    let others: Vec<&String> = axes
        .iter()
        .filter(|k| k.as_str() != axis && !is_seed_axis(k))
        .collect();
    let mut moved: Vec<(f64, String, Vec<Change>)> = MAIN_METRICS
        .iter()
        .filter_map(|choices| {
            let key = choices
                .iter()
                .find(|k| done.iter().any(|c| metric(c, k).is_some()))?;
            let changes = changes(axis, first, last, &others, done, key);
            (!changes.is_empty()).then(|| (median_size(&changes), key.to_string(), changes))
        })
        .collect();
    // The largest changes first; equal ones keep the order of preference (a stable sort).
    moved.sort_by(|a, b| b.0.total_cmp(&a.0));
    let subject = format!(
        "{} {} → {}",
        md_code(axis),
        md_text(&value_name(axis, first)),
        md_text(&value_name(axis, last))
    );
    let sentences: Vec<String> = moved
        .iter()
        .take(PER_AXIS)
        .enumerate()
        .map(|(i, (_, key, changes))| {
            let who = if i == 0 { subject.as_str() } else { "It" };
            format!("{who} {}.", predicate(key, changes))
        })
        .collect();
    (!sentences.is_empty()).then(|| sentences.join(" "))
}

/// The most seeds any setting was rendered with.
fn seed_count(axes: &[String], done: &[&Collected]) -> usize {
    axes.iter()
        .filter(|a| is_seed_axis(a))
        .map(|a| distinct_values(done.iter().copied(), a).len())
        .product::<usize>()
        .max(1)
}

/// A cell's value of metric `key`, as `cells.csv` has it.
fn metric(c: &Collected, key: &str) -> Option<f64> {
    let column = METRIC_COLUMNS.iter().find(|m| m.key == key)?;
    (column.value)(c.record.as_ref()?, c.reference.as_ref()).filter(|v| v.is_finite())
}

/// The change of `key` from `axis = first` to `axis = last` in each case (each combination
/// of the `others`' values, in plan order), the cells of a case averaged over seeds. A case
/// without cells at both ends, or at 0 before (no percentage of nothing), is left out.
fn changes(
    axis: &str,
    first: &serde_json::Value,
    last: &serde_json::Value,
    others: &[&String],
    done: &[&Collected],
    key: &str,
) -> Vec<Change> {
    let case_of = |c: &Collected| -> Vec<Option<serde_json::Value>> {
        others.iter().map(|k| axis_value(&c.planned, k)).collect()
    };
    let seed_of = |c: &Collected| -> Vec<Option<serde_json::Value>> {
        c.planned
            .axes
            .iter()
            .filter(|(k, _)| is_seed_axis(k))
            .map(|(_, v)| Some(v.clone()))
            .collect()
    };
    let mut cases: Vec<Vec<Option<serde_json::Value>>> = Vec::new();
    for c in done {
        let case = case_of(c);
        if !cases.contains(&case) {
            cases.push(case);
        }
    }
    // Each cell of a case and an end of the axis, by its seeds' values.
    let at = |case: &Vec<Option<serde_json::Value>>, value: &serde_json::Value| {
        done.iter()
            .filter(|c| case_of(c) == *case && axis_value(&c.planned, axis).as_ref() == Some(value))
            .filter_map(|c| Some((seed_of(c), metric(c, key)?)))
            .collect::<Vec<_>>()
    };
    let mean = |v: &[(Vec<Option<serde_json::Value>>, f64)]| {
        (!v.is_empty()).then(|| v.iter().map(|(_, m)| m).sum::<f64>() / v.len() as f64)
    };
    cases
        .iter()
        .filter_map(|case| {
            let (from, to) = (at(case, first), at(case, last));
            let (before, after) = (mean(&from)?, mean(&to)?);
            // The same seed at both ends: a paired change.
            let per_seed: Vec<f64> = from
                .iter()
                .filter(|(_, b)| *b != 0.0)
                .filter_map(|(seed, b)| {
                    let (_, a) = to.iter().find(|(s, _)| s == seed)?;
                    Some(100.0 * (a - b) / b.abs())
                })
                .collect();
            (before != 0.0).then(|| Change {
                case: case_label(others, case),
                percent: 100.0 * (after - before) / before.abs(),
                beyond: beyond_spread(&per_seed),
            })
        })
        .collect()
}

/// A case as a sentence names it: `σt(d_min) 80, foot`.
fn case_label(others: &[&String], case: &[Option<serde_json::Value>]) -> String {
    others
        .iter()
        .zip(case)
        .filter_map(|(k, v)| {
            let v = value_name(k, v.as_ref()?);
            Some(if k.as_str() == "scene" {
                v
            } else {
                format!("{} {v}", axis_name(k))
            })
        })
        .map(|s| md_text(&s))
        .collect::<Vec<_>>()
        .join(", ")
}

/// The median of the changes' sizes: what ranks a metric's sentence.
fn median_size(changes: &[Change]) -> f64 {
    let mut sizes: Vec<f64> = changes.iter().map(|c| c.percent.abs()).collect();
    sizes.sort_by(f64::total_cmp);
    sizes[sizes.len() / 2]
}

/// A percentage as a sentence gives it: whole percents, tenths below 1 %.
fn percent(p: f64) -> String {
    if p.abs() < 1.0 {
        format!("{p:.1}")
    } else {
        format!("{p:.0}")
    }
}

/// A signed percentage, with a real minus sign (none on a change that rounds to 0).
fn signed(p: f64) -> String {
    let text = percent(p.abs());
    match p {
        _ if p.abs() < 0.05 => text,
        _ if p < 0.0 => format!("−{text}"),
        _ => format!("+{text}"),
    }
}

/// "` lowers `rmse` by 62 % at σt(d_min) 80, 18 % at σt(d_min) 20`" and its variants:
/// `raises`, `changes` (mixed directions, signed numbers), `leaves … within` (every change
/// below [`UNCHANGED`]); beyond [`LISTED`] cases the range, its cases and the median.
fn predicate(key: &str, changes: &[Change]) -> String {
    let (down, up) = (
        changes.iter().all(|c| c.percent < 0.0),
        changes.iter().all(|c| c.percent > 0.0),
    );
    let (verb, size): (&str, fn(f64) -> String) =
        if changes.iter().all(|c| c.percent.abs() < UNCHANGED) {
            ("leaves", |p: f64| percent(p.abs()))
        } else if down {
            ("lowers", |p: f64| percent(p.abs()))
        } else if up {
            ("raises", |p: f64| percent(p.abs()))
        } else {
            ("changes", signed)
        };
    let by = if verb == "leaves" { "within" } else { "by" };
    let flag = |c: &Change| match c.beyond {
        Some(false) => " (within the seed spread)",
        _ => "",
    };
    let at = |c: &Change| {
        if c.case.is_empty() {
            format!("{} %{}", size(c.percent), flag(c))
        } else {
            format!("{} % at {}{}", size(c.percent), c.case, flag(c))
        }
    };
    if changes.len() <= LISTED {
        let listed: Vec<String> = changes.iter().map(at).collect();
        return format!("{verb} {} {by} {}", md_code(key), listed.join(", "));
    }
    // Ranges run from the smallest change to the largest (by size, in one direction), or
    // from the most negative to the most positive when the directions differ.
    let mut sorted: Vec<&Change> = changes.iter().collect();
    match verb {
        "changes" => sorted.sort_by(|a, b| a.percent.total_cmp(&b.percent)),
        _ => sorted.sort_by(|a, b| a.percent.abs().total_cmp(&b.percent.abs())),
    }
    let (from, to) = (sorted[0], sorted[sorted.len() - 1]);
    let median = sorted[sorted.len() / 2];
    let lower = changes.iter().filter(|c| c.percent < 0.0).count();
    let measured = changes.iter().filter(|c| c.beyond.is_some()).count();
    let beyond = changes.iter().filter(|c| c.beyond == Some(true)).count();
    format!(
        "{verb} {} {by} {} % (at {}) to {} % (at {}) in {} cases, median {} %{}{}",
        md_code(key),
        size(from.percent),
        from.case,
        size(to.percent),
        to.case,
        changes.len(),
        size(median.percent),
        if verb == "changes" {
            format!(", lower in {lower} of them")
        } else {
            String::new()
        },
        if measured > 0 {
            format!("; {beyond} of the {measured} beyond their seed spread")
        } else {
            String::new()
        }
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn change(case: &str, percent: f64) -> Change {
        Change {
            case: case.into(),
            percent,
            beyond: None,
        }
    }

    #[test]
    fn a_predicate_states_the_direction_and_each_case() {
        let down = [change("σt(d_min) 80", -62.4), change("σt(d_min) 20", -18.0)];
        assert_eq!(
            predicate("disco_energy", &down),
            "lowers `disco_energy` by 62 % at σt(d_min) 80, 18 % at σt(d_min) 20"
        );
        let mixed = [change("foot", -62.0), change("head", 18.0)];
        assert_eq!(
            predicate("rmse", &mixed),
            "changes `rmse` by −62 % at foot, +18 % at head"
        );
        assert_eq!(
            predicate("ms_share", &[change("", 0.2)]),
            "leaves `ms_share` within 0.2 %"
        );
        assert_eq!(
            predicate("time_render", &[change("", 40.0)]),
            "raises `time_render` by 40 %"
        );
    }

    #[test]
    fn many_cases_are_given_by_their_range_and_median() {
        let down: Vec<Change> = [-5.0, -30.0, -62.0, -12.0]
            .iter()
            .map(|p| change(&format!("nused {}", -p), *p))
            .collect();
        assert_eq!(
            predicate("disco_energy", &down),
            "lowers `disco_energy` by 5 % (at nused 5) to 62 % (at nused 62) in 4 cases, median 30 %"
        );
        let many: Vec<Change> = [-5.0, -30.0, -62.0, -12.0, 3.0]
            .iter()
            .enumerate()
            .map(|(i, p)| change(&format!("σt(d_min) {i}"), *p))
            .collect();
        assert_eq!(
            predicate("rmse", &many),
            "changes `rmse` by −62 % (at σt(d_min) 2) to +3 % (at σt(d_min) 4) in 5 cases, median −12 %, lower in 4 of them"
        );
    }

    #[test]
    fn changes_inside_the_seed_spread_are_marked() {
        assert_eq!(beyond_spread(&[-10.0]), None);
        assert_eq!(beyond_spread(&[-10.0, -12.0, -11.0]), Some(true));
        assert_eq!(
            beyond_spread(&[-10.0, 2.0, -11.0]),
            Some(false),
            "mixed signs"
        );
        assert_eq!(
            beyond_spread(&[-1.0, -30.0]),
            Some(false),
            "mean within 2 se"
        );
        let within = [Change {
            case: "foot".into(),
            percent: -5.0,
            beyond: Some(false),
        }];
        assert_eq!(
            predicate("disco_excess", &within),
            "lowers `disco_excess` by 5 % at foot (within the seed spread)"
        );
        assert!(ordered(&[serde_json::json!(6), serde_json::json!(true)]));
        assert!(!ordered(&[serde_json::json!("scenes/foot.toml")]));
    }
}
