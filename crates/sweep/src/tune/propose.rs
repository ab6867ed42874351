//! Proposing configurations: uniform draws, or BOHB's model step with the `tpe` crate's
//! tree-Parzen estimators (one per parameter, fitted on the largest fidelity level with
//! enough evaluations). Deterministic: one seeded stream per bracket, observations in id
//! order, parameters in file order.

use anyhow::Result;
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64Mcg;

use crate::plan::{Proposal, TuneSpec};

/// How a configuration was proposed (sensitivity uses the uniform ones).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Origin {
    /// A uniform draw.
    Random,
    /// The tree-Parzen model's choice.
    Model,
}

impl Origin {
    /// The name in `observations.csv`.
    pub(crate) fn name(self) -> &'static str {
        match self {
            Origin::Random => "random",
            Origin::Model => "model",
        }
    }
}

/// What the model learns from: one evaluated configuration at one level.
#[derive(Debug, Clone)]
pub(crate) struct Observed<'a> {
    /// Configuration id (the sort key that makes fitting order-independent).
    pub(crate) id: &'a str,
    /// Fidelity level.
    pub(crate) level: u32,
    /// Parameter values.
    pub(crate) values: &'a [f64],
    /// Objective (+∞ when failed or infeasible).
    pub(crate) loss: f64,
}

/// Share of the best evaluations the "good" density is fitted on (BOHB's q).
const GAMMA: f64 = 0.15;
/// Candidates drawn from the good density per proposal (BOHB's N_s).
const CANDIDATES: usize = 64;

/// The stream of proposals for bracket `bracket` of Hyperband iteration `iteration`.
pub(crate) fn stream(seed: u64, iteration: u32, bracket: u32) -> Pcg64Mcg {
    let key = (u64::from(iteration) << 32) | u64::from(bracket);
    Pcg64Mcg::seed_from_u64(splitmix64(seed ^ splitmix64(key.wrapping_add(0x7475_6e65))))
}

