//! Writing user strings into `report.md` and the generated HTML. An experiment's
//! description, its name, axis values (scene paths, labels), folder and file names are the
//! user's text: written raw, a value such as `"><img src=x onerror=alert(1)>` became live
//! HTML, a `|` split a table row, and a `javascript:` link ran script when clicked. Every
//! such string goes through one of these, and every Markdown page is rendered to HTML
//! through [`page_events`], the one sanitiser: an allow-list of tags and attributes, no raw
//! HTML, and no link but relative and http(s).

use pulldown_cmark::{Event, Tag, TagEnd};

use crate::spans::{Spans, work};

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

/// The byte ranges of `s` that are code by CommonMark's rules (§6.1 code spans: a run of n
/// backticks opens one only where a later run of exactly n closes it within the same
/// paragraph; fenced and indented blocks), as a CommonMark parser with GitHub's
/// extensions finds them: there, and only there, text is shown literally.
///
/// The text is parsed as it will be after escaping: with `<`, `>` and `&` as plain
/// characters (same byte lengths), so that raw HTML which escaping removes cannot shape
/// the blocks (an HTML block followed by an indented line made that line code in the raw
/// text and raw HTML in the escaped one).
fn code_spans(s: &str) -> Vec<std::ops::Range<usize>> {
    use pulldown_cmark::{Options, Parser};
    let options = Options::ENABLE_TABLES
        | Options::ENABLE_STRIKETHROUGH
        | Options::ENABLE_TASKLISTS
        | Options::ENABLE_FOOTNOTES;
    let neutral = s.replace(['<', '>', '&'], "x");
    Parser::new_ext(&neutral, options)
        .into_offset_iter()
        .filter(|(e, _)| matches!(e, Event::Code(_) | Event::Start(Tag::CodeBlock(_))))
        .map(|(_, r)| r)
        .collect()
}

/// Whether a link's destination may be followed: a relative reference, or an http(s)
/// URL. Browsers drop ASCII whitespace and control characters inside a scheme
/// (`java\tscript:`), so those are removed before the scheme is read.
pub(crate) fn safe_url(url: &str) -> bool {
    let cleaned: String = url
        .chars()
        .filter(|c| !c.is_ascii_control() && !c.is_whitespace())
        .collect();
    let scheme_end = cleaned.find(':');
    let path_start = cleaned.find(['/', '?', '#']);
    match scheme_end {
        Some(colon) if path_start.is_none_or(|p| colon < p) => {
            let scheme = cleaned[..colon].to_ascii_lowercase();
            scheme == "http" || scheme == "https"
        }
        _ => true,
    }
}

/// The experiment's description: the author's Markdown (code spans, emphasis and safe links
/// stay), with raw HTML neutralised — `<`, `>` and `&` outside code spans become entities —
/// and links to anything but relative or http(s) addresses left as plain text.
///
/// The result is parsed again (CommonMark with GitHub's extensions) and must hold no raw
/// HTML and no unsafe link; text crafted so that escaping shifts the blocks (a line that
/// opens an HTML block in the middle of a code span) falls back to escaping everywhere,
/// code spans included, and at last to plain text.
pub(crate) fn md_prose(s: &str) -> String {
    let spans = code_spans(s);
    let candidate = escape_outside(s, &spans);
    if renders_safely(&candidate) {
        return candidate;
    }
    let strict = escape_outside(s, &[])
        .replace('[', "\\[")
        .replace(']', "\\]");
    if renders_safely(&strict) {
        return strict;
    }
    md_text(s)
}

/// `s` with `<`, `>`, `&` as entities and unsafe link destinations broken, outside `code`.
/// One pass: the code spans, sorted, are walked beside the characters (searching them all
/// for every character made a description of many code spans quadratic).
fn escape_outside(s: &str, code: &[std::ops::Range<usize>]) -> String {
    let code = Spans::new(code.iter().cloned());
    let mut spans = code.ranges().iter().peekable();
    let mut out = String::with_capacity(s.len());
    for (i, c) in s.char_indices() {
        work::add(1);
        while spans.next_if(|r| r.end <= i).is_some() {}
        if spans.peek().is_some_and(|r| r.start <= i) {
            out.push(c);
            continue;
        }
        match c {
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '&' => out.push_str("&amp;"),
            // `](dest` of an inline link, `]: dest` of a definition: an unsafe destination
            // loses its link syntax.
            '(' | ':' if s[..i].ends_with(']') && !safe_url(link_destination(&s[i + 1..])) => {
                out.push('\\');
                out.push(c);
            }
            _ => out.push(c),
        }
    }
    out
}

