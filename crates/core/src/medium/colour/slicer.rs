//! 3D Slicer volume-property files: the nine-line `.vp` text format
//! (`vtkMRMLVolumePropertyStorageNode`) and `.vp.json`
//! (`vtkMRMLVolumePropertyJsonStorageNode`). Only the scalar opacity, the colour transfer
//! and (JSON) `scalarOpacityUnitDistance` matter for rendering here; shading and gradient
//! opacity are surface-rendering terms with no counterpart in a participating medium.

use std::path::Path;

use serde_json::Value;

use super::ColourTransfer;
use crate::error::{Error, Result};

/// Reads a `.vp` or `.vp.json` file (chosen by extension).
pub fn read(path: &Path) -> Result<ColourTransfer> {
    let text = crate::util::read_text_capped(
        path,
        crate::util::TEXT_INPUT_CAP,
        "3D Slicer volume property (.vp or .vp.json)",
    )?;
    let name = path.display().to_string();
    let lower = name.to_ascii_lowercase();
    let parsed = if lower.ends_with(".json") {
        parse_json(&text)
    } else if lower.ends_with(".vp") {
        parse_vp(&text, &name)
    } else {
        Err(Error::format(
            path,
            "expected a Slicer volume property (.vp or .vp.json)",
        ))
    };
    parsed.map_err(|e| match e {
        Error::Format { .. } => e,
        other => Error::format(path, other.to_string()),
    })
}

/// Parses the `.vp` text: line 7 the scalar opacity (`N x y …`), line 9 the colour
/// (`N x r g b …`), N counting the numbers that follow.
pub fn parse_vp(text: &str, what: &str) -> Result<ColourTransfer> {
    let lines: Vec<&str> = text.lines().collect();
    if lines.len() < 9 {
        return Err(Error::parameter(
            what,
            format!("{} lines", lines.len()),
            "the nine lines of a Slicer .vp file (opacity on line 7, colour on line 9)",
        ));
    }
    let opacity = counted::<2>(lines[6], what, 7, "scalar opacity")?;
    let colour = counted::<4>(lines[8], what, 9, "colour transfer")?;
    ColourTransfer {
        source: what.to_string(),
        opacity,
        colour,
        unit_distance: 1.0,
    }
    .validated(what)
}

/// `N v1 v2 …` with N values following, grouped by `K`.
fn counted<const K: usize>(
    line: &str,
    what: &str,
    number: usize,
    name: &str,
) -> Result<Vec<[f64; K]>> {
    let key = format!("{what}:{number} ({name})");
    let mut tokens = line.split_whitespace();
    let n: usize = tokens.next().and_then(|t| t.parse().ok()).ok_or_else(|| {
        Error::parameter(&key, format!("{line:?}"), "a count followed by the numbers")
    })?;
    let values: Vec<f64> = tokens
        .map(|t| t.parse::<f64>())
        .collect::<std::result::Result<_, _>>()
        .map_err(|e| Error::parameter(&key, format!("{line:?}"), format!("numbers ({e})")))?;
    if values.len() != n || !n.is_multiple_of(K) || n == 0 {
        return Err(Error::parameter(
            &key,
            format!("count {n} with {} numbers following", values.len()),
            format!("a count equal to the numbers that follow, a non-zero multiple of {K}"),
        ));
    }
    Ok(values
        .chunks_exact(K)
        .map(|c| std::array::from_fn(|i| c[i]))
        .collect())
}

