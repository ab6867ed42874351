//! `sweep claims`: every number a document cites from a study is checked against the
//! committed data it comes from.
//!
//! A cited number carries its source as a comment right after it, invisible when the
//! Markdown is rendered:
//!
//! ```markdown
//! the share is 0.157<!-- = mean(single_vs_multiple-paper: ms_share | scene=skeleton,
//! sigma.t=6, integrator.multiple=true) --> at σt 6
//! ```
//!
//! The checked number is the last one before the comment on its line (in a table, in its
//! cell); it must equal the query's value to its printed precision (half a unit in its last
//! digit). The query language is in [`expr`]; its sources are read by [`source`]. With
//! `--update`, numbers that differ are rewritten from the data in the same form.

mod cited;
mod expr;
mod source;

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};

pub(crate) use cited::Cited;
use source::Sources;

/// The comment that carries a claim's query.
const OPEN: &str = "<!-- =";
const CLOSE: &str = "-->";

/// One claim of a document.
#[derive(Debug, Clone)]
pub(crate) struct Claim {
    /// 1-based line of the comment.
    pub(crate) line: usize,
    /// The number it checks (none: the comment follows no number).
    pub(crate) cited: Option<Cited>,
    /// The query as written.
    pub(crate) query: String,
}

/// What checking a claim found.
#[derive(Debug, Clone)]
pub(crate) enum Outcome {
    /// The data give the cited number.
    Agrees(f64),
    /// The data give another number.
    Differs(f64),
    /// The claim cannot be checked: no number before it, a bad query, missing data.
    Broken(String),
}

/// A claim and its outcome.
#[derive(Debug, Clone)]
pub(crate) struct Checked {
    pub(crate) claim: Claim,
    pub(crate) outcome: Outcome,
}

/// Every claim of a Markdown text (outside fenced code blocks).
pub(crate) fn claims_in(text: &str) -> Vec<Claim> {
    let mut claims = Vec::new();
    let mut fenced = false;
    for (i, line) in text.lines().enumerate() {
        if line.trim_start().starts_with("```") {
            fenced = !fenced;
            continue;
        }
        if fenced {
            continue;
        }
        let mut from = 0;
        while let Some(open) = line[from..].find(OPEN).map(|o| o + from) {
            let Some(close) = line[open..].find(CLOSE).map(|c| c + open) else {
                break;
            };
            // The number is in the text since the previous claim or table cell.
            let cell_start = line[from..open].rfind('|').map_or(from, |p| from + p + 1);
            let cited = cited::last_number(&line[cell_start..open]).map(|mut c| {
                c.span = (c.span.0 + cell_start, c.span.1 + cell_start);
                c
            });
            claims.push(Claim {
                line: i + 1,
                cited,
                query: line[open + OPEN.len()..close].trim().to_string(),
            });
            from = close + CLOSE.len();
        }
    }
    claims
}

/// Checks every claim of the document at `path` against the data, with sources relative to
/// `base` (default: the document's folder).
pub(crate) fn check(path: &Path, base: Option<&Path>) -> Result<Vec<Checked>> {
    let text = volphot::read_text_capped(path, volphot::TEXT_INPUT_CAP, "Markdown document")?;
    let base: PathBuf = match base {
        Some(b) => b.to_path_buf(),
        None => path.parent().map_or(PathBuf::from("."), Path::to_path_buf),
    };
    let mut sources = Sources::default();
    Ok(claims_in(&text)
        .into_iter()
        .map(|claim| {
            let outcome = evaluate(&claim, &base, &mut sources);
            Checked { claim, outcome }
        })
        .collect())
}

fn evaluate(claim: &Claim, base: &Path, sources: &mut Sources) -> Outcome {
    let Some(cited) = &claim.cited else {
        return Outcome::Broken("no number before the claim on its line".into());
    };
    let value = expr::parse(&claim.query).and_then(|e| {
        e.eval(&mut |call| {
            let values = sources.values(base, call)?;
            call.aggregate.apply(&values)
        })
    });
    match value {
        Ok(v) if !v.is_finite() => Outcome::Broken(format!("the query gives {v}")),
        Ok(v) if cited.agrees(v) => Outcome::Agrees(v),
        Ok(v) => Outcome::Differs(v),
        Err(e) => Outcome::Broken(format!("{e:#}")),
    }
}

