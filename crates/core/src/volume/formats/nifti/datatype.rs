//! The NIfTI-1 `datatype` codes read here — the scalar ones — and how their bytes become
//! `f32` values. Colour (RGB24, RGBA32), complex and 128-bit types are refused by name,
//! never reinterpreted as another type of the same size.

use super::super::{ByteOrder, VoxelType};

/// A scalar voxel type of NIfTI-1.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Datatype {
    Uint8,
    Int8,
    Uint16,
    Int16,
    Uint32,
    Int32,
    Uint64,
    Int64,
    Float32,
    Float64,
}

/// Every type read, in the order the supported list is shown.
const SUPPORTED: [Datatype; 10] = [
    Datatype::Uint8,
    Datatype::Int8,
    Datatype::Uint16,
    Datatype::Int16,
    Datatype::Uint32,
    Datatype::Int32,
    Datatype::Uint64,
    Datatype::Int64,
    Datatype::Float32,
    Datatype::Float64,
];

impl Datatype {
    /// The type with NIfTI-1 code `code`, or the reason it is not read.
    pub(super) fn from_code(code: i16) -> Result<Datatype, String> {
        if let Some(t) = SUPPORTED.into_iter().find(|t| t.code() == code) {
            return Ok(t);
        }
        let what = match unsupported_name(code) {
            Some(name) => format!("datatype {code} ({name}) is not supported"),
            None => format!("datatype {code} is not a NIfTI-1 datatype code and not supported"),
        };
        Err(format!(
            "{what}: only scalar voxels are read; expected one of {}",
            supported_list()
        ))
    }

    /// The NIfTI-1 code (`DT_UINT8` = 2, …).
    pub(super) fn code(self) -> i16 {
        match self {
            Datatype::Uint8 => 2,
            Datatype::Int8 => 256,
            Datatype::Uint16 => 512,
            Datatype::Int16 => 4,
            Datatype::Uint32 => 768,
            Datatype::Int32 => 8,
            Datatype::Uint64 => 1280,
            Datatype::Int64 => 1024,
            Datatype::Float32 => 16,
            Datatype::Float64 => 64,
        }
    }

    /// The name nifti1.h gives it, in lower case.
    pub(super) fn name(self) -> &'static str {
        match self {
            Datatype::Uint8 => "uint8",
            Datatype::Int8 => "int8",
            Datatype::Uint16 => "uint16",
            Datatype::Int16 => "int16",
            Datatype::Uint32 => "uint32",
            Datatype::Int32 => "int32",
            Datatype::Uint64 => "uint64",
            Datatype::Int64 => "int64",
            Datatype::Float32 => "float32",
            Datatype::Float64 => "float64",
        }
    }

    /// Bytes per voxel.
    pub(super) fn bytes(self) -> usize {
        match self {
            Datatype::Uint8 | Datatype::Int8 => 1,
            Datatype::Uint16 | Datatype::Int16 => 2,
            Datatype::Uint32 | Datatype::Int32 | Datatype::Float32 => 4,
            Datatype::Uint64 | Datatype::Int64 | Datatype::Float64 => 8,
        }
    }

    /// The stored type as the volume records it (the wider types are converted to `f32`).
    pub(super) fn voxel_type(self) -> VoxelType {
        match self {
            Datatype::Uint8 => VoxelType::U8,
            Datatype::Int8 => VoxelType::I8,
            Datatype::Uint16 => VoxelType::U16,
            Datatype::Int16 => VoxelType::I16,
            _ => VoxelType::F32,
        }
    }

    /// Appends the values of `bytes` (whole voxels) to `out`.
    pub(super) fn decode(self, bytes: &[u8], order: ByteOrder, out: &mut Vec<f32>) {
        macro_rules! each {
            ($t:ty) => {
                out.extend(bytes.chunks_exact(size_of::<$t>()).map(|c| {
                    let a = c.try_into().expect("chunks_exact yields whole voxels");
                    (match order {
                        ByteOrder::Little => <$t>::from_le_bytes(a),
                        ByteOrder::Big => <$t>::from_be_bytes(a),
                    }) as f32
                }))
            };
        }
        match self {
            Datatype::Uint8 => each!(u8),
            Datatype::Int8 => each!(i8),
            Datatype::Uint16 => each!(u16),
            Datatype::Int16 => each!(i16),
            Datatype::Uint32 => each!(u32),
            Datatype::Int32 => each!(i32),
            Datatype::Uint64 => each!(u64),
            Datatype::Int64 => each!(i64),
            Datatype::Float32 => each!(f32),
            Datatype::Float64 => each!(f64),
        }
    }
}

impl std::fmt::Display for Datatype {
    /// `datatype 4 (int16)`.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "datatype {} ({})", self.code(), self.name())
    }
}

/// The nifti1.h names of the codes that exist but are not read.
fn unsupported_name(code: i16) -> Option<&'static str> {
    Some(match code {
        0 => "unknown",
        1 => "binary",
        32 => "complex64",
        128 => "RGB24",
        1536 => "float128",
        1792 => "complex128",
        2048 => "complex256",
        2304 => "RGBA32",
        _ => return None,
    })
}

/// `uint8 (2), int8 (256), …`.
fn supported_list() -> String {
    SUPPORTED
        .iter()
        .map(|t| format!("{} ({})", t.name(), t.code()))
        .collect::<Vec<_>>()
        .join(", ")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn codes_round_trip_and_decode_both_byte_orders() {
        for t in SUPPORTED {
            assert_eq!(Datatype::from_code(t.code()), Ok(t));
        }
        let mut out = Vec::new();
        Datatype::Int16.decode(&[0xff, 0xfe, 0x01, 0x00], ByteOrder::Big, &mut out);
        Datatype::Float64.decode(&2.5f64.to_le_bytes(), ByteOrder::Little, &mut out);
        Datatype::Uint32.decode(&[0, 0, 1, 0], ByteOrder::Little, &mut out);
        assert_eq!(out, vec![-2.0, 256.0, 2.5, 65536.0]);
    }
}
