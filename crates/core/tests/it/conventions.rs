//! Conventions pinned by images: an asymmetric phantom lands where expected.

use volphot::test_util as common;

use glam::Vec3;
use volphot::Control;
use volphot::Layer;
use volphot::render_march;

#[test]
fn orientation_phantom_lands_where_expected() {
    // Looking down −z with +y up: +x must appear on the right, +y at the top (row 0).
    let scene = common::scene(
        r#"
[volume]
phantom = { name = "orientation", resolution = [48, 48, 48] }
[sigma]
t = 40
[camera]
eye = [0.5, 0.5, 3.0]
look_at = [0.5, 0.5, 0.5]
up = [0, 1, 0]
fov = 30
resolution = [64, 64]
[[lights]]
type = "point"
position = [0.5, 0.5, 3.0]
intensity = 30
[integrator]
multiple = false
stepsize = 0.002
"#,
    );
    let film = &render_march(&scene, &[], &[], &Control::none())
        .unwrap()
        .films[0];
    let camera = scene.camera();
    let brightness = |p: Vec3| {
        let (x, y) = camera.project(p).unwrap();
        let (x, y) = (x as usize, y as usize);
        film.layer(Layer::Single)[y * film.width() + x].x
    };
    let (cube, mirror) = (
        brightness(Vec3::new(0.8, 0.5, 0.5)),
        brightness(Vec3::new(0.2, 0.5, 0.5)),
    );
    let (sphere, below) = (
        brightness(Vec3::new(0.5, 0.8, 0.5)),
        brightness(Vec3::new(0.5, 0.2, 0.5)),
    );
    assert!(
        cube > 0.0 && mirror == 0.0,
        "cube at +x: {cube} vs mirror {mirror}"
    );
    assert!(
        sphere > 0.0 && below == 0.0,
        "sphere at +y: {sphere} vs below {below}"
    );
    let (cx, _) = camera.project(Vec3::new(0.8, 0.5, 0.5)).unwrap();
    assert!(cx > 32.0, "+x is on the image's right half");
    let (_, sy) = camera.project(Vec3::new(0.5, 0.8, 0.5)).unwrap();
    assert!(sy < 32.0, "+y is in the top half (row 0 at the top)");
}
