//! NIfTI-1: single files (`.nii`, `.nii.gz`) and `.hdr`/`.img` pairs (either part may be
//! gzipped), read here byte for byte. The 348-byte header is read and checked first —
//! magic, dims against the memory budget, datatype, bitpix, vox_offset, scaling, voxel
//! sizes — and only then are the voxels read from vox_offset, with a bound ([`stream`]).
//! Values are times `scl_slope` plus `scl_inter`; voxel axes come from the sform
//! (preferred) or the qform, converted from NIfTI's RAS to LPS and oriented onto the grid
//! axes like DICOM (exactly for axis-aligned volumes; oblique ones keep their own frame).

mod datatype;
mod header;
mod stream;

use std::path::{Path, PathBuf};

use self::header::{Header, Layout, Storage};
use self::stream::Source;
use super::orient::{PatientAxes, reorient};
use super::{Acquisition, LoadedVoxels};
use crate::error::{Error, Result};

/// Whether `path` names a NIfTI-1 file: `.nii`, or a pair's header `.hdr` (either may
/// end in `.gz`).
pub fn is_nifti(path: &Path) -> bool {
    storage_of(path).is_some()
}

fn storage_of(path: &Path) -> Option<Storage> {
    let name = path.file_name()?.to_str()?.to_ascii_lowercase();
    let name = name.strip_suffix(".gz").unwrap_or(&name);
    if name.ends_with(".nii") {
        Some(Storage::SingleFile)
    } else if name.ends_with(".hdr") {
        Some(Storage::Pair)
    } else {
        None
    }
}

/// Reads a NIfTI-1 volume.
pub fn read(path: &Path) -> Result<LoadedVoxels> {
    let storage = storage_of(path).ok_or_else(|| {
        Error::format(
            path,
            "expected a NIfTI-1 file: .nii, .nii.gz, .hdr or .hdr.gz",
        )
    })?;
    let mut source = Source::open(path, "NIfTI-1 file")?;
    let header = Header::parse(path, &source.read_header(path)?)?;
    let layout = header::check(path, &header, storage)?;
    let (axes, frame) = axes_of(path, &header, layout.dims)?;
    let (values, data_path) = match storage {
        Storage::SingleFile => (source.read_voxels(path, &layout)?, path.to_path_buf()),
        Storage::Pair => {
            let img = pair_image(path)?;
            let values = Source::open(&img, "NIfTI-1 image (.img)")?.read_voxels(&img, &layout)?;
            (values, img)
        }
    };
    let values = rescaled(values, layout.rescale);
    let (map, orientation) = axes.grid_map();
    let (values, dims) = reorient(values, layout.dims, &map);
    let spacing = axes.grid_spacing(&map);
    Ok(LoadedVoxels {
        dims,
        values,
        voxel_type: voxel_type(&layout),
        spacing: Some(spacing.map(|s| s as f32)),
        data_path,
        format: "nifti",
        acquisition: Some(Acquisition {
            format: "nifti".into(),
            series_uid: None,
            description: Some(
                String::from_utf8_lossy(&header.descrip)
                    .trim_end_matches(['\0', ' '])
                    .trim()
                    .to_string(),
            )
            .filter(|d| !d.is_empty()),
            modality: None,
            slices: dims[2],
            files: if storage == Storage::Pair { 2 } else { 1 },
            spacing_mm: spacing,
            rescale: vec![layout.rescale],
            orientation,
            choice: frame,
        }),
    })
}

/// The `.img` (or `.img.gz`) beside a pair's `.hdr`.
fn pair_image(header_path: &Path) -> Result<PathBuf> {
    let name = header_path
        .file_name()
        .and_then(|n| n.to_str())
        .unwrap_or_default();
    let lower = name.to_ascii_lowercase();
    let stem_len = lower
        .strip_suffix(".gz")
        .unwrap_or(&lower)
        .strip_suffix(".hdr")
        .map_or(name.len(), str::len);
    let stem = &name[..stem_len];
    let candidates =
        [".img", ".img.gz"].map(|ext| header_path.with_file_name(format!("{stem}{ext}")));
    let found = candidates.iter().find(|p| p.exists()).ok_or_else(|| {
        Error::format(
            header_path,
            format!(
                "the header of a .hdr/.img pair, but neither {} nor {} exists beside it",
                candidates[0].display(),
                candidates[1].display()
            ),
        )
    })?;
    // Beside the header, as if the header named it: a link must not lead it elsewhere.
    let folder = header_path.parent().unwrap_or(Path::new(""));
    crate::util::confined(
        folder,
        Path::new(found.file_name().unwrap_or_default()),
        "the header's folder",
    )
}

/// Values times scl_slope plus scl_inter (in f64, then back to f32).
fn rescaled(mut values: Vec<f32>, [slope, inter]: [f64; 2]) -> Vec<f32> {
    if [slope, inter] != [1.0, 0.0] {
        for v in &mut values {
            *v = (f64::from(*v) * slope + inter) as f32;
        }
    }
    values
}

