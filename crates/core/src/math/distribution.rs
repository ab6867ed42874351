//! Discrete sampling, one toolkit for every caller (pbrt-v4's `PiecewiseConstant1D/2D` and
//! `AliasTable`): a piecewise-constant distribution over entries, its 2-D form (a marginal
//! over rows and a conditional over each row's columns), and an alias table for constant-
//! time draws from a fixed set. Each answers `sample`, `pmf` and `invert`, and hands back
//! where the draw fell inside its entry so stratified numbers stay stratified.
//!
//! Sums are kept in `f64` (a large environment map's distribution would lose its small
//! texels in `f32`), as running sums of the weights in their order, so a caller that
//! summed the same weights in the same order gets the same bits.

/// The largest `f64` below 1: a sample coordinate is clamped to `[0, ONE_BELOW]`.
const ONE_BELOW: f64 = 1.0 - f64::EPSILON / 2.0;

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

#[cfg(test)]
mod tests {
    use super::*;

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
}
