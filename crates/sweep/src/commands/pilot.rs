//! `sweep plan`'s pilot renders: each march group rendered at a few hundred pixels on this
//! machine, timed, and scaled to the cells' size.
//!
//! A model calibrated once on one frame misses what a cell's settings and this machine
//! do to its cost: the default shadow tolerance fills the optical depth twice as densely
//! as the one the constants were measured at, a thin medium lets eye rays cross the whole
//! volume, and the same build ran 1.4× slower on one day than on another
//! (`reports/REPRODUCTION.md`). A pilot measures the group's own per-pixel cost instead:
//! the same `render_shared` call a run makes, on a `PILOT_SIDE`-pixel image of the same
//! view, with the photon maps at their full size (their cost does not depend on the
//! image). What does not scale with the pixels is timed apart and added unscaled: loading
//! and preparing the media, tracing and indexing each photon map, and the pass that measures
//! thinning's error on up to 32 × 32 probe pixels (left out of the pilot, and charged at
//! the pilot's per-pixel cost: [`error_probe_rays`] eye rays per probe pixel).
//!
//! Measured against the committed `--paper` studies (`reports/REPRODUCTION.md`, "How far to
//! trust the estimate"): two studies rendered from scratch right after their plans took
//! 0.86× and 0.87× of the estimate, and the committed point-estimate studies 0.90–1.12×
//! (per study, render and photon maps), except two rendered on an afternoon this machine
//! ran 1.4× slower (1.5×): a pilot measures the machine as it is when it plans.
//! Progressive renders are over-estimated, by 1.2× over 16 iterations and 1.5× over 64:
//! every later pass is charged at the second iteration's, whose gather radius is the
//! largest of them.

use std::path::Path;
use std::time::Instant;

use anyhow::Result;
use volphot::{
    Control, IntegratorParams, ProgressiveStats, SceneParams, SearchPath, error_probe_pixels,
};

use crate::plan::CellSpec;
use crate::render::Caches;

/// Pixels along the pilot image's longer side.
pub(crate) const PILOT_SIDE: u32 = 32;

/// Iterations a progressive or beam pilot renders: the first pass (every layer) and one
/// later pass (the multiple layer alone), each timed; the rest are the later pass again.
const PILOT_ITERATIONS: u32 = 2;

/// Samples per pixel a reference pilot traces.
const PILOT_REFERENCE_SPP: u32 = 4;

/// Eye rays the error pass traces per probe pixel, at the image's per-pixel cost: thinning
/// traces each probe pixel twice (as rendered, and with every sample evaluated, which costs
/// more: counting it once is the lower bound), the caches' check once more.
fn error_probe_rays(i: &IntegratorParams) -> f64 {
    let thinning = if i.thin_below > 0.0 { 2.0 } else { 0.0 };
    let caches = if i.shadow_cache > 0 || i.ms_cache > 0 {
        1.0
    } else {
        0.0
    };
    thinning + caches
}

/// The pilot image's size for a `[w, h]` image (the same aspect, at most `PILOT_SIDE` a
/// side, never larger than the image), and how many times its pixels the image has.
fn pilot_size([w, h]: [u32; 2]) -> ([u32; 2], f64) {
    let scale = (PILOT_SIDE as f64 / w.max(h) as f64).min(1.0);
    let side = |n: u32| ((n as f64 * scale).round() as u32).max(1);
    let size = [side(w), side(h)];
    let ratio = (w as f64 * h as f64) / (size[0] as f64 * size[1] as f64);
    (size, ratio)
}

/// Photons a pilot traces per map at most: a larger map is traced at this size and its
/// tracing and indexing time scaled up by the ratio (both are linear in the photons, to
/// a logarithm), so that a plan of a billion-photon cell does not trace it.
const PILOT_MAX_PHOTONS: u64 = 1_000_000;

/// A cell's integrator settings as its pilot renders them: at most two iterations, no
/// stopping rule that needs a reference or a clock, and at most `PILOT_MAX_PHOTONS` per
/// map.
fn pilot_integrator(i: &IntegratorParams) -> IntegratorParams {
    let mut pilot = i.clone();
    pilot.iterations = i.iterations.clamp(1, PILOT_ITERATIONS);
    pilot.target_rmse = 0.0;
    pilot.time_budget = 0.0;
    pilot.volume_photons = i.volume_photons.min(PILOT_MAX_PHOTONS);
    pilot.photons_per_iteration = i.photons_per_iteration.min(PILOT_MAX_PHOTONS);
    pilot
}

