//! `report.md`'s "What changed" section: for each axis, its first value against its last,
//! in the main metrics it moves most, one sentence per metric ("`integrator.nused` 25 → 150
//! lowers `disco_energy` by 62 % at σt(d_min) 80 (95 % CI 55 to 70 %), 18 % at σt(d_min)
//! 20 (95 % CI 12 to 24 %)").
//!
//! The numbers are the cells' own (the extractors of `cells.csv`). Cells that differ in
//! another axis are never averaged together: each combination of the other axes' values
//! is a case of its own, named in the sentence; only cells that repeat another with a new
//! seed are averaged (their mean is compared), as the plots do. Whether a case's change is
//! an effect is decided by the one rule `sweep claims` also checks
//! ([`crate::analyse::Verdict`]: a paired t-test over the seeds at the 5 % level, δ =
//! [`UNCHANGED`] for "none"): "lowers" and "raises" only for changes the rule calls falls
//! and rises, each with its 95 % interval; anything else is "changes", each case with its
//! verdict. A study without a seed axis has no noise estimate, and says so instead of
//! calling a change an effect. Axes whose values are not numbers or switches (the dataset,
//! an estimator, a rule) have no first and last value to compare and get no sentence.

use std::fmt::Write as _;

use super::collect::{Collected, axis_value, distinct_values};
use super::escape::{md_code, md_text};
use super::plots::{axis_name, is_seed_axis, value_name};
use crate::analyse::{METRIC_COLUMNS, MIN_SEEDS, Paired, Verdict};

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

/// δ of the effect rule, in percent of the value before: a change whose 95 % interval lies
/// within ±0.5 % is none (timing noise and rounding move a metric by that much between
/// identical cells).
const UNCHANGED: f64 = 0.5;

/// Cases (combinations of the other axes) a sentence names one by one; more are given by
/// their range and median, so that a sentence stays a sentence.
const LISTED: usize = 3;

/// What the seeds say about one case's change.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Noise {
    /// The study has no seed axis: no noise estimate.
    Unmeasured,
    /// The rule on the paired per-seed changes (`None`: no seed at both ends).
    Seeds(Option<Paired>),
}

impl Noise {
    /// The rule's verdict (`None` without a seed axis).
    fn verdict(&self) -> Option<Verdict> {
        match self {
            Noise::Unmeasured => None,
            Noise::Seeds(p) => Some(p.map_or(Verdict::Unclear, |p| p.verdict(Some(UNCHANGED)))),
        }
    }
}

/// One case's change of a metric from the axis's first value to its last, in percent of
/// its mean at the first.
struct Change {
    /// The other axes' values, as the sentence names them (empty: the only case).
    case: String,
    percent: f64,
    noise: Noise,
}

/// Whether an axis's values can be first and last of something: numbers and switches.
fn ordered(values: &[serde_json::Value]) -> bool {
    values.iter().all(|v| v.is_number() || v.is_boolean())
}

