//! Bad input, table-driven: every case must produce an error whose text names the culprit
//! (file, key, value) — and nothing may panic.

use std::path::{Path, PathBuf};

use volphot::SearchPath;
use volphot::TransferFunction;
use volphot::{ByteOrder, FileRequest, Normalization, RawLayout, VoxelType, read_volume};
use volphot::{Scene, SceneParams, locate_error, validate_params};
use volphot::{SigmaMapping, SigmaParams};

/// Runs a loader on a scratch folder and returns its error text.
type Loader = Box<dyn Fn(&Path) -> Result<(), String>>;

struct Case {
    name: &'static str,
    /// Runs the loader and returns its error text.
    run: Loader,
    /// Substrings the error must contain.
    expect: &'static [&'static str],
}

fn raw_request(path: PathBuf, dims: [usize; 3], voxel: VoxelType) -> FileRequest {
    FileRequest {
        path,
        raw_layout: Some(RawLayout {
            dims,
            voxel,
            byte_order: ByteOrder::Little,
            header_bytes: 0,
        }),
        placement: None,
        normalization: Some(Normalization::TypeRange),
        dataset: None,
        expected_sha256: None,
    }
}

fn write(dir: &Path, name: &str, bytes: &[u8]) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, bytes).unwrap();
    p
}

use volphot::test_util::SMALL_SCENE as SCENE;
use volphot::test_util::dicom::{SliceSpec, write_slice};

/// Parses, validates and builds a scene from text; returns the located error.
fn scene(dir: &Path, text: &str) -> Result<(), String> {
    let file = dir.join("scene.toml");
    std::fs::write(&file, text).unwrap();
    Scene::load(&file, &SearchPath::new(vec![dir.to_path_buf()]))
        .map(|_| ())
        .map_err(|e| e.to_string())
}

/// Writes 2×2 slices `ct/s0.dcm`, `ct/s1.dcm`, … of one series at positions `z` (mm along
/// the normal), each edited by `edit`, and loads a scene reading them with `extra` in
/// `[volume]`; returns the located error.
fn dicom_scene(d: &Path, z: &[f64], edit: fn(&mut SliceSpec), extra: &str) -> Result<(), String> {
    let ct = d.join("ct");
    std::fs::create_dir(&ct).unwrap();
    for (p, at) in z.iter().enumerate() {
        let mut spec = SliceSpec::ct("2.25.60", &format!("2.25.60.{p}"), *at, [2, 2]);
        edit(&mut spec);
        write_slice(&ct.join(format!("s{p}.dcm")), &spec, &[0; 4]).unwrap();
    }
    scene(
        d,
        &format!("[volume]\ndicom = \"ct\"\n{extra}[three_point]\n"),
    )
}

