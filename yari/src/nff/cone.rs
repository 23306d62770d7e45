//! NFF cones and cylinders as clipped YARI quadrics, built directly in world space.
//!
//! With `d` the unit axis from the base B (radius rb) to the apex A (radius ra), h = |A - B|,
//! q = p - B, t = q . d and k = (ra - rb) / h, the surface is every p with
//!
//! ```text
//! |q|^2 - t^2 - (rb + k t)^2 = 0
//! ```
//!
//! (k = 0 is a cylinder). Its quadratic part is M = I - (1 + k^2) d d^T, its linear part in q is
//! -2 rb k d, its constant -rb^2; substituting q = p - B gives the 4x4 matrix in the order of
//! [`crate::model::Quadric`]. Two planes keep 0 <= t <= h (which also removes the second nappe
//! of a cone), and a box around the two end discs bounds it for the renderer.

use super::read::{dot, sub};
use crate::ast::{Clip, Primitive, Vec3};

/// The clipped quadric of an NFF `c`, or `None` when it is degenerate (both radii zero, a
/// negative radius, or base and apex the same point).
pub fn cone_quadric(
    base: Vec3,
    base_radius: f64,
    apex: Vec3,
    apex_radius: f64,
) -> Option<Primitive> {
    let axis = sub(apex, base);
    let h = dot(axis, axis).sqrt();
    if h.is_nan()
        || h <= 0.0
        || base_radius < 0.0
        || apex_radius < 0.0
        || base_radius + apex_radius <= 0.0
    {
        return None;
    }
    let d = [axis[0] / h, axis[1] / h, axis[2] / h];
    let k = (apex_radius - base_radius) / h;
    let rb = base_radius;

    // f(q) = q^T M q + l . q + c0
    let s = 1.0 + k * k;
    let mut m = [[0.0; 3]; 3];
    for (i, row) in m.iter_mut().enumerate() {
        for (j, v) in row.iter_mut().enumerate() {
            *v = if i == j { 1.0 } else { 0.0 } - s * d[i] * d[j];
        }
    }
    let l = [
        -2.0 * rb * k * d[0],
        -2.0 * rb * k * d[1],
        -2.0 * rb * k * d[2],
    ];
    let c0 = -rb * rb;

    // Substitute q = p - B: linear part l - 2 M B, constant B^T M B - l . B + c0.
    let mb = [dot(m[0], base), dot(m[1], base), dot(m[2], base)];
    let lin = [l[0] - 2.0 * mb[0], l[1] - 2.0 * mb[1], l[2] - 2.0 * mb[2]];
    let constant = dot(base, mb) - dot(l, base) + c0;
    let coeffs = [
        m[0][0],
        m[0][1],
        m[0][2],
        lin[0] / 2.0,
        m[1][1],
        m[1][2],
        lin[1] / 2.0,
        m[2][2],
        lin[2] / 2.0,
        constant,
    ];

    let (min, max) = disc_bounds(base, base_radius, apex, apex_radius, d);
    let clip = vec![
        Clip::Plane {
            normal: [-d[0], -d[1], -d[2]],
            offset: -dot(d, base),
        },
        Clip::Plane {
            normal: d,
            offset: dot(d, apex),
        },
        Clip::Box { min, max },
    ];
    Some(Primitive::Quadric { coeffs, clip })
}

/// The box around the two end discs, padded by a hair so points on its faces stay inside.
fn disc_bounds(base: Vec3, rb: f64, apex: Vec3, ra: f64, d: Vec3) -> (Vec3, Vec3) {
    let mut min = [0.0; 3];
    let mut max = [0.0; 3];
    let size = rb.max(ra) + dot(sub(apex, base), sub(apex, base)).sqrt();
    for i in 0..3 {
        let extent = (1.0 - d[i] * d[i]).max(0.0).sqrt();
        let pad = 1e-9 * (size + base[i].abs().max(apex[i].abs()));
        min[i] = (base[i] - rb * extent).min(apex[i] - ra * extent) - pad;
        max[i] = (base[i] + rb * extent).max(apex[i] + ra * extent) + pad;
    }
    (min, max)
}

