//! Consistent photon mapping (issue #16): the progressive and beam estimators converge to
//! the reference path tracer, the beam estimate is the point estimate's limit, and every
//! iteration's photons carry the same power.

use volphot::test_util as common;

use volphot::{
    BeamMap, BeamRadius, Control, Estimate, EyeRays, InitialRadius, IntegratorParams, Layer,
    MsEstimator, MsVariant, RadiusRule, Scene, build_photon_map, mean_rgb, render, render_march,
    render_march_beams, render_reference,
};

/// The shared spot-lit sphere (σt = 3, albedo 0.8) at 16×16, multiple scattering only.
fn sphere() -> Scene {
    let src = common::SPOT_SPHERE.replace("resolution = [20, 20]", "resolution = [16, 16]");
    with(&common::scene(&src), |s| {
        s.single = false;
        s.stepsize = 0.004;
        s.spp = 16;
        s.maxdist = 0.1;
    })
}

/// Two slabs along x (σt 2 for x < ½, 8 beyond: a fluence gradient and a kink at the
/// interface), lit from the thin side, seen from the front.
const TWO_SLAB: &str = r#"
[volume]
phantom = { name = "two-slab", resolution = [32, 32, 32], densities = [0.25, 1.0] }
reconstruction = "nearest"
[sigma]
mapping = "thesis"
t = 8
albedo = 0.9
[camera]
eye = [0.5, -1.6, 0.5]
look_at = [0.5, 0.5, 0.5]
up = [0, 0, 1]
fov = 36
resolution = [16, 16]
[[lights]]
type = "spot"
position = [-0.6, 0.5, 0.5]
target = [0.5, 0.5, 0.5]
intensity = 4
cone_angle = 20
beam_width = 20
[integrator]
single = false
stepsize = 0.004
spp = 16
"#;

fn with(scene: &Scene, change: impl FnOnce(&mut IntegratorParams)) -> Scene {
    let mut settings = scene.integrator().clone();
    change(&mut settings);
    scene.with_integrator(settings).unwrap()
}

/// The multiple layer of a reference render and its per-pixel relative noise (RMS).
fn reference(scene: &Scene, spp: u32) -> (Vec<glam::Vec3>, f64) {
    let (film, _) = render_reference(scene, spp, &Control::none()).unwrap();
    let layer = film.layer(Layer::Multiple).to_vec();
    let noise = mean_rgb(film.variance(Layer::Multiple).unwrap()).sqrt() / mean_rgb(&layer);
    (layer, noise)
}

/// rRMSE against the reference with the reference's own noise removed.
fn excess_error(image: &[glam::Vec3], reference: &[glam::Vec3], noise: f64) -> f64 {
    let rel = common::relative_rmse(image, reference);
    (rel * rel - noise * noise).max(0.0).sqrt()
}

#[test]
fn beam_estimate_equals_the_point_estimate_as_the_step_shrinks() {
    let base = sphere();
    let map = build_photon_map(
        &with(&base, |s| s.volume_photons = 20_000),
        &Control::none(),
    )
    .unwrap();
    let radius = 0.08;
    let mut gaps = Vec::new();
    for step in [0.04f32, 0.01, 0.0025] {
        let scene = with(&base, |s| {
            s.stepsize = step;
            s.estimate = Estimate::Fluence;
        });
        let point = MsVariant {
            map: 0,
            nused: u32::MAX,
            maxdist: radius,
            estimate: Estimate::Fluence,
        };
        let points = render_march(&scene, &[&map], &[point], &Control::none()).unwrap();
        let beams = BeamMap::new(&map, BeamRadius::Fixed(radius), scene.medium(), false);
        let beam = render_march_beams(&scene, &beams, &Control::none()).unwrap();
        let (p, b) = (
            points.films[0].layer(Layer::Multiple),
            beam.films[0].layer(Layer::Multiple),
        );
        gaps.push((step, common::relative_rmse(b, p)));
    }
    eprintln!("beam vs point estimate (step, rRMSE): {gaps:?}");
    assert!(gaps[0].1 > gaps[1].1 && gaps[1].1 > gaps[2].1, "{gaps:?}");
    assert!(gaps[2].1 < 0.01, "{gaps:?}");
}

