//! The disco-ball artifact metric (thesis §8.1.1, Fig. 12: "bright, fairly large, circular
//! spots" in the multiple-scattering layer).
//!
//! Definition, on the luminance `Y` of the multiple-scattering layer inside the object mask
//! `M` (pixels that received any light):
//!
//! 1. For scales `s = 1.5·√2^k` px up to 1/20 of the image size, the local mean
//!    `A_s = G_s∗(Y·M) / G_s∗M` and the surround `B_s = A_{3s}` (normalised convolution,
//!    so the black background never counts as "darker surroundings").
//! 2. Local contrast `C_s = A_s / B_s − 1`. A pixel is in a blob when `max_s C_s > τ` with
//!    `τ = 0.25`: its neighbourhood at some scale is 25 % brighter than three times that
//!    neighbourhood. Smooth shading, gradients and pixel noise stay below τ; a blob of
//!    contrast `c` above its background reaches `C ≈ c` at its own scale.
//! 3. Blobs are the 4-connected components of those pixels with at least 7 pixels
//!    (π·1.5²).
//! 4. Scores: `energy` = Σ over blob pixels of `(Y − B_{s*})₊` / Σ over the mask of `Y`
//!    (the share of the layer's energy that sits in blobs above their surroundings, `s*`
//!    the pixel's best scale); `blobs` = component count; `area` = blob pixels / mask pixels.
//!
//! Two parameters (`τ`, the scale range) are fixed and documented here; the metric was
//! validated on synthetic images with planted blobs (tests below) before being applied to
//! renders, and is not tuned to agree with the thesis.

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::store::DiscoScore;

/// Contrast threshold τ.
pub(crate) const CONTRAST_THRESHOLD: f32 = 0.25;
/// Smallest blob scale (Gaussian σ, pixels).
pub(crate) const MIN_SCALE: f32 = 1.5;
/// Ratio of surround to centre scale.
pub(crate) const SURROUND_RATIO: f32 = 3.0;

/// A scalar image.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub(crate) struct Gray {
    /// Width.
    pub(crate) width: usize,
    /// Height.
    pub(crate) height: usize,
    /// Row-major values.
    pub(crate) data: Vec<f32>,
}

impl Gray {
    /// A zero image.
    #[cfg(test)]
    pub(crate) fn new(width: usize, height: usize) -> Self {
        Gray {
            width,
            height,
            data: vec![0.0; width * height],
        }
    }
}

/// Separable Gaussian blur with zero padding (radius 3σ).
///
/// Each pass adds one kernel tap at a time to a whole row (`out[x] += k · in[x + offset]`
/// over the pixels the tap reaches), which vectorises; every pixel still sums its taps in
/// the same order, from the first tap it reaches, so the result is bit for bit that of the
/// per-pixel sum (`tests::blur_matches_the_per_pixel_sum`). Rows are blurred in parallel.
/// At 512² the disco score blurs 18 distinct σ up to 72 px, twice each: as a per-pixel sum
/// with a bounds test per tap, a cell's metrics took 2.2–3.2 s (`cost --paper`), now
/// 0.20–0.34 s with the same numbers.
pub(crate) fn gaussian_blur(img: &Gray, sigma: f32) -> Gray {
    let radius = (3.0 * sigma).ceil() as usize;
    let kernel: Vec<f32> = (-(radius as isize)..=radius as isize)
        .map(|i| (-(i * i) as f32 / (2.0 * sigma * sigma)).exp())
        .collect();
    let norm: f32 = kernel.iter().sum();
    let kernel: Vec<f32> = kernel.iter().map(|k| k / norm).collect();
    let (w, h) = (img.width, img.height);
    let mut out = Gray {
        width: w,
        height: h,
        data: vec![0.0f32; img.data.len()],
    };
    if w == 0 || h == 0 {
        return out;
    }
    // Along x: tap `k` reads pixel `x + k − radius` of the same row.
    let mut along_x = vec![0.0f32; img.data.len()];
    along_x
        .par_chunks_mut(w)
        .zip(img.data.par_chunks(w))
        .for_each(|(row, source)| {
            for (k, &kv) in kernel.iter().enumerate() {
                let (lo, hi) = tap_range(k, radius, w);
                if lo == hi {
                    continue;
                }
                for (o, &v) in row[lo..hi].iter_mut().zip(&source[lo + k - radius..]) {
                    *o += kv * v;
                }
            }
        });
    // Along y: tap `k` adds row `y + k − radius`.
    out.data.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
        for (k, &kv) in kernel.iter().enumerate() {
            let Some(yy) = (y + k).checked_sub(radius).filter(|&yy| yy < h) else {
                continue;
            };
            for (o, &v) in row.iter_mut().zip(&along_x[yy * w..(yy + 1) * w]) {
                *o += kv * v;
            }
        }
    });
    out
}

