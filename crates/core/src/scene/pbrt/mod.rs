//! Import of the thesis's pbrt-v1 scene files ([`import_pbrt`]).
//!
//! The study's system was a pair of pbrt-v1 plugins (thesis §7): `Volume "rawvolumegrid"`
//! (§7.2.1) and `VolumeIntegrator "volphotonmap"` (§7.1.1). Their scenes are read with the
//! directives pbrt-v1 gives them meaning by — `LookAt`, the transform stack, `Camera
//! "perspective"`, `Film`, `Sampler`, `LightSource "spot"` / `"point"` / `"infinite"`
//! (constant, as a one-colour sky), `Include` — and
//! written as the equivalent volphot scene. Where pbrt-v1 and volphot differ the import
//! follows pbrt-v1's sources (`mmp/pbrt-v1`):
//! * `fov` spans the *shorter* image axis (`cameras/perspective.cpp`), volphot's the
//!   vertical one: portrait films are converted;
//! * a spot light's falloff is quartic in cosine between `coneangle − conedeltaangle` and
//!   `coneangle` (`lights/spot.cpp`): lights get `falloff = "pbrt"`;
//! * lights and the volume box are placed by the transform current at their statement;
//!   the camera by the one current at `Camera` (world to camera);
//! * densities are scaled to `[0, 1]` by the stored type's range (§7.2.2) and σ = base ×
//!   density (`mapping = "explicit"`); 16-bit files are read little-endian (the study ran
//!   on x86).
//!
//! Every statement, parameter or value that has no volphot meaning is returned in
//! [`PbrtImport::unmapped`] with its file, line and the reason, never dropped silently.

mod syntax;

use std::collections::HashMap;
use std::fmt;
use std::path::{Component, Path, PathBuf};
use std::rc::Rc;

use glam::{DMat4, DVec3};

use super::camera::{Camera, CameraParams};
use super::light::{Intensity, Light, LightKind, LightParams, SpotFalloff};
use super::params::{BoxParams, NormalizeKind, SceneParams, VolumeParams, validate_params};
use super::settings::IntegratorParams;
use crate::error::{Error, Result};
use crate::medium::{
    DEFAULT_BRICK_SIZE, MappingKind, SigmaMapping, SigmaParams, TransferFunction, TransferKind,
    TransferParams,
};
use crate::util::{TEXT_INPUT_CAP, byte_size, open_regular, read_text_capped};
use crate::volume::{DATASETS, VoxelType};
use syntax::{Param, Statement, Value};

/// A pbrt-v1 scene read into volphot's parameters.
#[derive(Debug, Clone, PartialEq)]
pub struct PbrtImport {
    /// The equivalent volphot scene (paths relative to the output folder given).
    pub params: SceneParams,
    /// Every statement or parameter that was not mapped, with the reason.
    pub unmapped: Vec<Unmapped>,
    /// Decisions the import made that a reader should know (a registered dataset used for a
    /// missing file, defaults taken).
    pub notes: Vec<String>,
    /// The `[integrator]` keys the file set (the rest stay at volphot's defaults).
    integrator_keys: Vec<&'static str>,
    source: PathBuf,
}

/// One part of a pbrt file the import could not express.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Unmapped {
    /// The file (the scene or one it includes).
    pub file: PathBuf,
    /// 1-based line of the statement.
    pub line: usize,
    /// The statement head, with the parameter if only that is unmapped.
    pub what: String,
    /// Why it has no volphot equivalent.
    pub reason: String,
}

impl Unmapped {
    /// `statement` (or only its parameter `what`) not mapped, because of `reason`.
    fn at(statement: &Statement, what: Option<&Param>, reason: &str) -> Self {
        Unmapped {
            file: statement.file.to_path_buf(),
            line: statement.line,
            what: match what {
                Some(p) => format!("{}: \"{} {}\"", statement.head(), p.ty, p.name),
                None => statement.head(),
            },
            reason: reason.to_string(),
        }
    }
}

impl fmt::Display for Unmapped {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{}:{}: {} — {}",
            printable(&self.file.display().to_string()),
            self.line,
            printable(&self.what),
            printable(&self.reason)
        )
    }
}

/// Reads the pbrt-v1 scene `path` (and the files it includes) into volphot parameters;
/// file paths in the result are written relative to `output_dir`, where the scene will be
/// saved. Errors name the file, line and directive; the result is validated as a scene
/// file would be.
///
/// ```
/// # fn main() -> Result<(), Box<dyn std::error::Error>> {
/// let dir = tempfile::tempdir()?;
/// std::fs::write(dir.path().join("v.raw"), vec![0u8; 8])?;
/// let pbrt = dir.path().join("scene.pbrt");
/// std::fs::write(&pbrt, r#"
///     LookAt 0.5 -2 0.5  0.5 0.5 0.5  0 0 1
///     Camera "perspective" "float fov" [30]
///     Film "image" "integer xresolution" [64] "integer yresolution" [64]
///     VolumeIntegrator "volphotonmap" "integer nused" [150] "float maxdist" .5
///     WorldBegin
///     LightSource "point" "color I" [5 5 5] "point from" [0.5 -1 2]
///     Volume "rawvolumegrid" "integer nx" 2 "integer ny" 2 "integer nz" 2
///         "string rawfile" "v.raw" "color sigma_a" [1 1 1] "color sigma_s" [10 10 10]
///     WorldEnd
/// "#)?;
/// let scene = volphot::import_pbrt(&pbrt, dir.path())?;
/// assert_eq!(scene.params.integrator.nused, 150);
/// assert!(scene.unmapped.is_empty());
/// # Ok(()) }
/// ```
pub fn import_pbrt(path: &Path, output_dir: &Path) -> Result<PbrtImport> {
    let mut splicer = Splicer::default();
    splicer.splice(path)?;
    let mut importer = Importer::new(output_dir);
    for statement in &splicer.out {
        importer.statement(statement)?;
    }
    importer.finish(path)
}

