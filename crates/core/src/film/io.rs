//! Film files: OpenEXR (32-bit float, every layer as `single.R` …, plus `total`, the
//! per-pixel variance of the mean when known, and depth), PNG (exposure + sRGB) and PFM
//! (total, linear). Every file is written atomically.

use std::path::Path;

use glam::Vec3;

use super::{Film, Layer};
use crate::error::{Error, Result};
use crate::util::write_atomic_with;

impl Film {
    /// Writes every layer, `total`, and variance layers (`var_single` …, `var_total`) when
    /// present, as 32-bit float OpenEXR (ZIP, lossless), atomically.
    pub fn write_exr(&self, path: &Path) -> Result<()> {
        use exr::prelude::{
            AnyChannel, AnyChannels, Encoding, FlatSamples, Image, SmallVec, Text, WritableImage,
        };
        let mut list: SmallVec<[AnyChannel<FlatSamples>; 4]> = SmallVec::new();
        let mut push = |name: &str, data: &[Vec3]| {
            for (c, suffix) in ["R", "G", "B"].iter().enumerate() {
                let samples: Vec<f32> = data.iter().map(|v| v[c]).collect();
                list.push(AnyChannel::new(
                    Text::new_or_panic(format!("{name}.{suffix}")),
                    FlatSamples::F32(samples),
                ));
            }
        };
        push("total", &self.total());
        for layer in Layer::ALL {
            push(layer.name(), self.layer(layer));
        }
        if let Some(var) = &self.variance {
            for layer in Layer::ALL {
                push(&format!("var_{}", layer.name()), &var[layer.index()]);
            }
        }
        if let Some(var) = &self.total_variance {
            push("var_total", var);
        }
        if let Some(depth) = &self.depth {
            list.push(AnyChannel::new(
                Text::new_or_panic("depth.Z"),
                FlatSamples::F32(depth.clone()),
            ));
        }
        let image = Image::from_encoded_channels(
            (self.width, self.height),
            Encoding::SMALL_LOSSLESS,
            AnyChannels::sort(list),
        );
        let mut bytes = std::io::Cursor::new(Vec::new());
        image
            .write()
            .to_buffered(&mut bytes)
            .map_err(|e| Error::format(path, format!("writing OpenEXR: {e}")))?;
        crate::util::write_atomic(path, bytes.get_ref())
    }

    /// Reads a film written by [`Film::write_exr`].
    pub fn read_exr(path: &Path) -> Result<Self> {
        let image = exr::prelude::read_all_flat_layers_from_file(path)
            .map_err(|e| Error::format(path, format!("reading OpenEXR: {e}")))?;
        let layer = image
            .layer_data
            .first()
            .ok_or_else(|| Error::format(path, "OpenEXR file has no layers"))?;
        let (width, height) = (layer.size.width(), layer.size.height());
        let n = width * height;
        let mut found: std::collections::HashMap<String, [Vec<f32>; 3]> = Default::default();
        for ch in &layer.channel_data.list {
            let name = ch.name.to_string();
            let Some((lname, comp)) = name.rsplit_once('.') else {
                continue;
            };
            let idx = match comp {
                "R" => 0,
                "G" => 1,
                "B" => 2,
                _ => continue,
            };
            found
                .entry(lname.to_string())
                .or_insert_with(|| [vec![], vec![], vec![]])[idx] =
                ch.sample_data.values_as_f32().collect();
        }
        let take = |name: &str| -> Result<Vec<Vec3>> {
            let rgb = found
                .get(name)
                .ok_or_else(|| Error::format(path, format!("OpenEXR file lacks layer `{name}`")))?;
            if rgb.iter().any(|c| c.len() != n) {
                return Err(Error::format(path, format!("layer `{name}` is incomplete")));
            }
            Ok((0..n)
                .map(|i| Vec3::new(rgb[0][i], rgb[1][i], rgb[2][i]))
                .collect())
        };
        let mut film = Film::from_layers(
            width,
            height,
            [take("single")?, take("multiple")?, take("emission")?],
        );
        if found.contains_key("var_single") {
            film.variance = Some([
                take("var_single")?,
                take("var_multiple")?,
                take("var_emission")?,
            ]);
        }
        if found.contains_key("var_total") {
            film.total_variance = Some(take("var_total")?);
        }
        if let Some(z) = layer
            .channel_data
            .list
            .iter()
            .find(|c| c.name.to_string() == "depth.Z")
        {
            let depth: Vec<f32> = z.sample_data.values_as_f32().collect();
            if depth.len() != n {
                return Err(Error::format(path, "layer `depth` is incomplete"));
            }
            film.depth = Some(depth);
        }
        Ok(film)
    }

