//! One pass over the files' headers (pixel data not read): every frame of every image
//! becomes a [`SliceHeader`] with its series, position, orientation and pixel format.

use std::path::{Path, PathBuf};

use std::borrow::Cow;

use dicom_core::header::Header as _;
use dicom_core::value::{C, PrimitiveValue};
use dicom_core::{DataElement, Tag, VR};
use dicom_dictionary_std::tags;
use dicom_object::mem::InMemElement;
use dicom_object::{DefaultDicomObject, InMemDicomObject};
use dicom_transfer_syntax_registry::{TransferSyntaxIndex, TransferSyntaxRegistry};

use super::open;
use crate::error::{Error, Result};
use crate::volume::formats::orient::cross;

/// What one frame of one file says about itself.
#[derive(Debug, Clone)]
pub struct SliceHeader {
    /// The file.
    pub path: PathBuf,
    /// Frame index within the file (0 for single-frame images).
    pub frame: u32,
    /// How many frames the file holds (1 for single-frame images).
    pub frames: u32,
    /// SeriesInstanceUID.
    pub series_uid: String,
    /// SeriesDescription (may be empty).
    pub description: String,
    /// Modality (CT, MR, …; may be empty).
    pub modality: String,
    /// Transfer syntax UID of the file.
    pub transfer_syntax: String,
    /// ImagePositionPatient: the centre of the first pixel, mm, LPS.
    pub position: [f64; 3],
    /// ImageOrientationPatient: row direction then column direction.
    pub orientation: [f64; 6],
    /// PixelSpacing: (between rows, between columns) in mm.
    pub pixel_spacing: [f64; 2],
    /// Rows, columns.
    pub size: [u32; 2],
    /// Pixel format.
    pub format: PixelFormat,
    /// RescaleSlope, RescaleIntercept (1, 0 when absent), times DoseGridScaling for RT
    /// Dose (modality values in Gy).
    pub rescale: [f64; 2],
    /// SliceThickness, used only for a single-slice series.
    pub thickness: Option<f64>,
}

/// How stored pixel values are encoded.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PixelFormat {
    /// BitsAllocated (8, 16 or 32).
    pub bits_allocated: u16,
    /// BitsStored.
    pub bits_stored: u16,
    /// PixelRepresentation = 1.
    pub signed: bool,
    /// PhotometricInterpretation MONOCHROME1 (higher stored value = darker).
    pub inverted: bool,
}

/// Why a file in a folder is not an image slice (skipped, counted in errors).
pub enum Skip {
    /// Not DICOM at all (no `DICM` magic, unreadable meta group).
    NotDicom(String),
    /// DICOM but no image (DICOMDIR, structured report, …).
    NoImage,
}

/// Reads the header of one file: its frames, or why it is no image. Only a regular file
/// is opened (a FIFO would block, a device never end): anything else is an error naming it,
/// and so is a DICOM file whose header is damaged ([`open`]).
pub fn scan(path: &Path) -> Result<std::result::Result<Vec<SliceHeader>, Skip>> {
    let (file, length) = crate::util::open_regular(path, "DICOM file")?;
    let reader = std::io::BufReader::new(file);
    let obj = match open::open(reader, length, open::Extent::Header) {
        Ok(o) => o,
        Err(open::Refusal::NotDicom(why)) => return Ok(Err(Skip::NotDicom(why))),
        Err(open::Refusal::Damaged(why)) => return Err(damaged(path, &why)),
    };
    if obj.get(tags::ROWS).is_none() {
        return Ok(Err(Skip::NoImage));
    }
    slices_of(path, &obj).map(Ok)
}

/// The error for a DICOM file that cannot be parsed.
pub fn damaged(path: &Path, why: &str) -> Error {
    Error::format(
        path,
        format!(
            "a damaged DICOM file: {why}; remove it from the folder (or list only the good files)"
        ),
    )
}

