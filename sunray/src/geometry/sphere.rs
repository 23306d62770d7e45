//! Spheres and ellipsoids, with a numerically stable quadratic.

use super::{Ray, Real, Vec3};
use glam::DAffine3;

/// Roots of `a t^2 + 2 b t + c = 0` in increasing order, computed without cancellation
/// (`q = -(b + sign(b) sqrt(b^2 - ac))`, roots `q / a` and `c / q`). `disc` is `b^2 - ac`,
/// passed in so callers can compute it in a better-conditioned way.
#[inline]
pub fn stable_roots(a: Real, b: Real, c: Real, disc: Real) -> Option<(Real, Real)> {
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

/// Smallest root in `(t_min, t_max)`.
#[inline]
pub fn first_root(roots: (Real, Real), t_min: Real, t_max: Real) -> Option<Real> {
    let (r0, r1) = roots;
    if r0 > t_min && r0 < t_max {
        Some(r0)
    } else if r1 > t_min && r1 < t_max {
        Some(r1)
    } else {
        None
    }
}

/// Ray / sphere: the nearest `t` in `(t_min, t_max)`.
#[inline]
pub fn intersect_sphere(
    ray: &Ray,
    centre: Vec3,
    radius: Real,
    t_min: Real,
    t_max: Real,
) -> Option<Real> {
    let oc = ray.origin - centre;
    let a = ray.dir.length_squared();
    let b = oc.dot(ray.dir);
    let c = oc.length_squared() - radius * radius;
    if c > 0.0 && b > 0.0 && t_min >= 0.0 {
        // Outside and moving away: both roots are negative (their product c/a is positive,
        // their sum -2b/a negative), exactly as the full computation below would find.
        return None;
    }
    // b^2 - ac rewritten as a (r^2 - |oc - (b/a) d|^2) (Hearn and Baker), which keeps its
    // precision for rays that pass far from the centre.
    let l = oc - ray.dir * (b / a);
    let disc = a * (radius * radius - l.length_squared());
    first_root(stable_roots(a, b, c, disc)?, t_min, t_max)
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
