//! The bounding-volume hierarchy the beam and plane estimates share: boxes over items
//! (photon spheres, blurred photon planes), split at the median of their centres on the
//! longest axis, and walked by an eye ray (or a point) down to the leaves it may touch.
//! Ties in the split are broken by each item's index, so the tree — and with it the order
//! in which a ray meets the items, and so the rounding of every sum — is canonical.

use std::ops::Range;

use glam::Vec3;

use crate::math::Ray;

/// Leaves hold at most this many items.
const LEAF_SIZE: usize = 4;

/// What the hierarchy needs of an item.
pub(super) trait Bounded {
    /// The item's box `(min, max)`.
    fn bounds(&self) -> (Vec3, Vec3);
    /// The point the item is sorted by when its node is split.
    fn centre(&self) -> Vec3;
    /// The item's canonical index (it breaks ties in the split).
    fn index(&self) -> u32;
}

/// One node of the hierarchy: a box, and either two children or a range of items.
#[derive(Debug, Clone, Copy)]
struct Node {
    min: Vec3,
    max: Vec3,
    /// Leaf: first item; inner: index of the second child (the first follows the node).
    start: u32,
    /// Leaf: item count; inner: 0.
    count: u32,
}

/// A hierarchy over a slice of items, which [`Bvh::new`] reorders so that every leaf holds
/// a contiguous range of it.
#[derive(Debug, Default)]
pub(super) struct Bvh {
    nodes: Vec<Node>,
}

impl Bvh {
    /// The hierarchy over `items`, reordering them in place.
    pub(super) fn new<T: Bounded>(items: &mut [T]) -> Self {
        let mut nodes = Vec::with_capacity(2 * items.len() / LEAF_SIZE + 1);
        if !items.is_empty() {
            build(items, 0, items.len(), &mut nodes);
        }
        Bvh { nodes }
    }

    /// Calls `leaf` with the item range of every leaf whose box the ray meets within
    /// `span` (`[t_min, t_max]`), in the hierarchy's fixed order.
    pub(super) fn leaves_along(
        &self,
        ray: &Ray,
        span: (f32, f32),
        stack: &mut Vec<u32>,
        leaf: impl FnMut(Range<usize>),
    ) {
        let (t_min, t_max) = span;
        if t_max <= t_min {
            return;
        }
        let inv_dir = ray.direction.recip();
        self.walk(
            stack,
            |node| slab_hit(node.min, node.max, ray.origin, inv_dir, t_min, t_max),
            leaf,
        );
    }

    /// Calls `leaf` with the item range of every leaf whose box holds `x`.
    pub(super) fn leaves_holding(
        &self,
        x: Vec3,
        stack: &mut Vec<u32>,
        leaf: impl FnMut(Range<usize>),
    ) {
        self.walk(
            stack,
            |node| !(x.cmplt(node.min).any() || x.cmpgt(node.max).any()),
            leaf,
        );
    }

    /// Depth first through the nodes `enter` accepts, first child before second.
    fn walk(
        &self,
        stack: &mut Vec<u32>,
        enter: impl Fn(&Node) -> bool,
        mut leaf: impl FnMut(Range<usize>),
    ) {
        if self.nodes.is_empty() {
            return;
        }
        stack.clear();
        stack.push(0);
        while let Some(index) = stack.pop() {
            let node = self.nodes[index as usize];
            if !enter(&node) {
                continue;
            }
            if node.count == 0 {
                stack.push(node.start);
                stack.push(index + 1);
            } else {
                leaf(node.start as usize..(node.start + node.count) as usize);
            }
        }
    }
}

/// Whether the ray from `origin` with inverse direction `inv_dir` meets the box `[min, max]`
/// within `[t_min, t_max]`.
#[inline]
fn slab_hit(min: Vec3, max: Vec3, origin: Vec3, inv_dir: Vec3, t_min: f32, t_max: f32) -> bool {
    let t1 = (min - origin) * inv_dir;
    let t2 = (max - origin) * inv_dir;
    let near = t1.min(t2).max_element().max(t_min);
    let far = t1.max(t2).min_element().min(t_max);
    // NaN (a zero direction component on the slab's plane) counts as a hit.
    near.partial_cmp(&far) != Some(std::cmp::Ordering::Greater)
}

