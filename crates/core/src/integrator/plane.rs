//! The photon-plane estimate along one eye ray (Bitterli & Jarosz 2017, 1-D blur; the
//! planes and their transmittance in [`crate::photon::PlaneMap`]).
//!
//! For every plane whose blurred slab the eye ray crosses on `[t_enter, t_exit]`, one `t`
//! is drawn uniformly there (from the eye ray's own random stream) and the plane adds
//!
//! `(t_exit − t_enter) · weight · Φ · σs(x(s,0)) · 1{τ(x(s,0) → x(s,u)) < τ*} ·
//! σs(t) · p(ω_{a+1}, −ω) · T_eye(t)`,
//!
//! `(s, u)` the plane coordinates of the ray's point at `t` and `weight = 1/(2r·|ω_a ×
//! ω_{a+1}|)`. The eye side is the march's model, as for the beam estimate: σt constant
//! over each sample's segment, the optical depth linear within it, nothing between
//! segments (skipped empty bricks) or past the `termination` cut-off. The optical depth
//! along the plane's second direction is the exact cell walk, stopped once it passes `τ*`.

use glam::Vec3;

use super::marcher::Marcher;
use super::sample::{Accumulator, RaySample};
use crate::math::{Ray, Rng};
use crate::medium::Medium;
use crate::photon::PlaneMap;

impl Marcher<'_> {
    /// The multiple-scattering term of the collected samples from the photon planes.
    pub(super) fn add_planes(
        &self,
        planes: &PlaneMap<'_>,
        ray: &Ray,
        rng: &mut Rng,
        acc: &mut Accumulator,
    ) {
        let (Some(first), Some(last)) = (acc.samples.first(), acc.samples.last()) else {
            return;
        };
        let span = (first.t_start, last.t_start + last.width);
        let samples = &acc.samples;
        let medium = self.medium;
        let (wo, phase) = (-ray.direction, medium.phase());
        let mut sum = [0.0f64; 3];
        planes.crossings(ray, span, &mut acc.stack, |c| {
            let length = c.t_exit - c.t_enter;
            let t = c.t_enter + rng.uniform() * length;
            let Some(sample) = segment_at(samples, t) else {
                return;
            };
            let (vertex, u) = c.vertex_at(t);
            let sigma_s = medium.sigma_s(vertex);
            if sigma_s == Vec3::ZERO || !reaches(medium, vertex, c.plane.second, u, c.plane.tau) {
                return;
            }
            let eye_t = (-(sample.tau_start + sample.sigma_t * (t - sample.t_start))).exp();
            let albedo = if medium.has_colour() {
                medium.albedo_at(ray.at(t))
            } else {
                medium.albedo()
            };
            let scalar =
                length * c.weight * sample.sigma_t * eye_t * phase.eval(c.plane.second, wo);
            let value = c.plane.power * sigma_s * albedo * scalar;
            for (s, v) in sum.iter_mut().zip(value.to_array()) {
                *s += v as f64;
            }
        });
        acc.counters.gathers += 1;
        acc.multiple[0] += Vec3::new(sum[0] as f32, sum[1] as f32, sum[2] as f32);
    }
}

/// The marching sample whose segment holds `t`, or `None` in a gap between segments
/// (σt = 0 there in the march's model).
fn segment_at(samples: &[RaySample], t: f32) -> Option<&RaySample> {
    let after = samples.partition_point(|s| s.t_start <= t);
    let sample = &samples[after.checked_sub(1)?];
    (t < sample.t_start + sample.width).then_some(sample)
}

/// Whether the exact optical depth from `from` along `direction` over `[0, u]` (inside the
/// box) stays below `tau`: the indicator whose expectation over `tau ~ Exp(1)` is the
/// transmittance. The cell walk stops once it passes `tau`.
fn reaches(medium: &Medium, from: Vec3, direction: Vec3, u: f32, tau: f32) -> bool {
    let ray = Ray {
        origin: from,
        direction,
    };
    let Some((t0, t1)) = medium.clip(&ray) else {
        return true;
    };
    let t1 = t1.min(u);
    t1 <= t0 || medium.optical_depth_capped(&ray, t0, t1, tau) < tau
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample(t_start: f32, width: f32) -> RaySample {
        RaySample {
            x: Vec3::ZERO,
            sigma_t: 1.0,
            weight: 0.0,
            t_start,
            width,
            tau_start: 0.0,
        }
    }

    #[test]
    fn a_point_between_segments_has_no_medium() {
        let samples = [sample(1.0, 0.5), sample(2.0, 0.5)];
        let start = |t| segment_at(&samples, t).map(|s| s.t_start);
        assert_eq!(start(0.5), None);
        assert_eq!(start(1.2), Some(1.0));
        assert_eq!(start(1.7), None);
        assert_eq!(start(2.0), Some(2.0));
        assert_eq!(start(2.6), None);
    }
}
