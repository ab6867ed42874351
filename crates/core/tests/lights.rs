//! Area and environment lights in every integrator, against closed forms:
//!
//! * a constant environment `L` around a homogeneous cube that scatters everything
//!   (albedo 1): the radiance field inside is `L` everywhere, so an eye ray through the
//!   cube sees `L·(1 − e^{−σt·chord})` in scattered light (the rest, `L·e^{−σt·chord}`,
//!   is the hidden background) — whatever the phase function;
//! * a disc light over a homogeneous cube: single scattering against a deterministic
//!   quadrature over the eye ray, the disc and the shadow ray's chord.

use glam::Vec3;
use std::f32::consts::PI;
use volphot::test_util as common;
use volphot::{Control, Layer, Ray, render, render_march, render_reference};

/// A homogeneous unit cube (σt, albedo, phase g) seen face-on along +x through a narrow
/// camera (every eye ray crosses the cube from x = 0 to x = 1), lit by `lights`.
fn cube(sigma_t: f32, albedo: f32, g: f32, lights: &str, integrator: &str) -> volphot::Scene {
    common::scene(&format!(
        r#"
[volume]
phantom = {{ name = "constant", resolution = [8, 8, 8] }}
[sigma]
t = {sigma_t}
albedo = {albedo}
[phase]
g = {g}
[camera]
eye = [-10, 0.5, 0.5]
look_at = [0.5, 0.5, 0.5]
up = [0, 0, 1]
fov = 4
resolution = [8, 8]
{lights}
[integrator]
{integrator}
"#
    ))
}

fn mean(film: &volphot::Film, layer: Layer) -> Vec3 {
    let v = film.layer(layer);
    v.iter().copied().sum::<Vec3>() / v.len() as f32
}

/// The chord through the unit cube of the ray through pixel position (x, y).
fn chord(scene: &volphot::Scene, x: f32, y: f32) -> f32 {
    let ray = scene.camera().ray(x, y);
    scene
        .medium()
        .clip(&ray)
        .map_or(0.0, |(t0, t1)| (t1 - t0).max(0.0))
}

/// `L·(1 − e^{−σt·chord})` averaged over the image (4×4 positions in each pixel).
fn scattered_in_uniform_field(scene: &volphot::Scene, sigma_t: f32, radiance: Vec3) -> Vec3 {
    let (w, h) = (scene.camera().width(), scene.camera().height());
    let mut sum = 0.0f64;
    for py in 0..h {
        for px in 0..w {
            for s in 0..16 {
                let (x, y) = (
                    px as f32 + (s % 4) as f32 / 4.0 + 0.125,
                    py as f32 + (s / 4) as f32 / 4.0 + 0.125,
                );
                sum += (1.0 - (-sigma_t * chord(scene, x, y)).exp()) as f64;
            }
        }
    }
    radiance * (sum / (16 * w * h) as f64) as f32
}

const GREY_SKY: &str = r#"
[[lights]]
type = "sky"
zenith = 0.7
horizon = 0.7
ground = 0.7
"#;

#[test]
fn a_constant_environment_around_a_white_cube_gives_the_uniform_field() {
    for g in [0.0, 0.7] {
        let scene = cube(1.5, 1.0, g, GREY_SKY, "multiple = true");
        let expected = scattered_in_uniform_field(&scene, 1.5, Vec3::splat(0.7));
        // A forward-peaked phase against directions drawn from the uniform sky is noisy:
        // 4096 paths a pixel keep the mean's noise well inside the tolerance.
        let (film, _) = render_reference(&scene, 4096, &Control::none()).unwrap();
        let total = mean(&film, Layer::Single) + mean(&film, Layer::Multiple);
        for c in 0..3 {
            assert!(
                (total[c] / expected[c] - 1.0).abs() < 0.02,
                "g {g}: path tracer {total} against L(1 − e^(−σt·chord)) = {expected}"
            );
        }
    }
}

/// The photon integrator's total (single + multiple) over the white cube (σt 1.5) under
/// the grey sky with `integrator`'s settings, and the uniform field it should approach.
fn photons_under_grey_sky(integrator: &str) -> (Vec3, Vec3) {
    let scene = cube(1.5, 1.0, 0.0, GREY_SKY, integrator);
    let expected = scattered_in_uniform_field(&scene, 1.5, Vec3::splat(0.7));
    let out = render(&scene, &Control::none()).unwrap();
    let total = mean(&out.film, Layer::Single) + mean(&out.film, Layer::Multiple);
    (total, expected)
}

