//! Multiple importance sampling of lights with extent (area lights, environments) against
//! the phase function, for the weighted tracker ([`super::weighted`]).
//!
//! At a scattering vertex two strategies see such a light: next-event estimation draws a
//! direction from the light (solid-angle pdf `p_L`), and the walk's next direction, drawn
//! from the phase function (pdf `p_P`), reaches the light when no collision comes first
//! (delta tracking's escape is an unbiased estimate of the transmittance). Each strategy's
//! estimate is weighted by the power heuristic (Veach 1997, §9.2.4; pbrt-v4's volumetric
//! path tracer does the same): `w_L = p_L² / (p_L² + p_P²)` and `w_P = 1 − w_L`. The weights
//! sum to 1 for every direction and light, so the estimate stays unbiased however a light
//! is chosen for the next event — the weighted tracker chooses one light at later vertices
//! with a probability that depends on every light's sampled direction, which therefore
//! does not enter `p_L`. The walk's direction is drawn anyway, so the phase strategy costs
//! one intersection per light per vertex and no shadow ray; where no walk leaves a vertex
//! (single scattering alone) the direction is drawn on its own and the transmittance along
//! it ratio-tracked. Delta lights (spots, points) have no area
//! for the phase function to hit: they are next-event estimated alone, as before, and a
//! scene of delta lights draws exactly the random numbers it drew before.

use glam::Vec3;

use crate::math::Ray;
use crate::scene::Scene;

/// Whether any of `scene`'s lights has extent (the phase strategy has something to hit).
#[inline]
pub(super) fn has_extended_lights(scene: &Scene) -> bool {
    scene.lights().iter().any(|l| !l.is_delta())
}

/// The power heuristic's weight of a strategy with pdf `own` against one with `other`,
/// written as a ratio so that neither an infinite nor a huge pdf overflows.
#[inline]
pub(super) fn power_heuristic(own: f32, other: f32) -> f32 {
    let ratio = other / own;
    if ratio.is_nan() {
        return 0.0;
    }
    1.0 / (1.0 + ratio * ratio)
}

/// Each light with extent that a phase-sampled `direction` from `x` (for a path that
/// arrived along `incoming`) hits, with its radiance times the phase strategy's
/// power-heuristic weight and its distance (infinite for an environment).
pub(super) fn reached(
    scene: &Scene,
    x: Vec3,
    incoming: Vec3,
    direction: Vec3,
) -> impl Iterator<Item = (Vec3, f32)> + '_ {
    let pdf_phase = scene.medium().phase().eval(incoming, direction);
    scene
        .lights()
        .iter()
        .filter(|l| !l.is_delta())
        .filter_map(move |light| {
            let (pdf_light, radiance, distance) = light.pdf_and_radiance(x, direction)?;
            Some((radiance * power_heuristic(pdf_phase, pdf_light), distance))
        })
}

/// The radiance the lights with extent send back along `ray` (drawn from the phase
/// function for a path that arrived along `incoming`), each weighted by the phase
/// strategy's power heuristic: the lights that `ray` reaches before its next collision
/// at `collision` (every light when it escapes, `None`).
#[inline]
pub(super) fn emitted_before(
    scene: &Scene,
    ray: &Ray,
    incoming: Vec3,
    collision: Option<f32>,
) -> Vec3 {
    reached(scene, ray.origin, incoming, ray.direction)
        .filter(|&(_, distance)| collision.is_none_or(|t| distance < t))
        .map(|(radiance, _)| radiance)
        .sum()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_two_weights_sum_to_one_and_survive_extreme_pdfs() {
        for (a, b) in [(1.0f32, 1.0), (0.1, 3.0), (1e30, 1e-30), (7.0, 0.0)] {
            let sum = power_heuristic(a, b) + power_heuristic(b, a);
            assert!((sum - 1.0).abs() < 1e-6, "{a} {b}: {sum}");
        }
        assert_eq!(power_heuristic(f32::INFINITY, 2.0), 1.0);
        assert_eq!(power_heuristic(2.0, f32::INFINITY), 0.0);
        assert_eq!(power_heuristic(0.0, 2.0), 0.0);
        assert_eq!(power_heuristic(1.0, 1.0), 0.5);
    }
}
