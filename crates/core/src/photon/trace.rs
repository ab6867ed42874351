//! Photon tracing (thesis §5.1, §7.1.2).
//!
//! * Photons leave the lights; each light emits a share of the photons proportional to its
//!   power, so all photons carry about the same power. Spot lights sample their cone by
//!   their falloff.
//! * The free path to the next interaction follows a named rule ([`FreePath`]): `delta`
//!   (Woodcock tracking, exact), `march` (inverting the ray-marched optical depth) or
//!   `thesis` (`d = −ln ξ / σt(x)` at the current point after searching forward for σt > 0).
//! * At an interaction, Russian roulette with the albedo decides scatter or absorb.
//! * A photon is stored at every interaction (scatter or absorb) but only after it has
//!   been scattered at least once — direct light is left to ray marching. Its power is the
//!   light's power divided by the number of photons that light EMITTED.
//! * Photon `i` draws from its own random stream `(seed, i)`: results do not depend on the
//!   thread count.

use std::time::Instant;

use glam::Vec3;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::control::Control;
use crate::error::Result;
use crate::math::{Domain, Ray, Rng, Sphere, apportion};
use crate::medium::{FreePath, Medium};
use crate::scene::{Light, MAX_PHOTONS};

/// A stored photon.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Photon {
    /// Where it interacted.
    pub position: Vec3,
    /// Its propagation direction when it arrived.
    pub direction: Vec3,
    /// Its power ΔΦ (W, RGB), already divided by its light's emitted count.
    pub power: Vec3,
    /// σt where it was stored (0 when the thesis's free-path rule lands in empty space).
    pub sigma_t: f32,
}

/// Statistics of one photon-tracing run.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct PhotonStats {
    /// Photons emitted, over all lights.
    pub emitted: u64,
    /// Photons emitted per light.
    pub emitted_per_light: Vec<u64>,
    /// Photons stored in the map.
    pub stored: u64,
    /// Photons stored per light (empty in records written before it was counted).
    #[serde(default)]
    pub stored_per_light: Vec<u64>,
    /// The stored-photon target the emitted count was chosen for (0: none, the emitted
    /// count was `volume_photons`).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub stored_target: u64,
    /// Tracing rounds it took to reach the target (0 without one).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub rounds: u32,
    /// Photons that never interacted (missed the volume or passed through).
    pub escaped_without_interaction: u64,
    /// Photons that were absorbed.
    pub absorbed: u64,
    /// Photons stopped by the interaction cap (albedo ≈ 1 in a closed medium).
    pub truncated: u64,
    /// Interactions per emitted photon.
    pub interactions_per_photon: f64,
    /// Mean length of the flights from one interaction to the next (world units): the
    /// empirical mean free path inside the medium. Flights that leave the volume are not
    /// counted (their length is censored), nor the first flight from the light.
    pub mean_flight_distance: f64,
    /// Median of the same flights.
    pub median_flight_distance: f64,
    /// Total power stored (W, RGB mean).
    pub stored_power: f64,
    /// Seconds spent tracing.
    pub seconds: f64,
}

fn is_zero<T: Default + PartialEq>(x: &T) -> bool {
    *x == T::default()
}

/// Interactions after which a photon is stopped (counted in [`PhotonStats::truncated`]).
pub const MAX_INTERACTIONS: u32 = 100_000;

/// The photon-tracing settings taken from the scene.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TraceSettings {
    /// Photons emitted in total (with a stored target: in the first round).
    pub photons: u64,
    /// Photons the map must hold (0: none; emit `photons`). See [`trace`].
    pub stored_target: u64,
    /// Free-path rule.
    pub free_path: FreePath,
    /// Step for the `march` and `thesis` rules.
    pub stepsize: f32,
    /// Random seed.
    pub seed: u64,
}

