//! Photon planes with a 1-D blur (Bitterli & Jarosz 2017, "Beyond points and beams:
//! higher-dimensional photon samples for volumetric light transport"), for a heterogeneous
//! medium.
//!
//! Every flight of a photon path — from vertex `x_a` (the light, or a scattering point)
//! along `ω_a` — is kept with the direction `ω_{a+1}` sampled from the phase function at its
//! end. Sweeping the flight along `ω_{a+1}` gives a plane `x(s, u) = x_a + s·ω_a + u·ω_{a+1}`:
//! every path `x_a → x(s, 0) → x(s, u)` whose middle vertex lies on the flight and whose
//! last vertex lies on the plane. An eye ray meets the plane at one point, so the plane
//! integrates both free-flight distances (`s`, `u`) analytically, with no density
//! estimate: its contribution to the eye is
//!
//! `Φ_a · σs(x(s,0)) · T(x_a → x(s,0)) · T(x(s,0) → x(s,u)) · σs(x) · p(ω_{a+1}, −ω) ·
//! T_eye / |det(ω_a, ω_{a+1}, ω)|`,
//!
//! (the phase function at `x(s,0)` cancels against the density it was sampled from). The
//! determinant makes grazing rays weigh without bound; the 1-D blur gives the plane a
//! thickness `2r` along its normal `n`, and the eye ray's stretch inside that slab is
//! integrated instead, `(1/(2r·|ω_a × ω_{a+1}|))·∫ f dt`, estimated by one uniform sample of
//! `t` on the stretch. As `r → 0` this is the plane's exact contribution; the progressive
//! loop shrinks `r` per iteration by `(i + α)/(i + 1)` (a 1-D kernel).
//!
//! Transmittance in a heterogeneous medium, without bias:
//!
//! * along `ω_a`: the plane ends where delta tracking put the path's next interaction
//!   (`s ≤ s*`). `P(s* > s) = T(x_a → x(s,0))` exactly, so the indicator replaces `T`.
//! * along `ω_{a+1}`: the lines `x(s, ·)` start at different points, so one sampled flight
//!   cannot serve them all. The plane draws one `τ* ~ Exp(1)` and keeps the point `x(s, u)`
//!   when the exact optical depth from `x(s, 0)` to it (the cell walk of
//!   [`Medium::optical_depth_capped`], no step, no noise) is below `τ*`:
//!   `P(τ* > τ) = e^{−τ}`, again exactly `T`, for every line at once. The walk stops as
//!   soon as it passes `τ*`.
//! * along the eye ray: the march's own optical depth, as the beam estimate takes it.
//!
//! The planes of a path cover every path of two or more scatterings exactly once: the
//! plane of flight `a` (the light's, `a = 0`, or the one after scattering `a`) ends its
//! paths at scattering `a + 2`, the eye ray's.

use glam::Vec3;
use rayon::prelude::*;

use super::PhotonStats;
use super::bvh::{Bounded, Bvh};
use super::trace::{
    Flight, PathCounters, PathRecord, TraceSettings, emission_target, trace_chunks, walk_path,
};
use crate::control::Control;
use crate::error::Result;
use crate::math::{Aabb, Domain, Ray, Rng};
use crate::medium::{Medium, Phase};
use crate::scene::Light;

/// One photon plane, as traced.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PhotonPlane {
    /// The flight's start `x_a` (the light, or a scattering point).
    pub origin: Vec3,
    /// The flight's direction `ω_a`.
    pub first: Vec3,
    /// The direction `ω_{a+1}` sampled at the flight's end, along which the plane is swept.
    pub second: Vec3,
    /// The flight's stretch inside the box, `[s_start, s_end]` along `first` (`s_end`: the
    /// next interaction, or the box's far side).
    pub s_start: f32,
    /// See `s_start`.
    pub s_end: f32,
    /// A distance along `second` past which no line of the plane is inside the box.
    pub u_end: f32,
    /// The optical depth `τ* ~ Exp(1)` along `second` up to which the plane reaches.
    pub tau: f32,
    /// The power leaving `x_a` (W, RGB).
    pub power: Vec3,
}

/// The planes of one chunk of photon paths and the paths' counters.
#[derive(Default)]
struct PlaneChunk {
    planes: Vec<PhotonPlane>,
    counters: PathCounters,
}

