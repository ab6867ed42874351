//! Colour + opacity transfer functions in data units: a Slicer preset on a DICOM series
//! gives σt = −ln(1 − α)/unit_distance per mm (converted to world units) and the preset's
//! colour as albedo; a coloured medium renders colour in single and multiple scattering
//! and in the path tracer; the grey pipeline is untouched; bad colour points and mappings
//! are errors naming the key.

use glam::Vec3;
use volphot::test_util::dicom::{SliceSpec, write_slice};
use volphot::{ColourTransfer, Control, Layer, Scene, SearchPath, render};

/// An 8×8×8 CT series: x < 4 air (−1000 HU), x ≥ 4 bone (700 HU); spacing 0.5 × 0.75 × 1 mm.
fn write_ct(dir: &std::path::Path) {
    let words: Vec<u16> = (0..64)
        .map(|i| {
            if i % 8 < 4 {
                -1000i16 as u16
            } else {
                700i16 as u16
            }
        })
        .collect();
    for z in 0..8 {
        let spec = SliceSpec::ct("2.25.40", &format!("2.25.40.{z}"), z as f64, [8, 8]);
        write_slice(&dir.join(format!("{z}.dcm")), &spec, &words).unwrap();
    }
}

fn scene_in(dir: &std::path::Path, body: &str) -> volphot::Result<Scene> {
    let path = dir.join("scene.toml");
    std::fs::write(&path, body).unwrap();
    Scene::load(&path, &SearchPath::new(vec![]))
}

#[test]
fn ct_bone_preset_gives_extinction_per_mm_and_colour_as_albedo() {
    let dir = tempfile::tempdir().unwrap();
    write_ct(dir.path());
    let scene = scene_in(
        dir.path(),
        "[volume]\ndicom = \".\"\nreconstruction = \"nearest\"\n[transfer]\npreset = \"CT-Bone\"\n[three_point]\n",
    )
    .unwrap();
    let medium = scene.medium();
    let bone = ColourTransfer::preset("CT-Bone").unwrap();
    // Largest physical extent: 8 slices × 1 mm = 8 mm = one world unit.
    let b = medium.bounds();
    let p_bone = b.min + (b.max - b.min) * Vec3::new(0.8, 0.5, 0.5);
    let p_air = b.min + (b.max - b.min) * Vec3::new(0.2, 0.5, 0.5);
    let expected = bone.extinction_per_mm(700.0) * 8.0;
    let got = medium.sigma_t(p_bone) as f64;
    assert!(
        (got - expected).abs() < 1e-4 * expected,
        "σt {got} vs {expected}"
    );
    assert_eq!(medium.sigma_t(p_air), 0.0);
    let c = bone.colour(700.0);
    let albedo = medium.albedo_at(p_bone);
    for k in 0..3 {
        assert!(
            (albedo[k] as f64 - c[k]).abs() < 1e-5,
            "{albedo:?} vs {c:?}"
        );
    }
    // The preset's colour at 700 HU is warm: red > blue.
    assert!(albedo.x > albedo.z);
}

#[test]
fn sigma_scale_and_albedo_scale_apply() {
    let dir = tempfile::tempdir().unwrap();
    write_ct(dir.path());
    let body = "[volume]\ndicom = \".\"\nreconstruction = \"nearest\"\n[transfer]\npreset = \"CT-Bone\"\n\
                [sigma]\nmapping = \"opacity\"\nscale = 0.5\nalbedo = 0.5\n[three_point]\n";
    let scene = scene_in(dir.path(), body).unwrap();
    let bone = ColourTransfer::preset("CT-Bone").unwrap();
    let b = scene.medium().bounds();
    let p = b.min + (b.max - b.min) * Vec3::new(0.8, 0.5, 0.5);
    let expected = bone.extinction_per_mm(700.0) * 8.0 * 0.5;
    assert!((scene.medium().sigma_t(p) as f64 - expected).abs() < 1e-4 * expected);
    assert!((scene.medium().albedo_at(p).x as f64 - 0.5 * bone.colour(700.0)[0]).abs() < 1e-5);
}

