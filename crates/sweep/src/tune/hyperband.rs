//! Hyperband (Li et al., JMLR 2018): brackets of synchronous successive halving over
//! fidelity levels, and what a level means for a render (resolution, photon fraction).

use crate::plan::Fidelity;

/// One rung of a bracket: how many configurations are evaluated at which level.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Rung {
    /// Configurations evaluated.
    pub(crate) configs: usize,
    /// Fidelity level (0 = cheapest, `levels − 1` = the target).
    pub(crate) level: u32,
}

/// The brackets of one Hyperband iteration, most exploratory first: bracket `s` starts
/// `ceil(levels/(s+1) · η^s)` configurations at level `levels − 1 − s` and keeps the best
/// `1/η` per rung up to the target level.
pub(crate) fn schedule(levels: u32, eta: u32) -> Vec<Vec<Rung>> {
    let s_max = levels.saturating_sub(1);
    (0..=s_max)
        .rev()
        .map(|s| {
            let n = (f64::from(s_max + 1) / f64::from(s + 1) * f64::from(eta).powi(s as i32)).ceil()
                as usize;
            (0..=s)
                .map(|i| Rung {
                    configs: (n / (eta as usize).pow(i)).max(1),
                    level: s_max - s + i,
                })
                .collect()
        })
        .collect()
}

/// The renders of a bracket (per context).
pub(crate) fn bracket_renders(bracket: &[Rung]) -> usize {
    bracket.iter().map(|r| r.configs).sum()
}

/// Hyperband iterations at most (a budget normally ends the search long before).
pub(crate) const MAX_ITERATIONS: u32 = 10_000;

/// How many brackets a budget of `budget` renders starts, and their renders, as the search
/// starts them: each iteration starts every bracket that still fits, for at most
/// [`MAX_ITERATIONS`] iterations. Computed without walking the iterations (the budget may
/// hold many): the whole iterations that fit, then the few passes over what is left.
pub(crate) fn brackets_within(
    brackets: &[Vec<Rung>],
    contexts: usize,
    budget: usize,
) -> (usize, usize) {
    let costs: Vec<usize> = brackets
        .iter()
        .map(|b| bracket_renders(b) * contexts)
        .collect();
    let iteration: usize = costs.iter().sum();
    if iteration == 0 {
        return (0, 0);
    }
    let whole = (budget / iteration).min(MAX_ITERATIONS as usize);
    let (mut started, mut planned) = (whole * costs.len(), whole * iteration);
    // Less than one iteration is left, so each pass starts one bracket at least and the
    // passes end within `iteration / min(costs)`.
    for _ in whole..MAX_ITERATIONS as usize {
        let before = started;
        for &cost in &costs {
            if planned + cost <= budget {
                planned += cost;
                started += 1;
            }
        }
        if started == before {
            break;
        }
    }
    (started, planned)
}

/// Where a level sits between the lowest (0) and the target (1), geometrically.
fn position(f: &Fidelity, level: u32) -> f64 {
    if f.levels <= 1 {
        1.0
    } else {
        f64::from(level) / f64::from(f.levels - 1)
    }
}

impl Fidelity {
    /// The resolution at a level: geometric steps from `min_resolution` to `resolution`.
    pub(crate) fn resolution(&self, level: u32) -> [u32; 2] {
        let t = position(self, level);
        std::array::from_fn(|k| {
            let (lo, hi) = (
                f64::from(self.min_resolution[k]),
                f64::from(self.resolution[k]),
            );
            (lo * (hi / lo).powf(t)).round().clamp(lo, hi) as u32
        })
    }

    /// The photon fraction at a level: geometric steps from `min_photon_fraction` to 1.
    pub(crate) fn photon_fraction(&self, level: u32) -> f64 {
        self.min_photon_fraction
            .powf(1.0 - position(self, level))
            .min(1.0)
    }

    /// The top level.
    pub(crate) fn top(&self) -> u32 {
        self.levels - 1
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn shape(levels: u32, eta: u32) -> Vec<Vec<(usize, u32)>> {
        schedule(levels, eta)
            .iter()
            .map(|b| b.iter().map(|r| (r.configs, r.level)).collect())
            .collect()
    }

    #[test]
    fn the_papers_schedules() {
        // R = 81, η = 3 (Li et al., Table 1): 81/27/9/3/1, 34/11/3/1, 15/5/1, 8/2, 5.
        let s = shape(5, 3);
        let counts: Vec<Vec<usize>> = s.iter().map(|b| b.iter().map(|r| r.0).collect()).collect();
        assert_eq!(
            counts,
            vec![
                vec![81, 27, 9, 3, 1],
                vec![34, 11, 3, 1],
                vec![15, 5, 1],
                vec![8, 2],
                vec![5]
            ]
        );
        assert_eq!(s[0][0].1, 0);
        assert!(
            s.iter().all(|b| b.last().unwrap().1 == 4),
            "ends at the top"
        );
        assert_eq!(s.iter().map(|b| bracket_renders_of(b)).sum::<usize>(), 206);
        // R = 9, η = 3.
        assert_eq!(
            shape(3, 3),
            vec![
                vec![(9, 0), (3, 1), (1, 2)],
                vec![(5, 1), (1, 2)],
                vec![(3, 2)]
            ]
        );
        assert_eq!(shape(1, 3), vec![vec![(1, 0)]]);
    }

    fn bracket_renders_of(b: &[(usize, u32)]) -> usize {
        b.iter().map(|r| r.0).sum()
    }

    /// The search's own walk: iteration after iteration, every bracket that fits.
    fn walked(brackets: &[Vec<Rung>], contexts: usize, budget: usize) -> (usize, usize) {
        let (mut started, mut planned) = (0, 0);
        for _ in 0..MAX_ITERATIONS {
            let before = started;
            for b in brackets {
                let cost = bracket_renders(b) * contexts;
                if planned + cost <= budget {
                    planned += cost;
                    started += 1;
                }
            }
            if started == before {
                break;
            }
        }
        (started, planned)
    }

    #[test]
    fn brackets_within_a_budget_match_the_walk_and_stop_at_the_iteration_limit() {
        for (levels, eta) in [(1, 3), (2, 3), (3, 3), (5, 3), (4, 2)] {
            let brackets = schedule(levels, eta);
            for contexts in [1, 3] {
                for budget in (0..700).chain([60_000, 61_234, 1_000_000]) {
                    assert_eq!(
                        brackets_within(&brackets, contexts, budget),
                        walked(&brackets, contexts, budget),
                        "levels {levels}, eta {eta}, {contexts} context(s), budget {budget}"
                    );
                }
            }
        }
        // Two levels: 6 renders per iteration, so the limit caps a huge budget.
        let most = MAX_ITERATIONS as usize;
        assert_eq!(
            brackets_within(&schedule(2, 3), 1, usize::MAX / 2),
            (2 * most, 6 * most)
        );
    }

    #[test]
    fn levels_interpolate_geometrically() {
        let f = Fidelity {
            resolution: [512, 256],
            min_resolution: [128, 64],
            min_photon_fraction: 0.25,
            levels: 3,
            eta: 3,
        };
        assert_eq!(f.resolution(0), [128, 64]);
        assert_eq!(f.resolution(1), [256, 128]);
        assert_eq!(f.resolution(2), [512, 256]);
        assert!((f.photon_fraction(0) - 0.25).abs() < 1e-12);
        assert!((f.photon_fraction(1) - 0.5).abs() < 1e-12);
        assert_eq!(f.photon_fraction(2), 1.0);
    }
}
