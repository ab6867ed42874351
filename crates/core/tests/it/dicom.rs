//! The DICOM series reader on series written here with the dicom-rs crates: sorting by
//! position (not file name), series choice, HU rescale, signed/unsigned storage,
//! MONOCHROME1, enhanced multi-frame objects, patient-axis orientation, and every bad input
//! the issue lists (each an error naming the file and the problem), RLE Lossless slices.
//! With the real data present, the cranium CT is written as a series (every third slice
//! RLE-compressed) and read back voxel for voxel.

use std::path::{Path, PathBuf};

use volphot::test_util::dicom::{SliceSpec, write_slice};
use volphot::{DicomInput, LoadedVoxels, Orientation, read_dicom_series};

mod pydicom_corpus;

/// RLE Lossless transfer syntax UID.
const RLE_LOSSLESS: &str = "1.2.840.10008.1.2.5";

const ROWS: u16 = 3;
const COLS: u16 = 4;

/// The stored value at column x, row y of the slice with position index p.
fn value(x: usize, y: usize, p: usize) -> i32 {
    x as i32 + 10 * y as i32 + 100 * p as i32 - 250
}

fn words(p: usize, encode: impl Fn(i32) -> u16) -> Vec<u16> {
    let mut out = Vec::new();
    for y in 0..ROWS as usize {
        for x in 0..COLS as usize {
            out.push(encode(value(x, y, p)));
        }
    }
    out
}

/// Writes slices p = 0..n at z = z0 + p·dz with names in a shuffled order, largest z first.
fn write_series(dir: &Path, uid: &str, n: usize, dz: f64, edit: impl Fn(usize, &mut SliceSpec)) {
    let order: Vec<usize> = (0..n).rev().collect();
    for (k, &p) in order.iter().enumerate() {
        let name = format!("IM{:04}", (k * 7 + 3) % 1000);
        let mut spec = SliceSpec::ct(
            uid,
            &format!("{uid}.{p}"),
            5.0 + p as f64 * dz,
            [ROWS, COLS],
        );
        edit(p, &mut spec);
        let encode = |v: i32| v as i16 as u16;
        write_slice(&dir.join(name), &spec, &words(p, encode)).unwrap();
    }
}

fn read(dir: &Path, series: Option<&str>) -> volphot::Result<LoadedVoxels> {
    read_dicom_series(&DicomInput::Folder(dir.to_path_buf()), series, false).map(|(v, _)| v)
}

fn error(dir: &Path, series: Option<&str>) -> String {
    match read(dir, series) {
        Ok(v) => panic!("expected an error, loaded {:?}", v.dims),
        Err(e) => e.to_string(),
    }
}

fn assert_values(v: &LoadedVoxels, n: usize, f: impl Fn(i32) -> f32) {
    assert_eq!(v.dims, [COLS as usize, ROWS as usize, n]);
    for p in 0..n {
        for y in 0..ROWS as usize {
            for x in 0..COLS as usize {
                let got = v.values[x + COLS as usize * (y + ROWS as usize * p)];
                assert_eq!(got, f(value(x, y, p)), "voxel ({x}, {y}, {p})");
            }
        }
    }
}

#[test]
fn slices_are_sorted_by_position_and_the_largest_series_is_chosen() {
    let dir = tempfile::tempdir().unwrap();
    write_series(dir.path(), "2.25.10", 5, 2.0, |_, _| {});
    write_series(
        &dir.path().join("scout").tap_mkdir(),
        "2.25.99",
        1,
        2.0,
        |_, _| {},
    );
    std::fs::write(dir.path().join("README.txt"), "not dicom").unwrap();
    let v = read(dir.path(), None).unwrap();
    assert_values(&v, 5, |s| s as f32);
    assert_eq!(v.spacing, Some([0.5, 0.75, 2.0]));
    let a = v.acquisition.unwrap();
    assert_eq!(a.series_uid.as_deref(), Some("2.25.10"));
    assert_eq!((a.slices, a.files), (5, 5));
    assert!(
        a.choice.contains("largest") && a.choice.contains("2.25.99 (1 slices)"),
        "{}",
        a.choice
    );
    assert_eq!(
        a.orientation,
        Orientation::AxisAligned {
            file_axes: ["L".into(), "P".into(), "S".into()]
        }
    );
    // The one-slice series can be asked for by UID.
    let one = read(dir.path(), Some("2.25.99")).unwrap();
    assert_eq!(one.dims, [4, 3, 1]);
}