fn splitmix64(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// The level the model is fitted on: the largest with at least `d + 3` evaluations (BOHB's
/// N_min + 2 with N_min = d + 1), of which at least two are finite.
fn model_level(spec: &TuneSpec, history: &[Observed<'_>]) -> Option<u32> {
    let need = spec.space.len() + 3;
    (0..spec.fidelity.levels).rev().find(|&level| {
        let at: Vec<&Observed<'_>> = history.iter().filter(|o| o.level == level).collect();
        at.len() >= need && at.iter().filter(|o| o.loss.is_finite()).count() >= 2
    })
}

/// `count` configurations from `rng`: each uniform with probability `random_fraction` (or
/// always with `proposal = "random"` or before a model level exists), otherwise the TPE
/// choice per parameter.
pub(crate) fn propose(
    spec: &TuneSpec,
    history: &[Observed<'_>],
    count: usize,
    rng: &mut Pcg64Mcg,
) -> Result<Vec<(Vec<f64>, Origin)>> {
    let level = match spec.proposal {
        Proposal::Tpe => model_level(spec, history),
        Proposal::Random => None,
    };
    let mut models = match level {
        Some(level) => Some(fit(spec, history, level)?),
        None => None,
    };
    let mut out = Vec::with_capacity(count);
    for _ in 0..count {
        let uniform = rng.random::<f64>() < spec.random_fraction;
        match models.as_mut().filter(|_| !uniform) {
            Some(models) => {
                let mut values = Vec::with_capacity(models.len());
                for (p, m) in spec.space.iter().zip(models.iter_mut()) {
                    let z = m.ask(rng).map_err(|e| match e {})?;
                    values.push(p.decode(z));
                }
                out.push((values, Origin::Model));
            }
            None => out.push((
                spec.space.iter().map(|p| p.sample(rng)).collect(),
                Origin::Random,
            )),
        }
    }
    Ok(out)
}

/// One tree-Parzen optimiser per parameter, told every evaluation at `level` in id order.
fn fit(spec: &TuneSpec, history: &[Observed<'_>], level: u32) -> Result<Vec<tpe::TpeOptimizer>> {
    let mut at: Vec<&Observed<'_>> = history.iter().filter(|o| o.level == level).collect();
    at.sort_by(|a, b| a.id.cmp(b.id));
    let mut models = Vec::new();
    for (j, p) in spec.space.iter().enumerate() {
        let (start, end) = p.model_range();
        let estimator = if p.is_choice() {
            tpe::histogram_estimator()
        } else {
            tpe::parzen_estimator()
        };
        let range = tpe::range(start, end)
            .map_err(|e| anyhow::anyhow!("`{}`: model range {start}..{end}: {e}", p.key))?;
        let mut m = tpe::TpeOptimizerBuilder::new()
            .gamma(GAMMA)
            .candidates(CANDIDATES)
            .build(estimator, range)
            .map_err(|e| anyhow::anyhow!("`{}`: {e}", p.key))?;
        for o in &at {
            m.tell(p.encode(o.values[j]), o.loss)
                .map_err(|e| anyhow::anyhow!("`{}` of {}: {e}", p.key, o.id))?;
        }
        models.push(m);
    }
    Ok(models)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plan::{Budget, Fidelity, Metric, Param, ParamKind};

    fn spec(proposal: Proposal) -> TuneSpec {
        TuneSpec {
            seed: 1,
            objective: vec![(Metric::Rmse, 1.0)],
            budget: Budget::Renders(10),
            proposal,
            random_fraction: 0.0,
            time_budgets: vec![],
            fidelity: Fidelity {
                resolution: [8, 8],
                min_resolution: [8, 8],
                min_photon_fraction: 1.0,
                levels: 1,
                eta: 3,
            },
            space: vec![Param {
                key: "x".into(),
                kind: ParamKind::Float {
                    lo: 0.0,
                    hi: 1.0,
                    log: false,
                },
            }],
            max_seconds: None,
        }
    }

    #[test]
    fn the_model_concentrates_near_the_best_and_is_reproducible() {
        let spec = spec(Proposal::Tpe);
        let ids: Vec<String> = (0..40).map(|i| format!("c{i:02}")).collect();
        let values: Vec<Vec<f64>> = (0..40).map(|i| vec![f64::from(i) / 39.0]).collect();
        let history: Vec<Observed<'_>> = (0..40)
            .map(|i| Observed {
                id: &ids[i],
                level: 0,
                values: &values[i],
                loss: (values[i][0] - 0.3).powi(2),
            })
            .collect();
        let a = propose(&spec, &history, 20, &mut stream(5, 0, 1)).unwrap();
        let b = propose(&spec, &history, 20, &mut stream(5, 0, 1)).unwrap();
        assert_eq!(a, b, "same seed, same proposals");
        assert!(a.iter().all(|(_, o)| *o == Origin::Model));
        let mean_dist: f64 = a.iter().map(|(v, _)| (v[0] - 0.3).abs()).sum::<f64>() / 20.0;
        assert!(mean_dist < 0.12, "mean distance to the optimum {mean_dist}");
        // The order of the history does not matter.
        let mut reversed = history.clone();
        reversed.reverse();
        assert_eq!(
            a,
            propose(&spec, &reversed, 20, &mut stream(5, 0, 1)).unwrap()
        );
        // Too few evaluations: uniform.
        let few = propose(&spec, &history[..2], 3, &mut stream(5, 0, 1)).unwrap();
        assert!(few.iter().all(|(_, o)| *o == Origin::Random));
        let random = propose(&spec_random(), &history, 3, &mut stream(5, 0, 1)).unwrap();
        assert!(random.iter().all(|(_, o)| *o == Origin::Random));
        assert_ne!(
            stream(5, 0, 1).random::<u64>(),
            stream(5, 1, 0).random::<u64>()
        );
    }

    fn spec_random() -> TuneSpec {
        spec(Proposal::Random)
    }
}
