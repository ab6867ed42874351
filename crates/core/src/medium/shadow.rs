//! The shadow ray, written once: a segment from a point towards a light, clipped to the
//! medium's kept region and ended at the light, and its optical depth or transmittance by
//! the estimator the caller names. Every integrator's shadow ray comes through here (the
//! marcher's, its optical-depth fill and caches, the error probes, the reference's
//! trackers and their light choice), so a change to how a shadow ray is bounded is made
//! in one place.

use glam::Vec3;

use super::Medium;
use crate::counters::{self, Counter};
use crate::math::{Ray, Rng};

/// A shadow segment: from `origin` along the unit `direction` for `distance` (a light's
/// distance; `f32::INFINITY` towards an environment).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ShadowSegment {
    /// Where the segment starts (a sample, a vertex, a cache node).
    pub origin: Vec3,
    /// Unit direction towards the light.
    pub direction: Vec3,
    /// How far the light is.
    pub distance: f32,
}

/// How far an optical depth is integrated.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum DepthCap {
    /// Exactly, capped at [`super::blocked_depth`]`(tau_max)`: past `tau_max` the light counts as
    /// blocked, and the walk stops as soon as the depth surely passes the blocked depth.
    Blocked(f32),
    /// Exactly; past the cap the result is a lower bound above it (the walk stops at the
    /// end of the run of bricks where the depth passes it).
    Exact(f32),
}

/// How a shadow segment's transmittance is estimated: the tracker, as an argument.
#[derive(Debug)]
pub enum ShadowBy<'r> {
    /// `exp(−τ)` of the exact depth; 0 past `tau_max` (the light blocked).
    Exact {
        /// The depth past which the light counts as blocked.
        tau_max: f32,
    },
    /// `exp(−τ)` of the depth marched with `step` from a jittered start (the thesis's
    /// shadow ray); 0 past `tau_max`. The jitter is drawn from `rng` only when the
    /// segment meets the medium.
    Marched {
        /// The marching step.
        step: f32,
        /// The depth past which the light counts as blocked (the march stops there).
        tau_max: f32,
        /// The pixel's or path's stream.
        rng: &'r mut Rng,
    },
    /// Ratio tracking with Russian roulette (unbiased).
    Ratio(&'r mut Rng),
}

impl Medium {
    /// The part of `segment` inside the medium, as a ray and its interval (`None` where it
    /// misses the kept region).
    fn shadow_interval(&self, segment: &ShadowSegment) -> Option<(Ray, f32, f32)> {
        let ray = Ray {
            origin: segment.origin,
            direction: segment.direction,
        };
        let (t0, t1) = self.clip(&ray)?;
        Some((ray, t0, t1.min(segment.distance)))
    }

    /// The optical depth along `segment` (0 where it misses the medium).
    pub fn shadow_depth(&self, segment: &ShadowSegment, cap: DepthCap) -> f32 {
        let Some((ray, t0, t1)) = self.shadow_interval(segment) else {
            return 0.0;
        };
        match cap {
            DepthCap::Blocked(tau_max) => self.optical_depth_capped(&ray, t0, t1, tau_max),
            DepthCap::Exact(cap) => self.optical_depth_exact(&ray, t0, t1, cap),
        }
    }

    /// The transmittance along `segment` by `by` (1 where it misses the medium). Counted as
    /// a shadow ray in a counted pass ([`crate::Counter`]).
    pub fn shadow_transmittance(&self, segment: &ShadowSegment, by: ShadowBy<'_>) -> f32 {
        counters::count(Counter::ShadowRays);
        let Some((ray, t0, t1)) = self.shadow_interval(segment) else {
            return 1.0;
        };
        match by {
            ShadowBy::Exact { tau_max } => {
                transmittance_of(self.optical_depth_capped(&ray, t0, t1, tau_max), tau_max)
            }
            ShadowBy::Marched { step, tau_max, rng } => {
                let tau =
                    self.optical_depth_marched_until(&ray, t0, t1, step, rng.uniform(), tau_max);
                transmittance_of(tau, tau_max)
            }
            ShadowBy::Ratio(rng) => self.transmittance_ratio_tracking(&ray, t0, t1, rng),
        }
    }
}

/// Transmittance from an optical depth; beyond `tau_max` the light counts as blocked.
#[inline]
pub(crate) fn transmittance_of(tau: f32, tau_max: f32) -> f32 {
    if tau > tau_max { 0.0 } else { (-tau).exp() }
}
