//! Discrete sampling, one toolkit for every caller (pbrt-v4's `PiecewiseConstant1D/2D`,
//! `AliasTable` and `SampleDiscrete`): a piecewise-constant distribution over entries, its
//! 2-D form (a marginal over rows and a conditional over each row's columns), an alias
//! table for constant-time draws from a fixed set, and [`sample_discrete`] for one draw
//! among a few weights built on the spot (the reference tracer's light choice, the
//! environment's sun or map). The tables answer `sample`, `pmf` and `invert`; every draw
//! hands back where it fell inside its entry so stratified numbers stay stratified.
//! [`apportion`] splits a count over entries instead of drawing one (the photons each light
//! emits).
//!
//! Sums are kept in `f64` (a large environment map's distribution would lose its small
//! texels in `f32`), as running sums of the weights in their order, so a caller that
//! summed the same weights in the same order gets the same bits. [`sample_discrete`] sums
//! its `f32` weights the same way, from 0 in index order.

/// The largest `f64` below 1: a sample coordinate is clamped to `[0, ONE_BELOW]`.
const ONE_BELOW: f64 = 1.0 - f64::EPSILON / 2.0;

/// The largest `f32` below 1 (`1 − 2⁻²⁴`): [`sample_discrete`]'s remapped `u` is clamped to
/// `[0, ONE_BELOW_F32]`.
const ONE_BELOW_F32: f32 = 1.0 - f32::EPSILON / 2.0;

/// A sample coordinate clamped into `[0, 1)` (a NaN reads as 0).
pub(crate) fn unit_interval(u: f64) -> f64 {
    if u.is_nan() {
        0.0
    } else {
        u.clamp(0.0, ONE_BELOW)
    }
}

/// A distribution over entries `0..n` proportional to their weights (piecewise constant
/// over the unit interval, each entry's width its share).
///
/// ```
/// use volphot::PiecewiseConstant1D;
/// let d = PiecewiseConstant1D::new([1.0, 0.0, 3.0]);
/// assert_eq!(d.pmf(2), 0.75);
/// // u = 0.5 lands a third of the way into entry 2 (which covers [0.25, 1)).
/// let (entry, within) = d.sample(0.5).unwrap();
/// assert_eq!(entry, 2);
/// assert!((within - 1.0 / 3.0).abs() < 1e-12);
/// assert!((d.invert(entry, within) - 0.5).abs() < 1e-12);
/// ```
#[derive(Debug, Clone, PartialEq, Default)]
pub struct PiecewiseConstant1D {
    /// Running sums: entry `i` holds the weights of `0..=i`.
    cdf: Vec<f64>,
}

impl PiecewiseConstant1D {
    /// The distribution of `weights` (each ≥ 0).
    pub fn new(weights: impl IntoIterator<Item = f64>) -> Self {
        let mut running = 0.0;
        let cdf = weights
            .into_iter()
            .map(|w| {
                running += w;
                running
            })
            .collect();
        PiecewiseConstant1D { cdf }
    }

    /// The distribution whose running sums are `cdf` (non-decreasing).
    pub fn from_running_sums(cdf: Vec<f64>) -> Self {
        debug_assert!(cdf.windows(2).all(|w| w[0] <= w[1]));
        PiecewiseConstant1D { cdf }
    }

    /// The number of entries.
    pub fn len(&self) -> usize {
        self.cdf.len()
    }

    /// Whether there are no entries.
    pub fn is_empty(&self) -> bool {
        self.cdf.is_empty()
    }

    /// The sum of the weights.
    pub fn total(&self) -> f64 {
        self.cdf.last().copied().unwrap_or(0.0)
    }

    /// The running sums as the view every search and inversion goes through.
    fn view(&self) -> PiecewiseConstantView<'_> {
        PiecewiseConstantView { cdf: &self.cdf }
    }

    /// Entry `i`'s weight.
    pub fn weight(&self, i: usize) -> f64 {
        self.view().weight(i)
    }

    /// The probability of entry `i` (0 for a distribution of no weight).
    pub fn pmf(&self, i: usize) -> f64 {
        let total = self.total();
        if total > 0.0 {
            self.weight(i) / total
        } else {
            0.0
        }
    }

    /// The entry `u` (clamped into `[0, 1)`) falls in, and where inside it, in `[0, 1)`;
    /// `None` when the weights sum to 0 (or are not finite). An entry of weight 0 is never
    /// drawn.
    pub fn sample(&self, u: f64) -> Option<(usize, f64)> {
        let total = self.total();
        if !(total > 0.0 && total.is_finite()) {
            return None;
        }
        Some(self.view().search(unit_interval(u) * total))
    }

    /// The `u` that [`Self::sample`] maps to entry `i` at position `f` inside it.
    pub fn invert(&self, i: usize, f: f64) -> f64 {
        self.view().invert(i, f)
    }
}

