//! The thesis's three-point lighting (§8.2) as a preset: key, fill and rim spot lights
//! placed from the camera, or in the cinematic style an area key and a sky.

use std::f32::consts::PI;
use std::sync::Arc;

use glam::Vec3;
use serde::{Deserialize, Serialize};

use super::Light;
use super::incident::MAX_INTENSITY;
use super::schema::{DEFAULT_GROUND, DEFAULT_HORIZON, DEFAULT_ZENITH};
use super::spot::SpotLight;
use crate::error::{Error, Result};
use crate::math::Aabb;
use crate::scene::area::{AreaLight, AreaShape};
use crate::scene::camera::Camera;
use crate::scene::environment::{EnvironmentLight, EnvironmentSource, SkyColours};

/// Parameters of the three-point preset (§8.2): key ~15° left of and ~30° above the
/// camera, fill ~15° right and lower at 1/10 of the key, rim from behind onto the top,
/// a little weaker than the key — as spot lights, or in the cinematic style as an area
/// key and a sky.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ThreePointParams {
    /// Key light intensity on its axis, W/sr.
    #[serde(default = "default_key")]
    pub key_intensity: f32,
    /// Fill intensity as a fraction of the key (§8.2: ~1/10).
    #[serde(default = "default_fill_ratio")]
    pub fill_ratio: f32,
    /// Rim intensity as a fraction of the key (§8.2: "a little weaker").
    #[serde(default = "default_rim_ratio")]
    pub rim_ratio: f32,
    /// Light distance from the volume centre as a multiple of the camera's distance.
    #[serde(default = "default_distance")]
    pub distance_scale: f32,
    /// `spots` (the thesis's key, fill and rim spot lights) or `cinematic` (the key as a
    /// soft area light, fill and rim as a sky). Not written when `spots`, so the content
    /// addresses of the thesis's scenes stay what they were.
    #[serde(default, skip_serializing_if = "LightingStyle::is_spots")]
    pub style: LightingStyle,
}

/// The light sources of the three-point layout.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum LightingStyle {
    /// Key, fill and rim spot lights (§8.2).
    #[default]
    Spots,
    /// What cinematic volume renderers light with: the key as a square area light at the
    /// key's place, facing the volume, subtending [`CINEMATIC_KEY_DEGREES`] and sending
    /// the key spot's intensity along its axis (`L·A = key_intensity`); the fill and rim
    /// replaced by a sky (the default gradient, its zenith the camera's up) whose fluence
    /// `4π·L̄` equals what the fill and rim spots send to the volume's centre,
    /// `(fill_ratio + rim_ratio)·key_intensity / d²`.
    Cinematic,
}

impl LightingStyle {
    fn is_spots(&self) -> bool {
        *self == LightingStyle::Spots
    }
}

/// The angle the cinematic key light's side subtends from the volume's centre, degrees.
pub const CINEMATIC_KEY_DEGREES: f32 = 20.0;

fn default_key() -> f32 {
    100.0
}
fn default_fill_ratio() -> f32 {
    0.1
}
fn default_rim_ratio() -> f32 {
    0.8
}
fn default_distance() -> f32 {
    1.0
}

impl Default for ThreePointParams {
    fn default() -> Self {
        ThreePointParams {
            key_intensity: default_key(),
            fill_ratio: default_fill_ratio(),
            rim_ratio: default_rim_ratio(),
            distance_scale: default_distance(),
            style: LightingStyle::Spots,
        }
    }
}

