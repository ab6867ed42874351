//! Pixel data read here rather than by dicom-pixeldata: uncompressed samples in the file's
//! byte order (dicom-rs holds big-endian OW as 16-bit words, so 32-bit samples came out
//! with their halves swapped), and RLE Lossless (PS3.5 Annex G) at 8, 16 and 32 bits
//! (dicom-pixeldata's RLE decoder refuses 32-bit RT Dose grids). Both give the samples as
//! little-endian bytes, frames concatenated.

use std::path::Path;

use dicom_core::value::{DicomValueType as _, PrimitiveValue, Value};
use dicom_dictionary_std::tags;
use dicom_object::DefaultDicomObject;

use crate::error::{Error, Result};

/// The PixelData element's value, or an error naming the file.
fn pixel_value<'a>(
    path: &Path,
    obj: &'a DefaultDicomObject,
) -> Result<&'a Value<dicom_object::InMemDicomObject, Vec<u8>>> {
    obj.get(tags::PIXEL_DATA)
        .map(|e| e.value())
        .ok_or_else(|| Error::format(path, "no PixelData (7FE0,0010): expected an image"))
}

/// Uncompressed samples of `bits` bits as little-endian bytes: the file's bytes put back in
/// their order (dicom-rs parsed OW/OL into words of the file's byte order), then each
/// sample byte-swapped when the file is big endian.
pub fn little_endian_samples(
    path: &Path,
    obj: &DefaultDicomObject,
    bits: u16,
    big_endian: bool,
) -> Result<Vec<u8>> {
    let Some(value) = pixel_value(path, obj)?.primitive() else {
        return Err(Error::format(
            path,
            "PixelData is encapsulated (fragments) under an uncompressed transfer syntax: expected native pixel data",
        ));
    };
    let file_order: Vec<u8> = match value {
        PrimitiveValue::U8(v) => v.to_vec(),
        PrimitiveValue::U16(v) => words(v, big_endian, u16::to_be_bytes, u16::to_le_bytes),
        PrimitiveValue::I16(v) => words(v, big_endian, i16::to_be_bytes, i16::to_le_bytes),
        PrimitiveValue::U32(v) => words(v, big_endian, u32::to_be_bytes, u32::to_le_bytes),
        PrimitiveValue::I32(v) => words(v, big_endian, i32::to_be_bytes, i32::to_le_bytes),
        PrimitiveValue::Empty => Vec::new(),
        other => {
            return Err(Error::format(
                path,
                format!(
                    "PixelData holds {:?} values: expected bytes or words (VR OB or OW)",
                    other.value_type()
                ),
            ));
        }
    };
    if !big_endian || bits == 8 {
        return Ok(file_order);
    }
    let width = usize::from(bits / 8);
    let mut out = file_order;
    out.chunks_exact_mut(width).for_each(<[u8]>::reverse);
    Ok(out)
}

fn words<T: Copy, const N: usize>(
    values: &[T],
    big_endian: bool,
    be: fn(T) -> [u8; N],
    le: fn(T) -> [u8; N],
) -> Vec<u8> {
    let to = if big_endian { be } else { le };
    values.iter().flat_map(|v| to(*v)).collect()
}

/// RLE Lossless frames (one fragment each) decoded to little-endian samples of `bits`
/// bits, `frame_bytes` bytes a frame.
pub fn rle_frames(
    path: &Path,
    obj: &DefaultDicomObject,
    bits: u16,
    frames: u32,
    frame_bytes: usize,
) -> Result<Vec<u8>> {
    let fragments = pixel_value(path, obj)?.fragments().ok_or_else(|| {
        Error::format(
            path,
            "RLE Lossless pixel data is not encapsulated (no fragments)",
        )
    })?;
    if fragments.len() != frames as usize {
        return Err(Error::format(
            path,
            format!(
                "RLE Lossless pixel data holds {} fragments for {frames} frames: expected one fragment a frame",
                fragments.len()
            ),
        ));
    }
    let mut out = Vec::with_capacity(frame_bytes * fragments.len());
    for (k, fragment) in fragments.iter().enumerate() {
        let frame = rle_frame(fragment, usize::from(bits / 8), frame_bytes).map_err(|why| {
            Error::format(
                path,
                format!("cannot decode RLE frame {} of {frames}: {why}", k + 1),
            )
        })?;
        out.extend(frame);
    }
    Ok(out)
}

