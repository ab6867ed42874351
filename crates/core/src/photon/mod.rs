//! Photons (thesis §5): tracing from the lights through the medium ([`trace`]) and the
//! kd-tree photon map with its radiance estimate ([`PhotonMap`]); the same paths as spheres
//! for the beam estimate ([`BeamMap`]) or as planes ([`PlaneMap`]).

mod beams;
mod map;
mod neighbours;
mod planes;
mod trace;

pub use beams::{BeamMap, BeamRadius, Crossing};
pub use map::{GatherScratch, GatherVariant, Gathered, PhotonMap};
pub use planes::{PhotonPlane, PlaneCrossing, PlaneMap, trace_planes};
pub use trace::{MAX_INTERACTIONS, Photon, PhotonStats, TraceSettings, photons_per_light, trace};

use glam::Vec3;

/// Whether the ray from `origin` with inverse direction `inv_dir` meets the box `[min, max]`
/// within `[t_min, t_max]` (the slab test of the beam and plane hierarchies).
#[inline]
fn slab_hit(min: Vec3, max: Vec3, origin: Vec3, inv_dir: Vec3, t_min: f32, t_max: f32) -> bool {
    let t1 = (min - origin) * inv_dir;
    let t2 = (max - origin) * inv_dir;
    let near = t1.min(t2).max_element().max(t_min);
    let far = t1.max(t2).min_element().min(t_max);
    // NaN (a zero direction component on the slab's plane) counts as a hit.
    near.partial_cmp(&far) != Some(std::cmp::Ordering::Greater)
}
