//! Photons as spheres for the beam radiance estimate (Jarosz, Zwicker & Jensen 2008): each
//! photon gets a radius — fixed, or the distance to its `k`-th nearest photon (the
//! "sample-point" kernel, measured at the photon rather than at the query) — and the
//! spheres go into a bounding-volume hierarchy that an eye ray walks once to find every
//! photon whose sphere it crosses.

use std::num::NonZeroUsize;

use glam::Vec3;
use kiddo::SquaredEuclidean;
use rayon::prelude::*;

use super::bvh::{Bounded, Bvh};
use super::map::{Gathered, PhotonMap};
use crate::math::Ray;
use crate::medium::{Medium, Phase};
use crate::scene::RadiusRule;

/// How each photon's sphere radius is chosen.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum BeamRadius {
    /// Every photon the same radius.
    Fixed(f32),
    /// From the distance `r_k` to each photon's `k`-th nearest photon (itself counted), at
    /// most `max`, by `rule` ([`RadiusRule`]), times `scale` (progressive beams shrink every
    /// radius by one factor).
    Nearest {
        /// Neighbours that set the radius.
        k: u32,
        /// The largest radius.
        max: f32,
        /// The factor applied to every radius.
        scale: f32,
        /// `Nearest`: `r_k`; `Global`: the median `r_k` for every photon; `Balanced`:
        /// `r_k^(3/7)·σt^(−4/7)` scaled to the median `r_k`.
        rule: RadiusRule,
    },
}

/// A photon's sphere, as the hierarchy stores it.
#[derive(Debug, Clone, Copy)]
struct Sphere {
    center: Vec3,
    radius2: f32,
    /// `1 / (V·share)`: the kernel's normalisation (`share` the medium's part of the sphere
    /// for the masked form, else 1).
    inv_volume: f32,
    photon: u32,
}

impl Bounded for Sphere {
    fn bounds(&self) -> (Vec3, Vec3) {
        let r = self.radius2.sqrt();
        (self.center - r, self.center + r)
    }
    fn centre(&self) -> Vec3 {
        self.center
    }
    fn index(&self) -> u32 {
        self.photon
    }
}

/// A photon map's photons as spheres in a bounding-volume hierarchy.
#[derive(Debug)]
pub struct BeamMap<'a> {
    map: &'a PhotonMap,
    spheres: Vec<Sphere>,
    bvh: Bvh,
    mean_radius: f32,
}

/// One photon whose sphere an eye ray crosses.
#[derive(Debug, Clone, Copy)]
pub struct Crossing {
    /// Where the chord through the sphere begins and ends along the ray.
    pub t_enter: f32,
    /// See `t_enter`.
    pub t_exit: f32,
    /// The photon's term (`p·ΔΦ/σt` for fluence, `p·ΔΦ` for flux) over its kernel volume.
    pub density: Vec3,
}

impl<'a> BeamMap<'a> {
    /// The spheres of `map`'s photons; with `masked`, each kernel is normalised by the
    /// medium's share of its sphere (photons cannot sit in empty space).
    pub fn new(map: &'a PhotonMap, radius: BeamRadius, medium: &Medium, masked: bool) -> Self {
        let radii = photon_radii(map, radius);
        let mut spheres: Vec<Sphere> = map
            .photons()
            .par_iter()
            .zip(&radii)
            .enumerate()
            .filter(|(_, (_, r))| **r > 0.0)
            .map(|(i, (photon, &r))| {
                let share = if masked {
                    medium.occupancy(photon.position, r)
                } else {
                    1.0
                };
                let volume = 4.0 / 3.0 * std::f32::consts::PI * r * r * r * share;
                Sphere {
                    center: photon.position,
                    radius2: r * r,
                    inv_volume: if volume > 0.0 { 1.0 / volume } else { 0.0 },
                    photon: i as u32,
                }
            })
            .collect();
        let mean_radius = if radii.is_empty() {
            0.0
        } else {
            (radii.iter().map(|&r| r as f64).sum::<f64>() / radii.len() as f64) as f32
        };
        let bvh = Bvh::new(&mut spheres);
        BeamMap {
            map,
            spheres,
            bvh,
            mean_radius,
        }
    }

    /// The mean sphere radius.
    pub fn mean_radius(&self) -> f32 {
        self.mean_radius
    }

    /// Calls `visit` for every photon whose sphere the ray crosses within `span`
    /// (`[t_min, t_max]`), in a fixed order (the hierarchy's), with its chord clipped to that
    /// interval and its term towards `wo` (the direction back along the ray).
    pub fn crossings(
        &self,
        ray: &Ray,
        span: (f32, f32),
        gathered: Gathered,
        phase: Phase,
        stack: &mut Vec<u32>,
        mut visit: impl FnMut(Crossing),
    ) {
        let (t_min, t_max) = span;
        let wo = -ray.direction;
        self.bvh.leaves_along(ray, span, stack, |leaf| {
            for sphere in &self.spheres[leaf] {
                let to_center = sphere.center - ray.origin;
                let t_c = to_center.dot(ray.direction);
                let d2 = (to_center - ray.direction * t_c).length_squared();
                if d2 >= sphere.radius2 {
                    continue;
                }
                let half = (sphere.radius2 - d2).sqrt();
                let (t_enter, t_exit) = ((t_c - half).max(t_min), (t_c + half).min(t_max));
                if t_enter >= t_exit {
                    continue;
                }
                let photon = &self.map.photons()[sphere.photon as usize];
                let term = PhotonMap::term(photon, gathered, phase, wo);
                visit(Crossing {
                    t_enter,
                    t_exit,
                    density: term * sphere.inv_volume,
                });
            }
        });
    }
}

