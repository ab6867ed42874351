//! The TOML scene format: one file = one render.
//!
//! ```toml
//! [volume]
//! dataset = "foot"                 # or: file = "ct.nrrd" / phantom = { name = "engine" }
//!
//! [transfer]
//! kind = "points"
//! points = [[0.0, 0.0], [0.08, 0.0], [0.3, 1.0], [1.0, 1.0]]
//!
//! [sigma]
//! mapping = "thesis"               # σt(d_min) = t (§8.1.2)
//! t = 80
//! albedo = 0.818
//!
//! [camera]
//! eye = [0.5, -2.2, 0.5]
//! look_at = [0.5, 0.5, 0.5]
//! up = [0, 0, 1]
//! fov = 30
//! resolution = [512, 512]
//!
//! [three_point]                    # key, fill and rim spot lights (§8.2)
//! key_intensity = 100
//!
//! [integrator]
//! volume_photons = 40000
//! nused = 150
//! maxdist = 0.1
//! stepsize = 0.0005
//! ```
//!
//! Unknown keys and wrong types are reported by the TOML reader with line and column; range
//! checks happen in each component's `create`, which names the key, and [`load_params`] /
//! [`Scene::load`] turn that key back into the line and column where it was written.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use glam::Vec3;
use serde::{Deserialize, Serialize};

use crate::camera::{Camera, CameraParams};
use crate::error::{Error, Result};
use crate::grid::Reconstruction;
use crate::light::{Light, LightParams, ThreePointParams, three_point};
use crate::medium::{DEFAULT_BRICK_SIZE, Medium, MediumSettings};
use crate::sampling::Phase;
use crate::settings::{FilmParams, IntegratorParams};
use crate::sigma::{SigmaMapping, SigmaParams};
use crate::transfer::{TransferFunction, TransferParams};
use crate::volume::phantom::PhantomParams;
use crate::volume::registry::{DatasetOverrides, SearchPath, load_dataset};
use crate::volume::{
    ByteOrder, FileRequest, Normalization, Placement, RawLayout, Volume, VolumeSource, VoxelType,
};

/// `[volume]`: where the voxels come from and how they are placed and scaled.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct VolumeParams {
    /// A registry name (`foot`, `engine`, `head`, `head16`, `skeleton`, …).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub dataset: Option<String>,
    /// A file path, relative to the scene file.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub file: Option<PathBuf>,
    /// A procedural phantom.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub phantom: Option<PhantomParams>,
    /// RAW files: voxel counts.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub dims: Option<[usize; 3]>,
    /// RAW files: stored type.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub voxel: Option<VoxelType>,
    /// RAW files: byte order (default little).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub byte_order: Option<ByteOrder>,
    /// RAW files: bytes before the first voxel.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub header_bytes: Option<u64>,
    /// Expected sha256 of a `file` (verified when given).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sha256: Option<String>,
    /// World box `p0..p1` (thesis §7.2.1).
    #[serde(default, rename = "box", skip_serializing_if = "Option::is_none")]
    pub bounds: Option<BoxParams>,
    /// Physical voxel spacing (the volume is centred in the unit box, longest axis 1).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub spacing: Option<[f32; 3]>,
    /// `type-range`, `min-max` or `window`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub normalize: Option<String>,
    /// With `normalize = "window"`: raw `[lo, hi]`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub window: Option<[f64; 2]>,
    /// `trilinear` (default) or `nearest`.
    #[serde(default)]
    pub reconstruction: Reconstruction,
    /// Majorant brick edge in voxels.
    #[serde(default = "default_brick_size")]
    pub brick_size: usize,
}

fn default_brick_size() -> usize {
    DEFAULT_BRICK_SIZE
}

/// A world box.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BoxParams {
    /// Lower corner.
    pub p0: [f32; 3],
    /// Upper corner.
    pub p1: [f32; 3],
}

/// `[phase]`: the phase function.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PhaseParams {
    /// Henyey–Greenstein asymmetry; 0 = isotropic (thesis eq. 4).
    #[serde(default)]
    pub g: f32,
}