/// The stored type, or `f32` once scaled.
fn voxel_type(layout: &Layout) -> super::VoxelType {
    if layout.rescale == [1.0, 0.0] {
        layout.datatype.voxel_type()
    } else {
        super::VoxelType::F32
    }
}

/// The voxel axes in LPS from the sform (code > 0), else the qform (code > 0), else the
/// pixdim spacing with the voxel order kept; plus which one was used. The voxel sizes
/// must be able to place the volume ([`sizes_fit`]).
fn axes_of(path: &Path, h: &Header, dims: [usize; 3]) -> Result<(PatientAxes, String)> {
    let (ras, frame): ([[f64; 3]; 3], String) = if h.sform_code > 0 {
        let rows = h.srow.map(|r| r.map(f64::from));
        (
            [0, 1, 2].map(|s| [rows[0][s], rows[1][s], rows[2][s]]),
            format!("sform (code {})", h.sform_code),
        )
    } else if h.qform_code > 0 {
        check_pixdim(path, h, dims, "the qform scales its rotation by them")?;
        (qform_columns(h), format!("qform (code {})", h.qform_code))
    } else {
        check_pixdim(path, h, dims, "there is no sform or qform")?;
        let d = [1, 2, 3].map(|i| f64::from(h.pixdim[i]).abs());
        let axes = PatientAxes {
            directions: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
            spacing: d,
        };
        return Ok((
            axes,
            "no sform or qform: voxel order kept, spacing from pixdim, patient axes unknown".into(),
        ));
    };
    let mut directions = [[0.0; 3]; 3];
    let mut spacing = [0.0; 3];
    for s in 0..3 {
        // RAS → LPS: negate x and y.
        let c = [-ras[s][0], -ras[s][1], ras[s][2]];
        let n = (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt();
        if !(n.is_finite() && n > 0.0) {
            return Err(Error::format(
                path,
                format!("{frame}: voxel axis {s} has length {n}; expected a non-degenerate affine"),
            ));
        }
        directions[s] = c.map(|v| v / n);
        spacing[s] = n;
    }
    sizes_fit(spacing, dims).map_err(|why| {
        Error::format(path, format!("{frame}: voxel sizes {spacing:?} mm: {why}"))
    })?;
    Ok((
        PatientAxes {
            directions,
            spacing,
        },
        frame,
    ))
}

/// Why voxel sizes (mm, per file axis) cannot place a volume of `dims`, if they cannot: each
/// must be finite and not 0 as the grid's `f32`, the extent over the dims finite, and no side
/// under a millionth of the longest (it would be flat once the longest is scaled to 1).
fn sizes_fit(sizes: [f64; 3], dims: [usize; 3]) -> Result<(), String> {
    let narrow = sizes.map(|s| s.abs() as f32);
    if !narrow.iter().all(|s| s.is_finite() && *s > 0.0) {
        return Err("expected voxel sizes in mm, finite and not 0".into());
    }
    let extent = [0, 1, 2].map(|i| sizes[i].abs() * dims[i] as f64);
    let longest = extent.iter().copied().fold(0.0, f64::max);
    if !(longest as f32).is_finite() || extent.iter().any(|&e| e < longest * 1e-6) {
        return Err(format!(
            "the extent over dims {dims:?} is {extent:?} mm; expected it finite, no side under a millionth of the longest"
        ));
    }
    Ok(())
}

/// The voxel sizes `pixdim[1..3]`, where they give the spacing, must fit (a 0 or NaN
/// would only surface later as the scene's `spacing`, far from its cause).
fn check_pixdim(path: &Path, h: &Header, dims: [usize; 3], why_used: &str) -> Result<()> {
    let sizes = [h.pixdim[1], h.pixdim[2], h.pixdim[3]];
    sizes_fit(sizes.map(f64::from), dims).map_err(|why| {
        let shown: Vec<String> = sizes.iter().map(|&s| header::number(s)).collect();
        Error::format(
            path,
            format!("pixdim[1..3] = [{}]: {why} ({why_used})", shown.join(", ")),
        )
    })
}

/// Columns of the qform matrix (nifti1.h): rotation from the quaternion times pixdim,
/// the third column times qfac.
fn qform_columns(h: &Header) -> [[f64; 3]; 3] {
    let [b, c, d] = h.quatern.map(f64::from);
    let a = (1.0 - (b * b + c * c + d * d)).max(0.0).sqrt();
    let r = [
        [
            a * a + b * b - c * c - d * d,
            2.0 * (b * c - a * d),
            2.0 * (b * d + a * c),
        ],
        [
            2.0 * (b * c + a * d),
            a * a + c * c - b * b - d * d,
            2.0 * (c * d - a * b),
        ],
        [
            2.0 * (b * d - a * c),
            2.0 * (c * d + a * b),
            a * a + d * d - c * c - b * b,
        ],
    ];
    let qfac = if h.pixdim[0] < 0.0 { -1.0 } else { 1.0 };
    let scale = [
        f64::from(h.pixdim[1]),
        f64::from(h.pixdim[2]),
        f64::from(h.pixdim[3]) * qfac,
    ];
    [0, 1, 2].map(|s| [r[0][s] * scale[s], r[1][s] * scale[s], r[2][s] * scale[s]])
}