fn cases() -> Vec<Case> {
    let s = |name, run: Loader, expect| Case { name, run, expect };
    vec![
        // --- DICOM: the error names the DICOM file and its field, not the scene ---
        s(
            "dicom: PixelSpacing 0",
            Box::new(|d| dicom_scene(d, &[0.0, 1.0, 2.0], |s| s.pixel_spacing = [0.0; 2], "")),
            &[
                "/ct/s",
                ".dcm",
                "PixelSpacing (0028,0030) is [0, 0]",
                "positive",
            ],
        ),
        s(
            "dicom: negative PixelSpacing",
            Box::new(|d| dicom_scene(d, &[0.0, 1.0, 2.0], |s| s.pixel_spacing = [-0.75, 0.5], "")),
            &[
                "/ct/s",
                ".dcm",
                "PixelSpacing (0028,0030) is [-0.75, 0.5]",
                "positive",
            ],
        ),
        s(
            "dicom: slices 1e300 mm apart",
            Box::new(|d| dicom_scene(d, &[0.0, 1e300], |_| {}, "")),
            &[
                "/ct/s0.dcm",
                "/ct/s1.dcm",
                "ImagePositionPatient (0020,0032)",
                "1e300 mm",
            ],
        ),
        s(
            "dicom: resampling onto 1e300 slices",
            Box::new(|d| dicom_scene(d, &[0.0, 1.0, 2.0, 1e300], |_| {}, "resample = true\n")),
            &[
                "/ct/s0.dcm",
                "/ct/s3.dcm",
                "ImagePositionPatient (0020,0032)",
                "resample",
            ],
        ),
        // --- RAW ---
        s(
            "raw: truncated file",
            Box::new(|d| {
                let p = write(d, "t.raw", &[0u8; 500]);
                read_volume(&raw_request(p, [8, 8, 8], VoxelType::U8))
                    .map(|_| ())
                    .map_err(|e| e.to_string())
            }),
            &["t.raw", "500 bytes", "512 bytes"],
        ),
        s(
            "raw: wrong type (u16 dims on an 8-bit file)",
            Box::new(|d| {
                let p = write(d, "w.raw", &[0u8; 512]);
                read_volume(&raw_request(p, [8, 8, 8], VoxelType::U16))
                    .map(|_| ())
                    .map_err(|e| e.to_string())
            }),
            &["w.raw", "512 bytes", "1024 bytes", "u16"],
        ),
        s(
            "raw: zero dimension",
            Box::new(|d| {
                let p = write(d, "z.raw", &[0u8; 8]);
                read_volume(&raw_request(p, [8, 0, 1], VoxelType::U8))
                    .map(|_| ())
                    .map_err(|e| e.to_string())
            }),
            &["z.raw", "[8, 0, 1]"],
        ),
        s(
            "raw: dims too large for memory",
            Box::new(|d| {
                let p = write(d, "huge.raw", &[0u8; 8]);
                read_volume(&raw_request(p, [1 << 20, 1 << 20, 1 << 10], VoxelType::U8))
                    .map(|_| ())
                    .map_err(|e| e.to_string())
            }),
            &["huge.raw", "refusing"],
        ),
        s(
            "raw: missing file",
            Box::new(|d| {
                read_volume(&raw_request(d.join("absent.raw"), [2, 2, 2], VoxelType::U8))
                    .map(|_| ())
                    .map_err(|e| e.to_string())
            }),
            &["absent.raw"],
        ),
        s(
            "raw: wrong checksum",
            Box::new(|d| {
                let p = write(d, "c.raw", &[1u8; 8]);
                let mut r = raw_request(p, [2, 2, 2], VoxelType::U8);
                r.expected_sha256 = Some("00".repeat(32));
                read_volume(&r).map(|_| ()).map_err(|e| e.to_string())
            }),
            &["c.raw", "sha256", "0000"],
        ),
        // --- NRRD ---
        s(
            "nrrd: bad magic",
            Box::new(|d| {
                let p = write(d, "m.nrrd", b"NRRX0004\ntype: uchar\n\n");
                volphot::read_nrrd(&p)
                    .map(|_| ())
                    .map_err(|e| e.to_string())
            }),
            &["m.nrrd", "NRRD"],
        ),
        s(
            "nrrd: unsupported type",
            Box::new(|d| {
                let p = write(d, "ty.nrrd", b"NRRD0004\ntype: double\ndimension: 3\nsizes: 2 2 2\nencoding: raw\nendian: little\n\n");
                volphot::read_nrrd(&p)
                    .map(|_| ())
                    .map_err(|e| e.to_string())
            }),
            &["ty.nrrd", "double"],
        ),
        s(
            "nrrd: truncated data",
            Box::new(|d| {
                let mut bytes =
                    b"NRRD0004\ntype: uchar\ndimension: 3\nsizes: 4 4 4\nencoding: raw\n\n"
                        .to_vec();
                bytes.extend_from_slice(&[0u8; 10]);
                let p = write(d, "tr.nrrd", &bytes);
                volphot::read_nrrd(&p)
                    .map(|_| ())
                    .map_err(|e| e.to_string())
            }),
            &["tr.nrrd", "10 bytes", "64 bytes"],
        ),
        s(
            "nrrd: 2-D image",
            Box::new(|d| {
                let p = write(
                    d,
                    "2d.nrrd",
                    b"NRRD0004\ntype: uchar\ndimension: 2\nsizes: 2 2\nencoding: raw\n\n\0\0\0\0",
                );
                volphot::read_nrrd(&p)
                    .map(|_| ())
                    .map_err(|e| e.to_string())
            }),
            &["2d.nrrd", "dimension"],
        ),
        s(
            "nrrd: missing sizes",
            Box::new(|d| {
                let p = write(
                    d,
                    "ns.nrrd",
                    b"NRRD0004\ntype: uchar\ndimension: 3\nencoding: raw\n\n",
                );
                volphot::read_nrrd(&p)
                    .map(|_| ())
                    .map_err(|e| e.to_string())
            }),
            &["ns.nrrd", "sizes"],
        ),
        // --- MetaImage ---
        s(
            "mhd: unsupported element type",
            Box::new(|d| {
                let p = write(d, "e.mhd", b"NDims = 3\nDimSize = 2 2 2\nElementType = MET_DOUBLE\nElementDataFile = e.raw\n");
                volphot::read_metaimage(&p)
                    .map(|_| ())
                    .map_err(|e| e.to_string())
            }),
            &["e.mhd", "MET_DOUBLE"],
        ),
        s(
            "mhd: data file missing",
            Box::new(|d| {
                let p = write(d, "f.mhd", b"NDims = 3\nDimSize = 2 2 2\nElementType = MET_UCHAR\nElementDataFile = gone.raw\n");
                volphot::read_metaimage(&p)
                    .map(|_| ())
                    .map_err(|e| e.to_string())
            }),
            &["gone.raw"],
        ),
        s(
            "mha: truncated local data",
            Box::new(|d| {
                let mut bytes = b"NDims = 3\nDimSize = 4 4 4\nElementType = MET_USHORT\nElementDataFile = LOCAL\n".to_vec();
                bytes.extend_from_slice(&[0u8; 20]);
                let p = write(d, "t.mha", &bytes);
                volphot::read_metaimage(&p)
                    .map(|_| ())
                    .map_err(|e| e.to_string())
            }),
            &["t.mha", "20 bytes", "128 bytes"],
        ),
        // --- PGM transfer functions ---
        s(
            "pgm: wrong size",
            Box::new(|d| {
                let p = write(d, "small.pgm", &volphot::write_pgm(16, 16, &[0u8; 256]));
                TransferFunction::from_pgm(&p)
                    .map(|_| ())
                    .map_err(|e| e.to_string())
            }),
            &["small.pgm", "16×16", "256×256"],
        ),
        s(
            "pgm: colour image (P6)",
            Box::new(|d| {
                let p = write(d, "c.pgm", b"P6\n1 1\n255\n\0\0\0");
                TransferFunction::from_pgm(&p)
                    .map(|_| ())
                    .map_err(|e| e.to_string())
            }),
            &["c.pgm", "P6"],
        ),
        s(
            "pgm: truncated raster",
            Box::new(|d| {
                let p = write(d, "tr.pgm", b"P5\n256 256\n255\n\0\0\0");
                TransferFunction::from_pgm(&p)
                    .map(|_| ())
                    .map_err(|e| e.to_string())
            }),
            &["tr.pgm", "3 bytes", "65536"],
        ),
        // --- scene TOML ---
        s(
            "scene: unknown key",
            Box::new(|d| scene(d, &format!("{SCENE}[integrator]\nnsued = 5\n"))),
            &["scene.toml:5:1", "nsued", "nused"],
        ),
        s(
            "scene: wrong type",
            Box::new(|d| scene(d, &format!("{SCENE}[integrator]\nstepsize = \"small\"\n"))),
            &["scene.toml:5:12", "stepsize"],
        ),
        s(
            "scene: negative stepsize",
            Box::new(|d| scene(d, &format!("{SCENE}[integrator]\nstepsize = -0.001\n"))),
            &[
                "scene.toml:5:12",
                "`integrator.stepsize` = -0.001",
                "[1e-6, 1]",
            ],
        ),
        s(
            "scene: non-finite maxdist",
            Box::new(|d| scene(d, &format!("{SCENE}[integrator]\nmaxdist = nan\n"))),
            &["scene.toml:5:11", "`integrator.maxdist` = NaN"],
        ),
        s(
            "scene: two volume sources",
            Box::new(|d| {
                scene(
                    d,
                    &format!("{SCENE}[volume.x]\n")
                        .replace("[volume]\n", "[volume]\ndataset = \"foot\"\n")
                        .replace("[volume.x]\n", ""),
                )
            }),
            &["scene.toml:1", "exactly one of"],
        ),
        s(
            "scene: unknown dataset",
            Box::new(|d| scene(d, "[volume]\ndataset = \"feet\"\n[three_point]\n")),
            &["scene.toml:2:11", "feet", "foot"],
        ),
        s(
            "scene: dataset not on the search path",
            Box::new(|d| scene(d, "[volume]\ndataset = \"engine\"\n[three_point]\n")),
            &["engine_256x256x128_uint8.raw", "VOLPHOT_DATA"],
        ),
        s(
            "scene: RAW file without dims",
            Box::new(|d| {
                write(d, "v.raw", &[0u8; 8]);
                scene(
                    d,
                    "[volume]\nfile = \"v.raw\"\nvoxel = \"u8\"\n[three_point]\n",
                )
            }),
            &["scene.toml", "`volume.dims`", "RAW"],
        ),
        s(
            "scene: spot light beam wider than its cone",
            Box::new(|d| {
                scene(
                    d,
                    "[volume]\nphantom = { name = \"sphere\", resolution = [8, 8, 8] }\n[[lights]]\ntype = \"spot\"\nposition = [0, 0, 3]\ntarget = [0.5, 0.5, 0.5]\nintensity = 10\ncone_angle = 20\nbeam_width = 30\n",
                )
            }),
            &["scene.toml:9:14", "`lights[0].beam_width` = 30"],
        ),
        s(
            "scene: camera looking at its own eye",
            Box::new(|d| {
                scene(
                    d,
                    &format!("{SCENE}[camera]\neye = [1, 2, 3]\nlook_at = [1, 2, 3]\n"),
                )
            }),
            &["scene.toml:6:11", "`camera.look_at`"],
        ),
        s(
            "scene: phantom parameter for the wrong phantom",
            Box::new(|d| {
                scene(
                    d,
                    "[volume]\nphantom = { name = \"engine\", resolution = [8, 8, 8], radius = 0.3 }\n[three_point]\n",
                )
            }),
            &["scene.toml:2", "`volume.phantom.radius`"],
        ),
        s(
            "scene: transfer threshold above the data",
            Box::new(|d| {
                write(
                    d,
                    "v16.raw",
                    &[0u8, 1, 0, 2, 0, 3, 0, 4, 0, 5, 0, 6, 0, 7, 0, 8],
                );
                scene(
                    d,
                    "[volume]\nfile = \"v16.raw\"\ndims = [2, 2, 2]\nvoxel = \"u16\"\n[transfer]\nkind = \"threshold\"\nthreshold = 40000\n[three_point]\n",
                )
            }),
            &["scene.toml:7:13", "`transfer.threshold` = 40000", "2048"],
        ),
        s(
            "raw: a directory given as the file",
            Box::new(|d| {
                std::fs::create_dir_all(d.join("dir.raw")).unwrap();
                read_volume(&raw_request(d.join("dir.raw"), [2, 2, 2], VoxelType::U8))
                    .map(|_| ())
                    .map_err(|e| e.to_string())
            }),
            &["dir.raw", "is a directory"],
        ),
        s(
            "raw: a NaN voxel in float data",
            Box::new(|d| {
                let mut bytes = Vec::new();
                for i in 0..8 {
                    let v = if i == 5 { f32::NAN } else { i as f32 };
                    bytes.extend_from_slice(&v.to_le_bytes());
                }
                let p = write(d, "nan.raw", &bytes);
                read_volume(&raw_request(p, [2, 2, 2], VoxelType::F32))
                    .map(|_| ())
                    .map_err(|e| e.to_string())
            }),
            &["nan.raw", "voxel 5", "x = 1, y = 0, z = 1", "NaN"],
        ),
        s(
            "scene: a step far too small for a huge box",
            Box::new(|d| {
                scene(
                    d,
                    &format!(
                        "{}[sigma]\nt = 0.001\n[integrator]\nstepsize = 0.0005\n",
                        SCENE.replace(
                            "[three_point]",
                            "box = { p0 = [0, 0, 0], p1 = [1e5, 1e5, 1e5] }\n[three_point]"
                        )
                    ),
                )
            }),
            &["`integrator.stepsize` = 0.0005", "samples per ray"],
        ),
        // --- σ mappings ---
        s(
            "sigma: t so large that free paths vanish (hung before)",
            Box::new(|d| scene(d, &format!("{SCENE}[sigma]\nt = 1e30\n"))),
            &[
                "scene.toml:5:5",
                "`sigma.t` = 1000000000000000000000000000000",
                "mean free path",
            ],
        ),
        s(
            "sigma: t = 1e7 on a unit volume",
            Box::new(|d| scene(d, &format!("{SCENE}[sigma]\nt = 1e7\n"))),
            &["`sigma.t` = 10000000", "σt_max <= 1.000e6"],
        ),
        s(
            "sigma: mean free path of 1e-12 %",
            Box::new(|d| {
                scene(
                    d,
                    &format!("{SCENE}[sigma]\nmapping = \"mean-free-path\"\npercent = 1e-12\n"),
                )
            }),
            &["scene.toml:6:11", "`sigma.percent`", "mean free path"],
        ),
        s(
            "sigma: explicit σ = 1e9",
            Box::new(|d| {
                scene(
                    d,
                    &format!(
                        "{SCENE}[sigma]\nmapping = \"explicit\"\nsigma_a = [1e9, 1e9, 1e9]\nsigma_s = [1e9, 1e9, 1e9]\n"
                    ),
                )
            }),
            &["`sigma.sigma_s`", "mean free path"],
        ),
        s(
            "sigma: negative t",
            Box::new(|d| scene(d, &format!("{SCENE}[sigma]\nt = -80\n"))),
            &["scene.toml:5:5", "`sigma.t` = -80"],
        ),
        s(
            "sigma: chromatic extinction",
            Box::new(|_| {
                SigmaMapping::create(&SigmaParams {
                    mapping: volphot::MappingKind::Explicit,
                    sigma_a: Some([1.0, 1.0, 1.0]),
                    sigma_s: Some([10.0, 5.0, 10.0]),
                    ..Default::default()
                })
                .map(|_| ())
                .map_err(|e| e.to_string())
            }),
            &["`sigma_s`", "grey extinction"],
        ),
        s(
            "sigma: ratio and albedo together",
            Box::new(|d| {
                scene(
                    d,
                    &format!("{SCENE}[sigma]\nalbedo = 0.8\nratio = [1, 4]\n"),
                )
            }),
            &["scene.toml:6:9", "`sigma.ratio`", "either"],
        ),
        s(
            "sigma: percent out of range",
            Box::new(|d| {
                scene(
                    d,
                    &format!("{SCENE}[sigma]\nmapping = \"mean-free-path\"\npercent = -2\n"),
                )
            }),
            &["scene.toml:6:11", "`sigma.percent` = -2"],
        ),
        s(
            "sigma: empty volume after transfer",
            Box::new(|d| {
                scene(
                    d,
                    &format!(
                        "{SCENE}[transfer]\nkind = \"points\"\npoints = [[0.0, 0.0], [1.0, 0.0]]\n"
                    ),
                )
            }),
            &["scene.toml", "non-zero density"],
        ),
    ]
}

