//! The 348-byte NIfTI-1 header, parsed byte for byte and checked field by field — size,
//! magic, dims against the memory budget, datatype, bitpix, vox_offset, scaling — before a
//! single voxel is read or inflated, so a bad header is refused by its field and value, not
//! by what happens when its claims are acted on.

use std::path::Path;

use super::super::{ByteOrder, check_dims};
use super::datatype::Datatype;
use crate::error::{Error, Result};
use crate::util::escaped_prefix;

/// Bytes of a NIfTI-1 header (also its `sizeof_hdr`).
pub(super) const HEADER_BYTES: usize = 348;

/// Where a file's voxels are, which its magic must say.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Storage {
    /// A `.nii`: the voxels follow the header in the same file (magic `n+1\0`).
    SingleFile,
    /// A `.hdr`: the voxels are in the `.img` beside it (magic `ni1\0`).
    Pair,
}

impl Storage {
    fn magic(self) -> &'static [u8; 4] {
        match self {
            Storage::SingleFile => b"n+1\0",
            Storage::Pair => b"ni1\0",
        }
    }

    fn what(self) -> &'static str {
        match self {
            Storage::SingleFile => "a single-file .nii",
            Storage::Pair => "the header of a .hdr/.img pair",
        }
    }

    /// The least vox_offset: past the header and its 4 extension-flag bytes in a `.nii`,
    /// anywhere in a pair's `.img`.
    fn least_offset(self) -> u64 {
        match self {
            Storage::SingleFile => HEADER_BYTES as u64 + 4,
            Storage::Pair => 0,
        }
    }
}

/// The header fields the reader uses, in the file's byte order already converted.
#[derive(Debug, Clone)]
pub(super) struct Header {
    pub byte_order: ByteOrder,
    pub dim: [i16; 8],
    pub datatype: i16,
    pub bitpix: i16,
    pub pixdim: [f32; 8],
    pub vox_offset: f32,
    pub scl_slope: f32,
    pub scl_inter: f32,
    pub descrip: [u8; 80],
    pub qform_code: i16,
    pub sform_code: i16,
    pub quatern: [f32; 3],
    pub srow: [[f32; 4]; 3],
    pub magic: [u8; 4],
}

/// Reads fixed-size fields at byte offsets in one byte order.
struct Fields<'a> {
    bytes: &'a [u8; HEADER_BYTES],
    order: ByteOrder,
}

impl Fields<'_> {
    fn array<const N: usize>(&self, at: usize) -> [u8; N] {
        self.bytes[at..at + N]
            .try_into()
            .expect("offsets lie in the header")
    }

    fn i16(&self, at: usize) -> i16 {
        let a = self.array(at);
        match self.order {
            ByteOrder::Little => i16::from_le_bytes(a),
            ByteOrder::Big => i16::from_be_bytes(a),
        }
    }

    fn f32(&self, at: usize) -> f32 {
        let a = self.array(at);
        match self.order {
            ByteOrder::Little => f32::from_le_bytes(a),
            ByteOrder::Big => f32::from_be_bytes(a),
        }
    }

    fn f32s<const N: usize>(&self, at: usize) -> [f32; N] {
        std::array::from_fn(|i| self.f32(at + 4 * i))
    }
}

impl Header {
    /// Parses the header; its byte order is the one in which `sizeof_hdr` reads 348
    /// (nifti1.h's own test).
    pub(super) fn parse(path: &Path, bytes: &[u8; HEADER_BYTES]) -> Result<Header> {
        let size = [0, 1, 2, 3].map(|i| bytes[i]);
        let order = match (i32::from_le_bytes(size), i32::from_be_bytes(size)) {
            (348, _) => ByteOrder::Little,
            (_, 348) => ByteOrder::Big,
            (540, _) | (_, 540) => {
                return Err(Error::format(
                    path,
                    "sizeof_hdr 540 (bytes 0-3) is NIfTI-2, which is not supported; expected 348 (NIfTI-1)",
                ));
            }
            (little, _) => {
                return Err(Error::format(
                    path,
                    format!(
                        "sizeof_hdr {little} (bytes 0-3): expected 348 in either byte order; not a NIfTI-1 file? It starts with `{}`",
                        escaped_prefix(bytes, 8)
                    ),
                ));
            }
        };
        let f = Fields { bytes, order };
        Ok(Header {
            byte_order: order,
            dim: std::array::from_fn(|i| f.i16(40 + 2 * i)),
            datatype: f.i16(70),
            bitpix: f.i16(72),
            pixdim: f.f32s(76),
            vox_offset: f.f32(108),
            scl_slope: f.f32(112),
            scl_inter: f.f32(116),
            descrip: f.array(148),
            qform_code: f.i16(252),
            sform_code: f.i16(254),
            quatern: f.f32s(256),
            srow: [f.f32s(280), f.f32s(296), f.f32s(312)],
            magic: f.array(344),
        })
    }
}