/// The photon planes take the eye's transmittance from the march (σt constant over each
/// step), as the beam estimate does; along both legs of a plane they need no step. With
/// the same planes, the plane estimate at steps 0.04, 0.01, 0.0025 approaches its value at
/// 0.000625: the step's error shrinks and is within 1 % at 0.0025.
#[test]
fn plane_estimate_converges_as_the_step_shrinks() {
    let base = with(&sphere(), |s| {
        s.estimator = MsEstimator::Plane;
        s.estimate = Estimate::Fluence;
        s.spp = 64;
    });
    let (planes, _) = volphot::trace_planes(
        base.medium(),
        base.lights(),
        &volphot::TraceSettings {
            photons: 2_000,
            stored_target: 0,
            free_path: volphot::FreePath::Delta,
            stepsize: 0.004,
            seed: 3,
        },
        &Control::none(),
    )
    .unwrap();
    let map = volphot::PlaneMap::new(&planes, 0.01);
    let at = |step: f32| {
        let scene = with(&base, |s| s.stepsize = step);
        let out = volphot::render_march_planes(&scene, &map, &Control::none()).unwrap();
        out.films[0].layer(Layer::Multiple).to_vec()
    };
    let finest = at(0.000625);
    let gaps: Vec<(f32, f64)> = [0.04f32, 0.01, 0.0025]
        .into_iter()
        .map(|step| (step, common::relative_rmse(&at(step), &finest)))
        .collect();
    eprintln!("plane estimate against step 0.000625 (step, rRMSE): {gaps:?}");
    assert!(gaps[0].1 > gaps[1].1 && gaps[1].1 > gaps[2].1, "{gaps:?}");
    assert!(gaps[2].1 < 0.01, "{gaps:?}");
}

/// Errors beyond the reference's noise of `estimator` after 1, 4, 16 and 64 iterations,
/// and the final mean ratio.
fn convergence(
    scene: &Scene,
    reference: &(Vec<glam::Vec3>, f64),
    estimator: MsEstimator,
) -> (Vec<f64>, f64) {
    converging(scene, reference, &format!("{estimator:?}"), |s| {
        s.estimator = estimator;
        s.photons_per_iteration = 20_000;
        s.nused = 50;
        s.maxdist = 0.2;
        s.initial_radius = InitialRadius::Nused;
    })
}

/// Errors beyond the reference's noise after 1, 4, 16 and 64 iterations of the settings
/// `configure` makes, and the final mean ratio.
fn converging(
    scene: &Scene,
    reference: &(Vec<glam::Vec3>, f64),
    name: &str,
    configure: impl Fn(&mut IntegratorParams),
) -> (Vec<f64>, f64) {
    let (ref_multiple, noise) = reference;
    let mut errors = Vec::new();
    let mut ratio = 0.0;
    for iterations in [1, 4, 16, 64] {
        let scene = with(scene, |s| {
            configure(s);
            s.iterations = iterations;
        });
        let out = render(&scene, &Control::none()).unwrap();
        let stats = out.record.progressive.as_ref().unwrap();
        assert_eq!(stats.iterations, iterations);
        assert_eq!(stats.radii.len(), iterations as usize);
        let multiple = out.film.layer(Layer::Multiple);
        errors.push(excess_error(multiple, ref_multiple, *noise));
        ratio = mean_rgb(multiple) / mean_rgb(ref_multiple);
    }
    eprintln!(
        "{name}: rRMSE beyond reference noise {noise:.4} at 1/4/16/64 iterations \
         {errors:?}, final mean ratio {ratio:.4}"
    );
    (errors, ratio)
}

#[test]
fn progressive_points_and_beams_converge_to_the_reference() {
    for (name, scene) in [("sphere", sphere()), ("two-slab", common::scene(TWO_SLAB))] {
        let reference = reference(&scene, 8192);
        for estimator in [MsEstimator::Progressive, MsEstimator::Beam] {
            let (errors, ratio) = convergence(&scene, &reference, estimator);
            // α = 4/7: RMSE ∝ N^(−2/7) for points (3.3× from 1 to 64 iterations), slower
            // for beams (their 2-D rule); the reference's noise floor flattens the tail.
            assert!(
                errors[0] / errors[3] > 1.6,
                "{name} {estimator:?}: {errors:?}"
            );
            assert!(
                errors.windows(2).all(|w| w[0] > w[1]),
                "{name} {estimator:?}: {errors:?}"
            );
            assert!(
                (ratio - 1.0).abs() < 0.03,
                "{name} {estimator:?}: mean ratio {ratio}"
            );
        }
    }
}