/// The most a scene with everything it includes may hold, a file counted each time an
/// `Include` splices it: 15 files each including the next four times would splice 4¹⁴
/// copies (past 60 s and 4 GB before these limits existed). The thesis's scenes hold a few
/// hundred tokens.
const MAX_TOKENS: usize = 1_000_000;
const MAX_BYTES: u64 = 64 << 20;
/// How deep `Include`s may nest.
const MAX_INCLUDE_DEPTH: usize = 16;

/// A file read once and spliced as often as it is included.
struct SceneFile {
    /// Its canonical path: a file that includes itself, through any path, is a cycle.
    canonical: PathBuf,
    statements: Vec<Statement>,
    tokens: usize,
    bytes: u64,
}

/// Reads a scene and splices its `Include`d files in place (relative to the including
/// file) within [`MAX_TOKENS`], [`MAX_BYTES`] and [`MAX_INCLUDE_DEPTH`]. Every file goes
/// through [`read_text_capped`] (regular files of at most 16 MiB), and an included file
/// must look like a pbrt scene before any of it is quoted ([`syntax::check_included`]).
#[derive(Default)]
struct Splicer {
    files: HashMap<PathBuf, Rc<SceneFile>>,
    tokens: usize,
    bytes: u64,
    out: Vec<Statement>,
    /// The `Include` statements leading to the file being read, outermost first.
    sites: Vec<Statement>,
    /// The canonical paths of the files being read, outermost first.
    open: Vec<PathBuf>,
}

impl Splicer {
    fn splice(&mut self, path: &Path) -> Result<()> {
        let file = match self.files.get(path) {
            Some(file) => file.clone(),
            None => self.read(path)?,
        };
        if self.open.contains(&file.canonical) {
            let message = format!("{} includes itself", path.display());
            return Err(self.chain_error(path, &message));
        }
        self.tokens += file.tokens;
        self.bytes += file.bytes;
        if self.tokens > MAX_TOKENS || self.bytes > MAX_BYTES {
            return Err(self.over_limits(path));
        }
        self.open.push(file.canonical.clone());
        for s in &file.statements {
            if s.directive != "Include" {
                self.out.push(s.clone());
                continue;
            }
            let folder = s.file.parent().unwrap_or(Path::new("."));
            let included = crate::util::confined(
                folder,
                Path::new(s.type_name()?),
                "the including file's folder",
            )
            .map_err(|e| s.error(e.to_string()))?;
            self.sites.push(s.clone());
            if self.sites.len() > MAX_INCLUDE_DEPTH {
                let message = format!("Includes nest more than {MAX_INCLUDE_DEPTH} deep");
                return Err(self.chain_error(&included, &message));
            }
            self.splice(&included)?;
            self.sites.pop();
        }
        self.open.pop();
        Ok(())
    }

    /// Reads, checks and parses `path` once (it is kept for further Includes).
    fn read(&mut self, path: &Path) -> Result<Rc<SceneFile>> {
        let src = read_text_capped(path, TEXT_INPUT_CAP, "pbrt scene file")
            .and_then(|src| {
                if !self.sites.is_empty() {
                    syntax::check_included(&src, path)?;
                }
                Ok(src)
            })
            .map_err(|e| self.at_site(e))?;
        let shared: Rc<Path> = Rc::from(path);
        let parsed = syntax::parse(&src, &shared, MAX_TOKENS - self.tokens)
            .map_err(|e| self.inside(e))?
            .ok_or_else(|| self.over_limits(path))?;
        let file = Rc::new(SceneFile {
            canonical: std::fs::canonicalize(path).unwrap_or_else(|_| path.to_path_buf()),
            statements: parsed.statements,
            tokens: parsed.tokens,
            bytes: src.len() as u64,
        });
        self.files.insert(path.to_path_buf(), file.clone());
        Ok(file)
    }

    /// `scene.pbrt:1 → a.pbrt:3 → b.pbrt`: the Includes that lead to the file being read,
    /// each file as the Include before it names it (the first as the scene's own path).
    fn chain(&self) -> String {
        let mut links = Vec::new();
        let mut file = match self.sites.first() {
            Some(s) => s.file.display().to_string(),
            None => String::new(),
        };
        for s in &self.sites {
            links.push(format!("{file}:{}", s.line));
            file = s.type_name().unwrap_or_default().to_string();
        }
        links.push(file);
        links.join(" → ")
    }

    /// An error about the included file as a whole (it cannot be read or is not a pbrt
    /// file), located at the `Include` that named it, with the chain when Includes nest.
    /// The scene file's own errors stand as they are.
    fn at_site(&self, e: Error) -> Error {
        match self.sites.as_slice() {
            [] => e,
            [site] => site.error(e.to_string()),
            [.., site] => site.error(format!("{e}; included through {}", self.chain())),
        }
    }

    /// An error at the innermost `Include`, naming the whole chain (or about `path`, the
    /// scene file, when there is none).
    fn chain_error(&self, path: &Path, message: &str) -> Error {
        match self.sites.last() {
            Some(site) => site.error(format!("{message}: {}", self.chain())),
            None => Error::format(path, message),
        }
    }

    /// An error located inside an included file, with the Includes that led there.
    fn inside(&self, e: Error) -> Error {
        match e {
            Error::Scene {
                file,
                line,
                column,
                message,
            } if !self.sites.is_empty() => {
                let chain = self.chain();
                Error::Scene {
                    file,
                    line,
                    column,
                    message: format!("{message} (included through {chain})"),
                }
            }
            e => e,
        }
    }

    fn over_limits(&self, path: &Path) -> Error {
        let message = format!(
            "the scene with the files it includes holds more than {MAX_TOKENS} tokens or {} (the import's limits; a file counts each time it is included: {} tokens and {} bytes so far)",
            byte_size(MAX_BYTES),
            self.tokens,
            self.bytes
        );
        self.chain_error(path, &message)
    }
}

