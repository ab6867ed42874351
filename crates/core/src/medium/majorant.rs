//! Majorant bricks: a coarse grid of the maximum σt over bricks of voxels, and the
//! piecewise-constant majorant segments of a ray through it (a 3-D DDA, as pbrt-v4's
//! `DDAMajorantIterator`). Empty bricks (σ_maj = 0) are skipped by every tracker and by
//! ray marching; the others bound σt for delta and ratio tracking.

use glam::Vec3;

use crate::math::{Aabb, Ray};
use crate::volume::Grid;

/// A coarse grid of maximum σt per brick.
#[derive(Debug, Clone)]
pub struct MajorantGrid {
    res: [usize; 3],
    sigma: Vec<f32>,
    /// One bit per brick, set where σ_maj > 0 (x fastest, as `sigma`): 32 KiB for 64³
    /// bricks, so a walk that only asks "empty?" stays in cache (the `f32`s are 1 MiB).
    occupied: Vec<u64>,
    bounds: Aabb,
    /// The grid's extent in bricks, `n / brick_size` per axis: brick coordinates are
    /// `(p − bounds.min) / extent · bricks`, so brick `b` spans `[b, b + 1)`, the voxels
    /// `b · brick_size … (b + 1) · brick_size` that its maximum covers (a last, partial
    /// brick ends at the grid's edge). Scaling by `res` instead stretched each brick over
    /// `n / res` voxels, past what its maximum covered, wherever `brick_size` does not
    /// divide `n` (the thesis's head has 109 slices).
    bricks: Vec3,
    brick_size: usize,
}

impl MajorantGrid {
    /// Builds bricks of `brick_size` voxels over a density grid; σ_maj = `scale`·max density.
    /// A brick's maximum includes the voxels one beyond its faces, because trilinear
    /// interpolation inside the brick reads them.
    pub fn build(density: &Grid, scale: f32, brick_size: usize) -> Self {
        let dims = density.dims();
        let res = dims.map(|n| n.div_ceil(brick_size));
        let mut sigma = vec![0.0f32; res[0] * res[1] * res[2]];
        for bz in 0..res[2] {
            for by in 0..res[1] {
                for bx in 0..res[0] {
                    let range = |b: usize, n: usize| {
                        let lo = (b * brick_size).saturating_sub(1);
                        let hi = ((b + 1) * brick_size).min(n - 1);
                        lo..=hi
                    };
                    let mut max = 0.0f32;
                    for z in range(bz, dims[2]) {
                        for y in range(by, dims[1]) {
                            for x in range(bx, dims[0]) {
                                max = max.max(density.voxel(x, y, z));
                            }
                        }
                    }
                    sigma[bx + res[0] * (by + res[1] * bz)] = max * scale;
                }
            }
        }
        let mut occupied = vec![0u64; sigma.len().div_ceil(64)];
        for (i, _) in sigma.iter().enumerate().filter(|(_, s)| **s > 0.0) {
            occupied[i / 64] |= 1 << (i % 64);
        }
        MajorantGrid {
            res,
            sigma,
            occupied,
            bounds: density.bounds(),
            bricks: Vec3::from(dims.map(|n| n as f32 / brick_size as f32)),
            brick_size,
        }
    }

    /// Bricks along x, y, z.
    pub fn resolution(&self) -> [usize; 3] {
        self.res
    }

    /// Brick edge in voxels.
    pub fn brick_size(&self) -> usize {
        self.brick_size
    }

    /// Fraction of bricks with σ_maj = 0 (skipped entirely).
    pub fn empty_fraction(&self) -> f64 {
        self.sigma.iter().filter(|s| **s == 0.0).count() as f64 / self.sigma.len() as f64
    }

