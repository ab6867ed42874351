//! DICOM series (`[volume] dicom = "folder"` or a list of files), read with the dicom-rs
//! crates: the headers of every file are scanned, the slices grouped by
//! SeriesInstanceUID, one series chosen, sorted along its slice normal, checked for a
//! regular stack, decoded to modality values (HU for CT) and oriented onto the grid axes
//! L, P, S (exactly, for axis-aligned series; oblique series keep their own frame).

mod assemble;
mod decode;
mod header;

use std::path::{Path, PathBuf};

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::orient::reorient;
use super::{Acquisition, LoadedVoxels, VoxelType, check_dims};
use crate::error::{Error, Result};
use header::Skip;

/// Where the DICOM files are (`[volume] dicom`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum DicomInput {
    /// A folder, searched recursively; files that are not DICOM images are skipped.
    Folder(PathBuf),
    /// Explicit files; each must be a DICOM image.
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
    let slices = scan_all(input)?;
    let chosen = assemble::choose(&anchor, slices, series)?;
    let mut choice = chosen.choice;
    let mut slices = chosen.slices;
    let (axes, positions) = assemble::stack(&mut slices, resample)?;
    for s in &slices {
        header::check_transfer_syntax(&s.path, &s.transfer_syntax)?;
    }
    let [rows, cols] = slices[0].size;
    let dims = [cols as usize, rows as usize, slices.len()];
    let count = check_dims(&anchor, dims)?;
    let mut values = vec![0.0f32; count];
    let sha256 = decode::decode_into(&slices, &mut values)?;
    let mut dims = dims;
    if let assemble::Positions::Irregular(z) = &positions {
        let plane = dims[0] * dims[1];
        let (resampled, count) = assemble::resample_slices(&values, plane, z, axes.spacing[2]);
        check_dims(&anchor, [dims[0], dims[1], count])?;
        choice += &format!(
            "; RESAMPLED: {} irregularly spaced slices interpolated linearly onto {count} slices {:.4} mm apart",
            dims[2], axes.spacing[2]
        );
        (values, dims[2]) = (resampled, count);
    }
    let (map, orientation) = axes.grid_map();
    let (values, dims) = reorient(values, dims, &map);
    let spacing = axes.grid_spacing(&map);
    let first = &slices[0];
    let mut rescale: Vec<[f64; 2]> = Vec::new();
    for s in &slices {
        if !rescale.contains(&s.rescale) {
            rescale.push(s.rescale);
        }
    }
    let files: std::collections::HashSet<&Path> = slices.iter().map(|s| s.path.as_path()).collect();
    let acquisition = Acquisition {
        format: "dicom".into(),
        series_uid: Some(first.series_uid.clone()),
        description: Some(first.description.clone()),
        modality: Some(first.modality.clone()),
        slices: slices.len(),
        files: files.len(),
        spacing_mm: spacing,
        rescale,
        orientation,
        choice,
    };
    let voxel_type = match positions {
        assemble::Positions::Regular => voxel_type(&first.format, &acquisition.rescale),
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

fn scan_all(input: &DicomInput) -> Result<Vec<header::SliceHeader>> {
    let (files, folder) = match input {
        DicomInput::Folder(dir) => (list_folder(dir)?, Some(dir)),
        DicomInput::Files(files) if files.is_empty() => {
            return Err(Error::parameter(
                "volume.dicom",
                "[]",
                "a folder or at least one file",
            ));
        }
        DicomInput::Files(files) => (files.clone(), None),
    };
    let scanned: Vec<(PathBuf, std::result::Result<Vec<header::SliceHeader>, Skip>)> = files
        .par_iter()
        .map(|p| header::scan(p).map(|r| (p.clone(), r)))
        .collect::<Result<_>>()?;
    let mut slices = Vec::new();
    let (mut not_dicom, mut no_image) = (0usize, 0usize);
    for (path, result) in scanned {
        match (result, folder) {
            (Ok(s), _) => slices.extend(s),
            (Err(Skip::NotDicom(why)), None) => {
                return Err(Error::format(
                    &path,
                    format!("not a readable DICOM file: {why}"),
                ));
            }
            (Err(Skip::NoImage), None) => {
                return Err(Error::format(
                    &path,
                    "a DICOM file without an image (no Rows attribute)",
                ));
            }
            (Err(Skip::NotDicom(_)), Some(_)) => not_dicom += 1,
            (Err(Skip::NoImage), Some(_)) => no_image += 1,
        }
    }
    if slices.is_empty() {
        return Err(Error::format(
            input.anchor(),
            format!(
                "no DICOM images: {} files looked at, {not_dicom} not DICOM, {no_image} DICOM without an image; expected a folder of DICOM slices",
                files.len()
            ),
        ));
    }
    Ok(slices)
}

/// All regular files under `dir` (recursively, hidden entries skipped), sorted.
fn list_folder(dir: &Path) -> Result<Vec<PathBuf>> {
    if !dir.is_dir() {
        return Err(Error::format(
            dir,
            "not a folder; expected a folder of DICOM files (or a list of files)",
        ));
    }
    let mut out = Vec::new();
    let mut pending = vec![dir.to_path_buf()];
    while let Some(d) = pending.pop() {
        for entry in std::fs::read_dir(&d).map_err(|e| Error::io(&d, e))? {
            let path = entry.map_err(|e| Error::io(&d, e))?.path();
            if path
                .file_name()
                .and_then(|n| n.to_str())
                .is_some_and(|n| n.starts_with('.'))
            {
                continue;
            }
            if path.is_dir() {
                pending.push(path);
            } else {
                out.push(path);
            }
        }
    }
    if out.is_empty() {
        return Err(Error::format(
            dir,
            "the folder is empty; expected DICOM files",
        ));
    }
    out.sort();
    Ok(out)
}
