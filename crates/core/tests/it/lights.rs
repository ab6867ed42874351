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

/// The solid angle of a sun of angular diameter `degrees`, `2π(1 − cos θ)` with `θ` half
/// the diameter, computed as `4π sin²(θ/2)` (no cancellation).
fn sun_solid_angle(degrees: f64) -> f64 {
    let half = (degrees / 2.0).to_radians();
    4.0 * std::f64::consts::PI * (half / 2.0).sin().powi(2)
}

/// Towards the sun: above the cube, off every axis (so no coordinate of a direction near
/// it is exactly 0 or 1 in 32-bit floats) — where the 32-bit cone made the path tracer
/// 12 % dark and the photon renderer 75 % bright at 0.03°.
const SUN_DIRECTION: [f32; 3] = [1.0, -1.0, 1.0];

/// A sun above the cube ([`SUN_DIRECTION`]) of angular diameter `degrees` whose radiance
/// gives the irradiance `L·Ω = 1` at every size, over a sky too dim to matter.
fn sun_over_the_cube(degrees: f64, integrator: &str) -> volphot::Scene {
    let radiance = 1.0 / sun_solid_angle(degrees);
    let sun = format!(
        "[[lights]]\ntype = \"sky\"\nzenith = 1e-6\nhorizon = 1e-6\nground = 1e-6\nsun_direction = {SUN_DIRECTION:?}\nsun_radiance = {radiance:e}\nsun_angle = {degrees}\n"
    );
    cube(1.5, 0.8, 0.0, &sun, integrator)
}

/// Single scattering of the sun of `degrees` (irradiance 1, isotropic phase, albedo 0.8,
/// σt 1.5) averaged over the image, by quadrature: 2 × 2 positions a pixel, the eye ray in
/// 64 steps, the sun's disc in 8 rings × 8 directions of equal solid angle.
fn single_from_sun(scene: &volphot::Scene, degrees: f64) -> f32 {
    let (sigma_t, albedo) = (1.5f32, 0.8f32);
    let one_minus_cos = sun_solid_angle(degrees) / (2.0 * std::f64::consts::PI);
    let frame = volphot::Frame::from_w(Vec3::from(SUN_DIRECTION).normalize());
    let directions: Vec<Vec3> = (0..64)
        .map(|i| {
            let (ring, k) = (i / 8, i % 8);
            let omc = one_minus_cos * (ring as f64 + 0.5) / 8.0;
            let sin = (omc * (2.0 - omc)).sqrt();
            let phi = std::f64::consts::TAU * (k as f64 + 0.5) / 8.0;
            frame.to_world(Vec3::new(
                (sin * phi.cos()) as f32,
                (sin * phi.sin()) as f32,
                (1.0 - omc) as f32,
            ))
        })
        .collect();
    let (w, h) = (scene.camera().width(), scene.camera().height());
    let mut sum = 0.0f64;
    for py in 0..h {
        for px in 0..w {
            for s in 0..4 {
                let (x, y) = (
                    px as f32 + 0.25 + 0.5 * (s % 2) as f32,
                    py as f32 + 0.25 + 0.5 * (s / 2) as f32,
                );
                let ray = scene.camera().ray(x, y);
                let Some((t0, t1)) = scene.medium().clip(&ray) else {
                    continue;
                };
                let dt = (t1 - t0) / 64.0;
                for i in 0..64 {
                    let t = t0 + (i as f32 + 0.5) * dt;
                    let p = ray.at(t);
                    let shadow: f32 = directions
                        .iter()
                        .map(|&d| {
                            let inside = scene
                                .medium()
                                .clip(&Ray::new(p, d))
                                .map_or(0.0, |(s0, s1)| (s1 - s0).max(0.0));
                            (-sigma_t * inside).exp()
                        })
                        .sum::<f32>()
                        / directions.len() as f32;
                    let eye = (-sigma_t * (t - t0)).exp();
                    sum += (albedo * sigma_t * eye * shadow / (4.0 * PI) * dt) as f64;
                }
            }
        }
    }
    (sum / (4 * w * h) as f64) as f32
}

