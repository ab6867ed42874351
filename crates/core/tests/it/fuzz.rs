//! Property-based tests of every file parser of the core: RAW layouts, NRRD, MetaImage,
//! NIfTI-1 headers, PGM transfer functions, scene TOML, DICOM folders (slices among links,
//! FIFOs, sockets and nested folders), environment maps (PFM, Radiance `.hdr` and OpenEXR
//! headers and data), light tables and clip tables. Generated inputs mix valid and invalid
//! pieces of each format; for every case the parser must return within a time bound, must
//! not panic, must not ask for a gigabyte at once (an allocation probe measures each
//! case's largest request), and a rejection must name its file (and, for scenes, the line
//! and column or the key). Every run must see both accepted and rejected inputs, so a
//! generator cannot drift to one side.
//!
//! CI runs a few thousand cases per parser; the long run (`cargo test --release -p
//! volphot-core --test it fuzz:: -- --ignored`) runs 100 000 each.

use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU32, Ordering};
use std::sync::mpsc;
use std::time::Duration;

use proptest::prelude::*;
use proptest::test_runner::{Config, TestCaseError, TestRunner};
use volphot::test_util::alloc::{largest_allocation, reset_largest};
use volphot::test_util::dicom::{SliceSpec, write_slice};
use volphot::test_util::nifti::Nifti1;
use volphot::{
    ByteOrder, DicomInput, FileRequest, Normalization, RawLayout, Scene, SearchPath,
    TransferFunction, VoxelType, read_dicom_series, read_metaimage, read_nrrd, read_volume,
};

/// Cases per parser in a normal test run, and in the long (`--ignored`) run.
const CI_CASES: u32 = 1500;
const LONG_CASES: u32 = 100_000;

/// The most any one case may take.
const BOUND: Duration = Duration::from_secs(20);

/// The most a case may allocate at once: a gigabyte asked for at once is an input read
/// whole, or sized from a header, that should have been refused first.
const ALLOCATION_LIMIT: usize = 1 << 30;

/// What a parser did with one generated input.
enum Verdict {
    Accepted,
    /// Rejected with an error that names its file (and key or position).
    Rejected,
}

/// How many generated inputs a parser accepted and rejected. A run must see both: a
/// generator that drifted to one side no longer tests the other.
#[derive(Default)]
struct Tally {
    accepted: AtomicU32,
    rejected: AtomicU32,
}

impl Tally {
    fn count(&self, verdict: &Verdict) {
        let counter = match verdict {
            Verdict::Accepted => &self.accepted,
            Verdict::Rejected => &self.rejected,
        };
        counter.fetch_add(1, Ordering::Relaxed);
    }

    /// Prints the counts; fails when either is zero.
    fn check(self, name: &str, cases: u32) {
        let (accepted, rejected) = (self.accepted.into_inner(), self.rejected.into_inner());
        let _ = writeln!(
            std::io::stderr().lock(),
            "fuzz {name}: {cases} cases, {accepted} accepted, {rejected} rejected with a located error, 0 panics, 0 hangs, no allocation of 1 GiB"
        );
        assert!(
            accepted > 0,
            "fuzz {name}: the parser accepted none of {cases} generated inputs; the generator makes no valid file any more"
        );
        assert!(
            rejected > 0,
            "fuzz {name}: the parser rejected none of {cases} generated inputs; the generator makes no invalid file any more"
        );
    }
}

/// Runs `check` on each generated case in a thread of its own, failing a case that
/// panics, hangs past [`BOUND`], allocates [`ALLOCATION_LIMIT`] at once or is rejected
/// with an error that does not say where, and a run whose cases were all accepted or all
/// rejected ([`Tally`]).
fn fuzz<S, F>(name: &str, cases: u32, strategy: S, check: F)
where
    S: Strategy,
    S::Value: Clone + std::fmt::Debug + Send + 'static,
    F: Fn(&Path, S::Value) -> Result<Verdict, String> + Send + Sync + Clone + 'static,
{
    let tally = Tally::default();
    let dir = tempfile::tempdir().unwrap();
    let mut runner = TestRunner::new(Config {
        cases,
        failure_persistence: None,
        ..Config::default()
    });
    let result = runner.run(&strategy, |input| {
        let (tx, rx) = mpsc::channel();
        let check = check.clone();
        let case_dir = dir.path().to_path_buf();
        let shown = format!("{input:?}");
        std::thread::spawn(move || {
            reset_largest();
            let outcome =
                std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| check(&case_dir, input)));
            let _ = tx.send((outcome, largest_allocation()));
        });
        match rx.recv_timeout(BOUND) {
            Err(_) => Err(TestCaseError::fail(format!(
                "no answer within {BOUND:?} (a hang) for {shown}"
            ))),
            Ok((_, largest)) if largest >= ALLOCATION_LIMIT => Err(TestCaseError::fail(format!(
                "{largest} bytes allocated at once for {shown}"
            ))),
            Ok((Err(_), _)) => Err(TestCaseError::fail(format!("panicked on {shown}"))),
            Ok((Ok(Err(message)), _)) => Err(TestCaseError::fail(message)),
            Ok((Ok(Ok(verdict)), _)) => {
                tally.count(&verdict);
                Ok(())
            }
        }
    });
    if let Err(e) = result {
        panic!("{e}");
    }
    tally.check(name, cases);
}

/// The harness itself: a generator that drifted to making only rejected inputs (or only
/// accepted ones) tests one side of its parser, and must fail the test that uses it.
#[test]
#[should_panic(expected = "accepted none")]
fn a_generator_of_only_rejected_inputs_fails_its_test() {
    fuzz("only_rejected", 8, Just(0u8), |_, _| Ok(Verdict::Rejected));
}

#[test]
#[should_panic(expected = "rejected none")]
fn a_generator_of_only_accepted_inputs_fails_its_test() {
    fuzz("only_accepted", 8, Just(0u8), |_, _| Ok(Verdict::Accepted));
}

#[test]
#[should_panic(expected = "allocated at once")]
fn a_case_that_allocates_a_gigabyte_fails_its_test() {
    fuzz("allocates", 1, Just(0u8), |_, _| {
        let v: Vec<u8> = Vec::with_capacity(ALLOCATION_LIMIT);
        Ok(if v.capacity() > 0 {
            Verdict::Accepted
        } else {
            Verdict::Rejected
        })
    });
}

/// A rejection must name the file (or, for a bad parameter of the request, its key).
fn named(result: volphot::Result<()>, file: &Path) -> Result<Verdict, String> {
    match result {
        Ok(()) => Ok(Verdict::Accepted),
        Err(volphot::Error::Parameter { .. }) => Ok(Verdict::Rejected),
        Err(e) => {
            let text = e.to_string();
            let name = file.file_name().unwrap().to_string_lossy();
            if text.contains(name.as_ref()) {
                Ok(Verdict::Rejected)
            } else {
                Err(format!("error does not name {name}: {text}"))
            }
        }
    }
}

fn write(path: &Path, bytes: &[u8]) {
    std::fs::write(path, bytes).unwrap();
}

fn gzip(bytes: &[u8]) -> Vec<u8> {
    let mut e = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
    e.write_all(bytes).unwrap();
    e.finish().unwrap()
}

fn zlib(bytes: &[u8]) -> Vec<u8> {
    let mut e = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::fast());
    e.write_all(bytes).unwrap();
    e.finish().unwrap()
}

// --- RAW --------------------------------------------------------------------------------

fn voxel_type() -> impl Strategy<Value = VoxelType> {
    prop_oneof![
        Just(VoxelType::U8),
        Just(VoxelType::I8),
        Just(VoxelType::U16),
        Just(VoxelType::I16),
        Just(VoxelType::F32)
    ]
}

fn dimension() -> impl Strategy<Value = usize> {
    prop_oneof![
        4 => 0usize..12,
        1 => Just(1usize << 20),
        1 => Just(usize::MAX / 3),
    ]
}

#[derive(Debug, Clone)]
struct RawCase {
    dims: [usize; 3],
    voxel: VoxelType,
    big_endian: bool,
    header_bytes: u64,
    bytes: Vec<u8>,
    normalization: u8,
}

