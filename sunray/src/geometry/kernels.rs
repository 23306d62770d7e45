//! The intersection kernels of the hot path, written once by a macro and instantiated twice:
//! [`k64`] (`f64`, glam `DVec3`) is what the renderer runs ([`super::triangle`],
//! [`super::sphere`], [`super::aabb`] and [`super::RayPre`] call it), and [`k32`] (`f32`,
//! `Vec3`) is the same code in single precision, for `sunray bench precision`'s comparison.
//! (glam has no scalar-generic vector, hence a macro rather than a generic function.)

macro_rules! kernels {
    ($name:ident, $R:ty, $V:ty, $huge:expr) => {
        /// The hot path's kernels in this precision.
        pub mod $name {
            /// The scalar type.
            pub type R = $R;
            /// The vector type.
            pub type V = $V;

            /// Woop's shear of a direction `d`, and its inverse for the slab test
            /// ([`shear`] and [`inverse`]: the renderer computes the shear only for rays that
            /// meet a triangle).
            #[inline]
            pub fn shear_and_inverse(d: V) -> ([usize; 3], [R; 3], V) {
                let (k, s) = shear(d);
                (k, s, inverse(d))
            }

            /// `1 / d` per component with an infinite quotient replaced by a huge finite one
            /// of the same sign (so the slab test never computes `0 * inf`), in one vector
            /// division. Every ray pays this.
            #[inline]
            pub fn inverse(d: V) -> V {
                let finite = |i: R| {
                    if i.is_finite() {
                        i
                    } else {
                        ($huge as R).copysign(i)
                    }
                };
                let q = V::ONE / d;
                V::new(finite(q.x), finite(q.y), finite(q.z))
            }

            /// Woop's shear of a direction `d`: the axis along which `d` is largest goes last
            /// (`k = [kx, ky, kz]`, swapped to keep the winding when `d[kz] < 0`), and
            /// `s = [d[kx] / d[kz], d[ky] / d[kz], 1 / d[kz]]`.
            ///
            /// The components are read from an array by indices the compiler can see are in
            /// range (glam's `d[k]` is a `match` with a panic arm), and each quotient is the
            /// same one division as `V / R` computes it.
            #[inline]
            pub fn shear(d: V) -> ([usize; 3], [R; 3]) {
                let a = d.abs();
                let kz = if a.x >= a.y && a.x >= a.z {
                    0
                } else if a.y >= a.z {
                    1
                } else {
                    2
                };
                let v = d.to_array();
                let [mut kx, mut ky] = [[1, 2], [2, 0], [0, 1]][kz];
                let dz = v[kz];
                if dz < 0.0 {
                    std::mem::swap(&mut kx, &mut ky);
                }
                ([kx, ky, kz], [v[kx] / dz, v[ky] / dz, 1.0 / dz])
            }

            /// Watertight ray / triangle (Woop, Benthin and Wald, JCGT 2013): the nearest `t`
            /// in `(t_min, t_max)` where the ray from `o` sheared by `(k, s)` ([`shear_and_inverse`])
            /// crosses triangle `v`.
            #[inline(always)]
            pub fn triangle(
                o: V,
                k: [usize; 3],
                s: [R; 3],
                v: &[V; 3],
                t_min: R,
                t_max: R,
            ) -> Option<R> {
                // The axes as array indices the compiler can see are in range (no bounds
                // checks).
                let (kx, ky, kz) = (k[0].min(2), k[1].min(2), k[2].min(2));
                let [sx, sy, sz] = s;
                let a = (v[0] - o).to_array();
                let b = (v[1] - o).to_array();
                let c = (v[2] - o).to_array();
                let ax = a[kx] - sx * a[kz];
                let ay = a[ky] - sy * a[kz];
                let bx = b[kx] - sx * b[kz];
                let by = b[ky] - sy * b[kz];
                let cx = c[kx] - sx * c[kz];
                let cy = c[ky] - sy * c[kz];
                let u = cx * by - cy * bx;
                let vv = ax * cy - ay * cx;
                let w = bx * ay - by * ax;
                // Non-short-circuit operators: six compares, one branch.
                let negative = (u < 0.0) | (vv < 0.0) | (w < 0.0);
                let positive = (u > 0.0) | (vv > 0.0) | (w > 0.0);
                if negative & positive {
                    return None;
                }
                let det = u + vv + w;
                if det == 0.0 {
                    return None;
                }
                let az = sz * a[kz];
                let bz = sz * b[kz];
                let cz = sz * c[kz];
                let t = (u * az + vv * bz + w * cz) / det;
                if t > t_min && t < t_max {
                    Some(t)
                } else {
                    None
                }
            }

            /// Roots of `a t^2 + 2 b t + c = 0` in increasing order, computed without
            /// cancellation (`q = -(b + sign(b) sqrt(b^2 - ac))`, roots `q / a` and `c / q`).
            /// `disc` is `b^2 - ac`, passed in so callers can compute it in a
            /// better-conditioned way.
            #[inline]
            pub fn stable_roots(a: R, b: R, c: R, disc: R) -> Option<(R, R)> {
                if disc < 0.0 || a == 0.0 {
                    return None;
                }
                let q = -(b + disc.sqrt().copysign(b));
                if q == 0.0 {
                    // b == 0 and disc == 0: a double root at 0.
                    return Some((0.0, 0.0));
                }
                let (r0, r1) = (q / a, c / q);
                Some(if r0 <= r1 { (r0, r1) } else { (r1, r0) })
            }

            /// The smallest root in `(t_min, t_max)`.
            #[inline]
            pub fn first_root(roots: (R, R), t_min: R, t_max: R) -> Option<R> {
                let (r0, r1) = roots;
                if r0 > t_min && r0 < t_max {
                    Some(r0)
                } else if r1 > t_min && r1 < t_max {
                    Some(r1)
                } else {
                    None
                }
            }

            /// Ray `o + t d` / sphere: the nearest `t` in `(t_min, t_max)`.
            #[inline(always)]
            pub fn sphere(o: V, d: V, centre: V, radius: R, t_min: R, t_max: R) -> Option<R> {
                let oc = o - centre;
                let a = d.length_squared();
                let b = oc.dot(d);
                let c = oc.length_squared() - radius * radius;
                if c > 0.0 && b > 0.0 && t_min >= 0.0 {
                    // Outside and moving away: both roots are negative (their product c/a is
                    // positive, their sum -2b/a negative), exactly as the full computation
                    // below would find.
                    return None;
                }
                // b^2 - ac rewritten as a (r^2 - |oc - (b/a) d|^2) (Hearn and Baker), which
                // keeps its precision for rays that pass far from the centre.
                let l = oc - d * (b / a);
                let disc = a * (radius * radius - l.length_squared());
                first_root(stable_roots(a, b, c, disc)?, t_min, t_max)
            }

            /// The slab test: where the ray from `o` with inverse direction `inv`
            /// ([`shear_and_inverse`]) is inside the box `lo..hi`, clipped to `[t_min, t_max]`.
            #[inline]
            pub fn slab(lo: V, hi: V, o: V, inv: V, t_min: R, t_max: R) -> Option<(R, R)> {
                let a = (lo - o) * inv;
                let b = (hi - o) * inv;
                let t0 = a.min(b).max_element().max(t_min);
                let t1 = a.max(b).min_element().min(t_max);
                if t0 <= t1 {
                    Some((t0, t1))
                } else {
                    None
                }
            }
        }
    };
}

