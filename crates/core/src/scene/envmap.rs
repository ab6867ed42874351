//! Equirectangular HDR environment maps for an environment light: reading (.exr, .pfm,
//! .hdr), lookup, and importance sampling from a piecewise-constant 2-D distribution.
//!
//! Directions follow Mitsuba 3's `envmap`, so that an exported scene agrees. In the light's
//! local frame (+y up) a unit direction `d` pointing from the scene towards the sky (the
//! direction light arrives from) maps to
//!
//! ```text
//! u = atan2(d.x, −d.z) / 2π   wrapped into [0, 1)      column ⌊u·W⌋ (clamped to W − 1)
//! v = acos(d.y) / π                                    row    ⌊v·H⌋ (clamped to H − 1)
//! ```
//!
//! so row 0, the image's top row, holds the zenith. The inverse is `φ = 2πu`, `θ = πv`,
//! `d = (sin θ sin φ, cos θ, −sin θ cos φ)`.
//!
//! The map is piecewise constant (nearest texel, as pbrt-v4's `ImageInfiniteLight` looks
//! up), which lets sampling be exactly proportional to it: a texel is chosen with
//! probability ∝ mean(RGB) × its solid angle, then a point uniform in φ and in cos θ inside
//! it, so the solid-angle pdf is constant inside a texel and equals mean(RGB) / Σ(mean·Ω).

use std::cell::Cell;
use std::io::Read;
use std::path::Path;

use glam::{DVec3, Vec3};

use super::light::incident::MAX_INTENSITY;
use crate::error::{Error, Result};
use crate::math::PiecewiseConstant2D;
use crate::util::{PfmChannels, read_pfm_bounded};
use crate::util::{byte_size, memory_budget_bytes, open_regular};

/// The most texels a map file may hold: 2^27, a 16384 × 8192 map (the largest
/// equirectangular maps published). Checked from the file's header before any texel is
/// read or allocated, together with [`BYTES_PER_TEXEL`] against half the machine's
/// available memory.
pub const MAX_TEXELS: usize = 1 << 27;

/// Memory a loaded map takes per texel: its RGB (12 bytes) and its sampling
/// distribution's running sum (8). The largest map, [`MAX_TEXELS`], takes 2.5 GiB.
pub const BYTES_PER_TEXEL: u64 = 20;

/// The longest header of a Radiance `.hdr` or OpenEXR map read before its size is known
/// (a real one is a few hundred bytes).
const HEADER_CAP: u64 = 1 << 20;

/// The largest f64 below 1: sample positions are kept in [0, 1).
const ONE_BELOW: f64 = 1.0 - f64::EPSILON / 2.0;

/// What the texel checks expect of every texel.
const TEXEL_EXPECTED: &str =
    "finite, non-negative RGB radiance of at most 1e20 (W/m²/sr) in every texel (row 0 is the top)";

/// An equirectangular environment map (RGB radiance, row 0 at the zenith).
#[derive(Debug, Clone, PartialEq)]
pub struct EnvironmentMap {
    width: usize,
    height: usize,
    texels: Vec<Vec3>,
    /// Each texel's sampling weight, mean(RGB) × solid angle, as a 2-D distribution
    /// (marginal over rows, conditional over columns); its total is the sampling pdf's
    /// normaliser (0 for a black map, which is never sampled).
    distribution: PiecewiseConstant2D,
    /// ∫ L dω over the sphere.
    integral: Vec3,
    /// The largest texel value of each channel.
    brightest: Vec3,
}

/// Whether a map black everywhere is an error (a file or texels given: it would light
/// nothing) or allowed (a sky whose sun is its only light).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum BlackMap {
    Refused,
    Allowed,
}

/// A map's texels as a file held them, before the checks.
struct Decoded {
    width: usize,
    height: usize,
    texels: Vec<Vec3>,
    /// A PFM header's scale other than ±1, which multiplied every value (errors say so).
    pfm_scale: Option<f32>,
}

/// What is wrong with texel data: the value found and what was expected. The caller adds
/// the file or the key.
struct Invalid {
    value: String,
    expected: String,
}

impl EnvironmentMap {
    /// Reads .exr (the first layer with R, G and B channels), .pfm (`PF` = RGB, `Pf` =
    /// grey, either byte order, scaled by |scale| as pbrt-v4 reads it) or .hdr (Radiance
    /// RGBE), chosen by the extension, case-insensitive. Errors name the file, what was
    /// wrong and what was expected; a NaN, infinite or negative texel is named by column
    /// and row (row 0 the image's top), and a map black everywhere is refused.
    pub fn load(path: &Path) -> Result<Self> {
        let extension = path
            .extension()
            .map(|e| e.to_string_lossy().to_ascii_lowercase());
        let decoded = match extension.as_deref() {
            Some("exr") => read_exr(path)?,
            Some("pfm") => read_pfm(path)?,
            Some("hdr") => read_hdr(path)?,
            other => {
                let found = match other {
                    Some(e) => format!(
                        "extension .{}",
                        crate::util::escaped_prefix(e.as_bytes(), 8)
                    ),
                    None => "no extension".to_string(),
                };
                return Err(Error::format(
                    path,
                    format!("not an HDR image ({found}): expected .exr, .pfm or .hdr"),
                ));
            }
        };
        let scaled = match decoded.pfm_scale {
            Some(s) => format!(" (the file's values times its header's scale {})", s.abs()),
            None => String::new(),
        };
        Self::build(
            decoded.width,
            decoded.height,
            decoded.texels,
            BlackMap::Refused,
        )
        .map_err(|e| {
            Error::format(
                path,
                format!(
                    "environment map {}{scaled}: expected {}",
                    e.value, e.expected
                ),
            )
        })
    }

