//! From loose slices to one series: grouping by SeriesInstanceUID, choosing a series,
//! and the geometry checks (same size and orientation, sorted along the slice normal,
//! uniform spacing from the positions).

use std::collections::BTreeMap;
use std::path::Path;

use super::header::{SPACING_RANGE_MM, SliceHeader, mm, plausible_spacing};
use crate::error::{Error, Result};
use crate::volume::formats::orient::{PatientAxes, cross, dot};

/// Relative tolerance on slice spacing (a gap beyond 1 % of the usual step is an error).
const SPACING_TOLERANCE: f64 = 0.01;

/// The slices of the chosen series and how it was chosen.
pub struct Chosen {
    /// Its slices (unsorted).
    pub slices: Vec<SliceHeader>,
    /// How it was chosen, for the record.
    pub choice: String,
}

/// Groups slices by series and picks `wanted`, or the one with the most slices.
pub fn choose(where_: &Path, slices: Vec<SliceHeader>, wanted: Option<&str>) -> Result<Chosen> {
    let mut groups: BTreeMap<String, Vec<SliceHeader>> = BTreeMap::new();
    for s in slices {
        groups.entry(s.series_uid.clone()).or_default().push(s);
    }
    let listing = |groups: &BTreeMap<String, Vec<SliceHeader>>| {
        groups
            .iter()
            .map(|(uid, s)| format!("{uid} ({} slices, {:?})", s.len(), s[0].description))
            .collect::<Vec<_>>()
            .join("; ")
    };
    if let Some(uid) = wanted {
        let text = listing(&groups);
        let n = groups.len();
        return match groups.remove(uid) {
            Some(slices) => Ok(Chosen {
                choice: format!("series {uid} as asked (of {n} series in the input)"),
                slices,
            }),
            None => Err(Error::format(
                where_,
                format!("series = {uid:?} is not in the input; it holds {text}"),
            )),
        };
    }
    let most = groups.values().map(Vec::len).max().unwrap_or(0);
    let largest: Vec<&String> = groups
        .iter()
        .filter(|(_, s)| s.len() == most)
        .map(|(uid, _)| uid)
        .collect();
    if largest.len() > 1 {
        return Err(Error::format(
            where_,
            format!(
                "{} series have {most} slices each, so none is the obvious choice; set `series` to one of: {}",
                largest.len(),
                listing(&groups)
            ),
        ));
    }
    let uid = largest[0].clone();
    let choice = if groups.len() == 1 {
        format!("series {uid}, the only one in the input")
    } else {
        let others: Vec<String> = groups
            .iter()
            .filter(|(u, _)| **u != uid)
            .map(|(u, s)| format!("{u} ({} slices)", s.len()))
            .collect();
        format!(
            "series {uid}, the largest ({most} slices) of {} series; not used: {}",
            groups.len(),
            others.join(", ")
        )
    };
    Ok(Chosen {
        slices: groups.remove(&uid).unwrap_or_default(),
        choice,
    })
}

/// A stack's slice positions along its normal.
pub enum Positions {
    /// Evenly spaced.
    Regular,
    /// Irregular (a missing slice or uneven gaps), allowed by `resample`: the positions in
    /// mm, to be interpolated onto the usual step.
    Irregular(Vec<f64>),
}

/// Checks that the slices form one stack, sorts them along the slice normal and returns
/// the voxel axes in the patient frame (with the usual step as z spacing). Irregular
/// spacing is an error naming the gap unless `resample`.
pub fn stack(slices: &mut [SliceHeader], resample: bool) -> Result<(PatientAxes, Positions)> {
    let first = slices[0].clone();
    for s in slices.iter() {
        same_frame(&first, s)?;
    }
    let o = first.orientation;
    let (row, col) = (
        unit(&first, [o[0], o[1], o[2]])?,
        unit(&first, [o[3], o[4], o[5]])?,
    );
    if dot(row, col).abs() > 1e-3 {
        return Err(Error::format(
            &first.path,
            format!(
                "ImageOrientationPatient {o:?}: the row and column directions are not perpendicular"
            ),
        ));
    }
    let normal = cross(row, col);
    slices.sort_by(|a, b| dot(a.position, normal).total_cmp(&dot(b.position, normal)));
    check_in_plane(slices, normal)?;
    let (step, positions) = match slice_step(slices, normal) {
        Ok(step) => (step, Positions::Regular),
        Err(Irregular { usual, .. }) if resample => (
            usual,
            Positions::Irregular(slices.iter().map(|s| dot(s.position, normal)).collect()),
        ),
        Err(Irregular { error, .. }) => return Err(error),
    };
    check_step(slices, normal, step)?;
    Ok((
        PatientAxes {
            directions: [row, col, normal],
            spacing: [first.pixel_spacing[1], first.pixel_spacing[0], step],
        },
        positions,
    ))
}

