//! Exact optical depth along a ray: the integral of σt over the voxel cells it crosses.
//!
//! Between voxel centres the density is trilinear, so along a line it is a cubic polynomial
//! in `t` within each cell of the grid of centres, and Simpson's rule — `(t₁ − t₀)/6 ·
//! (f₀ + 4 f_m + f₁)` — integrates a cubic exactly. A 3-D DDA over that grid therefore
//! gives the optical depth with no step size and no noise, at three density evaluations per
//! cell (two new ones: the exit value is the next cell's entry value). With nearest-voxel
//! reconstruction the density is constant per voxel and the integral is a sum of
//! `value × length`. Majorant bricks with σ_maj = 0 are skipped whole.
//!
//! This replaces marching (§6: `n = d / stepsize` samples, one jittered offset) for shadow
//! rays: the thesis's estimate converges to this integral as the step shrinks.

use glam::Vec3;

use super::Medium;
use super::compact_density::CompactDensity;
use super::majorant::CrossingAxis;
use crate::math::Ray;
use crate::volume::{Grid, Reconstruction, Voxels, trilinear_corners};

/// A 3-D DDA over unit cells of a continuous coordinate `c(t) = origin + t · direction`:
/// yields the parameter intervals of the successive cells in `[t_min, t_max]`.
pub(super) struct CellWalk {
    t: f32,
    t_max: f32,
    next: [f32; 3],
    delta: [f32; 3],
}

impl CellWalk {
    pub(super) fn new(origin: Vec3, direction: Vec3, t_min: f32, t_max: f32) -> Self {
        let c = origin + direction * t_min;
        let mut next = [f32::INFINITY; 3];
        let mut delta = [f32::INFINITY; 3];
        for a in 0..3 {
            let d = direction[a];
            if d != 0.0 {
                let cell = c[a].floor();
                let boundary = if d > 0.0 { cell + 1.0 } else { cell };
                // Points exactly on a boundary moving down start in the cell below.
                let boundary = if d < 0.0 && boundary == c[a] {
                    boundary - 1.0
                } else {
                    boundary
                };
                next[a] = t_min + (boundary - c[a]) / d;
                delta[a] = 1.0 / d.abs();
            }
        }
        CellWalk {
            t: t_min,
            t_max,
            next,
            delta,
        }
    }
}

impl Iterator for CellWalk {
    type Item = (f32, f32);

    #[inline]
    fn next(&mut self) -> Option<(f32, f32)> {
        if self.t >= self.t_max {
            return None;
        }
        let crossing = CrossingAxis::of(self.next);
        let exit = crossing.t.min(self.t_max).max(self.t);
        let cell = (self.t, exit);
        self.next = crossing.advance(self.next, self.delta);
        // Cells shorter than the precision of t are merged into the next one.
        self.t = if exit > self.t {
            exit
        } else {
            self.t.next_up()
        };
        Some(cell)
    }
}

/// `x.floor() as i64` without the libm call (`floorf` is not inlined without SSE4.1), for
/// the coordinates of a grid of at most 2³¹ cells.
#[inline]
fn floor_i64(x: f32) -> i64 {
    let truncated = x as i64;
    truncated - i64::from(x < truncated as f32)
}

/// A ray in the coordinates of the grid of voxel centres (centres at integers), where the
/// trilinear density is a cubic in `t` within each cell, and the corners of those cells.
pub(super) struct CentreFrame {
    /// The ray's origin in centre coordinates.
    pub origin: Vec3,
    /// The ray's direction in centre coordinates (per unit of the ray's `t`).
    pub direction: Vec3,
    last: [i64; 3],
    pitch: [usize; 3],
}

impl CentreFrame {
    pub fn new(grid: &Grid, ray: &Ray) -> Self {
        let bounds = grid.bounds();
        let dims = grid.dims();
        let scale = Vec3::from(dims.map(|n| n as f32)) / bounds.extent();
        CentreFrame {
            origin: (ray.origin - bounds.min) * scale - Vec3::splat(0.5),
            direction: ray.direction * scale,
            last: dims.map(|n| n as i64 - 1),
            pitch: [1, dims[0], dims[0] * dims[1]],
        }
    }

