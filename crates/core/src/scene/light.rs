//! Lights: point and spot lights, the thesis's three-point preset (§8.2), and the lights
//! cinematic volume renderers use — rectangle and disc area lights ([`super::area`]) and
//! an environment map or procedural sky ([`super::environment`]) — behind one enum.
//!
//! Conventions (as in common physically based renderers):
//! * point light: radiant intensity `I` (W/sr, RGB) in every direction; irradiance `I/r²`;
//! * spot light: `I·falloff(θ)/r²` with θ the angle to the axis; `falloff = 1` for
//!   `θ ≤ beam_width`, falling linearly in angle to 0 at `θ = cone_angle`.
//!   Its power is `Φ = 2π·I·(1 + (sin θw − sin θc)/(θc − θw))` (→ `2π·I·(1 − cos θc)` when
//!   `θw = θc`). With `falloff = "pbrt"` the band between the angles follows pbrt-v1's
//!   `SpotLight::Falloff` instead, `((cos θ − cos θc)/(cos θw − cos θc))⁴`, so scenes
//!   imported from the thesis's pbrt files light the volume as they did there; its power is
//!   `Φ = 2π·I·((1 − cos θw) + (cos θw − cos θc)/5)`.

use std::f32::consts::PI;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use glam::Vec3;
use serde::{Deserialize, Serialize};

use super::area::{AreaLight, AreaShape};
use super::camera::Camera;
use super::environment::{EnvironmentLight, EnvironmentSource, SkyColours, Sun};
use super::envmap::EnvironmentMap;
use crate::error::{Error, Result};
use crate::math::{Aabb, Frame, Ray, Rng, Sphere, uniform_sphere};

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
    fn keys(self) -> &'static [&'static str] {
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

/// A spot light.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SpotLight {
    position: Vec3,
    frame: Frame,
    intensity: Vec3,
    cone_angle: f32,
    beam_width: f32,
    cos_cone: f32,
    cos_beam: f32,
    /// A cosine above which `acos` surely gives an angle inside the beam: the linear
    /// falloff skips its `acos` there.
    cos_surely_in_beam: f32,
    shape: SpotFalloff,
}

/// A point light.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PointLight {
    position: Vec3,
    intensity: Vec3,
}

/// A light source: every integrator asks each light the same questions (is it a delta
/// light, what arrives at a point — sampled for lights with extent —, with which pdf, its
/// power, an emitted photon).
#[derive(Debug, Clone, PartialEq)]
pub enum Light {
    /// Spot light.
    Spot(SpotLight),
    /// Point light.
    Point(PointLight),
    /// Rectangle or disc area light.
    Area(AreaLight),
    /// Environment map or procedural sky (shared: a map can be large).
    Environment(Arc<EnvironmentLight>),
}

/// What building a light may need from its scene.
#[derive(Debug, Clone, Copy)]
pub struct LightContext<'a> {
    /// The volume's bounds (an environment's photons start on its bounding sphere).
    pub bounds: &'a Aabb,
    /// The scene file's folder (relative `file` paths).
    pub base: &'a Path,
}

/// Light arriving at a point from one light, before any attenuation by the medium.
#[derive(Debug, Clone, Copy)]
pub struct Incident {
    /// Unit direction from the point towards the light.
    pub to_light: Vec3,
    /// Distance to the light.
    pub distance: f32,
    /// Irradiance-like term `I·falloff/r²` for a delta light (W/m² per unit solid angle
    /// of the phase function); for a sampled light the radiance divided by the solid-angle
    /// pdf — either way `σs·p·radiance·T` estimates single scattering.
    pub radiance: Vec3,
    /// The solid-angle pdf of the sampled direction (`∞` for a delta light).
    pub pdf: f32,
}

/// The narrowest spot light `cone_angle`, degrees: its solid angle `2π(1 − cos θ)` is
/// computed in 32-bit floats, whose cosines near 1 are `6·10⁻⁸` apart — 0.16 % of `1 − cos`
/// at 0.5°, all of it below 0.02° (the photons of such a spot carried no power).
pub const MIN_SPOT_CONE_DEG: f32 = 0.5;