#[test]
fn unsigned_storage_with_intercept_is_rescaled_to_hu() {
    let dir = tempfile::tempdir().unwrap();
    let uid = "2.25.11";
    for p in 0..3 {
        let mut spec = SliceSpec::ct(uid, &format!("{uid}.{p}"), p as f64 * 1.25, [ROWS, COLS]);
        spec.signed = false;
        spec.rescale = [1.0, -1024.0];
        write_slice(
            &dir.path().join(format!("s{p}")),
            &spec,
            &words(p, |v| (v + 1024) as u16),
        )
        .unwrap();
    }
    let v = read(dir.path(), None).unwrap();
    assert_values(&v, 3, |s| s as f32);
    assert_eq!(v.voxel_type, volphot::VoxelType::I16);
    assert_eq!(v.acquisition.unwrap().rescale, vec![[1.0, -1024.0]]);
}

#[test]
fn twelve_bit_monochrome1_is_inverted_and_slope_applied() {
    let dir = tempfile::tempdir().unwrap();
    write_series(dir.path(), "2.25.12", 3, 1.0, |_, s| {
        s.signed = false;
        s.bits_stored = 12;
        s.monochrome1 = true;
        s.rescale = [0.5, 10.0];
    });
    // write_series stores v as i16 bits; with 12 unsigned bits the reader sees v & 0xFFF.
    let v = read(dir.path(), None).unwrap();
    assert_values(&v, 3, |s| 0.5 * (4095 - (s & 0xFFF)) as f32 + 10.0);
    assert_eq!(v.voxel_type, volphot::VoxelType::F32);
}

#[test]
fn enhanced_multi_frame_object_is_one_series() {
    let dir = tempfile::tempdir().unwrap();
    let mut spec = SliceSpec::ct("2.25.13", "2.25.13.1", 0.0, [ROWS, COLS]);
    // Frames stored in the order p = 2, 0, 3, 1.
    let order = [2usize, 0, 3, 1];
    spec.positions = order
        .iter()
        .map(|&p| [-100.0, -120.0, 1.5 * p as f64])
        .collect();
    spec.rescale = [1.0, -1000.0];
    let all: Vec<u16> = order
        .iter()
        .flat_map(|&p| words(p, |v| v as i16 as u16))
        .collect();
    write_slice(&dir.path().join("enhanced.dcm"), &spec, &all).unwrap();
    let v = read(dir.path(), None).unwrap();
    assert_values(&v, 4, |s| s as f32 - 1000.0);
    assert_eq!(v.spacing, Some([0.5, 0.75, 1.5]));
    assert_eq!(v.acquisition.unwrap().files, 1);
}

