//! Physics checked against closed forms and against the reference path tracer — never
//! against the photon integrator itself.

use volphot::test_util as common;

use glam::Vec3;
use volphot::Control;
use volphot::FreePath;
use volphot::build_photon_map;
use volphot::render_march;
use volphot::render_reference;
use volphot::{Domain, Rng};
use volphot::{Layer, mean_rgb};
use volphot::{TraceSettings, sample_interaction_march, sample_interaction_thesis, trace};

/// A homogeneous unit cube (σt = 4, albedo 0.75) seen by a 1×1 camera along +y through its
/// centre, lit by a point light at (1.5, 0.5, 0.5).
const HOMOGENEOUS: &str = r#"
[volume]
phantom = { name = "constant", resolution = [8, 8, 8] }
[sigma]
mapping = "explicit"
sigma_a = [1, 1, 1]
sigma_s = [3, 3, 3]
[camera]
eye = [0.5, -1.0, 0.5]
look_at = [0.5, 0.5, 0.5]
up = [0, 0, 1]
fov = 0.001
resolution = [1, 1]
[[lights]]
type = "point"
position = [1.5, 0.5, 0.5]
intensity = 1.0
[integrator]
multiple = false
stepsize = 0.001
spp = 8
"#;

/// The closed form of single scattering along that ray, integrated numerically (Simpson).
fn homogeneous_single_scattering() -> f64 {
    let (sigma_t, sigma_s, intensity) = (4.0f64, 3.0f64, 1.0f64);
    let f = |y: f64| {
        let r2 = 1.0 + (y - 0.5).powi(2);
        let r = r2.sqrt();
        // The shadow ray leaves the cube at x = 1 after 0.5·r.
        (-sigma_t * y).exp() * sigma_s / (4.0 * std::f64::consts::PI) * intensity / r2
            * (-sigma_t * 0.5 * r).exp()
    };
    let n = 20_000;
    let h = 1.0 / n as f64;
    let mut sum = f(0.0) + f(1.0);
    for i in 1..n {
        sum += f(i as f64 * h) * if i % 2 == 1 { 4.0 } else { 2.0 };
    }
    sum * h / 3.0
}

#[test]
fn single_scattering_in_homogeneous_medium_matches_closed_form() {
    let expected = homogeneous_single_scattering();
    for shadow in ["march", "ratio"] {
        let scene = common::scene(
            &HOMOGENEOUS.replace("spp = 8", &format!("spp = 512\nshadow = \"{shadow}\"")),
        );
        let out = render_march(&scene, &[], &[], &Control::none()).unwrap();
        let got = out.films[0].layer(Layer::Single)[0].x as f64;
        let rel = (got - expected).abs() / expected;
        assert!(
            rel < 0.01,
            "{shadow}: integrator {got} vs closed form {expected} ({rel:.4})"
        );
    }
    // The reference path tracer estimates the same integral.
    let scene = common::scene(&HOMOGENEOUS.replace("spp = 8", "spp = 8\nreference_spp = 200000"));
    let (film, _) = render_reference(&scene, 200_000, &Control::none()).unwrap();
    let got = film.layer(Layer::Single)[0].x as f64;
    let sigma = (film.variance(Layer::Single).unwrap()[0].x as f64).sqrt();
    assert!(
        (got - expected).abs() < 4.0 * sigma + 1e-3 * expected,
        "reference {got} ± {sigma} vs closed form {expected}"
    );
}

/// Fraction of photons from the cube's centre that leave without interacting:
/// E_ω[exp(−σt·L(ω))] with L the distance to the cube's surface.
fn escape_fraction(sigma_t: f64) -> f64 {
    let n = 400;
    let mut sum = 0.0;
    for i in 0..n {
        let cos_t = -1.0 + (i as f64 + 0.5) * 2.0 / n as f64;
        let sin_t = (1.0 - cos_t * cos_t).sqrt();
        for j in 0..n {
            let phi = (j as f64 + 0.5) * 2.0 * std::f64::consts::PI / n as f64;
            let d = [sin_t * phi.cos(), sin_t * phi.sin(), cos_t];
            let l = d
                .iter()
                .map(|c| {
                    if c.abs() > 0.0 {
                        0.5 / c.abs()
                    } else {
                        f64::INFINITY
                    }
                })
                .fold(f64::INFINITY, f64::min);
            sum += (-sigma_t * l).exp();
        }
    }
    sum / (n * n) as f64
}

