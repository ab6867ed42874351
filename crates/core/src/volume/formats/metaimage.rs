//! MetaImage volume files (ITK/VTK): a `.mhd` text header naming a separate data file, or a
//! `.mha` file whose voxels follow the header line `ElementDataFile = LOCAL`.
//!
//! Supported: 3-D scalar data of type `MET_UCHAR`, `MET_CHAR`, `MET_USHORT`, `MET_SHORT` or
//! `MET_FLOAT`, either byte order, raw or zlib-compressed (`CompressedData = True`). Multi-file
//! data (`LIST`, file patterns), ASCII data and multi-channel voxels are refused with an error
//! naming the field. Header parsing and the data-size checks are shared with [`super::nrrd`].

use std::io::{BufReader, Write};
use std::path::Path;

use flate2::Compression;
use flate2::write::ZlibEncoder;

use super::nrrd::{
    Codec, Field, Fields, Payload, check_single_data_file, check_write_args, data_file_name,
    missing, next_header_line, normalize_key, parse_sizes, positive_spacing, quoted, read_payload,
};
use super::raw::{ByteOrder, VoxelType, decode, encode};
use super::{LoadedVoxels, check_dims};
use crate::error::{Error, Result};
use crate::util::{write_atomic, write_atomic_with};

/// Every `ElementType` we accept, for error messages.
const SUPPORTED_TYPES: &str =
    "MET_UCHAR (u8), MET_CHAR (i8), MET_USHORT (u16), MET_SHORT (i16) or MET_FLOAT (f32)";

/// Reads a MetaImage volume: a `.mhd` header with its data file, or a `.mha` (or any header
/// with `ElementDataFile = LOCAL`) holding the voxels after the header.
///
/// Keys are matched without regard to case. The voxel count is validated with [`check_dims`]
/// before any voxel is read, and zlib data is decompressed through a bounded reader.
pub fn read(path: &Path) -> Result<LoadedVoxels> {
    let (fields, data_field, consumed) = read_fields(path)?;
    let Header {
        dims,
        voxel,
        type_name,
        order,
        compressed,
        skip,
        from_end,
        spacing,
    } = Header::parse(path, &fields)?;
    let local = data_field.value.eq_ignore_ascii_case("LOCAL");
    let (data_path, base) = if local {
        (path.to_path_buf(), consumed)
    } else {
        let folder = path.parent().unwrap_or(Path::new(""));
        let named = Path::new(&data_field.value);
        (
            crate::util::confined(folder, named, "the header's folder")?,
            0,
        )
    };

    let count = check_dims(path, dims)?;
    let expected = count
        .checked_mul(voxel.size())
        .ok_or_else(|| Error::format(path, format!("DimSize {dims:?}: the data size overflows")))?;
    let offset = base
        .checked_add(skip)
        .ok_or_else(|| Error::format(path, format!("`HeaderSize` {skip} is too large")))?;
    let payload = Payload {
        path: &data_path,
        header: path,
        offset,
        from_end,
        codec: if compressed { Codec::Zlib } else { Codec::Raw },
        skip_decompressed: 0,
        expected,
        need: format!(
            "DimSize {dims:?} × {} ({} byte{} each)",
            quoted(&type_name),
            voxel.size(),
            if voxel.size() == 1 { "" } else { "s" }
        ),
    };
    let bytes = read_payload(&payload)?;
    Ok(LoadedVoxels {
        dims,
        values: decode(&bytes, voxel, order),
        voxel_type: voxel,
        spacing,
        data_path,
        format: "metaimage",
        acquisition: None,
    })
}

