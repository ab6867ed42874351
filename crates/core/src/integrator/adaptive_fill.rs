//! Error-controlled evaluation of a smooth per-sample quantity along an eye ray.
//!
//! The marching samples of one eye ray are `stepsize` apart (0.0005, an eighth of a voxel in
//! the thesis's scenes), while the quantities evaluated at them — the optical depth to each
//! light, the photon-map estimate over a gather sphere of ~0.01–0.1 — change on the scale
//! of a voxel or more. [`fill_adaptive`] evaluates the quantity exactly at every
//! `stride`-th sample and at each interval's midpoint; where the midpoint agrees with the
//! straight line through the interval's ends (within the track's tolerance) the other
//! samples are interpolated, otherwise the interval is halved and checked again, down to
//! single samples. Shadow edges, structure boundaries and blocked lights thus get exact
//! values; smooth stretches cost two evaluations per stride.

/// A per-sample quantity along one eye ray, filled by [`fill_adaptive`].
pub(super) trait Track {
    /// Computes and stores the exact value at sample `i`.
    fn evaluate(&mut self, i: usize);
    /// Stores at sample `i` the linear interpolation between samples `a` and `b`.
    fn interpolate(&mut self, a: usize, b: usize, i: usize);
    /// Whether interpolating between `a` and `b` at `m` agrees with the exact value stored
    /// at `m` within the track's tolerance.
    fn agrees(&self, a: usize, b: usize, m: usize) -> bool;
}

/// Fills samples `0..n` of `track` (see the module docs); returns the number of exact
/// evaluations.
pub(super) fn fill_adaptive(n: usize, stride: usize, track: &mut impl Track) -> usize {
    if n == 0 {
        return 0;
    }
    track.evaluate(0);
    1 + fill_span(0, n, stride, track)
}

/// Fills samples `start + 1..n` of `track`, sample `start` being exact already; returns the
/// number of exact evaluations.
pub(super) fn fill_span(start: usize, n: usize, stride: usize, track: &mut impl Track) -> usize {
    let mut evaluations = 0;
    let mut a = start;
    while a + 1 < n {
        let b = (a + stride.max(1)).min(n - 1);
        track.evaluate(b);
        evaluations += 1 + refine(a, b, track);
        a = b;
    }
    evaluations
}

/// Fills the samples strictly between `a` and `b` (both exact); returns the number of
/// evaluations made.
fn refine(a: usize, b: usize, track: &mut impl Track) -> usize {
    if b - a < 2 {
        return 0;
    }
    let m = (a + b) / 2;
    track.evaluate(m);
    if track.agrees(a, b, m) {
        for i in (a + 1..m).chain(m + 1..b) {
            let (lo, hi) = if i < m { (a, m) } else { (m, b) };
            track.interpolate(lo, hi, i);
        }
        1
    } else {
        1 + refine(a, m, track) + refine(m, b, track)
    }
}

/// The interpolation weight of `i` between `a` and `b`.
#[inline]
pub(super) fn fraction(a: usize, b: usize, i: usize) -> f32 {
    (i - a) as f32 / (b - a) as f32
}

#[cfg(test)]
mod tests {
    use super::*;

    struct Values<F: Fn(usize) -> f32> {
        f: F,
        out: Vec<f32>,
        calls: usize,
        strict: bool,
    }

    impl<F: Fn(usize) -> f32> Track for Values<F> {
        fn evaluate(&mut self, i: usize) {
            self.calls += 1;
            self.out[i] = (self.f)(i);
        }
        fn interpolate(&mut self, a: usize, b: usize, i: usize) {
            self.out[i] = self.out[a] + (self.out[b] - self.out[a]) * fraction(a, b, i);
        }
        fn agrees(&self, a: usize, b: usize, m: usize) -> bool {
            let p = self.out[a] + (self.out[b] - self.out[a]) * fraction(a, b, m);
            !self.strict && (p - self.out[m]).abs() < 1e-3
        }
    }

    fn run<F: Fn(usize) -> f32>(n: usize, stride: usize, f: F, strict: bool) -> Values<F> {
        let mut v = Values {
            f,
            out: vec![f32::NAN; n],
            calls: 0,
            strict,
        };
        let evaluations = fill_adaptive(n, stride, &mut v);
        assert_eq!(evaluations, v.calls);
        v
    }

    #[test]
    fn smooth_quantities_take_few_evaluations_and_edges_are_exact() {
        // A straight line: two evaluations per stride of 8, values exact.
        let line = run(65, 8, |i| 0.5 + 0.25 * i as f32, false);
        assert_eq!(line.calls, 1 + 8 * 2);
        assert!(
            line.out
                .iter()
                .enumerate()
                .all(|(i, v)| (v - (0.5 + 0.25 * i as f32)).abs() < 1e-5)
        );
        // A step (a shadow edge) between samples 20 and 21: found and kept sharp.
        let step = |i: usize| if i <= 20 { 0.0 } else { 5.0 };
        let edge = run(65, 8, step, false);
        assert!(
            edge.out.iter().enumerate().all(|(i, v)| *v == step(i)),
            "{:?}",
            edge.out
        );
        assert!(edge.calls < 30, "{}", edge.calls);
        // Every value evaluated when nothing may be interpolated.
        let all = run(10, 4, |i| i as f32, true);
        assert_eq!(all.calls, 10);
        assert!(all.out.iter().enumerate().all(|(i, v)| *v == i as f32));
    }
}
