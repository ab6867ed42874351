//! Routes to a faster reference, chosen by its variance budget ([`super::budget`]) and
//! raced against the default tracker (`sweep bench --reference`):
//!
//! * [`Route::StratifiedEye`] — the two largest sources the budget names at the eye: each
//!   pixel's samples take their footprint and the first free path's first tentative
//!   collision from one Owen-scrambled Sobol sequence indexed by the sample (dimensions
//!   0–2), so a pixel's samples are stratified across passes; everything after draws as
//!   before. Every point is uniform, so the estimate stays unbiased.
//! * [`Route::VisibleLights`] — the light choice at later vertices also weighs each
//!   light's transmittance from the region around the vertex (a coarse grid of exact
//!   optical depths from its cell centres, computed once per scene), floored so that every
//!   light stays possible: the choice is still divided by its probability.
//!
//! A route's estimate is the tracker's in expectation; its recorded variance per pixel is
//! the samples' spread, which over-states the variance of a stratified mean (so a route is
//! raced against a converged reference, never used as one).

use glam::Vec3;
use rayon::prelude::*;

use crate::math::{Aabb, scrambled_sobol};
use crate::medium::{DepthCap, ShadowSegment};
use crate::scene::Scene;

/// A faster reference's candidate, raced by `sweep bench --reference`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Route {
    /// The default weighted tracker, unchanged.
    Weighted,
    /// Footprint and first free path stratified across a pixel's samples.
    StratifiedEye,
    /// The light at later vertices chosen also by its transmittance around the vertex.
    VisibleLights,
    /// Both.
    Both,
}

impl Route {
    /// Every route, the default first.
    pub const ALL: [Route; 4] = [
        Route::Weighted,
        Route::StratifiedEye,
        Route::VisibleLights,
        Route::Both,
    ];

    /// The route's name in reports.
    pub fn name(self) -> &'static str {
        match self {
            Route::Weighted => "weighted",
            Route::StratifiedEye => "stratified eye samples",
            Route::VisibleLights => "visibility-weighted light choice",
            Route::Both => "both",
        }
    }

    pub(super) fn stratified(self) -> bool {
        matches!(self, Route::StratifiedEye | Route::Both)
    }

    pub(super) fn visible_lights(self) -> bool {
        matches!(self, Route::VisibleLights | Route::Both)
    }
}

/// Cells of the visibility grid along the box's largest extent.
const VISIBILITY_CELLS: f32 = 32.0;

/// The smallest weight of a light in the choice: a light the grid sees as blocked keeps
/// this share of its unshadowed weight (its transmittance at the vertex itself may not be).
const VISIBILITY_FLOOR: f32 = 0.02;

/// Each grid cell's transmittance from its centre to each light (exact optical depth).
#[derive(Debug, Clone, PartialEq)]
pub(super) struct LightVisibility {
    bounds: Aabb,
    cells: [usize; 3],
    lights: usize,
    /// `cells` in x-fastest order, `lights` values each.
    transmittance: Vec<f32>,
}

impl LightVisibility {
    /// The grid of `scene`'s medium: a few tens of thousands of exact shadow rays.
    pub(super) fn build(scene: &Scene) -> Self {
        let medium = scene.medium();
        let bounds = medium.bounds();
        let extent = bounds.extent();
        let size = extent.max_element() / VISIBILITY_CELLS;
        let cells = [0, 1, 2].map(|a| ((extent[a] / size).ceil() as usize).max(1));
        let lights = scene.lights().len();
        let count = cells[0] * cells[1] * cells[2];
        let transmittance: Vec<f32> = (0..count)
            .into_par_iter()
            .flat_map_iter(|i| {
                let (x, y, z) = (
                    i % cells[0],
                    (i / cells[0]) % cells[1],
                    i / (cells[0] * cells[1]),
                );
                let centre = bounds.min
                    + Vec3::new(x as f32 + 0.5, y as f32 + 0.5, z as f32 + 0.5)
                        * (extent / Vec3::new(cells[0] as f32, cells[1] as f32, cells[2] as f32));
                scene
                    .lights()
                    .iter()
                    .map(move |light| match light.incident(centre) {
                        None => 0.0,
                        Some(inc) => {
                            let segment = ShadowSegment {
                                origin: centre,
                                direction: inc.to_light,
                                distance: inc.distance,
                            };
                            (-medium.shadow_depth(&segment, DepthCap::Exact(30.0))).exp()
                        }
                    })
            })
            .collect();
        LightVisibility {
            bounds,
            cells,
            lights,
            transmittance,
        }
    }