/// A whole scene file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneParams {
    /// The volume.
    pub volume: VolumeParams,
    /// Transfer function (default identity).
    #[serde(default)]
    pub transfer: TransferParams,
    /// σ mapping (default: the thesis's rule, σt(d_min) = 80, albedo 9/11).
    #[serde(default)]
    pub sigma: SigmaParams,
    /// Phase function.
    #[serde(default)]
    pub phase: PhaseParams,
    /// Camera.
    #[serde(default)]
    pub camera: CameraParams,
    /// The three-point preset (§8.2), built from the camera.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub three_point: Option<ThreePointParams>,
    /// Explicit lights.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub lights: Vec<LightParams>,
    /// Renderer settings.
    #[serde(default)]
    pub integrator: IntegratorParams,
    /// Film settings.
    #[serde(default)]
    pub film: FilmParams,
}

impl SceneParams {
    /// Parses scene TOML; unknown keys and wrong types are located by line and column.
    pub fn from_toml(src: &str, file: &Path) -> Result<Self> {
        toml::from_str(src).map_err(|e| toml_error(&e, src, file))
    }

    /// Deserialises from an already-parsed table (e.g. a base scene with sweep overrides);
    /// errors name the key path but have no position.
    pub fn from_table(table: toml::Table) -> Result<Self> {
        let text = toml::to_string(&table).map_err(|e| Error::Render(e.to_string()))?;
        toml::from_str(&text).map_err(|e| Error::Parameter {
            key: "scene".into(),
            value: String::new(),
            expected: e.message().to_string(),
        })
    }

    /// The parameters as a TOML table (for overrides and records).
    pub fn to_table(&self) -> toml::Table {
        toml::Table::try_from(self).expect("scene parameters serialise to TOML")
    }
}

/// Converts a TOML reader error into a located [`Error::Scene`].
pub fn toml_error(e: &toml::de::Error, src: &str, file: &Path) -> Error {
    let (line, column) = e.span().map(|s| line_col(src, s.start)).unwrap_or((1, 1));
    // Quote the offending line so the key is named even when the reader points at a value.
    let quoted = src
        .lines()
        .nth(line - 1)
        .map(str::trim)
        .filter(|l| !l.is_empty())
        .map(|l| format!(" (in `{l}`)"))
        .unwrap_or_default();
    Error::Scene {
        file: file.to_path_buf(),
        line,
        column,
        message: format!("{}{quoted}", e.message().trim()),
    }
}

/// 1-based line and column (in characters) of a byte offset.
pub fn line_col(src: &str, byte: usize) -> (usize, usize) {
    let before = src.get(..byte.min(src.len())).unwrap_or(src);
    let line = before.matches('\n').count() + 1;
    let column = before.rsplit('\n').next().unwrap_or("").chars().count() + 1;
    (line, column)
}

/// Splits a key path such as `lights[1].cone_angle` into `["lights", "1", "cone_angle"]`.
fn key_segments(key: &str) -> Vec<String> {
    let mut out = Vec::new();
    for part in key.split('.') {
        let mut rest = part;
        if let Some(open) = rest.find('[') {
            out.push(rest[..open].to_string());
            rest = &rest[open..];
            while let Some(stripped) = rest.strip_prefix('[') {
                let close = stripped.find(']').unwrap_or(stripped.len());
                out.push(stripped[..close].to_string());
                rest = stripped.get(close + 1..).unwrap_or("");
            }
        } else {
            out.push(rest.to_string());
        }
    }
    out.retain(|s| !s.is_empty());
    out
}

/// Line and column of the value at `key` (dotted, with `[i]` indices) in `src`, or of its
/// deepest written ancestor when the key itself is absent (a default).
pub fn locate(src: &str, key: &str) -> Option<(usize, usize)> {
    use toml::de::{DeTable, DeValue};
    let root = DeTable::parse(src).ok()?;
    let segments = key_segments(key);
    let mut best = None;
    let mut table: Option<&DeTable<'_>> = Some(root.get_ref());
    let mut value: Option<&toml::Spanned<DeValue<'_>>> = None;
    for (i, seg) in segments.iter().enumerate() {
        let next = match (table, value.map(|v| v.get_ref())) {
            (Some(t), _) => match t.get_key_value(seg.as_str()) {
                Some((k, v)) => {
                    best = Some(k.span().start);
                    v
                }
                None => break,
            },
            (None, Some(DeValue::Array(a))) => {
                match seg.parse::<usize>().ok().and_then(|i| a.get(i)) {
                    Some(v) => {
                        best = Some(v.span().start);
                        v
                    }
                    None => break,
                }
            }
            _ => break,
        };
        // The key's own value (not a table header or an array of tables) is where a
        // reader's eye goes.
        let is_leaf_value = i + 1 == segments.len()
            && match next.get_ref() {
                DeValue::Table(_) => false,
                DeValue::Array(a) => {
                    !a.iter().all(|e| matches!(e.get_ref(), DeValue::Table(_))) || a.is_empty()
                }
                _ => true,
            };
        if is_leaf_value {
            best = Some(next.span().start);
        }
        value = Some(next);
        table = next.get_ref().as_table();
    }
    best.map(|b| line_col(src, b))
}

