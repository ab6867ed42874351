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

use std::time::Instant;

use glam::Vec3;
use kiddo::ImmutableKdTree;

use super::neighbours::{Neighbours, key_distance2};
use super::{Photon, PhotonStats};
use crate::medium::Phase;

/// What a gather sums over its photons.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Gathered {
    /// `Σ p·ΔΦ / V`: interaction-weighted flux density (eq. 11).
    Flux,
    /// `Σ p·ΔΦ/σt(x_p) / V`: in-scattered fluence density, continuous across density edges.
    /// Photons stored where σt = 0 (possible only with the thesis's free-path rule) add 0.
    Fluence,
}

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

/// A kd-tree over stored photons.
pub struct PhotonMap {
    /// Unique per map built in this process: gather candidates remember which map they
    /// came from.
    id: u64,
    tree: ImmutableKdTree<f32, 3>,
    photons: Vec<Photon>,
    /// The largest power component of a photon, and of a photon's power over its σt: with
    /// the phase function's maximum they bound every term of a gather (see [`FixedSum`]).
    largest_flux: f32,
    largest_fluence: f32,
    stats: PhotonStats,
    build_seconds: f64,
}

impl std::fmt::Debug for PhotonMap {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("PhotonMap")
            .field("photons", &self.photons.len())
            .field("stats", &self.stats)
            .finish()
    }
}

impl PhotonMap {
    /// Builds the kd-tree (kiddo's immutable tree) over the photons' positions.
    pub fn new(photons: Vec<Photon>, stats: PhotonStats) -> Self {
        let start = Instant::now();
        let positions: Vec<[f32; 3]> = photons.iter().map(|p| p.position.to_array()).collect();
        let tree = ImmutableKdTree::new_from_slice(&positions)
            .expect("photon count fits u32 (capped by volume_photons ≤ 1e8)");
        let largest = |f: &dyn Fn(&Photon) -> f32| photons.iter().map(f).fold(0.0f32, f32::max);
        let largest_flux = largest(&|p| p.power.max_element());
        let largest_fluence = largest(&|p| {
            if p.sigma_t > 0.0 {
                p.power.max_element() / p.sigma_t
            } else {
                0.0
            }
        });
        static NEXT_ID: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(1);
        PhotonMap {
            id: NEXT_ID.fetch_add(1, std::sync::atomic::Ordering::Relaxed),
            tree,
            photons,
            largest_flux,
            largest_fluence,
            stats,
            build_seconds: start.elapsed().as_secs_f64(),
        }
    }

    /// Stored photons.
    pub fn photons(&self) -> &[Photon] {
        &self.photons
    }

    /// Number of stored photons.
    pub fn len(&self) -> usize {
        self.photons.len()
    }

    /// Whether no photon was stored.
    pub fn is_empty(&self) -> bool {
        self.photons.is_empty()
    }

    /// Photon-tracing statistics.
    pub fn stats(&self) -> &PhotonStats {
        &self.stats
    }

    /// Seconds spent building the kd-tree.
    pub fn build_seconds(&self) -> f64 {
        self.build_seconds
    }

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

    pub(super) fn id(&self) -> u64 {
        self.id
    }

    pub(super) fn tree(&self) -> &ImmutableKdTree<f32, 3> {
        &self.tree
    }

    /// A bound on any gather's sum of terms: the largest term times the photon count.
    pub(super) fn term_bound(&self, gathered: Gathered, phase: Phase) -> f32 {
        let largest = match gathered {
            Gathered::Flux => self.largest_flux,
            Gathered::Fluence => self.largest_fluence,
        };
        largest * phase.max_value() * self.photons.len() as f32
    }

    /// Photon `i`'s term of a gather: `p·ΔΦ` (flux), or `p·ΔΦ/σt` (fluence; 0 where it was
    /// stored with σt = 0).
    #[inline]
    pub(super) fn term(photon: &Photon, gathered: Gathered, phase: Phase, wo: Vec3) -> Vec3 {
        let contribution = photon.power * phase.eval(photon.direction, wo);
        match gathered {
            Gathered::Flux => contribution,
            Gathered::Fluence if photon.sigma_t > 0.0 => contribution / photon.sigma_t,
            Gathered::Fluence => Vec3::ZERO,
        }
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

/// `n` photons of power `power` uniform in the unit cube (tests of the photon stage).
#[cfg(test)]
pub(super) fn uniform_cloud(n: usize, power: f32, seed: u64) -> PhotonMap {
    let mut rng = crate::math::Rng::stream(seed, crate::math::Domain::Misc, 0);
    let photons = (0..n)
        .map(|_| Photon {
            position: Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()),
            direction: Vec3::Z,
            power: Vec3::splat(power),
            sigma_t: 1.0,
        })
        .collect();
    PhotonMap::new(photons, PhotonStats::default())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::{Domain, Rng};

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