/// The largest radiant intensity a light may have (W/sr). Its power is summed over
/// photons, multiplied by the phase function and σs and summed again over a pixel's
/// samples in 32-bit floats: from about 10³⁴ on that overflows to infinity (a
/// `key_intensity` of 3·10³⁸ gave an image of infinities). The thesis's key is 40–100.
pub const MAX_INTENSITY: f32 = 1e20;

fn validate_intensity(i: Vec3) -> Result<()> {
    if i.is_finite()
        && i.min_element() >= 0.0
        && i.max_element() > 0.0
        && i.max_element() <= MAX_INTENSITY
    {
        Ok(())
    } else {
        Err(Error::parameter(
            "intensity",
            format!("{:?}", i.to_array()),
            "finite values >= 0, not all 0, at most 1e20 (W/sr)",
        ))
    }
}

impl Light {
    /// Builds a light that needs nothing from its scene (spot, point, area lights); the
    /// environments are built by [`Self::create_in`]. Errors name the key.
    pub fn create(params: &LightParams) -> Result<Self> {
        if params.kind.needs_scene() {
            return Err(Error::parameter(
                "type",
                format!("{:?}", params.kind),
                "a light built with its scene (Light::create_in)",
            ));
        }
        Self::create_in(
            params,
            LightContext {
                bounds: &Aabb::unit(),
                base: Path::new("."),
            },
        )
    }

    /// Builds any light in its scene's context; errors name the key.
    pub fn create_in(params: &LightParams, context: LightContext<'_>) -> Result<Self> {
        check_keys(params)?;
        match params.kind {
            LightKind::Point => Ok(Light::Point(PointLight {
                position: required_point(params.position, "position")?,
                intensity: intensity_of(params)?,
            })),
            LightKind::Spot => {
                let position = required_point(params.position, "position")?;
                let intensity = intensity_of(params)?;
                let target = params.target.ok_or_else(|| {
                    Error::parameter("target", "(missing)", "the point the spot light aims at")
                })?;
                let cone = params.cone_angle.unwrap_or(30.0);
                let beam = params.beam_width.unwrap_or(cone * 0.8);
                let shape = params.falloff.unwrap_or_default();
                SpotLight::new(position, Vec3::from(target), intensity, cone, beam)
                    .map(|s| Light::Spot(s.with_falloff(shape)))
            }
            LightKind::Rect | LightKind::Disc => area_light(params).map(Light::Area),
            LightKind::Environment | LightKind::Sky => {
                environment_light(params, context).map(|e| Light::Environment(Arc::new(e)))
            }
        }
    }

    /// The parameters that build this light again (a spot's target one unit along its
    /// axis; angles in degrees; an environment as it was written).
    pub fn params(&self) -> LightParams {
        match self {
            Light::Point(p) => LightParams {
                kind: LightKind::Point,
                position: Some(p.position.to_array()),
                intensity: Some(Intensity::Rgb(p.intensity.to_array())),
                ..LightParams::default()
            },
            Light::Spot(s) => LightParams {
                kind: LightKind::Spot,
                position: Some(s.position.to_array()),
                target: Some((s.position + s.frame.w).to_array()),
                intensity: Some(Intensity::Rgb(s.intensity.to_array())),
                cone_angle: Some(s.cone_angle.to_degrees()),
                beam_width: Some(s.beam_width.to_degrees()),
                falloff: (s.shape != SpotFalloff::Linear).then_some(s.shape),
                ..LightParams::default()
            },
            Light::Area(a) => LightParams {
                kind: match a.shape() {
                    AreaShape::Rect => LightKind::Rect,
                    AreaShape::Disc => LightKind::Disc,
                },
                position: Some(a.centre().to_array()),
                normal: Some(a.normal().to_array()),
                up: (a.shape() == AreaShape::Rect).then(|| a.height_axis().to_array()),
                size: (a.shape() == AreaShape::Rect).then(|| a.extent()),
                radius: (a.shape() == AreaShape::Disc).then(|| a.extent()[0]),
                radiance: Some(Intensity::Rgb(a.radiance().to_array())),
                ..LightParams::default()
            },
            Light::Environment(e) => e.params(),
        }
    }

    /// Whether the light is a delta light (a point or spot: one direction per point, no
    /// sampling, no pdf).
    pub fn is_delta(&self) -> bool {
        matches!(self, Light::Spot(_) | Light::Point(_))
    }

