//! The environment light: radiance arriving from infinitely far away in every direction,
//! from an equirectangular HDR map ([`EnvironmentMap`], `type = "environment"`) or from a
//! procedural sky (`type = "sky"`: zenith, horizon and ground colours baked into a map,
//! plus an optional sun disc).
//!
//! * Orientation: the map's local frame is Mitsuba's (`+y` up; `u = 0` looks along `−z`).
//!   `up` (default the world's `+z`) is the map's `+y`; `rotation` turns the map about it.
//! * Sampling: the map by its piecewise-constant 2-D distribution, the sun uniformly in its
//!   cone, the two chosen in proportion to their power; a sampled direction's pdf is the
//!   mixture's, so estimates stay unbiased wherever the two overlap.
//! * Photons (§5.1 generalised to a light at infinity): a direction `ω` from the
//!   distribution, then an origin uniform on the disc of radius `R` facing `ω` of the
//!   sphere around what can scatter (the medium's occupied, kept part), outside the
//!   sphere; the photon travels along `−ω` with power `L(ω)/p(ω)·πR²/N`, whose mean is the
//!   power crossing the disc, `Φ = πR²·∫L dω`.
//! * Camera rays do not see the environment (a black background, as the thesis's images
//!   and Mitsuba's `hide_emitters`): it lights the volume only.

use std::f32::consts::PI;
use std::path::PathBuf;

use glam::Vec3;

use super::envmap::EnvironmentMap;
use super::light::{Incident, Intensity, LightKind, LightParams};
use crate::error::{Error, Result};
use crate::math::{Aabb, Frame, Ray, Rng, Sphere, concentric_disc, uniform_cone};

/// The width of the equirectangular map a procedural sky is baked into (height half).
pub const SKY_MAP_WIDTH: usize = 256;

/// Where an environment's radiance comes from.
#[derive(Debug, Clone, PartialEq)]
pub enum EnvironmentSource {
    /// An HDR file (EXR, PFM or Radiance `.hdr`), as resolved.
    File(PathBuf),
    /// A procedural sky.
    Sky(SkyColours),
}

/// A procedural sky's colours (radiance, W/m²/sr): linear in `sin(elevation)` from the
/// horizon to the zenith above, and from the horizon to the ground below.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SkyColours {
    /// Radiance straight up.
    pub zenith: Vec3,
    /// Radiance at the horizon.
    pub horizon: Vec3,
    /// Radiance straight down.
    pub ground: Vec3,
}

/// A sun: a disc of constant radiance around a direction.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sun {
    /// Unit direction towards the sun (world).
    pub direction: Vec3,
    /// Radiance of the disc.
    pub radiance: Vec3,
    /// Half the angular diameter, radians.
    pub half_angle: f32,
    cos_half_angle: f32,
}

impl Sun {
    /// A sun towards `direction` with `radiance` and angular diameter `diameter_deg`.
    pub fn new(direction: Vec3, radiance: Vec3, diameter_deg: f32) -> Result<Self> {
        let d = direction.normalize_or_zero();
        if !direction.is_finite() || d == Vec3::ZERO {
            return Err(Error::parameter(
                "sun_direction",
                format!("{:?}", direction.to_array()),
                "a finite non-zero direction towards the sun",
            ));
        }
        if !(diameter_deg.is_finite() && diameter_deg > 0.0 && diameter_deg <= 90.0) {
            return Err(Error::parameter(
                "sun_angle",
                diameter_deg,
                "an angular diameter in (0, 90] degrees (the real sun: 0.53)",
            ));
        }
        super::area::check_radiance(radiance).map_err(|_| {
            Error::parameter(
                "sun_radiance",
                format!("{:?}", radiance.to_array()),
                "finite values >= 0, not all 0, at most 1e20 (W/m²/sr)",
            )
        })?;
        let half_angle = (diameter_deg / 2.0).to_radians();
        Ok(Sun {
            direction: d,
            radiance,
            half_angle,
            cos_half_angle: half_angle.cos(),
        })
    }

    fn solid_angle(&self) -> f32 {
        2.0 * PI * (1.0 - self.cos_half_angle)
    }

    fn contains(&self, w: Vec3) -> bool {
        w.dot(self.direction) >= self.cos_half_angle
    }
}