impl BeamMap<'_> {
    /// The sum of the terms (as [`Crossing::density`]) of every photon whose sphere holds
    /// `x`, towards `wo`: the sample-point density estimate with each photon's own radius.
    pub fn density_at(
        &self,
        x: Vec3,
        gathered: Gathered,
        phase: Phase,
        wo: Vec3,
        stack: &mut Vec<u32>,
    ) -> Vec3 {
        let mut sum = Vec3::ZERO;
        self.bvh.leaves_holding(x, stack, |leaf| {
            for sphere in &self.spheres[leaf] {
                if (x - sphere.center).length_squared() < sphere.radius2 {
                    let photon = &self.map.photons()[sphere.photon as usize];
                    sum += PhotonMap::term(photon, gathered, phase, wo) * sphere.inv_volume;
                }
            }
        });
        sum
    }
}

/// Each photon's radius.
fn photon_radii(map: &PhotonMap, radius: BeamRadius) -> Vec<f32> {
    match radius {
        BeamRadius::Fixed(r) => vec![r; map.len()],
        BeamRadius::Nearest {
            k,
            max,
            scale,
            rule,
        } => {
            let nearest = nearest_distances(map, k, max);
            let radii = match rule {
                RadiusRule::Nearest | RadiusRule::Auto => nearest,
                RadiusRule::Global => vec![median(&nearest); nearest.len()],
                RadiusRule::Balanced => balanced(map, &nearest, max),
            };
            radii.into_iter().map(|r| r * scale).collect()
        }
    }
}

/// The distance from each photon to its `k`-th nearest photon (itself counted), or `max`
/// when fewer than `k` lie within `max`.
fn nearest_distances(map: &PhotonMap, k: u32, max: f32) -> Vec<f32> {
    let k = NonZeroUsize::new(k.max(1) as usize).expect("k ≥ 1");
    map.photons()
        .par_iter()
        .map(|photon| {
            let found = map
                .tree()
                .query(&photon.position.to_array())
                .nearest_n::<SquaredEuclidean<f32>>(k)
                .within(max * max)
                .unsorted()
                .execute();
            if found.len() < k.get() {
                max
            } else {
                found.iter().fold(0.0f32, |m, h| m.max(h.distance)).sqrt()
            }
        })
        .collect()
}

/// The median of `values` (0 when empty).
fn median(values: &[f32]) -> f32 {
    if values.is_empty() {
        return 0.0;
    }
    let mut sorted = values.to_vec();
    let mid = sorted.len() / 2;
    *sorted.select_nth_unstable_by(mid, f32::total_cmp).1
}

