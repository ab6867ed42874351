//! σ mappings: how transferred density becomes absorption and scattering coefficients.
//!
//! The medium is `σa(x) = σa_base·d(x)`, `σs(x) = σs_base·d(x)`, `σt = σa + σs` (thesis
//! §7.2.2). The base values are chosen by a named strategy, because the choice is itself a
//! parameter under study (§8.1.2):
//!
//! * `explicit` — give `sigma_a` and `sigma_s` base values directly (the pbrt plugin's way).
//! * `thesis` — the smallest non-zero density `d_min` maps to `σt = t`, i.e.
//!   `σt_base = t / d_min`, split by an `albedo` or a `ratio = [σa, σs]`
//!   (§8.1.2 example: `t = 80`, `σs = 9/11·σt`).
//! * `opacity` — for colour transfer functions ([`crate::ColourTransfer`]): the
//!   transferred density already is extinction, `−ln(1 − α)/unit_distance` converted to
//!   world units, times `scale` (default 1); `albedo` scales the colour (default 1).
//! * `mean-free-path` — the mean free path `1/σt` at `d_min` is `percent` % of the largest
//!   extent of the volume (§8.1.2: 1–2 % for nused > 100, 3–4 % below, ≥ 6–8 % transparent).
//!
//! Extinction is grey (the same σt for R, G and B) so free paths and transmittance are
//! scalar; albedo may be coloured. Every mapping reports its σt range and its nominal mean
//! free path at `d_min` — `1/σt` and the median `ln 2/σt` — as % of the largest extent
//! (the thesis quoted the median-like `ξ = 0.5` value, §8.1.1).
//!
//! ```
//! use volphot::{MappingKind, SigmaParams, SigmaMapping};
//! let params = SigmaParams { mapping: MappingKind::Thesis, t: Some(80.0), ratio: Some([1.0, 4.0]), ..Default::default() };
//! let mapping = SigmaMapping::create(&params).unwrap();
//! let coefficients = mapping.resolve(0.1, 1.0, 1.0).unwrap();
//! assert!((coefficients.sigma_t_base - 800.0).abs() < 1e-3);
//! assert!((coefficients.albedo.x - 0.8).abs() < 1e-6);
//! ```

use glam::Vec3;
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result, check_positive, check_range, check_rgb_non_negative};

/// σ-mapping parameters as written in a scene's `[sigma]` table.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SigmaParams {
    /// `explicit`, `thesis` or `mean-free-path`.
    #[serde(default)]
    pub mapping: MappingKind,
    /// `explicit`: absorption base value (RGB).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sigma_a: Option<[f32; 3]>,
    /// `explicit`: scattering base value (RGB).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sigma_s: Option<[f32; 3]>,
    /// `thesis`: σt at the smallest non-zero density.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub t: Option<f32>,
    /// `mean-free-path`: 1/σt at `d_min` as % of the largest extent.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub percent: Option<f32>,
    /// Single-scattering albedo σs/σt (grey), for `thesis` and `mean-free-path`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub albedo: Option<f32>,
    /// `[σa, σs]` proportions (e.g. `[1, 4]`), alternative to `albedo`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ratio: Option<[f32; 2]>,
    /// `opacity`: multiplier on the extinction the opacity gives (default 1).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub scale: Option<f32>,
    /// Emission base value `Le` (RGB radiance per unit length per unit density).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub emission: Option<[f32; 3]>,
    /// Tint the emission by the colour transfer function's colour at each point
    /// (`Le · colour(x) · d(x)`, the emission–absorption model of Slicer/VTK's ray caster).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub emission_colour: bool,
}

/// The σ-mapping strategy a scene's `[sigma]` table names.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum MappingKind {
    /// Base values `sigma_a`, `sigma_s` given directly.
    Explicit,
    /// σt(d_min) = `t` (§8.1.2).
    #[default]
    Thesis,
    /// Mean free path at `d_min` = `percent` % of the largest extent.
    MeanFreePath,
    /// Extinction from a colour transfer function's opacity, times `scale`.
    Opacity,
}

