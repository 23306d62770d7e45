//! Leaves of static triangles tested four at a time: each such leaf's triangles are copied,
//! in leaf order, into groups of four ([`Tri4`]: the corners one array per vertex and axis), and
//! a ray meets a group in one pass of AVX2 arithmetic with no branch per triangle and no walk
//! from item to slot to triangle to corners.
//!
//! Each lane computes Woop's watertight test exactly as the scalar kernel does
//! ([`crate::geometry::kernels::k64::triangle`]): the same `f64` operations in the same order
//! (Rust and these intrinsics never fuse a multiply and an add), so a lane's `t` is the scalar
//! test's to the bit, the hits are the same and so are the counters (a leaf's triangles are
//! counted as tested one by one would be).
//!
//! The groups copy the corners (76 bytes a triangle, more where a leaf's last group is not
//! full), so they are made only while they take at most [`BUDGET`] bytes: every SPD scene and
//! model of some hundred thousand triangles; a scene of millions keeps the memory it had and
//! tests item by item. On the SPD scenes the eye + shadow rays of `sunray bench limit` trace
//! 5-13% faster (bench/results/limit.md).

use super::items::LeafItems;
use super::wide::{Child, Node};
use crate::accel::Hit;
use crate::geometry::{Primitives, RayPre, Real};
use crate::stats::Counters;

/// Triangles per group.
pub const LANES: usize = 4;

/// The most bytes of groups a tree holds (see the module's text).
pub const BUDGET: usize = 64 << 20;

/// Four triangles: `corners[vertex][axis][lane]`, and each lane's primitive (`u32::MAX` for a
/// lane past the leaf's end).
#[derive(Clone, Copy, Debug)]
#[repr(C, align(32))]
pub struct Tri4 {
    corners: [[[Real; LANES]; 3]; 3],
    prims: [u32; LANES],
}

/// The groups of every leaf made of static triangles only.
#[derive(Clone, Debug, Default)]
pub struct Leaves4 {
    groups: Vec<Tri4>,
    /// For the first item of each leaf: its first group, or `u32::MAX` when the leaf holds
    /// something other than a static triangle (it is tested item by item).
    start: Vec<u32>,
}

impl Leaves4 {
    /// The groups of the leaves of `nodes` over `items`; none if they would take more than
    /// [`BUDGET`] bytes.
    pub fn new(nodes: &[Node], items: &LeafItems, prims: &Primitives) -> Leaves4 {
        Leaves4::within(nodes, items, prims, BUDGET)
    }

    /// [`Leaves4::new`] with a budget of `budget` bytes.
    fn within(nodes: &[Node], items: &LeafItems, prims: &Primitives, budget: usize) -> Leaves4 {
        let most = leaves(nodes)
            .map(|l| (l.count as usize).div_ceil(LANES))
            .sum::<usize>();
        if bytes(most, items) > budget {
            return Leaves4::default();
        }
        let mut out = Leaves4 {
            groups: Vec::with_capacity(most),
            start: vec![u32::MAX; items.len()],
        };
        for leaf in leaves(nodes) {
            out.add_leaf(leaf, items, prims);
        }
        if out.groups.is_empty() {
            // No leaf of triangles alone (balls, shells): no table to look up at every leaf.
            return Leaves4::default();
        }
        out
    }

    fn add_leaf(&mut self, leaf: Child, items: &LeafItems, prims: &Primitives) {
        let first = leaf.index as usize;
        let range = first..first + leaf.count as usize;
        let corners: Option<Vec<_>> = range
            .clone()
            .map(|k| {
                let i = items.prim(prims, k);
                prims.mesh_triangle(i).map(|v| (i, v))
            })
            .collect();
        let Some(corners) = corners else { return };
        self.start[first] = self.groups.len() as u32;
        for chunk in corners.chunks(LANES) {
            let mut g = Tri4 {
                corners: [[[0.0; LANES]; 3]; 3],
                prims: [u32::MAX; LANES],
            };
            for (lane, (i, v)) in chunk.iter().enumerate() {
                g.prims[lane] = *i;
                for (j, corner) in v.iter().enumerate() {
                    for axis in 0..3 {
                        g.corners[j][axis][lane] = corner[axis];
                    }
                }
            }
            self.groups.push(g);
        }
    }

    /// The groups of `leaf`, when its items are all static triangles.
    #[inline(always)]
    pub fn groups_of(&self, leaf: Child) -> Option<&[Tri4]> {
        let g = *self.start.get(leaf.index as usize)?;
        if g == u32::MAX {
            return None;
        }
        let n = (leaf.count as usize).div_ceil(LANES);
        self.groups.get(g as usize..g as usize + n)
    }

    /// How many groups there are.
    pub fn len(&self) -> usize {
        self.groups.len()
    }

