//! Image figures: labelled contact sheets and difference images.
//!
//! Difference images come in two forms: a signed colour map (blue = darker, red = brighter
//! than the image compared against, white = equal; the scale is printed), and the thesis's
//! brightness-amplified difference (Fig. 18): `gain · |a − b|`, tone mapped, with the gain
//! printed on the image.

use std::path::Path;

use anyhow::Result;
use glam::Vec3;
use volphot::{to_srgb8, write_png_rgb8};

/// An 8-bit RGB image.
#[derive(Debug, Clone)]
pub(crate) struct Rgb8 {
    /// Width.
    pub(crate) width: usize,
    /// Height.
    pub(crate) height: usize,
    /// Packed RGB, row-major.
    pub(crate) data: Vec<u8>,
}

impl Rgb8 {
    /// A filled image.
    pub(crate) fn filled(width: usize, height: usize, colour: [u8; 3]) -> Self {
        Rgb8 {
            width,
            height,
            data: colour
                .iter()
                .copied()
                .cycle()
                .take(width * height * 3)
                .collect(),
        }
    }

    /// Reads a PNG.
    pub(crate) fn read_png(path: &Path) -> Result<Self> {
        let img = image::open(path)
            .map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?
            .into_rgb8();
        Ok(Rgb8 {
            width: img.width() as usize,
            height: img.height() as usize,
            data: img.into_raw(),
        })
    }

    /// Writes a PNG atomically.
    pub(crate) fn write_png(&self, path: &Path) -> Result<()> {
        Ok(write_png_rgb8(path, self.width, self.height, &self.data)?)
    }

    /// Copies `other` with its top-left corner at `(x, y)`.
    pub(crate) fn paste(&mut self, other: &Rgb8, x: usize, y: usize) {
        for row in 0..other.height {
            let ty = y + row;
            if ty >= self.height {
                break;
            }
            let n = other.width.min(self.width.saturating_sub(x));
            let src = &other.data[row * other.width * 3..row * other.width * 3 + n * 3];
            let start = (ty * self.width + x) * 3;
            self.data[start..start + n * 3].copy_from_slice(src);
        }
    }

    /// Draws text with its top-left at `(x, y)`, `px` pixels tall, on a translucent box.
    pub(crate) fn text(&mut self, text: &str, x: f32, y: f32, px: f32, colour: [u8; 3]) {
        use ab_glyph::{Font, FontRef, ScaleFont};
        let font = FontRef::try_from_slice(ttf_noto_sans::REGULAR).expect("embedded font parses");
        let scaled = font.as_scaled(px);
        let width: f32 = text
            .chars()
            .map(|c| scaled.h_advance(scaled.glyph_id(c)))
            .sum();
        // Darken a box behind the text so labels stay legible on bright images.
        let (x0, y0) = (x.max(0.0) as usize, y.max(0.0) as usize);
        let (x1, y1) = (
            ((x + width + 4.0) as usize).min(self.width),
            ((y + px * 1.25) as usize).min(self.height),
        );
        for yy in y0..y1 {
            for xx in x0..x1 {
                let i = (yy * self.width + xx) * 3;
                for c in 0..3 {
                    self.data[i + c] /= 3;
                }
            }
        }
        let baseline = y + scaled.ascent();
        let mut caret = x + 2.0;
        let mut previous = None;
        for ch in text.chars() {
            let id = scaled.glyph_id(ch);
            if let Some(p) = previous {
                caret += scaled.kern(p, id);
            }
            let glyph = id.with_scale_and_position(px, ab_glyph::point(caret, baseline));
            caret += scaled.h_advance(id);
            previous = Some(id);
            if let Some(outline) = font.outline_glyph(glyph) {
                let bounds = outline.px_bounds();
                outline.draw(|gx, gy, coverage| {
                    let px_x = bounds.min.x as i64 + gx as i64;
                    let px_y = bounds.min.y as i64 + gy as i64;
                    if px_x < 0
                        || px_y < 0
                        || px_x >= self.width as i64
                        || px_y >= self.height as i64
                    {
                        return;
                    }
                    let i = (px_y as usize * self.width + px_x as usize) * 3;
                    let a = coverage.clamp(0.0, 1.0);
                    for (d, &c) in self.data[i..i + 3].iter_mut().zip(&colour) {
                        *d = (*d as f32 * (1.0 - a) + c as f32 * a).round() as u8;
                    }
                });
            }
        }
    }
}

/// A number with three significant digits (`0.0123`, `12.3`, `1.23e5`).
pub(crate) fn sig3(v: f32) -> String {
    if v == 0.0 || !v.is_finite() {
        return format!("{v}");
    }
    let digits = 2 - v.abs().log10().floor() as i32;
    if (-2..=6).contains(&digits) {
        format!("{:.*}", digits.max(0) as usize, v)
    } else {
        format!("{v:.2e}")
    }
}

/// One tile of a contact sheet.
pub(crate) struct Tile {
    /// The image (may be missing: drawn as a grey placeholder).
    pub(crate) image: Option<Rgb8>,
    /// Caption drawn on the tile.
    pub(crate) caption: String,
}

