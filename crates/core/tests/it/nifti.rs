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

// --- Headers checked before any voxel is read (issue #45, round 3) ----------------------

use volphot::test_util::nifti::{Nifti1, gzip};

/// The 24 voxels of [`Nifti1::default`] in file order (x fastest).
fn default_values() -> Vec<i16> {
    (0..24).map(|i| i * 37 - 400).collect()
}

/// Writes `bytes` as `name` in `dir` and reads it; the error text or the voxels.
fn read_bytes(dir: &Path, name: &str, bytes: &[u8]) -> Result<LoadedVoxels, String> {
    let path = dir.join(name);
    std::fs::write(&path, bytes).unwrap();
    volphot::read_voxels(&path, None).map_err(|e| e.to_string())
}

fn refused(dir: &Path, name: &str, bytes: &[u8]) -> String {
    match read_bytes(dir, name, bytes) {
        Ok(v) => panic!("{name} was read ({:?}); expected an error", v.dims),
        Err(e) => e,
    }
}

fn assert_names(error: &str, needles: &[&str]) {
    for needle in needles {
        assert!(error.contains(needle), "`{error}` lacks `{needle}`");
    }
}

/// Case 5: a header claiming far more voxels than memory allows is refused from the
/// header alone; the deflate stream after it is damaged, so reading on would fail
/// differently (and the unfixed reader reserved the claimed size first).
#[test]
fn an_oversized_nii_gz_is_refused_from_its_header_before_inflating() {
    let dir = tempfile::tempdir().unwrap();
    let header = Nifti1 {
        dim: [3, 4096, 4096, 4096, 1, 1, 1, 1],
        datatype: 2,
        bitpix: 8,
        ..Nifti1::default()
    };
    let mut gz = gzip(&header.file(&vec![0u8; 1 << 16]));
    let n = gz.len();
    gz.truncate(n / 2);
    gz.extend_from_slice(&[0xff; 64]);
    let e = refused(dir.path(), "huge.nii.gz", &gz);
    assert_names(&e, &["huge.nii.gz", "[4096, 4096, 4096]", "refusing"]);
}

/// Case 5: the stream (gzip or not) must hold exactly vox_offset + the voxels' bytes.
#[test]
fn a_stream_longer_or_shorter_than_its_header_claims_is_refused_naming_both_sizes() {
    let dir = tempfile::tempdir().unwrap();
    let h = Nifti1::default();
    let data = h.int16_data(&default_values());
    let mut long = h.file(&data);
    long.extend_from_slice(&[7; 100]);
    let e = refused(dir.path(), "long.nii.gz", &gzip(&long));
    assert_names(&e, &["long.nii.gz", "500 bytes", "352 + 48 = 400"]);
    let e = refused(dir.path(), "long.nii", &long);
    assert_names(&e, &["long.nii", "500 bytes", "352 + 48 = 400"]);
    let short = &long[..390];
    let e = refused(dir.path(), "short.nii.gz", &gzip(short));
    assert_names(
        &e,
        &["short.nii.gz", "390 bytes", "352 + 48 = 400", "truncated"],
    );
    let e = refused(dir.path(), "short.nii", short);
    assert_names(
        &e,
        &["short.nii", "390 bytes", "352 + 48 = 400", "truncated"],
    );
}

/// Case 9: these panicked inside the nifti crate ("Inconsistent raw data size").
#[test]
fn complex_rgb24_and_a_bitpix_that_disagrees_with_the_datatype_are_errors_not_panics() {
    let dir = tempfile::tempdir().unwrap();
    for (name, datatype, bitpix, needles) in [
        ("complex.nii", 32, 64, &["datatype 32 (complex64)"][..]),
        ("rgb.nii", 128, 24, &["datatype 128 (RGB24)"][..]),
        (
            "bitpix.nii",
            4,
            8,
            &["bitpix 8", "datatype 4 (int16)", "16 bits"][..],
        ),
    ] {
        let h = Nifti1 {
            datatype,
            bitpix,
            ..Nifti1::default()
        };
        let e = refused(
            dir.path(),
            name,
            &h.file(&vec![1u8; 24 * bitpix as usize / 8]),
        );
        assert_names(&e, &[name]);
        assert_names(&e, needles);
    }
}