#[test]
fn sagittal_series_is_permuted_exactly_onto_patient_axes() {
    let dir = tempfile::tempdir().unwrap();
    // Columns run +P, rows run −S (towards the feet); slices are stacked along x.
    for p in 0..3 {
        let mut spec = SliceSpec::ct("2.25.14", &format!("2.25.14.{p}"), 0.0, [ROWS, COLS]);
        spec.orientation = [0.0, 1.0, 0.0, 0.0, 0.0, -1.0];
        spec.positions = vec![[2.0 * p as f64, -50.0, 80.0]];
        write_slice(
            &dir.path().join(format!("x{p}")),
            &spec,
            &words(p, |v| v as i16 as u16),
        )
        .unwrap();
    }
    let v = read(dir.path(), None).unwrap();
    // Normal = row × column = (0,1,0) × (0,0,−1) = (−1,0,0): sorted along −x, so the slice
    // with the largest x (p = 2) comes first; grid x = L runs over p ascending.
    assert_eq!(v.dims, [3, COLS as usize, ROWS as usize]);
    assert_eq!(v.spacing, Some([2.0, 0.5, 0.75]));
    for z in 0..ROWS as usize {
        for y in 0..COLS as usize {
            for x in 0..3 {
                let got = v.values[x + 3 * (y + COLS as usize * z)];
                // grid y = P = column index; grid z = S = rows reversed.
                assert_eq!(
                    got,
                    value(y, ROWS as usize - 1 - z, x) as f32,
                    "grid ({x},{y},{z})"
                );
            }
        }
    }
    match v.acquisition.unwrap().orientation {
        Orientation::AxisAligned { file_axes } => assert_eq!(file_axes, ["P", "I", "R"]),
        other => panic!("{other:?}"),
    }
}

#[test]
fn oblique_series_keeps_its_own_frame_and_says_so() {
    let dir = tempfile::tempdir().unwrap();
    let (c, s) = (0.8, 0.6);
    for p in 0..3 {
        let mut spec = SliceSpec::ct("2.25.15", &format!("2.25.15.{p}"), 0.0, [ROWS, COLS]);
        spec.orientation = [c, s, 0.0, -s, c, 0.0];
        spec.positions = vec![[1.0, 2.0, 3.0 * p as f64]];
        write_slice(
            &dir.path().join(format!("o{p}")),
            &spec,
            &words(p, |v| v as i16 as u16),
        )
        .unwrap();
    }
    let v = read(dir.path(), None).unwrap();
    assert_values(&v, 3, |s| s as f32);
    let a = v.acquisition.unwrap();
    assert!(matches!(a.orientation, Orientation::Oblique { .. }));
    assert!(a.describe().contains("OBLIQUE"), "{}", a.describe());
}

#[test]
fn a_missing_slice_is_an_error_naming_the_gap() {
    let dir = tempfile::tempdir().unwrap();
    write_series(dir.path(), "2.25.16", 6, 1.5, |_, _| {});
    let gone = (0..6)
        .map(|k| dir.path().join(format!("IM{:04}", (k * 7 + 3) % 1000)))
        .nth(2)
        .unwrap();
    std::fs::remove_file(&gone).unwrap();
    let e = error(dir.path(), None);
    assert!(
        e.contains("gap of 3.0000 mm") && e.contains("1.5000 mm apart"),
        "{e}"
    );
    assert!(e.contains("IM"), "{e}");
    assert!(
        e.contains("resample = true"),
        "the error says how to go on: {e}"
    );

    // Asked to, the reader interpolates the missing slice from its neighbours (the values
    // are linear in the position index, so the interpolation is exact) and says so.
    let (v, _) =
        read_dicom_series(&DicomInput::Folder(dir.path().to_path_buf()), None, true).unwrap();
    assert_values(&v, 6, |s| s as f32);
    assert_eq!(v.spacing.map(|s| s[2]), Some(1.5));
    assert_eq!(v.voxel_type, volphot::VoxelType::F32);
    let a = v.acquisition.unwrap();
    assert!(
        a.choice.contains("RESAMPLED")
            && a.choice.contains("5 irregularly spaced slices")
            && a.choice.contains("onto 6 slices"),
        "{}",
        a.choice
    );
}

