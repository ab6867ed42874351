//! What a plan costs: each cell's wall-clock seconds, measured by pilot renders on this
//! machine ([`pilot`]) or, with `--no-pilot` or where a scene cannot be loaded, from a
//! model calibrated on one frame (`sweep plan` prints it).

mod pilot;

use std::collections::{HashMap, HashSet};

use anyhow::Result;
use volphot::{
    EyeProbe, Method, PassCost, SceneParams, SearchPath, ShadowEstimator, probe_eye_rays,
};

use crate::plan::{CellSpec, Experiment, ReferenceMethod, reference_key, reference_params};
use crate::render::Caches;
use crate::store::ReferencePool;
use pilot::Pilots;

/// Wall-clock seconds on 2 cores, measured on the thesis's headline scene (real foot 256³,
/// σt(d_min) 80, three spot lights, 512²) in the `--paper` runs of `cost/` and `stepsize/`
/// (2026-12-02, commit 85f5af9; `reports/REPRODUCTION.md`, "At the thesis's resolution"):
/// the per-pixel costs at stepsize 0.0005. The speed-ups since are folded in as measured
/// (2026-12-04): one-thread headline renders of that build and of today's started together,
/// one per core, the same images (marked "today" below). They scale with the eye march's length in samples, probed on
/// each scene before planning (a dense medium stops the march early, a thin one lets it
/// cross the volume: `consistency --paper` took 0.36× the unprobed estimate at σt 290 and
/// 5.8× on the head at σt 6); marched shadow rays also grow with 1/stepsize.
mod calibration {
    /// Eye-march samples per ray on that frame (`volphot::probe_eye_rays`, 32 × 32
    /// rays): the costs below are per pixel at this march length.
    pub(super) const SAMPLES_PER_RAY: f64 = 28.1;
    /// Single scattering with the exact shadow integral, per pixel and light (single +
    /// multiple at nused 150 took 14.6 s, multiple alone 7.6 s, with three lights: 8.9e-6;
    /// today 0.76× that: 36.0 → 29.6 CPU-s with both layers, 19.4 → 17.0 multiple alone).
    pub(super) const SINGLE_EXACT: f64 = 6.8e-6;
    /// Single scattering with marched shadow rays (§6), per pixel and light (48e-6; today
    /// 0.97× at stepsize 0.0005: 106.5 → 103.7 CPU-s beside the multiple layer).
    pub(super) const SINGLE_MARCHED: f64 = 46.8e-6;
    /// Multiple scattering, per pixel: a fixed part and a part per photon gathered
    /// (15.4e-6; today 0.88×, as the multiple layer alone above).
    pub(super) const MULTIPLE: f64 = 13.5e-6;
    /// Multiple scattering, per pixel and photon of `nused` (0.068e-6; today 0.88×).
    pub(super) const MULTIPLE_PER_NUSED: f64 = 0.060e-6;
    /// One path-traced sample of a reference (1.0e-6; today 0.80×: 8 spp of the headline
    /// frame in 5.37 → 4.30 CPU-s).
    pub(super) const REFERENCE_SAMPLE: f64 = 0.80e-6;
    /// A cell's wall time beyond its render, per pixel: saving the film and its images,
    /// the metrics, its share of the report (the run's wall time less its cells' render,
    /// photon and tree times: `cost --paper`, 12 cells at 512², 0.63 s a cell on
    /// 2026-12-04 with the row-wise blur of the disco metric, 2.9 s before it).
    pub(super) const RECORD: f64 = 2.4e-6;
    /// A progressive iteration's fixed-radius gathers against the k-NN gathers of the same
    /// nused, and its eye march per pixel: each iteration marches every eye ray again, and
    /// thinning spaces out only the gathers (2026-12-04: the foot at 256², stepsize 0.001,
    /// nused 50, 24 against 8 iterations, `thin_below` 0 and 0.5, twice each: 0.62 s and
    /// 0.37 s an iteration, where the constants before said 0.33 s and 0.18 s; `alpha
    /// --paper` took 2.1× its estimate for the same reason).
    pub(super) const PROGRESSIVE_GATHER: f64 = 0.85;
    /// See [`PROGRESSIVE_GATHER`].
    pub(super) const PROGRESSIVE_MARCH: f64 = 2.7e-6;
    /// One beam-estimate pass, per pixel: the eye march and the photon spheres it crosses
    /// (`consistency/` at 512², 40 000 photons: 16 maps cost 0.21–0.57 s a map more than
    /// one, 0.42 s at the median on the foot and engine).
    pub(super) const BEAM_PASS: f64 = 1.6e-6;
    /// Tracing one photon and storing it.
    pub(super) const PHOTON: f64 = 1.0e-6;
    /// Cached transmittance and multiple scattering against the exact integrator
    /// (`sweep bench`: 3.84 s cached, 15.35 s exact).
    pub(super) const CACHED: f64 = 0.25;
}

