//! Byte ranges of a text (where a Markdown renderer sees code, raw HTML, a heading) and
//! the starts of its lines, asked about in logarithmic time. A leaf shared by `sweep
//! claims` and the report's escaping: both ask "is this offset inside code?" once per
//! number or character, and a list searched from its start each time made a document of
//! 100 000 claims, or a description of 100 000 code spans, quadratic.
//!
//! [`work`] counts the steps of those scans in tests, so that a test can check that
//! doubling a document doubles the work without timing anything.

use std::ops::Range;

/// Sorted, disjoint ranges: overlapping and touching ones merged.
#[derive(Debug, Clone, Default)]
pub(crate) struct Spans {
    ranges: Vec<Range<usize>>,
}

impl Spans {
    /// The union of `ranges`, in any order.
    pub(crate) fn new(ranges: impl IntoIterator<Item = Range<usize>>) -> Spans {
        let mut all: Vec<Range<usize>> = ranges.into_iter().filter(|r| r.start < r.end).collect();
        all.sort_by_key(|r| r.start);
        work::add(all.len());
        let mut merged: Vec<Range<usize>> = Vec::with_capacity(all.len());
        for r in all {
            match merged.last_mut() {
                Some(last) if r.start <= last.end => last.end = last.end.max(r.end),
                _ => merged.push(r),
            }
        }
        Spans { ranges: merged }
    }

    /// The merged range that holds byte `at`, if any.
    pub(crate) fn around(&self, at: usize) -> Option<Range<usize>> {
        let i = self.ranges.partition_point(|r| r.end <= at);
        work::add(usize::BITS as usize - self.ranges.len().leading_zeros() as usize + 1);
        self.ranges.get(i).filter(|r| r.start <= at).cloned()
    }

    /// Whether byte `at` is inside one of the ranges.
    pub(crate) fn contains(&self, at: usize) -> bool {
        self.around(at).is_some()
    }

    /// Whether all of `range` lies inside one merged range.
    pub(crate) fn covers(&self, range: &Range<usize>) -> bool {
        self.around(range.start).is_some_and(|r| range.end <= r.end)
    }

    /// The ranges, sorted and merged.
    pub(crate) fn ranges(&self) -> &[Range<usize>] {
        &self.ranges
    }
}

/// Where each line of a text starts.
#[derive(Debug, Clone)]
pub(crate) struct Lines {
    starts: Vec<usize>,
}

impl Lines {
    pub(crate) fn new(text: &str) -> Lines {
        work::add(text.len());
        let starts = std::iter::once(0)
            .chain(text.match_indices('\n').map(|(i, _)| i + 1))
            .collect();
        Lines { starts }
    }

    /// The 0-based index of the line that holds byte `at`.
    fn index(&self, at: usize) -> usize {
        work::add(usize::BITS as usize - self.starts.len().leading_zeros() as usize + 1);
        self.starts.partition_point(|&s| s <= at) - 1
    }

    /// The 1-based number of the line that holds byte `at`.
    pub(crate) fn number(&self, at: usize) -> usize {
        self.index(at) + 1
    }

    /// The byte where the line holding byte `at` starts.
    pub(crate) fn start(&self, at: usize) -> usize {
        self.starts[self.index(at)]
    }
}

/// A count of the steps the text scans take (bytes looked at, probes of a search), kept
/// per thread in tests and compiled away otherwise.
pub(crate) mod work {
    #[cfg(test)]
    thread_local! {
        static STEPS: std::cell::Cell<u64> = const { std::cell::Cell::new(0) };
    }

    /// Counts `steps` more.
    #[inline]
    pub(crate) fn add(steps: usize) {
        #[cfg(test)]
        STEPS.with(|s| s.set(s.get() + steps as u64));
        #[cfg(not(test))]
        let _ = steps;
    }

    /// The steps `f` takes on this thread.
    #[cfg(test)]
    pub(crate) fn of(f: impl FnOnce()) -> u64 {
        let before = STEPS.with(std::cell::Cell::get);
        f();
        STEPS.with(std::cell::Cell::get) - before
    }

    /// Fails unless `work(2n)` is at most `slack` times `2 · work(n)` (linear, with room
    /// for logarithms) and grows at all (something was counted).
    #[cfg(test)]
    pub(crate) fn assert_linear(
        what: &str,
        n: usize,
        slack: f64,
        mut work: impl FnMut(usize) -> u64,
    ) {
        let (small, large) = (work(n), work(2 * n));
        assert!(
            small > 0 && large > small,
            "{what}: no work counted ({small}, {large})"
        );
        let ratio = large as f64 / small as f64;
        eprintln!(
            "{what}: {small} steps for {n}, {large} for {} (×{ratio:.3})",
            2 * n
        );
        assert!(
            ratio <= 2.0 * slack,
            "{what}: doubling the input from {n} multiplied the work by {ratio:.2} ({small} → {large}); linear is 2"
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spans_merge_and_answer_membership() {
        let s = Spans::new([10..20, 0..5, 15..30, 30..31, 40..40]);
        assert_eq!(s.ranges(), &[0..5, 10..31]);
        assert!(s.contains(0) && s.contains(4) && !s.contains(5) && s.contains(30));
        assert!(!s.contains(31) && !s.contains(40));
        assert!(s.covers(&(12..31)) && !s.covers(&(3..12)) && !s.covers(&(30..32)));
        assert!(!Spans::default().contains(0));
    }

    #[test]
    fn lines_number_and_start() {
        let l = Lines::new("ab\ncd\n\nx");
        assert_eq!((l.number(0), l.start(1)), (1, 0));
        assert_eq!(
            (l.number(2), l.start(2)),
            (1, 0),
            "the newline ends its line"
        );
        assert_eq!((l.number(3), l.start(4)), (2, 3));
        assert_eq!((l.number(6), l.number(7), l.start(7)), (3, 4, 7));
    }

    #[test]
    fn lookups_take_logarithmic_steps() {
        work::assert_linear("lookups", 4096, 1.15, |n| {
            let s = Spans::new((0..n).map(|i| 3 * i..3 * i + 1));
            work::of(|| {
                for at in 0..3 * n {
                    let _ = s.contains(at);
                }
            })
        });
    }
}