/// Evaluates x^T Q x at a point (for tests and callers that check the surface).
pub fn eval_quadric(q: &[f64; 10], p: Vec3) -> f64 {
    let [a, b, c, d, e, f, g, h, i, j] = *q;
    let [x, y, z] = p;
    a * x * x
        + 2.0 * b * x * y
        + 2.0 * c * x * z
        + 2.0 * d * x
        + e * y * y
        + 2.0 * f * y * z
        + 2.0 * g * y
        + h * z * z
        + 2.0 * i * z
        + j
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::nff::read::cross;

    fn inside(clip: &[Clip], p: Vec3) -> bool {
        clip.iter().all(|c| match c {
            Clip::Plane { normal, offset } => dot(*normal, p) <= offset + 1e-12,
            Clip::Box { min, max } => (0..3).all(|i| p[i] >= min[i] && p[i] <= max[i]),
        })
    }

    fn check_cone(base: Vec3, rb: f64, apex: Vec3, ra: f64) {
        let Some(Primitive::Quadric { coeffs, clip }) = cone_quadric(base, rb, apex, ra) else {
            panic!("degenerate");
        };
        let axis = sub(apex, base);
        let h = dot(axis, axis).sqrt();
        let d = [axis[0] / h, axis[1] / h, axis[2] / h];
        let helper = if d[0].abs() < 0.9 {
            [1.0, 0.0, 0.0]
        } else {
            [0.0, 1.0, 0.0]
        };
        let u = cross(d, helper);
        let un = dot(u, u).sqrt();
        let u = [u[0] / un, u[1] / un, u[2] / un];
        let v = cross(d, u);
        for step in 0..=10 {
            let t = step as f64 / 10.0;
            let r = rb + (ra - rb) * t;
            for k in 0..12 {
                let phi = k as f64 * std::f64::consts::TAU / 12.0;
                let (c, s) = (phi.cos(), phi.sin());
                let p: Vec3 =
                    std::array::from_fn(|i| base[i] + axis[i] * t + r * (c * u[i] + s * v[i]));
                assert!(
                    eval_quadric(&coeffs, p).abs() < 1e-9,
                    "on-surface point off by {}",
                    eval_quadric(&coeffs, p)
                );
                assert!(inside(&clip, p), "surface point {p:?} clipped away");
                // A point pushed outward is off the surface.
                let out: Vec3 = std::array::from_fn(|i| p[i] + 0.1 * (c * u[i] + s * v[i]));
                assert!(eval_quadric(&coeffs, out).abs() > 1e-4);
            }
        }
        // Beyond either end the clip planes reject the axis continuation.
        let beyond: Vec3 = std::array::from_fn(|i| apex[i] + axis[i] * 0.5);
        let before: Vec3 = std::array::from_fn(|i| base[i] - axis[i] * 0.5);
        assert!(!inside(&clip, beyond) && !inside(&clip, before));
    }

    #[test]
    fn cylinders_and_cones_in_any_orientation() {
        check_cone([0.0, 0.0, 0.0], 1.0, [0.0, 0.0, 2.0], 1.0);
        check_cone([1.0, -2.0, 3.0], 0.5, [2.0, 1.0, -1.0], 0.5);
        check_cone([1.0, 2.0, 3.0], 1.0, [-1.0, 0.5, 4.0], 0.0);
        check_cone([0.3, 0.1, -0.7], 0.2, [0.3, 2.1, -0.7], 0.7);
    }

    #[test]
    fn unit_cylinder_coefficients() {
        // x^2 + y^2 - 1 = 0 along z: a = e = 1, j = -1, everything else 0.
        let Some(Primitive::Quadric { coeffs, .. }) =
            cone_quadric([0.0; 3], 1.0, [0.0, 0.0, 1.0], 1.0)
        else {
            panic!()
        };
        assert_eq!(coeffs, [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, -1.0]);
    }

    #[test]
    fn degenerate_cones_are_refused() {
        assert!(cone_quadric([0.0; 3], 1.0, [0.0; 3], 1.0).is_none());
        assert!(cone_quadric([0.0; 3], 0.0, [0.0, 0.0, 1.0], 0.0).is_none());
        assert!(cone_quadric([0.0; 3], -1.0, [0.0, 0.0, 1.0], 1.0).is_none());
    }
}