#[test]
fn resampling_interpolates_uneven_gaps_linearly() {
    let dir = tempfile::tempdir().unwrap();
    // Positions 0, 1, 3, 4 (mm): the median step is 1, so slices land at 0, 1, 2, 3, 4 and
    // the one at 2 is halfway between the slices at 1 and 3.
    let z = [0.0, 1.0, 3.0, 4.0];
    for (p, zp) in z.iter().enumerate() {
        let spec = SliceSpec::ct("2.25.17", &format!("2.25.17.{p}"), *zp, [ROWS, COLS]);
        write_slice(
            &dir.path().join(format!("s{p}")),
            &spec,
            &words(p, |v| v as i16 as u16),
        )
        .unwrap();
    }
    let (v, _) =
        read_dicom_series(&DicomInput::Folder(dir.path().to_path_buf()), None, true).unwrap();
    assert_eq!(v.dims, [COLS as usize, ROWS as usize, 5]);
    let plane = (ROWS * COLS) as usize;
    for (k, source) in [(0, 0.0), (1, 1.0), (2, 1.5), (3, 2.0), (4, 3.0)] {
        let got = v.values[k * plane];
        let expected = value(0, 0, 0) as f32 + 100.0 * source;
        assert!(
            (got - expected).abs() < 1e-3,
            "slice {k}: {got} vs {expected}"
        );
    }
}

#[test]
fn a_slice_of_another_size_is_an_error_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    write_series(dir.path(), "2.25.17", 3, 1.0, |_, _| {});
    let spec = SliceSpec::ct("2.25.17", "2.25.17.9", 8.0, [ROWS + 1, COLS]);
    write_slice(
        &dir.path().join("odd.dcm"),
        &spec,
        &vec![0; (ROWS as usize + 1) * COLS as usize],
    )
    .unwrap();
    let e = error(dir.path(), None);
    assert!(
        e.contains("odd.dcm") && e.contains("4×4 (rows×columns)") && e.contains("3×4"),
        "{e}"
    );
}

#[test]
fn equal_series_need_a_choice_and_the_error_lists_them() {
    let dir = tempfile::tempdir().unwrap();
    write_series(
        &dir.path().join("a").tap_mkdir(),
        "2.25.18",
        2,
        1.0,
        |_, _| {},
    );
    write_series(
        &dir.path().join("b").tap_mkdir(),
        "2.25.19",
        2,
        1.0,
        |_, s| s.description = "second".into(),
    );
    let e = error(dir.path(), None);
    assert!(
        e.contains("2.25.18 (2 slices") && e.contains("2.25.19 (2 slices, \"second\")"),
        "{e}"
    );
    assert!(e.contains("set `series`"), "{e}");
    let v = read(dir.path(), Some("2.25.19")).unwrap();
    assert_eq!(
        v.acquisition.unwrap().series_uid.as_deref(),
        Some("2.25.19")
    );
    let e = error(dir.path(), Some("2.25.77"));
    assert!(e.contains("\"2.25.77\" is not in the input"), "{e}");
}

trait TapMkdir {
    fn tap_mkdir(self) -> PathBuf;
}

impl TapMkdir for PathBuf {
    fn tap_mkdir(self) -> PathBuf {
        std::fs::create_dir_all(&self).unwrap();
        self
    }
}

/// RLE Lossless, decoded by dicom-rs's native codec: a series whose every other slice is
/// RLE-compressed (written here, PS3.5 Annex G, replicate and literal runs) reads exactly as
/// the uncompressed series.
#[test]
fn rle_lossless_slices_read_as_their_uncompressed_twins() {
    // 16×16 unsigned slices: a flat band (replicate runs in both byte planes) beside values
    // whose high and low bytes both vary (literal runs).
    let word = |x: usize, y: usize, p: usize| -> u16 {
        if x < 6 {
            1000 + 7 * p as u16
        } else {
            ((x * y * 397 + p * 1111) % 60000) as u16
        }
    };
    let dir = tempfile::tempdir().unwrap();
    for p in 0..4 {
        let mut spec = SliceSpec::ct("2.25.22", &format!("2.25.22.{p}"), p as f64, [16, 16]);
        spec.signed = false;
        spec.rescale = [1.0, 0.0];
        if p % 2 == 0 {
            spec.transfer_syntax = RLE_LOSSLESS.into();
        }
        let words: Vec<u16> = (0..256).map(|i| word(i % 16, i / 16, p)).collect();
        write_slice(&dir.path().join(format!("s{p}")), &spec, &words).unwrap();
    }
    let v = read(dir.path(), None).unwrap();
    assert_eq!(v.dims, [16, 16, 4]);
    for (i, got) in v.values.iter().enumerate() {
        let (x, y, p) = (i % 16, (i / 16) % 16, i / 256);
        assert_eq!(*got, f32::from(word(x, y, p)), "voxel ({x}, {y}, {p})");
    }
}

