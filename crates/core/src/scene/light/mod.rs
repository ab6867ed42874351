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

mod build;
pub(crate) mod incident;
mod presets;
pub(crate) mod schema;
mod spot;

use std::f32::consts::PI;
use std::path::Path;
use std::sync::Arc;

use glam::Vec3;

pub use build::LightContext;
use build::{area_light, check_keys, environment_light, intensity_of, required_point};
pub use incident::Incident;
pub use presets::{CINEMATIC_KEY_DEGREES, LightingStyle, ThreePointParams, three_point};
pub use schema::{Intensity, LightKind, LightParams, SpotFalloff};
pub use spot::{PointLight, SpotLight};

use crate::error::{Error, Result};
use crate::math::{Aabb, Ray, Rng, Sphere, uniform_sphere};
use crate::scene::area::{AreaLight, AreaShape};
use crate::scene::environment::EnvironmentLight;

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

    /// The one position a delta light shines from (`None` for a light with extent or an
    /// environment, which have none).
    pub fn delta_position(&self) -> Option<Vec3> {
        self.is_delta().then(|| self.position())
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Domain;
    use crate::scene::Camera;

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
