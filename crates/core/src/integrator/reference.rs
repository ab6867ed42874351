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

use std::path::Path;
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
    pixels: Vec<PixelStats>,
    /// Whether the total's statistics cover every pass (not after [`Self::from_film`] of
    /// a film written without the total's variance).
    total_known: bool,
}

/// Welford sums of one pixel: mean and sum of squared deviations per layer (single,
/// multiple, emission) and of their total (whose variance is not the sum of the layers':
/// one path feeds several layers).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
struct PixelStats {
    mean: [Vec3; 4],
    m2: [Vec3; 4],
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
        ReferenceAccumulator {
            width,
            height,
            passes: 0,
            pixels: vec![PixelStats::default(); width * height],
            total_known: true,
        }
    }

    /// Restores an accumulator from a film written with variance layers after `passes`
    /// passes (the variance of the mean is `m2 / (n (n − 1))`).
    pub fn from_film(film: &Film, passes: u32) -> Result<Self> {
        let mut acc = ReferenceAccumulator::new(film.width(), film.height());
        acc.passes = passes;
        acc.total_known = passes == 0;
        let k = passes as f32 * (passes as f32 - 1.0);
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
                    px.m2[i] = var[p] * k;
                }
            }
        }
        if passes >= 2
            && let Some(total) = film.total_variance()
        {
            for (px, var) in acc.pixels.iter_mut().zip(total) {
                px.m2[3] = *var * k;
            }
            acc.total_known = true;
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
        self.pixels
            .par_chunks_mut(width)
            .enumerate()
            .for_each(|(y, row)| {
                if control.expired() {
                    return;
                }
                for (x, stats) in row.iter_mut().enumerate() {
                    let pixel = (y * width + x) as u64;
                    for pass in first..first + passes {
                        let mut rng = Rng::stream2(seed, Domain::Reference, pixel, pass as u64);
                        let [jx, jy] = rng.uniform2();
                        let ray = camera.ray(x as f32 + jx, y as f32 + jy);
                        stats.add(&trace_path(scene, ray, &mut rng), (pass + 1) as f32);
                    }
                }
                control.report(rows_done.fetch_add(1, Ordering::Relaxed) + 1);
            });
        control.check()?;
        self.passes += passes;
        Ok(start.elapsed().as_secs_f64())
    }

    /// Variance of the mean from a sum of squared deviations.
    fn variance_of_mean(&self, i: usize) -> Vec<Vec3> {
        let n = self.passes as f32;
        self.pixels
            .iter()
            .map(|p| {
                if self.passes < 2 {
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

    /// Writes the accumulator's exact state (every running sum, bit for bit) to `path`.
    ///
    /// A film keeps the variance of the mean, from which [`Self::from_film`] recovers the
    /// sums only to rounding; [`Self::read_state`] recovers them exactly, so passes added
    /// after it give the bits of an accumulator that ran them all at once: a reference of
    /// `n` passes is the same image whether it was rendered whole or refined in steps.
    pub fn write_state(&self, path: &Path) -> Result<()> {
        let mut bytes = Vec::with_capacity(STATE_HEADER_LEN + self.pixels.len() * PIXEL_BYTES);
        bytes.extend_from_slice(STATE_MAGIC);
        for n in [self.width as u32, self.height as u32, self.passes] {
            bytes.extend_from_slice(&n.to_le_bytes());
        }
        bytes.push(u8::from(self.total_known));
        for px in &self.pixels {
            for v in px.mean.iter().chain(&px.m2) {
                for c in v.to_array() {
                    bytes.extend_from_slice(&c.to_le_bytes());
                }
            }
        }
        std::fs::write(path, bytes).map_err(|error| Error::Io {
            path: path.to_path_buf(),
            error,
        })
    }

    /// Reads a state written by [`Self::write_state`].
    pub fn read_state(path: &Path) -> Result<Self> {
        let bytes = std::fs::read(path).map_err(|error| Error::Io {
            path: path.to_path_buf(),
            error,
        })?;
        let format = |message: String| Error::Format {
            path: path.to_path_buf(),
            message,
        };
        if bytes.len() < STATE_HEADER_LEN || !bytes.starts_with(STATE_MAGIC) {
            return Err(format(format!(
                "not a reference accumulator state (expected a file starting with {:?})",
                String::from_utf8_lossy(STATE_MAGIC)
            )));
        }
        let word = |i: usize| {
            let at = STATE_MAGIC.len() + 4 * i;
            u32::from_le_bytes(bytes[at..at + 4].try_into().expect("4 bytes"))
        };
        let (width, height, passes) = (word(0) as usize, word(1) as usize, word(2));
        let expected = width
            .checked_mul(height)
            .and_then(|n| n.checked_mul(PIXEL_BYTES))
            .and_then(|n| n.checked_add(STATE_HEADER_LEN));
        if expected != Some(bytes.len()) {
            return Err(format(format!(
                "{} bytes for a {width}×{height} state, expected {}",
                bytes.len(),
                expected.map_or("fewer pixels".into(), |n| n.to_string())
            )));
        }
        let mut floats = bytes[STATE_HEADER_LEN..]
            .chunks_exact(4)
            .map(|b| f32::from_le_bytes(b.try_into().expect("4 bytes")));
        let mut next = || {
            Vec3::new(
                next_f32(&mut floats),
                next_f32(&mut floats),
                next_f32(&mut floats),
            )
        };
        let pixels = (0..width * height)
            .map(|_| PixelStats {
                mean: std::array::from_fn(|_| next()),
                m2: std::array::from_fn(|_| next()),
            })
            .collect();
        Ok(ReferenceAccumulator {
            width,
            height,
            passes,
            pixels,
            total_known: bytes[STATE_HEADER_LEN - 1] != 0,
        })
    }

    /// Per-pixel variance of the mean of the total (all layers), when every pass was
    /// accumulated here.
    pub fn total_variance(&self) -> Option<Vec<Vec3>> {
        self.total_known.then(|| self.variance_of_mean(3))
    }
}

/// The first bytes of a state file ([`ReferenceAccumulator::write_state`]).
const STATE_MAGIC: &[u8] = b"volphot reference state 1\n";
/// Magic, width, height, passes, whether the total is known.
const STATE_HEADER_LEN: usize = STATE_MAGIC.len() + 3 * 4 + 1;
/// Four means and four sums of squared deviations, three channels each.
const PIXEL_BYTES: usize = 8 * 3 * 4;

/// The next float of a state whose length was checked.
fn next_f32(floats: &mut impl Iterator<Item = f32>) -> f32 {
    floats.next().expect("length checked")
}

/// Traces one path from the camera.
fn trace_path(scene: &Scene, mut ray: Ray, rng: &mut Rng) -> PathSample {
    let medium = scene.medium();
    let settings = scene.integrator();
    let mut out = PathSample::default();
    let mut beta = Vec3::ONE;
    let mut vertices = 0u32;
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
        let albedo = medium.albedo_at(x);
        let survive = crate::medium::survival_probability(albedo);
        if survive <= 0.0 || rng.uniform() >= survive {
            break;
        }
        beta *= albedo / survive;
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_util::{SPOT_SPHERE, scene, spot_sphere_with_albedo};

    /// Per channel: the image's mean of the total, and the variance of that mean.
    fn mean_and_variance(scene: &Scene, passes: u32) -> (Vec3, Vec3) {
        let mut acc = ReferenceAccumulator::new(20, 20);
        acc.add_passes(scene, passes, &Control::none()).unwrap();
        let total = acc.film().total();
        let n = total.len() as f32;
        let mean = total.iter().sum::<Vec3>() / n;
        let variance = acc.total_variance().unwrap().iter().sum::<Vec3>() / (n * n);
        (mean, variance)
    }

    #[test]
    fn each_channel_of_a_coloured_albedo_renders_as_the_grey_medium_of_its_albedo() {
        // σt = 20 in every channel; albedo (0.9, 0.3, 0.1). Extinction is grey, so each
        // channel's light is the grey medium's with that channel's albedo.
        let albedo = [0.9, 0.3, 0.1];
        let passes = 256;
        let coloured = spot_sphere_with_albedo(20.0, albedo);
        let (mean, variance) = mean_and_variance(&coloured, passes);
        for (c, a) in albedo.into_iter().enumerate() {
            let grey = spot_sphere_with_albedo(20.0, [a; 3]);
            let (grey_mean, grey_variance) = mean_and_variance(&grey, passes);
            let z = (mean[c] - grey_mean[c]) / (variance[c] + grey_variance[c]).sqrt();
            assert!(
                z.abs() < 4.0,
                "channel {c}: {} vs grey {}, z = {z}",
                mean[c],
                grey_mean[c]
            );
            // The weights stay bounded: no channel is much noisier than its grey medium
            // (surviving with the channels' mean, red's variance is many times grey 0.9's).
            assert!(
                variance[c] <= 1.5 * grey_variance[c],
                "channel {c}: variance {} vs grey {}",
                variance[c],
                grey_variance[c]
            );
        }
    }

    #[test]
    fn a_state_resumes_to_the_bits_of_one_whole_run() {
        let scene = scene(SPOT_SPHERE);
        let none = Control::none();
        let mut whole = ReferenceAccumulator::new(20, 20);
        whole.add_passes(&scene, 9, &none).unwrap();
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("state.bin");
        let mut resumed = ReferenceAccumulator::new(20, 20);
        for step in [2, 4, 3] {
            resumed.add_passes(&scene, step, &none).unwrap();
            resumed.write_state(&path).unwrap();
            resumed = ReferenceAccumulator::read_state(&path).unwrap();
        }
        assert_eq!(resumed, whole);
        assert_eq!(resumed.film(), whole.film());
        // Through a film the sums come back only to rounding: the reason for the state.
        let mut through_film = ReferenceAccumulator::new(20, 20);
        through_film.add_passes(&scene, 4, &none).unwrap();
        let mut through_film = ReferenceAccumulator::from_film(&through_film.film(), 4).unwrap();
        through_film.add_passes(&scene, 5, &none).unwrap();
        assert_ne!(through_film, whole);
    }

    #[test]
    fn a_damaged_state_is_refused_naming_the_file() {
        let scene = scene(SPOT_SPHERE);
        let mut acc = ReferenceAccumulator::new(20, 20);
        acc.add_passes(&scene, 2, &Control::none()).unwrap();
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("state.bin");
        acc.write_state(&path).unwrap();
        let bytes = std::fs::read(&path).unwrap();
        std::fs::write(&path, &bytes[..bytes.len() - 1]).unwrap();
        let err = ReferenceAccumulator::read_state(&path)
            .unwrap_err()
            .to_string();
        assert!(err.contains("state.bin") && err.contains("20×20"), "{err}");
        std::fs::write(&path, b"P6 not a state").unwrap();
        let err = ReferenceAccumulator::read_state(&path)
            .unwrap_err()
            .to_string();
        assert!(err.contains("not a reference accumulator state"), "{err}");
    }

    #[test]
    fn the_total_variance_survives_a_film_and_a_resume() {
        let scene = scene(SPOT_SPHERE);
        let none = Control::none();
        let mut whole = ReferenceAccumulator::new(20, 20);
        whole.add_passes(&scene, 8, &none).unwrap();
        let mut first = ReferenceAccumulator::new(20, 20);
        first.add_passes(&scene, 5, &none).unwrap();
        // Through an EXR, as the sweep refines a reference in place.
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("reference.exr");
        first.film().write_exr(&path).unwrap();
        let mut resumed =
            ReferenceAccumulator::from_film(&Film::read_exr(&path).unwrap(), 5).unwrap();
        resumed.add_passes(&scene, 3, &none).unwrap();
        let (a, b) = (
            whole.total_variance().unwrap(),
            resumed.total_variance().unwrap(),
        );
        for (x, y) in a.iter().zip(&b) {
            assert!(
                (*x - *y).abs().max_element() <= 1e-5 * x.max_element().max(1e-6),
                "{x} {y}"
            );
        }
        // The total's variance is not the layers' sum: one path feeds both layers.
        let film = whole.film();
        let summed: Vec<Vec3> = (film.variance(Layer::Single).unwrap().iter())
            .zip(film.variance(Layer::Multiple).unwrap())
            .map(|(s, m)| *s + *m)
            .collect();
        assert_ne!(summed, a);
        // Emission is black here, so single + multiple is the total.
        let both = film.variance_of_sum(&[Layer::Single, Layer::Multiple]);
        assert_eq!(both.as_deref(), Some(a.as_slice()));
        // A film without the total's variance (written before it was kept) resumes without.
        let layers_only = Film::from_layers(
            20,
            20,
            std::array::from_fn(|i| film.layer(Layer::ALL[i]).to_vec()),
        )
        .with_variance(std::array::from_fn(|i| {
            film.variance(Layer::ALL[i]).unwrap().to_vec()
        }));
        assert_eq!(
            layers_only.variance_of_sum(&[Layer::Single, Layer::Multiple]),
            Some(summed),
            "without the total's variance: the layers' sum"
        );
        assert!(
            ReferenceAccumulator::from_film(&layers_only, 8)
                .unwrap()
                .total_variance()
                .is_none()
        );
    }
}
