//! Writes NIfTI-1 headers byte for byte for the reader's tests: any field may hold any
//! value, valid or not (the `nifti` crate's writer would fix or refuse most bad ones), in
//! either byte order, as a single `.nii` or as the header of a `.hdr`/`.img` pair.

use std::io::Write as _;

/// The fields of a NIfTI-1 header the reader looks at; everything else is written as zero.
#[derive(Debug, Clone, PartialEq)]
pub struct Nifti1 {
    /// `sizeof_hdr` (bytes 0–3): 348 for NIfTI-1.
    pub sizeof_hdr: i32,
    /// `dim[0..8]` (bytes 40–55): the dimensionality, then the sizes.
    pub dim: [i16; 8],
    /// `datatype` (byte 70).
    pub datatype: i16,
    /// `bitpix` (byte 72).
    pub bitpix: i16,
    /// `pixdim[0..8]` (bytes 76–107): qfac, then the voxel sizes.
    pub pixdim: [f32; 8],
    /// `vox_offset` (byte 108).
    pub vox_offset: f32,
    /// `scl_slope`, `scl_inter` (bytes 112, 116).
    pub scl: [f32; 2],
    /// `qform_code`, `sform_code` (bytes 252, 254).
    pub codes: [i16; 2],
    /// `quatern_b`, `quatern_c`, `quatern_d` (bytes 256–267).
    pub quatern: [f32; 3],
    /// `srow_x`, `srow_y`, `srow_z` (bytes 280–327).
    pub srow: [[f32; 4]; 3],
    /// `magic` (bytes 344–347).
    pub magic: [u8; 4],
    /// Big-endian instead of little-endian.
    pub big_endian: bool,
}

impl Default for Nifti1 {
    /// A valid single-file header: 4×3×2 `int16` voxels of 1 mm, no sform or qform, data
    /// right after the header's 4 extension bytes.
    fn default() -> Self {
        Nifti1 {
            sizeof_hdr: 348,
            dim: [3, 4, 3, 2, 1, 1, 1, 1],
            datatype: 4,
            bitpix: 16,
            pixdim: [1.0, 1.0, 1.0, 1.0, 0.0, 0.0, 0.0, 0.0],
            vox_offset: 352.0,
            scl: [1.0, 0.0],
            codes: [0, 0],
            quatern: [0.0; 3],
            srow: [[0.0; 4]; 3],
            magic: *b"n+1\0",
            big_endian: false,
        }
    }
}

impl Nifti1 {
    /// The 348 header bytes.
    pub fn header(&self) -> Vec<u8> {
        let mut h = Header {
            bytes: vec![0u8; 348],
            big_endian: self.big_endian,
        };
        h.put(
            0,
            &self.sizeof_hdr.to_le_bytes(),
            &self.sizeof_hdr.to_be_bytes(),
        );
        for (i, d) in self.dim.iter().enumerate() {
            h.put(40 + 2 * i, &d.to_le_bytes(), &d.to_be_bytes());
        }
        h.put(
            70,
            &self.datatype.to_le_bytes(),
            &self.datatype.to_be_bytes(),
        );
        h.put(72, &self.bitpix.to_le_bytes(), &self.bitpix.to_be_bytes());
        h.floats(76, &self.pixdim);
        h.floats(108, &[self.vox_offset, self.scl[0], self.scl[1]]);
        for (i, c) in self.codes.iter().enumerate() {
            h.put(252 + 2 * i, &c.to_le_bytes(), &c.to_be_bytes());
        }
        h.floats(256, &self.quatern);
        for (i, row) in self.srow.iter().enumerate() {
            h.floats(280 + 16 * i, row);
        }
        h.bytes[344..348].copy_from_slice(&self.magic);
        h.bytes
    }

    /// A single `.nii` file: the header, 4 zero extension bytes, zero padding up to
    /// `vox_offset` (when it is a whole number past them), then `data`.
    pub fn file(&self, data: &[u8]) -> Vec<u8> {
        let mut bytes = self.header();
        bytes.extend_from_slice(&[0; 4]);
        let offset = self.vox_offset;
        if offset.is_finite() && offset.fract() == 0.0 && offset > 352.0 && offset < 1e8 {
            bytes.resize(offset as usize, 0);
        }
        bytes.extend_from_slice(data);
        bytes
    }

    /// `values` as `int16` voxel bytes in this header's byte order.
    pub fn int16_data(&self, values: &[i16]) -> Vec<u8> {
        values
            .iter()
            .flat_map(|v| {
                if self.big_endian {
                    v.to_be_bytes()
                } else {
                    v.to_le_bytes()
                }
            })
            .collect()
    }
}

/// A header being written in one byte order.
struct Header {
    bytes: Vec<u8>,
    big_endian: bool,
}

impl Header {
    fn put(&mut self, at: usize, little: &[u8], big: &[u8]) {
        let b = if self.big_endian { big } else { little };
        self.bytes[at..at + b.len()].copy_from_slice(b);
    }

    fn floats(&mut self, at: usize, values: &[f32]) {
        for (i, v) in values.iter().enumerate() {
            self.put(at + 4 * i, &v.to_le_bytes(), &v.to_be_bytes());
        }
    }
}

/// `bytes` as one gzip member (what a `.nii.gz` holds).
pub fn gzip(bytes: &[u8]) -> Vec<u8> {
    let mut e = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
    e.write_all(bytes).expect("writing to memory");
    e.finish().expect("writing to memory")
}