/// Records a path's flights as planes; draws `τ*` and the directions of flights that end
/// the path from its own stream, so the path itself is the photon tracer's.
struct PlaneRecord<'a> {
    planes: &'a mut Vec<PhotonPlane>,
    rng: Rng,
    phase: Phase,
    bounds: Aabb,
}

impl PathRecord for PlaneRecord<'_> {
    fn interaction(&mut self, _: &Medium, _: Vec3, _: Vec3, _: Vec3, _: u32) {}

    fn flight(&mut self, f: &Flight) {
        let s_end = f.hit.unwrap_or(f.t1);
        let second = match f.next {
            Some(next) => next,
            None => self.phase.sample(f.ray.direction, self.rng.uniform2()),
        };
        let tau = -self.rng.uniform_open0().ln();
        if s_end <= f.t0 {
            return;
        }
        let ends = [f.ray.at(f.t0), f.ray.at(s_end)];
        self.planes.push(PhotonPlane {
            origin: f.ray.origin,
            first: f.ray.direction,
            second,
            s_start: f.t0,
            s_end,
            u_end: exit_bound(&self.bounds, ends, second),
            tau,
            power: f.power,
        });
    }
}

/// A distance along `direction` past which every line from the segment `ends` has left the
/// box: per axis the distance to the far face is affine along the segment, so its largest
/// value is at an end, and the exit is the smallest over the axes.
fn exit_bound(bounds: &Aabb, ends: [Vec3; 2], direction: Vec3) -> f32 {
    let mut bound = f32::INFINITY;
    for a in 0..3 {
        let d = direction[a];
        if d == 0.0 {
            continue;
        }
        let face = if d > 0.0 {
            bounds.max[a]
        } else {
            bounds.min[a]
        };
        let far = ends
            .iter()
            .map(|p| (face - p[a]) / d)
            .fold(0.0f32, f32::max);
        bound = bound.min(far);
    }
    if bound.is_finite() { bound } else { 0.0 }
}

/// Traces photons as [`trace`](super::trace) does (the same paths for the same seed) and
/// returns every flight through the box as a plane, in photon-index order, with the
/// paths' statistics (`stored`: the planes).
pub fn trace_planes(
    medium: &Medium,
    lights: &[Light],
    settings: &TraceSettings,
    control: &Control<'_>,
) -> Result<(Vec<PhotonPlane>, PhotonStats)> {
    let start = std::time::Instant::now();
    let (chunk, total, per_light) = trace_chunks(
        lights,
        &emission_target(medium),
        settings,
        control,
        |photon, chunk: &mut PlaneChunk| {
            let mut record = PlaneRecord {
                planes: &mut chunk.planes,
                rng: Rng::stream(settings.seed, Domain::Planes, photon.index),
                phase: medium.phase(),
                bounds: medium.bounds(),
            };
            walk_path(medium, photon, settings, &mut record, &mut chunk.counters);
        },
        |all: &mut PlaneChunk, other: PlaneChunk| {
            all.planes.extend(other.planes);
            all.counters.merge(other.counters);
        },
    )?;
    let mut stats = chunk.counters.stats(total, per_light);
    stats.stored = chunk.planes.len() as u64;
    stats.stored_power = chunk.planes.iter().map(|p| mean3(p.power)).sum();
    stats.seconds = start.elapsed().as_secs_f64();
    Ok((chunk.planes, stats))
}

fn mean3(v: Vec3) -> f64 {
    (v.x as f64 + v.y as f64 + v.z as f64) / 3.0
}

/// A plane as the hierarchy stores it: the linear maps from a point to its plane
/// coordinates `(s, u, w)` (`w` the offset along the unit normal), the ranges that bound
/// the slab, and what a crossing needs.
#[derive(Debug, Clone, Copy)]
struct Slab {
    origin: Vec3,
    /// `s = dual_s·(x − origin)`, `u = dual_u·(x − origin)`, `w = normal·(x − origin)`.
    dual_s: Vec3,
    dual_u: Vec3,
    normal: Vec3,
    s_range: (f32, f32),
    u_end: f32,
    /// `1 / (2r·|ω_a × ω_{a+1}|)`: the blurred plane's weight per unit of eye-ray length.
    weight: f32,
    plane: u32,
}