/// An environment light around a volume.
#[derive(Debug, Clone, PartialEq)]
pub struct EnvironmentLight {
    source: EnvironmentSource,
    map: EnvironmentMap,
    /// Multiplies the map (not the sun).
    scale: Vec3,
    /// Columns: the map's local x, y (up), z in world coordinates.
    right: Vec3,
    up: Vec3,
    back: Vec3,
    rotation_deg: f32,
    sun: Option<Sun>,
    /// Probability of sampling the sun rather than the map.
    sun_probability: f32,
    /// The volume's bounding sphere (photons start on its tangent discs).
    centre: Vec3,
    radius: f32,
}

impl EnvironmentLight {
    /// An environment from `map` (with its `source` for the parameters), oriented by `up`
    /// and `rotation_deg`, scaled by `scale`, with an optional sun, around `bounds`.
    pub fn new(
        source: EnvironmentSource,
        map: EnvironmentMap,
        scale: Vec3,
        up: Vec3,
        rotation_deg: f32,
        sun: Option<Sun>,
        bounds: &Aabb,
    ) -> Result<Self> {
        if !(scale.is_finite() && scale.min_element() >= 0.0 && scale.max_element() > 0.0) {
            return Err(Error::parameter(
                "scale",
                format!("{:?}", scale.to_array()),
                "finite values >= 0, not all 0",
            ));
        }
        let u = up.normalize_or_zero();
        if !up.is_finite() || u == Vec3::ZERO {
            return Err(Error::parameter(
                "up",
                format!("{:?}", up.to_array()),
                "a finite non-zero direction",
            ));
        }
        if !(rotation_deg.is_finite() && rotation_deg.abs() <= 360.0) {
            return Err(Error::parameter(
                "rotation",
                rotation_deg,
                "an angle in [-360, 360] degrees",
            ));
        }
        // The map's forward (u = 0) is a fixed horizontal direction turned by `rotation`.
        let base = Frame::from_w(u);
        let r = rotation_deg.to_radians();
        let forward = base.u * r.cos() + base.v * r.sin();
        let back = -forward;
        let right = u.cross(back);
        let map_power = mean(map.integral() * scale);
        let sun_power = sun.map_or(0.0, |s| mean(s.radiance) * s.solid_angle());
        Ok(EnvironmentLight {
            source,
            map,
            scale,
            right,
            up: u,
            back,
            rotation_deg,
            sun,
            sun_probability: sun_power / (sun_power + map_power),
            centre: bounds.center(),
            radius: bounds.diagonal() * 0.5,
        })
    }

    /// A procedural sky baked into a [`SKY_MAP_WIDTH`] × half map.
    pub fn sky_map(colours: &SkyColours) -> Result<EnvironmentMap> {
        let (w, h) = (SKY_MAP_WIDTH, SKY_MAP_WIDTH / 2);
        let texels = (0..h)
            .flat_map(|row| {
                // sin(elevation) at the row's centre: cos θ with θ from the zenith.
                let s = (PI * (row as f32 + 0.5) / h as f32).cos();
                let c = if s >= 0.0 {
                    colours.horizon.lerp(colours.zenith, s)
                } else {
                    colours.horizon.lerp(colours.ground, -s)
                };
                std::iter::repeat_n(c, w)
            })
            .collect();
        EnvironmentMap::from_texels(w, h, texels)
    }

    /// Where the radiance comes from.
    pub fn source(&self) -> &EnvironmentSource {
        &self.source
    }

    /// The map (a sky's bake).
    pub fn map(&self) -> &EnvironmentMap {
        &self.map
    }

    /// The map's scale.
    pub fn scale(&self) -> Vec3 {
        self.scale
    }

    /// The map's up direction (world).
    pub fn up(&self) -> Vec3 {
        self.up
    }

    /// The rotation about `up`, degrees.
    pub fn rotation_deg(&self) -> f32 {
        self.rotation_deg
    }

    /// The map's local axes in world coordinates: `[x, y (up), z]` (Mitsuba's `to_world`).
    pub fn to_world_columns(&self) -> [Vec3; 3] {
        [self.right, self.up, self.back]
    }

    /// The sun, if any.
    pub fn sun(&self) -> Option<&Sun> {
        self.sun.as_ref()
    }

    /// The volume's bounding-sphere centre.
    pub fn centre(&self) -> Vec3 {
        self.centre
    }

