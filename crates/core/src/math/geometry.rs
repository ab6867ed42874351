//! Rays, boxes and orthonormal frames.
//!
//! The world is right-handed. A volume occupies an axis-aligned box `p0..p1` (thesis §7.2.1);
//! there is no medium outside it.

use glam::Vec3;
use serde::{Deserialize, Serialize};

/// A half-line `origin + t·direction`, `t >= 0`. `direction` is unit length.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ray {
    /// Start point.
    pub origin: Vec3,
    /// Unit direction.
    pub direction: Vec3,
}

impl Ray {
    /// A ray from `origin` along `direction` (normalised here).
    pub fn new(origin: Vec3, direction: Vec3) -> Self {
        Ray {
            origin,
            direction: direction.normalize(),
        }
    }

    /// The point at parameter `t`.
    #[inline]
    pub fn at(&self, t: f32) -> Vec3 {
        self.origin + self.direction * t
    }
}

/// An axis-aligned box from `min` to `max` (inclusive).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Aabb {
    /// The "left-bottom-front" corner (`p0` in the thesis).
    pub min: Vec3,
    /// The "right-top-back" corner (`p1` in the thesis).
    pub max: Vec3,
}

impl Aabb {
    /// A box spanning `min..max`.
    pub fn new(min: Vec3, max: Vec3) -> Self {
        Aabb { min, max }
    }

    /// The unit cube `[0,1]³`.
    pub fn unit() -> Self {
        Aabb::new(Vec3::ZERO, Vec3::ONE)
    }

    /// Edge lengths.
    pub fn extent(&self) -> Vec3 {
        self.max - self.min
    }

    /// The longest edge: the thesis's "largest extent" for mean-free-path rules (§8.1.2).
    pub fn largest_extent(&self) -> f32 {
        self.extent().max_element()
    }

    /// The centre point.
    pub fn center(&self) -> Vec3 {
        (self.min + self.max) * 0.5
    }

    /// Length of the diagonal.
    pub fn diagonal(&self) -> f32 {
        self.extent().length()
    }

    /// Whether `p` lies inside (boundary included).
    pub fn contains(&self, p: Vec3) -> bool {
        p.cmpge(self.min).all() && p.cmple(self.max).all()
    }

    /// The parametric interval `[t0, t1]` of `ray` inside the box, clipped to `t >= 0`,
    /// or `None` when the ray misses.
    pub fn intersect(&self, ray: &Ray) -> Option<(f32, f32)> {
        let inv = ray.direction.recip();
        let ta = (self.min - ray.origin) * inv;
        let tb = (self.max - ray.origin) * inv;
        // `min`/`max` on NaN (0·∞ for rays in a face plane) pick the other operand, so a ray
        // parallel to a slab is decided by the remaining axes.
        let t_near = ta.min(tb);
        let t_far = ta.max(tb);
        let t0 = t_near.max_element().max(0.0);
        let t1 = t_far.min_element();
        if t0 <= t1 && t1 > 0.0 {
            Some((t0, t1))
        } else {
            None
        }
    }
}

/// An orthonormal frame around a unit vector `w` (e.g. a light's axis or a scattering
/// direction), used to turn local samples into world directions.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Frame {
    /// First tangent.
    pub u: Vec3,
    /// Second tangent.
    pub v: Vec3,
    /// The axis.
    pub w: Vec3,
}

impl Frame {
    /// A frame whose third axis is the unit vector `w` (Duff et al. 2017, branchless).
    pub fn from_w(w: Vec3) -> Self {
        let sign = 1.0f32.copysign(w.z);
        let a = -1.0 / (sign + w.z);
        let b = w.x * w.y * a;
        let u = Vec3::new(1.0 + sign * w.x * w.x * a, sign * b, -sign * w.x);
        let v = Vec3::new(b, sign + w.y * w.y * a, -w.y);
        Frame { u, v, w }
    }

    /// Local coordinates `(x, y, z)` to a world vector.
    #[inline]
    pub fn to_world(&self, local: Vec3) -> Vec3 {
        self.u * local.x + self.v * local.y + self.w * local.z
    }
}

/// A ball: where the photons of lights with extent are aimed, around what can scatter.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sphere {
    /// The centre.
    pub centre: Vec3,
    /// The radius (> 0).
    pub radius: f32,
}