impl MappingKind {
    /// The name as written in scene files.
    pub fn name(self) -> &'static str {
        match self {
            MappingKind::Explicit => "explicit",
            MappingKind::Thesis => "thesis",
            MappingKind::MeanFreePath => "mean-free-path",
            MappingKind::Opacity => "opacity",
        }
    }
}

/// The shortest mean free path a medium may have, as a fraction of the volume's largest
/// extent (in its densest voxel). Denser media cannot be tracked: a free-path step would
/// fall below the `f32` precision of the ray parameter.
pub const MIN_MEAN_FREE_PATH: f64 = 1e-6;

/// The thesis's worked example (§8.1.2): σt(d_min) = 80, σs = 9/11·σt.
pub const THESIS_T: f32 = 80.0;
/// The thesis's worked-example albedo, 9/11 (≈ 0.818; note §8.1.2 recommends 1:4 = 0.8).
pub const THESIS_ALBEDO: f32 = 9.0 / 11.0;

impl Default for SigmaParams {
    fn default() -> Self {
        SigmaParams {
            mapping: MappingKind::Thesis,
            sigma_a: None,
            sigma_s: None,
            t: None,
            percent: None,
            albedo: None,
            ratio: None,
            scale: None,
            emission: None,
            emission_colour: false,
        }
    }
}

/// How σt is split into absorption and scattering.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum Split {
    /// σs/σt.
    Albedo(f32),
    /// `σa : σs`.
    Ratio(f32, f32),
}

impl Split {
    /// The albedo this split gives.
    pub fn albedo(&self) -> f32 {
        match *self {
            Split::Albedo(a) => a,
            Split::Ratio(a, s) => s / (a + s),
        }
    }

    fn describe(&self) -> String {
        match *self {
            Split::Albedo(a) => format!("albedo {a}"),
            Split::Ratio(a, s) => format!("σa:σs = {a}:{s}"),
        }
    }
}

/// A validated σ mapping strategy.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum SigmaMapping {
    /// Base values given directly.
    Explicit {
        /// σa base (RGB).
        sigma_a: [f32; 3],
        /// σs base (RGB).
        sigma_s: [f32; 3],
    },
    /// `σt(d_min) = t` (thesis §8.1.2).
    Thesis {
        /// σt at the smallest non-zero density.
        t: f32,
        /// Absorption/scattering split.
        split: Split,
    },
    /// Mean free path at `d_min` = `percent` % of the largest extent.
    MeanFreePath {
        /// The percentage.
        percent: f32,
        /// Absorption/scattering split.
        split: Split,
    },
    /// σt = `scale` × the colour transfer function's extinction; albedo = `albedo` × colour.
    Opacity {
        /// Multiplier on extinction.
        scale: f32,
        /// Multiplier on the colour (the albedo where the colour is white).
        albedo: f32,
    },
}

/// Base coefficients resolved for a concrete volume.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Coefficients {
    /// σt per unit transferred density (grey).
    pub sigma_t_base: f32,
    /// σs/σt per channel.
    pub albedo: Vec3,
}

/// A key that the chosen mapping does not take.
fn forbid(params: &SigmaParams, key: &str, present: bool) -> Result<()> {
    if present {
        Err(Error::given_without_use(
            key,
            format!("no `{key}` with mapping = \"{}\"", params.mapping.name()),
        ))
    } else {
        Ok(())
    }
}

/// The absorption/scattering split from `albedo` or `ratio` (default: the thesis's 9/11).
fn split(params: &SigmaParams) -> Result<Split> {
    match (params.albedo, params.ratio) {
        (Some(_), Some(_)) => Err(Error::parameter(
            "ratio",
            "(given with albedo)",
            "either `albedo` or `ratio`, not both",
        )),
        (Some(a), None) => {
            check_range("albedo", a as f64, 0.0, 1.0)?;
            Ok(Split::Albedo(a))
        }
        (None, Some([a, s])) => {
            if !(a.is_finite() && s.is_finite() && a >= 0.0 && s >= 0.0 && a + s > 0.0) {
                return Err(Error::parameter(
                    "ratio",
                    format!("[{a}, {s}]"),
                    "[σa, σs] proportions: finite, >= 0, not both 0",
                ));
            }
            Ok(Split::Ratio(a, s))
        }
        (None, None) => Ok(Split::Albedo(THESIS_ALBEDO)),
    }
}