fn raw_case() -> impl Strategy<Value = RawCase> {
    (
        [dimension(), dimension(), dimension()],
        voxel_type(),
        any::<bool>(),
        prop_oneof![3 => 0u64..16, 1 => Just(u64::MAX)],
        prop_oneof![
            Just(Vec::new()),
            prop::collection::vec(any::<u8>(), 0..2000)
        ],
        0u8..4,
    )
        .prop_map(
            |(dims, voxel, big_endian, header_bytes, bytes, normalization)| RawCase {
                dims,
                voxel,
                big_endian,
                header_bytes,
                bytes,
                normalization,
            },
        )
}

fn check_raw(dir: &Path, c: RawCase) -> Result<Verdict, String> {
    let path = dir.join(format!("v{}.raw", std::process::id()));
    // An empty byte list stands for a file of exactly the right size (random otherwise).
    let exact = c
        .dims
        .iter()
        .try_fold(c.voxel.size() as u64, |a, &n| a.checked_mul(n as u64))
        .and_then(|n| n.checked_add(c.header_bytes))
        .filter(|&n| n < 1 << 20);
    match (c.bytes.is_empty(), exact) {
        (true, Some(n)) => write(
            &path,
            &(0..n)
                .map(|i| (i as u8).wrapping_mul(13))
                .collect::<Vec<u8>>(),
        ),
        _ => write(&path, &c.bytes),
    }
    let request = FileRequest {
        path: path.clone(),
        raw_layout: Some(RawLayout {
            dims: c.dims,
            voxel: c.voxel,
            byte_order: if c.big_endian {
                ByteOrder::Big
            } else {
                ByteOrder::Little
            },
            header_bytes: c.header_bytes,
        }),
        placement: None,
        normalization: match c.normalization {
            0 => None,
            1 => Some(Normalization::TypeRange),
            2 => Some(Normalization::MinMax),
            _ => Some(Normalization::Window { lo: 5.0, hi: 1.0 }),
        },
        dataset: None,
        expected_sha256: None,
    };
    match read_volume(&request) {
        Ok(v) => {
            if v.grid()
                .values()
                .iter()
                .all(|d| d.is_finite() && (0.0..=1.0).contains(d))
            {
                Ok(Verdict::Accepted)
            } else {
                Err(format!("densities outside [0, 1] accepted from {c:?}"))
            }
        }
        Err(e) => named(Err(e), &path),
    }
}

#[test]
fn fuzz_raw_layouts() {
    fuzz("raw_layouts", CI_CASES, raw_case(), check_raw);
}

#[test]
#[ignore = "long run: cargo test --release -p volphot-core --test it fuzz:: -- --ignored"]
fn fuzz_raw_layouts_long() {
    fuzz("raw_layouts", LONG_CASES, raw_case(), check_raw);
}

// --- NRRD and MetaImage headers -----------------------------------------------------------

/// A change to a valid header-and-data file.
#[derive(Debug, Clone)]
enum Mutation {
    /// Replace field `i`'s value.
    SetValue(usize, String),
    /// Remove field `i`.
    Drop(usize),
    /// Insert a line before field `i`.
    Insert(usize, String),
    /// Lengthen (> 0) or shorten (< 0) the voxel data.
    DataDelta(i64),
    /// Flip a bit of the header text.
    Flip(usize, u8),
}

fn mutation(values: BoxedStrategy<String>) -> impl Strategy<Value = Mutation> {
    prop_oneof![
        4 => (0usize..8, values.clone()).prop_map(|(i, v)| Mutation::SetValue(i, v)),
        2 => (0usize..8).prop_map(Mutation::Drop),
        1 => (0usize..8, "[ -~]{0,16}").prop_map(|(i, l)| Mutation::Insert(i, l)),
        2 => (-40i64..40).prop_map(Mutation::DataDelta),
        1 => (0usize..400, 0u8..8).prop_map(|(i, b)| Mutation::Flip(i, b)),
    ]
}

/// A valid file of a header format, before mutations.
#[derive(Debug, Clone)]
struct HeaderCase {
    dims: [usize; 3],
    /// (type name in the header, bytes per voxel).
    voxel: (&'static str, usize),
    compressed: bool,
    big_endian: bool,
    seed: u8,
    mutations: Vec<Mutation>,
}

fn header_case(
    types: &'static [(&'static str, usize)],
    values: BoxedStrategy<String>,
) -> impl Strategy<Value = HeaderCase> {
    (
        [1usize..6, 1usize..6, 1usize..6],
        prop::sample::select(types),
        any::<bool>(),
        any::<bool>(),
        any::<u8>(),
        prop::collection::vec(mutation(values), 0..4),
    )
        .prop_map(
            |(dims, voxel, compressed, big_endian, seed, mutations)| HeaderCase {
                dims,
                voxel,
                compressed,
                big_endian,
                seed,
                mutations,
            },
        )
}

/// Applies the mutations to `(key, value)` fields and the data; returns the header lines
/// (`key{sep}value`) and the voxel bytes.
fn mutate(c: &HeaderCase, mut fields: Vec<(String, String)>, sep: &str) -> (Vec<String>, Vec<u8>) {
    let count = c.dims.iter().product::<usize>() * c.voxel.1;
    let mut data: Vec<u8> = (0..count)
        .map(|i| (i as u8).wrapping_mul(31) ^ c.seed)
        .collect();
    let mut extra: Vec<(usize, String)> = Vec::new();
    for m in &c.mutations {
        match m {
            Mutation::SetValue(i, v) if *i < fields.len() => fields[*i].1 = v.clone(),
            Mutation::Drop(i) if *i < fields.len() => {
                fields.remove(*i);
            }
            Mutation::Insert(i, l) => extra.push((*i, l.clone())),
            Mutation::DataDelta(d) if *d < 0 => {
                data.truncate(data.len().saturating_sub((-d) as usize))
            }
            Mutation::DataDelta(d) => data.extend(std::iter::repeat_n(7u8, *d as usize)),
            _ => {}
        }
    }
    let mut lines: Vec<String> = fields.iter().map(|(k, v)| format!("{k}{sep}{v}")).collect();
    for (i, l) in extra {
        lines.insert(i.min(lines.len()), l);
    }
    (lines, data)
}

/// Flips header bits as the mutations ask (the data are mutated by [`mutate`]).
fn flip(c: &HeaderCase, header: &mut [u8]) {
    for m in &c.mutations {
        if let Mutation::Flip(i, bit) = m
            && !header.is_empty()
        {
            let n = header.len();
            header[i % n] ^= 1 << bit;
        }
    }
}

fn header_value() -> impl Strategy<Value = String> {
    prop_oneof![
        Just("3".to_string()),
        Just("4".to_string()),
        Just("-1".to_string()),
        Just("0".to_string()),
        Just("4 4 4".to_string()),
        Just("1 4 4 4".to_string()),
        Just("0 4 4".to_string()),
        Just("99999999 99999999 99999999".to_string()),
        Just("uchar".to_string()),
        Just("double".to_string()),
        Just("MET_DOUBLE".to_string()),
        Just("ascii".to_string()),
        Just("bzip2".to_string()),
        Just("middle".to_string()),
        Just("nan 1 inf".to_string()),
        Just("LIST".to_string()),
        Just("missing.raw".to_string()),
        Just("%d".to_string()),
        Just("True".to_string()),
        Just("False".to_string()),
        "[ -~]{0,12}",
    ]
}

const NRRD_TYPES: &[(&str, usize)] = &[
    ("uchar", 1),
    ("signed char", 1),
    ("ushort", 2),
    ("short", 2),
    ("float", 4),
];

fn check_nrrd(dir: &Path, c: HeaderCase) -> Result<Verdict, String> {
    let path = dir.join("v.nrrd");
    let [x, y, z] = c.dims;
    let fields = vec![
        ("type".to_string(), c.voxel.0.to_string()),
        ("dimension".into(), "3".into()),
        ("sizes".into(), format!("{x} {y} {z}")),
        (
            "encoding".into(),
            if c.compressed { "gzip" } else { "raw" }.into(),
        ),
        (
            "endian".into(),
            if c.big_endian { "big" } else { "little" }.into(),
        ),
        ("spacings".into(), "1 1 1.5".into()),
    ];
    let (lines, data) = mutate(&c, fields, ": ");
    let mut header = format!("NRRD0004\n{}\n\n", lines.join("\n")).into_bytes();
    flip(&c, &mut header);
    header.extend(if c.compressed { gzip(&data) } else { data });
    write(&path, &header);
    named(read_nrrd(&path).map(|_| ()), &path)
}

