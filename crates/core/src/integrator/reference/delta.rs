//! Today's tracer up to issue #47 (`tracker = "delta"`): delta tracking finds real
//! collisions along each path; at a collision, Russian roulette with the albedo decides
//! between absorption and scattering; at a scattering vertex, next-event estimation
//! connects to every light through ratio-tracked transmittance, and a new direction is
//! sampled from the phase function. Kept as it was, so every reference rendered with it
//! can be rendered again to the bit.

use glam::Vec3;

use super::{MAX_VERTICES, PathSample, albedo_at, emission_at};
use crate::math::{Ray, Rng};
use crate::medium::{ShadowBy, ShadowSegment};
use crate::scene::Scene;

/// Traces one path from the camera.
pub(super) fn trace_path(scene: &Scene, mut ray: Ray, rng: &mut Rng) -> PathSample {
    let medium = scene.medium();
    let settings = scene.integrator();
    let mut out = PathSample::default();
    let mut beta = Vec3::ONE;
    let mut vertices = 0u32;
    while let Some((t0, t1)) = medium.clip(&ray) {
        let Some(t) = medium.sample_interaction_delta(&ray, t0, t1, rng) else {
            break;
        };
        let x = ray.at(t);
        if vertices == 0 && settings.emission && medium.has_emission() {
            out.emission += beta * emission_at(medium, x);
        }
        // Absorb or scatter with the albedo (σs/σt) as survival probability.
        let albedo = albedo_at(medium, x);
        let survive = crate::medium::survival_probability(albedo);
        if survive <= 0.0 || rng.uniform() >= survive {
            break;
        }
        beta *= albedo / survive;
        vertices += 1;
        let layer_wanted = if vertices == 1 {
            settings.single
        } else {
            settings.multiple
        };
        if layer_wanted {
            let mut direct = Vec3::ZERO;
            for light in scene.lights() {
                let Some(inc) = light.sample_incident(x, rng) else {
                    continue;
                };
                let segment = ShadowSegment {
                    origin: x,
                    direction: inc.to_light,
                    distance: inc.distance,
                };
                let tr = medium.shadow_transmittance(&segment, ShadowBy::Ratio(rng));
                if tr > 0.0 {
                    direct +=
                        inc.radiance * (tr * medium.phase().eval(-inc.to_light, -ray.direction));
                }
            }
            if vertices == 1 {
                out.single += beta * direct;
            } else {
                out.multiple += beta * direct;
            }
        }
        if !settings.multiple || vertices >= MAX_VERTICES {
            // Later vertices only feed the multiple layer.
            break;
        }
        let direction = medium.phase().sample(ray.direction, rng.uniform2());
        ray = Ray::new(x, direction);
    }
    out
}
