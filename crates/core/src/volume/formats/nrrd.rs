//! NRRD volume files (teem's "nearly raw raster data"): attached `.nrrd` files (header, blank
//! line, voxels) and detached `.nhdr` headers whose `data file` field names the voxel file.
//!
//! Only what a scalar CT/MRI volume needs is supported: 3-D data (or 4-D with a first axis of
//! size 1), 8/16-bit integer or `float` voxels, `raw` or `gzip` encoding. Anything else is
//! refused with an error naming the field, its value and what is supported.
//!
//! The helpers marked `pub(super)` (header lines, fields, payload reading) are shared with the
//! MetaImage reader, so both formats report problems with the same wording.

use std::fs::File;
use std::io::{BufRead, BufReader, Read, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

use flate2::Compression;
use flate2::read::{MultiGzDecoder, ZlibDecoder};
use flate2::write::GzEncoder;

use super::raw::{ByteOrder, VoxelType, decode, encode};
use super::{LoadedVoxels, check_dims};
use crate::error::{Error, Result};
use crate::util::{write_atomic, write_atomic_with};

/// Longest header we scan. A header is a few hundred bytes; the cap stops us from reading a
/// whole binary file while looking for the end of a header that is not there.
pub(super) const MAX_HEADER_BYTES: u64 = 1 << 20;

/// Every `type` spelling we accept, for error messages.
const SUPPORTED_TYPES: &str = "`uchar`/`unsigned char`/`uint8`/`uint8_t` (u8), \
     `signed char`/`int8`/`int8_t` (i8), \
     `ushort`/`unsigned short`/`unsigned short int`/`uint16`/`uint16_t` (u16), \
     `short`/`short int`/`signed short`/`signed short int`/`int16`/`int16_t` (i16) \
     or `float` (f32)";

/// Reads a NRRD volume: an attached `.nrrd` or a detached `.nhdr` with its data file.
///
/// The header is checked completely (magic, dimension, sizes, type, encoding, byte order,
/// skips) and the voxel count is validated with [`check_dims`] before any voxel is read.
/// Gzip data is decompressed through a bounded reader, so a malicious file cannot make us
/// allocate more than the header's sizes imply.
pub fn read(path: &Path) -> Result<LoadedVoxels> {
    let (fields, consumed, blank_line) = read_fields(path)?;
    let header = Header::parse(path, &fields)?;
    let count = check_dims(path, header.dims)?;
    let expected = count.checked_mul(header.voxel.size()).ok_or_else(|| {
        Error::format(
            path,
            format!("sizes {:?}: the data size overflows", header.sizes),
        )
    })?;

    let (data_path, offset, from_end, skip_decompressed) =
        header.data_placement(path, consumed, blank_line)?;
    let payload = Payload {
        path: &data_path,
        header: path,
        offset,
        from_end,
        codec: header.codec,
        skip_decompressed,
        expected,
        need: format!(
            "sizes {:?} × type {} ({} byte{} each)",
            header.sizes,
            quoted(&header.type_name),
            header.voxel.size(),
            if header.voxel.size() == 1 { "" } else { "s" }
        ),
    };
    let bytes = read_payload(&payload)?;
    Ok(LoadedVoxels {
        dims: header.dims,
        values: decode(&bytes, header.voxel, header.order),
        voxel_type: header.voxel,
        spacing: header.spacing,
        data_path,
        format: "nrrd",
        acquisition: None,
    })
}

/// Reads the header's field lines (after the magic) up to the blank line that ends an
/// attached header; returns the fields, the bytes consumed and whether the blank line came.
fn read_fields(path: &Path) -> Result<(Fields, u64, bool)> {
    let (file, _) = crate::util::open_regular(path, "NRRD file (.nrrd or .nhdr)")?;
    let mut reader = BufReader::new(file);
    let mut consumed = read_magic(path, &mut reader)?;
    let mut fields = Fields::default();
    let mut line_no = 1usize;
    let mut blank_line = false;
    while let Some(line) = next_header_line(&mut reader, path, &mut consumed)? {
        line_no += 1;
        if line.trim().is_empty() {
            blank_line = true;
            break;
        }
        if line.starts_with('#') {
            continue;
        }
        // `key:=value` pairs are free-form metadata; a field line always has `: ` before any
        // `:=` that may appear inside its value.
        if let Some(kv) = line.find(":=")
            && !line.get(..kv).is_some_and(|head| head.contains(": "))
        {
            continue;
        }
        let Some((name, value)) = line.split_once(':') else {
            return Err(Error::format(
                path,
                format!(
                    "line {line_no} {}: expected `field: value`, `key:=value` or a `#` comment",
                    quoted(&line)
                ),
            ));
        };
        let field = Field {
            name: name.trim().to_string(),
            value: value.trim().to_string(),
            line: line_no,
        };
        let key = normalize_key(&field.name);
        if key == "datafile" {
            // Checked now: a `LIST` header is followed by file names that are not fields.
            check_single_data_file(path, &field)?;
        }
        fields.insert(path, key, field)?;
    }
    Ok((fields, consumed, blank_line))
}

/// Writes a NRRD0004 volume, little endian, with `spacings`.
///
/// `values` are raw values in the range of `voxel` (they are rounded and clamped by
/// the encoder). With `detached`, `path` receives the header (conventionally `.nhdr`) and the
/// voxels go to a file beside it with the same stem and extension `.raw` (or `.raw.gz` with
/// `gzip`); otherwise `path` (conventionally `.nrrd`) holds both. Files are written atomically,
/// the data file before the header that points to it.
pub fn write(
    path: &Path,
    dims: [usize; 3],
    values: &[f32],
    voxel: VoxelType,
    spacing: [f32; 3],
    gzip: bool,
    detached: bool,
) -> Result<()> {
    check_write_args(path, dims, values, spacing)?;
    let bytes = encode(values, voxel, ByteOrder::Little);
    let type_name = match voxel {
        VoxelType::U8 => "uint8",
        VoxelType::I8 => "int8",
        VoxelType::U16 => "uint16",
        VoxelType::I16 => "int16",
        VoxelType::F32 => "float",
    };
    let mut header = format!(
        "NRRD0004\n\
         # Complete NRRD file format specification at:\n\
         # http://teem.sourceforge.net/nrrd/format.html\n\
         type: {type_name}\n\
         dimension: 3\n\
         sizes: {} {} {}\n\
         spacings: {} {} {}\n\
         kinds: domain domain domain\n\
         endian: little\n\
         encoding: {}\n",
        dims[0],
        dims[1],
        dims[2],
        spacing[0],
        spacing[1],
        spacing[2],
        if gzip { "gzip" } else { "raw" },
    );
    if detached {
        let data_path = path.with_extension(if gzip { "raw.gz" } else { "raw" });
        let name = data_file_name(path, &data_path)?;
        header.push_str(&format!("data file: {name}\n"));
        write_atomic_with(&data_path, |w| write_encoded(w, &bytes, gzip))?;
        write_atomic(path, header.as_bytes())
    } else {
        header.push('\n');
        write_atomic_with(path, |w| {
            w.write_all(header.as_bytes())?;
            write_encoded(w, &bytes, gzip)
        })
    }
}

/// Writes voxel bytes, gzip-compressed or as they are.
fn write_encoded<W: Write>(w: &mut W, bytes: &[u8], gzip: bool) -> std::io::Result<()> {
    if gzip {
        let mut encoder = GzEncoder::new(w, Compression::default());
        encoder.write_all(bytes)?;
        encoder.finish()?;
        Ok(())
    } else {
        w.write_all(bytes)
    }
}

/// The name a header uses for its detached data file `data_path`, which lies beside `header`.
pub(super) fn data_file_name(header: &Path, data_path: &Path) -> Result<String> {
    if data_path == header {
        return Err(Error::format(
            header,
            "cannot write a detached header here: its data file would have the same name; \
             expected a header extension such as .nhdr or .mhd",
        ));
    }
    let name = data_path
        .file_name()
        .and_then(|n| n.to_str())
        .ok_or_else(|| {
            Error::format(
                data_path,
                "cannot write: the data file name is not valid UTF-8",
            )
        })?;
    if name.contains(['\n', '\r']) || name.trim() != name {
        return Err(Error::format(
            data_path,
            "cannot write: the data file name has line breaks or surrounding spaces, which a \
             text header cannot hold",
        ));
    }
    Ok(name.to_string())
}

/// Validates writer arguments: dims positive, one value per voxel, spacing finite and > 0.
pub(super) fn check_write_args(
    path: &Path,
    dims: [usize; 3],
    values: &[f32],
    spacing: [f32; 3],
) -> Result<()> {
    let count = dims
        .iter()
        .try_fold(1usize, |acc, &n| acc.checked_mul(n))
        .filter(|_| !dims.contains(&0))
        .ok_or_else(|| {
            Error::format(
                path,
                format!("cannot write dims {dims:?}: expected positive sizes whose product fits in memory"),
            )
        })?;
    if values.len() != count {
        return Err(Error::format(
            path,
            format!(
                "cannot write: {} values given but dims {dims:?} need {count}",
                values.len()
            ),
        ));
    }
    if !spacing.iter().all(|s| s.is_finite() && *s > 0.0) {
        return Err(Error::format(
            path,
            format!("cannot write spacing {spacing:?}: expected three finite numbers > 0"),
        ));
    }
    Ok(())
}

/// How the voxels follow a `byte skip`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum ByteSkip {
    /// Skip this many bytes (of the file for raw, of the decompressed stream for gzip).
    Bytes(u64),
    /// `-1`: the voxels are the last bytes of the file.
    FromEnd,
}

