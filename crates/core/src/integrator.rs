//! The ray-marching integrator (thesis §6, §7.1.3).
//!
//! Each eye ray is cut into segments of `stepsize`; one sample per segment at a random
//! offset that is the same for every segment of the ray (Pauly et al. 2000). At each sample
//! with σt > 0 (samples with σs = 0 are skipped, §7.1.3):
//!
//! * single scattering from every light: `σs · p · I·falloff/r² · T(x → light)`;
//! * multiple scattering from the photon map: `σs(x) · Σ p ΔΦ_p / (σt(x_p) · V_m)` with
//!   `V_m` the medium's share of the gather sphere (eq. 11 in fluence form, normalised by
//!   where photons can be; the thesis's own form is selectable, see [`Estimate`]);
//! * emission: `Le · d(x)`;
//!
//! each weighted by the segment's quadrature and the running eye transmittance, which is
//! updated multiplicatively (eq. 3). Marching stops when the eye transmittance drops below
//! `termination`; the radiance lost is at most that fraction of what lies behind. Marched
//! shadow rays stop at the same threshold (the light they could still carry is below that
//! fraction) and count as blocked.
//!
//! All three layers come from ONE pass, so "single only" and "single + multiple" share
//! every random decision.
//!
//! Acceleration that keeps results honest: empty-space skipping over majorant bricks, an
//! optional per-light transmittance cache (`shadow_cache`) and an optional
//! multiple-scattering cache (`ms_cache`, view-independent for isotropic phase). Both
//! caches are off by default; their error against the uncached path is measured in tests.

use std::ops::ControlFlow;
use std::sync::OnceLock;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

use glam::Vec3;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::film::{Film, Layer};
use crate::geometry::{Aabb, Ray};
use crate::light::Light;
use crate::medium::Medium;
use crate::photon_map::{GatherScratch, GatherVariant, Gathered, PhotonMap};
use crate::rng::{Domain, Rng};
use crate::scene::Scene;
use crate::settings::{Estimate, IntegratorParams, Quadrature, ShadowEstimator};

/// Optical depth up to which the transmittance cache marches its nodes (T ≈ 10⁻¹⁶): far
/// beyond any shadow threshold, so interpolation between a lit and a dark node stays exact
/// in the logarithm.
pub const CACHE_TAU_MAX: f32 = 36.8;

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

/// A lattice of nodes spanning a box, corner-aligned, for the caches.
#[derive(Debug, Clone)]
struct NodeLattice {
    res: [usize; 3],
    bounds: Aabb,
    spacing: Vec3,
}

impl NodeLattice {
    fn new(bounds: Aabb, longest: u32) -> Self {
        let extent = bounds.extent();
        let longest_extent = extent.max_element();
        let res = [0, 1, 2].map(|a| {
            ((extent[a] / longest_extent * (longest - 1) as f32).round() as usize + 1).max(2)
        });
        let spacing = Vec3::new(
            extent.x / (res[0] - 1) as f32,
            extent.y / (res[1] - 1) as f32,
            extent.z / (res[2] - 1) as f32,
        );
        NodeLattice {
            res,
            bounds,
            spacing,
        }
    }

    fn len(&self) -> usize {
        self.res[0] * self.res[1] * self.res[2]
    }

    fn position(&self, index: usize) -> Vec3 {
        let x = index % self.res[0];
        let y = (index / self.res[0]) % self.res[1];
        let z = index / (self.res[0] * self.res[1]);
        self.bounds.min + Vec3::new(x as f32, y as f32, z as f32) * self.spacing
    }