    /// The cell holding the point `c` (centre coordinates).
    #[inline]
    pub fn cell_of(c: Vec3) -> [i64; 3] {
        [floor_i64(c.x), floor_i64(c.y), floor_i64(c.z)]
    }

    /// The eight corner values of `cell`, with indices clamped as the reconstruction
    /// clamps them (the outer half-voxel shell is constant: its corners coincide along the
    /// clamped axis, so the cell's polynomial does not depend on that coordinate).
    #[inline]
    pub fn corners<V: Voxels + ?Sized>(&self, voxels: &V, cell: [i64; 3]) -> [f32; 8] {
        let (last, pitch) = (self.last, self.pitch);
        // The lower corner's index and the steps to the upper ones (0 where clamped).
        let lo = [0, 1, 2].map(|a| cell[a].clamp(0, last[a]) as usize);
        let step = [0, 1, 2].map(|a| ((cell[a] + 1).clamp(0, last[a]) as usize - lo[a]) * pitch[a]);
        voxels.corners(lo[0] + lo[1] * pitch[1] + lo[2] * pitch[2], step)
    }
}

/// The optical depth past which a light counts as blocked, for a cap `tau_max` (one more
/// than the cap, so an interpolated depth between a blocked and an open sample leaves the
/// cap on the blocked side): see [`Medium::optical_depth_capped`].
#[inline]
pub fn blocked_depth(tau_max: f32) -> f32 {
    tau_max.min(1e6) + 1.0
}

impl Medium {
    /// The exact optical depth τ = ∫σt dt over `[t0, t1]` (inside the box, as
    /// [`Medium::clip`] returns it). Past `tau_max` the result is a lower bound above
    /// `tau_max`: the walk stops at the end of the run of bricks where τ exceeds it.
    pub fn optical_depth_exact(&self, ray: &Ray, t0: f32, t1: f32, tau_max: f32) -> f32 {
        self.optical_depth_walk(ray, t0, t1, tau_max, f32::INFINITY)
    }

    /// [`Medium::optical_depth_exact`] capped at
    /// [`blocked_depth`](crate::blocked_depth)`(tau_max)` (the depth of a shadow ray, where
    /// anything past `tau_max` blocks the light): the cell walk stops as soon as τ surely
    /// exceeds the blocked depth, instead of crossing the rest of the volume, and the
    /// result is `optical_depth_exact(…).min(blocked_depth(tau_max))` to the bit.
    pub fn optical_depth_capped(&self, ray: &Ray, t0: f32, t1: f32, tau_max: f32) -> f32 {
        let blocked = blocked_depth(tau_max);
        self.optical_depth_walk(ray, t0, t1, tau_max, blocked)
            .min(blocked)
    }

    /// The optical depth over `[t0, t1]`, stopping at the end of a run of bricks once τ
    /// exceeds `tau_max` and inside a run once it surely exceeds `stop_within`.
    fn optical_depth_walk(
        &self,
        ray: &Ray,
        t0: f32,
        t1: f32,
        tau_max: f32,
        stop_within: f32,
    ) -> f32 {
        let mut tau = 0.0f32;
        // Runs of adjacent non-empty bricks are integrated in one cell walk: the walk and
        // its entry value are set up once per run instead of once per brick.
        for (a, b) in self.majorants.occupied_runs(ray, t0, t1) {
            tau += match self.reconstruction {
                Reconstruction::Trilinear => {
                    let stop = self.raw_sum_past(stop_within - tau);
                    self.density_integral_trilinear(ray, a, b, stop)
                }
                Reconstruction::Nearest => self.density_integral_nearest(ray, a, b),
            } * self.sigma_t_base;
            if tau > tau_max {
                break;
            }
        }
        tau
    }

    /// A Simpson sum (six times the density integral) past which a run's optical depth
    /// surely adds more than `remaining`. The margin of 10⁻⁴ covers the rounding of this
    /// bound and of `τ + sum / 6 · σ` (a few ulps, ~10⁻⁷), so a walk stopped there ends
    /// with τ at or above the stop even though it skipped the rest of the run; every term
    /// is ≥ 0 and rounding is monotone, so the full run's τ is at least as large, and
    /// `min(stop)` is the same either way.
    #[inline]
    fn raw_sum_past(&self, remaining: f32) -> f32 {
        if self.sigma_t_base > 0.0 && remaining.is_finite() {
            6.0 * remaining.max(0.0) / self.sigma_t_base * (1.0 + 1e-4)
        } else {
            f32::INFINITY
        }
    }

