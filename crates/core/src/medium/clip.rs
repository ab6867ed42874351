//! Clip planes and a crop box (`[clip]`): the part of the volume that is kept, as the
//! cinematic renderers and 3D Slicer's volume rendering let a user cut a volume open. The
//! medium is empty outside — for eye rays, shadow rays, photons and every point query —
//! because every integrator bounds its rays by [`Medium::clip`](super::Medium::clip) and
//! asks densities through [`Medium::density`](super::Medium::density), which both consult
//! the [`ClipRegion`]. The σ mapping (σt(d_min), §8.1.2) is resolved on the whole volume, so a
//! cut does not change the colours of what stays.
//!
//! The kept region is convex (a box intersected with half-spaces), so a ray meets it in one
//! interval and the region's faces are one convex polytope ([`ClipRegion::faces`]).

use glam::Vec3;
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::math::{Aabb, Ray};

/// The thinnest kept region, relative to the volume's size (its largest extent, or the
/// largest coordinate of its box if that is larger): about eight steps of a 32-bit float.
pub const MIN_RELATIVE_THICKNESS: f32 = 1e-6;

/// Where the clip's coordinates live.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ClipSpace {
    /// Fractions of the volume's box: 0 at its lower corner, 1 at its upper one, on every
    /// axis (a plane's normal and offset are in these coordinates too).
    #[default]
    Volume,
    /// World coordinates, as the camera and the lights are placed.
    World,
    /// The camera's frame at its look-at point (world units): `x` to the image's right,
    /// `y` up, `z` forward, from the eye towards the look-at point. `normal = [0, 0, 1]`,
    /// `offset = 0` keeps the far half and opens the volume towards the camera, whatever
    /// the scene — a view-aligned clip plane. Planes only (a crop box is axis-aligned).
    View,
}

/// The camera's frame, for `space = "view"`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ViewFrame {
    /// The look-at point (the frame's origin).
    pub origin: Vec3,
    /// The image's right.
    pub right: Vec3,
    /// The image's up.
    pub up: Vec3,
    /// From the eye towards the look-at point.
    pub forward: Vec3,
}

/// One half-space: the kept side is where `normal · x ≥ offset` (the normal points into
/// what is kept).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ClipPlaneParams {
    /// Points into the kept side; need not be unit length.
    pub normal: [f32; 3],
    /// `normal · x` on the plane (with a unit normal, the plane's signed distance from the
    /// origin of the clip's space).
    pub offset: f32,
}

/// The crop box's corners.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CropBoxParams {
    /// Lower corner.
    pub p0: [f32; 3],
    /// Upper corner.
    pub p1: [f32; 3],
}

/// `[clip]`: a crop box and any number of clip planes. Empty (the default) keeps the
/// whole volume and leaves a scene's content address as it was.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ClipParams {
    /// The coordinates of `box`, `plane` and `planes`.
    #[serde(default)]
    pub space: ClipSpace,
    /// An axis-aligned crop box.
    #[serde(default, rename = "box", skip_serializing_if = "Option::is_none")]
    pub crop: Option<CropBoxParams>,
    /// One clip plane (its `offset` is a natural sweep axis: `clip.plane.offset`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub plane: Option<ClipPlaneParams>,
    /// Further clip planes.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub planes: Vec<ClipPlaneParams>,
}

impl ClipParams {
    /// Whether nothing is clipped.
    pub fn is_empty(&self) -> bool {
        self.crop.is_none() && self.plane.is_none() && self.planes.is_empty()
    }

    /// The planes with the keys that name them (`plane`, `planes[0]`, …).
    fn named_planes(&self) -> Vec<(String, ClipPlaneParams)> {
        let single = self.plane.map(|p| ("plane".to_string(), p));
        single
            .into_iter()
            .chain(
                self.planes
                    .iter()
                    .enumerate()
                    .map(|(i, p)| (format!("planes[{i}]"), *p)),
            )
            .collect()
    }

