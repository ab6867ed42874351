//! Progressive volume photon mapping (Knaus & Zwicker 2011, "probabilistic PPM", in 3-D),
//! and the beam estimate over independent photon maps (progressive beams).
//!
//! Iteration `i` traces a fresh, independent photon map of `M` photons and gathers with a
//! fixed radius `r_i` (a range query: every photon within `r_i`, no `nused`); the image is
//! the running mean of the iterations. The radius shrinks as
//!
//! `r_{i+1} = r_i · ((i + α)/(i + 1))^{1/3}`
//!
//! — the cube root because the kernel is 3-D: each iteration's variance ∝ 1/(M·r³) then
//! grows by `(i + 1)/(i + α)`, so the mean's variance falls as N^−α while the bias (∝ r²)
//! falls as N^−2(1−α)/3; with α in (0, 1) both vanish and the estimate converges to the
//! unbiased solution. Only one iteration's photons are held at a time. The single
//! (and emission) layers come from the first iteration's march; later marches add only
//! the multiple-scattering term, at the same eye samples (each pixel's random stream is
//! the same in every iteration), which the first march keeps (32 bytes a sample, up to
//! 4 GiB) so that later ones shade them without marching the medium again.
//!
//! The beam estimate ([`super::beam`]) runs through the same loop: its photons' own radii
//! shrink by one factor per iteration, `((i + α)/(i + 1))^{1/2}` (its kernel is a disc
//! across the ray), and with `iterations = 1` it is the plain beam estimate.

use std::time::Instant;

use glam::Vec3;
use serde::{Deserialize, Serialize};

use super::beam::{beam_masked, beam_radius};
use super::error_probes::CacheError;
use super::eye_samples::{EyeSampleStore, EyeSamples};
use super::gather::MsVariant;
use super::multiple::MsSource;
use super::pass::{MarchOutput, MarchStats, Measure, march_measured, photons_measured};
use crate::control::Control;
use crate::error::{Error, Result};
use crate::film::{Film, Layer};
use crate::photon::{
    BeamMap, PhotonMap, PhotonPlane, PhotonStats, PlaneMap, TraceSettings, trace, trace_planes,
};
use crate::scene::{EyeRays, IntegratorParams, Kernel, MsEstimator, Scene, Traces};

/// What a progressive render did.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct ProgressiveStats {
    /// Iterations completed (fewer than asked when the time budget ran out).
    pub iterations: u32,
    /// Photons per iteration.
    pub photons_per_iteration: u64,
    /// The gather radius of each iteration.
    pub radii: Vec<f32>,
    /// Photons stored per iteration.
    pub stored: Vec<u64>,
    /// The power the stored photons of each iteration carry (W, mean of RGB): the same
    /// in expectation every iteration.
    #[serde(default)]
    pub stored_power: Vec<f64>,
    /// Seconds spent tracing photons, all iterations.
    pub photon_seconds: f64,
    /// Seconds spent building search structures (kd-trees, beam hierarchies), all
    /// iterations.
    #[serde(default)]
    pub tree_seconds: f64,
    /// Seconds spent marching, all iterations.
    pub march_seconds: f64,
    /// Seconds spent marching, per iteration: the first renders every layer, the later
    /// ones the multiple layer alone, at the first one's eye samples.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub march_seconds_each: Vec<f64>,
    /// RMSE of the image after each iteration against the reference the render was given
    /// (empty without one).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub errors: Vec<f64>,
    /// Why the iterations stopped.
    #[serde(default)]
    pub stopped: StopReason,
}

/// Why a progressive render stopped iterating.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum StopReason {
    /// All `iterations` ran.
    #[default]
    Iterations,
    /// The `time_budget` ran out.
    TimeBudget,
    /// The image came within `target_rmse` of the reference.
    TargetRmse,
}

/// The result of [`render_progressive`].
#[derive(Debug, Clone)]
pub struct ProgressiveOutput {
    /// The image: single (and emission) layers of the first march, the mean multiple layer.
    pub film: Film,
    /// Counters of the first march.
    pub march: MarchStats,
    /// Statistics of the first photon map.
    pub photons: PhotonStats,
    /// What the iterations did.
    pub stats: ProgressiveStats,
    /// What thinning erred by, measured on the first iteration's march (its photon map
    /// and radius, single and multiple layers, as a points render measures its own march;
    /// `None` without thinning).
    pub cache_error: Option<CacheError>,
}