/// The outputs `lo..hi` of an `n`-pixel line that tap `k` of a kernel of `radius` reaches
/// (`0 ≤ x + k − radius < n`); empty where it reaches none.
fn tap_range(k: usize, radius: usize, n: usize) -> (usize, usize) {
    let lo = radius.saturating_sub(k).min(n);
    let hi = (n + radius).saturating_sub(k).min(n).max(lo);
    (lo, hi)
}

/// The blob scales for an image size.
pub(crate) fn scales(width: usize, height: usize) -> Vec<f32> {
    let max = (width.max(height) as f32 / 20.0).max(MIN_SCALE);
    let mut s = MIN_SCALE;
    let mut out = Vec::new();
    while s <= max * 1.0001 {
        out.push(s);
        s *= std::f32::consts::SQRT_2;
    }
    out
}

/// Normalised convolution: the mean of `y` over mask pixels in a Gaussian window.
fn masked_mean(weighted: &Gray, mask: &Gray, sigma: f32) -> (Gray, Gray) {
    (gaussian_blur(weighted, sigma), gaussian_blur(mask, sigma))
}

/// Per pixel, the largest centre/surround contrast over the scales (centre σ, surround
/// σ·[`SURROUND_RATIO`], both means over mask pixels), and the surround it was found with.
fn best_contrast(
    weighted: &Gray,
    mask_img: &Gray,
    mask: &[bool],
    mean_y: f32,
) -> (Vec<f32>, Vec<f32>) {
    let (w, h) = (weighted.width, weighted.height);
    let n = w * h;
    let mut best_contrast = vec![0.0f32; n];
    let mut best_surround = vec![0.0f32; n];
    // The scales step by √2 and the surround is 3×, so no σ is needed twice.
    for s in scales(w, h) {
        let (num_a, den_a) = masked_mean(weighted, mask_img, s);
        let (num_b, den_b) = masked_mean(weighted, mask_img, s * SURROUND_RATIO);
        for i in 0..n {
            if !mask[i] || den_a.data[i] < 1e-3 || den_b.data[i] < 1e-3 {
                continue;
            }
            let a = num_a.data[i] / den_a.data[i];
            let b = num_b.data[i] / den_b.data[i];
            // Surroundings darker than 1 % of the mean layer radiance carry no meaningful
            // contrast (division by ~0).
            if b <= 0.01 * mean_y {
                continue;
            }
            let c = a / b - 1.0;
            if c > best_contrast[i] {
                best_contrast[i] = c;
                best_surround[i] = b;
            }
        }
    }
    (best_contrast, best_surround)
}

