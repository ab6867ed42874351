//! One eye ray of the marching pass: its samples first, then each light's transmittance
//! and each photon map's estimates at those samples.
//!
//! The samples of a ray are collected before any source term is evaluated, so that the
//! optical depth to each light can be filled along the ray ([`super::adaptive_fill`]): with
//! the exact estimator and `shadow_stride = s > 0` it is computed at every `s`-th sample
//! and at interval midpoints, and interpolated only where the midpoint shows the straight
//! line holds to within `shadow_tolerance`; everywhere else (shadow edges, cone edges,
//! blocked stretches) every sample gets its exact value. Photon-map estimates are gathered
//! at every sample in front: interpolating them everywhere was measured to miss the 2 %
//! per-pixel bound. Behind the front, where the eye transmittance is below `thin_below`,
//! both are spaced out by band ([`super::thinning`]), the estimates checked at midpoints
//! like the optical depth ([`super::estimate_track`]).

use std::ops::ControlFlow;

use glam::Vec3;

use super::estimate_track::EstimateTrack;
use super::gather::{MapGroup, source_factor};
use super::marcher::Marcher;
use super::multiple::MsSource;
use super::sample::{Accumulator, RaySample};
use super::shadow_track::ShadowTrack;
use super::thinning::Bands;
use crate::math::{Ray, Rng};
use crate::medium::{ShadowBy, ShadowSegment, transmittance_of};
use crate::scene::{Quadrature, ShadowEstimator};
use crate::volume::CellCursor;

/// Which evaluations an eye ray makes: the scene's, or every one of them (the thinning
/// error compares both, [`super::error_probes`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Evaluation {
    /// As the scene sets them: thinned below `thin_below`, optical depth filled by
    /// `shadow_stride`.
    Scene,
    /// A photon-map gather and an exact optical depth at every sample: the uncached
    /// marcher's own answer, which thinning and the stride approximate.
    EverySample,
}

