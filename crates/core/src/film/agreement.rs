//! How closely one image follows another, by luminance: the bias of the mean and the
//! spread of the per-pixel relative error. `sweep bench` measures the speed-ups that claim
//! to be exact with it (against the uncached, unthinned marcher), and the thinning tests
//! hold the marcher to its bounds with it (0.5 % bias, 2 % at the 99th percentile).

use glam::Vec3;
use serde::{Deserialize, Serialize};

/// Pixels darker than this fraction of the reference's mean luminance are left out of the
/// per-pixel relative errors (their relative error is noise over nothing).
const DARK_FRACTION: f64 = 0.01;

/// Rec. 709 luminance of a linear RGB value.
///
/// ```
/// use glam::Vec3;
/// assert_eq!(volphot::luminance(Vec3::new(1.0, 0.0, 0.0)), 0.2126);
/// assert_eq!(volphot::luminance(Vec3::ZERO), 0.0);
/// ```
pub fn luminance(v: Vec3) -> f32 {
    0.2126 * v.x + 0.7152 * v.y + 0.0722 * v.z
}

/// The agreement of an image with a reference image ([`agreement`]).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Agreement {
    /// Mean luminance ratio − 1: the bias of the mean.
    pub mean: f64,
    /// Median of the per-pixel relative luminance error.
    pub p50: f64,
    /// 99th percentile of the per-pixel relative luminance error.
    pub p99: f64,
    /// Pixels compared (those at least 1 % of the reference's mean luminance).
    pub pixels: usize,
}

/// The agreement of `image` with `reference` (equally sized), by [`luminance`]: the
/// ratio of their summed luminances − 1, and quantiles of `|image − reference| / reference`
/// over the pixels of at least 1 % of the reference's mean luminance. `None` when the
/// reference is black.
///
/// ```
/// use glam::Vec3;
/// use volphot::agreement;
///
/// let reference = vec![Vec3::ONE; 100];
/// let mut image = reference.clone();
/// // Two pixels of a hundred 50 % too bright: the mean is 1 % high, the median pixel
/// // exact, and the 99th percentile is one of the two.
/// image[0] = Vec3::splat(1.5);
/// image[1] = Vec3::splat(1.5);
/// let a = agreement(&image, &reference).unwrap();
/// assert!((a.mean - 0.01).abs() < 1e-6);
/// assert_eq!(a.p50, 0.0);
/// assert!((a.p99 - 0.5).abs() < 1e-6);
/// assert_eq!(a.pixels, 100);
///
/// // Dark reference pixels are left out; a black reference has nothing to compare.
/// let mut dark = reference.clone();
/// dark[99] = Vec3::splat(0.001);
/// assert_eq!(agreement(&image, &dark).unwrap().pixels, 99);
/// assert_eq!(agreement(&image, &[Vec3::ZERO; 100]), None);
/// ```
pub fn agreement(image: &[Vec3], reference: &[Vec3]) -> Option<Agreement> {
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
}