kernels!(k64, f64, glam::DVec3, 1e300_f64);
kernels!(k32, f32, glam::Vec3, 1e30_f32);

#[cfg(test)]
mod tests {
    use glam::DVec3;

    /// The shear and inverse as first written, six divisions.
    fn by_hand(d: DVec3) -> ([usize; 3], [f64; 3], DVec3) {
        let a = d.abs();
        let kz = if a.x >= a.y && a.x >= a.z {
            0
        } else if a.y >= a.z {
            1
        } else {
            2
        };
        let mut kx = (kz + 1) % 3;
        let mut ky = (kx + 1) % 3;
        if d[kz] < 0.0 {
            std::mem::swap(&mut kx, &mut ky);
        }
        let safe = |x: f64| {
            let i = 1.0 / x;
            if i.is_finite() {
                i
            } else {
                1e300_f64.copysign(i)
            }
        };
        (
            [kx, ky, kz],
            [d[kx] / d[kz], d[ky] / d[kz], 1.0 / d[kz]],
            DVec3::new(safe(d.x), safe(d.y), safe(d.z)),
        )
    }

    #[test]
    fn shear_and_inverse_is_bit_for_bit_the_six_divisions() {
        let mut s = 0x9E37_79B9_7F4A_7C15_u64;
        let mut next = || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        };
        let mut dirs: Vec<DVec3> = (0..10_000)
            .map(|_| DVec3::new(next(), next(), next()).normalize())
            .collect();
        dirs.extend([
            DVec3::X,
            DVec3::NEG_Y,
            DVec3::Z,
            DVec3::new(0.0, -0.0, 1.0),
            DVec3::new(1e-300, 1.0, 0.0).normalize(),
            DVec3::new(-0.6, 0.8, 0.0),
        ]);
        for d in dirs {
            let (k, s, inv) = super::k64::shear_and_inverse(d);
            let (k0, s0, inv0) = by_hand(d);
            assert_eq!(k, k0, "{d}");
            let bits = |v: [f64; 3]| v.map(f64::to_bits);
            assert_eq!(bits(s), bits(s0), "{d}");
            assert_eq!(bits(inv.to_array()), bits(inv0.to_array()), "{d}");
        }
    }
}
