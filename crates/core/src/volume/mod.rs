//! Volume data: RAW, NRRD, MetaImage and NIfTI-1 files, DICOM series, procedural phantoms, normalisation to
//! `[0, 1]` and the dataset registry (thesis §2.1, §7.2).
//!
//! A [`Volume`] is a [`Grid`] of normalised densities plus a record of where it came from
//! ([`VolumeSource`]) and how its raw values were scaled ([`NormalizationRecord`]).
//!
//! ```
//! use volphot::{PhantomParams, Volume};
//! let volume = Volume::from_phantom(&PhantomParams::named("sphere", 16)).unwrap();
//! assert_eq!(volume.grid().dims(), [16, 16, 16]);
//! assert!(volume.source().describe().starts_with("phantom sphere"));
//! ```

mod formats;
mod grid;
mod phantom;
mod registry;

use std::path::PathBuf;

use glam::Vec3;
use serde::{Deserialize, Serialize};

pub use formats::{
    Acquisition, ByteOrder, DicomInput, LoadedVoxels, Orientation, RawLayout, VoxelType,
    check_dims, is_nifti, read_dicom_series, read_metaimage, read_nifti, read_nrrd, read_voxels,
    write_metaimage, write_nrrd,
};
pub(crate) use grid::{CellCursor, Voxels, corner_offsets, trilinear_corners};
pub use grid::{Grid, Reconstruction};
pub use phantom::PhantomParams;
pub use registry::{
    DATASETS, DatasetInfo, DatasetOverrides, DatasetStatus, SearchPath, find_dataset, load_dataset,
    survey_datasets,
};

use crate::error::{Error, Result};
use crate::math::Aabb;

/// How raw voxel values are scaled to densities in `[0, 1]`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Normalization {
    /// Divide by the type's range, as the thesis does (§7.2.2): `u8 / 255`, `u16 / 65535`;
    /// signed types map `[min, max]` of the type onto `[0, 1]`.
    #[default]
    TypeRange,
    /// Map the raw window `[lo, hi]` onto `[0, 1]`, clamping outside (e.g. a Hounsfield window
    /// for CT). Values are raw units.
    Window {
        /// Raw value that maps to 0.
        lo: f64,
        /// Raw value that maps to 1.
        hi: f64,
    },
    /// Map the data's own minimum and maximum onto `[0, 1]`.
    MinMax,
}

impl Normalization {
    /// The default for data stored as `voxel`: the thesis's type range for unsigned integers
    /// (§7.2.2); the data's own range for signed and float data, whose type range would put
    /// air (−1024 HU in a CT) at half density and render a solid block.
    pub fn default_for(voxel: VoxelType) -> Self {
        if voxel.is_signed() {
            Normalization::MinMax
        } else {
            Normalization::TypeRange
        }
    }

    /// Validates a window (finite, `lo < hi`).
    pub fn validate(&self) -> Result<()> {
        if let Normalization::Window { lo, hi } = *self
            && !(lo.is_finite() && hi.is_finite() && lo < hi)
        {
            return Err(Error::parameter(
                "normalize.window",
                format!("[{lo}, {hi}]"),
                "two finite raw values with lo < hi",
            ));
        }
        Ok(())
    }
}

/// What normalisation was applied, with the numbers needed to undo it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct NormalizationRecord {
    /// The rule that was selected.
    pub method: Normalization,
    /// Raw value mapped to 0.
    pub raw_lo: f64,
    /// Raw value mapped to 1.
    pub raw_hi: f64,
    /// Smallest raw value in the data.
    pub data_min: f64,
    /// Largest raw value in the data.
    pub data_max: f64,
}

impl NormalizationRecord {
    /// Converts a raw value (e.g. a 16-bit `threshold`) to the normalised scale.
    pub fn normalize(&self, raw: f64) -> f64 {
        ((raw - self.raw_lo) / (self.raw_hi - self.raw_lo)).clamp(0.0, 1.0)
    }
}

/// Where a volume came from: recorded in every output so a result can be traced back.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "kebab-case")]
pub enum VolumeSource {
    /// Loaded from a file.
    File {
        /// Registry name, when loaded through the registry.
        dataset: Option<String>,
        /// The file that holds the voxels (the data file for detached headers).
        path: PathBuf,
        /// The header file, for NRRD/MetaImage.
        header: Option<PathBuf>,
        /// sha256 of the voxel file, lowercase hex.
        sha256: String,
        /// `raw`, `nrrd`, `metaimage`, `nifti` or `dicom` (then `path` is the folder or the
        /// first file and `sha256` covers every file of the series in slice order).
        format: String,
        /// Series, slice count, spacing, rescale and orientation (DICOM, NIfTI).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        acquisition: Option<Box<Acquisition>>,
    },
    /// Generated procedurally ([`crate::PhantomParams`]).
    Phantom {
        /// Phantom name.
        name: String,
        /// Its parameters in a stable textual form.
        parameters: String,
    },
}

