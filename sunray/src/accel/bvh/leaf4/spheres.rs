//! Four spheres of a leaf tested at once ([`Sph4`]): the sphere test in AVX2 lanes, each lane
//! computing exactly what the scalar kernel ([`crate::geometry::kernels::k64::sphere`])
//! computes, with the same `f64` operations in the same order (glam's dot products add left
//! to right; `sqrt` and division are correctly rounded in both), so a lane's `t` is the scalar
//! test's to the bit.

use super::{Lanes, LANES};
use crate::geometry::{RayPre, Real, Vec3};

/// Four spheres: centres one array per axis, radii, and each lane's primitive (`u32::MAX`
/// for a lane past the leaf's end).
#[derive(Clone, Copy, Debug)]
#[repr(C, align(32))]
pub struct Sph4 {
    centre: [[Real; LANES]; 3],
    radius: [Real; LANES],
    prims: [u32; LANES],
    /// The lanes holding a sphere, a bit a lane.
    lanes: u32,
}

impl Sph4 {
    /// The group of up to four spheres (primitive, centre, radius), in lane order.
    pub fn of(spheres: &[(u32, Vec3, Real)]) -> Sph4 {
        let mut g = Sph4 {
            centre: [[0.0; LANES]; 3],
            radius: [0.0; LANES],
            prims: [u32::MAX; LANES],
            lanes: 0,
        };
        for (lane, (i, c, r)) in spheres.iter().enumerate().take(LANES) {
            g.prims[lane] = *i;
            g.radius[lane] = *r;
            for axis in 0..3 {
                g.centre[axis][lane] = c[axis];
            }
        }
        g.lanes = super::used_lanes(&g.prims);
        g
    }
}

impl Lanes for Sph4 {
    fn hits_scalar(&self, r: &RayPre, t_max: Real) -> ([Real; LANES], u32) {
        super::lane_by_lane(self.lanes(), |lane| {
            let c = self.centre.map(|axis| axis[lane]);
            let (c, radius) = (Vec3::from(c), self.radius[lane]);
            crate::geometry::sphere::intersect_sphere(&r.ray, c, radius, 0.0, t_max)
        })
    }

    #[inline(always)]
    fn prims(&self) -> &[u32; LANES] {
        &self.prims
    }

    /// Every lane holding a sphere (no ray is known to miss a sphere untested).
    #[inline(always)]
    fn live(&self, _: &RayPre) -> u32 {
        self.lanes
    }

    #[inline(always)]
    fn lanes(&self) -> u32 {
        self.lanes
    }