/// Rough wall-clock cost of one cell on 2 cores, split into the part cells sharing a march
/// pay once (eye rays and single scattering) and the part every cell pays (its photon map
/// and its gathers). Real volumes and σ move it by a factor of a few (an opaque volume
/// stops eye rays early, a transparent one lets them run through): the estimate orders
/// plans, it does not promise times.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub(crate) struct CellCost {
    /// Seconds shared by the cells of one march group.
    pub(crate) march: f64,
    /// Seconds of this cell's own.
    pub(crate) own: f64,
}

impl CellCost {
    /// The cell rendered alone.
    pub(crate) fn alone(&self) -> f64 {
        self.march + self.own
    }
}

/// The estimated cost of one cell (see [`CellCost`]), given the scene's eye-march samples
/// and gathers per ray when it could be probed (else the calibration frame's, scaled by
/// the step). Where `thin_below` spaces gathers out, the shading costs scale by gathers
/// per sample (the optical-depth fills thin out alike, about as much).
pub(crate) fn estimate_cost(p: &SceneParams, probe: Option<EyeProbe>) -> CellCost {
    use calibration::*;
    let [w, h] = p.camera.resolution;
    let i = &p.integrator;
    let pixels = w as f64 * h as f64;
    if i.method == Method::Reference {
        return CellCost {
            march: 0.0,
            own: pixels * i.reference_spp as f64 * REFERENCE_SAMPLE,
        };
    }
    let eye_rays = pixels * i.spp.max(1) as f64;
    let steps = 0.0005 / i.stepsize as f64;
    let march_length = probe.map_or(steps, |e| e.samples / SAMPLES_PER_RAY);
    let shaded = probe.map_or(march_length, |e| e.gathers / SAMPLES_PER_RAY);
    let lights = (p.lights.len() + if p.three_point.is_some() { 3 } else { 0 }).max(1) as f64;
    let cache = |cached: bool| if cached { CACHED } else { 1.0 };
    let single = match (i.single, i.shadow) {
        (false, _) => 0.0,
        (true, ShadowEstimator::March) => SINGLE_MARCHED * march_length * steps,
        (true, _) => SINGLE_EXACT * shaded,
    } * eye_rays
        * lights
        * cache(i.shadow_cache > 0);
    let multiple = if i.multiple {
        (MULTIPLE + MULTIPLE_PER_NUSED * i.nused as f64) * shaded * eye_rays * cache(i.ms_cache > 0)
    } else {
        0.0
    };
    let tracing = i.volume_photons as f64 * PHOTON;
    let record = pixels * RECORD;
    // Progressive, beam and plane renders march alone: single scattering in the first
    // pass, then one multiple-scattering pass per photon set.
    let Some(pass_cost) = i.estimator.pass_cost() else {
        return CellCost {
            march: single,
            own: multiple + tracing + record,
        };
    };
    let pass = match (pass_cost, i.multiple) {
        (_, false) => 0.0,
        (PassCost::Gathers, true) => {
            multiple * PROGRESSIVE_GATHER + PROGRESSIVE_MARCH * march_length * eye_rays
        }
        (PassCost::Traversal, true) => BEAM_PASS * march_length * eye_rays,
    };
    CellCost {
        march: 0.0,
        own: single + i.iterations.max(1) as f64 * (pass + tracing) + record,
    }
}

/// Eye-march samples and gathers per ray of each distinct scene, probed once
/// (`probe_eye_rays` on 32 × 32 rays); `None` where the scene cannot be loaded here (a dataset not on this
/// machine), which the estimate then takes as the calibration frame's.
#[derive(Default)]
struct Probes {
    caches: Caches,
    samples: HashMap<String, Option<EyeProbe>>,
    seconds: f64,
}

impl Probes {
    /// Rays per side of the probe grid.
    const RAYS: u32 = 32;

