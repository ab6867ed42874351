//! Exact k-nearest-neighbour gathers for the nearby samples of one eye ray.
//!
//! The samples of an eye ray lie a stepsize apart (0.0005 in the thesis's scenes) while a
//! gather covers a sphere of radius ~0.01–0.1, so consecutive neighbourhoods overlap almost
//! entirely. One wide kd-tree query at a centre `c` returns every photon closer than some
//! `R` ([`Candidates`]). A gather at `p` whose `k` nearest candidates lie within `ρ` needs
//! only photons within `ρ + |p − c|` of the centre; while that stays below `R` those `k`
//! candidates *are* the `k` nearest photons of `p` (triangle inequality) — the answer is
//! exact, not approximate, and the tree is not walked again.
//!
//! Ties at equal distance are broken by photon index, so the set is canonical whatever the
//! candidates were, and sums are taken in fixed point ([`FixedSum`]), so their value does
//! not depend on the order the photons come in: an estimate is bit-identical however
//! gathers are shared, grouped or threaded.

use std::num::NonZeroUsize;

use glam::Vec3;
use kiddo::dist::SquaredEuclidean;

use super::map::{Gathered, PhotonMap};
use crate::medium::Phase;

/// A wide query asks for this many times the photons of the gather …
const WIDE_NEIGHBOURS: f32 = 2.0;
/// … within this many times its largest radius.
const WIDE_RADIUS: f32 = 1.25;
/// A range query near the last gather stops past this many photons for a gather of `k`
/// (it holds about 3–7 times `k` when the density is even; millions where a sparse
/// region's reach meets bone).
fn ball_limit(k: usize) -> usize {
    16 * k + 64
}
/// Float headroom on the validity test: the two distance computations (kiddo's and ours)
/// round differently by ~1e-7 relative.
const COMPLETENESS_MARGIN: f32 = 1.0 - 1e-4;

/// A gather key: `(squared distance bits << 32) | photon index` orders by distance, then
/// index (non-negative floats order as their bits).
#[inline]
pub(super) fn key(d2: f32, photon: u32) -> u64 {
    ((d2.to_bits() as u64) << 32) | photon as u64
}

/// The squared distance encoded in a gather key.
#[inline]
pub(super) fn key_distance2(key: u64) -> f32 {
    f32::from_bits((key >> 32) as u32)
}

/// Every photon closer than `complete_within` to `centre`, positions split by axis so the
/// distance loop vectorises, with each photon's fixed-point term cached for the current
/// direction (constant along an eye ray).
#[derive(Debug, Default, Clone)]
struct Candidates {
    /// The [`PhotonMap::id`] they came from (0: none yet).
    map: u64,
    centre: Vec3,
    complete_within: f32,
    xs: Vec<f32>,
    ys: Vec<f32>,
    zs: Vec<f32>,
    photons: Vec<u32>,
    /// Cached terms per [`Gathered`] kind, and what they were computed for.
    terms: [Vec<[i64; 3]>; 2],
    terms_for: [Option<(Vec3, u32, u64)>; 2],
}

/// The per-worker state of exact gathers: candidates, and the selected photons of the
/// last gather as `(key, candidate slot)`.
#[derive(Debug, Default, Clone)]
pub(super) struct Neighbours {
    candidates: Candidates,
    d2: Vec<f32>,
    selected: Vec<(u64, u32)>,
    /// Whether `selected` is sorted by key, and its largest entry when it holds `k`.
    sorted: bool,
    farthest: (u64, u32),
    /// The previous gather: point, `k`, `maxdist` and the distance of its `k`-th photon.
    previous: Option<(Vec3, usize, f32, f32)>,
}

impl Neighbours {
    /// The photons of the last gather, `(key, candidate slot)`.
    pub(super) fn selected(&self) -> &[(u64, u32)] {
        &self.selected
    }

    /// The largest entry of `selected[..n]`, for `n` the whole selection of a full gather
    /// (`k` photons) or any prefix of a sorted one.
    pub(super) fn farthest(&self, n: usize) -> (u64, u32) {
        if self.sorted {
            self.selected[n - 1]
        } else {
            debug_assert_eq!(n, self.selected.len());
            self.farthest
        }
    }

