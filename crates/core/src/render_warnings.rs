//! Renders outside what their own settings can resolve: they finish without an error, but
//! their image says little (a smear of a few photons, a near-black transparent volume).
//! [`render_warnings`] names them; `sweep render` and `sweep run` print them on stderr and
//! keep them in the render's record (`warnings`).

use crate::medium::{MappingKind, SigmaReport};
use crate::photon::PhotonStats;
use crate::scene::{IntegratorParams, Method};

/// Stored photons per `nused` below which a render is warned about. A k-NN estimate of
/// `nused` photons from a map of N averages `nused/N` of the whole map: at the thesis's
/// settings (40 000 photons stored many times over, nused 150) that is well under 1 %, a
/// local estimate. Below 10 × nused each estimate averages a tenth of the map or more (or,
/// with `maxdist` capping the search, finds far fewer than `nused` photons): the
/// multiple-scattering layer is a smear or a few blotches, not the light's distribution.
pub const PHOTONS_PER_NUSED: u64 = 10;

/// A nominal mean free path (`1/σt(d_min)`) longer than this share of the volume's largest
/// extent is warned about: at the lowest density light then crosses the whole volume with
/// `e^(−1)` = 37 % or more of it unscattered, so the medium is nearly transparent there and
/// the image near black (photons pass through, eye rays find little to scatter). That holds
/// where `d_min` is the tissue the mapping was set for (`thesis`, `mean-free-path`: §8.1.2
/// sets σt there). Where it is only where a ramp begins (`opacity` presets, `explicit`
/// coefficients), a nearly clear `d_min` is the point of the ramp, so there the densest
/// material is judged: `1/σt(d_max)` longer than the volume.
pub const TRANSPARENT_FREE_PATH_PERCENT: f32 = 100.0;

/// Something a render's settings cannot resolve.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum RenderWarning {
    /// Fewer stored photons than [`PHOTONS_PER_NUSED`] × `nused`.
    FewPhotons {
        /// Photons stored in the map.
        stored: u64,
        /// Photons per estimate.
        nused: u32,
        /// Photons emitted for the map (the scene's `volume_photons`).
        emitted: u64,
    },
    /// A nominal mean free path longer than the volume ([`TRANSPARENT_FREE_PATH_PERCENT`]):
    /// at `d_min` for the `thesis` and `mean-free-path` mappings, at `d_max` for the others.
    Transparent {
        /// `1/σt(d_min)` as % of the largest extent.
        at_d_min: f32,
        /// `1/σt(d_max)` as % of the largest extent.
        at_d_max: f32,
        /// The scene's σ mapping (what to raise).
        mapping: MappingKind,
    },
}

impl RenderWarning {
    /// What the warning is about, in a few words: a run prints each kind in full for its
    /// first cells and then names the other cells with it once.
    pub fn kind(&self) -> &'static str {
        match self {
            RenderWarning::FewPhotons { .. } => "fewer than 10 × nused photons stored",
            RenderWarning::Transparent { .. } => "a mean free path longer than the volume",
        }
    }
}

impl std::fmt::Display for RenderWarning {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match *self {
            RenderWarning::FewPhotons {
                stored,
                nused,
                emitted,
            } => {
                // Photons stored per photon emitted stay about the same for more photons.
                let needed = emitted.max(1) as f64 * (PHOTONS_PER_NUSED * nused as u64) as f64
                    / stored.max(1) as f64;
                write!(
                    f,
                    "{stored} photons stored for nused {nused}: fewer than {PHOTONS_PER_NUSED} × nused, so each estimate averages a large part of the whole map and the multiple-scattering layer is a smear, not the light's distribution; trace more photons (volume_photons ≥ {:.0}) or lower nused",
                    needed.ceil()
                )
            }
            RenderWarning::Transparent {
                at_d_min,
                at_d_max,
                mapping,
            } => {
                let raise = match mapping {
                    MappingKind::Thesis => {
                        "raise sigma.t (the thesis uses 80, a mean free path of 1.25 %)"
                    }
                    MappingKind::MeanFreePath => {
                        "lower sigma.percent (the thesis's σt 80 is a mean free path of 1.25 %)"
                    }
                    MappingKind::Opacity => "raise sigma.scale",
                    MappingKind::Explicit => "raise sigma_a and sigma_s",
                };
                if judged_at_d_min(mapping) {
                    write!(
                        f,
                        "the nominal mean free path 1/σt(d_min) is {} of the volume's largest extent (1/σt(d_max): {}): light crosses the volume mostly unscattered where the density is low, and the image is near black there; {raise}",
                        percent(at_d_min),
                        percent(at_d_max)
                    )
                } else {
                    write!(
                        f,
                        "even the densest material's mean free path 1/σt(d_max) is {} of the volume's largest extent: light crosses the whole volume mostly unscattered, and the image is near black; {raise}",
                        percent(at_d_max)
                    )
                }
            }
        }
    }
}

/// Whether a mapping sets σt for the tissue at `d_min` (so a clear `d_min` means a clear
/// medium), rather than letting `d_min` be where a ramp begins.
fn judged_at_d_min(mapping: MappingKind) -> bool {
    matches!(mapping, MappingKind::Thesis | MappingKind::MeanFreePath)
}

