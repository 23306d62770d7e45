//! General quadrics `x^T Q x = 0` clipped by half-spaces (see [`yari::model::Quadric`] for the
//! coefficient order), and their bounding boxes where one can be found.

use super::sphere::stable_roots;
use super::{Aabb, Ray, Real, Vec3};
use yari::model::{HalfSpace, Quadric};

/// `(Q x)_xyz` and `(Q x)_w` for homogeneous x = (p, 1).
#[inline]
fn q_times(q: &[Real; 10], p: Vec3) -> (Vec3, Real) {
    let [a, b, c, d, e, f, g, h, i, j] = *q;
    (
        Vec3::new(
            a * p.x + b * p.y + c * p.z + d,
            b * p.x + e * p.y + f * p.z + g,
            c * p.x + f * p.y + h * p.z + i,
        ),
        d * p.x + g * p.y + i * p.z + j,
    )
}

/// `Q3 v` for a direction (w = 0).
#[inline]
fn q3_times(q: &[Real; 10], v: Vec3) -> Vec3 {
    let [a, b, c, _, e, f, _, h, _, _] = *q;
    Vec3::new(
        a * v.x + b * v.y + c * v.z,
        b * v.x + e * v.y + f * v.z,
        c * v.x + f * v.y + h * v.z,
    )
}

/// True when `p` is in every clip half-space (`normal . p <= offset`; on the boundary counts).
pub fn inside_clip(clip: &[HalfSpace], p: Vec3) -> bool {
    clip.iter().all(|h| h.normal.dot(p) <= h.offset)
}

/// The nearest `t` in `(t_min, t_max)` on the quadric and inside every clip half-space.
pub fn intersect_quadric(ray: &Ray, q: &Quadric, t_min: Real, t_max: Real) -> Option<Real> {
    let (qo, qo_w) = q_times(&q.q, ray.origin);
    let a = q3_times(&q.q, ray.dir).dot(ray.dir);
    let b = qo.dot(ray.dir);
    let c = qo.dot(ray.origin) + qo_w;
    // The stable form needs no threshold on `a`: as `a -> 0` the root `q / a` runs off to
    // infinity and `c / q` tends to the linear root `-c / 2b`, both computed without
    // cancellation. Only `a == 0` exactly (a ray parallel to a cylinder's or cone's line) is
    // linear; a cut-off like `|a| < 1e-12 (|b| + |c|)` would lose the true hit of a ray
    // nearly parallel to a cylinder's axis (`a = eps^2`).
    let roots = if a == 0.0 {
        if b == 0.0 {
            return None;
        }
        let t = -c / (2.0 * b);
        (t, t)
    } else {
        stable_roots(a, b, c, b * b - a * c)?
    };
    [roots.0, roots.1]
        .into_iter()
        .find(|&t| t > t_min && t < t_max && inside_clip(&q.clip, ray.at(t)))
}

/// The gradient direction (unnormalised outward normal, pointing to where x^T Q x > 0).
pub fn quadric_normal(q: &Quadric, p: Vec3) -> Vec3 {
    q_times(&q.q, p).0.normalize_or_zero()
}

/// A bounding box of the clipped quadric, or None when it is unbounded or we cannot tell.
///
/// Two cases are bounded: an ellipsoid (positive definite quadratic part), and any quadric whose
/// clip holds a pair of opposite parallel planes (a slab) cutting it in ellipses at both ends
/// (capped cylinders and cones, as NFF's `c` becomes): then the box of the two end ellipses
/// bounds the piece between, since along a slab the cross-sections of cones, cylinders,
/// paraboloids and hyperboloids reach their extremes at the ends.
pub fn quadric_bounds(q: &Quadric) -> Option<Aabb> {
    let mut best: Option<Aabb> = ellipsoid_bounds(&q.q);
    for (m, h1) in q.clip.iter().enumerate() {
        for h2 in &q.clip[m + 1..] {
            let n1 = h1.normal.normalize_or_zero();
            let n2 = h2.normal.normalize_or_zero();
            if n1 == Vec3::ZERO || n1.dot(n2) > -1.0 + 1e-12 {
                continue;
            }
            let d1 = h1.offset / h1.normal.length();
            let d2 = h2.offset / h2.normal.length();
            // The slab is n1 . p in [-d2, d1].
            let (Some(e1), Some(e2)) =
                (section_bounds(&q.q, n1, d1), section_bounds(&q.q, n1, -d2))
            else {
                continue;
            };
            let b = e1.union(e2);
            best = Some(match best {
                Some(o) => o.intersection(b),
                None => b,
            });
        }
    }
    best.filter(|b| b.is_finite() && !b.is_empty())
        .map(Aabb::padded)
}

fn ellipsoid_bounds(q: &[Real; 10]) -> Option<Aabb> {
    let [a, b, c, d, e, f, g, h, i, j] = *q;
    let m = glam::DMat3::from_cols_array(&[a, b, c, b, e, f, c, f, h]);
    let lin = Vec3::new(d, g, i);
    // Normalise the sign so the quadratic part is positive definite if it can be.
    let s = if a < 0.0 { -1.0 } else { 1.0 };
    let (m, lin, j) = (m * s, lin * s, j * s);
    if !(m.x_axis.x > 0.0
        && m.x_axis.x * m.y_axis.y - m.x_axis.y * m.y_axis.x > 0.0
        && m.determinant() > 0.0)
    {
        return None;
    }
    let inv = m.inverse();
    let centre = -inv.mul_vec3(lin);
    let r = lin.dot(inv.mul_vec3(lin)) - j;
    if r <= 0.0 {
        return None;
    }
    let half = Vec3::new(
        (r * inv.x_axis.x).sqrt(),
        (r * inv.y_axis.y).sqrt(),
        (r * inv.z_axis.z).sqrt(),
    );
    Some(Aabb::new(centre - half, centre + half))
}