impl VolumeSource {
    /// One line for captions, CSV and reports: `foot (foot.raw, sha256 9f8e…)` or
    /// `phantom engine (resolution=64)`. The file by its name only: the folder it was read
    /// from is the machine's, and the sha256 names the content wherever it lies.
    pub fn describe(&self) -> String {
        match self {
            VolumeSource::File {
                dataset,
                path,
                sha256,
                acquisition,
                ..
            } => {
                let name = dataset.clone().unwrap_or_else(|| "file".into());
                let what = acquisition
                    .as_ref()
                    .map(|a| format!("; {}", a.describe()))
                    .unwrap_or_default();
                let file = path.file_name().map_or_else(
                    || path.display().to_string(),
                    |f| f.to_string_lossy().into_owned(),
                );
                format!("{name} ({file}, sha256 {sha256}{what})")
            }
            VolumeSource::Phantom { name, parameters } => {
                format!("phantom {name} ({parameters})")
            }
        }
    }

    /// A content identity: the sha256 for files, the phantom description otherwise.
    pub fn identity(&self) -> String {
        match self {
            VolumeSource::File { sha256, .. } => sha256.clone(),
            VolumeSource::Phantom { name, parameters } => format!("phantom:{name}:{parameters}"),
        }
    }
}

/// Where the grid sits in the world.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Placement {
    /// An explicit box `p0..p1` (thesis §7.2.1).
    Box {
        /// Lower corner.
        p0: [f32; 3],
        /// Upper corner.
        p1: [f32; 3],
    },
    /// Physical voxel spacing; the volume is scaled so its longest axis spans 1 and centred
    /// in the unit box `[0,1]³`.
    Spacing([f32; 3]),
}

impl Default for Placement {
    fn default() -> Self {
        Placement::Spacing([1.0; 3])
    }
}

impl Placement {
    /// The world box for a grid of `dims` voxels.
    pub fn bounds(&self, dims: [usize; 3]) -> Result<Aabb> {
        match *self {
            Placement::Box { p0, p1 } => {
                let (p0, p1) = (Vec3::from(p0), Vec3::from(p1));
                if !(p0.is_finite() && p1.is_finite() && p1.cmpgt(p0).all()) {
                    return Err(Error::parameter(
                        "box",
                        format!("p0 = {p0:?}, p1 = {p1:?}"),
                        "finite corners with p1 > p0 on every axis",
                    ));
                }
                Ok(Aabb::new(p0, p1))
            }
            Placement::Spacing(s) => {
                if !s.iter().all(|v| v.is_finite() && *v > 0.0) {
                    return Err(Error::parameter(
                        "spacing",
                        format!("{s:?}"),
                        "three finite numbers > 0",
                    ));
                }
                let size = Vec3::new(
                    dims[0] as f32 * s[0],
                    dims[1] as f32 * s[1],
                    dims[2] as f32 * s[2],
                );
                let extent = size / size.max_element();
                let min = Vec3::splat(0.5) - extent * 0.5;
                let max = min + extent;
                // Huge sizes overflow the extent to ∞ (a NaN box); wildly unequal ones
                // flatten a side to nothing once the longest is scaled to 1.
                if !(size.is_finite() && max.cmpgt(min).all()) {
                    return Err(Error::parameter(
                        "spacing",
                        format!("{s:?} over dims {dims:?}"),
                        "voxel sizes whose extent over the dims is finite, with every side still > 0 once the longest is scaled to 1",
                    ));
                }
                Ok(Aabb::new(min, max))
            }
        }
    }
}

/// A scalar volume with densities normalised to `[0, 1]`.
#[derive(Debug, Clone)]
pub struct Volume {
    grid: Grid,
    source: VolumeSource,
    normalization: NormalizationRecord,
    voxel_type: Option<VoxelType>,
    spacing: Option<[f32; 3]>,
}

