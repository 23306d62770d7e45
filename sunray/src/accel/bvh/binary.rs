//! The binary tree the BVH starts from, built with the binned surface area heuristic (Wald
//! 2007) and flattened depth-first: a node's left child follows it, the right child is at
//! `index`. [`super::wide`] collapses it into the 4-wide tree that rays traverse.

use crate::geometry::{Aabb, Real, Vec3};

const BINS: usize = 16;
const MAX_LEAF: usize = 4;
/// Cost of a node traversal relative to one primitive test.
const TRAVERSAL_COST: Real = 1.0;

/// One node of the binary tree: a leaf or an interior node with two children.
#[derive(Clone, Debug)]
pub struct Node {
    /// The box around everything below the node.
    pub bounds: Aabb,
    /// Leaf: first item; interior: index of the right child (the left one follows the node).
    pub index: u32,
    /// Leaf: number of items (> 0); interior: 0.
    pub count: u16,
}

/// A binary BVH: nodes depth-first, and the primitive indices its leaves point into.
#[derive(Clone, Debug)]
pub struct BinaryBvh {
    /// The nodes, depth-first from the root at index 0.
    pub nodes: Vec<Node>,
    /// Primitive indices in leaf order: a leaf holds `items[index..index + count]`.
    pub items: Vec<u32>,
}

/// One primitive while the tree is built, in 40 bytes: its box rounded outwards to `f32`
/// (a box only has to contain its primitive; the hits never depend on the tree) and its
/// centre, so that a scene of millions of triangles is built in little memory.
struct BuildItem {
    prim: u32,
    lo: [f32; 3],
    hi: [f32; 3],
    centre: [f32; 3],
}

impl BuildItem {
    fn new(prim: u32, b: Aabb) -> BuildItem {
        let c = b.centre();
        BuildItem {
            prim,
            lo: b.min.to_array().map(round_down),
            hi: b.max.to_array().map(round_up),
            centre: [c.x as f32, c.y as f32, c.z as f32],
        }
    }

    #[inline]
    fn bounds(&self) -> Aabb {
        let v = |a: [f32; 3]| Vec3::new(a[0].into(), a[1].into(), a[2].into());
        Aabb::new(v(self.lo), v(self.hi))
    }

    #[inline]
    fn centre(&self, axis: usize) -> Real {
        self.centre[axis].into()
    }
}

/// The largest `f32` at most `x`.
fn round_down(x: Real) -> f32 {
    let f = x as f32;
    if Real::from(f) > x {
        f.next_down()
    } else {
        f
    }
}

/// The smallest `f32` at least `x`.
fn round_up(x: Real) -> f32 {
    let f = x as f32;
    if Real::from(f) < x {
        f.next_up()
    } else {
        f
    }
}

impl BinaryBvh {
    /// Builds over `(primitive index, bounds)` pairs.
    pub fn build(bounded: impl Iterator<Item = (u32, Aabb)>) -> BinaryBvh {
        let mut items: Vec<BuildItem> = bounded.map(|(p, b)| BuildItem::new(p, b)).collect();
        let mut bvh = BinaryBvh {
            nodes: Vec::with_capacity(2 * items.len() / MAX_LEAF + 1),
            items: Vec::new(),
        };
        if !items.is_empty() {
            let n = items.len();
            bvh.build_node(&mut items, 0, n);
        }
        bvh.items = items.iter().map(|i| i.prim).collect();
        bvh
    }

    fn build_node(&mut self, items: &mut [BuildItem], start: usize, end: usize) -> usize {
        let node = self.nodes.len();
        let slice = &mut items[start..end];
        let bounds = slice.iter().fold(Aabb::EMPTY, |b, i| b.union(i.bounds()));
        self.nodes.push(Node {
            bounds,
            index: start as u32,
            count: slice.len() as u16,
        });
        if slice.len() <= MAX_LEAF {
            return node;
        }
        let Some((axis, split, bins)) = best_split(slice, &bounds) else {
            if slice.len() <= u16::MAX as usize && slice.len() <= 16 {
                return node;
            }
            // No useful SAH split (all centres equal, or a leaf is cheaper but too big):
            // split in the middle of the list.
            let mid = start + slice.len() / 2;
            self.finish_interior(node, items, start, mid, end);
            return node;
        };
        let mid = start + partition(slice, |i| bins.of(i.centre(axis)) < split);
        let mid = if mid == start || mid == end {
            start + (end - start) / 2
        } else {
            mid
        };
        self.finish_interior(node, items, start, mid, end);
        node
    }