#[test]
fn mismatched_mapping_and_bad_points_are_errors_naming_the_key() {
    let dir = tempfile::tempdir().unwrap();
    write_ct(dir.path());
    let thesis = "[volume]\ndicom = \".\"\n[transfer]\npreset = \"CT-Bone\"\n[sigma]\nmapping = \"thesis\"\nt = 5\n[three_point]\n";
    let e = scene_in(dir.path(), thesis).err().unwrap().to_string();
    assert!(e.contains("sigma.mapping") && e.contains("opacity"), "{e}");
    let order = "[volume]\ndicom = \".\"\n[transfer]\nopacity = [[0, 0], [100, 1]]\ncolour = [[100, 1, 0, 0], [0, 1, 1, 1]]\n[three_point]\n";
    let e = scene_in(dir.path(), order).err().unwrap().to_string();
    assert!(
        e.contains("transfer.colour[1]") && e.contains("increasing"),
        "{e}"
    );
    let vp = dir.path().join("bad.vp");
    std::fs::write(
        &vp,
        "1\n1\n0.9\n0.1\n0.2\n10\n6 0 0 100 1\n4 0 1 255 1\n8 0 1 1 1 100 1 1 1\n",
    )
    .unwrap();
    let e = scene_in(
        dir.path(),
        "[volume]\ndicom = \".\"\n[transfer]\nfile = \"bad.vp\"\n[three_point]\n",
    )
    .err()
    .unwrap()
    .to_string();
    assert!(
        e.contains("bad.vp") && e.contains("count 6 with 4 numbers"),
        "{e}"
    );
}

const RED_SPHERE: &str = r#"
[volume]
phantom = { name = "sphere", resolution = [16, 16, 16], radius = 0.4 }
[transfer]
opacity = [[0, 0], [1, 0.05]]
colour = [[0, 0.9, 0.2, 0.0], [1, 0.9, 0.2, 0.0]]
[camera]
eye = [0.5, -1.8, 0.5]
look_at = [0.5, 0.5, 0.5]
up = [0, 0, 1]
fov = 36
resolution = [12, 12]
[[lights]]
type = "point"
position = [0.5, -1.0, 1.5]
intensity = 5
[integrator]
stepsize = 0.01
volume_photons = 4000
"#;

#[test]
fn a_coloured_medium_renders_colour_in_every_layer() {
    let scene = volphot::test_util::scene(RED_SPHERE);
    assert!(scene.medium().has_colour());
    let out = render(&scene, &Control::none()).unwrap();
    for layer in [Layer::Single, Layer::Multiple] {
        let sum: Vec3 = out.film.layer(layer).iter().copied().sum();
        assert!(sum.x > 0.0, "{layer:?} {sum:?}");
        assert_eq!(sum.z, 0.0, "{layer:?}: blue albedo 0 scatters no blue");
        // Multiple scattering weighs the albedo twice or more: red/green grows beyond 4.5.
        let ratio = sum.x / sum.y;
        let least = if layer == Layer::Single { 4.4 } else { 4.6 };
        assert!(ratio > least, "{layer:?} red/green {ratio}");
    }
    let reference = volphot::test_util::scene(&format!(
        "{RED_SPHERE}method = \"reference\"\nreference_spp = 8\n"
    ));
    let out = render(&reference, &Control::none()).unwrap();
    let sum: Vec3 = out.film.total().iter().copied().sum();
    assert!(sum.x > 0.0 && sum.z == 0.0, "path tracer {sum:?}");
}

/// The colour scene presets for the real data load: each has a per-voxel colour, a finite
/// σt range and some medium left after the opacity.
#[test]
fn real_data_colour_presets_load() {
    if volphot::test_util::real_data_dir().is_none() {
        volphot::test_util::skip(
            "colour presets on real data",
            "no real data (set VOLPHOT_DATA)",
        );
        return;
    }
    let scenes = volphot::test_util::workspace_root().join("experiments/scenes");
    for name in [
        "cranium-ct-bone",
        "cranium-ct-soft-tissue",
        "colin27-mr-default",
        "engine-colour",
        "cthead-ct-bone",
        "foot-colour",
    ] {
        let path = scenes.join(format!("{name}.toml"));
        let scene = Scene::load(&path, &volphot::test_util::search_path())
            .unwrap_or_else(|e| panic!("{name}: {e}"));
        let medium = scene.medium();
        assert!(medium.has_colour(), "{name}");
        let report = medium.report();
        assert!(
            report.sigma_t_at_dmax.is_finite() && report.sigma_t_at_dmax > 0.0,
            "{name}: {report:?}"
        );
    }
}