    /// ∫ density dt over `[ta, tb]` for trilinear reconstruction, reading the corners from
    /// the grid's compact copy when it has one (the same values in less memory); the walk
    /// stops once its Simpson sum exceeds `stop`.
    fn density_integral_trilinear(&self, ray: &Ray, ta: f32, tb: f32, stop: f32) -> f32 {
        match self.compact_density() {
            Some(CompactDensity::Byte(bytes)) => self.integrate_cells(ray, ta, tb, bytes, stop),
            Some(CompactDensity::Word(words)) => self.integrate_cells(ray, ta, tb, words, stop),
            None => self.integrate_cells(ray, ta, tb, self.density.values(), stop),
        }
    }

    /// ∫ density dt over `[ta, tb]`: Simpson's rule per cell of the grid of voxel centres
    /// (exact for the cubic the density is along the ray there), with the cell's eight
    /// corner values fetched once from `voxels`. Once the Simpson sum (six times the
    /// integral) exceeds `stop` the walk returns what it has (a blocked shadow ray need not
    /// cross the rest of the volume).
    fn integrate_cells<V: Voxels + ?Sized>(
        &self,
        ray: &Ray,
        ta: f32,
        tb: f32,
        voxels: &V,
        stop: f32,
    ) -> f32 {
        let frame = CentreFrame::new(&self.density, ray);
        let (origin, direction) = (frame.origin, frame.direction);
        let mut sum = 0.0f32;
        let empty = self.empty_cells();
        let mut f0 = self.density.trilinear_clamped(ray.at(ta));
        for (t0, t1) in CellWalk::new(origin, direction, ta, tb) {
            let tm = 0.5 * (t0 + t1);
            let cm = origin + direction * tm;
            let cell = CentreFrame::cell_of(cm);
            if empty.is_empty(cell) {
                // Eight zero corners: f_m = f₁ = 0, and (f₀ + 4·0 + 0) is f₀ to the bit.
                sum += (t1 - t0) * f0;
                f0 = 0.0;
                continue;
            }
            let corners = frame.corners(voxels, cell);
            let base = Vec3::new(cell[0] as f32, cell[1] as f32, cell[2] as f32);
            let local = |c: Vec3| (c - base).clamp(Vec3::ZERO, Vec3::ONE);
            let fm = trilinear_corners(&corners, local(cm).to_array());
            let f1 = trilinear_corners(&corners, local(origin + direction * t1).to_array());
            sum += (t1 - t0) * (f0 + 4.0 * fm + f1);
            f0 = f1;
            if sum > stop {
                break;
            }
        }
        sum / 6.0
    }

    /// ∫ density dt over `[ta, tb]` for nearest reconstruction: value × length per voxel.
    fn density_integral_nearest(&self, ray: &Ray, ta: f32, tb: f32) -> f32 {
        let grid = &self.density;
        let bounds = grid.bounds();
        let scale = Vec3::from(grid.dims().map(|n| n as f32)) / bounds.extent();
        let origin = (ray.origin - bounds.min) * scale;
        let direction = ray.direction * scale;
        CellWalk::new(origin, direction, ta, tb)
            .map(|(t0, t1)| (t1 - t0) * grid.nearest(ray.at(0.5 * (t0 + t1))))
            .sum()
    }
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use super::{CompactDensity, blocked_depth};
    use crate::math::Ray;
    use crate::medium::test_media::{phantom_medium as medium, random_ray};

    #[test]
    fn floor_matches_the_library_floor() {
        for x in [-2.5f32, -1.0, -0.5, -0.0, 0.0, 0.3, 1.0, 1.5, 255.99, 1e6] {
            assert_eq!(super::floor_i64(x), x.floor() as i64, "{x}");
        }
    }