#[test]
fn every_bad_input_is_named_and_nothing_panics() {
    let cases = cases();
    assert!(cases.len() >= 20, "at least 20 cases");
    let mut failures = Vec::new();
    for case in &cases {
        let dir = tempfile::tempdir().unwrap();
        let result =
            std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| (case.run)(dir.path())));
        match result {
            Err(_) => failures.push(format!("{}: panicked", case.name)),
            Ok(Ok(())) => failures.push(format!("{}: accepted bad input", case.name)),
            Ok(Err(text)) => {
                for needle in case.expect {
                    if !text.contains(needle) {
                        failures.push(format!("{}: `{text}` lacks `{needle}`", case.name));
                    }
                }
            }
        }
    }
    assert!(
        failures.is_empty(),
        "{} of {} cases failed:\n{}",
        failures.len(),
        cases.len(),
        failures.join("\n")
    );
}

#[test]
fn validate_params_and_locate_agree_on_keys() {
    // A parameter error's key path leads back to where it was written.
    let src = &format!("{SCENE}key_intensity = -1\n");
    let params = SceneParams::from_toml(src, Path::new("s.toml")).unwrap();
    validate_params(&params).unwrap();
    let err = Scene::from_params(&params, Path::new("."), &SearchPath::new(vec![])).unwrap_err();
    let located = locate_error(err, src, Path::new("s.toml")).to_string();
    assert!(located.starts_with("s.toml:4:17"), "{located}");
    assert!(
        located.contains("`three_point.key_intensity` = -1"),
        "{located}"
    );
}