#[test]
fn fuzz_nrrd_headers() {
    fuzz(
        "nrrd_headers",
        CI_CASES,
        header_case(NRRD_TYPES, header_value().boxed()),
        check_nrrd,
    );
}

#[test]
#[ignore = "long run: cargo test --release -p volphot-core --test it fuzz:: -- --ignored"]
fn fuzz_nrrd_headers_long() {
    fuzz(
        "nrrd_headers",
        LONG_CASES,
        header_case(NRRD_TYPES, header_value().boxed()),
        check_nrrd,
    );
}

const MHD_TYPES: &[(&str, usize)] = &[
    ("MET_UCHAR", 1),
    ("MET_CHAR", 1),
    ("MET_USHORT", 2),
    ("MET_SHORT", 2),
    ("MET_FLOAT", 4),
];

fn check_mha(dir: &Path, c: HeaderCase) -> Result<Verdict, String> {
    let path = dir.join("v.mha");
    let [x, y, z] = c.dims;
    let fields = vec![
        ("ObjectType".to_string(), "Image".to_string()),
        ("NDims".into(), "3".into()),
        ("DimSize".into(), format!("{x} {y} {z}")),
        ("ElementType".into(), c.voxel.0.into()),
        (
            "BinaryDataByteOrderMSB".into(),
            if c.big_endian { "True" } else { "False" }.into(),
        ),
        (
            "CompressedData".into(),
            if c.compressed { "True" } else { "False" }.into(),
        ),
        ("ElementSpacing".into(), "1 1 1.5".into()),
        ("ElementDataFile".into(), "LOCAL".into()),
    ];
    let (lines, data) = mutate(&c, fields, " = ");
    let mut header = format!("{}\n", lines.join("\n")).into_bytes();
    flip(&c, &mut header);
    header.extend(if c.compressed { zlib(&data) } else { data });
    write(&path, &header);
    named(read_metaimage(&path).map(|_| ()), &path)
}

#[test]
fn fuzz_metaimage_headers() {
    fuzz(
        "metaimage_headers",
        CI_CASES,
        header_case(MHD_TYPES, header_value().boxed()),
        check_mha,
    );
}

#[test]
#[ignore = "long run: cargo test --release -p volphot-core --test it fuzz:: -- --ignored"]
fn fuzz_metaimage_headers_long() {
    fuzz(
        "metaimage_headers",
        LONG_CASES,
        header_case(MHD_TYPES, header_value().boxed()),
        check_mha,
    );
}

// --- PGM transfer functions -----------------------------------------------------------------

#[derive(Debug, Clone)]
struct PgmCase {
    binary: bool,
    width: usize,
    height: usize,
    maxval: u32,
    header_tokens: Vec<(usize, String)>,
    data_delta: i64,
    seed: u8,
}

fn pgm_case() -> impl Strategy<Value = PgmCase> {
    (
        any::<bool>(),
        prop_oneof![Just(256usize), 1usize..300],
        prop_oneof![Just(256usize), 1usize..300],
        prop_oneof![Just(255u32), Just(65535u32), 0u32..70000],
        prop::collection::vec(
            (
                0usize..5,
                prop_oneof![
                    Just("P6".to_string()),
                    Just("-1".to_string()),
                    Just("# c\n".to_string()),
                    "[ -~]{0,5}"
                ],
            ),
            0..2,
        ),
        prop_oneof![3 => Just(0i64), 1 => -300i64..300],
        any::<u8>(),
    )
        .prop_map(
            |(binary, width, height, maxval, header_tokens, data_delta, seed)| PgmCase {
                binary,
                width,
                height,
                maxval,
                header_tokens,
                data_delta,
                seed,
            },
        )
}

fn pgm_bytes(c: &PgmCase) -> Vec<u8> {
    let mut tokens = vec![
        if c.binary { "P5" } else { "P2" }.to_string(),
        c.width.to_string(),
        c.height.to_string(),
        c.maxval.to_string(),
    ];
    for (i, t) in &c.header_tokens {
        if *i < tokens.len() {
            tokens[*i] = t.clone();
        } else {
            tokens.push(t.clone());
        }
    }
    let mut bytes = format!("{}\n", tokens.join(" ")).into_bytes();
    let wide = c.maxval > 255;
    let n = (c.width * c.height) as i64 * if c.binary && wide { 2 } else { 1 };
    let n = (n + c.data_delta).max(0) as usize;
    if c.binary {
        bytes.extend((0..n).map(|i| (i as u8) ^ c.seed));
    } else {
        let values: Vec<String> = (0..n)
            .map(|i| ((i as u32 * 7 + c.seed as u32) % (c.maxval.max(1) + 1)).to_string())
            .collect();
        bytes.extend(values.join(" ").into_bytes());
    }
    bytes
}

fn check_pgm(dir: &Path, c: PgmCase) -> Result<Verdict, String> {
    let path = dir.join("tf.pgm");
    write(&path, &pgm_bytes(&c));
    named(TransferFunction::from_pgm(&path).map(|_| ()), &path)
}

#[test]
fn fuzz_pgm_transfer_functions() {
    fuzz("pgm_transfer_functions", CI_CASES, pgm_case(), check_pgm);
}

#[test]
#[ignore = "long run: cargo test --release -p volphot-core --test it fuzz:: -- --ignored"]
fn fuzz_pgm_transfer_functions_long() {
    fuzz("pgm_transfer_functions", LONG_CASES, pgm_case(), check_pgm);
}

// --- scene TOML -----------------------------------------------------------------------------

/// A TOML value of many kinds, mostly plausible for some key and often not for this one.
fn toml_value() -> impl Strategy<Value = String> {
    prop_oneof![
        Just("0".to_string()),
        Just("1".to_string()),
        Just("-3".to_string()),
        Just("80".to_string()),
        Just("1e30".to_string()),
        Just("1e-30".to_string()),
        Just("nan".to_string()),
        Just("inf".to_string()),
        Just("0.5".to_string()),
        Just("true".to_string()),
        Just("\"thesis\"".to_string()),
        Just("\"explicit\"".to_string()),
        Just("\"mean-free-path\"".to_string()),
        Just("\"points\"".to_string()),
        Just("\"spot\"".to_string()),
        Just("\"point\"".to_string()),
        Just("\"sphere\"".to_string()),
        Just("\"reference\"".to_string()),
        Just("\"min-max\"".to_string()),
        Just("[16, 16]".to_string()),
        Just("[16, 16, 16]".to_string()),
        Just("[0.5, 0.5, 0.5]".to_string()),
        Just("[[0.0, 0.0], [0.5, 1.0]]".to_string()),
        Just("[1, 4]".to_string()),
        Just("{ name = \"sphere\", resolution = [8, 8, 8] }".to_string()),
        Just("{ name = \"slab\", resolution = [2, 2, 2], range = [0.9, 0.1] }".to_string()),
        "\"[ -~&&[^\"\\\\]]{0,8}\"",
    ]
}

const SCENE_KEYS: &[(&str, &[&str])] = &[
    (
        "volume",
        &[
            "phantom",
            "dataset",
            "file",
            "dims",
            "voxel",
            "normalize",
            "window",
            "box",
            "spacing",
            "reconstruction",
            "brick_size",
        ],
    ),
    ("transfer", &["kind", "points", "file", "threshold"]),
    (
        "sigma",
        &[
            "mapping", "t", "albedo", "ratio", "percent", "sigma_a", "sigma_s", "emission",
        ],
    ),
    ("camera", &["eye", "look_at", "up", "fov", "resolution"]),
    ("three_point", &["key_intensity", "fill_ratio", "rim_ratio"]),
    (
        "integrator",
        &[
            "method",
            "volume_photons",
            "nused",
            "maxdist",
            "stepsize",
            "free_path",
            "estimate",
            "spp",
            "termination",
            "shadow_cache",
            "ms_cache",
            "seed",
        ],
    ),
    ("phase", &["g"]),
    ("film", &["exposure"]),
    ("nonsense", &["x"]),
];

fn scene_case() -> impl Strategy<Value = Vec<(usize, usize, String)>> {
    prop::collection::vec((0..SCENE_KEYS.len(), 0usize..16, toml_value()), 0..14)
}