/// The header of every frame of one DICOM object (one for a classic slice, several for an
/// enhanced multi-frame object).
fn slices_of(path: &Path, obj: &DefaultDicomObject) -> Result<Vec<SliceHeader>> {
    let frames = frame_count(path, obj)?;
    let format = pixel_format(path, obj)?;
    let common = SliceCommon {
        path,
        obj,
        transfer_syntax: obj.meta().transfer_syntax().to_string(),
        size: [
            int(path, obj, tags::ROWS, "Rows")?,
            int(path, obj, tags::COLUMNS, "Columns")?,
        ],
        format,
        frames,
        offsets: frame_offsets(path, obj, frames)?,
    };
    (0..frames).map(|frame| common.frame(frame)).collect()
}

/// `NumberOfFrames` (1 when absent), at least 1.
fn frame_count(path: &Path, obj: &DefaultDicomObject) -> Result<u32> {
    let frames: u32 = match obj.get(tags::NUMBER_OF_FRAMES) {
        None => 1,
        Some(e) => e
            .to_int()
            .map_err(|_| bad(path, "NumberOfFrames", "a positive integer"))?,
    };
    if frames == 0 {
        return Err(bad(path, "NumberOfFrames", "at least 1 (the value is 0)"));
    }
    Ok(frames)
}

/// The pixel format of a greyscale image (one sample a pixel), checked.
fn pixel_format(path: &Path, obj: &DefaultDicomObject) -> Result<PixelFormat> {
    let samples = int(path, obj, tags::SAMPLES_PER_PIXEL, "SamplesPerPixel").unwrap_or(1);
    if samples != 1 {
        return Err(Error::format(
            path,
            format!("SamplesPerPixel is {samples}: only greyscale (1 sample) images form a volume"),
        ));
    }
    let photometric = text(obj, tags::PHOTOMETRIC_INTERPRETATION);
    let format = PixelFormat {
        bits_allocated: int(path, obj, tags::BITS_ALLOCATED, "BitsAllocated")?.min(64) as u16,
        bits_stored: int(path, obj, tags::BITS_STORED, "BitsStored")?.min(64) as u16,
        signed: int(path, obj, tags::PIXEL_REPRESENTATION, "PixelRepresentation")? == 1,
        inverted: photometric == "MONOCHROME1",
    };
    check_format(path, &format, &photometric)?;
    Ok(format)
}

/// What every frame of one object shares.
struct SliceCommon<'a> {
    path: &'a Path,
    obj: &'a DefaultDicomObject,
    transfer_syntax: String,
    size: [u32; 2],
    format: PixelFormat,
    frames: u32,
    /// Each frame's distance from ImagePositionPatient along the slice normal, mm.
    offsets: Vec<f64>,
}

impl SliceCommon<'_> {
    /// Frame `frame`'s header: its geometry and rescale from the object or, in an enhanced
    /// object, from the frame's functional groups.
    fn frame(&self, frame: u32) -> Result<SliceHeader> {
        let (path, obj) = (self.path, self.obj);
        let found = |tag, seq| functional(obj, frame, seq, tag);
        let position = floats::<3>(
            path,
            found(tags::IMAGE_POSITION_PATIENT, tags::PLANE_POSITION_SEQUENCE),
            "ImagePositionPatient",
            frame,
        )?;
        let orientation = floats::<6>(
            path,
            found(
                tags::IMAGE_ORIENTATION_PATIENT,
                tags::PLANE_ORIENTATION_SEQUENCE,
            ),
            "ImageOrientationPatient",
            frame,
        )?;
        let pixel_spacing = floats::<2>(
            path,
            found(tags::PIXEL_SPACING, tags::PIXEL_MEASURES_SEQUENCE),
            "PixelSpacing",
            frame,
        )?;
        check_pixel_spacing(path, pixel_spacing, frame)?;
        let thickness = found(tags::SLICE_THICKNESS, tags::PIXEL_MEASURES_SEQUENCE);
        let normal = cross(
            [orientation[0], orientation[1], orientation[2]],
            [orientation[3], orientation[4], orientation[5]],
        );
        let offset = self.offsets[frame as usize];
        Ok(SliceHeader {
            path: path.to_path_buf(),
            frame,
            frames: self.frames,
            series_uid: text(obj, tags::SERIES_INSTANCE_UID),
            description: text(obj, tags::SERIES_DESCRIPTION),
            modality: text(obj, tags::MODALITY),
            transfer_syntax: self.transfer_syntax.clone(),
            position: [0, 1, 2].map(|a| position[a] + offset * normal[a]),
            orientation,
            pixel_spacing,
            size: self.size,
            format: self.format,
            rescale: self.rescale(frame)?,
            thickness: optional_float(path, thickness, "SliceThickness")?,
        })
    }
}

