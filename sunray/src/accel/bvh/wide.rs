//! The 4-wide tree rays traverse: each node holds the boxes of up to four children side by
//! side (one array per coordinate), so one ray is tested against all four in a few vector
//! instructions, and a ray visits about half as many nodes as in the binary tree.
//!
//! It is made by collapsing a [`BinaryBvh`]: a node takes its two children, then keeps
//! replacing the interior child with the largest surface by that child's own two children
//! until it has four.

use super::binary::BinaryBvh;
use crate::geometry::{Aabb, RayPre, Real};

/// The children of one node.
pub const WIDTH: usize = 4;

/// A child slot: an interior node, a leaf (a range of items), or nothing.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(C)]
pub struct Child {
    /// Interior: the node's index; leaf: its first item.
    pub index: u32,
    /// Leaf: how many items (> 0); interior or empty: 0.
    pub count: u32,
}

impl Child {
    /// True for a leaf (a non-empty range of items).
    pub fn is_leaf(&self) -> bool {
        self.count > 0
    }
}

/// Four child boxes, one array per coordinate: `planes[0]` the minima, `planes[1]` the
/// maxima. An empty slot's box is `+inf..+inf`, which no ray with a finite `t` limit hits.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
pub struct Node {
    /// `planes[min or max][axis][child]`: the four children's boxes.
    pub planes: [[[Real; WIDTH]; 3]; 2],
    /// The four child slots, matching the columns of `planes`.
    pub children: [Child; WIDTH],
}

/// A node's bytes in memory: its planes and children (224), then padding to its alignment.
pub const NODE_SIZE: usize = 256;
const _: () = assert!(std::mem::size_of::<Node>() == NODE_SIZE);

// SAFETY: `repr(C)`: 24 f64 planes, then 4 children of two u32, then 32 bytes of padding
// (written as zeros); any bits are a valid Node.
unsafe impl crate::store::Plain for Node {
    fn put(&self, out: &mut Vec<u8>) {
        for p in self.planes.iter().flatten().flatten() {
            p.put(out);
        }
        for c in &self.children {
            c.index.put(out);
            c.count.put(out);
        }
        out.extend_from_slice(&[0; NODE_SIZE - 24 * 8 - WIDTH * 8]);
    }
}

/// A ray prepared for the box tests: origin and inverse direction per axis, and where each
/// axis's near and far planes lie in a node ([`ROWS`]).
#[derive(Clone, Copy, Debug)]
pub struct BoxRay {
    origin: [Real; 3],
    inv: [Real; 3],
    rows: &'static [usize; 6],
}

/// For each combination of the direction's signs (bit `axis` set where the inverse direction
/// is negative): the offset, in `Real`s from the start of a node's planes, of each axis's near
/// row, then of each axis's far row. Read from this table, a walk's set-up is the three signs;
/// computed at every walk's start, the six offsets took some 24 instructions and six stack
/// slots (bench/results/limit.md, session 40).
static ROWS: [[usize; 6]; 8] = rows_table();

const fn rows_table() -> [[usize; 6]; 8] {
    let mut t = [[0; 6]; 8];
    let mut code = 0;
    while code < 8 {
        let mut axis = 0;
        while axis < 3 {
            let n = (code >> axis) & 1;
            t[code][axis] = (n * 3 + axis) * WIDTH;
            t[code][axis + 3] = ((n ^ 1) * 3 + axis) * WIDTH;
            axis += 1;
        }
        code += 1;
    }
    t
}

impl BoxRay {
    /// Where each axis's near row (`[0..3]`) and far row (`[3..6]`) lie in a node's planes,
    /// in `Real`s from their start.
    pub fn rows(&self) -> &'static [usize; 6] {
        self.rows
    }

    /// Prepares `r` for the box tests of every node it visits.
    #[inline(always)]
    pub fn new(r: &RayPre) -> BoxRay {
        let sign = |i: Real| usize::from(i < 0.0);
        let d = r.inv_dir;
        BoxRay {
            origin: r.ray.origin.to_array(),
            inv: d.to_array(),
            rows: &ROWS[sign(d.x) | sign(d.y) << 1 | sign(d.z) << 2],
        }
    }
}

impl Node {
    fn empty() -> Node {
        Node {
            planes: [[[Real::INFINITY; WIDTH]; 3]; 2],
            children: [Child { index: 0, count: 0 }; WIDTH],
        }
    }

    /// Whether slot `k` holds a child.
    pub fn used(&self, k: usize) -> bool {
        self.planes[0][0][k] != Real::INFINITY
    }

    /// The box of slot `k`.
    pub fn child_box(&self, k: usize) -> Aabb {
        let corner = |m: usize| {
            crate::geometry::Vec3::new(
                self.planes[m][0][k],
                self.planes[m][1][k],
                self.planes[m][2][k],
            )
        };
        Aabb::new(corner(0), corner(1))
    }

