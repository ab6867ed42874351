//! Errors with user-facing text.
//!
//! Every error names its culprit: the file, the key (as a dotted path such as
//! `integrator.nused`), the offending value and what was expected. Constructors in this crate
//! validate their parameters and return [`Error::Parameter`]; the scene loader then adds the
//! file, line and column where the key was written ([`Error::Scene`]).

use std::path::{Path, PathBuf};

/// Result alias used throughout the crate.
pub type Result<T, E = Error> = std::result::Result<T, E>;

/// Everything that can go wrong while loading or rendering a scene.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// Reading or writing a file failed.
    #[error("{}: {error}", path.display())]
    Io {
        /// The file involved.
        path: PathBuf,
        /// The operating system's error (shown in the message, so not chained as a source).
        error: std::io::Error,
    },

    /// A file's content is not in the expected format.
    #[error("{}: {message}", path.display())]
    Format {
        /// The file involved.
        path: PathBuf,
        /// What is wrong and what was expected.
        message: String,
    },

    /// A parameter has a value outside its allowed range or of the wrong kind.
    #[error("`{key}` = {value}: expected {expected}")]
    Parameter {
        /// Dotted key path, e.g. `sigma.t`.
        key: String,
        /// The value as written.
        value: String,
        /// What is allowed.
        expected: String,
    },

    /// An error located in a scene or experiment file.
    #[error("{}:{line}:{column}: {message}", file.display())]
    Scene {
        /// The TOML file.
        file: PathBuf,
        /// 1-based line.
        line: usize,
        /// 1-based column.
        column: usize,
        /// The underlying message (names the key, value and expectation).
        message: String,
    },

    /// A named dataset could not be found on the search path.
    #[error(
        "dataset `{name}`: file `{file}` not found; searched {} (set VOLPHOT_DATA to the folder holding it)",
        searched.iter().map(|p| p.display().to_string()).collect::<Vec<_>>().join(", ")
    )]
    DatasetNotFound {
        /// Registry name.
        name: String,
        /// Expected file name.
        file: String,
        /// Folders searched, in order.
        searched: Vec<PathBuf>,
    },

    /// A file's checksum does not match the registry.
    #[error("{}: sha256 is {actual}, expected {expected} (the file is not the registered dataset)", path.display())]
    Checksum {
        /// The file involved.
        path: PathBuf,
        /// Registered checksum.
        expected: String,
        /// Computed checksum.
        actual: String,
    },

    /// A volume holds a NaN or infinite voxel.
    #[error(
        "{source_name}: voxel {index} (x = {x}, y = {y}, z = {z}) is {value}; every voxel must be a finite number (replace NaN/∞ in the data, e.g. with the background value)",
        x = position[0],
        y = position[1],
        z = position[2]
    )]
    NonFiniteVoxel {
        /// The file or phantom, described.
        source_name: String,
        /// Linear index `x + nx·(y + ny·z)` of the first bad voxel.
        index: usize,
        /// Its position `(x, y, z)`.
        position: [usize; 3],
        /// The value found.
        value: f32,
    },

    /// A render was asked to use a photon map it was not given.
    #[error(
        "multiple-scattering variant uses photon map {index} but {given} map(s) were given (build one with build_photon_map)"
    )]
    MissingPhotonMap {
        /// The index asked for.
        index: usize,
        /// How many maps were given.
        given: usize,
    },

    /// Two images (or an image and a scene) that must have the same size do not.
    #[error("{what} is {}×{} but {other} is {}×{}", size[0], size[1], other_size[0], other_size[1])]
    SizeMismatch {
        /// The first image.
        what: String,
        /// Its size.
        size: [usize; 2],
        /// What it must match.
        other: String,
        /// That size.
        other_size: [usize; 2],
    },

    /// A render ran past its time limit and was stopped.
    #[error(
        "stopped after the time limit of {seconds} s (raise it with --cell-timeout, or make the cell cheaper: fewer pixels, photons or samples, a larger stepsize)"
    )]
    TimeLimit {
        /// The limit, in seconds.
        seconds: f64,
    },

    /// A progressive render cannot resume from a film that lacks its statistics.
    #[error(
        "{what}: the film has no variance layers to resume from (render it again from the start)"
    )]
    CannotResume {
        /// The film.
        what: String,
    },
}

impl Error {
    /// A parameter error naming `key`, its `value` and the `expected` range.
    pub fn parameter(
        key: impl Into<String>,
        value: impl std::fmt::Display,
        expected: impl Into<String>,
    ) -> Self {
        Error::Parameter {
            key: key.into(),
            value: value.to_string(),
            expected: expected.into(),
        }
    }

    /// A parameter error for `key`, given where it does not apply: its value reads
    /// "(given)" and `expected` says where it would.
    pub fn given_without_use(key: impl Into<String>, expected: impl Into<String>) -> Self {
        Error::parameter(key, "(given)", expected)
    }

    /// A format error for `path`.
    pub fn format(path: impl AsRef<Path>, message: impl Into<String>) -> Self {
        Error::Format {
            path: path.as_ref().to_path_buf(),
            message: message.into(),
        }
    }

    /// An I/O error for `path`.
    pub fn io(path: impl AsRef<Path>, error: std::io::Error) -> Self {
        Error::Io {
            path: path.as_ref().to_path_buf(),
            error,
        }
    }

    /// Prefixes the key of a [`Error::Parameter`] with `prefix.` so that a component's own
    /// key (`t`) becomes the scene's key path (`sigma.t`). Other errors pass unchanged.
    pub fn within(self, prefix: &str) -> Self {
        match self {
            Error::Parameter {
                key,
                value,
                expected,
            } => Error::Parameter {
                key: if key.is_empty() {
                    prefix.to_string()
                } else {
                    format!("{prefix}.{key}")
                },
                value,
                expected,
            },
            other => other,
        }
    }
}

/// Checks that a floating-point parameter is finite and inside `[lo, hi]`.
pub fn check_range(key: &str, value: f64, lo: f64, hi: f64) -> Result<()> {
    if value.is_finite() && value >= lo && value <= hi {
        Ok(())
    } else {
        Err(Error::parameter(
            key,
            value,
            format!("a finite number in [{lo}, {hi}]"),
        ))
    }
}

/// Checks that a floating-point parameter is finite and strictly positive.
pub fn check_positive(key: &str, value: f64) -> Result<()> {
    if value.is_finite() && value > 0.0 {
        Ok(())
    } else {
        Err(Error::parameter(key, value, "a finite number > 0"))
    }
}

/// Checks that a floating-point parameter is finite and not negative.
pub fn check_non_negative(key: &str, value: f64) -> Result<()> {
    if value.is_finite() && value >= 0.0 {
        Ok(())
    } else {
        Err(Error::parameter(key, value, "a finite number >= 0"))
    }
}

/// Checks every component of an RGB triple with [`check_non_negative`].
pub fn check_rgb_non_negative(key: &str, value: [f32; 3]) -> Result<()> {
    if value.iter().all(|v| v.is_finite() && *v >= 0.0) {
        Ok(())
    } else {
        Err(Error::parameter(
            key,
            format!("{value:?}"),
            "three finite numbers >= 0",
        ))
    }
}
