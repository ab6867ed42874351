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

/// A point uniformly distributed on the unit disc (Shirley and Chiu's concentric map, so
/// strata of `u` stay compact on the disc).
#[inline]
pub fn concentric_disc(u: [f32; 2]) -> [f32; 2] {
    let (a, b) = (2.0 * u[0] - 1.0, 2.0 * u[1] - 1.0);
    if a == 0.0 && b == 0.0 {
        return [0.0, 0.0];
    }
    let (r, theta) = if a.abs() > b.abs() {
        (a, (PI / 4.0) * (b / a))
    } else {
        (b, PI / 2.0 - (PI / 4.0) * (a / b))
    };
    [r * theta.cos(), r * theta.sin()]
}

/// A direction in the hemisphere around +z with density `cos θ / π` (Malley's method).
#[inline]
pub fn cosine_hemisphere(u: [f32; 2]) -> Vec3 {
    let [x, y] = concentric_disc(u);
    Vec3::new(x, y, (1.0 - x * x - y * y).max(0.0).sqrt())
}
