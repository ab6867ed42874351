//! `sweep claims`: every number a document cites from a study is checked against the
//! committed data it comes from, and every comparison it draws against the seeds.
//!
//! A cited number carries its source as a comment right after it, invisible when the
//! Markdown is rendered:
//!
//! ```markdown
//! the share is 0.157<!-- = mean(single_vs_multiple-paper: ms_share where scene=skeleton,
//! sigma.t=6, integrator.multiple=true) --> at σt 6
//! ```
//!
//! The checked number is the last one before the comment on its line (in a table, in its
//! cell); it must equal the query's value to its printed precision (half a unit in its last
//! digit), or within an explicit `± tolerance` after the query. A number printed with fewer
//! than two significant digits must be exact or carry a tolerance (`1×` does not pass for
//! 1.24). A condition, `<!-- holds: min_over(seed: A - B) > 0 -->`, must hold on the data,
//! and a verdict, `<!-- verdict: falls over(integrator.seed: A - B) -->`, must be the word
//! the one rule for an effect over seeds gives ([`crate::analyse::Verdict`]).
//! The query language is in [`expr`]; its sources are read by [`source`], confined to the
//! document's folder. With `--update`, numbers that differ are rewritten from the data in
//! the same form ([`update`]).

mod cited;
mod document;
mod expr;
#[cfg(test)]
mod fuzz;
mod quote;
mod source;
mod uncited;
mod update;

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};

use crate::analyse::{Paired, Verdict};
pub(crate) use cited::Cited;
pub(crate) use document::{Claim, Found};
use expr::{Assertion, VerdictClaim};
use source::{DocumentData, Sources};
pub(crate) use uncited::uncited_numbers;

/// What checking a claim found.
#[derive(Debug, Clone)]
pub(crate) enum Outcome {
    /// The data give the cited number.
    Agrees(f64),
    /// The data give another number.
    Differs(f64),
    /// The number is printed with fewer than two significant digits and the data do not
    /// give it exactly: `--update` prints it with two.
    Coarse(f64),
    /// A condition holds: its two sides' values.
    Holds(f64, f64),
    /// A condition fails on the data: its two sides' values.
    Fails(f64, f64),
    /// A verdict's word against the rule's (they agree or not).
    Judged(Judgement),
    /// The claim cannot be checked: no number before it, a bad query, missing data, a
    /// malformed comment.
    Broken(String),
}

impl Outcome {
    /// Whether the claim is right as written: the number agrees, the condition holds, the
    /// verdict is the rule's.
    pub(crate) fn is_right(&self) -> bool {
        match self {
            Outcome::Agrees(_) | Outcome::Holds(..) => true,
            Outcome::Judged(j) => j.agrees(),
            _ => false,
        }
    }
}

/// What the effect rule made of a verdict's differences.
#[derive(Debug, Clone)]
pub(crate) struct Judgement {
    /// The word the document writes.
    pub(crate) declared: Verdict,
    /// The word the rule gives.
    pub(crate) computed: Verdict,
    /// The key the differences are paired over.
    pub(crate) key: String,
    pub(crate) paired: Paired,
    pub(crate) delta: Option<f64>,
}

impl Judgement {
    pub(crate) fn agrees(&self) -> bool {
        self.declared == self.computed
    }

    /// `n 8 seeds, mean −0.0123, 95 % interval −0.0151 to −0.0095, δ 0.005`.
    pub(crate) fn numbers(&self) -> String {
        let p = &self.paired;
        let interval = match p.interval {
            Some((low, high)) => format!("95 % interval {} to {}", sig(low), sig(high)),
            None => "no interval (one value)".to_string(),
        };
        let few = if p.n < crate::analyse::MIN_SEEDS {
            format!(
                " (fewer than {} values: too few to tell)",
                crate::analyse::MIN_SEEDS
            )
        } else {
            String::new()
        };
        let delta = self
            .delta
            .map_or("no δ".to_string(), |d| format!("δ {}", sig(d)));
        format!(
            "n {} values of {}{few}, mean {}, {interval}, {delta}",
            p.n,
            self.key,
            sig(p.mean)
        )
    }
}