/// Splits `total` photons over lights in proportion to the power they send towards
/// `target` (largest remainders, [`apportion`]), so photons carry equal energies (§7.1.2).
pub fn photons_per_light(lights: &[Light], target: &Sphere, total: u64) -> Vec<u64> {
    let powers: Vec<f64> = lights
        .iter()
        .map(|l| {
            let p = l.emitted_power(target);
            (p.x as f64 + p.y as f64 + p.z as f64) / 3.0
        })
        .collect();
    apportion(&powers, total)
}

/// What the paths of one chunk of photons did, whatever they record.
#[derive(Default)]
pub(super) struct PathCounters {
    /// Lengths of the flights between interactions (see [`PhotonStats::mean_flight_distance`]).
    pub(super) flights: Vec<f32>,
    pub(super) interactions: u64,
    pub(super) escaped: u64,
    pub(super) absorbed: u64,
    pub(super) truncated: u64,
}

impl PathCounters {
    /// Adds another chunk's counters.
    pub(super) fn merge(&mut self, other: PathCounters) {
        self.flights.extend(other.flights);
        self.interactions += other.interactions;
        self.escaped += other.escaped;
        self.absorbed += other.absorbed;
        self.truncated += other.truncated;
    }

    /// The statistics of `total` emitted photons (`per_light` of them per light) from these
    /// counters; what was stored is the caller's to fill in.
    pub(super) fn stats(mut self, total: u64, per_light: Vec<u64>) -> PhotonStats {
        let lights = per_light.len();
        let mut stats = PhotonStats {
            emitted: total,
            emitted_per_light: per_light,
            stored_per_light: vec![0; lights],
            escaped_without_interaction: self.escaped,
            absorbed: self.absorbed,
            truncated: self.truncated,
            ..Default::default()
        };
        if total > 0 {
            stats.interactions_per_photon = self.interactions as f64 / total as f64;
        }
        if !self.flights.is_empty() {
            stats.mean_flight_distance =
                self.flights.iter().map(|&f| f as f64).sum::<f64>() / self.flights.len() as f64;
            let mid = self.flights.len() / 2;
            let (_, median, _) = self
                .flights
                .select_nth_unstable_by(mid, |a, b| a.total_cmp(b));
            stats.median_flight_distance = *median as f64;
        }
        stats
    }
}

/// One flight of a photon path through the box: from `ray.origin` along `ray.direction`
/// carrying `power`, over `[t0, t1]` (the box, clipped), ending at the interaction `hit`
/// (or leaving the box when `None`).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Flight {
    pub(crate) ray: Ray,
    pub(crate) power: Vec3,
    pub(crate) t0: f32,
    pub(crate) t1: f32,
    pub(crate) hit: Option<f32>,
    /// The direction the path went on in after `hit`, when it scattered there.
    pub(crate) next: Option<Vec3>,
}

/// What a photon path is recorded as: stored photons at its interactions, or its flights.
pub(crate) trait PathRecord {
    /// An interaction at `position`, reached along `direction` with `power`, after
    /// `scattered` scatterings.
    fn interaction(
        &mut self,
        medium: &Medium,
        position: Vec3,
        direction: Vec3,
        power: Vec3,
        scattered: u32,
    );
    /// A flight through the box, once its end is known.
    fn flight(&mut self, flight: &Flight);
}

#[derive(Default)]
struct Chunk {
    photons: Vec<Photon>,
    /// Photons stored per light, indexed by light (grown on demand).
    stored_per_light: Vec<u64>,
    counters: PathCounters,
}

impl PathRecord for Vec<Photon> {
    /// Stores a photon at every interaction after the first scattering: direct light is
    /// left to ray marching.
    fn interaction(
        &mut self,
        medium: &Medium,
        position: Vec3,
        direction: Vec3,
        power: Vec3,
        scattered: u32,
    ) {
        if scattered >= 1 {
            self.push(Photon {
                position,
                direction,
                power,
                sigma_t: medium.sigma_t(position),
            });
        }
    }