    /// Selects the `k` nearest photons within `maxdist` of `p` (ties broken by photon
    /// index), sorted by key when `sorted`.
    pub(super) fn gather(
        &mut self,
        map: &PhotonMap,
        p: Vec3,
        k: usize,
        maxdist: f32,
        sorted: bool,
    ) {
        self.selected.clear();
        self.sorted = sorted;
        if k == 0 || map.is_empty() {
            return;
        }
        // Attempt 0 reuses the candidates; 1 replaces them by a wide query at `p`; 2 (only
        // when photons tie at the wide query's farthest distance) by every photon within the
        // reach attempt 1 found, which is complete by construction.
        let mut reach = maxdist;
        // Candidates of another map are no candidates at all.
        let first = if self.candidates.map == map.id() {
            0
        } else {
            1
        };
        if first == 1 {
            self.previous = None;
        }
        for attempt in first..3 {
            match attempt {
                // A range query (k at least the photon count): every photon within a
                // ball a little wider than `maxdist`.
                1 if k >= map.len() => self.candidates.query_ball(map, p, maxdist * WIDE_RADIUS),
                // Near the last full gather, a ball a little wider than its bound holds the
                // k nearest of `p`: a range query, cheaper than a best-n one — unless the
                // ball reaches into much denser photons than the last gather saw (a sparse
                // region's wide reach stepping up to bone), where a best-n query bounded
                // by the same ball takes only the nearest.
                1 => match self.since_previous(p, k, maxdist) {
                    Some((r, moved)) if moved < 0.5 * r => {
                        let radius = ((r + moved) * WIDE_RADIUS).min(maxdist * WIDE_RADIUS);
                        if !self
                            .candidates
                            .query_ball_at_most(map, p, radius, ball_limit(k))
                        {
                            self.candidates.query_wide(map, p, k, radius)
                        }
                    }
                    _ => self.candidates.query_wide(map, p, k, maxdist * WIDE_RADIUS),
                },
                2 => self.candidates.query_ball(map, p, reach * (1.0 + 1e-3)),
                _ => {}
            }
            reach = self.select(p, k, maxdist);
            let offset = p.distance(self.candidates.centre);
            if attempt == 2
                || reach + offset <= self.candidates.complete_within * COMPLETENESS_MARGIN
            {
                break;
            }
        }
        if sorted {
            self.selected.sort_unstable_by_key(|s| s.0);
        }
    }

    /// The previous full gather's reach and the distance from its point to `p`, when it
    /// asked for the same `k` and `maxdist`: its `k` photons lie within `reach + moved` of
    /// `p` (triangle inequality), so the `k` nearest of `p` do too.
    fn since_previous(&self, p: Vec3, k: usize, maxdist: f32) -> Option<(f32, f32)> {
        match self.previous {
            Some((q, pk, pmax, reach)) if pk == k && pmax == maxdist => {
                Some((reach, p.distance(q)))
            }
            _ => None,
        }
    }

    /// The `k` nearest candidates within `maxdist` of `p` into `selected` (unsorted);
    /// returns their reach: the `k`-th distance, or `maxdist` when fewer were found.
    fn select(&mut self, p: Vec3, k: usize, maxdist: f32) -> f32 {
        let r2_max = maxdist * maxdist;
        // A tighter filter from the previous gather, the same answer.
        let r2_bound = match self.since_previous(p, k, maxdist) {
            Some((reach, moved)) => {
                let bound = (reach + moved) * (1.0 + 1e-5) + 1e-7;
                (bound * bound).min(r2_max)
            }
            None => r2_max,
        };
        self.candidates.distances2(p, &mut self.d2);
        self.filter(r2_bound);
        if self.selected.len() < k && r2_bound < r2_max {
            self.filter(r2_max);
        }
        let reach = if self.selected.len() < k {
            maxdist
        } else {
            // After the partial sort the `k`-th entry is the largest of the first `k`.
            self.farthest = if self.selected.len() > k {
                self.selected.select_nth_unstable_by_key(k - 1, |s| s.0);
                self.selected.truncate(k);
                self.selected[k - 1]
            } else {
                let largest = self.selected.iter().max_by_key(|s| s.0);
                *largest.expect("k > 0 photons selected")
            };
            key_distance2(self.farthest.0).sqrt()
        };
        self.previous = (self.selected.len() == k).then_some((p, k, maxdist, reach));
        reach
    }

    /// The candidates within `sqrt(r2)`, as `(key, slot)`.
    ///
    /// Branch-free: every candidate is written and the end advances only past those
    /// inside, because about half of them are, which a branch would mispredict.
    fn filter(&mut self, r2: f32) {
        let n = self.d2.len();
        self.selected.clear();
        self.selected.resize(n, (0, 0));
        let mut end = 0;
        for (slot, (&d2, &photon)) in self.d2.iter().zip(&self.candidates.photons).enumerate() {
            self.selected[end.min(n - 1)] = (key(d2, photon), slot as u32);
            end += usize::from(d2 <= r2);
        }
        self.selected.truncate(end);
    }