/// A distribution over the cells of a `width × height` grid proportional to their
/// weights: a marginal over rows (each row's weight the sum of its columns) and, in each
/// row, a conditional over its columns.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct PiecewiseConstant2D {
    width: usize,
    /// Each row's running sums over its columns, row after row.
    conditional: Vec<f64>,
    /// The rows' running sums: each row's weight is exactly the last entry of its
    /// conditional, so a row drawn here always has a column with weight.
    marginal: PiecewiseConstant1D,
}

impl PiecewiseConstant2D {
    /// The distribution of `weight(row, column)` over `width × height` cells (each ≥ 0),
    /// summed row by row in column order.
    pub fn new(width: usize, height: usize, weight: impl Fn(usize, usize) -> f64) -> Self {
        let mut conditional = Vec::with_capacity(width * height);
        let mut rows = Vec::with_capacity(height);
        let mut total = 0.0;
        for row in 0..height {
            let mut running = 0.0;
            for column in 0..width {
                running += weight(row, column);
                conditional.push(running);
            }
            total += running;
            rows.push(total);
        }
        PiecewiseConstant2D {
            width,
            conditional,
            marginal: PiecewiseConstant1D::from_running_sums(rows),
        }
    }

    /// The sum of every cell's weight.
    pub fn total(&self) -> f64 {
        self.marginal.total()
    }

    fn row(&self, row: usize) -> PiecewiseConstantView<'_> {
        let start = row * self.width;
        PiecewiseConstantView {
            cdf: &self.conditional[start..start + self.width],
        }
    }

    /// The cell `u` falls in — `(row, position in the row, column, position in the
    /// column)`, positions in `[0, 1)` — or `None` when every weight is 0.
    pub fn sample(&self, u: [f64; 2]) -> Option<(usize, f64, usize, f64)> {
        let (row, f_row) = self.marginal.sample(u[0])?;
        let conditional = self.row(row);
        let row_weight = conditional.cdf[self.width - 1];
        let (column, f_column) = conditional.search(unit_interval(u[1]) * row_weight);
        Some((row, f_row, column, f_column))
    }

    /// The probability of cell `(row, column)`.
    pub fn pmf(&self, row: usize, column: usize) -> f64 {
        let total = self.total();
        if total > 0.0 {
            self.row(row).weight(column) / total
        } else {
            0.0
        }
    }

    /// The `u` that [`Self::sample`] maps to cell `(row, column)` at the given positions.
    pub fn invert(&self, row: usize, f_row: f64, column: usize, f_column: f64) -> [f64; 2] {
        [
            self.marginal.invert(row, f_row),
            self.row(row).invert(column, f_column),
        ]
    }
}

/// A borrowed run of running sums: what [`PiecewiseConstant1D`] and each row of the 2-D
/// distribution search and invert (a row without copying it).
struct PiecewiseConstantView<'a> {
    cdf: &'a [f64],
}

impl PiecewiseConstantView<'_> {
    fn below(&self, i: usize) -> f64 {
        if i == 0 { 0.0 } else { self.cdf[i - 1] }
    }

    fn weight(&self, i: usize) -> f64 {
        self.cdf[i] - self.below(i)
    }

    fn invert(&self, i: usize, f: f64) -> f64 {
        let total = self.cdf.last().copied().unwrap_or(0.0);
        if total > 0.0 {
            (self.below(i) + f * self.weight(i)) / total
        } else {
            0.0
        }
    }

    /// The first entry whose running sum lies strictly above `target` (so an entry of
    /// weight zero is never chosen), and where `target` falls inside it, in `[0, 1)`.
    fn search(&self, target: f64) -> (usize, f64) {
        let cdf = self.cdf;
        let mut i = cdf.partition_point(|&c| c <= target);
        if i == cdf.len() {
            // Only when rounding put `target` at the total: take the last entry with weight.
            i = (0..cdf.len())
                .rev()
                .find(|&j| self.weight(j) > 0.0)
                .unwrap_or(cdf.len() - 1);
        }
        let width = self.weight(i);
        let f = if width > 0.0 {
            ((target - self.below(i)) / width).clamp(0.0, ONE_BELOW)
        } else {
            0.5
        };
        (i, f)
    }
}

