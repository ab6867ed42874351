//! The default tracer (`tracker = "weighted"`, issue #47): the same collisions as
//! [`super::delta`], weighted instead of played by roulette where that removes noise for
//! little work.
//!
//! * **First vertex**: delta tracking finds the eye ray's first real collision (the
//!   exact free-path sampler); its single scattering connects to every light and carries
//!   the albedo as a weight, where today's tracer first plays Russian roulette with it (a
//!   second coin flip on the layer the eye sees most directly).
//! * **Later vertices** (the multiple layer): the path's throughput is multiplied by the
//!   albedo at each collision (survival biasing) instead of ending the path with
//!   probability `1 − albedo`; Russian roulette only where the throughput's largest
//!   channel has fallen below [`ROULETTE_BELOW`], with survival probability
//!   `throughput / ROULETTE_BELOW`. Analog absorption was the largest single source of the
//!   multiple layer's noise on the headline frame (its variance per sample −35 %, at
//!   about the same cost).
//! * **Next-event estimation at later vertices** connects to ONE light, chosen with
//!   probability proportional to its unshadowed contribution (intensity × falloff / r² ×
//!   phase) and divided by that probability: shadow rays are most of a path's cost, and a
//!   vertex in bone is usually lit by one light at most.
//! * **Lights with extent** (area lights, environments) are also reached by the walk's
//!   phase-sampled direction, and both strategies are weighted by the power heuristic
//!   ([`super::mis`]); delta lights are next-event estimated alone, as before.
//!
//! Transmittance to a light is ratio-tracked as in today's tracer: the exact optical
//! depth has no noise but, walked cell by cell to the light, cost more than the noise it
//! removed (measured on the headline frame, issue #47). Every choice above keeps each
//! layer's expectation: roulette and light selection divide by their probabilities.

use glam::Vec3;

use super::mis;
use super::routes::LightVisibility;
use super::{MAX_VERTICES, PathSample, albedo_at, emission_at};
use crate::math::{Ray, Rng, sample_discrete};
use crate::medium::{Medium, ShadowBy, ShadowSegment};
use crate::scene::{Light, Scene};

/// Throughput (largest channel) below which a path plays Russian roulette. Over 0.2, 0.3
/// and 0.5 on the headline frame, 0.3 was the most efficient (0.2 within noise).
pub(super) const ROULETTE_BELOW: f32 = 0.3;

/// Lights a vertex chooses among without allocating (more are summed, as every light is
/// at the first vertex).
const MAX_CHOSEN_LIGHTS: usize = 16;

/// What a variance budget replaces by its expectation ([`super::budget`]): each switch
/// removes one source of noise and keeps the estimate's expectation. `Knobs::default()` is
/// the tracer as it renders references, draw for draw.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub(super) struct Knobs {
    /// Transmittance to the lights at the first vertex from the exact optical depth.
    pub(super) exact_single_transmittance: bool,
    /// The same at later vertices.
    pub(super) exact_multiple_transmittance: bool,
    /// Next-event estimation to every light at later vertices (not one chosen).
    pub(super) every_light_later: bool,
    /// No roulette: survival biasing until the throughput falls below [`NO_ROULETTE_CUT`].
    pub(super) no_roulette: bool,
}

/// The throughput at which a path without roulette ends (its remaining light is below any
/// noise the budget can measure).
pub(super) const NO_ROULETTE_CUT: f32 = 1e-6;

/// The optical depth past which exact transmittance counts as 0 (e^−30 ≈ 10⁻¹³).
const EXACT_TAU_MAX: f32 = 30.0;

/// What a route of a faster reference adds to the tracker ([`super::routes`]): each keeps
/// every pixel's expectation. `Guides::default()` adds nothing.
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct Guides<'a> {
    /// The uniform that places the eye ray's first tentative collision (a stratified one
    /// stratifies the first free path).
    pub(super) first_collision: Option<f32>,
    /// Each region's transmittance to each light, to choose the light at later vertices.
    pub(super) visibility: Option<&'a LightVisibility>,
}

/// Traces one path from the camera.
pub(super) fn trace_path(scene: &Scene, ray: Ray, rng: &mut Rng) -> PathSample {
    trace_path_with(scene, ray, rng, Knobs::default(), Guides::default())
}

/// [`trace_path`] with parts replaced by their expectation, or guided.
pub(super) fn trace_path_with(
    scene: &Scene,
    ray: Ray,
    rng: &mut Rng,
    knobs: Knobs,
    guides: Guides<'_>,
) -> PathSample {
    let mut out = PathSample {
        work: 1,
        ..PathSample::default()
    };
    let Some(x) = first_vertex(scene, &ray, rng, guides.first_collision, &mut out) else {
        return out;
    };
    let walk = Walk {
        knobs,
        visibility: guides.visibility,
    };
    from_first_vertex(scene, x, ray.direction, rng, walk, &mut out);
    out
}

