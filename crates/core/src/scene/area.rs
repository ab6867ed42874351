//! Area lights: a rectangle or a disc emitting constant radiance `L` from one side (the
//! side its normal points to), as Mitsuba's `rectangle`/`disk` shapes with an `area`
//! emitter and pbrt's `diffuse` area light with `twosided false`.
//!
//! * power `Φ = π·A·L` (a Lambertian emitter of area `A`);
//! * next-event estimation samples a point uniformly by area, so the solid-angle pdf at a
//!   receiver `x` is `r² / (A·cos θ_l)` with `θ_l` the angle between the normal and the
//!   direction to `x` (area sampling: exact, and cheap enough for lights that subtend a
//!   modest solid angle, as the study's do);
//! * photons leave a point uniform on the surface in a cosine-weighted direction, each with
//!   power `Φ/N` — or, when the medium's scattering sphere lies wholly in front of the
//!   light, in a direction uniform in the cone that sphere subtends, weighted by
//!   `L·cos θ·A·Ω` (no photon is spent on directions that miss the medium).
//!
//! The light is not a surface for the medium: it neither blocks nor reflects light (the
//! Mitsuba export gives the shape a `null` BSDF so the peer agrees).

use std::f32::consts::PI;

use glam::Vec3;

use super::light::incident::{Incident, check_radiance};
use crate::error::{Error, Result};
use crate::math::{Frame, Ray, Rng, Sphere, concentric_disc, cosine_hemisphere, uniform_cone};

/// The smallest size or radius of an area light, relative to the largest coordinate of its
/// position (and at least this in world units): about eight steps of a 32-bit float there.
pub const MIN_RELATIVE_EXTENT: f32 = 1e-6;

/// The shape of an [`AreaLight`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AreaShape {
    /// A rectangle of `size = [width, height]`.
    Rect,
    /// A disc of `radius`.
    Disc,
}

/// A one-sided rectangle or disc light.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AreaLight {
    shape: AreaShape,
    centre: Vec3,
    /// `w` is the normal (the emitting side); `u` spans the width, `v` the height.
    frame: Frame,
    /// Rectangle: half width and half height; disc: the radius twice.
    half: [f32; 2],
    radiance: Vec3,
    area: f32,
}

impl AreaLight {
    /// A light of `shape` centred at `centre`, emitting towards `normal`, with
    /// `extent = [width, height]` (rectangle) or `[radius, radius]` (disc); `up` orients
    /// the rectangle's height (projected into its plane), `None` for any orientation.
    pub fn new(
        shape: AreaShape,
        centre: Vec3,
        normal: Vec3,
        up: Option<Vec3>,
        extent: [f32; 2],
        radiance: Vec3,
    ) -> Result<Self> {
        let n = normal.normalize_or_zero();
        if !centre.is_finite() {
            return Err(Error::parameter(
                "position",
                format!("{:?}", centre.to_array()),
                "three finite numbers",
            ));
        }
        if !normal.is_finite() || n == Vec3::ZERO {
            return Err(Error::parameter(
                "normal",
                format!("{:?}", normal.to_array()),
                "a finite non-zero direction (or a `target` other than `position`)",
            ));
        }
        let frame = oriented_frame(n, up)?;
        let key = if shape == AreaShape::Rect {
            "size"
        } else {
            "radius"
        };
        // Points of a smaller light are not distinct in 32-bit floats around its
        // position, and its area (1e-30² is 0 in f32) no longer weighs its samples: it
        // would light nothing, silently.
        let smallest = MIN_RELATIVE_EXTENT * centre.abs().max_element().max(1.0);
        if !extent
            .iter()
            .all(|e| e.is_finite() && *e >= smallest && *e < 1e6)
        {
            return Err(Error::parameter(
                key,
                format!("{extent:?}"),
                format!(
                    "finite lengths from {smallest:e} (10⁻⁶ of the light's distance from the origin, at least 10⁻⁶: smaller, 32-bit floats cannot place its points) to below 1e6 (world units)"
                ),
            ));
        }
        check_radiance(radiance)?;
        let (half, area) = match shape {
            AreaShape::Rect => ([extent[0] / 2.0, extent[1] / 2.0], extent[0] * extent[1]),
            AreaShape::Disc => ([extent[0], extent[0]], PI * extent[0] * extent[0]),
        };
        Ok(AreaLight {
            shape,
            centre,
            frame,
            half,
            radiance,
            area,
        })
    }

