//! `reports/index.html`: the page a reader opens first. One card per study folder (what it
//! varies, its cells, a thumbnail, its report and tables), a link to the paper and to the
//! committed benchmarks — plain HTML with relative links, so it works from a `file://` open
//! of a clone.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result};

use super::escape;
use crate::store::{OutputDir, read_plan};

/// What the index shows of one study.
struct Study {
    /// Folder name (`artifacts-paper`).
    folder: String,
    /// Experiment name and quality.
    name: String,
    quality: String,
    /// The description's first paragraph.
    description: String,
    /// `axis (n values)` for every axis.
    axes: Vec<String>,
    cells: usize,
    done: usize,
    /// Relative path of a thumbnail (a contact sheet, else a plot), if any.
    thumbnail: Option<String>,
    has_html: bool,
}

/// The first paragraph of the experiment copy's description (plain text).
fn description(dir: &Path) -> String {
    let Ok(text) = volphot::read_text_capped(
        &dir.join("experiment.toml"),
        volphot::TEXT_INPUT_CAP,
        "experiment file",
    ) else {
        return String::new();
    };
    let table: toml::Table = text.parse().unwrap_or_default();
    let d = table
        .get("description")
        .and_then(|v| v.as_str())
        .unwrap_or("")
        .trim();
    d.split("\n\n")
        .next()
        .unwrap_or("")
        .split_whitespace()
        .collect::<Vec<_>>()
        .join(" ")
}

/// The first contact sheet, else the first plot, relative to the index.
fn thumbnail(dir: &Path, folder: &str) -> Option<String> {
    let pick = |sub: &str, prefix: &str| -> Option<String> {
        let mut names: Vec<String> = std::fs::read_dir(dir.join(sub))
            .ok()?
            .flatten()
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .filter(|n| n.starts_with(prefix) && n.ends_with(".png"))
            .collect();
        names.sort();
        names.first().map(|n| format!("{folder}/{sub}/{n}"))
    };
    pick("figures", "sheet").or_else(|| pick("figures/plots", "p"))
}

fn study(root: &Path, folder: &str) -> Result<Option<Study>> {
    let dir = root.join(folder);
    if !dir.join("plan.json").is_file() {
        return Ok(None);
    }
    let plan = read_plan(&OutputDir::new(&dir))?;
    let axes = plan
        .axes
        .iter()
        .map(|a| {
            let mut values: Vec<&serde_json::Value> = Vec::new();
            for c in &plan.cells {
                if let Some((_, v)) = c.axes.iter().find(|(k, _)| k == a)
                    && !values.contains(&v)
                {
                    values.push(v);
                }
            }
            format!("{a} ({} values)", values.len())
        })
        .collect();
    let done = std::fs::read_to_string(dir.join("cells.csv"))
        .map(|t| t.lines().filter(|l| l.contains(",done,")).count())
        .unwrap_or(0);
    Ok(Some(Study {
        folder: folder.to_string(),
        name: plan.experiment.clone(),
        quality: plan.quality.clone(),
        description: description(&dir),
        axes,
        cells: plan.cells.len(),
        done,
        thumbnail: thumbnail(&dir, folder),
        has_html: dir.join("report.html").is_file(),
    }))
}

const STYLE: &str = "body{font-family:sans-serif;max-width:1200px;margin:2em auto;padding:0 1em;color:#222}\
.grid{display:grid;grid-template-columns:repeat(auto-fill,minmax(340px,1fr));gap:1em}\
.card{border:1px solid #ccc;border-radius:6px;padding:0.8em}.card img{width:100%;height:160px;object-fit:contain;background:#111}\
.card h3{margin:0.3em 0}.meta{color:#555;font-size:0.9em}code{background:#f3f3f3;padding:0 3px}";

fn card(s: &Study) -> String {
    let mut c = String::from("<div class=\"card\">");
    let target = if s.has_html {
        format!("{}/report.html", s.folder)
    } else {
        format!("{}/report.md", s.folder)
    };
    if let Some(t) = &s.thumbnail {
        let _ = write!(
            c,
            "<a href=\"{}\"><img alt=\"{}\" src=\"{}\" loading=\"lazy\"></a>",
            escape::html(&target),
            escape::html(&s.name),
            escape::html(t)
        );
    }
    let _ = write!(
        c,
        "<h3><a href=\"{}\">{}{}</a></h3><p class=\"meta\"><code>{}</code> · {} quality · {} cells, {} done</p><p>{}</p><p class=\"meta\">varies: {}</p><p class=\"meta\"><a href=\"{}/report.md\">report.md</a> · <a href=\"{}/cells.csv\">cells.csv</a></p></div>",
        escape::html(&target),
        escape::html(&s.name),
        if s.quality == "default" {
            String::new()
        } else {
            format!(" ({})", escape::html(&s.quality))
        },
        escape::html(&s.folder),
        escape::html(&s.quality),
        s.cells,
        s.done,
        escape::html(&s.description),
        escape::html(&s.axes.join(", ")),
        escape::html(&s.folder),
        escape::html(&s.folder),
    );
    c
}

