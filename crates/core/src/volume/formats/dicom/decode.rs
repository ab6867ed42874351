//! Decoding the chosen slices into one x-fastest buffer: each file is read once (in
//! parallel), hashed, decoded by dicom-pixeldata's codecs and its frames converted to
//! modality values (HU for CT).

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use dicom_pixeldata::PixelDecoder;
use rayon::prelude::*;
use sha2::{Digest, Sha256};

use super::header::{PixelFormat, SliceHeader, damaged};
use super::{native, open};
use crate::error::{Error, Result};

/// The frames to decode from one file and where each goes.
type Frames<'a> = Vec<(&'a SliceHeader, &'a mut [f32])>;

/// Decodes `slices` (sorted) into `out` (one rows×columns block per slice) and returns the
/// sha256 of the files' contents in slice order.
pub fn decode_into(slices: &[SliceHeader], out: &mut [f32]) -> Result<String> {
    let per_slice = out.len() / slices.len();
    let mut files: Vec<(PathBuf, Frames)> = Vec::new();
    let mut index: HashMap<&Path, usize> = HashMap::new();
    for (s, chunk) in slices.iter().zip(out.chunks_mut(per_slice)) {
        let i = *index.entry(&s.path).or_insert_with(|| {
            files.push((s.path.clone(), Vec::new()));
            files.len() - 1
        });
        files[i].1.push((s, chunk));
    }
    let hashes: Vec<[u8; 32]> = files
        .into_par_iter()
        .map(|(path, frames)| decode_file(&path, frames))
        .collect::<Result<_>>()?;
    Ok(crate::util::sha256_bytes(&hashes.concat()))
}

fn decode_file(path: &Path, frames: Frames) -> Result<[u8; 32]> {
    let (mut file, length) = crate::util::open_regular(path, "DICOM file")?;
    let mut bytes = Vec::with_capacity(length as usize);
    std::io::Read::read_to_end(&mut file, &mut bytes).map_err(|e| Error::io(path, e))?;
    let hash: [u8; 32] = Sha256::digest(&bytes).into();
    let length = bytes.len() as u64;
    let obj = open::open(
        std::io::Cursor::new(&bytes[..]),
        length,
        open::Extent::Everything,
    )
    .map_err(|e| match e {
        open::Refusal::NotDicom(why) | open::Refusal::Damaged(why) => damaged(path, &why),
    })?;
    let Some((first, _)) = frames.first() else {
        return Ok(hash);
    };
    let format = first.format;
    let syntax = obj.meta().transfer_syntax().to_string();
    let frame_bytes =
        first.size[0] as usize * first.size[1] as usize * usize::from(format.bits_allocated / 8);
    let pixels = match Storage::of(&syntax) {
        Storage::Native { big_endian } => {
            native::little_endian_samples(path, &obj, format.bits_allocated, big_endian)?
        }
        Storage::Rle => {
            native::rle_frames(path, &obj, format.bits_allocated, first.frames, frame_bytes)?
        }
        Storage::Codec => codec_frames(path, &obj, &syntax)?,
    };
    for (s, out) in frames {
        let data = pixels.get(s.frame as usize * frame_bytes..(s.frame as usize + 1) * frame_bytes).ok_or_else(|| {
            Error::format(
                path,
                format!(
                    "pixel data holds {} bytes, too few for frame {} of {}×{} pixels at {} bits ({frame_bytes} bytes per frame): truncated",
                    pixels.len(),
                    s.frame + 1,
                    s.size[0],
                    s.size[1],
                    s.format.bits_allocated
                ),
            )
        })?;
        convert(data, &s.format, s.rescale, out);
    }
    Ok(hash)
}

/// How a transfer syntax stores the pixel data.
enum Storage {
    /// Uncompressed (the data set may be deflated): read here, in the file's byte order.
    Native { big_endian: bool },
    /// RLE Lossless (PS3.5 Annex G): decoded here, for 8, 16 and 32 bits.
    Rle,
    /// JPEG: dicom-pixeldata's pure-Rust codecs.
    Codec,
}

impl Storage {
    fn of(uid: &str) -> Storage {
        match uid {
            "1.2.840.10008.1.2" | "1.2.840.10008.1.2.1" | "1.2.840.10008.1.2.1.99" => {
                Storage::Native { big_endian: false }
            }
            "1.2.840.10008.1.2.2" => Storage::Native { big_endian: true },
            "1.2.840.10008.1.2.5" => Storage::Rle,
            _ => Storage::Codec,
        }
    }
}

