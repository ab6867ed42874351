//! Built-in 3D Slicer volume-rendering presets, shipped as Slicer `.vp` files in
//! `crates/core/presets/slicer/` (numbers from Slicer's `presets.xml`; see the README
//! there).

use super::ColourTransfer;
use crate::error::{Error, Result};

/// `(name, .vp text)` of every built-in preset.
const PRESETS: &[(&str, &str)] = &[
    ("CT-AAA", include_str!("../../../presets/slicer/CT-AAA.vp")),
    (
        "CT-Bone",
        include_str!("../../../presets/slicer/CT-Bone.vp"),
    ),
    (
        "CT-Bones",
        include_str!("../../../presets/slicer/CT-Bones.vp"),
    ),
    (
        "CT-Cardiac",
        include_str!("../../../presets/slicer/CT-Cardiac.vp"),
    ),
    (
        "CT-Cardiac3",
        include_str!("../../../presets/slicer/CT-Cardiac3.vp"),
    ),
    (
        "CT-Chest-Contrast-Enhanced",
        include_str!("../../../presets/slicer/CT-Chest-Contrast-Enhanced.vp"),
    ),
    ("CT-Fat", include_str!("../../../presets/slicer/CT-Fat.vp")),
    (
        "CT-Lung",
        include_str!("../../../presets/slicer/CT-Lung.vp"),
    ),
    (
        "CT-Muscle",
        include_str!("../../../presets/slicer/CT-Muscle.vp"),
    ),
    (
        "CT-Soft-Tissue",
        include_str!("../../../presets/slicer/CT-Soft-Tissue.vp"),
    ),
    (
        "MR-Angio",
        include_str!("../../../presets/slicer/MR-Angio.vp"),
    ),
    (
        "MR-Default",
        include_str!("../../../presets/slicer/MR-Default.vp"),
    ),
    (
        "MR-T2-Brain",
        include_str!("../../../presets/slicer/MR-T2-Brain.vp"),
    ),
];

/// The names of the built-in presets.
pub const NAMES: [&str; 13] = [
    "CT-AAA",
    "CT-Bone",
    "CT-Bones",
    "CT-Cardiac",
    "CT-Cardiac3",
    "CT-Chest-Contrast-Enhanced",
    "CT-Fat",
    "CT-Lung",
    "CT-Muscle",
    "CT-Soft-Tissue",
    "MR-Angio",
    "MR-Default",
    "MR-T2-Brain",
];

/// The preset `name` (case-insensitive).
pub fn get(name: &str) -> Result<ColourTransfer> {
    let (found, text) = PRESETS
        .iter()
        .find(|(n, _)| n.eq_ignore_ascii_case(name))
        .ok_or_else(|| {
            Error::parameter(
                "transfer.preset",
                format!("{name:?}"),
                format!("one of {}", NAMES.join(", ")),
            )
        })?;
    super::slicer::parse_vp(text, &format!("preset {found}"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_preset_parses_and_names_match() {
        assert_eq!(PRESETS.len(), NAMES.len());
        for ((name, _), listed) in PRESETS.iter().zip(NAMES) {
            assert_eq!(*name, listed);
            let tf = get(name).unwrap();
            assert!(tf.opacity.len() >= 2 && tf.colour.len() >= 2, "{name}");
        }
    }

    #[test]
    fn ct_bone_numbers_are_slicers() {
        let tf = get("ct-bone").unwrap();
        assert_eq!(
            tf.opacity,
            vec![
                [-3024.0, 0.0],
                [-16.4458, 0.0],
                [641.385, 0.715686],
                [3071.0, 0.705882]
            ]
        );
        assert_eq!(tf.colour[1], [-16.4458, 0.729412, 0.254902, 0.301961]);
        assert_eq!(tf.unit_distance, 1.0);
    }

    #[test]
    fn unknown_preset_lists_the_known_ones() {
        let e = get("CT-Nope").unwrap_err().to_string();
        assert!(e.contains("CT-Nope") && e.contains("MR-Default"), "{e}");
    }
}