    /// True when no leaf has groups.
    pub fn is_empty(&self) -> bool {
        self.groups.is_empty()
    }
}

/// The leaves of `nodes`.
fn leaves(nodes: &[Node]) -> impl Iterator<Item = Child> + '_ {
    nodes.iter().flat_map(|node| {
        (0..node.children.len())
            .filter(|&k| node.used(k) && node.children[k].is_leaf())
            .map(|k| node.children[k])
    })
}

/// The bytes of `groups` groups and the leaf starts of `items`.
fn bytes(groups: usize, items: &LeafItems) -> usize {
    groups * std::mem::size_of::<Tri4>() + items.len() * 4
}

impl Tri4 {
    /// Each lane's `t` where the ray crosses its triangle in `(0, t_max)`, and a mask of the
    /// lanes that it crosses (bit per lane).
    #[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
    #[inline(always)]
    pub fn hits(&self, r: &RayPre, t_max: Real) -> ([Real; LANES], u32) {
        use std::arch::x86_64::*;
        let shear = r.shear();
        let (kx, ky, kz) = (shear.k[0].min(2), shear.k[1].min(2), shear.k[2].min(2));
        let o = r.ray.origin.to_array();
        let mut out = [0.0; LANES];
        let mask;
        // SAFETY: the build enables AVX2 (the cfg above); every load and store is an
        // unaligned one of a whole `[f64; 4]`.
        unsafe {
            let load = |j: usize, axis: usize| {
                _mm256_sub_pd(
                    _mm256_loadu_pd(self.corners[j][axis].as_ptr()),
                    _mm256_set1_pd(o[axis]),
                )
            };
            let (sx, sy, sz) = (
                _mm256_set1_pd(shear.s[0]),
                _mm256_set1_pd(shear.s[1]),
                _mm256_set1_pd(shear.s[2]),
            );
            let (a_kz, b_kz, c_kz) = (load(0, kz), load(1, kz), load(2, kz));
            let ax = _mm256_sub_pd(load(0, kx), _mm256_mul_pd(sx, a_kz));
            let ay = _mm256_sub_pd(load(0, ky), _mm256_mul_pd(sy, a_kz));
            let bx = _mm256_sub_pd(load(1, kx), _mm256_mul_pd(sx, b_kz));
            let by = _mm256_sub_pd(load(1, ky), _mm256_mul_pd(sy, b_kz));
            let cx = _mm256_sub_pd(load(2, kx), _mm256_mul_pd(sx, c_kz));
            let cy = _mm256_sub_pd(load(2, ky), _mm256_mul_pd(sy, c_kz));
            let u = _mm256_sub_pd(_mm256_mul_pd(cx, by), _mm256_mul_pd(cy, bx));
            let v = _mm256_sub_pd(_mm256_mul_pd(ax, cy), _mm256_mul_pd(ay, cx));
            let w = _mm256_sub_pd(_mm256_mul_pd(bx, ay), _mm256_mul_pd(by, ax));
            let zero = _mm256_setzero_pd();
            let negative = _mm256_or_pd(
                _mm256_or_pd(
                    _mm256_cmp_pd::<_CMP_LT_OQ>(u, zero),
                    _mm256_cmp_pd::<_CMP_LT_OQ>(v, zero),
                ),
                _mm256_cmp_pd::<_CMP_LT_OQ>(w, zero),
            );
            let positive = _mm256_or_pd(
                _mm256_or_pd(
                    _mm256_cmp_pd::<_CMP_GT_OQ>(u, zero),
                    _mm256_cmp_pd::<_CMP_GT_OQ>(v, zero),
                ),
                _mm256_cmp_pd::<_CMP_GT_OQ>(w, zero),
            );
            let det = _mm256_add_pd(_mm256_add_pd(u, v), w);
            let az = _mm256_mul_pd(sz, a_kz);
            let bz = _mm256_mul_pd(sz, b_kz);
            let cz = _mm256_mul_pd(sz, c_kz);
            let num = _mm256_add_pd(
                _mm256_add_pd(_mm256_mul_pd(u, az), _mm256_mul_pd(v, bz)),
                _mm256_mul_pd(w, cz),
            );
            let t = _mm256_div_pd(num, det);
            let ok = _mm256_andnot_pd(
                _mm256_and_pd(negative, positive),
                _mm256_and_pd(
                    _mm256_cmp_pd::<_CMP_NEQ_OQ>(det, zero),
                    _mm256_and_pd(
                        _mm256_cmp_pd::<_CMP_GT_OQ>(t, zero),
                        _mm256_cmp_pd::<_CMP_LT_OQ>(t, _mm256_set1_pd(t_max)),
                    ),
                ),
            );
            _mm256_storeu_pd(out.as_mut_ptr(), t);
            mask = _mm256_movemask_pd(ok) as u32;
        }
        (out, mask & self.lanes())
    }