/// How many times the photons of the pilot's map the cell's map has.
fn photon_scale(i: &IntegratorParams) -> f64 {
    let per_map = |i: &IntegratorParams| {
        if i.iterates() && i.photons_per_iteration > 0 {
            i.photons_per_iteration
        } else {
            i.volume_photons
        }
    };
    per_map(i) as f64 / per_map(&pilot_integrator(i)).max(1) as f64
}

/// The seconds of a progressive or beam render of `i.iterations`, from a pilot's
/// iterations `p`: the first pass scaled by `first_scale` (pixels and error probes), each
/// later one as the pilot's second scaled by the pixels, and one photon map per iteration;
/// a time budget stops it after the iteration that spends it.
fn iterated_seconds(
    p: &ProgressiveStats,
    i: &IntegratorParams,
    first_scale: f64,
    ratio: f64,
) -> f64 {
    let passes = p.march_seconds_each.len().max(1) as f64;
    let first = p.march_seconds_each.first().copied().unwrap_or(0.0);
    let later = p.march_seconds_each.get(1).copied().unwrap_or(first);
    let per_map = (p.photon_seconds + p.tree_seconds) * photon_scale(i) / passes;
    let iterations = i.iterations.max(1) as f64;
    let all = first * first_scale + (iterations - 1.0) * (later * ratio + per_map) + per_map;
    let budget = f64::from(i.time_budget);
    if budget > 0.0 {
        all.min(budget + later * ratio + per_map)
    } else {
        all
    }
}

/// Pilot renders of a plan's groups and references, with the scenes they loaded.
#[derive(Default)]
pub(crate) struct Pilots {
    caches: Caches,
    /// Seconds spent getting the pilots' scenes: each medium loaded and prepared once,
    /// then taken from the cache, as a run gets its groups' scenes.
    pub(crate) setup_seconds: f64,
    /// Wall-clock seconds the pilots took.
    pub(crate) seconds: f64,
    /// Pilot renders made.
    pub(crate) renders: usize,
}

impl Pilots {
    /// The scene of `params`, its medium prepared (loaded and prepared on first use; a
    /// medium already prepared returns at once).
    fn scene(&mut self, params: &SceneParams, base: &Path) -> Result<volphot::Scene> {
        let start = Instant::now();
        let scene = self.caches.scene(params, base, &SearchPath::from_env())?;
        scene.medium().prepare();
        self.setup_seconds += start.elapsed().as_secs_f64();
        Ok(scene)
    }

    /// The wall-clock seconds each cell of a march group costs at its own size (its share
    /// of the shared march, its photon maps and iterations), from one pilot render of the
    /// group. `cells` share a march key (or are one cell).
    pub(crate) fn group(&mut self, cells: &[&CellSpec], record: f64) -> Result<Vec<f64>> {
        let start = Instant::now();
        let first = cells[0];
        let full = first.params.camera.resolution;
        let (size, ratio) = pilot_size(full);
        let mut params = first.params.clone();
        params.camera.resolution = size;
        params.integrator = pilot_integrator(&params.integrator);
        params.integrator.multiple = cells.iter().any(|c| c.params.integrator.multiple);
        let scene = self.scene(&params, &first.base_dir)?;
        let integrators: Vec<_> = cells
            .iter()
            .map(|c| pilot_integrator(&c.params.integrator))
            .collect();
        let control = Control::none().without_error_probes();
        let shared = volphot::render_shared(&scene, &integrators, &control)?;
        self.seconds += start.elapsed().as_secs_f64();
        self.renders += 1;
        let pilot_pixels = size[0] as f64 * size[1] as f64;
        let probe_rays = error_probe_pixels(full[0], full[1]) as f64;
        // The shared march: the image's pixels and the error pass's probe rays.
        let march_scale =
            |i: &IntegratorParams| ratio + error_probe_rays(i) * probe_rays / pilot_pixels;
        let n = cells.len() as f64;
        let record = record * full[0] as f64 * full[1] as f64;
        let costs = cells
            .iter()
            .zip(&shared.films)
            .map(|(cell, film)| {
                let i = &cell.params.integrator;
                // A shared map is traced once for all the variants it serves.
                let map = (film.photon_seconds + film.tree_seconds) * photon_scale(i)
                    / film.map_shared_by.max(1) as f64;
                match (&film.progressive, i.iterates()) {
                    (Some(p), true) => iterated_seconds(p, i, march_scale(i), ratio) + record,
                    _ => shared.render_seconds * march_scale(i) / n + map + record,
                }
            })
            .collect();
        Ok(costs)
    }

