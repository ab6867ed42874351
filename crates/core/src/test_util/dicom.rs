//! Writes small DICOM files with the dicom-rs crates for the reader's tests: classic
//! single-frame CT slices and enhanced multi-frame objects, with any position,
//! orientation, storage (signed or not, BitsStored), photometric interpretation, rescale
//! and transfer syntax.

use std::path::Path;

use dicom_core::value::{DataSetSequence, PixelFragmentSequence, PrimitiveValue};
use dicom_core::{DataElement, Length, Tag, VR};
use dicom_dictionary_std::{tags, uids};
use dicom_object::{FileMetaTableBuilder, InMemDicomObject};

/// One file to write.
#[derive(Debug, Clone)]
pub struct SliceSpec {
    /// SeriesInstanceUID.
    pub series_uid: String,
    /// SeriesDescription.
    pub description: String,
    /// SOPInstanceUID (must be unique per file).
    pub sop_uid: String,
    /// ImagePositionPatient of each frame (one entry: a classic single-frame image; more:
    /// an enhanced multi-frame object with per-frame functional groups).
    pub positions: Vec<[f64; 3]>,
    /// ImageOrientationPatient.
    pub orientation: [f64; 6],
    /// PixelSpacing (between rows, between columns).
    pub pixel_spacing: [f64; 2],
    /// Rows, columns.
    pub size: [u16; 2],
    /// PixelRepresentation 1.
    pub signed: bool,
    /// BitsStored (BitsAllocated is 16).
    pub bits_stored: u16,
    /// MONOCHROME1 instead of MONOCHROME2.
    pub monochrome1: bool,
    /// RescaleSlope, RescaleIntercept.
    pub rescale: [f64; 2],
    /// Transfer syntax UID; anything but the uncompressed ones writes the words as one
    /// encapsulated fragment (enough to test that the reader refuses it).
    pub transfer_syntax: String,
}

impl SliceSpec {
    /// A 16-bit signed axial CT slice at `z` (orientation 1,0,0,0,1,0; spacing 0.5 × 0.75).
    pub fn ct(series_uid: &str, sop_uid: &str, z: f64, size: [u16; 2]) -> Self {
        SliceSpec {
            series_uid: series_uid.into(),
            description: "volphot test series".into(),
            sop_uid: sop_uid.into(),
            positions: vec![[-100.0, -120.0, z]],
            orientation: [1.0, 0.0, 0.0, 0.0, 1.0, 0.0],
            pixel_spacing: [0.75, 0.5],
            size,
            signed: true,
            bits_stored: 16,
            monochrome1: false,
            rescale: [1.0, 0.0],
            transfer_syntax: uids::EXPLICIT_VR_LITTLE_ENDIAN.into(),
        }
    }
}

fn ds(values: &[f64]) -> PrimitiveValue {
    PrimitiveValue::Strs(values.iter().map(|v| format!("{v:.6}")).collect())
}

fn us(v: u16) -> PrimitiveValue {
    PrimitiveValue::from(v)
}

fn sequence(items: Vec<InMemDicomObject>) -> DataSetSequence<InMemDicomObject> {
    DataSetSequence::new(items, Length::UNDEFINED)
}

fn item(elements: Vec<DataElement<InMemDicomObject>>) -> InMemDicomObject {
    InMemDicomObject::from_element_iter(elements)
}

/// Writes `spec` with `words` (stored values as 16-bit words, row-major, frames
/// concatenated) to `path`.
pub fn write_slice(path: &Path, spec: &SliceSpec, words: &[u16]) -> Result<(), String> {
    let mut obj = InMemDicomObject::new_empty();
    let multi = spec.positions.len() > 1;
    put_identity(&mut obj, spec, multi);
    put_pixel_module(&mut obj, spec);
    if multi {
        put_functional_groups(&mut obj, spec);
    } else {
        put_plane(&mut obj, spec);
    }
    put_pixel_data(&mut obj, spec, words);
    let file = obj
        .with_meta(FileMetaTableBuilder::new().transfer_syntax(spec.transfer_syntax.as_str()))
        .map_err(|e| format!("{}: meta: {e}", path.display()))?;
    file.write_to_file(path)
        .map_err(|e| format!("{}: write: {e}", path.display()))
}