/// Vose's alias table: a draw from a fixed discrete distribution in constant time (one
/// uniform chooses a bin, the same uniform's remainder chooses between the bin and its
/// alias), for choices made many times from the same weights.
///
/// ```
/// use volphot::AliasTable;
/// let table = AliasTable::new(&[1.0, 3.0]).unwrap();
/// assert_eq!(table.pmf(1), 0.75);
/// let draws = 1000;
/// let second = (0..draws)
///     .filter(|k| table.sample((*k as f64 + 0.5) / draws as f64).0 == 1)
///     .count();
/// assert_eq!(second, 750);
/// ```
#[derive(Debug, Clone, PartialEq, Default)]
pub struct AliasTable {
    /// Each bin's probability of keeping its own entry, and the entry it otherwise gives.
    bins: Vec<(f64, usize)>,
    pmf: Vec<f64>,
}

impl AliasTable {
    /// The table of `weights` (each ≥ 0, not all 0), or `None` when they sum to 0 or are
    /// not finite.
    pub fn new(weights: &[f64]) -> Option<Self> {
        let total: f64 = weights.iter().sum();
        if !(total > 0.0 && total.is_finite()) {
            return None;
        }
        let n = weights.len();
        let pmf: Vec<f64> = weights.iter().map(|w| w / total).collect();
        let scaled: Vec<f64> = pmf.iter().map(|p| p * n as f64).collect();
        let (mut small, mut large): (Vec<usize>, Vec<usize>) =
            (0..n).partition(|&i| scaled[i] < 1.0);
        let mut bins = vec![(1.0, 0usize); n];
        let mut left = scaled.clone();
        while let (Some(s), Some(&l)) = (small.pop(), large.last()) {
            bins[s] = (left[s], l);
            left[l] -= 1.0 - left[s];
            if left[l] < 1.0 {
                large.pop();
                small.push(l);
            }
        }
        // What rounding leaves in either list keeps its whole bin.
        for i in small.into_iter().chain(large) {
            bins[i] = (1.0, i);
        }
        Some(AliasTable { bins, pmf })
    }

    /// The number of entries.
    pub fn len(&self) -> usize {
        self.pmf.len()
    }

    /// Whether there are no entries.
    pub fn is_empty(&self) -> bool {
        self.pmf.is_empty()
    }

    /// The probability of entry `i`.
    pub fn pmf(&self, i: usize) -> f64 {
        self.pmf[i]
    }

    /// The entry `u` (clamped into `[0, 1)`) draws, and a fresh uniform in `[0, 1)` left
    /// over from it.
    pub fn sample(&self, u: f64) -> (usize, f64) {
        let scaled = unit_interval(u) * self.bins.len() as f64;
        let bin = (scaled as usize).min(self.bins.len() - 1);
        let within = scaled - bin as f64;
        let (keep, alias) = self.bins[bin];
        if within < keep {
            (bin, unit_interval(within / keep))
        } else {
            (alias, unit_interval((within - keep) / (1.0 - keep)))
        }
    }
}

