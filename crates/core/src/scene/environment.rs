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

use glam::{DVec3, Vec3};

use super::envmap::EnvironmentMap;
use super::light::incident::{Incident, MAX_INTENSITY, check_radiance};
use super::light::schema::{Intensity, LightKind, LightParams};
use crate::error::{Error, Result};
use crate::math::{Aabb, Frame, Ray, Rng, Sphere, concentric_disc, sample_discrete};

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

/// The smallest sun `sun_angle` (angular diameter, degrees) accepted. A direction is held
/// in 32-bit floats, which place it to about 10⁻⁷ rad; a disc of 0.001° (a half-angle of
/// 8.7·10⁻⁶ rad) is still a hundred times wider, so whether a direction lies inside it is
/// decided without ambiguity, and sampling and hitting it agree. A smaller sun renders as
/// this one with the same `sun_radiance × angle²` (the same irradiance): a volume cannot
/// tell them apart.
pub const MIN_SUN_ANGLE_DEG: f32 = 0.001;

/// A sun: a disc of constant radiance around a direction.
///
/// Its cone is held in `f64` and in terms of `1 − cos θ`: the sun's half-angle is small,
/// and `cos θ` in `f32` rounds to 1 below about 0.02° (`cos 0.005° = 1 − 3.8·10⁻⁹`), which
/// made small suns' solid angle wrong by up to 74 % and, below 0.02°, zero. Whether a
/// direction is inside is decided by the sine of its angle to the axis (a cross product,
/// exact in `f64` for `f32` inputs), never by a cosine near 1.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sun {
    /// Unit direction towards the sun (world).
    pub direction: Vec3,
    /// Radiance of the disc.
    pub radiance: Vec3,
    /// Half the angular diameter, radians.
    pub half_angle: f32,
    /// The angular diameter as given, degrees.
    diameter_deg: f32,
    /// `1 − cos(half_angle)`, as `2 sin²(half_angle / 2)` (no cancellation).
    one_minus_cos: f64,
    /// `sin²(half_angle)`: a unit direction `w` is inside when `|w × axis|² ≤ sin²` on the
    /// sun's side.
    sin2_half_angle: f64,
    /// An orthonormal frame around `direction` in `f64` (tangents, then the axis).
    frame: [DVec3; 3],
}

impl Sun {
    /// A sun towards `direction` with `radiance` and angular diameter `diameter_deg`, in
    /// [0.001, 90] degrees (below, 32-bit directions cannot tell the disc's inside from
    /// its outside).
    pub fn new(direction: Vec3, radiance: Vec3, diameter_deg: f32) -> Result<Self> {
        let d = direction.normalize_or_zero();
        if !direction.is_finite() || d == Vec3::ZERO {
            return Err(Error::parameter(
                "sun_direction",
                format!("{:?}", direction.to_array()),
                "a finite non-zero direction towards the sun",
            ));
        }
        if !(diameter_deg.is_finite() && (MIN_SUN_ANGLE_DEG..=90.0).contains(&diameter_deg)) {
            return Err(Error::parameter(
                "sun_angle",
                diameter_deg,
                format!(
                    "an angular diameter in [{MIN_SUN_ANGLE_DEG}, 90] degrees (the real sun: 0.53). Below {MIN_SUN_ANGLE_DEG}° a 32-bit direction cannot tell inside the disc from outside; a sun of {MIN_SUN_ANGLE_DEG}° with sun_radiance × (angle / {MIN_SUN_ANGLE_DEG})² has the same irradiance and renders the same"
                ),
            ));
        }
        check_radiance(radiance).map_err(|_| {
            Error::parameter(
                "sun_radiance",
                format!("{:?}", radiance.to_array()),
                "finite values >= 0, not all 0, at most 1e20 (W/m²/sr)",
            )
        })?;
        let half = (diameter_deg as f64 / 2.0).to_radians();
        let axis = d.as_dvec3().normalize();
        Ok(Sun {
            direction: d,
            radiance,
            half_angle: half as f32,
            diameter_deg,
            one_minus_cos: 2.0 * (half / 2.0).sin().powi(2),
            sin2_half_angle: half.sin().powi(2),
            frame: frame_f64(axis),
        })
    }

    /// The angular diameter, degrees, as it was given.
    pub fn diameter_deg(&self) -> f32 {
        self.diameter_deg
    }

