//! The optional caches trade accuracy for speed; their error against the uncached path is
//! measured here and bounded.

use volphot::test_util as common;

use volphot::Control;
use volphot::IntegratorParams;
use volphot::Layer;
use volphot::build_photon_map;
use volphot::render_march;

const SCENE: &str = r#"
[volume]
phantom = { name = "foot", resolution = [64, 64, 64] }
[sigma]
t = 20
albedo = 0.8
[camera]
eye = [2.0, -1.4, 1.6]
look_at = [0.5, 0.5, 0.5]
up = [0, 0, 1]
fov = 30
resolution = [64, 64]
[three_point]
key_intensity = 60
[integrator]
volume_photons = 20000
nused = 60
maxdist = 0.1
stepsize = 0.002
"#;

#[test]
fn cache_errors_are_measured_and_small() {
    let base = common::scene(SCENE);
    let map = build_photon_map(&base, &Control::none()).unwrap();
    let render = |shadow_cache: u32, ms_cache: u32| {
        let scene = base
            .with_integrator(IntegratorParams {
                shadow_cache,
                ms_cache,
                ..base.integrator().clone()
            })
            .unwrap();
        render_march(&scene, &[&map], &[], &Control::none()).unwrap()
    };
    let exact = render(0, 0);
    let shadow = render(96, 0);
    let scatter = render(0, 96);
    let single_err = common::relative_rmse(
        shadow.films[0].layer(Layer::Single),
        exact.films[0].layer(Layer::Single),
    );
    let multiple_err = common::relative_rmse(
        scatter.films[0].layer(Layer::Multiple),
        exact.films[0].layer(Layer::Multiple),
    );
    let mean_single =
        shadow.films[0].mean(Layer::Single) / exact.films[0].mean(Layer::Single) - 1.0;
    let mean_multiple =
        scatter.films[0].mean(Layer::Multiple) / exact.films[0].mean(Layer::Multiple) - 1.0;
    eprintln!(
        "shadow cache (96): single rRMSE {single_err:.4}, mean {mean_single:+.4}; ms cache (96): multiple rRMSE {multiple_err:.4}, mean {mean_multiple:+.4}"
    );
    // The shadow cache leaves the multiple layer untouched and vice versa.
    assert_eq!(
        shadow.films[0].layer(Layer::Multiple),
        exact.films[0].layer(Layer::Multiple)
    );
    assert_eq!(
        scatter.films[0].layer(Layer::Single),
        exact.films[0].layer(Layer::Single)
    );
    assert!(shadow.stats.shadow_cache_nodes > 0 && scatter.stats.ms_cache_nodes > 0);
    assert!(
        single_err < 0.15 && mean_single.abs() < 0.05,
        "shadow cache error {single_err} / {mean_single}"
    );
    assert!(
        multiple_err < 0.2 && mean_multiple.abs() < 0.05,
        "ms cache error {multiple_err} / {mean_multiple}"
    );
}
