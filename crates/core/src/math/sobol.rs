//! Owen-scrambled Sobol points for stratifying a pixel's samples across passes.
//!
//! Sample `k` of a pixel takes point `k` of the first three Sobol dimensions (Joe & Kuo's
//! direction numbers), each scrambled by a hash-based nested uniform scramble (Burley 2020,
//! "Practical Hash-based Owen Scrambling") seeded by the pixel and the dimension. Every
//! point is uniformly distributed (so an estimator that uses it stays unbiased), and the
//! first `n` points of a pixel are stratified in all three dimensions together: a pixel's
//! mean converges faster where its integrand is smooth. The points are a function of
//! `(seed, pixel, k)` alone, so images stay bit-identical whatever the thread count and
//! however the passes are split.

/// Dimensions with direction numbers here.
pub const SOBOL_DIMENSIONS: usize = 3;

/// The direction numbers of dimensions 0–2 (32 bits each).
const DIRECTIONS: [[u32; 32]; SOBOL_DIMENSIONS] = directions();

/// Direction numbers: dimension 0 is van der Corput; 1 and 2 use the primitive polynomials
/// `x + 1` and `x² + x + 1` with Joe & Kuo's initial numbers (1) and (1, 3).
const fn directions() -> [[u32; 32]; SOBOL_DIMENSIONS] {
    let mut v = [[0u32; 32]; SOBOL_DIMENSIONS];
    let mut i = 0;
    while i < 32 {
        v[0][i] = 1u32 << (31 - i);
        i += 1;
    }
    // Dimension 1: degree 1, m₁ = 1: v_i = v_{i−1} ⊕ (v_{i−1} ≫ 1).
    v[1][0] = 1u32 << 31;
    let mut i = 1;
    while i < 32 {
        v[1][i] = v[1][i - 1] ^ (v[1][i - 1] >> 1);
        i += 1;
    }
    // Dimension 2: degree 2, a = 1, m = (1, 3): v_i = v_{i−2} ⊕ (v_{i−2} ≫ 2) ⊕ v_{i−1}.
    v[2][0] = 1u32 << 31;
    v[2][1] = 3u32 << 30;
    let mut i = 2;
    while i < 32 {
        v[2][i] = v[2][i - 2] ^ (v[2][i - 2] >> 2) ^ v[2][i - 1];
        i += 1;
    }
    v
}

/// The unscrambled point `index` of dimension `dim`, as 32 bits.
#[inline]
fn sobol_bits(index: u32, dim: usize) -> u32 {
    let mut x = 0u32;
    let mut k = index;
    let mut bit = 0;
    while k != 0 {
        if k & 1 != 0 {
            x ^= DIRECTIONS[dim][bit];
        }
        k >>= 1;
        bit += 1;
    }
    x
}

/// Laine & Karras's permutation of the bits below each bit, in reversed bit order.
#[inline]
fn laine_karras(mut x: u32, seed: u32) -> u32 {
    x = x.wrapping_add(seed);
    x ^= x.wrapping_mul(0x6c50_b47c);
    x ^= x.wrapping_mul(0xb82f_1e52);
    x ^= x.wrapping_mul(0xc7af_e638);
    x ^= x.wrapping_mul(0x8d22_f6e6);
    x
}

/// Nested uniform (Owen) scrambling of 32 bits with `seed`.
#[inline]
fn owen(x: u32, seed: u32) -> u32 {
    laine_karras(x.reverse_bits(), seed).reverse_bits()
}

/// Point `index` of dimension `dim` (< [`SOBOL_DIMENSIONS`]), scrambled with `seed`
/// (different per pixel and dimension), in `[0, 1)`.
#[inline]
pub fn scrambled_sobol(index: u32, dim: usize, seed: u64) -> f32 {
    let s =
        (crate::math::mix64(seed ^ (dim as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15)) >> 32) as u32;
    let bits = owen(sobol_bits(index, dim), s);
    // The top 24 bits: exactly representable, strictly below 1.
    (bits >> 8) as f32 * (1.0 / (1u32 << 24) as f32)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_three_dimensions_form_a_net_together() {
        // Any two dimensions: the first 16 points fill the 4 × 4 strata, and the three
        // together the 2 × 2 × 2 cells of the first 8 points (a (0, 3)-net in base 2).
        let unscrambled = |k: u32, d: usize| sobol_bits(k, d) as f64 / 2f64.powi(32);
        for (a, b) in [(0, 1), (0, 2), (1, 2)] {
            let mut cells = [0u32; 16];
            for k in 0..16 {
                let (x, y) = (unscrambled(k, a), unscrambled(k, b));
                cells[(x * 4.0) as usize * 4 + (y * 4.0) as usize] += 1;
            }
            assert!(cells.iter().all(|c| *c == 1), "dims {a}, {b}: {cells:?}");
        }
        let mut cube = [0u32; 8];
        for k in 0..8 {
            let c: Vec<usize> = (0..3).map(|d| (unscrambled(k, d) * 2.0) as usize).collect();
            cube[c[0] * 4 + c[1] * 2 + c[2]] += 1;
        }
        assert!(cube.iter().all(|c| *c == 1), "{cube:?}");
    }

    /// Every power-of-two prefix of a pixel's scrambled points has one point in each
    /// elementary interval of each dimension (stratified), and the points are uniform over
    /// many pixels.
    #[test]
    fn prefixes_are_stratified_and_points_uniform() {
        for dim in 0..SOBOL_DIMENSIONS {
            for seed in 0..20u64 {
                let n = 64u32;
                let mut cells = vec![0u32; n as usize];
                for k in 0..n {
                    let u = scrambled_sobol(k, dim, seed);
                    assert!((0.0..1.0).contains(&u));
                    cells[(u * n as f32) as usize] += 1;
                }
                assert!(cells.iter().all(|c| *c == 1), "dim {dim}, seed {seed}");
            }
            // Over pixels, point 5 is uniform.
            let mean: f64 = (0..20_000u64)
                .map(|s| f64::from(scrambled_sobol(5, dim, s)))
                .sum::<f64>()
                / 20_000.0;
            assert!((mean - 0.5).abs() < 0.01, "dim {dim}: mean {mean}");
        }
        // Two dimensions together: the first 16 points fill the 4 × 4 strata.
        let mut cells = [0u32; 16];
        for k in 0..16 {
            let (a, b) = (scrambled_sobol(k, 0, 7), scrambled_sobol(k, 1, 7));
            cells[(a * 4.0) as usize * 4 + (b * 4.0) as usize] += 1;
        }
        assert!(cells.iter().all(|c| *c == 1), "{cells:?}");
    }
}
