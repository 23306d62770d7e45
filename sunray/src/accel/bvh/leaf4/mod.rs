//! Leaves tested four primitives at a time: a leaf of static triangles alone, or of static
//! spheres alone, is copied in leaf order into groups of four ([`triangles::Tri4`]: corners
//! one array per vertex and axis; [`spheres::Sph4`]: centres and radii), and a ray meets a
//! group in one pass of AVX2 arithmetic, with no branch per primitive and no walk from item
//! to slot to table to corners. A leaf that mixes kinds, or holds anything else, is tested
//! item by item as before.
//!
//! Each lane computes exactly what the scalar kernel computes, so every `t` is the scalar
//! test's to the bit, the hits are the same and so are the counters (a leaf's primitives are
//! counted as tested one by one would be, up to the one that ends a shadow ray).
//!
//! The groups copy the geometry (80 bytes a triangle, 40 a sphere, more where a leaf's last
//! group is not full), so they are made only while they take at most [`BUDGET`] bytes: every
//! SPD scene and models of some hundred thousand triangles; a scene of millions keeps the
//! memory it had and tests item by item (bench/results/limit.md has the speed).

pub mod spheres;
pub mod triangles;

use super::items::LeafItems;
use super::wide::{Child, Node};
use crate::accel::Hit;
use crate::geometry::{Primitives, RayPre, Real};
use crate::stats::Counters;
use spheres::Sph4;
use triangles::Tri4;

/// Primitives per group.
pub const LANES: usize = 4;

/// The mask of the lanes of `prims` that hold a primitive (not `u32::MAX`).
fn used_lanes(prims: &[u32; LANES]) -> u32 {
    let mut m = 0;
    for (lane, p) in prims.iter().enumerate() {
        m |= u32::from(*p != u32::MAX) << lane;
    }
    m
}

/// The most bytes of groups a tree holds (see the module's text).
pub const BUDGET: usize = 64 << 20;

/// A leaf's start in the sphere groups is marked with this bit.
const SPHERES: u32 = 1 << 31;

/// A group of four primitives of one kind, tested at once.
pub trait Lanes {
    /// Each lane's primitive, `u32::MAX` for an empty lane.
    fn prims(&self) -> &[u32; LANES];

    /// The lanes holding a primitive that `r` is not known to miss.
    fn live(&self, r: &RayPre) -> u32;

    /// Each lane's `t` where the ray meets its primitive in `(0, t_max)`, and the mask (a bit
    /// per lane) of the lanes it meets: in AVX2 lanes where the build has AVX2.
    #[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
    fn hits(&self, r: &RayPre, t_max: Real) -> ([Real; LANES], u32);

    /// [`Lanes::hits`] without AVX2: each lane through the scalar kernel.
    #[cfg(not(all(target_arch = "x86_64", target_feature = "avx2")))]
    #[inline(always)]
    fn hits(&self, r: &RayPre, t_max: Real) -> ([Real; LANES], u32) {
        self.hits_scalar(r, t_max)
    }

    /// What [`Lanes::hits`] gives, each lane through the scalar kernel.
    fn hits_scalar(&self, r: &RayPre, t_max: Real) -> ([Real; LANES], u32);

    /// The lanes holding a primitive (a bit a lane, kept with the group: computed from
    /// [`Lanes::prims`] at every test, it took some 20 instructions a group, twice).
    fn lanes(&self) -> u32;

    /// How many lanes hold a primitive.
    #[inline(always)]
    fn count(&self) -> u64 {
        u64::from(self.lanes().count_ones())
    }

    /// The lanes whose primitives the ray meets in `(0, t_max)`, in lane order, as (lane,
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
        let prims = *self.prims();
        std::iter::from_fn(move || {
            (m != 0).then(|| {
                let lane = m.trailing_zeros() as usize;
                m &= m - 1;
                (lane, t[lane], prims[lane])
            })
        })
    }
}

/// The groups of a leaf.
#[derive(Clone, Copy, Debug)]
pub enum Groups<'a> {
    /// A leaf of static triangles.
    Triangles(&'a [Tri4]),
    /// A leaf of static spheres.
    Spheres(&'a [Sph4]),
}

/// The groups of every leaf made of one kind of static primitive.
#[derive(Clone, Debug, Default)]
pub struct Leaves4 {
    triangles: Vec<Tri4>,
    spheres: Vec<Sph4>,
    /// For the first item of each leaf: its first group (in `spheres` when [`SPHERES`] is
    /// set), or `u32::MAX` when the leaf is tested item by item.
    start: Vec<u32>,
}

impl Leaves4 {
    /// The groups of the leaves of `nodes` over `items`; none if they could take more than
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
            start: vec![u32::MAX; items.len()],
            ..Leaves4::default()
        };
        for leaf in leaves(nodes) {
            out.add_leaf(leaf, items, prims);
        }
        if out.is_empty() {
            // No leaf of one kind (a scene of quadrics): no table to look up at every leaf.
            return Leaves4::default();
        }
        out
    }

    fn add_leaf(&mut self, leaf: Child, items: &LeafItems, prims: &Primitives) {
        let first = leaf.index as usize;
        let range = || (first..first + leaf.count as usize).map(|k| items.prim(prims, k));
        let triangles: Option<Vec<_>> = range()
            .map(|i| prims.mesh_triangle(i).map(|v| (i, v)))
            .collect();
        if let Some(triangles) = triangles {
            self.start[first] = self.triangles.len() as u32;
            self.triangles.extend(triangles.chunks(LANES).map(Tri4::of));
            return;
        }
        let spheres: Option<Vec<_>> = range()
            .map(|i| prims.table_sphere(i).map(|(c, r)| (i, c, r)))
            .collect();
        if let Some(spheres) = spheres {
            self.start[first] = SPHERES | self.spheres.len() as u32;
            self.spheres.extend(spheres.chunks(LANES).map(Sph4::of));
        }
    }

    /// The groups of `leaf`, when its items are all of one kind.
    #[inline(always)]
    pub fn groups_of(&self, leaf: Child) -> Option<Groups<'_>> {
        let g = *self.start.get(leaf.index as usize)?;
        if g == u32::MAX {
            return None;
        }
        let n = (leaf.count as usize).div_ceil(LANES);
        let at = (g & !SPHERES) as usize;
        if g & SPHERES == 0 {
            self.triangles.get(at..at + n).map(Groups::Triangles)
        } else {
            self.spheres.get(at..at + n).map(Groups::Spheres)
        }
    }

    /// How many groups there are.
    pub fn len(&self) -> usize {
        self.triangles.len() + self.spheres.len()
    }

    /// True when no leaf has groups.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// Each lane's `t` from `test(lane)` (None where it misses) for the lanes of `lanes`, and
