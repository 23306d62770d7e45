//! Glassner's adaptive octree (thesis 4.2.1): the world voxel is split into eight while it
//! holds more than `max_per_voxel` primitives and the depth limit is not reached. A ray walks
//! the leaves it crosses in order along the ray; a hit is accepted once it lies inside the
//! voxel being visited (`t <= exit`), so nothing behind it is ever tested.

use super::{AccelOptions, Hit, Mailbox};
use crate::geometry::{Aabb, Primitives, RayPre, Real, Vec3};
use crate::stats::Counters;

/// A hard cap on `--max-depth`, whatever is asked: deeper voxels only cost memory.
pub const MAX_DEPTH: u32 = 20;

#[derive(Clone, Debug)]
struct Node {
    /// Centre of the voxel (the split point).
    mid: Vec3,
    /// Leaf: items[first..first+count]; interior: children at nodes[first..first+8].
    first: u32,
    count: u32,
    leaf: bool,
}

/// Glassner's adaptive octree over the bounded primitives: a voxel with too many primitives is
/// split into eight.
#[derive(Clone, Debug)]
pub struct Octree {
    bounds: Aabb,
    nodes: Vec<Node>,
    items: Vec<u32>,
}

impl Octree {
    /// Builds over the bounded primitives; `overlaps(prim, voxel)` says whether a primitive
    /// touches a voxel (it must be true whenever the primitive has a point in the voxel).
    pub fn build(
        bounded: &[(u32, Aabb)],
        overlaps: &dyn Fn(u32, &Aabb) -> bool,
        opts: &AccelOptions,
    ) -> Octree {
        let bounds = bounded.iter().fold(Aabb::EMPTY, |b, (_, pb)| b.union(*pb));
        let mut tree = Octree {
            bounds,
            nodes: Vec::new(),
            items: Vec::new(),
        };
        if bounded.is_empty() {
            tree.bounds = Aabb::new(Vec3::ZERO, Vec3::ZERO);
        }
        let all: Vec<usize> = (0..bounded.len()).collect();
        tree.nodes.push(Node {
            mid: tree.bounds.centre(),
            first: 0,
            count: 0,
            leaf: true,
        });
        tree.subdivide(0, tree.bounds, all, bounded, overlaps, opts, 0);
        tree
    }

    #[allow(clippy::too_many_arguments)]
    fn subdivide(
        &mut self,
        node: usize,
        bounds: Aabb,
        items: Vec<usize>,
        bounded: &[(u32, Aabb)],
        overlaps: &dyn Fn(u32, &Aabb) -> bool,
        opts: &AccelOptions,
        depth: u32,
    ) {
        let mid = bounds.centre();
        if items.len() > opts.max_per_voxel && depth < opts.max_depth.min(MAX_DEPTH) {
            let boxes: [Aabb; 8] = std::array::from_fn(|k| child_bounds(&bounds, mid, k));
            let mut lists: [Vec<usize>; 8] = Default::default();
            for &i in &items {
                let pb = &bounded[i].1;
                let mask = (0..8).fold(0u8, |m, k| m | (u8::from(pb.overlaps(&boxes[k])) << k));
                if mask.count_ones() == 1 {
                    // The primitive touches this voxel and its box only this child.
                    lists[mask.trailing_zeros() as usize].push(i);
                } else {
                    for (k, list) in lists.iter_mut().enumerate() {
                        if mask & (1 << k) != 0 && overlaps(bounded[i].0, &boxes[k]) {
                            list.push(i);
                        }
                    }
                }
            }
            let children: Vec<(Aabb, Vec<usize>)> = boxes.into_iter().zip(lists).collect();
            // Splitting is useless when every child would hold everything.
            if children
                .iter()
                .any(|(_, l): &(Aabb, Vec<usize>)| l.len() < items.len())
            {
                let first = self.nodes.len();
                for _ in 0..8 {
                    self.nodes.push(Node {
                        mid: Vec3::ZERO,
                        first: 0,
                        count: 0,
                        leaf: true,
                    });
                }
                self.nodes[node] = Node {
                    mid,
                    first: first as u32,
                    count: 8,
                    leaf: false,
                };
                for (k, (cb, list)) in children.into_iter().enumerate() {
                    self.subdivide(first + k, cb, list, bounded, overlaps, opts, depth + 1);
                }
                return;
            }
        }
        let first = self.items.len() as u32;
        self.items.extend(items.iter().map(|&i| bounded[i].0));
        self.nodes[node] = Node {
            mid,
            first,
            count: items.len() as u32,
            leaf: true,
        };
    }

