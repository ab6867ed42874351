//! The scene file's parameters (`[volume]`, `[transfer]`, `[sigma]`, `[phase]`, `[camera]`,
//! `[three_point]`, `[[lights]]`, `[integrator]`, `[film]`), their validation, and loading
//! the volume and medium they name.

use std::path::{Path, PathBuf};

use glam::Vec3;
use serde::{Deserialize, Serialize};

use super::camera::{Camera, CameraParams};
use super::diagnostics::{locate_error, toml_error};
use super::light::{Light, LightKind, LightParams, LightingStyle, ThreePointParams};
use super::settings::{FilmParams, IntegratorParams, Method};
use crate::error::{Error, Result};
use crate::medium::{
    ClipParams, ClipSpace, DEFAULT_BRICK_SIZE, MappingKind, Medium, MediumSettings, Phase,
    SigmaMapping, SigmaParams, TransferFunction, TransferParams, ViewFrame,
};
use crate::util::confined;
use crate::volume::{
    ByteOrder, DatasetOverrides, DicomInput, FileRequest, Normalization, PhantomParams, Placement,
    RawLayout, Reconstruction, SearchPath, Volume, VolumeSource, VoxelType, is_nifti, load_dataset,
    read_dicom_volume, read_volume,
};

/// `[volume]`: where the voxels come from and how they are placed and scaled.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct VolumeParams {
    /// A registry name (`foot`, `engine`, `head`, `head16`, `skeleton`, …).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub dataset: Option<String>,
    /// A file path, relative to the scene file (`.raw`, `.nrrd`, `.nhdr`, `.mhd`, `.mha`,
    /// `.nii`, `.nii.gz`, or a NIfTI pair's `.hdr`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub file: Option<PathBuf>,
    /// A DICOM series: a folder (searched recursively) or a list of files, relative to the
    /// scene file.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub dicom: Option<DicomInput>,
    /// With `dicom`: the SeriesInstanceUID to read when the input holds several series
    /// (default: the one with the most slices; equal candidates are an error).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub series: Option<String>,
    /// With `dicom`: interpolate a series with a missing slice or uneven gaps linearly onto
    /// its usual slice step (default: such a series is an error naming the gap).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub resample: bool,
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
    /// `type-range`, `min-max` or `window`; by default type-range for unsigned data and
    /// min-max for signed and float data.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub normalize: Option<NormalizeKind>,
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

/// How raw voxel values are scaled to densities (`[volume] normalize`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum NormalizeKind {
    /// Divide by the stored type's range (thesis §7.2.2).
    TypeRange,
    /// Map the data's own minimum and maximum onto `[0, 1]`.
    MinMax,
    /// Map the raw `window = [lo, hi]` onto `[0, 1]`, clamping outside.
    Window,
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
    /// Clip planes and a crop box (none by default; an empty `[clip]` leaves the scene's
    /// content address as it was).
    #[serde(default, skip_serializing_if = "ClipParams::is_empty")]
    pub clip: ClipParams,
}

impl SceneParams {
    /// Parses scene TOML; unknown keys and wrong types are located by line and column.
    pub fn from_toml(src: &str, file: &Path) -> Result<Self> {
        if let Ok(table) = src.parse::<toml::Table>()
            && let Some((key, value)) = beyond_f32(&toml::Value::Table(table), "")
        {
            let (line, column) = super::diagnostics::locate(src, &key).unwrap_or((1, 1));
            return Err(Error::Scene {
                file: file.to_path_buf(),
                line,
                column,
                message: format!(
                    "`{key}` = {value:e} is beyond what a 32-bit float holds (±{:e}): it would become infinity",
                    f32::MAX
                ),
            });
        }
        toml::from_str(src).map_err(|e| toml_error(&e, src, file))
    }

