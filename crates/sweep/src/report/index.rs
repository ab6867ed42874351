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
        names.first().map(|n| {
            let mut segments = vec![folder];
            segments.extend(sub.split('/'));
            segments.push(n);
            escape::local_href(&segments)
        })
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
    let done = volphot::read_text_capped(
        &dir.join("cells.csv"),
        volphot::TEXT_INPUT_CAP,
        "cells table",
    )
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
    let target = escape::local_href(&[
        &s.folder,
        if s.has_html {
            "report.html"
        } else {
            "report.md"
        },
    ]);
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
        escape::local_href(&[&s.folder]),
        escape::local_href(&[&s.folder]),
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
    // Rendered like a report: no raw HTML (the claims' comments are dropped), no link but
    // relative and http(s).
    pulldown_cmark::html::push_html(
        &mut body,
        escape::safe_events(pulldown_cmark::Parser::new_ext(&markdown, options)).into_iter(),
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

/// What `sweep index` wrote: the page, and the folders it skipped (with why).
pub(crate) struct Index {
    pub(crate) path: PathBuf,
    pub(crate) skipped: Vec<(String, String)>,
}

/// Writes `root/index.html` for every study folder below `root`. A folder whose records
/// cannot be read is skipped and named, never the whole index lost.
pub(crate) fn write_index(root: &Path) -> Result<Index> {
    let mut folders: Vec<String> = std::fs::read_dir(root)
        .with_context(|| format!("reading {}", root.display()))?
        .flatten()
        .filter(|e| e.path().is_dir())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    folders.sort();
    let mut studies = Vec::new();
    let mut skipped = Vec::new();
    for f in &folders {
        match study(root, f) {
            Ok(Some(s)) => studies.push(s),
            Ok(None) => {}
            Err(e) => skipped.push((f.clone(), format!("{e:#}"))),
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
            .map(|b| {
                format!(
                    "<a href=\"{}\">{}</a>",
                    escape::local_href(&["bench", b]),
                    escape::html(b)
                )
            })
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
    Ok(Index { path, skipped })
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// A real study's plan, as a valid `plan.json`.
    const PLAN: &str = include_str!("../../../../reports/quickstart/plan.json");

    /// Hostile folder names and contents: nothing reaches the page as markup or a script
    /// link, and a broken study is skipped and named.
    fn folder_name() -> impl Strategy<Value = String> {
        prop_oneof![
            Just("quickstart".to_string()),
            Just("javascript:alert(document.domain)".to_string()),
            Just("JaVaScRiPt:alert(1)".to_string()),
            Just("\"><img src=x onerror=alert(1)>".to_string()),
            Just("a b#c?d".to_string()),
            Just("données".to_string()),
            Just("data:text,x".to_string()),
        ]
    }

    #[derive(Debug, Clone)]
    enum PlanFile {
        Valid,
        Broken,
        Fifo,
        Sparse,
        Folder,
        Missing,
    }

    fn plan_file() -> impl Strategy<Value = PlanFile> {
        prop_oneof![
            3 => Just(PlanFile::Valid),
            1 => Just(PlanFile::Broken),
            1 => Just(PlanFile::Fifo),
            1 => Just(PlanFile::Sparse),
            1 => Just(PlanFile::Folder),
            1 => Just(PlanFile::Missing),
        ]
    }

    fn description() -> impl Strategy<Value = String> {
        prop_oneof![
            Just("A study.".to_string()),
            Just("Tick ` then <img src=x onerror=alert(11)> end.".to_string()),
            Just("[the data](javascript:alert(12))".to_string()),
            Just("<script>alert(1)</script>".to_string()),
            Just("\"\"\"".to_string()),
        ]
    }

    /// One generated study folder: its name, its plan, its description, whether its
    /// `cells.csv` is a FIFO.
    type Study = (String, PlanFile, String, bool);

    fn case() -> impl Strategy<Value = (Vec<Study>, bool)> {
        (
            prop::collection::vec(
                (folder_name(), plan_file(), description(), any::<bool>()),
                1..4,
            ),
            any::<bool>(),
        )
    }

    /// Builds the generated folders and writes the index; accepted when nothing was skipped.
    fn build(dir: &Path, (studies, paper): (Vec<Study>, bool)) -> Result<bool, String> {
        let root = tempfile::tempdir_in(dir).unwrap();
        let root = root.path();
        for (name, plan, description, fifo_csv) in studies {
            let folder = root.join(&name);
            // One folder per name: a repeated name keeps its first contents.
            if folder.exists() {
                continue;
            }
            std::fs::create_dir_all(&folder).unwrap();
            std::fs::write(
                folder.join("experiment.toml"),
                format!("name = \"x\"\ndescription = {description:?}\n"),
            )
            .unwrap();
            let plan_path = folder.join("plan.json");
            match plan {
                PlanFile::Valid => std::fs::write(&plan_path, PLAN).unwrap(),
                PlanFile::Broken => std::fs::write(&plan_path, "{broken").unwrap(),
                PlanFile::Fifo => {
                    std::process::Command::new("mkfifo")
                        .arg(&plan_path)
                        .status()
                        .unwrap();
                }
                PlanFile::Sparse => std::fs::File::create(&plan_path)
                    .unwrap()
                    .set_len(3 << 30)
                    .unwrap(),
                PlanFile::Folder => std::fs::create_dir_all(&plan_path).unwrap(),
                PlanFile::Missing => {}
            }
            let csv = folder.join("cells.csv");
            if fifo_csv {
                std::process::Command::new("mkfifo")
                    .arg(&csv)
                    .status()
                    .unwrap();
            } else {
                std::fs::write(&csv, "cell,status\n0,done,\n").unwrap();
            }
        }
        if paper {
            std::fs::write(
                root.join("REPRODUCTION.md"),
                "# Paper\n\n<script>alert(1)</script>\n\n[j](javascript:alert(2)) 0.5<!-- = value(s: x) -->\n",
            )
            .unwrap();
        }
        let index = write_index(root).map_err(|e| format!("{e:#}"))?;
        for page in ["index.html", "REPRODUCTION.html"] {
            let Ok(html) = std::fs::read_to_string(root.join(page)) else {
                continue;
            };
            let lower = html.to_ascii_lowercase();
            for bad in [
                "<script",
                "<img src=x",
                "href=\"javascript",
                "src=\"javascript",
                "href=\"data:",
            ] {
                if lower.contains(bad) {
                    return Err(format!("{page} holds `{bad}`"));
                }
            }
        }
        Ok(index.skipped.is_empty())
    }

    /// Case 9 and "one broken plan.json fails the whole index" of the fourth reliability
    /// round, and cases 3–4 (links and raw HTML): hostile names and broken records.
    #[test]
    fn fuzz_index_folders() {
        let dir = tempfile::tempdir().unwrap();
        crate::fuzz::run("index", dir.path(), 120, case(), build);
    }

    #[test]
    fn a_broken_study_is_skipped_and_named() {
        let dir = tempfile::tempdir().unwrap();
        for (name, plan) in [("good", PLAN), ("bad", "{broken")] {
            std::fs::create_dir_all(dir.path().join(name)).unwrap();
            std::fs::write(dir.path().join(name).join("plan.json"), plan).unwrap();
        }
        let index = write_index(dir.path()).unwrap();
        assert_eq!(index.skipped.len(), 1);
        assert_eq!(index.skipped[0].0, "bad");
        let html = std::fs::read_to_string(index.path).unwrap();
        assert!(html.contains("./good/"), "{html}");
    }
}