// --- Environment maps and the files a scene names -----------------------------------------

use volphot::test_util::alloc::{largest_allocation, reset_largest};

/// Loads a scene in `dir` lit by the environment map `file` (with `extra` keys in its
/// light table); returns the located error.
fn environment(dir: &Path, file: &str, extra: &str) -> Result<(), String> {
    scene(
        dir,
        &format!("{SCENE}[[lights]]\ntype = \"environment\"\nfile = \"{file}\"\n{extra}"),
    )
}

/// A file of `length` bytes (sparse: only `head` is written) in `dir`.
fn sparse(dir: &Path, name: &str, head: &[u8], length: u64) -> PathBuf {
    let path = write(dir, name, head);
    std::fs::OpenOptions::new()
        .write(true)
        .open(&path)
        .unwrap()
        .set_len(length)
        .unwrap();
    path
}

/// A PFM header whose width times 4 wraps to 0 in 64 bits: `width · 4` passed the size
/// check against an empty file and `vec!` panicked with "capacity overflow" — for the
/// environment map, and for the PFM the peer's Python returns (`read_pfm`).
#[test]
fn a_pfm_whose_size_wraps_64_bits_is_refused() {
    for kind in ["Pf", "PF"] {
        let dir = tempfile::tempdir().unwrap();
        let path = write(
            dir.path(),
            "wrap.pfm",
            format!("{kind}\n4611686018427387904 1\n-1.0\n").as_bytes(),
        );
        let e = environment(dir.path(), "wrap.pfm", "").unwrap_err();
        assert!(
            e.contains("wrap.pfm") && e.contains("4611686018427387904×1") && e.contains("0 bytes"),
            "{kind}: {e}"
        );
        let e = volphot::read_pfm(&path).unwrap_err().to_string();
        assert!(e.contains("wrap.pfm"), "{kind}: {e}");
    }
}