/// The radius of iteration `i + 1` from that of iteration `i` (1-based): the variance of
/// a kernel over `d` dimensions grows as `r^−d`, so `r^d` shrinks by `(i + α)/(i + 1)` —
/// `d = 3` for the point estimate's ball, `d = 2` for the beam estimate (its kernel,
/// integrated along the ray, is a disc across it), `d = 1` for the planes' blur.
pub fn next_radius(radius: f32, i: u32, alpha: f32, estimator: MsEstimator) -> f32 {
    estimator.shrink(radius, (i as f32 + alpha) / (i as f32 + 1.0))
}

/// Progress units of a render: image rows per march, times the iterations.
pub fn progress_rows(settings: &IntegratorParams, rows: u32) -> u64 {
    if settings.iterates() {
        rows as u64 * settings.iterations as u64
    } else {
        rows as u64
    }
}

/// Renders `scene` progressively (see the module docs): the `progressive` estimator, or
/// the `beam` estimate over `iterations` photon maps.
///
/// With a reference in `control` ([`Control::with_reference`]) the image's RMSE against it
/// is recorded after every iteration, and `target_rmse` stops the iterations once it is
/// reached; a target without a reference is an error.
pub fn render_progressive(scene: &Scene, control: &Control<'_>) -> Result<ProgressiveOutput> {
    let start = Instant::now();
    let s = scene.integrator().clone();
    check_reference(scene, &s, control)?;
    let photons = if s.photons_per_iteration > 0 {
        s.photons_per_iteration
    } else {
        s.volume_photons
    };
    let rows = scene.camera().height() as u64;
    let mut sums = Iterations::new(photons);
    let mut radius = first_radius(&s);
    // The first march's eye samples, which every later one shades again.
    let mut eye_samples: Option<EyeSampleStore> = None;
    for i in 1..=s.iterations {
        let traced = trace_iteration(scene, &s, i, photons, control)?;
        if let (1, Traced::Map(map)) = (i, &traced)
            && s.estimator.sizes_first_radius_from_map(&s)
        {
            radius = median_nused_distance(map, s.nused, s.maxdist);
        }
        let progress = |r: u64| control.report((i as u64 - 1) * rows + r);
        let iteration_control = control.with_progress(&progress);
        let pass = Pass {
            index: i,
            // The first march renders every layer, so it is the one thinning is measured on.
            measure: if i == 1 {
                Measure::asked_by(control)
            } else {
                Measure::Skip
            },
            eye: match (&eye_samples, i) {
                _ if s.eye_rays == EyeRays::Fresh => EyeSamples::March,
                (Some(store), _) => EyeSamples::Replay(store),
                (None, 1) if s.iterations > 1 => EyeSamples::Record,
                (None, _) => EyeSamples::March,
            },
        };
        let mut iteration = march_iteration(scene, &s, &traced, radius, &iteration_control, pass)?;
        eye_samples = eye_samples.or(iteration.eye_samples.take());
        sums.add(i, &traced, iteration, &s, control);
        radius = next_radius(radius, i, s.alpha, s.estimator);
        if let Some(stopped) = sums.stop_reason(&s, control, start) {
            sums.stats.stopped = stopped;
            break;
        }
    }
    Ok(sums.finish())
}

/// What the iterations of [`render_progressive`] have added up so far.
#[derive(Default)]
struct Iterations {
    stats: ProgressiveStats,
    /// The first iteration's film (its single and emission layers are the image's).
    film: Option<Film>,
    first_march: MarchStats,
    first_photons: PhotonStats,
    first_error: Option<CacheError>,
    /// The sum of the iterations' multiple layers.
    multiple_sum: Vec<Vec3>,
    /// With fresh eye rays: the sums of the iterations' single and emission layers.
    single_sum: Vec<Vec3>,
    emission_sum: Vec<Vec3>,
    /// With a reference: the first march's direct layers, the part of the image that no
    /// later iteration changes.
    direct: Vec<Vec3>,
}

impl Iterations {
    fn new(photons_per_iteration: u64) -> Self {
        Iterations {
            stats: ProgressiveStats {
                photons_per_iteration,
                ..Default::default()
            },
            ..Default::default()
        }
    }

