//! The multiple-scattering estimator as one type. Every question a caller asks of it is
//! answered here, each by one exhaustive `match`: whether it iterates, what a pass traces,
//! which kernel a pass gathers with, where its radius starts and how it shrinks, which
//! `[integrator]` keys it reads and what it cannot be combined with, and how the planner
//! prices its passes. Adding an estimator is a variant here and its answers — the compiler
//! lists every `match` to extend — and its code in `integrator/`; no caller compares it.

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::medium::FreePath;

/// How the multiple-scattering term is estimated from photons.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum MsEstimator {
    /// The thesis's point estimate: `nused` nearest photons at every marching sample.
    Points,
    /// Progressive photon mapping (Knaus & Zwicker 2011, in 3-D): `iterations` independent
    /// photon maps, fixed-radius gathers whose radius shrinks by `((i + α)/(i + 1))^{1/3}`
    /// per iteration, the image their running mean: consistent — it converges to the
    /// unbiased solution.
    Progressive,
    /// The beam radiance estimate (Jarosz, Zwicker & Jensen 2008) for heterogeneous media:
    /// every photon whose sphere an eye ray crosses, weighted by the exact eye
    /// transmittance over its chord; no `stepsize` and no k-NN query per sample.
    Beam,
    /// Photon planes with a 1-D blur (Bitterli & Jarosz 2017, "Beyond points and beams"):
    /// each flight of a photon path swept along the direction sampled at its end, met by
    /// the eye ray at a point — both free flights integrated, no density estimate. In a
    /// heterogeneous medium the plane ends at the flight's delta-tracked interaction and,
    /// along its second direction, where the exact optical depth passes one sampled
    /// `τ* ~ Exp(1)`: unbiased transmittance both ways. The blur half-width starts at
    /// `maxdist` and shrinks by `(i + α)/(i + 1)` per iteration (a 1-D kernel).
    Plane,
}

/// Radiance estimate form (§5.2, eq. 11).
///
/// Photons are stored at every interaction, i.e. at rate σt along their paths, so
/// `Σ ΔΦ / V` estimates `σt·φ` averaged over the gather sphere (φ the fluence), while the
/// in-scattering source term is `σs(x)·p·φ(x)`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Estimate {
    /// `σs(x)·Σ p·ΔΦ_p / (σt(x_p)·V_m)` with `V_m` the part of the gather sphere that holds
    /// medium (σt > 0): photons exist only there, so dividing by the whole sphere dilutes
    /// the estimate wherever the sphere reaches into empty space (thin bone, surfaces).
    /// `V_m` is estimated from 32 fixed points in the sphere. The default.
    Masked,
    /// `σs(x)·Σ p·ΔΦ_p / (σt(x_p)·4/3 π r³)`: each photon's power over σt where it was
    /// stored estimates the fluence, which is continuous across density edges; then the
    /// local σs is applied. Consistent inside the medium, biased low near its boundaries.
    Fluence,
    /// `Λ·Σ p·ΔΦ/(4/3 π r³)`: fixes eq. 11's missing albedo factor but, like eq. 11, assumes
    /// σt constant over the gather sphere, so dense tissue lights thin neighbours.
    Albedo,
    /// `Σ p·ΔΦ/(4/3 π r³)` exactly as eq. 11 ("σs cancels"): too bright by `1/Λ` and biased
    /// at density edges.
    Thesis,
}

/// Where the progressive estimate's first radius comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum InitialRadius {
    /// `maxdist`.
    Maxdist,
    /// The median distance from a photon of the first map to its `nused`-th neighbour
    /// (at most `maxdist`): the radius the point estimate would typically use.
    Nused,
}