/// The camera as the `Camera` statement left it (resolved once the film is known).
struct CameraState {
    world_to_camera: DMat4,
    /// The `LookAt` arguments when they alone made the transform (kept verbatim).
    look_at: Option<[DVec3; 3]>,
    statement: Statement,
}

/// The interpretation state: pbrt-v1's graphics state plus what has been mapped.
struct Importer {
    output_dir: PathBuf,
    ctm: DMat4,
    stack: Vec<(DMat4, Option<[DVec3; 3]>)>,
    named: HashMap<String, DMat4>,
    /// `LookAt` arguments while the CTM is exactly that `LookAt`.
    look_at: Option<[DVec3; 3]>,
    camera: Option<CameraState>,
    film: Option<Statement>,
    params: SceneParams,
    volume_seen: bool,
    integrator_keys: Vec<&'static str>,
    unmapped: Vec<Unmapped>,
    notes: Vec<String>,
}

impl Importer {
    fn new(output_dir: &Path) -> Self {
        Importer {
            output_dir: output_dir.to_path_buf(),
            ctm: DMat4::IDENTITY,
            stack: Vec::new(),
            named: HashMap::new(),
            look_at: None,
            camera: None,
            film: None,
            params: SceneParams {
                volume: VolumeParams::default(),
                transfer: TransferParams::default(),
                sigma: SigmaParams::default(),
                phase: Default::default(),
                camera: CameraParams::default(),
                three_point: None,
                lights: Vec::new(),
                integrator: IntegratorParams::default(),
                film: Default::default(),
                // pbrt-v1 has no clip planes.
                clip: Default::default(),
            },
            volume_seen: false,
            integrator_keys: Vec::new(),
            unmapped: Vec::new(),
            notes: Vec::new(),
        }
    }

    fn unmapped(&mut self, statement: &Statement, what: Option<&Param>, reason: &str) {
        self.unmapped.push(Unmapped::at(statement, what, reason));
    }

    /// Reports the parameters of `statement` that no mapping took.
    fn leftovers(&mut self, statement: &Statement, left: Vec<Param>) {
        for p in &left {
            self.unmapped(
                statement,
                Some(p),
                "no such parameter in pbrt-v1 or no volphot equivalent; ignored",
            );
        }
    }

    fn statement(&mut self, s: &Statement) -> Result<()> {
        match s.directive.as_str() {
            "LookAt" | "Translate" | "Scale" | "Rotate" | "Transform" | "ConcatTransform"
            | "Identity" | "CoordinateSystem" | "CoordSysTransform" => self.transform(s),
            "AttributeBegin" | "TransformBegin" => {
                s.numbers(0)?;
                self.stack.push((self.ctm, self.look_at));
                Ok(())
            }
            "AttributeEnd" | "TransformEnd" => {
                s.numbers(0)?;
                let (ctm, look_at) = self
                    .stack
                    .pop()
                    .ok_or_else(|| s.error("no matching AttributeBegin/TransformBegin"))?;
                (self.ctm, self.look_at) = (ctm, look_at);
                Ok(())
            }
            "WorldBegin" => {
                s.numbers(0)?;
                (self.ctm, self.look_at) = (DMat4::IDENTITY, None);
                self.named.insert("world".into(), self.ctm);
                Ok(())
            }
            "WorldEnd" => s.numbers(0).map(|_| ()),
            "Camera" => self.camera(s),
            "Film" => {
                self.film = Some(s.clone());
                Ok(())
            }
            "Sampler" => self.sampler(s),
            "VolumeIntegrator" => self.volume_integrator(s),
            "Volume" => self.volume(s),
            "LightSource" => self.light(s),
            "PixelFilter" => {
                self.unmapped(
                    s,
                    None,
                    "volphot's film averages its rays with a box filter",
                );
                Ok(())
            }
            "Shape" | "Material" | "Texture" | "AreaLightSource" | "SurfaceIntegrator"
            | "MakeNamedMaterial" | "NamedMaterial" | "ObjectBegin" | "ObjectEnd"
            | "ObjectInstance" | "ReverseOrientation" => {
                self.unmapped(s, None, "volphot renders a volume without surfaces");
                Ok(())
            }
            "Accelerator" | "SearchPath" => {
                self.unmapped(s, None, "not needed: volphot builds its own structures");
                Ok(())
            }
            _ => {
                self.unmapped(s, None, "not a pbrt-v1 directive volphot knows");
                Ok(())
            }
        }
    }

    /// The transform directives, post-multiplied onto the CTM as pbrt-v1's `api.cpp` does.
    fn transform(&mut self, s: &Statement) -> Result<()> {
        let was_identity = self.ctm == DMat4::IDENTITY;
        let m = match s.directive.as_str() {
            "LookAt" => {
                let v = s.numbers(9)?;
                let [eye, look, up] = [0, 3, 6].map(|i| DVec3::new(v[i], v[i + 1], v[i + 2]));
                let m = look_at(eye, look, up).ok_or_else(|| {
                    s.error("the eye equals the look-at point or `up` is parallel to the view")
                })?;
                self.ctm *= m;
                self.look_at = was_identity.then_some([eye, look, up]);
                return Ok(());
            }
            "Translate" => {
                let v = s.numbers(3)?;
                DMat4::from_translation(DVec3::new(v[0], v[1], v[2]))
            }
            "Scale" => {
                let v = s.numbers(3)?;
                if v.contains(&0.0) {
                    return Err(s.error("a scale factor of 0 collapses the scene"));
                }
                DMat4::from_scale(DVec3::new(v[0], v[1], v[2]))
            }
            "Rotate" => {
                let v = s.numbers(4)?;
                let axis = DVec3::new(v[1], v[2], v[3]);
                if axis.length() < 1e-12 {
                    return Err(s.error("the rotation axis is the zero vector"));
                }
                DMat4::from_axis_angle(axis.normalize(), v[0].to_radians())
            }
            "Transform" | "ConcatTransform" => {
                let v = s.numbers(16)?;
                let m = DMat4::from_cols_slice(&v);
                if m.determinant().abs() < 1e-12 {
                    return Err(s.error("the matrix is singular"));
                }
                if s.directive == "Transform" {
                    self.ctm = m;
                    self.look_at = None;
                    return Ok(());
                }
                m
            }
            "Identity" => {
                s.numbers(0)?;
                self.ctm = DMat4::IDENTITY;
                self.look_at = None;
                return Ok(());
            }
            "CoordinateSystem" => {
                self.named.insert(s.type_name()?.to_string(), self.ctm);
                return Ok(());
            }
            _ => {
                let name = s.type_name()?;
                self.ctm = *self
                    .named
                    .get(name)
                    .ok_or_else(|| s.error(format!("no coordinate system named `{name}`")))?;
                self.look_at = None;
                return Ok(());
            }
        };
        self.ctm *= m;
        self.look_at = None;
        Ok(())
    }

