//! The path tracer's two trackers (`[integrator] tracker`): each against an independent
//! estimate of a homogeneous cube's single and multiple scattering (analytic
//! transmittance and free paths, no majorants, no tracking), and against each other
//! pixel by pixel on a heterogeneous phantom; and the weighted tracker's recorded
//! variance against the spread of its images over seeds.

use glam::Vec3;
use volphot::test_util as common;
use volphot::{Control, Layer, ReferenceAccumulator, Scene, Tracker};

/// A homogeneous unit cube (σt = 4, albedo 0.75) seen by a 1×1 camera along +y through its
/// centre, lit by a point light at (1.5, 0.5, 0.5) (`physics.rs`'s closed-form scene, with
/// multiple scattering).
const CUBE: &str = r#"
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
"#;

const SIGMA_T: f64 = 4.0;
const ALBEDO: f64 = 0.75;
const LIGHT: [f64; 3] = [1.5, 0.5, 0.5];

fn with_tracker(scene: &Scene, tracker: Tracker) -> Scene {
    let mut integrator = scene.integrator().clone();
    integrator.tracker = tracker;
    scene.with_integrator(integrator).unwrap()
}

/// Mean and standard error of `n` samples' sums.
fn mean_and_error(sum: f64, sum2: f64, n: f64) -> (f64, f64) {
    let mean = sum / n;
    (mean, ((sum2 / n - mean * mean) / (n - 1.0)).max(0.0).sqrt())
}

/// A small deterministic generator for the independent estimate (SplitMix64).
struct SplitMix(u64);