/// How the kernel radius of the progressive and beam estimators varies in space. Each rule
/// sets the first iteration's radii; every later iteration scales them all by the same
/// factor (`alpha`), which keeps each rule consistent.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum RadiusRule {
    /// Each estimator's rule from before the rule was a setting: `global` for progressive
    /// points, `nearest` for beams. The default.
    #[default]
    Auto,
    /// One radius everywhere: the median `nused`-th-neighbour distance of the first map (or
    /// `maxdist`, as `initial_radius` says), as in Knaus & Zwicker's probabilistic PPM.
    Global,
    /// Each photon's own distance to its `nused`-th neighbour (at most `maxdist`): radii
    /// follow the photon density, small where photons crowd and wide where they are
    /// sparse (the per-beam radii of progressive photon beams, Jarosz et al. 2011).
    Nearest,
    /// The radius that balances a 3-D kernel's squared bias against its variance (the
    /// asymptotic-MSE rule behind adaptive progressive photon mapping, Kaplanyan &
    /// Dachsbacher 2013): `r ∝ (ρ·κ⁴)^(−1/7)` for photon density `ρ` and a fluence that
    /// curves on the scale `1/κ`. In a scattering medium the fluence varies over the
    /// diffusion length, so `κ ∝ σt`, and with `ρ ∝ 1/r_k³` from the `nused`-th
    /// neighbour this is `r ∝ r_k^(3/7)·σt^(−4/7)`, scaled so that its median is the
    /// median `r_k` (at most `maxdist`): smaller than `Nearest` in dense tissue, where
    /// the fluence curves fast, wider in thin tissue.
    Balanced,
}

/// The `[integrator]` settings an estimator's answers depend on (the scene's
/// `IntegratorParams` implements it; this module does not see that type, so the settings
/// can hold an estimator without a circle of imports).
pub trait EstimatorSettings {
    /// Where the first radius comes from.
    fn initial_radius(&self) -> InitialRadius;
    /// How the kernel radius varies in space.
    fn radius_rule(&self) -> RadiusRule;
    /// The largest gather radius (the first radius of a ball or the planes' blur).
    fn maxdist(&self) -> f32;
    /// Photons per iteration (0: `volume_photons`).
    fn photons_per_iteration(&self) -> u64;
    /// The stored-photon target (0: off).
    fn stored_photons(&self) -> u64;
    /// The RMSE an iterating render stops at (0: off).
    fn target_rmse(&self) -> f32;
    /// The radiance estimate's form.
    fn estimate(&self) -> Estimate;
    /// The multiple-scattering cache's resolution (0: off).
    fn ms_cache(&self) -> u32;
    /// How photons' free paths are sampled.
    fn free_path(&self) -> FreePath;
}

/// What one photon pass of an estimator traces.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Traces {
    /// Photons stored at their interactions, in a kd-tree photon map.
    Photons,
    /// Each flight of a photon path swept into a plane ([`crate::trace_planes`]).
    Planes,
}

/// The kernel a pass gathers the multiple-scattering term with.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kernel {
    /// The `nused` nearest photons at every marching sample (the thesis's estimate).
    Nearest,
    /// Every photon within one shrinking radius of a sample (a range query on the map).
    Ball,
    /// Every photon whose own sphere (sized by its `nused`-th neighbours) holds the sample.
    Spheres,
    /// Every photon sphere an eye ray crosses, weighted over its chord.
    Beams,
    /// Photon planes met by the eye ray, blurred in one dimension.
    Planes,
}

/// How the planner prices one later pass of an iterating estimator.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PassCost {
    /// Gathers at every eye sample, as a march does.
    Gathers,
    /// One traversal of the eye ray through a hierarchy of beams or planes.
    Traversal,
}

impl MsEstimator {
    /// Every estimator, in the order the documents list them.
    pub const ALL: [MsEstimator; 4] = [
        MsEstimator::Points,
        MsEstimator::Progressive,
        MsEstimator::Beam,
        MsEstimator::Plane,
    ];

