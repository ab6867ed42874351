//! Rays and boxes, deterministic random streams, direction sampling, discrete sampling.

mod distribution;
mod geometry;
mod rng;
mod sampling;
mod sobol;

pub use distribution::{AliasTable, PiecewiseConstant1D, PiecewiseConstant2D};
pub(crate) use distribution::{apportion, sample_discrete};
pub use geometry::{Aabb, Frame, Ray, Sphere};
pub use rng::{Domain, Rng, mix64};
pub use sampling::{INV_4PI, concentric_disc, cosine_hemisphere, uniform_cone, uniform_sphere};
pub(crate) use sobol::scrambled_sobol;
