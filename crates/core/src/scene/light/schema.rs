//! A light as a scene file writes it: the `[[lights]]` table's keys, the kinds and which
//! keys each takes. Plain data: building a light from it is `build`'s, checking its values
//! too.

use std::path::PathBuf;

use glam::Vec3;
use serde::{Deserialize, Serialize};

/// One light as written in a scene's `[[lights]]` array. Which keys a light takes depends
/// on its `type` (a key given to a light that has no use for it is an error naming it).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LightParams {
    /// `spot`, `point`, `rect`, `disc`, `environment` or `sky`.
    #[serde(rename = "type")]
    pub kind: LightKind,
    /// `spot`, `point`: the light's position; `rect`, `disc`: the centre.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub position: Option<[f32; 3]>,
    /// `spot`: the point the axis aims at; `rect`, `disc`: the point the normal faces.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub target: Option<[f32; 3]>,
    /// `spot`, `point`: radiant intensity on the axis, W/sr: one number (white) or RGB.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub intensity: Option<Intensity>,
    /// `spot`: angle from the axis to the cut-off, degrees.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cone_angle: Option<f32>,
    /// `spot`: angle from the axis where the falloff starts, degrees.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub beam_width: Option<f32>,
    /// `spot`: the shape of the falloff between `beam_width` and `cone_angle`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub falloff: Option<SpotFalloff>,
    /// `rect`, `disc`: the emitting side's normal (instead of `target`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub normal: Option<[f32; 3]>,
    /// `rect`: `[width, height]`, world units.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub size: Option<[f32; 2]>,
    /// `disc`: the radius, world units.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub radius: Option<f32>,
    /// `rect`, `disc`: emitted radiance, W/m²/sr: one number or RGB.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub radiance: Option<Intensity>,
    /// `rect`: the direction the rectangle's height follows; `environment`, `sky`: the
    /// map's zenith (default `[0, 0, 1]`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub up: Option<[f32; 3]>,
    /// `environment`: the HDR map (EXR, PFM or Radiance `.hdr`), relative to the scene file.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub file: Option<PathBuf>,
    /// `environment`, `sky`: multiplies the map's radiance (default 1).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub scale: Option<Intensity>,
    /// `environment`, `sky`: turns the map about `up`, degrees.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rotation: Option<f32>,
    /// `sky`: radiance straight up.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub zenith: Option<Intensity>,
    /// `sky`: radiance at the horizon.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub horizon: Option<Intensity>,
    /// `sky`: radiance straight down.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ground: Option<Intensity>,
    /// `sky`: the direction towards the sun (no sun without it).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sun_direction: Option<[f32; 3]>,
    /// `sky`: the sun disc's radiance.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sun_radiance: Option<Intensity>,
    /// `sky`: the sun's angular diameter, degrees (default 0.53, the real sun's).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sun_angle: Option<f32>,
}

/// How a spot light's intensity falls from the beam width to the cone angle.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum SpotFalloff {
    /// Linearly in angle (Mitsuba's and pbrt-v4's convention before smoothstep).
    #[default]
    Linear,
    /// pbrt-v1's quartic in cosine, `((cos θ − cos θc)/(cos θw − cos θc))⁴` (thesis §7,
    /// the renderer the study's scenes were written for).
    Pbrt,
}

/// The kind of a light (`type = "spot"`, `"point"`, `"rect"`, `"disc"`, `"environment"`
/// or `"sky"` in a scene).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum LightKind {
    /// A spot light: a cone with a linear falloff in angle.
    Spot,
    /// A point light radiating equally in every direction.
    #[default]
    Point,
    /// A one-sided rectangular area light.
    Rect,
    /// A one-sided disc area light.
    Disc,
    /// An environment from an HDR map.
    Environment,
    /// A procedural sky (gradient and optional sun).
    Sky,
}

impl LightKind {
    /// The keys a light of this kind takes besides `type`.
    pub(crate) fn keys(self) -> &'static [&'static str] {
        match self {
            LightKind::Point => &["position", "intensity"],
            LightKind::Spot => &[
                "position",
                "target",
                "intensity",
                "cone_angle",
                "beam_width",
                "falloff",
            ],
            LightKind::Rect => &["position", "target", "normal", "up", "size", "radiance"],
            LightKind::Disc => &["position", "target", "normal", "radius", "radiance"],
            LightKind::Environment => &["file", "scale", "up", "rotation"],
            LightKind::Sky => &[
                "scale",
                "up",
                "rotation",
                "zenith",
                "horizon",
                "ground",
                "sun_direction",
                "sun_radiance",
                "sun_angle",
            ],
        }
    }

    /// The kind as a scene file writes it (`type = "…"`).
    pub(crate) fn name(self) -> &'static str {
        match self {
            LightKind::Point => "point",
            LightKind::Spot => "spot",
            LightKind::Rect => "rect",
            LightKind::Disc => "disc",
            LightKind::Environment => "environment",
            LightKind::Sky => "sky",
        }
    }

    /// Whether building the light needs the scene (the volume's bounds, the scene file's
    /// folder): the environments.
    pub fn needs_scene(self) -> bool {
        matches!(self, LightKind::Environment | LightKind::Sky)
    }
}

/// An intensity given as one grey number or an RGB triple.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum Intensity {
    /// The same value for R, G, B.
    Grey(f32),
    /// Per channel.
    Rgb([f32; 3]),
}

impl Intensity {
    /// As an RGB vector.
    pub fn rgb(&self) -> Vec3 {
        match *self {
            Intensity::Grey(v) => Vec3::splat(v),
            Intensity::Rgb(c) => Vec3::from(c),
        }
    }
}

/// A clear day's sky by default: blue above, a bright horizon, a dim ground (W/m²/sr).
pub(crate) const DEFAULT_ZENITH: [f32; 3] = [0.25, 0.4, 0.9];
pub(crate) const DEFAULT_HORIZON: [f32; 3] = [0.9, 0.9, 0.9];
pub(crate) const DEFAULT_GROUND: [f32; 3] = [0.15, 0.13, 0.1];
/// The real sun's angular diameter, degrees.
pub(crate) const DEFAULT_SUN_ANGLE: f32 = 0.53;
