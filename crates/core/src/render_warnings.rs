//! Renders outside what their own settings can resolve: they finish without an error, but
//! their image says little (a smear of a few photons, a near-black transparent volume).
//! [`render_warnings`] names them; `sweep render` and `sweep run` print them on stderr and
//! keep them in the render's record (`warnings`).

use crate::medium::{MappingKind, SigmaReport};
use crate::photon::PhotonStats;
use crate::scene::{IntegratorParams, MAX_PHOTONS, Method};

/// Which key sets the photons of one map: what a warning tells to raise.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PhotonKey {
    /// `volume_photons`: the one map, or each iteration's when `photons_per_iteration` is 0.
    VolumePhotons,
    /// `photons_per_iteration`: each iteration's map of a progressive, beam or plane render.
    PhotonsPerIteration,
    /// `stored_photons`: the one map's stored-photon target.
    StoredPhotons,
}

impl PhotonKey {
    fn of(integrator: &IntegratorParams) -> Self {
        if integrator.stored_photons > 0 {
            PhotonKey::StoredPhotons
        } else if integrator.iterates() && integrator.photons_per_iteration > 0 {
            PhotonKey::PhotonsPerIteration
        } else {
            PhotonKey::VolumePhotons
        }
    }

    fn name(self) -> &'static str {
        match self {
            PhotonKey::VolumePhotons => "volume_photons",
            PhotonKey::PhotonsPerIteration => "photons_per_iteration",
            PhotonKey::StoredPhotons => "stored_photons",
        }
    }
}

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
    /// Fewer stored photons than [`PHOTONS_PER_NUSED`] × `nused` (only for an estimator
    /// that gathers `nused` photons).
    FewPhotons {
        /// Photons stored in the map.
        stored: u64,
        /// Photons per estimate.
        nused: u32,
        /// Photons emitted for the map (one iteration's, for an iterating render).
        emitted: u64,
        /// The key that sets `emitted`.
        key: PhotonKey,
    },
    /// A stored-photon target the tracer gave up on: it emitted the most a round may
    /// ([`MAX_PHOTONS`]) and the map still holds fewer.
    TargetMissed {
        /// Photons stored in the map.
        stored: u64,
        /// `stored_photons`.
        target: u64,
        /// Photons emitted in the last round.
        emitted: u64,
    },
    /// Photons were stored, yet the multiple-scattering layer is black everywhere: no
    /// sample found a photon within reach (`maxdist` far below the photons' spacing).
    BlackMultiple {
        /// Photons stored in the map.
        stored: u64,
        /// The gather radius (or the planes' blur half-width).
        maxdist: f32,
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
            RenderWarning::TargetMissed { .. } => "a stored-photon target not reached",
            RenderWarning::BlackMultiple { .. } => "a black multiple-scattering layer",
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
                key,
            } => few_photons(f, stored, nused, emitted, key),
            RenderWarning::TargetMissed {
                stored,
                target,
                emitted,
            } => write!(
                f,
                "stored_photons = {target} not reached: {emitted} photons emitted (the most a round may trace) stored {stored}; the lights barely reach the medium or it scatters almost nothing: raise σt, aim the lights at the volume, or lower stored_photons"
            ),
            RenderWarning::BlackMultiple { stored, maxdist } => write!(
                f,
                "{stored} photons stored, but the multiple-scattering layer is black: no sample found a photon within maxdist = {maxdist:e} (far below the photons' spacing); raise maxdist (the thesis uses 0.1, 10 % of the longest axis)"
            ),
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

