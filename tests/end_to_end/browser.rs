//! The HTML report in a real browser: headless Chromium (Debian's `chromium`, installed by
//! `.ci/run` when missing) opens `report.html` from disk; every image decodes, every link
//! resolves, nothing reaches the console as an error, and a full-page screenshot is saved
//! next to the report (`report-screenshot.png`) for a person to look at.
//!
//! The explorer is scripted in Chromium (`explorer`) and, from `file://`, in Firefox
//! (`firefox`). Without a browser a test says so and passes, except under `CI=true`, where
//! it fails.

use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

use headless_chrome::protocol::cdp::types::Event;
use headless_chrome::protocol::cdp::{Log, Page, Runtime};
use headless_chrome::{Browser, LaunchOptions, Tab};
use volphot_tests::{run_ok, skip, sweep, write_experiment};

mod committed;
mod explorer;
mod firefox;
mod security;

/// Chromium from `$CHROMIUM` or the usual Debian paths.
fn chromium() -> Option<PathBuf> {
    std::env::var_os("CHROMIUM")
        .map(PathBuf::from)
        .into_iter()
        .chain(
            ["/usr/bin/chromium", "/usr/bin/chromium-browser"]
                .into_iter()
                .map(PathBuf::from),
        )
        .find(|p| p.is_file())
}

/// A fresh folder under target/tmp, kept after the test so that its screenshots can be
/// looked at.
fn kept_dir(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// A small phantom sweep with every kind of figure: contact sheet, plot, layer differences,
/// reference comparison.
fn small_report(dir: &Path) -> PathBuf {
    let exp = write_experiment(
        dir,
        "browser",
        "phantom-engine.toml",
        r#"
[set]
"volume.phantom.resolution" = [24, 24, 24]
"camera.resolution" = [32, 32]
"integrator.volume_photons" = 2000
"integrator.stepsize" = 0.005
[axes]
"sigma.t" = [20, 60]
"integrator.nused" = [20, 80]
[reference]
spp = 4
[[compare]]
kind = "layers"
[[compare]]
kind = "reference"
[[sheets]]
rows = "sigma.t"
cols = "integrator.nused"
layer = "multiple"
[[plots]]
x = "integrator.nused"
y = ["disco_energy", "rmse"]
series = "sigma.t"
"#,
    );
    let out = dir.join("out");
    run_ok(
        sweep()
            .arg("run")
            .arg(&exp)
            .arg("--output")
            .arg(&out)
            .arg("--quiet"),
    );
    out
}

/// Headless Chromium with a 1280×900 window.
fn launch(chrome: PathBuf) -> Browser {
    Browser::new(
        LaunchOptions::default_builder()
            .path(Some(chrome))
            // Containers run tests as root, where Chromium's sandbox cannot start.
            .sandbox(false)
            .window_size(Some((1280, 900)))
            // The explorer test pauses between calls while it reads films.
            .idle_browser_timeout(std::time::Duration::from_secs(120))
            .build()
            .unwrap(),
    )
    .expect("Chromium starts")
}

/// Collects what the page reports as errors: failed loads, `console.error`, exceptions.
fn watch_console(tab: &Tab) -> Arc<Mutex<Vec<String>>> {
    let console: Arc<Mutex<Vec<String>>> = Arc::default();
    let sink = console.clone();
    tab.add_event_listener(Arc::new(move |event: &Event| {
        let line = match event {
            Event::LogEntryAdded(e)
                if matches!(e.params.entry.level, Log::LogEntryLevel::Error) =>
            {
                Some(format!(
                    "log: {} {:?}",
                    e.params.entry.text, e.params.entry.url
                ))
            }
            Event::RuntimeConsoleAPICalled(e)
                if matches!(
                    e.params.Type,
                    Runtime::ConsoleAPICalledEventTypeOption::Error
                        | Runtime::ConsoleAPICalledEventTypeOption::Assert
                ) =>
            {
                let args: Vec<String> = e
                    .params
                    .args
                    .iter()
                    .map(|a| match (&a.value, &a.description) {
                        (Some(v), _) => v.to_string(),
                        (None, Some(d)) => d.clone(),
                        (None, None) => String::new(),
                    })
                    .collect();
                Some(format!("console.{:?}: {}", e.params.Type, args.join(" ")))
            }
            Event::RuntimeExceptionThrown(e) => {
                let d = &e.params.exception_details;
                let detail = d.exception.as_ref().and_then(|x| x.description.clone());
                Some(format!(
                    "exception: {} {}",
                    d.text,
                    detail.unwrap_or_default()
                ))
            }
            _ => None,
        };
        if let Some(line) = line {
            sink.lock().unwrap().push(line);
        }
    }))
    .unwrap();
    tab.enable_log().unwrap();
    tab.enable_runtime().unwrap();
    console
}

/// Opens `report.html` of `out` from disk.
fn open_report(tab: &Tab, out: &Path) {
    let report = out.join("report.html");
    assert!(report.is_file());
    let url = format!("file://{}", report.canonicalize().unwrap().display());
    tab.navigate_to(&url)
        .unwrap()
        .wait_until_navigated()
        .unwrap();
}

/// What the page reported: problems found by the browser itself.
#[derive(Debug, serde::Deserialize)]
struct PageCheck {
    images: usize,
    broken_images: Vec<String>,
    links: Vec<String>,
    missing_anchors: Vec<String>,
    width: f64,
    height: f64,
    /// The explorer's A/B labels' background colour (computed).
    tag_background: String,
}

const CHECK_PAGE: &str = r#"JSON.stringify((() => {
  const images = Array.from(document.images);
  const broken = images
    .filter(i => !(i.complete && i.naturalWidth > 0 && i.naturalHeight > 0))
    .map(i => (i.alt || '') + ' ' + i.src.slice(0, 60));
  const anchors = Array.from(document.querySelectorAll('a[href]'));
  const missing = anchors
    .map(a => a.getAttribute('href'))
    .filter(h => h.startsWith('#') && h.length > 1 && !document.getElementById(h.slice(1)));
  return {
    images: images.length,
    broken_images: broken,
    links: anchors.map(a => a.href),
    missing_anchors: missing,
    width: document.documentElement.scrollWidth,
    height: document.documentElement.scrollHeight,
    tag_background: getComputedStyle(document.getElementById('ex-tag-0')).backgroundColor,
  };
})())"#;

