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
