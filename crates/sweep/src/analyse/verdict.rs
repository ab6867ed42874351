//! The one rule for "an effect": whether paired differences over seeds show that a change
//! rises, falls, is none, or is unclear. `sweep claims` checks a document's `verdict:`
//! comments with it, and the report's "What changed" says "lowers" or "raises" only when
//! it holds; docs/experiments.md states it for the reader.
//!
//! The rule is a paired t-test at the 5 % level. The differences d₁ … dₙ (one per seed
//! where both sides exist) have mean m, sample standard deviation s and standard error
//! SE = s/√n; the two-sided 95 % confidence interval of their mean is m ± t·SE, with t the
//! 0.975 quantile of Student's t distribution for n − 1 degrees of freedom:
//!
//! - **rises** when n ≥ 3 and the interval lies entirely above 0;
//! - **falls** when n ≥ 3 and it lies entirely below 0;
//! - **none** when n ≥ 3 and it lies entirely inside (−δ, +δ), δ being the smallest effect
//!   the sentence cares about (always stated, never a default);
//! - **unclear** otherwise, and always with fewer than three seeds.
//!
//! With s = 0 the interval is the point m: it rises for m > 0, falls for m < 0, and is none
//! for m = 0 (whatever δ). A difference that is not a finite number (NaN from 0/0) is an
//! error, never a seed left out.

use thiserror::Error;

/// What paired differences over seeds say about a change.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Verdict {
    /// The 95 % interval of the mean difference lies above 0.
    Rises,
    /// The interval lies below 0.
    Falls,
    /// The interval lies inside (−δ, +δ): no effect as large as δ.
    None,
    /// Neither: too few seeds, or an interval that holds 0 and reaches beyond δ.
    Unclear,
}

impl Verdict {
    /// The word a document writes: `rises`, `falls`, `none`, `unclear`.
    pub(crate) fn word(self) -> &'static str {
        match self {
            Verdict::Rises => "rises",
            Verdict::Falls => "falls",
            Verdict::None => "none",
            Verdict::Unclear => "unclear",
        }
    }

    /// The verdict a word names.
    pub(crate) fn from_word(word: &str) -> Option<Self> {
        [
            Verdict::Rises,
            Verdict::Falls,
            Verdict::None,
            Verdict::Unclear,
        ]
        .into_iter()
        .find(|v| v.word() == word)
    }
}

/// The fewest seeds that can show a verdict other than unclear.
pub(crate) const MIN_SEEDS: usize = 3;

/// Why differences cannot be judged.
#[derive(Debug, Clone, PartialEq, Error)]
pub(crate) enum PairedError {
    #[error("no paired difference to judge")]
    Empty,
    /// The difference at `index` (in the order given) is NaN or infinite.
    #[error("difference {} of {count} is {value}, not a finite number", index + 1)]
    NotFinite {
        index: usize,
        count: usize,
        value: f64,
    },
}

/// Paired differences summarised: their number, mean, and (from two on) the 95 %
/// confidence interval of their mean.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Paired {
    pub(crate) n: usize,
    pub(crate) mean: f64,
    /// Sample standard deviation (n − 1); `None` for one difference.
    pub(crate) sd: Option<f64>,
    /// The two-sided 95 % interval `(low, high)` of the mean; `None` for one difference.
    pub(crate) interval: Option<(f64, f64)>,
}

impl Paired {
    /// Summarises the differences; every one must be a finite number.
    pub(crate) fn of(differences: &[f64]) -> Result<Paired, PairedError> {
        let n = differences.len();
        if n == 0 {
            return Err(PairedError::Empty);
        }
        if let Some(index) = differences.iter().position(|d| !d.is_finite()) {
            return Err(PairedError::NotFinite {
                index,
                count: n,
                value: differences[index],
            });
        }
        let mean = differences.iter().sum::<f64>() / n as f64;
        if n < 2 {
            return Ok(Paired {
                n,
                mean,
                sd: None,
                interval: None,
            });
        }
        let squares = differences.iter().map(|d| (d - mean).powi(2)).sum::<f64>();
        let sd = (squares / (n - 1) as f64).sqrt();
        // With s = 0 the interval is the point m (never 0 · t, whatever t is).
        let half = if sd == 0.0 {
            0.0
        } else {
            t_975(n - 1) * sd / (n as f64).sqrt()
        };
        Ok(Paired {
            n,
            mean,
            sd: Some(sd),
            interval: Some((mean - half, mean + half)),
        })
    }