    /// Position of the light (a delta light's; an area light's centre; an environment's
    /// bounding-sphere centre).
    pub fn position(&self) -> Vec3 {
        match self {
            Light::Spot(s) => s.position,
            Light::Point(p) => p.position,
            Light::Area(a) => a.centre(),
            Light::Environment(e) => e.centre(),
        }
    }

    /// Total emitted power Φ (W, RGB); an environment's is the power entering the volume's
    /// bounding sphere.
    pub fn power(&self) -> Vec3 {
        match self {
            Light::Point(p) => 4.0 * PI * p.intensity,
            Light::Spot(s) => s.intensity * s.solid_angle_weight(),
            Light::Area(a) => a.power(),
            Light::Environment(e) => e.power(),
        }
    }

    /// Light arriving at `p` from a delta light (unattenuated), or `None` outside a spot's
    /// cone — and for lights with extent, which are sampled ([`Self::sample_incident`]).
    #[inline]
    pub fn incident(&self, p: Vec3) -> Option<Incident> {
        let (position, intensity) = match self {
            Light::Spot(s) => (s.position, s.intensity),
            Light::Point(l) => (l.position, l.intensity),
            Light::Area(_) | Light::Environment(_) => return None,
        };
        let d = position - p;
        let dist2 = d.length_squared();
        if dist2 <= 0.0 {
            return None;
        }
        let distance = dist2.sqrt();
        let to_light = d / distance;
        let falloff = match self {
            Light::Spot(s) => s.falloff(-to_light),
            _ => 1.0,
        };
        if falloff <= 0.0 {
            return None;
        }
        Some(Incident {
            to_light,
            distance,
            radiance: intensity * (falloff / dist2),
            pdf: f32::INFINITY,
        })
    }

    /// Light arriving at `p`: a delta light's exactly (drawing nothing from `rng`, so a
    /// scene of spot lights renders as before), a light with extent's from one sampled
    /// direction (radiance over pdf).
    #[inline]
    pub fn sample_incident(&self, p: Vec3, rng: &mut Rng) -> Option<Incident> {
        match self {
            Light::Spot(_) | Light::Point(_) => self.incident(p),
            Light::Area(a) => a.sample_incident(p, rng.uniform2()),
            Light::Environment(e) => e.sample_incident(rng.uniform2()),
        }
    }

    /// The solid-angle pdf with which [`Self::sample_incident`] at `p` returns direction
    /// `w`, the radiance arriving along it and the distance to the light (`None` for a
    /// delta light, or where `w` misses the light): what multiple importance sampling
    /// asks of a direction the phase function chose.
    pub fn pdf_and_radiance(&self, p: Vec3, w: Vec3) -> Option<(f32, Vec3, f32)> {
        match self {
            Light::Spot(_) | Light::Point(_) => None,
            Light::Area(a) => a.pdf(p, w).map(|(pdf, t)| (pdf, a.radiance(), t)),
            Light::Environment(e) => {
                let pdf = e.pdf(w);
                (pdf > 0.0).then(|| (pdf, e.eval(w), f32::INFINITY))
            }
        }
    }

    /// An emitted photon's ray and its power relative to [`Self::emitted_power`]`/N` (per
    /// channel): equal powers for delta lights (§7.1.2); an area light's photons aimed at
    /// `target` carry their `cos θ` and cone, an environment's `L/p`.
    pub fn emit(&self, rng: &mut Rng, target: &Sphere) -> (Ray, Vec3) {
        match self {
            Light::Spot(_) | Light::Point(_) => (
                Ray::new(self.position(), self.sample_direction(rng)),
                Vec3::ONE,
            ),
            Light::Area(a) => {
                let (ray, relative) = a.emit_towards(rng, target);
                (ray, Vec3::splat(relative))
            }
            Light::Environment(e) => e.emit(rng, target),
        }
    }

    /// The power [`Self::emit`]'s photons carry in all when aimed at `target` (W, RGB):
    /// a delta light's whole power (its photons are not aimed, so spot-lit maps stay what
    /// they were); what an area light sends towards the sphere (a normaliser, see
    /// [`AreaLight::power_towards`]); what an environment sends into it. Photons are split
    /// over lights in proportion to it, so they carry about equal powers where they can
    /// reach the medium.
    pub fn emitted_power(&self, target: &Sphere) -> Vec3 {
        match self {
            Light::Point(_) | Light::Spot(_) => self.power(),
            Light::Area(a) => a.power_towards(target),
            Light::Environment(e) => e.power_into(target),
        }
    }