/// The slice step must be a plausible distance ([`plausible_spacing`]); the error names
/// the field it came from and the outermost slices.
fn check_step(slices: &[SliceHeader], normal: [f64; 3], step: f64) -> Result<()> {
    if plausible_spacing(step) {
        return Ok(());
    }
    let [low, high] = SPACING_RANGE_MM.map(mm);
    let (first, last) = (&slices[0], &slices[slices.len() - 1]);
    let what = if slices.len() == 1 {
        format!(
            "SliceThickness (0018,0050) of the only slice is {}",
            mm(step)
        )
    } else {
        format!(
            "ImagePositionPatient (0020,0032) puts the slices {} mm apart ({} slices from {} at {} mm along the \
             slice normal to this one at {} mm)",
            mm(step),
            slices.len(),
            describe(first),
            mm(dot(first.position, normal)),
            mm(dot(last.position, normal))
        )
    };
    Err(Error::format(
        &last.path,
        format!(
            "{what}: expected a slice step from {low} to {high} mm; the header is damaged or not in millimetres"
        ),
    ))
}

/// How many slices resampling `slices` (sorted, at `positions` along the normal) onto
/// `step` makes; an error naming the outermost files when the positions span more steps
/// than can be counted (damaged positions, never an overflow or a huge allocation).
pub fn resampled_count(slices: &[SliceHeader], positions: &[f64], step: f64) -> Result<usize> {
    let (first, last) = (positions[0], positions[positions.len() - 1]);
    let steps = ((last - first) / step).round();
    if steps.is_finite() && steps < f64::from(u32::MAX) {
        return Ok(steps as usize + 1);
    }
    Err(Error::format(
        &slices[slices.len() - 1].path,
        format!(
            "resample = true would interpolate {:e} slices {} mm apart between {} (at {} mm along the slice \
             normal) and this slice (at {} mm): ImagePositionPatient (0020,0032) of these slices is damaged \
             (remove them, or pass only the regular run of slices)",
            steps + 1.0,
            mm(step),
            describe(&slices[0]),
            mm(first),
            mm(last)
        ),
    ))
}

/// Why a stack's spacing is not one step: the error to report, and the usual (median) step
/// to resample onto (0 when no step exists, e.g. two slices at one position).
struct Irregular {
    error: Error,
    usual: f64,
}

fn same_frame(first: &SliceHeader, s: &SliceHeader) -> Result<()> {
    let differs = |what: &str, this: String, that: String| {
        Err(Error::format(
            &s.path,
            format!(
                "{what} is {this} but {} has {that}: every slice of series {} must match",
                first.path.display(),
                s.series_uid
            ),
        ))
    };
    if s.size != first.size {
        let f = |z: [u32; 2]| format!("{}×{} (rows×columns)", z[0], z[1]);
        return differs("the slice size", f(s.size), f(first.size));
    }
    if s.orientation
        .iter()
        .zip(first.orientation)
        .any(|(a, b)| (a - b).abs() > 1e-4)
    {
        return differs(
            "ImageOrientationPatient",
            format!("{:?}", s.orientation),
            format!("{:?}", first.orientation),
        );
    }
    if s.pixel_spacing
        .iter()
        .zip(first.pixel_spacing)
        .any(|(a, b)| (a - b).abs() > 1e-4 * b.abs().max(1.0))
    {
        return differs(
            "PixelSpacing",
            format!("{:?}", s.pixel_spacing),
            format!("{:?}", first.pixel_spacing),
        );
    }
    if s.format != first.format {
        return differs(
            "the pixel format",
            format!("{:?}", s.format),
            format!("{:?}", first.format),
        );
    }
    Ok(())
}

fn unit(s: &SliceHeader, v: [f64; 3]) -> Result<[f64; 3]> {
    let n = dot(v, v).sqrt();
    if (n - 1.0).abs() > 1e-2 {
        return Err(Error::format(
            &s.path,
            format!(
                "ImageOrientationPatient {:?}: direction {v:?} has length {n}, expected unit vectors",
                s.orientation
            ),
        ));
    }
    Ok(v.map(|x| x / n))
}