#[test]
fn photon_mapping_lit_by_the_environment_approaches_the_uniform_field() {
    let (total, expected) = photons_under_grey_sky(
        "volume_photons = 100000\nnused = 100\nmaxdist = 0.3\nstepsize = 0.01",
    );
    // The point estimate's bias near the faces stays within a few per cent here.
    assert!(
        (total.x / expected.x - 1.0).abs() < 0.06,
        "photon map {total} against {expected}"
    );
    // The marcher's single scattering from the sampled environment equals the path
    // tracer's (both unbiased for single scattering).
    let single = |s: &volphot::Scene| {
        mean(
            &render_march(s, &[], &[], &Control::none()).unwrap().films[0],
            Layer::Single,
        )
    };
    let single_scene = cube(
        1.5,
        1.0,
        0.0,
        GREY_SKY,
        "multiple = false\nstepsize = 0.01\nlight_samples = 4",
    );
    let marched = single(&single_scene);
    let (traced, _) = render_reference(&single_scene, 512, &Control::none()).unwrap();
    let traced = mean(&traced, Layer::Single);
    assert!(
        (marched.x / traced.x - 1.0).abs() < 0.02,
        "marched single {marched} against traced {traced}"
    );
}

#[test]
fn the_consistent_estimators_light_with_the_environment_too() {
    // Progressive, beam and plane estimates are built from the same emitted photons: lit
    // by the grey sky, each total approaches the uniform field as the point estimate does.
    for estimator in ["progressive", "beam", "plane"] {
        let integrator = format!(
            "volume_photons = 50000\nnused = 100\nmaxdist = 0.3\nstepsize = 0.01\nestimator = \"{estimator}\"\niterations = 4"
        );
        let (total, expected) = photons_under_grey_sky(&integrator);
        assert!(
            (total.x / expected.x - 1.0).abs() < 0.08,
            "{estimator}: {total} against {expected}"
        );
    }
}

/// A disc light facing down (−z) over the cube: its centre height, radius and radiance.
#[derive(Clone, Copy)]
struct Disc {
    height: f32,
    radius: f32,
    radiance: f32,
}

impl Disc {
    /// A small disc well above the cube: next-event estimation carries nearly all of it.
    const SMALL: Disc = Disc {
        height: 1.6,
        radius: 0.4,
        radiance: 10.0,
    };
    /// A disc wider than the cube just above it: its solid-angle pdf is below the
    /// isotropic phase function's over most of it, so the phase-sampled direction carries
    /// most of the light (multiple importance sampling, reference/mis.rs).
    const WIDE: Disc = Disc {
        height: 1.05,
        radius: 3.0,
        radiance: 1.0,
    };

    fn toml(self) -> String {
        format!(
            "[[lights]]\ntype = \"disc\"\nposition = [0.5, 0.5, {}]\nnormal = [0, 0, -1]\nradius = {}\nradiance = {}\n",
            self.height, self.radius, self.radiance
        )
    }
}

/// Single scattering from `disc` at the eye ray through (x, y), by quadrature: the eye
/// ray in 96 steps, the disc on a 48 × 48 polar grid (isotropic phase, albedo `a`).
fn single_from_disc(
    scene: &volphot::Scene,
    disc: Disc,
    x: f32,
    y: f32,
    sigma_t: f32,
    a: f32,
) -> f32 {
    let ray = scene.camera().ray(x, y);
    let Some((t0, t1)) = scene.medium().clip(&ray) else {
        return 0.0;
    };
    let (centre, radius, radiance) = (Vec3::new(0.5, 0.5, disc.height), disc.radius, disc.radiance);
    let (n_t, n_r, n_phi) = (96, 48, 48);
    let dt = (t1 - t0) / n_t as f32;
    let mut sum = 0.0f64;
    for i in 0..n_t {
        let t = t0 + (i as f32 + 0.5) * dt;
        let p = ray.at(t);
        let eye_t = (-sigma_t * (t - t0)).exp();
        let mut in_scattered = 0.0f64;
        for j in 0..n_r {
            let (r0, r1) = (
                radius * j as f32 / n_r as f32,
                radius * (j + 1) as f32 / n_r as f32,
            );
            let r = 0.5 * (r0 + r1);
            let ring = PI * (r1 * r1 - r0 * r0) / n_phi as f32;
            for k in 0..n_phi {
                let phi = 2.0 * PI * (k as f32 + 0.5) / n_phi as f32;
                let y_pt = centre + Vec3::new(r * phi.cos(), r * phi.sin(), 0.0);
                let d = y_pt - p;
                let dist = d.length();
                let w = d / dist;
                let cos_l = w.z; // −w·normal with normal −z
                let shadow = Ray::new(p, w);
                let inside = scene
                    .medium()
                    .clip(&shadow)
                    .map_or(0.0, |(s0, s1)| (s1.min(dist) - s0).max(0.0));
                let tr = (-sigma_t * inside).exp();
                in_scattered += (radiance * cos_l / (dist * dist) * tr * ring) as f64;
            }
        }
        sum +=
            (a * sigma_t * eye_t) as f64 * in_scattered / (4.0 * std::f64::consts::PI) * dt as f64;
    }
    sum as f32
}