/// Maps larger than the stated bound (2^27 texels, and half the available memory) are
/// refused from their header before a texel is allocated; a file longer than its header's
/// size can take is refused by its length before it is read.
#[test]
fn maps_beyond_the_memory_bound_are_refused_from_their_header() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let header = b"PF\n16384 16384\n-1\n";
    sparse(
        d,
        "huge.pfm",
        header,
        header.len() as u64 + 16384 * 16384 * 12,
    );
    // A Radiance header declaring 16384 × 16384, then run-length encoded scan lines that
    // would fill it from 17 MB (only the first is written: the header is what counts).
    let mut hdr = b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 16384 +X 16384\n".to_vec();
    hdr.extend([2, 2, 64, 0]);
    for _ in 0..4 {
        for _ in 0..129 {
            hdr.extend([128 + 127, 1]);
        }
    }
    write(d, "huge.hdr", &hdr);
    let small = b"PF\n8 4\n-1\n";
    sparse(d, "tail.pfm", small, 3 << 30);
    let mut small_hdr = b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 4 +X 8\n".to_vec();
    small_hdr.extend([0u8; 128]);
    sparse(d, "tail.hdr", &small_hdr, 3 << 30);
    let exr = d.join("small.exr");
    exr::prelude::write_rgb_file(&exr, 8, 4, |_, _| (1.0f32, 1.0f32, 1.0f32)).unwrap();
    sparse(d, "tail.exr", &std::fs::read(&exr).unwrap(), 3 << 30);
    for (file, expected) in [
        ("huge.pfm", "16384×16384 texels"),
        ("huge.hdr", "16384×16384 texels"),
        ("tail.pfm", "3221225462 bytes of pixels, expected 384"),
        ("tail.hdr", "3221225472 bytes is more than a 8×4 map"),
        ("tail.exr", "3221225472 bytes is more than a 8×4 map"),
    ] {
        reset_largest();
        let start = std::time::Instant::now();
        let e = environment(d, file, "").unwrap_err();
        assert!(e.contains(file) && e.contains(expected), "{file}: {e}");
        assert!(
            largest_allocation() < 16 << 20,
            "{file}: {} bytes allocated at once",
            largest_allocation()
        );
        // Reading 3 GiB of a sparse file takes seconds; the header alone, milliseconds.
        assert!(
            start.elapsed().as_secs_f32() < 1.0,
            "{file}: {:?}",
            start.elapsed()
        );
    }
    let e = environment(d, "huge.pfm", "").unwrap_err();
    assert!(e.contains("134217728 (16384 × 8192)"), "{e}");
}

