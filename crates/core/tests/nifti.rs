//! The NIfTI-1 reader on files written here by the `nifti` crate (sform and qform axes,
//! flips and permutations onto grid L, P, S; scl_slope/scl_inter; truncated files), and
//! on the real `ch2.nii.gz` (Debian's `mricron-data`) against the Colin27 RAW.

use std::path::Path;

use ndarray::Array3;
use nifti::NiftiHeader;
use nifti::writer::WriterOptions;
use volphot::{LoadedVoxels, Orientation, read_nifti};

const DIMS: [usize; 3] = [4, 3, 2];

fn value(i: usize, j: usize, k: usize) -> i16 {
    (i + 10 * j + 100 * k) as i16 - 50
}

fn write(path: &Path, header: &NiftiHeader) {
    let data = Array3::from_shape_fn((DIMS[0], DIMS[1], DIMS[2]), |(i, j, k)| value(i, j, k));
    WriterOptions::new(path)
        .reference_header(header)
        .write_nifti(&data)
        .unwrap();
}

fn sform(rows: [[f32; 4]; 3]) -> NiftiHeader {
    NiftiHeader {
        sform_code: 1,
        qform_code: 0,
        srow_x: rows[0],
        srow_y: rows[1],
        srow_z: rows[2],
        ..NiftiHeader::default()
    }
}

/// Checks every grid voxel against the file voxel `source(x, y, z)`.
fn check(
    v: &LoadedVoxels,
    dims: [usize; 3],
    f: impl Fn(usize, usize, usize) -> f32,
    source: impl Fn(usize, usize, usize) -> [usize; 3],
) {
    assert_eq!(v.dims, dims);
    for z in 0..dims[2] {
        for y in 0..dims[1] {
            for x in 0..dims[0] {
                let [i, j, k] = source(x, y, z);
                let got = v.values[x + dims[0] * (y + dims[1] * z)];
                assert_eq!(got, f(i, j, k), "grid ({x},{y},{z}) ← file ({i},{j},{k})");
            }
        }
    }
}

#[test]
fn ras_sform_is_flipped_onto_lps_with_its_spacing() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("ras.nii.gz");
    write(
        &path,
        &sform([
            [0.8, 0.0, 0.0, -50.0],
            [0.0, 0.9, 0.0, -60.0],
            [0.0, 0.0, 1.5, -70.0],
        ]),
    );
    let v = read_nifti(&path).unwrap();
    let [nx, ny, _] = DIMS;
    check(
        &v,
        DIMS,
        |i, j, k| value(i, j, k) as f32,
        |x, y, z| [nx - 1 - x, ny - 1 - y, z],
    );
    assert_eq!(v.spacing, Some([0.8, 0.9, 1.5]));
    assert_eq!(v.voxel_type, volphot::VoxelType::I16);
    let a = v.acquisition.unwrap();
    assert_eq!(
        a.orientation,
        Orientation::AxisAligned {
            file_axes: ["R".into(), "A".into(), "S".into()]
        }
    );
    assert!(a.choice.starts_with("sform"), "{}", a.choice);
}

#[test]
fn permuted_sform_is_reordered_exactly() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("perm.nii");
    // i → +A (2 mm), j → +S (3 mm), k → +R (1 mm).
    write(
        &path,
        &sform([
            [0.0, 0.0, 1.0, 0.0],
            [2.0, 0.0, 0.0, 0.0],
            [0.0, 3.0, 0.0, 0.0],
        ]),
    );
    let v = read_nifti(&path).unwrap();
    // LPS: i → −P, j → +S, k → −L. Grid x = L ← k reversed, y = P ← i reversed, z = S ← j.
    let [ni, nj, nk] = DIMS;
    check(
        &v,
        [nk, ni, nj],
        |i, j, k| value(i, j, k) as f32,
        |x, y, z| [ni - 1 - y, z, nk - 1 - x],
    );
    assert_eq!(v.spacing, Some([1.0, 2.0, 3.0]));
}

#[test]
fn qform_with_negative_qfac_flips_the_slices() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("q.nii");
    let header = NiftiHeader {
        sform_code: 0,
        qform_code: 1,
        quatern_b: 0.0,
        quatern_c: 0.0,
        quatern_d: 0.0,
        pixdim: [-1.0, 1.0, 2.0, 2.5, 0.0, 0.0, 0.0, 0.0],
        ..NiftiHeader::default()
    };
    write(&path, &header);
    let v = read_nifti(&path).unwrap();
    let [nx, ny, nz] = DIMS;
    check(
        &v,
        DIMS,
        |i, j, k| value(i, j, k) as f32,
        |x, y, z| [nx - 1 - x, ny - 1 - y, nz - 1 - z],
    );
    assert_eq!(v.spacing, Some([1.0, 2.0, 2.5]));
    assert!(v.acquisition.unwrap().choice.starts_with("qform"));
}

