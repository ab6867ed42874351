//! Transfer functions: density → density scaling, applied to every voxel before rendering
//! (thesis §2.3, §7.2.3).
//!
//! * [`TransferFunction::Table`] — the thesis's 256×256 PGM (P2 or P5). Column `i` stands for
//!   density bin `i`; its value is the column mean / maxval, which equals the grey level of a
//!   gradient image and the curve height of a filled-under-curve drawing.
//! * [`TransferFunction::Points`] — piecewise-linear control points `[density, value]`.
//! * [`TransferFunction::Threshold`] — the 16-bit rule: values below a raw threshold map to 0.
//! * [`TransferFunction::Identity`].
//! * [`TransferFunction::Colour`] — a colour + opacity function in data units
//!   ([`ColourTransfer`]: points, a Slicer `.vp`/`.vp.json` file or a built-in preset); the
//!   transferred density is the extinction per world unit, the colour the albedo.
//!
//! ```
//! use volphot::TransferFunction;
//! let tf = TransferFunction::points(&[[0.0, 0.0], [0.5, 1.0]]).unwrap();
//! assert_eq!(tf.apply(0.25), 0.5);
//! assert_eq!(tf.apply(0.9), 1.0);
//! ```

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::colour::ColourTransfer;
use crate::error::{Error, Result};
use crate::util::{TEXT_INPUT_CAP, escaped_prefix, read_bytes_capped};
use crate::volume::NormalizationRecord;

/// A 1-D transfer function over normalised density.
#[derive(Debug, Clone, PartialEq)]
pub enum TransferFunction {
    /// Density passes unchanged.
    Identity,
    /// 256 bins (PGM columns), linearly interpolated at `d·255`.
    Table {
        /// Bin values.
        bins: Vec<f32>,
        /// The file it came from.
        source: PathBuf,
    },
    /// Piecewise-linear through sorted control points, constant beyond the ends.
    Points(Vec<[f32; 2]>),
    /// Normalised densities below `normalized` map to 0 (raw threshold kept for records).
    Threshold {
        /// Threshold in normalised units.
        normalized: f32,
        /// Threshold as written, in raw voxel units.
        raw: f64,
    },
    /// Colour + opacity in data units: density becomes extinction per world unit.
    Colour {
        /// The function.
        tf: Box<ColourTransfer>,
        /// Raw value at normalised density 0.
        raw_lo: f64,
        /// Raw value at 1 minus raw value at 0.
        raw_span: f64,
        /// Millimetres per world unit (set by the scene from the volume's spacing).
        mm_per_world: f64,
    },
}

/// Transfer-function parameters as written in a scene's `[transfer]` table.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TransferParams {
    /// `identity`, `pgm`, `points` or `threshold`.
    #[serde(default)]
    pub kind: TransferKind,
    /// `pgm`: path of the 256×256 PGM, relative to the scene file.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub file: Option<PathBuf>,
    /// `points`: `[[density, value], …]` with increasing densities in `[0, 1]`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub points: Option<Vec<[f32; 2]>>,
    /// `threshold`: raw voxel value below which density is 0 (thesis: 16-bit data).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub threshold: Option<f64>,
    /// `colour`: a built-in 3D Slicer preset (`CT-Bone`, `CT-AAA`, `MR-Default`, …).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub preset: Option<String>,
    /// `colour`: `[[value, opacity], …]` in data units (HU for CT), increasing values.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub opacity: Option<Vec<[f64; 2]>>,
    /// `colour`: `[[value, r, g, b], …]` in data units, increasing values.
    #[serde(default, skip_serializing_if = "Option::is_none", alias = "color")]
    pub colour: Option<Vec<[f64; 4]>>,
    /// `colour`: the opacity unit distance in mm (default: the file's, else 1).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub unit_distance: Option<f64>,
    /// `colour`: added to the stored values to give the data units the function is written
    /// in (a RAW file that stores HU + 1024, like CThead, takes −1024; DICOM and NIfTI are
    /// already rescaled).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub intercept: Option<f64>,
}

/// The kind of transfer function a scene's `[transfer]` table asks for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum TransferKind {
    /// Density passes unchanged.
    #[default]
    Identity,
    /// The thesis's 256×256 PGM image (`file`).
    Pgm,
    /// Piecewise-linear control points (`points`).
    Points,
    /// The 16-bit rule: raw values below `threshold` map to 0.
    Threshold,
    /// Colour + opacity in data units (`preset`, a `.vp`/`.vp.json` `file`, or `opacity`
    /// and `colour` points); implied by any of `preset`, `opacity`, `colour` or a `.vp` /
    /// `.vp.json` file.
    #[serde(alias = "color")]
    Colour,
}