/// Builds key, fill and rim spot lights around `bounds` as seen from `camera`.
pub fn three_point(
    camera: &Camera,
    bounds: &Aabb,
    params: &ThreePointParams,
) -> Result<Vec<Light>> {
    crate::error::check_positive("key_intensity", params.key_intensity as f64)?;
    if params.key_intensity > MAX_INTENSITY {
        return Err(Error::parameter(
            "key_intensity",
            params.key_intensity,
            "at most 1e20 W/sr (more overflows 32-bit floats in the image)",
        ));
    }
    crate::error::check_range("fill_ratio", params.fill_ratio as f64, 0.0, 10.0)?;
    crate::error::check_range("rim_ratio", params.rim_ratio as f64, 0.0, 10.0)?;
    crate::error::check_range("distance_scale", params.distance_scale as f64, 0.1, 100.0)?;
    let centre = bounds.center();
    let to_camera = camera.eye() - centre;
    let distance = to_camera.length() * params.distance_scale;
    let back = to_camera.normalize();
    let up = camera.up();
    let right = camera.right();
    let radius = bounds.diagonal() * 0.5;
    // Direction from the centre at `yaw` (positive = camera's right) and `pitch` (up).
    let dir = |yaw_deg: f32, pitch_deg: f32| {
        let (yaw, pitch) = (yaw_deg.to_radians(), pitch_deg.to_radians());
        (back * yaw.cos() + right * yaw.sin()) * pitch.cos() + up * pitch.sin()
    };
    let spot = |position: Vec3, target: Vec3, intensity: f32| -> Result<Light> {
        // Cone wide enough to cover the whole volume from this distance.
        let half = (radius / (position - target).length()).atan().to_degrees() * 1.15;
        let cone = half.clamp(5.0, 89.0);
        SpotLight::new(position, target, Vec3::splat(intensity), cone, cone * 0.75).map(Light::Spot)
    };
    if params.style == LightingStyle::Cinematic {
        return cinematic(camera, bounds, params, centre + dir(-15.0, 30.0) * distance);
    }
    let key = spot(
        centre + dir(-15.0, 30.0) * distance,
        centre,
        params.key_intensity,
    )?;
    let mut lights = vec![key];
    if params.fill_ratio > 0.0 {
        lights.push(spot(
            centre + dir(15.0, -10.0) * distance,
            centre,
            params.key_intensity * params.fill_ratio,
        )?);
    }
    if params.rim_ratio > 0.0 {
        let top = centre + up * (bounds.extent().dot(up.abs()) * 0.3);
        lights.push(spot(
            centre + dir(180.0, 45.0) * distance,
            top,
            params.key_intensity * params.rim_ratio,
        )?);
    }
    Ok(lights)
}

/// The cinematic style's key area light at `key_position` and its sky
/// ([`LightingStyle::Cinematic`]).
fn cinematic(
    camera: &Camera,
    bounds: &Aabb,
    params: &ThreePointParams,
    key_position: Vec3,
) -> Result<Vec<Light>> {
    let centre = bounds.center();
    let d = (key_position - centre).length();
    let side = 2.0 * d * (CINEMATIC_KEY_DEGREES.to_radians() / 2.0).tan();
    let radiance = Vec3::splat(params.key_intensity / (side * side));
    let key = AreaLight::new(
        AreaShape::Rect,
        key_position,
        centre - key_position,
        Some(camera.up()),
        [side, side],
        radiance,
    )?;
    let colours = SkyColours {
        zenith: Vec3::from(DEFAULT_ZENITH),
        horizon: Vec3::from(DEFAULT_HORIZON),
        ground: Vec3::from(DEFAULT_GROUND),
    };
    let map = EnvironmentLight::sky_map(&colours)?;
    let mean_radiance = (map.integral().x + map.integral().y + map.integral().z) / (3.0 * 4.0 * PI);
    let fluence = (params.fill_ratio + params.rim_ratio) * params.key_intensity / (d * d);
    let mut lights = vec![Light::Area(key)];
    if fluence > 0.0 {
        let scale = Vec3::splat(fluence / (4.0 * PI * mean_radiance));
        let sky = EnvironmentLight::new(
            EnvironmentSource::Sky(colours),
            map,
            scale,
            camera.up(),
            0.0,
            None,
            bounds,
        )?;
        lights.push(Light::Environment(Arc::new(sky)));
    }
    Ok(lights)
}
