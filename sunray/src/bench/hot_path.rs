//! The renderer's hot path as `sunray bench precision` calls it: thin adapters over the
//! renderer's own kernels ([`crate::geometry::kernels`]: Woop's watertight triangle test, the
//! stable sphere test, the slab test), in f32 ([`p32`]) and f64 ([`p64`], exactly what the
//! renderer runs), for rays from `o` along `d` with `t > 0`.

macro_rules! hot_path {
    ($name:ident, $k:ident) => {
        /// The hot path in this precision.
        pub mod $name {
            use crate::geometry::kernels::$k;
            pub use $k::{R, V};

            /// Per-ray constants of the watertight and slab tests.
            pub struct Pre {
                /// Origin.
                pub o: V,
                /// `1 / d`, made finite.
                pub inv: V,
                k: [usize; 3],
                s: [R; 3],
            }

            /// The per-ray constants of a ray from `o` along `d`.
            pub fn pre(o: V, d: V) -> Pre {
                let (k, s, inv) = $k::shear_and_inverse(d);
                Pre { o, inv, k, s }
            }

            /// The nearest `t > 0` where the ray crosses triangle `v`.
            #[inline]
            pub fn triangle(r: &Pre, v: &[V; 3]) -> Option<R> {
                $k::triangle(r.o, r.k, r.s, v, 0.0, R::INFINITY)
            }

            /// The nearest `t > 0` where the ray `o + t d` meets the sphere.
            #[inline]
            pub fn sphere(o: V, d: V, centre: V, radius: R) -> Option<R> {
                $k::sphere(o, d, centre, radius, 0.0, R::INFINITY)
            }

            /// Whether the ray meets the box `lo..hi` at some `t >= 0`.
            #[inline]
            pub fn slab(r: &Pre, lo: V, hi: V) -> bool {
                $k::slab(lo, hi, r.o, r.inv, 0.0, R::INFINITY).is_some()
            }
        }
    };
}

hot_path!(p32, k32);
hot_path!(p64, k64);
