//! A scalar grid placed in a world box, with trilinear or nearest reconstruction (§2.1).
//!
//! Convention (documented once, used everywhere): voxel `(i, j, k)` has its centre at
//! `p0 + ((i + ½)/nx, (j + ½)/ny, (k + ½)/nz) · (p1 − p0)`. Lookups interpolate between
//! centres and clamp to the edge voxel in the outer half-voxel shell; outside the box the
//! value is 0 (no medium outside the volume).

use glam::Vec3;
use serde::{Deserialize, Serialize};

use crate::math::Aabb;

/// Voxel values read by linear index: a grid's own `f32`s, or a compact copy of them
/// (`medium`'s indexed density).
pub(crate) trait Voxels {
    /// The eight corners of the cell whose lower corner has linear index `base`, the upper
    /// ones `step` further along x, y and z (x fastest, as [`trilinear_corners`] takes
    /// them).
    fn corners(&self, base: usize, step: [usize; 3]) -> [f32; 8];
}

/// The corner offsets of a cell in the order of [`Voxels::corners`].
#[inline]
pub(crate) fn corner_offsets([sx, sy, sz]: [usize; 3]) -> [usize; 8] {
    [0, sx, sy, sx + sy, sz, sx + sz, sy + sz, sx + sy + sz]
}

impl Voxels for [f32] {
    #[inline]
    fn corners(&self, base: usize, step: [usize; 3]) -> [f32; 8] {
        let block = &self[base..=base + step[0] + step[1] + step[2]];
        corner_offsets(step).map(|o| block[o])
    }
}

/// Trilinear interpolation of a cell's corners (x fastest) at fractions `f` in [0, 1]³:
/// along x, then y, then z. Every trilinear value of the renderer comes from here, so the
/// grid and its compact copy give the same value to the bit.
#[inline]
pub(crate) fn trilinear_corners(c: &[f32; 8], f: [f32; 3]) -> f32 {
    let x00 = c[0] + (c[1] - c[0]) * f[0];
    let x10 = c[2] + (c[3] - c[2]) * f[0];
    let x01 = c[4] + (c[5] - c[4]) * f[0];
    let x11 = c[6] + (c[7] - c[6]) * f[0];
    let y0 = x00 + (x10 - x00) * f[1];
    let y1 = x01 + (x11 - x01) * f[1];
    y0 + (y1 - y0) * f[2]
}

/// Trilinear lookups along a path that stays in one cell for several samples (a ray
/// marched at a step below the voxel size): the cell's corners are read once and reused
/// while the samples stay in it, and a cell of eight zero corners answers zero at once.
/// The same value to the bit as [`Grid::trilinear_clamped`]: the same cell, fractions and
/// corners go into the same formula.
#[derive(Debug, Clone)]
pub(crate) struct CellCursor {
    /// The linear index of the current cell's lower corner (one number: comparing three
    /// indices stored apart made every lookup wait on a failed store-to-load forward).
    base: usize,
    corners: [f32; 8],
    empty: bool,
}

impl Default for CellCursor {
    fn default() -> Self {
        CellCursor {
            base: usize::MAX,
            corners: [0.0; 8],
            empty: true,
        }
    }
}

impl CellCursor {
    /// [`Grid::trilinear_clamped`] at `p`.
    #[inline]
    pub(crate) fn trilinear(&mut self, grid: &Grid, p: Vec3) -> f32 {
        let (cell, fraction) = grid.trilinear_cell(p);
        let (base, step) = grid.cell_corners(cell);
        if base != self.base {
            self.corners = grid.values.corners(base, step);
            self.empty = self.corners.iter().all(|&c| c == 0.0);
            self.base = base;
        }
        if self.empty {
            // Every lerp of zeros is zero (a −0 would add nothing to a sum either).
            return 0.0;
        }
        trilinear_corners(&self.corners, fraction)
    }
}

/// How values between voxel centres are reconstructed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Reconstruction {
    /// Trilinear interpolation of the 8 surrounding voxels (thesis §2.1, the default).
    #[default]
    Trilinear,
    /// The value of the voxel whose cell contains the point (for comparison).
    Nearest,
}

/// A dense `nx × ny × nz` grid of `f32`, x fastest: `index = x + nx·(y + ny·z)`.
#[derive(Debug, Clone)]
pub struct Grid {
    dims: [usize; 3],
    values: Vec<f32>,
    bounds: Aabb,
    /// `dims / extent`, cached for lookups.
    scale: Vec3,
}