    /// The disc's solid angle, `2π(1 − cos θ)`.
    pub fn solid_angle(&self) -> f64 {
        std::f64::consts::TAU * self.one_minus_cos
    }

    /// Whether direction `w` (any length) lies inside the disc: on the sun's side, with
    /// `|w × d|² ≤ sin²θ·|w|²·|d|²`, each product of two `f32` exact in `f64`.
    fn contains(&self, w: Vec3) -> bool {
        let (w, d) = (w.as_dvec3(), self.direction.as_dvec3());
        w.dot(d) > 0.0
            && w.cross(d).length_squared()
                <= self.sin2_half_angle * w.length_squared() * d.length_squared()
    }

    /// A direction uniform over the disc's solid angle: `1 − cos θ` uniform in
    /// `[0, 1 − cos θmax]` (pbrt-v4's cone sampling in its `sin²` form, so a tiny cone
    /// keeps its shape), built in `f64` and rounded once. Rounding may carry a point on
    /// the rim out of the disc (about one in 10⁵ at 0.001°); such a point is drawn again
    /// at half the angle, so every sample is inside and the estimate keeps its mean.
    fn sample(&self, u: [f32; 2]) -> Vec3 {
        let [tangent, bitangent, axis] = self.frame;
        let phi = std::f64::consts::TAU * u[1] as f64;
        let fraction = (u[0] as f64).clamp(0.0, 1.0);
        for shrink in [1.0, 0.25] {
            let one_minus_cos = fraction * shrink * self.one_minus_cos;
            let sin_theta = (one_minus_cos * (2.0 - one_minus_cos)).sqrt();
            let w = (tangent * (sin_theta * phi.cos())
                + bitangent * (sin_theta * phi.sin())
                + axis * (1.0 - one_minus_cos))
                .as_vec3();
            if self.contains(w) {
                return w;
            }
        }
        self.direction
    }
}