/// Case 10: the voxels start at vox_offset, whatever lies between the header and it.
#[test]
fn the_voxels_are_read_at_vox_offset() {
    let dir = tempfile::tempdir().unwrap();
    let h = Nifti1::default();
    let data = h.int16_data(&default_values());
    let at_352 = read_bytes(dir.path(), "a.nii", &h.file(&data)).unwrap();
    let h608 = Nifti1 {
        vox_offset: 608.0,
        ..Nifti1::default()
    };
    let mut padded = h.header();
    padded.extend_from_slice(&[0; 4]);
    padded.extend_from_slice(&[0xab; 256]);
    padded.extend_from_slice(&data);
    padded[108..112].copy_from_slice(&608f32.to_le_bytes());
    assert_eq!(
        padded,
        h608.file(&data)
            .iter()
            .enumerate()
            .map(|(i, &b)| if (352..608).contains(&i) { 0xab } else { b })
            .collect::<Vec<_>>()
    );
    for (name, bytes) in [("b.nii", padded.clone()), ("b.nii.gz", gzip(&padded))] {
        let v = read_bytes(dir.path(), name, &bytes).unwrap();
        assert_eq!(v.values, at_352.values, "{name}");
    }
    let expected: Vec<f32> = default_values().iter().map(|&v| f32::from(v)).collect();
    assert_eq!(at_352.values, expected);
}

/// Case 10: impossible offsets are refused with the value and the file.
#[test]
fn impossible_vox_offsets_are_refused_naming_the_value() {
    let dir = tempfile::tempdir().unwrap();
    let data = Nifti1::default().int16_data(&default_values());
    for (offset, shown) in [
        (f32::NAN, "vox_offset NaN"),
        (-352.0, "vox_offset -352"),
        (0.0, "vox_offset 0"),
        (348.0, "vox_offset 348"),
        (352.5, "vox_offset 352.5"),
        (1e6, "vox_offset 1000000"),
        (368.0, "vox_offset 368"),
    ] {
        let h = Nifti1 {
            vox_offset: offset,
            ..Nifti1::default()
        };
        // The voxels written at 352 whatever the header says: 368 leaves them short.
        let mut bytes = h.header();
        bytes.extend_from_slice(&[0; 4]);
        bytes.extend_from_slice(&data);
        for name in ["o.nii", "o.nii.gz"] {
            let file = if name.ends_with(".gz") {
                gzip(&bytes)
            } else {
                bytes.clone()
            };
            let e = refused(dir.path(), name, &file);
            assert_names(&e, &[name, shown]);
        }
    }
}

/// Case 10: a `.hdr`/`.img` pair: the offset is into the `.img` (either may be gzipped).
#[test]
fn a_hdr_img_pair_reads_its_voxels_at_vox_offset_in_the_img() {
    let dir = tempfile::tempdir().unwrap();
    let h = Nifti1 {
        magic: *b"ni1\0",
        vox_offset: 16.0,
        ..Nifti1::default()
    };
    let mut img = vec![0x55u8; 16];
    img.extend_from_slice(&h.int16_data(&default_values()));
    let expected: Vec<f32> = default_values().iter().map(|&v| f32::from(v)).collect();
    std::fs::write(dir.path().join("p.img"), &img).unwrap();
    let v = read_bytes(dir.path(), "p.hdr", &h.header()).unwrap();
    assert_eq!(v.values, expected);
    assert_eq!(v.data_path, dir.path().join("p.img"));
    std::fs::write(dir.path().join("q.img.gz"), gzip(&img)).unwrap();
    let v = read_bytes(dir.path(), "q.hdr", &h.header()).unwrap();
    assert_eq!(v.values, expected);
    let e = refused(dir.path(), "r.hdr", &h.header());
    assert_names(&e, &["r.img", "r.img.gz"]);
    std::fs::write(dir.path().join("s.img"), &img[..40]).unwrap();
    let e = refused(dir.path(), "s.hdr", &h.header());
    assert_names(&e, &["s.img", "40 bytes", "16 + 48 = 64"]);
}