/// How much of a link destination [`link_destination`] reads.
const DESTINATION_READ: usize = 256;

/// Whether Markdown renders with no raw HTML and no link or image but relative or http(s).
fn renders_safely(markdown: &str) -> bool {
    use pulldown_cmark::{Options, Parser};
    let options = Options::ENABLE_TABLES
        | Options::ENABLE_STRIKETHROUGH
        | Options::ENABLE_TASKLISTS
        | Options::ENABLE_FOOTNOTES;
    Parser::new_ext(markdown, options).all(|e| match e {
        Event::Html(_) | Event::InlineHtml(_) => false,
        Event::Start(Tag::Link { dest_url, .. }) | Event::Start(Tag::Image { dest_url, .. }) => {
            safe_url(&dest_url)
        }
        _ => true,
    })
}

/// The destination at the start of `rest` (after `](` or `]:`), up to its end, and at most
/// [`DESTINATION_READ`] bytes of it: enough for any scheme, and each `](` reads a bounded
/// stretch (the whole rest, for each of many, was quadratic). What this misjudges, the
/// final check of [`md_prose`] catches.
fn link_destination(rest: &str) -> &str {
    let rest = &rest[..rest.floor_char_boundary(DESTINATION_READ)];
    work::add(rest.len());
    let rest = rest.trim_start();
    let rest = rest.strip_prefix('<').unwrap_or(rest);
    let end = rest
        .find(|c: char| c == ')' || c == '>' || c == '"' || c == '\'' || c.is_whitespace())
        .unwrap_or(rest.len());
    &rest[..end]
}

/// The Markdown extensions every page reads user Markdown with: GitHub's tables,
/// strikethrough and footnotes, so a page shows what a code host shows of the same file.
/// Heading attributes (`## A {#id .class key=value}`) are not among them: a code host shows
/// the braces as text, and as attributes they made `onfocus` with `autofocus` live.
pub(crate) const PAGE_MARKDOWN: pulldown_cmark::Options = pulldown_cmark::Options::ENABLE_TABLES
    .union(pulldown_cmark::Options::ENABLE_STRIKETHROUGH)
    .union(pulldown_cmark::Options::ENABLE_FOOTNOTES);

/// The one sanitiser of the HTML pages `sweep` writes (a study's `report.html`, the
/// paper's page): Markdown from user text parsed with [`PAGE_MARKDOWN`] and every event
/// rebuilt from an allow-list, so the HTML written from it holds only the tags CommonMark
/// with tables and footnotes makes, and of attributes only a link's `href` and `title`, an
/// image's `src`, `alt` and `title` (relative or http(s) addresses, [`safe_url`]), a list's
/// `start`, a table cell's alignment and the footnotes' own numbered ids — never an event
/// handler, `style`, `autofocus`, a class or an id written by the user. Raw HTML is kept
/// only as shown text (comments, such as the claims' queries, are dropped); a link or
/// image whose address is not safe keeps its text and loses its address. The page's own
/// markup (figures, the explorer) is added to these events by the page.
pub(crate) fn page_events(markdown: &str) -> Vec<Event<'_>> {
    let mut sanitiser = Sanitiser::default();
    pulldown_cmark::Parser::new_ext(markdown, PAGE_MARKDOWN)
        .filter_map(|event| sanitiser.event(event))
        .collect()
}

/// [`page_events`] written as HTML (the body of a page).
pub(crate) fn page_html(markdown: &str) -> String {
    let mut body = String::new();
    pulldown_cmark::html::push_html(&mut body, page_events(markdown).into_iter());
    body
}

/// The state of [`page_events`]: which open links were dropped, and the footnotes' labels
/// by their numbered ids.
#[derive(Default)]
struct Sanitiser {
    /// For each open link or image: whether it was dropped.
    dropped: Vec<bool>,
    /// Footnote labels in order of first use; label `i` is written as `footnote-{i + 1}`.
    footnotes: Vec<String>,
}