    /// The fixed-point sum of the terms of `selected[..n]` (see [`FixedSum`]).
    ///
    /// With `without_farthest` the photon with the largest key among them (the one that
    /// sets a k-NN radius) is left out: its term is subtracted, exactly, in fixed point.
    pub(super) fn sum(
        &mut self,
        map: &PhotonMap,
        n: usize,
        without_farthest: bool,
        gathered: Gathered,
        phase: Phase,
        wo: Vec3,
    ) -> Vec3 {
        let left_out = (without_farthest && n > 0).then(|| self.farthest(n).1);
        let scale = FixedSum::scale(map.term_bound(gathered, phase));
        let terms = self.candidates.terms(map, gathered, phase, wo, scale);
        let mut sum = [0i64; 3];
        for &(_, slot) in &self.selected[..n] {
            let t = terms[slot as usize];
            for a in 0..3 {
                sum[a] = sum[a].saturating_add(t[a]);
            }
        }
        if let Some(slot) = left_out {
            let t = terms[slot as usize];
            for a in 0..3 {
                sum[a] = sum[a].saturating_sub(t[a]);
            }
        }
        FixedSum::value(sum, scale)
    }
}

impl Candidates {
    /// Replaces the candidates by one wide query at `p`: the nearest photons (a few times
    /// `k`) within `radius`.
    fn query_wide(&mut self, map: &PhotonMap, p: Vec3, k: usize, radius: f32) {
        let wide = (k as f32 * WIDE_NEIGHBOURS).ceil() as usize + 16;
        let found = map
            .tree()
            .query(&p.to_array())
            .nearest_n::<SquaredEuclidean<f32>>(NonZeroUsize::new(wide).expect("wide > 0"))
            .within(radius * radius)
            .unsorted()
            .execute();
        // A full answer holds every photon strictly closer than its farthest one; a short
        // one holds every photon within the query radius.
        let complete_within = if found.len() == wide {
            found.iter().fold(0.0f32, |m, h| m.max(h.distance)).sqrt() * (1.0 - 1e-6)
        } else {
            radius
        };
        self.keep(map, p, complete_within, found.iter().map(|h| h.item));
    }

    /// Replaces the candidates by every photon within `radius` of `p` (a closed ball).
    fn query_ball(&mut self, map: &PhotonMap, p: Vec3, radius: f32) {
        let found = map
            .tree()
            .query(&p.to_array())
            .within::<SquaredEuclidean<f32>>(radius * radius)
            .unsorted()
            .execute();
        self.keep(map, p, radius, found.iter().map(|h| h.item));
    }

    /// Replaces the candidates by every photon within `radius` of `p`, as
    /// [`query_ball`](Self::query_ball) does, when there are at most `limit` of them;
    /// otherwise stops walking the tree at the first photon past the limit, leaves no
    /// candidates and returns `false`.
    fn query_ball_at_most(&mut self, map: &PhotonMap, p: Vec3, radius: f32, limit: usize) -> bool {
        // One statement: the iterator borrows the query it is built from.
        self.keep(
            map,
            p,
            radius,
            map.tree()
                .query(&p.to_array())
                .within::<SquaredEuclidean<f32>>(radius * radius)
                .unsorted()
                .iter()
                .take(limit + 1)
                .map(|h| h.item),
        );
        let complete = self.photons.len() <= limit;
        if !complete {
            self.map = 0;
        }
        complete
    }

    fn keep(
        &mut self,
        map: &PhotonMap,
        centre: Vec3,
        complete_within: f32,
        items: impl Iterator<Item = u32>,
    ) {
        self.map = map.id();
        self.centre = centre;
        self.complete_within = complete_within;
        self.xs.clear();
        self.ys.clear();
        self.zs.clear();
        self.photons.clear();
        self.terms_for = [None; 2];
        for i in items {
            let q = map.photons()[i as usize].position;
            self.xs.push(q.x);
            self.ys.push(q.y);
            self.zs.push(q.z);
            self.photons.push(i);
        }
    }

