//! Colour and opacity transfer functions in data units (HU for CT, raw values otherwise):
//! control points from a scene's `[transfer]` table, 3D Slicer volume-property files
//! (`.vp`, `.vp.json`) or a built-in Slicer preset by name ([`presets`]).
//!
//! Physics: the opacity α(v) a preset gives over its unit distance becomes extinction
//! `σt = −ln(1 − α) / unit_distance` (per mm), times the scene's scale; the colour is the
//! single-scattering albedo per channel.
//!
//! ```
//! use volphot::ColourTransfer;
//! let bone = ColourTransfer::preset("CT-Bone").unwrap();
//! assert_eq!(bone.opacity(-1000.0), 0.0);
//! assert!(bone.opacity(700.0) > 0.7);
//! assert!(bone.extinction_per_mm(700.0) > 1.2);
//! ```

pub mod presets;
mod slicer;

use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};

/// The largest opacity used for extinction (α = 1 would be infinitely dense).
const MAX_OPACITY: f64 = 1.0 - 1e-6;

/// A piecewise-linear colour + opacity transfer function over data values.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ColourTransfer {
    /// Where it came from: a preset name, a file or `points`.
    pub source: String,
    /// `[value, opacity]` with non-decreasing values, opacity in `[0, 1]`.
    pub opacity: Vec<[f64; 2]>,
    /// `[value, r, g, b]` with non-decreasing values, colour in `[0, 1]`.
    pub colour: Vec<[f64; 4]>,
    /// The distance in mm over which the opacity accumulates (Slicer and VTK: 1).
    pub unit_distance: f64,
}

impl ColourTransfer {
    /// Checks the points; `what` names the file or key in errors.
    pub fn validated(self, what: &str) -> Result<Self> {
        check_points(what, "opacity", self.opacity.iter().map(|p| p.as_slice()))?;
        check_points(what, "colour", self.colour.iter().map(|p| p.as_slice()))?;
        if !(self.unit_distance.is_finite() && self.unit_distance > 0.0) {
            return Err(Error::parameter(
                format!("{what}.unit_distance"),
                self.unit_distance,
                "a distance in mm > 0",
            ));
        }
        Ok(self)
    }

    /// A built-in 3D Slicer preset by name (`CT-Bone`, `CT-AAA`, `MR-Default`, …; see
    /// `crates/core/presets/slicer/`).
    pub fn preset(name: &str) -> Result<Self> {
        presets::get(name)
    }

    /// Reads a Slicer `.vp` or `.vp.json` file.
    pub fn read(path: &Path) -> Result<Self> {
        slicer::read(path)
    }

    /// Opacity at data value `v` (clamped to the end points beyond them).
    pub fn opacity(&self, v: f64) -> f64 {
        interpolate(&self.opacity, v, |p| p[1])
    }

    /// Colour at data value `v`.
    pub fn colour(&self, v: f64) -> [f64; 3] {
        [1, 2, 3].map(|c| interpolate(&self.colour, v, |p| p[c]))
    }

    /// Extinction per mm at data value `v`: `−ln(1 − α) / unit_distance`.
    pub fn extinction_per_mm(&self, v: f64) -> f64 {
        -(1.0 - self.opacity(v).clamp(0.0, MAX_OPACITY)).ln() / self.unit_distance
    }

    /// One line for records: source, point counts and unit distance.
    pub fn describe(&self) -> String {
        format!(
            "colour transfer {} ({} opacity, {} colour points, unit distance {} mm)",
            self.source,
            self.opacity.len(),
            self.colour.len(),
            self.unit_distance
        )
    }
}

/// Piecewise-linear through points sorted by `p[0]`, constant beyond the ends.
fn interpolate<const N: usize>(points: &[[f64; N]], v: f64, y: impl Fn(&[f64; N]) -> f64) -> f64 {
    let Some(first) = points.first() else {
        return 0.0;
    };
    let i = points.partition_point(|p| p[0] <= v);
    if i == 0 {
        return y(first);
    }
    if i == points.len() {
        return y(&points[i - 1]);
    }
    let (a, b) = (&points[i - 1], &points[i]);
    let t = if b[0] > a[0] {
        (v - a[0]) / (b[0] - a[0])
    } else {
        1.0
    };
    y(a) + t * (y(b) - y(a))
}

/// At least one point; finite numbers; values non-decreasing; outputs in `[0, 1]`.
fn check_points<'a>(what: &str, key: &str, points: impl Iterator<Item = &'a [f64]>) -> Result<()> {
    let mut last: Option<f64> = None;
    let mut count = 0;
    for (i, p) in points.enumerate() {
        count += 1;
        let shown = format!("{p:?}");
        if p.iter().any(|v| !v.is_finite()) {
            return Err(Error::parameter(
                format!("{what}.{key}[{i}]"),
                shown,
                "finite numbers",
            ));
        }
        if p[1..].iter().any(|v| !(0.0..=1.0).contains(v)) {
            return Err(Error::parameter(
                format!("{what}.{key}[{i}]"),
                shown,
                format!("{key} values in [0, 1] after the data value"),
            ));
        }
        if let Some(prev) = last
            && p[0] < prev
        {
            return Err(Error::parameter(
                format!("{what}.{key}[{i}]"),
                shown,
                format!("points in increasing data value (the previous point is at {prev})"),
            ));
        }
        last = Some(p[0]);
    }
    if count == 0 {
        return Err(Error::parameter(
            format!("{what}.{key}"),
            "[]",
            "at least one point",
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tf() -> ColourTransfer {
        ColourTransfer {
            source: "test".into(),
            opacity: vec![[0.0, 0.0], [100.0, 0.5], [100.0, 0.8], [200.0, 1.0]],
            colour: vec![[0.0, 1.0, 0.0, 0.0], [200.0, 0.0, 0.0, 1.0]],
            unit_distance: 2.0,
        }
    }

    #[test]
    fn piecewise_linear_clamped_with_steps() {
        let t = tf().validated("t").unwrap();
        assert_eq!(t.opacity(-5.0), 0.0);
        assert_eq!(t.opacity(50.0), 0.25);
        assert_eq!(
            t.opacity(100.0),
            0.8,
            "a repeated value is a step; the later point wins"
        );
        assert_eq!(t.opacity(500.0), 1.0);
        assert_eq!(t.colour(100.0), [0.5, 0.0, 0.5]);
        assert!((t.extinction_per_mm(50.0) - (-(0.75f64).ln() / 2.0)).abs() < 1e-12);
        assert!(t.extinction_per_mm(300.0).is_finite());
    }

    #[test]
    fn out_of_order_and_out_of_range_points_are_named() {
        let mut t = tf();
        t.colour = vec![[10.0, 0.0, 0.0, 0.0], [5.0, 1.0, 1.0, 1.0]];
        let e = t.validated("transfer").unwrap_err().to_string();
        assert!(
            e.contains("transfer.colour[1]") && e.contains("increasing"),
            "{e}"
        );
        let mut t = tf();
        t.opacity[1][1] = 1.5;
        let e = t.validated("transfer").unwrap_err().to_string();
        assert!(
            e.contains("transfer.opacity[1]") && e.contains("[0, 1]"),
            "{e}"
        );
    }
}