    /// Samples a delta light's photon direction with a pdf proportional to the emitted
    /// intensity (so all photons of a light carry equal power, §5.1/§7.1.2).
    pub fn sample_direction(&self, rng: &mut Rng) -> Vec3 {
        match self {
            Light::Spot(s) => s.sample_direction(rng),
            _ => uniform_sphere(rng.uniform2()),
        }
    }
}

/// A key given to a light whose type has no use for it is an error naming it.
fn check_keys(params: &LightParams) -> Result<()> {
    let given = [
        ("position", params.position.is_some()),
        ("target", params.target.is_some()),
        ("intensity", params.intensity.is_some()),
        ("cone_angle", params.cone_angle.is_some()),
        ("beam_width", params.beam_width.is_some()),
        ("falloff", params.falloff.is_some()),
        ("normal", params.normal.is_some()),
        ("size", params.size.is_some()),
        ("radius", params.radius.is_some()),
        ("radiance", params.radiance.is_some()),
        ("up", params.up.is_some()),
        ("file", params.file.is_some()),
        ("scale", params.scale.is_some()),
        ("rotation", params.rotation.is_some()),
        ("zenith", params.zenith.is_some()),
        ("horizon", params.horizon.is_some()),
        ("ground", params.ground.is_some()),
        ("sun_direction", params.sun_direction.is_some()),
        ("sun_radiance", params.sun_radiance.is_some()),
        ("sun_angle", params.sun_angle.is_some()),
    ];
    let allowed = params.kind.keys();
    for (key, present) in given {
        if present && !allowed.contains(&key) {
            return Err(Error::given_without_use(
                key,
                format!(
                    "no such key for a {} light (it takes {})",
                    kind_name(params.kind),
                    allowed.join(", ")
                ),
            ));
        }
    }
    Ok(())
}

fn kind_name(kind: LightKind) -> &'static str {
    match kind {
        LightKind::Point => "point",
        LightKind::Spot => "spot",
        LightKind::Rect => "rect",
        LightKind::Disc => "disc",
        LightKind::Environment => "environment",
        LightKind::Sky => "sky",
    }
}

fn required_point(p: Option<[f32; 3]>, key: &str) -> Result<Vec3> {
    let p = p.ok_or_else(|| Error::parameter(key, "(missing)", "three finite numbers"))?;
    let v = Vec3::from(p);
    if v.is_finite() {
        Ok(v)
    } else {
        Err(Error::parameter(
            key,
            format!("{p:?}"),
            "three finite numbers",
        ))
    }
}

fn intensity_of(params: &LightParams) -> Result<Vec3> {
    let i = params
        .intensity
        .ok_or_else(|| Error::parameter("intensity", "(missing)", "W/sr: one number or RGB"))?
        .rgb();
    validate_intensity(i)?;
    Ok(i)
}

/// A rectangle or disc from `position`, `normal` or `target`, `size` or `radius`,
/// `radiance` and (rectangle) `up`.
fn area_light(params: &LightParams) -> Result<AreaLight> {
    let centre = required_point(params.position, "position")?;
    let normal = match (params.normal, params.target) {
        (Some(n), None) => Vec3::from(n),
        (None, Some(t)) => Vec3::from(t) - centre,
        (Some(_), Some(_)) => {
            return Err(Error::parameter(
                "target",
                "(given with normal)",
                "either `normal` or `target`, not both",
            ));
        }
        (None, None) => {
            return Err(Error::parameter(
                "normal",
                "(missing)",
                "the emitting side's normal, or a `target` it faces",
            ));
        }
    };
    let (shape, extent) = match params.kind {
        LightKind::Rect => (
            AreaShape::Rect,
            params.size.ok_or_else(|| {
                Error::parameter("size", "(missing)", "[width, height] in world units")
            })?,
        ),
        _ => {
            let r = params
                .radius
                .ok_or_else(|| Error::parameter("radius", "(missing)", "a length > 0"))?;
            (AreaShape::Disc, [r, r])
        }
    };
    let radiance = params
        .radiance
        .ok_or_else(|| Error::parameter("radiance", "(missing)", "W/m²/sr: one number or RGB"))?
        .rgb();
    AreaLight::new(
        shape,
        centre,
        normal,
        params.up.map(Vec3::from),
        extent,
        radiance,
    )
}