/// Reads the header's `Key = Value` lines up to `ElementDataFile` (the last one by
/// definition); returns the other fields, that field, and the bytes consumed.
fn read_fields(path: &Path) -> Result<(Fields, Field, u64)> {
    let (file, _) = crate::util::open_regular(path, "MetaImage header (.mhd or .mha)")?;
    let mut reader = BufReader::new(file);
    let mut consumed = 0u64;
    let mut fields = Fields::default();
    let mut data_field = None;
    let mut line_no = 0usize;
    while let Some(line) = next_header_line(&mut reader, path, &mut consumed)? {
        line_no += 1;
        let text = line.trim();
        if text.is_empty() {
            continue;
        }
        let Some((name, value)) = text.split_once('=') else {
            return Err(Error::format(
                path,
                format!(
                    "line {line_no} {}: expected `Key = Value` (is this a MetaImage header?)",
                    // A first line that is not `Key = Value` may be any file: show its first
                    // bytes only, never its content.
                    if line_no == 1 {
                        format!(
                            "starts `{}`",
                            crate::util::escaped_prefix(text.as_bytes(), 8)
                        )
                    } else {
                        quoted(text)
                    }
                ),
            ));
        };
        let field = Field {
            name: name.trim().to_string(),
            value: value.trim().to_string(),
            line: line_no,
        };
        let key = normalize_key(&field.name);
        if key == "elementdatafile" {
            // The last header line by definition; with LOCAL the voxels start right after it.
            check_single_data_file(path, &field)?;
            data_field = Some(field);
            break;
        }
        fields.insert(path, key, field)?;
    }
    drop(reader);
    let data_field = data_field.ok_or_else(|| {
        missing(
            path,
            "ElementDataFile",
            "`LOCAL` or a data file name, on the last line of the header",
        )
    })?;
    Ok((fields, data_field, consumed))
}

/// The validated header fields we use.
struct Header {
    dims: [usize; 3],
    voxel: VoxelType,
    /// `ElementType` as written, for messages.
    type_name: String,
    order: ByteOrder,
    compressed: bool,
    /// Bytes to skip in the data file.
    skip: u64,
    /// `HeaderSize = -1`: the voxels are the data file's last bytes.
    from_end: bool,
    spacing: Option<[f32; 3]>,
}

/// `HeaderSize`: bytes to skip in the data file, or -1 (uncompressed only) for data at
/// its end.
fn parse_header_size(path: &Path, fields: &Fields, compressed: bool) -> Result<(u64, bool)> {
    // HeaderSize: bytes to skip in the data file; -1 means the voxels are its last bytes,
    // which cannot be located in a compressed stream.
    Ok(match fields.get("headersize") {
        None => (0, false),
        Some(f) => match f.value.parse::<i64>() {
            Ok(-1) if !compressed => (0, true),
            Ok(n) if n >= 0 => (n.unsigned_abs(), false),
            _ => {
                return Err(f.invalid(
                    path,
                    if compressed {
                        "a whole number >= 0 (-1 is not supported with `CompressedData = True`)"
                    } else {
                        "a whole number >= 0, or -1 for data at the end of the file"
                    },
                ));
            }
        },
    })
}

impl Header {
    /// The header's fields checked and interpreted: the grid, the voxel type and layout,
    /// compression, where the data start and the spacing.
    fn parse(path: &Path, fields: &Fields) -> Result<Header> {
        let dims = parse_dims(path, fields)?;
        let (voxel, type_name) = parse_element(path, fields)?;
        let order = parse_byte_order(path, fields)?;
        let compressed = match fields.get("compresseddata") {
            Some(f) => parse_bool(path, f)?,
            None => false,
        };

        let (skip, from_end) = parse_header_size(path, fields, compressed)?;

        // ElementSpacing is the distance between voxel centres, ElementSize their extent; prefer
        // the spacing when a header gives both.
        let spacing = match fields
            .get("elementspacing")
            .or_else(|| fields.get("elementsize"))
        {
            Some(f) => Some(parse_spacing(path, f)?),
            None => None,
        };
        Ok(Header {
            dims,
            voxel,
            type_name,
            order,
            compressed,
            skip,
            from_end,
            spacing,
        })
    }
}

/// `NDims = 3` and the three `DimSize`s.
fn parse_dims(path: &Path, fields: &Fields) -> Result<[usize; 3]> {
    let ndims = fields
        .get("ndims")
        .ok_or_else(|| missing(path, "NDims", "3"))?;
    if ndims.value.parse::<usize>() != Ok(3) {
        return Err(ndims.invalid(path, "3 (only 3-D volumes are supported)"));
    }

    let dim_size = fields
        .get("dimsize")
        .ok_or_else(|| missing(path, "DimSize", "3 whole numbers >= 1 (one per axis)"))?;
    let sizes = parse_sizes(path, dim_size, 3)?;
    match sizes.as_slice() {
        [x, y, z] => Ok([*x, *y, *z]),
        _ => Err(dim_size.invalid(path, "3 whole numbers >= 1 (one per axis)")),
    }
}