    fn set(&mut self, k: usize, b: &Aabb, child: Child) {
        for axis in 0..3 {
            self.planes[0][axis][k] = b.min[axis];
            self.planes[1][axis][k] = b.max[axis];
        }
        self.children[k] = child;
    }

    /// The entry `t` of the ray into each child box within `[0, limit]`, or +inf where it
    /// misses (the slab test of [`Aabb::hit`], four boxes at once), and the children hit as
    /// bits (bit k for child k), so a walk visits the children hit without testing each slot. Written with AVX2 intrinsics where the
    /// build has AVX2 (the x86-64-v3 default): from the plain loop ([`Node::entries_scalar`])
    /// the compiler made one vector step, then lane by lane scalar code with a branch per
    /// lane. The instructions compute exactly what the loop does: `max_pd(a, t)` is
    /// `if a > t { a } else { t }`, `min_pd` likewise.
    #[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
    #[inline(always)]
    pub fn entries_hit(&self, r: &BoxRay, limit: Real) -> ([Real; WIDTH], u32) {
        use std::arch::x86_64::{
            _mm256_blendv_pd, _mm256_cmp_pd, _mm256_loadu_pd, _mm256_max_pd, _mm256_min_pd,
            _mm256_movemask_pd, _mm256_mul_pd, _mm256_set1_pd, _mm256_setzero_pd, _mm256_storeu_pd,
            _mm256_sub_pd, _CMP_LE_OQ,
        };
        let limit = limit.min(Real::MAX);
        let mut out = [0.0; WIDTH];
        let planes = self.planes.as_ptr().cast::<Real>();
        // SAFETY: the build enables AVX2 (the cfg above); every load and store is an
        // unaligned one of a whole `[f64; 4]` (a row of `planes`, by ROWS's offsets).
        let mask = unsafe {
            let mut t0 = _mm256_setzero_pd();
            let mut t1 = _mm256_set1_pd(limit);
            for axis in 0..3 {
                // Rows of `planes`: every offset in ROWS is a whole row's start, below 6 rows.
                let near = _mm256_loadu_pd(planes.add(r.rows[axis]));
                let far = _mm256_loadu_pd(planes.add(r.rows[axis + 3]));
                let o = _mm256_set1_pd(r.origin[axis]);
                let inv = _mm256_set1_pd(r.inv[axis]);
                t0 = _mm256_max_pd(_mm256_mul_pd(_mm256_sub_pd(near, o), inv), t0);
                t1 = _mm256_min_pd(_mm256_mul_pd(_mm256_sub_pd(far, o), inv), t1);
            }
            let hit = _mm256_cmp_pd::<_CMP_LE_OQ>(t0, t1);
            let t = _mm256_blendv_pd(_mm256_set1_pd(Real::INFINITY), t0, hit);
            _mm256_storeu_pd(out.as_mut_ptr(), t);
            _mm256_movemask_pd(hit) as u32
        };
        (out, mask)
    }

    /// [`Node::entries_hit`] where the build has no AVX2.
    #[cfg(not(all(target_arch = "x86_64", target_feature = "avx2")))]
    #[inline(always)]
    pub fn entries_hit(&self, r: &BoxRay, limit: Real) -> ([Real; WIDTH], u32) {
        let t = self.entries_scalar(r, limit);
        let mask = (0..WIDTH).fold(0, |m, k| m | u32::from(t[k] != Real::INFINITY) << k);
        (t, mask)
    }

    /// [`Node::entries_hit`]'s entries as a plain loop.
    #[inline(always)]
    pub fn entries_scalar(&self, r: &BoxRay, limit: Real) -> [Real; WIDTH] {
        let limit = limit.min(Real::MAX);
        let mut t0 = [0.0; WIDTH];
        let mut t1 = [limit; WIDTH];
        let rows = self.planes.as_flattened();
        for axis in 0..3 {
            let (near, far) = (&rows[r.rows[axis] / WIDTH], &rows[r.rows[axis + 3] / WIDTH]);
            let (o, inv) = (r.origin[axis], r.inv[axis]);
            for k in 0..WIDTH {
                let a = (near[k] - o) * inv;
                let b = (far[k] - o) * inv;
                t0[k] = if a > t0[k] { a } else { t0[k] };
                t1[k] = if b < t1[k] { b } else { t1[k] };
            }
        }
        let mut out = [Real::INFINITY; WIDTH];
        for k in 0..WIDTH {
            if t0[k] <= t1[k] {
                out[k] = t0[k];
            }
        }
        out
    }
}

/// Collapses `bin` into 4-wide nodes; the root is node 0. Leaves keep `bin`'s item ranges.
pub fn collapse(bin: &BinaryBvh) -> Vec<Node> {
    let mut nodes = Vec::with_capacity(bin.nodes.len() / 2 + 1);
    if bin.nodes.is_empty() {
        return nodes;
    }
    nodes.push(Node::empty());
    let root = &bin.nodes[0];
    if root.count > 0 {
        nodes[0].set(
            0,
            &root.bounds,
            Child {
                index: root.index,
                count: u32::from(root.count),
            },
        );
        return nodes;
    }
    fill(bin, 0, 0, &mut nodes);
    nodes
}