#[test]
fn an_unsupported_transfer_syntax_is_named() {
    let dir = tempfile::tempdir().unwrap();
    write_series(dir.path(), "2.25.20", 2, 1.0, |_, s| {
        s.transfer_syntax = "1.2.840.10008.1.2.4.90".into();
    });
    let e = error(dir.path(), None);
    assert!(
        e.contains("1.2.840.10008.1.2.4.90") && e.contains("JPEG 2000"),
        "{e}"
    );
}

#[test]
fn truncated_pixel_data_is_an_error_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    write_series(dir.path(), "2.25.21", 3, 1.0, |_, _| {});
    let victim = dir.path().join("IM0010");
    let bytes = std::fs::read(&victim).unwrap();
    std::fs::write(&victim, &bytes[..bytes.len() - 7]).unwrap();
    let e = error(dir.path(), None);
    assert!(e.contains("IM0010"), "{e}");
}

#[test]
fn folders_without_dicom_images_are_errors() {
    let dir = tempfile::tempdir().unwrap();
    let e = error(dir.path(), None);
    assert!(e.contains("empty"), "{e}");
    std::fs::write(dir.path().join("notes.txt"), "hello").unwrap();
    let e = error(dir.path(), None);
    assert!(
        e.contains("no DICOM images") && e.contains("not DICOM") && e.contains("notes.txt"),
        "{e}"
    );
    let e = read_dicom_series(
        &DicomInput::Files(vec![dir.path().join("notes.txt")]),
        None,
        false,
    )
    .err()
    .unwrap()
    .to_string();
    assert!(
        e.contains("notes.txt") && e.contains("not a readable DICOM file"),
        "{e}"
    );
}

#[test]
fn a_scene_renders_a_dicom_folder_and_records_the_series() {
    let dir = tempfile::tempdir().unwrap();
    let series = dir.path().join("series");
    std::fs::create_dir(&series).unwrap();
    write_series(&series, "2.25.22", 4, 1.0, |_, _| {});
    let src = "[volume]\ndicom = \"series\"\n[three_point]\n";
    let scene_path = dir.path().join("scene.toml");
    std::fs::write(&scene_path, src).unwrap();
    let scene = volphot::Scene::load(&scene_path, &volphot::SearchPath::new(vec![])).unwrap();
    let described = scene.volume_source().describe();
    assert!(
        described.contains("2.25.22") && described.contains("4 slices"),
        "{described}"
    );
    let json = serde_json::to_string(scene.volume_source()).unwrap();
    assert!(
        json.contains("\"series_uid\":\"2.25.22\"") && json.contains("\"spacing_mm\""),
        "{json}"
    );
}