/// An environment map or a sky, oriented and scaled, around the scene's bounds.
fn environment_light(params: &LightParams, context: LightContext<'_>) -> Result<EnvironmentLight> {
    let (source, map) = if params.kind == LightKind::Environment {
        let file = params.file.as_ref().ok_or_else(|| {
            Error::parameter("file", "(missing)", "an HDR map: .exr, .pfm or .hdr")
        })?;
        // The map's own error (missing, not HDR, a bad texel, a link out of the scene's
        // folder) under the key that named it, so the scene file's line is reported too.
        let map = crate::util::confined(context.base, file, "the scene's folder")
            .and_then(|path| EnvironmentMap::load(&path))
            .map_err(|e| Error::parameter("file", file.display(), e.to_string()))?;
        (EnvironmentSource::File(file.clone()), map)
    } else {
        let colour = |v: Option<Intensity>, key: &str, default: [f32; 3]| -> Result<Vec3> {
            let c = v.map_or(Vec3::from(default), |i| i.rgb());
            if c.is_finite() && c.min_element() >= 0.0 && c.max_element() <= MAX_INTENSITY {
                Ok(c)
            } else {
                Err(Error::parameter(
                    key,
                    format!("{:?}", c.to_array()),
                    "finite radiances >= 0 (W/m²/sr)",
                ))
            }
        };
        let colours = SkyColours {
            zenith: colour(params.zenith, "zenith", DEFAULT_ZENITH)?,
            horizon: colour(params.horizon, "horizon", DEFAULT_HORIZON)?,
            ground: colour(params.ground, "ground", DEFAULT_GROUND)?,
        };
        let map = EnvironmentLight::sky_map(&colours)?;
        (EnvironmentSource::Sky(colours), map)
    };
    let sun = match (params.sun_direction, params.sun_radiance) {
        (Some(d), Some(r)) => Some(Sun::new(
            Vec3::from(d),
            r.rgb(),
            params.sun_angle.unwrap_or(DEFAULT_SUN_ANGLE),
        )?),
        (None, None) if params.sun_angle.is_none() => None,
        _ => {
            return Err(Error::parameter(
                "sun_direction",
                "(sun incomplete)",
                "both `sun_direction` and `sun_radiance` for a sun (`sun_angle` optional)",
            ));
        }
    };
    let scale = params.scale.map_or(Vec3::ONE, |s| s.rgb());
    let up = params.up.map_or(Vec3::Z, Vec3::from);
    EnvironmentLight::new(
        source,
        map,
        scale,
        up,
        params.rotation.unwrap_or(0.0),
        sun,
        context.bounds,
    )
}

/// A clear day's sky by default: blue above, a bright horizon, a dim ground (W/m²/sr).
const DEFAULT_ZENITH: [f32; 3] = [0.25, 0.4, 0.9];
const DEFAULT_HORIZON: [f32; 3] = [0.9, 0.9, 0.9];
const DEFAULT_GROUND: [f32; 3] = [0.15, 0.13, 0.1];
/// The real sun's angular diameter, degrees.
const DEFAULT_SUN_ANGLE: f32 = 0.53;

/// The smallest `f32` cosine whose `acos` is within `angle`, four ulps up (so that `acos`
/// rounding differently one ulp apart cannot matter): every cosine at or above it is
/// inside. Near 1 a cosine resolves angles only to ~3·10⁻⁴ rad, so the search is in
/// ulps of the cosine, not in the angle.
fn cos_surely_within(angle: f32) -> f32 {
    let mut c = angle.cos();
    while c < 1.0 && c.acos() > angle {
        c = c.next_up();
    }
    while c > -1.0 && c.next_down().acos() <= angle {
        c = c.next_down();
    }
    (0..4).fold(c, |c, _| c.next_up())
}