#[test]
fn every_iteration_carries_the_same_power() {
    let scene = with(&sphere(), |s| {
        s.estimator = MsEstimator::Progressive;
        s.iterations = 6;
        s.photons_per_iteration = 20_000;
    });
    let out = render(&scene, &Control::none()).unwrap();
    let stats = out.record.progressive.unwrap();
    // One big map of the same scene: the power per iteration must match it.
    let big = build_photon_map(
        &with(&scene, |s| s.volume_photons = 200_000),
        &Control::none(),
    )
    .unwrap();
    let expected: f64 = big
        .photons()
        .iter()
        .map(|p| (p.power.x + p.power.y + p.power.z) as f64 / 3.0)
        .sum();
    assert_eq!(stats.stored_power.len(), 6);
    // Each iteration's march timed on its own (`sweep plan` scales the first and a later
    // one), adding up to the total.
    assert_eq!(stats.march_seconds_each.len(), 6);
    let sum: f64 = stats.march_seconds_each.iter().sum();
    assert!((sum - stats.march_seconds).abs() <= 1e-9 * stats.march_seconds.max(1.0));
    for (i, power) in stats.stored_power.iter().enumerate() {
        assert!(
            (power / expected - 1.0).abs() < 0.03,
            "iteration {}: {power} vs {expected}",
            i + 1
        );
    }
    // Independent maps: no two iterations store the same photons.
    assert!(
        stats.stored.windows(2).any(|w| w[0] != w[1]) || {
            let p = &stats.stored_power;
            p.windows(2).all(|w| w[0] != w[1])
        }
    );
    // The radius shrinks by the volumetric rule.
    for (i, w) in stats.radii.windows(2).enumerate() {
        let expected = volphot::next_radius(
            w[0],
            i as u32 + 1,
            scene.integrator().alpha,
            MsEstimator::Progressive,
        );
        assert_eq!(w[1], expected);
    }
}

/// With a reference, a progressive render records its RMSE after every iteration (falling,
/// as it converges) and `target_rmse` stops it at the first iteration that reaches it; a
/// target without a reference, or with the point estimate, is an error naming the key.
#[test]
fn a_target_error_stops_the_iterations_and_every_error_is_recorded() {
    let scene = with(&sphere(), |s| {
        s.estimator = MsEstimator::Progressive;
        s.iterations = 8;
        s.photons_per_iteration = 4_000;
    });
    let (reference, _) = reference(&scene, 1024);
    let control = Control::none().with_reference(&reference);
    let all = render(&scene, &control)
        .unwrap()
        .record
        .progressive
        .unwrap();
    assert_eq!(all.errors.len(), 8);
    assert_eq!(all.stopped, volphot::StopReason::Iterations);
    assert!(
        all.errors[7] < 0.8 * all.errors[0],
        "the error falls: {:?}",
        all.errors
    );
    // The last recorded error is the returned image's.
    let out = render(&scene, &control).unwrap();
    let last = volphot::rmse(out.film.layer(Layer::Multiple), &reference);
    assert!(
        (last - all.errors[7]).abs() < 1e-9 * last.max(1.0),
        "{last} vs {:?}",
        all.errors
    );

    // A target between the errors stops at the first iteration below it.
    let target = 0.5 * (all.errors[2] + all.errors[7]);
    let first_below = all.errors.iter().position(|e| *e <= target).unwrap() + 1;
    let stopped = with(&scene, |s| s.target_rmse = target as f32);
    let stats = render(&stopped, &control)
        .unwrap()
        .record
        .progressive
        .unwrap();
    assert_eq!(stats.stopped, volphot::StopReason::TargetRmse);
    assert_eq!(stats.iterations as usize, first_below, "{:?}", all.errors);
    assert_eq!(
        stats.errors,
        all.errors[..first_below].to_vec(),
        "the same iterations"
    );

    let e = render(&stopped, &Control::none()).unwrap_err().to_string();
    assert!(
        e.contains("integrator.target_rmse") && e.contains("reference"),
        "{e}"
    );
    let mut points = scene.integrator().clone();
    points.estimator = MsEstimator::Points;
    points.target_rmse = 0.01;
    let e = points.validate().unwrap_err().to_string();
    assert!(e.contains("target_rmse") && e.contains("points"), "{e}");
}