#[test]
fn html_report_renders_in_chromium() {
    let Some(chrome) = chromium() else {
        skip(
            "html_report_renders_in_chromium",
            "no Chromium: install Debian's `chromium` (.ci/run does) or set $CHROMIUM",
        );
        return;
    };
    let dir = kept_dir("browser-report");
    let out = small_report(&dir);

    let browser = launch(chrome);
    let tab = browser.new_tab().unwrap();
    let console = watch_console(&tab);
    open_report(&tab, &out);

    let result = tab.evaluate(CHECK_PAGE, false).unwrap();
    let text = result
        .value
        .and_then(|v| v.as_str().map(str::to_string))
        .expect("the check returns a JSON string");
    let page: PageCheck = serde_json::from_str(&text).unwrap();

    // Every figure of report.md is on the page and decoded by the browser.
    let markdown = std::fs::read_to_string(out.join("report.md")).unwrap();
    let figures = markdown.matches("![").count();
    assert!(
        page.images == figures && figures >= 4,
        "{} images on the page, {figures} figures in report.md",
        page.images
    );
    assert!(
        page.broken_images.is_empty(),
        "images the browser could not decode: {:?}",
        page.broken_images
    );
    assert!(
        page.missing_anchors.is_empty(),
        "{:?}",
        page.missing_anchors
    );
    assert!(!page.links.is_empty(), "the report links its tables");
    // At a 1280 × 900 window nothing widens the page: wide tables scroll in their boxes.
    assert!(
        page.width <= 1280.0,
        "the page is {} px wide in a 1280 px window",
        page.width
    );
    // The A/B labels stay readable on bright images: a dark backdrop of their own.
    let rgba: Vec<f64> = page
        .tag_background
        .trim_start_matches("rgba(")
        .trim_start_matches("rgb(")
        .trim_end_matches(')')
        .split(',')
        .filter_map(|v| v.trim().parse().ok())
        .collect();
    let alpha = rgba.get(3).copied().unwrap_or(1.0);
    assert!(
        rgba.len() >= 3 && rgba[..3].iter().all(|c| *c < 80.0) && alpha >= 0.5,
        "the explorer's labels have no dark backdrop: {}",
        page.tag_background
    );
    for link in &page.links {
        let path = link
            .strip_prefix("file://")
            .unwrap_or_else(|| panic!("report links outside itself: {link}"));
        let path = path.split('#').next().unwrap();
        assert!(Path::new(path).exists(), "broken link {link}");
    }

    // A full-page screenshot for people.
    let shot = tab
        .call_method(Page::CaptureScreenshot {
            format: Some(Page::CaptureScreenshotFormatOption::Png),
            quality: None,
            clip: Some(Page::Viewport {
                x: 0.0,
                y: 0.0,
                width: page.width,
                height: page.height,
                scale: 1.0,
            }),
            from_surface: Some(true),
            capture_beyond_viewport: Some(true),
            optimize_for_speed: None,
        })
        .unwrap();
    use base64::Engine as _;
    let png = base64::engine::general_purpose::STANDARD
        .decode(shot.data)
        .unwrap();
    let screenshot = out.join("report-screenshot.png");
    std::fs::write(&screenshot, &png).unwrap();
    let decoded = image::load_from_memory(&png).unwrap().to_rgb8();
    assert!(decoded.height() as f64 >= page.height.min(900.0) - 1.0);
    // Not a blank page: the dark figures and the light page both appear.
    let luma: Vec<u8> = decoded.pixels().map(|p| p.0[1]).collect();
    let dark = luma.iter().filter(|&&v| v < 40).count();
    let light = luma.iter().filter(|&&v| v > 200).count();
    assert!(dark > 1000 && light > 1000, "dark {dark}, light {light}");

    let console = console.lock().unwrap();
    assert!(console.is_empty(), "console errors: {console:?}");
    eprintln!("screenshot: {}", screenshot.display());
}
