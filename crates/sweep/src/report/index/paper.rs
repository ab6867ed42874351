//! What the index takes from the paper (`REPRODUCTION.md`): which study answers which claim
//! (its "What was run" table), each claim's verdict (its "Verdicts" table), and the paper
//! itself as a page. The index is ordered as the paper is and says what the paper says: it
//! never retypes a verdict.

use std::path::{Path, PathBuf};

use anyhow::Result;

use super::super::escape;

/// One row of the paper's "What was run" table.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Entry {
    /// What the study is, as the paper names it (`disco balls`).
    pub(crate) label: String,
    /// The claims it answers, in the paper's order (`§1.1`, `C1`, …).
    pub(crate) claims: Vec<String>,
    /// Its folders (`artifacts-paper`).
    pub(crate) folders: Vec<String>,
}

/// What the index knows from the paper.
#[derive(Debug, Clone, Default)]
pub(crate) struct Paper {
    pub(crate) entries: Vec<Entry>,
    /// Each claim's verdict, its first (bold) phrase: `C1` → `reproduced in trend, …`.
    pub(crate) verdicts: Vec<(String, String)>,
    /// The §1.1 answer's closing paragraph (`So the measurements support …`) as Markdown,
    /// if any.
    pub(crate) answer: Option<String>,
}

impl Paper {
    /// The verdict of a claim.
    pub(crate) fn verdict(&self, claim: &str) -> Option<&str> {
        self.verdicts
            .iter()
            .find(|(c, _)| c == claim)
            .map(|(_, v)| v.as_str())
    }

    /// The paper's entry of a study folder (`artifacts-paper` or its default-quality
    /// sibling `artifacts`).
    pub(crate) fn entry_of(&self, folder: &str) -> Option<(usize, &Entry)> {
        let base = folder.strip_suffix("-paper").unwrap_or(folder);
        self.entries.iter().enumerate().find(|(_, e)| {
            e.folders
                .iter()
                .any(|f| f == folder || f.strip_suffix("-paper").unwrap_or(f) == base)
        })
    }
}

/// The cells of a Markdown table row, without the claims' comments.
fn cells(row: &str) -> Vec<String> {
    let mut row = row.trim().to_string();
    while let Some(open) = row.find("<!--") {
        let close = row[open..].find("-->").map_or(row.len(), |c| open + c + 3);
        row.replace_range(open..close, "");
    }
    row.trim_matches('|')
        .split('|')
        .map(|c| c.trim().to_string())
        .collect()
}

/// The rows of the table that follows the heading `heading`.
fn table_after<'a>(markdown: &'a str, heading: &str) -> Vec<&'a str> {
    let Some(at) = markdown.find(heading) else {
        return Vec::new();
    };
    markdown[at..]
        .lines()
        .skip_while(|l| !l.trim_start().starts_with('|'))
        .take_while(|l| l.trim_start().starts_with('|'))
        .skip(2)
        .collect()
}

/// `C1–C3, C5, §1.1` → `§1.1, C1, C2, C3, C5` (the paper's order: the question first).
fn claims_in(text: &str) -> Vec<String> {
    let mut claims = Vec::new();
    if text.contains("§1.1") {
        claims.push("§1.1".to_string());
    }
    let chars: Vec<char> = text.chars().collect();
    let mut i = 0;
    let number = |i: &mut usize| -> Option<u32> {
        let start = *i;
        while chars.get(*i).is_some_and(char::is_ascii_digit) {
            *i += 1;
        }
        chars[start..*i].iter().collect::<String>().parse().ok()
    };
    let mut numbers = Vec::new();
    while i < chars.len() {
        if chars[i] == 'C' && chars.get(i + 1).is_some_and(char::is_ascii_digit) {
            i += 1;
            let Some(first) = number(&mut i) else {
                continue;
            };
            let mut last = first;
            if matches!(chars.get(i), Some('–' | '-')) && chars.get(i + 1) == Some(&'C') {
                i += 2;
                last = number(&mut i).unwrap_or(first);
            }
            numbers.extend(first..=last.max(first));
            continue;
        }
        i += 1;
    }
    numbers.sort_unstable();
    numbers.dedup();
    claims.extend(numbers.into_iter().map(|n| format!("C{n}")));
    claims
}

