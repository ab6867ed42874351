//! Renderer settings (`[integrator]` and `[film]` in a scene) and their defaults.
//!
//! The defaults are the thesis's recommended values (§7.1.1, §8.1.3) where it gives them:
//!
//! | key | default | source |
//! |---|---|---|
//! | `volume_photons` | 40 000 | §8.1.3 "about 40 000 photons" (emitted) |
//! | `stored_photons` | 0 (off) | a stored-photon target (Jensen, pbrt): emit until the map holds this many; `volume_photons` is the first round |
//! | `nused` | 150 | §8.1.1: no disco-ball artifacts from 150 on |
//! | `maxdist` | 0.1 | §8.1.3: 10 % of the longest axis |
//! | `stepsize` | 0.0005 | §8.1.3 |
//! | `emission` / `single` / `multiple` | false / true / true | §7.1.1 |
//! | `free_path` | `delta` | correct sampler; `thesis` reproduces §5.1/§7.1.2 |
//! | `shadow` | `exact` | transmittance to the light from the exact optical depth (`march`: §6's ray marching) |
//! | `quadrature` | `exact` | per-segment `(1 − e^{−σtΔx})/σt` instead of `Δx` |
//! | `estimate` | `masked` | `σs(x)·Σ p ΔΦ/(σt(x_p)·V_m)`, `V_m` the medium's share of the gather sphere; `fluence` divides by the whole sphere, `albedo` and `thesis` (eq. 11) also assume σt constant in it |
//! | `termination` | 0.001 | stop marching eye and shadow rays when transmittance < 0.1 % |
//! | `shadow_stride` | 8 | exact optical depth at every 8th sample and wherever interpolating it would err by more than `shadow_tolerance` (0: every sample) |
//! | `shadow_tolerance` | 0.025 | the optical-depth difference at a checked midpoint below which the shadow fill interpolates (2.5 % in transmittance); 0.05 until issue #17 measured single-scattering p99 up to 4.2 % with it at σt(d_min) 290 |
//! | `thin_below` | 0.5 | behind the front, where the eye transmittance is below this, gathers and shadow fills are spaced out by band and interpolated where a checked midpoint agrees (0: every sample); measured within 0.30 % in the mean and 1.4 % at p99 of the unthinned marcher at 1.6–2.3× its speed on the thesis's settings; each render records its own error (README "Performance") |
//! | `shadow_cache`, `ms_cache` | 0 (off) | exact path by default |
//! | `spp` | 1 | one jittered eye ray per pixel, as the thesis |
//! | `reference_spp` | 64 | reference path tracer passes: samples per pixel (with `tracker = "weighted"` on average, by cost) |
//! | `tracker` | `weighted` | how the path tracer samples paths; `delta` is the tracer every reference before issue #47 was rendered with |
//! | `seed` | 1 | |
//! | `estimator` | `points` | the thesis's k-NN point estimate; `progressive`, `beam` and `plane` are consistent / stepsize-free alternatives |
//! | `alpha` | 0.3 | radius shrink per iteration: `((i+α)/(i+1))^{1/3}` for points (3-D kernel), `^{1/2}` for beams (a 2-D kernel across the ray), `^1` for planes (a 1-D blur) |
//! | `iterations`, `photons_per_iteration`, `time_budget` | 16, 0 (= `volume_photons`), 0 (none) | progressive and beam: independent photon maps averaged (beam with 1: the plain beam estimate) |
//! | `target_rmse` | 0 (off) | progressive and beam: stop after the iteration whose image is within this RMSE of the reference (in an experiment with `[reference]`) |
//! | `radius` | `auto` | progressive and beam: `global` (one radius; progressive's `auto`), `nearest` (each photon's `nused`-th-neighbour distance; the beams' `auto`) or `balanced` (`r_k^{3/7}·σt^{−4/7}`, the asymptotic-MSE balance) |
//! | `light_samples` | 1 | the marcher's directions drawn from each area or environment light at every eye-ray step, each with its own shadow ray: the steps are a few voxels apart, so a pixel already averages hundreds of light samples along its ray, and more per step multiplies the shadow rays |
//! | `eye_rays` | `replayed` | progressive, beam and plane: later iterations shade the first one's eye samples; `fresh` draws new eye rays every iteration and averages every layer (converges per pixel, a full march per iteration) |
//! | `initial_radius` | `nused` | progressive: median `nused`-th-neighbour distance of the first map; beam: each photon's own `nused`-th-neighbour distance (or `maxdist` for both) |
//! | `film.exposure` | 0 | stops applied before sRGB encoding |