impl Sphere {
    /// The sphere through `bounds`' corners.
    pub fn around(bounds: &Aabb) -> Self {
        Sphere {
            centre: bounds.center(),
            radius: (bounds.diagonal() * 0.5).max(f32::MIN_POSITIVE),
        }
    }

    /// A small sphere holding every point (`None` for none): the centre from Bădoiu and
    /// Clarkson's iteration — step towards the farthest point by `1/(i + 1)`, within about
    /// `1/√i` of the smallest sphere's radius after `i` steps — and the radius the largest
    /// distance from it, so every point lies inside whatever the iteration's accuracy.
    pub fn enclosing(points: &[Vec3]) -> Option<Self> {
        let first = *points.first()?;
        let farthest = |c: Vec3| {
            points
                .iter()
                .copied()
                .max_by(|a, b| a.distance_squared(c).total_cmp(&b.distance_squared(c)))
                .unwrap_or(first)
        };
        // Start at the centroid (the box's centre for a box's corners) and keep the best
        // centre the iteration visits.
        let mut centre = points.iter().copied().sum::<Vec3>() / points.len() as f32;
        let mut best = (farthest(centre).distance(centre), centre);
        for i in 1..=1000 {
            centre += (farthest(centre) - centre) / (i + 1) as f32;
            let radius = farthest(centre).distance(centre);
            if radius < best.0 {
                best = (radius, centre);
            }
        }
        let (radius, centre) = best;
        Some(Sphere {
            centre,
            radius: radius.max(f32::MIN_POSITIVE) * (1.0 + 1e-6),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_enclosing_sphere_holds_every_point_and_is_nearly_the_smallest() {
        // A cube's corners: the smallest sphere is the one through them.
        let corners: Vec<Vec3> = (0..8)
            .map(|i| Vec3::new((i & 1) as f32, ((i >> 1) & 1) as f32, (i >> 2) as f32))
            .collect();
        let s = Sphere::enclosing(&corners).unwrap();
        assert!(corners.iter().all(|p| p.distance(s.centre) <= s.radius));
        assert!(s.radius < 1.05 * 3f32.sqrt() / 2.0, "{s:?}");
        // A right triangle: the smallest circle has the hypotenuse as its diameter.
        let tri = [Vec3::ZERO, Vec3::X * 2.0, Vec3::Y * 2.0];
        let s = Sphere::enclosing(&tri).unwrap();
        assert!(tri.iter().all(|p| p.distance(s.centre) <= s.radius));
        assert!(s.radius < 1.05 * 2f32.sqrt(), "{s:?}");
        assert!(Sphere::enclosing(&[]).is_none());
        let one = Sphere::enclosing(&[Vec3::ONE]).unwrap();
        assert!(one.radius > 0.0 && one.centre == Vec3::ONE);
    }

    #[test]
    fn ray_box_interval() {
        let b = Aabb::unit();
        let r = Ray::new(Vec3::new(-1.0, 0.5, 0.5), Vec3::X);
        let (t0, t1) = b.intersect(&r).unwrap();
        assert!((t0 - 1.0).abs() < 1e-6 && (t1 - 2.0).abs() < 1e-6);
        let inside = Ray::new(Vec3::splat(0.5), Vec3::Y);
        let (t0, t1) = b.intersect(&inside).unwrap();
        assert_eq!(t0, 0.0);
        assert!((t1 - 0.5).abs() < 1e-6);
        let miss = Ray::new(Vec3::new(-1.0, 2.0, 0.5), Vec3::X);
        assert!(b.intersect(&miss).is_none());
        let behind = Ray::new(Vec3::new(2.0, 0.5, 0.5), Vec3::X);
        assert!(b.intersect(&behind).is_none());
    }

    #[test]
    fn frame_is_orthonormal() {
        for w in [
            Vec3::X,
            Vec3::Y,
            Vec3::Z,
            -Vec3::Z,
            Vec3::new(0.3, -0.4, 0.866).normalize(),
        ] {
            let f = Frame::from_w(w);
            assert!((f.u.length() - 1.0).abs() < 1e-5);
            assert!((f.v.length() - 1.0).abs() < 1e-5);
            assert!(f.u.dot(f.v).abs() < 1e-5);
            assert!(f.u.dot(f.w).abs() < 1e-5);
            assert!(f.v.dot(f.w).abs() < 1e-5);
            assert!((f.u.cross(f.v) - f.w).length() < 1e-5, "right-handed");
        }
    }
}