impl Grid {
    /// A grid from values in x-fastest order. Panics if `values.len()` is not the product
    /// of `dims` or a dimension is zero: callers validate user input before this point.
    pub fn new(dims: [usize; 3], values: Vec<f32>, bounds: Aabb) -> Self {
        assert!(dims.iter().all(|&n| n > 0), "grid dims must be positive");
        assert_eq!(values.len(), dims[0] * dims[1] * dims[2], "grid size");
        let scale = Vec3::new(dims[0] as f32, dims[1] as f32, dims[2] as f32) / bounds.extent();
        Grid {
            dims,
            values,
            bounds,
            scale,
        }
    }

    /// A grid of the same shape and placement as `self` with new values.
    pub fn with_values(&self, values: Vec<f32>) -> Self {
        Grid::new(self.dims, values, self.bounds)
    }

    /// Voxel counts along x, y, z.
    pub fn dims(&self) -> [usize; 3] {
        self.dims
    }

    /// The world box the grid spans.
    pub fn bounds(&self) -> Aabb {
        self.bounds
    }

    /// All values, x fastest.
    pub fn values(&self) -> &[f32] {
        &self.values
    }

    /// Consumes the grid and returns its values.
    pub fn into_values(self) -> Vec<f32> {
        self.values
    }

    /// Linear index of voxel `(x, y, z)`.
    #[inline]
    pub fn index(&self, x: usize, y: usize, z: usize) -> usize {
        x + self.dims[0] * (y + self.dims[1] * z)
    }

    /// The value of voxel `(x, y, z)`.
    #[inline]
    pub fn voxel(&self, x: usize, y: usize, z: usize) -> f32 {
        self.values[self.index(x, y, z)]
    }

    /// World position of the centre of voxel `(x, y, z)`.
    pub fn voxel_center(&self, x: usize, y: usize, z: usize) -> Vec3 {
        self.bounds.min + (Vec3::new(x as f32, y as f32, z as f32) + 0.5) / self.scale
    }

    /// The edge length of one voxel along each axis, in world units.
    pub fn voxel_size(&self) -> Vec3 {
        self.scale.recip()
    }

    /// Reconstructed value at world point `p` (0 outside the box).
    #[inline]
    pub fn sample(&self, p: Vec3, reconstruction: Reconstruction) -> f32 {
        match reconstruction {
            Reconstruction::Trilinear => self.trilinear(p),
            Reconstruction::Nearest => self.nearest(p),
        }
    }

    /// Trilinear reconstruction between voxel centres (§2.1).
    #[inline]
    pub fn trilinear(&self, p: Vec3) -> f32 {
        if !self.bounds.contains(p) {
            return 0.0;
        }
        self.trilinear_clamped(p)
    }

    /// Trilinear reconstruction for a point known to lie in the box (e.g. a marching sample
    /// inside the ray's clipped interval); points outside read the nearest edge cell.
    #[inline]
    pub fn trilinear_clamped(&self, p: Vec3) -> f32 {
        let (cell, fraction) = self.trilinear_cell(p);
        let (base, step) = self.cell_corners(cell);
        trilinear_corners(&self.values.corners(base, step), fraction)
    }

    /// The linear index of `cell`'s lower corner voxel and the steps to its upper corners
    /// along x, y and z (0 along an axis one voxel wide, where the corners coincide), as
    /// [`Voxels::corners`] takes them.
    #[inline]
    pub(crate) fn cell_corners(&self, cell: [usize; 3]) -> (usize, [usize; 3]) {
        let [nx, ny, _] = self.dims;
        let pitch = [1, nx, nx * ny];
        let base = cell[0] + pitch[1] * cell[1] + pitch[2] * cell[2];
        let step = [0, 1, 2].map(|a| if self.dims[a] > 1 { pitch[a] } else { 0 });
        (base, step)
    }

    /// Voxels per unit length along each axis (`dims / extent`).
    #[inline]
    pub(crate) fn scale(&self) -> Vec3 {
        self.scale
    }

    /// The lower corner of the cell of voxel centres that [`Self::trilinear_clamped`]
    /// interpolates at `p` (it reads that voxel and the next one along each axis, clamped
    /// to the grid), and `p`'s fractions between them.
    #[inline]
    pub fn trilinear_cell(&self, p: Vec3) -> ([usize; 3], [f32; 3]) {
        // Continuous voxel coordinate with centres at integers.
        let c = (p - self.bounds.min) * self.scale - 0.5;
        let corner = |c: f32, n: usize| {
            let f = c.clamp(0.0, (n - 1) as f32);
            let lower = (f as usize).min(n.saturating_sub(2));
            (lower, f - lower as f32)
        };
        let [(x0, tx), (y0, ty), (z0, tz)] = [0, 1, 2].map(|a| corner(c[a], self.dims[a]));
        ([x0, y0, z0], [tx, ty, tz])
    }