/// Suns of every size from 0.001° to 10° with the same irradiance render the same image
/// in the path tracer and in the photon renderer (its marcher's single scattering and its
/// photons' multiple scattering): single scattering within 2 % of the quadrature, and the
/// total within 3 % of the 1° sun's. In 32-bit floats the cone's `cos θ` rounded to 1 near
/// 0.02°: at 0.03° the path tracer was 12 % dark and the photon renderer 75 % bright, and
/// at 0.01° and below the sun was gone (a mean of 3·10⁻⁷ against 0.023).
#[test]
fn suns_of_every_size_with_one_irradiance_render_the_same_image() {
    let angles = [0.001, 0.01, 0.03, 0.1, 0.53, 1.0, 10.0];
    let mut totals = Vec::new();
    for &degrees in &angles {
        let traced_scene = sun_over_the_cube(degrees, "multiple = true\nstepsize = 0.01");
        let expected = single_from_sun(&traced_scene, degrees);
        let (film, _) = render_reference(&traced_scene, 1024, &Control::none()).unwrap();
        let (single, multiple) = (mean(&film, Layer::Single).x, mean(&film, Layer::Multiple).x);
        assert!(
            (single / expected - 1.0).abs() < 0.02,
            "{degrees}°: path tracer's single scattering {single} against the quadrature's {expected}"
        );
        let photon_scene = sun_over_the_cube(
            degrees,
            "volume_photons = 40000\nnused = 100\nmaxdist = 0.3\nstepsize = 0.01\nlight_samples = 4",
        );
        let out = render(&photon_scene, &Control::none()).unwrap();
        let marched = mean(&out.film, Layer::Single).x;
        assert!(
            (marched / expected - 1.0).abs() < 0.02,
            "{degrees}°: the photon renderer's single scattering {marched} against the quadrature's {expected}"
        );
        totals.push((
            degrees,
            single + multiple,
            marched + mean(&out.film, Layer::Multiple).x,
        ));
    }
    let &(_, traced_1, photons_1) = totals.iter().find(|t| t.0 == 1.0).unwrap();
    for &(degrees, traced, photons) in &totals {
        assert!(
            (traced / traced_1 - 1.0).abs() < 0.03 && (photons / photons_1 - 1.0).abs() < 0.03,
            "{degrees}°: totals {traced} (path tracer) and {photons} (photons) against the 1° sun's {traced_1} and {photons_1}"
        );
    }
}

/// The error of loading a scene file `name` holding `text` (in a folder of its own); a
/// scene that loads fails the test.
fn load_error(name: &str, text: &str) -> String {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join(name);
    std::fs::write(&path, text).unwrap();
    match volphot::Scene::load(&path, &volphot::SearchPath::new(vec![])) {
        Ok(_) => panic!("{name} loaded: {text}"),
        Err(e) => e.to_string(),
    }
}

/// A sun smaller than 32-bit directions resolve is refused, saying which angle renders
/// the same; the smallest accepted renders (the test above).
#[test]
fn a_sun_below_the_smallest_angle_is_refused_with_the_equivalent() {
    let err = load_error(
        "tiny-sun.toml",
        "[volume]\nphantom = { name = \"constant\", resolution = [4, 4, 4] }\n[[lights]]\ntype = \"sky\"\nsun_direction = [0, 0, 1]\nsun_radiance = 1e9\nsun_angle = 0.0001\n",
    );
    assert!(
        err.contains("tiny-sun.toml:7") && err.contains("sun_angle") && err.contains("0.001"),
        "{err}"
    );
}

/// A sky whose only light is its sun (zenith, horizon and ground 0) lights the cube; one
/// with neither colours nor a sun is refused as emitting nothing.
#[test]
fn a_sky_lit_by_its_sun_alone_renders() {
    let sun = "[[lights]]\ntype = \"sky\"\nzenith = 0\nhorizon = 0\nground = 0\nsun_direction = [0, 0, 1]\nsun_radiance = 20000\n";
    let scene = cube(1.5, 0.8, 0.0, sun, "multiple = false\nstepsize = 0.01");
    let lit = mean(
        &render(&scene, &Control::none()).unwrap().film,
        Layer::Single,
    )
    .x;
    assert!(lit > 0.01, "{lit}");
    let dark = "[volume]\nphantom = { name = \"constant\", resolution = [4, 4, 4] }\n[[lights]]\ntype = \"sky\"\nzenith = 0\nhorizon = 0\nground = 0\n";
    let err = load_error("dark.toml", dark);
    assert!(err.contains("dark.toml") && err.contains("no sun"), "{err}");
}

/// A rectangle or disc too small for 32-bit floats (its area 0 in `f32`) used to be
/// accepted and light nothing; it is refused naming its key.
#[test]
fn area_lights_too_small_for_32_bit_floats_are_refused() {
    for (light, key) in [
        (
            "type = \"rect\"\nposition = [0.5, 0.5, 2]\nnormal = [0, 0, -1]\nsize = [1e-30, 1e-30]\nradiance = 1",
            "size",
        ),
        (
            "type = \"disc\"\nposition = [0.5, 0.5, 2]\nnormal = [0, 0, -1]\nradius = 1e-23\nradiance = 1",
            "radius",
        ),
        (
            "type = \"disc\"\nposition = [1e5, 0.5, 2]\nnormal = [-1, 0, 0]\nradius = 0.01\nradiance = 1",
            "radius",
        ),
    ] {
        let err = load_error(
            "tiny.toml",
            &format!(
                "[volume]\nphantom = {{ name = \"constant\", resolution = [4, 4, 4] }}\n[[lights]]\n{light}\n"
            ),
        );
        assert!(
            err.contains("tiny.toml")
                && err.contains(&format!("lights[0].{key}"))
                && err.contains("32-bit"),
            "{light}: {err}"
        );
    }
}