impl Volume {
    /// Builds a volume from raw values (as `f64`-exact `f32`), normalising them.
    pub fn from_raw_values(
        dims: [usize; 3],
        raw_values: Vec<f32>,
        voxel_type: Option<VoxelType>,
        normalization: Normalization,
        placement: Placement,
        source: VolumeSource,
    ) -> Result<Self> {
        normalization.validate()?;
        let bounds = placement.bounds(dims)?;
        if let Some(index) = raw_values.iter().position(|v| !v.is_finite()) {
            let [nx, ny, _] = dims;
            return Err(Error::NonFiniteVoxel {
                source_name: source.describe(),
                index,
                position: [index % nx, (index / nx) % ny, index / (nx * ny)],
                value: raw_values[index],
            });
        }
        let (data_min, data_max) = raw_values
            .iter()
            .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), &v| {
                (lo.min(v), hi.max(v))
            });
        let (raw_lo, raw_hi) = match normalization {
            Normalization::TypeRange => match voxel_type {
                Some(t) => t.range(),
                None => (0.0, 1.0),
            },
            Normalization::Window { lo, hi } => (lo, hi),
            Normalization::MinMax => {
                if data_max > data_min {
                    (data_min as f64, data_max as f64)
                } else {
                    // A constant volume: map its value to 1 so it is not silently empty.
                    // Past 2^53, value − 1 rounds back to the value; step down by the
                    // value's own magnitude there instead, so the range is never empty.
                    let value = data_min as f64;
                    let below = if value - 1.0 < value {
                        value - 1.0
                    } else {
                        value - value.abs()
                    };
                    (below, value)
                }
            }
        };
        let inv = 1.0 / (raw_hi - raw_lo);
        let values = if raw_lo == 0.0 && raw_hi == 1.0 && data_min >= 0.0 && data_max <= 1.0 {
            raw_values
        } else {
            raw_values
                .into_iter()
                .map(|v| ((v as f64 - raw_lo) * inv).clamp(0.0, 1.0) as f32)
                .collect()
        };
        Ok(Volume {
            grid: Grid::new(dims, values, bounds),
            source,
            normalization: NormalizationRecord {
                method: normalization,
                raw_lo,
                raw_hi,
                data_min: data_min as f64,
                data_max: data_max as f64,
            },
            voxel_type,
            spacing: match placement {
                Placement::Spacing(s) => Some(s),
                Placement::Box { .. } => None,
            },
        })
    }

    /// The physical voxel spacing (mm for medical data) when the volume was placed by
    /// spacing; `None` for an explicit world box.
    pub fn spacing(&self) -> Option<[f32; 3]> {
        self.spacing
    }

    /// Generates a procedural phantom.
    pub fn from_phantom(params: &phantom::PhantomParams) -> Result<Self> {
        phantom::generate(params)
    }

    /// The normalised density grid.
    pub fn grid(&self) -> &Grid {
        &self.grid
    }

    /// Where the volume came from.
    pub fn source(&self) -> &VolumeSource {
        &self.source
    }

    /// How raw values were scaled.
    pub fn normalization(&self) -> &NormalizationRecord {
        &self.normalization
    }

    /// The voxel type of the file, if loaded from one.
    pub fn voxel_type(&self) -> Option<VoxelType> {
        self.voxel_type
    }
}

/// A request to load a volume from a file with everything a headerless RAW file lacks.
#[derive(Debug, Clone)]
pub struct FileRequest {
    /// The file (`.raw`, `.nrrd`, `.nhdr`, `.mhd`, `.mha`, `.nii`, `.nii.gz`, `.hdr`).
    pub path: PathBuf,
    /// Layout for RAW files (ignored for header formats, which carry their own).
    pub raw_layout: Option<RawLayout>,
    /// Placement; `None` uses the header's spacing (or 1,1,1 for RAW).
    pub placement: Option<Placement>,
    /// Normalisation rule; `None` chooses by voxel type ([`Normalization::default_for`]).
    pub normalization: Option<Normalization>,
    /// Registry name, for provenance.
    pub dataset: Option<String>,
    /// Expected sha256 of the voxel data file, verified when given.
    pub expected_sha256: Option<String>,
}

/// Reads a volume file (choosing the reader by extension) and normalises it.
pub fn read_volume(request: &FileRequest) -> Result<Volume> {
    let loaded = formats::read_voxels(&request.path, request.raw_layout.as_ref())?;
    let sha256 = crate::util::sha256_content(&loaded.data_path)?;
    if let Some(expected) = &request.expected_sha256
        && !expected.eq_ignore_ascii_case(&sha256)
    {
        return Err(Error::Checksum {
            path: loaded.data_path.clone(),
            expected: expected.clone(),
            actual: sha256,
        });
    }
    let header = (loaded.data_path != request.path).then(|| request.path.clone());
    from_loaded(loaded, request, header, sha256)
}

/// Reads a DICOM series ([`read_dicom_series`]) and normalises it; `request.path` is ignored.
pub fn read_dicom_volume(
    input: &DicomInput,
    series: Option<&str>,
    resample: bool,
    request: &FileRequest,
) -> Result<Volume> {
    let (loaded, sha256) = read_dicom_series(input, series, resample)?;
    from_loaded(loaded, request, None, sha256)
}

fn from_loaded(
    loaded: LoadedVoxels,
    request: &FileRequest,
    header: Option<PathBuf>,
    sha256: String,
) -> Result<Volume> {
    let placement = request
        .placement
        .unwrap_or(Placement::Spacing(loaded.spacing.unwrap_or([1.0; 3])));
    Volume::from_raw_values(
        loaded.dims,
        loaded.values,
        Some(loaded.voxel_type),
        request
            .normalization
            .unwrap_or(Normalization::default_for(loaded.voxel_type)),
        placement,
        VolumeSource::File {
            dataset: request.dataset.clone(),
            path: loaded.data_path,
            header,
            sha256,
            format: loaded.format.to_string(),
            acquisition: loaded.acquisition.map(Box::new),
        },
    )
}