    fn camera(&mut self, s: &Statement) -> Result<()> {
        if s.type_name()? != "perspective" {
            self.unmapped(
                s,
                None,
                "volphot has a perspective (pinhole) camera only; its default camera is used",
            );
            return Ok(());
        }
        self.named.insert("camera".into(), self.ctm.inverse());
        self.camera = Some(CameraState {
            world_to_camera: self.ctm,
            look_at: self.look_at,
            statement: s.clone(),
        });
        Ok(())
    }

    fn sampler(&mut self, s: &Statement) -> Result<()> {
        let mut p = Params::of(s);
        let spp = match p.int("pixelsamples")? {
            Some(n) => Some(n),
            None => match (p.int("xsamples")?, p.int("ysamples")?) {
                (None, None) => None,
                (x, y) => Some(x.unwrap_or(2) * y.unwrap_or(2)),
            },
        };
        if let Some(spp) = spp {
            self.params.integrator.spp = positive_u32(s, "pixelsamples", spp)?;
            self.integrator_keys.push("spp");
        }
        self.unmapped(s, None, "volphot draws its own per-pixel random sequence (the sample count is kept as `integrator.spp`)");
        let left = p.finish();
        self.leftovers(s, left);
        Ok(())
    }

    fn volume_integrator(&mut self, s: &Statement) -> Result<()> {
        let mut p = Params::of(s);
        let kind = s.type_name()?.to_string();
        if !matches!(kind.as_str(), "volphotonmap" | "emission" | "single") {
            self.unmapped(
                s,
                None,
                "volphot's integrators are volphotonmap, single and emission",
            );
            return Ok(());
        }
        let integrator = &mut self.params.integrator;
        let mut keys = Vec::new();
        match kind.as_str() {
            "volphotonmap" => {
                if let Some(n) = p.int("volumephotons")? {
                    integrator.volume_photons = u64::try_from(n).map_err(|_| {
                        s.error(format!(
                            "\"integer volumephotons\" = {n}: expected a count >= 0"
                        ))
                    })?;
                    keys.push("volume_photons");
                }
                if let Some(n) = p.int("nused")? {
                    integrator.nused = positive_u32(s, "nused", n)?;
                    keys.push("nused");
                }
                if let Some(d) = p.float("maxdist")? {
                    integrator.maxdist = d as f32;
                    keys.push("maxdist");
                }
                for (name, key, slot) in [
                    ("emission", "emission", &mut integrator.emission),
                    ("single", "single", &mut integrator.single),
                    ("multiple", "multiple", &mut integrator.multiple),
                ] {
                    if let Some(b) = p.bool(name)? {
                        *slot = b;
                        keys.push(key);
                    }
                }
            }
            // pbrt-v1's own integrators: emission only, or emission plus single scattering.
            _ => {
                integrator.emission = true;
                integrator.single = kind == "single";
                integrator.multiple = false;
                keys.extend(["emission", "single", "multiple"]);
            }
        }
        if let Some(step) = p.float("stepsize")? {
            integrator.stepsize = step as f32;
            keys.push("stepsize");
        }
        integrator.validate().map_err(|e| s.error(e.to_string()))?;
        self.integrator_keys.extend(keys);
        let left = p.finish();
        self.leftovers(s, left);
        Ok(())
    }

    fn volume(&mut self, s: &Statement) -> Result<()> {
        if s.type_name()? != "rawvolumegrid" {
            self.unmapped(s, None, "volphot reads the thesis's `rawvolumegrid` volumes (and its own formats through [volume])");
            return Ok(());
        }
        if self.volume_seen {
            self.unmapped(
                s,
                None,
                "volphot renders one volume per scene; the first one is kept",
            );
            return Ok(());
        }
        self.volume_seen = true;
        let mut p = Params::of(s);
        let volume = raw_volume(s, &mut p, self.ctm, &self.output_dir, &mut self.notes)?;
        let (transfer, sigma, g) = raw_volume_medium(
            s,
            &mut p,
            &self.output_dir,
            &mut self.unmapped,
            &mut self.notes,
        )?;
        self.params.volume = volume;
        self.params.transfer = transfer;
        self.params.sigma = sigma;
        self.params.phase.g = g;
        let left = p.finish();
        self.leftovers(s, left);
        Ok(())
    }

