//! The reference's variance budget: where the noise of the default (`weighted`) tracker
//! comes from, and what each part of a path costs.
//!
//! The budget is a ladder of variants of the tracker, each replacing one more source of
//! noise by its expectation while keeping every pixel's expected value:
//!
//! 1. `production` — the tracker as it renders references;
//! 2. `+ exact single-scattering transmittance` — the first vertex's shadow rays from the
//!    exact optical depth instead of ratio tracking;
//! 3. `+ exact multiple-scattering transmittance` — the same at later vertices;
//! 4. `+ every light at later vertices` — no light choice;
//! 5. `+ no roulette` — survival biasing to the end of the path.
//!
//! The drop of the variance per sample from one rung to the next is that source's share.
//! What is left at the last rung — the pixel footprint, the eye ray's first free path and
//! the multiple-scattering paths' directions and collisions — is split by replicates: per
//! sample, one footprint, two first free paths from it, two continuations from each
//! (law of total variance: `paths = E[(X₁ − X₂)²]/2` within a first vertex, `first free
//! path = E[(X̄a − X̄b)²]/2 − paths/2` between two, the footprint the rest). With exact
//! single-scattering transmittance and delta lights the single layer is a function of the
//! first vertex alone, so these three are all the noise left; a light with extent adds its
//! sampled directions and the phase strategy's ([`super::mis`]) to `paths`.
//!
//! Every variance is the per-sample variance of a pixel's total (single + multiple),
//! averaged over the pixels (channels averaged), with the per-layer values beside it;
//! pixels are classed by their centre ray (empty, surface, soft, deep), and each variant's
//! CPU time per sample is measured, so that a route's gain — a variance removed at a cost —
//! can be predicted before it is built.

use std::time::Instant;

use glam::Vec3;
use rayon::prelude::*;

use super::PathSample;
use super::weighted::{self, Guides, Knobs, Walk};
use crate::control::Control;
use crate::error::Result;
use crate::math::{Domain, Ray, Rng};
use crate::scene::Scene;

/// A rung of the ladder: its name, what it replaces, and its knobs.
const LADDER: [(&str, &str, Knobs); 5] = [
    (
        "production",
        "the weighted tracker as it renders references",
        Knobs {
            exact_single_transmittance: false,
            exact_multiple_transmittance: false,
            every_light_later: false,
            no_roulette: false,
        },
    ),
    (
        "exact_single_transmittance",
        "+ the first vertex's transmittance to each light from the exact optical depth",
        Knobs {
            exact_single_transmittance: true,
            exact_multiple_transmittance: false,
            every_light_later: false,
            no_roulette: false,
        },
    ),
    (
        "exact_multiple_transmittance",
        "+ the later vertices' transmittance from the exact optical depth",
        Knobs {
            exact_single_transmittance: true,
            exact_multiple_transmittance: true,
            every_light_later: false,
            no_roulette: false,
        },
    ),
    (
        "every_light_later",
        "+ next-event estimation to every light at later vertices",
        Knobs {
            exact_single_transmittance: true,
            exact_multiple_transmittance: true,
            every_light_later: true,
            no_roulette: false,
        },
    ),
    (
        "no_roulette",
        "+ no Russian roulette (survival biasing to a throughput of 1e-6)",
        Knobs {
            exact_single_transmittance: true,
            exact_multiple_transmittance: true,
            every_light_later: true,
            no_roulette: true,
        },
    ),
];

/// The names of the noise sources, in the order the budget reports them.
pub const SOURCES: [&str; 7] = [
    "single_transmittance",
    "multiple_transmittance",
    "light_choice",
    "roulette",
    "multiple_paths",
    "first_free_path",
    "pixel_footprint",
];

/// How a pixel's centre ray meets the medium.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PixelClass {
    /// Optical depth below 0.05 along the whole ray.
    Empty,
    /// Optical depth 1 reached within 2 voxels of where the medium begins: a bone surface.
    Surface,
    /// Optical depth 1 reached 2 to 16 voxels in: soft tissue, light that enters.
    Soft,
    /// Optical depth 1 reached deeper than 16 voxels, or never: thin or deep medium.
    Deep,
}