impl SliceCommon<'_> {
    /// RescaleSlope and RescaleIntercept of `frame` (1 and 0 when absent or empty), times
    /// DoseGridScaling for RT Dose: the modality values PS3.3 C.8.8.3 defines (Gy).
    fn rescale(&self, frame: u32) -> Result<[f64; 2]> {
        let (path, obj) = (self.path, self.obj);
        let found = |tag| functional(obj, frame, tags::PIXEL_VALUE_TRANSFORMATION_SEQUENCE, tag);
        let slope = optional_float(path, found(tags::RESCALE_SLOPE), "RescaleSlope")?;
        let intercept = optional_float(path, found(tags::RESCALE_INTERCEPT), "RescaleIntercept")?;
        let mut rescale = [slope.unwrap_or(1.0), intercept.unwrap_or(0.0)];
        if text(obj, tags::MODALITY) == "RTDOSE" {
            let scaling =
                optional_float(path, obj.get(tags::DOSE_GRID_SCALING), "DoseGridScaling")?;
            if let Some(scaling) = scaling {
                rescale = rescale.map(|v| v * scaling);
            }
        }
        Ok(rescale)
    }
}

/// Each frame's offset along the slice normal from ImagePositionPatient, mm: from
/// GridFrameOffsetVector (3004,000C) in a multi-frame object without functional groups (an
/// RT Dose grid, PS3.3 C.8.8.3.2: relative offsets when the first is 0, else z coordinates
/// of an axial grid; either way the differences from the first), else 0.
fn frame_offsets(path: &Path, obj: &DefaultDicomObject, frames: u32) -> Result<Vec<f64>> {
    let zeros = vec![0.0; frames as usize];
    let grouped = obj
        .get(tags::PER_FRAME_FUNCTIONAL_GROUPS_SEQUENCE)
        .is_some();
    let Some(e) = obj
        .get(tags::GRID_FRAME_OFFSET_VECTOR)
        .filter(|_| frames > 1 && !grouped)
    else {
        return Ok(zeros);
    };
    let e = resolved(e);
    let v = e.to_multi_float64().unwrap_or_default();
    if v.len() < frames as usize || v.iter().any(|x| !x.is_finite()) {
        return Err(bad(
            path,
            "GridFrameOffsetVector (3004,000C)",
            &format!(
                "{frames} finite offsets, one a frame (found {} values: {:?})",
                v.len(),
                printable_value(&e)
            ),
        ));
    }
    Ok(v[..frames as usize].iter().map(|x| x - v[0]).collect())
}

/// The smallest and largest spacing, mm, between pixels or slices: 1 nm (electron
/// microscopy) to 10 m. Outside it the header is damaged or not in millimetres, and the
/// volume would be degenerate (a zero, negative or non-finite spacing is no volume at all).
pub const SPACING_RANGE_MM: [f64; 2] = [1e-6, 1e4];

/// Whether `mm` is a spacing in [`SPACING_RANGE_MM`].
pub fn plausible_spacing(mm: f64) -> bool {
    (SPACING_RANGE_MM[0]..=SPACING_RANGE_MM[1]).contains(&mm)
}

/// A length in mm for messages: fixed point for usual values, exponent for extreme ones.
pub fn mm(v: f64) -> String {
    if v == 0.0 || (1e-3..1e6).contains(&v.abs()) {
        format!("{v}")
    } else {
        format!("{v:e}")
    }
}