    /// Builds from texels in row-major order, row 0 at the top. Refuses (as a parameter
    /// error for `environment`) a zero width or height, a texel count other than
    /// width × height, a NaN, infinite, negative or brighter than 1e20 texel, and a map
    /// black everywhere.
    pub fn from_texels(width: usize, height: usize, texels: Vec<Vec3>) -> Result<Self> {
        Self::build(width, height, texels, BlackMap::Refused)
            .map_err(|e| Error::parameter("environment", e.value, e.expected))
    }

    /// A procedural sky's bake: as [`Self::from_texels`], but black everywhere is allowed
    /// (a sky lit by its sun alone); such a map is never sampled and has pdf 0.
    pub(crate) fn sky(width: usize, height: usize, texels: Vec<Vec3>) -> Result<Self> {
        Self::build(width, height, texels, BlackMap::Allowed)
            .map_err(|e| Error::parameter("environment", e.value, e.expected))
    }

    /// Texels across (the φ direction).
    pub fn width(&self) -> usize {
        self.width
    }

    /// Texels down (the θ direction; row 0 at the zenith).
    pub fn height(&self) -> usize {
        self.height
    }

    /// The texels in row-major order, row 0 at the top.
    pub fn texels(&self) -> &[Vec3] {
        &self.texels
    }

    /// Radiance arriving from local direction `d` (nearest texel: piecewise constant, as
    /// pbrt-v4's ImageInfiniteLight looks up, so the sampling pdf is exactly proportional
    /// to it). `d` need not be normalised.
    pub fn eval(&self, d: Vec3) -> Vec3 {
        self.texels[self.texel_of(d)]
    }

    /// Samples a local direction with pdf ∝ mean(RGB) of the texel over the sphere: picks a
    /// texel from the 2-D piecewise-constant distribution (marginal over rows, conditional
    /// over columns; binary search on CDFs), then a point uniform in φ and uniform in cos θ
    /// within the texel, so the solid-angle pdf is constant inside a texel. Returns
    /// (direction, solid-angle pdf, radiance eval(direction)), or None if the map is black.
    ///
    /// `u` is clamped into [0, 1) (a NaN reads as 0). Each coordinate's position inside the
    /// chosen CDF interval becomes the position inside the texel, so stratified `u` stay
    /// stratified on the sphere.
    pub fn sample(&self, u: [f32; 2]) -> Option<(Vec3, f32, Vec3)> {
        let (row, f_row, column, f_column) =
            self.distribution.sample([u[0] as f64, u[1] as f64])?;
        let chosen = row * self.width + column;
        let mut d = self.texel_point(row, f_row, column, f_column);
        if self.texel_of(d) != chosen {
            // Rounding carried a point on the texel's edge into its neighbour (which may be
            // black). This has probability ~1e-7 and moves no measurable mass; the texel's
            // centre is inside it by half a texel.
            d = self.texel_point(row, 0.5, column, 0.5);
        }
        // Looked up again so that the returned pdf and radiance are exactly pdf(d), eval(d).
        let index = self.texel_of(d);
        debug_assert_eq!(index, chosen, "texel centre must map back to its texel");
        Some((d, self.texel_pdf(index), self.texels[index]))
    }

    /// The solid-angle pdf with which `sample` returns `d` (0 where a texel is black).
    pub fn pdf(&self, d: Vec3) -> f32 {
        self.texel_pdf(self.texel_of(d))
    }

    /// ∫ L dω over the sphere, exact for the piecewise-constant map: Σ texel ·
    /// (2π/W)·(cos θ_top − cos θ_bottom).
    pub fn integral(&self) -> Vec3 {
        self.integral
    }

    /// The largest value of each channel over the texels.
    pub fn brightest(&self) -> Vec3 {
        self.brightest
    }

    /// Validates the texels and builds the sampling distribution.
    fn build(
        width: usize,
        height: usize,
        texels: Vec<Vec3>,
        black: BlackMap,
    ) -> std::result::Result<Self, Invalid> {
        check_texels(width, height, &texels)?;
        let mut integral = DVec3::ZERO;
        let mut brightest = Vec3::ZERO;
        for (row, texels) in texels.chunks_exact(width).enumerate() {
            let omega = texel_solid_angle(row, width, height);
            let mut sum = DVec3::ZERO;
            for &t in texels {
                sum += t.as_dvec3();
                brightest = brightest.max(t);
            }
            integral += sum * omega;
        }
        // Summed in f64 (the toolkit's sums): a large map's would lose its small texels in
        // f32.
        let distribution = PiecewiseConstant2D::new(width, height, |row, column| {
            mean_rgb(texels[row * width + column]) * texel_solid_angle(row, width, height)
        });
        if distribution.total() <= 0.0 && black == BlackMap::Refused {
            return Err(Invalid {
                value: "is black everywhere".to_string(),
                expected: "at least one texel above zero (an environment map that emits \
                           nothing lights nothing)"
                    .to_string(),
            });
        }
        Ok(EnvironmentMap {
            width,
            height,
            texels,
            distribution,
            integral: integral.as_vec3(),
            brightest,
        })
    }