/// The NIfTI-1 header's scl_slope (byte 112) and scl_inter (byte 116), patched in place
/// because the writer always stores 1 and 0.
fn patch_scaling(path: &Path, slope: f32, inter: f32) {
    let mut bytes = std::fs::read(path).unwrap();
    bytes[112..116].copy_from_slice(&slope.to_le_bytes());
    bytes[116..120].copy_from_slice(&inter.to_le_bytes());
    std::fs::write(path, bytes).unwrap();
}

#[test]
fn scl_slope_and_inter_are_applied_and_recorded() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("scaled.nii");
    write(
        &path,
        &sform([
            [-1.0, 0.0, 0.0, 0.0],
            [0.0, -1.0, 0.0, 0.0],
            [0.0, 0.0, 1.0, 0.0],
        ]),
    );
    patch_scaling(&path, 0.5, -3.0);
    let v = read_nifti(&path).unwrap();
    // An LPS sform: no flips.
    check(
        &v,
        DIMS,
        |i, j, k| 0.5 * value(i, j, k) as f32 - 3.0,
        |x, y, z| [x, y, z],
    );
    assert_eq!(v.voxel_type, volphot::VoxelType::F32);
    assert_eq!(v.acquisition.unwrap().rescale, vec![[0.5, -3.0]]);
}

#[test]
fn truncated_files_are_errors_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let gz = dir.path().join("cut.nii.gz");
    write(&gz, &NiftiHeader::default());
    let bytes = std::fs::read(&gz).unwrap();
    std::fs::write(&gz, &bytes[..bytes.len() / 2]).unwrap();
    let e = read_nifti(&gz)
        .expect_err("a truncated .nii.gz must fail")
        .to_string();
    assert!(e.contains("cut.nii.gz") && e.contains("truncated"), "{e}");

    let nii = dir.path().join("short.nii");
    write(&nii, &NiftiHeader::default());
    let bytes = std::fs::read(&nii).unwrap();
    std::fs::write(&nii, &bytes[..bytes.len() - 10]).unwrap();
    let e = read_nifti(&nii)
        .expect_err("short data must fail")
        .to_string();
    assert!(e.contains("short.nii") && e.contains("truncated"), "{e}");
}

#[test]
fn a_scene_reads_nii_gz_by_extension() {
    let dir = tempfile::tempdir().unwrap();
    write(&dir.path().join("vol.nii.gz"), &NiftiHeader::default());
    let scene_path = dir.path().join("scene.toml");
    std::fs::write(
        &scene_path,
        "[volume]\nfile = \"vol.nii.gz\"\n[three_point]\n",
    )
    .unwrap();
    let scene = volphot::Scene::load(&scene_path, &volphot::SearchPath::new(vec![])).unwrap();
    let json = serde_json::to_string(scene.volume_source()).unwrap();
    assert!(
        json.contains("\"format\":\"nifti\"") && json.contains("\"spacing_mm\""),
        "{json}"
    );
}

/// `ch2.nii.gz` from Debian's mricron-data is the Colin27 RAW in RAS order: read into LPS
/// it is the RAW mirrored in x and y, voxel for voxel.
#[test]
fn real_ch2_matches_the_colin27_raw() {
    let ch2 = Path::new("/usr/share/mricron/templates/ch2.nii.gz");
    let data = volphot::test_util::real_data_dir();
    let (Some(data), true) = (data, ch2.is_file()) else {
        volphot::test_util::skip(
            "ch2.nii.gz against Colin27",
            "needs /usr/share/mricron/templates/ch2.nii.gz (apt-get install mricron-data) and the real data",
        );
        return;
    };
    let raw = std::fs::read(data.join("colin27_t1_181x217x181_uint8.raw")).unwrap();
    let v = read_nifti(ch2).unwrap();
    let dims = [181, 217, 181];
    assert_eq!(v.dims, dims);
    let (nx, ny) = (dims[0], dims[1]);
    let mut differing = 0usize;
    for z in 0..dims[2] {
        for y in 0..ny {
            for x in 0..nx {
                let file = (nx - 1 - x) + nx * ((ny - 1 - y) + ny * z);
                differing += usize::from(v.values[x + nx * (y + ny * z)] != f32::from(raw[file]));
            }
        }
    }
    assert_eq!(differing, 0);
    assert_eq!(v.spacing, Some([1.0, 1.0, 1.0]));
}
