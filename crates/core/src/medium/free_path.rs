//! Free paths and transmittance along a ray: every tracker runs on ONE collision loop,
//! [`sample_t_maj`] (pbrt-v4's `SampleT_maj`), which walks the ray's majorant segments and
//! samples tentative collisions at rate σ_maj; each tracker decides per collision.
//!
//! * **delta** (Woodcock) tracking — a tentative collision is real with probability
//!   σt/σ_maj: the exact free-path sampler for any heterogeneous medium;
//! * **ratio** tracking — the transmittance estimate is multiplied by `1 − σt/σ_maj` at each
//!   tentative collision: unbiased transmittance for shadow rays;
//! * **march** — inverts the ray-marched optical depth (`stepsize` resolution);
//! * **thesis** — §5.1, §7.1.2: search forward for σt > 0, then jump `−ln ξ / σt` evaluated
//!   at that one point; biased in heterogeneous media (kept to measure that bias).

use std::ops::ControlFlow;

use serde::{Deserialize, Serialize};

use super::Medium;
use crate::counters::{self, Counter, WalkCounts};
use crate::math::{Ray, Rng};

/// Free-path sampling rule for photons (§5.1, §7.1.2).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum FreePath {
    /// Delta (Woodcock) tracking over the majorant bricks: exact.
    Delta,
    /// Inverts the ray-marched optical depth (stepsize resolution).
    March,
    /// `d = −ln ξ / σt(x)` at the current point after searching forward for σt > 0, as the
    /// thesis describes; biased in heterogeneous media.
    Thesis,
}

/// The collision loop shared by every majorant tracker (pbrt-v4's `SampleT_maj`): for each
/// majorant segment of `ray` over `[t0, t1]` with σ_maj > 0, samples exponential steps at
/// rate σ_maj and calls `at_collision(t, σ_maj, rng)` at each tentative collision that lies
/// inside the segment. Returns the `t` at which the callback stopped the walk, or `None`
/// when the ray left `[t0, t1]` first. The bricks it steps and the steps that leave a
/// brick are counted in locals and added to the pass's counters once, at the walk's end
/// ([`crate::counters`]); the callers count the tentative collisions.
#[inline]
pub(crate) fn sample_t_maj<F>(
    medium: &Medium,
    ray: &Ray,
    t0: f32,
    t1: f32,
    rng: &mut Rng,
    mut at_collision: F,
) -> Option<f32>
where
    F: FnMut(f32, f32, &mut Rng) -> ControlFlow<()>,
{
    let mut walk = WalkCounts::default();
    let stopped = 'walk: {
        for seg in medium.segments(ray, t0, t1) {
            walk.bricks += 1;
            if seg.sigma_maj == 0.0 {
                walk.empty += 1;
                continue;
            }
            let mut t = seg.t_min;
            loop {
                let next = t - rng.uniform_open0().ln() / seg.sigma_maj;
                // Always progress: a step below the precision of `t` (which the σ bound of
                // `SigmaMapping::resolve` rules out for any valid medium) still moves on.
                t = if next > t { next } else { t.next_up() };
                if t >= seg.t_max {
                    walk.overshoots += 1;
                    break;
                }
                if at_collision(t, seg.sigma_maj, rng).is_break() {
                    break 'walk Some(t);
                }
            }
        }
        None
    };
    walk.add();
    stopped
}

impl Medium {
    /// Unbiased transmittance over `[t0, t1]` by ratio tracking with Russian roulette.
    pub fn transmittance_ratio_tracking(&self, ray: &Ray, t0: f32, t1: f32, rng: &mut Rng) -> f32 {
        let mut tr = 1.0f32;
        let mut steps = 0u32;
        let stopped = sample_t_maj(self, ray, t0, t1, rng, |t, sigma_maj, rng| {
            steps += 1;
            tr *= 1.0 - self.sigma_t(ray.at(t)) / sigma_maj;
            if tr < 0.1 {
                // Russian roulette keeps the estimator unbiased and bounded in cost.
                if rng.uniform() < 0.5 {
                    return ControlFlow::Break(());
                }
                tr *= 2.0;
            }
            ControlFlow::Continue(())
        });
        // Each step is one density lookup.
        let steps = u64::from(steps);
        counters::add_each([
            (Counter::RatioSteps, steps),
            (Counter::DensityLookups, steps),
        ]);
        if stopped.is_some() { 0.0 } else { tr }
    }

