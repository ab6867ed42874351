//! pydicom's own test files (bundled in its wheel) as a reference: each file alone, each
//! single-frame image as a three-slice series written by pydicom (pixel bytes and transfer
//! syntax untouched), and each file beside good slices. `scripts/pydicom-corpus.sh`
//! installs pydicom with its decoders into a virtual environment and exports pydicom's
//! arrays; every file volphot accepts must match them voxel for voxel, every refusal must
//! give a reason, and no file may be dropped from a folder without a word.

use std::path::{Path, PathBuf};

use volphot::test_util::dicom::{SliceSpec, write_slice};
use volphot::{DicomInput, LoadedVoxels, Orientation, read_dicom_series};

/// What volphot made of one input, against pydicom.
#[derive(Debug, PartialEq)]
enum Class {
    /// Read, and equal to pydicom's modality values voxel for voxel.
    AcceptedAndMatches,
    /// Refused with a reason that names what is missing or unsupported.
    Refused(String),
    /// Not DICOM for pydicom either (README, JSON, ICC profile, files without meta).
    NotDicom(String),
    /// DICOM without pixel data (DICOMDIR, SR, RT Plan …): no volume.
    NotAVolume(String),
}

/// What went wrong, one line per input.
type Failures = Vec<String>;

fn venv() -> PathBuf {
    if let Ok(v) = std::env::var("VOLPHOT_PYDICOM_VENV") {
        return v.into();
    }
    let cache = std::env::var("XDG_CACHE_HOME")
        .map(PathBuf::from)
        .unwrap_or_else(|_| {
            PathBuf::from(std::env::var("HOME").unwrap_or_default()).join(".cache")
        });
    cache.join("volphot/pydicom-venv")
}

fn workspace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// Exports pydicom's view of its corpus into `out`; `None` (skipped) without pydicom,
/// unless CI, where the script installs it.
fn export(test: &str, out: &Path) -> Option<serde_json::Value> {
    let python = venv().join("bin/python");
    let installed = std::process::Command::new(&python)
        .args(["-c", "import pydicom, numpy, pylibjpeg"])
        .output()
        .is_ok_and(|o| o.status.success());
    if !installed && !volphot::test_util::required() {
        volphot::test_util::skip(
            test,
            &format!(
                "pydicom is not installed in {} (scripts/pydicom-corpus.sh --install makes it)",
                venv().display()
            ),
        );
        return None;
    }
    let status = std::process::Command::new(workspace().join("scripts/pydicom-corpus.sh"))
        .arg(out)
        .status()
        .expect("scripts/pydicom-corpus.sh runs");
    assert!(status.success(), "scripts/pydicom-corpus.sh failed");
    let text = std::fs::read_to_string(out.join("manifest.json")).unwrap();
    Some(serde_json::from_str(&text).unwrap())
}

/// `v`'s values in the file's own order (columns fastest, then rows, then slices along
/// the normal), undoing the permutation and flips onto patient axes.
fn file_order(v: &LoadedVoxels) -> (Vec<f32>, [usize; 3]) {
    let axes = match &v.acquisition.as_ref().unwrap().orientation {
        Orientation::AxisAligned { file_axes } => file_axes.clone(),
        Orientation::Oblique { .. } => return (v.values.clone(), v.dims),
    };
    // For each file axis: the grid axis it became and whether it runs backwards.
    let map: Vec<(usize, bool)> = axes
        .iter()
        .map(|a| match a.as_str() {
            "L" => (0, false),
            "R" => (0, true),
            "P" => (1, false),
            "A" => (1, true),
            "S" => (2, false),
            _ => (2, true),
        })
        .collect();
    let g = v.dims;
    let mut dims = [0; 3];
    for (n, (axis, _)) in map.iter().enumerate() {
        dims[n] = g[*axis];
    }
    let mut out = Vec::with_capacity(v.values.len());
    for k in 0..dims[2] {
        for j in 0..dims[1] {
            for i in 0..dims[0] {
                let mut at = [0; 3];
                for (n, idx) in [i, j, k].into_iter().enumerate() {
                    let (axis, back) = map[n];
                    at[axis] = if back { g[axis] - 1 - idx } else { idx };
                }
                out.push(v.values[at[0] + g[0] * (at[1] + g[1] * at[2])]);
            }
        }
    }
    (out, dims)
}