    fn finish_interior(
        &mut self,
        node: usize,
        items: &mut [BuildItem],
        start: usize,
        mid: usize,
        end: usize,
    ) {
        self.build_node(items, start, mid);
        let right = self.build_node(items, mid, end);
        let n = &mut self.nodes[node];
        n.index = right as u32;
        n.count = 0;
    }
}

/// The range of the items' centres on each axis.
fn centre_ranges(items: &[BuildItem]) -> [(Real, Real); 3] {
    let mut r = [(Real::INFINITY, Real::NEG_INFINITY); 3];
    for i in items {
        for (axis, (lo, hi)) in r.iter_mut().enumerate() {
            let c = i.centre(axis);
            (*lo, *hi) = (lo.min(c), hi.max(c));
        }
    }
    r
}

/// The bins of one axis: `BINS` equal slices of the centres' range.
#[derive(Clone, Copy)]
struct Bins {
    lo: Real,
    /// Bins per unit length.
    scale: Real,
}

impl Bins {
    /// The bins over `(lo, hi)`, or None when the range is empty or a point.
    fn over((lo, hi): (Real, Real)) -> Option<Bins> {
        let scale = BINS as Real / (hi - lo);
        (hi > lo && scale.is_finite()).then_some(Bins { lo, scale })
    }

    /// The bin of centre coordinate `x`.
    #[inline]
    fn of(&self, x: Real) -> usize {
        (((x - self.lo) * self.scale) as usize).min(BINS - 1)
    }
}

/// The best (axis, bin boundary) by SAH and that axis's bins, or None when a leaf is cheaper
/// or centres coincide.
fn best_split(items: &[BuildItem], bounds: &Aabb) -> Option<(usize, usize, Bins)> {
    let mut best: Option<(Real, usize, usize, Bins)> = None;
    for (axis, range) in centre_ranges(items).into_iter().enumerate() {
        let Some(bins) = Bins::over(range) else {
            continue;
        };
        let mut boxes = [Aabb::EMPTY; BINS];
        let mut counts = [0usize; BINS];
        for i in items {
            let b = bins.of(i.centre(axis));
            boxes[b] = boxes[b].union(i.bounds());
            counts[b] += 1;
        }
        // Sweep from the right to get suffix areas, then from the left.
        let mut right_area = [0.0; BINS];
        let mut right_count = [0usize; BINS];
        let (mut acc, mut n) = (Aabb::EMPTY, 0);
        for b in (1..BINS).rev() {
            acc = acc.union(boxes[b]);
            n += counts[b];
            right_area[b] = acc.surface_area();
            right_count[b] = n;
        }
        let (mut acc, mut n) = (Aabb::EMPTY, 0);
        for b in 1..BINS {
            acc = acc.union(boxes[b - 1]);
            n += counts[b - 1];
            if n == 0 || right_count[b] == 0 {
                continue;
            }
            let cost = acc.surface_area() * n as Real + right_area[b] * right_count[b] as Real;
            if best.is_none_or(|(c, ..)| cost < c) {
                best = Some((cost, axis, b, bins));
            }
        }
    }
    let (cost, axis, split, bins) = best?;
    let area = bounds.surface_area().max(1e-300);
    let split_cost = TRAVERSAL_COST + cost / area;
    let leaf_cost = items.len() as Real;
    if split_cost >= leaf_cost && items.len() <= 16 {
        return None;
    }
    Some((axis, split, bins))
}

/// Moves the items for which `left` holds to the front; returns how many there are.
fn partition(items: &mut [BuildItem], left: impl Fn(&BuildItem) -> bool) -> usize {
    let mut k = 0;
    for i in 0..items.len() {
        if left(&items[i]) {
            items.swap(i, k);
            k += 1;
        }
    }
    k
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_box_rounded_to_f32_contains_the_f64_box() {
        for x in [
            0.1, -0.1, 1e-40, -1e-40, 3.0, 1e39, -1e39, 123456.789, -7.25,
        ] {
            assert!(Real::from(round_down(x)) <= x, "{x}");
            assert!(Real::from(round_up(x)) >= x, "{x}");
        }
        let b = Aabb::new(Vec3::new(-0.1, 0.3, 1e-7), Vec3::new(0.7, 1.1, 2.0 / 3.0));
        let r = BuildItem::new(0, b).bounds();
        assert!(
            r.min.cmple(b.min).all() && r.max.cmpge(b.max).all(),
            "{r:?}"
        );
        assert_eq!(std::mem::size_of::<BuildItem>(), 40);
    }
}