    /// The index of the texel holding direction `d`.
    fn texel_of(&self, d: Vec3) -> usize {
        let (u, v) = direction_to_uv(d);
        // `as usize` saturates (a NaN gives 0), and the clamp keeps u = 1, v = 1 inside.
        let column = ((u * self.width as f64) as usize).min(self.width - 1);
        let row = ((v * self.height as f64) as usize).min(self.height - 1);
        row * self.width + column
    }

    /// The solid-angle pdf inside texel `index`: its weight mean·Ω over the total, divided
    /// by its solid angle Ω.
    fn texel_pdf(&self, index: usize) -> f32 {
        let total = self.distribution.total();
        if total <= 0.0 {
            return 0.0;
        }
        (mean_rgb(self.texels[index]) / total) as f32
    }

    /// The direction at fraction `f_row` of the way down texel row `row` in cos θ and
    /// `f_column` of the way across column `column` in φ.
    fn texel_point(&self, row: usize, f_row: f64, column: usize, f_column: f64) -> Vec3 {
        let (cos_top, band) = row_band(row, self.height);
        // In f64: near the poles a row spans less in cos θ than f32 resolves near 1.
        let cos_theta = (cos_top - f_row * band).clamp(-1.0, 1.0);
        let sin_theta = ((1.0 - cos_theta) * (1.0 + cos_theta)).max(0.0).sqrt();
        let phi = std::f64::consts::TAU * (column as f64 + f_column) / self.width as f64;
        Vec3::new(
            (sin_theta * phi.sin()) as f32,
            cos_theta as f32,
            (-sin_theta * phi.cos()) as f32,
        )
    }
}

/// Checks the size and every texel; the first bad texel is named by column and row.
fn check_texels(width: usize, height: usize, texels: &[Vec3]) -> std::result::Result<(), Invalid> {
    if width == 0 || height == 0 {
        return Err(Invalid {
            value: format!("is {width}×{height} texels"),
            expected: "a width and height of at least 1".to_string(),
        });
    }
    if width.checked_mul(height) != Some(texels.len()) {
        return Err(Invalid {
            value: format!("has {} texels for {width}×{height}", texels.len()),
            expected: format!(
                "width × height = {} texels, row-major with row 0 at the top",
                width as u128 * height as u128
            ),
        });
    }
    let bad = texels.iter().position(|t| {
        !t.is_finite() || t.cmplt(Vec3::ZERO).any() || t.max_element() > MAX_INTENSITY
    });
    if let Some(i) = bad {
        let t = texels[i];
        return Err(Invalid {
            value: format!(
                "texel (column {}, row {}) = ({}, {}, {})",
                i % width,
                i / width,
                t.x,
                t.y,
                t.z
            ),
            expected: TEXEL_EXPECTED.to_string(),
        });
    }
    Ok(())
}

/// mean(r, g, b) in f64, so that three large texel values cannot overflow.
fn mean_rgb(t: Vec3) -> f64 {
    (t.x as f64 + t.y as f64 + t.z as f64) / 3.0
}

/// Row `row`'s cos θ at its top edge and cos θ_top − cos θ_bottom. The difference is taken
/// as 2 sin(θ_mid) sin(Δθ/2): subtracting two cosines near 1 would cancel at the poles.
fn row_band(row: usize, height: usize) -> (f64, f64) {
    let pi = std::f64::consts::PI;
    let h = height as f64;
    let cos_top = (pi * row as f64 / h).cos();
    let band = 2.0 * (pi * (row as f64 + 0.5) / h).sin() * (pi / (2.0 * h)).sin();
    (cos_top, band)
}

/// The solid angle of one texel of row `row`: (2π/W)·(cos θ_top − cos θ_bottom).
fn texel_solid_angle(row: usize, width: usize, height: usize) -> f64 {
    std::f64::consts::TAU / width as f64 * row_band(row, height).1
}

/// Direction → (u, v) in [0, 1) × [0, 1] (the module's convention; `d` need not be unit).
fn direction_to_uv(d: Vec3) -> (f64, f64) {
    let d = d.as_dvec3();
    let mut u = d.x.atan2(-d.z) / std::f64::consts::TAU;
    if u < 0.0 {
        u += 1.0;
    }
    // Just left of the seam atan2 gives −tiny, and −tiny + 1 rounds to 1: the last column.
    // (`min` also turns a NaN into that column rather than panicking later.)
    let u = u.min(ONE_BELOW);
    // acos(d.y) loses precision near the poles, where a row of a tall map spans less than
    // f32 resolves in cos θ; atan2 of the horizontal length is accurate everywhere and
    // equals acos(d.y) for a unit d.
    let v = d.x.hypot(d.z).atan2(d.y) / std::f64::consts::PI;
    (u, v)
}