/// pydicom's reference values (frames × rows × columns, little-endian f32), `copies` times.
fn reference(out: &Path, entry: &serde_json::Value, copies: usize) -> Option<Vec<f32>> {
    let name = entry["reference"].as_str()?;
    let bytes = std::fs::read(out.join(name)).unwrap();
    let one: Vec<f32> = bytes
        .chunks_exact(4)
        .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
        .collect();
    Some(one.repeat(copies))
}

/// Refusals a decoded greyscale image may get: what volphot does not promise (JPEG 2000,
/// JPEG-LS), what is no volume (no position, a palette, 1-bit segmentations), and the
/// damaged files pydicom itself cannot decode.
const ALLOWED_REFUSALS: &[&str] = &[
    "JPEG 2000",
    "JPEG-LS",
    "ImagePositionPatient: expected present",
    "ImageOrientationPatient: expected present",
    "PixelSpacing: expected present",
    "PALETTE COLOR",
    "BitsAllocated 1 ",
];

/// Reads `input` and classifies the result against pydicom's `expected` values.
fn classify(
    input: DicomInput,
    expected: Option<&[f32]>,
    failures: &mut Failures,
    what: &str,
) -> Class {
    let shown = what.to_string();
    let result = std::panic::catch_unwind(|| read_dicom_series(&input, None, false));
    let result = match result {
        Ok(r) => r,
        Err(_) => {
            failures.push(format!("{shown}: PANIC"));
            return Class::Refused("panic".into());
        }
    };
    match (result, expected) {
        (Ok((v, _)), Some(expected)) => {
            let (values, dims) = file_order(&v);
            let differing = values
                .iter()
                .zip(expected)
                .filter(|(a, b)| a.to_bits() != b.to_bits() && !(a.is_nan() && b.is_nan()))
                .count();
            if values.len() != expected.len() || differing > 0 {
                let first = values.iter().zip(expected).find(|(a, b)| a != b);
                failures.push(format!(
                    "{shown}: accepted as {dims:?} ({} values) but {differing} differ from pydicom's {} values; first {first:?}",
                    values.len(),
                    expected.len()
                ));
            }
            Class::AcceptedAndMatches
        }
        (Ok((v, _)), None) => {
            failures.push(format!(
                "{shown}: accepted as {:?} where pydicom gives no greyscale array",
                v.dims
            ));
            Class::AcceptedAndMatches
        }
        (Err(e), _) => Class::Refused(e.to_string()),
    }
}

/// One pydicom file alone: its class, with failures noted.
fn alone(out: &Path, entry: &serde_json::Value, failures: &mut Failures) -> Class {
    let path = PathBuf::from(entry["path"].as_str().unwrap());
    let file = entry["file"].as_str().unwrap();
    let expected = reference(out, entry, 1);
    let class = classify(
        DicomInput::Files(vec![path]),
        expected.as_deref(),
        failures,
        file,
    );
    let Class::Refused(reason) = class else {
        return class;
    };
    if !entry["pydicom"].as_str().unwrap().starts_with("read") {
        return Class::NotDicom(reason);
    }
    if entry["pixels"] == "none" {
        return Class::NotAVolume(reason);
    }
    check_reason(entry, expected.is_some(), &reason, failures);
    Class::Refused(reason)
}

/// A refusal names its reason; colour is refused as colour; a greyscale image pydicom
/// decodes is refused only for what volphot does not promise.
fn check_reason(entry: &serde_json::Value, greyscale: bool, reason: &str, failures: &mut Failures) {
    let file = entry["file"].as_str().unwrap();
    if reason.trim_end().ends_with("Could not decode pixel data") {
        failures.push(format!("{file}: refused without a reason: {reason}"));
    }
    let samples = entry["SamplesPerPixel"].as_u64().unwrap_or(1);
    if entry["pixels"] == "decoded" && samples > 1 && !reason.contains("SamplesPerPixel") {
        failures.push(format!(
            "{file}: a colour image refused, but not as colour: {reason}"
        ));
    }
    if greyscale && !ALLOWED_REFUSALS.iter().any(|a| reason.contains(a)) {
        failures.push(format!(
            "{file}: pydicom decodes it, volphot refuses: {reason}"
        ));
    }
}

