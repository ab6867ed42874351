//! Progress bars: indicatif, hidden when stderr is not a terminal or with `--quiet`.

use indicatif::{MultiProgress, ProgressBar, ProgressDrawTarget, ProgressStyle};

/// A multi-bar display that draws nothing when `quiet` (indicatif itself hides bars when
/// stderr is not a terminal).
pub(crate) fn multi(quiet: bool) -> MultiProgress {
    if quiet {
        MultiProgress::with_draw_target(ProgressDrawTarget::hidden())
    } else {
        MultiProgress::new()
    }
}

/// A bar counting `len` units with a label.
pub(crate) fn bar(multi: &MultiProgress, len: u64, label: &str, unit: &str) -> ProgressBar {
    let bar = multi.add(ProgressBar::new(len));
    bar.set_style(
        ProgressStyle::with_template(&format!(
            "{{prefix:>14.bold}} [{{elapsed_precise}}] {{wide_bar:.cyan/blue}} {{pos}}/{{len}} {unit} ({{eta}}) {{msg}}"
        ))
        .expect("valid progress template")
        .progress_chars("=> "),
    );
    bar.set_prefix(label.to_string());
    bar
}
