//! A bounding volume hierarchy: built as a binary tree with the binned surface area heuristic
//! ([`binary`]), then collapsed into a 4-wide tree ([`wide`]) whose leaves list their
//! primitives' slots in the scene's compact tables ([`items`]), which take the leaves' order.
//!
//! A built tree can be written and read back, checked ([`file`]), or made of tables viewed
//! in place in a prepared scene file ([`tables`]). Leaves of static triangles alone, or of
//! static spheres alone, are also copied into groups of four tested at once ([`leaf4`]),
//! within a memory budget. [`cut`] takes the boxes of a cut through it, for the render's
//! footprint.
//!
//! [`packet`] walks the tree with up to four neighbouring rays at once.
//!
//! Closest-hit queries visit the children a ray enters nearest first and skip a child whose
//! entry lies beyond the best hit so far; any-hit queries (shadow rays) stop at the first
//! accepted hit. Ties between equal `t` go to the lower primitive index, as everywhere.

pub mod binary;
mod cut;
pub mod file;
pub mod items;
pub mod leaf4;
pub mod packet;
pub mod tables;
pub mod wide;

use super::Hit;
use crate::geometry::{Primitives, RayPre, Real};
use crate::stats::Counters;
use arrayvec::ArrayVec;
use binary::BinaryBvh;
use items::LeafItems;
use wide::{BoxRay, Child, WIDTH};

/// A built BVH: the 4-wide nodes and the leaf primitives they point into.
#[derive(Clone, Debug)]
pub struct Bvh {
    nodes: crate::store::Store<wide::Node>,
    items: LeafItems,
    leaves4: leaf4::Leaves4,
}

/// A child waiting on the traversal stack, with the `t` at which the ray enters it.
#[derive(Clone, Copy)]
struct Pending {
    t: Real,
    child: Child,
}

/// Traversal stack size. Each node visited pushes at most three children beyond the one it
/// continues with, so this covers trees 40 levels deep; deeper subtrees are searched
/// recursively instead.
const STACK: usize = 128;

impl Bvh {
    /// Builds over the primitives of `prims` that have bounds, and has `prims` adopt the
    /// leaves' order ([`Primitives::adopt_order`]; the first accelerator built does).
    pub fn build(prims: &mut Primitives) -> Bvh {
        let costed = super::bounded(prims).map(|(i, b)| (i, b, prims.test_cost(i)));
        let bin = BinaryBvh::build(costed);
        prims.adopt_order(&bin.items);
        let nodes: crate::store::Store<wide::Node> = wide::collapse(&bin).into();
        let items = LeafItems::new(prims, &bin.items);
        let leaves4 = leaf4::Leaves4::new(&nodes, &items, prims);
        Bvh {
            nodes,
            items,
            leaves4,
        }
    }

    /// Nodes of the 4-wide tree.
    pub fn node_count(&self) -> usize {
        self.nodes.len()
    }