    fn flight(&mut self, _: &Flight) {}
}

/// Traces photons from every light through the medium and returns the stored photons in
/// photon-index order with statistics. `control`'s time limit is checked between chunks
/// of 1024 photons.
///
/// With a stored target (`settings.stored_target > 0`, as Jensen's photon map and pbrt
/// fill a map to a size rather than shoot a count), the first round emits
/// `settings.photons`; while the map is outside `[target, 1.1 × target]` the next round
/// traces again from the start with the count the last round's stored fraction says lands
/// 5 % above the target (twice as many when nothing was stored), up to [`MAX_PHOTONS`]
/// (the bound of `volume_photons`): a scene whose lights barely reach the medium stops
/// there with fewer stored than the target, and a render warning says so. After
/// `MAX_ROUNDS` (8) rounds the last that reached the target is kept (else the largest).
/// Every round is an ordinary trace of its count, so the map is the one that count gives — powers still
/// divided by each light's emitted count (§7.1.2), independent of the threads — and
/// [`PhotonStats::rounds`] says how many it took.
pub fn trace(
    medium: &Medium,
    lights: &[Light],
    settings: &TraceSettings,
    control: &Control<'_>,
) -> Result<(Vec<Photon>, PhotonStats)> {
    let start = Instant::now();
    let target = settings.stored_target;
    let mut emitted = settings.photons;
    let mut kept: Option<(Vec<Photon>, PhotonStats)> = None;
    for round in 1..=MAX_ROUNDS {
        let (photons, mut stats) = trace_once(
            medium,
            lights,
            &TraceSettings {
                photons: emitted,
                ..*settings
            },
            control,
        )?;
        let next = next_emission(emitted, stats.stored, target);
        if target > 0 {
            stats.stored_target = target;
            stats.rounds = round;
        }
        // A round that reaches the target replaces any; one that does not replaces only a
        // round that stored fewer (the last of several short rounds is the largest).
        let better = kept.as_ref().is_none_or(|(_, k)| {
            stats.stored >= target || (k.stored < target && stats.stored > k.stored)
        });
        if better {
            kept = Some((photons, stats));
        }
        match next {
            Some(n) if round < MAX_ROUNDS => emitted = n,
            _ => break,
        }
    }
    let (photons, mut stats) = kept.expect("at least one round");
    stats.seconds = start.elapsed().as_secs_f64();
    Ok((photons, stats))
}

/// The most rounds a stored target may take (the count is predicted from the last round's
/// stored fraction, so two or three usually do).
pub const MAX_ROUNDS: u32 = 8;

/// The next round's emitted count for a stored `target`, or `None` when this round's
/// `stored` lies in `[target, 1.1 × target]` (or no target is set), or when more are
/// needed but `emitted` is already [`MAX_PHOTONS`].
fn next_emission(emitted: u64, stored: u64, target: u64) -> Option<u64> {
    let in_range = stored >= target && stored as f64 <= 1.1 * target as f64;
    if target == 0 || in_range || (stored < target && emitted >= MAX_PHOTONS) {
        return None;
    }
    let predicted = if stored == 0 {
        emitted.saturating_mul(2)
    } else {
        // 5 % beyond the count the stored fraction predicts, so the next round's own noise
        // rarely leaves it short.
        (emitted as f64 * target as f64 / stored as f64 * 1.05).ceil() as u64
    };
    let next = predicted.clamp(1, MAX_PHOTONS);
    // A round that would trace the same count again cannot do better.
    (next != emitted).then_some(next)
}

/// One round of [`trace`]: `settings.photons` emitted.
fn trace_once(
    medium: &Medium,
    lights: &[Light],
    settings: &TraceSettings,
    control: &Control<'_>,
) -> Result<(Vec<Photon>, PhotonStats)> {
    trace_aimed(medium, lights, &emission_target(medium), settings, control)
}

