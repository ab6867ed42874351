//! The running per-pixel statistics of a reference: Welford sums per layer, refined pass
//! by pass; per pixel as many samples as its allocation gives it.

use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

use glam::Vec3;
use rayon::prelude::*;

use super::allocation::Allocation;
use super::routes::{LightVisibility, Route, stratified_eye};
use super::{PathSample, delta, weighted};
use crate::control::Control;
use crate::counters::{self, Counter, Counts, Tallying};
use crate::error::{Error, Result};
use crate::film::{Film, Layer};
use crate::math::{Domain, Rng};
use crate::scene::{Scene, Tracker};

/// Running per-pixel statistics of the reference estimate.
#[derive(Debug, Clone, PartialEq)]
pub struct ReferenceAccumulator {
    pub(super) width: usize,
    pub(super) height: usize,
    pub(super) passes: u32,
    pub(super) pixels: Vec<PixelStats>,
    /// Whether the total's statistics cover every pass (not after [`Self::from_film`] of
    /// a film written without the total's variance).
    pub(super) total_known: bool,
    /// How many samples each pixel gets per pass (`None`: one), fixed by the first
    /// [`Self::add_passes`] of a tracker that allocates ([`Tracker::Weighted`]).
    pub(super) allocation: Option<Allocation>,
}

/// Welford sums of one pixel: mean and sum of squared deviations per layer (single,
/// multiple, emission) and of their total (whose variance is not the sum of the layers':
/// one path feeds several layers).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub(super) struct PixelStats {
    pub(super) mean: [Vec3; 4],
    pub(super) m2: [Vec3; 4],
}

impl PixelStats {
    /// Adds the `n`-th sample (1-based).
    #[inline]
    fn add(&mut self, s: &PathSample, n: f32) {
        let values = [
            s.single,
            s.multiple,
            s.emission,
            s.single + s.multiple + s.emission,
        ];
        for ((mean, m2), v) in self.mean.iter_mut().zip(&mut self.m2).zip(values) {
            let delta = v - *mean;
            *mean += delta / n;
            *m2 += delta * (v - *mean);
        }
    }
}

/// One path of `tracker` through pixel `pixel` (row-major over `width` columns), its
/// position in the pixel drawn first from `rng`.
#[inline]
fn trace(scene: &Scene, tracker: Tracker, width: usize, pixel: usize, rng: &mut Rng) -> PathSample {
    let (x, y) = (pixel % width, pixel / width);
    let [jx, jy] = rng.uniform2();
    let ray = scene.camera().ray(x as f32 + jx, y as f32 + jy);
    match tracker {
        Tracker::Delta => delta::trace_path(scene, ray, rng),
        Tracker::Weighted => weighted::trace_path(scene, ray, rng),
    }
}

/// Sample `k` of `pixel` along `route` (the weighted tracker, guided as the route says).
#[inline]
fn trace_route(
    scene: &Scene,
    route: Route,
    visibility: Option<&LightVisibility>,
    pixel: usize,
    k: u32,
    rng: &mut Rng,
) -> PathSample {
    let width = scene.camera().width() as usize;
    let (x, y) = (pixel % width, pixel / width);
    let (jitter, first_collision) = if route.stratified() {
        let [jx, jy, u] = stratified_eye(scene.integrator().seed, pixel, k);
        ([jx, jy], Some(u))
    } else {
        (rng.uniform2(), None)
    };
    let ray = scene
        .camera()
        .ray(x as f32 + jitter[0], y as f32 + jitter[1]);
    let guides = weighted::Guides {
        first_collision,
        visibility: visibility.filter(|_| route.visible_lights()),
    };
    weighted::trace_path_with(scene, ray, rng, weighted::Knobs::default(), guides)
}

impl ReferenceAccumulator {
    /// An empty accumulator for `width × height` pixels.
    pub fn new(width: usize, height: usize) -> Self {
        ReferenceAccumulator {
            width,
            height,
            passes: 0,
            pixels: vec![PixelStats::default(); width * height],
            total_known: true,
            allocation: None,
        }
    }

