//! HDR film with separate layers — single scattering, multiple scattering, emission — from
//! one render pass, so that "single only" and "single + multiple" share every random
//! decision and differ by exactly the multiple-scattering layer.
//!
//! Files: OpenEXR (32-bit float, every layer as `single.R` …, plus `total`, and the per-pixel
//! variance of the mean when known), PNG (exposure + sRGB) and PFM (total, linear).
//!
//! ```
//! use glam::Vec3;
//! use volphot::{Film, Layer};
//! let mut film = Film::new(2, 1);
//! film.set(Layer::Single, 0, 0, Vec3::splat(0.5));
//! film.set(Layer::Multiple, 0, 0, Vec3::splat(0.25));
//! assert_eq!(film.total_at(0, 0), Vec3::splat(0.75));
//! ```

mod agreement;
mod io;

use glam::Vec3;
use serde::{Deserialize, Serialize};

pub use crate::util::{read_pfm, write_pfm};
pub use agreement::{Agreement, agreement, luminance};
pub use io::{to_srgb8, write_png, write_png_rgb8};

/// One of the film's radiance layers.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Layer {
    /// Light scattered once (direct lighting).
    Single,
    /// Light scattered more than once (photon map).
    Multiple,
    /// Emission seen directly.
    Emission,
}

impl Layer {
    /// All layers in file order.
    pub const ALL: [Layer; 3] = [Layer::Single, Layer::Multiple, Layer::Emission];

    /// Lowercase name used in files.
    pub fn name(self) -> &'static str {
        match self {
            Layer::Single => "single",
            Layer::Multiple => "multiple",
            Layer::Emission => "emission",
        }
    }

    fn index(self) -> usize {
        self as usize
    }

    /// The layers an image of a render shows: single scattering, plus multiple
    /// scattering and emission when they were rendered.
    pub fn shown(multiple: bool, emission: bool) -> Vec<Layer> {
        let mut layers = vec![Layer::Single];
        if multiple {
            layers.push(Layer::Multiple);
        }
        if emission {
            layers.push(Layer::Emission);
        }
        layers
    }
}

/// An HDR image with three radiance layers (and optional variance layers).
#[derive(Debug, Clone, PartialEq)]
pub struct Film {
    width: usize,
    height: usize,
    layers: [Vec<Vec3>; 3],
    variance: Option<[Vec<Vec3>; 3]>,
    /// Variance of the mean of the layers' sum, when known: not the sum of the layers'
    /// variances, because one path feeds several layers.
    total_variance: Option<Vec<Vec3>>,
    depth: Option<Vec<f32>>,
}

impl Film {
    /// A black film.
    pub fn new(width: usize, height: usize) -> Self {
        let n = width * height;
        Film {
            width,
            height,
            layers: [
                vec![Vec3::ZERO; n],
                vec![Vec3::ZERO; n],
                vec![Vec3::ZERO; n],
            ],
            variance: None,
            total_variance: None,
            depth: None,
        }
    }

    /// A film from layer data (row-major, top row first).
    pub fn from_layers(width: usize, height: usize, layers: [Vec<Vec3>; 3]) -> Self {
        assert!(
            layers.iter().all(|l| l.len() == width * height),
            "layer size"
        );
        Film {
            width,
            height,
            layers,
            variance: None,
            total_variance: None,
            depth: None,
        }
    }

    /// Attaches per-pixel variance of the mean for every layer.
    pub fn with_variance(mut self, variance: [Vec<Vec3>; 3]) -> Self {
        assert!(variance.iter().all(|l| l.len() == self.width * self.height));
        self.variance = Some(variance);
        self
    }

    /// Attaches the per-pixel variance of the mean of the layers' sum.
    pub fn with_total_variance(mut self, variance: Vec<Vec3>) -> Self {
        assert_eq!(variance.len(), self.width * self.height);
        self.total_variance = Some(variance);
        self
    }

    /// Attaches a depth layer: per pixel, the distance from the eye at which the eye
    /// transmittance fell below ½ (the visible surface), averaged over the pixel's samples
    /// that reached it; `+∞` where none did.
    pub fn with_depth(mut self, depth: Vec<f32>) -> Self {
        assert_eq!(depth.len(), self.width * self.height);
        self.depth = Some(depth);
        self
    }

    /// The depth layer, when rendered.
    pub fn depth(&self) -> Option<&[f32]> {
        self.depth.as_deref()
    }

    /// Width in pixels.
    pub fn width(&self) -> usize {
        self.width
    }

    /// Height in pixels.
    pub fn height(&self) -> usize {
        self.height
    }