/// The scene text: a valid small scene, then random keys appended to its tables (a key
/// given twice is itself a case).
fn scene_text(entries: &[(usize, usize, String)]) -> String {
    let mut tables: Vec<(String, Vec<String>)> = vec![
        (
            "volume".into(),
            vec!["phantom = { name = \"sphere\", resolution = [8, 8, 8] }".into()],
        ),
        ("camera".into(), vec!["resolution = [8, 8]".into()]),
        ("three_point".into(), vec![]),
        ("integrator".into(), vec!["volume_photons = 100".into()]),
    ];
    for (t, k, v) in entries {
        let (table, keys) = SCENE_KEYS[*t];
        let key = keys[k % keys.len()];
        let line = format!("{key} = {v}");
        match tables.iter_mut().find(|(n, _)| n == table) {
            Some((_, lines)) => lines.push(line),
            None => tables.push((table.to_string(), vec![line])),
        }
    }
    tables
        .iter()
        .map(|(t, lines)| format!("[{t}]\n{}\n", lines.join("\n")))
        .collect()
}

fn check_scene(dir: &Path, entries: Vec<(usize, usize, String)>) -> Result<Verdict, String> {
    let path: PathBuf = dir.join("scene.toml");
    let text = scene_text(&entries);
    write(&path, text.as_bytes());
    match Scene::load(&path, &SearchPath::new(vec![dir.to_path_buf()])) {
        Ok(_) => Ok(Verdict::Accepted),
        Err(e) => {
            let message = e.to_string();
            // Located: `scene.toml:line:col: …`, or an error that names its key or file.
            let located = message.starts_with(&format!("{}:", path.display()));
            if located {
                Ok(Verdict::Rejected)
            } else {
                Err(format!("unlocated error `{message}` for\n{text}"))
            }
        }
    }
}

#[test]
fn fuzz_scene_files() {
    fuzz("scene_files", CI_CASES, scene_case(), check_scene);
}

#[test]
#[ignore = "long run: cargo test --release -p volphot-core --test it fuzz:: -- --ignored"]
fn fuzz_scene_files_long() {
    fuzz("scene_files", LONG_CASES, scene_case(), check_scene);
}

// --- NIfTI-1 headers -----------------------------------------------------------------------

/// NIfTI-1 datatype codes with their bits per voxel: the ten read, then the ones refused.
const NIFTI_TYPES: [(i16, i16); 17] = [
    (2, 8),
    (256, 8),
    (512, 16),
    (4, 16),
    (768, 32),
    (8, 32),
    (1280, 64),
    (1024, 64),
    (16, 32),
    (64, 64),
    (0, 0),
    (1, 1),
    (32, 64),
    (128, 24),
    (1536, 128),
    (1792, 128),
    (2304, 32),
];

#[derive(Debug, Clone)]
struct NiftiCase {
    header: Nifti1,
    /// Bytes added (> 0) or removed (< 0) after the voxels the header claims.
    data_delta: i64,
    gzip: bool,
    /// Cut the written file to this many 256ths of its length.
    cut: Option<u8>,
}

fn nifti_float(usual: BoxedStrategy<f32>) -> BoxedStrategy<f32> {
    prop_oneof![
        8 => usual,
        1 => prop::sample::select(vec![0.0, -1.0, f32::NAN, f32::INFINITY, f32::NEG_INFINITY, 1e30, 1e-30]),
        1 => any::<f32>(),
    ]
    .boxed()
}

fn nifti_dim() -> impl Strategy<Value = [i16; 8]> {
    let size = prop_oneof![8 => 1i16..6, 1 => any::<i16>(), 1 => Just(i16::MAX)];
    let rank = prop_oneof![8 => 1i16..=4, 1 => any::<i16>()];
    let extra = prop_oneof![8 => Just(1i16), 1 => -1i16..3];
    (
        rank,
        [size.clone(), size.clone(), size],
        extra.clone(),
        extra,
    )
        .prop_map(|(rank, [x, y, z], t, u)| [rank, x, y, z, t, u, 1, 1])
}

fn nifti_type() -> impl Strategy<Value = (i16, i16)> {
    prop_oneof![
        12 => prop::sample::select(NIFTI_TYPES[..10].to_vec()),
        2 => prop::sample::select(NIFTI_TYPES[10..].to_vec()),
        1 => (any::<i16>(), any::<i16>()),
        1 => (prop::sample::select(NIFTI_TYPES.to_vec()), prop::sample::select(vec![0i16, 8, 16, 24, 32, 64, -8])).prop_map(|((code, _), bits)| (code, bits)),
    ]
}

fn nifti_offset() -> BoxedStrategy<f32> {
    nifti_float(prop_oneof![6 => Just(352.0f32), 2 => (22u32..200).prop_map(|n| (16 * n) as f32), 1 => Just(348.0), 1 => Just(352.5)].boxed())
}

fn nifti_header() -> impl Strategy<Value = Nifti1> {
    let spacing = nifti_float((1u8..40).prop_map(|n| f32::from(n) / 10.0).boxed());
    let magic = prop_oneof![12 => Just(*b"n+1\0"), 1 => Just(*b"ni1\0"), 1 => any::<[u8; 4]>()];
    let sizeof_hdr = prop_oneof![12 => Just(348), 1 => Just(540), 1 => any::<i32>()];
    let codes = prop_oneof![4 => Just([0i16, 0]), 2 => Just([1, 0]), 2 => Just([0, 1]), 1 => any::<[i16; 2]>()];
    let unit = nifti_float(Just(0.0f32).boxed());
    let scl = (
        nifti_float(prop_oneof![Just(1.0f32), Just(0.0), Just(0.5)].boxed()),
        nifti_float(Just(0.0f32).boxed()),
    );
    (
        (
            sizeof_hdr,
            nifti_dim(),
            nifti_type(),
            [spacing.clone(), spacing.clone(), spacing.clone(), spacing],
        ),
        (
            nifti_offset(),
            scl,
            codes,
            [unit.clone(), unit.clone(), unit],
        ),
        (magic, any::<bool>()),
    )
        .prop_map(
            |(
                (sizeof_hdr, dim, (datatype, bitpix), [qfac, dx, dy, dz]),
                (vox_offset, (slope, inter), codes, quatern),
                (magic, big_endian),
            )| {
                let srow = [
                    [dx, 0.0, 0.0, 0.0],
                    [0.0, dy, 0.0, 0.0],
                    [0.0, 0.0, dz, 0.0],
                ];
                Nifti1 {
                    sizeof_hdr,
                    dim,
                    datatype,
                    bitpix,
                    pixdim: [qfac.signum(), dx, dy, dz, 0.0, 0.0, 0.0, 0.0],
                    vox_offset,
                    scl: [slope, inter],
                    codes,
                    quatern,
                    srow,
                    magic,
                    big_endian,
                }
            },
        )
}

fn nifti_case() -> impl Strategy<Value = NiftiCase> {
    (
        nifti_header(),
        prop_oneof![8 => Just(0i64), 1 => -60i64..60],
        any::<bool>(),
        prop_oneof![8 => Just(None), 1 => any::<u8>().prop_map(Some)],
    )
        .prop_map(|(header, data_delta, gzip, cut)| NiftiCase {
            header,
            data_delta,
            gzip,
            cut,
        })
}

/// Voxels the header claims, if its dims are sane enough to say.
fn claimed_voxels(h: &Nifti1) -> Option<u64> {
    let rank = usize::try_from(h.dim[0])
        .ok()
        .filter(|r| (1..=7).contains(r))?;
    h.dim[1..=rank]
        .iter()
        .try_fold(1u64, |n, &d| n.checked_mul(u64::try_from(d).ok()?))
}

/// The bytes of a case: its header, the voxels it claims (when that is under 1 MiB, a
/// few bytes otherwise) give or take `data_delta`, gzipped or not, maybe cut.
fn nifti_bytes(c: &NiftiCase) -> Vec<u8> {
    let claimed = claimed_voxels(&c.header)
        .and_then(|n| n.checked_mul(u64::try_from(c.header.bitpix).ok()? / 8))
        .filter(|&n| n < 1 << 20)
        .unwrap_or(64);
    let length = (claimed as i64 + c.data_delta).max(0) as usize;
    let data: Vec<u8> = (0..length)
        .map(|i| (i as u8).wrapping_mul(31).wrapping_add(7))
        .collect();
    let mut bytes = c.header.file(&data);
    if c.gzip {
        bytes = gzip(&bytes);
    }
    if let Some(cut) = c.cut {
        bytes.truncate(bytes.len() * usize::from(cut) / 256);
    }
    bytes
}