    fn probe(&mut self, cell: &CellSpec) -> Option<EyeProbe> {
        let p = &cell.params;
        // What decides the march: the medium, the view and the step (and where the gathers
        // thin out).
        let key = serde_json::to_string(&(
            &p.volume,
            &p.transfer,
            &p.sigma,
            &p.camera,
            p.integrator.stepsize,
            p.integrator.termination,
            p.integrator.thin_below,
            &cell.base_dir,
        ))
        .ok()?;
        if let Some(known) = self.samples.get(&key) {
            return *known;
        }
        let start = std::time::Instant::now();
        let probed = self
            .caches
            .scene(p, &cell.base_dir, &SearchPath::from_env())
            .ok()
            .map(|scene| probe_eye_rays(&scene, Self::RAYS));
        self.seconds += start.elapsed().as_secs_f64();
        self.samples.insert(key, probed);
        probed
    }

    /// How the estimate was scaled, for the summary line.
    fn summary(&self) -> String {
        let missing = self.samples.values().filter(|s| s.is_none()).count();
        let total = self.samples.len();
        if missing == 0 {
            format!("the eye-march length probed on each of its {total} scene(s)")
        } else {
            format!(
                "the eye-march length probed on {} of its {total} scene(s) (the other {missing} could not be loaded here and count as the foot at σt 80)",
                total - missing
            )
        }
    }
}

/// The estimate of the experiment's references: each distinct one once, less the passes a
/// reference pool already holds.
#[derive(Debug, Default)]
pub(crate) struct ReferenceEstimate {
    /// Seconds left to render.
    pub(crate) seconds: f64,
    /// Distinct references.
    pub(crate) count: usize,
    /// References the pool holds at the wanted passes, and those it holds in part.
    pub(crate) pooled: usize,
    pub(crate) partly_pooled: usize,
}

impl ReferenceEstimate {
    fn of(
        exp: &Experiment,
        cells: &[CellSpec],
        pool: Option<&ReferencePool>,
        costing: &mut Costing,
    ) -> Result<Self> {
        let mut estimate = ReferenceEstimate::default();
        let Some(spec) = &exp.reference else {
            return Ok(estimate);
        };
        let mut seen = HashSet::new();
        for c in cells {
            let p = reference_params(&c.params, spec)?;
            if !seen.insert(serde_json::to_string(&p)?) {
                continue;
            }
            let held = match pool {
                Some(pool) if spec.method == ReferenceMethod::Path => {
                    pool.held_passes(&reference_key(c, spec)?, spec.spp)
                }
                _ => 0,
            };
            estimate.pooled += usize::from(held == spec.spp);
            estimate.partly_pooled += usize::from(held > 0 && held < spec.spp);
            let left = 1.0 - f64::from(held) / f64::from(spec.spp.max(1));
            if left <= 0.0 {
                continue;
            }
            estimate.seconds += costing.reference(&p, c) * left;
        }
        estimate.count = seen.len();
        Ok(estimate)
    }

    /// What the pool took off, for the summary line.
    pub(crate) fn pool_note(&self, pool: Option<&ReferencePool>) -> String {
        match pool {
            Some(pool) => format!(
                "; the pool {} holds {} of them and {} in part",
                pool.root().display(),
                self.pooled,
                self.partly_pooled
            ),
            None => String::new(),
        }
    }
}

/// The cells in the march groups a run renders together, in plan order.
fn march_groups<'a>(exp: &Experiment, cells: &'a [CellSpec]) -> Vec<Vec<&'a CellSpec>> {
    crate::render::group_by_march(cells.iter().collect(), exp.share, |c| c)
}

/// How the plan's costs were found.
enum Costing {
    /// Pilot renders on this machine, with the model where a scene could not be loaded.
    Pilot(Pilots),
    /// The calibrated model alone.
    Model,
}

impl Costing {
    /// The seconds of the reference `params` of `cell` rendered whole: a pilot's, or the
    /// model's when there is none (or it failed, said on stderr).
    fn reference(&mut self, params: &SceneParams, cell: &CellSpec) -> f64 {
        let piloted = match self {
            Costing::Pilot(pilots) if params.integrator.method == Method::Reference => {
                pilots.reference(params, &cell.base_dir)
            }
            Costing::Pilot(pilots) => {
                let spec = CellSpec {
                    params: params.clone(),
                    ..cell.clone()
                };
                pilots.group(&[&spec], 0.0).map(|costs| costs[0])
            }
            Costing::Model => return estimate_cost(params, None).alone(),
        };
        piloted.unwrap_or_else(|e| {
            eprintln!(
                "note: no pilot for the reference of cell {} ({e:#}): the model costs it",
                cell.index
            );
            estimate_cost(params, None).alone()
        })
    }
}

