//! Image statistics and errors against a reference.
//!
//! RMSE and relative MSE are computed on linear radiance; SSIM (image-compare's MSSIM on the
//! luma of the tone-mapped images) and FLIP (NVIDIA's perceptual error via `nv-flip`) on the
//! tone-mapped sRGB images, as a viewer would see them.

use std::time::Instant;

use glam::Vec3;
use volphot::{Film, Layer, to_srgb8};

use super::agreement::mse_against_noisy_reference;
use super::disco::{Gray, disco_score, gaussian_blur, relative_disco_score};
use crate::store::{
    DiscoScore, IMAGE_STATS_VERSION, ImageStats, REFERENCE_METRICS_VERSION, ReferenceMetrics,
};

/// Luminance (Rec. 709), the one core's [`agreement`](volphot::agreement) weighs by.
pub(crate) use volphot::luminance;

/// The layers a cell displays: single (+ multiple when rendered) (+ emission when rendered).
pub(crate) fn displayed(film: &Film, multiple: bool, emission: bool) -> Vec<Vec3> {
    film.combine(&Layer::shown(multiple, emission))
}

/// Luminance of a film's multiple-scattering layer, where disco balls live.
fn multiple_luminance(film: &Film) -> Gray {
    Gray {
        width: film.width(),
        height: film.height(),
        data: film
            .layer(Layer::Multiple)
            .iter()
            .map(|v| luminance(*v))
            .collect(),
    }
}

/// The object: every pixel that received any light.
fn lit_mask(film: &Film) -> Vec<bool> {
    film.total().iter().map(|v| luminance(*v) > 0.0).collect()
}

/// The disco-ball score of a film's multiple layer over the object ([`lit_mask`]).
pub(crate) fn disco(film: &Film) -> DiscoScore {
    disco_score(&multiple_luminance(film), &lit_mask(film))
}

/// Tone-mapped luminance in [0, 1] (sRGB encoding of each channel, then Rec. 709 weights).
fn display_luminance(pixels: &[Vec3], exposure: f32) -> Vec<f32> {
    srgb8_luminance(&to_srgb8(pixels, exposure))
}

/// Rec. 709 luminance in [0, 1] of 8-bit sRGB triples.
fn srgb8_luminance(rgb: &[u8]) -> Vec<f32> {
    rgb.chunks_exact(3)
        .map(|c| (0.2126 * c[0] as f32 + 0.7152 * c[1] as f32 + 0.0722 * c[2] as f32) / 255.0)
        .collect()
}

fn sobel_mean(l: &[f32], w: usize, h: usize, mask: &[bool]) -> f64 {
    let at = |x: usize, y: usize| l[y * w + x];
    let (mut sum, mut n) = (0.0f64, 0usize);
    for y in 1..h.saturating_sub(1) {
        for x in 1..w.saturating_sub(1) {
            if !mask[y * w + x] {
                continue;
            }
            let gx = at(x + 1, y - 1) + 2.0 * at(x + 1, y) + at(x + 1, y + 1)
                - at(x - 1, y - 1)
                - 2.0 * at(x - 1, y)
                - at(x - 1, y + 1);
            let gy = at(x - 1, y + 1) + 2.0 * at(x, y + 1) + at(x + 1, y + 1)
                - at(x - 1, y - 1)
                - 2.0 * at(x, y - 1)
                - at(x + 1, y - 1);
            sum += ((gx * gx + gy * gy).sqrt() / 8.0) as f64;
            n += 1;
        }
    }
    if n == 0 { 0.0 } else { sum / n as f64 }
}

fn detail_mean(l: &[f32], w: usize, h: usize, mask: &[bool]) -> f64 {
    let img = Gray {
        width: w,
        height: h,
        data: l.to_vec(),
    };
    let blurred = gaussian_blur(&img, 2.0);
    let (mut sum, mut n) = (0.0f64, 0usize);
    for i in 0..l.len() {
        if mask[i] {
            sum += (l[i] - blurred.data[i]).abs() as f64;
            n += 1;
        }
    }
    if n == 0 { 0.0 } else { sum / n as f64 }
}

fn correlation(a: &[f32], b: &[f32], mask: &[bool]) -> f64 {
    let pairs: Vec<(f64, f64)> = a
        .iter()
        .zip(b)
        .zip(mask)
        .filter(|((_, d), m)| **m && d.is_finite())
        .map(|((x, y), _)| (*x as f64, *y as f64))
        .collect();
    let n = pairs.len() as f64;
    if n < 3.0 {
        return 0.0;
    }
    let (mx, my) = (
        pairs.iter().map(|p| p.0).sum::<f64>() / n,
        pairs.iter().map(|p| p.1).sum::<f64>() / n,
    );
    let (mut sxy, mut sxx, mut syy) = (0.0, 0.0, 0.0);
    for (x, y) in &pairs {
        sxy += (x - mx) * (y - my);
        sxx += (x - mx) * (x - mx);
        syy += (y - my) * (y - my);
    }
    if sxx <= 0.0 || syy <= 0.0 {
        0.0
    } else {
        sxy / (sxx * syy).sqrt()
    }
}

