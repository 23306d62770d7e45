//! Closest hits of a packet of up to [`PACKET`] rays from one origin (the eye rays of
//! neighbouring pixels through a pinhole), which walk the tree together. At each node one
//! interval test stands for the whole packet: with a shared origin, and each axis's inverse
//! directions of one sign and between a least and a greatest, a box's entry and exit for any
//! ray of the packet lie between bounds computed from those two alone ([`Frustum`]). The
//! bounds are rounded as the rays' own `t`s are (a correctly rounded product is monotone in
//! each factor), so the packet enters every box any of its rays enters: each ray meets at
//! least the leaves it would meet alone, tests their primitives itself, and keeps the same
//! hit (the smallest `t`, ties to the lower primitive index, which no order of visits and
//! no extra leaf changes). A packet whose rays do not share an origin and signs walks ray by
//! ray.

use super::wide::{BoxRay, Child, Node, WIDTH};
use super::{Bvh, STACK};
use crate::accel::Hit;
use crate::geometry::{Primitives, RayPre, Real};
use crate::stats::Counters;
use arrayvec::ArrayVec;

/// Rays in a packet.
pub const PACKET: usize = 4;

/// A child waiting on the packet's stack: where the nearest ray may enter it, and the rays
/// that were live when it was pushed.
#[derive(Clone, Copy)]
struct PendingGroup {
    t: Real,
    child: Child,
    rays: u32,
}

/// The bits set in `m`, lowest first.
fn bits(mut m: u32) -> impl Iterator<Item = usize> {
    std::iter::from_fn(move || {
        (m != 0).then(|| {
            let k = m.trailing_zeros() as usize;
            m &= m - 1;
            k
        })
    })
}

/// A packet of rays from one origin as the box tests see it: per axis the least and the
/// greatest inverse direction, all of one sign, and where that sign's near and far rows lie
/// in a node ([`BoxRay::rows`]).
#[derive(Clone, Copy, Debug)]
pub struct Frustum {
    origin: [Real; 3],
    lo: [Real; 3],
    hi: [Real; 3],
    rows: &'static [usize; 6],
}

impl Frustum {
    /// The frustum of the rays of `rays` in `live`, if they share their origin to the bit and
    /// their directions' signs.
    pub fn of(rays: &[RayPre], live: u32) -> Option<Frustum> {
        let mut each = bits(live).filter_map(|k| rays.get(k));
        let first = each.next()?;
        let rows = BoxRay::new(first).rows();
        let origin = first.ray.origin.to_array();
        let (mut lo, mut hi) = (first.inv_dir.to_array(), first.inv_dir.to_array());
        for r in each {
            let same_origin =
                r.ray.origin.to_array().map(Real::to_bits) == origin.map(Real::to_bits);
            if !same_origin || !std::ptr::eq(BoxRay::new(r).rows(), rows) {
                return None;
            }
            for (axis, inv) in r.inv_dir.to_array().into_iter().enumerate() {
                lo[axis] = lo[axis].min(inv);
                hi[axis] = hi[axis].max(inv);
            }
        }
        Some(Frustum {
            origin,
            lo,
            hi,
            rows,
        })
    }

    /// For each child of `node`: a lower bound of any ray's entry into its box within
    /// `[0, limit]`, or +inf where no ray can enter it; and the children some ray may enter,
    /// as bits. Written with AVX2 intrinsics where the build has AVX2, which compute what
    /// [`Frustum::entries_scalar`] does.
    #[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
    #[inline(always)]
    pub fn entries(&self, node: &Node, limit: Real) -> ([Real; WIDTH], u32) {
        use std::arch::x86_64::{
            _mm256_blendv_pd, _mm256_cmp_pd, _mm256_loadu_pd, _mm256_max_pd, _mm256_min_pd,
            _mm256_movemask_pd, _mm256_mul_pd, _mm256_set1_pd, _mm256_setzero_pd, _mm256_storeu_pd,
            _mm256_sub_pd, _CMP_LE_OQ,
        };
        let limit = limit.min(Real::MAX);
        let mut out = [0.0; WIDTH];
        let planes = node.planes.as_ptr().cast::<Real>();
        // SAFETY: the build enables AVX2 (the cfg above); every load and store is an
        // unaligned one of a whole `[f64; 4]` (a row of `planes`, by ROWS's offsets).
        let mask = unsafe {
            let mut t0 = _mm256_setzero_pd();
            let mut t1 = _mm256_set1_pd(limit);
            for axis in 0..3 {
                let near = _mm256_loadu_pd(planes.add(self.rows[axis]));
                let far = _mm256_loadu_pd(planes.add(self.rows[axis + 3]));
                let o = _mm256_set1_pd(self.origin[axis]);
                let (lo, hi) = (_mm256_set1_pd(self.lo[axis]), _mm256_set1_pd(self.hi[axis]));
                let dn = _mm256_sub_pd(near, o);
                let df = _mm256_sub_pd(far, o);
                let n = _mm256_min_pd(_mm256_mul_pd(dn, lo), _mm256_mul_pd(dn, hi));
                let f = _mm256_max_pd(_mm256_mul_pd(df, lo), _mm256_mul_pd(df, hi));
                t0 = _mm256_max_pd(n, t0);
                t1 = _mm256_min_pd(f, t1);
            }
            let hit = _mm256_cmp_pd::<_CMP_LE_OQ>(t0, t1);
            let t = _mm256_blendv_pd(_mm256_set1_pd(Real::INFINITY), t0, hit);
            _mm256_storeu_pd(out.as_mut_ptr(), t);
            _mm256_movemask_pd(hit) as u32
        };
        (out, mask)
    }