    /// Delta (Woodcock) tracking: the distance to the next real interaction along `ray`
    /// within `[t0, t1]`, or `None` if the ray leaves first. Exact for any heterogeneous
    /// medium bounded by the majorants.
    pub fn sample_interaction_delta(
        &self,
        ray: &Ray,
        t0: f32,
        t1: f32,
        rng: &mut Rng,
    ) -> Option<f32> {
        let mut tentative = 0u32;
        let collision = sample_t_maj(self, ray, t0, t1, rng, |t, sigma_maj, rng| {
            tentative += 1;
            if rng.uniform() * sigma_maj < self.sigma_t(ray.at(t)) {
                ControlFlow::Break(())
            } else {
                ControlFlow::Continue(())
            }
        });
        counters::delta_walk(tentative, collision.is_some());
        counters::add(Counter::DensityLookups, u64::from(tentative));
        collision
    }

    /// [`Medium::sample_interaction_delta`] with its first tentative collision placed by the
    /// uniform `u` (the majorant optical depth `−ln(1 − u)` along the ray) instead of a draw:
    /// a stratified `u` stratifies the free path, and since every tentative collision
    /// after it is drawn as before (exponential steps are memoryless), the sampled
    /// distance has exactly delta tracking's distribution.
    pub fn sample_interaction_delta_first(
        &self,
        ray: &Ray,
        t0: f32,
        t1: f32,
        u: f32,
        rng: &mut Rng,
    ) -> Option<f32> {
        let mut depth = -(1.0 - u).max(f32::MIN_POSITIVE).ln();
        // Counted as one walk with the delta-tracked rest, when there is one (which counts
        // itself).
        let mut walk = WalkCounts::default();
        for seg in self.segments(ray, t0, t1) {
            walk.bricks += 1;
            if seg.sigma_maj == 0.0 {
                walk.empty += 1;
                continue;
            }
            let reach = seg.sigma_maj * (seg.t_max - seg.t_min);
            if depth >= reach {
                depth -= reach;
                continue;
            }
            let t = seg.t_min + depth / seg.sigma_maj;
            walk.add();
            if rng.uniform() * seg.sigma_maj < self.sigma_t(ray.at(t)) {
                counters::delta_walk(1, true);
                counters::count(Counter::DensityLookups);
                return Some(t);
            }
            counters::add_each([(Counter::NullCollisions, 1), (Counter::DensityLookups, 1)]);
            return self.sample_interaction_delta(ray, t, t1, rng);
        }
        walk.add();
        counters::delta_walk(0, false);
        None
    }

    /// The next interaction along `ray` within `[t0, t1]` by the chosen `rule`; `step` is the
    /// marching step of the `march` and `thesis` rules.
    pub fn sample_free_path(
        &self,
        rule: FreePath,
        ray: &Ray,
        t0: f32,
        t1: f32,
        step: f32,
        rng: &mut Rng,
    ) -> Option<f32> {
        match rule {
            FreePath::Delta => self.sample_interaction_delta(ray, t0, t1, rng),
            FreePath::March => sample_interaction_march(self, ray, t0, t1, step, rng),
            FreePath::Thesis => sample_interaction_thesis(self, ray, t0, t1, step, rng),
        }
    }
}

/// Free path by inverting the ray-marched optical depth: sample τ* = −ln ξ and march with
/// `step` until the accumulated τ reaches it, interpolating inside the last step.
pub fn sample_interaction_march(
    medium: &Medium,
    ray: &Ray,
    t0: f32,
    t1: f32,
    step: f32,
    rng: &mut Rng,
) -> Option<f32> {
    let target = -rng.uniform_open0().ln();
    let u = rng.uniform();
    let mut tau = 0.0f32;
    let mut hit = None;
    medium.march(ray, t0, t1, step, u, |t, w| {
        let sigma_t = medium.sigma_t(ray.at(t));
        let d_tau = sigma_t * w;
        if tau + d_tau >= target && sigma_t > 0.0 {
            // The step covers [t − u·w, t − u·w + w]; σt is taken as constant over it.
            let start = t - u * w;
            hit = Some((start + (target - tau) / sigma_t).min(t1));
            return ControlFlow::Break(());
        }
        tau += d_tau;
        ControlFlow::Continue(())
    });
    hit
}

