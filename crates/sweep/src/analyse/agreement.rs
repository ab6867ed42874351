//! How closely one image follows another: for speed-ups that claim to be exact (the bench),
//! and for peers that render the same scene (the Mitsuba harness).

use glam::Vec3;

use super::luminance;

/// Pixels darker than this fraction of the reference's mean luminance are left out of the
/// per-pixel relative errors (their relative error is noise over nothing).
const DARK_FRACTION: f64 = 0.01;

/// Agreement of an image with a reference image.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub(crate) struct Agreement {
    /// Mean luminance ratio − 1.
    pub(crate) mean: f64,
    /// Median of the per-pixel relative luminance error.
    pub(crate) p50: f64,
    /// 99th percentile of the per-pixel relative luminance error.
    pub(crate) p99: f64,
    /// Pixels compared (those at least 1 % of the reference's mean luminance).
    pub(crate) pixels: usize,
}

/// The agreement of `image` with `reference` (`None` when the reference is black).
pub(crate) fn agreement(image: &[Vec3], reference: &[Vec3]) -> Option<Agreement> {
    let lum = |v: &Vec3| luminance(*v) as f64;
    let total_ref: f64 = reference.iter().map(lum).sum();
    let total_img: f64 = image.iter().map(lum).sum();
    if total_ref <= 0.0 {
        return None;
    }
    let floor = DARK_FRACTION * total_ref / reference.len() as f64;
    let mut errors: Vec<f64> = image
        .iter()
        .zip(reference)
        .filter(|(_, r)| lum(r) >= floor)
        .map(|(i, r)| ((lum(i) - lum(r)) / lum(r)).abs())
        .collect();
    errors.sort_by(f64::total_cmp);
    let quantile = |q: f64| errors[((errors.len() - 1) as f64 * q).round() as usize];
    Some(Agreement {
        mean: total_img / total_ref - 1.0,
        p50: quantile(0.5),
        p99: quantile(0.99),
        pixels: errors.len(),
    })
}

/// The mean squared error of `image` against the true image, estimated from a noisy
/// unbiased `reference` with per-pixel variance of its mean: `E[(i − r)²] = (i − μ)² +
/// Var(r)`, so subtracting the reference's own variance leaves the image's error.
pub(crate) fn mse_against_noisy_reference(
    image: &[Vec3],
    reference: &[Vec3],
    reference_variance: &[Vec3],
) -> f64 {
    let sum: f64 = image
        .iter()
        .zip(reference)
        .zip(reference_variance)
        .map(|((i, r), v)| {
            let d = *i - *r;
            (d * d - *v)
                .to_array()
                .iter()
                .map(|&x| x as f64)
                .sum::<f64>()
        })
        .sum();
    sum / (3 * image.len()) as f64
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn agreement_reports_bias_and_spread_over_lit_pixels() {
        let reference = vec![Vec3::ONE; 100];
        let mut image = reference.clone();
        image[0] = Vec3::splat(1.5);
        let a = agreement(&image, &reference).unwrap();
        assert!((a.mean - 0.005).abs() < 1e-6);
        assert_eq!(a.p50, 0.0);
        assert_eq!(a.pixels, 100);
        assert!((agreement(&reference, &reference).unwrap().p99).abs() < 1e-12);
        assert_eq!(agreement(&image, &[Vec3::ZERO; 100]), None);
    }

    #[test]
    fn the_reference_noise_is_removed_from_the_error() {
        // A reference off by exactly its standard deviation everywhere: no error left.
        let truth = vec![Vec3::splat(2.0); 50];
        let reference = vec![Vec3::splat(2.1); 50];
        let variance = vec![Vec3::splat(0.01); 50];
        // 2.1 and 0.01 are not exact in f32: (2.1 − 2)² − 0.01 is −2e-8 there, not 0.
        assert!(mse_against_noisy_reference(&truth, &reference, &variance).abs() < 1e-7);
        let off = vec![Vec3::splat(2.5); 50];
        let mse = mse_against_noisy_reference(&off, &reference, &variance);
        assert!((mse - (0.16 - 0.01)).abs() < 1e-6, "{mse}");
    }
}
