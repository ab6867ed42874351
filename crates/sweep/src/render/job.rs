//! A cell to render now, and the error for an image that overflowed: what the render's
//! groups and references share.

use crate::plan::{CellSpec, toml_to_json};

/// A cell to render now.
pub(crate) struct Job {
    pub(super) spec: CellSpec,
    pub(super) hash: String,
    pub(super) reference: Option<String>,
}

impl Job {
    pub(super) fn axes_json(&self) -> Vec<(String, serde_json::Value)> {
        self.spec
            .axes
            .iter()
            .map(|(k, v)| (k.clone(), toml_to_json(v)))
            .collect()
    }
}

/// The error for an image with infinite or NaN pixels: which layers, how many, and the
/// scene's values most likely to have overflowed (its brightest light, its σt).
pub(crate) fn non_finite(
    what: &str,
    film: &volphot::Film,
    params: &volphot::SceneParams,
) -> anyhow::Error {
    let layers: Vec<String> = film
        .non_finite_pixels()
        .iter()
        .map(|(l, n)| format!("{} layer {n} pixels", l.name()))
        .collect();
    let mut lights: Vec<(String, f32)> = params
        .lights
        .iter()
        .enumerate()
        .filter_map(|(i, l)| {
            // The brightest delta light's intensity, or an area light's radiance.
            let (key, value) = match (l.intensity, l.radiance) {
                (Some(v), _) => ("intensity", v),
                (None, Some(v)) => ("radiance", v),
                _ => return None,
            };
            Some((format!("lights[{i}].{key}"), value.rgb().max_element()))
        })
        .collect();
    if let Some(t) = &params.three_point {
        lights.push(("three_point.key_intensity".into(), t.key_intensity));
    }
    let brightest = lights
        .iter()
        .max_by(|a, b| a.1.total_cmp(&b.1))
        .map_or(String::new(), |(k, v)| {
            format!("; the brightest light is `{k}` = {v:e}")
        });
    anyhow::anyhow!(
        "{what} rendered infinite or NaN values ({}): a value overflowed 32-bit floats{brightest}, σt(d_min) `sigma.t` = {}; lower the light's intensity or σt",
        layers.join(", "),
        params.sigma.t.map_or("unset".into(), |t| format!("{t:e}"))
    )
}
