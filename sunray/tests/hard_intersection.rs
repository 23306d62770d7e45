//! Spheres and quadrics at the edge of their precision, and self-intersection of secondary
//! rays at unit scale, at 1e-4 and 1e+4, and far from the origin.
#![allow(clippy::unwrap_used, clippy::expect_used)] // a test: a failed unwrap is a failed test

use glam::DVec3;
use sunray::geometry::primitive::PrimitiveKind;
use sunray::geometry::quadric::intersect_quadric;
use sunray::geometry::sphere::intersect_sphere;
use sunray::geometry::{offset_from, Primitive, Ray, RayPre};
use yari::model::{HalfSpace, Quadric};

fn prim(kind: PrimitiveKind) -> Primitive {
    Primitive {
        kind,
        object: 0,
        surface: 0,
        motion: DVec3::ZERO,
    }
}

/// Deterministic unit vectors.
fn directions(n: usize, seed: u64) -> Vec<DVec3> {
    let mut s = seed;
    let mut next = || {
        let v = sunray::sampler::splitmix64(&mut s);
        (v >> 11) as f64 / (1u64 << 53) as f64
    };
    (0..n)
        .map(|_| {
            let z = 2.0 * next() - 1.0;
            let phi = 2.0 * std::f64::consts::PI * next();
            let r = (1.0 - z * z).sqrt();
            DVec3::new(r * phi.cos(), r * phi.sin(), z)
        })
        .collect()
}

/// From points on a sphere reached by eye rays, reflected (outward) rays never re-hit it and
/// refracted (inward) rays reach the far side, not the surface they start on: at radius 1,
/// 1e-4, 1e+4, and for a unit sphere centred 1e5 from the origin.
#[test]
fn secondary_rays_leave_spheres_cleanly_at_every_scale() {
    let cases = [
        (DVec3::ZERO, 1.0),
        (DVec3::splat(1e-4), 1e-4),
        (DVec3::new(3e4, -2e4, 1e4), 1e4),
        (DVec3::new(1e5, 0.0, 0.0), 1.0),
        (DVec3::new(-7e4, 7e4, 1e3), 1.0),
    ];
    for (centre, radius) in cases {
        let sphere = prim(PrimitiveKind::Sphere { centre, radius });
        for (k, d) in directions(2000, 7).into_iter().enumerate() {
            // An eye ray from 10 radii away towards a point near the centre.
            let aim = centre + directions(1, k as u64 + 99)[0] * (0.7 * radius);
            let eye = aim - d * (10.0 * radius);
            let ray = Ray::new(eye, d);
            let Some(t) = sphere.intersect(&RayPre::new(ray), 0.0, f64::INFINITY) else {
                panic!("eye ray towards {aim} missed the sphere at {centre}, r = {radius}");
            };
            let p = ray.at(t);
            let n = sphere.normal(p, 0.0);
            let refl = d - n * (2.0 * d.dot(n));
            let out = Ray::new(offset_from(p, n, eye), refl);
            let again = sphere.intersect(&RayPre::new(out), 0.0, f64::INFINITY);
            assert_eq!(
                again, None,
                "reflected ray re-hit at r = {radius}, centre {centre}"
            );
            // A shadow ray towards a light outside.
            let to_light = (n + refl).normalize();
            let shadow = Ray::new(offset_from(p, n, eye), to_light);
            assert_eq!(
                sphere.intersect(&RayPre::new(shadow), 0.0, f64::INFINITY),
                None,
                "shadow ray re-hit at r = {radius}"
            );
            let inward = Ray::new(offset_from(p, -n, eye), d);
            let far = sphere.intersect(&RayPre::new(inward), 0.0, f64::INFINITY);
            let chord = -2.0 * d.dot(n) * radius;
            // The offset moves the start by OFFSET_RELATIVE of the coordinates' magnitude.
            let magnitude = eye.abs().max_element().max(p.abs().max_element());
            let slack = 4.0 * sunray::geometry::OFFSET_RELATIVE * magnitude / -d.dot(n);
            assert!(
                far.is_some_and(|t| (t - chord).abs() <= slack + 1e-12 * chord),
                "refracted ray: {far:?}, chord {chord}, r = {radius}, centre {centre}"
            );
        }
    }
}

#[test]
fn ray_starting_on_a_sphere_and_tangent_rays_are_handled() {
    // Origin exactly on the surface (a representable point), leaving outward: no hit; going
    // inward: the far side at the chord length.
    let c = DVec3::ZERO;
    let p = DVec3::new(0.0, 0.6, 0.8);
    let r = Ray::new(p, DVec3::new(0.0, 0.6, 0.8));
    assert_eq!(intersect_sphere(&r, c, 1.0, 0.0, 1e9), None);
    let r = Ray::new(p, -p);
    let t = intersect_sphere(&r, c, 1.0, 0.0, 1e9).unwrap();
    assert!((t - 2.0).abs() < 1e-12, "{t}");
    // Tangent rays: exactly tangent gives at most a (double) root on the tangent point; just
    // inside hits near it, just outside misses; never a NaN.
    for (offset, hits) in [
        (1.0, None),
        (1.0 - 1e-12, Some(true)),
        (1.0 + 1e-12, Some(false)),
    ] {
        let r = Ray::new(DVec3::new(-5.0, offset, 0.0), DVec3::X);
        let t = intersect_sphere(&r, c, 1.0, 0.0, 1e9);
        if let Some(t) = t {
            assert!(t.is_finite());
            assert!((t - 5.0).abs() < 1e-5, "{t}");
        }
        if let Some(h) = hits {
            assert_eq!(t.is_some(), h, "offset {offset}");
        }
    }
}

