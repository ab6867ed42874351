//! A pinhole look-at camera.
//!
//! Conventions: `fov` is the full vertical angle in degrees; row 0 is the top of the image,
//! column 0 the left; the image's right is `forward × up` (right-handed world).
//!
//! ```
//! use volphot::{Camera, CameraParams};
//! let camera = Camera::create(&CameraParams::default()).unwrap();
//! let centre = camera.ray(256.0, 256.0);
//! assert!((centre.direction - camera.forward()).length() < 1e-6);
//! ```

use glam::Vec3;
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::math::Ray;

/// Camera parameters as written in a scene's `[camera]` table.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraParams {
    /// Eye position.
    #[serde(default = "default_eye")]
    pub eye: [f32; 3],
    /// Point looked at.
    #[serde(default = "default_look_at")]
    pub look_at: [f32; 3],
    /// Up hint (need not be orthogonal to the view direction).
    #[serde(default = "default_up")]
    pub up: [f32; 3],
    /// Full vertical field of view in degrees.
    #[serde(default = "default_fov")]
    pub fov: f32,
    /// `[width, height]` in pixels (thesis: 512×512).
    #[serde(default = "default_resolution")]
    pub resolution: [u32; 2],
}

fn default_eye() -> [f32; 3] {
    [0.5, -2.2, 0.5]
}
fn default_look_at() -> [f32; 3] {
    [0.5, 0.5, 0.5]
}
fn default_up() -> [f32; 3] {
    [0.0, 0.0, 1.0]
}
fn default_fov() -> f32 {
    30.0
}
fn default_resolution() -> [u32; 2] {
    [512, 512]
}

impl Default for CameraParams {
    fn default() -> Self {
        CameraParams {
            eye: default_eye(),
            look_at: default_look_at(),
            up: default_up(),
            fov: default_fov(),
            resolution: default_resolution(),
        }
    }
}

/// A validated pinhole camera.
#[derive(Debug, Clone, PartialEq)]
pub struct Camera {
    eye: Vec3,
    look_at: Vec3,
    forward: Vec3,
    right: Vec3,
    up: Vec3,
    tan_half_fov: f32,
    width: u32,
    height: u32,
}

impl Camera {
    /// Validates the parameters and builds the camera frame.
    pub fn create(params: &CameraParams) -> Result<Self> {
        let eye = Vec3::from(params.eye);
        let look_at = Vec3::from(params.look_at);
        let up_hint = Vec3::from(params.up);
        if !eye.is_finite() {
            return Err(Error::parameter(
                "eye",
                format!("{:?}", params.eye),
                "three finite numbers",
            ));
        }
        if !look_at.is_finite() || (look_at - eye).length() < 1e-6 {
            return Err(Error::parameter(
                "look_at",
                format!("{:?}", params.look_at),
                "a finite point different from `eye`",
            ));
        }
        let forward = (look_at - eye).normalize();
        if !up_hint.is_finite()
            || up_hint.length() < 1e-6
            || forward.cross(up_hint.normalize()).length() < 1e-4
        {
            return Err(Error::parameter(
                "up",
                format!("{:?}", params.up),
                "a non-zero vector not parallel to the view direction",
            ));
        }
        if !(params.fov.is_finite() && params.fov > 0.0 && params.fov < 179.0) {
            return Err(Error::parameter(
                "fov",
                params.fov,
                "a vertical angle in (0, 179) degrees",
            ));
        }
        let [w, h] = params.resolution;
        if !(1..=16384).contains(&w) || !(1..=16384).contains(&h) {
            return Err(Error::parameter(
                "resolution",
                format!("{:?}", params.resolution),
                "[width, height] in 1..=16384",
            ));
        }
        let right = forward.cross(up_hint).normalize();
        let up = right.cross(forward);
        Ok(Camera {
            eye,
            look_at,
            forward,
            right,
            up,
            tan_half_fov: (params.fov.to_radians() * 0.5).tan(),
            width: w,
            height: h,
        })
    }