/// Parses `.vp.json`: the first component of the first volume property.
pub fn parse_json(text: &str) -> Result<ColourTransfer> {
    let root: Value = serde_json::from_str(text).map_err(|e| {
        Error::parameter(
            "vp.json",
            format!("line {}", e.line()),
            format!("valid JSON ({e})"),
        )
    })?;
    let component = root
        .pointer("/volumeProperties/0/components/0")
        .ok_or_else(|| {
            Error::parameter(
                "volumeProperties[0].components[0]",
                "(missing)",
                "a volume property component",
            )
        })?;
    let points = |pointer: &str| -> Result<&Vec<Value>> {
        component
            .pointer(pointer)
            .and_then(Value::as_array)
            .ok_or_else(|| {
                Error::parameter(
                    format!("components[0]{}", pointer.replace('/', ".")),
                    "(missing)",
                    "an array of points",
                )
            })
    };
    let number = |v: &Value, key: String| -> Result<f64> {
        v.as_f64()
            .ok_or_else(|| Error::parameter(key, v.to_string(), "a number"))
    };
    let mut opacity = Vec::new();
    for (i, p) in points("/scalarOpacity/points")?.iter().enumerate() {
        let key = format!("scalarOpacity.points[{i}]");
        opacity.push([
            number(&p["x"], format!("{key}.x"))?,
            number(&p["y"], format!("{key}.y"))?,
        ]);
    }
    let mut colour = Vec::new();
    for (i, p) in points("/rgbTransferFunction/points")?.iter().enumerate() {
        let key = format!("rgbTransferFunction.points[{i}]");
        let c = |k: usize| number(&p["color"][k], format!("{key}.color[{k}]"));
        colour.push([number(&p["x"], format!("{key}.x"))?, c(0)?, c(1)?, c(2)?]);
    }
    let unit_distance = match component.get("scalarOpacityUnitDistance") {
        None => 1.0,
        Some(v) => number(v, "scalarOpacityUnitDistance".into())?,
    };
    ColourTransfer {
        source: "vp.json".into(),
        opacity,
        colour,
        unit_distance,
    }
    .validated("vp.json")
}

#[cfg(test)]
mod tests {
    use super::*;

    const CARDIAC3: &str = "1\n1\n0.9\n0.1\n0.2\n10\n\
        14 -3024 0 -86.9767 0 45.3791 0.169643 139.919 0.589286 347.907 0.607143 1224.16 0.607143 3071 0.616071\n\
        4 0 1 255 1\n\
        28 -3024 0 0 0 -86.9767 0 0.25098 1 45.3791 1 0 0 139.919 1 0.894893 0.894893 347.907 1 1 0.25098 1224.16 1 1 1 3071 0.827451 0.658824 1\n";

    #[test]
    fn vp_text_from_slicers_guide() {
        let tf = parse_vp(CARDIAC3, "cardiac3.vp").unwrap();
        assert_eq!(tf.opacity.len(), 7);
        assert_eq!(tf.colour.len(), 7);
        assert_eq!(tf.colour[2], [45.3791, 1.0, 0.0, 0.0]);
    }

    #[test]
    fn a_wrong_point_count_names_the_line() {
        let bad = CARDIAC3.replace("14 -3024", "16 -3024");
        let e = parse_vp(&bad, "bad.vp").unwrap_err().to_string();
        assert!(
            e.contains("bad.vp:7 (scalar opacity)") && e.contains("count 16 with 14 numbers"),
            "{e}"
        );
        let odd = CARDIAC3.replace("28 -3024 0 0 0 ", "27 -3024 0 0 ");
        let e = parse_vp(&odd, "odd.vp").unwrap_err().to_string();
        assert!(e.contains("odd.vp:9 (colour transfer)"), "{e}");
    }

    #[test]
    fn vp_json_with_unit_distance_and_a_repeated_point() {
        let json = r#"{"volumeProperties": [{"components": [{
            "scalarOpacityUnitDistance": 2.5,
            "rgbTransferFunction": {"points": [{"x": 0, "color": [0, 0, 0]}, {"x": 40, "color": [0.4, 0.1, 0.1]},
                                               {"x": 40, "color": [0.4, 0.1, 0.1]}, {"x": 1024, "color": [1, 1, 1]}]},
            "scalarOpacity": {"points": [{"x": 0, "y": 0}, {"x": 120, "y": 0.3}]}}]}]}"#;
        let tf = parse_json(json).unwrap();
        assert_eq!(tf.unit_distance, 2.5);
        assert_eq!(tf.colour.len(), 4);
        assert!((tf.opacity(60.0) - 0.15).abs() < 1e-12);
        let e = parse_json(&json.replace("\"x\": 120", "\"x\": -5"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("opacity[1]") && e.contains("increasing"), "{e}");
    }
}
