//! Portable float maps (PFM): linear RGB (or grey) floats, bottom row first — the films'
//! plain format and one of the environment maps'. Below the film and the scene, which both
//! read and write it. The header is read first and every size checked before a pixel is
//! read; errors quote a header field only as a number or a few escaped bytes.

use std::path::Path;

use glam::Vec3;

use crate::error::{Error, Result};
use crate::util::write_atomic_with;

/// Writes linear RGB as PFM (little-endian, bottom row first as the format requires).
pub fn write_pfm(path: &Path, width: usize, height: usize, pixels: &[Vec3]) -> Result<()> {
    write_atomic_with(path, |w| {
        use std::io::Write;
        write!(w, "PF\n{width} {height}\n-1.0\n")?;
        for y in (0..height).rev() {
            for p in &pixels[y * width..(y + 1) * width] {
                for c in [p.x, p.y, p.z] {
                    w.write_all(&c.to_le_bytes())?;
                }
            }
        }
        Ok(())
    })
}

/// Reads a colour PFM (`PF`, either byte order, bottom row first) as top-row-first RGB:
/// `(width, height, pixels)`. The header is read first: a file whose size is not what its
/// header promises, or whose pixels would not fit in 2^28 pixels or half the
/// machine's available memory, is refused before any pixel is read.
pub fn read_pfm(path: &Path) -> Result<(usize, usize, Vec<Vec3>)> {
    let (width, height, pixels, _) =
        read_pfm_bounded(path, PfmChannels::ColourOnly, "PFM image", |w, h| {
            check_pfm_pixels(path, w, h)
        })?;
    Ok((width, height, pixels))
}

/// The most pixels a PFM image read by [`read_pfm`] may hold (2^28, 3 GiB of RGB floats).
const MAX_PFM_PIXELS: usize = 1 << 28;

/// Refuses a film larger than [`MAX_PFM_PIXELS`] or than half the available memory.
fn check_pfm_pixels(path: &Path, width: usize, height: usize) -> Result<()> {
    let budget = crate::util::memory_budget_bytes() / 12;
    let limit = (MAX_PFM_PIXELS as u64).min(budget);
    match width.checked_mul(height) {
        Some(n) if n as u64 <= limit => Ok(()),
        _ => Err(Error::format(
            path,
            format!(
                "PFM: {width}×{height} pixels is more than the {limit} this machine loads (at most {MAX_PFM_PIXELS}, and 12 bytes each within half the available memory)"
            ),
        )),
    }
}

/// Which PFM types a reader accepts.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PfmChannels {
    /// `PF` only (films).
    ColourOnly,
    /// `PF`, or `Pf` read as grey RGB (environment maps).
    ColourOrGrey,
}

/// The longest PFM header read: the type, two sizes and the scale, each at most 32 bytes,
/// and the white space between them.
const PFM_HEADER_CAP: usize = 256;

/// A PFM file's header: its type, size and scale, and where its pixels start.
#[derive(Debug, Clone, Copy, PartialEq)]
struct PfmHeader {
    /// Pixels across.
    width: usize,
    /// Pixels down.
    height: usize,
    /// 3 for `PF`, 1 for `Pf`.
    channels: usize,
    /// The header's scale: its sign is the byte order (negative: little-endian), its
    /// magnitude multiplies every value.
    scale: f32,
    /// The offset of the first pixel byte.
    data_start: usize,
}