impl SpotLight {
    /// A spot light at `position` aiming at `target`.
    pub fn new(
        position: Vec3,
        target: Vec3,
        intensity: Vec3,
        cone_angle_deg: f32,
        beam_width_deg: f32,
    ) -> Result<Self> {
        validate_intensity(intensity)?;
        let axis = target - position;
        if !target.is_finite() || axis.length() < 1e-6 {
            return Err(Error::parameter(
                "target",
                format!("{:?}", target.to_array()),
                "a finite point different from `position`",
            ));
        }
        if !(MIN_SPOT_CONE_DEG..180.0).contains(&cone_angle_deg) {
            return Err(Error::parameter(
                "cone_angle",
                cone_angle_deg,
                format!(
                    "an angle in [{MIN_SPOT_CONE_DEG}, 180) degrees: in a narrower cone 32-bit cosines hold its solid angle, and so the power its photons carry, to worse than 0.2 % (at 0.01° to nothing)"
                ),
            ));
        }
        if !(beam_width_deg.is_finite() && beam_width_deg > 0.0 && beam_width_deg <= cone_angle_deg)
        {
            return Err(Error::parameter(
                "beam_width",
                beam_width_deg,
                format!("an angle in (0, cone_angle = {cone_angle_deg}] degrees"),
            ));
        }
        let cone = cone_angle_deg.to_radians();
        Ok(SpotLight {
            position,
            frame: Frame::from_w(axis.normalize()),
            intensity,
            cone_angle: cone,
            beam_width: beam_width_deg.to_radians(),
            cos_cone: cone.cos(),
            cos_beam: beam_width_deg.to_radians().cos(),
            cos_surely_in_beam: cos_surely_within(beam_width_deg.to_radians()),
            shape: SpotFalloff::Linear,
        })
    }

    /// The same light with another falloff shape.
    pub fn with_falloff(self, shape: SpotFalloff) -> Self {
        SpotLight { shape, ..self }
    }

    /// The falloff shape.
    pub fn falloff_shape(&self) -> SpotFalloff {
        self.shape
    }

    /// Falloff for a unit direction leaving the light.
    #[inline]
    pub fn falloff(&self, w: Vec3) -> f32 {
        let c = w.dot(self.frame.w);
        if c < self.cos_cone {
            return 0.0;
        }
        if self.shape == SpotFalloff::Pbrt {
            // pbrt-v1 lights/spot.cpp: 1 inside the beam, then δ⁴ with δ linear in cos θ.
            if c > self.cos_beam {
                return 1.0;
            }
            let delta = (c - self.cos_cone) / (self.cos_beam - self.cos_cone);
            return (delta * delta) * (delta * delta);
        }
        if c >= self.cos_surely_in_beam {
            return 1.0;
        }
        self.linear_falloff_by_angle(c)
    }

    /// The linear falloff inside the cone as the angle defines it: 1 within the beam, then
    /// linear in the angle down to 0 at the cone's edge.
    #[inline]
    fn linear_falloff_by_angle(&self, c: f32) -> f32 {
        let theta = c.clamp(-1.0, 1.0).acos();
        if theta <= self.beam_width {
            1.0
        } else {
            ((self.cone_angle - theta) / (self.cone_angle - self.beam_width)).clamp(0.0, 1.0)
        }
    }

    /// `∫ falloff dω` (sr).
    pub fn solid_angle_weight(&self) -> f32 {
        let (tw, tc) = (self.beam_width, self.cone_angle);
        if self.shape == SpotFalloff::Pbrt {
            // ∫ δ⁴ d(cos θ) over the band = (cos θw − cos θc)/5.
            return 2.0 * PI * ((1.0 - self.cos_beam) + (self.cos_beam - self.cos_cone) / 5.0);
        }
        if tc - tw < 1e-6 {
            return 2.0 * PI * (1.0 - tc.cos());
        }
        2.0 * PI * (1.0 + (tw.sin() - tc.sin()) / (tc - tw))
    }