    /// The 8 surrounding nodes and their trilinear weights.
    #[inline]
    fn corners(&self, p: Vec3) -> [(usize, f32); 8] {
        let c = ((p - self.bounds.min) / self.spacing).max(Vec3::ZERO);
        let i0 = [0, 1, 2].map(|a| (c[a] as usize).min(self.res[a] - 2));
        let t = Vec3::new(
            (c.x - i0[0] as f32).clamp(0.0, 1.0),
            (c.y - i0[1] as f32).clamp(0.0, 1.0),
            (c.z - i0[2] as f32).clamp(0.0, 1.0),
        );
        let mut out = [(0usize, 0f32); 8];
        for (k, o) in out.iter_mut().enumerate() {
            let (dx, dy, dz) = (k & 1, (k >> 1) & 1, (k >> 2) & 1);
            let idx = (i0[0] + dx) + self.res[0] * ((i0[1] + dy) + self.res[1] * (i0[2] + dz));
            let w = (if dx == 1 { t.x } else { 1.0 - t.x })
                * (if dy == 1 { t.y } else { 1.0 - t.y })
                * (if dz == 1 { t.z } else { 1.0 - t.z });
            *o = (idx, w);
        }
        out
    }
}

/// Per-light cache of the optical depth to the light at lattice nodes, filled lazily (each
/// node depends only on its own position, so the result does not depend on thread order).
struct TransmittanceCache {
    lattice: NodeLattice,
    tau: Vec<OnceLock<f32>>,
    computed: AtomicU64,
}

impl TransmittanceCache {
    fn new(bounds: Aabb, res: u32) -> Self {
        let lattice = NodeLattice::new(bounds, res);
        let tau = (0..lattice.len()).map(|_| OnceLock::new()).collect();
        TransmittanceCache {
            lattice,
            tau,
            computed: AtomicU64::new(0),
        }
    }

    fn transmittance(&self, medium: &Medium, light: &Light, step: f32, p: Vec3) -> f32 {
        let mut tau = 0.0;
        for (idx, w) in self.lattice.corners(p) {
            if w == 0.0 {
                continue;
            }
            let node_tau = *self.tau[idx].get_or_init(|| {
                self.computed.fetch_add(1, Ordering::Relaxed);
                let node = self.lattice.position(idx);
                let to_light = light.position() - node;
                let distance = to_light.length();
                if distance <= 0.0 {
                    return 0.0;
                }
                let ray = Ray::new(node, to_light);
                match medium.clip(&ray) {
                    Some((t0, t1)) => medium.optical_depth_marched_until(
                        &ray,
                        t0,
                        t1.min(distance),
                        step,
                        0.5,
                        CACHE_TAU_MAX,
                    ),
                    None => 0.0,
                }
            });
            tau += w * node_tau;
        }
        (-tau).exp()
    }
}

/// Cache of multiple-scattering source terms at lattice nodes (isotropic phase only).
struct ScatterCache {
    lattice: NodeLattice,
    nodes: Vec<OnceLock<Box<[Vec3]>>>,
    computed: AtomicU64,
}

impl ScatterCache {
    fn new(bounds: Aabb, res: u32) -> Self {
        let lattice = NodeLattice::new(bounds, res);
        let nodes = (0..lattice.len()).map(|_| OnceLock::new()).collect();
        ScatterCache {
            lattice,
            nodes,
            computed: AtomicU64::new(0),
        }
    }

    fn lookup(
        &self,
        map: &PhotonMap,
        gather: &[GatherVariant],
        masked: &[bool],
        medium: &Medium,
        p: Vec3,
        out: &mut [Vec3],
    ) {
        out.iter_mut().for_each(|o| *o = Vec3::ZERO);
        for (idx, w) in self.lattice.corners(p) {
            if w == 0.0 {
                continue;
            }
            let values = self.nodes[idx].get_or_init(|| {
                self.computed.fetch_add(1, Ordering::Relaxed);
                let mut v = vec![Vec3::ZERO; gather.len()];
                let mut scratch = GatherScratch::default();
                let node = self.lattice.position(idx);
                map.estimates(node, Vec3::Z, medium.phase(), gather, &mut scratch, &mut v);
                mask_estimates(medium, node, masked, scratch.radii(), &mut v);
                v.into_boxed_slice()
            });
            for (o, v) in out.iter_mut().zip(values.iter()) {
                *o += *v * w;
            }
        }
    }
}

