//! The multiple-scattering source term at a marching sample (thesis §5.2, eq. 11): the
//! variants that share one photon map and thus one k-NN query, the medium-share
//! normalisation of masked estimates, and the factor that turns a gathered density into a
//! source term per unit length for each [`Estimate`] form.

use glam::Vec3;

use super::cache::ScatterCache;
use super::multiple::mask_estimates;
use crate::error::{Error, Result};
use crate::math::Aabb;
use crate::medium::Medium;
use crate::photon::{GatherScratch, GatherVariant, Gathered, PhotonMap};
use crate::scene::{Estimate, IntegratorParams};

/// One multiple-scattering image rendered from a shared march: which photon map, and the
/// radiance-estimate parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MsVariant {
    /// Index into the photon maps passed to [`super::render_march`].
    pub map: usize,
    /// Photons per estimate.
    pub nused: u32,
    /// Largest gather radius.
    pub maxdist: f32,
    /// Estimate form.
    pub estimate: Estimate,
}

impl MsVariant {
    /// The scene's own estimate on the first photon map.
    pub(super) fn of_scene(settings: &IntegratorParams) -> Self {
        MsVariant {
            map: 0,
            nused: settings.nused,
            maxdist: settings.maxdist,
            estimate: settings.estimate,
        }
    }
}

/// The variants that share one photon map, and thus one k-NN query per sample.
pub(super) struct MapGroup<'a> {
    pub(super) map: &'a PhotonMap,
    /// Indices into the variant list (and output films).
    pub(super) variants: Vec<usize>,
    /// The gathers to run, aligned with `variants`.
    pub(super) gather: Vec<GatherVariant>,
    /// Which gathers are normalised by the medium's share of the sphere.
    pub(super) masked: Vec<bool>,
    pub(super) cache: Option<ScatterCache>,
}

impl MapGroup<'_> {
    /// Estimates of every variant of the group at `x` (towards `wo`) into `out`, from the
    /// cache when there is one; returns whether a k-NN gather ran.
    pub(super) fn estimate(
        &self,
        medium: &Medium,
        x: Vec3,
        wo: Vec3,
        scratch: &mut GatherScratch,
        out: &mut [Vec3],
    ) -> bool {
        match &self.cache {
            Some(cache) => {
                cache.lookup(self.map, &self.gather, &self.masked, medium, x, out);
                false
            }
            None => {
                self.estimate_uncached(medium, x, wo, scratch, out);
                true
            }
        }
    }

    /// Estimates of every variant of the group at `x` from a gather, cache or not.
    pub(super) fn estimate_uncached(
        &self,
        medium: &Medium,
        x: Vec3,
        wo: Vec3,
        scratch: &mut GatherScratch,
        out: &mut [Vec3],
    ) {
        self.map
            .estimates(x, wo, medium.phase(), &self.gather, scratch, out);
        mask_estimates(medium, x, &self.masked, scratch.radii(), out);
    }
}

/// Groups `variants` by photon map (variants on one map share one k-NN query per sample).
pub(super) fn group_by_map<'a>(
    variants: &[MsVariant],
    maps: &[&'a PhotonMap],
    settings: &IntegratorParams,
    bounds: Aabb,
) -> Result<Vec<MapGroup<'a>>> {
    if let Some(v) = variants.iter().find(|v| v.map >= maps.len()) {
        return Err(Error::MissingPhotonMap {
            index: v.map,
            given: maps.len(),
        });
    }
    let mut groups: Vec<MapGroup> = Vec::new();
    for (vi, v) in variants.iter().enumerate() {
        let gather = GatherVariant {
            nused: v.nused,
            maxdist: v.maxdist,
            gathered: match v.estimate {
                Estimate::Masked | Estimate::Fluence => Gathered::Fluence,
                Estimate::Albedo | Estimate::Thesis => Gathered::Flux,
            },
        };
        let masked = v.estimate == Estimate::Masked;
        match groups.iter_mut().find(|g| std::ptr::eq(g.map, maps[v.map])) {
            Some(g) => {
                g.variants.push(vi);
                g.gather.push(gather);
                g.masked.push(masked);
            }
            None => groups.push(MapGroup {
                map: maps[v.map],
                variants: vec![vi],
                gather: vec![gather],
                masked: vec![masked],
                cache: (settings.ms_cache > 0)
                    .then(|| ScatterCache::new(bounds, settings.ms_cache)),
            }),
        }
    }
    Ok(groups)
}

/// Source term per unit length from a gathered density, for each [`Estimate`] form.
#[inline]
pub(super) fn source_factor(estimate: Estimate, medium: &Medium, x: Vec3, sigma_t: f32) -> Vec3 {
    match estimate {
        Estimate::Masked | Estimate::Fluence => medium.albedo_at(x) * sigma_t,
        Estimate::Albedo => medium.albedo_at(x),
        Estimate::Thesis => Vec3::ONE,
    }
}
