//! The error probes: what a render's caches and its thinning err by, measured after the
//! pass ([`CacheError`], each quantity an [`ErrorBound`]; thinning's a [`ThinningError`]).
//!
//! A cache trades exactness for speed, so a render that used one says by how much: after
//! the pass, the marching samples of a regular 32 × 32 subset of the eye rays (the same
//! samples the render used) are probed, and at each the cached quantity is compared with
//! the value it stands for — the direct light `Σ L·T·p` with cached against exact
//! transmittance, and each variant's multiple-scattering estimate from the cache against
//! a gather. Where the exact value is at least 1 % of its largest, the relative error is
//! taken; the bound reports its 99th percentile and maximum, and the ratio of the sums
//! (the bias a mean would show).
//!
//! Thinning (`thin_below`) is no cache but also trades exactness for speed, so it is
//! measured the same way at the pixel level: the probe pixels' eye rays are traced again
//! with every sample evaluated, from the same random streams, and each layer's radiance
//! as rendered compared with that.

use glam::Vec3;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::error_bound::ErrorBound;
use super::eye_ray::Evaluation;
use super::marcher::Marcher;
use super::sample::Accumulator;
use super::thinning::ThinningError;
use crate::medium::{DepthCap, Medium, ShadowSegment};
use crate::scene::Camera;

/// Eye rays (pixels) probed per image axis.
const PROBE_RAYS_PER_AXIS: u32 = 32;
/// At most this many probe points (every k-th sample beyond).
const MAX_PROBES: usize = 8192;

/// The pixels whose eye rays a `width` × `height` render traces again to measure what its
/// thinning and caches err by (a regular grid of at most 32 × 32): thinning traces each
/// twice more, once as rendered and once with every sample evaluated. A fixed cost of the
/// render, whatever its size.
///
/// ```
/// assert_eq!(volphot::error_probe_pixels(512, 512), 1024);
/// assert_eq!(volphot::error_probe_pixels(16, 48), 16 * 32);
/// ```
pub fn error_probe_pixels(width: u32, height: u32) -> u32 {
    PROBE_RAYS_PER_AXIS.min(width) * PROBE_RAYS_PER_AXIS.min(height)
}

/// What a render's caches and its thinning were measured to err by, for one output image.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CacheError {
    /// Probe points (0 without caches).
    pub probes: usize,
    /// The direct light with the transmittance cache (`shadow_cache`).
    pub shadow: Option<ErrorBound>,
    /// The multiple-scattering estimate with the scattering cache (`ms_cache`).
    pub multiple: Option<ErrorBound>,
    /// The probe pixels as rendered against every sample evaluated (`thin_below > 0`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub thinning: Option<ThinningError>,
}

impl CacheError {
    /// Whether a cache (not only thinning) was measured.
    pub fn has_cache(&self) -> bool {
        self.shadow.is_some() || self.multiple.is_some()
    }
}

