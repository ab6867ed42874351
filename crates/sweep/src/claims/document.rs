//! Finding a document's claims as a reader's renderer sees them.
//!
//! A claim is an HTML comment right after the number it checks. The comments are found in
//! the raw text, and each is checked against what a CommonMark renderer with GitHub's
//! tables (pulldown-cmark) makes of the document: a claim must render as one hidden
//! comment. A `|` inside a comment on a table row splits the row there (GitHub does the
//! same), and the query would show as text in the cells; such a claim is an error, as is
//! any comment that opens like a claim and does not parse, or a comment never closed.
//! Comments inside code (spans and blocks) are examples, not claims.

use std::ops::Range;

use pulldown_cmark::{Event, Options, Parser, Tag};

use super::cited::{self, Cited};
use crate::spans::{Lines, Spans, work};

/// A claim comment.
#[derive(Debug, Clone)]
pub(crate) struct Claim {
    /// 1-based line of the comment's opening.
    pub(crate) line: usize,
    /// The number it checks: the last one before the comment on its line, in its table
    /// cell, after any earlier claim (none: the comment follows no number).
    pub(crate) cited: Option<Cited>,
    /// Byte offset of the cited number's line in the document (its span is relative to it).
    pub(crate) line_start: usize,
    /// What the comment says (between `<!--` and `-->`), trimmed.
    pub(crate) query: String,
}

/// What the scan finds: a claim, or a comment that should be one and is not.
#[derive(Debug, Clone)]
pub(crate) enum Found {
    Claim(Claim),
    Malformed { line: usize, why: String },
}

/// The options GitHub renders a document with (its Markdown is CommonMark plus tables,
/// strikethrough, task lists, footnotes and autolinks).
pub(crate) fn github_options() -> Options {
    Options::ENABLE_TABLES
        | Options::ENABLE_STRIKETHROUGH
        | Options::ENABLE_TASKLISTS
        | Options::ENABLE_FOOTNOTES
}

/// Where the rendered document holds code (literal text) and raw HTML.
pub(crate) struct Rendered {
    pub(crate) code: Spans,
    pub(crate) html: Spans,
}

pub(crate) fn rendered(text: &str) -> Rendered {
    let mut code = Vec::new();
    let mut html: Vec<Range<usize>> = Vec::new();
    for (event, range) in Parser::new_ext(text, github_options()).into_offset_iter() {
        match event {
            Event::Code(_) | Event::Start(Tag::CodeBlock(_)) => code.push(range),
            Event::Html(_) | Event::InlineHtml(_) | Event::Start(Tag::HtmlBlock) => {
                // Consecutive pieces of one HTML block (or one multi-line comment) join.
                match html.last_mut() {
                    Some(last)
                        if range.start <= last.end
                            || text[last.end..range.start].trim().is_empty() =>
                    {
                        work::add(range.start.saturating_sub(last.end));
                        last.end = last.end.max(range.end);
                    }
                    _ => html.push(range),
                }
            }
            _ => {}
        }
    }
    Rendered {
        code: Spans::new(code),
        html: Spans::new(html),
    }
}

/// The kinds of claim comment, by how they start.
const KINDS: [&str; 3] = ["=", "holds", "verdict"];

/// Whether a comment's text reads like a query (an aggregate call with a source).
fn looks_like_claim(text: &str) -> bool {
    const NAMES: [&str; 12] = [
        "value", "mean", "min", "max", "sum", "count", "median", "sd", "se", "spread", "_over",
        "over",
    ];
    text.contains(':')
        && NAMES.iter().any(|n| {
            text.match_indices(n).any(|(i, _)| {
                text[i + n.len()..].trim_start().starts_with('(')
                    && !text[..i].ends_with(|c: char| c.is_ascii_alphanumeric())
            })
        })
}

/// Every claim (and every broken claim) of a Markdown text, in order. Linear in the text:
/// each comment is found once, its line and its code or HTML context by binary search, and
/// its number in the text since the previous claim.
pub(crate) fn claims_in(text: &str) -> Vec<Found> {
    let rendered = rendered(text);
    let lines = Lines::new(text);
    let mut found = Vec::new();
    // Where the number of the next claim on the same line may start.
    let mut after_previous = 0;
    let mut from = 0;
    while let Some(open) = text[from..].find("<!--").map(|o| o + from) {
        work::add(open + 4 - from);
        from = open + 4;
        if rendered.code.contains(open) {
            continue;
        }
        let line = lines.number(open);
        let Some(close) = text[open + 4..].find("-->").map(|c| c + open + 4) else {
            found.push(Found::Malformed {
                line,
                why: "an HTML comment is opened here and never closed (`-->`): a renderer hides the rest of the document".into(),
            });
            break;
        };
        work::add(close + 3 - from);
        let content = text[open + 4..close].trim();
        from = close + 3;
        if !KINDS.iter().any(|k| content.starts_with(k)) {
            if looks_like_claim(content) {
                found.push(Found::Malformed {
                    line,
                    why: "this comment reads like a claim but starts with none of `=` (a cited number), `holds:` (a condition) and `verdict:` (an effect over seeds)".into(),
                });
            }
            continue;
        }
        if !rendered.html.covers(&(open..close + 3)) {
            found.push(Found::Malformed {
                line,
                why: "this claim does not render as one hidden comment: a table row is split at every `|` (filters follow `where`), and a comment must not contain `--`".into(),
            });
            continue;
        }
        let line_start = lines.start(open);
        let segment_start = line_start.max(after_previous);
        let segment = &text[segment_start..open];
        work::add(segment.len());
        // In a table, the number is in the comment's own cell.
        let cell_start = segment.rfind('|').map_or(0, |p| p + 1);
        let cited = cited::last_number(&segment[cell_start..]).map(|mut c| {
            let shift = segment_start + cell_start - line_start;
            c.span = (c.span.0 + shift, c.span.1 + shift);
            c
        });
        found.push(Found::Claim(Claim {
            line,
            cited,
            line_start,
            query: content.to_string(),
        }));
        after_previous = close + 3;
    }
    found
}

