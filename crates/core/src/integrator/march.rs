//! The ray-marching pass: eye rays through every pixel, a source term at every marching
//! sample, layers accumulated front to back (thesis §6, eq. in §6 and §7.1.3).

use std::ops::ControlFlow;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

use glam::Vec3;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::cache::TransmittanceCache;
use super::gather::{MapGroup, MsVariant, group_by_map, source_factor};
use crate::control::Control;
use crate::error::{Error, Result};
use crate::film::{Film, Layer};
use crate::math::{Domain, Ray, Rng};
use crate::medium::Medium;
use crate::photon::{GatherScratch, PhotonMap};
use crate::scene::{Camera, IntegratorParams, Light, Quadrature, Scene, ShadowEstimator};

/// Counters of one marching pass.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct MarchStats {
    /// Wall-clock seconds.
    pub seconds: f64,
    /// Eye rays traced.
    pub eye_rays: u64,
    /// Samples where the source term was evaluated (σt > 0).
    pub samples: u64,
    /// Shadow transmittance evaluations (cache look-ups included).
    pub shadow_queries: u64,
    /// Radiance-estimate gathers (cache look-ups excluded).
    pub gathers: u64,
    /// Transmittance-cache nodes computed.
    pub shadow_cache_nodes: u64,
    /// Multiple-scattering-cache nodes computed.
    pub ms_cache_nodes: u64,
}

/// The films of one pass: one per multiple-scattering variant. Their single and emission
/// layers are identical.
#[derive(Debug, Clone)]
pub struct MarchOutput {
    /// One film per [`MsVariant`] (one film when `multiple` is off).
    pub films: Vec<Film>,
    /// Counters.
    pub stats: MarchStats,
}

struct Marcher<'a> {
    medium: &'a Medium,
    lights: &'a [Light],
    settings: &'a IntegratorParams,
    variants: &'a [MsVariant],
    groups: Vec<MapGroup<'a>>,
    shadow_caches: Option<Vec<TransmittanceCache>>,
    /// `−ln(termination)`: optical depth at which a marched shadow ray counts as blocked.
    shadow_tau_max: f32,
}

#[derive(Default)]
struct RowCounters {
    samples: u64,
    shadow: u64,
    gathers: u64,
}

/// Radiance accumulated for one pixel, plus scratch space and counters of its row.
struct Accumulator {
    single: Vec3,
    emission: Vec3,
    /// Sum and count of the depths where the eye transmittance fell below ½.
    depth_sum: f32,
    depth_hits: u32,
    multiple: Vec<Vec3>,
    estimates: Vec<Vec3>,
    gather: GatherScratch,
    counters: RowCounters,
}

impl Accumulator {
    fn new(variants: usize, max_group: usize) -> Self {
        Accumulator {
            single: Vec3::ZERO,
            emission: Vec3::ZERO,
            depth_sum: 0.0,
            depth_hits: 0,
            multiple: vec![Vec3::ZERO; variants],
            estimates: vec![Vec3::ZERO; max_group],
            gather: GatherScratch::default(),
            counters: RowCounters::default(),
        }
    }

    /// Clears the per-pixel sums (scratch space and counters stay).
    fn start_pixel(&mut self) {
        self.single = Vec3::ZERO;
        self.emission = Vec3::ZERO;
        self.depth_sum = 0.0;
        self.depth_hits = 0;
        self.multiple.iter_mut().for_each(|m| *m = Vec3::ZERO);
    }
}

/// One finished image row.
struct Row {
    single: Vec<Vec3>,
    emission: Vec<Vec3>,
    depth: Vec<f32>,
    multiple: Vec<Vec<Vec3>>,
    counters: RowCounters,
}

impl Row {
    fn new(width: usize, variants: usize) -> Self {
        Row {
            single: vec![Vec3::ZERO; width],
            emission: vec![Vec3::ZERO; width],
            depth: vec![f32::INFINITY; width],
            multiple: vec![vec![Vec3::ZERO; width]; variants],
            counters: RowCounters::default(),
        }
    }

    /// Stores pixel `x` as the mean of its `spp` samples.
    fn store(&mut self, x: usize, acc: &Accumulator, spp: u32) {
        let inv = 1.0 / spp as f32;
        self.single[x] = acc.single * inv;
        self.emission[x] = acc.emission * inv;
        if acc.depth_hits > 0 {
            self.depth[x] = acc.depth_sum / acc.depth_hits as f32;
        }
        for (dst, m) in self.multiple.iter_mut().zip(&acc.multiple) {
            dst[x] = *m * inv;
        }
    }
}