/// the mask of the lanes hit: a group's test one lane at a time, as the scalar kernels do it.
fn lane_by_lane(lanes: u32, test: impl Fn(usize) -> Option<Real>) -> ([Real; LANES], u32) {
    let mut out = [0.0; LANES];
    let mut mask = 0;
    for (lane, t) in out.iter_mut().enumerate() {
        if let Some(hit) = test(lane) {
            *t = hit;
            mask |= 1 << lane;
        }
    }
    (out, mask & lanes)
}

/// The leaves of `nodes`.
fn leaves(nodes: &[Node]) -> impl Iterator<Item = Child> + '_ {
    nodes.iter().flat_map(|node| {
        (0..node.children.len())
            .filter(|&k| node.used(k) && node.children[k].is_leaf())
            .map(|k| node.children[k])
    })
}

/// The most bytes `groups` groups and the leaf starts of `items` take.
fn bytes(groups: usize, items: &LeafItems) -> usize {
    groups * std::mem::size_of::<Tri4>().max(std::mem::size_of::<Sph4>()) + items.len() * 4
}

/// The closest hit among a leaf's groups that improves on `best`.
#[inline(always)]
pub fn closest(
    groups: Groups<'_>,
    r: &RayPre,
    t_max: Real,
    best: Option<Hit>,
    c: &mut Counters,
) -> Option<Hit> {
    match groups {
        Groups::Triangles(g) => closest_in(g, r, t_max, best, c),
        Groups::Spheres(g) => closest_in(g, r, t_max, best, c),
    }
}

/// Some hit among a leaf's groups that `accept` takes, the first in leaf order.
#[inline(always)]
pub fn any(
    groups: Groups<'_>,
    r: &RayPre,
    t_max: Real,
    accept: &dyn Fn(u32, Real) -> bool,
    c: &mut Counters,
) -> Option<Hit> {
    match groups {
        Groups::Triangles(g) => any_in(g, r, t_max, accept, c),
        Groups::Spheres(g) => any_in(g, r, t_max, accept, c),
    }
}

#[inline(always)]
fn closest_in<G: Lanes>(
    groups: &[G],
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

#[inline(always)]
fn any_in<G: Lanes>(
    groups: &[G],
    r: &RayPre,
    t_max: Real,
    accept: &dyn Fn(u32, Real) -> bool,
    c: &mut Counters,
) -> Option<Hit> {
    for g in groups {
        for (lane, t, prim) in g.crossings(r, t_max) {
            if accept(prim, t) {
                // Counted as the item-by-item walk counts: up to the primitive that ends it.
                c.intersection_tests += lane as u64 + 1;
                return Some(Hit { t, prim });
            }
        }
        c.intersection_tests += g.count();
    }
    None
}

/// Asserts that group `g`'s lanes, in AVX2 and scalar alike, give `want` (each lane's `t`,
/// the scalar kernel's) to the bit, and that no empty lane is hit; `round` names the case.
#[cfg(test)]
fn assert_lanes_are(g: &impl Lanes, r: &RayPre, t_max: Real, want: &[Option<Real>], round: usize) {
    for (t, mask) in [g.hits(r, t_max), g.hits_scalar(r, t_max)] {
        for (lane, w) in want.iter().enumerate() {
            let got = (mask >> lane & 1 == 1).then_some(t[lane]);
            assert_eq!(
                got.map(Real::to_bits),
                w.map(Real::to_bits),
                "{round} {lane}"
            );
        }
        assert_eq!(mask >> want.len(), 0, "no empty lane is hit");
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{Ray, Vec3};
    use crate::sampler::unit_f64 as rand;

    /// A tree with groups finds what the same tree tested item by item finds, with the same
    /// counts, on triangles (tetra), triangles with spheres (mount), slivers (gears) and
    /// spheres (balls).
    #[test]
    fn a_tree_with_groups_answers_as_item_by_item() {
        use super::super::Bvh;
        use yari::spd::Database;
        let mut s = 5u64;
        for (db, size) in [
            (Database::Tetra, 3),
            (Database::Mount, 2),
            (Database::Gears, 1),
            (Database::Balls, 2),
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
                let opaque = |i: u32, t: Real| {
                    // The walk passes the t where the ray meets the primitive.
                    assert_eq!(prims.intersect(i, &r, 0.0, t_max), Some(t));
                    !i.is_multiple_of(3)
                };
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