    /// The wall-clock seconds of the path-traced reference `params` at its own size and
    /// samples per pixel, from a pilot at `PILOT_REFERENCE_SPP`.
    pub(crate) fn reference(&mut self, params: &SceneParams, base: &Path) -> Result<f64> {
        let start = Instant::now();
        let full = params.camera.resolution;
        let (size, ratio) = pilot_size(full);
        let spp = params.integrator.reference_spp.max(1);
        let mut pilot = params.clone();
        pilot.camera.resolution = size;
        pilot.integrator.reference_spp = spp.min(PILOT_REFERENCE_SPP);
        let scene = self.scene(&pilot, base)?;
        let out = volphot::render(&scene, &Control::none())?;
        self.seconds += start.elapsed().as_secs_f64();
        self.renders += 1;
        let samples = f64::from(spp) / f64::from(pilot.integrator.reference_spp);
        Ok(out.record.timings.render * ratio * samples)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_pilot_keeps_the_aspect_and_never_exceeds_the_image() {
        assert_eq!(pilot_size([512, 512]), ([32, 32], 256.0));
        let ([w, h], ratio) = pilot_size([640, 320]);
        assert_eq!([w, h], [32, 16]);
        assert!((ratio - 400.0).abs() < 1e-9);
        assert_eq!(pilot_size([16, 8]), ([16, 8], 1.0));
        assert_eq!(pilot_size([4000, 1]).0, [32, 1]);
    }

    /// The cells of an experiment on the sphere phantom at `resolution`: two nused sharing a
    /// march, and progressive renders of 1 and 6 iterations.
    fn cells(dir: &Path, resolution: u32) -> Vec<CellSpec> {
        let scene = format!(
            "{}[camera]\nresolution = [{resolution}, {resolution}]\n[integrator]\nvolume_photons = 2000\nstepsize = 0.01\n",
            volphot::test_util::SMALL_SCENE
        );
        std::fs::write(dir.join("s.toml"), scene).unwrap();
        let exp = r#"scene = "s.toml"
[[zip]]
"integrator.estimator" = ["points", "points", "progressive", "progressive"]
"integrator.nused" = [10, 40, 10, 10]
"integrator.iterations" = [1, 1, 1, 6]
"#;
        std::fs::write(dir.join("e.toml"), exp).unwrap();
        let exp = crate::plan::Experiment::load(&dir.join("e.toml")).unwrap();
        exp.plan_with_hashes(crate::plan::Quality::Default, false)
            .unwrap()
            .0
    }

    #[test]
    fn a_pilot_costs_each_cell_and_more_iterations_cost_more() {
        let tmp = tempfile::tempdir().unwrap();
        let cells = cells(tmp.path(), 96);
        let mut pilots = Pilots::default();
        let points = pilots.group(&[&cells[0], &cells[1]], 0.0).unwrap();
        assert_eq!(points.len(), 2, "one cost per cell of the shared march");
        assert!(
            points.iter().all(|s| s.is_finite() && *s > 0.0),
            "{points:?}"
        );
        let one = pilots.group(&[&cells[2]], 0.0).unwrap()[0];
        let six = pilots.group(&[&cells[3]], 0.0).unwrap()[0];
        // Five more photon maps and later passes: strictly more, whatever the clock says.
        assert!(six > one, "{six} against {one}");
        assert_eq!(pilots.renders, 3);
        // The record's cost is added per cell, once.
        let with_record = pilots.group(&[&cells[2]], 1e-3).unwrap()[0];
        assert!(with_record > 96.0 * 96.0 * 1e-3, "{with_record}");
    }

    #[test]
    fn the_pilot_renders_two_iterations_and_no_stopping_rule() {
        let mut i = IntegratorParams {
            iterations: 16,
            target_rmse: 0.01,
            time_budget: 30.0,
            ..Default::default()
        };
        let p = pilot_integrator(&i);
        assert_eq!((p.iterations, p.target_rmse, p.time_budget), (2, 0.0, 0.0));
        i.iterations = 1;
        assert_eq!(pilot_integrator(&i).iterations, 1);
        // A map of ten million photons is piloted at one million and scaled.
        i.volume_photons = 10_000_000;
        assert_eq!(pilot_integrator(&i).volume_photons, PILOT_MAX_PHOTONS);
        assert!((photon_scale(&i) - 10.0).abs() < 1e-12);
        i.volume_photons = 40_000;
        assert_eq!(photon_scale(&i), 1.0);
    }
}