    /// The choice weight of light `l` at `x`: its cell's transmittance, floored.
    #[inline]
    pub(super) fn weight(&self, x: Vec3, l: usize) -> f32 {
        let rel = (x - self.bounds.min) / self.bounds.extent();
        let cell = |a: usize| ((rel[a] * self.cells[a] as f32) as usize).min(self.cells[a] - 1);
        let i = cell(0) + self.cells[0] * (cell(1) + self.cells[1] * cell(2));
        self.transmittance
            .get(i * self.lights + l)
            .copied()
            .unwrap_or(1.0)
            .max(VISIBILITY_FLOOR)
    }
}

/// The stratified footprint and first-collision uniform of sample `k` of `pixel`.
#[inline]
pub(super) fn stratified_eye(seed: u64, pixel: usize, k: u32) -> [f32; 3] {
    let key = crate::math::mix64(seed ^ crate::math::mix64(pixel as u64 ^ 0x0005_EED0_FEE5));
    [0, 1, 2].map(|dim| scrambled_sobol(k, dim, key))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::control::Control;
    use crate::integrator::reference::ReferenceAccumulator;
    use crate::scene::Tracker;
    use crate::test_util::{SPOT_SPHERE, scene};

    fn weighted() -> Scene {
        let s = scene(SPOT_SPHERE);
        let mut i = s.integrator().clone();
        i.tracker = Tracker::Weighted;
        s.with_integrator(i).unwrap()
    }

    fn route(s: &Scene, route: Route, passes: u32, threads: usize) -> ReferenceAccumulator {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| {
                let mut acc = ReferenceAccumulator::new(20, 20);
                acc.add_passes_route(s, passes, route, &Control::none())
                    .unwrap();
                acc
            })
    }

    #[test]
    fn the_weighted_route_is_the_weighted_tracker_to_the_bit() {
        let s = weighted();
        let mut production = ReferenceAccumulator::new(20, 20);
        production.add_passes(&s, 6, &Control::none()).unwrap();
        assert_eq!(route(&s, Route::Weighted, 6, 2), production);
    }

    /// Each route renders the same image in expectation (unbiased: its image mean within
    /// four standard errors of the weighted tracker's), and the same bits on one thread or
    /// two.
    #[test]
    fn every_route_is_unbiased_and_deterministic() {
        let s = weighted();
        let mean = |acc: &ReferenceAccumulator| {
            let film = acc.film();
            let total = film.total();
            let n = total.len() as f64;
            let m = total
                .iter()
                .map(|v| f64::from(v.x + v.y + v.z) / 3.0)
                .sum::<f64>()
                / n;
            let var = acc
                .total_variance()
                .unwrap()
                .iter()
                .map(|v| f64::from(v.x + v.y + v.z) / 3.0)
                .sum::<f64>()
                / (n * n);
            (m, var)
        };
        let (m0, v0) = mean(&route(&s, Route::Weighted, 256, 2));
        for r in [Route::StratifiedEye, Route::VisibleLights, Route::Both] {
            let acc = route(&s, r, 256, 2);
            let (m, v) = mean(&acc);
            // The recorded variance over-states a stratified mean's: a conservative z.
            let z = (m - m0) / (v + v0).sqrt();
            assert!(z.abs() < 4.0, "{}: mean {m} against {m0}, z {z}", r.name());
            assert_eq!(acc, route(&s, r, 256, 1), "{} on one thread", r.name());
        }
    }
}
