//! Polygons to triangles: repeated vertices removed, zero-area polygons dropped, convex
//! polygons fan-triangulated, concave ones ear-clipped in their plane. The algorithm is
//! [`yari::polygon`]'s, shared with the POV-Ray writer so that both cut a polygon alike;
//! here its triangles are given as corners.

use super::Vec3;
pub use yari::polygon::{Degenerate, Triangulation};

/// A polygon ready for rendering: triangles (vertex triples) and the plane's unit normal (by
/// the right-hand rule over the vertex order, Newell's method).
#[derive(Clone, Debug, PartialEq)]
pub struct Triangulated {
    /// The triangles, each a vertex triple in the polygon's winding.
    pub triangles: Vec<[Vec3; 3]>,
    /// The plane's unit normal (right-hand rule over the vertex order).
    pub normal: Vec3,
}

/// Triangulates a planar polygon given in order.
pub fn triangulate(vertices: &[Vec3]) -> Result<Triangulated, Degenerate> {
    let t = triangulate_indexed(vertices)?;
    Ok(Triangulated {
        triangles: t
            .triangles
            .into_iter()
            .map(|c| c.map(|k| vertices[k]))
            .collect(),
        normal: t.normal,
    })
}

/// Triangulates a planar polygon given in order, each triangle as indices into `vertices`
/// (so a smooth polygon's corners find their normals).
pub fn triangulate_indexed(vertices: &[Vec3]) -> Result<Triangulation, Degenerate> {
    yari::polygon::triangulate(vertices)
}

/// The unit normal of the plane through `v` by Newell's method, computed exactly as
/// [`triangulate`] computes [`Triangulated::normal`] (so the normal of a triangle can be
/// recomputed from its corners, to the bit, instead of stored).
#[inline]
pub fn plane_normal(v: &[Vec3]) -> Vec3 {
    yari::polygon::plane_normal(v)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Real;

    fn area(t: &Triangulated) -> Real {
        t.triangles
            .iter()
            .map(|t| (t[1] - t[0]).cross(t[2] - t[0]).length() / 2.0)
            .sum()
    }

    #[test]
    fn square_is_two_triangles_with_its_normal() {
        let sq = [Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y];
        let t = triangulate(&sq).unwrap();
        assert_eq!(t.triangles.len(), 2);
        assert_eq!(t.normal, Vec3::Z);
        assert!((area(&t) - 1.0).abs() < 1e-12);
    }

    #[test]
    fn concave_l_shape_keeps_its_area() {
        // An L of area 3, clockwise seen from +z, in the plane x = 2.
        let l2 = [
            [0.0, 0.0],
            [2.0, 0.0],
            [2.0, 1.0],
            [1.0, 1.0],
            [1.0, 2.0],
            [0.0, 2.0],
        ];
        let pts: Vec<Vec3> = l2
            .iter()
            .rev()
            .map(|[a, b]| Vec3::new(2.0, *a, *b))
            .collect();
        let t = triangulate(&pts).unwrap();
        assert_eq!(t.triangles.len(), 4);
        assert!((area(&t) - 3.0).abs() < 1e-12, "{}", area(&t));
        assert_eq!(t.normal, -Vec3::X);
    }

    #[test]
    fn degenerate_polygons_are_dropped() {
        let line = [Vec3::ZERO, Vec3::X, Vec3::X * 2.0];
        assert_eq!(triangulate(&line), Err(Degenerate::ZeroArea));
        let repeated = [Vec3::ZERO, Vec3::ZERO, Vec3::X, Vec3::X];
        assert_eq!(triangulate(&repeated), Err(Degenerate::TooFewVertices));
        let nan = [Vec3::ZERO, Vec3::X, Vec3::new(f64::NAN, 0.0, 0.0)];
        assert!(triangulate(&nan).is_err());
        // A repeated vertex inside an otherwise good triangle is removed, not fatal.
        let t = triangulate(&[Vec3::ZERO, Vec3::X, Vec3::X, Vec3::Y]).unwrap();
        assert_eq!(t.triangles.len(), 1);
    }
}