use serde::{Deserialize, Serialize};

use super::estimator::{
    Estimate, EstimatorSettings, ITERATION_KEYS, InitialRadius, MsEstimator, RadiusRule,
};
use crate::error::{Error, Result, check_range};
use crate::medium::FreePath;

/// The eye transmittance below which the marcher thins its gathers and optical-depth fills
/// (`thin_below`). At 0.5 the headline frame rendered 1.8× faster than with every sample,
/// 0.17 % darker in single scattering and +0.01 % in multiple (p99 1.3 %); five more scenes
/// at 256² stayed within 0.30 % and 1.4 % (`sweep bench --only marched,exact,thinned`,
/// README "Performance"), inside the 0.5 % / 2 % bounds the default must keep. Over the
/// committed studies the mean stayed within 0.36 %; where the photon estimate is noisy
/// (maxdist 0.02, 10 000 photons) the per-pixel p99 of the multiple layer reached 22 %
/// with unchecked interpolation and 8.8 % since the gathers are checked at midpoints
/// (`reports/REPRODUCTION.md`); every thinned render measures and records its own.
pub const DEFAULT_THIN_BELOW: f32 = 0.5;

/// The largest optical-depth difference between a checked midpoint's exact value and the
/// straight line through its interval's ends at which the shadow fill still interpolates
/// (`shadow_tolerance`; in thinned band `b` it is this divided by the band's largest eye
/// transmittance, `thin_below / 2^(b−1)`, so no band adds more pixel error than the
/// front). At 0.05, the value
/// before it was a setting, the single-scattering layer of the real foot at σt(d_min) 290
/// (160², step 0.001) was 4.2 % off at p99 of rendering every sample; at 0.025 it is 1.7 %,
/// and the headline frame's single-layer bias halved (−0.12 % → −0.06 %) for 6–8 % more
/// render time (README "Performance"). Paper-quality and tuning studies pin 0.05, the value
/// their committed cells were rendered with.
pub const DEFAULT_SHADOW_TOLERANCE: f32 = 0.025;

/// The progressive radius parameter α, chosen by measurement (`experiments/alpha.toml`,
/// `reports/alpha/`): over 16–64 iterations on the real foot, engine and head at σt(d_min)
/// 80 the error is still bias-dominated, and α = 0.3 (the fastest shrink tried) gave the
/// lowest RMSE against the path-traced reference — 6–8 % below 4/7 on the engine and head
/// after 64 iterations, equal on the foot. Asymptotically 4/7 balances variance (∝ N^−α)
/// and squared bias (∝ N^−4(1−α)/3) of a 3-D kernel; that regime lies beyond the iteration
/// counts a study can afford.
pub const DEFAULT_ALPHA: f32 = 0.3;

/// The most photons a map may be traced with (`volume_photons`, `photons_per_iteration`).
pub const MAX_PHOTONS: u64 = 100_000_000;

/// How shadow-ray transmittance to a light is estimated.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ShadowEstimator {
    /// The exact integral of σt, cell by cell through the voxel grid (no step, no noise):
    /// the limit the thesis's marching converges to. The default.
    Exact,
    /// Ray marching with `stepsize` (thesis §6), for studies of the step itself.
    March,
    /// Unbiased ratio tracking over the majorant bricks.
    Ratio,
}

/// Quadrature of the source term over one ray-marching segment.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Quadrature {
    /// `S·(1 − e^{−σt Δx})/σt`: exact for a segment with constant coefficients.
    Exact,
    /// `S·Δx` as in the thesis's combined formula (§6); overshoots when `σt·Δx` is large.
    Riemann,
}