/// One entry of `weights` (each ≥ 0) drawn by `u` (in `[0, 1)`) with probability
/// `weight / total`: `(entry, its probability, u remapped)`, the last where the draw fell
/// inside the entry, in `[0, 1)` (a fresh uniform for a choice that follows). `None` when
/// the weights sum to 0 or to no finite number. An entry of weight 0 is never drawn.
///
/// The weights are summed from 0 in index order, so a caller that sums them the same way
/// holds the same total to the bit: it can decide whether to draw at all before spending a
/// random number, and divide by `total / weight` itself rather than by the probability.
///
/// pbrt-v4's `SampleDiscrete` (`src/pbrt/util/sampling.h`) is the model, with four
/// differences. (1) pbrt walks a running sum up, `while (sum + w[i] <= up) sum += w[i++]`;
/// ours subtracts each weight from `u · total` and stops at the first entry whose weight
/// exceeds what is left. The two round differently, so at an entry's edge they may pick
/// neighbours an ulp apart; the subtraction is the scan the reference tracer's light
/// choice always made, and keeping it keeps the references' images bit-identical.
/// (2) Weights of 0 (or below) are skipped by test, not by `sum + 0 <= up`. (3) pbrt
/// nudges `up` below the total (`NextFloatDown`) and asserts it never runs past the end;
/// here a draw that rounding carries past the end takes the last entry with weight, its
/// `u` remapped to just below 1. (4) pbrt answers -1 for no weights and does not guard an
/// all-zero or non-finite sum; here each is `None`. The remapped `u` is clamped into
/// `[0, 1)` on both sides (pbrt: only from above).
///
/// ```text
/// sample_discrete(&[1.0, 0.0, 3.0], 0.5) == Some((2, 0.75, 1.0 / 3.0))
/// ```
pub fn sample_discrete(weights: &[f32], u: f32) -> Option<(usize, f32, f32)> {
    // The caller's loop, spelled out (`Sum` for floats starts from −0).
    let mut total = 0.0f32;
    for &w in weights {
        total += w;
    }
    if !(total > 0.0 && total.is_finite()) {
        return None;
    }
    let drawn = |entry: usize, rest: f32| {
        let weight = weights[entry];
        let within = rest / weight;
        let within = if within.is_nan() {
            0.0
        } else {
            within.clamp(0.0, ONE_BELOW_F32)
        };
        (entry, weight / total, within)
    };
    let mut rest = u * total;
    let mut last = None;
    for (entry, &weight) in weights.iter().enumerate().filter(|(_, w)| **w > 0.0) {
        if rest < weight {
            return Some(drawn(entry, rest));
        }
        last = Some((entry, rest));
        rest -= weight;
    }
    // Only when rounding left `rest` at or past the last weight.
    last.map(|(entry, rest)| drawn(entry, rest))
}