    /// The parameters that build this environment again.
    pub fn params(&self) -> LightParams {
        let rgb = |v: Vec3| Some(Intensity::Rgb(v.to_array()));
        let mut p = LightParams {
            scale: (self.scale != Vec3::ONE).then(|| Intensity::Rgb(self.scale.to_array())),
            up: (self.up != Vec3::Z).then(|| self.up.to_array()),
            rotation: (self.rotation_deg != 0.0).then_some(self.rotation_deg),
            ..LightParams::default()
        };
        match &self.source {
            EnvironmentSource::File(path) => {
                p.kind = LightKind::Environment;
                p.file = Some(path.clone());
            }
            EnvironmentSource::Sky(c) => {
                p.kind = LightKind::Sky;
                (p.zenith, p.horizon, p.ground) = (rgb(c.zenith), rgb(c.horizon), rgb(c.ground));
            }
        }
        if let Some(s) = &self.sun {
            p.sun_direction = Some(s.direction.to_array());
            p.sun_radiance = rgb(s.radiance);
            p.sun_angle = Some((2.0 * s.half_angle).to_degrees());
        }
        p
    }

    fn to_local(&self, w: Vec3) -> Vec3 {
        Vec3::new(w.dot(self.right), w.dot(self.up), w.dot(self.back))
    }

    fn to_world(&self, l: Vec3) -> Vec3 {
        self.right * l.x + self.up * l.y + self.back * l.z
    }

    /// Radiance arriving from world direction `w`.
    pub fn eval(&self, w: Vec3) -> Vec3 {
        let sky = self.map.eval(self.to_local(w)) * self.scale;
        match self.sun {
            Some(s) if s.contains(w) => sky + s.radiance,
            _ => sky,
        }
    }

    /// The solid-angle pdf with which [`Self::sample`] returns `w`.
    pub fn pdf(&self, w: Vec3) -> f32 {
        let map = self.map.pdf(self.to_local(w)) * (1.0 - self.sun_probability);
        match self.sun {
            Some(s) if s.contains(w) => map + self.sun_probability / s.solid_angle(),
            _ => map,
        }
    }

    /// A world direction towards the environment with its mixture pdf and radiance.
    pub fn sample(&self, u: [f32; 2]) -> Option<(Vec3, f32, Vec3)> {
        let p = self.sun_probability;
        let w = match self.sun {
            Some(s) if u[0] < p => {
                let local = uniform_cone([u[0] / p, u[1]], s.cos_half_angle);
                Frame::from_w(s.direction).to_world(local)
            }
            _ => {
                let u0 = ((u[0] - p) / (1.0 - p)).clamp(0.0, 1.0 - f32::EPSILON / 2.0);
                self.to_world(self.map.sample([u0, u[1]])?.0)
            }
        };
        let pdf = self.pdf(w);
        (pdf > 0.0).then(|| (w, pdf, self.eval(w)))
    }

    /// Light arriving at any point from a sampled direction: radiance over pdf (the
    /// environment is unshadowed at infinity; the medium's box bounds the shadow ray).
    pub fn sample_incident(&self, u: [f32; 2]) -> Option<Incident> {
        let (to_light, pdf, radiance) = self.sample(u)?;
        Some(Incident {
            to_light,
            distance: f32::INFINITY,
            radiance: radiance / pdf,
            pdf,
        })
    }

    /// Total power entering the volume's bounding sphere: `πR²·∫L dω` (RGB).
    pub fn power(&self) -> Vec3 {
        self.power_into(&Sphere {
            centre: self.centre,
            radius: self.radius,
        })
    }

    /// Total power entering `target`'s sphere: `πR²·∫L dω` (RGB).
    pub fn power_into(&self, target: &Sphere) -> Vec3 {
        let sun = self
            .sun
            .map_or(Vec3::ZERO, |s| s.radiance * s.solid_angle());
        (self.map.integral() * self.scale + sun) * (PI * target.radius * target.radius)
    }

    /// A photon entering `target`'s sphere and its power relative to
    /// [`Self::power_into`]`/N` (per channel; 0 where that power is 0).
    pub fn emit(&self, rng: &mut Rng, target: &Sphere) -> (Ray, Vec3) {
        let u = rng.uniform2();
        let disc = rng.uniform2();
        let Some((w, pdf, radiance)) = self.sample(u) else {
            return (Ray::new(target.centre, Vec3::Z), Vec3::ZERO);
        };
        let frame = Frame::from_w(w);
        let [a, b] = concentric_disc(disc);
        let origin = target.centre + (w + frame.u * a + frame.v * b) * target.radius * (1.0 + 1e-3);
        let power = self.power_into(target);
        let carried = radiance / pdf * (PI * target.radius * target.radius);
        let relative = Vec3::from_array(std::array::from_fn(|c| {
            if power[c] > 0.0 {
                carried[c] / power[c]
            } else {
                0.0
            }
        }));
        (Ray::new(origin, -w), relative)
    }
}

