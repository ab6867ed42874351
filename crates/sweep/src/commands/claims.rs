//! `sweep claims`: check (or `--update`) the numbers documents cite from the studies, or
//! list those that cite nothing (`--uncited`).

use std::process::ExitCode;

use anyhow::Result;

use crate::claims::{Checked, ClaimOptions, Outcome, check_document, uncited_numbers};
use crate::cli::ClaimsArgs;

/// Checks every document; fails when any claim differs from its data or cannot be checked.
pub(crate) fn run(args: &ClaimsArgs) -> Result<ExitCode> {
    if args.uncited {
        return uncited(args);
    }
    let options = ClaimOptions {
        base: args.base.clone(),
        update: args.update,
        allow_empty: args.allow_empty,
    };
    let mut wrong = 0;
    for document in &args.documents {
        let checked = check_document(document, &options)?;
        let count = |f: fn(&Outcome) -> bool| checked.iter().filter(|c| f(&c.outcome)).count();
        let differ = count(|o| matches!(o, Outcome::Differs(_) | Outcome::Coarse(_)));
        let hold = count(|o| matches!(o, Outcome::Holds(..)));
        let fail = count(|o| matches!(o, Outcome::Fails(..)));
        let verdicts = count(|o| matches!(o, Outcome::Judged(_)));
        let disagree = count(|o| matches!(o, Outcome::Judged(j) if !j.agrees()));
        let broken = count(|o| matches!(o, Outcome::Broken(_)));
        for c in &checked {
            if args.verbose || !c.outcome.is_right() {
                println!("{}", line(document.display(), c, args.update));
            }
        }
        println!(
            "{}: {} claims, {} agree with the data ({hold} conditions hold, {} verdicts agree), {differ} differ{}, {fail} conditions fail, {disagree} verdicts disagree, {broken} cannot be checked",
            document.display(),
            checked.len(),
            checked.len() - differ - broken - fail - disagree,
            verdicts - disagree,
            if args.update && differ > 0 {
                " (rewritten from the data)"
            } else {
                ""
            }
        );
        wrong += broken + fail + disagree + if args.update { 0 } else { differ };
    }
    Ok(if wrong == 0 {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    })
}

/// `--uncited`: every number that looks measured and carries no claim, and every comment
/// that hides text from the review (never closed, or not rendered as one comment).
fn uncited(args: &ClaimsArgs) -> Result<ExitCode> {
    let mut any = 0;
    for document in &args.documents {
        let text =
            volphot::read_text_capped(document, volphot::TEXT_INPUT_CAP, "Markdown document")?;
        let review = uncited_numbers(&text);
        for (line, why) in &review.problems {
            println!("{}:{line}: cannot be reviewed: {why}", document.display());
        }
        for u in &review.uncited {
            println!("{}:{}: {} has no claim", document.display(), u.line, u.text);
        }
        println!(
            "{}: {} numbers look measured and carry no claim, {} comments keep text from review",
            document.display(),
            review.uncited.len(),
            review.problems.len()
        );
        any += review.uncited.len() + review.problems.len();
    }
    Ok(if any == 0 {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    })
}

/// What a condition found: `holds: 0.031 > 0.012`.
fn condition(c: &Checked) -> String {
    let symbol = c
        .claim
        .as_ref()
        .and_then(|claim| crate::claims::comparison_of(&claim.query))
        .unwrap_or("?");
    match c.outcome {
        Outcome::Holds(a, b) => format!("holds: {a:.6} {symbol} {b:.6}"),
        Outcome::Fails(a, b) => {
            format!("does not hold on the data: {a:.6} {symbol} {b:.6} is false")
        }
        _ => String::new(),
    }
}

/// `FILE:LINE: cited 0.157, the data give 0.1612 (query)`.
fn line(file: impl std::fmt::Display, c: &Checked, updated: bool) -> String {
    let cited = c
        .claim
        .as_ref()
        .and_then(|claim| claim.cited.as_ref())
        .map_or("nothing".to_string(), |n| format!("{}", n.value));
    let what = match &c.outcome {
        Outcome::Agrees(v) => format!("cited {cited}, the data give {v:.6}"),
        Outcome::Differs(v) if updated => {
            format!("cited {cited}, the data give {v:.6}: rewritten")
        }
        Outcome::Differs(v) => format!(
            "cited {cited}, the data give {v:.6} (more than half a unit of its last digit apart)"
        ),
        Outcome::Coarse(v) if updated => {
            format!("cited {cited}, the data give {v:.6}: rewritten with two significant digits")
        }
        Outcome::Coarse(v) => format!(
            "cited {cited} has fewer than two significant digits and the data give {v:.6}: print two (`--update` does), or add a tolerance (`= … ± 0.5`)"
        ),
        Outcome::Holds(..) | Outcome::Fails(..) => condition(c),
        Outcome::Judged(j) if j.agrees() => format!(
            "verdict {} agrees with the rule: {}",
            j.declared.word(),
            j.numbers()
        ),
        Outcome::Judged(j) => format!(
            "the sentence says {}, the rule gives {} (a paired t-test at the 5 % level): {}",
            j.declared.word(),
            j.computed.word(),
            j.numbers()
        ),
        Outcome::Broken(why) => format!("cannot be checked: {why}"),
    };
    format!("{file}:{}: {what} — {}", c.line, c.query())
}
