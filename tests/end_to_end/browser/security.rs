//! Generated HTML carries no markup and no script link from user strings (the fourth
//! reliability round, cases 2–4): a study whose description holds an unmatched backtick
//! before an `<img onerror>`, a `javascript:` link and a `<script>`, listed by an index
//! whose folder is named `javascript:alert(document.domain)`, beside a paper with raw
//! `<script>`. Each page is opened in Chromium: no payload runs, no element carries an
//! event handler or a `javascript:` address, and only the page's own scripts exist.

use std::path::Path;

use serde_json::Value;
use volphot_tests::{run_ok, skip, sweep, write_experiment};

use super::{chromium, kept_dir, launch, watch_console};

/// The payloads: each would set `window.pwned` if it ran.
const DESCRIPTION: &str = "Tick ` then <img src=x onerror=\"window.pwned=11\"> end. \
    [the data](javascript:window.pwned=12) <script>window.pwned=13</script> \
    [x]( JaVaScRiPt:window.pwned=14) <svg onload=window.pwned=15>";

/// What a page holds that could run: handlers, script links, script elements.
const PROBE: &str = r#"JSON.stringify((() => {
  const all = Array.from(document.querySelectorAll('*'));
  const handlers = all.filter((e) => Array.from(e.attributes).some((a) => /^on/i.test(a.name)));
  const links = Array.from(document.querySelectorAll('[href], [src]'))
    .map((e) => e.getAttribute('href') || e.getAttribute('src'))
    .filter((u) => /^\s*(javascript|vbscript|data:text)/i.test(u));
  for (const a of document.querySelectorAll('a[href]')) {
    if (/^\s*javascript/i.test(a.getAttribute('href'))) a.click();
  }
  return {
    pwned: window.pwned === undefined ? null : String(window.pwned),
    handlers: handlers.map((e) => e.outerHTML.slice(0, 80)),
    links,
    scripts: document.scripts.length,
  };
})())"#;

fn probe(tab: &headless_chrome::Tab, page: &Path) -> Value {
    assert!(page.is_file(), "{} was not written", page.display());
    let url = format!("file://{}", page.display());
    tab.navigate_to(&url)
        .unwrap()
        .wait_until_navigated()
        .unwrap();
    std::thread::sleep(std::time::Duration::from_millis(300));
    let text = tab.evaluate(PROBE, false).unwrap().value;
    serde_json::from_str(
        text.as_ref()
            .and_then(Value::as_str)
            .expect("a JSON string"),
    )
    .unwrap()
}

#[test]
fn no_user_string_becomes_script_in_chromium() {
    let Some(chrome) = chromium() else {
        skip(
            "no_user_string_becomes_script_in_chromium",
            "no Chromium: install Debian's `chromium` (.ci/run does) or set $CHROMIUM",
        );
        return;
    };
    let dir = kept_dir("browser-security");
    let exp = write_experiment(
        &dir,
        "hostile",
        "phantom-engine.toml",
        &format!(
            "description = {DESCRIPTION:?}\n[set]\n\"volume.phantom.resolution\" = [16, 16, 16]\n\"camera.resolution\" = [16, 16]\n\"integrator.volume_photons\" = 1000\n\"integrator.stepsize\" = 0.01\n[axes]\n\"sigma.t\" = [20, 60]\n"
        ),
    );
    let reports = dir.join("reports");
    let study = reports.join("javascript:alert(document.domain)");
    run_ok(
        sweep()
            .arg("run")
            .arg(&exp)
            .arg("-o")
            .arg(&study)
            .arg("--quiet"),
    );
    std::fs::write(
        reports.join("REPRODUCTION.md"),
        "# Paper\n\n<script>window.pwned=21</script>\n\n<img src=x onerror=\"window.pwned=22\">\n\n[x](javascript:window.pwned=23) 1<!-- = count(x: y) -->\n",
    )
    .unwrap();
    run_ok(sweep().arg("index").arg(&reports));

    let browser = launch(chrome);
    let tab = browser.new_tab().unwrap();
    let console = watch_console(&tab);
    for (page, scripts) in [
        (study.join("report.html"), 2),
        (reports.join("index.html"), 0),
        (reports.join("REPRODUCTION.html"), 0),
    ] {
        let found = probe(&tab, &page);
        assert_eq!(found["pwned"], Value::Null, "{}: {found}", page.display());
        assert_eq!(
            found["handlers"],
            serde_json::json!([]),
            "{}: {found}",
            page.display()
        );
        assert_eq!(
            found["links"],
            serde_json::json!([]),
            "{}: {found}",
            page.display()
        );
        assert_eq!(found["scripts"], scripts, "{}: {found}", page.display());
    }
    // The index's link to the study is a relative file name that opens it.
    let html = std::fs::read_to_string(reports.join("index.html")).unwrap();
    assert!(
        html.contains("href=\"./javascript%3Aalert%28document.domain%29/report.html\""),
        "{html}"
    );
    let console = console.lock().unwrap();
    assert!(
        console.iter().all(|l| !l.contains("pwned")),
        "console: {console:?}"
    );
}

