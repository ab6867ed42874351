//! Headerless RAW voxel files (thesis §2.1, §7.2.1): x fastest,
//! `index = x + nx·(y + ny·z)`.

use std::io::Read;
use std::path::Path;

use serde::{Deserialize, Serialize};

use super::{LoadedVoxels, check_dims};
use crate::error::{Error, Result};

/// The stored type of one voxel.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum VoxelType {
    /// Unsigned 8-bit.
    U8,
    /// Signed 8-bit.
    I8,
    /// Unsigned 16-bit.
    U16,
    /// Signed 16-bit (e.g. CT in Hounsfield units).
    I16,
    /// 32-bit IEEE float.
    F32,
}

impl VoxelType {
    /// Bytes per voxel.
    pub fn size(self) -> usize {
        match self {
            VoxelType::U8 | VoxelType::I8 => 1,
            VoxelType::U16 | VoxelType::I16 => 2,
            VoxelType::F32 => 4,
        }
    }

    /// The value range used by [`crate::Normalization::TypeRange`] (thesis: divide by
    /// `2^bits − 1`). Floats are assumed to be already in `[0, 1]`.
    pub fn range(self) -> (f64, f64) {
        match self {
            VoxelType::U8 => (0.0, 255.0),
            VoxelType::I8 => (-128.0, 127.0),
            VoxelType::U16 => (0.0, 65535.0),
            VoxelType::I16 => (-32768.0, 32767.0),
            VoxelType::F32 => (0.0, 1.0),
        }
    }

    /// Whether the type stores negative values (CT in Hounsfield units, floats).
    pub fn is_signed(self) -> bool {
        matches!(self, VoxelType::I8 | VoxelType::I16 | VoxelType::F32)
    }

    /// Short name as used in scene files (`u8`, `u16`, `i16`, …).
    pub fn name(self) -> &'static str {
        match self {
            VoxelType::U8 => "u8",
            VoxelType::I8 => "i8",
            VoxelType::U16 => "u16",
            VoxelType::I16 => "i16",
            VoxelType::F32 => "f32",
        }
    }
}

impl std::fmt::Display for VoxelType {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// Byte order of multi-byte voxels.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ByteOrder {
    /// Least significant byte first (all files in `../shared/data`).
    #[default]
    Little,
    /// Most significant byte first.
    Big,
}

/// Everything needed to read a headerless RAW file.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct RawLayout {
    /// Voxel counts along x, y, z.
    pub dims: [usize; 3],
    /// Stored type.
    pub voxel: VoxelType,
    /// Byte order.
    pub byte_order: ByteOrder,
    /// Bytes to skip before the first voxel.
    pub header_bytes: u64,
}

impl RawLayout {
    /// Bytes of voxel data the layout describes.
    pub fn data_bytes(&self) -> u64 {
        self.dims.iter().map(|&n| n as u64).product::<u64>() * self.voxel.size() as u64
    }
}

/// Decodes voxel bytes to `f32` values.
pub fn decode(bytes: &[u8], voxel: VoxelType, order: ByteOrder) -> Vec<f32> {
    let big = order == ByteOrder::Big;
    match voxel {
        VoxelType::U8 => bytes.iter().map(|&b| b as f32).collect(),
        VoxelType::I8 => bytes.iter().map(|&b| b as i8 as f32).collect(),
        VoxelType::U16 => bytes
            .chunks_exact(2)
            .map(|c| {
                let a = [c[0], c[1]];
                (if big {
                    u16::from_be_bytes(a)
                } else {
                    u16::from_le_bytes(a)
                }) as f32
            })
            .collect(),
        VoxelType::I16 => bytes
            .chunks_exact(2)
            .map(|c| {
                let a = [c[0], c[1]];
                (if big {
                    i16::from_be_bytes(a)
                } else {
                    i16::from_le_bytes(a)
                }) as f32
            })
            .collect(),
        VoxelType::F32 => bytes
            .chunks_exact(4)
            .map(|c| {
                let a = [c[0], c[1], c[2], c[3]];
                if big {
                    f32::from_be_bytes(a)
                } else {
                    f32::from_le_bytes(a)
                }
            })
            .collect(),
    }
}