/// Builds the subtree of `items[start..end]`, appending its nodes in depth-first order.
fn build<T: Bounded>(items: &mut [T], start: usize, end: usize, nodes: &mut Vec<Node>) {
    let (mut min, mut max) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    let (mut cmin, mut cmax) = (min, max);
    for item in &items[start..end] {
        let (lo, hi) = item.bounds();
        min = min.min(lo);
        max = max.max(hi);
        cmin = cmin.min(item.centre());
        cmax = cmax.max(item.centre());
    }
    let index = nodes.len();
    nodes.push(Node {
        min,
        max,
        start: start as u32,
        count: (end - start) as u32,
    });
    if end - start <= LEAF_SIZE {
        return;
    }
    // The first longest axis (x before y before z on ties).
    let axis = (cmax - cmin).max_position();
    let mid = (start + end) / 2;
    items[start..end].select_nth_unstable_by(mid - start, |a, b| {
        a.centre()[axis]
            .total_cmp(&b.centre()[axis])
            .then(a.index().cmp(&b.index()))
    });
    build(items, start, mid, nodes);
    let second = nodes.len() as u32;
    build(items, mid, end, nodes);
    nodes[index].start = second;
    nodes[index].count = 0;
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A point with its index, boxed by a cube of half-side `h`.
    struct Dot(Vec3, u32, f32);

    impl Bounded for Dot {
        fn bounds(&self) -> (Vec3, Vec3) {
            (self.0 - self.2, self.0 + self.2)
        }
        fn centre(&self) -> Vec3 {
            self.0
        }
        fn index(&self) -> u32 {
            self.1
        }
    }

    fn dots(n: u32) -> Vec<Dot> {
        let mut rng = crate::math::Rng::stream(5, crate::math::Domain::Pixels, 2);
        (0..n)
            .map(|i| {
                Dot(
                    Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()),
                    i,
                    0.05,
                )
            })
            .collect()
    }

    #[test]
    fn a_point_reaches_exactly_the_leaves_whose_items_may_hold_it() {
        let mut items = dots(500);
        let bvh = Bvh::new(&mut items);
        let mut stack = Vec::new();
        for x in [Vec3::splat(0.5), Vec3::new(0.1, 0.9, 0.3), Vec3::splat(2.0)] {
            let mut seen = Vec::new();
            bvh.leaves_holding(x, &mut stack, |r| {
                seen.extend(
                    items[r]
                        .iter()
                        .filter(|d| (d.0 - x).abs().max_element() <= d.2)
                        .map(|d| d.1),
                )
            });
            let mut want: Vec<u32> = items
                .iter()
                .filter(|d| (d.0 - x).abs().max_element() <= d.2)
                .map(|d| d.1)
                .collect();
            seen.sort_unstable();
            want.sort_unstable();
            assert_eq!(seen, want, "at {x}");
        }
    }

    #[test]
    fn the_tree_does_not_depend_on_the_items_first_order() {
        let mut forward = dots(300);
        let mut backward = dots(300);
        backward.reverse();
        let (a, b) = (Bvh::new(&mut forward), Bvh::new(&mut backward));
        let order = |items: &[Dot]| items.iter().map(|d| d.1).collect::<Vec<_>>();
        assert_eq!(order(&forward), order(&backward));
        assert_eq!(a.nodes.len(), b.nodes.len());
        let ray = Ray::new(Vec3::new(-1.0, 0.5, 0.5), Vec3::X);
        let mut stack = Vec::new();
        let (mut ra, mut rb) = (Vec::new(), Vec::new());
        a.leaves_along(&ray, (0.0, 10.0), &mut stack, |r| ra.push(r));
        b.leaves_along(&ray, (0.0, 10.0), &mut stack, |r| rb.push(r));
        assert!(!ra.is_empty());
        assert_eq!(ra, rb);
    }
}