/// How the reference path tracer (`method = "reference"`) samples its paths. Both are
/// unbiased; they differ in noise per CPU-second.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Tracker {
    /// The tracer every reference before issue #47 was rendered with: Russian roulette
    /// with the albedo at every delta-tracked collision, next-event estimation to every
    /// light, one sample per pixel per pass.
    Delta,
    /// The same collisions with the albedo as a weight (roulette only below a throughput
    /// of 0.3), next-event estimation to one light chosen by its unshadowed contribution
    /// after the first vertex, and each pixel's share of the samples set by a pilot. The
    /// default: 1.5–1.9× as efficient as `delta` on the thesis's frames (issue #47).
    Weighted,
}

/// Which eye rays the iterations of a progressive, beam or plane render shade.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum EyeRays {
    /// The first iteration's: later iterations shade its eye samples again with their own
    /// photons, and the single and emission layers come from the first march alone. Cheap
    /// (no march after the first), but the image converges to the estimate of those fixed
    /// rays, so each pixel keeps the sampling error of its `spp` jittered rays.
    #[default]
    Replayed,
    /// New jittered eye rays every iteration (stochastic progressive photon mapping,
    /// Hachisuka & Jensen 2009): every layer is the mean over the iterations, so the image
    /// converges to each pixel's integral, at the cost of a full march per iteration.
    Fresh,
}

/// Which renderer produces the image.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Method {
    /// Volume photon mapping + ray marching (the thesis's method).
    Photon,
    /// The unbiased reference path tracer.
    Reference,
}

/// `[integrator]` as written in a scene file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct IntegratorParams {
    /// `photon` or `reference`.
    pub method: Method,
    /// The path tracer's sampling (`method = "reference"` only).
    pub tracker: Tracker,
    /// Photons emitted in total over all lights (with `stored_photons`: in the first
    /// round).
    pub volume_photons: u64,
    /// Photons the map must hold (0: off, `volume_photons` are emitted): the tracer emits
    /// as many as it takes, each photon's power still divided by its light's emitted count
    /// (Jensen's photon map, pbrt's). Only the point estimate's one map. Not written when
    /// 0, so content addresses stay what they were.
    #[serde(skip_serializing_if = "is_zero_u64")]
    pub stored_photons: u64,
    /// Photons used per radiance estimate.
    pub nused: u32,
    /// Largest gather radius (world units).
    pub maxdist: f32,
    /// Ray-marching step (world units).
    pub stepsize: f32,
    /// Add the emission layer.
    pub emission: bool,
    /// Add single scattering.
    pub single: bool,
    /// Add multiple scattering from the photon map.
    pub multiple: bool,
    /// Free-path rule for photons.
    pub free_path: FreePath,
    /// Shadow transmittance estimator.
    pub shadow: ShadowEstimator,
    /// Segment quadrature.
    pub quadrature: Quadrature,
    /// Radiance-estimate normalisation.
    pub estimate: Estimate,
    /// Transmittance below which eye and shadow rays stop marching.
    pub termination: f32,
    /// Per-light transmittance cache resolution along the longest axis (0 = off).
    pub shadow_cache: u32,
    /// Multiple-scattering cache resolution along the longest axis (0 = off).
    pub ms_cache: u32,
    /// With `shadow = "exact"`: the optical depth to each light is computed at every
    /// this-many-th sample of an eye ray and at interval midpoints, and interpolated only
    /// where the midpoint agrees with the straight line (within `shadow_tolerance`); shadow
    /// and cone edges get exact values at every sample. 0 computes every sample.
    pub shadow_stride: u32,
    /// With `shadow_stride > 0`: the optical-depth difference at a checked midpoint up to
    /// which the fill interpolates (0: only where the line is exact). Always written; a
    /// cell's content address leaves it out at 0.05, its value before it was a setting.
    pub shadow_tolerance: f32,
    /// Eye transmittance below which the marcher spaces out its photon-map gathers and its
    /// optical-depth fills, doubling the spacing at each halving of the transmittance, and
    /// interpolates in between where a checked midpoint agrees with the straight line
    /// (0 = off, every sample as above). Always written, so a
    /// record says which it was; a cell's content address leaves it out when 0, as before
    /// it had a default (`sweep`'s store).
    pub thin_below: f32,
    /// Eye rays per pixel for the photon integrator.
    pub spp: u32,
    /// Samples per pixel for the reference path tracer.
    pub reference_spp: u32,
    /// Random seed.
    pub seed: u64,
    /// How multiple scattering is estimated from photons.
    pub estimator: MsEstimator,
    /// Progressive: the radius shrink parameter α in (0, 1).
    pub alpha: f32,
    /// Progressive: iterations (each a fresh photon map).
    pub iterations: u32,
    /// Progressive: photons per iteration (0: `volume_photons`).
    pub photons_per_iteration: u64,
    /// Progressive: stop after the iteration that passes this many seconds (0: no limit).
    pub time_budget: f32,
    /// Progressive: stop after the iteration whose image is within this RMSE of the
    /// reference the render is given (0: no target). Not written when 0, so the content
    /// addresses of cells without a target stay what they were.
    #[serde(skip_serializing_if = "is_zero")]
    pub target_rmse: f32,
    /// Progressive: where the first radius comes from.
    pub initial_radius: InitialRadius,
    /// Progressive and beam: how the radius varies in space. Not written when `auto`, so
    /// the content addresses of cells that do not set it stay what they were.
    #[serde(skip_serializing_if = "is_auto")]
    pub radius: RadiusRule,
    /// Progressive, beam and plane: which eye rays the iterations shade. Not written when
    /// `replayed`, so the content addresses of cells that do not set it stay what they were.
    #[serde(skip_serializing_if = "is_replayed")]
    pub eye_rays: EyeRays,
    /// The marcher's light samples per eye-ray step for each light with extent (area,
    /// environment). Not written when 1, so content addresses stay what they were.
    #[serde(skip_serializing_if = "is_one")]
    pub light_samples: u32,
}

