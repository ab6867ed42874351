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
use crate::math::{Domain, Ray, Rng};
use crate::medium::{FreePath, Medium};
use crate::scene::Light;

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

/// Interactions after which a photon is stopped (counted in [`PhotonStats::truncated`]).
pub const MAX_INTERACTIONS: u32 = 100_000;

/// The photon-tracing settings taken from the scene.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TraceSettings {
    /// Photons emitted in total.
    pub photons: u64,
    /// Free-path rule.
    pub free_path: FreePath,
    /// Step for the `march` and `thesis` rules.
    pub stepsize: f32,
    /// Random seed.
    pub seed: u64,
}

/// Splits `total` photons over lights in proportion to their power (largest remainders),
/// so photons carry equal energies (§7.1.2).
pub fn photons_per_light(lights: &[Light], total: u64) -> Vec<u64> {
    let powers: Vec<f64> = lights
        .iter()
        .map(|l| {
            let p = l.power();
            (p.x as f64 + p.y as f64 + p.z as f64) / 3.0
        })
        .collect();
    let sum: f64 = powers.iter().sum();
    if sum <= 0.0 || lights.is_empty() {
        return vec![0; lights.len()];
    }
    let exact: Vec<f64> = powers.iter().map(|p| total as f64 * p / sum).collect();
    let mut counts: Vec<u64> = exact.iter().map(|e| e.floor() as u64).collect();
    let mut remainder = total - counts.iter().sum::<u64>();
    let mut order: Vec<usize> = (0..lights.len()).collect();
    order.sort_by(|&a, &b| {
        (exact[b] - exact[b].floor())
            .partial_cmp(&(exact[a] - exact[a].floor()))
            .unwrap_or(std::cmp::Ordering::Equal)
            .then(a.cmp(&b))
    });
    for &i in order.iter().cycle() {
        if remainder == 0 {
            break;
        }
        counts[i] += 1;
        remainder -= 1;
    }
    counts
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
        let mut stats = PhotonStats {
            emitted: total,
            emitted_per_light: per_light,
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
pub fn trace(
    medium: &Medium,
    lights: &[Light],
    settings: &TraceSettings,
    control: &Control<'_>,
) -> Result<(Vec<Photon>, PhotonStats)> {
    let start = Instant::now();
    let (chunk, total, per_light) = trace_chunks(
        lights,
        settings,
        control,
        |photon, chunk: &mut Chunk| {
            walk_path(
                medium,
                photon,
                settings,
                &mut chunk.photons,
                &mut chunk.counters,
            )
        },
        |all: &mut Chunk, other: Chunk| {
            all.photons.extend(other.photons);
            all.counters.merge(other.counters);
        },
    )?;
    let mut stats = chunk.counters.stats(total, per_light);
    let photons = chunk.photons;
    stats.stored = photons.len() as u64;
    stats.stored_power = photons
        .iter()
        .map(|p| (p.power.x as f64 + p.power.y as f64 + p.power.z as f64) / 3.0)
        .sum();
    stats.seconds = start.elapsed().as_secs_f64();
    Ok((photons, stats))
}

/// Photon `index` leaving its light: the light, its power share, and its random stream.
pub(crate) struct Emitted<'a> {
    pub(crate) light: &'a Light,
    pub(crate) power: Vec3,
    pub(crate) index: u64,
}

/// Runs `one` for every emitted photon, in parallel chunks of 1024 photons (the time limit
/// checked between them), and joins the chunks in photon-index order with `join`. Returns
/// the joined record, the photons emitted and their split over the lights.
pub(crate) fn trace_chunks<C: Default + Send>(
    lights: &[Light],
    settings: &TraceSettings,
    control: &Control<'_>,
    one: impl Fn(Emitted<'_>, &mut C) + Sync,
    join: impl Fn(&mut C, C),
) -> Result<(C, u64, Vec<u64>)> {
    let per_light = photons_per_light(lights, settings.photons);
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
                let power = light.power() / per_light[light_index] as f32;
                one(
                    Emitted {
                        light,
                        power,
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
    let (mut ray, relative_power) = photon.light.emit(&mut rng);
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

    #[test]
    fn photons_split_by_power() {
        let lights = [point(1.0), point(3.0), point(0.0001)];
        let counts = photons_per_light(&lights, 1001);
        assert_eq!(counts.iter().sum::<u64>(), 1001);
        assert_eq!(counts[1], 751, "largest remainder gets the leftover photon");
        assert_eq!(counts[0], 250);
    }
}