/// Refuses, from its header, a map with more texels than [`MAX_TEXELS`] or than half the
/// machine's available memory holds at [`BYTES_PER_TEXEL`], before anything is allocated.
fn check_texel_count(path: &Path, width: usize, height: usize) -> Result<()> {
    let fits = memory_budget_bytes() / BYTES_PER_TEXEL;
    let texels = (width as u128) * (height as u128);
    if texels <= MAX_TEXELS as u128 && texels <= fits as u128 {
        return Ok(());
    }
    Err(Error::format(
        path,
        format!(
            "environment map is {width}×{height} texels: expected at most {MAX_TEXELS} (16384 × 8192){}",
            if (fits as u128) < texels {
                format!(
                    " and at most {fits} here ({} a texel within half of this machine's available memory, {})",
                    byte_size(BYTES_PER_TEXEL),
                    byte_size(memory_budget_bytes())
                )
            } else {
                String::new()
            }
        ),
    ))
}

/// A file longer than its header's size can need is refused before it is read.
fn check_length(
    path: &Path,
    length: u64,
    most: Option<u64>,
    width: usize,
    height: usize,
) -> Result<()> {
    match most {
        Some(most) if length <= most => Ok(()),
        _ => Err(Error::format(
            path,
            format!(
                "{length} bytes is more than a {width}×{height} map can take ({}); is this the right file?",
                most.map_or("beyond any file".to_string(), |m| format!(
                    "at most {m} bytes"
                ))
            ),
        )),
    }
}

/// A reader that reads as ended after its allowance, which its owner can raise once a
/// header has said how much is to come: no corrupt header can make a reader read a
/// long file whole (Radiance's header lines, for one, are read until a newline).
struct Allowance<'a, R> {
    inner: R,
    left: &'a Cell<u64>,
}

impl<R: Read> Read for Allowance<'_, R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let n = (buf.len() as u64).min(self.left.get()) as usize;
        if n == 0 {
            return Ok(0);
        }
        let got = self.inner.read(&mut buf[..n])?;
        self.left.set(self.left.get() - got as u64);
        Ok(got)
    }
}

/// Reads the first OpenEXR layer with R, G and B channels (A, if any, is ignored); row 0
/// is the image's top, as OpenEXR's y grows downwards. The headers are read first: a
/// layer too large, or a file longer than its layers can take, is refused before any
/// pixel is read.
fn read_exr(path: &Path) -> Result<Decoded> {
    // The reader's builder methods come from the crate's extension traits.
    use exr::prelude::traits::*;
    use std::io::{Seek, SeekFrom};
    type Pixels = (usize, usize, Vec<Vec3>);
    let (file, length) = open_regular(path, "environment map (OpenEXR)")?;
    let bad = |e: exr::error::Error| {
        Error::format(
            path,
            format!(
                "reading OpenEXR: {} (expected an image with R, G and B channels)",
                decoder_message(&e.to_string())
            ),
        )
    };
    let left = Cell::new(HEADER_CAP);
    let reader = Allowance {
        inner: std::io::BufReader::new(&file),
        left: &left,
    };
    let meta = exr::meta::MetaData::read_from_buffered(reader, false).map_err(bad)?;
    let mut most = Some(HEADER_CAP);
    for header in meta.headers.iter() {
        let (w, h) = (header.layer_size.width(), header.layer_size.height());
        check_texel_count(path, w, h)?;
        // Generous for any compression, mip levels and tiles of one pixel (each chunk's
        // offset, coordinates and size take under 64 bytes).
        let per_texel = 4 * header.channels.bytes_per_pixel as u64 + 64;
        most = most.and_then(|m| m.checked_add((w as u64 * h as u64).checked_mul(per_texel)?));
    }
    if let Some(first) = meta.headers.first() {
        let size = first.layer_size;
        check_length(path, length, most, size.width(), size.height())?;
    }
    (&file)
        .seek(SeekFrom::Start(0))
        .map_err(|e| Error::io(path, e))?;
    let image = exr::prelude::read()
        .no_deep_data()
        .largest_resolution_level()
        .rgba_channels(
            |size, _| {
                let (w, h) = (size.width(), size.height());
                // Every layer's size was checked above; this only guards the allocation.
                let n = w.checked_mul(h).filter(|&n| n <= MAX_TEXELS).unwrap_or(0);
                (w, h, vec![Vec3::ZERO; n])
            },
            |pixels: &mut Pixels,
             at: exr::math::Vec2<usize>,
             (r, g, b, _): (f32, f32, f32, f32)| {
                if let Some(p) = pixels.2.get_mut(at.y() * pixels.0 + at.x()) {
                    *p = Vec3::new(r, g, b);
                }
            },
        )
        .first_valid_layer()
        .all_attributes()
        .from_unbuffered(&file)
        .map_err(bad)?;
    let (width, height, texels) = image.layer_data.channel_data.pixels;
    check_texel_count(path, width, height)?;
    Ok(Decoded {
        width,
        height,
        texels,
        pfm_scale: None,
    })
}

