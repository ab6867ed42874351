//! The volume photon map: a kd-tree over the stored photons (thesis §5.2), and the term
//! each photon adds to a gather. The radiance estimate over it is `estimate`'s; the exact
//! neighbour search `neighbours`'.

use std::time::Instant;

use glam::Vec3;
use kiddo::ImmutableKdTree;

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