impl PixelClass {
    /// All classes, in report order.
    pub const ALL: [PixelClass; 4] = [
        PixelClass::Empty,
        PixelClass::Surface,
        PixelClass::Soft,
        PixelClass::Deep,
    ];

    /// The class's name in the budget.
    pub fn name(self) -> &'static str {
        match self {
            PixelClass::Empty => "empty",
            PixelClass::Surface => "surface",
            PixelClass::Soft => "soft",
            PixelClass::Deep => "deep",
        }
    }
}

/// Variance per sample of a pixel's total and layers, averaged over pixels.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct LayerVariance {
    /// single + multiple + emission.
    pub total: f64,
    /// The single-scattering layer.
    pub single: f64,
    /// The multiple-scattering layer.
    pub multiple: f64,
}

/// A rung of the ladder, measured.
#[derive(Debug, Clone, PartialEq)]
pub struct Variant {
    /// Its name (`production`, `exact_single_transmittance`, …).
    pub name: &'static str,
    /// What it replaces.
    pub replaces: &'static str,
    /// Variance per sample, averaged over all pixels.
    pub variance: LayerVariance,
    /// The same, averaged over the pixels of each class ([`PixelClass::ALL`] order).
    pub by_class: [f64; 4],
    /// The image's mean (total, channels averaged) and its standard error: every rung
    /// estimates the same image.
    pub mean: (f64, f64),
    /// CPU seconds per sample of every pixel (one pass of one sample per pixel).
    pub cpu_per_pass_s: f64,
    /// `(Σᵢ √(vᵢ·cᵢ))²`: the variance × cost of one pass when samples go where the noise is
    /// (the weighted tracker's allocation, `cᵢ` each pixel's share of the CPU time by its
    /// work units); a route's predicted speed-up is production's over its own.
    pub allocated_variance_cost: f64,
}

/// One source's share of the production tracker's noise.
#[derive(Debug, Clone, PartialEq)]
pub struct Source {
    /// Its name ([`SOURCES`]).
    pub name: &'static str,
    /// Variance per sample it contributes, averaged over all pixels (of the total).
    pub variance: f64,
    /// The same per class.
    pub by_class: [f64; 4],
    /// Its share of production's variance.
    pub share: f64,
}

/// The CPU time of one production pass, by part of the path.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CpuSplit {
    /// Eye rays to their first collision (timed with neither layer).
    pub eye_rays_s: f64,
    /// The first vertex's shadow rays (single only, minus the eye rays).
    pub single_shadow_rays_s: f64,
    /// The multiple-scattering paths (all, minus single only).
    pub multiple_paths_s: f64,
}

/// The whole budget of one scene.
#[derive(Debug, Clone, PartialEq)]
pub struct Budget {
    /// Samples per pixel each rung averaged.
    pub samples: u32,
    /// Pixels per class ([`PixelClass::ALL`] order).
    pub class_pixels: [usize; 4],
    /// The ladder, measured.
    pub variants: Vec<Variant>,
    /// The production tracker's noise by source.
    pub sources: Vec<Source>,
    /// The sources' sum over production's variance: 1 by construction (the footprint is
    /// the remainder), kept as a check of the arithmetic, not a measurement.
    pub closure: f64,
    /// Production's CPU time by part.
    pub cpu: CpuSplit,
}

/// Per-pixel Welford sums of the total and the two layers (channels averaged).
#[derive(Debug, Clone, Copy, Default)]
struct Welford {
    n: u32,
    mean: [f64; 3],
    m2: [f64; 3],
    work: f64,
}

impl Welford {
    fn add(&mut self, s: &PathSample) {
        self.n += 1;
        let values = [
            mean3(s.single + s.multiple + s.emission),
            mean3(s.single),
            mean3(s.multiple),
        ];
        for ((mean, m2), v) in self.mean.iter_mut().zip(&mut self.m2).zip(values) {
            let d = v - *mean;
            *mean += d / f64::from(self.n);
            *m2 += d * (v - *mean);
        }
        self.work += f64::from(s.work);
    }

    fn variance(&self, i: usize) -> f64 {
        if self.n < 2 {
            0.0
        } else {
            self.m2[i] / f64::from(self.n - 1)
        }
    }
}

fn mean3(v: Vec3) -> f64 {
    (f64::from(v.x) + f64::from(v.y) + f64::from(v.z)) / 3.0
}

