//! `sweep claims --uncited`: the numbers of a document that look measured and carry no
//! claim — a review list, so that no number read off the data is typed by hand.
//!
//! A number looks measured when it has a fractional part or a unit of a measurement right
//! after it (`%`, `×`, seconds, bytes); integers without a unit (counts of settings, years),
//! section numbers (`§7.1.2`) and numbers right after a setting's name (the word `nused`
//! in `nused 150`, `maxdist 0.1`) are not listed, nor anything a reader does not see as
//! text: code, headings, quotations of the thesis (block quotes), links, HTML tags and
//! comments (the text between the tags of an HTML block is read like any other). Only a
//! `=` claim cites the number before it: a `holds:` condition or a `verdict:` checks a
//! sentence, not its numbers. A number that is not data (a value the thesis printed, an
//! arithmetic fact) is marked `<!-- given: why -->` after it: the mark covers the numbers
//! since the previous comment on its line. A comment that is never closed, or a claim or
//! mark that does not render as one hidden comment, is a problem of the list: what it
//! hides cannot be reviewed.
//!
//! The scan is linear in the document: one pass of the renderer, one over the comments,
//! one over the numbers, each asking its context by binary search.

use std::collections::HashSet;
use std::ops::Range;

use pulldown_cmark::{Event, Parser, Tag};

use super::cited;
use super::document::{Found, claims_in, github_options, rendered};
use crate::spans::{Lines, Spans, work};

/// A number without a claim.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Uncited {
    /// 1-based line.
    pub(crate) line: usize,
    /// The number as printed, with the unit that made it look measured.
    pub(crate) text: String,
}

/// What `--uncited` finds in a document: numbers without a claim, and comments that keep
/// part of it from being reviewed.
#[derive(Debug, Clone, Default, PartialEq)]
pub(crate) struct Review {
    pub(crate) uncited: Vec<Uncited>,
    /// (1-based line, why) of each comment that is never closed or does not render as one.
    pub(crate) problems: Vec<(usize, String)>,
}

/// Setting names: the number right after one of these words is the setting's value, not a
/// measurement. (A metric's name, `RMSE`, is not a setting: the number after it is one.)
const SETTINGS: [&str; 16] = [
    "nused",
    "maxdist",
    "stepsize",
    "σt",
    "σs",
    "σa",
    "d_min)",
    "α",
    "alpha",
    "radius",
    "spp",
    "seed",
    "step",
    "albedo",
    "thin_below",
    "shadow_tolerance",
];

/// Units after a number that make it a measurement.
const UNITS: [&str; 12] = [
    "%", "×", "CPU-s", "ms", "min", "MB", "MiB", "GB", "GiB", "KiB", "KB", "s",
];

/// The ranges a reader does not see as text: code, headings, block quotes, links and
/// images, and inside HTML its tags and comments.
fn hidden(text: &str, comments: &[Range<usize>]) -> Spans {
    let mut ranges: Vec<Range<usize>> = comments.to_vec();
    for (event, range) in Parser::new_ext(text, github_options()).into_offset_iter() {
        match event {
            Event::Code(_)
            | Event::InlineHtml(_)
            | Event::Start(
                Tag::CodeBlock(_)
                | Tag::Heading { .. }
                | Tag::BlockQuote(_)
                | Tag::Link { .. }
                | Tag::Image { .. },
            ) => ranges.push(range),
            // A line of an HTML block: its tags are hidden, the text between them is not.
            Event::Html(_) => ranges.extend(tags(text, range)),
            _ => {}
        }
    }
    Spans::new(ranges)
}

/// The tags (`<…>`) inside `range` of `text`.
fn tags(text: &str, range: Range<usize>) -> Vec<Range<usize>> {
    let mut out = Vec::new();
    let mut at = range.start;
    while let Some(open) = text[at..range.end].find('<').map(|o| o + at) {
        let close = text[open..range.end]
            .find('>')
            .map_or(range.end, |c| open + c + 1);
        work::add(close - at);
        out.push(open..close);
        at = close;
    }
    out
}

