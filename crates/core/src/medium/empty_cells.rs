//! Which cells of the grid of voxel centres are empty: one bit per cell, set when all eight
//! of its corner voxels are zero.
//!
//! The exact optical depth ([`super::optical_depth`]) walks every cell its ray crosses
//! inside a non-empty majorant brick. With the thesis's bone-only transfer functions about
//! half of those cells are empty (measured on the headline foot frame: 47 % of 3.1·10⁸
//! cells), and there a bit test replaces the eight corner loads and two trilinear
//! evaluations: the density is zero across the cell, so its integral is the entry value's
//! share alone — the same number the full evaluation gives, to the bit.

use crate::volume::Grid;

/// One bit per cell of the grid of voxel centres: all eight corners zero.
#[derive(Debug, Clone)]
pub(super) struct EmptyCells {
    /// Cells per axis (`n − 1` for `n ≥ 2` voxels, else 1).
    cells: [usize; 3],
    bits: Vec<u64>,
}

impl EmptyCells {
    /// Marks the empty cells of `density`.
    pub(super) fn build(density: &Grid) -> Self {
        let dims = density.dims();
        let cells = dims.map(|n| n.saturating_sub(1).max(1));
        let values = density.values();
        let voxel = |x: usize, y: usize, z: usize| {
            let [x, y, z] = [x.min(dims[0] - 1), y.min(dims[1] - 1), z.min(dims[2] - 1)];
            values[x + dims[0] * (y + dims[1] * z)] == 0.0
        };
        // Pairs along x first, then their 2 × 2 neighbourhoods in y and z.
        let mut pairs = vec![false; cells[0] * dims[1] * dims[2]];
        for z in 0..dims[2] {
            for y in 0..dims[1] {
                for x in 0..cells[0] {
                    pairs[x + cells[0] * (y + dims[1] * z)] = voxel(x, y, z) && voxel(x + 1, y, z);
                }
            }
        }
        let pair = |x: usize, y: usize, z: usize| {
            let [y, z] = [y.min(dims[1] - 1), z.min(dims[2] - 1)];
            pairs[x + cells[0] * (y + dims[1] * z)]
        };
        let count = cells[0] * cells[1] * cells[2];
        let mut bits = vec![0u64; count.div_ceil(64)];
        for z in 0..cells[2] {
            for y in 0..cells[1] {
                for x in 0..cells[0] {
                    let empty = pair(x, y, z)
                        && pair(x, y + 1, z)
                        && pair(x, y, z + 1)
                        && pair(x, y + 1, z + 1);
                    if empty {
                        let i = x + cells[0] * (y + cells[1] * z);
                        bits[i / 64] |= 1 << (i % 64);
                    }
                }
            }
        }
        EmptyCells { cells, bits }
    }

    /// Whether the cell with lower corner `cell` is empty. Cells outside the grid are
    /// clamped to the nearest one, which holds every corner the clamped reconstruction
    /// reads there (the outer half-voxel shell repeats the boundary voxels).
    #[inline]
    pub(super) fn is_empty(&self, cell: [i64; 3]) -> bool {
        let c = [0, 1, 2].map(|a| cell[a].clamp(0, self.cells[a] as i64 - 1) as usize);
        let i = c[0] + self.cells[0] * (c[1] + self.cells[1] * c[2]);
        self.bits[i / 64] >> (i % 64) & 1 == 1
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Aabb;
    use glam::Vec3;

    #[test]
    fn a_cell_is_empty_exactly_when_its_eight_corners_are_zero() {
        // 5³ voxels, zero but for one voxel at (2, 3, 1).
        let n = 5;
        let mut values = vec![0.0f32; n * n * n];
        values[2 + n * (3 + n)] = 0.5;
        let grid = Grid::new([n, n, n], values, Aabb::new(Vec3::ZERO, Vec3::ONE));
        let empty = EmptyCells::build(&grid);
        for z in -1..=n as i64 {
            for y in -1..=n as i64 {
                for x in -1..=n as i64 {
                    // The cell (clamped as the reconstruction clamps) reads voxels c and
                    // c + 1 per axis: it holds (2, 3, 1) when c ∈ {1, 2} in x, {2, 3} in y,
                    // {0, 1} in z.
                    let clamp = |c: i64| c.clamp(0, n as i64 - 2);
                    let holds = (1..=2).contains(&clamp(x))
                        && (2..=3).contains(&clamp(y))
                        && (0..=1).contains(&clamp(z));
                    assert_eq!(empty.is_empty([x, y, z]), !holds, "cell {x} {y} {z}");
                }
            }
        }
    }
}