    fn light(&mut self, s: &Statement) -> Result<()> {
        let kind = s.type_name()?;
        let mut p = Params::of(s);
        let intensity = p.triple("I", &["color", "rgb"])?.unwrap_or(DVec3::ONE);
        let from = p.triple("from", &["point"])?.unwrap_or(DVec3::ZERO);
        let position = self.ctm.transform_point3(from);
        let light = match kind {
            "point" => LightParams {
                kind: LightKind::Point,
                position: Some(position.as_vec3().to_array()),
                intensity: Some(intensity_of(intensity)),
                ..LightParams::default()
            },
            "spot" => {
                let to = p.triple("to", &["point"])?.unwrap_or(DVec3::Z);
                let cone = p.float("coneangle")?.unwrap_or(30.0);
                let delta = p.float("conedeltaangle")?.unwrap_or(5.0);
                if !(delta >= 0.0 && delta < cone) {
                    return Err(s.error(format!(
                        "\"float conedeltaangle\" = {delta}: expected an angle in [0, coneangle = {cone})"
                    )));
                }
                LightParams {
                    kind: LightKind::Spot,
                    position: Some(position.as_vec3().to_array()),
                    target: Some(self.ctm.transform_point3(to).as_vec3().to_array()),
                    intensity: Some(intensity_of(intensity)),
                    cone_angle: Some(cone as f32),
                    beam_width: Some((cone - delta) as f32),
                    falloff: Some(SpotFalloff::Pbrt),
                    ..LightParams::default()
                }
            }
            "infinite" => {
                let radiance = p.triple("L", &["color", "rgb"])?.unwrap_or(DVec3::ONE);
                if p.string("mapname")?.is_some() {
                    self.unmapped(
                        s,
                        None,
                        "pbrt-v1's infinite-light map (φ = atan2(y, x) about +z) is the mirror image of the equirectangular convention volphot and Mitsuba use: convert the map and write an `environment` light",
                    );
                    return Ok(());
                }
                // A constant environment: a sky of one colour (orientation is moot).
                let colour = Some(intensity_of(radiance));
                LightParams {
                    kind: LightKind::Sky,
                    zenith: colour,
                    horizon: colour,
                    ground: colour,
                    ..LightParams::default()
                }
            }
            _ => {
                self.unmapped(
                    s,
                    None,
                    "volphot imports spot, point and constant infinite lights (area lights are pbrt shapes: write them as `rect` or `disc` lights)",
                );
                return Ok(());
            }
        };
        if !light.kind.needs_scene() {
            Light::create(&light).map_err(|e| s.error(e.to_string()))?;
        }
        self.params.lights.push(light);
        let left = p.finish();
        self.leftovers(s, left);
        Ok(())
    }

    /// The camera from the `Camera` statement and the film; then the whole scene checked.
    fn finish(mut self, source: &Path) -> Result<PbrtImport> {
        let resolution = self.film_resolution()?;
        if let Some(camera) = self.camera.take() {
            self.params.camera = self.camera_params(&camera, resolution)?;
        } else {
            self.params.camera.resolution = resolution;
            self.notes
                .push("no `Camera` statement: volphot's default camera is used".into());
        }
        let file_error = |message: String| Error::Format {
            path: source.to_path_buf(),
            message,
        };
        if !self.volume_seen {
            return Err(file_error(
                "no `Volume \"rawvolumegrid\"` statement: there is nothing to render".into(),
            ));
        }
        if self.params.lights.is_empty() {
            return Err(file_error("no `LightSource \"spot\"` or `\"point\"` statement: volphot needs at least one light".into()));
        }
        validate_params(&self.params)
            .map_err(|e| file_error(format!("the imported scene is not valid: {e}")))?;
        // Film and camera are resolved last; report in the file's order.
        self.unmapped
            .sort_by(|a, b| (&a.file, a.line).cmp(&(&b.file, b.line)));
        Ok(PbrtImport {
            params: self.params,
            unmapped: self.unmapped,
            notes: self.notes.iter().map(|n| printable(n)).collect(),
            integrator_keys: self.integrator_keys,
            source: source.to_path_buf(),
        })
    }

    /// `Film "image"`'s resolution (pbrt-v1's default 640×480).
    fn film_resolution(&mut self) -> Result<[u32; 2]> {
        let Some(film) = self.film.take() else {
            self.notes
                .push("no `Film` statement: pbrt-v1's default 640×480 is used".into());
            return Ok([640, 480]);
        };
        let mut p = Params::of(&film);
        let x = p.int("xresolution")?.unwrap_or(640);
        let y = p.int("yresolution")?.unwrap_or(480);
        for name in ["filename", "cropwindow", "display"] {
            if let Some(param) = p.take(name) {
                self.unmapped(
                    &film,
                    Some(&param),
                    "volphot names and writes its own outputs (full frame)",
                );
            }
        }
        let left = p.finish();
        self.leftovers(&film, left);
        Ok([
            positive_u32(&film, "xresolution", x)?,
            positive_u32(&film, "yresolution", y)?,
        ])
    }

    /// The camera: position and axes from the inverse of the world-to-camera transform;
    /// pbrt-v1's `fov` spans the shorter image axis, volphot's the vertical one.
    fn camera_params(
        &mut self,
        camera: &CameraState,
        resolution: [u32; 2],
    ) -> Result<CameraParams> {
        let s = &camera.statement;
        let mut p = Params::of(s);
        let fov = p.float("fov")?.unwrap_or(90.0);
        let aspect = match p.float("frameaspectratio")? {
            Some(a) => a,
            None => resolution[0] as f64 / resolution[1] as f64,
        };
        for name in [
            "screenwindow",
            "lensradius",
            "focaldistance",
            "hither",
            "yon",
            "shutteropen",
            "shutterclose",
        ] {
            if let Some(param) = p.take(name) {
                self.unmapped(
                    s,
                    Some(&param),
                    "volphot's camera is a full-frame pinhole without clipping or shutter",
                );
            }
        }
        let left = p.finish();
        self.leftovers(s, left);
        let half = (fov.to_radians() / 2.0).tan();
        let vertical = if aspect > 1.0 {
            fov
        } else {
            2.0 * (half / aspect).atan().to_degrees()
        };
        let (eye, look, up) = match camera.look_at {
            Some([eye, look, up]) => (eye, look, up),
            None => {
                let to_world = camera.world_to_camera.inverse();
                let eye = to_world.transform_point3(DVec3::ZERO);
                let dir = to_world.transform_vector3(DVec3::Z).normalize();
                let up = to_world.transform_vector3(DVec3::Y);
                let right = to_world.transform_vector3(DVec3::X);
                if dir.cross(up).dot(right) < 0.0 {
                    self.unmapped(s, None, "the transform before `Camera` mirrors the image (e.g. `Scale -1 1 1`); volphot renders it unmirrored");
                }
                (eye, eye + dir, up)
            }
        };
        let params = CameraParams {
            eye: eye.as_vec3().to_array(),
            look_at: look.as_vec3().to_array(),
            up: up.as_vec3().to_array(),
            fov: vertical as f32,
            resolution,
        };
        Camera::create(&params).map_err(|e| s.error(e.to_string()))?;
        Ok(params)
    }
}

