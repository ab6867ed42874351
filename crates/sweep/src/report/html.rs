//! `report.html`: the report's Markdown as one self-contained page (images inlined), for a
//! plain `file://` open without a network, with the image explorer before the first
//! section; plot points and rows of the cells table open their cells in it. The Markdown is
//! parsed by pulldown-cmark (CommonMark with GitHub's tables, strikethrough and footnotes)
//! through the pages' one sanitiser ([`escape::page_events`]), so the page shows what
//! `report.md` shows on a code host: table alignment rows, joined paragraph lines, escapes.

use std::fmt::Write as _;
use std::path::Path;

use anyhow::{Context, Result};
use base64::Engine as _;
use pulldown_cmark::{CowStr, Event, HeadingLevel, Tag, TagEnd};

use super::escape;
use super::explorer::Explorer;
use super::{Figures, PlotFigure};
use crate::confine::Refused;

/// The page's own style. Wide tables scroll inside their box (`.table-wrap`) instead of
/// widening the page; a figure's caption is the emphasised paragraph after it.
const STYLE: &str = "body{font-family:sans-serif;max-width:1200px;margin:2em auto;padding:0 1em;color:#222}\
table{border-collapse:collapse;font-size:0.85em;margin:1em 0}td,th{border:1px solid #ccc;padding:2px 6px;text-align:right}\
th{background:#eee}img{max-width:100%}figure{margin:1em 0 0 0}figure+p{font-style:italic;color:#555;margin-top:0.2em}\
.table-wrap{max-width:100%;overflow-x:auto}code{background:#f3f3f3;padding:0 3px}";

/// The clickable points over a plot image: an SVG with the plot's geometry, one circle per
/// drawn point carrying the plan indices of its cells.
fn plot_points(plot: &PlotFigure) -> String {
    let (w, h) = plot.size;
    let mut svg =
        format!("<svg class=\"plot-points\" viewBox=\"0 0 {w} {h}\" preserveAspectRatio=\"none\">");
    for p in &plot.points {
        let cells: Vec<String> = p.cells.iter().map(usize::to_string).collect();
        let _ = write!(
            svg,
            "<circle cx=\"{}\" cy=\"{}\" r=\"9\" data-cells=\"{}\"><title>{}</title></circle>",
            p.at.0,
            p.at.1,
            cells.join(" "),
            escape::html(&p.text)
        );
    }
    svg + "</svg>"
}

/// An image of the report's folder as a `<figure>` with the PNG inlined; a plot gets its
/// clickable points. An image the Markdown names outside the folder (an absolute path, `..`,
/// a link out, a hidden file: a description can name any) is not read — `None`, and it
/// stays an address for the browser — so no file of the machine is inlined into the page.
fn figure(
    root: &Path,
    src: &str,
    alt: &str,
    plots: &[(String, &PlotFigure)],
) -> Result<Option<String>> {
    let folder =
        std::fs::canonicalize(root).with_context(|| format!("reading {}", root.display()))?;
    let path = match crate::confine::inside(&root.join(src), &folder) {
        Ok(path) => path,
        Err(Refused::Missing(path)) => {
            anyhow::bail!("embedding {src}: {} does not exist", path.display())
        }
        Err(Refused::Outside { .. } | Refused::Hidden(_)) => return Ok(None),
    };
    let bytes = volphot::read_bytes_capped(&path, 256 << 20, "figure (PNG)")
        .with_context(|| format!("embedding {src}"))?;
    let data = base64::engine::general_purpose::STANDARD.encode(bytes);
    let img = format!(
        "<img alt=\"{}\" src=\"data:image/png;base64,{data}\">",
        escape::html(alt)
    );
    Ok(Some(match plots.iter().find(|(path, _)| path == src) {
        Some((_, plot)) => format!(
            "<figure class=\"plot\"><div class=\"plot-box\">{img}{}</div></figure>\n",
            plot_points(plot)
        ),
        None => format!("<figure>{img}</figure>\n"),
    }))
}