impl SplitMix {
    fn uniform(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// The distance from `p` (inside the unit cube) along unit `d` to the cube's surface.
fn to_surface(p: [f64; 3], d: [f64; 3]) -> f64 {
    (0..3)
        .filter(|&a| d[a] != 0.0)
        .map(|a| {
            if d[a] > 0.0 {
                (1.0 - p[a]) / d[a]
            } else {
                -p[a] / d[a]
            }
        })
        .fold(f64::INFINITY, f64::min)
}

/// Light from the point light arriving at `p` and scattered isotropically (before σs/σt).
fn direct(p: [f64; 3]) -> f64 {
    let d = [LIGHT[0] - p[0], LIGHT[1] - p[1], LIGHT[2] - p[2]];
    let r2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
    // The shadow ray leaves the cube through x = 1 (the light is at x = 1.5).
    let inside = (1.0 - p[0]) / d[0] * r2.sqrt();
    (-SIGMA_T * inside).exp() / r2 / (4.0 * std::f64::consts::PI)
}

/// A collision forced inside `length` (distance, and the probability one happens there).
fn forced_collision(length: f64, rng: &mut SplitMix) -> (f64, f64) {
    let p = 1.0 - (-SIGMA_T * length).exp();
    ((-(1.0 - rng.uniform() * p).ln()) / SIGMA_T, p)
}

/// Single and multiple scattering of [`CUBE`]'s pixel by forced collisions with analytic
/// transmittance: per layer, mean and standard error over `paths`.
fn independent_estimate(paths: usize) -> [(f64, f64); 2] {
    let mut rng = SplitMix(0x5eed);
    let mut sums = [[0.0f64; 2]; 2];
    for _ in 0..paths {
        let (t, p_hit) = forced_collision(1.0, &mut rng);
        let mut p = [0.5, t, 0.5];
        let mut weight = p_hit * ALBEDO;
        let single = weight * direct(p);
        let mut multiple = 0.0;
        loop {
            let z = 1.0 - 2.0 * rng.uniform();
            let phi = 2.0 * std::f64::consts::PI * rng.uniform();
            let s = (1.0 - z * z).max(0.0).sqrt();
            let d = [s * phi.cos(), s * phi.sin(), z];
            let (t, p_hit) = forced_collision(to_surface(p, d), &mut rng);
            p = [p[0] + t * d[0], p[1] + t * d[1], p[2] + t * d[2]];
            weight *= p_hit * ALBEDO;
            multiple += weight * direct(p);
            if weight < 0.05 {
                if rng.uniform() >= weight / 0.05 {
                    break;
                }
                weight = 0.05;
            }
        }
        for (s, v) in sums.iter_mut().zip([single, multiple]) {
            s[0] += v;
            s[1] += v * v;
        }
    }
    sums.map(|[s, s2]| mean_and_error(s, s2, paths as f64))
}

#[test]
fn both_trackers_match_an_independent_estimate_in_a_homogeneous_cube() {
    let [single, multiple] = independent_estimate(400_000);
    let base = common::scene(CUBE);
    for tracker in [Tracker::Delta, Tracker::Weighted] {
        let scene = with_tracker(&base, tracker);
        let (film, _) = volphot::render_reference(&scene, 200_000, &Control::none()).unwrap();
        for (layer, (expected, error)) in [(Layer::Single, single), (Layer::Multiple, multiple)] {
            let got = film.layer(layer)[0].x as f64;
            let sigma = (film.variance(layer).unwrap()[0].x as f64).sqrt();
            let z = (got - expected) / sigma.hypot(error);
            assert!(
                z.abs() < 4.0,
                "{tracker:?} {layer:?}: {got} ± {sigma} vs independent {expected} ± {error} (z = {z:.2})"
            );
        }
    }
}

/// The foot phantom, small, with the three-point lights: heterogeneous, with empty space.
fn phantom() -> Scene {
    common::scene(
        r#"
[volume]
phantom = { name = "foot", resolution = [32, 32, 32] }
[sigma]
t = 40
[camera]
eye = [2.0, -1.4, 1.6]
look_at = [0.5, 0.5, 0.5]
up = [0, 0, 1]
fov = 30
resolution = [48, 40]
[three_point]
key_intensity = 40
"#,
    )
}

fn render(scene: &Scene, passes: u32, seed: u64) -> ReferenceAccumulator {
    let mut integrator = scene.integrator().clone();
    integrator.seed = seed;
    let scene = scene.with_integrator(integrator).unwrap();
    let camera = scene.camera();
    let mut acc = ReferenceAccumulator::new(camera.width() as usize, camera.height() as usize);
    acc.add_passes(&scene, passes, &Control::none()).unwrap();
    acc
}

fn mean3(v: Vec3) -> f64 {
    (v.x as f64 + v.y as f64 + v.z as f64) / 3.0
}

#[test]
fn the_weighted_tracker_agrees_with_the_delta_tracker_pixel_by_pixel() {
    let base = phantom();
    // Different seeds: with the same one both trackers draw the same pixel positions and
    // first collisions, and their difference would be less noisy than their variances say.
    let delta = render(&with_tracker(&base, Tracker::Delta), 1024, 7);
    let weighted = render(&with_tracker(&base, Tracker::Weighted), 1024, 8);
    let (a, b) = (delta.film(), weighted.film());
    let (va, vb) = (
        delta.total_variance().unwrap(),
        weighted.total_variance().unwrap(),
    );
    let (ta, tb) = (a.total(), b.total());
    // Per pixel: z² averages 1 when the images agree and each records its own variance.
    let z2: Vec<f64> = (0..ta.len())
        .filter(|&i| mean3(va[i] + vb[i]) > 0.0)
        .map(|i| (mean3(ta[i]) - mean3(tb[i])).powi(2) / mean3(va[i] + vb[i]))
        .collect();
    let chi2 = z2.iter().sum::<f64>() / z2.len() as f64;
    assert!(z2.len() > 200, "{} pixels with light", z2.len());
    assert!(
        (0.75..1.33).contains(&chi2),
        "mean z² = {chi2} over {} pixels",
        z2.len()
    );
    // The image means, layer by layer.
    for layer in [Layer::Single, Layer::Multiple] {
        let mean = |f: &volphot::Film| f.mean(layer);
        let error = |f: &volphot::Film| {
            let v = f.variance(layer).unwrap();
            (v.iter().map(|v| mean3(*v)).sum::<f64>()).sqrt() / v.len() as f64
        };
        let z = (mean(&a) - mean(&b)) / error(&a).hypot(error(&b));
        assert!(
            z.abs() < 4.0,
            "{layer:?}: delta {} vs weighted {} (z = {z:.2})",
            mean(&a),
            mean(&b)
        );
    }
}

#[test]
fn the_weighted_trackers_recorded_variance_is_its_spread_over_seeds() {
    // Each seed has its own pilot and so its own allocation; the variance of a pixel's
    // mean over seeds is the mean over seeds of σ²/n, which each render records.
    let scene = with_tracker(&phantom(), Tracker::Weighted);
    let seeds = 24;
    let renders: Vec<ReferenceAccumulator> =
        (0..seeds).map(|s| render(&scene, 8, 100 + s)).collect();
    let totals: Vec<Vec<Vec3>> = renders.iter().map(|r| r.film().total()).collect();
    let recorded: Vec<Vec<Vec3>> = renders
        .iter()
        .map(|r| r.total_variance().unwrap())
        .collect();
    let (mut spread, mut noted) = (0.0f64, 0.0f64);
    for i in 0..totals[0].len() {
        let values: Vec<f64> = totals.iter().map(|t| mean3(t[i])).collect();
        let mean = values.iter().sum::<f64>() / seeds as f64;
        spread += values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (seeds - 1) as f64;
        noted += recorded.iter().map(|r| mean3(r[i])).sum::<f64>() / seeds as f64;
    }
    let ratio = spread / noted;
    assert!(
        (0.8..1.25).contains(&ratio),
        "spread over seeds / recorded = {ratio}"
    );
    // The allocation is not uniform: some pixels hold several times the samples of others.
    let samples = renders[0].samples_per_pixel();
    let (least, most) = (samples.iter().min().unwrap(), samples.iter().max().unwrap());
    assert!(*most >= 4 * *least, "samples per pixel {least}..{most}");
}