/// [`trace_once`] with photons from lights with extent aimed at `target`.
fn trace_aimed(
    medium: &Medium,
    lights: &[Light],
    target: &Sphere,
    settings: &TraceSettings,
    control: &Control<'_>,
) -> Result<(Vec<Photon>, PhotonStats)> {
    let (chunk, total, per_light) = trace_chunks(
        lights,
        target,
        settings,
        control,
        |photon, chunk: &mut Chunk| {
            let light = photon.light_index;
            let before = chunk.photons.len();
            walk_path(
                medium,
                photon,
                settings,
                &mut chunk.photons,
                &mut chunk.counters,
            );
            let stored = (chunk.photons.len() - before) as u64;
            if stored > 0 {
                if chunk.stored_per_light.len() <= light {
                    chunk.stored_per_light.resize(light + 1, 0);
                }
                chunk.stored_per_light[light] += stored;
            }
        },
        |all: &mut Chunk, other: Chunk| {
            all.photons.extend(other.photons);
            if all.stored_per_light.len() < other.stored_per_light.len() {
                all.stored_per_light.resize(other.stored_per_light.len(), 0);
            }
            for (a, b) in all.stored_per_light.iter_mut().zip(other.stored_per_light) {
                *a += b;
            }
            all.counters.merge(other.counters);
        },
    )?;
    let mut stats = chunk.counters.stats(total, per_light);
    for (s, c) in stats
        .stored_per_light
        .iter_mut()
        .zip(chunk.stored_per_light)
    {
        *s = c;
    }
    let photons = chunk.photons;
    stats.stored = photons.len() as u64;
    stats.stored_power = photons
        .iter()
        .map(|p| (p.power.x as f64 + p.power.y as f64 + p.power.z as f64) / 3.0)
        .sum();
    Ok((photons, stats))
}

/// Where the photons of `medium`'s lights with extent are aimed: the sphere around what
/// can scatter ([`Medium::scattering_sphere`]; around the box when nothing can).
pub(crate) fn emission_target(medium: &Medium) -> Sphere {
    medium
        .scattering_sphere()
        .unwrap_or_else(|| Sphere::around(&medium.bounds()))
}

/// Photon `index` leaving its light: the light (and its place in the scene's list), its
/// power share, where it is aimed, and its random stream.
pub(crate) struct Emitted<'a> {
    pub(crate) light: &'a Light,
    pub(crate) light_index: usize,
    pub(crate) power: Vec3,
    pub(crate) target: &'a Sphere,
    pub(crate) index: u64,
}