/// A number with four significant digits, in scientific form when very large or small.
fn sig(v: f64) -> String {
    if v == 0.0 {
        return "0".into();
    }
    let magnitude = v.abs().log10().floor() as i32;
    if !(-4..6).contains(&magnitude) {
        return format!("{v:.3e}");
    }
    format!("{v:.*}", (3 - magnitude).max(0) as usize)
}

/// A claim and its outcome.
#[derive(Debug, Clone)]
pub(crate) struct Checked {
    /// 1-based line of the claim.
    pub(crate) line: usize,
    /// The claim (none: a malformed comment, whose outcome says why).
    pub(crate) claim: Option<Claim>,
    pub(crate) outcome: Outcome,
}

impl Checked {
    /// The query as written (empty for a malformed comment).
    pub(crate) fn query(&self) -> &str {
        self.claim.as_ref().map_or("", |c| c.query.as_str())
    }
}

/// How `sweep claims` checks a document.
#[derive(Debug, Clone, Default)]
pub(crate) struct ClaimOptions {
    /// The folder sources are relative to (default: the document's).
    pub(crate) base: Option<PathBuf>,
    /// Rewrite numbers that differ from their data.
    pub(crate) update: bool,
    /// A document without claims is fine (else an error: a checked document should cite).
    pub(crate) allow_empty: bool,
}

/// Checks every claim of a document's `text` against the data: sources relative to `from`,
/// inside `root`.
pub(crate) fn check_text(text: &str, from: &Path, root: &Path) -> Result<Vec<Checked>> {
    let mut sources = Sources::new(from, root)?;
    Ok(document::claims_in(text)
        .into_iter()
        .map(|found| match found {
            Found::Claim(claim) => Checked {
                line: claim.line,
                outcome: evaluate(&claim, &mut sources),
                claim: Some(claim),
            },
            Found::Malformed { line, why } => Checked {
                line,
                claim: None,
                outcome: Outcome::Broken(why),
            },
        })
        .collect())
}

fn evaluate(claim: &Claim, sources: &mut Sources) -> Outcome {
    let assertion = match expr::parse_assertion(&claim.query) {
        Ok(a) => a,
        Err(e) => return Outcome::Broken(format!("{e:#}")),
    };
    let mut data = DocumentData { sources };
    let mut eval = |e: &expr::Expr| -> Result<f64> {
        let v = e.eval(&mut data)?;
        if !v.is_finite() {
            bail!("the query gives {v}");
        }
        Ok(v)
    };
    match assertion {
        Assertion::Equals { expr, tolerance } => {
            let Some(cited) = &claim.cited else {
                return Outcome::Broken("no number before the claim on its line".into());
            };
            if let Some(problem) = &cited.problem {
                return Outcome::Broken(format!("the cited number: {problem}"));
            }
            match eval(&expr) {
                Err(e) => Outcome::Broken(format!("{e:#}")),
                Ok(v) => compare(cited, tolerance, v),
            }
        }
        Assertion::Holds(left, comparison, right) => match (eval(&left), eval(&right)) {
            (Ok(a), Ok(b)) if comparison.holds(a, b) => Outcome::Holds(a, b),
            (Ok(a), Ok(b)) => Outcome::Fails(a, b),
            (Err(e), _) | (_, Err(e)) => Outcome::Broken(format!("{e:#}")),
        },
        Assertion::Verdict(v) => match judge(v, &mut data) {
            Ok(j) => Outcome::Judged(j),
            Err(e) => Outcome::Broken(format!("{e:#}")),
        },
    }
}

/// The rule's verdict on a verdict claim's differences, one per value of its key.
fn judge(v: VerdictClaim, data: &mut DocumentData) -> Result<Judgement> {
    let differences: Vec<f64> = v
        .expr
        .per_group(data, &[], &v.key)
        .with_context(|| format!("verdict over({}: …)", v.key))?
        .into_iter()
        .map(|(_, d)| d)
        .collect();
    let paired = Paired::of(&differences).with_context(|| format!("verdict over({}: …)", v.key))?;
    Ok(Judgement {
        declared: v.declared,
        computed: paired.verdict(v.delta),
        key: v.key,
        paired,
        delta: v.delta,
    })
}