    /// Voxels in the tree, interior ones included.
    pub fn node_count(&self) -> usize {
        self.nodes.len()
    }

    /// Closest hit, improving on `best` (from the unbounded list).
    pub fn closest(
        &self,
        prims: &Primitives,
        r: &RayPre,
        t_max: Real,
        mut best: Option<Hit>,
        mb: &mut Mailbox,
        c: &mut Counters,
    ) -> Option<Hit> {
        let Some((t0, t1)) = self.bounds.hit(r, 0.0, t_max) else {
            return best;
        };
        let mut visit = |leaf: &Node, _t0: Real, t1: Real| -> bool {
            c.voxels += 1;
            for &i in &self.items[leaf.first as usize..(leaf.first + leaf.count) as usize] {
                let t = test(prims, i, r, t_max, mb, c);
                if let Some(t) = t {
                    if Hit::improves(t, i, &best) {
                        best = Some(Hit { t, prim: i });
                    }
                }
            }
            // Accept the hit only if it lies inside this voxel.
            matches!(best, Some(b) if b.t <= t1)
        };
        self.walk(0, r, t0, t1, &mut visit);
        best
    }

    /// Any hit that `accept` takes.
    pub fn any(
        &self,
        prims: &Primitives,
        r: &RayPre,
        t_max: Real,
        accept: &dyn Fn(u32, Real) -> bool,
        mb: &mut Mailbox,
        c: &mut Counters,
    ) -> Option<Hit> {
        let (t0, t1) = self.bounds.hit(r, 0.0, t_max)?;
        let mut found = None;
        let mut visit = |leaf: &Node, _t0: Real, _t1: Real| -> bool {
            c.voxels += 1;
            for &i in &self.items[leaf.first as usize..(leaf.first + leaf.count) as usize] {
                if let Some(t) = test(prims, i, r, t_max, mb, c) {
                    if accept(i, t) {
                        found = Some(Hit { t, prim: i });
                        return true;
                    }
                }
            }
            false
        };
        self.walk(0, r, t0, t1, &mut visit);
        found
    }

    /// Visits the leaves under `node` crossed by the ray in `[t0, t1]`, in order along the
    /// ray, until `visit` returns true. Returns whether it stopped.
    fn walk(
        &self,
        node: usize,
        r: &RayPre,
        t0: Real,
        t1: Real,
        visit: &mut dyn FnMut(&Node, Real, Real) -> bool,
    ) -> bool {
        let n = &self.nodes[node];
        if n.leaf {
            return n.count > 0 && visit(n, t0, t1);
        }
        let o = r.ray.origin;
        let d = r.ray.dir;
        // Plane crossing times and the child containing the start of the interval.
        let mut child = 0usize;
        let mut cross = [(Real::INFINITY, 0usize); 3];
        for k in 0..3 {
            let tm = (n.mid[k] - o[k]) * r.inv_dir[k];
            let upper_at_start = if d[k] > 0.0 {
                tm <= t0
            } else if d[k] < 0.0 {
                tm > t0
            } else {
                o[k] >= n.mid[k]
            };
            if upper_at_start {
                child |= 1 << k;
            }
            cross[k] = (
                if tm > t0 && tm < t1 {
                    tm
                } else {
                    Real::INFINITY
                },
                k,
            );
        }
        cross.sort_by(|a, b| a.0.total_cmp(&b.0));
        let mut ts = t0;
        for (tc, k) in cross.iter().copied().chain(std::iter::once((t1, 3))) {
            let te = tc.min(t1);
            if self.walk(n.first as usize + child, r, ts, te, visit) {
                return true;
            }
            if k == 3 || tc >= t1 {
                break;
            }
            child ^= 1 << k;
            ts = te;
        }
        false
    }
}

/// One primitive test through the mailbox.
#[inline]
fn test(
    prims: &Primitives,
    i: u32,
    r: &RayPre,
    t_max: Real,
    mb: &mut Mailbox,
    c: &mut Counters,
) -> Option<Real> {
    if mb.enabled() {
        c.mailbox_uses += 1;
        if let Some(known) = mb.get(i) {
            c.mailbox_hits += 1;
            return known;
        }
    }
    c.intersection_tests += 1;
    let t = prims.intersect(i, r, 0.0, t_max);
    mb.put(i, t);
    t
}

fn child_bounds(b: &Aabb, mid: Vec3, k: usize) -> Aabb {
    let mut min = b.min;
    let mut max = b.max;
    for axis in 0..3 {
        if k & (1 << axis) != 0 {
            min[axis] = mid[axis];
        } else {
            max[axis] = mid[axis];
        }
    }
    Aabb::new(min, max)
}