    /// Nearest-voxel reconstruction.
    #[inline]
    pub fn nearest(&self, p: Vec3) -> f32 {
        if !self.bounds.contains(p) {
            return 0.0;
        }
        let c = (p - self.bounds.min) * self.scale;
        let x = (c.x as usize).min(self.dims[0] - 1);
        let y = (c.y as usize).min(self.dims[1] - 1);
        let z = (c.z as usize).min(self.dims[2] - 1);
        self.voxel(x, y, z)
    }

    /// Smallest and largest value.
    pub fn min_max(&self) -> (f32, f32) {
        self.values
            .iter()
            .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), &v| {
                (lo.min(v), hi.max(v))
            })
    }

    /// The smallest strictly positive value (the thesis's `d_min`, §8.1.2), if any.
    pub fn min_positive(&self) -> Option<f32> {
        self.values
            .iter()
            .copied()
            .filter(|v| *v > 0.0)
            .fold(None, |m: Option<f32>, v| Some(m.map_or(v, |m| m.min(v))))
    }

    /// The arithmetic mean of all values.
    pub fn mean(&self) -> f64 {
        self.values.iter().map(|&v| v as f64).sum::<f64>() / self.values.len() as f64
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_cell_cursor_reads_what_the_grid_reads_to_the_bit() {
        use crate::math::{Domain, Rng};
        // Sparse values: whole cells of zeros beside cells of irregular values.
        let dims = [13, 9, 7];
        let mut rng = Rng::stream(3, Domain::Misc, 0);
        let values = (0..dims[0] * dims[1] * dims[2])
            .map(|_| {
                let v = rng.uniform();
                if v < 0.5 { 0.0 } else { v * 3.7 }
            })
            .collect();
        let grid = Grid::new(dims, values, Aabb::unit());
        let mut cursor = CellCursor::default();
        let (mut reused, mut zero) = (0, 0);
        for _ in 0..200 {
            // Rays that start and end a little outside the box (clamped lookups).
            let a = Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()) * 1.2 - 0.1;
            let b = Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()) * 1.2 - 0.1;
            let mut previous = None;
            for i in 0..=400 {
                let p = a.lerp(b, i as f32 / 400.0);
                let got = cursor.trilinear(&grid, p);
                assert_eq!(got.to_bits(), grid.trilinear_clamped(p).to_bits(), "at {p}");
                let cell = grid.trilinear_cell(p).0;
                reused += usize::from(previous == Some(cell));
                zero += usize::from(got == 0.0);
                previous = Some(cell);
            }
        }
        // The walk did reuse corners and did meet empty cells.
        assert!(
            reused > 40_000 && zero > 1_000,
            "{reused} reused, {zero} zero"
        );
    }

    fn ramp_x(n: usize) -> Grid {
        let mut values = vec![0.0; n * 2 * 2];
        for z in 0..2 {
            for y in 0..2 {
                for x in 0..n {
                    values[x + n * (y + 2 * z)] = x as f32;
                }
            }
        }
        Grid::new([n, 2, 2], values, Aabb::unit())
    }

    #[test]
    fn trilinear_hits_voxel_centres_and_interpolates() {
        let g = ramp_x(4);
        // Centres at x = 0.125, 0.375, 0.625, 0.875.
        assert!((g.trilinear(Vec3::new(0.375, 0.5, 0.5)) - 1.0).abs() < 1e-6);
        assert!((g.trilinear(Vec3::new(0.5, 0.3, 0.7)) - 1.5).abs() < 1e-6);
        // Outer half-voxel shell clamps to the edge voxel.
        assert!((g.trilinear(Vec3::new(0.01, 0.5, 0.5)) - 0.0).abs() < 1e-6);
        assert!((g.trilinear(Vec3::new(0.99, 0.5, 0.5)) - 3.0).abs() < 1e-6);
        assert_eq!(g.trilinear(Vec3::new(1.01, 0.5, 0.5)), 0.0);
        assert_eq!(g.voxel_center(1, 0, 0), Vec3::new(0.375, 0.25, 0.25));
    }

    #[test]
    fn nearest_picks_containing_cell() {
        let g = ramp_x(4);
        assert_eq!(g.nearest(Vec3::new(0.26, 0.5, 0.5)), 1.0);
        assert_eq!(g.nearest(Vec3::new(1.0, 0.5, 0.5)), 3.0);
    }

    #[test]
    fn single_voxel_axes_are_constant() {
        let g = Grid::new([1, 1, 1], vec![0.7], Aabb::unit());
        assert!((g.trilinear(Vec3::splat(0.3)) - 0.7).abs() < 1e-6);
        assert_eq!(g.min_positive(), Some(0.7));
    }
}
