//! The primitives of the BVH's leaves, stored in leaf order. A static triangle or sphere keeps
//! a copy of its geometry here, so a leaf is tested from one contiguous block of memory
//! instead of through the scene's primitive list; other primitives are tested through it.
//! Either way `t` comes from the same function with the same inputs, so the hits are exactly
//! those of the other accelerators.

use crate::geometry::sphere::intersect_sphere;
use crate::geometry::triangle::intersect_triangle;
use crate::geometry::{Primitive, PrimitiveKind, RayPre, Real, Vec3};

/// The BVH's leaf primitives in leaf order, with inline copies of static triangles and spheres.
#[derive(Clone, Debug)]
pub struct LeafItems {
    prims: Vec<u32>,
    shapes: Vec<Shape>,
}

/// The geometry of one item.
#[derive(Clone, Debug)]
enum Shape {
    Triangle([Vec3; 3]),
    Sphere {
        centre: Vec3,
        radius: Real,
    },
    /// Tested through the primitive list (ellipsoids, quadrics, anything moving).
    Other,
}

impl LeafItems {
    /// The items of `order` (primitive indices in leaf order).
    pub fn new(prims: &[Primitive], order: &[u32]) -> LeafItems {
        let shapes = order
            .iter()
            .map(|&i| {
                let p = &prims[i as usize];
                match &p.kind {
                    _ if p.motion != Vec3::ZERO => Shape::Other,
                    PrimitiveKind::Triangle { v, .. } => Shape::Triangle(*v),
                    PrimitiveKind::Sphere { centre, radius } => Shape::Sphere {
                        centre: *centre,
                        radius: *radius,
                    },
                    _ => Shape::Other,
                }
            })
            .collect();
        LeafItems {
            prims: order.to_vec(),
            shapes,
        }
    }

    /// Primitive index of item `k`.
    #[inline(always)]
    pub fn prim(&self, k: usize) -> u32 {
        self.prims[k]
    }

    /// Item `k`'s nearest `t` in `(0, t_max)`.
    #[inline(always)]
    pub fn intersect(
        &self,
        prims: &[Primitive],
        k: usize,
        r: &RayPre,
        t_max: Real,
    ) -> Option<Real> {
        match &self.shapes[k] {
            Shape::Triangle(v) => intersect_triangle(r, v, 0.0, t_max),
            Shape::Sphere { centre, radius } => {
                intersect_sphere(&r.ray, *centre, *radius, 0.0, t_max)
            }
            Shape::Other => prims[self.prims[k] as usize].intersect(r, 0.0, t_max),
        }
    }
}