impl TransferKind {
    /// The name as written in scene files.
    pub fn name(self) -> &'static str {
        match self {
            TransferKind::Identity => "identity",
            TransferKind::Pgm => "pgm",
            TransferKind::Points => "points",
            TransferKind::Threshold => "threshold",
            TransferKind::Colour => "colour",
        }
    }
}

impl Default for TransferParams {
    fn default() -> Self {
        TransferParams {
            kind: TransferKind::Identity,
            file: None,
            points: None,
            threshold: None,
            preset: None,
            opacity: None,
            colour: None,
            unit_distance: None,
            intercept: None,
        }
    }
}

impl TransferParams {
    /// Whether any key of the colour transfer function is given (`preset`, `opacity`,
    /// `colour`, `unit_distance`, `intercept`, or a 3D Slicer `.vp`/`.vp.json` file).
    fn has_colour_keys(&self) -> bool {
        let slicer_file = self.file.as_ref().is_some_and(|f| {
            let name = f.to_string_lossy().to_ascii_lowercase();
            name.ends_with(".vp") || name.ends_with(".vp.json")
        });
        self.preset.is_some()
            || self.opacity.is_some()
            || self.colour.is_some()
            || self.unit_distance.is_some()
            || self.intercept.is_some()
            || slicer_file
    }
}

impl TransferFunction {
    /// Builds a transfer function from its parameters. `base` resolves relative file paths;
    /// `normalization` converts a raw threshold to the normalised scale.
    pub fn create(
        params: &TransferParams,
        base: &Path,
        normalization: &NormalizationRecord,
    ) -> Result<Self> {
        let colour_keys = params.has_colour_keys();
        if params.kind == TransferKind::Colour
            || (params.kind == TransferKind::Identity && colour_keys)
        {
            return Self::create_colour(params, base, normalization);
        }
        if colour_keys {
            return Err(Error::parameter(
                "kind",
                params.kind.name(),
                "kind = \"colour\" with `preset`, `opacity`, `colour`, `unit_distance` or `intercept`",
            ));
        }
        match params.kind {
            TransferKind::Colour => unreachable!("handled above"),
            TransferKind::Identity => Self::create_identity(params),
            TransferKind::Pgm => {
                let file = params.file.as_ref().ok_or_else(|| {
                    Error::parameter("file", "(missing)", "the path of a 256×256 PGM image")
                })?;
                let path = crate::util::confined(base, file, "the scene's folder")?;
                Self::from_pgm(&path).map_err(|e| match e {
                    Error::Io { path, error } if error.kind() == std::io::ErrorKind::NotFound => {
                        Error::format(
                            &path,
                            "does not exist; `transfer.file` names the 256×256 PGM transfer function, relative to the scene file (or use kind = \"points\")",
                        )
                    }
                    e => e,
                })
            }
            TransferKind::Points => {
                let points = params.points.as_ref().ok_or_else(|| {
                    Error::parameter("points", "(missing)", "[[density, value], …]")
                })?;
                Self::points(points)
            }
            TransferKind::Threshold => Self::create_threshold(params, normalization),
        }
    }

    /// `kind = "identity"`, which takes no `file`, `points` or `threshold`.
    fn create_identity(params: &TransferParams) -> Result<Self> {
        let given = [
            ("file", params.file.is_some()),
            ("points", params.points.is_some()),
            ("threshold", params.threshold.is_some()),
        ];
        if let Some((key, _)) = given.into_iter().find(|(_, present)| *present) {
            return Err(Error::given_without_use(
                key,
                format!("no `{key}` with kind = \"{}\"", params.kind.name()),
            ));
        }
        Ok(TransferFunction::Identity)
    }

    /// `kind = "threshold"`: a raw voxel value, at most the data's maximum, on the
    /// normalised scale.
    fn create_threshold(
        params: &TransferParams,
        normalization: &NormalizationRecord,
    ) -> Result<Self> {
        let raw = params
            .threshold
            .ok_or_else(|| Error::parameter("threshold", "(missing)", "a raw voxel value"))?;
        if !raw.is_finite() {
            return Err(Error::parameter(
                "threshold",
                raw,
                "a finite raw voxel value",
            ));
        }
        let lo = normalization.raw_lo;
        let hi = normalization.raw_hi;
        if raw > normalization.data_max {
            return Err(Error::parameter(
                "threshold",
                raw,
                format!(
                    "a raw value <= the data's maximum {} (a larger threshold blanks the whole volume; see the head16 note in the dataset registry)",
                    normalization.data_max
                ),
            ));
        }
        let normalized = ((raw - lo) / (hi - lo)).clamp(0.0, 1.0) as f32;
        Ok(TransferFunction::Threshold { normalized, raw })
    }

