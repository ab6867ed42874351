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
    bounds: Aabb,
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
        MajorantGrid {
            res,
            sigma,
            bounds: density.bounds(),
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

    /// The majorant at world point `p` (0 outside).
    pub fn at(&self, p: Vec3) -> f32 {
        if !self.bounds.contains(p) {
            return 0.0;
        }
        let c = (p - self.bounds.min) / self.bounds.extent();
        let i = |a: f32, n: usize| ((a * n as f32) as usize).min(n - 1);
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
        let extent = self.bounds.extent();
        let res = Vec3::new(self.res[0] as f32, self.res[1] as f32, self.res[2] as f32);
        let p = (ray.at(t_min) - self.bounds.min) / extent * res;
        let d = ray.direction / extent * res;
        let mut voxel = [0i32; 3];
        let mut step = [0i32; 3];
        let mut limit = [0i32; 3];
        let mut next_crossing = [0f32; 3];
        let mut delta = [0f32; 3];
        for a in 0..3 {
            let n = self.res[a] as i32;
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
        MajorantSegments {
            grid: self,
            t_min,
            t_max,
            voxel,
            step,
            limit,
            next_crossing,
            delta,
        }
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
    t_min: f32,
    t_max: f32,
    voxel: [i32; 3],
    step: [i32; 3],
    limit: [i32; 3],
    next_crossing: [f32; 3],
    delta: [f32; 3],
}

impl Iterator for MajorantSegments<'_> {
    type Item = MajorantSegment;

    #[inline]
    fn next(&mut self) -> Option<MajorantSegment> {
        if self.t_min >= self.t_max {
            return None;
        }
        let nc = self.next_crossing;
        let axis = if nc[0] < nc[1] {
            if nc[0] < nc[2] { 0 } else { 2 }
        } else if nc[1] < nc[2] {
            1
        } else {
            2
        };
        let [x, y, z] = self.voxel.map(|v| v as usize);
        let res = self.grid.res;
        let sigma_maj = self.grid.sigma[x + res[0] * (y + res[1] * z)];
        let t_exit = self.t_max.min(nc[axis]);
        let segment = MajorantSegment {
            t_min: self.t_min,
            t_max: t_exit,
            sigma_maj,
        };
        self.t_min = t_exit;
        if nc[axis] > self.t_max {
            self.t_min = self.t_max;
        }
        self.voxel[axis] += self.step[axis];
        if self.voxel[axis] == self.limit[axis] {
            self.t_min = self.t_max;
        }
        self.next_crossing[axis] += self.delta[axis];
        Some(segment)
    }
}