    /// Deserialises from an already-parsed table (e.g. a base scene with sweep overrides);
    /// errors name the key path but have no position.
    pub fn from_table(table: toml::Table) -> Result<Self> {
        if let Some((key, value)) = beyond_f32(&toml::Value::Table(table.clone()), "") {
            return Err(Error::Parameter {
                key,
                value: format!("{value:e}"),
                expected: format!(
                    "a number a 32-bit float holds (at most ±{:e}); it would become infinity",
                    f32::MAX
                ),
            });
        }
        let text = toml::to_string(&table).map_err(|e| Error::Parameter {
            key: "scene".into(),
            value: String::new(),
            expected: format!("a table that serialises to TOML ({e})"),
        })?;
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

    /// Whether a light of the scene has extent (an area light, an environment or sky, the
    /// cinematic three-point layout): only those are sampled `light_samples` times.
    pub fn has_light_with_extent(&self) -> bool {
        self.three_point
            .as_ref()
            .is_some_and(|tp| tp.style == LightingStyle::Cinematic)
            || self
                .lights
                .iter()
                .any(|l| !matches!(l.kind, LightKind::Spot | LightKind::Point))
    }

    /// The `[integrator]` keys a render of this scene never reads: the settings' own
    /// ([`IntegratorParams::ignored_keys`]), and `light_samples` where the marcher draws no
    /// direction from a light — every light a spot or point (a delta light is evaluated,
    /// never sampled), or no single scattering. Tested render by render, as the settings'.
    pub fn ignored_integrator_keys(&self) -> Vec<&'static str> {
        let mut keys = self.integrator.ignored_keys();
        let i = &self.integrator;
        if i.method == Method::Photon && (!i.single || !self.has_light_with_extent()) {
            keys.push("light_samples");
        }
        keys
    }

    /// These parameters with every `[integrator]` key a render ignores
    /// ([`SceneParams::ignored_integrator_keys`]) at its default: two scenes that differ
    /// only there render the same image, and this is what a content address is taken over.
    pub fn with_ignored_at_default(&self) -> SceneParams {
        let mut p = self.clone();
        p.integrator = self.integrator.with_ignored_at_default();
        if self.ignored_integrator_keys().contains(&"light_samples") {
            p.integrator.light_samples = IntegratorParams::default().light_samples;
        }
        p
    }
}

/// Reads and parses a scene file; parameter errors are located.
pub fn load_params(path: &Path) -> Result<(SceneParams, String)> {
    let src = crate::util::read_text_capped(path, crate::util::TEXT_INPUT_CAP, "scene file")?;
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
    // Environments are built (their maps read) with the scene, in `Scene::assemble`.
    for (i, l) in params.lights.iter().enumerate() {
        if !l.kind.needs_scene() {
            Light::create(l).map_err(|e| e.within(&format!("lights[{i}]")))?;
        }
    }
    if params.lights.is_empty() && params.three_point.is_none() {
        return Err(Error::parameter(
            "lights",
            "(none)",
            "at least one [[lights]] entry or a [three_point] table",
        ));
    }
    params.clip.validate().map_err(|e| e.within("clip"))?;
    volume_choice(&params.volume)?;
    Ok(())
}