fn is_one(n: &u32) -> bool {
    *n == 1
}

fn is_auto(r: &RadiusRule) -> bool {
    *r == RadiusRule::Auto
}

fn is_replayed(e: &EyeRays) -> bool {
    *e == EyeRays::Replayed
}

fn is_zero(x: &f32) -> bool {
    *x == 0.0
}

fn is_zero_u64(x: &u64) -> bool {
    *x == 0
}

impl Default for IntegratorParams {
    fn default() -> Self {
        IntegratorParams {
            method: Method::Photon,
            tracker: Tracker::Weighted,
            volume_photons: 40_000,
            stored_photons: 0,
            nused: 150,
            maxdist: 0.1,
            stepsize: 0.0005,
            emission: false,
            single: true,
            multiple: true,
            free_path: FreePath::Delta,
            shadow: ShadowEstimator::Exact,
            quadrature: Quadrature::Exact,
            estimate: Estimate::Masked,
            termination: 1e-3,
            shadow_cache: 0,
            ms_cache: 0,
            shadow_stride: 8,
            shadow_tolerance: DEFAULT_SHADOW_TOLERANCE,
            thin_below: DEFAULT_THIN_BELOW,
            spp: 1,
            reference_spp: 64,
            seed: 1,
            estimator: MsEstimator::Points,
            alpha: DEFAULT_ALPHA,
            iterations: 16,
            photons_per_iteration: 0,
            time_budget: 0.0,
            target_rmse: 0.0,
            initial_radius: InitialRadius::Nused,
            radius: RadiusRule::Auto,
            eye_rays: EyeRays::Replayed,
            light_samples: 1,
        }
    }
}

impl IntegratorParams {
    /// Whether a render with these settings iterates over independent photon maps
    /// ([`crate::render_progressive`]): photon mapping with multiple scattering by the
    /// progressive or the beam estimator. Only such a render depends on `alpha`,
    /// `iterations` and `target_rmse`, and only it records an error per iteration.
    pub fn iterates(&self) -> bool {
        self.method == Method::Photon && self.multiple && self.estimator.iterates()
    }