    /// Writes the total (linear) as a PFM file.
    pub fn write_pfm(&self, path: &Path) -> Result<()> {
        write_pfm(path, self.width, self.height, &self.total())
    }
}

/// Linear → sRGB-encoded 8-bit after scaling by `2^exposure`.
pub fn to_srgb8(pixels: &[Vec3], exposure: f32) -> Vec<u8> {
    let scale = 2f32.powf(exposure);
    let encode = |v: f32| -> u8 {
        let v = (v * scale).clamp(0.0, 1.0);
        let s = if v <= 0.003_130_8 {
            12.92 * v
        } else {
            1.055 * v.powf(1.0 / 2.4) - 0.055
        };
        (s * 255.0 + 0.5) as u8
    };
    pixels
        .iter()
        .flat_map(|p| [encode(p.x), encode(p.y), encode(p.z)])
        .collect()
}

/// Writes an 8-bit RGB PNG atomically.
pub fn write_png_rgb8(path: &Path, width: usize, height: usize, rgb: &[u8]) -> Result<()> {
    use image::ImageEncoder;
    assert_eq!(rgb.len(), width * height * 3);
    write_atomic_with(path, |w| {
        image::codecs::png::PngEncoder::new_with_quality(
            w,
            image::codecs::png::CompressionType::Best,
            image::codecs::png::FilterType::Adaptive,
        )
        .write_image(
            rgb,
            width as u32,
            height as u32,
            image::ExtendedColorType::Rgb8,
        )
        .map_err(std::io::Error::other)
    })
}

/// Tone maps (exposure + sRGB) and writes a PNG.
pub fn write_png(
    path: &Path,
    width: usize,
    height: usize,
    pixels: &[Vec3],
    exposure: f32,
) -> Result<()> {
    write_png_rgb8(path, width, height, &to_srgb8(pixels, exposure))
}

/// Writes linear RGB as PFM (little-endian, bottom row first as the format requires).
pub fn write_pfm(path: &Path, width: usize, height: usize, pixels: &[Vec3]) -> Result<()> {
    write_atomic_with(path, |w| {
        use std::io::Write;
        write!(w, "PF\n{width} {height}\n-1.0\n")?;
        for y in (0..height).rev() {
            for p in &pixels[y * width..(y + 1) * width] {
                for c in [p.x, p.y, p.z] {
                    w.write_all(&c.to_le_bytes())?;
                }
            }
        }
        Ok(())
    })
}

/// Reads a colour PFM (`PF`, either byte order, bottom row first) as top-row-first RGB:
/// `(width, height, pixels)`.
pub fn read_pfm(path: &Path) -> Result<(usize, usize, Vec<Vec3>)> {
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    decode_pfm(path, &bytes, PfmChannels::ColourOnly)
}

/// Which PFM types [`decode_pfm`] accepts.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PfmChannels {
    /// `PF` only (films).
    ColourOnly,
    /// `PF`, or `Pf` read as grey RGB (environment maps).
    ColourOrGrey,
}

/// Decodes a PFM file's bytes (`path` names it in errors): little-endian if the scale is
/// negative, values times |scale| (as pbrt-v4 reads them; writers write ±1), rows stored
/// bottom row first and returned top row first.
pub fn decode_pfm(
    path: &Path,
    bytes: &[u8],
    accepted: PfmChannels,
) -> Result<(usize, usize, Vec<Vec3>)> {
    let bad = |what: String| Error::format(path, format!("PFM: {what}"));
    let (fields, at) = pfm_header(bytes).ok_or_else(|| {
        bad("expected the header `PF` or `Pf`, width, height and scale".to_string())
    })?;
    let text = |f: &[u8]| String::from_utf8_lossy(f).into_owned();
    let channels = match (fields[0], accepted) {
        (b"PF", _) => 3,
        (b"Pf", PfmChannels::ColourOrGrey) => 1,
        (b"Pf", PfmChannels::ColourOnly) => {
            return Err(bad("`Pf` is not a colour PFM (expected `PF`)".to_string()));
        }
        (other, _) => {
            return Err(bad(format!(
                "type `{}`: expected `PF` (RGB) or `Pf` (grey)",
                text(other)
            )));
        }
    };
    let size = |f: &[u8]| text(f).parse::<usize>().ok().filter(|&n| n >= 1);
    let (Some(width), Some(height)) = (size(fields[1]), size(fields[2])) else {
        return Err(bad(format!(
            "size `{} {}`: expected two whole numbers ≥ 1",
            text(fields[1]),
            text(fields[2])
        )));
    };
    let scale = text(fields[3])
        .parse::<f32>()
        .ok()
        .filter(|s| s.is_finite() && *s != 0.0)
        .ok_or_else(|| {
            bad(format!(
                "scale `{}`: expected a non-zero number (negative: little-endian)",
                text(fields[3])
            ))
        })?;
    let row_bytes = width * channels * 4;
    let data = bytes.get(at..).unwrap_or_default();
    if row_bytes.checked_mul(height) != Some(data.len()) {
        return Err(bad(format!(
            "{} bytes of pixels, expected {} for {width}×{height} {}",
            data.len(),
            (row_bytes as u128) * (height as u128),
            if channels == 3 { "RGB" } else { "grey" }
        )));
    }
    let value = |b: &[u8]| {
        let b: [u8; 4] = b.try_into().expect("chunks of 4 bytes");
        scale.abs()
            * if scale < 0.0 {
                f32::from_le_bytes(b)
            } else {
                f32::from_be_bytes(b)
            }
    };
    let mut texels = vec![Vec3::ZERO; width * height];
    for (stored, line) in data.chunks_exact(row_bytes).enumerate() {
        let row = height - 1 - stored;
        for (x, px) in line.chunks_exact(channels * 4).enumerate() {
            let mut c = [0.0; 3];
            for (k, b) in px.chunks_exact(4).enumerate() {
                c[k] = value(b);
            }
            texels[row * width + x] = if channels == 3 {
                Vec3::from(c)
            } else {
                Vec3::splat(c[0])
            };
        }
    }
    Ok((width, height, texels))
}