    /// The world box of the bricks with σ_maj > 0 (`None` when every brick is empty): no
    /// point outside it has σt > 0, since a brick's maximum covers every voxel that
    /// trilinear interpolation inside it reads.
    pub fn occupied_bounds(&self) -> Option<Aabb> {
        let mut lo = [usize::MAX; 3];
        let mut hi = [0usize; 3];
        for bz in 0..self.res[2] {
            for by in 0..self.res[1] {
                for bx in 0..self.res[0] {
                    if self.is_occupied(bx + self.res[0] * (by + self.res[1] * bz)) {
                        for (a, b) in [bx, by, bz].into_iter().enumerate() {
                            lo[a] = lo[a].min(b);
                            hi[a] = hi[a].max(b + 1);
                        }
                    }
                }
            }
        }
        if lo[0] == usize::MAX {
            return None;
        }
        // Brick `b` spans `[b, b + 1)` in brick coordinates, which run over `bricks` across
        // the box (a last partial brick ends at the box's face).
        let extent = self.bounds.extent();
        let world = |b: usize, a: usize| {
            let f = (b as f32 / self.bricks[a]).min(1.0);
            self.bounds.min[a] + f * extent[a]
        };
        Some(Aabb::new(
            Vec3::new(world(lo[0], 0), world(lo[1], 1), world(lo[2], 2)),
            Vec3::new(world(hi[0], 0), world(hi[1], 1), world(hi[2], 2)),
        ))
    }

    /// The majorant at world point `p` (0 outside).
    pub fn at(&self, p: Vec3) -> f32 {
        if !self.bounds.contains(p) {
            return 0.0;
        }
        let c = (p - self.bounds.min) / self.bounds.extent() * self.bricks;
        let i = |a: f32, n: usize| (a as usize).min(n - 1);
        let (x, y, z) = (
            i(c.x, self.res[0]),
            i(c.y, self.res[1]),
            i(c.z, self.res[2]),
        );
        self.sigma[x + self.res[0] * (y + self.res[1] * z)]
    }

    /// Majorant segments of `ray` over `[t_min, t_max]` (a 3-D DDA, as pbrt-v4's
    /// `DDAMajorantIterator`).
    pub fn segments(&self, ray: &Ray, t_min: f32, t_max: f32) -> MajorantSegments<'_> {
        MajorantSegments {
            grid: self,
            walk: BrickWalk::new(self, ray, t_min, t_max),
        }
    }

    /// The runs of adjacent non-empty bricks along `ray` over `[t_min, t_max]`, as
    /// parameter intervals: the segments with σ_maj > 0 merged, walked over the occupancy
    /// bits instead of the majorants (the same DDA, so the same interval ends to the bit).
    pub(super) fn occupied_runs(&self, ray: &Ray, t_min: f32, t_max: f32) -> OccupiedRuns<'_> {
        OccupiedRuns {
            grid: self,
            walk: BrickWalk::new(self, ray, t_min, t_max),
        }
    }

    #[inline]
    fn is_occupied(&self, brick: usize) -> bool {
        self.occupied[brick / 64] & (1 << (brick % 64)) != 0
    }
}

/// The 3-D DDA over the bricks a ray crosses.
#[derive(Debug, Clone)]
struct BrickWalk {
    t_min: f32,
    t_max: f32,
    res: [usize; 3],
    voxel: [i32; 3],
    step: [i32; 3],
    limit: [i32; 3],
    next_crossing: [f32; 3],
    delta: [f32; 3],
}

impl BrickWalk {
    fn new(grid: &MajorantGrid, ray: &Ray, t_min: f32, t_max: f32) -> Self {
        let extent = grid.bounds.extent();
        let p = (ray.at(t_min) - grid.bounds.min) / extent * grid.bricks;
        let d = ray.direction / extent * grid.bricks;
        let mut voxel = [0i32; 3];
        let mut step = [0i32; 3];
        let mut limit = [0i32; 3];
        let mut next_crossing = [0f32; 3];
        let mut delta = [0f32; 3];
        for a in 0..3 {
            let n = grid.res[a] as i32;
            voxel[a] = (p[a].floor() as i32).clamp(0, n - 1);
            let da = if d[a] == 0.0 { 0.0 } else { d[a] };
            delta[a] = if da == 0.0 {
                f32::INFINITY
            } else {
                1.0 / da.abs()
            };
            if da >= 0.0 {
                let next = (voxel[a] + 1) as f32;
                next_crossing[a] = if da == 0.0 {
                    f32::INFINITY
                } else {
                    t_min + (next - p[a]) / da
                };
                step[a] = 1;
                limit[a] = n;
            } else {
                next_crossing[a] = t_min + (voxel[a] as f32 - p[a]) / da;
                step[a] = -1;
                limit[a] = -1;
            }
        }
        BrickWalk {
            t_min,
            t_max,
            res: grid.res,
            voxel,
            step,
            limit,
            next_crossing,
            delta,
        }
    }