/// Lays tiles out in `cols` columns with a title bar and row/column captions on the tiles.
pub(crate) fn contact_sheet(title: &str, tiles: &[Tile], cols: usize, tile_size: usize) -> Rgb8 {
    let cols = cols.max(1);
    let rows = tiles.len().div_ceil(cols);
    let gap = 4;
    let header = 34;
    let width = cols * (tile_size + gap) + gap;
    let height = header + rows * (tile_size + gap) + gap;
    let mut sheet = Rgb8::filled(width, height, [24, 24, 24]);
    sheet.text(title, 6.0, 6.0, 20.0, [255, 255, 255]);
    for (i, tile) in tiles.iter().enumerate() {
        let (r, c) = (i / cols, i % cols);
        let (x, y) = (
            gap + c * (tile_size + gap),
            header + gap + r * (tile_size + gap),
        );
        let img = match &tile.image {
            Some(img) => resize(img, tile_size, tile_size),
            None => {
                let mut p = Rgb8::filled(tile_size, tile_size, [70, 70, 70]);
                p.text(
                    "missing",
                    8.0,
                    tile_size as f32 / 2.0 - 8.0,
                    16.0,
                    [255, 200, 200],
                );
                p
            }
        };
        sheet.paste(&img, x, y);
        let px = (tile_size as f32 / 16.0).clamp(11.0, 16.0);
        sheet.text(
            &tile.caption,
            (x + 2) as f32,
            (y + 2) as f32,
            px,
            [255, 255, 160],
        );
    }
    sheet
}

/// Resizes (bilinear via `image`).
pub(crate) fn resize(img: &Rgb8, width: usize, height: usize) -> Rgb8 {
    if img.width == width && img.height == height {
        return img.clone();
    }
    let buffer = image::RgbImage::from_raw(img.width as u32, img.height as u32, img.data.clone())
        .expect("image size");
    let out = image::imageops::resize(
        &buffer,
        width as u32,
        height as u32,
        image::imageops::FilterType::Triangle,
    );
    Rgb8 {
        width,
        height,
        data: out.into_raw(),
    }
}

/// Signed difference `a − b` as a diverging colour map, saturating at ±`scale` (luminance).
pub(crate) fn signed_difference(
    a: &[Vec3],
    b: &[Vec3],
    width: usize,
    height: usize,
    scale: f32,
) -> Rgb8 {
    let data = a
        .iter()
        .zip(b)
        .flat_map(|(x, y)| {
            let d = crate::analyse::luminance(*x - *y) / scale.max(1e-12);
            let t = d.clamp(-1.0, 1.0);
            // white at 0, red for positive, blue for negative.
            let (r, g, bl) = if t >= 0.0 {
                (1.0, 1.0 - t, 1.0 - t)
            } else {
                (1.0 + t, 1.0 + t, 1.0)
            };
            [(r * 255.0) as u8, (g * 255.0) as u8, (bl * 255.0) as u8]
        })
        .collect();
    let mut img = Rgb8 {
        width,
        height,
        data,
    };
    img.text(
        &format!("a − b, red = +{0}, blue = −{0}", sig3(scale)),
        4.0,
        height as f32 - 22.0,
        14.0,
        [255, 255, 255],
    );
    img
}

/// The thesis's brightness-amplified difference: `gain · |a − b|`, tone mapped.
pub(crate) fn amplified_difference(
    a: &[Vec3],
    b: &[Vec3],
    width: usize,
    height: usize,
    gain: f32,
    exposure: f32,
) -> Rgb8 {
    let diff: Vec<Vec3> = a
        .iter()
        .zip(b)
        .map(|(x, y)| (*x - *y).abs() * gain)
        .collect();
    let mut img = Rgb8 {
        width,
        height,
        data: to_srgb8(&diff, exposure),
    };
    img.text(
        &format!("|a − b| × {}", sig3(gain)),
        4.0,
        height as f32 - 22.0,
        14.0,
        [255, 255, 160],
    );
    img
}

/// A gain that maps the 99th percentile of `|a − b|` luminance to 0.8 of full scale
/// (after exposure), so differences are visible but rarely clip.
pub(crate) fn auto_gain(diffs: &[f32], exposure: f32) -> f32 {
    let mut v: Vec<f32> = diffs.iter().copied().filter(|d| *d > 0.0).collect();
    if v.is_empty() {
        return 1.0;
    }
    let k = ((v.len() as f32 * 0.99) as usize).min(v.len() - 1);
    let (_, p99, _) = v.select_nth_unstable_by(k, |a, b| a.total_cmp(b));
    let display = *p99 * 2f32.powf(exposure);
    if display <= 0.0 { 1.0 } else { 0.8 / display }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn amplified_differences_keep_their_colour() {
        // A red-only difference (a colour medium's multiple layer) stays red; the signed map
        // is by luminance (documented), so it only has to be non-white.
        let (w, h) = (40, 40);
        let a = vec![Vec3::new(0.4, 0.0, 0.0); w * h];
        let b = vec![Vec3::ZERO; w * h];
        let img = amplified_difference(&a, &b, w, h, 1.0, 0.0);
        let px = &img.data[..3];
        assert!(px[0] > 100 && px[1] == 0 && px[2] == 0, "{px:?}");
        let signed = signed_difference(&a, &b, w, h, 0.5);
        assert!(
            signed.data[..3] != [255, 255, 255],
            "{:?}",
            &signed.data[..3]
        );
    }

    #[test]
    fn text_changes_pixels_and_paste_places_images() {
        let mut img = Rgb8::filled(120, 40, [0, 0, 0]);
        img.text("nused = 150", 2.0, 2.0, 16.0, [255, 255, 255]);
        assert!(img.data.iter().any(|&v| v > 200), "glyphs drawn");
        let mut sheet = Rgb8::filled(10, 10, [0, 0, 0]);
        sheet.paste(&Rgb8::filled(3, 3, [9, 9, 9]), 2, 2);
        assert_eq!(sheet.data[(2 * 10 + 2) * 3], 9);
        assert_eq!(sheet.data[(10 + 1) * 3], 0);
    }

    #[test]
    fn gain_maps_p99_to_most_of_the_range() {
        let diffs: Vec<f32> = (1..=1000).map(|i| i as f32 / 1000.0).collect();
        let g = auto_gain(&diffs, 0.0);
        assert!((g * 0.99 - 0.8).abs() < 0.01, "{g}");
    }
}
