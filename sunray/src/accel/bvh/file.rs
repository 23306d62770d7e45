//! A built BVH as bytes, so a host keeps the one it built and the next worker reads it
//! instead of building it again (thesis future research 8: preprocessing once).
//!
//! Layout (little-endian): magic `SUNRAYB1`, the scene's primitive count (u64), node count
//! (u64), item count (u64), the nodes (24 planes as f64, then 4 children as two u32 each),
//! the items (primitive numbers in leaf order, u32), and an FNV-1a 64 of all that.
//!
//! What is read is not trusted (any process of the host may write the cache): every count
//! is checked against the length before anything is allocated, every index against what it
//! indexes, every item must appear in exactly one leaf, every box must contain the boxes
//! (and at the leaves the primitives) below it, and the tree may be at most [`MAX_DEPTH`]
//! deep. A tree that passes finds exactly the hits a freshly built one does (every
//! accelerator does: the hits never depend on the tree), so a wrong file can cost time,
//! never a pixel.

use super::items::LeafItems;
use super::wide::{Child, Node, WIDTH};
use super::Bvh;
use crate::geometry::{Aabb, Primitives, Real, Vec3};

const MAGIC: &[u8; 8] = b"SUNRAYB1";
const NODE_BYTES: usize = 24 * 8 + WIDTH * 8;
/// The deepest tree read back (a genuine tree of a sane scene is far shallower; the
/// traversal's fallback recurses this deep at most).
pub const MAX_DEPTH: usize = 512;

/// Why bytes are not a BVH of the given primitives.
#[derive(Debug, thiserror::Error, PartialEq, Eq)]
#[error("not a BVH of this scene: {0}")]
pub struct BvhFileError(String);

pub(super) fn bad<T>(why: impl Into<String>) -> Result<T, BvhFileError> {
    Err(BvhFileError(why.into()))
}

impl Bvh {
    /// The BVH as bytes (see the module's text).
    pub fn to_bytes(&self, prims: &Primitives) -> Vec<u8> {
        let items = self.items.len();
        let mut out = Vec::with_capacity(32 + self.nodes.len() * NODE_BYTES + items * 4 + 8);
        out.extend_from_slice(MAGIC);
        for n in [prims.len(), self.nodes.len(), items] {
            out.extend_from_slice(&(n as u64).to_le_bytes());
        }
        for node in self.nodes.iter() {
            for plane in node.planes.iter().flatten().flatten() {
                out.extend_from_slice(&plane.to_le_bytes());
            }
            for c in &node.children {
                out.extend_from_slice(&c.index.to_le_bytes());
                out.extend_from_slice(&c.count.to_le_bytes());
            }
        }
        for k in 0..items {
            out.extend_from_slice(&self.items.prim(prims, k).to_le_bytes());
        }
        let sum = yari::modelfile::fnv1a(&out);
        out.extend_from_slice(&sum.to_le_bytes());
        out
    }

    /// The BVH of `prims` in `bytes`, checked (see the module's text); `prims` adopts its
    /// leaf order ([`Primitives::adopt_order`]) as when it was built.
    pub fn from_bytes(bytes: &[u8], prims: &mut Primitives) -> Result<Bvh, BvhFileError> {
        let Some((body, sum)) = bytes.split_last_chunk::<8>() else {
            return bad("too short");
        };
        if body.len() < 32 || &body[..8] != MAGIC {
            return bad("no BVH header");
        }
        if yari::modelfile::fnv1a(body) != u64::from_le_bytes(*sum) {
            return bad("checksum mismatch");
        }
        let word = |at: usize| u64::from_le_bytes(body[at..at + 8].try_into().unwrap_or([0; 8]));
        let (count, nodes, items) = (word(8), word(16), word(24));
        if count != prims.len() as u64 {
            return bad("for another number of primitives");
        }
        let expected = (nodes as u128) * NODE_BYTES as u128 + (items as u128) * 4;
        if expected != (body.len() - 32) as u128 {
            return bad("counts do not match the length");
        }
        let (node_bytes, item_bytes) = body[32..].split_at(nodes as usize * NODE_BYTES);
        let nodes: Vec<Node> = node_bytes.chunks_exact(NODE_BYTES).map(node_of).collect();
        let order: Vec<u32> = item_bytes
            .chunks_exact(4)
            .map(|b| u32::from_le_bytes(b.try_into().unwrap_or([0; 4])))
            .collect();
        check(&nodes, &order, prims)?;
        prims.adopt_order(&order);
        let items = LeafItems::new(prims, &order);
        let leaves4 = super::leaf4::Leaves4::new(&nodes, &items, prims);
        Ok(Bvh {
            nodes: nodes.into(),
            items,
            leaves4,
        })
    }
}

