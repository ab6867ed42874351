//! DICOM series (`[volume] dicom = "folder"` or a list of files), read with the dicom-rs
//! crates: the headers of every file are scanned, the slices grouped by
//! SeriesInstanceUID, one series chosen, sorted along its slice normal, checked for a
//! regular stack, decoded to modality values (HU for CT) and oriented onto the grid axes
//! L, P, S (exactly, for axis-aligned series; oblique series keep their own frame).

mod assemble;
mod decode;
mod header;
mod native;
mod open;
mod walk;

use std::path::{Path, PathBuf};

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::orient::reorient;
use super::{Acquisition, LoadedVoxels, VoxelType, check_dims};
use crate::error::{Error, Result};
use header::Skip;
use walk::Reason;

/// Where the DICOM files are (`[volume] dicom`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum DicomInput {
    /// A folder, searched recursively; files that are not DICOM images are skipped, and so
    /// are symbolic links leading out of the folder and anything but regular files (the
    /// record lists them). Each file is read once, however many paths reach it.
    Folder(PathBuf),
    /// Explicit files; each must be a regular file holding a DICOM image (a file named
    /// twice is read once).
    Files(Vec<PathBuf>),
}

impl DicomInput {
    /// The same input with relative paths resolved against `base`.
    pub fn resolved(&self, base: &Path) -> DicomInput {
        match self {
            DicomInput::Folder(p) => DicomInput::Folder(base.join(p)),
            DicomInput::Files(f) => DicomInput::Files(f.iter().map(|p| base.join(p)).collect()),
        }
    }

    /// The folder, or the first file, for messages and provenance.
    pub fn anchor(&self) -> PathBuf {
        match self {
            DicomInput::Folder(p) => p.clone(),
            DicomInput::Files(f) => f.first().cloned().unwrap_or_default(),
        }
    }
}

/// Reads one series; `series` picks it by SeriesInstanceUID (default: the largest).
/// Returns the voxels (grid x, y, z = L, P, S for axis-aligned series), the sha256 of the
/// series' files and what was read.
///
/// With `resample`, a series with a missing slice or uneven gaps is linearly interpolated
/// along the slice normal onto its usual (median) step, and the record says so; without it
/// such a series is an error naming the gap.
pub fn read_series(
    input: &DicomInput,
    series: Option<&str>,
    resample: bool,
) -> Result<(LoadedVoxels, String)> {
    let anchor = input.anchor();
    let (slices, skipped) = scan_all(input)?;
    let chosen = assemble::choose(&anchor, slices, series)?;
    let mut choice = chosen.choice;
    if !skipped.is_empty() {
        choice += &format!("; SKIPPED: {}", walk::describe_skipped(&skipped));
    }
    let mut slices = chosen.slices;
    let (axes, positions) = assemble::stack(&mut slices, resample)?;
    for s in &slices {
        header::check_transfer_syntax(&s.path, &s.transfer_syntax)?;
    }
    let [rows, cols] = slices[0].size;
    let mut dims = [cols as usize, rows as usize, slices.len()];
    let count = check_dims(&anchor, dims)?;
    // The resampled size is checked before anything is decoded or allocated.
    let resampled = match &positions {
        assemble::Positions::Irregular(z) => {
            let count = assemble::resampled_count(&slices, z, axes.spacing[2])?;
            check_dims(&anchor, [dims[0], dims[1], count])?;
            Some((z, count))
        }
        assemble::Positions::Regular => None,
    };
    let mut values = vec![0.0f32; count];
    let sha256 = decode::decode_into(&slices, &mut values)?;
    if let Some((z, count)) = resampled {
        let plane = dims[0] * dims[1];
        values = assemble::resample_slices(&values, plane, z, axes.spacing[2], count);
        choice += &format!(
            "; RESAMPLED: {} irregularly spaced slices interpolated linearly onto {count} slices {:.4} mm apart",
            dims[2], axes.spacing[2]
        );
        dims[2] = count;
    }
    let (map, orientation) = axes.grid_map();
    let (values, dims) = reorient(values, dims, &map);
    let spacing = axes.grid_spacing(&map);
    let acquisition = acquisition(&slices, spacing, orientation, choice);
    let voxel_type = match positions {
        assemble::Positions::Regular => voxel_type(&slices[0].format, &acquisition.rescale),
        assemble::Positions::Irregular(_) => VoxelType::F32,
    };
    Ok((
        LoadedVoxels {
            dims,
            values,
            voxel_type,
            spacing: Some(spacing.map(|s| s as f32)),
            data_path: anchor,
            format: "dicom",
            acquisition: Some(acquisition),
        },
        sha256,
    ))
}

/// The record of what was read: the series, its slices and files, the distinct rescales.
fn acquisition(
    slices: &[header::SliceHeader],
    spacing_mm: [f64; 3],
    orientation: super::Orientation,
    choice: String,
) -> Acquisition {
    let first = &slices[0];
    let mut rescale: Vec<[f64; 2]> = Vec::new();
    for s in slices {
        if !rescale.contains(&s.rescale) {
            rescale.push(s.rescale);
        }
    }
    let files: std::collections::HashSet<&Path> = slices.iter().map(|s| s.path.as_path()).collect();
    Acquisition {
        format: "dicom".into(),
        series_uid: Some(first.series_uid.clone()),
        description: Some(first.description.clone()),
        modality: Some(first.modality.clone()),
        slices: slices.len(),
        files: files.len(),
        spacing_mm,
        rescale,
        orientation,
        choice,
    }
}

