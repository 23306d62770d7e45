//! Polygons to triangles, the one way every part of SunRay cuts them: repeated vertices
//! removed, zero-area polygons refused, convex triangles and quadrilaterals fan-triangulated,
//! anything else ear-clipped in its plane, the shortest ear first. The renderer
//! (`sunray::geometry::polygon`) and the POV-Ray writer ([`crate::pov`], for smooth polygons)
//! both use it, so a smooth polygon's triangles and their corners' normals are the same in
//! both.

use glam::DVec3;

/// Why a polygon was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Degenerate {
    /// Fewer than three vertices once consecutive repeats are removed.
    TooFewVertices,
    /// The area is negligible at the vertices' scale (e.g. collinear), or a vertex is not finite.
    ZeroArea,
}

/// A polygon cut into triangles: each triangle as three indices into the vertices given to
/// [`triangulate`] (in the polygon's winding), and the plane's unit normal (by the
/// right-hand rule over the vertex order, Newell's method).
#[derive(Clone, Debug, PartialEq)]
pub struct Triangulation {
    /// The triangles, as indices into the polygon's vertices.
    pub triangles: Vec<[usize; 3]>,
    /// The plane's unit normal (right-hand rule over the vertex order).
    pub normal: DVec3,
}

/// Triangulates a planar polygon given in order.
pub fn triangulate(vertices: &[DVec3]) -> Result<Triangulation, Degenerate> {
    let scale = vertices
        .iter()
        .fold(0.0_f64, |m, v| m.max(v.abs().max_element()))
        .max(1e-300);
    let eps = scale * 1e-12;
    // Drop repeated (consecutive, and last == first) vertices; `orig` keeps where each
    // remaining one was.
    let mut v: Vec<DVec3> = Vec::with_capacity(vertices.len());
    let mut orig: Vec<usize> = Vec::with_capacity(vertices.len());
    for (i, &p) in vertices.iter().enumerate() {
        if !p.is_finite() {
            return Err(Degenerate::ZeroArea);
        }
        if v.last()
            .is_none_or(|&q: &DVec3| (p - q).abs().max_element() > eps)
        {
            v.push(p);
            orig.push(i);
        }
    }
    while v.len() > 1 && (v[0] - v[v.len() - 1]).abs().max_element() <= eps {
        v.pop();
        orig.pop();
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
    let p2: Vec<[f64; 2]> = v.iter().map(|p| [p[i], p[j] * sign]).collect();
    // A fan of a convex polygon of many corners is slivers too (a disc's cap).
    let index_triangles = if v.len() <= 4 && is_convex(&p2) {
        fan(v.len())
    } else {
        ear_clip(&p2)
    };
    let min_area = eps * scale;
    let triangles: Vec<[usize; 3]> = index_triangles
        .into_iter()
        .filter(|&[a, b, c]| (v[b] - v[a]).cross(v[c] - v[a]).length() > min_area)
        .map(|t| t.map(|k| orig[k]))
        .collect();
    if triangles.is_empty() {
        return Err(Degenerate::ZeroArea);
    }
    Ok(Triangulation { triangles, normal })
}

/// The unit normal of the plane through `v` by Newell's method, computed exactly as
/// [`triangulate`] computes [`Triangulation::normal`] (so the normal of a triangle can be
/// recomputed from its corners, to the bit, instead of stored).
#[inline]
pub fn plane_normal(v: &[DVec3]) -> DVec3 {
    let newell = newell_normal(v);
    let area2 = newell.length();
    newell / area2
}

/// A smooth polygon's vertex normals as the renderer shades with them: each of unit length,
/// and all turned to the side of the polygon's plane normal `plane` (all negated when their
/// sum points away from it), so that they agree with the side the geometry faces. `None`
/// when one of them cannot be normalised.
pub fn shading_normals(normals: &[DVec3], plane: DVec3) -> Option<Vec<DVec3>> {
    let mut unit = unit_normals(normals)?;
    if against(&unit, plane) {
        for n in &mut unit {
            *n = -*n;
        }
    }
    Some(unit)
}

/// Each normal at unit length; `None` when one cannot be normalised.
pub fn unit_normals(normals: &[DVec3]) -> Option<Vec<DVec3>> {
    normals.iter().map(|n| n.try_normalize()).collect()
}

/// Whether a polygon's (unit) vertex normals point, taken together, away from its plane
/// normal `plane` ([`shading_normals`] then negates them all).
pub fn against(unit: &[DVec3], plane: DVec3) -> bool {
    unit.iter().copied().sum::<DVec3>().dot(plane) < 0.0
}

#[inline]
fn newell_normal(v: &[DVec3]) -> DVec3 {
    let mut n = DVec3::ZERO;
    for (idx, a) in v.iter().enumerate() {
        let b = v[(idx + 1) % v.len()];
        n += DVec3::new(
            (a.y - b.y) * (a.z + b.z),
            (a.z - b.z) * (a.x + b.x),
            (a.x - b.x) * (a.y + b.y),
        );
    }
    n
}

fn cross2(o: [f64; 2], a: [f64; 2], b: [f64; 2]) -> f64 {
    (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])
}