    /// Adds iteration `i`, traced as `traced` and marched as `pass`.
    fn add(
        &mut self,
        i: u32,
        traced: &Traced,
        pass: IterationPass,
        s: &IntegratorParams,
        control: &Control<'_>,
    ) {
        let stats = &mut self.stats;
        stats.photon_seconds += traced.stats().seconds;
        stats.tree_seconds += traced.build_seconds();
        stats.tree_seconds += pass.build_seconds;
        stats.march_seconds += pass.march.seconds;
        stats.march_seconds_each.push(pass.march.seconds);
        stats.radii.push(pass.radius);
        stats.stored.push(traced.stats().stored);
        stats.stored_power.push(traced.stats().stored_power);
        stats.iterations = i;
        accumulate(&mut self.multiple_sum, pass.film.layer(Layer::Multiple));
        if s.eye_rays == EyeRays::Fresh {
            accumulate(&mut self.single_sum, pass.film.layer(Layer::Single));
            accumulate(&mut self.emission_sum, pass.film.layer(Layer::Emission));
        }
        if i == 1 {
            self.first_march = pass.march;
            self.first_error = pass.cache_error;
            self.first_photons = traced.stats().clone();
            if control.reference().is_some() {
                self.direct = pass.film.combine(&Layer::shown(false, s.emission));
            }
            self.film = Some(pass.film);
        }
    }

    /// Why the iterations stop after the last one added, if they do: the image came within
    /// the target of the reference (its error is recorded on the way), or the time ran out.
    fn stop_reason(
        &mut self,
        s: &IntegratorParams,
        control: &Control<'_>,
        start: Instant,
    ) -> Option<StopReason> {
        if let Some(reference) = control.reference() {
            let error = crate::film::rmse(&self.image(s.emission), reference);
            self.stats.errors.push(error);
            if s.target_rmse > 0.0 && error <= s.target_rmse as f64 {
                return Some(StopReason::TargetRmse);
            }
        }
        let out_of_time =
            s.time_budget > 0.0 && start.elapsed().as_secs_f64() >= s.time_budget as f64;
        out_of_time.then_some(StopReason::TimeBudget)
    }

    /// The image after the iterations so far, for a reference: the direct layers (the
    /// first march's, or their mean with fresh eye rays; emission when `emission`) plus the
    /// mean multiple layer.
    fn image(&self, emission: bool) -> Vec<Vec3> {
        let n = self.stats.iterations as f32;
        let direct = |k: usize| {
            if self.single_sum.is_empty() {
                return self.direct[k];
            }
            let glow = if emission {
                self.emission_sum[k]
            } else {
                Vec3::ZERO
            };
            (self.single_sum[k] + glow) / n
        };
        (0..self.multiple_sum.len())
            .map(|k| direct(k) + self.multiple_sum[k] / n)
            .collect()
    }

    /// The image (the first iteration's direct layers, or their mean with fresh eye rays;
    /// the mean multiple layer) and what the iterations did.
    fn finish(self) -> ProgressiveOutput {
        let mut film = self.film.expect("at least one iteration");
        let n = self.stats.iterations as f32;
        let mean = |sum: &[Vec3]| sum.iter().map(|v| *v / n).collect();
        film.set_layer(Layer::Multiple, mean(&self.multiple_sum));
        if !self.single_sum.is_empty() {
            film.set_layer(Layer::Single, mean(&self.single_sum));
            film.set_layer(Layer::Emission, mean(&self.emission_sum));
        }
        ProgressiveOutput {
            film,
            march: self.first_march,
            photons: self.first_photons,
            stats: self.stats,
            cache_error: self.first_error,
        }
    }
}

/// A target needs a reference of the camera's size.
fn check_reference(scene: &Scene, s: &IntegratorParams, control: &Control<'_>) -> Result<()> {
    let pixels = scene.camera().width() as usize * scene.camera().height() as usize;
    match control.reference() {
        None if s.target_rmse > 0.0 => Err(Error::parameter(
            "integrator.target_rmse",
            s.target_rmse,
            "0 when the render has no reference (set it in an experiment with [reference], which gives every cell its converged image)",
        )),
        Some(r) if r.len() != pixels => Err(Error::parameter(
            "integrator.target_rmse",
            s.target_rmse,
            format!("a reference of {pixels} pixels, not {}", r.len()),
        )),
        _ => Ok(()),
    }
}

/// The radius of the first iteration ([`MsEstimator::first_radius`]).
fn first_radius(s: &IntegratorParams) -> f32 {
    s.estimator.first_radius(s)
}

/// What one iteration traced: a photon map, or the paths' flights as planes.
enum Traced {
    Map(PhotonMap),
    Planes(Vec<PhotonPlane>, PhotonStats),
}

impl Traced {
    fn stats(&self) -> &PhotonStats {
        match self {
            Traced::Map(map) => map.stats(),
            Traced::Planes(_, stats) => stats,
        }
    }

    /// Seconds spent building the map's kd-tree (planes build their hierarchy per march).
    fn build_seconds(&self) -> f64 {
        match self {
            Traced::Map(map) => map.build_seconds(),
            Traced::Planes(..) => 0.0,
        }
    }
}

