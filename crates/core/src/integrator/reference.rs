//! The unbiased reference: a volumetric path tracer for the same scenes.
//!
//! Delta tracking finds real collisions along each path; at a collision, Russian roulette
//! with the albedo decides between absorption and scattering; at a scattering vertex,
//! next-event estimation connects to every light through ratio-tracked transmittance, and a
//! new direction is sampled from the phase function. Layers follow the photon integrator's
//! split: light from a path's first scattering vertex is `single`, from later vertices
//! `multiple`; emission seen directly (before any scattering) is `emission`.
//!
//! Rendering is progressive: [`ReferenceAccumulator::add_passes`] adds one sample per pixel
//! per pass, keeping the running mean and the per-pixel variance (Welford), so a reference
//! can be refined later and its own noise is known. Pass `k` of pixel `i` always draws from
//! the random stream `(seed, i, k)`.

use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

use glam::Vec3;
use rayon::prelude::*;

use crate::control::Control;
use crate::error::{Error, Result};
use crate::film::{Film, Layer};
use crate::math::{Domain, Ray, Rng};
use crate::scene::Scene;

/// Vertices after which a path is stopped (albedo ≈ 1 in a closed medium).
pub const MAX_VERTICES: u32 = 100_000;

/// Running per-pixel statistics of the reference estimate.
#[derive(Debug, Clone, PartialEq)]
pub struct ReferenceAccumulator {
    width: usize,
    height: usize,
    passes: u32,
    mean: [Vec<Vec3>; 3],
    m2: [Vec<Vec3>; 3],
}

/// Radiance of one path, split by layer.
#[derive(Debug, Clone, Copy, Default)]
struct PathSample {
    single: Vec3,
    multiple: Vec3,
    emission: Vec3,
}

impl ReferenceAccumulator {
    /// An empty accumulator for `width × height` pixels.
    pub fn new(width: usize, height: usize) -> Self {
        let n = width * height;
        let zeros = || {
            [
                vec![Vec3::ZERO; n],
                vec![Vec3::ZERO; n],
                vec![Vec3::ZERO; n],
            ]
        };
        ReferenceAccumulator {
            width,
            height,
            passes: 0,
            mean: zeros(),
            m2: zeros(),
        }
    }

    /// Restores an accumulator from a film written with variance layers after `passes`
    /// passes (the variance of the mean is `m2 / (n (n − 1))`).
    pub fn from_film(film: &Film, passes: u32) -> Result<Self> {
        let mut acc = ReferenceAccumulator::new(film.width(), film.height());
        acc.passes = passes;
        for layer in Layer::ALL {
            let i = layer as usize;
            acc.mean[i] = film.layer(layer).to_vec();
            if passes >= 2 {
                let var = film.variance(layer).ok_or_else(|| Error::CannotResume {
                    what: "reference accumulator".into(),
                })?;
                let k = passes as f32 * (passes as f32 - 1.0);
                acc.m2[i] = var.iter().map(|v| *v * k).collect();
            }
        }
        Ok(acc)
    }

    /// Passes (samples per pixel) accumulated so far.
    pub fn passes(&self) -> u32 {
        self.passes
    }

    /// Adds `passes` samples per pixel. `control` receives the number of rows finished
    /// within the current call and may stop it; a stopped call leaves the accumulator
    /// partly updated, so it must be discarded.
    pub fn add_passes(&mut self, scene: &Scene, passes: u32, control: &Control<'_>) -> Result<f64> {
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
        let first = self.passes;
        let width = self.width;
        let rows_done = AtomicU64::new(0);
        let seed = scene.integrator().seed;
        let [ms, mm, me] = &mut self.mean;
        let [vs, vm, ve] = &mut self.m2;
        ms.par_chunks_mut(width)
            .zip(mm.par_chunks_mut(width))
            .zip(me.par_chunks_mut(width))
            .zip(vs.par_chunks_mut(width))
            .zip(vm.par_chunks_mut(width))
            .zip(ve.par_chunks_mut(width))
            .enumerate()
            .for_each(|(y, (((((ms, mm), me), vs), vm), ve))| {
                if control.expired() {
                    return;
                }
                for x in 0..width {
                    let pixel = (y * width + x) as u64;
                    for pass in first..first + passes {
                        let mut rng = Rng::stream2(seed, Domain::Reference, pixel, pass as u64);
                        let [jx, jy] = rng.uniform2();
                        let ray = camera.ray(x as f32 + jx, y as f32 + jy);
                        let s = trace_path(scene, ray, &mut rng);
                        let n = (pass + 1) as f32;
                        for (mean, m2, v) in [
                            (&mut ms[x], &mut vs[x], s.single),
                            (&mut mm[x], &mut vm[x], s.multiple),
                            (&mut me[x], &mut ve[x], s.emission),
                        ] {
                            let delta = v - *mean;
                            *mean += delta / n;
                            *m2 += delta * (v - *mean);
                        }
                    }
                }
                control.report(rows_done.fetch_add(1, Ordering::Relaxed) + 1);
            });
        control.check()?;
        self.passes += passes;
        Ok(start.elapsed().as_secs_f64())
    }