/// Encodes `f32` values (already in the type's range) back to bytes; the inverse of
/// [`decode`], used by the header writers and tests.
pub fn encode(values: &[f32], voxel: VoxelType, order: ByteOrder) -> Vec<u8> {
    let big = order == ByteOrder::Big;
    let mut out = Vec::with_capacity(values.len() * voxel.size());
    for &v in values {
        match voxel {
            VoxelType::U8 => out.push(v.round().clamp(0.0, 255.0) as u8),
            VoxelType::I8 => out.push(v.round().clamp(-128.0, 127.0) as i8 as u8),
            VoxelType::U16 => {
                let x = v.round().clamp(0.0, 65535.0) as u16;
                out.extend_from_slice(&if big {
                    x.to_be_bytes()
                } else {
                    x.to_le_bytes()
                });
            }
            VoxelType::I16 => {
                let x = v.round().clamp(-32768.0, 32767.0) as i16;
                out.extend_from_slice(&if big {
                    x.to_be_bytes()
                } else {
                    x.to_le_bytes()
                });
            }
            VoxelType::F32 => {
                out.extend_from_slice(&if big {
                    v.to_be_bytes()
                } else {
                    v.to_le_bytes()
                });
            }
        }
    }
    out
}

/// Reads a RAW file. The file size is checked against `dims × type` before any voxel is
/// read; a mismatch names both numbers.
pub fn read(path: &Path, layout: &RawLayout) -> Result<LoadedVoxels> {
    check_dims(path, layout.dims)?;
    let meta = std::fs::metadata(path).map_err(|e| Error::io(path, e))?;
    let expected = layout
        .data_bytes()
        .checked_add(layout.header_bytes)
        .ok_or_else(|| {
            Error::format(
                path,
                format!(
                    "header_bytes {} + dims {:?} × {}: the size overflows",
                    layout.header_bytes, layout.dims, layout.voxel
                ),
            )
        })?;
    if meta.len() != expected {
        return Err(Error::format(
            path,
            format!(
                "file has {} bytes but dims {:?} × {} ({} byte{}){} need {} bytes",
                meta.len(),
                layout.dims,
                layout.voxel,
                layout.voxel.size(),
                if layout.voxel.size() == 1 { "" } else { "s" },
                if layout.header_bytes > 0 {
                    format!(" + {} header bytes", layout.header_bytes)
                } else {
                    String::new()
                },
                expected
            ),
        ));
    }
    let mut file = std::fs::File::open(path).map_err(|e| Error::io(path, e))?;
    let mut bytes = Vec::with_capacity(expected as usize);
    file.read_to_end(&mut bytes)
        .map_err(|e| Error::io(path, e))?;
    if bytes.len() as u64 != expected {
        return Err(Error::format(
            path,
            format!(
                "read {} bytes, expected {expected} (file changed while reading?)",
                bytes.len()
            ),
        ));
    }
    let values = decode(
        &bytes[layout.header_bytes as usize..],
        layout.voxel,
        layout.byte_order,
    );
    Ok(LoadedVoxels {
        dims: layout.dims,
        values,
        voxel_type: layout.voxel,
        spacing: None,
        data_path: path.to_path_buf(),
        format: "raw",
        acquisition: None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn decode_encode_round_trip_all_types_and_orders() {
        let samples: &[(VoxelType, Vec<f32>)] = &[
            (VoxelType::U8, vec![0.0, 1.0, 255.0]),
            (VoxelType::I8, vec![-128.0, 0.0, 127.0]),
            (VoxelType::U16, vec![0.0, 258.0, 65535.0]),
            (VoxelType::I16, vec![-1024.0, 0.0, 3071.0]),
            (VoxelType::F32, vec![-0.5, 0.25, 1.0e6]),
        ];
        for (t, values) in samples {
            for order in [ByteOrder::Little, ByteOrder::Big] {
                let bytes = encode(values, *t, order);
                assert_eq!(bytes.len(), values.len() * t.size());
                assert_eq!(&decode(&bytes, *t, order), values, "{t} {order:?}");
            }
        }
    }

    #[test]
    fn byte_order_matters_for_16_bit() {
        let bytes = [0x01, 0x02];
        assert_eq!(
            decode(&bytes, VoxelType::U16, ByteOrder::Little),
            vec![513.0]
        );
        assert_eq!(decode(&bytes, VoxelType::U16, ByteOrder::Big), vec![258.0]);
        assert_eq!(
            decode(&[0x00, 0xFC], VoxelType::I16, ByteOrder::Little),
            vec![-1024.0]
        );
    }

    #[test]
    fn size_mismatch_names_both_numbers() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("v.raw");
        std::fs::write(&path, vec![0u8; 100]).unwrap();
        let layout = RawLayout {
            dims: [4, 4, 4],
            voxel: VoxelType::U16,
            byte_order: ByteOrder::Little,
            header_bytes: 0,
        };
        let err = read(&path, &layout).unwrap_err().to_string();
        assert!(
            err.contains("100 bytes") && err.contains("128 bytes"),
            "{err}"
        );
        assert!(err.contains("v.raw"), "{err}");
    }
}