/// The photons of iteration `i`: its own seed, so iterations are independent.
fn trace_iteration(
    scene: &Scene,
    s: &IntegratorParams,
    i: u32,
    photons: u64,
    control: &Control<'_>,
) -> Result<Traced> {
    let settings = TraceSettings {
        photons,
        stored_target: 0,
        free_path: s.free_path,
        stepsize: s.stepsize,
        seed: s.seed ^ ((i as u64) << 40),
    };
    let (medium, lights) = (scene.medium(), scene.lights());
    Ok(match s.estimator.traces() {
        Traces::Planes => {
            let (planes, stats) = trace_planes(medium, lights, &settings, control)?;
            Traced::Planes(planes, stats)
        }
        Traces::Photons => {
            let (photons, stats) = trace(medium, lights, &settings, control)?;
            Traced::Map(PhotonMap::new(photons, stats))
        }
    })
}

/// What one iteration's march produced.
struct IterationPass {
    film: Film,
    march: MarchStats,
    /// The (mean) gather radius used.
    radius: f32,
    /// What thinning erred by, when the pass measured it.
    cache_error: Option<CacheError>,
    /// Seconds spent building the beams' hierarchy (0 for point gathers, whose kd-tree is
    /// the photon map's).
    build_seconds: f64,
    /// The eye samples the pass kept for later ones.
    eye_samples: Option<EyeSampleStore>,
}

/// Which iteration a march is (1-based), whether it measures thinning's error, and where
/// its eye samples come from.
struct Pass<'a> {
    index: u32,
    measure: Measure,
    eye: EyeSamples<'a>,
}

/// One iteration's march: everything in the first, the multiple term alone afterwards
/// (measuring what thinning errs by when the pass asks). Later iterations shade the first
/// one's eye samples again instead of marching the medium: each pixel's random stream is
/// the same every iteration, so its samples are too, and only the photon map and the
/// radius differ (the same image to the bit, a test checks it).
fn march_iteration(
    scene: &Scene,
    s: &IntegratorParams,
    traced: &Traced,
    radius: f32,
    control: &Control<'_>,
    pass: Pass<'_>,
) -> Result<IterationPass> {
    let Pass {
        index: i,
        measure,
        eye,
    } = pass;
    let scene = scene.with_integrator(iteration_settings(s, i))?;
    let map = match traced {
        Traced::Planes(planes, _) => {
            let start = Instant::now();
            let planes = PlaneMap::new(planes, radius);
            let build_seconds = start.elapsed().as_secs_f64();
            let source = MsSource::Planes(&planes);
            let (out, eye_samples) = photons_measured(&scene, source, control, measure, eye)?;
            return Ok(IterationPass::of(out, radius, build_seconds, eye_samples));
        }
        Traced::Map(map) => map,
    };
    let kernel = s.estimator.kernel(s);
    if matches!(kernel, Kernel::Beams | Kernel::Spheres) {
        let start = Instant::now();
        let beams = BeamMap::new(map, beam_radius(s, radius), scene.medium(), beam_masked(s));
        let build_seconds = start.elapsed().as_secs_f64();
        let source = if kernel == Kernel::Beams {
            MsSource::Beams(&beams)
        } else {
            MsSource::Spheres(&beams)
        };
        let (out, eye_samples) = photons_measured(&scene, source, control, measure, eye)?;
        // The hierarchy is a search structure built once per map, like a kd-tree: its
        // time is the tree's, not the march's (which scales with the pixels).
        return Ok(IterationPass::of(
            out,
            beams.mean_radius(),
            build_seconds,
            eye_samples,
        ));
    }
    let variant = MsVariant {
        map: 0,
        nused: u32::MAX, // a range query: every photon within the radius
        maxdist: radius,
        estimate: s.estimate,
    };
    let (out, eye_samples) = march_measured(&scene, &[map], &[variant], control, measure, eye)?;
    Ok(IterationPass::of(out, radius, 0.0, eye_samples))
}

/// The settings of iteration `i`'s march: after the first, the multiple layer alone at the
/// same eye rays — or, with fresh eye rays, every layer at eye rays of their own (the
/// pixels' streams are keyed by the seed).
fn iteration_settings(s: &IntegratorParams, i: u32) -> IntegratorParams {
    let mut settings = s.clone();
    if i == 1 {
        return settings;
    }
    match s.eye_rays {
        EyeRays::Replayed => (settings.single, settings.emission) = (false, false),
        EyeRays::Fresh => settings.seed = crate::math::mix64(s.seed ^ ((i as u64) << 32)),
    }
    settings
}

