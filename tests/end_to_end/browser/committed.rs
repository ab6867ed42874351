//! The committed reports as a reader of a fresh clone meets them: the files git tracks under
//! `reports/` (nothing rendered, no `cells/`) are copied to a folder of their own, and
//! `reports/index.html` is opened there in Chromium and in Firefox. Every image on the index
//! decodes, every relative link names a file of the copy, nothing reaches the console as an
//! error; every study's `report.html` the index links opens with its images decoded and,
//! where it has an explorer, the explorer paints its first cell without an error.

use std::path::{Path, PathBuf};

use serde_json::Value;
use volphot_tests::{copy_tracked, skip};

use super::firefox::{firefox, run_probe};
use super::{chromium, kept_dir, launch, watch_console};

/// What a clone holds under `reports/`, copied into `dest/reports/`; `None` when git cannot
/// list it (not a checkout).
fn clone_of_reports(dest: &Path) -> Option<PathBuf> {
    copy_tracked("reports", dest).map(|_| dest.join("reports"))
}

/// What the page holds: images (decoded or not), relative links, whether an explorer is on
/// it and, once it painted, its errors.
const CHECK: &str = r#"(async () => {
  const t0 = Date.now();
  const images = Array.from(document.images);
  images.forEach((i) => { i.loading = 'eager'; });
  const settled = () => images.every((i) => i.complete);
  while (!settled() && Date.now() - t0 < 20000) await new Promise((r) => setTimeout(r, 50));
  const hasExplorer = !!document.getElementById('explorer-manifest');
  if (hasExplorer) {
    while (!(window.explorer && window.explorer.renders > 0) && Date.now() - t0 < 30000)
      await new Promise((r) => setTimeout(r, 50));
  }
  return JSON.stringify({
    images: images.length,
    broken: images.filter((i) => !(i.naturalWidth > 0)).map((i) => i.getAttribute('src')),
    links: Array.from(document.querySelectorAll('a[href]')).map((a) => a.getAttribute('href'))
      .filter((h) => !/^(#|[a-z]+:)/.test(h)),
    explorer: hasExplorer,
    renders: hasExplorer && window.explorer ? window.explorer.renders : 0,
    explorerErrors: hasExplorer && window.explorer ? window.explorer.errors : [],
    pair: hasExplorer && window.explorer ? [window.explorer.state.a, window.explorer.state.b].map((i) => window.explorer.manifest.cells[i].coords) : [],
    pairValues: hasExplorer && window.explorer ? [window.explorer.state.a, window.explorer.state.b].map((i) => Object.fromEntries(window.explorer.manifest.axes.map((a, k) => [a.key, a.values[window.explorer.manifest.cells[i].coords[k]]]))) : [],
    cards: Array.from(document.querySelectorAll('.card')).map((c) => ({
      id: c.id,
      claims: Array.from(c.querySelectorAll('.claims li')).map((l) => l.textContent.trim()),
      imageWidth: c.querySelector('img') ? c.querySelector('img').getBoundingClientRect().width : 0,
    })),
  });
})()"#;

/// The page's check, run in Chromium.
fn check_in_chromium(tab: &headless_chrome::Tab, page: &Path) -> Value {
    let url = format!("file://{}", page.display());
    tab.navigate_to(&url)
        .unwrap()
        .wait_until_navigated()
        .unwrap();
    let result = tab.evaluate(CHECK, true).unwrap();
    let text = result.value.and_then(|v| v.as_str().map(str::to_string));
    serde_json::from_str(&text.expect("the check returns a JSON string")).unwrap()
}

/// Every relative link of `page` names a file (fragments and queries dropped).
fn assert_links_resolve(page: &Path, check: &Value) {
    for link in check["links"].as_array().unwrap() {
        let link = link.as_str().unwrap();
        let path = link.split(['#', '?']).next().unwrap();
        let target = page.parent().unwrap().join(path);
        assert!(
            target.exists(),
            "{}: the link `{link}` names no file of a clone",
            page.display()
        );
    }
}