/// Runs `one` for every emitted photon, in parallel chunks of 1024 photons (the time limit
/// checked between them), and joins the chunks in photon-index order with `join`. Returns
/// the joined record, the photons emitted and their split over the lights.
pub(crate) fn trace_chunks<C: Default + Send>(
    lights: &[Light],
    target: &Sphere,
    settings: &TraceSettings,
    control: &Control<'_>,
    one: impl Fn(Emitted<'_>, &mut C) + Sync,
    join: impl Fn(&mut C, C),
) -> Result<(C, u64, Vec<u64>)> {
    let per_light = photons_per_light(lights, target, settings.photons);
    // Each photon's share of its light's power towards the target.
    let shares: Vec<Vec3> = lights
        .iter()
        .zip(&per_light)
        .map(|(l, &n)| l.emitted_power(target) / n.max(1) as f32)
        .collect();
    // Photon i belongs to the first light whose cumulative count exceeds i.
    let ends: Vec<u64> = per_light
        .iter()
        .scan(0u64, |acc, &n| {
            *acc += n;
            Some(*acc)
        })
        .collect();
    let total = ends.last().copied().unwrap_or(0);
    const CHUNK: u64 = 1024;
    let chunks: Vec<C> = (0..total.div_ceil(CHUNK))
        .into_par_iter()
        .map(|c| {
            let mut chunk = C::default();
            if control.expired() {
                return chunk;
            }
            for i in c * CHUNK..((c + 1) * CHUNK).min(total) {
                let light_index = ends.partition_point(|&e| e <= i);
                let light = &lights[light_index];
                one(
                    Emitted {
                        light,
                        light_index,
                        power: shares[light_index],
                        target,
                        index: i,
                    },
                    &mut chunk,
                );
            }
            chunk
        })
        .collect();
    control.check()?;
    let mut joined = C::default();
    for c in chunks {
        join(&mut joined, c);
    }
    Ok((joined, total, per_light))
}

/// Follows one photon from its light through the medium (free paths by the settings' rule,
/// Russian roulette with the albedo, phase-function scattering), telling `record` of every
/// interaction and flight. The path draws from the stream `(seed, Photons, index)` alone.
pub(crate) fn walk_path(
    medium: &Medium,
    photon: Emitted<'_>,
    s: &TraceSettings,
    record: &mut impl PathRecord,
    out: &mut PathCounters,
) {
    let mut rng = Rng::stream(s.seed, Domain::Photons, photon.index);
    let (mut ray, relative_power) = photon.light.emit(&mut rng, photon.target);
    let mut power = photon.power * relative_power;
    let mut scattered = 0u32;
    let mut interactions = 0u32;
    while let Some((t0, t1)) = medium.clip(&ray) {
        let mut flight = Flight {
            ray,
            power,
            t0,
            t1,
            hit: None,
            next: None,
        };
        flight.hit = medium.sample_free_path(s.free_path, &ray, t0, t1, s.stepsize, &mut rng);
        let Some(t) = flight.hit else {
            record.flight(&flight);
            break;
        };
        let position = ray.at(t);
        // The empirical mean free path counts flights between interactions; the first
        // flight, from where the photon entered the box, mostly crosses empty space.
        if interactions > 0 {
            out.flights.push(t - t0);
        }
        interactions += 1;
        record.interaction(medium, position, ray.direction, power, scattered);
        if interactions >= MAX_INTERACTIONS {
            record.flight(&flight);
            out.truncated += 1;
            out.interactions += interactions as u64;
            return;
        }
        // Russian roulette with the albedo (§5.1), re-weighting by albedo / survive to keep
        // each channel's expected power (for a coloured albedo no channel's power grows).
        let albedo = medium.albedo_at(position);
        let survive = crate::medium::survival_probability(albedo);
        if rng.uniform() >= survive {
            record.flight(&flight);
            out.absorbed += 1;
            out.interactions += interactions as u64;
            return;
        }
        power *= albedo / survive;
        scattered += 1;
        let direction = medium.phase().sample(ray.direction, rng.uniform2());
        flight.next = Some(direction);
        record.flight(&flight);
        ray = Ray::new(position, direction);
    }
    if interactions == 0 {
        out.escaped += 1;
    }
    out.interactions += interactions as u64;
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Aabb;
    use crate::medium::FreePath;
    use crate::scene::{Intensity, LightParams};

    fn point(intensity: f32) -> Light {
        Light::create(&LightParams {
            kind: crate::scene::LightKind::Point,
            position: Some([0.5, 0.5, 3.0]),
            intensity: Some(Intensity::Grey(intensity)),
            ..LightParams::default()
        })
        .unwrap()
    }

    /// Photons through the spot-lit sphere at σt = 20 with an explicit split per channel.
    fn dense_sphere_photons(albedo: [f32; 3]) -> (Vec<Photon>, Vec3) {
        let scene = crate::test_util::spot_sphere_with_albedo(20.0, albedo);
        let settings = TraceSettings {
            photons: 20_000,
            stored_target: 0,
            free_path: FreePath::Delta,
            stepsize: 0.002,
            seed: 5,
        };
        let (photons, _) =
            trace(scene.medium(), scene.lights(), &settings, &Control::none()).expect("traced");
        let emitted = scene.lights()[0].power() / settings.photons as f32;
        (photons, emitted)
    }

    #[test]
    fn a_coloured_albedo_never_raises_a_photons_power_and_keeps_each_channels_total() {
        let albedo = [0.9, 0.3, 0.1];
        let (photons, emitted) = dense_sphere_photons(albedo);
        let total: Vec3 = photons.iter().map(|p| p.power).sum();
        for p in &photons {
            assert!(
                p.power.cmple(emitted * (1.0 + 1e-5)).all(),
                "{} > {emitted}",
                p.power
            );
        }
        // Extinction is grey, so each channel carries what the grey medium of its albedo
        // stores (20 000 photons: a few per cent of noise on the dimmest channel).
        for (c, a) in albedo.into_iter().enumerate() {
            let (grey, _) = dense_sphere_photons([a; 3]);
            let grey_total: f32 = grey.iter().map(|p| p.power[c]).sum();
            assert!(
                (total[c] / grey_total - 1.0).abs() < 0.05,
                "channel {c}: {} vs grey {grey_total}",
                total[c]
            );
        }
    }

    /// The unit cube cropped and cut by an oblique plane (a corner of it kept), σt
    /// `sigma_t`, albedo 0.8, under a grey uniform sky of radiance 0.7.
    fn clipped_cube_under_a_uniform_sky(sigma_t: f32) -> crate::Scene {
        crate::test_util::scene(&clipped_cube_source(sigma_t))
    }

    fn clipped_cube_source(sigma_t: f32) -> String {
        format!(
            r#"
[volume]
phantom = {{ name = "constant", resolution = [16, 16, 16] }}
[sigma]
t = {sigma_t}
albedo = 0.8
[clip]
box = {{ p0 = [0.2, 0.2, 0.2], p1 = [1, 1, 1] }}
plane = {{ normal = [1, 1, 1], offset = 1.8 }}
[camera]
eye = [-3, 0.5, 0.5]
look_at = [0.5, 0.5, 0.5]
up = [0, 0, 1]
[[lights]]
type = "sky"
zenith = 0.7
horizon = 0.7
ground = 0.7"#
        )
    }

    fn settings(photons: u64, seed: u64) -> TraceSettings {
        TraceSettings {
            photons,
            stored_target: 0,
            free_path: FreePath::Delta,
            stepsize: 0.002,
            seed,
        }
    }

    /// Mean and standard error of per-photon values.
    fn mean_and_error(values: &[f64]) -> (f64, f64) {
        let n = values.len() as f64;
        let mean = values.iter().sum::<f64>() / n;
        let var = values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0);
        (mean, (var / n).sqrt())
    }

    /// Σ ΔΦ·ℓ over the emitted photons, ℓ each one's chord through the kept region, as
    /// one value per photon (times the photon count, so the mean estimates the sum).
    fn track_lengths(scene: &crate::Scene, target: &Sphere, n: u64) -> Vec<f64> {
        let medium = scene.medium();
        let (chunk, _, _) = trace_chunks(
            scene.lights(),
            target,
            &settings(n, 3),
            &Control::none(),
            |photon, values: &mut Vec<f64>| {
                let mut rng = Rng::stream(3, Domain::Photons, photon.index);
                let (ray, relative) = photon.light.emit(&mut rng, photon.target);
                let chord = medium.clip(&ray).map_or(0.0, |(t0, t1)| t1 - t0);
                let power = photon.power * relative;
                let power = (power.x + power.y + power.z) as f64 / 3.0;
                values.push(power * chord as f64 * n as f64);
            },
            |all: &mut Vec<f64>, other| all.extend(other),
        )
        .unwrap();
        chunk
    }

    /// Under a uniform sky of radiance L the uncollided fluence integrated over a convex
    /// region is `4π·L·V` (Cauchy: every direction's chords sum to V). The photons aimed at
    /// the clipped cube's sphere carry exactly that in `Σ ΔΦ·ℓ`, as do those spread over
    /// the whole box's sphere — with less noise, since fewer miss.
    #[test]
    fn aimed_sky_photons_carry_the_closed_form_fluence_into_a_clipped_cube() {
        let scene = clipped_cube_under_a_uniform_sky(2.0);
        let volume = scene.medium().clip_region().unwrap().volume() as f64;
        let exact = 4.0 * std::f64::consts::PI * 0.7 * volume;
        let aimed = emission_target(scene.medium());
        let whole = Sphere::around(&scene.medium().bounds());
        assert!(aimed.radius < 0.8 * whole.radius, "{aimed:?} vs {whole:?}");
        let mut errors = Vec::new();
        for target in [aimed, whole] {
            let (mean, error) = mean_and_error(&track_lengths(&scene, &target, 200_000));
            assert!(
                (mean - exact).abs() < 4.0 * error,
                "Σ ΔΦ·ℓ = {mean} ± {error} against 4πLV = {exact} ({target:?})"
            );
            assert!(error < 0.01 * exact, "{error}");
            errors.push(error);
        }
        assert!(errors[0] < errors[1], "aimed {errors:?}");
    }

    /// An area light's photons aimed at the cube's sphere carry the same `Σ ΔΦ·ℓ` as its
    /// cosine-weighted photons (a target the light cannot aim at), with less noise.
    #[test]
    fn aimed_area_light_photons_carry_what_cosine_weighted_ones_do() {
        let sky = "[[lights]]\ntype = \"sky\"\nzenith = 0.7\nhorizon = 0.7\nground = 0.7";
        let rect = "[[lights]]\ntype = \"rect\"\nposition = [0.3, 0.4, 2.5]\ntarget = [0.5, 0.5, 0.5]\nsize = [0.8, 0.5]\nradiance = 3";
        let src = clipped_cube_source(2.0).replace(sky, rect);
        let scene = crate::test_util::scene(&src);
        let aimed = emission_target(scene.medium());
        let cosine = Sphere {
            centre: Vec3::new(0.3, 0.4, 2.5),
            radius: 10.0,
        };
        let (a, ea) = mean_and_error(&track_lengths(&scene, &aimed, 200_000));
        let (c, ec) = mean_and_error(&track_lengths(&scene, &cosine, 200_000));
        assert!(
            (a - c).abs() < 4.0 * (ea * ea + ec * ec).sqrt(),
            "aimed {a} ± {ea}, cosine-weighted {c} ± {ec}"
        );
        assert!(ea < 0.5 * ec, "aimed ± {ea}, cosine ± {ec}");
    }

    /// The stored map of photons aimed at the kept region against the one spread over the
    /// box's sphere: the same stored power and centroid within the noise over seeds, and
    /// more photons stored for the same emitted count.
    #[test]
    fn aimed_and_whole_box_emission_store_the_same_map_within_noise() {
        let scene = clipped_cube_under_a_uniform_sky(4.0);
        let (medium, lights) = (scene.medium(), scene.lights());
        let targets = [emission_target(medium), Sphere::around(&medium.bounds())];
        let runs: Vec<Vec<[f64; 3]>> = targets
            .iter()
            .map(|target| {
                (0..8)
                    .map(|seed| {
                        let (photons, stats) = trace_aimed(
                            medium,
                            lights,
                            target,
                            &settings(20_000, seed),
                            &Control::none(),
                        )
                        .unwrap();
                        let power: f64 = photons.iter().map(|p| p.power.x as f64).sum();
                        let centroid = |axis: usize| {
                            photons
                                .iter()
                                .map(|p| (p.power.x * p.position[axis]) as f64)
                                .sum::<f64>()
                                / power
                        };
                        assert_eq!(stats.stored_per_light, vec![stats.stored]);
                        [power, centroid(0), stats.stored as f64]
                    })
                    .collect()
            })
            .collect();
        for (k, what) in ["stored power", "centroid x"].iter().enumerate() {
            let a: Vec<f64> = runs[0].iter().map(|r| r[k]).collect();
            let b: Vec<f64> = runs[1].iter().map(|r| r[k]).collect();
            let ((ma, ea), (mb, eb)) = (mean_and_error(&a), mean_and_error(&b));
            assert!(
                (ma - mb).abs() < 4.0 * (ea * ea + eb * eb).sqrt(),
                "{what}: aimed {ma} ± {ea}, whole box {mb} ± {eb}"
            );
        }
        // Stored photons grow with the disc's area the photons cross, `πR²`.
        let stored = |r: &Vec<[f64; 3]>| r.iter().map(|x| x[2]).sum::<f64>();
        let area_ratio = (targets[1].radius / targets[0].radius).powi(2) as f64;
        assert!(area_ratio > 1.2, "{targets:?}");
        let ratio = stored(&runs[0]) / stored(&runs[1]);
        assert!(
            (ratio / area_ratio - 1.0).abs() < 0.05,
            "{ratio} vs {area_ratio}"
        );
    }

    /// A stored target traces until the map holds it, and no more than a tenth beyond it —
    /// from a first round that stores too few and from one that stores too many; the map is
    /// the one the final emitted count gives on its own.
    #[test]
    fn a_stored_target_is_reached_and_equals_a_plain_trace_of_its_count() {
        for (first, target) in [(1_000, 6_000), (60_000, 3_000)] {
            stored_target_reached(first, target);
        }
    }

    fn stored_target_reached(first: u64, target: u64) {
        let scene = clipped_cube_under_a_uniform_sky(4.0);
        let (medium, lights) = (scene.medium(), scene.lights());
        let asked = TraceSettings {
            stored_target: target,
            ..settings(first, 5)
        };
        let (photons, stats) = trace(medium, lights, &asked, &Control::none()).unwrap();
        assert!(
            stats.stored >= target && stats.stored as f64 <= 1.1 * target as f64,
            "{} for {target}",
            stats.stored
        );
        assert!(stats.rounds >= 2 && stats.stored_target == target);
        let (plain, plain_stats) = trace(
            medium,
            lights,
            &settings(stats.emitted, 5),
            &Control::none(),
        )
        .unwrap();
        assert_eq!(photons, plain);
        assert_eq!(plain_stats.rounds, 0);
        assert_eq!(stats.stored_per_light, plain_stats.stored_per_light);
    }

    #[test]
    fn the_next_round_emits_what_the_stored_fraction_predicts_up_to_the_cap() {
        assert_eq!(next_emission(1_000, 1_500, 1_500), None);
        assert_eq!(next_emission(1_000, 1_650, 1_500), None);
        assert_eq!(next_emission(1_000, 100, 0), None);
        assert_eq!(next_emission(1_000, 100, 1_500), Some(15_750));
        assert_eq!(next_emission(1_000, 0, 1_500), Some(2_000));
        assert_eq!(next_emission(1_000, 1_499, 1_500), Some(1_051));
        // Too many stored: fewer emitted next time.
        assert_eq!(next_emission(40_000, 23_682, 13_514), Some(23_968));
        assert_eq!(next_emission(MAX_PHOTONS - 5, 1, 1_500), Some(MAX_PHOTONS));
        assert_eq!(next_emission(MAX_PHOTONS, 1, 1_500), None);
    }

    #[test]
    fn photons_split_by_power() {
        let lights = [point(1.0), point(3.0), point(0.0001)];
        let counts = photons_per_light(&lights, &Sphere::around(&Aabb::unit()), 1001);
        assert_eq!(counts.iter().sum::<u64>(), 1001);
        assert_eq!(counts[1], 751, "largest remainder gets the leftover photon");
        assert_eq!(counts[0], 250);
    }
}
