//! The beam radiance estimate in a heterogeneous medium (Jarosz, Zwicker & Jensen 2008,
//! with the exact chord form of the 3-D kernel).
//!
//! The marched point estimate (§5.2, `Fluence` form) adds, per segment `k` of the eye ray,
//! `Λ·(T_k^start − T_k^end)·ê(x_k)` with `ê(x) = Σ_p w_p·1{|x − x_p| < r_p}/V_p` and
//! `w_p = p·ΔΦ_p/σt(x_p)`. Swapping the sums and letting the step go to zero gives, per
//! photon whose sphere the ray crosses on the chord `[a_p, b_p]`,
//!
//! `∫_{a_p}^{b_p} σs(t)·T(t) dt = Λ·[T(a_p) − T(b_p)]`   (because `dT/dt = −σt·T`),
//!
//! so `L_ms = Λ·Σ_p (w_p/V_p)·[T(a_p) − T(b_p)]`: exact for any σt along the chord, with
//! the eye transmittance `T` the only heterogeneous quantity. `T` comes from the march the
//! single-scattering term already makes along the same ray (σt constant per segment,
//! optical depth linear within it), so the beam and point estimates share one model of the
//! eye ray and agree as the step and radius shrink; the term no longer costs a k-NN query
//! per step. The eye ray's end (box exit or the `termination` cut-off) clips every chord.
//! In a colour medium Λ varies along a chord and is taken at its midpoint.
//!
//! The same spheres also give the progressive point estimate with per-photon radii
//! ([`RadiusRule`] `nearest` or `balanced`): at each marching sample, the sum over the
//! spheres that hold it ([`Marcher::add_spheres`]).

use super::marcher::Marcher;
use super::sample::{Accumulator, RaySample};
use crate::math::Ray;
use crate::photon::{BeamMap, BeamRadius, Gathered};
use crate::scene::{Estimate, InitialRadius, IntegratorParams, RadiusRule};

impl Marcher<'_> {
    /// The multiple-scattering term of the collected samples from the photons' spheres.
    pub(super) fn add_beams(&self, beams: &BeamMap<'_>, ray: &Ray, acc: &mut Accumulator) {
        let (Some(first), Some(last)) = (acc.samples.first(), acc.samples.last()) else {
            return;
        };
        let (t_min, t_max) = (first.t_start, last.t_start + last.width);
        let samples = &acc.samples;
        let medium = self.medium;
        let mut sum = [0.0f64; 3];
        beams.crossings(
            ray,
            (t_min, t_max),
            Gathered::Fluence,
            medium.phase(),
            &mut acc.stack,
            |crossing| {
                let through = (-optical_depth_at(samples, crossing.t_enter)).exp()
                    - (-optical_depth_at(samples, crossing.t_exit)).exp();
                // A colour medium's albedo varies along the chord: taken at its midpoint
                // (exact as the radius shrinks); a grey medium's is the constant Λ.
                let term = if medium.has_colour() {
                    let mid = ray.at(0.5 * (crossing.t_enter + crossing.t_exit));
                    crossing.density * medium.albedo_at(mid)
                } else {
                    crossing.density
                };
                for (s, d) in sum.iter_mut().zip(term.to_array()) {
                    *s += d as f64 * through as f64;
                }
            },
        );
        acc.counters.gathers += 1;
        let sum = glam::Vec3::new(sum[0] as f32, sum[1] as f32, sum[2] as f32);
        acc.multiple[0] += if medium.has_colour() {
            sum
        } else {
            medium.albedo() * sum
        };
    }
}

impl Marcher<'_> {
    /// The multiple-scattering term of the collected samples from the point estimate with
    /// per-photon radii: at every sample, the sum over the spheres that hold it (no
    /// thinning: the term is not interpolated behind the front).
    pub(super) fn add_spheres(&self, spheres: &BeamMap<'_>, wo: glam::Vec3, acc: &mut Accumulator) {
        let medium = self.medium;
        let estimate = self.settings.estimate;
        for sample in &acc.samples {
            let density = spheres.density_at(
                sample.x,
                Gathered::Fluence,
                medium.phase(),
                wo,
                &mut acc.stack,
            );
            let factor = super::gather::source_factor(estimate, medium, sample.x, sample.sigma_t);
            acc.multiple[0] += factor * density * sample.weight;
        }
        acc.counters.gathers += acc.samples.len() as u64;
    }
}

/// The eye's optical depth at `t` in the march's model: σt constant over each sample's
/// segment, zero between segments (skipped empty bricks), nothing before the first.
fn optical_depth_at(samples: &[RaySample], t: f32) -> f32 {
    let after = samples.partition_point(|s| s.t_start <= t);
    let Some(s) = after.checked_sub(1).map(|k| &samples[k]) else {
        return 0.0;
    };
    s.tau_start + s.sigma_t * (t - s.t_start).min(s.width)
}

/// How a scene's settings size the photons' spheres: from the `nused`-th neighbour of each
/// photon (at most `maxdist`) by the scene's radius rule (each photon's own distance
/// unless `radius` says otherwise), or `maxdist` for all.
pub(crate) fn beam_radius(settings: &IntegratorParams, scale: f32) -> BeamRadius {
    match settings.initial_radius {
        InitialRadius::Nused => BeamRadius::Nearest {
            k: settings.nused,
            max: settings.maxdist,
            scale,
            rule: match settings.radius {
                RadiusRule::Auto => RadiusRule::Nearest,
                rule => rule,
            },
        },
        InitialRadius::Maxdist => BeamRadius::Fixed(settings.maxdist * scale),
    }
}

/// Whether the beam kernels are normalised by the medium's share of each sphere.
pub(crate) fn beam_masked(settings: &IntegratorParams) -> bool {
    settings.estimate == Estimate::Masked
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    fn sample(t_start: f32, width: f32, sigma_t: f32, tau_start: f32) -> RaySample {
        RaySample {
            x: Vec3::ZERO,
            sigma_t,
            weight: 0.0,
            t_start,
            width,
            tau_start,
        }
    }

    #[test]
    fn optical_depth_is_piecewise_linear_with_gaps() {
        // Segments [1, 1.5) σt 2 and [2, 2.5) σt 4; empty space between.
        let samples = [sample(1.0, 0.5, 2.0, 0.0), sample(2.0, 0.5, 4.0, 1.0)];
        for (t, tau) in [
            (0.5, 0.0),
            (1.25, 0.5),
            (1.75, 1.0),
            (2.25, 2.0),
            (2.5, 3.0),
            (9.0, 3.0),
        ] {
            assert!(
                (optical_depth_at(&samples, t) - tau).abs() < 1e-6,
                "t = {t}"
            );
        }
    }
}