/// What a checked header says about the voxels.
#[derive(Debug, Clone)]
pub(super) struct Layout {
    pub dims: [usize; 3],
    pub datatype: Datatype,
    pub byte_order: ByteOrder,
    /// Where the voxels start in the file that holds them (vox_offset).
    pub offset: u64,
    /// Bytes of voxel data: voxels × bytes per voxel.
    pub data_bytes: u64,
    /// `[scl_slope, scl_inter]`, `[1, 0]` when the slope is 0 (no scaling, nifti1.h).
    pub rescale: [f64; 2],
}

/// Checks the fields the voxels depend on, in the order a reader would act on them:
/// magic, dims (against the memory budget), datatype, bitpix, vox_offset, scaling.
pub(super) fn check(path: &Path, h: &Header, storage: Storage) -> Result<Layout> {
    let fail = |message: String| Error::format(path, message);
    if &h.magic != storage.magic() {
        return Err(fail(wrong_magic(&h.magic, storage)));
    }
    let dims = dims_of(h).map_err(fail)?;
    let count = check_dims(path, dims)?;
    let datatype = Datatype::from_code(h.datatype).map_err(fail)?;
    let bits = 8 * datatype.bytes();
    if usize::try_from(h.bitpix) != Ok(bits) {
        return Err(fail(format!(
            "bitpix {} does not match {datatype}, which has {bits} bits per voxel; the header is inconsistent",
            h.bitpix
        )));
    }
    Ok(Layout {
        dims,
        datatype,
        byte_order: h.byte_order,
        offset: offset_of(h.vox_offset, storage).map_err(fail)?,
        data_bytes: count as u64 * datatype.bytes() as u64,
        rescale: rescale_of(h).map_err(fail)?,
    })
}

fn wrong_magic(found: &[u8; 4], storage: Storage) -> String {
    let shown = |m: &[u8]| escaped_prefix(m, 4);
    let expected = storage.magic();
    let hint = if found == Storage::Pair.magic() {
        "; it marks the header of a .hdr/.img pair: name the file .hdr, with its .img beside it"
    } else if found == Storage::SingleFile.magic() {
        "; it marks a single-file .nii: name the file .nii"
    } else {
        " (NIfTI-1); damaged, or not a NIfTI-1 file?"
    };
    format!(
        "magic `{}` (bytes 344-347): expected `{}` for {}{hint}",
        shown(found),
        shown(expected),
        storage.what()
    )
}

/// The three spatial sizes: `dim[0]` dimensions (1 to 7), each at least 1, any past the
/// third equal to 1 (one volume).
fn dims_of(h: &Header) -> Result<[usize; 3], String> {
    let rank = h.dim[0];
    if !(1..=7).contains(&rank) {
        return Err(format!(
            "dim[0] = {rank}: expected the number of dimensions, 1 to 7"
        ));
    }
    let sizes = &h.dim[1..=rank as usize];
    if sizes.iter().any(|&n| n < 1) {
        return Err(format!(
            "dim[1..={rank}] = {sizes:?}: every size must be at least 1"
        ));
    }
    if sizes.len() > 3 && sizes[3..].iter().any(|&n| n > 1) {
        return Err(format!(
            "dims {sizes:?}: a {rank}-D image with more than one volume; expected a 3-D volume"
        ));
    }
    let at = |i: usize| sizes.get(i).map_or(1, |&n| n as usize);
    Ok([at(0), at(1), at(2)])
}

/// vox_offset as a byte position: a whole number, at least past the header in a `.nii`.
/// (That it lies inside the file, with the voxels after it, is checked as it is read.)
fn offset_of(vox_offset: f32, storage: Storage) -> Result<u64, String> {
    let least = storage.least_offset();
    if vox_offset.is_finite() && vox_offset.fract() == 0.0 && vox_offset >= least as f32 {
        // A whole f32 of at least 0 converts exactly (saturating past u64::MAX, which no
        // file reaches).
        return Ok(vox_offset as u64);
    }
    Err(format!(
        "vox_offset {}: expected a whole number of bytes, at least {least} for {}",
        number(vox_offset),
        storage.what()
    ))
}

/// `[scl_slope, scl_inter]`: a slope of 0 means no scaling (nifti1.h); otherwise both
/// must be finite, or every voxel would be NaN or infinite.
fn rescale_of(h: &Header) -> Result<[f64; 2], String> {
    let (slope, inter) = (h.scl_slope, h.scl_inter);
    if slope == 0.0 {
        return Ok([1.0, 0.0]);
    }
    for (name, value) in [("scl_slope", slope), ("scl_inter", inter)] {
        if !value.is_finite() {
            return Err(format!(
                "{name} {}: expected a finite number (scl_slope 0 means no scaling)",
                number(value)
            ));
        }
    }
    Ok([f64::from(slope), f64::from(inter)])
}

/// A header number as written in messages: `352`, `352.5`, `NaN`, `1e-30` (not thirty
/// zeros).
pub(super) fn number(value: f32) -> String {
    let plain = value.to_string();
    if plain.len() <= 12 {
        plain
    } else {
        format!("{value:e}")
    }
}