/// A map that is not one — a token file, a key, terminal control sequences, or a link to
/// such a file — is refused without quoting it: at most a few escaped bytes of its start.
#[test]
fn a_map_that_is_not_one_is_refused_without_quoting_it() {
    let secrets: [&[u8]; 4] = [
        // Words of at most 32 bytes, which the PFM reader quoted whole.
        b"ghp_16C7e42F292c6912E7710c83 8347Ae178B4a 1\n",
        b"AKIAIOSFODNN7EXAMPLE wJalrXUtnFEMI/K7MDENG 1\n",
        b"\x1b]0;pwned\x07\x1b[2J\x1b[31mred 4 4\n-1\n",
        // A Radiance header whose FORMAT the image crate quoted (20 bytes).
        b"#?RADIANCE\nFORMAT=ghp_16C7e42F292c6912E7710c83\n\n-Y 1 +X 1\n",
    ];
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for (i, secret) in secrets.iter().enumerate() {
        write(d, &format!("secret{i}.txt"), secret);
        for ext in ["pfm", "hdr", "exr"] {
            let file = format!("sky{i}.{ext}");
            write(d, &file, secret);
            let link = format!("link{i}.{ext}");
            std::os::unix::fs::symlink(format!("secret{i}.txt"), d.join(&link)).unwrap();
            for name in [&file, &link] {
                let e = environment(d, name, "").unwrap_err();
                assert!(e.contains(name.as_str()), "{name}: {e}");
                for quoted in ["16C7e42F", "IOSFODNN", "wJalrX", "pwned", "red"] {
                    assert!(!e.contains(quoted), "{name} quotes `{quoted}`: {e}");
                }
                assert!(
                    !e.contains('\x1b') && !e.contains('\x07'),
                    "{name}: raw control bytes in {e:?}"
                );
            }
        }
    }
}

