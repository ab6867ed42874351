//! Writing user strings into `report.md`. An experiment's description, its name, axis
//! values (scene paths, labels) and file names are the user's text: written raw, a value
//! such as `"><img src=x onerror=alert(1)>` became live HTML in the Markdown (issue #45,
//! case 8) and a `|` split a table row. Every such string goes through one of these.

/// Text for HTML (an element's content or a quoted attribute): `&`, `<`, `>` and `"` become
/// entities. What `report.html`, the index and the paper page write around user strings.
pub(crate) fn html(t: &str) -> String {
    t.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// Text shown as written: HTML's special characters become entities, and Markdown's inline
/// syntax is escaped where it could take effect — `|` (a table cell), `` ` ``, `\\`, `*`,
/// a `_` at a word boundary, `]` before `(`, `[` or `:` (a link), doubled `~` — so units
/// such as `rmse [W/(m2 sr)]` and keys such as `volume_photons` stay readable in the raw
/// file. A line break becomes a space (a value never starts a new block).
pub(crate) fn md_text(s: &str) -> String {
    let chars: Vec<char> = s.chars().collect();
    let word = |i: Option<usize>| {
        i.and_then(|i| chars.get(i))
            .is_some_and(|c| c.is_alphanumeric())
    };
    let mut out = String::with_capacity(s.len());
    for (i, &c) in chars.iter().enumerate() {
        let next = chars.get(i + 1).copied();
        let escaped = match c {
            '\\' | '`' | '*' | '|' => true,
            '_' => !(word(i.checked_sub(1)) && word(Some(i + 1))),
            ']' => matches!(next, Some('(' | '[' | ':')),
            '~' => next == Some('~') || i.checked_sub(1).map(|j| chars[j]) == Some('~'),
            _ => false,
        };
        match c {
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '&' => out.push_str("&amp;"),
            '\n' | '\r' => out.push(' '),
            _ if escaped => {
                out.push('\\');
                out.push(c);
            }
            _ => out.push(c),
        }
    }
    out
}

/// A code span holding `s` verbatim: fenced by one more backtick than its longest run of
/// backticks (CommonMark §6.1), with spaces inside when it starts or ends with one.
pub(crate) fn md_code(s: &str) -> String {
    let s = s.replace(['\n', '\r'], " ");
    let longest = s.split(|c| c != '`').map(str::len).max().unwrap_or(0);
    let fence = "`".repeat(longest + 1);
    if s.starts_with('`') || s.ends_with('`') || longest > 0 {
        format!("{fence} {s} {fence}")
    } else {
        format!("{fence}{s}{fence}")
    }
}

/// The experiment's description: the author's Markdown (code spans, emphasis and links
/// stay), with raw HTML neutralised — `<`, `>` and `&` outside code spans become entities.
pub(crate) fn md_prose(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    let mut in_code = false;
    for c in s.chars() {
        match c {
            '`' => {
                in_code = !in_code;
                out.push(c);
            }
            '<' if !in_code => out.push_str("&lt;"),
            '>' if !in_code => out.push_str("&gt;"),
            '&' if !in_code => out.push_str("&amp;"),
            _ => out.push(c),
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    const ATTACK: &str = "\"><img src=x onerror=alert(1)>";

    /// What a CommonMark renderer makes of `markdown`, as HTML.
    fn rendered(markdown: &str) -> String {
        let mut html = String::new();
        let parser = pulldown_cmark::Parser::new_ext(markdown, pulldown_cmark::Options::all());
        pulldown_cmark::html::push_html(&mut html, parser);
        html
    }

    #[test]
    fn a_value_never_becomes_markup() {
        for value in [
            ATTACK,
            "a | b",
            "*bold* _it_ [x](javascript:alert(1)) `code` ~~s~~ \\",
            "![i](x.png) [r][x] [x]: y __b__ a_b_c",
        ] {
            let html = rendered(&format!("| a |\n|---|\n| {} |\n", md_text(value)));
            assert!(!html.contains("<img") && !html.contains("<a ") && !html.contains("<em>"));
            assert!(
                !html.contains("<code>") && !html.contains("<del>"),
                "{html}"
            );
            assert_eq!(html.matches("<td>").count(), 1, "{html}");
        }
        assert_eq!(md_text("rmse [W/(m2 sr)]"), "rmse [W/(m2 sr)]");
        assert_eq!(
            md_text("integrator.volume_photons"),
            "integrator.volume_photons"
        );
        let html = rendered(&md_text(ATTACK));
        assert!(
            html.contains("&gt;&lt;img src=x onerror=alert(1)&gt;"),
            "{html}"
        );
    }

    #[test]
    fn code_spans_hold_any_text() {
        assert_eq!(md_code("sweep run a.toml"), "`sweep run a.toml`");
        let html = rendered(&md_code("a`b ``c"));
        assert!(html.contains("<code>a`b ``c</code>"), "{html}");
        assert!(rendered(&md_code(ATTACK)).contains("&lt;img"));
    }

    #[test]
    fn prose_keeps_markdown_but_not_html() {
        let html = rendered(&md_prose(&format!("Renders `iterations` maps. {ATTACK}")));
        assert!(html.contains("<code>iterations</code>"), "{html}");
        assert!(!html.contains("<img"), "{html}");
    }
}
