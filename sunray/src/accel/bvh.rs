//! A bounding volume hierarchy built with the binned surface area heuristic (Wald 2007),
//! flattened depth-first: a node's left child follows it, the right child is at `right`.

use super::Hit;
use crate::geometry::{Aabb, Primitive, RayPre, Real, Vec3};
use crate::stats::Counters;

const BINS: usize = 16;
const MAX_LEAF: usize = 4;
/// Cost of a node traversal relative to one primitive test.
const TRAVERSAL_COST: Real = 1.0;

#[derive(Clone, Debug)]
struct Node {
    bounds: Aabb,
    /// Leaf: first item; interior: index of the right child.
    index: u32,
    /// Leaf: number of items (> 0); interior: 0.
    count: u16,
    axis: u8,
}

#[derive(Clone, Debug)]
pub struct Bvh {
    nodes: Vec<Node>,
    items: Vec<u32>,
}

struct BuildItem {
    prim: u32,
    bounds: Aabb,
    centre: Vec3,
}

impl Bvh {
    pub fn build(bounded: &[(u32, Aabb)]) -> Bvh {
        let mut items: Vec<BuildItem> = bounded
            .iter()
            .map(|(p, b)| BuildItem {
                prim: *p,
                bounds: *b,
                centre: b.centre(),
            })
            .collect();
        let mut bvh = Bvh {
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
        let bounds = slice.iter().fold(Aabb::EMPTY, |b, i| b.union(i.bounds));
        self.nodes.push(Node {
            bounds,
            index: start as u32,
            count: slice.len() as u16,
            axis: 0,
        });
        if slice.len() <= MAX_LEAF {
            return node;
        }
        let Some((axis, split)) = best_split(slice, &bounds) else {
            if slice.len() <= u16::MAX as usize && slice.len() <= 16 {
                return node;
            }
            // No useful SAH split (all centres equal, or a leaf is cheaper but too big):
            // split in the middle of the list.
            let mid = start + slice.len() / 2;
            self.finish_interior(node, items, start, mid, end, 0);
            return node;
        };
        let range = centre_range(slice, axis);
        let mid = start + partition(slice, |i| bin_of(i.centre[axis], &range) < split);
        let mid = if mid == start || mid == end {
            start + (end - start) / 2
        } else {
            mid
        };
        self.finish_interior(node, items, start, mid, end, axis);
        node
    }

    fn finish_interior(
        &mut self,
        node: usize,
        items: &mut [BuildItem],
        start: usize,
        mid: usize,
        end: usize,
        axis: usize,
    ) {
        self.build_node(items, start, mid);
        let right = self.build_node(items, mid, end);
        let n = &mut self.nodes[node];
        n.index = right as u32;
        n.count = 0;
        n.axis = axis as u8;
    }

    pub fn node_count(&self) -> usize {
        self.nodes.len()
    }

    pub fn closest(
        &self,
        prims: &[Primitive],
        r: &RayPre,
        t_max: Real,
        mut best: Option<Hit>,
        c: &mut Counters,
    ) -> Option<Hit> {
        if self.nodes.is_empty() {
            return best;
        }
        let mut stack = [0u32; 64];
        let mut sp = 0;
        let mut node = 0usize;
        loop {
            let n = &self.nodes[node];
            c.voxels += 1;
            let limit = best.map_or(t_max, |b| b.t);
            let mut next = None;
            if n.bounds.hit(r, 0.0, limit).is_some() {
                if n.count > 0 {
                    let first = n.index as usize;
                    for &i in &self.items[first..first + n.count as usize] {
                        c.intersection_tests += 1;
                        if let Some(t) = prims[i as usize].intersect(r, 0.0, t_max) {
                            if Hit::improves(t, i, &best) {
                                best = Some(Hit { t, prim: i });
                            }
                        }
                    }
                } else {
                    let (near, far) = if r.ray.dir[n.axis as usize] < 0.0 {
                        (n.index as usize, node + 1)
                    } else {
                        (node + 1, n.index as usize)
                    };
                    if sp < stack.len() {
                        stack[sp] = far as u32;
                        sp += 1;
                        next = Some(near);
                    } else {
                        // Pathologically deep tree: fall back to testing the whole subtree.
                        best = self.closest_subtree(prims, r, t_max, best, node, c);
                    }
                }
            }
            node = match next {
                Some(n) => n,
                None if sp > 0 => {
                    sp -= 1;
                    stack[sp] as usize
                }
                None => return best,
            };
        }
    }

    fn closest_subtree(
        &self,
        prims: &[Primitive],
        r: &RayPre,
        t_max: Real,
        mut best: Option<Hit>,
        node: usize,
        c: &mut Counters,
    ) -> Option<Hit> {
        let n = &self.nodes[node];
        if n.count > 0 {
            let first = n.index as usize;
            for &i in &self.items[first..first + n.count as usize] {
                c.intersection_tests += 1;
                if let Some(t) = prims[i as usize].intersect(r, 0.0, t_max) {
                    if Hit::improves(t, i, &best) {
                        best = Some(Hit { t, prim: i });
                    }
                }
            }
            return best;
        }
        best = self.closest_subtree(prims, r, t_max, best, node + 1, c);
        self.closest_subtree(prims, r, t_max, best, n.index as usize, c)
    }

    fn any_subtree(
        &self,
        prims: &[Primitive],
        r: &RayPre,
        t_max: Real,
        accept: &dyn Fn(u32) -> bool,
        node: usize,
        c: &mut Counters,
    ) -> Option<Hit> {
        let n = &self.nodes[node];
        if n.count == 0 {
            return self
                .any_subtree(prims, r, t_max, accept, node + 1, c)
                .or_else(|| self.any_subtree(prims, r, t_max, accept, n.index as usize, c));
        }
        let first = n.index as usize;
        for &i in &self.items[first..first + n.count as usize] {
            c.intersection_tests += 1;
            if let Some(t) = prims[i as usize].intersect(r, 0.0, t_max) {
                if accept(i) {
                    return Some(Hit { t, prim: i });
                }
            }
        }
        None
    }

    pub fn any(
        &self,
        prims: &[Primitive],
        r: &RayPre,
        t_max: Real,
        accept: &dyn Fn(u32) -> bool,
        c: &mut Counters,
    ) -> Option<Hit> {
        if self.nodes.is_empty() {
            return None;
        }
        let mut stack = [0u32; 64];
        let mut sp = 1;
        while sp > 0 {
            sp -= 1;
            let node = stack[sp] as usize;
            let n = &self.nodes[node];
            c.voxels += 1;
            if n.bounds.hit(r, 0.0, t_max).is_none() {
                continue;
            }
            if n.count > 0 {
                let first = n.index as usize;
                for &i in &self.items[first..first + n.count as usize] {
                    c.intersection_tests += 1;
                    if let Some(t) = prims[i as usize].intersect(r, 0.0, t_max) {
                        if accept(i) {
                            return Some(Hit { t, prim: i });
                        }
                    }
                }
            } else if sp + 2 <= stack.len() {
                stack[sp] = n.index;
                stack[sp + 1] = (node + 1) as u32;
                sp += 2;
            } else {
                // Pathologically deep tree: search the subtree recursively.
                if let Some(h) = self.any_subtree(prims, r, t_max, accept, node, c) {
                    return Some(h);
                }
            }
        }
        None
    }
}

fn centre_range(items: &[BuildItem], axis: usize) -> (Real, Real) {
    items
        .iter()
        .fold((Real::INFINITY, Real::NEG_INFINITY), |(lo, hi), i| {
            (lo.min(i.centre[axis]), hi.max(i.centre[axis]))
        })
}

#[inline]
fn bin_of(x: Real, range: &(Real, Real)) -> usize {
    let (lo, hi) = *range;
    let f = (x - lo) / (hi - lo) * BINS as Real;
    (f as usize).min(BINS - 1)
}

/// The best (axis, bin boundary) by SAH, or None when a leaf is cheaper or centres coincide.
fn best_split(items: &[BuildItem], bounds: &Aabb) -> Option<(usize, usize)> {
    let mut best: Option<(Real, usize, usize)> = None;
    for axis in 0..3 {
        let range = centre_range(items, axis);
        if range.1.is_nan() || range.1 <= range.0 {
            continue;
        }
        let mut boxes = [Aabb::EMPTY; BINS];
        let mut counts = [0usize; BINS];
        for i in items {
            let b = bin_of(i.centre[axis], &range);
            boxes[b] = boxes[b].union(i.bounds);
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
            if best.is_none_or(|(c, _, _)| cost < c) {
                best = Some((cost, axis, b));
            }
        }
    }
    let (cost, axis, split) = best?;
    let area = bounds.surface_area().max(1e-300);
    let split_cost = TRAVERSAL_COST + cost / area;
    let leaf_cost = items.len() as Real;
    if split_cost >= leaf_cost && items.len() <= 16 {
        return None;
    }
    Some((axis, split))
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