/// Reads a Radiance RGBE (.hdr) image, top row first: its header first (at most
/// [`HEADER_CAP`] bytes), then, once its size is known to fit and the file not to be
/// longer than such a map can take, its scan lines straight into the texels.
fn read_hdr(path: &Path) -> Result<Decoded> {
    use image::ImageDecoder as _;
    let (file, length) = open_regular(path, "environment map (Radiance .hdr)")?;
    let bad = |e: image::ImageError| hdr_error(path, e);
    let left = Cell::new(HEADER_CAP);
    let reader = Allowance {
        inner: std::io::BufReader::new(file),
        left: &left,
    };
    let decoder = image::codecs::hdr::HdrDecoder::new(reader).map_err(bad)?;
    let (w, h) = decoder.dimensions();
    let (width, height) = (w as usize, h as usize);
    check_texel_count(path, width, height)?;
    // A scan line takes at most 4 bytes a texel flat, or 4 + 4·(W + ⌈W/128⌉) run-length
    // encoded; 8 + 8·W covers both.
    let most = (height as u64)
        .checked_mul(8 + 8 * width as u64)
        .and_then(|p| p.checked_add(HEADER_CAP));
    check_length(path, length, most, width, height)?;
    left.set(most.unwrap_or(0));
    let mut texels = vec![Vec3::ZERO; width * height];
    // The decoder writes each texel as three native-endian f32, which is a Vec3's layout.
    decoder
        .read_image(bytemuck::cast_slice_mut(&mut texels))
        .map_err(bad)?;
    Ok(Decoded {
        width,
        height,
        texels,
        pfm_scale: None,
    })
}

/// The Radiance reader's error. Its "unsupported" errors quote the header's `FORMAT` value
/// (20 bytes of a file that may not be a map at all), so they are named, not shown.
fn hdr_error(path: &Path, e: image::ImageError) -> Error {
    let what = match e {
        image::ImageError::Unsupported(_) => {
            "a variant this reader does not take (expected `FORMAT=32-bit_rle_rgbe` and a size line such as `-Y 512 +X 1024`)".to_string()
        }
        other => decoder_message(&other.to_string()),
    };
    Error::format(path, format!("reading Radiance HDR: {what}"))
}

/// A decoder library's message as an error shows it: control characters escaped (a
/// library may quote text from a header), and cut at 200 characters.
fn decoder_message(message: &str) -> String {
    let escaped: String = message
        .chars()
        .flat_map(|c| {
            let shown: Vec<char> = if c.is_control() {
                c.escape_default().collect()
            } else {
                vec![c]
            };
            shown
        })
        .collect();
    match escaped.char_indices().nth(200) {
        Some((at, _)) => format!("{}…", &escaped[..at]),
        None => escaped,
    }
}

/// Reads a PFM file, `PF` (RGB) or `Pf` (grey), with the project's one PFM reader: the
/// header first, its size checked, then the rows.
fn read_pfm(path: &Path) -> Result<Decoded> {
    let (width, height, texels, scale) = read_pfm_bounded(
        path,
        PfmChannels::ColourOrGrey,
        "environment map (PFM)",
        |w, h| check_texel_count(path, w, h),
    )?;
    Ok(Decoded {
        width,
        height,
        texels,
        pfm_scale: (scale.abs() != 1.0).then_some(scale),
    })
}

#[cfg(test)]
mod tests {
    use std::f32::consts::PI;

    use super::*;

    /// The inverse mapping: φ = 2πu, θ = πv, d = (sin θ sin φ, cos θ, −sin θ cos φ).
    fn uv_to_direction(u: f64, v: f64) -> Vec3 {
        let (phi, theta) = (std::f64::consts::TAU * u, std::f64::consts::PI * v);
        Vec3::new(
            (theta.sin() * phi.sin()) as f32,
            theta.cos() as f32,
            (-theta.sin() * phi.cos()) as f32,
        )
    }

    /// Just off the zenith towards −z: row 0, column 0 (u = 0).
    const NEAR_ZENITH: Vec3 = Vec3::new(0.0, 1.0, -1e-3);

    /// A deterministic uniform number in [0, 1) from two integers.
    fn hash01(a: u64, b: u64) -> f32 {
        let mut z = a
            .wrapping_mul(0x9E37_79B9_7F4A_7C15)
            .wrapping_add(b.wrapping_mul(0xBF58_476D_1CE4_E5B9));
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        (z >> 40) as f32 / (1u64 << 24) as f32
    }

    /// 16×8, non-uniform and coloured: one bright texel, a black row, every seventh texel
    /// black, and a pure-red texel (zero green and blue but not black).
    fn test_map() -> EnvironmentMap {
        let (w, h) = (16, 8);
        let mut texels: Vec<Vec3> = (0..w * h)
            .map(|i| {
                let i = i as u64;
                Vec3::new(hash01(i, 1), hash01(i, 2), hash01(i, 3)) + 0.05
            })
            .collect();
        for (i, t) in texels.iter_mut().enumerate() {
            if i % 7 == 3 || i / w == 5 {
                *t = Vec3::ZERO;
            }
        }
        texels[2 * w + 9] = Vec3::new(80.0, 60.0, 40.0);
        texels[6 * w + 1] = Vec3::new(2.0, 0.0, 0.0);
        EnvironmentMap::from_texels(w, h, texels).unwrap()
    }

    fn rel(a: f32, b: f32) -> f32 {
        (a - b).abs() / b.abs().max(1e-30)
    }