/// Detail, lit regions and depth cues of the single-scattering layer vs the displayed
/// image (see [`ImageStats`]).
pub(crate) fn image_stats(film: &Film, shown: &[Vec3], exposure: f32) -> ImageStats {
    let (w, h) = (film.width(), film.height());
    let single = display_luminance(film.layer(Layer::Single), exposure);
    let shown8 = to_srgb8(shown, exposure);
    let total = srgb8_luminance(&shown8);
    let mask: Vec<bool> = shown.iter().map(|v| luminance(*v) > 0.0).collect();
    let object = mask.iter().filter(|m| **m).count().max(1) as f64;
    let lit = single
        .iter()
        .zip(&total)
        .zip(&mask)
        .filter(|((s, t), m)| **m && **s < 0.05 && **t >= 0.05)
        .count() as f64;
    let depth: Vec<f32> = film
        .depth()
        .map(<[f32]>::to_vec)
        .unwrap_or_else(|| vec![f32::INFINITY; w * h]);
    let clipped = shown8
        .chunks_exact(3)
        .zip(&mask)
        .filter(|(c, m)| **m && c.iter().any(|&v| v >= 254))
        .count() as f64;
    let opaque = depth
        .iter()
        .zip(&mask)
        .filter(|(d, m)| **m && d.is_finite())
        .count() as f64;
    let mean = |l: &[f32]| {
        l.iter()
            .zip(&mask)
            .filter(|(_, m)| **m)
            .map(|(v, _)| *v as f64)
            .sum::<f64>()
            / object
    };
    ImageStats {
        version: IMAGE_STATS_VERSION,
        luma_single: mean(&single),
        luma_total: mean(&total),
        gradient_single: sobel_mean(&single, w, h, &mask),
        gradient_total: sobel_mean(&total, w, h, &mask),
        detail_single: detail_mean(&single, w, h, &mask),
        detail_total: detail_mean(&total, w, h, &mask),
        lit_by_multiple: lit / object,
        depth_corr_single: correlation(&single, &depth, &mask),
        depth_corr_total: correlation(&total, &depth, &mask),
        clipped_total: clipped / object,
        opaque_share: opaque / object,
    }
}

/// The disco score of a film's multiple layer relative to a reference film's.
pub(crate) fn disco_excess(film: &Film, reference: &Film) -> DiscoScore {
    relative_disco_score(
        &multiple_luminance(film),
        &multiple_luminance(reference),
        &lit_mask(film),
    )
}

/// Errors of `image` against `reference` (linear RGB, same size); with the per-pixel
/// variance of the reference's mean, also the RMSE with the reference's own noise removed.
pub(crate) fn compare(
    image: &[Vec3],
    reference: &[Vec3],
    reference_variance: Option<&[Vec3]>,
    size: [usize; 2],
    exposure: f32,
    reference_key: &str,
) -> ReferenceMetrics {
    let [width, height] = size;
    let start = Instant::now();
    let n = image.len() as f64;
    let mean_ref = volphot::mean_rgb(reference);
    let eps = 0.01 * mean_ref * mean_ref;
    let mut rel = 0.0f64;
    for (a, b) in image.iter().zip(reference) {
        for c in 0..3 {
            let d = (a[c] - b[c]) as f64;
            rel += d * d / ((b[c] as f64).powi(2) + eps);
        }
    }
    // The same RMSE a progressive render stops on (`integrator.target_rmse`).
    let rmse = volphot::rmse(image, reference);
    // A noisy reference adds its variance to every squared difference (see
    // `mse_against_noisy_reference`); what remains is the image's own error. Below 0 the
    // image is within the reference's noise.
    let rmse_corrected = reference_variance.map(|var| {
        mse_against_noisy_reference(image, reference, var)
            .max(0.0)
            .sqrt()
    });
    let rel_mse = rel / (3.0 * n);
    let a8 = to_srgb8(image, exposure);
    let b8 = to_srgb8(reference, exposure);
    let ssim = ssim(&a8, &b8, width as u32, height as u32);
    let flip = flip(&a8, &b8, width as u32, height as u32);
    ReferenceMetrics {
        version: REFERENCE_METRICS_VERSION,
        reference: reference_key.to_string(),
        reference_passes: 0,
        rmse,
        rmse_corrected,
        rel_mse,
        ssim,
        flip,
        disco_excess: 0.0,
        disco_excess_blobs: 0,
        seconds: start.elapsed().as_secs_f64(),
    }
}

