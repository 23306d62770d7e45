//! A primitive as a plain value: the shape of anything the compact tables of
//! [`super::primitives`] do not hold (ellipsoids, quadrics, moving shapes), and the form
//! tests and queries off the hot path use.

use super::quadric::{intersect_quadric, quadric_bounds, quadric_normal};
use super::sphere::{ellipsoid_normal, intersect_ellipsoid, intersect_sphere};
use super::triangle::intersect_triangle;
use super::{Aabb, RayPre, Real, Vec3};
use glam::DAffine3;
use yari::model::Quadric;

/// The shape of a primitive, in world coordinates.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub enum PrimitiveKind {
    /// A sphere given by centre and radius.
    Sphere {
        /// Centre in world units.
        centre: Vec3,
        /// Radius in world units, > 0.
        radius: Real,
    },
    /// The unit sphere under an affine map: intersected in the unit sphere's space.
    Ellipsoid {
        /// World to the unit sphere's space (the inverse of the object's transform).
        to_local: DAffine3,
    },
    /// One triangle of a polygon; `normal` is the polygon's unit plane normal. `solid`: the
    /// polygon is a face of a closed transparent mesh ([`super::solid`]), and `normal`
    /// points out of the volume.
    Triangle {
        /// The corners in world coordinates, in the polygon's winding order.
        v: [Vec3; 3],
        /// The polygon's unit plane normal.
        normal: Vec3,
        /// True for a face of a closed transparent mesh (`normal` points out of the volume).
        solid: bool,
    },
    /// A quadric surface in the model's form: ten coefficients and clipping half-spaces.
    Quadric(Quadric),
}

/// One intersectable piece of the scene: a shape with its object, surface and motion.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct Primitive {
    /// Its shape.
    pub kind: PrimitiveKind,
    /// Index of the model object it came from.
    pub object: u32,
    /// Index into the world's surfaces (the Hall attributes it is shaded with).
    pub surface: u32,
    /// Displacement over the shutter interval (zero when static).
    pub motion: Vec3,
}

/// A primitive that could not be built, for a warning.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Dropped {
    /// Index of the model object that was dropped.
    pub object: usize,
    /// Why, in words, e.g. "polygon with zero area".
    pub reason: String,
}

impl Primitive {
    /// World-space bounds over the whole shutter interval, or None if unbounded.
    pub fn bounds(&self) -> Option<Aabb> {
        let b = match &self.kind {
            PrimitiveKind::Sphere { centre, radius } => Aabb::new(
                *centre - Vec3::splat(*radius),
                *centre + Vec3::splat(*radius),
            ),
            PrimitiveKind::Ellipsoid { to_local } => {
                let to_world = to_local.inverse();
                let m = to_world.matrix3;
                // Half extent along axis k is the length of row k of the linear map.
                let half = Vec3::new(m.row(0).length(), m.row(1).length(), m.row(2).length());
                Aabb::new(to_world.translation - half, to_world.translation + half)
            }
            PrimitiveKind::Triangle { v, .. } => Aabb::from_points(v),
            PrimitiveKind::Quadric(q) => quadric_bounds(q)?,
        };
        let b = if self.motion == Vec3::ZERO {
            b
        } else {
            b.union(Aabb::new(b.min + self.motion, b.max + self.motion))
        };
        Some(b.padded())
    }

    /// Whether the primitive may touch box `b` (conservative: true when unsure). Exact for
    /// static triangles and spheres, by bounds for the rest.
    pub fn overlaps_box(&self, b: &Aabb) -> bool {
        self.overlaps_box_with(b, || self.bounds())
    }

    /// [`Primitive::overlaps_box`], asking `bounds` for the primitive's bounds when it needs
    /// them (a caller that keeps them saves finding a quadric's again).
    pub fn overlaps_box_with(&self, b: &Aabb, bounds: impl FnOnce() -> Option<Aabb>) -> bool {
        let b = b.padded();
        let by_bounds = |bounds: Option<Aabb>| bounds.is_none_or(|pb| pb.overlaps(&b));
        if self.motion != Vec3::ZERO {
            return by_bounds(bounds());
        }
        match &self.kind {
            PrimitiveKind::Triangle { v, .. } => triangle_overlaps(v, &b),
            PrimitiveKind::Sphere { centre, radius } => sphere_overlaps(*centre, *radius, &b),
            _ => by_bounds(bounds()),
        }
    }

    /// The nearest `t` in `(t_min, t_max)`.
    #[inline]
    pub fn intersect(&self, r: &RayPre, t_min: Real, t_max: Real) -> Option<Real> {
        if self.motion != Vec3::ZERO {
            let moved = r.from_origin(r.ray.origin - self.motion * r.ray.time);
            return self.intersect_static(&moved, t_min, t_max);
        }
        self.intersect_static(r, t_min, t_max)
    }

    #[inline]
    fn intersect_static(&self, r: &RayPre, t_min: Real, t_max: Real) -> Option<Real> {
        match &self.kind {
            PrimitiveKind::Triangle { v, .. } => intersect_triangle(r, v, t_min, t_max),
            PrimitiveKind::Sphere { centre, radius } => {
                intersect_sphere(&r.ray, *centre, *radius, t_min, t_max)
            }
            PrimitiveKind::Ellipsoid { to_local } => {
                intersect_ellipsoid(&r.ray, to_local, t_min, t_max)
            }
            PrimitiveKind::Quadric(q) => intersect_quadric(&r.ray, q, t_min, t_max),
        }
    }