/// JPEG pixel data decoded by dicom-pixeldata, as little-endian samples; an error gives the
/// codec's reason (the whole chain of causes), and 12-bit JPEG extended, which the
/// pure-Rust codecs cannot decode, is refused by name.
fn codec_frames(
    path: &Path,
    obj: &dicom_object::DefaultDicomObject,
    syntax: &str,
) -> Result<Vec<u8>> {
    if let Some(precision) = native::jpeg_precision(obj).filter(|p| *p > 8)
        && matches!(syntax, "1.2.840.10008.1.2.4.51" | "1.2.840.10008.1.2.4.50")
    {
        return Err(Error::format(
            path,
            format!(
                "transfer syntax {syntax} (JPEG extended) with {precision}-bit samples cannot be decoded here \
                 (the pure-Rust JPEG codec reads 8-bit DCT and lossless JPEG); convert first, e.g. `gdcmconv --raw` or `dcmdjpeg`"
            ),
        ));
    }
    let pixels = obj.decode_pixel_data().map_err(|e| {
        Error::format(
            path,
            format!("cannot decode the pixel data ({syntax}): {}", causes(&e)),
        )
    })?;
    Ok(pixels.data().to_vec())
}

/// An error and its causes, joined: "Could not decode pixel data: …: the codec's reason".
fn causes(e: &dyn std::error::Error) -> String {
    let mut text = e.to_string();
    let mut source = e.source();
    while let Some(s) = source {
        let next = s.to_string();
        if !text.ends_with(&next) {
            text += &format!(": {next}");
        }
        source = s.source();
    }
    open::printable(&text)
}

/// Stored values (masked to BitsStored, sign-extended when signed, inverted for
/// MONOCHROME1) times RescaleSlope plus RescaleIntercept.
pub fn convert(bytes: &[u8], f: &PixelFormat, rescale: [f64; 2], out: &mut [f32]) {
    let bits = u32::from(f.bits_stored);
    let mask: u64 = if bits >= 64 {
        u64::MAX
    } else {
        (1u64 << bits) - 1
    };
    let sign = 1u64 << (bits - 1);
    let [slope, intercept] = rescale;
    let value = |raw: u64| -> f32 {
        let v = raw & mask;
        let mut x = if f.signed && v & sign != 0 {
            v as i64 - (mask as i64) - 1
        } else {
            v as i64
        };
        if f.inverted {
            x = if f.signed { -1 - x } else { mask as i64 - x };
        }
        (slope * x as f64 + intercept) as f32
    };
    match f.bits_allocated {
        8 => out
            .iter_mut()
            .zip(bytes)
            .for_each(|(o, &b)| *o = value(u64::from(b))),
        16 => out
            .iter_mut()
            .zip(bytes.chunks_exact(2))
            .for_each(|(o, c)| *o = value(u64::from(u16::from_le_bytes([c[0], c[1]])))),
        _ => out
            .iter_mut()
            .zip(bytes.chunks_exact(4))
            .for_each(|(o, c)| *o = value(u64::from(u32::from_le_bytes([c[0], c[1], c[2], c[3]])))),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn format(bits_allocated: u16, bits_stored: u16, signed: bool, inverted: bool) -> PixelFormat {
        PixelFormat {
            bits_allocated,
            bits_stored,
            signed,
            inverted,
        }
    }

    #[test]
    fn twelve_bit_signed_is_masked_and_sign_extended() {
        // 0xF800 has garbage above bit 11; the low 12 bits 0x800 are −2048.
        let bytes = [0x00, 0xF8, 0xFF, 0x07];
        let mut out = [0.0; 2];
        convert(&bytes, &format(16, 12, true, false), [1.0, 0.0], &mut out);
        assert_eq!(out, [-2048.0, 2047.0]);
    }

    #[test]
    fn rescale_and_monochrome1_inversion() {
        let mut out = [0.0; 2];
        convert(
            &[0, 255],
            &format(8, 8, false, true),
            [2.0, -10.0],
            &mut out,
        );
        assert_eq!(out, [500.0, -10.0]);
        let bytes = 1000i16.to_le_bytes();
        let mut one = [0.0];
        convert(&bytes, &format(16, 16, true, true), [1.0, 0.0], &mut one);
        assert_eq!(one, [-1001.0]);
    }
}
