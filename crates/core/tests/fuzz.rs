//! Property-based tests of every file parser of the core: RAW layouts, NRRD, MetaImage, PGM
//! transfer functions and scene TOML. Generated inputs mix valid and invalid pieces of each
//! format; for every case the parser must return within a time bound, must not panic, and
//! a rejection must name its file (and, for scenes, the line and column or the key).
//!
//! CI runs a few thousand cases per parser; the long run (`cargo test --release -p
//! volphot-core --test fuzz -- --ignored`) runs 100 000 each.

use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::sync::mpsc;
use std::time::Duration;

use proptest::prelude::*;
use proptest::test_runner::{Config, TestCaseError, TestRunner};
use volphot::{
    ByteOrder, FileRequest, Normalization, RawLayout, Scene, SearchPath, TransferFunction,
    VoxelType, read_metaimage, read_nrrd, read_volume,
};

/// Cases per parser in a normal test run, and in the long (`--ignored`) run.
const CI_CASES: u32 = 1500;
const LONG_CASES: u32 = 100_000;

/// The most any one case may take.
const BOUND: Duration = Duration::from_secs(20);

/// What a parser did with one generated input.
enum Verdict {
    Accepted,
    /// Rejected with an error that names its file (and key or position).
    Rejected,
}

/// Runs `check` on each generated case in a thread of its own, failing a case that
/// panics, hangs past [`BOUND`] or is rejected with an error that does not say where.
/// Prints how many cases were accepted and rejected.
fn fuzz<S, F>(name: &str, cases: u32, strategy: S, check: F)
where
    S: Strategy,
    S::Value: Clone + std::fmt::Debug + Send + 'static,
    F: Fn(&Path, S::Value) -> Result<Verdict, String> + Send + Sync + Clone + 'static,
{
    let accepted = std::sync::atomic::AtomicU32::new(0);
    let rejected = std::sync::atomic::AtomicU32::new(0);
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
            let outcome =
                std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| check(&case_dir, input)));
            let _ = tx.send(outcome);
        });
        match rx.recv_timeout(BOUND) {
            Err(_) => Err(TestCaseError::fail(format!(
                "no answer within {BOUND:?} (a hang) for {shown}"
            ))),
            Ok(Err(_)) => Err(TestCaseError::fail(format!("panicked on {shown}"))),
            Ok(Ok(Err(message))) => Err(TestCaseError::fail(message)),
            Ok(Ok(Ok(Verdict::Accepted))) => {
                accepted.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                Ok(())
            }
            Ok(Ok(Ok(Verdict::Rejected))) => {
                rejected.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                Ok(())
            }
        }
    });
    if let Err(e) = result {
        panic!("{e}");
    }
    let _ = writeln!(
        std::io::stderr().lock(),
        "fuzz {name}: {cases} cases, {} accepted, {} rejected with a located error, 0 panics, 0 hangs",
        accepted.into_inner(),
        rejected.into_inner()
    );
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
#[ignore = "long run: cargo test --release -p volphot-core --test fuzz -- --ignored"]
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
#[ignore = "long run: cargo test --release -p volphot-core --test fuzz -- --ignored"]
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
#[ignore = "long run: cargo test --release -p volphot-core --test fuzz -- --ignored"]
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
#[ignore = "long run: cargo test --release -p volphot-core --test fuzz -- --ignored"]
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
#[ignore = "long run: cargo test --release -p volphot-core --test fuzz -- --ignored"]
fn fuzz_scene_files_long() {
    fuzz("scene_files", LONG_CASES, scene_case(), check_scene);
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
#[ignore = "long run: cargo test --release -p volphot-core --test fuzz -- --ignored"]
fn fuzz_pbrt_include_graphs_long() {
    fuzz(
        "pbrt_include_graphs",
        LONG_CASES,
        include_graph(),
        check_include_graph,
    );
}