/// The jittered eye ray of sample `k` of `pixel`: its footprint is the stream's first two
/// draws, as the tracer's.
fn eye_ray(scene: &Scene, pixel: usize, rng: &mut Rng) -> Ray {
    let width = scene.camera().width() as usize;
    let (x, y) = (pixel % width, pixel / width);
    let [jx, jy] = rng.uniform2();
    scene.camera().ray(x as f32 + jx, y as f32 + jy)
}

/// Runs one rung over every pixel with `samples` samples each: per-pixel sums and the CPU
/// seconds it took.
fn rung(
    scene: &Scene,
    knobs: Knobs,
    samples: u32,
    control: &Control<'_>,
) -> Result<(Vec<Welford>, f64)> {
    let pixels = (scene.camera().width() * scene.camera().height()) as usize;
    let seed = scene.integrator().seed;
    let start = crate::util::process_cpu_seconds();
    let wall = Instant::now();
    let sums: Vec<Welford> = (0..pixels)
        .into_par_iter()
        .map(|pixel| {
            let mut w = Welford::default();
            if control.expired() {
                return w;
            }
            for k in 0..samples {
                let mut rng = Rng::stream2(
                    seed,
                    Domain::ReferenceBudget,
                    pixel as u64,
                    u64::from(k) * 8 + 7,
                );
                let ray = eye_ray(scene, pixel, &mut rng);
                w.add(&weighted::trace_path_with(
                    scene,
                    ray,
                    &mut rng,
                    knobs,
                    Guides::default(),
                ));
            }
            w
        })
        .collect();
    control.check()?;
    let cpu = match (start, crate::util::process_cpu_seconds()) {
        (Some(a), Some(b)) => b - a,
        _ => wall.elapsed().as_secs_f64(),
    };
    Ok((sums, cpu))
}

/// The last rung's noise split by replicates: per pixel, the mean over its samples of
/// `(X₁ − X₂)²/2` within a first vertex and of `(X̄a − X̄b)²/2` between two.
fn replicates(scene: &Scene, samples: u32, control: &Control<'_>) -> Result<Vec<(f64, f64)>> {
    let knobs = LADDER[LADDER.len() - 1].2;
    let pixels = (scene.camera().width() * scene.camera().height()) as usize;
    let seed = scene.integrator().seed;
    let splits: Vec<(f64, f64)> = (0..pixels)
        .into_par_iter()
        .map(|pixel| {
            let (mut within, mut between) = (0.0, 0.0);
            if control.expired() {
                return (0.0, 0.0);
            }
            for k in 0..samples {
                let stream = |part: u64| {
                    Rng::stream2(
                        seed,
                        Domain::ReferenceBudget,
                        pixel as u64,
                        u64::from(k) * 8 + part,
                    )
                };
                let ray = eye_ray(scene, pixel, &mut stream(0));
                let mut means = [0.0f64; 2];
                for (branch, mean) in means.iter_mut().enumerate() {
                    let mut first = PathSample::default();
                    let vertex = weighted::first_vertex(
                        scene,
                        &ray,
                        &mut stream(1 + branch as u64),
                        None,
                        &mut first,
                    );
                    let mut values = [0.0f64; 2];
                    for (c, value) in values.iter_mut().enumerate() {
                        let mut out = first;
                        if let Some(x) = vertex {
                            // Exact transmittance: under delta lights the single layer
                            // draws nothing.
                            let mut rng = stream(3 + 2 * branch as u64 + c as u64);
                            let walk = Walk {
                                knobs,
                                visibility: None,
                            };
                            weighted::from_first_vertex(
                                scene,
                                x,
                                ray.direction,
                                &mut rng,
                                walk,
                                &mut out,
                            );
                        }
                        *value = mean3(out.single + out.multiple + out.emission);
                    }
                    within += (values[0] - values[1]).powi(2) / 2.0;
                    *mean = (values[0] + values[1]) / 2.0;
                }
                between += (means[0] - means[1]).powi(2) / 2.0;
            }
            // Two first vertices per sample, each with its pair of continuations.
            let n = f64::from(samples);
            (within / (2.0 * n), between / n)
        })
        .collect();
    control.check()?;
    Ok(splits)
}