/// An orthonormal frame `[u, v, w]` with `w` the unit vector `w` (Duff et al. 2017), in
/// `f64`.
fn frame_f64(w: DVec3) -> [DVec3; 3] {
    let sign = 1.0f64.copysign(w.z);
    let a = -1.0 / (sign + w.z);
    let b = w.x * w.y * a;
    let u = DVec3::new(1.0 + sign * w.x * w.x * a, sign * b, -sign * w.x);
    let v = DVec3::new(b, sign + w.y * w.y * a, -w.y);
    [u, v, w]
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
        check_brightness(&map, scale)?;
        let map_power = mean(map.integral() * scale);
        let sun_power = sun.map_or(0.0, |s| mean(s.radiance) * s.solid_angle() as f32);
        if map_power <= 0.0 && sun_power <= 0.0 {
            // Only a sky's bake may be black (a file's black map is refused as it loads).
            return Err(Error::parameter(
                "zenith",
                "(zenith, horizon and ground all 0, and no sun)",
                "a sky that emits something: a colour above 0, or a sun (sun_direction and sun_radiance)",
            ));
        }
        let light = EnvironmentLight {
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
        };
        if !light.power().is_finite() {
            return Err(Error::parameter(
                "scale",
                format!("{:?}", scale.to_array()),
                format!(
                    "an environment whose power πR²·∫L dω stays finite in 32-bit floats around a volume of bounding radius R = {}",
                    light.radius
                ),
            ));
        }
        Ok(light)
    }

    /// A procedural sky baked into a [`SKY_MAP_WIDTH`] × half map (black when all three
    /// colours are 0: a sky lit by its sun alone).
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
        EnvironmentMap::sky(w, h, texels)
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
            p.sun_angle = Some(s.diameter_deg());
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
            Some(s) if s.contains(w) => {
                map + (self.sun_probability as f64 / s.solid_angle()) as f32
            }
            _ => map,
        }
    }

    /// A world direction towards the environment with its mixture pdf and radiance: `u[0]`
    /// chooses the sun or the map by their power and, remapped, samples the one chosen.
    pub fn sample(&self, u: [f32; 2]) -> Option<(Vec3, f32, Vec3)> {
        let p = self.sun_probability;
        // `p + (1 − p)` rounds to exactly 1 for any `p` in [0, 1], so the draw is `u[0] < p`
        // and the remapped `u[0]` is `u[0] / p` (sun) or `(u[0] − p) / (1 − p)` (map), bit
        // for bit; without a sun `p` is 0 and the map gets `u[0]` as it was.
        let (chosen, _, u0) = sample_discrete(&[p, 1.0 - p], u[0])?;
        let w = match self.sun {
            Some(s) if chosen == 0 => s.sample([u0, u[1]]),
            _ => self.to_world(self.map.sample([u0, u[1]])?.0),
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
            .map_or(Vec3::ZERO, |s| s.radiance * s.solid_angle() as f32);
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

/// The map times `scale` must stay within the radiance every light keeps to
/// ([`MAX_INTENSITY`], 1e20 W/m²/sr): beyond it the light's power and the photons'
/// sums overflow 32-bit floats, and a render ends in infinities.
fn check_brightness(map: &EnvironmentMap, scale: Vec3) -> Result<()> {
    let brightest = map.brightest() * scale;
    if brightest.is_finite() && brightest.max_element() <= MAX_INTENSITY {
        return Ok(());
    }
    Err(Error::parameter(
        "scale",
        format!("{:?}", scale.to_array()),
        format!(
            "a scale that keeps the map's radiance at most 1e20 (W/m²/sr): its brightest texel {:?} times the scale is {:?}",
            map.brightest().to_array(),
            brightest.to_array()
        ),
    ))
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

    /// A sun's disc as sampled, hit and weighed agrees with its analytic solid angle at
    /// every size: every sample lies inside, the set of `f32` directions judged inside
    /// has the solid angle `2π(1 − cos θ)` (directions uniform over a cone twice as wide
    /// land inside a quarter of the time, less the rim's curvature), and the power is
    /// `L·Ω·πR²`. In `f32` cosines a 0.03° sun's solid angle came out 1.74× too large and a
    /// 0.01° sun's 0.
    #[test]
    fn a_sun_of_any_size_has_its_exact_solid_angle() {
        let direction = Vec3::new(0.3, -0.7, 0.64);
        for degrees in [0.001f32, 0.01, 0.03, 0.53, 10.0, 90.0] {
            let sun = Sun::new(direction, Vec3::ONE, degrees).unwrap();
            let half = (degrees as f64 / 2.0).to_radians();
            let exact = std::f64::consts::TAU * (1.0 - half.cos());
            assert!((sun.solid_angle() / exact - 1.0).abs() < 1e-6, "{degrees}°");
            let mut rng = Rng::stream(17, Domain::Photons, degrees.to_bits() as u64);
            for _ in 0..100_000 {
                let w = sun.sample(rng.uniform2());
                assert!(sun.contains(w), "{degrees}°: {w} sampled outside");
                assert!((w.length() - 1.0).abs() < 1e-6);
            }
            if degrees <= 45.0 {
                let wide = Sun::new(direction, Vec3::ONE, 2.0 * degrees).unwrap();
                let n = 400_000;
                let inside = (0..n)
                    .filter(|_| sun.contains(wide.sample(rng.uniform2())))
                    .count();
                let expected = sun.solid_angle() / wide.solid_angle();
                let sd = (expected * (1.0 - expected) / n as f64).sqrt();
                let fraction = inside as f64 / n as f64;
                assert!(
                    (fraction - expected).abs() < 4.0 * sd,
                    "{degrees}°: {fraction} of a cone twice as wide inside, expected {expected}"
                );
            }
            let env = EnvironmentLight::new(
                EnvironmentSource::Sky(SkyColours {
                    zenith: Vec3::ZERO,
                    horizon: Vec3::ZERO,
                    ground: Vec3::ZERO,
                }),
                EnvironmentLight::sky_map(&SkyColours {
                    zenith: Vec3::ZERO,
                    horizon: Vec3::ZERO,
                    ground: Vec3::ZERO,
                })
                .unwrap(),
                Vec3::ONE,
                Vec3::Z,
                0.0,
                Some(Sun::new(direction, Vec3::splat(2.0), degrees).unwrap()),
                &Aabb::unit(),
            )
            .unwrap();
            let want = 2.0 * exact * std::f64::consts::PI * (env.radius as f64).powi(2);
            assert!(
                (env.power().x as f64 / want - 1.0).abs() < 1e-5,
                "{degrees}°"
            );
        }
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