/// The advice for too few photons: how many to trace, if a map may hold that many.
fn few_photons(
    f: &mut std::fmt::Formatter<'_>,
    stored: u64,
    nused: u32,
    emitted: u64,
    key: PhotonKey,
) -> std::fmt::Result {
    let name = key.name();
    if stored == 0 {
        return write!(
            f,
            "none of the {emitted} photons emitted for the map was stored (they missed the volume or crossed it without scattering): the multiple-scattering layer is black; raise {name}, or σt if the medium is nearly clear"
        );
    }
    write!(
        f,
        "{stored} photons stored for nused {nused}: fewer than {PHOTONS_PER_NUSED} × nused, so each estimate averages a large part of the whole map and the multiple-scattering layer is a smear, not the light's distribution; "
    )?;
    if key == PhotonKey::StoredPhotons {
        // The target is a stored count: the advice is the count itself.
        let needed = PHOTONS_PER_NUSED * nused as u64;
        return write!(
            f,
            "raise stored_photons to {needed} or more, or lower nused"
        );
    }
    // Photons stored per photon emitted stay about the same for more photons.
    let needed =
        (emitted as f64 * (PHOTONS_PER_NUSED * nused as u64) as f64 / stored as f64).ceil();
    let lower = stored / PHOTONS_PER_NUSED;
    if needed <= MAX_PHOTONS as f64 {
        write!(
            f,
            "trace more photons ({name} ≥ {needed:.0}) or lower nused"
        )
    } else if lower >= 2 {
        write!(
            f,
            "{name} ≥ {needed:.0} would be needed, more than the {MAX_PHOTONS} a map may hold: lower nused to {lower} or less"
        )
    } else {
        write!(
            f,
            "no photon count up to {MAX_PHOTONS} stores enough for any nused: the medium scatters too little of the light; raise σt or {name}"
        )
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
/// `mapping`), with the photon map `photons` (when it traced one; an iterating render's
/// first map) and the mean of its multiple-scattering layer, cannot resolve.
pub fn render_warnings(
    integrator: &IntegratorParams,
    mapping: MappingKind,
    sigma: &SigmaReport,
    photons: Option<&PhotonStats>,
    mean_multiple: Option<f64>,
) -> Vec<RenderWarning> {
    let mut warnings = Vec::new();
    let photons = photons.filter(|_| integrator.method == Method::Photon && integrator.multiple);
    // Planes and a radius from maxdist never gather nused photons.
    let gathers_nused = !integrator.ignored_keys().contains(&"nused");
    if let Some(p) = photons
        && (p.stored == 0
            || (gathers_nused && p.stored < PHOTONS_PER_NUSED * integrator.nused as u64))
    {
        warnings.push(RenderWarning::FewPhotons {
            stored: p.stored,
            nused: integrator.nused,
            emitted: p.emitted,
            key: PhotonKey::of(integrator),
        });
    }
    if let Some(p) = photons
        && p.stored_target > 0
        && p.stored < p.stored_target
    {
        warnings.push(RenderWarning::TargetMissed {
            stored: p.stored,
            target: p.stored_target,
            emitted: p.emitted,
        });
    }
    if let Some(p) = photons
        && p.stored > 0
        && mean_multiple == Some(0.0)
    {
        warnings.push(RenderWarning::BlackMultiple {
            stored: p.stored,
            maxdist: integrator.maxdist,
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
            emitted: 10_000,
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
            render_warnings(
                &i,
                MappingKind::Thesis,
                &sigma(80.0),
                Some(&stored(1500)),
                None
            )
            .is_empty()
        );
        let few = render_warnings(
            &i,
            MappingKind::Thesis,
            &sigma(80.0),
            Some(&stored(264)),
            None,
        );
        assert_eq!(
            few,
            vec![RenderWarning::FewPhotons {
                stored: 264,
                nused: 150,
                emitted: 10_000,
                key: PhotonKey::VolumePhotons,
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
                Some(&stored(264)),
                None
            )
            .is_empty()
        );
        // 1/σt(d_min) = 100 % of the extent is not yet transparent; 238 % is.
        assert!(render_warnings(&i, MappingKind::Thesis, &sigma(1.0), None, None).is_empty());
        let thin = render_warnings(&i, MappingKind::Thesis, &sigma(1.0 / 2.38), None, None);
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
        assert!(
            render_warnings(&i, MappingKind::Opacity, &ramp(100.0 / 805.0), None, None).is_empty()
        );
        assert!(
            !render_warnings(&i, MappingKind::Thesis, &ramp(100.0 / 805.0), None, None).is_empty()
        );
        for mapping in [MappingKind::Opacity, MappingKind::Explicit] {
            let clear = render_warnings(&i, mapping, &ramp(100.0 / 805.0 / 500.0), None, None);
            assert!(
                matches!(clear[..], [RenderWarning::Transparent { at_d_max, .. }] if at_d_max > 100.0),
                "{clear:?}"
            );
            let text = clear[0].to_string();
            assert!(text.contains("densest material"), "{text}");
            assert!(!text.contains("sigma.t"), "{text}");
        }
    }

    /// Case 12 of the fourth reliability round: advice beyond the photon limit, for the
    /// wrong key, about nused where it is not read, and silence over a black layer.
    #[test]
    fn warnings_name_the_right_key_within_the_limits() {
        use crate::scene::MsEstimator;
        let progressive = IntegratorParams {
            estimator: MsEstimator::Progressive,
            photons_per_iteration: 10,
            volume_photons: 4_000_000,
            ..Default::default()
        };
        let p = PhotonStats {
            stored: 4,
            emitted: 10,
            ..Default::default()
        };
        let w = render_warnings(
            &progressive,
            MappingKind::Thesis,
            &sigma(80.0),
            Some(&p),
            None,
        );
        let text = w[0].to_string();
        assert!(text.contains("photons_per_iteration ≥ 3750"), "{text}");
        let huge = PhotonStats {
            stored: 100,
            emitted: 40_000_000,
            ..Default::default()
        };
        let w = render_warnings(
            &IntegratorParams::default(),
            MappingKind::Thesis,
            &sigma(80.0),
            Some(&huge),
            None,
        );
        let text = w[0].to_string();
        assert!(
            text.contains("lower nused to 10 or less") && text.contains("more than the 100000000"),
            "{text}"
        );
        let plane = IntegratorParams {
            estimator: MsEstimator::Plane,
            ..Default::default()
        };
        assert!(
            render_warnings(
                &plane,
                MappingKind::Thesis,
                &sigma(80.0),
                Some(&stored(134)),
                Some(0.1)
            )
            .is_empty(),
            "planes do not read nused"
        );
        let black = render_warnings(
            &IntegratorParams::default(),
            MappingKind::Thesis,
            &sigma(80.0),
            Some(&stored(20_000)),
            Some(0.0),
        );
        assert!(
            matches!(
                black[..],
                [RenderWarning::BlackMultiple { stored: 20_000, .. }]
            ),
            "{black:?}"
        );
        assert!(black[0].to_string().contains("raise maxdist"));
        let none = PhotonStats {
            stored: 0,
            emitted: 40_000,
            ..Default::default()
        };
        let w = render_warnings(
            &plane,
            MappingKind::Thesis,
            &sigma(80.0),
            Some(&none),
            Some(0.0),
        );
        assert!(
            w[0].to_string().starts_with("none of the 40000 photons"),
            "{}",
            w[0]
        );
    }
}