impl SigmaMapping {
    /// Validates parameters; each error names the key.
    pub fn create(params: &SigmaParams) -> Result<Self> {
        if let Some(e) = params.emission {
            check_rgb_non_negative("emission", e)?;
        }
        if params.emission_colour && params.emission.is_none_or(|e| e == [0.0; 3]) {
            return Err(Error::parameter(
                "emission_colour",
                true,
                "a non-zero `emission` (the Le scale the colour tints) beside it",
            ));
        }
        if params.mapping != MappingKind::Opacity {
            forbid(params, "scale", params.scale.is_some())?;
        }
        match params.mapping {
            MappingKind::Explicit => Self::create_explicit(params),
            MappingKind::Opacity => {
                for (key, present) in [
                    ("sigma_a", params.sigma_a.is_some()),
                    ("sigma_s", params.sigma_s.is_some()),
                    ("t", params.t.is_some()),
                    ("percent", params.percent.is_some()),
                    ("ratio", params.ratio.is_some()),
                ] {
                    forbid(params, key, present)?;
                }
                let scale = params.scale.unwrap_or(1.0);
                check_positive("scale", scale as f64)?;
                let albedo = params.albedo.unwrap_or(1.0);
                check_range("albedo", albedo as f64, 0.0, 1.0)?;
                Ok(SigmaMapping::Opacity { scale, albedo })
            }
            MappingKind::Thesis => {
                forbid(params, "sigma_a", params.sigma_a.is_some())?;
                forbid(params, "sigma_s", params.sigma_s.is_some())?;
                forbid(params, "percent", params.percent.is_some())?;
                let t = params.t.unwrap_or(THESIS_T);
                check_positive("t", t as f64)?;
                Ok(SigmaMapping::Thesis {
                    t,
                    split: split(params)?,
                })
            }
            MappingKind::MeanFreePath => {
                forbid(params, "sigma_a", params.sigma_a.is_some())?;
                forbid(params, "sigma_s", params.sigma_s.is_some())?;
                forbid(params, "t", params.t.is_some())?;
                let percent = params.percent.ok_or_else(|| {
                    Error::parameter(
                        "percent",
                        "(missing)",
                        "a mean free path in % of the largest extent, e.g. 1.5",
                    )
                })?;
                if !(percent.is_finite() && percent > 0.0 && percent <= 1000.0) {
                    return Err(Error::parameter(
                        "percent",
                        percent,
                        "a percentage in (0, 1000]",
                    ));
                }
                Ok(SigmaMapping::MeanFreePath {
                    percent,
                    split: split(params)?,
                })
            }
        }
    }

    /// `mapping = "explicit"`: RGB base values whose sums σa + σs agree (grey extinction).
    fn create_explicit(params: &SigmaParams) -> Result<Self> {
        forbid(params, "t", params.t.is_some())?;
        forbid(params, "percent", params.percent.is_some())?;
        forbid(params, "albedo", params.albedo.is_some())?;
        forbid(params, "ratio", params.ratio.is_some())?;
        let sigma_a = params.sigma_a.ok_or_else(|| {
            Error::parameter("sigma_a", "(missing)", "an RGB base value, e.g. [1, 1, 1]")
        })?;
        let sigma_s = params.sigma_s.ok_or_else(|| {
            Error::parameter(
                "sigma_s",
                "(missing)",
                "an RGB base value, e.g. [10, 10, 10]",
            )
        })?;
        check_rgb_non_negative("sigma_a", sigma_a)?;
        check_rgb_non_negative("sigma_s", sigma_s)?;
        let t: Vec<f32> = (0..3).map(|i| sigma_a[i] + sigma_s[i]).collect();
        let spread = t.iter().cloned().fold(f32::NEG_INFINITY, f32::max)
            - t.iter().cloned().fold(f32::INFINITY, f32::min);
        if spread > 1e-4 * t[0].abs().max(1.0) {
            return Err(Error::parameter(
                "sigma_s",
                format!("{sigma_s:?} with sigma_a = {sigma_a:?}"),
                "sigma_a + sigma_s equal for R, G and B (grey extinction; colour belongs in the albedo)",
            ));
        }
        if t[0] <= 0.0 {
            return Err(Error::parameter(
                "sigma_s",
                format!("{sigma_s:?} with sigma_a = {sigma_a:?}"),
                "sigma_a + sigma_s > 0",
            ));
        }
        Ok(SigmaMapping::Explicit { sigma_a, sigma_s })
    }