fn check_nifti(dir: &Path, c: NiftiCase) -> Result<Verdict, String> {
    let name = if c.gzip { "v.nii.gz" } else { "v.nii" };
    let path = dir.join(format!("{}-{name}", std::process::id()));
    write(&path, &nifti_bytes(&c));
    let request = FileRequest {
        path: path.clone(),
        raw_layout: None,
        placement: None,
        normalization: None,
        dataset: None,
        expected_sha256: None,
    };
    // The harness checks the case's largest allocation (a header that claims gigabytes
    // must be refused before they are asked for).
    match read_volume(&request) {
        Ok(v) => {
            let b = v.grid().bounds();
            let densities_ok = v
                .grid()
                .values()
                .iter()
                .all(|d| d.is_finite() && (0.0..=1.0).contains(d));
            if densities_ok && b.min.is_finite() && b.max.is_finite() && b.max.cmpgt(b.min).all() {
                Ok(Verdict::Accepted)
            } else {
                Err(format!(
                    "densities outside [0, 1] or a degenerate box {b:?} accepted from {c:?}"
                ))
            }
        }
        Err(e) => {
            let text = e.to_string();
            if over_budget(&c) && !text.contains("refusing") {
                return Err(format!(
                    "a claim over the memory budget refused otherwise: {text}"
                ));
            }
            named(Err(e), &path)
        }
    }
}

/// Whether an intact, otherwise readable header claims more working memory than the
/// budget (12 bytes a voxel), so the memory check must be what refuses it.
fn over_budget(c: &NiftiCase) -> bool {
    let h = &c.header;
    let intact = c.cut.is_none() && h.sizeof_hdr == 348 && h.magic == *b"n+1\0";
    let rank_ok = (1..=7).contains(&h.dim[0]);
    let sizes_ok = rank_ok && h.dim[1..=h.dim[0] as usize].iter().all(|&d| d >= 1);
    let one_volume = rank_ok && h.dim[4..=h.dim[0].max(3) as usize].iter().all(|&d| d <= 1);
    intact
        && sizes_ok
        && one_volume
        && claimed_voxels(h).is_some_and(|n| n.saturating_mul(12) > volphot::memory_budget_bytes())
}

fn fuzz_nifti(cases: u32) {
    fuzz("nifti_headers", cases, nifti_case(), check_nifti);
}

#[test]
fn fuzz_nifti_headers() {
    fuzz_nifti(CI_CASES);
}

#[test]
#[ignore = "long run: cargo test --release -p volphot-core --test it fuzz:: -- --ignored"]
fn fuzz_nifti_headers_long() {
    fuzz_nifti(LONG_CASES);
}

// --- DICOM folders ------------------------------------------------------------------------

/// What a symbolic link in a generated DICOM folder points at.
#[derive(Debug, Clone, Copy)]
enum LinkTarget {
    /// `/`: the whole file system.
    Root,
    /// `.`: the folder holding the link.
    Itself,
    /// `..`: its parent (outside the series folder when the link is at the top).
    Parent,
    /// The series folder, by absolute path.
    SeriesFolder,
    /// A name that does not exist.
    Missing,
    /// Another link that points back at this one.
    Loop,
    /// The first slice written, by absolute path (else nothing).
    FirstSlice,
    /// `/dev/zero`.
    DevZero,
}

/// One entry of a generated DICOM folder.
#[derive(Debug, Clone)]
enum FolderEntry {
    /// The next slice of the series (slices are 1 mm apart in the order written).
    Slice,
    Link(LinkTarget),
    /// A hard link to the first slice written (else nothing).
    HardLink,
    Fifo,
    Socket,
    /// A subfolder with its own entries.
    Folder(Vec<FolderEntry>),
}

fn folder_entry() -> impl Strategy<Value = FolderEntry> {
    let target = prop_oneof![
        Just(LinkTarget::Root),
        Just(LinkTarget::Itself),
        Just(LinkTarget::Parent),
        Just(LinkTarget::SeriesFolder),
        Just(LinkTarget::Missing),
        Just(LinkTarget::Loop),
        Just(LinkTarget::FirstSlice),
        Just(LinkTarget::DevZero),
    ];
    let leaf = prop_oneof![
        4 => Just(FolderEntry::Slice),
        4 => target.prop_map(FolderEntry::Link),
        1 => Just(FolderEntry::HardLink),
        1 => Just(FolderEntry::Fifo),
        1 => Just(FolderEntry::Socket),
    ];
    leaf.prop_recursive(3, 24, 6, |inner| {
        prop::collection::vec(inner, 0..6).prop_map(FolderEntry::Folder)
    })
}

/// Writes a generated folder; counts the slices and remembers the first.
struct FolderWriter {
    series: PathBuf,
    slices: usize,
    first: Option<PathBuf>,
    names: usize,
}

impl FolderWriter {
    fn name(&mut self) -> String {
        self.names += 1;
        format!("e{}", self.names)
    }

    fn write(&mut self, at: &Path, entries: &[FolderEntry]) {
        for entry in entries {
            let path = at.join(self.name());
            match entry {
                FolderEntry::Slice => self.slice(&path),
                FolderEntry::Link(target) => self.link(&path, *target),
                FolderEntry::HardLink => match &self.first {
                    Some(first) => std::fs::hard_link(first, &path).unwrap(),
                    None => self.slice(&path),
                },
                FolderEntry::Fifo => {
                    let ok = std::process::Command::new("mkfifo").arg(&path).status();
                    assert!(ok.unwrap().success());
                }
                FolderEntry::Socket => {
                    drop(std::os::unix::net::UnixListener::bind(&path).unwrap());
                }
                FolderEntry::Folder(inner) => {
                    std::fs::create_dir(&path).unwrap();
                    self.write(&path, inner);
                }
            }
        }
    }

    fn slice(&mut self, path: &Path) {
        let p = self.slices;
        let spec = SliceSpec::ct("2.25.70", &format!("2.25.70.{p}"), p as f64, [2, 3]);
        write_slice(path, &spec, &[p as u16; 6]).unwrap();
        self.slices += 1;
        self.first.get_or_insert_with(|| path.to_path_buf());
    }

    fn link(&mut self, path: &Path, target: LinkTarget) {
        let to: PathBuf = match target {
            LinkTarget::Root => "/".into(),
            LinkTarget::Itself => ".".into(),
            LinkTarget::Parent => "..".into(),
            LinkTarget::SeriesFolder => self.series.clone(),
            LinkTarget::Missing => "missing".into(),
            LinkTarget::Loop => {
                let other = path.with_extension("back");
                std::os::unix::fs::symlink(path, &other).unwrap();
                other
            }
            LinkTarget::FirstSlice => self.first.clone().unwrap_or_else(|| "none".into()),
            LinkTarget::DevZero => "/dev/zero".into(),
        };
        std::os::unix::fs::symlink(to, path).unwrap();
    }
}

/// Every slice written is read exactly once, whatever links and special files surround it;
/// a folder without slices is an error naming it. Never a hang (the folders hold FIFOs and
/// links to `/`), never a panic.
fn check_dicom_folder(dir: &Path, entries: Vec<FolderEntry>) -> Result<Verdict, String> {
    let case = tempfile::tempdir_in(dir).unwrap();
    let series = case.path().join("series");
    std::fs::create_dir(&series).unwrap();
    let mut writer = FolderWriter {
        series: series.clone(),
        slices: 0,
        first: None,
        names: 0,
    };
    writer.write(&series, &entries);
    match read_dicom_series(&DicomInput::Folder(series.clone()), None, false) {
        Ok((v, _)) => {
            let a = v.acquisition.unwrap();
            if (a.slices, a.files) == (writer.slices, writer.slices) {
                Ok(Verdict::Accepted)
            } else {
                Err(format!(
                    "read {} slices from {} files, wrote {}: {}",
                    a.slices, a.files, writer.slices, a.choice
                ))
            }
        }
        Err(e) => {
            let text = e.to_string();
            if writer.slices == 0 && text.starts_with(&series.display().to_string()) {
                Ok(Verdict::Rejected)
            } else {
                Err(format!("{} slices written, yet: {text}", writer.slices))
            }
        }
    }
}