/// Each cell's estimated seconds (its share of a shared march), in plan order, and the
/// groups the model had to cost (their scene could not be loaded for a pilot).
fn cell_estimates(
    groups: &[Vec<&CellSpec>],
    cells: usize,
    costing: &mut Costing,
    probes: &mut Probes,
) -> (Vec<f64>, usize) {
    let multi = crate::progress::multi(false);
    let bar = match costing {
        Costing::Pilot(_) => Some(crate::progress::bar(
            &multi,
            groups.len() as u64,
            "pilot",
            "groups",
        )),
        Costing::Model => None,
    };
    let mut estimates = vec![0.0; cells];
    let mut modelled = 0;
    let mut first_failure = None;
    for group in groups {
        let piloted = match costing {
            Costing::Pilot(pilots) => match pilots.group(group, calibration::RECORD) {
                Ok(costs) => Some(costs),
                Err(e) => {
                    first_failure.get_or_insert_with(|| format!("cell {}: {e:#}", group[0].index));
                    None
                }
            },
            Costing::Model => None,
        };
        let costs = piloted.unwrap_or_else(|| {
            modelled += usize::from(matches!(costing, Costing::Pilot(_)));
            // The model: the group pays its longest march once, each cell its own part.
            let costs: Vec<CellCost> = group
                .iter()
                .map(|c| estimate_cost(&c.params, probes.probe(c)))
                .collect();
            let march = costs.iter().map(|c| c.march).fold(0.0, f64::max) / group.len() as f64;
            costs.iter().map(|c| c.own + march).collect()
        });
        for (c, cost) in group.iter().zip(costs) {
            estimates[c.index] = cost;
        }
        if let Some(bar) = &bar {
            bar.inc(1);
        }
    }
    if let Some(bar) = bar {
        bar.finish_and_clear();
    }
    if let Some(why) = first_failure {
        eprintln!(
            "note: no pilot render for {modelled} of {} march group(s), costed by the model instead (the first: {why})",
            groups.len()
        );
    }
    (estimates, modelled)
}

/// How a plan is costed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum CostMethod {
    /// Pilot renders on this machine (the model where a scene cannot be loaded).
    Pilot,
    /// The model calibrated on one frame, scaled by each scene's probed march.
    Model,
}

/// What a plan is estimated to cost.
pub(crate) struct PlanEstimate {
    /// Each cell's seconds (its share of a shared march), in plan order.
    pub(crate) cells: Vec<f64>,
    /// The march groups a run renders together, as plan indices.
    pub(crate) groups: Vec<Vec<usize>>,
    /// Seconds of loading and preparing the pilots' volumes (a run loads them too).
    pub(crate) setup: f64,
    /// The experiment's references.
    pub(crate) references: ReferenceEstimate,
    /// How the costs were found, one sentence for the summary.
    pub(crate) how: String,
    /// Wall-clock seconds the pilot renders took (their volumes' loading included).
    pub(crate) pilot_seconds: f64,
    /// Pilot renders made.
    pub(crate) pilot_renders: usize,
    /// Seconds spent probing eye-march lengths for the model.
    pub(crate) probe_seconds: f64,
}

impl PlanEstimate {
    /// Seconds of the cells, volumes loaded included.
    pub(crate) fn cells_total(&self) -> f64 {
        self.cells.iter().sum::<f64>() + self.setup
    }

    /// Seconds of everything: cells and references.
    pub(crate) fn total(&self) -> f64 {
        self.cells_total() + self.references.seconds
    }

    /// Wall-clock seconds of a run that renders `side_by_side` march groups at once without
    /// sharing cores: the references first, one at a time (as a run renders them), then
    /// the groups, each taken by the first free job in plan order; the volumes' loading
    /// is paid once.
    pub(crate) fn wall_seconds(&self, side_by_side: usize) -> f64 {
        let mut jobs = vec![0.0f64; side_by_side.max(1)];
        for group in &self.groups {
            let seconds: f64 = group.iter().map(|&i| self.cells[i]).sum();
            let free = jobs
                .iter_mut()
                .min_by(|a, b| a.total_cmp(b))
                .expect("at least one job");
            *free += seconds;
        }
        self.references.seconds + self.setup + jobs.into_iter().fold(0.0, f64::max)
    }
}