impl Marcher<'_> {
    fn shadow_transmittance(
        &self,
        light_index: usize,
        p: Vec3,
        to_light: Vec3,
        distance: f32,
        rng: &mut Rng,
    ) -> f32 {
        let light = &self.lights[light_index];
        if let Some(caches) = &self.shadow_caches {
            return caches[light_index].transmittance(
                self.medium,
                light,
                self.settings.stepsize,
                p,
            );
        }
        let ray = Ray {
            origin: p,
            direction: to_light,
        };
        let Some((t0, t1)) = self.medium.clip(&ray) else {
            return 1.0;
        };
        let t1 = t1.min(distance);
        match self.settings.shadow {
            ShadowEstimator::March => {
                // A shadow ray stops, like the eye ray, once its transmittance drops below
                // `termination`: the light it could still carry is below that fraction.
                let tau = self.medium.optical_depth_marched_until(
                    &ray,
                    t0,
                    t1,
                    self.settings.stepsize,
                    rng.uniform(),
                    self.shadow_tau_max,
                );
                if tau > self.shadow_tau_max {
                    0.0
                } else {
                    (-tau).exp()
                }
            }
            ShadowEstimator::Ratio => self.medium.transmittance_ratio_tracking(&ray, t0, t1, rng),
        }
    }

    /// Light scattered once at `x` towards `wo`: `Σ_lights L·T(x → light)·p` (to be
    /// weighted by σs and the quadrature).
    fn direct_light(&self, x: Vec3, wo: Vec3, rng: &mut Rng, acc: &mut Accumulator) -> Vec3 {
        let mut direct = Vec3::ZERO;
        for (li, light) in self.lights.iter().enumerate() {
            let Some(inc) = light.incident(x) else {
                continue;
            };
            acc.counters.shadow += 1;
            let tr = self.shadow_transmittance(li, x, inc.to_light, inc.distance, rng);
            if tr > 0.0 {
                direct += inc.radiance * (tr * self.medium.phase().eval(-inc.to_light, wo));
            }
        }
        direct
    }

    /// Adds every variant's multiple-scattering source term at `x`, weighted.
    fn add_multiple(&self, x: Vec3, wo: Vec3, sigma_t: f32, weight: f32, acc: &mut Accumulator) {
        for group in &self.groups {
            let estimates = &mut acc.estimates[..group.gather.len()];
            if group.estimate(self.medium, x, wo, &mut acc.gather, estimates) {
                acc.counters.gathers += 1;
            }
            for (&vi, e) in group.variants.iter().zip(estimates.iter()) {
                let factor = source_factor(self.variants[vi].estimate, self.medium, sigma_t);
                acc.multiple[vi] += factor * *e * weight;
            }
        }
    }

    /// Marches one eye ray; adds its radiance into the accumulator.
    fn trace(&self, ray: &Ray, rng: &mut Rng, acc: &mut Accumulator) {
        let Some((t0, t1)) = self.medium.clip(ray) else {
            return;
        };
        let s = self.settings;
        let u = rng.uniform();
        let wo = -ray.direction;
        let mut eye_t = 1.0f32;
        self.medium.march(ray, t0, t1, s.stepsize, u, |t, w| {
            let x = ray.at(t);
            let sigma_t = self.medium.sigma_t_in_box(x);
            if sigma_t <= 0.0 {
                return ControlFlow::Continue(());
            }
            acc.counters.samples += 1;
            let segment_t = (-sigma_t * w).exp();
            let weight = match s.quadrature {
                Quadrature::Exact => (1.0 - segment_t) / sigma_t,
                Quadrature::Riemann => w,
            } * eye_t;
            if s.single {
                let direct = self.direct_light(x, wo, rng, acc);
                acc.single += self.medium.albedo() * sigma_t * direct * weight;
            }
            if s.multiple {
                self.add_multiple(x, wo, sigma_t, weight, acc);
            }
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
    }

    /// Renders image row `y`: `spp` jittered eye rays per pixel, each from its own random
    /// stream `(seed, pixel, sample)`.
    fn render_row(&self, camera: &Camera, y: usize, max_group: usize) -> Row {
        let width = camera.width() as usize;
        let spp = self.settings.spp;
        let mut row = Row::new(width, self.variants.len());
        let mut acc = Accumulator::new(self.variants.len(), max_group);
        for x in 0..width {
            let pixel = (y * width + x) as u64;
            acc.start_pixel();
            for sample in 0..spp {
                let mut rng =
                    Rng::stream2(self.settings.seed, Domain::Pixels, pixel, sample as u64);
                let [jx, jy] = rng.uniform2();
                let ray = camera.ray(x as f32 + jx, y as f32 + jy);
                self.trace(&ray, &mut rng, &mut acc);
            }
            row.store(x, &acc, spp);
        }
        row.counters = std::mem::take(&mut acc.counters);
        row
    }
}

/// Renders a scene with the ray-marching integrator.
///
/// `maps` are photon maps of this scene (e.g. with different photon counts or free-path
/// rules); `variants` lists the multiple-scattering images to produce from one march, each
/// naming its map and estimate parameters (empty means the scene's own settings on
/// `maps[0]`). Variants on the same map share one k-NN query per sample; all share the
/// eye rays, the single-scattering and the emission layers. `control` receives the number
/// of rows finished and may stop the pass (a time limit).
pub fn render_march(
    scene: &Scene,
    maps: &[&PhotonMap],
    variants: &[MsVariant],
    control: &Control<'_>,
) -> Result<MarchOutput> {
    let start = Instant::now();
    let settings = scene.integrator();
    let medium = scene.medium();
    let own = [MsVariant {
        map: 0,
        nused: settings.nused,
        maxdist: settings.maxdist,
        estimate: settings.estimate,
    }];
    let variants: &[MsVariant] = if !settings.multiple {
        &[]
    } else if variants.is_empty() {
        &own
    } else {
        variants
    };
    if settings.ms_cache > 0 && settings.multiple && !medium.phase().is_isotropic() {
        return Err(Error::parameter(
            "integrator.ms_cache",
            settings.ms_cache,
            "0 when phase.g != 0 (the cached estimate is only view-independent for isotropic scattering)",
        ));
    }
    let bounds = medium.bounds();
    let groups = group_by_map(variants, maps, settings, bounds)?;
    let max_group = groups.iter().map(|g| g.gather.len()).max().unwrap_or(0);
    let marcher = Marcher {
        medium,
        lights: scene.lights(),
        settings,
        variants,
        groups,
        shadow_tau_max: if settings.termination > 0.0 {
            -settings.termination.ln()
        } else {
            f32::INFINITY
        },
        shadow_caches: (settings.shadow_cache > 0 && settings.single).then(|| {
            scene
                .lights()
                .iter()
                .map(|_| TransmittanceCache::new(bounds, settings.shadow_cache))
                .collect()
        }),
    };
    let camera = scene.camera();
    let rows_done = AtomicU64::new(0);
    let rows: Vec<Row> = (0..camera.height() as usize)
        .into_par_iter()
        .map(|y| {
            if control.expired() {
                // Past the time limit: the remaining rows are skipped and the pass fails.
                return Row::new(0, 0);
            }
            let row = marcher.render_row(camera, y, max_group);
            control.report(rows_done.fetch_add(1, Ordering::Relaxed) + 1);
            row
        })
        .collect();
    control.check()?;
    let (films, mut stats) = assemble(rows, camera, variants.len(), settings.spp);
    stats.shadow_cache_nodes = marcher
        .shadow_caches
        .as_ref()
        .map(|c| c.iter().map(|c| c.computed.load(Ordering::Relaxed)).sum())
        .unwrap_or(0);
    stats.ms_cache_nodes = marcher
        .groups
        .iter()
        .filter_map(|g| g.cache.as_ref())
        .map(|c| c.computed.load(Ordering::Relaxed))
        .sum();
    stats.seconds = start.elapsed().as_secs_f64();
    Ok(MarchOutput { films, stats })
}

/// Joins the rows into one film per variant (sharing the single, emission and depth
/// layers) and sums the rows' counters.
fn assemble(rows: Vec<Row>, camera: &Camera, variants: usize, spp: u32) -> (Vec<Film>, MarchStats) {
    let (width, height) = (camera.width() as usize, camera.height() as usize);
    let mut single = Vec::with_capacity(width * height);
    let mut emission = Vec::with_capacity(width * height);
    let mut depth = Vec::with_capacity(width * height);
    let mut multiple: Vec<Vec<Vec3>> = vec![Vec::with_capacity(width * height); variants];
    let mut stats = MarchStats {
        eye_rays: (width * height) as u64 * spp as u64,
        ..Default::default()
    };
    for row in rows {
        single.extend(row.single);
        emission.extend(row.emission);
        depth.extend(row.depth);
        for (dst, src) in multiple.iter_mut().zip(row.multiple) {
            dst.extend(src);
        }
        stats.samples += row.counters.samples;
        stats.shadow_queries += row.counters.shadow;
        stats.gathers += row.counters.gathers;
    }
    let films = (0..variants.max(1))
        .map(|i| {
            let mut film = Film::new(width, height).with_depth(depth.clone());
            film.set_layer(Layer::Single, single.clone());
            film.set_layer(Layer::Emission, emission.clone());
            if let Some(m) = multiple.get(i) {
                film.set_layer(Layer::Multiple, m.clone());
            }
            film
        })
        .collect();
    (films, stats)
}