/// Cases in a normal run: each writes a few tiny slices, links and FIFOs.
const DICOM_FOLDER_CASES: u32 = 100;

#[test]
fn fuzz_dicom_folders() {
    fuzz(
        "dicom_folders",
        DICOM_FOLDER_CASES,
        prop::collection::vec(folder_entry(), 0..8),
        check_dicom_folder,
    );
}

#[test]
#[ignore = "long run: cargo test --release -p volphot-core --test it fuzz:: -- --ignored"]
fn fuzz_dicom_folders_long() {
    fuzz(
        "dicom_folders",
        LONG_CASES / 10,
        prop::collection::vec(folder_entry(), 0..8),
        check_dicom_folder,
    );
}

// --- pbrt Include graphs ------------------------------------------------------------------

/// What one `Include` of a generated graph names.
#[derive(Debug, Clone)]
enum IncludeTarget {
    /// Another file of the graph (by index, modulo the graph's size): chains, fan-out and
    /// cycles.
    File(usize),
    Missing,
    Folder,
    DevZero,
    Fifo,
    /// A sparse 1 GiB file.
    Huge,
    /// A file that reads as pbrt tokens but is someone's secret.
    Foreign,
}

/// One file of a graph: whether it holds the whole small scene, and its Includes, each
/// written up to four times.
type GraphFile = (bool, Vec<(IncludeTarget, usize)>);

fn include_graph() -> impl Strategy<Value = Vec<GraphFile>> {
    let target = prop_oneof![
        10 => (0usize..5).prop_map(IncludeTarget::File),
        1 => Just(IncludeTarget::Missing),
        1 => Just(IncludeTarget::Folder),
        1 => Just(IncludeTarget::DevZero),
        1 => Just(IncludeTarget::Fifo),
        1 => Just(IncludeTarget::Huge),
        1 => Just(IncludeTarget::Foreign),
    ];
    let includes = prop::collection::vec((target, 1usize..=4), 0..4);
    prop::collection::vec((any::<bool>(), includes), 1..=5)
}

const PBRT_SCENE: &str = "LookAt 0.5 -2 0.5  0.5 0.5 0.5  0 0 1\nCamera \"perspective\" \"float fov\" [30]\nWorldBegin\nLightSource \"point\" \"color I\" [5 5 5] \"point from\" [0.5 -1 2]\nVolume \"rawvolumegrid\" \"integer nx\" 2 \"integer ny\" 2 \"integer nz\" 2 \"string rawfile\" \"v.raw\"\nWorldEnd\n";

/// The files every graph may name, made once in the shared case folder.
fn include_fixtures(dir: &Path) {
    if dir.join("v.raw").exists() {
        return;
    }
    write(&dir.join("v.raw"), &[0u8; 8]);
    write(&dir.join("secret.env"), b"API_TOKEN \"SECRET\"\n");
    std::fs::create_dir(dir.join("folder.pbrt")).unwrap();
    let huge = std::fs::File::create(dir.join("huge.pbrt")).unwrap();
    huge.set_len(1 << 30).unwrap();
    let made = std::process::Command::new("mkfifo")
        .arg(dir.join("pipe.pbrt"))
        .status();
    assert!(made.is_ok_and(|s| s.success()), "mkfifo");
}

fn check_include_graph(dir: &Path, files: Vec<GraphFile>) -> Result<Verdict, String> {
    include_fixtures(dir);
    for (k, (scene, includes)) in files.iter().enumerate() {
        let mut text = if *scene {
            PBRT_SCENE.to_string()
        } else {
            String::new()
        };
        for (target, times) in includes {
            let name = match target {
                IncludeTarget::File(i) => format!("g{}.pbrt", i % files.len()),
                IncludeTarget::Missing => "gone.pbrt".into(),
                IncludeTarget::Folder => "folder.pbrt".into(),
                IncludeTarget::DevZero => "/dev/zero".into(),
                IncludeTarget::Fifo => "pipe.pbrt".into(),
                IncludeTarget::Huge => "huge.pbrt".into(),
                IncludeTarget::Foreign => "secret.env".into(),
            };
            text.push_str(&format!("Include \"{name}\"\n").repeat(*times));
        }
        write(&dir.join(format!("g{k}.pbrt")), text.as_bytes());
    }
    let (shown, verdict) = match volphot::import_pbrt(&dir.join("g0.pbrt"), dir) {
        Ok(import) => (import.to_toml(), Verdict::Accepted),
        Err(e) => (e.to_string(), Verdict::Rejected),
    };
    if shown.contains("SECRET") {
        return Err(format!("a foreign file's content is quoted: {shown}"));
    }
    // Every rejection names a pbrt file: the scene, or the file and line of the Include.
    if matches!(verdict, Verdict::Rejected) && !shown.contains(".pbrt:") {
        return Err(format!("unlocated error `{shown}` for {files:?}"));
    }
    Ok(verdict)
}

#[test]
fn fuzz_pbrt_include_graphs() {
    fuzz(
        "pbrt_include_graphs",
        CI_CASES,
        include_graph(),
        check_include_graph,
    );
}

#[test]
#[ignore = "long run: cargo test --release -p volphot-core --test it fuzz:: -- --ignored"]
fn fuzz_pbrt_include_graphs_long() {
    fuzz(
        "pbrt_include_graphs",
        LONG_CASES,
        include_graph(),
        check_include_graph,
    );
}

// --- environment maps: PFM, Radiance .hdr, OpenEXR -----------------------------------------

/// What a generated map file starts as.
#[derive(Debug, Clone, Copy)]
enum MapFormat {
    /// `PF` (RGB) or `Pf` (grey), little- or big-endian.
    Pfm {
        grey: bool,
        big: bool,
    },
    Hdr,
    Exr,
}

/// A change to a valid map file.
#[derive(Debug, Clone)]
enum MapMutation {
    /// Replace header field `i` (PFM: type, width, height, scale; .hdr: the size line).
    Field(usize, String),
    /// Flip a bit of the first 96 bytes.
    Flip(usize, u8),
    /// Keep this many 256ths of the file.
    Cut(u8),
    /// Append bytes.
    Append(Vec<u8>),
    /// Make the file 3 GiB long (sparse).
    Huge,
}

#[derive(Debug, Clone)]
struct MapCase {
    format: MapFormat,
    width: usize,
    height: usize,
    /// Texel values, cycled; some are out of range.
    values: Vec<f32>,
    mutations: Vec<MapMutation>,
}

/// A value a header field might hold: sizes that wrap or exceed the bound, bad scales, a
/// secret (which no error may quote) and control bytes.
fn map_field() -> impl Strategy<Value = String> {
    prop_oneof![
        Just("PF".to_string()),
        Just("Pf".to_string()),
        Just("P6".to_string()),
        Just("4611686018427387904".to_string()),
        Just("16384".to_string()),
        Just("0".to_string()),
        Just("3".to_string()),
        Just("-1".to_string()),
        Just("-1e38".to_string()),
        Just("1e39".to_string()),
        Just("nan".to_string()),
        Just("hunter2secret".to_string()),
        Just("\u{1b}]0;x\u{7}".to_string()),
        Just("-Y 16384 +X 16384".to_string()),
        Just("-Y 4294967295 +X 4294967295".to_string()),
        Just("+Y 2 -X 3".to_string()),
        "[ -~]{0,10}",
    ]
}