/// Case 11: colour and complex types are refused by name, never reinterpreted.
#[test]
fn unsupported_datatypes_are_refused_by_name_with_the_supported_list() {
    let dir = tempfile::tempdir().unwrap();
    for (datatype, bitpix, shown) in [
        (2304, 32, "datatype 2304 (RGBA32)"),
        (1536, 128, "datatype 1536 (float128)"),
        (1792, 128, "datatype 1792 (complex128)"),
        (0, 16, "datatype 0 (unknown)"),
        (77, 16, "datatype 77"),
    ] {
        let h = Nifti1 {
            datatype,
            bitpix,
            ..Nifti1::default()
        };
        let name = format!("t{datatype}.nii");
        let e = refused(
            dir.path(),
            &name,
            &h.file(&vec![0u8; 24 * bitpix as usize / 8]),
        );
        assert_names(
            &e,
            &[&name, shown, "not supported", "uint8 (2)", "float64 (64)"],
        );
    }
}

/// Case 14: pixdim 0 or NaN named by the NIfTI file and field, not as the scene's
/// `spacing` at scene.toml:1:1.
#[test]
fn zero_or_nan_pixdim_names_the_nifti_file_and_field() {
    let dir = tempfile::tempdir().unwrap();
    let data = Nifti1::default().int16_data(&default_values());
    for (codes, pixdim, shown) in [
        ([0, 0], [1.0, 0.0, 0.0, 1.0], "pixdim[1..3] = [0, 0, 1]"),
        (
            [0, 0],
            [1.0, f32::NAN, 1.0, 1.0],
            "pixdim[1..3] = [NaN, 1, 1]",
        ),
        ([1, 0], [1.0, 2.0, 0.0, 1.0], "pixdim[1..3] = [2, 0, 1]"),
    ] {
        let mut p = [0.0f32; 8];
        p[..4].copy_from_slice(&pixdim);
        let h = Nifti1 {
            codes,
            pixdim: p,
            ..Nifti1::default()
        };
        std::fs::write(dir.path().join("p.nii"), h.file(&data)).unwrap();
        let scene_path = dir.path().join("scene.toml");
        std::fs::write(&scene_path, "[volume]\nfile = \"p.nii\"\n[three_point]\n").unwrap();
        let e = volphot::Scene::load(&scene_path, &volphot::SearchPath::new(vec![]))
            .map(|_| ())
            .expect_err("a zero or NaN pixdim must be refused")
            .to_string();
        assert_names(&e, &["p.nii", shown]);
    }
}

/// Case 14: a wrong magic names the file, the magic found and the one expected.
#[test]
fn a_wrong_magic_names_the_file_the_magic_found_and_the_one_expected() {
    let dir = tempfile::tempdir().unwrap();
    let data = Nifti1::default().int16_data(&default_values());
    for (name, magic, needles) in [
        (
            "pair.nii",
            *b"ni1\0",
            &["magic `ni1\\x00`", "expected `n+1\\x00`", ".hdr"][..],
        ),
        (
            "bad.nii.gz",
            *b"n+2\0",
            &["magic `n+2\\x00`", "expected `n+1\\x00`"][..],
        ),
        (
            "single.hdr",
            *b"n+1\0",
            &["magic `n+1\\x00`", "expected `ni1\\x00`"][..],
        ),
    ] {
        let h = Nifti1 {
            magic,
            ..Nifti1::default()
        };
        let file = h.file(&data);
        let file = if name.ends_with(".gz") {
            gzip(&file)
        } else {
            file
        };
        let e = refused(dir.path(), name, &file);
        assert_names(&e, &[name]);
        assert_names(&e, needles);
    }
    let h = Nifti1 {
        sizeof_hdr: 540,
        ..Nifti1::default()
    };
    let e = refused(dir.path(), "two.nii", &h.file(&data));
    assert_names(&e, &["two.nii", "sizeof_hdr 540", "NIfTI-2"]);
}