    #[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
    #[inline(always)]
    fn hits(&self, r: &RayPre, t_max: Real) -> ([Real; LANES], u32) {
        use std::arch::x86_64::*;
        let (o, d) = (r.ray.origin, r.ray.dir);
        // The same for every lane, computed as the scalar kernel does.
        let a = d.length_squared();
        let mut out = [0.0; LANES];
        let mask;
        // SAFETY: the build enables AVX2 (the cfg above); every load and store is an
        // unaligned one of a whole `[f64; 4]`.
        unsafe {
            let splat = _mm256_set1_pd;
            let (mul, add, sub) = (_mm256_mul_pd, _mm256_add_pd, _mm256_sub_pd);
            let oc = |axis: usize| sub(splat(o[axis]), _mm256_loadu_pd(self.centre[axis].as_ptr()));
            let (ox, oy, oz) = (oc(0), oc(1), oc(2));
            let (dx, dy, dz) = (splat(d.x), splat(d.y), splat(d.z));
            let dot = |x, y, z, u, v, w| add(add(mul(x, u), mul(y, v)), mul(z, w));
            let b = dot(ox, oy, oz, dx, dy, dz);
            let radius = _mm256_loadu_pd(self.radius.as_ptr());
            let rr = mul(radius, radius);
            let c = sub(dot(ox, oy, oz, ox, oy, oz), rr);
            let zero = _mm256_setzero_pd();
            let gt = |x, y| _mm256_cmp_pd::<_CMP_GT_OQ>(x, y);
            let lt = |x, y| _mm256_cmp_pd::<_CMP_LT_OQ>(x, y);
            // Outside and moving away (t_min is 0 here, so `t_min >= 0` holds).
            let away = _mm256_and_pd(gt(c, zero), gt(b, zero));
            let (va, q) = (splat(a), _mm256_div_pd(b, splat(a)));
            let (lx, ly, lz) = (
                sub(ox, mul(dx, q)),
                sub(oy, mul(dy, q)),
                sub(oz, mul(dz, q)),
            );
            let disc = mul(va, sub(rr, dot(lx, ly, lz, lx, ly, lz)));
            let no_roots = _mm256_or_pd(lt(disc, zero), _mm256_cmp_pd::<_CMP_EQ_OQ>(va, zero));
            // q = -(b + sqrt(disc).copysign(b))
            let sign = splat(-0.0);
            let root = _mm256_sqrt_pd(disc);
            let signed = _mm256_or_pd(_mm256_andnot_pd(sign, root), _mm256_and_pd(sign, b));
            let qq = _mm256_xor_pd(add(b, signed), sign);
            // q == 0 gives the double root 0, which is not in (0, t_max).
            let q_zero = _mm256_cmp_pd::<_CMP_EQ_OQ>(qq, zero);
            let (r0, r1) = (_mm256_div_pd(qq, va), _mm256_div_pd(c, qq));
            let ordered = _mm256_cmp_pd::<_CMP_LE_OQ>(r0, r1);
            let lo = _mm256_blendv_pd(r1, r0, ordered);
            let hi = _mm256_blendv_pd(r0, r1, ordered);
            let limit = splat(t_max);
            let inside = |t| _mm256_and_pd(gt(t, zero), lt(t, limit));
            let (lo_in, hi_in) = (inside(lo), inside(hi));
            let t = _mm256_blendv_pd(hi, lo, lo_in);
            let missed = _mm256_or_pd(_mm256_or_pd(away, no_roots), q_zero);
            let ok = _mm256_andnot_pd(missed, _mm256_or_pd(lo_in, hi_in));
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

    /// Every lane gives the scalar kernel's answer to the bit: rays from outside and inside,
    /// grazing ones, tiny and huge spheres, limits exactly at a hit.
    #[test]
    fn four_lanes_give_the_scalar_test_bit_for_bit() {
        let mut s = 23u64;
        let mut hits = 0;
        for round in 0..4000usize {
            let p = |s: &mut u64| Vec3::new(rand(s), rand(s), rand(s)) * 4.0 - 2.0;
            let used = 1 + round % LANES;
            let spheres: Vec<(u32, Vec3, Real)> = (0..used)
                .map(|k| {
                    let scale = [1e-3, 0.5, 1.0, 30.0][(round + k) % 4];
                    (k as u32, p(&mut s), scale * (0.1 + rand(&mut s)))
                })
                .collect();
            let g = Sph4::of(&spheres);
            let mut o = p(&mut s) * 3.0;
            if round.is_multiple_of(5) {
                o = spheres[0].1; // from a centre: inside
            }
            let aim = spheres[round % used].1 + p(&mut s) * spheres[round % used].2 * 0.6;
            let dir = if round.is_multiple_of(3) {
                (aim - o).normalize()
            } else {
                aim - o // not normalised, as a secondary ray's may be
            };
            let r = RayPre::new(Ray::new(o, dir));
            let scalar = |t_max| {
                spheres
                    .iter()
                    .map(|&(_, c, rad)| {
                        crate::geometry::sphere::intersect_sphere(&r.ray, c, rad, 0.0, t_max)
                    })
                    .collect::<Vec<_>>()
            };
            let mut t_max = Real::INFINITY;
            if round.is_multiple_of(7) {
                if let Some(t) = scalar(t_max).iter().flatten().next() {
                    t_max = *t;
                }
            }
            let want = scalar(t_max);
            super::super::assert_lanes_are(&g, &r, t_max, &want, round);
            hits += want.iter().flatten().count();
        }
        assert!(hits > 2000, "{hits}");
    }
}
