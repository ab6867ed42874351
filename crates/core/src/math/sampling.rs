//! Direction sampling.

use glam::Vec3;
use std::f32::consts::PI;

/// `1/(4π)`.
pub const INV_4PI: f32 = 1.0 / (4.0 * PI);

/// A uniformly distributed direction on the unit sphere.
#[inline]
pub fn uniform_sphere(u: [f32; 2]) -> Vec3 {
    let z = 1.0 - 2.0 * u[0];
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * PI * u[1];
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}