    /// The shape.
    pub fn shape(&self) -> AreaShape {
        self.shape
    }

    /// The centre.
    pub fn centre(&self) -> Vec3 {
        self.centre
    }

    /// The unit normal (the emitting side).
    pub fn normal(&self) -> Vec3 {
        self.frame.w
    }

    /// The unit vector along the rectangle's width (the disc's first tangent).
    pub fn width_axis(&self) -> Vec3 {
        self.frame.u
    }

    /// The unit vector along the rectangle's height.
    pub fn height_axis(&self) -> Vec3 {
        self.frame.v
    }

    /// `[width, height]` of a rectangle, `[radius, radius]` of a disc.
    pub fn extent(&self) -> [f32; 2] {
        match self.shape {
            AreaShape::Rect => [self.half[0] * 2.0, self.half[1] * 2.0],
            AreaShape::Disc => self.half,
        }
    }

    /// The emitted radiance `L` (W/m²/sr, RGB).
    pub fn radiance(&self) -> Vec3 {
        self.radiance
    }

    /// The surface area.
    pub fn area(&self) -> f32 {
        self.area
    }

    /// Total emitted power `π·A·L`.
    pub fn power(&self) -> Vec3 {
        PI * self.area * self.radiance
    }

    /// A point uniform on the surface.
    fn sample_point(&self, u: [f32; 2]) -> Vec3 {
        let [a, b] = match self.shape {
            AreaShape::Rect => [2.0 * u[0] - 1.0, 2.0 * u[1] - 1.0],
            AreaShape::Disc => concentric_disc(u),
        };
        self.centre + self.frame.u * (a * self.half[0]) + self.frame.v * (b * self.half[1])
    }

    /// Light arriving at `x` from a point drawn uniformly on the surface: the radiance
    /// divided by the solid-angle pdf, so `σs·p·radiance·T` estimates single scattering
    /// (`None` behind the light or at its plane).
    pub fn sample_incident(&self, x: Vec3, u: [f32; 2]) -> Option<Incident> {
        let d = self.sample_point(u) - x;
        let dist2 = d.length_squared();
        if dist2 <= 0.0 {
            return None;
        }
        let distance = dist2.sqrt();
        let to_light = d / distance;
        let cos_light = -to_light.dot(self.frame.w);
        if cos_light <= 0.0 {
            return None;
        }
        let pdf = dist2 / (self.area * cos_light);
        Some(Incident {
            to_light,
            distance,
            radiance: self.radiance / pdf,
            pdf,
        })
    }

    /// The solid-angle pdf with which [`Self::sample_incident`] at `x` returns direction
    /// `w`, and the distance to the light along it (`None` if the ray misses the emitting
    /// side).
    pub fn pdf(&self, x: Vec3, w: Vec3) -> Option<(f32, f32)> {
        let t = self.hit(&Ray::new(x, w))?;
        let cos_light = -w.dot(self.frame.w);
        Some((t * t / (self.area * cos_light), t))
    }

    /// The distance along `ray` to the emitting side, if the ray hits it.
    pub fn hit(&self, ray: &Ray) -> Option<f32> {
        let denom = ray.direction.dot(self.frame.w);
        if denom >= 0.0 {
            return None;
        }
        let t = (self.centre - ray.origin).dot(self.frame.w) / denom;
        if !(t > 0.0 && t.is_finite()) {
            return None;
        }
        let local = ray.at(t) - self.centre;
        let (a, b) = (local.dot(self.frame.u), local.dot(self.frame.v));
        let inside = match self.shape {
            AreaShape::Rect => a.abs() <= self.half[0] && b.abs() <= self.half[1],
            AreaShape::Disc => a * a + b * b <= self.half[0] * self.half[0],
        };
        inside.then_some(t)
    }