fn map_case() -> impl Strategy<Value = MapCase> {
    let format = prop_oneof![
        (any::<bool>(), any::<bool>()).prop_map(|(grey, big)| MapFormat::Pfm { grey, big }),
        Just(MapFormat::Hdr),
        Just(MapFormat::Exr),
    ];
    let value = prop_oneof![
        6 => 0.0f32..4.0,
        1 => Just(0.0f32),
        1 => Just(3e38f32),
        1 => Just(-1.0f32),
        1 => Just(f32::NAN),
    ];
    let mutation = prop_oneof![
        3 => (0usize..4, map_field()).prop_map(|(i, v)| MapMutation::Field(i, v)),
        2 => (0usize..96, 0u8..8).prop_map(|(i, b)| MapMutation::Flip(i, b)),
        1 => any::<u8>().prop_map(MapMutation::Cut),
        1 => prop::collection::vec(any::<u8>(), 1..64).prop_map(MapMutation::Append),
        1 => Just(MapMutation::Huge),
    ];
    (
        format,
        1usize..7,
        1usize..5,
        prop::collection::vec(value, 1..6),
        prop::collection::vec(mutation, 0..3),
    )
        .prop_map(|(format, width, height, values, mutations)| MapCase {
            format,
            width,
            height,
            values,
            mutations,
        })
}

/// The header fields and the pixel bytes of the case's valid file.
fn map_parts(dir: &Path, c: &MapCase) -> (Vec<String>, Vec<u8>) {
    let (w, h) = (c.width, c.height);
    let texel = |i: usize| c.values[i % c.values.len()];
    match c.format {
        MapFormat::Pfm { grey, big } => {
            let channels = if grey { 1 } else { 3 };
            let data = (0..w * h * channels)
                .flat_map(|i| {
                    if big {
                        texel(i).to_be_bytes()
                    } else {
                        texel(i).to_le_bytes()
                    }
                })
                .collect();
            let kind = if grey { "Pf" } else { "PF" };
            let scale = if big { "1" } else { "-1" };
            (
                vec![kind.into(), w.to_string(), h.to_string(), scale.into()],
                data,
            )
        }
        MapFormat::Hdr => {
            let rgb: Vec<image::Rgb<f32>> = (0..w * h)
                .map(|i| image::Rgb([texel(i).abs().min(1e30), texel(i + 1).abs().min(1e30), 0.5]))
                .collect();
            let mut bytes = Vec::new();
            image::codecs::hdr::HdrEncoder::new(&mut bytes)
                .encode(&rgb, w, h)
                .unwrap();
            // Split after the size line: the fields are the header's lines.
            let text_end = bytes
                .windows(2)
                .position(|p| p == b"\n\n")
                .map_or(0, |i| i + 2);
            let size_end = text_end
                + bytes[text_end..]
                    .iter()
                    .position(|&b| b == b'\n')
                    .unwrap_or(0)
                + 1;
            let head = String::from_utf8_lossy(&bytes[..text_end]).into_owned();
            let size = String::from_utf8_lossy(&bytes[text_end..size_end - 1]).into_owned();
            (vec![head, size], bytes[size_end..].to_vec())
        }
        MapFormat::Exr => {
            let path = dir.join(format!("make-{}.exr", std::process::id()));
            exr::prelude::write_rgb_file(&path, w, h, |x, y| {
                let i = y * w + x;
                (texel(i), texel(i + 1), texel(i + 2))
            })
            .unwrap();
            (vec![], std::fs::read(&path).unwrap())
        }
    }
}

fn map_bytes(dir: &Path, c: &MapCase) -> (Vec<u8>, bool) {
    let (mut fields, data) = map_parts(dir, c);
    let mut huge = false;
    for m in &c.mutations {
        if let MapMutation::Field(i, v) = m
            && !fields.is_empty()
        {
            let n = fields.len();
            fields[i % n] = v.clone();
        }
    }
    let mut bytes = match c.format {
        MapFormat::Pfm { .. } => format!(
            "{}\n{} {}\n{}\n",
            fields[0], fields[1], fields[2], fields[3]
        )
        .into_bytes(),
        MapFormat::Hdr => format!("{}{}\n", fields[0], fields[1]).into_bytes(),
        MapFormat::Exr => Vec::new(),
    };
    bytes.extend(data);
    for m in &c.mutations {
        match m {
            MapMutation::Flip(i, bit) if !bytes.is_empty() => {
                let n = bytes.len().min(96);
                bytes[i % n] ^= 1 << bit;
            }
            MapMutation::Cut(k) => bytes.truncate(bytes.len() * usize::from(*k) / 256),
            MapMutation::Append(extra) => bytes.extend(extra),
            MapMutation::Huge => huge = true,
            _ => {}
        }
    }
    (bytes, huge)
}

/// An error must name the file, and never quote a secret or a raw control byte of it.
fn check_map_error(text: &str, path: &Path, c: &MapCase) -> Result<Verdict, String> {
    let name = path.file_name().unwrap().to_string_lossy();
    if !text.contains(name.as_ref()) {
        return Err(format!("error does not name {name}: {text}"));
    }
    if text.contains("hunter2") || text.chars().any(|ch| ch.is_control() && ch != '\n') {
        return Err(format!("error quotes the file: {text:?} for {c:?}"));
    }
    Ok(Verdict::Rejected)
}

fn check_map(dir: &Path, c: MapCase) -> Result<Verdict, String> {
    let ext = match c.format {
        MapFormat::Pfm { .. } => "pfm",
        MapFormat::Hdr => "hdr",
        MapFormat::Exr => "exr",
    };
    let path = dir.join(format!("map-{}.{ext}", std::process::id()));
    let (bytes, huge) = map_bytes(dir, &c);
    write(&path, &bytes);
    if huge {
        let file = std::fs::OpenOptions::new().write(true).open(&path).unwrap();
        file.set_len(3 << 30).unwrap();
    }
    match volphot::EnvironmentMap::load(&path) {
        Ok(map) => {
            let sane = map
                .texels()
                .iter()
                .all(|t| t.is_finite() && t.min_element() >= 0.0 && t.max_element() <= 1e20)
                && map.integral().is_finite()
                && map.width() * map.height() == map.texels().len();
            if sane {
                Ok(Verdict::Accepted)
            } else {
                Err(format!(
                    "a map with texels beyond [0, 1e20] accepted from {c:?}"
                ))
            }
        }
        Err(e) => check_map_error(&e.to_string(), &path, &c),
    }
}

#[test]
fn fuzz_environment_maps() {
    fuzz("environment_maps", CI_CASES, map_case(), check_map);
}

#[test]
#[ignore = "long run: cargo test --release -p volphot-core --test it fuzz:: -- --ignored"]
fn fuzz_environment_maps_long() {
    fuzz("environment_maps", LONG_CASES, map_case(), check_map);
}

// --- light and clip tables -------------------------------------------------------------------

/// The keys that make each light type valid, written after the generated ones (which take
/// precedence) so that a good share of the tables build.
const LIGHT_TEMPLATES: &[&[(&str, &str)]] = &[
    &[("position", "[0.5, 0.5, 2]"), ("intensity", "1")],
    &[
        ("position", "[0.5, 0.5, 2]"),
        ("target", "[0.5, 0.5, 0.5]"),
        ("intensity", "1"),
    ],
    &[
        ("position", "[0.5, 0.5, 2]"),
        ("normal", "[0, 0, -1]"),
        ("size", "[0.5, 0.25]"),
        ("radiance", "1"),
    ],
    &[
        ("position", "[0.5, 0.5, 2]"),
        ("normal", "[0, 0, -1]"),
        ("radius", "0.25"),
        ("radiance", "1"),
    ],
    &[],
    &[("file", "\"sky.pfm\"")],
    &[],
];

/// Each light type with its keys (a key of another type is drawn now and then too).
const LIGHT_TYPES: &[(&str, &[&str])] = &[
    ("point", &["position", "intensity"]),
    (
        "spot",
        &[
            "position",
            "target",
            "intensity",
            "cone_angle",
            "beam_width",
        ],
    ),
    (
        "rect",
        &["position", "target", "normal", "up", "size", "radiance"],
    ),
    (
        "disc",
        &["position", "target", "normal", "radius", "radiance"],
    ),
    (
        "sky",
        &[
            "scale",
            "up",
            "rotation",
            "zenith",
            "horizon",
            "ground",
            "sun_direction",
            "sun_radiance",
            "sun_angle",
        ],
    ),
    ("environment", &["file", "scale", "up", "rotation"]),
    ("laser", &["position"]),
];

