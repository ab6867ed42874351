//! `reports/index.html`: the page a reader starts at. The studies in the order of the paper
//! (the thesis's question §1.1 first, then C1–C9, then beyond the thesis), each card with
//! the claims it answers and the paper's verdict on each, a representative image large
//! enough to see, and links to its report and image explorer (and its default-quality
//! check); then the benchmarks. Plain HTML with relative, percent-encoded links, so it works
//! from a `file://` open of a clone. What it says of the claims is read from the paper
//! ([`paper`]), never retyped.

mod paper;

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result};

use super::escape;
use crate::confine::Refused;
use crate::store::{OutputDir, read_plan};

/// What the index shows of one study folder.
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
    /// The image that stands for it (a contact sheet of the whole image, else any sheet,
    /// else a plot), relative to the index.
    image: Option<String>,
    has_html: bool,
}

/// The first paragraph of the description in the experiment copy at `file` (plain text).
fn description(file: Option<&Path>) -> String {
    let Some(Ok(text)) = file
        .map(|file| volphot::read_text_capped(file, volphot::TEXT_INPUT_CAP, "experiment file"))
    else {
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

/// The study's representative image: its first contact sheet of the whole image (single
/// against single + multiple, say), else its first sheet, else its first plot.
fn representative_image(dir: &Path, folder: &str) -> Option<String> {
    let pick = |sub: &str, wanted: &dyn Fn(&str) -> bool| -> Option<String> {
        let mut names: Vec<String> = std::fs::read_dir(dir.join(sub))
            .ok()?
            .flatten()
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .filter(|n| n.ends_with(".png") && wanted(n))
            .collect();
        names.sort();
        names.first().map(|n| {
            let mut segments = vec![folder];
            segments.extend(sub.split('/'));
            segments.push(n);
            escape::local_href(&segments)
        })
    };
    pick("figures", &|n| {
        n.starts_with("sheet") && n.contains("_total_")
    })
    .or_else(|| pick("figures", &|n| n.starts_with("sheet")))
    .or_else(|| pick("figures/plots", &|n| n.starts_with('p')))
}

/// A file of the indexed folder, resolved inside `repository` ([`crate::confine`]); `None`
/// when there is none. A link out of the repository or a hidden file is an error: its text
/// would be rendered into a page that gets committed.
fn confined(path: &Path, repository: &Path) -> Result<Option<PathBuf>> {
    match crate::confine::inside(path, repository) {
        Ok(real) => Ok(Some(real)),
        Err(Refused::Missing(_)) => Ok(None),
        Err(refused) => anyhow::bail!(
            "{refused}; the index reads only files inside the repository it indexes, {}",
            repository.display()
        ),
    }
}

/// A study folder's card data; `None` when it holds no `plan.json`. Every file it reads
/// stays inside `repository`.
fn study(root: &Path, repository: &Path, folder: &str) -> Result<Option<Study>> {
    let dir = root.join(folder);
    let Some(plan_file) = confined(&dir.join("plan.json"), repository)? else {
        return Ok(None);
    };
    let experiment = confined(&dir.join("experiment.toml"), repository)?;
    let cells_table = confined(&dir.join("cells.csv"), repository)?;
    let plan = read_plan(&OutputDir::new(plan_file.parent().unwrap_or(&dir)))?;
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
    let done = cells_table
        .and_then(|file| {
            volphot::read_text_capped(&file, volphot::TEXT_INPUT_CAP, "cells table").ok()
        })
        .map_or(0, |t| t.lines().filter(|l| l.contains(",done,")).count());
    Ok(Some(Study {
        folder: folder.to_string(),
        name: plan.experiment.clone(),
        quality: plan.quality.clone(),
        description: description(experiment.as_deref()),
        axes,
        cells: plan.cells.len(),
        done,
        image: representative_image(&dir, folder),
        has_html: dir.join("report.html").is_file(),
    }))
}

const STYLE: &str = "body{font-family:sans-serif;max-width:1280px;margin:2em auto;padding:0 1em;color:#222;line-height:1.4}\
.grid{display:grid;grid-template-columns:repeat(auto-fill,minmax(520px,1fr));gap:1.2em}\
.card{border:1px solid #ccc;border-radius:6px;padding:0.9em}.card img{width:100%;max-height:420px;object-fit:contain;background:#1a1a1a;border-radius:4px}\
.card h3{margin:0.3em 0}.meta{color:#555;font-size:0.9em}.claims{margin:0.4em 0;padding-left:1.2em}.claims li{margin:0.15em 0}\
.tag{display:inline-block;background:#eef;border-radius:3px;padding:0 5px;font-weight:bold;margin-right:4px}code{background:#f3f3f3;padding:0 3px}";

/// A study's card: the paper's name for it, the claims it answers with their verdicts, its
/// image, its links.
fn card(
    s: &Study,
    entry: Option<&paper::Entry>,
    paper: &paper::Paper,
    quick: Option<&Study>,
) -> String {
    let report = escape::local_href(&[
        &s.folder,
        if s.has_html {
            "report.html"
        } else {
            "report.md"
        },
    ]);
    let title = entry.map_or(s.name.clone(), |e| e.label.clone());
    let mut c = format!(
        "<div class=\"card\" id=\"{}\"><h3><a href=\"{report}\">{}</a></h3>",
        escape::html(&s.folder),
        escape::html(&title)
    );
    if let Some(e) = entry.filter(|e| !e.claims.is_empty()) {
        c += &claims_list(e, paper);
    } else if entry.is_some() {
        c += "<p class=\"meta\">beyond the thesis</p>";
    }
    if let Some(image) = &s.image {
        let _ = write!(
            c,
            "<a href=\"{report}\"><img alt=\"{}\" src=\"{image}\" loading=\"lazy\"></a>",
            escape::html(&format!("{title}: a figure of the study"))
        );
    }
    let _ = write!(
        c,
        "<p>{}</p><p class=\"meta\"><code>{}</code> · {} quality · {} cells, {} done · varies: {}</p>",
        escape::html(&s.description),
        escape::html(&s.folder),
        escape::html(&s.quality),
        s.cells,
        s.done,
        escape::html(&s.axes.join(", ")),
    );
    let links = card_links(s, &report, quick);
    let _ = write!(c, "<p class=\"meta\">{}</p></div>", links.join(" · "));
    c
}

/// The claims a card answers, each with the paper's verdict (read from the paper, never
/// retyped).
fn claims_list(entry: &paper::Entry, paper: &paper::Paper) -> String {
    let mut list = "<ul class=\"claims\">".to_string();
    for claim in &entry.claims {
        let verdict = match claim.as_str() {
            "§1.1" => {
                "does global illumination make medical volume images better? the paper's answer"
                    .to_string()
            }
            other => paper.verdict(other).unwrap_or("").to_string(),
        };
        let _ = write!(
            list,
            "<li><span class=\"tag\">{}</span>{}</li>",
            escape::html(claim),
            escape::html(&verdict)
        );
    }
    list + "</ul>"
}

/// A card's links: its report, explorer, tables and the default-quality check.
fn card_links(s: &Study, report: &str, quick: Option<&Study>) -> Vec<String> {
    let mut links = vec![format!("<a href=\"{report}\">report</a>")];
    if s.has_html {
        links.push(format!("<a href=\"{report}#explorer\">image explorer</a>"));
    }
    links.push(format!(
        "<a href=\"{}\">report.md</a>",
        escape::local_href(&[&s.folder, "report.md"])
    ));
    links.push(format!(
        "<a href=\"{}\">cells.csv</a>",
        escape::local_href(&[&s.folder, "cells.csv"])
    ));
    if let Some(q) = quick {
        let page = if q.has_html {
            "report.html"
        } else {
            "report.md"
        };
        links.push(format!(
            "<a href=\"{}\">the default-quality check ({})</a>",
            escape::local_href(&[&q.folder, page]),
            escape::html(&q.folder)
        ));
    }
    links
}

/// The committed benchmark files (`bench/*.json`), by name.
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

/// What `sweep index` wrote: the page, and the folders it skipped (with why).
pub(crate) struct Index {
    pub(crate) path: PathBuf,
    pub(crate) skipped: Vec<(String, String)>,
}

/// The studies in the paper's order: a study's place is its first claim's (§1.1, then C1 …
/// C9, then the paper's beyond-the-thesis rows in their order, then studies the paper does
/// not name). A default-quality study goes with its `-paper` sibling.
fn ordered<'a>(studies: &'a [Study], paper: &paper::Paper) -> Vec<(&'a Study, Option<&'a Study>)> {
    let rank = |s: &Study| -> (usize, usize, usize, String) {
        match paper.entry_of(&s.folder) {
            Some((row, e)) => {
                let first = e.claims.first().map_or(1000, |c| match c.as_str() {
                    "§1.1" => 0,
                    c => c.trim_start_matches('C').parse::<usize>().unwrap_or(999),
                });
                let base = s.folder.strip_suffix("-paper").unwrap_or(&s.folder);
                let at = e
                    .folders
                    .iter()
                    .position(|f| f.strip_suffix("-paper").unwrap_or(f) == base)
                    .unwrap_or(0);
                (first, row, at, s.folder.clone())
            }
            None => (2000, 0, 0, s.folder.clone()),
        }
    };
    let mut main: Vec<&Study> = studies
        .iter()
        .filter(|s| {
            s.folder.ends_with("-paper")
                || !studies
                    .iter()
                    .any(|o| o.folder == format!("{}-paper", s.folder))
        })
        .collect();
    main.sort_by_key(|s| rank(s));
    main.into_iter()
        .map(|s| {
            let quick = s
                .folder
                .strip_suffix("-paper")
                .and_then(|base| studies.iter().find(|o| o.folder == base));
            (s, quick)
        })
        .collect()
}

/// Writes `root/index.html` for every study folder below `root` (and the paper's page). A
/// folder whose records cannot be read is skipped and named, never the whole index lost.
/// Every file read stays inside the repository that holds `root` (or `root` itself outside
/// a repository): a paper that links out of it is refused, a study that does is skipped.
pub(crate) fn write_index(root: &Path) -> Result<Index> {
    let repository = crate::confine::repository_of(root)
        .with_context(|| format!("reading {}", root.display()))?;
    let mut folders: Vec<String> = std::fs::read_dir(root)
        .with_context(|| format!("reading {}", root.display()))?
        .flatten()
        .filter(|e| e.path().is_dir())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        // Hidden folders (`.git`, caches) are not studies.
        .filter(|name| !name.starts_with('.'))
        .collect();
    folders.sort();
    let mut studies = Vec::new();
    let mut skipped = Vec::new();
    for f in &folders {
        match study(root, &repository, f) {
            Ok(Some(s)) => studies.push(s),
            Ok(None) => {}
            Err(e) => skipped.push((f.clone(), format!("{e:#}"))),
        }
    }
    let markdown = confined(&root.join("REPRODUCTION.md"), &repository)?
        .map(|paper| {
            volphot::read_text_capped(&paper, volphot::TEXT_INPUT_CAP, "Markdown document")
        })
        .transpose()?;
    let paper_page = paper::write_page(root, markdown.as_deref())?;
    let paper = markdown.as_deref().map(paper::parse).unwrap_or_default();
    let mut body = String::from("<h1>volphot: the studies</h1>");
    let _ = write!(
        body,
        "<p>A 2006 student thesis asked whether light scattered more than once makes CT and MRI volume images better, and stated its findings C1–C9 from the images it saw. The paper, {}, measures each again; the studies below are its data, in its order, each with the claims it answers and the paper's verdict. Every study opens in its report with an image explorer (pick two cells, compare them, zoom to pixels, read the values).</p>",
        match paper_page {
            Some(_) =>
                "<a href=\"./REPRODUCTION.html\">REPRODUCTION</a> (<a href=\"./REPRODUCTION.md\">Markdown</a>)",
            None => "<a href=\"./REPRODUCTION.md\">REPRODUCTION.md</a>",
        }
    );
    if let Some(answer) = &paper.answer {
        let page = if paper_page.is_some() {
            "./REPRODUCTION.html"
        } else {
            "./REPRODUCTION.md"
        };
        let _ = write!(
            body,
            "<p><b>The answer:</b> {}</p>",
            paper::answer_html(answer, page)
        );
    }
    let ordered = ordered(&studies, &paper);
    let _ = write!(body, "<div class=\"grid\">");
    for (s, quick) in &ordered {
        body += &card(s, paper.entry_of(&s.folder).map(|(_, e)| e), &paper, *quick);
    }
    body += "</div>";
    let benches = benches(root);
    if !benches.is_empty() {
        body += "<h2>Benchmarks</h2><p>The machine, the configurations and every run's times: ";
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
    const PLAN: &str = include_str!("../../../../../reports/quickstart/plan.json");

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

    /// Row 4 of the fifth reliability round: a `REPRODUCTION.md` or a study's
    /// `experiment.toml` that links to a file outside the repository had that file's text
    /// rendered into the pages.
    #[test]
    fn files_that_link_out_of_the_repository_are_not_read() {
        let dir = tempfile::tempdir().unwrap();
        let secret = dir.path().join("secret.txt");
        std::fs::write(
            &secret,
            "# SECRET-PAPER\n\ndescription = \"SECRET-DESCRIPTION\"\n",
        )
        .unwrap();
        let reports = dir.path().join("reports");
        for name in ["good", "linked"] {
            std::fs::create_dir_all(reports.join(name)).unwrap();
            std::fs::write(reports.join(name).join("plan.json"), PLAN).unwrap();
        }
        std::os::unix::fs::symlink(&secret, reports.join("linked/experiment.toml")).unwrap();
        // Without a paper: the study that links out is skipped and named.
        let index = write_index(&reports).unwrap();
        assert_eq!(index.skipped.len(), 1, "{:?}", index.skipped);
        assert_eq!(index.skipped[0].0, "linked");
        assert!(
            index.skipped[0].1.contains("leads outside"),
            "{:?}",
            index.skipped
        );
        let html = std::fs::read_to_string(&index.path).unwrap();
        assert!(
            !html.contains("SECRET") && html.contains("./good/"),
            "{html}"
        );
        // A paper that links out is refused, and nothing of it is written.
        std::os::unix::fs::symlink(&secret, reports.join("REPRODUCTION.md")).unwrap();
        let error = format!("{:#}", write_index(&reports).err().expect("refused"));
        assert!(
            error.contains("REPRODUCTION.md") && error.contains("leads outside"),
            "{error}"
        );
        assert!(!reports.join("REPRODUCTION.html").exists());
        // Inside the repository a link is followed.
        std::fs::remove_file(reports.join("REPRODUCTION.md")).unwrap();
        std::fs::write(reports.join("paper.md"), "# INSIDE-PAPER\n").unwrap();
        std::os::unix::fs::symlink("paper.md", reports.join("REPRODUCTION.md")).unwrap();
        write_index(&reports).unwrap();
        let page = std::fs::read_to_string(reports.join("REPRODUCTION.html")).unwrap();
        assert!(page.contains("INSIDE-PAPER"), "{page}");
    }
}