    /// The name a scene file writes (`estimator = "…"`).
    pub fn name(self) -> &'static str {
        match self {
            MsEstimator::Points => "points",
            MsEstimator::Progressive => "progressive",
            MsEstimator::Beam => "beam",
            MsEstimator::Plane => "plane",
        }
    }

    /// Whether a render iterates over independent photon sets (and so renders alone,
    /// reads `alpha`, `iterations` and `target_rmse`, and records an error per iteration).
    pub fn iterates(self) -> bool {
        match self {
            MsEstimator::Points => false,
            MsEstimator::Progressive | MsEstimator::Beam | MsEstimator::Plane => true,
        }
    }

    /// What a photon pass traces.
    pub fn traces(self) -> Traces {
        match self {
            MsEstimator::Plane => Traces::Planes,
            MsEstimator::Points | MsEstimator::Progressive | MsEstimator::Beam => Traces::Photons,
        }
    }

    /// The kernel a pass gathers with under settings `s`.
    pub fn kernel(self, s: &impl EstimatorSettings) -> Kernel {
        match self {
            MsEstimator::Points => Kernel::Nearest,
            MsEstimator::Progressive if sizes_per_photon(s) => Kernel::Spheres,
            MsEstimator::Progressive => Kernel::Ball,
            MsEstimator::Beam => Kernel::Beams,
            MsEstimator::Plane => Kernel::Planes,
        }
    }

    /// The radius of iteration `i + 1` from that of iteration `i` (1-based), given the
    /// shrink ratio `(i + α)/(i + 1)`: the variance of a kernel over `d` dimensions grows
    /// as `r^−d`, so `r^d` shrinks by the ratio — `d = 3` for a ball, `d = 2` for the beam
    /// estimate (its kernel, integrated along the ray, is a disc across it), `d = 1` for
    /// the planes' blur.
    pub fn shrink(self, radius: f32, ratio: f32) -> f32 {
        match self {
            MsEstimator::Plane => radius * ratio,
            MsEstimator::Beam => radius * ratio.sqrt(),
            MsEstimator::Points | MsEstimator::Progressive => radius * ratio.cbrt(),
        }
    }

    /// The first iteration's radius under settings `s`: a ball's gather radius
    /// (`maxdist`), the scale of the photons' own radii for beams and per-photon spheres,
    /// or the planes' blur half-width (`maxdist`).
    pub fn first_radius(self, s: &impl EstimatorSettings) -> f32 {
        match self.kernel(s) {
            Kernel::Beams | Kernel::Spheres => 1.0,
            Kernel::Nearest | Kernel::Ball | Kernel::Planes => s.maxdist(),
        }
    }

    /// Whether the first map replaces the first radius by its median distance to the
    /// `nused`-th neighbour (`initial_radius = "nused"` for one shrinking ball).
    pub fn sizes_first_radius_from_map(self, s: &impl EstimatorSettings) -> bool {
        self.kernel(s) == Kernel::Ball && s.initial_radius() == InitialRadius::Nused
    }

    /// Whether one stored-photon target can set the photon count (only the point
    /// estimate's one map: the iterating estimators set each map by
    /// `photons_per_iteration`).
    pub fn takes_stored_target(self) -> bool {
        !self.iterates()
    }

    /// How the planner prices a later pass (`None` for an estimator that does not
    /// iterate: its one gather per sample is part of the march).
    pub fn pass_cost(self) -> Option<PassCost> {
        match self {
            MsEstimator::Points => None,
            MsEstimator::Progressive => Some(PassCost::Gathers),
            // A plane pass is priced as a beam pass until a pilot measures it.
            MsEstimator::Beam | MsEstimator::Plane => Some(PassCost::Traversal),
        }
    }

    /// Whether the planner's pilot also renders the last iteration's radius: only a ball
    /// shrinks enough past the second iteration for its later passes to cost less.
    pub fn pilots_last_radius(self) -> bool {
        match self {
            MsEstimator::Progressive => true,
            MsEstimator::Points | MsEstimator::Beam | MsEstimator::Plane => false,
        }
    }

    /// The `[integrator]` keys a render by this estimator with multiple scattering never
    /// reads under settings `s` (besides those every photon render ignores).
    pub fn ignored_keys(self, s: &impl EstimatorSettings) -> Vec<&'static str> {
        let photons_per_iteration = s.photons_per_iteration() > 0;
        let radius_from_maxdist = s.initial_radius() == InitialRadius::Maxdist;
        let mut keys = Vec::new();
        match self {
            MsEstimator::Points => {
                keys.extend(ITERATION_KEYS);
                keys.push("initial_radius");
            }
            MsEstimator::Progressive | MsEstimator::Beam => {
                if photons_per_iteration {
                    keys.push("volume_photons");
                }
                if radius_from_maxdist {
                    keys.extend(["nused", "radius"]);
                }
            }
            MsEstimator::Plane => {
                keys.extend(["nused", "initial_radius", "radius", "estimate"]);
                if photons_per_iteration {
                    keys.push("volume_photons");
                }
            }
        }
        keys
    }

    /// What this estimator cannot be combined with in `s`; errors name the key.
    pub fn check(self, s: &impl EstimatorSettings) -> Result<()> {
        if s.stored_photons() > 0 && !self.takes_stored_target() {
            return Err(Error::parameter(
                "stored_photons",
                s.stored_photons(),
                format!(
                    "0 with estimator = \"{}\" (a stored-photon target fills the point estimate's one map; the iterating estimators set each map by `photons_per_iteration`)",
                    self.name()
                ),
            ));
        }
        if s.target_rmse() > 0.0 && !self.iterates() {
            return Err(Error::parameter(
                "target_rmse",
                s.target_rmse(),
                format!(
                    "0 with estimator = \"{}\" (only the iterating estimators iterate towards a target)",
                    self.name()
                ),
            ));
        }
        match self {
            MsEstimator::Beam => check_beam(s),
            MsEstimator::Plane => check_plane(s),
            MsEstimator::Points | MsEstimator::Progressive => Ok(()),
        }
    }
}