    /// Restores an accumulator from a film written with variance layers after `passes`
    /// passes of one sample per pixel (the variance of the mean is `m2 / (n (n − 1))`).
    /// A film of a tracker that allocates samples per pixel is restored by
    /// [`Self::resume`].
    pub fn from_film(film: &Film, passes: u32) -> Result<Self> {
        Self::restore(film, passes, None)
    }

    /// Restores an accumulator from a film that `scene` rendered with `passes` passes: a
    /// tracker that allocates samples per pixel runs its pilot again (the same allocation:
    /// it depends on the scene and seed alone), so each pixel's sums come back from its
    /// own number of samples.
    pub fn resume(scene: &Scene, film: &Film, passes: u32) -> Result<Self> {
        let allocation = (passes > 0)
            .then(|| pilot(scene, film.width(), film.height()))
            .flatten();
        Self::restore(film, passes, allocation)
    }

    fn restore(film: &Film, passes: u32, allocation: Option<Allocation>) -> Result<Self> {
        let mut acc = ReferenceAccumulator::new(film.width(), film.height());
        acc.passes = passes;
        acc.total_known = passes == 0;
        acc.allocation = allocation;
        let k: Vec<f32> = (0..acc.pixels.len())
            .map(|i| {
                let n = acc.samples(i, passes) as f32;
                n * (n - 1.0)
            })
            .collect();
        for layer in Layer::ALL {
            let i = layer as usize;
            let variance = if passes >= 2 {
                Some(film.variance(layer).ok_or_else(|| Error::CannotResume {
                    what: "reference accumulator".into(),
                })?)
            } else {
                None
            };
            for (p, px) in acc.pixels.iter_mut().enumerate() {
                px.mean[i] = film.layer(layer)[p];
                px.mean[3] += px.mean[i];
                if let Some(var) = variance {
                    px.m2[i] = var[p] * k[p];
                }
            }
        }
        if passes >= 2
            && let Some(total) = film.total_variance()
        {
            for ((px, var), k) in acc.pixels.iter_mut().zip(total).zip(&k) {
                px.m2[3] = *var * k;
            }
            acc.total_known = true;
        }
        Ok(acc)
    }

    /// Passes accumulated so far (samples per pixel, or per pixel's share of them when
    /// the samples are allocated).
    pub fn passes(&self) -> u32 {
        self.passes
    }

    /// Samples pixel `i` holds after `passes` passes.
    #[inline]
    pub(super) fn samples(&self, i: usize, passes: u32) -> u32 {
        match &self.allocation {
            Some(a) => a.samples(i, passes),
            None => passes,
        }
    }

    /// The number of samples each pixel holds.
    pub fn samples_per_pixel(&self) -> Vec<u32> {
        (0..self.pixels.len())
            .map(|i| self.samples(i, self.passes))
            .collect()
    }

    /// Adds `passes` passes: one sample per pixel each, or with an allocation each pixel's
    /// share (the first call of a tracker that allocates runs its pilot). Sample `k` of
    /// pixel `i` draws from the random stream `(seed, i, k)`. `control` receives the
    /// number of rows finished within the current call and may stop it; a stopped call
    /// leaves the accumulator partly updated, so it must be discarded.
    pub fn add_passes(&mut self, scene: &Scene, passes: u32, control: &Control<'_>) -> Result<f64> {
        self.add_passes_with(scene, passes, None, control)
    }

    /// [`Self::add_passes`] of the weighted tracker along a route to a faster reference
    /// ([`Route`]), with the weighted tracker's allocation: what `sweep bench --reference`
    /// races. [`Route::Weighted`] renders the weighted tracker's samples to the bit.
    pub fn add_passes_route(
        &mut self,
        scene: &Scene,
        passes: u32,
        route: Route,
        control: &Control<'_>,
    ) -> Result<f64> {
        let mut weighted = scene.integrator().clone();
        weighted.tracker = Tracker::Weighted;
        let scene = scene.with_integrator(weighted)?;
        self.add_passes_with(&scene, passes, Some(route), control)
    }