/// The committed benchmark files (`bench/*.json`), newest name last.
fn benches(root: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(root.join("bench"))
        .map(|d| {
            d.flatten()
                .map(|e| e.file_name().to_string_lossy().into_owned())
                .filter(|n| n.ends_with(".json"))
                .collect()
        })
        .unwrap_or_default();
    names.sort();
    names
}

/// `REPRODUCTION.md` as a page beside it (CommonMark with tables; the claims' comments are
/// invisible), so the paper reads in a browser from a clone; `None` without the paper.
fn write_paper(root: &Path) -> Result<Option<PathBuf>> {
    let source = root.join("REPRODUCTION.md");
    if !source.is_file() {
        return Ok(None);
    }
    let markdown =
        volphot::read_text_capped(&source, volphot::TEXT_INPUT_CAP, "Markdown document")?;
    let options = pulldown_cmark::Options::ENABLE_TABLES
        | pulldown_cmark::Options::ENABLE_HEADING_ATTRIBUTES
        | pulldown_cmark::Options::ENABLE_FOOTNOTES;
    let mut body = String::new();
    pulldown_cmark::html::push_html(
        &mut body,
        pulldown_cmark::Parser::new_ext(&markdown, options),
    );
    let html = format!(
        "<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>volphot: reproducing the 2006 study</title><style>{PAPER_STYLE}</style></head><body>\n<p><a href=\"index.html\">← all studies</a></p>\n{body}</body></html>\n"
    );
    let path = root.join("REPRODUCTION.html");
    volphot::write_atomic(&path, html.as_bytes())?;
    Ok(Some(path))
}

const PAPER_STYLE: &str = "body{font-family:serif;max-width:860px;margin:2em auto;padding:0 1em;color:#222;line-height:1.45}\
table{border-collapse:collapse;font-size:0.9em;margin:1em 0;display:block;overflow-x:auto}td,th{border:1px solid #ccc;padding:2px 6px}\
th{background:#eee}img{max-width:100%}code{background:#f3f3f3;padding:0 3px;font-size:0.9em}";

/// Writes `root/index.html` for every study folder below `root`; returns its path.
pub(crate) fn write_index(root: &Path) -> Result<PathBuf> {
    let mut folders: Vec<String> = std::fs::read_dir(root)
        .with_context(|| format!("reading {}", root.display()))?
        .flatten()
        .filter(|e| e.path().is_dir())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    folders.sort();
    let mut studies = Vec::new();
    for f in &folders {
        if let Some(s) = study(root, f)? {
            studies.push(s);
        }
    }
    let mut body = String::new();
    let paper = write_paper(root)?;
    let _ = write!(
        body,
        "<h1>volphot: the studies</h1><p>The thesis's findings, checked one by one, are in the paper: {}. A study whose explorer data are committed opens its report.html with the image explorer (pick two cells, compare, zoom, read pixel values); the others open their report.md until they are rendered again.</p>",
        match paper {
            Some(_) =>
                "<a href=\"REPRODUCTION.html\">REPRODUCTION</a> (<a href=\"REPRODUCTION.md\">Markdown</a>)",
            None => "<a href=\"REPRODUCTION.md\">REPRODUCTION.md</a>",
        }
    );
    let benches = benches(root);
    if !benches.is_empty() {
        body += "<p>Benchmarks (machine, configurations, every run's times): ";
        body += &benches
            .iter()
            .map(|b| format!("<a href=\"bench/{0}\">{0}</a>", escape::html(b)))
            .collect::<Vec<_>>()
            .join(", ");
        body += "</p>";
    }
    let _ = write!(
        body,
        "<p>{} studies.</p><div class=\"grid\">",
        studies.len()
    );
    for s in &studies {
        body += &card(s);
    }
    body += "</div>";
    let html = format!(
        "<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>volphot studies</title><style>{STYLE}</style></head><body>\n{body}\n</body></html>\n"
    );
    let path = root.join("index.html");
    volphot::write_atomic(&path, html.as_bytes())?;
    Ok(path)
}