    /// Base coefficients for a volume whose smallest non-zero transferred density is `d_min`
    /// and whose largest extent is `largest_extent` (world units).
    ///
    /// The densest voxel's mean free path `1/σt_max` must be at least
    /// [`MIN_MEAN_FREE_PATH`] of the largest extent: beyond that no tracker can resolve the
    /// medium (free-path steps fall below the precision of a ray's parameter), and the
    /// error names the key that set σt.
    pub fn resolve(&self, d_min: f32, d_max: f32, largest_extent: f32) -> Result<Coefficients> {
        let coefficients = self.coefficients(d_min, largest_extent)?;
        let sigma_t_max = coefficients.sigma_t_base as f64 * d_max as f64;
        let bound = 1.0 / (MIN_MEAN_FREE_PATH * largest_extent as f64);
        if !(sigma_t_max.is_finite() && sigma_t_max <= bound) {
            let (key, value) = self.sigma_t_key();
            return Err(Error::parameter(
                key,
                value,
                format!(
                    "a σ mapping whose densest voxel keeps a mean free path of at least {MIN_MEAN_FREE_PATH:e} of the volume's largest extent ({largest_extent}), i.e. σt_max <= {bound:.3e}; this one gives σt_max = {sigma_t_max:.3e}"
                ),
            ));
        }
        Ok(coefficients)
    }

    /// The key (and its value) that sets the scale of σt in this mapping.
    fn sigma_t_key(&self) -> (&'static str, String) {
        match self {
            SigmaMapping::Explicit { sigma_s, .. } => ("sigma_s", format!("{sigma_s:?}")),
            SigmaMapping::Thesis { t, .. } => ("t", t.to_string()),
            SigmaMapping::MeanFreePath { percent, .. } => ("percent", percent.to_string()),
            SigmaMapping::Opacity { scale, .. } => ("scale", scale.to_string()),
        }
    }

    fn coefficients(&self, d_min: f32, largest_extent: f32) -> Result<Coefficients> {
        let need_dmin = || -> Result<f32> {
            if d_min > 0.0 && d_min.is_finite() {
                Ok(d_min)
            } else {
                Err(Error::parameter(
                    "mapping",
                    "(empty volume)",
                    "a volume with some non-zero density after the transfer function",
                ))
            }
        };
        match self {
            SigmaMapping::Explicit { sigma_a, sigma_s } => {
                let t = sigma_a[0] + sigma_s[0];
                Ok(Coefficients {
                    sigma_t_base: t,
                    albedo: Vec3::from(*sigma_s) / t,
                })
            }
            SigmaMapping::Thesis { t, split } => Ok(Coefficients {
                sigma_t_base: t / need_dmin()?,
                albedo: Vec3::splat(split.albedo()),
            }),
            SigmaMapping::Opacity { scale, albedo } => Ok(Coefficients {
                sigma_t_base: *scale,
                albedo: Vec3::splat(*albedo),
            }),
            SigmaMapping::MeanFreePath { percent, split } => {
                let sigma_t_at_dmin = 1.0 / (percent / 100.0 * largest_extent);
                Ok(Coefficients {
                    sigma_t_base: sigma_t_at_dmin / need_dmin()?,
                    albedo: Vec3::splat(split.albedo()),
                })
            }
        }
    }

    /// One line for provenance and captions.
    pub fn describe(&self) -> String {
        match self {
            SigmaMapping::Explicit { sigma_a, sigma_s } => {
                format!("explicit σa {sigma_a:?}, σs {sigma_s:?}")
            }
            SigmaMapping::Thesis { t, split } => {
                format!("σt(d_min) = {t}, {}", split.describe())
            }
            SigmaMapping::Opacity { scale, albedo } => {
                format!("σt = {scale} × −ln(1 − opacity)/unit distance, albedo {albedo} × colour")
            }
            SigmaMapping::MeanFreePath { percent, split } => {
                format!(
                    "mean free path at d_min = {percent} % of extent, {}",
                    split.describe()
                )
            }
        }
    }
}