impl Marcher<'_> {
    /// Whether any cache is on.
    pub(super) fn uses_caches(&self) -> bool {
        self.shadow_caches.is_some() || self.groups.iter().any(|g| g.cache.is_some())
    }

    /// The cache error of each variant's image (one entry when there are no variants);
    /// `None` entries without caches.
    pub(super) fn cache_errors(&self, camera: &Camera) -> Vec<Option<CacheError>> {
        let images = self.variants.len().max(1);
        let thinning = self.thinning_errors(camera);
        if !self.uses_caches() {
            return thinning
                .into_iter()
                .map(|t| {
                    t.map(|t| CacheError {
                        probes: 0,
                        shadow: None,
                        multiple: None,
                        thinning: Some(t),
                    })
                })
                .collect();
        }
        let probes = self.probe_points(camera);
        let shadow = self
            .shadow_caches
            .is_some()
            .then(|| self.shadow_error(&probes));
        let mut multiple = vec![None; images];
        for group in self.groups.iter().filter(|g| g.cache.is_some()) {
            let mut pairs = vec![Vec::with_capacity(probes.len()); group.variants.len()];
            let (mut cached, mut exact) = (vec![Vec3::ZERO; group.gather.len()], vec![]);
            exact.resize(group.gather.len(), Vec3::ZERO);
            let mut scratch = Default::default();
            for &(x, wo) in &probes {
                group.estimate(self.medium, x, wo, &mut scratch, &mut cached);
                group.estimate_uncached(self.medium, x, wo, &mut scratch, &mut exact);
                for (j, p) in pairs.iter_mut().enumerate() {
                    p.push((mean3(cached[j]), mean3(exact[j])));
                }
            }
            for (&vi, p) in group.variants.iter().zip(&pairs) {
                multiple[vi] = ErrorBound::of(p);
            }
        }
        multiple
            .into_iter()
            .zip(thinning)
            .map(|(multiple, thinning)| {
                Some(CacheError {
                    probes: probes.len(),
                    shadow: shadow.flatten(),
                    multiple,
                    thinning,
                })
            })
            .collect()
    }

    /// The probe pixels of the image, in a regular grid of at most 32 × 32.
    fn probe_pixels(camera: &Camera) -> impl Iterator<Item = (u32, u32)> {
        let (w, h) = (camera.width(), camera.height());
        let (nx, ny) = (PROBE_RAYS_PER_AXIS.min(w), PROBE_RAYS_PER_AXIS.min(h));
        debug_assert_eq!(nx * ny, error_probe_pixels(w, h));
        (0..ny).flat_map(move |j| {
            (0..nx).map(move |i| ((2 * i + 1) * w / (2 * nx), (2 * j + 1) * h / (2 * ny)))
        })
    }

    /// The thinning error of each variant's image (`None` entries when thinning is off):
    /// each probe pixel's first eye ray traced as rendered and with every sample evaluated,
    /// from the same random stream the render drew it from.
    fn thinning_errors(&self, camera: &Camera) -> Vec<Option<ThinningError>> {
        let images = self.variants.len().max(1);
        let c = self.settings.thin_below;
        if c <= 0.0 {
            return vec![None; images];
        }
        // The probe pixels in parallel (each from its own random stream, so the pairs do
        // not depend on the threads), collected in pixel order.
        let pixels: Vec<(u32, u32)> = Self::probe_pixels(camera).collect();
        let traced: Vec<[(Vec3, Vec<Vec3>); 2]> = pixels
            .into_par_iter()
            .map_init(
                || self.accumulator(),
                |acc, (x, y)| {
                    [Evaluation::Scene, Evaluation::EverySample].map(|evaluation| {
                        let (ray, mut rng) = self.eye_ray(camera, x, y, 0);
                        acc.start_pixel();
                        self.trace_evaluating(&ray, &mut rng, acc, evaluation);
                        (acc.single, acc.multiple.clone())
                    })
                },
            )
            .collect();
        let mut single = Vec::with_capacity(traced.len());
        let mut multiple = vec![Vec::with_capacity(traced.len()); self.variants.len()];
        for [(thinned, thinned_ms), (exact, exact_ms)] in traced {
            single.push((mean3(thinned), mean3(exact)));
            for (v, pairs) in multiple.iter_mut().enumerate() {
                pairs.push((mean3(thinned_ms[v]), mean3(exact_ms[v])));
            }
        }
        let bound = |pairs: &[(f32, f32)]| {
            Some(ThinningError {
                thin_below: c,
                pixels: single.len(),
                single: self
                    .settings
                    .single
                    .then(|| ErrorBound::of(&single))
                    .flatten(),
                multiple: ErrorBound::of(pairs),
            })
        };
        if multiple.is_empty() {
            return vec![bound(&[])];
        }
        multiple.iter().map(|p| bound(p)).collect()
    }

    /// The marching samples (and view directions) of a regular subset of eye rays, drawn
    /// from the render's own per-pixel streams.
    fn probe_points(&self, camera: &Camera) -> Vec<(Vec3, Vec3)> {
        let mut acc = Accumulator::new(0, 0, 0);
        let mut points = Vec::new();
        for (x, y) in Self::probe_pixels(camera) {
            let (ray, mut rng) = self.eye_ray(camera, x, y, 0);
            self.collect_samples(&ray, &mut rng, &mut acc);
            points.extend(acc.samples.iter().map(|s| (s.x, -ray.direction)));
        }
        let keep_every = points.len().div_ceil(MAX_PROBES).max(1);
        points.into_iter().step_by(keep_every).collect()
    }

    /// Direct light at the probes with cached and with exact transmittance.
    fn shadow_error(&self, probes: &[(Vec3, Vec3)]) -> Option<ErrorBound> {
        let pairs: Vec<(f32, f32)> = probes
            .iter()
            .map(|&(x, wo)| {
                let (mut cached, mut exact) = (0.0, 0.0);
                for (li, light) in self.lights.iter().enumerate() {
                    let Some(inc) = light.incident(x) else {
                        continue;
                    };
                    let scale = mean3(inc.radiance) * self.medium.phase().eval(-inc.to_light, wo);
                    let cache = self.shadow_caches.as_ref().expect("shadow caches")[li]
                        .as_ref()
                        .expect("a delta light, which has a cache");
                    cached += scale * cache.transmittance(self.medium, x);
                    exact +=
                        scale * exact_transmittance(self.medium, x, inc.to_light, inc.distance);
                }
                (cached, exact)
            })
            .collect();
        ErrorBound::of(&pairs)
    }
}

/// `exp(−τ)` with τ integrated exactly (no termination).
fn exact_transmittance(medium: &Medium, x: Vec3, to_light: Vec3, distance: f32) -> f32 {
    let segment = ShadowSegment {
        origin: x,
        direction: to_light,
        distance,
    };
    (-medium.shadow_depth(&segment, DepthCap::Exact(f32::INFINITY))).exp()
}

fn mean3(v: Vec3) -> f32 {
    (v.x + v.y + v.z) / 3.0
}