    /// Squared distances from `p` to every candidate.
    fn distances2(&self, p: Vec3, out: &mut Vec<f32>) {
        out.clear();
        out.extend(
            self.xs
                .iter()
                .zip(&self.ys)
                .zip(&self.zs)
                .map(|((x, y), z)| {
                    let (dx, dy, dz) = (x - p.x, y - p.y, z - p.z);
                    dx * dx + dy * dy + dz * dz
                }),
        );
    }

    /// Every candidate's fixed-point term for `(gathered, phase, wo)`, computed once per
    /// candidate set and direction.
    fn terms(
        &mut self,
        map: &PhotonMap,
        gathered: Gathered,
        phase: Phase,
        wo: Vec3,
        scale: f64,
    ) -> &[[i64; 3]] {
        let which = gathered as usize;
        let wanted = Some((wo, phase.g().to_bits(), scale.to_bits()));
        if self.terms_for[which] != wanted {
            let photons = map.photons();
            self.terms[which].clear();
            self.terms[which].extend(self.photons.iter().map(|&i| {
                FixedSum::fixed(
                    PhotonMap::term(&photons[i as usize], gathered, phase, wo),
                    scale,
                )
            }));
            self.terms_for[which] = wanted;
        }
        &self.terms[which]
    }
}

/// Order-independent sums of non-negative `Vec3` terms: each term in fixed point at a
/// power-of-two scale chosen from a bound on any sum (2⁶² × scale ≥ the bound, so nothing
/// overflows and the resolution is 2⁻⁶² of the bound), summed as integers. Integer
/// addition is associative, so a sum is bit-identical in whatever order its terms come.
pub(super) struct FixedSum;

impl FixedSum {
    /// The scale for sums of at most `bound`.
    pub(super) fn scale(bound: f32) -> f64 {
        let exponent = if bound.is_finite() && bound > 0.0 {
            62 - (bound as f64).log2().ceil() as i32
        } else {
            0
        };
        2f64.powi(exponent)
    }

    /// `term` in fixed point.
    #[inline]
    pub(super) fn fixed(term: Vec3, scale: f64) -> [i64; 3] {
        term.to_array().map(|t| (t as f64 * scale) as i64)
    }

    /// The value of a fixed-point sum.
    pub(super) fn value(sum: [i64; 3], scale: f64) -> Vec3 {
        Vec3::from_array(sum.map(|s| (s as f64 / scale) as f32))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::{Domain, Rng};
    use crate::photon::map::uniform_cloud;
    use crate::photon::{Photon, PhotonStats};

    /// Every photon within `maxdist`, sorted: the brute-force answer.
    fn brute_gather(map: &PhotonMap, p: Vec3, k: usize, maxdist: f32) -> Vec<u64> {
        let mut all: Vec<u64> = (0..map.len() as u32)
            .map(|i| key(map.photons()[i as usize].position.distance_squared(p), i))
            .filter(|&k| key_distance2(k) <= maxdist * maxdist)
            .collect();
        all.sort_unstable();
        all.truncate(k);
        all
    }

    fn gathered(n: &mut Neighbours, map: &PhotonMap, p: Vec3, k: usize, maxdist: f32) -> Vec<u64> {
        n.gather(map, p, k, maxdist, true);
        n.selected().iter().map(|s| s.0).collect()
    }

    #[test]
    fn gathers_reusing_candidates_along_a_path_equal_brute_force_ones() {
        let map = uniform_cloud(20_000, 1.0, 2);
        let mut rng = Rng::stream(5, Domain::Misc, 0);
        let mut neighbours = Neighbours::default();
        let mut p = Vec3::splat(0.5);
        let mut reused = 0;
        for step in 0..3000 {
            // A random walk with occasional jumps, as eye rays and new rays give.
            p = if step % 100 == 0 {
                Vec3::new(rng.uniform(), rng.uniform(), rng.uniform())
            } else {
                p + (Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()) - 0.5) * 0.004
            };
            for (k, maxdist) in [(150, 0.1), (40, 0.5), (150, 0.03), (1, 0.2)] {
                let centre = neighbours.candidates.centre;
                let got = gathered(&mut neighbours, &map, p, k, maxdist);
                reused += usize::from(neighbours.candidates.centre == centre);
                assert_eq!(got, brute_gather(&map, p, k, maxdist), "step {step}, k {k}");
            }
        }
        // The point of the candidates: most gathers do not walk the tree.
        assert!(
            reused > 6000,
            "only {reused} of 12000 gathers reused candidates"
        );
    }

