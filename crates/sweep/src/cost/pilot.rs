//! `sweep plan`'s pilot renders: each march group rendered at a few hundred pixels on this
//! machine, timed, and scaled to the cells' size.
//!
//! A model calibrated once on one frame misses what a cell's settings and this machine
//! do to its cost: the default shadow tolerance fills the optical depth twice as densely
//! as the one the constants were measured at, a thin medium lets eye rays cross the whole
//! volume, and the same build ran 1.4× slower on one day than on another
//! (`reports/REPRODUCTION.md`). A pilot measures the group's own per-pixel cost instead:
//! the same `render_shared` call a run makes, on an image of at most `PILOT_SIDE` pixels a
//! side (`ITERATED_PILOT_SIDE` for progressive and beam renders) of the same view, with
//! the photon maps at their full size (their cost does not depend on the image). What
//! does not scale with the pixels is timed apart and added unscaled: loading
//! and preparing the media, tracing and indexing each photon map, and the pass that measures
//! thinning's error on up to 32 × 32 probe pixels (left out of the pilot, and charged at
//! the pilot's per-pixel cost: [`error_probe_rays`] eye rays per probe pixel).
//!
//! Measured against the committed `--paper` studies (`reports/REPRODUCTION.md`, "How far to
//! trust the estimate"): two studies rendered from scratch right after their plans took
//! 0.86× and 0.87× of the estimate, and the committed point-estimate studies 0.90–1.12×
//! (per study, render and photon maps), except two rendered on an afternoon this machine
//! ran 1.4× slower (1.5×): a pilot measures the machine as it is when it plans.
//!
//! A progressive render's later passes gather in a ball that shrinks every iteration
//! (`r³` by `(i + α)/(i + 1)`), and a ball holds photons in proportion to its volume, so
//! their cost falls as the iterations go on. Charging every one at the second iteration's
//! cost over-estimated 16 iterations by 1.2× and 64 by 1.5×. A progressive pilot of more
//! than two iterations is therefore rendered twice: as the cell starts, and with its
//! second iteration at the cell's last radius; each later pass is charged by linear
//! interpolation in `r³` between the two (a per-gather part that does not shrink, and a
//! per-photon part that shrinks with the ball). Beam renders, whose radii are per-photon
//! scales, are still charged at their second iteration's cost.

use std::path::Path;
use std::time::Instant;

use anyhow::Result;
use volphot::{
    Control, InitialRadius, IntegratorParams, ProgressiveStats, SceneParams, SearchPath,
    error_probe_pixels, next_radius,
};

use crate::plan::CellSpec;
use crate::render::Caches;

/// Pixels along the pilot image's longer side.
pub(crate) const PILOT_SIDE: u32 = 32;

/// Pixels along the longer side of a progressive or beam pilot: a later pass shades a
/// first march's samples again with no march of its own, 3–10 ms at 32² on the thesis's
/// foot, where what a pass costs whatever its pixels is scaled by the pixel ratio with it
/// (256 at 32², 64 at 64²). `sweep plan experiments/alpha.toml --paper` against the 571 s
/// of wall time its committed run spent beyond its references: 1 017 and 1 034 s at 32²,
/// 729–826 s in six plans at 64². One cell's estimate still differs by up to 1.6× between
/// two plans at either size (timing noise).
pub(crate) const ITERATED_PILOT_SIDE: u32 = 64;

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