/// The balanced radii ([`RadiusRule::Balanced`]): `r_k^(3/7)·σt^(−4/7)` at each photon,
/// scaled so that their median is the median `r_k`, at most `max`. A photon stored where
/// σt = 0 (the thesis's free-path rule) keeps its `r_k`.
fn balanced(map: &PhotonMap, nearest: &[f32], max: f32) -> Vec<f32> {
    let shape: Vec<f32> = map
        .photons()
        .iter()
        .zip(nearest)
        .map(|(p, &r)| {
            if p.sigma_t > 0.0 {
                r.powf(3.0 / 7.0) * p.sigma_t.powf(-4.0 / 7.0)
            } else {
                0.0
            }
        })
        .collect();
    let positive: Vec<f32> = shape.iter().copied().filter(|g| *g > 0.0).collect();
    let scale = median(nearest) / median(&positive).max(f32::MIN_POSITIVE);
    shape
        .iter()
        .zip(nearest)
        .map(|(&g, &r)| if g > 0.0 { (g * scale).min(max) } else { r })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::photon::map::uniform_cloud;

    #[test]
    fn the_hierarchy_finds_exactly_the_spheres_a_ray_crosses() {
        let map = uniform_cloud(3000, 1.0, 7);
        let scene = crate::test_util::scene(crate::test_util::SMALL_SCENE);
        let beams = BeamMap::new(&map, BeamRadius::Fixed(0.03), scene.medium(), false);
        let mut rng = crate::math::Rng::stream(3, crate::math::Domain::Pixels, 1);
        let mut stack = Vec::new();
        for _ in 0..50 {
            let origin = Vec3::new(rng.uniform(), rng.uniform(), -0.5);
            let direction = (Vec3::new(rng.uniform(), rng.uniform(), 1.5) - origin).normalize();
            let ray = Ray { origin, direction };
            let mut found = Vec::new();
            beams.crossings(
                &ray,
                (0.2, 1.8),
                Gathered::Flux,
                Phase::ISOTROPIC,
                &mut stack,
                |c| found.push((c.t_enter, c.t_exit)),
            );
            let mut expected = Vec::new();
            for p in map.photons() {
                let t_c = (p.position - origin).dot(direction);
                let d2 = (p.position - ray.at(t_c)).length_squared();
                if d2 < 0.03 * 0.03 {
                    let half = (0.03f32 * 0.03 - d2).sqrt();
                    let (a, b) = ((t_c - half).max(0.2), (t_c + half).min(1.8));
                    if a < b {
                        expected.push((a, b));
                    }
                }
            }
            found.sort_by(|a, b| a.0.total_cmp(&b.0));
            expected.sort_by(|a, b| a.0.total_cmp(&b.0));
            assert_eq!(found.len(), expected.len());
            for (f, e) in found.iter().zip(&expected) {
                assert!((f.0 - e.0).abs() < 1e-5 && (f.1 - e.1).abs() < 1e-5);
            }
        }
    }

    #[test]
    fn balanced_radii_shrink_with_the_extinction_and_keep_the_median() {
        // Uniform photons, half stored where σt = 1 and half where σt = 16 (alternating):
        // their k-NN distances are alike, so the balanced radii differ by 16^(−4/7) ≈ 0.2
        // between the halves, and their median is the median k-NN distance.
        let mut map = uniform_cloud(4000, 1.0, 7);
        let photons: Vec<_> = map
            .photons()
            .iter()
            .enumerate()
            .map(|(i, p)| crate::photon::Photon {
                sigma_t: if i % 2 == 0 { 1.0 } else { 16.0 },
                ..*p
            })
            .collect();
        map = PhotonMap::new(photons, Default::default());
        let radii = |rule| {
            photon_radii(
                &map,
                BeamRadius::Nearest {
                    k: 10,
                    max: 1.0,
                    scale: 1.0,
                    rule,
                },
            )
        };
        let (nearest, balanced, global) = (
            radii(RadiusRule::Nearest),
            radii(RadiusRule::Balanced),
            radii(RadiusRule::Global),
        );
        assert!(global.iter().all(|&r| r == median(&nearest)));
        assert!((median(&balanced) / median(&nearest) - 1.0).abs() < 0.02);
        let half = |parity: usize| -> Vec<f32> {
            balanced.iter().skip(parity).step_by(2).copied().collect()
        };
        let ratio = median(&half(1)) / median(&half(0));
        assert!(
            (ratio / 16f32.powf(-4.0 / 7.0) - 1.0).abs() < 0.1,
            "{ratio}"
        );
    }

    #[test]
    fn the_density_at_a_point_sums_exactly_the_spheres_that_hold_it() {
        let map = uniform_cloud(3000, 1.0, 3);
        let scene = crate::test_util::scene(crate::test_util::SMALL_SCENE);
        let radius = BeamRadius::Nearest {
            k: 8,
            max: 0.2,
            scale: 1.0,
            rule: RadiusRule::Nearest,
        };
        let beams = BeamMap::new(&map, radius, scene.medium(), false);
        let radii = photon_radii(&map, radius);
        let mut rng = crate::math::Rng::stream(4, crate::math::Domain::Misc, 2);
        let mut stack = Vec::new();
        for _ in 0..200 {
            let x = Vec3::new(rng.uniform(), rng.uniform(), rng.uniform());
            let got = beams.density_at(x, Gathered::Flux, Phase::ISOTROPIC, Vec3::Z, &mut stack);
            let expected: Vec3 = map
                .photons()
                .iter()
                .zip(&radii)
                .filter(|(p, r)| (p.position - x).length_squared() < *r * *r)
                .map(|(p, r)| {
                    let term = PhotonMap::term(p, Gathered::Flux, Phase::ISOTROPIC, Vec3::Z);
                    term / (4.0 / 3.0 * std::f32::consts::PI * r * r * r)
                })
                .sum();
            assert!(
                (got - expected).length() <= 1e-4 * expected.length().max(1e-6),
                "{got} vs {expected}"
            );
        }
    }

    #[test]
    fn nearest_radii_are_the_kth_neighbour_distance() {
        let map = uniform_cloud(2000, 1.0, 7);
        let radii = photon_radii(
            &map,
            BeamRadius::Nearest {
                k: 10,
                max: 1.0,
                scale: 1.0,
                rule: RadiusRule::Nearest,
            },
        );
        for (i, p) in map.photons().iter().enumerate().step_by(97) {
            let mut d: Vec<f32> = map
                .photons()
                .iter()
                .map(|q| (q.position - p.position).length_squared())
                .collect();
            d.sort_by(f32::total_cmp);
            assert!((radii[i] - d[9].sqrt()).abs() < 1e-6, "photon {i}");
        }
    }
}