/// The thesis's free path (§5.1, §7.1.2): search forward (in `step`s) for the first point
/// with σt > 0, then jump `d = −ln ξ / σt` evaluated at that single point. The interaction
/// happens at the landing point whatever the medium does in between — which is why this
/// rule is biased in heterogeneous media.
pub fn sample_interaction_thesis(
    medium: &Medium,
    ray: &Ray,
    t0: f32,
    t1: f32,
    step: f32,
    rng: &mut Rng,
) -> Option<f32> {
    let u = rng.uniform();
    let mut found = None;
    medium.march(ray, t0, t1, step, u, |t, _| {
        let sigma_t = medium.sigma_t(ray.at(t));
        if sigma_t > 0.0 {
            found = Some((t, sigma_t));
            ControlFlow::Break(())
        } else {
            ControlFlow::Continue(())
        }
    });
    let (t_start, sigma_t) = found?;
    let t = t_start - rng.uniform_open0().ln() / sigma_t;
    (t < t1).then_some(t)
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use crate::math::{Domain, Ray, Rng};
    use crate::medium::test_media::phantom_medium as medium;

    #[test]
    fn transmittance_through_two_slabs_matches_closed_form() {
        // Two slabs along x with densities 0.25 and 1; σt(d_min = 0.25) = 4 → base 16.
        // τ along x through the unit box = 16·(0.25·0.5 + 1·0.5) = 10.
        let m = medium("two-slab", 16, Some([0.25, 1.0]), 4.0);
        let ray = Ray::new(Vec3::new(-1.0, 0.37, 0.61), Vec3::X);
        let (t0, t1) = m.clip(&ray).unwrap();
        let expected_tau = 16.0 * (0.25 * 0.5 + 0.5);
        let tau = m.optical_depth_marched(&ray, t0, t1, 0.001, 0.5);
        assert!((tau - expected_tau).abs() < 1e-2, "{tau}");
        // Partial path: from x = 0.25 to 0.75 (crosses the boundary in the middle).
        let tau = m.optical_depth_marched(&ray, 1.25, 1.75, 0.0005, 0.3);
        let expected = 16.0 * (0.25 * 0.25 + 0.25);
        assert!((tau - expected).abs() < 1e-2, "{tau} vs {expected}");
        // Ratio tracking is unbiased: the mean over many estimates.
        let n = 40_000;
        let mut rng = Rng::stream(3, Domain::Misc, 0);
        let ray2 = Ray::new(Vec3::new(-1.0, 0.37, 0.61), Vec3::X);
        let mean: f64 = (0..n)
            .map(|_| m.transmittance_ratio_tracking(&ray2, 1.25, 1.75, &mut rng) as f64)
            .sum::<f64>()
            / n as f64;
        let exact = (-(expected as f64)).exp();
        assert!((mean - exact).abs() < 4e-3, "{mean} vs {exact}");
    }

    /// Runs `f` on a thread and fails if it does not finish within `seconds`.
    fn within<T: Send + 'static>(seconds: u64, f: impl FnOnce() -> T + Send + 'static) -> T {
        let (tx, rx) = std::sync::mpsc::channel();
        std::thread::spawn(move || {
            let _ = tx.send(f());
        });
        rx.recv_timeout(std::time::Duration::from_secs(seconds))
            .expect("the tracker did not finish: it hangs")
    }

    #[test]
    fn trackers_progress_where_steps_fall_below_the_precision_of_t() {
        // 1000 units from a medium at the σ bound (σt = 9·10⁵ per unit), where the bricks
        // around the sphere hold empty space (null collisions only), a free-path step
        // of about 1/σ_maj ≈ 1.1·10⁻⁶ is below the ulp of t (6·10⁻⁵): `t + step == t`.
        // Every tracker must still finish.
        let done = within(20, || {
            let m = medium("sphere", 16, None, 9e5);
            let ray = Ray::new(Vec3::new(-1000.0, 0.5, 0.5), Vec3::X);
            let (t0, t1) = m.clip(&ray).unwrap();
            let mut rng = Rng::stream(1, Domain::Misc, 0);
            for _ in 0..20 {
                let _ = m.sample_interaction_delta(&ray, t0, t1, &mut rng);
                let _ = m.transmittance_ratio_tracking(&ray, t0, t1, &mut rng);
            }
            true
        });
        assert!(done);
    }

    #[test]
    fn delta_tracking_free_path_is_exponential_in_homogeneous_medium() {
        let m = medium("constant", 8, None, 5.0); // σt = 5 everywhere
        let ray = Ray::new(Vec3::new(0.0, 0.5, 0.5), Vec3::X);
        let mut rng = Rng::stream(9, Domain::Misc, 1);
        let n = 50_000;
        let mut hits = 0;
        let mut sum = 0.0f64;
        for _ in 0..n {
            if let Some(t) = m.sample_interaction_delta(&ray, 0.0, 1.0, &mut rng) {
                hits += 1;
                sum += t as f64;
            }
        }
        let p_hit = hits as f64 / n as f64;
        assert!((p_hit - (1.0 - (-5.0f64).exp())).abs() < 0.01, "{p_hit}");
        // E[t | t < 1] for rate 5.
        let lambda = 5.0f64;
        let cond_mean = 1.0 / lambda - (-lambda).exp() / (1.0 - (-lambda).exp());
        assert!((sum / hits as f64 - cond_mean).abs() < 0.005);
    }
}