/// Text of a Markdown cell as plain text: emphasis and code marks dropped.
fn plain(text: &str) -> String {
    text.replace("**", "").replace('`', "").trim().to_string()
}

/// Reads what the index needs from the paper's Markdown.
pub(crate) fn parse(markdown: &str) -> Paper {
    let entries = table_after(markdown, "## What was run")
        .into_iter()
        .filter_map(|row| {
            let c = cells(row);
            let (label_cell, folder_cell) = (c.first()?, c.get(1)?);
            let folders: Vec<String> = folder_cell
                .split('`')
                .skip(1)
                .step_by(2)
                .map(|f| f.trim_end_matches('/').to_string())
                .filter(|f| !f.is_empty())
                .collect();
            let label = label_cell
                .split(" (")
                .next()
                .unwrap_or(label_cell)
                .trim()
                .to_string();
            Some(Entry {
                label,
                claims: claims_in(label_cell),
                folders,
            })
        })
        .collect();
    let verdicts = table_after(markdown, "## Verdicts")
        .into_iter()
        .filter_map(|row| {
            let c = cells(row);
            let verdict = c.get(2)?;
            let short = verdict
                .strip_prefix("**")
                .and_then(|v| v.split("**").next())
                .unwrap_or(verdict);
            Some((plain(c.first()?), plain(short)))
        })
        .collect();
    let answer = markdown
        .lines()
        .find(|l| l.starts_with("So the measurements"))
        .map(|first| {
            let at = markdown.find(first).unwrap_or(0);
            let paragraph = markdown[at..].split("\n\n").next().unwrap_or(first);
            paragraph.split_whitespace().collect::<Vec<_>>().join(" ")
        });
    Paper {
        entries,
        verdicts,
        answer,
    }
}

/// `REPRODUCTION.md` as a page beside it, through the pages' one sanitiser
/// ([`escape::page_html`]: GitHub's tables and footnotes, the claims' comments dropped, raw
/// HTML shown as text, only relative and http(s) links, no attribute from the text), so the
/// paper reads in a browser from a clone; `None` without the paper.
pub(crate) fn write_page(root: &Path, markdown: Option<&str>) -> Result<Option<PathBuf>> {
    let Some(markdown) = markdown else {
        return Ok(None);
    };
    let body = escape::page_html(markdown);
    let html = format!(
        "<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>volphot: reproducing the 2006 study</title><style>{PAPER_STYLE}</style></head><body>\n<p><a href=\"./index.html\">← all studies</a></p>\n{body}</body></html>\n"
    );
    let path = root.join("REPRODUCTION.html");
    volphot::write_atomic(&path, html.as_bytes())?;
    Ok(Some(path))
}

/// The paper's answer paragraph as HTML through the pages' one sanitiser
/// ([`escape::page_events`]: raw HTML as text, the claims' comments dropped), without its
/// paragraph tags; each link to a section of the paper (`[words](#section)`) becomes a link
/// to the paper's `page` (whose headings carry no ids), any other link keeps its words.
pub(crate) fn answer_html(answer: &str, page: &str) -> String {
    use pulldown_cmark::{CowStr, Event, Tag, TagEnd};
    let mut dropped = Vec::new();
    let events = escape::page_events(answer)
        .into_iter()
        .filter_map(|event| match event {
            Event::Start(Tag::Paragraph) | Event::End(TagEnd::Paragraph) => None,
            Event::Start(Tag::Link {
                link_type,
                dest_url,
                title,
                id,
            }) => {
                let section = dest_url.starts_with('#');
                dropped.push(!section);
                section.then(|| {
                    Event::Start(Tag::Link {
                        link_type,
                        dest_url: CowStr::from(page.to_string()),
                        title,
                        id,
                    })
                })
            }
            Event::End(TagEnd::Link) => (!dropped.pop().unwrap_or(false)).then_some(event),
            event => Some(event),
        });
    let mut html = String::new();
    pulldown_cmark::html::push_html(&mut html, events);
    html
}

