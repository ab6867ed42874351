//! Loaders on the real CT/MRI files of `../shared/data` (or `$VOLPHOT_DATA`): checksums,
//! value statistics from the data README, the x-fastest layout, and orientation.
//! Under `CI=true` a missing dataset is a failure, not a skip.

use volphot::test_util as common;

use volphot::{DATASETS, DatasetOverrides, load_dataset};

/// (name, min, max, mean) of the raw values as documented in `../shared/data/README.md`.
const STATS: &[(&str, f64, f64, f64, f64)] = &[
    ("engine", 0.0, 255.0, 22.35, 0.006),
    ("bonsai", 0.0, 255.0, 13.71, 0.006),
    ("foot", 0.0, 255.0, 13.94, 0.006),
    ("head", 0.0, 255.0, 40.65, 0.006),
    ("head16", 0.0, 4328.0, 275.8, 0.06),
    ("cthead", 0.0, 3272.0, 379.5, 0.06),
    ("skeleton", -1024.0, 2986.0, -586.0, 0.6),
    ("colin27", 0.0, 254.0, 44.6, 0.06),
];

fn data_available() -> bool {
    let search = common::search_path();
    let all = DATASETS.iter().all(|d| search.locate(d.file).is_some());
    if !all {
        common::skip(
            "real-data tests",
            &format!(
                "real datasets not found on {:?} (set VOLPHOT_DATA)",
                search.folders()
            ),
        );
    }
    all
}

#[test]
fn every_dataset_loads_with_its_checksum_and_documented_statistics() {
    if !data_available() {
        return;
    }
    let search = common::search_path();
    for &(name, min, max, mean, tol) in STATS {
        // load_dataset verifies the registry's sha256 before returning.
        let v = load_dataset(name, &search, &DatasetOverrides::default()).unwrap();
        let n = v.normalization();
        assert_eq!((n.data_min, n.data_max), (min, max), "{name}");
        // Every window contains the data, so the mean maps back exactly.
        let raw_mean = v.grid().mean() * (n.raw_hi - n.raw_lo) + n.raw_lo;
        assert!(
            (raw_mean - mean).abs() <= tol,
            "{name}: mean {raw_mean} vs {mean}"
        );
        let info = volphot::find_dataset(name).unwrap();
        assert_eq!(v.grid().dims(), info.dims);
        match v.source() {
            volphot::VolumeSource::File {
                sha256, dataset, ..
            } => {
                assert_eq!(sha256, info.sha256);
                assert_eq!(dataset.as_deref(), Some(name));
            }
            other => panic!("{other:?}"),
        }
    }
}

#[test]
fn voxels_are_x_fastest_and_values_exact() {
    if !data_available() {
        return;
    }
    let search = common::search_path();
    let v = load_dataset("engine", &search, &DatasetOverrides::default()).unwrap();
    let bytes = std::fs::read(search.locate("engine_256x256x128_uint8.raw").unwrap()).unwrap();
    let [nx, ny, _] = v.grid().dims();
    for (x, y, z) in [(0, 0, 0), (137, 91, 64), (255, 3, 127), (10, 250, 5)] {
        let raw = bytes[x + nx * (y + ny * z)] as f32;
        assert_eq!(
            v.grid().voxel(x, y, z) * 255.0,
            raw,
            "voxel ({x}, {y}, {z})"
        );
    }
    // Signed CT: the air peak at −1024 HU maps to 0 in the [-1024, 3071] window.
    let ct = load_dataset("skeleton", &search, &DatasetOverrides::default()).unwrap();
    assert_eq!(ct.grid().min_max().0, 0.0);
    let bone = ct.normalization().normalize(1000.0);
    assert!((bone - 2024.0 / 4095.0).abs() < 1e-9, "1000 HU → {bone}");
}

#[test]
fn eight_and_sixteen_bit_heads_are_spatially_aligned() {
    // The 8-bit copy was made from PNG slices with flipped rows to match the 16-bit raw
    // orientation (data README: correlation 0.987 with the flip, 0.62 without).
    if !data_available() {
        return;
    }
    let search = common::search_path();
    let a = load_dataset("head", &search, &DatasetOverrides::default()).unwrap();
    let b = load_dataset("head16", &search, &DatasetOverrides::default()).unwrap();
    let (x, y) = (a.grid().values(), b.grid().values());
    let n = x.len() as f64;
    let (mx, my) = (
        x.iter().map(|&v| v as f64).sum::<f64>() / n,
        y.iter().map(|&v| v as f64).sum::<f64>() / n,
    );
    let (mut sxy, mut sxx, mut syy) = (0.0, 0.0, 0.0);
    for (&p, &q) in x.iter().zip(y) {
        let (dp, dq) = (p as f64 - mx, q as f64 - my);
        sxy += dp * dq;
        sxx += dp * dp;
        syy += dq * dq;
    }
    let r = sxy / (sxx * syy).sqrt();
    assert!(r > 0.95, "correlation {r}");
    assert_eq!(
        a.grid().bounds(),
        b.grid().bounds(),
        "same placement (spacing 1, 1, 1.5)"
    );
}