impl IterationPass {
    /// The pass of one iteration from its march's output (one film).
    fn of(
        mut out: MarchOutput,
        radius: f32,
        build_seconds: f64,
        eye_samples: Option<EyeSampleStore>,
    ) -> Self {
        IterationPass {
            film: out.films.swap_remove(0),
            march: out.stats,
            radius,
            cache_error: out.cache_errors.swap_remove(0),
            build_seconds,
            eye_samples,
        }
    }
}

/// The median over (up to 1000 of) the map's photons of the distance to their `nused`-th
/// neighbour, at most `maxdist`.
fn median_nused_distance(map: &PhotonMap, nused: u32, maxdist: f32) -> f32 {
    let photons = map.photons();
    if photons.is_empty() {
        return maxdist;
    }
    let step = photons.len().div_ceil(1000);
    let mut distances: Vec<f32> = photons
        .iter()
        .step_by(step)
        .map(|p| {
            let hits = map.gather(p.position, nused as usize, maxdist);
            if hits.len() == nused as usize {
                hits.last().map_or(maxdist, |h| h.0.sqrt())
            } else {
                maxdist
            }
        })
        .collect();
    distances.sort_by(f32::total_cmp);
    distances[distances.len() / 2].max(f32::MIN_POSITIVE)
}

fn accumulate(sum: &mut Vec<Vec3>, layer: &[Vec3]) {
    if sum.is_empty() {
        sum.resize(layer.len(), Vec3::ZERO);
    }
    for (s, v) in sum.iter_mut().zip(layer) {
        *s += *v;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_util::{SPOT_SPHERE, scene as scene_from};

    /// The multiple layer of `iterations` passes that each march the medium again, as
    /// [`render_progressive`] did before it kept the first pass's eye samples.
    fn marching_every_pass(scene: &Scene, iterations: u32) -> Vec<Vec3> {
        let s = scene.integrator().clone();
        let control = Control::none();
        let mut radius = first_radius(&s);
        let mut sum = Vec::new();
        for i in 1..=iterations {
            let map = trace_iteration(scene, &s, i, s.photons_per_iteration, &control).unwrap();
            if let (1, Traced::Map(m)) = (i, &map)
                && s.estimator.sizes_first_radius_from_map(&s)
            {
                radius = median_nused_distance(m, s.nused, s.maxdist);
            }
            let pass = Pass {
                index: i,
                measure: Measure::Skip,
                eye: EyeSamples::March,
            };
            let out = march_iteration(scene, &s, &map, radius, &control, pass).unwrap();
            assert!(out.eye_samples.is_none());
            accumulate(&mut sum, out.film.layer(Layer::Multiple));
            radius = next_radius(radius, i, s.alpha, s.estimator);
        }
        sum.iter().map(|v| *v / iterations as f32).collect()
    }

    #[test]
    fn later_iterations_shade_the_first_eye_samples_to_the_bit() {
        // Not square and two eye rays a pixel, so a sample store indexed wrongly by row,
        // pixel or ray would shade another ray's samples; thinned (the default).
        let src = SPOT_SPHERE.replace("resolution = [20, 20]", "resolution = [13, 9]");
        for estimator in [
            MsEstimator::Progressive,
            MsEstimator::Beam,
            MsEstimator::Plane,
        ] {
            let mut settings = scene_from(&src).integrator().clone();
            settings.estimator = estimator;
            settings.iterations = 4;
            settings.photons_per_iteration = 4_000;
            settings.spp = 2;
            let scene = scene_from(&src).with_integrator(settings).unwrap();
            let out = render_progressive(&scene, &Control::none()).unwrap();
            let expected = marching_every_pass(&scene, 4);
            let got = out.film.layer(Layer::Multiple);
            assert!(got.iter().any(|v| v.x > 0.0), "{estimator:?}: a lit image");
            let same = got
                .iter()
                .zip(&expected)
                .all(|(a, b)| a.to_array().map(f32::to_bits) == b.to_array().map(f32::to_bits));
            assert!(same, "{estimator:?}: the replayed passes differ");
        }
    }

    #[test]
    fn radii_follow_the_closed_form_schedule() {
        // r_N³ / r_1³ = Γ(N + α) / (Γ(1 + α) Γ(N + 1)) ~ N^(α−1) / Γ(1 + α).
        let alpha = 0.5f32;
        let mut r = 1.0f32;
        for i in 1..1000 {
            r = next_radius(r, i, alpha, MsEstimator::Progressive);
        }
        let n = 1000f64;
        let gamma_1_alpha = 0.886_226_925_452_758f64; // Γ(1.5)
        let asymptotic = n.powf(alpha as f64 - 1.0) / gamma_1_alpha;
        assert!(((r as f64).powi(3) / asymptotic - 1.0).abs() < 0.01, "{r}");
    }
}