/// `emission_colour`: the emission is `Le · colour(x) · d(x)` — the preset's colour glows,
/// in the emission layer only when single and multiple scattering are off; without a
/// colour transfer function or without `emission` it is an error naming the key.
#[test]
fn emission_takes_the_colour_of_the_transfer_function() {
    let glowing = RED_SPHERE.replace(
        "[camera]",
        "[sigma]\nemission = [2, 2, 2]\nemission_colour = true\n[camera]",
    );
    let scene = volphot::test_util::scene(&format!(
        "{glowing}emission = true\nsingle = false\nmultiple = false\n"
    ));
    let medium = scene.medium();
    let centre = Vec3::splat(0.5);
    let expected = Vec3::new(0.9, 0.2, 0.0) * 2.0 * medium.density(centre);
    assert!(medium.density(centre) > 0.0);
    assert!(
        (medium.emission(centre) - expected).length() < 1e-5 * expected.length(),
        "{} vs {expected}",
        medium.emission(centre)
    );
    let out = render(&scene, &Control::none()).unwrap();
    let sum: Vec3 = out.film.layer(Layer::Emission).iter().copied().sum();
    assert!(sum.x > 0.0 && sum.z == 0.0, "{sum:?}");
    assert!(
        (sum.x / sum.y - 4.5).abs() < 1e-3,
        "red/green {}",
        sum.x / sum.y
    );
    for layer in [Layer::Single, Layer::Multiple] {
        assert!(out.film.layer(layer).iter().all(|v| *v == Vec3::ZERO));
    }

    let grey = "[volume]\nphantom = { name = \"sphere\", resolution = [8, 8, 8] }\n[sigma]\nemission = [1, 1, 1]\nemission_colour = true\n[three_point]\n";
    let dir = tempfile::tempdir().unwrap();
    let e = scene_in(dir.path(), grey).err().unwrap().to_string();
    assert!(
        e.contains("sigma.emission_colour") && e.contains("colour transfer function"),
        "{e}"
    );
    let unscaled = RED_SPHERE.replace("[camera]", "[sigma]\nemission_colour = true\n[camera]");
    let e = scene_in(dir.path(), &unscaled).err().unwrap().to_string();
    assert!(
        e.contains("emission_colour") && e.contains("non-zero `emission`"),
        "{e}"
    );
}

/// A RAW file that stores HU + 1024 (as CThead does) with `intercept = -1024` reads the
/// preset exactly as the same CT in Hounsfield units does; without it, it does not.
#[test]
fn an_intercept_puts_stored_values_into_the_presets_units() {
    let dir = tempfile::tempdir().unwrap();
    write_ct(dir.path());
    let hu = scene_in(
        dir.path(),
        "[volume]\ndicom = \".\"\nreconstruction = \"nearest\"\n[transfer]\npreset = \"CT-Bone\"\n[three_point]\n",
    )
    .unwrap();
    let stored: Vec<u8> = (0..512u32)
        .flat_map(|i| (if i % 8 < 4 { 0u16 } else { 1724 }).to_le_bytes())
        .collect();
    std::fs::write(dir.path().join("ct.raw"), stored).unwrap();
    let raw = |intercept: &str| {
        scene_in(
            dir.path(),
            &format!(
                "[volume]\nfile = \"ct.raw\"\ndims = [8, 8, 8]\nvoxel = \"u16\"\nspacing = [0.5, 0.75, 1.0]\nnormalize = \"window\"\nwindow = [0, 4095]\nreconstruction = \"nearest\"\n[transfer]\npreset = \"CT-Bone\"\n{intercept}\n[three_point]\n"
            ),
        )
        .unwrap()
    };
    let (shifted, unshifted) = (raw("intercept = -1024"), raw(""));
    let at = |s: &Scene| {
        let b = s.medium().bounds();
        let p = b.min + (b.max - b.min) * Vec3::new(0.8, 0.5, 0.5);
        (s.medium().sigma_t(p), s.medium().albedo_at(p))
    };
    let (sigma_hu, albedo_hu) = at(&hu);
    let (sigma, albedo) = at(&shifted);
    assert!(sigma_hu > 0.0);
    assert!(
        (sigma - sigma_hu).abs() < 1e-4 * sigma_hu,
        "{sigma} vs {sigma_hu}"
    );
    assert!(
        (albedo - albedo_hu).length() < 1e-5,
        "{albedo} vs {albedo_hu}"
    );
    let (sigma_wrong, _) = at(&unshifted);
    assert!(
        (sigma_wrong - sigma_hu).abs() > 1e-2 * sigma_hu,
        "1724 read as HU is another tissue"
    );
}