enum VolumeChoice<'a> {
    Dataset(&'a str),
    File(&'a Path),
    Dicom(&'a DicomInput),
    Phantom(&'a PhantomParams),
}

/// Which source the `[volume]` table names, once its keys are checked to fit that source.
fn volume_choice(v: &VolumeParams) -> Result<VolumeChoice<'_>> {
    check_one_source(v)?;
    check_dicom_keys(v)?;
    check_raw_keys(v)?;
    check_placement_and_values(v)?;
    Ok(match (&v.dataset, &v.file, &v.phantom, &v.dicom) {
        (Some(d), _, _, _) => VolumeChoice::Dataset(d),
        (_, Some(f), _, _) => VolumeChoice::File(f),
        (_, _, Some(p), _) => VolumeChoice::Phantom(p),
        (_, _, _, Some(d)) => VolumeChoice::Dicom(d),
        _ => unreachable!("exactly one source checked above"),
    })
}

/// Exactly one of `dataset`, `file`, `dicom`, `phantom`.
fn check_one_source(v: &VolumeParams) -> Result<()> {
    let given = [
        v.dataset.is_some(),
        v.file.is_some(),
        v.phantom.is_some(),
        v.dicom.is_some(),
    ]
    .iter()
    .filter(|b| **b)
    .count();
    if given != 1 {
        return Err(Error::parameter(
            "volume",
            format!("{given} sources"),
            "exactly one of `dataset`, `file`, `dicom`, `phantom`",
        ));
    }
    Ok(())
}

/// `resample` and `series` only with `dicom`.
fn check_dicom_keys(v: &VolumeParams) -> Result<()> {
    if v.resample && v.dicom.is_none() {
        return Err(Error::parameter(
            "volume.resample",
            "true",
            "only with `dicom` (other formats carry their own regular spacing)",
        ));
    }
    if v.series.is_some() && v.dicom.is_none() {
        return Err(Error::given_without_use(
            "volume.series",
            "only with `dicom` (it picks a SeriesInstanceUID)",
        ));
    }
    Ok(())
}

/// The layout keys (`dims`, `voxel`, `byte_order`, `header_bytes`) only with a headerless
/// RAW file, which needs at least `dims` and `voxel`.
fn check_raw_keys(v: &VolumeParams) -> Result<()> {
    let raw_keys = [
        ("dims", v.dims.is_some()),
        ("voxel", v.voxel.is_some()),
        ("byte_order", v.byte_order.is_some()),
        ("header_bytes", v.header_bytes.is_some()),
    ];
    let is_raw_file = v.file.as_ref().is_some_and(|f| {
        !is_nifti(f)
            && !matches!(
                f.extension()
                    .and_then(|e| e.to_str())
                    .map(|e| e.to_ascii_lowercase())
                    .as_deref(),
                Some("nrrd" | "nhdr" | "mhd" | "mha")
            )
    });
    for (key, present) in raw_keys {
        if present && !is_raw_file {
            return Err(Error::given_without_use(
                format!("volume.{key}"),
                "only with a headerless RAW `file` (datasets and header files carry their own layout)",
            ));
        }
    }
    if is_raw_file && v.dims.is_none() {
        return Err(Error::parameter(
            "volume.dims",
            "(missing)",
            "[nx, ny, nz] for a RAW file",
        ));
    }
    if is_raw_file && v.voxel.is_none() {
        return Err(Error::parameter(
            "volume.voxel",
            "(missing)",
            "u8, i8, u16, i16 or f32 for a RAW file",
        ));
    }
    Ok(())
}

/// `box` or `spacing`, not both; `window` only with its normalisation, `sha256` only with
/// a `file`, no normalisation for phantoms.
fn check_placement_and_values(v: &VolumeParams) -> Result<()> {
    if v.bounds.is_some() && v.spacing.is_some() {
        return Err(Error::parameter(
            "volume.spacing",
            "(given with box)",
            "either `box` or `spacing`",
        ));
    }
    if v.window.is_some() && v.normalize != Some(NormalizeKind::Window) {
        return Err(Error::given_without_use(
            "volume.window",
            "only with normalize = \"window\"",
        ));
    }
    if v.sha256.is_some() && v.file.is_none() {
        return Err(Error::given_without_use(
            "volume.sha256",
            "only with `file`",
        ));
    }
    if v.phantom.is_some() && v.normalize.is_some() {
        return Err(Error::given_without_use(
            "volume.normalize",
            "no normalisation for phantoms (they are already in [0, 1])",
        ));
    }
    Ok(())
}

fn normalization(v: &VolumeParams) -> Result<Option<Normalization>> {
    match v.normalize {
        None => Ok(None),
        Some(NormalizeKind::TypeRange) => Ok(Some(Normalization::TypeRange)),
        Some(NormalizeKind::MinMax) => Ok(Some(Normalization::MinMax)),
        Some(NormalizeKind::Window) => {
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
            let path = confined(base, file, "the scene's folder")?;
            let raw_layout = v.dims.map(|dims| RawLayout {
                dims,
                voxel: v.voxel.unwrap_or(VoxelType::U8),
                byte_order: v.byte_order.unwrap_or_default(),
                header_bytes: v.header_bytes.unwrap_or(0),
            });
            read_volume(&FileRequest {
                path,
                raw_layout,
                placement: place,
                normalization: norm,
                dataset: None,
                expected_sha256: v.sha256.clone(),
            })
        }
        VolumeChoice::Dicom(input) => read_dicom_volume(
            &confined_dicom(input, base)?,
            v.series.as_deref(),
            v.resample,
            &FileRequest {
                path: base.to_path_buf(),
                raw_layout: None,
                placement: place,
                normalization: norm,
                dataset: None,
                expected_sha256: None,
            },
        ),
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

/// A DICOM folder or list of files named by a scene, resolved against its folder `base`
/// and confined to it as every file a scene names is ([`confined`]).
fn confined_dicom(input: &DicomInput, base: &Path) -> Result<DicomInput> {
    let inside = |p: &PathBuf| confined(base, p, "the scene's folder");
    Ok(match input {
        DicomInput::Folder(p) => DicomInput::Folder(inside(p)?),
        DicomInput::Files(files) => {
            DicomInput::Files(files.iter().map(inside).collect::<Result<_>>()?)
        }
    })
}

/// Millimetres per world unit: the volume's physical size (its placement spacing, else the
/// DICOM/NIfTI spacing, else 1 mm per voxel) over its world box.
fn mm_per_world(volume: &Volume) -> f64 {
    let acquired = match volume.source() {
        VolumeSource::File {
            acquisition: Some(a),
            ..
        } => Some(a.spacing_mm),
        _ => None,
    };
    let spacing = volume
        .spacing()
        .map(|s| s.map(f64::from))
        .or(acquired)
        .unwrap_or([1.0; 3]);
    let dims = volume.grid().dims();
    let extent_mm = (0..3)
        .map(|a| dims[a] as f64 * spacing[a])
        .fold(0.0, f64::max);
    extent_mm / volume.grid().bounds().largest_extent() as f64
}

/// The σ mapping: a colour transfer function takes `mapping = "opacity"` (implied when
/// `[sigma]` is left at its defaults); other transfer functions may not use it.
fn colour_mapping(params: &SceneParams, transfer: &TransferFunction) -> Result<SigmaMapping> {
    let colour = matches!(transfer, TransferFunction::Colour { .. });
    // A colour transfer function implies `mapping = "opacity"` unless the table names
    // another mapping's own keys (`albedo`, `scale`, `emission` belong to every mapping).
    let s = &params.sigma;
    let thesis_keys = s.t.is_some() || s.percent.is_some() || s.ratio.is_some();
    let explicit_keys = s.sigma_a.is_some() || s.sigma_s.is_some();
    let sigma = if colour && s.mapping == MappingKind::Thesis && !thesis_keys && !explicit_keys {
        SigmaParams {
            mapping: MappingKind::Opacity,
            ..s.clone()
        }
    } else {
        params.sigma.clone()
    };
    if colour != (sigma.mapping == MappingKind::Opacity) {
        return Err(Error::parameter(
            "sigma.mapping",
            sigma.mapping.name(),
            if colour {
                "\"opacity\" with a colour transfer function (σt comes from its opacity)"
            } else {
                "\"opacity\" only with a colour transfer function ([transfer] preset, file .vp or opacity/colour points)"
            },
        ));
    }
    SigmaMapping::create(&sigma).map_err(|e| e.within("sigma"))
}

/// Builds the medium for a scene from an already-loaded volume.
pub fn build_medium(params: &SceneParams, volume: &Volume, base: &Path) -> Result<Medium> {
    let transfer = TransferFunction::create(&params.transfer, base, volume.normalization())
        .map_err(|e| e.within("transfer"))?
        .with_world_scale(mm_per_world(volume));
    let mapping = colour_mapping(params, &transfer)?;
    let phase = Phase::henyey_greenstein(params.phase.g)
        .map_err(|_| Error::parameter("phase.g", params.phase.g, "an asymmetry in (-1, 1)"))?;
    Medium::create(
        volume,
        &MediumSettings {
            transfer,
            mapping,
            emission: Vec3::from(params.sigma.emission.unwrap_or([0.0; 3])),
            emission_colour: params.sigma.emission_colour,
            phase,
            reconstruction: params.volume.reconstruction,
            brick_size: params.volume.brick_size,
            clip: params.clip.clone(),
            clip_view: view_frame(params)?,
        },
    )
    .map_err(|e| match e {
        Error::Parameter { ref key, .. } if key == "brick_size" => e.within("volume"),
        other => other,
    })
}
/// The camera's frame for a clip in the view's space (`None` for any other clip).
fn view_frame(params: &SceneParams) -> Result<Option<ViewFrame>> {
    if params.clip.space != ClipSpace::View {
        return Ok(None);
    }
    let camera = super::Camera::create(&params.camera).map_err(|e| e.within("camera"))?;
    Ok(Some(ViewFrame {
        origin: camera.look_at(),
        right: camera.right(),
        up: camera.up(),
        forward: camera.forward(),
    }))
}

/// The first number of a scene (its dotted key and value) that no 32-bit float holds: the
/// scene's floats are `f32`, and serde turns `t = 1e39` into infinity without a word.
fn beyond_f32(value: &toml::Value, key: &str) -> Option<(String, f64)> {
    let join = |k: &str| {
        if key.is_empty() {
            k.to_string()
        } else {
            format!("{key}.{k}")
        }
    };
    match value {
        toml::Value::Float(f) if f.is_finite() && f.abs() > f64::from(f32::MAX) => {
            Some((key.to_string(), *f))
        }
        toml::Value::Table(t) => t.iter().find_map(|(k, v)| beyond_f32(v, &join(k))),
        toml::Value::Array(a) => a
            .iter()
            .enumerate()
            .find_map(|(i, v)| beyond_f32(v, &format!("{key}[{i}]"))),
        _ => None,
    }
}