/// The document with every differing number rewritten from its data, in the same form.
pub(crate) fn updated(text: &str, checked: &[Checked]) -> String {
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    // Right to left within a line, so earlier spans stay valid.
    let mut edits: Vec<(usize, (usize, usize), String)> = checked
        .iter()
        .filter_map(|c| match (&c.outcome, &c.claim.cited) {
            (Outcome::Differs(v), Some(cited)) => {
                Some((c.claim.line - 1, cited.span, cited.format(*v)))
            }
            _ => None,
        })
        .collect();
    edits.sort_by(|a, b| (a.0, b.1.0).cmp(&(b.0, a.1.0)));
    for (line, (start, end), new) in edits {
        lines[line].replace_range(start..end, &new);
    }
    let mut out = lines.join("\n");
    if text.ends_with('\n') {
        out.push('\n');
    }
    out
}

/// Reads, checks and (with `update`) rewrites a document; returns its checked claims.
pub(crate) fn check_document(
    path: &Path,
    base: Option<&Path>,
    update: bool,
) -> Result<Vec<Checked>> {
    let checked = check(path, base)?;
    if update
        && checked
            .iter()
            .any(|c| matches!(c.outcome, Outcome::Differs(_)))
    {
        let text =
            std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
        volphot::write_atomic(path, updated(&text, &checked).as_bytes())?;
    }
    Ok(checked)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn study(dir: &Path) {
        let s = dir.join("s");
        std::fs::create_dir_all(&s).unwrap();
        std::fs::write(
            s.join("cells.csv"),
            "cell,nused,rmse [W/(m2 sr)]\n0,25,0.0312\n1,150,0.0125\n2,150,0.0131\n",
        )
        .unwrap();
    }

    #[test]
    fn claims_are_found_after_their_numbers_in_text_and_tables() {
        let text = "a 0.03<!-- = value(s: rmse | nused=25) --> and 2<!-- = count(s: cell | nused=150) -->\n\
                    ```\n7<!-- = value(s: x) -->\n```\n\
                    | 150 | 0.0128<!-- = mean(s: rmse | nused=150) --> |\n\
                    | 9 | <!-- = value(s: rmse) --> |\n";
        let claims = claims_in(text);
        assert_eq!(claims.len(), 4, "{claims:?}");
        assert_eq!(claims[0].cited.as_ref().unwrap().value, 0.03);
        assert_eq!(claims[1].cited.as_ref().unwrap().value, 2.0);
        assert_eq!(claims[2].line, 5);
        assert_eq!(claims[2].cited.as_ref().unwrap().value, 0.0128);
        assert!(
            claims[3].cited.is_none(),
            "the number of another cell is not taken"
        );
    }

    #[test]
    fn a_perturbed_number_differs_and_update_restores_it() {
        let dir = tempfile::tempdir().unwrap();
        study(dir.path());
        let doc = dir.path().join("paper.md");
        let good = "RMSE 0.0312<!-- = value(s: rmse | nused=25) --> at nused 25, \
                    falling by 59 %<!-- = 100 * (1 - mean(s: rmse | nused=150) / value(s: rmse | nused=25)) -->.\n";
        std::fs::write(&doc, good).unwrap();
        let checked = check_document(&doc, None, false).unwrap();
        assert!(
            checked
                .iter()
                .all(|c| matches!(c.outcome, Outcome::Agrees(_))),
            "{checked:?}"
        );
        std::fs::write(&doc, good.replace("0.0312", "0.0321")).unwrap();
        let checked = check_document(&doc, None, true).unwrap();
        assert!(matches!(checked[0].outcome, Outcome::Differs(v) if v == 0.0312));
        assert_eq!(std::fs::read_to_string(&doc).unwrap(), good);
        std::fs::write(&doc, "RMSE 0.03<!-- = value(s: rmse | nused=150) -->\n").unwrap();
        let checked = check_document(&doc, None, false).unwrap();
        assert!(
            matches!(&checked[0].outcome, Outcome::Broken(m) if m.contains("2 rows match")),
            "{checked:?}"
        );
    }
}