/// The validated header fields we use.
#[derive(Debug)]
struct Header {
    voxel: VoxelType,
    /// The `type` value as written, for messages.
    type_name: String,
    /// `sizes` as written (3 or 4 entries), for messages.
    sizes: Vec<usize>,
    dims: [usize; 3],
    codec: Codec,
    order: ByteOrder,
    byte_skip: ByteSkip,
    spacing: Option<[f32; 3]>,
    data_file: Option<PathBuf>,
}

impl Header {
    fn parse(path: &Path, fields: &Fields) -> Result<Header> {
        const DIMENSION: &str =
            "3 (or 4 with a first axis of size 1); only 3-D scalar volumes are supported";
        let dimension_f = fields
            .get("dimension")
            .ok_or_else(|| missing(path, "dimension", DIMENSION))?;
        let dimension = match dimension_f.value.parse::<usize>() {
            Ok(d @ (3 | 4)) => d,
            _ => return Err(dimension_f.invalid(path, DIMENSION)),
        };

        let type_f = fields
            .get("type")
            .ok_or_else(|| missing(path, "type", &format!("one of {SUPPORTED_TYPES}")))?;
        let voxel = parse_type(path, type_f)?;

        let sizes_f = fields.get("sizes").ok_or_else(|| {
            missing(
                path,
                "sizes",
                &format!("{dimension} whole numbers >= 1 (one per axis)"),
            )
        })?;
        let sizes = parse_sizes(path, sizes_f, dimension)?;
        let dims = match sizes.as_slice() {
            [x, y, z] | [1, x, y, z] => [*x, *y, *z],
            _ => {
                return Err(sizes_f.invalid(
                    path,
                    "a first axis of size 1 when `dimension` is 4 (only scalar volumes are supported)",
                ));
            }
        };

        let codec = parse_encoding(path, fields)?;

        let order = parse_endian(path, fields, voxel, type_f)?;

        let byte_skip = parse_byte_skip(path, fields, codec)?;

        if let Some(f) = fields.get("lineskip")
            && f.value.parse::<u64>() != Ok(0)
        {
            return Err(f.invalid(path, "0 (skipping lines before the data is not supported)"));
        }

        let data_file = fields
            .get("datafile")
            .map(|f| {
                let folder = path.parent().unwrap_or(Path::new(""));
                crate::util::confined(folder, Path::new(&f.value), "the header's folder")
            })
            .transpose()?;

        Ok(Header {
            voxel,
            type_name: type_f.value.clone(),
            sizes,
            dims,
            codec,
            order,
            byte_skip,
            spacing: parse_spacing(path, fields, dimension)?,
            data_file,
        })
    }

