//! The binary tree the BVH starts from, built with the binned surface area heuristic (Wald
//! 2007) down to nodes of [`EXACT`] items, then with the exact one, weighing each item by the
//! cost of its intersection test; flattened depth-first: a node's left child follows it, the
//! right child is at `index`. [`super::wide`] collapses it into the 4-wide tree that rays
//! traverse.

use crate::geometry::{Aabb, Real, Vec3};

const BINS: usize = 16;
/// Nodes of at most this many items are split by the exact SAH ([`exact_split`]), not by bins,
/// and may be leaves; larger ones are always split.
const EXACT: usize = 16;
/// The traversal cost [`exact_split`] weighs a split by, against items' test costs
/// ([`crate::geometry::Primitives::test_cost`]): 1 split trees into many small leaves and was
/// 2-8% slower on mount6 and balls4 than the 4-item leaves before; 2 and 3 were within 2% of
/// them everywhere, and 2 the faster on tree11, lattice12 and jacks1.
const TRAVERSAL_COST: Real = 2.0;

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

/// One primitive while the tree is built, in 44 bytes: its box rounded outwards to `f32`
/// (a box only has to contain its primitive; the hits never depend on the tree), its
/// centre and the cost of its test, so that a scene of millions of triangles is built in
/// little memory.
struct BuildItem {
    prim: u32,
    cost: f32,
    bounds: Box32,
    centre: [f32; 3],
}