fn node_of(b: &[u8]) -> Node {
    let f = |k: usize| Real::from_le_bytes(b[k * 8..k * 8 + 8].try_into().unwrap_or([0; 8]));
    let u = |at: usize| u32::from_le_bytes(b[at..at + 4].try_into().unwrap_or([0; 4]));
    let mut planes = [[[0.0; WIDTH]; 3]; 2];
    for (k, p) in planes.iter_mut().flatten().flatten().enumerate() {
        *p = f(k);
    }
    let mut children = [Child { index: 0, count: 0 }; WIDTH];
    for (k, c) in children.iter_mut().enumerate() {
        let at = 24 * 8 + k * 8;
        *c = Child {
            index: u(at),
            count: u(at + 4),
        };
    }
    Node { planes, children }
}

/// Slot `k`'s box in `node`; `None` when the slot is empty (every plane +inf).
fn slot_box(node: &Node, k: usize) -> Result<Option<Aabb>, BvhFileError> {
    let p = |side: usize| {
        Vec3::new(
            node.planes[side][0][k],
            node.planes[side][1][k],
            node.planes[side][2][k],
        )
    };
    let (lo, hi) = (p(0), p(1));
    if lo.is_nan() || hi.is_nan() {
        return bad("a box is not a number");
    }
    if lo == Vec3::INFINITY && hi == Vec3::INFINITY {
        return Ok(None);
    }
    if !lo.cmple(hi).all() {
        return bad("an inside-out box");
    }
    Ok(Some(Aabb::new(lo, hi)))
}

fn contains(outer: &Aabb, inner: &Aabb) -> bool {
    outer.min.cmple(inner.min).all() && outer.max.cmpge(inner.max).all()
}