    /// The standard error of the mean, s/√n (from two differences on).
    pub(crate) fn se(&self) -> Option<f64> {
        Some(self.sd? / (self.n as f64).sqrt())
    }

    /// The paired t statistic m/SE (from two differences on, and with a spread).
    pub(crate) fn t(&self) -> Option<f64> {
        let se = self.se()?;
        (se > 0.0).then(|| self.mean / se)
    }

    /// The rule: rises, falls, none (inside ±`delta`, when a δ is given) or unclear.
    pub(crate) fn verdict(&self, delta: Option<f64>) -> Verdict {
        let Some((low, high)) = self.interval.filter(|_| self.n >= MIN_SEEDS) else {
            return Verdict::Unclear;
        };
        if low > 0.0 {
            Verdict::Rises
        } else if high < 0.0 {
            Verdict::Falls
        } else if delta.is_some_and(|d| -d < low && high < d) || (low == 0.0 && high == 0.0) {
            Verdict::None
        } else {
            Verdict::Unclear
        }
    }
}

/// The 0.975 quantile of Student's t distribution with `dof` degrees of freedom (the
/// half-width of a two-sided 95 % interval in standard errors): 12.706 for 1, 4.303 for 2,
/// 2.262 for 9, tending to the normal's 1.960.
pub(crate) fn t_975(dof: usize) -> f64 {
    debug_assert!(dof > 0, "a t quantile needs a degree of freedom");
    if dof > 1000 {
        return cornish_fisher(dof as f64);
    }
    // P(|T| ≤ t) grows with t: bisect for 0.95 (a bracket first, then to the last bit).
    let mut high = 2.0;
    while two_sided_cdf(high, dof) < 0.95 {
        high *= 2.0;
    }
    let mut low = 0.0;
    for _ in 0..100 {
        let mid = 0.5 * (low + high);
        if two_sided_cdf(mid, dof) < 0.95 {
            low = mid;
        } else {
            high = mid;
        }
    }
    0.5 * (low + high)
}

/// P(|T| ≤ t) for Student's t with `nu` degrees of freedom, by the finite series of
/// Abramowitz & Stegun 26.7.3–4 (exact for whole degrees of freedom; no term cancels).
fn two_sided_cdf(t: f64, nu: usize) -> f64 {
    let theta = (t / (nu as f64).sqrt()).atan();
    let (sin, cos) = theta.sin_cos();
    let cos2 = cos * cos;
    if nu % 2 == 1 {
        // 2/π (θ + sin θ (cos θ + 2/3 cos³θ + … + (2·4⋯(ν−3))/(1·3⋯(ν−2)) cos^(ν−2)θ)).
        let mut sum = 0.0;
        if nu > 1 {
            let mut term = cos;
            sum = term;
            for k in 1..=(nu - 3) / 2 {
                term *= cos2 * (2 * k) as f64 / (2 * k + 1) as f64;
                sum += term;
            }
        }
        std::f64::consts::FRAC_2_PI * (theta + sin * sum)
    } else {
        // sin θ (1 + 1/2 cos²θ + … + (1·3⋯(ν−3))/(2·4⋯(ν−2)) cos^(ν−2)θ).
        let (mut term, mut sum) = (1.0, 1.0);
        for k in 1..=(nu - 2) / 2 {
            term *= cos2 * (2 * k - 1) as f64 / (2 * k) as f64;
            sum += term;
        }
        sin * sum
    }
}