/// Puts one element.
fn put(obj: &mut InMemDicomObject, tag: Tag, vr: VR, value: PrimitiveValue) {
    obj.put(DataElement::new(tag, vr, value));
}

/// The SOP class (enhanced CT for several frames) and instance, modality, study and
/// series.
fn put_identity(obj: &mut InMemDicomObject, spec: &SliceSpec, multi: bool) {
    let class = if multi {
        uids::ENHANCED_CT_IMAGE_STORAGE
    } else {
        uids::CT_IMAGE_STORAGE
    };
    put(obj, tags::SOP_CLASS_UID, VR::UI, class.into());
    put(
        obj,
        tags::SOP_INSTANCE_UID,
        VR::UI,
        spec.sop_uid.as_str().into(),
    );
    put(obj, tags::MODALITY, VR::CS, "CT".into());
    put(obj, tags::STUDY_INSTANCE_UID, VR::UI, "2.25.1".into());
    put(
        obj,
        tags::SERIES_INSTANCE_UID,
        VR::UI,
        spec.series_uid.as_str().into(),
    );
    put(
        obj,
        tags::SERIES_DESCRIPTION,
        VR::LO,
        spec.description.as_str().into(),
    );
}

/// The image pixel module: one greyscale sample, size, 16 bits allocated, signedness.
fn put_pixel_module(obj: &mut InMemDicomObject, spec: &SliceSpec) {
    put(obj, tags::SAMPLES_PER_PIXEL, VR::US, us(1));
    let photometric = if spec.monochrome1 {
        "MONOCHROME1"
    } else {
        "MONOCHROME2"
    };
    put(
        obj,
        tags::PHOTOMETRIC_INTERPRETATION,
        VR::CS,
        photometric.into(),
    );
    put(obj, tags::ROWS, VR::US, us(spec.size[0]));
    put(obj, tags::COLUMNS, VR::US, us(spec.size[1]));
    put(obj, tags::BITS_ALLOCATED, VR::US, us(16));
    put(obj, tags::BITS_STORED, VR::US, us(spec.bits_stored));
    put(obj, tags::HIGH_BIT, VR::US, us(spec.bits_stored - 1));
    put(
        obj,
        tags::PIXEL_REPRESENTATION,
        VR::US,
        us(u16::from(spec.signed)),
    );
}

/// A single frame's plane (position, orientation, spacing) and rescale.
fn put_plane(obj: &mut InMemDicomObject, spec: &SliceSpec) {
    put(
        obj,
        tags::IMAGE_POSITION_PATIENT,
        VR::DS,
        ds(&spec.positions[0]),
    );
    put(
        obj,
        tags::IMAGE_ORIENTATION_PATIENT,
        VR::DS,
        ds(&spec.orientation),
    );
    put(obj, tags::PIXEL_SPACING, VR::DS, ds(&spec.pixel_spacing));
    put(obj, tags::RESCALE_SLOPE, VR::DS, ds(&spec.rescale[..1]));
    put(obj, tags::RESCALE_INTERCEPT, VR::DS, ds(&spec.rescale[1..]));
}

/// The pixel data: native words, RLE fragments, or one fragment of raw bytes for any
/// other (encapsulated) transfer syntax.
fn put_pixel_data(obj: &mut InMemDicomObject, spec: &SliceSpec, words: &[u16]) {
    let native = [
        uids::EXPLICIT_VR_LITTLE_ENDIAN,
        uids::IMPLICIT_VR_LITTLE_ENDIAN,
    ]
    .contains(&spec.transfer_syntax.as_str());
    if native {
        obj.put(DataElement::new(
            tags::PIXEL_DATA,
            VR::OW,
            PrimitiveValue::U16(words.iter().copied().collect()),
        ));
    } else if spec.transfer_syntax == uids::RLE_LOSSLESS {
        let (rows, cols) = (spec.size[0] as usize, spec.size[1] as usize);
        obj.put(DataElement::new(
            tags::PIXEL_DATA,
            VR::OB,
            PixelFragmentSequence::new(vec![], rle_frames(words, rows, cols)),
        ));
    } else {
        let bytes: Vec<u8> = words.iter().flat_map(|w| w.to_le_bytes()).collect();
        obj.put(DataElement::new(
            tags::PIXEL_DATA,
            VR::OB,
            PixelFragmentSequence::new(vec![], vec![bytes]),
        ));
    }
}

