//! Clip planes and a crop box against closed forms and against the same medium built
//! without a clip: a homogeneous cube cut in half by a plane must be, for every ray, photon
//! and estimate, the homogeneous half-box it leaves.

use glam::Vec3;
use volphot::test_util as common;
use volphot::{Control, Layer, Ray, build_photon_map, render_march, render_reference};

/// A homogeneous medium (σt = 10 in the unit box) lit by a spot, at `volume_box` and with
/// `clip` appended.
fn scene(volume_box: &str, clip: &str, multiple: bool) -> volphot::Scene {
    common::scene(&format!(
        r#"
[volume]
phantom = {{ name = "constant", resolution = [16, 16, 16] }}
{volume_box}
[sigma]
t = 10
albedo = 0.8
[camera]
eye = [-1.2, 0.5, 0.5]
look_at = [0.5, 0.5, 0.5]
up = [0, 0, 1]
fov = 40
resolution = [10, 10]
[[lights]]
type = "spot"
position = [-1.0, 1.2, 1.1]
target = [0.6, 0.5, 0.5]
intensity = 20
cone_angle = 40
beam_width = 35
[integrator]
multiple = {multiple}
volume_photons = 20000
nused = 60
maxdist = 0.2
stepsize = 0.004
{clip}
"#
    ))
}

const HALF_BOX: &str = "box = { p0 = [0.5, 0, 0], p1 = [1, 1, 1] }";
const CLIP_PLANE: &str = "[clip]\nplane = { normal = [1, 0, 0], offset = 0.5 }";

fn mean(film: &volphot::Film, layer: Layer) -> f32 {
    let v = film.layer(layer);
    v.iter().map(|p| p.x + p.y + p.z).sum::<f32>() / (3 * v.len()) as f32
}

#[test]
fn a_clip_plane_leaves_the_optical_depth_of_what_it_keeps() {
    let clipped = scene("", CLIP_PLANE, false);
    let medium = clipped.medium();
    let sigma_t = medium.sigma_t_base() * medium.density(Vec3::splat(0.75));
    assert!((sigma_t - 10.0).abs() < 1e-4, "σt {sigma_t}");
    // Along +x through the whole box: only x ∈ [0.5, 1] holds medium.
    let ray = Ray::new(Vec3::new(-1.0, 0.37, 0.61), Vec3::X);
    let (t0, t1) = medium.clip(&ray).unwrap();
    assert!(
        (t0 - 1.5).abs() < 1e-5 && (t1 - 2.0).abs() < 1e-5,
        "{t0} {t1}"
    );
    let tau = medium.optical_depth_exact(&ray, t0, t1, f32::INFINITY);
    assert!((tau - 5.0).abs() < 1e-3, "τ {tau}, expected σt · 0.5 = 5");
    // Points on the removed side hold nothing; a sphere on the cut is half medium, as
    // in the half box.
    assert_eq!(medium.density(Vec3::new(0.49, 0.5, 0.5)), 0.0);
    let half = scene(HALF_BOX, "", false);
    for (c, r) in [(Vec3::splat(0.5), 0.2), (Vec3::new(0.55, 0.3, 0.7), 0.1)] {
        assert_eq!(
            medium.occupancy(c, r),
            half.medium().occupancy(c, r),
            "occupancy at {c} r {r}"
        );
    }
    assert!((medium.occupancy(Vec3::splat(0.5), 0.2) - 0.5).abs() < 0.1);
}

#[test]
fn photons_are_stored_only_where_the_clip_keeps_medium() {
    let clipped = scene("", CLIP_PLANE, true);
    let map = build_photon_map(&clipped, &Control::none()).unwrap();
    assert!(
        map.photons().len() > 1000,
        "{} photons",
        map.photons().len()
    );
    let outside = map
        .photons()
        .iter()
        .filter(|p| p.position.x < 0.5 - 1e-5)
        .count();
    assert_eq!(outside, 0, "photons stored in the clipped half");
}

#[test]
fn a_clipped_cube_renders_as_the_half_box_it_keeps() {
    // The path tracer (unbiased) and the marcher (deterministic quadrature) each render the
    // clipped cube and the half box; the images agree within the tracer's noise and the
    // marcher's step.
    let clipped = scene("", CLIP_PLANE, true);
    let half = scene(HALF_BOX, "", true);
    let passes = 256;
    let (a, _) = render_reference(&clipped, passes, &Control::none()).unwrap();
    let (b, _) = render_reference(&half, passes, &Control::none()).unwrap();
    for layer in [Layer::Single, Layer::Multiple] {
        let (ma, mb) = (mean(&a, layer), mean(&b, layer));
        assert!(ma > 0.0, "{layer:?} is black");
        assert!(
            (ma / mb - 1.0).abs() < 0.03,
            "{layer:?}: clipped {ma} against half box {mb}"
        );
    }
    let single = |s: &volphot::Scene| {
        let out = render_march(s, &[], &[], &Control::none()).unwrap();
        mean(&out.films[0], Layer::Single)
    };
    let (sa, sb) = (
        single(&scene("", CLIP_PLANE, false)),
        single(&scene(HALF_BOX, "", false)),
    );
    assert!(
        (sa / sb - 1.0).abs() < 0.01,
        "marched single: {sa} against {sb}"
    );
    // Against the unclipped cube the clip must matter: the eye and the light face the cut,
    // which the whole cube's removed half would hide.
    let whole = single(&scene("", "", false));
    assert!(
        (whole / sa - 1.0).abs() > 0.2,
        "the clip changed nothing: {whole} vs {sa}"
    );
}