fn cube_with_central_light(sigma_t: f32, albedo: f32) -> volphot::Scene {
    common::scene(&format!(
        r#"
[volume]
phantom = {{ name = "constant", resolution = [8, 8, 8] }}
[sigma]
mapping = "thesis"
t = {sigma_t}
albedo = {albedo}
[[lights]]
type = "point"
position = [0.5, 0.5, 0.5]
intensity = 2.0
[integrator]
volume_photons = 200000
"#
    ))
}

#[test]
fn photon_energy_bookkeeping_matches_closed_forms() {
    // Thin cube: the uncollided fraction follows Beer–Lambert from the centre.
    let scene = cube_with_central_light(2.0, 0.5);
    let map = build_photon_map(&scene, &Control::none()).unwrap();
    let stats = map.stats();
    let escaped = stats.escaped_without_interaction as f64 / stats.emitted as f64;
    let expected = escape_fraction(2.0);
    let sigma = (expected * (1.0 - expected) / stats.emitted as f64).sqrt();
    assert!(
        (escaped - expected).abs() < 4.0 * sigma,
        "escape {escaped} vs {expected}"
    );

    // Optically thick cube (τ ≥ 100 to the surface), albedo Λ: a photon makes N ~ Geom(1−Λ)
    // interactions and is stored at all but the first, so the stored power is
    // Φ·Λ/(1−Λ); the power is divided by the photons emitted by the light.
    for albedo in [0.5f32, 0.8] {
        let scene = cube_with_central_light(200.0, albedo);
        let map = build_photon_map(&scene, &Control::none()).unwrap();
        let phi = 4.0 * std::f64::consts::PI * 2.0;
        let expected = phi * albedo as f64 / (1.0 - albedo as f64);
        let got = map.stats().stored_power;
        assert!(
            (got / expected - 1.0).abs() < 0.02,
            "albedo {albedo}: stored {got} vs {expected}"
        );
        let per_photon = map.photons()[0].power.x as f64;
        assert!((per_photon - phi / 200_000.0).abs() < 1e-9 * phi);
    }
}

/// A two-slab medium along x (σt = 2 for x < ½, 8 beyond), nearest reconstruction so the
/// step is exact: the free-path CDF from x = 0 along +x is F(t) = 1 − exp(−τ(t)).
fn two_slab() -> volphot::Scene {
    common::scene(
        r#"
[volume]
phantom = { name = "two-slab", resolution = [64, 64, 64], densities = [0.25, 1.0] }
reconstruction = "nearest"
[sigma]
mapping = "thesis"
t = 2
[[lights]]
type = "spot"
position = [-0.5, 0.5, 0.5]
target = [0.5, 0.5, 0.5]
intensity = 1
cone_angle = 15
beam_width = 15
"#,
    )
}

fn two_slab_cdf(t: f64) -> f64 {
    let tau = if t < 0.5 {
        2.0 * t
    } else if t < 1.0 {
        1.0 + 8.0 * (t - 0.5)
    } else {
        f64::INFINITY
    };
    1.0 - (-tau).exp()
}

/// Kolmogorov–Smirnov distance of samples (escapes as +∞) to the CDF.
fn ks_distance(mut samples: Vec<f64>) -> f64 {
    samples.sort_by(f64::total_cmp);
    let n = samples.len() as f64;
    samples
        .iter()
        .enumerate()
        .filter(|(_, t)| t.is_finite())
        .map(|(i, &t)| {
            let f = two_slab_cdf(t);
            (f - i as f64 / n).abs().max((f - (i + 1) as f64 / n).abs())
        })
        .fold(0.0, f64::max)
        .max({
            // The escape mass: empirical P(t < 1) against F(1⁻).
            let finite = samples.iter().filter(|t| t.is_finite()).count() as f64 / n;
            (finite - two_slab_cdf(0.999_999)).abs()
        })
}

#[test]
fn free_path_rules_ks_test_in_two_slab_medium() {
    let scene = two_slab();
    let medium = scene.medium();
    let ray = volphot::Ray::new(Vec3::new(0.0, 0.5, 0.5), Vec3::X);
    let n = 20_000;
    // 99.9 % critical value of the one-sample KS statistic.
    let critical = 1.95 / (n as f64).sqrt();
    let draw = |rule: &str| -> Vec<f64> {
        (0..n)
            .map(|i| {
                let mut rng = Rng::stream(11, Domain::Misc, i as u64);
                let t = match rule {
                    "delta" => medium.sample_interaction_delta(&ray, 0.0, 1.0, &mut rng),
                    // The first tentative collision placed by a stratified uniform (the
                    // i-th of n evenly spread): the distribution must stay delta's.
                    "first" => {
                        let u = (i as f32 + 0.5) / n as f32;
                        medium.sample_interaction_delta_first(&ray, 0.0, 1.0, u, &mut rng)
                    }
                    "march" => sample_interaction_march(medium, &ray, 0.0, 1.0, 0.0005, &mut rng),
                    _ => sample_interaction_thesis(medium, &ray, 0.0, 1.0, 0.0005, &mut rng),
                };
                t.map_or(f64::INFINITY, |t| t as f64)
            })
            .collect()
    };
    let d_delta = ks_distance(draw("delta"));
    let d_first = ks_distance(draw("first"));
    assert!(
        d_first < critical,
        "stratified first collision D = {d_first} ≥ {critical}"
    );
    let d_march = ks_distance(draw("march"));
    let d_thesis = ks_distance(draw("thesis"));
    assert!(d_delta < critical, "delta D = {d_delta} ≥ {critical}");
    assert!(d_march < critical, "march D = {d_march} ≥ {critical}");
    assert!(
        d_thesis > 5.0 * critical,
        "thesis D = {d_thesis} should fail clearly"
    );
}

