//! Content addresses: a cell is stored under the first 16 hex digits of the sha256 of the
//! program version, its effective scene parameters and the identity of its volume (sha256
//! of the file, or the phantom's parameters), so a rerun finds finished cells and a changed
//! input never reuses a stale one.

use std::path::Path;

use anyhow::{Context, Result};
use volphot::{Method, SceneParams, Tracker};

/// Program version recorded in every output (and part of every address).
pub(crate) const VERSION: &str = env!("CARGO_PKG_VERSION");

/// The identity of a cell's volume without loading it.
pub(crate) fn volume_identity(params: &SceneParams, base: &Path) -> Result<String> {
    let v = &params.volume;
    if let Some(d) = &v.dataset {
        let info = volphot::find_dataset(d)?;
        return Ok(info.sha256.to_string());
    }
    if let Some(p) = &v.phantom {
        return Ok(format!("phantom:{}:{}", p.name, p.describe()));
    }
    if let Some(f) = &v.file {
        let path = base.join(f);
        return volphot::sha256_content(&path)
            .with_context(|| format!("hashing volume file {}", path.display()));
    }
    Ok(String::new())
}

/// α as the addresses of existing cells were computed with it (the default until the
/// `alpha` study moved it to 0.3).
const ADDRESS_ALPHA: f32 = 4.0 / 7.0;

/// The shadow fill's tolerance before it was a setting (`shadow_tolerance`): addresses
/// leave the setting out at this value.
pub(super) const ADDRESS_SHADOW_TOLERANCE: f32 = 0.05;

/// The parameters an address is taken over. A render whose estimator does not iterate
/// (the path tracer, the point estimate, no multiple scattering) cannot depend on the
/// progressive radius shrink α; where such a render has today's default α it is addressed
/// with the old default [`ADDRESS_ALPHA`], so the change of default neither orphaned
/// finished cells nor re-rendered references (an α set explicitly is addressed as set).
///
/// The path tracer's `tracker` did not exist before `weighted` became the default (issue
/// #47): an address leaves it out where it cannot change the image (photon mapping) and
/// at `delta`, the tracer every earlier reference was rendered with, so those references
/// keep their addresses and `weighted` ones get their own.
///
/// `thin_below` was left out of the parameters when 0 until it became the default (0.5),
/// and `shadow_tolerance` did not exist until it became a setting (its value was 0.05): an
/// address leaves each out at that old value, so cells rendered with it keep their
/// addresses, and the path tracer, which neither thins nor fills, is addressed without them.
///
/// A key the render does not read ([`volphot::SceneParams::ignored_integrator_keys`]: the
/// progressive radius rule of a point estimate, `nused` of photon planes, every photon key
/// without multiple scattering, `light_samples` under spot and point lights) is addressed
/// at its default, so settings that render the same image share one address.
fn addressed(params: &SceneParams) -> Result<String> {
    let mut p = params.with_ignored_at_default();
    if !p.integrator.iterates() && p.integrator.alpha == volphot::DEFAULT_ALPHA {
        p.integrator.alpha = ADDRESS_ALPHA;
    }
    if p.integrator.method == Method::Reference {
        p.integrator.thin_below = 0.0;
        p.integrator.shadow_tolerance = ADDRESS_SHADOW_TOLERANCE;
    }
    // Removed from the text, not from a `serde_json::Value`: a `Value` sorts its keys, and
    // the addresses are of the fields in declaration order.
    let mut text = serde_json::to_string(&p)?;
    if p.integrator.shadow_tolerance == ADDRESS_SHADOW_TOLERANCE {
        text = without_field(&text, "shadow_tolerance", ADDRESS_SHADOW_TOLERANCE)?;
    }
    if p.integrator.thin_below == 0.0 {
        text = without_field(&text, "thin_below", 0.0)?;
    }
    if p.integrator.method != Method::Reference || p.integrator.tracker == Tracker::Delta {
        text = without_text(
            &text,
            &format!(
                ",\"tracker\":{}",
                serde_json::to_string(&p.integrator.tracker)?
            ),
        )?;
    }
    Ok(text)
}

/// `text` without its one occurrence of `field`.
fn without_text(text: &str, field: &str) -> Result<String> {
    anyhow::ensure!(
        text.matches(field).count() == 1,
        "cannot address a cell: expected one `{field}` in its parameters, found {text}"
    );
    Ok(text.replacen(field, "", 1))
}

/// `text` without its one `,"key":value` field.
fn without_field(text: &str, key: &str, value: f32) -> Result<String> {
    without_text(
        text,
        &format!(",\"{key}\":{}", serde_json::to_string(&value)?),
    )
}