fn put_functional_groups(obj: &mut InMemDicomObject, spec: &SliceSpec) {
    let frames: Vec<InMemDicomObject> = spec
        .positions
        .iter()
        .map(|p| {
            let position = item(vec![DataElement::new(
                tags::IMAGE_POSITION_PATIENT,
                VR::DS,
                ds(p),
            )]);
            item(vec![DataElement::new(
                tags::PLANE_POSITION_SEQUENCE,
                VR::SQ,
                sequence(vec![position]),
            )])
        })
        .collect();
    let orientation = item(vec![DataElement::new(
        tags::IMAGE_ORIENTATION_PATIENT,
        VR::DS,
        ds(&spec.orientation),
    )]);
    let measures = item(vec![DataElement::new(
        tags::PIXEL_SPACING,
        VR::DS,
        ds(&spec.pixel_spacing),
    )]);
    let transform = item(vec![
        DataElement::new(tags::RESCALE_SLOPE, VR::DS, ds(&spec.rescale[..1])),
        DataElement::new(tags::RESCALE_INTERCEPT, VR::DS, ds(&spec.rescale[1..])),
    ]);
    let shared = item(vec![
        DataElement::new(
            tags::PLANE_ORIENTATION_SEQUENCE,
            VR::SQ,
            sequence(vec![orientation]),
        ),
        DataElement::new(
            tags::PIXEL_MEASURES_SEQUENCE,
            VR::SQ,
            sequence(vec![measures]),
        ),
        DataElement::new(
            tags::PIXEL_VALUE_TRANSFORMATION_SEQUENCE,
            VR::SQ,
            sequence(vec![transform]),
        ),
    ]);
    obj.put(DataElement::new(
        tags::SHARED_FUNCTIONAL_GROUPS_SEQUENCE,
        VR::SQ,
        sequence(vec![shared]),
    ));
    obj.put(DataElement::new(
        tags::PER_FRAME_FUNCTIONAL_GROUPS_SEQUENCE,
        VR::SQ,
        sequence(frames),
    ));
    obj.put(DataElement::new(
        tags::NUMBER_OF_FRAMES,
        VR::IS,
        PrimitiveValue::from(spec.positions.len().to_string()),
    ));
}

/// RLE Lossless (PS3.5 Annex G) fragments, one per frame of `rows × cols` 16-bit words: a
/// 64-byte header with two segment offsets, then the high bytes and the low bytes of the
/// frame, each PackBits-encoded row by row and padded to even length.
fn rle_frames(words: &[u16], rows: usize, cols: usize) -> Vec<Vec<u8>> {
    words
        .chunks(rows * cols)
        .map(|frame| {
            let segments: Vec<Vec<u8>> = [1usize, 0]
                .iter()
                .map(|&byte| {
                    let plane: Vec<u8> = frame.iter().map(|w| w.to_le_bytes()[byte]).collect();
                    let mut segment: Vec<u8> = plane.chunks(cols).flat_map(packbits).collect();
                    if segment.len() % 2 == 1 {
                        segment.push(0);
                    }
                    segment
                })
                .collect();
            let mut header = [0u32; 16];
            header[0] = 2;
            header[1] = 64;
            header[2] = 64 + segments[0].len() as u32;
            let mut out: Vec<u8> = header.iter().flat_map(|h| h.to_le_bytes()).collect();
            segments.iter().for_each(|s| out.extend(s));
            out
        })
        .collect()
}

/// PackBits: runs of 3 or more equal bytes as replicate runs (`257 − n`, byte), the rest
/// as literal runs (`n − 1`, bytes), at most 128 bytes per run.
fn packbits(row: &[u8]) -> Vec<u8> {
    let mut out = Vec::new();
    let mut i = 0;
    while i < row.len() {
        let run = row[i..]
            .iter()
            .take(128)
            .take_while(|&&b| b == row[i])
            .count();
        if run >= 3 {
            out.extend([(257 - run) as u8, row[i]]);
            i += run;
            continue;
        }
        let start = i;
        while i < row.len() && i - start < 128 {
            let ahead = row[i..]
                .iter()
                .take(3)
                .take_while(|&&b| b == row[i])
                .count();
            if ahead >= 3 {
                break;
            }
            i += 1;
        }
        out.push((i - start - 1) as u8);
        out.extend(&row[start..i]);
    }
    out
}
