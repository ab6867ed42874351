//! The error of approximate values against the exact ones they stand for, as the error
//! probes ([`super::error_probes`]) measure the caches and thinning: relative errors where
//! the exact value is not negligible, and the bias of their sum.

use serde::{Deserialize, Serialize};

/// The error of one cached quantity at the probes.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ErrorBound {
    /// Σ cached / Σ exact − 1: the bias of a mean.
    pub mean: f64,
    /// 99th percentile of |cached − exact| / exact.
    pub p99: f64,
    /// Largest |cached − exact| / exact.
    pub max: f64,
}

impl ErrorBound {
    /// The bound of paired `(cached, exact)` values: relative errors where the exact value
    /// is at least 1 % of the largest (`None` when no value is).
    pub fn of(pairs: &[(f32, f32)]) -> Option<ErrorBound> {
        let largest = pairs.iter().map(|p| p.1).fold(0.0f32, f32::max);
        if largest <= 0.0 {
            return None;
        }
        let (mut cached, mut exact) = (0.0f64, 0.0f64);
        let mut relative: Vec<f64> = Vec::with_capacity(pairs.len());
        for &(c, e) in pairs {
            cached += c as f64;
            exact += e as f64;
            if e >= 0.01 * largest {
                relative.push(((c - e) / e).abs() as f64);
            }
        }
        relative.sort_by(f64::total_cmp);
        let p99 = relative[((relative.len() - 1) as f64 * 0.99).round() as usize];
        Some(ErrorBound {
            mean: cached / exact - 1.0,
            p99,
            max: *relative.last().expect("the largest value qualifies"),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bounds_ignore_negligible_values_and_report_the_bias() {
        let pairs = [(1.1, 1.0), (0.9, 1.0), (2.0, 2.0), (1e-6, 1e-4)];
        let b = ErrorBound::of(&pairs).unwrap();
        assert!((b.max - 0.1).abs() < 1e-6, "{b:?}");
        assert!((b.mean - (4.000001 / 4.0001 - 1.0)).abs() < 1e-9, "{b:?}");
        assert_eq!(ErrorBound::of(&[(1.0, 0.0)]), None);
    }
}
