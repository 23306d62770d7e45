//! Four triangles of a leaf tested at once ([`Tri4`]): Woop's watertight test in AVX2 lanes,
//! each lane computing exactly what the scalar kernel ([`crate::geometry::kernels::k64::triangle`])
//! computes: the same `f64` operations in the same order (Rust and these intrinsics never
//! fuse a multiply and an add), so a lane's `t` is the scalar test's to the bit.

use super::{Lanes, LANES};
use crate::geometry::{RayPre, Real, Vec3};

/// Four triangles: `corners[vertex][axis][lane]`, and each lane's primitive (`u32::MAX` for a
/// lane past the leaf's end).
#[derive(Clone, Copy, Debug)]
#[repr(C, align(32))]
pub struct Tri4 {
    pub(super) corners: [[[Real; LANES]; 3]; 3],
    pub(super) prims: [u32; LANES],
    /// The lanes holding a triangle, a bit a lane.
    lanes: u32,
}

impl Tri4 {
    /// The group of up to four triangles (primitive, corners), in lane order.
    pub fn of(tris: &[(u32, [Vec3; 3])]) -> Tri4 {
        let mut g = Tri4 {
            corners: [[[0.0; LANES]; 3]; 3],
            prims: [u32::MAX; LANES],
            lanes: 0,
        };
        for (lane, (i, v)) in tris.iter().enumerate().take(LANES) {
            g.prims[lane] = *i;
            for (j, corner) in v.iter().enumerate() {
                for axis in 0..3 {
                    g.corners[j][axis][lane] = corner[axis];
                }
            }
        }
        g.lanes = super::used_lanes(&g.prims);
        g
    }
}

impl Lanes for Tri4 {
    fn hits_scalar(&self, r: &RayPre, t_max: Real) -> ([Real; LANES], u32) {
        super::lane_by_lane(self.lanes(), |lane| {
            let v = self.corners.map(|c| Vec3::from(c.map(|axis| axis[lane])));
            crate::geometry::triangle::intersect_triangle(r, &v, 0.0, t_max)
        })
    }

    #[inline(always)]
    fn prims(&self) -> &[u32; LANES] {
        &self.prims
    }

    /// The lanes holding a triangle that `r` is not known to miss ([`RayPre::skips`]: a ray
    /// leaving a flat face skips its triangles before anything is computed, the shear too).
    /// Every lane is checked without a branch (the empty ones are masked off after): with
    /// `&&` the compiler branched per lane and loaded the skipped range four times.
    #[inline(always)]
    fn live(&self, r: &RayPre) -> u32 {
        let mut skipped = 0;
        for (lane, p) in self.prims.iter().enumerate() {
            skipped |= u32::from(r.skips(*p)) << lane;
        }
        self.lanes & !skipped
    }

    #[inline(always)]
    fn lanes(&self) -> u32 {
        self.lanes
    }

    #[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
    #[inline(always)]
    fn hits(&self, r: &RayPre, t_max: Real) -> ([Real; LANES], u32) {
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
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Ray;
    use crate::sampler::unit_f64 as rand;

    fn group(tris: &[[Vec3; 3]]) -> Tri4 {
        let lanes: Vec<_> = tris
            .iter()
            .enumerate()
            .map(|(k, v)| (k as u32, *v))
            .collect();
        Tri4::of(&lanes)
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
            super::super::assert_lanes_are(&g, &r, t_max, &want, round);
            hits += want.iter().flatten().count();
        }
        assert!(hits > 1000, "{hits}");
    }
}