    /// Checks what can be checked without the volume: finite numbers, a normal that is not
    /// zero, a box whose corners are ordered. Keys are relative to `[clip]`.
    pub fn validate(&self) -> Result<()> {
        if self.space == ClipSpace::View && self.crop.is_some() {
            return Err(Error::parameter(
                "box",
                "(given with space = \"view\")",
                "a crop box in space = \"volume\" or \"world\" (it is axis-aligned); in the view's frame only planes",
            ));
        }
        if let Some(b) = &self.crop {
            for (name, corner) in [("box.p0", b.p0), ("box.p1", b.p1)] {
                if corner.iter().any(|v| !v.is_finite()) {
                    return Err(Error::parameter(
                        name,
                        format!("{corner:?}"),
                        "three finite coordinates",
                    ));
                }
            }
            if (0..3).any(|a| b.p0[a] >= b.p1[a]) {
                return Err(Error::parameter(
                    "box",
                    format!("p0 = {:?}, p1 = {:?}", b.p0, b.p1),
                    "p0 below p1 on every axis (the crop box's lower and upper corners)",
                ));
            }
        }
        for (key, p) in self.named_planes() {
            let n = Vec3::from(p.normal);
            if !n.is_finite() || n.length_squared() == 0.0 || !n.length_squared().is_finite() {
                return Err(Error::parameter(
                    format!("{key}.normal"),
                    format!("{:?}", p.normal),
                    "a finite, non-zero vector pointing into the kept side",
                ));
            }
            if !p.offset.is_finite() {
                return Err(Error::parameter(
                    format!("{key}.offset"),
                    p.offset,
                    "a finite number (normal · x on the plane)",
                ));
            }
        }
        Ok(())
    }
}

/// A half-space in world coordinates: kept where `normal · x ≥ offset`, `normal` unit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HalfSpace {
    /// Unit normal into the kept side.
    pub normal: Vec3,
    /// `normal · x` on the plane.
    pub offset: f32,
}

/// The kept part of a volume in world coordinates: its box intersected with the crop box
/// and the half-spaces.
#[derive(Debug, Clone, PartialEq)]
pub struct ClipRegion {
    crop: Aabb,
    planes: Vec<HalfSpace>,
}

impl ClipRegion {
    /// The region `params` keep of a volume in `bounds`; `None` when nothing is clipped.
    /// Errors name the key (relative to `[clip]`) and say why: a bad number, or a region
    /// that keeps nothing of the volume.
    pub fn create(
        params: &ClipParams,
        bounds: Aabb,
        view: Option<&ViewFrame>,
    ) -> Result<Option<Self>> {
        if params.is_empty() {
            return Ok(None);
        }
        params.validate()?;
        let view = match (params.space, view) {
            (ClipSpace::View, None) => {
                return Err(Error::parameter(
                    "space",
                    "\"view\"",
                    "\"volume\" or \"world\" where there is no camera",
                ));
            }
            (_, v) => v.copied(),
        };
        let extent = bounds.extent();
        let to_world = |q: [f32; 3]| match params.space {
            ClipSpace::Volume => bounds.min + Vec3::from(q) * extent,
            ClipSpace::World | ClipSpace::View => Vec3::from(q),
        };
        let crop = match &params.crop {
            Some(b) => {
                let (lo, hi) = (to_world(b.p0), to_world(b.p1));
                Aabb::new(lo.max(bounds.min), hi.min(bounds.max))
            }
            None => bounds,
        };
        if (0..3).any(|a| crop.min[a] >= crop.max[a]) {
            return Err(Error::parameter(
                "box",
                format!("{:?} … {:?}", crop.min.to_array(), crop.max.to_array()),
                format!(
                    "a crop box that overlaps the volume's box {:?} … {:?} (world)",
                    bounds.min.to_array(),
                    bounds.max.to_array()
                ),
            ));
        }
        let planes = params
            .named_planes()
            .into_iter()
            .map(|(_, p)| world_half_space(p, params.space, bounds, view.as_ref()))
            .collect();
        let region = ClipRegion { crop, planes };
        let faces = region.faces();
        if faces.is_empty() {
            return Err(Error::parameter(
                "plane",
                describe_planes(params),
                "clip planes that keep part of the crop box (each keeps the side its normal points to; together they keep nothing)",
            ));
        }
        region.check_thickness(&faces, bounds, params)?;
        Ok(Some(region))
    }