/// A share of the extent as a warning gives it (`∞` when nothing scatters at all).
fn percent(p: f32) -> String {
    if p.is_finite() {
        format!("{p:.0} %")
    } else {
        "infinite".to_string()
    }
}

/// What a render with `integrator` settings on a medium described by `sigma` (mapped by
/// `mapping`), with the photon map `photons` (when it traced one), cannot resolve.
pub fn render_warnings(
    integrator: &IntegratorParams,
    mapping: MappingKind,
    sigma: &SigmaReport,
    photons: Option<&PhotonStats>,
) -> Vec<RenderWarning> {
    let mut warnings = Vec::new();
    if let Some(p) = photons.filter(|_| integrator.method == Method::Photon && integrator.multiple)
        && p.stored < PHOTONS_PER_NUSED * integrator.nused as u64
    {
        warnings.push(RenderWarning::FewPhotons {
            stored: p.stored,
            nused: integrator.nused,
            emitted: integrator.volume_photons,
        });
    }
    let at_d_max = sigma.mean_free_path_percent_at_dmax();
    let judged = if judged_at_d_min(mapping) {
        sigma.mean_free_path_percent
    } else {
        at_d_max
    };
    // NaN (no density at all) counts as transparent, as infinity does.
    if judged.is_nan() || judged > TRANSPARENT_FREE_PATH_PERCENT {
        warnings.push(RenderWarning::Transparent {
            at_d_min: sigma.mean_free_path_percent,
            at_d_max,
            mapping,
        });
    }
    warnings
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::medium::Coefficients;

    fn sigma(t: f32) -> SigmaReport {
        let c = Coefficients {
            sigma_t_base: t,
            albedo: glam::Vec3::splat(0.8),
        };
        SigmaReport::new(&c, 1.0, 4.0, 1.0)
    }

    fn stored(n: u64) -> PhotonStats {
        PhotonStats {
            stored: n,
            ..Default::default()
        }
    }

    #[test]
    fn the_thresholds_sit_where_the_comments_say() {
        let i = IntegratorParams {
            nused: 150,
            volume_photons: 10_000,
            ..Default::default()
        };
        assert!(
            render_warnings(&i, MappingKind::Thesis, &sigma(80.0), Some(&stored(1500))).is_empty()
        );
        let few = render_warnings(&i, MappingKind::Thesis, &sigma(80.0), Some(&stored(264)));
        assert_eq!(
            few,
            vec![RenderWarning::FewPhotons {
                stored: 264,
                nused: 150,
                emitted: 10_000
            }]
        );
        // 10 000 emitted gave 264: 1500 stored need about 57 000.
        assert!(
            few[0].to_string().contains("volume_photons ≥ 56819"),
            "{}",
            few[0]
        );
        // Without multiple scattering there is no map to warn about.
        let single = IntegratorParams {
            multiple: false,
            ..i.clone()
        };
        assert!(
            render_warnings(
                &single,
                MappingKind::Thesis,
                &sigma(80.0),
                Some(&stored(264))
            )
            .is_empty()
        );
        // 1/σt(d_min) = 100 % of the extent is not yet transparent; 238 % is.
        assert!(render_warnings(&i, MappingKind::Thesis, &sigma(1.0), None).is_empty());
        let thin = render_warnings(&i, MappingKind::Thesis, &sigma(1.0 / 2.38), None);
        assert!(
            matches!(thin[..], [RenderWarning::Transparent { at_d_min, at_d_max, .. }]
                if (at_d_min - 238.0).abs() < 0.1 && (at_d_max - 59.5).abs() < 0.1),
            "{thin:?}"
        );
        assert!(thin[0].to_string().contains("238 %"), "{}", thin[0]);
    }

    /// A Slicer preset's ramp starts at a nearly clear density: that is its point, not a
    /// transparent medium (presets-paper's bone and soft-tissue cells said "805 %" there
    /// while their densest material had a mean free path under 1 %). Its densest material
    /// is judged instead.
    #[test]
    fn a_ramp_that_starts_clear_is_judged_by_its_densest_material() {
        let i = IntegratorParams::default();
        // d_min 1, d_max 400: 1/σt(d_min) 805 %, 1/σt(d_max) 2 %.
        let ramp = |t: f32| {
            let c = Coefficients {
                sigma_t_base: t,
                albedo: glam::Vec3::splat(0.8),
            };
            SigmaReport::new(&c, 1.0, 400.0, 1.0)
        };
        assert!(render_warnings(&i, MappingKind::Opacity, &ramp(100.0 / 805.0), None).is_empty());
        assert!(!render_warnings(&i, MappingKind::Thesis, &ramp(100.0 / 805.0), None).is_empty());
        for mapping in [MappingKind::Opacity, MappingKind::Explicit] {
            let clear = render_warnings(&i, mapping, &ramp(100.0 / 805.0 / 500.0), None);
            assert!(
                matches!(clear[..], [RenderWarning::Transparent { at_d_max, .. }] if at_d_max > 100.0),
                "{clear:?}"
            );
            let text = clear[0].to_string();
            assert!(text.contains("densest material"), "{text}");
            assert!(!text.contains("sigma.t"), "{text}");
        }
    }
}
