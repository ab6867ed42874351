//! The unbiased reference: a volumetric path tracer for the same scenes.
//!
//! Two trackers sample its paths (`[integrator] tracker`, both unbiased):
//!
//! * [`weighted`] (the default since issue #47): delta tracking to each real collision;
//!   single scattering from every light with the albedo as a weight; later vertices
//!   survival-biased (throughput × albedo, Russian roulette only below a threshold) with
//!   next-event estimation to one light chosen by its unshadowed contribution, weighted
//!   against the phase function's direction for lights with extent ([`mis`]); and each
//!   pixel's share of the samples set by a pilot ([`allocation`]);
//! * [`delta`] (`tracker = "delta"`, every reference before it): Russian roulette with the
//!   albedo at every collision, next-event estimation to every light, one sample per
//!   pixel per pass — kept as it was, so its references render again to the bit (lights
//!   with extent by next-event estimation alone).
//!
//! Layers follow the photon integrator's split: light from a path's first scattering
//! vertex is `single`, from later vertices `multiple`; emission seen directly (before any
//! scattering) is `emission`.
//!
//! Rendering is progressive: [`ReferenceAccumulator::add_passes`] adds passes, keeping
//! each pixel's running mean and variance (Welford), so a reference can be refined later
//! and its own noise is known. Sample `k` of pixel `i` always draws from the random stream
//! `(seed, i, k)`, whatever the thread count and however the passes were split.

mod accumulator;
mod allocation;
mod budget;
mod delta;
mod mis;
mod routes;
mod state;
mod weighted;

use glam::Vec3;

pub use accumulator::ReferenceAccumulator;
pub use budget::{
    Budget, CpuSplit, LayerVariance, PixelClass, SOURCES, Source, Variant, reference_budget,
};
pub use routes::Route;

use crate::control::Control;
use crate::counters::{self, Counter};
use crate::error::Result;
use crate::film::Film;
use crate::medium::Medium;
use crate::scene::Scene;

/// Vertices after which a path is stopped (albedo ≈ 1 in a closed medium).
pub const MAX_VERTICES: u32 = 100_000;

/// Radiance of one path, split by layer.
#[derive(Debug, Clone, Copy, Default)]
struct PathSample {
    single: Vec3,
    multiple: Vec3,
    emission: Vec3,
    /// Work units spent (eye rays, vertices, shadow rays): the pilot's measure of a
    /// pixel's cost, the same on every machine and thread count.
    work: u32,
}

/// The emission a first vertex at `x` collects: the collision estimator of ∫ T ε dt, whose
/// collision density is σt·T. Its two density lookups are counted in a counted pass.
fn emission_at(medium: &Medium, x: Vec3) -> Vec3 {
    counters::add(Counter::DensityLookups, 2);
    medium.emission(x) / medium.sigma_t(x)
}

/// The albedo at a vertex `x`, counted as a colour lookup in a counted pass when the
/// medium is coloured.
fn albedo_at(medium: &Medium, x: Vec3) -> Vec3 {
    if medium.has_colour() {
        counters::count(Counter::ColourLookups);
    }
    medium.albedo_at(x)
}