/// What a mapping gives on a concrete volume, reported with every render.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SigmaReport {
    /// Smallest non-zero transferred density.
    pub d_min: f32,
    /// Largest transferred density.
    pub d_max: f32,
    /// σt per unit density.
    pub sigma_t_base: f32,
    /// σt at `d_min`.
    pub sigma_t_at_dmin: f32,
    /// σt at `d_max`.
    pub sigma_t_at_dmax: f32,
    /// Grey albedo (mean over channels).
    pub albedo: f32,
    /// Largest extent of the volume box.
    pub largest_extent: f32,
    /// `1/σt(d_min)` as % of the largest extent.
    pub mean_free_path_percent: f32,
    /// `ln 2/σt(d_min)` (the median free path) as % of the largest extent.
    pub median_free_path_percent: f32,
}

impl SigmaReport {
    /// Builds the report from resolved coefficients.
    pub fn new(c: &Coefficients, d_min: f32, d_max: f32, largest_extent: f32) -> Self {
        let sigma_t_at_dmin = c.sigma_t_base * d_min;
        let mfp = free_path_percent(sigma_t_at_dmin, largest_extent);
        SigmaReport {
            d_min,
            d_max,
            sigma_t_base: c.sigma_t_base,
            sigma_t_at_dmin,
            sigma_t_at_dmax: c.sigma_t_base * d_max,
            albedo: (c.albedo.x + c.albedo.y + c.albedo.z) / 3.0,
            largest_extent,
            mean_free_path_percent: mfp,
            median_free_path_percent: mfp * std::f32::consts::LN_2,
        }
    }

    /// `1/σt(d_max)` as % of the largest extent: the densest material's mean free path.
    pub fn mean_free_path_percent_at_dmax(&self) -> f32 {
        free_path_percent(self.sigma_t_at_dmax, self.largest_extent)
    }
}

