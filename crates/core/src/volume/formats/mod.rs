//! Volume file formats: headerless RAW, NRRD (attached or detached, raw or gzip),
//! MetaImage (`.mhd`/`.mha`, raw or zlib), NIfTI-1 (`.nii` or a `.hdr`/`.img` pair, gzipped
//! or not) and DICOM series (a folder or a list of files, read separately by
//! [`read_dicom_series`]). Each reader returns [`LoadedVoxels`] — raw values with their
//! type, spacing and data file — after checking the voxel count against the memory budget
//! ([`check_dims`]) and before anything is normalised.

mod dicom;
mod metaimage;
mod nifti;
mod nrrd;
pub mod orient;
mod raw;

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};

pub use dicom::{DicomInput, read_series as read_dicom_series};
pub use metaimage::{read as read_metaimage, write as write_metaimage};
pub use nifti::{is_nifti, read as read_nifti};
pub use nrrd::{read as read_nrrd, write as write_nrrd};
pub use orient::Orientation;
pub use raw::{ByteOrder, RawLayout, VoxelType};

/// What a medical reader (DICOM, NIfTI) found: recorded with the volume's source in every
/// output (render sidecar, cell record).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Acquisition {
    /// `dicom` or `nifti`.
    pub format: String,
    /// SeriesInstanceUID (DICOM).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub series_uid: Option<String>,
    /// SeriesDescription (DICOM) or `descrip` (NIfTI).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub description: Option<String>,
    /// Modality (DICOM: CT, MR, …).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub modality: Option<String>,
    /// Slices (frames) in the volume.
    pub slices: usize,
    /// Files read.
    pub files: usize,
    /// Voxel spacing along grid x, y, z in mm.
    pub spacing_mm: [f64; 3],
    /// The distinct `[slope, intercept]` pairs applied (RescaleSlope/Intercept, scl_slope/inter).
    pub rescale: Vec<[f64; 2]>,
    /// How the voxel axes were put onto the grid.
    pub orientation: Orientation,
    /// How the series was chosen (DICOM) or which transform gave the axes (NIfTI).
    pub choice: String,
}

impl Acquisition {
    /// One line for logs and captions.
    pub fn describe(&self) -> String {
        let rescale: Vec<String> = self
            .rescale
            .iter()
            .map(|[s, i]| format!("{s}·v{i:+}"))
            .collect();
        format!(
            "{} {}{} slices from {} files, spacing {:?} mm, rescale {}, {}; {}",
            self.format,
            self.modality
                .as_deref()
                .map(|m| format!("{m} "))
                .unwrap_or_default(),
            self.slices,
            self.files,
            self.spacing_mm,
            rescale.join(" / "),
            self.orientation.describe(),
            self.choice
        )
    }
}

/// Reads the voxels of a volume file, choosing the reader by extension (`.nrrd`/`.nhdr`,
/// `.mhd`/`.mha`, `.nii`/`.hdr` with or without `.gz`; anything else is headerless RAW and
/// needs `raw_layout`).
pub fn read_voxels(path: &Path, raw_layout: Option<&RawLayout>) -> Result<LoadedVoxels> {
    if path.is_dir() {
        return Err(Error::format(
            path,
            "is a directory; expected a volume file (.raw, .nrrd, .nhdr, .mhd, .mha, .nii or .hdr)",
        ));
    }
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase())
        .unwrap_or_default();
    match ext.as_str() {
        "nrrd" | "nhdr" => read_nrrd(path),
        "mhd" | "mha" => read_metaimage(path),
        _ if is_nifti(path) => read_nifti(path),
        _ => {
            let layout = raw_layout.ok_or_else(|| {
                Error::format(
                    path,
                    "a headerless RAW file needs `dims` and `voxel` (or use a .nrrd/.nhdr/.mhd/.mha header)",
                )
            })?;
            raw::read(path, layout)
        }
    }
}

/// Voxels as read from a file, before normalisation.
#[derive(Debug, Clone)]
pub struct LoadedVoxels {
    /// Voxel counts.
    pub dims: [usize; 3],
    /// Raw values converted to `f32` (exact for 8- and 16-bit types).
    pub values: Vec<f32>,
    /// The stored type.
    pub voxel_type: VoxelType,
    /// Voxel spacing from the header, if it gives one.
    pub spacing: Option<[f32; 3]>,
    /// The file holding the voxels (differs from the header for detached headers).
    pub data_path: PathBuf,
    /// `raw`, `nrrd`, `metaimage`, `nifti` or `dicom`.
    pub format: &'static str,
    /// Series, geometry and rescale, for the medical formats.
    pub acquisition: Option<Acquisition>,
}

/// Validates dims (positive, product fits `usize` and the memory budget) before any read.
pub fn check_dims(path: &Path, dims: [usize; 3]) -> Result<usize> {
    if dims.contains(&0) {
        return Err(Error::format(
            path,
            format!("dims {dims:?}: every dimension must be at least 1"),
        ));
    }
    let count = dims
        .iter()
        .try_fold(1usize, |acc, &n| acc.checked_mul(n))
        .ok_or_else(|| Error::format(path, format!("dims {dims:?}: voxel count overflows")))?;
    let bytes = (count as u64).saturating_mul(crate::util::WORKING_BYTES_PER_VOXEL);
    let budget = crate::util::memory_budget_bytes();
    if bytes > budget {
        return Err(Error::format(
            path,
            format!(
                "dims {dims:?} = {count} voxels need about {} MiB of working memory, more than the {} MiB available; refusing to load",
                bytes >> 20,
                budget >> 20
            ),
        ));
    }
    Ok(count)
}