/// PixelSpacing must be two positive millimetre distances in [`SPACING_RANGE_MM`].
fn check_pixel_spacing(path: &Path, spacing: [f64; 2], frame: u32) -> Result<()> {
    if spacing.iter().all(|s| plausible_spacing(*s)) {
        return Ok(());
    }
    let of_frame = if frame > 0 {
        format!(" (frame {})", frame + 1)
    } else {
        String::new()
    };
    Err(Error::format(
        path,
        format!(
            "PixelSpacing (0028,0030) is [{}, {}]{of_frame}: expected two positive distances (between rows, \
             between columns) from {} to {} mm; the header is damaged or not in millimetres",
            mm(spacing[0]),
            mm(spacing[1]),
            mm(SPACING_RANGE_MM[0]),
            mm(SPACING_RANGE_MM[1])
        ),
    ))
}

fn check_format(path: &Path, f: &PixelFormat, photometric: &str) -> Result<()> {
    if !matches!(photometric, "MONOCHROME1" | "MONOCHROME2") {
        return Err(Error::format(
            path,
            format!(
                "PhotometricInterpretation is {photometric:?}: expected MONOCHROME1 or MONOCHROME2"
            ),
        ));
    }
    if !matches!(f.bits_allocated, 8 | 16 | 32)
        || f.bits_stored == 0
        || f.bits_stored > f.bits_allocated
    {
        return Err(Error::format(
            path,
            format!(
                "BitsAllocated {} / BitsStored {}: expected 8, 16 or 32 bits allocated and 1..=allocated stored",
                f.bits_allocated, f.bits_stored
            ),
        ));
    }
    Ok(())
}

/// Checks that the file's transfer syntax can be decoded by the built-in (pure-Rust) codecs.
pub fn check_transfer_syntax(path: &Path, uid: &str) -> Result<()> {
    match TransferSyntaxRegistry.get(uid) {
        None => Err(Error::format(
            path,
            format!("unknown transfer syntax {uid}: expected a DICOM transfer syntax UID"),
        )),
        Some(ts) if !ts.can_decode_all() => Err(Error::format(
            path,
            format!(
                "transfer syntax {uid} ({}) cannot be decoded here; supported are the uncompressed syntaxes, \
                 deflate, RLE lossless and JPEG baseline, extended (8-bit) and lossless (convert first, e.g. `gdcmconv --raw` or `dcmdjpeg`)",
                ts.name()
            ),
        )),
        Some(_) => Ok(()),
    }
}

/// An attribute of `frame`: in the frame's functional group item, the shared functional
/// groups, or (classic images) the top-level data set.
fn functional(obj: &InMemDicomObject, frame: u32, seq: Tag, tag: Tag) -> Option<&InMemElement> {
    let in_group = |group: Tag, index: usize| {
        obj.get(group)?
            .items()?
            .get(index)?
            .get(seq)?
            .items()?
            .first()?
            .get(tag)
    };
    in_group(tags::PER_FRAME_FUNCTIONAL_GROUPS_SEQUENCE, frame as usize)
        .or_else(|| in_group(tags::SHARED_FUNCTIONAL_GROUPS_SEQUENCE, 0))
        .or_else(|| obj.get(tag))
}

fn text(obj: &InMemDicomObject, tag: Tag) -> String {
    obj.get(tag)
        .and_then(|e| resolved(e).to_str().ok().map(|s| s.to_string()))
        .map(|s| s.trim_end_matches(['\0', ' ']).trim().to_string())
        .unwrap_or_default()
}