    /// [`Tri4::hits`] lane by lane, where the build has no AVX2.
    #[cfg(not(all(target_arch = "x86_64", target_feature = "avx2")))]
    #[inline(always)]
    pub fn hits(&self, r: &RayPre, t_max: Real) -> ([Real; LANES], u32) {
        self.hits_scalar(r, t_max)
    }

    /// Each lane through the scalar kernel.
    pub fn hits_scalar(&self, r: &RayPre, t_max: Real) -> ([Real; LANES], u32) {
        let mut out = [0.0; LANES];
        let mut mask = 0;
        for (lane, t) in out.iter_mut().enumerate() {
            let corner = |j: usize| {
                let c = &self.corners[j];
                crate::geometry::Vec3::new(c[0][lane], c[1][lane], c[2][lane])
            };
            let v = [corner(0), corner(1), corner(2)];
            if let Some(hit) = crate::geometry::triangle::intersect_triangle(r, &v, 0.0, t_max) {
                *t = hit;
                mask |= 1 << lane;
            }
        }
        (out, mask & self.lanes())
    }

    /// The lanes that hold a triangle.
    #[inline(always)]
    fn lanes(&self) -> u32 {
        let mut m = 0;
        for (lane, p) in self.prims.iter().enumerate() {
            m |= u32::from(*p != u32::MAX) << lane;
        }
        m
    }

    /// The lanes holding a triangle that `r` is not known to miss ([`RayPre::skips`]: a ray
    /// leaving a flat face skips its triangles before anything is computed, the shear too).
    #[inline(always)]
    fn live(&self, r: &RayPre) -> u32 {
        let mut m = 0;
        for (lane, p) in self.prims.iter().enumerate() {
            m |= u32::from(*p != u32::MAX && !r.skips(*p)) << lane;
        }
        m
    }

    /// How many lanes hold a triangle.
    #[inline(always)]
    pub fn count(&self) -> u64 {
        u64::from(self.lanes().count_ones())
    }

    /// The lanes whose triangles the ray crosses in `(0, t_max)`, in lane order, as (lane,
    /// `t`, primitive); nothing is computed when the ray is known to miss every one.
    #[inline(always)]
    fn crossings(&self, r: &RayPre, t_max: Real) -> impl Iterator<Item = (usize, Real, u32)> {
        let live = self.live(r);
        let (t, hits) = if live == 0 {
            ([0.0; LANES], 0)
        } else {
            self.hits(r, t_max)
        };
        let mut m = hits & live;
        let prims = self.prims;
        std::iter::from_fn(move || {
            (m != 0).then(|| {
                let lane = m.trailing_zeros() as usize;
                m &= m - 1;
                (lane, t[lane], prims[lane])
            })
        })
    }
}

/// The closest hit among `groups` that improves on `best`.
#[inline(always)]
pub fn closest(
    groups: &[Tri4],
    r: &RayPre,
    t_max: Real,
    mut best: Option<Hit>,
    c: &mut Counters,
) -> Option<Hit> {
    for g in groups {
        c.intersection_tests += g.count();
        for (_, t, prim) in g.crossings(r, t_max) {
            if Hit::improves(t, prim, &best) {
                best = Some(Hit { t, prim });
            }
        }
    }
    best
}

