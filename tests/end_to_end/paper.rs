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

/// The cells of a GitHub-flavoured Markdown table row: split at every `|` that no
/// backslash escapes (GFM splits there even inside code spans and HTML comments).
fn table_cells(row: &str) -> usize {
    let row = row.trim();
    let mut count = 0;
    let mut escaped = false;
    for c in row.chars() {
        match c {
            '\\' if !escaped => {
                escaped = true;
                continue;
            }
            '|' if !escaped => count += 1,
            _ => {}
        }
        escaped = false;
    }
    // `| a | b |` has three pipes for two cells; a row without its outer pipes has one
    // pipe fewer per missing end.
    let outer = usize::from(row.starts_with('|')) + usize::from(row.ends_with('|'));
    count + 1 - outer
}

/// Issue "Conclusions that hold up", part 1: a claim's `|` split GitHub's table rows, and
/// queries showed as text. Every row of every table of every checked document has its
/// header's cells, and cmark-gfm (comrak) renders no comment delimiter as text.
#[test]
fn the_documents_render_as_github_renders_them() {
    for document in DOCUMENTS {
        let text = std::fs::read_to_string(workspace().join(document)).unwrap();
        let lines: Vec<&str> = text.lines().collect();
        let mut rows = 0;
        for (i, pair) in lines.windows(2).enumerate() {
            let is_delimiter = pair[1].trim().starts_with("|-") || pair[1].trim().starts_with("|:");
            if !(pair[0].trim_start().starts_with('|') && is_delimiter) {
                continue;
            }
            let header = table_cells(pair[0]);
            for (k, row) in lines[i + 2..]
                .iter()
                .take_while(|l| l.trim_start().starts_with('|'))
                .enumerate()
            {
                assert_eq!(
                    table_cells(row),
                    header,
                    "{document}:{}: a row of {} cells under a header of {header}",
                    i + 3 + k,
                    table_cells(row)
                );
                rows += 1;
            }
        }
        assert!(rows > 0, "{document}: no table rows");
        let mut options = comrak::Options::default();
        options.extension.table = true;
        options.extension.strikethrough = true;
        options.extension.autolink = true;
        options.extension.tasklist = true;
        let html = comrak::markdown_to_html(&text, &options);
        for visible in ["&lt;!--", "--&gt;", "where scene="] {
            assert!(
                !html.contains(visible),
                "{document}: `{visible}` is visible text where GitHub renders it"
            );
        }
    }
}

#[test]
fn the_row_check_counts_cells_as_github_does() {
    assert_eq!(table_cells("| a | b |"), 2);
    assert_eq!(table_cells("a | b"), 2);
    assert_eq!(table_cells("| 1<!-- = v(s: x | k=1) --> | b |"), 3);
    assert_eq!(table_cells("| a \\| b | c |"), 2);
}

/// Issue "Conclusions that hold up", part 8: report.md and report.html of every study
/// carried the absolute paths of the machine that rendered them. No committed result does:
/// datasets are named with their sha256, files by their names or paths in the repository.
#[test]
fn no_committed_result_carries_a_machine_path() {
    let out = std::process::Command::new("git")
        .args(["ls-files", "-z", "reports"])
        .current_dir(workspace())
        .output()
        .unwrap();
    let files: Vec<String> = String::from_utf8_lossy(&out.stdout)
        .split('\0')
        .filter(|f| !f.is_empty() && !f.ends_with(".png"))
        .map(str::to_string)
        .collect();
    assert!(
        files.len() > 100,
        "git lists {} files under reports/",
        files.len()
    );
    let roots = [
        "/home/", "/root/", "/tmp/", "/work/", "/Users/", "/mnt/", "/var/", "/opt/", "/srv/",
    ];
    let mut found = Vec::new();
    for file in &files {
        let Ok(text) = std::fs::read_to_string(workspace().join(file)) else {
            continue;
        };
        for (n, line) in text.lines().enumerate() {
            for root in roots {
                // A path begins a word: after a space, a quote, a bracket, `=` or `:`.
                let starts_path = line.match_indices(root).any(|(i, _)| {
                    i == 0
                        || line[..i]
                            .chars()
                            .last()
                            .is_some_and(|c| " \"'(=:[,".contains(c))
                });
                if starts_path {
                    found.push(format!(
                        "{file}:{}: {}",
                        n + 1,
                        &line[..line.len().min(120)]
                    ));
                }
            }
        }
    }
    assert!(
        found.is_empty(),
        "machine paths in committed results:\n{}",
        found.join("\n")
    );
}

/// Issue "Conclusions that hold up", part 5: no number measured from data is typed by hand
/// in the checked documents: `sweep claims --uncited` lists none.
#[test]
fn no_measured_number_is_left_without_its_source() {
    let out = sweep()
        .arg("claims")
        .arg("--uncited")
        .args(DOCUMENTS)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "numbers without a claim:\n{}",
        String::from_utf8_lossy(&out.stdout)
    );
}