#[test]
fn an_empty_clip_leaves_the_scene_as_it_was() {
    let plain = scene("", "", false);
    let empty = scene("", "[clip]", false);
    assert_eq!(plain.params().to_table(), empty.params().to_table());
    assert!(empty.medium().clip_region().is_none());
}

#[test]
fn bad_clips_are_named_in_the_scene_file() {
    let src = |clip: &str| {
        format!(
            "[volume]\nphantom = {{ name = \"constant\", resolution = [8, 8, 8] }}\n[three_point]\n{clip}\n"
        )
    };
    for (clip, expected) in [
        (
            "[clip]\nplane = { normal = [0, 0, 0], offset = 0.5 }",
            "clip.plane.normal",
        ),
        (
            "[clip]\nbox = { p0 = [0.6, 0, 0], p1 = [0.4, 1, 1] }",
            "clip.box",
        ),
        (
            "[clip]\nplanes = [{ normal = [1, 0, 0], offset = 2 }]",
            "clip.plane",
        ),
        ("[clip]\nplane = { normal = [1, 0, 0] }", "offset"),
        ("[clip]\nspace = \"screen\"", "space"),
    ] {
        let text = src(clip);
        let err = volphot::SceneParams::from_toml(&text, std::path::Path::new("s.toml"))
            .and_then(|p| {
                volphot::validate_params(&p)?;
                volphot::Scene::from_params(
                    &p,
                    std::path::Path::new("."),
                    &volphot::SearchPath::new(vec![]),
                )
                .map(|_| ())
            })
            .expect_err(clip)
            .to_string();
        assert!(err.contains(expected), "{clip}: {err}");
    }
}

/// Planes that keep a region of zero thickness (`x ≥ 0.5` and `x ≤ 0.5`), or one thinner
/// than a 32-bit float's step, keep nothing a ray resolves: an error naming the planes and
/// the thickness, as the docs promise for planes that keep nothing — not a black image.
#[test]
fn planes_that_keep_a_slab_of_no_thickness_are_refused() {
    let load = |clip: &str| {
        let text = format!(
            "[volume]\nphantom = {{ name = \"constant\", resolution = [8, 8, 8] }}\n[three_point]\n[clip]\n{clip}\n"
        );
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("slab.toml");
        std::fs::write(&path, &text).unwrap();
        volphot::Scene::load(&path, &volphot::SearchPath::new(vec![])).map(|_| ())
    };
    for clip in [
        "plane = { normal = [1, 0, 0], offset = 0.5 }\nplanes = [{ normal = [-1, 0, 0], offset = -0.5 }]",
        "plane = { normal = [1, 0, 0], offset = 0.5 }\nplanes = [{ normal = [-1, 0, 0], offset = -0.5000001 }]",
        "plane = { normal = [1, 1, 0], offset = 1 }\nplanes = [{ normal = [-1, -1, 0], offset = -1 }]",
        "box = { p0 = [0, 0, 0.5], p1 = [1, 1, 0.5000001] }",
    ] {
        let err = load(clip).expect_err(clip).to_string();
        assert!(
            err.contains("slab.toml") && err.contains("thick") && err.contains("keep nothing"),
            "{clip}: {err}"
        );
    }
    // A thin slab that 32-bit floats still resolve (a thousandth of the box) is kept.
    load("plane = { normal = [1, 0, 0], offset = 0.5 }\nplanes = [{ normal = [-1, 0, 0], offset = -0.501 }]")
        .unwrap();
}

#[test]
fn a_view_aligned_plane_keeps_the_far_side_of_the_look_at_point() {
    // The camera looks along +x at the centre: a view plane with normal [0, 0, 1] (forward)
    // through the look-at point is the world plane x = 0.5, whatever the camera's up.
    let view = scene(
        "",
        "[clip]\nspace = \"view\"\nplane = { normal = [0, 0, 1], offset = 0 }",
        false,
    );
    let world = scene("", CLIP_PLANE, false);
    let medium = view.medium();
    assert_eq!(medium.density(Vec3::new(0.49, 0.5, 0.5)), 0.0);
    assert!(medium.density(Vec3::new(0.51, 0.5, 0.5)) > 0.0);
    let ray = Ray::new(Vec3::new(-1.0, 0.37, 0.61), Vec3::X);
    let (a, b) = (
        medium.clip(&ray).unwrap(),
        world.medium().clip(&ray).unwrap(),
    );
    assert!(
        (a.0 - b.0).abs() < 1e-5 && (a.1 - b.1).abs() < 1e-5,
        "{a:?} {b:?}"
    );
    // An offset towards the eye by more than the volume's radius keeps it whole.
    let whole = scene(
        "",
        "[clip]\nspace = \"view\"\nplane = { normal = [0, 0, 1], offset = -1 }",
        false,
    );
    assert!(whole.medium().density(Vec3::new(0.05, 0.5, 0.5)) > 0.0);
    // A crop box has no meaning in the view's frame.
    let params = volphot::SceneParams::from_toml(
        "[volume]\nphantom = { name = \"constant\", resolution = [4, 4, 4] }\n[three_point]\n[clip]\nspace = \"view\"\nbox = { p0 = [0, 0, 0], p1 = [1, 1, 1] }\n",
        std::path::Path::new("inline.toml"),
    );
    let err = params
        .and_then(|p| {
            volphot::Scene::from_params(
                &p,
                std::path::Path::new("."),
                &volphot::SearchPath::new(vec![]),
            )
        })
        .unwrap_err()
        .to_string();
    assert!(err.contains("clip.box"), "{err}");
}
