//! The renderer's hot path (Woop's watertight triangle test, the stable sphere test, the slab
//! box test) written once and instantiated in f32 ([`p32`], glam `Vec3`) and f64 ([`p64`],
//! `DVec3`), for [`super::precision`]'s comparison.

macro_rules! hot_path {
    ($name:ident, $R:ty, $V:ty) => {
        pub mod $name {
            pub type R = $R;
            pub type V = $V;

            /// Per-ray constants of the watertight test (Woop, Benthin and Wald 2013).
            pub struct Pre {
                pub o: V,
                pub d: V,
                pub inv: V,
                k: [usize; 3],
                s: [R; 3],
            }

            pub fn pre(o: V, d: V) -> Pre {
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
                Pre {
                    o,
                    d,
                    inv: V::ONE / d,
                    k: [kx, ky, kz],
                    s: [d[kx] / d[kz], d[ky] / d[kz], 1.0 / d[kz]],
                }
            }

            #[inline]
            pub fn triangle(r: &Pre, v: &[V; 3]) -> Option<R> {
                let [kx, ky, kz] = r.k;
                let [sx, sy, sz] = r.s;
                let (a, b, c) = (v[0] - r.o, v[1] - r.o, v[2] - r.o);
                let ax = a[kx] - sx * a[kz];
                let ay = a[ky] - sy * a[kz];
                let bx = b[kx] - sx * b[kz];
                let by = b[ky] - sy * b[kz];
                let cx = c[kx] - sx * c[kz];
                let cy = c[ky] - sy * c[kz];
                let u = cx * by - cy * bx;
                let vv = ax * cy - ay * cx;
                let w = bx * ay - by * ax;
                if (u < 0.0 || vv < 0.0 || w < 0.0) && (u > 0.0 || vv > 0.0 || w > 0.0) {
                    return None;
                }
                let det = u + vv + w;
                if det == 0.0 {
                    return None;
                }
                let t = (u * sz * a[kz] + vv * sz * b[kz] + w * sz * c[kz]) / det;
                (t > 0.0).then_some(t)
            }

            #[inline]
            pub fn sphere(o: V, d: V, centre: V, radius: R) -> Option<R> {
                let oc = o - centre;
                let a = d.length_squared();
                let b = oc.dot(d);
                let c = oc.length_squared() - radius * radius;
                let l = oc - d * (b / a);
                let disc = a * (radius * radius - l.length_squared());
                if disc < 0.0 {
                    return None;
                }
                let q = -(b + disc.sqrt().copysign(b));
                if q == 0.0 {
                    return None;
                }
                let (r0, r1) = (q / a, c / q);
                let (lo, hi) = if r0 <= r1 { (r0, r1) } else { (r1, r0) };
                if lo > 0.0 {
                    Some(lo)
                } else if hi > 0.0 {
                    Some(hi)
                } else {
                    None
                }
            }

            #[inline]
            pub fn slab(r: &Pre, lo: V, hi: V) -> bool {
                let t0 = (lo - r.o) * r.inv;
                let t1 = (hi - r.o) * r.inv;
                let near = t0.min(t1).max_element();
                let far = t0.max(t1).min_element();
                near <= far && far > 0.0
            }
        }
    };
}

hot_path!(p32, f32, glam::Vec3);
hot_path!(p64, f64, glam::DVec3);