/// SSIM of two sRGB8 images (luma, image-compare's MSSIM with 8×8 windows; 1 = identical).
pub(crate) fn ssim(a: &[u8], b: &[u8], width: u32, height: u32) -> f64 {
    let to_gray = |rgb: &[u8]| {
        let img = image::RgbImage::from_raw(width, height, rgb.to_vec()).expect("image size");
        image::imageops::grayscale(&img)
    };
    image_compare::gray_similarity_structure(
        &image_compare::Algorithm::MSSIMSimple,
        &to_gray(a),
        &to_gray(b),
    )
    .map(|s| s.score)
    .unwrap_or(f64::NAN)
}

/// Mean FLIP error of two sRGB8 images at the default 67 pixels per degree (0 = identical).
pub(crate) fn flip(a: &[u8], b: &[u8], width: u32, height: u32) -> f64 {
    nv_flip::FlipPool::from_image(&flip_image(a, b, width, height)).mean() as f64
}

/// The per-pixel FLIP error of `a` against the reference `b` (sRGB8, row-major, in [0, 1]);
/// its mean is [`flip`].
pub(crate) fn flip_map(a: &[u8], b: &[u8], width: u32, height: u32) -> Vec<f32> {
    flip_image(a, b, width, height).to_vec()
}

fn flip_image(a: &[u8], b: &[u8], width: u32, height: u32) -> nv_flip::FlipImageFloat {
    let reference = nv_flip::FlipImageRgb8::with_data(width, height, b);
    let test = nv_flip::FlipImageRgb8::with_data(width, height, a);
    nv_flip::flip(reference, test, nv_flip::DEFAULT_PIXELS_PER_DEGREE)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn identical_images_have_zero_error() {
        let img: Vec<Vec3> = (0..64 * 64)
            .map(|i| Vec3::splat((i % 64) as f32 / 64.0))
            .collect();
        let m = compare(&img, &img, None, [64, 64], 0.0, "r");
        assert_eq!(m.rmse, 0.0);
        assert_eq!(m.rel_mse, 0.0);
        assert!((m.ssim - 1.0).abs() < 1e-9, "{}", m.ssim);
        assert!(m.flip.abs() < 1e-6, "{}", m.flip);
    }

    #[test]
    fn image_stats_see_detail_light_and_depth() {
        // A ramp in depth that gets darker with distance; multiple scattering lights a
        // region that single scattering leaves dark.
        let (w, h) = (32, 32);
        let mut film = Film::new(w, h);
        let mut depth = vec![f32::INFINITY; w * h];
        for y in 0..h {
            for x in 0..w {
                let d = 1.0 + x as f32 / w as f32;
                depth[y * w + x] = d;
                let single = if y < 8 { 0.0 } else { 0.6 / d };
                film.set(Layer::Single, x, y, Vec3::splat(single));
                film.set(Layer::Multiple, x, y, Vec3::splat(0.1));
            }
        }
        let film = film.with_depth(depth);
        let shown = displayed(&film, true, false);
        let s = image_stats(&film, &shown, 0.0);
        assert!((s.lit_by_multiple - 8.0 / 32.0).abs() < 1e-9, "{s:?}");
        assert!(
            s.depth_corr_total < s.depth_corr_single && s.depth_corr_single < 0.0,
            "{s:?}"
        );
        assert!(s.gradient_single > 0.0 && s.detail_single > 0.0);
        assert_eq!(s.version, IMAGE_STATS_VERSION);
        // The uniform multiple layer brightens without adding structure.
        assert!(s.luma_total > s.luma_single && s.luma_single > 0.0, "{s:?}");
    }

    #[test]
    fn uniform_brightening_lowers_relative_contrast() {
        // A checkerboard plus a constant: absolute detail stays (almost) the same after
        // tone mapping compresses it a little, but contrast relative to luminance falls.
        let (w, h) = (32, 32);
        let mut film = Film::new(w, h);
        for y in 0..h {
            for x in 0..w {
                let v = if (x + y) % 2 == 0 { 0.05 } else { 0.15 };
                film.set(Layer::Single, x, y, Vec3::splat(v));
                film.set(Layer::Multiple, x, y, Vec3::splat(0.3));
            }
        }
        let s = image_stats(&film, &displayed(&film, true, false), 0.0);
        let single = s.detail_single / s.luma_single;
        let total = s.detail_total / s.luma_total;
        assert!(total < 0.6 * single, "{single} vs {total}");
    }

    #[test]
    fn errors_grow_with_the_difference() {
        let img: Vec<Vec3> = (0..64 * 64)
            .map(|i| Vec3::splat(0.2 + (i % 64) as f32 / 128.0))
            .collect();
        let small: Vec<Vec3> = img.iter().map(|v| *v * 1.05).collect();
        let large: Vec<Vec3> = img.iter().map(|v| *v * 1.5).collect();
        let s = compare(&small, &img, None, [64, 64], 0.0, "r");
        let l = compare(&large, &img, None, [64, 64], 0.0, "r");
        assert!(l.rmse > s.rmse && l.rel_mse > s.rel_mse && l.flip > s.flip && l.ssim <= s.ssim);
        assert!((s.rmse - 0.05 * volphot::mean_rgb(&img)).abs() < 0.01);
    }
}