/// Each pixel's class, from its centre ray.
fn classes(scene: &Scene) -> Vec<PixelClass> {
    let (width, height) = (scene.camera().width(), scene.camera().height());
    let medium = scene.medium();
    let grid = medium.density_grid();
    let extent = medium.bounds().extent();
    let voxel = (0..3)
        .map(|a| extent[a] / grid.dims()[a].max(1) as f32)
        .fold(f32::INFINITY, f32::min);
    (0..width * height)
        .into_par_iter()
        .map(|pixel| {
            let ray = scene
                .camera()
                .ray((pixel % width) as f32 + 0.5, (pixel / width) as f32 + 0.5);
            let Some((t0, t1)) = medium.clip(&ray) else {
                return PixelClass::Empty;
            };
            if medium.optical_depth_exact(&ray, t0, t1, 1.0) < 0.05 {
                return PixelClass::Empty;
            }
            // Where the medium begins, and where τ passes 1, at a quarter voxel.
            let step = voxel / 4.0;
            let mut t = t0;
            let mut begin = None;
            let mut tau = 0.0f32;
            while t < t1 {
                let s = medium.sigma_t(ray.at(t));
                if s > 0.0 && begin.is_none() {
                    begin = Some(t);
                }
                tau += s * step;
                if tau >= 1.0 {
                    let depth = (t - begin.unwrap_or(t)) / voxel;
                    return match depth {
                        d if d <= 2.0 => PixelClass::Surface,
                        d if d <= 16.0 => PixelClass::Soft,
                        _ => PixelClass::Deep,
                    };
                }
                t += step;
            }
            PixelClass::Deep
        })
        .collect()
}

/// The mean over pixels of `f(pixel)`, over all and per class.
fn averages(classes: &[PixelClass], f: impl Fn(usize) -> f64) -> (f64, [f64; 4]) {
    let mut sums = [0.0f64; 4];
    let mut counts = [0usize; 4];
    let mut all = 0.0;
    for (i, c) in classes.iter().enumerate() {
        let v = f(i);
        all += v;
        sums[*c as usize] += v;
        counts[*c as usize] += 1;
    }
    let by = std::array::from_fn(|k| {
        if counts[k] > 0 {
            sums[k] / counts[k] as f64
        } else {
            0.0
        }
    });
    (all / classes.len().max(1) as f64, by)
}

/// Measures the budget of `scene` with `samples` samples per pixel and rung.
pub fn reference_budget(scene: &Scene, samples: u32, control: &Control<'_>) -> Result<Budget> {
    let classes = classes(scene);
    let class_pixels =
        std::array::from_fn(|k| classes.iter().filter(|c| **c as usize == k).count());
    let mut variants = Vec::new();
    let mut per_pixel: Vec<Vec<f64>> = Vec::new();
    for (name, replaces, knobs) in LADDER {
        let (sums, cpu) = rung(scene, knobs, samples, control)?;
        let cpu_per_pass_s = cpu / f64::from(samples);
        let total_work: f64 = sums.iter().map(|w| w.work).sum();
        let (total, by_class) = averages(&classes, |i| sums[i].variance(0));
        let allocated = sums
            .iter()
            .map(|w| (w.variance(0) * cpu_per_pass_s * w.work / total_work.max(1.0)).sqrt())
            .sum::<f64>()
            .powi(2);
        let pixels = sums.len() as f64;
        let mean = sums.iter().map(|w| w.mean[0]).sum::<f64>() / pixels;
        let se = (sums
            .iter()
            .map(|w| w.variance(0) / f64::from(w.n.max(1)))
            .sum::<f64>())
        .sqrt()
            / pixels;
        variants.push(Variant {
            name,
            replaces,
            mean: (mean, se),
            variance: LayerVariance {
                total,
                single: averages(&classes, |i| sums[i].variance(1)).0,
                multiple: averages(&classes, |i| sums[i].variance(2)).0,
            },
            by_class,
            cpu_per_pass_s,
            allocated_variance_cost: allocated,
        });
        per_pixel.push(sums.iter().map(|w| w.variance(0)).collect());
    }
    let splits = replicates(scene, samples, control)?;
    let sources = split_sources(&variants, &per_pixel, &splits, &classes);
    let production = variants[0].variance.total;
    let closure =
        sources.iter().map(|s| s.variance).sum::<f64>() / production.max(f64::MIN_POSITIVE);
    let cpu = cpu_split(scene, samples, control)?;
    Ok(Budget {
        samples,
        class_pixels,
        variants,
        sources,
        closure,
        cpu,
    })
}