/// Values for light and clip keys: ordinary ones, extremes of 32-bit floats, degenerate
/// vectors and the environment map the fixtures hold.
fn light_value() -> impl Strategy<Value = String> {
    prop_oneof![
        Just("[0.5, 0.5, 2]".to_string()),
        Just("[0, 0, 1]".to_string()),
        Just("[0, 0, -1]".to_string()),
        Just("[0, 0, 0]".to_string()),
        Just("[1e-30, 1e-30]".to_string()),
        Just("[0.5, 0.25]".to_string()),
        Just("[1e38, 1e38, 1e38]".to_string()),
        Just("[1, nan, 1]".to_string()),
        Just("1".to_string()),
        Just("0".to_string()),
        Just("-2".to_string()),
        Just("30".to_string()),
        Just("0.53".to_string()),
        Just("0.0001".to_string()),
        Just("0.001".to_string()),
        Just("90".to_string()),
        Just("1e-23".to_string()),
        Just("1e38".to_string()),
        Just("3e38".to_string()),
        Just("inf".to_string()),
        Just("\"sky.pfm\"".to_string()),
        Just("\"../outside.pfm\"".to_string()),
        Just("\"link.pfm\"".to_string()),
        Just("\"none.exr\"".to_string()),
    ]
}

/// A light table: its type, then keys as (type whose key list to draw from — mostly its
/// own —, index into that list, value).
type LightTable = (usize, Vec<(Option<usize>, usize, String)>);

fn light_case() -> impl Strategy<Value = Vec<LightTable>> {
    let key = (
        prop::option::weighted(0.1, 0..LIGHT_TYPES.len()),
        0usize..16,
        light_value(),
    );
    let table = (0..LIGHT_TYPES.len(), prop::collection::vec(key, 0..4));
    prop::collection::vec(table, 1..3)
}

/// The maps a light table may name: one inside the folder, one beside it (named by its
/// path), and a link out of the folder.
fn light_fixtures(dir: &Path) {
    let mut map = b"Pf\n2 2\n-1\n".to_vec();
    map.extend([1.0f32, 2.0, 0.5, 0.0].iter().flat_map(|v| v.to_le_bytes()));
    write(&dir.join("sky.pfm"), &map);
    let outside = dir.parent().unwrap().join("outside.pfm");
    write(&outside, &map);
    let link = dir.join("link.pfm");
    if !link.exists() {
        std::os::unix::fs::symlink(&outside, &link).unwrap();
    }
}

/// Light arriving at the volume's centre from each light: finite, and a power finite and
/// above 0 (every light must emit) — what the integrators sum in 32-bit floats.
fn lights_are_finite(scene: &Scene) -> bool {
    let mut rng = volphot::Rng::stream(7, volphot::Domain::Photons, 0);
    scene.lights().iter().all(|light| {
        let power = light.power();
        let incident_ok = (0..64).all(|_| {
            light
                .sample_incident(glam::Vec3::splat(0.5), &mut rng)
                .is_none_or(|i| i.radiance.is_finite() && i.to_light.is_finite() && i.pdf > 0.0)
        });
        power.is_finite() && power.min_element() >= 0.0 && power.max_element() > 0.0 && incident_ok
    })
}

fn check_lights(dir: &Path, tables: Vec<LightTable>) -> Result<Verdict, String> {
    light_fixtures(dir);
    let mut text =
        "[volume]\nphantom = { name = \"sphere\", resolution = [4, 4, 4] }\n".to_string();
    for (kind, keys) in &tables {
        let (name, own) = LIGHT_TYPES[*kind];
        text += &format!("[[lights]]\ntype = \"{name}\"\n");
        let mut seen = Vec::new();
        for (from, k, v) in keys {
            let list = from.map_or(own, |t| LIGHT_TYPES[t].1);
            let key = list[k % list.len()];
            if !seen.contains(&key) {
                seen.push(key);
                text += &format!("{key} = {v}\n");
            }
        }
        for (key, v) in LIGHT_TEMPLATES[*kind] {
            if !seen.contains(key) {
                text += &format!("{key} = {v}\n");
            }
        }
    }
    let path = dir.join("lights.toml");
    write(&path, text.as_bytes());
    match Scene::load(&path, &SearchPath::new(vec![])) {
        Ok(scene) if lights_are_finite(&scene) => Ok(Verdict::Accepted),
        Ok(_) => Err(format!(
            "a light with infinite or NaN light accepted from\n{text}"
        )),
        Err(e) => {
            let message = e.to_string();
            if message.starts_with(&format!("{}:", path.display())) {
                Ok(Verdict::Rejected)
            } else {
                Err(format!("unlocated error `{message}` for\n{text}"))
            }
        }
    }
}

fn fuzz_light_tables_with(cases: u32) {
    let root = tempfile::tempdir().unwrap();
    let scenes = root.path().join("scenes");
    std::fs::create_dir(&scenes).unwrap();
    fuzz("light_tables", cases, light_case(), move |_, tables| {
        check_lights(&scenes, tables)
    });
}

#[test]
fn fuzz_light_tables() {
    fuzz_light_tables_with(CI_CASES);
}

#[test]
#[ignore = "long run: cargo test --release -p volphot-core --test it fuzz:: -- --ignored"]
fn fuzz_light_tables_long() {
    fuzz_light_tables_with(LONG_CASES);
}

/// A generated plane: a normal and an offset from lists that include the degenerate.
fn clip_plane() -> impl Strategy<Value = String> {
    let normal = prop_oneof![
        Just("[1, 0, 0]"),
        Just("[-1, 0, 0]"),
        Just("[0, 1, 1]"),
        Just("[1e-30, 0, 0]"),
        Just("[1e30, 1e30, 0]"),
        Just("[0, 0, 0]"),
        Just("[nan, 0, 1]"),
    ];
    let offset = prop_oneof![
        Just("0.5"),
        Just("-0.5"),
        Just("-0.5000001"),
        Just("-0.501"),
        Just("0"),
        Just("1"),
        Just("-1"),
        Just("1e30"),
    ];
    (normal, offset).prop_map(|(n, o)| format!("{{ normal = {n}, offset = {o} }}"))
}

fn clip_case() -> impl Strategy<Value = (u8, Option<String>, Vec<String>)> {
    let crop = prop_oneof![
        Just("{ p0 = [0, 0, 0], p1 = [1, 1, 1] }".to_string()),
        Just("{ p0 = [0, 0, 0.5], p1 = [1, 1, 0.5000001] }".to_string()),
        Just("{ p0 = [0.2, 0.2, 0.2], p1 = [0.8, 0.8, 0.3] }".to_string()),
        Just("{ p0 = [2, 2, 2], p1 = [3, 3, 3] }".to_string()),
        Just("{ p0 = [0.6, 0, 0], p1 = [0.4, 1, 1] }".to_string()),
    ];
    (
        0u8..3,
        prop::option::of(crop),
        prop::collection::vec(clip_plane(), 0..4),
    )
}

fn check_clip(
    dir: &Path,
    (space, crop, planes): (u8, Option<String>, Vec<String>),
) -> Result<Verdict, String> {
    let mut text = "[volume]\nphantom = { name = \"constant\", resolution = [4, 4, 4] }\n[three_point]\n[clip]\n".to_string();
    text += &format!(
        "space = \"{}\"\n",
        ["volume", "world", "view"][space as usize]
    );
    if let Some(b) = &crop {
        text += &format!("box = {b}\n");
    }
    if !planes.is_empty() {
        text += &format!("planes = [{}]\n", planes.join(", "));
    }
    let path = dir.join("clip.toml");
    write(&path, text.as_bytes());
    match Scene::load(&path, &SearchPath::new(vec![])) {
        Ok(scene) => match scene.medium().clip_region() {
            Some(region) if region.volume().is_nan() || region.volume() <= 0.0 => Err(format!(
                "a region of volume {} accepted from\n{text}",
                region.volume()
            )),
            _ => Ok(Verdict::Accepted),
        },
        Err(e) => {
            let message = e.to_string();
            if message.starts_with(&format!("{}:", path.display())) {
                Ok(Verdict::Rejected)
            } else {
                Err(format!("unlocated error `{message}` for\n{text}"))
            }
        }
    }
}

#[test]
fn fuzz_clip_tables() {
    fuzz("clip_tables", CI_CASES, clip_case(), check_clip);
}

#[test]
#[ignore = "long run: cargo test --release -p volphot-core --test it fuzz:: -- --ignored"]
fn fuzz_clip_tables_long() {
    fuzz("clip_tables", LONG_CASES, clip_case(), check_clip);
}