    #[test]
    fn the_compact_grid_gives_the_same_depth_to_the_bit() {
        let mut rng = crate::math::Rng::stream(5, crate::math::Domain::Misc, 0);
        for name in ["foot", "engine", "head"] {
            let m = medium(name, 40, None, 30.0);
            let compact = m
                .compact_density()
                .expect("a phantom has few distinct values");
            let CompactDensity::Byte(bytes) = compact else {
                panic!("a phantom has at most 256 distinct values")
            };
            for _ in 0..200 {
                let (ray, t0, t1) = random_ray(&m, &mut rng);
                let values = m.integrate_cells(&ray, t0, t1, m.density.values(), f32::INFINITY);
                let indexed = m.integrate_cells(&ray, t0, t1, bytes, f32::INFINITY);
                assert_eq!(values.to_bits(), indexed.to_bits(), "{name} {ray:?}");
            }
        }
    }

    #[test]
    fn a_capped_depth_is_the_exact_depth_capped_to_the_bit() {
        let mut rng = crate::math::Rng::stream(7, crate::math::Domain::Misc, 0);
        let mut stopped_inside_a_run = 0;
        for name in ["foot", "engine", "head"] {
            let m = medium(name, 40, None, 80.0);
            for _ in 0..300 {
                let (ray, t0, t1) = random_ray(&m, &mut rng);
                let full = m.optical_depth_exact(&ray, t0, t1, f32::INFINITY);
                for tau_max in [0.5, 2.0, 6.9, 30.0, f32::INFINITY] {
                    let blocked = blocked_depth(tau_max);
                    let exact = m.optical_depth_exact(&ray, t0, t1, tau_max);
                    let capped = m.optical_depth_capped(&ray, t0, t1, tau_max);
                    assert_eq!(capped.to_bits(), exact.min(blocked).to_bits(), "{ray:?}");
                    if full <= tau_max {
                        assert_eq!(exact.to_bits(), full.to_bits(), "{ray:?}");
                    }
                    let walked = m.optical_depth_walk(&ray, t0, t1, tau_max, blocked);
                    stopped_inside_a_run += usize::from(walked < exact);
                }
            }
        }
        // The early stop is exercised, not only the runs' ends.
        assert!(stopped_inside_a_run > 50, "{stopped_inside_a_run}");
    }

    #[test]
    fn exact_depth_matches_the_two_slab_closed_form() {
        // Two slabs along x with densities 0.25 and 1; σt(d_min = 0.25) = 4 → base 16.
        let m = medium("two-slab", 16, Some([0.25, 1.0]), 4.0);
        let ray = Ray::new(Vec3::new(-1.0, 0.37, 0.61), Vec3::X);
        let (t0, t1) = m.clip(&ray).unwrap();
        let tau = m.optical_depth_exact(&ray, t0, t1, f32::INFINITY);
        // Trilinear between centres: the step between the slabs is a ramp over one voxel
        // centred on x = 0.5, which integrates to the same as the step.
        let expected = 16.0 * (0.25 * 0.5 + 0.5);
        assert!(
            (tau - expected).abs() < 1e-4 * expected,
            "{tau} vs {expected}"
        );
    }

    #[test]
    fn exact_depth_is_the_limit_of_marching_on_an_oblique_ray() {
        // At 27 voxels bricks of 4 do not divide the grid (the last brick is partial).
        let cases = [
            ("sphere", 24, 10.0),
            ("engine", 24, 40.0),
            ("foot", 24, 80.0),
            ("foot", 27, 80.0),
            ("engine", 27, 40.0),
        ];
        for (name, size, t) in cases {
            let m = medium(name, size, None, t);
            let ray = Ray::new(
                Vec3::new(-0.3, 0.13, 0.21),
                Vec3::new(1.0, 0.61, 0.37).normalize(),
            );
            let (t0, t1) = m.clip(&ray).unwrap();
            let exact = m.optical_depth_exact(&ray, t0, t1, f32::INFINITY) as f64;
            // The midpoint rule with a tiny step, accumulated in f64.
            let n = 400_000;
            let h = (t1 - t0) as f64 / n as f64;
            let marched: f64 = (0..n)
                .map(|k| m.sigma_t(ray.at((t0 as f64 + (k as f64 + 0.5) * h) as f32)) as f64)
                .sum::<f64>()
                * h;
            assert!(
                (exact - marched).abs() <= 2e-4 * marched.max(1.0),
                "{name} {size}³: exact {exact} vs marched {marched}"
            );
        }
    }
}
