//! The search space: each parameter's model space (ln for log scales, an index for
//! choices), uniform sampling, and the scene value a parameter value sets.

use rand::{Rng, RngExt};
use toml::Value;

use crate::plan::{Param, ParamKind};

/// Keeps the exclusive upper bound of `tpe`'s ranges just above `hi`.
const PAD: f64 = 1e-9;

impl Param {
    /// The half-open model-space range `[start, end)`.
    pub(crate) fn model_range(&self) -> (f64, f64) {
        match &self.kind {
            ParamKind::Float { lo, hi, log: true } => (lo.ln(), hi.ln() + PAD),
            ParamKind::Float { lo, hi, log: false } => (*lo, hi + PAD * (hi - lo).abs().max(1.0)),
            ParamKind::Int { lo, hi, log: true } => {
                ((*lo as f64 - 0.5).max(0.5).ln(), (*hi as f64 + 0.5).ln())
            }
            ParamKind::Int { lo, hi, log: false } => (*lo as f64 - 0.5, *hi as f64 + 0.5),
            ParamKind::Choice(c) => (0.0, c.len() as f64),
        }
    }

    /// Model space → parameter value (integers rounded, choices as an index).
    pub(crate) fn decode(&self, z: f64) -> f64 {
        match &self.kind {
            ParamKind::Float { lo, hi, log } => {
                round_sig(if *log { z.exp() } else { z }, 6).clamp(*lo, *hi)
            }
            ParamKind::Int { lo, hi, log } => {
                let v = if *log { z.exp() } else { z };
                (v.round() as i64).clamp(*lo, *hi) as f64
            }
            ParamKind::Choice(c) => z.floor().clamp(0.0, (c.len() - 1) as f64),
        }
    }

    /// Parameter value → model space (what the proposal model is told), inside the range.
    pub(crate) fn encode(&self, v: f64) -> f64 {
        let z = match &self.kind {
            ParamKind::Float { log: true, .. } | ParamKind::Int { log: true, .. } => v.ln(),
            _ => v,
        };
        let (start, end) = self.model_range();
        z.clamp(start, end - PAD * (end - start).abs().max(1.0))
    }

    /// A uniform draw in model space, decoded.
    pub(crate) fn sample<R: Rng + ?Sized>(&self, rng: &mut R) -> f64 {
        let (start, end) = self.model_range();
        self.decode(rng.random_range(start..end))
    }

    /// Whether sensitivity bins it by category.
    pub(crate) fn is_choice(&self) -> bool {
        matches!(self.kind, ParamKind::Choice(_))
    }

    /// The scene value of a parameter value.
    pub(crate) fn value(&self, v: f64) -> Value {
        match &self.kind {
            ParamKind::Float { .. } => Value::Float(round_sig(v, 6)),
            ParamKind::Int { .. } => Value::Integer(v as i64),
            ParamKind::Choice(c) => c[v as usize].clone(),
        }
    }

    /// The value as text for tables.
    pub(crate) fn text(&self, v: f64) -> String {
        crate::plan::value_text(&self.value(v))
    }
}

/// `v` rounded to `digits` significant digits, so scene files and labels stay readable
/// (and a configuration's cells have short, stable keys).
pub(crate) fn round_sig(v: f64, digits: i32) -> f64 {
    if v == 0.0 || !v.is_finite() {
        return v;
    }
    let scale = 10f64.powi(digits - 1 - v.abs().log10().floor() as i32);
    (v * scale).round() / scale
}

#[cfg(test)]
mod tests {
    use rand::SeedableRng;
    use rand_pcg::Pcg64Mcg;

    use super::*;

    fn param(kind: ParamKind) -> Param {
        Param {
            key: "k".into(),
            kind,
        }
    }

    #[test]
    fn samples_stay_in_range_and_round_trip() {
        let mut rng = Pcg64Mcg::seed_from_u64(3);
        let kinds = [
            ParamKind::Float {
                lo: 0.01,
                hi: 0.5,
                log: true,
            },
            ParamKind::Int {
                lo: 2,
                hi: 1000,
                log: true,
            },
            ParamKind::Int {
                lo: -3,
                hi: 3,
                log: false,
            },
            ParamKind::Choice(vec![Value::from("a"), Value::from("b")]),
        ];
        for kind in kinds {
            let p = param(kind);
            let (start, end) = p.model_range();
            for _ in 0..500 {
                let v = p.sample(&mut rng);
                let z = p.encode(v);
                assert!(
                    start <= z && z < end,
                    "{p:?}: {v} → {z} outside {start}..{end}"
                );
                assert_eq!(p.decode(z), v, "{p:?}");
            }
        }
        // Integer ends are reachable.
        let p = param(ParamKind::Int {
            lo: 2,
            hi: 4,
            log: false,
        });
        let seen: std::collections::BTreeSet<i64> =
            (0..200).map(|_| p.sample(&mut rng) as i64).collect();
        assert_eq!(seen.into_iter().collect::<Vec<_>>(), vec![2, 3, 4]);
    }

    #[test]
    fn rounding_keeps_six_digits() {
        assert_eq!(round_sig(0.123456789, 6), 0.123457);
        assert_eq!(round_sig(81234.56789, 3), 81200.0);
        assert_eq!(round_sig(0.0, 3), 0.0);
    }
}
