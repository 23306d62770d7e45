//! Vertex normals of a surface of revolution (`revolve --smooth`): the surface is smooth
//! around the axis everywhere, and along the profile wherever the profile turns by no more
//! than the crease angle; at a sharper corner each side keeps its own normal, so a cylinder's
//! rim stays a rim. Caps stay flat.
//!
//! A profile edge from (r_i, h_i) to (r_j, h_j) (radius, height) has the normal
//! (dh, -dr) / |.| in the (radius, height) plane; at angle theta around the axis that is
//! `axis * n_h + (e1 cos theta + e2 sin theta) * n_r`. At a smooth profile point the two
//! edges' normals are averaged. A point on the axis whose normal is within the crease angle of
//! the axis gets the axis itself (a smooth pole, as on a sphere); otherwise (a cone's tip) each
//! face keeps its edge's normal at the face's middle angle. Which way these normals point
//! (out of the solid) is settled after the faces are oriented ([`orient_normals`]).

use crate::mesh::Mesh;
use glam::DVec3;

/// A profile point's normal in the (radius, height) plane, as seen from the edge before it
/// and from the edge after it (equal at a smooth point); `None` where there is no such edge.
pub type PointNormals = [Option<(f64, f64)>; 2];

/// The unit normal of the profile edge from `a` to `b` (radius, height), `None` if they
/// coincide.
fn edge_normal(a: (f64, f64), b: (f64, f64)) -> Option<(f64, f64)> {
    let (dr, dh) = (b.0 - a.0, b.1 - a.1);
    let len = dr.hypot(dh);
    (len > 0.0 && len.is_finite()).then(|| (dh / len, -dr / len))
}

/// Each profile point's normals (see [`PointNormals`]) for a profile `rh` (open or
/// `closed`), smoothing corners that turn by at most `crease_deg` degrees.
pub fn profile_normals(rh: &[(f64, f64)], closed: bool, crease_deg: f64) -> Vec<PointNormals> {
    let n = rh.len();
    // A hair of tolerance, so that a corner of exactly the crease angle counts as smooth.
    let cos_crease = crease_deg.to_radians().cos() - 1e-12;
    let edge = |i: usize| -> Option<(f64, f64)> {
        let j = if closed { (i + 1) % n } else { i + 1 };
        (j < n).then(|| edge_normal(rh[i], rh[j])).flatten()
    };
    (0..n)
        .map(|i| {
            let before = if i > 0 {
                edge(i - 1)
            } else if closed {
                edge(n - 1)
            } else {
                None
            };
            let after = edge(i);
            let mut out = [before, after];
            if let (Some(b), Some(a)) = (before, after) {
                if b.0 * a.0 + b.1 * a.1 >= cos_crease {
                    let (r, h) = (b.0 + a.0, b.1 + a.1);
                    let len = r.hypot(h);
                    if len > 0.0 {
                        out = [Some((r / len, h / len)); 2];
                    }
                }
            }
            if rh[i].0 == 0.0 {
                // A pole: along the axis when the surface meets it smoothly.
                for m in out.iter_mut().flatten() {
                    if m.1.abs() >= cos_crease {
                        *m = (0.0, m.1.signum());
                    }
                }
            }
            out
        })
        .collect()
}

/// The frame of the revolution: the axis and the two radial directions at angle 0 and 90.
#[derive(Clone, Copy, Debug)]
pub struct Frame {
    /// The axis of revolution (unit).
    pub axis: DVec3,
    /// The radial direction at angle 0.
    pub e1: DVec3,
    /// The radial direction at 90 degrees.
    pub e2: DVec3,
}

impl Frame {
    /// The 3-D normal of the profile normal `(n_r, n_h)` at angle `theta` around the axis.
    pub fn normal(&self, (nr, nh): (f64, f64), theta: f64) -> DVec3 {
        let (s, c) = theta.sin_cos();
        self.axis * nh + (self.e1 * c + self.e2 * s) * nr
    }
}

/// Turns every face's corner normals to the outside: after the faces were oriented outward
/// (and the normals reversed with them), the normals are negated, all together, if they point
/// against their faces. (They were all made with one convention, so one test decides.)
pub fn orient_normals(mesh: &mut Mesh) {
    let against = mesh.faces.iter().zip(&mesh.normals).find_map(|(f, n)| {
        let n = n.as_ref()?;
        let sum: DVec3 = n.iter().copied().sum();
        let face = newell(f.iter().map(|&i| mesh.vertices[i]).collect());
        let d = sum.dot(face);
        (d != 0.0).then_some(d < 0.0)
    });
    if against == Some(true) {
        for n in mesh.normals.iter_mut().flatten() {
            for v in n {
                *v = -*v;
            }
        }
    }
}

fn newell(v: Vec<DVec3>) -> DVec3 {
    let mut n = DVec3::ZERO;
    for (i, a) in v.iter().enumerate() {
        let b = v[(i + 1) % v.len()];
        n += DVec3::new(
            (a.y - b.y) * (a.z + b.z),
            (a.z - b.z) * (a.x + b.x),
            (a.x - b.x) * (a.y + b.y),
        );
    }
    n
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn corners_within_the_crease_angle_are_averaged_and_poles_follow_the_axis() {
        // A cylinder profile: pole, rim, rim, pole. The rims turn by 90 degrees.
        let rh = [(0.0, 0.0), (1.0, 0.0), (1.0, 2.0), (0.0, 2.0)];
        let n = profile_normals(&rh, false, 45.0);
        assert_eq!(n[0], [None, Some((0.0, -1.0))]);
        assert_eq!(n[1], [Some((0.0, -1.0)), Some((1.0, 0.0))], "a sharp rim");
        assert_eq!(n[3], [Some((0.0, 1.0)), None]);
        // Crease 90: the rims are smoothed to the diagonal.
        let n = profile_normals(&rh, false, 90.0);
        let d = 0.5f64.sqrt();
        assert!((n[1][0].unwrap().0 - d).abs() < 1e-15 && n[1][0] == n[1][1]);
        // A cone's tip (edge normal 45 degrees from the axis) stays a tip at crease 30.
        let cone = [(1.0, 0.0), (0.0, 1.0)];
        let n = profile_normals(&cone, false, 30.0);
        assert!((n[1][0].unwrap().0 - d).abs() < 1e-15);
    }

    #[test]
    fn frame_normals_turn_with_the_angle() {
        let f = Frame {
            axis: DVec3::Y,
            e1: DVec3::X,
            e2: DVec3::NEG_Z,
        };
        assert_eq!(f.normal((1.0, 0.0), 0.0), DVec3::X);
        assert!(
            (f.normal((0.6, 0.8), std::f64::consts::PI) - DVec3::new(-0.6, 0.8, 0.0)).length()
                < 1e-15
        );
    }
}
