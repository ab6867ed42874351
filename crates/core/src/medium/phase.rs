//! Phase functions (thesis eq. 4, §3.3.2).
//!
//! The thesis uses the isotropic phase function `p = 1/(4π)`. Henyey–Greenstein with
//! asymmetry `g` is an extension; `g = 0` reproduces isotropic scattering exactly (same
//! value, same sampled directions).

use std::f32::consts::PI;

use glam::Vec3;

use crate::error::{Error, Result};
use crate::math::{Frame, INV_4PI, uniform_sphere};

/// The Henyey–Greenstein phase function (isotropic when `g = 0`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Phase {
    g: f32,
}

impl Phase {
    /// Isotropic scattering (thesis eq. 4).
    pub const ISOTROPIC: Phase = Phase { g: 0.0 };

    /// HG with asymmetry `g ∈ (−1, 1)`.
    pub fn henyey_greenstein(g: f32) -> Result<Self> {
        if !(g.is_finite() && g > -1.0 && g < 1.0) {
            return Err(Error::parameter("phase_g", g, "an asymmetry in (-1, 1)"));
        }
        Ok(Phase { g })
    }

    /// The asymmetry parameter.
    pub fn g(&self) -> f32 {
        self.g
    }

    /// Whether the phase function is isotropic (then in-scattered radiance is
    /// view-independent, which the multiple-scattering cache relies on).
    pub fn is_isotropic(&self) -> bool {
        self.g == 0.0
    }

    /// Phase value for light travelling along `wi` and leaving along `wo`
    /// (`cos θ = wi·wo`; forward scattering when `g > 0`).
    #[inline]
    pub fn eval(&self, wi: Vec3, wo: Vec3) -> f32 {
        self.eval_cos(wi.dot(wo))
    }

    /// The largest phase value over all angles (forward for `g > 0`, backward for `g < 0`).
    pub fn max_value(&self) -> f32 {
        self.eval_cos(1.0).max(self.eval_cos(-1.0))
    }

    /// Phase value for the cosine between the propagation directions.
    #[inline]
    pub fn eval_cos(&self, cos_theta: f32) -> f32 {
        if self.g == 0.0 {
            return INV_4PI;
        }
        let g = self.g;
        let denom = 1.0 + g * g - 2.0 * g * cos_theta;
        INV_4PI * (1.0 - g * g) / (denom * denom.max(1e-12).sqrt())
    }

    /// Samples a new propagation direction for light travelling along `wi`; the sample's pdf
    /// equals [`Phase::eval`], so the weight is 1.
    #[inline]
    pub fn sample(&self, wi: Vec3, u: [f32; 2]) -> Vec3 {
        if self.g == 0.0 {
            return uniform_sphere(u);
        }
        let g = self.g;
        let s = (1.0 - g * g) / (1.0 + g - 2.0 * g * u[0]);
        let cos_theta = ((1.0 + g * g - s * s) / (2.0 * g)).clamp(-1.0, 1.0);
        let sin_theta = (1.0 - cos_theta * cos_theta).max(0.0).sqrt();
        let phi = 2.0 * PI * u[1];
        Frame::from_w(wi).to_world(Vec3::new(
            sin_theta * phi.cos(),
            sin_theta * phi.sin(),
            cos_theta,
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::{Domain, Rng};

    #[test]
    fn phase_normalises_and_samples_its_own_density() {
        for g in [0.0f32, 0.5, -0.3, 0.9] {
            let p = Phase::henyey_greenstein(g).unwrap();
            // ∫ p dω = 2π ∫ p(cos) dcos = 1 (midpoint rule).
            let n = 20000;
            let integral: f32 = (0..n)
                .map(|i| {
                    let c = -1.0 + (i as f32 + 0.5) * 2.0 / n as f32;
                    p.eval_cos(c) * 2.0 / n as f32
                })
                .sum::<f32>()
                * 2.0
                * PI;
            assert!((integral - 1.0).abs() < 2e-3, "g={g}: {integral}");
            // Mean cosine of sampled directions equals g.
            let mut rng = Rng::stream(1, Domain::Misc, 0);
            let wi = Vec3::new(0.0, 0.6, 0.8);
            let m = 100_000;
            let mean: f32 = (0..m)
                .map(|_| p.sample(wi, rng.uniform2()).dot(wi))
                .sum::<f32>()
                / m as f32;
            assert!((mean - g).abs() < 0.01, "g={g}: mean cos {mean}");
        }
    }

    #[test]
    fn zero_g_is_exactly_isotropic() {
        let p = Phase::henyey_greenstein(0.0).unwrap();
        assert_eq!(p.eval_cos(0.3), INV_4PI);
        assert_eq!(p.sample(Vec3::Z, [0.2, 0.7]), uniform_sphere([0.2, 0.7]));
        assert!(Phase::henyey_greenstein(1.0).is_err());
    }
}