impl BuildItem {
    fn new(prim: u32, b: Aabb, cost: f32) -> BuildItem {
        let c = b.centre();
        BuildItem {
            prim,
            cost,
            bounds: Box32 {
                lo: b.min.to_array().map(round_down),
                hi: b.max.to_array().map(round_up),
            },
            centre: [c.x as f32, c.y as f32, c.z as f32],
        }
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
    /// Builds over `(primitive index, bounds, test cost)`: the cost of the primitive's
    /// intersection test relative to a triangle's
    /// ([`crate::geometry::Primitives::test_cost`]).
    pub fn build(bounded: impl Iterator<Item = (u32, Aabb, f32)>) -> BinaryBvh {
        let mut items: Vec<BuildItem> = bounded
            .map(|(p, b, cost)| BuildItem::new(p, b, cost))
            .collect();
        let mut bvh = BinaryBvh {
            nodes: Vec::with_capacity(items.len() / 2 + 1),
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
        let (bounds, centres) = summary(slice);
        self.nodes.push(Node {
            bounds,
            index: start as u32,
            count: slice.len() as u16,
        });
        if slice.len() <= EXACT {
            return match exact_split(slice, &bounds) {
                Some(k) => {
                    self.finish_interior(node, items, start, start + k, end);
                    node
                }
                None => node,
            };
        }
        let Some((axis, split, bins)) = best_split(slice, centres) else {
            // All centres equal: split in the middle of the list.
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

/// A box in `f32`, as the items' are: unions of them are exact, so a box made here and
/// widened to `f64` is the one `f64` unions of the items' boxes give.
#[derive(Clone, Copy)]
struct Box32 {
    lo: [f32; 3],
    hi: [f32; 3],
}

impl Box32 {
    const EMPTY: Box32 = Box32 {
        lo: [f32::INFINITY; 3],
        hi: [f32::NEG_INFINITY; 3],
    };

    #[inline(always)]
    fn grow(&mut self, other: &Box32) {
        let (lo, hi) = (&other.lo, &other.hi);
        for a in 0..3 {
            self.lo[a] = if lo[a] < self.lo[a] {
                lo[a]
            } else {
                self.lo[a]
            };
            self.hi[a] = if hi[a] > self.hi[a] {
                hi[a]
            } else {
                self.hi[a]
            };
        }
    }

    fn aabb(&self) -> Aabb {
        let v = |a: [f32; 3]| Vec3::new(a[0].into(), a[1].into(), a[2].into());
        Aabb::new(v(self.lo), v(self.hi))
    }
}

/// The box around the items and the range of their centres on each axis, in one pass.
fn summary(items: &[BuildItem]) -> (Aabb, [(Real, Real); 3]) {
    let (mut b, mut c) = (Box32::EMPTY, Box32::EMPTY);
    for i in items {
        b.grow(&i.bounds);
        c.grow(&Box32 {
            lo: i.centre,
            hi: i.centre,
        });
    }
    let range = |a: usize| (Real::from(c.lo[a]), Real::from(c.hi[a]));
    (b.aabb(), [range(0), range(1), range(2)])
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

/// The best (axis, bin boundary) by SAH and that axis's bins, or None when the centres
/// coincide. `centres` are the items' centre ranges. The items are binned on the three axes
/// in one pass.
fn best_split(items: &[BuildItem], centres: [(Real, Real); 3]) -> Option<(usize, usize, Bins)> {
    let bins = centres.map(Bins::over);
    let mut rows = [[(Box32::EMPTY, 0.0); BINS]; 3];
    for i in items {
        for axis in 0..3 {
            if let Some(bins) = &bins[axis] {
                let bin = &mut rows[axis][bins.of(i.centre(axis))];
                bin.0.grow(&i.bounds);
                bin.1 += 1.0;
            }
        }
    }
    let mut best: Option<(Real, usize, usize, Bins)> = None;
    for axis in 0..3 {
        let Some(bins) = bins[axis] else {
            continue;
        };
        if let Some((cost, b)) = cheapest_cut(&rows[axis]) {
            if best.is_none_or(|(c, ..)| cost < c) {
                best = Some((cost, axis, b, bins));
            }
        }
    }
    best.map(|(_, axis, split, bins)| (axis, split, bins))
}

/// The cheapest place to cut a row of boxes, each with a weight (items in a bin, cost of a
/// test), in two by the SAH: `(area of the boxes before k * their weight + area of the
/// boxes from k on * theirs, k)` for the first least such sum, `0 < k < len`, where neither
/// side weighs nothing. Used for bins ([`best_split`]) and for items ([`exact_split`]),
/// both at most 16 long.
fn cheapest_cut(row: &[(Box32, Real)]) -> Option<(Real, usize)> {
    const LONGEST: usize = if BINS > EXACT { BINS } else { EXACT };
    let n = row.len().min(LONGEST);
    // The area and weight of the boxes from k on.
    let mut right = [(0.0, 0.0); LONGEST];
    let (mut acc, mut weight) = (Box32::EMPTY, 0.0);
    for k in (1..n).rev() {
        acc.grow(&row[k].0);
        weight += row[k].1;
        right[k] = (acc.aabb().surface_area(), weight);
    }
    let mut best: Option<(Real, usize)> = None;
    let (mut acc, mut weight) = (Box32::EMPTY, 0.0);
    for k in 1..n {
        acc.grow(&row[k - 1].0);
        weight += row[k - 1].1;
        if weight == 0.0 || right[k].1 == 0.0 {
            continue;
        }
        let cost = acc.aabb().surface_area() * weight + right[k].0 * right[k].1;
        if best.is_none_or(|(c, _)| cost < c) {
            best = Some((cost, k));
        }
    }
    best
}

/// The exact SAH split of a small node, each item weighed by its test cost: on each axis the
/// items in order of their centres (ties by primitive), every place between two of them.
/// Returns how many items go left (the slice is then in that axis's order), or None when a
/// leaf is cheaper. Unlike bins, this separates a huge item from small ones whose centres
/// are close to its own: tree11's ground polygon shared a leaf with the trunk, and every
/// shadow ray leaving the ground tested all three (900,000 of its 1.09M shadow rays).
fn exact_split(items: &mut [BuildItem], bounds: &Aabb) -> Option<usize> {
    let n = items.len();
    if n < 2 {
        return None;
    }
    let order = |axis: usize| {
        move |a: &BuildItem, b: &BuildItem| {
            a.centre[axis]
                .total_cmp(&b.centre[axis])
                .then(a.prim.cmp(&b.prim))
        }
    };
    let total: Real = items.iter().map(|i| Real::from(i.cost)).sum();
    let mut best: Option<(Real, usize, usize)> = None;
    let mut row = [(Box32::EMPTY, 0.0); EXACT];
    for axis in 0..3 {
        items.sort_unstable_by(order(axis));
        for (r, i) in row.iter_mut().zip(items.iter()) {
            *r = (i.bounds, Real::from(i.cost));
        }
        if let Some((cost, k)) = cheapest_cut(&row[..n]) {
            if best.is_none_or(|(c, ..)| cost < c) {
                best = Some((cost, axis, k));
            }
        }
    }
    let (cost, axis, k) = best?;
    let split_cost = TRAVERSAL_COST + cost / bounds.surface_area().max(1e-300);
    if split_cost >= total {
        return None;
    }
    if axis != 2 {
        items.sort_unstable_by(order(axis));
    }
    Some(k)
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
        let r = BuildItem::new(0, b, 1.0).bounds.aabb();
        assert!(
            r.min.cmple(b.min).all() && r.max.cmpge(b.max).all(),
            "{r:?}"
        );
        assert_eq!(std::mem::size_of::<BuildItem>(), 44);
    }

    fn item(prim: u32, lo: [f64; 3], hi: [f64; 3], cost: f32) -> BuildItem {
        BuildItem::new(prim, Aabb::new(Vec3::from(lo), Vec3::from(hi)), cost)
    }

    fn leaves(bvh: &BinaryBvh) -> Vec<Vec<u32>> {
        let mut out: Vec<Vec<u32>> = bvh
            .nodes
            .iter()
            .filter(|n| n.count > 0)
            .map(|n| {
                let (a, b) = (n.index as usize, n.index as usize + n.count as usize);
                let mut l = bvh.items[a..b].to_vec();
                l.sort();
                l
            })
            .collect();
        out.sort();
        out
    }

    fn build(items: Vec<BuildItem>) -> BinaryBvh {
        let list = items.iter().map(|i| (i.prim, i.bounds.aabb(), i.cost));
        BinaryBvh::build(list.collect::<Vec<_>>().into_iter())
    }

    #[test]
    fn a_huge_flat_item_gets_a_leaf_of_its_own() {
        // tree11's ground (two triangles, 100 x 100) and the trunk standing on its centre:
        // binned by centre they share a leaf, which every ray leaving the ground enters.
        let ground = |p| item(p, [-50.0, -50.0, 0.0], [50.0, 50.0, 0.0], 1.0);
        let trunk = item(2, [-0.15, -0.15, 0.0], [0.15, 0.15, 1.0], 3.0);
        let crown = item(3, [-0.1, -0.1, 0.9], [0.1, 0.1, 1.1], 1.0);
        let bvh = build(vec![ground(0), trunk, ground(1), crown]);
        let l = leaves(&bvh);
        assert!(l.contains(&vec![0, 1]), "{l:?}");
        assert!(!l.iter().any(|l| l.contains(&0) && l.contains(&2)), "{l:?}");
    }

    #[test]
    fn alike_neighbours_share_a_leaf_unless_their_tests_are_dear() {
        // Four unit boxes in a row, touching: splitting them would cost more node visits than
        // it saves tests of triangles, but not of quadrics.
        let row = |cost| {
            (0..4u32)
                .map(|k| {
                    let x = f64::from(k);
                    item(k, [x, 0.0, 0.0], [x + 1.0, 1.0, 1.0], cost)
                })
                .collect::<Vec<_>>()
        };
        assert_eq!(leaves(&build(row(1.0))), [vec![0, 1, 2, 3]]);
        assert!(leaves(&build(row(3.0))).len() > 1);
    }

    #[test]
    fn the_f32_summary_is_the_f64_union() {
        let mut seed = 5u64;
        let mut rnd = || (crate::sampler::splitmix64(&mut seed) >> 11) as f64 / 9e15 - 0.5;
        let items: Vec<BuildItem> = (0..200)
            .map(|k| {
                let (x, y, z) = (rnd() * 1e3, rnd(), rnd() * 1e-3);
                item(k, [x, y, z], [x + rnd().abs(), y + 0.1, z + 1e-4], 1.0)
            })
            .collect();
        let (bounds, centres) = summary(&items);
        let want = items
            .iter()
            .fold(Aabb::EMPTY, |b, i| b.union(i.bounds.aabb()));
        assert_eq!(bounds, want);
        for (axis, (lo, hi)) in centres.into_iter().enumerate() {
            let c = items.iter().map(|i| i.centre(axis));
            assert_eq!(lo, c.clone().fold(Real::INFINITY, Real::min));
            assert_eq!(hi, c.fold(Real::NEG_INFINITY, Real::max));
        }
    }

    #[test]
    fn big_nodes_are_split_and_leaves_stay_small() {
        // Seventeen coinciding boxes: no split is better than another, and still no leaf holds
        // more than the exact split's limit.
        let same: Vec<_> = (0..17).map(|k| item(k, [0.0; 3], [1.0; 3], 1.0)).collect();
        let bvh = build(same);
        assert!(bvh.nodes.iter().all(|n| usize::from(n.count) <= EXACT));
        let mut all: Vec<u32> = bvh.items.clone();
        all.sort();
        assert_eq!(all, (0..17).collect::<Vec<_>>());
    }
}