    #[test]
    fn directions_round_trip_and_the_zenith_is_row_zero() {
        for i in 0..200 {
            for j in 1..100 {
                let (u, v) = (i as f64 / 200.0 + 0.001, j as f64 / 100.0);
                let d = uv_to_direction(u, v);
                assert!((d.length() - 1.0).abs() < 1e-6);
                let (u2, v2) = direction_to_uv(d);
                assert!(
                    (u2 - u).abs() < 1e-6 && (v2 - v).abs() < 1e-6,
                    "{u} {v} → {u2} {v2}"
                );
            }
        }
        // The convention's anchor points: +y is v = 0, −z is u = 0, +x is u = 1/4.
        assert_eq!(direction_to_uv(Vec3::Y).1, 0.0);
        assert_eq!(direction_to_uv(Vec3::NEG_Y).1, 1.0);
        assert!(direction_to_uv(Vec3::NEG_Z).0.abs() < 1e-12);
        assert!((direction_to_uv(Vec3::X).0 - 0.25).abs() < 1e-12);
        assert!((direction_to_uv(Vec3::Z).0 - 0.5).abs() < 1e-12);
        // Just left of the seam stays in [0, 1).
        let (u, _) = direction_to_uv(Vec3::new(-1e-30, 0.0, -1.0));
        assert!((0.0..1.0).contains(&u), "{u}");

        let (w, h) = (8, 4);
        let texels = (0..w * h).map(|i| Vec3::splat(i as f32 + 1.0)).collect();
        let map = EnvironmentMap::from_texels(w, h, texels).unwrap();
        assert_eq!(map.eval(NEAR_ZENITH), Vec3::splat(1.0), "row 0, column 0");
        // At the pole itself atan2(0, −0) = π: row 0, column W/2, as in Mitsuba.
        assert_eq!(map.eval(Vec3::Y), Vec3::splat(5.0), "zenith → row 0");
        assert_eq!(
            map.eval(Vec3::new(0.1, 1.0, 0.02)).x,
            3.0,
            "row 0, column 2"
        );
        assert_eq!(
            map.eval(Vec3::NEG_Y).x,
            (w * (h - 1) + 5) as f32,
            "nadir → last row"
        );
        assert_eq!(map.eval(Vec3::new(-0.01, 0.1, -1.0)).x, (w + w) as f32);
        // Unnormalised and degenerate directions never panic.
        assert_eq!(map.eval(NEAR_ZENITH * 5.0), Vec3::splat(1.0));
        let _ = map.eval(Vec3::ZERO);
        let _ = map.eval(Vec3::NAN);
    }

    #[test]
    fn integral_of_constant_and_top_half_maps() {
        let c = Vec3::new(0.5, 2.0, 3.0);
        let map = EnvironmentMap::from_texels(7, 5, vec![c; 35]).unwrap();
        let want = 4.0 * PI * c;
        for k in 0..3 {
            assert!(rel(map.integral()[k], want[k]) < 1e-5, "{}", map.integral());
        }
        let (w, h) = (6, 10);
        let texels = (0..w * h)
            .map(|i| if i / w < h / 2 { Vec3::ONE } else { Vec3::ZERO })
            .collect();
        let map = EnvironmentMap::from_texels(w, h, texels).unwrap();
        assert!(rel(map.integral().x, 2.0 * PI) < 1e-5, "{}", map.integral());
        // The lower hemisphere is black: never sampled, pdf 0 there.
        assert_eq!(map.pdf(Vec3::NEG_Y), 0.0);
        assert!((map.pdf(Vec3::Y) - 1.0 / (2.0 * PI)).abs() < 1e-6);
    }

    #[test]
    fn samples_agree_with_pdf_and_eval_and_estimate_the_integral() {
        let map = test_map();
        let n = 400;
        let mut sum = DVec3::ZERO;
        for i in 0..n {
            for j in 0..n {
                let u = [
                    (i as f32 + hash01(i, j)) / n as f32,
                    (j as f32 + hash01(j, i + 7)) / n as f32,
                ];
                let (d, pdf, radiance) = map.sample(u).expect("the map is not black");
                assert!(d.is_finite() && (d.length() - 1.0).abs() < 1e-5, "{d}");
                assert!(
                    pdf > 0.0 && radiance != Vec3::ZERO,
                    "a black texel was sampled"
                );
                assert_eq!(pdf, map.pdf(d));
                assert_eq!(radiance, map.eval(d));
                sum += (radiance / pdf).as_dvec3();
            }
        }
        let estimate = (sum / (n * n) as f64).as_vec3();
        for k in 0..3 {
            assert!(
                rel(estimate[k], map.integral()[k]) < 0.02,
                "{estimate} vs {}",
                map.integral()
            );
        }
    }

    #[test]
    fn a_grey_map_samples_with_zero_variance() {
        let (w, h) = (16, 8);
        let texels: Vec<Vec3> = (0..w * h)
            .map(|i| match i % 5 {
                0 => Vec3::ZERO,
                _ => Vec3::splat(hash01(i as u64, 9) * 10.0),
            })
            .collect();
        let map = EnvironmentMap::from_texels(w, h, texels).unwrap();
        let total = map.integral().x;
        for i in 0..100_000u64 {
            let (_, pdf, radiance) = map.sample([hash01(i, 1), hash01(i, 2)]).unwrap();
            assert!(
                rel(radiance.x / pdf, total) < 1e-3,
                "{} vs {total}",
                radiance.x / pdf
            );
        }
    }