#[test]
fn header_formats_read_the_real_files_voxel_for_voxel() {
    // Users hold the same data behind NRRD and MetaImage headers: detached headers that
    // point at the real RAW files, and attached / compressed copies written from them.
    if !data_available() {
        return;
    }
    use volphot::{find_dataset as find, read_metaimage, read_nrrd, write_metaimage, write_nrrd};
    let search = common::search_path();
    let tmp = tempfile::tempdir().unwrap();
    for (name, nrrd_type, met_type) in [
        ("engine", "uint8", "MET_UCHAR"),
        ("skeleton", "int16", "MET_SHORT"),
    ] {
        let info = find(name).unwrap();
        let raw_path = search.locate(info.file).unwrap();
        let bytes = std::fs::read(&raw_path).unwrap();
        let [nx, ny, nz] = info.dims;
        let expected: Vec<f32> = match info.voxel {
            volphot::VoxelType::U8 => bytes.iter().map(|&b| b as f32).collect(),
            _ => bytes
                .chunks_exact(2)
                .map(|c| i16::from_le_bytes([c[0], c[1]]) as f32)
                .collect(),
        };
        let [sx, sy, sz] = info.spacing;

        let nhdr = tmp.path().join(format!("{name}.nhdr"));
        std::fs::write(
            &nhdr,
            format!(
                "NRRD0004\ntype: {nrrd_type}\ndimension: 3\nsizes: {nx} {ny} {nz}\n\
                 spacings: {sx} {sy} {sz}\nendian: little\nencoding: raw\n\
                 data file: {}\n",
                raw_path.display()
            ),
        )
        .unwrap();
        let mhd = tmp.path().join(format!("{name}.mhd"));
        std::fs::write(
            &mhd,
            format!(
                "ObjectType = Image\nNDims = 3\nDimSize = {nx} {ny} {nz}\n\
                 ElementSpacing = {sx} {sy} {sz}\nElementByteOrderMSB = False\n\
                 ElementType = {met_type}\nElementDataFile = {}\n",
                raw_path.display()
            ),
        )
        .unwrap();
        for loaded in [read_nrrd(&nhdr).unwrap(), read_metaimage(&mhd).unwrap()] {
            assert_eq!(loaded.dims, info.dims, "{name} {}", loaded.format);
            assert_eq!(loaded.spacing, Some(info.spacing), "{name}");
            assert_eq!(loaded.data_path, raw_path, "{name}");
            assert!(loaded.values == expected, "{name} via {}", loaded.format);
        }

        // Attached gzip NRRD and compressed / attached MetaImage copies round-trip exactly.
        let gz = tmp.path().join(format!("{name}.nrrd"));
        write_nrrd(
            &gz,
            info.dims,
            &expected,
            info.voxel,
            info.spacing,
            true,
            false,
        )
        .unwrap();
        let mha = tmp.path().join(format!("{name}.mha"));
        write_metaimage(&mha, info.dims, &expected, info.voxel, info.spacing, false).unwrap();
        let zraw = tmp.path().join(format!("{name}-z.mhd"));
        write_metaimage(&zraw, info.dims, &expected, info.voxel, info.spacing, true).unwrap();
        for loaded in [
            read_nrrd(&gz).unwrap(),
            read_metaimage(&mha).unwrap(),
            read_metaimage(&zraw).unwrap(),
        ] {
            assert!(
                loaded.values == expected,
                "{name} copy via {}",
                loaded.format
            );
        }
    }
}

/// The threshold the `head16` registry note advises, as a number (`… use ~N …`).
fn advised_head16_threshold() -> f64 {
    let note = volphot::find_dataset("head16").unwrap().note;
    note.split("use ~")
        .nth(1)
        .and_then(|s| s.split(|c: char| !c.is_ascii_digit()).next())
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("the head16 note advises no `use ~N`: {note}"))
}

/// The `threshold` of the `head16` scene preset.
fn preset_head16_threshold() -> f64 {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../experiments/scenes/head16.toml"
    );
    let text = std::fs::read_to_string(path).unwrap();
    text.lines()
        .find_map(|l| l.trim().strip_prefix("threshold = "))
        .and_then(|v| v.trim().parse().ok())
        .unwrap_or_else(|| panic!("{path} has no `threshold = N` line"))
}

/// The dataset registry's advice for the 16-bit head and its scene preset give one threshold,
/// and on the data it keeps about the share of voxels the 8-bit `head` preset keeps (its
/// transfer function zeroes the MRI background below 0.25 of the 8-bit range).
#[test]
fn head16_threshold_advice_agrees_with_its_preset_and_the_data() {
    let advised = advised_head16_threshold();
    assert_eq!(
        advised,
        preset_head16_threshold(),
        "the registry note and experiments/scenes/head16.toml disagree"
    );
    if !data_available() {
        return;
    }
    let search = common::search_path();
    let share_above = |name: &str, raw_threshold: f64| {
        let v = load_dataset(name, &search, &DatasetOverrides::default()).unwrap();
        let n = v.normalization();
        let values = v.grid().values();
        let above = values
            .iter()
            .filter(|&&d| d as f64 * (n.raw_hi - n.raw_lo) + n.raw_lo > raw_threshold)
            .count();
        above as f64 / values.len() as f64
    };
    let head8 = share_above("head", 0.25 * 255.0);
    let head16 = share_above("head16", advised);
    assert!(
        (head16 - head8).abs() < 0.03,
        "threshold {advised} keeps {:.1} % of head16's voxels, the 8-bit preset {:.1} % of head's",
        100.0 * head16,
        100.0 * head8
    );
}