/// What a first vertex at `x` (reached along `incoming`) adds: its single scattering,
/// then the walk of the multiple layer, whose first direction is also the single layer's
/// phase strategy for lights with extent ([`super::mis`]). Without a walk (single
/// scattering alone) that direction is drawn on its own and its transmittance
/// ratio-tracked, as a shadow ray's is (delta tracking's escape, 0 or 1, raised the single
/// layer's RMSE on the transparent foot under the sky).
pub(super) fn from_first_vertex(
    scene: &Scene,
    x: Vec3,
    incoming: Vec3,
    rng: &mut Rng,
    walk: Walk<'_>,
    out: &mut PathSample,
) {
    let settings = scene.integrator();
    let albedo = albedo_at(scene.medium(), x);
    if settings.single {
        out.single += single_at(scene, x, incoming, rng, walk.knobs, &mut out.work);
    }
    if settings.multiple {
        scatter_on(scene, x, incoming, albedo, rng, walk, out);
    } else if settings.single && mis::has_extended_lights(scene) {
        out.single += albedo * phase_sampled(scene, x, incoming, rng, &mut out.work);
    }
}

/// The phase strategy at a first vertex `x` whose path does not walk on: one
/// phase-sampled direction and, for each light with extent it reaches, the light's
/// power-heuristic share times the ratio-tracked transmittance to it (before the albedo).
/// `work` counts the rays.
fn phase_sampled(scene: &Scene, x: Vec3, incoming: Vec3, rng: &mut Rng, work: &mut u32) -> Vec3 {
    let medium = scene.medium();
    let direction = medium.phase().sample(incoming, rng.uniform2());
    let mut sum = Vec3::ZERO;
    for (radiance, distance) in mis::reached(scene, x, incoming, direction) {
        *work += 1;
        sum += radiance * transmittance(medium, x, direction, distance, rng, false);
    }
    sum
}

/// How a path walks after its first vertex: the budget's knobs and the light choice's
/// guide.
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct Walk<'a> {
    pub(super) knobs: Knobs,
    pub(super) visibility: Option<&'a LightVisibility>,
}

/// The eye ray's first real collision (delta tracking; its first tentative collision
/// placed by `first` when given), with its emission collected.
pub(super) fn first_vertex(
    scene: &Scene,
    ray: &Ray,
    rng: &mut Rng,
    first: Option<f32>,
    out: &mut PathSample,
) -> Option<Vec3> {
    let medium = scene.medium();
    let (t0, t1) = medium.clip(ray)?;
    let t = match first {
        Some(u) => medium.sample_interaction_delta_first(ray, t0, t1, u, rng),
        None => medium.sample_interaction_delta(ray, t0, t1, rng),
    }?;
    let x = ray.at(t);
    out.work += 1;
    if scene.integrator().emission && medium.has_emission() {
        out.emission += emission_at(medium, x);
    }
    Some(x)
}

/// The single-scattering layer of a first vertex at `x`: every light, the albedo as a
/// weight.
fn single_at(
    scene: &Scene,
    x: Vec3,
    incoming: Vec3,
    rng: &mut Rng,
    knobs: Knobs,
    work: &mut u32,
) -> Vec3 {
    let albedo = albedo_at(scene.medium(), x);
    let exact = knobs.exact_single_transmittance;
    albedo * direct_from_every_light(scene, x, incoming, rng, exact, work)
}

/// The rest of a path after its first vertex at `x` (reached along `incoming`, carrying
/// `throughput`): phase-sampled directions, delta-tracked collisions, survival biasing
/// with roulette below [`ROULETTE_BELOW`], and one light's next event into the multiple
/// layer at each vertex.
fn scatter_on(
    scene: &Scene,
    mut x: Vec3,
    mut incoming: Vec3,
    mut throughput: Vec3,
    rng: &mut Rng,
    walk: Walk<'_>,
    out: &mut PathSample,
) {
    let knobs = walk.knobs;
    let medium = scene.medium();
    let extended = mis::has_extended_lights(scene);
    let single = scene.integrator().single;
    for vertex in 1..MAX_VERTICES {
        let direction = medium.phase().sample(incoming, rng.uniform2());
        let ray = Ray::new(x, direction);
        let collision = medium
            .clip(&ray)
            .and_then(|(t0, t1)| medium.sample_interaction_delta(&ray, t0, t1, rng));
        if extended {
            // The phase strategy: what the walk's direction reaches before its next
            // collision belongs to the layer of the vertex it leaves.
            let seen = throughput * mis::emitted_before(scene, &ray, incoming, collision);
            if vertex > 1 {
                out.multiple += seen;
            } else if single {
                out.single += seen;
            }
        }
        let Some(t) = collision else {
            return;
        };
        x = ray.at(t);
        out.work += 1;
        throughput *= albedo_at(medium, x);
        let largest = throughput.max_element();
        if knobs.no_roulette {
            if largest < NO_ROULETTE_CUT {
                return;
            }
        } else if largest < ROULETTE_BELOW {
            let survive = largest / ROULETTE_BELOW;
            if survive <= 0.0 || rng.uniform() >= survive {
                return;
            }
            throughput /= survive;
        }
        let exact = knobs.exact_multiple_transmittance;
        out.multiple += throughput
            * if knobs.every_light_later {
                direct_from_every_light(scene, x, direction, rng, exact, &mut out.work)
            } else {
                direct_from_one_light(
                    scene,
                    x,
                    direction,
                    rng,
                    exact,
                    walk.visibility,
                    &mut out.work,
                )
            };
        incoming = direction;
    }
}