/// The paper's Markdown extensions as a hostile contributor would use them (the fifth
/// reliability round, row 3): heading attributes with `autofocus` and `onfocus`, a
/// `style` that covers the page, raw `<details ontoggle>`, footnotes whose labels are
/// markup or the ids of the page's own elements, a fenced block whose info string closes
/// its class, `javascript:` and `data:` links and images. Opened in Chromium, no payload
/// runs, nothing has focus, and no element carries an attribute from the text: no
/// handler, no `style` but a table cell's alignment, no `autofocus` or `tabindex`, no
/// `class` or `id` but the footnotes' own.
const HOSTILE_PAPER: &str = r#"# Paper

## Details {tabindex=0 autofocus onfocus="window.pwned=31"}

## Cover {#explorer .x style="position:fixed;inset:0;background:red" onclick="window.pwned=32"}

<details open ontoggle="window.pwned=33"><summary>x</summary></details>

A note[^"><img src=x onerror="window.pwned=34">] and another[^explorer].

[^"><img src=x onerror="window.pwned=34">]: the first.
[^explorer]: the second.

```js" onclick="window.pwned=35
code
```

| a | b |
|:--|--:|
| [l](javascript:window.pwned=36) | ![i](data:image/svg+xml,<svg onload=window.pwned=37>) |

[x]( JaVaScRiPt:window.pwned=38) <a href="javascript:window.pwned=39">y</a>
"#;

/// Every attribute on the page that did not come from the page's own fixed markup.
const ATTRIBUTES: &str = r#"JSON.stringify((() => {
  const found = [];
  for (const e of document.body.querySelectorAll('*')) {
    for (const a of Array.from(e.attributes)) {
      const tag = e.tagName.toLowerCase();
      const ok = (tag === 'a' && a.name === 'href' && !/^\s*(javascript|vbscript|data)/i.test(a.value))
        || (tag === 'img' && (a.name === 'alt' || (a.name === 'src' && !/^\s*(javascript|data)/i.test(a.value))))
        || ((tag === 'th' || tag === 'td') && a.name === 'style' && /^text-align: (left|center|right);?$/.test(a.value))
        || (tag === 'div' && a.name === 'class' && a.value === 'footnote-definition')
        || (tag === 'div' && a.name === 'id' && /^footnote-\d+$/.test(a.value))
        || (tag === 'sup' && a.name === 'class' && /^footnote-(reference|definition-label)$/.test(a.value));
      if (!ok) found.push(`<${tag} ${a.name}="${a.value}">`);
    }
  }
  return {
    pwned: window.pwned === undefined ? null : String(window.pwned),
    focused: document.activeElement ? document.activeElement.tagName : null,
    found,
  };
})())"#;

#[test]
fn paper_markdown_extensions_carry_no_attribute_in_chromium() {
    let Some(chrome) = chromium() else {
        skip(
            "paper_markdown_extensions_carry_no_attribute_in_chromium",
            "no Chromium: install Debian's `chromium` (.ci/run does) or set $CHROMIUM",
        );
        return;
    };
    let reports = kept_dir("browser-paper-extensions");
    std::fs::write(reports.join("REPRODUCTION.md"), HOSTILE_PAPER).unwrap();
    run_ok(sweep().arg("index").arg(&reports));
    let page = reports.join("REPRODUCTION.html");
    let browser = launch(chrome);
    let tab = browser.new_tab().unwrap();
    let console = watch_console(&tab);
    // The handlers a probe's clicks and focus could set off.
    let found = probe(&tab, &page);
    assert_eq!(found["pwned"], Value::Null, "{found}");
    assert_eq!(found["handlers"], serde_json::json!([]), "{found}");
    let text = tab.evaluate(ATTRIBUTES, false).unwrap().value;
    let found: Value = serde_json::from_str(
        text.as_ref()
            .and_then(Value::as_str)
            .expect("a JSON string"),
    )
    .unwrap();
    assert_eq!(found["pwned"], Value::Null, "{found}");
    assert_eq!(found["focused"], "BODY", "{found}");
    assert_eq!(found["found"], serde_json::json!([]), "{found}");
    // The text is still there: the headings read as a code host shows them.
    let html = std::fs::read_to_string(&page).unwrap();
    assert!(html.contains("<h2>Details {tabindex=0"), "{html}");
    let console = console.lock().unwrap();
    assert!(
        console.iter().all(|l| !l.contains("pwned")),
        "console: {console:?}"
    );
}