    #[test]
    fn pdf_integrates_to_one() {
        let map = test_map();
        // Midpoint rule in (φ, cos θ), where dω = dφ d(cos θ).
        let n = 1000;
        let mut sum = 0.0f64;
        for i in 0..n {
            for j in 0..n {
                let phi = 2.0 * PI * (i as f32 + 0.5) / n as f32;
                let z = 1.0 - 2.0 * (j as f32 + 0.5) / n as f32;
                let s = (1.0 - z * z).max(0.0).sqrt();
                let d = Vec3::new(s * phi.sin(), z, -s * phi.cos());
                sum += map.pdf(d) as f64;
            }
        }
        let integral = sum * 4.0 * std::f64::consts::PI / (n * n) as f64;
        assert!((integral - 1.0).abs() < 0.01, "∫ pdf dω = {integral}");
    }

    #[test]
    fn sampling_is_robust_at_the_ends_and_near_the_poles() {
        let map = test_map();
        for u in [
            [0.0, 0.0],
            [1.0, 1.0],
            [f32::NAN, 0.5],
            [0.999_999_94, 0.999_999_94],
            [-3.0, 7.0],
        ] {
            let (d, pdf, radiance) = map.sample(u).unwrap();
            assert!(
                d.is_finite() && pdf > 0.0 && radiance != Vec3::ZERO,
                "{u:?}"
            );
            assert_eq!(pdf, map.pdf(d));
        }
        // A tall map lit only in its top and bottom rows: the rows span ~1e-7 in cos θ,
        // less than f32 resolves near 1, and must still be hit exactly.
        let (w, h) = (4, 8192);
        let mut texels = vec![Vec3::ZERO; w * h];
        texels[1] = Vec3::ONE;
        texels[w * h - 2] = Vec3::splat(3.0);
        let map = EnvironmentMap::from_texels(w, h, texels).unwrap();
        // The ends of [0, 1) land on black texels' CDF entries: they must be skipped.
        let ends = [[0.0, 0.0], [0.0, 1.0], [1.0, 0.0], [1.0, 1.0]];
        let random = (0..10_000u64).map(|i| [hash01(i, 3), hash01(i, 4)]);
        for u in ends.into_iter().chain(random) {
            let (d, pdf, radiance) = map.sample(u).unwrap();
            assert!(radiance != Vec3::ZERO && pdf == map.pdf(d), "{d}");
            assert!(rel(radiance.x / pdf, map.integral().x) < 1e-3);
        }
    }

    /// A PFM file by hand: `rows` top row first, written bottom row first.
    fn pfm_bytes(kind: &str, w: usize, scale: &str, big: bool, rows: &[f32]) -> Vec<u8> {
        let channels = if kind == "PF" { 3 } else { 1 };
        let h = rows.len() / (w * channels);
        let mut bytes = format!("{kind}\n{w} {h}\n{scale}\n").into_bytes();
        for row in (0..h).rev() {
            for &v in &rows[row * w * channels..(row + 1) * w * channels] {
                bytes.extend(if big {
                    v.to_be_bytes()
                } else {
                    v.to_le_bytes()
                });
            }
        }
        bytes
    }

    fn ramp(w: usize, h: usize) -> Vec<Vec3> {
        (0..w * h)
            .map(|i| {
                Vec3::new(
                    i as f32 + 0.5,
                    2.0 * (i / w) as f32 + 0.25,
                    1.0 / (i + 1) as f32,
                )
            })
            .collect()
    }

    #[test]
    fn pfm_files_round_trip_with_row_zero_on_top() {
        let dir = tempfile::tempdir().unwrap();
        let (w, h) = (5, 3);
        let texels = ramp(w, h);
        let path = dir.path().join("project.pfm");
        crate::util::write_pfm(&path, w, h, &texels).unwrap();
        let map = EnvironmentMap::load(&path).unwrap();
        assert_eq!(
            (map.width(), map.height(), map.texels()),
            (w, h, &texels[..])
        );
        assert_eq!(
            map.eval(NEAR_ZENITH),
            texels[0],
            "row 0 is the file's top row"
        );

        let flat: Vec<f32> = texels.iter().flat_map(|t| t.to_array()).collect();
        for (big, scale, name) in [(true, "1.0", "big.PFM"), (false, "-1", "little.pfm")] {
            let path = dir.path().join(name);
            std::fs::write(&path, pfm_bytes("PF", w, scale, big, &flat)).unwrap();
            assert_eq!(
                EnvironmentMap::load(&path).unwrap().texels(),
                &texels[..],
                "{name}"
            );
        }
        // Grey, scaled by |scale| as pbrt-v4 reads it.
        let grey: Vec<f32> = (0..w * h).map(|i| i as f32).collect();
        let path = dir.path().join("grey.pfm");
        std::fs::write(&path, pfm_bytes("Pf", w, "2.0", true, &grey)).unwrap();
        let map = EnvironmentMap::load(&path).unwrap();
        let want: Vec<Vec3> = grey.iter().map(|&g| Vec3::splat(2.0 * g)).collect();
        assert_eq!(map.texels(), &want[..]);
    }

