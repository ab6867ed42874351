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

    #[test]
    fn the_page_code_cannot_close_its_script_element() {
        for text in [SCRIPT, STYLE] {
            assert!(!text.to_ascii_lowercase().contains("</script"));
        }
    }
}
