//! The volume photon map and its radiance estimate (thesis §5.2, eq. 11).
//!
//! `L(x, ω) ≈ Σ_{p < n} p(x, ω_p, ω) · ΔΦ_p / (4/3 · π · r³)` over the `n = nused` nearest
//! photons within `maxdist`. `r` is the radius of the sphere the estimate actually covers:
//! the distance to the `n`-th photon when `n` were found — that photon only sets the radius
//! and is not summed, which makes the estimate unbiased (eq. 11 sums all `n` and over-counts
//! by `n/(n − 1)`: E[1/V_n] = λ/(n − 1)) — otherwise `maxdist`, with every photon inside
//! summed (the whole searched sphere holds fewer than `n`, so its volume is the honest
//! denominator).
//!
//! One k-NN query can serve several `(nused, maxdist)` pairs at once ([`GatherVariant`]):
//! the neighbours come back sorted, so every smaller `nused` or radius is a prefix.
//!
//! ```
//! use glam::Vec3;
//! use volphot::{Photon, PhotonStats};
//! use volphot::{PhotonMap, GatherVariant, Gathered};
//! use volphot::Phase;
//! let photons: Vec<Photon> = (0..1000)
//!     .map(|i| Photon { position: Vec3::new((i % 10) as f32, ((i / 10) % 10) as f32, (i / 100) as f32) * 0.1,
//!                       direction: Vec3::Z, power: Vec3::splat(0.001), sigma_t: 1.0 })
//!     .collect();
//! let map = PhotonMap::new(photons, PhotonStats::default());
//! let v = [GatherVariant { nused: 8, maxdist: 0.5, gathered: Gathered::Flux }];
//! let mut out = [Vec3::ZERO];
//! map.estimates(Vec3::splat(0.45), Vec3::X, Phase::ISOTROPIC, &v, &mut Default::default(), &mut out);
//! assert!(out[0].x > 0.0);
//! ```

use glam::Vec3;

use super::map::{Gathered, PhotonMap};
use super::neighbours::{Neighbours, key_distance2};
use crate::medium::Phase;

/// One `(nused, maxdist, what)` estimate served by a shared gather.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GatherVariant {
    /// Photons used per estimate.
    pub nused: u32,
    /// Largest gather radius.
    pub maxdist: f32,
    /// What is summed.
    pub gathered: Gathered,
}

/// Reusable buffers for [`PhotonMap::estimates`], one per worker, so the hot loop does not
/// allocate.
#[derive(Debug, Default, Clone)]
pub struct GatherScratch {
    neighbours: Neighbours,
    radii: Vec<f32>,
}

impl GatherScratch {
    /// The radius each variant of the last [`PhotonMap::estimates`] call used (0 when it
    /// found no photons).
    pub fn radii(&self) -> &[f32] {
        &self.radii
    }
}

impl PhotonMap {
    /// The up to `k` nearest photons within `maxdist` of `p`, sorted by distance (ties by
    /// photon index), as `(squared distance, photon index)`.
    pub fn gather(&self, p: Vec3, k: usize, maxdist: f32) -> Vec<(f32, u32)> {
        let mut neighbours = Neighbours::default();
        neighbours.gather(self, p, k, maxdist, true);
        neighbours
            .selected()
            .iter()
            .map(|&(key, _)| (key_distance2(key), key as u32))
            .collect()
    }

    /// Radiance estimates (eq. 11) at `p` towards propagation direction `wo` for every
    /// variant, from a single gather with the largest `nused` and `maxdist`.
    ///
    /// Each variant's photons are a prefix of the shared gather in its canonical order, and
    /// its sum runs over that prefix in that order, so a variant's value is bit-identical
    /// whether it is estimated alone or with others.
    pub fn estimates(
        &self,
        p: Vec3,
        wo: Vec3,
        phase: Phase,
        variants: &[GatherVariant],
        scratch: &mut GatherScratch,
        out: &mut [Vec3],
    ) {
        debug_assert_eq!(variants.len(), out.len());
        let k = variants.iter().map(|v| v.nused).max().unwrap_or(0) as usize;
        let r_max = variants.iter().map(|v| v.maxdist).fold(0.0f32, f32::max);
        // One variant sums all its photons; several need them in order to take prefixes.
        let neighbours = &mut scratch.neighbours;
        neighbours.gather(self, p, k, r_max, variants.len() > 1);
        scratch.radii.clear();
        for (v, o) in variants.iter().zip(out.iter_mut()) {
            let selected = neighbours.selected();
            let r2_max = v.maxdist * v.maxdist;
            // Photons of this variant: the prefix within its radius, at most nused.
            let n = if variants.len() == 1 {
                selected.len()
            } else {
                let within = selected.partition_point(|s| key_distance2(s.0) <= r2_max);
                within.min(v.nused as usize)
            };
            let r = if n == v.nused as usize {
                key_distance2(neighbours.farthest(n).0).sqrt()
            } else {
                v.maxdist
            };
            // No photons, or coincident photons (zero radius): the estimate is left black
            // rather than undefined.
            if n == 0 || r <= 0.0 {
                *o = Vec3::ZERO;
                scratch.radii.push(0.0);
                continue;
            }
            // The n-th photon only sets the radius: Σ_{i<n} ΔΦ_i / V(r_n) is unbiased, where
            // Σ_{i≤n} over-counts by n/(n−1) (E[1/V_n] = λ/(n−1) for n photons of density
            // λ). With fewer than nused inside maxdist every photon counts: count/V(maxdist)
            // is unbiased too.
            let radius_from_photon = n == v.nused as usize;
            let sum = neighbours.sum(self, n, radius_from_photon, v.gathered, phase, wo);
            scratch.radii.push(r);
            *o = sum / (4.0 / 3.0 * std::f32::consts::PI * r * r * r);
        }
    }

