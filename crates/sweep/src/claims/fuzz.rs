//! Property tests of `sweep claims`: generated documents mix prose, tables and code with
//! valid, invalid and hostile claim comments (sources outside the folder, deep nesting,
//! numbers beyond a double, `|` in tables, unclosed comments) over a small study, a JSON
//! file, a FIFO and a sparse 3 GiB file. Each document is checked and updated without a
//! panic, a hang or an allocation of a gigabyte; a run must see documents that pass and
//! documents that fail.

use std::path::Path;

use proptest::prelude::*;

use super::{ClaimOptions, Outcome, check_document};
use crate::fuzz::run;

const CI_CASES: u32 = 600;

fn query() -> impl Strategy<Value = String> {
    prop_oneof![
        Just("value(s: rmse where nused=25, seed=1)".to_string()),
        Just("mean(s: rmse where nused=150)".to_string()),
        Just("count(s: cell)".to_string()),
        Just("count(s: cell where nused=105)".to_string()),
        Just(
            "min_over(seed: value(s: rmse where nused=25) - value(s: rmse where nused=150))"
                .to_string()
        ),
        Just("sd_over(seed: mean(s: rmse))".to_string()),
        Just(
            "ci_low_over(seed: mean(s: rmse where nused=25) - mean(s: rmse where nused=150))"
                .to_string()
        ),
        Just("value(s: rmse where nused=25) / value(s: zero where nused=25)".to_string()),
        Just("mean(s: nan)".to_string()),
        Just("value(b.json: machine.cores)".to_string()),
        Just("value(b.json: runs.s where name=a)".to_string()),
        Just("value(s: rmse | nused=25)".to_string()),
        Just("value(../outside.csv: v)".to_string()),
        Just("value(/etc/passwd: root)".to_string()),
        Just("value(fifo.csv: v)".to_string()),
        Just("value(sparse.csv: v)".to_string()),
        Just("value(s: secret)".to_string()),
        Just("avg(s: rmse)".to_string()),
        Just("1e400".to_string()),
        Just("2 * (3 + 4".to_string()),
        (1usize..60).prop_map(|n| format!("{}1{}", "(".repeat(n), ")".repeat(n))),
        (1usize..200).prop_map(|n| format!("{}1", "-".repeat(n))),
        (1usize..3000).prop_map(|n| vec!["1"; n].join("+")),
    ]
}

fn verdict() -> impl Strategy<Value = String> {
    prop_oneof![
        Just("rises".to_string()),
        Just("falls".to_string()),
        Just("none within 0.005".to_string()),
        Just("unclear within 0.01".to_string()),
        Just("none".to_string()),
        Just("rises within 1".to_string()),
        Just("up".to_string()),
        Just("unclear within -1".to_string()),
    ]
}

fn number() -> impl Strategy<Value = String> {
    prop_oneof![
        Just("0.0312".to_string()),
        Just("0.0128".to_string()),
        Just("4".to_string()),
        Just("2".to_string()),
        Just("1×".to_string()),
        Just("1e400".to_string()),
        Just("1e-400".to_string()),
        Just("7·10⁻¹⁰⁹⁷²⁶²⁵⁷²".to_string()),
        Just("−0.5".to_string()),
        Just("10\u{202f}308".to_string()),
        Just(String::new()),
    ]
}

fn piece() -> impl Strategy<Value = String> {
    prop_oneof![
        3 => (number(), query()).prop_map(|(n, q)| format!("{n}<!-- = {q} -->")),
        1 => (number(), query()).prop_map(|(n, q)| format!("{n}<!--={q}-->")),
        1 => query().prop_map(|q| format!("<!-- holds: {q} > 0 -->")),
        1 => (verdict(), query()).prop_map(|(v, q)| format!("<!-- verdict: {v} over(seed: {q}) -->")),
        1 => query().prop_map(|q| format!("<!-- {q} -->")),
        1 => query().prop_map(|q| format!("1<!-- = {q}")),
        1 => (number(), query()).prop_map(|(n, q)| format!("\n| a | b |\n|---|---|\n| {n}<!-- = {q} --> | x |\n")),
        1 => query().prop_map(|q| format!("`3<!-- = {q} -->`")),
        1 => Just("\n```\n5<!-- = value(x: y) -->\n```\n".to_string()),
        2 => Just(" some prose, ".to_string()),
        1 => Just("\r\n".to_string()),
        1 => Just("\n\n".to_string()),
    ]
}

fn document() -> impl Strategy<Value = String> {
    prop::collection::vec(piece(), 0..8).prop_map(|p| p.concat())
}

/// The study, JSON, FIFO and sparse file the generated claims name.
fn fixtures(dir: &Path) {
    let study = dir.join("s");
    std::fs::create_dir_all(&study).unwrap();
    std::fs::write(
        study.join("cells.csv"),
        "cell,nused,seed,rmse [1],secret,zero,nan\n0,25,1,0.0312,hunter2,0,NaN\n1,150,1,0.0125,x,0,1\n2,150,2,0.0131,y,0,2\n3,25,2,0.0120,z,0,3\n",
    )
    .unwrap();
    std::fs::write(
        dir.join("b.json"),
        r#"{"machine": {"cores": 2}, "runs": [{"name": "a", "s": 1.5}, {"name": "b", "s": 2}]}"#,
    )
    .unwrap();
    let fifo = dir.join("fifo.csv");
    if !fifo.exists() {
        let _ = std::process::Command::new("mkfifo").arg(&fifo).status();
    }
    let sparse = std::fs::File::create(dir.join("sparse.csv")).unwrap();
    sparse.set_len(3 << 30).unwrap();
    let outside = dir.parent().unwrap().join("outside.csv");
    std::fs::write(outside, "v\n1\n").unwrap();
}

/// Checks a document and updates a copy of it; accepted when every claim holds.
fn check(dir: &Path, text: String) -> Result<bool, String> {
    let docs = dir.join("docs");
    let doc = docs.join(format!("d{}.md", std::process::id()));
    std::fs::write(&doc, &text).unwrap();
    let options = ClaimOptions {
        base: Some(docs.clone()),
        ..ClaimOptions::default()
    };
    let checked = check_document(&doc, &options);
    let update = ClaimOptions {
        update: true,
        ..options.clone()
    };
    let _ = check_document(&doc, &update);
    // Nothing a source holds is quoted beyond a few bytes.
    if let Err(e) = &checked
        && format!("{e:#}").contains("hunter2")
    {
        return Err(format!("an error quotes a value: {e:#}"));
    }
    if let Ok(c) = &checked
        && let Some(m) = c.iter().find_map(|c| match &c.outcome {
            Outcome::Broken(m) if m.contains("hunter2") => Some(m),
            _ => None,
        })
    {
        return Err(format!("a claim's error quotes a value: {m}"));
    }
    Ok(checked.is_ok_and(|c| c.iter().all(|c| c.outcome.is_right())))
}

fn fuzz(cases: u32) {
    let root = tempfile::tempdir().unwrap();
    let docs = root.path().join("work").join("docs");
    std::fs::create_dir_all(&docs).unwrap();
    fixtures(&docs);
    run(
        "claims",
        &root.path().join("work"),
        cases,
        document(),
        check,
    );
}

#[test]
fn fuzz_claim_documents() {
    fuzz(CI_CASES);
}

#[test]
#[ignore = "long run: cargo test --release -p volphot-sweep fuzz -- --ignored"]
fn fuzz_claim_documents_long() {
    fuzz(50_000);
}