/// The unit right after a number ending at `end`, if it is one of [`UNITS`]. A `×` is a
/// ratio's only when attached to the number and not followed by another factor (`2.1×`,
/// not `512 × 512` or `16 × k`).
fn unit_after(text: &str, end: usize) -> Option<&'static str> {
    let rest = text[end..].trim_start_matches([' ', '\u{202f}', '\u{2009}', '\u{a0}']);
    let attached = rest.len() == text.len() - end;
    UNITS.iter().copied().find(|u| {
        if !rest.starts_with(u) {
            return false;
        }
        let after = &rest[u.len()..];
        match *u {
            "×" => attached && !after.starts_with(|c: char| c.is_alphanumeric()),
            _ if u.chars().all(|c| c.is_ascii_alphabetic()) => {
                !rest[u.len()..].starts_with(|c: char| c.is_alphanumeric())
            }
            _ => true,
        }
    })
}

/// Whether the words before `start` on its line end with a setting's name, as a whole word
/// (`step 0.5`, not `footstep 0.33 s`).
fn after_setting(text: &str, start: usize) -> bool {
    let before = text[..start].trim_end_matches([' ', '=', '(', '\u{202f}']);
    SETTINGS.iter().any(|s| {
        before.strip_suffix(s).is_some_and(|rest| {
            !rest.ends_with(|c: char| c.is_alphanumeric() || c == '_' || c == '-')
        })
    })
}

/// A comment as the renderer sees it (outside code), and whether it is a `given` mark.
struct Comment {
    range: Range<usize>,
    given: bool,
}

/// The document's comments, in order; an unclosed one ends the list (a renderer hides the
/// rest of the document, and [`claims_in`] names it).
fn comments(text: &str, code: &Spans) -> Vec<Comment> {
    let mut out = Vec::new();
    let mut from = 0;
    while let Some(open) = text[from..].find("<!--").map(|o| o + from) {
        work::add(open + 4 - from);
        from = open + 4;
        if code.contains(open) {
            continue;
        }
        let Some(close) = text[from..].find("-->").map(|c| c + from + 3) else {
            break;
        };
        work::add(close - from);
        from = close;
        let given = text[open + 4..close - 3].trim_start().starts_with("given:");
        out.push(Comment {
            range: open..close,
            given,
        });
    }
    out
}

/// Where the numbers that `=` claims cite start, and the comments that should be claims
/// and are not (never closed, split by a table row, unparseable openings).
fn claimed_and_malformed(text: &str) -> (HashSet<usize>, Vec<(usize, String)>) {
    let mut claimed = HashSet::new();
    let mut malformed = Vec::new();
    for found in claims_in(text) {
        match found {
            Found::Claim(c) if c.query.starts_with('=') => {
                claimed.extend(c.cited.map(|n| c.line_start + n.span.0));
            }
            Found::Claim(_) => {}
            Found::Malformed { line, why } => malformed.push((line, why)),
        }
    }
    (claimed, malformed)
}