/// A paragraph that holds one image and nothing else: its source and alt text.
fn lone_image<'a>(events: &[Event<'a>]) -> Option<(CowStr<'a>, String, usize)> {
    let [
        Event::Start(Tag::Paragraph),
        Event::Start(Tag::Image { dest_url, .. }),
        rest @ ..,
    ] = events
    else {
        return None;
    };
    let mut alt = String::new();
    for (i, e) in rest.iter().enumerate() {
        match e {
            Event::Text(t) | Event::Code(t) => alt.push_str(t),
            Event::End(TagEnd::Image) => {
                return matches!(rest.get(i + 1), Some(Event::End(TagEnd::Paragraph)))
                    .then(|| (dest_url.clone(), alt, i + 4));
            }
            _ => {}
        }
    }
    None
}

/// The index of the heading the explorer goes before: the first section after "What
/// changed" (the report's few sentences are read before the images are explored).
fn explorer_position(events: &[Event<'_>]) -> Option<usize> {
    let h2 = |e: &Event<'_>| matches!(e, Event::Start(Tag::Heading { level, .. }) if *level == HeadingLevel::H2);
    events.iter().enumerate().position(|(i, e)| {
        h2(e) && !matches!(events.get(i + 1), Some(Event::Text(t)) if t.as_ref() == "What changed")
    })
}

/// Turns the report's Markdown into a self-contained HTML page (images inlined) with the
/// explorer.
pub(crate) fn html(
    root: &Path,
    markdown: &str,
    explorer: &Explorer,
    figures: &Figures,
) -> Result<String> {
    let plots: Vec<(String, &PlotFigure)> = figures
        .plots
        .iter()
        .map(|p| (super::markdown::rel(root, &p.path), p))
        .collect();
    // The one sanitiser: nothing but allow-listed markup reaches the page from the
    // Markdown; the page's own markup (figures, the explorer) is added below.
    let events: Vec<Event> = escape::page_events(markdown);
    let explorer_at = explorer_position(&events);
    let mut out: Vec<Event> = Vec::with_capacity(events.len());
    let (mut explorer_placed, mut in_section_title, mut section) = (false, false, String::new());
    let mut i = 0;
    while i < events.len() {
        if let Some((src, alt, used)) = lone_image(&events[i..])
            && let Some(figure) = figure(root, &src, &alt, &plots)?
        {
            out.push(Event::Html(figure.into()));
            i += used;
            continue;
        }
        let event = events[i].clone();
        i += 1;
        match &event {
            // The explorer goes before the first section after the summary.
            Event::Start(Tag::Heading { level, .. }) if *level == HeadingLevel::H2 => {
                if !explorer_placed && Some(i - 1) == explorer_at {
                    out.push(Event::Html(explorer.section().into()));
                    explorer_placed = true;
                }
                in_section_title = true;
                section.clear();
            }
            Event::End(TagEnd::Heading(HeadingLevel::H2)) => in_section_title = false,
            Event::Text(t) if in_section_title => section.push_str(t),
            // The cells table: the explorer sorts and filters it, a row opens its cell.
            Event::Start(Tag::Table(_)) => {
                let id = if section == "Cells" {
                    " id=\"cells-table-wrap\""
                } else {
                    ""
                };
                out.push(Event::Html(
                    format!("<div class=\"table-wrap\"{id}>").into(),
                ));
            }
            _ => {}
        }
        let closes_table = matches!(event, Event::End(TagEnd::Table));
        out.push(event);
        if closes_table {
            out.push(Event::Html("</div>\n".into()));
        }
    }
    let mut body = String::new();
    pulldown_cmark::html::push_html(&mut body, out.into_iter());
    // pulldown-cmark writes tables without attributes: the cells table gets its id here.
    let body = body.replacen(
        "<div class=\"table-wrap\" id=\"cells-table-wrap\"><table>",
        "<div class=\"table-wrap\"><table id=\"cells-table\">",
        1,
    );
    let explorer_tail = if explorer_placed {
        String::new()
    } else {
        explorer.section()
    };
    Ok(format!(
        "<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>volphot report</title><style>{STYLE}</style></head><body>\n{body}{explorer_tail}{}</body></html>\n",
        explorer.script()
    ))
}
