//! Delta lights: the spot light (§8.2's key, fill and rim; linear or pbrt-v1 falloff) and
//! the point light. Fields are the light module's: the `Light` enum answers for them.

use std::f32::consts::PI;

use glam::Vec3;

use super::incident::{MIN_SPOT_CONE_DEG, validate_intensity};
use super::schema::SpotFalloff;
use crate::error::{Error, Result};
use crate::math::{Frame, Rng};

/// A spot light.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SpotLight {
    pub(super) position: Vec3,
    pub(super) frame: Frame,
    pub(super) intensity: Vec3,
    pub(super) cone_angle: f32,
    pub(super) beam_width: f32,
    pub(super) cos_cone: f32,
    pub(super) cos_beam: f32,
    /// A cosine above which `acos` surely gives an angle inside the beam: the linear
    /// falloff skips its `acos` there.
    pub(super) cos_surely_in_beam: f32,
    pub(super) shape: SpotFalloff,
}

/// A point light.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PointLight {
    pub(super) position: Vec3,
    pub(super) intensity: Vec3,
}

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
    pub(super) fn linear_falloff_by_angle(&self, c: f32) -> f32 {
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

    pub(super) fn sample_direction(&self, rng: &mut Rng) -> Vec3 {
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