/// Estimates each cell's cost and the references': cells of one march group pay their
/// shared march once, and each distinct reference is counted once.
pub(crate) fn estimate(
    exp: &Experiment,
    cells: &[CellSpec],
    pool: Option<&ReferencePool>,
    method: CostMethod,
) -> Result<PlanEstimate> {
    let mut costing = match method {
        CostMethod::Pilot => Costing::Pilot(Pilots::default()),
        CostMethod::Model => Costing::Model,
    };
    let mut probes = Probes::default();
    let groups = march_groups(exp, cells);
    let (estimates, modelled) = cell_estimates(&groups, cells.len(), &mut costing, &mut probes);
    let references = ReferenceEstimate::of(exp, cells, pool, &mut costing)?;
    let (setup, how, pilot_seconds, pilot_renders) = match &costing {
        Costing::Pilot(p) => (
            p.setup_seconds,
            pilot_sentence(p, modelled, &probes),
            p.seconds,
            p.renders,
        ),
        Costing::Model => (
            0.0,
            format!(
                "Rough: calibrated on the foot at σt 80 and scaled by {} (pilot renders measure it: drop --no-pilot)",
                probes.summary()
            ),
            0.0,
            0,
        ),
    };
    Ok(PlanEstimate {
        cells: estimates,
        groups: groups
            .iter()
            .map(|g| g.iter().map(|c| c.index).collect())
            .collect(),
        setup,
        references,
        how,
        pilot_seconds,
        pilot_renders,
        probe_seconds: probes.seconds,
    })
}

