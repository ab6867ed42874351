//! `sweep claims --uncited`: the numbers of a document that look measured and carry no
//! claim — a review list, so that no number read off the data is typed by hand.
//!
//! A number looks measured when it has a fractional part or a unit of a measurement right
//! after it (`%`, `×`, seconds, bytes); integers without a unit (counts of settings, years),
//! section numbers (`§7.1.2`) and numbers right after a setting's name (`nused 150`, `maxdist 0.1`)
//! are not listed, nor anything in code, headings, quotations of the thesis (block quotes)
//! or links. A number that is not data (a value the thesis printed, an arithmetic fact)
//! is marked `<!-- given: why -->` after it: the mark covers the numbers since the previous
//! comment on its line.

use std::ops::Range;

use pulldown_cmark::{Event, Parser, Tag};

use super::cited;
use super::document::{Found, claims_in, github_options};

/// A number without a claim.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Uncited {
    /// 1-based line.
    pub(crate) line: usize,
    /// The number as printed, with the unit that made it look measured.
    pub(crate) text: String,
}

/// Setting names: the number right after one is the setting's value, not a measurement.
const SETTINGS: [&str; 19] = [
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
    "RMSE",
    "rmse",
    "default",
];

/// Units after a number that make it a measurement.
const UNITS: [&str; 12] = [
    "%", "×", "CPU-s", "ms", "min", "MB", "MiB", "GB", "GiB", "KiB", "KB", "s",
];

/// The ranges where numbers are not the document's measurements.
fn excluded(text: &str) -> Vec<Range<usize>> {
    Parser::new_ext(text, github_options())
        .into_offset_iter()
        .filter(|(e, _)| {
            matches!(
                e,
                Event::Code(_)
                    | Event::Html(_)
                    | Event::InlineHtml(_)
                    | Event::Start(
                        Tag::CodeBlock(_)
                            | Tag::Heading { .. }
                            | Tag::BlockQuote(_)
                            | Tag::Link { .. }
                            | Tag::Image { .. }
                            | Tag::HtmlBlock
                    )
            )
        })
        .map(|(_, r)| r)
        .collect()
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

/// Whether the words before `start` on its line end with a setting's name.
fn after_setting(text: &str, start: usize) -> bool {
    let before = text[..start].trim_end_matches([' ', '=', '(', '\u{202f}']);
    SETTINGS.iter().any(|s| before.ends_with(s))
}

/// The numbers of `text` that look measured and carry neither a claim nor a `given` mark.
pub(crate) fn uncited_numbers(text: &str) -> Vec<Uncited> {
    let excluded = excluded(text);
    let claimed: Vec<usize> = claims_in(text)
        .into_iter()
        .filter_map(|f| match f {
            Found::Claim(c) => c.cited.map(|n| c.line_start + n.span.0),
            Found::Malformed { .. } => None,
        })
        .collect();
    let mut out = Vec::new();
    let mut line_start = 0;
    for (i, line) in text.split_inclusive('\n').enumerate() {
        let mut pending: Vec<Uncited> = Vec::new();
        let mut at = 0;
        // A line is cut at its comments: a `given` mark clears what came before it.
        while at < line.len() {
            let (segment_end, comment) = match line[at..].find("<!--") {
                Some(o) => {
                    let close = line[at + o..]
                        .find("-->")
                        .map_or(line.len(), |c| at + o + c + 3);
                    (at + o, Some(&line[at + o..close]))
                }
                None => (line.len(), None),
            };
            for n in cited::numbers(&line[at..segment_end]) {
                let (start, end) = (line_start + at + n.span.0, line_start + at + n.span.1);
                let measured = n.decimals > 0 || unit_after(text, end).is_some();
                // `3.9.1` is a version, not a measurement.
                let version = text[end..].starts_with('.')
                    && text[end + 1..].starts_with(|c: char| c.is_ascii_digit());
                // `§7.1.2` is a section of the thesis, not a measurement.
                let section = text[..start].ends_with('§');
                if !measured
                    || version
                    || section
                    || claimed.contains(&start)
                    || excluded.iter().any(|r| r.start <= start && start < r.end)
                    || after_setting(text, start)
                {
                    continue;
                }
                let unit = unit_after(text, end).unwrap_or("");
                pending.push(Uncited {
                    line: i + 1,
                    text: format!(
                        "{}{}{unit}",
                        &text[start..end],
                        if unit.is_empty() { "" } else { " " }
                    ),
                });
            }
            match comment {
                Some(c)
                    if c.trim_start_matches("<!--")
                        .trim_start()
                        .starts_with("given:") =>
                {
                    pending.clear();
                }
                _ => {}
            }
            out.append(&mut pending);
            at = match comment {
                Some(c) => segment_end + c.len(),
                None => line.len(),
            };
        }
        line_start += line.len();
    }
    for u in &mut out {
        u.text = u.text.trim_end().to_string();
    }
    out
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
        let listed: Vec<String> = uncited_numbers(text).into_iter().map(|u| u.text).collect();
        assert_eq!(
            listed,
            vec!["3.4 s".to_string(), "2 %".to_string(), "2 ×".to_string()]
        );
    }
}