/// The real cranium CT written as a series (unsigned storage with intercept −1024, file
/// names shuffled, positions descending, plus a one-slice series in the same folder) reads
/// back voxel for voxel equal to the RAW.
#[test]
fn cranium_ct_written_as_dicom_reads_back_voxel_for_voxel() {
    let Some(data) = volphot::test_util::real_data_dir() else {
        volphot::test_util::skip(
            "cranium DICOM round trip",
            "no real data (set VOLPHOT_DATA)",
        );
        return;
    };
    let raw = std::fs::read(data.join("cranium_ct_256x256x108_int16.raw")).unwrap();
    let hu: Vec<i16> = raw
        .chunks_exact(2)
        .map(|c| i16::from_le_bytes([c[0], c[1]]))
        .collect();
    let (n, nz) = (256usize, 108usize);
    let dir = tempfile::tempdir().unwrap();
    for z in 0..nz {
        let mut spec = SliceSpec::ct(
            "2.25.30",
            &format!("2.25.30.{z}"),
            0.0,
            [n as u16, n as u16],
        );
        spec.positions = vec![[-122.0, -122.0, 200.0 - 1.5 * (nz - 1 - z) as f64]];
        spec.pixel_spacing = [0.957, 0.957];
        spec.signed = false;
        spec.rescale = [1.0, -1024.0];
        if z % 3 == 0 {
            spec.transfer_syntax = RLE_LOSSLESS.into();
        }
        let slice = &hu[z * n * n..(z + 1) * n * n];
        let w: Vec<u16> = slice
            .iter()
            .map(|&v| (i32::from(v) + 1024) as u16)
            .collect();
        let name = format!("{:03}.dcm", (z * 37) % nz);
        write_slice(&dir.path().join(name), &spec, &w).unwrap();
    }
    let scout = SliceSpec::ct("2.25.31", "2.25.31.1", 0.0, [8, 8]);
    write_slice(&dir.path().join("scout.dcm"), &scout, &[0; 64]).unwrap();
    let v = read(dir.path(), None).unwrap();
    assert_eq!(v.dims, [n, n, nz]);
    let spacing = v.spacing.unwrap();
    assert!(
        (spacing[2] - 1.5).abs() < 1e-5 && (spacing[0] - 0.957).abs() < 1e-6,
        "{spacing:?}"
    );
    let bad = v
        .values
        .iter()
        .zip(&hu)
        .position(|(a, &b)| *a != f32::from(b));
    assert_eq!(bad, None, "first differing voxel");
}

/// Benchmark, not a timed test (`cargo test -p volphot-core --test it dicom:: -- --ignored
/// --nocapture load_cost`): a generated 512-slice series of 256×256 signed CT slices
/// against the same voxels as a RAW file, both read and normalised through the public
/// loaders (each computes its content sha256). The issue asks for DICOM ≤ 2× RAW.
#[test]
#[ignore = "benchmark: prints the DICOM/RAW load-time ratio"]
fn load_cost_of_a_512_slice_series_against_raw() {
    use std::time::Instant;
    let (n, nz) = (256usize, 512usize);
    let dir = tempfile::tempdir().unwrap();
    let series = dir.path().join("series");
    std::fs::create_dir(&series).unwrap();
    let mut raw = Vec::with_capacity(n * n * nz * 2);
    for z in 0..nz {
        let slice: Vec<i16> = (0..n * n)
            .map(|i| ((i * 7 + z * 13) % 3000) as i16 - 1024)
            .collect();
        raw.extend(slice.iter().flat_map(|v| v.to_le_bytes()));
        let spec = SliceSpec::ct(
            "2.25.50",
            &format!("2.25.50.{z}"),
            z as f64 * 0.625,
            [n as u16, n as u16],
        );
        let words: Vec<u16> = slice.iter().map(|&v| v as u16).collect();
        write_slice(&series.join(format!("{z:04}.dcm")), &spec, &words).unwrap();
    }
    let raw_path = dir.path().join("same.raw");
    std::fs::write(&raw_path, &raw).unwrap();
    let request = volphot::FileRequest {
        path: raw_path.clone(),
        raw_layout: Some(volphot::RawLayout {
            dims: [n, n, nz],
            voxel: volphot::VoxelType::I16,
            byte_order: volphot::ByteOrder::Little,
            header_bytes: 0,
        }),
        placement: None,
        normalization: None,
        dataset: None,
        expected_sha256: None,
    };
    let t = Instant::now();
    let a = volphot::read_volume(&request).unwrap();
    let raw_s = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let b = volphot::read_dicom_volume(&DicomInput::Folder(series), None, false, &request).unwrap();
    let dicom_s = t.elapsed().as_secs_f64();
    assert_eq!(a.grid().values(), b.grid().values());
    println!(
        "512-slice series ({} MiB of voxels): RAW {raw_s:.3} s, DICOM {dicom_s:.3} s, ratio {:.2}",
        raw.len() >> 20,
        dicom_s / raw_s
    );
}