/// The dotted key path whose key or value covers byte `offset` of `src` (the inverse of
/// [`locate`]), e.g. to name the key behind a type error in generated TOML.
pub fn key_at(src: &str, offset: usize) -> Option<String> {
    use toml::de::{DeTable, DeValue};
    fn walk(table: &DeTable<'_>, offset: usize, prefix: &str) -> Option<String> {
        for (k, v) in table.iter() {
            let key = if prefix.is_empty() {
                k.get_ref().to_string()
            } else {
                format!("{prefix}.{}", k.get_ref())
            };
            let (ks, vs) = (k.span(), v.span());
            let inside =
                |r: &std::ops::Range<usize>| r.start <= offset && offset < r.end.max(r.start + 1);
            if let DeValue::Table(t) = v.get_ref()
                && let Some(found) = walk(t, offset, &key)
            {
                return Some(found);
            }
            if inside(&ks) || inside(&vs) {
                return Some(key);
            }
        }
        None
    }
    let root = DeTable::parse(src).ok()?;
    walk(root.get_ref(), offset, "")
}

/// Turns a keyed [`Error::Parameter`] into an [`Error::Scene`] at the key's position.
pub fn locate_error(err: Error, src: &str, file: &Path) -> Error {
    match &err {
        Error::Parameter { key, .. } => {
            let (line, column) = locate(src, key).unwrap_or((1, 1));
            Error::Scene {
                file: file.to_path_buf(),
                line,
                column,
                message: err.to_string(),
            }
        }
        _ => err,
    }
}

/// Reads and parses a scene file; parameter errors are located.
pub fn load_params(path: &Path) -> Result<(SceneParams, String)> {
    let src = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
    let params = SceneParams::from_toml(&src, path)?;
    validate_params(&params).map_err(|e| locate_error(e, &src, path))?;
    Ok((params, src))
}

/// Checks everything that can be checked without loading the volume.
pub fn validate_params(params: &SceneParams) -> Result<()> {
    params
        .integrator
        .validate()
        .map_err(|e| e.within("integrator"))?;
    params.film.validate().map_err(|e| e.within("film"))?;
    SigmaMapping::create(&params.sigma).map_err(|e| e.within("sigma"))?;
    Phase::henyey_greenstein(params.phase.g)
        .map_err(|_| Error::parameter("phase.g", params.phase.g, "an asymmetry in (-1, 1)"))?;
    Camera::create(&params.camera).map_err(|e| e.within("camera"))?;
    for (i, l) in params.lights.iter().enumerate() {
        Light::create(l).map_err(|e| e.within(&format!("lights[{i}]")))?;
    }
    if params.lights.is_empty() && params.three_point.is_none() {
        return Err(Error::parameter(
            "lights",
            "(none)",
            "at least one [[lights]] entry or a [three_point] table",
        ));
    }
    volume_choice(&params.volume)?;
    Ok(())
}