/// One plane whose blurred slab an eye ray crosses.
#[derive(Debug, Clone, Copy)]
pub struct PlaneCrossing<'a> {
    /// The plane.
    pub plane: &'a PhotonPlane,
    /// Where the ray's stretch inside the slab (and the plane's ranges) begins and ends.
    pub t_enter: f32,
    /// See `t_enter`.
    pub t_exit: f32,
    /// The blurred plane's weight per unit of eye-ray length, `1/(2r·|ω_a × ω_{a+1}|)`.
    pub weight: f32,
    /// The plane coordinates `(s, u)` of the ray's point at `t`, as `a + b·t`.
    pub s: (f32, f32),
    /// See `s`.
    pub u: (f32, f32),
}

impl PlaneCrossing<'_> {
    /// The ray's point at `t` in plane coordinates: the middle vertex `x(s, 0)` and the
    /// distance `u` from it along the plane's second direction.
    pub fn vertex_at(&self, t: f32) -> (Vec3, f32) {
        let s = self.s.0 + self.s.1 * t;
        let u = self.u.0 + self.u.1 * t;
        (self.plane.origin + self.plane.first * s, u)
    }
}

/// The planes of one photon set, blurred to slabs of half-width `r`, in a bounding-volume
/// hierarchy an eye ray walks once.
#[derive(Debug)]
pub struct PlaneMap<'a> {
    planes: &'a [PhotonPlane],
    slabs: Vec<Slab>,
    bvh: Bvh,
    blur: f32,
}

impl<'a> PlaneMap<'a> {
    /// The slabs of `planes` at blur half-width `blur` (> 0). Planes whose two directions
    /// are parallel to f32 precision span no area and are left out (an event of
    /// probability ~1e-12 for a smooth phase function).
    pub fn new(planes: &'a [PhotonPlane], blur: f32) -> Self {
        let slabs: Vec<(Slab, Aabb)> = planes
            .par_iter()
            .enumerate()
            .filter_map(|(i, p)| slab_of(p, i as u32, blur))
            .collect();
        let (mut slabs, boxes): (Vec<Slab>, Vec<Aabb>) = slabs.into_iter().unzip();
        let mut order: Vec<(u32, Aabb)> = boxes
            .into_iter()
            .enumerate()
            .map(|(i, b)| (i as u32, b))
            .collect();
        let bvh = Bvh::new(&mut order);
        slabs = order.iter().map(|(i, _)| slabs[*i as usize]).collect();
        PlaneMap {
            planes,
            slabs,
            bvh,
            blur,
        }
    }

    /// The blur half-width.
    pub fn blur(&self) -> f32 {
        self.blur
    }

    /// Calls `visit` for every plane whose slab the ray crosses within `span`, in the
    /// hierarchy's fixed order, with the stretch of the crossing.
    pub fn crossings(
        &self,
        ray: &Ray,
        span: (f32, f32),
        stack: &mut Vec<u32>,
        mut visit: impl FnMut(PlaneCrossing<'_>),
    ) {
        let (t_min, t_max) = span;
        self.bvh.leaves_along(ray, span, stack, |leaf| {
            for slab in &self.slabs[leaf] {
                if let Some(c) = self.cross(slab, ray, t_min, t_max) {
                    visit(c);
                }
            }
        });
    }

    /// The ray's stretch inside `slab` (its three coordinate ranges) within `[t_min, t_max]`.
    #[inline]
    fn cross(&self, slab: &Slab, ray: &Ray, t_min: f32, t_max: f32) -> Option<PlaneCrossing<'_>> {
        let rel = ray.origin - slab.origin;
        let s = (slab.dual_s.dot(rel), slab.dual_s.dot(ray.direction));
        let u = (slab.dual_u.dot(rel), slab.dual_u.dot(ray.direction));
        let w = (slab.normal.dot(rel), slab.normal.dot(ray.direction));
        let (mut lo, mut hi) = (t_min, t_max);
        for (line, range) in [
            (s, slab.s_range),
            (u, (0.0, slab.u_end)),
            (w, (-self.blur, self.blur)),
        ] {
            (lo, hi) = clip_linear(line, range, lo, hi)?;
        }
        Some(PlaneCrossing {
            plane: &self.planes[slab.plane as usize],
            t_enter: lo,
            t_exit: hi,
            weight: slab.weight,
            s,
            u,
        })
    }
}