/// The studies' `report.html` pages the index links to.
fn linked_reports(index: &Path, check: &Value) -> Vec<PathBuf> {
    let mut pages: Vec<PathBuf> = check["links"]
        .as_array()
        .unwrap()
        .iter()
        .filter_map(|l| l.as_str())
        .filter(|l| l.ends_with("/report.html"))
        .map(|l| index.parent().unwrap().join(l))
        .collect();
    pages.sort();
    pages.dedup();
    pages
}

#[test]
fn committed_reports_open_from_a_clone_in_chromium() {
    let Some(chrome) = chromium() else {
        skip(
            "committed_reports_open_from_a_clone_in_chromium",
            "no Chromium: install Debian's `chromium` (.ci/run does) or set $CHROMIUM",
        );
        return;
    };
    let dir = kept_dir("browser-committed");
    let Some(reports) = clone_of_reports(&dir) else {
        skip(
            "committed_reports_open_from_a_clone_in_chromium",
            "not a git checkout: `git ls-files reports` lists nothing",
        );
        return;
    };
    let index = reports.join("index.html");
    assert!(index.is_file(), "a clone has reports/index.html");
    let browser = launch(chrome);
    let tab = browser.new_tab().unwrap();
    let console = watch_console(&tab);
    let check = check_in_chromium(&tab, &index);
    assert!(check["images"].as_u64().unwrap() >= 10, "{check}");
    assert_index_guides(&check);
    assert_eq!(check["broken"], serde_json::json!([]), "index: {check}");
    assert_links_resolve(&index, &check);
    let studies = linked_reports(&index, &check);
    assert!(
        studies.len() >= 12,
        "{} studies with report.html",
        studies.len()
    );
    let mut with_explorer = 0;
    for page in &studies {
        let check = check_in_chromium(&tab, page);
        assert_eq!(
            check["broken"],
            serde_json::json!([]),
            "{}: {check}",
            page.display()
        );
        assert_links_resolve(page, &check);
        if check["explorer"] == true {
            with_explorer += 1;
            assert!(
                check["renders"].as_u64().unwrap() > 0,
                "{}: {check}",
                page.display()
            );
            assert_eq!(
                check["explorerErrors"],
                serde_json::json!([]),
                "{}",
                page.display()
            );
            if page.parent().unwrap().ends_with("single_vs_multiple-paper") {
                assert_opens_on_its_pair(&check);
            }
            assert_opens_on_the_named_pair(page, &check);
        }
    }
    eprintln!(
        "{} studies opened from a clone, {with_explorer} with an explorer",
        studies.len()
    );
    assert_eq!(
        with_explorer,
        studies.len(),
        "every report.html has its explorer"
    );
    let errors = console.lock().unwrap().clone();
    assert!(errors.is_empty(), "console: {errors:?}");
}

/// The index is where a reader starts (issue "Conclusions that hold up", part 7): the
/// studies in the paper's order, the one answering §1.1 first, every claim with the paper's
/// verdict beside it, images large enough to see.
fn assert_index_guides(check: &Value) {
    let cards = check["cards"].as_array().expect("the index has cards");
    assert!(cards.len() >= 10, "{} cards", cards.len());
    assert_eq!(
        cards[0]["id"], "single_vs_multiple-paper",
        "the study that answers §1.1 comes first: {check}"
    );
    assert!(
        cards[0]["claims"][0].as_str().unwrap().starts_with("§1.1"),
        "{}",
        cards[0]
    );
    let mut last_claim = 0;
    for card in cards {
        for claim in card["claims"].as_array().unwrap() {
            let text = claim.as_str().unwrap();
            let (tag, verdict) = text.split_at(text.find(char::is_whitespace).unwrap_or(0));
            assert!(!verdict.trim().is_empty(), "{tag} has no verdict: {card}");
        }
        // The cards' first claims run in the paper's order (C1 before C2 …).
        if let Some(first) = card["claims"][0].as_str()
            && let Some(n) = first
                .strip_prefix('C')
                .and_then(|r| r.split_whitespace().next())
            && let Ok(n) = n.parse::<u32>()
        {
            assert!(n >= last_claim, "C{n} after C{last_claim}: {check}");
            last_claim = n;
        }
        if card["imageWidth"].as_f64().unwrap() > 0.0 {
            assert!(
                card["imageWidth"].as_f64().unwrap() >= 400.0,
                "an image narrower than 400 px: {card}"
            );
        }
    }
}