fn mean(v: Vec3) -> f32 {
    (v.x + v.y + v.z) / 3.0
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Domain;

    fn sky(sun: Option<Sun>) -> EnvironmentLight {
        let colours = SkyColours {
            zenith: Vec3::new(0.2, 0.4, 1.0),
            horizon: Vec3::splat(0.8),
            ground: Vec3::splat(0.1),
        };
        let map = EnvironmentLight::sky_map(&colours).unwrap();
        EnvironmentLight::new(
            EnvironmentSource::Sky(colours),
            map,
            Vec3::ONE,
            Vec3::Z,
            30.0,
            sun,
            &Aabb::unit(),
        )
        .unwrap()
    }

    #[test]
    fn the_frame_is_right_handed_and_up_is_the_zenith() {
        let env = sky(None);
        let [x, y, z] = env.to_world_columns();
        assert!((x.cross(y) - z).length() < 1e-6);
        assert_eq!(y, Vec3::Z);
        // Straight up is the zenith colour (row 0), straight down the ground's.
        assert!((env.eval(Vec3::Z) - Vec3::new(0.2, 0.4, 1.0)).length() < 0.02);
        assert!((env.eval(-Vec3::Z) - Vec3::splat(0.1)).length() < 0.02);
    }

    /// `∫ L dω` by the sampled estimate equals the exact integral, sun included, and each
    /// sampled pdf equals `pdf(ω)`.
    #[test]
    fn sampling_estimates_the_integral_with_its_own_pdf() {
        let sun = Sun::new(Vec3::new(1.0, 0.0, 1.0), Vec3::splat(2000.0), 2.0).unwrap();
        let env = sky(Some(sun));
        let exact = env.power() / (PI * env.radius * env.radius);
        let mut rng = Rng::stream(11, Domain::Photons, 0);
        let n = 400_000;
        let mut sum = Vec3::ZERO;
        for _ in 0..n {
            let (w, pdf, l) = env.sample(rng.uniform2()).unwrap();
            assert!((env.pdf(w) / pdf - 1.0).abs() < 1e-4);
            sum += l / pdf / n as f32;
        }
        for c in 0..3 {
            assert!((sum[c] / exact[c] - 1.0).abs() < 0.01, "{sum} vs {exact}");
        }
    }

    /// Photons through the bounding sphere: their mean power is Φ/N, they start outside
    /// the sphere and head into it.
    #[test]
    fn photons_carry_the_power_through_the_sphere() {
        let env = sky(None);
        let mut rng = Rng::stream(13, Domain::Photons, 0);
        let n = 100_000;
        let mut mean_relative = Vec3::ZERO;
        for _ in 0..n {
            let target = Sphere {
                centre: env.centre,
                radius: env.radius,
            };
            let (ray, relative) = env.emit(&mut rng, &target);
            assert!((ray.origin - env.centre).length() >= env.radius);
            assert!(ray.direction.dot(env.centre - ray.origin) > 0.0);
            mean_relative += relative / n as f32;
        }
        assert!(
            (mean_relative - Vec3::ONE).abs().max_element() < 0.01,
            "{mean_relative}"
        );
    }

    #[test]
    fn bad_parameters_name_their_key() {
        let err = |e: Error| e.to_string();
        assert!(err(Sun::new(Vec3::ZERO, Vec3::ONE, 1.0).unwrap_err()).contains("sun_direction"));
        assert!(err(Sun::new(Vec3::Z, Vec3::ONE, 0.0).unwrap_err()).contains("sun_angle"));
        assert!(err(Sun::new(Vec3::Z, Vec3::NAN, 1.0).unwrap_err()).contains("sun_radiance"));
        let map = || {
            EnvironmentLight::sky_map(&SkyColours {
                zenith: Vec3::ONE,
                horizon: Vec3::ONE,
                ground: Vec3::ONE,
            })
            .unwrap()
        };
        let src = || {
            EnvironmentSource::Sky(SkyColours {
                zenith: Vec3::ONE,
                horizon: Vec3::ONE,
                ground: Vec3::ONE,
            })
        };
        let b = Aabb::unit();
        let e = EnvironmentLight::new(src(), map(), Vec3::ZERO, Vec3::Z, 0.0, None, &b);
        assert!(err(e.unwrap_err()).contains("scale"));
        let e = EnvironmentLight::new(src(), map(), Vec3::ONE, Vec3::ZERO, 0.0, None, &b);
        assert!(err(e.unwrap_err()).contains("up"));
        let e = EnvironmentLight::new(src(), map(), Vec3::ONE, Vec3::Z, f32::NAN, None, &b);
        assert!(err(e.unwrap_err()).contains("rotation"));
    }
}