impl Sanitiser {
    /// The event as the page may write it, or `None` to leave it out.
    fn event<'a>(&mut self, event: Event<'a>) -> Option<Event<'a>> {
        use pulldown_cmark::CowStr;
        match event {
            Event::Start(tag) => self.start(tag).map(Event::Start),
            Event::End(TagEnd::Link | TagEnd::Image) => {
                let dropped = self.dropped.pop().unwrap_or(false);
                (!dropped).then_some(event)
            }
            Event::End(TagEnd::HtmlBlock | TagEnd::MetadataBlock(_)) => None,
            Event::End(_) => Some(event),
            Event::Html(h) | Event::InlineHtml(h) => {
                (!h.trim_start().starts_with("<!--")).then_some(Event::Text(h))
            }
            Event::InlineMath(m) | Event::DisplayMath(m) => Some(Event::Code(m)),
            Event::FootnoteReference(label) => Some(Event::FootnoteReference(CowStr::from(
                self.footnote(&label),
            ))),
            Event::TaskListMarker(done) => {
                Some(Event::Text(if done { "[x] " } else { "[ ] " }.into()))
            }
            Event::Text(_) | Event::Code(_) | Event::SoftBreak | Event::HardBreak | Event::Rule => {
                Some(event)
            }
        }
    }

    /// A start tag rebuilt from what the page needs of it; `None` drops it (raw HTML's
    /// block, metadata, a link or image to an unsafe address).
    fn start<'a>(&mut self, tag: Tag<'a>) -> Option<Tag<'a>> {
        use pulldown_cmark::{CodeBlockKind, CowStr};
        match tag {
            // Level only: no id, class or attribute of the user's.
            Tag::Heading { level, .. } => Some(Tag::Heading {
                level,
                id: None,
                classes: Vec::new(),
                attrs: Vec::new(),
            }),
            // The info string would become a class.
            Tag::CodeBlock(_) => Some(Tag::CodeBlock(CodeBlockKind::Fenced("".into()))),
            Tag::FootnoteDefinition(label) => {
                Some(Tag::FootnoteDefinition(CowStr::from(self.footnote(&label))))
            }
            Tag::Link {
                link_type,
                dest_url,
                title,
                ..
            } => self.kept(safe_url(&dest_url)).then(|| Tag::Link {
                link_type,
                dest_url,
                title,
                id: "".into(),
            }),
            Tag::Image {
                link_type,
                dest_url,
                title,
                ..
            } => self.kept(safe_url(&dest_url)).then(|| Tag::Image {
                link_type,
                dest_url,
                title,
                id: "".into(),
            }),
            Tag::HtmlBlock | Tag::MetadataBlock(_) => None,
            Tag::Paragraph
            | Tag::BlockQuote(_)
            | Tag::List(_)
            | Tag::Item
            | Tag::DefinitionList
            | Tag::DefinitionListTitle
            | Tag::DefinitionListDefinition
            | Tag::Table(_)
            | Tag::TableHead
            | Tag::TableRow
            | Tag::TableCell
            | Tag::Emphasis
            | Tag::Strong
            | Tag::Strikethrough
            | Tag::Superscript
            | Tag::Subscript => Some(tag),
        }
    }

    /// Records whether an opened link or image is kept.
    fn kept(&mut self, safe: bool) -> bool {
        self.dropped.push(!safe);
        safe
    }

    /// The numbered id a footnote label is written as (`footnote-1` …), the same for its
    /// references and its definition.
    fn footnote(&mut self, label: &str) -> String {
        let at = match self.footnotes.iter().position(|l| l == label) {
            Some(at) => at,
            None => {
                self.footnotes.push(label.to_string());
                self.footnotes.len() - 1
            }
        };
        format!("footnote-{}", at + 1)
    }
}