/// The voxel type (`ElementType`, as written too), one channel, binary data.
fn parse_element(path: &Path, fields: &Fields) -> Result<(VoxelType, String)> {
    let type_f = fields
        .get("elementtype")
        .ok_or_else(|| missing(path, "ElementType", SUPPORTED_TYPES))?;
    let voxel = match type_f.value.to_ascii_uppercase().as_str() {
        "MET_UCHAR" => VoxelType::U8,
        "MET_CHAR" => VoxelType::I8,
        "MET_USHORT" => VoxelType::U16,
        "MET_SHORT" => VoxelType::I16,
        "MET_FLOAT" => VoxelType::F32,
        _ => {
            return Err(type_f.invalid(path, format!("a supported type: {SUPPORTED_TYPES}")));
        }
    };

    if let Some(f) = fields.get("elementnumberofchannels")
        && f.value.parse::<u64>() != Ok(1)
    {
        return Err(f.invalid(path, "1 (only scalar volumes are supported)"));
    }
    if let Some(f) = fields.get("binarydata")
        && !parse_bool(path, f)?
    {
        return Err(f.invalid(path, "True (ASCII voxel data is not supported)"));
    }
    Ok((voxel, type_f.value.clone()))
}

/// The byte order (`BinaryDataByteOrderMSB` or `ElementByteOrderMSB`; little endian
/// without either).
fn parse_byte_order(path: &Path, fields: &Fields) -> Result<ByteOrder> {
    // ITK writes either name for the byte order; the first is the current one.
    let msb = match fields
        .get("binarydatabyteordermsb")
        .or_else(|| fields.get("elementbyteordermsb"))
    {
        Some(f) => parse_bool(path, f)?,
        None => false,
    };
    Ok(if msb {
        ByteOrder::Big
    } else {
        ByteOrder::Little
    })
}

/// Writes a MetaImage volume, little endian, with `ElementSpacing`.
///
/// `values` are raw values in the range of `voxel` (rounded and clamped to the type). A
/// path ending in `.mha` gets the voxels after the header (`ElementDataFile = LOCAL`); any
/// other path (conventionally `.mhd`) gets a data file beside it with the same stem and
/// extension `.raw`, or `.zraw` when `compressed` (zlib). Files are written atomically, the
/// data file before the header that points to it.
pub fn write(
    path: &Path,
    dims: [usize; 3],
    values: &[f32],
    voxel: VoxelType,
    spacing: [f32; 3],
    compressed: bool,
) -> Result<()> {
    check_write_args(path, dims, values, spacing)?;
    let raw = encode(values, voxel, ByteOrder::Little);
    let data = if compressed {
        // Compressed up front: the header records the compressed size, as ITK does.
        let mut encoder = ZlibEncoder::new(Vec::new(), Compression::default());
        encoder.write_all(&raw).map_err(|e| Error::io(path, e))?;
        encoder.finish().map_err(|e| Error::io(path, e))?
    } else {
        raw
    };
    let type_name = match voxel {
        VoxelType::U8 => "MET_UCHAR",
        VoxelType::I8 => "MET_CHAR",
        VoxelType::U16 => "MET_USHORT",
        VoxelType::I16 => "MET_SHORT",
        VoxelType::F32 => "MET_FLOAT",
    };
    let local = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("mha"));
    let data_path = if local {
        None
    } else {
        Some(path.with_extension(if compressed { "zraw" } else { "raw" }))
    };
    let data_name = match &data_path {
        Some(data_path) => data_file_name(path, data_path)?,
        None => "LOCAL".to_string(),
    };
    let mut header = String::from(
        "ObjectType = Image\n\
         NDims = 3\n\
         BinaryData = True\n\
         BinaryDataByteOrderMSB = False\n",
    );
    if compressed {
        header.push_str(&format!(
            "CompressedData = True\nCompressedDataSize = {}\n",
            data.len()
        ));
    } else {
        header.push_str("CompressedData = False\n");
    }
    header.push_str(&format!(
        "TransformMatrix = 1 0 0 0 1 0 0 0 1\n\
         Offset = 0 0 0\n\
         DimSize = {} {} {}\n\
         ElementSpacing = {} {} {}\n\
         ElementType = {type_name}\n\
         ElementDataFile = {data_name}\n",
        dims[0], dims[1], dims[2], spacing[0], spacing[1], spacing[2],
    ));
    match &data_path {
        Some(data_path) => {
            write_atomic(data_path, &data)?;
            write_atomic(path, header.as_bytes())
        }
        None => write_atomic_with(path, |w| {
            w.write_all(header.as_bytes())?;
            w.write_all(&data)
        }),
    }
}

