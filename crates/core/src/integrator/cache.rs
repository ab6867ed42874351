//! Optional caches of the ray-marching integrator: a per-light transmittance cache
//! (`shadow_cache`) and a multiple-scattering cache (`ms_cache`, view-independent for an
//! isotropic phase function), both on a corner-aligned lattice of nodes filled lazily. Each
//! node depends only on its own position, so results do not depend on thread order; the
//! caches' error against the uncached path is measured in `tests/caches.rs`.

use std::sync::OnceLock;
use std::sync::atomic::{AtomicU64, Ordering};

use glam::Vec3;

use super::multiple::mask_estimates;
use crate::math::Aabb;
use crate::medium::{DepthCap, Medium, ShadowSegment};
use crate::photon::{GatherScratch, GatherVariant, PhotonMap};
use crate::scene::Light;

/// Optical depth up to which the transmittance cache integrates its nodes (T ≈ 10⁻¹⁶): far
/// beyond any shadow threshold, so interpolation between a lit and a dark node stays exact
/// in the logarithm.
pub const CACHE_TAU_MAX: f32 = 36.8;

#[derive(Debug, Clone)]
struct NodeLattice {
    res: [usize; 3],
    bounds: Aabb,
    spacing: Vec3,
}

impl NodeLattice {
    fn new(bounds: Aabb, longest: u32) -> Self {
        let extent = bounds.extent();
        let longest_extent = extent.max_element();
        let res = [0, 1, 2].map(|a| {
            ((extent[a] / longest_extent * (longest - 1) as f32).round() as usize + 1).max(2)
        });
        let spacing = Vec3::new(
            extent.x / (res[0] - 1) as f32,
            extent.y / (res[1] - 1) as f32,
            extent.z / (res[2] - 1) as f32,
        );
        NodeLattice {
            res,
            bounds,
            spacing,
        }
    }

    fn len(&self) -> usize {
        self.res[0] * self.res[1] * self.res[2]
    }

    fn position(&self, index: usize) -> Vec3 {
        let x = index % self.res[0];
        let y = (index / self.res[0]) % self.res[1];
        let z = index / (self.res[0] * self.res[1]);
        self.bounds.min + Vec3::new(x as f32, y as f32, z as f32) * self.spacing
    }

    /// The 8 surrounding nodes and their trilinear weights.
    #[inline]
    fn corners(&self, p: Vec3) -> [(usize, f32); 8] {
        let c = ((p - self.bounds.min) / self.spacing).max(Vec3::ZERO);
        let i0 = [0, 1, 2].map(|a| (c[a] as usize).min(self.res[a] - 2));
        let t = Vec3::new(
            (c.x - i0[0] as f32).clamp(0.0, 1.0),
            (c.y - i0[1] as f32).clamp(0.0, 1.0),
            (c.z - i0[2] as f32).clamp(0.0, 1.0),
        );
        let mut out = [(0usize, 0f32); 8];
        for (k, o) in out.iter_mut().enumerate() {
            let (dx, dy, dz) = (k & 1, (k >> 1) & 1, (k >> 2) & 1);
            let idx = (i0[0] + dx) + self.res[0] * ((i0[1] + dy) + self.res[1] * (i0[2] + dz));
            let w = (if dx == 1 { t.x } else { 1.0 - t.x })
                * (if dy == 1 { t.y } else { 1.0 - t.y })
                * (if dz == 1 { t.z } else { 1.0 - t.z });
            *o = (idx, w);
        }
        out
    }
}

/// Per-light cache of the optical depth to a delta light at lattice nodes, filled lazily
/// (each node depends only on its own position, so the result does not depend on thread
/// order). Only a light with one position has one: a light with extent or an environment
/// has no single direction a node's depth could be taken towards.
pub(super) struct TransmittanceCache {
    lattice: NodeLattice,
    /// The light's position.
    light: Vec3,
    tau: Vec<OnceLock<f32>>,
    pub(super) computed: AtomicU64,
}

impl TransmittanceCache {
    /// The cache of `light` over `bounds` at `res` nodes a side, or `None` for a light
    /// without one position.
    pub(super) fn towards(light: &Light, bounds: Aabb, res: u32) -> Option<Self> {
        let light = light.delta_position()?;
        let lattice = NodeLattice::new(bounds, res);
        let tau = (0..lattice.len()).map(|_| OnceLock::new()).collect();
        Some(TransmittanceCache {
            lattice,
            light,
            tau,
            computed: AtomicU64::new(0),
        })
    }

    /// The transmittance from `p` to the light, interpolated between the nodes' depths.
    pub(super) fn transmittance(&self, medium: &Medium, p: Vec3) -> f32 {
        let mut tau = 0.0;
        for (idx, w) in self.lattice.corners(p) {
            if w == 0.0 {
                continue;
            }
            let node_tau = *self.tau[idx].get_or_init(|| {
                self.computed.fetch_add(1, Ordering::Relaxed);
                let node = self.lattice.position(idx);
                let to_light = self.light - node;
                let distance = to_light.length();
                if distance <= 0.0 {
                    return 0.0;
                }
                let segment = ShadowSegment {
                    origin: node,
                    direction: to_light.normalize(),
                    distance,
                };
                medium.shadow_depth(&segment, DepthCap::Exact(CACHE_TAU_MAX))
            });
            tau += w * node_tau;
        }
        (-tau).exp()
    }
}

/// Cache of multiple-scattering source terms at lattice nodes (isotropic phase only).
pub(super) struct ScatterCache {
    lattice: NodeLattice,
    nodes: Vec<OnceLock<Box<[Vec3]>>>,
    pub(super) computed: AtomicU64,
}

impl ScatterCache {
    pub(super) fn new(bounds: Aabb, res: u32) -> Self {
        let lattice = NodeLattice::new(bounds, res);
        let nodes = (0..lattice.len()).map(|_| OnceLock::new()).collect();
        ScatterCache {
            lattice,
            nodes,
            computed: AtomicU64::new(0),
        }
    }

    pub(super) fn lookup(
        &self,
        map: &PhotonMap,
        gather: &[GatherVariant],
        masked: &[bool],
        medium: &Medium,
        p: Vec3,
        out: &mut [Vec3],
    ) {
        out.iter_mut().for_each(|o| *o = Vec3::ZERO);
        for (idx, w) in self.lattice.corners(p) {
            if w == 0.0 {
                continue;
            }
            let values = self.nodes[idx].get_or_init(|| {
                self.computed.fetch_add(1, Ordering::Relaxed);
                let mut v = vec![Vec3::ZERO; gather.len()];
                let mut scratch = GatherScratch::default();
                let node = self.lattice.position(idx);
                map.estimates(node, Vec3::Z, medium.phase(), gather, &mut scratch, &mut v);
                mask_estimates(medium, node, masked, scratch.radii(), &mut v);
                v.into_boxed_slice()
            });
            for (o, v) in out.iter_mut().zip(values.iter()) {
                *o += *v * w;
            }
        }
    }
}