    /// The `[integrator]` keys a photon-mapping render with these settings never reads:
    /// whatever their values, the image is the same (tested render by render). Only the
    /// structure of the settings decides (estimator, `multiple`, where the first radius
    /// and the photon count come from), never a value that happens to make a key moot.
    /// The path tracer's keys are left to its own address.
    pub fn ignored_keys(&self) -> Vec<&'static str> {
        if self.method != Method::Photon {
            return Vec::new();
        }
        // The path tracer's settings: a photon render never runs it.
        let mut keys = vec!["tracker", "reference_spp"];
        if !self.multiple {
            keys.extend([
                "volume_photons",
                "stored_photons",
                "nused",
                "maxdist",
                "free_path",
                "estimate",
                "ms_cache",
                "estimator",
                "initial_radius",
                "target_rmse",
            ]);
            keys.extend(ITERATION_KEYS);
            return keys;
        }
        keys.extend(self.estimator.ignored_keys(self));
        keys
    }

    /// These settings with every key they ignore ([`IntegratorParams::ignored_keys`]) at
    /// its default: two settings that differ only there render the same image, and this
    /// is what a content address is taken over.
    pub fn with_ignored_at_default(&self) -> IntegratorParams {
        let d = IntegratorParams::default();
        let mut s = self.clone();
        for key in self.ignored_keys() {
            match key {
                "tracker" => s.tracker = d.tracker,
                "reference_spp" => s.reference_spp = d.reference_spp,
                "volume_photons" => s.volume_photons = d.volume_photons,
                "stored_photons" => s.stored_photons = d.stored_photons,
                "nused" => s.nused = d.nused,
                "maxdist" => s.maxdist = d.maxdist,
                "free_path" => s.free_path = d.free_path,
                "estimate" => s.estimate = d.estimate,
                "ms_cache" => s.ms_cache = d.ms_cache,
                "estimator" => s.estimator = d.estimator,
                "initial_radius" => s.initial_radius = d.initial_radius,
                "alpha" => s.alpha = d.alpha,
                "iterations" => s.iterations = d.iterations,
                "photons_per_iteration" => s.photons_per_iteration = d.photons_per_iteration,
                "time_budget" => s.time_budget = d.time_budget,
                "target_rmse" => s.target_rmse = d.target_rmse,
                "radius" => s.radius = d.radius,
                "eye_rays" => s.eye_rays = d.eye_rays,
                other => unreachable!("ignored_keys names `{other}`, which is not reset"),
            }
        }
        s
    }

    /// Validates ranges; errors name the key (without the `integrator.` prefix).
    pub fn validate(&self) -> Result<()> {
        self.validate_photons()?;
        self.validate_march()?;
        self.validate_samples()?;
        self.validate_iterations()?;
        if !(self.single || self.multiple || self.emission) {
            return Err(Error::parameter(
                "single",
                false,
                "at least one of `single`, `multiple`, `emission` set to true",
            ));
        }
        Ok(())
    }

    /// The photon map and its gathers: `volume_photons`, `nused`, `maxdist`.
    fn validate_photons(&self) -> Result<()> {
        if self.volume_photons > MAX_PHOTONS {
            return Err(Error::parameter(
                "volume_photons",
                self.volume_photons,
                "at most 100 000 000 photons",
            ));
        }
        if self.stored_photons > MAX_PHOTONS {
            return Err(Error::parameter(
                "stored_photons",
                self.stored_photons,
                "at most 100 000 000 photons (0: off)",
            ));
        }
        if self.multiple && self.method == Method::Photon && self.volume_photons == 0 {
            return Err(Error::parameter(
                "volume_photons",
                0,
                "at least 1 photon when `multiple = true`",
            ));
        }
        if !(2..=100_000).contains(&self.nused) {
            return Err(Error::parameter(
                "nused",
                self.nused,
                "an integer in [2, 100000] (the nused-th photon sets the radius and is not counted)",
            ));
        }
        if !(self.maxdist.is_finite() && self.maxdist > 0.0 && self.maxdist <= 10.0) {
            return Err(Error::parameter(
                "maxdist",
                self.maxdist,
                "a radius in (0, 10] world units",
            ));
        }
        Ok(())
    }

    /// The eye march and what spares it work: `stepsize`, `termination`, thinning, the
    /// shadow fill's tolerance and the caches.
    fn validate_march(&self) -> Result<()> {
        if !(self.stepsize.is_finite() && self.stepsize >= 1e-6 && self.stepsize <= 1.0) {
            return Err(Error::parameter(
                "stepsize",
                self.stepsize,
                "a step in [1e-6, 1] world units",
            ));
        }
        check_range("termination", self.termination as f64, 0.0, 0.5)?;
        check_range("thin_below", self.thin_below as f64, 0.0, 1.0)?;
        check_range("shadow_tolerance", self.shadow_tolerance as f64, 0.0, 1.0)?;
        check_cache_resolution("shadow_cache", self.shadow_cache)?;
        check_cache_resolution("ms_cache", self.ms_cache)?;
        Ok(())
    }

    /// Samples per pixel: `spp` (eye rays) and `reference_spp` (paths).
    fn validate_samples(&self) -> Result<()> {
        if !(1..=65_536).contains(&self.spp) {
            return Err(Error::parameter(
                "spp",
                self.spp,
                "an integer in [1, 65536]",
            ));
        }
        if !(1..=1024).contains(&self.light_samples) {
            return Err(Error::parameter(
                "light_samples",
                self.light_samples,
                "an integer in [1, 1024]",
            ));
        }
        if !(1..=1_048_576).contains(&self.reference_spp) {
            return Err(Error::parameter(
                "reference_spp",
                self.reference_spp,
                "an integer in [1, 1048576]",
            ));
        }
        Ok(())
    }

    /// The progressive and beam estimators' iterations, radius shrink and stopping rules.
    fn validate_iterations(&self) -> Result<()> {
        if !(self.alpha > 0.0 && self.alpha < 1.0) {
            return Err(Error::parameter(
                "alpha",
                self.alpha,
                "a number in (0, 1): α = 1 never shrinks the radius, α = 0 never averages the noise away",
            ));
        }
        if !(1..=100_000).contains(&self.iterations) {
            return Err(Error::parameter(
                "iterations",
                self.iterations,
                "an integer in [1, 100000]",
            ));
        }
        if self.photons_per_iteration > MAX_PHOTONS {
            return Err(Error::parameter(
                "photons_per_iteration",
                self.photons_per_iteration,
                "0 (use volume_photons) or at most 100 000 000 photons",
            ));
        }
        check_range("time_budget", self.time_budget as f64, 0.0, 1e7)?;
        check_range("target_rmse", self.target_rmse as f64, 0.0, 1e9)?;
        self.estimator.check(self)
    }
}