/// The comparison a condition's query makes (`>` for `holds: a > b`), if it parses.
pub(crate) fn comparison_of(query: &str) -> Option<&'static str> {
    match expr::parse_assertion(query).ok()? {
        Assertion::Holds(_, c, _) => Some(c.symbol()),
        Assertion::Equals { .. } | Assertion::Verdict(_) => None,
    }
}

/// A cited number against the data's value.
fn compare(cited: &Cited, tolerance: Option<f64>, v: f64) -> Outcome {
    match tolerance {
        Some(t) if (v - cited.value).abs() <= t * (1.0 + 1e-9) => Outcome::Agrees(v),
        Some(t) => Outcome::Broken(format!(
            "cited {} ± {t}, the data give {v:.6}: outside the tolerance (fix the number or the tolerance by hand)",
            cited.value
        )),
        None if cited.significant < 2 && cited.equals_exactly(v) => Outcome::Agrees(v),
        None if cited.significant < 2 => Outcome::Coarse(v),
        None if cited.agrees(v) => Outcome::Agrees(v),
        None => Outcome::Differs(v),
    }
}

/// The document with every differing number rewritten from its data, in the same form;
/// everything else, line endings included, byte for byte as it was.
pub(crate) fn updated(text: &str, checked: &[Checked]) -> String {
    let mut edits: Vec<(usize, usize, String)> = checked
        .iter()
        .filter_map(|c| match (&c.outcome, &c.claim) {
            (Outcome::Differs(v), Some(claim)) => claim.cited.as_ref().map(|cited| {
                (
                    claim.line_start + cited.span.0,
                    claim.line_start + cited.span.1,
                    cited.reprinted(*v),
                )
            }),
            (Outcome::Coarse(v), Some(claim)) => claim.cited.as_ref().map(|cited| {
                (
                    claim.line_start + cited.span.0,
                    claim.line_start + cited.span.1,
                    cited.two_significant(*v).format(*v),
                )
            }),
            _ => None,
        })
        .collect();
    // Left to right in one pass: the text between edits is copied once (a rewrite in
    // place moved the rest of the document for every edit).
    edits.sort_by_key(|e| e.0);
    let mut out = String::with_capacity(text.len());
    let mut copied = 0;
    for (start, end, new) in edits {
        if start < copied {
            continue;
        }
        out.push_str(&text[copied..start]);
        out.push_str(&new);
        copied = end;
    }
    out.push_str(&text[copied..]);
    crate::spans::work::add(text.len() + out.len());
    out
}

/// Where a document's sources start and the folder they must stay in: `--base` for both,
/// else the document's folder, inside the git repository that holds it (or inside that
/// folder alone when no repository does).
fn folders(document: &Path, base: Option<&Path>) -> Result<(PathBuf, PathBuf)> {
    if let Some(base) = base {
        return Ok((base.to_path_buf(), base.to_path_buf()));
    }
    let folder = document
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .map_or(PathBuf::from("."), Path::to_path_buf);
    let real = std::fs::canonicalize(&folder)
        .with_context(|| format!("the folder of {}", document.display()))?;
    let root = crate::confine::repository_of(&real)
        .with_context(|| format!("the folder of {}", document.display()))?;
    Ok((real, root))
}