    /// `kind = "colour"`: exactly one of `preset`, `file` (`.vp`, `.vp.json`) or the
    /// `opacity` + `colour` points.
    fn create_colour(
        params: &TransferParams,
        base: &Path,
        normalization: &NormalizationRecord,
    ) -> Result<Self> {
        let given = [
            params.preset.is_some(),
            params.file.is_some(),
            params.opacity.is_some() || params.colour.is_some(),
        ];
        if given.iter().filter(|g| **g).count() != 1 {
            return Err(Error::parameter(
                "preset",
                format!("{} sources", given.iter().filter(|g| **g).count()),
                "exactly one of `preset`, `file` (.vp or .vp.json) or `opacity` with `colour`",
            ));
        }
        if params.points.is_some() || params.threshold.is_some() {
            return Err(Error::given_without_use(
                "points",
                "no `points` or `threshold` with a colour transfer function",
            ));
        }
        let mut tf = if let Some(name) = &params.preset {
            ColourTransfer::preset(name)?
        } else if let Some(file) = &params.file {
            ColourTransfer::read(&crate::util::confined(base, file, "the scene's folder")?)?
        } else {
            let missing = |key: &str| {
                Error::parameter(
                    key,
                    "(missing)",
                    format!("`{key}` points with a colour transfer function"),
                )
            };
            ColourTransfer {
                source: "points".into(),
                opacity: params.opacity.clone().ok_or_else(|| missing("opacity"))?,
                colour: params.colour.clone().ok_or_else(|| missing("colour"))?,
                unit_distance: 1.0,
            }
        };
        if let Some(u) = params.unit_distance {
            tf.unit_distance = u;
        }
        let tf = tf.validated("transfer")?;
        let intercept = params.intercept.unwrap_or(0.0);
        if !intercept.is_finite() {
            return Err(Error::parameter(
                "intercept",
                intercept,
                "a finite offset in data units",
            ));
        }
        Ok(TransferFunction::Colour {
            tf: Box::new(tf),
            raw_lo: normalization.raw_lo + intercept,
            raw_span: normalization.raw_hi - normalization.raw_lo,
            mm_per_world: 1.0,
        })
    }

    /// The same function with extinction expressed per world unit when one world unit is
    /// `mm` millimetres (only colour transfer functions depend on it).
    pub fn with_world_scale(mut self, mm: f64) -> Self {
        if let TransferFunction::Colour { mm_per_world, .. } = &mut self {
            *mm_per_world = mm;
        }
        self
    }

    /// The albedo colour at normalised density `d`, for colour transfer functions.
    pub fn colour_at(&self, d: f32) -> Option<[f32; 3]> {
        match self {
            TransferFunction::Colour {
                tf,
                raw_lo,
                raw_span,
                ..
            } => Some(tf.colour(raw_lo + d as f64 * raw_span).map(|c| c as f32)),
            _ => None,
        }
    }

    /// Piecewise-linear control points, validated.
    pub fn points(points: &[[f32; 2]]) -> Result<Self> {
        if points.is_empty() {
            return Err(Error::parameter(
                "points",
                "[]",
                "at least one [density, value] pair",
            ));
        }
        for (i, [d, v]) in points.iter().enumerate() {
            if !(d.is_finite() && (0.0..=1.0).contains(d)) {
                return Err(Error::parameter(
                    format!("points[{i}]"),
                    format!("[{d}, {v}]"),
                    "a density in [0, 1]",
                ));
            }
            if !(v.is_finite() && *v >= 0.0) {
                return Err(Error::parameter(
                    format!("points[{i}]"),
                    format!("[{d}, {v}]"),
                    "a finite value >= 0",
                ));
            }
            if i > 0 && *d <= points[i - 1][0] {
                return Err(Error::parameter(
                    format!("points[{i}]"),
                    format!("[{d}, {v}]"),
                    format!(
                        "a density greater than the previous one ({})",
                        points[i - 1][0]
                    ),
                ));
            }
        }
        Ok(TransferFunction::Points(points.to_vec()))
    }