/// What the estimator's answers ([`MsEstimator`]) read of the settings.
impl EstimatorSettings for IntegratorParams {
    fn initial_radius(&self) -> InitialRadius {
        self.initial_radius
    }
    fn radius_rule(&self) -> RadiusRule {
        self.radius
    }
    fn maxdist(&self) -> f32 {
        self.maxdist
    }
    fn photons_per_iteration(&self) -> u64 {
        self.photons_per_iteration
    }
    fn stored_photons(&self) -> u64 {
        self.stored_photons
    }
    fn target_rmse(&self) -> f32 {
        self.target_rmse
    }
    fn estimate(&self) -> Estimate {
        self.estimate
    }
    fn ms_cache(&self) -> u32 {
        self.ms_cache
    }
    fn free_path(&self) -> FreePath {
        self.free_path
    }
}

/// A cache resolution: 0 (off) or a lattice of 8 to 1024 nodes a side.
fn check_cache_resolution(key: &str, resolution: u32) -> Result<()> {
    if resolution != 0 && !(8..=1024).contains(&resolution) {
        return Err(Error::parameter(
            key,
            resolution,
            "0 (off) or a resolution in [8, 1024]",
        ));
    }
    Ok(())
}

/// `[film]` as written in a scene file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct FilmParams {
    /// Exposure in stops applied before tone mapping to PNG.
    pub exposure: f32,
}

impl Default for FilmParams {
    fn default() -> Self {
        FilmParams { exposure: 0.0 }
    }
}

impl FilmParams {
    /// Validates the exposure.
    pub fn validate(&self) -> Result<()> {
        check_range("exposure", self.exposure as f64, -40.0, 40.0)
    }
}