/// One RLE frame (PS3.5 G.3–G.5): a 64-byte header with the segment count and offsets,
/// then one PackBits segment per byte of a sample, most significant byte first.
pub fn rle_frame(
    data: &[u8],
    width: usize,
    frame_bytes: usize,
) -> std::result::Result<Vec<u8>, String> {
    let pixels = frame_bytes / width;
    let header = |i: usize| -> std::result::Result<usize, String> {
        data.get(4 * i..4 * i + 4)
            .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as usize)
            .ok_or_else(|| {
                format!(
                    "the fragment has {} bytes, too few for the 64-byte RLE header",
                    data.len()
                )
            })
    };
    let segments = header(0)?;
    if segments != width {
        return Err(format!(
            "{segments} segments, expected {width} (one per byte of a {}-bit sample)",
            8 * width
        ));
    }
    let mut out = vec![0u8; frame_bytes];
    for s in 0..segments {
        let start = header(1 + s)?;
        let end = if s + 1 < segments {
            header(2 + s)?
        } else {
            data.len()
        };
        let segment = data
            .get(start..end.max(start).min(data.len()))
            .unwrap_or(&[]);
        let bytes = packbits(segment, pixels)
            .map_err(|why| format!("segment {} at byte {start}: {why}", s + 1))?;
        // Segment s holds byte (width − 1 − s) of each little-endian sample.
        let byte = width - 1 - s;
        for (i, b) in bytes.into_iter().enumerate() {
            out[i * width + byte] = b;
        }
    }
    Ok(out)
}

/// PackBits: a header byte n ≥ 0 copies the next n + 1 bytes, −127…−1 repeats the next
/// byte 1 − n times, −128 does nothing. Exactly `count` bytes must come out.
fn packbits(data: &[u8], count: usize) -> std::result::Result<Vec<u8>, String> {
    let mut out = Vec::with_capacity(count);
    let mut i = 0;
    while out.len() < count {
        let Some(&n) = data.get(i) else {
            return Err(format!("ends after {} of {count} bytes", out.len()));
        };
        let n = n as i8;
        i += 1;
        if n >= 0 {
            let run = data
                .get(i..i + n as usize + 1)
                .ok_or("a literal run past the segment's end")?;
            out.extend_from_slice(run);
            i += n as usize + 1;
        } else if n != -128 {
            let b = *data
                .get(i)
                .ok_or("a replicate run past the segment's end")?;
            out.extend(std::iter::repeat_n(b, (1 - isize::from(n)) as usize));
            i += 1;
        }
    }
    out.truncate(count);
    Ok(out)
}

/// The sample precision of the first JPEG frame header (SOF0–SOF15 but DHT, JPG, DAC) in
/// the first fragment, if any.
pub fn jpeg_precision(obj: &DefaultDicomObject) -> Option<u8> {
    let fragment = obj.get(tags::PIXEL_DATA)?.value().fragments()?.first()?;
    let mut i = 2;
    while i + 4 < fragment.len() {
        if fragment[i] != 0xFF {
            return None;
        }
        let marker = fragment[i + 1];
        if (0xC0..=0xCF).contains(&marker) && !matches!(marker, 0xC4 | 0xC8 | 0xCC) {
            return fragment.get(i + 4).copied();
        }
        let length = usize::from(u16::from_be_bytes([fragment[i + 2], fragment[i + 3]]));
        i += 2 + length;
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn packbits_literal_and_replicate_runs() {
        // 2 literal bytes, 3 × 7, a no-op.
        let data = [1, 10, 20, (-2i8) as u8, 7, 0x80];
        assert_eq!(packbits(&data, 5).unwrap(), [10, 20, 7, 7, 7]);
        assert!(
            packbits(&data[..2], 5)
                .unwrap_err()
                .contains("past the segment")
        );
    }

    #[test]
    fn a_32_bit_rle_frame_puts_the_first_segment_in_the_top_byte() {
        let mut data = vec![0u8; 64];
        data[0] = 4;
        let mut segments = Vec::new();
        for (s, b) in [0x12u8, 0x34, 0x56, 0x78].into_iter().enumerate() {
            let offset = 64 + segments.len() as u32;
            data[4 + 4 * s..8 + 4 * s].copy_from_slice(&offset.to_le_bytes());
            segments.extend([(-1i8) as u8, b]); // two pixels
        }
        data.extend(segments);
        let frame = rle_frame(&data, 4, 8).unwrap();
        assert_eq!(frame, [0x78, 0x56, 0x34, 0x12, 0x78, 0x56, 0x34, 0x12]);
    }
}