/// Every slice must sit on the line through the first along the normal (no shear).
fn check_in_plane(slices: &[SliceHeader], normal: [f64; 3]) -> Result<()> {
    let first = &slices[0];
    let tolerance = 0.01 * first.pixel_spacing[0].min(first.pixel_spacing[1]) + 1e-3;
    let off = |s: &SliceHeader| {
        let d = dot(s.position, normal);
        [0, 1, 2].map(|a| s.position[a] - d * normal[a])
    };
    let base = off(first);
    for s in slices {
        let o = off(s);
        let shift =
            ((o[0] - base[0]).powi(2) + (o[1] - base[1]).powi(2) + (o[2] - base[2]).powi(2)).sqrt();
        if shift > tolerance {
            return Err(Error::format(
                &s.path,
                format!(
                    "ImagePositionPatient {:?} is shifted {shift:.4} mm within the slice plane against {}: \
                     a sheared stack (gantry tilt?) is not supported",
                    s.position,
                    first.path.display()
                ),
            ));
        }
    }
    Ok(())
}

/// A slice for messages: its file, and its frame when the file holds several.
fn describe(s: &SliceHeader) -> String {
    if s.frames <= 1 {
        s.path.display().to_string()
    } else {
        format!("{} frame {} of {}", s.path.display(), s.frame + 1, s.frames)
    }
}

/// The slice step from the positions, checked uniform.
fn slice_step(slices: &[SliceHeader], normal: [f64; 3]) -> std::result::Result<f64, Irregular> {
    let d: Vec<f64> = slices.iter().map(|s| dot(s.position, normal)).collect();
    if slices.len() == 1 {
        return Ok(slices[0].thickness.filter(|t| *t > 0.0).unwrap_or(1.0));
    }
    let mut steps: Vec<f64> = d.windows(2).map(|w| w[1] - w[0]).collect();
    for (k, step) in steps.iter().enumerate() {
        if *step < 1e-4 {
            return Err(Irregular {
                usual: 0.0,
                error: Error::format(
                    &slices[k + 1].path,
                    format!(
                        "two slices at the same position {:.4} mm along the normal: {} and {}{}",
                        d[k + 1],
                        describe(&slices[k + 1]),
                        describe(&slices[k]),
                        same_position_hint(&slices[k])
                    ),
                ),
            });
        }
    }
    let all = steps.clone();
    steps.sort_by(f64::total_cmp);
    let usual = steps[steps.len() / 2];
    for (k, step) in all.iter().enumerate() {
        if (step - usual).abs() > SPACING_TOLERANCE * usual {
            return Err(Irregular {
                usual,
                error: Error::format(
                    &slices[k + 1].path,
                    format!(
                        "gap of {step:.4} mm between {} (at {:.4} mm along the slice normal) and this slice (at {:.4} mm), \
                     where the other slices are {usual:.4} mm apart: a missing slice or irregular spacing \
                     (add the missing file, pass only a regular run of slices, or set `resample = true` in \
                     [volume] to interpolate onto {usual:.4} mm)",
                        describe(&slices[k]),
                        d[k],
                        d[k + 1]
                    ),
                ),
            });
        }
    }
    Ok((d[d.len() - 1] - d[0]) / (d.len() - 1) as f64)
}

/// Why frames of one file may share a position: a multi-frame object that places its
/// frames neither by functional groups nor by GridFrameOffsetVector.
fn same_position_hint(s: &SliceHeader) -> &'static str {
    if s.frames > 1 {
        " (the file places its frames neither by per-frame functional groups nor by GridFrameOffsetVector, \
         so every frame is at ImagePositionPatient)"
    } else {
        ""
    }
}

/// Linear interpolation of `values` (`nz` slices of `plane` voxels at `positions`, sorted)
/// onto `count` slices ([`resampled_count`]) `step` apart from the first position.
pub fn resample_slices(
    values: &[f32],
    plane: usize,
    positions: &[f64],
    step: f64,
    count: usize,
) -> Vec<f32> {
    let (first, last) = (positions[0], positions[positions.len() - 1]);
    let mut out = Vec::with_capacity(count * plane);
    let mut below = 0;
    for k in 0..count {
        let z = (first + k as f64 * step).min(last);
        while below + 2 < positions.len() && positions[below + 1] < z {
            below += 1;
        }
        let (z0, z1) = (positions[below], positions[below + 1]);
        let t = ((z - z0) / (z1 - z0)).clamp(0.0, 1.0) as f32;
        let (a, b) = (
            &values[below * plane..][..plane],
            &values[(below + 1) * plane..][..plane],
        );
        out.extend(a.iter().zip(b).map(|(a, b)| a + (b - a) * t));
    }
    out
}
