//! How much marching an image will take, measured before rendering it.
//!
//! The marching integrator's cost grows with its samples: each sample with σt > 0 is shaded
//! for every light and gathered once (§6). How many samples an eye ray takes depends on the
//! volume, the transfer function and σt: a dense medium stops the march early at
//! `termination`, a thin one lets it cross the whole volume. Counting them on a coarse grid
//! of eye rays is cheap (no shading, no photons) and gives a planner the scene's own scale.

use super::marcher::Marcher;
use super::sample::Accumulator;
use super::thinning::Bands;
use crate::math::{Domain, Rng};
use crate::scene::Scene;

/// What a probe measured per eye ray.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EyeProbe {
    /// Marching samples (σt > 0).
    pub samples: f64,
    /// Photon-map gathers per map: the samples, or fewer where `thin_below` spaces them out
    /// behind the front (counted as where the estimate is smooth: where a checked midpoint
    /// disagrees, a render gathers more).
    pub gathers: f64,
}

/// The mean number of marching samples (σt > 0) and of gathers per eye ray, over `rays` ×
/// `rays` eye rays spread evenly over the image, each at a pixel's centre. Deterministic:
/// the rays and each ray's random offset depend only on the scene's seed.
///
/// ```
/// use std::path::Path;
/// use volphot::{Scene, SceneParams, SearchPath, probe_eye_rays};
/// let src = "[volume]\nphantom = { name = \"sphere\", resolution = [16, 16, 16] }\n[three_point]\n";
/// let params = SceneParams::from_toml(src, Path::new("sphere.toml")).unwrap();
/// let scene = Scene::from_params(&params, Path::new("."), &SearchPath::new(vec![])).unwrap();
/// let probe = probe_eye_rays(&scene, 8);
/// assert!(probe.samples > 0.0);
/// assert!(probe.gathers <= probe.samples, "thinned behind the front (the default)");
/// assert_eq!(probe, probe_eye_rays(&scene, 8));
/// ```
pub fn probe_eye_rays(scene: &Scene, rays: u32) -> EyeProbe {
    let settings = scene.integrator();
    let marcher = Marcher::probe(scene);
    let camera = scene.camera();
    let (width, height) = (camera.width() as f32, camera.height() as f32);
    let rays = rays.max(1);
    let mut acc = Accumulator::new(0, 0, 0);
    let (mut samples, mut gathers) = (0u64, 0u64);
    for j in 0..rays {
        for i in 0..rays {
            let (x, y) = (
                (i as f32 + 0.5) / rays as f32 * width,
                (j as f32 + 0.5) / rays as f32 * height,
            );
            let ray = camera.ray(x, y);
            let mut rng = Rng::stream2(settings.seed, Domain::Pixels, (j * rays + i) as u64, 0);
            marcher.collect_samples(&ray, &mut rng, &mut acc);
            samples += acc.samples.len() as u64;
            let bands = Bands::new(&acc.samples, settings.thin_below);
            gathers += bands.gathers(marcher.gather_knot_cap) as u64;
        }
    }
    let per_ray = |total: u64| total as f64 / (rays as f64 * rays as f64);
    EyeProbe {
        samples: per_ray(samples),
        gathers: per_ray(gathers),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_util;

    /// A constant medium seen head-on through the unit box: the rays cross it in length 1.
    fn constant_box(t: f32, stepsize: f32) -> Scene {
        test_util::scene(&format!(
            r#"
[volume]
phantom = {{ name = "constant", resolution = [8, 8, 8] }}
[sigma]
mapping = "thesis"
t = {t}
[camera]
eye = [0.5, -2.0, 0.5]
look_at = [0.5, 0.5, 0.5]
up = [0, 0, 1]
fov = 1
resolution = [16, 16]
[three_point]
[integrator]
stepsize = {stepsize}
"#
        ))
    }

    #[test]
    fn a_ray_takes_one_sample_per_step_until_the_eye_transmittance_is_spent() {
        // Thin: every ray crosses the whole box, one sample per step.
        let thin = constant_box(0.5, 0.01);
        let samples = probe_eye_rays(&thin, 4).samples;
        assert!((samples - 100.0).abs() <= 1.0, "{samples}");
        // Dense: the march stops where T = termination, at ln(1/termination)/σt.
        let dense = constant_box(40.0, 0.001);
        let sigma_t = dense.medium().sigma_t(glam::Vec3::splat(0.5)) as f64;
        let termination = dense.integrator().termination as f64;
        let expected = (1.0 / termination).ln() / sigma_t / 0.001;
        assert!(
            expected < 1000.0,
            "the test needs the march to stop inside the box"
        );
        let samples = probe_eye_rays(&dense, 4).samples;
        assert!(
            (samples - expected).abs() <= 2.0,
            "{samples} against {expected}"
        );
    }

    #[test]
    fn thinning_counts_fewer_gathers_than_samples_behind_the_front() {
        let dense = constant_box(40.0, 0.001);
        let with = |thin_below: f32| {
            dense
                .with_integrator(crate::IntegratorParams {
                    thin_below,
                    ..dense.integrator().clone()
                })
                .unwrap()
        };
        let plain = probe_eye_rays(&with(0.0), 4);
        assert_eq!(plain.gathers, plain.samples);
        let probe = probe_eye_rays(&with(0.5), 4);
        assert_eq!(
            probe.samples, plain.samples,
            "the march itself is unchanged"
        );
        // σt = 40 per unit at step 0.001: transmittance 0.5 after ~17 samples, and the
        // bands below it take 2, 4, 8, 16 and up to 31 samples per gather.
        assert!(
            probe.gathers < 0.3 * probe.samples && probe.gathers > 17.0,
            "{probe:?}"
        );
    }
}