/// The type that holds the modality values exactly: integers when every rescale is integral.
fn voxel_type(f: &header::PixelFormat, rescale: &[[f64; 2]]) -> VoxelType {
    let integral = rescale
        .iter()
        .all(|[s, i]| s.fract() == 0.0 && i.fract() == 0.0 && *s >= 0.0);
    if !integral || f.bits_stored > 16 {
        return VoxelType::F32;
    }
    let negative = f.signed || rescale.iter().any(|[_, i]| *i < 0.0);
    match (
        negative,
        f.bits_stored <= 8 && rescale.iter().all(|r| *r == [1.0, 0.0]),
    ) {
        (false, true) => VoxelType::U8,
        (false, false) => VoxelType::U16,
        (true, _) => VoxelType::I16,
    }
}

/// Entries of the input not read, and why.
type Skipped = Vec<(Reason, PathBuf)>;

/// The files of `input`, each once, and the entries left out (a folder's links leading
/// out of it, special files, second paths to one file; a list's repeated files).
fn input_files(input: &DicomInput) -> Result<(Vec<PathBuf>, Skipped)> {
    match input {
        DicomInput::Folder(dir) => {
            let listing = walk::list(dir, walk::LIMITS)?;
            if listing.files.is_empty() {
                return Err(Error::format(dir, empty_folder(&listing.skipped)));
            }
            Ok((listing.files, listing.skipped))
        }
        DicomInput::Files(files) if files.is_empty() => Err(Error::parameter(
            "volume.dicom",
            "[]",
            "a folder or at least one file",
        )),
        DicomInput::Files(files) => unique_files(files),
    }
}

fn empty_folder(skipped: &[(Reason, PathBuf)]) -> String {
    if skipped.is_empty() {
        "the folder is empty; expected DICOM files".into()
    } else {
        format!(
            "no regular files in the folder (skipped: {}); expected DICOM files",
            walk::describe_skipped(skipped)
        )
    }
}

/// The listed files, each a regular file (a FIFO or device named here is an error naming
/// it, never opened), a file listed twice (or through a link) kept once.
fn unique_files(files: &[PathBuf]) -> Result<(Vec<PathBuf>, Skipped)> {
    use std::os::unix::fs::MetadataExt;
    let mut seen = std::collections::HashSet::new();
    let (mut unique, mut repeated) = (Vec::new(), Vec::new());
    for path in files {
        let (file, _) = crate::util::open_regular(path, "DICOM file")?;
        let meta = file.metadata().map_err(|e| Error::io(path, e))?;
        if seen.insert((meta.dev(), meta.ino())) {
            unique.push(path.clone());
        } else {
            repeated.push((Reason::AlreadyRead, path.clone()));
        }
    }
    Ok((unique, repeated))
}

/// The slices of every file of `input`, and the entries left out (for the record): a
/// folder's files that are not DICOM or hold no image are named there; a listed file that
/// is no image, or any DICOM file that cannot be parsed, is an error naming it.
fn scan_all(input: &DicomInput) -> Result<(Vec<header::SliceHeader>, Skipped)> {
    let (files, mut skipped) = input_files(input)?;
    let scanned: Vec<(PathBuf, std::result::Result<Vec<header::SliceHeader>, Skip>)> = files
        .par_iter()
        .map(|p| header::scan(p).map(|r| (p.clone(), r)))
        .collect::<Result<_>>()?;
    let mut slices = Vec::new();
    for (path, result) in scanned {
        let reason = match (result, input) {
            (Ok(s), _) => {
                slices.extend(s);
                continue;
            }
            (Err(Skip::NotDicom(why)), DicomInput::Files(_)) => {
                return Err(Error::format(
                    &path,
                    format!("not a readable DICOM file: {why}"),
                ));
            }
            (Err(Skip::NoImage), DicomInput::Files(_)) => {
                return Err(Error::format(
                    &path,
                    "a DICOM file without an image (no Rows attribute)",
                ));
            }
            (Err(Skip::NotDicom(_)), DicomInput::Folder(_)) => Reason::NotDicom,
            (Err(Skip::NoImage), DicomInput::Folder(_)) => Reason::NoImage,
        };
        let relative = match input {
            DicomInput::Folder(dir) => path.strip_prefix(dir).unwrap_or(&path).to_path_buf(),
            DicomInput::Files(_) => path,
        };
        skipped.push((reason, relative));
    }
    skipped.sort();
    if slices.is_empty() {
        return Err(Error::format(
            input.anchor(),
            format!(
                "no DICOM images among {} files (skipped: {}); expected a folder of DICOM slices",
                files.len(),
                walk::describe_skipped(&skipped)
            ),
        ));
    }
    Ok((slices, skipped))
}
