//! Photons (thesis §5): tracing from the lights through the medium ([`trace`]) and the
//! kd-tree photon map with its radiance estimate ([`PhotonMap`]); the same paths as spheres
//! for the beam estimate ([`BeamMap`]) or as planes ([`PlaneMap`]).

mod beams;
mod bvh;
mod estimate;
mod map;
mod neighbours;
mod planes;
mod trace;

pub use beams::{BeamMap, BeamRadius, Crossing};
pub use estimate::{GatherScratch, GatherVariant};
pub use map::{Gathered, PhotonMap};
pub use planes::{PhotonPlane, PlaneCrossing, PlaneMap, trace_planes};
pub use trace::{Photon, PhotonStats, TraceSettings, trace};