    /// The same camera at another resolution (for quality presets).
    pub fn with_resolution(&self, width: u32, height: u32) -> Self {
        Camera {
            width,
            height,
            ..self.clone()
        }
    }

    /// Eye position.
    pub fn eye(&self) -> Vec3 {
        self.eye
    }

    /// Look-at point.
    pub fn look_at(&self) -> Vec3 {
        self.look_at
    }

    /// Unit view direction.
    pub fn forward(&self) -> Vec3 {
        self.forward
    }

    /// Unit image-right direction.
    pub fn right(&self) -> Vec3 {
        self.right
    }

    /// Unit image-up direction.
    pub fn up(&self) -> Vec3 {
        self.up
    }

    /// Image width in pixels.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Image height in pixels.
    pub fn height(&self) -> u32 {
        self.height
    }

    /// The ray through film position `(x, y)` in pixels (`(0, 0)` is the top-left corner,
    /// pixel centres at `+0.5`).
    pub fn ray(&self, x: f32, y: f32) -> Ray {
        let aspect = self.width as f32 / self.height as f32;
        let sx = (2.0 * x / self.width as f32 - 1.0) * aspect * self.tan_half_fov;
        let sy = (1.0 - 2.0 * y / self.height as f32) * self.tan_half_fov;
        Ray::new(self.eye, self.forward + self.right * sx + self.up * sy)
    }

    /// The film position where world point `p` projects, if in front of the camera.
    pub fn project(&self, p: Vec3) -> Option<(f32, f32)> {
        let d = p - self.eye;
        let z = d.dot(self.forward);
        if z <= 0.0 {
            return None;
        }
        let aspect = self.width as f32 / self.height as f32;
        let sx = d.dot(self.right) / z / (aspect * self.tan_half_fov);
        let sy = d.dot(self.up) / z / self.tan_half_fov;
        Some((
            (sx + 1.0) * 0.5 * self.width as f32,
            (1.0 - sy) * 0.5 * self.height as f32,
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn image_axes_follow_conventions() {
        let cam = Camera::create(&CameraParams {
            eye: [0.0, 0.0, 5.0],
            look_at: [0.0, 0.0, 0.0],
            up: [0.0, 1.0, 0.0],
            fov: 60.0,
            resolution: [200, 100],
        })
        .unwrap();
        // Looking down −z with +y up: image right is +x (right-handed).
        assert!((cam.right() - Vec3::X).length() < 1e-6);
        let (x, y) = cam.project(Vec3::new(1.0, 0.0, 0.0)).unwrap();
        assert!(x > 100.0 && (y - 50.0).abs() < 1e-3, "+x lands right");
        let (_, y) = cam.project(Vec3::new(0.0, 1.0, 0.0)).unwrap();
        assert!(y < 50.0, "+y lands in the top half (row 0 at the top)");
        // fov is the full vertical angle: a point at 30° above the axis hits the top edge.
        let top = Vec3::new(0.0, 5.0 * (30f32).to_radians().tan(), 0.0);
        let (_, y) = cam.project(top).unwrap();
        assert!(y.abs() < 1e-3, "{y}");
        // ray() inverts project().
        let r = cam.ray(37.0, 81.0);
        let (x, y) = cam.project(r.at(3.0)).unwrap();
        assert!((x - 37.0).abs() < 1e-3 && (y - 81.0).abs() < 1e-3);
    }

    #[test]
    fn bad_parameters_are_named() {
        let bad = |f: fn(&mut CameraParams), key: &str| {
            let mut p = CameraParams::default();
            f(&mut p);
            let e = Camera::create(&p).unwrap_err().to_string();
            assert!(e.contains(&format!("`{key}`")), "{e}");
        };
        bad(|p| p.fov = 0.0, "fov");
        bad(|p| p.fov = f32::NAN, "fov");
        bad(|p| p.up = [0.0, 1.0, 0.0], "up");
        bad(|p| p.look_at = p.eye, "look_at");
        bad(|p| p.resolution = [0, 10], "resolution");
    }
}