    /// Where the voxels are: the data file, the byte offset in it, whether they are the
    /// file's last bytes, and the bytes to skip after decompression.
    fn data_placement(
        &self,
        path: &Path,
        consumed: u64,
        blank_line: bool,
    ) -> Result<(PathBuf, u64, bool, u64)> {
        let header = self;
        let (data_path, base) = match &header.data_file {
            Some(data) => (data.clone(), 0),
            None => {
                if !blank_line {
                    return Err(Error::format(
                        path,
                        "the header has no blank line after it and no `data file` field; expected \
                         an attached NRRD (header, blank line, data) or a detached header naming its \
                         data file",
                    ));
                }
                (path.to_path_buf(), consumed)
            }
        };
        let (offset, from_end, skip_decompressed) = match (header.byte_skip, header.codec) {
            (ByteSkip::FromEnd, _) => (base, true, 0),
            (ByteSkip::Bytes(n), Codec::Raw) => {
                let offset = base
                    .checked_add(n)
                    .ok_or_else(|| Error::format(path, format!("`byte skip` {n} is too large")))?;
                (offset, false, 0)
            }
            // NRRD applies the byte skip to the decompressed stream for compressed encodings.
            (ByteSkip::Bytes(n), _) => (base, false, n),
        };
        Ok((data_path, offset, from_end, skip_decompressed))
    }
}

/// `encoding`: raw or gzip.
fn parse_encoding(path: &Path, fields: &Fields) -> Result<Codec> {
    let encoding_f = fields
        .get("encoding")
        .ok_or_else(|| missing(path, "encoding", "`raw` or `gzip`"))?;
    Ok(match encoding_f.value.to_ascii_lowercase().as_str() {
        "raw" => Codec::Raw,
        "gzip" | "gz" => Codec::Gzip,
        _ => {
            return Err(encoding_f.invalid(
                path,
                "`raw` or `gzip` (ascii, hex and bzip2 encodings are not supported)",
            ));
        }
    })
}

/// `endian`, which one-byte types may omit.
fn parse_endian(
    path: &Path,
    fields: &Fields,
    voxel: VoxelType,
    type_f: &Field,
) -> Result<ByteOrder> {
    Ok(match fields.get("endian") {
        Some(f) => match f.value.to_ascii_lowercase().as_str() {
            "little" => ByteOrder::Little,
            "big" => ByteOrder::Big,
            _ => return Err(f.invalid(path, "`little` or `big`")),
        },
        // Byte order is meaningless for one-byte voxels, so NRRD lets writers omit it.
        None if voxel.size() == 1 => ByteOrder::Little,
        None => {
            return Err(missing(
                path,
                "endian",
                &format!(
                    "`little` or `big` (required for type {}, {} bytes per voxel)",
                    quoted(&type_f.value),
                    voxel.size()
                ),
            ));
        }
    })
}

/// `byte skip`: bytes before the voxels, or -1 for the file's last bytes (raw only).
fn parse_byte_skip(path: &Path, fields: &Fields, codec: Codec) -> Result<ByteSkip> {
    Ok(match fields.get("byteskip") {
        None => ByteSkip::Bytes(0),
        Some(f) => match f.value.parse::<i64>() {
            Ok(-1) if codec == Codec::Raw => ByteSkip::FromEnd,
            Ok(n) if n >= 0 => ByteSkip::Bytes(n.unsigned_abs()),
            _ => {
                return Err(f.invalid(
                    path,
                    if codec == Codec::Raw {
                        "a whole number >= 0, or -1 for data at the end of the file"
                    } else {
                        "a whole number >= 0 (-1 is only supported with `encoding: raw`)"
                    },
                ));
            }
        },
    })
}

/// Maps the NRRD `type` spellings we support.
fn parse_type(path: &Path, field: &Field) -> Result<VoxelType> {
    let name = field
        .value
        .split_whitespace()
        .collect::<Vec<_>>()
        .join(" ")
        .to_ascii_lowercase();
    Ok(match name.as_str() {
        "uchar" | "unsigned char" | "uint8" | "uint8_t" => VoxelType::U8,
        "signed char" | "int8" | "int8_t" => VoxelType::I8,
        "ushort" | "unsigned short" | "unsigned short int" | "uint16" | "uint16_t" => {
            VoxelType::U16
        }
        "short" | "short int" | "signed short" | "signed short int" | "int16" | "int16_t" => {
            VoxelType::I16
        }
        "float" => VoxelType::F32,
        _ => {
            return Err(field.invalid(path, format!("a supported type: one of {SUPPORTED_TYPES}")));
        }
    })
}