    #[test]
    fn a_sparse_reach_stepping_towards_dense_photons_keeps_few_candidates() {
        // 2 000 photons spread through the cube and 60 000 in a ball of radius 0.02 at its
        // centre: an eye ray from the sparse side reaches the ball with a reach of ~0.2.
        let mut rng = Rng::stream(11, Domain::Misc, 0);
        let mut point = |spread: f32| {
            (Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()) - 0.5) * spread
                + Vec3::splat(0.5)
        };
        let mut positions: Vec<Vec3> = (0..2000).map(|_| point(1.0)).collect();
        positions.extend(
            (0..60_000)
                .map(|_| point(0.023))
                .filter(|q| q.distance(Vec3::splat(0.5)) < 0.02),
        );
        let photons = positions
            .into_iter()
            .map(|position| Photon {
                position,
                direction: Vec3::Z,
                power: Vec3::ONE,
                sigma_t: 1.0,
            })
            .collect();
        let map = PhotonMap::new(photons, PhotonStats::default());
        let (k, maxdist) = (50, 0.5);
        let limit = ball_limit(k);
        let mut neighbours = Neighbours::default();
        let mut most = 0;
        for step in 0..100 {
            let p = Vec3::new(0.1 + 0.004 * step as f32, 0.5, 0.5);
            let got = gathered(&mut neighbours, &map, p, k, maxdist);
            assert_eq!(got, brute_gather(&map, p, k, maxdist), "step {step}");
            most = most.max(neighbours.candidates.photons.len());
        }
        assert!(
            most <= limit,
            "{most} candidates for k = {k} (limit {limit})"
        );
    }

    #[test]
    fn range_queries_gather_every_photon_within_the_radius() {
        let map = uniform_cloud(5000, 1.0, 2);
        let mut neighbours = Neighbours::default();
        for (i, p) in [
            Vec3::splat(0.5),
            Vec3::new(0.51, 0.5, 0.5),
            Vec3::splat(0.02),
        ]
        .into_iter()
        .enumerate()
        {
            let got = gathered(&mut neighbours, &map, p, usize::MAX, 0.1);
            assert_eq!(got, brute_gather(&map, p, usize::MAX, 0.1), "point {i}");
        }
    }

    #[test]
    fn candidates_of_another_map_are_not_reused() {
        let (a, b) = (uniform_cloud(5000, 1.0, 2), uniform_cloud(7000, 1.0, 2));
        let mut neighbours = Neighbours::default();
        let p = Vec3::splat(0.5);
        gathered(&mut neighbours, &a, p, 50, 0.2);
        assert_eq!(
            gathered(&mut neighbours, &b, p, 50, 0.2),
            brute_gather(&b, p, 50, 0.2)
        );
    }

    #[test]
    fn ties_at_the_wide_query_boundary_still_gather_exactly() {
        // A lattice: many photons at exactly equal distances.
        let photons = (0..1000)
            .map(|i| Photon {
                position: Vec3::new((i % 10) as f32, ((i / 10) % 10) as f32, (i / 100) as f32)
                    * 0.1,
                direction: Vec3::Z,
                power: Vec3::ONE,
                sigma_t: 1.0,
            })
            .collect();
        let map = PhotonMap::new(photons, PhotonStats::default());
        let mut neighbours = Neighbours::default();
        for p in [
            Vec3::splat(0.4),
            Vec3::new(0.45, 0.4, 0.4),
            Vec3::splat(0.0),
        ] {
            for k in [1, 6, 7, 27, 100] {
                let got = gathered(&mut neighbours, &map, p, k, 0.5);
                assert_eq!(got, brute_gather(&map, p, k, 0.5), "{p} k {k}");
            }
        }
    }

    #[test]
    fn fixed_sums_do_not_depend_on_order() {
        let mut rng = Rng::stream(9, Domain::Misc, 0);
        let terms: Vec<Vec3> = (0..300)
            .map(|_| Vec3::new(rng.uniform(), rng.uniform() * 1e-3, rng.uniform() * 1e3))
            .collect();
        let scale = FixedSum::scale(300.0 * 1e3);
        let total = |ts: &[Vec3]| {
            let mut s = [0i64; 3];
            for t in ts {
                let f = FixedSum::fixed(*t, scale);
                (0..3).for_each(|a| s[a] += f[a]);
            }
            FixedSum::value(s, scale)
        };
        let forward = total(&terms);
        let mut reversed = terms.clone();
        reversed.reverse();
        assert_eq!(forward, total(&reversed));
        let float: Vec3 = terms.iter().sum();
        assert!((forward - float).abs().max_element() <= 1e-5 * float.max_element());
    }
}