    /// Closest hit of `r` before `t_max`, improving on `best` (from the unbounded list); uses AVX2
    /// when the CPU has it.
    pub fn closest(
        &self,
        prims: &Primitives,
        r: &RayPre,
        t_max: Real,
        best: Option<Hit>,
        c: &mut Counters,
    ) -> Option<Hit> {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU has AVX2, the one requirement of `closest_avx2`.
            return unsafe { self.closest_avx2(prims, r, t_max, best, c) };
        }
        self.closest_impl(prims, r, t_max, best, c)
    }

    /// The same query compiled for AVX2, which tests the four boxes of a node in one go.
    /// No code changes its results: Rust never fuses a multiply and an add on its own.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn closest_avx2(
        &self,
        prims: &Primitives,
        r: &RayPre,
        t_max: Real,
        best: Option<Hit>,
        c: &mut Counters,
    ) -> Option<Hit> {
        self.closest_impl(prims, r, t_max, best, c)
    }

    #[inline(always)]
    fn closest_impl(
        &self,
        prims: &Primitives,
        r: &RayPre,
        t_max: Real,
        mut best: Option<Hit>,
        c: &mut Counters,
    ) -> Option<Hit> {
        if self.nodes.is_empty() {
            return best;
        }
        let br = BoxRay::new(r);
        let mut stack = ArrayVec::<Pending, STACK>::new();
        let mut child = Child { index: 0, count: 0 };
        loop {
            if child.is_leaf() {
                best = self.closest_in_leaf(prims, child, r, t_max, best, c);
            } else {
                c.voxels += 1;
                let limit = best.map_or(t_max, |b| b.t);
                let node = &self.nodes[child.index as usize];
                let (t, mut hits) = node.entries_hit(&br, limit);
                // The nearest child hit is visited next; the others wait on the stack,
                // farthest deepest. The children hit in slot order, from their bits.
                let mut near = WIDTH;
                let mut pushed = 0;
                while hits != 0 {
                    let k = hits.trailing_zeros() as usize & (WIDTH - 1);
                    hits &= hits - 1;
                    if near == WIDTH {
                        near = k;
                        continue;
                    }
                    let far = if t[k] < t[near] {
                        std::mem::replace(&mut near, k)
                    } else {
                        k
                    };
                    let entry = Pending {
                        t: t[far],
                        child: node.children[far],
                    };
                    if stack.try_push(entry).is_err() {
                        best = self.closest_subtree(prims, entry.child, r, t_max, best, c);
                        continue;
                    }
                    // Keep the entries of this node sorted, nearest on top.
                    let mut at = stack.len() - 1;
                    for _ in 0..pushed {
                        if stack[at - 1].t < stack[at].t {
                            stack.swap(at - 1, at);
                            at -= 1;
                        } else {
                            break;
                        }
                    }
                    pushed += 1;
                }
                if near < WIDTH {
                    child = node.children[near];
                    continue;
                }
            }
            let limit = best.map_or(t_max, |b| b.t);
            loop {
                let Some(p) = stack.pop() else { return best };
                if p.t <= limit {
                    child = p.child;
                    break;
                }
            }
        }
    }

    /// A leaf's primitives against the ray. Not inlined: inlined, the leaf code's tables
    /// (groups, items, primitives) were loaded and kept on the stack at every walk's start
    /// (58 instructions a ray), and its registers crowded the node loop's; called, they are
    /// loaded when a leaf is reached (a ray that misses every leaf never pays them).
    #[inline(never)]
    fn closest_in_leaf(
        &self,
        prims: &Primitives,
        leaf: Child,
        r: &RayPre,
        t_max: Real,
        mut best: Option<Hit>,
        c: &mut Counters,
    ) -> Option<Hit> {
        if let Some(groups) = self.leaves4.groups_of(leaf) {
            return leaf4::closest(groups, r, t_max, best, c);
        }
        let first = leaf.index as usize;
        for k in first..first + leaf.count as usize {
            c.intersection_tests += 1;
            if let Some(t) = self.items.intersect(prims, k, r, t_max) {
                let i = self.items.prim(prims, k);
                if Hit::improves(t, i, &best) {
                    best = Some(Hit { t, prim: i });
                }
            }
        }
        best
    }

    /// Every primitive of a subtree (the fallback for trees deeper than the stack).
    fn closest_subtree(
        &self,
        prims: &Primitives,
        child: Child,
        r: &RayPre,
        t_max: Real,
        mut best: Option<Hit>,
        c: &mut Counters,
    ) -> Option<Hit> {
        if child.is_leaf() {
            return self.closest_in_leaf(prims, child, r, t_max, best, c);
        }
        let node = &self.nodes[child.index as usize];
        for (k, ch) in node.children.iter().enumerate() {
            if node.used(k) {
                best = self.closest_subtree(prims, *ch, r, t_max, best, c);
            }
        }
        best
    }

    /// Some hit in `(0, t_max)` that `accept` takes, or None.
    pub fn any(
        &self,
        prims: &Primitives,
        r: &RayPre,
        t_max: Real,
        accept: &dyn Fn(u32, Real) -> bool,
        c: &mut Counters,
    ) -> Option<Hit> {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU has AVX2, the one requirement of `any_avx2`.
            return unsafe { self.any_avx2(prims, r, t_max, accept, c) };
        }
        self.any_impl(prims, r, t_max, accept, c)
    }

    /// The same query compiled for AVX2, which tests the four boxes of a node in one go.
    /// No code changes its results: Rust never fuses a multiply and an add on its own.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn any_avx2(
        &self,
        prims: &Primitives,
        r: &RayPre,
        t_max: Real,
        accept: &dyn Fn(u32, Real) -> bool,
        c: &mut Counters,
    ) -> Option<Hit> {
        self.any_impl(prims, r, t_max, accept, c)
    }

    #[inline(always)]
    fn any_impl(
        &self,
        prims: &Primitives,
        r: &RayPre,
        t_max: Real,
        accept: &dyn Fn(u32, Real) -> bool,
        c: &mut Counters,
    ) -> Option<Hit> {
        if self.nodes.is_empty() {
            return None;
        }
        let br = BoxRay::new(r);
        let mut stack = ArrayVec::<Child, STACK>::new();
        let mut child = Child { index: 0, count: 0 };
        loop {
            if child.is_leaf() {
                if let Some(h) = self.any_in_leaf(prims, child, r, t_max, accept, c) {
                    return Some(h);
                }
            } else {
                c.voxels += 1;
                let node = &self.nodes[child.index as usize];
                let (_, mut hits) = node.entries_hit(&br, t_max);
                if hits != 0 {
                    // The children hit wait in slot order and the last of them is taken at
                    // once, without a push and a pop: the order of a stack of them all.
                    let last = (31 - hits.leading_zeros()) as usize & (WIDTH - 1);
                    hits &= !(1 << last);
                    while hits != 0 {
                        let child = node.children[hits.trailing_zeros() as usize & (WIDTH - 1)];
                        hits &= hits - 1;
                        if stack.try_push(child).is_err() {
                            if let Some(h) = self.any_subtree(prims, child, r, t_max, accept, c) {
                                return Some(h);
                            }
                        }
                    }
                    child = node.children[last];
                    continue;
                }
            }
            match stack.pop() {
                Some(next) => child = next,
                None => break,
            }
        }
        None
    }

    /// [`Bvh::closest_in_leaf`]'s twin for [`Bvh::any`], not inlined for the same reason.
    #[inline(never)]
    fn any_in_leaf(
        &self,
        prims: &Primitives,
        leaf: Child,
        r: &RayPre,
        t_max: Real,
        accept: &dyn Fn(u32, Real) -> bool,
        c: &mut Counters,
    ) -> Option<Hit> {
        if let Some(groups) = self.leaves4.groups_of(leaf) {
            return leaf4::any(groups, r, t_max, accept, c);
        }
        let first = leaf.index as usize;
        for k in first..first + leaf.count as usize {
            c.intersection_tests += 1;
            if let Some(t) = self.items.intersect(prims, k, r, t_max) {
                let i = self.items.prim(prims, k);
                if accept(i, t) {
                    return Some(Hit { t, prim: i });
                }
            }
        }
        None
    }

    fn any_subtree(
        &self,
        prims: &Primitives,
        child: Child,
        r: &RayPre,
        t_max: Real,
        accept: &dyn Fn(u32, Real) -> bool,
        c: &mut Counters,
    ) -> Option<Hit> {
        if child.is_leaf() {
            return self.any_in_leaf(prims, child, r, t_max, accept, c);
        }
        let node = &self.nodes[child.index as usize];
        node.children
            .iter()
            .enumerate()
            .filter(|(k, _)| node.used(*k))
            .find_map(|(_, ch)| self.any_subtree(prims, *ch, r, t_max, accept, c))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{Primitive, PrimitiveKind, Ray, Vec3};
    use crate::sampler::unit_f64 as rand;

    fn sphere(centre: Vec3, radius: Real, i: u32) -> Primitive {
        Primitive {
            kind: PrimitiveKind::Sphere { centre, radius },
            object: i,
            surface: 0,
            motion: Vec3::ZERO,
        }
    }

    fn bvh_of(prims: &mut Primitives) -> Bvh {
        Bvh::build(prims)
    }

    fn brute_force(prims: &Primitives, r: &RayPre, t_max: Real) -> Option<Hit> {
        let mut best = None;
        for i in 0..prims.len() as u32 {
            if let Some(t) = prims.intersect(i, r, 0.0, t_max) {
                if Hit::improves(t, i, &best) {
                    best = Some(Hit { t, prim: i });
                }
            }
        }
        best
    }

    /// Spheres along the x axis, each 1.1 times as far out and as big as the one before:
    /// the surface area heuristic peels them off one by one, so the tree is as deep as the
    /// list is long, deeper than the traversal stack. (The tree is built with boxes in
    /// `f32`, so the farthest stays below 1.1^930, `f32`'s largest.)
    fn deep_scene(n: usize) -> Vec<Primitive> {
        (0..n)
            .map(|i| {
                let x = 1.1f64.powi(i as i32);
                sphere(Vec3::new(x, 0.0, 0.0), x * 0.1, i as u32)
            })
            .collect()
    }

    #[test]
    fn a_tree_deeper_than_the_stack_still_finds_every_hit() {
        let mut prims = Primitives::from_list(deep_scene(900));
        let bvh = bvh_of(&mut prims);
        let depth = |bvh: &Bvh| {
            let mut deepest = 0;
            let mut stack = vec![(0usize, 1)];
            while let Some((i, d)) = stack.pop() {
                deepest = deepest.max(d);
                for ch in bvh.nodes[i].children.iter().filter(|c| !c.is_leaf()) {
                    if ch.index != 0 {
                        stack.push((ch.index as usize, d + 1));
                    }
                }
            }
            deepest
        };
        assert!(depth(&bvh) * 3 > STACK, "only {} levels", depth(&bvh));
        let mut c = Counters::default();
        let mut s = 5u64;
        let mut hits = 0;
        for _ in 0..300 {
            // From beyond the far end back along the axis: every box is on the way.
            let o = Vec3::new(1.1f64.powi(901), rand(&mut s) - 0.5, rand(&mut s) - 0.5);
            let d = Vec3::new(-1.0, (rand(&mut s) - 0.5) * 1e-3, 0.0);
            let r = RayPre::new(Ray::new(o, d));
            let want = brute_force(&prims, &r, Real::INFINITY);
            hits += usize::from(want.is_some());
            assert_eq!(bvh.closest(&prims, &r, Real::INFINITY, None, &mut c), want);
            assert_eq!(
                bvh.any(&prims, &r, Real::INFINITY, &|_, _| true, &mut c)
                    .is_some(),
                want.is_some()
            );
        }
        assert!(hits > 100, "{hits}");
        // Packets of four rays from one point agree too.
        for _ in 0..100 {
            let o = Vec3::new(1.1f64.powi(901), rand(&mut s) - 0.5, rand(&mut s) - 0.5);
            let rays: Vec<RayPre> = (0..packet::PACKET)
                .map(|_| {
                    let d = Vec3::new(-1.0, (rand(&mut s) - 0.5) * 1e-3, 0.0);
                    RayPre::new(Ray::new(o, d))
                })
                .collect();
            let mut got = [None; packet::PACKET];
            bvh.closest_packet(&prims, &rays, u32::MAX, Real::INFINITY, &mut got, &mut c);
            for (k, r) in rays.iter().enumerate() {
                assert_eq!(got[k], brute_force(&prims, r, Real::INFINITY));
            }
        }
    }

    #[test]
    fn the_plain_and_the_vector_builds_agree() {
        let mut s = 11u64;
        let mut prims = Primitives::from_list(
            (0..500)
                .map(|i| {
                    let c = Vec3::new(rand(&mut s), rand(&mut s), rand(&mut s)) * 20.0 - 10.0;
                    sphere(c, 0.1 + rand(&mut s), i)
                })
                .collect(),
        );
        let bvh = bvh_of(&mut prims);
        let mut c = Counters::default();
        for _ in 0..2000 {
            let o = Vec3::new(rand(&mut s), rand(&mut s), rand(&mut s)) * 30.0 - 15.0;
            let d = Vec3::new(rand(&mut s), rand(&mut s), rand(&mut s)) - 0.5;
            let r = RayPre::new(Ray::new(o, d));
            let want = brute_force(&prims, &r, Real::INFINITY);
            assert_eq!(
                bvh.closest_impl(&prims, &r, Real::INFINITY, None, &mut c),
                want
            );
            assert_eq!(bvh.closest(&prims, &r, Real::INFINITY, None, &mut c), want);
            let any = bvh.any_impl(&prims, &r, Real::INFINITY, &|_, _| true, &mut c);
            assert_eq!(any.is_some(), want.is_some());
        }
    }
}
