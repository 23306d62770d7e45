//! Smooth triangles: the normal interpolated from the corners' normals with the barycentric
//! coordinates of the hit (Phong's shading normal), and the shadow-terminator fix of Hanika
//! ("Hacking the shadow terminator", Ray Tracing Gems II, ch. 4, 2021): shadow rays start
//! from the hit point lifted onto the surface the corners' tangent planes describe, not from
//! the flat facet, so a coarse mesh lit from the side is not cut into dark facets.

use super::{Real, Vec3};

/// A hit on a smooth triangle: its corners, their unit normals (turned to the side of the
/// triangle's geometric normal), and the hit's barycentric coordinates.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SmoothHit {
    /// The triangle's corners.
    pub corners: [Vec3; 3],
    /// The corners' unit normals, on the side of the geometric normal.
    pub normals: [Vec3; 3],
    /// The weights of the corners at the hit point (each in [0, 1], summing to 1).
    pub bary: [Real; 3],
}

impl SmoothHit {
    /// The hit at point `p` of the triangle `corners` with corner normals `normals`.
    pub fn new(corners: [Vec3; 3], normals: [Vec3; 3], p: Vec3) -> SmoothHit {
        SmoothHit {
            corners,
            normals,
            bary: barycentric(&corners, p),
        }
    }

    /// The shading normal: the corners' normals weighted by the barycentric coordinates,
    /// normalised; `None` when they cancel out.
    pub fn normal(&self) -> Option<Vec3> {
        let [a, b, c] = self.bary;
        (self.normals[0] * a + self.normals[1] * b + self.normals[2] * c).try_normalize()
    }

    /// Hanika's shadow-ray origin for a ray leaving on the side `side` (+1: the side the
    /// normals point to, -1: the other): the hit point `p` moved, for each corner, onto that
    /// corner's tangent plane when it lies below it, the moves weighted by the barycentric
    /// coordinates. Where the surface the normals describe is convex towards `side` this
    /// lifts the point off the facet towards it; elsewhere the point stays where it is.
    pub fn shadow_origin(&self, p: Vec3, side: Real) -> Vec3 {
        let mut lifted = p;
        for k in 0..3 {
            let n = self.normals[k] * side;
            let below = (p - self.corners[k]).dot(n).min(0.0);
            lifted -= n * (below * self.bary[k]);
        }
        if lifted.is_finite() {
            lifted
        } else {
            p
        }
    }
}

/// The barycentric coordinates of `p` (a point in, or very near, the triangle's plane) with
/// respect to `v`: the weights of the corners, each clamped to [0, 1] and summing to 1
/// (rounding can put a hit on an edge a hair outside). A degenerate triangle gives the
/// centre.
pub fn barycentric(v: &[Vec3; 3], p: Vec3) -> [Real; 3] {
    let n = (v[1] - v[0]).cross(v[2] - v[0]);
    let area2 = n.length_squared();
    let third = [1.0 / 3.0; 3];
    if !(area2 > 0.0 && area2.is_finite()) {
        return third;
    }
    // Each corner's weight is the signed area of the sub-triangle opposite it.
    let w = [
        (v[1] - p).cross(v[2] - p).dot(n) / area2,
        (v[2] - p).cross(v[0] - p).dot(n) / area2,
        (v[0] - p).cross(v[1] - p).dot(n) / area2,
    ]
    .map(|x| x.clamp(0.0, 1.0));
    let sum = w[0] + w[1] + w[2];
    if sum > 0.0 && sum.is_finite() {
        w.map(|x| x / sum)
    } else {
        third
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: Vec3, b: Vec3) -> bool {
        (a - b).length() < 1e-12
    }

    #[test]
    fn barycentric_coordinates_by_hand() {
        let v = [
            Vec3::ZERO,
            Vec3::new(2.0, 0.0, 0.0),
            Vec3::new(0.0, 2.0, 0.0),
        ];
        // p = 0.5 v0 + 0.25 v1 + 0.25 v2 = (0.5, 0.5, 0).
        let b = barycentric(&v, Vec3::new(0.5, 0.5, 0.0));
        assert!((b[0] - 0.5).abs() < 1e-15 && (b[1] - 0.25).abs() < 1e-15);
        assert!((b[2] - 0.25).abs() < 1e-15);
        assert_eq!(barycentric(&v, v[1]), [0.0, 1.0, 0.0]);
        // A point a hair outside an edge is clamped onto it.
        let b = barycentric(&v, Vec3::new(1.0, -1e-17, 0.0));
        assert!(b.iter().all(|x| (0.0..=1.0).contains(x)));
        assert_eq!(barycentric(&[Vec3::ZERO; 3], Vec3::X), [1.0 / 3.0; 3]);
    }

    #[test]
    fn interpolated_normal_by_hand() {
        // Corner normals z, x and y; the hit at barycentrics (1/2, 1/4, 1/4) has the normal
        // (1/4, 1/4, 1/2) / |.| = (1, 1, 2) / sqrt(6).
        let v = [
            Vec3::ZERO,
            Vec3::new(2.0, 0.0, 0.0),
            Vec3::new(0.0, 2.0, 0.0),
        ];
        let h = SmoothHit::new(v, [Vec3::Z, Vec3::X, Vec3::Y], Vec3::new(0.5, 0.5, 0.0));
        let want = Vec3::new(1.0, 1.0, 2.0) / 6f64.sqrt();
        assert!(close(h.normal().unwrap(), want), "{:?}", h.normal());
        // At a corner the normal is that corner's.
        let h = SmoothHit::new(v, [Vec3::Z, Vec3::X, Vec3::Y], v[2]);
        assert!(close(h.normal().unwrap(), Vec3::Y));
        // Opposite normals cancel halfway.
        let h = SmoothHit::new(v, [Vec3::Z, -Vec3::Z, Vec3::Z], Vec3::new(1.0, 0.0, 0.0));
        assert_eq!(h.normal(), None);
    }

    #[test]
    fn the_shadow_origin_is_lifted_onto_the_tangent_planes_on_a_convex_side_only() {
        // A facet of a unit sphere: corners on the sphere, normals radial. The centre of the
        // facet lies inside the sphere; lifted towards the normals it moves out along them.
        let v = [Vec3::X, Vec3::Y, Vec3::Z];
        let h = SmoothHit::new(v, v, Vec3::splat(1.0 / 3.0));
        let p = Vec3::splat(1.0 / 3.0);
        let q = h.shadow_origin(p, 1.0);
        // By hand: each corner's plane x.c = 1 is 2/3 above p, so p moves by
        // (2/3)(1/3)(c) for each corner c: q = p + (2/9)(1,1,1) = (5/9)(1,1,1).
        assert!(close(q, Vec3::splat(5.0 / 9.0)), "{q}");
        // Towards the other side the surface is concave: nothing moves.
        assert_eq!(h.shadow_origin(p, -1.0), p);
        // A flat triangle (all normals equal the plane's) is not moved either way.
        let flat = [Vec3::ZERO, Vec3::X, Vec3::Y];
        let h = SmoothHit::new(flat, [Vec3::Z; 3], Vec3::new(0.2, 0.3, 0.0));
        assert_eq!(
            h.shadow_origin(Vec3::new(0.2, 0.3, 0.0), 1.0),
            Vec3::new(0.2, 0.3, 0.0)
        );
        assert_eq!(
            h.shadow_origin(Vec3::new(0.2, 0.3, 0.0), -1.0),
            Vec3::new(0.2, 0.3, 0.0)
        );
    }
}
