//! Primitives to world-space shapes under the current transformation.
//!
//! - A sphere under a similarity (rotation, translation, uniform scale, within 1e-9) stays a
//!   [`Shape::Sphere`]; otherwise it is a [`Shape::Ellipsoid`] with its exact affine map.
//! - A polygon's vertices are transformed; repeated consecutive vertices are removed and a
//!   polygon left with fewer than 3 vertices or no area is dropped with a warning. Its
//!   vertex normals (if any) follow their vertices: each becomes L^-T n, renormalised, for
//!   M = (L, t); with no transformation in effect they are kept as written.
//! - A quadric Q becomes M^-T Q M^-1; a clip box becomes 6 half-spaces and every half-space
//!   n.p <= d becomes (L^-T n).p <= d + (L^-T n).t for M = (L, t). Normals are not rescaled.

use super::stack::State;
use super::Compiler;
use crate::ast::{Clip, Primitive};
use crate::model::{HalfSpace, Quadric, Shape};
use crate::span::Span;
use glam::{DAffine3, DMat3, DMat4, DVec3, DVec4};

impl Compiler<'_> {
    /// The world-space shape of a primitive, or `None` after an error or a dropped polygon.
    pub(crate) fn primitive(&mut self, p: &Primitive, state: &State, span: Span) -> Option<Shape> {
        match p {
            Primitive::Sphere { center, radius } => self.sphere(*center, *radius, state, span),
            Primitive::Polygon { vertices, normals } => {
                self.polygon(vertices, normals.as_deref(), state, span)
            }
            Primitive::Quadric { coeffs, clip } => self.quadric(coeffs, clip, state, span),
        }
    }

    fn sphere(
        &mut self,
        center: [f64; 3],
        radius: f64,
        state: &State,
        span: Span,
    ) -> Option<Shape> {
        if !(radius > 0.0 && radius.is_finite()) {
            self.error(
                span,
                format!("sphere radius must be more than 0, not {radius}"),
            );
            return None;
        }
        if !DVec3::from_array(center).is_finite() {
            self.error(span, "sphere center is not finite");
            return None;
        }
        if state.identity {
            return Some(Shape::Sphere {
                center: DVec3::from_array(center),
                radius,
            });
        }
        let shape = match similarity_scale(&state.transform.matrix3) {
            Some(s) => Shape::Sphere {
                center: state.point(center),
                radius: radius * s,
            },
            None => {
                let local = DAffine3 {
                    matrix3: DMat3::from_diagonal(DVec3::splat(radius)),
                    translation: DVec3::from_array(center),
                };
                let to_world = state.transform * local;
                if !to_world.inverse().is_finite() {
                    self.error(
                        span,
                        "sphere under a singular transformation (it would be flat)",
                    );
                    return None;
                }
                Shape::Ellipsoid { to_world }
            }
        };
        self.finite_shape(shape, span)
    }

    fn polygon(
        &mut self,
        vertices: &[[f64; 3]],
        normals: Option<&[[f64; 3]]>,
        state: &State,
        span: Span,
    ) -> Option<Shape> {
        if vertices.len() < 3 {
            self.error(
                span,
                format!(
                    "a polygon needs at least 3 vertices, not {}",
                    vertices.len()
                ),
            );
            return None;
        }
        if normals.is_some_and(|n| n.len() != vertices.len()) {
            self.error(span, "a polygon needs one normal per vertex");
            return None;
        }
        let normals = match normals {
            Some(n) => Some(self.normals(n, state, span)?),
            None => None,
        };
        let mut world: Vec<DVec3> = Vec::with_capacity(vertices.len());
        let mut kept: Vec<DVec3> = Vec::with_capacity(normals.as_ref().map_or(0, Vec::len));
        for (i, v) in vertices.iter().enumerate() {
            let p = state.point(*v);
            if world.last() != Some(&p) {
                world.push(p);
                if let Some(n) = &normals {
                    kept.push(n[i]);
                }
            }
        }
        while world.len() > 1 && world.first() == world.last() {
            world.pop();
            kept.pop();
        }
        if world.iter().any(|p| !p.is_finite()) {
            self.error(span, "polygon vertices are not finite after transformation");
            return None;
        }
        if world.len() < 3 {
            self.warn(
                span,
                "degenerate polygon dropped: fewer than 3 distinct vertices",
            );
            return None;
        }
        if world.len() < vertices.len() {
            self.warn(span, "repeated vertices removed from polygon");
        }
        if !has_area(&world) {
            self.warn(span, "degenerate polygon dropped: it has no area");
            return None;
        }
        Some(match normals {
            Some(_) => Shape::SmoothPolygon {
                vertices: world,
                normals: kept,
            },
            None => Shape::Polygon { vertices: world },
        })
    }

    /// A polygon's vertex normals in world space: as written with no transformation in
    /// effect, else L^-T n renormalised for the current map M = (L, t). `None` after an
    /// error (a zero normal, or one the transformation sends out of range).
    fn normals(&mut self, normals: &[[f64; 3]], state: &State, span: Span) -> Option<Vec<DVec3>> {
        let Some(inv) = state.inverse() else {
            self.error(
                span,
                "the current transformation cannot be inverted to place the polygon's normals",
            );
            return None;
        };
        let lt = inv.matrix3.transpose();
        let mut out = Vec::with_capacity(normals.len());
        for (k, n) in normals.iter().enumerate() {
            let n = DVec3::from_array(*n);
            let w = if state.identity {
                Some(n).filter(|n| n.length_squared().is_normal())
            } else {
                (lt * n).try_normalize()
            };
            let Some(w) = w else {
                self.error(
                    span,
                    format!(
                        "the normal of vertex {} has no direction after transformation",
                        k + 1
                    ),
                );
                return None;
            };
            out.push(w);
        }
        Some(out)
    }

    fn quadric(
        &mut self,
        coeffs: &[f64; 10],
        clip: &[Clip],
        state: &State,
        span: Span,
    ) -> Option<Shape> {
        if coeffs.iter().all(|c| *c == 0.0) {
            self.error(span, "quadric has all coefficients zero");
            return None;
        }
        let mut halves = Vec::with_capacity(clip.len() * 6);
        for c in clip {
            match c {
                Clip::Box { min, max } => {
                    for axis in 0..3 {
                        let mut n = DVec3::ZERO;
                        n[axis] = 1.0;
                        halves.push(HalfSpace {
                            normal: n,
                            offset: max[axis],
                        });
                        halves.push(HalfSpace {
                            normal: -n,
                            offset: -min[axis],
                        });
                    }
                }
                Clip::Plane { normal, offset } => {
                    let n = DVec3::from_array(*normal);
                    if n == DVec3::ZERO {
                        self.error(span, "clipping plane has a zero normal");
                        return None;
                    }
                    halves.push(HalfSpace {
                        normal: n,
                        offset: *offset,
                    });
                }
            }
        }
        if clip.is_empty() && !bounded(coeffs) {
            self.warn(
                span,
                "quadric is unbounded and has no `clip`: it extends to infinity",
            );
        }
        if state.identity {
            let shape = Shape::Quadric(Quadric {
                q: *coeffs,
                clip: halves,
            });
            return self.finite_shape(shape, span);
        }
        let Some(inv) = state.inverse() else {
            self.error(
                span,
                "the current transformation cannot be inverted to place the quadric",
            );
            return None;
        };
        let minv = DMat4::from(inv);
        let q = minv.transpose() * sym(coeffs) * minv;
        let q = upper(&q);
        let lt = inv.matrix3.transpose();
        let t = state.transform.translation;
        for h in &mut halves {
            let n = lt * h.normal;
            if n == DVec3::ZERO {
                // Found by yari/tests/roundtrip_prop.rs: scales of 1e153 and 1e135.
                self.error(
                    span,
                    "a clipping plane's normal vanishes after transformation (the numbers underflow)",
                );
                return None;
            }
            *h = HalfSpace {
                normal: n,
                offset: h.offset + n.dot(t),
            };
        }
        self.finite_shape(Shape::Quadric(Quadric { q, clip: halves }), span)
    }

    fn finite_shape(&mut self, shape: Shape, span: Span) -> Option<Shape> {
        let finite = match &shape {
            Shape::Sphere { center, radius } => {
                center.is_finite() && radius.is_finite() && *radius > 0.0
            }
            Shape::Ellipsoid { to_world } => to_world.is_finite(),
            Shape::Polygon { vertices } => vertices.iter().all(|v| v.is_finite()),
            Shape::SmoothPolygon { vertices, normals } => {
                vertices.iter().chain(normals).all(|v| v.is_finite())
            }
            Shape::Quadric(q) => {
                q.q.iter().all(|c| c.is_finite())
                    && q.clip
                        .iter()
                        .all(|h| h.normal.is_finite() && h.offset.is_finite())
            }
        };
        if finite {
            Some(shape)
        } else {
            self.error(
                span,
                "primitive is not finite after transformation (the numbers overflow)",
            );
            None
        }
    }
}