/// The whole check of a tree read back: see the module's text.
pub fn check(nodes: &[Node], order: &[u32], prims: &Primitives) -> Result<(), BvhFileError> {
    let bounded = (0..prims.len() as u32)
        .filter(|&i| prims.bounds(i).is_some())
        .count();
    if order.len() != bounded {
        return bad("not every bounded primitive is in it");
    }
    let mut listed = vec![false; prims.len()];
    for &i in order {
        if i as usize >= prims.len() || prims.bounds(i).is_none() {
            return bad("an item is no bounded primitive");
        }
        if std::mem::replace(&mut listed[i as usize], true) {
            return bad("an item is listed twice");
        }
    }
    if nodes.is_empty() {
        return if order.is_empty() {
            Ok(())
        } else {
            bad("items but no nodes")
        };
    }
    let mut covered = vec![false; order.len()];
    let mut visited = vec![false; nodes.len()];
    // (node, depth, the box of the slot that leads to it)
    let mut stack: Vec<(usize, usize, Option<Aabb>)> = vec![(0, 1, None)];
    while let Some((at, depth, outer)) = stack.pop() {
        if depth > MAX_DEPTH {
            return bad("deeper than a tree is read back");
        }
        if std::mem::replace(&mut visited[at], true) {
            return bad("a node is reached twice");
        }
        let node = &nodes[at];
        for k in 0..WIDTH {
            let child = node.children[k];
            let Some(b) = slot_box(node, k)? else {
                if child != (Child { index: 0, count: 0 }) {
                    return bad("an empty slot with a child");
                }
                continue;
            };
            if outer.is_some_and(|o| !contains(&o, &b)) {
                return bad("a box outside its parent's");
            }
            if child.is_leaf() {
                let (first, n) = (child.index as usize, child.count as usize);
                if first.checked_add(n).is_none_or(|end| end > order.len()) {
                    return bad("a leaf past the items");
                }
                for (k, &i) in order[first..first + n].iter().enumerate() {
                    if std::mem::replace(&mut covered[first + k], true) {
                        return bad("an item in two leaves");
                    }
                    if prims.bounds(i).is_none_or(|pb| !contains(&b, &pb)) {
                        return bad("a primitive outside its leaf's box");
                    }
                }
            } else {
                let next = child.index as usize;
                if next <= at || next >= nodes.len() {
                    return bad("a child index out of order");
                }
                stack.push((next, depth + 1, Some(b)));
            }
        }
    }
    if covered.iter().any(|c| !c) {
        return bad("an item in no leaf");
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{Ray, RayPre};
    use crate::stats::Counters;

    fn scene() -> Primitives {
        let w = crate::bench::spd_world(yari::spd::Database::Mount, 2).unwrap();
        crate::scene::Scene::new(w).prims
    }

    #[test]
    fn a_bvh_read_back_is_the_one_written() {
        let mut built_prims = scene();
        let built = Bvh::build(&mut built_prims);
        let bytes = built.to_bytes(&built_prims);
        let mut prims = scene();
        let read = Bvh::from_bytes(&bytes, &mut prims).unwrap();
        assert_eq!(read.nodes.len(), built.nodes.len());
        assert_eq!(read.to_bytes(&prims), bytes);
        let mut c = Counters::default();
        let mut s = 3u64;
        for _ in 0..500 {
            let mut r = || (crate::sampler::splitmix64(&mut s) >> 11) as f64 / (1u64 << 53) as f64;
            let o = Vec3::new(r(), r(), r()) * 8.0 - 4.0;
            let d = Vec3::new(r(), r(), r()) - 0.5;
            let ray = RayPre::new(Ray::new(o, d));
            assert_eq!(
                read.closest(&prims, &ray, Real::INFINITY, None, &mut c),
                built.closest(&built_prims, &ray, Real::INFINITY, None, &mut c)
            );
        }
    }

    #[test]
    fn damaged_or_hostile_bytes_are_refused_never_trusted() {
        let mut p = scene();
        let bvh = Bvh::build(&mut p);
        let good = bvh.to_bytes(&p);
        let reseal = |mut body: Vec<u8>| {
            body.truncate(body.len() - 8);
            let sum = yari::modelfile::fnv1a(&body);
            body.extend_from_slice(&sum.to_le_bytes());
            body
        };
        let read = |bytes: &[u8]| Bvh::from_bytes(bytes, &mut scene()).map(|_| ());
        assert!(read(&good).is_ok());
        for n in [0, 7, 8, 39, good.len() - 1] {
            assert!(read(&good[..n]).is_err(), "a prefix of {n}");
        }
        let mut flipped = good.clone();
        flipped[100] ^= 1;
        assert!(read(&flipped).is_err(), "checksum");
        // A resealed box shrunk so that its primitives stick out.
        // (Node 0's planes: [min, max][x, y, z][slot]; slot 0's box made flat in x.)
        let mut shrunk = good.clone();
        let (min_x, max_x) = (32, 32 + 8 * 12);
        let min = shrunk[min_x..min_x + 8].to_vec();
        shrunk[max_x..max_x + 8].copy_from_slice(&min);
        assert!(read(&reseal(shrunk)).is_err());
        // A child pointing back at the root (a cycle).
        let mut cycle = good.clone();
        let first_interior = (0..WIDTH)
            .find(|&k| !bvh.nodes[0].children[k].is_leaf() && bvh.nodes[0].used(k))
            .unwrap();
        let at = 32 + 24 * 8 + first_interior * 8;
        cycle[at..at + 4].copy_from_slice(&0u32.to_le_bytes());
        assert!(read(&reseal(cycle)).is_err());
        // Counts that claim more than there is.
        let mut huge = good.clone();
        huge[16..24].copy_from_slice(&u64::MAX.to_le_bytes());
        assert!(read(&reseal(huge)).is_err());
        // An item out of range.
        let mut item = good.clone();
        let at = good.len() - 8 - 4;
        item[at..at + 4].copy_from_slice(&u32::MAX.to_le_bytes());
        assert!(read(&reseal(item)).is_err());
        // Another scene.
        let other = crate::scene::Scene::new(
            crate::bench::spd_world(yari::spd::Database::Tetra, 2).unwrap(),
        );
        assert!(Bvh::from_bytes(&good, &mut other.prims.clone()).is_err());
    }
}