    /// Refuses a kept region thinner than [`MIN_RELATIVE_THICKNESS`] of the volume's size
    /// (two planes keeping the slab `x ≥ 0.5`, `x ≤ 0.5`, or a sliver under a 32-bit
    /// float's step): it keeps nothing a ray can resolve, and would render black. The
    /// width is measured across every plane and every axis of the crop box, the
    /// directions in which such a region is thin.
    fn check_thickness(
        &self,
        faces: &[Vec<Vec3>],
        bounds: Aabb,
        params: &ClipParams,
    ) -> Result<()> {
        let scale = bounds
            .largest_extent()
            .max(bounds.min.abs().max_element())
            .max(bounds.max.abs().max_element());
        let least = MIN_RELATIVE_THICKNESS * scale;
        let directions = [Vec3::X, Vec3::Y, Vec3::Z]
            .into_iter()
            .chain(self.planes.iter().map(|h| h.normal));
        let width_along = |n: Vec3| {
            let (lo, hi) = faces
                .iter()
                .flatten()
                .map(|v| n.dot(*v))
                .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), d| {
                    (lo.min(d), hi.max(d))
                });
            hi - lo
        };
        let (width, across) =
            directions
                .map(|n| (width_along(n), n))
                .fold(
                    (f32::INFINITY, Vec3::X),
                    |a, b| if b.0 < a.0 { b } else { a },
                );
        if width >= least {
            return Ok(());
        }
        let (key, what) = match params.crop {
            Some(_) if self.planes.is_empty() => ("box", "a crop box"),
            _ => ("plane", "clip planes (and crop box)"),
        };
        let box_and_planes = params
            .crop
            .map(|b| format!("box: p0 = {:?}, p1 = {:?}", b.p0, b.p1))
            .into_iter()
            .chain((!self.planes.is_empty()).then(|| describe_planes(params)))
            .collect::<Vec<_>>()
            .join("; ");
        Err(Error::parameter(
            key,
            box_and_planes,
            format!(
                "{what} that keep a region at least {least:e} thick (10⁻⁶ of the volume's size, world units): these keep {width:e} across {:?}, which no ray resolves — the planes together keep nothing",
                across.to_array()
            ),
        ))
    }

    /// The crop box in world coordinates (inside the volume's box).
    pub fn crop(&self) -> Aabb {
        self.crop
    }

    /// The half-spaces in world coordinates.
    pub fn planes(&self) -> &[HalfSpace] {
        &self.planes
    }

    /// Whether `p` is kept.
    #[inline]
    pub fn contains(&self, p: Vec3) -> bool {
        self.crop.contains(p) && self.planes.iter().all(|h| h.normal.dot(p) >= h.offset)
    }

    /// The ray's parametric interval inside the region (`t ≥ 0`), or `None`.
    pub fn interval(&self, ray: &Ray) -> Option<(f32, f32)> {
        let (mut t0, mut t1) = self.crop.intersect(ray)?;
        for h in &self.planes {
            let along = h.normal.dot(ray.direction);
            let gap = h.offset - h.normal.dot(ray.origin);
            if along > 0.0 {
                t0 = t0.max(gap / along);
            } else if along < 0.0 {
                t1 = t1.min(gap / along);
            } else if gap > 0.0 {
                return None;
            }
        }
        (t0 < t1).then_some((t0, t1))
    }

    /// The region's boundary as convex polygons (vertices counter-clockwise seen from
    /// outside): the crop box's faces cut by every plane, plus one cap per plane that cuts.
    /// Empty when the region keeps nothing of positive volume.
    pub fn faces(&self) -> Vec<Vec<Vec3>> {
        let mut faces = box_faces(self.crop);
        for h in &self.planes {
            faces = cut(&faces, *h);
            if faces.is_empty() {
                break;
            }
        }
        faces
    }

    /// The part of the region inside `bounds` (`None` when it keeps nothing there).
    pub fn within(&self, bounds: Aabb) -> Option<ClipRegion> {
        let (lo, hi) = (self.crop.min.max(bounds.min), self.crop.max.min(bounds.max));
        if (0..3).any(|a| lo[a] >= hi[a]) {
            return None;
        }
        let region = ClipRegion {
            crop: Aabb::new(lo, hi),
            planes: self.planes.clone(),
        };
        (!region.faces().is_empty()).then_some(region)
    }

    /// The same region with its crop box pushed out by `margin` wherever the crop box lies
    /// on `bounds` (beyond which the medium is empty anyway): the boundary a peer renderer
    /// can hold the medium in without its ray-spawn offset eating into the volume's faces.
    pub fn with_margin_on(&self, bounds: Aabb, margin: f32) -> ClipRegion {
        let mut crop = self.crop;
        for a in 0..3 {
            if crop.min[a] <= bounds.min[a] {
                crop.min[a] -= margin;
            }
            if crop.max[a] >= bounds.max[a] {
                crop.max[a] += margin;
            }
        }
        ClipRegion {
            crop,
            planes: self.planes.clone(),
        }
    }

    /// The region's volume (from its faces, by the divergence theorem).
    pub fn volume(&self) -> f32 {
        self.faces()
            .iter()
            .map(|f| {
                (1..f.len() - 1)
                    .map(|i| f[0].dot(f[i].cross(f[i + 1])))
                    .sum::<f32>()
            })
            .sum::<f32>()
            / 6.0
    }
}