/// Convex (counter-clockwise, after projection) when no turn is clockwise.
fn is_convex(p: &[[f64; 2]]) -> bool {
    let n = p.len();
    (0..n).all(|i| cross2(p[i], p[(i + 1) % n], p[(i + 2) % n]) >= 0.0)
}

fn fan(n: usize) -> Vec<[usize; 3]> {
    (1..n - 1).map(|i| [0, i, i + 1]).collect()
}

/// Ear clipping for a simple counter-clockwise polygon, the shortest ear first: each step cuts
/// off the ear whose new edge (from its previous to its next corner) is the shortest, ties to
/// the lowest corner. Cutting the first ear found would make a fan of long slivers across a
/// many-sided polygon (a gear's 144 corners), every one of them crossing the same boxes of an
/// accelerator; the shortest ear first peels the rim and leaves triangles about as wide as
/// they are long. Only the two corners beside a cut change whether they are ears, so it is
/// O(n^2) for n corners.
fn ear_clip(p: &[[f64; 2]]) -> Vec<[usize; 3]> {
    let n = p.len();
    let mut prev: Vec<usize> = (0..n).map(|i| (i + n - 1) % n).collect();
    let mut next: Vec<usize> = (0..n).map(|i| (i + 1) % n).collect();
    let mut alive = vec![true; n];
    let mut left = n;
    // Only a reflex (or flat) corner can lie inside an ear, and cutting ears never makes a
    // corner reflex: the corners reflex at the start are all an ear's test needs.
    let reflex: Vec<usize> = (0..n)
        .filter(|&b| cross2(p[prev[b]], p[b], p[next[b]]) <= 0.0)
        .collect();
    let ear = |b: usize, prev: &[usize], next: &[usize], alive: &[bool]| -> Option<f64> {
        let (a, c) = (prev[b], next[b]);
        if cross2(p[a], p[b], p[c]) <= 0.0 {
            return None; // reflex or flat corner
        }
        let contains_other = reflex.iter().any(|&m| {
            alive[m] && m != a && m != b && m != c && inside_triangle(p[m], p[a], p[b], p[c])
        });
        if contains_other {
            return None;
        }
        let (dx, dy) = (p[c][0] - p[a][0], p[c][1] - p[a][1]);
        Some(dx * dx + dy * dy)
    };
    let mut ears: Vec<Option<f64>> = (0..n).map(|b| ear(b, &prev, &next, &alive)).collect();
    let mut out = Vec::with_capacity(n.saturating_sub(2));
    while left > 3 {
        let best = (0..n)
            .filter(|&b| alive[b])
            .filter_map(|b| ears[b].map(|len| (len, b)))
            .min_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)));
        let Some((_, b)) = best else {
            break; // not simple: fall back to a fan of what is left
        };
        let (a, c) = (prev[b], next[b]);
        out.push([a, b, c]);
        alive[b] = false;
        left -= 1;
        next[a] = c;
        prev[c] = a;
        ears[a] = ear(a, &prev, &next, &alive);
        ears[c] = ear(c, &prev, &next, &alive);
    }
    let mut rest: Vec<usize> = Vec::with_capacity(left);
    if let Some(first) = (0..n).find(|&i| alive[i]) {
        let mut i = first;
        loop {
            rest.push(i);
            i = next[i];
            if i == first {
                break;
            }
        }
    }
    for i in 1..rest.len().saturating_sub(1) {
        out.push([rest[0], rest[i], rest[i + 1]]);
    }
    out
}