/// The pilot image's size for a `[w, h]` image (the same aspect, at most `pilot_side` a
/// side, never larger than the image), and how many times its pixels the image has.
fn pilot_size([w, h]: [u32; 2], pilot_side: u32) -> ([u32; 2], f64) {
    let scale = (pilot_side as f64 / w.max(h) as f64).min(1.0);
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

/// The radius of each later iteration `2 ..= iterations` of a render whose second iteration
/// gathers at `second`.
fn later_radii(second: f32, i: &IntegratorParams) -> Vec<f32> {
    let mut radius = second;
    (2..=i.iterations.max(2))
        .map(|k| {
            let this = radius;
            radius = next_radius(radius, k, i.alpha, i.estimator);
            this
        })
        .collect()
}

/// A pilot of the progressive render `i` whose second iteration gathers at `radius` (the
/// cell's last): its first starts at the radius whose successor that is. Only that second
/// pass is used, which shades the multiple layer alone, so the first pass renders no
/// direct layers either.
fn last_radius_pilot(i: &IntegratorParams, radius: f32) -> IntegratorParams {
    let mut pilot = pilot_integrator(i);
    pilot.initial_radius = InitialRadius::Maxdist;
    pilot.maxdist = radius / next_radius(1.0, 1, i.alpha, i.estimator);
    (pilot.single, pilot.emission) = (false, false);
    pilot
}

/// Whether a progressive pilot of `i` is also rendered at the last iteration's radius: the
/// point estimate's ball shrinks past the second iteration.
fn pilots_last_radius(i: &IntegratorParams) -> bool {
    i.estimator.pilots_last_radius() && i.multiple && i.iterations > PILOT_ITERATIONS
}

/// The seconds of each later pass of a progressive or beam render, at the pilot's size:
/// the pilot's second pass `p` where the radius does not shrink (or nothing measured
/// it), else interpolated in `r³` between it and `last`, the second pass of a pilot at
/// the last iteration's radius.
fn later_pass_seconds(
    p: &ProgressiveStats,
    last: Option<&ProgressiveStats>,
    i: &IntegratorParams,
) -> Vec<f64> {
    let first = p.march_seconds_each.first().copied().unwrap_or(0.0);
    let second = p.march_seconds_each.get(1).copied().unwrap_or(first);
    let later = i.iterations.max(1) as usize - 1;
    let at_last = last.and_then(|l| Some((*l.radii.get(1)?, *l.march_seconds_each.get(1)?)));
    let (Some(&r2), Some((r_last, seconds_last))) = (p.radii.get(1), at_last) else {
        return vec![second; later];
    };
    let (v2, v_last) = ((r2 as f64).powi(3), (r_last as f64).powi(3));
    if v2 - v_last <= f64::EPSILON * v2 {
        return vec![second; later];
    }
    later_radii(r2, i)
        .iter()
        .take(later)
        .map(|&r| {
            let f = (((r as f64).powi(3) - v_last) / (v2 - v_last)).clamp(0.0, 1.0);
            seconds_last + f * (second - seconds_last)
        })
        .collect()
}

/// The seconds of a progressive or beam render of `i.iterations`, from a pilot's
/// iterations `p` (and `last`, see [`later_pass_seconds`]): the first pass scaled by
/// `first_scale` (pixels and error probes), each later one scaled by the pixels, and one
/// photon map per iteration; a time budget stops it after the iteration that spends it.
fn iterated_seconds(
    p: &ProgressiveStats,
    last: Option<&ProgressiveStats>,
    i: &IntegratorParams,
    first_scale: f64,
    ratio: f64,
) -> f64 {
    let passes = p.march_seconds_each.len().max(1) as f64;
    let first = p.march_seconds_each.first().copied().unwrap_or(0.0);
    let per_map = (p.photon_seconds + p.tree_seconds) * photon_scale(i) / passes;
    let later = later_pass_seconds(p, last, i);
    let mut elapsed = first * first_scale + per_map;
    let budget = f64::from(i.time_budget);
    for pass in later {
        // The budget is checked after each iteration: the one that spends it completes.
        if budget > 0.0 && elapsed > budget {
            break;
        }
        elapsed += pass * ratio + per_map;
    }
    elapsed
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
        let iterated = cells.iter().any(|c| c.params.integrator.iterates());
        let side = if iterated {
            ITERATED_PILOT_SIDE
        } else {
            PILOT_SIDE
        };
        let (size, ratio) = pilot_size(full, side);
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
        let mut costs = Vec::with_capacity(cells.len());
        for (cell, film) in cells.iter().zip(&shared.films) {
            let i = &cell.params.integrator;
            // A shared map is traced once for all the variants it serves.
            let map = (film.photon_seconds + film.tree_seconds) * photon_scale(i)
                / film.map_shared_by.max(1) as f64;
            costs.push(match (&film.progressive, i.iterates()) {
                (Some(p), true) => {
                    let last = self.at_last_radius(&scene, i, p)?;
                    iterated_seconds(p, last.as_ref(), i, march_scale(i), ratio) + record
                }
                _ => shared.render_seconds * march_scale(i) / n + map + record,
            });
        }
        Ok(costs)
    }

    /// The pilot of the progressive render `i` (at `scene`'s pilot size) with its second
    /// iteration at the last iteration's radius, when `i` iterates past the two iterations
    /// `p` (the pilot as the cell starts) measured: see [`later_pass_seconds`].
    fn at_last_radius(
        &mut self,
        scene: &volphot::Scene,
        i: &IntegratorParams,
        p: &ProgressiveStats,
    ) -> Result<Option<ProgressiveStats>> {
        let Some(&second) = p.radii.get(1).filter(|_| pilots_last_radius(i)) else {
            return Ok(None);
        };
        let last = *later_radii(second, i)
            .last()
            .expect("at least one later iteration");
        let start = Instant::now();
        let control = Control::none().without_error_probes();
        let pilot = last_radius_pilot(i, last);
        let mut shared = volphot::render_shared(scene, std::slice::from_ref(&pilot), &control)?;
        self.seconds += start.elapsed().as_secs_f64();
        self.renders += 1;
        Ok(shared.films.pop().and_then(|film| film.progressive))
    }

    /// The wall-clock seconds of the path-traced reference `params` at its own size and
    /// samples per pixel, from a pilot at `PILOT_REFERENCE_SPP`.
    pub(crate) fn reference(&mut self, params: &SceneParams, base: &Path) -> Result<f64> {
        let start = Instant::now();
        let full = params.camera.resolution;
        let (size, ratio) = pilot_size(full, PILOT_SIDE);
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
    use volphot::MsEstimator;

    #[test]
    fn the_pilot_keeps_the_aspect_and_never_exceeds_the_image() {
        assert_eq!(pilot_size([512, 512], 32), ([32, 32], 256.0));
        assert_eq!(pilot_size([512, 512], 64), ([64, 64], 64.0));
        let ([w, h], ratio) = pilot_size([640, 320], 32);
        assert_eq!([w, h], [32, 16]);
        assert!((ratio - 400.0).abs() < 1e-9);
        assert_eq!(pilot_size([16, 8], 32), ([16, 8], 1.0));
        assert_eq!(pilot_size([4000, 1], 32).0, [32, 1]);
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
        // Six iterations are piloted twice (as they start and at the last radius).
        assert_eq!(pilots.renders, 4);
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

    /// Progressive stats of a pilot: its two iterations' radii and seconds.
    fn two_passes(radii: [f32; 2], seconds: [f64; 2]) -> ProgressiveStats {
        ProgressiveStats {
            radii: radii.to_vec(),
            march_seconds_each: seconds.to_vec(),
            ..Default::default()
        }
    }

    fn progressive(iterations: u32) -> IntegratorParams {
        IntegratorParams {
            estimator: MsEstimator::Progressive,
            iterations,
            alpha: 0.5,
            ..Default::default()
        }
    }

    #[test]
    fn the_last_radius_pilot_gathers_at_the_last_radius_in_its_second_iteration() {
        let i = progressive(16);
        let radii = later_radii(0.02, &i);
        assert_eq!(radii.len(), 15);
        assert_eq!(radii[0], 0.02);
        assert!(radii.windows(2).all(|w| w[1] < w[0]), "{radii:?}");
        // r³ shrinks by (k + α)/(k + 1) from iteration k to k + 1.
        let ratio = (radii[1] / radii[0]).powi(3);
        assert!((ratio - 2.5 / 3.0).abs() < 1e-5, "{ratio}");
        let last = radii[14];
        let pilot = last_radius_pilot(&i, last);
        assert_eq!(pilot.initial_radius, InitialRadius::Maxdist);
        assert_eq!(pilot.iterations, PILOT_ITERATIONS);
        assert!(pilot.multiple && !pilot.single && !pilot.emission);
        let second = next_radius(pilot.maxdist, 1, i.alpha, i.estimator);
        assert!((second / last - 1.0).abs() < 1e-6, "{second} vs {last}");
        assert!(pilots_last_radius(&i));
        assert!(!pilots_last_radius(&progressive(2)));
        let beam = IntegratorParams {
            estimator: MsEstimator::Beam,
            ..progressive(16)
        };
        assert!(!pilots_last_radius(&beam));
    }

    #[test]
    fn later_passes_are_interpolated_in_the_ball_volume_between_the_two_pilots() {
        let i = progressive(16);
        let radii = later_radii(0.02, &i);
        let p = two_passes([0.025, 0.02], [3.0, 1.0]);
        let last = two_passes([0.01, radii[14]], [2.0, 0.4]);
        let passes = later_pass_seconds(&p, Some(&last), &i);
        assert_eq!(passes.len(), 15);
        assert!((passes[0] - 1.0).abs() < 1e-9 && (passes[14] - 0.4).abs() < 1e-6);
        assert!(passes.windows(2).all(|w| w[1] < w[0]), "{passes:?}");
        // Linear in r³: the pass whose ball is halfway in volume costs halfway.
        let (v2, v_last) = (0.02f64.powi(3), (radii[14] as f64).powi(3));
        for (r, s) in radii.iter().zip(&passes) {
            let f = ((*r as f64).powi(3) - v_last) / (v2 - v_last);
            assert!((s - (0.4 + 0.6 * f)).abs() < 1e-6, "{r}: {s}");
        }
        // Without the second pilot every later pass costs the second iteration's.
        assert_eq!(later_pass_seconds(&p, None, &i), vec![1.0; 15]);
        // The total: the first pass scaled, the later ones at the pixel ratio.
        let total = iterated_seconds(&p, Some(&last), &i, 2.0, 10.0);
        let expected = 3.0 * 2.0 + 10.0 * passes.iter().sum::<f64>();
        assert!((total - expected).abs() < 1e-9, "{total} vs {expected}");
        assert!(total < iterated_seconds(&p, None, &i, 2.0, 10.0));
    }

    #[test]
    fn a_time_budget_stops_after_the_iteration_that_spends_it() {
        let mut i = progressive(16);
        i.time_budget = 25.0;
        let p = two_passes([0.025, 0.02], [3.0, 1.0]);
        // 6 s, then 10 s per later pass: 16 and 26 s after two and three iterations.
        assert_eq!(iterated_seconds(&p, None, &i, 2.0, 10.0), 26.0);
        i.time_budget = 0.0;
        assert_eq!(iterated_seconds(&p, None, &i, 2.0, 10.0), 156.0);
    }
}
