//! Polygons to triangles: repeated vertices removed, zero-area polygons dropped, convex
//! polygons fan-triangulated, concave ones ear-clipped in their plane.

use super::{Real, Vec3};

/// Why a polygon was dropped.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Degenerate {
    /// Fewer than three vertices once consecutive repeats are removed.
    TooFewVertices,
    /// The area is negligible at the vertices' scale (e.g. collinear), or a vertex is not finite.
    ZeroArea,
}

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
    let scale = vertices
        .iter()
        .fold(0.0_f64, |m, v| m.max(v.abs().max_element()))
        .max(1e-300);
    let eps = scale * 1e-12;
    // Drop repeated (consecutive, and last == first) vertices.
    let mut v: Vec<Vec3> = Vec::with_capacity(vertices.len());
    for &p in vertices {
        if !p.is_finite() {
            return Err(Degenerate::ZeroArea);
        }
        if v.last()
            .is_none_or(|&q: &Vec3| (p - q).abs().max_element() > eps)
        {
            v.push(p);
        }
    }
    while v.len() > 1 && (v[0] - v[v.len() - 1]).abs().max_element() <= eps {
        v.pop();
    }
    if v.len() < 3 {
        return Err(Degenerate::TooFewVertices);
    }
    let newell = newell_normal(&v);
    let area2 = newell.length();
    if area2.is_nan() || area2 <= eps * scale {
        return Err(Degenerate::ZeroArea);
    }
    let normal = newell / area2;
    // Project onto the plane of the two axes other than the normal's largest.
    let k = normal.abs().max_position();
    let (i, j) = ((k + 1) % 3, (k + 2) % 3);
    let sign = if normal[k] >= 0.0 { 1.0 } else { -1.0 };
    let p2: Vec<[Real; 2]> = v.iter().map(|p| [p[i], p[j] * sign]).collect();
    let index_triangles = if is_convex(&p2) {
        fan(v.len())
    } else {
        ear_clip(&p2)
    };
    let min_area = eps * scale;
    let triangles: Vec<[Vec3; 3]> = index_triangles
        .into_iter()
        .map(|[a, b, c]| [v[a], v[b], v[c]])
        .filter(|t| (t[1] - t[0]).cross(t[2] - t[0]).length() > min_area)
        .collect();
    if triangles.is_empty() {
        return Err(Degenerate::ZeroArea);
    }
    Ok(Triangulated { triangles, normal })
}

/// The unit normal of the plane through `v` by Newell's method, computed exactly as
/// [`triangulate`] computes [`Triangulated::normal`] (so the normal of a triangle can be
/// recomputed from its corners, to the bit, instead of stored).
#[inline]
pub fn plane_normal(v: &[Vec3]) -> Vec3 {
    let newell = newell_normal(v);
    let area2 = newell.length();
    newell / area2
}

fn newell_normal(v: &[Vec3]) -> Vec3 {
    let mut n = Vec3::ZERO;
    for (idx, a) in v.iter().enumerate() {
        let b = v[(idx + 1) % v.len()];
        n += Vec3::new(
            (a.y - b.y) * (a.z + b.z),
            (a.z - b.z) * (a.x + b.x),
            (a.x - b.x) * (a.y + b.y),
        );
    }
    n
}

fn cross2(o: [Real; 2], a: [Real; 2], b: [Real; 2]) -> Real {
    (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])
}

/// Convex (counter-clockwise, after projection) when no turn is clockwise.
fn is_convex(p: &[[Real; 2]]) -> bool {
    let n = p.len();
    (0..n).all(|i| cross2(p[i], p[(i + 1) % n], p[(i + 2) % n]) >= 0.0)
}

fn fan(n: usize) -> Vec<[usize; 3]> {
    (1..n - 1).map(|i| [0, i, i + 1]).collect()
}

/// Ear clipping for a simple counter-clockwise polygon; O(n^2), enough for modelled input.
fn ear_clip(p: &[[Real; 2]]) -> Vec<[usize; 3]> {
    let mut idx: Vec<usize> = (0..p.len()).collect();
    let mut out = Vec::with_capacity(p.len().saturating_sub(2));
    let mut guard = 0;
    while idx.len() > 3 && guard < 4 * p.len() * p.len() {
        guard += 1;
        let n = idx.len();
        let mut clipped = false;
        for k in 0..n {
            let (a, b, c) = (idx[(k + n - 1) % n], idx[k], idx[(k + 1) % n]);
            if cross2(p[a], p[b], p[c]) <= 0.0 {
                continue; // reflex or flat corner
            }
            let contains_other = idx
                .iter()
                .any(|&m| m != a && m != b && m != c && inside_triangle(p[m], p[a], p[b], p[c]));
            if !contains_other {
                out.push([a, b, c]);
                idx.remove(k);
                clipped = true;
                break;
            }
        }
        if !clipped {
            break; // not simple: fall back to a fan of what is left
        }
    }
    if idx.len() >= 3 {
        for i in 1..idx.len() - 1 {
            out.push([idx[0], idx[i], idx[i + 1]]);
        }
    }
    out
}

fn inside_triangle(q: [Real; 2], a: [Real; 2], b: [Real; 2], c: [Real; 2]) -> bool {
    cross2(a, b, q) >= 0.0 && cross2(b, c, q) >= 0.0 && cross2(c, a, q) >= 0.0
}

#[cfg(test)]
mod tests {
    use super::*;

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