/// `total` items split over entries in proportion to `weights` (each ≥ 0) by the largest-
/// remainder method: each entry gets the whole part of its exact share
/// `total · weight / Σ weights`, and what is left goes one each to the entries of the
/// largest fractional parts, the lower index first where they tie. The counts sum to
/// `total`, each within 1 of its share, and an entry of weight 0 gets none; all are 0
/// when the weights sum to 0 (or there are none).
///
/// ```text
/// apportion(&[1.0, 1.0, 1.0], 2) == [1, 1, 0]
/// apportion(&[0.0, 1.0, 0.0, 3.0], 7) == [0, 2, 0, 5]
/// ```
pub fn apportion(weights: &[f64], total: u64) -> Vec<u64> {
    let sum: f64 = weights.iter().sum();
    if sum <= 0.0 || weights.is_empty() {
        return vec![0; weights.len()];
    }
    let exact: Vec<f64> = weights.iter().map(|w| total as f64 * w / sum).collect();
    let mut counts: Vec<u64> = exact.iter().map(|e| e.floor() as u64).collect();
    let mut remainder = total - counts.iter().sum::<u64>();
    let mut order: Vec<usize> = (0..weights.len()).collect();
    order.sort_by(|&a, &b| {
        (exact[b] - exact[b].floor())
            .partial_cmp(&(exact[a] - exact[a].floor()))
            .unwrap_or(std::cmp::Ordering::Equal)
            .then(a.cmp(&b))
    });
    for &i in order.iter().cycle() {
        if remainder == 0 {
            break;
        }
        counts[i] += 1;
        remainder -= 1;
    }
    counts
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::{Domain, Rng};

    /// Draws `n` stratified uniforms and counts where they land.
    fn counts(n: usize, entries: usize, draw: impl Fn(f64) -> usize) -> Vec<f64> {
        let mut c = vec![0.0; entries];
        for k in 0..n {
            c[draw((k as f64 + 0.5) / n as f64)] += 1.0 / n as f64;
        }
        c
    }

    #[test]
    fn a_1d_distribution_draws_each_entry_by_its_weight_and_inverts() {
        let d = PiecewiseConstant1D::new([1.0, 0.0, 3.0, 4.0]);
        assert_eq!(d.total(), 8.0);
        let got = counts(80_000, 4, |u| d.sample(u).unwrap().0);
        for (i, p) in [0.125, 0.0, 0.375, 0.5].into_iter().enumerate() {
            assert!(
                (got[i] - p).abs() < 1e-4,
                "entry {i}: {} against {p}",
                got[i]
            );
            assert_eq!(d.pmf(i), p);
        }
        for u in [0.0, 0.1, 0.37, 0.5, 0.99] {
            let (i, f) = d.sample(u).unwrap();
            assert!((d.invert(i, f) - u).abs() < 1e-12, "{u}");
        }
        assert!(PiecewiseConstant1D::new([0.0, 0.0]).sample(0.3).is_none());
        // The ends and a NaN stay inside, never on an entry of no weight.
        for u in [f64::NAN, -1.0, 1.0, 2.0] {
            let (i, f) = d.sample(u).unwrap();
            assert!(d.weight(i) > 0.0 && (0.0..1.0).contains(&f), "{u}: {i} {f}");
        }
    }

    #[test]
    fn a_2d_distribution_is_its_marginal_times_its_conditional() {
        let w = |r: usize, c: usize| ((r * 3 + c) % 5) as f64;
        let d = PiecewiseConstant2D::new(3, 4, w);
        let total: f64 = (0..4).flat_map(|r| (0..3).map(move |c| w(r, c))).sum();
        assert_eq!(d.total(), total);
        let n = 400;
        let mut got = [0.0; 12];
        for a in 0..n {
            for b in 0..n {
                let u = [(a as f64 + 0.5) / n as f64, (b as f64 + 0.5) / n as f64];
                let (r, fr, c, fc) = d.sample(u).unwrap();
                got[r * 3 + c] += 1.0 / (n * n) as f64;
                let back = d.invert(r, fr, c, fc);
                assert!((back[0] - u[0]).abs() < 1e-12 && (back[1] - u[1]).abs() < 1e-12);
            }
        }
        for r in 0..4 {
            for c in 0..3 {
                let p = w(r, c) / total;
                assert!((got[r * 3 + c] - p).abs() < 3e-3, "({r}, {c})");
                assert!((d.pmf(r, c) - p).abs() < 1e-15);
            }
        }
    }

    #[test]
    fn an_alias_table_draws_each_entry_by_its_weight_with_a_fresh_remainder() {
        let weights = [0.5, 2.0, 0.0, 1.5, 4.0];
        let t = AliasTable::new(&weights).unwrap();
        let total: f64 = weights.iter().sum();
        let got = counts(100_000, 5, |u| t.sample(u).0);
        for (i, w) in weights.iter().enumerate() {
            assert!((got[i] - w / total).abs() < 1e-4, "entry {i}: {}", got[i]);
            assert_eq!(t.pmf(i), w / total);
        }
        // The remainder is uniform: its mean over many draws is a half.
        let mean: f64 = (0..100_000)
            .map(|k| t.sample((k as f64 + 0.5) / 1e5).1)
            .sum::<f64>()
            / 1e5;
        assert!((mean - 0.5).abs() < 1e-3, "{mean}");
        assert!(AliasTable::new(&[0.0, 0.0]).is_none());
        assert!(AliasTable::new(&[f64::INFINITY]).is_none());
    }

    /// The reference tracer's light choice as it was written before the toolkit took it
    /// over (`choose` in `integrator/reference/weighted.rs`), with the caller's sum: the
    /// entry it took, or `None` where the caller drew nothing.
    fn old_light_choice(weights: &[f32], u: f32) -> Option<usize> {
        let mut total = 0.0f32;
        for &w in weights {
            total += w;
        }
        if total <= 0.0 {
            return None;
        }
        let mut u = u * total;
        let mut last = 0;
        for (i, &w) in weights.iter().enumerate().filter(|(_, w)| **w > 0.0) {
            if u < w {
                return Some(i);
            }
            u -= w;
            last = i;
        }
        Some(last)
    }

    #[test]
    fn a_discrete_draw_takes_each_entry_by_its_weight_with_its_exact_pmf() {
        let weights = [0.5f32, 2.0, 0.0, 1.5, 4.0];
        let pmf = [0.0625f32, 0.25, 0.0, 0.1875, 0.5];
        let n = 80_000;
        let mut count = [0usize; 5];
        for k in 0..n {
            let u = (k as f32 + 0.5) / n as f32;
            let (i, p, _) = sample_discrete(&weights, u).unwrap();
            count[i] += 1;
            assert_eq!(p, pmf[i], "entry {i}");
            assert_eq!(p, weights[i] / 8.0);
        }
        // Stratified draws land within a draw or two of each expectation, so the chi-square
        // statistic is far below its 3 degrees of freedom (where random draws would put it).
        let chi2: f64 = (0..5)
            .filter(|&i| pmf[i] > 0.0)
            .map(|i| {
                let expected = n as f64 * pmf[i] as f64;
                (count[i] as f64 - expected).powi(2) / expected
            })
            .sum();
        assert!(chi2 < 0.01, "chi-square {chi2}, counts {count:?}");
        assert_eq!(count[2], 0);
    }

    #[test]
    fn a_discrete_draw_remaps_u_uniformly_inside_each_entry() {
        let weights = [0.5f32, 2.0, 0.0, 1.5, 4.0];
        let n = 80_000;
        // Per entry: how many draws, the sum of their remapped u, and a 10-bucket histogram.
        let mut seen = [(0usize, 0.0f64, [0usize; 10]); 5];
        for k in 0..n {
            let (i, _, f) = sample_discrete(&weights, (k as f32 + 0.5) / n as f32).unwrap();
            assert!((0.0..1.0).contains(&f), "{f}");
            seen[i].0 += 1;
            seen[i].1 += f as f64;
            seen[i].2[(f * 10.0) as usize] += 1;
        }
        for (i, (draws, sum, buckets)) in seen.iter().enumerate().filter(|(_, s)| s.0 > 0) {
            let mean = sum / *draws as f64;
            assert!((mean - 0.5).abs() < 1e-3, "entry {i}: mean {mean}");
            for (b, &c) in buckets.iter().enumerate() {
                let expected = *draws as f64 / 10.0;
                assert!(
                    (c as f64 - expected).abs() <= 2.0,
                    "entry {i}, bucket {b}: {c} of {draws}"
                );
            }
        }
    }

    #[test]
    fn a_discrete_draw_never_takes_a_zero_weight_and_needs_a_positive_finite_sum() {
        let mut rng = Rng::stream(7, Domain::Misc, 0);
        for _ in 0..10_000 {
            let weights: Vec<f32> = (0..6)
                .map(|_| {
                    if rng.uniform() < 0.4 {
                        0.0
                    } else {
                        rng.uniform() * 10.0
                    }
                })
                .collect();
            for u in [0.0, rng.uniform(), ONE_BELOW_F32] {
                match sample_discrete(&weights, u) {
                    Some((i, p, f)) => {
                        assert!(weights[i] > 0.0 && p > 0.0, "{weights:?} {u}: {i}");
                        assert!((0.0..1.0).contains(&f), "{weights:?} {u}: {f}");
                    }
                    None => assert!(weights.iter().all(|&w| w == 0.0), "{weights:?}"),
                }
            }
        }
        // Rounding carries this draw past the last weight: it takes the last entry with
        // weight (not the trailing 0), just below the top of it.
        let weights = [0.3f32, 1.1, 0.001, 0.0];
        let (i, _, f) = sample_discrete(&weights, ONE_BELOW_F32).unwrap();
        assert_eq!((i, f), (2, ONE_BELOW_F32));
        assert_eq!(old_light_choice(&weights, ONE_BELOW_F32), Some(2));
        assert_eq!(sample_discrete(&[], 0.5), None);
        assert_eq!(sample_discrete(&[0.0, 0.0], 0.5), None);
        assert_eq!(sample_discrete(&[1.0, f32::INFINITY], 0.5), None);
        assert_eq!(sample_discrete(&[1.0, f32::NAN], 0.5), None);
    }

    /// The reference tracer's light choice goes through [`sample_discrete`]: on any weights
    /// (zeros, magnitudes from 10⁻⁶ to 10⁶, up to the 16 lights it chooses among) and any
    /// `u` (the generator's 24-bit grid and off it) it takes the entry the old scan took.
    #[test]
    fn a_discrete_draw_is_the_old_light_choice_bit_for_bit() {
        let mut rng = Rng::stream(11, Domain::Misc, 0);
        for _ in 0..50_000 {
            let n = 1 + (rng.uniform() * 16.0) as usize;
            let weights: Vec<f32> = (0..n)
                .map(|_| {
                    if rng.uniform() < 0.25 {
                        0.0
                    } else {
                        rng.uniform() * 10f32.powi((rng.uniform() * 13.0) as i32 - 6)
                    }
                })
                .collect();
            let on_grid = rng.uniform();
            let off_grid = rng.uniform() * rng.uniform();
            for u in [0.0, on_grid, off_grid, ONE_BELOW_F32] {
                let mut total = 0.0f32;
                for &w in &weights {
                    total += w;
                }
                let got = sample_discrete(&weights, u);
                assert_eq!(
                    got.map(|(i, _, _)| i),
                    old_light_choice(&weights, u),
                    "{weights:?} {u}"
                );
                if let Some((i, p, _)) = got {
                    assert_eq!(p.to_bits(), (weights[i] / total).to_bits());
                }
            }
        }
    }

    /// The environment's sun-or-map choice through [`sample_discrete`] with the weights
    /// `[p, 1 − p]`: since `p + (1 − p)` rounds to exactly 1 for every `p` in [0, 1], the
    /// draw is the old `u < p`, and the remapped `u` the old `u / p` for the sun and
    /// `((u − p) / (1 − p))` clamped for the map, bit for bit.
    #[test]
    fn a_two_way_draw_is_the_old_sun_or_map_choice_bit_for_bit() {
        let old = |p: f32, u: f32| -> (usize, f32) {
            if u < p {
                (0, u / p)
            } else {
                (
                    1,
                    ((u - p) / (1.0 - p)).clamp(0.0, 1.0 - f32::EPSILON / 2.0),
                )
            }
        };
        let mut rng = Rng::stream(13, Domain::Misc, 0);
        let mut ps = vec![
            0.0,
            1.0,
            0.5,
            0.5 - f32::EPSILON / 4.0,
            0.5 + f32::EPSILON / 2.0,
            ONE_BELOW_F32,
            f32::MIN_POSITIVE,
            f32::from_bits(1),
            1e-30,
        ];
        for _ in 0..20_000 {
            let r = rng.uniform();
            ps.push(r);
            ps.push(r * r * r);
        }
        for p in ps {
            assert_eq!(p + (1.0 - p), 1.0, "{p}");
            let mut us = vec![
                0.0,
                ONE_BELOW_F32,
                rng.uniform(),
                rng.uniform() * rng.uniform(),
            ];
            if p < 1.0 {
                us.push(p);
            }
            for u in us {
                let (i, _, f) = sample_discrete(&[p, 1.0 - p], u).unwrap();
                let (old_i, old_f) = old(p, u);
                assert_eq!((i, f.to_bits()), (old_i, old_f.to_bits()), "p {p}, u {u}");
            }
        }
    }

    #[test]
    fn apportioning_gives_each_entry_its_share_within_one_and_all_of_the_total() {
        let mut rng = Rng::stream(17, Domain::Misc, 0);
        for _ in 0..5_000 {
            let n = 1 + (rng.uniform() * 10.0) as usize;
            let weights: Vec<f64> = (0..n)
                .map(|_| {
                    if rng.uniform() < 0.3 {
                        0.0
                    } else {
                        rng.uniform() as f64 * 100.0
                    }
                })
                .collect();
            let total = (rng.uniform() * 1e6) as u64;
            let counts = apportion(&weights, total);
            assert_eq!(counts.len(), n);
            let sum: f64 = weights.iter().sum();
            if sum == 0.0 {
                assert!(counts.iter().all(|&c| c == 0), "{counts:?}");
                continue;
            }
            assert_eq!(counts.iter().sum::<u64>(), total, "{weights:?}");
            for (&c, &w) in counts.iter().zip(&weights) {
                let share = total as f64 * w / sum;
                assert!((c as f64 - share).abs() < 1.0, "{c} for {share}");
                if w == 0.0 {
                    assert_eq!(c, 0);
                }
            }
        }
    }

    #[test]
    fn apportioning_breaks_ties_by_index_and_gives_zero_weights_nothing() {
        // Equal fractions: the lower index first.
        assert_eq!(apportion(&[1.0, 1.0, 1.0], 2), [1, 1, 0]);
        assert_eq!(apportion(&[1.0, 1.0, 1.0, 1.0], 5), [2, 1, 1, 1]);
        assert_eq!(apportion(&[1.0, 2.0, 1.0], 2), [1, 1, 0]);
        // The largest fraction first, whatever its index.
        assert_eq!(apportion(&[0.0, 1.0, 0.0, 3.0], 7), [0, 2, 0, 5]);
        assert_eq!(apportion(&[1.0, 3.0, 0.0001], 1001), [250, 751, 0]);
        assert_eq!(apportion(&[0.0, 0.0], 9), [0, 0]);
        assert_eq!(apportion(&[], 9), Vec::<u64>::new());
    }
}