    /// Reads the thesis's PGM transfer function (P2 or P5, 256×256): a regular file of at
    /// most 16 MiB (a device or a FIFO named by mistake is refused, not read).
    pub fn from_pgm(path: &Path) -> Result<Self> {
        let bytes = read_bytes_capped(path, TEXT_INPUT_CAP, "PGM transfer function")?;
        let image = parse_pgm(&bytes).map_err(|m| Error::format(path, m))?;
        if image.width != 256 || image.height != 256 {
            return Err(Error::format(
                path,
                format!(
                    "transfer function image is {}×{}, expected 256×256 (thesis §7.2.3)",
                    image.width, image.height
                ),
            ));
        }
        let bins = (0..256)
            .map(|x| {
                let sum: f64 = (0..256).map(|y| image.pixels[y * 256 + x] as f64).sum();
                (sum / 256.0 / image.maxval as f64) as f32
            })
            .collect();
        Ok(TransferFunction::Table {
            bins,
            source: path.to_path_buf(),
        })
    }

    /// Transferred density for normalised density `d`.
    #[inline]
    pub fn apply(&self, d: f32) -> f32 {
        match self {
            TransferFunction::Identity => d,
            TransferFunction::Table { bins, .. } => {
                let x = (d.clamp(0.0, 1.0)) * 255.0;
                let i = (x as usize).min(254);
                let t = x - i as f32;
                bins[i] + (bins[i + 1] - bins[i]) * t
            }
            TransferFunction::Points(points) => {
                let first = points[0];
                if d <= first[0] {
                    return first[1];
                }
                for w in points.windows(2) {
                    let ([d0, v0], [d1, v1]) = (w[0], w[1]);
                    if d <= d1 {
                        return v0 + (v1 - v0) * (d - d0) / (d1 - d0);
                    }
                }
                points[points.len() - 1][1]
            }
            TransferFunction::Threshold { normalized, .. } => {
                if d < *normalized {
                    0.0
                } else {
                    d
                }
            }
            TransferFunction::Colour {
                tf,
                raw_lo,
                raw_span,
                mm_per_world,
            } => (tf.extinction_per_mm(raw_lo + d as f64 * raw_span) * mm_per_world) as f32,
        }
    }

    /// One line for provenance records.
    pub fn describe(&self) -> String {
        match self {
            TransferFunction::Identity => "identity".into(),
            TransferFunction::Table { source, .. } => format!("pgm {}", source.display()),
            TransferFunction::Points(p) => format!("points {p:?}"),
            TransferFunction::Threshold { raw, normalized } => {
                format!("threshold {raw} (normalised {normalized})")
            }
            TransferFunction::Colour {
                tf, mm_per_world, ..
            } => format!("{}, {mm_per_world} mm per world unit", tf.describe()),
        }
    }
}

/// A decoded greyscale PGM.
#[derive(Debug, Clone, PartialEq)]
pub struct Pgm {
    /// Columns.
    pub width: usize,
    /// Rows.
    pub height: usize,
    /// Maximum grey value.
    pub maxval: u32,
    /// Row-major grey values.
    pub pixels: Vec<u32>,
}

/// Parses a P2 (ASCII) or P5 (binary, 8- or 16-bit) PGM. Errors are plain messages; the
/// caller attaches the path.
pub fn parse_pgm(bytes: &[u8]) -> std::result::Result<Pgm, String> {
    let mut reader = PgmReader { bytes, pos: 0 };
    let magic = reader.token()?;
    if magic != "P2" && magic != "P5" {
        // A few escaped bytes only: the file may be any file (`/etc/passwd`).
        return Err(format!(
            "not a greyscale PGM: it starts with `{}`, expected the magic \"P2\" or \"P5\"",
            escaped_prefix(bytes, 4)
        ));
    }
    let width = reader.number("width")? as usize;
    let height = reader.number("height")? as usize;
    let maxval = reader.number("maxval")?;
    if width == 0 || height == 0 || width > 65536 || height > 65536 {
        return Err(format!("PGM size {width}×{height} is not usable"));
    }
    if maxval == 0 || maxval > 65535 {
        return Err(format!("PGM maxval {maxval}, expected 1..=65535"));
    }
    let pixels = if magic == "P5" {
        reader.binary_raster(width, height, maxval)?
    } else {
        reader.ascii_raster(width, height)?
    };
    if let Some((i, v)) = pixels.iter().enumerate().find(|(_, v)| **v > maxval) {
        return Err(format!("PGM pixel {i} is {v}, above maxval {maxval}"));
    }
    Ok(Pgm {
        width,
        height,
        maxval,
        pixels,
    })
}