/// Reads, checks and (with `update`) rewrites a document; returns its checked claims.
pub(crate) fn check_document(path: &Path, options: &ClaimOptions) -> Result<Vec<Checked>> {
    let (from, root) = folders(path, options.base.as_deref())?;
    let checked = if options.update {
        update::locked(path, |text| {
            let checked = check_text(text, &from, &root)?;
            let differs = checked
                .iter()
                .any(|c| matches!(c.outcome, Outcome::Differs(_) | Outcome::Coarse(_)));
            let new = differs.then(|| updated(text, &checked));
            Ok((checked, new))
        })?
    } else {
        let text = volphot::read_text_capped(path, volphot::TEXT_INPUT_CAP, "Markdown document")?;
        check_text(&text, &from, &root)?
    };
    if checked.is_empty() && !options.allow_empty {
        bail!(
            "{}: no claims (no `<!-- = … -->` after a cited number); a checked document cites its numbers, or pass --allow-empty",
            path.display()
        );
    }
    Ok(checked)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spans::work;

    fn study(dir: &Path) {
        let s = dir.join("s");
        std::fs::create_dir_all(&s).unwrap();
        std::fs::write(
            s.join("cells.csv"),
            "cell,nused,seed,rmse [W/(m2 sr)]\n0,25,1,0.0312\n1,150,1,0.0125\n2,150,2,0.0131\n3,25,2,0.0120\n",
        )
        .unwrap();
    }

    fn outcomes(doc: &Path, options: &ClaimOptions) -> Vec<Outcome> {
        check_document(doc, options)
            .unwrap()
            .into_iter()
            .map(|c| c.outcome)
            .collect()
    }

    #[test]
    fn a_perturbed_number_differs_and_update_restores_it() {
        let dir = tempfile::tempdir().unwrap();
        study(dir.path());
        let doc = dir.path().join("paper.md");
        let good = "RMSE 0.0312<!-- = value(s: rmse where nused=25, seed=1) --> at nused 25,\r\n\
                    falling by 59 %<!-- = 100 * (1 - mean(s: rmse where nused=150) / value(s: rmse where nused=25, seed=1)) -->.\r\n";
        std::fs::write(&doc, good).unwrap();
        let all_agree = |o: &[Outcome]| o.iter().all(|o| matches!(o, Outcome::Agrees(_)));
        assert!(all_agree(&outcomes(&doc, &ClaimOptions::default())));
        std::fs::write(&doc, good.replace("0.0312", "0.0321")).unwrap();
        let update = ClaimOptions {
            update: true,
            ..ClaimOptions::default()
        };
        let o = outcomes(&doc, &update);
        assert!(matches!(o[0], Outcome::Differs(v) if v == 0.0312));
        assert_eq!(
            std::fs::read_to_string(&doc).unwrap(),
            good,
            "restored, CRLF kept"
        );
        std::fs::write(&doc, "RMSE 0.03<!-- = value(s: rmse where nused=150) -->\n").unwrap();
        let o = outcomes(&doc, &ClaimOptions::default());
        assert!(
            matches!(&o[0], Outcome::Broken(m) if m.contains("2 rows match")),
            "{o:?}"
        );
    }

    /// Issue "Conclusions that hold up", part 5: the holes of `sweep claims`.
    #[test]
    fn zero_rows_coarse_numbers_and_unsupported_orderings_fail() {
        let dir = tempfile::tempdir().unwrap();
        study(dir.path());
        let doc = dir.path().join("paper.md");
        let cases = [
            // A mistyped filter value counted no rows and "agreed" with 0.
            (
                "0<!-- = count(s: cell where nused=105) -->",
                "no row matches",
            ),
            // One significant digit: 1 for 1.244 passed.
            (
                "1×<!-- = value(s: rmse where nused=25, seed=1) / 0.025 -->",
                "coarse",
            ),
            // nused 150 is better than 25 for seed 1 but not for seed 2.
            (
                "<!-- holds: min_over(seed: value(s: rmse where nused=25) - value(s: rmse where nused=150)) > 0 -->",
                "",
            ),
        ];
        for (text, says) in cases {
            std::fs::write(&doc, format!("x {text}\n")).unwrap();
            let o = outcomes(&doc, &ClaimOptions::default());
            match &o[0] {
                Outcome::Broken(m) => assert!(m.contains(says), "{text}: {m}"),
                Outcome::Coarse(v) => assert!(says == "coarse" && (v - 1.248).abs() < 1e-9),
                Outcome::Fails(a, b) => assert!(says.is_empty() && a <= b, "{text}"),
                other => panic!("{text}: {other:?}"),
            }
        }
        // The same with a tolerance, an exact count, and the ordering that holds on average.
        std::fs::write(
            &doc,
            "1×<!-- = value(s: rmse where nused=25, seed=1) / 0.025 ± 0.3 --> 4<!-- = count(s: cell) -->\n\
             <!-- holds: mean(s: rmse where nused=25) > mean(s: rmse where nused=150) -->\n",
        )
        .unwrap();
        let o = outcomes(&doc, &ClaimOptions::default());
        assert!(matches!(o[0], Outcome::Agrees(_)), "{o:?}");
        assert!(matches!(o[1], Outcome::Agrees(_)), "{o:?}");
        assert!(matches!(o[2], Outcome::Holds(_, _)), "{o:?}");
        // --update prints a coarse number with two significant digits.
        std::fs::write(
            &doc,
            "1×<!-- = value(s: rmse where nused=25, seed=1) / 0.025 -->\n",
        )
        .unwrap();
        let update = ClaimOptions {
            update: true,
            ..ClaimOptions::default()
        };
        check_document(&doc, &update).unwrap();
        assert!(
            std::fs::read_to_string(&doc)
                .unwrap()
                .starts_with("1.2×<!--")
        );
        assert!(matches!(
            outcomes(&doc, &ClaimOptions::default())[0],
            Outcome::Agrees(_)
        ));
    }

    #[test]
    fn a_document_without_claims_is_an_error_unless_allowed() {
        let dir = tempfile::tempdir().unwrap();
        let doc = dir.path().join("empty.md");
        std::fs::write(&doc, "no numbers cited here\n").unwrap();
        let e = check_document(&doc, &ClaimOptions::default()).unwrap_err();
        assert!(e.to_string().contains("no claims"), "{e}");
        let allowed = ClaimOptions {
            allow_empty: true,
            ..ClaimOptions::default()
        };
        assert!(check_document(&doc, &allowed).unwrap().is_empty());
    }

    /// A study `v` whose cells are (seed, side, x): the verdict tests' data.
    fn paired_study(dir: &Path, a: &[f64], b: &[f64]) {
        let s = dir.join("v");
        std::fs::create_dir_all(&s).unwrap();
        let mut csv = String::from("cell,integrator.seed,side,x [1]\n");
        for (side, values) in [("a", a), ("b", b)] {
            for (i, v) in values.iter().enumerate() {
                csv += &format!("{},{},{side},{v}\n", csv.lines().count() - 1, i + 1);
            }
        }
        std::fs::write(s.join("cells.csv"), csv).unwrap();
    }

    const DIFFERENCE: &str = "value(v: x where side=a) - value(v: x where side=b)";

    /// The outcome of `comment` (one claim) over a paired study of sides `a` and `b`.
    fn verdict_of(a: &[f64], b: &[f64], comment: &str) -> Outcome {
        let dir = tempfile::tempdir().unwrap();
        paired_study(dir.path(), a, b);
        let doc = dir.path().join("paper.md");
        std::fs::write(&doc, format!("It falls.<!-- {comment} -->\n")).unwrap();
        let mut o = outcomes(&doc, &ClaimOptions::default());
        assert_eq!(o.len(), 1, "{o:?}");
        o.remove(0)
    }

    /// Whether the one verdict claim agrees (panics when it cannot be checked).
    fn agrees(a: &[f64], b: &[f64], comment: &str) -> bool {
        match verdict_of(a, b, comment) {
            Outcome::Judged(j) => j.agrees(),
            other => panic!("{comment}: {other:?}"),
        }
    }

    /// The principal issue's noise rule: each word agrees where the rule gives it and fails
    /// where it does not.
    #[test]
    fn each_verdict_word_agrees_or_fails_by_the_rule() {
        let base = [1.0, 1.0, 1.0, 1.0];
        let over = format!("over(integrator.seed: {DIFFERENCE})");
        // a − b per seed: clearly up, clearly down, near 0, and wide.
        let up = [1.9, 2.1, 2.0, 2.05];
        let down = [0.1, -0.1, 0.0, 0.05];
        let flat = [1.001, 0.999, 1.0005, 0.9995];
        let wide = [1.5, 0.4, 1.9, 0.6];
        for (a, word, agrees_with) in [
            (&up, "rises", true),
            (&up, "falls", false),
            (&down, "falls", true),
            (&down, "rises", false),
            (&flat, "none within 0.01", true),
            (&flat, "none within 0.0001", false),
            (&wide, "unclear within 0.01", true),
            (&wide, "rises", false),
            (&flat, "unclear within 0.01", false),
            (&up, "unclear within 0.01", false),
        ] {
            let comment = format!("verdict: {word} {over}");
            assert_eq!(agrees(a, &base, &comment), agrees_with, "{a:?}: {comment}");
        }
        // The failure names both words and the numbers behind them.
        let Outcome::Judged(j) = verdict_of(&wide, &base, &format!("verdict: rises {over}")) else {
            panic!("not judged")
        };
        assert_eq!((j.declared, j.computed), (Verdict::Rises, Verdict::Unclear));
        let numbers = j.numbers();
        for part in [
            "n 4 values of integrator.seed",
            "mean 0.1000",
            "95 % interval",
            "no δ",
        ] {
            assert!(numbers.contains(part), "{part} not in {numbers}");
        }
    }

    #[test]
    fn two_seeds_are_unclear_and_no_spread_is_a_point() {
        let over = format!("over(integrator.seed: {DIFFERENCE})");
        // Two seeds that both rise a lot: too few to tell.
        let two = ([3.0, 3.1], [1.0, 1.0]);
        assert!(!agrees(&two.0, &two.1, &format!("verdict: rises {over}")));
        assert!(agrees(
            &two.0,
            &two.1,
            &format!("verdict: unclear within 0.1 {over}")
        ));
        // Every seed changes by exactly the same: s = 0.
        let (same_a, same_b) = ([2.0, 3.0, 4.0], [1.0, 2.0, 3.0]);
        assert!(agrees(&same_a, &same_b, &format!("verdict: rises {over}")));
        assert!(agrees(&same_b, &same_a, &format!("verdict: falls {over}")));
        assert!(agrees(
            &same_a,
            &same_a,
            &format!("verdict: none within 0.001 {over}")
        ));
        assert!(!agrees(
            &same_a,
            &same_a,
            &format!("verdict: unclear within 0.001 {over}")
        ));
    }

    #[test]
    fn verdict_syntax_mistakes_and_a_nan_seed_are_errors() {
        let over = format!("over(integrator.seed: {DIFFERENCE})");
        let (a, b) = ([2.0, 2.1, 2.2], [1.0, 1.0, 1.0]);
        for (comment, says) in [
            (format!("verdict: none {over}"), "needs `within δ`"),
            (format!("verdict: unclear {over}"), "needs `within δ`"),
            (
                format!("verdict: rises within 0.1 {over}"),
                "takes no `within δ`",
            ),
            (
                format!("verdict: up {over}"),
                "expected rises, falls, none or unclear",
            ),
            (format!("verdict: none within 0 {over}"), "positive"),
            (
                format!("verdict: rises min_over(integrator.seed: {DIFFERENCE})"),
                "expected `over(",
            ),
            (
                "verdict: rises over(integrator.seed: 1 - 2)".to_string(),
                "reads no data",
            ),
        ] {
            match verdict_of(&a, &b, &comment) {
                Outcome::Broken(m) => assert!(m.contains(says), "{comment}: {m}"),
                other => panic!("{comment}: {other:?}"),
            }
        }
        // A seed whose difference is 0/0 is an error naming the seed, not a seed left out.
        let ratio = "over(integrator.seed: (value(v: x where side=a) - 1) / (value(v: x where side=b) - 1))";
        match verdict_of(
            &[2.0, 1.0, 3.0],
            &[2.0, 1.0, 3.0],
            &format!("verdict: none within 0.5 {ratio}"),
        ) {
            Outcome::Broken(m) => {
                assert!(m.contains("integrator.seed=2") && m.contains("NaN"), "{m}")
            }
            other => panic!("{other:?}"),
        }
    }

    /// The interval, t and n as numbers a document can cite.
    #[test]
    fn the_interval_is_a_citable_number() {
        let dir = tempfile::tempdir().unwrap();
        // a − b = 1, 2, 3: mean 2, sd 1, se 1/√3, t(2) = 4.303.
        paired_study(dir.path(), &[2.0, 4.0, 6.0], &[1.0, 2.0, 3.0]);
        let doc = dir.path().join("paper.md");
        let q = |f: &str| format!("{f}_over(integrator.seed: {DIFFERENCE})");
        std::fs::write(
            &doc,
            format!(
                "from −0.484<!-- = {} --> to 4.484<!-- = {} -->, t 3.464<!-- = {} --> over 3<!-- = {} --> seeds\n",
                q("ci_low"),
                q("ci_high"),
                q("t"),
                q("n")
            ),
        )
        .unwrap();
        let o = outcomes(&doc, &ClaimOptions::default());
        assert!(o.iter().all(|o| matches!(o, Outcome::Agrees(_))), "{o:?}");
    }

    /// Case 16 of the fifth reliability round: a NaN seed or cell was dropped by min, max
    /// and median (median sorted it last), and the condition held.
    #[test]
    fn a_nan_seed_or_cell_is_refused_by_every_aggregate() {
        let dir = tempfile::tempdir().unwrap();
        let s = dir.path().join("n");
        std::fs::create_dir_all(&s).unwrap();
        std::fs::write(
            s.join("cells.csv"),
            "cell,seed,a,b,c\n0,1,1,1,0.7\n1,2,0,0,NaN\n2,3,3,2,0.9\n3,4,2,2,0.8\n",
        )
        .unwrap();
        let doc = dir.path().join("paper.md");
        for claim in [
            "holds: min_over(seed: value(n: a) / value(n: b)) >= 0.5",
            "holds: max_over(seed: value(n: a) / value(n: b)) <= 1.5",
            "holds: median_over(seed: value(n: a) / value(n: b)) >= 0.5",
            "holds: min(n: c) >= 0.5",
            "holds: max(n: c) <= 0.95",
            "holds: median(n: c) <= 0.86",
            "holds: mean(n: c) <= 0.85",
        ] {
            std::fs::write(&doc, format!("x<!-- {claim} -->\n")).unwrap();
            match &outcomes(&doc, &ClaimOptions::default())[0] {
                Outcome::Broken(m) => assert!(m.contains("NaN"), "{claim}: {m}"),
                other => panic!("{claim}: {other:?}"),
            }
        }
    }

    /// Case 17: a condition between numbers written in it read no data and "agreed".
    #[test]
    fn a_claim_that_reads_no_data_is_an_error() {
        let dir = tempfile::tempdir().unwrap();
        study(dir.path());
        let doc = dir.path().join("paper.md");
        for claim in ["holds: 1 < 2", "holds: 2 * (3 - 1) >= 4", "= 6 / 2"] {
            std::fs::write(&doc, format!("3<!-- {claim} -->\n")).unwrap();
            match &outcomes(&doc, &ClaimOptions::default())[0] {
                Outcome::Broken(m) => assert!(m.contains("reads no data"), "{claim}: {m}"),
                other => panic!("{claim}: {other:?}"),
            }
        }
        std::fs::write(&doc, "x<!-- holds: count(s: cell) > 3 -->\n").unwrap();
        assert!(matches!(
            outcomes(&doc, &ClaimOptions::default())[0],
            Outcome::Holds(..)
        ));
    }

    /// Case 8: `--update` moved the rest of the document for every rewritten number.
    #[test]
    fn updating_is_linear_in_the_document() {
        work::assert_linear("updated", 2000, 1.1, |n| {
            let line = "RMSE 0.0321<!-- = value(s: rmse where nused=25, seed=1) --> x\n";
            let text = line.repeat(n);
            let checked: Vec<Checked> = document::claims_in(&text)
                .into_iter()
                .map(|f| match f {
                    Found::Claim(claim) => Checked {
                        line: claim.line,
                        claim: Some(claim),
                        outcome: Outcome::Differs(0.0312),
                    },
                    Found::Malformed { why, .. } => panic!("{why}"),
                })
                .collect();
            let mut new = String::new();
            let steps = work::of(|| new = updated(&text, &checked));
            assert_eq!(new, text.replace("0.0321", "0.0312"));
            steps
        });
    }
}