    #[test]
    fn exr_files_round_trip_with_row_zero_on_top() {
        let dir = tempfile::tempdir().unwrap();
        let (w, h) = (6, 4);
        let texels = ramp(w, h);
        let path = dir.path().join("sky.EXR");
        exr::prelude::write_rgb_file(&path, w, h, |x, y| {
            let t = texels[y * w + x];
            (t.x, t.y, t.z)
        })
        .unwrap();
        let map = EnvironmentMap::load(&path).unwrap();
        assert_eq!(
            (map.width(), map.height(), map.texels()),
            (w, h, &texels[..])
        );
        assert_eq!(
            map.eval(NEAR_ZENITH),
            texels[0],
            "row 0 is the image's top row"
        );
    }

    #[test]
    fn hdr_files_round_trip_within_rgbe_precision() {
        let dir = tempfile::tempdir().unwrap();
        let (w, h) = (6, 4);
        let texels = ramp(w, h);
        let path = dir.path().join("sky.hdr");
        let rgb: Vec<image::Rgb<f32>> = texels.iter().map(|t| image::Rgb(t.to_array())).collect();
        let file = std::io::BufWriter::new(std::fs::File::create(&path).unwrap());
        image::codecs::hdr::HdrEncoder::new(file)
            .encode(&rgb, w, h)
            .unwrap();
        let map = EnvironmentMap::load(&path).unwrap();
        assert_eq!((map.width(), map.height()), (w, h));
        for (got, want) in map.texels().iter().zip(&texels) {
            // RGBE shares one exponent: each channel is exact to ~1 % of the largest.
            assert!(
                (*got - *want).abs().max_element() <= 0.01 * want.max_element(),
                "{got} vs {want}"
            );
        }
        assert!(
            rel(map.eval(NEAR_ZENITH).x, texels[0].x) < 0.01,
            "row 0 is the image's top row"
        );
        assert!(rel(map.eval(Vec3::new(0.0, -1.0, -1e-3)).x, texels[w * h - w].x) < 0.01);
    }

    #[test]
    fn errors_name_the_file_and_what_was_expected() {
        let dir = tempfile::tempdir().unwrap();
        let message = |name: &str, bytes: &[u8]| {
            let path = dir.path().join(name);
            std::fs::write(&path, bytes).unwrap();
            let e = EnvironmentMap::load(&path).unwrap_err().to_string();
            assert!(e.contains(name), "{e} should name the file");
            e
        };
        let e = message("sky.png", b"\x89PNG");
        assert!(
            e.contains("not an HDR image") && e.contains(".exr, .pfm or .hdr"),
            "{e}"
        );
        let e = message("truncated.pfm", b"PF\n2 2\n-1.0\n\0\0\0\0");
        assert!(e.contains("4 bytes of pixels, expected 48"), "{e}");
        let e = message("header.pfm", b"PF\n2");
        assert!(e.contains("header"), "{e}");
        let e = message("kind.pfm", b"P6\n2 2\n-1.0\n");
        assert!(e.contains("`PF` (RGB) or `Pf` (grey)"), "{e}");

        let mut rows = vec![1.0f32; 3 * 4 * 2];
        rows[3 * (4 + 2) + 1] = f32::NAN; // top-first row 1, column 2, green
        let e = message("nan.pfm", &pfm_bytes("PF", 4, "-1", false, &rows));
        assert!(e.contains("texel (column 2, row 1) = (1, NaN, 1)"), "{e}");
        assert!(e.contains("finite, non-negative"), "{e}");
        let e = message("black.pfm", &pfm_bytes("Pf", 2, "-1", false, &[0.0; 4]));
        assert!(e.contains("emits nothing"), "{e}");
        let e = message("corrupt.exr", b"v/1\x01 not an exr");
        assert!(e.contains("OpenEXR"), "{e}");
        let e = message("corrupt.hdr", b"#?RADIANCE\nnonsense");
        assert!(e.contains("Radiance HDR"), "{e}");
        let missing = dir.path().join("missing.hdr");
        let e = EnvironmentMap::load(&missing).unwrap_err().to_string();
        assert!(e.contains("missing.hdr"), "{e}");

        let param = |w, h, texels: Vec<Vec3>| {
            EnvironmentMap::from_texels(w, h, texels)
                .unwrap_err()
                .to_string()
        };
        let e = param(2, 2, vec![Vec3::ZERO; 4]);
        assert!(
            e.contains("`environment`") && e.contains("emits nothing"),
            "{e}"
        );
        let e = param(0, 2, vec![]);
        assert!(e.contains("0×2") && e.contains("at least 1"), "{e}");
        let e = param(2, 2, vec![Vec3::ONE; 3]);
        assert!(e.contains("3 texels") && e.contains("= 4 texels"), "{e}");
        let mut texels = vec![Vec3::ONE; 6];
        texels[5] = Vec3::new(1.0, -2.0, 1.0);
        let e = param(3, 2, texels);
        assert!(e.contains("(column 2, row 1) = (1, -2, 1)"), "{e}");
        let mut texels = vec![Vec3::ONE; 6];
        texels[0].z = f32::INFINITY;
        assert!(param(3, 2, texels).contains("(column 0, row 0) = (1, 1, inf)"));
    }
}