/// The Cornish–Fisher expansion of the quantile about the normal's 1.95996 (Abramowitz &
/// Stegun 26.7.5): within 10⁻¹³ of the exact value beyond a thousand degrees of freedom.
fn cornish_fisher(nu: f64) -> f64 {
    let z: f64 = 1.959_963_984_540_054;
    let g1 = (z.powi(3) + z) / 4.0;
    let g2 = (5.0 * z.powi(5) + 16.0 * z.powi(3) + 3.0 * z) / 96.0;
    let g3 = (3.0 * z.powi(7) + 19.0 * z.powi(5) + 17.0 * z.powi(3) - 15.0 * z) / 384.0;
    let g4 = (79.0 * z.powi(9) + 776.0 * z.powi(7) + 1482.0 * z.powi(5)
        - 1920.0 * z.powi(3)
        - 945.0 * z)
        / 92160.0;
    z + g1 / nu + g2 / nu.powi(2) + g3 / nu.powi(3) + g4 / nu.powi(4)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_t_quantile_matches_the_tables() {
        for (dof, table) in [
            (1, 12.706),
            (2, 4.303),
            (3, 3.182),
            (7, 2.365),
            (9, 2.262),
            (30, 2.042),
            (60, 2.000),
            (120, 1.980),
        ] {
            assert!(
                (t_975(dof) - table).abs() < 5e-4,
                "{dof}: {} against {table}",
                t_975(dof)
            );
        }
        // Closed form for 2 degrees of freedom: t² = 2 p² / (1 − p²) with p = 0.95.
        assert!((t_975(2) - (2.0 * 0.9025f64 / 0.0975).sqrt()).abs() < 1e-12);
        // The series and the expansion meet where one hands over to the other.
        assert!((t_975(1000) - cornish_fisher(1000.0)).abs() < 1e-12);
        assert!((t_975(1_000_000) - 1.959_966).abs() < 1e-6);
    }

    fn judged(d: &[f64], delta: Option<f64>) -> Verdict {
        Paired::of(d).unwrap().verdict(delta)
    }

    #[test]
    fn each_verdict_follows_the_interval() {
        // Mean 1, sd 0.1 over 4 seeds: the interval is 1 ± 3.182 · 0.05.
        let p = Paired::of(&[0.9, 1.0, 1.1, 1.0]).unwrap();
        let (low, high) = p.interval.unwrap();
        let half = 3.182_446_305_283_706 * p.sd.unwrap() / 2.0;
        assert!((low - (1.0 - half)).abs() < 1e-12 && (high - (1.0 + half)).abs() < 1e-12);
        assert_eq!(p.verdict(None), Verdict::Rises);
        assert_eq!(judged(&[-0.9, -1.0, -1.1, -1.0], None), Verdict::Falls);
        // Around 0, within ±0.5: none with that δ, unclear with a smaller one or none.
        let small = [0.1, -0.1, 0.05, -0.02];
        assert_eq!(judged(&small, Some(0.5)), Verdict::None);
        assert_eq!(judged(&small, Some(0.1)), Verdict::Unclear);
        assert_eq!(judged(&small, None), Verdict::Unclear);
        // Every seed positive is not enough when the interval reaches 0.
        assert_eq!(judged(&[0.1, 5.0, 0.2], None), Verdict::Unclear);
    }

    #[test]
    fn too_few_seeds_or_no_spread() {
        assert_eq!(judged(&[5.0, 6.0], Some(0.1)), Verdict::Unclear, "n = 2");
        assert_eq!(judged(&[5.0], None), Verdict::Unclear, "n = 1");
        assert_eq!(judged(&[2.0, 2.0, 2.0], None), Verdict::Rises, "s = 0");
        assert_eq!(judged(&[-2.0, -2.0, -2.0], None), Verdict::Falls);
        assert_eq!(judged(&[0.0, 0.0, 0.0], None), Verdict::None);
        assert_eq!(judged(&[2.0, 2.0], None), Verdict::Unclear, "s = 0, n = 2");
        let p = Paired::of(&[2.0, 2.0, 2.0]).unwrap();
        assert_eq!((p.interval, p.t()), (Some((2.0, 2.0)), None));
    }

    #[test]
    fn a_difference_that_is_not_a_number_is_an_error() {
        let e = Paired::of(&[1.0, f64::NAN, 2.0]).unwrap_err();
        assert!(matches!(e, PairedError::NotFinite { index: 1, .. }), "{e}");
        assert!(e.to_string().contains("difference 2 of 3 is NaN"), "{e}");
        assert!(Paired::of(&[f64::INFINITY, 1.0, 1.0]).is_err());
        assert_eq!(Paired::of(&[]), Err(PairedError::Empty));
        for word in ["rises", "falls", "none", "unclear"] {
            assert_eq!(Verdict::from_word(word).unwrap().word(), word);
        }
        assert_eq!(Verdict::from_word("up"), None);
    }
}
