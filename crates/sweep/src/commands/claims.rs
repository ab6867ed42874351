//! `sweep claims`: check (or `--update`) the numbers documents cite from the studies.

use std::process::ExitCode;

use anyhow::Result;

use crate::claims::{Checked, Outcome, check_document};
use crate::cli::ClaimsArgs;

/// Checks every document; fails when any claim differs from its data or cannot be checked.
pub(crate) fn run(args: &ClaimsArgs) -> Result<ExitCode> {
    let mut wrong = 0;
    for document in &args.documents {
        let checked = check_document(document, args.base.as_deref(), args.update)?;
        let count = |f: fn(&Outcome) -> bool| checked.iter().filter(|c| f(&c.outcome)).count();
        let differ = count(|o| matches!(o, Outcome::Differs(_)));
        let broken = count(|o| matches!(o, Outcome::Broken(_)));
        for c in &checked {
            if args.verbose || !matches!(c.outcome, Outcome::Agrees(_)) {
                println!("{}", line(document.display(), c, args.update));
            }
        }
        println!(
            "{}: {} claims, {} agree with the data, {differ} differ{}, {broken} cannot be checked",
            document.display(),
            checked.len(),
            checked.len() - differ - broken,
            if args.update && differ > 0 {
                " (rewritten from the data)"
            } else {
                ""
            }
        );
        wrong += broken + if args.update { 0 } else { differ };
    }
    Ok(if wrong == 0 {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    })
}

/// `FILE:LINE: cited 0.157, the data give 0.1612 (query)`.
fn line(file: impl std::fmt::Display, c: &Checked, updated: bool) -> String {
    let cited = c
        .claim
        .cited
        .as_ref()
        .map_or("nothing".to_string(), |n| format!("{}", n.value));
    let what = match &c.outcome {
        Outcome::Agrees(v) => format!("cited {cited}, the data give {v:.6}"),
        Outcome::Differs(v) if updated => {
            format!("cited {cited}, the data give {v:.6}: rewritten")
        }
        Outcome::Differs(v) => format!(
            "cited {cited}, the data give {v:.6} (more than half a unit of its last digit apart)"
        ),
        Outcome::Broken(why) => format!("cannot be checked: {why}"),
    };
    format!("{file}:{}: {what} — {}", c.claim.line, c.claim.query)
}