/// A link to a file of the index's folder: `./` and each path segment percent-encoded
/// (RFC 3986 unreserved characters kept), so that a folder named `javascript:alert(1)`
/// is a relative file name to the browser, never a scheme.
pub(crate) fn local_href(segments: &[&str]) -> String {
    let mut out = String::from(".");
    for segment in segments {
        out.push('/');
        for b in segment.bytes() {
            if b.is_ascii_alphanumeric() || matches!(b, b'-' | b'.' | b'_' | b'~') {
                out.push(b as char);
            } else {
                out.push_str(&format!("%{b:02X}"));
            }
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

    /// Case 2 of the fourth reliability round: one unmatched backtick turned escaping off
    /// for the rest of the description.
    #[test]
    fn an_unmatched_backtick_does_not_stop_the_escaping() {
        for text in [
            "Tick ` then <img src=x onerror=alert(11)> end.",
            "``a` <img src=x onerror=alert(1)>",
            "\\` <img src=x onerror=alert(1)> `",
            "`a` ` <script>alert(1)</script>",
        ] {
            let html = rendered(&md_prose(text));
            assert!(
                !html.contains("<img") && !html.contains("<script"),
                "{text}: {html}"
            );
        }
        assert!(rendered(&md_prose("`<b>` and ``a`b``")).contains("<code>&lt;b&gt;</code>"));
    }

    /// Case 3: a `javascript:` link in a description was live.
    #[test]
    fn unsafe_links_lose_their_destination() {
        for text in [
            "[the data](javascript:alert(12))",
            "[x]( JaVaScRiPt:alert(1))",
            "[x](java\tscript:alert(1))",
            "[x][r]\n\n[r]: javascript:alert(1)",
            "[x](data:text/html,<script>alert(1)</script>)",
            "<javascript:alert(1)>",
        ] {
            let html = rendered(&md_prose(text));
            assert!(!html.contains("href"), "{text}: {html}");
        }
        let html = rendered(&md_prose(
            "[pbrt](https://pbrt.org) and [the data](cells.csv)",
        ));
        assert_eq!(html.matches("href").count(), 2, "{html}");
        assert!(safe_url("figures/a.png") && safe_url("https://x.org/a:b") && safe_url("#top"));
        assert!(!safe_url("javascript:x") && !safe_url("vbscript:x") && !safe_url("data:x"));
    }

    #[test]
    fn page_events_drop_raw_html_and_unsafe_links() {
        let md = "a <img src=x onerror=alert(1)> b <!-- = query -->\n\n<script>alert(1)</script>\n\n[j](javascript:alert(1)) [h](https://x.org)\n";
        let html = page_html(md);
        assert!(
            !html.contains("<img") && !html.contains("<script"),
            "{html}"
        );
        assert!(
            !html.contains("query") && !html.contains("javascript"),
            "{html}"
        );
        assert!(
            html.contains("href=\"https://x.org\"") && html.contains("<p>j <a"),
            "{html}"
        );
    }

    /// Row 3 of the fifth reliability round: heading attributes reached the paper's page,
    /// so `{tabindex=0 autofocus onfocus=…}` ran script on load.
    #[test]
    fn heading_attributes_are_text_never_attributes() {
        let html = page_html(
            "## Details {tabindex=0 autofocus onfocus=alert(1)}\n\n## Cover {#explorer .x style=\"position:fixed\" onclick=alert(2)}\n",
        );
        let tags = tags_of(&html).unwrap();
        assert!(
            tags.iter().all(|(_, attributes)| attributes.is_empty()),
            "{html}"
        );
        assert!(html.contains("<h2>Details {tabindex=0"), "{html}");
    }

    /// A tag's name and its attributes' names and values.
    type HtmlTag = (String, Vec<(String, String)>);

    /// The tags of generated HTML with their attributes (values with `&amp;`, `&quot;`,
    /// `&lt;`, `&gt;` decoded); an error where the text is not well-formed tags and text.
    /// pulldown-cmark escapes every `<` of text, so each `<` opens a tag.
    fn tags_of(html: &str) -> Result<Vec<HtmlTag>, String> {
        let mut tags = Vec::new();
        let mut rest = html;
        while let Some(open) = rest.find('<') {
            let after = &rest[open + 1..];
            let close = after.find('>').ok_or("an unclosed tag")?;
            let inside = after[..close].trim_end_matches('/').trim();
            rest = &after[close + 1..];
            if inside.starts_with('/') {
                continue;
            }
            let (name, mut attrs) = inside.split_once(' ').unwrap_or((inside, ""));
            let mut attributes = Vec::new();
            while !attrs.trim().is_empty() {
                let (key, value_part) = attrs
                    .trim_start()
                    .split_once("=\"")
                    .ok_or_else(|| format!("an attribute without a quoted value in <{inside}>"))?;
                let end = value_part.find('"').ok_or("an unclosed attribute value")?;
                let value = value_part[..end]
                    .replace("&quot;", "\"")
                    .replace("&lt;", "<")
                    .replace("&gt;", ">")
                    .replace("&amp;", "&");
                attributes.push((key.trim().to_ascii_lowercase(), value));
                attrs = &value_part[end + 1..];
            }
            tags.push((name.to_ascii_lowercase(), attributes));
        }
        Ok(tags)
    }

    /// What a page may hold from user Markdown: these tags, and of attributes only these.
    fn allowed(tag: &str, attribute: &str, value: &str) -> bool {
        let numbered = |prefix: &str| {
            value
                .strip_prefix(prefix)
                .is_some_and(|n| !n.is_empty() && n.bytes().all(|b| b.is_ascii_digit()))
        };
        match (tag, attribute) {
            // An e-mail autolink is written `mailto:` and its address.
            ("a", "href") => match value.strip_prefix("mailto:") {
                Some(address) => !address.contains(':'),
                None => safe_url(value) && (!value.starts_with('#') || numbered("#footnote-")),
            },
            ("img", "src") => safe_url(value),
            ("a" | "img", "title") | ("img", "alt") => true,
            ("ol", "start") => value.bytes().all(|b| b.is_ascii_digit()),
            ("th" | "td", "style") => {
                matches!(
                    value,
                    "text-align: left" | "text-align: center" | "text-align: right"
                )
            }
            ("div", "class") => value == "footnote-definition",
            ("div", "id") => numbered("footnote-"),
            ("sup", "class") => {
                matches!(value, "footnote-reference" | "footnote-definition-label")
            }
            ("blockquote", "class") => value.starts_with("markdown-alert-"),
            _ => false,
        }
    }

    const TAGS: [&str; 29] = [
        "p",
        "h1",
        "h2",
        "h3",
        "h4",
        "h5",
        "h6",
        "blockquote",
        "pre",
        "code",
        "ol",
        "ul",
        "li",
        "table",
        "thead",
        "tbody",
        "tr",
        "th",
        "td",
        "em",
        "strong",
        "del",
        "sup",
        "a",
        "img",
        "br",
        "hr",
        "div",
        "dl",
    ];

    /// The paper's page (and a report's) from Markdown built of every extension an attacker
    /// might combine — heading attributes, raw HTML blocks and inline tags, links and
    /// images of every form, footnotes with hostile labels, fenced code with an info
    /// string, tables with alignment, autolinks: whatever the mix, the HTML holds only the
    /// allow-listed tags and attributes, and no address but relative and http(s).
    #[test]
    fn fuzz_page_markdown_keeps_only_allowed_markup() {
        use proptest::prelude::*;
        let fragment = prop::sample::select(vec![
            "## Details {tabindex=0 autofocus onfocus=alert(1)}\n",
            "# T {#explorer .c style=\"position:fixed;inset:0\" onclick=alert(1)}\n",
            "### {data-x=1 onmouseover=alert(1)}\n",
            "<details open ontoggle=alert(1)>\n",
            "<div style=\"position:fixed\" autofocus tabindex=0 onfocus=alert(1)>x</div>\n",
            "<img src=x onerror=alert(1)>",
            "<a href=\"javascript:alert(1)\">a</a>",
            "[a](javascript:alert(1))",
            "[a](JaVaScRiPt:alert(1) \"t\\\" onclick=x\")",
            "[a](<java\tscript:x>)",
            "[a](&#106;avascript:alert(1))",
            "![i](data:image/svg+xml,<svg onload=alert(1)>)",
            "![i](x.png \"\\\" onerror=alert(1)\")",
            "[r]: javascript:alert(1)\n",
            "[a][r] ![b][r]",
            "<javascript:alert(1)>",
            "<https://x.org/a?b=\"c\">",
            "<a@b.c>",
            "[^\"><img src=x onerror=alert(1)>]",
            "\n\n[^\"><img src=x onerror=alert(1)>]: note\n",
            "[^explorer]\n\n[^explorer]: clobber\n",
            "```js\" onclick=\"alert(1)\nx\n```\n",
            "| a | b |\n|:--|--:|\n| <b onclick=x>1</b> | [l](javascript:x) |\n",
            "> [!NOTE]\n> hi\n",
            "1. a\n2. b\n",
            "3) c\n",
            "- [x] done\n",
            "~~s~~ *e* **b** `c`",
            "<!-- = query -->",
            "$x$ $$y$$",
            "---\ntitle: x\n---\n",
            "\n\n",
            " text ",
            "[ok](https://x.org) ![ok](figures/a.png)",
        ]);
        let mut runner = proptest::test_runner::TestRunner::new(proptest::test_runner::Config {
            cases: 2000,
            failure_persistence: None,
            ..Default::default()
        });
        runner
            .run(&prop::collection::vec(fragment, 0..10), |parts| {
                let markdown = parts.concat();
                let html = page_html(&markdown);
                let tags =
                    tags_of(&html).map_err(|e| TestCaseError::fail(format!("{e}: {html}")))?;
                for (tag, attributes) in tags {
                    prop_assert!(
                        TAGS.contains(&tag.as_str()),
                        "<{tag}> from {markdown:?}: {html}"
                    );
                    for (name, value) in attributes {
                        prop_assert!(
                            allowed(&tag, &name, &value),
                            "<{tag} {name}=\"{value}\"> from {markdown:?}: {html}"
                        );
                    }
                }
                Ok(())
            })
            .unwrap();
    }

    /// Descriptions built from every fragment an attacker might combine: whatever the mix,
    /// rendered by CommonMark with GitHub's extensions, no tag and no script link appears.
    #[test]
    fn fuzz_descriptions_never_become_markup() {
        use proptest::prelude::*;
        let fragment = prop::sample::select(vec![
            "`",
            "``",
            "\\",
            "\\`",
            "<img src=x onerror=alert(1)>",
            "<script>alert(1)</script>",
            "[a](javascript:alert(1))",
            "[a]( JAVASCRIPT:alert(1) )",
            "[a](java\tscript:x)",
            "[a][r]",
            "\n\n[r]: javascript:alert(1)\n",
            "<javascript:alert(1)>",
            "](",
            "]:",
            "[",
            "]",
            "(",
            ")",
            "&lt;",
            "&#x3C;img src=x onerror=alert(1)>",
            "<!--",
            "-->",
            "[ok](https://x.org)",
            "*",
            "_",
            "\n",
            " text ",
            "<a href=\"javascript:x\">a</a>",
            "![i](javascript:alert(1))",
            "<svg onload=alert(1)>",
            "\n    <img src=x>\n",
        ]);
        let mut runner = proptest::test_runner::TestRunner::new(proptest::test_runner::Config {
            cases: 3000,
            failure_persistence: None,
            ..Default::default()
        });
        runner
            .run(&prop::collection::vec(fragment, 0..12), |parts| {
                let text = parts.concat();
                let html = rendered(&md_prose(&text)).to_ascii_lowercase();
                // Tags only: inside a code span the same words are shown as text.
                for bad in [
                    "<img",
                    "<script",
                    "<svg",
                    "<a href=\"javascript",
                    "<a href=\"data",
                ] {
                    prop_assert!(!html.contains(bad), "{bad} from {text:?}: {html}");
                }
                Ok(())
            })
            .unwrap();
    }

    #[test]
    fn local_hrefs_are_relative_and_encoded() {
        assert_eq!(
            local_href(&["javascript:alert(document.domain)", "report.html"]),
            "./javascript%3Aalert%28document.domain%29/report.html"
        );
        assert_eq!(
            local_href(&["artifacts-paper", "cells.csv"]),
            "./artifacts-paper/cells.csv"
        );
    }

    /// Case 8 of the fifth reliability round: a description of 180 000 code spans took
    /// minutes (every character searched every span).
    #[test]
    fn escaping_a_description_is_linear() {
        for piece in ["`a` <b> ", "[x](javascript:a) `c` ](", "]:]:]:]:]:]:]:]:"] {
            work::assert_linear("md_prose", 2000, 1.2, |n| {
                let text = piece.repeat(n);
                let mut out = String::new();
                let steps = work::of(|| out = md_prose(&text));
                assert!(!out.contains("<b>"), "{piece}");
                steps
            });
        }
    }
}