    /// A single flux-density estimate (eq. 11).
    pub fn estimate(&self, p: Vec3, wo: Vec3, nused: u32, maxdist: f32, phase: Phase) -> Vec3 {
        let mut out = [Vec3::ZERO];
        let variant = GatherVariant {
            nused,
            maxdist,
            gathered: Gathered::Flux,
        };
        self.estimates(
            p,
            wo,
            phase,
            &[variant],
            &mut GatherScratch::default(),
            &mut out,
        );
        out[0]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::{Domain, Rng};
    use crate::photon::PhotonStats;
    use crate::photon::map::uniform_cloud;

    #[test]
    fn estimate_of_uniform_density_is_flux_per_volume_times_phase() {
        // n photons of power q uniformly in the unit cube: Σ ΔΦ / V → n·q, times 1/(4π).
        let n = 200_000;
        let q = 1e-5;
        let map = uniform_cloud(n, q, 2);
        let expected = n as f32 * q * crate::math::INV_4PI;
        let est = map.estimate(Vec3::splat(0.5), Vec3::X, 400, 0.3, Phase::ISOTROPIC);
        assert!(
            (est.x / expected - 1.0).abs() < 0.1,
            "{} vs {expected}",
            est.x
        );
    }

    #[test]
    fn variants_match_separate_queries_and_radius_rule() {
        let map = uniform_cloud(5000, 1.0, 2);
        let p = Vec3::new(0.3, 0.6, 0.4);
        let variants = [
            GatherVariant {
                nused: 10,
                maxdist: 0.5,
                gathered: Gathered::Flux,
            },
            GatherVariant {
                nused: 150,
                maxdist: 0.5,
                gathered: Gathered::Flux,
            },
            GatherVariant {
                nused: 150,
                maxdist: 0.08,
                gathered: Gathered::Flux,
            },
        ];
        let mut shared = [Vec3::ZERO; 3];
        map.estimates(
            p,
            Vec3::X,
            Phase::ISOTROPIC,
            &variants,
            &mut GatherScratch::default(),
            &mut shared,
        );
        for (v, s) in variants.iter().zip(shared) {
            let single = map.estimate(p, Vec3::X, v.nused, v.maxdist, Phase::ISOTROPIC);
            assert!(
                (single - s).length() <= 1e-6 * single.length().max(1.0),
                "{v:?}"
            );
        }
        // Fewer than nused within maxdist: r = maxdist.
        let hits = map.gather(p, 150, 0.08);
        assert!(!hits.is_empty() && hits.len() < 150);
        let expected = hits.len() as f32 * crate::math::INV_4PI
            / (4.0 / 3.0 * std::f32::consts::PI * 0.08f32.powi(3));
        assert!(
            (shared[2].x - expected).abs() < 1e-3 * expected,
            "{} vs {expected} ({} hits)",
            shared[2].x,
            hits.len()
        );
    }

    /// On a uniform photon field of density λ the estimate is unbiased for any `nused`:
    /// eq. 11 as the thesis writes it (all n photons over V(r_n)) gives λ·n/(n − 1), 1.25 at
    /// nused 5.
    #[test]
    fn the_knn_estimate_is_unbiased_on_a_uniform_field() {
        let (photons_per_map, maps) = (4000, 400);
        for nused in [3u32, 5, 10] {
            let mut sum = 0.0f64;
            let mut rng = Rng::stream(11, Domain::Misc, nused as u64);
            for m in 0..maps {
                let map = uniform_cloud(photons_per_map, 1.0, 1000 + m);
                // Interior points: the query sphere stays inside the cube.
                let p = Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()) * 0.5 + 0.25;
                sum += map.estimate(p, Vec3::X, nused, 0.2, Phase::ISOTROPIC).x as f64;
            }
            let expected = photons_per_map as f64 * crate::math::INV_4PI as f64;
            let ratio = sum / maps as f64 / expected;
            // Relative standard error of one estimate ≈ 1/sqrt(nused − 2), over 400 maps.
            let tolerance = 3.0 / ((nused as f64 - 2.0).max(1.0) * maps as f64).sqrt();
            assert!(
                (ratio - 1.0).abs() < tolerance,
                "nused {nused}: mean estimate / density = {ratio:.4} (±{tolerance:.4}); the biased form gives {:.3}",
                nused as f64 / (nused as f64 - 1.0)
            );
        }
    }

    #[test]
    fn empty_map_estimates_zero() {
        let map = PhotonMap::new(Vec::new(), PhotonStats::default());
        assert_eq!(
            map.estimate(Vec3::ZERO, Vec3::X, 10, 0.1, Phase::ISOTROPIC),
            Vec3::ZERO
        );
    }
}