    /// The next brick's index and parameter interval, or `None` past the end.
    #[inline]
    fn next_brick(&mut self) -> Option<(usize, f32, f32)> {
        if self.t_min >= self.t_max {
            return None;
        }
        let crossing = CrossingAxis::of(self.next_crossing);
        let [x, y, z] = self.voxel.map(|v| v as usize);
        let brick = x + self.res[0] * (y + self.res[1] * z);
        let t_exit = self.t_max.min(crossing.t);
        let interval = (brick, self.t_min, t_exit);
        self.t_min = t_exit;
        self.voxel = crossing.step(self.voxel, self.step);
        // Only the crossed axis moved, and only it can have reached its limit.
        if (0..3).any(|a| self.voxel[a] == self.limit[a]) {
            self.t_min = self.t_max;
        }
        self.next_crossing = crossing.advance(self.next_crossing, self.delta);
        Some(interval)
    }
}

/// The axis a 3-D DDA crosses next — the smallest next crossing, ties to the later axis
/// (as pbrt-v4's `DDAMajorantIterator`) — as a mask. The walks update their state with it
/// by selects: indexing their arrays by the axis keeps them in memory, and the next
/// step's load of all three crossings then waits on the store of one (measured: the
/// largest single cost of the shadow rays' walk).
#[derive(Debug, Clone, Copy)]
pub(super) struct CrossingAxis {
    mask: [bool; 3],
    /// The crossing's parameter.
    pub(super) t: f32,
}

impl CrossingAxis {
    /// The next crossing of a walk whose next crossings along x, y, z are `next`.
    #[inline]
    pub(super) fn of(next: [f32; 3]) -> Self {
        let [n0, n1, n2] = next;
        // Crossings are never NaN (an axis the ray does not move along has +∞).
        let x = n0 < n1 && n0 < n2;
        let y = n1 <= n0 && n1 < n2;
        let t = if x {
            n0
        } else if y {
            n1
        } else {
            n2
        };
        CrossingAxis {
            mask: [x, y, !x && !y],
            t,
        }
    }

    /// `next` with the crossed axis's entry advanced by its `delta`.
    #[inline]
    pub(super) fn advance(self, next: [f32; 3], delta: [f32; 3]) -> [f32; 3] {
        [0, 1, 2].map(|a| {
            if self.mask[a] {
                next[a] + delta[a]
            } else {
                next[a]
            }
        })
    }

    /// `cell` with the crossed axis's index moved by its `step`.
    #[inline]
    fn step(self, cell: [i32; 3], step: [i32; 3]) -> [i32; 3] {
        [0, 1, 2].map(|a| {
            if self.mask[a] {
                cell[a] + step[a]
            } else {
                cell[a]
            }
        })
    }
}

/// A piece of a ray with a constant majorant.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MajorantSegment {
    /// Start parameter.
    pub t_min: f32,
    /// End parameter.
    pub t_max: f32,
    /// Maximum σt along the piece.
    pub sigma_maj: f32,
}

/// Iterator over [`MajorantSegment`]s.
#[derive(Debug, Clone)]
pub struct MajorantSegments<'a> {
    grid: &'a MajorantGrid,
    walk: BrickWalk,
}

impl Iterator for MajorantSegments<'_> {
    type Item = MajorantSegment;

    #[inline]
    fn next(&mut self) -> Option<MajorantSegment> {
        let (brick, t_min, t_max) = self.walk.next_brick()?;
        Some(MajorantSegment {
            t_min,
            t_max,
            sigma_maj: self.grid.sigma[brick],
        })
    }
}

/// Iterator over the runs of adjacent non-empty bricks, `(t_min, t_max)`
/// ([`MajorantGrid::occupied_runs`]).
#[derive(Debug, Clone)]
pub(super) struct OccupiedRuns<'a> {
    grid: &'a MajorantGrid,
    walk: BrickWalk,
}