    /// One layer's pixels.
    pub fn layer(&self, layer: Layer) -> &[Vec3] {
        &self.layers[layer.index()]
    }

    /// Mutable access to one layer.
    pub fn layer_mut(&mut self, layer: Layer) -> &mut [Vec3] {
        &mut self.layers[layer.index()]
    }

    /// Replaces one layer.
    pub fn set_layer(&mut self, layer: Layer, data: Vec<Vec3>) {
        assert_eq!(data.len(), self.width * self.height);
        self.layers[layer.index()] = data;
    }

    /// Variance layers, when known.
    pub fn variance(&self, layer: Layer) -> Option<&[Vec3]> {
        self.variance.as_ref().map(|v| v[layer.index()].as_slice())
    }

    /// Variance of the total's mean, when known.
    pub fn total_variance(&self) -> Option<&[Vec3]> {
        self.total_variance.as_deref()
    }

    /// Per-pixel variance of the mean of the sum of `layers`: the noise a comparison
    /// against this film as a reference should discount. Exact when the
    /// film knows its total's variance and every layer left out is black; otherwise the
    /// sum of the layers' variances, which leaves out their covariance (layers fed by one
    /// path are positively correlated in the path tracer, so the sum is then a lower
    /// bound). `None` without variance layers.
    pub fn variance_of_sum(&self, layers: &[Layer]) -> Option<Vec<Vec3>> {
        let left_out_black = Layer::ALL
            .iter()
            .filter(|l| !layers.contains(l))
            .all(|&l| self.layer(l).iter().all(|v| *v == Vec3::ZERO));
        if let Some(total) = &self.total_variance
            && left_out_black
        {
            return Some(total.clone());
        }
        let variance = self.variance.as_ref()?;
        let mut sum = vec![Vec3::ZERO; self.width * self.height];
        for &layer in layers {
            for (s, v) in sum.iter_mut().zip(&variance[layer.index()]) {
                *s += *v;
            }
        }
        Some(sum)
    }

    /// Sets one pixel of a layer.
    pub fn set(&mut self, layer: Layer, x: usize, y: usize, value: Vec3) {
        let i = y * self.width + x;
        self.layers[layer.index()][i] = value;
    }

    /// The sum of all layers at a pixel.
    pub fn total_at(&self, x: usize, y: usize) -> Vec3 {
        let i = y * self.width + x;
        self.layers.iter().map(|l| l[i]).sum()
    }

    /// The sum of all layers.
    pub fn total(&self) -> Vec<Vec3> {
        (0..self.width * self.height)
            .map(|i| self.layers[0][i] + self.layers[1][i] + self.layers[2][i])
            .collect()
    }

    /// The image with only the chosen layers summed (e.g. single only).
    pub fn combine(&self, layers: &[Layer]) -> Vec<Vec3> {
        (0..self.width * self.height)
            .map(|i| layers.iter().map(|l| self.layers[l.index()][i]).sum())
            .collect()
    }

    /// Mean radiance of a layer (RGB mean over pixels).
    pub fn mean(&self, layer: Layer) -> f64 {
        mean_rgb(self.layer(layer))
    }

    /// Whether every value is finite (renders must never produce NaN or ∞).
    pub fn is_finite(&self) -> bool {
        self.layers.iter().all(|l| l.iter().all(|v| v.is_finite()))
    }

    /// Each layer that holds infinite or NaN pixels, with how many.
    pub fn non_finite_pixels(&self) -> Vec<(Layer, usize)> {
        Layer::ALL
            .iter()
            .map(|&l| (l, self.layer(l).iter().filter(|v| !v.is_finite()).count()))
            .filter(|(_, n)| *n > 0)
            .collect()
    }
}

/// Root-mean-square difference over all RGB components of two equally sized images (the
/// sweep's `rmse` metric, and a progressive render's stopping error).
pub fn rmse(image: &[Vec3], reference: &[Vec3]) -> f64 {
    if image.is_empty() {
        return 0.0;
    }
    let mut se = 0.0f64;
    for (a, b) in image.iter().zip(reference) {
        for c in 0..3 {
            let d = (a[c] - b[c]) as f64;
            se += d * d;
        }
    }
    (se / (3.0 * image.len() as f64)).sqrt()
}

/// Mean of all RGB components.
pub fn mean_rgb(pixels: &[Vec3]) -> f64 {
    if pixels.is_empty() {
        return 0.0;
    }
    pixels
        .iter()
        .map(|v| (v.x as f64 + v.y as f64 + v.z as f64) / 3.0)
        .sum::<f64>()
        / pixels.len() as f64
}