/// The explorer of single_vs_multiple opens on single against single + multiple of one
/// setting: its two cells differ in exactly one axis, not in their seed alone.
fn assert_opens_on_its_pair(check: &Value) {
    let pair = check["pair"].as_array().expect("the explorer's first pair");
    let (a, b) = (pair[0].as_array().unwrap(), pair[1].as_array().unwrap());
    let differing = a.iter().zip(b).filter(|(x, y)| x != y).count();
    assert_eq!(differing, 1, "A and B differ in {differing} axes: {check}");
}

/// The explorer opens on the pair its study names (`[report] pair` in the study's
/// `experiment.toml`): the first cell has every value of `a`, the second every value of `b`.
/// A study that names no pair fails: each was made to compare something.
fn assert_opens_on_the_named_pair(page: &Path, check: &Value) {
    let experiment = page.with_file_name("experiment.toml");
    let text = std::fs::read_to_string(&experiment)
        .unwrap_or_else(|e| panic!("{}: {e}", experiment.display()));
    let table: toml::Table = text.parse().unwrap();
    let pair = table
        .get("report")
        .and_then(|r| r.get("pair"))
        .unwrap_or_else(|| panic!("{} names no [report] pair", experiment.display()));
    let opened = check["pairValues"]
        .as_array()
        .expect("the explorer's first pair");
    for (side, cell) in ["a", "b"].iter().zip(opened) {
        for (key, wanted) in pair[side].as_table().unwrap() {
            let shown = cell[key.as_str()].as_str().unwrap_or_else(|| {
                panic!(
                    "{}: the explorer has no axis {key}: {check}",
                    page.display()
                )
            });
            // The page shows a value as text: a number, flag or list as JSON, else the text.
            let shown: Value =
                serde_json::from_str(shown).unwrap_or_else(|_| Value::String(shown.into()));
            let wanted: Value = serde_json::to_value(wanted).unwrap();
            let same = match (shown.as_f64(), wanted.as_f64()) {
                (Some(x), Some(y)) => (x - y).abs() <= 1e-6 * y.abs().max(1.0),
                _ => shown == wanted,
            };
            assert!(
                same,
                "{}: the explorer opens with {side}.{key} = {shown}, the study's pair names {wanted}",
                page.display()
            );
        }
    }
}

/// The probe for Firefox: the same check, printed through `dump()`.
fn firefox_probe() -> String {
    format!(
        "<script>\nwindow.addEventListener('load', () => {{ const errors = []; window.addEventListener('error', (e) => errors.push(e.message)); {CHECK}.then((r) => {{ const o = JSON.parse(r); o.errors = errors; dump('RESULT ' + JSON.stringify(o) + '\\n'); }}).catch((e) => dump('RESULT ' + JSON.stringify({{ errors: ['probe: ' + e] }}) + '\\n')); }});\n</script>"
    )
}