    fn add_passes_with(
        &mut self,
        scene: &Scene,
        passes: u32,
        route: Option<Route>,
        control: &Control<'_>,
    ) -> Result<f64> {
        let camera = scene.camera();
        if camera.width() as usize != self.width || camera.height() as usize != self.height {
            return Err(Error::SizeMismatch {
                what: "the reference accumulator".into(),
                size: [self.width, self.height],
                other: "the scene's camera".into(),
                other_size: [camera.width() as usize, camera.height() as usize],
            });
        }
        let start = Instant::now();
        if self.passes == 0 && passes > 0 {
            self.allocation = pilot(scene, self.width, self.height);
        }
        let visibility = route
            .filter(|r| r.visible_lights())
            .map(|_| LightVisibility::build(scene));
        let (first, width) = (self.passes, self.width);
        let rows_done = AtomicU64::new(0);
        let (seed, tracker) = (scene.integrator().seed, scene.integrator().tracker);
        let allocation = self.allocation.as_ref();
        let samples = |i: usize, p: u32| allocation.map_or(p, |a| a.samples(i, p));
        let counting = control.counting();
        // Each row counts on its own thread (when counting) and the rows' counts are summed
        // once, at the end of the call: no atomic in the loops (`crate::counters`).
        let counted = self
            .pixels
            .par_chunks_mut(width)
            .enumerate()
            .map(|(y, row)| {
                if control.expired() {
                    return Counts::default();
                }
                let tally = Tallying::start(counting.is_some());
                for (x, stats) in row.iter_mut().enumerate() {
                    let pixel = y * width + x;
                    let (from, to) = (samples(pixel, first), samples(pixel, first + passes));
                    for k in from..to {
                        let mut rng = Rng::stream2(seed, Domain::Reference, pixel as u64, k as u64);
                        let sample = match route {
                            Some(r) => {
                                trace_route(scene, r, visibility.as_ref(), pixel, k, &mut rng)
                            }
                            None => trace(scene, tracker, width, pixel, &mut rng),
                        };
                        stats.add(&sample, (k + 1) as f32);
                    }
                    counters::add(Counter::Samples, u64::from(to - from));
                }
                control.report(rows_done.fetch_add(1, Ordering::Relaxed) + 1);
                tally.finish()
            })
            .reduce(Counts::default, |a, b| a + b);
        control.check()?;
        if let Some(counting) = counting {
            counting.add(counted);
        }
        self.passes += passes;
        Ok(start.elapsed().as_secs_f64())
    }

    /// Variance of the mean from a sum of squared deviations, per pixel over its own
    /// number of samples.
    fn variance_of_mean(&self, i: usize) -> Vec<Vec3> {
        self.pixels
            .iter()
            .enumerate()
            .map(|(pixel, p)| {
                let n = self.samples(pixel, self.passes) as f32;
                if n < 2.0 {
                    Vec3::ZERO
                } else {
                    p.m2[i] / (n * (n - 1.0))
                }
            })
            .collect()
    }

    /// The current estimate with per-pixel variance of the mean (of each layer, and of
    /// their total when known).
    pub fn film(&self) -> Film {
        let layer = |i: usize| self.pixels.iter().map(|p| p.mean[i]).collect();
        let film = Film::from_layers(self.width, self.height, [layer(0), layer(1), layer(2)])
            .with_variance([
                self.variance_of_mean(0),
                self.variance_of_mean(1),
                self.variance_of_mean(2),
            ]);
        match self.total_variance() {
            Some(total) => film.with_total_variance(total),
            None => film,
        }
    }

    /// Per-pixel variance of the mean of the total (all layers), when every pass was
    /// accumulated here.
    pub fn total_variance(&self) -> Option<Vec<Vec3>> {
        self.total_known.then(|| self.variance_of_mean(3))
    }
}

/// The allocation of `scene`'s tracker over `width × height` pixels: a pilot for a
/// tracker that allocates, `None` (one sample per pixel per pass) for one that does not.
fn pilot(scene: &Scene, width: usize, height: usize) -> Option<Allocation> {
    let tracker = scene.integrator().tracker;
    match tracker {
        Tracker::Delta => None,
        Tracker::Weighted => Some(Allocation::from_pilot(
            scene,
            width,
            height,
            |pixel, rng| trace(scene, tracker, width, pixel, rng),
        )),
    }
}