/// `True`/`False` (any case; `1`/`0` too, as ITK only looks at the first character).
fn parse_bool(path: &Path, field: &Field) -> Result<bool> {
    match field.value.to_ascii_lowercase().as_str() {
        "true" | "1" => Ok(true),
        "false" | "0" => Ok(false),
        _ => Err(field.invalid(path, "`True` or `False`")),
    }
}

/// Three non-zero finite numbers; their magnitudes are the spacing.
fn parse_spacing(path: &Path, field: &Field) -> Result<[f32; 3]> {
    let expected = "3 finite numbers > 0 (one per axis)";
    let values = field
        .value
        .split_whitespace()
        .map(|t| t.parse::<f64>().ok().and_then(positive_spacing))
        .collect::<Option<Vec<_>>>()
        .ok_or_else(|| field.invalid(path, expected))?;
    match values.as_slice() {
        [x, y, z] => Ok([*x, *y, *z]),
        _ => Err(field.invalid(path, expected)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample(voxel: VoxelType, n: usize) -> Vec<f32> {
        (0..n)
            .map(|i| {
                let i = i as f32;
                match voxel {
                    VoxelType::U8 => (i * 37.0) % 256.0,
                    VoxelType::I8 => (i * 37.0) % 256.0 - 128.0,
                    VoxelType::U16 => (i * 1103.0) % 65536.0,
                    VoxelType::I16 => (i * 1103.0) % 65536.0 - 32768.0,
                    VoxelType::F32 => i * 0.25 - 3.0,
                }
            })
            .collect()
    }

    fn zlib(bytes: &[u8]) -> Vec<u8> {
        let mut encoder = ZlibEncoder::new(Vec::new(), Compression::default());
        encoder.write_all(bytes).unwrap();
        encoder.finish().unwrap()
    }

    fn err_text(path: &Path) -> String {
        read(path).unwrap_err().to_string()
    }

    #[test]
    fn round_trips_mha_mhd_raw_and_compressed() {
        let dir = tempfile::tempdir().unwrap();
        let dims = [5, 4, 3];
        let spacing = [0.25, 1.5, 3.0];
        for voxel in [
            VoxelType::U8,
            VoxelType::U16,
            VoxelType::I16,
            VoxelType::F32,
        ] {
            let values = sample(voxel, 60);
            for (ext, compressed) in [("mha", false), ("mha", true), ("mhd", false), ("mhd", true)]
            {
                let path = dir.path().join(format!("v_{voxel}_{compressed}.{ext}"));
                write(&path, dims, &values, voxel, spacing, compressed).unwrap();
                let loaded = read(&path).unwrap();
                let case = format!("{voxel} {ext} compressed={compressed}");
                assert_eq!(loaded.dims, dims, "{case}");
                assert_eq!(loaded.values, values, "{case}");
                assert_eq!(loaded.voxel_type, voxel, "{case}");
                assert_eq!(loaded.spacing, Some(spacing), "{case}");
                assert_eq!(loaded.format, "metaimage");
                let data_path = match (ext, compressed) {
                    ("mhd", false) => path.with_extension("raw"),
                    ("mhd", true) => path.with_extension("zraw"),
                    _ => path.clone(),
                };
                assert_eq!(loaded.data_path, data_path, "{case}");
            }
        }
    }

    #[test]
    fn element_size_only_and_big_endian() {
        let dir = tempfile::tempdir().unwrap();
        let data = encode(&[1.0, 258.0, 65535.0, 0.0], VoxelType::U16, ByteOrder::Big);
        std::fs::write(dir.path().join("e.raw"), &data).unwrap();
        let path = dir.path().join("e.mhd");
        std::fs::write(
            &path,
            "ObjectType = Image\r\nndims = 3\r\nDimSize = 1 2 2\r\nElementSize = 0.5 0.5 2\r\n\
             ElementByteOrderMSB = True\r\nElementType = MET_USHORT\r\nElementDataFile = e.raw\r\n",
        )
        .unwrap();
        let loaded = read(&path).unwrap();
        assert_eq!(loaded.dims, [1, 2, 2]);
        assert_eq!(loaded.spacing, Some([0.5, 0.5, 2.0]));
        assert_eq!(loaded.values, vec![1.0, 258.0, 65535.0, 0.0]);
        assert_eq!(loaded.data_path, dir.path().join("e.raw"));

        // Both given: ElementSpacing wins.
        std::fs::write(
            &path,
            "NDims = 3\nDimSize = 1 2 2\nElementSize = 9 9 9\nElementSpacing = 1 2 3\n\
             BinaryDataByteOrderMSB = true\nElementType = MET_USHORT\nElementDataFile = e.raw\n",
        )
        .unwrap();
        assert_eq!(read(&path).unwrap().spacing, Some([1.0, 2.0, 3.0]));

        // Neither: no spacing.
        std::fs::write(
            &path,
            "NDims = 3\nDimSize = 1 2 2\nBinaryDataByteOrderMSB = True\nElementType = MET_USHORT\n\
             ElementDataFile = e.raw\n",
        )
        .unwrap();
        assert_eq!(read(&path).unwrap().spacing, None);
    }

    #[test]
    fn header_size_skips_and_end_of_file() {
        let dir = tempfile::tempdir().unwrap();
        let values = sample(VoxelType::I16, 8);
        let data = encode(&values, VoxelType::I16, ByteOrder::Little);
        std::fs::write(dir.path().join("h.raw"), [&[0xAAu8; 6][..], &data].concat()).unwrap();
        for header_size in ["6", "-1"] {
            let path = dir.path().join("h.mhd");
            std::fs::write(
                &path,
                format!(
                    "NDims = 3\nDimSize = 2 2 2\nElementType = MET_SHORT\nHeaderSize = {header_size}\n\
                     ElementDataFile = h.raw\n"
                ),
            )
            .unwrap();
            assert_eq!(
                read(&path).unwrap().values,
                values,
                "HeaderSize {header_size}"
            );
        }
        // LOCAL data with trailing bytes and -1: the voxels are the file's last bytes.
        let path = dir.path().join("l.mha");
        let header = "NDims = 3\nDimSize = 2 2 2\nElementType = MET_SHORT\nHeaderSize = -1\n\
                      ElementDataFile = LOCAL\n";
        std::fs::write(&path, [header.as_bytes(), &[1, 2, 3], &data].concat()).unwrap();
        assert_eq!(read(&path).unwrap().values, values);
    }

    #[test]
    fn bad_inputs_name_the_field() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("bad.mha");
        let base = "NDims = 3\nDimSize = 2 2 2\nElementType = MET_UCHAR\n";
        let cases: Vec<(String, &str)> = vec![
            (
                "NDims = 3\nElementType = MET_UCHAR\nElementDataFile = LOCAL\n".into(),
                "missing field `DimSize`",
            ),
            (
                "NDims = 3\nDimSize = 2 2 2\nElementType = MET_DOUBLE\nElementDataFile = LOCAL\n"
                    .into(),
                "MET_DOUBLE",
            ),
            (
                "NDims = 2\nDimSize = 2 2\nElementType = MET_UCHAR\nElementDataFile = LOCAL\n"
                    .into(),
                "NDims",
            ),
            (
                format!("{base}ElementDataFile = LIST\nslice0.raw\n"),
                "LIST",
            ),
            (
                format!("{base}ElementDataFile = slice%03d.raw 1 4 1\n"),
                "pattern",
            ),
            (
                format!("{base}ElementNumberOfChannels = 3\nElementDataFile = LOCAL\n"),
                "ElementNumberOfChannels",
            ),
            (
                format!("{base}BinaryData = False\nElementDataFile = LOCAL\n"),
                "ASCII",
            ),
            (
                format!("{base}CompressedData = maybe\nElementDataFile = LOCAL\n"),
                "CompressedData",
            ),
            (
                format!("{base}CompressedData = True\nHeaderSize = -1\nElementDataFile = LOCAL\n"),
                "HeaderSize",
            ),
            (
                format!("{base}HeaderSize = -2\nElementDataFile = LOCAL\n"),
                "HeaderSize",
            ),
            (
                format!("{base}ElementSpacing = 1 1\nElementDataFile = LOCAL\n"),
                "ElementSpacing",
            ),
            (
                format!("{base}ElementSize = 1 nan 1\nElementDataFile = LOCAL\n"),
                "ElementSize",
            ),
            (base.to_string(), "missing field `ElementDataFile`"),
            ("\u{1}\u{2} binary\n".into(), "Key = Value"),
        ];
        for (text, needle) in &cases {
            // Every case fails in the header, before any voxel is needed.
            std::fs::write(&path, text).unwrap();
            let err = err_text(&path);
            assert!(
                err.contains(needle) && err.contains("bad.mha"),
                "{needle}: {err}"
            );
        }
        let type_err = {
            std::fs::write(&path, &cases[1].0).unwrap();
            err_text(&path)
        };
        assert!(
            type_err.contains("MET_UCHAR") && type_err.contains("MET_FLOAT"),
            "{type_err}"
        );
        let list_err = {
            std::fs::write(&path, &cases[3].0).unwrap();
            err_text(&path)
        };
        assert!(list_err.contains("not supported"), "{list_err}");
    }

    #[test]
    fn truncated_data_names_both_byte_counts() {
        let dir = tempfile::tempdir().unwrap();
        let header = "NDims = 3\nDimSize = 4 4 4\nElementType = MET_SHORT\n";

        let local = dir.path().join("short.mha");
        std::fs::write(
            &local,
            [header.as_bytes(), b"ElementDataFile = LOCAL\n", &[0u8; 100]].concat(),
        )
        .unwrap();
        let err = err_text(&local);
        assert!(
            err.contains("100 bytes") && err.contains("128 bytes"),
            "{err}"
        );
        assert!(err.contains("short.mha"), "{err}");

        let zipped = dir.path().join("short_z.mha");
        std::fs::write(
            &zipped,
            [
                header.as_bytes(),
                b"CompressedData = True\nElementDataFile = LOCAL\n",
                &zlib(&[0u8; 100]),
            ]
            .concat(),
        )
        .unwrap();
        let err = err_text(&zipped);
        assert!(
            err.contains("100 bytes") && err.contains("128 bytes"),
            "{err}"
        );

        std::fs::write(dir.path().join("s.raw"), [0u8; 100]).unwrap();
        let mhd = dir.path().join("s.mhd");
        std::fs::write(&mhd, format!("{header}ElementDataFile = s.raw\n")).unwrap();
        let err = err_text(&mhd);
        assert!(err.contains("s.raw") && err.contains("s.mhd"), "{err}");
        assert!(
            err.contains("100 bytes") && err.contains("128 bytes"),
            "{err}"
        );

        let missing = dir.path().join("gone.mhd");
        std::fs::write(&missing, format!("{header}ElementDataFile = gone.raw\n")).unwrap();
        assert!(err_text(&missing).contains("gone.raw"));
    }

    #[test]
    fn compressed_data_is_read_bounded() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("big.mha");
        let header = "NDims = 3\nDimSize = 2 2 2\nElementType = MET_UCHAR\n\
                      CompressedData = True\nElementDataFile = LOCAL\n";
        std::fs::write(&path, [header.as_bytes(), &zlib(&[3u8; 200_000])].concat()).unwrap();
        assert_eq!(read(&path).unwrap().values, vec![3.0; 8]);
    }

    #[test]
    fn writer_rejects_a_data_file_that_would_replace_the_header() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("v.raw");
        let err = write(&path, [1, 1, 1], &[0.0], VoxelType::U8, [1.0; 3], false)
            .unwrap_err()
            .to_string();
        assert!(err.contains("v.raw"), "{err}");
    }
}
