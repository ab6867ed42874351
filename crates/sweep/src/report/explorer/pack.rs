//! Pixel data as small text the explorer can read from `file://`: half floats (11
//! significant bits, the precision of the readout), planar RGB with the high bytes of every
//! value before the low bytes (so deflate sees long runs of similar exponents), raw
//! deflate, base64. The page inflates with `DecompressionStream('deflate-raw')`.

use std::io::Write as _;

use anyhow::{Context, Result};
use base64::Engine as _;
use glam::Vec3;
use half::f16;

/// A radiance layer packed for the explorer, or `None` when every value is zero (the page
/// then uses zeros; a disabled layer costs nothing).
pub(super) fn pack_layer(pixels: &[Vec3]) -> Result<Option<String>> {
    if pixels.iter().all(|p| *p == Vec3::ZERO) {
        return Ok(None);
    }
    let n = pixels.len();
    let mut bits = Vec::with_capacity(3 * n);
    for channel in 0..3 {
        bits.extend(pixels.iter().map(|p| f16::from_f32(p[channel]).to_bits()));
    }
    let mut shuffled = Vec::with_capacity(2 * bits.len());
    shuffled.extend(bits.iter().map(|b| (b >> 8) as u8));
    shuffled.extend(bits.iter().map(|b| (b & 0xff) as u8));
    deflate_base64(&shuffled).map(Some)
}

/// Values in [0, 1] (a FLIP error map) as bytes: `round(255 v)`, as FLIP indexes its
/// colour map.
pub(super) fn pack_unit(values: &[f32]) -> Result<String> {
    let bytes: Vec<u8> = values
        .iter()
        .map(|v| (v.clamp(0.0, 1.0) * 255.0).round() as u8)
        .collect();
    deflate_base64(&bytes)
}

/// Plain base64 of a few bytes (a colour map).
pub(super) fn base64(bytes: &[u8]) -> String {
    base64::engine::general_purpose::STANDARD.encode(bytes)
}

fn deflate_base64(bytes: &[u8]) -> Result<String> {
    let mut z = flate2::write::DeflateEncoder::new(Vec::new(), flate2::Compression::new(6));
    z.write_all(bytes).context("compressing explorer data")?;
    let compressed = z.finish().context("compressing explorer data")?;
    Ok(base64(&compressed))
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;
    use std::io::Read as _;

    /// What the page does: base64 → inflate → bytes.
    pub(crate) fn inflate(text: &str) -> Vec<u8> {
        let bytes = base64::engine::general_purpose::STANDARD
            .decode(text)
            .unwrap();
        let mut out = Vec::new();
        flate2::read::DeflateDecoder::new(bytes.as_slice())
            .read_to_end(&mut out)
            .unwrap();
        out
    }

    /// What the page does with a packed layer: planar RGB back to pixels.
    pub(crate) fn unpack_layer(text: &str) -> Vec<Vec3> {
        let b = inflate(text);
        let half = b.len() / 2;
        let value = |i: usize| f16::from_bits(u16::from(b[i]) << 8 | u16::from(b[half + i]));
        let n = half / 3;
        (0..n)
            .map(|i| {
                Vec3::new(
                    value(i).to_f32(),
                    value(n + i).to_f32(),
                    value(2 * n + i).to_f32(),
                )
            })
            .collect()
    }

    #[test]
    fn layers_round_trip_to_half_precision() {
        let pixels: Vec<Vec3> = (0..300)
            .map(|i| {
                let x = i as f32;
                Vec3::new(x * 0.013, 1.0 / (1.0 + x), (x * 0.7).sin().abs() * 1e-3)
            })
            .collect();
        let packed = pack_layer(&pixels).unwrap().unwrap();
        let back = unpack_layer(&packed);
        assert_eq!(back.len(), pixels.len());
        for (a, b) in pixels.iter().zip(&back) {
            for c in 0..3 {
                assert_eq!(b[c], f16::from_f32(a[c]).to_f32(), "{a} vs {b}");
                assert!((b[c] - a[c]).abs() <= a[c].abs() * 2f32.powi(-11) + 6e-8);
            }
        }
        // Deterministic text: the same film gives the same file.
        assert_eq!(pack_layer(&pixels).unwrap().unwrap(), packed);
    }

    #[test]
    fn zero_layers_are_omitted_and_large_values_saturate() {
        assert_eq!(pack_layer(&[Vec3::ZERO; 16]).unwrap(), None);
        let back = unpack_layer(
            &pack_layer(&[Vec3::new(1e6, 65504.0, -2.0)])
                .unwrap()
                .unwrap(),
        );
        assert_eq!(back[0].x, f32::INFINITY);
        assert_eq!(back[0].y, 65504.0);
        assert_eq!(back[0].z, -2.0);
    }

    #[test]
    fn unit_maps_quantise_to_bytes() {
        let packed = pack_unit(&[0.0, 0.5, 1.0, 2.0, -1.0, 0.002]).unwrap();
        assert_eq!(inflate(&packed), vec![0, 128, 255, 255, 0, 1]);
    }
}