/// `[lo, hi]` narrowed to where `a + b·t` lies in `range`, or `None` when that is empty.
#[inline]
fn clip_linear((a, b): (f32, f32), range: (f32, f32), lo: f32, hi: f32) -> Option<(f32, f32)> {
    let (lo, hi) = if b == 0.0 {
        if a < range.0 || a > range.1 {
            return None;
        }
        (lo, hi)
    } else {
        let (t0, t1) = ((range.0 - a) / b, (range.1 - a) / b);
        (lo.max(t0.min(t1)), hi.min(t0.max(t1)))
    };
    (lo < hi).then_some((lo, hi))
}

/// The slab of plane `p` at half-width `blur` and its bounding box, or `None` for a plane
/// with parallel directions.
fn slab_of(p: &PhotonPlane, index: u32, blur: f32) -> Option<(Slab, Aabb)> {
    let cross = p.first.cross(p.second);
    let area = cross.length();
    if area < 1e-6 || blur <= 0.0 {
        return None;
    }
    let normal = cross / area;
    // Dual basis of (first, second) within the plane: dual_s·first = 1, dual_s·second = 0.
    let dual_s = p.second.cross(normal) / area;
    let dual_u = normal.cross(p.first) / area;
    let mut min = Vec3::splat(f32::INFINITY);
    let mut max = Vec3::splat(f32::NEG_INFINITY);
    for s in [p.s_start, p.s_end] {
        for u in [0.0, p.u_end] {
            for w in [-blur, blur] {
                let x = p.origin + p.first * s + p.second * u + normal * w;
                min = min.min(x);
                max = max.max(x);
            }
        }
    }
    let slab = Slab {
        origin: p.origin,
        dual_s,
        dual_u,
        normal,
        s_range: (p.s_start, p.s_end),
        u_end: p.u_end,
        weight: 1.0 / (2.0 * blur * area),
        plane: index,
    };
    Some((slab, Aabb::new(min, max)))
}