// --- The folder walk: symbolic links, special files, each file once, bounds ---

/// Longer than any of these tiny loads may take: past it a load counts as a hang, and the
/// test fails instead of blocking CI (a generous guard, not a timing assertion).
const HANG: std::time::Duration = std::time::Duration::from_secs(30);

/// Reads `input` on a thread of its own; a hang fails the test after [`HANG`].
fn read_guarded(input: DicomInput) -> volphot::Result<LoadedVoxels> {
    let (tx, rx) = std::sync::mpsc::channel();
    let shown = format!("{input:?}");
    std::thread::spawn(move || {
        let _ = tx.send(read_dicom_series(&input, None, false).map(|(v, _)| v));
    });
    match rx.recv_timeout(HANG) {
        Ok(result) => result,
        Err(_) => panic!("no answer within {HANG:?} (a hang) reading {shown}"),
    }
}

/// A folder holding three slices (IM0003, IM0010, IM0017) of series 2.25.40, 1 mm apart.
fn three_slices() -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    write_series(dir.path(), "2.25.40", 3, 1.0, |_, _| {});
    dir
}

/// Loads the folder (guarded), checks it is the three slices read once each and returns
/// the record's account of how the series was chosen (where skipped entries are listed).
fn three_slices_read_once(dir: &Path) -> String {
    let v = read_guarded(DicomInput::Folder(dir.to_path_buf())).unwrap();
    assert_values(&v, 3, |s| s as f32);
    let a = v.acquisition.unwrap();
    assert_eq!((a.slices, a.files), (3, 3), "{}", a.choice);
    a.choice
}

fn symlink(target: impl AsRef<Path>, link: impl AsRef<Path>) {
    std::os::unix::fs::symlink(target, link).unwrap();
}

fn mkfifo(path: &Path) {
    let status = std::process::Command::new("mkfifo")
        .arg(path)
        .status()
        .expect("mkfifo");
    assert!(status.success());
}

#[test]
fn a_link_to_the_root_folder_is_not_followed() {
    let dir = three_slices();
    symlink("/", dir.path().join("root"));
    let choice = three_slices_read_once(dir.path());
    assert!(
        choice.contains("SKIPPED") && choice.contains("root -> /") && choice.contains("out of"),
        "{choice}"
    );
}

#[test]
fn links_to_the_folder_itself_and_its_parent_are_not_walked_again() {
    let dir = three_slices();
    symlink(".", dir.path().join("loop"));
    symlink("..", dir.path().join("up"));
    let sub = dir.path().join("sub").tap_mkdir();
    symlink("..", sub.join("back"));
    let choice = three_slices_read_once(dir.path());
    assert!(choice.contains("up -> "), "{choice}");
    assert!(
        choice.contains("loop") && choice.contains("sub/back") && choice.contains("already"),
        "{choice}"
    );
}

#[test]
fn a_fifo_in_the_folder_is_skipped_without_being_opened() {
    let dir = three_slices();
    // Opening it would block until a writer comes, which none will.
    mkfifo(&dir.path().join("zz.dcm"));
    let choice = three_slices_read_once(dir.path());
    assert!(
        choice.contains("FIFO") && choice.contains("zz.dcm"),
        "{choice}"
    );
}

#[test]
fn a_socket_in_the_folder_is_skipped_and_named() {
    let dir = three_slices();
    let _listener = std::os::unix::net::UnixListener::bind(dir.path().join("s.sock")).unwrap();
    let choice = three_slices_read_once(dir.path());
    assert!(
        choice.contains("socket") && choice.contains("s.sock"),
        "{choice}"
    );
}