/// A plane of `space` in world coordinates. A volume-space point is `q = (x − min) / e`
/// per axis, so `n · q ≥ d` is `m · x ≥ d + m · min` with `m = n / e`, normalised.
fn world_half_space(
    p: ClipPlaneParams,
    space: ClipSpace,
    bounds: Aabb,
    view: Option<&ViewFrame>,
) -> HalfSpace {
    let n = Vec3::from(p.normal);
    let (m, offset) = match space {
        ClipSpace::World => (n, p.offset),
        // `n · (R^T (x − o)) ≥ d` is `(R n) · x ≥ d + (R n) · o`, `R` the frame's columns.
        ClipSpace::View => {
            let v = view.expect("checked in create");
            let m = v.right * n.x + v.up * n.y + v.forward * n.z;
            (m, p.offset + m.dot(v.origin))
        }
        ClipSpace::Volume => {
            let m = n / bounds.extent();
            (m, p.offset + m.dot(bounds.min))
        }
    };
    let length = m.length();
    HalfSpace {
        normal: m / length,
        offset: offset / length,
    }
}

fn describe_planes(params: &ClipParams) -> String {
    params
        .named_planes()
        .iter()
        .map(|(k, p)| format!("{k}: normal {:?}, offset {}", p.normal, p.offset))
        .collect::<Vec<_>>()
        .join("; ")
}

/// The six faces of a box, counter-clockwise seen from outside.
fn box_faces(b: Aabb) -> Vec<Vec<Vec3>> {
    let c = |x: usize, y: usize, z: usize| {
        Vec3::new(
            [b.min.x, b.max.x][x],
            [b.min.y, b.max.y][y],
            [b.min.z, b.max.z][z],
        )
    };
    vec![
        vec![c(0, 0, 0), c(0, 0, 1), c(0, 1, 1), c(0, 1, 0)], // −x
        vec![c(1, 0, 0), c(1, 1, 0), c(1, 1, 1), c(1, 0, 1)], // +x
        vec![c(0, 0, 0), c(1, 0, 0), c(1, 0, 1), c(0, 0, 1)], // −y
        vec![c(0, 1, 0), c(0, 1, 1), c(1, 1, 1), c(1, 1, 0)], // +y
        vec![c(0, 0, 0), c(0, 1, 0), c(1, 1, 0), c(1, 0, 0)], // −z
        vec![c(0, 0, 1), c(1, 0, 1), c(1, 1, 1), c(0, 1, 1)], // +z
    ]
}