    fn sample_direction(&self, rng: &mut Rng) -> Vec3 {
        // Uniform in the cone's solid angle, accepted with probability falloff: exact for the
        // falloff-weighted distribution.
        loop {
            let u = rng.uniform2();
            let cos_t = 1.0 - u[0] * (1.0 - self.cos_cone);
            let sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
            let phi = 2.0 * PI * u[1];
            let w = self
                .frame
                .to_world(Vec3::new(sin_t * phi.cos(), sin_t * phi.sin(), cos_t));
            let f = self.falloff(w);
            if f >= 1.0 || rng.uniform() < f {
                return w;
            }
        }
    }
}

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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Domain;

    fn spot(cone: f32, beam: f32) -> SpotLight {
        SpotLight::new(Vec3::ZERO, Vec3::Z, Vec3::ONE, cone, beam).unwrap()
    }

    #[test]
    fn spot_power_matches_numerical_integral() {
        let shapes = [SpotFalloff::Linear, SpotFalloff::Pbrt];
        for ((cone, beam), shape) in [(30.0, 20.0), (45.0, 45.0), (60.0, 5.0)]
            .into_iter()
            .flat_map(|a| shapes.map(|s| (a, s)))
        {
            let s = spot(cone, beam).with_falloff(shape);
            let n = 200_000;
            let integral: f32 = (0..n)
                .map(|i| {
                    let theta = (i as f32 + 0.5) / n as f32 * PI;
                    let w = Vec3::new(theta.sin(), 0.0, theta.cos());
                    s.falloff(w) * theta.sin() * PI / n as f32
                })
                .sum::<f32>()
                * 2.0
                * PI;
            assert!(
                (integral - s.solid_angle_weight()).abs() < 1e-3,
                "{cone}/{beam} {shape:?}"
            );
        }
    }

    #[test]
    fn falloff_convention() {
        let s = spot(30.0, 20.0);
        let at = |deg: f32| {
            s.falloff(Vec3::new(
                deg.to_radians().sin(),
                0.0,
                deg.to_radians().cos(),
            ))
        };
        assert_eq!(at(0.0), 1.0);
        assert_eq!(at(19.9), 1.0);
        assert!((at(25.0) - 0.5).abs() < 1e-3);
        assert_eq!(at(31.0), 0.0);
    }

    #[test]
    fn the_beam_test_without_acos_agrees_with_the_angle() {
        // The falloff as the angle defines it, acos everywhere inside the cone.
        let by_angle = |s: &SpotLight, w: Vec3| {
            let c = w.dot(s.frame.w);
            if c < s.cos_cone {
                0.0
            } else {
                s.linear_falloff_by_angle(c)
            }
        };
        let mut inside = 0;
        for (cone, beam) in [
            (30.0, 20.0),
            (45.0, 45.0),
            (60.0, 5.0),
            (10.0, 0.01),
            (1.0, 0.5),
        ] {
            let s = spot(cone, beam);
            // A dense sweep across the beam's edge, and a coarse one across the cone.
            let near = (0..=20_000).map(|i| beam - 0.05 + 0.1 * i as f32 / 20_000.0);
            let all = (0..=2_000).map(|i| cone * 1.1 * i as f32 / 2_000.0);
            for deg in near.chain(all).filter(|d| *d >= 0.0) {
                let t = deg.to_radians();
                let w = Vec3::new(t.sin(), 0.0, t.cos());
                assert_eq!(s.falloff(w), by_angle(&s, w), "{cone}/{beam} at {deg}°");
                inside += usize::from(w.z >= s.cos_surely_in_beam);
            }
        }
        assert!(inside > 10_000, "the fast path was taken {inside} times");
    }

    #[test]
    fn pbrt_falloff_is_quartic_in_cosine() {
        // pbrt-v1 defaults: coneangle 30, conedeltaangle 5 → falloff starts at 25°.
        let s = spot(30.0, 25.0).with_falloff(SpotFalloff::Pbrt);
        let at = |deg: f32| {
            let t = deg.to_radians();
            s.falloff(Vec3::new(t.sin(), 0.0, t.cos()))
        };
        assert_eq!(at(24.9), 1.0);
        assert_eq!(at(30.1), 0.0);
        let (ct, cs) = (30f32.to_radians().cos(), 25f32.to_radians().cos());
        let delta = (27.5f32.to_radians().cos() - ct) / (cs - ct);
        assert!((at(27.5) - delta.powi(4)).abs() < 1e-5);
        assert!(
            at(27.5) < 0.1,
            "quartic: far below the linear 0.5 at mid-band"
        );
    }

    #[test]
    fn sampled_directions_follow_falloff() {
        let s = spot(30.0, 10.0);
        let light = Light::Spot(s);
        let mut rng = Rng::stream(1, Domain::Misc, 7);
        // Fraction inside the beam = ∫_beam dω / ∫ falloff dω.
        let n = 100_000;
        let inside = (0..n)
            .filter(|_| light.sample_direction(&mut rng).z >= 10f32.to_radians().cos())
            .count();
        let expected = 2.0 * PI * (1.0 - 10f32.to_radians().cos()) / s.solid_angle_weight();
        assert!((inside as f32 / n as f32 - expected).abs() < 0.01);
    }

    #[test]
    fn inverse_square_and_cone() {
        let l = Light::create(&LightParams {
            kind: LightKind::Point,
            position: Some([0.0, 0.0, 2.0]),
            intensity: Some(Intensity::Grey(8.0)),
            ..LightParams::default()
        })
        .unwrap();
        let inc = l.incident(Vec3::ZERO).unwrap();
        assert!((inc.radiance - Vec3::splat(2.0)).length() < 1e-6);
        assert!((l.power().x - 32.0 * PI).abs() < 1e-4);
        let s = Light::Spot(spot(30.0, 20.0));
        let on_axis = s.incident(Vec3::new(0.0, 0.0, 2.0)).unwrap();
        assert!((on_axis.radiance.x - 0.25).abs() < 1e-6 && on_axis.to_light.z < 0.0);
        assert!(
            s.incident(Vec3::new(1.0, 0.0, 0.1)).is_none(),
            "outside the cone"
        );
        assert!(
            s.incident(Vec3::new(0.0, 0.0, -1.0)).is_none(),
            "behind the spot"
        );
    }

    #[test]
    fn three_point_layout() {
        let cam = Camera::create(&super::super::CameraParams::default()).unwrap();
        let lights = three_point(&cam, &Aabb::unit(), &ThreePointParams::default()).unwrap();
        assert_eq!(lights.len(), 3);
        let c = Vec3::splat(0.5);
        let key = lights[0].position() - c;
        let fill = lights[1].position() - c;
        let rim = lights[2].position() - c;
        assert!(key.dot(cam.right()) < 0.0, "key is left of the camera");
        assert!(key.dot(cam.up()) > 0.0, "key is above");
        assert!(fill.dot(cam.right()) > 0.0 && fill.dot(cam.up()) < key.dot(cam.up()));
        assert!(rim.dot(cam.forward()) > 0.0, "rim is behind the volume");
        assert!((lights[1].power().x / lights[0].power().x - 0.1).abs() < 1e-4);
    }

    /// The cinematic style: the key as a square facing the centre from the key spot's
    /// place with the key spot's on-axis intensity, and a sky whose fluence at the centre
    /// is what the fill and rim spots send there.
    #[test]
    fn cinematic_layout_keeps_the_key_and_the_fill_and_rim_fluence() {
        let cam = Camera::create(&super::super::CameraParams::default()).unwrap();
        let spots = three_point(&cam, &Aabb::unit(), &ThreePointParams::default()).unwrap();
        let params = ThreePointParams {
            style: LightingStyle::Cinematic,
            ..ThreePointParams::default()
        };
        let lights = three_point(&cam, &Aabb::unit(), &params).unwrap();
        let [Light::Area(key), Light::Environment(sky)] = lights.as_slice() else {
            panic!("{lights:?}")
        };
        let c = Vec3::splat(0.5);
        assert!((key.centre() - spots[0].position()).length() < 1e-5);
        assert!(key.normal().dot((c - key.centre()).normalize()) > 0.9999);
        let intensity = key.radiance().x * key.area();
        assert!((intensity / params.key_intensity - 1.0).abs() < 1e-5);
        let d = (key.centre() - c).length();
        let power = sky.power();
        let fluence =
            (power.x + power.y + power.z) / 3.0 / (PI * sky_radius(&Aabb::unit()).powi(2));
        let expected = (params.fill_ratio + params.rim_ratio) * params.key_intensity / (d * d);
        assert!(
            (fluence / expected - 1.0).abs() < 0.02,
            "{fluence} vs {expected}"
        );
        assert_eq!(sky.up(), cam.up());
        // The spot style is the default and is not written.
        let toml = toml::to_string(&ThreePointParams::default()).unwrap();
        assert!(!toml.contains("style"), "{toml}");
    }

    fn sky_radius(bounds: &Aabb) -> f32 {
        bounds.diagonal() * 0.5
    }
}