impl Marcher<'_> {
    /// Marches one eye ray; adds its radiance into the accumulator.
    pub(super) fn trace(&self, ray: &Ray, rng: &mut Rng, acc: &mut Accumulator) {
        self.trace_evaluating(ray, rng, acc, Evaluation::Scene);
    }

    /// [`Self::trace`] with the given evaluations.
    pub(super) fn trace_evaluating(
        &self,
        ray: &Ray,
        rng: &mut Rng,
        acc: &mut Accumulator,
        evaluation: Evaluation,
    ) {
        self.collect_samples(ray, rng, acc);
        self.shade_samples(ray, rng, acc, evaluation);
    }

    /// Traces one eye ray from its samples as an earlier pass collected them (`samples`,
    /// from [`Self::collect_samples`] on the same ray and random stream): the same
    /// radiance to the bit, without marching the ray again.
    pub(super) fn trace_replayed(
        &self,
        ray: &Ray,
        rng: &mut Rng,
        samples: &[RaySample],
        acc: &mut Accumulator,
    ) {
        acc.samples.clear();
        if samples.is_empty() {
            return;
        }
        // The march drew its jitter from the stream (one uniform; a ray that misses the
        // box draws none and has no samples): draw it, so the shading goes on with the
        // stream where it did.
        let _jitter = rng.uniform();
        acc.samples.extend_from_slice(samples);
        acc.counters.samples += samples.len() as u64;
        self.shade_samples(ray, rng, acc, Evaluation::Scene);
    }

    /// The source terms at the collected samples `acc.samples`: single scattering by each
    /// light, multiple scattering by each photon map (or the beams).
    fn shade_samples(
        &self,
        ray: &Ray,
        rng: &mut Rng,
        acc: &mut Accumulator,
        evaluation: Evaluation,
    ) {
        if acc.samples.is_empty() {
            return;
        }
        let (thin_below, stride) = match evaluation {
            Evaluation::Scene => (self.settings.thin_below, self.settings.shadow_stride),
            Evaluation::EverySample => (0.0, 0),
        };
        let wo = -ray.direction;
        let bands = Bands::new(&acc.samples, thin_below);
        if self.settings.single {
            self.add_single(wo, &bands, stride as usize, rng, acc);
        }
        if self.settings.multiple {
            match self.source {
                MsSource::Gathers => self.add_multiple(wo, &bands, acc),
                MsSource::Beams(beams) => self.add_beams(beams, ray, acc),
                MsSource::Spheres(spheres) => self.add_spheres(spheres, wo, acc),
                MsSource::Planes(planes) => self.add_planes(planes, ray, rng, acc),
            }
        }
    }

    /// Marches the eye ray, keeping the samples with σt > 0 (and adding emission and depth,
    /// which are cheap), until the eye transmittance falls below `termination`.
    pub(super) fn collect_samples(&self, ray: &Ray, rng: &mut Rng, acc: &mut Accumulator) {
        acc.samples.clear();
        let Some((t0, t1)) = self.medium.clip(ray) else {
            return;
        };
        let s = self.settings;
        let u = rng.uniform();
        let mut eye_t = 1.0f32;
        let mut tau = 0.0f32;
        let mut cursor = CellCursor::default();
        self.medium.march(ray, t0, t1, s.stepsize, u, |t, w| {
            let x = ray.at(t);
            let sigma_t = self.medium.sigma_t_marched(&mut cursor, x);
            if sigma_t <= 0.0 {
                return ControlFlow::Continue(());
            }
            let segment_t = (-sigma_t * w).exp();
            let weight = match s.quadrature {
                Quadrature::Exact => (1.0 - segment_t) / sigma_t,
                Quadrature::Riemann => w,
            } * eye_t;
            acc.samples.push(RaySample {
                x,
                sigma_t,
                weight,
                // The sample sits at fraction `u` of its segment (full steps and the tail).
                t_start: t - u * w,
                width: w,
                tau_start: tau,
            });
            tau += sigma_t * w;
            if s.emission {
                acc.emission += self.medium.emission(x) * weight;
            }
            if eye_t >= 0.5 && eye_t * segment_t < 0.5 {
                acc.depth_sum += t;
                acc.depth_hits += 1;
            }
            eye_t *= segment_t;
            if eye_t < s.termination {
                ControlFlow::Break(())
            } else {
                ControlFlow::Continue(())
            }
        });
        acc.counters.samples += acc.samples.len() as u64;
    }

    /// Single scattering of the collected samples, light by light:
    /// `σs · p · L · T(x → light)` at each sample, weighted; exact optical depths are
    /// filled by `stride` (0: computed at every sample).
    fn add_single(
        &self,
        wo: Vec3,
        bands: &Bands,
        stride: usize,
        rng: &mut Rng,
        acc: &mut Accumulator,
    ) {
        let n = acc.samples.len();
        let adaptive = self.settings.shadow == ShadowEstimator::Exact
            && self.shadow_caches.is_none()
            && stride > 0;
        for (li, light) in self.lights.iter().enumerate() {
            if !light.is_delta() {
                self.add_single_sampled(li, wo, rng, acc);
                continue;
            }
            if adaptive {
                acc.tau.clear();
                acc.tau.resize(n, 0.0);
                let mut track = ShadowTrack {
                    marcher: self,
                    light,
                    samples: &acc.samples,
                    tau: &mut acc.tau,
                    tolerance: self.settings.shadow_tolerance,
                };
                acc.counters.shadow += track.fill(stride, bands) as u64;
            }
            for i in 0..n {
                let sample = acc.samples[i];
                let Some(inc) = light.incident(sample.x) else {
                    continue;
                };
                let tr = if adaptive {
                    transmittance_of(acc.tau[i], self.shadow_tau_max)
                } else {
                    acc.counters.shadow += 1;
                    self.shadow_transmittance(li, sample.x, inc.to_light, inc.distance, rng)
                };
                if tr > 0.0 {
                    let direct = inc.radiance * (tr * self.medium.phase().eval(-inc.to_light, wo));
                    acc.single +=
                        self.medium.albedo_at(sample.x) * sample.sigma_t * direct * sample.weight;
                }
            }
        }
    }

    /// Single scattering from a light with extent (area, environment): at every sample,
    /// `light_samples` directions drawn from the light, each with its own shadow ray (a
    /// sampled direction changes from step to step, so the optical depths cannot be
    /// interpolated along the ray as a delta light's are, nor cached at lattice nodes).
    fn add_single_sampled(&self, li: usize, wo: Vec3, rng: &mut Rng, acc: &mut Accumulator) {
        let light = &self.lights[li];
        let n = self.settings.light_samples.max(1);
        let per_sample = 1.0 / n as f32;
        for sample in &acc.samples {
            let mut direct = Vec3::ZERO;
            for _ in 0..n {
                let Some(inc) = light.sample_incident(sample.x, rng) else {
                    continue;
                };
                acc.counters.shadow += 1;
                let tr = self.shadow_transmittance(li, sample.x, inc.to_light, inc.distance, rng);
                if tr > 0.0 {
                    direct += inc.radiance * (tr * self.medium.phase().eval(-inc.to_light, wo));
                }
            }
            acc.single += self.medium.albedo_at(sample.x)
                * sample.sigma_t
                * direct
                * (sample.weight * per_sample);
        }
    }

    /// Multiple scattering of the collected samples: every variant's source term at every
    /// sample, weighted (variants on one map share one gather per sample); behind the front
    /// the estimates of the thinned bands are interpolated between gathers.
    fn add_multiple(&self, wo: Vec3, bands: &Bands, acc: &mut Accumulator) {
        let n = acc.samples.len();
        let front = bands.last_in_front();
        for (gi, group) in self.groups.iter().enumerate() {
            let estimates = &mut acc.estimates[..group.gather.len()];
            for sample in &acc.samples[..=front] {
                if group.estimate(self.medium, sample.x, wo, &mut acc.gather[gi], estimates) {
                    acc.counters.gathers += 1;
                }
                self.add_source(group, sample, |v| estimates[v], &mut acc.multiple);
            }
            if front + 1 < n {
                self.add_multiple_thinned(gi, bands, wo, acc);
            }
        }
    }

    /// The thinned samples of map group `gi` (`acc.estimates` holds the estimates at the
    /// last sample gathered in front), variant by variant: each variant's estimate is
    /// filled by its own [`EstimateTrack`] (gathers at the bands' knots and checked
    /// midpoints, linear where the midpoint agrees), so what a variant interpolates does not
    /// depend on which variants share its map; a sample gathered for one is reused by all.
    fn add_multiple_thinned(&self, gi: usize, bands: &Bands, wo: Vec3, acc: &mut Accumulator) {
        let group = &self.groups[gi];
        let nv = group.gather.len();
        let n = acc.samples.len();
        let front = bands.last_in_front();
        let Accumulator {
            samples,
            estimates,
            gathered,
            values,
            gather,
            multiple,
            counters,
            ..
        } = acc;
        gathered.start(n, nv, front, &estimates[..nv]);
        values.clear();
        values.resize(n, Vec3::ZERO);
        for (v, &at_front) in estimates[..nv].iter().enumerate() {
            values[front] = at_front;
            let mut track = EstimateTrack {
                marcher: self,
                group,
                wo,
                variant: v,
                samples,
                gathered,
                scratch: &mut gather[gi],
                values,
                tolerance: 0.0,
                gathers: 0,
            };
            track.fill(bands, self.gather_knot_cap);
            counters.gathers += track.gathers;
            for (sample, value) in samples.iter().zip(values.iter()).skip(front + 1) {
                self.add_variant_source(group, v, sample, *value, multiple);
            }
        }
    }

    /// Adds each variant's source term at `sample`, `estimate(v)` being the group's `v`-th
    /// estimate there.
    #[inline]
    fn add_source(
        &self,
        group: &MapGroup<'_>,
        sample: &RaySample,
        estimate: impl Fn(usize) -> Vec3,
        multiple: &mut [Vec3],
    ) {
        for v in 0..group.variants.len() {
            self.add_variant_source(group, v, sample, estimate(v), multiple);
        }
    }

    /// Adds the source term of the group's `v`-th variant at `sample`, its estimate there
    /// being `estimate`.
    #[inline]
    fn add_variant_source(
        &self,
        group: &MapGroup<'_>,
        v: usize,
        sample: &RaySample,
        estimate: Vec3,
        multiple: &mut [Vec3],
    ) {
        let vi = group.variants[v];
        let factor = source_factor(
            self.variants[vi].estimate,
            self.medium,
            sample.x,
            sample.sigma_t,
        );
        multiple[vi] += factor * estimate * sample.weight;
    }

    /// Transmittance from `p` to light `light_index` by the scene's estimator (or its
    /// cache), at one sample.
    pub(super) fn shadow_transmittance(
        &self,
        light_index: usize,
        p: Vec3,
        to_light: Vec3,
        distance: f32,
        rng: &mut Rng,
    ) -> f32 {
        // The cache holds each lattice node's depth towards one point: delta lights only.
        if let Some(cache) = self
            .shadow_caches
            .as_ref()
            .and_then(|c| c[light_index].as_ref())
        {
            return cache.transmittance(self.medium, p);
        }
        let segment = ShadowSegment {
            origin: p,
            direction: to_light,
            distance,
        };
        let tau_max = self.shadow_tau_max;
        let by = match self.settings.shadow {
            ShadowEstimator::Exact => ShadowBy::Exact { tau_max },
            // A marched shadow ray stops, like the eye ray, once its transmittance drops
            // below `termination`: the light it could still carry is below that fraction.
            ShadowEstimator::March => ShadowBy::Marched {
                step: self.settings.stepsize,
                tau_max,
                rng,
            },
            ShadowEstimator::Ratio => ShadowBy::Ratio(rng),
        };
        self.medium.shadow_transmittance(&segment, by)
    }
}