/// A convex polytope's faces cut by a half-space (Sutherland–Hodgman on each face), with
/// the cap that closes the cut.
fn cut(faces: &[Vec<Vec3>], h: HalfSpace) -> Vec<Vec<Vec3>> {
    let side = |p: Vec3| h.normal.dot(p) - h.offset;
    let mut kept = Vec::new();
    let mut on_plane: Vec<Vec3> = Vec::new();
    for face in faces {
        let mut polygon = Vec::new();
        for (i, &a) in face.iter().enumerate() {
            let b = face[(i + 1) % face.len()];
            let (sa, sb) = (side(a), side(b));
            if sa >= 0.0 {
                polygon.push(a);
            }
            if (sa >= 0.0) != (sb >= 0.0) {
                let crossing = a + (b - a) * (sa / (sa - sb));
                polygon.push(crossing);
                on_plane.push(crossing);
            }
        }
        if polygon.len() >= 3 && polygon_area(&polygon) > 0.0 {
            kept.push(polygon);
        }
    }
    if kept.is_empty() {
        return kept;
    }
    if let Some(cap) = cap(&on_plane, h.normal) {
        kept.push(cap);
    }
    kept
}

/// The cap of a cut: the crossing points ordered around their centre, counter-clockwise
/// seen from outside (along −normal, since the normal points into what is kept).
fn cap(points: &[Vec3], normal: Vec3) -> Option<Vec<Vec3>> {
    let mut unique: Vec<Vec3> = Vec::new();
    for &p in points {
        if !unique.iter().any(|q| q.distance_squared(p) < 1e-12) {
            unique.push(p);
        }
    }
    if unique.len() < 3 {
        return None;
    }
    let centre = unique.iter().copied().sum::<Vec3>() / unique.len() as f32;
    let frame = crate::math::Frame::from_w(-normal);
    unique.sort_by(|a, b| {
        let angle = |p: &Vec3| {
            let d = *p - centre;
            d.dot(frame.v).atan2(d.dot(frame.u))
        };
        angle(a).total_cmp(&angle(b))
    });
    (polygon_area(&unique) > 0.0).then_some(unique)
}