/// The identity of a scene's inputs besides its parameters: the volume's, followed by the
/// content of every light's file (an environment map), so editing a map in place gives
/// new addresses. Without such files it is the volume's identity alone, so the addresses
/// of scenes without them are what they were.
pub(crate) fn inputs_identity(params: &SceneParams, base: &Path) -> Result<String> {
    let mut text = volume_identity(params, base)?;
    for file in params.lights.iter().filter_map(|l| l.file.as_ref()) {
        let path = base.join(file);
        text += "\n";
        text += &volphot::sha256_content(&path).unwrap_or_else(|_| path.display().to_string());
    }
    Ok(text)
}

/// The content address of a cell: version, effective parameters, volume (and transfer
/// function and environment map file) identity.
/// `base` resolves the scene's relative file paths.
pub(crate) fn cell_hash(params: &SceneParams, base: &Path) -> Result<String> {
    let mut text = format!("volphot-sweep {VERSION}\n");
    text += &addressed(params)?;
    text += "\n";
    text += &inputs_identity(params, base)?;
    if let Some(f) = &params.transfer.file {
        let path = base.join(f);
        text += "\n";
        text += &volphot::sha256_content(&path).unwrap_or_else(|_| path.display().to_string());
    }
    Ok(volphot::sha256_bytes(text.as_bytes())[..16].to_string())
}

