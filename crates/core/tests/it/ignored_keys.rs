//! The `[integrator]` keys a render ignores ([`IntegratorParams::ignored_keys`]) are left
//! out of a cell's content address, so the table must be true: changing any of them leaves
//! the image bit for bit what it was, for every estimator and every structure of settings
//! that decides what is read. A wrong entry would give two different renders one address.

use volphot::test_util as common;
use volphot::{Control, Layer, render};

const SCENE: &str = r#"
[volume]
phantom = { name = "sphere", resolution = [16, 16, 16] }
[sigma]
t = 20
[camera]
resolution = [12, 12]
[three_point]
[integrator]
"#;

/// The `[integrator]` lines every render starts from; a test's lines replace them by key.
const BASE: [&str; 4] = [
    "volume_photons = 1500",
    "stepsize = 0.02",
    "iterations = 2",
    "nused = 12",
];

/// The scene with `lines` over [`BASE`] (a key given twice: the last one counts).
fn scene_text(lines: &str) -> String {
    let mut all: Vec<String> = BASE.iter().map(|l| l.to_string()).collect();
    for line in lines.lines().filter(|l| !l.trim().is_empty()) {
        let key = line.split('=').next().unwrap().trim();
        all.retain(|l| l.split('=').next().unwrap().trim() != key);
        all.push(line.to_string());
    }
    SCENE.replace(
        "[integrator]\n",
        &format!("[integrator]\n{}\n", all.join("\n")),
    )
}

/// Another valid value for `key`, as the TOML text of `[integrator]`.
fn other_value(key: &str) -> &'static str {
    match key {
        "tracker" => "tracker = \"delta\"",
        "reference_spp" => "reference_spp = 7",
        "volume_photons" => "volume_photons = 2500",
        "stored_photons" => "stored_photons = 3000",
        "nused" => "nused = 30",
        "maxdist" => "maxdist = 0.05",
        "free_path" => "free_path = \"thesis\"",
        "estimate" => "estimate = \"fluence\"",
        "ms_cache" => "ms_cache = 16",
        "estimator" => "estimator = \"progressive\"",
        "initial_radius" => "initial_radius = \"maxdist\"",
        "alpha" => "alpha = 0.6",
        "iterations" => "iterations = 3",
        "photons_per_iteration" => "photons_per_iteration = 700",
        "time_budget" => "time_budget = 1000",
        "target_rmse" => "target_rmse = 0.5",
        "radius" => "radius = \"nearest\"",
        "eye_rays" => "eye_rays = \"fresh\"",
        "light_samples" => "light_samples = 4",
        other => panic!("no other value for `{other}`"),
    }
}

/// Every layer of a render of `integrator` (the extra `[integrator]` lines).
fn layers(integrator: &str) -> Option<Vec<Vec<[u32; 3]>>> {
    layers_of(&scene_text(integrator))
}

/// Every layer of a render of the scene `text`, bit for bit.
fn layers_of(text: &str) -> Option<Vec<Vec<[u32; 3]>>> {
    let params = volphot::SceneParams::from_toml(text, std::path::Path::new("t.toml")).ok()?;
    volphot::validate_params(&params).ok()?;
    let scene = common::scene(text);
    let film = render(&scene, &Control::none()).ok()?.film;
    Some(
        Layer::ALL
            .iter()
            .map(|&l| {
                film.layer(l)
                    .iter()
                    .map(|v| [v.x.to_bits(), v.y.to_bits(), v.z.to_bits()])
                    .collect()
            })
            .collect(),
    )
}

#[test]
fn every_ignored_key_leaves_the_image_bit_identical() {
    let structures = [
        "multiple = false",
        "estimator = \"points\"",
        "estimator = \"progressive\"",
        "estimator = \"progressive\"\nphotons_per_iteration = 800\ninitial_radius = \"maxdist\"",
        "estimator = \"beam\"",
        "estimator = \"beam\"\nphotons_per_iteration = 800\ninitial_radius = \"maxdist\"",
        "estimator = \"plane\"",
        "estimator = \"plane\"\nphotons_per_iteration = 800",
    ];
    let mut compared = 0;
    for structure in structures {
        let base = layers(structure).unwrap_or_else(|| panic!("{structure} renders"));
        let params =
            volphot::SceneParams::from_toml(&scene_text(structure), std::path::Path::new("t.toml"))
                .unwrap();
        for key in params.ignored_integrator_keys() {
            let changed = format!("{structure}\n{}", other_value(key));
            // Some combinations are refused by validation (a cache with beams): nothing to
            // compare there.
            let Some(other) = layers(&changed) else {
                continue;
            };
            assert!(
                other == base,
                "`{key}` is listed as ignored under `{structure}`, but changing it changed the image"
            );
            compared += 1;
        }
    }
    assert!(compared >= 40, "only {compared} renders compared");
}

#[test]
fn a_key_that_is_read_changes_the_image() {
    // The test above can fail: keys that are read do change the picture.
    let base = layers("estimator = \"points\"").unwrap();
    for read in ["nused = 30", "maxdist = 0.05", "volume_photons = 2500"] {
        let other = layers(&format!("estimator = \"points\"\n{read}")).unwrap();
        assert!(other != base, "{read} should change a points render");
    }
}

/// Row 14 of the fifth reliability round: `light_samples` under spot lights only gave two
/// addresses of one image. It is ignored there (listed, and the image the same, above) and
/// read where a light has extent.
#[test]
fn light_samples_are_read_only_where_a_light_has_extent() {
    let spots = scene_text("");
    let params = volphot::SceneParams::from_toml(&spots, std::path::Path::new("t.toml")).unwrap();
    assert!(params.ignored_integrator_keys().contains(&"light_samples"));
    let cinematic = spots.replace("[three_point]\n", "[three_point]\nstyle = \"cinematic\"\n");
    let params =
        volphot::SceneParams::from_toml(&cinematic, std::path::Path::new("t.toml")).unwrap();
    assert!(!params.ignored_integrator_keys().contains(&"light_samples"));
    let more = cinematic.replace("[integrator]\n", "[integrator]\nlight_samples = 4\n");
    assert!(
        layers_of(&cinematic).unwrap() != layers_of(&more).unwrap(),
        "light_samples should change a render under an area light and a sky"
    );
    let unlit_single = cinematic.replace("[integrator]\n", "[integrator]\nsingle = false\n");
    let params =
        volphot::SceneParams::from_toml(&unlit_single, std::path::Path::new("t.toml")).unwrap();
    assert!(params.ignored_integrator_keys().contains(&"light_samples"));
}