    /// [`Frustum::entries`] where the build has no AVX2.
    #[cfg(not(all(target_arch = "x86_64", target_feature = "avx2")))]
    #[inline(always)]
    pub fn entries(&self, node: &Node, limit: Real) -> ([Real; WIDTH], u32) {
        let t = self.entries_scalar(node, limit);
        let mask = (0..WIDTH).fold(0, |m, k| m | u32::from(t[k] != Real::INFINITY) << k);
        (t, mask)
    }

    /// [`Frustum::entries`]'s bounds as a plain loop: per axis, the near plane's `t` at the
    /// lesser of the two products and the far plane's at the greater.
    pub fn entries_scalar(&self, node: &Node, limit: Real) -> [Real; WIDTH] {
        let limit = limit.min(Real::MAX);
        let mut t0 = [0.0; WIDTH];
        let mut t1 = [limit; WIDTH];
        let rows = node.planes.as_flattened();
        for axis in 0..3 {
            let near = &rows[self.rows[axis] / WIDTH];
            let far = &rows[self.rows[axis + 3] / WIDTH];
            let (o, lo, hi) = (self.origin[axis], self.lo[axis], self.hi[axis]);
            for k in 0..WIDTH {
                let (dn, df) = (near[k] - o, far[k] - o);
                let (a, b) = (dn * lo, dn * hi);
                let (c, d) = (df * lo, df * hi);
                let n = if a < b { a } else { b };
                let f = if c > d { c } else { d };
                t0[k] = if n > t0[k] { n } else { t0[k] };
                t1[k] = if f < t1[k] { f } else { t1[k] };
            }
        }
        std::array::from_fn(|k| {
            if t0[k] <= t1[k] {
                t0[k]
            } else {
                Real::INFINITY
            }
        })
    }
}

impl Bvh {
    /// For each ray `k` of `rays` whose bit is set in `live`: its closest hit before `t_max`,
    /// improving on `best[k]`, as [`Bvh::closest`] finds it; uses AVX2 when the CPU has it.
    pub fn closest_packet(
        &self,
        prims: &Primitives,
        rays: &[RayPre],
        live: u32,
        t_max: Real,
        best: &mut [Option<Hit>; PACKET],
        c: &mut Counters,
    ) {
        let live = live & ((1 << rays.len().min(PACKET)) - 1);
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU has AVX2, the one requirement of `closest_packet_avx2`.
            return unsafe { self.closest_packet_avx2(prims, rays, live, t_max, best, c) };
        }
        self.closest_packet_impl(prims, rays, live, t_max, best, c)
    }

    /// The same walk compiled for AVX2.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn closest_packet_avx2(
        &self,
        prims: &Primitives,
        rays: &[RayPre],
        live: u32,
        t_max: Real,
        best: &mut [Option<Hit>; PACKET],
        c: &mut Counters,
    ) {
        self.closest_packet_impl(prims, rays, live, t_max, best, c)
    }

    #[inline(always)]
    fn closest_packet_impl(
        &self,
        prims: &Primitives,
        rays: &[RayPre],
        mut live: u32,
        t_max: Real,
        best: &mut [Option<Hit>; PACKET],
        c: &mut Counters,
    ) {
        if self.nodes.is_empty() || live == 0 {
            return;
        }
        let Some(frustum) = Frustum::of(rays, live) else {
            for k in bits(live) {
                best[k] = self.closest_impl(prims, &rays[k], t_max, best[k], c);
            }
            return;
        };
        // Each ray's limit (its best hit's `t`, or `t_max`), and the farthest of the live
        // rays', which bounds the packet's box tests; both change only at a leaf or a pop.
        let mut lim: [Real; PACKET] = std::array::from_fn(|k| best[k].map_or(t_max, |b| b.t));
        let farthest_of =
            |lim: &[Real; PACKET], live: u32| bits(live).fold(0.0, |m: Real, k| m.max(lim[k]));
        let mut farthest = farthest_of(&lim, live);
        let mut stack = ArrayVec::<PendingGroup, STACK>::new();
        let mut child = Child { index: 0, count: 0 };
        loop {
            if child.is_leaf() {
                for k in bits(live) {
                    best[k] = self.closest_in_leaf(prims, child, &rays[k], t_max, best[k], c);
                    lim[k] = best[k].map_or(t_max, |b| b.t);
                }
            } else {
                c.voxels += u64::from(live.count_ones());
                let node = &self.nodes[child.index as usize];
                let (t, mut hits) = frustum.entries(node, farthest);
                // As the single walk: the nearest child next, the others on the stack,
                // farthest deepest, taken in slot order from their bits.
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
                    let entry = PendingGroup {
                        t: t[far],
                        child: node.children[far],
                        rays: live,
                    };
                    if stack.try_push(entry).is_err() {
                        for k in bits(live) {
                            best[k] = self.closest_subtree(
                                prims,
                                entry.child,
                                &rays[k],
                                t_max,
                                best[k],
                                c,
                            );
                            lim[k] = best[k].map_or(t_max, |b| b.t);
                        }
                        farthest = farthest_of(&lim, live);
                        continue;
                    }
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
            loop {
                let Some(p) = stack.pop() else { return };
                // The rays whose best hit so far is not before the box's nearest entry.
                live = p.rays & not_before(p.t, &lim);
                if live != 0 {
                    child = p.child;
                    farthest = farthest_of(&lim, live);
                    break;
                }
            }
        }
    }
}

