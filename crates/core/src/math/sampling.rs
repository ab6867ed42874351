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

/// A direction uniform in the cone around +z whose half-angle has `1 − cos = one_minus_cos`
/// (pbrt-v4's small-angle form: the cosine is never formed from a value near 1, so a
/// narrow cone keeps its digits).
#[inline]
pub fn uniform_cone(u: [f32; 2], one_minus_cos: f32) -> Vec3 {
    let one_minus_cos_t = u[0] * one_minus_cos;
    let sin_t = (one_minus_cos_t * (2.0 - one_minus_cos_t)).max(0.0).sqrt();
    let phi = 2.0 * PI * u[1];
    Vec3::new(sin_t * phi.cos(), sin_t * phi.sin(), 1.0 - one_minus_cos_t)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Directions uniform in a cone lie inside it and average `cos θ` to `1 − (1 − cos α)/2`,
    /// down to a cone of 0.01° whose cosine rounds to 1 in 32-bit floats.
    #[test]
    fn cone_samples_stay_inside_and_are_uniform_in_solid_angle() {
        for half_angle in [30f64, 1.0, 0.01] {
            let one_minus_cos = (2.0 * (half_angle.to_radians() / 2.0).sin().powi(2)) as f32;
            let n = 10_000;
            let mut mean_one_minus_cos = 0.0f64;
            for i in 0..n {
                let u = [
                    (i as f32 + 0.5) / n as f32,
                    (i * 7919 % n) as f32 / n as f32,
                ];
                let w = uniform_cone(u, one_minus_cos);
                let sin_t = (w.x * w.x + w.y * w.y).sqrt() as f64;
                assert!(
                    sin_t <= (half_angle.to_radians().sin()) * (1.0 + 1e-4),
                    "{half_angle}: {w}"
                );
                mean_one_minus_cos +=
                    (sin_t * sin_t / (1.0 + (1.0 - sin_t * sin_t).sqrt())) / n as f64;
            }
            let expected = one_minus_cos as f64 / 2.0;
            assert!(
                (mean_one_minus_cos / expected - 1.0).abs() < 1e-3,
                "{half_angle}: {mean_one_minus_cos} vs {expected}"
            );
        }
    }
}