/// Light from every light arriving at `x` and scattered back along `incoming` (before the
/// albedo), each through ratio-tracked transmittance; `work` counts the shadow rays.
fn direct_from_every_light(
    scene: &Scene,
    x: Vec3,
    incoming: Vec3,
    rng: &mut Rng,
    exact: bool,
    work: &mut u32,
) -> Vec3 {
    let medium = scene.medium();
    let mut sum = Vec3::ZERO;
    for light in scene.lights() {
        if let Some((radiance, to_light, distance)) = unshadowed(medium, light, x, incoming, rng) {
            *work += 1;
            sum += radiance * transmittance(medium, x, to_light, distance, rng, exact);
        }
    }
    sum
}

/// [`direct_from_every_light`] estimated from one light, chosen in proportion to its
/// unshadowed contribution (summed over every light past [`MAX_CHOSEN_LIGHTS`]).
fn direct_from_one_light(
    scene: &Scene,
    x: Vec3,
    incoming: Vec3,
    rng: &mut Rng,
    exact: bool,
    visibility: Option<&LightVisibility>,
    work: &mut u32,
) -> Vec3 {
    let lights = scene.lights();
    if lights.len() > MAX_CHOSEN_LIGHTS {
        return direct_from_every_light(scene, x, incoming, rng, exact, work);
    }
    let medium = scene.medium();
    let mut candidates = [(Vec3::ZERO, Vec3::ZERO, 0.0f32); MAX_CHOSEN_LIGHTS];
    let mut weights = [0.0f32; MAX_CHOSEN_LIGHTS];
    let mut total = 0.0f32;
    for (l, light) in lights.iter().enumerate() {
        if let Some(candidate) = unshadowed(medium, light, x, incoming, rng) {
            // With a guide, the choice also weighs how much of the light gets through the
            // region around `x` (never less than a floor, so every light stays possible).
            let seen = visibility.map_or(1.0, |v| v.weight(x, l));
            let radiance = candidate.0;
            weights[l] = (radiance.x + radiance.y + radiance.z).max(0.0) * seen;
            candidates[l] = candidate;
            total += weights[l];
        }
    }
    if total <= 0.0 {
        return Vec3::ZERO;
    }
    // The toolkit sums the weights as this loop did and draws by the same subtractive
    // scan, so the light chosen and `total / weight` are the bits they always were.
    let Some((chosen, _, _)) = sample_discrete(&weights[..lights.len()], rng.uniform()) else {
        return Vec3::ZERO;
    };
    let (radiance, to_light, distance) = candidates[chosen];
    *work += 1;
    let t = transmittance(medium, x, to_light, distance, rng, exact);
    radiance * (t * total / weights[chosen])
}

/// The light `light` sends to `x` and the phase function scatters back along `incoming`,
/// before shadowing, with the direction and distance to it (`None` outside a spot's cone).
/// A light with extent is sampled (one direction, radiance over pdf); a delta light draws
/// nothing, so a choice among candidates weighs each light's sampled estimate and stays
/// unbiased. A light with extent shares its directions with the phase strategy
/// ([`super::mis`]) and carries its power-heuristic weight.
#[inline]
fn unshadowed(
    medium: &Medium,
    light: &Light,
    x: Vec3,
    incoming: Vec3,
    rng: &mut Rng,
) -> Option<(Vec3, Vec3, f32)> {
    let inc = light.sample_incident(x, rng)?;
    let phase = medium.phase().eval(-inc.to_light, -incoming);
    let weight = if inc.pdf.is_finite() {
        mis::power_heuristic(inc.pdf, phase)
    } else {
        1.0
    };
    Some((inc.radiance * (phase * weight), inc.to_light, inc.distance))
}

/// Ratio-tracked transmittance from `x` along `to_light` for `distance` (1 outside the box);
/// `exact`: from the exact optical depth instead (no draw, no noise).
#[inline]
fn transmittance(
    medium: &Medium,
    x: Vec3,
    to_light: Vec3,
    distance: f32,
    rng: &mut Rng,
    exact: bool,
) -> f32 {
    let segment = ShadowSegment {
        origin: x,
        direction: to_light,
        distance,
    };
    let by = if exact {
        ShadowBy::Exact {
            tau_max: EXACT_TAU_MAX,
        }
    } else {
        ShadowBy::Ratio(rng)
    };
    medium.shadow_transmittance(&segment, by)
}