#[test]
fn tiny_and_distant_spheres_are_hit_on_their_surface() {
    for (centre, radius) in [
        (DVec3::new(0.0, 0.0, -1.0), 1e-6),
        (DVec3::new(0.0, 0.0, -1e6), 1.0),
        (DVec3::new(0.0, 0.0, -1e8), 1e3),
        (DVec3::new(1e5, 1e5, -1e5), 1e-3),
    ] {
        let eye = DVec3::ZERO;
        for d in directions(200, 3) {
            let target = centre + d * (0.9 * radius);
            let ray = Ray::new(eye, (target - eye).normalize());
            let t = intersect_sphere(&ray, centre, radius, 0.0, f64::INFINITY)
                .unwrap_or_else(|| panic!("missed sphere r = {radius} at {centre}"));
            let err = ((ray.at(t) - centre).length() - radius).abs() / radius;
            assert!(
                err < 1e-6,
                "r = {radius} at {centre}: relative error {err:e}"
            );
        }
    }
}

fn cylinder_z() -> Quadric {
    // x^2 + y^2 - 1 = 0
    Quadric {
        q: [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, -1.0],
        clip: vec![],
    }
}

/// Rays (nearly) parallel to a quadric's axis: the leading coefficient is 0 or tiny, the
/// stable form still gives the right root.
#[test]
fn rays_parallel_to_a_quadric_axis() {
    let cyl = cylinder_z();
    // Exactly parallel, inside: never reaches the wall.
    let r = Ray::new(DVec3::new(0.3, 0.2, 0.0), DVec3::Z);
    assert_eq!(intersect_quadric(&r, &cyl, 0.0, f64::INFINITY), None);
    // Nearly parallel: a = eps^2 is tiny, the wall is reached at t ~ 1/eps.
    for eps in [1e-3, 1e-5, 1e-7, 1e-9] {
        let d = DVec3::new(eps, 0.0, 1.0);
        let r = Ray::new(DVec3::ZERO, d);
        let t = intersect_quadric(&r, &cyl, 0.0, f64::INFINITY);
        let want = 1.0 / eps;
        assert!(
            t.is_some_and(|t| ((t - want) / want).abs() < 1e-9),
            "eps {eps}: {t:?}, want {want}"
        );
    }
    // A cone x^2 + y^2 = z^2 and a ray parallel to one of its lines: one (linear) root.
    let cone = Quadric {
        q: [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, -1.0, 0.0, 0.0],
        clip: vec![],
    };
    let r = Ray::new(DVec3::new(0.5, 0.0, 0.0), DVec3::new(1.0, 0.0, 1.0));
    // (0.5 + t)^2 = t^2  ->  t = -0.25 (behind); the other way t = +0.25.
    assert_eq!(intersect_quadric(&r, &cone, 0.0, f64::INFINITY), None);
    let r = Ray::new(DVec3::new(0.5, 0.0, 0.0), DVec3::new(-1.0, 0.0, 1.0));
    let t = intersect_quadric(&r, &cone, 0.0, f64::INFINITY).unwrap();
    assert!((t - 0.25).abs() < 1e-15, "{t}");
    // A clipped cylinder (0 <= z <= 1) viewed along its axis from outside: only the rim.
    let mut capped = cylinder_z();
    capped.clip = vec![
        HalfSpace {
            normal: DVec3::Z,
            offset: 1.0,
        },
        HalfSpace {
            normal: -DVec3::Z,
            offset: 0.0,
        },
    ];
    let r = Ray::new(DVec3::new(0.5, 0.0, -5.0), DVec3::Z);
    assert_eq!(intersect_quadric(&r, &capped, 0.0, f64::INFINITY), None);
}

/// Secondary rays from a quadric's surface do not re-hit it, at scale 1 and 1e4.
#[test]
fn rays_leaving_a_quadric_do_not_rehit_it() {
    for scale in [1e-4, 1.0, 1e4] {
        let mut q = cylinder_z();
        q.q[9] = -scale * scale;
        let p = prim(PrimitiveKind::Quadric(q));
        for d in directions(1000, 11) {
            let d = DVec3::new(d.x, d.y, d.z * 0.3).normalize();
            let ray = Ray::new(DVec3::new(0.0, 0.0, 0.0), d);
            let Some(t) = p.intersect(&RayPre::new(ray), 0.0, f64::INFINITY) else {
                continue;
            };
            let hit = ray.at(t);
            let n = p.normal(hit, 0.0);
            // Leaving outward (n points out of the cylinder): nothing more.
            let out = Ray::new(offset_from(hit, n, DVec3::ZERO), (n + d).normalize());
            assert_eq!(p.intersect(&RayPre::new(out), 0.0, f64::INFINITY), None);
            // Reflected back inside: the opposite wall, a finite distance away.
            let back = d - n * (2.0 * d.dot(n));
            let inside = Ray::new(offset_from(hit, -n, DVec3::ZERO), back);
            let t2 = p.intersect(&RayPre::new(inside), 0.0, f64::INFINITY);
            assert!(
                t2.is_some_and(|t| t > 1e-3 * scale),
                "scale {scale}: reflected ray re-hit at {t2:?}"
            );
        }
    }
}