/// A PGM file's bytes and how far they have been read.
struct PgmReader<'a> {
    bytes: &'a [u8],
    pos: usize,
}

impl PgmReader<'_> {
    /// The next whitespace-separated header token, skipping `#` comments.
    fn token(&mut self) -> std::result::Result<String, String> {
        let bytes = self.bytes;
        loop {
            while self.pos < bytes.len() && bytes[self.pos].is_ascii_whitespace() {
                self.pos += 1;
            }
            if self.pos < bytes.len() && bytes[self.pos] == b'#' {
                while self.pos < bytes.len() && bytes[self.pos] != b'\n' {
                    self.pos += 1;
                }
                continue;
            }
            break;
        }
        let start = self.pos;
        while self.pos < bytes.len()
            && !bytes[self.pos].is_ascii_whitespace()
            && bytes[self.pos] != b'#'
        {
            self.pos += 1;
        }
        if start == self.pos {
            return Err("unexpected end of PGM header".into());
        }
        Ok(String::from_utf8_lossy(&bytes[start..self.pos]).into_owned())
    }

    /// The next header token as the non-negative integer `name`.
    fn number(&mut self, name: &str) -> std::result::Result<u32, String> {
        let t = self.token()?;
        t.parse::<u32>()
            .map_err(|_| format!("PGM {name} is {t:?}, expected a positive integer"))
    }

    /// A P5 raster: one byte a pixel up to maxval 255, else two, big-endian.
    fn binary_raster(
        &mut self,
        width: usize,
        height: usize,
        maxval: u32,
    ) -> std::result::Result<Vec<u32>, String> {
        // Exactly one whitespace byte separates the header from the raster.
        self.pos += 1;
        let bpp = if maxval > 255 { 2 } else { 1 };
        let need = width * height * bpp;
        let have = self.bytes.len().saturating_sub(self.pos);
        if have < need {
            return Err(format!(
                "PGM raster has {have} bytes, expected {need} for {width}×{height} at {} byte(s) per pixel",
                bpp
            ));
        }
        let raster = &self.bytes[self.pos..self.pos + need];
        Ok(if bpp == 1 {
            raster.iter().map(|&b| b as u32).collect()
        } else {
            raster
                .chunks_exact(2)
                .map(|c| u16::from_be_bytes([c[0], c[1]]) as u32)
                .collect()
        })
    }

    /// A P2 raster: `width × height` whitespace-separated integers.
    fn ascii_raster(
        &mut self,
        width: usize,
        height: usize,
    ) -> std::result::Result<Vec<u32>, String> {
        let count = width * height;
        let mut pixels = Vec::with_capacity(count);
        for i in 0..count {
            let t = self.token().map_err(|_| {
                format!("PGM has {i} pixel values, expected {count} for {width}×{height}")
            })?;
            let v: u32 = t
                .parse()
                .map_err(|_| format!("PGM pixel {i} is {t:?}, expected an integer"))?;
            pixels.push(v);
        }
        Ok(pixels)
    }
}