/// Renders a reference image with `passes` passes (samples per pixel, on average by cost
/// when the tracker allocates them).
pub fn render_reference(scene: &Scene, passes: u32, control: &Control<'_>) -> Result<(Film, f64)> {
    let camera = scene.camera();
    let mut acc = ReferenceAccumulator::new(camera.width() as usize, camera.height() as usize);
    let seconds = acc.add_passes(scene, passes, control)?;
    Ok((acc.film(), seconds))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::film::Layer;
    use crate::scene::Tracker;
    use crate::test_util::{SPOT_SPHERE, scene, spot_sphere_with_albedo};

    /// Both trackers, each with its scene.
    fn both(src: &str) -> [(Tracker, Scene); 2] {
        [Tracker::Delta, Tracker::Weighted].map(|t| (t, with_tracker(&scene(src), t)))
    }

    fn with_tracker(scene: &Scene, tracker: Tracker) -> Scene {
        let mut integrator = scene.integrator().clone();
        integrator.tracker = tracker;
        scene.with_integrator(integrator).unwrap()
    }

    fn accumulated(scene: &Scene, passes: u32) -> ReferenceAccumulator {
        let camera = scene.camera();
        let mut acc = ReferenceAccumulator::new(camera.width() as usize, camera.height() as usize);
        acc.add_passes(scene, passes, &Control::none()).unwrap();
        acc
    }

    /// Per channel: the image's mean of the total, and the variance of that mean.
    fn mean_and_variance(scene: &Scene, passes: u32) -> (Vec3, Vec3) {
        let acc = accumulated(scene, passes);
        let total = acc.film().total();
        let n = total.len() as f32;
        let mean = total.iter().sum::<Vec3>() / n;
        let variance = acc.total_variance().unwrap().iter().sum::<Vec3>() / (n * n);
        (mean, variance)
    }

    #[test]
    fn each_channel_of_a_coloured_albedo_renders_as_the_grey_medium_of_its_albedo() {
        // σt = 20 in every channel; albedo (0.9, 0.3, 0.1). Extinction is grey, so each
        // channel's light is the grey medium's with that channel's albedo.
        let albedo = [0.9, 0.3, 0.1];
        let passes = 256;
        for tracker in [Tracker::Delta, Tracker::Weighted] {
            let coloured = with_tracker(&spot_sphere_with_albedo(20.0, albedo), tracker);
            let (mean, variance) = mean_and_variance(&coloured, passes);
            for (c, a) in albedo.into_iter().enumerate() {
                let grey = with_tracker(&spot_sphere_with_albedo(20.0, [a; 3]), tracker);
                let (grey_mean, grey_variance) = mean_and_variance(&grey, passes);
                let z = (mean[c] - grey_mean[c]) / (variance[c] + grey_variance[c]).sqrt();
                assert!(
                    z.abs() < 4.0,
                    "{tracker:?}, channel {c}: {} vs grey {}, z = {z}",
                    mean[c],
                    grey_mean[c]
                );
                // The weights stay bounded: no channel is much noisier than its grey
                // medium (surviving with the channels' mean, red's variance is many times
                // grey 0.9's).
                assert!(
                    variance[c] <= 1.5 * grey_variance[c],
                    "{tracker:?}, channel {c}: variance {} vs grey {}",
                    variance[c],
                    grey_variance[c]
                );
            }
        }
    }

    #[test]
    fn a_state_resumes_to_the_bits_of_one_whole_run() {
        let none = Control::none();
        for (tracker, scene) in both(SPOT_SPHERE) {
            let whole = accumulated(&scene, 9);
            let dir = tempfile::tempdir().unwrap();
            let path = dir.path().join("state.bin");
            let mut resumed = ReferenceAccumulator::new(20, 20);
            for step in [2, 4, 3] {
                resumed.add_passes(&scene, step, &none).unwrap();
                resumed.write_state(&path).unwrap();
                resumed = ReferenceAccumulator::read_state(&path).unwrap();
            }
            assert_eq!(resumed, whole, "{tracker:?}");
            assert_eq!(resumed.film(), whole.film(), "{tracker:?}");
            // The delta tracker's state is the format every earlier release wrote.
            let magic = std::fs::read(&path).unwrap()[..26].to_vec();
            let expected: &[u8] = match tracker {
                Tracker::Delta => b"volphot reference state 1\n",
                Tracker::Weighted => b"volphot reference state 2\n",
            };
            assert_eq!(magic, expected, "{tracker:?}");
            // Through a film the sums come back only to rounding: the reason for the state.
            let through_film = accumulated(&scene, 4);
            let mut through_film =
                ReferenceAccumulator::resume(&scene, &through_film.film(), 4).unwrap();
            through_film.add_passes(&scene, 5, &none).unwrap();
            assert_ne!(through_film, whole, "{tracker:?}");
        }
    }

    #[test]
    fn a_damaged_state_is_refused_naming_the_file() {
        for (tracker, scene) in both(SPOT_SPHERE) {
            let acc = accumulated(&scene, 2);
            let dir = tempfile::tempdir().unwrap();
            let path = dir.path().join("state.bin");
            acc.write_state(&path).unwrap();
            let bytes = std::fs::read(&path).unwrap();
            std::fs::write(&path, &bytes[..bytes.len() - 1]).unwrap();
            let err = ReferenceAccumulator::read_state(&path)
                .unwrap_err()
                .to_string();
            assert!(
                err.contains("state.bin") && err.contains("20×20"),
                "{tracker:?}: {err}"
            );
            std::fs::write(&path, b"P6 not a state").unwrap();
            let err = ReferenceAccumulator::read_state(&path)
                .unwrap_err()
                .to_string();
            assert!(err.contains("not a reference accumulator state"), "{err}");
        }
        // A share of the samples that is not a positive number.
        let acc = accumulated(&scene(SPOT_SPHERE), 2);
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("state.bin");
        acc.write_state(&path).unwrap();
        let mut bytes = std::fs::read(&path).unwrap();
        let last = bytes.len() - 4;
        bytes[last..].copy_from_slice(&(-1.0f32).to_le_bytes());
        std::fs::write(&path, &bytes).unwrap();
        let err = ReferenceAccumulator::read_state(&path)
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("state.bin") && err.contains("share") && err.contains("-1"),
            "{err}"
        );
    }

    #[test]
    fn the_total_variance_survives_a_film_and_a_resume() {
        let none = Control::none();
        for (tracker, scene) in both(SPOT_SPHERE) {
            let whole = accumulated(&scene, 8);
            let first = accumulated(&scene, 5);
            // Through an EXR, as the sweep refines a reference in place.
            let dir = tempfile::tempdir().unwrap();
            let path = dir.path().join("reference.exr");
            first.film().write_exr(&path).unwrap();
            let mut resumed =
                ReferenceAccumulator::resume(&scene, &Film::read_exr(&path).unwrap(), 5).unwrap();
            resumed.add_passes(&scene, 3, &none).unwrap();
            let (a, b) = (
                whole.total_variance().unwrap(),
                resumed.total_variance().unwrap(),
            );
            for (x, y) in a.iter().zip(&b) {
                assert!(
                    (*x - *y).abs().max_element() <= 1e-5 * x.max_element().max(1e-6),
                    "{tracker:?}: {x} {y}"
                );
            }
            // The total's variance is not the layers' sum: one path feeds both layers.
            let film = whole.film();
            let summed: Vec<Vec3> = (film.variance(Layer::Single).unwrap().iter())
                .zip(film.variance(Layer::Multiple).unwrap())
                .map(|(s, m)| *s + *m)
                .collect();
            assert_ne!(summed, a);
            // Emission is black here, so single + multiple is the total.
            let both = film.variance_of_sum(&[Layer::Single, Layer::Multiple]);
            assert_eq!(both.as_deref(), Some(a.as_slice()));
            // A film without the total's variance (written before it was kept) resumes
            // without.
            let layers_only = Film::from_layers(
                20,
                20,
                std::array::from_fn(|i| film.layer(Layer::ALL[i]).to_vec()),
            )
            .with_variance(std::array::from_fn(|i| {
                film.variance(Layer::ALL[i]).unwrap().to_vec()
            }));
            assert_eq!(
                layers_only.variance_of_sum(&[Layer::Single, Layer::Multiple]),
                Some(summed),
                "without the total's variance: the layers' sum"
            );
            assert!(
                ReferenceAccumulator::resume(&scene, &layers_only, 8)
                    .unwrap()
                    .total_variance()
                    .is_none()
            );
        }
    }

    #[test]
    fn counting_changes_no_bit_and_counts_the_same_on_any_thread_count() {
        use crate::counters::{Counter, Counting, Counts};
        for (tracker, scene) in both(SPOT_SPHERE) {
            let plain = accumulated(&scene, 3);
            let counted = |threads: usize| -> (ReferenceAccumulator, Counts) {
                let counting = Counting::new();
                let control = Control::none().with_counting(&counting);
                let pool = rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .build()
                    .unwrap();
                let acc = pool.install(|| {
                    let mut acc = ReferenceAccumulator::new(20, 20);
                    acc.add_passes(&scene, 3, &control).unwrap();
                    acc
                });
                (acc, counting.total())
            };
            let (one, counts) = counted(1);
            let (two, counts_on_two) = counted(2);
            assert_eq!(one, plain, "{tracker:?}: one thread, counted");
            assert_eq!(two, plain, "{tracker:?}: two threads, counted");
            assert_eq!(counts, counts_on_two, "{tracker:?}");
            // Every sample of the passes (not the pilot's) is counted, once.
            let samples: u64 = plain
                .samples_per_pixel()
                .iter()
                .map(|&n| u64::from(n))
                .sum();
            assert_eq!(counts.get(Counter::Samples), samples, "{tracker:?}");
            for c in [
                Counter::FreePathWalks,
                Counter::NullCollisions,
                Counter::RealCollisions,
                Counter::RatioSteps,
                Counter::BricksStepped,
                Counter::ShadowRays,
            ] {
                assert!(counts.get(c) > 0, "{tracker:?}: no {c:?} in {counts:?}");
            }
            // In a grey medium without emission every density lookup is one tentative
            // collision's.
            let tentative = counts.get(Counter::NullCollisions)
                + counts.get(Counter::RealCollisions)
                + counts.get(Counter::RatioSteps);
            assert_eq!(
                counts.get(Counter::DensityLookups),
                tentative,
                "{tracker:?}"
            );
            assert_eq!(counts.get(Counter::ColourLookups), 0, "{tracker:?}");
        }
    }

    #[test]
    fn the_pilot_gives_the_medium_more_samples_than_empty_space() {
        // SPOT_SPHERE: a sphere in the middle of the frame, black around it.
        let (_, weighted) = both(SPOT_SPHERE).into_iter().nth(1).unwrap();
        let acc = accumulated(&weighted, 16);
        let samples = acc.samples_per_pixel();
        let centre = samples[10 * 20 + 10];
        let corner = samples[0];
        assert!(centre > 2 * corner, "centre {centre}, corner {corner}");
        // Every pixel keeps at least two samples, so its variance is known.
        assert!(samples.iter().all(|n| *n >= 2), "{samples:?}");
        // The delta tracker takes one sample per pixel per pass.
        let (_, delta) = both(SPOT_SPHERE).into_iter().next().unwrap();
        assert!(
            accumulated(&delta, 16)
                .samples_per_pixel()
                .iter()
                .all(|n| *n == 16)
        );
    }
}