    /// An emitted photon: origin uniform on the surface, direction cosine-weighted about
    /// the normal (every photon carries `Φ/N`).
    pub fn emit(&self, rng: &mut Rng) -> Ray {
        let origin = self.sample_point(rng.uniform2());
        Ray::new(
            origin,
            self.frame.to_world(cosine_hemisphere(rng.uniform2())),
        )
    }

    /// Whether photons can be aimed at `target`: the sphere lies wholly on the emitting
    /// side, so every point of the light sees all of it in front of its surface.
    fn can_aim_at(&self, target: &Sphere) -> bool {
        (target.centre - self.centre).dot(self.frame.w) > target.radius
    }

    /// The power sent towards `target` from the light's centre, as if every point of the
    /// light saw the sphere as its centre does: `L·A·cos θ_c·Ω_c`. Only a normaliser (the
    /// photon split over lights and what [`Self::emit_towards`]'s weights are relative
    /// to): each photon's own weight is exact, so the estimate does not depend on it.
    /// Without aim, `Φ`.
    pub fn power_towards(&self, target: &Sphere) -> Vec3 {
        if !self.can_aim_at(target) {
            return self.power();
        }
        let (axis, one_minus_cos) = cone_towards(self.centre, target);
        self.radiance * self.area * axis.dot(self.frame.w) * cone_solid_angle(one_minus_cos)
    }

    /// A photon aimed at `target`: origin uniform on the surface, direction uniform in the
    /// cone the sphere subtends from it. Its weight relative to
    /// [`Self::power_towards`] is `L·cos θ·A·Ω(x) / power_towards` — the cosine-weighted
    /// emission restricted to the directions that can reach the medium, importance-sampled,
    /// so the power arriving at every point of the sphere is unchanged. Where the sphere
    /// is not wholly in front of the light, the plain cosine-weighted photon of
    /// [`Self::emit`] (weight 1).
    pub fn emit_towards(&self, rng: &mut Rng, target: &Sphere) -> (Ray, f32) {
        if !self.can_aim_at(target) {
            return (self.emit(rng), 1.0);
        }
        let origin = self.sample_point(rng.uniform2());
        let (axis, one_minus_cos) = cone_towards(origin, target);
        let direction = Frame::from_w(axis).to_world(uniform_cone(rng.uniform2(), one_minus_cos));
        let cos_theta = direction.dot(self.frame.w).max(0.0);
        let (centre_axis, centre_one_minus_cos) = cone_towards(self.centre, target);
        let relative = cos_theta * cone_solid_angle(one_minus_cos)
            / (centre_axis.dot(self.frame.w) * cone_solid_angle(centre_one_minus_cos));
        (Ray::new(origin, direction), relative)
    }
}

/// The unit axis from `from` to `target`'s centre and `1 − cos` of the half-angle of the
/// cone the sphere subtends (`from` outside the sphere), as `sin²/(1 + cos)`.
fn cone_towards(from: Vec3, target: &Sphere) -> (Vec3, f32) {
    let d = target.centre - from;
    let distance = d.length();
    let sin2 = (target.radius / distance).powi(2).min(1.0);
    (d / distance, sin2 / (1.0 + (1.0 - sin2).sqrt()))
}

/// The solid angle of a cone whose half-angle has `1 − cos = one_minus_cos`.
fn cone_solid_angle(one_minus_cos: f32) -> f32 {
    2.0 * PI * one_minus_cos
}