fn inside_triangle(q: [f64; 2], a: [f64; 2], b: [f64; 2], c: [f64; 2]) -> bool {
    cross2(a, b, q) >= 0.0 && cross2(b, c, q) >= 0.0 && cross2(c, a, q) >= 0.0
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn indices_point_at_the_vertices_given_past_repeats() {
        // A square with a repeated corner and its first corner repeated at the end.
        let sq = [
            DVec3::ZERO,
            DVec3::X,
            DVec3::X,
            DVec3::new(1.0, 1.0, 0.0),
            DVec3::Y,
            DVec3::ZERO,
        ];
        let t = triangulate(&sq).unwrap();
        assert_eq!(t.triangles, vec![[0, 1, 3], [0, 3, 4]]);
        assert_eq!(t.normal, DVec3::Z);
    }

    /// The triangles' signed areas (all positive: none flipped) and the total length of the
    /// edges they add inside the polygon (each diagonal counted on both of its sides).
    fn areas_and_diagonals(v: &[DVec3], t: &Triangulation) -> (Vec<f64>, f64) {
        let n = v.len();
        let mut inner = 0.0;
        let mut areas = Vec::new();
        for &[a, b, c] in &t.triangles {
            areas.push((v[b] - v[a]).cross(v[c] - v[a]).dot(t.normal) / 2.0);
            for (x, y) in [(a, b), (b, c), (c, a)] {
                if (x + 1) % n != y && (y + 1) % n != x {
                    inner += (v[x] - v[y]).length();
                }
            }
        }
        (areas, inner)
    }

    /// A gear's outline (72 teeth, 144 corners) and a 144-sided disc are cut into triangles
    /// that cover them exactly, and with short inner edges: less than a third of the length
    /// a fan from one corner adds (the slivers the first ear found, or a fan, made).
    #[test]
    fn many_cornered_polygons_are_cut_into_short_triangles_not_slivers() {
        let ring = |n: usize, radius: &dyn Fn(usize) -> f64| -> Vec<DVec3> {
            (0..n)
                .map(|k| {
                    let a = std::f64::consts::TAU * k as f64 / n as f64;
                    DVec3::new(a.cos(), a.sin(), 0.0) * radius(k)
                })
                .collect()
        };
        let gear = ring(144, &|k| if (k / 2) % 2 == 0 { 1.0 } else { 0.9 });
        let disc = ring(144, &|_| 1.0);
        for v in [gear, disc] {
            let t = triangulate(&v).unwrap();
            assert_eq!(t.triangles.len(), v.len() - 2);
            let (areas, inner) = areas_and_diagonals(&v, &t);
            assert!(areas.iter().all(|&a| a > 0.0));
            let polygon_area = newell_normal(&v).length() / 2.0;
            let total: f64 = areas.iter().sum();
            assert!(
                (total - polygon_area).abs() < 1e-12,
                "{total} vs {polygon_area}"
            );
            let fan = Triangulation {
                triangles: fan(v.len()),
                normal: t.normal,
            };
            let (_, fan_inner) = areas_and_diagonals(&v, &fan);
            assert!(
                inner < fan_inner / 3.0,
                "inner edges {inner} vs a fan's {fan_inner}"
            );
        }
    }

    #[test]
    fn a_concave_polygon_is_ear_clipped_into_its_own_corners() {
        let l: Vec<DVec3> = [
            [0.0, 0.0],
            [2.0, 0.0],
            [2.0, 1.0],
            [1.0, 1.0],
            [1.0, 2.0],
            [0.0, 2.0],
        ]
        .iter()
        .map(|[a, b]| DVec3::new(*a, *b, 0.0))
        .collect();
        let t = triangulate(&l).unwrap();
        assert_eq!(t.triangles.len(), 4);
        let area: f64 = t
            .triangles
            .iter()
            .map(|&[a, b, c]| (l[b] - l[a]).cross(l[c] - l[a]).z / 2.0)
            .sum();
        assert!((area - 3.0).abs() < 1e-12, "{area}");
    }
}
