//! The paper's and the README's numbers against the committed data (`sweep claims`): every
//! cited number carries its query, and a number that no longer matches the data fails CI,
//! naming its line.

use std::path::Path;

use volphot_tests::{sweep, workspace};

/// The documents whose cited numbers CI checks.
const DOCUMENTS: [&str; 4] = [
    "reports/REPRODUCTION.md",
    "README.md",
    "docs/performance.md",
    "docs/peer.md",
];

/// `N claims` from `sweep claims`'s summary line of `document`.
fn claims_of(stdout: &str, document: &str) -> usize {
    stdout
        .lines()
        .find(|l| l.starts_with(document))
        .and_then(|l| l.split(": ").nth(1)?.split(' ').next()?.parse().ok())
        .unwrap_or_else(|| panic!("no summary for {document} in {stdout}"))
}

#[test]
fn the_documents_cite_the_committed_data() {
    let out = sweep().arg("claims").args(DOCUMENTS).output().unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "a cited number disagrees with its data:\n{stdout}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    // The paper rests on its numbers, the README's and the performance notes' bench tables
    // on the committed bench JSON: a check that finds few would pass vacuously.
    assert!(claims_of(&stdout, DOCUMENTS[0]) >= 300, "{stdout}");
    assert!(claims_of(&stdout, DOCUMENTS[1]) >= 20, "{stdout}");
    assert!(claims_of(&stdout, DOCUMENTS[2]) >= 20, "{stdout}");
    assert!(claims_of(&stdout, DOCUMENTS[3]) >= 6, "{stdout}");
}

/// A copy of the paper with its first cited number changed fails, naming that line, the
/// cited and the recomputed value.
#[test]
fn a_perturbed_number_fails_naming_its_line() {
    let paper = std::fs::read_to_string(workspace().join(DOCUMENTS[0])).unwrap();
    let at = paper.find("<!-- =").expect("the paper cites numbers");
    // The digit right before the comment (its number's last digit), changed by one.
    let digit_at = paper[..at]
        .char_indices()
        .rev()
        .find(|(_, c)| c.is_ascii_digit())
        .map(|(i, _)| i)
        .unwrap();
    let digit = paper.as_bytes()[digit_at] - b'0';
    let mut perturbed = paper.clone();
    perturbed.replace_range(digit_at..digit_at + 1, &((digit + 1) % 10).to_string());
    let line = paper[..digit_at].matches('\n').count() + 1;
    let dir = tempfile::tempdir().unwrap();
    let copy = dir.path().join("REPRODUCTION.md");
    std::fs::write(&copy, perturbed).unwrap();
    let out = sweep()
        .arg("claims")
        .arg(&copy)
        .arg("--base")
        .arg(workspace().join("reports"))
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        !out.status.success(),
        "the perturbed paper passed:\n{stdout}"
    );
    let named = format!("REPRODUCTION.md:{line}: cited");
    assert!(stdout.contains(&named), "{named:?} not in:\n{stdout}");
    assert!(stdout.contains("the data give"), "{stdout}");
    assert!(Path::new(&copy).is_file());
}
