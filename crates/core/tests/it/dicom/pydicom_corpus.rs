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
    "(JPEG extended) with 12-bit samples cannot be decoded here",
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

/// The image given a position by pydicom (pixel bytes untouched): accepted and equal to
/// pydicom's values, or refused for a reason volphot gives (never a bare codec failure).
fn placed(out: &Path, entry: &serde_json::Value, failures: &mut Failures) -> Option<Class> {
    let path = out.join(entry["placed"].as_str()?);
    let file = format!("{} placed", entry["file"].as_str().unwrap());
    let expected = reference(out, entry, 1);
    let class = classify(
        DicomInput::Files(vec![path]),
        expected.as_deref(),
        failures,
        &file,
    );
    if let Class::Refused(reason) = &class {
        check_reason(entry, expected.is_some(), reason, failures);
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
        if let Some(p) = placed(out.path(), entry, &mut failures) {
            let at = out.path().join(entry["placed"].as_str().unwrap());
            line += &format!(" | placed: {}", one_line(&p, &at.display().to_string()));
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

// --- The rows, one test each, on pydicom's files ---------------------------------

/// pydicom's test file `name` (from its installed package), or `None` (skipped) without it.
fn pydicom_file(test: &str, name: &str) -> Option<PathBuf> {
    let python = venv().join("bin/python");
    let found = std::process::Command::new(&python)
        .args([
            "-c",
            "import pydicom, os; print(os.path.dirname(pydicom.__file__))",
        ])
        .output()
        .ok()
        .filter(|o| o.status.success());
    let Some(out) = found else {
        volphot::test_util::skip(
            test,
            &format!(
                "pydicom is not installed in {} (scripts/pydicom-corpus.sh --install)",
                venv().display()
            ),
        );
        return None;
    };
    let dir = String::from_utf8_lossy(&out.stdout).trim().to_string();
    Some(Path::new(&dir).join("data/test_files").join(name))
}

fn read_files(paths: &[PathBuf]) -> volphot::Result<LoadedVoxels> {
    read_dicom_series(&DicomInput::Files(paths.to_vec()), None, false).map(|(v, _)| v)
}

/// `bytes` without the first occurrence of `element` (which must be there).
fn without(bytes: &[u8], element: &[u8]) -> Vec<u8> {
    let at = bytes
        .windows(element.len())
        .position(|w| w == element)
        .expect("the element is in the file");
    [&bytes[..at], &bytes[at + element.len()..]].concat()
}

/// Row 23: a 32-bit big-endian dose (its empty SliceThickness deleted) reads as its
/// little-endian twin, in pydicom's range (stored 795 000…1 254 000 × DoseGridScaling 1e-6),
/// not with the 16-bit halves of each value swapped.
#[test]
fn big_endian_32_bit_dose_reads_as_its_little_endian_twin() {
    let test = "big_endian_32_bit_dose_reads_as_its_little_endian_twin";
    let (Some(be), Some(le)) = (
        pydicom_file(test, "rtdose_expb_1frame.dcm"),
        pydicom_file(test, "rtdose_1frame.dcm"),
    ) else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let edited = dir.path().join("expb.dcm");
    // (0018,0050) DS, length 0, big endian.
    let empty_thickness = [0x00, 0x18, 0x00, 0x50, b'D', b'S', 0x00, 0x00];
    std::fs::write(
        &edited,
        without(&std::fs::read(&be).unwrap(), &empty_thickness),
    )
    .unwrap();
    let big = read_files(&[edited]).unwrap();
    let little = read_files(&[le]).unwrap();
    assert_eq!(big.dims, [10, 10, 1]);
    assert_eq!(big.values, little.values);
    let (lo, hi) = big
        .values
        .iter()
        .fold((f32::MAX, f32::MIN), |(a, b), v| (a.min(*v), b.max(*v)));
    assert!(
        (0.79..0.80).contains(&lo) && (1.25..1.26).contains(&hi),
        "{lo} … {hi} Gy"
    );
}

/// Peak resident memory of this process, bytes.
fn peak_resident() -> u64 {
    // The address space's own high-water mark (`VmHWM`): a new one begins at `exec`, where
    // `getrusage`'s `ru_maxrss` carries over the spawning process's resident set (a child
    // spawned by a large test binary reported the parent's peak).
    let status = std::fs::read_to_string("/proc/self/status").unwrap();
    let kib: u64 = status
        .lines()
        .find_map(|l| l.strip_prefix("VmHWM:"))
        .and_then(|v| v.trim().trim_end_matches("kB").trim().parse().ok())
        .expect("VmHWM in /proc/self/status");
    kib * 1024
}

/// Reads the file named by `VOLPHOT_READ_ONE` and prints the peak resident memory: run by
/// [`a_malformed_header_is_refused_cheaply_and_named`] in a process of its own, so other
/// tests' memory does not count.
#[test]
#[ignore = "run by a_malformed_header_is_refused_cheaply_and_named in a child process"]
fn read_one_file_and_print_peak_memory() {
    let Ok(file) = std::env::var("VOLPHOT_READ_ONE") else {
        return;
    };
    let result = read_files(&[PathBuf::from(file)]).map(|v| v.dims);
    println!("peak-resident-bytes={} result={result:?}", peak_resident());
}

/// The test harness's name of [`read_one_file_and_print_peak_memory`]: its module path
/// without the crate's name (the module sits wherever the test binary mounts it).
fn read_one_test_name() -> String {
    let module = module_path!().split_once("::").map_or("", |(_, m)| m);
    format!("{module}::read_one_file_and_print_peak_memory")
}

/// The peak resident memory of reading `file` alone, in a child process.
fn peak_memory_reading(file: &Path) -> u64 {
    let out = std::process::Command::new(std::env::current_exe().unwrap())
        .args(["--exact", &read_one_test_name()])
        .args(["--ignored", "--nocapture", "--test-threads", "1"])
        .env("VOLPHOT_READ_ONE", file)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    let peak = stdout
        .split("peak-resident-bytes=")
        .nth(1)
        .and_then(|t| t.split_whitespace().next())
        .and_then(|n| n.parse().ok());
    peak.unwrap_or_else(|| panic!("the child printed no peak: {stdout}"))
}

/// Row 24: a 674-byte file whose data set is encoded otherwise than its transfer syntax
/// says is refused at once (not after gigabytes), and named — alone, and beside good
/// slices.
#[test]
fn a_malformed_header_is_refused_cheaply_and_named() {
    let test = "a_malformed_header_is_refused_cheaply_and_named";
    let Some(un) = pydicom_file(test, "UN_sequence.dcm") else {
        return;
    };
    let e = read_files(std::slice::from_ref(&un))
        .err()
        .unwrap()
        .to_string();
    assert!(
        e.contains("UN_sequence.dcm") && e.contains("damaged"),
        "{e}"
    );
    let peak = peak_memory_reading(&un);
    assert!(peak < 256 << 20, "peak resident memory {} MiB", peak >> 20);
    let dir = tempfile::tempdir().unwrap();
    for p in 0..3 {
        let spec = SliceSpec::ct("2.25.4343", &format!("2.25.4343.{p}"), p as f64, [2, 2]);
        write_slice(&dir.path().join(format!("s{p}")), &spec, &[p as u16; 4]).unwrap();
    }
    std::fs::copy(&un, dir.path().join("s9")).unwrap();
    let e = read_dicom_series(&DicomInput::Folder(dir.path().into()), None, false)
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("s9") && e.contains("damaged"), "{e}");
}

/// Row 24: the end slice of a series with its header cut short.
#[test]
fn a_damaged_end_slice_is_an_error_naming_it() {
    let dir = tempfile::tempdir().unwrap();
    for p in 0..4 {
        let spec = SliceSpec::ct("2.25.4444", &format!("2.25.4444.{p}"), p as f64, [2, 2]);
        write_slice(&dir.path().join(format!("s{p}")), &spec, &[p as u16; 4]).unwrap();
    }
    let last = dir.path().join("s3");
    let bytes = std::fs::read(&last).unwrap();
    std::fs::write(&last, &bytes[..bytes.len() / 2]).unwrap();
    let e = read_dicom_series(&DicomInput::Folder(dir.path().into()), None, false)
        .err()
        .map(|e| e.to_string())
        .unwrap_or_else(|| panic!("the damaged end slice was dropped without a word"));
    assert!(e.contains("s3") && e.contains("damaged"), "{e}");
}

/// Row 25: the RT Dose grids: an empty SliceThickness (type 2) is no error, the frames of
/// a multi-frame grid sit at GridFrameOffsetVector along the normal, DoseGridScaling gives
/// Gy; without the offsets, the error names the frames.
#[test]
fn rt_dose_grids_are_placed_by_their_frame_offsets_and_scaled() {
    let test = "rt_dose_grids_are_placed_by_their_frame_offsets_and_scaled";
    let Some(dose) = pydicom_file(test, "rtdose.dcm") else {
        return;
    };
    let v = read_files(std::slice::from_ref(&dose)).unwrap();
    assert_eq!(v.dims, [10, 10, 15]);
    assert_eq!(v.spacing, Some([10.0, 10.0, 5.0]));
    let max = v.values.iter().fold(0.0f32, |a, b| a.max(*b));
    assert!(max > 0.5 && max < 2.0, "largest dose {max} Gy");
    // (3004,000C) renamed to an unknown tag: every frame at ImagePositionPatient. The
    // tag's bytes appear first as the value of FrameIncrementPointer (0028,0009), then as
    // the element's own tag.
    let dir = tempfile::tempdir().unwrap();
    let unplaced = dir.path().join("unplaced.dcm");
    let mut bytes = std::fs::read(&dose).unwrap();
    let tag = [0x04, 0x30, 0x0C, 0x00];
    let at: Vec<usize> = (0..bytes.len() - 4)
        .filter(|&i| bytes[i..i + 4] == tag)
        .collect();
    assert!(at.len() >= 2, "{at:?}");
    bytes[at[1] + 2] = 0x0B;
    std::fs::write(&unplaced, bytes).unwrap();
    let e = read_files(&[unplaced]).err().unwrap().to_string();
    assert!(
        e.contains("frame 2 of 15")
            && e.contains("frame 1 of 15")
            && e.contains("GridFrameOffsetVector"),
        "{e}"
    );
}

/// Row 26: elements stored with VR UN are read through the dictionary (and the RLE 32-bit
/// dose decodes).
#[test]
fn un_elements_are_read_through_the_dictionary() {
    let test = "un_elements_are_read_through_the_dictionary";
    let (Some(rle), Some(plain)) = (
        pydicom_file(test, "rtdose_rle.dcm"),
        pydicom_file(test, "rtdose.dcm"),
    ) else {
        return;
    };
    let a = read_files(&[rle]).unwrap();
    let b = read_files(&[plain]).unwrap();
    assert_eq!((a.dims, a.spacing), (b.dims, b.spacing));
    assert_eq!(a.values, b.values);
}

/// Row 27: 12-bit JPEG extended, which the pure-Rust codec cannot decode, is refused by
/// name (the docs no longer promise it), and a codec's failure says why.
#[test]
fn undecodable_jpeg_is_refused_with_its_reason() {
    let test = "undecodable_jpeg_is_refused_with_its_reason";
    let out = tempfile::tempdir().unwrap();
    let Some(manifest) = export(test, out.path()) else {
        return;
    };
    for name in ["JPGExtended.dcm", "JPEG-lossy.dcm"] {
        let entry = manifest["files"]
            .as_array()
            .unwrap()
            .iter()
            .find(|e| e["file"] == name)
            .unwrap();
        let placed = out.path().join(entry["placed"].as_str().unwrap());
        let e = read_files(&[placed]).err().unwrap().to_string();
        assert!(
            e.contains("1.2.840.10008.1.2.4.51") && e.contains("12-bit"),
            "{e}"
        );
    }
    // A baseline JPEG fragment that is no JPEG: the codec's own words follow.
    let dir = tempfile::tempdir().unwrap();
    let mut spec = SliceSpec::ct("2.25.4545", "2.25.4545.0", 0.0, [2, 2]);
    spec.transfer_syntax = "1.2.840.10008.1.2.4.50".into();
    spec.signed = false;
    let file = dir.path().join("broken.dcm");
    write_slice(&file, &spec, &[0xD8FF, 0xDBFF, 7, 7]).unwrap();
    let e = read_files(&[file]).err().unwrap().to_string();
    let (_, cause) = e.split_once("Could not decode pixel data").expect(&e);
    assert!(cause.trim_start_matches([':', ' ']).len() > 5, "{e}");
}

/// Row 28: a colour image whose data set is implicit VR under an explicit transfer syntax
/// is read (as pydicom reads it) and refused as colour.
#[test]
fn a_colour_image_in_implicit_vr_is_refused_as_colour() {
    let test = "a_colour_image_in_implicit_vr_is_refused_as_colour";
    let Some(rgb) = pydicom_file(test, "SC_rgb_jpeg.dcm") else {
        return;
    };
    let e = read_files(&[rgb]).err().unwrap().to_string();
    assert!(e.contains("SamplesPerPixel is 3"), "{e}");
}