/// Voxel spacing from `space directions` (norm of each spatial axis vector) or `spacings`.
/// `nan` entries on a spatial axis mean "unknown", which yields no spacing rather than an error.
fn parse_spacing(path: &Path, fields: &Fields, dimension: usize) -> Result<Option<[f32; 3]>> {
    // The spatial axes are the last three; a 4-D file's first axis is the size-1 channel axis.
    let first_spatial = dimension.saturating_sub(3);
    if let Some(f) = fields.get("spacedirections") {
        let expected = || {
            format!(
                "{dimension} entries, each `none` or a vector such as `(0.5,0,0)`, with a \
                 non-zero finite vector for each spatial axis"
            )
        };
        let entries = parse_directions(&f.value).ok_or_else(|| f.invalid(path, expected()))?;
        if entries.len() != dimension {
            return Err(f.invalid(path, expected()));
        }
        let mut spacing = [0.0f32; 3];
        for (slot, entry) in spacing.iter_mut().zip(entries.iter().skip(first_spatial)) {
            let Some(vector) = entry else {
                return Err(f.invalid(path, expected()));
            };
            if vector.iter().any(|c| c.is_nan()) {
                return Ok(None);
            }
            let norm = vector.iter().map(|c| c * c).sum::<f64>().sqrt();
            *slot = positive_spacing(norm).ok_or_else(|| f.invalid(path, expected()))?;
        }
        return Ok(Some(spacing));
    }
    if let Some(f) = fields.get("spacings") {
        let expected =
            || format!("{dimension} numbers, non-zero and finite (or `nan`) for each spatial axis");
        let values = f
            .value
            .split_whitespace()
            .map(|t| t.parse::<f64>())
            .collect::<std::result::Result<Vec<_>, _>>()
            .map_err(|_| f.invalid(path, expected()))?;
        if values.len() != dimension {
            return Err(f.invalid(path, expected()));
        }
        let mut spacing = [0.0f32; 3];
        for (slot, &value) in spacing.iter_mut().zip(values.iter().skip(first_spatial)) {
            if value.is_nan() {
                return Ok(None);
            }
            *slot = positive_spacing(value).ok_or_else(|| f.invalid(path, expected()))?;
        }
        return Ok(Some(spacing));
    }
    Ok(None)
}

/// Parses `none (1,0,0) (0,0.5,0) …` into entries; `None` for malformed text.
fn parse_directions(text: &str) -> Option<Vec<Option<Vec<f64>>>> {
    let mut entries = Vec::new();
    let mut rest = text.trim_start();
    while !rest.is_empty() {
        if let Some(open) = rest.strip_prefix('(') {
            let close = open.find(')')?;
            let vector = open
                .get(..close)?
                .split(',')
                .map(|c| c.trim().parse::<f64>().ok())
                .collect::<Option<Vec<_>>>()?;
            entries.push(Some(vector));
            rest = open.get(close + 1..)?.trim_start();
        } else {
            let end = rest.find(char::is_whitespace).unwrap_or(rest.len());
            if !rest.get(..end)?.eq_ignore_ascii_case("none") {
                return None;
            }
            entries.push(None);
            rest = rest.get(end..)?.trim_start();
        }
    }
    Some(entries)
}

/// `|value|` as a spacing, if finite and non-zero once converted to `f32`.
pub(super) fn positive_spacing(value: f64) -> Option<f32> {
    let s = value.abs() as f32;
    (s.is_finite() && s > 0.0).then_some(s)
}

/// Parses exactly `count` whole numbers >= 1.
pub(super) fn parse_sizes(path: &Path, field: &Field, count: usize) -> Result<Vec<usize>> {
    let expected = || format!("{count} whole numbers >= 1 (one per axis)");
    let sizes = field
        .value
        .split_whitespace()
        .map(|t| t.parse::<usize>())
        .collect::<std::result::Result<Vec<_>, _>>()
        .map_err(|_| field.invalid(path, expected()))?;
    if sizes.len() != count || sizes.contains(&0) {
        return Err(field.invalid(path, expected()));
    }
    Ok(sizes)
}

/// Reads and checks the magic line; returns its length in bytes.
fn read_magic<R: BufRead>(path: &Path, reader: &mut R) -> Result<u64> {
    let mut buf = Vec::new();
    // A short bound: a binary file without line breaks must not be scanned.
    let n = Read::take(&mut *reader, 16)
        .read_until(b'\n', &mut buf)
        .map_err(|e| Error::io(path, e))?;
    let text = String::from_utf8_lossy(&buf);
    let magic = text.trim_end_matches(['\n', '\r']);
    if matches!(
        magic,
        "NRRD0001" | "NRRD0002" | "NRRD0003" | "NRRD0004" | "NRRD0005"
    ) {
        return Ok(n as u64);
    }
    let message = if magic.starts_with("NRRD") {
        format!(
            "unsupported NRRD magic {}: expected `NRRD0001` … `NRRD0005`",
            quoted(magic)
        )
    } else {
        format!(
            "not a NRRD file: bad magic {}, expected a first line `NRRD0001` … `NRRD0005`",
            quoted(magic)
        )
    };
    Err(Error::format(path, message))
}

/// Rejects `LIST` and file-name patterns in a data file field (`data file`, `ElementDataFile`):
/// multi-file volumes are not supported.
pub(super) fn check_single_data_file(path: &Path, field: &Field) -> Result<()> {
    let mut tokens = field.value.split_whitespace();
    let first = tokens.next().unwrap_or("");
    let problem = if first.is_empty() {
        Some("a data file name")
    } else if first == "LIST" {
        Some("a single data file name; multi-file data (`LIST`) is not supported")
    } else if tokens.next().is_some() && first.contains('%') {
        Some("a single data file name; multi-file data (a file name pattern) is not supported")
    } else {
        None
    };
    match problem {
        Some(expected) => Err(field.invalid(path, expected)),
        None => Ok(()),
    }
}