/// The keys only an iterating estimator reads.
pub(crate) const ITERATION_KEYS: [&str; 6] = [
    "alpha",
    "iterations",
    "photons_per_iteration",
    "time_budget",
    "radius",
    "eye_rays",
];

/// Whether the progressive ball sizes its kernels per photon (a `nearest` or `balanced`
/// radius rule from the `nused`-th neighbours): then its "radius" is the scale of the
/// photons' own radii, as for the beams.
fn sizes_per_photon(s: &impl EstimatorSettings) -> bool {
    s.initial_radius() == InitialRadius::Nused
        && matches!(s.radius_rule(), RadiusRule::Nearest | RadiusRule::Balanced)
}

/// What the beam estimate cannot combine with.
fn check_beam(s: &impl EstimatorSettings) -> Result<()> {
    if matches!(s.estimate(), Estimate::Albedo | Estimate::Thesis) {
        return Err(Error::parameter(
            "estimate",
            format!("{:?}", s.estimate()).to_lowercase(),
            "`masked` or `fluence` with estimator = \"beam\" (the beam estimate integrates σs·T exactly along each chord, which needs the fluence form)",
        ));
    }
    if s.ms_cache() > 0 {
        return Err(Error::parameter(
            "ms_cache",
            s.ms_cache(),
            "0 with estimator = \"beam\" (the beam estimate has no per-sample gathers to cache)",
        ));
    }
    Ok(())
}

/// What photon planes cannot combine with.
fn check_plane(s: &impl EstimatorSettings) -> Result<()> {
    if s.free_path() != FreePath::Delta {
        return Err(Error::parameter(
            "free_path",
            format!("{:?}", s.free_path()).to_lowercase(),
            "`delta` with estimator = \"plane\" (a plane ends at its flight's sampled interaction, which stands in for the transmittance only when the free path is sampled exactly)",
        ));
    }
    if s.ms_cache() > 0 {
        return Err(Error::parameter(
            "ms_cache",
            s.ms_cache(),
            "0 with estimator = \"plane\" (photon planes have no per-sample gathers to cache)",
        ));
    }
    Ok(())
}