/// Some hit among `groups` that `accept` takes, the first in leaf order.
#[inline(always)]
pub fn any(
    groups: &[Tri4],
    r: &RayPre,
    t_max: Real,
    accept: &dyn Fn(u32) -> bool,
    c: &mut Counters,
) -> Option<Hit> {
    for g in groups {
        for (lane, t, prim) in g.crossings(r, t_max) {
            if accept(prim) {
                // Counted as the item-by-item walk counts: up to the triangle that ends it.
                c.intersection_tests += lane as u64 + 1;
                return Some(Hit { t, prim });
            }
        }
        c.intersection_tests += g.count();
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{Ray, Vec3};
    use crate::sampler::splitmix64;

    fn rand(s: &mut u64) -> Real {
        (splitmix64(s) >> 11) as Real / (1u64 << 53) as Real
    }

    fn group(tris: &[[Vec3; 3]]) -> Tri4 {
        let mut g = Tri4 {
            corners: [[[0.0; LANES]; 3]; 3],
            prims: [u32::MAX; LANES],
        };
        for (lane, v) in tris.iter().enumerate() {
            g.prims[lane] = lane as u32;
            for (j, corner) in v.iter().enumerate() {
                for axis in 0..3 {
                    g.corners[j][axis][lane] = corner[axis];
                }
            }
        }
        g
    }

    /// Every lane gives the scalar kernel's answer to the bit: random triangles, slivers,
    /// triangles sharing edges, degenerate ones, rays along the axes and `t` limits at a hit.
    #[test]
    fn four_lanes_give_the_scalar_test_bit_for_bit() {
        let mut s = 17u64;
        let mut hits = 0;
        for round in 0..4000 {
            let mut p = || Vec3::new(rand(&mut s), rand(&mut s), rand(&mut s)) * 4.0 - 2.0;
            let (a, b, c, d) = (p(), p(), p(), p());
            let mut tris = vec![[a, b, c], [a, c, d], [a, b, a + (b - a) * 0.5], [c, b, d]];
            tris[3][2] = tris[3][1] + (tris[3][2] - tris[3][1]) * 1e-3; // a sliver
            let used = 1 + round % LANES;
            tris.truncate(used);
            let g = group(&tris);
            let o = p() * 2.0;
            let mut dir = (p() * 0.3 + (a + b + c) / 3.0 - o).normalize();
            if round.is_multiple_of(7) {
                dir = Vec3::new(0.0, 0.0, if round.is_multiple_of(2) { 1.0 } else { -1.0 });
            }
            let r = RayPre::new(Ray::new(o, dir));
            let mut t_max = if round.is_multiple_of(3) {
                2.5
            } else {
                Real::INFINITY
            };
            let want: Vec<_> = tris
                .iter()
                .map(|v| crate::geometry::triangle::intersect_triangle(&r, v, 0.0, t_max))
                .collect();
            if round.is_multiple_of(5) {
                // A limit exactly at a hit: `t < t_max` leaves it out in both.
                if let Some(t) = want.iter().flatten().next() {
                    t_max = *t;
                }
            }
            let want: Vec<_> = tris
                .iter()
                .map(|v| crate::geometry::triangle::intersect_triangle(&r, v, 0.0, t_max))
                .collect();
            for (t, mask) in [g.hits(&r, t_max), g.hits_scalar(&r, t_max)] {
                for (lane, w) in want.iter().enumerate() {
                    let got = (mask >> lane & 1 == 1).then_some(t[lane]);
                    assert_eq!(
                        got.map(Real::to_bits),
                        w.map(Real::to_bits),
                        "{round} {lane}"
                    );
                }
                assert_eq!(mask >> used, 0, "no empty lane is hit");
            }
            hits += want.iter().flatten().count();
        }
        assert!(hits > 1000, "{hits}");
    }

    /// A tree with groups finds what the same tree tested item by item finds, with the same
    /// counts, on triangles (tetra), triangles with spheres (mount) and slivers (gears).
    #[test]
    fn a_tree_with_groups_answers_as_item_by_item() {
        use super::super::Bvh;
        use yari::spd::Database;
        let mut s = 5u64;
        for (db, size) in [
            (Database::Tetra, 3),
            (Database::Mount, 2),
            (Database::Gears, 1),
        ] {
            let world = crate::bench::spd_world(db, size).unwrap();
            let mut prims = crate::scene::Scene::new(world).prims;
            let grouped = Bvh::build(&mut prims);
            assert!(!grouped.leaves4.is_empty());
            let mut plain = grouped.clone();
            plain.leaves4 = Leaves4::default();
            let (mut c1, mut c2) = (Counters::default(), Counters::default());
            for _ in 0..3000 {
                let mut p = || Vec3::new(rand(&mut s), rand(&mut s), rand(&mut s)) * 4.0 - 2.0;
                let (o, d) = (p(), p().normalize());
                let mut r = RayPre::new(Ray::new(o, d));
                if rand(&mut s) < 0.5 {
                    // A ray leaving a flat face: some primitives skipped untested.
                    let first = (rand(&mut s) * prims.len() as Real) as u32;
                    r = r.leaving([first, first + 1 + (rand(&mut s) * 40.0) as u32]);
                }
                let t_max = if rand(&mut s) < 0.5 {
                    1.0
                } else {
                    Real::INFINITY
                };
                let (a, b) = (
                    grouped.closest(&prims, &r, t_max, None, &mut c1),
                    plain.closest(&prims, &r, t_max, None, &mut c2),
                );
                assert_eq!(a, b);
                let opaque = |i: u32| !i.is_multiple_of(3);
                let (a, b) = (
                    grouped.any(&prims, &r, t_max, &opaque, &mut c1),
                    plain.any(&prims, &r, t_max, &opaque, &mut c2),
                );
                assert_eq!(a, b);
            }
            assert_eq!(c1, c2, "{db:?}");
            assert!(c1.intersection_tests > 1000, "{c1:?}");
            let (nodes, items) = (&grouped.nodes, &grouped.items);
            let most = leaves(nodes)
                .map(|l| (l.count as usize).div_ceil(LANES))
                .sum();
            assert!(grouped.leaves4.len() <= most);
            let need = bytes(most, items);
            assert!(!Leaves4::within(nodes, items, &prims, need).is_empty());
            assert!(Leaves4::within(nodes, items, &prims, need - 1).is_empty());
        }
    }
}
