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

mod area;
mod camera;
mod diagnostics;
mod environment;
mod envmap;
mod estimator;
mod export;
mod light;
mod params;
mod pbrt;
mod settings;

use std::path::Path;
use std::sync::Arc;

pub use area::{AreaLight, AreaShape};
pub use camera::{Camera, CameraParams};
pub use diagnostics::{key_at, line_col, locate, locate_error, toml_error};
pub use environment::{EnvironmentLight, EnvironmentSource, SKY_MAP_WIDTH, SkyColours, Sun};
pub use envmap::EnvironmentMap;
pub use estimator::{Estimate, InitialRadius, Kernel, MsEstimator, PassCost, RadiusRule, Traces};
pub use export::{MitsubaExport, export_mitsuba};
pub use light::{
    CINEMATIC_KEY_DEGREES, Incident, Intensity, Light, LightContext, LightKind, LightParams,
    LightingStyle, PointLight, SpotFalloff, SpotLight, ThreePointParams, three_point,
};
pub use params::{
    BoxParams, NormalizeKind, PhaseParams, SceneParams, VolumeParams, build_medium, load_params,
    load_volume, validate_params,
};
pub use pbrt::{PbrtImport, Unmapped, import_pbrt};
pub use settings::{
    DEFAULT_ALPHA, DEFAULT_SHADOW_TOLERANCE, DEFAULT_THIN_BELOW, EyeRays, FilmParams,
    IntegratorParams, MAX_PHOTONS, Method, Quadrature, ShadowEstimator, Tracker,
};

use crate::error::Result;
use crate::medium::Medium;
use crate::volume::{SearchPath, VolumeSource};

/// The most marching samples an eye or shadow ray may take through the volume.
pub const MAX_MARCH_STEPS: f64 = 1e7;

/// A step so small against the volume that one ray takes more than [`MAX_MARCH_STEPS`]
/// samples would make a render run for days: refused, naming the key.
fn check_march_length(params: &SceneParams, medium: &Medium) -> Result<()> {
    let diagonal = medium.bounds().diagonal() as f64;
    let step = params.integrator.stepsize as f64;
    if diagonal / step > MAX_MARCH_STEPS {
        return Err(crate::error::Error::parameter(
            "integrator.stepsize",
            step,
            format!(
                "a step of at least {:.3e}: the volume's diagonal ({diagonal}) over at most {MAX_MARCH_STEPS:e} samples per ray",
                diagonal / MAX_MARCH_STEPS
            ),
        ));
    }
    Ok(())
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
        // `load_params` has checked the parameters (locating errors in the file).
        let (params, src) = load_params(path)?;
        let base = path.parent().unwrap_or(Path::new("."));
        Self::build_checked(&params, base, search).map_err(|e| locate_error(e, &src, path))
    }

    /// Builds a scene from parameters (errors carry key paths, not positions).
    pub fn from_params(params: &SceneParams, base: &Path, search: &SearchPath) -> Result<Self> {
        validate_params(params)?;
        Self::build_checked(params, base, search)
    }

    /// [`Self::from_params`] for parameters [`validate_params`] has passed.
    fn build_checked(params: &SceneParams, base: &Path, search: &SearchPath) -> Result<Self> {
        let volume = load_volume(&params.volume, base, search)?;
        let medium = build_medium(params, &volume, base)?;
        Self::assemble_checked(params, Arc::new(medium), volume.source().clone(), base)
    }

    /// Builds a scene around an existing medium (shared between sweep cells); `base` is the
    /// scene file's folder (an environment's relative `file`).
    pub fn assemble(
        params: &SceneParams,
        medium: Arc<Medium>,
        volume_source: VolumeSource,
        base: &Path,
    ) -> Result<Self> {
        validate_params(params)?;
        Self::assemble_checked(params, medium, volume_source, base)
    }

    /// [`Self::assemble`] for parameters [`validate_params`] has passed: each is checked
    /// once on every way in.
    fn assemble_checked(
        params: &SceneParams,
        medium: Arc<Medium>,
        volume_source: VolumeSource,
        base: &Path,
    ) -> Result<Self> {
        check_march_length(params, &medium)?;
        let camera = Camera::create(&params.camera).map_err(|e| e.within("camera"))?;
        let mut lights = Vec::new();
        if let Some(tp) = &params.three_point {
            lights.extend(
                three_point(&camera, &medium.bounds(), tp).map_err(|e| e.within("three_point"))?,
            );
        }
        let bounds = medium.bounds();
        let context = LightContext {
            bounds: &bounds,
            base,
        };
        for (i, l) in params.lights.iter().enumerate() {
            lights
                .push(Light::create_in(l, context).map_err(|e| e.within(&format!("lights[{i}]")))?);
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

    /// A copy whose `[three_point]` lights are of another style (the scene's other lights
    /// kept); an error naming `three_point` if the scene has none.
    pub fn with_lighting_style(&self, style: LightingStyle) -> Result<Self> {
        let Some(tp) = &self.params.three_point else {
            return Err(crate::error::Error::parameter(
                "three_point",
                "(none)",
                "a [three_point] table whose lights take the style",
            ));
        };
        let tp = ThreePointParams {
            style,
            ..tp.clone()
        };
        // The preset's lights come first, the scene's own `[[lights]]` after them.
        let before = self.lights.len() - self.params.lights.len();
        let preset = three_point(&self.camera, &self.medium.bounds(), &tp)
            .map_err(|e| e.within("three_point"))?;
        let mut s = self.clone();
        s.lights = preset
            .into_iter()
            .chain(self.lights[before..].iter().cloned())
            .collect();
        s.params.three_point = Some(tp);
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
}
