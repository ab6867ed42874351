//! The multiple-scattering term's leaf: which estimator a marching pass asks at its samples
//! ([`MsSource`]: photon-map gathers, beams, photon spheres or planes) and the medium-share
//! normalisation every masked estimate shares ([`mask_estimates`], thesis §5.2 eq. 11 in the
//! form that divides by where photons can be). The pass, the marcher, the eye ray, the
//! progressive loop, the gathers and the scattering cache all import from here and this
//! file imports none of them, so the dispatch sits below every estimator instead of in a
//! circle through the pass.

use glam::Vec3;

use crate::medium::Medium;
use crate::photon::{BeamMap, PlaneMap};

/// Where a pass's multiple-scattering term comes from.
#[derive(Debug, Clone, Copy)]
pub(super) enum MsSource<'a> {
    /// Photon-map gathers at the marching samples (the variants' map groups).
    Gathers,
    /// The beam radiance estimate over photons as spheres.
    Beams(&'a BeamMap<'a>),
    /// The point estimate with each photon's own radius (sample-point kernels) at every
    /// marching sample.
    Spheres(&'a BeamMap<'a>),
    /// Photon planes.
    Planes(&'a PlaneMap<'a>),
}

/// Divides masked estimates by the medium's share of their gather sphere. Variants often
/// share a radius (all that hit `maxdist`, or equal `nused` under different caps), so each
/// distinct radius is measured once.
pub(super) fn mask_estimates(
    medium: &Medium,
    at: Vec3,
    masked: &[bool],
    radii: &[f32],
    values: &mut [Vec3],
) {
    let mut measured: [(f32, f32); 8] = [(f32::NAN, 0.0); 8];
    let mut count = 0;
    for ((value, &m), &r) in values.iter_mut().zip(masked).zip(radii) {
        if !m || r <= 0.0 {
            continue;
        }
        let share = match measured[..count].iter().find(|(radius, _)| *radius == r) {
            Some(&(_, share)) => share,
            None => {
                let share = medium.occupancy(at, r);
                measured[count % measured.len()] = (r, share);
                count = (count + 1).min(measured.len());
                share
            }
        };
        *value = if share > 0.0 {
            *value / share
        } else {
            Vec3::ZERO
        };
    }
}