/// A non-finite scl_slope or scl_inter would make every voxel NaN: refused by field.
#[test]
fn a_non_finite_scaling_is_refused_by_field() {
    let dir = tempfile::tempdir().unwrap();
    let data = Nifti1::default().int16_data(&default_values());
    for (scl, shown) in [
        ([f32::NAN, 0.0], "scl_slope NaN"),
        ([f32::INFINITY, 0.0], "scl_slope inf"),
        ([2.0, f32::NEG_INFINITY], "scl_inter -inf"),
    ] {
        let h = Nifti1 {
            scl,
            ..Nifti1::default()
        };
        let e = refused(dir.path(), "s.nii", &h.file(&data));
        assert_names(&e, &["s.nii", shown]);
    }
}

/// Big-endian headers and voxels read the same as little-endian ones.
#[test]
fn big_endian_files_read_the_same_values() {
    let dir = tempfile::tempdir().unwrap();
    let h = Nifti1 {
        big_endian: true,
        ..Nifti1::default()
    };
    let v = read_bytes(
        dir.path(),
        "be.nii",
        &h.file(&h.int16_data(&default_values())),
    )
    .unwrap();
    let expected: Vec<f32> = default_values().iter().map(|&v| f32::from(v)).collect();
    assert_eq!(v.values, expected);
}

/// Four of mricron-data's templates keep their voxels past byte 352 (extensions or
/// padding, with the extension flag 0): read at vox_offset, each holds exactly the values
/// stored there. The unfixed reader read them from byte 352, shifted (inia19-NeuroMaps'
/// sum came out 1.8× too large).
#[test]
fn real_templates_are_read_at_their_vox_offset() {
    use std::io::Read as _;
    let folder = Path::new("/usr/share/mricron/templates");
    if !folder.is_dir() {
        volphot::test_util::skip(
            "real_templates_are_read_at_their_vox_offset",
            "needs /usr/share/mricron/templates (apt-get install mricron-data)",
        );
        return;
    }
    for name in [
        "HarvardOxford-cort-maxprob-thr0-1mm.nii.gz",
        "inia19-NeuroMaps.nii.gz",
        "jhu189.nii.gz",
        "natbrainlab.nii.gz",
    ] {
        let path = folder.join(name);
        let mut bytes = Vec::new();
        flate2::read::GzDecoder::new(std::fs::File::open(&path).unwrap())
            .read_to_end(&mut bytes)
            .unwrap();
        let offset = f32::from_le_bytes(bytes[108..112].try_into().unwrap()) as usize;
        assert!(offset > 352, "{name}: vox_offset {offset}");
        let stored: Vec<i32> = match i16::from_le_bytes([bytes[70], bytes[71]]) {
            2 => bytes[offset..].iter().map(|&b| i32::from(b)).collect(),
            4 => bytes[offset..]
                .chunks_exact(2)
                .map(|c| i32::from(i16::from_le_bytes([c[0], c[1]])))
                .collect(),
            other => panic!("{name}: datatype {other}"),
        };
        // The reader reorders the voxels onto LPS: compare them as sorted lists.
        let mut read: Vec<i32> = read_nifti(&path)
            .unwrap()
            .values
            .iter()
            .map(|&v| v as i32)
            .collect();
        let mut stored = stored;
        read.sort_unstable();
        stored.sort_unstable();
        assert!(
            read == stored,
            "{name}: the voxels read differ from those at vox_offset"
        );
    }
}