/// Reads one header line (without its line break) and adds its length to `consumed`.
/// `None` at the end of the file. The total header length is capped at [`MAX_HEADER_BYTES`].
pub(super) fn next_header_line<R: BufRead>(
    reader: &mut R,
    path: &Path,
    consumed: &mut u64,
) -> Result<Option<String>> {
    let too_long = || {
        Error::format(
            path,
            format!(
                "no end of the header within its first {MAX_HEADER_BYTES} bytes; expected a \
                 short text header"
            ),
        )
    };
    let remaining = MAX_HEADER_BYTES.saturating_sub(*consumed);
    let mut buf = Vec::new();
    let n = Read::take(&mut *reader, remaining)
        .read_until(b'\n', &mut buf)
        .map_err(|e| Error::io(path, e))?;
    if n == 0 {
        return if remaining == 0 {
            Err(too_long())
        } else {
            Ok(None)
        };
    }
    *consumed = consumed.saturating_add(n as u64);
    if buf.last() != Some(&b'\n') && n as u64 == remaining {
        return Err(too_long());
    }
    while matches!(buf.last(), Some(b'\n' | b'\r')) {
        buf.pop();
    }
    Ok(Some(String::from_utf8_lossy(&buf).into_owned()))
}

/// Header text shown in messages: backquoted, control characters escaped, long text cut.
pub(super) fn quoted(text: &str) -> String {
    const MAX: usize = 80;
    let mut shown: String = text.chars().take(MAX).collect();
    if text.chars().nth(MAX).is_some() {
        shown.push('…');
    }
    format!("`{}`", shown.escape_debug())
}

/// Field names compared without case and spaces (`data file` = `datafile`, `NDims` = `ndims`).
pub(super) fn normalize_key(name: &str) -> String {
    name.chars()
        .filter(|c| !c.is_whitespace())
        .collect::<String>()
        .to_ascii_lowercase()
}

/// One `name: value` (NRRD) or `Name = Value` (MetaImage) header line.
#[derive(Debug, Clone)]
pub(super) struct Field {
    /// The name as written.
    pub(super) name: String,
    /// The value, trimmed.
    pub(super) value: String,
    /// 1-based line number.
    pub(super) line: usize,
}

impl Field {
    /// An error naming the line, the field, its value and what was `expected`.
    pub(super) fn invalid(&self, path: &Path, expected: impl std::fmt::Display) -> Error {
        Error::format(
            path,
            format!(
                "line {}: field `{}` = {}: expected {expected}",
                self.line,
                self.name,
                quoted(&self.value)
            ),
        )
    }
}

/// An error for a required field that is absent.
pub(super) fn missing(path: &Path, name: &str, expected: &str) -> Error {
    Error::format(path, format!("missing field `{name}`: expected {expected}"))
}

/// Header fields by normalised name, in file order.
#[derive(Debug, Default)]
pub(super) struct Fields {
    entries: Vec<(String, Field)>,
}

impl Fields {
    /// Adds a field; a repeated field is an error (which one would the writer have meant?).
    pub(super) fn insert(&mut self, path: &Path, key: String, field: Field) -> Result<()> {
        if let Some((_, first)) = self.entries.iter().find(|(k, _)| *k == key) {
            return Err(Error::format(
                path,
                format!(
                    "line {}: field `{}` is given twice (first on line {}); expected it once",
                    field.line, field.name, first.line
                ),
            ));
        }
        self.entries.push((key, field));
        Ok(())
    }

    /// The field with normalised name `key` (see [`normalize_key`]).
    pub(super) fn get(&self, key: &str) -> Option<&Field> {
        self.entries
            .iter()
            .find(|(k, _)| k == key)
            .map(|(_, field)| field)
    }
}

/// How voxel bytes are stored.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Codec {
    /// Uncompressed.
    Raw,
    /// gzip stream (NRRD `gzip`).
    Gzip,
    /// zlib stream (MetaImage `CompressedData = True`).
    Zlib,
}

/// Where the voxel bytes are and how many are needed.
#[derive(Debug)]
pub(super) struct Payload<'a> {
    /// The file holding the voxels.
    pub(super) path: &'a Path,
    /// The header file, named in messages when it differs from `path`.
    pub(super) header: &'a Path,
    /// Where the data (or the compressed stream) starts in the file.
    pub(super) offset: u64,
    /// Raw only: the voxels are the last `expected` bytes of the file, starting at or after
    /// `offset`.
    pub(super) from_end: bool,
    /// Storage.
    pub(super) codec: Codec,
    /// Decompressed bytes to discard before the voxels.
    pub(super) skip_decompressed: u64,
    /// Voxel bytes needed (dims × type size).
    pub(super) expected: usize,
    /// What needs them, e.g. ``sizes [4, 4, 4] × type `ushort` (2 bytes each)``.
    pub(super) need: String,
}

impl Payload<'_> {
    /// ` (header …)` for detached headers, so the message names both files.
    fn header_note(&self) -> String {
        if self.header == self.path {
            String::new()
        } else {
            format!(" (header {})", self.header.display())
        }
    }

    /// The "not enough data" error, naming both byte counts.
    fn too_short(&self, have: u64, context: &str) -> Error {
        Error::format(
            self.path,
            format!(
                "data has {have} bytes{context} but {} need {} bytes{}",
                self.need,
                self.expected,
                self.header_note()
            ),
        )
    }
}

/// Reads exactly `expected` voxel bytes as described by `p`.
pub(super) fn read_payload(p: &Payload<'_>) -> Result<Vec<u8>> {
    let io = |e: std::io::Error| Error::io(p.path, e);
    let (mut file, _) = crate::util::open_regular(p.path, "volume data file").map_err(|e| {
        if p.path == p.header {
            e
        } else {
            // A detached header names its data file: say which header, and which file.
            Error::format(p.header, format!("its data file cannot be read: {e}"))
        }
    })?;
    match p.codec {
        Codec::Raw => read_raw(p, file),
        Codec::Gzip => {
            file.seek(SeekFrom::Start(p.offset)).map_err(io)?;
            read_decompressed(p, MultiGzDecoder::new(BufReader::new(file)), "gzip")
        }
        Codec::Zlib => {
            file.seek(SeekFrom::Start(p.offset)).map_err(io)?;
            read_decompressed(p, ZlibDecoder::new(BufReader::new(file)), "zlib")
        }
    }
}