/// A slab's box in the hierarchy, with the slab's index before ordering.
impl Bounded for (u32, Aabb) {
    fn bounds(&self) -> (Vec3, Vec3) {
        (self.1.min, self.1.max)
    }
    fn centre(&self) -> Vec3 {
        self.1.center()
    }
    fn index(&self) -> u32 {
        self.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::medium::FreePath;
    use crate::test_util::{SPOT_SPHERE, scene};

    fn settings(photons: u64) -> TraceSettings {
        TraceSettings {
            photons,
            stored_target: 0,
            free_path: FreePath::Delta,
            stepsize: 0.002,
            seed: 9,
        }
    }

    #[test]
    fn planes_are_the_flights_of_the_photon_paths() {
        // Every photon the tracer stores (an interaction after a scattering) ends a flight
        // that began at a scattering, so it is where a plane of the same paths ends.
        let scene = scene(SPOT_SPHERE);
        let (medium, lights) = (scene.medium(), scene.lights());
        let (photons, _) =
            super::super::trace(medium, lights, &settings(2000), &Control::none()).expect("traced");
        let (planes, stats) =
            trace_planes(medium, lights, &settings(2000), &Control::none()).expect("traced");
        assert_eq!(stats.stored, planes.len() as u64);
        let light = lights[0].position();
        let ends: Vec<Vec3> = planes
            .iter()
            .filter(|p| p.origin != light)
            .map(|p| p.origin + p.first * p.s_end)
            .collect();
        assert!(photons.len() > 500, "{}", photons.len());
        for photon in &photons {
            let nearest = ends
                .iter()
                .map(|e| (*e - photon.position).length())
                .fold(f32::INFINITY, f32::min);
            assert!(
                nearest < 1e-5,
                "photon at {} ends no plane",
                photon.position
            );
        }
        for p in &planes {
            assert!(
                (p.first.length() - 1.0).abs() < 1e-5 && (p.second.length() - 1.0).abs() < 1e-5
            );
            assert!(p.s_end > p.s_start && p.tau > 0.0 && p.u_end >= 0.0);
        }
    }

    #[test]
    fn no_line_of_a_plane_is_inside_the_box_past_its_bound() {
        let bounds = Aabb::unit();
        let mut rng = Rng::stream(4, Domain::Misc, 0);
        for _ in 0..2000 {
            let mut point = || Vec3::new(rng.uniform(), rng.uniform(), rng.uniform());
            let ends = [point(), point()];
            let direction = crate::math::uniform_sphere(rng.uniform2());
            let bound = exit_bound(&bounds, ends, direction);
            for k in 0..=16 {
                let start = ends[0].lerp(ends[1], k as f32 / 16.0);
                let ray = Ray::new(start, direction);
                let (_, exit) = bounds.intersect(&ray).expect("inside");
                assert!(exit <= bound + 1e-5, "{exit} > {bound}");
            }
        }
    }

    #[test]
    fn the_hierarchy_finds_exactly_the_slabs_a_ray_crosses() {
        let mut rng = Rng::stream(5, Domain::Misc, 1);
        let planes: Vec<PhotonPlane> = (0..3000)
            .map(|_| {
                let origin = Vec3::new(rng.uniform(), rng.uniform(), rng.uniform());
                let first = crate::math::uniform_sphere(rng.uniform2());
                let second = crate::math::uniform_sphere(rng.uniform2());
                PhotonPlane {
                    origin,
                    first,
                    second,
                    s_start: 0.0,
                    s_end: 0.1 * rng.uniform(),
                    u_end: 0.2 * rng.uniform(),
                    tau: 1.0,
                    power: Vec3::ONE,
                }
            })
            .collect();
        let blur = 0.01;
        let map = PlaneMap::new(&planes, blur);
        let mut stack = Vec::new();
        for _ in 0..50 {
            let origin = Vec3::new(rng.uniform(), rng.uniform(), -0.5);
            let target = Vec3::new(rng.uniform(), rng.uniform(), 1.5);
            let ray = Ray::new(origin, (target - origin).normalize());
            let mut found = Vec::new();
            map.crossings(&ray, (0.2, 1.8), &mut stack, |c| {
                // The stretch lies on the plane's ranges and inside the slab.
                for t in [c.t_enter, c.t_exit] {
                    let (vertex, u) = c.vertex_at(t);
                    let s = (vertex - c.plane.origin).dot(c.plane.first);
                    assert!(s >= c.plane.s_start - 1e-4 && s <= c.plane.s_end + 1e-4);
                    assert!(u >= -1e-4 && u <= c.plane.u_end + 1e-4);
                    let off_plane = ray.at(t) - (vertex + c.plane.second * u);
                    assert!(off_plane.length() <= blur + 1e-4, "{}", off_plane.length());
                }
                found.push((c.t_enter, c.t_exit));
            });
            let mut expected = Vec::new();
            for (i, p) in planes.iter().enumerate() {
                if let Some((slab, _)) = slab_of(p, i as u32, blur)
                    && let Some(c) = map.cross(&slab, &ray, 0.2, 1.8)
                {
                    expected.push((c.t_enter, c.t_exit));
                }
            }
            found.sort_by(|a, b| a.0.total_cmp(&b.0));
            expected.sort_by(|a, b| a.0.total_cmp(&b.0));
            assert_eq!(found, expected);
        }
    }

    #[test]
    fn a_grazing_ray_weighs_no_more_than_the_slab_allows() {
        // A ray in the plane itself: the 0-D estimate's weight would be infinite; the slab
        // bounds the stretch by the plane's extent, so the blurred weight is finite.
        let plane = PhotonPlane {
            origin: Vec3::ZERO,
            first: Vec3::X,
            second: Vec3::Y,
            s_start: 0.0,
            s_end: 0.5,
            u_end: 0.5,
            tau: 1.0,
            power: Vec3::ONE,
        };
        let planes = [plane];
        let map = PlaneMap::new(&planes, 0.01);
        let ray = Ray::new(Vec3::new(-1.0, 0.25, 0.0), Vec3::X);
        let mut stack = Vec::new();
        let mut seen = Vec::new();
        map.crossings(&ray, (0.0, 10.0), &mut stack, |c| {
            seen.push((c.t_exit - c.t_enter) * c.weight)
        });
        assert_eq!(seen.len(), 1);
        // Stretch 0.5 (the plane's extent along x) over 2r = 0.02: weight 25.
        assert!((seen[0] - 25.0).abs() < 1e-3, "{seen:?}");
    }
}