/// The content address of a reference: its scene (with the samples per pixel reset, so a
/// reference can be refined in place) and the identity of the volume it renders.
pub(crate) fn reference_hash(params: &SceneParams, volume_identity: &str) -> Result<String> {
    let mut p = params.clone();
    p.integrator.reference_spp = 1;
    let text = format!(
        "volphot-reference {VERSION}\n{}\n{volume_identity}",
        addressed(&p)?,
    );
    Ok(volphot::sha256_bytes(text.as_bytes())[..16].to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn params(extra: &str) -> SceneParams {
        let src = format!("{}{extra}", volphot::test_util::SMALL_SCENE);
        SceneParams::from_toml(&src, Path::new("s.toml")).unwrap()
    }

    #[test]
    fn a_new_default_alpha_keeps_the_addresses_of_renders_it_cannot_change() {
        let base = Path::new(".");
        let hash = |extra: &str| cell_hash(&params(extra), base).unwrap();
        assert_eq!(
            hash(""),
            hash("[integrator]\nalpha = 0.5714286\n"),
            "the point estimate"
        );
        let progressive = "[integrator]\nestimator = \"progressive\"\n";
        assert_ne!(
            hash(progressive),
            hash(&format!("{progressive}alpha = 0.5714286\n")),
            "α shapes a progressive image"
        );
        let reference = |alpha: f32| {
            let mut p = params("[integrator]\nmethod = \"reference\"\n");
            p.integrator.alpha = alpha;
            reference_hash(&p, "v").unwrap()
        };
        assert_eq!(reference(volphot::DEFAULT_ALPHA), reference(4.0 / 7.0));
    }

    #[test]
    fn a_cell_address_follows_its_parameters_and_its_volume_content() {
        let base = Path::new(".");
        let a = cell_hash(&params(""), base).unwrap();
        assert_eq!(a, cell_hash(&params(""), base).unwrap(), "stable");
        assert_eq!(a.len(), 16);
        assert_ne!(
            a,
            cell_hash(&params("[integrator]\nnused = 50\n"), base).unwrap()
        );
        // A volume file: same name, different bytes, different address.
        let tmp = tempfile::tempdir().unwrap();
        let file = tmp.path().join("v.raw");
        let raw = "[volume]\nfile = \"v.raw\"\ndims = [2, 2, 2]\nvoxel = \"u8\"\n[three_point]\n";
        let p = SceneParams::from_toml(raw, Path::new("s.toml")).unwrap();
        std::fs::write(&file, [1u8; 8]).unwrap();
        let first = cell_hash(&p, tmp.path()).unwrap();
        std::fs::write(&file, [2u8; 8]).unwrap();
        let second = cell_hash(&p, tmp.path()).unwrap();
        assert_ne!(first, second);
    }

    #[test]
    fn the_delta_tracker_and_photon_cells_keep_the_addresses_they_had_before_trackers() {
        let base = Path::new(".");
        let photon = params("");
        assert!(!addressed(&photon).unwrap().contains("tracker"));
        let mut photon_delta = photon.clone();
        photon_delta.integrator.tracker = Tracker::Delta;
        assert_eq!(
            cell_hash(&photon, base).unwrap(),
            cell_hash(&photon_delta, base).unwrap(),
            "photon mapping does not trace paths"
        );
        let reference = |tracker: Tracker| {
            let mut p = params("[integrator]\nmethod = \"reference\"\n");
            p.integrator.tracker = tracker;
            p
        };
        let delta = addressed(&reference(Tracker::Delta)).unwrap();
        assert!(!delta.contains("tracker"), "{delta}");
        let weighted = addressed(&reference(Tracker::Weighted)).unwrap();
        assert!(weighted.contains("\"tracker\":\"weighted\""), "{weighted}");
        assert_ne!(
            reference_hash(&reference(Tracker::Delta), "v").unwrap(),
            reference_hash(&reference(Tracker::Weighted), "v").unwrap()
        );
    }

    #[test]
    fn thinning_off_keeps_the_addresses_it_had_before_it_became_the_default() {
        let base = Path::new(".");
        let off = params("[integrator]\nthin_below = 0\n");
        let json = addressed(&off).unwrap();
        assert!(!json.contains("thin_below"), "{json}");
        let on = params("");
        assert_eq!(on.integrator.thin_below, volphot::DEFAULT_THIN_BELOW);
        assert_ne!(
            cell_hash(&off, base).unwrap(),
            cell_hash(&on, base).unwrap()
        );
        // The path tracer never thins: one reference whatever the setting.
        let reference = |thin: f32| {
            let mut p = params("[integrator]\nmethod = \"reference\"\n");
            p.integrator.thin_below = thin;
            reference_hash(&p, "v").unwrap()
        };
        assert_eq!(reference(0.0), reference(volphot::DEFAULT_THIN_BELOW));
    }

    #[test]
    fn the_old_shadow_tolerance_keeps_the_addresses_it_had_before_it_was_a_setting() {
        let base = Path::new(".");
        let old = params("[integrator]\nshadow_tolerance = 0.05\nthin_below = 0\n");
        let json = addressed(&old).unwrap();
        assert!(!json.contains("shadow_tolerance"), "{json}");
        assert!(!json.contains("thin_below"), "{json}");
        assert!(json.contains("\"shadow_stride\":8"), "{json}");
        let new = params("");
        assert_eq!(
            new.integrator.shadow_tolerance,
            volphot::DEFAULT_SHADOW_TOLERANCE
        );
        assert!(
            addressed(&new)
                .unwrap()
                .contains("\"shadow_tolerance\":0.025")
        );
        assert_ne!(
            cell_hash(&old, base).unwrap(),
            cell_hash(&new, base).unwrap()
        );
        // The path tracer never fills optical depths along an eye ray.
        let reference = |tolerance: f32| {
            let mut p = params("[integrator]\nmethod = \"reference\"\n");
            p.integrator.shadow_tolerance = tolerance;
            reference_hash(&p, "v").unwrap()
        };
        assert_eq!(
            reference(0.05),
            reference(volphot::DEFAULT_SHADOW_TOLERANCE)
        );
    }

    #[test]
    fn a_reference_address_ignores_its_sample_count() {
        let mut p = params("");
        let a = reference_hash(&p, "vol").unwrap();
        p.integrator.reference_spp = 4096;
        assert_eq!(a, reference_hash(&p, "vol").unwrap());
        assert_ne!(a, reference_hash(&p, "other volume").unwrap());
    }

    /// An environment map is part of what a cell renders: editing it in place gives new
    /// addresses, and a scene without one keeps the volume's identity alone.
    #[test]
    fn an_environment_map_s_content_is_part_of_the_address() {
        let dir = tempfile::tempdir().unwrap();
        let map = dir.path().join("sky.pfm");
        volphot::write_pfm(&map, 2, 1, &[glam::Vec3::ONE, glam::Vec3::splat(2.0)]).unwrap();
        let lit = params("[[lights]]\ntype = \"environment\"\nfile = \"sky.pfm\"\n");
        let plain = params("");
        assert_eq!(
            inputs_identity(&plain, dir.path()).unwrap(),
            volume_identity(&plain, dir.path()).unwrap()
        );
        let before = cell_hash(&lit, dir.path()).unwrap();
        let reference_before =
            reference_hash(&lit, &inputs_identity(&lit, dir.path()).unwrap()).unwrap();
        volphot::write_pfm(&map, 2, 1, &[glam::Vec3::ONE, glam::Vec3::splat(3.0)]).unwrap();
        assert_ne!(before, cell_hash(&lit, dir.path()).unwrap());
        assert_ne!(
            reference_before,
            reference_hash(&lit, &inputs_identity(&lit, dir.path()).unwrap()).unwrap()
        );
    }
}
