//! NIfTI-1 (`.nii`, `.nii.gz`) through the `nifti` crate: values times `scl_slope` plus
//! `scl_inter`, voxel axes from the sform (preferred) or the qform, converted from NIfTI's
//! RAS to LPS and oriented onto the grid axes like DICOM (exactly for axis-aligned
//! volumes; oblique ones keep their own frame).

use std::path::Path;

use nifti::{IntoNdArray, NiftiHeader, NiftiObject, NiftiType, ReaderOptions};

use super::orient::{PatientAxes, reorient};
use super::{Acquisition, LoadedVoxels, VoxelType, check_dims};
use crate::error::{Error, Result};

/// Whether `path` names a NIfTI-1 file (`.nii` or `.nii.gz`).
pub fn is_nifti(path: &Path) -> bool {
    let name = path
        .file_name()
        .and_then(|n| n.to_str())
        .unwrap_or_default()
        .to_ascii_lowercase();
    name.ends_with(".nii") || name.ends_with(".nii.gz")
}

/// Reads a NIfTI-1 volume.
pub fn read(path: &Path) -> Result<LoadedVoxels> {
    let obj = ReaderOptions::new()
        .read_file(path)
        .map_err(|e| nifti_error(path, e))?;
    let header = obj.header().clone();
    let dims = dims_of(path, &header)?;
    check_dims(path, dims)?;
    let datatype = header.data_type().map_err(|e| nifti_error(path, e))?;
    let array = obj
        .into_volume()
        .into_ndarray::<f32>()
        .map_err(|e| nifti_error(path, e))?;
    // The array is indexed [x, y, z] in Fortran order: its transpose iterates x fastest.
    let values: Vec<f32> = array.t().iter().copied().collect();
    let rescale = if header.scl_slope == 0.0 {
        [1.0, 0.0]
    } else {
        [f64::from(header.scl_slope), f64::from(header.scl_inter)]
    };
    let (axes, frame) = axes_of(path, &header)?;
    let (map, orientation) = axes.grid_map();
    let (values, dims) = reorient(values, dims, &map);
    let spacing = axes.grid_spacing(&map);
    Ok(LoadedVoxels {
        dims,
        values,
        voxel_type: voxel_type(datatype, rescale),
        spacing: Some(spacing.map(|s| s as f32)),
        data_path: path.to_path_buf(),
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
            files: 1,
            spacing_mm: spacing,
            rescale: vec![rescale],
            orientation,
            choice: frame,
        }),
    })
}

fn nifti_error(path: &Path, e: nifti::NiftiError) -> Error {
    let message = match e {
        nifti::NiftiError::IncompatibleLength(got, expected) => format!(
            "the file holds {got} bytes of voxel data but its header's dims and datatype need {expected}: truncated or a wrong header"
        ),
        nifti::NiftiError::Io(io) => {
            format!("cannot read the NIfTI-1 data ({io}): truncated or damaged (gzip) file?")
        }
        nifti::NiftiError::InvalidFormat => {
            "not a NIfTI-1 file (bad header size or magic; NIfTI-2 is not supported)".to_string()
        }
        other => format!("cannot read the NIfTI-1 file: {other}"),
    };
    Error::format(path, message)
}

fn dims_of(path: &Path, h: &NiftiHeader) -> Result<[usize; 3]> {
    let dim = h.dim().map_err(|e| nifti_error(path, e))?;
    if dim.len() > 3 && dim[3..].iter().any(|&n| n > 1) {
        return Err(Error::format(
            path,
            format!(
                "dims {dim:?}: a {}-D image with more than one volume; expected a 3-D volume",
                dim.len()
            ),
        ));
    }
    let at = |i: usize| dim.get(i).map_or(1, |&n| usize::from(n));
    Ok([at(0), at(1), at(2)])
}

/// The voxel axes in LPS from the sform (code > 0), else the qform (code > 0), else the
/// pixdim spacing with the voxel order kept; plus which one was used.
fn axes_of(path: &Path, h: &NiftiHeader) -> Result<(PatientAxes, String)> {
    let (ras, frame): ([[f64; 3]; 3], String) = if h.sform_code > 0 {
        let rows = [h.srow_x, h.srow_y, h.srow_z].map(|r| r.map(f64::from));
        (
            [0, 1, 2].map(|s| [rows[0][s], rows[1][s], rows[2][s]]),
            format!("sform (code {})", h.sform_code),
        )
    } else if h.qform_code > 0 {
        (qform_columns(h), format!("qform (code {})", h.qform_code))
    } else {
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
    Ok((
        PatientAxes {
            directions,
            spacing,
        },
        frame,
    ))
}

/// Columns of the qform matrix (nifti1.h): rotation from the quaternion times pixdim,
/// the third column times qfac.
fn qform_columns(h: &NiftiHeader) -> [[f64; 3]; 3] {
    let (b, c, d) = (
        f64::from(h.quatern_b),
        f64::from(h.quatern_c),
        f64::from(h.quatern_d),
    );
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

fn voxel_type(t: NiftiType, rescale: [f64; 2]) -> VoxelType {
    if rescale != [1.0, 0.0] {
        return VoxelType::F32;
    }
    match t {
        NiftiType::Uint8 => VoxelType::U8,
        NiftiType::Int8 => VoxelType::I8,
        NiftiType::Uint16 => VoxelType::U16,
        NiftiType::Int16 => VoxelType::I16,
        _ => VoxelType::F32,
    }
}
