//! Criterion benchmarks of the renderer's phases on the foot phantom (runs anywhere), plus
//! the thesis's headline frame on the real foot when the data is present:
//!
//! ```sh
//! cargo bench -p volphot-core                      # all groups
//! VOLPHOT_DATA=../shared/data cargo bench -p volphot-core -- headline
//! ```
//!
//! The CLI equivalent with JSON output is `sweep bench`.

use std::hint::black_box;
use std::path::Path;

use criterion::{Criterion, criterion_group, criterion_main};
use glam::Vec3;
use volphot::Control;
use volphot::Phase;
use volphot::SearchPath;
use volphot::build_photon_map;
use volphot::render_march;
use volphot::{FreePath, IntegratorParams};
use volphot::{GatherScratch, GatherVariant, Gathered, PhotonMap};
use volphot::{Scene, SceneParams, load_params};
use volphot::{TraceSettings, trace};

fn phantom_scene(resolution: u32) -> Scene {
    let src = format!(
        r#"
[volume]
phantom = {{ name = "foot", resolution = [128, 128, 128] }}
[transfer]
kind = "points"
points = [[0.0, 0.0], [0.2999, 0.0], [0.3, 0.3], [1.0, 1.0]]
[sigma]
t = 80
albedo = 0.8181818
[camera]
eye = [2.0, -1.4, 1.6]
look_at = [0.5, 0.5, 0.5]
up = [0, 0, 1]
resolution = [{resolution}, {resolution}]
[three_point]
[integrator]
volume_photons = 40000
nused = 150
maxdist = 0.1
stepsize = 0.0005
"#
    );
    let params = SceneParams::from_toml(&src, Path::new("bench.toml")).expect("bench scene");
    Scene::from_params(&params, Path::new("."), &SearchPath::new(vec![]))
        .expect("bench scene builds")
}

fn phases(c: &mut Criterion) {
    let scene = phantom_scene(128);
    let mut group = c.benchmark_group("phases");
    group.sample_size(10);
    for (name, free_path) in [("delta", FreePath::Delta), ("thesis", FreePath::Thesis)] {
        group.bench_function(format!("trace_40k_photons_{name}"), |b| {
            b.iter(|| {
                trace(
                    scene.medium(),
                    scene.lights(),
                    &TraceSettings {
                        photons: 40_000,
                        stored_target: 0,
                        free_path,
                        stepsize: 0.0005,
                        seed: 1,
                    },
                    &Control::none(),
                )
                .expect("traces")
            })
        });
    }
    let map = build_photon_map(&scene, &Control::none()).unwrap();
    let photons = map.photons().to_vec();
    let stats = map.stats().clone();
    group.bench_function("kd_tree_build", |b| {
        b.iter(|| PhotonMap::new(black_box(photons.clone()), stats.clone()))
    });
    let variants = [GatherVariant {
        nused: 150,
        maxdist: 0.1,
        gathered: Gathered::Fluence,
    }];
    let mut scratch = GatherScratch::default();
    let mut out = [Vec3::ZERO];
    let points: Vec<Vec3> = map
        .photons()
        .iter()
        .step_by(97)
        .take(256)
        .map(|p| p.position)
        .collect();
    group.bench_function("radiance_estimate_nused_150", |b| {
        b.iter(|| {
            for p in &points {
                map.estimates(
                    *p,
                    Vec3::X,
                    Phase::ISOTROPIC,
                    &variants,
                    &mut scratch,
                    &mut out,
                );
            }
            black_box(out[0])
        })
    });
    for (name, cache) in [("uncached", 0u32), ("cached", 128)] {
        let s = scene
            .with_integrator(IntegratorParams {
                shadow_cache: cache,
                ms_cache: cache,
                ..scene.integrator().clone()
            })
            .expect("valid settings");
        group.bench_function(format!("march_128px_{name}"), |b| {
            b.iter(|| render_march(&s, &[&map], &[], &Control::none()).expect("renders"))
        });
    }
    group.finish();
}

/// The thesis's headline frame (foot 256³, 512², 40 000 photons, nused 150), cached.
fn headline(c: &mut Criterion) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../experiments/scenes/foot.toml");
    let search = SearchPath::from_env()
        .with_extra([Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data")]);
    let Ok((params, _)) = load_params(&path) else {
        return;
    };
    let Ok(scene) = Scene::from_params(&params, path.parent().expect("scene dir"), &search) else {
        eprintln!(
            "headline: the real foot dataset is not on the search path; skipped (set VOLPHOT_DATA)"
        );
        return;
    };
    let scene = scene
        .with_integrator(IntegratorParams {
            shadow_cache: 128,
            ms_cache: 128,
            ..scene.integrator().clone()
        })
        .expect("valid settings");
    let mut group = c.benchmark_group("headline");
    group.sample_size(10);
    group.bench_function("foot_512px_40k_nused150_cached", |b| {
        b.iter(|| {
            let map = build_photon_map(&scene, &Control::none()).unwrap();
            render_march(&scene, &[&map], &[], &Control::none()).expect("renders")
        })
    });
    group.finish();
}

criterion_group!(benches, phases, headline);
criterion_main!(benches);
