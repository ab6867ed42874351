//! What every light answers and every light is bounded by: the light arriving at a point
//! ([`Incident`]) and the largest intensity or radiance a light may have. A leaf the light
//! kinds share (area lights, environments, their maps), so that none of them imports the
//! `Light` enum that holds them.

use glam::Vec3;

use crate::error::{Error, Result};

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

pub(crate) fn validate_intensity(i: Vec3) -> Result<()> {
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

/// Emitted radiance: finite, ≥ 0, not all 0, at most [`MAX_INTENSITY`].
pub(crate) fn check_radiance(radiance: Vec3) -> Result<()> {
    if radiance.is_finite()
        && radiance.min_element() >= 0.0
        && radiance.max_element() > 0.0
        && radiance.max_element() <= MAX_INTENSITY
    {
        Ok(())
    } else {
        Err(Error::parameter(
            "radiance",
            format!("{:?}", radiance.to_array()),
            "finite values >= 0, not all 0, at most 1e20 (W/m²/sr)",
        ))
    }
}