/// Divides masked estimates by the medium's share of their gather sphere. Variants often
/// share a radius (all that hit `maxdist`, or equal `nused` under different caps), so each
/// distinct radius is measured once.
fn mask_estimates(medium: &Medium, at: Vec3, masked: &[bool], radii: &[f32], values: &mut [Vec3]) {
    let mut measured: [(f32, f32); 8] = [(f32::NAN, 0.0); 8];
    let mut count = 0;
    for ((value, &m), &r) in values.iter_mut().zip(masked).zip(radii) {
        if !m || r <= 0.0 {
            continue;
        }
        let share = match measured[..count].iter().find(|(radius, _)| *radius == r) {
            Some(&(_, share)) => share,
            None => {
                let share = medium.occupancy(at, r);
                measured[count % measured.len()] = (r, share);
                count = (count + 1).min(measured.len());
                share
            }
        };
        *value = if share > 0.0 {
            *value / share
        } else {
            Vec3::ZERO
        };
    }
}

/// One multiple-scattering image rendered from a shared march: which photon map, and the
/// radiance-estimate parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MsVariant {
    /// Index into the photon maps passed to [`render_march`].
    pub map: usize,
    /// Photons per estimate.
    pub nused: u32,
    /// Largest gather radius.
    pub maxdist: f32,
    /// Estimate form.
    pub estimate: Estimate,
}

/// The variants that share one photon map, and thus one k-NN query per sample.
struct MapGroup<'a> {
    map: &'a PhotonMap,
    /// Indices into the variant list (and output films).
    variants: Vec<usize>,
    /// The gathers to run, aligned with `variants`.
    gather: Vec<GatherVariant>,
    /// Which gathers are normalised by the medium's share of the sphere.
    masked: Vec<bool>,
    cache: Option<ScatterCache>,
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

/// One finished image row.
struct Row {
    single: Vec<Vec3>,
    emission: Vec<Vec3>,
    depth: Vec<f32>,
    multiple: Vec<Vec<Vec3>>,
    counters: RowCounters,
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
                acc.single += self.medium.albedo() * sigma_t * direct * weight;
            }
            if s.multiple {
                for group in &self.groups {
                    let estimates = &mut acc.estimates[..group.gather.len()];
                    match &group.cache {
                        Some(cache) => cache.lookup(
                            group.map,
                            &group.gather,
                            &group.masked,
                            self.medium,
                            x,
                            estimates,
                        ),
                        None => {
                            acc.counters.gathers += 1;
                            group.map.estimates(
                                x,
                                wo,
                                self.medium.phase(),
                                &group.gather,
                                &mut acc.gather,
                                estimates,
                            );
                            mask_estimates(
                                self.medium,
                                x,
                                &group.masked,
                                acc.gather.radii(),
                                estimates,
                            );
                        }
                    }
                    for (&vi, e) in group.variants.iter().zip(estimates.iter()) {
                        // Source term per unit length from the gathered density (`Estimate`).
                        let factor = match self.variants[vi].estimate {
                            Estimate::Masked | Estimate::Fluence => self.medium.albedo() * sigma_t,
                            Estimate::Albedo => self.medium.albedo(),
                            Estimate::Thesis => Vec3::ONE,
                        };
                        acc.multiple[vi] += factor * *e * weight;
                    }
                }
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
}