enum VolumeChoice<'a> {
    Dataset(&'a str),
    File(&'a Path),
    Phantom(&'a PhantomParams),
}

fn volume_choice(v: &VolumeParams) -> Result<VolumeChoice<'_>> {
    let given = [v.dataset.is_some(), v.file.is_some(), v.phantom.is_some()]
        .iter()
        .filter(|b| **b)
        .count();
    if given != 1 {
        return Err(Error::parameter(
            "volume",
            format!("{given} sources"),
            "exactly one of `dataset`, `file`, `phantom`",
        ));
    }
    let raw_keys = [
        ("dims", v.dims.is_some()),
        ("voxel", v.voxel.is_some()),
        ("byte_order", v.byte_order.is_some()),
        ("header_bytes", v.header_bytes.is_some()),
    ];
    let is_raw_file = v.file.as_ref().is_some_and(|f| {
        !matches!(
            f.extension()
                .and_then(|e| e.to_str())
                .map(|e| e.to_ascii_lowercase())
                .as_deref(),
            Some("nrrd" | "nhdr" | "mhd" | "mha")
        )
    });
    for (key, present) in raw_keys {
        if present && !is_raw_file {
            return Err(Error::parameter(
                format!("volume.{key}"),
                "(given)",
                "only with a headerless RAW `file` (datasets and header files carry their own layout)",
            ));
        }
    }
    if is_raw_file {
        if v.dims.is_none() {
            return Err(Error::parameter(
                "volume.dims",
                "(missing)",
                "[nx, ny, nz] for a RAW file",
            ));
        }
        if v.voxel.is_none() {
            return Err(Error::parameter(
                "volume.voxel",
                "(missing)",
                "u8, i8, u16, i16 or f32 for a RAW file",
            ));
        }
    }
    if v.bounds.is_some() && v.spacing.is_some() {
        return Err(Error::parameter(
            "volume.spacing",
            "(given with box)",
            "either `box` or `spacing`",
        ));
    }
    if v.window.is_some() && v.normalize.as_deref() != Some("window") {
        return Err(Error::parameter(
            "volume.window",
            "(given)",
            "only with normalize = \"window\"",
        ));
    }
    if v.sha256.is_some() && v.file.is_none() {
        return Err(Error::parameter(
            "volume.sha256",
            "(given)",
            "only with `file`",
        ));
    }
    if v.phantom.is_some() && v.normalize.is_some() {
        return Err(Error::parameter(
            "volume.normalize",
            "(given)",
            "no normalisation for phantoms (they are already in [0, 1])",
        ));
    }
    Ok(match (&v.dataset, &v.file, &v.phantom) {
        (Some(d), _, _) => VolumeChoice::Dataset(d),
        (_, Some(f), _) => VolumeChoice::File(f),
        (_, _, Some(p)) => VolumeChoice::Phantom(p),
        _ => unreachable!("exactly one source checked above"),
    })
}

fn normalization(v: &VolumeParams) -> Result<Option<Normalization>> {
    match v.normalize.as_deref() {
        None => Ok(None),
        Some("type-range") => Ok(Some(Normalization::TypeRange)),
        Some("min-max") => Ok(Some(Normalization::MinMax)),
        Some("window") => {
            let [lo, hi] = v.window.ok_or_else(|| {
                Error::parameter(
                    "volume.window",
                    "(missing)",
                    "[lo, hi] raw values for normalize = \"window\"",
                )
            })?;
            let n = Normalization::Window { lo, hi };
            n.validate().map_err(|_| {
                Error::parameter(
                    "volume.window",
                    format!("[{lo}, {hi}]"),
                    "two finite raw values with lo < hi",
                )
            })?;
            Ok(Some(n))
        }
        Some(other) => Err(Error::parameter(
            "volume.normalize",
            format!("\"{other}\""),
            "one of type-range, min-max, window",
        )),
    }
}

fn placement(v: &VolumeParams) -> Option<Placement> {
    if let Some(b) = v.bounds {
        Some(Placement::Box { p0: b.p0, p1: b.p1 })
    } else {
        v.spacing.map(Placement::Spacing)
    }
}

/// Loads the volume a scene names. `base` resolves relative file paths.
pub fn load_volume(v: &VolumeParams, base: &Path, search: &SearchPath) -> Result<Volume> {
    let norm = normalization(v)?;
    let place = placement(v);
    if let Some(p) = place {
        // Validate placement early so the error names the scene key.
        p.bounds([1, 1, 1]).map_err(|e| match p {
            Placement::Box { .. } => e.within("volume"),
            Placement::Spacing(_) => e.within("volume"),
        })?;
    }
    match volume_choice(v)? {
        VolumeChoice::Dataset(name) => load_dataset(
            name,
            search,
            &DatasetOverrides {
                normalization: norm,
                placement: place,
            },
        )
        .map_err(|e| e.within("volume")),
        VolumeChoice::File(file) => {
            let path = base.join(file);
            let raw_layout = v.dims.map(|dims| RawLayout {
                dims,
                voxel: v.voxel.unwrap_or(VoxelType::U8),
                byte_order: v.byte_order.unwrap_or_default(),
                header_bytes: v.header_bytes.unwrap_or(0),
            });
            crate::volume::load(&FileRequest {
                path,
                raw_layout,
                placement: place,
                normalization: norm.unwrap_or_default(),
                dataset: None,
                expected_sha256: v.sha256.clone(),
            })
        }
        VolumeChoice::Phantom(p) => {
            let volume = Volume::from_phantom(p).map_err(|e| e.within("volume"))?;
            match place {
                // Re-place the generated grid when the scene asks for a box or spacing.
                Some(pl) => Volume::from_raw_values(
                    volume.grid().dims(),
                    volume.grid().values().to_vec(),
                    None,
                    Normalization::TypeRange,
                    pl,
                    volume.source().clone(),
                )
                .map_err(|e| e.within("volume")),
                None => Ok(volume),
            }
        }
    }
}

/// Builds the medium for a scene from an already-loaded volume.
pub fn build_medium(params: &SceneParams, volume: &Volume, base: &Path) -> Result<Medium> {
    let transfer = TransferFunction::create(&params.transfer, base, volume.normalization())
        .map_err(|e| e.within("transfer"))?;
    let mapping = SigmaMapping::create(&params.sigma).map_err(|e| e.within("sigma"))?;
    let phase = Phase::henyey_greenstein(params.phase.g)
        .map_err(|_| Error::parameter("phase.g", params.phase.g, "an asymmetry in (-1, 1)"))?;
    Medium::create(
        volume,
        &MediumSettings {
            transfer,
            mapping,
            emission: Vec3::from(params.sigma.emission.unwrap_or([0.0; 3])),
            phase,
            reconstruction: params.volume.reconstruction,
            brick_size: params.volume.brick_size,
        },
    )
    .map_err(|e| match e {
        Error::Parameter { ref key, .. } if key == "brick_size" => e.within("volume"),
        other => other,
    })
}

/// A scene ready to render.
#[derive(Debug, Clone)]
pub struct Scene {
    medium: Arc<Medium>,
    camera: Camera,
    lights: Vec<Light>,
    integrator: IntegratorParams,
    film: FilmParams,
    volume_source: VolumeSource,
    params: SceneParams,
}

impl Scene {
    /// Loads a scene file, its volume and medium; every error names the file and, for
    /// parameters, the line and column.
    pub fn load(path: &Path, search: &SearchPath) -> Result<Self> {
        let (params, src) = load_params(path)?;
        let base = path.parent().unwrap_or(Path::new("."));
        Self::from_params(&params, base, search).map_err(|e| locate_error(e, &src, path))
    }

    /// Builds a scene from parameters (errors carry key paths, not positions).
    pub fn from_params(params: &SceneParams, base: &Path, search: &SearchPath) -> Result<Self> {
        validate_params(params)?;
        let volume = load_volume(&params.volume, base, search)?;
        let medium = build_medium(params, &volume, base)?;
        Self::assemble(params, Arc::new(medium), volume.source().clone())
    }

    /// Builds a scene around an existing medium (shared between sweep cells).
    pub fn assemble(
        params: &SceneParams,
        medium: Arc<Medium>,
        volume_source: VolumeSource,
    ) -> Result<Self> {
        validate_params(params)?;
        let camera = Camera::create(&params.camera).map_err(|e| e.within("camera"))?;
        let mut lights = Vec::new();
        if let Some(tp) = &params.three_point {
            lights.extend(
                three_point(&camera, &medium.bounds(), tp).map_err(|e| e.within("three_point"))?,
            );
        }
        for (i, l) in params.lights.iter().enumerate() {
            lights.push(Light::create(l).map_err(|e| e.within(&format!("lights[{i}]")))?);
        }
        Ok(Scene {
            medium,
            camera,
            lights,
            integrator: params.integrator.clone(),
            film: params.film.clone(),
            volume_source,
            params: params.clone(),
        })
    }

    /// The medium.
    pub fn medium(&self) -> &Medium {
        &self.medium
    }

    /// The shared medium handle.
    pub fn medium_arc(&self) -> Arc<Medium> {
        Arc::clone(&self.medium)
    }

    /// The camera.
    pub fn camera(&self) -> &Camera {
        &self.camera
    }

    /// The lights.
    pub fn lights(&self) -> &[Light] {
        &self.lights
    }

    /// Integrator settings.
    pub fn integrator(&self) -> &IntegratorParams {
        &self.integrator
    }

    /// Film settings.
    pub fn film(&self) -> &FilmParams {
        &self.film
    }

    /// Where the volume came from.
    pub fn volume_source(&self) -> &VolumeSource {
        &self.volume_source
    }

    /// The parameters the scene was built from.
    pub fn params(&self) -> &SceneParams {
        &self.params
    }

    /// A copy with different integrator settings (validated).
    pub fn with_integrator(&self, integrator: IntegratorParams) -> Result<Self> {
        integrator.validate().map_err(|e| e.within("integrator"))?;
        let mut s = self.clone();
        s.params.integrator = integrator.clone();
        s.integrator = integrator;
        Ok(s)
    }

    /// A copy rendered at another resolution.
    pub fn with_resolution(&self, width: u32, height: u32) -> Self {
        let mut s = self.clone();
        s.camera = s.camera.with_resolution(width, height);
        s.params.camera.resolution = [width, height];
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const GOOD: &str = r#"
[volume]
phantom = { name = "sphere", resolution = [16, 16, 16] }

[sigma]
mapping = "thesis"
t = 10

[three_point]

[integrator]
volume_photons = 1000
nused = 50
"#;

    fn err(src: &str) -> String {
        let file = Path::new("scene.toml");
        match SceneParams::from_toml(src, file) {
            Err(e) => e.to_string(),
            Ok(p) => match validate_params(&p) {
                Err(e) => locate_error(e, src, file).to_string(),
                Ok(()) => match Scene::from_params(&p, Path::new("."), &SearchPath::new(vec![])) {
                    Err(e) => locate_error(e, src, file).to_string(),
                    Ok(_) => "ok".into(),
                },
            },
        }
    }

    #[test]
    fn good_scene_builds() {
        assert_eq!(err(GOOD), "ok");
        let p = SceneParams::from_toml(GOOD, Path::new("s.toml")).unwrap();
        let s = Scene::from_params(&p, Path::new("."), &SearchPath::new(vec![])).unwrap();
        assert_eq!(s.lights().len(), 3);
        assert_eq!(s.integrator().nused, 50);
        assert_eq!(s.integrator().maxdist, 0.1, "thesis default");
    }

    #[test]
    fn errors_are_located_and_named() {
        let cases = [
            (
                GOOD.replace("nused = 50", "nsued = 50"),
                "scene.toml:13:1",
                "nsued",
            ),
            (
                GOOD.replace("nused = 50", "nused = \"many\""),
                "scene.toml:13:9",
                "expected u32 (in `nused = \"many\"`)",
            ),
            (
                GOOD.replace("nused = 50", "nused = 0"),
                "scene.toml:13:9",
                "`integrator.nused` = 0",
            ),
            (
                GOOD.replace("t = 10", "t = -10"),
                "scene.toml:7:5",
                "`sigma.t` = -10",
            ),
            (
                GOOD.replace("resolution = [16, 16, 16]", "resolution = [16, 16, 1]"),
                "scene.toml:3",
                "phantom.resolution",
            ),
            (
                GOOD.replace("[three_point]", ""),
                "scene.toml:1:1",
                "lights",
            ),
            (
                GOOD.replace("nused = 50", "maxdist = -1"),
                "scene.toml:13:11",
                "`integrator.maxdist` = -1",
            ),
        ];
        for (src, at, what) in cases {
            let e = err(&src);
            assert!(e.starts_with(at), "{e} should start with {at}");
            assert!(e.contains(what), "{e} should name {what}");
        }
    }

    #[test]
    fn key_paths_with_indices() {
        assert_eq!(
            key_segments("lights[1].cone_angle"),
            vec!["lights", "1", "cone_angle"]
        );
        let src = "[[lights]]\ntype = \"point\"\nposition = [0,0,0]\nintensity = 1\n\n[[lights]]\ntype = \"spot\"\nposition = [0,0,0]\ntarget = [1,0,0]\nintensity = 1\ncone_angle = 400\n";
        assert_eq!(locate(src, "lights[1].cone_angle"), Some((11, 14)));
        // An absent key falls back to its deepest written ancestor (the second light).
        let (line, _) = locate(src, "lights[1].beam_width").unwrap();
        assert!((6..=11).contains(&line), "{line}");
    }
}