/// How pilot renders costed the plan, for the summary.
fn pilot_sentence(p: &Pilots, modelled: usize, probes: &Probes) -> String {
    format!(
        "Measured: each march group and reference rendered at {side} pixels a side ({iterated} for progressive and beam cells) on this machine{model}, scaled to its size; {setup:.1} s of loading the volumes included",
        side = pilot::PILOT_SIDE,
        iterated = pilot::ITERATED_PILOT_SIDE,
        model = if modelled > 0 {
            format!(
                " ({modelled} group(s) whose scene could not be loaded from the model, calibrated on the foot at σt 80 and scaled by {})",
                probes.summary()
            )
        } else {
            String::new()
        },
        setup = p.setup_seconds,
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use volphot::MsEstimator;

    fn scene() -> SceneParams {
        let mut p: SceneParams = toml::from_str(volphot::test_util::SMALL_SCENE).unwrap();
        p.camera.resolution = [512, 512];
        p.integrator.stepsize = 0.0005;
        p.integrator.single = true;
        p.integrator.multiple = true;
        p.integrator.volume_photons = 0;
        p
    }

    /// The frame's part of a cost: without the cell's record, which does not scale with
    /// the step, the caches or the lights (the scenes trace no photons).
    fn frame(p: &SceneParams) -> f64 {
        frame_probed(p, None)
    }

    /// [`frame`] with the march probed as `probe`.
    fn frame_probed(p: &SceneParams, probe: Option<EyeProbe>) -> f64 {
        let [w, h] = p.camera.resolution;
        estimate_cost(p, probe).alone() - (w * h) as f64 * calibration::RECORD
    }

    #[test]
    fn a_probed_march_length_scales_the_marching_costs_and_nothing_else() {
        let p = scene();
        let [w, h] = p.camera.resolution;
        let fixed = (w * h) as f64 * calibration::RECORD
            + p.integrator.volume_photons as f64 * calibration::PHOTON;
        let at = |samples: f64| {
            let gathers = samples;
            estimate_cost(&p, Some(EyeProbe { samples, gathers }))
        };
        let base = at(calibration::SAMPLES_PER_RAY);
        let unprobed = estimate_cost(&p, None);
        assert!(
            (base.alone() / unprobed.alone() - 1.0).abs() < 1e-6,
            "the calibration frame's own length"
        );
        // A medium whose rays take 3× the samples (a thin one, crossed end to end).
        let thin = at(3.0 * calibration::SAMPLES_PER_RAY);
        assert!((thin.march / base.march - 3.0).abs() < 1e-9);
        assert!(((thin.own - fixed) / (base.own - fixed) - 3.0).abs() < 1e-9);
    }

    #[test]
    fn thinned_gathers_scale_the_shading_costs() {
        let p = scene();
        let [w, h] = p.camera.resolution;
        let fixed = (w * h) as f64 * calibration::RECORD;
        let samples = calibration::SAMPLES_PER_RAY;
        let full = estimate_cost(
            &p,
            Some(EyeProbe {
                samples,
                gathers: samples,
            }),
        );
        let thinned = estimate_cost(
            &p,
            Some(EyeProbe {
                samples,
                gathers: 0.4 * samples,
            }),
        );
        assert!((thinned.march / full.march - 0.4).abs() < 1e-9);
        assert!(((thinned.own - fixed) / (full.own - fixed) - 0.4).abs() < 1e-9);
    }

    #[test]
    fn marched_shadows_grow_with_the_square_of_the_step_count() {
        let mut p = scene();
        p.integrator.multiple = false;
        let cost = frame;
        p.integrator.shadow = ShadowEstimator::Exact;
        let exact = cost(&p);
        p.integrator.stepsize = 0.00025;
        assert!((cost(&p) / exact - 2.0).abs() < 1e-9);
        p.integrator.shadow = ShadowEstimator::March;
        let fine = cost(&p);
        p.integrator.stepsize = 0.0005;
        assert!((fine / cost(&p) - 4.0).abs() < 1e-9);
    }

    #[test]
    fn thinning_spares_a_progressive_iteration_its_gathers_but_not_its_march() {
        let mut p = scene();
        p.integrator.single = false;
        p.integrator.estimator = MsEstimator::Progressive;
        p.integrator.iterations = 10;
        let samples = calibration::SAMPLES_PER_RAY;
        let at = |gathers: f64| frame_probed(&p, Some(EyeProbe { samples, gathers }));
        let (full, thinned) = (at(samples), at(0.4 * samples));
        let march = 10.0 * calibration::PROGRESSIVE_MARCH * 512.0 * 512.0;
        assert!(((thinned - march) / (full - march) - 0.4).abs() < 1e-9);
        assert!(thinned / full > 0.4 + 0.05, "the march is a visible share");
    }

    #[test]
    fn a_shared_march_is_paid_once_and_caches_and_iterations_scale_the_cost() {
        let p = scene();
        let points = estimate_cost(&p, None);
        assert!(points.march > 0.0 && points.own > 0.0);
        let mut more = p.clone();
        more.integrator.nused = 300;
        let wider = estimate_cost(&more, None);
        assert_eq!(wider.march, points.march, "nused does not change the march");
        assert!(wider.own > points.own);
        let mut cached = p.clone();
        cached.integrator.shadow_cache = 64;
        cached.integrator.ms_cache = 64;
        assert!((frame(&cached) / frame(&p) - 0.25).abs() < 1e-9);
        let mut progressive = p.clone();
        progressive.integrator.estimator = MsEstimator::Progressive;
        progressive.integrator.iterations = 16;
        assert_eq!(
            estimate_cost(&progressive, None).march,
            0.0,
            "each iteration marches alone"
        );
        // Single scattering once, then 16 fixed-radius passes, each with its own march.
        let pixels = 512.0 * 512.0;
        let multiple = points.own - pixels * calibration::RECORD;
        let pass =
            calibration::PROGRESSIVE_GATHER * multiple + calibration::PROGRESSIVE_MARCH * pixels;
        let expected = points.march + 16.0 * pass;
        assert!((frame(&progressive) / expected - 1.0).abs() < 1e-6);
        // A beam pass walks the photons' spheres instead of gathering: far cheaper, and
        // independent of nused.
        let mut beams = progressive.clone();
        beams.integrator.estimator = MsEstimator::Beam;
        let beam_cost = frame(&beams);
        assert!(beam_cost > points.march && beam_cost < frame(&progressive));
        beams.integrator.nused = 300;
        assert_eq!(frame(&beams), beam_cost);
    }

    #[test]
    fn wall_time_runs_groups_side_by_side_after_the_references() {
        let estimate = PlanEstimate {
            cells: vec![2.0, 1.0, 2.0, 2.0],
            groups: vec![vec![0, 1], vec![2], vec![3]],
            setup: 0.5,
            references: ReferenceEstimate {
                seconds: 10.0,
                count: 1,
                ..Default::default()
            },
            how: String::new(),
            pilot_seconds: 0.0,
            pilot_renders: 0,
            probe_seconds: 0.0,
        };
        assert_eq!(estimate.total(), 17.5);
        assert_eq!(estimate.wall_seconds(1), 17.5, "one job: the total");
        // Groups of 3, 2 and 2 s on two jobs: 3 s on one, 2 + 2 s on the other.
        assert_eq!(estimate.wall_seconds(2), 10.5 + 4.0);
        assert_eq!(estimate.wall_seconds(8), 10.5 + 3.0, "the longest group");
    }
}