    /// The current estimate with per-pixel variance of the mean.
    pub fn film(&self) -> Film {
        let n = self.passes as f32;
        let var = |m2: &Vec<Vec3>| -> Vec<Vec3> {
            if self.passes < 2 {
                vec![Vec3::ZERO; m2.len()]
            } else {
                m2.iter().map(|v| *v / (n * (n - 1.0))).collect()
            }
        };
        Film::from_layers(self.width, self.height, self.mean.clone()).with_variance([
            var(&self.m2[0]),
            var(&self.m2[1]),
            var(&self.m2[2]),
        ])
    }
}

/// Traces one path from the camera.
fn trace_path(scene: &Scene, mut ray: Ray, rng: &mut Rng) -> PathSample {
    let medium = scene.medium();
    let settings = scene.integrator();
    let mut out = PathSample::default();
    let mut beta = Vec3::ONE;
    let mut vertices = 0u32;
    let survive = medium.mean_albedo();
    while let Some((t0, t1)) = medium.clip(&ray) {
        let Some(t) = medium.sample_interaction_delta(&ray, t0, t1, rng) else {
            break;
        };
        let x = ray.at(t);
        if vertices == 0 && settings.emission && medium.has_emission() {
            // Collision estimator of ∫ T ε dt: the collision density is σt·T.
            out.emission += beta * medium.emission(x) / medium.sigma_t(x);
        }
        // Absorb or scatter with the albedo (σs/σt) as survival probability.
        if survive <= 0.0 || rng.uniform() >= survive {
            break;
        }
        beta *= medium.albedo() / survive;
        vertices += 1;
        let layer_wanted = if vertices == 1 {
            settings.single
        } else {
            settings.multiple
        };
        if layer_wanted {
            let mut direct = Vec3::ZERO;
            for light in scene.lights() {
                let Some(inc) = light.incident(x) else {
                    continue;
                };
                let shadow = Ray {
                    origin: x,
                    direction: inc.to_light,
                };
                let tr = match medium.clip(&shadow) {
                    Some((s0, s1)) => {
                        medium.transmittance_ratio_tracking(&shadow, s0, s1.min(inc.distance), rng)
                    }
                    None => 1.0,
                };
                if tr > 0.0 {
                    direct +=
                        inc.radiance * (tr * medium.phase().eval(-inc.to_light, -ray.direction));
                }
            }
            if vertices == 1 {
                out.single += beta * direct;
            } else {
                out.multiple += beta * direct;
            }
        }
        if !settings.multiple || vertices >= MAX_VERTICES {
            // Later vertices only feed the multiple layer.
            break;
        }
        let direction = medium.phase().sample(ray.direction, rng.uniform2());
        ray = Ray::new(x, direction);
    }
    out
}

/// Renders a reference image with `passes` samples per pixel.
pub fn render_reference(scene: &Scene, passes: u32, control: &Control<'_>) -> Result<(Film, f64)> {
    let camera = scene.camera();
    let mut acc = ReferenceAccumulator::new(camera.width() as usize, camera.height() as usize);
    let seconds = acc.add_passes(scene, passes, control)?;
    Ok((acc.film(), seconds))
}