/// An environment beyond the radiance every light keeps to (1e20 W/m²/sr) is refused as
/// the scene loads, naming the key or the file: a sky's `scale = 1e38`, a PFM whose header
/// scale is −1e38, texels at 3e38 (with `scale = 4`, which the Mitsuba export turned into
/// 48 infinite texels). These were accepted and ended a whole render in infinities.
#[test]
fn environments_too_bright_for_32_bit_sums_are_refused_as_they_load() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let e = scene(
        d,
        &format!("{SCENE}[[lights]]\ntype = \"sky\"\nscale = 1e38\n"),
    )
    .unwrap_err();
    assert!(
        e.contains("scene.toml:6") && e.contains("`lights[0].scale`") && e.contains("1e20"),
        "{e}"
    );
    let pfm = |header_scale: &str, texel: f32| {
        let mut bytes = format!("Pf\n2 2\n{header_scale}\n").into_bytes();
        for v in [1.0, 2.0, texel, 0.5f32] {
            bytes.extend(v.to_le_bytes());
        }
        bytes
    };
    write(d, "loud.pfm", &pfm("-1e38", 1.0));
    let e = environment(d, "loud.pfm", "").unwrap_err();
    assert!(
        e.contains("loud.pfm")
            && e.contains("header's scale 100000000000000000000000000000000000000")
            && e.contains("1e20"),
        "{e}"
    );
    write(d, "hot.pfm", &pfm("-1", 3e38));
    let e = environment(d, "hot.pfm", "scale = 4\n").unwrap_err();
    assert!(
        e.contains("hot.pfm")
            && e.contains("(column 0, row 0) = (300000000000000000000000000000000000000")
            && e.contains("1e20"),
        "{e}"
    );
    // Within the bound each texel is, the scale still may not carry it past it.
    write(d, "warm.pfm", &pfm("-1", 1e19));
    let e = environment(d, "warm.pfm", "scale = 100\n").unwrap_err();
    assert!(
        e.contains("`lights[0].scale`") && e.contains("brightest texel"),
        "{e}"
    );
    environment(d, "warm.pfm", "scale = 10\n").unwrap();
}

