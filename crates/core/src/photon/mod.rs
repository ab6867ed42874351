//! Photons (thesis §5): tracing from the lights through the medium ([`trace`]) and the
//! kd-tree photon map with its radiance estimate ([`PhotonMap`]).

mod beams;
mod map;
mod neighbours;
mod trace;

pub use beams::{BeamMap, BeamRadius, Crossing};
pub use map::{GatherScratch, GatherVariant, Gathered, PhotonMap};
pub use trace::{MAX_INTERACTIONS, Photon, PhotonStats, TraceSettings, photons_per_light, trace};