/// The rays (as bits) whose limit is not before `t`.
#[inline(always)]
fn not_before(t: Real, lim: &[Real; PACKET]) -> u32 {
    (0..PACKET).fold(0, |m, k| m | u32::from(t <= lim[k]) << k)
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

    /// Packets of neighbouring rays, of rays in every direction, of fewer than four rays
    /// and with rays left out: each ray's hit is the one the single walk finds.
    #[test]
    fn a_packet_finds_each_rays_own_closest_hit() {
        let mut s = 3u64;
        let mut prims = crate::geometry::Primitives::from_list(
            (0..400)
                .map(|i| {
                    let c = Vec3::new(rand(&mut s), rand(&mut s), rand(&mut s)) * 20.0 - 10.0;
                    sphere(c, 0.2 + rand(&mut s), i)
                })
                .collect(),
        );
        let bvh = Bvh::build(&mut prims);
        let mut c = Counters::default();
        let (mut hits, mut rays_tried) = (0, 0);
        for round in 0..600 {
            let o = Vec3::new(rand(&mut s), rand(&mut s), rand(&mut s)) * 30.0 - 15.0;
            let d = Vec3::new(rand(&mut s), rand(&mut s), rand(&mut s)) - 0.5;
            // Neighbours (a small spread) half the time, unrelated directions otherwise.
            let spread = if round % 2 == 0 { 0.02 } else { 2.0 };
            let n = 1 + round % PACKET;
            let rays: Vec<RayPre> = (0..n)
                .map(|_| {
                    let e = Vec3::new(rand(&mut s), rand(&mut s), rand(&mut s)) - 0.5;
                    RayPre::new(Ray::new(o, d + e * spread))
                })
                .collect();
            let live = if round % 5 == 0 { 0b1011 } else { 0b1111 };
            let mut got = [None; PACKET];
            bvh.closest_packet(&prims, &rays, live, Real::INFINITY, &mut got, &mut c);
            for (k, r) in rays.iter().enumerate() {
                let want = if live >> k & 1 == 1 {
                    rays_tried += 1;
                    bvh.closest(&prims, r, Real::INFINITY, None, &mut c)
                } else {
                    None
                };
                hits += usize::from(want.is_some());
                assert_eq!(got[k], want, "round {round}, ray {k}");
            }
        }
        assert!(
            hits > rays_tried / 10 && hits < rays_tried,
            "{hits} of {rays_tried}"
        );
    }

    /// The frustum's entry into a box is never after any of its rays' own, its boxes hit
    /// include every box a ray hits, and the vector and plain versions agree to the bit:
    /// on rays from one point through neighbouring pixels, and on axis-parallel ones.
    #[test]
    fn a_frustum_enters_every_box_its_rays_enter() {
        let mut s = 17u64;
        let (mut ray_hits, mut frustum_only) = (0, 0);
        for round in 0..3000 {
            let mut node = super::super::wide::collapse(&super::super::binary::BinaryBvh::build(
                (0..4u32).map(|i| {
                    let c = Vec3::new(rand(&mut s), rand(&mut s), rand(&mut s)) * 8.0 - 4.0;
                    let h = Vec3::new(rand(&mut s), rand(&mut s), rand(&mut s)) + 0.05;
                    (i, crate::geometry::Aabb::new(c - h, c + h), 1.0)
                }),
            ))[0];
            if round % 7 == 0 {
                node.children[3] = Child { index: 0, count: 0 };
                for m in 0..2 {
                    for axis in 0..3 {
                        node.planes[m][axis][3] = Real::INFINITY;
                    }
                }
            }
            let o = Vec3::new(rand(&mut s), rand(&mut s), rand(&mut s)) * 16.0 - 8.0;
            let d = Vec3::new(rand(&mut s), rand(&mut s), rand(&mut s)) - 0.5 - o * 0.1;
            let rays: Vec<RayPre> = (0..PACKET)
                .map(|k| {
                    let mut e = d + Vec3::new(k as Real, (k % 2) as Real, 0.0) * 0.003;
                    if round % 5 == 0 {
                        e.z = 0.0; // axis-parallel in z: the huge inverse
                    }
                    RayPre::new(Ray::new(o, e))
                })
                .collect();
            let Some(f) = Frustum::of(&rays, 0b1111) else {
                continue;
            };
            let limit = if round % 2 == 0 {
                Real::INFINITY
            } else {
                rand(&mut s) * 20.0
            };
            let (t, mask) = f.entries(&node, limit);
            assert_eq!(
                t.map(f64::to_bits),
                f.entries_scalar(&node, limit).map(f64::to_bits)
            );
            for r in &rays {
                let (tr, hits) = node.entries_hit(&BoxRay::new(r), limit);
                for j in 0..WIDTH {
                    if hits >> j & 1 == 1 {
                        ray_hits += 1;
                        assert!(
                            mask >> j & 1 == 1 && t[j] <= tr[j],
                            "round {round}, box {j}"
                        );
                    }
                }
            }
            frustum_only += (mask.count_ones() as usize) * PACKET;
        }
        assert!(ray_hits > 1000, "{ray_hits}");
        assert!(frustum_only >= ray_hits);
    }

    /// Rays that do not share their origin, or the signs of their directions, make no
    /// frustum (the packet then walks ray by ray).
    #[test]
    fn only_rays_from_one_point_with_one_sign_make_a_frustum() {
        let r = |o: Vec3, d: Vec3| RayPre::new(Ray::new(o, d));
        let (o, d) = (Vec3::new(1.0, 2.0, 3.0), Vec3::new(0.3, -0.2, 1.0));
        assert!(Frustum::of(&[r(o, d), r(o, d * 1.1)], 0b11).is_some());
        assert!(Frustum::of(&[r(o, d), r(o + Vec3::X * 1e-12, d)], 0b11).is_none());
        assert!(Frustum::of(&[r(o, d), r(o, Vec3::new(-0.3, -0.2, 1.0))], 0b11).is_none());
        // A ray left out does not count.
        assert!(Frustum::of(&[r(o, d), r(o + Vec3::X, d)], 0b01).is_some());
        assert!(Frustum::of(&[r(o, d)], 0).is_none());
    }

    /// A packet's walk improves on the hits it is given, and of two spheres met at the same
    /// `t` keeps the one the single walk keeps (the lower index).
    #[test]
    fn a_packet_keeps_given_hits_and_ties() {
        let mut prims = crate::geometry::Primitives::from_list(vec![
            sphere(Vec3::new(0.0, 0.0, 5.0), 1.0, 0),
            sphere(Vec3::new(0.0, 0.0, 5.0), 1.0, 1),
            sphere(Vec3::new(3.0, 0.0, 5.0), 1.0, 2),
        ]);
        let bvh = Bvh::build(&mut prims);
        let mut c = Counters::default();
        let ray = |x: Real| RayPre::new(Ray::new(Vec3::new(x, 0.0, 0.0), Vec3::Z));
        let rays = [ray(0.0), ray(3.0), ray(0.0), ray(9.0)];
        let given = Some(Hit { t: 1.5, prim: 7 });
        let mut got = [None, None, given, None];
        bvh.closest_packet(&prims, &rays, 0b1111, Real::INFINITY, &mut got, &mut c);
        let mut single = |r: &RayPre| bvh.closest(&prims, r, Real::INFINITY, None, &mut c);
        let want = [single(&rays[0]), single(&rays[1]), given, None];
        assert_eq!(got, want);
        assert_eq!(
            got.map(|h| h.map(|h| h.t)),
            [Some(4.0), Some(4.0), Some(1.5), None]
        );
    }
}