/// The 4-connected components of the `true` pixels of a `w × h` image, in scan order.
fn components(in_blob: &[bool], w: usize, h: usize) -> Vec<Vec<usize>> {
    let mut label = vec![false; in_blob.len()];
    let mut out = Vec::new();
    let mut stack = Vec::new();
    for start in 0..in_blob.len() {
        if !in_blob[start] || label[start] {
            continue;
        }
        let mut component = Vec::new();
        label[start] = true;
        stack.push(start);
        while let Some(i) = stack.pop() {
            component.push(i);
            let (x, y) = (i % w, i / w);
            let mut visit = |j: usize| {
                if in_blob[j] && !label[j] {
                    label[j] = true;
                    stack.push(j);
                }
            };
            if x > 0 {
                visit(i - 1);
            }
            if x + 1 < w {
                visit(i + 1);
            }
            if y > 0 {
                visit(i - w);
            }
            if y + 1 < h {
                visit(i + w);
            }
        }
        out.push(component);
    }
    out
}

/// Scores the multiple-scattering luminance `y`; `mask` marks object pixels.
pub(crate) fn disco_score(y: &Gray, mask: &[bool]) -> DiscoScore {
    let (w, h) = (y.width, y.height);
    let mask_img = Gray {
        width: w,
        height: h,
        data: mask.iter().map(|&m| if m { 1.0 } else { 0.0 }).collect(),
    };
    let weighted = Gray {
        width: w,
        height: h,
        data: y
            .data
            .iter()
            .zip(mask)
            .map(|(&v, &m)| if m { v.max(0.0) } else { 0.0 })
            .collect(),
    };
    let total: f64 = weighted.data.iter().map(|&v| v as f64).sum();
    let mask_count = mask.iter().filter(|m| **m).count();
    if total <= 0.0 || mask_count == 0 {
        return DiscoScore::default();
    }
    let mean_y = (total / mask_count as f64) as f32;
    let (best_contrast, best_surround) = best_contrast(&weighted, &mask_img, mask, mean_y);
    let in_blob: Vec<bool> = best_contrast
        .iter()
        .map(|&c| c > CONTRAST_THRESHOLD)
        .collect();
    // Blobs of at least π·1.5² ≈ 7 pixels.
    let min_pixels = (std::f32::consts::PI * MIN_SCALE * MIN_SCALE).ceil() as usize;
    let mut blobs = 0u64;
    let mut blob_pixels = 0usize;
    let mut energy = 0.0f64;
    for component in components(&in_blob, w, h) {
        if component.len() >= min_pixels {
            blobs += 1;
            blob_pixels += component.len();
            for &i in &component {
                energy += (weighted.data[i] - best_surround[i]).max(0.0) as f64;
            }
        }
    }
    DiscoScore {
        energy: energy / total,
        blobs,
        area: blob_pixels as f64 / mask_count as f64,
    }
}

/// The disco score of `y` relative to a reference rendering of the same layer (e.g. the
/// path tracer's multiple-scattering layer): the ratio `y / G_1.5px∗reference` is scored
/// instead of `y`, so structure that is really there (thin bright bone) cancels and only
/// blobs the reference lacks remain. Pixels where the blurred reference is below 5 % of
/// its mean are left out (the ratio is unstable there).
pub(crate) fn relative_disco_score(y: &Gray, reference: &Gray, mask: &[bool]) -> DiscoScore {
    let blurred = gaussian_blur(reference, MIN_SCALE);
    let inside: Vec<f32> = blurred
        .data
        .iter()
        .zip(mask)
        .filter(|(_, m)| **m)
        .map(|(v, _)| *v)
        .collect();
    if inside.is_empty() {
        return DiscoScore::default();
    }
    let mean = inside.iter().map(|&v| v as f64).sum::<f64>() / inside.len() as f64;
    let floor = (0.05 * mean) as f32;
    let mask: Vec<bool> = mask
        .iter()
        .zip(&blurred.data)
        .map(|(&m, &b)| m && b > floor)
        .collect();
    let ratio = Gray {
        width: y.width,
        height: y.height,
        data: y
            .data
            .iter()
            .zip(&blurred.data)
            .zip(&mask)
            .map(|((&v, &b), &m)| if m { v / b } else { 0.0 })
            .collect(),
    };
    disco_score(&ratio, &mask)
}