/// Writes a P5 PGM (used by tests and to export transfer functions).
pub fn write_pgm(width: usize, height: usize, pixels: &[u8]) -> Vec<u8> {
    let mut out = format!("P5\n{width} {height}\n255\n").into_bytes();
    out.extend_from_slice(pixels);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn record(lo: f64, hi: f64, max: f64) -> NormalizationRecord {
        NormalizationRecord {
            method: crate::volume::Normalization::TypeRange,
            raw_lo: lo,
            raw_hi: hi,
            data_min: lo,
            data_max: max,
        }
    }

    #[test]
    fn pgm_gradient_is_identity_like_and_curve_is_height() {
        // Gradient: every pixel in column x has grey x.
        let grad: Vec<u8> = (0..256 * 256).map(|i| (i % 256) as u8).collect();
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("g.pgm");
        std::fs::write(&p, write_pgm(256, 256, &grad)).unwrap();
        let tf = TransferFunction::from_pgm(&p).unwrap();
        assert!((tf.apply(100.0 / 255.0) - 100.0 / 255.0).abs() < 1e-6);
        // Filled-under-curve drawing: column x white up to height x/2.
        let mut curve = vec![0u8; 256 * 256];
        for x in 0..256 {
            for y in 0..x / 2 {
                curve[(255 - y) * 256 + x] = 255;
            }
        }
        std::fs::write(&p, write_pgm(256, 256, &curve)).unwrap();
        let tf = TransferFunction::from_pgm(&p).unwrap();
        assert!((tf.apply(200.0 / 255.0) - 100.0 / 256.0).abs() < 1e-6);
    }

    #[test]
    fn pgm_ascii_matches_binary() {
        let mut text = String::from("P2\n# a comment\n256 256\n255\n");
        for i in 0..256 * 256 {
            text += &format!("{} ", (i % 256) / 2);
        }
        let a = parse_pgm(text.as_bytes()).unwrap();
        let raster: Vec<u8> = (0..256 * 256).map(|i| ((i % 256) / 2) as u8).collect();
        let b = parse_pgm(&write_pgm(256, 256, &raster)).unwrap();
        assert_eq!(a, b);
    }

    #[test]
    fn pgm_errors() {
        assert!(
            parse_pgm(b"P6\n1 1\n255\n\0\0\0")
                .unwrap_err()
                .contains("P6")
        );
        assert!(
            parse_pgm(b"P5\n256 256\n255\n\0\0")
                .unwrap_err()
                .contains("65536")
        );
        assert!(
            parse_pgm(b"P2\n2 1\n10\n3 11")
                .unwrap_err()
                .contains("above maxval")
        );
        assert!(parse_pgm(b"P2\n2 x\n10\n").unwrap_err().contains("height"));
    }

    #[test]
    fn foreign_endless_and_missing_files_are_named_never_quoted_or_read_whole() {
        let dir = tempfile::tempdir().unwrap();
        let passwd = dir.path().join("passwd.pgm");
        std::fs::write(&passwd, "root:x:0:0:SECRET:/root:/bin/bash\n").unwrap();
        let e = TransferFunction::from_pgm(&passwd).unwrap_err().to_string();
        assert!(
            e.contains("passwd.pgm") && e.contains("\"P2\" or \"P5\""),
            "names the file and the magic expected: {e}"
        );
        assert!(!e.contains("SECRET") && !e.contains("x:0"), "{e}");
        // `/dev/zero` never ends: refused by its kind, on a thread so a regression fails.
        let (tx, rx) = std::sync::mpsc::channel();
        std::thread::spawn(move || {
            let result = TransferFunction::from_pgm(Path::new("/dev/zero"));
            let _ = tx.send(result.map(|_| ()).map_err(|e| e.to_string()));
        });
        let e = rx
            .recv_timeout(std::time::Duration::from_secs(30))
            .expect("/dev/zero was read for 30 s")
            .unwrap_err();
        assert!(
            e.contains("/dev/zero") && e.contains("character device"),
            "{e}"
        );
        let params = TransferParams {
            kind: TransferKind::Pgm,
            file: Some("gone.pgm".into()),
            ..TransferParams::default()
        };
        let e = TransferFunction::create(&params, dir.path(), &record(0.0, 255.0, 255.0))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("gone.pgm") && e.contains("does not exist") && e.contains("transfer.file"),
            "{e}"
        );
    }

    #[test]
    fn threshold_uses_raw_units() {
        let params = TransferParams {
            kind: TransferKind::Threshold,
            threshold: Some(2500.0),
            ..Default::default()
        };
        let tf = TransferFunction::create(&params, Path::new("."), &record(0.0, 65535.0, 4328.0))
            .unwrap();
        assert_eq!(tf.apply(2000.0 / 65535.0), 0.0);
        let d = 3000.0 / 65535.0;
        assert_eq!(tf.apply(d), d);
        let bad = TransferParams {
            threshold: Some(40000.0),
            ..params
        };
        let e = TransferFunction::create(&bad, Path::new("."), &record(0.0, 65535.0, 4328.0))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("threshold") && e.contains("40000") && e.contains("4328"),
            "{e}"
        );
    }

    #[test]
    fn points_validation_names_index() {
        let e = TransferFunction::points(&[[0.0, 0.0], [0.5, 1.0], [0.4, 1.0]])
            .unwrap_err()
            .to_string();
        assert!(e.contains("points[2]"), "{e}");
        let e = TransferFunction::points(&[[0.0, -1.0]])
            .unwrap_err()
            .to_string();
        assert!(e.contains("points[0]") && e.contains("-1"), "{e}");
    }
}