/// Box of the conic cut by the plane `n . p = d` (n unit), when that conic is an ellipse.
fn section_bounds(q: &[Real; 10], n: Vec3, d: Real) -> Option<Aabb> {
    let o = n * d;
    let u = n.any_orthonormal_vector();
    let v = n.cross(u);
    // Restrict: p = o + s u + t v.  x^T Q x = [s t] A2 [s t]^T + 2 b2 . [s t] + c2.
    let (qo, qo_w) = q_times(q, o);
    let qu = q3_times(q, u);
    let qv = q3_times(q, v);
    let a2 = glam::DMat2::from_cols_array(&[qu.dot(u), qu.dot(v), qv.dot(u), qv.dot(v)]);
    let b2 = glam::DVec2::new(qo.dot(u), qo.dot(v));
    let c2 = qo.dot(o) + qo_w;
    let s = if a2.x_axis.x < 0.0 { -1.0 } else { 1.0 };
    let (a2, b2, c2) = (a2 * s, b2 * s, c2 * s);
    if !(a2.x_axis.x > 0.0 && a2.determinant() > 0.0) {
        return None;
    }
    let inv = a2.inverse();
    let centre2 = -inv.mul_vec2(b2);
    let r = b2.dot(inv.mul_vec2(b2)) - c2;
    if r < 0.0 {
        return None;
    }
    let centre = o + u * centre2.x + v * centre2.y;
    let mut half = Vec3::ZERO;
    for k in 0..3 {
        let g = glam::DVec2::new(u[k], v[k]);
        half[k] = (r * g.dot(inv.mul_vec2(g))).max(0.0).sqrt();
    }
    Some(Aabb::new(centre - half, centre + half))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// x^2 + y^2 - 1 = 0 between z = 0 and z = 2.
    fn cylinder() -> Quadric {
        Quadric {
            q: [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, -1.0],
            clip: vec![
                HalfSpace {
                    normal: Vec3::Z,
                    offset: 2.0,
                },
                HalfSpace {
                    normal: -Vec3::Z,
                    offset: 0.0,
                },
            ],
        }
    }

    #[test]
    fn clipped_cylinder_hits_and_clips() {
        let q = cylinder();
        let r = Ray::new(Vec3::new(-5.0, 0.0, 1.0), Vec3::X);
        assert_eq!(intersect_quadric(&r, &q, 0.0, 100.0), Some(4.0));
        let above = Ray::new(Vec3::new(-5.0, 0.0, 3.0), Vec3::X);
        assert_eq!(intersect_quadric(&above, &q, 0.0, 100.0), None);
        // Looking down into the open tube: the inside wall, after the clipped near part.
        let slant = Ray::new(Vec3::new(0.0, 0.0, 3.0), Vec3::new(1.0, 0.0, -1.0));
        assert_eq!(intersect_quadric(&slant, &q, 0.0, 100.0), Some(1.0));
        let n = quadric_normal(&q, Vec3::new(1.0, 0.0, 1.0));
        assert!((n - Vec3::X).length() < 1e-12);
    }

    #[test]
    fn bounds_of_capped_cylinder_and_ellipsoid() {
        let b = quadric_bounds(&cylinder()).unwrap();
        assert!(
            (b.min - Vec3::new(-1.0, -1.0, 0.0)).length() < 1e-6,
            "{b:?}"
        );
        assert!((b.max - Vec3::new(1.0, 1.0, 2.0)).length() < 1e-6, "{b:?}");
        // (x-1)^2/4 + y^2 + z^2 = 1  ->  x^2/4 - x/2 + y^2 + z^2 - 3/4 = 0
        let e = Quadric {
            q: [0.25, 0.0, 0.0, -0.25, 1.0, 0.0, 0.0, 1.0, 0.0, -0.75],
            clip: vec![],
        };
        let b = quadric_bounds(&e).unwrap();
        assert!(
            (b.min - Vec3::new(-1.0, -1.0, -1.0)).length() < 1e-6,
            "{b:?}"
        );
        assert!((b.max - Vec3::new(3.0, 1.0, 1.0)).length() < 1e-6, "{b:?}");
        // An unclipped cylinder is unbounded.
        let open = Quadric {
            clip: vec![],
            ..cylinder()
        };
        assert!(quadric_bounds(&open).is_none());
    }

    #[test]
    fn cone_reintersection_from_hit_point() {
        // x^2 + y^2 - z^2 = 0, 0 <= z <= 1.
        let q = Quadric {
            q: [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, -1.0, 0.0, 0.0],
            clip: vec![
                HalfSpace {
                    normal: Vec3::Z,
                    offset: 1.0,
                },
                HalfSpace {
                    normal: -Vec3::Z,
                    offset: 0.0,
                },
            ],
        };
        let r = Ray::new(Vec3::new(-5.0, 0.1, 0.5), Vec3::X);
        let t = intersect_quadric(&r, &q, 0.0, 100.0).unwrap();
        let p = r.at(t);
        assert!((p.x * p.x + p.y * p.y - p.z * p.z).abs() < 1e-9);
        let n = quadric_normal(&q, p);
        let again = Ray::new(crate::geometry::offset_origin(p, -n), r.dir);
        let t2 = intersect_quadric(&again, &q, 0.0, 100.0).unwrap();
        assert!(t2 > 0.5, "re-hit itself at {t2}");
    }
}