/// The section, or nothing when no axis has two values among the finished cells.
pub(crate) fn what_changed(axes: &[String], cells: &[Collected]) -> String {
    let done: Vec<&Collected> = cells.iter().filter(|c| c.record.is_some()).collect();
    let has_seeds = axes.iter().any(|a| is_seed_axis(a));
    let bullets: Vec<String> = axes
        .iter()
        .filter(|a| !is_seed_axis(a))
        .filter(|a| ordered(&distinct_values(done.iter().copied(), a)))
        .filter_map(|a| axis_bullet(a, axes, &done, has_seeds))
        .collect();
    if bullets.is_empty() {
        return String::new();
    }
    let seeds = seed_count(axes, &done);
    let mut s = String::from("## What changed\n\n");
    let _ = writeln!(
        s,
        "Each axis from its first value to its last, in the two main metrics (`rmse` or `rmse_corrected` against the reference, `disco_excess` or `disco_energy`, `ms_share`, `time_render`) it moves most. Cells that differ in another axis are compared apart; axes of names (the dataset, an estimator) are not compared. {} [cells.csv](cells.csv) has every value.\n",
        if has_seeds {
            format!(
                "Cells repeated with {seeds} seeds are compared by their mean, and each change is judged over its seeds by a paired t-test at the 5 % level: it is an effect (lowers, raises) only when the 95 % confidence interval (CI) of its mean lies on one side of 0, none when the interval lies within ±{UNCHANGED} %, and unclear otherwise — always with fewer than {MIN_SEEDS} seeds."
            )
        } else {
            format!(
                "The study has no seed axis: each setting was rendered once, no noise estimate exists, and no change below is called an effect (a seed axis of {MIN_SEEDS} values or more tells effects from noise)."
            )
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
fn axis_bullet(
    axis: &str,
    axes: &[String],
    done: &[&Collected],
    has_seeds: bool,
) -> Option<String> {
    let values = distinct_values(done.iter().copied(), axis);
    let (first, last) = (values.first()?, values.last()?);
    if values.len() < 2 {
        return None;
    }
    let others: Vec<&String> = axes
        .iter()
        .filter(|k| k.as_str() != axis && !is_seed_axis(k))
        .collect();
    let ends = Ends {
        axis,
        first,
        last,
        has_seeds,
    };
    let mut moved: Vec<(f64, String, Vec<Change>)> = MAIN_METRICS
        .iter()
        .filter_map(|choices| {
            let key = choices
                .iter()
                .find(|k| done.iter().any(|c| metric(c, k).is_some()))?;
            let changes = changes(&ends, &others, done, key);
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

/// The axis compared and its two ends.
struct Ends<'a> {
    axis: &'a str,
    first: &'a serde_json::Value,
    last: &'a serde_json::Value,
    /// Whether the study has a seed axis (else no noise estimate exists).
    has_seeds: bool,
}

/// The values of some axes of a cell (the other axes', or the seeds').
type Values = Vec<Option<serde_json::Value>>;

/// The change of `key` from the axis's first value to its last in each case (each
/// combination of the `others`' values, in plan order), the cells of a case averaged over
/// seeds, and judged over the seeds present at both ends. A case without cells at both
/// ends, or at 0 before (no percentage of nothing), is left out.
fn changes(ends: &Ends, others: &[&String], done: &[&Collected], key: &str) -> Vec<Change> {
    let case_of =
        |c: &Collected| -> Values { others.iter().map(|k| axis_value(&c.planned, k)).collect() };
    let seed_of = |c: &Collected| -> Values {
        c.planned
            .axes
            .iter()
            .filter(|(k, _)| is_seed_axis(k))
            .map(|(_, v)| Some(v.clone()))
            .collect()
    };
    let mut cases: Vec<Values> = Vec::new();
    for c in done {
        let case = case_of(c);
        if !cases.contains(&case) {
            cases.push(case);
        }
    }
    // Each cell of a case and an end of the axis, by its seeds' values.
    let at = |case: &Values, value: &serde_json::Value| {
        done.iter()
            .filter(|c| {
                case_of(c) == *case && axis_value(&c.planned, ends.axis).as_ref() == Some(value)
            })
            .filter_map(|c| Some((seed_of(c), metric(c, key)?)))
            .collect::<Vec<_>>()
    };
    let mean = |v: &[(Values, f64)]| {
        (!v.is_empty()).then(|| v.iter().map(|(_, m)| m).sum::<f64>() / v.len() as f64)
    };
    cases
        .iter()
        .filter_map(|case| {
            let (from, to) = (at(case, ends.first), at(case, ends.last));
            let (before, after) = (mean(&from)?, mean(&to)?);
            if before == 0.0 {
                return None;
            }
            // The same seed at both ends: a paired change, in percent of the mean before
            // (so that their mean is the case's change when every seed is paired).
            let per_seed: Vec<f64> = from
                .iter()
                .filter_map(|(seed, b)| {
                    let (_, a) = to.iter().find(|(s, _)| s == seed)?;
                    Some(100.0 * (a - b) / before.abs())
                })
                .collect();
            let noise = if ends.has_seeds {
                Noise::Seeds(Paired::of(&per_seed).ok())
            } else {
                Noise::Unmeasured
            };
            Some(Change {
                case: case_label(others, case),
                percent: 100.0 * (after - before) / before.abs(),
                noise,
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

/// An end of an interval in percent: as [`percent`], with two significant digits below
/// 0.1 % (an interval that ends just beyond 0 must not read as ending at 0).
fn bound(p: f64) -> String {
    if p == 0.0 || p.abs() >= 0.1 {
        return percent(p);
    }
    let decimals = (1 - p.abs().log10().floor() as i32).clamp(2, 12) as usize;
    format!("{p:.decimals$}")
}

/// [`bound`] with its sign, a real minus.
fn signed_bound(p: f64) -> String {
    match bound(p.abs()) {
        text if p == 0.0 => text,
        text if p < 0.0 => format!("−{text}"),
        text => format!("+{text}"),
    }
}

/// What a sentence says of its metric, from its cases' verdicts.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Verb {
    /// Every case falls by the rule.
    Lowers,
    /// Every case rises.
    Raises,
    /// Every case is none: within ±δ.
    Leaves,
    /// Anything else, each case with its verdict (or no noise estimate).
    Changes,
}

impl Verb {
    fn of(changes: &[Change]) -> Verb {
        let all = |v: Verdict| changes.iter().all(|c| c.noise.verdict() == Some(v));
        if all(Verdict::Falls) {
            Verb::Lowers
        } else if all(Verdict::Rises) {
            Verb::Raises
        } else if all(Verdict::None) {
            Verb::Leaves
        } else {
            Verb::Changes
        }
    }

    fn word(self) -> &'static str {
        match self {
            Verb::Lowers => "lowers",
            Verb::Raises => "raises",
            Verb::Leaves => "leaves",
            Verb::Changes => "changes",
        }
    }

    /// A percentage as this verb gives it: a size after lowers and raises, else signed.
    fn size(self, p: f64) -> String {
        match self {
            Verb::Lowers | Verb::Raises => percent(p.abs()),
            Verb::Leaves | Verb::Changes => signed(p),
        }
    }

    /// A 95 % interval: `55 to 70` (sizes, smaller first) or `−3 to +40`.
    fn interval(self, (low, high): (f64, f64)) -> String {
        match self {
            Verb::Lowers => format!("{} to {}", bound(-high), bound(-low)),
            Verb::Raises => format!("{} to {}", bound(low), bound(high)),
            Verb::Leaves | Verb::Changes => {
                format!("{} to {}", signed_bound(low), signed_bound(high))
            }
        }
    }
}

/// What a listed case adds after its number: its interval, and under "changes" its verdict
/// (`(falls: 95 % CI −70 to −55 %)`, `(unclear: 2 seeds)`).
fn noise_note(verb: Verb, noise: &Noise) -> String {
    let Noise::Seeds(paired) = noise else {
        return String::new();
    };
    let verdict = noise.verdict().unwrap_or(Verdict::Unclear);
    let label = if verb == Verb::Changes {
        format!("{}: ", verdict.word())
    } else {
        String::new()
    };
    match paired {
        Some(p) if p.n >= MIN_SEEDS => match p.interval {
            Some(interval) => format!(" ({label}95 % CI {} %)", verb.interval(interval)),
            None => format!(" ({label}{} seeds)", p.n),
        },
        Some(p) => format!(" ({label}{} seed{})", p.n, if p.n == 1 { "" } else { "s" }),
        None => format!(" ({label}no seed at both ends)"),
    }
}

/// "` lowers `rmse` by 62 % at σt(d_min) 80 (95 % CI 55 to 70 %), …`" and its variants:
/// `raises`, `leaves … within ±0.5 %`, `changes` (mixed or unclear verdicts, or no noise
/// estimate: signed numbers, each case's verdict); beyond [`LISTED`] cases the range, its
/// cases, the median and how many cases each verdict has.
fn predicate(key: &str, changes: &[Change]) -> String {
    let verb = Verb::of(changes);
    let by = if verb == Verb::Leaves {
        format!("within ±{UNCHANGED} %:")
    } else {
        "by".to_string()
    };
    let unmeasured = changes.iter().any(|c| c.noise == Noise::Unmeasured);
    let tail = if unmeasured {
        " (no noise estimate)"
    } else {
        ""
    };
    if changes.len() <= LISTED {
        let listed: Vec<String> = changes
            .iter()
            .map(|c| {
                let at = if c.case.is_empty() {
                    String::new()
                } else {
                    format!(" at {}", c.case)
                };
                format!(
                    "{} %{at}{}",
                    verb.size(c.percent),
                    noise_note(verb, &c.noise)
                )
            })
            .collect();
        return format!(
            "{} {} {by} {}{tail}",
            verb.word(),
            md_code(key),
            listed.join(", ")
        );
    }
    // Ranges run from the smallest change to the largest (by size, in one direction), or
    // from the most negative to the most positive otherwise.
    let mut sorted: Vec<&Change> = changes.iter().collect();
    match verb {
        Verb::Lowers | Verb::Raises => {
            sorted.sort_by(|a, b| a.percent.abs().total_cmp(&b.percent.abs()))
        }
        Verb::Leaves | Verb::Changes => sorted.sort_by(|a, b| a.percent.total_cmp(&b.percent)),
    }
    let (from, to) = (sorted[0], sorted[sorted.len() - 1]);
    let median = sorted[sorted.len() / 2];
    let lower = changes.iter().filter(|c| c.percent < 0.0).count();
    format!(
        "{} {} {by} {} % (at {}) to {} % (at {}) in {} cases, median {} %{}{}",
        verb.word(),
        md_code(key),
        verb.size(from.percent),
        from.case,
        verb.size(to.percent),
        to.case,
        changes.len(),
        verb.size(median.percent),
        if verb == Verb::Changes {
            format!(", lower in {lower} of them")
        } else {
            String::new()
        },
        if unmeasured {
            "; no noise estimate".to_string()
        } else {
            format!("; over the seeds {}", verdict_counts(changes))
        }
    )
}

/// `8 fall, 1 rises, 3 unclear`: how many cases have each verdict.
fn verdict_counts(changes: &[Change]) -> String {
    let counts: Vec<String> = [
        (Verdict::Falls, "fall", "falls"),
        (Verdict::Rises, "rise", "rises"),
        (Verdict::None, "none", "none"),
        (Verdict::Unclear, "unclear", "unclear"),
    ]
    .iter()
    .filter_map(|(v, many, one)| {
        let n = changes
            .iter()
            .filter(|c| c.noise.verdict() == Some(*v))
            .count();
        (n > 0).then(|| format!("{n} {}", if n == 1 { one } else { many }))
    })
    .collect();
    counts.join(", ")
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A case whose seeds changed by `per_seed` percent (their mean is the change).
    fn seeded(case: &str, per_seed: &[f64]) -> Change {
        Change {
            case: case.into(),
            percent: per_seed.iter().sum::<f64>() / per_seed.len() as f64,
            noise: Noise::Seeds(Paired::of(per_seed).ok()),
        }
    }

    fn unseeded(case: &str, percent: f64) -> Change {
        Change {
            case: case.into(),
            percent,
            noise: Noise::Unmeasured,
        }
    }

    #[test]
    fn an_effect_is_named_only_with_its_interval() {
        let down = [
            seeded("σt(d_min) 80", &[-60.0, -62.0, -64.0]),
            seeded("σt(d_min) 20", &[-17.0, -18.0, -19.0]),
        ];
        assert_eq!(
            predicate("disco_energy", &down),
            "lowers `disco_energy` by 62 % at σt(d_min) 80 (95 % CI 57 to 67 %), 18 % at σt(d_min) 20 (95 % CI 16 to 20 %)"
        );
        assert_eq!(
            predicate("time_render", &[seeded("", &[39.0, 40.0, 41.0])]),
            "raises `time_render` by 40 % (95 % CI 38 to 42 %)"
        );
        assert_eq!(
            predicate("ms_share", &[seeded("", &[0.1, 0.2, 0.3])]),
            "leaves `ms_share` within ±0.5 %: +0.2 % (95 % CI −0.048 to +0.4 %)"
        );
    }

    #[test]
    fn an_interval_near_0_keeps_two_digits() {
        assert_eq!(bound(0.031), "0.031");
        assert_eq!(bound(0.0049), "0.0049");
        assert_eq!(
            (bound(0.26), bound(12.4), bound(0.0)),
            ("0.3".into(), "12".into(), "0.0".into())
        );
        assert_eq!(signed_bound(-0.031), "−0.031");
        assert_eq!(
            predicate("ms_share", &[seeded("", &[-1.0, -2.0, -3.0, -1.9])]),
            "lowers `ms_share` by 2 % (95 % CI 0.7 to 3 %)"
        );
    }

    #[test]
    fn mixed_or_unclear_changes_give_each_verdict() {
        let mixed = [
            seeded("foot", &[-60.0, -62.0, -64.0]),
            seeded("head", &[-10.0, 40.0, 24.0]),
            seeded("engine", &[-5.0, -6.0]),
        ];
        assert_eq!(
            predicate("rmse", &mixed),
            "changes `rmse` by −62 % at foot (falls: 95 % CI −67 to −57 %), +18 % at head (unclear: 95 % CI −45 to +81 %), −6 % at engine (unclear: 2 seeds)"
        );
    }

    #[test]
    fn without_a_seed_axis_no_change_is_an_effect() {
        let down = [unseeded("foot", -62.4), unseeded("head", -18.0)];
        assert_eq!(
            predicate("rmse", &down),
            "changes `rmse` by −62 % at foot, −18 % at head (no noise estimate)"
        );
        let many: Vec<Change> = [-5.0, -30.0, -62.0, -12.0]
            .iter()
            .map(|p| unseeded(&format!("nused {}", -p), *p))
            .collect();
        assert_eq!(
            predicate("disco_energy", &many),
            "changes `disco_energy` by −62 % (at nused 62) to −5 % (at nused 5) in 4 cases, median −12 %, lower in 4 of them; no noise estimate"
        );
    }

    #[test]
    fn many_cases_are_given_by_their_range_median_and_verdicts() {
        let down: Vec<Change> = [-5.0, -30.0, -62.0, -12.0]
            .iter()
            .map(|p| seeded(&format!("nused {}", -p), &[p - 1.0, *p, p + 1.0]))
            .collect();
        assert_eq!(
            predicate("disco_energy", &down),
            "lowers `disco_energy` by 5 % (at nused 5) to 62 % (at nused 62) in 4 cases, median 30 %; over the seeds 4 fall"
        );
        let mut many: Vec<Change> = down;
        many.push(seeded("σt(d_min) 4", &[3.0, -10.0, 16.0]));
        assert_eq!(
            predicate("rmse", &many),
            "changes `rmse` by −62 % (at nused 62) to +3 % (at σt(d_min) 4) in 5 cases, median −12 %, lower in 4 of them; over the seeds 4 fall, 1 unclear"
        );
    }

    /// The report and `sweep claims` judge a change by one rule: a case is an effect
    /// exactly when the rule's verdict says so. The old test ("every seed moves the same
    /// way by more than twice the standard error") called two seeds an effect and a
    /// clear rise with one stray seed noise.
    #[test]
    fn the_report_uses_the_rule_of_the_claims() {
        let cases: [&[f64]; 4] = [
            &[-10.0, -11.0],
            &[-10.0, -12.0, -11.0],
            &[5.0, 5.2, 4.9, 5.1, 5.0, 4.8, 5.1, 5.0, -0.1],
            &[-1.0, -30.0, -2.0],
        ];
        for per_seed in cases {
            let change = seeded("", per_seed);
            let rule = Paired::of(per_seed).unwrap().verdict(Some(UNCHANGED));
            let sentence = predicate("rmse", std::slice::from_ref(&change));
            let expected = match rule {
                Verdict::Falls => "lowers",
                Verdict::Rises => "raises",
                Verdict::None => "leaves",
                Verdict::Unclear => "changes",
            };
            assert!(sentence.starts_with(expected), "{per_seed:?}: {sentence}");
        }
        assert_eq!(Noise::Seeds(None).verdict(), Some(Verdict::Unclear));
        assert!(ordered(&[serde_json::json!(6), serde_json::json!(true)]));
        assert!(!ordered(&[serde_json::json!("scenes/foot.toml")]));
    }
}