/// Fills wide node `at` with the (up to four) descendants of binary interior node `b`.
fn fill(bin: &BinaryBvh, b: usize, at: usize, nodes: &mut Vec<Node>) {
    let children_of = |i: usize| [i + 1, bin.nodes[i].index as usize];
    let mut slots: Vec<usize> = children_of(b).to_vec();
    while slots.len() < WIDTH {
        // Open the interior child with the largest surface.
        let widest = slots
            .iter()
            .enumerate()
            .filter(|(_, &i)| bin.nodes[i].count == 0)
            .max_by(|x, y| {
                let area = |i: usize| bin.nodes[i].bounds.surface_area();
                area(*x.1).total_cmp(&area(*y.1))
            })
            .map(|(k, _)| k);
        let Some(k) = widest else { break };
        let i = slots.swap_remove(k);
        slots.extend(children_of(i));
    }
    for (k, &i) in slots.iter().enumerate() {
        let n = &bin.nodes[i];
        let child = if n.count > 0 {
            Child {
                index: n.index,
                count: u32::from(n.count),
            }
        } else {
            let index = nodes.len();
            nodes.push(Node::empty());
            fill(bin, i, index, nodes);
            Child {
                index: index as u32,
                count: 0,
            }
        };
        nodes[at].set(k, &n.bounds, child);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{Ray, Vec3};

    fn unit_boxes(n: usize) -> Vec<(u32, Aabb)> {
        (0..n)
            .map(|i| {
                let c = Vec3::new(i as Real * 3.0, (i % 5) as Real, (i % 3) as Real);
                (i as u32, Aabb::new(c, c + Vec3::ONE))
            })
            .collect()
    }

    /// Every item is reachable exactly once, and each child's box holds its subtree.
    fn check(nodes: &[Node], bin: &BinaryBvh, n: usize) {
        let mut seen = vec![0; n];
        let mut stack = vec![0usize];
        while let Some(i) = stack.pop() {
            for (k, c) in nodes[i].children.iter().enumerate() {
                if !nodes[i].used(k) {
                    continue;
                }
                if c.is_leaf() {
                    for &item in &bin.items[c.index as usize..(c.index + c.count) as usize] {
                        seen[item as usize] += 1;
                    }
                } else {
                    stack.push(c.index as usize);
                }
            }
        }
        assert!(seen.iter().all(|&s| s == 1), "{seen:?}");
    }

    #[test]
    fn collapse_keeps_every_item_once() {
        for n in [1, 2, 3, 5, 17, 200] {
            let bin = BinaryBvh::build(unit_boxes(n).into_iter().map(|(i, b)| (i, b, 1.0)));
            let nodes = collapse(&bin);
            check(&nodes, &bin, n);
            if n > 16 {
                assert!(nodes.len() < bin.nodes.len() / 2, "{n}: {}", nodes.len());
            }
        }
    }

    #[test]
    fn entries_match_the_scalar_slab_test() {
        let boxes = unit_boxes(4);
        let mut node = Node::empty();
        for (k, (_, b)) in boxes.iter().enumerate().take(3) {
            node.set(k, b, Child { index: 0, count: 1 });
        }
        let mut s = 7u64;
        for _ in 0..2000 {
            let mut rnd =
                || (crate::sampler::splitmix64(&mut s) >> 11) as f64 / (1u64 << 53) as f64;
            let o = Vec3::new(rnd() * 12.0 - 3.0, rnd() * 8.0 - 2.0, rnd() * 6.0 - 2.0);
            let mut d = Vec3::new(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5);
            if rnd() < 0.2 {
                d.y = 0.0; // axis-parallel rays
            }
            let r = RayPre::new(Ray::new(o, d));
            let limit = if rnd() < 0.5 {
                Real::INFINITY
            } else {
                rnd() * 20.0
            };
            let (got, mask) = node.entries_hit(&BoxRay::new(&r), limit);
            let plain = node.entries_scalar(&BoxRay::new(&r), limit);
            assert_eq!(got.map(f64::to_bits), plain.map(f64::to_bits));
            for (k, t) in got.iter().enumerate() {
                assert_eq!(mask >> k & 1 == 1, *t != Real::INFINITY, "child {k}");
            }
            for k in 0..3 {
                let want = boxes[k].1.hit(&r, 0.0, limit).map(|(t0, _)| t0);
                match want {
                    Some(t) => assert_eq!(got[k], t),
                    None => assert_eq!(got[k], Real::INFINITY),
                }
            }
            assert_eq!(got[3], Real::INFINITY, "the empty slot is never hit");
        }
    }
}