/// The sources from the ladder's drops and the replicates' split of its last rung.
fn split_sources(
    variants: &[Variant],
    per_pixel: &[Vec<f64>],
    splits: &[(f64, f64)],
    classes: &[PixelClass],
) -> Vec<Source> {
    let production = variants[0].variance.total;
    let last = per_pixel.len() - 1;
    let mut sources = Vec::new();
    // The ladder's drops: rung k − 1 against rung k.
    for (k, name) in SOURCES.iter().take(4).enumerate() {
        let (v, by) = averages(classes, |i| per_pixel[k][i] - per_pixel[k + 1][i]);
        sources.push((*name, v, by));
    }
    let (paths, paths_by) = averages(classes, |i| splits[i].0);
    let (free, free_by) = averages(classes, |i| splits[i].1 - splits[i].0 / 2.0);
    let (footprint, footprint_by) = averages(classes, |i| {
        per_pixel[last][i] - splits[i].1 - splits[i].0 / 2.0
    });
    sources.push((SOURCES[4], paths, paths_by));
    sources.push((SOURCES[5], free, free_by));
    sources.push((SOURCES[6], footprint, footprint_by));
    sources
        .into_iter()
        .map(|(name, variance, by_class)| Source {
            name,
            variance,
            by_class,
            share: variance / production.max(f64::MIN_POSITIVE),
        })
        .collect()
}

/// Production's CPU time per pass by part: eye rays alone, with single scattering, with
/// both layers.
fn cpu_split(scene: &Scene, samples: u32, control: &Control<'_>) -> Result<CpuSplit> {
    let with = |single: bool, multiple: bool| -> Result<f64> {
        let mut settings = scene.integrator().clone();
        settings.single = single;
        settings.multiple = multiple;
        // A render with no layer is refused; emission stands in (nothing emits here).
        settings.emission = !(single || multiple);
        let variant = scene.with_integrator(settings)?;
        Ok(rung(&variant, Knobs::default(), samples, control)?.1 / f64::from(samples))
    };
    let eye = with(false, false)?;
    let single = with(true, false)?;
    let all = with(true, true)?;
    Ok(CpuSplit {
        eye_rays_s: eye,
        single_shadow_rays_s: (single - eye).max(0.0),
        multiple_paths_s: (all - single).max(0.0),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_util::{SPOT_SPHERE, scene};

    /// The ladder keeps every pixel's expectation (each rung is unbiased), and the
    /// replicates' split of the last rung fits inside it. (The sources add up to
    /// production's variance by construction — the footprint is the remainder — so what
    /// can fail is a split that claims more than the rung holds.)
    #[test]
    fn each_rung_keeps_the_mean_and_the_split_fits_the_last_rung() {
        let s = scene(SPOT_SPHERE);
        let budget = reference_budget(&s, 64, &Control::none()).unwrap();
        assert_eq!(budget.variants.len(), 5);
        assert_eq!(budget.sources.len(), SOURCES.len());
        let remainder = budget.sources.last().unwrap();
        assert!(
            remainder.share > -0.1,
            "paths and first free path claim more than the last rung's variance: remainder {}",
            remainder.share
        );
        // Every rung estimates the same image.
        let (m0, se0) = budget.variants[0].mean;
        for v in &budget.variants[1..] {
            let z = (v.mean.0 - m0) / (v.mean.1.powi(2) + se0 * se0).sqrt();
            assert!(
                z.abs() < 4.0,
                "{}: mean {} against {m0}, z {z}",
                v.name,
                v.mean.0
            );
        }
        // Removing noise sources lowers the variance (up to sampling error).
        let first = budget.variants[0].variance.total;
        let last = budget.variants[4].variance.total;
        assert!(last < first, "{first} → {last}");
        assert!(budget.class_pixels.iter().sum::<usize>() == 400);
        assert!(budget.class_pixels[0] > 0 && budget.class_pixels[0] < 400);
        assert!(budget.cpu.eye_rays_s >= 0.0 && budget.cpu.multiple_paths_s >= 0.0);
    }
}