impl PfmHeader {
    /// Parses the header at the start of `bytes` (errors name `path`, and quote a field
    /// only as a number or by its first few bytes, escaped: the file may not be a PFM at
    /// all, and its first words may be anything).
    fn parse(path: &Path, bytes: &[u8], accepted: PfmChannels) -> Result<Self> {
        let bad = |what: String| Error::format(path, format!("PFM: {what}"));
        let (fields, data_start) = pfm_header(bytes).ok_or_else(|| {
            bad(format!(
                "expected the header `PF` or `Pf`, width, height and scale (within its first {PFM_HEADER_CAP} bytes); the file starts with `{}`",
                crate::util::escaped_prefix(bytes, 2)
            ))
        })?;
        let channels = match (fields[0], accepted) {
            (b"PF", _) => 3,
            (b"Pf", PfmChannels::ColourOrGrey) => 1,
            (b"Pf", PfmChannels::ColourOnly) => {
                return Err(bad("`Pf` is not a colour PFM (expected `PF`)".to_string()));
            }
            (other, _) => {
                return Err(bad(format!(
                    "type `{}`: expected `PF` (RGB) or `Pf` (grey)",
                    crate::util::escaped_prefix(other, 2)
                )));
            }
        };
        let size = |f: &[u8]| {
            std::str::from_utf8(f)
                .ok()
                .and_then(|t| t.parse::<usize>().ok())
                .filter(|&n| n >= 1)
        };
        let (Some(width), Some(height)) = (size(fields[1]), size(fields[2])) else {
            return Err(bad(format!(
                "size `{} {}`: expected two whole numbers ≥ 1",
                shown_field(fields[1]),
                shown_field(fields[2])
            )));
        };
        let scale = std::str::from_utf8(fields[3])
            .ok()
            .and_then(|t| t.parse::<f32>().ok())
            .filter(|s| s.is_finite() && *s != 0.0)
            .ok_or_else(|| {
                bad(format!(
                    "scale `{}`: expected a finite non-zero number (negative: little-endian)",
                    shown_field(fields[3])
                ))
            })?;
        Ok(PfmHeader {
            width,
            height,
            channels,
            scale,
            data_start,
        })
    }

    /// The bytes of pixel data the header promises, `None` past `u64` (a corrupt size).
    fn pixel_bytes(&self) -> Option<u64> {
        (self.width as u64)
            .checked_mul(self.height as u64)?
            .checked_mul(self.channels as u64 * 4)
    }

    /// The error for pixel data of `found` bytes where the header promises another size.
    fn wrong_size(&self, path: &Path, found: u64) -> Error {
        Error::format(
            path,
            format!(
                "PFM: {found} bytes of pixels, expected {} for {}×{} {}",
                (self.width as u128) * (self.height as u128) * (self.channels as u128) * 4,
                self.width,
                self.height,
                if self.channels == 3 { "RGB" } else { "grey" }
            ),
        )
    }

    /// Decodes one stored row (`width · channels` values) into `out`, times |scale|.
    fn decode_row(&self, line: &[u8], out: &mut [Vec3]) {
        let little = self.scale < 0.0;
        let magnitude = self.scale.abs();
        let value = |b: &[u8]| {
            let b: [u8; 4] = b.try_into().expect("chunks of 4 bytes");
            magnitude
                * if little {
                    f32::from_le_bytes(b)
                } else {
                    f32::from_be_bytes(b)
                }
        };
        for (px, texel) in line.chunks_exact(self.channels * 4).zip(out) {
            *texel = if self.channels == 3 {
                Vec3::new(value(&px[0..4]), value(&px[4..8]), value(&px[8..12]))
            } else {
                Vec3::splat(value(px))
            };
        }
    }
}

/// A header field as an error shows it: whole if it is a number as written (digits, sign,
/// point, exponent), else its first four bytes, escaped.
fn shown_field(field: &[u8]) -> String {
    let numeric = field
        .iter()
        .all(|b| b.is_ascii_digit() || b"+-.eE".contains(b));
    if numeric {
        String::from_utf8_lossy(field).into_owned()
    } else {
        crate::util::escaped_prefix(field, 4)
    }
}

