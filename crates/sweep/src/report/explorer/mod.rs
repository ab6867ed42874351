//! The image explorer in `report.html`: pick any two cells by their axis values, compare
//! them side by side, with a split or by flipping, zoom to single pixels, switch layers,
//! exposure and gamma, see A − B, the relative error against the reference and the FLIP
//! map in false colour, and read the linear values under the cursor.
//!
//! The page works from a plain `file://` open: the manifest is inlined, the pixel data of
//! each cell and reference are small script files under `explorer/` (see [`data`]) loaded
//! when a cell is shown, and every pixel computation uses those floats, never a PNG (a
//! canvas that drew a `file://` image may not be read). The page's code is `explorer.js`,
//! `explorer.css` and `explorer.html` beside this file.

mod data;
mod manifest;
mod pack;

use anyhow::Result;

use super::collect::Collected;
use crate::plan::PairSpec;
use crate::store::{OutputDir, PlanRecord};

/// The two cells the explorer opens on.
#[derive(Debug, Clone, Copy)]
pub(crate) enum Opening<'a> {
    /// The pair the study names (`[report] pair`).
    Named(&'a PairSpec),
    /// A study that names none: the ends of the axis it is about.
    Axis(&'a str),
}

const MARKUP: &str = include_str!("explorer.html");
const STYLE: &str = include_str!("explorer.css");
const SCRIPT: &str = include_str!("explorer.js");

/// `html` (a `report.html` with an explorer) opening on `pair`: the manifest's `start`
/// changes, and the page's code becomes this build's (a page made before the explorer
/// read `start` would ignore it; the markup and style it drives are checked to be this
/// build's, so the code finds what it expects). What a clone can do with a committed study
/// whose pair changed, since the cells' data the page was built from are not committed.
pub(crate) fn reopen_page(html: &str, pair: &PairSpec) -> Result<String> {
    const OPEN: &str = "<script type=\"application/json\" id=\"explorer-manifest\">";
    const CODE: &str = "</script>\n<script>\n";
    if !html.contains(MARKUP) || !html.contains(STYLE) {
        anyhow::bail!(
            "the page's explorer controls are not this build's: render the study again (`sweep report` on its run folder)"
        );
    }
    let start = html
        .find(OPEN)
        .map(|i| i + OPEN.len())
        .ok_or_else(|| anyhow::anyhow!("the page has no explorer manifest"))?;
    let end = start
        + html[start..].find(CODE).ok_or_else(|| {
            anyhow::anyhow!("the page's explorer manifest is not followed by its code")
        })?;
    let code = end + CODE.len();
    let code_end = code
        + html[code..]
            .find("</script>")
            .ok_or_else(|| anyhow::anyhow!("the page's explorer code is not closed"))?;
    let mut manifest: serde_json::Value = serde_json::from_str(&html[start..end])?;
    manifest::reopen(&mut manifest, pair)?;
    // As `Manifest::to_script_json` writes it: no `<` that could close the element.
    let json = serde_json::to_string(&manifest)?.replace('<', "\\u003c");
    Ok(format!(
        "{}{json}{CODE}{SCRIPT}{}",
        &html[..start],
        &html[code_end..]
    ))
}

/// A report's explorer, its data files written.
pub(crate) struct Explorer {
    manifest: String,
}

impl Explorer {
    /// Writes the data files that are missing or out of date (see [`data`]) and prepares
    /// the page's manifest.
    /// `max_side` bounds the pixel data's long side (`[report] explorer_max_side`); the page
    /// opens on `opening` (else on its first two finished cells).
    pub(crate) fn build(
        out: &OutputDir,
        plan: &PlanRecord,
        cells: &[Collected],
        max_side: Option<usize>,
        opening: Option<Opening<'_>>,
    ) -> Result<Self> {
        let index = data::write_data(out, cells, max_side)?;
        let manifest = manifest::Manifest::new(plan, cells, &index, opening).to_script_json()?;
        Ok(Explorer { manifest })
    }

    /// The explorer's section of the page (controls, views, readout).
    pub(crate) fn section(&self) -> String {
        format!("<style>{STYLE}</style>\n{MARKUP}")
    }

    /// The manifest and the code, for the end of the page (after the tables and plots the
    /// code links to the explorer).
    pub(crate) fn script(&self) -> String {
        format!(
            "<script type=\"application/json\" id=\"explorer-manifest\">{}</script>\n<script>\n{SCRIPT}</script>\n",
            self.manifest
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A page made by an older build opens on the pair it is given, with this build's code;
    /// its other cells and text stay as they were, and a page whose controls are not this
    /// build's is refused rather than given code that would not find them.
    #[test]
    fn a_page_reopens_on_its_pair_with_this_builds_code() {
        let table = |text: &str| -> toml::Table {
            let (key, value) = text.split_once(" = ").unwrap();
            format!("\"{key}\" = {value}").parse().unwrap()
        };
        let manifest = serde_json::json!({
            "format": 1,
            "axes": [
                {"key": "scene", "values": ["a.toml", "b.toml"]},
                {"key": "integrator.nused", "values": ["25", "50", "150"]}
            ],
            "cells": [
                {"coords": [0, 0], "data": "0.js"}, {"coords": [0, 1], "data": "1.js"},
                {"coords": [0, 2]}, {"coords": [1, 0], "data": "3.js"},
                {"coords": [1, 2], "data": "4.js"}
            ],
            "start": [0, 1]
        });
        let page = |style: &str| {
            format!(
                "<p>before</p><style>{style}</style>\n{MARKUP}<script type=\"application/json\" id=\"explorer-manifest\">{manifest}</script>\n<script>\nold code\n</script>\n<p>after</p>"
            )
        };
        let pair = PairSpec {
            a: table("integrator.nused = 25"),
            b: table("integrator.nused = 150"),
        };
        let html = reopen_page(&page(STYLE), &pair).unwrap();
        // A is the first finished cell of nused 25 (cell 0); of the nused-150 cells only
        // cell 4 (scene b) is finished, so B is cell 4 though cell 2 shares A's scene.
        assert!(html.contains("\"start\":[0,4]"), "{html}");
        assert!(html.contains(SCRIPT) && !html.contains("old code"));
        assert!(html.starts_with("<p>before</p>") && html.ends_with("</script>\n<p>after</p>"));
        let refused = reopen_page(&page("p{}"), &pair).unwrap_err().to_string();
        assert!(refused.contains("render the study again"), "{refused}");
        let unknown = PairSpec {
            a: table("integrator.nused = 25"),
            b: table("integrator.nused = 300"),
        };
        let none = reopen_page(&page(STYLE), &unknown).unwrap_err();
        assert!(format!("{none:#}").contains("300"), "{none:#}");
    }

    #[test]
    fn the_page_code_cannot_close_its_script_element() {
        for text in [SCRIPT, STYLE] {
            assert!(!text.to_ascii_lowercase().contains("</script"));
        }
    }
}