fn polygon_area(polygon: &[Vec3]) -> f32 {
    let mut twice = Vec3::ZERO;
    for i in 1..polygon.len() - 1 {
        twice += (polygon[i] - polygon[0]).cross(polygon[i + 1] - polygon[0]);
    }
    0.5 * twice.length()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn plane(normal: [f32; 3], offset: f32) -> ClipPlaneParams {
        ClipPlaneParams { normal, offset }
    }

    fn region(params: ClipParams, bounds: Aabb) -> ClipRegion {
        ClipRegion::create(&params, bounds, None).unwrap().unwrap()
    }

    #[test]
    fn a_volume_space_plane_lands_where_its_fraction_says() {
        // A box from (1, 2, 3) of extent (2, 4, 8): the volume-space plane y ≥ 0.25 is
        // world y ≥ 3.
        let bounds = Aabb::new(Vec3::new(1.0, 2.0, 3.0), Vec3::new(3.0, 6.0, 11.0));
        let r = region(
            ClipParams {
                plane: Some(plane([0.0, 2.0, 0.0], 0.5)),
                ..ClipParams::default()
            },
            bounds,
        );
        assert!(r.contains(Vec3::new(2.0, 3.01, 5.0)));
        assert!(!r.contains(Vec3::new(2.0, 2.99, 5.0)));
        assert!(
            (r.volume() - 2.0 * 3.0 * 8.0).abs() < 1e-3,
            "{}",
            r.volume()
        );
        // An oblique volume-space plane x + y ≥ 1 keeps half the box.
        let r = region(
            ClipParams {
                plane: Some(plane([1.0, 1.0, 0.0], 1.0)),
                ..ClipParams::default()
            },
            bounds,
        );
        assert!((r.volume() - 0.5 * 64.0).abs() < 1e-3, "{}", r.volume());
    }

    #[test]
    fn intervals_match_the_closed_form() {
        let bounds = Aabb::unit();
        let r = region(
            ClipParams {
                space: ClipSpace::World,
                crop: Some(CropBoxParams {
                    p0: [0.0, 0.0, 0.0],
                    p1: [1.0, 1.0, 0.8],
                }),
                plane: Some(plane([1.0, 0.0, 0.0], 0.5)),
                planes: vec![plane([0.0, -1.0, 0.0], -0.75)],
            },
            bounds,
        );
        let ray = Ray::new(Vec3::new(-1.0, 0.5, 0.5), Vec3::X);
        let (t0, t1) = r.interval(&ray).unwrap();
        assert!(
            (t0 - 1.5).abs() < 1e-6 && (t1 - 2.0).abs() < 1e-6,
            "{t0} {t1}"
        );
        // Along +y the plane y ≤ 0.75 ends the interval; along z the crop box does.
        let ray = Ray::new(Vec3::new(0.7, -1.0, 0.5), Vec3::Y);
        let (t0, t1) = r.interval(&ray).unwrap();
        assert!(
            (t0 - 1.0).abs() < 1e-6 && (t1 - 1.75).abs() < 1e-6,
            "{t0} {t1}"
        );
        let ray = Ray::new(Vec3::new(0.7, 0.5, -1.0), Vec3::Z);
        let (_, t1) = r.interval(&ray).unwrap();
        assert!((t1 - 1.8).abs() < 1e-6, "{t1}");
        // Parallel to a plane on its far side: nothing.
        assert!(
            r.interval(&Ray::new(Vec3::new(0.2, 0.5, -1.0), Vec3::Z))
                .is_none()
        );
        // From inside: the interval starts at 0.
        let (t0, _) = r
            .interval(&Ray::new(Vec3::new(0.7, 0.5, 0.5), Vec3::X))
            .unwrap();
        assert_eq!(t0, 0.0);
    }

    #[test]
    fn faces_close_a_polytope_of_the_right_volume() {
        // Three planes cutting a corner off the unit cube: x + y + z ≥ 1 removes a
        // tetrahedron of volume 1/6.
        let r = region(
            ClipParams {
                space: ClipSpace::World,
                plane: Some(plane([1.0, 1.0, 1.0], 1.0)),
                ..ClipParams::default()
            },
            Aabb::unit(),
        );
        assert!((r.volume() - 5.0 / 6.0).abs() < 1e-4, "{}", r.volume());
        assert_eq!(r.faces().len(), 7);
        for face in r.faces() {
            assert!(
                face.iter()
                    .all(|p| r.contains(*p + (r.crop().center() - *p) * 1e-4))
            );
        }
    }

    #[test]
    fn bad_clips_name_their_key() {
        let err = |p: ClipParams| {
            ClipRegion::create(&p, Aabb::unit(), None)
                .unwrap_err()
                .to_string()
        };
        let e = err(ClipParams {
            plane: Some(plane([0.0, 0.0, 0.0], 0.5)),
            ..ClipParams::default()
        });
        assert!(e.contains("plane.normal") && e.contains("non-zero"), "{e}");
        let e = err(ClipParams {
            planes: vec![
                plane([1.0, 0.0, 0.0], 0.2),
                plane([1.0, 0.0, 0.0], f32::NAN),
            ],
            ..ClipParams::default()
        });
        assert!(e.contains("planes[1].offset"), "{e}");
        let e = err(ClipParams {
            crop: Some(CropBoxParams {
                p0: [0.5, 0.0, 0.0],
                p1: [0.4, 1.0, 1.0],
            }),
            ..ClipParams::default()
        });
        assert!(e.contains("box") && e.contains("p0 below p1"), "{e}");
        let e = err(ClipParams {
            crop: Some(CropBoxParams {
                p0: [2.0, 0.0, 0.0],
                p1: [3.0, 1.0, 1.0],
            }),
            ..ClipParams::default()
        });
        assert!(e.contains("overlaps the volume"), "{e}");
        // Two planes facing away from each other keep nothing.
        let e = err(ClipParams {
            plane: Some(plane([1.0, 0.0, 0.0], 0.6)),
            planes: vec![plane([-1.0, 0.0, 0.0], -0.4)],
            ..ClipParams::default()
        });
        assert!(e.contains("keep nothing"), "{e}");
        assert!(
            ClipRegion::create(&ClipParams::default(), Aabb::unit(), None)
                .unwrap()
                .is_none()
        );
    }
}