/// pbrt-v1's `LookAt` (world to camera), or `None` for a degenerate frame.
fn look_at(eye: DVec3, look: DVec3, up: DVec3) -> Option<DMat4> {
    let dir = (look - eye).try_normalize()?;
    let right = dir.cross(up).try_normalize()?;
    let new_up = right.cross(dir);
    let camera_to_world = DMat4::from_cols(
        right.extend(0.0),
        new_up.extend(0.0),
        dir.extend(0.0),
        eye.extend(1.0),
    );
    Some(camera_to_world.inverse())
}

fn intensity_of(i: DVec3) -> Intensity {
    if i.x == i.y && i.y == i.z {
        Intensity::Grey(i.x as f32)
    } else {
        Intensity::Rgb(i.as_vec3().to_array())
    }
}

fn positive_u32(s: &Statement, name: &str, n: i64) -> Result<u32> {
    u32::try_from(n).ok().filter(|n| *n > 0).ok_or_else(|| {
        s.error(format!(
            "\"integer {name}\" = {n}: expected a positive integer"
        ))
    })
}

/// `[volume]` from a `rawvolumegrid`: dims, the file, the stored type and the box.
fn raw_volume(
    s: &Statement,
    p: &mut Params,
    ctm: DMat4,
    output_dir: &Path,
    notes: &mut Vec<String>,
) -> Result<VolumeParams> {
    let mut dims = [0usize; 3];
    for (slot, name) in dims.iter_mut().zip(["nx", "ny", "nz"]) {
        let n = p
            .int(name)?
            .ok_or_else(|| s.error(format!("\"integer {name}\" is missing")))?;
        *slot = positive_u32(s, name, n)? as usize;
    }
    let voxel = match p.int("bits")?.unwrap_or(8) {
        8 => VoxelType::U8,
        16 => VoxelType::U16,
        b => return Err(s.error(format!("\"integer bits\" = {b}: expected 8 or 16 (§7.2.1)"))),
    };
    let raw = p
        .string("rawfile")?
        .ok_or_else(|| s.error("\"string rawfile\" is missing"))?;
    let p0 = p.triple("p0", &["point"])?.unwrap_or(DVec3::ZERO);
    let p1 = p.triple("p1", &["point"])?.unwrap_or(DVec3::ONE);
    let bounds = placed_box(s, ctm, p0, p1)?;
    let mut volume = VolumeParams {
        bounds: Some(bounds),
        normalize: Some(NormalizeKind::TypeRange),
        brick_size: DEFAULT_BRICK_SIZE,
        ..VolumeParams::default()
    };
    let folder = s.file.parent().unwrap_or(Path::new("."));
    let path = crate::util::confined(folder, Path::new(&raw), "the pbrt file's folder")
        .map_err(|e| s.error(format!("\"string rawfile\": {e}")))?;
    // A device or FIFO would reach the render as "0 bytes" (or block it): refuse it here.
    let exists = match open_regular(&path, "RAW volume file") {
        Ok(_) => true,
        Err(Error::Io { error, .. }) if error.kind() == std::io::ErrorKind::NotFound => false,
        Err(e) => return Err(s.error(format!("\"string rawfile\": {e}"))),
    };
    match (exists, registered_match(&raw, dims, voxel)) {
        (false, Some(name)) => {
            notes.push(format!(
                "rawfile `{}` ({}:{}) is not there; its size and type match the registered dataset `{name}`, which is used instead",
                path.display(),
                s.file.display(),
                s.line
            ));
            volume.dataset = Some(name.to_string());
        }
        (exists, _) => {
            if !exists {
                notes.push(format!(
                    "rawfile `{}` ({}:{}) does not exist yet: the scene loads once it is there",
                    path.display(),
                    s.file.display(),
                    s.line
                ));
            }
            volume.file = Some(relative_to(&path, output_dir));
            volume.dims = Some(dims);
            volume.voxel = Some(voxel);
        }
    }
    Ok(volume)
}

/// The box `p0..p1` under the CTM: translations and positive scales keep it an axis-aligned
/// box with the data unmirrored; anything else cannot be expressed.
fn placed_box(s: &Statement, ctm: DMat4, p0: DVec3, p1: DVec3) -> Result<BoxParams> {
    let linear = glam::DMat3::from_mat4(ctm);
    let axis_aligned = (0..3).all(|c| {
        (0..3).all(|r| r == c || linear.col(c)[r].abs() < 1e-9 * linear.col(c)[c].abs())
            && linear.col(c)[c] > 0.0
    });
    if !axis_aligned {
        return Err(s.error(
            "the current transform rotates or mirrors the volume; volphot volumes are axis-aligned boxes, so only Translate and positive Scale may precede a Volume",
        ));
    }
    let (a, b) = (ctm.transform_point3(p0), ctm.transform_point3(p1));
    if !(b.cmpgt(a).all()) {
        return Err(s.error(format!(
            "\"point p1\" {:?} must exceed \"point p0\" {:?} on every axis",
            b.to_array(),
            a.to_array()
        )));
    }
    Ok(BoxParams {
        p0: a.as_vec3().to_array(),
        p1: b.as_vec3().to_array(),
    })
}

