//! Exact (conservative) primitive / box overlap tests, used to put primitives only into the
//! octree voxels they really touch: the separating-axis test for triangles (Akenine-Moller
//! 2001) and the closest-point test for spheres.

use super::{Aabb, Real, Vec3};

/// Whether triangle `v` overlaps box `b` (touching counts).
pub fn triangle_box(v: &[Vec3; 3], b: &Aabb) -> bool {
    let c = b.centre();
    let h = b.extent() * 0.5;
    let p = [v[0] - c, v[1] - c, v[2] - c];
    // 1. The box's face normals: the triangle's bounds against the box.
    for k in 0..3 {
        let lo = p[0][k].min(p[1][k]).min(p[2][k]);
        let hi = p[0][k].max(p[1][k]).max(p[2][k]);
        if lo > h[k] || hi < -h[k] {
            return false;
        }
    }
    let e = [p[1] - p[0], p[2] - p[1], p[0] - p[2]];
    // 2. The triangle's plane.
    let n = e[0].cross(e[1]);
    let r = h.x * n.x.abs() + h.y * n.y.abs() + h.z * n.z.abs();
    if n.dot(p[0]).abs() > r {
        return false;
    }
    // 3. The nine cross products of edges and box axes.
    let axes = [Vec3::X, Vec3::Y, Vec3::Z];
    for edge in e {
        for axis in axes {
            let a = edge.cross(axis);
            if separated(a, &p, h) {
                return false;
            }
        }
    }
    true
}

#[inline]
fn separated(a: Vec3, p: &[Vec3; 3], h: Vec3) -> bool {
    let d = [a.dot(p[0]), a.dot(p[1]), a.dot(p[2])];
    let lo = d[0].min(d[1]).min(d[2]);
    let hi = d[0].max(d[1]).max(d[2]);
    let r = h.x * a.x.abs() + h.y * a.y.abs() + h.z * a.z.abs();
    lo > r || hi < -r
}

/// Whether the ball of `radius` about `centre` overlaps box `b`.
pub fn sphere_box(centre: Vec3, radius: Real, b: &Aabb) -> bool {
    let q = centre.clamp(b.min, b.max);
    (q - centre).length_squared() <= radius * radius
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn triangle_box_cases() {
        let b = Aabb::new(Vec3::ZERO, Vec3::ONE);
        let inside = [
            Vec3::splat(0.2),
            Vec3::new(0.8, 0.2, 0.2),
            Vec3::new(0.2, 0.8, 0.5),
        ];
        assert!(triangle_box(&inside, &b));
        // Big triangle cutting through the box with all vertices outside.
        let through = [
            Vec3::new(-5.0, 0.5, -5.0),
            Vec3::new(5.0, 0.5, -5.0),
            Vec3::new(0.0, 0.5, 5.0),
        ];
        assert!(triangle_box(&through, &b));
        // Its bounding box overlaps the box, but the triangle passes beside the corner.
        let corner_miss = [
            Vec3::new(1.2, 3.0, 0.5),
            Vec3::new(3.0, 1.2, 0.5),
            Vec3::new(3.0, 3.0, 0.5),
        ];
        assert!(Aabb::from_points(&corner_miss).overlaps(&Aabb::new(Vec3::ZERO, Vec3::splat(2.0))));
        assert!(!triangle_box(
            &corner_miss,
            &Aabb::new(Vec3::ZERO, Vec3::splat(2.0))
        ));
        // Touching a face counts.
        let touching = [
            Vec3::new(1.0, 0.2, 0.2),
            Vec3::new(2.0, 0.2, 0.2),
            Vec3::new(1.0, 0.8, 0.2),
        ];
        assert!(triangle_box(&touching, &b));
    }

    #[test]
    fn sphere_box_cases() {
        let b = Aabb::new(Vec3::ZERO, Vec3::ONE);
        assert!(sphere_box(Vec3::splat(0.5), 0.1, &b));
        assert!(sphere_box(Vec3::new(1.5, 0.5, 0.5), 0.5, &b));
        // Near the corner: the boxes overlap, the ball does not.
        assert!(!sphere_box(Vec3::splat(1.5), 0.8, &b));
    }
}