/// Renders a scene with the ray-marching integrator.
///
/// `maps` are photon maps of this scene (e.g. with different photon counts or free-path
/// rules); `variants` lists the multiple-scattering images to produce from one march, each
/// naming its map and estimate parameters (empty means the scene's own settings on
/// `maps[0]`). Variants on the same map share one k-NN query per sample; all share the
/// eye rays, the single-scattering and the emission layers. `progress` is called with the
/// number of rows finished.
pub fn render_march(
    scene: &Scene,
    maps: &[&PhotonMap],
    variants: &[MsVariant],
    progress: &(dyn Fn(u64) + Sync),
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
    if let Some(v) = variants.iter().find(|v| v.map >= maps.len()) {
        return Err(Error::Render(format!(
            "multiple scattering variant uses photon map {} but {} map(s) were given (build one with build_photon_map)",
            v.map,
            maps.len()
        )));
    }
    if settings.ms_cache > 0 && settings.multiple && !medium.phase().is_isotropic() {
        return Err(Error::parameter(
            "integrator.ms_cache",
            settings.ms_cache,
            "0 when phase.g != 0 (the cached estimate is only view-independent for isotropic scattering)",
        ));
    }
    let bounds = medium.bounds();
    let mut groups: Vec<MapGroup> = Vec::new();
    for (vi, v) in variants.iter().enumerate() {
        let gather = GatherVariant {
            nused: v.nused,
            maxdist: v.maxdist,
            gathered: match v.estimate {
                Estimate::Masked | Estimate::Fluence => Gathered::Fluence,
                Estimate::Albedo | Estimate::Thesis => Gathered::Flux,
            },
        };
        let masked = v.estimate == Estimate::Masked;
        match groups.iter_mut().find(|g| std::ptr::eq(g.map, maps[v.map])) {
            Some(g) => {
                g.variants.push(vi);
                g.gather.push(gather);
                g.masked.push(masked);
            }
            None => groups.push(MapGroup {
                map: maps[v.map],
                variants: vec![vi],
                gather: vec![gather],
                masked: vec![masked],
                cache: (settings.ms_cache > 0)
                    .then(|| ScatterCache::new(bounds, settings.ms_cache)),
            }),
        }
    }
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
    let (width, height) = (camera.width() as usize, camera.height() as usize);
    let n_films = variants.len().max(1);
    let rows_done = AtomicU64::new(0);
    let spp = settings.spp;
    let rows: Vec<Row> = (0..height)
        .into_par_iter()
        .map(|y| {
            let mut row = Row {
                single: vec![Vec3::ZERO; width],
                emission: vec![Vec3::ZERO; width],
                depth: vec![f32::INFINITY; width],
                multiple: vec![vec![Vec3::ZERO; width]; variants.len()],
                counters: RowCounters::default(),
            };
            let mut acc = Accumulator {
                single: Vec3::ZERO,
                emission: Vec3::ZERO,
                depth_sum: 0.0,
                depth_hits: 0,
                multiple: vec![Vec3::ZERO; variants.len()],
                estimates: vec![Vec3::ZERO; max_group],
                gather: GatherScratch::default(),
                counters: RowCounters::default(),
            };
            let inv = 1.0 / spp as f32;
            for x in 0..width {
                let pixel = (y * width + x) as u64;
                acc.single = Vec3::ZERO;
                acc.emission = Vec3::ZERO;
                acc.depth_sum = 0.0;
                acc.depth_hits = 0;
                acc.multiple.iter_mut().for_each(|m| *m = Vec3::ZERO);
                for sample in 0..spp {
                    let mut rng = Rng::stream2(settings.seed, Domain::Pixels, pixel, sample as u64);
                    let [jx, jy] = rng.uniform2();
                    let ray = camera.ray(x as f32 + jx, y as f32 + jy);
                    marcher.trace(&ray, &mut rng, &mut acc);
                }
                row.single[x] = acc.single * inv;
                row.emission[x] = acc.emission * inv;
                if acc.depth_hits > 0 {
                    row.depth[x] = acc.depth_sum / acc.depth_hits as f32;
                }
                for (dst, m) in row.multiple.iter_mut().zip(&acc.multiple) {
                    dst[x] = *m * inv;
                }
            }
            row.counters = std::mem::take(&mut acc.counters);
            progress(rows_done.fetch_add(1, Ordering::Relaxed) + 1);
            row
        })
        .collect();
    let mut single = Vec::with_capacity(width * height);
    let mut emission = Vec::with_capacity(width * height);
    let mut depth = Vec::with_capacity(width * height);
    let mut multiple: Vec<Vec<Vec3>> = vec![Vec::with_capacity(width * height); variants.len()];
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
    let films = (0..n_films)
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