    /// The geometric unit normal at world point `p` reached at shutter time `time` (outward for
    /// closed shapes; the plane normal for polygons).
    pub fn normal(&self, p: Vec3, time: Real) -> Vec3 {
        let p = p - self.motion * time;
        match &self.kind {
            PrimitiveKind::Sphere { centre, radius } => (p - *centre) / *radius,
            PrimitiveKind::Ellipsoid { to_local } => ellipsoid_normal(to_local, p),
            PrimitiveKind::Triangle { normal, .. } => *normal,
            PrimitiveKind::Quadric(q) => quadric_normal(q, p),
        }
    }

    /// Whether the shape is flat (a triangle): a line meets it at most once.
    pub fn is_planar(&self) -> bool {
        matches!(self.kind, PrimitiveKind::Triangle { .. })
    }

    /// Whether the shape encloses a volume (rays can be inside it).
    pub fn is_closed(&self) -> bool {
        matches!(
            self.kind,
            PrimitiveKind::Sphere { .. }
                | PrimitiveKind::Ellipsoid { .. }
                | PrimitiveKind::Triangle { solid: true, .. }
        )
    }
}

/// Whether static triangle `v` touches box `b` (already padded): exactly, by the separating
/// axis test, unless it lies inside.
pub fn triangle_overlaps(v: &[Vec3; 3], b: &Aabb) -> bool {
    let tb = Aabb::from_points(v);
    let inside = tb.min.cmpge(b.min).all() && tb.max.cmple(b.max).all();
    inside || (tb.overlaps(b) && super::overlap::triangle_box(v, b))
}

/// Whether a static sphere touches box `b` (already padded), by its closest point.
pub fn sphere_overlaps(centre: Vec3, radius: Real, b: &Aabb) -> bool {
    super::overlap::sphere_box(centre, radius * (1.0 + 1e-9), b)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Ray;

    fn prim(kind: PrimitiveKind, motion: Vec3) -> Primitive {
        Primitive {
            kind,
            object: 0,
            surface: 0,
            motion,
        }
    }

    #[test]
    fn ellipsoid_bounds_contain_its_surface() {
        let to_world = DAffine3::from_translation(Vec3::new(1.0, 2.0, 3.0))
            * DAffine3::from_rotation_z(0.7)
            * DAffine3::from_scale(Vec3::new(3.0, 1.0, 0.5));
        let p = prim(
            PrimitiveKind::Ellipsoid {
                to_local: to_world.inverse(),
            },
            Vec3::ZERO,
        );
        let b = p.bounds().unwrap();
        let mut touches = [false; 6];
        for i in 0..64 {
            for j in 0..32 {
                let (th, ph) = (
                    i as f64 / 64.0 * std::f64::consts::TAU,
                    j as f64 / 31.0 * std::f64::consts::PI,
                );
                let q = to_world.transform_point3(Vec3::new(
                    th.cos() * ph.sin(),
                    th.sin() * ph.sin(),
                    ph.cos(),
                ));
                assert!(
                    q.cmpge(b.min).all() && q.cmple(b.max).all(),
                    "{q} outside {b:?}"
                );
                for k in 0..3 {
                    touches[k] |= q[k] - b.min[k] < 0.05;
                    touches[k + 3] |= b.max[k] - q[k] < 0.05;
                }
            }
        }
        assert!(
            touches.iter().all(|&t| t),
            "bounds are not tight: {touches:?}"
        );
    }

    #[test]
    fn moving_sphere_is_hit_where_it_is_at_the_rays_time() {
        let p = prim(
            PrimitiveKind::Sphere {
                centre: Vec3::ZERO,
                radius: 1.0,
            },
            Vec3::new(4.0, 0.0, 0.0),
        );
        let b = p.bounds().unwrap();
        assert!(b.min.x <= -1.0 && b.max.x >= 5.0, "bounds sweep the motion");
        let mut ray = Ray::new(Vec3::new(4.0, 0.0, -5.0), Vec3::Z);
        assert_eq!(p.intersect(&RayPre::new(ray), 0.0, 100.0), None);
        ray.time = 1.0;
        assert_eq!(p.intersect(&RayPre::new(ray), 0.0, 100.0), Some(4.0));
        assert!((p.normal(Vec3::new(4.0, 0.0, -1.0), 1.0) + Vec3::Z).length() < 1e-12);
    }

    #[test]
    fn degenerate_objects_are_dropped_not_nan() {
        use yari::model::Shape;
        let mut w = crate::bench::spd_world(yari::spd::Database::Tetra, 1).unwrap();
        let n = w.objects.len();
        w.objects.push(yari::model::Object {
            shape: Shape::Sphere {
                center: Vec3::ZERO,
                radius: f64::NAN,
            },
            surface: 0,
            motion: Vec3::ZERO,
        });
        w.objects.push(yari::model::Object {
            shape: Shape::Polygon {
                vertices: vec![Vec3::ZERO, Vec3::ZERO, Vec3::X],
            },
            surface: 0,
            motion: Vec3::ZERO,
        });
        let mut b = crate::geometry::primitives::PrimitivesBuilder::new();
        for o in &w.objects {
            b.add(&w.surfaces, o);
        }
        let (prims, dropped) = b.finish();
        assert_eq!(prims.len(), n);
        assert_eq!(
            dropped.iter().map(|d| d.object).collect::<Vec<_>>(),
            vec![n, n + 1]
        );
    }
}