/// An element stored with VR UN (unknown, e.g. written by a system without the
/// dictionary) read with the VR the standard dictionary gives its tag, as pydicom and
/// PS3.5 §6.2.2 do: text split at `\\`, binary numbers little endian. Anything else, as it is.
fn resolved(e: &InMemElement) -> Cow<'_, InMemElement> {
    if e.vr() != VR::UN {
        return Cow::Borrowed(e);
    }
    let Ok(bytes) = e.to_bytes() else {
        return Cow::Borrowed(e);
    };
    let vr = open::dictionary_vr(e.tag());
    let value = match vr {
        VR::AE
        | VR::AS
        | VR::CS
        | VR::DA
        | VR::DS
        | VR::DT
        | VR::IS
        | VR::LO
        | VR::LT
        | VR::PN
        | VR::SH
        | VR::ST
        | VR::TM
        | VR::UC
        | VR::UI
        | VR::UR
        | VR::UT => {
            let text = String::from_utf8_lossy(&bytes);
            let parts: Vec<String> = text
                .split('\\')
                .map(|p| p.trim_matches(['\0', ' ']).to_string())
                .collect();
            PrimitiveValue::Strs(parts.into_iter().collect())
        }
        VR::US => PrimitiveValue::U16(words(&bytes, u16::from_le_bytes)),
        VR::SS => PrimitiveValue::I16(words(&bytes, i16::from_le_bytes)),
        VR::UL => PrimitiveValue::U32(words(&bytes, u32::from_le_bytes)),
        VR::SL => PrimitiveValue::I32(words(&bytes, i32::from_le_bytes)),
        VR::FL => PrimitiveValue::F32(words(&bytes, f32::from_le_bytes)),
        VR::FD => PrimitiveValue::F64(words(&bytes, f64::from_le_bytes)),
        _ => return Cow::Borrowed(e),
    };
    Cow::Owned(DataElement::new(e.tag(), vr, value))
}

/// Fixed-size numbers from little-endian bytes (a trailing partial number is dropped).
fn words<T, const N: usize>(bytes: &[u8], f: impl Fn([u8; N]) -> T) -> C<T> {
    bytes
        .chunks_exact(N)
        .map(|c| f(c.try_into().expect("chunks_exact gives N bytes")))
        .collect()
}

/// An element's value for a message: at most 48 characters, escaped.
fn printable_value(e: &InMemElement) -> String {
    let text = e.to_str().map(|s| s.to_string()).unwrap_or_default();
    let short: String = text.chars().take(48).collect();
    let more = if text.chars().count() > 48 { "…" } else { "" };
    format!("\"{}{more}\"", short.escape_debug())
}

fn int(path: &Path, obj: &InMemDicomObject, tag: Tag, name: &str) -> Result<u32> {
    let e = obj
        .get(tag)
        .ok_or_else(|| bad(path, name, "present (it is missing)"))?;
    let e = resolved(e);
    e.to_int::<u32>().map_err(|_| {
        bad(
            path,
            name,
            &format!("an integer (found {})", printable_value(&e)),
        )
    })
}

fn floats<const N: usize>(
    path: &Path,
    element: Option<&InMemElement>,
    name: &str,
    frame: u32,
) -> Result<[f64; N]> {
    let e = element.ok_or_else(|| {
        bad(
            path,
            name,
            &format!(
                "present for frame {} (it is missing; volphot needs it to place the slice)",
                frame + 1
            ),
        )
    })?;
    let e = resolved(e);
    let v = e.to_multi_float64().unwrap_or_default();
    <[f64; N]>::try_from(v.as_slice())
        .ok()
        .filter(|a| a.iter().all(|x| x.is_finite()))
        .ok_or_else(|| {
            bad(
                path,
                name,
                &format!("{N} finite numbers (found {})", printable_value(&e)),
            )
        })
}

/// An optional number: `None` when absent or empty (a type 2 element may be empty).
fn optional_float(path: &Path, element: Option<&InMemElement>, name: &str) -> Result<Option<f64>> {
    let Some(e) = element.map(resolved) else {
        return Ok(None);
    };
    if e.to_str()
        .is_ok_and(|s| s.trim_matches(['\0', ' ']).is_empty())
    {
        return Ok(None);
    }
    e.to_float64()
        .ok()
        .filter(|v| v.is_finite())
        .map(Some)
        .ok_or_else(|| {
            bad(
                path,
                name,
                &format!("a finite number (found {})", printable_value(&e)),
            )
        })
}

fn bad(path: &Path, name: &str, expected: &str) -> Error {
    Error::format(path, format!("{name}: expected {expected}"))
}