/// The registered dataset a thesis file name stands for: same size and type, and (when
/// several match) the one whose name is in the file name (`foot.raw` → `foot`).
fn registered_match(raw: &str, dims: [usize; 3], voxel: VoxelType) -> Option<&'static str> {
    let stem = Path::new(raw).file_stem()?.to_string_lossy().to_lowercase();
    let fits: Vec<_> = DATASETS
        .iter()
        .filter(|d| d.dims == dims && d.voxel == voxel)
        .collect();
    match fits.as_slice() {
        [one] => Some(one.name),
        many => many.iter().find(|d| stem.contains(d.name)).map(|d| d.name),
    }
}

/// `[transfer]`, `[sigma]` and the phase asymmetry from a `rawvolumegrid`.
fn raw_volume_medium(
    s: &Statement,
    p: &mut Params,
    output_dir: &Path,
    unmapped: &mut Vec<Unmapped>,
    notes: &mut Vec<String>,
) -> Result<(TransferParams, SigmaParams, f32)> {
    let transfer_on = p.bool("transfer")?.unwrap_or(false);
    if !transfer_on && let Some(table) = p.take("transferfile") {
        let reason = "ignored: \"bool transfer\" is false";
        unmapped.push(Unmapped::at(s, Some(&table), reason));
    }
    let table = p.string("transferfile")?;
    let threshold = p.take("threshold");
    let mut transfer = TransferParams::default();
    match (transfer_on, table, threshold) {
        (true, None, _) => {
            return Err(s.error("\"bool transfer\" is true but \"string transferfile\" is missing"));
        }
        (true, Some(file), threshold) => {
            transfer.kind = TransferKind::Pgm;
            transfer.file = Some(pgm_transfer(s, &file, output_dir, notes)?);
            if let Some(t) = threshold {
                unmapped.push(Unmapped::at(s, Some(&t), "ignored: the transfer function applies (the threshold is the 16-bit rule without one, §7.2.1)"));
            }
        }
        (false, _, Some(t)) => {
            let value = Params::number_of(s, &t, &["integer", "float"])?;
            transfer.kind = TransferKind::Threshold;
            transfer.threshold = Some(value);
        }
        (false, _, None) => {}
    }
    let base =
        |v: Option<DVec3>, default: f64| v.unwrap_or(DVec3::splat(default)).as_vec3().to_array();
    let sigma = SigmaParams {
        mapping: MappingKind::Explicit,
        sigma_a: Some(base(p.triple("sigma_a", &["color", "rgb"])?, 1.0)),
        sigma_s: Some(base(p.triple("sigma_s", &["color", "rgb"])?, 1.0)),
        emission: p
            .triple("Le", &["color", "rgb"])?
            .map(|v| v.as_vec3().to_array())
            .filter(|e| *e != [0.0; 3]),
        ..SigmaParams::default()
    };
    SigmaMapping::create(&sigma).map_err(|e| s.error(e.within("sigma").to_string()))?;
    let g = p.float("g")?.unwrap_or(0.0) as f32;
    Ok((transfer, sigma, g))
}

/// The `transferfile` (relative to the statement's file), read now so that the render never
/// meets it first: a file that is not a 256×256 PGM is an error naming it (never quoting
/// it); a missing one is a note with the resolved path and an alternative, as a missing
/// `rawfile` is. Returns the path relative to `output_dir`.
fn pgm_transfer(
    s: &Statement,
    file: &str,
    output_dir: &Path,
    notes: &mut Vec<String>,
) -> Result<PathBuf> {
    let folder = s.file.parent().unwrap_or(Path::new("."));
    let path = crate::util::confined(folder, Path::new(file), "the pbrt file's folder")
        .map_err(|e| s.error(format!("\"string transferfile\": {e}")))?;
    match TransferFunction::from_pgm(&path) {
        Ok(_) => {}
        Err(Error::Io { error, .. }) if error.kind() == std::io::ErrorKind::NotFound => {
            notes.push(format!(
                "transferfile `{}` ({}:{}) does not exist: the render fails until it is there; or write [transfer] kind = \"points\" in its place (points = [[0.0, 0.0], [1.0, 1.0]] uses the densities as they are)",
                path.display(),
                s.file.display(),
                s.line
            ));
        }
        Err(e) => return Err(s.error(format!("\"string transferfile\": {e}"))),
    }
    Ok(relative_to(&path, output_dir))
}

/// `text` with its control characters escaped (`\n`, `\u{1b}`): a string's `\n` escape
/// would end a TOML comment and make the rest of its line TOML, and an escape sequence
/// would reach the terminal.
fn printable(text: &str) -> String {
    text.chars()
        .map(|c| {
            if c.is_control() {
                c.escape_default().to_string()
            } else {
                c.to_string()
            }
        })
        .collect()
}

/// `path` relative to `base` when both are on the same root, else absolute.
fn relative_to(path: &Path, base: &Path) -> PathBuf {
    let absolute = |p: &Path| std::path::absolute(p).unwrap_or_else(|_| p.to_path_buf());
    let (path, base) = (absolute(path), absolute(base));
    fn normal(p: &Path) -> Vec<Component<'_>> {
        let mut out: Vec<Component> = Vec::new();
        for c in p.components() {
            match c {
                Component::CurDir => {}
                Component::ParentDir if matches!(out.last(), Some(Component::Normal(_))) => {
                    out.pop();
                }
                c => out.push(c),
            }
        }
        out
    }
    let (p, b) = (normal(&path), normal(&base));
    let common = p.iter().zip(&b).take_while(|(x, y)| x == y).count();
    if common == 0 {
        return path;
    }
    let mut out = PathBuf::new();
    for _ in common..b.len() {
        out.push("..");
    }
    for c in &p[common..] {
        out.push(c.as_os_str());
    }
    out
}