/// A frame around the normal `n` whose `v` axis is `up` projected into the plane.
fn oriented_frame(n: Vec3, up: Option<Vec3>) -> Result<Frame> {
    let Some(up) = up else {
        return Ok(Frame::from_w(n));
    };
    let v = (up - n * up.dot(n)).normalize_or_zero();
    if !up.is_finite() || v.length_squared() < 0.5 {
        return Err(Error::parameter(
            "up",
            format!("{:?}", up.to_array()),
            "a finite direction not parallel to the light's normal",
        ));
    }
    Ok(Frame {
        u: v.cross(n),
        v,
        w: n,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Domain;

    fn rect() -> AreaLight {
        AreaLight::new(
            AreaShape::Rect,
            Vec3::new(0.0, 0.0, 2.0),
            -Vec3::Z,
            Some(Vec3::Y),
            [1.0, 0.5],
            Vec3::new(1.0, 2.0, 3.0),
        )
        .unwrap()
    }

    /// The irradiance `∫ L cos θ dω` below the centre of a disc of radius `R` at height `h`
    /// is `π·L·R²/(R² + h²)`: the sampled estimate must agree.
    #[test]
    fn disc_irradiance_matches_closed_form() {
        let (r, h) = (0.7f32, 1.3f32);
        let disc = AreaLight::new(
            AreaShape::Disc,
            Vec3::Z * h,
            -Vec3::Z,
            None,
            [r, r],
            Vec3::ONE,
        )
        .unwrap();
        let mut rng = Rng::stream(3, Domain::Photons, 0);
        let n = 200_000;
        let mut sum = 0.0f64;
        for _ in 0..n {
            if let Some(inc) = disc.sample_incident(Vec3::ZERO, rng.uniform2()) {
                sum += (inc.radiance.x * inc.to_light.z) as f64;
            }
        }
        let expected = PI * r * r / (r * r + h * h);
        let got = (sum / n as f64) as f32;
        assert!((got / expected - 1.0).abs() < 0.01, "{got} vs {expected}");
    }

    #[test]
    fn pdf_of_a_sampled_direction_matches_and_back_side_is_dark() {
        let light = rect();
        let x = Vec3::new(0.2, -0.1, 0.0);
        let mut rng = Rng::stream(5, Domain::Photons, 1);
        for _ in 0..1000 {
            let inc = light.sample_incident(x, rng.uniform2()).unwrap();
            let (pdf, t) = light.pdf(x, inc.to_light).unwrap();
            assert!((pdf / inc.pdf - 1.0).abs() < 1e-3, "{pdf} vs {}", inc.pdf);
            assert!((t / inc.distance - 1.0).abs() < 1e-4);
        }
        // Above the light (behind its emitting side) nothing arrives.
        assert!(light.sample_incident(Vec3::Z * 3.0, [0.3, 0.6]).is_none());
        assert!(light.pdf(Vec3::Z * 3.0, -Vec3::Z).is_none());
    }

    #[test]
    fn photons_leave_the_emitting_side_from_the_surface() {
        let light = rect();
        let mut rng = Rng::stream(7, Domain::Photons, 2);
        let mut mean_cos = 0.0;
        for _ in 0..20_000 {
            let ray = light.emit(&mut rng);
            let local = ray.origin - light.centre();
            assert!(local.dot(light.normal()).abs() < 1e-5);
            assert!(local.dot(light.width_axis()).abs() <= 0.5 + 1e-5);
            assert!(local.dot(light.height_axis()).abs() <= 0.25 + 1e-5);
            let c = ray.direction.dot(light.normal());
            assert!(c >= 0.0);
            mean_cos += c / 20_000.0;
        }
        // Cosine-weighted: E[cos θ] = 2/3.
        assert!((mean_cos - 2.0 / 3.0).abs() < 0.01, "{mean_cos}");
        assert!((light.power() - PI * 0.5 * Vec3::new(1.0, 2.0, 3.0)).length() < 1e-5);
    }

    #[test]
    fn bad_shapes_name_their_key() {
        let bad = |shape, normal, extent, radiance| {
            AreaLight::new(shape, Vec3::ZERO, normal, None, extent, radiance)
                .unwrap_err()
                .to_string()
        };
        assert!(bad(AreaShape::Rect, Vec3::Z, [0.0, 1.0], Vec3::ONE).contains("size"));
        assert!(bad(AreaShape::Disc, Vec3::Z, [f32::NAN; 2], Vec3::ONE).contains("radius"));
        assert!(bad(AreaShape::Rect, Vec3::ZERO, [1.0; 2], Vec3::ONE).contains("normal"));
        assert!(bad(AreaShape::Rect, Vec3::Z, [1.0; 2], Vec3::ZERO).contains("radiance"));
        let up = AreaLight::new(
            AreaShape::Rect,
            Vec3::ZERO,
            Vec3::Z,
            Some(Vec3::Z),
            [1.0; 2],
            Vec3::ONE,
        );
        assert!(up.unwrap_err().to_string().contains("up"));
    }
}