/// The three-slice series pydicom wrote of a single-frame image: accepted exactly when the
/// file alone is, and then pydicom's values three times.
fn series(
    out: &Path,
    entry: &serde_json::Value,
    single: &Class,
    failures: &mut Failures,
) -> Option<Class> {
    let dir = out.join(entry["series"].as_str()?);
    let file = format!("{} ×3", entry["file"].as_str().unwrap());
    let expected = reference(out, entry, 3);
    let class = classify(
        DicomInput::Folder(dir),
        expected.as_deref(),
        failures,
        &file,
    );
    if matches!(single, Class::AcceptedAndMatches) != matches!(class, Class::AcceptedAndMatches) {
        failures.push(format!("{file}: {class:?} but alone {single:?}"));
    }
    Some(class)
}

/// The file copied into a folder beside three good slices: the volume holds the good
/// slices and the record names the file (or, for an image of another series, that series
/// as not used), or the error names the file — never a silent drop.
fn beside_good_slices(entry: &serde_json::Value, single: &Class, failures: &mut Failures) {
    if matches!(single, Class::AcceptedAndMatches) {
        return;
    }
    let file = entry["file"].as_str().unwrap();
    let dir = tempfile::tempdir().unwrap();
    for p in 0..3 {
        let spec = SliceSpec::ct("2.25.4242", &format!("2.25.4242.{p}"), p as f64, [2, 2]);
        write_slice(&dir.path().join(format!("good{p}")), &spec, &[p as u16; 4]).unwrap();
    }
    let name = "zz-the-odd-one";
    std::fs::copy(entry["path"].as_str().unwrap(), dir.path().join(name)).unwrap();
    match std::panic::catch_unwind(|| {
        read_dicom_series(&DicomInput::Folder(dir.path().into()), None, false)
    }) {
        Err(_) => failures.push(format!("{file} beside good slices: PANIC")),
        Ok(Ok((v, _))) => {
            // Named, or (an image of another series) its series named as not used.
            let choice = v.acquisition.unwrap().choice;
            if !choice.contains(name) && !choice.contains("not used:") {
                failures.push(format!(
                    "{file} beside good slices: left out without a word ({choice})"
                ));
            }
        }
        Ok(Err(e)) => {
            if !e.to_string().contains(name) {
                failures.push(format!(
                    "{file} beside good slices: the error does not name it: {e}"
                ));
            }
        }
    }
}

fn one_line(class: &Class, path: &str) -> String {
    let (label, reason) = match class {
        Class::AcceptedAndMatches => return "accepted-and-matches".into(),
        Class::Refused(r) => ("refused-with-reason", r),
        Class::NotDicom(r) => ("not-DICOM", r),
        Class::NotAVolume(r) => ("not-a-volume", r),
    };
    // The reason without the path that starts it.
    let tail = reason
        .strip_prefix(path)
        .map_or(reason.as_str(), |t| t.trim_start_matches([':', ' ']));
    let tail: String = tail.chars().take(110).collect();
    format!("{label}: {tail}")
}

#[test]
fn pydicom_corpus_matches_pydicom_file_by_file() {
    let test = "pydicom_corpus_matches_pydicom_file_by_file";
    let out = tempfile::tempdir().unwrap();
    let Some(manifest) = export(test, out.path()) else {
        return;
    };
    let files = manifest["files"].as_array().unwrap();
    assert!(files.len() >= 100, "pydicom bundles {} files", files.len());
    let mut failures = Failures::new();
    let mut table = Vec::new();
    let mut accepted = 0;
    for entry in files {
        let single = alone(out.path(), entry, &mut failures);
        accepted += usize::from(single == Class::AcceptedAndMatches);
        let path = entry["path"].as_str().unwrap();
        let mut line = format!(
            "{:<44} {}",
            entry["file"].as_str().unwrap(),
            one_line(&single, path)
        );
        if let Some(s) = series(out.path(), entry, &single, &mut failures) {
            let first = out
                .path()
                .join(entry["series"].as_str().unwrap())
                .join("s0.dcm");
            line += &format!(" | ×3: {}", one_line(&s, &first.display().to_string()));
        }
        beside_good_slices(entry, &single, &mut failures);
        table.push(line);
    }
    eprintln!(
        "pydicom {} corpus, {} files:\n{}",
        manifest["pydicom"],
        files.len(),
        table.join("\n")
    );
    assert!(
        failures.is_empty(),
        "{} failures:\n{}",
        failures.len(),
        failures.join("\n")
    );
    assert!(accepted >= 40, "only {accepted} files accepted");
}