#[cfg(test)]
mod tests {
    use super::*;

    fn claims(text: &str) -> Vec<Claim> {
        claims_in(text)
            .into_iter()
            .map(|f| match f {
                Found::Claim(c) => c,
                Found::Malformed { line, why } => panic!("line {line}: {why}"),
            })
            .collect()
    }

    fn malformed(text: &str) -> Vec<String> {
        claims_in(text)
            .into_iter()
            .filter_map(|f| match f {
                Found::Malformed { why, .. } => Some(why),
                Found::Claim(_) => None,
            })
            .collect()
    }

    #[test]
    fn claims_are_found_after_their_numbers_in_text_and_tables() {
        let text = "a 0.03<!-- = value(s: rmse where nused=25) --> and 2<!-- = count(s: cell where nused=150) -->\n\
                    \n```\n7<!-- = value(s: x) -->\n```\n\n\
                    | a | b |\n|---|---|\n\
                    | 150 | 0.0128<!-- = mean(s: rmse where nused=150) --> |\n\
                    | 9 | <!-- = value(s: rmse) --> |\n\n\
                    `<!-- = value(s: example) -->` in code is an example.\n";
        let claims = claims(text);
        assert_eq!(claims.len(), 4, "{claims:?}");
        assert_eq!(claims[0].cited.as_ref().unwrap().value, 0.03);
        assert_eq!(claims[1].cited.as_ref().unwrap().value, 2.0);
        assert_eq!(claims[2].line, 9);
        assert_eq!(claims[2].cited.as_ref().unwrap().value, 0.0128);
        assert!(
            claims[3].cited.is_none(),
            "the number of another cell is not taken"
        );
    }

    /// Issue "Conclusions that hold up", and case 11 of the fourth reliability round: a
    /// typo turned a claim into an ordinary comment, and a `|` broke the table it was in.
    #[test]
    fn comments_that_should_be_claims_are_errors() {
        // No space, more spaces, over two lines: still claims.
        let ok = claims(
            "a 1<!--= value(s: x) --> b 2<!--   = value(s: y) --> c 3<!-- = value(s:\nz) -->\n",
        );
        assert_eq!(ok.len(), 3);
        assert_eq!(ok[2].cited.as_ref().unwrap().value, 3.0);
        for (text, says) in [
            ("a 1<!-- value(s: x) -->\n", "reads like a claim"),
            ("a 1<!-- = value(s: x)\n\nmore text\n", "never closed"),
            (
                "| a | b |\n|---|---|\n| 1<!-- = value(s: x | k=1) --> | 2 |\n",
                "split at every `|`",
            ),
        ] {
            let m = malformed(text);
            assert!(m.iter().any(|w| w.contains(says)), "{text:?}: {m:?}");
        }
        assert!(malformed("<!-- an ordinary note -->\n").is_empty());
    }

    /// Case 8 of the fifth reliability round: a document of 111 000 claims timed out: each
    /// comment searched every code span and HTML block and counted the lines before it.
    #[test]
    fn finding_claims_is_linear_in_the_document() {
        let piece =
            "a `x` 0.03<!-- = value(s: rmse where nused=25) --> <b>b</b> `<!-- = value(s: y) -->` ";
        for lines in [true, false] {
            work::assert_linear("claims_in", 1000, 1.2, |n| {
                let text = if lines {
                    format!("{piece}\n").repeat(n)
                } else {
                    piece.repeat(n)
                };
                let mut found = Vec::new();
                let steps = work::of(|| found = claims_in(&text));
                assert_eq!(claims(&text).len(), n);
                assert_eq!(found.len(), n);
                steps
            });
        }
    }

    #[test]
    fn verdicts_are_claims() {
        let c = claims("It falls.<!-- verdict: falls over(seed: mean(s: x)) -->\n");
        assert_eq!(c.len(), 1);
        assert!(c[0].query.starts_with("verdict:"));
        let m = malformed("<!-- falls over(seed: mean(s: x)) -->\n");
        assert!(m[0].contains("`verdict:`"), "{m:?}");
    }
}
