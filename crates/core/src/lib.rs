//! # volphot
//!
//! Volume photon mapping for medical CT/MRI visualisation, after N. Henrich's 2006 study
//! *Photon Mapping zur Verbesserung medizinischer Volumenvisualisierung* (section numbers
//! `§…` in these docs refer to it), built for measured parameter studies.
//!
//! Data flows one way, one module per stage:
//!
//! ```text
//! volume ─→ medium ─→ scene ─→ photon tracing ─→ photon map ─→ integrator ─→ film
//! (file,     (transfer  (camera,  (free paths,     (kd-tree,     (ray marching  (layers,
//!  phantom,   function, lights,    Russian          radiance      + caches; or   EXR/PNG/
//!  registry)  σ, bricks) params)   roulette)        estimate)     reference)     PFM)
//! ```
//!
//! * [`Volume`] — a normalised density grid from RAW/NRRD/MetaImage, a phantom or the
//!   dataset registry ([`load_dataset`], [`read_volume`]);
//! * [`Medium`] — transfer function + σ mapping + phase function, majorant bricks, and every
//!   free-path tracker on one collision loop;
//! * [`Scene`] — a medium with camera, lights and integrator settings, loaded from a TOML
//!   scene file ([`Scene::load`]) with located errors;
//! * [`trace`] and [`PhotonMap`] — photon tracing and the volume photon map (§5);
//! * [`render_march`] (the thesis's integrator, §6) and [`render_reference`] (the unbiased
//!   path tracer);
//! * [`Film`] — single / multiple / emission layers from one pass; [`rmse`] and
//!   [`agreement`] (bias and per-pixel p99, as `sweep bench` measures) compare two images;
//! * [`render`] — the one-call entry, and [`render_shared`] for several settings from one
//!   march.
//!
//! ```
//! use std::path::Path;
//! use volphot::{Control, Layer, Scene, SceneParams, SearchPath, render};
//!
//! let src = r#"
//! [volume]
//! phantom = { name = "sphere", resolution = [16, 16, 16] }
//! [sigma]
//! t = 10
//! [camera]
//! resolution = [16, 16]
//! [three_point]
//! [integrator]
//! volume_photons = 2000
//! stepsize = 0.01
//! "#;
//! let params = SceneParams::from_toml(src, Path::new("inline.toml")).unwrap();
//! let scene = Scene::from_params(&params, Path::new("."), &SearchPath::new(vec![])).unwrap();
//! assert_eq!(scene.lights().len(), 3);
//! assert!((scene.medium().report().sigma_t_at_dmin - 10.0).abs() < 1e-4);
//!
//! let out = render(&scene, &Control::none()).unwrap();
//! assert!(out.film.mean(Layer::Single) > 0.0);
//! assert!(out.film.mean(Layer::Multiple) > 0.0);
//! ```
#![deny(missing_docs)]

mod control;
mod counters;
mod error;
mod film;
mod integrator;
mod math;
mod medium;
mod photon;
mod render;
mod render_warnings;
mod scene;
mod util;
mod volume;

#[cfg(any(test, feature = "test-util"))]
pub mod test_util;

pub use control::Control;
pub use counters::{Counter, Counting, Counts};
pub use error::{Error, Result, check_non_negative};
pub use film::{
    Agreement, Film, Layer, agreement, luminance, mean_rgb, read_pfm, rmse, to_srgb8, write_pfm,
    write_png, write_png_rgb8,
};
pub use integrator::{
    Budget, CACHE_TAU_MAX, CacheError, CpuSplit, ErrorBound, EyeProbe, LayerVariance, MarchOutput,
    MarchStats, MsVariant, PixelClass, ProgressiveOutput, ProgressiveStats, ReferenceAccumulator,
    Route, SOURCES, Source, StopReason, ThinningError, Variant, error_probe_pixels, next_radius,
    probe_eye_rays, progress_rows, reference_budget, render_march, render_march_beams,
    render_march_planes, render_progressive, render_reference,
};
pub use math::{
    Aabb, AliasTable, Domain, Frame, PiecewiseConstant1D, PiecewiseConstant2D, Ray, Rng, Sphere,
};
pub use medium::{
    ClipParams, ClipPlaneParams, ClipRegion, ClipSpace, Coefficients, ColourTransfer,
    CropBoxParams, FreePath, HalfSpace, MIN_MEAN_FREE_PATH, MajorantGrid, MajorantSegment,
    MajorantSegments, MappingKind, Medium, MediumSettings, Pgm, Phase, SigmaMapping, SigmaParams,
    SigmaReport, Split, THESIS_ALBEDO, THESIS_T, TransferFunction, TransferKind, TransferParams,
    ViewFrame, blocked_depth, sample_interaction_march, sample_interaction_thesis, write_pgm,
};
pub use photon::{
    BeamMap, BeamRadius, Crossing, GatherScratch, GatherVariant, Gathered, Photon, PhotonMap,
    PhotonPlane, PhotonStats, PlaneCrossing, PlaneMap, TraceSettings, trace, trace_planes,
};
pub use render::{
    Provenance, RenderOutput, RenderRecord, SharedFilm, SharedRender, Timings, build_photon_map,
    march_key, photon_map_key, record, render, render_shared, shared_progress_units,
};
pub use render_warnings::{
    PHOTONS_PER_NUSED, PhotonKey, RenderWarning, TRANSPARENT_FREE_PATH_PERCENT, render_warnings,
};
pub use scene::{
    AreaLight, AreaShape, BoxParams, CINEMATIC_KEY_DEGREES, Camera, CameraParams, DEFAULT_ALPHA,
    DEFAULT_SHADOW_TOLERANCE, DEFAULT_THIN_BELOW, EnvironmentLight, EnvironmentMap,
    EnvironmentSource, Estimate, EyeRays, FilmParams, Incident, InitialRadius, IntegratorParams,
    Intensity, Light, LightContext, LightKind, LightParams, LightingStyle, MAX_MARCH_STEPS,
    MAX_PHOTONS, Method, MitsubaExport, MsEstimator, NormalizeKind, PassCost, PbrtImport,
    PhaseParams, PointLight, Quadrature, RadiusRule, SKY_MAP_WIDTH, Scene, SceneParams,
    ShadowEstimator, SkyColours, SpotFalloff, SpotLight, Sun, ThreePointParams, Tracker, Unmapped,
    VolumeParams, build_medium, export_mitsuba, import_pbrt, key_at, line_col, load_params,
    load_volume, locate, locate_error, three_point, toml_error, validate_params,
};
pub use util::{
    TEXT_INPUT_CAP, byte_size, confined, escaped_prefix, hostname, is_stale_temp,
    memory_budget_bytes, open_regular, peak_memory_bytes, process_cpu_seconds, read_bytes_capped,
    read_text_capped, sha256_bytes, sha256_cached, sha256_content, sha256_file, temp_sibling,
    write_atomic,
};
pub use volume::{
    Acquisition, ByteOrder, DATASETS, DatasetInfo, DatasetOverrides, DatasetStatus, DicomInput,
    FileRequest, Grid, LoadedVoxels, Normalization, NormalizationRecord, Orientation,
    PhantomParams, Placement, RawLayout, Reconstruction, SearchPath, Volume, VolumeSource,
    VoxelType, check_dims, find_dataset, load_dataset, read_dicom_series, read_dicom_volume,
    read_metaimage, read_nifti, read_nrrd, read_volume, read_voxels, survey_datasets,
    write_metaimage, write_nrrd,
};
