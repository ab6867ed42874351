//! How closely one image follows another: for speed-ups that claim to be exact (the bench),
//! and for peers that render the same scene (the Mitsuba harness).

use glam::Vec3;

/// The bias of the mean and the per-pixel relative error (median, 99th percentile) of an
/// image against a reference: core's, which its thinning tests hold the marcher to.
pub(crate) use volphot::{Agreement, agreement};

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