/// The numbers of `text` that look measured and carry neither a `=` claim nor a `given`
/// mark, and the comments that keep part of the text from review.
pub(crate) fn uncited_numbers(text: &str) -> Review {
    let (claimed, mut problems) = claimed_and_malformed(text);
    let rendered = rendered(text);
    let lines = Lines::new(text);
    let comments = comments(text, &rendered.code);
    for c in comments
        .iter()
        .filter(|c| c.given && !rendered.html.covers(&c.range))
    {
        problems.push((
            lines.number(c.range.start),
            "this `given:` mark does not render as one hidden comment (a `|` splits a table row; `--` ends a comment): it marks nothing".into(),
        ));
    }
    let ranges: Vec<Range<usize>> = comments.iter().map(|c| c.range.clone()).collect();
    let hidden = hidden(text, &ranges);
    let numbered = |start: usize, end: usize| Uncited {
        line: lines.number(start),
        text: match unit_after(text, end) {
            Some(unit) => format!("{} {unit}", &text[start..end]),
            None => text[start..end].to_string(),
        },
    };
    let measured = |start: usize, end: usize, decimals: usize| {
        let version = text[end..].starts_with('.')
            && text[end + 1..].starts_with(|c: char| c.is_ascii_digit());
        (decimals > 0 || unit_after(text, end).is_some())
            // `3.9.1` is a version, `§7.1.2` a section of the thesis: not measurements.
            && !version
            && !text[..start].ends_with('§')
            && !claimed.contains(&start)
            && !hidden.contains(start)
            && !after_setting(text, start)
    };
    let mut uncited = Vec::new();
    let mut pending: Vec<Uncited> = Vec::new();
    let mut next = comments.iter().peekable();
    // Pieces of text between comments and line ends: a `given` mark clears the numbers
    // since the previous comment on its line; a line end or another comment keeps them.
    let (mut at, mut line_end) = (0, 0);
    while at < text.len() {
        if at >= line_end {
            line_end = text[at..].find('\n').map_or(text.len(), |e| at + e + 1);
        }
        let comment = next.next_if(|c| c.range.start < line_end);
        let piece_end = comment.map_or(line_end, |c| c.range.start);
        work::add(piece_end - at);
        for n in cited::numbers(&text[at..piece_end]) {
            let (start, end) = (at + n.span.0, at + n.span.1);
            if measured(start, end, n.decimals) {
                pending.push(numbered(start, end));
            }
        }
        if comment.is_some_and(|c| c.given) {
            pending.clear();
        }
        uncited.append(&mut pending);
        at = comment.map_or(line_end, |c| c.range.end);
    }
    Review { uncited, problems }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lists_measured_looking_numbers_without_claims() {
        let text = "# C1 at 2.5\n\
                    The error fell by 12 %<!-- = value(s: x) --> and took 3.4 s, within 2 %, 2× sooner.\n\
                    nused 150 and maxdist 0.1 at 512² with 40 000 photons in 2006 (§7.1.2, §8.2).\n\
                    The thesis measured 1.7–3×<!-- given: thesis §8.2 --> and `0.25` in code, 512 × 512.\n\
                    > thesis quote 0.02\n";
        let listed: Vec<String> = uncited_numbers(text)
            .uncited
            .into_iter()
            .map(|u| u.text)
            .collect();
        assert_eq!(
            listed,
            vec!["3.4 s".to_string(), "2 %".to_string(), "2 ×".to_string()]
        );
    }

    fn listed(text: &str) -> Vec<String> {
        uncited_numbers(text)
            .uncited
            .into_iter()
            .map(|u| u.text)
            .collect()
    }

    /// Case 18 of the fifth reliability round: the setting filter matched a metric's name,
    /// "default" and any word ending in "step"; a `given` mark inside code marked the
    /// numbers before it; an HTML block hid its text; an unclosed comment hid the rest and
    /// the list was empty.
    #[test]
    fn metrics_words_code_and_html_do_not_hide_numbers() {
        assert_eq!(listed("The RMSE 0.0123 at nused 150.\n"), ["0.0123"]);
        assert_eq!(listed("It takes by default 6.07 s.\n"), ["6.07 s"]);
        assert_eq!(listed("a footstep 0.33 s, at step 0.5\n"), ["0.33 s"]);
        assert_eq!(
            listed("took 3.4 s, `<!-- given: x -->` in code\n"),
            ["3.4 s"]
        );
        assert_eq!(
            listed("took 3.4 s<!-- given: x -->\n"),
            Vec::<String>::new()
        );
        assert_eq!(
            listed("<table>\n<tr><td width=\"0.5\">RMSE 0.0123</td></tr>\n</table>\n\nend\n"),
            ["0.0123"]
        );
        let review = uncited_numbers("<!-- an unclosed note\n\nThe error fell by 12.5 %.\n");
        assert!(
            review
                .problems
                .iter()
                .any(|(line, why)| *line == 1 && why.contains("never closed")),
            "{review:?}"
        );
        // A `holds:` condition checks the sentence, not the number before it.
        assert_eq!(
            listed("fell by 12.5 %<!-- holds: mean(s: x) > 0 --> and 3.5 %<!-- = mean(s: y) -->\n"),
            ["12.5 %"]
        );
        assert_eq!(
            listed("fell by 12.5 %<!-- verdict: falls over(seed: mean(s: x)) -->\n"),
            ["12.5 %"]
        );
    }

    /// Case 8: `--uncited` on a document of 111 000 claims timed out (each number searched
    /// every claim and every excluded range).
    #[test]
    fn the_review_is_linear_in_the_document() {
        let piece = "took 3.4 s, `0.1` in code, 2.5 %<!-- = value(s: x) --> and 1.5 %<!-- given: t --> | [a 0.5](b) ";
        for lines in [true, false] {
            crate::spans::work::assert_linear("uncited", 1000, 1.2, |n| {
                let text = if lines {
                    format!("{piece}\n").repeat(n)
                } else {
                    piece.repeat(n)
                };
                let mut review = Review::default();
                let steps = crate::spans::work::of(|| review = uncited_numbers(&text));
                assert_eq!(review.uncited.len(), n, "one `3.4 s` per piece");
                steps
            });
        }
    }
}