#[test]
fn photon_free_path_rules_differ_only_for_thesis_rule() {
    // Through the whole tracer: delta and march store photons with the same depth
    // distribution; the thesis rule carries the thin slab's σt into the dense slab.
    let scene = two_slab();
    let run = |free_path| {
        let (photons, stats) = trace(
            scene.medium(),
            scene.lights(),
            &TraceSettings {
                photons: 50_000,
                stored_target: 0,
                free_path,
                stepsize: 0.0005,
                seed: 3,
            },
            &Control::none(),
        )
        .unwrap();
        let dense =
            photons.iter().filter(|p| p.position.x > 0.5).count() as f64 / photons.len() as f64;
        let depth = photons.iter().map(|p| p.position.x as f64).sum::<f64>() / photons.len() as f64;
        (dense, depth, stats.mean_flight_distance)
    };
    let (delta, march, thesis) = (
        run(FreePath::Delta),
        run(FreePath::March),
        run(FreePath::Thesis),
    );
    eprintln!(
        "(share stored in dense slab, mean depth, mean flight): delta {delta:?}, march {march:?}, thesis {thesis:?}"
    );
    assert!(
        (delta.0 / march.0 - 1.0).abs() < 0.02,
        "{delta:?} vs {march:?}"
    );
    assert!(
        (delta.1 / march.1 - 1.0).abs() < 0.01,
        "{delta:?} vs {march:?}"
    );
    assert!(
        (thesis.0 / delta.0 - 1.0).abs() > 0.05,
        "{thesis:?} vs {delta:?}"
    );
}

#[test]
fn photon_integrator_agrees_with_reference_and_converges() {
    let base = common::scene(common::SPOT_SPHERE);
    let (reference, _) = render_reference(&base, 4096, &Control::none()).unwrap();
    let ref_single = reference.layer(Layer::Single);
    let ref_multiple = reference.layer(Layer::Multiple);
    let ref_noise_single = mean_rgb(reference.variance(Layer::Single).unwrap()).sqrt();
    let ref_noise_multiple =
        mean_rgb(reference.variance(Layer::Multiple).unwrap()).sqrt() / mean_rgb(ref_multiple);
    eprintln!(
        "reference relative noise: single {:.4}, multiple {ref_noise_multiple:.4}",
        ref_noise_single / mean_rgb(ref_single)
    );

    // Single scattering: same integral, different estimators.
    let scene = base
        .with_integrator(volphot::IntegratorParams {
            multiple: false,
            spp: 16,
            ..base.integrator().clone()
        })
        .unwrap();
    let out = render_march(&scene, &[], &[], &Control::none()).unwrap();
    let single = out.films[0].layer(Layer::Single);
    let mean_err = (mean_rgb(single) / mean_rgb(ref_single) - 1.0).abs();
    assert!(
        mean_err < 0.02,
        "single-scattering mean differs by {mean_err:.4}"
    );
    let rel = common::relative_rmse(single, ref_single);
    let ref_rel_noise = ref_noise_single / mean_rgb(ref_single);
    assert!(
        rel < 3.0 * ref_rel_noise + 0.03,
        "single rRMSE {rel:.4} (reference noise {ref_rel_noise:.4})"
    );

    // Multiple scattering: the error against the reference falls as photons and nused grow.
    let mut errors = Vec::new();
    for (photons, nused) in [(10_000u64, 20u32), (100_000, 60), (1_000_000, 200)] {
        let scene = base
            .with_integrator(volphot::IntegratorParams {
                volume_photons: photons,
                nused,
                spp: 4,
                ..base.integrator().clone()
            })
            .unwrap();
        let map = build_photon_map(&scene, &Control::none()).unwrap();
        let out = render_march(&scene, &[&map], &[], &Control::none()).unwrap();
        let multiple = out.films[0].layer(Layer::Multiple);
        let rel = common::relative_rmse(multiple, ref_multiple);
        // The reference's own noise is part of the difference; remove it.
        let excess = (rel * rel - ref_noise_multiple * ref_noise_multiple)
            .max(0.0)
            .sqrt();
        let mean_ratio = mean_rgb(multiple) / mean_rgb(ref_multiple);
        errors.push((photons, nused, excess, mean_ratio));
    }
    eprintln!(
        "multiple-scattering error vs reference (photons, nused, rRMSE beyond reference noise, mean ratio): {errors:?}"
    );
    assert!(
        errors[0].2 > errors[1].2 && errors[1].2 > errors[2].2,
        "{errors:?}"
    );
    let (_, _, final_excess, final_ratio) = errors[2];
    assert!(
        (final_ratio - 1.0).abs() < 0.05,
        "final mean ratio {final_ratio}"
    );
    assert!(
        final_excess < 0.2,
        "final rRMSE beyond reference noise {final_excess}"
    );
}

