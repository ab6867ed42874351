//! `report.html`: the report's Markdown as one self-contained page (images inlined), for a
//! plain `file://` open without a network, with the image explorer before the first
//! section; plot points and rows of the cells table open their cells in it.

use std::fmt::Write as _;
use std::path::Path;

use anyhow::{Context, Result};
use base64::Engine as _;

use super::explorer::Explorer;
use super::{Figures, PlotFigure};

const STYLE: &str = "body{font-family:sans-serif;max-width:1200px;margin:2em auto;padding:0 1em;color:#222}\
table{border-collapse:collapse;font-size:0.85em;margin:1em 0}td,th{border:1px solid #ccc;padding:2px 6px;text-align:right}\
th{background:#eee}img{max-width:100%}figure{margin:1em 0 0 0}.caption{font-style:italic;color:#555;margin-top:0.2em}\
code{background:#f3f3f3;padding:0 3px}";

fn escape(t: &str) -> String {
    t.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

/// Inline Markdown: `code` and `[text](link)`.
fn inline(t: &str) -> String {
    let mut out = String::new();
    let mut code = false;
    for (i, part) in escape(t).split('`').enumerate() {
        if i > 0 {
            out += if code { "</code>" } else { "<code>" };
            code = !code;
        }
        out += part;
    }
    let mut result = String::new();
    let mut rest = out.as_str();
    while let Some(start) = rest.find('[') {
        let Some(mid) = rest[start..].find("](") else {
            break;
        };
        let Some(end) = rest[start + mid..].find(')') else {
            break;
        };
        result += &rest[..start];
        let text = &rest[start + 1..start + mid];
        let href = &rest[start + mid + 2..start + mid + end];
        result += &format!("<a href=\"{href}\">{text}</a>");
        rest = &rest[start + mid + end + 1..];
    }
    result += rest;
    result
}

/// Open blocks while converting line by line.
struct Blocks<'a> {
    body: String,
    in_table: bool,
    in_list: bool,
    /// The current `##` section's title.
    section: String,
    /// The plots, by their path relative to the report.
    plots: Vec<(String, &'a PlotFigure)>,
}

impl Blocks<'_> {
    /// Closes a table or list that the line does not continue.
    fn close_unless(&mut self, trimmed: &str) {
        if self.in_table && !trimmed.starts_with('|') {
            self.body += "</table>\n";
            self.in_table = false;
        }
        if self.in_list && !trimmed.starts_with("- ") {
            self.body += "</ul>\n";
            self.in_list = false;
        }
    }

    /// A table row; the first row is a header when the next line is a rule.
    fn table_row(&mut self, trimmed: &str, next: Option<&&str>) {
        if trimmed.chars().all(|c| matches!(c, '|' | '-' | ' ')) {
            return;
        }
        let header = !self.in_table
            && next.is_some_and(|n| n.trim().starts_with("|-") || n.trim().starts_with("|--"));
        if !self.in_table {
            // The cells table: the explorer sorts and filters it, a row opens its cell.
            self.body += if self.section == "Cells" {
                "<table id=\"cells-table\">\n"
            } else {
                "<table>\n"
            };
            self.in_table = true;
        }
        let tag = if header { "th" } else { "td" };
        let cells: Vec<String> = trimmed
            .trim_matches('|')
            .split(" | ")
            .map(|c| format!("<{tag}>{}</{tag}>", inline(c.trim())))
            .collect();
        self.body += &format!("<tr>{}</tr>\n", cells.join(""));
    }

    /// An image, embedded as a data URL.
    fn image(&mut self, root: &Path, img: &str) -> Result<()> {
        let (alt, src) = img.split_once("](").unwrap_or(("", ""));
        let src = src.trim_end_matches(')');
        let bytes = std::fs::read(root.join(src)).with_context(|| format!("embedding {src}"))?;
        let data = base64::engine::general_purpose::STANDARD.encode(bytes);
        let img = format!(
            "<img alt=\"{}\" src=\"data:image/png;base64,{data}\">",
            escape(alt)
        );
        match self.plots.iter().find(|(path, _)| path == src) {
            Some((_, plot)) => {
                self.body += &format!(
                    "<figure class=\"plot\"><div class=\"plot-box\">{img}{}</div></figure>\n",
                    plot_points(plot)
                );
            }
            None => self.body += &format!("<figure>{img}</figure>\n"),
        }
        Ok(())
    }

    /// Any other line: heading, list item, caption or paragraph.
    fn text(&mut self, line: &str, trimmed: &str) {
        if let Some(h) = trimmed.strip_prefix("### ") {
            self.body += &format!("<h3>{}</h3>\n", inline(h));
        } else if let Some(h) = trimmed.strip_prefix("## ") {
            self.section = h.trim().to_string();
            self.body += &format!("<h2>{}</h2>\n", inline(h));
        } else if let Some(h) = trimmed.strip_prefix("# ") {
            self.body += &format!("<h1>{}</h1>\n", inline(h));
        } else if let Some(item) = trimmed.strip_prefix("- ") {
            if !self.in_list {
                self.body += "<ul>\n";
                self.in_list = true;
            }
            self.body += &format!("<li>{}</li>\n", inline(item));
        } else if trimmed.starts_with('*') && trimmed.ends_with('*') && trimmed.len() > 2 {
            self.body += &format!(
                "<p class=\"caption\">{}</p>\n",
                inline(trimmed.trim_matches('*'))
            );
        } else if !trimmed.is_empty() {
            let tag = if line.starts_with("    ") { "pre" } else { "p" };
            self.body += &format!("<{tag}>{}</{tag}>\n", inline(trimmed));
        }
    }
}

/// The clickable points over a plot image: an SVG with the plot's geometry, one circle per
/// drawn point carrying the plan indices of its cells.
fn plot_points(plot: &PlotFigure) -> String {
    let (w, h) = super::chart::PLOT_SIZE;
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
            escape(&p.text)
        );
    }
    svg + "</svg>"
}

/// Turns the report's Markdown into a self-contained HTML page (images inlined) with the
/// explorer.
pub(crate) fn html(
    root: &Path,
    markdown: &str,
    explorer: &Explorer,
    figures: &Figures,
) -> Result<String> {
    let mut blocks = Blocks {
        body: String::new(),
        in_table: false,
        in_list: false,
        section: String::new(),
        plots: figures
            .plots
            .iter()
            .map(|p| (super::markdown::rel(root, &p.path), p))
            .collect(),
    };
    let lines: Vec<&str> = markdown.lines().collect();
    let mut explorer_placed = false;
    for (li, line) in lines.iter().enumerate() {
        let trimmed = line.trim();
        blocks.close_unless(trimmed);
        if !explorer_placed && trimmed.starts_with("## ") {
            blocks.body += &explorer.section();
            explorer_placed = true;
        }
        if trimmed.starts_with("#") || trimmed.starts_with("- ") {
            blocks.text(line, trimmed);
        } else if let Some(img) = trimmed.strip_prefix("![") {
            blocks.image(root, img)?;
        } else if trimmed.starts_with('|') {
            blocks.table_row(trimmed, lines.get(li + 1));
        } else {
            blocks.text(line, trimmed);
        }
    }
    blocks.close_unless("");
    if !explorer_placed {
        blocks.body += &explorer.section();
    }
    Ok(format!(
        "<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>volphot report</title><style>{STYLE}</style></head><body>\n{}{}</body></html>\n",
        blocks.body,
        explorer.script()
    ))
}
