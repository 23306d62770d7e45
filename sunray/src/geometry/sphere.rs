//! Spheres and ellipsoids, with a numerically stable quadratic.

use super::{Ray, Real, Vec3};
use glam::DAffine3;

pub use super::kernels::k64::{first_root, stable_roots};

/// Ray / sphere: the nearest `t` in `(t_min, t_max)` ([`super::kernels::k64::sphere`]).
#[inline]
pub fn intersect_sphere(
    ray: &Ray,
    centre: Vec3,
    radius: Real,
    t_min: Real,
    t_max: Real,
) -> Option<Real> {
    super::kernels::k64::sphere(ray.origin, ray.dir, centre, radius, t_min, t_max)
}

/// Ray / unit sphere at the origin, after mapping the ray by `to_local` (the inverse of the
/// ellipsoid's map). `t` is the same in both spaces because the direction is not normalised.
#[inline]
pub fn intersect_ellipsoid(
    ray: &Ray,
    to_local: &DAffine3,
    t_min: Real,
    t_max: Real,
) -> Option<Real> {
    let local = Ray {
        origin: to_local.transform_point3(ray.origin),
        dir: to_local.transform_vector3(ray.dir),
        time: ray.time,
    };
    intersect_sphere(&local, Vec3::ZERO, 1.0, t_min, t_max)
}

/// The outward unit normal of an ellipsoid at world point `p`: the inverse transpose of the map
/// applied to the local normal.
pub fn ellipsoid_normal(to_local: &DAffine3, p: Vec3) -> Vec3 {
    let local = to_local.transform_point3(p);
    to_local
        .matrix3
        .transpose()
        .mul_vec3(local)
        .normalize_or_zero()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sphere_hit_from_outside_and_inside() {
        let r = Ray::new(Vec3::new(0.0, 0.0, -5.0), Vec3::Z);
        assert_eq!(intersect_sphere(&r, Vec3::ZERO, 1.0, 0.0, 100.0), Some(4.0));
        let inside = Ray::new(Vec3::ZERO, Vec3::Z * 2.0);
        assert_eq!(
            intersect_sphere(&inside, Vec3::ZERO, 1.0, 0.0, 100.0),
            Some(0.5)
        );
        assert_eq!(intersect_sphere(&r, Vec3::ZERO, 1.0, 0.0, 3.0), None);
    }

    #[test]
    fn far_grazing_ray_keeps_precision() {
        // A ray from 1e6 away aimed one radius off centre: the tangent point is hit.
        let r = Ray::new(Vec3::new(-1e6, 0.999_999, 0.0), Vec3::X);
        let t = intersect_sphere(&r, Vec3::ZERO, 1.0, 0.0, 1e9).unwrap();
        let p = r.at(t);
        assert!((p.length() - 1.0).abs() < 1e-9, "{p}");
    }

    #[test]
    fn reintersection_from_hit_point_finds_the_far_side_only() {
        let r = Ray::new(Vec3::new(0.3, 0.2, -5.0), Vec3::new(0.01, -0.02, 1.0));
        let t = intersect_sphere(&r, Vec3::new(0.1, 0.0, 0.0), 1.0, 0.0, 100.0).unwrap();
        let p = r.at(t);
        let n = (p - Vec3::new(0.1, 0.0, 0.0)).normalize();
        // Leaving outward: nothing.
        let out = Ray::new(crate::geometry::offset_origin(p, n), n + Vec3::X * 0.3);
        assert_eq!(
            intersect_sphere(&out, Vec3::new(0.1, 0.0, 0.0), 1.0, 0.0, 100.0),
            None
        );
        // Going inward: the far side, about a diameter away.
        let inward = Ray::new(crate::geometry::offset_origin(p, -n), r.dir);
        let t2 = intersect_sphere(&inward, Vec3::new(0.1, 0.0, 0.0), 1.0, 0.0, 100.0).unwrap();
        assert!(t2 > 1.0, "{t2}");
    }

    #[test]
    fn ellipsoid_matches_scaled_sphere() {
        let to_world = DAffine3::from_scale(Vec3::new(2.0, 1.0, 1.0));
        let to_local = to_world.inverse();
        let r = Ray::new(Vec3::new(-10.0, 0.0, 0.0), Vec3::X);
        assert_eq!(intersect_ellipsoid(&r, &to_local, 0.0, 100.0), Some(8.0));
        let n = ellipsoid_normal(&to_local, Vec3::new(0.0, 1.0, 0.0));
        assert!((n - Vec3::Y).length() < 1e-12);
    }
}