/// Splits a PFM header into its four white-space separated fields ("PF" or "Pf", width,
/// height, scale) and the offset of the pixel data, after the one white-space byte that
/// ends the header.
fn pfm_header(bytes: &[u8]) -> Option<([&[u8]; 4], usize)> {
    let mut fields = [&bytes[..0]; 4];
    let mut at = 0;
    for field in &mut fields {
        while at < bytes.len() && bytes[at].is_ascii_whitespace() {
            at += 1;
        }
        let start = at;
        while at < bytes.len() && !bytes[at].is_ascii_whitespace() {
            at += 1;
        }
        if start == at || at - start > 32 {
            return None;
        }
        *field = &bytes[start..at];
    }
    Some((fields, at + 1))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pfm_round_trip_and_errors_name_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.pfm");
        let pixels: Vec<Vec3> = (0..6).map(|i| Vec3::new(i as f32, 0.5, -1.0)).collect();
        write_pfm(&path, 3, 2, &pixels).unwrap();
        assert_eq!(read_pfm(&path).unwrap(), (3, 2, pixels));
        std::fs::write(&path, b"PF\n3 2\n-1.0\n\0\0").unwrap();
        let err = read_pfm(&path).unwrap_err().to_string();
        assert!(
            err.contains("a.pfm") && err.contains("expected 72"),
            "{err}"
        );
        std::fs::write(&path, b"Pf\n3 2\n-1.0\n").unwrap();
        assert!(
            read_pfm(&path)
                .unwrap_err()
                .to_string()
                .contains("colour PFM")
        );
    }

    #[test]
    fn exr_round_trip_keeps_every_layer_bit_exact() {
        let mut film = Film::new(5, 3);
        for (k, layer) in Layer::ALL.iter().enumerate() {
            for y in 0..3 {
                for x in 0..5 {
                    film.set(
                        *layer,
                        x,
                        y,
                        Vec3::new(x as f32, y as f32, k as f32 + 0.125),
                    );
                }
            }
        }
        let var = [
            vec![Vec3::splat(1e-3); 15],
            vec![Vec3::ONE; 15],
            vec![Vec3::ZERO; 15],
        ];
        let film = film
            .with_variance(var)
            .with_total_variance((0..15).map(|i| Vec3::splat(i as f32 * 0.25)).collect())
            .with_depth((0..15).map(|i| i as f32 * 0.5).collect());
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("f.exr");
        film.write_exr(&p).unwrap();
        let back = Film::read_exr(&p).unwrap();
        assert_eq!(back, film);
    }

    #[test]
    fn srgb_encoding_and_exposure() {
        let px = [Vec3::new(0.0, 0.5, 1.0), Vec3::splat(0.25)];
        let a = to_srgb8(&px, 0.0);
        assert_eq!(&a[..3], &[0, 188, 255]);
        let b = to_srgb8(&px[1..], 1.0);
        assert_eq!(b[0], 188, "+1 stop doubles 0.25 to 0.5");
    }

    #[test]
    fn pfm_has_header_and_size() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("f.pfm");
        write_pfm(&p, 2, 2, &[Vec3::ONE; 4]).unwrap();
        let bytes = std::fs::read(&p).unwrap();
        assert!(bytes.starts_with(b"PF\n2 2\n-1.0\n"));
        assert_eq!(bytes.len(), 12 + 4 * 12);
    }
}