impl Iterator for OccupiedRuns<'_> {
    type Item = (f32, f32);

    #[inline]
    fn next(&mut self) -> Option<(f32, f32)> {
        let mut run: Option<(f32, f32)> = None;
        while let Some((brick, t_min, t_max)) = self.walk.next_brick() {
            match (self.grid.is_occupied(brick), &mut run) {
                (true, Some((_, end))) => *end = t_max.max(*end),
                (true, None) => run = Some((t_min, t_max)),
                (false, Some(_)) => return run,
                (false, None) => {}
            }
        }
        run
    }
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use super::{CrossingAxis, MajorantGrid};
    use crate::math::Aabb;
    use crate::medium::test_media::{phantom_medium as medium, random_ray};
    use crate::volume::Grid;

    #[test]
    fn the_crossing_mask_picks_the_axis_the_branches_pick() {
        // pbrt's branches: the smallest crossing, ties to the later axis.
        let branches = |n: [f32; 3]| {
            if n[0] < n[1] {
                if n[0] < n[2] { 0 } else { 2 }
            } else if n[1] < n[2] {
                1
            } else {
                2
            }
        };
        let values = [0.0, 0.5, 1.0, f32::INFINITY];
        for &a in &values {
            for &b in &values {
                for &c in &values {
                    let n = [a, b, c];
                    let axis = branches(n);
                    let crossing = CrossingAxis::of(n);
                    assert_eq!(crossing.t, n[axis], "{n:?}");
                    let moved = crossing.advance(n, [10.0; 3]);
                    for i in 0..3 {
                        let expected = if i == axis { n[i] + 10.0 } else { n[i] };
                        assert_eq!(moved[i], expected, "{n:?}");
                    }
                }
            }
        }
    }

    #[test]
    fn every_brick_bounds_the_density_where_the_walk_places_it() {
        // Dimensions that bricks of 4 divide and do not (the thesis's head has 109
        // slices, the Stanford CT head 113): one non-zero voxel at a time, and every
        // point where its trilinear footprint is positive must lie in a brick whose
        // majorant bounds it.
        for dims in [[4usize, 4, 9], [5, 4, 4], [4, 6, 13], [8, 8, 8]] {
            let n = dims[0] * dims[1] * dims[2];
            let bounds = Aabb::new(Vec3::ZERO, Vec3::ONE);
            for voxel in 0..n {
                let mut values = vec![0.0f32; n];
                values[voxel] = 1.0;
                let grid = Grid::new(dims, values, bounds);
                let majorants = MajorantGrid::build(&grid, 1.0, 4);
                let steps = 4 * dims.iter().max().unwrap();
                for i in 0..steps * steps * steps {
                    let (x, y, z) = (i % steps, i / steps % steps, i / steps / steps);
                    let p = Vec3::new(x as f32, y as f32, z as f32) / steps as f32
                        + Vec3::splat(0.5 / steps as f32);
                    let density = grid.trilinear_clamped(p);
                    assert!(
                        majorants.at(p) >= density,
                        "{dims:?} voxel {voxel}: density {density} > majorant {} at {p}",
                        majorants.at(p)
                    );
                }
            }
        }
    }

    #[test]
    fn occupied_runs_are_the_merged_non_empty_segments() {
        let mut rng = crate::math::Rng::stream(11, crate::math::Domain::Misc, 0);
        let mut runs_seen = 0;
        for name in ["foot", "engine", "sphere"] {
            let m = medium(name, 40, None, 10.0);
            for _ in 0..300 {
                let (ray, t0, t1) = random_ray(&m, &mut rng);
                let mut expected = Vec::new();
                let mut run: Option<(f32, f32)> = None;
                for seg in m.segments(&ray, t0, t1) {
                    if seg.sigma_maj > 0.0 {
                        run = Some(match run {
                            Some((a, b)) => (a, seg.t_max.max(b)),
                            None => (seg.t_min, seg.t_max),
                        });
                    } else if let Some(r) = run.take() {
                        expected.push(r);
                    }
                }
                expected.extend(run);
                let runs: Vec<_> = m.majorants().occupied_runs(&ray, t0, t1).collect();
                let bits = |v: &[(f32, f32)]| -> Vec<_> {
                    v.iter().map(|(a, b)| (a.to_bits(), b.to_bits())).collect()
                };
                assert_eq!(bits(&runs), bits(&expected), "{name} {ray:?}");
                runs_seen += runs.len();
            }
        }
        assert!(runs_seen > 300, "{runs_seen}");
    }
}
