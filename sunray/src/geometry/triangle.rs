//! Watertight ray / triangle intersection (Woop, Benthin and Wald, JCGT 2013).
//!
//! The ray is sheared so it runs along +z from the origin; the edge functions U, V, W of the
//! transformed vertices then decide the hit exactly the same way for both triangles sharing an
//! edge, so no ray slips between them.

use super::{RayPre, Real, Vec3};

/// The nearest `t` in `(t_min, t_max)` where the ray crosses triangle `v`
/// ([`super::kernels::k64::triangle`]).
#[inline]
pub fn intersect_triangle(r: &RayPre, v: &[Vec3; 3], t_min: Real, t_max: Real) -> Option<Real> {
    let shear = r.shear();
    super::kernels::k64::triangle(r.ray.origin, shear.k, shear.s, v, t_min, t_max)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Ray;

    fn tri() -> [Vec3; 3] {
        [
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
        ]
    }

    #[test]
    fn hits_inside_and_misses_outside() {
        let r = RayPre::new(Ray::new(Vec3::new(0.25, 0.25, 1.0), -Vec3::Z));
        assert_eq!(intersect_triangle(&r, &tri(), 0.0, 10.0), Some(1.0));
        let r = RayPre::new(Ray::new(Vec3::new(0.75, 0.75, 1.0), -Vec3::Z));
        assert_eq!(intersect_triangle(&r, &tri(), 0.0, 10.0), None);
        // Both orientations of the triangle are hit.
        let r = RayPre::new(Ray::new(Vec3::new(0.25, 0.25, -1.0), Vec3::Z));
        assert_eq!(intersect_triangle(&r, &tri(), 0.0, 10.0), Some(1.0));
    }

    #[test]
    fn shared_edge_is_watertight() {
        // Two triangles sharing the diagonal of a square; rays along the diagonal hit at
        // least one of them, for many origins (pbrt's watertightness test in miniature).
        let p = [
            Vec3::new(-1.3, -0.7, 0.1),
            Vec3::new(1.1, -1.2, 0.3),
            Vec3::new(0.9, 1.4, -0.2),
            Vec3::new(-1.0, 1.0, 0.0),
        ];
        let t1 = [p[0], p[1], p[2]];
        let t2 = [p[0], p[2], p[3]];
        let mut state = 12345u64;
        for _ in 0..2000 {
            let s = crate::sampler::splitmix64(&mut state);
            let f = (s >> 11) as f64 / (1u64 << 53) as f64;
            let on_edge = p[0] + (p[2] - p[0]) * f;
            let from = Vec3::new(0.3, -0.2, 5.0) + Vec3::splat(f * 0.1);
            let r = RayPre::new(Ray::new(from, on_edge - from));
            let hit = intersect_triangle(&r, &t1, 0.0, 10.0)
                .or_else(|| intersect_triangle(&r, &t2, 0.0, 10.0));
            assert!(
                hit.is_some(),
                "ray through the shared edge at {f} slipped through"
            );
        }
    }

    #[test]
    fn reintersection_from_a_hit_point_finds_the_far_face_only() {
        // A closed tetrahedron: a ray entering through one face, restarted at the hit point
        // (offset inwards), must leave through another face and not re-hit the first.
        let p = [Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z];
        let faces = [
            [p[0], p[2], p[1]],
            [p[0], p[1], p[3]],
            [p[0], p[3], p[2]],
            [p[1], p[2], p[3]],
        ];
        let r = RayPre::new(Ray::new(
            Vec3::new(0.2, 0.2, -3.0),
            Vec3::new(0.01, 0.02, 1.0),
        ));
        let (entry, t) = faces
            .iter()
            .enumerate()
            .filter_map(|(i, f)| intersect_triangle(&r, f, 0.0, 100.0).map(|t| (i, t)))
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .unwrap();
        let hit = r.ray.at(t);
        let inward = Vec3::Z; // the entry face is z = 0
        let again = RayPre::new(Ray::new(
            crate::geometry::offset_origin(hit, inward),
            r.ray.dir,
        ));
        assert_eq!(intersect_triangle(&again, &faces[entry], 0.0, 100.0), None);
        let exits: Vec<usize> = (0..4)
            .filter(|&i| intersect_triangle(&again, &faces[i], 0.0, 100.0).is_some())
            .collect();
        assert_eq!(exits.len(), 1, "{exits:?}");
        assert_ne!(exits[0], entry);
    }

    #[test]
    fn degenerate_triangle_is_never_hit() {
        let d = [Vec3::ZERO, Vec3::X, Vec3::X * 2.0];
        let r = RayPre::new(Ray::new(Vec3::new(0.5, 0.0, 1.0), -Vec3::Z));
        assert_eq!(intersect_triangle(&r, &d, 0.0, 10.0), None);
    }
}
