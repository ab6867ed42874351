//! A reference accumulator's exact state on disk, so a reference refined later gives the
//! bits of one rendered whole.
//!
//! Version 1 (one sample per pixel per pass): the magic, width, height and passes as
//! little-endian `u32`, a byte saying whether the total's statistics are known, then per
//! pixel four means and four sums of squared deviations (RGB `f32`). Version 2 (an
//! allocation, [`super::allocation`]) is the same with its own magic and each pixel's
//! share (`f32`) after the pixels. A state without an allocation is written as version 1,
//! byte for byte what every earlier release wrote.

use std::path::Path;

use glam::Vec3;

use super::accumulator::{PixelStats, ReferenceAccumulator};
use super::allocation::Allocation;
use crate::error::{Error, Result};

/// The first bytes of a state without an allocation.
const STATE_MAGIC: &[u8] = b"volphot reference state 1\n";
/// The first bytes of a state with an allocation (as long as [`STATE_MAGIC`]).
const ALLOCATED_MAGIC: &[u8] = b"volphot reference state 2\n";
/// Magic, width, height, passes, whether the total is known.
const STATE_HEADER_LEN: usize = STATE_MAGIC.len() + 3 * 4 + 1;
/// Four means and four sums of squared deviations, three channels each.
const PIXEL_BYTES: usize = 8 * 3 * 4;
/// A pixel's share of the samples.
const SHARE_BYTES: usize = 4;

impl ReferenceAccumulator {
    /// Writes the accumulator's exact state (every running sum, bit for bit) to `path`.
    ///
    /// A film keeps the variance of the mean, from which [`Self::from_film`] recovers the
    /// sums only to rounding; [`Self::read_state`] recovers them exactly, so passes added
    /// after it give the bits of an accumulator that ran them all at once: a reference of
    /// `n` passes is the same image whether it was rendered whole or refined in steps.
    pub fn write_state(&self, path: &Path) -> Result<()> {
        let shares = self.allocation.as_ref().map(Allocation::shares);
        let mut bytes =
            Vec::with_capacity(STATE_HEADER_LEN + self.pixels.len() * (PIXEL_BYTES + SHARE_BYTES));
        bytes.extend_from_slice(if shares.is_some() {
            ALLOCATED_MAGIC
        } else {
            STATE_MAGIC
        });
        for n in [self.width as u32, self.height as u32, self.passes] {
            bytes.extend_from_slice(&n.to_le_bytes());
        }
        bytes.push(u8::from(self.total_known));
        for px in &self.pixels {
            for v in px.mean.iter().chain(&px.m2) {
                for c in v.to_array() {
                    bytes.extend_from_slice(&c.to_le_bytes());
                }
            }
        }
        for share in shares.into_iter().flatten() {
            bytes.extend_from_slice(&share.to_le_bytes());
        }
        std::fs::write(path, bytes).map_err(|error| Error::Io {
            path: path.to_path_buf(),
            error,
        })
    }

    /// Reads a state written by [`Self::write_state`].
    pub fn read_state(path: &Path) -> Result<Self> {
        let bytes = std::fs::read(path).map_err(|error| Error::Io {
            path: path.to_path_buf(),
            error,
        })?;
        let format = |message: String| Error::Format {
            path: path.to_path_buf(),
            message,
        };
        let allocated = bytes.starts_with(ALLOCATED_MAGIC);
        if bytes.len() < STATE_HEADER_LEN || !(allocated || bytes.starts_with(STATE_MAGIC)) {
            return Err(format(format!(
                "not a reference accumulator state (expected a file starting with {:?} or {:?})",
                String::from_utf8_lossy(STATE_MAGIC),
                String::from_utf8_lossy(ALLOCATED_MAGIC)
            )));
        }
        let word = |i: usize| {
            let at = STATE_MAGIC.len() + 4 * i;
            u32::from_le_bytes(bytes[at..at + 4].try_into().expect("4 bytes"))
        };
        let (width, height, passes) = (word(0) as usize, word(1) as usize, word(2));
        let per_pixel = PIXEL_BYTES + if allocated { SHARE_BYTES } else { 0 };
        let expected = width
            .checked_mul(height)
            .and_then(|n| n.checked_mul(per_pixel))
            .and_then(|n| n.checked_add(STATE_HEADER_LEN));
        if expected != Some(bytes.len()) {
            return Err(format(format!(
                "{} bytes for a {width}×{height} state, expected {}",
                bytes.len(),
                expected.map_or("fewer pixels".into(), |n| n.to_string())
            )));
        }
        let mut floats = bytes[STATE_HEADER_LEN..]
            .chunks_exact(4)
            .map(|b| f32::from_le_bytes(b.try_into().expect("4 bytes")));
        let mut next = || {
            Vec3::new(
                next_f32(&mut floats),
                next_f32(&mut floats),
                next_f32(&mut floats),
            )
        };
        let pixels = (0..width * height)
            .map(|_| PixelStats {
                mean: std::array::from_fn(|_| next()),
                m2: std::array::from_fn(|_| next()),
            })
            .collect();
        let allocation = allocated.then(|| {
            let shares: Vec<f32> = floats.collect();
            Allocation::from_shares(shares)
        });
        if let Some(a) = &allocation
            && let Some(bad) = a.shares().iter().find(|s| !(s.is_finite() && **s > 0.0))
        {
            return Err(format(format!(
                "a pixel's share of the samples is {bad}, expected a positive number"
            )));
        }
        Ok(ReferenceAccumulator {
            width,
            height,
            passes,
            pixels,
            total_known: bytes[STATE_HEADER_LEN - 1] != 0,
            allocation,
        })
    }
}

/// The next float of a state whose length was checked.
fn next_f32(floats: &mut impl Iterator<Item = f32>) -> f32 {
    floats.next().expect("length checked")
}