const PAPER_STYLE: &str = "body{font-family:serif;max-width:860px;margin:2em auto;padding:0 1em;color:#222;line-height:1.45}\
table{border-collapse:collapse;font-size:0.9em;margin:1em 0;display:block;overflow-x:auto}td,th{border:1px solid #ccc;padding:2px 6px}\
th{background:#eee}img{max-width:100%}code{background:#f3f3f3;padding:0 3px;font-size:0.9em}";

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_answer_links_to_the_paper_instead_of_showing_markdown() {
        let html = answer_html(
            "So it <b>stays</b> ([the answer under cinematic light](#the-answer-under-cinematic-light)) and [x](https://example.org/)<!-- = value(s: c) -->.",
            "./REPRODUCTION.html",
        );
        assert_eq!(
            html,
            "So it &lt;b&gt;stays&lt;/b&gt; (<a href=\"./REPRODUCTION.html\">the answer under cinematic light</a>) and x."
        );
    }

    const PAPER: &str = "# P\n\n## The answer (§1.1)\n\nSo the measurements support the thesis's cautious answer:\nGI helps the engine.\n\n## Verdicts\n\n| claim | the thesis says | verdict |\n|---|---|---|\n| C1 | balls | **reproduced in trend**: they fade |\n| C8 | per dataset | **partly**: x |\n\n## What was run\n\n| study | folder | grid | cells |\n|---|---|---|---|\n| disco balls (C1–C3, C5) | `artifacts-paper/` | … | 648<!-- = count(a: b) --> |\n| single against multiple (C8, C9, §1.1) | `single_vs_multiple-paper/` | … | 32 |\n| tuned settings | `tune_foot/`, `tune_thesis/` | … | 1 |\n";

    #[test]
    fn reads_the_studies_their_claims_and_the_verdicts() {
        let p = parse(PAPER);
        assert_eq!(p.entries.len(), 3);
        assert_eq!(p.entries[0].claims, ["C1", "C2", "C3", "C5"]);
        assert_eq!(p.entries[1].claims, ["§1.1", "C8", "C9"]);
        assert_eq!(p.entries[2].folders, ["tune_foot", "tune_thesis"]);
        assert_eq!(p.verdict("C1"), Some("reproduced in trend"));
        assert_eq!(p.entry_of("artifacts").map(|(i, _)| i), Some(0));
        assert!(p.answer.unwrap().starts_with("So the measurements support"));
    }

    /// Row 3 of the fifth reliability round: `## Details {tabindex=0 autofocus onfocus=…}`
    /// in the paper put a live handler on its page, run on load.
    #[test]
    fn heading_attributes_never_reach_the_paper_page() {
        let dir = tempfile::tempdir().unwrap();
        let markdown = "# Paper\n\n## Details {tabindex=0 autofocus onfocus=alert(1)}\n\n## Cover {#explorer .x style=\"position:fixed;inset:0\" onclick=alert(2)}\n";
        let path = write_page(dir.path(), Some(markdown)).unwrap().unwrap();
        let html = std::fs::read_to_string(path).unwrap();
        let body = html.split("<body>").nth(1).unwrap();
        // No heading carries an attribute: the braces stay text, as a code host shows them.
        assert!(!body.contains("<h2 ") && !body.contains("<h1 "), "{body}");
        assert!(body.contains("<h2>Details {tabindex=0"), "{body}");
    }
}