/// Replayed eye rays converge to the estimate of the first iteration's rays, whose pixel
/// sampling error never falls; fresh eye rays average it away: from 16 to 64 iterations the
/// fresh image's error falls by a third (the replayed one's by an eighth, its photon noise
/// alone), and at 64 the fresh image is closer to the reference. Their first iteration is the same render. The
/// reference has 65 536 passes: at 8192 its own noise (6 % of the mean with the delta
/// tracker, 3.5 % with the weighted one) is as large as the errors compared, and removing
/// it left their ratio at the mercy of its estimate (0.50 with one tracker, 0.66 with the
/// other; at 65 536 both trackers give 0.66–0.67).
#[test]
fn fresh_eye_rays_converge_where_replayed_ones_stop() {
    let scene = sphere();
    let reference = reference(&scene, 65_536);
    let render_with = |eye_rays, iterations| {
        let s = with(&scene, |s| {
            s.estimator = MsEstimator::Beam;
            s.iterations = iterations;
            s.photons_per_iteration = 5_000;
            s.nused = 50;
            s.eye_rays = eye_rays;
        });
        let out = render(&s, &Control::none()).unwrap();
        out.film.layer(Layer::Multiple).to_vec()
    };
    let (replayed, fresh) = (
        render_with(EyeRays::Replayed, 1),
        render_with(EyeRays::Fresh, 1),
    );
    assert_eq!(
        replayed, fresh,
        "the first iteration does not depend on later ones"
    );
    let error = |eye_rays, iterations| {
        excess_error(
            &render_with(eye_rays, iterations),
            &reference.0,
            reference.1,
        )
    };
    let replayed = [error(EyeRays::Replayed, 16), error(EyeRays::Replayed, 64)];
    let fresh = [error(EyeRays::Fresh, 16), error(EyeRays::Fresh, 64)];
    eprintln!(
        "rRMSE beyond the reference's noise at 16 and 64 iterations: replayed {replayed:.4?}, fresh {fresh:.4?}"
    );
    assert!(fresh[1] < 0.85 * fresh[0], "fresh keeps falling: {fresh:?}");
    assert!(
        fresh[1] < 0.8 * replayed[1],
        "replayed {replayed:?}, fresh {fresh:?}"
    );
}

/// With fresh eye rays every radius rule of the progressive points and the beams, and the
/// photon planes, converge to the reference: the error beyond its noise falls at every
/// fourfold of the iterations, and the final mean is the reference's.
#[test]
fn radius_rules_and_planes_converge_with_fresh_eye_rays() {
    for (name, scene) in [("sphere", sphere()), ("two-slab", common::scene(TWO_SLAB))] {
        let reference = reference(&scene, 8192);
        let mut runs: Vec<(String, (Vec<f64>, f64))> = Vec::new();
        for estimator in [MsEstimator::Progressive, MsEstimator::Beam] {
            for rule in [
                RadiusRule::Global,
                RadiusRule::Nearest,
                RadiusRule::Balanced,
            ] {
                let label = format!("{name} {estimator:?} {rule:?}");
                let run = converging(&scene, &reference, &label, |s| {
                    s.estimator = estimator;
                    s.radius = rule;
                    s.eye_rays = EyeRays::Fresh;
                    s.photons_per_iteration = 5_000;
                    s.nused = 50;
                    s.maxdist = 0.2;
                });
                runs.push((label, run));
            }
        }
        let label = format!("{name} Plane");
        let planes = converging(&scene, &reference, &label, |s| {
            s.estimator = MsEstimator::Plane;
            s.eye_rays = EyeRays::Fresh;
            s.photons_per_iteration = 1_000;
            s.maxdist = 0.01;
        });
        runs.push((label, planes));
        for (label, (errors, ratio)) in runs {
            assert!(errors[0] / errors[3] > 2.0, "{label}: {errors:?}");
            assert!(
                errors.windows(2).all(|w| w[0] > w[1]),
                "{label}: {errors:?}"
            );
            assert!((ratio - 1.0).abs() < 0.03, "{label}: mean ratio {ratio}");
        }
    }
}