#[cfg(test)]
mod tests {
    use super::*;
    use volphot::{Domain, Rng};

    const W: usize = 256;

    /// A smooth lit object (disc) with a gradient and a gentle wave, 3 % pixel noise, and
    /// `blobs` Gaussian blobs of σ = `radius` px and peak contrast `contrast`.
    fn synthetic(blobs: &[(f32, f32)], radius: f32, contrast: f32, seed: u64) -> (Gray, Vec<bool>) {
        let mut img = Gray::new(W, W);
        let mut mask = vec![false; W * W];
        let mut rng = Rng::stream(seed, Domain::Misc, 0);
        let c = W as f32 / 2.0;
        for y in 0..W {
            for x in 0..W {
                let (fx, fy) = (x as f32 + 0.5, y as f32 + 0.5);
                if ((fx - c).powi(2) + (fy - c).powi(2)).sqrt() > 0.45 * W as f32 {
                    continue;
                }
                let i = y * W + x;
                mask[i] = true;
                let background =
                    1.0 + 0.6 * fx / W as f32 + 0.3 * (fy / W as f32 * std::f32::consts::TAU).sin();
                let mut v = background;
                for &(bx, by) in blobs {
                    let d2 = (fx - bx).powi(2) + (fy - by).powi(2);
                    v += contrast * background * (-d2 / (2.0 * radius * radius)).exp();
                }
                // Box–Muller noise.
                let [u1, u2] = rng.uniform2();
                let g = (-2.0 * (1.0 - u1).ln()).sqrt() * (std::f32::consts::TAU * u2).cos();
                img.data[i] = v * (1.0 + 0.03 * g);
            }
        }
        (img, mask)
    }

    const SIX: [(f32, f32); 6] = [
        (70.0, 80.0),
        (128.0, 60.0),
        (185.0, 90.0),
        (80.0, 170.0),
        (140.0, 150.0),
        (180.0, 190.0),
    ];

    #[test]
    fn blob_free_image_scores_about_zero() {
        let (img, mask) = synthetic(&[], 5.0, 0.0, 1);
        let s = disco_score(&img, &mask);
        assert_eq!(s.blobs, 0, "{s:?}");
        assert!(s.energy < 0.002 && s.area < 0.002, "{s:?}");
    }

    #[test]
    fn planted_blobs_are_found_at_several_sizes() {
        for radius in [3.0f32, 6.0, 10.0] {
            let (img, mask) = synthetic(&SIX, radius, 1.0, 2);
            let s = disco_score(&img, &mask);
            assert_eq!(s.blobs, 6, "radius {radius}: {s:?}");
            assert!(s.energy > 0.001, "radius {radius}: {s:?}");
        }
    }

    #[test]
    fn score_is_monotone_in_contrast() {
        // Non-decreasing over all contrasts; strictly increasing once blobs are detected.
        let mut last = -1.0;
        for contrast in [0.1f32, 0.3, 0.6, 1.0, 1.5, 2.4, 4.0] {
            let (img, mask) = synthetic(&SIX, 6.0, contrast, 3);
            let s = disco_score(&img, &mask);
            if contrast >= 0.6 {
                assert!(
                    s.energy > last,
                    "contrast {contrast}: {} after {last}",
                    s.energy
                );
            } else {
                assert!(
                    s.energy >= last.max(0.0),
                    "contrast {contrast}: {} after {last}",
                    s.energy
                );
            }
            last = s.energy;
        }
        // Weak blobs (10 %) stay below the threshold.
        let (img, mask) = synthetic(&SIX, 6.0, 0.1, 3);
        assert_eq!(disco_score(&img, &mask).blobs, 0);
    }

