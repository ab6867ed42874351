//! Image statistics and errors against a reference.
//!
//! RMSE and relative MSE are computed on linear radiance; SSIM (image-compare's MSSIM on the
//! luma of the tone-mapped images) and FLIP (NVIDIA's perceptual error via `nv-flip`) on the
//! tone-mapped sRGB images, as a viewer would see them.

use std::time::Instant;

use glam::Vec3;
use volphot::film::{Film, Layer, to_srgb8};

use crate::cells::{DiscoScore, ReferenceMetrics};
use crate::disco::{Gray, disco_score};

/// Luminance (Rec. 709).
pub fn luminance(v: Vec3) -> f32 {
    0.2126 * v.x + 0.7152 * v.y + 0.0722 * v.z
}

/// The layers a cell displays: single (+ multiple when rendered) (+ emission when rendered).
pub fn displayed(film: &Film, multiple: bool, emission: bool) -> Vec<Vec3> {
    let mut layers = vec![Layer::Single];
    if multiple {
        layers.push(Layer::Multiple);
    }
    if emission {
        layers.push(Layer::Emission);
    }
    film.combine(&layers)
}

/// The disco-ball score of a film's multiple layer; the object mask is every pixel that
/// received any light.
pub fn disco(film: &Film) -> DiscoScore {
    let total = film.total();
    let mask: Vec<bool> = total.iter().map(|v| luminance(*v) > 0.0).collect();
    let y = Gray {
        width: film.width(),
        height: film.height(),
        data: film
            .layer(Layer::Multiple)
            .iter()
            .map(|v| luminance(*v))
            .collect(),
    };
    disco_score(&y, &mask)
}

/// Errors of `image` against `reference` (linear RGB, same size).
pub fn compare(
    image: &[Vec3],
    reference: &[Vec3],
    width: usize,
    height: usize,
    exposure: f32,
    reference_key: &str,
) -> ReferenceMetrics {
    let start = Instant::now();
    let n = image.len() as f64;
    let mut se = 0.0f64;
    let mean_ref = volphot::film::mean_rgb(reference);
    let eps = 0.01 * mean_ref * mean_ref;
    let mut rel = 0.0f64;
    for (a, b) in image.iter().zip(reference) {
        for c in 0..3 {
            let d = (a[c] - b[c]) as f64;
            se += d * d;
            rel += d * d / ((b[c] as f64).powi(2) + eps);
        }
    }
    let rmse = (se / (3.0 * n)).sqrt();
    let rel_mse = rel / (3.0 * n);
    let a8 = to_srgb8(image, exposure);
    let b8 = to_srgb8(reference, exposure);
    let ssim = ssim(&a8, &b8, width as u32, height as u32);
    let flip = flip(&a8, &b8, width as u32, height as u32);
    ReferenceMetrics {
        reference: reference_key.to_string(),
        rmse,
        rel_mse,
        ssim,
        flip,
        seconds: start.elapsed().as_secs_f64(),
    }
}

/// SSIM of two sRGB8 images (luma, image-compare's MSSIM with 8×8 windows; 1 = identical).
pub fn ssim(a: &[u8], b: &[u8], width: u32, height: u32) -> f64 {
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
pub fn flip(a: &[u8], b: &[u8], width: u32, height: u32) -> f64 {
    let reference = nv_flip::FlipImageRgb8::with_data(width, height, b);
    let test = nv_flip::FlipImageRgb8::with_data(width, height, a);
    let error = nv_flip::flip(reference, test, nv_flip::DEFAULT_PIXELS_PER_DEGREE);
    nv_flip::FlipPool::from_image(&error).mean() as f64
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn identical_images_have_zero_error() {
        let img: Vec<Vec3> = (0..64 * 64)
            .map(|i| Vec3::splat((i % 64) as f32 / 64.0))
            .collect();
        let m = compare(&img, &img, 64, 64, 0.0, "r");
        assert_eq!(m.rmse, 0.0);
        assert_eq!(m.rel_mse, 0.0);
        assert!((m.ssim - 1.0).abs() < 1e-9, "{}", m.ssim);
        assert!(m.flip.abs() < 1e-6, "{}", m.flip);
    }

    #[test]
    fn errors_grow_with_the_difference() {
        let img: Vec<Vec3> = (0..64 * 64)
            .map(|i| Vec3::splat(0.2 + (i % 64) as f32 / 128.0))
            .collect();
        let small: Vec<Vec3> = img.iter().map(|v| *v * 1.05).collect();
        let large: Vec<Vec3> = img.iter().map(|v| *v * 1.5).collect();
        let s = compare(&small, &img, 64, 64, 0.0, "r");
        let l = compare(&large, &img, 64, 64, 0.0, "r");
        assert!(l.rmse > s.rmse && l.rel_mse > s.rel_mse && l.flip > s.flip && l.ssim <= s.ssim);
        assert!((s.rmse - 0.05 * volphot::film::mean_rgb(&img)).abs() < 0.01);
    }
}