#[test]
fn same_seed_gives_bit_identical_images_with_one_and_two_threads() {
    let scene = common::scene(&common::SPOT_SPHERE.replace(
        "reference_spp = 1024",
        "volume_photons = 5000\nshadow = \"ratio\"",
    ));
    let render = |threads| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| {
                let map = build_photon_map(&scene, &Control::none()).unwrap();
                let march = render_march(&scene, &[&map], &[], &Control::none()).unwrap();
                let (reference, _) = render_reference(&scene, 4, &Control::none()).unwrap();
                (map.photons().to_vec(), march.films[0].clone(), reference)
            })
    };
    let (p1, f1, r1) = render(1);
    let (p2, f2, r2) = render(2);
    assert_eq!(p1, p2);
    assert_eq!(f1, f2);
    assert_eq!(r1, r2);
    assert!(f1.is_finite() && mean_rgb(f1.layer(Layer::Multiple)) > 0.0);
}

#[test]
fn estimate_forms_on_a_thin_slab_against_the_reference() {
    // A slab 0.1 thick (σt = 10, albedo 0.8) seen face on: the gather sphere (nused 200
    // of 40 000 photons) is wider than the slab. The masked estimate divides by the part of
    // the sphere that holds medium; the plain fluence estimate divides by the whole sphere
    // and comes out low; eq. 11 as printed is 1/Λ brighter than its albedo-weighted form.
    let src = r#"
[volume]
phantom = { name = "slab", resolution = [32, 32, 32], range = [0.45, 0.55] }
[sigma]
t = 10
albedo = 0.8
[camera]
eye = [-1.5, 0.5, 0.5]
look_at = [0.5, 0.5, 0.5]
up = [0, 0, 1]
fov = 12
resolution = [12, 12]
[[lights]]
type = "spot"
position = [-1.2, -0.6, 0.9]
target = [0.5, 0.5, 0.5]
intensity = 10
cone_angle = 25
beam_width = 20
[integrator]
volume_photons = 40000
nused = 200
maxdist = 0.3
stepsize = 0.002
spp = 4
"#;
    let base = common::scene(src);
    let (reference, _) = render_reference(&base, 4096, &Control::none()).unwrap();
    let reference_mean = mean_rgb(reference.layer(Layer::Multiple));
    let map = build_photon_map(&base, &Control::none()).unwrap();
    let mut ratios = Vec::new();
    for estimate in [
        volphot::Estimate::Masked,
        volphot::Estimate::Fluence,
        volphot::Estimate::Albedo,
        volphot::Estimate::Thesis,
    ] {
        let scene = base
            .with_integrator(volphot::IntegratorParams {
                estimate,
                ..base.integrator().clone()
            })
            .unwrap();
        let out = render_march(&scene, &[&map], &[], &Control::none()).unwrap();
        ratios.push((
            estimate,
            mean_rgb(out.films[0].layer(Layer::Multiple)) / reference_mean,
        ));
    }
    eprintln!("multiple-scattering mean / reference on a thin slab: {ratios:?}");
    let ratio = |i: usize| ratios[i].1;
    assert!((ratio(0) - 1.0).abs() < 0.1, "masked {}", ratio(0));
    assert!(
        ratio(1) < 0.9 * ratio(0),
        "fluence {} vs masked {}",
        ratio(1),
        ratio(0)
    );
    assert!(
        (ratio(3) / ratio(2) - 1.25).abs() < 1e-3,
        "eq. 11 is 1/Λ = 1.25 × the albedo form"
    );
}
