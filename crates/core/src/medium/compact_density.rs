//! The density grid as indices into a table of its distinct values: the same numbers in a
//! quarter or half of the memory.
//!
//! The exact optical depth ([`super::optical_depth`]) reads eight corner voxels in every
//! cell a shadow ray crosses, and the rays of neighbouring pixels cross different parts of
//! the grid: a 256³ grid of `f32` (64 MiB) does not stay in the processor's caches (32 MiB
//! of L3 on the reference machine), so most corner loads wait for memory. The transfer
//! function maps each voxel's value on its own, so a grid holds at most as many distinct
//! densities as the data has raw values — 256 for the thesis's 8-bit volumes — and a byte
//! (or two) per voxel indexes them exactly: the loop reads the same `f32` values, and the
//! optical depth is the same to the bit.

use crate::volume::{Grid, Voxels, corner_offsets};

/// A density grid's values as indices into the table of its distinct values.
#[derive(Debug, Clone)]
pub(super) enum CompactDensity {
    /// At most 256 distinct values: one byte per voxel.
    Byte(Indexed<u8, 256>),
    /// At most 65 536 distinct values: two bytes per voxel.
    Word(Indexed<u16, 65536>),
}

/// Per voxel (x fastest), the position of its value in a table of `N` values (unused
/// entries zero).
#[derive(Debug, Clone)]
pub(super) struct Indexed<I, const N: usize> {
    index: Vec<I>,
    table: Box<[f32; N]>,
}

impl<I: Copy + Into<usize>, const N: usize> Voxels for Indexed<I, N> {
    #[inline]
    fn corners(&self, base: usize, step: [usize; 3]) -> [f32; 8] {
        let block = &self.index[base..=base + step[0] + step[1] + step[2]];
        corner_offsets(step).map(|o| self.table[block[o].into()])
    }
}

impl CompactDensity {
    /// The compact copy of `grid`, or `None` when it has more than 65 536 distinct values
    /// (bit patterns: `0.0` and `-0.0` are two).
    pub(super) fn build(grid: &Grid) -> Option<Self> {
        let (index, distinct) = index_distinct(grid.values())?;
        if distinct.len() <= 256 {
            let mut table = Box::new([0.0f32; 256]);
            table[..distinct.len()].copy_from_slice(&distinct);
            let index = index.into_iter().map(|i| i as u8).collect();
            return Some(CompactDensity::Byte(Indexed { index, table }));
        }
        let mut table: Box<[f32; 65536]> = vec![0.0f32; 65536].try_into().ok()?;
        table[..distinct.len()].copy_from_slice(&distinct);
        Some(CompactDensity::Word(Indexed { index, table }))
    }
}

/// Each value's position in the list of distinct values (by bit pattern, in order of first
/// appearance), and that list; `None` past 65 536 distinct values.
fn index_distinct(values: &[f32]) -> Option<(Vec<u16>, Vec<f32>)> {
    // Open addressing on the bit pattern; a slot holds its entry's position + 1 (0: free).
    const SLOTS: usize = 1 << 17;
    let mut slots = vec![(0u32, 0u32); SLOTS];
    let mut distinct: Vec<f32> = Vec::new();
    let mut index = Vec::with_capacity(values.len());
    // Runs of equal values (the empty space) skip the table.
    let mut last: Option<(u32, u16)> = None;
    for &v in values {
        let bits = v.to_bits();
        if let Some((b, i)) = last
            && b == bits
        {
            index.push(i);
            continue;
        }
        let mut slot = (bits.wrapping_mul(0x9E37_79B1) >> 15) as usize;
        let i = loop {
            match slots[slot] {
                (0, _) => {
                    if distinct.len() == 1 << 16 {
                        return None;
                    }
                    distinct.push(v);
                    slots[slot] = (distinct.len() as u32, bits);
                    break (distinct.len() - 1) as u16;
                }
                (entry, b) if b == bits => break (entry - 1) as u16,
                _ => slot = (slot + 1) % SLOTS,
            }
        };
        index.push(i);
        last = Some((bits, i));
    }
    Some((index, distinct))
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use super::*;
    use crate::math::Aabb;

    fn grid(values: Vec<f32>) -> Grid {
        let n = values.len();
        Grid::new([n, 1, 1], values, Aabb::new(Vec3::ZERO, Vec3::ONE))
    }

    /// Every value read back through the compact copy, to the bit.
    fn read_back(c: &CompactDensity, n: usize) -> Vec<u32> {
        (0..n)
            .map(|i| match c {
                CompactDensity::Byte(b) => b.corners(i, [0; 3])[0],
                CompactDensity::Word(w) => w.corners(i, [0; 3])[0],
            })
            .map(f32::to_bits)
            .collect()
    }

    #[test]
    fn few_values_take_a_byte_and_read_back_to_the_bit() {
        let values: Vec<f32> = (0..5000)
            .map(|i| [0.0, -0.0, 0.35, 1.0, f32::MIN_POSITIVE][i * 7 % 5] * (1 + i % 40) as f32)
            .collect();
        let c = CompactDensity::build(&grid(values.clone())).expect("few values");
        assert!(
            matches!(c, CompactDensity::Byte(_)),
            "at most 256 distinct values take a byte"
        );
        let bits: Vec<u32> = values.iter().map(|v| v.to_bits()).collect();
        assert_eq!(read_back(&c, values.len()), bits);
    }

    #[test]
    fn more_values_take_two_bytes_and_too_many_none() {
        let values: Vec<f32> = (0..70_000).map(|i| (i % 30_000) as f32 * 1e-3).collect();
        let c = CompactDensity::build(&grid(values.clone())).expect("30 000 values");
        assert!(
            matches!(c, CompactDensity::Word(_)),
            "more than 256 distinct values take two bytes"
        );
        let bits: Vec<u32> = values.iter().map(|v| v.to_bits()).collect();
        assert_eq!(read_back(&c, values.len()), bits);
        let unique: Vec<f32> = (0..70_000).map(|i| i as f32).collect();
        assert!(
            CompactDensity::build(&grid(unique)).is_none(),
            "70 000 distinct"
        );
    }

    #[test]
    fn corners_are_read_in_the_cells_order() {
        // A 2 × 2 × 2 grid of distinct values: the corners of its one cell are all of them.
        let values: Vec<f32> = (0..8).map(|i| i as f32 * 0.5).collect();
        let c = CompactDensity::build(&Grid::new(
            [2, 2, 2],
            values.clone(),
            Aabb::new(Vec3::ZERO, Vec3::ONE),
        ))
        .expect("eight values");
        let step = [1, 2, 4];
        assert_eq!(
            values.corners(0, step),
            [0.0, 0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 3.5]
        );
        let CompactDensity::Byte(bytes) = c else {
            panic!("eight values take a byte")
        };
        assert_eq!(bytes.corners(0, step), values.corners(0, step));
    }
}