#[test]
fn committed_index_and_a_study_open_from_a_clone_in_firefox() {
    let Some(firefox) = firefox() else {
        skip(
            "committed_index_and_a_study_open_from_a_clone_in_firefox",
            "no Firefox: install Debian's `firefox-esr` (.ci/run does) or set $FIREFOX",
        );
        return;
    };
    let dir = kept_dir("browser-committed-firefox");
    let Some(reports) = clone_of_reports(&dir) else {
        skip(
            "committed_index_and_a_study_open_from_a_clone_in_firefox",
            "not a git checkout: `git ls-files reports` lists nothing",
        );
        return;
    };
    let reports = reports.canonicalize().unwrap();
    let probed = |page: &Path| {
        let html = std::fs::read_to_string(page).unwrap();
        let copy = page.with_file_name("probe-firefox.html");
        std::fs::write(
            &copy,
            html.replace("</body>", &format!("{}</body>", firefox_probe())),
        )
        .unwrap();
        let r = run_probe(&firefox, &dir, &copy);
        assert_eq!(
            r["errors"],
            serde_json::json!([]),
            "{}: {r}",
            page.display()
        );
        assert_eq!(
            r["broken"],
            serde_json::json!([]),
            "{}: {r}",
            page.display()
        );
        assert_links_resolve(page, &r);
        r
    };
    let index = probed(&reports.join("index.html"));
    assert_index_guides(&index);
    let study = linked_reports(&reports.join("index.html"), &index)
        .into_iter()
        .find(|p| p.parent().unwrap().ends_with("single_vs_multiple"))
        .expect("the index links single_vs_multiple's report.html");
    let r = probed(&study);
    assert_eq!(r["explorer"], true, "{r}");
    assert_opens_on_its_pair(&r);
    assert!(r["renders"].as_u64().unwrap() > 0, "{r}");
    assert_eq!(r["explorerErrors"], serde_json::json!([]), "{r}");
}

/// The paper's §1.1 answer table as Chromium shows the committed `REPRODUCTION.html`
/// (issue "Conclusions that hold up", part 1: its cells showed query fragments and lost the
/// head's, the foot's and the engine's values): every row has the header's five cells, each
/// with a number and none with a claim's text.
#[test]
fn the_papers_answer_table_renders_whole_in_chromium() {
    let Some(chrome) = chromium() else {
        skip(
            "the_papers_answer_table_renders_whole_in_chromium",
            "no Chromium: install Debian's `chromium` (.ci/run does) or set $CHROMIUM",
        );
        return;
    };
    let dir = kept_dir("browser-paper");
    let Some(reports) = clone_of_reports(&dir) else {
        skip(
            "the_papers_answer_table_renders_whole_in_chromium",
            "not a git checkout: `git ls-files reports` lists nothing",
        );
        return;
    };
    let browser = launch(chrome);
    let tab = browser.new_tab().unwrap();
    let page = reports.join("REPRODUCTION.html");
    tab.navigate_to(&format!("file://{}", page.display()))
        .unwrap()
        .wait_until_navigated()
        .unwrap();
    let probe = r#"JSON.stringify((() => {
      const h = Array.from(document.querySelectorAll('h2')).find((e) => e.textContent.startsWith('The answer'));
      let t = h; while (t && t.tagName !== 'TABLE') t = t.nextElementSibling;
      return { header: t ? t.querySelectorAll('thead th').length : 0,
               rows: t ? Array.from(t.querySelectorAll('tbody tr')).map((r) => Array.from(r.cells).map((c) => c.textContent)) : [] };
    })())"#;
    let text = tab.evaluate(probe, false).unwrap().value;
    let table: Value = serde_json::from_str(
        text.as_ref()
            .and_then(Value::as_str)
            .expect("a JSON string"),
    )
    .unwrap();
    let header = table["header"].as_u64().unwrap();
    assert_eq!(header, 5, "{table}");
    let rows = table["rows"].as_array().unwrap();
    assert!(rows.len() >= 5, "{table}");
    for row in rows {
        let cells = row.as_array().unwrap();
        assert_eq!(cells.len() as u64, header, "{row}");
        for cell in &cells[1..] {
            let cell = cell.as_str().unwrap();
            assert!(
                cell.chars().any(|c| c.is_ascii_digit()),
                "no number in `{cell}`"
            );
            for leak in ["<!--", "-->", "where ", "value(", "mean("] {
                assert!(!cell.contains(leak), "`{leak}` shows in `{cell}`");
            }
        }
    }
}