fn read_raw(p: &Payload<'_>, mut file: File) -> Result<Vec<u8>> {
    let io = |e: std::io::Error| Error::io(p.path, e);
    let len = file.metadata().map_err(io)?.len();
    let expected = p.expected as u64;
    let available = len.saturating_sub(p.offset);
    if available < expected {
        let context = if p.offset > 0 {
            format!(" after the first {} bytes of the file", p.offset)
        } else {
            String::new()
        };
        return Err(p.too_short(available, &context));
    }
    let start = if p.from_end {
        len.saturating_sub(expected)
    } else {
        p.offset
    };
    file.seek(SeekFrom::Start(start)).map_err(io)?;
    let mut bytes = vec![0u8; p.expected];
    file.read_exact(&mut bytes).map_err(|e| {
        if e.kind() == std::io::ErrorKind::UnexpectedEof {
            Error::format(
                p.path,
                format!(
                    "the file became shorter while reading; expected {} bytes of data from byte {start}",
                    p.expected
                ),
            )
        } else {
            io(e)
        }
    })?;
    Ok(bytes)
}

fn read_decompressed<R: Read>(p: &Payload<'_>, mut decoder: R, name: &str) -> Result<Vec<u8>> {
    let damaged = |got: usize, e: std::io::Error| {
        Error::format(
            p.path,
            format!(
                "{name} data is damaged or cut short after {got} decompressed bytes: {e}{}",
                p.header_note()
            ),
        )
    };
    if p.skip_decompressed > 0 {
        let skipped = std::io::copy(
            &mut Read::take(&mut decoder, p.skip_decompressed),
            &mut std::io::sink(),
        )
        .map_err(|e| damaged(0, e))?;
        if skipped < p.skip_decompressed {
            return Err(Error::format(
                p.path,
                format!(
                    "{name} data has {skipped} bytes after decompression, fewer than the byte \
                     skip of {}{}",
                    p.skip_decompressed,
                    p.header_note()
                ),
            ));
        }
    }
    // One byte more than needed is enough to learn that the data is long enough; never more,
    // so a small file cannot expand into unbounded memory.
    let limit = (p.expected as u64).saturating_add(1);
    let mut bytes = Vec::with_capacity(p.expected.saturating_add(1));
    if let Err(e) = Read::take(&mut decoder, limit).read_to_end(&mut bytes) {
        // Trailing bytes after a complete stream (e.g. padding) do not spoil the voxels.
        if bytes.len() < p.expected {
            return Err(damaged(bytes.len(), e));
        }
    }
    if bytes.len() < p.expected {
        return Err(p.too_short(bytes.len() as u64, &format!(" after {name} decompression")));
    }
    bytes.truncate(p.expected);
    Ok(bytes)
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

    fn gz(bytes: &[u8]) -> Vec<u8> {
        let mut out = Vec::new();
        write_encoded(&mut out, bytes, true).unwrap();
        out
    }

    fn err_text(path: &Path) -> String {
        read(path).unwrap_err().to_string()
    }

    #[test]
    fn round_trips_attached_detached_raw_gzip() {
        let dir = tempfile::tempdir().unwrap();
        let dims = [3, 4, 5];
        let spacing = [0.5, 0.75, 2.0];
        for voxel in [
            VoxelType::U8,
            VoxelType::U16,
            VoxelType::I16,
            VoxelType::F32,
        ] {
            let values = sample(voxel, 60);
            for (gzip, detached) in [(false, false), (true, false), (false, true), (true, true)] {
                let ext = if detached { "nhdr" } else { "nrrd" };
                let path = dir
                    .path()
                    .join(format!("v_{voxel}_{gzip}_{detached}.{ext}"));
                write(&path, dims, &values, voxel, spacing, gzip, detached).unwrap();
                let loaded = read(&path).unwrap();
                let case = format!("{voxel} gzip={gzip} detached={detached}");
                assert_eq!(loaded.dims, dims, "{case}");
                assert_eq!(loaded.values, values, "{case}");
                assert_eq!(loaded.voxel_type, voxel, "{case}");
                assert_eq!(loaded.spacing, Some(spacing), "{case}");
                assert_eq!(loaded.format, "nrrd");
                let data_path = if detached {
                    path.with_extension(if gzip { "raw.gz" } else { "raw" })
                } else {
                    path.clone()
                };
                assert_eq!(loaded.data_path, data_path, "{case}");
                assert!(data_path.exists());
            }
        }
    }

    #[test]
    fn space_directions_give_spacing_and_big_endian_is_honoured() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("d.nrrd");
        let header = "NRRD0005\r\n# a comment\r\nTYPE: signed short\r\ndimension: 3\r\n\
                      space: left-posterior-superior\r\nsizes: 2 1 2\r\n\
                      space directions: (0.5,0,0) (0, 0.6, 0.8) (0,0,1.25)\r\n\
                      kinds: domain domain domain\r\nendian: big\r\nencoding: raw\r\n\
                      space origin: (0,0,0)\r\nmodality:=CT\r\n\r\n";
        let data = encode(&[-1024.0, 0.0, 7.0, 3071.0], VoxelType::I16, ByteOrder::Big);
        std::fs::write(&path, [header.as_bytes(), &data].concat()).unwrap();
        let loaded = read(&path).unwrap();
        assert_eq!(loaded.dims, [2, 1, 2]);
        assert_eq!(loaded.values, vec![-1024.0, 0.0, 7.0, 3071.0]);
        let s = loaded.spacing.unwrap();
        assert!(
            (s[0] - 0.5).abs() < 1e-6 && (s[1] - 1.0).abs() < 1e-6 && (s[2] - 1.25).abs() < 1e-6
        );
    }

    #[test]
    fn four_d_with_single_channel_is_three_d() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("c.nrrd");
        let header = "NRRD0004\ntype: uchar\ndimension: 4\nsizes: 1 2 2 1\n\
                      space directions: none (2,0,0) (0,3,0) (0,0,4)\nencoding: raw\n\n";
        std::fs::write(&path, [header.as_bytes(), &[1, 2, 3, 4]].concat()).unwrap();
        let loaded = read(&path).unwrap();
        assert_eq!(loaded.dims, [2, 2, 1]);
        assert_eq!(loaded.values, vec![1.0, 2.0, 3.0, 4.0]);
        assert_eq!(loaded.spacing, Some([2.0, 3.0, 4.0]));

        let bad = dir.path().join("rgb.nrrd");
        let header = "NRRD0004\ntype: uchar\ndimension: 4\nsizes: 3 2 2 1\nencoding: raw\n\n";
        std::fs::write(&bad, [header.as_bytes(), &[0; 12]].concat()).unwrap();
        let err = err_text(&bad);
        assert!(
            err.contains("sizes") && err.contains("first axis of size 1"),
            "{err}"
        );
    }

    #[test]
    fn byte_skips_raw_and_gzip() {
        let dir = tempfile::tempdir().unwrap();
        let values = sample(VoxelType::U16, 8);
        let data = encode(&values, VoxelType::U16, ByteOrder::Little);

        // Detached raw with byte skip -1: junk before the voxels.
        std::fs::write(dir.path().join("a.raw"), [&[9u8; 5][..], &data].concat()).unwrap();
        let a = dir.path().join("a.nhdr");
        std::fs::write(
            &a,
            "NRRD0004\ntype: uint16\ndimension: 3\nsizes: 2 2 2\nendian: little\n\
             encoding: raw\nbyte skip: -1\ndata file: a.raw\n",
        )
        .unwrap();
        let loaded = read(&a).unwrap();
        assert_eq!(loaded.values, values);
        assert_eq!(loaded.data_path, dir.path().join("a.raw"));
        assert_eq!(loaded.spacing, None);

        // Detached raw with a positive skip, via `datafile:`.
        let b = dir.path().join("b.nhdr");
        std::fs::write(
            &b,
            "NRRD0004\ntype: uint16\ndimension: 3\nsizes: 2 2 2\nendian: little\n\
             encoding: raw\nbyteskip: 5\ndatafile: a.raw\n",
        )
        .unwrap();
        assert_eq!(read(&b).unwrap().values, values);

        // Attached gzip: the skip applies to the decompressed stream.
        let c = dir.path().join("c.nrrd");
        let header = "NRRD0004\ntype: uint16\ndimension: 3\nsizes: 2 2 2\nendian: little\n\
                      encoding: gzip\nbyte skip: 3\n\n";
        let payload = gz(&[&[7u8; 3][..], &data].concat());
        std::fs::write(&c, [header.as_bytes(), &payload].concat()).unwrap();
        assert_eq!(read(&c).unwrap().values, values);

        // -1 is not allowed for gzip.
        let d = dir.path().join("d.nrrd");
        let header = "NRRD0004\ntype: uint16\ndimension: 3\nsizes: 2 2 2\nendian: little\n\
                      encoding: gzip\nbyte skip: -1\n\n";
        std::fs::write(&d, [header.as_bytes(), &payload].concat()).unwrap();
        let err = err_text(&d);
        assert!(err.contains("byte skip") && err.contains("-1"), "{err}");
    }

    #[test]
    fn longer_gzip_data_is_read_bounded() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("long.nrrd");
        let header = "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 2 2\nencoding: gz\n\n";
        let payload = gz(&[5u8; 100_000]);
        std::fs::write(&path, [header.as_bytes(), &payload].concat()).unwrap();
        let loaded = read(&path).unwrap();
        assert_eq!(loaded.values, vec![5.0; 8]);
    }

    #[test]
    fn bad_magic() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("bad.nrrd");
        std::fs::write(&path, b"\x89PNG\r\n\x1a\n\0\0\0\0\0\0\0\0\0\0\0\0").unwrap();
        let err = err_text(&path);
        assert!(
            err.contains("bad.nrrd") && err.contains("magic") && err.contains("NRRD0001"),
            "{err}"
        );
        std::fs::write(&path, b"NRRD0009\ntype: uchar\n").unwrap();
        let err = err_text(&path);
        assert!(err.contains("NRRD0009"), "{err}");
        std::fs::write(&path, b"").unwrap();
        assert!(err_text(&path).contains("magic"));
    }

    #[test]
    fn missing_fields_are_named() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("m.nrrd");
        std::fs::write(
            &path,
            "NRRD0004\ntype: uchar\ndimension: 3\nencoding: raw\n\n",
        )
        .unwrap();
        let err = err_text(&path);
        assert!(
            err.contains("m.nrrd") && err.contains("missing field `sizes`"),
            "{err}"
        );

        std::fs::write(
            &path,
            "NRRD0004\ntype: ushort\ndimension: 3\nsizes: 1 1 1\nencoding: raw\n\n\0\0",
        )
        .unwrap();
        let err = err_text(&path);
        assert!(err.contains("endian") && err.contains("ushort"), "{err}");
    }

    #[test]
    fn unsupported_type_lists_supported() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("t.nrrd");
        std::fs::write(
            &path,
            "NRRD0004\ntype: double\ndimension: 3\nsizes: 1 1 1\nendian: little\nencoding: raw\n\n",
        )
        .unwrap();
        let err = err_text(&path);
        assert!(
            err.contains("`double`") && err.contains("uchar") && err.contains("float"),
            "{err}"
        );
    }

    #[test]
    fn truncated_data_names_both_byte_counts() {
        let dir = tempfile::tempdir().unwrap();
        let header = "NRRD0004\ntype: ushort\ndimension: 3\nsizes: 4 4 4\nendian: little\n";
        let raw = dir.path().join("short.nrrd");
        std::fs::write(
            &raw,
            [header.as_bytes(), b"encoding: raw\n\n", &[0u8; 100]].concat(),
        )
        .unwrap();
        let err = err_text(&raw);
        assert!(
            err.contains("100 bytes") && err.contains("128 bytes"),
            "{err}"
        );
        assert!(err.contains("short.nrrd"), "{err}");

        let gzip = dir.path().join("short_gz.nrrd");
        std::fs::write(
            &gzip,
            [header.as_bytes(), b"encoding: gzip\n\n", &gz(&[0u8; 100])].concat(),
        )
        .unwrap();
        let err = err_text(&gzip);
        assert!(
            err.contains("100 bytes") && err.contains("128 bytes"),
            "{err}"
        );

        // Detached: the data file is named, and the header too.
        std::fs::write(dir.path().join("s.raw"), [0u8; 100]).unwrap();
        let nhdr = dir.path().join("s.nhdr");
        std::fs::write(
            &nhdr,
            [header.as_bytes(), b"encoding: raw\ndata file: s.raw\n"].concat(),
        )
        .unwrap();
        let err = err_text(&nhdr);
        assert!(err.contains("s.raw") && err.contains("s.nhdr"), "{err}");
        assert!(
            err.contains("100 bytes") && err.contains("128 bytes"),
            "{err}"
        );
    }

    #[test]
    fn dimension_two_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("flat.nrrd");
        std::fs::write(
            &path,
            "NRRD0004\ntype: uchar\ndimension: 2\nsizes: 2 2\nencoding: raw\n\n\0\0\0\0",
        )
        .unwrap();
        let err = err_text(&path);
        assert!(
            err.contains("dimension") && err.contains("`2`") && err.contains("3"),
            "{err}"
        );
    }

    #[test]
    fn multi_file_data_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("list.nhdr");
        std::fs::write(
            &path,
            "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 2 2\nencoding: raw\n\
             data file: LIST\nslice0.raw\nslice1.raw\n",
        )
        .unwrap();
        let err = err_text(&path);
        assert!(
            err.contains("LIST") && err.contains("not supported"),
            "{err}"
        );

        std::fs::write(
            &path,
            "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 2 2\nencoding: raw\n\
             data file: slice%03d.raw 0 1 1\n",
        )
        .unwrap();
        let err = err_text(&path);
        assert!(
            err.contains("pattern") && err.contains("not supported"),
            "{err}"
        );
    }

    #[test]
    fn other_bad_headers() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("x.nrrd");
        let cases: &[(&str, &str)] = &[
            (
                "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 2 2\nencoding: raw\nline skip: 1\n\n",
                "line skip",
            ),
            (
                "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 2 2\nencoding: hex\n\n",
                "encoding",
            ),
            (
                "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 2\nencoding: raw\n\n",
                "sizes",
            ),
            (
                "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 0 2\nencoding: raw\n\n",
                "sizes",
            ),
            (
                "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 2 2\nencoding: raw\nspacings: 1 0 1\n\n",
                "spacings",
            ),
            (
                "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 2 2\nencoding: raw\nspace directions: (1,0,0) (0,1,0\n\n",
                "space directions",
            ),
            ("NRRD0004\ntype: uchar\ntype: uchar\n\n", "twice"),
            ("NRRD0004\ntype: uchar\nnonsense\n\n", "line 3"),
            (
                "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 2 2\nencoding: raw\n",
                "blank line",
            ),
            (
                "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 99999999999 99999999999 99999999999\nencoding: raw\n\n",
                "dims",
            ),
        ];
        for (text, needle) in cases {
            // Data follows only headers that end with their blank line.
            let data: &[u8] = if text.ends_with("\n\n") { &[0; 8] } else { &[] };
            std::fs::write(&path, [text.as_bytes(), data].concat()).unwrap();
            let err = err_text(&path);
            assert!(
                err.contains(needle) && err.contains("x.nrrd"),
                "{needle}: {err}"
            );
        }
        // No spacing at all, and `nan` spacing, mean "unknown".
        std::fs::write(
            &path,
            "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 2 2\nencoding: raw\nspacings: nan nan nan\n\n\0\0\0\0\0\0\0\0",
        )
        .unwrap();
        assert_eq!(read(&path).unwrap().spacing, None);
    }

    #[test]
    fn writer_validates_arguments() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("w.nrrd");
        let err = write(
            &path,
            [2, 2, 2],
            &[0.0; 7],
            VoxelType::U8,
            [1.0; 3],
            false,
            false,
        )
        .unwrap_err()
        .to_string();
        assert!(err.contains("7 values") && err.contains('8'), "{err}");
        let err = write(
            &path,
            [2, 2, 2],
            &[0.0; 8],
            VoxelType::U8,
            [1.0, 0.0, 1.0],
            false,
            false,
        )
        .unwrap_err()
        .to_string();
        assert!(err.contains("spacing"), "{err}");
        let raw = dir.path().join("w.raw");
        assert!(
            write(
                &raw,
                [1, 1, 1],
                &[0.0],
                VoxelType::U8,
                [1.0; 3],
                false,
                true
            )
            .is_err()
        );
    }
}