/// A statement's parameters, taken one by one with their types checked.
struct Params<'a> {
    statement: &'a Statement,
    left: Vec<Param>,
}

impl<'a> Params<'a> {
    fn of(statement: &'a Statement) -> Self {
        Params {
            statement,
            left: statement.params.clone(),
        }
    }

    fn take(&mut self, name: &str) -> Option<Param> {
        let i = self.left.iter().position(|p| p.name == name)?;
        Some(self.left.remove(i))
    }

    fn finish(self) -> Vec<Param> {
        self.left
    }

    fn mismatch(s: &Statement, p: &Param, expected: &str) -> Error {
        let values: Vec<String> = p
            .values
            .iter()
            .map(|v| match v {
                Value::Number(x) => x.to_string(),
                Value::Text(t) => format!("\"{t}\""),
            })
            .collect();
        s.error(format!(
            "\"{} {}\" = [{}]: expected {expected}",
            p.ty,
            p.name,
            values.join(" ")
        ))
    }

    fn number_of(s: &Statement, p: &Param, types: &[&str]) -> Result<f64> {
        match p.values.as_slice() {
            [Value::Number(x)] if types.contains(&p.ty.as_str()) => Ok(*x),
            _ => Err(Self::mismatch(s, p, &format!("one {}", types.join(" or ")))),
        }
    }

    fn float(&mut self, name: &str) -> Result<Option<f64>> {
        let Some(p) = self.take(name) else {
            return Ok(None);
        };
        Self::number_of(self.statement, &p, &["float"]).map(Some)
    }

    fn int(&mut self, name: &str) -> Result<Option<i64>> {
        let Some(p) = self.take(name) else {
            return Ok(None);
        };
        match p.values.as_slice() {
            [Value::Number(x)] if p.ty == "integer" && x.fract() == 0.0 && x.abs() < 9e15 => {
                Ok(Some(*x as i64))
            }
            _ => Err(Self::mismatch(self.statement, &p, "one \"integer\"")),
        }
    }

    fn bool(&mut self, name: &str) -> Result<Option<bool>> {
        let Some(p) = self.take(name) else {
            return Ok(None);
        };
        match p.values.as_slice() {
            [Value::Text(t)] if p.ty == "bool" && (t == "true" || t == "false") => {
                Ok(Some(t == "true"))
            }
            _ => Err(Self::mismatch(
                self.statement,
                &p,
                "\"bool\" \"true\" or \"false\"",
            )),
        }
    }

    fn string(&mut self, name: &str) -> Result<Option<String>> {
        let Some(p) = self.take(name) else {
            return Ok(None);
        };
        match p.values.as_slice() {
            [Value::Text(t)] if p.ty == "string" => Ok(Some(t.clone())),
            _ => Err(Self::mismatch(self.statement, &p, "one \"string\"")),
        }
    }

    fn triple(&mut self, name: &str, types: &[&str]) -> Result<Option<DVec3>> {
        let Some(p) = self.take(name) else {
            return Ok(None);
        };
        match p.values.as_slice() {
            [Value::Number(x), Value::Number(y), Value::Number(z)]
                if types.contains(&p.ty.as_str()) =>
            {
                Ok(Some(DVec3::new(*x, *y, *z)))
            }
            _ => Err(Self::mismatch(
                self.statement,
                &p,
                &format!("three numbers as {}", types.join(" or ")),
            )),
        }
    }
}

impl PbrtImport {
    /// The scene as a volphot TOML file: a header naming the source, the notes and every
    /// unmapped line as comments, then the tables (integrator keys only where the file set
    /// them; everything else is volphot's default, which is the thesis's recommendation).
    pub fn to_toml(&self) -> String {
        let mut table = self.params.to_table();
        shortest_floats(&mut table);
        if let Some(toml::Value::Table(integrator)) = table.get_mut("integrator") {
            integrator.retain(|k, _| self.integrator_keys.contains(&k));
        }
        if let Some(toml::Value::Table(volume)) = table.get_mut("volume") {
            volume.retain(|k, _| !matches!(k, "reconstruction" | "brick_size"));
        }
        for key in ["film", "phase"] {
            let default = match key {
                "film" => toml::Table::try_from(super::settings::FilmParams::default()).ok(),
                _ => toml::Table::try_from(super::params::PhaseParams::default()).ok(),
            };
            if table.get(key).and_then(|v| v.as_table()) == default.as_ref() {
                table.remove(key);
            }
        }
        let mut out = format!(
            "# Imported by `sweep import` from {} (pbrt-v1, thesis §7).\n",
            printable(&self.source.display().to_string())
        );
        for note in &self.notes {
            out.push_str(&format!("# note: {note}\n"));
        }
        for u in &self.unmapped {
            out.push_str(&format!("# not mapped: {u}\n"));
        }
        out.push('\n');
        out.push_str(&toml::to_string(&table).unwrap_or_default());
        out
    }
}

/// Floats as the shortest decimal that reads back as the same `f32` (the parameters are
/// `f32`; TOML writes them widened, `-1.2000000476837158`).
fn shortest_floats(table: &mut toml::Table) {
    fn walk(value: &mut toml::Value) {
        match value {
            toml::Value::Float(x) => {
                *x = (*x as f32).to_string().parse().unwrap_or(*x);
            }
            toml::Value::Array(items) => items.iter_mut().for_each(walk),
            toml::Value::Table(t) => t.iter_mut().for_each(|(_, v)| walk(v)),
            _ => {}
        }
    }
    table.iter_mut().for_each(|(_, v)| walk(v));
}

#[cfg(test)]
mod tests;
