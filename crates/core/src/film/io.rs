//! Film files: OpenEXR (32-bit float, every layer as `single.R` …, plus `total`, the
//! per-pixel variance of the mean when known, and depth), PNG (exposure + sRGB) and PFM
//! (total, linear; the format itself is `util::pfm`'s). Every file is written atomically.

use std::path::Path;

use glam::Vec3;

use super::{Film, Layer};
use crate::error::{Error, Result};
use crate::util::{write_atomic_with, write_pfm};

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

#[cfg(test)]
mod tests {
    use super::*;

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
}