#[test]
fn a_disc_light_over_a_cube_matches_the_quadrature_in_every_integrator() {
    for disc in [Disc::SMALL, Disc::WIDE] {
        single_from_disc_matches_the_quadrature(disc);
    }
}

fn single_from_disc_matches_the_quadrature(disc: Disc) {
    let (sigma_t, albedo) = (2.0, 0.8);
    let scene = cube(
        sigma_t,
        albedo,
        0.0,
        &disc.toml(),
        "multiple = false\nstepsize = 0.005",
    );
    let (w, h) = (scene.camera().width(), scene.camera().height());
    let mut expected = 0.0;
    for py in 0..h {
        for px in 0..w {
            for s in 0..4 {
                let (x, y) = (
                    px as f32 + 0.25 + 0.5 * (s % 2) as f32,
                    py as f32 + 0.25 + 0.5 * (s / 2) as f32,
                );
                expected +=
                    single_from_disc(&scene, disc, x, y, sigma_t, albedo) / (4 * w * h) as f32;
            }
        }
    }
    assert!(expected > 0.01, "the disc lights the cube: {expected}");
    let (film, _) = render_reference(&scene, 1024, &Control::none()).unwrap();
    let traced = mean(&film, Layer::Single).x;
    assert!(
        (traced / expected - 1.0).abs() < 0.02,
        "path tracer {traced} against quadrature {expected} (disc radius {})",
        disc.radius
    );
    let marched = mean(
        &render_march(&scene, &[], &[], &Control::none())
            .unwrap()
            .films[0],
        Layer::Single,
    )
    .x;
    assert!(
        (marched / expected - 1.0).abs() < 0.02,
        "marcher {marched} against quadrature {expected} (disc radius {})",
        disc.radius
    );
}

#[test]
fn bad_lights_are_named_with_their_key_and_line() {
    let cases = [
        (
            "type = \"disc\"\nposition = [0, 0, 2]\nnormal = [0, 0, -1]\nradius = -1\nradiance = 1",
            "radius",
        ),
        (
            "type = \"rect\"\nposition = [0, 0, 2]\nnormal = [0, 0, 0]\nsize = [1, 1]\nradiance = 1",
            "normal",
        ),
        (
            "type = \"rect\"\nposition = [0, 0, 2]\ntarget = [0, 0, 0]\nsize = [1, 1]\nradiance = nan",
            "radiance",
        ),
        ("type = \"sky\"\nintensity = 3", "intensity"),
        (
            "type = \"environment\"\nfile = \"no-such-map.exr\"",
            "no-such-map.exr",
        ),
        ("type = \"sky\"\nsun_direction = [0, 0, 1]", "sun_direction"),
        (
            "type = \"point\"\nposition = [0, 0, 2]\nintensity = 1\nradius = 2",
            "radius",
        ),
    ];
    for (light, key) in cases {
        let src = format!(
            "[volume]\nphantom = {{ name = \"constant\", resolution = [4, 4, 4] }}\n[[lights]]\n{light}\n"
        );
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("scene.toml");
        std::fs::write(&path, &src).unwrap();
        let err = volphot::Scene::load(&path, &volphot::SearchPath::new(vec![]))
            .expect_err(light)
            .to_string();
        assert!(err.contains(key), "{light}: {err}");
        assert!(err.contains("scene.toml"), "{light}: {err}");
    }
}