    /// A background with real bright structures (four Gaussian bumps of contrast 1): the
    /// plain score counts them; scored relative to a reference that has them too, only
    /// planted artifacts count.
    #[test]
    fn relative_score_ignores_structure_the_reference_has() {
        let bumps = [
            (60.0f32, 130.0f32),
            (128.0, 200.0),
            (200.0, 140.0),
            (128.0, 110.0),
        ];
        let (reference, mask) = synthetic(&bumps, 6.0, 1.0, 11);
        let (clean, _) = synthetic(&bumps, 6.0, 1.0, 12);
        let plain = disco_score(&clean, &mask);
        assert!(
            plain.blobs >= 3,
            "the plain score sees the real bumps: {plain:?}"
        );
        let rel = relative_disco_score(&clean, &reference, &mask);
        assert_eq!(rel.blobs, 0, "{rel:?}");
        assert!(rel.energy < 0.002, "{rel:?}");
        // Plant artifacts on top of the structured image.
        let mut with = clean.clone();
        let (artifacts, _) = synthetic(&SIX, 5.0, 1.2, 12);
        let (plain_bg, _) = synthetic(&[], 5.0, 0.0, 12);
        for i in 0..with.data.len() {
            if plain_bg.data[i] > 0.0 {
                with.data[i] *= artifacts.data[i] / plain_bg.data[i];
            }
        }
        let rel = relative_disco_score(&with, &reference, &mask);
        assert_eq!(rel.blobs, 6, "{rel:?}");
        assert!(rel.energy > 0.005, "{rel:?}");
    }

    /// The blur as first written: each pixel sums its taps in order, skipping those off
    /// the image.
    fn blur_per_pixel(img: &Gray, sigma: f32) -> Gray {
        let radius = (3.0 * sigma).ceil() as isize;
        let kernel: Vec<f32> = (-radius..=radius)
            .map(|i| (-(i * i) as f32 / (2.0 * sigma * sigma)).exp())
            .collect();
        let norm: f32 = kernel.iter().sum();
        let kernel: Vec<f32> = kernel.iter().map(|k| k / norm).collect();
        let (w, h) = (img.width as isize, img.height as isize);
        let pass = |source: &[f32], step: (isize, isize)| {
            let mut out = vec![0.0f32; source.len()];
            for y in 0..h {
                for x in 0..w {
                    let mut acc = 0.0;
                    for (k, &kv) in kernel.iter().enumerate() {
                        let (xx, yy) = (
                            x + step.0 * (k as isize - radius),
                            y + step.1 * (k as isize - radius),
                        );
                        if (0..w).contains(&xx) && (0..h).contains(&yy) {
                            acc += kv * source[(yy * w + xx) as usize];
                        }
                    }
                    out[(y * w + x) as usize] = acc;
                }
            }
            out
        };
        let along_x = pass(&img.data, (1, 0));
        Gray {
            width: img.width,
            height: img.height,
            data: pass(&along_x, (0, 1)),
        }
    }

    #[test]
    fn blur_matches_the_per_pixel_sum() {
        // Odd sizes, and kernels wider than the image (σ 72: radius 216).
        let mut rng = Rng::stream(5, Domain::Misc, 0);
        for (w, h) in [(37, 23), (1, 9), (64, 64)] {
            let mut img = Gray::new(w, h);
            for v in &mut img.data {
                *v = rng.uniform() * 10.0;
            }
            for sigma in [0.5f32, 1.5, 4.24, 12.0, 72.0] {
                let fast = gaussian_blur(&img, sigma);
                let slow = blur_per_pixel(&img, sigma);
                let same = fast
                    .data
                    .iter()
                    .zip(&slow.data)
                    .all(|(a, b)| a.to_bits() == b.to_bits());
                assert!(same, "{w}×{h}, σ {sigma}");
            }
        }
    }

    #[test]
    fn blur_preserves_mass_away_from_borders() {
        let mut img = Gray::new(64, 64);
        img.data[32 * 64 + 32] = 1.0;
        let b = gaussian_blur(&img, 3.0);
        let sum: f32 = b.data.iter().sum();
        assert!((sum - 1.0).abs() < 1e-4);
    }
}