/// Reads a PFM file (little-endian if the scale is negative, values times |scale| as
/// pbrt-v4 reads them — writers write ±1 —, rows stored bottom row first and returned top
/// row first), its header first: `check_size(width, height)` may refuse its size before
/// anything is allocated, and a file longer or shorter than its header promises is
/// refused by its length before any pixel is read; then the pixels, one row at a time.
/// Returns `(width, height, pixels top row first, header scale)`; `what` names the file's
/// role in errors ("environment map (PFM)").
pub(crate) fn read_pfm_bounded(
    path: &Path,
    accepted: PfmChannels,
    what: &str,
    check_size: impl FnOnce(usize, usize) -> Result<()>,
) -> Result<(usize, usize, Vec<Vec3>, f32)> {
    use std::io::Read as _;
    let (file, length) = crate::util::open_regular(path, what)?;
    let mut reader = std::io::BufReader::new(file);
    let mut head = Vec::with_capacity(PFM_HEADER_CAP);
    (&mut reader)
        .take(PFM_HEADER_CAP as u64)
        .read_to_end(&mut head)
        .map_err(|e| Error::io(path, e))?;
    let header = PfmHeader::parse(path, &head, accepted)?;
    let promised = length.checked_sub(header.data_start as u64);
    if promised.is_none() || header.pixel_bytes() != promised {
        return Err(header.wrong_size(path, promised.unwrap_or(0)));
    }
    check_size(header.width, header.height)?;
    let row_bytes = header.width * header.channels * 4;
    let mut texels = vec![Vec3::ZERO; header.width * header.height];
    let mut line = vec![0u8; row_bytes];
    // The header's bytes already read past its end are the first pixels.
    let mut rest = std::io::Cursor::new(head[header.data_start.min(head.len())..].to_vec())
        .chain(reader.take(length));
    for stored in 0..header.height {
        rest.read_exact(&mut line).map_err(|e| {
            Error::format(
                path,
                format!("PFM: reading row {stored} of {} (from the bottom): {e}; the file changed while it was read?", header.height),
            )
        })?;
        let row = header.height - 1 - stored;
        header.decode_row(
            &line,
            &mut texels[row * header.width..(row + 1) * header.width],
        );
    }
    Ok((header.width, header.height, texels, header.scale))
}

/// Splits a PFM header into its four white-space separated fields ("PF" or "Pf", width,
/// height, scale) and the offset of the pixel data, after the one white-space byte that
/// ends the header.
fn pfm_header(bytes: &[u8]) -> Option<([&[u8]; 4], usize)> {
    let mut fields = [&bytes[..0]; 4];
    let mut at = 0;
    for field in &mut fields {
        while at < bytes.len() && bytes[at].is_ascii_whitespace() {
            at += 1;
        }
        let start = at;
        while at < bytes.len() && !bytes[at].is_ascii_whitespace() {
            at += 1;
        }
        if start == at || at - start > 32 {
            return None;
        }
        *field = &bytes[start..at];
    }
    // The one white-space byte that ends the header must be there (a header cut short
    // at the end of the bytes read is not a header).
    (at < bytes.len()).then_some((fields, at + 1))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pfm_round_trip_and_errors_name_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.pfm");
        let pixels: Vec<Vec3> = (0..6).map(|i| Vec3::new(i as f32, 0.5, -1.0)).collect();
        write_pfm(&path, 3, 2, &pixels).unwrap();
        assert_eq!(read_pfm(&path).unwrap(), (3, 2, pixels));
        std::fs::write(&path, b"PF\n3 2\n-1.0\n\0\0").unwrap();
        let err = read_pfm(&path).unwrap_err().to_string();
        assert!(
            err.contains("a.pfm") && err.contains("expected 72"),
            "{err}"
        );
        std::fs::write(&path, b"Pf\n3 2\n-1.0\n").unwrap();
        assert!(
            read_pfm(&path)
                .unwrap_err()
                .to_string()
                .contains("colour PFM")
        );
    }

    #[test]
    fn pfm_has_header_and_size() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("f.pfm");
        write_pfm(&p, 2, 2, &[Vec3::ONE; 4]).unwrap();
        let bytes = std::fs::read(&p).unwrap();
        assert!(bytes.starts_with(b"PF\n2 2\n-1.0\n"));
        assert_eq!(bytes.len(), 12 + 4 * 12);
    }
}