/// The scale factor of a similarity (L^T L = s^2 I within 1e-9), or `None`.
fn similarity_scale(l: &DMat3) -> Option<f64> {
    let g = l.transpose() * *l;
    let s2 = (g.x_axis.x + g.y_axis.y + g.z_axis.z) / 3.0;
    if !(s2 > 0.0 && s2.is_finite()) {
        return None;
    }
    let tol = 1e-9 * s2;
    let off = [g.x_axis.y, g.x_axis.z, g.y_axis.z];
    let diag = [g.x_axis.x, g.y_axis.y, g.z_axis.z];
    let ok = off.iter().all(|v| v.abs() <= tol) && diag.iter().all(|v| (v - s2).abs() <= tol);
    ok.then(|| s2.sqrt())
}

/// The symmetric 4x4 matrix of the ten coefficients (order in [`crate::model::Quadric`]).
fn sym(q: &[f64; 10]) -> DMat4 {
    let [a, b, c, d, e, f, g, h, i, j] = *q;
    DMat4::from_cols(
        DVec4::new(a, b, c, d),
        DVec4::new(b, e, f, g),
        DVec4::new(c, f, h, i),
        DVec4::new(d, g, i, j),
    )
}

/// The ten coefficients of a (nearly) symmetric matrix, averaging its two triangles.
fn upper(m: &DMat4) -> [f64; 10] {
    let e = |r: usize, c: usize| (m.col(c)[r] + m.col(r)[c]) * 0.5;
    [
        e(0, 0),
        e(0, 1),
        e(0, 2),
        e(0, 3),
        e(1, 1),
        e(1, 2),
        e(1, 3),
        e(2, 2),
        e(2, 3),
        e(3, 3),
    ]
}

/// True when the quadratic part is definite, so the surface (if any) is a bounded ellipsoid.
fn bounded(q: &[f64; 10]) -> bool {
    let [a, b, c, _, e, f, _, h, _, _] = *q;
    let m = DMat3::from_cols(
        DVec3::new(a, b, c),
        DVec3::new(b, e, f),
        DVec3::new(c, f, h),
    );
    let (m1, m2, m3) = (a, a * e - b * b, m.determinant());
    (m1 > 0.0 && m2 > 0.0 && m3 > 0.0) || (m1 < 0.0 && m2 > 0.0 && m3 < 0.0)
}

/// True when the polygon's area (the length of the sum of its fan's cross products) is not
/// negligible against the square of its size.
fn has_area(v: &[DVec3]) -> bool {
    let o = v[0];
    let mut n = DVec3::ZERO;
    for w in v[1..].windows(2) {
        n += (w[0] - o).cross(w[1] - o);
    }
    let (lo, hi) = v
        .iter()
        .fold((o, o), |(lo, hi), p| (lo.min(*p), hi.max(*p)));
    let extent = (hi - lo).max_element();
    n.length() > 1e-12 * extent * extent
}