#[test]
fn links_to_devices_dangling_links_and_link_loops_are_skipped_and_named() {
    let dir = three_slices();
    symlink("/dev/zero", dir.path().join("zero.dcm"));
    symlink("/dev/null", dir.path().join("null.dcm"));
    symlink("nowhere.dcm", dir.path().join("gone.dcm"));
    symlink("ping", dir.path().join("pong"));
    symlink("pong", dir.path().join("ping"));
    let choice = three_slices_read_once(dir.path());
    assert!(
        choice.contains("zero.dcm -> /dev/zero") && choice.contains("null.dcm -> /dev/null"),
        "{choice}"
    );
    assert!(
        choice.contains("3 × dangling or looping")
            && choice.contains("gone.dcm")
            && choice.contains("ping, pong"),
        "{choice}"
    );
}

#[test]
fn a_slice_reached_twice_through_links_is_read_once() {
    let dir = three_slices();
    symlink("IM0003", dir.path().join("copy.dcm"));
    let sub = dir.path().join("sub").tap_mkdir();
    symlink("../IM0010", sub.join("again.dcm"));
    std::fs::hard_link(dir.path().join("IM0017"), dir.path().join("hard.dcm")).unwrap();
    let choice = three_slices_read_once(dir.path());
    assert!(choice.contains("already"), "{choice}");
}

#[test]
fn two_files_at_one_position_are_an_error_naming_both() {
    let dir = three_slices();
    let spec = SliceSpec::ct("2.25.40", "2.25.40.9", 6.0, [ROWS, COLS]);
    write_slice(&dir.path().join("twin.dcm"), &spec, &words(1, |v| v as u16)).unwrap();
    let e = read_guarded(DicomInput::Folder(dir.path().to_path_buf()))
        .err()
        .unwrap()
        .to_string();
    assert!(
        e.contains("same position") && e.contains("twin.dcm") && e.contains("IM0010"),
        "{e}"
    );
}

#[test]
fn listed_files_must_be_regular_files_and_are_read_once() {
    let dir = three_slices();
    let fifo = dir.path().join("zz.dcm");
    mkfifo(&fifo);
    let names = ["IM0003", "IM0010", "IM0017"].map(|n| dir.path().join(n));
    let with = |extra: &Path| DicomInput::Files([&names[..], &[extra.to_path_buf()]].concat());
    let e = read_guarded(with(&fifo)).err().unwrap().to_string();
    assert!(e.contains("zz.dcm") && e.contains("FIFO"), "{e}");
    let e = read_guarded(with(Path::new("/dev/zero")))
        .err()
        .unwrap()
        .to_string();
    assert!(
        e.contains("/dev/zero") && e.contains("character device"),
        "{e}"
    );
    let sub = dir.path().join("sub").tap_mkdir();
    let e = read_guarded(with(&sub)).err().unwrap().to_string();
    assert!(e.contains("sub") && e.contains("a folder"), "{e}");
    // The same slice named twice, and once more through a link: read once.
    symlink("IM0003", dir.path().join("copy.dcm"));
    let files = [&names[..], &[names[0].clone(), dir.path().join("copy.dcm")]].concat();
    let v = read_guarded(DicomInput::Files(files)).unwrap();
    assert_values(&v, 3, |s| s as f32);
    assert_eq!(v.acquisition.unwrap().files, 3);
}

#[test]
fn folders_nested_past_the_depth_limit_are_an_error_naming_the_limit() {
    let dir = three_slices();
    let mut deep = dir.path().to_path_buf();
    for _ in 0..40 {
        deep = deep.join("d");
    }
    std::fs::create_dir_all(&deep).unwrap();
    let e = read_guarded(DicomInput::Folder(dir.path().to_path_buf()))
        .err()
        .unwrap()
        .to_string();
    let folder = dir.path().display().to_string();
    assert!(e.starts_with(&folder) && e.contains("32 levels"), "{e}");
}
