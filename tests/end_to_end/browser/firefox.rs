//! The explorer from `file://` in Firefox (`firefox-esr`, headless), whose default
//! `security.fileuri.strict_origin_policy` makes every file its own origin: a copy of the
//! report with a probe script at its end waits for the first images, picks a cell with the
//! axis select, flips by key, hovers one pixel and paints every mode, then prints what it
//! saw through `dump()`. The readout must equal the EXR's values to half precision and no
//! script error may occur.

use std::io::{BufRead as _, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::mpsc;
use std::time::Duration;

use serde_json::Value;
use volphot::Film;
use volphot_tests::skip;

use super::explorer::{brightest, cell_at, check_readout, film_of};
use super::{kept_dir, small_report};

/// Firefox from `$FIREFOX` or the usual Debian paths.
pub(super) fn firefox() -> Option<PathBuf> {
    std::env::var_os("FIREFOX")
        .map(PathBuf::from)
        .into_iter()
        .chain(["/usr/bin/firefox-esr", "/usr/bin/firefox"].map(PathBuf::from))
        .find(|p| p.is_file())
}

/// The probe: `A` and the pixel are filled in; it reports `RESULT <json>` on stdout.
const PROBE: &str = r#"<script>
(() => {
  const out = { errors: [] };
  window.addEventListener('error', (e) => out.errors.push('error: ' + e.message));
  window.addEventListener('unhandledrejection', (e) => out.errors.push('rejection: ' + e.reason));
  const logError = console.error;
  console.error = (...args) => { out.errors.push('console.error: ' + args.join(' ')); logError(...args); };
  const idle = () => explorer.idle();
  const change = async (id, value, type) => {
    const el = document.getElementById(id);
    el.value = value;
    el.dispatchEvent(new Event(type, { bubbles: true }));
    await idle();
  };
  (async () => {
    const t0 = Date.now();
    while (!(explorer.renders > 0) && Date.now() - t0 < 20000) await new Promise((r) => setTimeout(r, 50));
    await idle();
    out.ready = explorer.readyAt;
    for (const [k, v] of A_COORDS.entries()) await change('ex-pick-a-' + k, String(v), 'change');
    out.a = explorer.state.a;
    document.dispatchEvent(new KeyboardEvent('keydown', { key: 'f', bubbles: true }));
    out.flipped = explorer.state.compare === 'flip' && explorer.state.flipped;
    document.dispatchEvent(new KeyboardEvent('keydown', { key: 'f', bubbles: true }));
    await change('ex-compare', 'side', 'input');
    explorer.setView(40, 0, 0);
    explorer.setView(40, -40 * PX + 100, -40 * PY + 100);
    const p = explorer.clientPoint(PX, PY), view = document.getElementById('ex-view-0');
    view.dispatchEvent(new PointerEvent('pointermove', { clientX: p.x, clientY: p.y, bubbles: true }));
    out.readout = explorer.lastReadout;
    out.modes = {};
    for (const mode of ['diff', 'rel', 'flip', 'image']) {
      await change('ex-mode', mode, 'input');
      const c = document.getElementById('ex-canvas-0'), d = c.getContext('2d').getImageData(0, 0, c.width, c.height).data;
      const colours = new Set();
      for (let i = 0; i < d.length; i += 4) colours.add((d[i] << 16) | (d[i + 1] << 8) | d[i + 2]);
      out.modes[mode] = { colours: colours.size, note: document.getElementById('ex-msg-0').textContent };
    }
    out.explorerErrors = explorer.errors;
  })().catch((e) => out.errors.push('probe: ' + e + ' ' + e.stack))
    .finally(() => dump('RESULT ' + JSON.stringify(out) + '\n'));
})();
</script>
"#;

/// Runs Firefox on `page` until the probe reports (or a minute passes) and returns the
/// report.
pub(super) fn run_probe(firefox: &Path, dir: &Path, page: &Path) -> Value {
    let profile = dir.join("firefox-profile");
    std::fs::create_dir_all(&profile).unwrap();
    std::fs::write(
        profile.join("user.js"),
        "user_pref(\"browser.dom.window.dump.enabled\", true);\n",
    )
    .unwrap();
    let mut child = Command::new(firefox)
        .args(["--headless", "--no-remote", "--profile"])
        .arg(&profile)
        .arg(format!("file://{}", page.display()))
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .expect("Firefox starts");
    let stdout = child.stdout.take().unwrap();
    let (send, receive) = mpsc::channel();
    std::thread::spawn(move || {
        for line in BufReader::new(stdout).lines().map_while(Result::ok) {
            if let Some(json) = line.strip_prefix("RESULT ") {
                let _ = send.send(json.to_string());
            }
        }
    });
    let result = receive.recv_timeout(Duration::from_secs(60));
    let _ = child.kill();
    let _ = child.wait();
    let json = result.expect("Firefox printed the probe's result within a minute");
    serde_json::from_str(&json).unwrap()
}

#[test]
fn explorer_works_from_file_in_firefox() {
    let Some(firefox) = firefox() else {
        skip(
            "explorer_works_from_file_in_firefox",
            "no Firefox: install Debian's `firefox-esr` (.ci/run does) or set $FIREFOX",
        );
        return;
    };
    let dir = kept_dir("browser-firefox");
    let out = small_report(&dir).canonicalize().unwrap();
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    let m: Value = {
        let start = html.find("id=\"explorer-manifest\">").unwrap() + 23;
        let end = start + html[start..].find("</script>").unwrap();
        serde_json::from_str(&html[start..end]).unwrap()
    };
    let a = cell_at(&m, &[1, 0]);
    let film = Film::read_exr(&film_of(&out, m["cells"][a]["data"].as_str().unwrap())).unwrap();
    let (px, py) = brightest(&film);
    let probe = PROBE
        .replace("A_COORDS", "[1, 0]")
        .replace("PX", &px.to_string())
        .replace("PY", &py.to_string());
    let page = out.join("report-firefox.html");
    std::fs::write(&page, html.replace("</body>", &format!("{probe}</body>"))).unwrap();

    let r = run_probe(&firefox, &dir, &page);
    assert_eq!(r["errors"], serde_json::json!([]), "{r}");
    assert_eq!(r["explorerErrors"], serde_json::json!([]), "{r}");
    assert!(r["ready"].as_f64().unwrap() < 2000.0, "{r}");
    assert_eq!(r["a"].as_u64().unwrap() as usize, a, "{r}");
    assert_eq!(r["flipped"], true, "{r}");
    let readout = &r["readout"];
    assert_eq!(
        (readout["x"].as_u64(), readout["y"].as_u64()),
        (Some(px as u64), Some(py as u64)),
        "{r}"
    );
    check_readout(&out, &m, &r, readout, (px, py));
    for (mode, seen) in r["modes"].as_object().unwrap() {
        assert_eq!(seen["note"], "", "{mode}: {r}");
        assert!(seen["colours"].as_u64().unwrap() > 16, "{mode}: {r}");
    }
}