/// `1/σt` as % of `largest_extent` (infinite where nothing scatters).
fn free_path_percent(sigma_t: f32, largest_extent: f32) -> f32 {
    if sigma_t > 0.0 {
        100.0 / (sigma_t * largest_extent)
    } else {
        f32::INFINITY
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn params(mapping: MappingKind) -> SigmaParams {
        SigmaParams {
            mapping,
            ..Default::default()
        }
    }

    #[test]
    fn thesis_example_by_hand() {
        // §8.1.2: unit volume, d_min = 1/255 (8-bit), σt(d_min) = 80, σs = 9/11 σt.
        let m = SigmaMapping::create(&SigmaParams {
            t: Some(80.0),
            albedo: Some(9.0 / 11.0),
            ..params(MappingKind::Thesis)
        })
        .unwrap();
        let d_min = 1.0 / 255.0;
        let c = m.resolve(d_min, 1.0, 1.0).unwrap();
        assert!((c.sigma_t_base - 20400.0).abs() < 0.5);
        let r = SigmaReport::new(&c, d_min, 1.0, 1.0);
        assert!((r.sigma_t_at_dmin - 80.0).abs() < 1e-3);
        assert!((r.mean_free_path_percent - 1.25).abs() < 1e-4); // 1/80
        assert!((r.median_free_path_percent - 0.866_434).abs() < 1e-4); // ln2/80
        let sigma_s = c.sigma_t_base * c.albedo.x;
        assert!((sigma_s - 20400.0 * 9.0 / 11.0).abs() < 0.5);
    }

    #[test]
    fn mean_free_path_rule_by_hand() {
        // 2 % of an extent of 1 → σt(d_min) = 50; d_min = 0.2 → base 250.
        let m = SigmaMapping::create(&SigmaParams {
            percent: Some(2.0),
            ratio: Some([1.0, 4.0]),
            ..params(MappingKind::MeanFreePath)
        })
        .unwrap();
        let c = m.resolve(0.2, 1.0, 1.0).unwrap();
        assert!((c.sigma_t_base - 250.0).abs() < 1e-3);
        assert!((c.albedo.x - 0.8).abs() < 1e-6);
        let r = SigmaReport::new(&c, 0.2, 1.0, 1.0);
        assert!((r.mean_free_path_percent - 2.0).abs() < 1e-4);
        // Largest extent 0.5 halves the distance per percent.
        let c = m.resolve(0.2, 1.0, 0.5).unwrap();
        assert!((c.sigma_t_base - 500.0).abs() < 1e-3);
    }

    #[test]
    fn explicit_thesis_plugin_values() {
        // §7.2.1: sigma_a [1 1 1], sigma_s [10 10 10] → σt 11, albedo 10/11.
        let m = SigmaMapping::create(&SigmaParams {
            sigma_a: Some([1.0; 3]),
            sigma_s: Some([10.0; 3]),
            ..params(MappingKind::Explicit)
        })
        .unwrap();
        let c = m.resolve(0.5, 1.0, 1.0).unwrap();
        assert_eq!(c.sigma_t_base, 11.0);
        assert!((c.albedo.y - 10.0 / 11.0).abs() < 1e-6);
    }

    #[test]
    fn bad_parameters_name_the_key() {
        let cases: Vec<(SigmaParams, &str)> = vec![
            (
                SigmaParams {
                    t: Some(-3.0),
                    ..params(MappingKind::Thesis)
                },
                "`t` = -3",
            ),
            (
                SigmaParams {
                    t: Some(f32::NAN),
                    ..params(MappingKind::Thesis)
                },
                "`t` = NaN",
            ),
            (
                SigmaParams {
                    albedo: Some(1.5),
                    ..params(MappingKind::Thesis)
                },
                "`albedo` = 1.5",
            ),
            (
                SigmaParams {
                    albedo: Some(0.5),
                    ratio: Some([1.0, 4.0]),
                    ..params(MappingKind::Thesis)
                },
                "`ratio`",
            ),
            (
                SigmaParams {
                    ratio: Some([0.0, 0.0]),
                    ..params(MappingKind::Thesis)
                },
                "`ratio`",
            ),
            (params(MappingKind::MeanFreePath), "`percent` = (missing)"),
            (
                SigmaParams {
                    percent: Some(0.0),
                    ..params(MappingKind::MeanFreePath)
                },
                "`percent` = 0",
            ),
            (
                SigmaParams {
                    sigma_a: Some([1.0; 3]),
                    sigma_s: Some([1.0, 2.0, 3.0]),
                    ..params(MappingKind::Explicit)
                },
                "grey extinction",
            ),
            (
                SigmaParams {
                    sigma_a: Some([-1.0; 3]),
                    sigma_s: Some([1.0; 3]),
                    ..params(MappingKind::Explicit)
                },
                "`sigma_a`",
            ),
            (
                SigmaParams {
                    t: Some(80.0),
                    ..params(MappingKind::Explicit)
                },
                "`t`",
            ),
            (
                SigmaParams {
                    emission: Some([0.0, -1.0, 0.0]),
                    ..params(MappingKind::Thesis)
                },
                "`emission`",
            ),
        ];
        for (p, needle) in cases {
            let e = SigmaMapping::create(&p).unwrap_err().to_string();
            assert!(e.contains(needle), "{e} lacks {needle}");
        }
        // An unknown mapping is a type error of the scene file, located and naming the value.
        let e = crate::SceneParams::from_toml(
            "[volume]\nphantom = { name = \"sphere\" }\n[sigma]\nmapping = \"magic\"\n",
            std::path::Path::new("s.toml"),
        )
        .unwrap_err()
        .to_string();
        assert!(
            e.starts_with("s.toml:4:") && e.contains("mapping = \"magic\"") && e.contains("thesis"),
            "{e}"
        );
        let m = SigmaMapping::create(&params(MappingKind::Thesis)).unwrap();
        let e = m.resolve(0.0, 0.0, 1.0).unwrap_err().to_string();
        assert!(e.contains("non-zero density"), "{e}");
    }
}