/// A spot light narrower than 32-bit cosines resolve (`cone_angle = 0.0001`) had a solid
/// angle of 0, so its photons carried no power while its single scattering was lit; it is
/// refused naming the key.
#[test]
fn a_spot_narrower_than_32_bit_cosines_resolve_is_refused() {
    let err = load_error(
        "narrow.toml",
        "[volume]\nphantom = { name = \"constant\", resolution = [4, 4, 4] }\n[[lights]]\ntype = \"spot\"\nposition = [0.5, 0.5, 2]\ntarget = [0.5, 0.5, 0.5]\nintensity = 1\ncone_angle = 0.0001\n",
    );
    assert!(
        err.contains("narrow.toml:8") && err.contains("cone_angle") && err.contains("0.5"),
        "{err}"
    );
}

/// A slab of the homogeneous cube (the crop box `x ∈ [0.4, 0.6]`, across every eye ray) under
/// an environment whose
/// radiance is `above` over the upper hemisphere and `below` under it (a constant one
/// when they are equal): single scattering at the eye ray through (x, y) by quadrature — the eye
/// ray in 48 steps, the sphere of directions on a 48 × 96 grid, each direction's
/// transmittance from the exact chord to the slab's boundary (isotropic phase, albedo `a`).
fn single_from_environment(
    scene: &volphot::Scene,
    (x, y): (f32, f32),
    (above, below): (f32, f32),
    sigma_t: f32,
    a: f32,
) -> f64 {
    let ray = scene.camera().ray(x, y);
    let Some((t0, t1)) = scene.medium().clip(&ray) else {
        return 0.0;
    };
    let (n_t, n_theta, n_phi) = (48, 48, 96);
    let dt = (t1 - t0) / n_t as f32;
    let mut sum = 0.0f64;
    for i in 0..n_t {
        let t = t0 + (i as f32 + 0.5) * dt;
        let p = ray.at(t);
        let mut in_scattered = 0.0f64;
        for j in 0..n_theta {
            let theta = std::f64::consts::PI * (j as f64 + 0.5) / n_theta as f64;
            let d_omega = theta.sin()
                * (std::f64::consts::PI / n_theta as f64)
                * (std::f64::consts::TAU / n_phi as f64);
            let radiance = if theta < std::f64::consts::FRAC_PI_2 {
                above
            } else {
                below
            };
            for k in 0..n_phi {
                let phi = std::f64::consts::TAU * (k as f64 + 0.5) / n_phi as f64;
                let w = Vec3::new(
                    (theta.sin() * phi.cos()) as f32,
                    (theta.sin() * phi.sin()) as f32,
                    theta.cos() as f32,
                );
                let inside = scene
                    .medium()
                    .clip(&Ray::new(p, w))
                    .map_or(0.0, |(s0, s1)| (s1 - s0).max(0.0));
                in_scattered += radiance as f64 * (-(sigma_t * inside) as f64).exp() * d_omega;
            }
        }
        let eye = (-sigma_t * (t - t0)).exp() as f64;
        sum += (a * sigma_t) as f64 * eye * in_scattered / (4.0 * std::f64::consts::PI) * dt as f64;
    }
    sum
}

/// Light from an environment against a closed form: single scattering in a slab under a
/// constant environment and under one twice as bright above the horizon as below, from the
/// path tracer and from the marcher (as the disc does for area lights). The two-level map
/// is a file, its rows split at the horizon, so volphot's piecewise-constant texels are
/// exactly the two levels.
#[test]
fn an_environment_over_a_slab_matches_the_quadrature_in_every_integrator() {
    let (sigma_t, albedo) = (3.0, 0.8);
    let dir = tempfile::tempdir().unwrap();
    for (above, below) in [(0.6f32, 0.6f32), (1.2, 0.3)] {
        let (w, h) = (8usize, 4usize);
        let texels: Vec<Vec3> = (0..h)
            .flat_map(|row| {
                std::iter::repeat_n(Vec3::splat(if row < h / 2 { above } else { below }), w)
            })
            .collect();
        let map = dir.path().join(format!("two-level-{above}-{below}.pfm"));
        volphot::write_pfm(&map, w, h, &texels).unwrap();
        let lights = format!(
            "[[lights]]\ntype = \"environment\"\nfile = {:?}\n[clip]\nbox = {{ p0 = [0.4, 0, 0], p1 = [0.6, 1, 1] }}\n",
            map.display().to_string()
        );
        let scene = cube(
            sigma_t,
            albedo,
            0.0,
            &lights,
            "multiple = false\nstepsize = 0.002",
        );
        let (cw, ch) = (scene.camera().width(), scene.camera().height());
        let mut expected = 0.0;
        for py in 0..ch {
            for px in 0..cw {
                let at = (px as f32 + 0.5, py as f32 + 0.5);
                expected += single_from_environment(&scene, at, (above, below), sigma_t, albedo)
                    / (cw * ch) as f64;
            }
        }
        let expected = expected as f32;
        assert!(
            expected > 0.01,
            "the environment lights the slab: {expected}"
        );
        let (film, _) = render_reference(&scene, 1024, &Control::none()).unwrap();
        let traced = mean(&film, Layer::Single).x;
        assert!(
            (traced / expected - 1.0).abs() < 0.02,
            "path tracer {traced} against quadrature {expected} (above {above}, below {below})"
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
            "marcher {marched} against quadrature {expected} (above {above}, below {below})"
        );
    }
}