/// Every file a scene names — environment map, volume, PGM and colour transfer
/// functions, a DICOM folder, a NRRD's detached data — is read only if no symbolic link
/// leads it out of the folder its name places it in. A path written out (`../x`, an
/// absolute path) is read where it says; a link that stays inside is followed.
#[test]
fn files_a_scene_names_are_confined_to_its_folder() {
    let outside = tempfile::tempdir().unwrap();
    let o = outside.path();
    let map = |name: &str| {
        let mut bytes = b"Pf\n2 1\n-1\n".to_vec();
        bytes.extend([1.0f32, 2.0].iter().flat_map(|v| v.to_le_bytes()));
        write(o, name, &bytes)
    };
    map("sky.pfm");
    write(o, "v.raw", &[7u8; 8]);
    write(o, "tf.pgm", b"P2\n2 2\n255\n0 255\n0 255\n");
    write(o, "v.nrrd.raw", &[7u8; 8]);
    std::fs::create_dir(o.join("ct")).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let link =
        |target: &Path, name: &str| std::os::unix::fs::symlink(target, d.join(name)).unwrap();
    link(&o.join("sky.pfm"), "sky.pfm");
    link(&o.join("v.raw"), "v.raw");
    link(&o.join("tf.pgm"), "tf.pgm");
    link(&o.join("ct"), "ct");
    link(o, "elsewhere");
    link(&o.join("v.nrrd.raw"), "v.nrrd.raw");
    write(
        d,
        "v.nrrd",
        b"NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 2 2\nencoding: raw\ndata file: v.nrrd.raw\n\n",
    );
    let volume = "[volume]\nfile = \"v.raw\"\ndims = [2, 2, 2]\nvoxel = \"u8\"\n[three_point]\n";
    let cases = [
        (
            "sky.pfm",
            scene(
                d,
                &format!("{SCENE}[[lights]]\ntype = \"environment\"\nfile = \"sky.pfm\"\n"),
            ),
        ),
        ("elsewhere/sky.pfm", environment(d, "elsewhere/sky.pfm", "")),
        ("v.raw", scene(d, volume)),
        (
            "tf.pgm",
            scene(
                d,
                &format!("{SCENE}[transfer]\nkind = \"pgm\"\nfile = \"tf.pgm\"\n"),
            ),
        ),
        ("ct", scene(d, "[volume]\ndicom = \"ct\"\n[three_point]\n")),
        (
            "v.nrrd.raw",
            scene(d, "[volume]\nfile = \"v.nrrd\"\n[three_point]\n"),
        ),
    ];
    for (name, result) in cases {
        let e = result.expect_err(name);
        assert!(
            e.contains(name) && e.contains("leads out of") && e.contains("symbolic link"),
            "{name}: {e}"
        );
    }
    // Written out, the same files are read; a link inside the folder is followed.
    let outside_map = o.join("sky.pfm").display().to_string();
    environment(d, &outside_map, "").unwrap();
    let sub = d.join("maps");
    std::fs::create_dir(&sub).unwrap();
    std::fs::copy(o.join("sky.pfm"), sub.join("real.pfm")).unwrap();
    std::os::unix::fs::symlink("maps/real.pfm", d.join("inside.pfm")).unwrap();
    environment(d, "inside.pfm", "").unwrap();
    environment(&sub, "../inside.pfm", "").unwrap();
}
