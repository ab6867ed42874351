//! # volphot
//!
//! Volume photon mapping for medical CT/MRI visualisation, after N. Henrich's 2006 study
//! *Photon Mapping zur Verbesserung medizinischer Volumenvisualisierung* (section numbers
//! `§…` in these docs refer to it), built for measured parameter studies.
//!
//! Data flows one way:
//!
//! volume file → [`volume::Volume`] (grid + reconstruction) → [`medium::Medium`] (transfer
//! function + σ mapping, majorant bricks) → [`scene::Scene`] (+ camera, lights) → photon
//! tracing → photon map → integrator → film (HDR, with separate single / multiple /
//! emission layers).
//!
//! ```
//! use std::path::Path;
//! use volphot::scene::{Scene, SceneParams};
//! use volphot::volume::registry::SearchPath;
//!
//! let src = r#"
//! [volume]
//! phantom = { name = "sphere", resolution = [16, 16, 16] }
//! [sigma]
//! t = 10
//! [three_point]
//! "#;
//! let params = SceneParams::from_toml(src, Path::new("inline.toml")).unwrap();
//! let scene = Scene::from_params(&params, Path::new("."), &SearchPath::new(vec![])).unwrap();
//! assert_eq!(scene.lights().len(), 3);
//! assert!((scene.medium().report().sigma_t_at_dmin - 10.0).abs() < 1e-4);
//! ```
#![warn(missing_docs)]

pub mod camera;
pub mod checksum;
pub mod error;
pub mod film;
pub mod fsutil;
pub mod geometry;
pub mod grid;
pub mod integrator;
pub mod light;
pub mod medium;
pub mod photon;
pub mod photon_map;
pub mod reference;
pub mod render;
pub mod rng;
pub mod sampling;
pub mod scene;
pub mod settings;
pub mod sigma;
pub mod transfer;
pub mod volume;

pub use error::{Error, Result};
